"""The reduced-stiffness option of the packing continuum against the true stiffness (issue #18).

    python bench/packing_stiffness.py --json bench/results_packing_stiffness.json \
        [--formulation lagrangian] [--range R] [--ppd 10] [--mach 0.003,0.01,0.03] [--cases all]

For each case of the packing comparison: a run at the true contact stiffness K and runs at the
factors :func:`bsrflow.physics.column.suggest_stiffness_factor` picks for each impact Mach number
M; per run the top maximum's relative change, the change of its time, the mass-centre RMS
difference against the true-stiffness run (in d), the number of steps and the wall time (this
machine, one core).  ``--range``: the interaction range R/d (default: the column's, 1 in both
formulations since 2026-12-03; the Eulerian runs of docs/results/ before then are of the local
limit, R = 0).  The documented bound of the model
(``STIFFNESS_ERROR_BOUNDS``, at M ≤ 0.01) is checked for every case and the largest errors are
printed.
"""

from __future__ import annotations

import json
import os
import platform
import time

import numpy as np

from _args import Parser, float_in, list_of, output_json, positive_int, repo_path
from bsrflow.analysis.compare_packing import PACKING_CASES, case_setup
from bsrflow.physics.column import (STIFFNESS_ERROR_BOUNDS, ColumnSetup, impact_mach, run_bsr_column,
                                    stiffness_model, suggest_stiffness_factor)


def _peak(run, s):
    """The first tap's peak (several taps give nearly equal peaks, whose argmax would jump)."""
    window = (run.t >= s.tap_start) & (run.t < s.tap_start + (s.tap_period if s.n_taps > 1 else np.inf))
    k = int(np.argmax(np.where(window, run.top, -np.inf)))
    return float(run.top[k] / s.diameter), float(run.t[k])


def main(argv=None):
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", type=output_json, default=repo_path("bench/results_packing_stiffness.json"),
                    help="JSON file written (default bench/results_packing_stiffness.json)")
    ap.add_argument("--formulation", default="lagrangian", choices=("eulerian", "lagrangian"),
                    help="the packing continuum's formulation (default lagrangian)")
    ap.add_argument("--range", type=float, default=None, help="R/d (default: the formulation's)")
    ap.add_argument("--ppd", type=positive_int, default=10, help="points per diameter (default 10)")
    ap.add_argument("--mach", type=list_of(float_in(0.0, 1.0, lo_open=True)), default=[0.003, 0.01, 0.03],
                    help="Mach numbers, comma-separated, each in (0, 1]")
    ap.add_argument("--cases", default="all", help="comma-separated case names of the packing comparison, or all (default)")
    args = ap.parse_args(argv)
    known = {c["name"]: c for c in PACKING_CASES}
    names = list(known) if args.cases == "all" else args.cases.split(",")
    for n in names:
        if n not in known:
            ap.error(f"--cases: {n!r} is not a case; valid: all or {', '.join(known)}")
    try:
        probe = ColumnSetup(kernel_name="packing", formulation=args.formulation, range_over_d=args.range,
                            points_per_diameter=args.ppd)
    except ValueError as exc:
        ap.error(str(exc))
    model = stiffness_model(probe)
    bound = STIFFNESS_ERROR_BOUNDS.get(model)
    out = {"formulation": args.formulation, "range_over_d": probe.interaction_range(), "model": model,
           "ppd": args.ppd, "bound": bound,
           "machine": f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}",
           "cases": []}
    worst = {}
    for name in names:
        base = case_setup(known[name], ColumnSetup(points_per_diameter=args.ppd)).with_(
            formulation=args.formulation, range_over_d=args.range)
        w = time.perf_counter()
        ref = run_bsr_column(base)
        ref_wall = time.perf_counter() - w
        top0, t0 = _peak(ref, base)
        entry = {"name": name, "true": {"top_max_over_d": top0, "t_top_max": t0, "steps": int(ref.steps),
                                        "wall_s": ref_wall, "impact_mach": impact_mach(base)}, "reduced": []}
        print(f"{name}: true stiffness top {top0:.3f} d at {t0:.3f} s, M = {impact_mach(base):.2e}, "
              f"{ref.steps} steps, {ref_wall:.1f} s", flush=True)
        for mach in args.mach:
            phi = suggest_stiffness_factor(base, mach)
            s = base.with_(stiffness_factor=phi)
            w = time.perf_counter()
            r = run_bsr_column(s)
            wall = time.perf_counter() - w
            top, tt = _peak(r, s)
            rms = float(np.sqrt(np.mean(((np.interp(ref.t, r.t, r.mass_centre) - ref.mass_centre) / s.diameter) ** 2)))
            row = {"mach": mach, "stiffness_factor": phi, "top_max_rel": top / top0 - 1.0,
                   "t_top_max_rel": tt / t0 - 1.0, "mass_centre_rms_over_d": rms, "steps": int(r.steps),
                   "wall_s": wall, "speed_up": ref_wall / wall if wall > 0 else None}
            entry["reduced"].append(row)
            wm = worst.setdefault(mach, {"top_max_rel": 0.0, "mass_centre_rms_over_d": 0.0})
            wm["top_max_rel"] = max(wm["top_max_rel"], abs(row["top_max_rel"]))
            wm["mass_centre_rms_over_d"] = max(wm["mass_centre_rms_over_d"], rms)
            print(f"  M = {mach:g}: factor {phi:.3g}, top {100 * row['top_max_rel']:+.2f}%, t {100 * row['t_top_max_rel']:+.2f}%, "
                  f"mass-centre RMS {rms:.4f} d, {r.steps} steps ({ref.steps / max(r.steps, 1):.1f}x fewer), {wall:.2f} s",
                  flush=True)
        out["cases"].append(entry)
        out["worst"] = {str(k): v for k, v in worst.items()}
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=2)
    for mach, wm in sorted(worst.items()):
        if bound is None or mach > 0.01:
            note = "" if mach > 0.01 else f"  (no documented bound for {model})"
        else:
            within = (wm["top_max_rel"] <= bound["top_max_rel"]
                      and wm["mass_centre_rms_over_d"] <= bound["mass_centre_rms_over_d"])
            note = "  (within the documented bound)" if within else "  (OUTSIDE the documented bound)"
        print(f"worst over the cases at M = {mach:g}: |top| {100 * wm['top_max_rel']:.2f}%, mass-centre RMS "
              f"{wm['mass_centre_rms_over_d']:.4f} d" + note)
    print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
