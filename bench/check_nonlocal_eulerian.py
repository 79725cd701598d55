"""A trial, not part of the package: the nonlocal packing interaction in the Eulerian formulation.

    python bench/check_nonlocal_eulerian.py [--case d22mm_a1.0] [--ppd 5 10 20] [--cap 1.0] [--bulk 1.0]
                                            [--restitution E] [--no-dem]

The package runs the nonlocal interaction (``range_over_d`` > 0) in the Lagrangian formulation
only; this script keeps the finite-volume trial that docs/model.md reports on, so that its
numbers can be re-measured.  The scheme is the package's Eulerian one
(:mod:`bsrflow.numerics.packing_kernels`: minmod reconstruction, first order at compaction faces,
HLLE fluxes, no tension, SSP-RK3) for (ρ, ρu, ρh_1..ρh_L), h_ℓ the history of the bond of lag ℓ
whose upper end is the material at x, with the nonlocal stress in the momentum flux: virtual
points of mass m/ppd placed by the inverse of the cumulative mass carry the bonds of the
Lagrangian form, and the force their bonds transmit across a face is the face's stress.  The
HLLE wave speeds are those of the local law, capped at ``--cap`` times ω_max Δx/2 (ω_max the bond
network's bound; below about 0.5 the run goes unstable), and the time step follows them.
``--bulk`` scales the acoustic part of the wave bounds at faces inside the packed material
(both cells at 0.95 ρ_c or denser, not a compaction face): 1 is the trial (HLLE everywhere), 0 a
central flux there (upwinded at the flow speed only); the free surface keeps HLLE.
``--restitution`` overrides the case's e (1: elastic bonds, the histories play no part).

Since 2026-12-03 the package has an Eulerian form of the nonlocal interaction that keeps it (a
staggered Lagrange-remap step with a tracked free surface, :mod:`bsrflow.numerics.packing_staggered`);
its rows ("eulerian (package)") are printed beside the trial's ("eulerian FV (trial)").

For one case of ``bsrflow compare --kernel packing`` it prints, at each ``--ppd``, the top maximum
of the trial and of the package's nonlocal Lagrangian and Eulerian forms against the DEM (``--no-dem``: only the
probe below, no DEM and no run past it), and 10 ms after the tap (in aω, floor frame) the
velocities of the third sphere below the top one, of the top three spheres (the top one last)
and of the top four quarter-sphere slabs of material (top first), and the top slab's thickness in units of its packed thickness d/4: the
Lagrangian form's top slab is thrown ahead of the material below it (the dispersion of the
interaction at the free top) and stays nearly packed; the trial's top material moves with the
rest and is smeared over several times its thickness.  Writes nothing.  Takes minutes (the
trial is slow: SSP-RK3 at the acoustic time step, L history fields).
"""

from __future__ import annotations

import math
import time

import numba
import numpy as np

from bsrflow.analysis.compare import run_dem_column
from bsrflow.analysis.compare_packing import PACKING_CASES, _metrics, case_setup
from bsrflow.numerics.packing import EulerianPacking, PackingError, run_packing
from bsrflow.numerics.packing_kernels import (HIST, MOM, NG, RHO, active_top, clamped_step, compaction_face,
                                              hlle_combine, muscl_face_states, no_tension, state_failed)
from bsrflow.numerics.packing_nonlocal import nonlocal_time_step_bound
from bsrflow.physics.column import ColumnSetup, column_run_from_result
from bsrflow.physics.packing import history_update, packing_force, packing_wave_speed

from _args import Parser, float_in, int_in


# ------------------------------------------------------------------------------------------------
# The trial's compiled pieces
# ------------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def cumulative_mass(q, hi, dx, cum):
    """cum[f] = mass [kg] below face f = 0..hi+1 (cells 0..hi; negative densities count as 0).
    Returns the mass of cells 0..hi."""
    cum[0] = 0.0
    for k in range(hi + 1):
        r = q[RHO, NG + k]
        cum[k + 1] = cum[k] + (r if r > 0.0 else 0.0) * dx
    return cum[hi + 1]


@numba.njit(cache=True, inline="always")
def _position(q, cum, hi, dx, mass, k):
    """(x [m], cell) of the material at mass coordinate ``mass`` [kg] (> 0), the density uniform in
    each cell, searched up from cell k (k at most the cell sought): the inverse of the cumulative
    mass, empty cells skipped."""
    while k < hi and (cum[k + 1] < mass or q[RHO, NG + k] <= 0.0):
        k += 1
    r = q[RHO, NG + k]
    off = (mass - cum[k]) / r if r > 0.0 else dx
    return k * dx + min(max(off, 0.0), dx), k


@numba.njit(cache=True)
def nonlocal_fill_ghosts(q, hi):
    """Floor at face 0: mirror ghosts (ρ and every ρh_ℓ even, ρu odd).  Vacuum: cells hi+1 and
    hi+2 set to 0."""
    nv = q.shape[0]
    for g in range(NG):
        for v in range(nv):
            q[v, NG - 1 - g] = -q[v, NG + g] if v == MOM else q[v, NG + g]
    for k in range(hi + 1, hi + 3):
        for v in range(nv):
            q[v, NG + k] = 0.0


@numba.njit(cache=True)
def face_stress(q, hi, dx, weights, mu, n_virtual, ppd, d, k1, k2, cum, xv, kv, fsum, sig, sigf):
    """The nonlocal stress sigf[f] [N] transmitted across the faces f = 0..hi+1 (face 0 the floor).

    Virtual points i = 0..n_virtual−1 at the mass coordinates (i + ½) μ are placed by the inverse of
    the cumulative mass (xv [m], their cells kv).  Bond (ℓ, i) joins point i to point i − ℓ (the
    mirror image −xv[ℓ − 1 − i] for i < ℓ); its overlap δ = d − (ppd/ℓ)(length), its history h_ℓ of
    the cell holding point i, its force F = w_ℓ P(δ, h_ℓ).  The section between points p − 1 and p
    (mass p μ) is crossed by the bonds (ℓ, j), p ≤ j ≤ p + ℓ − 1: σ_p = Σ_ℓ Σ_j F (prefix sums
    fsum per lag); σ at a face is interpolated linearly in its mass coordinate cum[f] between the
    sections, 0 above the top point's section p = n_virtual.  Work arrays: cum (n+1), xv, kv
    (n_virtual), fsum, sig (n_virtual+1), sigf (n+1)."""
    cumulative_mass(q, hi, dx, cum)
    k = 0
    for i in range(n_virtual):
        xv[i], k = _position(q, cum, hi, dx, (i + 0.5) * mu, k)
        kv[i] = k
    for p in range(n_virtual + 1):
        sig[p] = 0.0
    for lag in range(1, weights.shape[0] + 1):
        w = weights[lag - 1]
        s = ppd / lag
        row = HIST + lag - 1
        fsum[0] = 0.0
        for j in range(n_virtual):
            i = j - lag
            length = xv[j] - xv[i] if i >= 0 else xv[j] + xv[lag - 1 - j]
            c = NG + kv[j]
            r = q[RHO, c]
            h = q[row, c] / r if r > 0.0 else 0.0
            fsum[j + 1] = fsum[j] + w * packing_force(d - s * length, h, k1, k2)
        for p in range(n_virtual + 1):
            sig[p] += fsum[min(p + lag, n_virtual)] - fsum[p]
    for f in range(hi + 2):
        a = cum[f] / mu
        p = int(a)
        if p >= n_virtual:
            sigf[f] = 0.0
        else:
            sigf[f] = sig[p] + (a - p) * (sig[p + 1] - sig[p])


@numba.njit(cache=True, inline="always")
def _capped_waves(rL, uL, hL, rR, uR, hR, d, m, k1, k2, c_cap, rho_tiny):
    """The HLLE wave bounds of the local scheme (:func:`hlle_waves`) with every sound speed capped
    at ``c_cap``, the bond network's grid-scale speed."""
    if rL <= rho_tiny:
        uL = 0.0
    if rR <= rho_tiny:
        uR = 0.0
    pL = packing_force(d - m / rL, hL, k1, k2) if rL > rho_tiny else 0.0
    pR = packing_force(d - m / rR, hR, k1, k2) if rR > rho_tiny else 0.0
    cL = min(packing_wave_speed(rL, d, m, k2), c_cap)
    cR = min(packing_wave_speed(rR, d, m, k2), c_cap)
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


@numba.njit(cache=True)
def nonlocal_fv_rhs(q, dq, hi, dx, accel, d, m, k1, k2, c_cap, rho_tiny, w, flux, sigf, bulk):
    """dq = L(q) on cells 0..hi (ghosts filled, cells hi+1, hi+2 empty, ``sigf`` the face stress of
    :func:`face_stress` for this q): the local scheme's finite volumes
    (:func:`bsrflow.numerics.packing_kernels.fv_rhs`: minmod reconstruction of the primitives
    (ρ, u, h_1..h_L), first order at compaction faces, HLLE with Einfeldt's bounds from the local
    law at the face states, the lag-1 history's) for (ρu, ρu², ρuh_ℓ), with the nonlocal stress
    σ_f in the momentum flux in place of P; no face transmits tension.  Source ρ·accel.
    ``bulk`` ∈ [0, 1] scales the wave bounds' excess over the flow speeds (S_L → β S_L + (1 − β)
    min(u_L, u_R, 0), S_R likewise) at second-order faces between two cells both at 0.95 ρ_c or
    denser: 1 is HLLE everywhere, 0 a central flux in the packed bulk (upwinded at the flow speed
    only); the free surface and compaction fronts keep HLLE.
    Work arrays: w (2+L, n+5), flux (2+L, n+1)."""
    nv = q.shape[0]
    for j in range(hi + 4):
        r = q[RHO, j]
        if r > rho_tiny:
            w[0, j] = r
            for v in range(1, nv):
                w[v, j] = q[v, j] / r
        else:
            for v in range(nv):
                w[v, j] = 0.0
    for v in range(nv):
        w[v, hi + 4] = 0.0
    for f in range(hi + 2):
        jl = f + 1
        jr = f + 2
        hs = 0.0 if compaction_face(w[0, jl], w[1, jl], w[0, jr], w[1, jr], d, m) else 0.5
        rL, rR = muscl_face_states(w, 0, jl, jr, hs)
        uL, uR = muscl_face_states(w, 1, jl, jr, hs)
        hL, hR = muscl_face_states(w, 2, jl, jr, hs)
        SL, SR, uL, uR, pL, pR = _capped_waves(rL, uL, hL, rR, uR, hR, d, m, k1, k2, c_cap, rho_tiny)
        if bulk < 1.0 and hs > 0.0 and min(w[0, jl], w[0, jr]) * d >= 0.95 * m:
            SL = bulk * SL + (1.0 - bulk) * min(uL, uR, 0.0)
            SR = bulk * SR + (1.0 - bulk) * max(uL, uR, 0.0)
        f_mass = hlle_combine(SL, SR, rL * uL, rR * uR, rL, rR)
        f_mom = hlle_combine(SL, SR, rL * uL * uL, rR * uR * uR, rL * uL, rR * uR) + sigf[f]
        flux[0, f] = f_mass
        flux[1, f] = no_tension(f_mass, f_mom, uL, uR)
        flux[2, f] = hlle_combine(SL, SR, rL * uL * hL, rR * uR * hR, rL * hL, rR * hR)
        for v in range(3, nv):
            hL, hR = muscl_face_states(w, v, jl, jr, hs)
            flux[v, f] = hlle_combine(SL, SR, rL * uL * hL, rR * uR * hR, rL * hL, rR * hR)
    inv_dx = 1.0 / dx
    for k in range(hi + 1):
        for v in range(nv):
            dq[v, k] = -(flux[v, k + 1] - flux[v, k]) * inv_dx
        dq[MOM, k] += q[RHO, NG + k] * accel
    return hi


@numba.njit(cache=True)
def nonlocal_fv_post_step(q, hi, dx, d, mu, ppd, rho_floor, cum):
    """Post-step passes on cells 0..hi: the density floor (0 ≤ ρ < ``rho_floor`` → 0 with every
    field), then the history of every bond: h_ℓ of cell k follows the overlap of the bond of lag ℓ
    (mass ℓμ) whose upper end is the cell's mass centre (at the cell centre; its lower end by the
    inverse cumulative mass, the mirror image below the floor), δ_max ← max(δ_max, δ) in contact,
    0 once the bond's overlap is ≤ 0."""
    nv = q.shape[0]
    for k in range(hi + 1):
        j = NG + k
        r = q[RHO, j]
        if 0.0 <= r < rho_floor:
            for v in range(nv):
                q[v, j] = 0.0
    cumulative_mass(q, hi, dx, cum)
    for lag in range(1, nv - 1):
        row = HIST + lag - 1
        s = ppd / lag
        ptr = 0
        for k in range(hi + 1):
            j = NG + k
            r = q[RHO, j]
            if not r > 0.0:
                continue
            lower = 0.5 * (cum[k] + cum[k + 1]) - lag * mu
            if lower > 0.0:
                xlo, ptr = _position(q, cum, hi, dx, lower, ptr)
            elif lower < 0.0:
                xlo, _ = _position(q, cum, hi, dx, -lower, 0)
                xlo = -xlo
            else:
                xlo = 0.0
            delta = d - s * ((k + 0.5) * dx - xlo)
            q[row, j] = r * history_update(delta, q[row, j] / r)


@numba.njit(cache=True)
def nonlocal_fv_advance(q, t, t_stop, dx, cfl, c_bound, d, m, k1, k2, rho_tiny, rho_floor, weights, ppd,
                        n_virtual, fn, params, gravity, counters, bulk):
    """Advance the nonlocal Eulerian state from t to exactly t_stop with SSP-RK3 steps in
    increment form, Δt = cfl Δx / (c_bound + max|u|), the post-step passes after every step, the
    vacuum skip and the monitors of :func:`bsrflow.numerics.packing_kernels.fv_advance`
    (counters: [steps, status, where, top]).  ``ppd``: virtual points per sphere (the grid's
    cells per diameter), each of mass μ = m/ppd; ``n_virtual`` = N ppd of them.
    Returns the time reached."""
    nv, npad = q.shape
    n = npad - 2 * NG
    mu = m / ppd
    q1 = q.copy()
    q2 = q.copy()
    dq = np.zeros((nv, n))
    inc1 = np.zeros((nv, n))
    inc2 = np.zeros((nv, n))
    w = np.zeros((nv, n + 2 * NG + 1))
    flux = np.zeros((nv, n + 1))
    cum = np.zeros(n + 1)
    xv = np.zeros(n_virtual)
    kv = np.zeros(n_virtual, dtype=np.int64)
    fsum = np.zeros(n_virtual + 1)
    sig = np.zeros(n_virtual + 1)
    sigf = np.zeros(n + 1)
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
        dt, last = clamped_step(t, t_stop, cfl * dx / (c_bound + umax))
        nonlocal_fill_ghosts(q, hi)
        face_stress(q, hi, dx, weights, mu, n_virtual, ppd, d, k1, k2, cum, xv, kv, fsum, sig, sigf)
        nonlocal_fv_rhs(q, dq, hi, dx, -gravity - fn(t, params)[2], d, m, k1, k2, c_bound, rho_tiny, w, flux, sigf, bulk)
        for v in range(nv):
            for k in range(hi + 1):
                inc1[v, k] = dt * dq[v, k]
                q1[v, NG + k] = q[v, NG + k] + inc1[v, k]
        nonlocal_fill_ghosts(q1, hi)
        face_stress(q1, hi, dx, weights, mu, n_virtual, ppd, d, k1, k2, cum, xv, kv, fsum, sig, sigf)
        nonlocal_fv_rhs(q1, dq, hi, dx, -gravity - fn(t + dt, params)[2], d, m, k1, k2, c_bound, rho_tiny, w, flux,
                        sigf, bulk)
        for v in range(nv):
            for k in range(hi + 1):
                inc2[v, k] = dt * dq[v, k]
                q2[v, NG + k] = q[v, NG + k] + 0.25 * (inc1[v, k] + inc2[v, k])
        nonlocal_fill_ghosts(q2, hi)
        face_stress(q2, hi, dx, weights, mu, n_virtual, ppd, d, k1, k2, cum, xv, kv, fsum, sig, sigf)
        nonlocal_fv_rhs(q2, dq, hi, dx, -gravity - fn(t + 0.5 * dt, params)[2], d, m, k1, k2, c_bound, rho_tiny, w,
                        flux, sigf, bulk)
        for v in range(nv):
            for k in range(hi + 1):
                q[v, NG + k] += (inc1[v, k] + inc2[v, k]) / 6.0 + (2.0 / 3.0) * (dt * dq[v, k])
        nonlocal_fv_post_step(q, hi, dx, d, mu, ppd, rho_floor, cum)
        t = t_stop if last else t + dt
        counters[0] += 1
        if state_failed(q, hi, counters):
            return t
        top = active_top(q, hi)
    counters[3] = top
    return t


class NonlocalEulerianTrial(EulerianPacking):
    """The trial's driver: :class:`EulerianPacking` with the state (ρ, ρu, ρh_1..ρh_L)."""

    def __init__(self, law, grid, n_spheres, motion, gravity, points_per_diameter, cfl=0.4, rho0=None, cap=1.0, bulk=1.0):
        from dataclasses import replace
        super().__init__(replace(law, range_over_d=0.0), grid, n_spheres, motion, gravity, points_per_diameter, cfl,
                         rho0)
        self.law = law
        self.weights = law.bond_weights(self.ppd)
        self.n_virtual = self.n_spheres * self.ppd
        q = np.zeros((2 + len(self.weights), self.q.shape[1]))
        q[:2] = self.q[:2]
        self.q = q
        omega = 2.0 / nonlocal_time_step_bound(self.weights, self.ppd, law.k2, law.particle_mass)
        self.c_bound = min(self.c_bound, cap * omega * grid.dx / 2.0)
        self.bulk = float(bulk)

    def advance(self, t, t_stop):
        law = self.law
        self.counters[1:] = 0
        t = nonlocal_fv_advance(self.q, float(t), float(t_stop), self.grid.dx, self.cfl, self.c_bound, law.diameter,
                                law.particle_mass, law.k1, law.k2, self.rho_tiny, self.rho_floor, self.weights,
                                float(self.ppd), self.n_virtual, self._fn, self._params, self.gravity, self.counters, self.bulk)
        self.steps = int(self.counters[0])
        if self.counters[1]:
            raise PackingError(f"trial stopped (status {int(self.counters[1])}) at t = {t:.6g} s", t)
        return t


def trial_column(setup, cap, bulk=1.0):
    law, grid = setup.packing_law(), setup.grid()
    rho0 = np.where(grid.x < setup.n_spheres * setup.diameter, law.close_packing_density, 0.0)
    return NonlocalEulerianTrial(law, grid, setup.n_spheres, setup.motion(), setup.gravity,
                                 setup.points_per_diameter, rho0=rho0, cap=cap, bulk=bulk)


def top_slabs(disc, n, m, slabs=4):
    """Velocities [m/s] of the top ``slabs`` quarter-sphere slabs of material (top first), of
    the top three spheres (the top one last) and of the third sphere below the top one, and the
    top slab's thickness [m]: by the cumulative mass and momentum of the observed fields in both
    formulations."""
    rho, u, _, _ = disc.observe()
    dx = disc.grid.dx
    faces = disc.grid.x[0] - 0.5 * dx + dx * np.arange(len(rho) + 1)
    cum = np.concatenate([[0.0], np.cumsum(rho) * dx])
    mom = np.concatenate([[0.0], np.cumsum(rho * u) * dx])
    top = n * m * (1.0 - 1e-12)
    edges = top - 0.25 * m * np.arange(slabs + 1)
    slab_v = -np.diff(np.interp(edges, cum, mom)) / (0.25 * m)
    spheres = np.concatenate([(n - np.arange(4, 0, -1)) * m, [top]])
    sphere_v = np.diff(np.interp(spheres, cum, mom)) / m
    x = np.interp(edges[:2], cum, faces)
    return slab_v, sphere_v, x[0] - x[1]


def main(argv=None):
    names = [c["name"] for c in PACKING_CASES]
    ap = Parser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", default="d22mm_a1.0", choices=names, metavar="NAME", help="one of: " + ", ".join(names))
    ap.add_argument("--ppd", type=int_in(2), nargs="+", default=[5, 10, 20], help="points per diameter (default 5 10 20)")
    ap.add_argument("--cap", type=float_in(0.0, lo_open=True), default=1.0,
                    help="cap of the HLLE wave speeds, in ω_max Δx/2 (default 1)")
    ap.add_argument("--bulk", type=float_in(0.0, 1.0), default=1.0,
                    help="dissipation in the packed bulk, 1 = HLLE (the trial), 0 = central flux (default 1)")
    ap.add_argument("--restitution", type=float_in(0.0, 1.0, lo_open=True), default=None,
                    help="override the case's e, in (0, 1]")
    ap.add_argument("--no-dem", action="store_true", help="skip the DEM and the runs after the probe")
    args = ap.parse_args(argv)
    case = next(c for c in PACKING_CASES if c["name"] == args.case)
    base = ColumnSetup(kernel_name="packing", formulation="lagrangian", range_over_d=1.0)
    s0 = case_setup(case, base, formulation="lagrangian", range_over_d=1.0)
    if args.restitution is not None:
        s0 = s0.with_(restitution=args.restitution)
    d, aw, m = s0.diameter, s0.amplitude * s0.omega, s0.particle_mass
    dem_top = None
    if not args.no_dem:
        t_d, pos, _ = run_dem_column(s0)
        dem_top = _metrics(t_d, pos[:, -1], pos.mean(axis=1), s0)["top_max_over_d"]
        print(f"{args.case} (e = {s0.restitution}): DEM top maximum {dem_top:.2f} d")
    print(f"tap + 10 ms: velocities [aw] of the third sphere below the top one ('3rd'), of the top three "
          f"spheres (the top one last) and of the top four quarter-sphere slabs (top first); the top slab's "
          f"thickness [d/4]; bulk = {args.bulk}")
    print(f"{'form':22s} {'ppd':>4s} {'top max/d':>9s} {'vs DEM':>7s}  {'3rd':>5s}  {'spheres':20s} {'slabs':27s} "
          f"{'thick':>6s} wall [s]")
    for p in args.ppd:
        s = s0.with_(points_per_diameter=p)
        for name, disc in (("lagrangian (package)", s.packing_discretisation()),
                           ("eulerian (package)", s.with_(formulation="eulerian").packing_discretisation()),
                           ("eulerian FV (trial)", trial_column(s, args.cap, args.bulk))):
            w = time.perf_counter()
            t_probe = s.tap_start + 0.01
            saves = np.round(np.arange(0.0, s.t_end + 1e-12, s.save_every), 9)
            top_txt = f"{'-':>9s} {'-':>7s}"
            try:
                first = run_packing(disc, t_probe, saves[saves <= t_probe])
                v, vs, thick = top_slabs(disc, s.n_spheres, m)
                if dem_top is not None:
                    rest = run_packing(disc, s.t_end, saves[saves > t_probe], t_start=t_probe)
                    res = first
                    for k in ("t", "rho", "u", "tracers", "floor"):
                        setattr(res, k, np.concatenate([getattr(first, k), getattr(rest, k)]))
                    run = column_run_from_result(s, disc.grid, res)
                    top = _metrics(run.t, run.top, run.mass_centre, s)["top_max_over_d"]
                    top_txt = f"{top:9.2f} {top / dem_top - 1:+7.1%}"
            except PackingError as err:
                print(f"{name:22s} {p:4d} stopped: {err}", flush=True)
                continue
            print(f"{name:22s} {p:4d} {top_txt}  {vs[0] / aw:5.3f}  {' '.join(f'{x / aw:.3f}' for x in vs[1:]):20s} "
                  f"{' '.join(f'{x / aw:.3f}' for x in v):27s} {thick / (0.25 * d):6.2f} {time.perf_counter() - w:8.1f}",
                  flush=True)


if __name__ == "__main__":
    main()
