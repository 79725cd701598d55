"""A compiled 1-D DEM of a vertical column of spheres on a moving floor (seed section 4.4).

N spheres of diameter d [m] and mass m = ρ_s π d³/6 [kg] have centres y_1 < ... < y_N [m]
(laboratory frame), initially y_k = (2k-1) d/2.  Gravity g [m/s²] acts downwards.  The floor
is at ϑ(t) (an :class:`~bsrflow.physics.motion.AppliedMotion`).  Contacts (overlap
δ = d - (y_{k+1} - y_k) between spheres, δ = d/2 - (y_1 - ϑ) with the floor) follow the bilinear
Walton-Braun model:

    loading   (δ >= δ_max):  F = K1 δ,  δ_max <- δ
    unloading (δ <  δ_max):  F = max(0, K2 (δ - δ0)),  δ0 = δ_max (1 - K1/K2)

with K1 = K (loading stiffness [N/m]) and K2 = K1/e² (e the coefficient of restitution); δ_max
is reset when the contact opens.  Reloading follows the K2 line back to the K1 line.  A binary
collision then has restitution e = sqrt(K1/K2).  Contacts only push.

Integration: velocity Verlet (second order, symplectic for e = 1), step Δt = t_c / steps_per_contact
with t_c = π sqrt(m_eff/K2), m_eff = m/2 the sphere-sphere effective mass (the shortest contact
period).  The whole loop is compiled with numba; the floor motion is compiled into it.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numba
import numpy as np

__all__ = ["DEMColumn", "DEMResult", "run_dem", "static_overlaps", "static_positions", "contact_forces"]


@dataclass
class DEMColumn:
    """Column parameters (SI).  Every bad value raises ValueError naming it and its range."""

    n_spheres: int = 20
    diameter: float = 0.022
    density: float = 1200.0
    stiffness: float = 1.366e7
    restitution: float = 0.9
    gravity: float = 9.81
    steps_per_contact: int = 50

    def __post_init__(self):
        if int(self.n_spheres) != self.n_spheres or self.n_spheres < 1:
            raise ValueError(f"n_spheres = {self.n_spheres!r} is outside the valid range: integers >= 1")
        for name in ("diameter", "density", "stiffness"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"{name} = {v!r} is outside the valid range (0, inf)")
        if not (0.0 < self.restitution <= 1.0):
            raise ValueError(f"restitution = {self.restitution!r} is outside the valid range (0, 1]")
        if not (np.isfinite(self.gravity) and self.gravity >= 0):
            raise ValueError(f"gravity = {self.gravity!r} is outside the valid range [0, inf) m/s^2")
        if int(self.steps_per_contact) != self.steps_per_contact or self.steps_per_contact < 10:
            raise ValueError(f"steps_per_contact = {self.steps_per_contact!r} is outside the valid range: "
                             "integers >= 10")

    @property
    def mass(self) -> float:
        return self.density * math.pi / 6.0 * self.diameter ** 3

    @property
    def unloading_stiffness(self) -> float:
        return self.stiffness / self.restitution ** 2

    @property
    def contact_time(self) -> float:
        """t_c = π sqrt((m/2)/K2) [s], the shortest contact duration."""
        return math.pi * math.sqrt(0.5 * self.mass / self.unloading_stiffness)

    @property
    def dt(self) -> float:
        return self.contact_time / self.steps_per_contact


@dataclass
class DEMResult:
    t: np.ndarray              # [s] sample times
    positions: np.ndarray      # [m] (n_samples, N) sphere centres, laboratory frame
    velocities: np.ndarray     # [m/s]
    floor: np.ndarray          # [m]
    kinetic: np.ndarray        # [J]
    potential: np.ndarray      # [J] gravitational, relative to y = 0
    elastic: np.ndarray        # [J] stored in the contacts
    dt: float
    wall_time: float = 0.0

    def top(self) -> np.ndarray:
        return self.positions[:, -1]

    def mass_centre(self) -> np.ndarray:
        return self.positions.mean(axis=1)

    @property
    def energy(self) -> np.ndarray:
        return self.kinetic + self.potential + self.elastic


@numba.njit(cache=True)
def _contact(delta, dmax, k1, k2):
    """Walton-Braun force [N] and the updated δ_max for overlap δ."""
    if delta <= 0.0:
        return 0.0, 0.0
    if delta >= dmax:
        return k1 * delta, delta
    f = k2 * (delta - dmax * (1.0 - k1 / k2))
    return (f if f > 0.0 else 0.0), dmax


@numba.njit(cache=True)
def _elastic_energy(delta, dmax, k1, k2):
    """Energy stored in a contact [J]: on the loading line ½K1δ², on the unloading line
    ½K2(δ-δ0)² (what it would return)."""
    if delta <= 0.0:
        return 0.0
    if delta >= dmax:
        return 0.5 * k1 * delta * delta
    d0 = dmax * (1.0 - k1 / k2)
    return 0.5 * k2 * (delta - d0) ** 2 if delta > d0 else 0.0


@functools.lru_cache(maxsize=16)
def _make_loop(motion_fn):
    M = motion_fn

    @numba.njit(cache=False)
    def forces(y, t, d, k1, k2, m, g, dmax, f, mp):
        n = y.size
        for k in range(n):
            f[k] = -m * g
        floor = M(t, mp)[0]
        fc, dmax[0] = _contact(0.5 * d - (y[0] - floor), dmax[0], k1, k2)
        f[0] += fc
        for k in range(n - 1):
            fc, dmax[k + 1] = _contact(d - (y[k + 1] - y[k]), dmax[k + 1], k1, k2)
            f[k] -= fc
            f[k + 1] += fc

    @numba.njit(cache=False)
    def loop(y, v, t0, dt, n_steps, sample_every, d, k1, k2, m, g, mp, out_y, out_v, out_t, out_floor,
             out_ke, out_pe, out_el):
        n = y.size
        dmax = np.zeros(n)
        f = np.empty(n)
        forces(y, t0, d, k1, k2, m, g, dmax, f, mp)
        s = 0
        t = t0
        for step in range(n_steps + 1):
            if step % sample_every == 0 and s < out_t.size:
                out_t[s] = t
                floor = M(t, mp)[0]
                out_floor[s] = floor
                ke = 0.0
                pe = 0.0
                for k in range(n):
                    out_y[s, k] = y[k]
                    out_v[s, k] = v[k]
                    ke += 0.5 * m * v[k] * v[k]
                    pe += m * g * y[k]
                el = _elastic_energy(0.5 * d - (y[0] - floor), dmax[0], k1, k2)
                for k in range(n - 1):
                    el += _elastic_energy(d - (y[k + 1] - y[k]), dmax[k + 1], k1, k2)
                out_ke[s] = ke
                out_pe[s] = pe
                out_el[s] = el
                s += 1
            if step == n_steps:
                break
            for k in range(n):
                v[k] += 0.5 * dt * f[k] / m
                y[k] += dt * v[k]
            t = t0 + (step + 1) * dt
            forces(y, t, d, k1, k2, m, g, dmax, f, mp)
            for k in range(n):
                v[k] += 0.5 * dt * f[k] / m
        return s

    return loop


def static_overlaps(column: DEMColumn) -> np.ndarray:
    """Force-balance overlaps of a resting column [m]: contact j (j = 0 the floor, j = k between
    spheres k and k+1, counted from the bottom) carries the weight of the N - j spheres above
    it, δ_j = (N - j) m g / K1 (on the loading line)."""
    n = column.n_spheres
    return (n - np.arange(n)) * column.mass * column.gravity / column.stiffness


def static_positions(column: DEMColumn) -> np.ndarray:
    """Sphere centres [m] of the resting column with the force-balance overlaps."""
    ov = static_overlaps(column)
    y = np.empty(column.n_spheres)
    y[0] = 0.5 * column.diameter - ov[0]
    for k in range(1, column.n_spheres):
        y[k] = y[k - 1] + column.diameter - ov[k]
    return y


def contact_forces(column: DEMColumn, positions: np.ndarray, floor: float = 0.0) -> np.ndarray:
    """Elastic contact forces [N] on the loading line K1 δ for given centres (floor contact first)."""
    ov = np.concatenate([[0.5 * column.diameter - (positions[0] - floor)], column.diameter - np.diff(positions)])
    return column.stiffness * np.maximum(ov, 0.0)


def run_dem(column: DEMColumn, motion, t_end: float, sample_interval: float = 1e-3, initial_positions=None,
            initial_velocities=None) -> DEMResult:
    """Integrate the column from t = 0 to ``t_end`` [s], sampling every ``sample_interval`` [s]."""
    import time
    if not (np.isfinite(t_end) and t_end > 0):
        raise ValueError(f"t_end = {t_end!r} is outside the valid range (0, inf) s")
    if not (np.isfinite(sample_interval) and sample_interval > 0):
        raise ValueError(f"sample_interval = {sample_interval!r} is outside the valid range (0, inf) s")
    n = column.n_spheres
    d = column.diameter
    y = ((np.arange(n) + 0.5) * d if initial_positions is None
         else np.array(initial_positions, float, copy=True))
    v = np.zeros(n) if initial_velocities is None else np.array(initial_velocities, float, copy=True)
    if y.shape != (n,) or v.shape != (n,):
        raise ValueError(f"initial_positions/initial_velocities must have shape ({n},)")
    dt0 = column.dt
    sample_every = max(1, int(round(sample_interval / dt0)))
    dt = sample_interval / sample_every           # samples land exactly on multiples of the interval
    n_steps = int(math.ceil(t_end / dt - 1e-9))
    n_samples = n_steps // sample_every + 1
    out = [np.empty((n_samples, n)), np.empty((n_samples, n))] + [np.empty(n_samples) for _ in range(5)]
    loop = _make_loop(motion.fn)
    w = time.perf_counter()
    s = loop(y, v, 0.0, dt, n_steps, sample_every, d, column.stiffness, column.unloading_stiffness,
             column.mass, column.gravity, motion.params, *out)
    wall = time.perf_counter() - w
    oy, ov, ot, of, ke, pe, el = (a[:s] for a in out)
    return DEMResult(ot, oy, ov, of, ke, pe, el, dt, wall)
