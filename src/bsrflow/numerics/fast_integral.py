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
  that slide from cell to cell with two running box sums U_i = Σ_{k=2}^{W} ρ_{i+k},
  L_i = Σ_{k=1}^{W-1} ρ_{i-k}:  A_{i+1} = A_i + (U_i - (W-1) ρ_{i+1}),
  B_{i+1} = B_i + ((W-1) ρ_i - L_i),  re-computed from scratch every ``ANCHOR`` cells, so
  round-off cannot accumulate.  Other rules: an O(W) loop per cell.
* **Friction part in O(1) where u is monotone over the window**: strictly increasing u gives
  σ(u_{i±k} - u_i) = ±1 and V_i = E_i; strictly decreasing gives V_i = -E_i; constant u
  (e.g. the extended velocity above a column) gives V_i = 0.  Monotonicity is decided from
  counts over the window of the nodes at which d_j = u_{j+1} - u_j breaks each property (and
  of the nodes with ρ != 0), four 16-bit counters packed in one integer and slid exactly from
  cell to cell, O(1) per cell (``_classify_scaled_elastic``; ``_classify`` finds the same
  classes with trackers of the last breaking node, and the tests check that they agree).
* Elsewhere (the velocity is not monotone over the window: near extrema, at rest with
  round-off chatter) V_i = Σ_{k≠0} b_|k| ρ_{i+k} [u_{i+k} > u_i] - Σ_{k≠0} b_|k| ρ_{i+k} [u_{i+k} < u_i]
  (exact ties give 0), computed for ``BLOCK`` consecutive cells at once: the cells are the
  lanes of AVX vectors, the 2W+1 offsets the loop, so each offset costs per 4 cells two
  unaligned vector loads (u_{i+k}, ρ_{i+k}), two compares, two masks and two fused
  multiply-adds into register accumulators (``_friction_block``, written as LLVM vector code
  because the compiler does not find this loop order by itself).

The passes: classify every cell (empty / constant / increasing / decreasing / other), E_i for
every cell, I_i = o λ f_c E_i with f = 0, 1, 1-ε, 1+ε, 1 for the classes (for the trapezoidal
rule ``_classify_scaled_elastic`` does these in three loops: node flags, elementwise; one
serial loop for the sliding sums and counts; classes and factors, elementwise), then on each
run of cells of the last class I_i -= o λ ε V_i.

The result equals the direct sum up to round-off (the terms are added in a different order):
``tests/test_fast_integral.py`` checks this on random, monotone, piecewise-constant and
tapped-column states, with both quadratures and both orientations.
"""

from __future__ import annotations

import numba
import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

__all__ = ["walton_braun_integral", "ANCHOR", "BLOCK"]

ANCHOR = 64
"""Cells between re-computations of the sliding window sums."""

_NV = 3
BLOCK = 4 * _NV
"""Cells per block of the vectorised friction sum (``_NV`` AVX vectors of 4 cells; three
vectors keep six independent chains of fused multiply-adds in flight: 3-6 % less time in the
integral than two on the column states at W = 40, in-process A/B, with the same sums bit for
bit)."""


@intrinsic
def _friction_block(typingctx, up, rp, bb, c, W, acc):
    """acc[0:BLOCK] = V for the BLOCK cells at padded indices c..c+BLOCK-1:
    V_l = Σ_{m=0}^{2W} bb[m] (ρ_j [u_j > u_l] - ρ_j [u_j < u_l]),  j = l - W + m.

    Written as explicit LLVM vector code: the cells are the vector lanes (4 per vector, _NV
    vectors, each with two accumulators for the positive and negative parts), the offsets m the
    loop, so every offset costs two unaligned vector loads, two compares, two masks and two
    fused multiply-adds per vector and nothing is spilled.  Reads up/rp[c-W : c+BLOCK+W]."""
    for a in (up, rp, bb, acc):
        if not (isinstance(a, types.Array) and a.ndim == 1 and a.dtype == types.float64 and a.layout == "C"):
            return None
    sig = types.void(up, rp, bb, c, W, acc)

    def codegen(context, builder, signature, args):
        upa, rpa, bba, c0, Wv, acca = args
        i64 = ir.IntType(64)
        c0 = context.cast(builder, c0, signature.args[3], types.int64)
        Wv = context.cast(builder, Wv, signature.args[4], types.int64)
        v4 = ir.VectorType(ir.DoubleType(), 4)
        pv4 = v4.as_pointer()

        def data(k, a):
            return context.make_array(signature.args[k])(context, builder, a).data

        upd, rpd, bbd, accd = data(0, upa), data(1, rpa), data(2, bba), data(5, acca)
        fma = cgutils.get_or_insert_function(builder.module, ir.FunctionType(v4, [v4, v4, v4]),
                                             "llvm.fma.v4f64")

        def vload(base, idx):
            return builder.load(builder.bitcast(builder.gep(base, [idx], inbounds=True), pv4), align=8)

        zero = ir.Constant(v4, [0.0] * 4)
        undef = ir.Constant(v4, ir.Undefined)
        splat = ir.Constant(ir.VectorType(ir.IntType(32), 4), [0] * 4)
        ui = [vload(upd, builder.add(c0, i64(4 * q))) for q in range(_NV)]
        sp = [cgutils.alloca_once_value(builder, zero) for _ in range(_NV)]
        sm = [cgutils.alloca_once_value(builder, zero) for _ in range(_NV)]
        start = builder.sub(c0, Wv)
        count = builder.add(builder.mul(Wv, i64(2)), i64(1))
        with cgutils.for_range(builder, count) as loop:
            m = loop.index
            b = builder.load(builder.gep(bbd, [m], inbounds=True))
            bv = builder.shuffle_vector(builder.insert_element(undef, b, i64(0)), undef, splat)
            o = builder.add(start, m)
            for q in range(_NV):
                j = builder.add(o, i64(4 * q))
                uj = vload(upd, j)
                x = vload(rpd, j)
                xp = builder.select(builder.fcmp_ordered(">", uj, ui[q]), x, zero)
                xm = builder.select(builder.fcmp_ordered("<", uj, ui[q]), x, zero)
                builder.store(builder.call(fma, [bv, xp, builder.load(sp[q])]), sp[q])
                builder.store(builder.call(fma, [bv, xm, builder.load(sm[q])]), sm[q])
        for q in range(_NV):
            v = builder.fsub(builder.load(sp[q]), builder.load(sm[q]))
            p = builder.bitcast(builder.gep(accd, [i64(4 * q)], inbounds=True), pv4)
            builder.store(v, p, align=8)
        return context.get_dummy_value()

    return sig, codegen


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
    """V_i = Σ_{k=-W}^{W} b_|k| ρ_{i+k} σ(u_{i+k} - u_i) (bb[W] = 0) for one cell (the cells
    of a run too close to the end of the arrays for a whole block)."""
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


@numba.njit(cache=True, inline="always")
def _class_start(up, rp, G, W):
    """The trackers of :func:`_class_next` before cell 0 (nodes G-W .. G+W-1)."""
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
    return no_inc, no_dec, no_eq, nz


@numba.njit(cache=True, inline="always")
def _class_next(up, rp, ii, W, no_inc, no_dec, no_eq, nz):
    """Class of the cell at padded index ii (unsigned) given the trackers up to node ii+W-1:
    the last node j at which d_j = u_{j+1} - u_j breaks strict increase, strict decrease or
    equality, and the last node with ρ != 0 (branch-free selects).  Returns the updated
    trackers and the class (0 empty, 1 constant, 2 increasing, 3 decreasing, 4 other)."""
    u64 = np.uint64
    j = ii + u64(W - 1)
    d = up[j + u64(1)] - up[j]
    sj = np.int64(j)
    no_inc = sj if d <= 0.0 else no_inc
    no_dec = sj if d >= 0.0 else no_dec
    no_eq = sj if d != 0.0 else no_eq
    nz = sj + 1 if rp[j + u64(1)] != 0.0 else nz
    start = np.int64(ii) - W
    c = 4
    c = 3 if no_dec < start else c
    c = 2 if no_inc < start else c
    c = 1 if no_eq < start else c
    c = 0 if nz < start else c
    return no_inc, no_dec, no_eq, nz, c


@numba.njit(cache=True, inline="always")
def _elastic_slide(rp, ii, W, w1, A, U, B, L):
    """The sliding sums of :func:`_classify_scaled_elastic` from cell ii to ii+1 (ii unsigned):
    A = Σ_{k=1}^{W-1} (W-k) ρ_{i+k}, U = Σ_{k=2}^{W} ρ_{i+k}, B = Σ_{k=1}^{W-1} (W-k) ρ_{i-k},
    L = Σ_{k=1}^{W-1} ρ_{i-k}."""
    u64 = np.uint64
    A = A + (U - w1 * rp[ii + u64(1)])
    U = U + (rp[ii + u64(W + 1)] - rp[ii + u64(2)])
    B = B + (w1 * rp[ii] - L)
    L = L + (rp[ii] - rp[ii - u64(W - 1)])
    return A, U, B, L


@numba.njit(cache=True)
def _classify(up, rp, G, N, W, cls):
    """cls[i]: 0 empty window (ρ = 0 on all 2W+1 nodes), 1 u constant, 2 u strictly
    increasing, 3 strictly decreasing over the window, 4 none of these (friction sum needed).
    O(1) per cell with the trackers of :func:`_class_next`."""
    no_inc, no_dec, no_eq, nz = _class_start(up, rp, G, W)
    # unsigned indices: no negative-index wrap-around code in the loop
    for i in range(np.uint64(N)):
        no_inc, no_dec, no_eq, nz, c = _class_next(up, rp, np.uint64(G) + i, W, no_inc, no_dec, no_eq, nz)
        cls[i] = c


_ONE_INC = np.int64(1)
_ONE_DEC = np.int64(1) << 16
_ONE_NEQ = np.int64(1) << 32
_ONE_NZ = np.int64(1) << 48
_FIELD = np.int64(0xFFFF)


@numba.njit(cache=True)
def _node_flags(up, rp, j0, n, flags):
    """flags[k], node j = j0 + k (k < n): four 16-bit counters packed in an int64, each 0 or 1:
    [d_j <= 0] (breaks strict increase), [d_j >= 0] << 16 (breaks strict decrease),
    [d_j != 0] << 32 (breaks constancy), d_j = u_{j+1} - u_j, and [ρ_j != 0] << 48.
    Elementwise (vectorised by the compiler; unsigned indices avoid wrap-around code)."""
    u64 = np.uint64
    for k in range(u64(n)):
        j = u64(j0) + k
        d = up[j + u64(1)] - up[j]
        f = _ONE_INC if d <= 0.0 else np.int64(0)
        f += _ONE_DEC if d >= 0.0 else np.int64(0)
        f += _ONE_NEQ if d != 0.0 else np.int64(0)
        f += _ONE_NZ if rp[j] != 0.0 else np.int64(0)
        flags[k] = f


@numba.njit(cache=True)
def _classify_scaled_elastic(up, rp, G, N, W, beta, fac, cls, out):
    """For the trapezoidal rule (b_k = β (W - k)): cls[i] as :func:`_classify` and
    out[i] = fac[cls[i]] E_i (0 for an empty window), E_i = β (A_i - B_i), in three loops:

    1. node flags (:func:`_node_flags`, elementwise);
    2. one serial pass: the triangular window sums A_i = Σ (W-k) ρ_{i+k}, B_i = Σ (W-k) ρ_{i-k}
       slid from cell to cell (:func:`_elastic_slide`, re-computed from scratch every ANCHOR
       cells so that round-off cannot accumulate), and the window's packed flag counts
       S_i = Σ_{j=ii-W}^{ii+W-1} flags_j slid exactly in integers (counts <= 2W+1 < 2^16);
    3. elementwise: the class from the counts (no break of a property in the window, or no
       ρ != 0 on its 2W+1 nodes) and the class factor times E_i.

    The classes equal :func:`_classify`'s (its trackers test the same predicates; tested) and
    E_i is the same expression as before, so the result is the same bit for bit."""
    u64 = np.uint64
    n_nodes = N + 2 * W                  # nodes G - W .. G + N + W - 1
    work = np.empty(n_nodes + N, dtype=np.int64)
    flags = work[:n_nodes]               # flags[k]: node G - W + k
    counts = work[n_nodes:]
    _node_flags(up, rp, G - W, n_nodes - 1, flags)
    # the last node's d_j is never used (and u_{j+1} may lie past the array): ρ flag only
    flags[n_nodes - 1] = _ONE_NZ if rp[G + N + W - 1] != 0.0 else np.int64(0)
    S = np.int64(0)
    for k in range(2 * W):
        S += flags[k]
    w1 = W - 1.0
    i0 = 0
    while i0 < N:
        i1 = min(N, i0 + ANCHOR)
        A, U, B, L = _window_sums(rp, G + i0, W)
        for i in range(u64(i0), u64(i1)):
            out[i] = beta * (A - B)
            counts[i] = S
            S += flags[i + u64(2 * W)] - flags[i]
            A, U, B, L = _elastic_slide(rp, u64(G) + i, W, w1, A, U, B, L)
        i0 = i1
    f1 = fac[1]
    f2 = fac[2]
    f3 = fac[3]
    f4 = fac[4]
    nz_field = _FIELD << 48
    for i in range(u64(N)):
        # the window's ρ nodes reach one node further than its d nodes (node ii + W)
        C = counts[i] + (flags[i + u64(2 * W)] & nz_field)
        c = 4
        c = 3 if ((C >> 16) & _FIELD) == 0 else c
        c = 2 if (C & _FIELD) == 0 else c
        c = 1 if ((C >> 32) & _FIELD) == 0 else c
        c = 0 if (C >> 48) == 0 else c
        cls[i] = c
        f = f4
        f = f3 if c == 3 else f
        f = f2 if c == 2 else f
        f = f1 if c == 1 else f
        e = f * out[i]
        out[i] = e if c != 0 else 0.0


@numba.njit(cache=True)
def walton_braun_integral(up, rp, G, N, W, qz, qw, kp, out):
    """I_i for the Walton–Braun kernel, kp = (λ, ε, R, orientation), from padded arrays
    (G >= W ghost cells); the same call signature and result as the direct quadrature sum."""
    upc = np.ascontiguousarray(up)
    rpc = np.ascontiguousarray(rp)
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
    # (the one-pass classes count window nodes in 16-bit fields: 2W + 1 < 2^16)
    linear = 1 < W < 32767
    for k in range(1, W + 1):
        if abs(b[k] - beta * (W - k)) > 1e-12 * abs(beta) * W:
            linear = False
    cls = np.empty(N, dtype=np.int8)
    fac = np.array([0.0, coef, coef * (1.0 - eps), coef * (1.0 + eps), coef])
    if linear:
        # classes, elastic part and the factor of each class in one pass
        _classify_scaled_elastic(upc, rpc, G, N, W, beta, fac, cls, out)
    else:
        _classify(upc, rpc, G, N, W, cls)
        for i in range(N):
            c = cls[i]
            out[i] = fac[c] * _elastic_sum(rpc, G + i, W, bs) if c != 0 else 0.0
    # friction part on the runs of class-4 cells, BLOCK cells at a time
    acc = np.empty(BLOCK)
    ce = coef * eps
    last = up.size - G - W - BLOCK           # last cell index whose whole block can be read
    i = 0
    while i < N:
        if cls[i] != 4:
            i += 1
            continue
        i1 = i
        while i1 < N and cls[i1] == 4:
            i1 += 1
        while i < i1:
            if i <= last:
                _friction_block(upc, rpc, bb, G + i, W, acc)
                for q in range(min(BLOCK, i1 - i)):
                    out[i + q] -= ce * acc[q]
                i += BLOCK
            else:
                out[i] -= ce * _friction_sum(upc, rpc, G + i, W, bb)
                i += 1
        i = i1
