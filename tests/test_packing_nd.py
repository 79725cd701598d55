"""Issue #19: the packing continuum on 2-D / 3-D grids. The horizontally uniform state is the 1-D
formulation (the verify cases embedding_packing_2d / _3d: bit for bit), the compiled right-hand
side agrees with its NumPy twin to 1e-12 on a non-uniform state, mass is conserved and ρ >= 0
in a genuinely 2-D run, and bad input is refused in one line."""
import numpy as np
import pytest

from bsrflow.numerics import packing_reference as ref
from bsrflow.numerics.grid_nd import GridND
from bsrflow.numerics.packing_nd import (EulerianPackingND, PackingLawND, embedding_packing_error, fv_rhs_nd,
                                         run_packing_nd)
from bsrflow.physics.motion import HalfSineTaps

LAW = PackingLawND.for_spheres(5e4, 0.9, 0.005, 1200.0, 0.636, 5.39)


pytestmark = pytest.mark.usefixtures("one_numba_thread")


@pytest.mark.parametrize("dim, t_end", [(2, 0.04), (3, 0.02)])
def test_horizontally_uniform_packing_equals_the_1d_run(dim, t_end):
    err, parts = embedding_packing_error(dim, t_end=t_end, details=True)
    assert err <= 1e-10                     # the criterion
    assert err == 0.0                       # measured: bit for bit with the 1-D law's constants
    assert parts["horizontal_velocity_max"] == 0.0
    assert parts["steps_nd"] == parts["steps_1d"] > 1000


def _random_state(rng, shape3, to_the_lid=False):
    rc = LAW.close_packing_density
    q = np.zeros((5,) + shape3)
    q[0] = rc * rng.uniform(0.9, 1.02, shape3)
    if not to_the_lid:
        q[0][..., -3:] = 0.0                   # vacuum at the top
    q[0][..., -4] *= 0.3
    for c in (1, 2, 3):
        q[c] = q[0] * rng.normal(0.0, 0.2, shape3)
    q[4] = q[0] * LAW.diameter * rng.uniform(0.0, 0.03, shape3)
    return q


@pytest.mark.parametrize("to_the_lid", [False, True])
@pytest.mark.parametrize("dim", [2, 3])
def test_compiled_rhs_matches_numpy(dim, to_the_lid):
    """Also with material in the top cells, against the lid at the domain top (mirror ghosts)."""
    rng = np.random.default_rng(5 + dim)
    shape3 = (5, 1, 12) if dim == 2 else (4, 5, 12)
    q = _random_state(rng, shape3, to_the_lid)
    if dim == 2:
        q[2] = 0.0
    dq = np.zeros_like(q)
    args = (dim, 0.001, -9.81 + 3.0, LAW.diameter, LAW.m_eff, LAW.k1, LAW.k2, LAW.wave_speed(),
            1e-12 * LAW.close_packing_density)
    # the state has compaction faces (first order) and others (second order) along z
    r = np.where(q[0] > args[-1], q[0], 0.0)
    uz = np.where(q[0] > args[-1], q[3] / np.where(q[0] > 0, q[0], 1.0), 0.0)
    first = ref.compaction_face(r[..., :-1], uz[..., :-1], r[..., 1:], uz[..., 1:], LAW.diameter, LAW.m_eff)
    assert 0 < np.count_nonzero(first) < first.size
    fv_rhs_nd(q, dq, *args)
    want = ref.fv_rhs_nd(q, *args)
    scale = np.maximum(np.max(np.abs(want), axis=tuple(range(1, 4)), keepdims=True), 1e-300)
    assert np.max(np.abs(dq - want) / scale) <= 1e-12


def test_a_2d_run_conserves_mass_and_keeps_rho_non_negative():
    dx = 0.001
    grid = GridND((12, 40), dx, bc_lower="floor", bc_upper="vacuum", bc_horizontal="periodic")
    x, z = grid.mesh()
    rho0 = np.where(z < 0.012 + 0.003 * np.sin(2 * np.pi * x / (12 * dx)), LAW.close_packing_density, 0.0)
    motion = HalfSineTaps(0.001, 20.0, start=0.002)
    disc = EulerianPackingND(LAW, grid, motion, 9.81, rho0)
    ts, us, rs, _ = run_packing_nd(disc, 0.03, np.linspace(0.0, 0.03, 7))
    mass = rs.reshape(len(ts), -1).sum(axis=1)
    assert np.max(np.abs(mass - mass[0])) <= 1e-12 * mass[0]
    assert rs.min() >= 0.0 and np.all(np.isfinite(us))
    assert np.max(np.abs(us[:, 0])) > 0.0                    # genuinely 2-D: horizontal motion


def test_bad_input_is_refused_in_one_line():
    g = GridND((4, 10), 0.001, bc_lower="floor", bc_upper="vacuum", bc_horizontal="periodic")
    m = HalfSineTaps(0.001, 20.0)
    for kw, text in ((dict(cfl=0.3), "cfl = 0.3 is outside the valid range (0, 0.25]"),
                     (dict(rho0=-np.ones((4, 10))), "rho0 must be finite, >= 0")):
        args = dict(rho0=np.zeros((4, 10)))
        args.update(kw)
        with pytest.raises(ValueError, match=text.replace("(", r"\(").replace(")", r"\)").replace("[", r"\[")
                           .replace("]", r"\]")):
            EulerianPackingND(LAW, g, m, 9.81, **args)
    with pytest.raises(ValueError, match="periodic sides"):
        EulerianPackingND(LAW, GridND((4, 10), 0.001, bc_horizontal="wall"), m, 9.81, np.zeros((4, 10)))
    with pytest.raises(ValueError, match="restitution"):
        PackingLawND(1.0, 1.5, 0.005, 700.0)


def test_a_column_runs_the_1d_finite_volumes_bit_for_bit():
    """One API for 1, 2 and 3 dimensions: EulerianPackingND on a column (GridND of dim 1) runs
    the 1-D formulation's finite volumes and equals EulerianPacking bit for bit (a tap and a
    landing of the seed's column, the history included)."""
    from bsrflow.numerics.packing import run_packing
    from bsrflow.numerics.solver import save_schedule
    from bsrflow.physics.column import ColumnSetup

    s = ColumnSetup(kernel_name="packing", formulation="eulerian", n_spheres=4, points_per_diameter=4,
                    tap_start=0.005, t_end=0.12, save_every=0.01, cfl=0.4, range_over_d=0.0)
    disc1 = s.packing_discretisation()
    saves = save_schedule(0.0, s.t_end, s.save_every)
    r1 = run_packing(disc1, s.t_end, saves)
    g1 = disc1.grid
    grid = GridND((g1.n_cells,), g1.dx, bc_lower="floor", bc_upper="vacuum")
    rho0 = np.where(g1.x < s.n_spheres * s.diameter, disc1.law.close_packing_density, 0.0)
    disc = EulerianPackingND(PackingLawND.from_1d(disc1.law), grid, s.motion(), s.gravity, rho0, cfl=0.4)
    ts, us, rs, _ = run_packing_nd(disc, s.t_end, saves)
    np.testing.assert_array_equal(rs, r1.rho)
    np.testing.assert_array_equal(us[:, 0], r1.u)
    np.testing.assert_array_equal(disc.q, disc1.q)                    # the history too
    assert set(disc.fields) == {"rho", "momentum_z", "rho_delta_max"}
    assert disc.steps == disc1.steps and np.ptp(r1.u) > 0.1


@pytest.mark.parametrize("dim", [2, 3])
def test_compiled_step_matches_numpy_on_a_non_uniform_state(dim):
    """One step of the compiled n-D loop (fv_advance_nd: its time step, the three SSP-RK3 stages
    in increment form with the floor's acceleration at t, t + Δt, t + Δt/2, the post-step density
    floor and history update) against the same step written with NumPy around the NumPy
    right-hand side, on a state that varies along every axis (the horizontal directions
    included, which the embedding cases never exercise)."""
    from bsrflow.numerics.packing_nd import fv_advance_nd

    rng = np.random.default_rng(11 + dim)
    shape3 = (5, 1, 12) if dim == 2 else (4, 5, 12)
    q0 = _random_state(rng, shape3)
    if dim == 2:
        q0[2] = 0.0
    q0[0][..., -4] = 1e-9 * LAW.close_packing_density            # cells the density floor clears,
    q0[1:, ..., -4] = 0.0                                          # at rest (else |u| sets a tiny Δt)
    dx, cfl, g, t = 0.001, 0.2, 9.81, 0.0031
    d, m, k1, k2, c = LAW.diameter, LAW.m_eff, LAW.k1, LAW.k2, LAW.wave_speed()
    rho_tiny, rho_floor = 1e-12 * LAW.close_packing_density, 1e-6 * LAW.close_packing_density
    motion = HalfSineTaps(0.002, 20.0, start=0.0)

    q = q0.copy()
    counters = np.zeros(3, np.int64)
    work = np.empty((5,) + q.shape)
    box = np.array([shape3[0] * dx, shape3[1] * dx, shape3[2] * dx])
    t1 = fv_advance_nd(q, t, 1.0, dim, dx, cfl, c, d, m, k1, k2, rho_tiny, rho_floor, 1.0, motion.fn,
                       motion.params, g, counters, np.zeros((0, 3)), np.zeros(3), box, work, 1)
    assert counters[0] == 1 and counters[1] == 0

    r = q0[0]
    moving = r > rho_tiny
    umax = np.max(np.where(moving, (np.abs(q0[1]) + np.abs(q0[2]) + np.abs(q0[3])) / np.where(moving, r, 1.0), 0.0))
    dt = cfl * dx / (c + umax)
    assert t1 == t + dt and dt > 1e-7

    def L(state, time):
        return ref.fv_rhs_nd(state, dim, dx, -g - motion.state(time)[2], d, m, k1, k2, c, rho_tiny)

    inc1 = dt * L(q0, t)
    inc2 = dt * L(q0 + inc1, t + dt)
    want = q0 + ((inc1 + inc2) / 6.0 + (2.0 / 3.0) * (dt * L(q0 + 0.25 * (inc1 + inc2), t + 0.5 * dt)))
    r = want[0]
    cleared = (r >= 0.0) & (r < rho_floor)
    assert cleared.any()
    want[:, cleared] = 0.0
    keep = r >= rho_floor
    want[4][keep] = r[keep] * ref.history_update(d - m / r[keep], want[4][keep] / r[keep])
    scale = np.maximum(np.max(np.abs(want), axis=tuple(range(1, 4)), keepdims=True), 1e-300)
    assert np.max(np.abs(q - want) / scale) <= 1e-12
