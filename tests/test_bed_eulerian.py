"""The vibrated bed's model on the Eulerian grid (bsrflow.numerics.bed_eulerian): the compiled
kernels against their NumPy twin, the horizontally uniform 2-D / 3-D bed against the column bit
for bit, mass, the bed at rest, refusals, and the agreement with the Lagrangian discretisation."""

import math

import numpy as np
import pytest

from bsrflow.numerics import bed_eulerian as B
from bsrflow.numerics import bed_eulerian_reference as R
from bsrflow.physics.granular_bed import BedSetup, constitutive_numpy


def _random_bed(shape, dx, par, seed=1):
    """A bed with dense, loose, dilute and empty cells, random velocities, temperatures and history."""
    rng = np.random.default_rng(seed)
    dim = 3 if shape[1] > 1 else (2 if shape[0] > 1 else 1)
    q = np.zeros((6,) + shape)
    z = (np.arange(shape[2]) + 0.5) * dx[2]
    prof = par["rho_c"] * (1.02 - 0.3 * np.clip((z - 0.02) / 0.03, 0, 1)) * (z < 0.05)
    q[0] = prof * (1 + 0.05 * rng.standard_normal(shape))
    q[0, ..., 30:] = 0.0
    q[0, ..., 28] = 1e-4 * par["rho_c"]
    for c in (1, 2, 3):
        q[c] = q[0] * 0.1 * rng.standard_normal(shape)
    if dim < 3:
        q[2] = 0.0
    if dim < 2:
        q[1] = 0.0
    q[4] = 1.5 * q[0] * 1e-3 * rng.random(shape)
    q[5] = q[0] * 1e-6 * rng.random(shape)
    return q, dim


def _params(s, dx):
    """The scheme's constants by name and as the kernels' array, the array in the kernels' order
    and the contact wave speed bound the setup's own (d√(k2/m) = √(K_eff d/(A e² ρ_c)))."""
    par = R.make_params(s, dx)
    arr, named = B.scheme_params(s)
    order = ("d", "m", "k1", "k2", "c_cap", "rho_tiny", "e", "rho_s", "phi_min", "e_w")
    assert arr.tolist() == [named[k] for k in order]
    assert named["c_cap"] == pytest.approx(s.contact_wave_speed(), rel=1e-14)
    assert named["k1"] == pytest.approx(s.layer_stiffness / s.area, rel=1e-15)
    return par, arr


@pytest.mark.parametrize("shape", [(1, 1, 40), (6, 1, 40), (5, 4, 40)])
def test_compiled_kernels_equal_the_numpy_twin(shape):
    s = BedSetup()
    dx = np.array([s.diameter / 4, s.diameter / 3, s.diameter / 4])
    par, arr = _params(s, dx)
    q, dim = _random_bed(shape, dx, par)
    ref, floor_ref = R.rhs_numpy(q, dim, dx, -9.81, par)
    dq = np.zeros_like(q)
    work = B.work_arrays(q.shape)
    floor = work[8]
    B.bed_rhs(q, dq, *work[3:8], floor, work[9], dim, dx, -9.81, arr, False)
    for c in range(6):
        scale = np.abs(ref[c]).max()
        if scale == 0.0:
            assert np.all(dq[c] == 0.0)
        else:
            assert np.abs(dq[c] - ref[c]).max() <= 1e-12 * scale, c
    assert np.abs(floor - floor_ref).max() <= 1e-12 * np.abs(floor_ref).max()
    assert floor.min() >= 0.0                                   # the floor never pulls
    dt, status, _ = B.bed_stable_dt(q, dim, dx, 0.4, arr, work[0], work[4])
    assert status == 0 and dt == pytest.approx(R.stable_dt_numpy(q, dim, dx, par), rel=1e-13)
    qb = q.copy()
    B.bed_post_step(qb, 1e-5, par["d"], par["m"], par["rho_s"], par["e_d"], par["rho_tiny"])
    assert np.abs(qb - R.post_step_numpy(q, 1e-5, par)).max() <= 1e-12 * np.abs(q).max()
    # the parallel passes: the serial numbers bit for bit
    dq_p = np.full_like(q, np.nan)
    work_p = B.work_arrays(q.shape)
    B.bed_rhs(q, dq_p, *work_p[3:8], work_p[8], work_p[9], dim, dx, -9.81, arr, True)
    assert np.array_equal(dq_p, dq) and np.array_equal(work_p[8], floor)


@pytest.mark.parametrize("shape", [(1, 1, 40), (6, 1, 40), (5, 4, 40)])
def test_one_compiled_step_equals_ssp_rk3_on_the_numpy_twin(shape):
    """One step of the compiled loop (bed_advance) against SSP-RK3 in Shu–Osher form written
    with NumPy around the twin's right-hand side (the floor's acceleration −g + aω² sin ωt at t,
    t + Δt, t + Δt/2), its time step and post-step pass; the floor impulse is the stages' mean
    floor stresses weighted 1/6, 1/6, 2/3."""
    s = BedSetup()
    dx = np.array([s.diameter / 4, s.diameter / 3, s.diameter / 4])
    par, arr = _params(s, dx)
    q0, dim = _random_bed(shape, dx, par, seed=5)
    g, amp, omega, t = 9.81, 1e-3, 2 * math.pi * 20.0, 0.0123
    q = q0.copy()
    counters = np.zeros(3, np.int64)
    t1, impulse = B.bed_advance(q, t, 1.0, dim, dx, 0.4, arr, g, amp, omega, True, par["e_d"],
                                B.work_arrays(q.shape), counters, 1, False, np.zeros((0, 3)),
                                dx * np.array(shape))
    assert counters[0] == 1 and counters[1] == 0
    dt = R.stable_dt_numpy(q0, dim, dx, par)
    assert t1 - t == pytest.approx(dt, rel=1e-13)
    dt = t1 - t                                            # the compiled step's own float

    def L(state, time):
        return R.rhs_numpy(state, dim, dx, -g + amp * omega ** 2 * math.sin(omega * time), par)

    k0, f0 = L(q0, t)
    q1 = q0 + dt * k0
    k1, f1 = L(q1, t + dt)
    q2 = 0.75 * q0 + 0.25 * (q1 + dt * k1)
    k2, f2 = L(q2, t + 0.5 * dt)
    want = R.post_step_numpy(q0 / 3.0 + (2.0 / 3.0) * (q2 + dt * k2), dt, par)
    for c in range(6):
        scale = np.abs(want[c]).max()
        assert np.abs(q[c] - want[c]).max() <= 1e-12 * scale if scale else np.all(q[c] == 0.0), c
    stress = dt * (f0.mean() / 6.0 + f1.mean() / 6.0 + (2.0 / 3.0) * f2.mean())
    assert impulse == pytest.approx(stress, rel=1e-12)


@pytest.mark.parametrize("shape", [(1, 1, 40), (6, 1, 40), (5, 4, 40)])
def test_time_step_bound_where_diffusion_binds(shape):
    """A hot bed with a dense / dilute interface (the conduction's face coefficient, the mean of a
    dense and a dilute cell's, acting on the dilute cell) and viscous cells at the floor and the
    lid: the compiled bound equals the twin's and is the diffusion limit (below the CFL bound);
    with the interface's dilute cells emptied below φ_min the bound grows."""
    s = BedSetup()
    dx = np.array([s.diameter / 4, s.diameter / 3, s.diameter / 4])
    par, arr = _params(s, dx)
    q, dim = _random_bed(shape, dx, par, seed=3)
    q[0, ..., 28] = 0.003 * par["rho_s"]                         # dilute, above φ_min
    q[0, ..., 39] = 0.01 * par["rho_s"]                          # material at the lid
    q[4] = 1.5 * q[0] * 0.3                                      # hot: θ = 0.3 m²/s²
    q[5] = 0.0
    work = B.work_arrays(q.shape)
    dt, status, _ = B.bed_stable_dt(q, dim, dx, 0.4, arr, work[0], work[4])
    assert status == 0 and dt == pytest.approx(R.stable_dt_numpy(q, dim, dx, par), rel=1e-13)
    cfl_only = dict(par, phi_min=2.0)                            # no transport anywhere: the CFL bound
    assert dt < 0.5 * R.stable_dt_numpy(q, dim, dx, cfl_only)
    q[0, ..., 28] = 0.0005 * par["rho_s"]                        # below φ_min: no face to the packing
    dt2, _, _ = B.bed_stable_dt(q, dim, dx, 0.4, arr, work[0], work[4])
    assert dt2 == pytest.approx(R.stable_dt_numpy(q, dim, dx, par), rel=1e-13) and dt2 > dt


def test_kinetic_sound_speed_is_the_isentropic_derivative():
    """c_k² = dp/dρ along the adiabat of E = (3/2)ρθ, (3/2)dθ = (p/ρ²)dρ, i.e. dθ/dρ = (2/3)θY/ρ
    with p = ρθY (a power law through the point with that slope), by a central difference."""
    e, rho_s = 0.9, 1200.0
    for phi, th in ((0.01, 1e-2), (0.3, 3e-3), (0.6, 1e-3)):
        y = float(constitutive_numpy(phi, th, rho_s, 0.005, e)["p"]) / (rho_s * phi * th)

        def p(ph):
            t = th * (ph / phi) ** (2.0 / 3.0 * y)
            return constitutive_numpy(ph, t, rho_s, 0.005, e)["p"]
        h = 1e-6 * phi
        c2 = (p(phi + h) - p(phi - h)) / (2 * h * rho_s)
        assert B.kinetic_sound_speed(phi, th, e) ** 2 == pytest.approx(float(c2), rel=1e-6)


def _column_prim(rho, uz, theta):
    """Primitives of a column (1, 1, n) with the given ρ, u_z and θ per cell (no history)."""
    r = np.asarray(rho, float)[None, None, :]
    z = np.zeros_like(r)
    return r, (z, z, np.asarray(uz, float) + z), np.asarray(theta, float) + z, z


def _kinetic_p(rho, theta, par):
    return float(constitutive_numpy(rho / par["rho_s"], theta, par["rho_s"], par["d"], par["e"])["p"])


@pytest.mark.parametrize("u", [0.0, 0.03, -0.03])
def test_vertical_faces_keep_a_contact_between_two_gases(u):
    """HLLC along z (since 2026-12-05, fourth session): two gases of the same pressure and velocity
    (below their sound speeds) but densities 2x apart (φ 0.2 and 0.4) meet at a face; the face's
    mass flux is the upwind side's ρu and its momentum flux ρu² + p, to round-off (HLLE's would
    carry more mass, −S_L S_R Δρ/(S_R − S_L) for the contact at rest: the smearing of the flying
    bed's bottom edge, docs/model.md).  Across x the flux stays HLLE's, which diffuses the same contact."""
    s = BedSetup()
    par = R.make_params(s, None)
    r1, r2, th1 = 0.2 * s.density, 0.4 * s.density, 2e-3
    p1 = _kinetic_p(r1, th1, par)
    th2 = th1 * p1 / _kinetic_p(r2, th1, par)           # p = ρθY(φ) is linear in θ
    assert _kinetic_p(r2, th2, par) == pytest.approx(p1, rel=1e-14)
    n = 8
    rho = np.where(np.arange(n) < 4, r1, r2)
    th = np.where(np.arange(n) < 4, th1, th2)
    f, uf = R.axis_fluxes_numpy(_column_prim(rho, u, th), 2, "wall", par)
    face = 4                                                   # between cells 3 and 4
    up = r1 if u >= 0.0 else r2
    assert f[R.RHO][0, 0, face] == pytest.approx(up * u, abs=1e-12 * r2)
    assert f[R.MZ][0, 0, face] == pytest.approx(up * u * u + p1, rel=1e-12)
    assert uf[0, 0, face] == pytest.approx(u, abs=1e-15)
    # the same contact across x (periodic, HLLE): mass crosses the resting contact
    zx = np.zeros((n, 1, 1))
    prim_x = (rho[:, None, None] + zx, (zx, zx, zx), th[:, None, None] + zx, zx)
    fx, _ = R.axis_fluxes_numpy(prim_x, 0, "periodic", par)
    assert abs(fx[R.RHO][0, 0, face]) > 1e-3 * r2


def test_a_bed_leaving_the_floor_sends_no_mass_into_the_gap():
    """A gas moving up from empty cells below it (u = 0.5 m/s, θ = 1e-4 m²/s²: its contact speed
    S* > 0) sends no mass down into them: the edge's face passes exactly zero mass (HLLE's flux
    would send its kinetic sound speed's share down)."""
    s = BedSetup()
    par = R.make_params(s, None)
    n = 8
    rho = np.where(np.arange(n) < 3, 0.0, 0.5 * s.density)
    f, _ = R.axis_fluxes_numpy(_column_prim(rho, np.where(rho > 0, 0.5, 0.0), 1e-4), 2, "wall", par)
    assert f[R.RHO][0, 0, 3] == 0.0
    assert np.all(f[R.RHO][0, 0, :3] == 0.0)
    # the walls (floor and lid) pass only the normal momentum: the others' fluxes exact zeros
    q = np.zeros((6, 1, 1, n))
    q[R.RHO, 0, 0] = 0.5 * s.density
    q[R.MX, 0, 0] = q[R.RHO, 0, 0] * 0.1
    q[R.MZ, 0, 0] = q[R.RHO, 0, 0] * np.linspace(-0.3, 0.3, n)
    q[R.ENER, 0, 0] = 1.5 * q[R.RHO, 0, 0] * 1e-3
    q[R.HIST, 0, 0] = q[R.RHO, 0, 0] * 1e-7
    fw, _ = R.axis_fluxes_numpy(R.primitives_numpy(q, par["rho_tiny"]), 2, "wall", par)
    for c in (R.RHO, R.MX, R.MY, R.ENER, R.HIST):
        assert fw[c][0, 0, 0] == 0.0 and fw[c][0, 0, -1] == 0.0, c
    assert fw[R.MZ][0, 0, 0] > 0.0 and fw[R.MZ][0, 0, -1] > 0.0


@pytest.mark.parametrize("uz0, leaving", [(-0.02, False), (0.02, True)])
def test_the_floor_gives_no_viscous_push_but_its_tension_stays(uz0, leaving):
    """The floor's face: its normal momentum flux is the Riemann flux minus the viscous normal
    stress, which may lower it (a bed starting to leave: u_z > 0 in the bottom cell) but not raise
    it (a bed's edge coming down: the mirror's 2u_z/Δz is a closing gap; the Riemann flux carries
    the impact).  Both cases have viscous coefficients (φ 0.4 to 0.55, θ 2e-3 m²/s²)."""
    s = BedSetup()
    par = R.make_params(s, None)
    dx = np.array([s.diameter / 4] * 3)
    n = 12
    rho = s.density * np.linspace(0.4, 0.55, n)
    uz = np.full(n, uz0)
    uz[0] = uz0 * 0.5
    q = np.zeros((6, 1, 1, n))
    q[R.RHO, 0, 0] = rho
    q[R.MZ, 0, 0] = rho * uz
    q[R.ENER, 0, 0] = 1.5 * rho * 2e-3
    prim = R.primitives_numpy(q, par["rho_tiny"])
    assert R.transport_numpy(prim, par)["mu"][0, 0, 0] > 0.0
    riemann = R.axis_fluxes_numpy(prim, 2, "wall", par)[0][R.MZ][0, 0, 0]
    _, floor = R.rhs_numpy(q, 1, dx, -9.81, par)
    assert riemann > 0.0
    if leaving:
        assert 0.0 <= floor[0, 0] < riemann                  # the tension lowers the floor's force
    else:
        assert floor[0, 0] == riemann                         # no viscous push
    dq = np.zeros_like(q)
    arr = B.scheme_params(s)[0]
    work = B.work_arrays(q.shape)
    B.bed_rhs(q, dq, *work[3:8], work[8], work[9], 1, dx, -9.81, arr, False)
    assert work[8][0, 0] == pytest.approx(floor[0, 0], rel=1e-13)


def _run(bed, t_end, settle=0.0):
    s = bed.setup
    if settle:
        bed.advance(-settle, 0.0, moving=False)
    bed.apply_velocity_jump(s.amplitude * s.omega)
    forces = [bed.advance(0.001 * i, 0.001 * (i + 1)) for i in range(int(round(t_end / 0.001)))]
    return np.array(forces)


@pytest.mark.parametrize("dim", [2, 3])
def test_horizontally_uniform_bed_equals_the_column_bit_for_bit(dim):
    """At the default 4 cells per d, with 3 lateral cells 4.3 d wide (narrower cells than the
    column's would set another step if the bound counted the uniform axes) and through a landing
    (the floor force nonzero; a sum over 3 columns is not exact), for 0.06 s."""
    s = BedSetup(gamma=3.0, cycles=2, n_spheres=600)
    col = B.EulerianBed(s, 1, cells_per_d=4)
    bed = B.EulerianBed(s, dim, cells_per_d=4, lateral_cells=3)
    f1 = _run(col, 0.06)
    fn = _run(bed, 0.06)
    assert col.counters[0] == bed.counters[0] > 5000
    assert np.count_nonzero(f1[20:]) > 10                        # landed: the force compared is not all 0
    assert np.array_equal(f1, fn)
    for i in range(3):
        for j in range(bed.q.shape[2]):
            assert np.array_equal(bed.q[:, i, j], col.q[:, 0, 0])
    assert np.all(bed.q[1] == 0.0) and np.all(bed.q[2] == 0.0)


def test_mass_is_conserved_and_a_lateral_mode_keeps_the_mass():
    """The lateral mode is one of the columns' heights: each column the static bed f = 1 + ε mode
    times as tall and heavy, at the static bed's solid fractions (no cell compressed beyond the
    uniform bed's), the total mass the uniform bed's; it starts a lateral flow and keeps the mass."""
    s = BedSetup(gamma=4.0, cycles=1, n_spheres=600)
    bed = B.EulerianBed(s, 3, cells_per_d=2, lateral_cells=4, perturbation=0.05)
    flat = B.EulerianBed(s, 3, cells_per_d=2, lateral_cells=4)
    assert bed.q[0].sum() == pytest.approx(flat.q[0].sum(), rel=1e-14)
    # no cell packed tighter than the static bed (the stretched bottom cell averages the static
    # profile over [0, Δz/f]: 7e-8 above the uniform bed's cell; the density mode had 5 %)
    assert bed.q[0].max() <= flat.q[0].max() * (1.0 + 1e-6)
    col = bed.q[0].sum(axis=2)
    mode = np.cos(0.5 * math.pi * np.arange(4))[:, None] * np.cos(0.5 * math.pi * np.arange(4))[None, :]
    np.testing.assert_allclose(col / flat.q[0].sum(axis=2), 1.0 + 0.05 * mode, rtol=1e-12)
    spread0 = bed.lateral_spread()
    assert spread0 == pytest.approx(0.05 * np.std(mode) * flat.mass_centre(), rel=0.05)   # heights differ
    _run(bed, 0.03)
    assert abs(bed.mass_error()) < 1e-12
    assert bed.q[0].min() >= 0.0
    assert 1e-4 * s.diameter < bed.lateral_spread() < spread0
    u = bed.q[1:3] / np.maximum(bed.q[0], 1e-30)
    assert np.abs(u[:, bed.q[0] > 0.1 * bed.named["rho_c"]]).max() > 1e-4      # lateral flow [m/s]


def test_the_lateral_mode_starts_the_bed_at_rest_without_energy():
    """A 5 % mode of the columns' heights adds no energy at the start: over 5 ms on the resting
    floor the bed gains as little kinetic and internal energy as the uniform bed (within 2x; both
    1.2-1.3e-3 of the floor's M(aω)²/2 here, the cell-averaged static profile settling) and below
    1e-2 of that scale, where the earlier density mode released 6.8 times the scale."""
    s = BedSetup(gamma=3.0, cycles=1, settle=0.0)
    scale = 0.5 * s.n_spheres * s.sphere_mass * (s.amplitude * s.omega) ** 2
    gained = []
    for eps in (0.0, 0.05):
        bed = B.EulerianBed(s, 2, cells_per_d=2, lateral_cells=4, perturbation=eps)
        bed.advance(-0.005, 0.0, moving=False)
        q = bed.q
        cell = s.area / (q.shape[1] * q.shape[2]) * bed.dx[2]
        kinetic = 0.5 * ((q[1] ** 2 + q[2] ** 2 + q[3] ** 2) / np.maximum(q[0], 1e-30)).sum() * cell
        gained.append(kinetic + q[4].sum() * cell)
    assert gained[1] < 2.0 * gained[0] and gained[1] < 1e-2 * scale, (gained, scale)


@pytest.mark.skipif(B.numba.config.NUMBA_NUM_THREADS < 2, reason="numba has one thread here: no concurrency to test")
def test_parallel_stepping_gives_the_serial_numbers_bit_for_bit(monkeypatch):
    """A 3-D bed with a lateral mode (every pass sees varying planes and lines), stepped through
    its first landing with the passes on two numba threads and one after the other: the same
    state, floor force and steps bit for bit.  The grid's choice (PARALLEL_MIN_CELLS, here
    forced both ways) reaches the compiled loop (its ``parallel`` argument recorded).  (Γ = 1.5:
    the floor's jump at t = 0 throws the bed for about 15 ms.)"""
    s = BedSetup(gamma=1.5, cycles=1, n_spheres=600, output_height=0.08)
    beds = [B.EulerianBed(s, 3, cells_per_d=2, lateral_cells=4, perturbation=0.05) for _ in range(2)]
    assert beds[0].q[0].size >= B.EulerianBed.PARALLEL_MIN_CELLS          # the default takes this grid parallel
    seen = []
    stepper = B.bed_advance

    def recording(*args):
        seen.append(args[15])                  # bed_advance's ``parallel``
        return stepper(*args)

    monkeypatch.setattr(B, "bed_advance", recording)
    n0 = B.numba.get_num_threads()
    B.numba.set_num_threads(2)
    try:
        forces = []
        for bed, parallel in zip(beds, (False, True)):
            bed.PARALLEL_MIN_CELLS = 0 if parallel else 10 ** 9
            assert bed.parallel is parallel
            seen.clear()
            forces.append(_run(bed, 0.03))
            assert set(seen) == {parallel}
    finally:
        B.numba.set_num_threads(n0)
    assert beds[0].counters[0] == beds[1].counters[0] > 1000
    assert np.count_nonzero(forces[0]) > 5
    assert np.array_equal(forces[0], forces[1]) and np.array_equal(beds[0].q, beds[1].q)
    assert beds[0].lateral_spread() > 1e-4 * s.diameter


def test_the_bed_at_rest_stays_at_rest():
    """From the Lagrangian static bed, cell-averaged, without vibration: the floor carries the weight
    to 1 %, and the mass centre drifts up by less than 0.003 d in 0.05 s (measured 2026-12-05,
    fourth session: 0.00094 d; 0.0092 d with HLLE along z, when the bound was 0.02 d).  The drift
    is the scheme's, at the bed's top: the partly filled top cells are below close packing, so
    without a packing stress they fall onto the packing, heat it (θ ~ 1.2e-4 m²/s² there after
    0.02 s, 5e-4 with HLLE, against the seed's 1e-6) and the heat dilates the top (docs/model.md)."""
    s = BedSetup(gamma=3.0, cycles=1)
    bed = B.EulerianBed(s, 1, cells_per_d=4)
    z0 = bed.mass_centre()
    forces = [bed.advance(-0.05 + 0.005 * i, -0.05 + 0.005 * (i + 1), moving=False) for i in range(10)]
    weight = s.n_spheres * s.sphere_mass * s.gravity
    assert 0.0 <= bed.mass_centre() - z0 < 0.003 * s.diameter
    assert forces[-1] == pytest.approx(weight, rel=0.01)


def test_eulerian_column_follows_the_lagrangian_bed_at_gamma_3():
    """The same model in two discretisations (cells per d 2 here; measured 2026-12-05, fourth
    session, with HLLC along z and no viscous push from the floor: mass-centre RMS 0.053 d over
    cycles 5-11, flight 24.45 ms against the Lagrangian 25.33 ms, ratio 0.965; 24.50 / 24.57 ms at
    4 / 8 cells per d, docs/model.md; the scheme before, HLLE along z and the push, flew 21.1 ms,
    ratio 0.83): the mass centres agree to 0.1 d once both have settled, the flights within 5 %."""
    from bsrflow.analysis.compare_bed import _last_six
    from bsrflow.numerics.bed_lagrangian import run_bed
    s = BedSetup(gamma=3.0, cycles=11)
    lag = run_bed(s)
    eul = B.run_eulerian_bed(s, 1, cells_per_d=2, save_every=s.save_every)
    t = eul["t"]
    sel = (t >= 5 * s.period - 1e-9) & (t < 11 * s.period - 1e-9)
    rms = math.sqrt(np.mean((eul["mass_centre"][sel] - np.interp(t[sel], lag.t, lag.mass_centre)) ** 2))
    assert rms < 0.1 * s.diameter
    f_l = np.mean(_last_six(lag.t, lag.floor_force, s)[2])
    f_e = np.mean(_last_six(t, eul["floor_force"], s)[2])
    assert 0.95 * f_l < f_e < f_l
    assert abs(eul["mass_error"]) < 1e-10


@pytest.mark.parametrize("kw, name", [({"dim": 4}, "dim"), ({"cells_per_d": 0}, "cells_per_d"),
                                      ({"cells_per_d": 2.5}, "cells_per_d"), ({"dim": 1, "lateral_cells": 2},
                                                                             "lateral_cells"),
                                      ({"dim": 3, "lateral_cells": 1}, "lateral_cells"),
                                      ({"dim": 1, "perturbation": 0.1}, "perturbation"),
                                      ({"dim": 2, "lateral_cells": 4, "perturbation": 1.0}, "perturbation"),
                                      ({"cfl": 0.9}, "cfl")])
def test_bad_settings_are_refused_in_one_line(kw, name):
    with pytest.raises(ValueError) as exc:
        B.EulerianBed(BedSetup(), **kw)
    msg = str(exc.value)
    assert msg.startswith(name + " = ") and "valid range" in msg and "\n" not in msg


@pytest.mark.parametrize("dim, lateral, cells_per_d, height, name, hi", [
    (3, 256, 64, 1.0, "cells_per_d", 1), (2, 256, 64, 100.0, "cells_per_d", 3), (3, 256, 16, 100.0, "lateral_cells", None)])
def test_a_grid_beyond_the_memory_bound_is_refused_before_it_is_made(dim, lateral, cells_per_d, height, name, hi):
    """A 256 x 256 x 12 800 grid (frequency 10 kHz, one cycle: few steps, so the cell-step bound
    let it through) asked for 37.5 GB and ended in a traceback (a fuzzing review): the cells are
    bounded by MAX_EULERIAN_CELLS (360 bytes each), the message naming the field with its range,
    or the lateral cells when no cells per d fits; the range's end is accepted."""
    from bsrflow.physics.granular_bed import MAX_EULERIAN_CELLS, EulerianBedSetup
    kw = dict(dimension=dim, lateral_cells=lateral, cells_per_d=cells_per_d, frequency=1e4, cycles=1,
              save_every=1e-4, output_height=height)
    with pytest.raises(ValueError) as exc:
        EulerianBedSetup(**kw)
    msg = str(exc.value)
    assert msg.startswith(f"{name} = ") and f"(at most {MAX_EULERIAN_CELLS:.0e}, 360 bytes each)" in msg, msg
    if hi is not None:
        assert f"integers in [1, {hi}]" in msg
        s = EulerianBedSetup(**{**kw, "cells_per_d": hi})
        assert s.cells_per_d == hi


@pytest.mark.parametrize("seed", range(4))
def test_spreading_cells_over_bins_is_the_dense_formula(seed):
    """bsrflow.numerics.grid.spread_over_bins against every cell against every bin, on uneven
    cells with faces on, near (one ulp) and between the bins' edges, reaching past both ends."""
    from bsrflow.numerics.grid import spread_over_bins
    rng = np.random.default_rng(seed)
    edges = np.linspace(0.0, 1.0, 41)
    faces = np.sort(np.concatenate([rng.uniform(-0.1, 1.1, 60), edges[::7], np.nextafter(edges[3::9], 2.0)]))
    faces = np.unique(faces)
    a, c = rng.uniform(0.0, 2.0, faces.size - 1), rng.normal(size=faces.size - 1)
    lo = np.clip(faces[:-1, None], edges[None, :-1], edges[None, 1:])
    hi = np.clip(faces[1:, None], edges[None, :-1], edges[None, 1:])
    frac = (hi - lo) / np.diff(faces)[:, None]
    got = spread_over_bins(faces, edges, a, c)
    for x, y in zip(got, ((a[:, None] * frac).sum(axis=0), (c[:, None] * frac).sum(axis=0))):
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12)
    inside = (faces[:-1] >= 0.0) & (faces[1:] <= 1.0)
    assert got[0].sum() >= a[inside].sum() - 1e-12                  # the cells inside are counted whole


@pytest.mark.parametrize("dim, cells_per_d, lateral", [(1, 3, 1), (1, 4, 1), (2, 16, 2), (3, 2, 3)])
def test_the_output_column_is_the_cells_mass_spread_over_their_height(dim, cells_per_d, lateral):
    """observe(): the cells' mass and momentum per bin of the output column, each cell's spread
    evenly over its height, against the dense formula (every cell against every bin, which took
    minutes on a tall grid: a fuzzing review) to 1e-12; the bins hold the bed's mass.  (The bed
    4 ms after the floor's start, its cells moved and with momentum; 12 ms, before 2026-12-06,
    cost 30 s at 16 cells per d for the same checks.)"""
    s = BedSetup(gamma=3.0)
    bed = B.EulerianBed(s, dim, cells_per_d, lateral, 0.05 if dim > 1 else 0.0)
    bed.apply_velocity_jump(s.amplitude * s.omega)
    bed.advance(0.0, 0.004)
    assert np.abs(bed.q[B.MZ]).max() > 0.0
    u, rho = bed.observe()
    g, dz = bed.grid, bed.dx[2]
    area = s.area / (bed.q.shape[1] * bed.q.shape[2])
    mass = bed.q[B.RHO].sum(axis=(0, 1)) * area * dz
    mom = bed.q[B.MZ].sum(axis=(0, 1)) * area * dz
    edges = g.lower[-1] + g.dx * np.arange(g.shape[0] + 1)
    zf = np.arange(mass.size + 1) * dz
    lo = np.clip(zf[:-1, None], edges[None, :-1], edges[None, 1:])
    hi = np.clip(zf[1:, None], edges[None, :-1], edges[None, 1:])
    m_bin = (mass[:, None] * (hi - lo) / dz).sum(axis=0)
    p_bin = (mom[:, None] * (hi - lo) / dz).sum(axis=0)
    np.testing.assert_allclose(rho, m_bin / g.dx, rtol=1e-12, atol=1e-12 * m_bin.max() / g.dx)
    full = m_bin > 1e-9 * m_bin.max()
    np.testing.assert_allclose(u[0][full], p_bin[full] / m_bin[full], rtol=1e-9, atol=1e-12)
    assert rho.sum() * g.dx == pytest.approx(s.n_spheres * s.sphere_mass, rel=1e-12)


EULERIAN_CONFIG = """[layer]
kind = "granular_bed_eulerian"
dimension = 2
lateral_cells = 3
cells_per_d = 1
perturbation = 0.05
n_spheres = 600
gamma = 3.0
cycles = 2
settle = 0.005
[output]
checkpoint_every = 0.05
"""


def test_the_eulerian_bed_runs_from_a_config_and_resumes_bit_for_bit(tmp_path):
    """``kind = "granular_bed_eulerian"`` through the shared driver: the file's column holds the
    bed's mass, its state the grid's fields with units (the run of the same setup through the
    Python API bit for bit), and a run interrupted at 0.075 s resumes from its checkpoint to the
    same file."""
    import xarray as xr
    from conftest import interrupt_and_resume

    from bsrflow.io.layer_runner import load_layer_config, run_layer_config
    from bsrflow.io.netcdf import read_snapshots
    from bsrflow.physics.granular_bed import EulerianBedSetup
    cfgfile = tmp_path / "bed.toml"
    cfgfile.write_text(EULERIAN_CONFIG)
    cfg = load_layer_config(cfgfile)
    assert isinstance(cfg.setup, EulerianBedSetup)
    full, part = tmp_path / "full.nc", tmp_path / "part.nc"
    run_layer_config(cfg, full)
    a, attrs = read_snapshots(full)
    s = cfg.setup
    mass = s.n_spheres * s.sphere_mass
    np.testing.assert_allclose(a["mass"], mass, rtol=1e-12)
    assert attrs["status"] == "ok" and list(attrs["grid_shape"]) == [3, 1, a["state_theta"].shape[-1]]
    bed = B.EulerianBed.from_setup(s)                 # the same run through the API
    bed.settle()
    bed.apply_velocity_jump(s.amplitude * s.omega)
    for k in range(1, 11):
        bed.advance((k - 1) * 1e-3, k * 1e-3)
    np.testing.assert_array_equal(a["state_solid_fraction"][10], bed.q[0] / s.density)
    assert a["state_floor_force"][10] == bed.last_floor_force
    with xr.open_dataset(full) as ds:
        units = {k: ds[k].attrs["units"] for k in ("rho", "state_theta", "state_velocity_z", "state_solid_fraction",
                                                   "state_floor_force")}
    assert units == {"rho": "kg m-1", "state_theta": "m2 s-2", "state_velocity_z": "m s-1",
                     "state_solid_fraction": "1", "state_floor_force": "N"}
    with xr.open_dataset(full) as ds:                   # the grid's dimensions are coordinates too
        for d, n in zip(("grid_x", "grid_y", "grid_z"), attrs["grid_shape"]):
            assert d in ds.coords and ds[d].size == n and list(ds[d].values[:1]) == [0]
            assert "grid_cell_size_m" in ds[d].attrs["long_name"]
        assert "grid_dimension" in ds.attrs["dimension_note"]

    def check(ck):
        assert set(ck.fields) == {"q", "floor_force"}

    outcome = interrupt_and_resume(cfg, part, between=check)
    assert outcome.resumed_from == pytest.approx(0.05)
    b, _ = read_snapshots(part)
    for k in ("time", "rho", "u_z", "mass_centre", "state_solid_fraction", "state_theta", "state_floor_force"):
        np.testing.assert_array_equal(a[k], b[k])


@pytest.mark.parametrize("line, text", [("n_cells = 40", "layer.n_cells: unknown key"),
                                        ("dimension = 4", "layer.dimension"),
                                        ("lateral_cells = 1", "layer.lateral_cells"),
                                        ("cells_per_d = 64\ncycles = 10000", "layer.cells_per_d")])
def test_eulerian_bed_config_refusals(tmp_path, line, text, capsys):
    from bsrflow.cli import main
    cfg = tmp_path / "bed.toml"
    body = EULERIAN_CONFIG.replace("lateral_cells = 3\n", "").replace("dimension = 2\n", "")
    body = body.replace("cycles = 2\n", "").replace("cells_per_d = 1\n", "")
    extra = {"dimension = 4": "lateral_cells = 3\ncells_per_d = 1\ncycles = 2\n",
             "lateral_cells = 1": "dimension = 2\ncells_per_d = 1\ncycles = 2\n"}.get(line, "dimension = 2\nlateral_cells = 3\n")
    if "cycles" not in line and "cycles" not in extra:
        extra += "cycles = 2\n"
    if "cells_per_d" not in line and "cells_per_d" not in extra:
        extra += "cells_per_d = 1\n"
    cfg.write_text(body.replace("[output]", line + "\n" + extra + "[output]"))
    out = tmp_path / "bed.nc"
    assert main(["run", str(cfg), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert text in err and len(err.splitlines()) == 1, err
    assert not out.exists()


def test_the_output_column_holds_all_the_mass_below_a_given_output_height():
    """The grid's lid is the last whole cell at or below output_top, so the column file's bins
    (up to output_top) hold all the mass; an output_height leaving no room above the bed is
    refused naming it; lateral_cells not given is 1 for a column, 4 otherwise."""
    from bsrflow.physics.granular_bed import EulerianBedSetup
    s = EulerianBedSetup(n_spheres=600, dimension=2, lateral_cells=2, cells_per_d=1, output_height=0.0252, cycles=1)
    bed = B.EulerianBed.from_setup(s)
    assert bed.shape[2] * bed.dx[2] <= s.output_top
    u, rho = bed.observe()
    assert float(np.sum(rho) * bed.grid.dx) == pytest.approx(s.n_spheres * s.sphere_mass, rel=1e-12)
    assert EulerianBedSetup(dimension=1).lateral_cells == 1 and EulerianBedSetup(dimension=2).lateral_cells == 4
    with pytest.raises(ValueError, match=r"^output_height = 0.0152 is outside the valid range at these settings"):
        EulerianBedSetup(n_spheres=600, dimension=2, lateral_cells=2, cells_per_d=1, output_height=0.0152)


def test_the_eulerian_bed_writes_its_cells_to_vtk(tmp_path):
    """``[output] vtk = true``: one .vtu per snapshot with the grid's cells (quadrilaterals of the
    grid's own sizes in 2-D) and the fields solid fraction, velocity and granular temperature,
    equal to the file's state; the .pvd lists every snapshot's time."""
    import meshio

    from bsrflow.io.layer_runner import load_layer_config, run_layer_config
    from bsrflow.io.netcdf import read_snapshots
    cfgfile = tmp_path / "bed.toml"
    cfgfile.write_text(EULERIAN_CONFIG.replace("cycles = 2\n", "cycles = 1\n")
                       .replace("[output]\n", "[output]\nvtk = true\n"))
    cfg = load_layer_config(cfgfile)
    out = tmp_path / "bed.nc"
    outcome = run_layer_config(cfg, out)
    data, _ = read_snapshots(out)
    folder = tmp_path / "bed_vtk"
    files = sorted(folder.glob("layer_*.vtu"))
    assert len(files) == len(data["time"]) == 51 and outcome.vtk.endswith("layer.pvd")
    mesh = meshio.read(files[20])
    nx, ny, nz = data["state_theta"].shape[1:]
    assert (nx, ny) == (3, 1) and mesh.cells[0].type == "quad" and len(mesh.cells[0].data) == nx * nz
    s = cfg.setup
    pts = mesh.points
    assert pts[:, 0].max() == pytest.approx(s.side) and pts[:, 2].max() == pytest.approx(nz * s.diameter / s.cells_per_d)
    np.testing.assert_array_equal(mesh.cell_data["solid fraction [1]"][0], data["state_solid_fraction"][20].ravel())
    np.testing.assert_array_equal(mesh.cell_data["granular temperature [m^2/s^2]"][0], data["state_theta"][20].ravel())
    vel = mesh.cell_data["velocity [m/s]"][0]
    np.testing.assert_array_equal(vel[:, 2], data["state_velocity_z"][20].ravel())
    assert (folder / "layer.pvd").read_text().count("<DataSet") == 51


# tracers ---------------------------------------------------------------------------------------

def _mass_fraction_below(bed, z):
    """The fraction of the bed's mass below the heights z [m] (the column's cumulative mass,
    linear inside a cell): a column's material lines."""
    col = bed.q[B.RHO].sum(axis=(0, 1))
    cum = np.concatenate([[0.0], np.cumsum(col)]) / col.sum()
    return np.interp(z, np.arange(len(col) + 1) * bed.dx[2], cum)


def test_tracers_stay_on_their_material_lines_in_a_column():
    """In a column (Γ = 3, the settled bed, the floor's first cycle: the take-off and the flight of
    about 2 d after the floor's jump; the first landing comes in the second cycle) the mass below
    a tracer started at a quarter, half and three quarters of the bed's height is its material
    line's: it changes by at most 2e-4 of the bed's mass at 4 cells per d (1.25e-4 measured
    since 2026-12-05, fourth session, with HLLC along z; 2.4e-4 with HLLE, when the bound was
    5e-4), and the largest change falls by more than 3x with each doubling of the cells (measured
    6.0x and 6.4x from 2 to 4 to 8 cells per d, 5.1x and 4.8x with HLLE; through the landing less,
    bench/check_eulerian_bed_tracers.py)."""
    s = BedSetup(gamma=3.0, cycles=1, settle=0.01)
    worst = []
    for cpd in (2, 4, 8):
        bed = B.EulerianBed(s, dim=1, cells_per_d=cpd)
        bed.settle()
        z0 = np.array([0.25, 0.5, 0.75]) * bed.top()
        bed.set_tracers(z0[:, None])
        f0 = _mass_fraction_below(bed, z0)
        bed.apply_velocity_jump(s.amplitude * s.omega)
        drift, rise = 0.0, 0.0
        for k in range(1, 101):
            bed.advance((k - 1) * 5e-4, k * 5e-4)
            z = bed.tracer_positions()[:, 0]
            drift = max(drift, float(np.max(np.abs(_mass_fraction_below(bed, z) - f0))))
            rise = max(rise, float(np.min(z - z0)))
        assert rise > 1.5 * s.diameter               # the tracers did fly with the bed
        worst.append(drift)
    assert worst[1] < 2e-4, worst
    assert worst[0] > 3.0 * worst[1] and worst[1] > 3.0 * worst[2], worst


def test_the_tracers_step_is_the_fields_shu_osher_step():
    """One step of :func:`bed_advance` moves the tracers as an independent SSP-RK3 step written
    here (the NumPy twin's interpolation on the stage states q, q1 = q + Δt L(q) and
    q2 = (3q + q1 + Δt L(q1))/4, at x0, x0 + Δt v0, x0 + Δt (v0 + v1)/4, then
    x0 + Δt (v0 + v1 + 4 v2)/6), over 20 steps of a 2-D bed with a lateral mode early in its
    first cycle, to 1e-15 m (interpolating on q instead of a stage state moves a tracer by about
    1e-9 m per step here: a review's mutants)."""
    from bsrflow.numerics.packing_reference import tracer_velocity_numpy
    s = BedSetup(gamma=3.0, cycles=1, settle=0.005)
    bed = B.EulerianBed(s, dim=2, cells_per_d=2, lateral_cells=4, perturbation=0.05)
    bed.settle()
    L, top = bed._box[0], bed._box[2]
    rng = np.random.default_rng(7)
    bed.set_tracers(np.column_stack([rng.uniform(0.0, L, 10), rng.uniform(0.0, 0.6 * top, 10)]))
    bed.apply_velocity_jump(s.amplitude * s.omega)
    bed.advance(0.0, 0.004)
    lo = np.zeros(3)
    rt = bed.named["rho_tiny"]

    def accel(t):
        return -s.gravity + s.amplitude * s.omega ** 2 * math.sin(s.omega * t)

    def at(q, p):
        p = p.copy()
        p[:, 2] = np.clip(p[:, 2], 0.0, top)
        return tracer_velocity_numpy(q, p, lo, bed.dx, rt)

    moved = 0.0
    for _ in range(20):
        q, x0, t = bed.q.copy(), bed.tracers.copy(), bed.t
        q1, q2, dq, w, co, G, div, heat, floor, scratch = B.work_arrays(q.shape)
        dt = B.bed_stable_dt(q, 2, bed.dx, bed.cfl, bed.par, w, co)[0]
        v0 = at(q, x0)
        B.bed_rhs(q, dq, w, co, G, div, heat, floor, scratch, 2, bed.dx, accel(t), bed.par, False)
        q1[:] = q + dt * dq
        v1 = at(q1, x0 + dt * v0)
        B.bed_rhs(q1, dq, w, co, G, div, heat, floor, scratch, 2, bed.dx, accel(t + dt), bed.par, False)
        q2[:] = 0.75 * q + 0.25 * (q1 + dt * dq)
        v2 = at(q2, x0 + 0.25 * dt * (v0 + v1))
        ref = x0 + dt * (v0 + v1 + 4.0 * v2) / 6.0
        ref[:, 0] = np.mod(ref[:, 0], L)
        ref[:, 2] = np.clip(ref[:, 2], 0.0, top)
        t_new, _ = B.bed_advance(bed.q, t, t + 1.0, 2, bed.dx, bed.cfl, bed.par, s.gravity, s.amplitude, s.omega,
                                 True, bed.named["e_d"], bed.work, bed.counters, 1, False, bed.tracers, bed._box)
        assert t_new - t == pytest.approx(dt, rel=1e-12)
        bed.t = t_new
        np.testing.assert_allclose(bed.tracers, ref, rtol=0, atol=1e-15)
        moved = max(moved, float(np.max(np.abs(bed.tracers - x0))))
    assert moved > 1e-7                                     # they did move (about 2e-6 m per step)


def test_tracers_cross_the_periodic_sides_in_both_directions():
    """A 3-D bed set drifting horizontally (u_x = 0.4, u_y = −0.3 m/s): the tracers leave through
    one side and come back in at the other, in x and in y, and stay inside [0, L)."""
    s = BedSetup(gamma=3.0, cycles=1, settle=0.0)
    bed = B.EulerianBed(s, dim=3, cells_per_d=1, lateral_cells=2)
    L = s.side
    bed.q[B.MX] = 0.4 * bed.q[B.RHO]
    bed.q[B.MY] = -0.3 * bed.q[B.RHO]
    start = np.array([[0.9 * L, 0.05 * L, 0.004], [0.5 * L, 0.5 * L, 0.008]])
    bed.set_tracers(start)
    bed.advance(0.0, 0.02, moving=False)
    p = bed.tracer_positions()
    assert np.all((p[:, :2] >= 0.0) & (p[:, :2] < L))
    np.testing.assert_allclose(p[:, 0], np.mod(start[:, 0] + 0.4 * 0.02, L), rtol=0, atol=1e-9)
    np.testing.assert_allclose(p[:, 1], np.mod(start[:, 1] - 0.3 * 0.02, L), rtol=0, atol=1e-9)
    assert p[0, 0] < 0.5 * L and p[0, 1] > 0.5 * L         # the first one wrapped in both


def test_tracers_of_a_horizontally_uniform_bed_move_as_the_columns():
    """A 3-D bed without a lateral mode: tracers at one height and different (x, y) move as the
    column's tracer at that height (to 1e-12 of the height: the interpolation's weights over
    equal columns), and their horizontal positions do not change at all."""
    s = BedSetup(gamma=3.0, cycles=1, settle=0.0)
    col = B.EulerianBed(s, dim=1, cells_per_d=2)
    box = B.EulerianBed(s, dim=3, cells_per_d=2, lateral_cells=2)
    z = np.array([0.3, 0.6, 0.9]) * col.top()
    col.set_tracers(z[:, None])
    xy = np.array([[0.001, 0.007], [0.0083, 0.0002], [0.0049, 0.0051]])
    box.set_tracers(np.column_stack([xy, z]))
    for bed in (col, box):
        bed.apply_velocity_jump(s.amplitude * s.omega)
        bed.advance(0.0, 0.03)
    zc = col.tracer_positions()[:, 0]
    assert np.min(zc - z) > 0.5 * s.diameter
    np.testing.assert_allclose(box.tracer_positions()[:, 2], zc, rtol=1e-12, atol=0)
    np.testing.assert_array_equal(box.tracer_positions()[:, :2], xy)


@pytest.mark.parametrize("dim, positions, text", [
    (1, [[0.001, 0.002]], "shape (n, 1)"), (3, [[0.001, 0.002]], "shape (n, 3)"),
    (2, [[-0.001, 0.002]], "outside the grid"), (2, [[0.001, 1.0]], "outside the grid"),
    (3, [[0.001, 0.002, float("nan")]], "finite"), (2, np.zeros((0, 2)), "shape (n, 2)")])
def test_bad_tracers_are_refused_in_one_line(dim, positions, text):
    bed = B.EulerianBed(BedSetup(), dim=dim, lateral_cells=1 if dim == 1 else 2)
    with pytest.raises(ValueError) as exc:
        bed.set_tracers(positions)
    msg = str(exc.value)
    assert msg.startswith("tracers: ") and text in msg and "\n" not in msg


def test_eulerian_bed_tracers_from_a_config_are_written_and_resume_bit_for_bit(tmp_path):
    """``[tracers]`` of a ``granular_bed_eulerian`` config (x, z per tracer in 2-D): the file has
    ``tracer_x`` and ``tracer_z`` (lab frame) from the given positions at t = 0 on the settled bed,
    the same as the run through the API, and a run interrupted at 0.075 s resumes to the same
    tracers; with VTK output they are a point cloud per snapshot."""
    import meshio

    from bsrflow.io.layer_runner import load_layer_config, run_layer_config
    from bsrflow.io.netcdf import read_snapshots
    from conftest import interrupt_and_resume
    pos = [[0.002, 0.003], [0.011, 0.008]]
    cfgfile = tmp_path / "bed.toml"
    cfgfile.write_text(EULERIAN_CONFIG.replace("[output]\n", "[output]\nvtk = true\n")
                       + f"[tracers]\npositions = {pos}\n")
    cfg = load_layer_config(cfgfile)
    full, part = tmp_path / "full.nc", tmp_path / "part.nc"
    run_layer_config(cfg, full)
    a, _ = read_snapshots(full)
    assert "tracer_y" not in a
    np.testing.assert_array_equal(a["tracer_x"][0], [0.002, 0.011])
    np.testing.assert_array_equal(a["tracer_z"][0], np.array([0.003, 0.008]) + a["floor"][0])
    s = cfg.setup
    bed = B.EulerianBed.from_setup(s)
    bed.settle()
    bed.set_tracers(pos)
    bed.apply_velocity_jump(s.amplitude * s.omega)
    for k in range(1, 11):                            # (the saves' intervals, as the driver's steps)
        bed.advance((k - 1) * 1e-3, k * 1e-3)
    np.testing.assert_array_equal(a["tracer_x"][10], bed.tracer_positions()[:, 0])
    # (the file's heights are in the lab frame: z + floor, so only round-off of the sum differs)
    np.testing.assert_allclose(a["tracer_z"][10] - a["floor"][10], bed.tracer_positions()[:, 1], rtol=0, atol=1e-17)
    assert np.ptp(a["tracer_z"][:, 0] - a["floor"]) > 0.5 * s.diameter
    cloud = meshio.read(tmp_path / "full_vtk" / "layer_tracers_000010.vtu")
    np.testing.assert_allclose(cloud.points[:, [0, 2]], bed.tracer_positions(), rtol=0, atol=1e-12)
    cfgfile.write_text(EULERIAN_CONFIG + f"[tracers]\npositions = {pos}\n")
    outcome = interrupt_and_resume(load_layer_config(cfgfile), part)
    assert outcome.resumed_from == pytest.approx(0.05)
    b, _ = read_snapshots(part)
    for key in ("time", "tracer_x", "tracer_z", "state_solid_fraction"):
        np.testing.assert_array_equal(a[key], b[key])


def test_a_lid_in_the_beds_path_stops_the_run_naming_output_height():
    """A grid whose lid is 1 d above the bed at rest (Γ = 6: the bed flies higher than that)
    stops once more than LID_MASS_FRACTION of the mass is within a diameter of the lid, saying when
    and what to change; the default lid does not (tested through the config runs above)."""
    from bsrflow.numerics.solver import SimulationError
    s = BedSetup(gamma=6.0, cycles=1, n_spheres=600, output_height=0.02)
    bed = B.EulerianBed(s, 1, cells_per_d=2)
    bed.apply_velocity_jump(s.amplitude * s.omega)
    with pytest.raises(SimulationError, match=r"^the Eulerian bed stopped at t = .* of its mass is within one "
                                              r"diameter of the grid's lid \(0\.02 m; at most 0\.001\); raise "
                                              r"output_height$"):
        for i in range(50):
            bed.advance(0.001 * i, 0.001 * (i + 1))
    assert bed.lid_mass_fraction() > B.EulerianBed.LID_MASS_FRACTION
