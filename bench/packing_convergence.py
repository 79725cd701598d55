"""Grid convergence of the packing continuum (issue #18): the tapped column at 5, 10, 20 and 40
cells (Eulerian) or material points (Lagrangian) per diameter.

    python bench/packing_convergence.py --json bench/results_packing_convergence.json \
        [--cases d22mm_a0.75,d22mm_a1.0] [--ppd 5,10,20,40] \
        [--models lagrangian:1,eulerian:0,lagrangian:0] [--formulations eulerian,lagrangian]

For each case and model (FORMULATION:R_OVER_D, as ``bsrflow compare --kernel packing --models``;
``--formulations`` keeps the models of those formulations): the top sphere's maximum (in d) and
its time, the relative change of the top maximum from the next coarser resolution, the
mass-centre RMS against the DEM, and, for a range run in both formulations, the
Eulerian-Lagrangian relative difference of the top maximum at each resolution.  The acceptance of
issue #18: a change of less than 1 % between the two finest, and the two formulations within 2 %.
Wall times are of this machine (one core; they vary with its load).
"""

from __future__ import annotations

import json
import os
import platform
import time

import numpy as np

from _args import Parser, int_in, list_of, output_json, repo_path
from bsrflow.analysis.compare import run_dem_column
from bsrflow.analysis.compare_packing import PACKING_CASES, case_setup, model_label, parse_models
from bsrflow.physics.column import ColumnSetup, run_bsr_column


def main(argv=None):
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", type=output_json, default=repo_path("bench/results_packing_convergence.json"),
                    help="output JSON (its folder must exist)")
    ap.add_argument("--cases", default="d22mm_a0.75,d22mm_a1.0",
                    help="comma-separated case names of `bsrflow compare --kernel packing`")
    ap.add_argument("--ppd", type=list_of(int_in(2)), default=[5, 10, 20, 40],
                    help="points or cells per diameter, comma-separated (each at least 2)")
    ap.add_argument("--models", default="lagrangian:1,eulerian:0,lagrangian:0",
                    help="formulation:R/d pairs, comma-separated (as `bsrflow compare --models`)")
    ap.add_argument("--formulations", default="eulerian,lagrangian",
                    help="keep only the models of these formulations")
    args = ap.parse_args(argv)
    names = args.cases.split(",")
    known = {c["name"]: c for c in PACKING_CASES}
    for n in names:
        if n not in known:
            ap.error(f"--cases: {n!r} is not a case; valid: {', '.join(known)}")
    forms = args.formulations.split(",")
    for f in forms:
        if f not in ("eulerian", "lagrangian"):
            ap.error(f"--formulations: {f!r} is not one of eulerian, lagrangian")
    try:
        models = [mdl for mdl in parse_models(args.models) if mdl[0] in forms]
    except ValueError as exc:
        ap.error(str(exc))
    if not models:
        ap.error("--models / --formulations: no model left to run")
    out = {"machine": f"{platform.machine()}, {os.cpu_count()} cores, {platform.python_implementation()} "
                      f"{platform.python_version()}", "cases": []}
    for name in names:
        base = case_setup(known[name], ColumnSetup())
        t_d, pos, _ = run_dem_column(base)
        d = base.diameter
        after = t_d >= base.tap_start
        kd = int(np.argmax(np.where(after, pos[:, -1], -np.inf)))
        entry = {"name": name, "dem_top_max_over_d": float(pos[kd, -1] / d), "dem_t_top_max": float(t_d[kd]),
                 "rows": []}
        tops = {}
        for form, rng in models:
            label = model_label(form, rng)
            prev = None
            for ppd in args.ppd:
                s = base.with_(formulation=form, range_over_d=rng, points_per_diameter=ppd)
                w = time.perf_counter()
                r = run_bsr_column(s)
                wall = time.perf_counter() - w
                k = int(np.argmax(np.where(r.t >= s.tap_start, r.top, -np.inf)))
                top = float(r.top[k] / d)
                rms = float(np.sqrt(np.mean(((np.interp(t_d, r.t, r.mass_centre) - pos.mean(axis=1)) / d) ** 2)))
                row = {"formulation": form, "range_over_d": rng, "model": label, "ppd": ppd,
                       "top_max_over_d": top, "t_top_max": float(r.t[k]),
                       "change_from_coarser": None if prev is None else top / prev - 1.0,
                       "top_max_rel_diff_dem": top / entry["dem_top_max_over_d"] - 1.0,
                       "mass_centre_rms_over_d": rms, "steps": int(r.steps), "wall_s": wall}
                entry["rows"].append(row)
                tops[(form, rng, ppd)] = top
                prev = top
                ch = "" if row["change_from_coarser"] is None else f"{100 * row['change_from_coarser']:+.3f}%"
                print(f"{name} {label:16s} ppd {ppd:3d}: top {top:.3f} d at {row['t_top_max']:.3f} s "
                      f"(change {ch or '-'}), vs DEM {100 * row['top_max_rel_diff_dem']:+.2f}%, mc RMS {rms:.3f} d, "
                      f"{r.steps} steps, {wall:.1f} s", flush=True)
                with open(args.json, "w") as fh:       # after every run: nothing lost if it dies
                    json.dump(out | {"cases": out["cases"] + [entry]}, fh, indent=2)
        both = sorted({r for f, r in models if ("eulerian", r) in models and ("lagrangian", r) in models})
        for rng in both:
            key = "eulerian_vs_lagrangian" + ("" if rng == 0.0 else f"_R{rng:g}d")
            entry[key] = {str(p): tops[("eulerian", rng, p)] / tops[("lagrangian", rng, p)] - 1.0
                          for p in args.ppd}
            print(f"{name} eulerian/lagrangian - 1: " + ", ".join(
                f"ppd {p}: {100 * v:+.3f}%" for p, v in ((int(k), v) for k, v in entry[key].items())))
        out["cases"].append(entry)
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=2)
    print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
