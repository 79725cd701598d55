"""Tracers moved by a grid's interpolated velocity (issue #19): the compiled pieces that the n-D
packing continuum (:mod:`bsrflow.numerics.packing_nd`) and the vibrated bed's Eulerian grid
(:mod:`bsrflow.numerics.bed_eulerian`) share.

A tracer at x [m] (floor frame) moves with dx/dt = u(x, t), the velocity interpolated from the
cell centres as the mass-weighted mean u = Σ w ρu / Σ w ρ (trilinear weights w, bilinear in 2-D),
integrated by the fields' own SSP-RK3 stages: the velocity at the stage positions x0,
x0 + Δt v0, x0 + Δt (v0 + v1)/4 on the stage states q, q1, q2, then x0 + Δt (v0 + v1 + 4 v2)/6.
The state arrays are (fields, NX, NY, NZ) with ρ, ρu_x, ρu_y, ρu_z as fields 0-3 (both solvers'
layout); the cells may have a different size per axis (``dx``, 3 values [m]).  NumPy twin of the
interpolation: :func:`bsrflow.numerics.packing_reference.tracer_velocity_numpy`.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["tracer_velocity", "tracer_stage", "tracer_combine"]

RHO, MX, MY, MZ = 0, 1, 2, 3


@numba.njit(cache=True)
def tracer_velocity(q, px, py, pz, lo, dx, rho_tiny, out):
    """Velocity [m/s] at the point (px, py, pz) [m] (floor frame; py ignored in 2-D, NY = 1) into
    ``out`` (3), cells of size dx (3) [m] per axis: the trilinear (bilinear in 2-D) interpolation
    of the momentum divided by that of the density over the surrounding cell centres,
    u = Σ w ρu / Σ w ρ, so that empty cells do not pull a tracer at the bed's edge towards rest;
    0 where Σ w ρ ≤ ``rho_tiny``.  Periodic sides; below the lowest and above the highest cell
    centres the floor's and the lid's mirror cells (ρ even, u_z odd), so u_z is 0 at the floor.  NumPy twin:
    :func:`bsrflow.numerics.packing_reference.tracer_velocity_numpy`."""
    _, NX, NY, NZ = q.shape
    sx = (px - lo[0]) / dx[0] - 0.5
    i0 = int(math.floor(sx))
    fx = sx - i0
    j0, fy, nb = 0, 0.0, 1
    if NY > 1:
        sy = (py - lo[1]) / dx[1] - 0.5
        j0 = int(math.floor(sy))
        fy = sy - j0
        nb = 2
    sz = (pz - lo[2]) / dx[2] - 0.5
    k0 = int(math.floor(sz))
    fz = sz - k0
    wr = 0.0
    wx = 0.0
    wy = 0.0
    wz = 0.0
    for a in range(2):
        wa = fx if a == 1 else 1.0 - fx
        i = ((i0 + a) % NX + NX) % NX
        for b in range(nb):
            wb = 1.0 if nb == 1 else (fy if b == 1 else 1.0 - fy)
            j = ((j0 + b) % NY + NY) % NY
            for c in range(2):
                wc = fz if c == 1 else 1.0 - fz
                k = k0 + c
                sgn = 1.0
                if k < 0:
                    k = -1 - k
                    sgn = -1.0
                elif k >= NZ:
                    k = 2 * NZ - 1 - k
                    sgn = -1.0
                k = min(max(k, 0), NZ - 1)
                w = wa * wb * wc
                wr += w * q[RHO, i, j, k]
                wx += w * q[MX, i, j, k]
                wy += w * q[MY, i, j, k]
                wz += w * sgn * q[MZ, i, j, k]
    if wr > rho_tiny:
        out[0], out[1], out[2] = wx / wr, wy / wr, wz / wr
    else:
        out[0], out[1], out[2] = 0.0, 0.0, 0.0


@numba.njit(cache=True)
def tracer_stage(q, tr, vt, st, dt, lo, top, dx, rho_tiny):
    """Stage ``st`` (0, 1, 2) of the tracers' SSP-RK3 (the fields' tableau): the velocity vt[st]
    at the stage position x0, x0 + Δt v0, x0 + Δt (v0 + v1)/4 on the stage state q (cells of size
    dx (3) [m]; the height kept in [floor, top])."""
    buf = np.zeros(3)
    p = np.empty(3)
    for n in range(tr.shape[0]):
        for cc in range(3):
            p[cc] = tr[n, cc]
            if st == 1:
                p[cc] += dt * vt[0, n, cc]
            elif st == 2:
                p[cc] += 0.25 * dt * (vt[0, n, cc] + vt[1, n, cc])
        p[2] = min(max(p[2], lo[2]), top)
        tracer_velocity(q, p[0], p[1], p[2], lo, dx, rho_tiny, buf)
        for cc in range(3):
            vt[st, n, cc] = buf[cc]


@numba.njit(cache=True)
def tracer_combine(tr, vt, dt, lo, box, top, has_y):
    """x += Δt (v0 + v1 + 4 v2)/6; periodic sides wrapped, the height kept in [floor, lid]."""
    for n in range(tr.shape[0]):
        for cc in range(3):
            tr[n, cc] += dt * ((vt[0, n, cc] + vt[1, n, cc]) / 6.0 + (2.0 / 3.0) * vt[2, n, cc])
        for cc in range(2):
            if cc == 1 and not has_y:
                continue
            rel = tr[n, cc] - lo[cc]
            tr[n, cc] = lo[cc] + (rel - box[cc] * math.floor(rel / box[cc]))
        tr[n, 2] = min(max(tr[n, 2], lo[2]), top)
