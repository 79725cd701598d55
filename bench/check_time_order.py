"""Time order of a preset on the smooth problem, refined further than ``bsrflow verify`` does.

    python bench/check_time_order.py [--scheme accurate] [--steps 128,256,512,1024]

The case ``smooth_time_accurate`` of ``bsrflow verify`` (the preset's semi-discrete system on
256 cells, refined in Δt against an RK4 solution with 8× the finest number of steps) at the
given numbers of steps.  Prints the relative errors, the pairwise observed orders and the
least-squares order.  Above about 1024 steps the errors come within a few per cent of the
round-off of the reference (two references, with 8× 2048 and 8× 4096 steps, differ by about
1e-12), so the finest pairwise orders there measure round-off, not the scheme.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from bsrflow.analysis.verify import case_smooth_time
from bsrflow.numerics.solver import Scheme


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scheme", default="accurate", help="scheme preset (default accurate)")
    ap.add_argument("--steps", default="128,256,512,1024",
                    help="comma-separated numbers of steps, increasing (default 128,256,512,1024)")
    args = ap.parse_args(argv)
    try:
        steps = tuple(int(v) for v in args.steps.split(","))
    except ValueError:
        ap.error(f"--steps = {args.steps!r} is not a comma-separated list of integers")
    if len(steps) < 2 or min(steps) < 1 or list(steps) != sorted(set(steps)):
        ap.error(f"--steps = {args.steps!r}: need at least two increasing integers >= 1")
    p = Scheme.preset(args.scheme)
    kw = dict(stepper=p.stepper, filter=False, hyperdiffusion=p.hyperdiffusion,
              selective_filter=p.selective_filter, sensor_dissipation=p.sensor_dissipation,
              positivity=p.positivity, name=args.scheme)
    if p.filter:
        kw["filter"] = True
    case = case_smooth_time(kw, steps=steps, name=f"smooth_time_{args.scheme}")
    e = np.array(case["errors"])
    pairwise = np.log2(e[:-1] / e[1:]) / np.log2(np.array(steps[1:]) / np.array(steps[:-1]))
    print(f"{args.scheme}, steps {', '.join(map(str, steps))}")
    print("  errors   " + " ".join(f"{v:.4e}" for v in e))
    print("  pairwise " + " ".join(f"{v:.4f}" for v in pairwise))
    print(f"  least-squares order {case['observed_order']:.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
