"""Interaction kernels Θ of the BSR momentum equation (3.7), (4.6), (4.13).

The interaction acceleration at x is

    I(x) = ∫_{-R}^{R} ρ(x + z) Θ(z, u(x), u(x + z)) dz                      [m/s²]

with ρ the mass per unit length [kg/m] (per unit volume in n-D), z the offset from the
point to its neighbour [m] and Θ the acceleration that a unit mass of neighbour material
gives a unit mass at x [m s⁻² kg⁻¹].

Writing a new kernel
--------------------
Write one function of ``(z, u_here, u_there, p)`` using only arithmetic and NumPy ufuncs
(``np.abs``, ``np.sign``, ``np.exp``, ...) so that it works both on scalars inside the
compiled loop and on arrays in the NumPy reference, and wrap it::

    import numpy as np
    from bsrflow.physics.kernels import Kernel

    def hertz_like(z, u_here, u_there, p):           # p = (strength, radius)
        return -p[0] * np.sign(z) * np.maximum(p[1] - np.abs(z), 0.0) ** 1.5

    kernel = Kernel(hertz_like, params=[1e3, 0.02], radius=0.02, name="hertz_like")

``Kernel`` compiles it with numba.  Θ must vanish at z = 0 or be continuous there (the
quadrature treats the node z = 0 as carrying no net contribution for odd kernels; see
:mod:`bsrflow.numerics.quadrature`).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field

import numba
import numpy as np

from .interaction import Interaction, compiled_for, linear_wave_speed, one_line, register_fast_integral

__all__ = ["Kernel", "walton_braun", "walton_braun_from_contact", "zero_kernel",
           "dissipation_from_restitution", "restitution_from_dissipation"]


def _walton_braun(z, u_here, u_there, p):
    # p = (λ [1/(kg s²)], ε [-], R [m], orientation [-]: -1 repulsive (default), +1 seed as printed)
    return p[3] * p[0] * (p[2] - np.abs(z)) * np.sign(z) * (1.0 - p[1] * np.sign(z * (u_there - u_here)))


def _zero(z, u_here, u_there, p):
    return 0.0 * z


@dataclass
class Kernel(Interaction):
    """An interaction kernel Θ(z, u_here, u_there; p) with support |z| <= radius: an
    :class:`~bsrflow.physics.interaction.Interaction` that reads the velocity at both points
    and whose wave-speed bound is that of a kernel linear in ρ, c = √(κ max ρ)
    (:meth:`stiffness_moment`).

    Parameters
    ----------
    fn : python function (z, u_here, u_there, p) -> Θ [m s⁻² kg⁻¹], NumPy-ufunc only.  Setting
        ``kernel.fn`` compiles the new function (and drops a ``fast_integral`` given for the old
        one); ``dataclasses.replace(kernel, fn=...)`` compiles it too but keeps a
        ``fast_integral`` given to ``kernel`` (and a ``compiled`` twin given explicitly): pass
        ``fast_integral=None`` (``compiled=None``) with it.  A solver
        built before the change keeps the kernel it was built with.
    params : finite float parameters p (runtime values: changing them does not recompile).
    radius : R [m], the interaction range (the seed's 2r, one particle diameter).
    name : label.
    param_names, param_units : documentation of p, copied into output attributes.
    fast_integral : optional compiled whole-array integral with the signature of
        :func:`bsrflow.numerics.compiled.make_direct_integral`'s result that computes the same
        sum with less work, for this kernel object only; a fast path registered for the
        kernel's function (:func:`bsrflow.physics.interaction.register_fast_integral`, e.g. the
        Walton–Braun algorithm of :mod:`bsrflow.numerics.fast_integral`) is found without it.
        The solver uses it unless asked for the direct sum.
    """

    state_fields = ("u",)

    fn: object
    params: np.ndarray
    radius: float
    name: str = "kernel"
    param_names: tuple = ()
    param_units: tuple = ()
    compiled: object = field(default=None, repr=False)
    fast_integral: object = field(default=None, repr=False)

    def __post_init__(self):
        if not callable(self.fn):
            raise ValueError(f"kernel fn = {self.fn!r} is not a function; give a Python function "
                             "(z, u_here, u_there, p) -> Θ written with NumPy ufuncs")
        if not (np.isfinite(self.radius) and self.radius >= 0):
            raise ValueError(f"kernel radius = {self.radius!r} is outside the valid range [0, inf) m")
        self.compiled = compiled_for(self.fn, self.compiled, _COMPILED, _compile)
        self._kappa = None
        _probe_kernel(self)

    def __setattr__(self, name, value):
        if name == "params":
            value = np.ascontiguousarray(np.atleast_1d(np.asarray(value, dtype=np.float64)))
            if not np.all(np.isfinite(value)):
                raise ValueError(f"kernel params = {value.tolist()!r} must be finite numbers")
        object.__setattr__(self, name, value)
        if name == "fn" and "compiled" in self.__dict__:
            # fn changed after construction: compile the new one; a fast integral given for the
            # old function is not this one's, and κ is measured again
            if not callable(value):
                raise ValueError(f"kernel fn = {value!r} is not a function; give a Python function "
                                 "(z, u_here, u_there, p) -> Θ written with NumPy ufuncs")
            object.__setattr__(self, "compiled", _compile(value))
            object.__setattr__(self, "fast_integral", None)
            object.__setattr__(self, "_kappa", None)
            _probe_kernel(self)

    def __call__(self, z, u_here, u_there):
        """Evaluate Θ with NumPy (arrays broadcast)."""
        return self.fn(np.asarray(z, float), np.asarray(u_here, float), np.asarray(u_there, float),
                       self.params)

    def stiffness_moment(self) -> float:
        """κ = max over relative motions of |∫_{-R}^{R} z Θ(z, ·) dz| [m³ s⁻² kg⁻¹].

        For a uniform state of density ρ the linearised model has sound speed c² = κ ρ
        (Appendix A, corrected; see :mod:`bsrflow.analysis.wavespeed`).  The solver uses
        c = sqrt(κ max ρ) in its CFL bound (:meth:`wave_speed_bound`).  Computed once per
        kernel object (its parameters are fixed for its lifetime).
        """
        key = (self.radius, self.params.tobytes())
        if self._kappa is not None and self._kappa[0] == key:
            return self._kappa[1]
        if self.radius == 0:
            kappa = 0.0
        else:
            z = np.linspace(-self.radius, self.radius, 4001)
            vals = []
            for du in (0.0, 1.0, -1.0):
                f = z * self(z, np.zeros_like(z), du * np.ones_like(z))
                vals.append(abs(np.trapezoid(f, z)))
            kappa = float(max(vals))
        self._kappa = (key, kappa)
        return kappa

    def wave_speed_bound(self, state) -> float:
        """c = √(κ max ρ) [m/s] for the state's density ``state["rho"]`` [kg/m]."""
        from .interaction import _max_density
        return math.sqrt(self.stiffness_moment() * _max_density(state))

    def compiled_wave_speed(self):
        """(:func:`~bsrflow.physics.interaction.linear_wave_speed`, [κ])."""
        return linear_wave_speed, np.array([self.stiffness_moment()])

    def to_dict(self) -> dict:
        return {"name": self.name, "radius": self.radius, "params": self.params.tolist(),
                "param_names": list(self.param_names), "param_units": list(self.param_units)}


_COMPILED: dict = {}
_PROBED: set = set()


def _probe_kernel(kernel) -> None:
    """Evaluate a kernel function once as the solver will (compiled, on scalars, z = 0 included)
    and as the NumPy reference and κ do (on arrays), so that a function numba cannot compile, one
    that only works on scalars, or one that divides by zero at z = 0 is refused here in one line
    (ValueError naming the function) instead of failing inside the time loop with a numba
    traceback.  Once per (function, parameters)."""
    key = (kernel.fn, id(kernel.compiled), kernel.params.tobytes(), float(kernel.radius))
    if kernel.fn in (_walton_braun, _zero) or key in _PROBED:      # the package's own: tested
        return
    name = getattr(kernel.fn, "__name__", repr(kernel.fn))
    R = float(kernel.radius)
    try:
        for z in (0.0, 0.5 * R, -0.5 * R):
            value = kernel.compiled(z, 0.0, 1.0, kernel.params)
            if not isinstance(value, numbers.Real):
                raise TypeError(f"it returned {value!r}, not a number")
    except ZeroDivisionError:
        raise ValueError(f"kernel fn {name}(z, u_here, u_there, p) divides by zero at z = 0; Θ must be "
                         "finite there (np.sign(z) rather than z/|z|)") from None
    except Exception as exc:                                   # numba's typing and lowering errors
        raise ValueError(f"kernel fn {name} cannot be compiled for the time loop (arithmetic and NumPy "
                         f"ufuncs only): {one_line(exc)}") from None
    try:
        z = np.linspace(-R, R, 5)
        values = np.asarray(kernel(z, np.zeros(5), np.ones(5)), dtype=float)
        if np.broadcast_shapes(values.shape, z.shape) != z.shape:
            raise TypeError(f"it returned shape {values.shape} for z of shape {z.shape}")
    except Exception as exc:
        raise ValueError(f"kernel fn {name} must also work on arrays (NumPy ufuncs, no Python if/else on "
                         f"z or u): {one_line(exc)}") from None
    _PROBED.add(key)


def _compile(fn):
    """numba-compile a kernel function once per function object (ValueError, one line, for an
    object numba cannot take: a callable object, a functools.partial)."""
    if fn not in _COMPILED:
        try:
            _COMPILED[fn] = numba.njit(inline="always")(fn)
        except Exception as exc:
            raise ValueError(f"kernel fn {fn!r} cannot be compiled by numba (give a plain Python function): "
                             f"{one_line(exc)}") from None
    return _COMPILED[fn]


def dissipation_from_restitution(e: float) -> float:
    """ε of the kernel factor (1 - ε σ(zΔu)) that gives a binary-contact restitution e.

    A linear contact with stiffness k(1+ε) on approach and k(1-ε) on separation (forces
    proportional to the same overlap) returns the fraction (1-ε)/(1+ε) of the energy, so
    e² = (1-ε)/(1+ε) and ε = (1-e²)/(1+e²).  e = 0.9 gives ε ≈ 0.105.
    """
    if not (0.0 < e <= 1.0):
        raise ValueError(f"restitution e = {e!r} is outside the valid range (0, 1]")
    return (1.0 - e * e) / (1.0 + e * e)


def restitution_from_dissipation(eps: float) -> float:
    """Inverse of :func:`dissipation_from_restitution`."""
    if not (0.0 <= eps < 1.0):
        raise ValueError(f"dissipation eps = {eps!r} is outside the valid range [0, 1)")
    return float(np.sqrt((1.0 - eps) / (1.0 + eps)))


def _register_fast_paths():
    # the Walton–Braun kernel's O(1)-per-cell integral (numerics.fast_integral imports nothing of
    # bsrflow, so this is no import cycle)
    from ..numerics.fast_integral import walton_braun_integral
    register_fast_integral(_walton_braun, walton_braun_integral)


_register_fast_paths()


def walton_braun(strength: float, dissipation: float, radius: float, seed_sign: bool = False) -> Kernel:
    """Bilinear Walton-Braun-type kernel of (4.6) in a repulsive, dissipative convention.

        Θ(z, u_x, u_y) = -λ (R - |z|) σ(z) (1 - ε σ(z (u_y - u_x))),   |z| <= R

    λ = ``strength`` [1/(kg s²)] (the seed's K/(m m0)), ε = ``dissipation`` in [0, 1),
    R = ``radius`` [m] (the seed's 2r = d).

    Sign convention.  z > 0 is a neighbour above.  The factor -σ(z) pushes the point away
    from its neighbours (repulsion in compression: a density bump spreads, c² = λR³ρ/3 > 0).
    z (u_y - u_x) < 0 means the pair approaches (loading): the factor is 1 + ε; separating
    (unloading) it is 1 - ε, so the force is larger on approach than on separation and
    relative motion loses energy.  Split into parts, Θ = -λ(R-|z|)σ(z) + λε(R-|z|)σ(u_y-u_x):
    an elastic part and a friction-like part that pulls u(x) towards its neighbours'
    velocities.  The seed's (4.6) as printed has the opposite overall sign (+λ): with z the
    offset to the neighbour and ρ a mass density that is an attraction towards denser
    material, which is ill-posed (seed-notes problem 1).  ``seed_sign=True`` reproduces it,
    for demonstration only.
    """
    for name, v, lo in (("strength", strength, 0.0), ("radius", radius, 0.0)):
        if not (np.isfinite(v) and v > lo):
            raise ValueError(f"{name} = {v!r} is outside the valid range (0, inf)")
    if not (0.0 <= dissipation < 1.0):
        raise ValueError(f"dissipation = {dissipation!r} is outside the valid range [0, 1)")
    return Kernel(_walton_braun, [strength, dissipation, radius, 1.0 if seed_sign else -1.0], radius,
                  name="walton_braun" + ("_seed_sign" if seed_sign else ""),
                  param_names=("strength", "dissipation", "radius", "orientation"),
                  param_units=("kg-1 s-2", "1", "m", "1"))


def walton_braun_from_contact(stiffness: float, particle_mass: float, m0: float, dissipation: float,
                              radius: float) -> Kernel:
    """The seed's parametrisation λ = K / (m m0) (4.6): K [N/m] contact stiffness, m [kg]
    particle mass, m0 [kg] the "characteristic mass" fitted to DEM, R [m] = d."""
    for name, v in (("stiffness", stiffness), ("particle_mass", particle_mass), ("m0", m0)):
        if not (np.isfinite(v) and v > 0):
            raise ValueError(f"{name} = {v!r} is outside the valid range (0, inf)")
    k = walton_braun(stiffness / (particle_mass * m0), dissipation, radius)
    k.name = "walton_braun"
    return k


def zero_kernel() -> Kernel:
    """No interaction (radius 0): the model reduces to pressureless gas dynamics."""
    return Kernel(_zero, [0.0], 0.0, name="zero")
