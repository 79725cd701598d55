"""Does the packing continuum predict columns outside the 14 cases of issue #18?

    python bench/check_packing_generality.py [--json PATH] [--variants NAME ...] [--a-over-d 0.75 1.0]

The 14 cases of ``bsrflow compare --kernel packing`` vary the sphere size and the tap amplitude
at one restitution (e = 0.9), one column (N = 20), one tap frequency (10 Hz) and one contact
stiffness.  This script changes one of those at a time, d = 22 mm, single taps, and runs the
built-in DEM, the nonlocal continuum (Lagrangian, R = d, the package's packing continuum) and
its local limit (R = 0) through the same comparison (:func:`bsrflow.analysis.compare_packing.
compare_packing`: nothing fitted, 10 points per diameter).  Variants:

    e0.5, e0.7, e0.95     restitution of the contact law (DEM and continuum alike)
    N10, N40              number of spheres
    f20                   tap frequency 20 Hz (the half-sine lasts 25 ms instead of 50 ms)
    K10x                  contact stiffness ten times the default (1.366e8 N/m)

It prints, per variant and tap amplitude, the top maximum's, the rise's and the top time's
relative errors against the DEM for both models, and the mass-centre RMS difference [d] over the
run, and from the tap's start on split at the DEM column's landing, taken as the ballistic return of its top (the tap's
start plus twice the rise time of the DEM's top maximum): before it (the tap and the flight) and
after it (the landing and what follows).  Writes the comparison entries (the schema of the compare
JSON, plus ``mass_centre_rms_flight_over_d``, ``mass_centre_rms_after_landing_over_d`` and
``dem_landing_time``) to ``--json`` (default ``bench/results_packing_generality.json``).  Takes a few minutes (the
K10x runs take longest: the step scales as 1/√K).
"""

from __future__ import annotations

import json
import time

import numpy as np

from bsrflow.analysis.compare import run_dem_column
from bsrflow.analysis.compare_packing import _metrics, _run_against_dem, case_setup
from bsrflow.physics.column import ColumnSetup
from _args import Parser, float_in, output_json, repo_path  # noqa: E402

VARIANTS = {
    "e0.5": {"restitution": 0.5},
    "e0.7": {"restitution": 0.7},
    "e0.95": {"restitution": 0.95},
    "N10": {"n_spheres": 10},
    "N40": {"n_spheres": 40},
    "f20": {"frequency": 20.0},
    "K10x": {"stiffness": 1.366e8},
}
MODELS = (("lagrangian", 1.0), ("lagrangian", 0.0))


def split_rms(t_dem, mc_dem, t_run, mc_run, t_tap, t_land, d):
    """Mass-centre RMS difference [d] over [t_tap, t_land) and [t_land, end] (on the DEM's output
    times)."""
    diff = (np.interp(t_dem, t_run, mc_run) - mc_dem) / d
    flight = (t_dem >= t_tap) & (t_dem < t_land)
    after = t_dem >= t_land
    return float(np.sqrt(np.mean(diff[flight] ** 2))), float(np.sqrt(np.mean(diff[after] ** 2)))


def main(argv=None):
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", type=output_json, default=repo_path("bench/results_packing_generality.json"),
                    help="output JSON path")
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=list(VARIANTS), metavar="NAME",
                    help="any of: " + ", ".join(VARIANTS))
    ap.add_argument("--a-over-d", type=float_in(0.0, 20.0, lo_open=True), nargs="+", default=[0.75, 1.0],
                    help="tap amplitudes a/d, in (0, 20]")
    args = ap.parse_args(argv)
    cases = [dict(name=f"d22mm_a{a}", diameter=0.022, a_over_d=a, n_taps=1) for a in args.a_over_d]
    out = {"models": [f"{f} R={r:g}d" for f, r in MODELS], "variants": {},
           "command": "python bench/check_packing_generality.py"}
    w0 = time.perf_counter()
    print(f"{'variant':8s} {'case':12s} {'model':18s} {'top':>7s} {'rise':>7s} {'t top':>7s}   mass-centre RMS [d]: "
          f"run / flight / after landing   (against the DEM)")
    for name in args.variants:
        base = ColumnSetup(kernel_name="packing").with_(**VARIANTS[name])
        entries = []
        for case in cases:
            s0 = case_setup(case, base)
            w = time.perf_counter()
            dem = run_dem_column(s0)
            dem_wall = time.perf_counter() - w
            t_d, pos, _ = dem
            dem_m = _metrics(t_d, pos[:, -1], pos.mean(axis=1), s0)
            t_land = s0.tap_start + 2.0 * dem_m["t_rise"]
            for form, rng in MODELS:
                run, c = _run_against_dem(case["name"], s0.with_(formulation=form, range_over_d=rng), dem, dem_m,
                                          dem_wall)
                fl, after = split_rms(t_d, pos.mean(axis=1), run.t, run.mass_centre, s0.tap_start, t_land,
                                      s0.diameter)
                c |= {"dem_landing_time": t_land, "mass_centre_rms_flight_over_d": fl,
                      "mass_centre_rms_after_landing_over_d": after}
                entries.append(c)
                print(f"{name:8s} {c['name']:12s} {c['model']:18s} {100 * c['top_max_rel_diff']:+6.1f}% "
                      f"{100 * c['rise_rel_diff']:+6.1f}% {100 * c['t_top_max_rel_diff']:+6.1f}%   "
                      f"{c['mass_centre_rms_over_d']:.3f} / {fl:.3f} / {after:.3f}", flush=True)
        out["variants"][name] = {"changes": VARIANTS[name], "cases": entries}
    out["wall_time_s"] = time.perf_counter() - w0
    with open(args.json, "w") as fh:
        json.dump(out, fh, indent=1)
    print(f"wrote {args.json} ({out['wall_time_s']:.0f} s)")


if __name__ == "__main__":
    main()
