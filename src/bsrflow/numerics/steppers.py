"""Explicit Runge-Kutta time steppers as data (Butcher tableaux).

A stepper advances dY/dt = F(t, Y) over one step Δt with s stages

    k_i = F(t + c_i Δt, Y + Δt Σ_{j<i} a_ij k_j),     Y_{n+1} = Y_n + Δt Σ_i b_i k_i.

The compiled solver takes the tableau arrays, so any explicit tableau can be used without
touching the time loop.  ``b_embedded`` (optional) gives a lower-order solution for error
control.

``kutta3`` is exactly the seed's scheme (4.17)-(4.24) / (B.1)-(B.5):
k1 at t, k2 at t + Δt/2 from Y + Δt k1/2, k3 at t + Δt from Y - Δt k1 + 2 Δt k2,
Y_{n+1} = Y_n + Δt (k1 + 4 k2 + k3)/6.

``rk4_0.4_0.25`` (the ``accurate`` preset's stepper) is the member of Kutta's two-parameter
family of four-stage fourth-order methods with nodes c2 = 2/5, c3 = 1/4 (c4 = 1); its
coefficients follow from the order conditions (``kutta4_family``).  Every member has the
stability polynomial of classical RK4; they differ in the error constants.  On the tapped
column, whose time error comes from the kernel's Coulomb-like friction switch, this member's
mass-centre error is 1.5-12x smaller than that of Kutta's RK3 at the same step (classical
RK4's is larger than RK3's); measured by a scan of the family, ``bench/scan_kutta4.py`` and
docs/model.md, "The accurate preset".
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Tableau", "STEPPERS", "get_stepper", "kutta4_family", "kutta4_tableau", "order_residual"]


@dataclass(frozen=True)
class Tableau:
    name: str
    a: np.ndarray          # (s, s) strictly lower triangular
    b: np.ndarray          # (s,)
    c: np.ndarray          # (s,)
    order: int
    b_embedded: np.ndarray | None = None   # (s,) weights of the embedded solution
    embedded_order: int | None = None

    @property
    def stages(self) -> int:
        return len(self.b)

    def stability_polynomial(self, z):
        """R(z) = 1 + z b^T (I - z A)^{-1} 1 for the linear test equation y' = λ y, z = λ Δt."""
        z = np.asarray(z, dtype=complex)
        s = self.stages
        out = np.empty(z.shape, dtype=complex)
        flat = z.ravel()
        res = out.ravel()
        for n, zz in enumerate(flat):
            k = np.linalg.solve(np.eye(s) - zz * self.a, np.ones(s))
            res[n] = 1.0 + zz * (self.b @ k)
        return out


def _t(name, a, b, c, order, be=None, eo=None):
    return Tableau(name, np.array(a, float), np.array(b, float), np.array(c, float), order,
                   None if be is None else np.array(be, float), eo)


def kutta4_family(c2, c3):
    """(A, b, c) of the four-stage fourth-order explicit RK method with nodes (0, c2, c3, 1).

    Kutta's (1901) general solution of the eight order conditions:
    b solves the quadrature conditions Σ b_i c_i^(k-1) = 1/k, k = 1..4, and the stage
    coefficients the remaining ones.  Needs c2, c3 distinct, not 0 or 1, c2 ≠ 1/2 and
    6 c2 c3 - 4 (c2 + c3) + 3 ≠ 0.  Exact for ``fractions.Fraction`` arguments.
    """
    u, v = c2, c3
    den = 6 * u * v - 4 * (u + v) + 3
    if u == v or not (0 < u < 1 and 0 < v < 1) or 2 * u == 1 or den == 0:
        raise ValueError(f"kutta4_family: nodes c2 = {c2!r}, c3 = {c3!r} are outside the general case "
                         "(need distinct values in (0, 1), c2 != 1/2, 6 c2 c3 - 4 (c2 + c3) + 3 != 0)")
    b2 = (1 - 2 * v) / (12 * u * (1 - u) * (u - v))
    b3 = (1 - 2 * u) / (12 * v * (1 - v) * (v - u))
    b4 = den / (12 * (1 - u) * (1 - v))
    b1 = 1 - b2 - b3 - b4
    a32 = v * (v - u) / (2 * u * (1 - 2 * u))
    a42 = (1 - u) * (u + v - 1 - (2 * v - 1) ** 2) / (2 * u * (v - u) * den)
    a43 = (1 - 2 * u) * (1 - u) * (1 - v) / (v * (v - u) * den)
    zero = 0 * u
    a = [[zero] * 4, [u, zero, zero, zero], [v - a32, a32, zero, zero], [1 - a42 - a43, a42, a43, zero]]
    return a, [b1, b2, b3, b4], [zero, u, v, 1 + zero]


def order_residual(a, b, c, order) -> float:
    """Largest residual of the Runge-Kutta order conditions up to ``order`` (at most 4)."""
    a, b, c = (np.asarray(x, float) for x in (a, b, c))
    e = np.ones_like(b)
    conds = [b @ e - 1]
    if order >= 2:
        conds += [b @ c - 1 / 2]
    if order >= 3:
        conds += [b @ c ** 2 - 1 / 3, b @ a @ c - 1 / 6]
    if order >= 4:
        conds += [b @ c ** 3 - 1 / 4, b @ (c * (a @ c)) - 1 / 8, b @ a @ c ** 2 - 1 / 12, b @ a @ a @ c - 1 / 24]
    return float(max(abs(x) for x in conds))


def kutta4_tableau(c2, c3, name) -> Tableau:
    """The :class:`Tableau` of ``kutta4_family(c2, c3)``, computed in exact fractions (c2, c3 are
    numbers or strings such as ``"2/5"``; floats are rounded to denominators up to 1000)."""
    from fractions import Fraction
    a, b, c = kutta4_family(*(Fraction(x).limit_denominator(1000) for x in (c2, c3)))
    return _t(name, [[float(x) for x in row] for row in a], [float(x) for x in b], [float(x) for x in c], 4)


STEPPERS: dict[str, Tableau] = {
    "euler": _t("euler", [[0.0]], [1.0], [0.0], 1),
    "heun": _t("heun", [[0, 0], [1, 0]], [0.5, 0.5], [0, 1], 2, [1.0, 0.0], 1),
    "kutta3": _t("kutta3", [[0, 0, 0], [0.5, 0, 0], [-1, 2, 0]], [1 / 6, 4 / 6, 1 / 6],
                 [0, 0.5, 1], 3, [0.0, 1.0, 0.0], 2),
    "rk4": _t("rk4", [[0, 0, 0, 0], [0.5, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 1, 0]],
              [1 / 6, 1 / 3, 1 / 3, 1 / 6], [0, 0.5, 0.5, 1], 4),
    # Bogacki-Shampine 3(2): FSAL pair used for adaptive stepping
    "bs32": _t("bs32", [[0, 0, 0, 0], [0.5, 0, 0, 0], [0, 0.75, 0, 0], [2 / 9, 1 / 3, 4 / 9, 0]],
               [2 / 9, 1 / 3, 4 / 9, 0], [0, 0.5, 0.75, 1], 3,
               [7 / 24, 1 / 4, 1 / 3, 1 / 8], 2),
    # A = [[0], [2/5], [31/64, -15/64], [2/5, 3, -12/5]], b = (1/4, 125/108, -16/27, 5/27)
    "rk4_0.4_0.25": kutta4_tableau("2/5", "1/4", "rk4_0.4_0.25"),
}
STEPPERS["rk3"] = STEPPERS["kutta3"]


def get_stepper(name: str) -> Tableau:
    """Look up a stepper by name: euler, heun, kutta3 (alias rk3), rk4, bs32, rk4_0.4_0.25."""
    try:
        return STEPPERS[name]
    except KeyError:
        raise ValueError(f"stepper = {name!r} is not one of {sorted(STEPPERS)}") from None
