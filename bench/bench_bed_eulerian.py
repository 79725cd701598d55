"""Cost of the vibrated bed's model on the Eulerian grid (bsrflow.numerics.bed_eulerian) per
cell-stage, in 1-D and 3-D, against the Lagrangian column's step, all measured in this run.

    python bench/bench_bed_eulerian.py [--json bench/results.json] [--lateral 4] [--cells-per-d 2]

Each grid, on one thread: the Γ = 3 bed (reference/liggghts_bed's) advanced from rest for
``--time`` seconds of vibration after a 20-ms warm-up that also compiles; the wall time per
step, per cell-stage (three right-hand sides per step) and the ratio of the 3-D grid's cost per
cell-stage to the column's (the horizontal axes' extra faces).  The Lagrangian column (200
cells, ``run_bed``'s loop) over the same simulated time gives the reference: the Eulerian
grids' wall time over its.

Then the threads (``--threads-lateral``, default 32: a 32 × 32 × 49 grid at 2 cells per d):
two copies of that bed stepped over the same ``--threads-repeats`` spans of
``--threads-time`` s (interleaved, span by span), one serially on one thread and one with the
right-hand side's parallel passes on two (whatever the grid's size against
``EulerianBed.PARALLEL_MIN_CELLS``); ns per cell-stage of each (the median over the spans), the
parallel efficiency t_serial / (2 t_parallel) (the median over the spans, and its range), the
threading layer, and whether the two states are equal bit for bit.
Writes the key ``bed_eulerian_step`` into the JSON file (merged with what is there).  Machine-
dependent: wall times of this machine, whatever else it is doing.
"""

from __future__ import annotations

import time

import numba
import numpy as np

from _args import Parser, int_in, merge_json, merge_target, positive_float, positive_int, repo_path
from bsrflow.numerics.bed_eulerian import EulerianBed
from bsrflow.numerics.bed_lagrangian import GranularBedColumn
from bsrflow.physics.granular_bed import BedSetup


def _time_eulerian(setup, dim, cells_per_d, lateral, span):
    bed = EulerianBed(setup, dim, cells_per_d, lateral, 0.05 if dim > 1 else 0.0)
    bed.apply_velocity_jump(setup.amplitude * setup.omega)
    bed.advance(0.0, 0.02)                               # warm-up (and compile)
    s0 = int(bed.counters[0])
    t0 = time.perf_counter()
    bed.advance(0.02, 0.02 + span)
    wall = time.perf_counter() - t0
    steps = int(bed.counters[0]) - s0
    cells = bed.q[0].size
    return {"dim": dim, "cells_per_d": cells_per_d, "lateral_cells": lateral, "grid_shape": list(bed.shape),
            "cells": cells, "steps": steps, "wall_s": wall, "us_per_step": 1e6 * wall / steps,
            "ns_per_cell_stage": 1e9 * wall / (steps * 3 * cells)}


def _time_threads(setup, cells_per_d, lateral, span, repeats):
    """The same 3-D bed stepped serially on one thread and in parallel on two (module docstring)."""
    n_threads = numba.get_num_threads()
    if n_threads < 2:
        return {"skipped": f"numba has {n_threads} thread(s) here"}
    beds = [EulerianBed(setup, 3, cells_per_d, lateral, 0.05) for _ in range(2)]
    beds[0].PARALLEL_MIN_CELLS = 1 << 62                      # serial on one thread
    beds[1].PARALLEL_MIN_CELLS = 0                            # parallel on two, whatever the grid's size
    walls = {1: [], 2: []}
    steps = {1: [], 2: []}
    try:
        for bed, threads in zip(beds, (1, 2)):
            numba.set_num_threads(threads)
            bed.apply_velocity_jump(setup.amplitude * setup.omega)
            bed.advance(0.0, 1e-5)                            # warm-up (and compile)
            if bed.parallel is not (threads == 2):
                raise RuntimeError("the thread test's beds did not take the serial / parallel paths")
        t = 1e-5
        for _ in range(repeats):                              # the two interleaved, span by span
            for bed, threads in zip(beds, (1, 2)):
                numba.set_num_threads(threads)
                s0 = int(bed.counters[0])
                t0 = time.perf_counter()
                bed.advance(t, t + span)
                walls[threads].append(time.perf_counter() - t0)
                steps[threads].append(int(bed.counters[0]) - s0)
            t += span
    finally:
        numba.set_num_threads(n_threads)
    cells = beds[0].q[0].size
    per = {k: [1e9 * w / (n * 3 * cells) for w, n in zip(walls[k], steps[k])] for k in (1, 2)}
    pairs = [a / (2.0 * b) for a, b in zip(per[1], per[2])]            # each span's efficiency
    return {"grid_shape": list(beds[0].shape), "cells": cells, "span_s": span, "repeats": repeats,
            "steps": steps[1], "wall_s_serial_1t": walls[1], "wall_s_parallel_2t": walls[2],
            "ns_per_cell_stage_serial_1t": float(np.median(per[1])),
            "ns_per_cell_stage_parallel_2t": float(np.median(per[2])),
            "parallel_efficiency_2t": float(np.median(pairs)), "parallel_efficiency_2t_range": [min(pairs), max(pairs)],
            "threading_layer": numba.threading_layer(),
            "bit_for_bit": bool(np.array_equal(beds[0].q, beds[1].q)) and steps[1] == steps[2]}


def _time_lagrangian(setup, span):
    col = GranularBedColumn(setup)
    col.apply_velocity_jump(setup.amplitude * setup.omega)
    col.advance(0.0, 0.02)
    s0 = col.steps
    t0 = time.perf_counter()
    col.advance(0.02, 0.02 + span)
    wall = time.perf_counter() - t0
    return {"cells": setup.n_cells, "steps": col.steps - s0, "wall_s": wall}


def main(argv=None):
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", type=merge_target, default=repo_path("bench/results.json"),
                    help="JSON file to merge the results into (default bench/results.json)")
    ap.add_argument("--cells-per-d", type=int_in(1, 64), default=2,
                    help="vertical cells per diameter, in [1, 64] (default 2)")
    ap.add_argument("--lateral", type=int_in(2, 256), default=4,
                    help="3-D: cells across the box, in [2, 256] (default 4)")
    ap.add_argument("--time", type=positive_float, default=0.02, help="simulated seconds timed (default 0.02)")
    ap.add_argument("--threads-lateral", type=int_in(2, 256), default=32,
                    help="the thread test's cells across the box, in [2, 256] (default 32)")
    ap.add_argument("--threads-time", type=positive_float, default=1e-4,
                    help="simulated seconds per timed span of the thread test (default 1e-4)")
    ap.add_argument("--threads-repeats", type=positive_int, default=5, help="timed spans (default 5)")
    args = ap.parse_args(argv)
    setup = BedSetup(gamma=3.0)
    n_threads = numba.get_num_threads()
    numba.set_num_threads(1)                 # the per-cell-stage comparison: one thread throughout
    try:
        lag = _time_lagrangian(setup, args.time)
        col = _time_eulerian(setup, 1, args.cells_per_d, 1, args.time)
        bed = _time_eulerian(setup, 3, args.cells_per_d, args.lateral, args.time)
    finally:
        numba.set_num_threads(n_threads)
    out = {"simulated_s": args.time, "lagrangian": lag, "eulerian_1d": col, "eulerian_3d": bed,
           "ratio_3d_to_1d_per_cell_stage": bed["ns_per_cell_stage"] / col["ns_per_cell_stage"],
           "ratio_1d_to_lagrangian_wall": col["wall_s"] / lag["wall_s"],
           "ratio_3d_to_lagrangian_wall": bed["wall_s"] / lag["wall_s"],
           "threads": _time_threads(setup, args.cells_per_d, args.threads_lateral, args.threads_time,
                                    args.threads_repeats),
           "note": "lagrangian, eulerian_1d and eulerian_3d on one thread; machine-dependent (this machine, this run)"}
    print(f"Lagrangian column ({lag['cells']} cells): {lag['wall_s']:.3f} s for {args.time:g} s ({lag['steps']} steps)")
    for name, r in (("Eulerian 1-D", col), ("Eulerian 3-D", bed)):
        print(f"{name} {tuple(r['grid_shape'])}: {r['wall_s']:.3f} s, {r['steps']} steps, {r['us_per_step']:.1f} us per "
              f"step, {r['ns_per_cell_stage']:.0f} ns per cell-stage")
    print(f"3-D / 1-D per cell-stage: {out['ratio_3d_to_1d_per_cell_stage']:.2f}; wall against the Lagrangian column: "
          f"1-D {out['ratio_1d_to_lagrangian_wall']:.1f}x, 3-D {out['ratio_3d_to_lagrangian_wall']:.1f}x")
    th = out["threads"]
    if "skipped" in th:
        print(f"threads: skipped ({th['skipped']})")
    else:
        lo, hi = th["parallel_efficiency_2t_range"]
        print(f"Eulerian 3-D {tuple(th['grid_shape'])}: {th['ns_per_cell_stage_serial_1t']:.0f} ns per cell-stage serial "
              f"(1 thread), {th['ns_per_cell_stage_parallel_2t']:.0f} parallel (2 threads, {th['threading_layer']}): "
              f"efficiency {th['parallel_efficiency_2t']:.2f} ({lo:.2f}-{hi:.2f}), bit for bit {th['bit_for_bit']}")
    merge_json(args.json, "bed_eulerian_step", out)


if __name__ == "__main__":
    main()
