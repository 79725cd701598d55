"""2-D / 3-D scenarios: a tapped granular layer in a box and a sinusoidally vibrated box.

Both put a layer of material (density ρ_b [kg/m^n] at the floor, height H [m]) at rest on the
floor of a box (mirror walls by default, or periodic sides), with a vacuum above, and move the
floor vertically (:mod:`bsrflow.physics.motion`).  The n-D model, its floor-frame form
(3.16)-(3.17) and the vector Walton-Braun kernel are those of
:mod:`bsrflow.physics.kernels_nd`; the solver is :class:`bsrflow.numerics.solver_nd.SimulationND`.

Material and the resting layer.  The kernel radius R is one particle diameter d.  A purely
repulsive kernel makes the continuum a cohesionless "gas": to leading order in R the
interaction acceleration is -M ∇ρ with M = -∫_B z_z Θ_z dz = πλR⁵/15 (3-D) or πλR⁴/12 (2-D)
(:func:`bsrflow.physics.kernels_nd.walton_braun_nd`), so away from its top a layer at rest
satisfies M ∂ρ/∂z = -g: the density falls linearly with height, over c²/g for a bottom sound
speed c (with the stiffness of a real grain contact that is metres, seed-notes problem 2).
Within R of the top the non-local sum sees no material above, and the resting layer ends with
a density jump (about 13 % of the bottom density for a layer 4 radii tall).  A uniform slab
or the linear profile cut at zero is therefore far from rest: its top collapses and the layer
rings.  The scenarios start from the exact *discrete* rest state instead: for a layer of m =
H/Δx cells the n-D quadrature sum (with the floor's point-reflected density images) is a linear
map of the column profile, and ``I_j = g`` for j < m, ρ_j = 0 above, is a linear system
(:func:`resting_profile`).  Its solution scales as 1/λ, so the kernel strength λ is chosen to
give the requested density ρ_b at the floor; the bottom sound speed is then c = sqrt(κ ρ_b)
(κ the discrete moment, :meth:`bsrflow.numerics.solver_nd.SimulationND.stiffness_moment`),
about sqrt(g H).  ε = 0.105 (restitution 0.9, as the 1-D column).

Initial state.  Each column (x, y) holds the resting profile of m(x, y) = round(h/Δx) cells with
h = H (1 + δ cos(2πx/L) cos(2πy/L)) a surface undulation (δ = ``surface_perturbation``; no y
factor in 2-D), u = 0.  With δ > 0 it is level only on average and sloshes while settling
during ``settle_time`` before the floor starts to move.

What the scheme does to the resting layer (measured, flat layer δ = 0, floor at rest, 3-D
defaults, 0.2 s; :func:`run_scenario`):

* unfiltered, elastic kernel (ε = 0): exactly at rest (kinetic energy 1e-34 J, |u| < 1e-15).
* unfiltered, ε = 0.105: round-off velocity differences switch the factor σ(z·Δu) of the
  kernel, whose ε-part does not vanish as Δu → 0 (a Coulomb-like, discontinuous force).
  Explicit steps then chatter: |u| grows to ~6 mm/s, ρ dips to -0.7 kg/m³.  The 1-D solver
  does the same (a uniform state with 1e-6 m/s noise reaches 3-40 % density noise in 0.1 s).
* the seed's scheme (moving average (5.7) after every step): the average diffuses the top's
  density jump into the vacuum; the material it spreads there is not held up and falls back,
  so the layer never rests: its centre of mass rises from 8.6 to 9.5 mm, then falls to
  about 6-7 mm with kinetic energy ~1e-4 J persisting, and a little mass (3e-7 relative) is
  carried out through the vacuum top of this short domain.  The same happens in 1-D (the
  embedding makes the two identical for flat layers).
* negative densities: central differences of the mass flux next to a receding free surface
  take a little mass out of the empty cell above it (dρ/dt = ρ_below u_below / (2Δx) < 0);
  in the shipped scenarios min ρ is about -2 kg/m³ (-0.3 % of ρ_b) with the seed's scheme,
  which has no positivity mechanism.  The scenarios therefore run it with the column-wise,
  mass-conserving positivity fix (``positivity=True``, the default;
  ``compiled_nd.make_positive_columns``: a negative cell is set to 0 and its deficit taken from
  the nearest positive cells of its vertical column), so ρ ≥ 0 and the mass is kept to
  round-off; ``positivity=False`` gives the seed's scheme as it is.

Domain height from an energy bound as for the column: the floor moves at most at aω; launch
speeds up to 3aω give flights of (3aω)²/(2g); the domain is H + (3aω)²/(2g) + 3R (rounded up
to whole cells).  The solver stops with an error if material reaches the top anyway.

Defaults are small (3-D, 16 × 16 × ~20 cells, Δx = 3 mm, R = 2 cells, 0.2 s, about 190 steps)
and run in 2-3 s on one core after compilation.  Units: SI.
"""

from __future__ import annotations

import functools
import math
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from ..numerics.grid_nd import GridND, ball_quadrature
from ..numerics.solver import Scheme
from ..numerics.solver_nd import ResultND, SimulationND
from .kernels_nd import BSRModelND, walton_braun_nd
from .motion import MAX_SETTLE_TIME, HalfSineTaps, SinusoidalVibration, check_frequency

__all__ = ["LayerSetup", "TappedLayer", "VibratedBox", "ScenarioRun", "run_scenario", "resting_profile",
           "check_whole_cells"]


def check_whole_cells(name: str, length: float, dx: float, least: int = 3) -> None:
    """Refuse a periodic box side ``length`` [m] that is not a whole number of cells of side
    ``dx`` [m] (ValueError naming ``name``): the grid would round it and the surface undulation,
    computed with the length as given, would no longer be periodic.  The suggested lengths are
    at least ``least`` cells (the periodic grid's 3)."""
    n = length / dx
    if abs(n - round(n)) > 1e-9 * max(1.0, n):
        lo, hi = max(math.floor(n), least) * dx, max(math.ceil(n), least + 1) * dx
        raise ValueError(f"{name} = {length!r} m is not a whole number of cells of Δx = {dx:.6g} m "
                         f"(d / cells_per_diameter; {n:.4g} cells): valid are multiples of Δx, e.g. "
                         f"{lo:.6g} or {hi:.6g} m")


def undulated_surface_cells(grid, height, perturbation, box_width) -> np.ndarray:
    """Cells below the surface h = H (1 + δ cos(2πx/L) cos(2πy/L)) (no y factor in 2-D) of each
    vertical column of ``grid``: round(h/Δx), an integer array of the horizontal shape."""
    X = grid.mesh()
    h = np.cos(2 * np.pi * X[0][..., 0] / box_width)
    if grid.dim == 3:
        h = h * np.cos(2 * np.pi * X[1][..., 0] / box_width)
    return np.rint(height * (1.0 + perturbation * h) / grid.dx).astype(int)


@functools.lru_cache(maxsize=64)
def _layer_table(dim: int, W: int, dx: float) -> np.ndarray:
    """T_k = Σ_{o: o_z = k} w_o Θ_z(c_o; u = 0) for the unit-strength Walton-Braun kernel of
    radius W Δx [m^(n+1) s⁻² kg⁻¹]: the vertical quadrature sum per layer k = -W..W."""
    offs, nodes, wts = ball_quadrature(dim, W, dx)
    c3 = np.zeros((len(wts), 3))
    c3[:, 0] = nodes[:, 0]
    c3[:, 2] = nodes[:, -1]
    if dim == 3:
        c3[:, 1] = nodes[:, 1]
    zero = np.zeros(len(wts))
    th = walton_braun_nd(1.0, 0.0, W * dx)((c3[:, 0], c3[:, 1], c3[:, 2]), (zero,) * 3, (zero,) * 3)[2]
    T = np.zeros(2 * W + 1)
    np.add.at(T, offs[:, -1] + W, wts * th)
    return T


def resting_profile(dim: int, W: int, dx: float, m: int, gravity: float) -> np.ndarray:
    """Density ρ_j (j = 0..m-1) [kg/m^n] of a horizontally uniform layer of m cells at rest on
    the supporting floor, for the Walton-Braun kernel of radius W Δx and unit strength (divide by
    λ for strength λ): the solution of Σ_k T_k ρ_{j+k} = g (j < m), ρ = 0 above, with the floor's
    images ρ_{-i} = 2 ρ_w - ρ_{i-1}, ρ_w = (3ρ_0 - ρ_1)/2 (grid_nd).  Raises ValueError if the
    solution is not positive (the floor images then would be clipped)."""
    if int(m) != m or m < W + 1:
        raise ValueError(f"m = {m!r} (layer height in cells) is outside the valid range: integers >= {W + 1}")
    T = _layer_table(int(dim), int(W), float(dx))
    A = np.zeros((m, m))
    for j in range(m):
        for k in range(-W, W + 1):
            i = j + k
            if i >= m:
                continue
            if i >= 0:
                A[j, i] += T[k + W]
            else:                              # floor image of cell -i-1 through ρ_w
                A[j, 0] += 3.0 * T[k + W]
                A[j, 1] -= T[k + W]
                A[j, -i - 1] -= T[k + W]
    rho = np.linalg.solve(A, np.full(m, float(gravity)))
    if not np.all(rho > 0):
        raise ValueError(f"m = {m}: the resting profile is not positive; use a taller layer")
    return rho


@dataclass
class LayerSetup:
    """A layer of material resting on the floor of a box (SI units).

    dim : 2 (x, z) or 3 (x, y, z).
    box_width : horizontal side L [m] (all horizontal axes).
    layer_height : H [m], the top of the resting layer (rounded to whole cells, >= R + Δx).
    diameter : particle diameter d = kernel radius R [m].
    cells_per_diameter : R / Δx, an integer >= 2.
    bottom_density : ρ_b [kg/m^n], the density at the floor of the resting layer.
    dissipation : ε of the kernel, in [0, 1).
    gravity : g [m/s²].
    sides : 'wall' (mirror walls) or 'periodic'.
    surface_perturbation : δ, relative amplitude of the initial surface undulation, [0, 0.5].
    settle_time : time at rest before the floor moves [s].
    t_end : end time [s]; save_every : snapshot interval [s].
    scheme : preset name of :class:`bsrflow.numerics.solver.Scheme` ('seed').
    positivity : add the column-wise mass-conserving positivity fix to the preset (True; see
        the module docstring); a :class:`Scheme` passed to :func:`run_scenario` is used as given.
    average : moving average 'na' (5.7) or 'tensor'.
    domain_height : total height [m] (default: the energy bound).
    """

    dim: int = 3
    box_width: float = 0.048
    layer_height: float = 0.024
    diameter: float = 0.006
    cells_per_diameter: int = 2
    bottom_density: float = 700.0
    dissipation: float = 0.105
    gravity: float = 9.81
    sides: str = "wall"
    surface_perturbation: float = 0.1
    settle_time: float = 0.1
    t_end: float = 0.2
    save_every: float = 0.01
    scheme: str = "seed"
    average: str = "na"
    domain_height: float | None = None
    positivity: bool = True

    def __post_init__(self):
        if self.dim not in (2, 3):
            raise ValueError(f"dim = {self.dim!r} is outside the valid range {{2, 3}}")
        if not isinstance(self.positivity, (bool, np.bool_)):
            raise ValueError(f"positivity = {self.positivity!r} must be True or False")
        if not (1e-6 <= self.bottom_density <= 1e6):        # NaN fails too
            raise ValueError(f"bottom_density = {self.bottom_density!r} is outside the valid range [1e-06, 1e+06] "
                             "kg/m^n")
        for name, v in (("box_width", self.box_width), ("layer_height", self.layer_height),
                        ("diameter", self.diameter), ("t_end", self.t_end),
                        ("save_every", self.save_every)):
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"{name} = {v!r} is outside the valid range (0, inf)")
        if int(self.cells_per_diameter) != self.cells_per_diameter or self.cells_per_diameter < 2:
            raise ValueError(f"cells_per_diameter = {self.cells_per_diameter!r} is outside the valid range: "
                             "integers >= 2")
        if not (0.0 <= self.dissipation < 1.0):
            raise ValueError(f"dissipation = {self.dissipation!r} is outside the valid range [0, 1)")
        if not (1e-3 <= self.gravity <= 1e4):                # the column's range; NaN fails too
            raise ValueError(f"gravity = {self.gravity!r} is outside the valid range [0.001, 10000] m/s^2")
        if self.average not in ("na", "tensor"):
            raise ValueError(f"average = {self.average!r} is not one of ('na', 'tensor')")
        if self.sides not in ("wall", "periodic"):
            raise ValueError(f"sides = {self.sides!r} is not one of ('wall', 'periodic')")
        if self.scheme != "seed":
            raise ValueError(f"scheme = {self.scheme!r} is not valid for a 2-D / 3-D layer (valid: 'seed'; the n-D "
                             "solver refuses the 'accurate' preset's dissipation options)")
        if not (0.0 <= self.surface_perturbation <= 0.5):
            raise ValueError(f"surface_perturbation = {self.surface_perturbation!r} is outside the valid "
                             "range [0, 0.5]")
        if not (np.isfinite(self.settle_time) and 0 <= self.settle_time <= MAX_SETTLE_TIME):
            raise ValueError(f"settle_time = {self.settle_time!r} is outside the valid range "
                             f"[0, {MAX_SETTLE_TIME:.0f}] s")
        if self.layer_cells * (1.0 - self.surface_perturbation) < self.cells_per_diameter + 1:
            m_min = self.least_layer_cells()
            raise ValueError(f"layer_height = {self.layer_height!r} m is outside the valid range: at least "
                             f"{(m_min - 0.5 + 1e-6) * self.dx:.4g} m ({m_min} cells of Δx = {self.dx:.4g} m: kernel "
                             "radius + 1 cell, also in the troughs of the surface undulation)")
        if round(self.box_width / self.dx) < self.cells_per_diameter + 1:      # (whole cells: checked next)
            raise ValueError(f"box_width = {self.box_width!r} m is outside the valid range: at least "
                             f"{(self.cells_per_diameter + 1) * self.dx:g} m (kernel radius + 1 cell)")
        check_whole_cells("box_width", self.box_width, self.dx)

    @property
    def dx(self) -> float:
        """Cell side Δx = d / cells_per_diameter [m]."""
        return self.diameter / self.cells_per_diameter

    def floor_speed(self) -> float:
        """Largest floor speed [m/s] (overridden by the scenarios)."""
        return 0.0

    def energy_bound_height(self) -> float:
        v = 3.0 * self.floor_speed()
        return self.layer_height * (1 + self.surface_perturbation) + v * v / (2 * self.gravity) + 3 * self.diameter

    def grid(self) -> GridND:
        H = self.domain_height or self.energy_bound_height()
        if H < self.energy_bound_height():
            raise ValueError(f"domain_height = {H!r} m is outside the valid range "
                             f"[{self.energy_bound_height():.4g}, inf) m (energy bound)")
        nz = int(math.ceil(H / self.dx - 1e-9))
        nh = int(round(self.box_width / self.dx))
        shape = (nh,) * (self.dim - 1) + (nz,)
        return GridND(shape, self.dx, bc_horizontal=self.sides, bc_lower="floor", bc_upper="vacuum")


    def least_layer_cells(self) -> int:
        """The fewest cells m = round(H / Δx) the resting layer may have: m (1 − δ) ≥ c + 1 (the
        kernel radius + 1 cell, also in the troughs of the surface undulation of amplitude δ);
        the least height is then (m − ½) Δx."""
        return math.ceil((self.cells_per_diameter + 1) / (1.0 - self.surface_perturbation) - 1e-9)

    @property
    def layer_cells(self) -> int:
        """m = round(H / Δx), the resting layer's height in cells."""
        return int(round(self.layer_height / self.dx))

    def strength(self) -> float:
        """λ [kg⁻¹ s⁻²] that makes the resting profile's floor density ρ_b (module docstring)."""
        prof = resting_profile(self.dim, self.cells_per_diameter, self.dx, self.layer_cells, self.gravity)
        return prof[0] / self.bottom_density

    def kernel(self):
        return walton_braun_nd(self.strength(), self.dissipation, self.diameter)

    def motion(self):
        raise NotImplementedError

    def model(self) -> BSRModelND:
        return BSRModelND(self.kernel(), self.motion(), self.gravity)

    def initial_state(self, grid: GridND | None = None):
        """(u0 (n, *shape) [m/s], ρ0 (*shape) [kg/m^n]) of the module docstring."""
        grid = grid or self.grid()
        m = undulated_surface_cells(grid, self.layer_height, self.surface_perturbation, self.box_width)
        lam = self.strength()
        rho = np.zeros(grid.shape)
        for mc in np.unique(m):
            prof = resting_profile(self.dim, self.cells_per_diameter, self.dx, int(mc), self.gravity) / lam
            rho[m == mc, :int(mc)] = prof
        return np.zeros((self.dim,) + grid.shape), rho

    def with_(self, **kw):
        return replace(self, **kw)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["kind"] = type(self).__name__
        return d


@dataclass
class TappedLayer(LayerSetup):
    """The tapped layer: half-sine displacement taps (4.5) of the floor, amplitude a [m],
    frequency f [Hz], ``n_taps`` taps ``tap_period`` [s] apart, the first after the settling
    time.  The 3-D counterpart of the tapped column (:mod:`bsrflow.physics.column`)."""

    amplitude: float = 0.003
    frequency: float = 10.0
    n_taps: int = 1
    tap_period: float = 0.5

    def __post_init__(self):
        super().__post_init__()
        if not (np.isfinite(self.amplitude) and self.amplitude >= 0):
            raise ValueError(f"amplitude = {self.amplitude!r} is outside the valid range [0, inf) m")
        check_frequency(self.frequency)
        if int(self.n_taps) != self.n_taps or self.n_taps < 1:
            raise ValueError(f"n_taps = {self.n_taps!r} is outside the valid range: integers >= 1")
        dur = 0.5 / self.frequency
        if self.n_taps > 1 and not (np.isfinite(self.tap_period) and self.tap_period >= dur):
            raise ValueError(f"tap_period = {self.tap_period!r} is outside the valid range [{dur:g}, inf) s "
                             f"(at least one tap, 1/(2f) = {dur:g} s)")

    def floor_speed(self) -> float:
        return self.amplitude * 2 * math.pi * self.frequency

    def motion(self):
        return HalfSineTaps(self.amplitude, self.frequency, start=self.settle_time, n_taps=self.n_taps,
                            period=self.tap_period)


@dataclass
class VibratedBox(LayerSetup):
    """The vibrated box: the floor moves as ϑ = a sin(2πf (t - t_s)) from the settling time t_s
    on.  Default a = 1 mm, f = 25 Hz: peak acceleration Γ = aω²/g ≈ 2.5, so the layer leaves the
    floor once per cycle."""

    amplitude: float = 0.001
    frequency: float = 25.0

    def __post_init__(self):
        super().__post_init__()
        if not (np.isfinite(self.amplitude) and self.amplitude >= 0):
            raise ValueError(f"amplitude = {self.amplitude!r} is outside the valid range [0, inf) m")
        check_frequency(self.frequency)

    def floor_speed(self) -> float:
        return self.amplitude * 2 * math.pi * self.frequency

    def motion(self):
        return SinusoidalVibration(self.amplitude, self.frequency, start=self.settle_time)


@dataclass
class ScenarioRun:
    """Result of a scenario run.  ``result`` holds the snapshots (floor frame); the series are
    per snapshot: mass [kg (3-D), kg/m (2-D)], min_density [kg/m^n], kinetic [J (or J/m)],
    centre_of_mass [m] (laboratory frame), floor [m]."""

    setup: LayerSetup
    result: ResultND
    mass: np.ndarray
    min_density: np.ndarray
    kinetic: np.ndarray
    centre_of_mass: np.ndarray
    floor: np.ndarray
    info: dict = field(default_factory=dict)

    @property
    def relative_mass_drift(self) -> float:
        """max |m(t) - m(0)| / m(0)."""
        return float(np.max(np.abs(self.mass - self.mass[0])) / self.mass[0])


def run_scenario(setup: LayerSetup, scheme: Scheme | str | None = None, observers=(), progress=None) -> ScenarioRun:
    """Run a :class:`TappedLayer` or :class:`VibratedBox` from its initial state to ``t_end``."""
    if not isinstance(setup, (TappedLayer, VibratedBox)):
        raise ValueError(f"setup = {setup!r} must be a TappedLayer or a VibratedBox")
    if scheme is None:
        scheme = setup.scheme
    if isinstance(scheme, str):
        scheme = Scheme.preset(scheme, positivity=bool(setup.positivity))
    grid = setup.grid()
    sim = SimulationND(setup.model(), grid, scheme, average=setup.average,
                       vacuum_density=1e-4 * setup.bottom_density, top_tolerance=1e-3 * setup.bottom_density)
    u0, rho0 = setup.initial_state(grid)
    res = sim.run(u0, rho0, setup.t_end, save_every=setup.save_every, observers=observers, progress=progress)
    nt = len(res.t)
    mins = res.rho.reshape(nt, -1).min(axis=1)
    com = res.centre_of_mass_height() + res.floor
    return ScenarioRun(setup, res, res.mass(), mins, res.kinetic_energy(), com, res.floor,
                       {"steps": res.steps, "wall_time_s": res.wall_time, "grid": grid.to_dict(),
                        "kernel": sim.model.kernel.to_dict(), "kappa": sim.kappa,
                        "bottom_sound_speed": float(np.sqrt(sim.kappa * setup.bottom_density))})
