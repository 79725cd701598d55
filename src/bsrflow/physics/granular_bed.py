"""The vibrated bed of issue #19 as a continuum: the packing stress plus a granular temperature.

Why a temperature.  The packing continuum alone (the contact law's stress, zero below contact,
:mod:`bsrflow.physics.packing`) has no pressure in the dilute state: run as the horizontally
uniform bed it lands as a block and bounces off the floor (flights of 37.5 ms on average at
Γ = 3 against LIGGGHTS's 27.2 ms, ``bench/check_bed_1d.py``), where the DEM bed dilates,
fluidises and lands grain by grain.  The grains' random motion carries momentum and energy; its
variance θ = ⟨C²⟩/3 [m²/s²] (the granular temperature) is the extra field.  The collisional
relations are the standard kinetic theory of smooth inelastic spheres (Lun, Savage, Jeffrey and
Chepurniy 1984, in the form used by Gidaspow 1994, Multiphase Flow and Fluidization), with
the Carnahan–Starling contact value g0; only d, ρ_s and the contact law's restitution e enter.

Fields (per unit area of the bed, floor frame): solid fraction φ, velocity u [m/s], θ [m²/s²],
and the history δ_max [m] of the packing law.  With ρ = ρ_s φ [kg/m³]:

    ρ (u_t + u u_z) = −ρ (g + ϑ''(t)) − ∂σ/∂z,      σ = p + σ_c + q          (momentum)
    (3/2) ρ (θ_t + u θ_z) = −(p + q) u_z + ∂/∂z (κ ∂θ/∂z) − γ             (fluctuation energy)

    g0(φ) = (1 − φ/2)/(1 − φ)³                                             (Carnahan–Starling)
    p = ρ_s φ θ [1 + 2 (1 + e) φ g0]                                       [Pa]
    λ = (4/3) ρ_s d φ² g0 (1 + e) √(θ/π)                                  (bulk viscosity) [Pa s]
    μ = (10 ρ_s d √(πθ)) / (96 (1 + e) g0) [1 + (4/5)(1 + e) φ g0]² + (4/5) ρ_s d φ² g0 (1 + e) √(θ/π)
    q = −(λ + 4μ/3) u_z                                                   (normal viscous stress)
    κ = (150 ρ_s d √(πθ)) / (384 (1 + e) g0) [1 + (6/5)(1 + e) φ g0]² + 2 ρ_s d φ² g0 (1 + e) √(θ/π)
    γ = 12 (1 − e²) g0 ρ_s φ² θ^{3/2} / (d √π)                            (collisional loss) [W/m³]

The packing (contact) stress σ_c: the Walton–Braun law of :mod:`bsrflow.physics.packing` per
layer of thickness d of the packing, for an isotropic packing of solid fraction φ_c with Z
contacts per sphere compressed uniaxially and affinely (a contact along n shortens by
d ε n_z²): σ_zz = n_c ⟨f l n_z²⟩ = (Z n/2) K d² ε ⟨n_z⁴⟩ = (3 Z φ_c K / (5 π d)) ε, n = 6φ_c/(πd³),
with ε = 1 − φ_c/φ (so δ = d ε is the layer's overlap).  As a force per layer of area A:
K_eff = 3 Z φ_c K A / (5 π d²) [N/m], unloading K_eff/e², history reset where δ ≤ 0.
Units: σ_c = WB(δ, δ_max)/A [Pa].

Floor (the vibrated plate, z = 0 in the floor frame; the floor moves as ϑ(t) = a sin ωt):
impermeable while it pushes, and it cannot pull (Shattuck 2007's cavitation condition): the bed's
bottom is held at z = 0 while the reaction is ≥ 0, free otherwise; the energy lost in the
collisions with the floor (restitution e_w: the spheres' e unless ``floor_restitution`` is given) is the flux
(1 − e_w) p √(2θ/π) into the floor while in contact (the Maxwellian flux of normal kinetic
energy onto a wall, ρ_w θ √(θ/(2π)), times the fraction 1 − e_w² lost, with the density at the
wall ρ_w = 2p/((1 + e_w)θ) from the pressure p the collisions exert on it: :func:`wall_loss`);
with ``floor_loss = "floor_reaction"`` (Lagrangian cells only) the whole floor reaction R takes
the place of p, (1 − e_w) R √(2θ/π) (:func:`wall_loss_from_reaction`).  Top: free surface (σ = 0,
no heat flux).

What is kept and dropped.  Kept: the contact law's K, e, d, ρ_s; the settled packing's φ_c and Z
(measured on the DEM's own settled bed, reference/liggghts_bed: 0.636, and 5.31 sphere–sphere
contacts per sphere; the floor contacts, which make it 5.39, do not stiffen the bulk), N and g.
Dropped: the −∇·u part of Lun et al.'s collisional loss (γ above is its θ^{3/2} part, as in MFIX
and OpenFOAM), friction and rotation, anisotropy of θ, the Knudsen layer at the dilute top and at the
floor (the kinetic relations are those of a dense, near-equilibrium gas), lateral structure (the
bed is horizontally uniform: this is the 1-D limit of the 3-D bed, which a horizontally uniform
3-D run equals; :mod:`bsrflow.numerics.bed_eulerian` runs the same relations on a 1-, 2- or 3-D
Eulerian grid).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numba
import numpy as np

from .._bounds import printed_bound
from .motion import check_frequency
from .packing_bed import MAX_STATIC_OVERLAP, MAX_STEPS      # the packing bed's bounds, the same here

__all__ = ["BedSetup", "g0_cs", "kinetic_pressure", "bulk_viscosity", "shear_viscosity", "pressure_and_viscosity",
           "conductivity",
           "dissipation", "wall_loss", "wall_loss_from_reaction", "FLOOR_LOSSES", "check_eulerian_floor_loss",
           "effective_restitution", "constitutive_numpy", "EulerianBedSetup",
           "check_eulerian_grid", "eulerian_vertical_cells"]

SQRT_PI = math.sqrt(math.pi)


@numba.njit(cache=True, inline="always")
def g0_cs(phi):
    """Carnahan–Starling contact value of the pair distribution, (1 − φ/2)/(1 − φ)³ (capped at
    φ = 0.95, far above close packing, where the contact stress rules)."""
    p = min(phi, 0.95)
    return (1.0 - 0.5 * p) / (1.0 - p) ** 3


@numba.njit(cache=True, inline="always")
def kinetic_pressure(phi, theta, rho_s, e):
    """p = ρ_s φ θ [1 + 2(1 + e) φ g0] [Pa]."""
    return rho_s * phi * theta * (1.0 + 2.0 * (1.0 + e) * phi * g0_cs(phi))


@numba.njit(cache=True, inline="always")
def bulk_viscosity(phi, theta, rho_s, d, e):
    """λ = (4/3) ρ_s d φ² g0 (1 + e) √(θ/π) [Pa s]."""
    return (4.0 / 3.0) * rho_s * d * phi * phi * g0_cs(phi) * (1.0 + e) * math.sqrt(max(theta, 0.0)) / SQRT_PI


@numba.njit(cache=True, inline="always")
def shear_viscosity(phi, theta, rho_s, d, e):
    """μ (module docstring) [Pa s]."""
    g = g0_cs(phi)
    st = math.sqrt(max(theta, 0.0))
    return (10.0 * rho_s * d * st * SQRT_PI / (96.0 * (1.0 + e) * g) * (1.0 + 0.8 * (1.0 + e) * phi * g) ** 2
            + 0.8 * rho_s * d * phi * phi * g * (1.0 + e) * st / SQRT_PI)


@numba.njit(cache=True, inline="always")
def pressure_and_viscosity(phi, theta, rho_s, d, e):
    """(p [Pa], λ + 4μ/3 [Pa s]): the pressure and the normal-stress viscosity of the functions
    above with one g0 and one square root (the step's hot loop; tested against them)."""
    g = g0_cs(phi)
    st = math.sqrt(max(theta, 0.0))
    ope = 1.0 + e
    coll = rho_s * d * phi * phi * g * ope * st / SQRT_PI          # ρ_s d φ² g0 (1+e) √(θ/π)
    mu_s = 10.0 * rho_s * d * st * SQRT_PI / (96.0 * ope * g) * (1.0 + 0.8 * ope * phi * g) ** 2 + 0.8 * coll
    return rho_s * phi * theta * (1.0 + 2.0 * ope * phi * g), (4.0 / 3.0) * coll + (4.0 / 3.0) * mu_s


@numba.njit(cache=True, inline="always")
def conductivity(phi, theta, rho_s, d, e):
    """κ (module docstring) [kg/(m s)]: the flux of fluctuation energy is −κ ∂θ/∂z [W/m²]."""
    g = g0_cs(phi)
    st = math.sqrt(max(theta, 0.0))
    return (150.0 * rho_s * d * st * SQRT_PI / (384.0 * (1.0 + e) * g) * (1.0 + 1.2 * (1.0 + e) * phi * g) ** 2
            + 2.0 * rho_s * d * phi * phi * g * (1.0 + e) * st / SQRT_PI)


@numba.njit(cache=True, inline="always")
def dissipation(phi, theta, rho_s, d, e):
    """γ = 12 (1 − e²) g0 ρ_s φ² θ^{3/2} / (d √π) [W/m³]."""
    t = max(theta, 0.0)
    return 12.0 * (1.0 - e * e) * g0_cs(phi) * rho_s * phi * phi * t * math.sqrt(t) / (d * SQRT_PI)


@numba.njit(cache=True, inline="always")
def wall_loss(phi, theta, rho_s, e, e_w):
    """Energy flux into the floor from the collisions with it [W/m²]:
    (1 − e_w) p √(2θ/π) = (1 − e_w²) ρ_w θ √(θ/(2π)), p the kinetic pressure of the bed at the
    floor (:func:`kinetic_pressure`, sphere–sphere restitution e).  A Maxwellian of density ρ_w
    at the wall brings the normal kinetic energy ρ_w θ √(θ/(2π)) per unit area and time, of which
    the fraction (1 − e_w²) is lost, and the momentum it gives the wall, (1 + e_w) ρ_w θ/2, is the
    pressure p there (the contact theorem of hard spheres at a hard wall): ρ_w = 2p/((1 + e_w)θ),
    which for elastic spheres and floor is ρ_s φ (1 + 4φg0), the wall's contact density (not the
    spheres' pair contact value ρ_s φ g0, which the package used before 2026-12-02)."""
    t = max(theta, 0.0)
    return (1.0 - e_w) * kinetic_pressure(phi, t, rho_s, e) * math.sqrt(2.0 * t / math.pi)


@numba.njit(cache=True, inline="always")
def wall_loss_from_reaction(reaction, theta, e_w):
    """Energy flux into the floor from the collisions with it [W/m²] with the whole floor reaction
    R [Pa] (``floor_loss = "floor_reaction"``): (1 − e_w) R √(2θ/π), the contact theorem of
    :func:`wall_loss` with every unit of the floor's momentum delivered by collisions, the
    contacts' elastic stress included.  It holds where the bottom layer is a dense gas pressed
    onto the floor rather than a packing resting on it: measured in the LIGGGHTS bed at Γ = 2, 3,
    4.5 (``reference/liggghts_bed/run_liggghts.py --floor-power``), this form on LIGGGHTS's own
    floor state gives 104–135 % of its sphere–floor contacts' loss, :func:`wall_loss` 6–26 %
    (docs/model.md, "The floor's share, measured").  A bed at rest on the floor (θ → 0) loses
    nothing."""
    return (1.0 - e_w) * reaction * math.sqrt(2.0 * max(theta, 0.0) / math.pi)


FLOOR_LOSSES = ("kinetic_pressure", "floor_reaction")
"""The closures of the floor's collisional loss (:attr:`BedSetup.floor_loss`), in the order of the
compiled step's ``wall_mode`` (0: :func:`wall_loss`, 1: :func:`wall_loss_from_reaction`)."""


def check_eulerian_floor_loss(floor_loss) -> None:
    """Refuse (ValueError, one line) a floor loss the Eulerian grid does not have: it takes only
    ``"kinetic_pressure"`` (:class:`EulerianBedSetup`, and
    :class:`bsrflow.numerics.bed_eulerian.EulerianBed` for any setup)."""
    if not (isinstance(floor_loss, str) and floor_loss == "kinetic_pressure"):
        raise ValueError(f"floor_loss = {floor_loss!r} is not one of the valid values on the Eulerian grid: "
                         "'kinetic_pressure' ('floor_reaction' is an option of the Lagrangian cells, "
                         "kind = \"granular_bed\")")


def effective_restitution(e: float, friction: float) -> float:
    """e_eff = e − (3/2) μ exp(−3μ) (Chialvo and Sundaresan 2013's effective restitution of
    frictional spheres, :attr:`BedSetup.dissipation_restitution`); e itself when μ = 0."""
    if friction == 0.0:
        return e
    return e - 1.5 * friction * math.exp(-3.0 * friction)


def constitutive_numpy(phi, theta, rho_s, d, e):
    """NumPy twin of the relations above (arrays): dict of g0, p, λ, μ, κ, γ."""
    phi = np.asarray(phi, float)
    t = np.maximum(np.asarray(theta, float), 0.0)
    p_ = np.minimum(phi, 0.95)
    g = (1.0 - 0.5 * p_) / (1.0 - p_) ** 3
    st = np.sqrt(t)
    return {
        "g0": g,
        "p": rho_s * phi * t * (1.0 + 2.0 * (1.0 + e) * phi * g),
        "lambda": (4.0 / 3.0) * rho_s * d * phi ** 2 * g * (1.0 + e) * st / SQRT_PI,
        "mu": (10.0 * rho_s * d * st * SQRT_PI / (96.0 * (1.0 + e) * g) * (1.0 + 0.8 * (1.0 + e) * phi * g) ** 2
               + 0.8 * rho_s * d * phi ** 2 * g * (1.0 + e) * st / SQRT_PI),
        "kappa": (150.0 * rho_s * d * st * SQRT_PI / (384.0 * (1.0 + e) * g) * (1.0 + 1.2 * (1.0 + e) * phi * g) ** 2
                  + 2.0 * rho_s * d * phi ** 2 * g * (1.0 + e) * st / SQRT_PI),
        "gamma": 12.0 * (1.0 - e * e) * g * rho_s * phi ** 2 * t * st / (d * SQRT_PI),
    }


@dataclass(frozen=True)
class BedSetup:
    """The vibrated bed (SI units; defaults: reference/liggghts_bed/params.json, the LIGGGHTS
    runs' bed).

    n_spheres N, diameter d [m], density ρ_s [kg/m³], stiffness K [N/m] (the contact law's
    loading stiffness; the LIGGGHTS runs use a reduced K and so does the continuum), restitution
    e (spheres and floor), friction μ in [0, 1] (the contacts' Coulomb coefficient, which enters
    only through the losses' effective restitution, :attr:`dissipation_restitution`; 0: smooth
    spheres), side L [m] of the laterally periodic box, phi_c φ_c and
    coordination Z of the settled packing, gravity g [m/s²], frequency f [Hz], gamma Γ = aω²/g
    of the floor ϑ(t) = a sin ωt (starting at t = 0 moving up at aω, as the LIGGGHTS deck),
    cycles (the run lasts cycles/f), settle [s]: time on the resting floor before t = 0 after
    the bed at rest (:func:`bsrflow.numerics.bed_lagrangian.static_bed`; 0 by default); numerics:
    n_cells (Lagrangian cells over the bed), cfl (of the contact wave speed), theta_seed
    [m²/s²] (the temperature at the start, the DEM bed's residual motion; 0 is an absorbing
    state: without a seed and without shocks θ stays 0), save_every [s]; output_height [m]: the
    top of the fixed output grid of ``bsrflow run`` (``kind = "granular_bed"``; None: the rest
    height + (3aω)²/(2g) + 10 d, :meth:`energy_bound_height`).  200 cells and
    cfl 0.4: the Γ = 3 comparison's flight time and mass-centre RMS change by 0.1 % and 0.01 d
    against 400 cells.  floor_restitution e_w in (0, 1]: the sphere–floor contacts' restitution
    where it is not e (None: e), used only in the floor's loss (:func:`wall_loss`; with friction
    through :attr:`floor_dissipation_restitution`); 1 makes the floor's collisions elastic.
    floor_loss: the closure of the floor's collisional loss, ``"kinetic_pressure"`` (the default,
    :func:`wall_loss`: the kinetic pressure p at the floor) or ``"floor_reaction"``
    (:func:`wall_loss_from_reaction`: the whole floor reaction R, the form LIGGGHTS's measured
    floor loss supports; the Lagrangian cells only).
    """

    n_spheres: int = 2000
    diameter: float = 0.005
    density: float = 1200.0
    stiffness: float = 5e4
    restitution: float = 0.9
    friction: float = 0.0
    side: float = 0.065
    phi_c: float = 0.636
    coordination: float = 5.31
    gravity: float = 9.81
    frequency: float = 20.0
    gamma: float = 3.0
    cycles: int = 11
    settle: float = 0.0
    n_cells: int = 200
    cfl: float = 0.4
    theta_seed: float = 1e-6
    save_every: float = 1e-4
    output_height: float | None = None
    floor_restitution: float | None = None
    floor_loss: str = "kinetic_pressure"

    def __post_init__(self):
        if not isinstance(self.floor_loss, str) or self.floor_loss not in FLOOR_LOSSES:
            raise ValueError(f"floor_loss = {self.floor_loss!r} is not one of the valid values: "
                             f"{' or '.join(repr(v) for v in FLOOR_LOSSES)}")
        for name, lo, hi in (("diameter", 0.0, 1.0), ("density", 0.0, 1e5), ("stiffness", 0.0, 1e12),
                             ("side", 0.0, 100.0), ("gravity", 0.0, 1e3), ("save_every", 0.0, 1.0)):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and lo < v <= hi):
                raise ValueError(f"{name} = {v!r} is outside the valid range ({lo:g}, {hi:g}]")
        check_frequency(self.frequency)            # the range of every floor motion, [1e-3, 1e4] Hz
        h = self.output_height
        if h is not None and (isinstance(h, bool) or not isinstance(h, (int, float)) or not math.isfinite(h)
                              or not 0.0 < h <= 100.0):
            raise ValueError(f"output_height = {h!r} is outside the valid range (0, 100] m (or not given)")
        for name, lo, hi in (("gamma", 0.0, 20.0), ("settle", 0.0, 10.0), ("theta_seed", 0.0, 1.0)):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and lo <= v <= hi):
                raise ValueError(f"{name} = {v!r} is outside the valid range [{lo:g}, {hi:g}]")
        if not (0.0 < self.restitution < 1.0):
            raise ValueError(f"restitution = {self.restitution!r} is outside the valid range (0, 1)")
        ew = self.floor_restitution
        if ew is not None and (isinstance(ew, bool) or not isinstance(ew, (int, float)) or not 0.0 < ew <= 1.0):
            raise ValueError(f"floor_restitution = {ew!r} is outside the valid range (0, 1] (or not given: the "
                             "spheres' restitution)")
        f = self.friction
        if isinstance(f, bool) or not isinstance(f, (int, float)) or not (0.0 <= f <= 1.0):
            raise ValueError(f"friction = {f!r} is outside the valid range [0, 1]")
        if ew is not None and not self.floor_dissipation_restitution > 0.0:
            raise ValueError(f"floor_restitution = {ew!r} is outside the valid range at friction = {f!r}: the "
                             f"effective restitution e_w - 1.5 mu exp(-3 mu) = {self.floor_dissipation_restitution:.3g} "
                             "must be > 0")
        if not self.dissipation_restitution > 0.0:
            raise ValueError(f"friction = {f!r} is outside the valid range at restitution = {self.restitution!r}: the "
                             f"effective restitution e - 1.5 mu exp(-3 mu) = {self.dissipation_restitution:.3g} must "
                             "be > 0")
        if not (0.0 < self.phi_c < 0.74):
            raise ValueError(f"phi_c = {self.phi_c!r} is outside the valid range (0, 0.74)")
        if not (0.0 < self.coordination <= 12.0):
            raise ValueError(f"coordination = {self.coordination!r} is outside the valid range (0, 12]")
        if not (0.0 < self.cfl <= 0.5):
            raise ValueError(f"cfl = {self.cfl!r} is outside the valid range (0, 0.5]")
        for name, lo in (("n_spheres", 1), ("cycles", 1), ("n_cells", 4)):
            v = getattr(self, name)
            if not (isinstance(v, (int, np.integer)) and not isinstance(v, bool) and lo <= v <= 10_000_000):
                raise ValueError(f"{name} = {v!r} is outside the valid range: integers in [{lo}, 1e7]")
        self._check_bed()

    def _check_bed(self):
        """Refuse (ValueError naming the field, with its valid range at these settings) a bed that is
        not a continuum of this model or that no run could finish: thinner than a diameter, so soft
        that its weight overlaps the bottom contacts by more than :data:`MAX_STATIC_OVERLAP` d (the
        contact law's small-overlap limit; the faces of :func:`static_bed` would cross), a default
        output column above 100 m, an ``output_height`` the bed at rest does not fit in, or more
        than :data:`MAX_STEPS` time steps."""
        n_min = math.ceil(self.n_spheres * self.diameter / self.rest_height - 1e-9)
        if self.rest_height < self.diameter:
            deep = f"the bed would be {self.rest_height / self.diameter:.3g} d deep (at least 1 d: a thinner bed is not a continuum)"
            if n_min > 10_000_000:       # no number of spheres fills this box: the box is too wide
                side_max = self.side * math.sqrt(self.rest_height / self.diameter)
                raise ValueError(f"side = {self.side!r} m is outside the valid range at these settings, (0, "
                                 f"{printed_bound(side_max * (1 - 1e-9), down=True)}] m (with n_spheres = "
                                 f"{self.n_spheres!r}; even 1e7 "
                                 f"spheres, the most, need a side of at most {math.sqrt(1e7 / n_min) * self.side:.3g} "
                                 f"m): {deep}")
            raise ValueError(f"n_spheres = {self.n_spheres!r} is outside the valid range at these settings, "
                             f"[{n_min}, 1e7]: {deep}")
        overlap = self.mass_per_area * self.gravity * self.area / self.layer_stiffness      # δ at the bottom [m]
        if overlap > MAX_STATIC_OVERLAP * self.diameter:
            k_min = self.stiffness * overlap / (MAX_STATIC_OVERLAP * self.diameter)
            raise ValueError(f"stiffness = {self.stiffness!r} N/m is outside the valid range at these settings, "
                             f"[{k_min:.3g}, 1e12] N/m: the bed's weight would overlap its bottom contacts by "
                             f"{overlap / self.diameter:.3g} d (at most {MAX_STATIC_OVERLAP:g} d)")
        if self.output_height is None and self.energy_bound_height() > 100.0:
            raise ValueError(f"frequency = {self.frequency!r} Hz is outside the valid range at gamma = {self.gamma!r}: "
                             f"the floor's speed {self.floor_speed():.3g} m/s makes the default output column "
                             f"{self.energy_bound_height():.3g} m high (at most 100 m; output_height sets it)")
        if self.output_height is not None and self.output_height <= self.rest_height:
            raise ValueError(f"output_height = {self.output_height!r} is outside the valid range at these settings, "
                             f"({self.rest_height:.4g}, 100] m: the bed at rest is {self.rest_height:.4g} m high")
        self._check_steps()

    def _check_steps(self):
        """Refuse more than :data:`MAX_STEPS` time steps of the Lagrangian cells (naming ``n_cells``,
        or ``cfl``)."""
        per_cell = self.rest_height / self.n_cells
        steps = (self.t_end + self.settle) * self.contact_wave_speed() / (self.cfl * per_cell)
        if steps > MAX_STEPS:
            n_max = int(self.n_cells * MAX_STEPS / steps)
            if n_max >= 4:
                raise ValueError(f"n_cells = {self.n_cells!r} is outside the valid range at these settings, [4, "
                                 f"{n_max}]: the run would take about {steps:.2g} time steps (at most {MAX_STEPS:.0e})")
            raise ValueError(f"cfl = {self.cfl!r} is outside the valid range at these settings: the run would take "
                             f"about {steps:.2g} time steps (at most {MAX_STEPS:.0e}; fewer cycles, cells or a "
                             "smaller stiffness shorten it)")

    # derived ------------------------------------------------------------------------------------
    @property
    def omega(self) -> float:
        return 2.0 * math.pi * self.frequency

    @property
    def dissipation_restitution(self) -> float:
        """The restitution of the collisional losses (the spheres' γ and the floor's), e_eff =
        e − (3/2) μ exp(−3μ) with μ = ``friction`` (Chialvo and Sundaresan 2013's effective
        restitution of frictional spheres, from their simulations of sheared frictional spheres,
        not fitted here): friction's extra loss in the kinetic theory of smooth spheres; the
        pressure, viscosities and conductivity keep e, as in their model.  e itself when μ = 0."""
        return effective_restitution(self.restitution, self.friction)

    @property
    def floor_dissipation_restitution(self) -> float:
        """The restitution of the floor's loss (:func:`wall_loss`): ``floor_restitution`` (the
        spheres' e when not given) with friction's effective part as in
        :attr:`dissipation_restitution` (> 0: checked)."""
        if self.floor_restitution is None:
            return self.dissipation_restitution
        return effective_restitution(float(self.floor_restitution), self.friction)

    @property
    def floor_loss_mode(self) -> int:
        """The compiled step's ``wall_mode`` for :attr:`floor_loss` (its index in
        :data:`FLOOR_LOSSES`)."""
        return FLOOR_LOSSES.index(self.floor_loss)

    @property
    def amplitude(self) -> float:
        """a = Γ g/ω² [m]."""
        return self.gamma * self.gravity / self.omega ** 2

    @property
    def area(self) -> float:
        return self.side ** 2

    @property
    def sphere_mass(self) -> float:
        return self.density * math.pi / 6.0 * self.diameter ** 3

    @property
    def mass_per_area(self) -> float:
        """N m / A [kg/m²]."""
        return self.n_spheres * self.sphere_mass / self.area

    @property
    def rest_height(self) -> float:
        """Height of the unstressed bed at φ_c [m]."""
        return self.mass_per_area / (self.density * self.phi_c)

    @property
    def layer_stiffness(self) -> float:
        """K_eff = 3 Z φ_c K A / (5 π d²) [N/m] (module docstring)."""
        return 3.0 * self.coordination * self.phi_c * self.stiffness * self.area / (5.0 * math.pi * self.diameter ** 2)

    def contact_wave_speed(self) -> float:
        """Sound speed of the packing on the unloading branch, √(K_eff d/(A e² ρ_s φ_c)) [m/s]."""
        return math.sqrt(self.layer_stiffness * self.diameter / (self.area * self.restitution ** 2
                                                                  * self.density * self.phi_c))

    @property
    def period(self) -> float:
        return 1.0 / self.frequency

    @property
    def t_end(self) -> float:
        return self.cycles / self.frequency

    def floor_speed(self) -> float:
        """aω [m/s], the floor's largest speed."""
        return self.amplitude * self.omega

    def energy_bound_height(self) -> float:
        """The bed's rest height, a flight from launch speeds up to 3aω, (3aω)²/(2g), and 10 d
        for its dilute top [m]: the default top of the output grid (``output_height``)."""
        v = 3.0 * self.floor_speed()
        return self.rest_height + v * v / (2.0 * self.gravity) + 10.0 * self.diameter

    dim = 1
    """A layer config's dimension: the horizontally uniform bed is a column."""

    @property
    def domain_height(self) -> float | None:
        """``output_height`` (a layer config's name for the domain's top)."""
        return self.output_height

    def grid(self):
        """The fixed output column of ``bsrflow run`` (:class:`bsrflow.numerics.grid_nd.GridND`):
        bins of d/10 from the floor to :attr:`output_top`."""
        from ..numerics.grid_nd import GridND
        dz = self.diameter / 10.0
        nz = int(math.ceil(self.output_top / dz - 1e-9))
        return GridND((nz,), dz, bc_lower="floor", bc_upper="vacuum")

    @property
    def output_top(self) -> float:
        """Top of the fixed output grid of ``bsrflow run`` [m]: ``output_height``, by default
        :meth:`energy_bound_height`."""
        return float(self.output_height) if self.output_height is not None else self.energy_bound_height()

    def with_(self, **kw) -> "BedSetup":
        from dataclasses import replace
        return replace(self, **kw)

    def to_dict(self) -> dict:
        return asdict(self)


MAX_CELLS_PER_D = 64
MAX_LATERAL_CELLS = 256
MAX_CELL_STEPS = 1e12
"""The most cell-steps an Eulerian bed run may need (days at the measured 0.5-2 µs per cell-stage)."""
MAX_EULERIAN_CELLS = 20_000_000
"""The most cells of an Eulerian bed's grid: its fields and work arrays take 45 floats, 360 bytes,
per cell (about 7 GB at this bound; a 256 × 256 × 12 800 grid asked for 37.5 GB and ended in a
traceback, a fuzzing review)."""
MAX_PERTURBATION = 0.05
"""The largest lateral mode of the columns' heights at the start (:class:`bsrflow.numerics.
bed_eulerian.EulerianBed`: each column 1 + ε cos(...) times as tall and heavy as the static bed):
a perturbation of the uniform bed, ±0.5 d on the reference's 10-d bed.  (Until 2026-12-05 a mode
of the density, bounded by the contact law's small-overlap limit.)"""


def eulerian_vertical_cells(setup: BedSetup, cells_per_d: int) -> int:
    """Cells of d/cells_per_d from the floor to the last whole cell at or below the setup's
    :attr:`~BedSetup.output_top` (the Eulerian grid's lid, :mod:`bsrflow.numerics.bed_eulerian`)."""
    return int(math.floor(setup.output_top * cells_per_d / setup.diameter + 1e-9))


def check_eulerian_grid(dim, cells_per_d, lateral_cells, perturbation, dim_name="dim") -> None:
    """Refuse (ValueError, one line naming the field and its valid range) a grid of the Eulerian
    bed (:mod:`bsrflow.numerics.bed_eulerian`) that is not one: ``dim`` in {1, 2, 3},
    ``cells_per_d`` an integer in [1, 64], ``lateral_cells`` 1 for a column and an integer in
    [2, 256] otherwise, ``perturbation`` in [0, :data:`MAX_PERTURBATION`] (0 for a column)."""
    if isinstance(dim, bool) or dim not in (1, 2, 3):
        raise ValueError(f"{dim_name} = {dim!r} is outside the valid range {{1, 2, 3}}")
    if isinstance(cells_per_d, bool) or not isinstance(cells_per_d, (int, np.integer)) or not (
            1 <= cells_per_d <= MAX_CELLS_PER_D):
        raise ValueError(f"cells_per_d = {cells_per_d!r} is outside the valid range: integers in [1, {MAX_CELLS_PER_D}]")
    lo, hi = (1, 1) if dim == 1 else (2, MAX_LATERAL_CELLS)
    if isinstance(lateral_cells, bool) or not isinstance(lateral_cells, (int, np.integer)) or not (
            lo <= lateral_cells <= hi):
        raise ValueError(f"lateral_cells = {lateral_cells!r} is outside the valid range at {dim_name} = {dim}: "
                         f"integers in [{lo}, {hi}]")
    if (isinstance(perturbation, bool) or not isinstance(perturbation, (int, float)) or not math.isfinite(perturbation)
            or not 0.0 <= perturbation <= MAX_PERTURBATION or (dim == 1 and perturbation != 0.0)):
        raise ValueError(f"perturbation = {perturbation!r} is outside the valid range at {dim_name} = {dim}: "
                         + (f"[0, {MAX_PERTURBATION:g}] (a small mode of the columns' heights at the start)"
                            if dim > 1 else "[0, 0] (a column has no lateral mode)"))


@dataclass(frozen=True)
class EulerianBedSetup(BedSetup):
    """The bed of :class:`BedSetup` on the Eulerian grid of :mod:`bsrflow.numerics.bed_eulerian`
    (``bsrflow run``'s ``kind = "granular_bed_eulerian"``): ``dimension`` 1 (a column), 2 (x, z)
    or 3 (x, y, z); ``cells_per_d`` cells per diameter vertically; ``lateral_cells`` cells across
    the box's side (periodic; not given: 1 for a column, 4 otherwise); ``perturbation`` ε: the
    start's columns 1 + ε cos(2πx/L) (cos(2πy/L) in 3-D) times as tall and heavy.  The grid's lid
    is at the whole number of cells at or below :attr:`output_top`, so the file's column holds all
    the mass.
    ``n_cells`` (the Lagrangian cells) is not used."""

    dimension: int = 3
    cells_per_d: int = 4
    lateral_cells: int | None = None
    perturbation: float = 0.0

    def __post_init__(self):
        if self.lateral_cells is None and self.dimension in (1, 2, 3) and not isinstance(self.dimension, bool):
            object.__setattr__(self, "lateral_cells", 1 if self.dimension == 1 else 4)
        check_eulerian_grid(self.dimension, self.cells_per_d, self.lateral_cells, self.perturbation, "dimension")
        check_eulerian_floor_loss(self.floor_loss)
        super().__post_init__()

    def _check_bed(self):
        """The base's checks, the grid's lid first (its bound is above the base's ``output_height``
        bound, which it would otherwise state: an ``output_height`` in that range was then refused
        with this one, a fuzzing review)."""
        if self.rest_height >= self.diameter:
            self._check_lid()
        super()._check_bed()

    def _check_lid(self):
        """Refuse a grid whose lid leaves the bed at rest less than a diameter of room."""
        dz = self.diameter / self.cells_per_d
        top = eulerian_vertical_cells(self, self.cells_per_d) * dz
        tallest = (1.0 + self.perturbation) * self.rest_height       # the tallest column at the start
        need = tallest + self.diameter                                 # a diameter of room below the lid
        if top < need - 1e-12 * need:
            lowest = math.ceil(need / dz - 1e-9) * dz
            raise ValueError(f"output_height = {self.output_height!r} is outside the valid range at these settings, "
                             f"[{printed_bound(lowest, down=False, slack=1e-6)}, 100] m: the grid of whole cells "
                             f"below it would end at {top:.4g} m, and "
                             f"the bed at rest ({tallest:.4g} m high) needs a diameter of room below the grid's lid "
                             "(a bed reaching the lid stops the run)")

    def grid_upper(self) -> tuple:
        """The grid's upper corner [m] in the tracers' layout (z in 1-D, (x, z) in 2-D, (x, y, z) in
        3-D; the lower corner is 0): the box's side L across, the lid in height."""
        lid = eulerian_vertical_cells(self, self.cells_per_d) * (self.diameter / self.cells_per_d)
        return (float(self.side),) * (self.dimension - 1) + (float(lid),)

    def _check_steps(self):
        """Refuse more than :data:`MAX_CELL_STEPS` cell-steps or :data:`MAX_STEPS` steps of the grid
        (naming ``cells_per_d``), in place of the Lagrangian cells' bound."""
        def cost(n):                     # (cells, steps) at n cells per diameter
            cells = eulerian_vertical_cells(self, n) * self.lateral_cells ** (self.dimension - 1)
            per_step = n / self.diameter + (self.dimension - 1) * self.lateral_cells / self.side      # Σ_a 1/Δx_a
            return cells, (self.t_end + self.settle) * self.contact_wave_speed() * per_step / self.cfl

        def fits(n):
            cells, steps = cost(n)
            return cells * steps <= MAX_CELL_STEPS and steps <= MAX_STEPS and cells <= MAX_EULERIAN_CELLS
        cells = cost(self.cells_per_d)[0]
        if cells > MAX_EULERIAN_CELLS:
            n_max = next((n for n in range(self.cells_per_d - 1, 0, -1) if fits(n)), None)
            if n_max is None:
                raise ValueError(f"lateral_cells = {self.lateral_cells!r} is outside the valid range at these settings: "
                                 f"the grid would have {cells} cells (at most {MAX_EULERIAN_CELLS:.0e}, 360 bytes "
                                 "each), and no cells_per_d fits both that and the run's length (at most "
                                 f"{MAX_CELL_STEPS:.0e} cell-steps): fewer cells across, a lower output_height or "
                                 "fewer cycles")
            raise ValueError(f"cells_per_d = {self.cells_per_d!r} is outside the valid range at these settings, "
                             f"integers in [1, {n_max}]: the grid would have {cells} cells (at most "
                             f"{MAX_EULERIAN_CELLS:.0e}, 360 bytes each)")
        if not fits(self.cells_per_d):
            cells, steps = cost(self.cells_per_d)
            n_max = next((n for n in range(self.cells_per_d - 1, 0, -1) if fits(n)), None)
            rng = f"integers in [1, {n_max}]" if n_max else "none fits"
            raise ValueError(f"cells_per_d = {self.cells_per_d!r} is outside the valid range at these settings, {rng}: "
                             f"the run would take about {cells * steps:.2g} cell-steps ({cells} cells, {steps:.2g} "
                             f"steps; at most {MAX_CELL_STEPS:.0e} and {MAX_STEPS:.0e}: fewer cells per d or across, "
                             "fewer cycles)")
