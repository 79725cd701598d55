"""A faster exact algorithm for the Walton–Braun interaction integral (issue #8).

The direct quadrature sum (:func:`bsrflow.numerics.compiled.make_direct_integral`) costs
2W+1 kernel evaluations per cell, W the kernel radius in cells.  For the Walton–Braun kernel
(:func:`bsrflow.physics.kernels.walton_braun`, the seed's (4.6))

    Θ(z, u_x, u_y) = o λ (R - |z|) σ(z) (1 - ε σ(z (u_y - u_x))),     o = ±1 the orientation,

and since σ(z)² = 1 for z ≠ 0, the quadrature sum at cell i splits into

    I_i = o λ (E_i - ε V_i),
    E_i = Σ_{k=1}^{W} b_k (ρ_{i+k} - ρ_{i-k})                          (elastic part)
    V_i = Σ_{k=1}^{W} b_k (ρ_{i+k} σ(u_{i+k} - u_i) + ρ_{i-k} σ(u_{i-k} - u_i))   (friction)

with b_k = w_k (R - |z_k|) the quadrature weight times the kernel's hat [m²].  Then:

* **Empty window** (ρ = 0 on all 2W+1 nodes): I_i = 0.
* **Elastic part in O(1)**: for the trapezoidal rule b_k = β (W - k) is linear in k, so
  E_i = β (A_i - B_i) with triangular window sums A_i = Σ (W-k) ρ_{i+k}, B_i = Σ (W-k) ρ_{i-k}
  that slide from cell to cell with two running box sums (re-computed from scratch every
  ``ANCHOR`` cells, so round-off cannot accumulate).  Other rules: a vectorised O(W) loop.
* **Friction part in O(1) where u is monotone over the window**: strictly increasing u gives
  σ(u_{i±k} - u_i) = ±1 and V_i = E_i; strictly decreasing gives V_i = -E_i; constant u
  (e.g. the extended velocity above a column) gives V_i = 0.  Monotonicity is tracked with
  run lengths of σ(u_{j+1} - u_j) at the window's leading edge, O(1) per cell.
* Elsewhere (the velocity is not monotone over the window: near extrema, at rest with
  round-off chatter) V_i by a branch-free loop that the compiler vectorises.

The result equals the direct sum up to round-off (the terms are added in a different order):
``tests/test_fast_integral.py`` checks this on random, monotone, piecewise-constant and
tapped-column states, with both quadratures and both orientations.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["walton_braun_integral", "ANCHOR"]

ANCHOR = 64
"""Cells between re-computations of the sliding window sums."""


@numba.njit(cache=True)
def _window_sums(rp, ii, W):
    """A = Σ_{k=1}^{W-1} (W-k) ρ_{ii+k},  U = Σ_{k=2}^{W} ρ_{ii+k},
    B = Σ_{k=1}^{W-1} (W-k) ρ_{ii-k},  L = Σ_{k=1}^{W-1} ρ_{ii-k}."""
    A = 0.0
    B = 0.0
    U = 0.0
    L = 0.0
    for k in range(1, W):
        A += (W - k) * rp[ii + k]
        B += (W - k) * rp[ii - k]
        L += rp[ii - k]
        U += rp[ii + k + 1]
    return A, U, B, L


@numba.njit(cache=True, fastmath=True)
def _friction_sum(up, rp, ii, W, bb):
    """V_i = Σ_{k=-W}^{W} b_|k| ρ_{i+k} σ(u_{i+k} - u_i) (bb[W] = 0), written with unsigned
    indices and selects so that the compiler vectorises it."""
    ui = up[ii]
    base = np.uint64(ii - W)
    sp = 0.0
    sm = 0.0
    for k in range(np.uint64(2 * W + 1)):
        j = base + k
        x = bb[k] * rp[j]
        sp += x if up[j] > ui else 0.0
        sm += x if up[j] < ui else 0.0
    return sp - sm


@numba.njit(cache=True, fastmath=True)
def _elastic_sum(rp, ii, W, bs):
    """E_i = Σ_{k=-W}^{W} σ(k) b_|k| ρ_{i+k} (bs = σ(k) b_|k|)."""
    base = np.uint64(ii - W)
    s = 0.0
    for k in range(np.uint64(2 * W + 1)):
        s += bs[k] * rp[base + k]
    return s


@numba.njit(cache=True)
def walton_braun_integral(up, rp, G, N, W, qz, qw, kp, out):
    """I_i for the Walton–Braun kernel, kp = (λ, ε, R, orientation), from padded arrays
    (G >= W ghost cells); the same call signature and result as the direct quadrature sum."""
    lam = kp[0]
    eps = kp[1]
    R = kp[2]
    coef = kp[3] * lam
    # hat weights b_k = w_k (R - |z_k|), k = 0..W (symmetric)
    b = np.empty(W + 1)
    for k in range(W + 1):
        b[k] = qw[W + k] * (R - abs(qz[W + k]))
    bb = np.empty(2 * W + 1)                   # b_|k|, k = -W..W, with the node k = 0 left out
    bs = np.empty(2 * W + 1)                   # σ(k) b_|k|
    for k in range(-W, W + 1):
        bb[k + W] = b[abs(k)] if k != 0 else 0.0
        bs[k + W] = bb[k + W] * (1.0 if k > 0 else -1.0) if k != 0 else 0.0
    # linear weights (trapezoidal rule): b_k = β (W - k)
    beta = b[1] / (W - 1) if W > 1 else 0.0
    linear = W > 1
    for k in range(1, W + 1):
        if abs(b[k] - beta * (W - k)) > 1e-12 * abs(beta) * W:
            linear = False
    # Window of cell i: padded nodes ii-W..ii+W (ii = G+i).  Track the last node index j at
    # which the differences d_j = u_{j+1} - u_j break strict increase, strict decrease or
    # equality, and the last node with ρ != 0; the window is monotone / constant / empty when
    # that index lies before its start.  Branch-free updates (selects).
    no_inc = -1
    no_dec = -1
    no_eq = -1
    nz = -1
    for j in range(G - W, G + W - 1):
        d = up[j + 1] - up[j]
        no_inc = j if d <= 0.0 else no_inc
        no_dec = j if d >= 0.0 else no_dec
        no_eq = j if d != 0.0 else no_eq
    for j in range(G - W, G + W):
        nz = j if rp[j] != 0.0 else nz
    A = 0.0
    U = 0.0
    B = 0.0
    L = 0.0
    E = 0.0
    anchor = 0
    for i in range(N):
        ii = G + i
        j = ii + W - 1
        d = up[j + 1] - up[j]
        no_inc = j if d <= 0.0 else no_inc
        no_dec = j if d >= 0.0 else no_dec
        no_eq = j if d != 0.0 else no_eq
        nz = ii + W if rp[ii + W] != 0.0 else nz
        start = ii - W
        if linear:
            if anchor == 0:
                A, U, B, L = _window_sums(rp, ii, W)
                anchor = ANCHOR
            anchor -= 1
            E = beta * (A - B)
            if i + 1 < N:                      # slide to cell i+1
                A = A - (W - 1) * rp[ii + 1] + U
                U = U - rp[ii + 2] + rp[ii + W + 1]
                B = B + (W - 1) * rp[ii] - L
                L = L + rp[ii] - rp[ii - W + 1]
        if nz < start:
            out[i] = 0.0
            continue
        if not linear:
            E = _elastic_sum(rp, ii, W, bs)
        if no_eq < start:
            out[i] = coef * E
        elif no_inc < start:
            out[i] = coef * E * (1.0 - eps)
        elif no_dec < start:
            out[i] = coef * E * (1.0 + eps)
        else:
            out[i] = coef * (E - eps * _friction_sum(up, rp, ii, W, bb))
