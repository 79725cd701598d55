"""The compiled (numba) time loop of the 1-D semidiscrete scheme.

One call of ``advance`` runs many whole steps without returning to Python: every Runge-Kutta
stage fills the ghost values, evaluates the right-hand side (central differences (4.19)-(4.24),
the interaction integral by quadrature), the stages are combined, the moving average is
applied (after (4.24)), tracers are moved, and the monitors are checked.

User physics (kernel Θ, external force e, applied motion ϑ, Dirichlet boundary values) is
compiled into the loop through a factory closure, ``make_core(...)``, cached per combination
of functions.  Everything else (tableau, boundary kinds, filter switch, quadrature weights,
parameters) is runtime data, so changing it does not recompile.

Status codes returned by ``advance``: see ``STATUS``.
"""

from __future__ import annotations

import functools
import math

import numba
import numpy as np

__all__ = ["make_core", "make_direct_integral", "direct_integral", "STATUS"]

STATUS = {
    0: "ok",
    1: "non-finite value (the solution blew up)",
    2: "density above the bound rho_max",
    3: "time step collapsed below dt_min (velocity or wave speed unbounded: gradient catastrophe?)",
    4: "maximum number of steps reached",
    5: "material reached the vacuum top of the domain (domain too short)",
    6: "compression-rate monitor: max(-u_x) * dt above the limit (characteristics about to cross)",
}


def make_direct_integral(kernel_fn):
    """The interaction integral by the direct quadrature sum: (2W+1) kernel calls per cell.

    ``integral(up, rp, G, N, W, qz, qw, kp, out)`` writes
    out[i] = Σ_k qw_k ρ_{i+k} Θ(z_k, u_i, u_{i+k}; kp) from padded arrays.
    """
    K = kernel_fn

    @numba.njit(cache=False)
    def integral(up, rp, G, N, W, qz, qw, kp, out):
        for i in range(N):
            ii = G + i
            ui = up[ii]
            s = 0.0
            for k in range(-W, W + 1):
                s += qw[k + W] * rp[ii + k] * K(qz[k + W], ui, up[ii + k], kp)
            out[i] = s

    return integral


_DIRECT: dict = {}


def direct_integral(kernel_fn):
    if kernel_fn not in _DIRECT:
        _DIRECT[kernel_fn] = make_direct_integral(kernel_fn)
    return _DIRECT[kernel_fn]


@functools.lru_cache(maxsize=64)
def make_core(integral_fn, external_fn, motion_fn, boundary_fn, wave_speed_fn):
    """Build the compiled functions for one combination of physics functions.

    ``integral_fn(up, rp, G, N, W, qz, qw, kp, out)`` computes the interaction integral at
    every cell (see :func:`make_direct_integral`; a faster algorithm for a particular kernel
    can be substituted), ``external_fn(t, x, u, p)``, ``boundary_fn(t, x, p) -> (u, rho)``
    and ``motion_fn(t, p) -> (ϑ, ϑ', ϑ'')`` are numba-compiled functions;
    ``wave_speed_fn(rho_max, p) -> c`` [m/s] is the interaction's wave-speed bound
    (:meth:`bsrflow.physics.interaction.Interaction.compiled_wave_speed`), used for the CFL step
    and the dissipations' speed with the parameter array ``wsp`` the functions take.
    Returns a namespace with ``fill_ghosts``, ``rhs``, ``moving_average`` and ``advance``.
    """
    INTEGRAL = integral_fn
    E = external_fn
    M = motion_fn
    B = boundary_fn
    WS = wave_speed_fn

    @numba.njit(cache=False)
    def fill_ghosts(u, rho, t, up, rp, G, bcl, bch, xlo, dx, bp):
        """Copy (u, rho) into padded arrays with G ghost cells on each side (see grid.py)."""
        fill_ghosts_below(u, rho, t, up, rp, G, bcl, bch, xlo, dx, bp, u.size)

    @numba.njit(cache=False)
    def fill_ghosts_below(u, rho, t, up, rp, G, bcl, bch, xlo, dx, bp, n_copy):
        """:func:`fill_ghosts` that copies only the cells below ``n_copy`` (the stages' reach
        when they skip the vacuum above a column); the padded entries of the cells above keep
        their old values, and both ghost layers are filled as usual."""
        N = u.size
        n = min(N, n_copy)
        # unsigned loops: about twice as fast as the slice assignment
        for i in range(np.uint64(n)):
            up[np.uint64(G) + i] = u[i]
        for i in range(np.uint64(n)):
            rp[np.uint64(G) + i] = rho[i]
        for g in range(1, G + 1):
            lo = G - g            # padded index of cell -g
            hi = G + N - 1 + g    # padded index of cell N-1+g
            if bcl == 0:
                m = (-g) % N
                up[lo] = u[m]
                rp[lo] = rho[m]
            elif bcl == 1 or bcl == 4:
                m = g - 1
                if m < N:
                    up[lo] = -u[m]
                    if bcl == 4:
                        rp[lo] = rho[m]
                    else:
                        # point reflection through the extrapolated wall density
                        rw = 1.5 * rho[0] - 0.5 * rho[1]
                        r = 2.0 * rw - rho[m]
                        rp[lo] = r if r > 0.0 else 0.0
                else:
                    up[lo] = 0.0
                    rp[lo] = 0.0
            elif bcl == 2:
                up[lo] = u[0]
                rp[lo] = 0.0
            else:
                uu, rr = B(t, xlo + (0.5 - g) * dx, bp)
                up[lo] = uu
                rp[lo] = rr
            if bch == 0:
                m = (N - 1 + g) % N
                up[hi] = u[m]
                rp[hi] = rho[m]
            elif bch == 2:
                up[hi] = u[N - 1]
                rp[hi] = 0.0
            else:
                uu, rr = B(t, xlo + (N - 0.5 + g) * dx, bp)
                up[hi] = uu
                rp[hi] = rr

    @numba.njit(cache=False)
    def sensor_on(rm, r0, r1, um, u0, u1, tau, speed):
        """Smoothness sensor of a cell from its and its neighbours' values (ρ_{i-1}, ρ_i, ρ_{i+1},
        u_{i-1}, u_i, u_{i+1}): s_ρ = |δ²ρ| / (ρ_{i-1} + 2ρ_i + ρ_{i+1}) and
        s_u = |δ²u| / (|u_{i-1}| + 2|u_i| + |u_{i+1}| + 4 U), U = ``speed``; True when either
        exceeds ``tau``.  Both are O(Δx²) on smooth fields and O(1) at jumps, vacuum edges and
        grid-scale oscillations.  Branch-free (inlined into vectorised loops)."""
        d2r = abs(rm - 2.0 * r0 + r1)
        sr = rm + 2.0 * r0 + r1
        d2u = abs(um - 2.0 * u0 + u1)
        su = abs(um) + 2.0 * abs(u0) + abs(u1) + 4.0 * speed
        return ((sr > 0.0) & (d2r > tau * sr)) | ((su > 0.0) & (d2u > tau * su))

    @numba.njit(cache=False)
    def rhs(t, up, rp, G, N, xlo, dx, W, qz, qw, kp, grav, ep, mp, du, dr, bcl, hyper, wsp, rho_mat, thr,
            sel2, sel_tau):
        """Semi-discrete right-hand side (4.13)-(4.14) at every cell from padded arrays.

        ``hyper`` (κ4 > 0): fourth-difference dissipation -κ4 s/Δx δ⁴q.  ``sel2`` (κ2 > 0):
        sensor-switched second-difference dissipation  +κ2 s/Δx δ²q  at the faces next to cells
        whose smoothness sensor (:func:`sensor_on`) exceeds ``sel_tau``.  s = max|u| + c(max ρ)
        [m/s] for both (c the interaction's bound, ``WS(ρ, wsp)``); ``rho_mat``, ``thr``: with thr > 0 max|u| is taken over the material
        cells only (rho_mat[i] >= thr, rho_mat the density at the start of the step): the velocity
        of vacuum cells is an extension with no physical meaning."""
        frame = M(t, mp)[2]
        h = 0.5 / dx
        INTEGRAL(up, rp, G, N, W, qz, qw, kp, du)
        # contiguous views (cells i-1, i, i+1) so that the loop has no index wrap-around
        # checks and vectorises
        uc = up[G:G + N]
        ul = up[G - 1:G - 1 + N]
        ur = up[G + 1:G + 1 + N]
        rl = rp[G - 1:G - 1 + N]
        rc = rp[G:G + N]
        rr = rp[G + 1:G + 1 + N]
        for i in range(N):
            ui = uc[i]
            x = xlo + (i + 0.5) * dx
            du[i] += -ui * (ur[i] - ul[i]) * h + E(t, x, ui, ep) - grav - frame
            dr[i] = -(rr[i] * ur[i] - rl[i] * ul[i]) * h
        if bcl == 1:
            # the mass flux through the floor uses the even image ρ_{-1} = ρ_0 (zero flux, exact
            # mass conservation); the point-reflected images serve the interaction integral only
            dr[0] = -(rp[G + 1] * up[G + 1] - rp[G] * up[G - 1]) * h
        if hyper > 0.0 or sel2 > 0.0:
            umax = 0.0
            rmax = 0.0
            every = thr <= 0.0
            for i in range(N):                  # uc, rc: contiguous views; branch-free maxima
                a = abs(uc[i]) if (every or rho_mat[i] >= thr) else 0.0
                umax = max(umax, a)
                rmax = max(rmax, rc[i])
            speed = umax + WS(rmax, wsp)
        if sel2 > 0.0:
            # sensor-switched second-difference dissipation in flux form, F_f = κ2 s/Δx (q_f - q_{f-1})
            # on the faces f (between cells f-1 and f) next to a flagged cell; zero mass flux
            # through a floor.  Branch-free passes (flags of cells -1..N, face fluxes, update)
            # so that the loops vectorise.
            coef2 = sel2 * speed / dx
            # contiguous views (no index wrap-around checks): cells k-1 = -2..N-1, k = -1..N,
            # k+1 = 0..N+1 for the flags of cells -1..N
            rm = rp[G - 2:G + N]
            r0 = rp[G - 1:G + N + 1]
            r1 = rp[G:G + N + 2]
            um = up[G - 2:G + N]
            u0 = up[G - 1:G + N + 1]
            u1 = up[G:G + N + 2]
            flag = np.empty(N + 2, dtype=np.bool_)
            for k in range(N + 2):
                flag[k] = sensor_on(rm[k], r0[k], r1[k], um[k], u0[k], u1[k], sel_tau, speed)
            fu = np.empty(N + 1)
            fr = np.empty(N + 1)
            for f in range(N + 1):              # face f between cells f-1 (= u0[f]) and f (= u1[f])
                on = 1.0 if (flag[f] | flag[f + 1]) else 0.0
                fu[f] = on * (coef2 * (u1[f] - u0[f]))
                fr[f] = on * (coef2 * (r1[f] - r0[f]))
            if bcl == 1:
                fr[0] = 0.0
            for i in range(N):
                du[i] += fu[i + 1] - fu[i]
                dr[i] += fr[i + 1] - fr[i]
        if hyper > 0.0:
            # fourth-difference artificial dissipation  -κ4 s/Δx δ⁴q  with one speed s for the
            # whole grid (max|u| + sqrt(κ max ρ)), so that it is a flux difference and conserves
            # mass; at a floor the density uses even images (zero dissipative flux through it)
            coef = hyper * speed / dx
            m = min(N, 2)
            keep = np.empty(2)
            for i in range(m):
                keep[i] = dr[i]
            a2, a1, a0, b1, b2 = up[G - 2:G - 2 + N], up[G - 1:G - 1 + N], up[G:G + N], up[G + 1:G + 1 + N], up[G + 2:G + 2 + N]
            p2, p1, p0, q1, q2 = rp[G - 2:G - 2 + N], rp[G - 1:G - 1 + N], rp[G:G + N], rp[G + 1:G + 1 + N], rp[G + 2:G + 2 + N]
            for i in range(N):                  # contiguous views, branch-free: vectorises
                du[i] -= coef * (a2[i] - 4.0 * a1[i] + 6.0 * a0[i] - 4.0 * b1[i] + b2[i])
                dr[i] -= coef * (p2[i] - 4.0 * p1[i] + 6.0 * p0[i] - 4.0 * q1[i] + q2[i])
            if bcl == 1:
                # at a floor the density's dissipative flux uses even images: cell 0 with
                # ρ_{-1} = ρ_0, ρ_{-2} = ρ_1, cell 1 with ρ_{-1} = ρ_0
                if m > 0:
                    d4r = rp[G + 1] - 4.0 * rp[G] + 6.0 * rp[G] - 4.0 * rp[G + 1] + rp[G + 2]
                    dr[0] = keep[0] - coef * d4r
                if m > 1:
                    d4r = rp[G] - 4.0 * rp[G] + 6.0 * rp[G + 1] - 4.0 * rp[G + 2] + rp[G + 3]
                    dr[1] = keep[1] - coef * d4r

    @numba.njit(cache=False)
    def moving_average(u, rho, up, rp, G, bcl):
        """Near-neighbour average (1/4, 1/2, 1/4) of (5.7), n = 1, from padded arrays.
        At a floor the density uses the even image (mass-conserving)."""
        N = u.size
        ul = up[G - 1:G - 1 + N]
        uc = up[G:G + N]
        ur = up[G + 1:G + 1 + N]
        rl = rp[G - 1:G - 1 + N]
        rc = rp[G:G + N]
        rr = rp[G + 1:G + 1 + N]
        for i in range(N):
            u[i] = 0.25 * (ul[i] + 2.0 * uc[i] + ur[i])
            rho[i] = 0.25 * (rl[i] + 2.0 * rc[i] + rr[i])
        if bcl == 1:
            rho[0] = 0.25 * (3.0 * rp[G] + rp[G + 1])

    @numba.njit(cache=False)
    def extend_velocity(u, rho, thr):
        """Velocity extension into vacuum: every cell with ρ < thr takes the velocity of the
        nearest cell with ρ >= thr (the lower one on a tie).  Velocity has no meaning where
        there is no material; without this, the vacuum above a column free-falls (u = -g t)
        and the central differences and the moving average drag that velocity into the
        material.  One pass over the runs of vacuum cells, no allocation.  Returns the index of
        the highest material cell (-1: none)."""
        N = u.size
        prev = -1                      # last material cell below the current run
        i = 0
        while i < N:
            if rho[i] >= thr:
                prev = i
                i += 1
                continue
            j = i
            while j < N and not rho[j] >= thr:      # a NaN is no material (and ends no run: the
                j += 1                              # loop went on forever on one)
            # vacuum run i..j-1, material at prev (< i, or -1) and j (or N: none); cell m takes
            # u[prev] where m - prev <= j - m, i.e. m <= (prev + j) // 2, else u[j]
            if prev >= 0 or j < N:
                if j >= N:
                    mid = j
                elif prev < 0:
                    mid = i
                else:
                    mid = min(j, (prev + j) // 2 + 1)
                if mid > i:
                    u[i:mid] = u[prev]
                if j > mid:
                    u[mid:j] = u[j]
            i = j
        return prev

    @numba.njit(cache=False)
    def selective_average(u, rho, up, rp, G, bcl, tau, speed):
        """The moving average applied only where a smoothness sensor asks for it.

        Sensor (:func:`sensor_on`) with U = ``speed`` = max|u| + c.  A face
        i+1/2 is switched on when either neighbour has a sensor above ``tau``; the update is the
        (1/4, 1/2, 1/4) average in flux form q_i += (F_{i+1/2} - F_{i-1/2}), F = s (q_{i+1} - q_i)/4,
        so the density stays conservative and the average is the seed's where every face is on."""
        N = u.size
        flag = np.zeros(N + 2, dtype=np.bool_)      # cells -1..N
        for i in range(-1, N + 1):
            ii = G + i
            if ii - 1 < 0 or ii + 1 >= up.size:
                continue
            flag[i + 1] = sensor_on(rp[ii - 1], rp[ii], rp[ii + 1], up[ii - 1], up[ii], up[ii + 1], tau, speed)
        fu = np.zeros(N + 1)
        fr = np.zeros(N + 1)
        for f in range(N + 1):                       # face between cells f-1 and f
            if flag[f] or flag[f + 1]:
                fu[f] = 0.25 * (up[G + f] - up[G + f - 1])
                fr[f] = 0.25 * (rp[G + f] - rp[G + f - 1])
        if bcl == 1:
            fr[0] = 0.0                              # no mass through the floor
        for i in range(N):
            u[i] += fu[i + 1] - fu[i]
            rho[i] += fr[i + 1] - fr[i]

    @numba.njit(cache=False)
    def make_positive(rho):
        """Mass-conserving positivity fix: each cell with ρ < 0 is set to 0 and its deficit is
        taken from the nearest cells with positive density, in proportion to their density,
        widening the neighbourhood until the deficit is covered (a state whose total is negative,
        a failed one, cannot be covered and is set to 0: mass is then created)."""
        N = rho.size
        for i in range(N):
            if rho[i] < 0.0:
                deficit = -rho[i]
                rho[i] = 0.0
                for w in range(1, N):
                    avail = 0.0
                    for j in range(max(0, i - w), min(N, i + w + 1)):
                        if rho[j] > 0.0:
                            avail += rho[j]
                    if avail >= deficit or w == N - 1:
                        f = deficit / avail if avail > 0.0 else 0.0
                        if f > 1.0:
                            f = 1.0
                        for j in range(max(0, i - w), min(N, i + w + 1)):
                            if rho[j] > 0.0:
                                rho[j] -= f * rho[j]
                        break

    @numba.njit(cache=False)
    def interp(up, G, N, xlo, dx, p):
        """Linear interpolation of a padded cell-centred field at position p."""
        q = (p - xlo) / dx - 0.5 + G
        if q < 0.0:
            q = 0.0
        if q > N + 2 * G - 1.000001:
            q = N + 2 * G - 1.000001
        i0 = int(math.floor(q))
        f = q - i0
        return (1.0 - f) * up[i0] + f * up[i0 + 1]

    # -- the step's pieces: the stepper's stages, the error estimate, the combination, the chain
    # of post-step passes and the state checks, each compiled on its own and composed once by
    # ``advance`` below (the controller of the compiled loop) ----------------------------------
    @numba.njit(cache=False)
    def stages(u, rho, t, dt, A, c, hi, n_copy, up, rp, G, upc, rpc, ku, kr, bcl, bch, xlo, dx, W, qz, qw, kp,
               grav, ep, mp, bp, hyper, wsp, vac_thr, sel2, sel_tau, tracers, tracer_mode, xt, vt):
        """The Runge-Kutta stages of one step (the stepper): stage s's state
        y_s = y + Δt Σ_j a_sj k_j is written into the padded arrays' interiors (cells below
        ``n_copy``; the stages update cells below ``hi``), the ghost layers filled, the tracers'
        stage velocities interpolated, and k_s = rhs(t + c_s Δt, y_s) evaluated (4.17)-(4.24)."""
        N = u.size
        s = c.size
        nt = tracers.size
        for st in range(s):
            # unsigned loops: about twice as fast as the slice assignment (no wrap-around
            # code, vectorised)
            for i in range(np.uint64(n_copy)):
                upc[i] = u[i]
            for i in range(np.uint64(n_copy)):
                rpc[i] = rho[i]
            for j in range(st):
                a = A[st, j]
                if a != 0.0:
                    for i in range(hi):
                        upc[i] += dt * a * ku[j, i]
                        rpc[i] += dt * a * kr[j, i]
            ts = t + c[st] * dt
            # ghost layers only (from the interior in place: nothing to copy)
            fill_ghosts_below(upc, rpc, ts, up, rp, G, bcl, bch, xlo, dx, bp, 0)
            if tracer_mode == 2 or (tracer_mode == 1 and st == 0):
                for n in range(nt):
                    xt[n] = tracers[n]
                    if tracer_mode == 2:
                        for j in range(st):
                            xt[n] += dt * A[st, j] * vt[j, n]
                    vt[st, n] = interp(up, G, N, xlo, dx, xt[n])
            rhs(ts, up, rp, G, hi, xlo, dx, W, qz, qw, kp, grav, ep, mp, ku[st], kr[st], bcl, hyper, wsp, rho, vac_thr,
                sel2, sel_tau)

    @numba.njit(cache=False)
    def error_norm(u, rho, dt, b, bhat, ku, kr, hi, atol_u, atol_r, rtol, vac_thr):
        """The embedded error estimate  max_i |Δt Σ_j (b_j - b̂_j) k_j| / (atol + rtol |y|) of u
        and ρ over the cells below ``hi``; with vac_thr > 0 the velocity error of vacuum cells (an
        extension) is not counted."""
        s = b.size
        err = 0.0
        for i in range(hi):
            eu = 0.0
            er = 0.0
            for j in range(s):
                eu += (b[j] - bhat[j]) * ku[j, i]
                er += (b[j] - bhat[j]) * kr[j, i]
            eu = abs(dt * eu) / (atol_u + rtol * abs(u[i]))
            if vac_thr > 0.0 and rho[i] < vac_thr:
                eu = 0.0
            er = abs(dt * er) / (atol_r + rtol * abs(rho[i]))
            if eu > err:
                err = eu
            if er > err:
                err = er
        return err

    @numba.njit(cache=False)
    def compression_monitor(u, dt, dx, tail):
        """max_i (-(u_{i+1} - u_{i-1}) / (2Δx)) Δt on the start-of-step velocity (0 on the uniform
        tail) and its cell: the gradient-catastrophe monitor."""
        N = u.size
        worst = 0.0
        where = -1
        for i in range(1, min(N - 1, tail + 1)):
            comp = -(u[i + 1] - u[i - 1]) / (2.0 * dx) * dt
            if comp > worst:
                worst = comp
                where = i
        return worst, where

    @numba.njit(cache=False)
    def combine(u, rho, dt, b, ku, kr, hi, tracers, tracer_mode, vt, tracer_bc, xlo, dx):
        """y += Δt Σ_j b_j k_j on the cells below ``hi``; the tracers by their integrator
        (1: forward Euler with the start-of-step velocity, 2: the tableau), then ``tracer_bc``
        1: kept above a floor, 2: wrapped into a periodic domain, 0: left as they are."""
        s = b.size
        nt = tracers.size
        for j in range(s):
            bj = b[j]
            if bj != 0.0:
                for i in range(hi):
                    u[i] += dt * bj * ku[j, i]
                    rho[i] += dt * bj * kr[j, i]
        if tracer_mode == 1:
            for n in range(nt):
                tracers[n] += dt * vt[0, n]
        elif tracer_mode == 2:
            for n in range(nt):
                for j in range(s):
                    tracers[n] += dt * b[j] * vt[j, n]
        if tracer_bc == 1:
            for n in range(nt):
                if tracers[n] < xlo:  # floor
                    tracers[n] = xlo
        elif tracer_bc == 2:
            length = u.size * dx
            for n in range(nt):       # periodic: back into [xlo, xlo + N dx)
                rel = tracers[n] - xlo
                tracers[n] = xlo + (rel - length * math.floor(rel / length))

    @numba.njit(cache=False)
    def post_step(u, rho, t, hi, can_skip, filt, positivity, vac_thr, sel_tau, sel2, rho_floor, up, rp, G, bcl,
                  bch, xlo, dx, bp, wsp):
        """The chain of post-step passes, in order: the positivity fix, the velocity extension
        into the vacuum, the moving average (after (4.24)) or the selective average, the density
        floor.  With the vacuum skip they run on the cells below n_act = hi + 2 only: above, ρ = 0
        and (after the extension) u is the top material cell's velocity c, so the extension, the
        moving average (of c, c, c) and the floor would give every cell there the same value,
        which is written directly (bit for bit the same; tested).  Returns (n_act, material):
        the cells above n_act hold ρ = 0 and one velocity; whether any cell holds material."""
        N = u.size
        material = False
        n_act = N
        if can_skip and (filt or not (sel_tau > 0.0 and sel2 <= 0.0)):
            n_act = min(N, hi + 2)
        if positivity:
            make_positive(rho[:n_act])      # ρ = 0 above: neither negative nor a donor
        top_u = 0.0
        if vac_thr > 0.0:
            top = extend_velocity(u[:n_act], rho[:n_act], vac_thr)
            material = top >= 0
            if n_act < N:
                if top < 0:
                    n_act = N               # no material: the whole grid as before
                else:
                    top_u = u[top]
                    u[n_act] = top_u        # read by the moving average of cell n_act - 1
        if filt:
            fill_ghosts_below(u, rho, t, up, rp, G, bcl, bch, xlo, dx, bp, n_act + 1)
            moving_average(u[:n_act], rho[:n_act], up, rp, G, bcl)
            if n_act < N:
                top_u = 0.25 * (top_u + 2.0 * top_u + top_u)
        elif sel_tau > 0.0 and sel2 <= 0.0:
            fill_ghosts(u, rho, t, up, rp, G, bcl, bch, xlo, dx, bp)
            umax = 0.0
            rmax = 0.0
            for i in range(N):
                if abs(u[i]) > umax:
                    umax = abs(u[i])
                if rho[i] > rmax:
                    rmax = rho[i]
            selective_average(u, rho, up, rp, G, bcl, sel_tau, umax + WS(rmax, wsp))
        if rho_floor > 0.0:
            # vacuum debris: |ρ| below the floor is set to 0 at the end of every step (above
            # hi + 1 ρ is exactly 0 already: the stages leave it, the moving average spreads
            # by one cell)
            for i in range(min(N, hi + 2)):
                r = rho[i]
                rho[i] = 0.0 if abs(r) < rho_floor else r
        if n_act < N:
            u[n_act:] = top_u
        return n_act, material

    @numba.njit(cache=False)
    def check_state(u, rho, n_act, rho_max, top_tol, bch, W):
        """The state checks after a step: (status, cell) with status 1 a non-finite value, 2 a
        density above rho_max (> 0), 5 material within the kernel's reach of a vacuum top, else 0
        (the cells above n_act are finite and empty)."""
        N = u.size
        for i in range(n_act):
            if not (math.isfinite(u[i]) and math.isfinite(rho[i])):
                return 1, i
            if rho_max > 0.0 and rho[i] > rho_max:
                return 2, i
        if top_tol > 0.0 and bch == 2:
            for i in range(max(0, N - 1 - W), N):
                if rho[i] > top_tol:
                    return 5, i
        return 0, -1

    @numba.njit(cache=False)
    def advance(u, rho, t, t_end, dt_fixed, cfl, wsp, A, b, c, filt, bcl, bch, xlo, dx, W, qz, qw,
                kp, grav, ep, mp, bp, dt_min, rho_max, max_steps, strain_limit, top_tol,
                tracers, tracer_mode, vac_thr, hyper, positivity, sel_tau, bhat, rtol, atol_u, atol_r,
                err_order, counters, skip_vacuum, sel2, rho_floor):
        """Advance (u, rho, tracers) in place from t to t_end.

        dt: ``dt_fixed`` if > 0, else cfl Δx / (max|u| + c(max ρ)), c = ``WS(ρ, wsp)`` the
        interaction's bound (for the seed's kernel √(κρ)); the last step is
        shortened to land on t_end.  tracer_mode: 0 none, 1 forward Euler with the velocity
        at the start of the step (the seed's), 2 the field's Runge-Kutta tableau with the
        stage velocity fields.  Returns (t, steps, status, where_index, dt_last).

        skip_vacuum: with a vacuum top and velocity extension (vac_thr > 0), the stages update
        only the cells below hi = z + 2 r s + 2 (z: one past the highest cell with ρ != 0 or
        tracer, s stages, r = 1, or 2 with the hyperdiffusion or the sensor dissipation: the
        cells a stage's stencil reaches).  Above, ρ stays exactly 0 during the step and the velocities there are
        overwritten by the extension after it; the dissipations' speed and the adaptive error
        norm of u use the material cells only (ρ >= vac_thr), so they are the same either way.
        The post-step passes (positivity fix, velocity extension, moving average, finiteness
        check) then run below hi + 2 and the uniform velocity above is written directly.
        Tested to give the same result bit for bit through a tap (fixed and adaptive steps, with
        both dissipations).  The skip needs material (ρ >= vac_thr) at the start of the step,
        since only then does the extension overwrite the vacuum velocities; without any the
        whole grid is computed.  Caveats: if the last material cell drops below vac_thr during
        a step, the skipped cells' velocities (of empty cells) differ from the computed ones at
        that step.  And the fast interaction integral chooses its summation
        path from the velocities in a cell's whole window, vacuum included; where the skipped
        and the computed stage velocities of vacuum cells would select different paths, the two
        results differ at round-off (the value is the same sum).

        rho_floor > 0: |ρ| below it is set to 0 at the end of every step (vacuum debris).
        """
        N = u.size
        G = max(W, 2)
        s = b.size
        nt = tracers.size
        up = np.empty(N + 2 * G)
        rp = np.empty(N + 2 * G)
        ku = np.empty((s, N))
        kr = np.empty((s, N))
        upc = up[G:G + N]      # the stage states are written straight into the padded arrays'
        rpc = rp[G:G + N]      # interiors (with the vacuum skip the cells above the stages'
        upc[:] = u             # reach keep earlier values, never read)
        rpc[:] = rho
        vt = np.empty((s, nt))
        xt = np.empty(nt)
        steps = 0
        status = 0
        where = -1
        dt = 0.0
        adaptive = rtol > 0.0
        dt_prop = 1e300
        can_skip = skip_vacuum and vac_thr > 0.0 and bch == 2
        reach = 2 if (hyper > 0.0 or sel2 > 0.0) else 1
        # tracers after a step: 1 kept above the floor (floor, mirror), 2 wrapped (periodic)
        tracer_bc = 1 if (bcl == 1 or bcl == 4) else (2 if bcl == 0 else 0)
        hi = N
        # the skip is exact only when the extension will overwrite the vacuum's velocities:
        # there is material at the start of the step (kept up to date from the extension)
        material = False
        if can_skip:
            for i in range(N):
                if rho[i] >= vac_thr:
                    material = True
                    break
        # tail: u[tail:] all equal u[N-1] and ρ[tail:] = 0 (set by the restricted post-step
        # passes; N: nothing known), so that whole-grid maxima need not read it
        tail = N
        while t < t_end:
            if can_skip and material:
                # ρ = 0 above the previous step's hi + 1 (the stages leave it at 0 there and the
                # moving average spreads it by one cell), so the search starts there
                z = 0
                for i in range(min(N, hi + 1) - 1, -1, -1):
                    if rho[i] != 0.0:
                        z = i + 1
                        break
                for n in range(nt):
                    q = int((tracers[n] - xlo) / dx) + 2
                    if q > z:
                        z = q
                hi = min(N, z + 2 * reach * s + 2)
            else:
                hi = N
            if dt_fixed > 0.0:
                dt = dt_fixed
            else:
                umax = 0.0
                rmax = 0.0
                for i in range(tail):           # branch-free maxima (exact in any order)
                    umax = max(umax, abs(u[i]))
                    rmax = max(rmax, rho[i])
                if tail < N:
                    umax = max(umax, abs(u[N - 1]))
                speed = umax + WS(rmax, wsp)
                if speed == 0.0:
                    # at rest without a wave speed (a state at rest under the zero kernel): the speed the
                    # body force e(t, x, 0) - g - ϑ''(t) gives in one cell, not a single step to the next
                    # event (which ran 0.3 s in one); its largest magnitude over the cells at this t
                    frame = M(t, mp)[2]
                    acc = 0.0
                    for i in range(N):
                        acc = max(acc, abs(E(t, xlo + (i + 0.5) * dx, 0.0, ep) - grav - frame))
                    speed = math.sqrt(dx * acc)
                dt = cfl * dx / speed if speed > 0.0 else t_end - t
            if adaptive and dt_prop < dt:
                dt = dt_prop
            last = False
            if t + dt >= t_end - 1e-12 * max(abs(t_end), dt):
                dt = t_end - t
                last = True
            if dt < dt_min and not last:
                status = 3
                umax = -1.0
                for i in range(N):
                    if abs(u[i]) > umax:
                        umax = abs(u[i])
                        where = i
                break
            # A stage reads the padded arrays only below hi + W + reach (its stencil and
            # window), so with the vacuum skip only those cells are copied
            n_copy = min(N, hi + W + 2) if can_skip else N
            stages(u, rho, t, dt, A, c, hi, n_copy, up, rp, G, upc, rpc, ku, kr, bcl, bch, xlo, dx, W, qz, qw, kp,
                   grav, ep, mp, bp, hyper, wsp, vac_thr, sel2, sel_tau, tracers, tracer_mode, xt, vt)
            if adaptive:
                err = error_norm(u, rho, dt, b, bhat, ku, kr, hi, atol_u, atol_r, rtol, vac_thr)
                fac = 0.9 * err ** (-1.0 / err_order) if err > 0.0 else 5.0
                if err > 1.0:
                    counters[0] += 1
                    dt_prop = dt * max(0.2, fac)
                    if dt_prop < dt_min:
                        status = 3
                        where = 0
                        break
                    continue
                dt_prop = dt * min(5.0, fac)
            if strain_limit > 0.0:
                worst, w_at = compression_monitor(u, dt, dx, tail)
                if w_at >= 0:
                    where = w_at
                if worst > strain_limit:
                    status = 6
                    break
            combine(u, rho, dt, b, ku, kr, hi, tracers, tracer_mode, vt, tracer_bc, xlo, dx)
            t = t_end if last else t + dt
            n_act, mat = post_step(u, rho, t, hi, can_skip, filt, positivity, vac_thr, sel_tau, sel2, rho_floor,
                                   up, rp, G, bcl, bch, xlo, dx, bp, wsp)
            if vac_thr > 0.0:
                material = mat
            tail = n_act
            steps += 1
            status, w_at = check_state(u, rho, n_act, rho_max, top_tol, bch, W)
            if status != 0:
                where = w_at
                break
            if steps >= max_steps and t < t_end:
                status = 4
                break
        return t, steps, status, where, dt

    class Core:
        pass

    core = Core()
    core.fill_ghosts = fill_ghosts
    core.fill_ghosts_below = fill_ghosts_below
    core.rhs = rhs
    core.moving_average = moving_average
    core.interp = interp
    core.extend_velocity = extend_velocity
    core.make_positive = make_positive
    core.selective_average = selective_average
    core.sensor_on = sensor_on
    core.stages = stages
    core.error_norm = error_norm
    core.compression_monitor = compression_monitor
    core.combine = combine
    core.post_step = post_step
    core.check_state = check_state
    core.advance = advance
    return core
