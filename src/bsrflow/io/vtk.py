"""VTK output of 1-D / 2-D / 3-D fields for ParaView, beside the netCDF file (issue #19).

:class:`VTKWriter` is an observer ``obs(t, u, rho, tracers)`` of
:meth:`bsrflow.numerics.solver_nd.SimulationND.run`.  Every snapshot becomes one VTK XML
unstructured-grid file ``<stem>_<k>.vtu`` (written by meshio: hexahedral cells in 3-D,
quadrilaterals in 2-D, line segments along z for a column, the grid's cells exactly) and the collection ``<stem>.pvd`` lists them with
their times, so ParaView opens the whole run as one time series.

Fields (cell data; VTK has no units attribute, so the unit is part of the name):

=====================  ===========  =============================================
name                   units        meaning
=====================  ===========  =============================================
``density [kg/m^3]``   kg/m³        ρ (2-D runs of the seed's kernel: ``density [kg/m^2]``, a planar continuum;
                                    a 2-D packing bed: ``density [kg/m^3]``, uniform in depth;
                                    a column: ``density [kg/m]``, per unit length)
``velocity [m/s]``     m/s          (u_x, u_y, u_z) relative to the floor (2-D: u_y = 0;
                                    a column: (0, 0, u))
=====================  ===========  =============================================

Tracers (a run with tracers): one more file per snapshot, ``<stem>_tracers_<k>.vtu``, with the
tracers as points (VTK vertices) and their index as the point field ``tracer [1]``; the ``.pvd``
lists them as part 1 of each time step, beside the fields (part 0).

The vibrated bed on its Eulerian grid (``kind = "granular_bed_eulerian"``,
:meth:`bsrflow.numerics.bed_eulerian.EulerianBed.vtk_fields`) writes its own fields through
:meth:`VTKWriter.write_fields`: ``solid fraction [1]``, ``velocity [m/s]``, ``granular temperature
[m^2/s^2]``, on cells of its own sizes (the grid's ``dx`` may give one size per axis).

Coordinates [m]: the floor frame, z vertical (a 2-D run's (x, z) plane is put at y = 0, so z
stays vertical in ParaView; a column is the z axis at x = y = 0).  The times [s] are those of the ``.pvd`` collection (``timestep``);
the floor's lab position ϑ(t) [m] is in the run's netCDF file (``floor``).

Crash safety: each ``.vtu`` and the ``.pvd`` are written to a temporary file and renamed over
the target, so a killed run leaves complete files for every snapshot written so far.
"""

from __future__ import annotations

import os
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

__all__ = ["VTKWriter", "density_name", "VELOCITY_NAME"]

VELOCITY_NAME = "velocity [m/s]"


def density_name(dim: int, per_depth: bool = False) -> str:
    """The density field's name in a ``dim``-D run's files (``per_depth``: a 2-D run of a 3-D
    material uniform in depth, the packing bed, whose density is per unit volume)."""
    if dim == 2 and per_depth:
        return "density [kg/m^3]"
    return "density [kg/m]" if dim == 1 else f"density [kg/m^{dim}]"


def _replace_atomically(path: Path, write) -> None:
    tmp = path.with_name(f"{path.name}.tmp{os.getpid()}{path.suffix}")
    try:
        write(tmp)
        os.replace(tmp, path)
    except OSError as exc:                  # name the file (meshio's writes name none)
        raise OSError(exc.errno, f"cannot write the VTK file ({exc.strerror or exc})", str(path)) from exc
    finally:
        if tmp.exists():
            tmp.unlink()


class VTKWriter:
    """Write every snapshot of an n-D run as VTK (module docstring).

    grid : :class:`bsrflow.numerics.grid_nd.GridND`; stem : output path without suffix (its
    folder must exist).
    Call ``writer(t, u, rho, tracers=None)`` at every save (u (n, *shape) [m/s], rho (*shape)
    [kg/m^n], tracers (n_tr, n) [m] floor frame or None; user layout).  ``files`` lists the ``.vtu`` written, ``pvd`` is the collection file."""

    def __init__(self, grid, stem, per_depth: bool = False):
        import meshio  # noqa: F401  (fail here, before the run, if it is missing)

        self.grid = grid
        self.dim = int(grid.dim)
        self.per_depth = bool(per_depth)
        if self.dim not in (1, 2, 3):
            raise ValueError(f"VTK output needs a 1-D, 2-D or 3-D grid (grid.dim = {self.dim})")
        self.stem = Path(os.fspath(stem))
        if not self.stem.parent.is_dir():
            raise ValueError(f"VTK output {self.stem}: folder {self.stem.parent} does not exist")
        self.pvd = Path(f"{self.stem}.pvd")
        self.files: list[Path] = []
        self.times: list[float] = []
        self.tracer_files: list[Path | None] = []
        self._points, self._cells = self._mesh()

    def _mesh(self):
        """Points (the cell corners, as (x, y, z) [m]) and the cell connectivity of the grid."""
        g = self.grid
        spacing = np.broadcast_to(np.asarray(g.dx, dtype=float), (self.dim,))     # one Δx, or one per axis
        edges = [g.lower[a] + np.arange(g.shape[a] + 1) * spacing[a] for a in range(self.dim)]
        if self.dim == 1:
            nz = g.shape[0]
            points = np.zeros((nz + 1, 3))
            points[:, 2] = edges[0]
            return points, [("line", np.column_stack([np.arange(nz), np.arange(1, nz + 1)]))]
        if self.dim == 2:
            nx, nz = g.shape
            X, Z = np.meshgrid(edges[0], edges[1], indexing="ij")
            points = np.column_stack([X.ravel(), np.zeros(X.size), Z.ravel()])
            idx = np.arange(points.shape[0]).reshape(nx + 1, nz + 1)
            i, k = np.meshgrid(np.arange(nx), np.arange(nz), indexing="ij")
            quads = np.stack([idx[i, k], idx[i + 1, k], idx[i + 1, k + 1], idx[i, k + 1]], axis=-1)
            return points, [("quad", quads.reshape(-1, 4))]
        nx, ny, nz = g.shape
        X, Y, Z = np.meshgrid(*edges, indexing="ij")
        points = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])
        idx = np.arange(points.shape[0]).reshape(nx + 1, ny + 1, nz + 1)
        i, j, k = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij")
        hexa = np.stack([idx[i, j, k], idx[i + 1, j, k], idx[i + 1, j + 1, k], idx[i, j + 1, k],
                         idx[i, j, k + 1], idx[i + 1, j, k + 1], idx[i + 1, j + 1, k + 1], idx[i, j + 1, k + 1]],
                        axis=-1)
        return points, [("hexahedron", hexa.reshape(-1, 8))]

    def cell_fields(self, u, rho) -> dict:
        """The cell data of one snapshot, in the cells' order (C order of the grid's axes)."""
        rho = np.asarray(rho, dtype=float)
        u = np.asarray(u, dtype=float)
        if rho.shape != tuple(self.grid.shape) or u.shape != (self.dim,) + tuple(self.grid.shape):
            raise ValueError(f"VTK output: rho {rho.shape} / u {u.shape} do not match the grid {self.grid.shape}")
        vel = np.zeros((rho.size, 3))
        if self.dim == 1:
            vel[:, 2] = u[0]
        elif self.dim == 2:
            vel[:, 0], vel[:, 2] = u[0].ravel(), u[1].ravel()
        else:
            vel[:] = u.reshape(3, -1).T
        return {density_name(self.dim, self.per_depth): rho.ravel(), VELOCITY_NAME: vel}

    def __call__(self, t, u, rho, tracers=None):
        self.write_fields(t, self.cell_fields(u, rho), tracers)

    def write_fields(self, t, fields: dict, tracers=None):
        """Write one snapshot of named cell fields (``{"name [unit]": values}``, values of the
        grid's cells in C order, (n_cells,) or (n_cells, 3)) at time t [s]."""
        import meshio

        t = float(t)
        k = len(self.files)
        path = Path(f"{self.stem}_{k:06d}.vtu")
        mesh = meshio.Mesh(self._points, self._cells, cell_data={n: [v] for n, v in fields.items()})
        _replace_atomically(path, lambda p: meshio.write(p, mesh, file_format="vtu"))
        tpath = None
        if tracers is not None and len(tracers) > 0:
            tr = np.asarray(tracers, dtype=float)
            if tr.ndim != 2 or tr.shape[1] != self.dim:
                raise ValueError(f"VTK output: tracers of shape {tr.shape}, expected (n, {self.dim})")
            pts = np.zeros((tr.shape[0], 3))
            pts[:, 2] = tr[:, -1]
            if self.dim > 1:
                pts[:, 0] = tr[:, 0]
            if self.dim == 3:
                pts[:, 1] = tr[:, 1]
            cloud = meshio.Mesh(pts, [("vertex", np.arange(tr.shape[0])[:, None])],
                                point_data={"tracer [1]": np.arange(tr.shape[0], dtype=float)})
            tpath = Path(f"{self.stem}_tracers_{k:06d}.vtu")
            _replace_atomically(tpath, lambda p: meshio.write(p, cloud, file_format="vtu"))
        self.files.append(path)
        self.times.append(t)
        self.tracer_files.append(tpath)
        self._write_pvd()

    def keep_before(self, t_keep):
        """Resume: take the collection written so far, keep its files with time < ``t_keep`` [s]
        (later ones are overwritten as the run goes on) and rewrite the ``.pvd``."""
        import re

        self.files, self.times, self.tracer_files = [], [], []
        if self.pvd.exists():
            text = self.pvd.read_text()
            tracer_of = dict(re.findall(r'timestep="([^"]+)" part="1" file="([^"]+)"', text))
            for t, name in re.findall(r'timestep="([^"]+)" part="0" file="([^"]+)"', text):
                if float(t) < t_keep:
                    self.times.append(float(t))
                    self.files.append(self.pvd.parent / name)
                    self.tracer_files.append(self.pvd.parent / tracer_of[t] if t in tracer_of else None)
        self._write_pvd()

    def _write_pvd(self):
        rows = []
        for t, f, tf in zip(self.times, self.files, self.tracer_files):
            rows.append(f'    <DataSet timestep={quoteattr(repr(t))} part="0" file={quoteattr(f.name)}/>')
            if tf is not None:
                rows.append(f'    <DataSet timestep={quoteattr(repr(t))} part="1" file={quoteattr(tf.name)}/>')
        rows = "\n".join(rows)
        text = ('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1">\n  <Collection>\n'
                f"{rows}\n  </Collection>\n</VTKFile>\n")
        _replace_atomically(self.pvd, lambda p: p.write_text(text))

    def close(self, status=None):
        """Nothing is held open (each file is complete when written); for the observer protocol."""
