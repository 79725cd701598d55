"""The compiled (numba, parallel) time loop of the 2-D / 3-D semidiscrete BSR scheme.

Layout.  Every run uses three internal axes (x, y, z), z vertical; a 2-D run is the x-z plane
with n_y = 1, no ghost layers in y, no y differences and u_y ≡ 0.  Arrays are C-ordered:
u (3, n_x, n_y, n_z) [m/s], ρ (n_x, n_y, n_z) [kg/m^n]; the padded copies carry G ghost layers
on each side of the active axes (see :mod:`bsrflow.numerics.grid_nd`).

One call of ``advance`` runs whole steps without returning to Python: every Runge-Kutta stage
fills the ghosts (per-axis index maps, so corner ghosts are images in every direction; the
supporting floor's density images are point reflections), evaluates the right-hand side, the
stages are combined, the velocity is extended into vacuum (optional), the moving average is
applied, and the monitors are checked.  The right-hand side at cell j is

    du/dt = -Σ_a u_a D_a u - (g + ϑ''(t)) e_z + Σ_o w_o ρ_{j+o} Θ(c_o, u_j, u_{j+o}),
    dρ/dt = -Σ_a D_a(ρ u_a),       D_a q_j = (q_{j+e_a} - q_{j-e_a}) / (2Δx)

(central differences as (4.19)-(4.24) and section 5.2; ball quadrature of grid_nd; at a
supporting floor the vertical flux of the lowest cell uses the even density image).

Moving average (switchable): mode 1 is the seed's near-neighbour average (5.7),
NA(q_j) = q_j/2 + (1/(4n)) Σ_a (q_{j+e_a} + q_{j-e_a}); mode 2 is the tensor product of the 1-D
average (1/4, 1/2, 1/4) along each axis (a 3^n-point stencil).  For a state that does not vary
horizontally mode 2 reduces to the 1-D average exactly, while (5.7) reduces to the weaker
average (1/(4n), 1 - 1/(2n), 1/(4n)) in z.

Parallelism and determinism.  All cell loops are ``prange`` over the x index; every cell's value
(including its whole quadrature sum, in a fixed order) is computed by one thread, and the only
cross-cell reductions (max |u|, max ρ for the time step) are exact maxima taken serially over
per-row results.  Results are therefore bitwise independent of scheduling and thread count.

Exact horizontal symmetry.  The ball table is stored as one half: offsets o with (o_x, o_y)
lexicographically positive, plus the vertical column (o_x = o_y = 0).  The partner
(-o_x, -o_y, o_z) is evaluated next to it and the pair's contribution is added as one number, so
for a state uniform in x and y with u_x = u_y = 0 the horizontal components cancel exactly and
the horizontal velocity stays exactly zero (needed for the embedding test).

Compilation.  The kernel-independent loops are module-level functions cached on disk by
numba (``cache=True``); the right-hand side is compiled once per kernel function, the serial
step loop ``advance`` once per (kernel, motion) pair.

Status codes: :data:`bsrflow.numerics.compiled.STATUS` (codes 0-5; 6 is not used in n-D).
"""

from __future__ import annotations

import functools
import math

import numba
import numpy as np
from numba import prange

__all__ = ["make_core_nd"]


@numba.njit(parallel=True, cache=True)
def fill_ghosts(u, rho, up, rp, sx, sy, sz, gx, gy, gz, kx, ky, kz, prz):
    """Padded copies: up[c, p, q, r] = sign_c · u[c, sx[p], sy[q], sz[r]], rp likewise
    with the density factor kx[p] ky[q] kz[r] (0 for vacuum ghosts); where prz[r] = 1 (floor
    ghosts) the density is the point reflection max(0, 2 ρ_w - ρ), ρ_w = (3ρ_0 - ρ_1)/2 of
    the source column (grid_nd)."""
    PX, PY, PZ = rp.shape
    for p in prange(PX):
        i = sx[p]
        for q in range(PY):
            j = sy[q]
            fx = gx[p]
            fy = gy[q]
            fk = kx[p] * ky[q]
            for r in range(PZ):
                k = sz[r]
                up[0, p, q, r] = fx * u[0, i, j, k]
                up[1, p, q, r] = fy * u[1, i, j, k]
                up[2, p, q, r] = gz[r] * u[2, i, j, k]
                if prz[r] != 0.0:
                    rw = 1.5 * rho[i, j, 0] - 0.5 * rho[i, j, 1]
                    v = 2.0 * rw - rho[i, j, k]
                    rp[p, q, r] = (fk * kz[r]) * (v if v > 0.0 else 0.0)
                else:
                    rp[p, q, r] = (fk * kz[r]) * rho[i, j, k]


@numba.njit(parallel=True, cache=True)
def moving_average(u, rho, up, rp, Gx, Gy, Gz, has_y, floor, dims, mode):
    """Overwrite (u, ρ) by their moving average from the padded arrays: mode 1 the seed's
    (5.7), mode 2 the tensor-product (1/4, 1/2, 1/4) average (module docstring).  With a
    supporting floor the density below k = 0 is the even image (mass-conserving)."""
    NX, NY, NZ = rho.shape
    cn = 1.0 / (4.0 * dims)
    for i in prange(NX):
        I = i + Gx
        for j in range(NY):
            J = j + Gy
            for k in range(NZ):
                Kc = k + Gz
                zl = 0 if (floor and k == 0) else -1     # density layer used below
                if mode == 1:
                    for c in range(3):
                        s = (up[c, I + 1, J, Kc] + up[c, I - 1, J, Kc]
                             + up[c, I, J, Kc + 1] + up[c, I, J, Kc - 1])
                        if has_y:
                            s += up[c, I, J + 1, Kc] + up[c, I, J - 1, Kc]
                        u[c, i, j, k] = 0.5 * up[c, I, J, Kc] + cn * s
                    s = rp[I + 1, J, Kc] + rp[I - 1, J, Kc] + rp[I, J, Kc + 1] + rp[I, J, Kc + zl]
                    if has_y:
                        s += rp[I, J + 1, Kc] + rp[I, J - 1, Kc]
                    rho[i, j, k] = 0.5 * rp[I, J, Kc] + cn * s
                else:
                    ylo = -1 if has_y else 0
                    yhi = 1 if has_y else 0
                    s0 = 0.0
                    s1 = 0.0
                    s2 = 0.0
                    sr = 0.0
                    for a in range(-1, 2):
                        wa = 0.5 if a == 0 else 0.25
                        for b in range(ylo, yhi + 1):
                            wb = wa * ((0.5 if b == 0 else 0.25) if has_y else 1.0)
                            for e in range(-1, 2):
                                w = wb * (0.5 if e == 0 else 0.25)
                                s0 += w * up[0, I + a, J + b, Kc + e]
                                s1 += w * up[1, I + a, J + b, Kc + e]
                                s2 += w * up[2, I + a, J + b, Kc + e]
                                sr += w * rp[I + a, J + b, Kc + (zl if e == -1 else e)]
                    u[0, i, j, k] = s0
                    u[1, i, j, k] = s1
                    u[2, i, j, k] = s2
                    rho[i, j, k] = sr


@numba.njit(cache=True)
def extend_velocity(u, rho, thr):
    """Velocity extension into vacuum, column by column (the 1-D solver's rule along z):
    every cell with ρ < thr takes the velocity vector of the nearest cell of its vertical
    column with ρ >= thr (the lower one on a tie); columns without material are left."""
    NX, NY, NZ = rho.shape
    for i in prange(NX):
        src = np.empty(NZ, np.int64)
        dist = np.empty(NZ, np.int64)
        for j in range(NY):
            last = -1
            for k in range(NZ):
                src[k] = -1
                dist[k] = NZ + 1
                if rho[i, j, k] >= thr:
                    last = k
                elif last >= 0:
                    dist[k] = k - last
                    src[k] = last
            nxt = -1
            for k in range(NZ - 1, -1, -1):
                if rho[i, j, k] >= thr:
                    nxt = k
                elif nxt >= 0 and nxt - k < dist[k]:
                    dist[k] = nxt - k
                    src[k] = nxt
            for k in range(NZ):
                if rho[i, j, k] < thr and src[k] >= 0:
                    m = src[k]
                    u[0, i, j, k] = u[0, i, j, m]
                    u[1, i, j, k] = u[1, i, j, m]
                    u[2, i, j, k] = u[2, i, j, m]


@numba.njit(cache=True, inline="always")
def _interp_axis(pos, lo, dx, G, P):
    """(index, weight) of the linear interpolation at ``pos`` [m] along one padded axis (the 1-D
    solver's ``interp``: cell centres at lo + (i + ½)Δx, G ghost cells, P padded cells)."""
    q = (pos - lo) / dx - 0.5 + G
    if q < 0.0:
        q = 0.0
    if q > P - 1.000001:
        q = P - 1.000001
    i0 = int(math.floor(q))
    return i0, q - i0


@numba.njit(cache=True)
def interp_velocity(up, x, y, z, lo, dx, Gx, Gy, Gz, has_y, out):
    """Trilinear (bilinear in 2-D) interpolation of the padded velocity ``up`` (3, PX, PY, PZ) at
    the point (x, y, z) [m] into ``out`` (3,)."""
    _, PX, PY, PZ = up.shape
    i0, fx = _interp_axis(x, lo[0], dx, Gx, PX)
    k0, fz = _interp_axis(z, lo[2], dx, Gz, PZ)
    if has_y:
        j0, fy = _interp_axis(y, lo[1], dx, Gy, PY)
    else:
        j0, fy = 0, 0.0
    for c in range(3):
        acc = 0.0
        for di in range(2):
            wx = fx if di else 1.0 - fx
            for dj in range(2 if has_y else 1):
                wy = (fy if dj else 1.0 - fy) if has_y else 1.0
                for dk in range(2):
                    wz = fz if dk else 1.0 - fz
                    acc += wx * wy * wz * up[c, i0 + di, j0 + dj, k0 + dk]
        out[c] = acc


@numba.njit(cache=True, parallel=True)
def _density_floor(rho, rho_floor):
    """Set |ρ| < ``rho_floor`` to 0 (vacuum debris; ``SimulationND``'s ``density_floor``)."""
    NX, NY, NZ = rho.shape
    for i in prange(NX):
        for j in range(NY):
            for k in range(NZ):
                if abs(rho[i, j, k]) < rho_floor:
                    rho[i, j, k] = 0.0


@numba.njit(cache=True, parallel=True)
def make_positive_columns(rho):
    """Mass-conserving positivity fix, column by column (the 1-D solver's
    ``compiled.make_positive`` along z): in every vertical column each cell with ρ < 0 is set
    to 0 and its deficit is taken from the nearest cells of the column with ρ > 0, in
    proportion to their density, widening the neighbourhood until the deficit is covered.  The
    mass of every column whose total is positive is kept (to round-off; a column whose total is
    negative, a failed state, is set to 0, which creates mass); a horizontally uniform state
    stays uniform."""
    NX, NY, NZ = rho.shape
    for i in prange(NX):
        for j in range(NY):
            for k in range(NZ):
                if rho[i, j, k] < 0.0:
                    deficit = -rho[i, j, k]
                    rho[i, j, k] = 0.0
                    for w in range(1, NZ):
                        lo = max(0, k - w)
                        hi = min(NZ, k + w + 1)
                        avail = 0.0
                        for m in range(lo, hi):
                            if rho[i, j, m] > 0.0:
                                avail += rho[i, j, m]
                        if avail >= deficit or w == NZ - 1:
                            f = deficit / avail if avail > 0.0 else 0.0
                            if f > 1.0:
                                f = 1.0
                            for m in range(lo, hi):
                                if rho[i, j, m] > 0.0:
                                    rho[i, j, m] -= f * rho[i, j, m]
                            break


@numba.njit(cache=True)
def _axpy_stage(yu, yr, u, rho, ku, kr, st, A, dt):
    """(yu, yr) = (u, ρ) + dt Σ_{j<st} A[st, j] (ku_j, kr_j)."""
    NX, NY, NZ = rho.shape
    for i in prange(NX):
        for j in range(NY):
            for k in range(NZ):
                a0 = u[0, i, j, k]
                a1 = u[1, i, j, k]
                a2 = u[2, i, j, k]
                ar = rho[i, j, k]
                for m in range(st):
                    f = dt * A[st, m]
                    if f != 0.0:
                        a0 += f * ku[m, 0, i, j, k]
                        a1 += f * ku[m, 1, i, j, k]
                        a2 += f * ku[m, 2, i, j, k]
                        ar += f * kr[m, i, j, k]
                yu[0, i, j, k] = a0
                yu[1, i, j, k] = a1
                yu[2, i, j, k] = a2
                yr[i, j, k] = ar


@numba.njit(cache=True)
def _combine(u, rho, ku, kr, b, dt):
    """(u, ρ) += dt Σ_j b_j (ku_j, kr_j), stage by stage in a fixed order."""
    NX, NY, NZ = rho.shape
    s = b.size
    for i in prange(NX):
        for j in range(NY):
            for k in range(NZ):
                for m in range(s):
                    f = dt * b[m]
                    if f != 0.0:
                        u[0, i, j, k] += f * ku[m, 0, i, j, k]
                        u[1, i, j, k] += f * ku[m, 1, i, j, k]
                        u[2, i, j, k] += f * ku[m, 2, i, j, k]
                        rho[i, j, k] += f * kr[m, i, j, k]


@numba.njit(cache=True)
def _row_stats(u, rho, smax, rmax, bad):
    """Per x-row: max Σ_a |u_a|, max ρ, and the first non-finite flat index (or -1)."""
    NX, NY, NZ = rho.shape
    for i in prange(NX):
        sm = 0.0
        rm = 0.0
        bi = -1
        for j in range(NY):
            for k in range(NZ):
                v = abs(u[0, i, j, k]) + abs(u[1, i, j, k]) + abs(u[2, i, j, k])
                r = rho[i, j, k]
                if not (math.isfinite(v) and math.isfinite(r)):
                    if bi < 0:
                        bi = (i * NY + j) * NZ + k
                if v > sm:
                    sm = v
                if r > rm:
                    rm = r
        smax[i] = sm
        rmax[i] = rm
        bad[i] = bi


@functools.lru_cache(maxsize=32)
def _cell_parts(kernel_fn):
    """The kernel-dependent parallel loop (the right-hand side), compiled once per kernel.  It
    does not depend on the motion (the frame acceleration enters as a number), so a second
    applied motion only recompiles the small serial step loop; the kernel-independent loops
    are module-level functions cached on disk by numba."""
    K = kernel_fn

    @numba.njit(parallel=True, cache=False)
    def rhs(acc_z, up, rp, PY, PZ, Gx, Gy, Gz, has_y, floor, dx, dA, dB, hc, hwA, hwB, kp, du, dr):
        """Semi-discrete right-hand side at every cell (module docstring) from the *flattened*
        padded arrays up (3, PX·PY·PZ), rp (PX·PY·PZ); acc_z = -(g + ϑ''(t)) [m/s²] is the
        vertical body acceleration in the floor frame.  Half table: flat offsets dA (o) and dB
        (its partner (-o_x, -o_y, o_z)), node c_o, weights hwA = w_o and hwB (w_o, or 0 for
        the vertical column, which has no partner).  A pair is skipped when both densities are
        0.  With a supporting floor the vertical flux at k = 0 uses the even image ρ_{-1} = ρ_0."""
        NX, NY, NZ = dr.shape
        h = 0.5 / dx
        P = hwA.size
        sX = PY * PZ
        sY = PZ
        for i in prange(NX):
            I = i + Gx
            for j in range(NY):
                J = j + Gy
                for k in range(NZ):
                    b = (I * PY + J) * PZ + k + Gz
                    ax = up[0, b]
                    ay = up[1, b]
                    az = up[2, b]
                    sx = 0.0
                    sy = 0.0
                    sz = 0.0
                    for n in range(P):
                        a = b + dA[n]
                        c = b + dB[n]
                        rA = rp[a]
                        rB = rp[c]
                        if rA != 0.0 or rB != 0.0:
                            cx = hc[n, 0]
                            cy = hc[n, 1]
                            cz = hc[n, 2]
                            tx, ty, tz = K((cx, cy, cz), (ax, ay, az), (up[0, a], up[1, a], up[2, a]), kp)
                            qx, qy, qz = K((-cx, -cy, cz), (ax, ay, az), (up[0, c], up[1, c], up[2, c]), kp)
                            wa = hwA[n] * rA
                            wb = hwB[n] * rB
                            # the pair as one number: exact cancellation for mirror-symmetric states
                            sx += wa * tx + wb * qx
                            sy += wa * ty + wb * qy
                            sz += wa * tz + wb * qz
                    # central differences
                    xp = b + sX
                    xm = b - sX
                    zp = b + 1
                    zm = b - 1
                    rlow = rp[b] if (floor and k == 0) else rp[zm]
                    flux = (rp[xp] * up[0, xp] - rp[xm] * up[0, xm] + rp[zp] * up[2, zp] - rlow * up[2, zm])
                    adv0 = ax * (up[0, xp] - up[0, xm]) + az * (up[0, zp] - up[0, zm])
                    adv1 = ax * (up[1, xp] - up[1, xm]) + az * (up[1, zp] - up[1, zm])
                    adv2 = ax * (up[2, xp] - up[2, xm]) + az * (up[2, zp] - up[2, zm])
                    if has_y:
                        yp = b + sY
                        ym = b - sY
                        adv0 += ay * (up[0, yp] - up[0, ym])
                        adv1 += ay * (up[1, yp] - up[1, ym])
                        adv2 += ay * (up[2, yp] - up[2, ym])
                        flux += rp[yp] * up[1, yp] - rp[ym] * up[1, ym]
                    du[0, i, j, k] = sx - adv0 * h
                    du[1, i, j, k] = sy - adv1 * h
                    du[2, i, j, k] = sz - adv2 * h + acc_z
                    dr[i, j, k] = -flux * h

    class Parts:
        pass

    parts = Parts()
    parts.rhs = rhs
    return parts


@functools.lru_cache(maxsize=32)
def make_core_nd(kernel_fn, motion_fn, wave_speed_fn, positivity=False, tracers=False):
    """Build the compiled n-D functions for one (kernel, motion) pair of numba functions and
    the interaction's wave-speed bound ``wave_speed_fn(rho_max, p) -> c`` [m/s]
    (:meth:`bsrflow.physics.interaction.Interaction.compiled_wave_speed`; the step loop's CFL
    bound is ``max Σ|u_a| + wave_speed_fn(max ρ, wsp)``).

    Returns a namespace with ``fill_ghosts``, ``rhs``, ``moving_average``,
    ``extend_velocity`` and ``advance``.  Everything else (tableau, boundary maps, quadrature
    table, parameters) is runtime data.

    ``positivity`` and ``tracers`` are compile-time switches of the step loop (the positivity
    pass, the tracer moves): a loop without them is compiled without their code (the runtime
    branch alone cost the seed's 3-D step 20 % at 64³, ``bench/bench_nd.py``).
    """
    parts = _cell_parts(kernel_fn)
    WS = wave_speed_fn
    M = motion_fn
    POSITIVITY = bool(positivity)
    TRACERS = bool(tracers)
    rhs = parts.rhs

    @numba.njit(cache=False)
    def advance(u, rho, t, t_end, dt_fixed, cfl, wsp, A, b, c, filt, dims, sx, sy, sz, gx, gy, gz,
                kx, ky, kz, prz, floor, Gx, Gy, Gz, dx, dA, dB, hc, hwA, hwB, kp, grav, mp, dt_min,
                rho_max, max_steps, top_tol, top_layers, vac_thr, rho_floor, tracers, tracer_mode, lo, box,
                periodic):
        """Advance (u, ρ) in place from t to t_end.

        dt: ``dt_fixed`` if > 0, else cfl Δx / (max_j Σ_a |u_a| + sqrt(n κ max ρ)) (the n-D
        bound of central differences: advection Σ|u_a|/Δx, sound speed c = sqrt(κρ) along a
        diagonal sqrt(n) c/Δx); the last step is shortened to land on t_end.  filt: 0 none,
        1 (5.7), 2 tensor average.  vac_thr > 0: velocity extension into vacuum after every
        step (before the average), as the 1-D solver.  positivity: the column-wise
        mass-conserving fix :func:`make_positive_columns` after every step (after the average).
        rho_floor > 0: |ρ| below it is set to 0 at the end of every step (after the positivity
        fix: vacuum debris, as the 1-D solver's ``density_floor``).
        Returns (t, steps, status, where_flat_index, dt_last).
        """
        NX, NY, NZ = rho.shape
        has_y = dims == 3
        s = b.size
        PY = NY + 2 * Gy
        PZ = NZ + 2 * Gz
        up = np.empty((3, NX + 2 * Gx, PY, PZ))
        rp = np.empty((NX + 2 * Gx, PY, PZ))
        upf = up.reshape(3, -1)
        rpf = rp.reshape(-1)
        ku = np.empty((s, 3, NX, NY, NZ))
        kr = np.empty((s, NX, NY, NZ))
        yu = np.empty((3, NX, NY, NZ))
        yr = np.empty((NX, NY, NZ))
        smax = np.empty(NX)
        rmax = np.empty(NX)
        bad = np.empty(NX, np.int64)
        steps = 0
        status = 0
        where = -1
        dt = 0.0
        nt = tracers.shape[0]
        vt = np.zeros((s, nt, 3))
        vbuf = np.zeros(3)
        while t < t_end:
            if dt_fixed > 0.0:
                dt = dt_fixed
            else:
                _row_stats(u, rho, smax, rmax, bad)
                speed = smax.max() + WS(max(rmax.max(), 0.0), wsp)
                if speed == 0.0:
                    # at rest without a wave speed (a state at rest under the zero kernel): the speed the
                    # body force -(g + ϑ''(t)) gives in one cell, not a single step to the next event
                    # (which ran 0.3 s in one)
                    speed = math.sqrt(dx * abs(grav + M(t, mp)[2]))
                dt = cfl * dx / speed if speed > 0.0 else t_end - t
            last = False
            if t + dt >= t_end - 1e-12 * max(abs(t_end), dt):
                dt = t_end - t
                last = True
            if dt < dt_min and not last:
                status = 3
                break
            for st in range(s):
                _axpy_stage(yu, yr, u, rho, ku, kr, st, A, dt)
                fill_ghosts(yu, yr, up, rp, sx, sy, sz, gx, gy, gz, kx, ky, kz, prz)
                if TRACERS and (tracer_mode == 2 or (tracer_mode == 1 and st == 0)):
                    for n in range(nt):
                        px, py, pz = tracers[n, 0], tracers[n, 1], tracers[n, 2]
                        if tracer_mode == 2:
                            for j in range(st):
                                px += dt * A[st, j] * vt[j, n, 0]
                                py += dt * A[st, j] * vt[j, n, 1]
                                pz += dt * A[st, j] * vt[j, n, 2]
                        interp_velocity(up, px, py, pz, lo, dx, Gx, Gy, Gz, has_y, vbuf)
                        for cc in range(3):
                            vt[st, n, cc] = vbuf[cc]
                acc_z = -(grav + M(t + c[st] * dt, mp)[2])
                rhs(acc_z, upf, rpf, PY, PZ, Gx, Gy, Gz, has_y, floor, dx, dA, dB, hc, hwA, hwB, kp,
                    ku[st], kr[st])
            _combine(u, rho, ku, kr, b, dt)
            for n in range(nt if TRACERS else 0):
                for cc in range(3):
                    if tracer_mode == 1:
                        tracers[n, cc] += dt * vt[0, n, cc]
                    else:
                        for j in range(s):
                            tracers[n, cc] += dt * b[j] * vt[j, n, cc]
                for cc in range(3):
                    if cc == 1 and not has_y:
                        tracers[n, cc] = 0.0
                        continue
                    rel = tracers[n, cc] - lo[cc]
                    if periodic[cc]:
                        tracers[n, cc] = lo[cc] + (rel - box[cc] * math.floor(rel / box[cc]))
                    elif cc < 2:
                        tracers[n, cc] = lo[cc] + min(max(rel, 0.0), box[cc])
                    elif floor and tracers[n, 2] < lo[2]:
                        tracers[n, 2] = lo[2]
            t = t_end if last else t + dt
            if vac_thr > 0.0:
                extend_velocity(u, rho, vac_thr)
            if filt > 0:
                fill_ghosts(u, rho, up, rp, sx, sy, sz, gx, gy, gz, kx, ky, kz, prz)
                moving_average(u, rho, up, rp, Gx, Gy, Gz, has_y, floor, dims, filt)
            if POSITIVITY:
                make_positive_columns(rho)
            if rho_floor > 0.0:
                _density_floor(rho, rho_floor)
            steps += 1
            _row_stats(u, rho, smax, rmax, bad)
            for i in range(NX):
                if bad[i] >= 0:
                    status = 1
                    where = bad[i]
                    break
            if status != 0:
                break
            if rho_max > 0.0 and rmax.max() > rho_max:
                status = 2
                where = -1
                for i in range(NX):
                    for j in range(NY):
                        for k in range(NZ):
                            if where < 0 and rho[i, j, k] > rho_max:
                                where = (i * NY + j) * NZ + k
                break
            if top_tol > 0.0 and top_layers > 0:
                for i in range(NX):
                    for j in range(NY):
                        for k in range(max(0, NZ - top_layers), NZ):
                            if where < 0 and rho[i, j, k] > top_tol:
                                where = (i * NY + j) * NZ + k
                if where >= 0:
                    status = 5
                    break
            if steps >= max_steps and t < t_end:
                status = 4
                break
        return t, steps, status, where, dt

    class CoreND:
        pass

    core = CoreND()
    core.fill_ghosts = fill_ghosts
    core.rhs = rhs
    core.moving_average = moving_average
    core.extend_velocity = extend_velocity
    core.make_positive_columns = make_positive_columns
    core.interp_velocity = interp_velocity
    core.advance = advance
    return core
