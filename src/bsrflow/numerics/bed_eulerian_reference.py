"""Plain NumPy twin of :mod:`bsrflow.numerics.bed_eulerian`: the vibrated bed's granular
hydrodynamics (:mod:`bsrflow.physics.granular_bed`) as Eulerian finite volumes on a 1-, 2- or 3-D
grid.  The compiled kernels are tested against these functions (tests/test_bed_eulerian.py); the
module docstring of :mod:`bsrflow.numerics.bed_eulerian` gives the scheme.

Fields ``q`` (6, NX, NY, NZ): ρ [kg/m³], ρu_x, ρu_y, ρu_z [kg/(m² s)], E = (3/2)ρθ [J/m³],
ρδ_max [kg/m²]; z (the last axis) is vertical, the floor at its first face, a lid at its last.
"""

from __future__ import annotations

import numpy as np

from ..physics.granular_bed import constitutive_numpy, effective_restitution

RHO, MX, MY, MZ, ENER, HIST = range(6)
N_FIELDS = 6
MOMENTA = (MX, MY, MZ)


def _minmod(a, b):
    return np.where(a * b <= 0.0, 0.0, np.where(np.abs(a) < np.abs(b), a, b))


def _pad(w, kind, odd=False):
    """Two ghost cells at each end of the last axis: ``periodic`` or ``wall`` (mirror at both
    ends: the floor below, the lid above; ``odd`` flips the sign, for the normal velocity)."""
    if kind == "periodic":
        return np.concatenate([w[..., -2:], w, w[..., :2]], axis=-1)
    s = -1.0 if odd else 1.0
    return np.concatenate([s * w[..., 1::-1], w, s * w[..., :-3:-1]], axis=-1)


def _g0(phi):
    p = np.minimum(phi, 0.95)
    return (1.0 - 0.5 * p) / (1.0 - p) ** 3


def kinetic_sound_speed_numpy(phi, theta, e):
    """Sound speed of the kinetic pressure p = ρθY(φ) at constant entropy of the fluctuations
    (E = (3/2)ρθ): c² = θ(Y + φY') + (2/3)θY² [m²/s²], Y = 1 + 2(1 + e)φg0, g0' of
    Carnahan–Starling (2.5 − φ)/(1 − φ)⁴ (0 above its cap at φ = 0.95)."""
    p = np.minimum(phi, 0.95)
    g = _g0(p)
    dg = np.where(phi < 0.95, (2.5 - p) / (1.0 - p) ** 4, 0.0)
    y = 1.0 + 2.0 * (1.0 + e) * phi * g
    dy = 2.0 * (1.0 + e) * (g + phi * dg)
    t = np.maximum(theta, 0.0)
    return np.sqrt(t * (y + phi * dy) + (2.0 / 3.0) * t * y * y)


def primitives_numpy(q, rho_tiny):
    """(ρ, (u_x, u_y, u_z), θ, δ_max): zero velocity, θ and δ_max where ρ ≤ ``rho_tiny``; θ ≥ 0."""
    r = q[RHO]
    has = r > rho_tiny
    safe = np.where(has, r, 1.0)
    u = tuple(np.where(has, q[c] / safe, 0.0) for c in MOMENTA)
    th = np.where(has, np.maximum(q[ENER] / (1.5 * safe), 0.0), 0.0)
    h = np.where(has, q[HIST] / safe, 0.0)
    return np.where(has, r, 0.0), u, th, h


def _packing_pressure(r, h, d, m, k1, k2, rho_tiny):
    safe = np.where(r > rho_tiny, r, 1.0)
    delta = d - m / safe
    dm = np.maximum(h, delta)
    return np.where(r > rho_tiny, np.maximum(0.0, k1 * dm - k2 * (dm - delta)), 0.0)


def _hlle(SL, SR, fL, fR, qL, qR):
    den = np.where(SR > SL, SR - SL, 1.0)
    mid = np.where(SR > SL, (SR * fL - SL * fR + SL * SR * (qR - qL)) / den, 0.5 * (fL + fR))
    return np.where(SL > 0.0, fL, np.where(SR < 0.0, fR, mid))


def axis_fluxes_numpy(prim, axis, kind, par):
    """Fluxes of the six conserved fields at the n + 1 faces along ``axis`` (0, 1, 2; HLLE across
    the horizontal axes, HLLC along z, the walls passing only the normal momentum) and the
    face velocities u_f [m/s] (the work term's divergence), each of shape (..., n + 1) with
    ``axis`` moved last.  ``kind``: ``periodic`` or ``wall``."""
    r, u, th, h = prim
    mv = lambda a: np.moveaxis(a, axis, -1)                                    # noqa: E731
    comp = [MX, MY, MZ]
    normal = comp[axis]
    trans = [c for c in comp if c != normal]
    ucell = {c: mv(u[c - MX]) for c in comp}
    W = {"r": _pad(mv(r), kind), "th": _pad(mv(th), kind), "h": _pad(mv(h), kind)}
    for c in comp:
        W[c] = _pad(ucell[c], kind, odd=(kind == "wall" and c == normal))
    n = mv(r).shape[-1]
    rl, rr = W["r"][..., 1:n + 2], W["r"][..., 2:n + 3]
    ul, ur = W[normal][..., 1:n + 2], W[normal][..., 2:n + 3]
    d, m, rho_c = par["d"], par["m"], par["rho_c"]
    compaction = (ur < ul) & (np.minimum(rl, rr) * d < m)
    hs = np.where(compaction, 0.0, 0.5)

    def faces(w):
        L = w[..., 1:n + 2] + hs * _minmod(w[..., 1:n + 2] - w[..., 0:n + 1], w[..., 2:n + 3] - w[..., 1:n + 2])
        R = w[..., 2:n + 3] - hs * _minmod(w[..., 2:n + 3] - w[..., 1:n + 2], w[..., 3:n + 4] - w[..., 2:n + 3])
        return L, R

    rL, rR = faces(W["r"])
    vacL, vacR = rL <= par["rho_tiny"], rR <= par["rho_tiny"]
    rL, rR = np.where(vacL, 0.0, rL), np.where(vacR, 0.0, rR)
    st = {}
    for key in ["th", "h"] + comp:
        a, b = faces(W[key])
        st[key] = (np.where(vacL, 0.0, a), np.where(vacR, 0.0, b))
    uL, uR = st[normal]
    thL, thR = st["th"]
    hL, hR = st["h"]
    k1, k2 = par["k1"], par["k2"]
    pL = _packing_pressure(rL, hL, d, m, k1, k2, par["rho_tiny"])
    pR = _packing_pressure(rR, hR, d, m, k1, k2, par["rho_tiny"])
    cL = np.where(rL * d > m, np.sqrt(k2 * m) / np.where(rL > 0, rL, 1.0), 0.0)
    cR = np.where(rR * d > m, np.sqrt(k2 * m) / np.where(rR > 0, rR, 1.0), 0.0)
    sl, sr = np.sqrt(rL), np.sqrt(rR)
    uh = np.where(sl + sr > 0.0, (sl * uL + sr * uR) / np.where(sl + sr > 0, sl + sr, 1.0), 0.0)
    dr = rR - rL
    big = np.abs(dr) > 1e-12 * (rL + rR)
    c2 = (pR - pL) / np.where(big, dr, 1.0)
    ch = np.where(big, np.sqrt(np.maximum(c2, 0.0)), np.maximum(cL, cR))
    ch = np.minimum(ch, par["c_cap"])
    # the kinetic pressure and its sound speed
    e, rho_s = par["e"], par["rho_s"]
    phL, phR = rL / rho_s, rR / rho_s
    kL = rL * thL * (1.0 + 2.0 * (1.0 + e) * phL * _g0(phL))
    kR = rR * thR * (1.0 + 2.0 * (1.0 + e) * phR * _g0(phR))
    ckL, ckR = kinetic_sound_speed_numpy(phL, thL, e), kinetic_sound_speed_numpy(phR, thR, e)
    ck = np.maximum(ckL, ckR)
    SL = np.minimum(np.minimum(uL - cL, uh - ch) - ck, uL - ckL)
    SR = np.maximum(np.maximum(uR + cR, uh + ch) + ck, uR + ckR)
    PL, PR = pL + kL, pR + kR
    f = {}
    if axis == 2:
        # vertical faces: HLLC with the same bounds (bed_eulerian._hllc_z)
        den = rL * (SL - uL) - rR * (SR - uR)
        ss = np.where(den != 0.0, (PR - PL + rL * uL * (SL - uL) - rR * uR * (SR - uR))
                      / np.where(den != 0.0, den, 1.0), 0.0)
        ss = np.minimum(np.maximum(ss, SL), SR)
        left = (SL >= 0.0) | (ss >= 0.0)
        aL_, aR_ = np.minimum(SL, 0.0), np.maximum(SR, 0.0)
        with np.errstate(divide="ignore", invalid="ignore"):      # the side not taken may divide by 0
            chiL = np.where(aL_ < 0.0, rL * (SL - uL) / np.where(aL_ < 0.0, SL - ss, 1.0), rL)
            chiR = np.where(aR_ > 0.0, rR * (SR - uR) / np.where(aR_ > 0.0, SR - ss, 1.0), rR)
        fmL = rL * uL + aL_ * (chiL - rL)
        fmR = rR * uR + aR_ * (chiR - rR)
        f[RHO] = np.where(left, fmL, fmR)
        fm = np.where(left, rL * uL * uL + PL + aL_ * (chiL * ss - rL * uL),
                      rR * uR * uR + PR + aR_ * (chiR * ss - rR * uR))
        for c in trans:
            aL, aR = st[c]
            f[c] = np.where(left, fmL * aL, fmR * aR)
        f[ENER] = np.where(left, fmL * 1.5 * thL, fmR * 1.5 * thR)
        f[HIST] = np.where(left, fmL * hL, fmR * hR)
    else:
        f[RHO] = _hlle(SL, SR, rL * uL, rR * uR, rL, rR)
        fm = _hlle(SL, SR, rL * uL * uL + PL, rR * uR * uR + PR, rL * uL, rR * uR)
        for c in trans:
            aL, aR = st[c]
            f[c] = _hlle(SL, SR, rL * uL * aL, rR * uR * aR, rL * aL, rR * aR)
        f[ENER] = _hlle(SL, SR, 1.5 * rL * thL * uL, 1.5 * rR * thR * uR, 1.5 * rL * thL, 1.5 * rR * thR)
        f[HIST] = _hlle(SL, SR, rL * uL * hL, rR * uR * hR, rL * hL, rR * hR)
    if kind == "wall":                                    # floor and lid: only the normal momentum crosses
        for c in [RHO, ENER, HIST] + trans:
            f[c][..., 0] = 0.0
            f[c][..., -1] = 0.0
    adv = f[RHO] * np.where(f[RHO] > 0.0, uL, uR)
    f[normal] = np.maximum(fm, adv)                       # no tension (packing_kernels.no_tension)
    uf = np.where(vacL & vacR, 0.0, np.where(vacL, uR, np.where(vacR, uL, 0.5 * (uL + uR))))
    return f, uf


def transport_numpy(prim, par):
    """Cell coefficients μ, λ, κ [Pa s, Pa s, kg/(m s)] of the kinetic theory
    (:func:`bsrflow.physics.granular_bed.constitutive_numpy`), zero where φ < ``phi_min``, and
    the kinetic pressure p [Pa] (everywhere)."""
    r, u, th, h = prim
    phi = r / par["rho_s"]
    c = constitutive_numpy(phi, th, par["rho_s"], par["d"], par["e"])
    on = phi >= par["phi_min"]
    out = {k: np.where(on, c[k], 0.0) for k in ("mu", "lambda", "kappa")}
    out["p"] = c["p"]
    return out


def _axis_kind(axis):
    return "wall" if axis == 2 else "periodic"


def _cell_gradient(u, axis, dx, odd):
    """Centred difference of the cell field u along ``axis`` (periodic sides, mirror at floor and lid)."""
    w = _pad(np.moveaxis(u, axis, -1), _axis_kind(axis), odd)
    n = w.shape[-1] - 4
    return np.moveaxis((w[..., 3:n + 3] - w[..., 1:n + 1]) / (2.0 * dx[axis]), -1, axis)


def rhs_numpy(q, dim, dx, accel, par):
    """(dq/dt, floor stress per column [Pa] (NX, NY)) with cell sizes dx (3) [m] along x, y, z
    (those of the axes the grid lacks unused): the module's right-hand side without the
    collisional loss (integrated exactly after the step, :func:`post_step_numpy`)."""
    dq = np.zeros_like(q)
    prim = primitives_numpy(q, par["rho_tiny"])
    r, u, th, h = prim
    axes = [2] + list(range(dim - 1))                     # vertical first, then x (and y)
    div = np.zeros_like(r)
    floor = None
    coef = transport_numpy(prim, par)
    mu_c, lam_c, kap_c = coef["mu"], coef["lambda"], coef["kappa"]
    active = [a for a in (0, 1, 2) if a == 2 or a < dim - 1]
    # cell gradients G[a][b] = ∂_a u_b (for the tangential derivatives at faces)
    G = {(a, b): (_cell_gradient(u[b], a, dx, odd=(a == 2 and b == 2)) if a in active else np.zeros_like(r))
         for a in (0, 1, 2) for b in (0, 1, 2)}
    heat = np.zeros_like(r)
    for a in axes:
        kind = _axis_kind(a)
        f, uf = axis_fluxes_numpy(prim, a, kind, par)
        # viscous stress and conduction at the faces of this axis
        mv = lambda x: np.moveaxis(x, a, -1)                                   # noqa: E731
        n = mv(r).shape[-1]

        def face_coef(c):
            w = _pad(mv(c), kind)
            lo, hi = w[..., 1:n + 2], w[..., 2:n + 3]
            return np.where((lo > 0.0) & (hi > 0.0), 0.5 * (lo + hi), 0.0)

        muf, lamf, kapf = face_coef(mu_c), face_coef(lam_c), face_coef(kap_c)
        Gf = {}
        for b in (0, 1, 2):
            w = _pad(mv(u[b]), kind, odd=(kind == "wall" and b == 2))
            Gf[(a, b)] = (w[..., 2:n + 3] - w[..., 1:n + 2]) / dx[a]
            for c in (0, 1, 2):
                if c == a:
                    continue
                wg = _pad(mv(G[(c, b)]), kind, odd=(kind == "wall" and b == 2))   # c ≠ 2 here
                Gf[(c, b)] = 0.5 * (wg[..., 1:n + 2] + wg[..., 2:n + 3])
        tr = Gf[(0, 0)] + Gf[(1, 1)] + Gf[(2, 2)]
        tau = {}
        for b in (0, 1, 2):
            tau[b] = muf * (Gf[(a, b)] + Gf[(b, a)]) + ((lamf - (2.0 / 3.0) * muf) * tr if b == a else 0.0)
        thp = _pad(mv(th), kind)
        qheat = -kapf * (thp[..., 2:n + 3] - thp[..., 1:n + 2]) / dx[a]
        if kind == "wall":
            # the lid: no stress, no heat flux; the floor: no heat flux (its loss below)
            for b in (0, 1, 2):
                tau[b][..., -1] = 0.0
            qheat[..., 0] = 0.0
            qheat[..., -1] = 0.0
            # the floor gives no viscous push (the Riemann flux carries the impact), and it
            # pushes but cannot pull: its face's normal momentum flux ≥ 0
            tau[2][..., 0] = np.maximum(tau[2][..., 0], 0.0)
            f0 = f[MZ][..., 0] - tau[2][..., 0]
            tau[2][..., 0] = np.where(f0 < 0.0, f[MZ][..., 0], tau[2][..., 0])
            floor = np.maximum(f0, 0.0)
        diss = tau[0] * Gf[(a, 0)] + tau[1] * Gf[(a, 1)] + tau[2] * Gf[(a, 2)]
        comp = [MX, MY, MZ]
        flux = dict(f)
        for b in (0, 1, 2):
            flux[comp[b]] = flux[comp[b]] - tau[b]
        flux[ENER] = flux[ENER] + qheat
        for c in range(N_FIELDS):
            dq[c] -= np.moveaxis((flux[c][..., 1:] - flux[c][..., :-1]) / dx[a], -1, a)
        div += np.moveaxis((uf[..., 1:] - uf[..., :-1]) / dx[a], -1, a)
        heat += np.moveaxis(0.5 * (diss[..., 1:] + diss[..., :-1]), -1, a)
    if dim < 3:
        dq[MY] = 0.0
    if dim < 2:
        dq[MX] = 0.0
    dq[MZ] += r * accel
    dq[ENER] += -coef["p"] * div + heat
    # the floor's collisional loss, (1 − e_w) p √(2θ/π) [W/m²], from the bottom cells
    ew = par["e_w"]
    p0, th0 = coef["p"][..., 0], th[..., 0]
    dq[ENER][..., 0] -= (1.0 - ew) * p0 * np.sqrt(2.0 * th0 / np.pi) / dx[2]
    return dq, floor


def post_step_numpy(q, dt, par):
    """After a step: the collisional loss integrated exactly over Δt (θ̇ = −Aθ^{3/2},
    A = 8(1 − e_d²)g0φ/(d√π)), θ ≥ 0, the momentum, energy and history of cells with
    ρ ≤ ``rho_tiny`` cleared (their mass kept),
    the history δ_max ← max(δ_max, δ) while in contact, 0 once separated."""
    q = q.copy()
    r = q[RHO]
    has = r > par["rho_tiny"]
    safe = np.where(has, r, 1.0)
    th = np.maximum(q[ENER] / (1.5 * safe), 0.0)
    phi = r / par["rho_s"]
    A = 8.0 * (1.0 - par["e_d"] ** 2) * _g0(phi) * phi / (par["d"] * np.sqrt(np.pi))
    th = th / (1.0 + 0.5 * A * dt * np.sqrt(th)) ** 2
    q[ENER] = np.where(has, 1.5 * r * th, 0.0)
    delta = par["d"] - par["m"] / safe
    h = q[HIST] / safe
    hn = np.where(delta > 0.0, np.maximum(h, delta), 0.0)
    q[HIST] = np.where(has, r * hn, 0.0)
    for c in (MX, MY, MZ):
        q[c] = np.where(has, q[c], 0.0)
    return q


def _varies_numpy(q, axis):
    return bool(np.any(q != np.roll(q, 1, axis=1 + axis)))


def stable_dt_numpy(q, dim, dx, par):
    """Δt (:func:`bsrflow.numerics.bed_eulerian.bed_stable_dt`'s rules): over the axes along which
    the state varies (z, and x / y where neighbouring cells differ), cfl / max Σ_a (c + c_k +
    |u_a|)/Δx_a (c_k and |u_a| at the largest φ, θ, |u_a| of the cell and its neighbours along
    those axes), and half the explicit limits of the conduction and the viscous stress with the
    operator's face coefficients (the mean of the two cells', none below φ_min; the floor's face
    viscous only, the lid's neither)."""
    prim = primitives_numpy(q, par["rho_tiny"])
    r, u, th, h = prim
    axes = [2] + [a for a in range(dim - 1) if _varies_numpy(q, a)]
    has = r > 0.0
    # the largest φ, θ, |u_b| of each cell and its neighbours along the counted axes
    phm, thm, um = r.copy(), th.copy(), [np.abs(u[b]) for b in range(3)]
    for a in axes:
        mv = lambda x: np.moveaxis(x, a, -1)                                       # noqa: E731
        n = mv(r).shape[-1]
        for side in (-1, 1):
            nb = lambda x: np.moveaxis(_pad(mv(x), _axis_kind(a))[..., 2 + side:n + 2 + side], -1, a)  # noqa: E731
            phm = np.maximum(phm, nb(r))
            thm = np.maximum(thm, nb(th))
            um = [np.maximum(um[b], np.abs(nb(u[b]))) for b in range(3)]
    ck = kinetic_sound_speed_numpy(phm / par["rho_s"], thm, par["e"])
    rate = sum((par["c_cap"] + ck + um[a]) / dx[a] for a in axes)
    rate = float(np.max(np.where(has, rate, 0.0)))
    dt = par["cfl"] / rate if rate > 0.0 else par["cfl"] * dx[2] / par["c_cap"]
    coef = transport_numpy(prim, par)
    zeta = coef["lambda"] + (4.0 / 3.0) * coef["mu"]
    on = coef["mu"] > 0.0
    sz = np.zeros_like(r)
    sk = np.zeros_like(r)
    for a in axes:
        for side in (-1, 1):
            kind = _axis_kind(a)
            mv = lambda x: np.moveaxis(x, a, -1)                                   # noqa: E731
            n = mv(r).shape[-1]
            nb_on = _pad(mv(on.astype(float)), kind)[..., 2 + side:n + 2 + side] > 0.0
            nb_z = _pad(mv(zeta), kind)[..., 2 + side:n + 2 + side]
            nb_k = _pad(mv(coef["kappa"]), kind)[..., 2 + side:n + 2 + side]
            both = mv(on) & nb_on
            fz = np.where(both, 0.5 * (mv(zeta) + nb_z), 0.0)
            fk = np.where(both, 0.5 * (mv(coef["kappa"]) + nb_k), 0.0)
            if kind == "wall":
                if side == 1:                     # the lid: neither
                    fz[..., -1] = 0.0
                    fk[..., -1] = 0.0
                else:                             # the floor: viscous only
                    fk[..., 0] = 0.0
            sz += np.moveaxis(fz, -1, a) / dx[a] ** 2
            sk += np.moveaxis(fk, -1, a) / dx[a] ** 2
    with np.errstate(divide="ignore"):
        lim = np.minimum(np.where(sz > 0.0, 0.5 * r / np.where(sz > 0, sz, 1.0), np.inf),
                         np.where(sk > 0.0, 0.75 * r / np.where(sk > 0, sk, 1.0), np.inf))
    return min(dt, float(lim.min()))


def make_params(setup, dx, cfl=0.4):
    """The scheme's constants for a :class:`~bsrflow.physics.granular_bed.BedSetup`, by name
    (:func:`bsrflow.numerics.bed_eulerian.scheme_params`'s) with ``cfl``; ``dx`` is not used (the
    constants do not depend on the grid)."""
    from .bed_eulerian import scheme_params
    return {**scheme_params(setup)[1], "cfl": cfl}


__all__ = ["primitives_numpy", "axis_fluxes_numpy", "rhs_numpy", "post_step_numpy", "stable_dt_numpy",
           "kinetic_sound_speed_numpy", "transport_numpy", "make_params", "effective_restitution"]
