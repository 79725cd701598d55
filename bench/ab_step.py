"""Whole-step A/B against an earlier commit, in one process (how the "What changed
today" gains of docs/performance.md were measured).

    python bench/ab_step.py --ref 131c662 [--ppd 40] [--scheme seed] [--repeats 15] [--steps 50]

The compiled core (``bsrflow.numerics.compiled``) and the fast integral
(``bsrflow.numerics.fast_integral``) of ``--ref`` are read with ``git show`` into a temporary
directory and compiled beside the working tree's.  On the five tapped-column states of
``bench/bench_step.py`` both cores take ``--steps`` fixed steps from the same state, their
repeats interleaved; the time of each is the minimum over ``--repeats`` (the least disturbed
by other load).  Prints ns per grid cell-stage of both, their ratio (old/new: > 1 means the
working tree is faster) and whether the states after the steps are the same bit for bit.
Needs a git checkout.  One core.
"""

from __future__ import annotations

import inspect
import os
import subprocess
import sys
import tempfile
import time

import numba
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import bench_step  # noqa: E402
from _args import Parser, positive_int  # noqa: E402
from _git_ref import load_module_at  # noqa: E402

from bsrflow.numerics.solver import Scheme  # noqa: E402
from bsrflow.physics.model import jit_user  # noqa: E402

MODULES = ("compiled", "fast_integral")


def _load_ref(ref, tmp):
    """The modules of ``ref`` as standalone modules (both import only numpy, numba, llvmlite)."""
    return {name: load_module_at(ref, name, tmp) for name in MODULES}


def main(argv=None) -> int:
    ap = Parser(description=" ".join(__doc__.split("\n\n")[0].split()))
    ap.add_argument("--ref", required=True, help="the earlier commit (any git revision)")
    ap.add_argument("--ppd", type=positive_int, default=40, help="grid points per diameter (default 40)")
    ap.add_argument("--scheme", default="seed", choices=("seed", "accurate"), help="scheme preset (default seed)")
    ap.add_argument("--repeats", type=positive_int, default=15, help="timed repeats per state (default 15)")
    ap.add_argument("--steps", type=positive_int, default=50, help="steps per repeat (default 50)")
    args = ap.parse_args(argv)
    numba.set_num_threads(1)
    try:
        tmp = tempfile.mkdtemp(prefix="bsrflow_ab_")
        ref = _load_ref(args.ref, tmp)
    except subprocess.CalledProcessError as e:
        print(f"ab_step: cannot read --ref {args.ref!r} from git: {e.stderr.strip()}", file=sys.stderr)
        return 2
    s, states = bench_step.column_states(args.ppd)
    tot = {"old": 0.0, "new": 0.0}
    all_same = True
    for t, u0, r0, dt in states:
        sims = {}
        for name in ("old", "new"):
            sim = bench_step._sim(s, Scheme.preset(args.scheme, dt=dt))
            if name == "old":
                m = sim.model
                make = ref["compiled"].make_core
                args_ = [ref["fast_integral"].walton_braun_integral, jit_user(m.external), m.motion.fn,
                         jit_user(m.boundary_values)]
                if len(inspect.signature(make).parameters) > 4:     # the interaction's wave speed
                    args_.append(sim._wave_speed_fn)
                else:                           # before it: the core took κ in its place
                    sim.wave_speed_params = float(sim.kappa)
                sim.core = make(*args_)
            sim.advance(u0.copy(), r0.copy(), t, t + dt)          # compile
            sims[name] = sim
        best = {"old": np.inf, "new": np.inf}
        res = {}
        for _ in range(args.repeats):
            for name, sim in sims.items():
                uu, rr = u0.copy(), r0.copy()
                w = time.perf_counter()
                sim.advance(uu, rr, t, t + args.steps * dt)
                best[name] = min(best[name], time.perf_counter() - w)
                res[name] = (uu, rr)
        same = all(np.array_equal(res["old"][k], res["new"][k]) for k in (0, 1))
        all_same &= same
        n = sims["new"].grid.n_cells * sims["new"].tableau.stages * args.steps
        print(f"t = {t:.2f} s: {args.ref} {best['old'] / n * 1e9:.3f}, working tree {best['new'] / n * 1e9:.3f} "
              f"ns per grid cell-stage, ratio {best['old'] / best['new']:.3f}, bit for bit {same}", flush=True)
        for k in tot:
            tot[k] += best[k]
    print(f"total ratio {args.ref}/working tree {tot['old'] / tot['new']:.3f} (ppd {args.ppd}, {args.scheme}); "
          f"bit for bit: {all_same}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
