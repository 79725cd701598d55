"""Applied (container / floor) motions ϑ(t), seed equations (3.13)-(3.16) and (4.5).

An applied motion is the prescribed vertical position of the container floor, ϑ(t) [m],
with its velocity ϑ'(t) [m/s] and acceleration ϑ''(t) [m/s^2].

* The DEM (:mod:`bsrflow.physics.dem`) moves the floor in the laboratory frame with
  ``state(t) -> (ϑ, ϑ', ϑ'')``.
* The continuum solver works in the frame moving with the floor (3.14)-(3.16): the
  momentum equation gains the inertial acceleration ``-ϑ''(t)`` and the velocity field
  is ``w = u - ϑ'``.  Where ϑ' jumps (the start and the end of a half-sine displacement
  pulse (4.5)), ϑ'' contains a Dirac impulse that the smooth formula ``a ω² sin ωt`` of
  (4.6) leaves out.  Each motion therefore also lists its velocity jumps: at a jump time
  ``t_j`` with jump ``Δ_j = ϑ'(t_j+) - ϑ'(t_j-)`` the solver shifts the whole velocity
  field by ``-Δ_j`` (seed-notes, known problem 3).

Writing a new motion
--------------------
Write one small numba-compilable function ``fn(t, p) -> (y, v, a)`` of the time ``t`` [s]
and a float64 parameter array ``p``, returning position, velocity and smooth acceleration
of the floor, and wrap it::

    import numba, numpy as np
    from bsrflow.physics.motion import AppliedMotion

    @numba.njit
    def shake(t, p):                      # ϑ = A sin²(ωt), p = (A [m], ω [1/s])
        s, c = np.sin(p[1] * t), np.cos(p[1] * t)
        return p[0] * s * s, 2.0 * p[0] * p[1] * s * c, 2.0 * p[0] * p[1] ** 2 * (c * c - s * s)

    motion = AppliedMotion(shake, params=[0.01, 60.0], name="shake")

If the velocity of your motion jumps, pass the jumps as ``jumps=[(t_j, Δ_j), ...]``.
The time loop is never touched: both solvers compile the function into their loop (a function
given without ``@numba.njit`` is compiled by ``AppliedMotion``, which also calls it once at t = 0
and refuses, in one line, one that numba cannot compile or that does not return three finite
numbers there).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field

import numba
import numpy as np

from .interaction import one_line

__all__ = [
    "AppliedMotion",
    "Rest",
    "HalfSineTaps",
    "SinusoidalVibration",
    "FREQUENCY_RANGE",
    "check_frequency",
]


MAX_SETTLE_TIME = 1e5
"""The longest time [s] a 2-D / 3-D scenario's floor rests before it moves (``settle_time``; the
column's ``tap.start`` range).  One at or after ``t_end`` is not refused: that run only settles."""


@numba.njit(cache=True)
def _rest_state(t, p):
    return 0.0, 0.0, 0.0


@numba.njit(cache=True)
def _half_sine_taps_state(t, p):
    """Train of half-sine displacement pulses (4.5).

    p = (amplitude a [m], angular frequency ω [1/s], start t0 [s], number of taps n,
    period T [s]).  Tap k (k = 0..n-1) occupies [t0 + kT, t0 + kT + π/ω] with
    ϑ = a sin(ω (t - t_k)); the floor is at rest at 0 elsewhere.
    """
    a = p[0]
    w = p[1]
    t0 = p[2]
    n = int(p[3])
    period = p[4]
    if t < t0:
        return 0.0, 0.0, 0.0
    # one tap: no train, the period plays no part (it may be shorter than the tap)
    k = int(math.floor((t - t0) / period)) if (period > 0.0 and n > 1) else 0
    if k >= n:
        return 0.0, 0.0, 0.0
    s = t - (t0 + k * period)
    if s < 0.0 or s > math.pi / w:
        return 0.0, 0.0, 0.0
    return a * math.sin(w * s), a * w * math.cos(w * s), -a * w * w * math.sin(w * s)


@numba.njit(cache=True)
def _sinusoid_state(t, p):
    """ϑ = a sin(ω (t - t0)) for t >= t0, at rest before.  p = (a [m], ω [1/s], t0 [s])."""
    a = p[0]
    w = p[1]
    t0 = p[2]
    if t < t0:
        return 0.0, 0.0, 0.0
    s = t - t0
    return a * math.sin(w * s), a * w * math.cos(w * s), -a * w * w * math.sin(w * s)


_JITTED: dict = {}
"""Plain motion functions compiled by :class:`AppliedMotion`, one numba object per function."""


@dataclass
class AppliedMotion:
    """A prescribed floor motion ϑ(t).

    Parameters
    ----------
    fn : function ``fn(t, p) -> (ϑ [m], ϑ' [m/s], ϑ'' [m/s^2])`` that numba can compile (a plain
        function is compiled here, once per function); ϑ'' is the smooth part of the
        acceleration only (no impulses).  It is called once at t = 0: three finite numbers, or a
        one-line ValueError.
    params : array of float
        Passed to ``fn`` as ``p``; changing them does not recompile anything.
    jumps : list of (time [s], velocity jump [m/s])
        Instants where ϑ' is discontinuous and the jump ϑ'(t+) - ϑ'(t-).
    name : str
        Short label used in outputs.
    """

    fn: object
    params: np.ndarray
    jumps: list = field(default_factory=list)
    name: str = "motion"

    def __post_init__(self):
        name = getattr(self.fn, "__name__", repr(self.fn))
        if not callable(self.fn) or isinstance(self.fn, type):
            raise ValueError(f"motion fn = {self.fn!r} is not a function fn(t, p) -> (ϑ [m], ϑ' [m/s], ϑ'' [m/s^2])")
        if not isinstance(self.fn, numba.core.dispatcher.Dispatcher):
            # compiled once per function: the time loop's cache is keyed on this object, so a new
            # one per AppliedMotion recompiled the whole loop for every amplitude of a sweep
            if self.fn not in _JITTED:
                try:
                    _JITTED[self.fn] = numba.njit(self.fn)
                except Exception as exc:
                    raise ValueError(f"motion fn {name} cannot be compiled by numba (give a plain Python "
                                     f"function): {one_line(exc)}") from None
            self.fn = _JITTED[self.fn]
        params = np.ascontiguousarray(np.atleast_1d(np.asarray(self.params, dtype=np.float64)))
        if not np.all(np.isfinite(params)):
            raise ValueError(f"motion params = {params.tolist()!r} must be finite numbers")
        self.params = params
        jumps = []
        for jump in self.jumps:
            try:
                t, dv = jump
                t, dv = float(t), float(dv)
            except (TypeError, ValueError):
                raise ValueError(f"motion jumps: {jump!r} is not a (time [s], velocity jump [m/s]) pair") from None
            if not (math.isfinite(t) and math.isfinite(dv)):
                raise ValueError(f"motion jumps: ({t!r}, {dv!r}) must be finite numbers (time [s], velocity jump [m/s])")
            jumps.append((t, dv))
        self.jumps = sorted(jumps)
        try:
            state = self.fn(0.0, self.params)
            state = tuple(float(v) for v in state)
            if len(state) != 3:
                raise TypeError(f"it returned {len(state)} values")
        except Exception as exc:                        # numba's typing errors, wrong returns
            raise ValueError(f"motion fn {name}(t, p) must compile with numba and return (ϑ [m], ϑ' [m/s], "
                             f"ϑ'' [m/s^2]); at t = 0: {one_line(exc)}") from None
        if not all(math.isfinite(v) for v in state):
            raise ValueError(f"motion fn {name}(0, p) = {state!r}: not finite")

    def state(self, t: float) -> tuple[float, float, float]:
        """(ϑ [m], ϑ' [m/s], smooth ϑ'' [m/s^2]) at time ``t`` [s]; at a velocity jump the value on
        either side may be returned (a half-sine tap gives ϑ' = aω at its start, the value after
        the jump, and −aω at its end, the value before it): use :attr:`jumps` for the jumps."""
        return self.fn(float(t), self.params)

    def displacement(self, t) -> np.ndarray:
        """ϑ(t) [m], vectorised over ``t``."""
        return np.array([self.fn(float(s), self.params)[0] for s in np.atleast_1d(t)])

    def velocity(self, t) -> np.ndarray:
        """ϑ'(t) [m/s], vectorised over ``t``."""
        return np.array([self.fn(float(s), self.params)[1] for s in np.atleast_1d(t)])

    def acceleration(self, t) -> np.ndarray:
        """Smooth part of ϑ''(t) [m/s^2], vectorised over ``t``."""
        return np.array([self.fn(float(s), self.params)[2] for s in np.atleast_1d(t)])

    def jumps_between(self, t_start: float, t_end: float) -> list[tuple[float, float]]:
        """Velocity jumps with ``t_start <= t_j < t_end`` (a jump at the start time of a run
        is applied before its first step)."""
        return [(t, dv) for t, dv in self.jumps if t_start <= t < t_end]

    def to_dict(self) -> dict:
        return {"name": self.name, "params": self.params.tolist(), "jumps": self.jumps}


def Rest() -> AppliedMotion:
    """A floor that never moves."""
    return AppliedMotion(_rest_state, np.zeros(1), [], name="rest")


def _check_positive(name, value, allow_zero=False):
    ok = value >= 0 if allow_zero else value > 0
    if not (np.isfinite(value) and ok):
        rng = "[0, inf)" if allow_zero else "(0, inf)"
        raise ValueError(f"{name} = {value!r} is outside the valid range {rng}")


def HalfSineTaps(amplitude: float, frequency: float, start: float = 0.0, n_taps: int = 1,
                 period: float | None = None) -> AppliedMotion:
    """Half-sine displacement taps (4.5): ϑ = a sin(ω (t - t_k)) on [t_k, t_k + π/ω].

    Parameters
    ----------
    amplitude : a [m]
    frequency : f [Hz], in :data:`FREQUENCY_RANGE`; ω = 2π f.  One tap lasts 1/(2f).
    start : time of the first tap t_0 [s]
    n_taps : number of taps
    period : time between tap starts [s]; with more than one tap at least the tap duration
        1/(2f); a single tap ignores it.  Default: 1 s.

    At each tap start ϑ' jumps from 0 to aω and at each tap end from -aω to 0, so both
    jumps are +aω; in the floor frame the material receives -aω at each.
    """
    _check_positive("amplitude", amplitude, allow_zero=True)
    check_frequency(frequency)
    _check_positive("start", start, allow_zero=True)
    if int(n_taps) != n_taps or n_taps < 1:
        raise ValueError(f"n_taps = {n_taps!r} is outside the valid range: integers >= 1")
    duration = 0.5 / frequency
    if period is None:
        period = 1.0
    _check_positive("period", period)
    if n_taps > 1 and period < duration:
        raise ValueError(f"period = {period!r} s is outside the valid range [{duration}, inf) "
                         "(a tap lasts 1/(2 f))")
    w = 2.0 * math.pi * frequency
    jumps = []
    for k in range(int(n_taps)):
        tk = start + k * period
        jumps += [(tk, amplitude * w), (tk + math.pi / w, amplitude * w)]
    m = AppliedMotion(_half_sine_taps_state, [amplitude, w, start, n_taps, period], jumps,
                      name="half_sine_taps")
    m.amplitude, m.frequency, m.start, m.n_taps, m.period = amplitude, frequency, start, n_taps, period
    return m


def SinusoidalVibration(amplitude: float, frequency: float, start: float = 0.0) -> AppliedMotion:
    """Sinusoidal vibration ϑ = a sin(2π f (t - t0)) for t >= t0 [m].

    The velocity jumps from 0 to aω at t0.
    """
    _check_positive("amplitude", amplitude, allow_zero=True)
    check_frequency(frequency)
    _check_positive("start", start, allow_zero=True)
    w = 2.0 * math.pi * frequency
    m = AppliedMotion(_sinusoid_state, [amplitude, w, start], [(start, amplitude * w)],
                      name="sinusoidal_vibration")
    m.amplitude, m.frequency, m.start = amplitude, frequency, start
    return m


FREQUENCY_RANGE = (1e-3, 1e4)
"""The floor's frequency f [Hz] a layer or bed accepts (the tapped column's range)."""


def check_frequency(frequency) -> None:
    """Refuse a floor frequency [Hz] outside :data:`FREQUENCY_RANGE` (ValueError naming it)."""
    lo, hi = FREQUENCY_RANGE
    if isinstance(frequency, bool) or not (isinstance(frequency, numbers.Real) and lo <= frequency <= hi):
        raise ValueError(f"frequency = {frequency!r} is outside the valid range [{lo:g}, {hi:g}] Hz")
