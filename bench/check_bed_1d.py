"""Can the packing continuum without a granular temperature describe the vibrated bed of
issue #19?  The horizontally uniform bed is a 1-D column: this runs it against the committed
LIGGGHTS data (reference/liggghts_bed), before any 3-D solver is built.

    python bench/check_bed_1d.py [--gammas 1.5 3 4] [--restitution 0.9] [--ppd 10]

Mapping of the 3-D bed (N spheres of d, ρ_s in a periodic box of side L, area A = L²) onto the
1-D packing law of :mod:`bsrflow.physics.packing`: the bed's mass per height at the packing's
solid fraction φ_c is ρ_c = φ_c ρ_s A, one "layer" of it (mass m_eff = ρ_c d) plays the sphere;
for an isotropic packing with Z contacts per sphere compressed uniaxially (affine, δ = d ε n_z²),
σ_zz = (3 Z φ_c K / (5 π d)) ε, i.e. a layer stiffness K_eff = 3 Z φ_c K A / (5 π d²); the
unloading K_eff/e².  φ_c = 0.636 and Z = 5.31 (sphere–sphere) are the settled LIGGGHTS bed's (README there).
The floor: z = A_f sin ωt from t = 0 (moving up at A_f ω at the start, as the deck's), after
0.5 s of settling on the resting floor.  Flight time per cycle: that of ``bsrflow compare-bed``
(:func:`bsrflow.analysis.compare_bed.flights_from_force`, the LIGGGHTS post-processing's).

Prints the flight time of each cycle, the mean of the last six (LIGGGHTS's steady measure) beside
LIGGGHTS's, and the RMS difference of the mass-centre height over cycles 5–10 in d.  Writes
nothing; a few seconds.
"""

from __future__ import annotations

import math
from pathlib import Path

import numba
import numpy as np

from _args import Parser, positive_float, positive_int
from bsrflow.analysis.compare_bed import flight_per_cycle, flights_from_force
from bsrflow.numerics import packing_kernels as pk
from bsrflow.physics.packing import packing_force

REF = Path(__file__).resolve().parents[1] / "reference" / "liggghts_bed"


@numba.njit(cache=True)
def _sine_floor(t, p):
    a, w = p[0], p[1]
    return (a * math.sin(w * t), a * w * math.cos(w * t), -a * w * w * math.sin(w * t))


def run_bed(gamma, restitution, ppd, cycles=11, n=2000, side=13.0, d=0.005, rho_s=1200.0, stiffness=5e4,
            phi=0.636, z=5.31, f=20.0, g=9.81, cfl=0.5):
    w = 2.0 * math.pi * f
    amp = gamma * g / w ** 2
    area = (side * d) ** 2
    total = n * rho_s * math.pi / 6.0 * d ** 3
    m_eff = phi * rho_s * area * d
    k1 = 3.0 * z * phi * stiffness * area / (5.0 * math.pi * d ** 2)
    k2 = k1 / restitution ** 2
    n_pts = int(round(total / m_eff * ppd))
    mu = total / n_pts
    ppd_f = m_eff / mu
    h = d / ppd_f
    x = (np.arange(n_pts) + 0.5) * h
    v = np.zeros(n_pts)
    hist = np.zeros(n_pts)
    dt = cfl * h / (d * math.sqrt(k2 / m_eff))
    counters = np.zeros(3, dtype=np.int64)
    pk.lagrangian_advance(x, v, hist, 0.0, 0.5, dt, mu, ppd_f, d, k1, k2, _sine_floor, np.array([0.0, w]), g, counters)
    v -= amp * w                                     # the floor starts moving up at A ω (floor frame)
    params = np.array([amp, w])
    ts = np.arange(1, int(round(cycles / f / 1e-4)) + 1) * 1e-4
    com, force = np.empty(ts.size), np.empty(ts.size)
    t = 0.0
    for k, te in enumerate(ts):
        t = pk.lagrangian_advance(x, v, hist, t, te, dt, mu, ppd_f, d, k1, k2, _sine_floor, params, g, counters)
        com[k] = x.mean()
        force[k] = packing_force(d - ppd_f * 2.0 * x[0], hist[0], k1, k2)
    if counters[1]:
        raise RuntimeError(f"material points crossed at Γ = {gamma}")
    return ts, com, force, total * g, 1.0 / f, total / m_eff


def main(argv=None):
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--gammas", type=positive_float, nargs="+", default=[1.5, 3.0, 4.0],
                    help="Γ = aω²/g of the runs; LIGGGHTS's numbers shown where it has a run at that Γ (default 1.5 3 4)")
    ap.add_argument("--restitution", type=float, choices=(0.9, 0.5), default=0.9,
                    help="0.9 (main LIGGGHTS runs) or 0.5 (the LIGGGHTS runs' values)")
    ap.add_argument("--ppd", type=positive_int, default=10, help="material points per layer")
    args = ap.parse_args(argv)
    tag = "" if args.restitution == 0.9 else "_e0.5"
    table = np.genfromtxt(REF / f"flight_vs_gamma{tag}.csv", delimiter=",", names=True, skip_header=1)
    d = 0.005
    print(f"e = {args.restitution}; flight time per cycle [ms] (continuum; LIGGGHTS last-6 mean), mass-centre RMS "
          "over cycles 5-10")
    for gamma in args.gammas:
        ts, com, force, weight, period, layers = run_bed(gamma, args.restitution, args.ppd)
        fl = flight_per_cycle(flights_from_force(ts, force, weight), period, int(round(ts[-1] / period))) * 1e3
        row = table[np.isclose(table["gamma"], gamma)]
        dem = f"{row['flight_time_mean_last6_s'][0] * 1e3:.1f}" if row.size else "–"
        traj = REF / "results" / f"gamma_{gamma:.2f}_N2000_L13d{tag}" / "trajectory.csv"
        rms = "–"
        if traj.exists():
            data = np.genfromtxt(traj, delimiter=",", names=True, skip_header=1)
            sel = (data["t_s"] >= 5 * period) & (data["t_s"] < 10 * period)
            diff = np.interp(data["t_s"][sel], ts, com) - data["com_rel_m"][sel]
            rms = f"{math.sqrt(float(np.mean(diff ** 2))) / d:.2f} d"
        print(f"Γ = {gamma:g} ({layers:.2f} layers): cycles {' '.join(f'{x:.1f}' for x in fl)}; last 6: "
              f"{np.nanmean(fl[5:]):.1f} (LIGGGHTS {dem}); mass-centre RMS {rms}")


if __name__ == "__main__":
    main()
