"""Wall time of the packing continuum's tapped column over 2 s of simulated time (issue #18).

    python bench/bench_packing.py --json bench/results.json [--repeats 3] [--ppd 10]

The default column (d = 2.2 cm, 20 spheres, a/d = 0.75, one tap at 0.4 s) from rest to t = 2 s:
each packing model (the nonlocal interaction, R = d, and its local limit, each in both
formulations) at the true contact stiffness and with the reduced-stiffness option
(``suggest_stiffness_factor`` at impact Mach number 0.01), beside the package's DEM of the same
column, measured in the same run (median of ``--repeats`` wall times after compilation, one
core).  The result is added under the key ``"packing_column_2s"`` to the JSON file (which
``bench/bench_step.py`` writes first in ``make bench``); other keys are kept.  Wall times are of
this machine and vary with its load; the ratios to the DEM in the same run are the comparable
figures.
"""

from __future__ import annotations

import os
import platform
import statistics
import time

from _args import Parser, merge_json, merge_target, positive_int, repo_path
from bsrflow.analysis.compare import run_dem_column
from bsrflow.analysis.compare_packing import PACKING_MODELS, model_label
from bsrflow.physics.column import ColumnSetup, run_bsr_column, suggest_stiffness_factor


def _median_wall(fn, repeats):
    fn()                                     # compile
    walls = []
    for _ in range(repeats):
        w = time.perf_counter()
        out = fn()
        walls.append(time.perf_counter() - w)
    return statistics.median(walls), walls, out


def main(argv=None):
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", type=merge_target, default=repo_path("bench/results.json"),
                    help="JSON to add the results to (its folder must exist)")
    ap.add_argument("--repeats", type=positive_int, default=3, help="timed runs per setting (median)")
    ap.add_argument("--ppd", type=positive_int, default=10, help="points or cells per diameter")
    args = ap.parse_args(argv)
    base = ColumnSetup(kernel_name="packing", t_end=2.0, points_per_diameter=args.ppd)
    phi = suggest_stiffness_factor(base)
    dem_wall, dem_walls, _ = _median_wall(lambda: run_dem_column(base), args.repeats)
    rows = []
    print(f"DEM: {dem_wall:.3f} s (median of {args.repeats})", flush=True)
    for form, rng in PACKING_MODELS + (("eulerian", 0.0), ("lagrangian", 0.0)):
        for factor in (1.0, phi):
            s = base.with_(formulation=form, range_over_d=rng, stiffness_factor=factor)
            wall, walls, run = _median_wall(lambda: run_bsr_column(s), args.repeats)
            rows.append({"formulation": form, "range_over_d": rng, "model": model_label(form, rng),
                         "stiffness_factor": factor, "wall_s": wall, "walls_s": walls,
                         "steps": int(run.steps), "wall_over_dem": wall / dem_wall,
                         "top_max_over_d": float(run.top.max() / s.diameter)})
            print(f"packing {model_label(form, rng):16s} stiffness factor {factor:.3g}: {wall:.2f} s, {run.steps} steps, "
                  f"{wall / dem_wall:.1f}x the DEM", flush=True)
    entry = {"column": "d = 0.022 m, 20 spheres, a/d = 0.75, one tap at 0.4 s, 0-2 s",
             "points_per_diameter": args.ppd, "repeats": args.repeats, "dem_wall_s": dem_wall,
             "dem_walls_s": dem_walls, "runs": rows,
             "machine": f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}"}
    merge_json(args.json, "packing_column_2s", entry)


if __name__ == "__main__":
    main()
