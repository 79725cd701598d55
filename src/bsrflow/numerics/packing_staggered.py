"""Formulation (a) of the nonlocal packing interaction: a staggered Lagrange-remap step on the
fixed grid with a tracked free surface (issue #18; docs/model.md, "The Eulerian form of the
nonlocal interaction").

The state lives on the grid of :class:`~bsrflow.numerics.grid.Grid1D` (cells of width Δx, faces
x_f = fΔx, the floor at face 0):

* ``mass[j]`` [kg]: the mass of cell j (ρ_j Δx in the packed bulk; the top cell, below);
* ``velocity[f]`` [m/s]: the velocity of the material at face f (floor frame), staggered from
  the mass; face 0 is the floor (a wall, velocity 0);
* the free surface: the top of the material is a node of its own at height X, moved with its
  velocity (dX/dt = v_s), so the jump from the packing to the vacuum stays sharp.  The top cell K
  spans [x_K, X], kept between Δx/2 and 3Δx/2 long by splitting it (when X − x_K > 3Δx/2) or
  merging it with the cell below (when < Δx/2), each conserving mass and momentum;
* ``delta_max[ℓ−1, f]`` [m]: the history of the bond from face f to the node ℓ faces above it
  (the surface node counts as the face above the top cell), and ``delta_max_image[g, h]`` that
  of the bond from node g to the mirror image of node h below the floor.

**The interaction** (:func:`bond_forces`) is the nonlocal one of the Lagrangian form
(:mod:`bsrflow.numerics.packing_nonlocal`) with the grid's nodes as its material points: a bond
joins two nodes f < g, spans the cells between them, of mass s = Σ_{f ≤ j < g} m_j [kg] and
length x_g − x_f [m], has the overlap per contact δ = d − m (x_g − x_f)/s (the density by
characteristics over the bond, (3.10)–(3.12)) and pushes its ends apart with the force
w(s) (M_f M_g/μ²) P(δ, δ_max) [N]: P the Walton–Braun law of :func:`~bsrflow.physics.packing.packing_force`,
M the nodes' masses (half of each adjacent cell; the floor node the whole of cell 0 with its
mirror half), μ = m/ppd, and w(s) the Lagrangian form's bond weight w_ℓ read at ℓ = s/μ (zero
from s = (L + ½)μ on).  On the packed column (cells of mass μ) these are exactly the
Lagrangian form's bonds and weights, so a uniform strain transmits the packing stress P.  The
floor is a mirror: node g is bonded to the image of node h ≥ 1 at −x_h (mass s = M(x_g) + M(x_h)
between them), which pushes node g only.  Antisymmetric bonds: momentum is conserved but for the
floor's reaction.

**A step** of Δt = cfl · 2/ω_max (ω_max the bond network's bound,
:func:`~bsrflow.numerics.packing_nonlocal.nonlocal_time_step_bound`):

1. a Lagrangian step: velocity Verlet of the nodes under the bonds, gravity and the floor
   frame's acceleration −g − ϑ''(t) (the cells keep their masses; the nodes move to y_f);
2. the remap to the fixed faces: the cells' masses by the mass between the fixed faces under the
   moved cells (density linear in each moved cell with a central slope where the cell and its
   neighbours are at least half packed, uniform elsewhere; conservative), the nodes' momenta over
   their dual cells (the mass crossing the centre of cell j is the mean of the crossings of its
   two faces, carrying the upwind node's velocity with Fromm's slope in the packed bulk;
   conservative); the surface node stays where the Lagrangian step put it;
3. the bonds' histories are carried with the material (first-order upwind in the lower node,
   at each lag, by the nodes' displacement) and updated as in the Lagrangian form: δ_max =
   max(δ_max, δ) while the bond is compressed, 0 once it opens (δ ≤ 0).  (The update is done in
   the next step's first force pass, bond by bond before its force, which it leaves unchanged;
   at the end of :func:`staggered_advance` by a pass of its own, so that the state it leaves is
   current and its next call starts from the histories as they are.)

No acoustic dissipation: the packed material is moved by the Lagrangian step (energy-conserving
Verlet), and the remap moves it by the flow speed's displacement only (of order 1e-3 of a cell
per step), whose first-order errors act only where the material is dilute or at the surface.
That is what the finite-volume trial (HLLE, a smeared surface) lacked: it damped the interaction's
short waves and had no packed top for the bonds to throw (docs/model.md).

Units: SI; masses [kg], lengths [m], velocities [m/s], forces [N].
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..physics.packing import history_update, packing_force

__all__ = ["bond_forces", "bond_forces_numpy", "staggered_advance", "weight_norm"]

# status codes of staggered_advance (counters[1])
OK, BAD_CELL, DOMAIN_TOP = 0, 2, 3
# what a pass of bond_forces does (its ``mode``)
FORCES, UPDATE, UPDATE_AND_FORCES = 0, 1, 2


def weight_norm(n_lags: int) -> float:
    """1 / Σ_ℓ ℓ (1 − (ℓ − ½)/L): the normalisation of the bond weights
    (:func:`bsrflow.physics.packing.bond_weights`)."""
    lags = np.arange(1, int(n_lags) + 1, dtype=float)
    return 1.0 / float(np.sum(lags * (1.0 - (lags - 0.5) / n_lags)))


@numba.njit(cache=True, inline="always")
def _weight(s, mu, n_lags, norm):
    """w(s): the bond weight w_ℓ ∝ 1 − (ℓ − ½)/L read at ℓ = s/μ, zero beyond."""
    r = 1.0 - (s / mu - 0.5) / n_lags
    return norm * r if r > 0.0 else 0.0


@numba.njit(cache=True, error_model="numpy")
def bond_forces(xn, mass, K, d, m_sph, k1, k2, mu, n_lags, norm, force, cum, mnode, hist, himg, mode):
    """Node forces [N] (``force[0..K+1]``) of the bonds, nodes 0..K at ``xn[0..K]`` and the
    surface node K + 1 at ``xn[K+1]``, cells 0..K of masses ``mass``; fills ``cum`` (the mass
    below each node) and ``mnode`` (the nodes' masses).  ``mode`` FORCES (0): the forces with
    the histories as they are; UPDATE (1): only update the histories at this configuration
    (module docstring, step 3); UPDATE_AND_FORCES (2): update each bond's history, then its force
    with it (one pass; the forces are those of an UPDATE pass followed by a FORCES pass)."""
    update = mode != FORCES
    forces = mode != UPDATE
    cum[0] = 0.0
    for j in range(K + 1):
        cum[j + 1] = cum[j] + mass[j]
    mnode[0] = mass[0]
    for f in range(1, K + 1):
        mnode[f] = 0.5 * (mass[f - 1] + mass[f])
    mnode[K + 1] = 0.5 * mass[K]
    smax = (n_lags + 0.5) * mu
    nl = hist.shape[0]
    for f in range(K + 2):
        force[f] = 0.0
    for f in range(K + 1):
        for g in range(f + 1, K + 2):
            s = cum[g] - cum[f]
            if s >= smax:
                break
            delta = d - m_sph * (xn[g] - xn[f]) / s
            lag = g - f
            hd = hist[lag - 1, f] if lag <= nl else 0.0
            if update and lag <= nl:
                hd = history_update(delta, hd)
                hist[lag - 1, f] = hd
            if forces and delta > 0.0:
                p = _weight(s, mu, n_lags, norm) * mnode[f] * mnode[g] / (mu * mu) * packing_force(delta, hd, k1, k2)
                force[g] += p
                force[f] -= p
    for g in range(1, K + 2):
        for h in range(1, K + 2):
            s = cum[g] + cum[h]
            if s >= smax:
                break
            delta = d - m_sph * (xn[g] + xn[h]) / s
            inside = g < himg.shape[0] and h < himg.shape[1]
            hd = himg[g, h] if inside else 0.0
            if update and inside:
                hd = history_update(delta, hd)
                himg[g, h] = hd
            if forces and delta > 0.0:
                force[g] += _weight(s, mu, n_lags, norm) * mnode[g] * mnode[h] / (mu * mu) * packing_force(delta, hd,
                                                                                                        k1, k2)


def bond_forces_numpy(xn, mass, K, d, m_sph, k1, k2, mu, n_lags, hist, himg):
    """Plain NumPy reference of :func:`bond_forces` (the force pass): the same formula, bond by
    bond as arrays.  Returns the forces [N] on nodes 0..K+1."""
    norm = weight_norm(n_lags)
    m = np.asarray(mass[:K + 1], dtype=float)
    cum = np.concatenate([[0.0], np.cumsum(m)])
    mnode = np.concatenate([[m[0]], 0.5 * (m[:-1] + m[1:]), [0.5 * m[-1]]])
    x = np.asarray(xn[:K + 2], dtype=float)
    smax = (n_lags + 0.5) * mu
    f_idx, g_idx = np.triu_indices(K + 2, 1)
    s = cum[g_idx] - cum[f_idx]
    lag = g_idx - f_idx
    nl = hist.shape[0]
    hd = np.where(lag <= nl, hist[np.minimum(lag, nl) - 1, f_idx], 0.0)
    force = np.zeros(K + 2)
    ok = s < smax
    delta = d - m_sph * (x[g_idx] - x[f_idx]) / np.where(ok, s, 1.0)
    w = norm * np.maximum(0.0, 1.0 - (s / mu - 0.5) / n_lags)
    dm = np.maximum(hd, delta)
    p = np.where(ok & (delta > 0.0), w * mnode[f_idx] * mnode[g_idx] / mu ** 2
                 * np.maximum(0.0, k1 * dm - k2 * (dm - delta)), 0.0)
    np.add.at(force, g_idx, p)
    np.add.at(force, f_idx, -p)
    g2, h2 = np.meshgrid(np.arange(1, K + 2), np.arange(1, K + 2), indexing="ij")
    g2, h2 = g2.ravel(), h2.ravel()
    s = cum[g2] + cum[h2]
    ok = s < smax
    inside = (g2 < himg.shape[0]) & (h2 < himg.shape[1])
    hd = np.where(inside, himg[np.minimum(g2, himg.shape[0] - 1), np.minimum(h2, himg.shape[1] - 1)], 0.0)
    delta = d - m_sph * (x[g2] + x[h2]) / np.where(ok, s, 1.0)
    w = norm * np.maximum(0.0, 1.0 - (s / mu - 0.5) / n_lags)
    dm = np.maximum(hd, delta)
    p = np.where(ok & (delta > 0.0), w * mnode[g2] * mnode[h2] / mu ** 2
                 * np.maximum(0.0, k1 * dm - k2 * (dm - delta)), 0.0)
    np.add.at(force, g2, p)
    return force


@numba.njit(cache=True, inline="always")
def _mass_below(y, rho, slope, j, x):
    """Mass [kg] of the moved cell j (from y[j] to y[j+1], density rho[j] + slope[j](ξ − centre))
    below x."""
    e = x - y[j]
    return e * (rho[j] - slope[j] * (y[j + 1] - y[j] - e) / 2.0)


@numba.njit(cache=True, error_model="numpy")
def staggered_advance(mass, v, hist, himg, surf, t, t_stop, dt, dx, d, m_sph, k1, k2, mu, n_lags, norm, rho_c,
                      fn, params, gravity, counters):
    """Steps from t to t_stop (no velocity jump inside: the controller applies them).  ``surf`` =
    [K, X, v_s] (the top cell, the surface height [m], its velocity [m/s]); ``counters`` =
    [steps, status, where].  Returns the time reached (the step's where the run stopped)."""
    n = mass.shape[0]
    K = int(surf[0])
    X = surf[1]
    vs = surf[2]
    xn = np.zeros(n + 2)
    y = np.zeros(n + 2)
    vn = np.zeros(n + 2)
    force = np.zeros(n + 2)
    cum = np.zeros(n + 2)
    mnode = np.zeros(n + 2)
    rho = np.zeros(n + 1)
    slope = np.zeros(n + 1)
    mnew = np.zeros(n + 1)
    crossed = np.zeros(n + 2)
    phi = np.zeros(n + 2)
    vface = np.zeros(n + 2)
    hcol = np.zeros(n + 2)
    nl = hist.shape[0]
    first = True
    while t < t_stop:
        h = dt
        last = False
        if t + h >= t_stop or t + 1.01 * h >= t_stop:
            h = t_stop - t
            last = True
        for f in range(K + 1):
            xn[f] = f * dx
            vn[f] = v[f]
        xn[K + 1] = X
        vn[K + 1] = vs
        vn[0] = 0.0
        # 1. the Lagrangian step: velocity Verlet of the nodes
        g0 = -gravity - fn(t, params)[2]
        # the previous step's history update (step 3) at this configuration and the forces, in one
        # pass; at the call's first step the histories are the state's as given (the initial
        # ones, or those updated at the end of the call that left the state)
        bond_forces(xn, mass, K, d, m_sph, k1, k2, mu, n_lags, norm, force, cum, mnode, hist, himg,
                    FORCES if first else UPDATE_AND_FORCES)
        first = False
        for f in range(1, K + 2):
            vn[f] += 0.5 * h * (force[f] / mnode[f] + g0)
        for f in range(K + 2):
            y[f] = xn[f] + h * vn[f]
        y[0] = 0.0
        g1 = -gravity - fn(t + h, params)[2]
        bond_forces(y, mass, K, d, m_sph, k1, k2, mu, n_lags, norm, force, cum, mnode, hist, himg, FORCES)
        for f in range(1, K + 2):
            vn[f] += 0.5 * h * (force[f] / mnode[f] + g1)
        # 2. the remap of the cells' masses to the fixed faces
        for j in range(K + 1):
            rho[j] = mass[j] / (y[j + 1] - y[j])
        for j in range(K + 1):
            slope[j] = 0.0
            if 1 <= j <= K - 2 and min(rho[j - 1], min(rho[j], rho[j + 1])) > 0.5 * rho_c:
                slope[j] = (rho[j + 1] - rho[j - 1]) / (0.5 * (y[j + 2] + y[j + 1]) - 0.5 * (y[j] + y[j - 1]))
        prev = 0.0
        crossed[0] = 0.0
        for f in range(1, K + 1):
            x = f * dx
            if x >= y[f]:
                below = cum[f] + _mass_below(y, rho, slope, f, x)
            else:
                below = cum[f] - (mass[f - 1] - _mass_below(y, rho, slope, f - 1, x))
            crossed[f] = below - cum[f]          # > 0: mass moved down across face f
            mnew[f - 1] = below - prev
            prev = below
        mnew[K] = cum[K + 1] - prev
        crossed[K + 1] = 0.0
        # ... and of the nodes' momenta over their dual cells
        for j in range(K + 1):
            phi[j] = 0.5 * (crossed[j] + crossed[j + 1])     # > 0: mass down across the centre of cell j
        for j in range(K + 1):
            up = j + 1 if phi[j] > 0.0 else j
            vt = vn[up]
            if 2 <= up <= K - 1 and min(min(rho[up - 2], rho[up - 1]), min(rho[up], rho[up + 1])) > 0.5 * rho_c:
                sl = 0.25 * (vn[up + 1] - vn[up - 1])
                vt = vn[up] - sl if phi[j] > 0.0 else vn[up] + sl
            vface[j] = vt
        for f in range(1, K + 1):
            v[f] = (mnode[f] * vn[f] + phi[f] * vface[f] - phi[f - 1] * vface[f - 1]) / (0.5 * (mnew[f - 1] + mnew[f]))
        vs = (mnode[K + 1] * vn[K + 1] - phi[K] * vface[K]) / (0.5 * mnew[K])
        v[0] = 0.0
        for j in range(K + 1):
            mass[j] = mnew[j]
        X = y[K + 1]
        # 3. the bonds' histories move with the material
        for lag in range(nl):
            for f in range(K + 2):
                hcol[f] = hist[lag, f]
            for f in range(1, K + 1):
                c = (y[f] - f * dx) / dx
                if c > 0.0:
                    hist[lag, f] = hcol[f] - c * (hcol[f] - hcol[f - 1])
                else:
                    hist[lag, f] = hcol[f] - c * (hcol[f + 1] - hcol[f])
        # the top cell between Δx/2 and 3Δx/2: split or merge (mass and momentum conserved)
        if X - K * dx > 1.5 * dx:
            if K + 4 >= n:
                counters[1] = DOMAIN_TOP
                counters[2] = K
                t += h
                break
            m_low = mass[K] * dx / (X - K * dx)
            m_up = mass[K] - m_low
            v[K + 1] = (m_up * v[K] + m_low * vs) / mass[K]
            mass[K + 1] = m_up
            mass[K] = m_low
            for f in range(K + 1):                         # the surface's bonds: one lag longer
                old = K + 1 - f
                if old + 1 <= nl:
                    hist[old, f] = hist[old - 1, f]
            K += 1
        elif X - K * dx < 0.5 * dx and K > 1:
            mk = mass[K]
            mk1 = mass[K - 1]
            m_node = 0.5 * (mass[K - 2] + mk1)
            v[K - 1] = (m_node * v[K - 1] + 0.5 * mk * v[K]) / (m_node + 0.5 * mk)
            vs = (0.5 * mk * vs + 0.5 * mk1 * v[K]) / (0.5 * mk + 0.5 * mk1)
            mass[K - 1] = mk1 + mk
            mass[K] = 0.0
            v[K] = 0.0
            for f in range(K):                             # the surface's bonds: one lag shorter
                old = K + 1 - f
                if old <= nl:
                    hist[old - 2, f] = hist[old - 1, f]
            K -= 1
        # (the histories' update at the new configuration is the next step's first pass)
        t = t_stop if last else t + h
        counters[0] += 1
        bad = -1
        if not (math.isfinite(X) and math.isfinite(vs)):
            bad = K
        for j in range(K + 1):
            if not (mass[j] > 0.0 and math.isfinite(v[j])):
                bad = j
                break
        if bad >= 0:
            counters[1] = BAD_CELL
            counters[2] = bad
            break
    if counters[1] == OK:
        # the histories at the configuration reached, as the state to save (the next step's
        # first pass repeats this update, a no-op)
        for f in range(K + 1):
            xn[f] = f * dx
        xn[K + 1] = X
        bond_forces(xn, mass, K, d, m_sph, k1, k2, mu, n_lags, norm, force, cum, mnode, hist, himg, UPDATE)
    surf[0] = K
    surf[1] = X
    surf[2] = vs
    return t
