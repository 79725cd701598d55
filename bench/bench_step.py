"""Benchmark (issue #8): the compiled 1-D step against the plain NumPy reference of the same
scheme, measured in the same run on the same tapped-column grids, one core; the wall time of
the default 2-s column; DEM against BSR for 20, 200 and 2000 spheres; a profile.

    python bench/bench_step.py --json bench/results.json [--repeats 5] [--quick]

States.  The step's cost depends on the state (the interaction integral's fast paths), so it
is measured on the default tapped column (``bsrflow init``'s defaults: seed scheme, a/d = 0.75,
f = 10 Hz, m0 = 406 kg, ε = 0.9) at five times of its run: 0.3 s (settled before the tap), 0.45 s
(launch), 0.6 s (flight), 0.9 s (landing), 1.3 s (settling).  At each state both codes take
steps of the same fixed Δt (the CFL step of that state); csups = cells × stages × steps / s
(all cells of the grid, vacuum included); the reported csups is the total over the five states
(Σ cell-stages / Σ median times).  "Results unchanged": after the same number of steps from the
same state, the largest relative difference (max-norm) of u and ρ between the compiled code and
the NumPy reference, and between the fast and the direct integral.  Timings are medians of
``--repeats`` runs, the three codes' runs interleaved; compilation is excluded.  Both codes run
the column's own solver settings (``ColumnSetup.simulation``: velocity extension, density floor).
"vs direct*" (``speedup_over_direct_no_skip``): bsrflow against the same compiled step with the
direct quadrature sum and without the vacuum skip, so it combines the fast integral's gain and
the skip's.
"""

from __future__ import annotations

import json
import os
import platform
import statistics
import time

import numba
import numpy as np

from bsrflow.numerics.compiled import direct_integral
from bsrflow.numerics.fast_integral import _classify, _classify_scaled_elastic
from bsrflow.numerics.reference import ReferenceScheme
from bsrflow.numerics.solver import Scheme
from bsrflow.physics.interaction import fast_integral_for
from bsrflow.physics.column import ColumnSetup, initial_density, run_bsr_column
from _args import Parser, output_json, positive_int, repo_path  # noqa: E402

DEFAULTS = dict(m0=406.0, kernel_dissipation=0.9, a_over_d=0.75, frequency=10.0)
STATE_TIMES = (0.3, 0.45, 0.6, 0.9, 1.3)


def _setup(ppd, **kw):
    return ColumnSetup(points_per_diameter=ppd, **dict(DEFAULTS, **kw))


def _sim(setup, scheme, **kw):
    """The column's own solver (its monitors, velocity extension and density floor)."""
    return setup.simulation(scheme, **kw)


def column_states(ppd):
    """(t, u, ρ, CFL Δt) of the default column at STATE_TIMES (velocity jumps applied)."""
    s = _setup(ppd, t_end=max(STATE_TIMES))
    sim = _sim(s, Scheme.preset("seed"))
    grid = sim.grid
    res = sim.run(np.zeros(grid.n_cells), initial_density(s, grid.x), s.t_end, save_times=STATE_TIMES)
    states = []
    for k, t in enumerate(res.t):
        u, r = res.u[k].copy(), res.rho[k].copy()
        tt, _, _, _, dt = sim.advance(u.copy(), r.copy(), t, t + 1.0, max_steps=1)
        states.append((float(t), u, r, float(dt)))
    return s, states


def _median_time(fn, repeats):
    times = []
    for _ in range(repeats):
        w = time.perf_counter()
        fn()
        times.append(time.perf_counter() - w)
    return statistics.median(times), times


def _interleaved_medians(fns, repeats):
    """Medians [s] of ``repeats`` timed calls of each function, the functions called in turn
    (round-robin); returns the medians, then the lists of times."""
    times = [[] for _ in fns]
    for _ in range(repeats):
        for k, fn in enumerate(fns):
            w = time.perf_counter()
            fn()
            times[k].append(time.perf_counter() - w)
    return (*[statistics.median(x) for x in times], *times)


def bench_grid(ppd, repeats, steps_c, steps_r):
    s, states = column_states(ppd)
    per_state = []
    tot_c = tot_d = tot_r = 0.0
    work_c = work_d = work_r = 0.0
    worst_ref = worst_direct = 0.0
    for t, u0, r0, dt in states:
        fast = _sim(s, Scheme.preset("seed", dt=dt))
        direct = _sim(s, Scheme.preset("seed", dt=dt), integral="direct", skip_vacuum=False)
        n = fast.grid.n_cells
        stages = fast.tableau.stages
        for sim in (fast, direct):                             # compile
            sim.advance(u0.copy(), r0.copy(), t, t + dt)

        def run(sim, k):
            sim.advance(u0.copy(), r0.copy(), t, t + k * dt)

        ref = ReferenceScheme(direct)
        # the three codes take turns, so that a drift of the machine's speed during the
        # measurement (frequent on this virtual machine) does not bias their ratios
        tc, td, tr, tcs, tds, trs = _interleaved_medians(
            [lambda: run(fast, steps_c), lambda: run(direct, max(1, steps_c // 4)),
             lambda: ref.run_fixed(u0.copy(), r0.copy(), t, dt, steps_r)], repeats)
        # results unchanged: the same steps three ways
        ur, rr = ref.run_fixed(u0.copy(), r0.copy(), t, dt, steps_r)
        uc, rc = u0.copy(), r0.copy()
        fast.advance(uc, rc, t, t + steps_r * dt)
        ud, rd = u0.copy(), r0.copy()
        direct.advance(ud, rd, t, t + steps_r * dt)
        rel = lambda a, b: float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))
        d_ref = max(rel(uc, ur), rel(rc, rr))
        d_dir = max(rel(uc, ud), rel(rc, rd))
        worst_ref = max(worst_ref, d_ref)
        worst_direct = max(worst_direct, d_dir)
        cs_c, cs_d, cs_r = n * stages * steps_c, n * stages * max(1, steps_c // 4), n * stages * steps_r
        tot_c += tc
        tot_d += td
        tot_r += tr
        work_c += cs_c
        work_d += cs_d
        work_r += cs_r
        per_state.append({"t": t, "dt": dt, "cells": n, "material_cells": int(np.sum(r0 > 1e-4 * r0.max())),
                          "bsrflow_csups": cs_c / tc, "direct_integral_csups": cs_d / td,
                          "numpy_csups": cs_r / tr, "speedup": (cs_c / tc) / (cs_r / tr),
                          "max_rel_diff_vs_numpy": d_ref, "max_rel_diff_fast_vs_direct": d_dir,
                          "times_s": {"bsrflow": tcs, "direct": tds, "numpy": trs}})
    return {"cells": states and int(len(states[0][1])), "kernel_radius_cells": ppd,
            "bsrflow_csups": work_c / tot_c, "direct_integral_csups": work_d / tot_d,
            "numpy_csups": work_r / tot_r, "speedup": (work_c / tot_c) / (work_r / tot_r),
            "speedup_over_direct_no_skip": (work_c / tot_c) / (work_d / tot_d),
            "max_rel_diff_vs_numpy": worst_ref, "max_rel_diff_fast_vs_direct": worst_direct,
            "steps": {"bsrflow": steps_c, "numpy": steps_r}, "states": per_state}


def profile(ppd, repeats):
    """Where a step's time goes, on the 1.3-s state (one core): each piece called as the step
    calls it and as often (the right-hand side and the integral over the cells below the column
    top hi, the stages' ghost layers, the moving average's ghost fill, velocity extension and
    moving average below hi + 2, as ``compiled.advance`` with the vacuum skip), in ns
    per grid cell-stage, beside the whole step.  Each piece is called from Python, which adds a
    dispatch overhead of about 1 µs per call that the step does not pay (visible at ppd10, where
    the pieces then add up to more than the step).  The direct integral over the same cells is
    given for comparison.  Times are the minimum over the repeats (the least disturbed by other
    load), unlike the medians of the csups table."""
    s, states = column_states(ppd)
    t, u, r, dt = states[-1]
    sim = _sim(s, Scheme.preset("seed", dt=dt))
    g = sim.grid
    N, W = g.n_cells, sim.W
    G = max(W, 2)
    stages = sim.tableau.stages
    nz = np.nonzero(r)[0]
    hi = min(N, (int(nz[-1]) + 1 if nz.size else 0) + 2 * stages + 2)     # as compiled.advance (reach 1)
    up, rp = np.empty(N + 2 * G), np.empty(N + 2 * G)
    du, dr, out = np.empty(N), np.empty(N), np.empty(N)
    c = sim.core
    kp, bp = sim.model.kernel.params, sim.model.boundary_params
    c.fill_ghosts(u, r, t, up, rp, G, 1, 2, 0.0, g.dx, bp)
    n_act = min(N, hi + 2)
    upc, rpc = up[G:G + N], rp[G:G + N]

    def fills_of_a_step():
        """As compiled.advance: the stages fill the ghost layers only (their state is written
        into the padded arrays), the moving average copies the cells below hi + 3."""
        for _ in range(stages):
            c.fill_ghosts_below(upc, rpc, t, up, rp, G, 1, 2, 0.0, g.dx, bp, 0)
        c.fill_ghosts_below(u, r, t, up, rp, G, 1, 2, 0.0, g.dx, bp, n_act + 1)

    fast = fast_integral_for(sim.model.kernel)
    direct = direct_integral(sim.model.kernel.compiled)
    uu, rr = u.copy(), r.copy()
    fac5 = np.ones(5)
    cls = np.empty(N, dtype=np.int8)
    pieces = {    # name: (function, calls per step)
        "fill_ghosts": (fills_of_a_step, 1),
        "rhs_with_fast_integral": (lambda: c.rhs(t, up, rp, G, hi, 0.0, g.dx, W, sim.qz, sim.qw, kp,
                                                 sim.model.gravity, sim.model.external_params,
                                                 sim.model.motion.params, du, dr, 1, 0.0, sim.wave_speed_params, r,
                                                 sim.vacuum_density, 0.0, 0.0), stages),
        "extend_velocity": (lambda: c.extend_velocity(uu[:n_act], r[:n_act], sim.vacuum_density), 1),
        "moving_average": (lambda: c.moving_average(uu[:n_act], rr[:n_act], up, rp, G, 1), 1),
        "integral_fast": (lambda: fast(up, rp, G, hi, W, sim.qz, sim.qw, kp, out), stages),
        "integral_direct": (lambda: direct(up, rp, G, hi, W, sim.qz, sim.qw, kp, out), stages),
        # the fast integral's O(1)-per-cell pass alone (classes, elastic sums, factors); the rest
        # of integral_fast is the O(W) sign sum on the cells_friction_sum cells
        "integral_one_pass": (lambda: _classify_scaled_elastic(up, rp, G, hi, W, 1.0, fac5, cls, out), stages),
    }
    n_rep = 200
    per_cs = N * stages
    prof = {}
    for name, (fn, calls) in pieces.items():
        fn()
        _, all_t = _median_time(lambda: [fn() for _ in range(n_rep)], max(repeats, 5))
        prof[name + "_ns_per_cell_stage"] = min(all_t) / n_rep * calls / per_cs * 1e9
    u2, r2 = u.copy(), r.copy()
    sim.advance(u2, r2, t, t + dt)
    _, all_t = _median_time(lambda: sim.advance(u.copy(), r.copy(), t, t + 100 * dt), max(repeats, 5))
    whole = min(all_t) / 100 / per_cs * 1e9
    prof["whole_step_ns_per_cell_stage"] = whole
    prof["state_t"] = t
    prof["cells"] = N
    prof["cells_below_top"] = hi
    prof["cells_friction_sum"] = int(_friction_cells(up, rp, G, hi, W))
    return prof


def _friction_cells(up, rp, G, N, W):
    """Number of cells whose window needs the O(W) sign sum (class 4 of the fast integral)."""
    cls = np.empty(N, dtype=np.int8)
    _classify(up, rp, G, N, W, cls)
    return np.sum(cls == 4)


def column_2s(repeats):
    """Wall time [s] of the default column (seed) over 2 s of simulated time: the first run
    (includes compilation) and the median of the following runs."""
    s = _setup(10, t_end=2.0)
    walls = []
    for k in range(repeats + 1):
        w = time.perf_counter()
        run_bsr_column(s)
        walls.append(time.perf_counter() - w)
    return {"first_run_s": walls[0], "median_s": statistics.median(walls[1:]), "runs_s": walls}


def dem_vs_bsr(sizes, repeats, t_end=2.0):
    from bsrflow.physics.dem import DEMColumn, run_dem
    rows = []
    for n in sizes:
        s = _setup(10, n_spheres=n, t_end=t_end, save_every=0.01)
        col = DEMColumn(n_spheres=n, diameter=s.diameter, density=s.density, stiffness=s.stiffness,
                        restitution=s.restitution, gravity=s.gravity)
        run_dem(col, s.motion(), 0.01, sample_interval=0.01)     # compile
        run_bsr_column(s.with_(t_end=0.01))
        reps = repeats if n <= 200 else 1
        dem_t, dem_all = _median_time(lambda: run_dem(col, s.motion(), t_end, sample_interval=0.01), reps)
        bsr_t, bsr_all = _median_time(lambda: run_bsr_column(s), reps)
        rows.append({"spheres": n, "dem_wall_s": dem_t, "bsr_wall_s": bsr_t, "ratio_dem_over_bsr": dem_t / bsr_t,
                     "bsr_cells": s.grid().n_cells, "dem_dt_s": col.dt, "dem_runs_s": dem_all,
                     "bsr_runs_s": bsr_all, "simulated_s": t_end})
        print(f"  {n:5d} spheres: DEM {dem_t:8.2f} s   BSR {bsr_t:8.2f} s   DEM/BSR {dem_t / bsr_t:7.1f}",
              flush=True)
    return rows


def _cpu_model() -> str:
    """The CPU model name (Linux /proc/cpuinfo), else platform.processor(), else 'unknown'."""
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.lower().startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def main(argv=None):
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", type=output_json, default=repo_path("bench/results.json"),
                    help="JSON file written (default bench/results.json)")
    ap.add_argument("--repeats", type=positive_int, default=5, help="timed repeats per case (median)")
    ap.add_argument("--quick", action="store_true", help="fewer steps and repeats, 20/200 spheres only")
    args = ap.parse_args(argv)
    numba.set_num_threads(1)
    reps = 2 if args.quick else args.repeats
    out = {"machine": {"python": platform.python_version(), "numba": numba.__version__,
                       "numpy": np.__version__, "cpu_count": os.cpu_count(), "processor": platform.processor(),
                       "loadavg_start": os.getloadavg() if hasattr(os, "getloadavg") else None},
           "repeats": reps, "one_core": True, "numpy_reference": {}, "bsrflow": {}, "speedup": {},
           "details": {}}
    m = out["machine"]
    print(f"machine: {_cpu_model()}, {m['cpu_count']} CPUs, Python {m['python']}, NumPy {m['numpy']}, "
          f"numba {m['numba']}; load average {' '.join(f'{v:.2f}' for v in m['loadavg_start'] or ())}", flush=True)
    out["machine"]["cpu_model"] = _cpu_model()
    print(f"{'grid':6s} {'cells':>6s} {'W':>3s} {'NumPy csups':>12s} {'bsrflow csups':>14s} {'speed-up':>9s} "
          f"{'vs direct*':>10s} {'max rel diff':>12s} {'ns/cell-stage NumPy, bsrflow':>29s}", flush=True)
    for ppd, sc, sr in ((10, 200, 4), (40, 100, 2)):
        if args.quick:
            sc, sr = sc // 4, 1
        key = f"ppd{ppd}"
        r = bench_grid(ppd, reps, sc, sr)
        out["numpy_reference"][key] = r["numpy_csups"]
        out["bsrflow"][key] = r["bsrflow_csups"]
        out["speedup"][key] = r["speedup"]
        out["details"][key] = r
        print(f"{key:6s} {r['cells']:6d} {r['kernel_radius_cells']:3d} {r['numpy_csups']:12.3e} "
              f"{r['bsrflow_csups']:14.3e} {r['speedup']:9.1f} {r['speedup_over_direct_no_skip']:10.1f} "
              f"{max(r['max_rel_diff_vs_numpy'], r['max_rel_diff_fast_vs_direct']):12.2e} "
              f"{1e9 / r['numpy_csups']:15.1f}, {1e9 / r['bsrflow_csups']:.2f}", flush=True)
    print("profile (ns per grid cell-stage, 1.3-s state):", flush=True)
    out["profile"] = {f"ppd{p}": profile(p, reps) for p in (10, 40)}
    for key, prof in out["profile"].items():
        print("  " + key + ": " + ", ".join(f"{k.replace('_ns_per_cell_stage', '')} {v:.3g}"
                                            for k, v in prof.items() if k.endswith("_ns_per_cell_stage"))
              + f" (cells {prof['cells']}, below the top {prof['cells_below_top']}, "
                f"with the sign sum {prof['cells_friction_sum']})", flush=True)
    c2 = column_2s(2 if args.quick else 3)
    out["column_2s_wall_s"] = c2["median_s"]
    out["column_2s"] = c2
    print(f"column over 2 s: {c2['median_s']:.2f} s (first run with compilation {c2['first_run_s']:.2f} s)",
          flush=True)
    print("DEM vs BSR over 2 s:", flush=True)
    out["dem_vs_bsr"] = dem_vs_bsr((20, 200) if args.quick else (20, 200, 2000), reps)
    out["machine"]["loadavg_end"] = os.getloadavg() if hasattr(os, "getloadavg") else None
    with open(args.json, "w") as fh:
        json.dump(out, fh, indent=2)
    print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
