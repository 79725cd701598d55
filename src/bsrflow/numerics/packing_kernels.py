"""Compiled pieces of the packing continuum's two discretisations (issue #18).

Each piece is a separate numba function, composed once by the drivers in
:mod:`bsrflow.numerics.packing`: a right-hand side (or force), a stepper loop, post-step passes
(the history update, the density floor).  :mod:`bsrflow.numerics.packing_reference` has a plain
NumPy twin of every right-hand side, tested to 1e-12.

State of the Eulerian grid: ``q`` of shape (3, n_cells + 4) with two ghost cells on each side,
rows ``RHO`` [kg/m], ``MOM`` = ρu [kg/s], ``HIST`` = ρ δ_max [kg] (conserved form of the history
field carried by the material).  State of the Lagrangian points: positions ``x`` [m], velocities
``v`` [m/s] (floor frame) and the history ``hist`` [m] of the bond beneath each point.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..physics.packing import history_update, packing_force, packing_wave_speed

RHO, MOM, HIST = 0, 1, 2
NG = 2          # ghost cells per side


@numba.njit(cache=True, inline="always")
def clamped_step(t, t_stop, dt_max):
    """(Δt, last): ``dt_max``, or what is left up to ``t_stop`` when that is not more (the last
    step then lands on t_stop exactly)."""
    if t + dt_max >= t_stop:
        return t_stop - t, True
    return dt_max, False


# ------------------------------------------------------------------------------------------------
# Eulerian finite volumes: MUSCL (minmod) reconstruction, HLLE fluxes, SSP-RK3
# ------------------------------------------------------------------------------------------------
@numba.njit(cache=True, inline="always")
def _minmod(a, b):
    if a * b <= 0.0:
        return 0.0
    return a if abs(a) < abs(b) else b


@numba.njit(cache=True, inline="always")
def muscl_face_states(w, v, jl, jr, hs):
    """(left, right) states of field row ``v`` of the primitives ``w`` at the face between padded
    cells jl and jr = jl + 1: the cells' values plus ``hs`` (½, or 0 for first order) times their
    minmod-limited slopes."""
    return (w[v, jl] + hs * _minmod(w[v, jl] - w[v, jl - 1], w[v, jr] - w[v, jl]),
            w[v, jr] - hs * _minmod(w[v, jr] - w[v, jl], w[v, jr + 1] - w[v, jr]))


@numba.njit(cache=True)
def fill_ghosts(q, hi):
    """Floor at face 0: mirror ghosts (ρ even, ρu odd, ρδ_max even).  Vacuum: cells hi+1 and
    hi+2 (read by the reconstruction at the last face) set to 0."""
    for g in range(NG):
        q[RHO, NG - 1 - g] = q[RHO, NG + g]
        q[MOM, NG - 1 - g] = -q[MOM, NG + g]
        q[HIST, NG - 1 - g] = q[HIST, NG + g]
    for k in range(hi + 1, hi + 3):
        q[RHO, NG + k] = 0.0
        q[MOM, NG + k] = 0.0
        q[HIST, NG + k] = 0.0


@numba.njit(cache=True)
def active_top(q, start):
    """Highest cell index (0-based, interior) holding material, searched down from ``start``;
    -1 if none."""
    n = q.shape[1] - 2 * NG
    k = min(start, n - 1)
    while k >= 0 and q[RHO, NG + k] == 0.0:
        k -= 1
    return k


@numba.njit(cache=True, inline="always")
def compaction_face(rl, ul, rr, ur, d, m):
    """True at a face where the material is being packed: the cells' velocities converge
    (u_r < u_l) and at least one of the two cells is below close packing (ρ d < m; a vacuum
    cell, ρ = 0, counts).  The reconstruction there is first order (the cells' own states): a
    compaction front is a shock of pressureless material running into the packing, and the
    limited slopes of the second-order reconstruction put states beyond close packing into the
    face, whose stiff stress gave part of the landing's kinetic energy back (the landed column
    rebounded, docs/model.md)."""
    return ur < ul and min(rl, rr) * d < m


@numba.njit(cache=True, inline="always")
def hlle_waves(rL, uL, hL, rR, uR, hR, d, m, k1, k2, c_cap, rho_tiny):
    """The HLLE wave bounds between the face states L and R (see fv_rhs): returns
    (S_L, S_R, u_L, u_R, P_L, P_R), the velocities set to 0 in vacuum.  Shared by the 1-D flux
    and the n-D flux (:mod:`bsrflow.numerics.packing_nd`)."""
    if rL <= rho_tiny:
        uL = 0.0
    if rR <= rho_tiny:
        uR = 0.0
    pL = packing_force(d - m / rL, hL, k1, k2) if rL > rho_tiny else 0.0
    pR = packing_force(d - m / rR, hR, k1, k2) if rR > rho_tiny else 0.0
    cL = packing_wave_speed(rL, d, m, k2)
    cR = packing_wave_speed(rR, d, m, k2)
    sl, sr = math.sqrt(rL), math.sqrt(rR)
    uh = (sl * uL + sr * uR) / (sl + sr) if sl + sr > 0.0 else 0.0
    dr = rR - rL
    if abs(dr) > 1e-12 * (rL + rR):
        c2 = (pR - pL) / dr
        ch = math.sqrt(c2) if c2 > 0.0 else 0.0
    else:
        ch = max(cL, cR)
    ch = min(ch, c_cap)
    return min(uL - cL, uh - ch), max(uR + cR, uh + ch), uL, uR, pL, pR


@numba.njit(cache=True, inline="always")
def hlle_combine(SL, SR, fL, fR, qL, qR):
    """HLLE flux of one conserved component from its left/right fluxes and states."""
    if SL > 0.0:
        return fL
    if SR < 0.0:
        return fR
    if SR == SL:                                  # SL = SR = 0: no wave leaves the face
        return 0.5 * (fL + fR)
    return (SR * fL - SL * fR + SL * SR * (qR - qL)) * (1.0 / (SR - SL))


@numba.njit(cache=True, inline="always")
def no_tension(f_mass, f_mom, uL, uR):
    """The face's normal momentum flux with no tension: at least the advective flux of the
    upwind side, f_mass · u_upwind (u_L if material flows to the right, else u_R).  The contact
    law carries no tension, so no face may; the HLLE flux's viscous term, of order cΔx/2 with the
    contact wave speed c, would otherwise pull separating material together (a numerical
    cohesion that kept blocks of the flying column at close packing, docs/model.md)."""
    adv = f_mass * (uL if f_mass > 0.0 else uR)
    return f_mom if f_mom > adv else adv


@numba.njit(cache=True, inline="always")
def _hlle(rL, uL, hL, rR, uR, hR, d, m, k1, k2, c_cap, rho_tiny):
    """HLLE flux of (ρu, ρu² + P, ρuδ_max) between the face states L and R (see fv_rhs), the
    momentum flux without tension (:func:`no_tension`)."""
    SL, SR, uL, uR, pL, pR = hlle_waves(rL, uL, hL, rR, uR, hR, d, m, k1, k2, c_cap, rho_tiny)
    f_mass = hlle_combine(SL, SR, rL * uL, rR * uR, rL, rR)
    f_mom = hlle_combine(SL, SR, rL * uL * uL + pL, rR * uR * uR + pR, rL * uL, rR * uR)
    return (f_mass, no_tension(f_mass, f_mom, uL, uR),
            hlle_combine(SL, SR, rL * uL * hL, rR * uR * hR, rL * hL, rR * hR))


@numba.njit(cache=True)
def fv_rhs(q, dq, hi, dx, accel, d, m, k1, k2, c_cap, rho_tiny, w, flux):
    """dq = L(q): the finite-volume right-hand side on cells 0..hi (ghosts filled; cells hi+1,
    hi+2 empty, so that no material crosses face hi+1/2).

    Primitive states w = (ρ, u, δ_max) per cell, minmod-limited linear reconstruction at the
    faces i+1/2, i = -1..hi, first order (the cells' own states) at compaction faces
    (:func:`compaction_face`: converging velocities, a cell below close packing); HLLE flux of (ρu, ρu² + P, ρuδ_max) with Einfeldt's bounds
    S_L = min(u_L − c_L, û − ĉ), S_R = max(u_R + c_R, û + ĉ), û the √ρ-weighted mean velocity and
    ĉ² = (P_R − P_L)/(ρ_R − ρ_L) the secant (Rankine–Hugoniot) sound speed, capped at ``c_cap``;
    at a stress-free edge of the packing (P = 0 on both sides) ĉ = 0, so no material is smeared
    into the vacuum at the packing's sound speed.  The momentum flux carries no tension
    (:func:`no_tension`).  Source: ρ·accel in the momentum [N/m].
    Work arrays: w (3, n+4), flux (3, n+1)."""
    for j in range(hi + 4):                       # cells -2 .. hi+1 (padded index j = NG + k)
        r = q[RHO, j]
        if r > rho_tiny:
            w[0, j], w[1, j], w[2, j] = r, q[MOM, j] / r, q[HIST, j] / r
        else:
            w[0, j], w[1, j], w[2, j] = 0.0, 0.0, 0.0
    w[0, hi + 4], w[1, hi + 4], w[2, hi + 4] = 0.0, 0.0, 0.0
    for f in range(hi + 2):                       # face f - 1/2 between padded cells f+1 and f+2
        jl = f + 1
        jr = f + 2
        # half slopes, none at a compaction face (first order there): a factor, not a branch
        hs = 0.0 if compaction_face(w[0, jl], w[1, jl], w[0, jr], w[1, jr], d, m) else 0.5
        rL, rR = muscl_face_states(w, 0, jl, jr, hs)
        uL, uR = muscl_face_states(w, 1, jl, jr, hs)
        hL, hR = muscl_face_states(w, 2, jl, jr, hs)
        flux[0, f], flux[1, f], flux[2, f] = _hlle(rL, uL, hL, rR, uR, hR, d, m, k1, k2, c_cap, rho_tiny)
    inv_dx = 1.0 / dx
    for k in range(hi + 1):
        dq[0, k] = -(flux[0, k + 1] - flux[0, k]) * inv_dx
        dq[1, k] = -(flux[1, k + 1] - flux[1, k]) * inv_dx + q[RHO, NG + k] * accel
        dq[2, k] = -(flux[2, k + 1] - flux[2, k]) * inv_dx
    return hi


@numba.njit(cache=True)
def fv_post_step(q, hi, d, m, rho_floor):
    """Post-step passes on cells 0..hi: density floor (0 ≤ ρ < ``rho_floor`` → 0 with its momentum
    and history), the history update δ_max ← max(δ_max, δ) in contact, 0 once separated."""
    for k in range(hi + 1):
        j = NG + k
        r = q[RHO, j]
        if r < 0.0:
            continue                              # left for the monitor of fv_advance
        if r < rho_floor:
            q[RHO, j] = 0.0
            q[MOM, j] = 0.0
            q[HIST, j] = 0.0
            continue
        h = q[HIST, j] / r
        q[HIST, j] = r * history_update(d - m / r, h)


@numba.njit(cache=True, inline="always")
def state_failed(q, hi, counters):
    """The monitor after a step: True, with counters[1] = 2 (non-finite ρ or ρu) or 1 (negative
    density) and counters[2] the cell, at the first bad cell of 0..hi; False if all are sound."""
    for k in range(hi + 1):
        r = q[RHO, NG + k]
        if not (math.isfinite(r) and math.isfinite(q[MOM, NG + k])):
            counters[1] = 2
            counters[2] = k
            return True
        if r < 0.0:
            counters[1] = 1
            counters[2] = k
            return True
    return False


@numba.njit(cache=True)
def fv_advance(q, t, t_stop, dx, cfl, c_bound, d, m, k1, k2, rho_tiny, rho_floor, fn, params, gravity,
               counters):
    """Advance the Eulerian state from t to exactly t_stop with SSP-RK3 (Shu–Osher) steps,
    Δt = cfl Δx / (c_bound + max|u|); post-step passes after every step.

    Vacuum skip: with ``top`` the highest cell holding material, every stage works on cells
    0..top+3 (material moves at most one cell per stage at cfl < 1), the cells above stay empty.
    counters: [steps, status, where, top]; status 0 ok, 1 negative density, 2 non-finite,
    3 material near the domain top.  Returns the time reached."""
    n = q.shape[1] - 2 * NG
    q1 = q.copy()
    q2 = q.copy()
    dq = np.zeros((3, n))
    inc1 = np.zeros((3, n))
    inc2 = np.zeros((3, n))
    w = np.zeros((3, n + 2 * NG + 1))
    flux = np.zeros((3, n + 1))
    top = active_top(q, n - 1)
    while t < t_stop:
        if top + 6 > n:
            counters[1] = 3
            counters[2] = top
            return t
        hi = top + 3
        umax = 0.0
        for k in range(top + 1):
            r = q[RHO, NG + k]
            if r > rho_tiny:
                umax = max(umax, abs(q[MOM, NG + k] / r))
        dt = cfl * dx / (c_bound + umax)
        last = False
        if t + dt >= t_stop:
            dt = t_stop - t
            last = True
        # stage 1 (increments k = Δt L(.) kept apart from the state, so that a resting state's
        # round-off does not accumulate in the same direction step after step)
        fill_ghosts(q, hi)
        fv_rhs(q, dq, hi, dx, -gravity - fn(t, params)[2], d, m, k1, k2, c_bound, rho_tiny, w, flux)
        for v in range(3):
            for k in range(hi + 1):
                inc1[v, k] = dt * dq[v, k]
                q1[v, NG + k] = q[v, NG + k] + inc1[v, k]
        # stage 2
        fill_ghosts(q1, hi)
        fv_rhs(q1, dq, hi, dx, -gravity - fn(t + dt, params)[2], d, m, k1, k2, c_bound, rho_tiny, w, flux)
        for v in range(3):
            for k in range(hi + 1):
                inc2[v, k] = dt * dq[v, k]
                q2[v, NG + k] = q[v, NG + k] + 0.25 * (inc1[v, k] + inc2[v, k])
        # stage 3: q + (k1 + k2)/6 + 2 k3/3, the Shu–Osher form rewritten in increments
        fill_ghosts(q2, hi)
        fv_rhs(q2, dq, hi, dx, -gravity - fn(t + 0.5 * dt, params)[2], d, m, k1, k2, c_bound, rho_tiny, w, flux)
        for v in range(3):
            for k in range(hi + 1):
                q[v, NG + k] += (inc1[v, k] + inc2[v, k]) / 6.0 + (2.0 / 3.0) * (dt * dq[v, k])
        fv_post_step(q, hi, d, m, rho_floor)
        t = t_stop if last else t + dt
        counters[0] += 1
        if state_failed(q, hi, counters):
            return t
        top = active_top(q, hi)
    counters[3] = top
    return t


# ------------------------------------------------------------------------------------------------
# Lagrangian material points: pair forces between neighbours, velocity Verlet
# ------------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def lagrangian_forces(x, hist, force, ppd, d, k1, k2):
    """Bond forces P_j [N] for j = 0..M−1 (bond j beneath point j; bond 0 between point 0 and its
    mirror image below the floor, length 2x_0); overlap δ_j = d − ppd·(bond length), since the
    bond's density by characteristics is (m/ppd)/length.  Returns the smallest bond length [m]."""
    M = x.shape[0]
    shortest = 2.0 * x[0]
    force[0] = packing_force(d - ppd * 2.0 * x[0], hist[0], k1, k2)
    for j in range(1, M):
        s = x[j] - x[j - 1]
        shortest = min(shortest, s)
        force[j] = packing_force(d - ppd * s, hist[j], k1, k2)
    return shortest


@numba.njit(cache=True)
def lagrangian_history(x, hist, ppd, d):
    """Post-step pass: δ_max of every bond (module :mod:`bsrflow.physics.packing`)."""
    hist[0] = history_update(d - ppd * 2.0 * x[0], hist[0])
    for j in range(1, x.shape[0]):
        hist[j] = history_update(d - ppd * (x[j] - x[j - 1]), hist[j])


@numba.njit(cache=True)
def lagrangian_advance(x, v, hist, t, t_stop, dt_max, mu, ppd, d, k1, k2, fn, params, gravity, counters):
    """Velocity Verlet (kick–drift–kick) from t to exactly t_stop with Δt ≤ dt_max: points move by
    ẋ = v, the pair forces act between neighbours, the history pass follows each step.
    counters: [steps, status, where]; status 4: a bond length reached 0 (points crossed)."""
    M = x.shape[0]
    force = np.empty(M)
    inv_mu = 1.0 / mu
    lagrangian_forces(x, hist, force, ppd, d, k1, k2)
    while t < t_stop:
        dt, last = clamped_step(t, t_stop, dt_max)
        a0 = -gravity - fn(t, params)[2]
        for i in range(M - 1):
            v[i] += 0.5 * dt * ((force[i] - force[i + 1]) * inv_mu + a0)
        v[M - 1] += 0.5 * dt * (force[M - 1] * inv_mu + a0)
        for i in range(M):
            x[i] += dt * v[i]
        t1 = t_stop if last else t + dt
        shortest = lagrangian_forces(x, hist, force, ppd, d, k1, k2)
        a1 = -gravity - fn(t1, params)[2]
        for i in range(M - 1):
            v[i] += 0.5 * dt * ((force[i] - force[i + 1]) * inv_mu + a1)
        v[M - 1] += 0.5 * dt * (force[M - 1] * inv_mu + a1)
        lagrangian_history(x, hist, ppd, d)
        t = t1
        counters[0] += 1
        if not shortest > 0.0:
            counters[1] = 4
            return t
    return t
