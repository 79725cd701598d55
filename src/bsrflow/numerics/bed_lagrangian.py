"""Lagrangian cells for the vibrated bed of :mod:`bsrflow.physics.granular_bed` (issue #19).

The horizontally uniform bed is a column of ``n`` cells of equal mass per area μ = (N m/A)/n
[kg/m²], between faces z_0 ≤ z_1 ≤ … ≤ z_n [m] (floor frame) that move with the material
(ż_f = v_f): the density by characteristics, φ_j = μ/(ρ_s (z_{j+1} − z_j)) (seed (3.10)–(3.12)
in mass coordinates).  Staggered: v on the faces, φ, θ and δ_max in the cells.

One step of length Δt (``bed_step``; symplectic Euler for the faces, then the energy):

1. the cells' stresses σ_j = p_j + q_j + σ_c,j at the current state (module
   :mod:`~bsrflow.physics.granular_bed`; q_j from the current face velocities);
2. interior faces and the top face: v_f += Δt ((σ_{f−1} − σ_f)/m_f − g_l(t)), σ_n = 0 above the top,
   m_f the mass per area of the half cells beside the face; g_l = g + ϑ''(t);
3. the bottom face (the bed's bottom on the floor): held (v_0 = 0, z_0 = 0) while the floor's
   reaction R = σ_0 + m_0 g_l is ≥ 0, free otherwise (the floor cannot pull); a free bottom that
   reaches the floor stops there;
4. z_f += Δt v_f;
5. θ_j += −(p_j + q_j)(v_{j+1} − v_j) Δt / (3μ/2) (compression work; the contact stress is
   elastic, its hysteresis loss leaves the bed), then the conduction fluxes
   H_f = −κ_f (θ_f − θ_{f−1}) / ((s_{f−1} + s_f)/2) between cells (none at the top; at the
   floor the wall loss while the floor pushes; with ``floor_loss = "floor_reaction"`` its
   θ̇ = −aθ^½ integrated exactly over the step, as the flux of the energy it removes), θ ≥ 0,
   then the collisional loss integrated
   exactly over the step (θ̇ = −A θ^{3/2}: θ ← θ / (1 + A Δt √θ / 2)²), then the history pass
   δ_max ← max(δ_max, δ) (0 where δ ≤ 0).

Mass is exact (fixed μ per cell).  Time step, per step: each step's Δt is the bound its
previous step returned (the first from :func:`stable_dt`), the smallest over the cells of
cfl · s_j/c, with c the contact wave speed at close packing (the fastest signal: the kinetic sound
speed, ~√θ, is two orders below it), and half the explicit limits of the viscous stress,
μ s_j/(2ζ_j) with ζ = λ + 4μ_s/3, and of the conduction, (3μ/2)/(κ_f/h_f + κ_f+1/h_f+1) over
the cell's two faces (h_f the distance of the cell centres across face f), so a state whose
viscosity or conductivity grows fast (a denser bed, a larger contact value g0) shortens the step
at once.  (Before 2026-12-03 the bound was set once per save, every 10⁻⁴ s, from the smallest
cell and the largest coefficients, with the same two halves; a one-off run with a larger g0
outran it.)

:func:`bed_step_numpy` is the plain NumPy twin of :func:`bed_step` (tests: agreement to 1e-12).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..physics.granular_bed import (conductivity, constitutive_numpy, dissipation, pressure_and_viscosity,
                                    wall_loss)
from ..physics.packing import history_update, packing_force, packing_force_numpy
from .controller import restore_named_fields
from .grid import spread_over_bins

__all__ = ["GranularBedColumn", "bed_step", "bed_advance", "stable_dt", "bed_step_numpy", "floor_reaction", "static_bed", "run_bed",
           "BedResult"]


@numba.njit(cache=True, error_model="numpy")
def bed_step(zf, vf, th, hist, sig, pq, flux, cond, dt, gl, mu, rho_s, d, e, phi_c, k1, k2, cfl, c, e_d, e_w,
             wall_mode):
    """One step (module docstring), in place; ``sig``, ``pq`` (n), ``flux``, ``cond`` (n + 1) are
    work arrays (``cond`` holds ζ_j/s_j until the conduction overwrites it); e_d the restitution of
    the spheres' collisional loss (:attr:`BedSetup.dissipation_restitution`, e without friction),
    e_w the floor's (:attr:`BedSetup.floor_dissipation_restitution`: e_d unless the floor's
    restitution is given); wall_mode the floor loss's closure (:attr:`BedSetup.floor_loss_mode`:
    0 the kinetic pressure's, :func:`wall_loss`; 1 the whole reaction's,
    :func:`wall_loss_from_reaction`).  Returns (floor reaction R
    [Pa], status, Δt bound [s]); status 1: a cell's
    thickness reached 0.  The bound, the next step's Δt, is the smallest over the cells of the
    contact wave's cfl s_j/c and half the explicit limits of the viscous stress, μ s_j/(2ζ_j),
    and of the conduction, (3μ/2)/(κ_f/h_f + κ_f+1/h_f+1) over the cell's two faces (h the
    distance of the cell centres), with ζ and κ as this step used them.

    Each cell loop is elementwise, the minima and maxima and the thickness check in loops of their
    own, and divisions follow IEEE (``error_model="numpy"``: no zero-division branch; the cells'
    thicknesses are checked > 0 at the end of every step), so that the compiler vectorises the
    loops: the results are those of the scalar loops bit for bit, about 4× faster (2026-12-04,
    this 2-core VM; ``python bench/ab_bed_step.py``)."""
    n = th.shape[0]
    for j in range(n):
        s = zf[j + 1] - zf[j]
        phi = mu / (rho_s * s)
        p, zeta = pressure_and_viscosity(phi, th[j], rho_s, d, e)
        zs = zeta / s
        q = -zs * (vf[j + 1] - vf[j])
        pq[j] = p + q
        sig[j] = p + q + packing_force(d * (1.0 - phi_c / phi), hist[j], k1, k2)
        cond[j] = zs
    s_min = 1e300
    zeta_s_max = 0.0          # max ζ_j/s_j
    for j in range(n):
        s_min = min(s_min, zf[j + 1] - zf[j])
        zeta_s_max = max(zeta_s_max, cond[j])
    m_half = 0.5 * mu
    for f in range(1, n):
        vf[f] += dt * ((sig[f - 1] - sig[f]) / mu - gl)
    vf[n] += dt * (sig[n - 1] / m_half - gl)
    reaction = 0.0
    if zf[0] <= 0.0 and vf[0] <= 0.0 and sig[0] + m_half * gl >= 0.0:
        reaction = sig[0] + m_half * gl
        vf[0] = 0.0
        zf[0] = 0.0
    else:
        vf[0] += dt * (-sig[0] / m_half - gl)
    for f in range(n + 1):
        zf[f] += dt * vf[f]
    if zf[0] < 0.0:
        zf[0] = 0.0
        if vf[0] < 0.0:
            vf[0] = 0.0
    bound = cfl * s_min / c
    if zeta_s_max > 0.0:
        bound = min(bound, 0.25 * mu / zeta_s_max)            # half of μ s/(2ζ)
    for j in range(n):
        if not zf[j + 1] - zf[j] > 0.0:
            return reaction, 1, bound
    for j in range(n):
        th[j] += -pq[j] * (vf[j + 1] - vf[j]) * dt / (1.5 * mu)
    flux[0] = 0.0
    cond[0] = 0.0
    if reaction > 0.0:
        if wall_mode == 1:
            # 1.5μ θ̇ = −wall_loss_from_reaction = −(1 − e_w) R √(2/π) √θ, i.e. θ̇ = −a√θ, over the
            # step exactly, √θ ← (√θ − aΔt/2)₊ (a flux that cannot empty the cell by itself),
            # passed as the flux of the energy it removes
            t0 = max(th[0], 0.0)
            r0 = math.sqrt(t0) - 0.5 * dt * ((1.0 - e_w) * reaction * math.sqrt(2.0 / math.pi)) / (1.5 * mu)
            flux[0] = -1.5 * mu * (t0 - (r0 * r0 if r0 > 0.0 else 0.0)) / dt
        else:
            flux[0] = -wall_loss(mu / (rho_s * (zf[1] - zf[0])), th[0], rho_s, e, e_w)
    flux[n] = 0.0
    cond[n] = 0.0
    for f in range(1, n):
        sa = zf[f] - zf[f - 1]
        sb = zf[f + 1] - zf[f]
        phi = 0.5 * (mu / (rho_s * sa) + mu / (rho_s * sb))
        t = 0.5 * (max(th[f - 1], 0.0) + max(th[f], 0.0))
        cond[f] = conductivity(phi, t, rho_s, d, e) / (0.5 * (sa + sb))      # κ_f / h_f
        flux[f] = -cond[f] * (th[f] - th[f - 1])
    g_max = 0.0
    for j in range(n):
        g_max = max(g_max, cond[j] + cond[j + 1])
    for j in range(n):
        t = th[j] + dt * (flux[j] - flux[j + 1]) / (1.5 * mu)
        if t < 0.0:
            t = 0.0
        s = zf[j + 1] - zf[j]
        phi = mu / (rho_s * s)
        a = dissipation(phi, 1.0, rho_s, d, e_d) * s / (1.5 * mu)   # γ s/(3μ/2) = a θ^{3/2}
        th[j] = t / (1.0 + 0.5 * a * dt * math.sqrt(t)) ** 2
        hist[j] = history_update(d * (1.0 - phi_c / phi), hist[j])
    if g_max > 0.0:
        bound = min(bound, 0.5 * 1.5 * mu / g_max)    # half of (3μ/2)/(κ_f/h_f + κ_f+1/h_f+1)
    return reaction, 0, bound


@numba.njit(cache=True)
def floor_reaction(zf, vf, th, hist, mu, rho_s, d, e, phi_c, k1, k2, gl):
    """The floor's reaction R [Pa] the next step would find (0 when the bottom is free)."""
    if not (zf[0] <= 0.0 and vf[0] <= 0.0):
        return 0.0
    s = zf[1] - zf[0]
    phi = mu / (rho_s * s)
    p, zeta = pressure_and_viscosity(phi, th[0], rho_s, d, e)
    sig0 = p - zeta * (vf[1] - vf[0]) / s + packing_force(d * (1.0 - phi_c / phi), hist[0], k1, k2)
    r = sig0 + 0.5 * mu * gl
    return r if r > 0.0 else 0.0


@numba.njit(cache=True)
def stable_dt(zf, th, mu, rho_s, d, e, cfl, c):
    """The bound of :func:`bed_step` [s] at the state (zf, θ): the smallest over the cells of
    cfl s_j/c, μ s_j/(4ζ_j) and (3/4) μ/(κ_f/h_f + κ_f+1/h_f+1) (ζ at no velocity gradient, κ
    at the faces)."""
    n = th.shape[0]
    bound = 1e300
    g_lo = 0.0
    for j in range(n):
        s = zf[j + 1] - zf[j]
        phi = mu / (rho_s * s)
        p, zeta = pressure_and_viscosity(phi, th[j], rho_s, d, e)
        b = cfl * s / c
        if zeta > 0.0:
            b = min(b, 0.25 * mu * s / zeta)
        g_hi = 0.0
        if j + 1 < n:
            sb = zf[j + 2] - zf[j + 1]
            phf = 0.5 * (phi + mu / (rho_s * sb))
            t = 0.5 * (max(th[j], 0.0) + max(th[j + 1], 0.0))
            g_hi = conductivity(phf, t, rho_s, d, e) / (0.5 * (s + sb))
        if g_lo + g_hi > 0.0:
            b = min(b, 0.5 * 1.5 * mu / (g_lo + g_hi))
        bound = min(bound, b)
        g_lo = g_hi
    return bound


@numba.njit(cache=True, error_model="numpy")
def bed_advance(zf, vf, th, hist, t, t_stop, dt_next, mu, rho_s, d, e, phi_c, k1, k2, g, amp, w, moving,
                counters, cfl, c, e_d, e_w, wall_mode, max_steps):
    """Steps from t towards t_stop, each with the bound its previous step returned
    (``dt_next[0]``: in, the first step's; out, the bound after the last step), at most
    ``max_steps`` of them (the caller calls again until t = t_stop: the same steps as one call,
    and Ctrl-C / SIGTERM handled in between); the floor ϑ = a sin ωt when ``moving``
    (g_l = g − a ω² sin ωt), at rest otherwise.  counters: [steps, status]; returns (t, last
    floor reaction [Pa]).  e_d, e_w: the spheres' and the floor's loss restitutions, wall_mode the
    floor loss's closure (:func:`bed_step`)."""
    n = th.shape[0]
    sig = np.empty(n)
    pq = np.empty(n)
    flux = np.empty(n + 1)
    cond = np.empty(n + 1)
    reaction = 0.0
    taken = 0
    while t < t_stop and taken < max_steps:
        taken += 1
        dt = dt_next[0]
        last = False
        if t + dt >= t_stop:
            dt = t_stop - t
            last = True
        gl = g - amp * w * w * math.sin(w * t) if moving else g
        reaction, status, bound = bed_step(zf, vf, th, hist, sig, pq, flux, cond, dt, gl, mu, rho_s, d, e, phi_c,
                                           k1, k2, cfl, c, e_d, e_w, wall_mode)
        dt_next[0] = bound
        counters[0] += 1
        t = t_stop if last else t + dt
        if status != 0:
            counters[1] = status
            return t, reaction
    return t, reaction


def bed_step_numpy(zf, vf, th, hist, dt, gl, mu, rho_s, d, e, phi_c, k1, k2, e_d=None, e_w=None,
                   floor_loss="kinetic_pressure"):
    """Plain NumPy twin of :func:`bed_step` (copies; returns (zf, vf, th, hist, reaction));
    ``e_d`` the losses' restitution (None: e), ``e_w`` the floor's (None: e_d), ``floor_loss``
    the floor loss's closure (:attr:`BedSetup.floor_loss`)."""
    e_d = e if e_d is None else e_d
    e_w = e_d if e_w is None else e_w
    zf, vf, th, hist = (np.array(a, dtype=float) for a in (zf, vf, th, hist))
    n = th.size
    s = np.diff(zf)
    phi = mu / (rho_s * s)
    c = constitutive_numpy(phi, th, rho_s, d, e)
    q = -(c["lambda"] + (4.0 / 3.0) * c["mu"]) * np.diff(vf) / s
    pq = c["p"] + q
    sig = pq + packing_force_numpy(d * (1.0 - phi_c / phi), hist, k1, k2)
    vf[1:n] += dt * ((sig[:-1] - sig[1:]) / mu - gl)
    vf[n] += dt * (sig[-1] / (0.5 * mu) - gl)
    reaction = 0.0
    if zf[0] <= 0.0 and vf[0] <= 0.0 and sig[0] + 0.5 * mu * gl >= 0.0:
        reaction = sig[0] + 0.5 * mu * gl
        vf[0] = 0.0
        zf[0] = 0.0
    else:
        vf[0] += dt * (-sig[0] / (0.5 * mu) - gl)
    zf += dt * vf
    if zf[0] < 0.0:
        zf[0] = 0.0
        vf[0] = max(vf[0], 0.0)
    s = np.diff(zf)
    th = th - pq * np.diff(vf) * dt / (1.5 * mu)
    flux = np.zeros(n + 1)
    phi_new = mu / (rho_s * s)
    if reaction > 0.0:
        t0 = max(th[0], 0.0)
        p0 = phi_new[0]
        p_kin = constitutive_numpy(p0, t0, rho_s, d, e)["p"]
        if floor_loss == "floor_reaction":      # integrated exactly over the step (bed_step)
            r0 = np.sqrt(t0) - 0.5 * dt * (1.0 - e_w) * reaction * np.sqrt(2.0 / np.pi) / (1.5 * mu)
            flux[0] = -1.5 * mu * (t0 - max(r0, 0.0) ** 2) / dt
        else:
            flux[0] = -(1.0 - e_w) * p_kin * np.sqrt(2.0 * t0 / np.pi)
    phi_f = 0.5 * (phi_new[:-1] + phi_new[1:])
    t_f = 0.5 * (np.maximum(th[:-1], 0.0) + np.maximum(th[1:], 0.0))
    flux[1:n] = -constitutive_numpy(phi_f, t_f, rho_s, d, e)["kappa"] * np.diff(th) / (0.5 * (s[:-1] + s[1:]))
    t = np.maximum(th + dt * (flux[:-1] - flux[1:]) / (1.5 * mu), 0.0)
    a = constitutive_numpy(phi_new, np.ones(n), rho_s, d, e_d)["gamma"] * s / (1.5 * mu)
    th = t / (1.0 + 0.5 * a * dt * np.sqrt(t)) ** 2
    delta = d * (1.0 - phi_c / phi_new)
    hist = np.where(delta > 0.0, np.maximum(hist, delta), 0.0)
    return zf, vf, th, hist, reaction


# ------------------------------------------------------------------------------------------------
# the driver
# ------------------------------------------------------------------------------------------------
from dataclasses import dataclass, field  # noqa: E402


@dataclass
class BedResult:
    """Output of :func:`run_bed` (SI units, floor frame unless said; t = 0 when the floor starts).

    t [s] save times; mass_centre [m] height of the mass centre above the floor; top [m] height
    below which 99 % of the mass lies (close to, not the same as, the reference's 'top99', the
    99th percentile of the sphere centres: a centre lies up to d/2 below its sphere's top); floor_force
    [N] the floor's reaction on the bed (area × R); floor [m] ϑ(t) (lab); profiles: {phase name:
    (z [m], φ)} the continuum's solid fraction convolved with a Gaussian of σ = d/2 (the
    reference smooths point volumes at the sphere centres with the same kernel),
    averaged over the cycles from 3 on at the floor phases ωt = 0, π/2, π, 3π/2; steps, wall_time
    [s] (the compiled loop and the bookkeeping, compilation excluded), status; theta_mean [m²/s²]
    the bed's mass-mean granular temperature at every save; theta_profiles: {phase name: (z [m],
    θ_z, θ_h)} [m²/s²] coarse-grained as the reference's temperature_profiles.csv (at the same
    phases and cycles as ``profiles``): θ_h = Σ CG(φθ) / Σ CG(φ), θ_z = Σ [CG(φ(θ + u²)) −
    CG(φu)²/CG(φ)] / Σ CG(φ) over the frames (u the cells' mean velocity; the velocity's variation
    inside a cell left out), so that the continuum's isotropic θ meets the reference's vertical
    and horizontal fluctuations through the same coarse graining; internal_energy [J] at every
    save: Σ m_j [(3/2)θ_j + (u_j − ū)²/2] over the cells (thermal plus the mean flow relative to
    the mass centre, the reference's E_int = Σ m|v − v_cm|²/2)."""

    t: np.ndarray
    mass_centre: np.ndarray
    top: np.ndarray
    floor_force: np.ndarray
    floor: np.ndarray
    profiles: dict
    steps: int
    wall_time: float
    status: str = "ok"
    info: dict = field(default_factory=dict)
    theta_mean: np.ndarray = None
    theta_profiles: dict = field(default_factory=dict)
    internal_energy: np.ndarray = None


PHASES = {"phase0": 0.0, "phase_pi2": 0.25, "phase_pi": 0.5, "phase_3pi2": 0.75}
"""Floor phases of the solid-fraction profiles (fraction of a cycle), as in the reference."""


def coarse_graining_weights(zf, z, sigma):
    """W[k, j] = ∫_{zf_j}^{zf_{j+1}} G_σ(z_k − z') dz' (exact), so that W @ f is the Gaussian
    coarse graining at the heights z of a field f constant in each cell [zf_j, zf_{j+1}]."""
    from scipy.special import erf
    e = erf((zf[None, :] - z[:, None]) / (math.sqrt(2.0) * sigma))
    return 0.5 * (e[:, 1:] - e[:, :-1])


def coarse_grained_fraction(zf, phi, z, sigma):
    """∫ φ(z') G_σ(z − z') dz' of the piecewise-constant φ on the cells [zf_j, zf_{j+1}] (exact)."""
    return coarse_graining_weights(zf, z, sigma) @ phi


def coarse_grained_temperature(zf, phi, theta, u, z, sigma):
    """The kinetic moments of the cells [zf_j, zf_{j+1}] (solid fraction φ, granular temperature θ
    [m²/s²], velocity u [m/s], each constant in a cell) coarse-grained with a Gaussian of σ [m] at
    the heights z [m], as the reference does with the spheres (reference/liggghts_bed,
    ``cg_temperature``): (n, nθ_z, nθ_h) with n = CG(φ), nθ_h = CG(φθ) and nθ_z = CG(φ(θ + u²)) −
    CG(φu)²/CG(φ) ≥ 0 (the vertical fluctuation about the coarse-grained mean velocity: θ is
    isotropic, the mean flow vertical)."""
    w = coarse_graining_weights(zf, z, sigma)
    n, nth_h, p, q = w @ phi, w @ (phi * theta), w @ (phi * u), w @ (phi * (theta + u * u))
    nth_z = np.maximum(q - p * p / np.where(n > 0.0, n, 1.0), 0.0)
    return n, nth_z, nth_h


def _compile_bed():
    """Compile the loop once on a tiny bed (so that ``wall_time`` is the run's own)."""
    zf = np.arange(5) * 1e-3
    c = np.zeros(2, dtype=np.int64)
    bed_advance(zf, np.zeros(5), np.zeros(4), np.zeros(4), 0.0, 1e-6, np.array([stable_dt(
        zf, np.zeros(4), 1.0, 1000.0, 1e-3, 0.9, 0.4, 10.0)]), 1.0, 1000.0, 1e-3, 0.9, 0.6, 1.0, 1.0, 9.81, 0.0, 1.0,
        False, c, 0.4, 10.0, 0.9, 0.9, 0, 10)


def static_bed(setup):
    """The bed at rest on the resting floor (faces [m], δ_max [m] per cell): cell j carries the
    weight above its middle, σ_j = (n − j − ½) μ g, on the packing law's loading branch
    (δ_j = σ_j/K1, δ_max = δ), so φ_j = φ_c/(1 − δ_j/d); the kinetic pressure of θ_seed is
    neglected (it is ~1e-9 of the stress).  The floor then carries the whole weight."""
    s = setup
    n = s.n_cells
    mu = s.mass_per_area / n
    k1 = s.layer_stiffness / s.area
    sigma = (n - np.arange(n) - 0.5) * mu * s.gravity
    delta = sigma / k1
    phi = s.phi_c / (1.0 - delta / s.diameter)
    zf = np.concatenate([[0.0], np.cumsum(mu / (s.density * phi))])
    return zf, delta.copy()


class GranularBedColumn:
    """The horizontally uniform bed of :class:`bsrflow.physics.granular_bed.BedSetup` as a
    discretisation of the run driver (the interface of the packing discretisations: ``advance``,
    ``apply_velocity_jump``, ``observe``, named ``fields``, ``load_fields``, ``counters``), so that
    ``bsrflow run`` (``kind = "granular_bed"``), its output, checkpoints and ``--resume`` serve it
    as every other run, and :func:`run_bed` (``bsrflow compare-bed``) steps the same object.

    State: the faces' heights ``zf`` [m] and velocities ``vf`` [m/s] (floor frame), the cells'
    θ [m²/s²] and δ_max [m], the next step's Δt bound [s] (:func:`bed_step`).  Built at t = 0:
    the bed at rest (:func:`static_bed`, θ = θ_seed), then (unless ``settle`` is False: a run
    that restores a checkpoint, or that calls :meth:`settle` later) ``setup.settle`` s on the
    resting floor (before t = 0).  The floor is ϑ = a sin ωt from t = 0 (:attr:`motion`: its velocity
    jumps by aω at t = 0, which the controller applies as ``apply_velocity_jump``).

    ``grid`` is the fixed output column (:meth:`observe`): bins of d/10 from the floor to
    ``setup.output_top`` [m], each holding the mass of the cells overlapping it, as a line density
    ρ_s φ A [kg/m] (the mass per metre of height of the whole bed, as a 1-D column's ρ), and the
    mass-weighted velocity [m/s].  A bed whose top passes the output grid's top stops the run
    (:class:`bsrflow.numerics.solver.SimulationError`, naming ``output_height``)."""

    name = "granular_bed"

    def __init__(self, setup, settle=True):
        from ..physics.motion import SinusoidalVibration
        s = self.setup = setup
        n = s.n_cells
        self.mu = s.mass_per_area / n
        self.k1 = s.layer_stiffness / s.area
        self.k2 = self.k1 / s.restitution ** 2
        self.c = s.contact_wave_speed()
        self.zf, self.hist = static_bed(s)
        self.vf = np.zeros(n + 1)
        self.th = np.full(n, float(s.theta_seed))
        self.counters = np.zeros(2, dtype=np.int64)
        self.steps = 0
        self.t = 0.0
        self.motion = SinusoidalVibration(s.amplitude, s.frequency, start=0.0)
        self._grid = None
        self._args = (self.mu, s.density, s.diameter, s.restitution, s.phi_c, self.k1, self.k2, s.gravity,
                      s.amplitude, s.omega)
        self.dt_next = np.array([stable_dt(self.zf, self.th, self.mu, s.density, s.diameter, s.restitution, s.cfl,
                                           self.c)])
        if settle:
            self.settle()

    def settle(self):
        """``setup.settle`` s on the resting floor, from t = −settle to 0 (in steps of at most 1 ms)."""
        s = self.setup
        if s.settle > 0.0:
            t_set = -float(s.settle)
            k_set = max(1, int(math.ceil(s.settle / 1e-3)))
            for k in range(k_set):
                self._advance(t_set + k * s.settle / k_set, t_set + (k + 1) * s.settle / k_set, False)

    @property
    def grid(self):
        """The output column (class docstring; :meth:`BedSetup.grid`), built on first use."""
        if self._grid is None:
            self._grid = self.setup.grid()
        return self._grid

    STEP_CHUNK_CELL_STEPS = 1 << 22
    """Cell-steps per compiled call (about 0.05 s): Ctrl-C and SIGTERM are handled between calls."""

    def _advance(self, t0, t1, moving):
        from .solver import SimulationError
        chunk = max(1, self.STEP_CHUNK_CELL_STEPS // self.setup.n_cells)
        t, t1 = float(t0), float(t1)
        while True:
            t, _ = bed_advance(self.zf, self.vf, self.th, self.hist, t, t1, self.dt_next, *self._args, moving,
                               self.counters, self.setup.cfl, self.c, self.setup.dissipation_restitution,
                               self.setup.floor_dissipation_restitution, self.setup.floor_loss_mode, chunk)
            if t >= t1 or self.counters[1]:
                break
        self.steps = int(self.counters[0])
        self.t = t
        if self.counters[1]:
            raise SimulationError(f"bed run stopped at t = {t:.6g} s: a cell's thickness reached 0 "
                                  f"({int(self.counters[0])} steps)", None, t, None, "stopped")

    def advance(self, t0, t1):
        """Steps from t0 to exactly t1 [s] (the floor moving; a no-op when t1 = t0)."""
        from .solver import SimulationError
        self._advance(t0, t1, True)
        top = self.grid.upper[-1]
        if self.zf[-1] > top:
            raise SimulationError(f"bed run stopped at t = {t1:.6g} s: the bed's top ({self.zf[-1]:.4g} m) passed "
                                  f"the output grid's top ({top:.4g} m); raise output_height", None, t1, None,
                                  "stopped")

    def apply_velocity_jump(self, dv):
        """The floor's velocity jumps by dv [m/s]: the bed's, relative to it, by −dv."""
        self.vf -= dv

    def tracer_positions(self):
        """None: the bed carries no tracers (its cells' faces are its material lines)."""
        return None

    def floor_force(self, t) -> float:
        """The floor's reaction on the bed [N] (area × R) at time t [s] (ϑ'' of the floor at t)."""
        s = self.setup
        gl = s.gravity - s.amplitude * s.omega ** 2 * math.sin(s.omega * t) if t >= 0.0 else s.gravity
        return floor_reaction(self.zf, self.vf, self.th, self.hist, self.mu, s.density, s.diameter, s.restitution,
                              s.phi_c, self.k1, self.k2, gl) * s.area

    def observe(self):
        """(u (1, nz) [m/s], ρ (nz) [kg/m]) on the output grid (class docstring)."""
        s = self.setup
        edges = self.grid.lower[-1] + self.grid.dx * np.arange(self.grid.shape[0] + 1)
        cell_mass = np.full(self.zf.size - 1, self.mu * s.area)                  # [kg]
        vc = 0.5 * (self.vf[1:] + self.vf[:-1])
        m_bin, mom = spread_over_bins(self.zf, edges, cell_mass, cell_mass * vc)
        u = np.where(m_bin > 0.0, mom / np.where(m_bin > 0.0, m_bin, 1.0), 0.0)
        return u[None, :], m_bin / self.grid.dx

    @property
    def fields(self) -> dict:
        """The named state (checkpoints): ``face_height`` [m], ``face_velocity`` [m/s] (n + 1),
        ``theta`` [m²/s²], ``delta_max`` [m] (n), ``dt_next`` [s] (1)."""
        return {"face_height": self.zf, "face_velocity": self.vf, "theta": self.th, "delta_max": self.hist,
                "dt_next": self.dt_next}

    def load_fields(self, fields):
        """Restore :attr:`fields` (ValueError naming the first that is missing or of another shape)."""
        restore_named_fields(self.fields, fields)

    def state_problem(self) -> str | None:
        """What makes the state one that no run reaches (a checkpoint edited or damaged by hand),
        in words, or None: the faces must rise from the floor (z_0 ≥ 0, each above the last), θ ≥ 0,
        δ_max ≥ 0 and the next step Δt > 0."""
        dz = np.diff(self.zf)
        if self.zf[0] < 0.0 or np.any(dz <= 0.0):
            k = int(np.argmax(dz <= 0.0)) + 1 if np.any(dz <= 0.0) else 0
            return f"face_height: face {k} at {self.zf[k]:.6g} m is not above the one below it (or the floor)"
        for name, arr in (("theta", self.th), ("delta_max", self.hist)):
            if np.any(arr < 0.0):
                k = int(np.argmax(arr < 0.0))
                return f"{name}: cell {k} holds {arr[k]:.6g}, outside the valid range [0, inf)"
        if not self.dt_next[0] > 0.0:
            return f"dt_next = {self.dt_next[0]:.6g} s, outside the valid range (0, inf) s"
        return None

    def output_schema(self) -> dict:
        """The state written with every snapshot (``state_<name>`` in the file): the cells and faces
        of the Lagrangian state, θ included, and the floor's force."""
        return {"face_height": (("face",), "m", "height of the Lagrangian cells' faces above the floor"),
                "face_velocity": (("face",), "m s-1", "velocity of the faces relative to the floor"),
                "solid_fraction": (("cell",), "1", "solid fraction phi of the Lagrangian cells"),
                "theta": (("cell",), "m2 s-2", "granular temperature theta = <C^2>/3 of the cells"),
                "delta_max": (("cell",), "m", "largest overlap per contact reached (the packing law's history)"),
                "floor_force": ((), "N", "the floor's force on the bed")}

    def output_fields(self) -> dict:
        """The fields of :meth:`output_schema` now (at time :attr:`t` [s], the end of the last advance)."""
        return {"face_height": self.zf, "face_velocity": self.vf,
                "solid_fraction": self.mu / (self.setup.density * np.diff(self.zf)), "theta": self.th,
                "delta_max": self.hist, "floor_force": np.float64(self.floor_force(self.t))}


def run_bed(setup, progress=None) -> BedResult:
    """Run the bed of ``setup`` (:class:`bsrflow.physics.granular_bed.BedSetup`) on a
    :class:`GranularBedColumn`: from the bed at rest, optionally ``setup.settle`` s more on the
    resting floor, then vibrate for ``setup.cycles`` cycles from t = 0 (the floor's velocity
    jumps to aω: the bed's velocity relative to the floor by −aω).  ``progress(t)`` is called at
    every save.  A cell collapsing stops the run with :class:`bsrflow.numerics.solver.SimulationError`."""
    import time

    s = setup
    _compile_bed()
    wall = time.perf_counter()
    bed = GranularBedColumn(s)
    n, mu = s.n_cells, bed.mu
    zf = bed.zf
    bed.apply_velocity_jump(s.amplitude * s.omega)
    n_save = int(round(s.t_end / s.save_every))
    ts = np.arange(n_save + 1) * s.save_every
    com = np.empty(n_save + 1)
    top = np.empty(n_save + 1)
    force = np.empty(n_save + 1)
    cum_frac = (np.arange(n + 1)) / n
    prof_z = np.arange(-1.0, 30.0 + 1e-9, 0.1) * s.diameter
    prof_sum = {k: np.zeros_like(prof_z) for k in PHASES}
    prof_n = dict.fromkeys(PHASES, 0)
    th_sum = {k: [np.zeros_like(prof_z) for _ in range(2)] for k in PHASES}   # Σ nθ_z, Σ nθ_h
    th_mean = np.empty(n_save + 1)
    e_int = np.empty(n_save + 1)
    th = bed.th
    m_cell = mu * s.area
    period = s.period
    phase_idx = {}
    for name, frac in PHASES.items():
        for cyc in range(3, s.cycles):
            phase_idx[int(round((cyc + frac) * period / s.save_every))] = name

    def record(i):
        zc = 0.5 * (zf[1:] + zf[:-1])
        com[i] = float(np.mean(zc))
        top[i] = float(np.interp(0.99, cum_frac, zf))
        force[i] = bed.floor_force(ts[i])
        th_mean[i] = float(np.mean(th))           # cells of equal mass: the mass mean
        vc = 0.5 * (bed.vf[1:] + bed.vf[:-1])
        e_int[i] = m_cell * float(np.sum(1.5 * th + 0.5 * (vc - np.mean(vc)) ** 2))
        if i in phase_idx:
            name = phase_idx[i]
            phi = mu / (s.density * np.diff(zf))
            moments = coarse_grained_temperature(zf, phi, th, vc, prof_z, 0.5 * s.diameter)
            prof_sum[name] += moments[0]
            prof_n[name] += 1
            th_sum[name][0] += moments[1]
            th_sum[name][1] += moments[2]
        if progress is not None:
            progress(ts[i])

    record(0)
    for i in range(1, n_save + 1):
        bed._advance(ts[i - 1], ts[i], True)
        record(i)
    wall = time.perf_counter() - wall
    profiles = {k: (prof_z, prof_sum[k] / max(prof_n[k], 1)) for k in PHASES}
    theta_profiles = {}
    for k, (nz, nh) in th_sum.items():
        nsum = prof_sum[k]
        has = nsum > 0.0
        safe = np.where(has, nsum, 1.0)
        theta_profiles[k] = (prof_z, np.where(has, nz / safe, np.nan), np.where(has, nh / safe, np.nan))
    floor = s.amplitude * np.sin(s.omega * ts)
    return BedResult(ts, com, top, force, floor, profiles, int(bed.counters[0]), wall,
                     info={"n_cells": n, "layer_stiffness_N_m": s.layer_stiffness,
                           "contact_wave_speed_m_s": bed.c}, theta_mean=th_mean, theta_profiles=theta_profiles,
                     internal_energy=e_int)
