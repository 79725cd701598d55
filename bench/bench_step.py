"""Benchmark: the compiled 1-D step against the plain NumPy reference of the same scheme,
measured in the same run on the same tapped-column grid, one core.

    python bench/bench_step.py --json bench/results.json [--repeats 5]

Prints cell-stage updates per second (csups = cells x stages x steps / s) for 10 and 40 grid
points per diameter (ppd10, ppd40), the speed-up of the compiled step over the reference, and
checks the two give the same state (relative difference printed).  Medians of repeats.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time

import numba
import numpy as np

from bsrflow.numerics.reference import ReferenceScheme
from bsrflow.numerics.solver import Scheme, Simulation
from bsrflow.physics.column import ColumnSetup, initial_density


def column_sim(ppd: int, dt: float):
    s = ColumnSetup(points_per_diameter=ppd, m0=410.0, kernel_dissipation=0.83)
    grid = s.grid()
    line = s.particle_mass / s.diameter
    sim = Simulation(s.model(), grid, Scheme.preset("seed", dt=dt), vacuum_density=1e-4 * line)
    rng = np.random.default_rng(0)
    rho = initial_density(s, grid.x)
    u = 0.01 * rng.standard_normal(grid.n_cells) * (rho > 0)
    return sim, u, rho


def bench(ppd: int, repeats: int, steps_c: int, steps_r: int):
    dt = 1e-5
    sim, u0, r0 = column_sim(ppd, dt)
    stages = sim.tableau.stages
    n = sim.grid.n_cells
    ref = ReferenceScheme(sim)
    u, r = u0.copy(), r0.copy()
    sim.advance(u, r, 0.0, dt)                          # compile
    tc, tr = [], []
    for _ in range(repeats):
        u, r = u0.copy(), r0.copy()
        w = time.perf_counter()
        sim.advance(u, r, 0.0, steps_c * dt)
        tc.append(time.perf_counter() - w)
    for _ in range(repeats):
        w = time.perf_counter()
        ur, rr = ref.run_fixed(u0.copy(), r0.copy(), 0.0, dt, steps_r)
        tr.append(time.perf_counter() - w)
    # results unchanged: the same number of steps both ways
    uc, rc = u0.copy(), r0.copy()
    sim.advance(uc, rc, 0.0, steps_r * dt)
    diff = max(np.max(np.abs(uc - ur)) / np.max(np.abs(ur)), np.max(np.abs(rc - rr)) / np.max(np.abs(rr)))
    csups_c = n * stages * steps_c / statistics.median(tc)
    csups_r = n * stages * steps_r / statistics.median(tr)
    return {"cells": n, "kernel_radius_cells": sim.W, "stages": stages, "compiled_csups": csups_c,
            "numpy_csups": csups_r, "speedup": csups_c / csups_r, "max_relative_difference": float(diff),
            "compiled_times_s": tc, "numpy_times_s": tr, "steps_compiled": steps_c, "steps_numpy": steps_r}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", default="bench/results.json")
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args(argv)
    numba.set_num_threads(1)
    out = {"machine": {"python": platform.python_version(), "numba": numba.__version__,
                       "numpy": np.__version__, "cpu_count": os.cpu_count(),
                       "loadavg": os.getloadavg() if hasattr(os, "getloadavg") else None},
           "repeats": args.repeats, "numpy_reference": {}, "bsrflow": {}, "speedup": {}, "details": {}}
    print(f"{'grid':6s} {'cells':>6s} {'W':>3s} {'NumPy csups':>12s} {'compiled csups':>15s} {'speed-up':>9s} {'max rel diff':>12s}")
    for ppd, sc, sr in ((10, 400, 20), (40, 200, 4)):
        key = f"ppd{ppd}"
        r = bench(ppd, args.repeats, sc, sr)
        out["numpy_reference"][key] = r["numpy_csups"]
        out["bsrflow"][key] = r["compiled_csups"]
        out["speedup"][key] = r["speedup"]
        out["details"][key] = r
        print(f"{key:6s} {r['cells']:6d} {r['kernel_radius_cells']:3d} {r['numpy_csups']:12.3e} "
              f"{r['compiled_csups']:15.3e} {r['speedup']:9.1f} {r['max_relative_difference']:12.2e}")
    os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
    with open(args.json, "w") as fh:
        json.dump(out, fh, indent=2)
    print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
