"""How much the later taps of the nonlocal packing continuum depend on rounding (issue #18).

    python bench/check_tap_sensitivity.py [--case d22mm_a1.0_three_taps] [--runs 12] [--ppd 10]
        [--profile seed|constant] [--json PATH]

The landing of a flying column is sensitive to small differences; what the next tap meets is the
state the landing left.  This script runs one case of ``bsrflow compare --kernel packing`` (the
Lagrangian formulation, R = d) ``--runs`` times, the bond weights multiplied by 1 + 1e-14·N(0, 1)
in every run but the first (a rounding-sized change), and prints each tap's top maximum per run
and the spread over the runs against the DEM's.

``--profile``: the bond weights' profile, ``seed`` (the package's: the seed kernel's (R − |z|),
:func:`bsrflow.physics.packing.bond_weights`) or ``constant`` (a trial profile, w_ℓ equal for
every lag, the constant micromodulus of bond-based peridynamics, which the package does not use:
docs/model.md says why).  Takes about 10 s per run at 10 points per diameter.
"""

from __future__ import annotations

import json

import numpy as np

from _args import Parser, output_json, positive_int
from bsrflow.analysis.compare import run_dem_column
from bsrflow.analysis.compare_packing import PACKING_CASES, _metrics, case_setup
from bsrflow.physics import packing
from bsrflow.physics.column import ColumnSetup, run_bsr_column


def main(argv=None):
    names = [c["name"] for c in PACKING_CASES]
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", default="d22mm_a1.0_three_taps", choices=names, metavar="NAME",
                    help="one of: " + ", ".join(names))
    ap.add_argument("--runs", type=positive_int, default=12, help="runs, all but the first with perturbed bond weights (default 12)")
    ap.add_argument("--ppd", type=positive_int, default=10, help="points per diameter (default 10)")
    ap.add_argument("--profile", default="seed", choices=("seed", "constant"),
                    help="the bond weights' profile (default seed, the package's)")
    ap.add_argument("--json", type=output_json, default=None, help="JSON file written (default: none)")
    args = ap.parse_args(argv)
    case = next(c for c in PACKING_CASES if c["name"] == args.case)
    s = case_setup(case, ColumnSetup(points_per_diameter=args.ppd), formulation="lagrangian", range_over_d=1.0)
    t_d, pos, _ = run_dem_column(s)
    dem = _metrics(t_d, pos[:, -1], pos.mean(axis=1), s)
    dem_peaks = [p["top_max_over_d"] for p in dem.get("taps", [dem])]
    print(f"{args.case}, profile {args.profile}, {args.ppd} points per diameter: DEM top maxima "
          + " ".join(f"{p:.2f}" for p in dem_peaks) + " d")
    L = s.packing_law().bond_lags(args.ppd)
    lags = np.arange(1, L + 1)
    base = packing.bond_weights(L) if args.profile == "seed" else 1.0 / np.sum(lags) * np.ones(L)
    original = packing.PackingLaw.bond_weights
    rows = []
    try:
        for k in range(args.runs):
            rng = np.random.default_rng(k)
            w = base if k == 0 else base * (1.0 + 1e-14 * rng.standard_normal(L))
            packing.PackingLaw.bond_weights = lambda self, ppd, w=w: w
            run = run_bsr_column(s)
            m = _metrics(run.t, run.top, run.mass_centre, s)
            peaks = [p["top_max_over_d"] for p in m.get("taps", [m])]
            rows.append(peaks)
            print(f"run {k:2d}: top maxima " + " ".join(f"{p:.2f}" for p in peaks) + " d, vs DEM "
                  + " ".join(f"{p / q - 1:+.1%}" for p, q in zip(peaks, dem_peaks)), flush=True)
    finally:
        packing.PackingLaw.bond_weights = original
    rel = np.array(rows) / np.array(dem_peaks) - 1.0
    print("per tap, over the runs: largest |difference from the DEM| "
          + " ".join(f"{v:.1%}" for v in np.max(np.abs(rel), axis=0))
          + "; spread (max - min) " + " ".join(f"{v:.2f} d" for v in np.ptp(np.array(rows), axis=0)))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"case": args.case, "profile": args.profile, "ppd": args.ppd, "dem_top_max_over_d": dem_peaks,
                       "runs_top_max_over_d": rows}, fh, indent=2)
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
