"""Plain NumPy reference of the packing continuum's compiled pieces (issue #18).

A vectorised twin, written from the formulas stated in the docstrings of
:mod:`bsrflow.physics.packing`, :mod:`bsrflow.numerics.packing_kernels` and
:mod:`bsrflow.numerics.packing_nonlocal` (it calls none of the compiled functions), used by
``tests/test_packing.py`` and ``tests/test_packing_nonlocal.py`` to check the compiled code to 1e-12
relative to the scale of the terms.  Every function is pure: it returns new arrays.

Eulerian state: ``q`` of shape (3, n + 4), rows ρ [kg/m], ρu [kg/s], ρδ_max [kg], two ghost
cells on each side (padded index = cell index + 2).  Lagrangian state: positions ``x`` [m],
velocities ``v`` [m/s] and the history ``hist`` [m] of the bond beneath each point (bond 0:
between point 0 and its mirror image below the floor, length 2x_0).

Comparisons at exact ties are written in the same form as the docstrings state them
(ρ d > m for "above close packing", δ = d − m/ρ), so that a state exactly at close packing,
ρ = m/d as the column starts, falls on the same side in both codes.

Units: SI.
"""

from __future__ import annotations

import numpy as np

__all__ = ["RHO", "MOM", "HIST", "NG", "contact_force", "history_update", "wave_speed", "minmod",
           "hlle_flux", "fill_ghosts", "fv_rhs", "fv_post_step", "fv_time_step", "active_top",
           "ssp_rk3_step", "bond_lengths", "lagrangian_forces", "lagrangian_accelerations",
           "lagrangian_history", "verlet_step", "hlle_waves", "hlle_combine", "fv_rhs_nd", "no_tension",
           "tracer_velocity_numpy", "compaction_face", "nonlocal_bond_lengths", "nonlocal_lagrangian_accelerations",
           "nonlocal_lagrangian_history", "nonlocal_verlet_step"]

RHO, MOM, HIST = 0, 1, 2
NG = 2


# ------------------------------------------------------------------------------------------------
# The packing law (physics/packing.py), by its branches
# ------------------------------------------------------------------------------------------------
def contact_force(delta, dmax, k1, k2):
    """Walton–Braun force [N]: 0 for δ ≤ 0; K1 δ on loading (δ ≥ δ_max); on unloading
    (δ < δ_max) max(0, K2 (δ − δ0)) with δ0 = δ_max (1 − K1/K2)."""
    delta = np.asarray(delta, dtype=float)
    dmax = np.asarray(dmax, dtype=float)
    delta0 = dmax * (1.0 - k1 / k2)
    p = np.where(delta >= dmax, k1 * delta, np.maximum(0.0, k2 * (delta - delta0)))
    return np.where(delta > 0.0, p, 0.0)


def history_update(delta, dmax):
    """δ_max after a step [m]: the largest overlap while in contact (δ > 0), 0 once separated."""
    delta = np.asarray(delta, dtype=float)
    return np.where(delta > 0.0, np.maximum(dmax, delta), 0.0)


def wave_speed(rho, d, m, k2):
    """√(K2 m)/ρ above close packing (ρ d > m), 0 below [m/s]."""
    rho = np.asarray(rho, dtype=float)
    above = rho * d > m
    return np.where(above, np.sqrt(k2 * m) / np.where(above, rho, 1.0), 0.0)


# ------------------------------------------------------------------------------------------------
# Eulerian finite volumes
# ------------------------------------------------------------------------------------------------
def minmod(a, b):
    """0 where a and b differ in sign (or one is 0), else the one of smaller modulus."""
    return np.where(a * b <= 0.0, 0.0, np.where(np.abs(a) < np.abs(b), a, b))


def hlle_flux(rL, uL, hL, rR, uR, hR, d, m, k1, k2, c_cap, rho_tiny):
    """HLLE flux of U = (ρ, ρu, ρδ_max), F(U) = (ρu, ρu² + P, ρuδ_max), between face states
    (ρ, u, δ_max)_L and _R, arrays over faces.  Returns an array (3, n_faces).

    Face states at or below ``rho_tiny`` are vacuum: u = 0, P = 0.  Wave speeds (Einfeldt):
    S_L = min(u_L − c_L, û − ĉ), S_R = max(u_R + c_R, û + ĉ), û = (√ρ_L u_L + √ρ_R u_R)/(√ρ_L + √ρ_R)
    (0 between two vacuum states), ĉ² = (P_R − P_L)/(ρ_R − ρ_L) (secant; ĉ = 0 where negative)
    unless |ρ_R − ρ_L| ≤ 1e-12 (ρ_L + ρ_R), then ĉ = max(c_L, c_R); ĉ ≤ c_cap.
    F = F_L if S_L > 0, F_R if S_R < 0, (F_L + F_R)/2 if S_L = S_R, else
    (S_R F_L − S_L F_R + S_L S_R (U_R − U_L)) / (S_R − S_L); then the momentum flux is raised to
    at least the upwind advective flux F_ρ u_upwind (no tension through a face)."""
    SL, SR, uL, uR, pL, pR = hlle_waves(rL, uL, hL, rR, uR, hR, d, m, k1, k2, c_cap, rho_tiny)
    UL = np.array([rL, rL * uL, rL * hL])
    UR = np.array([rR, rR * uR, rR * hR])
    FL = np.array([rL * uL, rL * uL ** 2 + pL, rL * uL * hL])
    FR = np.array([rR * uR, rR * uR ** 2 + pR, rR * uR * hR])
    F = hlle_combine(SL, SR, FL, FR, UL, UR)
    F[1] = no_tension(F[0], F[1], uL, uR)
    return F


def no_tension(f_mass, f_mom, uL, uR):
    """max(f_mom, f_mass u_upwind): the momentum flux carries no tension (u_L where f_mass > 0)."""
    return np.maximum(f_mom, f_mass * np.where(f_mass > 0.0, uL, uR))


def hlle_combine(SL, SR, FL, FR, UL, UR):
    """The HLLE formula of hlle_flux for any components (arrays broadcast over faces)."""
    width = SR - SL
    F = (SR * FL - SL * FR + SL * SR * (UR - UL)) / np.where(width != 0.0, width, 1.0)
    F = np.where(SL == SR, 0.5 * (FL + FR), F)
    F = np.where(SR < 0.0, FR, F)
    return np.where(SL > 0.0, FL, F)


def hlle_waves(rL, uL, hL, rR, uR, hR, d, m, k1, k2, c_cap, rho_tiny):
    """(S_L, S_R, u_L, u_R, P_L, P_R) of hlle_flux (velocities 0 in vacuum)."""
    fullL, fullR = rL > rho_tiny, rR > rho_tiny
    uL = np.where(fullL, uL, 0.0)
    uR = np.where(fullR, uR, 0.0)
    pL = np.where(fullL, contact_force(d - m / np.where(fullL, rL, 1.0), hL, k1, k2), 0.0)
    pR = np.where(fullR, contact_force(d - m / np.where(fullR, rR, 1.0), hR, k1, k2), 0.0)
    cL = wave_speed(rL, d, m, k2)
    cR = wave_speed(rR, d, m, k2)

    wL, wR = np.sqrt(rL), np.sqrt(rR)
    wsum = wL + wR
    u_hat = np.where(wsum > 0.0, (wL * uL + wR * uR) / np.where(wsum > 0.0, wsum, 1.0), 0.0)
    drho = rR - rL
    secant = np.abs(drho) > 1e-12 * (rL + rR)
    c2 = (pR - pL) / np.where(secant, drho, 1.0)
    c_hat = np.where(secant, np.sqrt(np.maximum(c2, 0.0)), np.maximum(cL, cR))
    c_hat = np.minimum(c_hat, c_cap)
    SL = np.minimum(uL - cL, u_hat - c_hat)
    SR = np.maximum(uR + cR, u_hat + c_hat)
    return SL, SR, uL, uR, pL, pR


def fv_rhs_nd(q, dim, dx, accel, d, m, k1, k2, c_cap, rho_tiny):
    """NumPy twin of :func:`bsrflow.numerics.packing_nd.fv_rhs_nd`: q of shape (5, NX, NY, NZ)
    (ρ, ρu_x, ρu_y, ρu_z, ρδ_max); returns dq.  Along every axis: primitives, ghosts (floor
    mirror with u_z odd and the lid at the domain top, a mirror too, along z; periodic along x, y), minmod reconstruction,
    the HLLE flux of (ρ, ρu_n, ρδ_max) and of the transverse momenta with the same wave bounds."""
    q = np.asarray(q, float)
    r = q[0]
    full = r > rho_tiny
    safe = np.where(full, r, 1.0)
    prim = [np.where(full, r, 0.0)] + [np.where(full, q[c] / safe, 0.0) for c in (1, 2, 3, 4)]
    dq = np.zeros_like(q)
    axes = [3] + ([1] if dim == 2 else [1, 2])          # z first, then x (and y)
    for ax in axes:
        normal = {1: 1, 2: 2, 3: 3}[ax]
        others = [c for c in (1, 2, 3) if c != normal]
        w = [np.moveaxis(p_, ax - 1, -1) for p_ in prim]    # the axis last
        if ax == 3:
            lo = [x[..., 1::-1] for x in w]
            lo[normal] = -lo[normal]
            top = [x[..., :-4:-1] for x in w]              # the lid: mirror ghosts, u_z odd
            top[normal] = -top[normal]
            w = [np.concatenate([a, x, b], axis=-1) for a, x, b in zip(lo, w, top)]
        else:
            w = [np.concatenate([x[..., -2:], x, x[..., :3]], axis=-1) for x in w]
        n = w[0].shape[-1] - 5

        first = compaction_face(w[0][..., 1:n + 2], w[normal][..., 1:n + 2], w[0][..., 2:n + 3],
                                w[normal][..., 2:n + 3], d, m)

        def faces(x):
            c = x[..., 1:n + 2]
            left = x[..., 0:n + 1]
            right = x[..., 2:n + 3]
            rr = x[..., 3:n + 4]
            xl = c + 0.5 * minmod(c - left, right - c)
            xr = right - 0.5 * minmod(right - c, rr - right)
            return np.where(first, c, xl), np.where(first, right, xr)

        (rL, rR), (uL, uR), (hL, hR) = faces(w[0]), faces(w[normal]), faces(w[4])
        tL, tR = zip(*[faces(w[c]) for c in others])
        SL, SR, uL0, uR0, pL, pR = hlle_waves(rL, uL, hL, rR, uR, hR, d, m, k1, k2, c_cap, rho_tiny)
        F = {0: hlle_combine(SL, SR, rL * uL0, rR * uR0, rL, rR),
             normal: hlle_combine(SL, SR, rL * uL0 ** 2 + pL, rR * uR0 ** 2 + pR, rL * uL0, rR * uR0),
             4: hlle_combine(SL, SR, rL * uL0 * hL, rR * uR0 * hR, rL * hL, rR * hR)}
        F[normal] = no_tension(F[0], F[normal], uL0, uR0)
        for c, a_, b_ in zip(others, tL, tR):
            a_ = np.where(rL > rho_tiny, a_, 0.0)
            b_ = np.where(rR > rho_tiny, b_, 0.0)
            F[c] = hlle_combine(SL, SR, rL * uL0 * a_, rR * uR0 * b_, rL * a_, rR * b_)
        for c in range(5):
            dq[c] += np.moveaxis(-(F[c][..., 1:] - F[c][..., :-1]) / dx, -1, ax - 1)
        if ax == 3:
            dq[3] += r * accel
    if dim == 2:
        dq[2] = 0.0
    return dq


def fill_ghosts(q, hi):
    """Copy of ``q`` with the floor's mirror ghosts (cells −1, −2 = cells 0, 1 with ρu negated)
    and cells hi+1, hi+2 emptied (the vacuum above the material)."""
    q = np.array(q, dtype=float)
    sign = np.array([1.0, -1.0, 1.0])
    q[:, NG - 1] = sign * q[:, NG]
    q[:, NG - 2] = sign * q[:, NG + 1]
    q[:, NG + hi + 1:NG + hi + 3] = 0.0
    return q


def compaction_face(rl, ul, rr, ur, d, m):
    """The faces where the material is being packed (arrays): u_r < u_l and min(ρ_l, ρ_r) d < m;
    their reconstruction is first order (``packing_kernels.compaction_face``)."""
    return (ur < ul) & (np.minimum(rl, rr) * d < m)


def _face_states(q, hi, rho_tiny, d, m):
    """Minmod-reconstructed primitive states (ρ, u, δ_max) on both sides of faces i+1/2,
    i = −1..hi: two arrays (3, hi+2); at compaction faces (:func:`compaction_face`) the two
    cells' own states."""
    cells = q[:, :NG + hi + 3].copy()             # cells -2 .. hi+2
    cells[:, NG + hi + 1:] = 0.0                  # cells hi+1, hi+2 are vacuum by contract
    r = cells[RHO]
    full = r > rho_tiny
    rs = np.where(full, r, 1.0)
    w = np.where(full, np.array([r, cells[MOM] / rs, cells[HIST] / rs]), 0.0)
    back = w[:, 1:-1] - w[:, :-2]                 # for cells -1 .. hi+1
    fwd = w[:, 2:] - w[:, 1:-1]
    slope = minmod(back, fwd)
    centre = w[:, 1:-1]
    left = centre[:, :-1] + 0.5 * slope[:, :-1]   # cells -1 .. hi: value at their upper face
    right = centre[:, 1:] - 0.5 * slope[:, 1:]    # cells 0 .. hi+1: value at their lower face
    first = compaction_face(centre[0, :-1], centre[1, :-1], centre[0, 1:], centre[1, 1:], d, m)
    left = np.where(first, centre[:, :-1], left)
    right = np.where(first, centre[:, 1:], right)
    return left, right


def fv_rhs(q, hi, dx, accel, d, m, k1, k2, c_cap, rho_tiny):
    """Finite-volume right-hand side on cells 0..hi of a state whose ghosts are filled.

    Returns (dq (3, hi+1), flux (3, hi+2)); flux[:, f] is the flux through face f − 1/2
    (f = 0: the floor).  dq = −(F_{k+1/2} − F_{k−1/2})/Δx + (0, ρ_k accel, 0)."""
    left, right = _face_states(q, hi, rho_tiny, d, m)
    flux = hlle_flux(left[0], left[1], left[2], right[0], right[1], right[2], d, m, k1, k2, c_cap, rho_tiny)
    dq = -(flux[:, 1:] - flux[:, :-1]) / dx
    dq[MOM] += q[RHO, NG:NG + hi + 1] * accel
    return dq, flux


def fv_post_step(q, hi, d, m, rho_floor):
    """Copy of ``q`` after the post-step passes on cells 0..hi: 0 ≤ ρ < rho_floor emptied (with
    momentum and history); elsewhere with ρ > 0 the history update of δ_max = (ρδ_max)/ρ at
    δ = d − m/ρ.  Negative densities are left unchanged."""
    q = np.array(q, dtype=float)
    s = slice(NG, NG + hi + 1)
    r = q[RHO, s]
    empty = (r >= 0.0) & (r < rho_floor)
    live = r >= rho_floor
    rs = np.where(live, r, 1.0)
    new_hist = rs * history_update(d - m / rs, q[HIST, s] / rs)
    q[HIST, s] = np.where(live, new_hist, q[HIST, s])
    for v in range(3):
        q[v, s] = np.where(empty, 0.0, q[v, s])
    return q


def active_top(q):
    """Highest interior cell with ρ ≠ 0 (−1 if none)."""
    nz = np.flatnonzero(q[RHO, NG:q.shape[1] - NG] != 0.0)
    return int(nz[-1]) if nz.size else -1


def fv_time_step(q, dx, cfl, c_bound, rho_tiny):
    """Δt = cfl Δx / (c_bound + max |u|), the maximum over material cells (ρ > rho_tiny)."""
    top = active_top(q)
    r = q[RHO, NG:NG + top + 1]
    mom = q[MOM, NG:NG + top + 1]
    u = np.where(r > rho_tiny, mom / np.where(r > rho_tiny, r, 1.0), 0.0)
    umax = float(np.max(np.abs(u))) if u.size else 0.0
    return cfl * dx / (c_bound + umax)


def ssp_rk3_step(q, t, dt, accel, dx, d, m, k1, k2, c_cap, rho_tiny, rho_floor):
    """One SSP-RK3 (Shu–Osher) step of length ``dt`` from time ``t``, then the post-step passes.

    ``accel(t)``: the acceleration e(t) [m/s²] of the source.  The stages work on cells 0..hi,
    hi = top + 3 (``top`` the highest material cell at the step's start): q1 = q + Δt L(q, t);
    q2 = ¾ q + ¼ (q1 + Δt L(q1, t + Δt)); q_new = ⅓ q + ⅔ (q2 + Δt L(q2, t + Δt/2)).
    Returns (q_new, hi)."""
    hi = active_top(q) + 3
    s = slice(NG, NG + hi + 1)
    law = (d, m, k1, k2, c_cap, rho_tiny)

    def L(state, time):
        return fv_rhs(fill_ghosts(state, hi), hi, dx, accel(time), *law)[0]

    q0 = fill_ghosts(q, hi)
    q1 = q0.copy()
    q1[:, s] = q0[:, s] + dt * L(q0, t)
    q2 = fill_ghosts(q1, hi)
    q2[:, s] = 0.75 * q0[:, s] + 0.25 * (q1[:, s] + dt * L(q1, t + dt))
    q3 = fill_ghosts(q2, hi)
    # ⅓ q + ⅔ (...) with exact weights (the rounded 2/3 would drift the mass by 3e-17 per step)
    q3[:, s] = (q0[:, s] + 2.0 * (q2[:, s] + dt * L(q2, t + 0.5 * dt))) / 3.0
    return fv_post_step(q3, hi, d, m, rho_floor), hi


# ------------------------------------------------------------------------------------------------
# Lagrangian material points
# ------------------------------------------------------------------------------------------------
def bond_lengths(x):
    """Length of the bond beneath each point [m]: 2 x_0 for point 0 (its mirror image below the
    floor), x_j − x_{j−1} above."""
    x = np.asarray(x, dtype=float)
    return np.concatenate([[2.0 * x[0]], np.diff(x)])


def lagrangian_forces(x, hist, ppd, d, k1, k2):
    """Bond forces [N]: the packing law at the bond's overlap δ = d − m/ρ with the density by
    characteristics ρ = (m/ppd)/length, i.e. δ = d − ppd·length."""
    return contact_force(d - ppd * bond_lengths(x), hist, k1, k2)


def lagrangian_accelerations(force, mu, accel):
    """Acceleration of each point [m/s²]: its bond below pushes it up, the bond above pushes it
    down (the top point has none), point mass mu = m/ppd, plus the body acceleration."""
    net = np.append(force[:-1] - force[1:], force[-1])
    return net / mu + accel


def lagrangian_history(x, hist, ppd, d):
    """History of every bond after a step (the packing law's update at its overlap)."""
    return history_update(d - ppd * bond_lengths(x), hist)


def verlet_step(x, v, hist, t, dt, accel, mu, ppd, d, k1, k2):
    """One velocity-Verlet (kick–drift–kick) step of length ``dt`` from ``t``; the forces use the
    history before the step, the history pass follows.  ``accel(t)``: body acceleration e(t).
    Returns (x, v, hist)."""
    f0 = lagrangian_forces(x, hist, ppd, d, k1, k2)
    v_half = v + 0.5 * dt * lagrangian_accelerations(f0, mu, accel(t))
    x_new = x + dt * v_half
    f1 = lagrangian_forces(x_new, hist, ppd, d, k1, k2)
    v_new = v_half + 0.5 * dt * lagrangian_accelerations(f1, mu, accel(t + dt))
    return x_new, v_new, lagrangian_history(x_new, hist, ppd, d)


# ------------------------------------------------------------------------------------------------
# Lagrangian material points, nonlocal interaction (numerics/packing_nonlocal.py)
# ------------------------------------------------------------------------------------------------
def nonlocal_bond_lengths(x, lag):
    """Length [m] of the bond of lag ℓ beneath each point j: x_j − x_{j−ℓ}, or for j < ℓ
    x_j + x_{ℓ−1−j} (to the mirror image of point ℓ − 1 − j below the floor)."""
    x = np.asarray(x, dtype=float)
    j = np.arange(x.size)
    lower = np.where(j >= lag, x[np.maximum(j - lag, 0)], -x[np.clip(lag - 1 - j, 0, x.size - 1)])
    return x - lower


def nonlocal_lagrangian_accelerations(x, hist, weights, ppd, d, k1, k2, mu):
    """Accelerations [m/s²] from the bonds (no gravity): bond (ℓ, j) pushes point j up and point
    j − ℓ down (its mirror image's reaction goes to the floor) with w_ℓ P(δ, hist[ℓ−1, j]),
    δ = d − (ppd/ℓ)·length.  Returns (accelerations, bond forces (L, M) [N])."""
    x = np.asarray(x, dtype=float)
    M = x.size
    acc = np.zeros(M)
    forces = np.zeros((len(weights), M))
    for lag in range(1, len(weights) + 1):
        f = weights[lag - 1] * contact_force(d - ppd / lag * nonlocal_bond_lengths(x, lag), hist[lag - 1], k1, k2)
        forces[lag - 1] = f
        acc += f
        acc[:M - lag] -= f[lag:]
    return acc / mu, forces


def nonlocal_lagrangian_history(x, hist, ppd, d):
    """History of every bond (ℓ, j) after a step."""
    return np.array([history_update(d - ppd / lag * nonlocal_bond_lengths(x, lag), hist[lag - 1])
                     for lag in range(1, hist.shape[0] + 1)])


def nonlocal_verlet_step(x, v, hist, weights, t, dt, accel, mu, ppd, d, k1, k2):
    """One velocity-Verlet step of the nonlocal form (as :func:`verlet_step`).  Returns (x, v, hist)."""
    a0, _ = nonlocal_lagrangian_accelerations(x, hist, weights, ppd, d, k1, k2, mu)
    v_half = v + 0.5 * dt * (a0 + accel(t))
    x_new = x + dt * v_half
    a1, _ = nonlocal_lagrangian_accelerations(x_new, hist, weights, ppd, d, k1, k2, mu)
    v_new = v_half + 0.5 * dt * (a1 + accel(t + dt))
    return x_new, v_new, nonlocal_lagrangian_history(x_new, hist, ppd, d)


# ------------------------------------------------------------------------------------------------
# n-D tracers (numerics/tracers.py, tracer_velocity)
# ------------------------------------------------------------------------------------------------
def tracer_velocity_numpy(q, points, lo, dx, rho_tiny):
    """Velocities (n, 3) [m/s] at ``points`` (n, 3) [m] on the n-D state q (ρ, ρu_x, ρu_y, ρu_z
    first, NX, NY, NZ), cells of size ``dx`` [m] (one number, or one per axis): the
    interpolated momentum over the interpolated density, u = Σ w ρu / Σ w ρ, with the trilinear
    weights w of the surrounding cell centres (bilinear when NY = 1), periodic sides, mirror cells
    (ρ even, ρu_z odd) below the lowest and above the highest cell centre; 0 where Σ w ρ ≤
    ``rho_tiny``."""
    _, NX, NY, NZ = q.shape
    pts = np.asarray(points, dtype=float)
    lo = np.asarray(lo, dtype=float)
    s = (pts - lo) / dx - 0.5
    base = np.floor(s).astype(int)
    frac = s - base
    if NY == 1:
        base[:, 1] = 0
        frac[:, 1] = 0.0
    num = np.zeros((pts.shape[0], 3))
    den = np.zeros(pts.shape[0])
    for a in (0, 1):
        for b in ((0, 1) if NY > 1 else (0,)):
            for c in (0, 1):
                w = ((frac[:, 0] if a else 1 - frac[:, 0]) * ((frac[:, 1] if b else 1 - frac[:, 1]) if NY > 1 else 1.0)
                     * (frac[:, 2] if c else 1 - frac[:, 2]))
                i = np.mod(base[:, 0] + a, NX)
                j = np.mod(base[:, 1] + b, NY)
                k = base[:, 2] + c
                sgn = np.where((k < 0) | (k >= NZ), -1.0, 1.0)
                k = np.where(k < 0, -1 - k, np.where(k >= NZ, 2 * NZ - 1 - k, k))
                k = np.clip(k, 0, NZ - 1)
                den += w * q[0, i, j, k]
                num[:, 0] += w * q[1, i, j, k]
                num[:, 1] += w * q[2, i, j, k]
                num[:, 2] += w * sgn * q[3, i, j, k]
    safe = np.where(den > rho_tiny, den, 1.0)
    return np.where((den > rho_tiny)[:, None], num / safe[:, None], 0.0)
