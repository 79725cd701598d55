"""The interaction interface of the BSR momentum equation, and the registry of its fast paths.

Every model of this package has a momentum equation of the form (3.7), (3.13)

    u_t + (u·∇)u = e(x, t) + I(x),   I(x) = ∫_{B_R(x)} ρ(y) Θ(x, y, s(x), s(y)) dy     [m/s²]

where s is the state at a point (its named fields: velocity, density, a history, …).  An
interaction is what the time loop needs to know about Θ, whatever the discretisation:

* ``state_fields``: the names of the state fields Θ reads at *both* points x and y (besides ρ(y),
  the weight of the integral).  The seed's kernel (4.6) reads the velocity only: Θ(z, u, u′).
  The packing interaction (:mod:`bsrflow.physics.packing`) reads the density and the history
  field: its stress depends on the local spacing m/ρ and the largest overlap reached.
* ``radius``: R [m] of the ball B_R(x) (for the packing interaction, the range of its BSR form; its
  discretisations use the local limit −(1/ρ)∇P, docs/model.md).
* ``wave_speed_bound(state)``: an upper bound [m/s] of the speed of the waves the interaction
  carries in the given state (a mapping of field name to array), for the time step's CFL bound.
  The time loop takes it from the interaction, never from a formula of its own.
* ``compiled_wave_speed()``: the same bound as a numba function ``(rho_max, p) -> c`` [m/s] with
  its parameter array ``p``, for the compiled loops, which see only the largest density of the
  current state.  The two agree (tested).

A new interaction implements these (subclass :class:`Interaction`) and a discretisation that can
evaluate it; :mod:`bsrflow.physics.kernels` explains how to write a kernel Θ for the seed's
grid, which needs nothing else.

Fast paths
----------
A specialised algorithm for one kernel (the seed's Walton–Braun O(1)-per-cell integral,
:mod:`bsrflow.numerics.fast_integral`) is registered with :func:`register_fast_integral` against
the kernel's function; the grid solver then uses it in place of the direct quadrature sum (and
``Scheme(integral="direct")`` forces the latter).  The fast path computes the same sum: its results
are tested against the direct one, and the seed's runs are bit for bit those of the registered
path.
"""

from __future__ import annotations

import abc
import math
from collections.abc import Mapping

import numba
import numpy as np

__all__ = ["Interaction", "linear_wave_speed", "constant_wave_speed", "register_fast_integral", "fast_integral_for",
           "FAST_INTEGRALS"]


def one_line(exc: BaseException, limit: int = 300) -> str:
    """An exception's message on one line (whitespace collapsed, at most ``limit`` characters):
    for the one-line errors about a user's kernel or motion that numba could not take."""
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= limit else text[:limit] + " ..."


def compiled_for(fn, compiled, cache: dict, compile_fn):
    """The compiled form of a kernel function ``fn``: ``compiled`` when it is a twin given
    explicitly (not made by ``compile_fn``), else ``fn``'s own from ``cache`` (``compile_fn(fn)``).
    A kernel copied with ``dataclasses.replace(k, fn=...)`` carries k's compiled function: one
    that ``compile_fn`` made from another function is replaced (the compiled loop ran the old
    kernel)."""
    made_here = cache.get(getattr(compiled, "py_func", None)) is compiled
    if compiled is None or (made_here and compiled.py_func is not fn):
        return compile_fn(fn)
    return compiled


@numba.njit(cache=True, inline="always")
def linear_wave_speed(rho_max, p):
    """c = √(p₀ ρ_max) [m/s]: the bound of a kernel linear in ρ (the seed's), p₀ = κ (1-D, c² = κρ,
    Appendix A corrected) or n κ (n-D central differences)."""
    return math.sqrt(p[0] * rho_max)


@numba.njit(cache=True, inline="always")
def constant_wave_speed(rho_max, p):
    """c = p₀ [m/s] for every state: a bound that holds at every density (the packing law's sound
    speed at close packing, which no denser state exceeds)."""
    return p[0]


class Interaction(abc.ABC):
    """The interface every interaction of the momentum equation implements (module docstring)."""

    #: names of the state fields Θ reads at both points (ρ(y) is the integral's weight)
    state_fields: tuple = ()

    @abc.abstractmethod
    def wave_speed_bound(self, state: Mapping) -> float:
        """Upper bound [m/s] of the interaction's wave speed in ``state`` (field name -> array)."""

    @abc.abstractmethod
    def compiled_wave_speed(self):
        """(numba function (rho_max, p) -> c [m/s], p: float64 array): the bound for compiled loops."""

    def describe(self) -> dict:
        """Self-description for output attributes (name, radius, parameters with units)."""
        return self.to_dict()


FAST_INTEGRALS: dict = {}
"""Registered fast paths: kernel function -> compiled whole-array integral (module docstring)."""


def register_fast_integral(kernel_fn, integral) -> None:
    """Register ``integral`` (the signature of
    :func:`bsrflow.numerics.compiled.make_direct_integral`'s result) as the fast path of every
    kernel built on the Python function ``kernel_fn``."""
    if not callable(kernel_fn) or not callable(integral):
        raise ValueError("register_fast_integral needs a kernel function and a compiled integral")
    FAST_INTEGRALS[kernel_fn] = integral


def fast_integral_for(kernel):
    """The fast path registered for ``kernel`` (its own ``fast_integral`` first, then the registry
    by its function), or None."""
    own = getattr(kernel, "fast_integral", None)
    if own is not None:
        return own
    return FAST_INTEGRALS.get(getattr(kernel, "fn", None))


def _max_density(state: Mapping) -> float:
    if "rho" not in state:
        raise ValueError(f"the state has no density field 'rho' (fields: {sorted(state)})")
    rho = np.asarray(state["rho"], float)
    return float(max(np.max(rho), 0.0)) if rho.size else 0.0
