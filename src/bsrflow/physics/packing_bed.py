"""A vertically vibrated bed of spheres as the packing continuum in 2-D / 3-D (issue #19).

The scenario of ``bsrflow run`` with ``[layer] kind = "packing_bed"``: a bed of monodisperse
spheres (diameter d [m], material density ρ_s [kg/m³], contact stiffness K [N/m], restitution e)
at close packing, ρ = ρ_c = φ_c ρ_s, up to the height H [m] on the floor of a box with periodic
sides and a vacuum above; the floor rests for ``settle_time`` [s] (the bed settles under its
weight) and then moves as ϑ(t) = a sin(2πf(t − t_s)) with a = Γ g/(2πf)² (Γ the peak floor
acceleration over g).  The stress is the packing law of :class:`bsrflow.numerics.packing_nd.
PackingLawND` for spheres: zero below ρ_c, the affine uniaxial stiffness of an isotropic packing
k1 = 3Zφ_cK/(5πd²) [Pa/m] on loading and k1/e² on unloading from the largest overlap reached
(a history field carried by the material, reset where it separates), never tensile.  With
Z = 5.31 and φ_c = 0.636 of the settled LIGGGHTS bed (reference/liggghts_bed) and K = 5·10⁴ N/m,
e = 0.9, d = 5 mm, ρ_s = 1200 kg/m³ (that reference's reduced stiffness and spheres) as the
defaults.  The solver is :class:`bsrflow.numerics.packing_nd.EulerianPackingND` (formulation
(a) of the 1-D packing continuum along each axis).

In 2-D (x, z) the fields are those of a 3-D bed uniform in y, per metre of depth: ρ [kg/m²
per metre of depth] and the stress take the values of the 3-D density [kg/m³] and stress [Pa],
so a 2-D run is a 3-D run of a bed uniform in y.

The stiffness option of the 1-D column (:func:`bsrflow.physics.column.suggest_stiffness_factor`)
carries over: ``stiffness_factor`` φ in (0, 1] scales K (loading and unloading); the impact Mach
number M = max(3aω, √(2gd))/c (c = d√(k2/(ρ_c d)), the packing's wave speed at the stiffness used) is
:meth:`PackingBed.impact_mach`, and :meth:`PackingBed.suggest_stiffness_factor` gives the φ of a
chosen M.  What it costs is measured in 1-D (docs/model.md, "Stiffness").

A packing stress alone has no pressure in the dilute state: this bed bounces as a block where a
real one fluidises (docs/model.md, "The vibrated bed"); the granular-temperature model that
``bsrflow compare-bed`` runs is 1-D (:mod:`bsrflow.physics.granular_bed`).  Units: SI.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np

from .motion import MAX_SETTLE_TIME, SinusoidalVibration, check_frequency
from .packing import impact_speed, stiffness_factor_for_mach

__all__ = ["PackingBed"]


MAX_DENSITY = 1.0e5
"""The largest material density a bed accepts [kg/m^3]."""
MAX_STATIC_OVERLAP = 0.05
"""The largest overlap per contact [d] the bed's weight may cause at its bottom: the packing law
is the contact law's small-overlap limit."""
MAX_STEPS = 1.0e9
"""The most time steps a bed run may need (days of computing even on a small grid, at the
measured 70-140 ns per cell-stage; :meth:`PackingBed._check_stiffness`)."""


@dataclass
class PackingBed:
    """The vibrated packing bed of the module docstring (SI units).

    dim : 2 (x, z) or 3 (x, y, z); box_width : horizontal side L [m] (periodic);
    bed_height : H [m] of the bed at close packing (rounded to whole cells);
    diameter d [m]; density ρ_s [kg/m³]; stiffness K [N/m]; restitution e in [0.01, 1] (as the column's);
    phi_c : close-packing solid fraction in (0, 0.75); coordination Z > 0 (contacts per sphere);
    cells_per_diameter : d/Δx, an integer >= 1; frequency f [Hz]; gamma Γ = aω²/g >= 0;
    settle_time t_s [s] before the floor moves; t_end, save_every [s];
    stiffness_factor φ in (0, 1]; surface_perturbation δ in [0, 0.5]: the bed's top is
    H(1 + δ cos(2πx/L) cos(2πy/L)) (to break the lateral symmetry; 0: flat);
    cfl in (0, 0.5/n] (None: 0.4/n); gravity g [m/s²]; domain_height [m] (None: the energy
    bound H(1 + δ) + (3aω)²/(2g) + 3d + 10Δx, :meth:`energy_bound_height`).
    """

    dim: int = 3
    box_width: float = 0.02
    bed_height: float = 0.03
    diameter: float = 0.005
    density: float = 1200.0
    stiffness: float = 5.0e4
    restitution: float = 0.9
    phi_c: float = 0.636
    coordination: float = 5.31
    cells_per_diameter: int = 4
    frequency: float = 20.0
    gamma: float = 3.0
    settle_time: float = 0.05
    t_end: float = 0.3
    save_every: float = 0.005
    stiffness_factor: float = 1.0
    surface_perturbation: float = 0.0
    cfl: float | None = None
    gravity: float = 9.81
    domain_height: float | None = None

    def __post_init__(self):
        if isinstance(self.dim, bool) or self.dim not in (2, 3):
            raise ValueError(f"dim = {self.dim!r} is outside the valid range {{2, 3}}")
        for name in ("box_width", "bed_height", "diameter", "density", "stiffness", "coordination",
                     "t_end", "save_every", "gravity"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} = {v!r} is outside the valid range (0, inf)")
        check_frequency(self.frequency)
        if not (0.01 <= self.restitution <= 1.0):      # unloading K/e²: e → 0 makes the step vanish
            raise ValueError(f"restitution = {self.restitution!r} is outside the valid range [0.01, 1]")
        if not (0.0 < self.phi_c < 0.75):
            raise ValueError(f"phi_c = {self.phi_c!r} is outside the valid range (0, 0.75)")
        c = self.cells_per_diameter
        if isinstance(c, bool) or int(c) != c or c < 1:
            raise ValueError(f"cells_per_diameter = {c!r} is outside the valid range: integers >= 1")
        if not (math.isfinite(self.gamma) and self.gamma >= 0.0):
            raise ValueError(f"gamma = {self.gamma!r} is outside the valid range [0, inf)")
        if not (math.isfinite(self.settle_time) and 0.0 <= self.settle_time <= MAX_SETTLE_TIME):
            raise ValueError(f"settle_time = {self.settle_time!r} is outside the valid range "
                             f"[0, {MAX_SETTLE_TIME:.0f}] s")
        if not (math.isfinite(self.stiffness_factor) and 0.0 < self.stiffness_factor <= 1.0):
            raise ValueError(f"stiffness_factor = {self.stiffness_factor!r} is outside the valid range (0, 1]")
        if not (0.0 <= self.surface_perturbation <= 0.5):
            raise ValueError(f"surface_perturbation = {self.surface_perturbation!r} is outside the valid range "
                             "[0, 0.5]")
        lim = 0.5 / self.dim
        if self.cfl is not None and not (0.0 < self.cfl <= lim):
            raise ValueError(f"cfl = {self.cfl!r} is outside the valid range (0, {lim:g}] for dim = {self.dim}")
        if self.bed_height * (1.0 - self.surface_perturbation) < 2.0 * self.dx:
            raise ValueError(f"bed_height = {self.bed_height!r} m is outside the valid range: at least "
                             f"{2 * self.dx / (1 - self.surface_perturbation):.3g} m (two cells, also in the "
                             "troughs of the surface undulation)")
        if round(self.box_width / self.dx) < 1:      # (1 or 2 cells: refused with the grid's range, layer_runner)
            raise ValueError(f"box_width = {self.box_width!r} m is outside the valid range: at least three cells "
                             f"({3 * self.dx:g} m; the periodic grid needs 3 across)")
        if self.domain_height is not None and not (self.domain_height >= self.energy_bound_height()):
            raise ValueError(f"domain_height = {self.domain_height!r} m is outside the valid range "
                             f"[{self.energy_bound_height():.4g}, inf) m (energy bound)")
        from .scenarios_nd import check_whole_cells
        check_whole_cells("box_width", self.box_width, self.dx)
        if self.coordination > 12.0:                     # the kissing number of equal spheres
            raise ValueError(f"coordination = {self.coordination!r} is outside the valid range (0, 12]")
        if self.density > MAX_DENSITY:
            raise ValueError(f"density = {self.density!r} kg/m^3 is outside the valid range (0, {MAX_DENSITY:g}] "
                             "(the densest solids are about 22 600 kg/m^3)")
        self._check_stiffness()

    def _check_stiffness(self):
        """The contact stiffness in use, K·stiffness_factor, neither so soft that the bed's
        weight overlaps its bottom contacts by more than 5 % of d (the packing law is a
        small-overlap law; a softer bed also falls through cells in one step) nor so stiff that
        the run needs more than 1e9 time steps.  ValueError naming ``stiffness`` with the
        valid range at these settings."""
        law = self.law()
        k_used = self.stiffness * self.stiffness_factor
        weight = law.close_packing_density * self.gravity * self.bed_height        # stress at the bottom [Pa]
        overlap = weight / law.k1                                                  # δ = σ / k1 [m]
        k_min = k_used * overlap / (MAX_STATIC_OVERLAP * self.diameter)
        cfl = 0.4 / self.dim if self.cfl is None else self.cfl
        speed_per_root_k = law.wave_speed() / math.sqrt(k_used)                     # c ∝ √K
        steps = self.t_end * law.wave_speed() / (cfl * self.dx)
        k_max = (MAX_STEPS * cfl * self.dx / (self.t_end * speed_per_root_k)) ** 2
        unit = "" if self.stiffness_factor == 1.0 else f" (× stiffness_factor {self.stiffness_factor:g})"
        if overlap > MAX_STATIC_OVERLAP * self.diameter:
            raise ValueError(f"stiffness = {self.stiffness!r} N/m{unit} is outside the valid range at these settings, "
                             f"[{k_min / self.stiffness_factor:.3g}, {k_max / self.stiffness_factor:.3g}] N/m: the "
                             f"bed's weight would overlap its bottom contacts by {overlap / self.diameter:.3g} d "
                             f"(at most {MAX_STATIC_OVERLAP:g} d)")
        if steps > MAX_STEPS:
            raise ValueError(f"stiffness = {self.stiffness!r} N/m{unit} is outside the valid range at these settings, "
                             f"[{k_min / self.stiffness_factor:.3g}, {k_max / self.stiffness_factor:.3g}] N/m: the run "
                             f"would take about {steps:.2g} time steps (at most {MAX_STEPS:.0e}; a stiffness_factor "
                             "below 1 reduces it)")

    @property
    def dx(self) -> float:
        """Cell side Δx = d / cells_per_diameter [m]."""
        return self.diameter / self.cells_per_diameter

    @property
    def amplitude(self) -> float:
        """a = Γ g / (2πf)² [m]."""
        return self.gamma * self.gravity / (2.0 * math.pi * self.frequency) ** 2

    def floor_speed(self) -> float:
        """aω [m/s], the floor's largest speed."""
        return self.amplitude * 2.0 * math.pi * self.frequency

    def energy_bound_height(self) -> float:
        """H(1 + δ) + (3aω)²/(2g) + 3d + 10Δx [m]: launch speeds up to 3aω (as for the column),
        and room for the thin tail of material that the scheme's diffusion spreads above the
        bed's top (:attr:`bsrflow.numerics.packing_nd.EulerianPackingND.top_fraction`)."""
        v = 3.0 * self.floor_speed()
        return (self.bed_height * (1.0 + self.surface_perturbation) + v * v / (2.0 * self.gravity)
                + 3.0 * self.diameter + 10.0 * self.dx)

    def law(self, stiffness_factor: float | None = None):
        """The packing stress (:meth:`PackingLawND.for_spheres`) at ``stiffness_factor`` (None: the setup's)."""
        from ..numerics.packing_nd import PackingLawND
        phi = self.stiffness_factor if stiffness_factor is None else stiffness_factor
        return PackingLawND.for_spheres(self.stiffness, self.restitution, self.diameter, self.density, self.phi_c,
                                        self.coordination, stiffness_factor=phi)

    def motion(self):
        return SinusoidalVibration(self.amplitude, self.frequency, start=self.settle_time)

    def grid(self):
        from ..numerics.grid_nd import GridND
        H = self.domain_height or self.energy_bound_height()
        nz = int(math.ceil(H / self.dx - 1e-9))
        nh = int(round(self.box_width / self.dx))
        return GridND((nh,) * (self.dim - 1) + (nz,), self.dx, bc_horizontal="periodic", bc_lower="floor",
                      bc_upper="vacuum")

    def initial_density(self, grid=None) -> np.ndarray:
        """ρ0 (*shape) [kg/m^n]: ρ_c in the cells below the bed's top (rounded to whole cells), 0
        above; at rest, unstressed (it settles during ``settle_time``)."""
        from .scenarios_nd import undulated_surface_cells
        grid = grid or self.grid()
        m = undulated_surface_cells(grid, self.bed_height, self.surface_perturbation, self.box_width)
        k = np.arange(grid.shape[-1])
        return np.where(k < m[..., None], self.phi_c * self.density, 0.0)

    def impact_speed(self) -> float:
        """max(3aω, √(2gd)) [m/s] (:func:`bsrflow.physics.packing.impact_speed`, the column's)."""
        return impact_speed(3.0 * self.floor_speed(), self.gravity, self.diameter)

    def impact_mach(self) -> float:
        """M = v/c with v = :meth:`impact_speed`, c = d√(k2/(ρ_c d)) the packing's wave speed at
        the stiffness used."""
        return self.impact_speed() / self.law().wave_speed()

    def suggest_stiffness_factor(self, mach: float) -> float:
        """The factor of impact Mach number ``mach`` in (0, 1] (the 1-D column's rule,
        :func:`bsrflow.physics.packing.stiffness_factor_for_mach`)."""
        return stiffness_factor_for_mach(self.impact_speed(), self.law(1.0).wave_speed(), mach)

    def discretisation(self, tracers=None):
        """The :class:`~bsrflow.numerics.packing_nd.EulerianPackingND` of this bed at t = 0, with
        ``tracers`` (None or (n, dim) positions [m], floor frame) moved by the scheme."""
        from ..numerics.packing_nd import EulerianPackingND
        grid = self.grid()
        return EulerianPackingND(self.law(), grid, self.motion(), self.gravity, self.initial_density(grid),
                                 cfl=self.cfl, tracers=tracers)

    def mass(self) -> float:
        """Mass of the bed [kg] (3-D) or per metre of depth [kg/m] (2-D)."""
        return float(np.sum(self.initial_density()) * self.dx ** self.dim)

    def with_(self, **kw):
        return replace(self, **kw)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["amplitude"] = self.amplitude
        d["units"] = {"box_width": "m", "bed_height": "m", "diameter": "m", "density": "kg m-3", "stiffness": "N m-1",
                      "frequency": "Hz", "settle_time": "s", "t_end": "s", "save_every": "s", "gravity": "m s-2",
                      "domain_height": "m", "amplitude": "m"}
        return d
