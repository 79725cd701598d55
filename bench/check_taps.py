"""Robustness check (issue #5): the tapped column with a scheme preset at several grids, tap
amplitudes and kernel constants; prints one line per run (ok with top and mass-centre maxima, or
the solver's stop message) and writes them as JSON.

    python bench/check_taps.py [--scheme accurate] [--ppd 10,20,40] [--json out/check_taps.json]

Cases: a single tap at a/d = 0.75 and 1.0 (to 1.3 s) and three taps at a/d = 0.75 (to 2.5 s),
each with (m0, ε) = (406 kg, 0.9) (the seed preset's calibration) and (179 kg, 0.898) (a
stiffer column).  One core.  Exit code 1 when any run stops early.
"""

from __future__ import annotations

import json
import os
import time

import numba
import numpy as np

from bsrflow.numerics.solver import Scheme, SimulationError
from bsrflow.physics.column import ColumnSetup, run_bsr_column
from _args import Parser, list_of, output_json, positive_int, repo_path  # noqa: E402

CASES = {"single_tap_a0.75": dict(a_over_d=0.75, n_taps=1),
         "single_tap_a1.0": dict(a_over_d=1.0, n_taps=1),
         "three_taps_a0.75": dict(a_over_d=0.75, n_taps=3, t_end=2.5)}
CONSTANTS = (dict(m0=406.0, kernel_dissipation=0.9), dict(m0=179.0, kernel_dissipation=0.898))


def main(argv=None):
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scheme", default="accurate", choices=("seed", "accurate"), help="scheme preset (default accurate)")
    ap.add_argument("--ppd", type=list_of(positive_int), default=[10, 20, 40], help="points per diameter, comma-separated")
    ap.add_argument("--json", type=output_json, default=repo_path("out/check_taps.json"),
                    help="JSON file written (default out/check_taps.json)")
    args = ap.parse_args(argv)
    numba.set_num_threads(1)
    rows, failed = [], 0
    for ppd in args.ppd:
        for case, kw in CASES.items():
            for const in CONSTANTS:
                s = ColumnSetup(points_per_diameter=ppd, **const, **kw)
                row = dict(ppd=ppd, case=case, **const)
                w = time.perf_counter()
                try:
                    r = run_bsr_column(s, Scheme.preset(args.scheme))
                    row.update(status="ok", top_max_over_d=float(np.max(r.top) / s.diameter),
                               mass_centre_max_over_d=float(np.max(r.mass_centre) / s.diameter),
                               min_density=float(r.rho.min()), steps=int(r.steps))
                except SimulationError as exc:
                    row.update(status=str(exc))
                    failed += 1
                row["wall_s"] = time.perf_counter() - w
                rows.append(row)
                what = (f"top {row['top_max_over_d']:.2f} d, mass centre {row['mass_centre_max_over_d']:.2f} d, "
                        f"min ρ {row['min_density']:.1e}" if row["status"] == "ok" else row["status"])
                print(f"{args.scheme} ppd {ppd:2d} {case:17s} m0 {const['m0']:5.0f}: {what}", flush=True)
    with open(args.json, "w") as fh:
        json.dump({"scheme": args.scheme, "runs": rows}, fh, indent=1)
    print(f"{len(rows) - failed} of {len(rows)} runs completed; wrote {args.json}")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
