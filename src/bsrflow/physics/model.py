"""The 1-D BSR model in the frame moving with the container, (3.16)-(3.17), (4.13)-(4.14).

    u_t = -u u_x + e(t, x, u) - g - ϑ''(t) + ∫_{-R}^{R} ρ(x+z) Θ(z, u(x), u(x+z)) dz     [m/s²]
    ρ_t = -(ρ u)_x                                                                   [kg/(m s)]

u [m/s] is the velocity relative to the floor, ρ [kg/m] the mass per unit length, g [m/s²]
gravity (acting towards -x), ϑ the applied floor motion (its smooth acceleration enters as the
inertial term -ϑ''; its velocity jumps shift u, see :mod:`bsrflow.physics.motion`), e an
optional external acceleration, Θ the interaction kernel (:mod:`bsrflow.physics.kernels`).
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass, field

import numba
import numpy as np

from .kernels import Kernel, zero_kernel
from .motion import AppliedMotion, Rest

__all__ = ["BSRModel", "no_external", "no_boundary_values"]


def _no_external(t, x, u, p):
    return 0.0 * u


def _no_boundary_values(t, x, p):
    return 0.0 * x, 0.0 * x


no_external = _no_external
no_boundary_values = _no_boundary_values
_JIT: dict = {}


def jit_user(fn):
    """numba-compile a user function once per function object."""
    if fn not in _JIT:
        _JIT[fn] = numba.njit(inline="always")(fn)
    return _JIT[fn]


@dataclass
class BSRModel:
    """The physics of a 1-D BSR run.

    Parameters
    ----------
    kernel : interaction kernel Θ (default: none).
    motion : applied floor motion ϑ(t) (default: rest).
    gravity : g [m/s²], acting towards -x (default 0).
    external : optional ``e(t, x, u, p)`` [m/s²], NumPy-ufunc only (compiled for the loop).
    external_params : its parameters p.
    boundary_values : ``(t, x, p) -> (u, ρ)`` ghost values for 'dirichlet' boundaries.
    boundary_params : their parameters p.
    """

    kernel: Kernel = field(default_factory=zero_kernel)
    motion: AppliedMotion = field(default_factory=Rest)
    gravity: float = 0.0
    external: object = _no_external
    external_params: np.ndarray = field(default_factory=lambda: np.zeros(1))
    boundary_values: object = _no_boundary_values
    boundary_params: np.ndarray = field(default_factory=lambda: np.zeros(1))

    def __post_init__(self):
        if not isinstance(self.kernel, Kernel):
            hint = (" (a 2-D/3-D kernel: use BSRModelND)" if type(self.kernel).__name__ == "KernelND" else
                    " (wrap a function: Kernel(fn, params, radius))" if callable(self.kernel) else "")
            what = getattr(self.kernel, "__name__", None) or type(self.kernel).__name__
            raise ValueError(f"kernel = {what} must be a bsrflow.physics.kernels.Kernel{hint}")
        if not isinstance(self.motion, AppliedMotion):
            hint = " (call it: HalfSineTaps(amplitude, frequency, ...))" if callable(self.motion) else ""
            what = getattr(self.motion, "__name__", None) or type(self.motion).__name__
            raise ValueError(f"motion = {what} must be an AppliedMotion{hint}")
        if isinstance(self.gravity, bool) or not isinstance(self.gravity, numbers.Real):
            raise ValueError(f"gravity = {self.gravity!r} must be a number (m/s^2)")
        if not np.isfinite(self.gravity):
            raise ValueError(f"gravity = {self.gravity!r} must be finite (m/s^2)")
        self.external_params = np.ascontiguousarray(np.atleast_1d(np.asarray(self.external_params, float)))
        self.boundary_params = np.ascontiguousarray(np.atleast_1d(np.asarray(self.boundary_params, float)))

    def to_dict(self) -> dict:
        return {"kernel": self.kernel.to_dict(), "motion": self.motion.to_dict(), "gravity": self.gravity,
                "external": getattr(self.external, "__name__", str(self.external)),
                "external_params": self.external_params.tolist()}
