"""Exact solutions by characteristics, section 3.3.1 of the seed, as BSR models.

Example A (blow-up at t = 1)
    u_t + u u_x = 1, ρ_t + (ρ u)_x = 0, u(x, 0) = -x, ρ(x, 0) = 1:
    u = (2(t - x) - t²) / (2(1 - t)),  ρ = 1/(1 - t)   for t < 1.
    Characteristics x(t) = x0 (1 - t) + t²/2 carry u = t - x0; they all meet at x = 1/2 at
    t = 1, where ρ and u_x = -1/(1-t) are unbounded (gradient catastrophe).

Example B (global)
    u_t + u u_x = -u, ρ_t + (ρ u)_x = 0, u(x, 0) = 1, ρ(x, 0) = ψ(x):
    u = e^{-t},  ρ = ψ(x + e^{-t} - 1).

Units: x [m], t [s], u [m/s], ρ [kg/m]; the constants 1 in the equations carry the units
needed (e.g. the external acceleration of Example A is 1 m/s², the damping rate of B 1/s).
"""

from __future__ import annotations

import numpy as np

from ..physics.model import BSRModel

__all__ = ["example_a_solution", "example_b_solution", "example_a_model", "example_b_model", "psi_b"]


def example_a_solution(x, t):
    """(u, ρ) of Example A at positions x [m], time t < 1 s."""
    x = np.asarray(x, float)
    u = (2.0 * (t - x) - t * t) / (2.0 * (1.0 - t))
    return u, np.full_like(x, 1.0 / (1.0 - t))


def _a_external(t, x, u, p):
    return 1.0 + 0.0 * u


def _a_boundary(t, x, p):
    return (2.0 * (t - x) - t * t) / (2.0 * (1.0 - t)), 1.0 / (1.0 - t) + 0.0 * x


def example_a_model() -> BSRModel:
    """Example A with the exact solution as Dirichlet (inflow) data at both ends."""
    return BSRModel(external=_a_external, boundary_values=_a_boundary)


def psi_b(x, amplitude=0.5, wavenumber=2.0 * np.pi):
    """Initial density of Example B used here: ψ(x) = 1 + A sin(k x) [kg/m] (periodic on [0, 1])."""
    return 1.0 + amplitude * np.sin(wavenumber * np.asarray(x, float))


def example_b_solution(x, t, amplitude=0.5, wavenumber=2.0 * np.pi):
    """(u, ρ) of Example B with ψ = psi_b."""
    x = np.asarray(x, float)
    return np.full_like(x, np.exp(-t)), psi_b(x + np.exp(-t) - 1.0, amplitude, wavenumber)


def _b_external(t, x, u, p):
    return -u


def example_b_model() -> BSRModel:
    """Example B: external acceleration e = -u (linear drag, rate 1/s)."""
    return BSRModel(external=_b_external)
