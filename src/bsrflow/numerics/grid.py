"""Uniform 1-D grids and boundary conditions.

The grid is cell-centred: ``x_j = lower + (j + 1/2) Δx``, ``j = 0..N-1``, ``Δx = (upper-lower)/N``
[m].  Boundary conditions act through ghost values beyond each end:

``periodic``
    ghosts wrap around; both ends must be periodic.
``floor`` (lower end only)
    an impenetrable, supporting wall at ``x = lower``.  The velocity is reflected oddly,
    ``u(lower - s) = -u(lower + s)`` (images approach the floor when the material does, so the
    kernel's loading/unloading sees the impact), and for the interaction integral the density
    is reflected point-symmetrically through its value extrapolated to the wall,
    ``ρ(lower - s) = max(0, 2 ρ_w - ρ(lower + s))`` with ``ρ_w = (3ρ_0 - ρ_1)/2``: the images
    continue the density gradient, so the floor pushes back through the kernel exactly as the
    material below a point in a resting column would, and a hydrostatic column is supported.
    The mass flux through the floor is zero (the flux and the moving average use the even
    image ρ_{-1} = ρ_0), so mass is conserved exactly.
``mirror`` (lower end only)
    plain mirror images, ρ even and u odd, also in the integral.  By symmetry the interaction
    force vanishes at the wall, so the material within the kernel radius of the floor is not
    held up against gravity: a resting column sinks into a dense wall layer.  Kept for
    comparison (seed-notes problem 4 suggested it; the measurement rules it out for columns).
``vacuum``
    an open end into empty space: ghost density 0, ghost velocity copied from the last
    cell (the seed's (4.30): ρ_N = 0, u_N = u_{N-1}).  No mass enters; mass in the last cell
    can leave.  The domain must be tall enough that the material never gets there (the
    solver checks this and stops with an error naming the time if it does).
``dirichlet``
    ghost values (u, ρ) given by the model's ``boundary_values(t, x, p)`` function, e.g. an
    exact solution as inflow data (verification Example A).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Grid1D", "BOUNDARY_CODES", "spread_over_bins"]

BOUNDARY_CODES = {"periodic": 0, "floor": 1, "vacuum": 2, "dirichlet": 3, "mirror": 4}


@dataclass(frozen=True)
class Grid1D:
    """Uniform cell-centred grid on [lower, upper] [m] with ``n_cells`` cells and the
    boundary conditions at each end (see module docstring)."""

    lower: float
    upper: float
    n_cells: int
    bc_lower: str = "periodic"
    bc_upper: str = "periodic"

    def __post_init__(self):
        for name in ("lower", "upper"):
            v = getattr(self, name)
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
                raise ValueError(f"{name} = {v!r} must be a number [m], not {type(v).__name__}")
        n = self.n_cells
        if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, float, np.integer, np.floating)):
            raise ValueError(f"n_cells = {n!r} is outside the valid range: integers >= 3 (got {type(n).__name__})")
        if not (np.isfinite(self.lower) and np.isfinite(self.upper) and self.upper > self.lower):
            raise ValueError(f"grid bounds lower = {self.lower!r}, upper = {self.upper!r}: "
                             "need finite values with upper > lower")
        if not np.isfinite(self.n_cells) or int(self.n_cells) != self.n_cells or self.n_cells < 3:
            raise ValueError(f"n_cells = {self.n_cells!r} is outside the valid range: integers >= 3")
        for name, v in (("bc_lower", self.bc_lower), ("bc_upper", self.bc_upper)):
            if v not in BOUNDARY_CODES:
                raise ValueError(f"{name} = {v!r} is not one of {sorted(BOUNDARY_CODES)}")
        if (self.bc_lower == "periodic") != (self.bc_upper == "periodic"):
            raise ValueError("bc_lower and bc_upper must both be 'periodic' or neither")
        if self.bc_upper in ("floor", "mirror"):
            raise ValueError(f"bc_upper = {self.bc_upper!r} is not supported: the floor is the lower end")

    @property
    def dx(self) -> float:
        """Cell width Δx [m]."""
        return (self.upper - self.lower) / self.n_cells

    @property
    def x(self) -> np.ndarray:
        """Cell centres [m]."""
        return self.lower + (np.arange(self.n_cells) + 0.5) * self.dx

    @property
    def length(self) -> float:
        return self.upper - self.lower

    @property
    def codes(self) -> tuple[int, int]:
        return BOUNDARY_CODES[self.bc_lower], BOUNDARY_CODES[self.bc_upper]

    def cells_per(self, length: float) -> float:
        """How many cells span ``length`` [m]."""
        return length / self.dx

    def to_dict(self) -> dict:
        return {"lower": self.lower, "upper": self.upper, "n_cells": self.n_cells,
                "bc_lower": self.bc_lower, "bc_upper": self.bc_upper}


def spread_over_bins(faces, edges, *amounts):
    """Each cell's amount (cells between the increasing ``faces`` [m], n + 1 of them), spread evenly
    over its height, summed per bin between the increasing ``edges`` [m]: one array per array of
    ``amounts`` (n each), of len(edges) − 1.  Every (cell, bin) overlap is one piece of the merged
    partition of the two sets of edges, so the cost is O(n + bins) and each bin's sum runs over
    its cells from the bottom up (the same sums as the dense cells × bins formula, which took
    minutes and gigabytes on a tall grid; a fuzzing review)."""
    faces = np.asarray(faces, dtype=float)
    edges = np.asarray(edges, dtype=float)
    pts = np.union1d(faces, edges)
    low = pts[:-1]                       # each piece's lower end: a face or an edge itself, so its cell and
    n, nb = faces.size - 1, edges.size - 1             # bin are found exactly (a midpoint rounds on slivers)
    cell = np.searchsorted(faces, low, side="right") - 1
    b = np.searchsorted(edges, low, side="right") - 1
    keep = (cell >= 0) & (cell < n) & (b >= 0) & (b < nb)
    cell, b = cell[keep], b[keep]
    frac = np.diff(pts)[keep] / (faces[cell + 1] - faces[cell])
    return tuple(np.bincount(b, np.asarray(a, dtype=float)[cell] * frac, minlength=nb).astype(float, copy=False)
                 for a in amounts)

