"""Compiled pieces of the nonlocal packing interaction (``range_over_d`` > 0), the Lagrangian
formulation (b).

The interaction (:mod:`bsrflow.physics.packing`, docs/model.md): material elements up to the mass
S = m R/d apart (one sphere's mass for R = d; in the packed state, one diameter apart) are bonded;
a bond spanning the mass s has the overlap per contact δ = d − m·(length)/s, the mean overlap of
the material it spans, and carries the force w P(δ, δ_max) of the DEM's Walton–Braun law with its
own history δ_max (every bond is a contact), never tensile.  With the material discretised by
points of mass μ = m/ppd, bonds join points ℓ = 1..L apart, L = round(ppd R/d), with the weights
w_ℓ of :func:`bsrflow.physics.packing.bond_weights` (the seed's (R − |z|) profile, Σ ℓ w_ℓ = 1:
a uniform strain transmits the packing stress P).  The floor is a mirror: the material below it is
the image of the material above, and a bond to an image point pushes its real end only (the floor
takes the reaction).  State: positions x [m], velocities v [m/s] (floor frame), the histories
(L, points) [m].

The Eulerian formulation (a) of the same bonds is :mod:`bsrflow.numerics.packing_staggered` (a
staggered Lagrange-remap step with a tracked free surface; the finite-volume trial of
``bench/check_nonlocal_eulerian.py`` lost the interaction's dispersion, docs/model.md).
:mod:`bsrflow.numerics.packing_reference` has a NumPy twin of every right-hand side and pass here.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..physics.packing import history_update, packing_force
from .packing_kernels import clamped_step


def nonlocal_time_step_bound(weights, ppd, k2, m):
    """2/ω_max [s] of the bond network, with the Gershgorin bound ω_max² ≤ 4 K2 ppd²/m Σ_ℓ w_ℓ/ℓ
    (a bond of lag ℓ has the stiffness w_ℓ K2 ppd/ℓ on points of mass m/ppd; a mirror bond's
    doubled stiffness on one point keeps the row sum).  For L = 1, w = 1 it is the local form's
    h/c."""
    lags = np.arange(1, len(weights) + 1)
    return 2.0 / math.sqrt(4.0 * k2 * ppd * ppd / m * float(np.sum(np.asarray(weights) / lags)))


@numba.njit(cache=True, inline="always")
def _bond_length(x, j, lag):
    """Length [m] of the bond of lag ``lag`` beneath point j: to point j − lag, or for j < lag to
    the mirror image of point lag − 1 − j below the floor (at −x[lag − 1 − j])."""
    i = j - lag
    return x[j] - x[i] if i >= 0 else x[j] + x[lag - 1 - j]


@numba.njit(cache=True)
def nonlocal_lagrangian_accelerations(x, hist, acc, weights, ppd, d, k1, k2, inv_mu, update_history=False):
    """Accelerations acc [m/s²] of the points from the bonds of the nonlocal packing interaction
    (no gravity): bond (ℓ, j), ℓ = 1..L = len(weights), joins point j to point j − ℓ (its mirror
    image below the floor for j < ℓ, whose reaction the floor takes); overlap
    δ = d − (ppd/ℓ)·length (the density by characteristics of the mass ℓ m/ppd it spans), force
    w_ℓ P(δ, hist[ℓ − 1, j]) [N] (every bond is a contact with its own history), pushing j up and
    j − ℓ down.  ``update_history``: after each bond's force, its history pass
    (:func:`nonlocal_lagrangian_history`, fused: the same result, one evaluation of the length).
    Returns the smallest distance between neighbouring points (lag-1 bond lengths, the floor's
    included) [m]."""
    M = x.shape[0]
    for j in range(M):
        acc[j] = 0.0
    for lag in range(1, weights.shape[0] + 1):
        w = weights[lag - 1] * inv_mu
        s = ppd / lag
        for j in range(min(lag, M)):                # the bonds to the floor's mirror images
            delta = d - s * (x[j] + x[lag - 1 - j])
            f = w * packing_force(delta, hist[lag - 1, j], k1, k2)
            if update_history:
                hist[lag - 1, j] = history_update(delta, hist[lag - 1, j])
            acc[j] += f
        for j in range(lag, M):
            delta = d - s * (x[j] - x[j - lag])
            f = w * packing_force(delta, hist[lag - 1, j], k1, k2)
            if update_history:
                hist[lag - 1, j] = history_update(delta, hist[lag - 1, j])
            acc[j] += f
            acc[j - lag] -= f
    shortest = 2.0 * x[0]
    for j in range(1, M):
        shortest = min(shortest, x[j] - x[j - 1])
    return shortest


@numba.njit(cache=True)
def nonlocal_lagrangian_history(x, hist, ppd, d):
    """Post-step pass: δ_max of every bond (ℓ, j) (:func:`nonlocal_lagrangian_accelerations`),
    reset where the bond's overlap is ≤ 0."""
    for lag in range(1, hist.shape[0] + 1):
        s = ppd / lag
        for j in range(x.shape[0]):
            hist[lag - 1, j] = history_update(d - s * _bond_length(x, j, lag), hist[lag - 1, j])


@numba.njit(cache=True)
def nonlocal_lagrangian_advance(x, v, hist, weights, t, t_stop, dt_max, mu, ppd, d, k1, k2, fn, params,
                                gravity, counters):
    """Velocity Verlet of the nonlocal Lagrangian form from t to exactly t_stop with Δt ≤ dt_max,
    the history pass after each step (as :func:`lagrangian_advance`; fused into the force
    evaluation at the step's new positions, whose forces use the histories before it).
    counters: [steps, status, where]; status 4: two neighbouring points met (crossed).
    ValueError unless hist has the shape (L, points) and L ≤ points (the mirror bonds' indices)."""
    M = x.shape[0]
    if hist.shape[0] != weights.shape[0] or hist.shape[1] != M or weights.shape[0] > M:
        raise ValueError("nonlocal_lagrangian_advance: hist must be (len(weights), len(x)) with len(weights) <= len(x)")
    acc = np.empty(M)
    inv_mu = 1.0 / mu
    nonlocal_lagrangian_accelerations(x, hist, acc, weights, ppd, d, k1, k2, inv_mu)
    while t < t_stop:
        dt, last = clamped_step(t, t_stop, dt_max)
        a0 = -gravity - fn(t, params)[2]
        for i in range(M):
            v[i] += 0.5 * dt * (acc[i] + a0)
            x[i] += dt * v[i]
        t1 = t_stop if last else t + dt
        shortest = nonlocal_lagrangian_accelerations(x, hist, acc, weights, ppd, d, k1, k2, inv_mu, True)
        a1 = -gravity - fn(t1, params)[2]
        for i in range(M):
            v[i] += 0.5 * dt * (acc[i] + a1)
        t = t1
        counters[0] += 1
        if not shortest > 0.0:
            counters[1] = 4
            return t
    return t
