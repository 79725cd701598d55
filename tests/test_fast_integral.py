"""The fast Walton–Braun integral equals the direct quadrature sum to round-off (issue #8);
skipping the empty cells above a column changes nothing, bit for bit."""

import numpy as np
import pytest

from bsrflow.numerics.compiled import direct_integral
from bsrflow.numerics.fast_integral import ANCHOR, walton_braun_integral
from bsrflow.numerics.quadrature import quadrature_weights
from bsrflow.numerics.solver import Scheme, Simulation
from bsrflow.physics.column import ColumnSetup, initial_density
from bsrflow.physics.kernels import walton_braun


def _both(up, rp, W, dx, rule, kernel):
    N = up.size - 2 * W
    qz, qw = quadrature_weights(W, dx, rule)
    out_fast, out_direct = np.empty(N), np.empty(N)
    walton_braun_integral(up, rp, W, N, W, qz, qw, kernel.params, out_fast)
    direct_integral(kernel.compiled)(up, rp, W, N, W, qz, qw, kernel.params, out_direct)
    # scale of the sum: |o λ| Σ_k |b_k| max ρ
    scale = abs(kernel.params[0]) * np.sum(np.abs(qw * (W * dx - np.abs(qz)))) * max(np.max(rp), 1e-300)
    return out_fast, out_direct, scale


def _random_state(rng, n, W):
    """Padded (u, ρ) with every case of the algorithm: random u (non-monotone), strictly
    increasing and decreasing stretches longer than a window, constant stretches, exact
    ties, empty stretches, and tiny densities."""
    m = n + 2 * W
    u = rng.standard_normal(m)
    rho = rng.random(m) * 3.0
    pos = 0
    while pos < m:
        length = int(rng.integers(1, 4 * W))
        kind = rng.integers(0, 6)
        sl = slice(pos, min(m, pos + length))
        k = sl.stop - sl.start
        if kind == 0:
            u[sl] = np.cumsum(rng.random(k) + 1e-3)          # increasing
        elif kind == 1:
            u[sl] = -np.cumsum(rng.random(k) + 1e-3)         # decreasing
        elif kind == 2:
            u[sl] = rng.standard_normal()                    # constant
        elif kind == 3:
            rho[sl] = 0.0                                    # empty
        elif kind == 4:
            u[sl] = np.round(rng.standard_normal(k))         # many exact ties
        else:
            rho[sl] *= 1e-250                                # tiny tail
        pos += length
    return u, rho


@pytest.mark.parametrize("rule,W", [("trapezoid", 2), ("trapezoid", 10), ("trapezoid", 40),
                                    ("boole", 8), ("boole", 40)])
@pytest.mark.parametrize("seed_sign", [False, True])
def test_fast_equals_direct_on_random_states(rule, W, seed_sign):
    rng = np.random.default_rng(W + 7 * seed_sign)
    dx = 1e-3
    kernel = walton_braun(3.7e4, 0.6, W * dx, seed_sign=seed_sign)
    for trial in range(5):
        n = int(rng.integers(3 * ANCHOR, 6 * ANCHOR))
        up, rp = _random_state(rng, n, W)
        fast, direct, scale = _both(up, rp, W, dx, rule, kernel)
        assert np.max(np.abs(fast - direct)) <= 1e-13 * scale
        # exact zeros where the window is empty
        for i in range(n):
            if not np.any(rp[i:i + 2 * W + 1]):
                assert fast[i] == 0.0 and direct[i] == 0.0


@pytest.mark.parametrize("ppd", [4, 10])
def test_fast_equals_direct_on_tapped_column_states(ppd):
    s = ColumnSetup(points_per_diameter=ppd, m0=406.0, kernel_dissipation=0.9, t_end=0.5)
    line = s.particle_mass / s.diameter
    sim = Simulation(s.model(), s.grid(), Scheme.preset("seed"), vacuum_density=1e-4 * line)
    g = sim.grid
    res = sim.run(np.zeros(g.n_cells), initial_density(s, g.x), 0.5, save_times=[0.0, 0.3, 0.45, 0.5])
    kernel = sim.model.kernel
    G = sim.W
    for k in range(res.t.size):
        up = np.empty(g.n_cells + 2 * G)
        rp = np.empty_like(up)
        sim.core.fill_ghosts(res.u[k], res.rho[k], res.t[k], up, rp, G, *g.codes, g.lower, g.dx,
                             sim.model.boundary_params)
        fast, direct, scale = _both(up, rp, G, g.dx, "trapezoid", kernel)
        assert np.max(np.abs(fast - direct)) <= 1e-13 * scale


def test_simulation_uses_fast_integral_and_rhs_agrees():
    s = ColumnSetup(points_per_diameter=6, m0=406.0, kernel_dissipation=0.9)
    line = s.particle_mass / s.diameter
    fast = Simulation(s.model(), s.grid(), Scheme.preset("seed"), vacuum_density=1e-4 * line)
    direct = Simulation(s.model(), s.grid(), Scheme.preset("seed"), vacuum_density=1e-4 * line,
                        integral="direct")
    assert fast.integral_name == "walton_braun_integral"
    assert direct.integral_name != fast.integral_name
    rng = np.random.default_rng(3)
    rho = initial_density(s, fast.grid.x)
    u = 0.05 * rng.standard_normal(rho.size)
    du_f, dr_f = fast.rhs(u, rho, 0.1)
    du_d, dr_d = direct.rhs(u, rho, 0.1)
    assert np.max(np.abs(du_f - du_d)) <= 1e-12 * np.max(np.abs(du_d))
    assert np.array_equal(dr_f, dr_d)
    with pytest.raises(ValueError, match="integral"):
        Simulation(s.model(), s.grid(), integral="bogus")


@pytest.mark.parametrize("scheme", [Scheme.preset("seed"), Scheme.preset("accurate"),
                                    Scheme.preset("accurate", stepper="bs32", cfl=0.8, rtol=1e-2,
                                                  atol=(1e-2, 1e-3))],
                         ids=["seed", "accurate", "accurate-adaptive"])
@pytest.mark.parametrize("floor", [0.0, 1e-30], ids=["no-floor", "floor"])
def test_skipping_the_vacuum_is_bitwise_identical(scheme, floor):
    """Through a tap (jumps, flight, landing) with tracers: the same state, bit for bit.  The
    skip covers the stages and the post-step passes (positivity fix, velocity extension,
    moving average, floor, finiteness check, the CFL maxima)."""
    s = ColumnSetup(points_per_diameter=5, m0=406.0, kernel_dissipation=0.9, tap_start=0.05, t_end=0.3)
    line = s.particle_mass / s.diameter
    runs = []
    for skip in (True, False):
        sim = Simulation(s.model(), s.grid(), scheme, vacuum_density=1e-4 * line,
                         skip_vacuum=skip, density_floor=floor * line)
        g = sim.grid
        runs.append(sim.run(np.zeros(g.n_cells), initial_density(s, g.x), s.t_end, save_every=0.05,
                            tracers=s.sphere_centres()))
    a, b = runs
    assert a.steps == b.steps
    for name in ("u", "rho", "tracers"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    # the skip really happened: a large part of the domain was empty at the saves
    assert min(np.count_nonzero(r) for r in a.rho) < 0.5 * a.rho.shape[1]


@pytest.mark.parametrize("level", [0.0, 1e-6], ids=["empty", "below-threshold"])
def test_skipping_the_vacuum_without_material_is_bitwise_identical(level):
    """With no material anywhere (ρ = 0, or ρ everywhere below the vacuum threshold, no
    tracers) the extension overwrites nothing, so the skip must compute the whole grid: the
    vacuum then falls freely in both runs, bit for bit the same."""
    s = ColumnSetup(points_per_diameter=5, m0=406.0, kernel_dissipation=0.9, tap_start=1.0, t_end=0.1)
    line = s.particle_mass / s.diameter
    runs = []
    for skip in (True, False):
        sim = Simulation(s.model(), s.grid(), Scheme.preset("seed"), vacuum_density=1e-4 * line,
                         skip_vacuum=skip)
        g = sim.grid
        rho = np.full(g.n_cells, level * line)
        runs.append(sim.run(np.zeros(g.n_cells), rho, s.t_end, save_every=0.05))
    a, b = runs
    assert a.steps == b.steps
    assert np.array_equal(a.u, b.u) and np.array_equal(a.rho, b.rho)
    # no tap before t_end: the vacuum fell, u = -g t in the middle of the grid
    mid = a.u[-1][a.u.shape[1] // 2]
    assert mid == pytest.approx(-s.gravity * s.t_end, rel=1e-6)


def test_extend_velocity_matches_nearest_material_cell():
    s = ColumnSetup(points_per_diameter=4)
    sim = Simulation(s.model(), s.grid(), Scheme.preset("seed"), vacuum_density=0.5)
    rng = np.random.default_rng(5)
    for trial in range(20):
        n = int(rng.integers(1, 40))
        rho = np.where(rng.random(n) < 0.4, 1.0, 0.0)
        u = rng.standard_normal(n)
        got = u.copy()
        sim.core.extend_velocity(got, rho, 0.5)
        mat = np.flatnonzero(rho >= 0.5)
        want = u.copy()
        if mat.size:
            for i in np.flatnonzero(rho < 0.5):
                dist = np.abs(mat - i)
                want[i] = u[mat[np.argmin(dist)]]        # argmin: the lower one on a tie
        assert np.array_equal(got, want)


@pytest.mark.parametrize("W", [2, 10, 40])
def test_one_pass_classes_and_elastic_sums(W):
    """_classify_scaled_elastic: the classes of _classify exactly, and the class factor times
    the elastic sum E_i = Σ_k σ(k) b_|k| ρ_{i+k} (the O(W) sum of _elastic_sum) to round-off,
    0 for empty windows; on states with every class, exact ties and 1e-250 tails."""
    from bsrflow.numerics.fast_integral import _classify, _classify_scaled_elastic, _elastic_sum
    rng = np.random.default_rng(100 + W)
    u, rho = _random_state(rng, 3000, W)
    N = u.size - 2 * W
    beta, coef, eps = 0.37, -2.5, 0.9
    fac = np.array([0.0, coef, coef * (1 - eps), coef * (1 + eps), coef])
    k = np.arange(-W, W + 1)
    bs = np.sign(k) * beta * (W - np.abs(k))                      # σ(k) b_|k|, b_k = β (W - k)
    cls_a, cls_b, out = np.empty(N, np.int8), np.empty(N, np.int8), np.empty(N)
    _classify(u, rho, W, N, W, cls_a)
    _classify_scaled_elastic(u, rho, W, N, W, beta, fac, cls_b, out)
    assert np.array_equal(cls_a, cls_b)
    assert set(np.unique(cls_b)) == {0, 1, 2, 3, 4}
    want = np.array([fac[c] * _elastic_sum(rho, W + i, W, bs) for i, c in enumerate(cls_a)])
    scale = abs(coef) * (1 + eps) * np.abs(bs).sum() * rho.max()
    assert np.max(np.abs(out - want)) <= 1e-13 * scale
    assert np.all(out[cls_b == 0] == 0.0)


def test_density_floor_leaves_the_material_unchanged():
    """The column's floor (|ρ| < 1e-30 m/d set to 0 after every step) removes the moving
    average's debris above the column and nothing else: through a tap, the tracers and the
    velocity of the material cells are the same bit for bit (the debris is absorbed in every
    sum it enters), and ρ differs only in the debris."""
    s = ColumnSetup(points_per_diameter=5, m0=406.0, kernel_dissipation=0.9, tap_start=0.05, t_end=0.3)
    line = s.particle_mass / s.diameter
    runs = []
    for floor in (1e-30 * line, 0.0):
        sim = s.simulation(Scheme.preset("seed"), density_floor=floor)
        assert sim.density_floor == floor
        g = sim.grid
        runs.append(sim.run(np.zeros(g.n_cells), initial_density(s, g.x), s.t_end, save_every=0.05,
                            tracers=s.sphere_centres()))
    a, b = runs
    assert a.steps == b.steps
    assert np.array_equal(a.tracers, b.tracers)
    material = b.rho >= 1e-4 * line
    assert np.array_equal(a.u[material], b.u[material])
    # ρ differs only in vacuum cells (below 1e-4 m/d in both runs), at round-off of those cells'
    # own values: 5.2 floors measured in this small case (the bound of 100 floors holds here
    # only; larger and longer runs differ by more floors in fuller vacuum cells, docs/model.md)
    differ = a.rho != b.rho
    assert np.all(np.maximum(np.abs(a.rho), np.abs(b.rho))[differ] < 1e-4 * line)
    assert np.max(np.abs(a.rho - b.rho)) <= 100 * 1e-30 * line
    # the debris was there without the floor and is gone with it
    assert np.count_nonzero(b.rho[-1]) > np.count_nonzero(a.rho[-1]) + 20
