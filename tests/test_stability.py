"""Von Neumann analysis of the steppers (seed section 5.4) and its check against the solver.

Test bed: BSRModel() (no interaction, no gravity) with u ≡ a on a periodic grid.  Then u_x = 0
exactly, u stays a, and the density obeys ρ_t = -a D1 ρ (central differences in every RK
stage) followed by the moving average: exactly the 'as_implemented' linear scheme.
"""
import json
import math

import numpy as np
import pytest

from bsrflow.analysis import stability as stab
from bsrflow.numerics.grid import Grid1D
from bsrflow.numerics.solver import Scheme, Simulation
from bsrflow.physics.model import BSRModel

N = 128
A = 1.0                      # advection speed [m/s]; 0.25(a + 2a + a) == a exactly
GRID = Grid1D(0.0, 1.0, N, "periodic", "periodic")
THETA = 2.0 * np.pi * np.fft.fftfreq(N)      # θ_k = k Δx (2π/L) of the grid's Fourier modes
COMBOS = [(s, f) for s in stab.STEPPER_NAMES for f in (False, True)]


@pytest.fixture(scope="module")
def limits():
    return {(r["stepper"], r["filter"], r["variant"]): r["cfl_limit"] for r in stab.cfl_table()}


def _advect(stepper, filt, nu, rho0, steps):
    """Run the real solver for exactly ``steps`` steps of Δt = ν Δx / a; return ρ.  With
    ``check_cfl=False``: these runs are unstable on purpose (Euler and Heun without the moving
    average, which Scheme refuses by default, and 1.02x the limit)."""
    sim = Simulation(BSRModel(), GRID, Scheme(stepper=stepper, filter=filt, dt=nu * GRID.dx / A, check_cfl=False))
    u = np.full(N, A)
    rho = rho0.copy()
    t, n, status, where, dt = sim.advance(u, rho, 0.0, 1e300, max_steps=steps)
    assert n == steps and status in (1, 4), (n, status)   # 4: step budget used (1 only if it blew up)
    assert np.all(u == A)                                 # the velocity is untouched
    return rho


# -- (a) analytic checks --------------------------------------------------------------------
def test_stability_polynomials_are_taylor():
    for name, order in (("euler", 1), ("heun", 2), ("kutta3", 3), ("rk4", 4), ("rk4_0.4_0.25", 4)):
        r = stab.stability_polynomial_coefficients(name)
        assert [float(x) for x in r] == [1.0 / math.factorial(k) for k in range(order + 1)]


def test_polynomial_excess_matches_direct_evaluation():
    """|g|² - 1 from the exact (s, ν) polynomial equals |g|² - 1 from the complex symbols, and
    the maximiser over θ is not beaten by a dense θ grid."""
    th = np.concatenate([np.linspace(0.0, np.pi, 20001), np.logspace(-8, -1, 200)])
    for st, f in COMBOS:
        for var in stab.VARIANTS:
            for nu in (0.3, 0.9, 1.7, 2.5):
                direct = np.abs(stab.amplification_factor(th, nu, st, f, var)) ** 2 - 1.0
                poly = stab.excess(th, nu, st, f, var)[0]
                assert np.max(np.abs(poly - direct)) < 1e-11 * max(1.0, np.max(np.abs(direct)))
                gmax, _ = stab.max_amplification(nu, st, f, var)
                assert np.max(np.sqrt(direct + 1.0)) <= gmax[0] + 1e-12


def test_euler_limits(limits):
    # FTCS: |g|² = 1 + ν² sin²θ > 1 for every ν > 0
    assert limits[("euler", False, "as_implemented")] == 0.0
    assert limits[("euler", False, "seed")] == 0.0
    # with the filter: (1 + 4ν² s c) c² <= 1  <=>  4ν² c³ <= 1 + c  <=>  ν <= 1/√2 (tangent at θ = 0);
    # the 1e-12 tolerance on |g| moves the computed value up by ~1e-6
    for var in stab.VARIANTS:
        assert abs(limits[("euler", True, var)] - 1.0 / math.sqrt(2.0)) < 5e-6


def test_closed_form_limits(limits):
    # Heun without filter: |R(iy)|² = 1 + y⁴/4: no stable ν > 0 (despite the 1e-12 tolerance)
    assert limits[("heun", False, "as_implemented")] == 0.0
    # Heun + filter: 4ν⁴ (1 - c) c⁴ <= 1 + c, worst c = (√17 - 1)/4
    assert abs(limits[("heun", True, "as_implemented")] - stab.heun_filter_limit()) < 1e-6
    assert abs(stab.heun_filter_limit() - 1.52893) < 1e-5
    # without the filter the worst mode is θ = π/2, y = ν: the imaginary-axis limits √3 and 2√2
    assert abs(limits[("kutta3", False, "as_implemented")] - math.sqrt(3.0)) < 1e-6
    assert abs(limits[("rk4", False, "as_implemented")] - 2.0 * math.sqrt(2.0)) < 1e-6
    # seed variant: Heun is Lax-Wendroff (|g|² = 1 - 4ν²(1-ν²) sin⁴(θ/2)): limit 1; the seed's
    # RK3 |ḡ|² at ν = 1 is 1 - (16/9) s²(1-s)(3-s) <= 1 and > 1 beyond: limit 1
    assert abs(limits[("heun", False, "seed")] - 1.0) < 1e-6
    assert abs(limits[("kutta3", False, "seed")] - 1.0) < 1e-6


def test_seed_claims_vs_computed(limits):
    """The seed's 1 for Heun/RK3 with filter is the unfiltered seed-variant limit; the filter
    and the implemented (every-stage) central differences both allow more."""
    assert limits[("heun", True, "seed")] > 1.45
    assert limits[("kutta3", True, "seed")] > 1.65
    assert limits[("kutta3", True, "as_implemented")] > 2.3
    for st in ("heun", "kutta3", "rk4"):
        for var in stab.VARIANTS:
            assert limits[(st, True, var)] >= limits[(st, False, var)]


def test_bad_input():
    with pytest.raises(ValueError, match="stepper"):
        stab.cfl_limit("rk5")
    with pytest.raises(ValueError, match="variant"):
        stab.cfl_limit("heun", True, "printed")
    with pytest.raises(ValueError, match="nu"):
        stab.amplification_factor(0.1, -1.0)
    with pytest.raises(ValueError, match="tol"):
        stab.cfl_limit("heun", True, tol=1e-3)


def test_cli_json(tmp_path, capsys):
    from bsrflow.cli import main
    out = tmp_path / "s.json"
    assert main(["stability", "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    assert len(data["limits"]) == 16
    assert {tuple(sorted(d)) for d in data["limits"]} == {("cfl_limit", "filter", "stepper", "variant")}
    assert "as_implemented" in capsys.readouterr().out


def test_write_figures(tmp_path, limits):
    rows = [{"stepper": s, "filter": f, "variant": v, "cfl_limit": L} for (s, f, v), L in limits.items()]
    paths = stab.write_figures(tmp_path, rows)
    assert len(paths) == 5 and all((tmp_path / p).stat().st_size > 10_000 for p in paths)


# -- (b) the solver against the analysis ----------------------------------------------------
@pytest.mark.parametrize("stepper,filt", COMBOS)
def test_solver_multiplies_fourier_modes_by_g(stepper, filt, rng):
    """Each Fourier coefficient of ρ is multiplied by exactly g(θ_k)^n (as implemented), and
    not by the seed variant's g (except for Euler, where they coincide)."""
    rho0 = 1.0 + 0.1 * rng.standard_normal(N)
    nu, steps = 0.6, 5
    rho = _advect(stepper, filt, nu, rho0, steps)
    ratio = np.fft.fft(rho) / np.fft.fft(rho0)
    g = stab.amplification_factor(THETA, nu, stepper, filt, "as_implemented") ** steps
    assert np.max(np.abs(ratio - g)) < 1e-10
    if stepper != "euler":
        gs = stab.amplification_factor(THETA, nu, stepper, filt, "seed") ** steps
        assert np.max(np.abs(ratio - gs)) > 1e-3


@pytest.mark.parametrize("stepper,filt", [c for c in COMBOS if c not in (("euler", False), ("heun", False))])
def test_solver_bounded_below_and_growing_above_limit(stepper, filt, limits, rng):
    """At 0.98 ν* the solution stays bounded; at 1.02 ν* it grows by a large factor.

    The step count is chosen so that the most unstable grid mode at 1.02 ν* would grow by
    1e4 (Euler + filter touches |g| = 1 tangentially at θ = 0: its growth at 1.02 ν* is only
    1.5e-4 per step, so it needs ~6e4 steps); at least 1000 steps in every case."""
    nu_star = limits[(stepper, filt, "as_implemented")]
    assert nu_star > 0
    g_hi = np.max(np.abs(stab.amplification_factor(THETA, 1.02 * nu_star, stepper, filt)))
    assert g_hi > 1.0
    steps = int(max(1000, math.ceil(math.log(1e4) / math.log(g_hi))))
    assert steps < 100_000
    rho0 = 1.0 + 0.1 * rng.standard_normal(N)
    size0 = np.max(np.abs(rho0 - rho0.mean()))
    lo = _advect(stepper, filt, 0.98 * nu_star, rho0, steps)
    hi = _advect(stepper, filt, 1.02 * nu_star, rho0, steps)
    grow_lo = np.max(np.abs(lo - lo.mean())) / size0
    grow_hi = np.max(np.abs(hi - hi.mean())) / size0
    assert grow_lo < 1.5, grow_lo
    assert grow_hi > 50.0, grow_hi


@pytest.mark.parametrize("stepper", ["euler", "heun"])
def test_solver_unstable_without_filter_at_small_nu(stepper, rng):
    """Euler and Heun without the filter grow even at ν = 0.3 (limit 0)."""
    rho0 = 1.0 + 0.1 * rng.standard_normal(N)
    nu = 0.3
    g = np.max(np.abs(stab.amplification_factor(THETA, nu, stepper, False)))
    steps = int(math.ceil(math.log(1e4) / math.log(g)))
    rho = _advect(stepper, False, nu, rho0, steps)
    assert np.max(np.abs(rho - rho.mean())) / np.max(np.abs(rho0 - rho0.mean())) > 50.0


def _seed_variant_step(v, nu, coeffs, filt):
    """One step of the seed's section-5.4 scheme as a stencil (not the shipped solver): the k-th
    term of the stability polynomial uses D1^(k mod 2) D2^(k div 2), D1 v = (v_{m+1}-v_{m-1})/2,
    D2 v = v_{m+1} - 2 v_m + v_{m-1}; then the moving average if ``filt``."""
    d1 = lambda w: 0.5 * (np.roll(w, -1) - np.roll(w, 1))
    d2 = lambda w: np.roll(w, -1) - 2 * w + np.roll(w, 1)
    out = np.zeros_like(v)
    for k, rk in enumerate(coeffs):
        w = v.copy()
        for _ in range(k // 2):
            w = d2(w)
        if k % 2:
            w = d1(w)
        out += rk * (-nu) ** k * w
    if filt:
        out = 0.25 * (np.roll(out, 1) + 2 * out + np.roll(out, -1))
    return out


@pytest.mark.parametrize("stepper,filt", [("euler", True), ("heun", False), ("heun", True), ("kutta3", False),
                                          ("kutta3", True), ("rk4", False), ("rk4", True)])
def test_seed_variant_limits_confirmed_by_iterating_its_stencil(stepper, filt):
    """The seed-variant limits printed by `bsrflow stability` are confirmed empirically too: the
    seed's stencils iterated at 0.98x the limit stay bounded, at 1.02x they grow."""
    from bsrflow.analysis import stability as st
    limit = st.cfl_limit(stepper, filt, "seed")
    coeffs = [float(c) for c in st.stability_polynomial_coefficients(stepper)]
    gmax = st.max_amplification([1.02 * limit], stepper, filt, "seed")[0][0]
    steps = int(min(200000, max(1000, np.log(1e4) / np.log(gmax))))
    rng = np.random.default_rng(7)
    v0 = rng.standard_normal(128)
    ratios = []
    for f in (0.98, 1.02):
        v = v0 - v0.mean()
        for _ in range(steps):
            v = _seed_variant_step(v, f * limit, coeffs, filt)
        ratios.append(np.max(np.abs(v)) / np.max(np.abs(v0 - v0.mean())))
    assert ratios[0] < 1.5
    assert ratios[1] > 50


def test_cfl_limit_table_is_the_measured_one(limits):
    """The table that the configuration and Scheme check against (numerics.limits) holds the
    limits of the analysis above, rounded to 4 decimals."""
    from bsrflow.numerics.limits import CFL_LIMITS
    for (stepper, filt), value in CFL_LIMITS.items():
        assert abs(value - limits[(stepper, filt, "as_implemented")]) <= 5e-5 + 1e-9, (stepper, filt)
