"""What do the default checkpoints cost?  ``bsrflow run`` on the default config (what
``bsrflow init`` writes) with checkpoints off (``run.checkpoint_every = 0``) and on (the
default, every 0.1 s of simulated time on snapshot times), alternating, in one process (the
solver is compiled once, before the timings).

    python bench/check_checkpoint_cost.py [--repeats 7] [--dir out/checkpoint_cost]

Prints the time-loop wall time of every run (``RunOutcome.wall_time``, without compiling), the
median and the minimum of each setting, and the time of one ``write_checkpoint`` of the
default grid.  Also checks that both settings give the same step count and bit-for-bit the
same snapshots (the checkpoints add no event: exit code 1 otherwise).
"""

from __future__ import annotations

import os
import statistics
import time

import numpy as np

from _args import Parser, int_in, make_scratch_dir, scratch_dir


def main(argv=None) -> int:
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int_in(1), default=7, help="runs per setting (default 7)")
    ap.add_argument("--dir", type=scratch_dir, default=os.path.join("out", "checkpoint_cost"),
                    help="scratch directory, created (with its parents) if missing (default out/checkpoint_cost)")
    args = ap.parse_args(argv)
    make_scratch_dir(ap, args.dir)
    from bsrflow.io.checkpoint import Checkpoint, write_checkpoint
    from bsrflow.io.config import Config
    from bsrflow.io.netcdf import read_snapshots
    from bsrflow.io.runner import run_config

    on = Config.default()
    off = on.with_overrides({"run.checkpoint_every": 0.0})
    print(f"default config: {on.checkpoint_times().size} checkpoints every {on.checkpoint_interval():g} s; "
          f"{on.column_setup().grid().n_cells} cells")
    run_config(off, os.path.join(args.dir, "warm.nc"))                    # compile
    walls = {"off": [], "on": []}
    steps = {}
    for _ in range(args.repeats):
        for name, cfg in (("off", off), ("on", on)):
            o = run_config(cfg, os.path.join(args.dir, f"{name}.nc"))
            walls[name].append(o.wall_time)
            steps[name] = o.steps
            print(f"  checkpoints {name:3s}: {o.steps} steps, time loop {o.wall_time:.3f} s", flush=True)
    for name in walls:
        print(f"checkpoints {name:3s}: median {statistics.median(walls[name]):.3f} s, min {min(walls[name]):.3f} s")
    med = statistics.median(walls["on"]) - statistics.median(walls["off"])
    low = min(walls["on"]) - min(walls["off"])
    print(f"overhead: {med:+.3f} s of medians ({100 * med / statistics.median(walls['off']):+.1f}%), "
          f"{low:+.3f} s of minima ({100 * low / min(walls['off']):+.1f}%)")
    n = on.column_setup().grid().n_cells
    ck = Checkpoint(0.1, {"u": np.zeros(n), "rho": np.ones(n)}, np.ones(20), 1, 0, 0.0, 1, on.to_toml())
    ts = []
    for _ in range(30):
        t = time.perf_counter()
        write_checkpoint(os.path.join(args.dir, "x.ckpt"), ck)
        ts.append(time.perf_counter() - t)
    print(f"one write_checkpoint ({os.path.getsize(os.path.join(args.dir, 'x.ckpt'))} bytes, with fsync): "
          f"median {1e3 * statistics.median(ts):.2f} ms, min {1e3 * min(ts):.2f} ms")
    a, _ = read_snapshots(os.path.join(args.dir, "off.nc"))
    b, _ = read_snapshots(os.path.join(args.dir, "on.nc"))
    same = steps["on"] == steps["off"] and all(np.array_equal(a[k], b[k]) for k in a)
    print("same steps and snapshots bit for bit:", same)
    return 0 if same else 1


if __name__ == "__main__":
    raise SystemExit(main())
