"""Cost of the vibrated bed's question (issue #19): the five-cycle trajectory at Γ = 3 after the
three start-up cycles, the continuum (:mod:`bsrflow.physics.granular_bed`, the horizontally
uniform bed) against LIGGGHTS on the same bed, both measured in this run on this machine.

    python bench/bench_bed.py [--json bench/results.json] [--no-liggghts]

The continuum: `run_bed` for 3 + 5 cycles from the bed at rest, the median of three
runs.  LIGGGHTS (when `liggghts` is on the PATH; Debian package `liggghts`):
``reference/liggghts_bed/run_liggghts.py --root TMP --settle`` then ``--gamma 3 --measured 5``
in a temporary folder (the committed data are left alone); the vibration run's wall time is
compared (the settling, a one-off preparation of the DEM bed, is reported beside it).  Writes
the key ``bed_gamma3_five_cycles`` into the JSON file (merged with what is there).
Machine-dependent: wall times of this machine, serial, whatever else it is doing.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from _args import Parser, merge_json, merge_target, repo_path
from bsrflow.numerics.bed_lagrangian import run_bed
from bsrflow.physics.granular_bed import BedSetup

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None):
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", type=merge_target, default=repo_path("bench/results.json"),
                    help="JSON file to merge the results into (default bench/results.json)")
    ap.add_argument("--no-liggghts", action="store_true", help="time the continuum only")
    args = ap.parse_args(argv)
    folder = os.path.dirname(os.path.abspath(args.json))
    if not os.path.isdir(folder):
        ap.error(f"--json {args.json}: folder {folder} does not exist")
    setup = BedSetup(gamma=3.0, cycles=8)
    run_bed(setup.with_(cycles=1, n_cells=16))                      # compile
    walls = []
    for _ in range(3):
        t0 = time.perf_counter()
        r = run_bed(setup)
        walls.append(time.perf_counter() - t0)
    cont = float(np.median(walls))
    out = {"continuum_s": cont, "continuum_runs_s": walls, "continuum_steps": r.steps,
           "continuum_cells": setup.n_cells, "liggghts_s": None, "liggghts_settle_s": None, "ratio": None}
    print(f"continuum ({setup.n_cells} cells, 3 + 5 cycles from the bed at rest): {cont:.2f} s (median of 3: "
          f"{', '.join(f'{w:.2f}' for w in walls)})")
    exe = shutil.which("liggghts")
    if args.no_liggghts or exe is None:
        print("LIGGGHTS: not run (" + ("--no-liggghts" if args.no_liggghts else "no liggghts on the PATH") + ")")
    else:
        script = ROOT / "reference" / "liggghts_bed" / "run_liggghts.py"
        with tempfile.TemporaryDirectory(prefix="bsrflow_bench_bed_") as tmp:
            t0 = time.perf_counter()
            subprocess.run([sys.executable, str(script), "--root", tmp, "--settle"], check=True,
                           stdout=subprocess.DEVNULL)
            settle = time.perf_counter() - t0
            t0 = time.perf_counter()
            subprocess.run([sys.executable, str(script), "--root", tmp, "--gamma", "3", "--measured", "5"],
                           check=True, stdout=subprocess.DEVNULL)
            vib = time.perf_counter() - t0
            summ = json.loads(next(Path(tmp, "results").glob("gamma_3.00_*/summary.json")).read_text())
        out.update(liggghts_s=vib, liggghts_settle_s=settle, liggghts_loop_s=summ.get("loop_time_s"),
                   ratio=vib / cont)
        print(f"LIGGGHTS (serial): settling {settle:.1f} s, vibration (3 + 5 cycles) {vib:.1f} s; "
              f"continuum is {vib / cont:.1f}x cheaper")
    merge_json(args.json, "bed_gamma3_five_cycles", out)


if __name__ == "__main__":
    main()
