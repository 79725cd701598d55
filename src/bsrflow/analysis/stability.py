"""Von Neumann stability of the semidiscrete scheme for linear advection (seed section 5.4).

The model problem is the frozen-coefficient linear advection equation

    u_t + a u_x = 0                                                              (5.4 start)

on a uniform grid, Δx [m], Δt [s], a [m/s], with Courant number ν = a Δt / Δx
(the seed's a λ, λ = Δt/Δx).  A Fourier mode u_m^n = g(θ)^n e^{imθ}, θ = k Δx ∈ [-π, π],
is multiplied by the amplification factor g(θ; ν) per time step.  The scheme is stable
when max_θ |g| <= 1.

Symbols of the difference operators (dimensionless, multiplied by Δx^k):

    D1 u_m = (u_{m+1} - u_{m-1}) / 2                         σ1(θ) = i sin θ
    D2 u_m = u_{m+1} - 2 u_m + u_{m-1}                       σ2(θ) = -4 sin²(θ/2)
    D3 u_m = (u_{m+2} - 2u_{m+1} + 2u_{m-1} - u_{m-2}) / 2   σ3(θ) = σ1 σ2  (the seed's u_xxx)
    D4 u_m = u_{m+2} - 4u_{m+1} + 6u_m - 4u_{m-1} + u_{m-2}  σ4(θ) = σ2²    (RK4 extension)

and of the moving average (1/4, 1/2, 1/4) applied after every full step (after (4.24)):

    M(θ) = (e^{iθ} + 2 + e^{-iθ}) / 4 = cos²(θ/2).

An explicit Runge-Kutta tableau (A, b) applied to y' = λ y gives y_{n+1} = R(z) y_n with the
stability polynomial R(z) = Σ_k r_k z^k, r_0 = 1, r_k = b^T A^{k-1} 1 (for euler, heun, kutta3
and rk4, r_k = 1/k! for k <= order: R is the Taylor polynomial of e^z).

Two variants are analysed.

``as_implemented``
    The solver (``numerics.compiled``) evaluates the central difference in *every* RK stage,
    so the semidiscrete operator is L = -(a/Δx) D1 with symbol -i (a/Δx) sin θ, and

        g(θ; ν) = R(-i ν sin θ) · [cos²(θ/2) if the filter is on].

    The powers of D1 are wide stencils: D1² has symbol -sin²θ (it is (u_{m+2}-2u_m+u_{m-2})/4),
    which vanishes at θ = π (the odd-even mode is invisible to it).  This is exact for the
    implementation: ``tests/test_stability.py`` checks that the Fourier coefficients of the
    solver's state are multiplied by exactly this g per step.

``seed``
    Section 5.4's derivation: expand the stages with continuous derivatives,
    u^{n+1} = Σ_k r_k (-a Δt ∂_x)^k u^n, and only then discretise each ∂_x^k with a compact
    stencil: ∂_x → D1, ∂_xx → D2, ∂_xxx → D3 as printed in 5.4 (Heun: the Lax-Wendroff
    scheme; RK3: the seed's five-point scheme), and, extending the same procedure by one
    term for RK4, ∂_xxxx → D4 (the standard five-point fourth difference, = D2²).  In general
    ∂_x^k → D1^{k mod 2} D2^{k div 2}, so

        g(θ; ν) = Σ_k r_k (-ν)^k σ1^{k mod 2} σ2^{k div 2} · [cos²(θ/2) if filter].

    Forward Euler is the same in both variants (FTCS).  For higher orders this is NOT the
    scheme that the solver (or the seed's own RK3 code, (4.17)-(4.24)) runs.

CFL limit
---------
:func:`cfl_limit` returns the end of the stability interval: the largest ν* such that
max_θ |g(θ; ν')| <= 1 + 1e-12 for every ν' in (0, ν*].

|g|² - 1 is a polynomial in s = sin²(θ/2) ∈ [0, 1] and ν (:func:`excess_polynomial`): every
coefficient of the unfiltered g = Σ_k α_k ν^k is α_k = (i sin θ)^{k mod 2} A_k(s) with A_k a
real polynomial (sin²θ = 4s(1 - s)), so

    |g|² - 1 = M² Σ_{n>=1} β_n(s) ν^n - (1 - M²),   β_n = Σ_{j+k=n} Re(α_j conj α_k),
    M = 1 - s (filter) or 1,   1 - M² = s (2 - s).

It is built in exact rational arithmetic, so identical cancellations (Heun's ν² term) are
exact.  For one ν the maximum over θ ∈ [0, π] (|g(-θ)| = |g(θ)|) is taken over s = 0, s = 1
and the real critical points of that polynomial (roots of its s-derivative, found in powers of
s and of 1 - s), evaluated from the polynomial where s < 0.01 (so that the tangency of the
filtered |g| with 1 at θ = 0 is resolved) and from the complex g elsewhere.  This is the
"dense θ grid plus local refinement" made exact; the tests check it against a dense grid of
2e4 θ values.  ν is scanned in steps of 0.01 from 0 up to ``nu_max`` and the first unstable
step is bisected to 1e-9.  A scheme whose |g| exceeds 1 for arbitrarily small ν > 0 (FTCS,
Heun without filter: |g|² = 1 + ν⁴ sin⁴θ / 4) gets the limit 0: this is decided from the
sign of the lowest non-vanishing power of ν in (|g|² - 1)/s, not by the tolerance, which
would otherwise accept Heun up to ν ≈ (8e-12)^(1/4) ≈ 1.7e-3.  Where |g| touches 1
tangentially at θ = 0 (Euler + filter) the 1e-12 tolerance moves the computed limit above
the exact one by ≈ 1e-6 (0.7071079 against 1/√2 = 0.7071068).

Results (``bsrflow stability``)::

    stepper filter  as_implemented   seed variant   seed's claim
    euler   no      0                0              unstable
    euler   yes     0.707107 (1/√2)  0.707107       1/√2
    heun    no      0                1 (Lax-Wendroff)
    heun    yes     1.528934         1.496177       1
    kutta3  no      1.732051 (√3)    1
    kutta3  yes     2.338843         1.704173       1
    rk4     no      2.828427 (2√2)   1.732051 (√3)
    rk4     yes     3.100994         2.219604

The seed states 1/√2 (Euler + filter), 1 (Heun + filter) and 1 (RK3 + filter).  1/√2 is
right (|g| touches 1 tangentially at θ = 0).  For Heun and RK3 the value 1 is the limit of
the seed variant *without* the filter (Lax-Wendroff; the seed's |ḡ|² of Figure 5.3, which at
ν = 1 is 1 - (16/9) s²(1-s)(3-s)); the seed's "necessary and sufficient" for Heun with the
filter is only sufficient: the factor cos⁴(θ/2) absorbs the growth of [1 + 4ν²(ν²-1) s²]
up to ν ≈ 1.496, and RK3's up to ν ≈ 1.704.  The implemented scheme (every stage a central
difference, so the higher "derivatives" are the wide stencils D1^k, whose symbols vanish at
θ = π) is a different scheme again: √3 and 2√2 (the imaginary-axis limits of RK3 and RK4)
without the filter, and ≈ 1.529 (Heun), ≈ 2.339 (RK3), ≈ 3.101 (RK4) with it, where the
worst mode is near θ ≈ 1-1.5 instead of θ = π.  Closed forms: Euler + filter
(1 + 4ν² s c) c² <= 1 with c = cos²(θ/2), s = 1 - c  ⇔  4ν² c³ <= 1 + c  ⇔  ν <= 1/√2;
Heun + filter (as implemented) (1 + 4ν⁴ s² c²) c² <= 1  ⇔  4ν⁴ s c⁴ <= 1 + c, worst at
c* = (√17 - 1)/4, ν*⁴ = (1 + c*)/(4 (1 - c*) c*⁴), ν* = 1.528934 (:func:`heun_filter_limit`).

These are limits for linear advection, ν = a Δt/Δx; the solver's ``Scheme.cfl`` uses
a = max|u| + sqrt(κ max ρ).  The seed preset (RK3 + filter, ν = 0.5) is well inside.

``bsrflow stability [--json PATH] [--figures DIR]`` prints the table, writes
``{"limits": [{"stepper", "filter", "variant", "cfl_limit"}]}`` and figures like the seed's
5.1-5.4 (:func:`write_figures`).
"""

from __future__ import annotations

import functools
import json
import math
import os
from fractions import Fraction

import numpy as np

from ..numerics.steppers import get_stepper

__all__ = ["STEPPER_NAMES", "VARIANTS", "SEED_CLAIMS", "amplification_factor", "excess",
           "max_amplification", "excess_polynomial", "stability_polynomial_coefficients", "cfl_limit", "cfl_table", "format_table", "heun_filter_limit",
           "write_figures", "add_parser"]

STEPPER_NAMES = ("euler", "heun", "kutta3", "rk4")
VARIANTS = ("as_implemented", "seed")
TOL = 1e-12
# the seed's stated limits (section 5.4): (stepper, filter) -> |a λ| limit
SEED_CLAIMS = {("euler", False): 0.0, ("euler", True): 1.0 / math.sqrt(2.0),
               ("heun", True): 1.0, ("kutta3", True): 1.0}

# -- validation -----------------------------------------------------------------------------
def _check(stepper, variant):
    if stepper not in STEPPER_NAMES:
        raise ValueError(f"stepper = {stepper!r} is not one of {list(STEPPER_NAMES)}")
    if variant not in VARIANTS:
        raise ValueError(f"variant = {variant!r} is not one of {list(VARIANTS)}")


def _check_nu(nu):
    nu = np.asarray(nu, dtype=float)
    if not np.all(np.isfinite(nu)) or np.any(nu < 0):
        raise ValueError(f"nu = {nu!r} is outside the valid range [0, inf) (Courant number a Δt/Δx)")
    return nu


@functools.lru_cache(maxsize=None)
def stability_polynomial_coefficients(stepper) -> tuple:
    """r_k, k = 0..s, of R(z) = 1 + z b^T (I - zA)^{-1} 1 = Σ_k r_k z^k (r_k = b^T A^{k-1} 1),
    as exact fractions (the tableau entries are rationals with small denominators)."""
    tb = get_stepper(stepper)
    a = [[Fraction(x).limit_denominator(10 ** 6) for x in row] for row in tb.a]
    b = [Fraction(x).limit_denominator(10 ** 6) for x in tb.b]
    s = tb.stages
    r = [Fraction(1)]
    v = [Fraction(1)] * s
    for _ in range(s):
        r.append(sum(bi * vi for bi, vi in zip(b, v)))
        v = [sum(a[i][j] * v[j] for j in range(s)) for i in range(s)]
    return tuple(r)


# polynomials in one variable: lists of Fractions, lowest power first
def _pmul(p, q):
    out = [Fraction(0)] * (len(p) + len(q) - 1)
    for i, x in enumerate(p):
        if x:
            for j, y in enumerate(q):
                out[i + j] += x * y
    return out


def _padd(p, q):
    n = max(len(p), len(q))
    return [(p[i] if i < len(p) else 0) + (q[i] if i < len(q) else 0) for i in range(n)]


def _pscale(p, c):
    return [c * x for x in p]


def _ppow(p, m):
    out = [Fraction(1)]
    for _ in range(m):
        out = _pmul(out, p)
    return out


@functools.lru_cache(maxsize=None)
def excess_polynomial(stepper, filter, variant) -> np.ndarray:
    """Coefficients C[a, b] with |g(θ; ν)|² - 1 = Σ_{a,b} C[a, b] s^a ν^b, s = sin²(θ/2) ∈ [0, 1].

    With σ1 = i sin θ, sin²θ = 4s(1 - s), σ2 = -4s, every coefficient of the unfiltered
    g = Σ_k α_k ν^k is α_k = (i sin θ)^{k mod 2} A_k(s) with a real polynomial A_k:
    as implemented A_k = (-1)^k r_k (-4s(1-s))^{k div 2}, seed A_k = (-1)^k r_k (-4s)^{k div 2}.
    Then |g|²-1 = M² Σ_n β_n ν^n - (1 - M²), β_n = Σ_{j+k=n, j≡k (2)} A_j A_k [4s(1-s) if j odd],
    M = 1 - s (filter) or 1.  Built in exact rational arithmetic, so cancellations (e.g. the
    ν² terms of Heun, which vanish identically) are exact; returned as floats.
    """
    _check(stepper, variant)
    r = stability_polynomial_coefficients(stepper)
    one = Fraction(1)
    q = [Fraction(0), Fraction(-4), Fraction(4)] if variant == "as_implemented" else [Fraction(0), Fraction(-4)]
    A = [_pscale(_ppow(q, k // 2), (-one) ** k * rk) for k, rk in enumerate(r)]
    sin2 = [Fraction(0), Fraction(4), Fraction(-4)]                   # sin²θ = 4s - 4s²
    nmax = 2 * (len(r) - 1)
    betas = []
    for n in range(1, nmax + 1):
        bn = [Fraction(0)]
        for j in range(len(r)):
            k = n - j
            if 0 <= k < len(r) and (j - k) % 2 == 0:
                term = _pmul(A[j], A[k])
                if j % 2:
                    term = _pmul(term, sin2)
                bn = _padd(bn, term)
        betas.append(bn)
    m2 = [one, Fraction(-2), one] if filter else [one]                 # M² = (1 - s)²
    damp = [Fraction(0), Fraction(2), -one] if filter else [Fraction(0)]   # 1 - M² = s(2 - s)
    deg_s = max(len(m2) + len(bn) - 1 for bn in betas)
    C = [[Fraction(0)] * (nmax + 1) for _ in range(max(deg_s, len(damp)))]
    for n, bn in enumerate(betas, start=1):
        for a, x in enumerate(_pmul(m2, bn)):
            C[a][n] += x
    for a, x in enumerate(damp):
        C[a][0] -= x
    arr = np.array([[float(x) for x in row] for row in C])
    nz = np.nonzero(np.any(arr != 0.0, axis=1))[0]
    arr = arr[: (nz[-1] + 1 if nz.size else 1)]
    arr.setflags(write=False)
    return arr


@functools.lru_cache(maxsize=None)
def _t_polynomial(stepper, filt, variant):
    out = _shift_to_t(excess_polynomial(stepper, filt, variant))
    out.setflags(write=False)
    return out


def _shift_to_t(C):
    """Re-expand Σ C[a, b] s^a ν^b in t = 1 - s (exactly: the entries are small rationals)."""
    out = np.zeros_like(C)
    for a in range(C.shape[0]):
        # s^a = (1 - t)^a = Σ_j binom(a, j) (-t)^j
        for j in range(a + 1):
            out[j] += math.comb(a, j) * (-1.0) ** j * C[a]
    return out


def _s_coefficients(C, nu):
    """c_a(ν) = Σ_b C[a, b] ν^b for each ν: shape (nν, deg_s + 1)."""
    nu = np.atleast_1d(nu).astype(float)
    out = np.zeros((nu.size, C.shape[0]))
    for b in range(C.shape[1] - 1, -1, -1):                            # Horner in ν
        out = out * nu[:, None] + C[:, b][None, :]
    return out


def _critical_points(c):
    """Real roots in [0, 1] of d/dx Σ_a c[a] x^a."""
    d = np.array([a * c[a] for a in range(1, c.size)])
    out = []
    if d.size > 1 and np.any(d != 0.0):
        d = d[: np.nonzero(d)[0][-1] + 1]
        if d.size > 1:
            for z in np.roots(d[::-1]):
                if abs(z.imag) <= 1e-7 * max(1.0, abs(z)) and -1e-12 <= z.real <= 1.0 + 1e-12:
                    out.append(min(max(z.real, 0.0), 1.0))
    return out


def _max_over_s(c):
    """max over s ∈ [0, 1] of Σ_a c[a] s^a (endpoints and real critical points)."""
    cand = np.array([0.0, 1.0] + _critical_points(c))
    vals = np.polynomial.polynomial.polyval(cand, c)
    k = int(np.argmax(vals))
    return float(vals[k]), float(cand[k])


def _max_excess(nu, stepper, filt, variant):
    """max over θ of |g(θ; ν)|² - 1 and the s = sin²(θ/2) where it is attained (one ν).

    Candidates: s = 0, 1 and the critical points of the exact polynomial, found both in
    powers of s and of t = 1 - s (each well conditioned at its own end).  Each candidate is
    evaluated with the polynomial in s where s < 0.01 (|g|² - 1 is tiny and the tangency at
    θ = 0 must be resolved) and from the complex g elsewhere (absolute error ~1e-16, better
    than the polynomial's cancellations in the middle and near s = 1)."""
    C = excess_polynomial(stepper, filt, variant)
    cs = _s_coefficients(C, nu)[0]
    ct = _s_coefficients(_t_polynomial(stepper, filt, variant), nu)[0]
    cand = [0.0, 1.0] + _critical_points(cs) + [1.0 - t for t in _critical_points(ct)]
    cand = np.unique(np.clip(np.array(cand), 0.0, 1.0))
    theta = 2.0 * np.arcsin(np.sqrt(cand))
    direct = np.abs(amplification_factor(theta, nu, stepper, filt, variant)) ** 2 - 1.0
    poly = np.polynomial.polynomial.polyval(cand, cs)
    vals = np.where(cand < 0.01, poly, direct)
    k = int(np.argmax(vals))
    return float(vals[k]), float(cand[k])


def amplification_factor(theta, nu, stepper="kutta3", filter=False, variant="as_implemented"):
    """g(θ; ν) (complex, dimensionless) for u_t + a u_x = 0, ν = a Δt/Δx, θ = k Δx [rad].

    ``theta`` and ``nu`` broadcast.  ``variant``: 'as_implemented' (g = R(-iν sin θ)·M) or
    'seed' (section 5.4's derivation); ``filter``: multiply by M(θ) = cos²(θ/2).
    Evaluated directly from the complex symbols (independent of :func:`excess_polynomial`).
    """
    _check(stepper, variant)
    nu = _check_nu(nu)
    theta, nu = np.broadcast_arrays(np.asarray(theta, dtype=float), nu)
    r = [float(x) for x in stability_polynomial_coefficients(stepper)]
    s1 = 1j * np.sin(theta)                       # central difference D1
    s2 = -4.0 * np.sin(0.5 * theta) ** 2          # compact second difference D2
    g = np.zeros(theta.shape, dtype=complex)
    for k, rk in enumerate(r):
        sym = s1 ** k if variant == "as_implemented" else s1 ** (k % 2) * s2 ** (k // 2)
        g = g + rk * (-nu) ** k * sym
    if filter:
        g = g * np.cos(0.5 * theta) ** 2
    return g


def excess(theta, nu, stepper="kutta3", filter=False, variant="as_implemented"):
    """|g(θ; ν)|² - 1 from :func:`excess_polynomial` (accurate where it is tiny).
    Returns shape (nν, nθ)."""
    C = excess_polynomial(stepper, bool(filter), variant)
    theta = np.atleast_1d(np.asarray(theta, dtype=float))
    s = np.sin(0.5 * theta) ** 2
    c = _s_coefficients(C, np.atleast_1d(_check_nu(nu)))
    return np.stack([np.polynomial.polynomial.polyval(s, ci) for ci in c])


def max_amplification(nu, stepper="kutta3", filter=False, variant="as_implemented"):
    """max_θ |g(θ; ν)| for each ν (array) and the θ ∈ [0, π] [rad] where it is attained."""
    _check(stepper, variant)
    nu = np.atleast_1d(_check_nu(nu))
    e = np.empty(nu.size)
    th = np.empty(nu.size)
    for i, n in enumerate(nu):
        e[i], s = _max_excess(float(n), stepper, bool(filter), variant)
        th[i] = 2.0 * math.asin(math.sqrt(s))
    return np.sqrt(np.maximum(1.0 + e, 0.0)), th


def _unstable_near_zero(C):
    """True if |g| > 1 for every small ν > 0.

    |g|² - 1 vanishes at s = 0, so write it as s q(s, ν).  As ν → 0 the sign of q is that of
    its lowest power of ν whose coefficient (a polynomial in s) is not identically zero:
    ν⁰ with the filter (-(2 - s) < 0: stable for small ν), otherwise ν² or ν⁴.  Unstable
    near zero if that coefficient is positive somewhere in [0, 1]."""
    q = C[1:]
    for b in range(q.shape[1]):
        col = q[:, b]
        if np.any(col != 0.0):
            return _max_over_s(col)[0] > 1e-12 * np.abs(col).sum()
    return False


def cfl_limit(stepper="kutta3", filter=False, variant="as_implemented", *, tol=TOL, nu_max=8.0,
              dnu=0.01, xtol=1e-9):
    """The CFL limit ν* (dimensionless, ν = a Δt/Δx): the largest ν such that
    max_θ |g(θ; ν')| <= 1 + ``tol`` for all 0 < ν' <= ν; 0 if no ν > 0 is stable.

    stepper : 'euler', 'heun', 'kutta3', 'rk4';  filter : moving average after every step;
    variant : 'as_implemented' or 'seed' (see the module docstring).
    tol in [0, 1e-6]; nu_max in (0, 100]: the scan range (ValueError if still stable there);
    dnu in (0, 0.1]: scan step; xtol in (0, 1e-4]: bisection tolerance.
    """
    _check(stepper, variant)
    if not (0.0 <= tol <= 1e-6):
        raise ValueError(f"tol = {tol!r} is outside the valid range [0, 1e-6]")
    if not (0.0 < nu_max <= 100.0):
        raise ValueError(f"nu_max = {nu_max!r} is outside the valid range (0, 100]")
    if not (0.0 < dnu <= 0.1):
        raise ValueError(f"dnu = {dnu!r} is outside the valid range (0, 0.1]")
    if not (0.0 < xtol <= 1e-4):
        raise ValueError(f"xtol = {xtol!r} is outside the valid range (0, 1e-4]")
    C = excess_polynomial(stepper, bool(filter), variant)
    thr = (1.0 + tol) ** 2 - 1.0
    if _unstable_near_zero(C):
        return 0.0

    def unstable(nu):
        return _max_excess(nu, stepper, bool(filter), variant)[0] > thr

    lo = 0.0
    nu = dnu
    while not unstable(nu):
        lo = nu
        nu += dnu
        if nu > nu_max:
            raise ValueError(f"{stepper} (filter={bool(filter)}, {variant}) is stable up to "
                             f"nu_max = {nu_max}; increase nu_max")
    hi = nu
    while hi - lo > xtol:
        mid = 0.5 * (lo + hi)
        if unstable(mid):
            hi = mid
        else:
            lo = mid
    return float(lo)


def heun_filter_limit() -> float:
    """Closed form of the as-implemented Heun + filter limit: with c = cos²(θ/2),
    |g|² = (1 + 4ν⁴(1-c)²c²) c² <= 1 ⇔ 4ν⁴(1-c)c⁴ <= 1 + c; the worst c solves
    2c² + c - 2 = 0, c* = (√17 - 1)/4, so ν*⁴ = (1 + c*) / (4 (1 - c*) c*⁴)."""
    c = (math.sqrt(17.0) - 1.0) / 4.0
    return ((1.0 + c) / (4.0 * (1.0 - c) * c ** 4)) ** 0.25


def cfl_table():
    """All limits: list of {"stepper", "filter", "variant", "cfl_limit"}."""
    rows = []
    for st in STEPPER_NAMES:
        for filt in (False, True):
            for var in VARIANTS:
                rows.append({"stepper": st, "filter": filt, "variant": var,
                             "cfl_limit": cfl_limit(st, filt, var)})
    return rows


def format_table(rows) -> str:
    lim = {(r["stepper"], r["filter"], r["variant"]): r["cfl_limit"] for r in rows}
    lines = ["CFL limits nu* = a dt/dx for u_t + a u_x = 0 (max |g| <= 1 + 1e-12)",
             f"{'stepper':8s} {'filter':6s} {'as_implemented':>15s} {'seed variant':>13s} {'seed claims':>12s}"]
    for st in STEPPER_NAMES:
        for filt in (False, True):
            claim = SEED_CLAIMS.get((st, filt))
            lines.append(f"{st:8s} {('yes' if filt else 'no'):6s} "
                         f"{lim.get((st, filt, 'as_implemented'), float('nan')):15.6f} "
                         f"{lim.get((st, filt, 'seed'), float('nan')):13.6f} "
                         f"{('-' if claim is None else f'{claim:.6f}'):>12s}")
    return "\n".join(lines)


# -- figures --------------------------------------------------------------------------------
FIGURE_NU = {"euler": 1.0 / math.sqrt(2.0), "heun": 1.0, "kutta3": 1.0, "rk4": 1.0}


def write_figures(outdir, rows=None):
    """Write figures like the seed's 5.1-5.4 to ``outdir`` and return their paths.

    ``stability_<stepper>.png``: g(θ) in the complex plane against the unit circle (left) and
    |g|² against θ (right), at the seed's ν (1/√2 for Euler, 1 otherwise), with and without
    the filter, both variants.  ``stability_max_g.png``: max_θ |g| - 1 against ν for every
    scheme, with the computed limits marked.
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    os.makedirs(outdir, exist_ok=True)
    if rows is None:
        rows = cfl_table()
    lim = {(r["stepper"], r["filter"], r["variant"]): r["cfl_limit"] for r in rows}
    paths = []
    th = np.linspace(-np.pi, np.pi, 1201)
    styles = {("as_implemented", False): ("C0", "-"), ("as_implemented", True): ("C3", "-"),
              ("seed", False): ("C0", "--"), ("seed", True): ("C3", "--")}
    for st in STEPPER_NAMES:
        nu = FIGURE_NU[st]
        fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.8))
        phi = np.linspace(0, 2 * np.pi, 400)
        ax1.plot(np.cos(phi), np.sin(phi), color="0.5", lw=1, label="unit circle")
        for var in VARIANTS:
            for filt in (False, True):
                g = amplification_factor(th, nu, st, filt, var)
                col, ls = styles[(var, filt)]
                lab = f"{var}, {'filter' if filt else 'no filter'}"
                ax1.plot(g.real, g.imag, color=col, ls=ls, label=lab)
                ax2.plot(th, np.abs(g) ** 2, color=col, ls=ls, label=lab)
        ax1.set_aspect("equal")
        ax1.set_xlabel("Re g(θ)")
        ax1.set_ylabel("Im g(θ)")
        same = " (both variants coincide)" if st == "euler" else ""
        ax1.set_title(f"{st}: g(θ) for ν = a Δt/Δx = {nu:.4g}{same}", fontsize=10)
        ax1.legend(fontsize=7, loc="lower left")
        ax1.grid(alpha=0.3)
        ax2.axhline(1.0, color="0.5", lw=1)
        ax2.set_xlabel("θ = k Δx [rad]")
        ax2.set_ylabel("|g(θ)|²")
        ax2.set_title(f"{st}: |g|² for ν = {nu:.4g}")
        ax2.grid(alpha=0.3)
        fig.tight_layout()
        p = os.path.join(outdir, f"stability_{st}.png")
        fig.savefig(p, dpi=110)
        plt.close(fig)
        paths.append(p)
    fig, axes = plt.subplots(2, 2, figsize=(11, 8), sharex=True)
    nus = np.linspace(0.0, 3.5, 176)
    for ax, st in zip(axes.ravel(), STEPPER_NAMES):
        for var in VARIANTS:
            for filt in (False, True):
                col, ls = styles[(var, filt)]
                gm, _ = max_amplification(nus, st, filt, var)
                ax.plot(nus, gm - 1.0, color=col, ls=ls,
                        label=f"{var}, {'filter' if filt else 'no filter'}: ν* = {lim[(st, filt, var)]:.4f}")
                ax.axvline(lim[(st, filt, var)], color=col, ls=ls, lw=0.6)
        ax.axhline(0.0, color="0.5", lw=1)
        ax.set_yscale("symlog", linthresh=1e-6)
        ax.set_ylim(bottom=0.0)
        ax.set_title(st)
        ax.set_ylabel("max_θ |g| - 1")
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("Courant number ν = a Δt/Δx")
    fig.tight_layout()
    p = os.path.join(outdir, "stability_max_g.png")
    fig.savefig(p, dpi=110)
    plt.close(fig)
    paths.append(p)
    return paths


# -- command line ---------------------------------------------------------------------------
def add_parser(sub):
    p = sub.add_parser("stability", help="von Neumann CFL limits of the steppers (seed section 5.4)",
                       description="Compute the CFL limits of every stepper with and without the "
                                   "moving average, as implemented and as derived in the seed.")
    p.add_argument("--json", metavar="PATH", help="write {'limits': [...]} to PATH (its folder must exist)")
    p.add_argument("--figures", metavar="DIR", help="write figures like the seed's 5.1-5.4 to DIR "
                   "(created if missing; the folder holding it must exist)")
    p.set_defaults(func=func)


def func(args) -> int:
    from ..io.paths import check_distinct, check_output_dir, check_output_file
    check_distinct(("--json", getattr(args, "json", None)), ("--figures", getattr(args, "figures", None)))
    if getattr(args, "json", None):
        check_output_file(args.json, "--json")
    if getattr(args, "figures", None):
        check_output_dir(args.figures, "--figures")
    rows = cfl_table()
    print(format_table(rows))
    if getattr(args, "json", None):
        with open(args.json, "w") as fh:
            json.dump({"limits": rows}, fh, indent=2)
        print(f"wrote {args.json}")
    if getattr(args, "figures", None):
        for p in write_figures(args.figures, rows):
            print(f"wrote {p}")
    return 0
