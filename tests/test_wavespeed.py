"""Local wave speed (Appendix A, corrected sign) against the linearised dispersion relation and
against pulses travelling in the actual solver.

Walton-Braun kernel, ε = 0, λ = 3/R³ and ρ0 = 1 kg/m, so κ = λR³/3 = 1 m³ s⁻² kg⁻¹ and
c0 = sqrt(κ ρ0) = 1 m/s.
"""
import numpy as np
import pytest

from bsrflow.analysis import wavespeed as ws
from bsrflow.numerics.grid import Grid1D
from bsrflow.numerics.solver import Scheme, Simulation
from bsrflow.physics.kernels import walton_braun
from bsrflow.physics.model import BSRModel

R = 0.04                 # kernel radius [m]
LAM = 3.0 / R ** 3       # strength λ [1/(kg s²)]
RHO0 = 1.0               # [kg/m]


@pytest.fixture(scope="module")
def kernel():
    return walton_braun(LAM, 0.0, R)


def _c0(kernel):
    return np.sqrt(kernel.stiffness_moment() * RHO0)


def test_dispersion_relation_matches_closed_form(kernel):
    """c(k)² = 2λρ0R³ (kR - sin kR)/(kR)³ (quadrature vs closed form), long-wave limit κρ0."""
    kR = np.array([1e-2, 0.1, 0.5, 1.0, 2.0, 5.0, 10.0])
    c = ws.sound_speed_dispersion(kernel, RHO0, kR / R)
    exact = np.sqrt(2 * LAM * RHO0 * R ** 3 * (kR - np.sin(kR)) / kR ** 3)
    assert np.max(np.abs(c / exact - 1)) < 1e-9
    # stiffness_moment integrates with a 4001-point trapezoid: relative error ~2.5e-7 in κ
    assert abs(ws.sound_speed_long_wave(kernel, RHO0) / _c0(kernel) - 1) < 1e-6
    assert abs(ws.sound_speed_long_wave(kernel, RHO0) - np.sqrt(LAM * R ** 3 / 3 * RHO0)) < 1e-12
    # shorter waves are slower: c(k)/c0 = 1 - (kR)²/40 + O((kR)⁴)
    assert np.all(np.diff(c) < 0)
    c_long = ws.sound_speed_long_wave(kernel, RHO0)
    assert abs(c[1] / c_long - (1 - 0.1 ** 2 / 40)) < 1e-6     # next term O((kR)⁴) ~ 1e-7


def test_attractive_kernel_has_no_sound_speed():
    """The seed's orientation of (4.6) (attraction): ω² = -κρ0k² < 0, growth instead of waves."""
    seed = walton_braun(LAM, 0.0, R, seed_sign=True)
    assert ws.phase_speed_squared(seed, RHO0, [0.0])[0] == pytest.approx(-1.0, rel=1e-9)
    assert np.isnan(ws.sound_speed_long_wave(seed, RHO0))


def test_local_wave_speed_sine_wave(kernel):
    """ρ = ρ0(1 + A sin kx) on a periodic grid, F from the solver's own right-hand side.

    For this field the corrected (A.12) gives exactly, up to O((kΔx)²) ≈ 1e-5,
        c²(x) = κ_h ρ(x) (1 - (kR)²/20),       κ_h = κ (1 - 1/W²)
    (trapezoid quadrature of the kernel on W cells per R, and the symbol's long-wave
    truncation).  So |c/sqrt(κρ0) - 1| <= (A + 1/W² + (kR)²/20)/2 + 1e-5, the last term
    covering the second-order products of these and the κ error (~1e-7)."""
    W = 16
    dx = R / W
    L = 64 * R
    N = int(round(L / dx))
    A = 1e-3
    grid = Grid1D(0.0, L, N, "periodic", "periodic")
    x = grid.x
    k = 2 * np.pi / L
    rho = RHO0 * (1 + A * np.sin(k * x))
    # the direct quadrature sum: this checks the formula of interaction_acceleration; the fast
    # algorithm's own agreement with the direct sum is tested in test_fast_integral.py (its
    # round-off is relative to the summands, and this nearly uniform field cancels them)
    sim = Simulation(BSRModel(kernel=kernel), grid, Scheme(dt=1e-3), integral="direct")
    F, _ = sim.rhs(np.zeros(N), rho, 0.0)          # u = 0: du/dt is the interaction term only
    assert np.max(np.abs(ws.interaction_acceleration(kernel, rho, dx) - F)) <= 1e-12 * np.max(np.abs(F))
    est = ws.local_wave_speed(x, rho, F)
    v = est.valid
    assert v.sum() > 0.95 * N
    kappa = kernel.stiffness_moment()
    # the sign: dΦ/dlog ρ < 0 for the repulsive kernel, so the printed (A.12) has no real root
    assert np.all(est.c2[v] > 0)
    # the structure of the estimate, to 1e-5
    expected = (1 - 1 / W ** 2) * (1 - (k * R) ** 2 / 20)
    assert np.max(np.abs(est.c2[v] / (kappa * rho[v]) - expected)) < 1e-5
    # against sqrt(κ ρ0) with the truncation-based tolerance
    tol = 0.5 * (A + 1 / W ** 2 + (k * R) ** 2 / 20) + 1e-5
    assert np.max(np.abs(est.c[v] / np.sqrt(kappa * RHO0) - 1)) < tol
    # the dispersion relation at this k agrees with sqrt(κρ0) to (kR)²/40
    ck = ws.sound_speed_dispersion(kernel, RHO0, [k])[0]
    assert abs(ck / np.sqrt(kappa * RHO0) - 1) < (k * R) ** 2 / 40 * 1.01 + 1e-6
    # and the semi-discrete long-wave speed is c0 sqrt(1 - 1/W²)
    assert ws.discrete_long_wave_speed(kernel, RHO0, dx) == pytest.approx(
        np.sqrt(kappa * RHO0 * (1 - 1 / W ** 2)), rel=1e-6)


@pytest.mark.parametrize("quadrature", ["trapezoid", "boole"])
def test_pulse_travels_at_sound_speed(kernel, quadrature):
    """A small Gaussian density pulse at rest splits into two halves moving at ±c.

    Periodic domain of 6 m, W = 8 cells per R, the seed's scheme (RK3 + moving average,
    ν = 0.5).  The speed is the least-squares slope of the centroid of ρ - ρ0 over each half
    of the domain, for t in [0.8, 2.0] s (the halves are then > 4σ apart from the centre and
    from the domain ends, so window leakage is < 1e-4 relative).

    Expected: the semi-discrete long-wave speed c_h = c0 sqrt(1 - 1/W²) for the trapezoid
    (0.78% below c0; exactly c0 for Boole's rule, which integrates z(R - z) exactly).  The
    centroid of a linear pulse moves at the group velocity at k = 0, c_h, whatever the
    dispersion and the filter's damping (real, symmetric factors do not move it); the
    remaining difference is nonlinear, bounded by the simple-wave speed excess
    (3/2)(δρ/ρ0) <= 0.75 A at the pulse peak: tolerance 1e-3 for A = 1e-3."""
    W = 8
    dx = R / W
    L = 6.0
    N = int(round(L / dx))
    A, sigma = 1e-3, 0.2
    grid = Grid1D(0.0, L, N, "periodic", "periodic")
    x = grid.x
    rho = RHO0 * (1 + A * np.exp(-0.5 * ((x - L / 2) / sigma) ** 2))
    sim = Simulation(BSRModel(kernel=kernel), grid,
                     Scheme(stepper="kutta3", filter=True, quadrature=quadrature, cfl=0.5))
    times = np.linspace(0.8, 2.0, 7)
    res = sim.run(np.zeros(N), rho, 2.0, save_times=np.concatenate([[0.0], times]))
    assert np.allclose(res.t[1:], times)
    speeds = []
    for half in (x > L / 2, x < L / 2):
        d = res.rho[1:, half] - RHO0
        centroid = (d * x[half]).sum(axis=1) / d.sum(axis=1)
        speeds.append(np.polyfit(times, centroid, 1)[0])
    c_right, c_left = speeds
    assert c_right == pytest.approx(-c_left, rel=1e-6)        # symmetric split
    c0 = _c0(kernel)
    c_h = ws.discrete_long_wave_speed(kernel, RHO0, dx, quadrature)
    assert abs(c_right / c_h - 1) < 1e-3
    quad_err = 1 - np.sqrt(1 - 1 / W ** 2) if quadrature == "trapezoid" else 0.0
    assert abs(c_right / c0 - 1) < quad_err + 1e-3
    # and it agrees with the local-wave-speed estimate on the initial field, at the flanks
    F, _ = sim.rhs(np.zeros(N), rho, 0.0)
    est = ws.local_wave_speed(x, rho, F, min_gradient=0.3)
    assert abs(np.nanmedian(est.c[est.valid]) / c_right - 1) < 5e-3


def test_bad_input(kernel):
    with pytest.raises(ValueError, match="rho0"):
        ws.sound_speed_dispersion(kernel, -1.0, [1.0])
    with pytest.raises(ValueError, match="k ="):
        ws.sound_speed_dispersion(kernel, 1.0, [-1.0])
    with pytest.raises(ValueError, match="rho"):
        ws.local_wave_speed(np.arange(5.0), np.array([1, 1, 0, 1, 1.0]), np.zeros(5))
    with pytest.raises(ValueError, match="x must be strictly increasing"):
        ws.local_wave_speed(np.array([0, 2, 1, 3, 4.0]), np.ones(5), np.zeros(5))
    with pytest.raises(ValueError, match="half_width"):
        ws.local_wave_speed(np.arange(5.0), np.ones(5), np.zeros(5), half_width=0)
    with pytest.raises(ValueError, match="dx"):
        ws.discrete_long_wave_speed(kernel, 1.0, R / 2.5)
