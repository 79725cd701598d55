"""Benchmark of the compiled 3-D BSR step: time per step and cell-stage updates per second.

    .venv/bin/python bench/bench_nd.py [--sizes 32 64 128] [--threads 1 2] [--json PATH]

Setup: cubic grids n^3 with Δx = 2 mm, fully periodic, the vector Walton-Braun kernel with a
ball of radius 2 cells (81 offsets, evaluated as 41 mirrored pairs), every cell filled with
material (random density 500-1000 kg/m^3, random velocity ~0.1 m/s: no cell is skipped as
vacuum), the seed's scheme (Kutta's RK3, 3 stages, plus the (5.7) average every step) with a
fixed step.  One timing = wall time of ``advance`` over a few steps (no Python in between),
divided by the steps; reported is the median of the repeats.

cell-stage updates per second = n_cells * stages / (time per step): one update is the whole
right-hand side of one cell (its 81-point quadrature sum, the central differences) plus its
share of the ghost fill, stage combination and average.  Parallel efficiency = t_1 / (p t_p).

The machine may be shared: the load average before and after is recorded in the JSON.
"""

from __future__ import annotations

import json
import os
import platform
import statistics
import sys
import time

import numba
import numpy as np

from bsrflow.numerics.grid_nd import GridND
from bsrflow.numerics.solver import Scheme
from bsrflow.numerics.solver_nd import BSRModelND, SimulationND, to_internal, walton_braun_nd
from bsrflow.physics.motion import HalfSineTaps
from _args import Parser, int_in, output_json  # noqa: E402

DX = 0.002
W = 2
PLAN = {32: (10, 5), 64: (3, 3), 128: (1, 3)}      # n -> (steps per timing, repeats)


def make_sim(n):
    grid = GridND((n, n, n), DX, bc_horizontal="periodic", bc_lower="periodic", bc_upper="periodic")
    model = BSRModelND(walton_braun_nd(1e9, 0.105, W * DX), HalfSineTaps(0.0, 10.0), 9.81)
    sim = SimulationND(model, grid, Scheme.preset("seed", dt=1e-5))
    rng = np.random.default_rng(0)
    rho = rng.uniform(500.0, 1000.0, grid.shape)
    u = rng.normal(0.0, 0.1, (3,) + grid.shape)
    return sim, *to_internal(grid, u, rho)


def time_steps(sim, ui, ri, steps):
    u, r = ui.copy(), ri.copy()
    t0 = time.perf_counter()
    _, done, status, _, _ = sim.advance_internal(u, r, 0.0, steps * 1e-5, max_steps=steps + 1)
    wall = time.perf_counter() - t0
    if status != 0 or done != steps:
        raise RuntimeError(f"benchmark run stopped: status {status}, {done} steps")
    return wall / steps


def main(argv=None) -> int:
    ap = Parser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int_in(max(3, W + 1)), nargs="+", default=[32, 64, 128],
                    help=f"grid sizes n (n^3 cells), in [{max(3, W + 1)}, inf)")
    ap.add_argument("--threads", type=int_in(1, numba.config.NUMBA_NUM_THREADS), nargs="+", default=[1, 2],
                    help=f"numba thread counts, in [1, {numba.config.NUMBA_NUM_THREADS}] (NUMBA_NUM_THREADS)")
    ap.add_argument("--json", type=output_json, default=os.path.join(os.path.dirname(__file__), "results_nd.json"),
                    help="output JSON path (default bench/results_nd.json)")
    args = ap.parse_args(argv)
    maxt = numba.config.NUMBA_NUM_THREADS
    for p in args.threads:                  # the default 2 too, on a machine with one thread
        if not (1 <= p <= maxt):
            ap.error(f"argument --threads: {p} is outside the valid range [1, {maxt}] (NUMBA_NUM_THREADS)")

    load0 = os.getloadavg()
    # compile once on a tiny grid
    sim, ui, ri = make_sim(8)
    t0 = time.perf_counter()
    time_steps(sim, ui, ri, 1)
    compile_s = time.perf_counter() - t0
    stages = sim.tableau.stages
    rows = []
    for n in args.sizes:
        sim, ui, ri = make_sim(n)
        steps, reps = PLAN.get(n, (2, 3))
        for p in args.threads:
            numba.set_num_threads(p)
            time_steps(sim, ui, ri, 1)                      # warm-up (first touch of memory)
            ts = [time_steps(sim, ui, ri, steps) for _ in range(reps)]
            t = statistics.median(ts)
            rows.append({"n": n, "cells": n ** 3, "threads": p, "steps_per_timing": steps, "repeats": reps,
                         "time_per_step_s": t, "all_times_s": ts,
                         "cell_stage_updates_per_s": n ** 3 * stages / t,
                         "offsets": int(sim.weights.size)})
            print(f"  n={n:4d} threads={p}: {t:.4g} s/step", flush=True)
    eff = {}
    for n in args.sizes:
        t1 = [r["time_per_step_s"] for r in rows if r["n"] == n and r["threads"] == 1]
        for r in rows:
            if r["n"] == n and r["threads"] > 1 and t1:
                r["parallel_efficiency"] = t1[0] / (r["threads"] * r["time_per_step_s"])
                eff[f"{n}^3 x{r['threads']}"] = r["parallel_efficiency"]
    load1 = os.getloadavg()

    head = f"{'grid':>8s} {'threads':>7s} {'s/step':>10s} {'cell-stage upd/s':>17s} {'par. eff.':>9s}"
    print(head)
    print("-" * len(head))
    for r in rows:
        pe = r.get("parallel_efficiency")
        print(f"{str(r['n']) + '^3':>8s} {r['threads']:7d} {r['time_per_step_s']:10.4g} "
              f"{r['cell_stage_updates_per_s']:17.4g} {'' if pe is None else f'{pe:9.2f}':>9s}")
    print(f"(compile {compile_s:.1f} s; load average {load0[0]:.2f} before, {load1[0]:.2f} after, "
          f"{os.cpu_count()} CPUs)")

    out = {"benchmark": "bsrflow n-D step (3-D, ball radius 2 cells, kutta3 + (5.7) average)",
           "stages": stages, "dx_m": DX, "kernel_radius_cells": W, "results": rows,
           "parallel_efficiency": eff, "compile_s": compile_s,
           "machine": {"cpus": os.cpu_count(), "platform": platform.platform(), "python": sys.version.split()[0],
                       "numba": numba.__version__, "numpy": np.__version__,
                       "threading_layer": numba.threading_layer(),
                       "load_average_before": load0, "load_average_after": load1}}
    with open(args.json, "w") as fh:
        json.dump(out, fh, indent=2)
    print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
