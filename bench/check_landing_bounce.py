"""The packing column's mass centre around its landing, per formulation and resolution, beside the
DEM's (issue #18: where the Eulerian bounce at 40 cells per diameter comes from).

    python bench/check_landing_bounce.py [--case d22mm_a1.0] [--runs eulerian:20,eulerian:40,lagrangian:40]
        [--stiffness-factor 1] [--times 0.9,0.95,1.0,1.05,1.1,1.15,1.2]

Prints the mass centre [d] at ``--times`` (within the run) for the DEM and each run
(formulation:points per diameter; the local limit of the packing continuum, ``range_over_d = 0``,
in both formulations, the model whose landing this script was written to study); then the top of the material [d] in the lab frame (the DEM:
the top sphere's centre + d/2; a continuum: the upper face of its highest cell above 1e-3 ρ_c)
and the DEM's widest gap between neighbouring spheres [d] (surface to surface: how spread out it
lands); then, for the last run, the material above the column at the end: the cells with more than 1e-6 ρ_c above the resting column's top N d, their density range
[ρ_c], extent [d] and mass-weighted mean velocity [m/s].  The true-stiffness Eulerian run at 40 cells per diameter takes about
10 minutes on one core of this VM.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from _args import Parser, float_in, list_of, positive_float
from bsrflow.analysis.compare import run_dem_column
from bsrflow.analysis.compare_packing import PACKING_CASES, case_setup
from bsrflow.physics.column import ColumnSetup, run_bsr_column


def _run_spec(text):
    form, _, ppd = text.partition(":")
    if form not in ("eulerian", "lagrangian") or not ppd.isdigit() or int(ppd) < 2:
        raise argparse.ArgumentTypeError(f"{text!r}: expected formulation:ppd, e.g. eulerian:20 (ppd >= 2)")
    return form, int(ppd)


def _table(series, names, times, d, title, extra=lambda tt: ""):
    """Print series[name] = (t, values [m]) in units of d at ``times`` ('-' outside a run)."""
    print("t [s]  " + "  ".join(f"{n:>14s}" for n in names) + "   " + title)
    for tt in times:
        row = []
        for n in names:
            t, v = series[n]
            row.append(f"{np.interp(tt, t, v) / d:14.2f}" if t[0] <= tt <= t[-1] else f"{'-':>14s}")
        print(f"{tt:5.2f}  " + "  ".join(row) + extra(tt))


def main(argv=None):
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", default="d22mm_a1.0", help="a case of `bsrflow compare --kernel packing`")
    ap.add_argument("--runs", type=list_of(_run_spec), default=[("eulerian", 20), ("eulerian", 40), ("lagrangian", 40)],
                    help="formulation:ppd pairs, comma-separated, e.g. eulerian:20,lagrangian:40")
    ap.add_argument("--stiffness-factor", type=float_in(0.0, 1.0, lo_open=True), default=1.0,
                    help="K x this factor, in (0, 1] (default 1)")
    ap.add_argument("--times", type=list_of(positive_float), default=[0.9, 0.95, 1.0, 1.05, 1.1, 1.15, 1.2],
                    help="times [s] at which the state is printed, comma-separated")
    args = ap.parse_args(argv)
    known = {c["name"]: c for c in PACKING_CASES}
    if args.case not in known:
        ap.error(f"--case: {args.case!r} is not a case; valid: {', '.join(known)}")
    base = case_setup(known[args.case], ColumnSetup())
    d = base.diameter
    t_d, pos, _ = run_dem_column(base)
    series = {"DEM": (t_d, pos.mean(axis=1))}
    tops = {"DEM": (t_d, pos[:, -1] + 0.5 * d)}
    last = None
    for form, ppd in args.runs:
        s = case_setup(known[args.case], ColumnSetup(points_per_diameter=ppd)).with_(
            formulation=form, stiffness_factor=args.stiffness_factor, range_over_d=0.0)   # the local limit, both
        w = time.perf_counter()
        r = run_bsr_column(s)
        print(f"{form} {ppd} per diameter: {r.steps} steps, {time.perf_counter() - w:.1f} s", flush=True)
        series[f"{form} {ppd}"] = (r.t, r.mass_centre)
        rc_run = s.packing_law().close_packing_density
        dx = r.x[1] - r.x[0]
        top = np.array([r.x[np.nonzero(rho > 1e-3 * rc_run)[0][-1]] + 0.5 * dx if np.any(rho > 1e-3 * rc_run) else 0.0
                        for rho in r.rho])
        tops[f"{form} {ppd}"] = (r.t, top + r.floor)       # the grid is the floor's frame; the DEM's the lab's
        last = (s, r)
    names = list(series)
    _table(series, names, args.times, d, "(mass centre [d])")
    gap = np.max(np.diff(pos, axis=1), axis=1) - d
    _table(tops, names, args.times, d, "(top of the material [d], lab frame)   DEM widest gap [d]",
           extra=lambda tt: f"   {np.interp(tt, t_d, gap) / d:8.2f}" if t_d[0] <= tt <= t_d[-1] else f"   {'-':>8s}")
    s, r = last
    rc = s.packing_law().close_packing_density
    rho, u, x = r.rho[-1], r.u[-1], r.x
    above = (rho > 1e-6 * rc) & (x > s.n_spheres * d)
    if np.any(above):
        k = np.nonzero(above)[0]
        print(f"last run at t = {r.t[-1]:.3g} s: material above {s.n_spheres} d: "
              f"{rho[k].min() / rc:.3g}-{rho[k].max() / rc:.3g} rho_c over {x[k].min() / d:.2f}-{x[k].max() / d:.2f} d, "
              f"mean velocity {np.average(u[k], weights=rho[k]):.3g} m/s")
    else:
        print(f"last run at t = {r.t[-1]:.3g} s: no material above {s.n_spheres} d")


if __name__ == "__main__":
    main()
