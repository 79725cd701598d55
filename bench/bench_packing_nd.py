"""Speed of the 3-D packing step (issue #19): ns per cell-stage of ``packing_nd`` at 64³ and 128³
on 1 and 2 threads, the parallel efficiency, and the modelled memory traffic per cell against a
bandwidth measured on this machine in the same run.

    python bench/bench_packing_nd.py [--json bench/results.json] [--sizes 64 128] [--steps 3] [--repeats 5]

The state: a 3-D bed of the LIGGGHTS spheres' law (PackingLawND.for_spheres) filling the lower
half of a periodic box with a small random density and velocity perturbation (every cell does
the full work: material everywhere below the top, vacuum above), advanced ``--steps`` SSP-RK3
steps (3 right-hand sides each) after one warm-up step.  The 1- and 2-thread timings are
interleaved (``--repeats`` pairs, one bed per thread count), so that a change of the machine's
load during the run falls on both alike: ns per cell-stage is the median over the repeats, the
parallel efficiency the median over the pairs of t1 / (2 t2), with its smallest and largest value.
Bandwidth: ``np.copyto`` of a 256 MiB array (read + write counted), the median of five.
Traffic model of one stage per cell: the right-hand side reads q (5 doubles) on each of the
3 axis passes and writes dq once and updates it twice (read + write), the stage update reads
3-4 and writes 2 arrays of 5 doubles: about (15 + 25 + 30) × 8 = 560 bytes.
Machine-dependent figures; writes the key ``packing_nd_step`` into the JSON file.
"""

from __future__ import annotations

import os
import time

import numba
import numpy as np

from _args import Parser, int_in, merge_json, merge_target, repo_path
from bsrflow.numerics.grid_nd import GridND
from bsrflow.numerics.packing_nd import EulerianPackingND, PackingLawND
from bsrflow.physics.motion import HalfSineTaps

BYTES_PER_CELL_STAGE = 560


def bandwidth():
    a = np.ones(32 * 2 ** 20)
    b = np.empty_like(a)
    times = []
    for _ in range(5):
        t0 = time.perf_counter()
        np.copyto(b, a)
        times.append(time.perf_counter() - t0)
    return 2 * a.nbytes / float(np.median(times))


def make(n):
    law = PackingLawND.for_spheres(5e4, 0.9, 0.005, 1200.0, 0.636, 5.39)
    dx = 0.005 / 4
    grid = GridND((n, n, n), dx, bc_lower="floor", bc_upper="vacuum", bc_horizontal="periodic")
    rng = np.random.default_rng(1)
    rho0 = np.zeros((n, n, n))
    rho0[..., : n // 2] = law.close_packing_density * rng.uniform(0.98, 1.01, (n, n, n // 2))
    disc = EulerianPackingND(law, grid, HalfSineTaps(0.0005, 20.0, start=10.0), 9.81, rho0)
    disc.PARALLEL_MIN_CELLS = 0                   # measure the parallel code at every size
    return disc


def time_pairs(n, steps, repeats, thread_counts):
    """Interleaved timings (module docstring): {threads: [ns per cell-stage per repeat]}."""
    discs, times = {}, {}
    for threads in thread_counts:
        numba.set_num_threads(threads)
        disc = make(n)
        dt_guess = disc.cfl * disc.grid.dx / disc.c_bound
        discs[threads] = [disc, disc.advance(0.0, dt_guess * 0.999), dt_guess]    # compile + warm-up: one step
        times[threads] = []
    for _ in range(repeats):
        for threads in thread_counts:
            numba.set_num_threads(threads)
            disc, t, dt_guess = discs[threads]
            s0 = disc.steps
            t0 = time.perf_counter()
            t = disc.advance(t, t + steps * dt_guess * 0.999)
            wall = time.perf_counter() - t0
            discs[threads][1] = t
            times[threads].append(wall / ((disc.steps - s0) * 3 * n ** 3) * 1e9)
    return times


def main(argv=None):
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", type=merge_target, default=repo_path("bench/results.json"),
                    help="JSON file to merge the results into (default bench/results.json)")
    ap.add_argument("--sizes", type=int_in(32), nargs="+", default=[64, 128],
                    help="grid sizes n, in [32, inf) (the bed fills the lower half; a smaller box lets the "
                         "expanding top reach the domain's top within the timed steps)")
    ap.add_argument("--steps", type=int_in(1), default=3, help="SSP-RK3 steps timed per repeat, after one warm-up step (default 3)")
    ap.add_argument("--repeats", type=int_in(1), default=5, help="interleaved 1- and 2-thread pairs; medians over them (default 5)")
    args = ap.parse_args(argv)
    folder = os.path.dirname(os.path.abspath(args.json))
    if not os.path.isdir(folder):
        ap.error(f"--json {args.json}: folder {folder} does not exist")
    n_max = numba.config.NUMBA_NUM_THREADS
    bw = bandwidth()
    print(f"bandwidth (np.copyto, read + write): {bw / 1e9:.2f} GB/s; modelled traffic {BYTES_PER_CELL_STAGE} B "
          f"per cell-stage -> bound {BYTES_PER_CELL_STAGE / bw * 1e9:.2f} ns per cell-stage")
    out = {"bandwidth_GB_s": bw / 1e9, "bytes_per_cell_stage_model": BYTES_PER_CELL_STAGE, "sizes": {}}
    threads_used = [k for k in (1, 2) if k <= n_max]
    for n in args.sizes:
        times = time_pairs(n, args.steps, args.repeats, threads_used)
        row = {"repeats": args.repeats}
        for threads in threads_used:
            ns = float(np.median(times[threads]))
            row[f"ns_per_cell_stage_{threads}t"] = ns
            print(f"{n}^3, {threads} thread(s): {ns:.1f} ns per cell-stage (median of {args.repeats}; "
                  f"{min(times[threads]):.1f}-{max(times[threads]):.1f}); {BYTES_PER_CELL_STAGE / ns:.2f} GB/s "
                  "modelled traffic")
        if 2 in threads_used:
            eff = [a / (2.0 * b) for a, b in zip(times[1], times[2])]
            row["parallel_efficiency_2t"] = float(np.median(eff))
            row["parallel_efficiency_2t_range"] = [float(min(eff)), float(max(eff))]
            print(f"{n}^3: 2-thread parallel efficiency {row['parallel_efficiency_2t']:.2f} (median of "
                  f"{len(eff)} interleaved pairs; {min(eff):.2f}-{max(eff):.2f})")
        out["sizes"][str(n)] = row
    numba.set_num_threads(n_max)
    merge_json(args.json, "packing_nd_step", out)


if __name__ == "__main__":
    main()
