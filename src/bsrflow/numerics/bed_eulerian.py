"""The vibrated bed's granular hydrodynamics on an Eulerian grid in 1, 2 or 3 dimensions (issue #19).

The model is :mod:`bsrflow.physics.granular_bed`'s (the packing stress of the contact law plus
the kinetic theory of a granular temperature θ), written for an n-D flow; the 1-D Lagrangian
cells of :mod:`bsrflow.numerics.bed_lagrangian` are its horizontally uniform limit.  Fields per
cell (conserved, floor frame): ρ = ρ_sφ [kg/m³], ρu_x, ρu_y, ρu_z [kg/(m² s)],
E = (3/2)ρθ [J/m³], ρδ_max [kg/m²]:

    ρ_t + ∇·(ρu) = 0
    (ρu)_t + ∇·(ρuu + (P_c + p) I − τ) = ρ(−g − ϑ''(t)) e_z
    E_t + ∇·(uE − κ∇θ) = −p ∇·u + τ:∇u − γ
    (ρδ_max)_t + ∇·(ρu δ_max) = 0,  then δ_max ← max(δ_max, δ) while in contact, 0 once separated

with P_c the packing stress (the Walton–Braun law per layer, k1 = 3Zφ_cK/(5πd²) [Pa/m],
unloading k1/e², of δ = d(1 − ρ_c/ρ), as :class:`bsrflow.numerics.packing_nd.PackingLawND` for
spheres), p, μ, λ, κ and γ the kinetic theory's (granular_bed), and the viscous stress
τ = μ(∇u + ∇uᵀ) + (λ − 2μ/3)(∇·u) I.

Scheme (one axis at a time, summed, unsplit; SSP-RK3):

* hyperbolic part: the n-D packing scheme's (minmod reconstruction of ρ, u, θ, δ_max, first order
  at compaction faces, the packing's HLLE wave bounds, no tension), the bounds widened by the
  kinetic sound speed c_k² = θ(Y + φY') + (2/3)θY² (p = ρθY(φ), E = (3/2)ρθ), the pressure P_c + p;
  the HLLE flux across the horizontal axes, the HLLC flux (:func:`_hllc_z`: the contact wave
  restored) along z.  (Until 2026-12-05, fourth session, HLLE along z too: its diffusion at the
  contact smeared the flying bed's bottom edge over two or three cells, a dilute tail that reached
  the floor early, and the column flew 21.1-23.0 ms at 2-16 cells per d against the Lagrangian
  cells' 25.3 ms at Γ = 3; docs/model.md.  HLLE stays across the horizontal axes, whose faces
  run along the landing's planar compaction front, where HLLC's exact contact is known to let
  odd-even perturbations grow);
* viscous stress and conduction at the faces: the face-normal derivatives by differences, the
  tangential ones the mean of the two cells' centred differences; face coefficients the mean of
  the two cells', none where either cell is below φ_min = 10⁻³ (mean free path above 40 d: no
  continuum there; the explicit diffusion limits would otherwise fall as φ) or has θ = 0 (its
  coefficients are 0);
* the work −p∇·u with ∇·u from the face velocities (the mean of the two face states', the
  material's own at a vacuum face, 0 at floor and lid), the viscous heating τ:∇u as the mean of
  the row of the face-normal derivatives over each axis's two faces (so that a horizontally
  uniform flow gets exactly the 1-D terms);
* after each step: the collisional loss integrated exactly (θ̇ = −Aθ^{3/2},
  A = 8(1 − e_d²)g0φ/(d√π)), θ ≥ 0, the momentum, energy and history of cells with
  ρ ≤ 10⁻¹² ρ_c cleared (their mass kept: mass is conserved to round-off), the history pass.

Boundaries: periodic sides; the floor (mirror ghosts: u_z odd; no mass, energy or history
crosses it), which pushes but cannot pull: its face's normal momentum flux, the Riemann flux minus
the viscous normal stress, is ≥ 0, and that stress may lower the Riemann flux (a packed bed
starting to leave, as the Lagrangian cells' bottom stress does) but not raise it: as a bed's
edge comes down, the mirror's gradient 2u_z/Δz across the floor's half cell is the closing of a
gap, not a velocity gradient, and the Riemann flux carries the impact.  (With that push, and HLLE
along z, the dilute edge cushioned the landing: at Γ = 3 and 4 cells per d the floor's force rose
through 0.1 M g at phase 0.645 of the cycle, the Lagrangian cells' at 0.711, and without the push,
with HLLC, at 0.696; docs/model.md.)  That flux times the area is the floor force.  No heat flux
through the floor but the collisions' loss (1 − e_w)p√(2θ/π) out of the bottom cells
(:func:`bsrflow.physics.granular_bed.wall_loss`), no shear stress (free slip).  A lid at the
domain top (mirror ghosts, no stress, no heat flux and nothing but the normal momentum through
it).  Time step (:func:`bed_stable_dt`, over the axes along which the state varies): the
unsplit CFL bound cfl / max Σ_a (c + c_k + |u_a|)/Δx_a, c_k and |u_a| at the largest φ, θ and
|u_a| of the cell and its neighbours (so that it bounds every face's waves), and half the
explicit limits of the conduction and the viscous stress with the face coefficients the operator
uses.

A horizontally uniform state evolves exactly as the column (dim 1): every horizontal face of a
uniform line computes the same numbers, so their differences are exact zeros, and the vertical
terms are the column's (tested bit for bit).  :mod:`bsrflow.numerics.bed_eulerian_reference` is
the plain NumPy twin (tested).  Units: SI.

Threads: on a grid of at least :attr:`EulerianBed.PARALLEL_MIN_CELLS` cells (and with more than
one numba thread) the right-hand side's cell, column and line passes run over their planes and
lines in parallel (:func:`bed_rhs`); every cell's numbers are computed by one thread in the
serial order, so the results are the serial ones bit for bit (tested).  The time-step bound, the
stages' sums and the post-step pass stay serial.  The parallel passes keep their scratch in the
work arrays: arrays allocated inside them were not freed (numba), nor was the memory of every
parallel launch under numba's tbb layer, which the package therefore ranks last
(:mod:`bsrflow._numba_threads`).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numba import prange

from ..physics.granular_bed import bulk_viscosity, conductivity, g0_cs, kinetic_pressure, shear_viscosity
from ..physics.packing import history_update
from . import packing_kernels as pk
from .grid import spread_over_bins
from .tracers import tracer_combine, tracer_stage

__all__ = ["EulerianBed", "run_eulerian_bed", "bed_rhs", "bed_post_step", "bed_stable_dt", "bed_advance",
           "kinetic_sound_speed", "scheme_params", "work_arrays", "N_FIELDS"]

RHO, MX, MY, MZ, ENER, HIST = 0, 1, 2, 3, 4, 5
N_FIELDS = 6
PHI_MIN = 1e-3
"""Below this solid fraction no viscous stress and no conduction (mean free path d/(6√2φg0) > 40 d)."""
SQRT_PI = math.sqrt(math.pi)
SCRATCH = 62
"""Floats of one scratch row of :func:`bed_rhs` (a face's outputs, the previous face's, _face's 46)."""


@numba.njit(cache=True, inline="always")
def kinetic_sound_speed(phi, theta, e):
    """c_k [m/s]: the sound speed of the kinetic pressure p = ρθY(φ) at constant entropy of the
    fluctuations, c_k² = θ(Y + φY') + (2/3)θY², Y = 1 + 2(1 + e)φg0 (Carnahan–Starling,
    g0' = (2.5 − φ)/(1 − φ)⁴, 0 above its cap at φ = 0.95)."""
    p = min(phi, 0.95)
    g = g0_cs(phi)
    dg = (2.5 - p) / (1.0 - p) ** 4 if phi < 0.95 else 0.0
    y = 1.0 + 2.0 * (1.0 + e) * phi * g
    dy = 2.0 * (1.0 + e) * (g + phi * dg)
    t = max(theta, 0.0)
    return math.sqrt(t * (y + phi * dy) + (2.0 / 3.0) * t * y * y)


@numba.njit(cache=True)
def _cell_pass_plane(q, w, co, i, rho_tiny, rho_s, d, e, phi_min):
    """Primitives w (6: ρ, u_x, u_y, u_z, θ, δ_max; zero where ρ ≤ rho_tiny, θ ≥ 0) and the cell
    coefficients co (4: μ, λ, κ, p of :mod:`bsrflow.physics.granular_bed`; μ, λ, κ zero below
    φ_min) of the cells of plane x = i."""
    _, NX, NY, NZ = q.shape
    for j in range(NY):
        for k in range(NZ):
            r = q[RHO, i, j, k]
            if r > rho_tiny:
                w[0, i, j, k] = r
                w[1, i, j, k] = q[MX, i, j, k] / r
                w[2, i, j, k] = q[MY, i, j, k] / r
                w[3, i, j, k] = q[MZ, i, j, k] / r
                th = max(q[ENER, i, j, k] / (1.5 * r), 0.0)
                w[4, i, j, k] = th
                w[5, i, j, k] = q[HIST, i, j, k] / r
            else:
                th = 0.0
                for c in range(6):
                    w[c, i, j, k] = 0.0
                r = 0.0
            phi = r / rho_s
            co[3, i, j, k] = kinetic_pressure(phi, th, rho_s, e)
            if phi >= phi_min:
                co[0, i, j, k] = shear_viscosity(phi, th, rho_s, d, e)
                co[1, i, j, k] = bulk_viscosity(phi, th, rho_s, d, e)
                co[2, i, j, k] = conductivity(phi, th, rho_s, d, e)
            else:
                co[0, i, j, k] = 0.0
                co[1, i, j, k] = 0.0
                co[2, i, j, k] = 0.0


@numba.njit(cache=True)
def _cell_pass(q, w, co, rho_tiny, rho_s, d, e, phi_min):
    """:func:`_cell_pass_plane` over every plane, in order."""
    for i in range(q.shape[1]):
        _cell_pass_plane(q, w, co, i, rho_tiny, rho_s, d, e, phi_min)


@numba.njit(cache=True, parallel=True)
def _cell_pass_parallel(q, w, co, rho_tiny, rho_s, d, e, phi_min):
    """:func:`_cell_pass_plane` over every plane, the planes in parallel."""
    for i in prange(q.shape[1]):
        _cell_pass_plane(q, w, co, i, rho_tiny, rho_s, d, e, phi_min)


@numba.njit(cache=True, inline="always")
def _at(a, c, i, j, k, NX, NY, NZ, sign_z):
    """a[c] at cell (i, j, k), periodic in i and j, mirrored in k below 0 and above NZ − 1 (times
    ``sign_z`` there).  (Indices as int64: a prange index may be unsigned, and unsigned with signed
    arithmetic gives floats.)"""
    i = np.int64(i) % NX
    j = np.int64(j) % NY
    k = np.int64(k)
    if k < 0:
        return sign_z * a[c, i, j, -1 - k]
    if k >= NZ:
        return sign_z * a[c, i, j, 2 * NZ - 1 - k]
    return a[c, i, j, k]


@numba.njit(cache=True)
def _gradients_plane(w, G, dx, dim, i):
    """Centred cell gradients G[3a + b] = ∂_a u_b (a, b: x, y, z) [1/s] of the cells of plane
    x = i (cell sizes dx (3) [m]); zero along the axes the grid does not have."""
    _, NX, NY, NZ = w.shape
    inv_x, inv_y, inv_z = 0.5 / dx[0], 0.5 / dx[1], 0.5 / dx[2]
    for j in range(NY):
        for k in range(NZ):
            for b in range(3):
                sz = -1.0 if b == 2 else 1.0
                G[6 + b, i, j, k] = (_at(w, 1 + b, i, j, k + 1, NX, NY, NZ, sz)
                                     - _at(w, 1 + b, i, j, k - 1, NX, NY, NZ, sz)) * inv_z
                if dim >= 2:
                    G[b, i, j, k] = (_at(w, 1 + b, i + 1, j, k, NX, NY, NZ, sz)
                                     - _at(w, 1 + b, i - 1, j, k, NX, NY, NZ, sz)) * inv_x
                else:
                    G[b, i, j, k] = 0.0
                if dim == 3:
                    G[3 + b, i, j, k] = (_at(w, 1 + b, i, j + 1, k, NX, NY, NZ, sz)
                                         - _at(w, 1 + b, i, j - 1, k, NX, NY, NZ, sz)) * inv_y
                else:
                    G[3 + b, i, j, k] = 0.0


@numba.njit(cache=True, inline="always")
def _cell_index(axis, i, j, k, s):
    """The cell s steps along ``axis`` from (i, j, k) (as int64)."""
    i, j, k = np.int64(i), np.int64(j), np.int64(k)
    if axis == 0:
        return i + s, j, k
    if axis == 1:
        return i, j + s, k
    return i, j, k + s


@numba.njit(cache=True, inline="always")
def _hllc_z(SL, SR, rL, uL, PL, rR, uR, PR, uLa, uRa, thL, thR, hL, hR, out):
    """HLLC fluxes at a vertical face (Toro, Spruce and Speares 1994; Batten et al. 1997) with the
    HLLE bounds S_L, S_R: the contact speed S* = (P_R − P_L + ρ_L u_L(S_L − u_L) − ρ_R u_R(S_R −
    u_R)) / (ρ_L(S_L − u_L) − ρ_R(S_R − u_R)) (0 between two vacua; held in [S_L, S_R]) and on the
    side K of the face that S* leaves, F_K + S_K(U*_K − U_K) with ρ*_K = ρ_K(S_K − u_K)/(S_K − S*),
    (ρu)* = ρ* S*; the horizontal velocities, θ and δ_max ride with the mass flux (their values per
    mass of side K).  Returns (mass flux, normal momentum flux); writes the horizontal momenta's,
    the energy's and the history's fluxes into out[1], out[2], out[4], out[5]."""
    den = rL * (SL - uL) - rR * (SR - uR)
    ss = (PR - PL + rL * uL * (SL - uL) - rR * uR * (SR - uR)) / den if den != 0.0 else 0.0
    ss = min(max(ss, SL), SR)
    if SL >= 0.0 or ss >= 0.0:
        return _hllc_side(min(SL, 0.0), SL, rL, uL, PL, ss, uLa, thL, hL, out)
    return _hllc_side(max(SR, 0.0), SR, rR, uR, PR, ss, uRa, thR, hR, out)


@numba.njit(cache=True, inline="always")
def _hllc_side(a, S, r, u, P, ss, ua, th, h, out):
    """:func:`_hllc_z`'s flux from side K (wave speed S = S_K, a = S_K if the star state of side K
    is in the face, else 0): F_K + a(U*_K − U_K); (mass flux, normal momentum flux), the passive
    fields' fluxes into ``out``."""
    chi = r * (S - u) / (S - ss) if a != 0.0 else r
    f_mass = r * u + a * (chi - r)
    f_mom = r * u * u + P + a * (chi * ss - r * u)
    out[1] = f_mass * ua[0]
    out[2] = f_mass * ua[1]
    out[4] = f_mass * 1.5 * th
    out[5] = f_mass * h
    return f_mass, f_mom


@numba.njit(cache=True)
def _face(w, co, G, axis, i, j, k, NX, NY, NZ, dx, par, out, sc):
    """Fluxes at the face between cell (i, j, k) and the next cell along ``axis`` (indices may be
    ghosts: periodic sides, mirrored in z).  out (8): the six conserved fields' fluxes (HLLE
    across x and y, HLLC along z, minus the viscous stress, plus the conduction), the face
    velocity, the heating row.
    sc: scratch (46), part of the caller's scratch row for its plane or line (allocating per face
    cost most of the step)."""
    d, m, k1, k2, c_cap, rho_tiny, e, rho_s = par[0], par[1], par[2], par[3], par[4], par[5], par[6], par[7]
    # the four cells along the axis: l-1, l, r, r+1
    rr4 = sc[0:4]
    un4 = sc[4:8]
    th4 = sc[8:12]
    h4 = sc[12:16]
    ua4 = sc[16:28].reshape((3, 4))
    for s in range(4):
        ii, jj, kk = _cell_index(axis, i, j, k, s - 1)
        rr4[s] = _at(w, 0, ii, jj, kk, NX, NY, NZ, 1.0)
        th4[s] = _at(w, 4, ii, jj, kk, NX, NY, NZ, 1.0)
        h4[s] = _at(w, 5, ii, jj, kk, NX, NY, NZ, 1.0)
        for b in range(3):
            ua4[b, s] = _at(w, 1 + b, ii, jj, kk, NX, NY, NZ, -1.0 if b == 2 else 1.0)
        un4[s] = ua4[axis, s]
    hs = 0.0 if pk.compaction_face(rr4[1], un4[1], rr4[2], un4[2], d, m) else 0.5
    rL = rr4[1] + hs * pk._minmod(rr4[1] - rr4[0], rr4[2] - rr4[1])
    rR = rr4[2] - hs * pk._minmod(rr4[2] - rr4[1], rr4[3] - rr4[2])
    vacL = rL <= rho_tiny
    vacR = rR <= rho_tiny
    if vacL:
        rL = 0.0
    if vacR:
        rR = 0.0
    uLa = sc[28:31]
    uRa = sc[31:34]
    for b in range(3):
        a0, a1, a2, a3 = ua4[b, 0], ua4[b, 1], ua4[b, 2], ua4[b, 3]
        uLa[b] = 0.0 if vacL else a1 + hs * pk._minmod(a1 - a0, a2 - a1)
        uRa[b] = 0.0 if vacR else a2 - hs * pk._minmod(a2 - a1, a3 - a2)
    thL = 0.0 if vacL else th4[1] + hs * pk._minmod(th4[1] - th4[0], th4[2] - th4[1])
    thR = 0.0 if vacR else th4[2] - hs * pk._minmod(th4[2] - th4[1], th4[3] - th4[2])
    hL = 0.0 if vacL else h4[1] + hs * pk._minmod(h4[1] - h4[0], h4[2] - h4[1])
    hR = 0.0 if vacR else h4[2] - hs * pk._minmod(h4[2] - h4[1], h4[3] - h4[2])
    # the packing's HLLE bounds (the n-D packing scheme's), widened below by the kinetic sound speed
    SLp, SRp, uL, uR, pL, pR = pk.hlle_waves(rL, uLa[axis], hL, rR, uRa[axis], hR, d, m, k1, k2, c_cap, rho_tiny)
    phL, phR = rL / rho_s, rR / rho_s
    kL = rL * thL * (1.0 + 2.0 * (1.0 + e) * phL * g0_cs(phL))
    kR = rR * thR * (1.0 + 2.0 * (1.0 + e) * phR * g0_cs(phR))
    ckL = kinetic_sound_speed(phL, thL, e)
    ckR = kinetic_sound_speed(phR, thR, e)
    ck = max(ckL, ckR)
    SL = min(SLp - ck, uL - ckL)
    SR = max(SRp + ck, uR + ckR)
    PL, PR = pL + kL, pR + kR
    il, jl, kl = _cell_index(axis, i, j, k, 0)
    lid = axis == 2 and kl == NZ - 1
    floor = axis == 2 and kl == -1
    if axis == 2:
        # vertical faces: HLLC (the contact restored, so that the bed's edges stay sharp)
        f_mass, f_mom = _hllc_z(SL, SR, rL, uL, PL, rR, uR, PR, uLa, uRa, thL, thR, hL, hR, out)
    else:
        # horizontal faces: HLLE (its dissipation along the landing's planar front: no odd-even decoupling)
        f_mass = pk.hlle_combine(SL, SR, rL * uL, rR * uR, rL, rR)
        f_mom = pk.hlle_combine(SL, SR, rL * uL * uL + PL, rR * uR * uR + PR, rL * uL, rR * uR)
        for b in range(3):
            if b != axis:
                out[1 + b] = pk.hlle_combine(SL, SR, rL * uL * uLa[b], rR * uR * uRa[b], rL * uLa[b], rR * uRa[b])
        out[4] = pk.hlle_combine(SL, SR, 1.5 * rL * thL * uL, 1.5 * rR * thR * uR, 1.5 * rL * thL, 1.5 * rR * thR)
        out[5] = pk.hlle_combine(SL, SR, rL * uL * hL, rR * uR * hR, rL * hL, rR * hR)
    if floor or lid:                              # walls: only the normal momentum crosses them
        f_mass = 0.0
        out[1] = out[2] = out[4] = out[5] = 0.0
    f_mom = pk.no_tension(f_mass, f_mom, uL, uR)
    out[0] = f_mass
    out[1 + axis] = f_mom
    if vacL and vacR:
        out[6] = 0.0
    elif vacL:
        out[6] = uR
    elif vacR:
        out[6] = uL
    else:
        out[6] = 0.5 * (uL + uR)
    # viscous stress and conduction
    ir, jr, kr = _cell_index(axis, i, j, k, 1)
    mul = _at(co, 0, il, jl, kl, NX, NY, NZ, 1.0)
    mur = _at(co, 0, ir, jr, kr, NX, NY, NZ, 1.0)
    out[7] = 0.0
    if mul > 0.0 and mur > 0.0 and not lid:
        muf = 0.5 * (mul + mur)
        lamf = 0.5 * (_at(co, 1, il, jl, kl, NX, NY, NZ, 1.0) + _at(co, 1, ir, jr, kr, NX, NY, NZ, 1.0))
        kapf = 0.5 * (_at(co, 2, il, jl, kl, NX, NY, NZ, 1.0) + _at(co, 2, ir, jr, kr, NX, NY, NZ, 1.0))
        Gf = sc[34:43].reshape((3, 3))
        for b in range(3):
            Gf[axis, b] = (ua4[b, 2] - ua4[b, 1]) / dx[axis]
            for c in range(3):
                if c != axis:
                    sz = -1.0 if b == 2 else 1.0         # ∂_c u_b mirrored in z (c horizontal here when axis is z)
                    Gf[c, b] = 0.5 * (_at(G, 3 * c + b, il, jl, kl, NX, NY, NZ, sz)
                                      + _at(G, 3 * c + b, ir, jr, kr, NX, NY, NZ, sz))
        tr = Gf[0, 0] + Gf[1, 1] + Gf[2, 2]
        tau = sc[43:46]
        for b in range(3):
            tau[b] = muf * (Gf[axis, b] + Gf[b, axis])
            if b == axis:
                tau[b] += (lamf - (2.0 / 3.0) * muf) * tr
        if floor and tau[2] < 0.0:
            tau[2] = 0.0                          # no viscous push from the floor (the Riemann flux's impact)
        if floor and f_mom - tau[2] < 0.0:
            tau[2] = f_mom                        # the floor cannot pull
        for b in range(3):
            out[1 + b] -= tau[b]
        out[7] = tau[0] * Gf[axis, 0] + tau[1] * Gf[axis, 1] + tau[2] * Gf[axis, 2]
        if not floor:
            out[4] += -kapf * (th4[2] - th4[1]) / dx[axis]


@numba.njit(cache=True, inline="always")
def _rhs_columns_plane(dq, w, co, G, div, heat, floor, scratch, dim, dx, par, i):
    """The gradients of plane x = i (:func:`_gradients_plane`), then its vertical lines' faces:
    dq, div and heat of its cells set to the vertical terms, ``floor`` its floor stresses.  (A
    vertical face needs the gradients of its own column only.)  ``scratch[i]``: the plane's
    scratch row (no allocation inside the parallel loops: numba leaked arrays allocated there,
    about 80 kB per step of a 4 × 4 × 49 grid, and the steps slowed down as the heap grew)."""
    _, NX, NY, NZ = w.shape
    i = np.int64(i)                       # (a prange index may be unsigned: keep the arithmetic integer)
    _gradients_plane(w, G, dx, dim, i)
    inv = 1.0 / dx[2]
    out = scratch[i, 0:8]
    prev = scratch[i, 8:16]
    sc = scratch[i, 16:SCRATCH]
    for j in range(NY):
        # vertical line: faces k − ½ for k = 0 … NZ (face k between cells k − 1 and k)
        for k in range(NZ + 1):
            _face(w, co, G, 2, i, j, k - 1, NX, NY, NZ, dx, par, out, sc)
            if k == 0:
                floor[i, j] = out[3]
            else:
                kc = k - 1
                for c in range(N_FIELDS):
                    dq[c, i, j, kc] = -(out[c] - prev[c]) * inv
                div[i, j, kc] = (out[6] - prev[6]) * inv
                heat[i, j, kc] = 0.5 * (out[7] + prev[7])
            for c in range(8):
                prev[c] = out[c]


@numba.njit(cache=True, inline="always")
def _rhs_line(dq, w, co, G, div, heat, scratch, dx, par, axis, p):
    """Line p of the horizontal ``axis`` (0: x, 1: y; the lines numbered (other horizontal index)
    × NZ + k): its faces' terms added to dq, div and heat of its cells (``scratch[p]``: the
    line's scratch row)."""
    _, NX, NY, NZ = w.shape
    p = np.int64(p)                       # (a prange index may be unsigned: keep the arithmetic integer)
    nA = NX if axis == 0 else NY
    inv_h = 1.0 / dx[axis]
    out = scratch[p, 0:8]
    prev = scratch[p, 8:16]
    sc = scratch[p, 16:SCRATCH]
    jb = p // NZ
    kk = p - jb * NZ
    for ia in range(nA + 1):
        if axis == 0:
            fi, fj = ia - 1, jb
        else:
            fi, fj = jb, ia - 1
        _face(w, co, G, axis, fi, fj, kk, NX, NY, NZ, dx, par, out, sc)
        if ia > 0:
            ic, jc = fi, fj
            for c in range(N_FIELDS):
                dq[c, ic, jc, kk] += -(out[c] - prev[c]) * inv_h
            div[ic, jc, kk] += (out[6] - prev[6]) * inv_h
            heat[ic, jc, kk] += 0.5 * (out[7] + prev[7])
        for c in range(8):
            prev[c] = out[c]


@numba.njit(cache=True)
def _rhs_sources_plane(dq, w, co, div, heat, dim, accel, e_w, inv_z, i):
    """The sources of plane x = i: gravity and the floor's acceleration, −p∇·u + τ:∇u, the
    floor's collisional loss out of the bottom cells; the momenta along absent axes zeroed."""
    _, NX, NY, NZ = w.shape
    for j in range(NY):
        for k in range(NZ):
            if dim < 3:
                dq[MY, i, j, k] = 0.0
            if dim < 2:
                dq[MX, i, j, k] = 0.0
            dq[MZ, i, j, k] += w[0, i, j, k] * accel
            dq[ENER, i, j, k] += -co[3, i, j, k] * div[i, j, k] + heat[i, j, k]
        th0 = w[4, i, j, 0]
        dq[ENER, i, j, 0] -= (1.0 - e_w) * co[3, i, j, 0] * math.sqrt(2.0 * th0 / math.pi) * inv_z


@numba.njit(cache=True, parallel=True)
def _columns_parallel(dq, w, co, G, div, heat, floor, scratch, dim, dx, par):
    """:func:`_rhs_columns_plane` of every plane, in parallel."""
    for i in prange(w.shape[1]):
        _rhs_columns_plane(dq, w, co, G, div, heat, floor, scratch, dim, dx, par, i)


@numba.njit(cache=True, parallel=True)
def _lines_parallel(dq, w, co, G, div, heat, scratch, dx, par, axis):
    """:func:`_rhs_line` of every line of the horizontal ``axis``, in parallel."""
    _, NX, NY, NZ = w.shape
    n_lines = NZ * (NY if axis == 0 else NX)
    for p in prange(n_lines):
        _rhs_line(dq, w, co, G, div, heat, scratch, dx, par, axis, p)


@numba.njit(cache=True)
def bed_rhs(q, dq, w, co, G, div, heat, floor, scratch, dim, dx, accel, par, parallel):
    """dq = L(q) (module docstring; work arrays w (6, …), co (4, …), G (9, …), div, heat (…)),
    floor (NX, NY): the floor's stress [Pa] per column, scratch: :func:`work_arrays`' rows.  par:
    d, m, k1, k2, c_cap, rho_tiny, e, rho_s, phi_min, e_w.  The passes, in order: the cells
    (primitives and coefficients), the columns (gradients, vertical faces), the horizontal lines,
    the sources.  ``parallel``: the first three over their planes (lines) on numba's threads (a
    pass writes only its own plane's or line's cells and reads what the passes before it wrote);
    every cell's numbers are computed by one thread in the serial order, so the result is the
    serial one bit for bit (tested)."""
    _, NX, NY, NZ = q.shape
    if parallel:
        _cell_pass_parallel(q, w, co, par[5], par[7], par[0], par[6], par[8])
        _columns_parallel(dq, w, co, G, div, heat, floor, scratch, dim, dx, par)
        for axis in range(dim - 1):
            _lines_parallel(dq, w, co, G, div, heat, scratch, dx, par, axis)
    else:
        _cell_pass(q, w, co, par[5], par[7], par[0], par[6], par[8])
        for i in range(NX):
            _rhs_columns_plane(dq, w, co, G, div, heat, floor, scratch, dim, dx, par, i)
        for axis in range(dim - 1):
            for p in range(NZ * (NY if axis == 0 else NX)):
                _rhs_line(dq, w, co, G, div, heat, scratch, dx, par, axis, p)
    for i in range(NX):
        _rhs_sources_plane(dq, w, co, div, heat, dim, accel, par[9], 1.0 / dx[2], i)


@numba.njit(cache=True)
def bed_post_step(q, dt, d, m, rho_s, e_d, rho_tiny):
    """The collisional loss over Δt exactly, θ ≥ 0, the momentum, energy and history of cells with
    ρ ≤ rho_tiny cleared (not their mass), the history pass."""
    _, NX, NY, NZ = q.shape
    for i in range(NX):
        for j in range(NY):
            for k in range(NZ):
                r = q[RHO, i, j, k]
                if not r > rho_tiny:                 # (its mass stays: mass is conserved)
                    for c in range(1, N_FIELDS):
                        q[c, i, j, k] = 0.0
                    continue
                th = max(q[ENER, i, j, k] / (1.5 * r), 0.0)
                phi = r / rho_s
                A = 8.0 * (1.0 - e_d * e_d) * g0_cs(phi) * phi / (d * SQRT_PI)
                th = th / (1.0 + 0.5 * A * dt * math.sqrt(th)) ** 2
                q[ENER, i, j, k] = 1.5 * r * th
                h = q[HIST, i, j, k] / r
                q[HIST, i, j, k] = r * history_update(d - m / r, h)


@numba.njit(cache=True)
def _varies(q, axis):
    """True if any field differs between neighbouring cells along horizontal ``axis`` (0, 1)."""
    _, NX, NY, NZ = q.shape
    for i in range(NX):
        for j in range(NY):
            i0, j0 = (i - 1) % NX, j
            if axis == 1:
                i0, j0 = i, (j - 1) % NY
            for k in range(NZ):
                for c in range(N_FIELDS):
                    if q[c, i, j, k] != q[c, i0, j0, k]:
                        return True
    return False


@numba.njit(cache=True)
def bed_stable_dt(q, dim, dx, cfl, par, w, co):
    """(Δt bound [s], status, where); status 1 at a negative density, 2 at a non-finite value
    (the first such cell, flat index).  w, co: work arrays of :func:`bed_rhs` (overwritten).

    The bound counts the axes along which the state varies (z always; x and y where some
    neighbouring cells differ: along a uniform axis every flux difference is an exact zero, so a
    horizontally uniform bed takes the column's steps):

    * the unsplit scheme's CFL: Δt ≤ cfl / max over the cells of Σ_a (c + c_k + |u_a|)/Δx_a, c the
      contact wave speed bound, c_k the kinetic sound speed and |u_a| at the largest φ, θ and
      |u_a| of the cell and its neighbours along the counted axes (a face's reconstructed states
      lie between its two cells' values, and c_k grows with φ and θ up to g0's cap at φ = 0.95,
      far above close packing: so the bound holds for the waves of every face of a cell with
      mass, which the cell's own values, φ and θ being reconstructed independently, did not
      quite do: up to 1.0002 of it, bench/check_face_wave_speed.py; cells without mass are
      skipped, their faces bounded by their neighbours');
    * half the explicit limits of the conduction and the viscous stress with the face
      coefficients the operator uses (the mean of the two cells', none below φ_min; the floor's
      face viscous, not conducting; the lid's neither): Δt ≤ ½ (3/2)ρ_i / Σ_f κ_f/Δx_f² and
      Δt ≤ ½ ρ_i / Σ_f ζ_f/Δx_f² over each cell's faces f, ζ = λ + 4μ/3."""
    _, NX, NY, NZ = q.shape
    c_cap, rho_tiny, e, rho_s, phi_min, d = par[4], par[5], par[6], par[7], par[8], par[0]
    status, where = 0, -1
    for i in range(NX):
        for j in range(NY):
            for k in range(NZ):
                for c in range(N_FIELDS):
                    if not math.isfinite(q[c, i, j, k]):
                        return 0.0, 2, (i * NY + j) * NZ + k
                if q[RHO, i, j, k] < 0.0 and status == 0:
                    status, where = 1, (i * NY + j) * NZ + k
    if status:
        return 0.0, status, where
    _cell_pass(q, w, co, rho_tiny, rho_s, d, e, phi_min)
    vx = dim >= 2 and _varies(q, 0)
    vy = dim == 3 and _varies(q, 1)
    rate = 0.0                     # max Σ_a (c + c_k + |u_a|)/Δx_a [1/s]
    dt_diff = math.inf
    for i in range(NX):
        for j in range(NY):
            for k in range(NZ):
                r = w[0, i, j, k]
                if not r > 0.0:
                    continue
                # the largest φ, θ and |u_b| of the cell and its neighbours along the counted axes:
                # every face state of the cell lies between its two cells' values, and c_k grows
                # with φ and θ, so this bounds the waves of the cell's faces
                phm = r
                thm = w[4, i, j, k]
                ux, uy, uz = abs(w[1, i, j, k]), abs(w[2, i, j, k]), abs(w[3, i, j, k])
                for a in range(3):
                    if (a == 0 and not vx) or (a == 1 and not vy):
                        continue
                    for side in (-1, 1):
                        ii, jj, kk = _cell_index(a, i, j, k, side)
                        phm = max(phm, _at(w, 0, ii, jj, kk, NX, NY, NZ, 1.0))
                        thm = max(thm, _at(w, 4, ii, jj, kk, NX, NY, NZ, 1.0))
                        ux = max(ux, abs(_at(w, 1, ii, jj, kk, NX, NY, NZ, 1.0)))
                        uy = max(uy, abs(_at(w, 2, ii, jj, kk, NX, NY, NZ, 1.0)))
                        uz = max(uz, abs(_at(w, 3, ii, jj, kk, NX, NY, NZ, 1.0)))
                ck = kinetic_sound_speed(phm / rho_s, thm, e)
                rt = (c_cap + ck + uz) / dx[2]
                if vx:
                    rt += (c_cap + ck + ux) / dx[0]
                if vy:
                    rt += (c_cap + ck + uy) / dx[1]
                rate = max(rate, rt)
                mu0 = co[0, i, j, k]
                if not mu0 > 0.0:
                    continue
                z0 = co[1, i, j, k] + (4.0 / 3.0) * mu0
                k0 = co[2, i, j, k]
                sz = 0.0
                sk = 0.0
                for a in range(3):
                    if (a == 0 and not vx) or (a == 1 and not vy):
                        continue
                    inv2 = 1.0 / (dx[a] * dx[a])
                    for side in (-1, 1):
                        ii, jj, kk = _cell_index(a, i, j, k, side)
                        if a == 2 and kk == NZ:          # the lid: no stress, no heat flux
                            continue
                        mun = _at(co, 0, ii, jj, kk, NX, NY, NZ, 1.0)
                        if not mun > 0.0:
                            continue
                        sz += 0.5 * (z0 + _at(co, 1, ii, jj, kk, NX, NY, NZ, 1.0) + (4.0 / 3.0) * mun) * inv2
                        if not (a == 2 and kk == -1):    # the floor conducts no heat
                            sk += 0.5 * (k0 + _at(co, 2, ii, jj, kk, NX, NY, NZ, 1.0)) * inv2
                if sz > 0.0:
                    dt_diff = min(dt_diff, 0.5 * r / sz)
                if sk > 0.0:
                    dt_diff = min(dt_diff, 0.5 * 1.5 * r / sk)
    dt = cfl / rate if rate > 0.0 else cfl * dx[2] / c_cap
    return min(dt, dt_diff), 0, -1


@numba.njit(cache=True)
def _combine(q, q1, dq, dt, a, b):
    """q1 = a q + b (q1 + Δt dq) (the SSP-RK3 stages; a = 0, b = 1 with q1 = q: q + Δt dq)."""
    qf, q1f, dqf = q.reshape(-1), q1.reshape(-1), dq.reshape(-1)
    for idx in range(qf.size):
        q1f[idx] = a * qf[idx] + b * (q1f[idx] + dt * dqf[idx])


@numba.njit(cache=True)
def _floor_mean(floor):
    """The columns' mean floor stress: the common value itself when every column has it (so a
    horizontally uniform bed gives the column's number bit for bit), else their sum over their
    number."""
    f0 = floor[0, 0]
    same = True
    for i in range(floor.shape[0]):
        for j in range(floor.shape[1]):
            if floor[i, j] != f0:
                same = False
    if same:
        return f0
    s = 0.0
    for i in range(floor.shape[0]):
        for j in range(floor.shape[1]):
            s += floor[i, j]
    return s / floor.size


@numba.njit(cache=True)
def bed_advance(q, t, t_stop, dim, dx, cfl, par, gravity, amp, omega, moving, e_d, work, counters, max_steps,
                parallel, tracers, box):
    """SSP-RK3 steps (Shu–Osher form) from t to exactly t_stop, at most ``max_steps``; returns
    (t, ∫ floor stress dt [Pa s]: the stages' floor stresses, mean over the columns, weighted
    1/6, 1/6, 2/3).  Floor acceleration ϑ'' = −aω² sin ωt while ``moving`` (else 0); counters:
    [steps, status, where] (status 1 negative density, 2 non-finite, as
    :func:`bed_stable_dt`).  work: (q1, q2, dq, w (6), co (4), G (9), div, heat, floor, scratch) from
    :func:`work_arrays`.  ``parallel``: the right-hand side's passes on numba's threads
    (:func:`bed_rhs`; the same numbers bit for bit), the rest of the step serial.  tracers
    (n, 3) [m] (x, y, z, floor frame; n = 0 for none) move with the interpolated velocity by the
    same stages (:mod:`bsrflow.numerics.tracers`: the stage states q, q1 = q + Δt L(q) and
    q2 = (3q + q1 + Δt L(q1))/4 are the positions' stages x0, x0 + Δt v0, x0 + Δt (v0 + v1)/4);
    box (3) the grid's extents [m] (lower corner 0)."""
    q1, q2, dq, w, co, G, div, heat, floor, scratch = work
    d, m, rho_s, rho_tiny = par[0], par[1], par[7], par[5]
    impulse = 0.0
    n = 0
    has_tr = tracers.shape[0] > 0
    vt = np.zeros((3, tracers.shape[0], 3))
    lo = np.zeros(3)
    top = box[2]
    while t < t_stop and n < max_steps:
        dt, status, where = bed_stable_dt(q, dim, dx, cfl, par, w, co)
        if status:
            counters[1], counters[2] = status, where
            return t, impulse
        last = False
        if t + dt >= t_stop:
            dt = t_stop - t
            last = True
        acc0 = -gravity + (amp * omega * omega * math.sin(omega * t) if moving else 0.0)
        acc1 = -gravity + (amp * omega * omega * math.sin(omega * (t + dt)) if moving else 0.0)
        acc2 = -gravity + (amp * omega * omega * math.sin(omega * (t + 0.5 * dt)) if moving else 0.0)
        if has_tr:
            tracer_stage(q, tracers, vt, 0, dt, lo, top, dx, rho_tiny)
        bed_rhs(q, dq, w, co, G, div, heat, floor, scratch, dim, dx, acc0, par, parallel)
        f0 = _floor_mean(floor)
        q1[:] = q
        _combine(q, q1, dq, dt, 0.0, 1.0)
        if has_tr:
            tracer_stage(q1, tracers, vt, 1, dt, lo, top, dx, rho_tiny)
        bed_rhs(q1, dq, w, co, G, div, heat, floor, scratch, dim, dx, acc1, par, parallel)
        f1 = _floor_mean(floor)
        q2[:] = q1
        _combine(q, q2, dq, dt, 0.75, 0.25)
        if has_tr:
            tracer_stage(q2, tracers, vt, 2, dt, lo, top, dx, rho_tiny)
        bed_rhs(q2, dq, w, co, G, div, heat, floor, scratch, dim, dx, acc2, par, parallel)
        f2 = _floor_mean(floor)
        _combine(q, q2, dq, dt, 1.0 / 3.0, 2.0 / 3.0)
        q[:] = q2
        if has_tr:
            tracer_combine(tracers, vt, dt, lo, box, top, dim == 3)
        bed_post_step(q, dt, d, m, rho_s, e_d, rho_tiny)
        impulse += dt * (f0 / 6.0 + f1 / 6.0 + (2.0 / 3.0) * f2)
        t = t_stop if last else t + dt
        counters[0] += 1
        n += 1
    return t, impulse


def work_arrays(shape):
    """The stage and work arrays of :func:`bed_advance` for fields of shape (6, NX, NY, NZ): the
    last, the scratch rows of :func:`bed_rhs` (one per plane or line)."""
    cells = shape[1:]
    nx, ny, nz = cells
    return (np.zeros(shape), np.zeros(shape), np.zeros(shape), np.zeros(shape), np.zeros((4,) + cells),
            np.zeros((9,) + cells), np.zeros(cells), np.zeros(cells), np.zeros(cells[:2]),
            np.zeros((max(nx, ny * nz, nx * nz), SCRATCH)))


def scheme_params(setup):
    """(par array of :func:`bed_rhs`, dict of the same by name) for a
    :class:`~bsrflow.physics.granular_bed.BedSetup`: d, m = ρ_c d, k1 = K_eff/A [Pa/m], k2 = k1/e²,
    the contact wave speed bound c = d√(k2/m), rho_tiny = 10⁻¹² ρ_c, e, ρ_s, φ_min, the floor's e_w."""
    s = setup
    rho_c = s.phi_c * s.density
    k1 = s.layer_stiffness / s.area
    k2 = k1 / s.restitution ** 2
    m = rho_c * s.diameter
    named = {"d": s.diameter, "m": m, "k1": k1, "k2": k2, "c_cap": s.diameter * math.sqrt(k2 / m),
             "rho_tiny": 1e-12 * rho_c, "e": s.restitution, "rho_s": s.density, "phi_min": PHI_MIN,
             "e_w": s.floor_dissipation_restitution, "e_d": s.dissipation_restitution, "rho_c": rho_c}
    order = ("d", "m", "k1", "k2", "c_cap", "rho_tiny", "e", "rho_s", "phi_min", "e_w")
    return np.array([named[k] for k in order]), named


class EulerianBed:
    """The vibrated bed of a :class:`~bsrflow.physics.granular_bed.BedSetup` on an Eulerian grid
    (module docstring): ``dim`` 1 (a column), 2 (x, z) or 3 (x, y, z); ``cells_per_d`` cells per
    diameter vertically; ``lateral_cells`` cells across the box's side L (periodic), so the
    horizontal cells are L/lateral_cells wide; the domain reaches the setup's
    :attr:`~bsrflow.physics.granular_bed.BedSetup.output_top` (by default the energy bound's
    height; the lid at the last whole cell below it, so that the output column holds all the
    mass).  For ``bsrflow run`` (``kind = "granular_bed_eulerian"``) it is the
    controller's discretisation, as :class:`bsrflow.numerics.bed_lagrangian.GranularBedColumn`:
    :meth:`observe` gives the column of d/10 bins of the setup's output grid (the bed's mass per
    metre of height and its mean vertical velocity), :attr:`fields` the conserved state for
    checkpoints, :meth:`output_fields` the state for the file (with units).

    The bed starts at rest as :func:`bsrflow.numerics.bed_lagrangian.static_bed`'s (its
    cumulative mass per area, cell-averaged; δ_max its overlap), θ = θ_seed; ``perturbation`` ε
    makes each column f = 1 + ε cos(2πx/L) (times cos(2πy/L) in 3-D) times as heavy and as tall,
    with x (y) the cells' lower edges: its cumulative mass f M(z/f) and overlap δ(z/f), so the
    solid fractions stay the static bed's and the columns' heights differ (a heap's lateral mode;
    the total mass is kept, Σ_i cos(2πi/n) = 0, and the mode is not 0 on two cells); ε at most
    :data:`~bsrflow.physics.granular_bed.MAX_PERTURBATION`.  (Until 2026-12-05 ε multiplied
    the density itself: a packed cell at φ_c(1 + ε) is compressed by d ε/(1 + ε), and at ε = 0.05
    on 2 cells per d the start released 7× the floor's M(aω)²/2 within 5 ms, a one-off
    measurement: the bed exploded before the floor moved.)
    In 2-D the fields are those of a bed uniform in y (per unit depth: the 3-D values)."""

    def __init__(self, setup, dim=1, cells_per_d=4, lateral_cells=1, perturbation=0.0, cfl=None, tracers=None):
        """(For an :class:`~bsrflow.physics.granular_bed.EulerianBedSetup`, :meth:`from_setup`
        takes the grid from the setup.)  ``tracers``: None or their positions (n, dim) [m]
        (:meth:`set_tracers`)."""
        from ..physics.granular_bed import check_eulerian_floor_loss, check_eulerian_grid, eulerian_vertical_cells
        from ..physics.motion import SinusoidalVibration
        from .bed_lagrangian import static_bed
        check_eulerian_grid(dim, cells_per_d, lateral_cells, perturbation)
        check_eulerian_floor_loss(setup.floor_loss)
        cfl = setup.cfl if cfl is None else cfl
        if not (isinstance(cfl, (int, float)) and 0.0 < cfl <= 0.5):
            raise ValueError(f"cfl = {cfl!r} is outside the valid range (0, 0.5]")
        s = setup
        self.setup, self.dim, self.cfl = s, dim, float(cfl)
        self.cells_per_d, self.lateral_cells, self.perturbation = int(cells_per_d), int(lateral_cells), perturbation
        self.par, self.named = scheme_params(s)
        dz = s.diameter / cells_per_d
        dh = s.side / lateral_cells
        self.dx = np.array([dh, dh, dz])
        nz = eulerian_vertical_cells(s, cells_per_d)             # the lid at or below output_top
        nx = lateral_cells
        ny = lateral_cells if dim == 3 else 1
        self.z = (np.arange(nz) + 0.5) * dz
        zf, delta = static_bed(s)
        n = len(delta)
        mass_faces = np.linspace(0.0, s.mass_per_area, n + 1)               # cumulative mass per area [kg/m²]
        edges = np.arange(nz + 1) * dz
        zmid = 0.5 * (zf[1:] + zf[:-1])
        q = np.zeros((N_FIELDS, nx, ny, nz))
        xc = np.arange(nx) / nx                  # the cells' lower edges, so that two cells carry the mode
        yc = np.arange(ny) / ny
        mode = np.cos(2.0 * math.pi * xc)[:, None] * (np.cos(2.0 * math.pi * yc)[None, :] if dim == 3 else 1.0)
        stretch = 1.0 + perturbation * mode      # each column: the static bed's profile, f times as tall and heavy
        for f in np.unique(stretch):             # (the mode takes a few values)
            rho = np.diff(f * np.interp(edges / f, zf, mass_faces)) / dz
            dmax = np.interp(self.z / f, zmid, delta, right=0.0)
            cols = stretch == f
            q[RHO][cols] = rho
            q[HIST][cols] = rho * np.where(rho > 0.0, dmax, 0.0)
        q[ENER] = 1.5 * q[RHO] * s.theta_seed
        self.q = q
        self.work = work_arrays(q.shape)
        self.counters = np.zeros(3, np.int64)
        self.mass0 = float(q[RHO].sum())
        self.motion = SinusoidalVibration(s.amplitude, s.frequency, start=0.0)
        self.steps = 0
        self.t = 0.0
        self._floor_force = np.zeros(1)          # the last advance's mean floor force [N] (checkpointed)
        self._grid = None
        self._box = np.array([nx * dh, ny * dh, nz * dz])
        self.tracers = np.zeros((0, 3))
        """Tracer positions [m] (floor frame) in the internal layout (n, 3): (x, y, z); y = 0 in
        1-D and 2-D, x the column's centre in 1-D.  :meth:`tracer_positions` gives the user's."""
        if tracers is not None:
            self.set_tracers(tracers)

    @classmethod
    def from_setup(cls, setup, tracers=None):
        """The bed of an :class:`~bsrflow.physics.granular_bed.EulerianBedSetup` (its grid fields),
        with ``tracers`` (:meth:`set_tracers`)."""
        return cls(setup, setup.dimension, setup.cells_per_d, setup.lateral_cells, setup.perturbation,
                   tracers=tracers)

    TRACER_AXES = {1: ("z",), 2: ("x", "z"), 3: ("x", "y", "z")}
    """The user layout of a tracer's position per dimension of the grid."""
    _TRACER_COLUMNS = {1: [2], 2: [0, 2], 3: [0, 1, 2]}
    """The internal (x, y, z) columns of :attr:`TRACER_AXES`."""

    def set_tracers(self, positions):
        """Set the tracers from positions (n, dim) [m] in the user layout (:attr:`TRACER_AXES`: z in
        1-D, (x, z) in 2-D, (x, y, z) in 3-D; floor frame), each inside the grid, [0, L] across the
        periodic sides and [0, lid] in height; ValueError (one line) otherwise.  They move with the
        cells' interpolated velocity (:func:`bed_advance`); the position across a side wraps."""
        axes = self.TRACER_AXES[self.dim]
        try:
            p = np.asarray(positions, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"tracers: need an array of numbers of shape (n, {len(axes)}) [m] "
                             f"({', '.join(axes)} per tracer)") from None
        if p.ndim != 2 or p.shape[1] != len(axes) or p.shape[0] == 0:
            raise ValueError(f"tracers: need positions of shape (n, {len(axes)}) [m] ({', '.join(axes)} per tracer), "
                             f"got {p.shape}")
        if not np.all(np.isfinite(p)):
            raise ValueError("tracers: the positions must be finite numbers [m]")
        box = self._box
        cols = self._TRACER_COLUMNS[self.dim]
        side = float(self.setup.side)           # (L itself: n (L/n) may be one ulp below it; L wraps to 0)
        hi = np.array([box[2] if c == 2 else side for c in cols])
        for k, pt in enumerate(p):
            if np.any(pt < 0.0) or np.any(pt > hi):
                raise ValueError(f"tracers: tracer {k} at {pt.tolist()} m is outside the grid "
                                 f"[0, {hi.tolist()}] m ({', '.join(axes)})")
        tr = np.zeros((p.shape[0], 3))
        tr[:, 0] = 0.5 * box[0]
        tr[:, cols] = p
        self.tracers = tr

    @property
    def shape(self):
        return self.q.shape[1:]

    def apply_velocity_jump(self, dv):
        """The floor's velocity jumps by dv [m/s]: the bed's, relative to it, by −dv."""
        self.q[MZ] -= self.q[RHO] * dv

    STEP_CHUNK_CELL_STEPS = 1 << 22
    """Cell-steps per compiled call (about 1-4 s): Ctrl-C and SIGTERM are handled between calls."""

    PARALLEL_MIN_CELLS = 512
    """Grids of at least this many cells step on numba's threads (:func:`bed_advance`'s
    ``parallel``; the same numbers bit for bit), smaller ones (the column) on one.  Measured on
    this project's 2-core VM, otherwise idle (one-off runs of the thread test of
    ``NUMBA_THREADING_LAYER=L python bench/bench_bed_eulerian.py --threads-lateral N
    --threads-time 1e-3``, 2026-12-05): on two threads a 4 × 4 × 49 grid (784 cells) stepped
    1.3-2.0x as fast as on one with numba's tbb, workqueue and omp layers, a 2 × 2 × 49 grid
    (196 cells) 1.1x, 0.6x and 2.0x.  With another process busy on one of the two cores, the
    4 × 4 × 49 grid stepped about 0.8x as fast on two threads as on one (omp and workqueue, a
    one-off run)."""

    LID_MASS_FRACTION = 1e-3
    """The most of the bed's mass that may be within one diameter of the grid's lid (its top
    ``cells_per_d`` layers) after an :meth:`advance`; more stops the run (the lid reflects the bed,
    so a lid in the bed's path would change its flight; the setup refuses a lid less than a
    diameter above the bed at rest).  With the default lid (the energy bound's height), one-off
    runs of 2026-12-05 over 11 cycles kept at most 6.6e-6 there (the reference's bed, a column at
    4 cells per d, Γ = 1.5-8), 2e-6 (600 spheres, 1-4 cells per d, Γ = 3-8) and 2.5e-5 to 1.3e-4
    (beds 1.0-1.2 d deep, 210-250 spheres, Γ = 3-8, a review's runs reaching 1e-4 too), with the
    HLLC flux along z (the fourth session's one-off runs) 1.3e-5 (the reference's bed, Γ = 3 and
    8) and 2.1e-5 (210-250 spheres, Γ = 8); a lid 2 d
    above a 600-sphere bed at Γ = 6 had the top cell at φ = 0.48 (a fuzzing review), one at 16 d
    0.4 % of the mass within a diameter of it."""

    @property
    def parallel(self) -> bool:
        """True if :meth:`advance` steps on numba's threads (more than one, and a grid of at least
        :attr:`PARALLEL_MIN_CELLS` cells)."""
        return numba.get_num_threads() > 1 and self.q[RHO].size >= self.PARALLEL_MIN_CELLS

    def advance(self, t0, t1, moving=True):
        """Steps from t0 to t1 [s] (the floor moving unless ``moving`` is False); returns the mean
        floor force over the interval [N] (the floor's stress, mean over the columns, times the
        area).  A failed state raises :class:`bsrflow.numerics.solver.SimulationError` naming the
        time and the cell."""
        s = self.setup
        chunk = max(1, self.STEP_CHUNK_CELL_STEPS // self.q[RHO].size)
        parallel = self.parallel
        t, impulse = float(t0), 0.0
        while True:
            t, imp = bed_advance(self.q, t, float(t1), self.dim, self.dx, self.cfl, self.par, s.gravity, s.amplitude,
                                 s.omega, moving, self.named["e_d"], self.work, self.counters, chunk, parallel,
                                 self.tracers, self._box)
            impulse += imp
            if t >= t1 or self.counters[1]:
                break
        self.steps = int(self.counters[0])
        self.t = t
        if self.counters[1]:
            from .solver import SimulationError
            what = {1: "a negative density", 2: "a non-finite value"}[int(self.counters[1])]
            idx = np.unravel_index(int(self.counters[2]), self.shape)
            raise SimulationError(f"the Eulerian bed failed at t = {t:.6g} s: {what} in cell {tuple(map(int, idx))} "
                                  f"(height {self.z[idx[2]]:.4g} m)", None, t, None, "stopped")
        if t1 > t0:
            self._floor_force[0] = impulse / (t1 - t0) * s.area
        near = self.lid_mass_fraction()
        if near > self.LID_MASS_FRACTION:
            from .solver import SimulationError
            lid = self.shape[2] * self.dx[2]
            raise SimulationError(f"the Eulerian bed stopped at t = {t:.6g} s: {near:.3g} of its mass is within one "
                                  f"diameter of the grid's lid ({lid:.4g} m; at most {self.LID_MASS_FRACTION:g}); "
                                  "raise output_height", None, t, None, "stopped")
        return self.last_floor_force if t1 > t0 else 0.0

    def lid_mass_fraction(self) -> float:
        """The fraction of the bed's mass within one diameter of the grid's lid (its top
        ``cells_per_d`` cell layers; :attr:`LID_MASS_FRACTION`)."""
        col = self.q[RHO].sum(axis=(0, 1))
        return float(col[-self.cells_per_d:].sum() / col.sum())

    @property
    def last_floor_force(self) -> float:
        """The floor's force on the bed [N], mean over the last advance (0 before any)."""
        return float(self._floor_force[0])

    # the controller's interface (bsrflow run) -------------------------------------------------
    name = "granular_bed_eulerian"

    def settle(self):
        """``setup.settle`` s on the resting floor, from t = −settle to 0."""
        if self.setup.settle > 0.0:
            self.advance(-float(self.setup.settle), 0.0, moving=False)

    @property
    def grid(self):
        """The output column of the setup (:meth:`~bsrflow.physics.granular_bed.BedSetup.grid`:
        bins of d/10 up to ``output_top``)."""
        if self._grid is None:
            self._grid = self.setup.grid()
        return self._grid

    def tracer_positions(self):
        """The tracers' positions (n, dim) [m] in the user layout (:attr:`TRACER_AXES`), floor
        frame; (0, dim) without tracers."""
        return self.tracers[:, self._TRACER_COLUMNS[self.dim]]

    def observe(self):
        """(u (1, nz) [m/s], ρ (nz) [kg/m]) on the output column: the bed's mass per metre of
        height (summed over the box) and its mass-weighted vertical velocity, the cells' mass
        spread evenly over their height."""
        s = self.setup
        g = self.grid
        dz = self.dx[2]
        cell_area = s.area / (self.q.shape[1] * self.q.shape[2])
        mass = self.q[RHO].sum(axis=(0, 1)) * cell_area * dz           # per z-cell [kg]
        mom = self.q[MZ].sum(axis=(0, 1)) * cell_area * dz
        edges = g.lower[-1] + g.dx * np.arange(g.shape[0] + 1)
        m_bin, p_bin = spread_over_bins(np.arange(len(mass) + 1) * dz, edges, mass, mom)
        u = np.where(m_bin > 0.0, p_bin / np.where(m_bin > 0.0, m_bin, 1.0), 0.0)
        return u[None, :], m_bin / g.dx

    @property
    def fields(self) -> dict:
        """The named state (checkpoints): ``q`` (6, NX, NY, NZ), the conserved fields ρ, ρu_x,
        ρu_y, ρu_z, (3/2)ρθ, ρδ_max (SI); ``floor_force`` (1) [N], the last advance's (written
        with the snapshot at the checkpoint's time)."""
        return {"q": self.q, "floor_force": self._floor_force}

    def load_fields(self, fields):
        """Restore :attr:`fields` (ValueError naming the first that is missing or of another shape)."""
        from .controller import restore_named_fields
        restore_named_fields(self.fields, fields)

    def state_problem(self) -> str | None:
        """What makes the state one that no run reaches (a checkpoint edited or damaged by hand),
        in words, or None: ρ, E and ρδ_max ≥ 0 in every cell, and the bed's mass the setup's to 1e-6
        (a run conserves it to round-off: 1.3e-10 after 2.6e6 steps, far inside that bound)."""
        for c, name in ((RHO, "density"), (ENER, "energy"), (HIST, "history rho delta_max")):
            if np.any(self.q[c] < 0.0):
                return f"q: the {name} is negative in {int(np.count_nonzero(self.q[c] < 0.0))} cell(s)"
        mass = float(self.q[RHO].sum())
        if not abs(mass / self.mass0 - 1.0) <= 1e-6:
            return f"q: the bed's mass is {mass / self.mass0:.6g} of the config's (a run conserves it to round-off)"
        return None

    def output_schema(self) -> dict:
        """The state written with every snapshot (``state_<name>``): the grid's fields with units,
        on the dimensions ``grid_x``, ``grid_y``, ``grid_z`` (cell centres at (i + ½)Δ, the cell
        sizes in the file's ``grid_cell_size_m``)."""
        dims = ("grid_x", "grid_y", "grid_z")
        return {"solid_fraction": (dims, "1", "solid fraction phi = rho / rho_s of the Eulerian cells"),
                "velocity_x": (dims, "m s-1", "horizontal velocity u_x of the cells"),
                "velocity_y": (dims, "m s-1", "horizontal velocity u_y of the cells (0 in 1-D and 2-D)"),
                "velocity_z": (dims, "m s-1", "vertical velocity u_z of the cells relative to the floor"),
                "theta": (dims, "m2 s-2", "granular temperature theta = <C^2>/3 of the cells"),
                "delta_max": (dims, "m", "largest overlap per contact reached (the packing law's history)"),
                "floor_force": ((), "N", "the floor's force on the bed, mean over the last advance")}

    def vtk_grid(self):
        """The grid's geometry for :class:`bsrflow.io.vtk.VTKWriter`: dim, shape and the cell
        sizes per axis [m] (a 2-D grid as (x, z), a column as (z,)), the lower corner at 0."""
        from types import SimpleNamespace
        nx, ny, nz = self.shape
        if self.dim == 1:
            shape, dx = (nz,), (self.dx[2],)
        elif self.dim == 2:
            shape, dx = (nx, nz), (self.dx[0], self.dx[2])
        else:
            shape, dx = (nx, ny, nz), tuple(self.dx)
        return SimpleNamespace(dim=self.dim, shape=shape, dx=np.array(dx), lower=(0.0,) * self.dim)

    def vtk_fields(self) -> dict:
        """The cells' fields for VTK (names with units; C order of :meth:`vtk_grid`'s axes):
        solid fraction, velocity (u_x, u_y, u_z) relative to the floor, granular temperature."""
        f = self.output_fields()
        vel = np.stack([f["velocity_x"].ravel(), f["velocity_y"].ravel(), f["velocity_z"].ravel()], axis=-1)
        return {"solid fraction [1]": f["solid_fraction"].ravel(), "velocity [m/s]": vel,
                "granular temperature [m^2/s^2]": f["theta"].ravel()}

    def output_fields(self) -> dict:
        """The fields of :meth:`output_schema` now."""
        q = self.q
        r = q[RHO]
        has = r > self.named["rho_tiny"]
        safe = np.where(has, r, 1.0)
        per = {"velocity_x": MX, "velocity_y": MY, "velocity_z": MZ}
        out = {"solid_fraction": r / self.setup.density}
        for k, c in per.items():
            out[k] = np.where(has, q[c] / safe, 0.0)
        out["theta"] = np.where(has, np.maximum(q[ENER] / (1.5 * safe), 0.0), 0.0)
        out["delta_max"] = np.where(has, q[HIST] / safe, 0.0)
        out["floor_force"] = np.float64(self.last_floor_force)
        return out

    def mass_centre(self) -> float:
        """Height of the bed's mass centre above the floor [m]."""
        col = self.q[RHO].sum(axis=(0, 1))
        return float((col * self.z).sum() / col.sum())

    def top(self) -> float:
        """Height below which 99 % of the mass lies [m]."""
        col = self.q[RHO].sum(axis=(0, 1))
        cum = np.concatenate([[0.0], np.cumsum(col)]) / col.sum()
        edges = np.arange(len(col) + 1) * self.dx[2]
        return float(np.interp(0.99, cum, edges))

    def lateral_spread(self) -> float:
        """The spread of the columns' mass centres [m]: their standard deviation over the columns
        (0 for a horizontally uniform bed)."""
        col = self.q[RHO]
        tot = col.sum(axis=2)
        com = (col * self.z).sum(axis=2) / np.where(tot > 0.0, tot, 1.0)
        return float(np.std(com))

    def mass_error(self) -> float:
        """Relative change of the total mass since the start."""
        return float(self.q[RHO].sum()) / self.mass0 - 1.0


def run_eulerian_bed(setup, dim=1, cells_per_d=4, lateral_cells=1, perturbation=0.0, save_every=1e-4,
                     progress=None) -> dict:
    """Run the setup's bed (:class:`EulerianBed`) as :func:`bsrflow.numerics.bed_lagrangian.run_bed`
    does: from rest, ``setup.settle`` s on the resting floor, then the floor's velocity jumps to
    aω and it vibrates for ``setup.cycles`` cycles.  Returns {t [s], mass_centre [m], top [m],
    floor_force [N] (the mean over each save interval), lateral_spread [m], steps, wall_time_s,
    mass_error, shape, dx [m]}."""
    import time
    s = setup
    wall = time.perf_counter()
    bed = EulerianBed(s, dim, cells_per_d, lateral_cells, perturbation)
    if s.settle > 0.0:
        bed.advance(-s.settle, 0.0, moving=False)
    bed.apply_velocity_jump(s.amplitude * s.omega)
    n = int(round(s.t_end / save_every))
    t = np.arange(n + 1) * save_every
    com, top, force, spread = (np.empty(n + 1) for _ in range(4))
    com[0], top[0], spread[0] = bed.mass_centre(), bed.top(), bed.lateral_spread()
    for i in range(1, n + 1):
        force[i] = bed.advance(t[i - 1], t[i])
        com[i], top[i], spread[i] = bed.mass_centre(), bed.top(), bed.lateral_spread()
        if progress is not None:
            progress(t[i])
    force[0] = force[1]
    return {"t": t, "mass_centre": com, "top": top, "floor_force": force, "lateral_spread": spread,
            "steps": int(bed.counters[0]), "wall_time_s": time.perf_counter() - wall, "mass_error": bed.mass_error(),
            "shape": tuple(int(v) for v in bed.shape), "dx": bed.dx.tolist()}
