"""Uniform 2-D and 3-D cell-centred grids, their boundary conditions, and the quadrature of
the interaction integral over the ball |z| <= R (the n-D model (3.7)).

Grid
----
Cells are cubes (squares in 2-D) of side Δx [m]; the centre of cell j = (j_1, ..., j_n) is
``x_j = lower + (j + 1/2) Δx``.  Axes are (x, z) in 2-D and (x, y, z) in 3-D: the *last* axis
is the vertical, gravity acts towards -z.  The state is the density ρ [kg/m^n] and the
velocity vector u [m/s] with one component per axis.

Boundary conditions act through ghost cells (as in :mod:`bsrflow.numerics.grid`):

``periodic`` (horizontal axes; or both vertical ends)
    ghosts wrap around.
``wall`` (horizontal axes)
    a mirror wall at each end of the axis: ρ is reflected evenly, the normal velocity
    component oddly, the tangential components evenly.  The image material pushes back
    through the interaction integral, no mass crosses the wall.
``floor`` (bottom end of the vertical axis; default)
    the supporting floor of the 1-D solver (:mod:`bsrflow.numerics.grid`), column by column:
    the velocity is reflected (u_z odd, tangential u even); for the interaction integral the
    density is reflected point-symmetrically through its value extrapolated to the floor,
    ρ(-s) = max(0, 2 ρ_w - ρ(s)) with ρ_w = (3 ρ_0 - ρ_1)/2 in each column, so the images
    continue the density gradient and a resting layer is held up; the mass flux through the
    floor and the moving average use the even image ρ_{-1} = ρ_0 (zero flux, mass conserved).
``mirror`` (bottom)
    plain mirror images: ρ even (also in the integral), u_z odd, tangential u even.  The
    interaction force vanishes at such a wall, so material near it is not held up against
    gravity (see grid.py); kept for comparison.
``vacuum`` (top end; or bottom)
    open end into empty space: ghost ρ = 0, ghost u copied from the last cell (all
    components), the seed's (4.30).

Ghost values are products of the per-axis rules (a corner ghost of a wall and the floor is
the image in both), so every padded cell is a transformed copy of one interior cell (the
floor's density images use the two lowest cells of the source column).
:meth:`GridND.ghost_maps` gives, per axis, the interior source index, the sign of the
normal velocity component and whether the density is zeroed, for every padded index, and
flags the floor ghosts.

Quadrature of the interaction integral
--------------------------------------
The integral ∫_{B_R(x)} ρ(y) Θ(y - x, u(x), u(y)) dy (3.7) is approximated by a sum over the
grid cells j + o whose cells meet the ball, R = W Δx with W a whole number of cells:

    I_j ≈ Σ_o w_o ρ_{j+o} Θ(c_o, u_j, u_{j+o}),

with w_o = |C_o ∩ B_R| the volume [m^n] of the part of the offset cell C_o = o Δx + [-Δx/2,
Δx/2]^n inside the ball, and the node c_o [m] the centroid of that part (a one-point rule per
cut cell, exact for integrands linear on each piece; the centroid of a convex piece of the
ball lies in the ball, so c_o never leaves the kernel's support).  For cells wholly inside
the ball w_o = Δx^n and c_o = o Δx.  The centre cell's node is c_0 = 0, where the kernels
vanish (they are odd in z, so the centre cell's exact contribution is zero as well).

Volumes and centroids are computed once per (dimension, W) by sub-sampling: midpoint rule
with m points per axis on all axes but one, and the exact chord length (and its first
moment) along the remaining axis.  They are computed for one canonical cell of each class
(non-negative offsets in decreasing order) and copied to the others by sign changes and
permutations, so the table is *exactly* (bitwise) symmetric under reflections and
permutations of the axes.  Sampling points: m = 20000 (2-D), m = 400 (3-D).

Accuracy (measured with ``ball_quadrature_accuracy``).  Sub-sampling: the total weight
equals the ball volume πW² resp. 4πW³/3 (cell units) to 3e-8 resp. 1.2e-6 relative for
W = 2 (smaller for larger W).  The one-point rule itself is second order: for the second
moment ∫_B z_z² dz, which sets the sound speed of the Walton-Braun kernel, the table is low
by 7.0 %, 3.4 %, 1.9 %, 0.50 % (2-D) and 8.8 %, 4.2 %, 2.4 %, 0.63 % (3-D) for
W = 2, 3, 4, 8 (the within-cell variance Δx²/12 per cell is missing), i.e. O(W⁻²).
The sub-sampling error is therefore negligible against the rule's own error.
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass

import numpy as np

__all__ = ["GridND", "ball_quadrature", "ball_quadrature_accuracy", "BC_CODES_ND"]

BC_CODES_ND = {"periodic": 0, "wall": 1, "mirror": 1, "vacuum": 2, "floor": 3}
_HORIZONTAL = ("periodic", "wall")
_LOWER = ("floor", "mirror", "vacuum", "periodic")
_UPPER = ("vacuum", "periodic")


@dataclass(frozen=True)
class GridND:
    """Uniform cell-centred grid in 1-D (z: a column), 2-D (x, z) or 3-D (x, y, z), z vertical.

    Parameters
    ----------
    shape : cells per axis, (n_z,), (n_x, n_z) or (n_x, n_y, n_z); each >= 3.  A column is run
        by the 1-D solver's discretisation (:meth:`as_grid1d`,
        :class:`bsrflow.numerics.solver_nd.SimulationND`).
    dx : cell side Δx [m], the same on every axis.
    lower : position of the lower corner [m] (default: the origin).
    bc_horizontal : 'periodic' or 'wall', one for all horizontal axes or one per axis.
    bc_lower : bottom of the vertical axis: 'floor' (default), 'mirror', 'vacuum' or 'periodic'.
    bc_upper : top: 'vacuum' (default) or 'periodic' (only with a periodic bottom).
    """

    shape: tuple
    dx: float
    lower: tuple | None = None
    bc_horizontal: object = "periodic"
    bc_lower: str = "floor"
    bc_upper: str = "vacuum"

    def __post_init__(self):
        try:
            shape = tuple(int(s) if int(s) == s else s for s in np.atleast_1d(self.shape).tolist())
        except (TypeError, ValueError, OverflowError):
            raise ValueError(f"shape = {self.shape!r} is outside the valid range: integers >= 3 per axis") from None
        if len(shape) not in (1, 2, 3):
            raise ValueError(f"shape = {self.shape!r}: need 1 (z), 2 (x, z) or 3 (x, y, z) cell counts")
        for s in shape:
            if not isinstance(s, int) or s < 3:
                raise ValueError(f"shape = {self.shape!r} is outside the valid range: integers >= 3 per axis")
        object.__setattr__(self, "shape", shape)
        if (isinstance(self.dx, (bool, np.bool_)) or not isinstance(self.dx, (int, float, np.integer, np.floating))
                or not (np.isfinite(self.dx) and self.dx > 0)):
            raise ValueError(f"dx = {self.dx!r} is outside the valid range (0, inf) m")
        object.__setattr__(self, "dx", float(self.dx))
        lower = (0.0,) * len(shape) if self.lower is None else tuple(float(v) for v in self.lower)
        if len(lower) != len(shape) or not all(np.isfinite(lower)):
            raise ValueError(f"lower = {self.lower!r}: need {len(shape)} finite coordinates (m)")
        object.__setattr__(self, "lower", lower)
        bh = self.bc_horizontal
        if len(shape) == 1:            # a column: no horizontal axis (the default is accepted)
            if not (bh == "periodic" or (not isinstance(bh, str) and len(tuple(bh)) == 0)):
                raise ValueError(f"bc_horizontal = {bh!r}: a column (1-D grid) has no horizontal axis")
            bh = ()
        bh = (bh,) * (len(shape) - 1) if isinstance(bh, str) else tuple(bh)
        if len(bh) != len(shape) - 1 or any(b not in _HORIZONTAL for b in bh):
            raise ValueError(f"bc_horizontal = {self.bc_horizontal!r}: need one of {_HORIZONTAL} "
                             f"(or a tuple of {len(shape) - 1} of them)")
        object.__setattr__(self, "bc_horizontal", bh)
        if self.bc_lower not in _LOWER:
            raise ValueError(f"bc_lower = {self.bc_lower!r} is not one of {_LOWER}")
        if self.bc_upper not in _UPPER:
            raise ValueError(f"bc_upper = {self.bc_upper!r} is not one of {_UPPER}")
        if (self.bc_lower == "periodic") != (self.bc_upper == "periodic"):
            raise ValueError("bc_lower and bc_upper must both be 'periodic' or neither")

    # -- geometry -------------------------------------------------------------------------
    @property
    def dim(self) -> int:
        return len(self.shape)

    @property
    def upper(self) -> tuple:
        """Upper corner [m]."""
        return tuple(lo + n * self.dx for lo, n in zip(self.lower, self.shape))

    @property
    def n_cells(self) -> int:
        return int(np.prod(self.shape))

    @property
    def cell_volume(self) -> float:
        """Δx^n [m^n]."""
        return self.dx ** self.dim

    def centres(self, axis: int) -> np.ndarray:
        """Cell-centre coordinates along one axis [m]."""
        return self.lower[axis] + (np.arange(self.shape[axis]) + 0.5) * self.dx

    @property
    def z(self) -> np.ndarray:
        """Cell-centre heights above the grid's lower end [m] (vertical axis)."""
        return self.centres(self.dim - 1)

    def mesh(self) -> tuple:
        """Cell-centre coordinate arrays, one per axis, each of ``shape`` [m]."""
        return tuple(np.meshgrid(*[self.centres(a) for a in range(self.dim)], indexing="ij"))

    def as_grid1d(self):
        """The 1-D grid of a column (dim = 1): :class:`bsrflow.numerics.grid.Grid1D` on the same
        cells with the same boundary conditions (the 1-D solver's discretisation)."""
        from .grid import Grid1D
        if self.dim != 1:
            raise ValueError(f"as_grid1d: the grid has {self.dim} dimensions, not 1")
        return Grid1D(self.lower[0], self.upper[0], self.shape[0], self.bc_lower, self.bc_upper)

    # -- internal 3-axis layout (2-D runs as x, y, z with n_y = 1 and no y neighbours) ------
    @property
    def shape3(self) -> tuple:
        """(n_x, n_y, n_z), with n_y = 1 in 2-D."""
        return self.shape if self.dim == 3 else (self.shape[0], 1, self.shape[1])

    def axis_codes(self) -> list:
        """[(code_lower, code_upper)] for the internal axes x, y, z (see ``BC_CODES_ND``)."""
        bh = list(self.bc_horizontal)
        if self.dim == 2:
            bh = [bh[0], "periodic"]
        out = [(BC_CODES_ND[b], BC_CODES_ND[b]) for b in bh]
        out.append((BC_CODES_ND[self.bc_lower], BC_CODES_ND[self.bc_upper]))
        return out

    def ghost_widths(self, W: int) -> tuple:
        """Ghost layers (G_x, G_y, G_z) for a ball radius of W cells (G_y = 0 in 2-D)."""
        G = max(int(W), 1)
        return (G, G if self.dim == 3 else 0, G)

    def ghost_maps(self, W: int):
        """Per internal axis a, arrays over the padded index q (0 .. n_a + 2 G_a - 1):
        ``src[a][q]`` interior source index, ``sign[a][q]`` (±1.0) factor of the velocity
        component normal to axis a, ``keep[a][q]`` (1.0 or 0.0) factor of the density; and
        ``prz[q]`` (1.0 or 0.0): the density of this z ghost is the floor's point reflection."""
        srcs, signs, keeps = [], [], []
        prz = None
        for a, (G, n, (lo, hi)) in enumerate(zip(self.ghost_widths(W), self.shape3, self.axis_codes())):
            q = np.arange(n + 2 * G)
            m = q - G
            src = m.copy()
            sign = np.ones(q.size)
            keep = np.ones(q.size)
            pr = np.zeros(q.size)
            for side, code in (("lo", lo), ("hi", hi)):
                sel = m < 0 if side == "lo" else m >= n
                if code == 0:
                    src[sel] = m[sel] % n
                elif code in (1, 3):
                    src[sel] = (-m[sel] - 1) if side == "lo" else (2 * n - 1 - m[sel])
                    sign[sel] = -1.0
                    if code == 3:
                        pr[sel] = 1.0
                else:
                    src[sel] = 0 if side == "lo" else n - 1
                    keep[sel] = 0.0
            if np.any(src < 0) or np.any(src >= n):
                raise ValueError(f"shape = {self.shape!r}: axis {a} has {n} cells, fewer than the "
                                 f"{G} ghost layers a mirror boundary needs (the kernel radius in cells)")
            srcs.append(src.astype(np.int64))
            signs.append(sign)
            keeps.append(keep)
            prz = pr
        return srcs, signs, keeps, prz

    def to_dict(self) -> dict:
        return {"shape": list(self.shape), "dx": self.dx, "lower": list(self.lower),
                "bc_horizontal": list(self.bc_horizontal), "bc_lower": self.bc_lower,
                "bc_upper": self.bc_upper}


# ---- quadrature over the ball ------------------------------------------------------------
_SAMPLES = {2: 20000, 3: 400}


def _cut_cell(canon, W, m):
    """Volume and centroid (cell units) of ([c - 1/2, c + 1/2]^n) ∩ B_W for one canonical
    offset (non-negative, decreasing).  Midpoint rule with m points on the first n-1 axes,
    exact chord along the last."""
    n = len(canon)
    grids = np.meshgrid(*[canon[a] - 0.5 + (np.arange(m) + 0.5) / m for a in range(n - 1)], indexing="ij")
    r2 = sum(g * g for g in grids)
    h = np.sqrt(np.maximum(W * W - r2, 0.0))
    c = canon[-1]
    hi = np.minimum(c + 0.5, h)
    lo = np.maximum(c - 0.5, -h)
    length = np.maximum(hi - lo, 0.0)
    moment_last = np.where(length > 0, 0.5 * (hi * hi - lo * lo), 0.0)
    cell = 1.0 / m ** (n - 1)
    vol = length.sum() * cell
    cen = np.zeros(n)
    if vol > 0:
        for a in range(n - 1):
            cen[a] = (grids[a] * length).sum() * cell / vol
        cen[-1] = moment_last.sum() * cell / vol
    # exact symmetry: a zero offset has its centroid on the symmetry plane, and equal offsets
    # have equal centroid components (the sampled and the exact axis differ by ~1e-9)
    for a in range(n):
        if canon[a] == 0:
            cen[a] = 0.0
    for v in set(canon):
        idx = [a for a in range(n) if canon[a] == v]
        if len(idx) > 1:
            cen[idx] = cen[idx].sum() / len(idx)
    return vol, cen


@functools.lru_cache(maxsize=32)
def _ball_table(dim: int, W: int):
    m = _SAMPLES[dim]
    canon_cache = {}
    offs, nodes, wts = [], [], []
    rng = range(-W, W + 1)
    for o in itertools.product(rng, repeat=dim):
        a = np.abs(np.array(o))
        if sum(max(0.0, x - 0.5) ** 2 for x in a) >= W * W:
            continue                               # the cell does not meet the open ball
        order = np.argsort(-a, kind="stable")      # canonical: decreasing absolute offsets
        canon = tuple(int(v) for v in a[order])
        if canon not in canon_cache:
            if max(canon) == 0:
                canon_cache[canon] = (1.0, np.zeros(dim))
            elif sum((x + 0.5) ** 2 for x in canon) <= W * W:
                canon_cache[canon] = (1.0, np.array(canon, float))   # wholly inside
            else:
                canon_cache[canon] = _cut_cell(canon, W, m)
        vol, cen_c = canon_cache[canon]
        if vol <= 0.0:
            continue
        cen = np.empty(dim)
        cen[order] = cen_c                          # undo the permutation
        cen = np.where(np.array(o) < 0, -cen, cen)  # undo the sign changes (exact)
        offs.append(o)
        nodes.append(cen)
        wts.append(vol)
    return np.array(offs, np.int64), np.array(nodes), np.array(wts)


def ball_quadrature(dim: int, W: int, dx: float = 1.0):
    """Offsets o (M, dim) [cells], nodes c_o (M, dim) [m] and weights w_o (M,) [m^dim] of the
    ball quadrature of radius R = W Δx (module docstring).  ``dx`` scales to metres."""
    if dim not in (2, 3):
        raise ValueError(f"dim = {dim!r} is outside the valid range {{2, 3}}")
    if int(W) != W or W < 1:
        raise ValueError(f"W = {W!r} (kernel radius in cells) is outside the valid range: integers >= 1")
    o, c, w = _ball_table(int(dim), int(W))
    return o.copy(), c * dx, w * dx ** dim


def ball_quadrature_accuracy(dim: int, W: int) -> dict:
    """Relative error of the table's total weight against the exact ball volume, and of the
    second moment Σ w c_z² against ∫_B z_z² dz (cell units)."""
    o, c, w = ball_quadrature(dim, W)
    if dim == 2:
        vol, mom = math.pi * W ** 2, math.pi * W ** 4 / 4
    else:
        vol, mom = 4 * math.pi * W ** 3 / 3, 4 * math.pi * W ** 5 / 15
    return {"volume_rel_error": float(w.sum() / vol - 1.0),
            "second_moment_rel_error": float((w * c[:, -1] ** 2).sum() / mom - 1.0)}
