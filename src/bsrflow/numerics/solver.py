"""Driver of the 1-D semidiscrete BSR solver: scheme choice, output times, velocity jumps,
monitors, and the error raised when a run stops early.

Happy path::

    from bsrflow import Grid1D, BSRModel, Scheme, Simulation, walton_braun
    grid = Grid1D(0.0, 1.0, 200, "floor", "vacuum")
    model = BSRModel(kernel=walton_braun(1e3, 0.1, 0.05), gravity=9.81)
    sim = Simulation(model, grid, Scheme.preset("seed"))
    result = sim.run(u0, rho0, t_end=1.0, save_every=0.01)
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field, asdict

import numpy as np

from .._bounds import printed_bound
from ..physics.interaction import fast_integral_for
from ..physics.model import BSRModel, jit_user
from .compiled import STATUS, direct_integral, make_core
from .limits import MAX_SNAPSHOTS, cfl_limit
from .controller import drive_events
from .grid import Grid1D
from .quadrature import QUADRATURES, quadrature_weights
from .steppers import get_stepper

__all__ = ["Scheme", "Simulation", "SimulationResult", "SimulationError", "MAX_SNAPSHOTS"]


@dataclass
class Scheme:
    """Numerical choices.

    stepper : 'euler', 'heun', 'kutta3' (the seed's RK3, (4.17)-(4.24)), 'rk4', 'bs32',
        'rk4_0.4_0.25' (see :mod:`bsrflow.numerics.steppers`).
    filter : apply the moving average (1/4, 1/2, 1/4) to u and ρ after every step.
    quadrature : 'trapezoid' or 'boole' (see numerics.quadrature).
    cfl : Courant number ν: Δt = ν Δx / (max|u| + c), c = sqrt(κ max ρ) the kernel's sound speed.
    dt : fixed time step [s]; overrides cfl when given.
    tracer_integrator : 'euler' (the seed's, first order) or 'rk' (the field's tableau).
    hyperdiffusion : κ4 >= 0, strength of the fourth-difference artificial dissipation added to
        both right-hand sides, -κ4 (max|u| + c)/Δx δ⁴q (c the kernel's sound speed): O(Δx³),
        independent of Δt, conservative.  0 for the seed's scheme.
    positivity : after every step, set negative densities to 0 taking the deficit from the
        nearest positive cells (mass-conserving; ``compiled.make_positive``).
    rtol, atol : adaptive time stepping with the stepper's embedded pair (e.g. 'bs32',
        'kutta3', 'heun'): a step is accepted when max_i |Δt Σ (b_j - b̂_j) k_j| / (atol + rtol |y_i|)
        <= 1 over u and ρ (atol = (atol_u [m/s], atol_ρ [kg/m])), else rejected and retried with a
        smaller step; the CFL bound still caps the step.  rtol None: off.  Rejected steps are
        counted (``SimulationResult.info['rejected_steps']``).
    selective_filter : τ > 0: smoothness-sensor threshold (``compiled.sensor_on``).  With
        ``sensor_dissipation`` = 0 the moving average is applied after every step (when
        ``filter`` is off) only at the faces next to cells whose sensor exceeds τ
        (``compiled.selective_average``).
    check_cfl : refuse (ValueError) a scheme the measured stability limits
        (:data:`bsrflow.numerics.limits.CFL_LIMITS`, the table the configuration checks
        use) call unstable: a stepper unstable at every Courant number with or without the moving
        average as chosen (Euler or Heun without it), or, when the step is set by ``cfl`` (no
        fixed ``dt``), a ``cfl`` above the limit.  With a fixed ``dt`` the Courant number
        depends on the solution and is not checked.  ``check_cfl=False`` is the explicit escape
        for runs that are unstable on purpose (the stability tests run the solver at 1.02x the
        limit to see the growth).
    sensor_dissipation : κ2 >= 0; with κ2 > 0 and τ > 0 the flagged faces get a second-difference
        dissipation +κ2 (max|u| + c)/Δx δ²q inside both right-hand sides instead of the
        post-step average: part of the semi-discrete system, so independent of Δt (the post-step
        average is a diffusion Δx²/(4Δt) that grows as the step shrinks); O(Δx³) where the
        sensor is off on smooth data; conservative (zero mass flux through a floor).  κ2 = 1/2
        is the dissipation of the local Lax-Friedrichs (Rusanov) flux.
    """

    stepper: str = "kutta3"
    filter: bool = True
    quadrature: str = "trapezoid"
    cfl: float = 0.5
    dt: float | None = None
    tracer_integrator: str = "rk"
    hyperdiffusion: float = 0.0
    positivity: bool = False
    selective_filter: float = 0.0
    sensor_dissipation: float = 0.0
    rtol: float | None = None
    atol: tuple = (1e-6, 1e-6)
    name: str = "custom"
    check_cfl: bool = True

    def __post_init__(self):
        get_stepper(self.stepper)
        if not isinstance(self.filter, (bool, np.bool_)):
            raise ValueError(f"filter = {self.filter!r} must be True or False")
        for name in ("cfl", "hyperdiffusion", "selective_filter", "sensor_dissipation"):
            _require_number(name, getattr(self, name))
        if self.dt is not None:
            _require_number("dt", self.dt)
        if self.rtol is not None:
            _require_number("rtol", self.rtol)
        if self.quadrature not in QUADRATURES:
            raise ValueError(f"quadrature = {self.quadrature!r} is not one of {QUADRATURES}")
        if not (np.isfinite(self.cfl) and 0 < self.cfl <= 4):
            raise ValueError(f"cfl = {self.cfl!r} is outside the valid range (0, 4]")
        if self.dt is not None and not (np.isfinite(self.dt) and self.dt > 0):
            raise ValueError(f"dt = {self.dt!r} is outside the valid range (0, inf) s")
        if not (np.isfinite(self.hyperdiffusion) and 0.0 <= self.hyperdiffusion <= 0.1):
            raise ValueError(f"hyperdiffusion = {self.hyperdiffusion!r} is outside the valid range [0, 0.1]")
        if not (np.isfinite(self.selective_filter) and 0.0 <= self.selective_filter <= 1.0):
            raise ValueError(f"selective_filter = {self.selective_filter!r} is outside the valid range [0, 1]")
        if not (np.isfinite(self.sensor_dissipation) and 0.0 <= self.sensor_dissipation <= 2.0):
            raise ValueError(f"sensor_dissipation = {self.sensor_dissipation!r} is outside the valid range [0, 2]")
        if self.sensor_dissipation > 0 and self.selective_filter <= 0:
            raise ValueError("sensor_dissipation > 0 needs a sensor threshold selective_filter in (0, 1]")
        if self.rtol is not None:
            if not (np.isfinite(self.rtol) and 0 < self.rtol < 1):
                raise ValueError(f"rtol = {self.rtol!r} is outside the valid range (0, 1)")
            if get_stepper(self.stepper).b_embedded is None:
                raise ValueError(f"rtol given but stepper = {self.stepper!r} has no embedded pair; "
                                 "use one of 'heun', 'kutta3', 'bs32'")
            if self.dt is not None:
                raise ValueError("rtol (adaptive stepping) and a fixed dt cannot both be given")
        if len(self.atol) != 2 or not all(np.isfinite(a) and a > 0 for a in self.atol):
            raise ValueError(f"atol = {self.atol!r} must be two positive numbers (m/s, kg/m)")
        if self.tracer_integrator not in ("euler", "rk"):
            raise ValueError(f"tracer_integrator = {self.tracer_integrator!r} is not one of ('euler', 'rk')")
        if self.check_cfl:
            self._check_stability_limit()

    def _check_stability_limit(self):
        try:
            limit = cfl_limit(self.stepper, self.filter)
        except KeyError:
            return                                      # a stepper without a measured limit
        with_avg = "with" if self.filter else "without"
        if limit == 0.0:
            raise ValueError(f"stepper = {self.stepper!r} {with_avg} the moving average (filter = {bool(self.filter)}) "
                             "is unstable at every CFL number (measured limit 0, bsrflow stability); use "
                             "filter=True or one of 'kutta3', 'rk4', 'bs32', 'rk4_0.4_0.25' (check_cfl=False to "
                             "run it anyway)")
        if self.dt is None and self.cfl > limit:
            raise ValueError(f"cfl = {self.cfl!r} is above the stability limit {limit:g} of {self.stepper} "
                             f"{with_avg} the moving average; valid range (0, {limit:g}] (check_cfl=False to run "
                             "above it on purpose)")

    @classmethod
    def preset(cls, preset_name: str, **overrides) -> "Scheme":
        """Named schemes.

        'seed': Kutta's RK3 + moving average every step, trapezoid, ν = 0.5, Euler tracers (the
        dissertation's choices).  'accurate': the four-stage fourth-order Runge-Kutta method
        ``rk4_0.4_0.25`` (Kutta's family, nodes 0, 2/5, 1/4, 1) at ν = 0.2, no moving average;
        fourth-difference dissipation κ4 = 1/32 and, at the faces a smoothness sensor flags
        (τ = 0.02), second-difference dissipation κ2 = 1/4, both inside the right-hand side
        (O(Δx³) on smooth data, independent of Δt); the mass-conserving positivity fix after
        every step; RK tracers.  The choices are measured, not assumed (docs/model.md,
        ``bench/bench_schemes.py``): on the settling column the time error comes from the
        kernel's friction term σ(Δu) (a Coulomb-like switch, first order in Δt whatever the
        stepper); among the four-stage fourth-order methods the error constant of that term
        varies by more than 10x with the nodes, and this member's is 1.5-12x smaller than Kutta's
        RK3's (classical RK4's is larger than RK3's) at the same step; any per-step smoothing (the seed's moving
        average, or a post-step selective average) adds a diffusion ~Δx²/(4Δt) that grows as
        Δt shrinks, while the κ2/κ4 terms do not; without the sensor dissipation the tapped
        column broke down at the floor after a tap at 20 ppd (measured with Kutta's RK3 at
        ν = 0.1)."""
        presets = {
            "seed": dict(stepper="kutta3", filter=True, quadrature="trapezoid", cfl=0.5,
                         tracer_integrator="euler"),
            "accurate": dict(stepper="rk4_0.4_0.25", filter=False, quadrature="trapezoid", cfl=0.2,
                             tracer_integrator="rk", hyperdiffusion=1.0 / 32.0, positivity=True,
                             selective_filter=0.02, sensor_dissipation=0.25),
        }
        if preset_name not in presets:
            raise ValueError(f"scheme = {preset_name!r} is not one of {sorted(presets)}")
        kw = dict(presets[preset_name], name=preset_name)
        kw.update(overrides)
        return cls(**kw)

    def to_dict(self) -> dict:
        return asdict(self)


def _check_declared_bound(kernel, kappa, ws_fn, ws_params, rho: float, unit: str = "kg/m") -> None:
    """Refuse a kernel whose declared wave-speed bound (its ``compiled_wave_speed``, which a
    subclass may override) is below the sound speed of its own Θ at the density ``rho`` [``unit``]
    (the initial state's largest), c = √(κρ), with ``kappa`` the κ that the solver measured from
    Θ (1-D: :meth:`Kernel.stiffness_moment`, Appendix A corrected; n-D: n times the scheme's
    discrete moment; None: nothing to check): the CFL step would then be too long for the waves
    the kernel carries.  The margin, 1e-6, is above the error of κ's quadrature (about 1e-7 in
    1-D), so a subclass that declares the exact closed-form bound is taken."""
    if kappa is None or not rho > 0.0:
        return
    declared = float(ws_fn(rho, ws_params))
    sound = math.sqrt(max(kappa, 0.0) * rho)
    if not declared >= sound * (1.0 - 1e-6):
        raise ValueError(f"kernel {kernel.name!r}: its wave-speed bound c(ρ = {rho:.6g} {unit}, the initial state's "
                         f"largest density) = {declared:.9g} m/s is below its linear sound speed √(κρ) = {sound:.9g} m/s "
                         f"(κ = {kappa:.9g} measured from Θ): the CFL step would be too long; "
                         "compiled_wave_speed must give at least √(κρ)")


@dataclass
class SimulationResult:
    """Saved snapshots of a run. Arrays have the time axis first."""

    t: np.ndarray            # [s]
    x: np.ndarray            # [m] cell centres (floor frame)
    u: np.ndarray            # [m/s] velocity relative to the floor
    rho: np.ndarray          # [kg/m]
    tracers: np.ndarray      # [m] tracer positions relative to the floor, (nt, n_tracers)
    floor: np.ndarray        # [m] floor position ϑ(t) in the laboratory frame
    steps: int = 0
    wall_time: float = 0.0
    status: str = "ok"
    info: dict = field(default_factory=dict)

    def mass(self, dx: float) -> np.ndarray:
        """Total mass Σ ρ Δx [kg] at each saved time."""
        return self.rho.sum(axis=1) * dx

    def kinetic_energy(self, dx: float) -> np.ndarray:
        """Σ ½ ρ u² Δx [J] at each saved time (floor frame)."""
        return 0.5 * (self.rho * self.u ** 2).sum(axis=1) * dx


def _require_number(name, value):
    """ValueError unless ``value`` is a real number (not a string, None or bool)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} = {value!r} must be a number, not {type(value).__name__}")


def save_schedule(t_start, t_end, save_every=None, save_times=None, save_every_max=np.inf) -> np.ndarray:
    """Sorted output times [s] in [t_start, t_end]: ``save_times`` if given, else every
    ``save_every`` from t_start plus t_end, else just the two ends.  At most
    :data:`MAX_SNAPSHOTS` intervals (ValueError naming ``save_every`` and its valid range, up to
    ``save_every_max`` [s], the field's own bound where it has one; or ``save_times``)."""
    if save_times is None:
        if save_every is None:
            save_times = np.array([t_start, t_end])
        else:
            _require_number("save_every", save_every)
            span = t_end - t_start
            least = span / MAX_SNAPSHOTS
            hi = "inf)" if save_every_max == np.inf else printed_bound(save_every_max, down=True, slack=1e-8) + "]"
            rng = f"[{printed_bound(least, down=False, slack=1e-8)}, {hi} s"       # (the printed ends are accepted)
            if not (np.isfinite(save_every) and save_every > 0):
                raise ValueError(f"save_every = {save_every!r} is outside the valid range {rng} (at most "
                                 f"{MAX_SNAPSHOTS} snapshots)")
            if span / save_every > MAX_SNAPSHOTS * (1.0 + 1e-12):
                raise ValueError(f"save_every = {save_every!r} s gives {span / save_every:.3g} snapshots from "
                                 f"t = {t_start:g} to {t_end:g} s; valid range {rng} (at most {MAX_SNAPSHOTS} "
                                 "snapshots)")
            n = int(np.floor((t_end - t_start) / save_every + 1e-9))
            save_times = t_start + save_every * np.arange(n + 1)
            if save_times[-1] < t_end - 1e-12 * max(1.0, abs(t_end)):
                save_times = np.append(save_times, t_end)
    try:
        save_times = np.asarray(save_times, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"save_times = {save_times!r} must be a list of numbers [s]") from None
    if not np.all(np.isfinite(save_times)):
        raise ValueError("save_times contains non-finite values")
    if save_times.size > MAX_SNAPSHOTS + 1:            # as many as the smallest save_every gives
        raise ValueError(f"save_times has {save_times.size} times; at most {MAX_SNAPSHOTS + 1} "
                         f"({MAX_SNAPSHOTS} intervals, the cap of save_every)")
    return np.unique(np.clip(save_times, t_start, t_end))


def check_tracers(tracers, grid, inside=True) -> np.ndarray:
    """Tracer positions [m] as a float array (a copy); ValueError for non-numbers, NaN or
    infinite values, or (``inside``) positions outside the domain [lower, upper] of ``grid``
    (floor frame)."""
    if tracers is None:
        return np.zeros(0)
    try:
        tr = np.array(tracers, dtype=float, copy=True).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"tracers = {tracers!r} must be a list of positions [m]") from None
    bad = ~np.isfinite(tr)
    if bad.any():
        k = int(np.argmax(bad))
        raise ValueError(f"tracers[{k}] = {float(tr[k])!r} is not a finite position; valid range "
                         f"[{grid.lower:g}, {grid.upper:g}] m (the domain)")
    out = (tr < grid.lower) | (tr > grid.upper)
    if inside and out.any():
        k = int(np.argmax(out))
        raise ValueError(f"tracers[{k}] = {float(tr[k])!r} m is outside the valid range [{grid.lower:g}, {grid.upper:g}] m "
                         "(the domain)")
    return tr


class SimulationError(RuntimeError):
    """A run stopped early. ``.result`` holds every snapshot saved before the stop;
    ``.time`` [s] and ``.position`` [m] say when and where."""

    def __init__(self, message, result, time, position, status):
        super().__init__(message)
        self.result = result
        self.time = time
        self.position = position
        self.status = status


def check_run_limits(max_steps, **nonnegative) -> None:
    """Refuse (ValueError, one line naming it) a solver's stopping criterion or threshold that is
    not a number in [0, inf) (``nonnegative``, by name) and a ``max_steps`` that is not an
    integer >= 1: the checks the 1-D and the n-D solvers share."""
    for name, v in nonnegative.items():
        if isinstance(v, bool) or not isinstance(v, (int, float, np.integer, np.floating)):
            raise ValueError(f"{name} = {v!r} must be a number")
        if not (np.isfinite(v) and v >= 0):
            raise ValueError(f"{name} = {v!r} is outside the valid range [0, inf)")
    if isinstance(max_steps, bool) or int(max_steps) != max_steps or max_steps < 1:
        raise ValueError(f"max_steps = {max_steps!r} is outside the valid range: integers >= 1")


class Simulation:
    """A BSR model on a grid with a scheme.

    Parameters
    ----------
    model : :class:`bsrflow.physics.model.BSRModel`
    grid : :class:`bsrflow.numerics.grid.Grid1D`; the kernel radius must be a whole number of
        cells, at least 2 (or 0 for no interaction).
    scheme : :class:`Scheme`
    rho_max : stop when ρ exceeds this [kg/m] (0: no bound).
    dt_min : stop when the CFL step falls below this [s].
    strain_limit : stop when max(-u_x) Δt exceeds this (0: off).
    top_tolerance : with a vacuum top, stop when ρ [kg/m] within the kernel radius of the top
        exceeds this (0: off).
    max_steps : stop after this many steps.
    vacuum_density : cells with ρ below this [kg/m] are vacuum: after every step their velocity
        is replaced by that of the nearest material cell (0: off).  See
        ``compiled.extend_velocity``.
    integral : 'fast' (default: the kernel's ``fast_integral`` when it has one, e.g. the
        Walton–Braun algorithm of :mod:`bsrflow.numerics.fast_integral`, which equals the direct
        sum to round-off) or 'direct' (the quadrature sum of (2W+1) kernel calls per cell,
        :func:`bsrflow.numerics.compiled.make_direct_integral`).
    integral_fn : a compiled whole-array interaction integral to use instead (overrides
        ``integral``).
    skip_vacuum : do not update the empty cells above a column during the stages (needs a
        vacuum top and ``vacuum_density`` > 0; a step without material, ρ >= vacuum_density,
        computes the whole grid).  The result is the same, bit for bit in the tests through a
        tap; the two round-off-level caveats are in ``compiled.make_core``'s ``advance``.
    density_floor : at the end of every step, densities with |ρ| below this [kg/m] are set to 0
        (0: off, the default; must be below ``vacuum_density`` when that is set).  The moving
        average spreads ρ by one cell per step, so without a floor an exponentially small
        debris (down to subnormal numbers, 1e-323 kg/m, and of either sign) creeps up through
        the vacuum above a column and is computed as material; the tapped column
        (:meth:`bsrflow.physics.column.ColumnSetup.simulation`) sets 1e-30 m/d.
    """

    def __init__(self, model: BSRModel, grid: Grid1D, scheme: Scheme | None = None, *, rho_max=0.0,
                 dt_min=1e-12, strain_limit=0.0, top_tolerance=0.0, max_steps=50_000_000,
                 vacuum_density=0.0, integral="fast", integral_fn=None, skip_vacuum=True,
                 density_floor=0.0):
        self.model = model
        self.grid = grid
        self.scheme = scheme or Scheme.preset("seed")
        R = model.kernel.radius
        Wf = R / grid.dx
        W = int(round(Wf))
        if R > 0 and (abs(Wf - W) > 1e-6 * max(1.0, Wf) or W < 2):
            raise ValueError(
                f"kernel radius {R!r} m must be a whole number (>= 2) of cells of width dx = {grid.dx!r} m; "
                f"it is {Wf:.6g} cells (choose n_cells so that radius/dx is an integer >= 2)")
        if grid.bc_lower == "periodic" and W >= grid.n_cells:
            raise ValueError(f"n_cells = {grid.n_cells} must exceed the kernel radius in cells ({W}) "
                             "for a periodic grid")
        self.W = W
        self.qz, self.qw = quadrature_weights(W, grid.dx, self.scheme.quadrature)
        self.tableau = get_stepper(self.scheme.stepper)
        tb = self.tableau
        self._bhat = tb.b_embedded if tb.b_embedded is not None else tb.b.copy()
        self._err_order = (tb.embedded_order or tb.order) + 1
        self.counters = np.zeros(2, dtype=np.int64)
        self.kappa = model.kernel.stiffness_moment()
        # the interaction's own wave-speed bound (for the seed's kernel √(κρ)), compiled in
        self._wave_speed_fn, self.wave_speed_params = model.kernel.compiled_wave_speed()
        # κ of the kernel's own Θ, for the check of a declared bound at run() (None: not a Kernel)
        from ..physics.kernels import Kernel
        self._kappa_of_theta = Kernel.stiffness_moment(model.kernel) if isinstance(model.kernel, Kernel) else None
        # (a negative or NaN one was taken silently: max_steps = 0 stopped every run at its first step)
        check_run_limits(max_steps, rho_max=rho_max, dt_min=dt_min, strain_limit=strain_limit,
                         top_tolerance=top_tolerance)
        self.rho_max = float(rho_max)
        self.dt_min = float(dt_min)
        self.strain_limit = float(strain_limit)
        self.top_tolerance = float(top_tolerance)
        self.max_steps = int(max_steps)
        if not (np.isfinite(vacuum_density) and vacuum_density >= 0):
            raise ValueError(f"vacuum_density = {vacuum_density!r} is outside the valid range [0, inf) kg/m")
        self.vacuum_density = float(vacuum_density)
        top = self.vacuum_density if self.vacuum_density > 0 else np.inf
        if not (np.isfinite(density_floor) and 0 <= density_floor < top):
            rng = f"[0, vacuum_density = {self.vacuum_density!r})" if self.vacuum_density > 0 else "[0, inf)"
            raise ValueError(f"density_floor = {density_floor!r} is outside the valid range {rng} kg/m")
        self.density_floor = float(density_floor)
        self.skip_vacuum = bool(skip_vacuum)
        if integral not in ("fast", "direct"):
            raise ValueError(f"integral = {integral!r} is not one of ('fast', 'direct')")
        if integral_fn is None:
            fast = fast_integral_for(model.kernel)
            integral_fn = fast if (integral == "fast" and fast is not None) else direct_integral(model.kernel.compiled)
        self.integral_name = getattr(integral_fn, "__name__", "custom")
        integral = integral_fn
        self.core = make_core(integral, jit_user(model.external), model.motion.fn,
                              jit_user(model.boundary_values), self._wave_speed_fn)

    # -- the pieces, exposed for tests and analysis ------------------------------------------
    def advance(self, u, rho, t, t_end, tracers=None, max_steps=None):
        """Advance (u, ρ, tracers) in place from t to t_end (no jumps, no saving).
        Returns (t, steps, status, where, dt_last)."""
        g = self.grid
        s = self.scheme
        bcl, bch = g.codes
        tr = np.zeros(0) if tracers is None else tracers
        mode = 0 if tracers is None or len(tracers) == 0 else (1 if s.tracer_integrator == "euler" else 2)
        tb = self.tableau
        return self.core.advance(
            u, rho, float(t), float(t_end), float(s.dt or 0.0), float(s.cfl), self.wave_speed_params,
            tb.a, tb.b, tb.c, bool(s.filter), bcl, bch, float(g.lower), float(g.dx), self.W, self.qz,
            self.qw, self.model.kernel.params, float(self.model.gravity), self.model.external_params,
            self.model.motion.params, self.model.boundary_params, self.dt_min, self.rho_max,
            int(max_steps or self.max_steps), self.strain_limit, self.top_tolerance, tr, mode,
            self.vacuum_density, float(s.hyperdiffusion), bool(s.positivity), float(s.selective_filter),
            self._bhat, float(s.rtol or 0.0), float(s.atol[0]), float(s.atol[1]), float(self._err_order),
            self.counters, self.skip_vacuum, float(s.sensor_dissipation), self.density_floor)

    def rhs(self, u, rho, t):
        """Semi-discrete right-hand side (du/dt, dρ/dt) at time t."""
        g = self.grid
        G = max(self.W, 2)
        N = g.n_cells
        up = np.empty(N + 2 * G)
        rp = np.empty(N + 2 * G)
        du = np.empty(N)
        dr = np.empty(N)
        bcl, bch = g.codes
        self.core.fill_ghosts(np.ascontiguousarray(u, float), np.ascontiguousarray(rho, float), float(t),
                              up, rp, G, bcl, bch, float(g.lower), float(g.dx), self.model.boundary_params)
        self.core.rhs(float(t), up, rp, G, N, float(g.lower), float(g.dx), self.W, self.qz, self.qw,
                      self.model.kernel.params, float(self.model.gravity), self.model.external_params,
                      self.model.motion.params, du, dr, bcl, float(self.scheme.hyperdiffusion), self.wave_speed_params,
                      np.ascontiguousarray(rho, float), float(self.vacuum_density),
                      float(self.scheme.sensor_dissipation), float(self.scheme.selective_filter))
        return du, dr

    # -- a whole run --------------------------------------------------------------------------
    def run(self, u0, rho0, t_end, *, t_start=0.0, save_every=None, save_times=None, tracers=None,
            observers=(), progress=None, extra_event_times=(), on_event=None,
            restart=False) -> SimulationResult:
        """Integrate from t_start to t_end [s], saving snapshots.

        u0 [m/s], rho0 [kg/m]: initial fields on the grid (floor frame).
        save_every [s] or save_times [s]: when to save (default: start and end only).
        tracers: initial tracer positions [m] (floor frame), moved with the velocity field.
        observers: callables ``obs(t, u, rho, tracers)`` called at every save (e.g. a writer),
            so output written before a failure is kept.
        progress: callable ``progress(t)`` called at every save.
        extra_event_times: further times [s]; those in (t_start, t_end) become events of the
            run: the time loop lands on them exactly (a step ends there) and calls
            ``on_event(t, u, rho, tracers, steps)`` (``steps``: steps taken so far in this
            call) *before* the velocity jump and the save at that time, if any.  State
            handed to ``on_event`` at t, restarted with ``run(..., t_start=t, restart=True)``
            with the remaining save times and event times, gives the same step sequence and
            bit-for-bit the same snapshots: the restarted run applies the jump at t itself
            (``jumps_between`` includes its start) and no step carries information across an
            event (every ``advance`` starts afresh).  Used for checkpoints.
        restart: the initial state is a state saved by an earlier run (a checkpoint): skip
            the check that rho0 >= 0 (schemes without the positivity fix leave round-off
            level negative densities, e.g. -1e-15 kg/m) and that the tracers lie inside the
            domain (a tracer moved to the floor may sit a round-off below it).
        ValueError (before any step) for arrays of the wrong shape (no reshaping: u0 and rho0
        must have shape (n_cells,)), non-finite values, t_end or save_every that are not
        numbers, more than :data:`MAX_SNAPSHOTS` snapshots, and tracers that are not finite
        or (without ``restart``) outside the domain.
        Raises :class:`SimulationError` (with ``.result``) if a monitor stops the run.
        """
        g = self.grid
        arrays = []
        for name, value in (("u0", u0), ("rho0", rho0)):
            try:
                arr = np.array(value, dtype=float, copy=True)
            except (TypeError, ValueError):
                raise ValueError(f"{name} must be an array of numbers of shape ({g.n_cells},)") from None
            if arr.shape != (g.n_cells,):
                raise ValueError(f"{name} has shape {arr.shape}; expected ({g.n_cells},) to match the grid "
                                 "(a 1-D array, one value per cell)")
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"{name} contains non-finite values")
            arrays.append(arr)
        u, rho = arrays
        if not restart and np.any(rho < 0):
            raise ValueError(f"rho0 has negative values (min {rho.min():.3g} kg/m); density must be >= 0")
        _check_declared_bound(self.model.kernel, self._kappa_of_theta, self._wave_speed_fn, self.wave_speed_params,
                              float(rho.max()))
        _require_number("t_start", t_start)
        _require_number("t_end", t_end)
        if not (np.isfinite(t_start) and np.isfinite(t_end) and t_end > t_start):
            raise ValueError(f"t_end = {t_end!r} must be finite and greater than t_start = {t_start!r}")
        tr = check_tracers(tracers, g, inside=not restart)
        save_times = save_schedule(t_start, t_end, save_every, save_times)
        jumps = self.model.motion.jumps_between(t_start, t_end)
        ts, us, rs, trs, fl = [], [], [], [], []
        motion = self.model.motion

        def save(t):
            ts.append(t)
            us.append(u.copy())
            rs.append(rho.copy())
            trs.append(tr.copy())
            fl.append(motion.state(t)[0])
            for obs in observers:
                obs(t, u, rho, tr)
            if progress is not None:
                progress(t)

        def result(status):
            return SimulationResult(np.array(ts), g.x, np.array(us), np.array(rs),
                                    np.array(trs).reshape(len(ts), tr.size), np.array(fl), total_steps,
                                    _time.perf_counter() - wall0, status,
                                    {"scheme": self.scheme.to_dict(), "grid": g.to_dict(),
                                     "model": self.model.to_dict(),
                                     "rejected_steps": int(self.counters[0] - rejected0)})

        wall0 = _time.perf_counter()
        rejected0 = int(self.counters[0])
        total_steps = 0

        def advance(t, ev):
            nonlocal total_steps
            t_new, steps, status, where, dt_last = self.advance(u, rho, t, ev, tr,
                                                                max_steps=self.max_steps - total_steps)
            total_steps += steps
            if status != 0:
                x_where = float(g.x[where]) if 0 <= where < g.n_cells else float("nan")
                msg = (f"simulation stopped at t = {t_new:.6g} s near x = {x_where:.6g} m "
                       f"(cell {where}): {STATUS[status]}; last dt = {dt_last:.3g} s, "
                       f"{total_steps} steps; {len(ts)} snapshot(s) up to t = "
                       f"{(ts[-1] if ts else t_start):.6g} s were kept")
                raise SimulationError(msg, result(STATUS[status]), t_new, x_where, status)

        def apply_jump(dv):
            # the floor velocity jumps by dv: the velocity relative to the floor by -dv (3.15)
            np.subtract(u, dv, out=u)

        drive_events(t_start, t_end, save_times, jumps, extra_event_times, advance=advance,
                     apply_jump=apply_jump, save=save,
                     on_event=None if on_event is None else (lambda ev: on_event(ev, u, rho, tr, total_steps)))
        return result("ok")
