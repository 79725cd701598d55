"""The packing continuum on a 2-D / 3-D grid (issue #19): formulation (a) of
:mod:`bsrflow.numerics.packing` on :class:`~bsrflow.numerics.grid_nd.GridND`.

Fields per cell (conserved): ρ [kg/m^n], ρu_a [kg/(m^(n−1) s)] for each axis a (z vertical, the
last), ρδ_max [kg m/m^n]; the stress is the packing law's as a pressure,
P(ρ, δ_max) = WB(d(1 − ρ_c/ρ), δ_max) with the loading stiffness k1 [Pa/m] and unloading k1/e²
(:class:`PackingLawND`): zero below close packing ρ_c, never tensile, the history reset where
the material separates.  For spheres (:meth:`PackingLawND.for_spheres`) ρ_c = φ_c ρ_s and
k1 = 3Zφ_cK/(5πd²), the affine uniaxial stiffness of an isotropic packing
(:mod:`bsrflow.physics.granular_bed`), so that the horizontally uniform bed is the 1-D law per
layer.

Scheme: the 1-D scheme along each axis, summed (unsplit): primitive states (ρ, u_a, δ_max),
minmod-limited linear reconstruction along the axis (first order at the 1-D rule's compaction
faces, ``packing_kernels.compaction_face``, with the axis's velocity), the 1-D HLLE wave bounds
(``packing_kernels.hlle_waves``: Einfeldt's bounds with the secant sound speed) for the
normal flux, the transverse momenta carried in the same HLLE flux; SSP-RK3 in increment form;
the density floor and history pass after every step.  Boundaries: periodic sides, the floor
below (mirror: ρ, δ_max even, u_z odd, u_x, u_y even), a lid at the domain top (mirror ghosts
too: no mass leaves; the run stops when more than ``top_fraction`` of the mass reaches the top six
cell layers, so in every run that finishes the material there, the diffusive trace of the
scheme above the bed, is at most that fraction).

Round-off: two runs that differ by round-off (a 90° rotation of the horizontal axes, one ulp in
one cell's initial density) drift apart by up to 3e-2 ρ_c in 0.06 s of a 3-D bed (a review's
runs, 2026-12-02): the sound-speed bound of the faces jumps from 0 to its close-packing value
where a cell reaches ρ_c, and which faces cross it first depends on the last bits.  The right-
hand side itself keeps the symmetries to 2e-16, and the runs are reproducible bit for bit (same
input, threads, resume); only bit-for-bit comparisons are meaningful, and differences below
about 1e-2 ρ_c between runs that should be equal are noise.

The stress is the uniaxial packing law used as a pressure, the same in every direction: a
horizontally uniform bed gets its vertical stress exactly, but laterally the packing pushes as
hard as vertically (9/5 of the isotropic pressure of the affine packing) and it has no shear
strength, so a heap flattens under gravity (a 10-mm surface undulation to 3.7 mm in 0.2 s at
rest, a review's one-off run).
Δt = cfl Δx / (c_bound + max Σ_a |u_a|), with cfl ≤ 0.5/n (default 0.4/n).

A horizontally uniform state evolves as the 1-D formulation at the same Δt: the horizontal
flux differences of equal states are exactly 0 (the horizontal velocity stays exactly 0) and
the vertical update is the 1-D one's formula.  With the 1-D law's constants (:meth:`PackingLawND.
from_1d` keeps its sphere mass m exactly, and the sound-speed bound is the 1-D formula d√(k2/m))
the two are equal bit for bit over 7·10⁴ and 1.1·10⁵ steps of a tapped 4-sphere column
(``bsrflow verify --case embedding_packing``: cases ``embedding_packing_2d`` / ``_3d``,
:func:`verify_cases`: error 0); before, with m = ρ_c d rounded, they differed by 2.7e-11 / 2.1e-12.
A column (dim = 1) runs the 1-D finite volumes themselves.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numba
import numpy as np
from numba import prange

from ..physics.interaction import Interaction
from ..physics.packing import BilinearStiffness, history_update
from . import packing_kernels as pk
from .tracers import tracer_combine, tracer_stage

__all__ = ["PackingLawND", "EulerianPackingND", "run_packing_nd", "fv_rhs_nd", "verify_cases"]

RHO, MX, MY, MZ, HIST = 0, 1, 2, 3, 4
LINE_BLOCKS = 64
"""Blocks the horizontal lines of a stage are shared out in (each allocates its work arrays once)."""


@dataclass(frozen=True)
class PackingLawND(BilinearStiffness, Interaction):
    """The packing stress on an n-D grid (SI): ``stiffness`` [Pa/m] the packing's loading
    stiffness, restitution e in (0, 1] (unloading k1/e²), diameter d [m], close_packing_density
    ρ_c [kg/m^n]; ``stiffness_factor`` φ in (0, 1] scales loading and unloading together (the
    reduced-stiffness option of the 1-D law, docs/model.md), so the stiffness used is
    k1 = φ · stiffness.  An :class:`~bsrflow.physics.interaction.Interaction` reading the density
    and the history at both points, with the constant bound of the sound speed at close packing
    (:meth:`wave_speed`)."""

    state_fields = ("rho", "rho_delta_max")
    radius = property(lambda self: self.diameter, doc="R = d [m], the range of the BSR form.")

    stiffness: float
    restitution: float
    diameter: float
    close_packing_density: float
    particle_mass: float | None = None
    """The 1-D law's sphere mass m when built from it (:meth:`from_1d`: then m_eff is m exactly,
    not ρ_c d rounded); None otherwise."""
    stiffness_factor: float = 1.0

    def __post_init__(self):
        for name in ("stiffness", "diameter", "close_packing_density"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} = {v!r} is outside the valid range (0, inf)")
        if not (0.0 < self.restitution <= 1.0):
            raise ValueError(f"restitution = {self.restitution!r} is outside the valid range (0, 1]")
        if not (math.isfinite(self.stiffness_factor) and 0.0 < self.stiffness_factor <= 1.0):
            raise ValueError(f"stiffness_factor = {self.stiffness_factor!r} is outside the valid range (0, 1]")

    @classmethod
    def for_spheres(cls, stiffness, restitution, diameter, density, phi_c, coordination, stiffness_factor=1.0):
        """3-D spheres of contact stiffness K [N/m] (``stiffness``): ρ_c = φ_c ρ_s,
        stiffness 3 Z φ_c K / (5 π d²) [Pa/m]."""
        return cls(3.0 * coordination * phi_c * stiffness / (5.0 * math.pi * diameter ** 2), restitution, diameter,
                   phi_c * density, stiffness_factor=stiffness_factor)

    @classmethod
    def from_1d(cls, law):
        """The 1-D law (:class:`bsrflow.physics.packing.PackingLaw`) on a unit cross-section:
        the same numbers (the embedding check), its stiffness factor included; the local law only
        (the nonlocal interaction, ``range_over_d`` > 0, is the 1-D formulations')."""
        if law.is_nonlocal:
            raise ValueError(f"range_over_d = {law.range_over_d!r} is outside the valid range [0, 0] of the "
                             "n-D packing law (the nonlocal interaction runs in 1-D only, in both formulations)")
        return cls(law.stiffness, law.restitution, law.diameter, law.close_packing_density, law.particle_mass,
                   law.stiffness_factor)

    @property
    def m_eff(self) -> float:
        """ρ_c d: the 1-D kernels' "particle mass" (δ = d − m/ρ); the 1-D law's m when built
        from it."""
        if self.particle_mass is not None:
            return self.particle_mass
        return self.close_packing_density * self.diameter

    def wave_speed(self) -> float:
        """Bound on the sound speed at close packing, √(k2 m_eff)/ρ_c = d √(k2/m_eff) [m/s] (the
        1-D law's formula; k1, k2 [Pa/m] of :class:`~bsrflow.physics.packing.BilinearStiffness`)."""
        return self.diameter * math.sqrt(self.k2 / self.m_eff)

    def to_dict(self) -> dict:
        return {"name": "packing_nd", "stiffness": self.stiffness, "stiffness_factor": self.stiffness_factor,
                "k1": self.k1, "restitution": self.restitution, "diameter": self.diameter,
                "close_packing_density": self.close_packing_density,
                "units": {"stiffness": "Pa m-1", "k1": "Pa m-1", "diameter": "m", "close_packing_density": "kg m-n"}}


@numba.njit(cache=True, inline="always")
def _axis_face(wr, wu, wt1, wt2, wh, jl, jr, d, m, k1, k2, c_cap, rho_tiny):
    """HLLE fluxes (mass, normal momentum, transverse momenta 1, 2, history) at the face between
    padded cells jl and jr of one line of primitives (the 1-D fv_rhs reconstruction); the normal
    momentum flux carries no tension (``packing_kernels.no_tension``)."""
    # half slopes, none at a compaction face (first order, the 1-D rule): a factor, not a branch
    # (the branch cost the 3-D step 60 %; 0 * slope adds an exact 0, so the states are the same)
    hs = 0.0 if pk.compaction_face(wr[jl], wu[jl], wr[jr], wu[jr], d, m) else 0.5
    rL = wr[jl] + hs * pk._minmod(wr[jl] - wr[jl - 1], wr[jr] - wr[jl])
    uL = wu[jl] + hs * pk._minmod(wu[jl] - wu[jl - 1], wu[jr] - wu[jl])
    hL = wh[jl] + hs * pk._minmod(wh[jl] - wh[jl - 1], wh[jr] - wh[jl])
    rR = wr[jr] - hs * pk._minmod(wr[jr] - wr[jl], wr[jr + 1] - wr[jr])
    uR = wu[jr] - hs * pk._minmod(wu[jr] - wu[jl], wu[jr + 1] - wu[jr])
    hR = wh[jr] - hs * pk._minmod(wh[jr] - wh[jl], wh[jr + 1] - wh[jr])
    aL = wt1[jl] + hs * pk._minmod(wt1[jl] - wt1[jl - 1], wt1[jr] - wt1[jl])
    aR = wt1[jr] - hs * pk._minmod(wt1[jr] - wt1[jl], wt1[jr + 1] - wt1[jr])
    bL = wt2[jl] + hs * pk._minmod(wt2[jl] - wt2[jl - 1], wt2[jr] - wt2[jl])
    bR = wt2[jr] - hs * pk._minmod(wt2[jr] - wt2[jl], wt2[jr + 1] - wt2[jr])
    SL, SR, uL, uR, pL, pR = pk.hlle_waves(rL, uL, hL, rR, uR, hR, d, m, k1, k2, c_cap, rho_tiny)
    if rL <= rho_tiny:
        aL, bL = 0.0, 0.0
    if rR <= rho_tiny:
        aR, bR = 0.0, 0.0
    f_mass = pk.hlle_combine(SL, SR, rL * uL, rR * uR, rL, rR)
    f_mom = pk.hlle_combine(SL, SR, rL * uL * uL + pL, rR * uR * uR + pR, rL * uL, rR * uR)
    return (f_mass, pk.no_tension(f_mass, f_mom, uL, uR),
            pk.hlle_combine(SL, SR, rL * uL * aL, rR * uR * aR, rL * aL, rR * aR),
            pk.hlle_combine(SL, SR, rL * uL * bL, rR * uR * bR, rL * bL, rR * bR),
            pk.hlle_combine(SL, SR, rL * uL * hL, rR * uR * hR, rL * hL, rR * hR))


@numba.njit(cache=True, inline="always")
def _line_fluxes(wr, wu, wa, wb, wh, n, fl, d, m, k1, k2, c_cap, rho_tiny):
    """Fluxes ``fl`` (5, n + 1) at the n + 1 faces of one padded line of n cells (ghosts filled)."""
    for f in range(n + 1):
        F = _axis_face(wr, wu, wa, wb, wh, f + 1, f + 2, d, m, k1, k2, c_cap, rho_tiny)
        for c in range(5):
            fl[c, f] = F[c]


@numba.njit(cache=True, inline="always")
def _line_buffers(n):
    """Work arrays of one line of n cells: primitives (ρ, u_normal, u_t1, u_t2, δ_max) with two
    ghosts below and three above, and the fluxes (5, n + 1) at its faces."""
    return (np.zeros(n + 5), np.zeros(n + 5), np.zeros(n + 5), np.zeros(n + 5), np.zeros(n + 5),
            np.zeros((5, n + 1)))


@numba.njit(cache=True, inline="always")
def _primitive(q, c, i, j, k, rho_tiny):
    r = q[RHO, i, j, k]
    if r > rho_tiny:
        return r, q[c, i, j, k] / r
    return 0.0, 0.0


@numba.njit(cache=True, parallel=True)
def fv_rhs_nd(q, dq, dim, dx, accel, d, m, k1, k2, c_cap, rho_tiny):
    """dq = L(q) on the whole grid (module docstring); q, dq of shape (5, NX, NY, NZ) (NY = 1 and
    the y momentum 0 in 2-D).  The vertical part is the 1-D ``fv_rhs``'s formula."""
    _, NX, NY, NZ = q.shape
    inv_dx = 1.0 / dx
    for i in prange(NX):
        wr, wu, wa, wb, wh, fl = _line_buffers(NZ)
        for j in range(NY):
            # vertical line: padded index p = k + 2; floor mirror below, the lid above (mirror)
            for k in range(NZ):
                r, u = _primitive(q, MZ, i, j, k, rho_tiny)
                wr[k + 2], wu[k + 2] = r, u
                wa[k + 2] = q[MX, i, j, k] / r if r > 0.0 else 0.0
                wb[k + 2] = q[MY, i, j, k] / r if r > 0.0 else 0.0
                wh[k + 2] = q[HIST, i, j, k] / r if r > 0.0 else 0.0
            for g in range(2):
                wr[1 - g], wu[1 - g], wa[1 - g], wb[1 - g], wh[1 - g] = (wr[2 + g], -wu[2 + g], wa[2 + g],
                                                                         wb[2 + g], wh[2 + g])
            # the lid at the domain top: mirror ghosts (no mass crosses it); only a trace of the
            # material (``top_fraction``) may reach it, more stops the run; with the top cells
            # empty these ghosts are zeros and the fluxes the 1-D formula's
            for g in range(3):
                wr[NZ + 2 + g], wu[NZ + 2 + g], wa[NZ + 2 + g], wb[NZ + 2 + g], wh[NZ + 2 + g] = (
                    wr[NZ + 1 - g], -wu[NZ + 1 - g], wa[NZ + 1 - g], wb[NZ + 1 - g], wh[NZ + 1 - g])
            _line_fluxes(wr, wu, wa, wb, wh, NZ, fl, d, m, k1, k2, c_cap, rho_tiny)
            for k in range(NZ):
                dq[RHO, i, j, k] = -(fl[0, k + 1] - fl[0, k]) * inv_dx
                dq[MZ, i, j, k] = -(fl[1, k + 1] - fl[1, k]) * inv_dx + q[RHO, i, j, k] * accel
                dq[MX, i, j, k] = -(fl[2, k + 1] - fl[2, k]) * inv_dx
                dq[MY, i, j, k] = -(fl[3, k + 1] - fl[3, k]) * inv_dx
                dq[HIST, i, j, k] = -(fl[4, k + 1] - fl[4, k]) * inv_dx
    # horizontal axes (periodic): x, and y in 3-D; their flux differences are added after the
    # vertical part, so that an exact 0 leaves the vertical update unchanged
    # (the lines are shared out by p = jb·NZ + kk, so that each thread gets whole columns of
    # lines: dense and empty heights alike; by height alone one thread got the dense half)
    for axis in range(dim - 1):
        nA = NX if axis == 0 else NY
        nB = NY if axis == 0 else NX
        cn = MX if axis == 0 else MY
        ct = MY if axis == 0 else MX
        # LINE_BLOCKS contiguous blocks of lines, each with its work arrays allocated once
        # (allocating them per line, 6 · nB · NZ times per axis and stage, serialised the threads
        # on the allocator: 2-thread efficiency 0.76-0.81 at 64³)
        n_lines = nB * NZ
        n_blocks = min(n_lines, LINE_BLOCKS)
        for blk in prange(n_blocks):
            wr, wu, wa, wb, wh, fl = _line_buffers(nA)
            for p in range(blk * n_lines // n_blocks, (blk + 1) * n_lines // n_blocks):
                _horizontal_line(q, dq, p, NZ, nA, axis, cn, ct, wr, wu, wa, wb, wh, fl, inv_dx, d, m, k1, k2,
                                 c_cap, rho_tiny)
    if dim == 2:
        for i in range(NX):
            for k in range(NZ):
                dq[MY, i, 0, k] = 0.0


@numba.njit(cache=True, inline="always")
def _horizontal_line(q, dq, p, NZ, nA, axis, cn, ct, wr, wu, wa, wb, wh, fl, inv_dx, d, m, k1, k2, c_cap, rho_tiny):
    """Add the flux differences of horizontal line p = jb·NZ + kk along ``axis`` to dq."""
    jb = p // NZ
    kk = p - jb * NZ
    for ia in range(nA):
        i, j = (ia, jb) if axis == 0 else (jb, ia)
        r, u = _primitive(q, cn, i, j, kk, rho_tiny)
        wr[ia + 2], wu[ia + 2] = r, u
        wa[ia + 2] = q[MZ, i, j, kk] / r if r > 0.0 else 0.0
        wb[ia + 2] = q[ct, i, j, kk] / r if r > 0.0 else 0.0
        wh[ia + 2] = q[HIST, i, j, kk] / r if r > 0.0 else 0.0
    for g in range(2):                     # periodic ghosts
        src_lo, src_hi = nA - 1 - g, g
        wr[1 - g], wu[1 - g], wa[1 - g], wb[1 - g], wh[1 - g] = (
            wr[src_lo + 2], wu[src_lo + 2], wa[src_lo + 2], wb[src_lo + 2], wh[src_lo + 2])
        wr[nA + 2 + g], wu[nA + 2 + g], wa[nA + 2 + g], wb[nA + 2 + g], wh[nA + 2 + g] = (
            wr[src_hi + 2], wu[src_hi + 2], wa[src_hi + 2], wb[src_hi + 2], wh[src_hi + 2])
    wr[nA + 4], wu[nA + 4], wa[nA + 4], wb[nA + 4], wh[nA + 4] = wr[4], wu[4], wa[4], wb[4], wh[4]
    _line_fluxes(wr, wu, wa, wb, wh, nA, fl, d, m, k1, k2, c_cap, rho_tiny)
    for ia in range(nA):
        i, j = (ia, jb) if axis == 0 else (jb, ia)
        dq[RHO, i, j, kk] += -(fl[0, ia + 1] - fl[0, ia]) * inv_dx
        dq[cn, i, j, kk] += -(fl[1, ia + 1] - fl[1, ia]) * inv_dx
        dq[MZ, i, j, kk] += -(fl[2, ia + 1] - fl[2, ia]) * inv_dx
        dq[ct, i, j, kk] += -(fl[3, ia + 1] - fl[3, ia]) * inv_dx
        dq[HIST, i, j, kk] += -(fl[4, ia + 1] - fl[4, ia]) * inv_dx


@numba.njit(cache=True, parallel=True)
def fv_post_step_nd(q, d, m, rho_floor):
    """The 1-D post-step passes (density floor, history update) on every cell."""
    _, NX, NY, NZ = q.shape
    for i in prange(NX):
        for j in range(NY):
            for k in range(NZ):
                r = q[RHO, i, j, k]
                if r < 0.0:
                    continue
                if r < rho_floor:
                    for c in range(5):
                        q[c, i, j, k] = 0.0
                    continue
                h = q[HIST, i, j, k] / r
                q[HIST, i, j, k] = r * history_update(d - m / r, h)


@numba.njit(cache=True, parallel=True)
def _speed_and_top(q, rho_tiny):
    """(max over cells of Σ_a |u_a|, fraction of the mass in the top 6 layers of cells, status,
    where): per vertical plane i in parallel, then reduced in the order of i (the same numbers
    on any number of threads); status 2 at the first non-finite cell, else 1 at the first
    negative density (flat index order)."""
    _, NX, NY, NZ = q.shape
    umax_i = np.zeros(NX)
    total_i = np.zeros(NX)
    near_i = np.zeros(NX)
    status_i = np.zeros(NX, np.int64)
    where_i = np.full(NX, -1, np.int64)
    for i in prange(NX):
        umax = 0.0
        total = 0.0
        near_top = 0.0
        for j in range(NY):
            for k in range(NZ):
                r = q[RHO, i, j, k]
                if not (math.isfinite(r) and math.isfinite(q[MZ, i, j, k])):
                    if status_i[i] != 2:
                        status_i[i], where_i[i] = 2, (i * NY + j) * NZ + k
                    continue
                if r < 0.0:
                    if status_i[i] == 0:
                        status_i[i], where_i[i] = 1, (i * NY + j) * NZ + k
                    continue
                total += r
                if k >= NZ - 6:
                    near_top += r
                if r > rho_tiny:
                    s = (abs(q[MX, i, j, k]) + abs(q[MY, i, j, k]) + abs(q[MZ, i, j, k])) / r
                    umax = max(umax, s)
        umax_i[i], total_i[i], near_i[i] = umax, total, near_top
    for st in (2, 1):
        for i in range(NX):
            if status_i[i] == st:
                return umax_i.max(), 0.0, st, where_i[i]
    total = 0.0
    near = 0.0
    for i in range(NX):
        total += total_i[i]
        near += near_i[i]
    return umax_i.max(), near / total if total > 0.0 else 0.0, 0, -1


@numba.njit(cache=True, parallel=True)
def _stage1(qf, q1f, i1f, dqf, dt):
    """k1 = Δt L(q), q1 = q + k1 (flat arrays)."""
    for idx in prange(qf.size):
        i1f[idx] = dt * dqf[idx]
        q1f[idx] = qf[idx] + i1f[idx]


@numba.njit(cache=True, parallel=True)
def _stage2(qf, q2f, i1f, i2f, dqf, dt):
    """k2 = Δt L(q1), q2 = q + (k1 + k2)/4."""
    for idx in prange(qf.size):
        i2f[idx] = dt * dqf[idx]
        q2f[idx] = qf[idx] + 0.25 * (i1f[idx] + i2f[idx])


@numba.njit(cache=True, parallel=True)
def _stage3(qf, i1f, i2f, dqf, dt):
    """q += (k1 + k2)/6 + 2 k3/3 with k3 = Δt L(q2) (the 1-D fv_advance's increment form)."""
    for idx in prange(qf.size):
        qf[idx] += (i1f[idx] + i2f[idx]) / 6.0 + (2.0 / 3.0) * (dt * dqf[idx])


@numba.njit(cache=True)
def fv_advance_nd(q, t, t_stop, dim, dx, cfl, c_bound, d, m, k1, k2, rho_tiny, rho_floor, top_fraction, fn, params,
                  gravity, counters, tracers, lo, box, work, max_steps):
    """SSP-RK3 steps (increment form, as the 1-D ``fv_advance``) from t to exactly t_stop, at most
    ``max_steps`` of them (the caller continues from the t returned: every step is chosen from
    the state alone, so the steps are the same however the interval is cut).
    counters: [steps, status, where]; status 1 negative density, 2 non-finite, 3 more than
    ``top_fraction`` of the mass in the top 6 layers of cells (the 1-D column stops on any
    material there; see :attr:`EulerianPackingND.top_fraction`).  tracers (n, 3) [m] (floor
    frame; n = 0 for none) move with the interpolated velocity (:func:`bsrflow.numerics.tracers.tracer_velocity`) by the
    same SSP-RK3 stages; lo (3) the grid's lower corner, box (3) its extents [m].  work: the
    stage arrays (5, *q.shape), allocated once by the caller (q1, q2, dq and the two increments;
    every element is written before it is read)."""
    _, NX, NY, NZ = q.shape
    vt = np.zeros((3, tracers.shape[0], 3))
    dxv = np.full(3, dx)                    # (cubic cells: the tracers' per-axis cell sizes)
    top = lo[2] + box[2]
    q1, q2, dq, inc1, inc2 = work[0], work[1], work[2], work[3], work[4]
    qf, q1f, q2f, dqf = q.reshape(-1), q1.reshape(-1), q2.reshape(-1), dq.reshape(-1)
    i1f, i2f = inc1.reshape(-1), inc2.reshape(-1)
    n_steps = 0
    while t < t_stop and n_steps < max_steps:
        umax, near_top, status, where = _speed_and_top(q, rho_tiny)
        if status:
            counters[1], counters[2] = status, where
            return t
        if near_top > top_fraction:
            counters[1], counters[2] = 3, NZ - 6
            return t
        dt = cfl * dx / (c_bound + umax)
        last = False
        if t + dt >= t_stop:
            dt = t_stop - t
            last = True
        has_tr = tracers.shape[0] > 0
        if has_tr:
            tracer_stage(q, tracers, vt, 0, dt, lo, top, dxv, rho_tiny)
        fv_rhs_nd(q, dq, dim, dx, -gravity - fn(t, params)[2], d, m, k1, k2, c_bound, rho_tiny)
        _stage1(qf, q1f, i1f, dqf, dt)
        if has_tr:
            tracer_stage(q1, tracers, vt, 1, dt, lo, top, dxv, rho_tiny)
        fv_rhs_nd(q1, dq, dim, dx, -gravity - fn(t + dt, params)[2], d, m, k1, k2, c_bound, rho_tiny)
        _stage2(qf, q2f, i1f, i2f, dqf, dt)
        if has_tr:
            tracer_stage(q2, tracers, vt, 2, dt, lo, top, dxv, rho_tiny)
        fv_rhs_nd(q2, dq, dim, dx, -gravity - fn(t + 0.5 * dt, params)[2], d, m, k1, k2, c_bound, rho_tiny)
        _stage3(qf, i1f, i2f, dqf, dt)
        if has_tr:
            tracer_combine(tracers, vt, dt, lo, box, top, dim == 3)
        fv_post_step_nd(q, d, m, rho_floor)
        t = t_stop if last else t + dt
        counters[0] += 1
        n_steps += 1
    if t >= t_stop:                 # (a chunk that ends earlier is checked at the next call's first step)
        umax, near_top, status, where = _speed_and_top(q, rho_tiny)
        if status:
            counters[1], counters[2] = status, where
    return t


class EulerianPackingND:
    """The n-D packing continuum on ``grid`` (GridND: periodic sides, floor, a vacuum top, closed by a
    lid, module docstring).  On a
    column (dim = 1) the 1-D finite volumes of :class:`bsrflow.numerics.packing.EulerianPacking`
    run (bit for bit its results for the same law and cfl), in the n-D layout.

    law : :class:`PackingLawND`; motion : an applied motion (:mod:`bsrflow.physics.motion`);
    gravity g [m/s²]; cfl in (0, 0.5/n] (default 0.4/n); rho0 : initial density (*grid.shape)
    [kg/m^n], at rest, δ_max = 0; tracers : None or (n_tr, dim) positions [m] (floor frame,
    inside the grid; dim >= 2), moved with the interpolated velocity (:func:`bsrflow.numerics.tracers.tracer_velocity`)
    by the fields' SSP-RK3 stages.  ``supports`` lists the options it takes (``tracers`` in
    2-D / 3-D: a column's tracers are the 1-D formulations' mass coordinates)."""

    name = "eulerian_nd"
    supports = frozenset({"cfl", "stiffness_factor", "save_every", "checkpoint_every", "tracers"})

    def __init__(self, law, grid, motion, gravity, rho0, cfl=None, tracers=None):
        from .grid_nd import GridND
        if not isinstance(grid, GridND) or grid.bc_lower != "floor" or grid.bc_upper != "vacuum" or \
                any(b != "periodic" for b in grid.bc_horizontal):
            raise ValueError("grid must be a GridND with periodic sides, a floor below and a vacuum top")
        self.dim = grid.dim
        lim = 0.5 / self.dim
        cfl = 0.4 / self.dim if cfl is None else float(cfl)
        if not (0.0 < cfl <= lim):
            raise ValueError(f"cfl = {cfl!r} is outside the valid range (0, {lim:g}] for the {self.dim}-D "
                             "packing finite volumes")
        rho0 = np.asarray(rho0, dtype=float)
        if rho0.shape != tuple(grid.shape) or not np.all(np.isfinite(rho0)) or np.any(rho0 < 0):
            raise ValueError(f"rho0 must be finite, >= 0, of shape {tuple(grid.shape)}")
        self.law, self.grid, self.motion, self.gravity, self.cfl = law, grid, motion, float(gravity), cfl
        if self.dim == 1:
            # a column: the 1-D finite volumes of bsrflow.numerics.packing (EulerianPacking's
            # compiled pieces, its state layout (ρ, ρu, ρδ_max) with two ghost cells a side)
            n = grid.shape[0]
            self.q = np.zeros((3, n + 2 * pk.NG))
            self.q[pk.RHO, pk.NG:pk.NG + n] = rho0
        else:
            shape3 = (grid.shape[0], 1, grid.shape[1]) if self.dim == 2 else tuple(grid.shape)
            self.q = np.zeros((5,) + shape3)
            self.q[RHO] = rho0.reshape(shape3)
        rc = law.close_packing_density
        self.rho_tiny = 1e-12 * rc
        self.rho_floor = 1e-30 * rc
        self.top_fraction = 1e-4
        """Fraction of the mass in the top 6 layers of cells that stops the run (dim >= 2).  The
        numerical diffusion of the bed's top leaves an exponentially thin tail of material
        above it that climbs as the run goes (a 3-D bed at 2 cells per diameter, 10 ms after
        the floor's first impulse: 1.5e-7 ρ_c six cells and 6e-14 ρ_c ten cells above its top
        cell; one-off run); that trace
        may reach the lid at the domain top (mirror ghosts: no mass leaves), more stops the run."""
        self.c_bound = law.wave_speed_bound()       # the interaction's own bound
        lower, upper = np.asarray(grid.lower, float), np.asarray(grid.upper, float)
        if self.dim == 2:
            lower, upper = np.array([lower[0], 0.0, lower[1]]), np.array([upper[0], 1.0, upper[1]])
        elif self.dim == 1:
            lower, upper = np.array([0.0, 0.0, lower[0]]), np.array([1.0, 1.0, upper[0]])
        self._lo = np.ascontiguousarray(lower)
        self._box = np.ascontiguousarray(upper - lower)
        self.tracers = np.zeros((0, 3))
        """Tracer positions [m] (floor frame) in the internal layout (n_tr, 3): (x, y, z), y = 0
        in 2-D; :meth:`tracer_positions` gives the user layout."""
        if tracers is not None:
            self.set_tracers(tracers)
        self.counters = np.zeros(4, dtype=np.int64)
        self.steps = 0
        self._fn = motion.fn
        self._params = np.ascontiguousarray(motion.params, dtype=np.float64)

    def field_schema(self, per_depth: bool = False) -> dict:
        """The named state fields: name -> (dimensions, units, long_name), the dimensions the
        grid's axes (x, (y,) z; a column z).  ``per_depth``: a 2-D grid is a material uniform in
        depth (the packing bed: densities per unit volume), not a planar continuum."""
        axes = {1: ("z",), 2: ("x", "z"), 3: ("x", "y", "z")}[self.dim]
        n = 3 if per_depth else self.dim
        rho, mom, hist = f"kg m-{n}", f"kg m-{n - 1} s-1" if n > 1 else "kg s-1", f"kg m-{n - 1}" if n > 1 else "kg"
        out = {"rho": (axes, rho, "density (the finite volumes' state)")}
        for a in axes[:-1]:
            out[f"momentum_{a}"] = (axes, mom, f"momentum density rho u_{a} (floor frame)")
        out["momentum_z"] = (axes, mom, "momentum density rho u_z (floor frame)")
        out["rho_delta_max"] = (axes, hist, "rho times delta_max, the largest overlap per contact reached "
                                "(the history, advected in conserved form)")
        return out

    @property
    def fields(self) -> dict:
        """The named state fields (views of the conserved state, interior cells, the grid's
        shape): ``rho`` [kg/m^n], ``momentum_x`` (``_y``), ``momentum_z`` [kg/(m^(n−1) s)] (floor
        frame), ``rho_delta_max`` [kg m/m^n] (the history field times ρ).  Checkpoints store
        them and :meth:`load_fields` restores them."""
        if self.dim == 1:
            s = slice(pk.NG, pk.NG + self.grid.shape[0])
            return {"rho": self.q[pk.RHO, s], "momentum_z": self.q[pk.MOM, s], "rho_delta_max": self.q[pk.HIST, s]}
        shape = tuple(self.grid.shape)
        rows = [("rho", RHO), ("momentum_x", MX)] + ([("momentum_y", MY)] if self.dim == 3 else []) + \
            [("momentum_z", MZ), ("rho_delta_max", HIST)]
        return {name: self.q[r].reshape(shape) for name, r in rows}

    def load_fields(self, fields: dict):
        """Set the state from named fields (:attr:`fields`; a checkpoint's), all or none; ValueError
        (one line) when one is missing or has the wrong shape."""
        from .controller import restore_named_fields
        restore_named_fields(self.fields, fields)

    def set_tracers(self, positions):
        """Set the tracers from user-layout positions (n_tr, dim) [m] (floor frame): ValueError
        (one line) for a column (dim = 1: its tracers are the mass coordinates of the 1-D
        formulations), a wrong shape or a point outside the grid."""
        if self.dim == 1:
            raise ValueError("tracers: the n-D packing solver moves tracers in 2-D / 3-D only; a column's "
                             "tracers are its mass coordinates (bsrflow.numerics.packing)")
        try:
            p = np.asarray(positions, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"tracers: need an array of numbers of shape (n, {self.dim}) [m]") from None
        if p.ndim != 2 or p.shape[1] != self.dim:
            raise ValueError(f"tracers: need positions of shape (n, {self.dim}) [m], got {p.shape}")
        if not np.all(np.isfinite(p)):
            raise ValueError("tracers: the positions must be finite numbers [m]")
        lo, hi = np.asarray(self.grid.lower, float), np.asarray(self.grid.upper, float)
        for k, pt in enumerate(p):
            if np.any(pt < lo) or np.any(pt > hi):
                raise ValueError(f"tracers: tracer {k} at {pt.tolist()} m is outside the grid "
                                 f"[{lo.tolist()}, {hi.tolist()}] m")
        tr = np.zeros((p.shape[0], 3))
        if self.dim == 2:
            tr[:, 0], tr[:, 2] = p[:, 0], p[:, 1]
        else:
            tr[:] = p
        self.tracers = tr

    def tracer_positions(self) -> np.ndarray:
        """Tracer positions (n_tr, dim) [m] in the user layout ((x, z) in 2-D), floor frame."""
        if self.dim == 2:
            return self.tracers[:, [0, 2]].copy()
        return self.tracers.copy()

    def apply_velocity_jump(self, dv):
        if self.dim == 1:
            s = slice(pk.NG, pk.NG + self.grid.shape[0])
            self.q[pk.MOM, s] -= dv * self.q[pk.RHO, s]
            return
        self.q[MZ] -= dv * self.q[RHO]

    STEP_CHUNK_CELL_STEPS = 1 << 22
    """Cell-steps per compiled call of a 2-D / 3-D run (at least one step): Python handles a
    signal (Ctrl-C, SIGTERM) only between calls, and 4.2e6 cell-steps take about a second (the
    step's 65–153 ns per cell-stage, README, "Two and three dimensions").  The results do not depend on it (tested)."""

    PARALLEL_MIN_CELLS = 32768
    """Grids smaller than this run on one thread: waking the second thread for every parallel
    loop costs more than the loop (measured: 1.8 ms against 62 µs per step on 3 × 118 cells)."""

    def advance(self, t, t_stop):
        n_threads = numba.get_num_threads()
        if self.grid.n_cells < self.PARALLEL_MIN_CELLS and n_threads > 1:
            numba.set_num_threads(1)
        try:
            return self._advance(t, t_stop)
        finally:
            numba.set_num_threads(n_threads)

    def _advance(self, t, t_stop):
        from .packing import PackingError
        law = self.law
        self.counters[1:] = 0
        if self.dim == 1:
            t = pk.fv_advance(self.q, float(t), float(t_stop), self.grid.dx, self.cfl, self.c_bound, law.diameter,
                              law.m_eff, law.k1, law.k2, self.rho_tiny, self.rho_floor, self._fn, self._params,
                              self.gravity, self.counters)
            self.steps = int(self.counters[0])
            status = int(self.counters[1])
            if status:
                msg = {1: "negative density", 2: "non-finite state", 3: "material reached the top of the domain"}[status]
                where = float(self.grid.z[min(int(self.counters[2]), self.grid.shape[0] - 1)])
                raise PackingError(f"{msg} at t = {t:.6g} s, z = {where:.4g} m (cell {int(self.counters[2])})", t, where)
            return t
        chunk = max(1, self.STEP_CHUNK_CELL_STEPS // self.grid.n_cells)
        t, t_stop = float(t), float(t_stop)
        while True:     # in chunks of steps, so that Ctrl-C / SIGTERM are handled within about a second
            t = fv_advance_nd(self.q, t, t_stop, self.dim, self.grid.dx, self.cfl, self.c_bound,
                              law.diameter, law.m_eff, law.k1, law.k2, self.rho_tiny, self.rho_floor, self.top_fraction,
                              self._fn, self._params, self.gravity, self.counters, self.tracers, self._lo, self._box,
                              self._work(), chunk)
            if t >= t_stop or self.counters[1]:
                break
        self.steps = int(self.counters[0])
        status = int(self.counters[1])
        if status == 3:
            raise PackingError(f"more than {self.top_fraction:g} of the mass reached the top 6 cell layers of the "
                               f"domain (z >= {self.grid.z[-6] - 0.5 * self.grid.dx:.4g} m) at t = {t:.6g} s; "
                               "give a larger domain height", t)
        if status:
            msg = {1: "negative density", 2: "non-finite state"}[status]
            raise PackingError(f"{msg} at t = {t:.6g} s (flat cell index {int(self.counters[2])})", t)
        return t

    def _work(self):
        """The stage arrays of :func:`fv_advance_nd`, allocated at the first step and kept."""
        if getattr(self, "_work_arrays", None) is None:
            self._work_arrays = np.empty((5,) + self.q.shape)
        return self._work_arrays

    def observe(self):
        """(u (n, *shape) [m/s] floor frame, rho (*shape) [kg/m^n]) in the user layout."""
        q = self.q
        if self.dim == 1:
            n = self.grid.shape[0]
            r = q[pk.RHO, pk.NG:pk.NG + n].copy()
            u = np.where(r > self.rho_tiny, q[pk.MOM, pk.NG:pk.NG + n] / np.where(r > 0, r, 1.0), 0.0)
            return u[None, :], r
        r = q[RHO]
        safe = np.where(r > self.rho_tiny, r, 1.0)
        comps = [MX, MZ] if self.dim == 2 else [MX, MY, MZ]
        u = np.stack([np.where(r > self.rho_tiny, q[c] / safe, 0.0) for c in comps])
        shape = tuple(self.grid.shape)
        return u.reshape((self.dim,) + shape), r.reshape(shape).copy()


def run_packing_nd(disc, t_end, save_times, *, t_start=0.0, observers=(), progress=None):
    """Run ``disc`` through the shared controller (saves, the motion's velocity jumps);
    observers ``obs(t, u, rho)``.  Returns (t, u, rho, wall time [s]) of the saves."""
    from .controller import drive_events
    ts, us, rs = [], [], []

    def save(e):
        u, rho = disc.observe()
        for obs in observers:
            obs(e, u, rho)
        ts.append(e)
        us.append(u)
        rs.append(rho)
        if progress is not None:
            progress(e)

    wall = time.perf_counter()
    drive_events(float(t_start), float(t_end), np.asarray(save_times, float), disc.motion.jumps_between(t_start, t_end),
                 (), advance=disc.advance, apply_jump=disc.apply_velocity_jump, save=save)
    return np.array(ts), np.array(us), np.array(rs), time.perf_counter() - wall


def embedding_packing_error(dim, n_spheres=4, ppd=4, tap_start=0.005, t_end=0.07, details=False):
    """Max relative difference of ρ and u_z over the saves of a tapped column (the seed's d and
    law, one tap at ``tap_start``, flight until ``t_end``) run in 1-D (``EulerianPacking``) and
    as a horizontally uniform n-D state (3 or 3 × 3 columns, unit cross-section), both at the n-D
    CFL number; also the largest horizontal velocity (0 exactly when the embedding is exact)."""
    from ..physics.column import ColumnSetup
    from .grid_nd import GridND
    from .packing import run_packing
    from .solver import save_schedule

    cfl = 0.4 / dim
    s = ColumnSetup(kernel_name="packing", formulation="eulerian", n_spheres=n_spheres, points_per_diameter=ppd,
                    tap_start=tap_start, t_end=t_end, save_every=0.005, cfl=cfl, range_over_d=0.0)
    disc1 = s.packing_discretisation()
    saves = save_schedule(0.0, t_end, s.save_every)
    r1 = run_packing(disc1, t_end, saves)
    g1 = disc1.grid
    shape = (3, g1.n_cells) if dim == 2 else (3, 3, g1.n_cells)
    grid = GridND(shape, g1.dx, bc_lower="floor", bc_upper="vacuum", bc_horizontal="periodic")
    rho0 = np.broadcast_to(np.where(g1.x < n_spheres * s.diameter, disc1.law.close_packing_density, 0.0), shape)
    disc = EulerianPackingND(PackingLawND.from_1d(disc1.law), grid, s.motion(), s.gravity, rho0, cfl=cfl)
    ts, us, rs, wall = run_packing_nd(disc, t_end, saves)
    rho_nd = rs.reshape(len(ts), -1, g1.n_cells)
    err_rho = float(np.max(np.abs(rho_nd - r1.rho[:, None, :])) / np.max(r1.rho))
    uz = us[:, -1].reshape(len(ts), -1, g1.n_cells)
    err_u = float(np.max(np.abs(uz - r1.u[:, None, :])) / max(np.max(np.abs(r1.u)), 1e-300))
    horiz = float(np.max(np.abs(us[:, :-1])))
    err = max(err_rho, err_u)
    if not details:
        return err
    return err, {"rho_rel": err_rho, "u_rel": err_u, "horizontal_velocity_max": horiz, "steps_1d": r1.steps,
                 "steps_nd": disc.steps, "shape": list(shape), "dx": g1.dx, "wall_time_nd_s": wall}


def verify_cases() -> list:
    """``bsrflow verify`` cases ``embedding_packing_2d`` / ``_3d`` (kind 'exact')."""
    out = []
    for dim in (2, 3):
        t0 = time.perf_counter()
        err, parts = embedding_packing_error(dim, details=True)
        out.append({"name": f"embedding_packing_{dim}d", "kind": "exact", "stepper": "ssp_rk3", "filter": False,
                    "scheme": "packing_fv", "resolutions": [parts["shape"][-1]], "h": [parts["dx"]],
                    "errors": [err], "observed_order": float("nan"), "pairwise_orders": [], "details": parts,
                    "wall_time_s": time.perf_counter() - t0})
    return out
