"""The packing interaction: the continuum limit of the DEM's own contact law (issue #18).

A column of spheres of diameter d [m] and mass m = ρ_s π d³/6 [kg] carries its load through
contacts.  In the continuum, ρ [kg/m] is the mass per length of the column (1-D), so the mean
spacing of sphere centres is m/ρ [m] and the overlap per contact is

    δ = d − m/ρ                                                         [m]

(δ ≤ 0: the spheres do not touch).  The force one contact transmits is the Walton–Braun law of
the DEM (:mod:`bsrflow.physics.dem`), with the largest overlap δ_max reached since the material
last separated as a history variable:

    loading    (δ ≥ δ_max):  P = K1 δ,                  δ_max ← δ
    unloading  (δ < δ_max):  P = max(0, K2 (δ − δ0)),   δ0 = δ_max (1 − K1/K2)
    separated  (δ ≤ 0):      P = 0,                     δ_max ← 0 (the reset)

K1 = K the DEM's loading stiffness [N/m], K2 = K/e² its unloading stiffness, e the restitution.
P [N] is the compressive force of the column (the 1-D stress; never tensile).  Written without
branches as P = max(0, K1 δ* − K2 (δ* − δ)) with δ* = max(δ_max, δ), as in the DEM.

Momentum balance (floor frame, seed (3.13)–(3.17)):

    u_t + u u_x = e(t) − (1/ρ) ∂P/∂x,        ρ_t + (ρ u)_x = 0,        (ρ δ_max)_t + (ρ u δ_max)_x = 0,

e(t) = −g − ϑ''(t) [m/s²] the gravity and the floor's inertial acceleration (with the impulses of
the tap's velocity jumps, :mod:`bsrflow.physics.motion`).  The history is carried by the material
(its last equation; in the Lagrangian form it simply stays with its material bond).

BSR form
--------
The interaction is an integral over the ball B_R(x) whose kernel sees the state (density and
history) at both points, as in SPH:

    ∫_{B_R(x)} ρ(y) Θ(x, y, s(x), s(y)) dy,
    Θ = −[P(s(x))/ρ(x)² + P(s(y))/ρ(y)²] ∂W_R(x − y)/∂x,

with W_R ≥ 0 an even weight of unit integral supported in [−R, R] [1/m], s = (ρ, δ_max).  Its
local limit: ∫ρ(y) P(y)/ρ(y)² ∂_x W dy = ∂_x[(P/ρ) * W] → ∂_x(P/ρ), ∫ρ(y) ∂_x W dy → ρ_x, so
the integral tends to −(P/ρ²) ρ_x − ∂_x(P/ρ) = −(1/ρ) ∂P/∂x as R → 0.  It conserves momentum:
∫ρ(x) ∫ρ(y) Θ dy dx = 0, since the bracket is symmetric in (x, y) and ∂_x W_R(x − y) is odd.
Units: Θ [N m²/kg² · 1/m² = m/s² · m/kg], ρ dy [kg], the integral [m/s²].

Choice of R: the local form (``range_over_d = 0``) uses the smallest consistent R, one grid
spacing / one material-point spacing, so that the model is the local limit: (a) Eulerian: the
finite-volume flux difference of P is the R → 0 limit; (b) Lagrangian: with material points at
spacing h = d/n, a top-hat W of radius h reduces the sum over points to the nearest neighbours,
i.e. a pair force P between neighbouring points, computed from the density of the material
between them (the density by characteristics (3.10)–(3.12): ρ = (m/n)/(x_{i+1} − x_i)), equal and
opposite on both (momentum exact).  The package's packing continuum is the nonlocal form
(``range_over_d`` > 0, R = d by default in the Lagrangian formulation): bonds between material up
to the mass m R/d apart, each a contact with its own history, weighted by :func:`bond_weights`
(:mod:`bsrflow.numerics.packing_nonlocal`, docs/model.md "The nonlocal interaction").

Compared with the seed's kernel (4.6)
-------------------------------------
Kept: a pairwise, repulsive, hysteretic Walton–Braun interaction with the DEM's K1 and K2, an
interaction range at the particle scale, the floor frame, the moving-frame forcing.
Dropped: the seed's Θ = −λ(R − |z|)σ(z)(1 − εσ(zΔu)) is linear in ρ (every pair of material
elements within R repels), so its continuum is a γ = 2 gas, P = κρ²/2, soft at every density;
a packing instead carries no load below contact (ρ < m/d) and the contact stiffness above it.
No fitted constant (m0, ε) remains: only K, e, d, the material density ρ_s, the number of
spheres N (through the initial state) and g enter.

Wave speed: c² = dP/dρ = K_b m/ρ² with K_b the stiffness of the branch (K1 loading, K2
unloading), 0 for δ ≤ 0; the time step uses the bound c = √(K2 m)/ρ for ρ > m/d.  At close
packing c = d√(K2/m) ≈ 1100 m/s for the seed's column (d = 2.2 cm).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from .interaction import Interaction, constant_wave_speed

__all__ = ["PackingLaw", "BilinearStiffness", "bond_lags", "bond_weights", "MAX_RANGE_OVER_D", "packing_force", "packing_wave_speed", "history_update",
           "impact_speed", "stiffness_factor_for_mach", "packing_force_numpy", "single_contact_restitution"]


@numba.njit(cache=True, inline="always")
def packing_force(delta, dmax, k1, k2):
    """Contact force P [N] at overlap ``delta`` [m] with history ``dmax`` [m] (module docstring)."""
    dm = max(dmax, delta)
    return max(0.0, k1 * dm - k2 * (dm - delta))


@numba.njit(cache=True, inline="always")
def history_update(delta, dmax):
    """New δ_max [m]: max(δ_max, δ) while in contact, 0 once the material separates (δ ≤ 0)."""
    return max(dmax, delta) if delta > 0.0 else 0.0


@numba.njit(cache=True, inline="always")
def packing_wave_speed(rho, d, m, k2):
    """Bound on the sound speed [m/s] at line density ``rho`` [kg/m]: √(K2 m)/ρ above close
    packing (ρ > m/d), 0 below."""
    if rho * d > m:
        return math.sqrt(k2 * m) / rho
    return 0.0


def impact_speed(launch_speed, gravity, diameter) -> float:
    """Upper bound [m/s] on the speed at which packed material meets the floor or itself: the
    launch speed bound (3aω for a floor of speed amplitude aω, the energy bound), at least the
    free-fall speed √(2 g d) of one diameter (the impact Mach number's speed, docs/model.md)."""
    return max(launch_speed, math.sqrt(2.0 * gravity * diameter))


def stiffness_factor_for_mach(impact, true_wave_speed, mach) -> float:
    """The reduced-stiffness option's rule: the smallest factor φ in (0, 1] for which the impact
    Mach number ``impact``/c stays at most ``mach`` in (0, 1]: φ = min(1, (v / (mach c_true))²),
    since c ∝ √φ (docs/model.md, "Stiffness")."""
    if not (math.isfinite(mach) and 0.0 < mach <= 1.0):
        raise ValueError(f"mach = {mach!r} is outside the valid range (0, 1]")
    ratio = impact / (mach * true_wave_speed)          # >= 1: the true stiffness is needed (no overflow)
    return 1.0 if not ratio < 1.0 else float(ratio * ratio)


def packing_force_numpy(delta, dmax, k1, k2):
    """NumPy twin of :func:`packing_force` (arrays)."""
    dm = np.maximum(dmax, delta)
    return np.maximum(0.0, k1 * dm - k2 * (dm - delta))


class BilinearStiffness:
    """The stiffness pieces the 1-D and the n-D packing laws share (a mixin of the dataclasses
    :class:`PackingLaw` and :class:`bsrflow.numerics.packing_nd.PackingLawND`, which hold
    ``stiffness``, ``restitution`` and ``stiffness_factor`` and define :meth:`wave_speed`, the
    sound speed at close packing).  Units: those of ``stiffness``, N/m in 1-D, Pa/m in n-D."""

    @property
    def k1(self) -> float:
        """Loading stiffness used: ``stiffness`` times the stiffness factor."""
        return self.stiffness * self.stiffness_factor

    @property
    def k2(self) -> float:
        """Unloading stiffness used, K1/e²."""
        return self.k1 / self.restitution ** 2

    def wave_speed_bound(self, state=None) -> float:
        """The sound speed at close packing (:meth:`wave_speed`) [m/s] for every state: no denser
        state has a faster wave."""
        return self.wave_speed()

    def compiled_wave_speed(self):
        """(:func:`~bsrflow.physics.interaction.constant_wave_speed`, [:meth:`wave_speed`])."""
        return constant_wave_speed, np.array([self.wave_speed()])


@dataclass(frozen=True)
class PackingLaw(BilinearStiffness, Interaction):
    """The packing interaction's constants (SI units): an
    :class:`~bsrflow.physics.interaction.Interaction` whose kernel reads the density and the
    history field at both points (module docstring) and whose wave-speed bound is the sound speed
    at close packing, d √(K2/m), which no state exceeds (c(ρ) = √(K2 m)/ρ above ρ_c, 0 below).

    stiffness K [N/m] (the DEM's loading stiffness K1), restitution e in (0, 1] (K2 = K/e²),
    diameter d [m], density ρ_s [kg/m³] of the sphere material.  ``stiffness_factor`` in (0, 1]
    scales K1 and K2 together (the reduced-stiffness option, docs/model.md); 1 is the DEM's own.
    """

    stiffness: float
    restitution: float
    diameter: float
    density: float
    stiffness_factor: float = 1.0
    range_over_d: float = 0.0
    """R/d, the interaction range in sphere diameters: 0 the local limit (pair forces between
    neighbouring points or a finite-volume flux of P), > 0 the nonlocal packing interaction whose
    bonds join material up to the mass m R/d apart (:func:`bond_weights`, docs/model.md)."""

    def __post_init__(self):
        for name, v in (("stiffness", self.stiffness), ("diameter", self.diameter), ("density", self.density)):
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"{name} = {v!r} is outside the valid range (0, inf)")
        if not (0.0 < self.restitution <= 1.0):
            raise ValueError(f"restitution = {self.restitution!r} is outside the valid range (0, 1]")
        if not (0.0 < self.stiffness_factor <= 1.0):
            raise ValueError(f"stiffness_factor = {self.stiffness_factor!r} is outside the valid range (0, 1]")
        if not (np.isfinite(self.range_over_d) and 0.0 <= self.range_over_d <= MAX_RANGE_OVER_D):
            raise ValueError(f"range_over_d = {self.range_over_d!r} is outside the valid range "
                             f"[0, {MAX_RANGE_OVER_D:g}]")

    @property
    def is_nonlocal(self) -> bool:
        """True for the nonlocal interaction (``range_over_d`` > 0)."""
        return self.range_over_d > 0.0

    def bond_lags(self, points_per_diameter: int) -> int:
        """L of this law at ``points_per_diameter`` (:func:`bond_lags`)."""
        return bond_lags(self.range_over_d, points_per_diameter)

    def bond_weights(self, points_per_diameter: int) -> np.ndarray:
        """Weights w_ℓ, ℓ = 1..L, of the nonlocal interaction (:func:`bond_weights`)."""
        return bond_weights(self.bond_lags(points_per_diameter))

    @property
    def particle_mass(self) -> float:
        """m = ρ_s π d³/6 [kg]."""
        return self.density * math.pi / 6.0 * self.diameter ** 3

    @property
    def close_packing_density(self) -> float:
        """m/d [kg/m]: the line density of touching spheres."""
        return self.particle_mass / self.diameter

    state_fields = ("rho", "rho_delta_max")
    radius = property(lambda self: self.diameter, doc="R = d [m], the range of the BSR form (module docstring).")

    def wave_speed(self) -> float:
        """Sound speed bound at close packing, d √(K2/m) [m/s] (K1 = :attr:`k1`, K2 = :attr:`k2`
        [N/m] of :class:`BilinearStiffness`)."""
        return self.diameter * math.sqrt(self.k2 / self.particle_mass)

    def to_dict(self) -> dict:
        return {"name": "packing", "stiffness": self.stiffness, "restitution": self.restitution,
                "diameter": self.diameter, "density": self.density, "stiffness_factor": self.stiffness_factor,
                "range_over_d": self.range_over_d,
                "units": {"stiffness": "N m-1", "diameter": "m", "density": "kg m-3", "range_over_d": "1"}}

    def contact_time(self) -> float:
        """Duration of a two-sphere contact on the K1/K2 path, π/2 (√(μ/K1) + √(μ/K2)) with
        μ = m/2 [s]."""
        mu = 0.5 * self.particle_mass
        return 0.5 * math.pi * (math.sqrt(mu / self.k1) + math.sqrt(mu / self.k2))


MAX_RANGE_OVER_D = 4.0
"""Largest interaction range R/d accepted (the bonds of a point grow as ppd·R/d)."""


def bond_lags(range_over_d: float, points_per_diameter: int) -> int:
    """L, the number of bond lags of the range R/d = ``range_over_d`` at ``points_per_diameter``
    material points per diameter: bonds join points ℓ = 1..L apart, L = ppd R/d, which must be a
    whole number ≥ 1 (a range between two point spacings would be rounded to one of them, and one
    below a spacing is the local form: both are refused, ValueError naming ``range_over_d``)."""
    n = points_per_diameter * range_over_d
    L = int(round(n))
    if L < 1 or abs(n - L) > 1e-9 * max(1.0, n):
        raise ValueError(f"range_over_d = {range_over_d!r} is outside the valid range: 0, or a whole "
                         f"number of point spacings k/ppd = k/{points_per_diameter} (k = 1, 2, ...) up to "
                         f"{MAX_RANGE_OVER_D:g}")
    return L


def bond_weights(n_lags: int) -> np.ndarray:
    """Weights w_ℓ of the bonds ℓ = 1..L points apart (L = ``n_lags``) of the nonlocal packing
    interaction: the seed's kernel profile (R − |z|) of (4.6), a weight falling linearly to zero at
    the range, sampled at the bonds' midpoints, w_ℓ ∝ 1 − (ℓ − ½)/L, normalised so that
    Σ ℓ w_ℓ = 1.

    A bond of lag ℓ joins two material points the mass s = ℓ m/ppd apart; its overlap per contact
    is δ = d − m·(length)/s (the mean spacing of sphere centres in the material it spans, the
    density by characteristics) and it carries the force w_ℓ P(δ, δ_max) of the packing law.
    ℓ bonds of lag ℓ cross every section, so a uniform strain transmits Σ ℓ w_ℓ P = P: the
    local limit is the packing stress.  L = 1 is the local model's nearest-neighbour bond."""
    L = int(n_lags)
    if L < 1:
        raise ValueError(f"n_lags = {n_lags!r} is outside the valid range: integers >= 1")
    lags = np.arange(1, L + 1, dtype=float)
    raw = 1.0 - (lags - 0.5) / L
    return raw / float(np.sum(lags * raw))


def single_contact_restitution(law: PackingLaw, v0: float = 0.1, steps: int = 2000) -> float:
    """Restitution of one contact of the packing law: two half-spaces of the packed continuum,
    i.e. one material element of mass m (one sphere) hitting a rigid wall through one contact
    (the Lagrangian form at one point per diameter), integrated with velocity Verlet over
    ``steps`` steps per contact time.  Returns |v_out / v_in|."""
    m = law.particle_mass
    k1, k2 = law.k1, law.k2
    dt = math.pi * math.sqrt(m / k1) / steps
    x, v, dmax = 0.0, -abs(v0), 0.0          # x: position of the sphere's contact point; δ = -x
    f = 0.0
    for _ in range(50 * steps):
        v += 0.5 * dt * f / m
        x += dt * v
        delta = -x
        f = float(packing_force(delta, dmax, k1, k2))
        dmax = float(history_update(delta, dmax))
        v += 0.5 * dt * f / m
        if x > 0.0 and v > 0.0:
            break
    return abs(v / v0)
