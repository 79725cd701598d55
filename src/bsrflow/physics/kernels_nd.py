"""Vector interaction kernels Θ of the n-D BSR momentum equation (3.5), (3.7), and the n-D model.

In the frame of the floor (3.16)-(3.17) the model solved by :mod:`bsrflow.numerics.solver_nd` is

    u_t + (u·∇)u = -g e_z - ϑ''(t) e_z + ∫_{B_R(x)} ρ(y) Θ(y - x, u(x), u(y)) dy      [m/s²]
    ρ_t = -div(ρ u)                                                             [kg/(m^n s)]

with u [m/s] the velocity relative to the floor, ρ [kg/m^n] the density (mass per unit area in
2-D, per unit volume in 3-D; the seed's scaled density ρ̂ = λρ has the constant λ absorbed into
the kernel), g [m/s²] gravity, ϑ(t) [m] the applied vertical floor motion
(:mod:`bsrflow.physics.motion`; its velocity jumps shift u_z, as in the 1-D solver) and Θ
[m s⁻² kg⁻¹] the acceleration that unit mass of neighbour material at offset z = y - x gives to
unit mass at x.  The last axis is the vertical z.

Writing a new kernel
--------------------
Write one function ``fn(z, a, b, p)`` where ``z = (z_x, z_y, z_z)`` is the offset to the
neighbour [m], ``a = (a_x, a_y, a_z)`` the velocity here and ``b`` the velocity there [m/s], and
``p`` a float parameter array; return the three components ``(Θ_x, Θ_y, Θ_z)``.  Use only
arithmetic and NumPy ufuncs so that it works on scalars in the compiled loop and on arrays in the
NumPy reference.  Components are always (x, y, z): in 2-D runs z_y = a_y = b_y = 0 (the x-z
plane) and Θ_y is ignored.  The solver evaluates Θ only for |z| <= R, at the quadrature nodes of
:func:`bsrflow.numerics.grid_nd.ball_quadrature`, including z = 0 where Θ must be 0.

    def soft(z, a, b, p):                       # p = (strength, radius)
        r = np.sqrt(z[0] * z[0] + z[1] * z[1] + z[2] * z[2])
        s = -p[0] * (p[1] - r) ** 2
        return s * z[0], s * z[1], s * z[2]

    kernel = KernelND(soft, params=[1e3, 0.02], radius=0.02, name="soft")
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numba
import numpy as np

from .interaction import Interaction, compiled_for, linear_wave_speed
from .motion import AppliedMotion, Rest

__all__ = ["KernelND", "walton_braun_nd", "BSRModelND", "LINE_RESTRICTIONS"]


def _walton_braun_nd(z, a, b, p):
    # p = (λ [kg⁻¹ s⁻²], ε [-], R [m])
    r = np.sqrt(z[0] * z[0] + z[1] * z[1] + z[2] * z[2])
    dot = z[0] * (b[0] - a[0]) + z[1] * (b[1] - a[1]) + z[2] * (b[2] - a[2])
    # (R - r)/r z is the unit direction times (R - r); at r = 0 the offset is 0 and so is Θ
    s = -p[0] * (p[2] - r) / (r + (r == 0.0)) * (1.0 - p[1] * np.sign(dot))
    return s * z[0], s * z[1], s * z[2]


_COMPILED: dict = {}


def _compile(fn):
    if fn not in _COMPILED:
        _COMPILED[fn] = numba.njit(inline="always")(fn)
    return _COMPILED[fn]


@dataclass
class KernelND(Interaction):
    """A vector interaction kernel Θ(z, u_here, u_there; p) with support |z| <= radius: an
    :class:`~bsrflow.physics.interaction.Interaction` that reads the velocity at both points, with
    the wave-speed bound of a kernel linear in ρ, c = √(n M max ρ) (:meth:`stiffness_moment`; the
    factor n is the central-difference scheme's, see :mod:`bsrflow.numerics.solver_nd`, which uses
    its own discrete M in place of the continuum's).

    Parameters
    ----------
    fn : python function ``(z, a, b, p) -> (Θ_x, Θ_y, Θ_z)`` [m s⁻² kg⁻¹] (module docstring);
        setting ``kernel.fn`` or ``dataclasses.replace(kernel, fn=...)`` compiles the new one.
    params : finite float parameters p (runtime values: changing them does not recompile).
    radius : R [m], the interaction range (one particle diameter).
    name, param_names, param_units : documentation, copied into output attributes.
    """

    fn: object
    params: np.ndarray
    radius: float
    name: str = "kernel_nd"
    param_names: tuple = ()
    param_units: tuple = ()
    compiled: object = field(default=None, repr=False)

    state_fields = ("u",)

    def __post_init__(self):
        if not callable(self.fn):
            raise ValueError(f"kernel fn = {self.fn!r} is not a function (z, a, b, p) -> (Θ_x, Θ_y, Θ_z)")
        self.params = np.ascontiguousarray(np.atleast_1d(np.asarray(self.params, dtype=np.float64)))
        if not np.all(np.isfinite(self.params)):
            raise ValueError(f"kernel params = {self.params.tolist()!r} must be finite numbers")
        if not (np.isfinite(self.radius) and self.radius > 0):
            raise ValueError(f"kernel radius = {self.radius!r} is outside the valid range (0, inf) m")
        self.compiled = compiled_for(self.fn, self.compiled, _COMPILED, _compile)

    def __setattr__(self, name, value):
        object.__setattr__(self, name, value)
        if name == "fn" and "compiled" in self.__dict__:        # changed after construction
            if not callable(value):
                raise ValueError(f"kernel fn = {value!r} is not a function (z, a, b, p) -> (Θ_x, Θ_y, Θ_z)")
            object.__setattr__(self, "compiled", _compile(value))

    def stiffness_moment(self, dim: int, cells: int = 24) -> float:
        """M = max over relative vertical motions b of |∫_B z_z Θ_z(z, 0, b) dz| [m^(n+2) s⁻² kg⁻¹]
        (b = 0, ±e_z m/s) in ``dim`` = 2 or 3 dimensions, by the ball quadrature with ``cells``
        cells per radius (for Walton–Braun πλR⁵/15 in 3-D, πλR⁴/12 in 2-D to 0.2 %)."""
        from ..numerics.grid_nd import ball_quadrature
        o, c, w = ball_quadrature(dim, cells, self.radius / cells)
        c3 = np.zeros((c.shape[0], 3))
        c3[:, 0] = c[:, 0]
        c3[:, 2] = c[:, -1]
        if dim == 3:
            c3[:, 1] = c[:, 1]
        zero = np.zeros(c.shape[0])
        vals = []
        for bz in (0.0, 1.0, -1.0):
            th = self(tuple(c3.T), (zero, zero, zero), (zero, zero, zero + bz))
            vals.append(abs(float(np.sum(w * c3[:, 2] * th[2]))))
        return max(vals)

    def wave_speed_bound(self, state) -> float:
        """c = √(n M max ρ) [m/s]; n from the velocity field ``state["u"]`` (components first)."""
        from .interaction import _max_density
        dim = len(state["u"]) if "u" in state else 3
        return float(np.sqrt(dim * self.stiffness_moment(dim) * _max_density(state)))

    def compiled_wave_speed(self, dim: int = 3, moment: float | None = None):
        """(:func:`~bsrflow.physics.interaction.linear_wave_speed`, [n M]) in ``dim`` dimensions;
        ``moment``: a discretisation's own M in place of the continuum's (the n-D solver passes
        its discrete moment, so the continuum's ball quadrature, seconds on first use, is not
        computed)."""
        m = self.stiffness_moment(dim) if moment is None else float(moment)
        return linear_wave_speed, np.array([float(dim) * m])

    def on_line(self):
        """The kernel restricted to a vertical line, as the 1-D :class:`~bsrflow.physics.kernels.Kernel`
        Θ₁(z, u, u′) = Θ_z((0, 0, z), (0, 0, u), (0, 0, u′)) [m s⁻² kg⁻¹] (the 1-D model of a
        column, :meth:`bsrflow.numerics.grid_nd.GridND.as_grid1d`).  A registered restriction
        (:data:`LINE_RESTRICTIONS`) gives the 1-D kernel with its fast path: Walton–Braun's is the
        1-D Walton–Braun kernel with the same λ, ε, R (equal values, the seed's O(1) integral)."""
        known = LINE_RESTRICTIONS.get(self.fn)
        if known is not None:
            return known(self)
        return _generic_line_kernel(self)

    def __call__(self, z, a, b):
        """Evaluate Θ with NumPy; z, a, b are 3-sequences of arrays (broadcast)."""
        f = lambda v: tuple(np.asarray(c, float) for c in v)  # noqa: E731
        return self.fn(f(z), f(a), f(b), self.params)

    def to_dict(self) -> dict:
        return {"name": self.name, "radius": self.radius, "params": self.params.tolist(),
                "param_names": list(self.param_names), "param_units": list(self.param_units)}


_LINE_FUNCTIONS: dict = {}
"""(NumPy, compiled) restrictions to the vertical line, once per n-D kernel's compiled function
(a new pair per call meant a new compile, and a new check of the 1-D kernel, per solver)."""


def _generic_line_kernel(k: "KernelND"):
    from .kernels import Kernel
    fn, cf = k.fn, k.compiled
    if cf not in _LINE_FUNCTIONS:
        def on_line(z, u_here, u_there, p):
            o = 0.0 * z
            return fn((o, o, z), (0.0 * u_here, 0.0 * u_here, u_here), (0.0 * u_there, 0.0 * u_there, u_there), p)[2]

        @numba.njit(inline="always")
        def on_line_compiled(z, u_here, u_there, p):
            return cf((0.0, 0.0, z), (0.0, 0.0, u_here), (0.0, 0.0, u_there), p)[2]

        _LINE_FUNCTIONS[cf] = (on_line, on_line_compiled)
    on_line, on_line_compiled = _LINE_FUNCTIONS[cf]
    return Kernel(on_line, k.params.copy(), k.radius, name=f"{k.name}_on_line", param_names=k.param_names,
                  param_units=k.param_units, compiled=on_line_compiled)


def _walton_braun_on_line(k: "KernelND"):
    from .kernels import walton_braun
    return walton_braun(float(k.params[0]), float(k.params[1]), float(k.params[2]))


LINE_RESTRICTIONS: dict = {}
"""Registered restrictions of n-D kernels to a line: kernel function -> (KernelND -> 1-D Kernel)."""


def walton_braun_nd(strength: float, dissipation: float, radius: float) -> KernelND:
    """Vector Walton-Braun-type kernel: a central, repulsive, dissipative pair force.

        Θ(z, u_x, u_y) = -λ (R - |z|) (z/|z|) (1 - ε σ(z·(u_y - u_x))),   0 < |z| <= R,
        Θ(0, ·, ·) = 0,

    λ = ``strength`` [kg⁻¹ s⁻²], ε = ``dissipation`` in [0, 1), R = ``radius`` [m].  The force
    acts along the line between the points and pushes x away from y (repulsion in compression);
    while the pair approaches, z·(u_y - u_x) < 0 and the factor is 1 + ε (loading), while it
    separates 1 - ε (unloading), so relative normal motion loses energy.  This is the n-D form of
    :func:`bsrflow.physics.kernels.walton_braun` (same sign convention, seed-notes problem 1).
    For a uniform state the linearised model has sound speed c² = M ρ with
    M = -∫_B z_z Θ_z dz = πλR⁵/15 (3-D), πλR⁴/12 (2-D) (the ε-part cancels).
    """
    for name, v in (("strength", strength), ("radius", radius)):
        if not (np.isfinite(v) and v > 0):
            raise ValueError(f"{name} = {v!r} is outside the valid range (0, inf)")
    if not (0.0 <= dissipation < 1.0):
        raise ValueError(f"dissipation = {dissipation!r} is outside the valid range [0, 1)")
    return KernelND(_walton_braun_nd, [strength, dissipation, radius], radius, name="walton_braun_nd",
                    param_names=("strength", "dissipation", "radius"),
                    param_units=("kg-1 s-2", "1", "m"))


@dataclass
class BSRModelND:
    """The physics of an n-D BSR run (module docstring).

    kernel : :class:`KernelND`.
    motion : applied vertical floor motion ϑ(t) (default: rest).
    gravity : g [m/s²], acting towards -z (default 0).
    """

    kernel: KernelND
    motion: AppliedMotion = field(default_factory=Rest)
    gravity: float = 0.0

    def __post_init__(self):
        if not isinstance(self.kernel, KernelND):
            raise ValueError(f"kernel = {self.kernel!r} must be a KernelND (see walton_braun_nd)")
        if not np.isfinite(self.gravity):
            raise ValueError(f"gravity = {self.gravity!r} must be finite (m/s^2)")
        self.gravity = float(self.gravity)

    def to_dict(self) -> dict:
        return {"kernel": self.kernel.to_dict(), "motion": self.motion.to_dict(), "gravity": self.gravity}


LINE_RESTRICTIONS[_walton_braun_nd] = _walton_braun_on_line
