"""The 2-D / 3-D solver: embedding of the 1-D solver, conservation, symmetry, compiled vs NumPy
reference, determinism across thread counts, scenarios.

All runs use the Walton-Braun kernel and the half-sine tap motion (one compile of the n-D core;
the vibrated-box scenario adds one small recompile of the step loop)."""
import numba
import numpy as np
import pytest

from bsrflow.numerics.grid_nd import GridND, ball_quadrature, ball_quadrature_accuracy
from bsrflow.numerics.solver import Scheme
from bsrflow.numerics.solver_nd import (ReferenceND, SimulationND, embedding_error, to_internal,
                                        verify_cases)
from bsrflow.physics.kernels_nd import BSRModelND, KernelND, walton_braun_nd
from bsrflow.physics.motion import HalfSineTaps
from bsrflow.physics.scenarios_nd import TappedLayer, VibratedBox, resting_profile, run_scenario

DX = 0.004
W = 2
LAM = 2e8            # strong enough for a sound speed of order 1 m/s at ρ ~ 1e3 kg/m^n


@pytest.fixture(autouse=True, scope="module")
def _one_thread():
    """Run this module on one numba thread: the results are thread-count independent (tested
    below), and on a shared, oversubscribed machine OpenMP barriers make small parallel runs
    erratically slow."""
    n0 = numba.get_num_threads()
    numba.set_num_threads(1)
    yield
    numba.set_num_threads(n0)


def _model(eps=0.2, gravity=9.81):
    return BSRModelND(walton_braun_nd(LAM, eps, W * DX), HalfSineTaps(0.002, 10.0, start=0.004), gravity)


def _random_state(grid, rng, vacuum_top=True):
    shape = grid.shape
    rho = rng.uniform(200.0, 1000.0, shape)
    if vacuum_top and grid.bc_upper == "vacuum":
        rho[..., -3:] = 0.0
        rho[..., -4] *= 0.01
    u = rng.normal(0.0, 0.3, (grid.dim,) + shape)
    return u, rho


def _rel(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


# ---- embedding -----------------------------------------------------------------------------
def test_horizontally_uniform_state_evolves_as_the_1d_solver():
    """The verify cases: unfiltered, the seed's average (5.7), the tensor average; 2-D and 3-D."""
    cases = verify_cases()
    names = [c["name"] for c in cases]
    for dim in (2, 3):
        for suffix in ("", "_filter", "_tensor"):
            assert f"embedding_{dim}d{suffix}" in names
    for c in cases:
        assert set(c) >= {"name", "kind", "stepper", "filter", "resolutions", "errors", "observed_order"}
        assert c["kind"] == "exact" and len(c["errors"]) == 1
        assert c["errors"][0] <= 1e-10, c["name"]
        assert c["details"]["u_horizontal"] == 0.0      # horizontal velocity stays exactly zero


def test_embedding_with_velocity_extension_into_vacuum():
    assert embedding_error(3, filter=True, average="tensor", vacuum_density=1.0) <= 1e-10


# ---- quadrature ----------------------------------------------------------------------------
@pytest.mark.parametrize("dim", [2, 3])
def test_ball_table_symmetric_and_accurate(dim):
    o, c, w = ball_quadrature(dim, 3)
    key = {tuple(x): (tuple(cc), ww) for x, cc, ww in zip(o, c, w)}
    perms = [(1, 0, 2), (0, 2, 1)] if dim == 3 else [(1, 0)]
    for x, (cc, ww) in key.items():
        for s in np.ndindex(*(2,) * dim):
            sg = np.where(np.array(s) == 1, -1, 1)
            y = tuple(sg * np.array(x))
            assert key[y][1] == ww and tuple(sg * np.array(cc)) == key[y][0]   # bitwise
        for p in perms:
            y = tuple(np.array(x)[list(p)])
            assert key[y][1] == ww and tuple(np.array(cc)[list(p)]) == key[y][0]
    acc = ball_quadrature_accuracy(dim, 3)
    assert abs(acc["volume_rel_error"]) < 2e-6
    assert np.all(np.linalg.norm(c, axis=1) <= 3.0 + 1e-12)   # nodes inside the ball


# ---- conservation, symmetry ----------------------------------------------------------------
@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("average", ["na", "tensor"])
def test_mass_conserved_with_periodic_boundaries(dim, average, rng):
    shape = (7, 6, 8) if dim == 3 else (9, 8)
    grid = GridND(shape, DX, bc_horizontal="periodic", bc_lower="periodic", bc_upper="periodic")
    sim = SimulationND(_model(), grid, Scheme.preset("seed"), average=average)
    u, rho = _random_state(grid, rng)
    res = sim.run(u, rho, 0.01, save_every=0.005)
    m = res.mass()
    assert res.steps > 5
    assert np.max(np.abs(m - m[0])) / m[0] < 1e-13


def test_mass_conserved_with_walls_and_floor(rng):
    """Two steps (each stage and the average widen the support by one cell), so nothing reaches
    the vacuum top, where mass may leave by design."""
    grid = GridND((6, 5, 16), DX, bc_horizontal="wall", bc_lower="floor", bc_upper="vacuum")
    sim = SimulationND(_model(), grid, Scheme.preset("seed", dt=2e-4))
    u, rho = _random_state(grid, rng)
    rho[..., 7:] = 0.0
    res = sim.run(u, rho, 4e-4)
    m = res.mass()
    assert res.steps == 2 and res.rho[-1][..., -1].max() == 0.0
    assert abs(m[-1] - m[0]) / m[0] < 1e-14


def _rotate(u, rho):
    """Rotation by +90° about the vertical: position (x, y) -> (-y, x), u -> R u."""
    rot = lambda a: np.rot90(a, 1, axes=(0, 1))  # noqa: E731
    return np.stack([rot(-u[1]), rot(u[0]), rot(u[2])]), rot(rho)


def _reflect(u, rho):
    """Reflection x -> -x."""
    return np.stack([-u[0][::-1]] + [c[::-1] for c in u[1:]]), rho[::-1]


@pytest.mark.parametrize("sides", ["periodic", "wall"])
def test_rotation_and_reflection_commute_with_the_solver(sides, rng):
    grid = GridND((6, 6, 10), DX, bc_horizontal=sides, bc_lower="floor", bc_upper="vacuum")
    sim = SimulationND(_model(), grid, Scheme.preset("seed"))
    u, rho = _random_state(grid, rng)
    t_end = 0.006
    base = sim.run(u, rho, t_end)
    ua, ra = base.u[-1], base.rho[-1]
    for op in (_rotate, _reflect):
        ub0, rb0 = op(u, rho)
        res = sim.run(ub0, rb0, t_end)
        ue, re = op(ua, ra)
        assert _rel(res.u[-1], ue) < 1e-12 and _rel(res.rho[-1], re) < 1e-12


def test_reflection_2d(rng):
    grid = GridND((8, 10), DX, bc_horizontal="wall", bc_lower="floor", bc_upper="vacuum")
    sim = SimulationND(_model(), grid, Scheme.preset("seed"))
    u, rho = _random_state(grid, rng)
    a = sim.run(u, rho, 0.006)
    b = sim.run(*_reflect(u, rho), 0.006)
    ue, re = _reflect(a.u[-1], a.rho[-1])
    assert _rel(b.u[-1], ue) < 1e-12 and _rel(b.rho[-1], re) < 1e-12


# ---- compiled vs reference -----------------------------------------------------------------
GRIDS = [
    ((9, 10), dict(bc_horizontal="periodic", bc_lower="floor", bc_upper="vacuum")),
    ((7, 6, 9), dict(bc_horizontal="wall", bc_lower="floor", bc_upper="vacuum")),
    ((6, 7, 8), dict(bc_horizontal=("periodic", "wall"), bc_lower="mirror", bc_upper="vacuum")),
    ((5, 6, 7), dict(bc_horizontal="periodic", bc_lower="periodic", bc_upper="periodic")),
]


@pytest.mark.parametrize("shape, bcs", GRIDS)
def test_rhs_matches_numpy_reference(shape, bcs, rng):
    grid = GridND(shape, DX, **bcs)
    sim = SimulationND(_model(), grid)
    ref = ReferenceND(sim)
    u, rho = _random_state(grid, rng)
    du, dr = sim.rhs(u, rho, 0.007)
    du_r, dr_r = ref.rhs(u, rho, 0.007)
    assert _rel(du, du_r) < 1e-12 and _rel(dr, dr_r) < 1e-12


@pytest.mark.parametrize("shape, bcs", GRIDS[:2])
@pytest.mark.parametrize("average, vac", [("na", 0.0), ("tensor", 300.0)])
def test_steps_match_numpy_reference(shape, bcs, average, vac, rng):
    grid = GridND(shape, DX, **bcs)
    sim = SimulationND(_model(), grid, Scheme(stepper="kutta3", filter=True, dt=2e-4), average=average,
                       vacuum_density=vac)
    u, rho = _random_state(grid, rng)
    (uc, rc), (ur, rr) = _three_steps(sim, u, rho)
    assert _rel(uc, ur) < 1e-12 and _rel(rc, rr) < 1e-12


def _three_steps(sim, u, rho, dt=2e-4, t0=0.001):
    """Three steps of Δt from t0 by the compiled loop and by the NumPy reference step:
    ((u, ρ) compiled, (u, ρ) reference) in the user layout."""
    grid = sim.grid
    ref = ReferenceND(sim)
    ur, rr = u.copy(), rho.copy()
    t = t0
    for _ in range(3):
        ur, rr = ref.step(ur, rr, t, dt)
        t += dt
    ui, ri = to_internal(grid, u, rho)
    ui, ri = ui.copy(), ri.copy()
    t1, steps, status, _, _ = sim.advance_internal(ui, ri, t0, t0 + 3 * dt)
    assert status == 0 and steps == 3
    uc = np.stack([ui[0][:, 0, :], ui[2][:, 0, :]]) if grid.dim == 2 else ui
    rc = ri[:, 0, :] if grid.dim == 2 else ri
    return (uc, rc), (ur, rr)


@pytest.mark.parametrize("shape, bcs", GRIDS[:2])
def test_density_floor_matches_numpy_reference(shape, bcs, rng):
    """The n-D density floor (issue #19: the 1-D solver's ``density_floor`` in n-D): |ρ| below it
    is 0 after every step, in the compiled loop as in the NumPy reference step."""
    grid = GridND(shape, DX, **bcs)
    floor = 1.0            # kg/m^n, against 200-1000 in the bulk: the thin top the average spreads
    sim = SimulationND(_model(), grid, Scheme(stepper="kutta3", filter=True, dt=2e-4), density_floor=floor)
    u, rho = _random_state(grid, rng)
    (uc, rc), (ur, rr) = _three_steps(sim, u, rho)
    assert _rel(uc, ur) < 1e-12 and _rel(rc, rr) < 1e-12
    assert np.array_equal(rc == 0.0, rr == 0.0)
    small = np.abs(rc[rc != 0.0])
    assert small.size and small.min() >= floor
    # the floor had work to do: without it these steps leave 0 < |ρ| < floor somewhere
    plain = SimulationND(_model(), grid, Scheme(stepper="kutta3", filter=True, dt=2e-4))
    (_, rp), _ = _three_steps(plain, u, rho)
    cleared = (rc == 0.0) & (rp != 0.0)
    assert cleared.any() and np.abs(rp[cleared]).max() < floor
    # the floor cleared cells that hold debris without it
    (_, r0), _ = _three_steps(SimulationND(_model(), grid, Scheme(stepper="kutta3", filter=True, dt=2e-4)), u, rho)
    assert np.count_nonzero(rc == 0.0) > np.count_nonzero(r0 == 0.0)


def test_density_floor_is_checked_and_reaches_the_column_solver():
    grid = GridND((9, 10), DX, bc_horizontal="periodic")
    with pytest.raises(ValueError, match=r"^density_floor = 5.0 is outside the valid range \[0, vacuum_density = 1.0\)"):
        SimulationND(_model(), grid, vacuum_density=1.0, density_floor=5.0)
    with pytest.raises(ValueError, match=r"^density_floor = -1.0 is outside the valid range \[0, inf\)"):
        SimulationND(_model(), grid, density_floor=-1.0)
    with pytest.raises(ValueError, match=r"^density_floor = None must be a number"):
        SimulationND(_model(), grid, density_floor=None)
    column = SimulationND(_model(), GridND((20,), DX), density_floor=1e-6)
    assert column._line.density_floor == 1e-6


def test_results_do_not_depend_on_the_thread_count(rng):
    grid = GridND((8, 7, 10), DX, bc_horizontal="wall", bc_lower="floor", bc_upper="vacuum")
    sim = SimulationND(_model(), grid, Scheme.preset("seed"))
    u, rho = _random_state(grid, rng)
    n0 = numba.get_num_threads()
    out = []
    try:
        for n in sorted({1, numba.config.NUMBA_NUM_THREADS}):
            numba.set_num_threads(n)
            r = sim.run(u, rho, 0.004)
            out.append((r.u[-1], r.rho[-1]))
    finally:
        numba.set_num_threads(n0)
    for uu, rr in out[1:]:
        assert np.array_equal(uu, out[0][0]) and np.array_equal(rr, out[0][1])


# ---- physics -------------------------------------------------------------------------------
def test_resting_layer_is_a_discrete_equilibrium():
    setup = TappedLayer(dim=3, surface_perturbation=0.0, box_width=0.024)
    grid = setup.grid()
    sim = SimulationND(setup.model(), grid)
    u, rho = setup.initial_state(grid)
    du, dr = sim.rhs(u, rho, 0.0)
    material = rho > 0
    assert np.max(np.abs(du[:, material])) < 1e-10 * setup.gravity
    assert np.max(np.abs(dr)) == 0.0
    prof = resting_profile(3, 2, setup.dx, setup.layer_cells, setup.gravity)
    assert np.all(np.diff(prof) < 0) and prof[-1] > 0     # decreasing, with a jump at the top


def test_density_bump_spreads_and_relative_motion_decays():
    """Repulsive kernel in 3-D (no gravity, periodic, unfiltered): a bump spreads (elastic
    kernel); with ε > 0 the kinetic energy of a compression-and-shear wave ends well below the
    elastic run's."""
    grid = GridND((10, 10, 10), DX, bc_horizontal="periodic", bc_lower="periodic", bc_upper="periodic")
    X = grid.mesh()
    c = [0.5 * 10 * DX] * 3
    r2 = sum((x - cc) ** 2 for x, cc in zip(X, c))
    rho0 = 2000.0 * (1.0 + 0.3 * np.exp(-r2 / (3 * DX) ** 2))
    scheme = Scheme.preset("seed", filter=False)
    elastic = SimulationND(_model(eps=0.0, gravity=0.0), grid, scheme)
    res = elastic.run(np.zeros((3,) + grid.shape), rho0, 0.01)
    assert res.rho[-1].max() < rho0.max() - 0.2 * (rho0.max() - 2000.0)
    assert res.rho[-1].min() > 0
    u0 = np.zeros((3,) + grid.shape)
    u0[0] = 0.2 * np.sin(2 * np.pi * X[2] / (10 * DX))      # shear: u_x varying with z
    u0[2] = 0.2 * np.sin(2 * np.pi * X[2] / (10 * DX))      # compression along z
    rho = np.full(grid.shape, 2000.0)
    ke0 = elastic.run(u0, rho, 0.03).kinetic_energy()
    ke1 = SimulationND(_model(eps=0.3, gravity=0.0), grid, scheme).run(u0, rho, 0.03).kinetic_energy()
    assert ke1[-1] < 0.8 * ke0[-1]


@pytest.fixture(scope="module")
def scenario_runs():
    return {cls.__name__: run_scenario(cls()) for cls in (TappedLayer, VibratedBox)}


@pytest.mark.parametrize("name", ["TappedLayer", "VibratedBox"])
def test_shipped_scenarios_run(name, scenario_runs):
    run = scenario_runs[name]
    setup = run.setup
    assert run.result.status == "ok" and run.result.t[-1] == pytest.approx(setup.t_end)
    assert run.relative_mass_drift < 1e-10
    assert np.all(np.isfinite(run.result.rho)) and np.all(np.isfinite(run.result.u))
    # small undershoots at receding free surfaces (central differences of ρu next to vacuum)
    assert run.min_density.min() > -0.01 * setup.bottom_density
    assert run.floor.max() > 0.5 * setup.amplitude        # the floor did move


@pytest.mark.parametrize("name", ["TappedLayer", "VibratedBox"])
def test_shipped_scenario_density_non_negative(name, scenario_runs):
    """With the column-wise positivity fix (the scenarios' default) ρ >= 0 everywhere, with the
    mass kept to round-off (test above)."""
    assert scenario_runs[name].min_density.min() >= 0.0


def test_without_the_positivity_fix_the_seed_scheme_dips_below_zero():
    """The fix is what keeps ρ >= 0: the seed's scheme as it is undershoots next to the receding
    free surface (about -0.3 % of the bottom density), with the same mass conservation."""
    run = run_scenario(TappedLayer(positivity=False))
    assert run.min_density.min() < 0.0
    assert run.min_density.min() > -0.01 * run.setup.bottom_density
    assert run.relative_mass_drift < 1e-10


def _make_positive_columns_reference(rho):
    """Plain NumPy/Python twin of compiled_nd.make_positive_columns (same formula, same order)."""
    rho = rho.copy()
    NX, NY, NZ = rho.shape
    for i in range(NX):
        for j in range(NY):
            col = rho[i, j]
            for k in range(NZ):
                if col[k] < 0.0:
                    deficit = -col[k]
                    col[k] = 0.0
                    for w in range(1, NZ):
                        sl = slice(max(0, k - w), min(NZ, k + w + 1))
                        pos = col[sl] > 0.0
                        avail = float(np.sum(col[sl][pos])) if pos.any() else 0.0
                        if avail >= deficit or w == NZ - 1:
                            f = min(deficit / avail, 1.0) if avail > 0.0 else 0.0
                            seg = col[sl]
                            seg[pos] -= f * seg[pos]
                            col[sl] = seg
                            break
    return rho


def test_column_positivity_fix_matches_numpy_and_keeps_each_column_mass():
    from bsrflow.numerics.compiled_nd import make_positive_columns
    rng = np.random.default_rng(7)
    rho = rng.uniform(0.0, 1.0, (4, 3, 12))
    rho[rng.uniform(size=rho.shape) < 0.2] *= -0.05
    ref = _make_positive_columns_reference(rho)
    out = rho.copy()
    make_positive_columns(out)
    assert np.max(np.abs(out - ref)) <= 1e-15
    assert out.min() >= 0.0
    assert np.max(np.abs(out.sum(axis=2) - rho.sum(axis=2))) <= 1e-14 * rho.sum(axis=2).max()


# ---- input validation ----------------------------------------------------------------------
def test_bad_inputs_give_clear_errors():
    with pytest.raises(ValueError, match=r"need 1 \(z\), 2 \(x, z\) or 3"):
        GridND((4, 4, 4, 4), DX)
    with pytest.raises(ValueError, match="bc_horizontal"):
        GridND((4,), DX, bc_horizontal="wall")          # a column has no horizontal axis
    with pytest.raises(ValueError, match="as_grid1d"):
        GridND((4, 4), DX).as_grid1d()
    with pytest.raises(ValueError, match="dx"):
        GridND((4, 4), -1.0)
    with pytest.raises(ValueError, match="bc_horizontal"):
        GridND((4, 4), DX, bc_horizontal="floor")
    with pytest.raises(ValueError, match="bc_lower"):
        GridND((4, 4), DX, bc_lower="wall")
    with pytest.raises(ValueError, match="dissipation"):
        walton_braun_nd(1.0, 1.5, 0.01)
    with pytest.raises(ValueError, match="radius"):
        KernelND(lambda z, a, b, p: z, [1.0], -1.0)
    with pytest.raises(ValueError, match="kernel radius"):
        SimulationND(BSRModelND(walton_braun_nd(1.0, 0.1, 2.5 * DX)), GridND((8, 8), DX))
    with pytest.raises(ValueError, match="average"):
        SimulationND(_model(), GridND((8, 8), DX), average="box")
    sim = SimulationND(_model(), GridND((8, 8), DX))
    with pytest.raises(ValueError, match="rho0 has shape"):
        sim.run(np.zeros((2, 8, 8)), np.zeros((8, 7)), 0.1)
    with pytest.raises(ValueError, match="rho0 has negative"):
        sim.run(np.zeros((2, 8, 8)), -np.ones((8, 8)), 0.1)
    with pytest.raises(ValueError, match="layer_height"):
        TappedLayer(layer_height=0.004)


@pytest.mark.parametrize("integrator", ["euler", "rk"])
def test_tracers_of_a_horizontally_uniform_state_follow_the_1d_tracers(integrator):
    """n-D tracers (issue #19): in the embedding case of test above they move as the 1-D
    solver's tracers (its interpolation, its integrator), their horizontal positions stay put."""
    from bsrflow.numerics.grid import Grid1D
    from bsrflow.numerics.solver import Simulation
    from bsrflow.numerics.solver_nd import _embedding_setup, induced_kernel_1d
    from bsrflow.physics.model import BSRModel

    dim, nv, nh, W = 3, 40, 4, 3
    dx, kernel, motion, rho_z, u_z = _embedding_setup(dim, nv, nh, W)
    dt, t_end = 0.3 * dx / 3.0, 0.08
    grid = GridND((nh, nh, nv), dx, bc_horizontal="periodic", bc_lower="floor", bc_upper="vacuum")
    scheme = Scheme(stepper="kutta3", filter=False, dt=dt, tracer_integrator=integrator, name="embedding")
    sim = SimulationND(BSRModelND(kernel, motion, 9.81), grid, scheme)
    u0 = np.zeros((dim, nh, nh, nv))
    u0[-1] = np.broadcast_to(u_z, (nh, nh, nv))
    z0 = np.array([0.5, 3.3, 7.9, 15.2]) * dx
    tr0 = np.column_stack([np.array([0.3, 1.7, 2.2, 3.9]) * dx, np.array([3.1, 0.2, 2.5, 1.0]) * dx, z0])
    res = sim.run(u0, np.broadcast_to(rho_z, (nh, nh, nv)).copy(), t_end, save_times=[0.0, 0.04, t_end],
                  tracers=tr0)
    sim1 = Simulation(BSRModel(kernel=induced_kernel_1d(kernel, dim, dx), motion=motion, gravity=9.81),
                      Grid1D(0.0, nv * dx, nv, "floor", "vacuum"), scheme)
    r1 = sim1.run(u_z, rho_z, t_end, save_times=[0.0, 0.04, t_end], tracers=z0)
    np.testing.assert_array_equal(res.tracers[:, :, :2], np.broadcast_to(tr0[:, :2], res.tracers[:, :, :2].shape))
    moved = np.max(np.abs(r1.tracers[-1] - z0))
    assert moved > 0.1 * dx
    assert np.max(np.abs(res.tracers[:, :, 2] - r1.tracers)) <= 1e-12 * moved


def test_tracers_are_checked_and_restart_bit_for_bit_from_a_checkpoint_event():
    sim = SimulationND(_model(), GridND((8, 8), DX))
    u0, rho = np.zeros((2, 8, 8)), np.full((8, 8), 500.0)
    with pytest.raises(ValueError, match=r"tracers must be a finite array of shape \(n, 2\)"):
        sim.run(u0, rho, 0.01, tracers=np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"tracers\[1\] .* outside the domain"):
        sim.run(u0, rho, 0.01, tracers=[[DX, DX], [DX, 9 * DX]])
    # a tapped layer with tracers: the state handed to the checkpoint event (tracers included),
    # restarted, continues bit for bit, as in 1-D
    setup = TappedLayer(dim=2, t_end=0.09, settle_time=0.01, save_every=0.01)
    grid = setup.grid()
    sim = SimulationND(setup.model(), grid, Scheme.preset("seed", positivity=True))
    u0, rho0 = setup.initial_state(grid)
    tr0 = np.column_stack([np.full(3, 0.5 * grid.upper[0]), np.array([0.2, 0.5, 0.8]) * setup.layer_height])
    saves = np.round(np.arange(0.0, setup.t_end + 1e-12, setup.save_every), 12)
    kept, seen = {}, []
    t_ck = 0.047
    full = sim.run(u0, rho0, setup.t_end, save_times=saves, extra_event_times=[t_ck], tracers=tr0,
                   observers=[lambda t, u, r, tr: seen.append(tr.copy())],
                   on_event=lambda t, u, r, tr, steps: kept.update(t=t, u=u.copy(), rho=r.copy(), tr=tr.copy()))
    assert kept["t"] == t_ck and kept["tr"].shape == (3, 2)
    np.testing.assert_array_equal(np.array(seen), full.tracers)
    assert np.max(np.abs(full.tracers[-1, :, 1] - tr0[:, 1])) > 0.05 * DX      # they moved
    rest = sim.run(kept["u"], kept["rho"], setup.t_end, t_start=t_ck, save_times=saves[saves >= t_ck],
                   restart=True, tracers=kept["tr"])
    np.testing.assert_array_equal(rest.tracers, full.tracers[full.t >= t_ck])
    np.testing.assert_array_equal(rest.rho, full.rho[full.t >= t_ck])


def test_a_column_runs_through_the_same_api_as_the_1d_solver_bit_for_bit():
    """One API for 1, 2 and 3 dimensions (issue #19): SimulationND on a 1-D GridND runs the 1-D
    discretisation with the kernel's restriction to the line (Walton–Braun's registered one keeps
    the fast integral) and gives the 1-D solver's results bit for bit, tracers and checkpoint
    events included; every scheme option is available there ('accurate' too)."""
    from bsrflow.numerics.grid import Grid1D
    from bsrflow.numerics.solver import Simulation
    from bsrflow.physics.kernels import walton_braun
    from bsrflow.physics.model import BSRModel

    lam, eps, R, n = 1e6, 0.105, 0.02, 200
    dx = R / 10
    motion = HalfSineTaps(0.01, 10.0, start=0.02)
    grid = GridND((n,), dx, bc_lower="floor", bc_upper="vacuum")
    z = grid.z
    rho0 = np.where(z < 0.1, 0.4 * (1.0 - 0.5 * z / 0.1), 0.0)
    tr0 = np.array([0.01, 0.05, 0.09])
    for preset in ("seed", "accurate"):
        scheme = Scheme.preset(preset)
        kw = dict(vacuum_density=1e-6, top_tolerance=1e-3)
        sim = SimulationND(BSRModelND(walton_braun_nd(lam, eps, R), motion, 9.81), grid, scheme, **kw)
        assert sim._line.integral_name == "walton_braun_integral"          # the fast path
        one = Simulation(BSRModel(kernel=walton_braun(lam, eps, R), motion=motion, gravity=9.81),
                         Grid1D(0.0, n * dx, n, "floor", "vacuum"), scheme, **kw)
        seen, kept = [], {}
        res = sim.run(np.zeros((1, n)), rho0, 0.12, save_every=0.02, tracers=tr0[:, None],
                      observers=[lambda t, u, r, tr: seen.append((u.shape, tr.shape))],
                      extra_event_times=[0.07],
                      on_event=lambda t, u, r, tr, st: kept.update(t=t, u=u.copy(), r=r.copy(), tr=tr.copy()))
        ref = one.run(np.zeros(n), rho0, 0.12, save_every=0.02, tracers=tr0, extra_event_times=[0.07],
                      on_event=lambda *a: None)
        np.testing.assert_array_equal(res.rho, ref.rho)
        np.testing.assert_array_equal(res.u[:, 0], ref.u)
        np.testing.assert_array_equal(res.tracers[:, :, 0], ref.tracers)
        assert res.steps == ref.steps and seen[0] == ((1, n), (3, 1)) and kept["tr"].shape == (3, 1)
        assert np.ptp(res.tracers[:, 2, 0]) > dx                 # the tap moved them
        rest = sim.run(kept["u"], kept["r"], 0.12, t_start=0.07, save_times=res.t[res.t >= 0.07],
                       tracers=kept["tr"], restart=True)
        np.testing.assert_array_equal(rest.rho, res.rho[res.t >= 0.07])
        du, dr = sim.rhs(np.zeros((1, n)), rho0, 0.03)
        du1, dr1 = one.rhs(np.zeros(n), rho0, 0.03)
        np.testing.assert_array_equal(du[0], du1)
        np.testing.assert_array_equal(dr, dr1)
    with pytest.raises(ValueError, match="SimulationND.advance_internal is a piece of the 2-D / 3-D"):
        sim.advance_internal(None, None, 0.0, 1.0)
    with pytest.raises(ValueError, match="ReferenceND: a column"):
        ReferenceND(sim)
    # a user kernel goes through its generic restriction (the direct sum)
    user = KernelND(lambda z, a, b, p: _wb_like(z, a, b, p), [lam, eps, R], R, name="user")
    sim_u = SimulationND(BSRModelND(user, motion, 9.81), grid)
    assert sim_u._line.integral_name == "integral"
    with pytest.raises(ValueError, match=r"u0 has shape \(2, 200\), expected \(1, 200\)"):
        sim_u.run(np.zeros((2, n)), rho0, 0.01)


@numba.njit
def _wb_like(z, a, b, p):          # compiled: a kernel's function calls only compiled functions
    r = np.sqrt(z[0] * z[0] + z[1] * z[1] + z[2] * z[2])
    dot = z[0] * (b[0] - a[0]) + z[1] * (b[1] - a[1]) + z[2] * (b[2] - a[2])
    s = -p[0] * (p[2] - r) / (r + (r == 0.0)) * (1.0 - p[1] * np.sign(dot))
    return s * z[0], s * z[1], s * z[2]


def _carried_tracer(shape, velocity, t_end, tracer, integrator, **bcs):
    """A tracer in a uniform flow (no interaction, no gravity) on a grid of cell 1 cm."""
    grid = GridND(shape, 0.01, **bcs)
    sim = SimulationND(BSRModelND(walton_braun_nd(1e-12, 0.0, 0.02), gravity=0.0), grid,
                       Scheme(stepper="kutta3", filter=False, dt=1e-3, tracer_integrator=integrator, check_cfl=False))
    u = np.zeros((grid.dim,) + shape)
    for axis, v in enumerate(velocity):
        u[axis] = v
    return sim.run(u, np.ones(shape), t_end, tracers=[tracer], save_times=[0.0, t_end]).tracers[-1][0]


@pytest.mark.parametrize("integrator", ["euler", "rk"])
def test_tracers_wrap_on_every_periodic_axis(integrator):
    """Each periodic axis wraps its tracers, whatever the other axes are: x periodic beside a
    y wall (it was clamped to the wall-like edge), and a periodic vertical axis (it left the box)."""
    x, y, z = _carried_tracer((8, 8, 8), (1.0, 0.0, 0.0), 0.1, [0.05, 0.04, 0.04], integrator,
                              bc_horizontal=("periodic", "wall"))
    assert x == pytest.approx((0.05 + 0.1) % 0.08, abs=1e-12) and (y, z) == pytest.approx((0.04, 0.04), abs=1e-12)
    x, z = _carried_tracer((8, 8), (1.0, 0.5), 0.1, [0.05, 0.05], integrator, bc_lower="periodic",
                           bc_upper="periodic")
    assert (x, z) == pytest.approx(((0.05 + 0.1) % 0.08, (0.05 + 0.05) % 0.08), abs=1e-12)


def test_tracer_wraps_on_a_periodic_1d_grid():
    from bsrflow.numerics.grid import Grid1D
    from bsrflow.numerics.solver import Simulation
    from bsrflow.physics.kernels import walton_braun
    from bsrflow.physics.model import BSRModel

    grid = Grid1D(0.0, 0.08, 8, "periodic", "periodic")
    sim = Simulation(BSRModel(kernel=walton_braun(1e-12, 0.0, 0.02)), grid,
                     Scheme(stepper="kutta3", filter=False, dt=1e-3, check_cfl=False))
    res = sim.run(np.ones(8), np.ones(8), 0.2, tracers=[0.05], save_times=[0.0, 0.2])
    assert res.tracers[-1][0] == pytest.approx((0.05 + 0.2) % 0.08, abs=1e-12)


def _constant_floor_acceleration(t, p):        # ϑ = A t²/2: no jump, ϑ'' = A from t = 0
    return 0.5 * p[0] * t * t, p[0] * t, p[0]


def test_at_rest_without_a_wave_speed_the_body_force_sets_the_step():
    """A layer at rest under no interaction (λ = 0: no wave speed) with g = 0 and a floor
    accelerating at A from t = 0: the step is the one of falling one cell under the body force
    -(g + ϑ''), cfl Δx / √(Δx A), and the layer falls as -A t²/2 (the fallback knew only g and,
    with g = 0, took one step to the end)."""
    from bsrflow.physics.kernels_nd import _walton_braun_nd
    from bsrflow.physics.motion import AppliedMotion

    grid = GridND((4, 4, 100), 0.01, bc_horizontal="periodic", bc_lower="floor", bc_upper="vacuum")
    z = (np.arange(100) + 0.5) * 0.01
    rho = np.broadcast_to(np.where((z > 0.5) & (z < 0.7), 0.5, 0.0), grid.shape).copy()
    model = BSRModelND(KernelND(_walton_braun_nd, [0.0, 0.0, 0.02], 0.02), AppliedMotion(_constant_floor_acceleration, [4.0]), 0.0)
    res = SimulationND(model, grid, Scheme.preset("seed")).run(np.zeros((3,) + grid.shape), rho, 0.1)
    centre = float((res.rho[-1] * z).sum() / res.rho[-1].sum())
    assert res.steps >= 4                      # cfl Δx / √(Δx A) = 0.02 s at the start
    assert centre == pytest.approx(0.6 - 0.5 * 4.0 * 0.1 ** 2, abs=2e-3)


def test_a_kernel_nd_declaring_a_wave_speed_below_its_sound_speed_is_refused():
    """As in 1-D: a KernelND subclass whose declared bound is below √(n κ ρ) (κ the scheme's
    discrete moment) at the initial state's largest density is refused in one line before any
    step; the solver's own bound (the base class's) is taken."""
    import dataclasses

    from bsrflow.numerics.solver import _check_declared_bound
    from bsrflow.physics.interaction import constant_wave_speed

    @dataclasses.dataclass(eq=False)
    class Slow(KernelND):
        speed: float = 0.0

        def compiled_wave_speed(self, dim=3, moment=None):
            return constant_wave_speed, np.array([self.speed])

    base = walton_braun_nd(LAM, 0.2, W * DX)
    grid = GridND((4, 4, 12), DX, bc_horizontal="periodic", bc_lower="floor", bc_upper="vacuum")
    rho = np.zeros(grid.shape)
    rho[..., :6] = 1000.0
    slow = Slow(base.fn, base.params, base.radius, name="slow", speed=0.1)
    sim = SimulationND(BSRModelND(slow, HalfSineTaps(0.002, 10.0, start=0.004), 9.81), grid, Scheme.preset("seed"))
    with pytest.raises(ValueError, match=r"^kernel 'slow': its wave-speed bound c\(ρ = 1000 kg/m\^3, the initial "
                                         r"state's largest density\) = 0.1 m/s is below its linear sound speed") as err:
        sim.run(np.zeros((3,) + grid.shape), rho, 1e-3)
    assert "\n" not in str(err.value)
    own = SimulationND(_model(), grid, Scheme.preset("seed"))
    assert _check_declared_bound(base, 3 * own.kappa, own._wave_speed_fn, own.wave_speed_params, 1000.0) is None
