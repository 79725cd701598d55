"""Local wave speed (seed Appendix A) and the sound speed of the linearised BSR model.

Units: x, z, R [m]; ρ [kg/m] (mass per length); u [m/s]; Θ [m s⁻² kg⁻¹]; the interaction
acceleration ("force per unit mass") F [m/s²]; its potential Φ [m²/s²]; k [1/m]; c [m/s].

Appendix A, corrected
---------------------
Without gravity and inertial forces the momentum equation is (A.1)

    u_t + u u_x = F(x, t),        F = ∂Φ/∂x,   Φ(x) = ∫_{x0}^{x} F(ξ) dξ          (A.2)

For a steady perturbation (in the frame in which the wave is at rest) u u_x = Φ_x, i.e.

    ∂/∂x (u²/2 - Φ) = 0                                         (A.3)-(A.4), corrected

The seed prints u²/2 + Φ: moving F = Φ_x to the left-hand side changes its sign, and that
sign is dropped.  With the continuity equation ρ u = const (A.5), small variations give

    ρ δu = -u δρ                                                       (A.8)
    u δu = +δΦ                                                         (A.9), corrected (seed: -δΦ)

so δΦ = -u² δρ/ρ, and the speed at which the perturbation propagates relative to the
material is

    c² = -dΦ / d(log ρ)                                                (A.11)-(A.12), corrected

Check against a pressure: F = -p_x/ρ gives dΦ = -p'(ρ) dρ/ρ, so -dΦ/dlog ρ = p'(ρ), the
familiar sound speed.  For the BSR interaction with long waves,
F(x) = ∫ ρ(x+z) Θ_o(z) dz ≈ ρ_x ∫ z Θ_o(z) dz = -κ ρ_x, so Φ = -κρ + const and
c² = -dΦ/dlog ρ = κ ρ (the 1-D "pressure" is p = κρ²/2 [N]).  With the sign as printed,
(A.12) gives c² = dΦ/dlog ρ = -κρ < 0 for a repulsive (well-posed) kernel: no real speed.
It is positive only for the seed's attractive orientation of (4.6) (seed-notes problem 1),
for which the linearised model has no waves at all (ω² = -κρ0 k² < 0: exponential growth),
i.e. the two sign slips compensate each other in the seed's Figures A.1-A.2.

Dispersion relation
-------------------
Linearise about the uniform state (ρ0, u0 = 0) with the kernel's elastic part
Θ_e(z) = Θ(z, v, v) (equal velocities; for Walton-Braun Θ_e = -λ(R - |z|)σ(z)), of which only
the odd part Θ_o(z) = (Θ_e(z) - Θ_e(-z))/2 acts on a uniform state (the even part would give
a uniform acceleration ρ0 ∫Θ_e dz, zero for the kernels shipped here).  With
ρ = ρ0 + ρ̂ e^{i(kx-ωt)}, u = û e^{i(kx-ωt)}:

    -iω ρ̂ + i k ρ0 û = 0,      -iω û = i S(k) ρ̂,      S(k) = ∫_{-R}^{R} Θ_o(z) sin(kz) dz

so ω² = -ρ0 k S(k) and the phase speed is

    c(k)² = ω²/k² = -ρ0 S(k) / k  →  c0² = -ρ0 ∫ z Θ_o(z) dz = κ ρ0   (k → 0)

with κ = :meth:`Kernel.stiffness_moment`.  For Walton-Braun (κ = λR³/3)
c(k)² = 2λρ0R³ (kR - sin kR)/(kR)³ = κρ0 (1 - (kR)²/20 + O((kR)⁴)): waves shorter than the
kernel range are slower.  S(k) is computed here by adaptive quadrature (scipy ``quad`` with
the sine weight); the closed form is used only in the tests.

The dissipative part.  Walton-Braun's factor (1 - ε σ(zΔu)) adds
λε(R - |z|) σ(u(x+z) - u(x)) to Θ: a friction-like term whose size does not shrink with the
perturbation amplitude (σ is ±1 for any Δu ≠ 0) and which is not differentiable at Δu = 0.
It cannot be linearised; only the elastic part is analysed, and the solver check uses ε = 0.

Discrete counterpart: the solver's quadrature replaces ∫ z Θ_o dz by Σ_k w_k z_k Θ_o(z_k);
for the trapezoidal rule and Walton-Braun this is exactly (1 - 1/W²) times the integral
(W = R/Δx), so the scheme's long waves travel at c0 (1 - 1/W²)^{1/2}
(:func:`discrete_long_wave_speed`); Boole's rule is exact for this kernel.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import quad

from ..numerics.quadrature import QUADRATURES, quadrature_weights
from ..physics.kernels import Kernel

__all__ = ["elastic_odd_part", "kernel_sine_transform", "phase_speed_squared",
           "sound_speed_dispersion", "sound_speed_long_wave", "discrete_long_wave_speed",
           "interaction_acceleration", "LocalWaveSpeed", "local_wave_speed"]


def _check_kernel(kernel):
    if not isinstance(kernel, Kernel):
        raise ValueError(f"kernel = {kernel!r} must be a bsrflow.physics.kernels.Kernel")
    if not (kernel.radius > 0):
        raise ValueError(f"kernel radius = {kernel.radius!r} m is outside the valid range (0, inf): "
                         "a kernel without range has no sound speed")


def _check_rho0(rho0):
    if not (np.isfinite(rho0) and rho0 > 0):
        raise ValueError(f"rho0 = {rho0!r} is outside the valid range (0, inf) kg/m")
    return float(rho0)


def elastic_odd_part(kernel, z):
    """Θ_o(z) = (Θ(z, 0, 0) - Θ(-z, 0, 0))/2 [m s⁻² kg⁻¹]: the odd part of the kernel at equal
    velocities (the elastic part; the velocity-dependent factor is inactive at Δu = 0)."""
    z = np.asarray(z, dtype=float)
    zero = np.zeros_like(z)
    return 0.5 * (np.asarray(kernel(z, zero, zero)) - np.asarray(kernel(-z, zero, zero)))


def _first_moment(kernel):
    """∫_{-R}^{R} z Θ_o(z) dz = 2 ∫_0^R z Θ_o(z) dz [m³ s⁻² kg⁻¹] (negative for repulsion)."""
    R = kernel.radius
    val, _ = quad(lambda z: z * float(elastic_odd_part(kernel, z)), 0.0, R, epsabs=0.0,
                  epsrel=1e-12, limit=200)
    return 2.0 * val


def kernel_sine_transform(kernel, k):
    """S(k) = ∫_{-R}^{R} Θ_o(z) sin(kz) dz = 2 ∫_0^R Θ_o(z) sin(kz) dz [m² s⁻² kg⁻¹]
    (the kernel's Fourier symbol is i S(k)), for wavenumbers k [1/m] >= 0 (array)."""
    _check_kernel(kernel)
    k = np.atleast_1d(np.asarray(k, dtype=float))
    if not np.all(np.isfinite(k)) or np.any(k < 0):
        raise ValueError(f"k = {k!r} is outside the valid range [0, inf) 1/m")
    R = kernel.radius
    out = np.empty(k.shape)
    for i, kk in enumerate(k.ravel()):
        if kk == 0.0:
            out.flat[i] = 0.0
            continue
        val, _ = quad(lambda z: float(elastic_odd_part(kernel, z)), 0.0, R, weight="sin", wvar=kk,
                      epsabs=0.0, epsrel=1e-12, limit=200)
        out.flat[i] = 2.0 * val
    return out


def phase_speed_squared(kernel, rho0, k):
    """c(k)² = ω²/k² = -ρ0 S(k)/k [m²/s²] of the linearised model about (ρ0 [kg/m], u = 0);
    k [1/m] >= 0 (array), the k = 0 value being the long-wave limit -ρ0 ∫ z Θ_o dz.
    Negative values mean exponential growth (an attractive kernel), not waves."""
    rho0 = _check_rho0(rho0)
    _check_kernel(kernel)
    k = np.atleast_1d(np.asarray(k, dtype=float))
    S = kernel_sine_transform(kernel, k)
    out = np.empty(k.shape)
    pos = k > 0
    out[pos] = -rho0 * S[pos] / k[pos]
    if np.any(~pos):
        out[~pos] = -rho0 * _first_moment(kernel)
    return out


def sound_speed_dispersion(kernel, rho0, k):
    """Phase speed c(k) = ω/k [m/s] of small perturbations e^{i(kx-ωt)} of the uniform state
    (ρ0 [kg/m], u = 0), elastic part of ``kernel`` only (see module docstring); k [1/m] >= 0.
    NaN where c² < 0 (attractive kernel: growth instead of waves)."""
    c2 = phase_speed_squared(kernel, rho0, k)
    with np.errstate(invalid="ignore"):
        return np.where(c2 >= 0, np.sqrt(np.abs(c2)), np.nan)


def sound_speed_long_wave(kernel, rho0) -> float:
    """c0 = lim_{k→0} c(k) = sqrt(-ρ0 ∫ z Θ_o(z) dz) [m/s] (= sqrt(κ ρ0)); NaN if attractive."""
    return float(sound_speed_dispersion(kernel, rho0, [0.0])[0])


def discrete_long_wave_speed(kernel, rho0, dx, quadrature="trapezoid") -> float:
    """Long-wave speed of the semi-discrete scheme [m/s]: sqrt(-ρ0 Σ_k w_k z_k Θ_o(z_k)) with
    the solver's quadrature nodes and weights on cells of width ``dx`` [m] (R/dx a whole number
    >= 2).  The central-difference flux and the Runge-Kutta stepping do not change it."""
    rho0 = _check_rho0(rho0)
    _check_kernel(kernel)
    if quadrature not in QUADRATURES:
        raise ValueError(f"quadrature = {quadrature!r} is not one of {QUADRATURES}")
    W = _cells(kernel.radius, dx)
    z, w = quadrature_weights(W, dx, quadrature)
    m1 = float(np.sum(w * z * elastic_odd_part(kernel, z)))
    return float(np.sqrt(-rho0 * m1)) if m1 <= 0 else float("nan")


def _cells(R, dx):
    if not (np.isfinite(dx) and dx > 0):
        raise ValueError(f"dx = {dx!r} is outside the valid range (0, inf) m")
    Wf = R / dx
    W = int(round(Wf))
    if abs(Wf - W) > 1e-6 * max(1.0, Wf) or W < 2:
        raise ValueError(f"dx = {dx!r} m: the kernel radius {R!r} m must be a whole number (>= 2) "
                         f"of cells; it is {Wf:.6g}")
    return W


def interaction_acceleration(kernel, rho, dx, u=None, quadrature="trapezoid", boundary="periodic"):
    """F_i = Σ_k w_k ρ_{i+k} Θ(z_k, u_i, u_{i+k}) [m/s²], the interaction term of (4.13) with the
    solver's quadrature, for cell-centred ρ [kg/m] (and u [m/s], default 0) on cells of width
    dx [m].  boundary: 'periodic' (wrap) or 'vacuum' (ρ = 0 outside)."""
    _check_kernel(kernel)
    if quadrature not in QUADRATURES:
        raise ValueError(f"quadrature = {quadrature!r} is not one of {QUADRATURES}")
    if boundary not in ("periodic", "vacuum"):
        raise ValueError(f"boundary = {boundary!r} is not one of ('periodic', 'vacuum')")
    rho = np.asarray(rho, dtype=float)
    if rho.ndim != 1 or rho.size < 3:
        raise ValueError(f"rho has shape {rho.shape}; expected a 1-D array of at least 3 cells")
    u = np.zeros_like(rho) if u is None else np.asarray(u, dtype=float)
    if u.shape != rho.shape:
        raise ValueError(f"u has shape {u.shape}; expected {rho.shape} to match rho")
    W = _cells(kernel.radius, dx)
    if boundary == "periodic" and W >= rho.size:
        raise ValueError(f"rho has {rho.size} cells; a periodic grid needs more than the kernel's {W}")
    z, w = quadrature_weights(W, dx, quadrature)
    out = np.zeros_like(rho)
    n = rho.size
    for k in range(-W, W + 1):
        if boundary == "periodic":
            rk = np.roll(rho, -k)
            uk = np.roll(u, -k)
        else:
            rk = np.zeros(n)
            uk = np.zeros(n)
            lo, hi = max(0, -k), min(n, n - k)
            rk[lo:hi] = rho[lo + k:hi + k]
            uk[lo:hi] = u[lo + k:hi + k]
        out += w[k + W] * rk * np.asarray(kernel(np.full(n, z[k + W]), u, uk))
    return out


@dataclass
class LocalWaveSpeed:
    """Result of :func:`local_wave_speed` (arrays on the input grid).

    phi : Φ(x) = ∫_{x0}^{x} F dξ [m²/s²] (A.2), cumulative trapezoid from the first point.
    c2 : c² = -ΔΦ/Δ log ρ [m²/s²] (corrected (A.12)); NaN where not defined.
    c : sqrt(c²) [m/s]; NaN where c² < 0 or not defined.
    valid : where c² is defined (interior points with a large enough density variation).
    """

    x: np.ndarray
    phi: np.ndarray
    c2: np.ndarray
    c: np.ndarray
    valid: np.ndarray


def local_wave_speed(x, rho, force_per_mass, *, half_width=1, min_gradient=1e-2) -> LocalWaveSpeed:
    """Local wave speed c² ≈ -dΦ/d log ρ (Appendix A with the sign of (A.3) corrected).

    x [m] strictly increasing positions, rho [kg/m] > 0, force_per_mass F [m/s²] (the
    interaction acceleration only: no gravity, no inertial forces, as in (A.1)), all 1-D of
    the same length.  Φ is the cumulative trapezoidal integral of F (A.2) and

        c²_i = -(Φ_{i+h} - Φ_{i-h}) / (log ρ_{i+h} - log ρ_{i-h}),   h = ``half_width`` (>= 1)

    i.e. the ratio of the variations δΦ/δ log ρ over 2h cells.  Where the density hardly varies
    (|Δ log ρ| below ``min_gradient`` ∈ [0, 1) times its maximum over the field) the ratio is
    0/0 and is reported as NaN, as are the first and last h points.
    """
    x = np.asarray(x, dtype=float)
    rho = np.asarray(rho, dtype=float)
    F = np.asarray(force_per_mass, dtype=float)
    if x.ndim != 1 or x.size < 3:
        raise ValueError(f"x has shape {x.shape}; expected a 1-D array of at least 3 points")
    for name, a in (("rho", rho), ("force_per_mass", F)):
        if a.shape != x.shape:
            raise ValueError(f"{name} has shape {a.shape}; expected {x.shape} to match x")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name} contains non-finite values")
    if not np.all(np.diff(x) > 0):
        raise ValueError("x must be strictly increasing")
    if np.any(rho <= 0):
        raise ValueError(f"rho must be > 0 kg/m everywhere (min {rho.min():.3g}); restrict x to the material")
    h = int(half_width)
    if h != half_width or not (1 <= h < x.size // 2):
        raise ValueError(f"half_width = {half_width!r} is outside the valid range: integers 1..{x.size // 2 - 1}")
    if not (0.0 <= min_gradient < 1.0):
        raise ValueError(f"min_gradient = {min_gradient!r} is outside the valid range [0, 1)")
    phi = np.concatenate([[0.0], np.cumsum(0.5 * (F[1:] + F[:-1]) * np.diff(x))])
    logr = np.log(rho)
    dphi = np.full(x.size, np.nan)
    dlog = np.full(x.size, np.nan)
    dphi[h:-h] = phi[2 * h:] - phi[:-2 * h]
    dlog[h:-h] = logr[2 * h:] - logr[:-2 * h]
    scale = np.nanmax(np.abs(dlog)) if np.any(np.isfinite(dlog)) else 0.0
    valid = np.isfinite(dlog) & (np.abs(np.nan_to_num(dlog)) > min_gradient * scale) & (scale > 0)
    c2 = np.full(x.size, np.nan)
    c2[valid] = -dphi[valid] / dlog[valid]
    with np.errstate(invalid="ignore"):
        c = np.where(valid & (c2 >= 0), np.sqrt(np.abs(np.nan_to_num(c2))), np.nan)
    return LocalWaveSpeed(x=x, phi=phi, c2=c2, c=c, valid=valid)
