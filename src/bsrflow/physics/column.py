"""The vertically tapped column of spheres (seed section 4.1 and 4.4, (4.5)-(4.8), (4.30)).

N spheres of diameter d and material density ρ_s rest on a floor; the floor is tapped with
half-sine displacement pulses (4.5) of amplitude a and frequency f.  The continuum (BSR)
column is solved in the floor frame with:

* line density ρ [kg/m] of the stacked spheres: each sphere k, centred at y_k = (2k-1)d/2,
  spreads its mass m over a raised-cosine bump m/d cos²(π(y-y_k)/(2d)), |y-y_k| < d; the
  bumps form a partition of unity, so the interior density is exactly m/d, and the part of the
  bottom bump below the floor is folded back above it (total mass exactly N m);
* the Walton-Braun kernel (4.6) in the repulsive, dissipative convention with
  λ = K/(m m0) and radius R = d (the seed's 2r);
* gravity, the tap's smooth inertial acceleration -ϑ'' and its velocity jumps;
* the supporting floor and the vacuum top of :mod:`bsrflow.numerics.grid`, velocity extension
  into vacuum, tracers started at the sphere centres.

The domain height comes from an energy bound: the floor moves at most at aω, a sphere hit by
it leaves at most at 2aω plus what the chain behind it passes on (we allow 3aω); in the
continuum the dilute top edge also expands into the vacuum like a gas with pressure ∝ ρ²
(γ = 2), whose front moves at most at 2c0/(γ-1) = 2c0 faster (c0 the kernel's sound speed at
the stacked density).  So the domain is N d + (3aω + 2c0)²/(2g) + 3 d tall; the solver stops
with an error naming the time if material reaches the top anyway.

Units: SI throughout; heights in outputs are also given in units of d where named ``*_over_d``.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from ..numerics.grid import Grid1D
from ..numerics.solver import Scheme, Simulation, SimulationError, save_schedule
from .kernels import walton_braun_from_contact
from .model import BSRModel
from .motion import HalfSineTaps

KERNELS = ("seed", "packing")
FORMULATIONS = ("eulerian", "lagrangian")

__all__ = ["ColumnSetup", "ColumnRun", "run_bsr_column", "initial_density"]

DEFAULT_DIAMETER = 0.022
"""Sphere diameter d [m].  The seed never states it.  Its reported DEM heights (top sphere
centre about 30 d for a/d = 0.75 and 38 d for a/d = 1.0) are reproduced by the package's DEM
only for d of about 2.1-2.3 cm (seed-notes problem 2; `bsrflow compare --sweep-d` re-measures
this); we take 2.2 cm.  An inference, not a quoted value."""


MAX_BONDS = 50_000_000
STIFFNESS_RANGE = (1e-3, 1e12)
"""The stiffness K [N/m] a column accepts (a packing column narrows it: :meth:`ColumnSetup._check_packing_stiffness`)."""
MAX_STATIC_OVERLAP = 0.05
"""Largest overlap per contact [d] that the packing column's weight may cause at the floor
(the packing law is a small-overlap law); :meth:`ColumnSetup._check_packing_stiffness`."""
MAX_PACKING_STEPS = 1.0e9
"""Largest number of time steps a packing column is allowed (issue #18's runs take at most about
1e7; a run refused here would take hours)."""
MAX_CFL_ELASTIC = 0.25
"""Largest cfl of the Lagrangian packing form with restitution e = 1: at 0.5 its velocity Verlet
gained 11–14 % energy over a landing (docs/model.md, "The nonlocal interaction")."""
"""Most bonds (histories) a nonlocal column may hold: 400 MB of history."""

DEFAULT_RANGE_OVER_D = 1.0
"""The packing interaction's default range R/d in both formulations: one diameter, the range of a
sphere's contacts (docs/model.md, "The nonlocal interaction")."""


@dataclass
class ColumnSetup:
    """Parameters of the tapped column (SI units).

    Physics: n_spheres, diameter d [m], density [kg/m³] of the sphere material, stiffness K
    [N/m] (DEM loading stiffness and the kernel's K), restitution e (DEM), m0 [kg] (continuum
    characteristic mass of (4.6)), kernel_dissipation ε of the continuum kernel, gravity g
    [m/s²]; tap: a_over_d, frequency f [Hz], tap_start [s], n_taps, tap_period [s];
    run: t_end [s]; numerics: points_per_diameter, scheme preset name, save_every [s].
    impulses: include the velocity jumps of the displacement pulse (True, correct) or only the
    smooth inertial term a ω² sin ωt of (4.6) as printed (False).
    kernel_name: "seed" (the seed's kernel (4.6) with m0 and ε, solved by the seed's scheme) or
    "packing" (the contact law's continuum, :mod:`bsrflow.physics.packing`; m0, ε and scheme
    do not enter); formulation: "eulerian" or "lagrangian" (packing only); stiffness_factor in
    (0, 1]: the packing law's stiffness K·factor (the reduced-stiffness option); cfl: the
    packing discretisation's CFL number (None: the discretisation's ``default_cfl``, 0.25
    Eulerian (R > 0), 0.4 Eulerian local limit, 0.5 Lagrangian, 0.25 Lagrangian with e = 1;
    :meth:`packing_class`); range_over_d: the packing interaction's range R/d
    (:meth:`interaction_range`; None: 1, R = d, in both formulations; 0: the local limit; a
    nonzero R must be a whole number of point spacings k/ppd).
    Note: ``formulation`` defaults to "eulerian" here (the seed kernel's grid), so
    ``ColumnSetup(kernel_name="packing")`` is the staggered Eulerian form of the nonlocal
    interaction (R = d); a config's packing column is ``formulation="lagrangian"`` by default.
    """

    n_spheres: int = 20
    diameter: float = DEFAULT_DIAMETER
    density: float = 1200.0
    stiffness: float = 1.366e7
    restitution: float = 0.9
    m0: float = 22.0
    kernel_dissipation: float = 0.105
    gravity: float = 9.81
    a_over_d: float = 0.75
    frequency: float = 10.0
    tap_start: float = 0.4
    n_taps: int = 1
    tap_period: float = 0.6
    t_end: float = 1.3
    points_per_diameter: int = 10
    scheme: str = "seed"
    save_every: float = 0.005
    domain_height: float | None = None
    impulses: bool = True
    kernel_name: str = "seed"
    formulation: str = "eulerian"
    stiffness_factor: float = 1.0
    cfl: float | None = None
    range_over_d: float | None = None

    def __post_init__(self):
        # lower bounds where a value near 0 would divide by zero or make the explicit step vanish
        # (a column of spheres of 1e-300 kg never finishes); all closed below
        checks = [
            ("n_spheres", self.n_spheres, 2, 100000, True),
            ("diameter", self.diameter, 1e-6, 10, False),
            ("density", self.density, 1.0, 1e5, False),
            ("stiffness", self.stiffness, *STIFFNESS_RANGE, False),
            ("m0", self.m0, 1e-12, 1e12, False),
            ("gravity", self.gravity, 1e-3, 1e4, False),
            ("frequency", self.frequency, 1e-3, 1e4, False),
            ("t_end", self.t_end, 1e-9, 1e5, False),
            ("save_every", self.save_every, 1e-9, 1e5, False),
        ]
        for name, v, lo, hi, integer in checks:
            if not (np.isfinite(v) and lo <= v <= hi) or (integer and int(v) != v):
                kind = "integers" if integer else "values"
                raise ValueError(f"{name} = {v!r} is outside the valid range: {kind} in [{lo:g}, {hi:g}]")
        if not (0.01 <= self.restitution <= 1.0):
            raise ValueError(f"restitution = {self.restitution!r} is outside the valid range [0.01, 1]")
        if not (0.0 <= self.kernel_dissipation < 1.0):
            raise ValueError(f"kernel_dissipation = {self.kernel_dissipation!r} is outside the valid range [0, 1)")
        if not (np.isfinite(self.a_over_d) and 0.0 <= self.a_over_d <= 20.0):
            raise ValueError(f"a_over_d = {self.a_over_d!r} is outside the valid range [0, 20]")
        if not (np.isfinite(self.tap_start) and self.tap_start >= 0.0):
            raise ValueError(f"tap_start = {self.tap_start!r} is outside the valid range [0, inf) s")
        if int(self.n_taps) != self.n_taps or self.n_taps < 0:
            raise ValueError(f"n_taps = {self.n_taps!r} is outside the valid range: integers >= 0")
        if (int(self.points_per_diameter) != self.points_per_diameter or not 2 <= self.points_per_diameter <= 1000):
            raise ValueError(f"points_per_diameter = {self.points_per_diameter!r} is outside the valid "
                             "range: integers in [2, 1000] (the kernel radius d must span at least 2 cells)")
        if self.n_taps > 1 and self.tap_period < 0.5 / self.frequency:
            raise ValueError(f"tap_period = {self.tap_period!r} s is outside the valid range "
                             f"[{0.5 / self.frequency:g}, inf) s (a tap lasts 1/(2f))")
        if self.kernel_name not in KERNELS:
            raise ValueError(f"kernel_name = {self.kernel_name!r} is not one of {', '.join(KERNELS)}")
        if self.formulation not in FORMULATIONS:
            raise ValueError(f"formulation = {self.formulation!r} is not one of {', '.join(FORMULATIONS)}")
        if self.kernel_name == "seed" and self.formulation != "eulerian":
            raise ValueError(f"formulation = {self.formulation!r} is not supported by the seed kernel "
                             "(valid: eulerian; the lagrangian formulation is the packing kernel's)")
        if not (np.isfinite(self.stiffness_factor) and 0.0 < self.stiffness_factor <= 1.0):
            raise ValueError(f"stiffness_factor = {self.stiffness_factor!r} is outside the valid range (0, 1]")
        if self.kernel_name == "seed" and self.stiffness_factor != 1.0:
            raise ValueError("stiffness_factor is an option of the packing kernel only (the seed kernel's "
                             "stiffness is set by m0)")
        if self.range_over_d is not None:
            from .packing import MAX_RANGE_OVER_D
            if self.kernel_name == "seed":
                raise ValueError("range_over_d is an option of the packing kernel only (the seed kernel's range "
                                 "is d)")
            if not (np.isfinite(self.range_over_d) and 0.0 <= self.range_over_d <= MAX_RANGE_OVER_D):
                raise ValueError(f"range_over_d = {self.range_over_d!r} is outside the valid range "
                                 f"[0, {MAX_RANGE_OVER_D:g}]")
            if self.range_over_d > self.n_spheres:
                raise ValueError(f"range_over_d = {self.range_over_d!r} is outside the valid range "
                                 f"[0, {self.n_spheres}] for a column of {self.n_spheres} spheres")
            if self.range_over_d > 0.0:
                from .packing import bond_lags
                bonds = bond_lags(self.range_over_d, self.points_per_diameter) * self.n_spheres * self.points_per_diameter
                if bonds > MAX_BONDS:
                    raise ValueError(f"range_over_d = {self.range_over_d!r} gives {bonds:.3g} bonds with "
                                     f"{self.n_spheres} spheres at {self.points_per_diameter} points per diameter; "
                                     f"valid: at most {MAX_BONDS:.0e} (ppd² R/d N)")
        if self.cfl is not None:
            if self.kernel_name == "seed":
                raise ValueError("cfl is an option of the packing kernel only (the seed kernel's CFL number "
                                 "is the scheme's)")
            lim = self.packing_class().cfl_limit
            elastic = self.formulation == "lagrangian" and self.restitution >= 1.0
            if elastic:
                lim = MAX_CFL_ELASTIC
            if not (np.isfinite(self.cfl) and 1e-3 <= self.cfl <= lim):
                why = (" with restitution = 1 (Verlet gains energy where contacts open and close; "
                       "docs/model.md)" if elastic else "")
                raise ValueError(f"cfl = {self.cfl!r} is outside the valid range [0.001, {lim}] for the "
                                 f"{self.formulation} packing formulation{why}")
        if self.kernel_name == "packing":
            self._check_packing_stiffness()
        need = self.energy_bound_height()
        if self.domain_height is not None and self.domain_height < need:
            raise ValueError(f"domain_height = {self.domain_height!r} m is outside the valid range "
                             f"[{need:.4g}, inf) m: the energy bound predicts flight up to {need:.4g} m")

    def _check_packing_stiffness(self):
        """The packing law's stiffness in use, K·stiffness_factor, neither so soft that the
        column's weight N m g overlaps its bottom contact by more than 5 % of d (the packing
        law is a small-overlap law; much softer, material points cross under the weight) nor so
        stiff that the run needs more than 1e9 time steps (estimated as t_end c/(cfl d/ppd), c the
        sound speed at close packing).  ValueError with the valid range at these settings, naming
        ``stiffness_factor`` where one below 1 is set and another would do, else ``stiffness``."""
        k_used = self.stiffness * self.stiffness_factor
        weight = self.n_spheres * self.particle_mass * self.gravity          # stress at the floor [N]
        overlap = weight / k_used                                             # δ = P/K1 [m]
        k_min = weight / (MAX_STATIC_OVERLAP * self.diameter)
        cfl = self.cfl if self.cfl is not None else self.packing_class().default_cfl(self.restitution)
        dx = self.diameter / self.points_per_diameter
        c_per_root_k = self.diameter / (self.restitution * math.sqrt(self.particle_mass))   # c = d √(K/(e² m))
        steps = self.t_end * c_per_root_k * math.sqrt(k_used) / (cfl * dx)
        k_max = (MAX_PACKING_STEPS * cfl * dx / (self.t_end * c_per_root_k)) ** 2
        if overlap > MAX_STATIC_OVERLAP * self.diameter:
            problem = (f"the column's weight would overlap its bottom contact by {overlap / self.diameter:.3g} d "
                       f"(at most {MAX_STATIC_OVERLAP:g} d)")
        elif steps > MAX_PACKING_STEPS:
            problem = (f"the run would take about {steps:.2g} time steps (at most {MAX_PACKING_STEPS:.0e}; a "
                       "stiffness_factor below 1 reduces it)")
        else:
            return
        factor, k = self.stiffness_factor, self.stiffness
        f_lo, f_hi = k_min / k, min(1.0, k_max / k)
        if factor != 1.0 and f_lo <= f_hi:            # the factor is what to change
            raise ValueError(f"stiffness_factor = {factor!r} is outside the valid range at these settings, "
                             f"[{f_lo:.3g}, {f_hi:.3g}] (stiffness {k:g} N/m): {problem}")
        lo, hi = max(k_min / factor, STIFFNESS_RANGE[0]), min(k_max / factor, STIFFNESS_RANGE[1])
        unit = "" if factor == 1.0 else f" (× stiffness_factor {factor:g})"
        valid = (f"[{lo:.3g}, {hi:.3g}] N/m" if lo <= hi else
                 f"empty (the weight needs at least {lo:.3g} N/m, the step count at most {hi:.3g} N/m; a shorter "
                 "t_end or fewer spheres widens it)")
        raise ValueError(f"stiffness = {k!r} N/m{unit} is outside the valid range at these settings, {valid}: "
                         f"{problem}")

    # derived quantities -----------------------------------------------------------------------
    @property
    def particle_mass(self) -> float:
        """m = ρ_s π d³/6 [kg]."""
        return self.density * math.pi / 6.0 * self.diameter ** 3

    @property
    def amplitude(self) -> float:
        """a [m]."""
        return self.a_over_d * self.diameter

    @property
    def omega(self) -> float:
        return 2.0 * math.pi * self.frequency

    def sound_speed(self) -> float:
        """c0 = sqrt(κ m/d) = sqrt(K d² / (3 m0)) [m/s], the kernel's sound speed at the stacked
        spheres' line density (κ = λR³/3, λ = K/(m m0), R = d)."""
        return math.sqrt(self.stiffness * self.diameter ** 2 / (3.0 * self.m0))

    def energy_bound_height(self) -> float:
        """Domain height [m] from the energy bound (module docstring; the packing has no gas
        expansion term: it carries no load below close packing)."""
        launch = 3.0 * self.amplitude * self.omega if self.n_taps > 0 else 0.0
        v = launch + (2.0 * self.sound_speed() if self.kernel_name == "seed" else 0.0)
        return self.n_spheres * self.diameter + v * v / (2.0 * self.gravity) + 3.0 * self.diameter

    def height(self) -> float:
        H = self.domain_height or self.energy_bound_height()
        # a whole number of cells
        dx = self.diameter / self.points_per_diameter
        return math.ceil(H / dx) * dx

    def motion(self):
        if self.n_taps == 0 or self.a_over_d == 0.0:
            from .motion import Rest
            return Rest()
        m = HalfSineTaps(self.amplitude, self.frequency, start=self.tap_start, n_taps=self.n_taps,
                         period=self.tap_period)
        if not self.impulses:
            # the seed's forcing as printed in (4.6): only the smooth part a ω² sin ωt
            m.jumps = []
            m.name = "half_sine_taps_smooth_part_only"
        return m

    def kernel(self):
        return walton_braun_from_contact(self.stiffness, self.particle_mass, self.m0, self.kernel_dissipation,
                                         self.diameter)

    def interaction_range(self) -> float:
        """R/d of the packing interaction: ``range_over_d``, or if None 1 in both formulations (the
        nonlocal interaction over one diameter, docs/model.md; before 2026-12-03 the Eulerian
        formulation's default was 0, the local limit, its only range then)."""
        if self.range_over_d is not None:
            return float(self.range_over_d)
        return DEFAULT_RANGE_OVER_D

    def packing_law(self):
        """The packing interaction of this column (:class:`bsrflow.physics.packing.PackingLaw`)."""
        from .packing import PackingLaw
        return PackingLaw(self.stiffness, self.restitution, self.diameter, self.density, self.stiffness_factor,
                          self.interaction_range())

    def packing_class(self):
        """The class of :meth:`packing_discretisation`: LagrangianPacking, StaggeredEulerianPacking
        (Eulerian, R > 0) or EulerianPacking (Eulerian, the local limit R = 0)."""
        from ..numerics.packing import EulerianPacking, LagrangianPacking, StaggeredEulerianPacking
        if self.formulation == "lagrangian":
            return LagrangianPacking
        return StaggeredEulerianPacking if self.interaction_range() > 0 else EulerianPacking

    def packing_discretisation(self):
        """The packing continuum's discretisation of this column, at rest at close packing
        (ρ = m/d on [0, N d]), an instance of :meth:`packing_class`."""
        return self.packing_class()(self.packing_law(), self.grid(), self.n_spheres, self.motion(), self.gravity,
                                    self.points_per_diameter, cfl=self.cfl)

    def model(self) -> BSRModel:
        return BSRModel(kernel=self.kernel(), motion=self.motion(), gravity=self.gravity)

    def grid(self) -> Grid1D:
        H = self.height()
        n = int(round(H / self.diameter * self.points_per_diameter))
        return Grid1D(0.0, H, n, "floor", "vacuum")

    def sphere_centres(self) -> np.ndarray:
        """Initial sphere centres y_k = (2k-1) d/2 [m]."""
        return (np.arange(self.n_spheres) + 0.5) * self.diameter

    def tap_times(self) -> np.ndarray:
        return self.tap_start + self.tap_period * np.arange(self.n_taps)

    def simulation(self, scheme: Scheme, **kw) -> Simulation:
        """The solver of this column with its monitors: velocity extension below 1e-4 of the
        stacked line density m/d, a stop when more than 1e-3 m/d [kg/m] reaches the kernel
        radius below the domain top, and |ρ| < 1e-30 m/d set to 0 after every step (vacuum
        debris; ``Simulation``'s ``density_floor``).  ``kw``: further ``Simulation`` options."""
        line = self.particle_mass / self.diameter
        opts = dict(vacuum_density=1e-4 * line, top_tolerance=1e-3 * line, density_floor=1e-30 * line)
        opts.update(kw)
        return Simulation(self.model(), self.grid(), scheme, **opts)

    def with_(self, **kw) -> "ColumnSetup":
        return replace(self, **kw)

    def to_dict(self) -> dict:
        return asdict(self)


STIFFNESS_MACH = 0.01
"""Default impact Mach number of the reduced-stiffness option (:func:`suggest_stiffness_factor`)."""

STIFFNESS_ERROR_BOUNDS = {
    "lagrangian R=1d": {"top_max_rel": 0.01, "mass_centre_rms_over_d": 0.15, "measured_at_mach_0.03": (0.014, 0.46)},
    "eulerian R=1d": {"top_max_rel": 0.01, "mass_centre_rms_over_d": 0.15, "measured_at_mach_0.03": (0.013, 0.50)},
    "lagrangian local": {"top_max_rel": 0.015, "mass_centre_rms_over_d": 0.25, "measured_at_mach_0.03": (0.018, 0.46)},
    "eulerian local": {"top_max_rel": 0.01, "mass_centre_rms_over_d": 1.2, "measured_at_mach_0.03": (0.012, 1.35)},
}
"""The documented cost of the reduced stiffness at impact Mach number ≤ 0.01, per packing model
(:func:`stiffness_model`): the top maximum and the mass-centre RMS against the true stiffness's run.
Measured on the 14 cases of the packing comparison (10 points per diameter) by ``python
bench/packing_stiffness.py --formulation F [--range R]`` (docs/model.md, "Stiffness"; tested).
The nonlocal interaction (R = d, ``--formulation lagrangian``): at most 0.51 % and 0.094 d at
M = 0.01 (0.45 % and 0.025 d at M = 0.003; docs/results/packing_stiffness_nonlocal_2026-12-02.json),
documented as 1 % and 0.15 d; in the Eulerian formulation (``--formulation eulerian --range 1``,
2026-12-03) at most 0.48 % and 0.093 d at M = 0.01 (0.17 % and 0.024 d at M = 0.003;
docs/results/packing_stiffness_eulerian_nonlocal_2026-12-03.json), documented the same.  The local limit, Lagrangian: at most 1.07 % and
0.20 d at M = 0.01 (0.34 % and 0.048 d at M = 0.003;
docs/results/packing_stiffness_local_lagrangian_2026-12-02.json); Eulerian at most 0.87 % and 1.08 d at
M = 0.01 (the three-tap a/d = 1.0 case; 0.38 d in the other 13), 0.26 % and 0.154 d at M = 0.003
(docs/results/packing_stiffness_eulerian_2026-12-01.json).  The Eulerian mass centre after a
landing is sensitive (its landing bounce, docs/model.md): at the true stiffness it moves by as
much between 20 and 40 cells per diameter, so its bound is wider.  ``measured_at_mach_0.03``: the
largest errors (top maximum, mass-centre RMS in d) measured at M = 0.03, beyond the bound's range.
Other ranges have no measured bound."""


def model_label(formulation: str, range_over_d: float) -> str:
    """The name of a packing model: 'lagrangian R=1d', or 'eulerian local' for the local limit
    (R = 0)."""
    return f"{formulation} " + ("local" if range_over_d == 0.0 else f"R={range_over_d:g}d")


def continuum_label(setup) -> str:
    """What a column setup runs: 'seed kernel', or 'packing ' + :func:`model_label` ('packing
    lagrangian R=1d', 'packing eulerian local', ...)."""
    if setup.kernel_name != "packing":
        return "seed kernel"
    return "packing " + model_label(setup.formulation, setup.interaction_range())


def stiffness_model(setup) -> str:
    """The key of ``setup``'s packing model in :data:`STIFFNESS_ERROR_BOUNDS`
    (:func:`model_label`): 'lagrangian R=1d', 'lagrangian local' or 'eulerian local' (other
    ranges have no bound; 'eulerian R=1d' since 2026-12-03)."""
    return model_label(setup.formulation, setup.interaction_range())


STIFFNESS_ERROR_BOUND = STIFFNESS_ERROR_BOUNDS["lagrangian R=1d"]
"""The bound of the package's packing continuum, the nonlocal interaction (:data:`STIFFNESS_ERROR_BOUNDS`)."""


def impact_speed_bound(setup: ColumnSetup) -> float:
    """Upper bound on the speed [m/s] at which the column meets the floor or itself: 3aω (the
    energy bound's launch speed; the DEM's top sphere leaves at about 2.05 aω), at least the
    free-fall speed √(2 g d) of one diameter."""
    from .packing import impact_speed
    launch = 3.0 * setup.amplitude * setup.omega if setup.n_taps > 0 else 0.0
    return impact_speed(launch, setup.gravity, setup.diameter)


def impact_mach(setup: ColumnSetup) -> float:
    """M = (impact speed bound) / (packing wave speed at the stiffness used): the strain of the
    packing when the column lands is about M, so its dynamics depart from the rigid limit by
    O(M) (docs/model.md, "Stiffness")."""
    return impact_speed_bound(setup) / setup.packing_law().wave_speed()


def suggest_stiffness_factor(setup: ColumnSetup, mach: float = STIFFNESS_MACH) -> float:
    """The reduced-stiffness option: the smallest factor φ in (0, 1] for which the impact Mach
    number stays at most ``mach``: φ = min(1, (v_impact / (mach c_true))²), c_true = d√(K2/m)
    at the true stiffness.  The explicit step then grows by 1/√φ."""
    from .packing import stiffness_factor_for_mach
    true = setup.with_(stiffness_factor=1.0)
    return stiffness_factor_for_mach(impact_speed_bound(true), true.packing_law().wave_speed(), mach)


def initial_density(setup: ColumnSetup, x: np.ndarray) -> np.ndarray:
    """Line density [kg/m] of the stacked spheres at heights x [m] (module docstring).

    Each bump m/d cos²(π(x-c)/(2d)), |x-c| < d, centred at c = ±y_k (the mirror image folds the
    part below the floor back up), is added only to the cells it covers: the cost is linear in
    spheres + cells.  The bumps are added to each cell in the order of the plain loop over
    spheres (y_k, then -y_k), with the same arithmetic, so the result equals that loop's bit
    for bit (tested).  For x not increasing, the plain loop is used."""
    d = setup.diameter
    m = setup.particle_mass
    x = np.asarray(x)
    rho = np.zeros_like(x, dtype=float)
    yk = setup.sphere_centres()
    centres = np.column_stack([yk, -yk]).reshape(-1)          # y_0, -y_0, y_1, -y_1, ...
    xf = np.asarray(x, dtype=float).reshape(-1)
    if xf.size < 2 or not np.all(np.diff(xf) > 0):
        for centre in centres:
            s = (x - centre) / d
            rho += np.where(np.abs(s) < 1.0, m / d * np.cos(0.5 * np.pi * s) ** 2, 0.0)
        return rho
    # candidate cells of each bump: x in [c - d, c + d] widened by one cell each side (the exact
    # test |s| < 1 below decides, as in the loop)
    lo = np.maximum(np.searchsorted(xf, centres - d, side="left") - 1, 0)
    hi = np.minimum(np.searchsorted(xf, centres + d, side="right") + 1, xf.size)
    count = np.maximum(hi - lo, 0)
    total = int(count.sum())
    if total == 0:
        return rho
    which = np.repeat(np.arange(centres.size), count)          # bump of each (bump, cell) pair
    first = np.cumsum(count) - count
    cell = lo[which] + (np.arange(total) - first[which])
    s = (xf[cell] - centres[which]) / d
    inside = np.abs(s) < 1.0
    cell, s = cell[inside], s[inside]
    values = m / d * np.cos(0.5 * np.pi * s) ** 2
    flat = rho.reshape(-1)
    np.add.at(flat, cell, values)                               # in order: bump by bump
    return rho


@dataclass
class ColumnRun:
    """Result of a BSR column run (laboratory-frame heights, from the floor at rest)."""

    setup: ColumnSetup
    t: np.ndarray                 # [s]
    x: np.ndarray                 # [m] grid (floor frame)
    rho: np.ndarray               # [kg/m] (nt, nx)
    u: np.ndarray                 # [m/s] floor frame
    floor: np.ndarray             # [m] floor position
    tracers: np.ndarray           # [m] lab-frame tracer heights (nt, N)
    top: np.ndarray               # [m] lab-frame height of the top tracer
    mass_centre: np.ndarray       # [m] lab-frame mass centre
    mass: np.ndarray              # [kg]
    kinetic: np.ndarray           # [J] Σ ½ ρ u² Δx (floor frame)
    wall_time: float
    steps: int
    info: dict = field(default_factory=dict)


def run_bsr_column(setup: ColumnSetup, scheme: Scheme | str | None = None, observers=(), progress=None,
                   tracer_integrator: str | None = None) -> ColumnRun:
    """Run the continuum column from rest (stacked spheres) to ``setup.t_end``; the packing
    kernel goes to :func:`run_packing_column`."""
    if setup.kernel_name == "packing":
        if scheme is not None or tracer_integrator is not None:
            raise ValueError("scheme and tracer_integrator are options of the seed kernel's solver only")
        return run_packing_column(setup, observers=observers, progress=progress)
    if scheme is None:
        scheme = setup.scheme
    if isinstance(scheme, str):
        scheme = Scheme.preset(scheme)
    if tracer_integrator is not None:
        scheme = replace(scheme, tracer_integrator=tracer_integrator)
    sim = setup.simulation(scheme)
    grid = sim.grid
    rho0 = initial_density(setup, grid.x)
    try:
        res = sim.run(np.zeros(grid.n_cells), rho0, setup.t_end, save_every=setup.save_every,
                      tracers=setup.sphere_centres(), observers=observers, progress=progress)
    except SimulationError as exc:      # the snapshots before the stop, as a ColumnRun, for the caller
        if exc.result is not None and len(exc.result.t):
            exc.column_run = column_run_from_result(setup, grid, exc.result)
        raise
    return column_run_from_result(setup, grid, res)


def run_packing_column(setup: ColumnSetup, observers=(), progress=None) -> ColumnRun:
    """Run the packing continuum of the column (``setup.kernel_name == "packing"``) in
    ``setup.formulation`` from rest to ``setup.t_end``."""
    from ..numerics.packing import run_packing
    disc = setup.packing_discretisation()
    res = run_packing(disc, setup.t_end, save_schedule(0.0, setup.t_end, setup.save_every), observers=observers,
                      progress=progress)
    res.info["scheme"] = f"packing_{disc.name}"
    return column_run_from_result(setup, disc.grid, res)


def column_run_from_result(setup, grid, res) -> ColumnRun:
    floor = res.floor
    mass = res.rho.sum(axis=1) * grid.dx
    centre = (res.rho * grid.x).sum(axis=1) * grid.dx / mass + floor
    tracers = res.tracers + floor[:, None]
    return ColumnRun(setup, res.t, grid.x, res.rho, res.u, floor, tracers, tracers[:, -1], centre, mass,
                     0.5 * (res.rho * res.u ** 2).sum(axis=1) * grid.dx, res.wall_time, res.steps,
                     {"scheme": res.info.get("scheme"), "status": res.status})
