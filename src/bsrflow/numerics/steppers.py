"""Explicit Runge-Kutta time steppers as data (Butcher tableaux).

A stepper advances dY/dt = F(t, Y) over one step Δt with s stages

    k_i = F(t + c_i Δt, Y + Δt Σ_{j<i} a_ij k_j),     Y_{n+1} = Y_n + Δt Σ_i b_i k_i.

The compiled solver takes the tableau arrays, so any explicit tableau can be used without
touching the time loop.  ``b_embedded`` (optional) gives a lower-order solution for error
control.

``kutta3`` is exactly the seed's scheme (4.17)-(4.24) / (B.1)-(B.5):
k1 at t, k2 at t + Δt/2 from Y + Δt k1/2, k3 at t + Δt from Y - Δt k1 + 2 Δt k2,
Y_{n+1} = Y_n + Δt (k1 + 4 k2 + k3)/6.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Tableau", "STEPPERS", "get_stepper"]


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
}
STEPPERS["rk3"] = STEPPERS["kutta3"]


def get_stepper(name: str) -> Tableau:
    """Look up a stepper by name: euler, heun, kutta3 (alias rk3), rk4, bs32."""
    try:
        return STEPPERS[name]
    except KeyError:
        raise ValueError(f"stepper = {name!r} is not one of {sorted(STEPPERS)}") from None
