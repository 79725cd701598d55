"""What a resolved 3-D continuum of the vibrated bed would cost for issue #19's question.

    python bench/estimate_bed_3d_cost.py [--results docs/results/make_bench_2026-12-03.json]

The question: the LIGGGHTS bed (2000 spheres of d = 5 mm in a 13 d x 13 d periodic box, about
10 d deep) vibrated at f = 20 Hz, Γ = 3, for 3 start-up + 5 cycles (0.4 s).  The estimate takes
the n-D packing step's measured time per cell-stage (the ``packing_nd_step`` entry of a
``make bench`` JSON, 2 threads at 64³) and counts the cell-stages of the grid
:class:`bsrflow.physics.packing_bed.PackingBed` builds for that bed (its default domain: the bed
plus the energy bound's flight) at its default CFL number, three stages per step, the time step
set by the packing's contact wave speed (the bound every step of the dry packing obeys; a
granular temperature would add fields and transport limits, so this is a lower bound).  It
prints the estimate beside the LIGGGHTS time of the same question from the same JSON
(``bed_gamma3_five_cycles``), for 2 and 4 cells per diameter and stiffness factors 1, 0.1 and
0.01 (the reduced-stiffness option).  Nothing is run; machine-dependent through the JSON.
"""

from __future__ import annotations

import json
import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))

from bsrflow.physics.granular_bed import BedSetup  # noqa: E402
from bsrflow.physics.packing_bed import PackingBed  # noqa: E402

from _args import Parser, repo_path  # noqa: E402

CYCLES = 8          # 3 start-up + 5 compared


def main(argv=None) -> int:
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--results", default=repo_path("docs/results/make_bench_2026-12-03.json"),
                    help="a make-bench JSON with packing_nd_step and bed_gamma3_five_cycles")
    args = ap.parse_args(argv)
    try:
        data = json.load(open(args.results))
        ns = float(data["packing_nd_step"]["sizes"]["64"]["ns_per_cell_stage_2t"])
        dem_s = float(data["bed_gamma3_five_cycles"]["liggghts_s"])
        cont_s = float(data["bed_gamma3_five_cycles"]["continuum_s"])
    except (OSError, ValueError, KeyError, TypeError) as exc:
        ap.error(f"--results {args.results}: no packing_nd_step / bed_gamma3_five_cycles entries there "
                 f"({type(exc).__name__}: {exc})")
    print(f"measured ({args.results}): n-D packing step {ns:.1f} ns per cell-stage (2 threads, 64^3); "
          f"LIGGGHTS {dem_s:.1f} s and the horizontally uniform continuum {cont_s:.2f} s for the question")
    print("| cells per d | grid | stiffness factor | time steps | cell-stages | estimate [s] | against LIGGGHTS |")
    print("|---|---|---|---|---|---|---|")
    ref = BedSetup()                        # the LIGGGHTS bed: its box side and rest height
    for cpd in (2, 4):
        for factor in (1.0, 0.1, 0.01):
            bed = PackingBed(dim=3, box_width=ref.side, bed_height=ref.rest_height, cells_per_diameter=cpd, gamma=3.0,
                             t_end=CYCLES / 20.0, settle_time=0.0, stiffness_factor=factor)
            grid = bed.grid()
            cells = math.prod(grid.shape)
            c = bed.law().wave_speed()
            dt = (0.4 / 3) * bed.dx / c
            steps = bed.t_end / dt
            stages = 3 * cells * steps
            est = stages * ns * 1e-9
            print(f"| {cpd} | {'x'.join(map(str, grid.shape))} | {factor:g} | {steps:.3g} | {stages:.3g} | "
                  f"{est:.0f} | {est / dem_s:.2g}x its time |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
