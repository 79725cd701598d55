"""Time order of a preset on the smooth problem, refined further than ``bsrflow verify`` does.

    python bench/check_time_order.py [--scheme accurate] [--stepper NAME] [--steps 64,128,256,512]

The case ``smooth_time_accurate`` of ``bsrflow verify`` (the preset's semi-discrete system on
256 cells, refined in Δt against an RK4 solution with 8× the finest number of steps) at the
given numbers of steps, with the preset's stepper or ``--stepper`` (e.g. ``kutta3``, the
previous preset's).  Prints the relative errors, the pairwise observed orders and the
least-squares order.  The reference's accumulated round-off is about 1e-12 (two references,
with 8× 2048 and 8× 4096 steps, differ by that much): once the errors come within a few
hundred times of it (Kutta's RK3 above about 1024 steps, the fourth-order steppers above about
256), the finest pairwise orders measure round-off, not the scheme: with the default steps the
last pair of a fourth-order stepper (256 → 512, error about 4e-12) is already affected.
"""

from __future__ import annotations

import os
import sys

import numpy as np

from bsrflow.analysis.verify import case_smooth_time
from bsrflow.numerics.solver import Scheme
from bsrflow.numerics.steppers import STEPPERS

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _args import Parser, list_of, positive_int  # noqa: E402


def main(argv=None) -> int:
    ap = Parser(description=__doc__.splitlines()[0])
    ap.add_argument("--scheme", default="accurate", choices=("seed", "accurate"), help="scheme preset (default accurate)")
    ap.add_argument("--stepper", default=None, choices=sorted(STEPPERS),
                    help="Runge-Kutta stepper (default: the preset's)")
    ap.add_argument("--steps", type=list_of(positive_int), default="64,128,256,512",
                    help="comma-separated numbers of steps, increasing (default 64,128,256,512)")
    args = ap.parse_args(argv)
    steps = tuple(args.steps)
    if len(steps) < 2 or list(steps) != sorted(set(steps)):
        ap.error(f"--steps = {args.steps}: need at least two increasing integers >= 1")
    p = Scheme.preset(args.scheme)
    stepper = args.stepper or p.stepper
    kw = dict(stepper=stepper, filter=False, hyperdiffusion=p.hyperdiffusion,
              selective_filter=p.selective_filter, sensor_dissipation=p.sensor_dissipation,
              positivity=p.positivity, name=args.scheme)
    if p.filter:
        kw["filter"] = True
    case = case_smooth_time(kw, steps=steps, name=f"smooth_time_{args.scheme}")
    e = np.array(case["errors"])
    pairwise = np.log2(e[:-1] / e[1:]) / np.log2(np.array(steps[1:]) / np.array(steps[:-1]))
    print(f"{args.scheme} with {stepper}, steps {', '.join(map(str, steps))}")
    print("  errors   " + " ".join(f"{v:.4e}" for v in e))
    print("  pairwise " + " ".join(f"{v:.4f}" for v in pairwise))
    print(f"  least-squares order {case['observed_order']:.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
