"""Tracers of the n-D packing bed against the bed's own material lines (issue #19).

    python bench/check_bed_tracers.py [--cells-per-diameter 2,4,8] [--json PATH]

A 2-D bed with a flat top (horizontally uniform, so its material lines are its mass coordinates:
the height below which a fixed fraction of the column's mass lies, as the 1-D column's tracers),
5 mm spheres, 3 d deep, settled for 0.05 s and then vibrated at Γ = 3, 20 Hz until 0.12 s
(launch, flight, landing).  Four tracers start at 0.5, 1.5, 2.5 and 2.9 d; they are moved by
the scheme (the interpolated velocity, the fields' SSP-RK3 stages).  Printed per resolution:
the largest distance [d] over the saves between each tracer and the mass coordinate it started
on, and the largest horizontal drift (0 exactly: the bed is uniform in x).  The top tracer sits in
the bed's top cell, where the scheme's numerical diffusion smears the free surface; both
measures are first order there.
"""

from __future__ import annotations

import json
import time

import numpy as np

from _args import Parser, list_of, output_json, positive_int
from bsrflow.numerics.packing_nd import run_packing_nd
from bsrflow.numerics.solver import save_schedule
from bsrflow.physics.packing_bed import PackingBed

START_HEIGHTS_D = (0.5, 1.5, 2.5, 2.9)


def material_line_errors(cells_per_diameter: int) -> dict:
    """Run the bed at ``cells_per_diameter`` and measure its tracers (module docstring)."""
    bed = PackingBed(dim=2, box_width=0.01, bed_height=0.015, cells_per_diameter=cells_per_diameter,
                     settle_time=0.05, t_end=0.12, save_every=0.005, surface_perturbation=0.0, gamma=3.0)
    d = bed.diameter
    zs = np.array(START_HEIGHTS_D) * d
    disc = bed.discretisation(np.stack([np.full(zs.size, 0.003), zs], axis=1))
    g = disc.grid
    edges = np.arange(g.shape[-1] + 1) * g.dx
    col0 = bed.initial_density(g)[0]
    cum0 = np.concatenate([[0.0], np.cumsum(col0)])
    frac = np.interp(zs, edges, cum0 / cum0[-1])
    positions = []
    wall = time.perf_counter()
    ts, us, rs, _ = run_packing_nd(disc, bed.t_end, save_schedule(0.0, bed.t_end, bed.save_every),
                                   observers=[lambda t, u, rho: positions.append(disc.tracer_positions())])
    wall = time.perf_counter() - wall
    positions = np.array(positions)
    err = np.zeros(zs.size)
    for n in range(ts.size):
        c = np.concatenate([[0.0], np.cumsum(rs[n][0])])
        z_mass = np.interp(frac, c / c[-1], edges)
        err = np.maximum(err, np.abs(positions[n, :, 1] - z_mass) / d)
    return {"cells_per_diameter": cells_per_diameter, "start_heights_d": list(START_HEIGHTS_D),
            "max_distance_d": err.tolist(), "horizontal_drift_m": float(np.max(np.abs(positions[:, :, 0] - 0.003))),
            "steps": int(disc.steps), "wall_time_s": wall}


def main(argv=None):
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cells-per-diameter", type=list_of(positive_int), default=[2, 4, 8],
                    help="grid resolutions, cells per sphere diameter, comma-separated (default 2,4,8)")
    ap.add_argument("--json", type=output_json, default=None, help="write the numbers to this JSON file")
    args = ap.parse_args(argv)
    rows = []
    print("cells/d | largest distance from the material line [d] at start 0.5 / 1.5 / 2.5 / 2.9 d | "
          "horizontal drift [m] | wall [s]")
    for cpd in args.cells_per_diameter:
        r = material_line_errors(cpd)
        rows.append(r)
        print(f"{cpd:7d} | " + " / ".join(f"{e:.3f}" for e in r["max_distance_d"])
              + f" | {r['horizontal_drift_m']:.3g} | {r['wall_time_s']:.1f}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"runs": rows}, fh, indent=1)


if __name__ == "__main__":
    main()
