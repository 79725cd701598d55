"""Driver of the 2-D / 3-D semidiscrete BSR solver, its NumPy reference, and the embedding check.

The model (floor frame, (3.7)-(3.8) with (3.16)-(3.17), z vertical, see
:mod:`bsrflow.physics.kernels_nd`):

    u_t + (u·∇)u = -g e_z - ϑ''(t) e_z + ∫_{B_R(x)} ρ(y) Θ(y - x, u(x), u(y)) dy,
    ρ_t = -div(ρ u),

discretised with central differences, the ball quadrature of :mod:`bsrflow.numerics.grid_nd`,
an explicit Runge-Kutta tableau (:mod:`bsrflow.numerics.steppers`) and, optionally, a moving
average after every step: the seed's (5.7) (``average="na"``, default) or the tensor product of
the 1-D average (``average="tensor"``).  Velocity jumps of the applied motion shift u_z by -Δ
at the jump time (as :mod:`bsrflow.numerics.solver`).

Happy path::

    from bsrflow.numerics.grid_nd import GridND
    from bsrflow.numerics.solver_nd import SimulationND
    from bsrflow.physics.kernels_nd import BSRModelND, walton_braun_nd
    grid = GridND((16, 16, 40), dx=0.005, bc_horizontal="wall")
    model = BSRModelND(walton_braun_nd(1e7, 0.1, 0.01), gravity=9.81)
    sim = SimulationND(model, grid)
    res = sim.run(u0, rho0, t_end=0.1, save_every=0.01)   # u0 (3, 16, 16, 40) m/s, rho0 kg/m^3

A column, ``GridND((n_z,), dx)``, runs through the same API on the 1-D discretisation (see
:class:`SimulationND`).  Not in the 2-D / 3-D discretisation (1-D only): user external forces,
Dirichlet boundaries, the compression-rate monitor, the options refused by
:func:`check_scheme_supported`.

Embedding.  A state that does not vary horizontally and has no horizontal velocity stays so, and
its vertical profile obeys a 1-D BSR system whose kernel is the n-D kernel summed over the
horizontal offsets of each vertical layer of the ball table.  :func:`induced_kernel_1d` builds
that kernel as a 1-D :class:`bsrflow.physics.kernels.Kernel` (a table per vertical offset k,
divided by the 1-D trapezoid weights so that the 1-D quadrature sum reproduces the n-D sum);
:func:`embedding_error` runs both solvers and returns the largest difference.
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field

import numpy as np

from ..physics.kernels import Kernel
from ..physics.kernels_nd import BSRModelND, KernelND, walton_braun_nd
from ..physics.model import BSRModel
from ..physics.motion import HalfSineTaps
from .compiled import STATUS
from .compiled_nd import make_core_nd
from .grid import Grid1D
from .grid_nd import GridND, ball_quadrature
from .quadrature import quadrature_weights
from .solver import (Scheme, Simulation, SimulationError, _check_declared_bound, _require_number, check_run_limits,
                     save_schedule)
from .steppers import get_stepper

__all__ = ["SimulationND", "ResultND", "ReferenceND", "induced_kernel_1d", "embedding_error",
           "verify_cases", "to_internal", "from_internal", "BSRModelND", "KernelND", "walton_braun_nd"]

AVERAGES = {"na": 1, "tensor": 2}


# ---- layout helpers ------------------------------------------------------------------------
def to_internal(grid: GridND, u, rho, names=("u", "rho")):
    """User layout (u (n, *shape), ρ shape) -> internal (u (3, n_x, n_y, n_z), ρ (n_x, n_y, n_z))."""
    u = np.asarray(u, float)
    rho = np.asarray(rho, float)
    if u.shape != (grid.dim,) + grid.shape:
        raise ValueError(f"{names[0]} has shape {u.shape}; expected {(grid.dim,) + grid.shape} "
                         "(one component per axis)")
    if rho.shape != grid.shape:
        raise ValueError(f"{names[1]} has shape {rho.shape}; expected {grid.shape} to match the grid")
    if grid.dim == 3:
        return np.ascontiguousarray(u), np.ascontiguousarray(rho)
    ui = np.zeros((3,) + grid.shape3)
    ui[0] = u[0][:, None, :]
    ui[2] = u[1][:, None, :]
    return ui, np.ascontiguousarray(rho[:, None, :])


def from_internal(grid: GridND, ui, ri):
    """Inverse of :func:`to_internal` (copies)."""
    if grid.dim == 3:
        return ui.copy(), ri.copy()
    return np.stack([ui[0][:, 0, :], ui[2][:, 0, :]]), ri[:, 0, :].copy()


# ---- results -------------------------------------------------------------------------------
@dataclass
class ResultND:
    """Saved snapshots; arrays have the time axis first.  u (nt, n, *shape) [m/s] relative to
    the floor, rho (nt, *shape) [kg/m^n], t [s], floor ϑ(t) [m] in the laboratory frame."""

    t: np.ndarray
    u: np.ndarray
    rho: np.ndarray
    floor: np.ndarray
    grid: GridND
    steps: int = 0
    wall_time: float = 0.0
    status: str = "ok"
    info: dict = field(default_factory=dict)
    tracers: np.ndarray | None = None
    """(nt, n, dim) tracer positions [m] (floor frame) when the run had tracers."""

    def mass(self) -> np.ndarray:
        """Total mass Σ ρ Δx^n [kg per unit length in 2-D (per metre of y), kg in 3-D]."""
        return self.rho.reshape(len(self.t), -1).sum(axis=1) * self.grid.cell_volume

    def kinetic_energy(self) -> np.ndarray:
        """Σ ½ ρ |u|² Δx^n [J (per metre in 2-D)] at each saved time (floor frame)."""
        e = 0.5 * self.rho * (self.u ** 2).sum(axis=1)
        return e.reshape(len(self.t), -1).sum(axis=1) * self.grid.cell_volume

    def centre_of_mass_height(self) -> np.ndarray:
        """Height of the centre of mass above the grid's lower end [m]."""
        z = self.grid.z - self.grid.lower[-1]
        m = self.rho.reshape(len(self.t), -1, self.grid.shape[-1]).sum(axis=1)
        return (m * z).sum(axis=1) / np.maximum(m.sum(axis=1), 1e-300)


# ---- the simulation ------------------------------------------------------------------------
SCHEME_OPTIONS_ND = frozenset({"stepper", "filter", "cfl", "dt", "name", "check_cfl", "tracer_integrator",
                               "positivity"})
"""The :class:`~bsrflow.numerics.solver.Scheme` options the n-D solver acts on; every other one
must keep its default (:func:`check_scheme_supported`).  ``tracer_integrator`` moves the
tracers of ``SimulationND.run(..., tracers=...)``."""


def check_scheme_supported(scheme: Scheme, supported, where: str):
    """Refuse (ValueError, one line naming the option and its valid value) a scheme that sets an
    option ``where`` does not implement: every :class:`Scheme` field outside ``supported`` must
    have its default.  A named preset (e.g. 'accurate') is named in the message."""
    from dataclasses import fields
    for f in fields(Scheme):
        if f.name in supported:
            continue
        value, default = getattr(scheme, f.name), f.default
        if value != default:
            preset = f" (set by the scheme preset {scheme.name!r})" if scheme.name not in ("custom", "seed") else ""
            raise ValueError(f"scheme option {f.name} = {value!r}{preset} is not supported by {where}; "
                             f"valid: {default!r} (supported options: {', '.join(sorted(supported))})")


class SimulationND:
    """A BSR model on a 1-D, 2-D or 3-D grid with a scheme: one API for every dimension.

    On a column (``grid.dim == 1``) the 1-D discretisation runs (:class:`bsrflow.numerics.solver.
    Simulation` on :meth:`GridND.as_grid1d`, with the kernel's restriction to the line,
    :meth:`KernelND.on_line`, and its registered fast integral): it supports every scheme option
    and gives the 1-D solver's results bit for bit; ``run`` takes and returns the n-D layout (u of
    shape (1, n), tracers (n_tr, 1)).  In 2-D and 3-D the n-D discretisation below runs.

    Parameters
    ----------
    model : :class:`bsrflow.physics.kernels_nd.BSRModelND`.
    grid : :class:`bsrflow.numerics.grid_nd.GridND`; the kernel radius must be a whole number
        W >= 2 of cells.
    scheme : :class:`bsrflow.numerics.solver.Scheme`; the options of :data:`SCHEME_OPTIONS_ND`
        (stepper, filter, cfl, dt, check_cfl, positivity: the column-wise mass-conserving fix
        ``compiled_nd.make_positive_columns`` after every step); any other option set away from
        its default (rtol, hyperdiffusion, the sensor, the 1-D quadrature, i.e. the 'accurate'
        preset) is refused with a ValueError naming it.  Default: the seed's preset.  Without a
        fixed dt the step is Δt = cfl Δx / (max_cells Σ_a |u_a| + sqrt(n κ max ρ)), κ from
        :meth:`stiffness_moment` (the n-D bound of central differences).
    average : moving average when ``scheme.filter``: 'na' the seed's (5.7), 'tensor' the
        product of 1-D (1/4, 1/2, 1/4) averages.
    rho_max : stop when ρ exceeds this [kg/m^n] (0: no bound).
    dt_min : stop when the CFL step falls below this [s].
    top_tolerance : with a vacuum top, stop when ρ [kg/m^n] within W cells of the top exceeds
        this (0: off).
    max_steps : stop after this many steps.
    vacuum_density : cells with ρ below this [kg/m^n] are vacuum: after every step their velocity
        is replaced by that of the nearest material cell of their vertical column (0: off), the
        1-D solver's velocity extension applied column by column
        (``compiled_nd.extend_velocity``).
    density_floor : at the end of every step (after the positivity fix) densities with |ρ|
        below this [kg/m^n] are set to 0 (0: off, the default; below ``vacuum_density`` when
        that is set): the vacuum debris the moving average spreads upwards one cell per step,
        as the 1-D solver's ``density_floor`` (on a column that option itself).
    """

    STEP_CHUNK_CELL_STEPS = 1 << 20
    """Cell-steps per compiled call of a 2-D / 3-D :meth:`run` (at least one step): Python handles
    a signal (Ctrl-C, SIGTERM) only between calls, and 1e6 cell-steps of the seed's kernel take
    about 1–3 s (README, "Two and three dimensions").  The results do not depend on it (tested)."""

    def __init__(self, model: BSRModelND, grid: GridND, scheme: Scheme | None = None, *, average="na",
                 rho_max=0.0, dt_min=1e-12, top_tolerance=0.0, max_steps=50_000_000, vacuum_density=0.0,
                 density_floor=0.0):
        if not isinstance(model, BSRModelND):
            raise ValueError(f"model = {model!r} must be a BSRModelND")
        if not isinstance(grid, GridND):
            raise ValueError(f"grid = {grid!r} must be a GridND")
        if average not in AVERAGES:
            raise ValueError(f"average = {average!r} is not one of {sorted(AVERAGES)}")
        check_run_limits(max_steps, rho_max=rho_max, dt_min=dt_min, top_tolerance=top_tolerance,
                         vacuum_density=vacuum_density, density_floor=density_floor)
        top = vacuum_density if vacuum_density > 0 else np.inf
        if not (np.isfinite(density_floor) and 0 <= density_floor < top):
            rng = f"[0, vacuum_density = {vacuum_density!r})" if vacuum_density > 0 else "[0, inf)"
            raise ValueError(f"density_floor = {density_floor!r} is outside the valid range {rng} kg/m^n")
        self.density_floor = float(density_floor)
        self.model = model
        self.grid = grid
        self.scheme = scheme or Scheme.preset("seed")
        self.average = average
        self._line = None
        if grid.dim == 1:
            # a column: the 1-D discretisation (its compiled loop, every scheme option, the
            # registered fast integral of the kernel's restriction to the line)
            self._line = Simulation(BSRModel(kernel=model.kernel.on_line(), motion=model.motion,
                                             gravity=model.gravity), grid.as_grid1d(), self.scheme,
                                    rho_max=rho_max, dt_min=dt_min, top_tolerance=top_tolerance,
                                    max_steps=max_steps, vacuum_density=vacuum_density,
                                    density_floor=density_floor)
            self.W = self._line.W
            self.kappa = self._line.kappa
            return
        check_scheme_supported(self.scheme, SCHEME_OPTIONS_ND, "the n-D solver (SimulationND)")
        R = model.kernel.radius
        Wf = R / grid.dx
        W = int(round(Wf))
        if abs(Wf - W) > 1e-6 * max(1.0, Wf) or W < 2:
            raise ValueError(f"kernel radius {R!r} m must be a whole number (>= 2) of cells of side "
                             f"dx = {grid.dx!r} m; it is {Wf:.6g} cells")
        for a, n in enumerate(grid.shape):
            if n <= W:
                raise ValueError(f"shape[{a}] = {n} must exceed the kernel radius in cells ({W})")
        self.W = W
        self.G = grid.ghost_widths(W)
        self.maps = grid.ghost_maps(W)
        offs, nodes, wts = ball_quadrature(grid.dim, W, grid.dx)
        self.offsets, self.nodes, self.weights = offs, nodes, wts      # user layout (dim columns)
        o3, c3 = self._three(offs), self._three(nodes)
        half = (o3[:, 0] > 0) | ((o3[:, 0] == 0) & (o3[:, 1] > 0)) | ((o3[:, 0] == 0) & (o3[:, 1] == 0))
        self.ho = np.ascontiguousarray(o3[half])
        self.hc = np.ascontiguousarray(c3[half])
        self.hw = np.ascontiguousarray(wts[half])
        self_pair = (self.ho[:, 0] == 0) & (self.ho[:, 1] == 0)      # the vertical column
        self.hwB = np.ascontiguousarray(np.where(self_pair, 0.0, self.hw))
        PY = grid.shape3[1] + 2 * self.G[1]
        PZ = grid.shape3[2] + 2 * self.G[2]
        self.dA = np.ascontiguousarray((self.ho[:, 0] * PY + self.ho[:, 1]) * PZ + self.ho[:, 2])
        self.dB = np.ascontiguousarray((-self.ho[:, 0] * PY - self.ho[:, 1]) * PZ + self.ho[:, 2])
        self.tableau = get_stepper(self.scheme.stepper)
        self.kappa = self.stiffness_moment()
        # the interaction's wave-speed bound, with this scheme's discrete moment: c = √(n κ ρ)
        self._wave_speed_fn, self.wave_speed_params = model.kernel.compiled_wave_speed(grid.dim, moment=self.kappa)
        self.rho_max = float(rho_max)
        self.dt_min = float(dt_min)
        self.top_tolerance = float(top_tolerance)
        self.max_steps = int(max_steps)
        self.vacuum_density = float(vacuum_density)
        self.floor = grid.bc_lower == "floor"
        self.core = make_core_nd(model.kernel.compiled, model.motion.fn, self._wave_speed_fn,
                                 positivity=bool(self.scheme.positivity))
        self._core_tracers = None           # the step loop with tracer moves, compiled when first needed

    def _three(self, a):
        a = np.asarray(a)
        if self.grid.dim == 3:
            return a.copy()
        out = np.zeros((a.shape[0], 3), a.dtype)
        out[:, 0] = a[:, 0]
        out[:, 2] = a[:, 1]
        return out

    def stiffness_moment(self) -> float:
        """κ = max over relative vertical motions of |Σ_o w_o (o_z Δx) Θ_z(c_o, 0, b)|
        [m^(n+2) s⁻² kg⁻¹] (b = 0, ±e_z m/s).  This is the discrete M of the scheme: for a
        density linear in z (sampled at cell centres, o_z Δx from the cell) the quadrature sum
        is exactly -M ∂ρ/∂z, and c² = M ρ is the sound speed of the semi-discrete model at
        long wavelengths.  The solver's CFL bound uses c = sqrt(κ max ρ)."""
        self._refuse_column("stiffness_moment")
        c3 = self._three(self.nodes).T
        oz = self.offsets[:, -1] * self.grid.dx
        zero = np.zeros(c3.shape[1])
        vals = []
        for bz in (0.0, 1.0, -1.0):
            th = self.model.kernel(tuple(c3), (zero, zero, zero), (zero, zero, zero + bz))
            vals.append(abs(float(np.sum(self.weights * oz * th[2]))))
        return max(vals)

    def _refuse_column(self, name):
        if self._line is not None:
            raise ValueError(f"SimulationND.{name} is a piece of the 2-D / 3-D discretisation; a column (dim = 1) "
                             "runs the 1-D solver's (run and rhs work on it)")

    def _filter_code(self):
        return AVERAGES[self.average] if self.scheme.filter else 0

    # -- the pieces ---------------------------------------------------------------------------
    def advance_internal(self, ui, ri, t, t_end, max_steps=None, tracers=None):
        """Advance internal-layout arrays (see :func:`to_internal`) in place from t to t_end
        (no jumps, no saving); ``tracers`` (n, 3) [m] internal (x, y, z) positions, moved in place.
        Returns (t, steps, status, where_flat_index, dt_last)."""
        self._refuse_column("advance_internal")
        g, s, tb = self.grid, self.scheme, self.tableau
        tr = np.zeros((0, 3)) if tracers is None else tracers
        mode = 0 if tracers is None else (1 if s.tracer_integrator == "euler" else 2)
        lo3 = np.array([g.lower[0], g.lower[1] if g.dim == 3 else 0.0, g.lower[-1]])
        box = np.array([g.shape[0] * g.dx, (g.shape[1] * g.dx) if g.dim == 3 else 1.0, g.shape[-1] * g.dx])
        # per axis (x, y, z): tracers wrapped on a periodic axis, kept inside the walls otherwise
        sides = tuple(g.bc_horizontal) + (("periodic",) if g.dim == 2 else ())
        periodic = np.array([sides[0] == "periodic", sides[1] == "periodic",
                             g.bc_lower == "periodic"])
        (sx, sy, sz), (gx, gy, gz), (kx, ky, kz), prz = self.maps
        Gx, Gy, Gz = self.G
        top_layers = self.W if g.bc_upper == "vacuum" else 0
        core = self.core
        if tracers is not None:
            if self._core_tracers is None:
                self._core_tracers = make_core_nd(self.model.kernel.compiled, self.model.motion.fn,
                                                  self._wave_speed_fn, positivity=bool(s.positivity), tracers=True)
            core = self._core_tracers
        return core.advance(
            ui, ri, float(t), float(t_end), float(s.dt or 0.0), float(s.cfl), self.wave_speed_params,
            tb.a, tb.b, tb.c, self._filter_code(), g.dim, sx, sy, sz, gx, gy, gz, kx, ky, kz, prz,
            self.floor, Gx, Gy, Gz, g.dx, self.dA, self.dB, self.hc, self.hw, self.hwB, self.model.kernel.params,
            self.model.gravity, self.model.motion.params, self.dt_min, self.rho_max,
            int(max_steps or self.max_steps), self.top_tolerance, top_layers, self.vacuum_density,
            self.density_floor, tr, mode, lo3, box, periodic)

    def _padded(self, ui, ri):
        Gx, Gy, Gz = self.G
        NX, NY, NZ = self.grid.shape3
        up = np.empty((3, NX + 2 * Gx, NY + 2 * Gy, NZ + 2 * Gz))
        rp = np.empty((NX + 2 * Gx, NY + 2 * Gy, NZ + 2 * Gz))
        (sx, sy, sz), (gx, gy, gz), (kx, ky, kz), prz = self.maps
        self.core.fill_ghosts(ui, ri, up, rp, sx, sy, sz, gx, gy, gz, kx, ky, kz, prz)
        return up, rp

    def rhs(self, u, rho, t):
        """Semi-discrete right-hand side (du/dt (n, *shape) [m/s²], dρ/dt [kg/(m^n s)]) at t [s]."""
        if self._line is not None:                   # a column: the 1-D solver's right-hand side
            du, dr = self._line.rhs(np.asarray(u, float)[0], rho, t)
            return du[None, :], dr
        g = self.grid
        ui, ri = to_internal(g, u, rho)
        up, rp = self._padded(ui, ri)
        du = np.empty_like(ui)
        dr = np.empty_like(ri)
        Gx, Gy, Gz = self.G
        acc_z = -(self.model.gravity + self.model.motion.state(float(t))[2])
        self.core.rhs(acc_z, up.reshape(3, -1), rp.reshape(-1), up.shape[2], up.shape[3], Gx, Gy, Gz,
                      g.dim == 3, self.floor, g.dx, self.dA, self.dB, self.hc, self.hw, self.hwB,
                      self.model.kernel.params, du, dr)
        return from_internal(g, du, dr)

    def moving_average(self, u, rho, mode=None):
        """The moving average of (u, ρ) (user layout) with the grid's ghosts; mode 'na'/'tensor'."""
        self._refuse_column("moving_average")
        g = self.grid
        ui, ri = to_internal(g, u, rho)
        ui, ri = ui.copy(), ri.copy()
        up, rp = self._padded(ui, ri)
        Gx, Gy, Gz = self.G
        self.core.moving_average(ui, ri, up, rp, Gx, Gy, Gz, g.dim == 3, self.floor, g.dim,
                                 AVERAGES[mode or self.average])
        return from_internal(g, ui, ri)

    def _position(self, where):
        if where < 0:
            return None
        NX, NY, NZ = self.grid.shape3
        i, rem = divmod(int(where), NY * NZ)
        j, k = divmod(rem, NZ)
        idx = (i, j, k) if self.grid.dim == 3 else (i, k)
        return tuple(float(self.grid.centres(a)[n]) for a, n in enumerate(idx))

    # -- a whole run --------------------------------------------------------------------------
    def run(self, u0, rho0, t_end, *, t_start=0.0, save_every=None, save_times=None, observers=(),
            progress=None, extra_event_times=(), on_event=None, restart=False, tracers=None) -> ResultND:
        """Integrate from t_start to t_end [s], saving snapshots, through the run controller
        shared with the 1-D solvers (:func:`bsrflow.numerics.controller.drive_events`).

        u0 (n, *shape) [m/s] velocity relative to the floor, rho0 (*shape) [kg/m^n].
        save_every [s] or save_times [s]: when to save (default: start and end only).
        observers: callables ``obs(t, u, rho, tracers)`` (user layout; ``tracers`` (n, dim) [m],
            floor frame, or None in a run without tracers) called at every save, as in 1-D.
        progress: callable ``progress(t)`` called at every save.
        extra_event_times, on_event: as for the 1-D :meth:`Simulation.run`: the time loop lands
            on those in (t_start, t_end) exactly and calls ``on_event(t, u, rho, tracers, steps)``
            (user layout; ``tracers`` as for the observers; ``steps`` taken so far in this call)
            before the velocity jump and the save at t; that state, restarted with
            ``run(..., t_start=t, restart=True, tracers=...)``, continues bit for bit
            (checkpoints).
        restart: the initial state is one saved by an earlier run: skip the check rho0 >= 0
            (without the positivity fix round-off level negative densities occur) and that the
            tracers lie in the domain.
        tracers: (n, dim) initial positions [m] (floor frame, user axes), moved with the
            interpolated velocity by ``scheme.tracer_integrator`` ('euler' the seed's, 'rk' the
            tableau); saved as ``ResultND.tracers`` (nt, n, dim).
        Raises :class:`bsrflow.numerics.solver.SimulationError` (``.result`` keeps the
        snapshots, ``.position`` is the cell centre (m) where the monitor fired, or None).
        """
        from .controller import drive_events
        g = self.grid
        if self._line is not None:
            return self._run_line(u0, rho0, t_end, t_start=t_start, save_every=save_every, save_times=save_times,
                                  observers=observers, progress=progress, extra_event_times=extra_event_times,
                                  on_event=on_event, restart=restart, tracers=tracers)
        u0 = np.asarray(u0, float)
        rho0 = np.asarray(rho0, float)
        for name, arr in (("u0", u0), ("rho0", rho0)):
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"{name} contains non-finite values")
        ui, ri = to_internal(g, u0, rho0, names=("u0", "rho0"))
        ui, ri = ui.copy(), ri.copy()
        if not restart and np.any(ri < 0):
            raise ValueError(f"rho0 has negative values (min {ri.min():.3g} kg/m^{g.dim}); density must be >= 0")
        # a KernelND subclass's declared bound against √(n κ ρ), κ this scheme's discrete moment
        from ..physics.kernels_nd import KernelND
        _check_declared_bound(self.model.kernel, g.dim * self.kappa if isinstance(self.model.kernel, KernelND) else None,
                              self._wave_speed_fn, self.wave_speed_params, float(ri.max()), f"kg/m^{g.dim}")
        _require_number("t_start", t_start)       # the checks of the 1-D Simulation.run
        _require_number("t_end", t_end)
        if not (np.isfinite(t_start) and np.isfinite(t_end) and t_end > t_start):
            raise ValueError(f"t_end = {t_end!r} must be finite and greater than t_start = {t_start!r}")
        save_times = save_schedule(t_start, t_end, save_every, save_times)
        tri = None
        if tracers is not None:
            arr = np.array(tracers, dtype=float)
            if arr.ndim != 2 or arr.shape[1] != g.dim or not np.all(np.isfinite(arr)):
                raise ValueError(f"tracers must be a finite array of shape (n, {g.dim}) [m]")
            if not restart:
                lo, hi = np.asarray(g.lower, float), np.asarray(g.upper, float)
                out = np.any((arr < lo) | (arr > hi), axis=1)
                if np.any(out):
                    k = int(np.argmax(out))
                    raise ValueError(f"tracers[{k}] = {arr[k].tolist()} is outside the domain "
                                     f"[{lo.tolist()}, {hi.tolist()}] m")
            tri = np.zeros((arr.shape[0], 3))
            tri[:, 0], tri[:, 2] = arr[:, 0], arr[:, -1]
            if g.dim == 3:
                tri[:, 1] = arr[:, 1]
        motion = self.model.motion
        jumps = motion.jumps_between(t_start, t_end)
        ts, us, rs, fl, trs = [], [], [], [], []
        wall0 = _time.perf_counter()
        total = 0

        def user_tracers():
            return None if tri is None else tri[:, [0, 1, 2] if g.dim == 3 else [0, 2]].copy()

        def save(t):
            uu, rr = from_internal(g, ui, ri)
            ts.append(t)
            us.append(uu)
            rs.append(rr)
            fl.append(motion.state(t)[0])
            tr_user = user_tracers()
            if tr_user is not None:
                trs.append(tr_user)
            for obs in observers:
                obs(t, uu, rr, tr_user)
            if progress is not None:
                progress(t)

        def result(status):
            return ResultND(np.array(ts), np.array(us).reshape((len(ts), g.dim) + g.shape),
                            np.array(rs).reshape((len(ts),) + g.shape), np.array(fl), g, total,
                            _time.perf_counter() - wall0, status,
                            {"scheme": self.scheme.to_dict(), "average": self.average, "grid": g.to_dict(),
                             "model": self.model.to_dict(), "kernel_radius_cells": self.W},
                            None if tri is None else np.array(trs).reshape(len(ts), tri.shape[0], g.dim))

        chunk = max(1, self.STEP_CHUNK_CELL_STEPS // g.n_cells)

        def advance(t, ev):
            nonlocal total
            while True:     # in chunks of steps, so that Ctrl-C / SIGTERM are handled within seconds
                budget = self.max_steps - total
                n = min(budget if budget > 0 else self.max_steps, chunk)
                t_new, steps, status, where, dt_last = self.advance_internal(ui, ri, t, ev, max_steps=n,
                                                                             tracers=tri)
                total += steps
                if status == 4 and n < budget:       # the chunk ended, not the run's step budget
                    t = t_new
                    continue
                break
            if status != 0:
                pos = self._position(where)
                axes = ("x", "y", "z") if g.dim == 3 else ("x", "z")
                near = ("" if pos is None else
                        f" near ({', '.join(axes)}) = ({', '.join(f'{p:.4g}' for p in pos)}) m")
                msg = (f"simulation stopped at t = {t_new:.6g} s{near}: {STATUS[status]}; "
                       f"last dt = {dt_last:.3g} s, {total} steps; {len(ts)} snapshot(s) up to t = "
                       f"{(ts[-1] if ts else t_start):.6g} s were kept")
                raise SimulationError(msg, result(STATUS[status]), t_new, pos, status)

        def apply_jump(dv):
            ui[2] -= dv          # floor velocity jumps by dv: u_z (floor frame) by -dv

        def event(ev):
            uu, rr = from_internal(g, ui, ri)
            on_event(ev, uu, rr, user_tracers(), total)

        drive_events(float(t_start), float(t_end), save_times, jumps, extra_event_times, advance=advance,
                     apply_jump=apply_jump, save=save, on_event=None if on_event is None else event)
        return result("ok")


    def _run_line(self, u0, rho0, t_end, *, tracers=None, observers=(), on_event=None, **kw):
        """:meth:`run` on a column (dim = 1): the 1-D solver, in the n-D layout (u (1, n),
        tracers (n_tr, 1)), with the same observers, events and result type."""
        g = self.grid
        n = g.shape[0]
        u0 = np.asarray(u0, float)
        if u0.shape != (1, n):
            raise ValueError(f"u0 has shape {u0.shape}, expected (1, {n}) (one velocity component)")
        tr = None
        if tracers is not None:
            arr = np.array(tracers, dtype=float)
            if arr.ndim != 2 or arr.shape[1] != 1:
                raise ValueError("tracers must be a finite array of shape (n, 1) [m]")
            tr = arr[:, 0]
        with_tracers = tr is not None

        def lift(u, tracers_1d):
            return u[None, :], (tracers_1d[:, None] if with_tracers else None)

        def wrap(observer):
            def obs(t, u, r, trc):
                uu, tt = lift(u, trc)
                observer(t, uu, r, tt)
            return obs

        obs = [wrap(o) for o in observers]
        ev = None
        if on_event is not None:
            def ev(t, u, r, trc, steps):
                uu, tt = lift(u, trc)
                on_event(t, uu, r, tt, steps)
        try:
            res = self._line.run(u0[0], rho0, t_end, tracers=tr, observers=obs, on_event=ev, **kw)
        except SimulationError as exc:
            exc.result = self._result_from_line(exc.result, with_tracers) if exc.result is not None else None
            raise
        return self._result_from_line(res, with_tracers)

    def _result_from_line(self, res, with_tracers):
        info = dict(res.info, grid=self.grid.to_dict(), model=self.model.to_dict(), discretisation="1-D (column)")
        return ResultND(res.t, res.u[:, None, :], res.rho, res.floor, self.grid, res.steps, res.wall_time,
                        res.status, info, res.tracers[:, :, None] if with_tracers else None)


# ---- plain NumPy reference -----------------------------------------------------------------
class ReferenceND:
    """NumPy implementation of the same scheme for a :class:`SimulationND`'s settings, written in
    the user layout (n components, n axes) with ghosts from ``np.pad``; for tests."""

    def __init__(self, sim: SimulationND):
        if sim.grid.dim == 1:
            raise ValueError("ReferenceND: a column (dim = 1) runs the 1-D solver; its NumPy reference is "
                             "bsrflow.numerics.reference.ReferenceScheme")
        self.sim = sim
        self.grid = sim.grid
        self.W = sim.W
        self.G = max(sim.W, 1)

    def pad(self, u, rho, even_floor=False):
        """Padded (u, ρ).  At a supporting floor ρ is point-reflected (integral), or with
        ``even_floor`` mirrored evenly (flux, average)."""
        g, G, n = self.grid, self.G, self.grid.dim
        up = [np.asarray(c, float) for c in u]
        rp = np.asarray(rho, float)
        sides = [(b, b) for b in g.bc_horizontal] + [(g.bc_lower, g.bc_upper)]
        for a, (lo, hi) in enumerate(sides):
            if lo == "periodic":
                width = [(0, 0)] * n
                width[a] = (G, G)
                up = [np.pad(c, width, mode="wrap") for c in up]
                rp = np.pad(rp, width, mode="wrap")
                continue
            for side, bc in ((0, lo), (1, hi)):
                width = [(0, 0)] * n
                width[a] = (G, 0) if side == 0 else (0, G)
                sl = [slice(None)] * n
                sl[a] = slice(0, G) if side == 0 else slice(-G, None)
                sl = tuple(sl)
                if bc in ("wall", "mirror", "floor"):
                    up = [np.pad(c, width, mode="symmetric") for c in up]
                    up[a][sl] *= -1.0
                    if bc == "floor" and not even_floor:
                        first = [slice(None)] * n
                        second = [slice(None)] * n
                        first[a] = slice(0, 1)
                        second[a] = slice(1, 2)
                        rw = 1.5 * rp[tuple(first)] - 0.5 * rp[tuple(second)]
                        rp = np.pad(rp, width, mode="symmetric")
                        rp[sl] = np.maximum(2.0 * rw - rp[sl], 0.0)
                    else:
                        rp = np.pad(rp, width, mode="symmetric")
                else:  # vacuum
                    up = [np.pad(c, width, mode="edge") for c in up]
                    rp = np.pad(rp, width, mode="constant", constant_values=0.0)
        return np.array(up), rp

    def _shift(self, arr, off):
        G = self.G
        return arr[(Ellipsis,) + tuple(slice(G + o, G + o + N) for o, N in zip(off, self.grid.shape))]

    def rhs(self, u, rho, t):
        g, n = self.grid, self.grid.dim
        m = self.sim.model
        up, rp = self.pad(u, rho)
        _, re = self.pad(u, rho, even_floor=True)
        sh = self._shift

        def three(v):  # user components -> (x, y, z)
            return (v[0], 0.0 * v[0], v[1]) if n == 2 else (v[0], v[1], v[2])

        uc = sh(up, (0,) * n)
        integral = np.zeros((n,) + g.shape)
        for off, node, w in zip(self.sim.offsets, self.sim.nodes, self.sim.weights):
            th = m.kernel(three(node), three(uc), three(sh(up, off)))
            th = (th[0], th[2]) if n == 2 else th
            rr = sh(rp, off)
            for a in range(n):
                integral[a] += w * rr * th[a]
        du = integral.copy()
        dr = np.zeros(g.shape)
        for a in range(n):
            e = [0] * n
            e[a] = 1
            em = [-x for x in e]
            du -= uc[a] * (sh(up, e) - sh(up, em)) / (2 * g.dx)
            dr -= (sh(re, e) * sh(up, e)[a] - sh(re, em) * sh(up, em)[a]) / (2 * g.dx)
        du[-1] -= m.gravity + m.motion.state(t)[2]
        return du, dr

    def moving_average(self, u, rho, mode="na"):
        n = self.grid.dim
        up, rp = self.pad(u, rho, even_floor=True)
        sh = self._shift

        def avg(q):
            if mode == "na":
                s = 0.5 * sh(q, (0,) * n)
                for a in range(n):
                    for d in (1, -1):
                        e = [0] * n
                        e[a] = d
                        s = s + sh(q, e) / (4 * n)
                return s
            s = 0.0
            for off in np.ndindex(*(3,) * n):
                o = [x - 1 for x in off]
                s = s + np.prod([0.5 if x == 0 else 0.25 for x in o]) * sh(q, o)
            return s

        return avg(up), avg(rp)

    def extend_velocity(self, u, rho, thr):
        """Column-wise velocity extension into vacuum (nearest material cell, lower on a tie)."""
        u = u.copy()
        n = self.grid.dim
        for col in np.ndindex(*self.grid.shape[:-1]):
            r = rho[col]
            mat = np.flatnonzero(r >= thr)
            if mat.size == 0:
                continue
            for k in np.flatnonzero(r < thr):
                d = np.abs(mat - k)
                src = mat[np.flatnonzero(d == d.min())[0]]
                for a in range(n):
                    u[(a,) + col + (k,)] = u[(a,) + col + (src,)]
        return u

    def step(self, u, rho, t, dt):
        tb = self.sim.tableau
        ku, kr = [], []
        for st in range(tb.stages):
            yu = u + dt * sum(tb.a[st, j] * ku[j] for j in range(st)) if st else u.copy()
            yr = rho + dt * sum(tb.a[st, j] * kr[j] for j in range(st)) if st else rho.copy()
            du, dr = self.rhs(yu, yr, t + tb.c[st] * dt)
            ku.append(du)
            kr.append(dr)
        un = u + dt * sum(tb.b[j] * ku[j] for j in range(tb.stages))
        rn = rho + dt * sum(tb.b[j] * kr[j] for j in range(tb.stages))
        if self.sim.vacuum_density > 0:
            un = self.extend_velocity(un, rn, self.sim.vacuum_density)
        if self.sim.scheme.filter:
            un, rn = self.moving_average(un, rn, self.sim.average)
        if self.sim.density_floor > 0:
            rn = np.where(np.abs(rn) < self.sim.density_floor, 0.0, rn)
        return un, rn


# ---- embedding: the induced 1-D kernel -----------------------------------------------------
def _induced_table(z, u_here, u_there, p):
    # p = (Δx [m], W, T_rest[2W+1], T_approach[2W+1], T_separate[2W+1]); node k <-> z = (k - W) Δx
    dx = p[0]
    W = p[1]
    n = int(2.0 * W + 1.0)
    d = np.sign(z * (u_there - u_here))
    s = 0.0 * z
    for k in range(n):
        hit = np.abs(z - (k - W) * dx) < 0.5 * dx
        s = s + hit * (p[2 + k] * (d == 0.0) + p[2 + n + k] * (d < 0.0) + p[2 + 2 * n + k] * (d > 0.0))
    return s


def induced_kernel_1d(kernel: KernelND, dim: int, dx: float, rule: str = "trapezoid") -> Kernel:
    """The 1-D kernel that a horizontally uniform n-D state with zero horizontal velocity feels.

    For vertical offset k (z_k = k Δx) the n-D quadrature sum over the horizontal offsets of that
    layer of the ball table is ρ_k Σ_o w_o Θ_z(c_o, u, u'), which depends on the velocities only
    through the sign of c_z (u'_z - u_z) = sign(z_k Δu) for kernels like Walton-Braun (c_z has the
    sign of k).  Three tables (Δu z = 0, < 0 approach, > 0 separate) of these layer sums
    [m s⁻² kg⁻¹ · m^n], each divided by the 1-D quadrature weight of node k [m], define a 1-D
    kernel Θ₁(z_k) [m s⁻² kg⁻¹] whose 1-D quadrature sum equals the n-D sum (to round-off).
    Lookup by k = round(z/Δx).  Exact only for kernels whose velocity dependence is through
    σ(z·(u_y - u_x)), as the Walton-Braun kernel's.
    """
    if dim not in (2, 3):
        raise ValueError(f"dim = {dim!r} is outside the valid range {{2, 3}}")
    Wf = kernel.radius / dx
    W = int(round(Wf))
    if abs(Wf - W) > 1e-6 * max(1.0, Wf) or W < 2:
        raise ValueError(f"kernel radius {kernel.radius!r} m must be a whole number (>= 2) of cells dx = {dx!r} m")
    offs, nodes, wts = ball_quadrature(dim, W, dx)
    c3 = np.zeros((nodes.shape[0], 3))
    c3[:, 0] = nodes[:, 0]
    c3[:, 2] = nodes[:, -1]
    if dim == 3:
        c3[:, 1] = nodes[:, 1]
    _, qw = quadrature_weights(W, dx, rule)
    zero = np.zeros(len(wts))
    tables = []
    for sgn in (0.0, -1.0, 1.0):           # sign of z Δu: rest, approach, separate
        kz = offs[:, -1]
        bz = sgn * np.sign(kz)              # u_there - u_here with sign(z_k bz) = sgn (k != 0)
        th = kernel((c3[:, 0], c3[:, 1], c3[:, 2]), (zero, zero, zero), (zero, zero, bz))[2]
        T = np.zeros(2 * W + 1)
        np.add.at(T, kz + W, wts * th)
        tables.append(T / qw)
    p = np.concatenate([[dx, float(W)], *tables])
    return Kernel(_induced_table, p, W * dx, name=f"induced_{dim}d_{kernel.name}",
                  param_names=("dx", "W", "tables"), param_units=("m", "1", "m s-2 kg-1"))


# ---- the embedding check -------------------------------------------------------------------
def _embedding_setup(dim, n_vertical, n_horizontal, W):
    dx = 0.004                                          # [m]
    R = W * dx
    rho_bulk = 800.0                                    # [kg/m^n]
    # strength for a sound speed of about 3 m/s (c² = M ρ, M = πλR⁵/15 or πλR⁴/12)
    M_unit = math.pi * R ** 5 / 15 if dim == 3 else math.pi * R ** 4 / 12
    lam = 9.0 / (M_unit * rho_bulk)
    kernel = walton_braun_nd(lam, 0.2, R)
    motion = HalfSineTaps(0.002, 10.0, start=0.01)      # jumps at 0.01 s and 0.06 s
    z = (np.arange(n_vertical) + 0.5) * dx
    H = 0.45 * n_vertical * dx
    # a compactly supported top (cos² taper over 6 cells): exactly empty above, no thin tail
    s = np.clip((z - H) / (6.0 * dx) + 0.5, 0.0, 1.0)
    rho_z = rho_bulk * np.cos(0.5 * np.pi * s) ** 2 * (1.0 + 0.1 * np.cos(7.0 * z / H))
    u_z = 0.05 * np.sin(5.0 * z / H) * np.exp(-z / H)
    return dx, kernel, motion, rho_z, u_z


def embedding_error(dim: int, *, filter: bool = False, average: str = "na", stepper: str = "kutta3",
                    n_vertical: int = 40, n_horizontal: int | None = None, W: int | None = None,
                    t_end: float = 0.08, cfl: float = 0.3, vacuum_density: float = 0.0,
                    details: bool = False):
    """Run a horizontally uniform n-D state and the 1-D solver with the induced kernel; return
    the largest difference max(‖u_z - u₁‖∞/‖u₁‖∞, ‖ρ - ρ₁‖∞/‖ρ₁‖∞, ‖u_h‖∞/‖u₁‖∞) over all
    columns at the final time (dimensionless).

    Setup: floor + vacuum column of ``n_vertical`` cells (Δx = 4 mm), periodic horizontal
    directions with ``n_horizontal`` cells (default W + 1), Walton-Braun kernel (ε = 0.2,
    radius W cells, default 3, sound speed about 3 m/s), gravity, one half-sine tap (2 mm,
    10 Hz, from t = 0.01 s: both velocity jumps and the frame acceleration are exercised), a
    non-uniform density profile with a compactly supported top and a non-uniform velocity,
    fixed Δt = cfl Δx / (3 m/s), to ``t_end`` [s]; optionally the velocity extension into
    vacuum below ``vacuum_density`` [kg/m^n] on both sides.

    filter=False: the 1-D side is :meth:`bsrflow.numerics.solver.Simulation.run`, unfiltered.
    filter=True, average='tensor': the 1-D side is ``Simulation.run`` with its own filter.
    filter=True, average='na' (5.7): restricted to such states (5.7) is the vertical average
    (1/(4n), 1 - 1/(2n), 1/(4n)), which the 1-D solver does not have; the 1-D side is then the
    1-D compiled step (``Simulation.advance``, one step at a time, unfiltered) followed by that
    average with the 1-D ghosts, with the same event (jump/save) handling as ``run``.
    With ``details=True`` returns (error, dict of the parts).
    """
    if dim not in (2, 3):
        raise ValueError(f"dim = {dim!r} is outside the valid range {{2, 3}}")
    if average not in AVERAGES:
        raise ValueError(f"average = {average!r} is not one of {sorted(AVERAGES)}")
    if W is None:
        W = 3
    if n_horizontal is None:
        n_horizontal = W + 1
    dx, kernel, motion, rho_z, u_z = _embedding_setup(dim, n_vertical, n_horizontal, W)
    dt = cfl * dx / 3.0
    g = 9.81
    shape = (n_horizontal,) * (dim - 1) + (n_vertical,)
    grid = GridND(shape, dx, bc_horizontal="periodic", bc_lower="floor", bc_upper="vacuum")
    scheme = Scheme(stepper=stepper, filter=filter, dt=dt, name="embedding")
    sim = SimulationND(BSRModelND(kernel, motion, g), grid, scheme, average=average,
                       vacuum_density=vacuum_density)
    rho0 = np.broadcast_to(rho_z, shape).copy()
    u0 = np.zeros((dim,) + shape)
    u0[-1] = np.broadcast_to(u_z, shape)
    save_times = [0.0, 0.5 * t_end, t_end]
    res = sim.run(u0, rho0, t_end, save_times=save_times)

    grid1 = Grid1D(0.0, n_vertical * dx, n_vertical, "floor", "vacuum")
    model1 = BSRModel(kernel=induced_kernel_1d(kernel, dim, dx), motion=motion, gravity=g)
    if not filter or average == "tensor":
        sim1 = Simulation(model1, grid1, Scheme(stepper=stepper, filter=filter, dt=dt, name="embedding"),
                          vacuum_density=vacuum_density)
        r1 = sim1.run(u_z, rho_z, t_end, save_times=save_times)
        u1, rho1 = r1.u[-1], r1.rho[-1]
    else:
        sim1 = Simulation(model1, grid1, Scheme(stepper=stepper, filter=False, dt=dt, name="embedding"),
                          vacuum_density=vacuum_density)
        u1, rho1 = _run_1d_with_average(sim1, u_z.copy(), rho_z.copy(), 0.0, t_end, save_times, motion, dim)
    uz = res.u[-1][-1].reshape(-1, n_vertical)
    uh = res.u[-1][:-1]
    rz = res.rho[-1].reshape(-1, n_vertical)
    parts = {"u_vertical": float(np.max(np.abs(uz - u1)) / np.max(np.abs(u1))),
             "rho": float(np.max(np.abs(rz - rho1)) / np.max(np.abs(rho1))),
             "u_horizontal": float(np.max(np.abs(uh)) / np.max(np.abs(u1))),
             "u_vertical_abs_m_per_s": float(np.max(np.abs(uz - u1))),
             "rho_abs": float(np.max(np.abs(rz - rho1))),
             "steps": int(res.steps), "dt": dt, "t_end": t_end, "dx": dx, "W": W,
             "shape": list(shape), "filter": bool(filter), "average": average if filter else None,
             "vacuum_density": vacuum_density}
    err = max(parts["u_vertical"], parts["rho"], parts["u_horizontal"])
    return (err, parts) if details else err


def _run_1d_with_average(sim1, u, rho, t0, t_end, save_times, motion, dim):
    """1-D compiled steps (unfiltered) + the restricted (5.7) average after each step."""
    G = max(sim1.W, 1)
    N = sim1.grid.n_cells
    up = np.empty(N + 2 * G)
    rp = np.empty(N + 2 * G)
    bcl, bch = sim1.grid.codes
    cn = 1.0 / (4.0 * dim)
    jumps = motion.jumps_between(t0, t_end)
    jump_at = {}
    for tj, dv in jumps:
        jump_at[tj] = jump_at.get(tj, 0.0) + dv
    events = sorted(set(float(s) for s in save_times) | set(jump_at))
    t = t0
    for ev in events:
        while t < ev:
            t, steps, status, where, _ = sim1.advance(u, rho, t, ev, max_steps=1)
            if status not in (0, 4) or steps != 1:
                raise RuntimeError(f"1-D comparison run stopped: {STATUS[status]}")
            sim1.core.fill_ghosts(u, rho, t, up, rp, G, bcl, bch, float(sim1.grid.lower), float(sim1.grid.dx),
                                  sim1.model.boundary_params)
            c = slice(G, G + N)
            lo = slice(G - 1, G + N - 1)
            hi = slice(G + 1, G + N + 1)
            if bcl == 1:
                rp[G - 1] = rp[G]            # the supporting floor averages with the even image
            # (5.7) for a horizontally uniform state: the 2(n-1) horizontal neighbours equal the centre
            u[:] = 0.5 * up[c] + cn * (2.0 * (dim - 1) * up[c] + up[hi] + up[lo])
            rho[:] = 0.5 * rp[c] + cn * (2.0 * (dim - 1) * rp[c] + rp[hi] + rp[lo])
        if ev in jump_at:
            u -= jump_at[ev]
    return u, rho


def verify_cases() -> list:
    """The n-D embedding cases for ``bsrflow verify`` (kind 'exact': errors are the embedding
    differences of :func:`embedding_error`, no order).

    embedding_2d / embedding_3d            unfiltered RK3, 1-D side = ``Simulation.run``
    embedding_2d_filter / _3d_filter       RK3 + the seed's average (5.7) every step
    embedding_2d_tensor / _3d_tensor       RK3 + tensor-product average, 1-D side with its filter
    """
    out = []
    for suffix, filt, avg in (("", False, "na"), ("_filter", True, "na"), ("_tensor", True, "tensor")):
        for dim in (2, 3):
            t0 = _time.perf_counter()
            err, parts = embedding_error(dim, filter=filt, average=avg, details=True)
            out.append({"name": f"embedding_{dim}d{suffix}", "kind": "exact", "stepper": "kutta3",
                        "filter": filt, "scheme": "seed" if filt and avg == "na" else
                        ("seed_unfiltered" if not filt else "tensor_average"),
                        "resolutions": [parts["shape"][-1]], "h": [parts["dx"]], "errors": [err],
                        "observed_order": float("nan"), "pairwise_orders": [], "details": parts,
                        "wall_time_s": _time.perf_counter() - t0})
    return out
