"""Drivers of the packing continuum (issue #18): two discretisations behind one run controller.

* :class:`EulerianPacking` — formulation (a): fields on the grid of :class:`Grid1D`, finite
  volumes (MUSCL-minmod reconstruction, first order at compaction faces, HLLE fluxes with secant
  wave speeds, SSP-RK3), the history field δ_max advected with the material in conserved form ρδ_max.
* :class:`LagrangianPacking` — formulation (b): material points moved by ẋ = u, the density
  by characteristics (3.10)–(3.12) over the bonds between them, velocity Verlet; the history
  lives on the bonds.  In the local limit (``range_over_d = 0``) the bonds join neighbouring
  points (pair forces); with the nonlocal interaction (``range_over_d`` > 0, the package's packing
  continuum) they join points up to L = ppd R/d apart (:mod:`bsrflow.numerics.packing_nonlocal`).
* :class:`StaggeredEulerianPacking` — formulation (a) of the nonlocal interaction: the mass in the
  grid's cells, the velocity on its faces, a tracked free surface, the same bonds between the
  grid's nodes, a staggered Lagrange-remap step (:mod:`bsrflow.numerics.packing_staggered`).
  ``formulation = "eulerian"`` runs it for ``range_over_d`` > 0 (the default) and
  :class:`EulerianPacking` for the local limit.

Both expose the same interface to :func:`run_packing` (the controller): a state of named fields
(``fields``; what checkpoints store), ``advance(t, t_stop)``, ``observe()`` (density and velocity
on the output grid, tracers by mass coordinate, all in the floor frame) and ``supports``, the
options each accepts.  Output goes through the observers of the seed solver
(:class:`bsrflow.io.netcdf.NetCDFWriter`), so both write the same netCDF as today.

Tracers: the height below which the mass (k + ½) m lies (the centre of sphere k, the top sphere
last).  In 1-D material lines never cross, so the mass coordinate is exactly Lagrangian: these
are the material trajectories of the sphere centres in both formulations.

Units: SI; ρ [kg/m] line density, u [m/s] floor frame, δ_max [m].
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..physics.packing import PackingLaw
from .grid import Grid1D
from .solver import SimulationError
from . import packing_kernels as pk
from . import packing_nonlocal as pnl
from . import packing_staggered as pst

__all__ = ["EulerianPacking", "StaggeredEulerianPacking", "LagrangianPacking", "PackingResult", "PackingError", "run_packing",
           "FORMULATIONS"]

FORMULATIONS = ("eulerian", "lagrangian")


class PackingError(SimulationError):
    """A monitor stopped the packing run; ``time`` [s] and ``position`` [m] say when and where
    (a :class:`~bsrflow.numerics.solver.SimulationError`: the CLI exits with code 3)."""

    def __init__(self, message, t, where=None):
        super().__init__(message, None, t, where, "stopped")


@dataclass
class PackingResult:
    t: np.ndarray
    rho: np.ndarray          # (nt, nx) [kg/m]
    u: np.ndarray            # (nt, nx) [m/s] floor frame
    tracers: np.ndarray      # (nt, N) [m] floor frame
    floor: np.ndarray        # (nt,) [m]
    steps: int
    wall_time: float
    status: str = "ok"
    info: dict = field(default_factory=dict)


class _Base:
    supports: frozenset = frozenset()
    name = ""
    DEFAULT_CFL = 0.4

    @classmethod
    def default_cfl(cls, restitution: float) -> float:
        """The CFL number a run of this discretisation takes when none is given."""
        return cls.DEFAULT_CFL

    def __init__(self, law: PackingLaw, grid: Grid1D, n_spheres: int, motion, gravity: float,
                 points_per_diameter: int, cfl: float | None):
        if cfl is None:
            cfl = self.default_cfl(law.restitution)
        if not isinstance(grid, Grid1D) or grid.bc_lower != "floor" or grid.bc_upper != "vacuum" or grid.lower != 0.0:
            raise ValueError("grid must be a Grid1D from 0 with a floor below and a vacuum top")
        if not (0.0 < cfl <= self.cfl_limit):
            raise ValueError(f"cfl = {cfl!r} is outside the valid range (0, {self.cfl_limit}] for the "
                             f"{self.name} packing formulation")
        self.law, self.grid, self.n_spheres = law, grid, int(n_spheres)
        self.motion, self.gravity, self.ppd, self.cfl = motion, float(gravity), int(points_per_diameter), float(cfl)
        self.steps = 0
        self._fn = motion.fn
        self._params = np.ascontiguousarray(motion.params, dtype=np.float64)
        self.sphere_masses = (np.arange(self.n_spheres) + 0.5) * law.particle_mass

    # the controller's view -----------------------------------------------------------------------
    @property
    def fields(self) -> dict:
        raise NotImplementedError

    def load_fields(self, fields: dict):
        """Set the state from named fields (:attr:`fields`; a checkpoint's), all or none; ValueError
        (one line) when one is missing or has the wrong shape."""
        from .controller import restore_named_fields
        restore_named_fields(self.fields, fields)

    def apply_velocity_jump(self, dv):
        raise NotImplementedError

    def total_mass(self) -> float:
        return self.law.particle_mass * self.n_spheres


class EulerianPacking(_Base):
    """Formulation (a): finite volumes on ``grid`` (module docstring).  ``rho0`` [kg/m] the initial
    density on the grid's cells; None: at rest at close packing on [0, N d], as the other
    discretisations start."""

    name = "eulerian"
    cfl_limit = 0.5
    DEFAULT_CFL = 0.4
    supports = frozenset({"cfl", "points_per_diameter", "stiffness_factor", "save_every", "checkpoint_every"})

    def __init__(self, law, grid, n_spheres, motion, gravity, points_per_diameter, cfl=None, rho0=None):
        super().__init__(law, grid, n_spheres, motion, gravity, points_per_diameter, cfl)
        n = grid.n_cells
        if law.is_nonlocal:
            raise ValueError(f"range_over_d = {law.range_over_d!r}: EulerianPacking runs the local limit "
                             "(range_over_d = 0); the nonlocal interaction's Eulerian form is StaggeredEulerianPacking")
        self.q = np.zeros((3, n + 2 * pk.NG))
        if rho0 is None:
            rho0 = np.where(grid.x < self.n_spheres * law.diameter, law.close_packing_density, 0.0)
        self.q[pk.RHO, pk.NG:pk.NG + n] = rho0
        rc = law.close_packing_density
        self.rho_tiny = 1e-12 * rc
        self.rho_floor = 1e-30 * rc
        self.c_bound = law.wave_speed_bound(self.fields)     # the interaction's own bound
        self.counters = np.zeros(4, dtype=np.int64)

    @property
    def field_schema(self) -> dict:
        """The named state fields: name -> (dimensions, units, long_name) (``x``: the grid's cells)."""
        return {"rho": (("x",), "kg m-1", "line density (the finite volumes' state)"),
                "momentum": (("x",), "kg s-1", "momentum per unit length rho u (floor frame)"),
                "rho_delta_max": (("x",), "kg", "rho times delta_max, the largest overlap per contact "
                                  "reached (the history, advected in conserved form)")}

    @property
    def fields(self):
        n = self.grid.n_cells
        s = slice(pk.NG, pk.NG + n)
        return {"rho": self.q[pk.RHO, s], "momentum": self.q[pk.MOM, s], "rho_delta_max": self.q[pk.HIST, s]}

    def apply_velocity_jump(self, dv):
        n = self.grid.n_cells
        s = slice(pk.NG, pk.NG + n)
        self.q[pk.MOM, s] -= dv * self.q[pk.RHO, s]

    def advance(self, t, t_stop):
        law = self.law
        self.counters[1:] = 0
        t = pk.fv_advance(self.q, float(t), float(t_stop), self.grid.dx, self.cfl, self.c_bound, law.diameter,
                          law.particle_mass, law.k1, law.k2, self.rho_tiny, self.rho_floor, self._fn,
                          self._params, self.gravity, self.counters)
        self.steps = int(self.counters[0])
        status = int(self.counters[1])
        if status:
            where = float(self.grid.x[min(int(self.counters[2]), self.grid.n_cells - 1)])
            msg = {1: "negative density", 2: "non-finite state", 3: "material reached the top of the domain"}[status]
            raise PackingError(f"{msg} at t = {t:.6g} s, x = {where:.4g} m (cell {int(self.counters[2])})", t, where)
        return t

    def observe(self):
        """(rho [kg/m], u [m/s], tracers [m], kinetic energy [J]) on the grid, floor frame."""
        f = self.fields
        rho = f["rho"].copy()
        u = np.where(rho > self.rho_tiny, f["momentum"] / np.where(rho > 0, rho, 1.0), 0.0)
        dx = self.grid.dx
        cum = np.concatenate([[0.0], np.cumsum(rho) * dx])
        faces = np.concatenate([[0.0], self.grid.x + 0.5 * dx])
        tracers = np.interp(self.sphere_masses * (cum[-1] / self.total_mass()), cum, faces)
        return rho, u, tracers, 0.5 * float(np.sum(rho * u * u)) * dx


class StaggeredEulerianPacking(_Base):
    """Formulation (a) of the nonlocal interaction (``range_over_d`` > 0): the mass in the grid's
    cells, the velocity on its faces, a tracked free surface, a staggered Lagrange-remap step
    (:mod:`bsrflow.numerics.packing_staggered`).  Starts at rest at close packing on [0, N d]
    (N d must be a whole number of cells: ``points_per_diameter`` cells per diameter)."""

    name = "eulerian"
    cfl_limit = 0.5
    DEFAULT_CFL = 0.25
    supports = frozenset({"cfl", "points_per_diameter", "stiffness_factor", "range_over_d", "save_every",
                          "checkpoint_every"})

    def __init__(self, law, grid, n_spheres, motion, gravity, points_per_diameter, cfl=None):
        super().__init__(law, grid, n_spheres, motion, gravity, points_per_diameter, cfl)
        if not law.is_nonlocal:
            raise ValueError("StaggeredEulerianPacking runs the nonlocal interaction (range_over_d > 0); the local "
                             "limit is EulerianPacking's")
        n = grid.n_cells
        top = self.n_spheres * self.ppd
        if abs(grid.dx * self.ppd - law.diameter) > 1e-9 * law.diameter or top + 6 > n:
            raise ValueError("grid must have points_per_diameter cells per diameter and room above the column")
        self.weights = law.bond_weights(self.ppd)
        self.n_lags = len(self.weights)
        self.norm = pst.weight_norm(self.n_lags)
        self.mu = law.particle_mass / self.ppd
        self.mass = np.zeros(n)
        self.mass[:top] = self.mu
        self.v = np.zeros(n + 1)
        self.hist = np.zeros((self.n_lags + 2, n + 2))
        self.himg = np.zeros((self.n_lags + 3, self.n_lags + 3))
        self.surf = np.array([top - 1.0, self.n_spheres * law.diameter, 0.0])
        self.dt_max = self.cfl * pnl.nonlocal_time_step_bound(self.weights, self.ppd, law.k2, law.particle_mass)
        self.counters = np.zeros(3, dtype=np.int64)

    @property
    def field_schema(self) -> dict:
        """The named state fields: name -> (dimensions, units, long_name) (``x``: the grid's cells;
        ``face``: its faces from the floor; ``lag``: 1..L + 2; ``node``, ``image``: 0..L + 2)."""
        return {"cell_mass": (("x",), "kg", "mass of each grid cell (the top cell reaches to the surface)"),
                "velocity": (("face",), "m s-1", "velocity of the material at each face (floor frame; face 0 "
                             "the floor)"),
                "delta_max": (("lag", "face_bonds"), "m", "largest overlap per contact reached on the bond from "
                              "each face to the node lag faces above it"),
                "delta_max_image": (("node", "image"), "m", "the same for the bond from each node to the "
                                    "mirror image of a node below the floor"),
                "surface": (("surface_state",), "1, m, m s-1", "the top cell's index, the free surface's "
                            "height (floor frame) and velocity")}

    @property
    def fields(self):
        return {"cell_mass": self.mass, "velocity": self.v, "delta_max": self.hist, "delta_max_image": self.himg,
                "surface": self.surf}

    def apply_velocity_jump(self, dv):
        K = int(self.surf[0])
        self.v[1:K + 1] -= dv
        self.surf[2] -= dv

    def advance(self, t, t_stop):
        law = self.law
        self.counters[1:] = 0
        t = pst.staggered_advance(self.mass, self.v, self.hist, self.himg, self.surf, float(t), float(t_stop),
                                  self.dt_max, self.grid.dx, law.diameter, law.particle_mass, law.k1, law.k2,
                                  self.mu, self.n_lags, self.norm, law.close_packing_density, self._fn,
                                  self._params, self.gravity, self.counters)
        self.steps = int(self.counters[0])
        status = int(self.counters[1])
        if status:
            cell = int(self.counters[2])
            where = float(min(cell + 0.5, self.grid.n_cells - 0.5) * self.grid.dx)
            msg = {pst.BAD_CELL: "a cell's mass became non-positive or its velocity non-finite",
                   pst.DOMAIN_TOP: "material reached the top of the domain"}[status]
            raise PackingError(f"{msg} at t = {t:.6g} s, x = {where:.4g} m (cell {cell})", t, where)
        return t

    def cumulative_mass(self):
        """(nodes [m], cumulative mass [kg]): the faces up to the top cell and the surface, and
        the mass below each (density uniform in each cell)."""
        K, X = int(self.surf[0]), float(self.surf[1])
        nodes = np.concatenate([self.grid.dx * np.arange(K + 1), [X]])
        cum = np.concatenate([[0.0], np.cumsum(self.mass[:K + 1])])
        return nodes, cum

    def observe(self):
        """(rho [kg/m], u [m/s], tracers [m], kinetic energy [J]) on the grid, floor frame."""
        nodes, cum = self.cumulative_mass()
        K = int(self.surf[0])
        dx = self.grid.dx
        faces = np.concatenate([[0.0], self.grid.x + 0.5 * dx])
        rho = np.diff(np.interp(faces, nodes, cum, right=cum[-1])) / dx
        vel = np.concatenate([self.v[:K + 1], [self.surf[2]]])
        u = np.interp(self.grid.x, nodes, vel)
        u[rho <= 0.0] = 0.0
        tracers = np.interp(self.sphere_masses, cum, nodes)
        mnode = np.concatenate([[0.5 * (self.mass[f - 1] + self.mass[f]) for f in range(1, K + 1)],
                                [0.5 * self.mass[K]]])
        return rho, u, tracers, 0.5 * float(np.sum(mnode * vel[1:] ** 2))


class LagrangianPacking(_Base):
    """Formulation (b): material points (module docstring); ``points_per_diameter`` points per
    sphere, each of mass m/ppd, starting at rest at the centres of equal slices of the column.
    With the local law (``range_over_d`` = 0) pair forces between neighbours, the history on the
    bond beneath each point; with the nonlocal law bonds up to L = round(ppd R/d) points apart,
    each with its own history (fields ``delta_max`` of shape (L, points);
    :mod:`bsrflow.numerics.packing_nonlocal`), Δt = cfl·2/ω_max of the bond network.

    ``cfl`` None: :attr:`DEFAULT_CFL`, or :attr:`DEFAULT_CFL_ELASTIC` with restitution e = 1.
    With e = 1 the law has no hysteresis, and velocity Verlet gains energy where weakly loaded
    bonds open and close at every few steps (the force's kink at δ = 0): a column resting under
    gravity (ppd 5 / 10) carried 4.1e-5 / 2.6e-5 J of kinetic energy after 0.4 s at cfl 0.5,
    2.3e-7 J at cfl 0.25 and 2.1e-7 J at 0.125 (its ringing from the start); with e = 0.999,
    0.99, 0.95 or 0.9 the hysteresis takes that energy out at any cfl up to 0.5 (one-off runs,
    2026-12-02, docs/model.md)."""

    name = "lagrangian"
    cfl_limit = 0.9
    DEFAULT_CFL = 0.5
    DEFAULT_CFL_ELASTIC = 0.25
    supports = frozenset({"cfl", "points_per_diameter", "stiffness_factor", "range_over_d", "save_every",
                          "checkpoint_every"})

    @classmethod
    def default_cfl(cls, restitution: float) -> float:
        return cls.DEFAULT_CFL_ELASTIC if restitution >= 1.0 else cls.DEFAULT_CFL

    def __init__(self, law, grid, n_spheres, motion, gravity, points_per_diameter, cfl=None):
        super().__init__(law, grid, n_spheres, motion, gravity, points_per_diameter, cfl)
        n_pts = self.n_spheres * self.ppd
        h = law.diameter / self.ppd
        self.x = (np.arange(n_pts) + 0.5) * h
        self.v = np.zeros(n_pts)
        self.mu = law.particle_mass / self.ppd
        if law.is_nonlocal:
            # bonds up to L points apart, their histories (L, points); Verlet is stable for
            # ω_max Δt < 2: Δt = cfl · 2/ω_max (Gershgorin bound of the bond network)
            self.weights = law.bond_weights(self.ppd)
            if len(self.weights) > n_pts:
                raise ValueError(f"range_over_d = {law.range_over_d!r} is outside the valid range "
                                 f"(0, {self.n_spheres:g}] for a column of {self.n_spheres} spheres")
            self.hist = np.zeros((len(self.weights), n_pts))
            self.dt_max = self.cfl * pnl.nonlocal_time_step_bound(self.weights, self.ppd, law.k2, law.particle_mass)
        else:
            self.weights = None
            self.hist = np.zeros(n_pts)
            # Verlet is stable for ω_max Δt < 2 with ω_max = 2 ppd √(K2/m): Δt = cfl h / c
            self.dt_max = self.cfl * h / law.wave_speed_bound()
        self.counters = np.zeros(3, dtype=np.int64)
        self.point_masses = (np.arange(n_pts) + 0.5) * self.mu

    @property
    def field_schema(self) -> dict:
        """The named state fields: name -> (dimensions, units, long_name) (``point``: the material
        points from the floor up; ``lag``: the nonlocal bonds' lag ℓ = 1..L)."""
        if self.weights is None:
            hist = (("point",), "m", "largest overlap per contact reached on the bond beneath each point "
                    "(the lowest point's: to its mirror image below the floor)")
        else:
            hist = (("lag", "point"), "m", "largest overlap per contact reached on the bond from each point to "
                    "the point lag below it (below the floor: its mirror image)")
        return {"position": (("point",), "m", "material point height (floor frame)"),
                "velocity": (("point",), "m s-1", "material point velocity relative to the floor"),
                "delta_max": hist}

    @property
    def fields(self):
        return {"position": self.x, "velocity": self.v, "delta_max": self.hist}

    def apply_velocity_jump(self, dv):
        self.v -= dv

    def advance(self, t, t_stop):
        law = self.law
        t_start = t
        self.counters[1:] = 0
        if self.weights is None:
            t = pk.lagrangian_advance(self.x, self.v, self.hist, float(t), float(t_stop), self.dt_max, self.mu,
                                      float(self.ppd), law.diameter, law.k1, law.k2, self._fn, self._params,
                                      self.gravity, self.counters)
        else:
            t = pnl.nonlocal_lagrangian_advance(self.x, self.v, self.hist, self.weights, float(t), float(t_stop),
                                               self.dt_max, self.mu, float(self.ppd), law.diameter, law.k1,
                                               law.k2, self._fn, self._params, self.gravity, self.counters)
        self.steps = int(self.counters[0])
        if self.counters[1]:
            gaps = np.diff(np.concatenate([[-self.x[0]], self.x]))     # the first to the floor's mirror image
            i = int(np.argmin(gaps))
            raise PackingError(f"material points crossed (a bond length reached 0) at t = {t:.6g} s, near x = "
                               f"{self.x[i]:.4g} m (point {i} of {self.x.size}, floor frame)", t, float(self.x[i]))
        if self.x[-1] > self.grid.upper - self.law.diameter:
            # checked once per call (a save interval), not per step: say so, with the interval
            raise PackingError(f"material reached the top of the domain between t = {t_start:.6g} and {t:.6g} s "
                               f"(checked at every save), x = {self.x[-1]:.4g} m", t, float(self.x[-1]))
        return t

    def cumulative_mass(self):
        """(nodes [m], cumulative mass [kg]): the piecewise-linear mass below each height: the
        bond between two points holds m/ppd spread uniformly; half a point's mass lies between the
        floor and the lowest point, half above the top point over half a rest spacing."""
        h = self.law.diameter / self.ppd
        nodes = np.concatenate([[0.0], self.x, [self.x[-1] + 0.5 * h]])
        cum = np.concatenate([[0.0], self.point_masses, [self.total_mass()]])
        return nodes, cum

    def observe(self):
        nodes, cum = self.cumulative_mass()
        dx = self.grid.dx
        faces = np.concatenate([[0.0], self.grid.x + 0.5 * dx])
        rho = np.diff(np.interp(faces, nodes, cum)) / dx
        u = np.interp(self.grid.x, self.x, self.v)
        u[rho <= 0.0] = 0.0                      # no velocity where there is no material (as Eulerian)
        tracers = np.interp(self.sphere_masses, cum, nodes)
        return rho, u, tracers, 0.5 * self.mu * float(np.sum(self.v * self.v))


def run_packing(disc, t_end, save_times, *, t_start=0.0, observers=(), extra_event_times=(), on_event=None,
                progress=None):
    """Run ``disc`` (either formulation) from t_start to t_end through the controller shared with
    the seed's solver (:func:`bsrflow.numerics.controller.drive_events`): advance from event to
    event (save times, the motion's velocity jumps, ``extra_event_times`` such as checkpoints,
    only those strictly inside (t_start, t_end)), call ``on_event(t, disc)`` at the extra events
    (before the jump and the save at t, as checkpoints need) and every observer
    ``obs(t, u, rho, tracers)`` at the saves.

    A monitor stop raises :class:`PackingError` after the observers got every snapshot before it
    and ``disc`` holds the state reached (nothing written so far is lost).  Returns a
    :class:`PackingResult` with the saved snapshots."""
    from .controller import drive_events
    t_end = float(t_end)
    save_times = np.asarray(save_times, dtype=float)
    out_t, out_rho, out_u, out_tr, out_floor = [], [], [], [], []
    steps0 = disc.steps
    wall = time.perf_counter()

    def save(e):
        rho, u, tr, _ = disc.observe()
        for obs in observers:
            obs(e, u, rho, tr)
        out_t.append(e)
        out_rho.append(rho)
        out_u.append(u)
        out_tr.append(tr)
        out_floor.append(disc.motion.state(e)[0])
        if progress is not None:
            progress(e)

    drive_events(float(t_start), t_end, save_times, disc.motion.jumps_between(t_start, t_end), extra_event_times,
                 advance=disc.advance, apply_jump=disc.apply_velocity_jump, save=save,
                 on_event=None if on_event is None else (lambda e: on_event(e, disc)))
    wall = time.perf_counter() - wall
    return PackingResult(np.array(out_t), np.array(out_rho), np.array(out_u), np.array(out_tr),
                         np.array(out_floor), disc.steps - steps0, wall,
                         info={"formulation": disc.name, "ppd": disc.ppd, "cfl": disc.cfl,
                               "range_over_d": float(disc.law.range_over_d)})
