"""Tracers of the vibrated bed's Eulerian column against its material lines (issue #19).

    python bench/check_eulerian_bed_tracers.py [--cells-per-d 2,4,8] [--cycles 3] [--json PATH]

The reference bed (:class:`bsrflow.physics.granular_bed.BedSetup` defaults, Γ = 3, 20 Hz) as a
column of :class:`bsrflow.numerics.bed_eulerian.EulerianBed`, settled for 10 ms; three tracers
start at a quarter, half and three quarters of the settled bed's height (its 99 % mass height)
and the floor starts to move.  In a column the material lines are the mass coordinates: the
fraction of the bed's mass below a tracer should not change.  Printed per resolution and per
cycle: the largest change of that fraction so far [fraction of the bed's mass], for each tracer.
The first cycle holds the take-off and the flight that follows the floor's jump (the bed's
first landing comes in the second cycle, near 1.6 cycles).  Each line also gives the wall time.
"""

from __future__ import annotations

import time

import numpy as np

from _args import Parser, int_in, list_of, output_json, write_json
from bsrflow.numerics.bed_eulerian import RHO, EulerianBed
from bsrflow.physics.granular_bed import BedSetup

START_FRACTIONS = (0.25, 0.5, 0.75)
SAVE = 5e-4
"""Interval between the measurements [s]."""


def mass_below(bed: EulerianBed, z) -> np.ndarray:
    """The fraction of the column's mass below the heights z [m] (linear inside a cell)."""
    col = bed.q[RHO].sum(axis=(0, 1))
    cum = np.concatenate([[0.0], np.cumsum(col)]) / col.sum()
    return np.interp(z, np.arange(len(col) + 1) * bed.dx[2], cum)


def material_line_drift(cells_per_d: int, cycles: int) -> dict:
    """Run the column at ``cells_per_d`` for ``cycles`` cycles; the largest change so far of each
    tracer's mass fraction at the end of every cycle (module docstring)."""
    s = BedSetup(gamma=3.0, cycles=cycles, settle=0.01)
    wall = time.perf_counter()
    bed = EulerianBed(s, dim=1, cells_per_d=cells_per_d)
    bed.settle()
    z0 = np.array(START_FRACTIONS) * bed.top()
    bed.set_tracers(z0[:, None])
    f0 = mass_below(bed, z0)
    bed.apply_velocity_jump(s.amplitude * s.omega)
    per_cycle = int(round(1.0 / (s.frequency * SAVE)))
    worst = np.zeros(len(z0))
    rows = []
    for k in range(1, cycles * per_cycle + 1):
        bed.advance((k - 1) * SAVE, k * SAVE)
        worst = np.maximum(worst, np.abs(mass_below(bed, bed.tracer_positions()[:, 0]) - f0))
        if k % per_cycle == 0:
            rows.append(worst.tolist())
    return {"cells_per_d": cells_per_d, "start_heights_d": (z0 / s.diameter).tolist(),
            "largest_drift_by_cycle": rows, "wall_s": time.perf_counter() - wall}


def main(argv=None) -> int:
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cells-per-d", type=list_of(int_in(1, 64)), default=[2, 4, 8],
                    help="resolutions, cells per diameter (default 2,4,8; at most 64)")
    ap.add_argument("--cycles", type=int_in(1, 50), default=3, help="cycles to run (default 3; at most 50)")
    ap.add_argument("--json", type=output_json, help="also write the results here")
    args = ap.parse_args(argv)
    print("cells/d | largest change of the mass fraction below each tracer (started at 1/4, 1/2, 3/4 of the "
          "bed's height), after cycle 1 / 2 / ... | wall [s]")
    out = []
    for c in args.cells_per_d:
        r = material_line_drift(c, args.cycles)
        out.append(r)
        cyc = " / ".join("[" + ", ".join(f"{v:.2e}" for v in row) + "]" for row in r["largest_drift_by_cycle"])
        print(f"{c:7d} | {cyc} | {r['wall_s']:.0f}", flush=True)
    if args.json:
        write_json(args.json, {"gamma": 3.0, "cases": out})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
