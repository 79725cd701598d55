"""The compiled step equals the plain NumPy reference of the same formulas (1e-12 relative)."""
import numpy as np
import pytest

from bsrflow.numerics.grid import Grid1D
from bsrflow.numerics.reference import ReferenceScheme
from bsrflow.numerics.solver import Scheme, Simulation
from bsrflow.physics.kernels import walton_braun
from bsrflow.physics.model import BSRModel
from bsrflow.physics.motion import HalfSineTaps


def _damping(t, x, u, p):
    return -p[0] * u + p[1] * np.sin(x)


def _inflow(t, x, p):
    return p[0] + 0.0 * x + 0.1 * t, p[1] + 0.0 * x


def _model(bc):
    kernel = walton_braun(40.0, 0.2, 0.1)
    motion = HalfSineTaps(0.01, 10.0, start=0.0)
    return BSRModel(kernel=kernel, motion=motion, gravity=9.81, external=_damping,
                    external_params=[0.3, 0.5], boundary_values=_inflow, boundary_params=[0.2, 3.0])


CASES = [("periodic", "periodic"), ("floor", "vacuum"), ("mirror", "vacuum"), ("dirichlet", "dirichlet"),
         ("vacuum", "vacuum")]


def _relerr(a, b):
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


@pytest.mark.parametrize("bcs", CASES)
@pytest.mark.parametrize("stepper", ["euler", "heun", "kutta3", "rk4", "rk4_0.4_0.25"])
@pytest.mark.parametrize("filt, hyper, sel, k2", [(False, 0.0, 0.0, 0.0), (True, 0.0, 0.0, 0.0),
                                                  (False, 1 / 32, 0.0, 0.0), (False, 1 / 32, 0.02, 0.0),
                                                  (False, 1 / 32, 0.02, 0.5), (False, 0.0, 0.3, 1.0)])
def test_step_matches_reference(bcs, stepper, filt, hyper, sel, k2, rng):
    grid = Grid1D(0.0, 1.0, 60, *bcs)                     # radius 0.1 m = 6 cells
    # check_cfl=False: Euler and Heun without the moving average are unstable at every CFL
    # number; here a few steps are compared with the reference implementation, not run long
    sim = Simulation(_model(bcs), grid, Scheme(stepper=stepper, filter=filt, dt=1e-3, hyperdiffusion=hyper,
                                               selective_filter=sel, sensor_dissipation=k2, check_cfl=False))
    ref = ReferenceScheme(sim)
    if k2 > 0 and sel == 0.3:
        # a threshold that switches some faces on and leaves others off
        u0 = rng.normal(0.0, 0.5, grid.n_cells)
        up, rp = ref.pad(u0, rng.uniform(0.5, 5.0, grid.n_cells), 0.013)
        on = ref._faces_on(up, rp, sel, 1.0)
        assert 0 < on.sum() < on.size
    u = rng.normal(0.0, 0.5, grid.n_cells)
    rho = rng.uniform(0.5, 5.0, grid.n_cells)
    t0 = 0.013
    un, rn = ref.run_fixed(u.copy(), rho.copy(), t0, 1e-3, 3)
    uc, rc = u.copy(), rho.copy()
    t, steps, status, where, _ = sim.advance(uc, rc, t0, t0 + 3e-3)
    assert status == 0 and steps == 3
    assert _relerr(uc, un) < 1e-12
    assert _relerr(rc, rn) < 1e-12


@pytest.mark.parametrize("quadrature", ["trapezoid", "boole"])
def test_rhs_matches_reference(quadrature, rng):
    grid = Grid1D(0.0, 1.0, 80, "floor", "vacuum")          # radius 0.1 m = 8 cells
    sim = Simulation(_model(("floor", "vacuum")), grid, Scheme(quadrature=quadrature))
    ref = ReferenceScheme(sim)
    u = rng.normal(0.0, 0.5, grid.n_cells)
    rho = rng.uniform(0.0, 5.0, grid.n_cells)
    du_c, dr_c = sim.rhs(u, rho, 0.02)
    du_r, dr_r = ref.rhs(u, rho, 0.02)
    assert _relerr(du_c, du_r) < 1e-12
    assert _relerr(dr_c, dr_r) < 1e-12


@pytest.mark.parametrize("integrator", ["euler", "rk"])
def test_tracers_euler_and_rk_match_formula(integrator):
    """Tracers in a non-uniform flow, u = 0.3 + 0.1 sin 2πx on a periodic unit domain, 10 steps
    of Kutta's RK3 without the moving average, against NumPy: the fields' stages from the
    solver's right-hand side (tested above), the tracers' velocity by periodic linear
    interpolation (np.interp) of the start-of-step field (the seed's Euler) or of each stage's
    field at the stage's tracer position, combined with the tableau's weights (RK)."""
    grid = Grid1D(0.0, 1.0, 50, "periodic", "periodic")
    dt, steps = 0.01, 10
    sim = Simulation(BSRModel(), grid, Scheme(stepper="kutta3", filter=False, dt=dt, tracer_integrator=integrator))
    u0 = 0.3 + 0.1 * np.sin(2 * np.pi * grid.x)
    rho0 = 1.0 + 0.2 * np.cos(2 * np.pi * grid.x)
    x0 = np.array([0.2, 0.55, 0.97])
    uc, rc, xc = u0.copy(), rho0.copy(), x0.copy()
    sim.advance(uc, rc, 0.0, dt * steps, tracers=xc)

    A = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.0], [-1.0, 2.0, 0.0]])
    b, c = np.array([1 / 6, 2 / 3, 1 / 6]), np.array([0.0, 0.5, 1.0])
    u, rho, x = u0.copy(), rho0.copy(), x0.copy()
    for n in range(steps):
        t = n * dt
        ku, kr, kx = [], [], []
        for s in range(3):
            us = u + dt * sum(A[s, j] * ku[j] for j in range(s))
            rs = rho + dt * sum(A[s, j] * kr[j] for j in range(s))
            xs = x + dt * sum(A[s, j] * kx[j] for j in range(s))
            kx.append(np.interp(xs, grid.x, us, period=1.0))
            du, dr = sim.rhs(us, rs, t + c[s] * dt)
            ku.append(du)
            kr.append(dr)
        u = u + dt * sum(bj * k for bj, k in zip(b, ku))
        rho = rho + dt * sum(bj * k for bj, k in zip(b, kr))
        x = x + dt * (kx[0] if integrator == "euler" else sum(bj * k for bj, k in zip(b, kx)))
        x = x % 1.0
    assert _relerr(uc, u) < 1e-12
    assert _relerr(rc, rho) < 1e-12
    # (the two integrators' tracers differ by up to 5.3e-7 m here: the tolerance tells them apart)
    assert np.abs(xc - x).max() < 1e-13
    moved = (xc - x0 + 0.5) % 1.0 - 0.5                 # the flow is not uniform
    assert np.ptp(moved) > 0.01


def test_velocity_extension_matches_reference(rng):
    """Vacuum cells (ρ below the threshold) take the velocity of the nearest material cell."""
    grid = Grid1D(0.0, 1.0, 60, "floor", "vacuum")
    sim = Simulation(_model(("floor", "vacuum")), grid, Scheme(stepper="kutta3", filter=True, dt=1e-3),
                     vacuum_density=1.0)
    ref = ReferenceScheme(sim)
    u = rng.normal(0.0, 0.5, grid.n_cells)
    rho = rng.uniform(0.0, 3.0, grid.n_cells)
    rho[20:35] = 0.0                     # a gap in the material and vacuum cells above
    rho[50:] = 0.0
    un, rn = ref.run_fixed(u.copy(), rho.copy(), 0.0, 1e-3, 2)
    uc, rc = u.copy(), rho.copy()
    sim.advance(uc, rc, 0.0, 2e-3)
    assert _relerr(uc, un) < 1e-12
    assert _relerr(rc, rn) < 1e-12


@pytest.mark.parametrize("seed", range(6))
def test_positivity_fix_matches_numpy(seed):
    """compiled.make_positive against reference.make_positive_numpy (the same sequential
    redistribution written with NumPy windows): random states with 5–40 % negative cells, some
    with a negative total (a failed state, which the widest window cannot cover)."""
    from bsrflow.numerics.reference import make_positive_numpy
    rng = np.random.default_rng(seed)
    grid = Grid1D(0.0, 1.0, 60, "floor", "vacuum")
    sim = Simulation(_model(("floor", "vacuum")), grid, Scheme(positivity=True))
    rho = rng.uniform(0.0, 1.0, 80)
    negative = rng.uniform(size=80) < 0.05 + 0.07 * seed
    rho[negative] *= -(0.05 if seed < 5 else 20.0)            # seed 5: more deficit than mass
    ref = make_positive_numpy(rho)
    out = rho.copy()
    sim.core.make_positive(out)
    assert negative.any()
    assert np.max(np.abs(out - ref)) <= 1e-15 * np.abs(rho).max()
    assert out.min() >= 0.0
    if rho.sum() > 0:
        assert abs(out.sum() - rho.sum()) <= 1e-13 * np.abs(rho).sum()
    else:
        assert rho.sum() < 0 and np.all(out == 0.0)


@pytest.mark.parametrize("stepper", ["kutta3", "rk4"])
def test_step_with_positivity_matches_reference(stepper, rng):
    """Two steps with the positivity fix, the compiled loop against the NumPy reference step
    (its fix now make_positive_numpy, not the compiled function): a thin, ragged layer whose
    unfixed step dips below 0."""
    grid = Grid1D(0.0, 1.0, 60, "floor", "vacuum")
    scheme = Scheme(stepper=stepper, filter=False, dt=2e-3, positivity=True, check_cfl=False)
    sim = Simulation(_model(("floor", "vacuum")), grid, scheme)
    u = rng.normal(0.0, 0.5, grid.n_cells)
    rho = rng.uniform(0.0, 3.0, grid.n_cells) * (rng.uniform(size=grid.n_cells) < 0.5)
    plain = Simulation(_model(("floor", "vacuum")), grid,
                       Scheme(stepper=stepper, filter=False, dt=2e-3, check_cfl=False))
    up, rp = u.copy(), rho.copy()
    plain.advance(up, rp, 0.0, 2e-3)
    assert rp.min() < 0.0                                     # the fix has work to do
    un, rn = ReferenceScheme(sim).run_fixed(u.copy(), rho.copy(), 0.0, 2e-3, 2)
    uc, rc = u.copy(), rho.copy()
    sim.advance(uc, rc, 0.0, 4e-3)
    assert rc.min() >= 0.0
    assert _relerr(uc, un) < 1e-12
    assert _relerr(rc, rn) < 1e-12


def test_positivity_fix_conserves_mass(rng):
    grid = Grid1D(0.0, 1.0, 60, "floor", "vacuum")
    sim = Simulation(_model(("floor", "vacuum")), grid, Scheme(positivity=True))
    rho = rng.uniform(-0.2, 1.0, 200)
    total = rho.sum()
    sim.core.make_positive(rho)
    assert rho.min() >= 0.0
    assert abs(rho.sum() - total) < 1e-12 * np.abs(rho).sum()


@pytest.mark.parametrize("skip", [True, False])
def test_density_floor_matches_reference(skip, rng):
    """|ρ| below the floor is 0 after every step, in the compiled step and the reference alike."""
    grid = Grid1D(0.0, 1.0, 60, "floor", "vacuum")
    sim = Simulation(_model(("floor", "vacuum")), grid, Scheme(stepper="kutta3", filter=True, dt=1e-3),
                     vacuum_density=1.0, density_floor=1e-3, skip_vacuum=skip)
    ref = ReferenceScheme(sim)
    u = rng.normal(0.0, 0.5, grid.n_cells)
    rho = rng.uniform(0.0, 3.0, grid.n_cells)
    rho[30:40] = 10.0 ** rng.uniform(-8, -1, 10) * rng.choice([-1.0, 1.0], 10)    # debris, both signs
    rho[40:] = 0.0
    un, rn = ref.run_fixed(u.copy(), rho.copy(), 0.0, 1e-3, 2)
    uc, rc = u.copy(), rho.copy()
    sim.advance(uc, rc, 0.0, 2e-3)
    assert np.all((rc == 0.0) | (np.abs(rc) >= 1e-3))
    assert np.count_nonzero((rho != 0) & (np.abs(rho) < 1e-3)) >= 5          # there was debris to clear
    assert np.array_equal(rc == 0.0, rn == 0.0)
    assert _relerr(uc, un) < 1e-12
    assert _relerr(rc, rn) < 1e-12


@pytest.mark.parametrize("floor, vacuum", [(-1.0, 1.0), (1.0, 1.0), (np.nan, 1.0), (np.inf, 0.0)])
def test_density_floor_out_of_range_is_a_clear_error(floor, vacuum):
    grid = Grid1D(0.0, 1.0, 60, "floor", "vacuum")
    with pytest.raises(ValueError, match=r"density_floor = .* outside the valid range \[0, "):
        Simulation(_model(("floor", "vacuum")), grid, vacuum_density=vacuum, density_floor=floor)


def _core():
    grid = Grid1D(0.0, 1.0, 60, "floor", "vacuum")
    return Simulation(_model(("floor", "vacuum")), grid, Scheme.preset("seed")).core


def test_step_pieces_against_numpy():
    """The compiled loop's separate pieces (the stages' combination, the embedded error norm, the
    compression monitor, the state checks) against NumPy forms of the same formulas."""
    core = _core()
    rng = np.random.default_rng(4)
    s, N = 3, 50
    b, bhat = np.array([1 / 6, 1 / 6, 2 / 3]), np.array([0.5, 0.5, 0.0])
    ku, kr = rng.normal(size=(s, N)), rng.normal(size=(s, N))
    u, rho = rng.normal(size=N), rng.uniform(0.0, 2.0, N)
    dt, hi = 1e-3, 40
    # combine: y += Δt Σ b_j k_j below hi, tracers by the tableau, kept above the floor
    uc, rc, tr = u.copy(), rho.copy(), np.array([0.05, -0.001 + 0.0, 0.5])
    vt = rng.normal(size=(s, 3))
    tr_ref = np.maximum(tr + dt * (b @ vt), 0.0)
    core.combine(uc, rc, dt, b, ku, kr, hi, tr, 2, vt, 1, 0.0, 0.02)
    np.testing.assert_allclose(uc[:hi], u[:hi] + dt * (b @ ku)[:hi], rtol=1e-14, atol=1e-16)
    np.testing.assert_array_equal(uc[hi:], u[hi:])
    np.testing.assert_allclose(rc[:hi], rho[:hi] + dt * (b @ kr)[:hi], rtol=1e-14, atol=1e-16)
    np.testing.assert_allclose(tr, tr_ref, rtol=1e-14, atol=1e-16)
    # on a periodic grid (mode 2) the tracers are wrapped into [0, N dx) instead
    trp = np.array([0.05, -0.001, 1.05])
    core.combine(u.copy(), rho.copy(), dt, b, ku, kr, hi, trp, 2, vt, 2, 0.0, 0.02)
    np.testing.assert_allclose(trp, np.mod(np.array([0.05, -0.001, 1.05]) + dt * (b @ vt), N * 0.02),
                               rtol=1e-12, atol=1e-15)
    # error norm, vacuum cells' velocity error not counted
    thr = 0.3
    eu = np.abs(dt * ((b - bhat) @ ku)) / (1e-6 + 1e-3 * np.abs(u))
    eu[rho < thr] = 0.0
    er = np.abs(dt * ((b - bhat) @ kr)) / (1e-7 + 1e-3 * np.abs(rho))
    ref = max(eu[:hi].max(), er[:hi].max())
    assert core.error_norm(u, rho, dt, b, bhat, ku, kr, hi, 1e-6, 1e-7, 1e-3, thr) == pytest.approx(ref, rel=1e-14)
    # compression monitor
    comp = -(u[2:] - u[:-2]) / (2 * 0.01) * dt
    worst, where = core.compression_monitor(u, dt, 0.01, N)
    assert worst == pytest.approx(max(comp.max(), 0.0), rel=1e-14) and where == int(np.argmax(comp)) + 1
    # state checks: non-finite, above rho_max, material at a vacuum top, fine
    assert core.check_state(u, rho, N, 0.0, 0.0, 2, 3) == (0, -1)
    bad = u.copy()
    bad[7] = np.nan
    assert core.check_state(bad, rho, N, 0.0, 0.0, 2, 3) == (1, 7)
    assert core.check_state(u, rho, N, 1.5, 0.0, 2, 3)[0] == 2
    top = rho.copy()
    top[-1] = 1.0
    assert core.check_state(u, top, N, 0.0, 1e-3, 2, 3) == (5, N - 4 + int(np.argmax(top[-4:] > 1e-3)))
