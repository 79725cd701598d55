"""The vibrated bed's step (``bsrflow.numerics.bed_lagrangian``) A/B against an earlier commit, in
one process: how the 2026-12-04 vectorisation of ``bed_step`` was measured.

    python bench/ab_bed_step.py --ref 6a61db0 [--repeats 5] [--cells 200] [--json PATH]

The module of ``--ref`` is read with ``git show`` into a temporary directory and compiled beside
the working tree's; ``run_bed`` answers issue #19's question (Γ = 3, 3 + 5 cycles from the bed at
rest) with each module's ``bed_advance``, the repeats interleaved, the time of each the minimum
over ``--repeats`` (the least disturbed by other load).  Prints both times, ns per cell-step,
their ratio (old/new: > 1 means the working tree is faster) and whether the two runs' series
(mass centre, top, θ, floor force, internal energy) and step counts are the same bit for bit.
Needs a git checkout.  One core.  Machine-dependent.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from _args import Parser, int_in, merge_json, merge_target, positive_int  # noqa: E402
from _git_ref import load_module_at  # noqa: E402

from bsrflow.numerics import bed_lagrangian  # noqa: E402
from bsrflow.physics.granular_bed import BedSetup  # noqa: E402

SERIES = ("mass_centre", "top", "theta_mean", "floor_force", "internal_energy")


def _run(advance, setup):
    """``run_bed(setup)`` stepping with ``advance``; (result, wall time [s])."""
    saved = bed_lagrangian.bed_advance
    bed_lagrangian.bed_advance = advance
    try:
        t0 = time.perf_counter()
        res = bed_lagrangian.run_bed(setup)
        return res, time.perf_counter() - t0
    finally:
        bed_lagrangian.bed_advance = saved


def _called_as_now(advance):
    """``advance`` taking the working tree's arguments: a ``bed_advance`` from before the floor's
    own restitution (2026-12-04) has neither ``e_w`` nor ``wall_mode`` (the two arguments after
    ``e_d``), one from before the floor loss's closure option (2026-12-06) no ``wall_mode``; the
    missing ones are dropped (the A/B's bed gives neither: e_w is then e_d and the closure the
    kinetic pressure's, which is what those versions ran)."""
    names = advance.py_func.__code__.co_varnames[:advance.py_func.__code__.co_argcount]
    if "wall_mode" in names:
        return advance
    drop = 1 if "e_w" in names else 2

    def older(*args):
        return advance(*args[:-1 - drop], args[-1])
    return older


def main(argv=None) -> int:
    ap = Parser(description=" ".join(__doc__.split("\n\n")[0].split()))
    ap.add_argument("--ref", required=True, help="the git commit to compare with (e.g. 6a61db0)")
    ap.add_argument("--repeats", type=positive_int, default=5, help="interleaved runs of each module; the minimum time counts (default 5)")
    ap.add_argument("--cells", type=int_in(4), default=None,
                    help="cells, in [4, inf) (default: the bed's default, 200)")
    ap.add_argument("--json", type=merge_target, default=None, help="merge the result into this JSON file")
    args = ap.parse_args(argv)
    setup = BedSetup(gamma=3.0, cycles=8)
    if args.cells is not None:
        setup = setup.with_(n_cells=args.cells)
    with tempfile.TemporaryDirectory(prefix="bsrflow_ab_bed_") as tmp:
        try:
            ref = load_module_at(args.ref, "bed_lagrangian", tmp)
        except subprocess.CalledProcessError as exc:
            print(f"ab_bed_step: --ref {args.ref}: git show failed: {exc.stderr.strip()}", file=sys.stderr)
            return 2
        advances = {"ref": _called_as_now(ref.bed_advance), "new": bed_lagrangian.bed_advance}
        small = setup.with_(cycles=1, n_cells=16)
        for adv in advances.values():                     # compile both
            _run(adv, small)
        times = {k: [] for k in advances}
        results = {}
        for _ in range(args.repeats):
            for k, adv in advances.items():
                results[k], w = _run(adv, setup)
                times[k].append(w)
    same = results["ref"].steps == results["new"].steps and all(
        np.array_equal(getattr(results["ref"], s), getattr(results["new"], s)) for s in SERIES)
    best = {k: min(v) for k, v in times.items()}
    cell_steps = results["new"].steps * setup.n_cells
    out = {"ref": args.ref, "cells": setup.n_cells, "steps": results["new"].steps,
           "ref_s": best["ref"], "new_s": best["new"], "ref_runs_s": times["ref"], "new_runs_s": times["new"],
           "ref_ns_per_cell_step": best["ref"] / cell_steps * 1e9,
           "new_ns_per_cell_step": best["new"] / cell_steps * 1e9,
           "ratio_ref_over_new": best["ref"] / best["new"], "bit_for_bit": bool(same)}
    print(f"bed, Γ = 3, 3 + 5 cycles, {setup.n_cells} cells, {results['new'].steps} steps "
          f"(minimum of {args.repeats}):")
    print(f"  {args.ref}: {best['ref']:.3f} s ({out['ref_ns_per_cell_step']:.1f} ns per cell-step)")
    print(f"  working tree: {best['new']:.3f} s ({out['new_ns_per_cell_step']:.1f} ns per cell-step)")
    print(f"  ratio {out['ratio_ref_over_new']:.2f} (> 1: the working tree is faster); "
          f"series and steps the same bit for bit: {same}")
    if args.json:
        merge_json(args.json, "ab_bed_step", out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
