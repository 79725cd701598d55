"""Plain NumPy reference of the semidiscrete scheme (same formulas as ``compiled.py``).

Used to test the compiled loop (equal to 1e-12 relative) and as the baseline of the
benchmarks.  Vectorised over cells; the interaction integral is a loop over the 2W+1
quadrature nodes, each a whole-array operation.
"""

from __future__ import annotations

import numpy as np

from .quadrature import quadrature_weights
from .steppers import get_stepper

__all__ = ["ReferenceScheme", "make_positive_numpy"]


def make_positive_numpy(rho: np.ndarray) -> np.ndarray:
    """The mass-conserving positivity fix of ``compiled.make_positive`` in NumPy (a copy is
    returned): the cells are visited from the bottom; a cell with ρ < 0 is set to 0 and its
    deficit is taken from the cells with ρ > 0 within the narrowest window i − w … i + w
    (w = 1, 2, …) that holds enough, each losing the same fraction of its density (all of it,
    with the widest window, when even that does not hold enough: a failed state, where mass is
    then created).  Sequential: a cell fixed earlier is a donor for the later ones."""
    rho = np.array(rho, dtype=float, copy=True)
    n = rho.size
    for i in range(n):
        if rho[i] >= 0.0:
            continue
        deficit = -rho[i]
        rho[i] = 0.0
        for w in range(1, n):
            window = rho[max(0, i - w):min(n, i + w + 1)]          # a view: updated in place
            donors = window > 0.0
            avail = float(window[donors].sum()) if donors.any() else 0.0
            if avail >= deficit or w == n - 1:
                f = min(deficit / avail, 1.0) if avail > 0.0 else 0.0
                window[donors] -= f * window[donors]
                break
    return rho


class ReferenceScheme:
    """NumPy implementation of one step of the scheme for a :class:`Simulation`'s settings."""

    def __init__(self, sim):
        self.sim = sim
        self.grid = sim.grid
        self.model = sim.model
        self.W = sim.W
        self.G = max(self.W, 2)
        self.qz, self.qw = quadrature_weights(self.W, self.grid.dx, sim.scheme.quadrature)
        self.tableau = get_stepper(sim.scheme.stepper)

    def pad(self, u, rho, t):
        """Padded copies of (u, ρ) with G ghost cells each side (boundary rules of grid.py)."""
        g, G, N = self.grid, self.G, self.grid.n_cells
        gi = np.arange(1, G + 1)                      # ghost distance from the end
        x_lo = g.lower + (0.5 - gi) * g.dx            # positions of cells -1, -2, ...
        x_hi = g.lower + (N - 0.5 + gi) * g.dx        # positions of cells N, N+1, ...
        p = self.model.boundary_params
        if g.bc_lower == "periodic":
            ul, rl = u[(-gi) % N], rho[(-gi) % N]
        elif g.bc_lower in ("floor", "mirror"):
            m = gi - 1
            inside = m < N
            ul = np.where(inside, -u[np.minimum(m, N - 1)], 0.0)
            rl = np.where(inside, rho[np.minimum(m, N - 1)], 0.0)
            if g.bc_lower == "floor":
                rw = 1.5 * rho[0] - 0.5 * rho[1]
                rl = np.where(inside, np.maximum(2.0 * rw - rl, 0.0), 0.0)
        elif g.bc_lower == "vacuum":
            ul, rl = np.full(G, u[0]), np.zeros(G)
        else:
            ul, rl = self.model.boundary_values(t, x_lo, p)
        if g.bc_upper == "periodic":
            uh, rh = u[(N - 1 + gi) % N], rho[(N - 1 + gi) % N]
        elif g.bc_upper == "vacuum":
            uh, rh = np.full(G, u[-1]), np.zeros(G)
        else:
            uh, rh = self.model.boundary_values(t, x_hi, p)
        up = np.concatenate([np.broadcast_to(ul, (G,))[::-1], u, np.broadcast_to(uh, (G,))])
        rp = np.concatenate([np.broadcast_to(rl, (G,))[::-1], rho, np.broadcast_to(rh, (G,))])
        return up, rp

    def rhs(self, u, rho, t, rho_mat=None):
        """(du/dt, dρ/dt) of (4.13)-(4.14) with central differences and quadrature.
        ``rho_mat``: start-of-step density; with a vacuum threshold the dissipations' speed
        max|u| is taken over its material cells (as in the compiled code)."""
        g, G, N, W = self.grid, self.G, self.grid.n_cells, self.W
        m = self.model
        up, rp = self.pad(u, rho, t)
        c = slice(G, G + N)
        right = slice(G + 1, G + N + 1)
        left = slice(G - 1, G + N - 1)
        ux = (up[right] - up[left]) / (2 * g.dx)
        frame = m.motion.state(t)[2]
        du = -u * ux + m.external(t, g.x, u, m.external_params) - m.gravity - frame
        integral = np.zeros(N)
        for k in range(-W, W + 1):
            sl = slice(G + k, G + k + N)
            integral += self.qw[k + W] * rp[sl] * m.kernel(self.qz[k + W], u, up[sl])
        du = du + integral
        dr = -(rp[right] * up[right] - rp[left] * up[left]) / (2 * g.dx)
        if g.bc_lower == "floor":
            # flux through the floor with the even image (see grid.py)
            dr[0] = -(rp[G + 1] * up[G + 1] - rp[G] * up[G - 1]) / (2 * g.dx)
        k4 = self.sim.scheme.hyperdiffusion
        k2 = self.sim.scheme.sensor_dissipation
        if k4 > 0 or k2 > 0:
            thr = self.sim.vacuum_density
            mat = (rho if rho_mat is None else rho_mat) >= thr if thr > 0 else np.ones(N, bool)
            umax = np.max(np.abs(u[mat])) if mat.any() else 0.0
            speed = umax + self.sim.model.kernel.wave_speed_bound({"rho": rho})
        if k2 > 0:
            fu, fr = self._face_fluxes(up, rp, self._faces_on(up, rp, self.sim.scheme.selective_filter, speed),
                                       k2 * speed / g.dx)
            du = du + fu[1:] - fu[:-1]
            dr = dr + fr[1:] - fr[:-1]
        if k4 > 0:
            coef = k4 * speed / g.dx
            d4 = lambda a: a[G - 2:G + N - 2] - 4 * a[G - 1:G + N - 1] + 6 * a[G:G + N] - 4 * a[G + 1:G + N + 1] + a[G + 2:G + N + 2]
            r4 = rp.copy()
            if g.bc_lower == "floor":
                r4[G - 1], r4[G - 2] = rho[0], rho[1]      # even images for the dissipative flux
            du = du - coef * d4(up)
            dr = dr - coef * d4(r4)
        return du, dr

    def moving_average(self, u, rho, t):
        up, rp = self.pad(u, rho, t)
        G, N = self.G, self.grid.n_cells
        avg = lambda a: 0.25 * (a[G - 1:G + N - 1] + 2 * a[G:G + N] + a[G + 1:G + N + 1])
        ru = avg(rp)
        if self.grid.bc_lower == "floor":
            ru[0] = 0.25 * (3.0 * rho[0] + rho[1])
        return avg(up), ru

    def step(self, u, rho, t, dt):
        """One whole step (all stages, then the moving average if the scheme has it)."""
        tb = self.tableau
        ku, kr = [], []
        for st in range(tb.stages):
            yu = u + dt * sum(tb.a[st, j] * ku[j] for j in range(st)) if st else u.copy()
            yr = rho + dt * sum(tb.a[st, j] * kr[j] for j in range(st)) if st else rho.copy()
            du, dr = self.rhs(yu, yr, t + tb.c[st] * dt, rho)
            ku.append(du)
            kr.append(dr)
        un = u + dt * sum(tb.b[j] * ku[j] for j in range(tb.stages))
        rn = rho + dt * sum(tb.b[j] * kr[j] for j in range(tb.stages))
        if self.sim.scheme.positivity:
            rn = make_positive_numpy(rn)
        thr = self.sim.vacuum_density
        if thr > 0:
            mat = np.flatnonzero(rn >= thr)
            if mat.size:
                vac = np.flatnonzero(rn < thr)
                # nearest material cell, the lower one on a tie
                pos = np.searchsorted(mat, vac)
                lo = mat[np.clip(pos - 1, 0, mat.size - 1)]
                hi = mat[np.clip(pos, 0, mat.size - 1)]
                dlo = np.where(pos > 0, vac - lo, np.iinfo(np.int64).max)
                dhi = np.where(pos < mat.size, hi - vac, np.iinfo(np.int64).max)
                un = un.copy()
                un[vac] = un[np.where(dhi < dlo, hi, lo)]
        if self.sim.scheme.filter:
            un, rn = self.moving_average(un, rn, t + dt)
        elif self.sim.scheme.selective_filter > 0 and self.sim.scheme.sensor_dissipation == 0:
            un, rn = self.selective_average(un, rn, t + dt)
        if self.sim.density_floor > 0:
            rn = np.where(np.abs(rn) < self.sim.density_floor, 0.0, rn)
        return un, rn

    def selective_average(self, u, rho, t):
        """Moving average in flux form on the faces next to cells flagged by the sensors."""
        up, rp = self.pad(u, rho, t)
        tau = self.sim.scheme.selective_filter
        speed = np.max(np.abs(u)) + self.sim.model.kernel.wave_speed_bound({"rho": rho})
        fu, fr = self._face_fluxes(up, rp, self._faces_on(up, rp, tau, speed), 0.25)
        return u + fu[1:] - fu[:-1], rho + fr[1:] - fr[:-1]

    def _face_fluxes(self, up, rp, on, coef):
        """coef (q_f - q_{f-1}) on the faces that are on, 0 elsewhere; no mass flux through a floor."""
        G, N = self.G, self.grid.n_cells
        fu = np.where(on, coef * (up[G:G + N + 1] - up[G - 1:G + N]), 0.0)
        fr = np.where(on, coef * (rp[G:G + N + 1] - rp[G - 1:G + N]), 0.0)
        if self.grid.bc_lower == "floor":
            fr[0] = 0.0
        return fu, fr

    def _faces_on(self, up, rp, tau, speed):
        """Faces f = 0..N (between cells f-1 and f) next to a cell whose smoothness sensor
        exceeds tau (``compiled.sensor_on``)."""
        G, N = self.G, self.grid.n_cells
        c = slice(G - 1, G + N + 1)                          # cells -1..N
        l = slice(G - 2, G + N)
        r = slice(G, G + N + 2)
        dr = np.abs(rp[l] - 2 * rp[c] + rp[r])
        sr = rp[l] + 2 * rp[c] + rp[r]
        du = np.abs(up[l] - 2 * up[c] + up[r])
        su = np.abs(up[l]) + 2 * np.abs(up[c]) + np.abs(up[r]) + 4 * speed
        flag = ((sr > 0) & (dr > tau * sr)) | ((su > 0) & (du > tau * su))
        return flag[:-1] | flag[1:]

    def run_fixed(self, u, rho, t, dt, n_steps):
        """n_steps steps of size dt."""
        for _ in range(n_steps):
            u, rho = self.step(u, rho, t, dt)
            t += dt
        return u, rho
