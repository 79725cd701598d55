"""Why the packing continuum's top sphere rises less than the DEM's (issue #18): the discrete
chain against its continuum limit, with the same contact law.

    python bench/check_discreteness.py [--case d22mm_a1.5] [--ppd 5 10 20 40] [--widths 0 0.1 0.3]

For one case of ``bsrflow compare --kernel packing`` prints the top sphere's rise (maximum minus
the top at rest, in d) and its error against the package's DEM for

* ``local``: the Lagrangian packing continuum's local limit (``range_over_d = 0``, R = one point
  spacing) at each ``--ppd``: its continuum limit (the package's default, the nonlocal
  interaction over one diameter, came out of this script's findings: docs/model.md);
* ``chain``: the same bond law on one material point per sphere, with the DEM's wall contact
  (overlap d/2 − y, stiffness K) to the floor: this is the DEM's own equations, so it must agree
  with the DEM (a check of the script), and it shows that the deficit is not in the contact law
  but in the continuum limit, i.e. in the chain's discreteness (dispersion);
* ``sphere``: a nonlocal try (R = d): bonds between material one sphere's mass apart, with a
  triangular weight of half-width ``--widths`` d in mass separation, 10 points per diameter.
  Width 0 decouples the points into ppd interleaved copies of the DEM chain (it reproduces the
  DEM, but is no continuum: nothing holds the copies together, and rounding differences grow in
  the chaotic bouncing until the mass order is lost); the line says when two neighbouring points
  first cross.

Writes nothing; takes about a minute.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from bsrflow.analysis.compare_packing import PACKING_CASES, case_setup
from bsrflow.physics.column import run_bsr_column
from bsrflow.physics.dem import DEMColumn, run_dem
from bsrflow.physics.packing import history_update, packing_force

from _args import Parser, float_in, int_in


@numba.njit(cache=True)
def _bond_accelerations(x, lo, hi, rest, scale, weight, hist, acc, inv_mu, k1, k2, update):
    """Bond b joins point hi[b] to point lo[b] (lo = −1: the floor at 0); overlap
    δ = rest[b] − scale[b]·(x_hi − x_lo), force weight[b]·P(δ, δ_max)."""
    acc[:] = 0.0
    for b in range(lo.shape[0]):
        i, j = lo[b], hi[b]
        xi = 0.0 if i < 0 else x[i]
        delta = rest[b] - scale[b] * (x[j] - xi)
        if update:
            hist[b] = history_update(delta, hist[b])
        f = weight[b] * packing_force(delta, hist[b], k1, k2) * inv_mu
        acc[j] += f
        if i >= 0:
            acc[i] -= f


@numba.njit(cache=True)
def _verlet(x, v, hist, lo, hi, rest, scale, weight, t, t_stop, dt_max, mu, k1, k2, fn, params, g, crossed):
    acc = np.empty(x.shape[0])
    _bond_accelerations(x, lo, hi, rest, scale, weight, hist, acc, 1.0 / mu, k1, k2, False)
    while t < t_stop:
        dt = min(dt_max, t_stop - t)
        a0 = -g - fn(t, params)[2]
        for i in range(x.shape[0]):
            v[i] += 0.5 * dt * (acc[i] + a0)
            x[i] += dt * v[i]
        t1 = t_stop if t + dt >= t_stop else t + dt
        _bond_accelerations(x, lo, hi, rest, scale, weight, hist, acc, 1.0 / mu, k1, k2, True)
        a1 = -g - fn(t1, params)[2]
        for i in range(x.shape[0]):
            v[i] += 0.5 * dt * (acc[i] + a1)
        t = t1
        if crossed[0] < 0.0:
            for i in range(1, x.shape[0]):
                if x[i] <= x[i - 1]:
                    crossed[0] = t
                    break
    return t


def _bonds(kind, n, ppd, d, width):
    """(lo, hi, rest, scale, weight) of the chain (ppd = 1, DEM wall) or the sphere-range bonds."""
    h = d / ppd
    rows = []
    if kind == "chain":
        rows += [(j - 1, j, d, 1.0, 1.0) for j in range(1, n)] + [(-1, 0, 0.5 * d, 1.0, 1.0)]
    else:
        q = int(round(width * ppd))
        lags = np.arange(ppd - q, ppd + q + 1)
        raw = (q + 1 - np.abs(lags - ppd)).astype(float)
        for ell, w in zip(lags, raw / np.sum(lags * raw)):      # Σ ℓ w_ℓ = 1: the local limit
            s = ppd / ell
            rows += [(j - ell, j, d, s, w) if j >= ell else (-1, j, s * (j + 0.5) * h, s, w)
                     for j in range(n * ppd)]
    a = np.array(rows)
    return a[:, 0].astype(np.int64), a[:, 1].astype(np.int64), a[:, 2].copy(), a[:, 3].copy(), a[:, 4].copy()


def run_bonds(setup, kind, ppd, width=0.0):
    """Top sphere trajectory [m, lab frame] of the bond model; returns (t, top, first crossing [s] or −1)."""
    d, n = setup.diameter, setup.n_spheres
    m = setup.particle_mass
    k1 = setup.stiffness
    k2 = k1 / setup.restitution ** 2
    bonds = _bonds(kind, n, ppd, d, width)
    h = d / ppd
    x = (np.arange(n * ppd) + 0.5) * h
    v = np.zeros_like(x)
    hist = np.zeros(bonds[0].shape[0])
    mu = m / ppd
    dt = 0.15 / math.sqrt(k2 / m)                    # ω_max ≤ 2√(K2/m) for both bond sets
    motion = setup.motion()
    params = np.ascontiguousarray(motion.params, dtype=float)
    jumps = dict((float(tj), dv) for tj, dv in motion.jumps_between(0.0, setup.t_end))
    saves = np.round(np.arange(0.0, setup.t_end + 1e-12, setup.save_every), 12)
    crossed = np.array([-1.0])
    top_mass = (n - 0.5) * m
    cum = (np.arange(n * ppd) + 0.5) * mu
    t, out = 0.0, []
    for e in sorted(set(saves.tolist()) | set(jumps)):
        if e > t:
            t = _verlet(x, v, hist, *bonds, t, e, dt, mu, k1, k2, motion.fn, params, setup.gravity, crossed)
        if e in jumps:
            v -= jumps[e]
        top = x[-1] if ppd == 1 else float(np.interp(top_mass, cum, np.sort(x)))
        out.append((e, top + motion.state(e)[0]))
    out = np.array(out)
    return out[:, 0], out[:, 1], float(crossed[0])


def rise(t, top, tap_start):
    return float(top.max() - top[t < tap_start][-1])


def main(argv=None):
    names = [c["name"] for c in PACKING_CASES]
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", default="d22mm_a1.5", choices=names, metavar="NAME", help="one of: " + ", ".join(names))
    ap.add_argument("--ppd", type=int_in(2), nargs="+", default=[5, 10, 20, 40],
                    help="points per diameter of the local-limit runs (default 5 10 20 40)")
    ap.add_argument("--widths", type=float_in(0.0, 1.0, hi_open=True), nargs="+", default=[0.0, 0.1, 0.3],
                    help="half-widths [d] of the nonlocal try's triangular weight, each in [0, 1) (default 0 0.1 0.3)")
    args = ap.parse_args(argv)
    s = case_setup(next(c for c in PACKING_CASES if c["name"] == args.case), formulation="lagrangian", range_over_d=0.0,
                   save_every=0.0005)
    d = s.diameter
    col = DEMColumn(n_spheres=s.n_spheres, diameter=d, density=s.density, stiffness=s.stiffness,
                    restitution=s.restitution, gravity=s.gravity)
    r = run_dem(col, s.motion(), s.t_end, sample_interval=s.save_every)
    rd = rise(np.asarray(r.t), np.asarray(r.positions)[:, -1], s.tap_start)
    print(f"{args.case}: DEM top rise {rd / d:.3f} d")
    print(f"{'model':28s} {'rise [d]':>9s} {'error':>8s}")
    for p in args.ppd:
        run = run_bsr_column(s.with_(points_per_diameter=p))
        rc = rise(run.t, run.tracers[:, -1] + run.floor, s.tap_start)
        print(f"{'local continuum, ppd ' + str(p):28s} {rc / d:9.3f} {rc / rd - 1:+8.2%}")
    t, top, _ = run_bonds(s, "chain", 1)
    rc = rise(t, top, s.tap_start)
    print(f"{'chain, 1 point per sphere':28s} {rc / d:9.3f} {rc / rd - 1:+8.2%}")
    for w in args.widths:
        t, top, crossed = run_bonds(s, "sphere", 10, w)
        rc = rise(t, top, s.tap_start)
        note = f"mass order lost at t = {crossed:.4f} s" if crossed >= 0 else "mass order kept"
        print(f"{'sphere range, width ' + format(w, 'g') + ' d':28s} {rc / d:9.3f} {rc / rd - 1:+8.2%}   {note}")


if __name__ == "__main__":
    main()
