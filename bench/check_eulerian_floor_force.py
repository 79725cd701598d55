"""Where the Eulerian column's landing comes early: the floor's force before the bed arrives (issue #19).

    python bench/check_eulerian_floor_force.py [--cells-per-d 4] [--cycle 6] [--json PATH]

The reference bed (:class:`bsrflow.physics.granular_bed.BedSetup` defaults, Γ = 3, 20 Hz) as the
Lagrangian cells (:class:`bsrflow.numerics.bed_lagrangian.GranularBedColumn`) and as an Eulerian
column (:class:`bsrflow.numerics.bed_eulerian.EulerianBed`), both started as ``compare-bed``
starts them (the static bed, the floor's jump to aω).  Printed for the approach to the landing of
cycle ``--cycle`` (phases 0.60 to 0.76 of the cycle, every 0.02): the floor's force averaged over
1 ms [M g] in both, the height of the Lagrangian bed's bottom face above the floor [d], and the
Eulerian bottom cell's state with the three parts of the floor face's HLLC flux at the mirror,
p + ρu² + ρ(S + |u|)|u| with S = |u| + c_k there (no contact wave below φ_c): the kinetic
pressure p, the momentum flux ρu² and the wave term ρ(|u| + c_k)|u|, each over the weight per
area [M g] (before the floor's viscous stress, which may only lower it, and the reconstruction's
limiter, which keeps the cell's value at the mirror).  The flight measure cuts the 1-ms force at
0.1 M g.
"""

from __future__ import annotations

import math
import time

import numpy as np

from _args import Parser, int_in, list_of, output_json, write_json
from bsrflow.numerics.bed_eulerian import ENER, MZ, RHO, EulerianBed, kinetic_sound_speed
from bsrflow.numerics.bed_lagrangian import GranularBedColumn
from bsrflow.physics.granular_bed import BedSetup, kinetic_pressure

SAVE = 1e-4
"""Interval of the floor-force samples [s] (compare-bed's)."""
PHASES = np.round(np.arange(0.60, 0.761, 0.02), 2)


def _run(bed, force, setup, cycle, record):
    """Advance ``bed`` to the end of ``cycle``; the floor force every SAVE; ``record(bed)`` at the
    samples of the last cycle.  Returns (times, forces, records)."""
    T = 1.0 / setup.frequency
    n = int(round(cycle * T / SAVE))
    start = int(round((cycle - 1) * T / SAVE))
    bed.apply_velocity_jump(setup.amplitude * setup.omega)
    f, rec = np.empty(n), []
    for i in range(n):
        f[i] = force(bed, i * SAVE, (i + 1) * SAVE)
        if i + 1 >= start:
            rec.append(record(bed))
    return np.arange(1, n + 1) * SAVE, f, rec


def approach(cells_per_d: int, cycle: int) -> dict:
    """The landing's approach in both discretisations (module docstring)."""
    s = BedSetup(gamma=3.0, cycles=cycle)
    d, rho_s, e = s.diameter, s.density, s.restitution
    weight = s.n_spheres * rho_s * math.pi * d ** 3 / 6.0 * s.gravity
    per_area = weight / s.area
    T = 1.0 / s.frequency
    wall = time.perf_counter()

    def lag_force(b, t0, t1):
        b.advance(t0, t1)
        return b.floor_force(t1)
    tl, fl, gaps = _run(GranularBedColumn(s), lag_force, s, cycle, lambda b: float(b.zf[0]))
    eb = EulerianBed(s, 1, cells_per_d, 1, 0.0)
    te, fe, cells = _run(eb, lambda b, t0, t1: b.advance(t0, t1), s, cycle,
                         lambda b: b.q[[RHO, MZ, ENER], 0, 0, 0].copy())
    rows = []
    for p in PHASES:
        tc = (cycle - 1 + p) * T
        win = np.abs(te - tc) < 0.5e-3 + 1e-12
        k = int(round(p * T / SAVE))
        r, m, en = cells[k]
        u, th = m / r, en / (1.5 * r)
        phi = r / rho_s
        ck = kinetic_sound_speed(phi, th, e)
        rows.append({"phase": float(p),
                     "floor_force_lagrangian_over_weight": float(fl[win].mean() / weight),
                     "floor_force_eulerian_over_weight": float(fe[win].mean() / weight),
                     "lagrangian_bottom_face_over_d": gaps[k] / d,
                     "eulerian_bottom_cell": {"solid_fraction": float(phi), "u_z_m_s": float(u),
                                              "theta_m2_s2": float(th)},
                     "kinetic_pressure_over_weight": float(kinetic_pressure(phi, th, rho_s, e) / per_area),
                     "momentum_flux_over_weight": float(r * u * u / per_area),
                     "wave_term_over_weight": float(r * (abs(u) + ck) * abs(u) / per_area)})
    return {"cells_per_d": cells_per_d, "cycle": cycle, "rows": rows, "wall_s": time.perf_counter() - wall}


def main(argv=None) -> int:
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cells-per-d", type=list_of(int_in(1, 16)), default=[4],
                    help="Eulerian resolutions, cells per diameter (default 4; at most 16)")
    ap.add_argument("--cycle", type=int_in(1, 11), default=6, help="the cycle whose landing is shown (default 6; "
                    "at most 11)")
    ap.add_argument("--json", type=output_json, help="also write the results here")
    args = ap.parse_args(argv)
    out = []
    for c in args.cells_per_d:
        r = approach(c, args.cycle)
        out.append(r)
        print(f"{c} cells per d, cycle {args.cycle} ({r['wall_s']:.0f} s): floor force [M g] and the Eulerian "
              "bottom cell's floor flux parts [M g]")
        print("phase | Lagrangian force | its bottom face [d] | Eulerian force | phi, u_z [m/s], theta [m2/s2] | "
              "p | rho u^2 | rho (|u| + c_k)|u|")
        for w in r["rows"]:
            b = w["eulerian_bottom_cell"]
            print(f"{w['phase']:.2f} | {w['floor_force_lagrangian_over_weight']:.3f} | "
                  f"{w['lagrangian_bottom_face_over_d']:.3f} | {w['floor_force_eulerian_over_weight']:.3f} | "
                  f"{b['solid_fraction']:.3f}, {b['u_z_m_s']:+.3f}, {b['theta_m2_s2']:.2e} | "
                  f"{w['kinetic_pressure_over_weight']:.3f} | {w['momentum_flux_over_weight']:.3f} | "
                  f"{w['wave_term_over_weight']:.3f}", flush=True)
    if args.json:
        write_json(args.json, {"gamma": 3.0, "cases": out})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
