"""Python API input checks (issue #20, "Python API"): the checks the configuration and the CLI
make, made by Scheme, Grid1D and Simulation.run too, as clear ValueErrors before any step."""

import math

import numpy as np
import pytest

from bsrflow.io.config import CFL_LIMITS, Config, ConfigError
from bsrflow.numerics import limits
from bsrflow.numerics.grid import Grid1D
from bsrflow.numerics.grid_nd import GridND
from bsrflow.numerics.solver import MAX_SNAPSHOTS, Scheme, Simulation, save_schedule
from bsrflow.physics.model import BSRModel

GRID = Grid1D(0.0, 1.0, 400, "periodic", "periodic")


@pytest.fixture(scope="module")
def sim():
    return Simulation(BSRModel(), GRID, Scheme.preset("seed"))


def _fields():
    return np.zeros(GRID.n_cells), np.ones(GRID.n_cells)


# -- snapshots ---------------------------------------------------------------------------------
def test_snapshot_cap_is_the_configs(sim):
    assert MAX_SNAPSHOTS == limits.MAX_SNAPSHOTS == 1_000_000
    u, r = _fields()
    with pytest.raises(ValueError, match=r"^save_every = 1e-09 s gives 1e\+09 snapshots .*valid range \[1e-06, inf\) s "
                                         r"\(at most 1000000 snapshots\)"):
        sim.run(u, r, 1.0, save_every=1e-9)
    # the configuration refuses the same save_every (the CLI's cap)
    with pytest.raises(ConfigError, match="at most 1000000 snapshots"):
        Config.from_dict({"run": {"t_end": 1.0, "save_every": 1e-9}})
    for bad in (0.0, -1.0, math.nan, math.inf * -1):
        with pytest.raises(ValueError, match="^save_every = .* valid range"):
            sim.run(u, r, 1.0, save_every=bad)
    with pytest.raises(ValueError, match="^save_every = '0.1' must be a number"):
        sim.run(u, r, 1.0, save_every="0.1")
    assert save_schedule(0.0, 1.0, 1e-6).size == MAX_SNAPSHOTS + 1     # the cap itself is allowed
    with pytest.raises(ValueError, match="save_times has 1000002 times; at most 1000001"):
        save_schedule(0.0, 1.0, save_times=np.linspace(0, 1, MAX_SNAPSHOTS + 2))
    with pytest.raises(ValueError, match="save_times contains non-finite"):
        save_schedule(0.0, 1.0, save_times=[0.1, math.nan])


# -- tracers -----------------------------------------------------------------------------------
@pytest.mark.parametrize("tracers, match", [
    ([0.1, math.nan], r"^tracers\[1\] = nan is not a finite position; valid range \[0, 1\] m"),
    ([math.inf], r"^tracers\[0\] = inf is not a finite"),
    ([0.5, 1.5], r"^tracers\[1\] = 1.5 m is outside the valid range \[0, 1\] m"),
    ([-0.01], r"^tracers\[0\] = -0.01 m is outside the valid range"),
    (["a"], r"^tracers = \['a'\] must be a list of positions"),
])
def test_tracers_must_be_finite_and_inside(sim, tracers, match):
    u, r = _fields()
    with pytest.raises(ValueError, match=match):
        sim.run(u, r, 1e-3, tracers=tracers)


def test_tracers_at_the_ends_are_accepted(sim):
    u, r = _fields()
    res = sim.run(u, r, 1e-3, tracers=[0.0, 0.5, 1.0])
    assert res.tracers.shape == (2, 3) and np.all(np.isfinite(res.tracers))


# -- arrays, times -----------------------------------------------------------------------------
def test_arrays_are_not_reshaped(sim):
    with pytest.raises(ValueError, match=r"^u0 has shape \(20, 20\); expected \(400,\)"):
        sim.run(np.zeros((20, 20)), np.ones(400), 1.0)
    with pytest.raises(ValueError, match=r"^rho0 has shape \(400, 1\); expected \(400,\)"):
        sim.run(np.zeros(400), np.ones((400, 1)), 1.0)
    with pytest.raises(ValueError, match="^rho0 must be an array of numbers"):
        sim.run(np.zeros(400), ["x"] * 400, 1.0)


@pytest.mark.parametrize("kw, match", [
    (dict(t_end="1"), r"^t_end = '1' must be a number, not str"),
    (dict(t_end=None), r"^t_end = None must be a number"),
    (dict(t_end=1.0, t_start="0"), r"^t_start = '0' must be a number"),
    (dict(t_end=math.nan), r"^t_end = nan must be finite"),
])
def test_times_must_be_numbers(sim, kw, match):
    u, r = _fields()
    with pytest.raises(ValueError, match=match):
        sim.run(u, r, **kw)


@pytest.mark.parametrize("args, match", [
    ((0, 1, None), r"^n_cells = None is outside the valid range: integers >= 3"),
    ((0, 1, "400"), r"^n_cells = '400' is outside the valid range"),
    ((0, 1, math.nan), r"^n_cells = nan is outside the valid range"),
    ((None, 1, 400), r"^lower = None must be a number"),
    ((0, "1", 400), r"^upper = '1' must be a number"),
])
def test_grid_arguments(args, match):
    with pytest.raises(ValueError, match=match):
        Grid1D(*args)


def test_nd_driver_refuses_the_same(tmp_path):
    from bsrflow.numerics.solver_nd import SimulationND
    from bsrflow.physics.kernels_nd import BSRModelND, walton_braun_nd

    with pytest.raises(ValueError, match="^shape = .* integers >= 3"):
        GridND((None, 8), 0.1)
    with pytest.raises(ValueError, match="^dx = '0.1' is outside"):
        GridND((8, 8), "0.1")
    grid = GridND((6, 8), 0.05, bc_horizontal="periodic", bc_lower="floor", bc_upper="vacuum")
    model = BSRModelND(walton_braun_nd(1e3, 0.1, 0.1), gravity=9.81)
    sim = SimulationND(model, grid, Scheme(stepper="kutta3", filter=True, dt=1e-4))
    u0, r0 = np.zeros((2, 6, 8)), np.ones((6, 8))
    with pytest.raises(ValueError, match=r"^t_end = '1' must be a number"):
        sim.run(u0, r0, "1")
    with pytest.raises(ValueError, match=r"^save_every = 1e-09 s gives"):
        sim.run(u0, r0, 1.0, save_every=1e-9)
    with pytest.raises(ValueError, match=r"u0 has shape \(2, 48\)"):
        sim.run(u0.reshape(2, 48), r0, 1.0)
    with pytest.raises(ValueError, match="unstable at every CFL number"):
        SimulationND(model, grid, Scheme(stepper="euler", filter=False, dt=1e-4))


# -- the stability limit -----------------------------------------------------------------------
def test_scheme_refuses_cfl_above_the_measured_limit():
    with pytest.raises(ValueError, match=r"^stepper = 'euler' without the moving average \(filter = False\) is "
                                         "unstable at every CFL number"):
        Scheme(stepper="euler", filter=False, cfl=0.5)
    with pytest.raises(ValueError, match="unstable at every CFL number"):
        Scheme(stepper="heun", filter=False, dt=1e-3)          # unstable whatever the step
    for (stepper, filt), limit in CFL_LIMITS.items():
        if limit == 0.0:
            continue
        Scheme(stepper=stepper, filter=filt, cfl=limit)        # at the limit: accepted
        with pytest.raises(ValueError, match=rf"^cfl = {limit * 1.001!r} is above the stability limit {limit:g} "
                                             rf"of {stepper} (with|without) the moving average; valid range "
                                             rf"\(0, {limit:g}\]"):
            Scheme(stepper=stepper, filter=filt, cfl=limit * 1.001)
    # steppers sharing a stability polynomial share the limit, as in the configuration
    with pytest.raises(ValueError, match="above the stability limit 2.8284"):
        Scheme.preset("accurate", cfl=2.9)
    with pytest.raises(ValueError, match="above the stability limit 1.7321"):
        Scheme(stepper="bs32", filter=False, cfl=1.8)
    # a fixed dt sets the step, not cfl: the Courant number is the solution's, not checked here
    Scheme(stepper="kutta3", filter=False, cfl=4.0, dt=1e-3)


def test_check_cfl_false_is_the_explicit_escape():
    s = Scheme(stepper="euler", filter=False, cfl=0.5, check_cfl=False)
    assert s.to_dict()["check_cfl"] is False
    Scheme(stepper="kutta3", filter=True, cfl=3.0, check_cfl=False)


def test_the_refused_scheme_really_blows_up():
    """What the check prevents: Euler without the average at ν = 0.5 on a smooth advected
    density gives ρ far outside its initial range within 400 steps (here with check_cfl=False)."""
    x = GRID.x
    sim = Simulation(BSRModel(), GRID, Scheme(stepper="euler", filter=False, cfl=0.5, check_cfl=False))
    u = np.full(GRID.n_cells, 1.0)
    rho = 1.0 + 0.1 * np.sin(2 * np.pi * x) + 1e-6 * np.cos(2 * np.pi * 150 * x)
    sim.advance(u, rho, 0.0, 1e300, max_steps=4000)
    assert not (0.8 < rho.min() and rho.max() < 1.2)


def test_scheme_argument_types():
    with pytest.raises(ValueError, match="^cfl = '0.5' must be a number"):
        Scheme(cfl="0.5")
    with pytest.raises(ValueError, match="^filter = 'yes' must be True or False"):
        Scheme(filter="yes")
    with pytest.raises(ValueError, match="^dt = '1e-3' must be a number"):
        Scheme(dt="1e-3")


def test_the_readme_two_dimensional_example_runs_as_written():
    """The README's n-D example ("Five lines of Python"), executed from the README itself: the
    package's top-level names, mass conserved to round-off, the density non-negative."""
    from pathlib import Path
    text = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    blocks = [b.split("```", 1)[0] for b in text.split("```python\n")[1:]]
    block = next(b for b in blocks if "from bsrflow import GridND" in b)
    scope = {}
    exec(compile(block, "README.md", "exec"), scope)
    res = scope["res"]
    assert res.status == "ok" and len(res.t) == 6
    mass = res.mass()
    assert abs(mass[-1] / mass[0] - 1.0) < 1e-12 and mass[0] == pytest.approx(1600.0 * 0.02 * 0.05)
    assert res.rho.min() >= 0.0


# -- a user's own kernel, motion and stopping criteria (an audit of extending the package) -------
@pytest.mark.parametrize("kw", [dict(rho_max=-1.0), dict(dt_min=-1.0), dict(strain_limit=-1.0),
                                dict(top_tolerance=math.nan), dict(max_steps=0), dict(max_steps=-5),
                                dict(max_steps=2.5), dict(rho_max="1")])
def test_simulation_refuses_bad_stopping_criteria(kw):
    name = next(iter(kw))
    with pytest.raises(ValueError, match=f"^{name} = .*(valid range|must be a number)"):
        Simulation(BSRModel(), GRID, Scheme.preset("seed"), **kw)


def _no_interaction(z, u_here, u_there, p):
    return 0.0 * z


def test_a_changed_kernel_function_is_the_one_compiled():
    """Setting ``fn`` or ``dataclasses.replace(kernel, fn=...)`` gives a kernel whose compiled
    loop runs the new function (it ran the old Walton–Braun one, while κ and the CFL bound
    came from the new one)."""
    import dataclasses

    from bsrflow.physics.kernels import walton_braun

    grid = Grid1D(0.0, 1.0, 200, "floor", "vacuum")
    rho = np.where(grid.x < 0.2, 0.5, 0.0)
    replaced = dataclasses.replace(walton_braun(48000.0, 0.1, 0.05), fn=_no_interaction)
    changed = walton_braun(48000.0, 0.1, 0.05)
    changed.fn = _no_interaction
    for kernel in (replaced, changed):
        assert kernel.compiled.py_func is _no_interaction and kernel.stiffness_moment() == 0.0
        sim = Simulation(BSRModel(kernel=kernel, gravity=9.81), grid, Scheme.preset("seed"))
        du, _ = sim.rhs(np.zeros(grid.n_cells), rho, 0.0)
        np.testing.assert_array_equal(du, -9.81)             # gravity alone


@pytest.mark.parametrize("params", [[math.nan], [1.0, math.inf]])
def test_kernel_parameters_must_be_finite(params):
    from bsrflow.physics.kernels import Kernel, walton_braun

    with pytest.raises(ValueError, match=r"^kernel params = .* must be finite numbers"):
        Kernel(_no_interaction, params, 0.1)
    kernel = walton_braun(48000.0, 0.1, 0.05)
    with pytest.raises(ValueError, match=r"^kernel params = "):
        kernel.params = [48000.0, math.nan, 0.05, -1.0]
    with pytest.raises(ValueError, match=r"^kernel fn = None is not a function"):
        Kernel(None, [1.0], 0.1)


def test_a_motion_that_gives_nan_stops_a_column_run_in_one_line():
    """A NaN from the applied motion, in a run with a vacuum top: the run stops at the first step
    after it with the non-finite message (it looped forever in the velocity extension, which took a NaN
    density for neither material nor vacuum)."""
    import numba

    from bsrflow.numerics.solver import SimulationError
    from bsrflow.physics.kernels import walton_braun
    from bsrflow.physics.motion import AppliedMotion

    @numba.njit
    def nan_motion(t, p):               # NaN from 1 ms on (at t = 0 AppliedMotion refuses it)
        return 0.0, 0.0, np.nan if t > 1e-3 else 0.0

    grid = Grid1D(0.0, 1.0, 200, "floor", "vacuum")
    model = BSRModel(kernel=walton_braun(48000.0, 0.1, 0.05), gravity=9.81, motion=AppliedMotion(nan_motion, [0.0]))
    sim = Simulation(model, grid, Scheme.preset("seed"), vacuum_density=1e-4)
    with pytest.raises(SimulationError, match="non-finite value") as err:
        sim.run(np.zeros(grid.n_cells), np.where(grid.x < 0.2, 0.5, 0.0), 0.3, save_every=0.1)
    assert "\n" not in str(err.value) and err.value.result.t.size == 1 and err.value.time < 0.01


def test_velocity_extension_takes_a_nan_density_for_vacuum():
    grid = Grid1D(0.0, 1.0, 20, "floor", "vacuum")
    sim = Simulation(BSRModel(), grid, Scheme.preset("seed"), vacuum_density=1e-3)
    u = np.arange(20.0)
    rho = np.ones(20)
    rho[5] = np.nan
    rho[12:] = 0.0
    top = sim.core.extend_velocity(u, rho, 1e-3)
    assert top == 11
    assert u[5] == 4.0 and np.all(u[12:] == 11.0)


def _constant_floor_acceleration(t, p):        # ϑ = A t²/2: no jump, ϑ'' = A from t = 0
    return 0.5 * p[0] * t * t, p[0] * t, p[0]


def test_at_rest_without_gravity_the_floor_acceleration_sets_the_step():
    """The zero kernel from rest: no velocity, no wave speed.  Here g = 0 and the floor accelerates
    upward at A from t = 0 (no velocity jump), so the body force in the floor frame is -A.  The
    step is the one of falling one cell, cfl Δx / √(Δx A), not one step to the next save (under
    gravity, 0.3 s in one step ended at u = −6.8e5 m/s; the fallback then knew only g, and with
    g = 0 still took that one step); the mass centre follows -A t²/2."""
    from bsrflow.physics.kernels import zero_kernel
    from bsrflow.physics.motion import AppliedMotion

    grid = Grid1D(0.0, 1.0, 400, "floor", "vacuum")
    rho = np.where((grid.x > 0.5) & (grid.x < 0.7), 0.5, 0.0)
    motion = AppliedMotion(_constant_floor_acceleration, [4.0])
    sim = Simulation(BSRModel(kernel=zero_kernel(), gravity=0.0, motion=motion), grid, Scheme.preset("seed"))
    res = sim.run(np.zeros(grid.n_cells), rho, 0.3)
    centre = (res.rho[-1] * grid.x).sum() / res.rho[-1].sum()
    assert res.steps > 100
    assert centre == pytest.approx(0.6 - 0.5 * 4.0 * 0.3 ** 2, abs=2e-3)
    assert np.abs(res.u[-1]).max() < 2.0


def _divides_at_zero(z, u_here, u_there, p):
    return p[0] * z / np.abs(z)


def _python_if(z, u_here, u_there, p):
    if z > 0:
        return -p[0] * z
    return p[0] * z


def _imports_inside(z, u_here, u_there, p):
    import math as m
    return m.erf(z)


@pytest.mark.parametrize("fn, match", [
    (_divides_at_zero, r"divides by zero at z = 0"),
    (_python_if, r"must also work on arrays .*truth value"),
    (_imports_inside, r"cannot be compiled for the time loop"),
])
def test_a_kernel_function_the_loop_cannot_run_is_refused_in_one_line(fn, match):
    from bsrflow.physics.kernels import Kernel

    with pytest.raises(ValueError, match=f"^kernel fn {fn.__name__}.*{match}") as err:
        Kernel(fn, [1.0], 0.1)
    assert "\n" not in str(err.value)


def _two_values(t, p):
    return 0.0, 0.0


def _plain_motion(t, p):                       # no @numba.njit: AppliedMotion compiles it
    return 0.0, 0.0, p[0] * np.sin(t)


def test_motion_and_model_arguments_are_checked_in_one_line():
    from bsrflow.physics.kernels_nd import walton_braun_nd
    from bsrflow.physics.motion import AppliedMotion, HalfSineTaps, SinusoidalVibration

    assert AppliedMotion(_plain_motion, [2.0]).state(0.5)[2] == pytest.approx(2 * math.sin(0.5))
    cases = [
        (lambda: AppliedMotion(None, [0.0]), r"^motion fn = None is not a function"),
        (lambda: AppliedMotion(_two_values, [0.0]), r"^motion fn _two_values\(t, p\) must .*returned 2 values"),
        (lambda: AppliedMotion(_plain_motion, [math.nan]), r"^motion params = \[nan\] must be finite"),
        (lambda: AppliedMotion(_plain_motion, [0.0], [0.05]), r"^motion jumps: 0.05 is not a \(time"),
        (lambda: AppliedMotion(_plain_motion, [0.0], [(math.nan, 1.0)]), r"^motion jumps: \(nan, 1.0\) must be finite"),
        (lambda: BSRModel(kernel=walton_braun_nd(1e3, 0.1, 0.05)), r"^kernel = KernelND must be .*use BSRModelND"),
        (lambda: BSRModel(kernel=_plain_motion), r"^kernel = _plain_motion must be .*Kernel\(fn, params, radius\)"),
        (lambda: BSRModel(motion=HalfSineTaps), r"^motion = HalfSineTaps must be an AppliedMotion \(call it"),
        (lambda: HalfSineTaps(0.01, 1e9), r"^frequency = 1000000000.0 is outside the valid range \[0.001, 10000\] Hz"),
        (lambda: SinusoidalVibration(0.01, 0.0), r"^frequency = 0.0 is outside the valid range \[0.001, 10000\] Hz"),
        (lambda: BSRModel(gravity="9.81"), r"^gravity = '9.81' must be a number"),
    ]
    for make, match in cases:
        with pytest.raises(ValueError, match=match) as err:
            make()
        assert "\n" not in str(err.value)


def test_review_findings_on_wrapping_user_functions():
    """A plain motion function is compiled once (the time loop's cache is keyed on the compiled
    object: a new one per AppliedMotion recompiled the loop for every amplitude of a sweep); an
    object numba cannot take is one line; the n-D kernel follows fn and checks its params."""
    import dataclasses
    import functools

    from bsrflow.physics.kernels import Kernel
    from bsrflow.physics.kernels_nd import KernelND, walton_braun_nd
    from bsrflow.physics.motion import AppliedMotion

    a, b = AppliedMotion(_plain_motion, [1.0]), AppliedMotion(_plain_motion, [2.0])
    assert a.fn is b.fn
    with pytest.raises(ValueError, match=r"^motion fn .* cannot be compiled by numba"):
        AppliedMotion(functools.partial(_plain_motion, p=[1.0]), [0.0])
    with pytest.raises(ValueError, match=r"^kernel fn .* cannot be compiled by numba"):
        Kernel(functools.partial(_no_interaction, p=[1.0]), [1.0], 0.1)
    with pytest.raises(ValueError, match=r"^kernel fn = 3 is not a function"):
        Kernel(_no_interaction, [1.0], 0.1).fn = 3

    def soft(z, a, b, p):
        return 0.0 * z[0], 0.0 * z[1], 0.0 * z[2]

    replaced = dataclasses.replace(walton_braun_nd(1e3, 0.1, 0.05), fn=soft)
    changed = walton_braun_nd(1e3, 0.1, 0.05)
    changed.fn = soft
    assert replaced.compiled.py_func is soft and changed.compiled.py_func is soft
    with pytest.raises(ValueError, match=r"^kernel params = \[nan\] must be finite"):
        KernelND(soft, [math.nan], 0.05)


def test_a_kernel_declaring_a_wave_speed_below_its_sound_speed_is_refused():
    """A Kernel subclass may override its wave-speed bound; one below the sound speed √(κρ) of its
    own Θ would let the CFL step outrun the waves, so the solver refuses it in one line.  A bound
    above it (a stricter step) is taken."""
    import dataclasses

    from bsrflow.physics.interaction import constant_wave_speed
    from bsrflow.physics.kernels import walton_braun

    @dataclasses.dataclass(eq=False)
    class Slow(type(walton_braun(1e3, 0.1, 0.05))):
        speed: float = 0.0

        def compiled_wave_speed(self):
            return constant_wave_speed, np.array([self.speed])

    base = walton_braun(1e3, 0.1, 0.05)
    grid = Grid1D(0.0, 1.0, 200, "floor", "vacuum")
    sound = math.sqrt(base.stiffness_moment() * 1000.0)
    rho = np.where(grid.x < 0.3, 1000.0, 0.0)
    slow = Slow(base.fn, base.params, base.radius, name="slow", speed=0.5 * sound)
    with pytest.raises(ValueError, match=r"^kernel 'slow': its wave-speed bound c\(ρ = 1000 kg/m, the initial state's "
                                         r"largest density\) = .* is below its linear sound speed") as err:
        Simulation(BSRModel(kernel=slow), grid, Scheme.preset("seed")).run(np.zeros(grid.n_cells), rho, 0.01)
    assert "\n" not in str(err.value)
    fast = Slow(base.fn, base.params, base.radius, name="fast", speed=2.0 * sound)
    from bsrflow.numerics.solver import _check_declared_bound
    assert _check_declared_bound(fast, base.stiffness_moment(), *fast.compiled_wave_speed(), 1000.0) is None  # taken
    exact = Slow(base.fn, base.params, base.radius, name="exact", speed=sound * (1.0 - 2e-7))  # κ's quadrature error
    assert _check_declared_bound(exact, base.stiffness_moment(), *exact.compiled_wave_speed(), 1000.0) is None
