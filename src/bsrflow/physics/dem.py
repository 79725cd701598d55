"""A compiled 1-D discrete element model (DEM) of a vertical column of spheres on a moving floor.

This is the particle reference for the tapped column (seed section 4.4).  SI units throughout:
lengths [m], times [s], masses [kg], forces [N], energies [J].

Model
-----
``N`` identical spheres of diameter ``d`` and material density ``ρ_s`` (mass
``m = ρ_s π d³ / 6``) have their centres ``y_1 < y_2 < ... < y_N`` on a vertical line
(laboratory frame, ``y`` upwards).  By default they start at rest, touching each other and the
floor: ``y_k = (2k - 1) d / 2``.  Gravity ``g`` acts downwards.  The floor is at ``ϑ(t)``, the
position returned by an :class:`~bsrflow.physics.motion.AppliedMotion`
(``motion.fn(t, motion.params)[0]``).

Contacts are numbered from the floor: contact ``k`` (k = 1..N) is the one *beneath* sphere
``k``, with overlap

    δ_1 = d/2 - (y_1 - ϑ(t))              (sphere 1 on the floor)
    δ_k = d - (y_k - y_{k-1}),  k >= 2    (sphere k on sphere k-1)

(arrays store contact k at index k-1, next to sphere k); a contact is closed while ``δ > 0``.
Its normal force follows the bilinear, hysteretic Walton-Braun law with loading stiffness
``K1 = K`` and unloading stiffness ``K2 = K1 / e²`` (``e`` in (0, 1] the coefficient of
restitution), remembering the largest overlap ``δ_max`` reached since the contact closed:

    loading    (δ >= δ_max):  F = K1 δ,                       and δ_max <- δ
    unloading / reloading (δ < δ_max):
                              F = max(0, K2 (δ - δ_0)),        δ_0 = δ_max (1 - K1/K2)
    open       (δ <= 0):      F = 0,                           and δ_max <- 0

Unloading and reloading both run along the steep ``K2`` line, which meets the loading line at
``δ_max``; there loading resumes.  Contacts only push (``F >= 0``).  A binary collision
stores ``K1 δ_max² / 2`` and returns ``K1² δ_max² / (2 K2)``, so the velocity ratio is
``e = sqrt(K1/K2)``.  Contact k pushes sphere k up and sphere k-1 (or the floor) down:

    m y_k'' = F_k - F_{k+1} - m g,       F_{N+1} = 0

Energies (reported at the samples)
    kinetic      Σ m v² / 2
    potential    Σ m g (y - ϑ(0))    gravitational, relative to the initial floor
    elastic      Σ F² / (2 K2)       the energy each contact would give back if it unloaded
                                     now.  On the loading line this is e² K1 δ² / 2, on the K2
                                     line K2 (δ - δ_0)² / 2; for e = 1 it is K δ² / 2.
With this choice the total ``kinetic + potential + elastic`` is continuous in time, constant
for ``e = 1`` on a resting floor, and never increases for ``e < 1`` on a resting floor (the
fraction ``1 - e²`` of the work done on a loading contact is dissipated as it is done).

Integration
-----------
Velocity Verlet (written in its equivalent leapfrog form: positions at whole steps, velocities
at half steps, synchronised at the samples).  It is second order, time reversible and
symplectic, so for ``e = 1`` the energy error stays bounded instead of drifting; it needs one
force evaluation per step and no storage beyond positions, velocities and ``δ_max``.  Higher
order schemes do not help here: the contact force has a kink where a contact closes or opens
(and, for ``e < 1``, where it switches between the ``K1`` and ``K2`` lines), which limits any
one-step method to an ``O((ω Δt)²)`` energy error per such event.

Time step: the shortest contact is between two spheres (reduced mass ``m/2``) on the stiff
``K2`` line, lasting half a period ``t_c = π sqrt((m/2) / K2)``;
``Δt = t_c / steps_per_contact`` (default 50), then shortened slightly so that a whole number
of steps fits into one sample interval.  Measured with this module (see ``tests/test_dem.py``):

* restitution of a single sphere on the floor: within about 1e-3 of ``e`` at 50 steps;
* energy (``e = 1``): the error is not a drift but a random walk of kicks of relative size
  ``~(ω Δt)²`` times the contact energy, one at every contact closing and opening (where the
  force has a kink), plus the bounded ``~(ω Δt)²`` oscillation of Verlet inside a contact.
  A sphere dropped 1 mm onto the floor, 1 s of bouncing: relative error 7e-5 at 50 steps per
  contact, 5e-6 at 200, 1.6e-7 at 1000, 3e-8 at 2000.  So 1e-6 needs about 1000 steps per
  contact; velocity Verlet with that smaller step is the remedy used (cheap for a few
  spheres).  The default Δt = t_c/50 (t_c the two-sphere unloading half period; a real
  contact gets 53-75 steps) converges the tapped column's top maximum to 0.004-0.006 d for one
  tap and 0.03 d for three (Δt against Δt/2, 1e-4 to 1e-3 relative; one-off runs, 2026-12-02).

The floor enters only through its position ϑ(t), which is continuous even where a tap makes
its velocity jump, so no impulse bookkeeping is needed in this laboratory-frame model.

The whole time loop is compiled with numba.  The floor motion ``fn`` is compiled into it:
:func:`make_dem_loop` builds (once per ``fn``) a loop closing over it.
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass, field

import numba
import numpy as np

__all__ = [
    "DEMColumn",
    "DEMResult",
    "run_dem",
    "settle",
    "static_overlaps",
    "static_positions",
    "make_dem_loop",
]


def _bad(name, value, valid):
    return ValueError(f"{name} = {value!r} is outside the valid range {valid}")


def _is_int(value):
    return isinstance(value, (int, np.integer)) and not isinstance(value, bool)


def _real(name, value, valid):
    """float(value), or ValueError naming the parameter if it is not a finite real number."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise _bad(name, value, valid) from None
    if not math.isfinite(x):
        raise _bad(name, value, valid)
    return x


@dataclass
class DEMColumn:
    """Parameters of the sphere column (SI units).

    Parameters
    ----------
    n_spheres : number of spheres N, integer >= 1.
    diameter : sphere diameter d [m], > 0.
    density : material density ρ_s [kg/m³], > 0.  Sphere mass m = ρ_s π d³/6.
    stiffness : loading stiffness K1 = K [N/m], > 0.
    restitution : coefficient of restitution e in (0, 1]; unloading stiffness K2 = K1/e².
    gravity : g [m/s²], >= 0, acting downwards.
    steps_per_contact : time steps per shortest contact duration t_c, integer >= 10.

    Every bad value raises ValueError naming the parameter, the value and the valid range.
    """

    n_spheres: int = 20
    diameter: float = 0.022
    density: float = 1200.0
    stiffness: float = 1.366e7
    restitution: float = 0.9
    gravity: float = 9.81
    steps_per_contact: int = 50

    def __post_init__(self):
        if not _is_int(self.n_spheres) or self.n_spheres < 1:
            raise _bad("n_spheres", self.n_spheres, "integers >= 1")
        for name in ("diameter", "density", "stiffness"):
            if _real(name, getattr(self, name), "(0, inf)") <= 0:
                raise _bad(name, getattr(self, name), "(0, inf)")
        e = _real("restitution", self.restitution, "(0, 1]")
        if not 0.0 < e <= 1.0:
            raise _bad("restitution", self.restitution, "(0, 1]")
        if _real("gravity", self.gravity, "[0, inf) m/s^2") < 0:
            raise _bad("gravity", self.gravity, "[0, inf) m/s^2")
        if not _is_int(self.steps_per_contact) or self.steps_per_contact < 10:
            raise _bad("steps_per_contact", self.steps_per_contact, "integers >= 10")
        self.n_spheres = int(self.n_spheres)
        self.steps_per_contact = int(self.steps_per_contact)
        for name in ("diameter", "density", "stiffness", "restitution", "gravity"):
            setattr(self, name, float(getattr(self, name)))

    @property
    def mass(self) -> float:
        """Sphere mass m = ρ_s π d³ / 6 [kg]."""
        return self.density * math.pi / 6.0 * self.diameter ** 3

    @property
    def loading_stiffness(self) -> float:
        """K1 = K [N/m]."""
        return self.stiffness

    @property
    def unloading_stiffness(self) -> float:
        """K2 = K1 / e² [N/m]."""
        return self.stiffness / self.restitution ** 2

    @property
    def contact_time(self) -> float:
        """Shortest contact duration t_c = π sqrt((m/2) / K2) [s] (two spheres, K2 line)."""
        return math.pi * math.sqrt(0.5 * self.mass / self.unloading_stiffness)

    @property
    def dt(self) -> float:
        """Largest time step Δt = t_c / steps_per_contact [s] (runs may use a slightly
        smaller one, see :func:`run_dem`)."""
        return self.contact_time / self.steps_per_contact


@dataclass
class DEMResult:
    """Output of :func:`run_dem`.  Arrays are sampled at the times ``t``.

    Attributes
    ----------
    t : (n_samples,) sample times [s], multiples of the sample interval starting at 0.
    positions : (n_samples, N) sphere centres y [m], laboratory frame, from the bottom sphere up.
    velocities : (n_samples, N) sphere velocities [m/s].
    floor : (n_samples,) floor position ϑ(t) [m].
    kinetic, potential, elastic : (n_samples,) energies [J] (see the module docstring);
        ``potential`` is relative to the initial floor ϑ(0).
    dt : time step used [s].
    column : the :class:`DEMColumn`.
    delta_max : (N,) contact memory δ_max [m] at the end (index j: the contact beneath
        sphere j, 0-based), to continue a run with
        ``run_dem(..., initial_delta_max=result.delta_max)``.
    max_overlap : largest overlap of any contact at any step [m].
    wall_time : time spent in the compiled loop [s] (compilation excluded).
    """

    t: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    floor: np.ndarray
    kinetic: np.ndarray
    potential: np.ndarray
    elastic: np.ndarray
    dt: float
    column: DEMColumn
    delta_max: np.ndarray
    max_overlap: float
    wall_time: float = field(default=0.0, repr=False)

    def top(self) -> np.ndarray:
        """Centre of the top sphere y_N(t) [m]."""
        return self.positions[:, -1]

    def mass_centre(self) -> np.ndarray:
        """Centre of mass of the column (mean of the centres) [m]."""
        return self.positions.mean(axis=1)

    @property
    def energy(self) -> np.ndarray:
        """Total energy kinetic + potential + elastic [J]."""
        return self.kinetic + self.potential + self.elastic

    def overlaps(self) -> np.ndarray:
        """(n_samples, N) contact overlaps δ [m]; column j is the contact beneath sphere j
        (0-based; j = 0 the floor contact), negative for open contacts (then minus the gap)."""
        d = self.column.diameter
        below = np.concatenate([self.floor[:, None] + 0.5 * d, self.positions[:, :-1] + d], axis=1)
        return below - self.positions


def static_overlaps(column: DEMColumn) -> np.ndarray:
    """Resting overlaps from the force balance, on the loading line [m].

    Element ``j`` (0-based) is the contact beneath sphere ``j``: ``j = 0`` the floor contact,
    ``j >= 1`` the contact between spheres ``j`` and ``j + 1`` counted from 1 at the bottom.
    It carries the weight of the ``N - j`` spheres above it:

        δ_j = (N - j) m g / K1.

    In 1-based contact numbering (contact k = j + 1, k = 1 the floor) this is
    δ_k = (N - k + 1) m g / K1.
    """
    n = column.n_spheres
    return (n - np.arange(n)) * column.mass * column.gravity / column.loading_stiffness


def static_positions(column: DEMColumn, floor: float = 0.0) -> np.ndarray:
    """Sphere centres [m] of the column resting at :func:`static_overlaps` on a floor at
    height ``floor`` [m]."""
    d = column.diameter
    gaps = np.full(column.n_spheres, d)
    gaps[0] = 0.5 * d
    return floor + np.cumsum(gaps - static_overlaps(column))


# ----------------------------------------------------------------------------- compiled core


@numba.njit(cache=True)
def _walton_braun(delta, dmax, k1, k2):
    """Walton-Braun force F [N] at overlap ``delta`` [m] with memory ``dmax`` [m]; returns
    (F, updated δ_max).

    Written without branches: with δ_max' = max(δ_max, δ),
    F = max(0, K1 δ_max' - K2 (δ_max' - δ)) is K1 δ on the loading line (δ >= δ_max) and
    K2 (δ - δ_0) below it; for δ <= 0 it is 0 because K2 >= K1.  The memory is reset to 0
    while the contact is open."""
    dm = max(dmax, delta)
    f = max(0.0, k1 * dm - k2 * (dm - delta))
    return f, (dm if delta > 0.0 else 0.0)


@numba.njit(cache=True)
def _smooth_ramp(s):
    """Smooth step: 0 for s <= 0, 1 for s >= 1, 6s⁵ - 15s⁴ + 10s³ between (C²)."""
    if s <= 0.0:
        return 0.0
    if s >= 1.0:
        return 1.0
    return s * s * s * (10.0 + s * (-15.0 + 6.0 * s))


@numba.njit(inline="always")
def _pass(y, v, dmax, floor, drift, kick, sync, d, m, g, k1, k2, vout, row, sampling, max_ov):
    """One fused sweep from the floor up: drift positions by ``drift``·v, evaluate all contact
    forces, kick velocities by ``kick``·a.  When ``sampling``, also store the synchronised
    velocities v + sync·a into ``vout[row]`` (sync = Δt/2 when v holds half-step velocities, 0
    when it holds whole-step ones).  Returns ``max_ov`` raised to the largest new overlap."""
    n = y.size
    inv_m = 1.0 / m
    y[0] += drift * v[0]
    delta = 0.5 * d - (y[0] - floor)
    f_below, dmax[0] = _walton_braun(delta, dmax[0], k1, k2)
    if delta > max_ov:
        max_ov = delta
    for k in range(1, n):                 # contact k: between spheres k-1 and k (0-based)
        y[k] += drift * v[k]
        delta = d - (y[k] - y[k - 1])
        f, dmax[k] = _walton_braun(delta, dmax[k], k1, k2)
        max_ov = max(max_ov, delta)
        a = (f_below - f) * inv_m - g
        if sampling:
            vout[row, k - 1] = v[k - 1] + sync * a
        v[k - 1] += kick * a
        f_below = f
    a = f_below * inv_m - g
    if sampling:
        vout[row, n - 1] = v[n - 1] + sync * a
    v[n - 1] += kick * a
    return max_ov


@numba.njit(cache=True)
def _record(row, t, floor, floor0, y, dmax, d, m, g, k1, k2, out_t, out_y, out_v, out_floor,
            out_ke, out_pe, out_el):
    """Store sample ``row`` (``out_v[row]`` is already filled by :func:`_pass`): positions,
    time, floor and the energies.  Contact memories ``dmax`` are those after the last force
    evaluation, so re-evaluating the force law reproduces the forces F and the recoverable
    elastic energy is Σ F²/(2 K2)."""
    n = y.size
    ke = 0.0
    pe = 0.0
    el = 0.0
    for k in range(n):
        out_y[row, k] = y[k]
        ke += out_v[row, k] * out_v[row, k]
        pe += y[k] - floor0
        delta = (0.5 * d - (y[0] - floor)) if k == 0 else (d - (y[k] - y[k - 1]))
        f = _walton_braun(delta, dmax[k], k1, k2)[0]
        el += f * f
    out_t[row] = t
    out_floor[row] = floor
    out_ke[row] = 0.5 * m * ke
    out_pe[row] = m * g * pe
    out_el[row] = 0.5 * el / k2


@functools.lru_cache(maxsize=32)
def make_dem_loop(fn):
    """Compiled time loop with the floor motion ``fn(t, p) -> (ϑ, ϑ', ϑ'')`` built in.

    Cached per ``fn``: each motion function is compiled into a loop once per process.  The
    returned function is

        loop(y, v, dmax, dt, n_steps, sample_every, ramp_time, d, m, g, k1, k2, p,
             out_t, out_y, out_v, out_floor, out_ke, out_pe, out_el) -> largest overlap [m]

    It advances positions ``y``, velocities ``v`` and contact memories ``dmax`` in place by
    ``n_steps`` steps of ``dt`` from t = 0, recording a sample every ``sample_every`` steps
    (including t = 0).  Gravity rises as g·S(t / ramp_time) (S a smooth step) if
    ``ramp_time > 0``.  On return ``v`` holds the synchronised velocities at the last step.
    """

    @numba.njit
    def loop(y, v, dmax, dt, n_steps, sample_every, ramp_time, d, m, g, k1, k2, p,
             out_t, out_y, out_v, out_floor, out_ke, out_pe, out_el):
        half = 0.5 * dt
        floor0 = fn(0.0, p)[0]
        g_now = 0.0 if ramp_time > 0.0 else g
        # t = 0: forces at the initial positions, first half kick, first sample
        max_ov = _pass(y, v, dmax, floor0, 0.0, half, 0.0, d, m, g_now, k1, k2, out_v, 0, True,
                       -np.inf)
        _record(0, 0.0, floor0, floor0, y, dmax, d, m, g_now, k1, k2, out_t, out_y, out_v,
                out_floor, out_ke, out_pe, out_el)
        row = 1
        countdown = sample_every
        for step in range(1, n_steps + 1):
            t = step * dt
            floor = fn(t, p)[0]
            if ramp_time > 0.0:
                g_now = g * _smooth_ramp(t / ramp_time)
            countdown -= 1
            sampling = countdown == 0
            kick = half if step == n_steps else dt      # the last step ends synchronised
            max_ov = _pass(y, v, dmax, floor, dt, kick, half, d, m, g_now, k1, k2, out_v, row,
                           sampling, max_ov)
            if sampling:
                _record(row, t, floor, floor0, y, dmax, d, m, g_now, k1, k2, out_t, out_y, out_v,
                        out_floor, out_ke, out_pe, out_el)
                row += 1
                countdown = sample_every
        return max_ov

    return loop


# ----------------------------------------------------------------------------- driver


def _state_array(name, value, n):
    if value is None:
        return None
    try:
        a = np.array(value, dtype=np.float64, copy=True).reshape(-1)
    except (TypeError, ValueError):
        a = None
    if a is None or a.shape != (n,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be {n} finite numbers (one per sphere); got shape "
                         f"{np.shape(value)}")
    return a


MAX_STEPS = 1_000_000_000
"""The most steps :func:`run_dem` takes (its compiled loop runs them in one call, so that a
Ctrl-C or SIGTERM waits for its end: 1–2 minutes at 1e9 for the 20-sphere column on the
machines of 2026-12, whose default run of 1.47e6 steps takes 0.08–0.18 s)."""


def run_dem(column: DEMColumn, motion, t_end: float, sample_interval: float = 1e-3,
            initial_positions=None, initial_velocities=None, initial_delta_max=None,
            gravity_ramp: float = 0.0) -> DEMResult:
    """Integrate the column from t = 0 to ``t_end`` [s] with the floor following ``motion``.

    Parameters
    ----------
    column : :class:`DEMColumn`.
    motion : :class:`~bsrflow.physics.motion.AppliedMotion`; floor at ``motion.fn(t, params)[0]``.
    t_end : end time [s], > 0.  Samples are taken at ``i * sample_interval`` for
        ``i = 0 .. floor(t_end / sample_interval)`` and the run stops at the last sample.
    sample_interval : time between samples [s], in (0, t_end].
    initial_positions : (N,) centres [m], strictly increasing, bottom centre above the floor.
        Default: touching spheres on the floor, y_k = ϑ(0) + (2k - 1) d / 2.
    initial_velocities : (N,) velocities [m/s]; default 0.
    initial_delta_max : (N,) contact memory δ_max [m] (index j: contact beneath sphere j),
        >= 0, e.g. ``result.delta_max`` of a previous run.  Default 0: closed contacts start
        on the loading line.
    gravity_ramp : if > 0, gravity rises smoothly from 0 to g over this time [s] (a settling
        device, see :func:`settle`); the potential energy uses the gravity of the moment.

    The time step is ``Δt = sample_interval / ceil(sample_interval / column.dt)``, at most
    ``column.dt``, so that the samples fall on steps.

    Returns
    -------
    :class:`DEMResult`.  Raises RuntimeError if some overlap reached d/2 (spheres passing
    through each other or through the floor: the contact model is far outside its range).
    """
    if not isinstance(column, DEMColumn):
        raise TypeError(f"column must be a DEMColumn, got {type(column).__name__}")
    t_end = _real("t_end", t_end, "(0, inf) s")
    if t_end <= 0:
        raise _bad("t_end", t_end, "(0, inf) s")
    sample_interval = _real("sample_interval", sample_interval, f"(0, t_end = {t_end}] s")
    if not 0.0 < sample_interval <= t_end * (1 + 1e-12):
        raise _bad("sample_interval", sample_interval, f"(0, t_end = {t_end}] s")
    gravity_ramp = _real("gravity_ramp", gravity_ramp, "[0, inf) s")
    if gravity_ramp < 0:
        raise _bad("gravity_ramp", gravity_ramp, "[0, inf) s")
    fn = getattr(motion, "fn", None)
    if fn is None or not hasattr(motion, "params"):
        raise ValueError(f"motion = {motion!r} is not an AppliedMotion (needs .fn and .params)")
    params = np.ascontiguousarray(motion.params, dtype=np.float64)

    n, d = column.n_spheres, column.diameter
    floor0 = float(fn(0.0, params)[0])
    y = _state_array("initial_positions", initial_positions, n)
    if y is None:
        y = floor0 + (np.arange(n) + 0.5) * d
    elif np.any(np.diff(y) <= 0) or y[0] <= floor0:
        raise ValueError("initial_positions must be strictly increasing with the bottom centre "
                         f"above the floor at {floor0} m")
    v = _state_array("initial_velocities", initial_velocities, n)
    if v is None:
        v = np.zeros(n)
    dmax = _state_array("initial_delta_max", initial_delta_max, n)
    if dmax is None:
        dmax = np.zeros(n)
    elif np.any(dmax < 0):
        raise ValueError("initial_delta_max must be >= 0")

    sample_every = max(1, math.ceil(sample_interval / column.dt * (1 - 1e-12)))
    dt = sample_interval / sample_every
    n_samples = int(math.floor(t_end / sample_interval * (1 + 1e-12))) + 1
    n_steps = (n_samples - 1) * sample_every
    if n_steps > MAX_STEPS:
        raise ValueError(f"the DEM would take {n_steps:.3g} steps of {dt:.3g} s (the contact time of spheres of "
                         f"d = {d:g} m at K = {column.loading_stiffness:g} N/m) to t_end = {t_end:g} s; valid: at "
                         f"most {MAX_STEPS:.0e} steps (larger spheres or a softer contact)")

    out_t = np.empty(n_samples)
    out_y = np.empty((n_samples, n))
    out_v = np.empty((n_samples, n))
    out_floor, out_ke, out_pe, out_el = (np.empty(n_samples) for _ in range(4))
    loop = make_dem_loop(fn)
    if not loop.signatures:           # compile first, so that wall_time measures the run only
        loop(y.copy(), v.copy(), dmax.copy(), dt, 0, 1, gravity_ramp, d, column.mass,
             column.gravity, column.loading_stiffness, column.unloading_stiffness, params,
             *(a[:1].copy() for a in (out_t, out_y, out_v, out_floor, out_ke, out_pe, out_el)))
    start = time.perf_counter()
    max_ov = loop(y, v, dmax, dt, n_steps, sample_every, gravity_ramp, d, column.mass,
                  column.gravity, column.loading_stiffness, column.unloading_stiffness, params,
                  out_t, out_y, out_v, out_floor, out_ke, out_pe, out_el)
    wall = time.perf_counter() - start
    if not max_ov < 0.5 * d:
        raise RuntimeError(f"an overlap reached {max_ov:.3g} m >= d/2 = {0.5 * d:.3g} m: spheres "
                           "passed through each other or the floor (stiffness too low for the "
                           "imposed motion?)")
    return DEMResult(out_t, out_y, out_v, out_floor, out_ke, out_pe, out_el, dt, column, dmax,
                     float(max_ov), wall)


def settle(column: DEMColumn, t_settle: float = 0.3, ramp_time: float | None = None,
           sample_interval: float = 1e-3) -> DEMResult:
    """Let the column come to rest on a resting floor, starting from touching spheres.

    Gravity is switched on smoothly over ``ramp_time`` [s] (default ``t_settle / 2``), slowly
    compared with the column's longest vibration period, about ``4 N sqrt(m / K1)`` (1.8 ms
    for the default 20 spheres).  Every contact then loads quasi-statically along the loading
    line and the column ends at rest at :func:`static_overlaps`.

    Why the ramp: a column released at once from touching contact overshoots (dynamic load,
    δ_max ≈ 2 W / K1 with W the weight a contact carries) and the Walton-Braun memory keeps
    the overshoot.  Its contacts end up vibrating along their K2 lines around
    ``δ = δ_max - (K1 δ_max - W) / K2``, which is above ``W / K1`` (measured for 20 spheres:
    1.2-1.3 W/K1 for e = 0.9, 1.7-3 W/K1 for e = 0.5), and since motion along a K2 line is
    elastic the vibration (20-40 % of W/K1 rms for e = 0.9) decays only very slowly.  These
    overlaps are ~1e-7 m, irrelevant for taps of millimetres, but they are not the static
    force-balance state.

    Returns the :class:`DEMResult` of the settling run; continue from it with
    ``run_dem(..., initial_positions=r.positions[-1], initial_velocities=r.velocities[-1],
    initial_delta_max=r.delta_max)``.
    """
    from .motion import Rest

    t_settle = _real("t_settle", t_settle, "(0, inf) s")
    if t_settle <= 0:
        raise _bad("t_settle", t_settle, "(0, inf) s")
    if ramp_time is None:
        ramp_time = 0.5 * t_settle
    ramp_time = _real("ramp_time", ramp_time, f"(0, t_settle = {t_settle}] s")
    if not 0.0 < ramp_time <= t_settle:
        raise _bad("ramp_time", ramp_time, f"(0, t_settle = {t_settle}] s")
    return run_dem(column, Rest(), t_settle, sample_interval=min(sample_interval, t_settle),
                   gravity_ramp=ramp_time)
