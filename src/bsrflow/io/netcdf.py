"""netCDF4 output of a tapped-column run, written snapshot by snapshot as the run goes.

:class:`NetCDFWriter` is an observer ``obs(t, u, rho, tracers)`` for
:meth:`bsrflow.numerics.solver.Simulation.run`.  Schema (``SCHEMA``; `bsrflow plot` reads it):

========================  ==================  ============================================
variable (dims)           units               long_name
========================  ==================  ============================================
time (time)               s                   simulated time
x (x)                     m                   height above the floor of the cell centre (floor frame)
tracer (tracer)           1                   tracer index (sphere number from the floor, 0-based)
rho (time, x)             kg m-1              line density
u (time, x)               m s-1               velocity relative to the floor
tracer_height (time, tracer) m                tracer height (lab frame)
floor (time)              m                   floor position (lab frame)
top (time)                m                   height of the top tracer (lab frame)
mass_centre (time)        m                   height of the mass centre (lab frame)
mass (time)               kg                  total mass
kinetic_energy (time)     J                   kinetic energy of the column (floor frame), sum(rho u^2/2 dx)
========================  ==================  ============================================

With ``state`` (``bsrflow run`` of a packing column with ``run.write_state = true``, of a packing
bed with ``[output] state = true``: :class:`NetCDFWriterND`, on the grid's axes) the file also
holds the discretisation's named state fields, ``state_<name>`` (time, ...) with their units
(:attr:`bsrflow.numerics.packing.EulerianPacking.field_schema`, ``LagrangianPacking.field_schema``:
on the grid's ``x``, or on the material points ``point`` and the bond lags ``lag``, with those
coordinates), the same fields as its checkpoints; the global attribute ``time_variables`` then
lists every time-dependent variable.

``time`` is unlimited.  Global attributes: ``bsrflow_version``, ``config`` (the full TOML text),
``scenario`` = "tapped_column", ``scheme``, ``diameter`` [m], ``status`` ("running" while the run
goes, then "ok" or the message of the monitor that stopped it), ``created`` (ISO 8601, UTC).
Lab-frame heights are measured from the floor at rest.

Crash safety.  A run killed at any moment (SIGKILL included) leaves a file that
``xarray.open_dataset`` opens, holding every snapshot written so far:

* the file appears atomically: it is first written complete (with the first snapshot, or with
  the snapshots kept on ``--resume``) to a temporary file that is then renamed over the target
  (``os.replace``);
* after that, a snapshot is appended in place (HDF5 via h5py, the file laid out by h5netcdf) and
  the HDF5 file is flushed (``H5Fflush``) before the run continues, so between snapshots the file
  on disk is complete and consistent.  The row chunks of every time-dependent variable are
  sized for the whole planned run (up to 8 MiB per chunk), so an append writes the new row into
  file space allocated when the file appeared and rewrites the fixed-size dataspace headers in
  place: no allocation and no index change, the operations that could leave dangling pointers if
  a kill interrupted a flush.  (Past the planned size -- not the case for `bsrflow run` -- new
  chunks are allocated; that window is then not covered.)
* the file is opened without the HDF5 file lock, so it can be read while the run goes.

What a kill inside the flush of an append can leave: HDF5 writes the new extents of the
variables one after another, so a kill between two of them leaves the last snapshot
incomplete: some variables hold it, the others end one row earlier, and a netCDF reader (whose
time dimension is the longest variable) shows their missing value as the fill value NaN.  Every
earlier snapshot is complete.  Measured with back-to-back appends (the flush is then most of the
time; ``bench/check_kill_rate.py``): 1 and 0 incomplete in two runs of 160 kills, and once in
a CI run of the test's 6 kills.  In a simulation the appends take a small part of the time, so a kill should land in a
flush less often; that rate was not measured.  :func:`read_snapshots` (and so ``--resume``)
keeps complete snapshots only.

``tests/test_run_io.py`` kills writers at random moments and opens every file left behind.
"""

from __future__ import annotations

import datetime as _dt
import os

import numpy as np

from .. import __version__

__all__ = ["NetCDFWriter", "NetCDFWriterND", "SCHEMA", "schema_nd", "read_snapshots", "finished_snapshots"]

SCHEMA = {
    # name: (dims, units, long_name)
    "time": (("time",), "s", "simulated time"),
    "x": (("x",), "m", "height above the floor of the cell centre (floor frame)"),
    "tracer": (("tracer",), "1", "tracer index (sphere number from the floor, 0-based)"),
    "rho": (("time", "x"), "kg m-1", "line density"),
    "u": (("time", "x"), "m s-1", "velocity relative to the floor"),
    "tracer_height": (("time", "tracer"), "m", "tracer height (lab frame)"),
    "floor": (("time",), "m", "floor position (lab frame)"),
    "top": (("time",), "m", "height of the top tracer (lab frame)"),
    "mass_centre": (("time",), "m", "height of the mass centre (lab frame)"),
    "mass": (("time",), "kg", "total mass"),
    "kinetic_energy": (("time",), "J", "kinetic energy of the column (floor frame)"),
}
"""Variables of the output file: name -> (dimensions, units, long_name)."""

_TIME_VARS = [k for k, (dims, _, _) in SCHEMA.items() if dims[0] == "time"]
_SERIES = [k for k in _TIME_VARS if SCHEMA[k][0] == ("time",)]      # 1-D in time
_CHUNK_BYTES = 8 * 2 ** 20


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


class NetCDFWriter:
    """Write snapshots of a 1-D column run into a netCDF4 file as they come (module docstring).

    Parameters
    ----------
    path : output file (``.nc``); replaced when the first snapshot arrives.
    x : cell centres [m] (floor frame).
    dx : cell width [m].
    n_tracers : number of tracers (0 allowed).
    floor : callable ``floor(t) -> ϑ(t)`` [m], the floor position in the lab frame
        (``motion.state(t)[0]``).
    attrs : further global attributes (``config``, ``scheme``, ``diameter`` [m], ...).
    expected_snapshots : how many snapshots the run will write (sizes the chunks; see the
        module docstring).

    state : optional ``(field_schema, source)``: the discretisation's named state fields, name ->
        (dimensions, units, long_name), and a callable returning them (name -> array) at a save;
        written as ``state_<name>`` (module docstring).

    Call ``writer(t, u, rho, tracers)`` at every save (t [s], u [m/s], rho [kg/m], tracers [m]
    floor frame); ``close(status)`` at the end.  The 1-D series written so far are kept in memory
    (``series(name)``), e.g. for a summary.
    """

    def __init__(self, path, x, dx, n_tracers, floor, attrs=None, expected_snapshots=None, state=None):
        self.path = os.fspath(path)
        self.x = np.ascontiguousarray(x, dtype=float)
        self.dx = float(dx)
        self.n_tracers = int(n_tracers)
        self.floor = floor
        self.attrs = {"bsrflow_version": __version__, "scenario": "tapped_column", "created": _now()}
        self.attrs.update(attrs or {})
        self.attrs["status"] = "running"
        self.expected = max(1, int(expected_snapshots or 1))
        schema = dict(SCHEMA)
        sizes = {"x": self.x.size, "tracer": self.n_tracers}
        coords = {"x": self.x, "tracer": np.arange(self.n_tracers, dtype=np.int32)}
        self.state = state
        if state is not None:
            _add_state_fields(state, schema, sizes, coords)
        self._init_schema(schema, sizes, coords)
        if state is not None:
            self.attrs["time_variables"] = " ".join(self._time_vars)

    def _init_schema(self, schema, dim_sizes, coords):
        """The file's variables (name -> (dims, units, long_name)), fixed dimension sizes and
        coordinate values; the in-memory rows and series start empty."""
        self.schema = schema
        self.dim_sizes = dict(dim_sizes)
        self.coords = coords
        self._time_vars = [k for k, (dims, _, _) in schema.items() if dims[0] == "time"]
        self._series_names = [k for k in self._time_vars if schema[k][0] == ("time",)]
        self._rows: dict[str, list] | None = {k: [] for k in self._time_vars}   # before the file appears
        self._series = {k: [] for k in self._series_names}
        self._h5 = None
        self._ds = {}
        self.n = 0
        self.closed = False

    # -- resuming ---------------------------------------------------------------------------------
    @classmethod
    def resume(cls, path, keep_before, x, dx, n_tracers, floor, expected_snapshots=None, state=None):
        """Reopen a partial file, keep its snapshots with time < ``keep_before`` [s] and return a
        writer that appends after them (x [m], dx [m], n_tracers, floor, state as for the
        constructor; x, n_tracers and the state fields must match the file).  The file is
        rewritten atomically with the kept snapshots (status "running"; the other attributes,
        ``created`` included, are kept)."""
        data, attrs = read_snapshots(path)
        x = np.ascontiguousarray(x, dtype=float)
        if data["x"].shape != x.shape or not np.array_equal(data["x"], x):
            raise ValueError(f"{os.fspath(path)}: its grid x differs from this run's ({data['x'].size} "
                             f"against {x.size} cells)")
        if data["tracer"].size != int(n_tracers):
            raise ValueError(f"{os.fspath(path)}: it has {data['tracer'].size} tracers, this run {n_tracers}")
        keep = data["time"] < keep_before
        w = cls(path, x, dx, n_tracers, floor, expected_snapshots=expected_snapshots, state=state)
        w._check_variables(path, data)
        return w._keep(data, attrs, keep)

    def _keep(self, data, attrs, keep):
        """Take the file's attributes and its snapshots where ``keep``; rewrite the file."""
        self.attrs = dict(attrs)
        self.attrs["status"] = "running"
        for k in self._time_vars:
            self._rows[k] = list(data[k][keep])
        for k in self._series_names:
            self._series[k] = list(data[k][keep])
        self.n = int(keep.sum())
        if self.n:
            self._publish()
        return self

    # -- the observer -----------------------------------------------------------------------------
    def __call__(self, t, u, rho, tracers):
        """Append the snapshot at t [s] and flush it to disk."""
        if self.closed:
            raise RuntimeError(f"{self.path}: writer is closed")
        self._append(self._row(float(t), u, rho, tracers))

    def _row(self, t, u, rho, tracers):
        """The values of every time-dependent variable at t."""
        fl = float(self.floor(t))
        u = np.asarray(u, dtype=float)
        rho = np.asarray(rho, dtype=float)
        tr = np.asarray(tracers, dtype=float).reshape(-1)
        mass = rho.sum() * self.dx
        row = {
            "time": t,
            "rho": rho.copy(),
            "u": u.copy(),
            "tracer_height": tr + fl,
            "floor": fl,
            "top": (tr[-1] + fl) if tr.size else np.nan,
            "mass_centre": (rho * self.x).sum() * self.dx / mass + fl if mass > 0 else np.nan,
            "mass": mass,
            "kinetic_energy": 0.5 * (rho * u ** 2).sum() * self.dx,
        }
        self._add_state_row(row)
        return row

    def _check_variables(self, path, data):
        """Refuse (ValueError) to resume a file whose time-dependent variables, or the shapes of its
        state fields, are not this writer's."""
        missing = [k for k in self._time_vars if k not in data]
        extra = [k for k in data if k.startswith("state_") and k not in self._time_vars]
        if missing or extra:
            raise ValueError(f"{os.fspath(path)}: its variables differ from this run's "
                             f"({'missing ' + ', '.join(missing) if missing else 'also ' + ', '.join(extra)})")
        for k in self._time_vars:
            if k.startswith("state_") and data[k].shape[1:] != tuple(self.dim_sizes[d] for d in self.schema[k][0][1:]):
                raise ValueError(f"{os.fspath(path)}: its {k} has the shape {data[k].shape[1:]} per snapshot, "
                                 "this run's differs")

    def _add_state_row(self, row):
        """The state fields at this save into ``row`` (``state_<name>``), when the file holds them."""
        if self.state is not None:
            for name, value in self.state[1]().items():
                row[f"state_{name}"] = np.array(value, dtype=float, copy=True)

    def _append(self, row):
        for k in self._series_names:
            self._series[k].append(row[k])
        if self._h5 is None:
            for k in self._time_vars:
                self._rows[k].append(row[k])
            self.n += 1
            self._publish()
            return
        k0 = self.n
        for k in self._time_vars:
            ds = self._ds[k]
            ds.resize(k0 + 1, axis=0)
            ds[k0] = row[k]
        self.n += 1
        self._h5.flush()

    def series(self, name) -> np.ndarray:
        """A 1-D time series written so far: time, floor, top, mass_centre, mass, kinetic_energy."""
        return np.asarray(self._series[name], dtype=float)

    def close(self, status: str | None = None, **extra_attrs):
        """Set the ``status`` attribute (e.g. "ok" or a stop message) and any ``extra_attrs``
        (global attributes such as ``steps``) and close the file."""
        if self.closed:
            return
        if status is not None:
            self.attrs["status"] = " ".join(str(status).split())
        self.attrs.update(extra_attrs)
        if self._h5 is None:
            if self.n == 0:
                self.closed = True
                return
            self._publish()
        self._h5.attrs["status"] = self.attrs["status"]
        for key, value in extra_attrs.items():
            self._h5.attrs[key] = value
        self._h5.flush()
        self._h5.close()
        self._h5 = None
        self.closed = True

    def close_as_is(self):
        """Close the file without writing to it (its status stays "running"): after a failed
        write on a full disk, where even a new status attribute may need space that HDF5 cannot
        get and a failed metadata write would leave the file unreadable.  Every snapshot
        appended so far was flushed, so the file on disk is complete."""
        if self.closed:
            return
        if self._h5 is not None:
            self._h5.close()
            self._h5 = None
        self.closed = True

    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        self.close(None if exc is None else f"failed: {type(exc).__name__}: {exc}")

    # -- file creation ----------------------------------------------------------------------------
    def _chunk_rows(self, bytes_per_row):
        return int(max(1, min(max(self.expected, self.n), _CHUNK_BYTES // max(8, bytes_per_row))))

    def planned_bytes(self) -> int:
        """The size [bytes] of the file when it appears: the row chunks of every time-dependent
        variable are allocated for the whole planned run (module docstring), plus the
        coordinates, the attributes and an allowance of 64 KiB for HDF5's own structures."""
        total = 64 * 1024 + sum(len(str(v)) for v in self.attrs.values())
        for name, (dims, _, _) in self.schema.items():
            per_row = 8 * int(np.prod([self.dim_sizes[d] for d in dims[1:]], dtype=np.int64))
            if dims[0] == "time":
                rows = self._chunk_rows(per_row)
                total += -(-max(self.expected, self.n) // rows) * rows * per_row
            else:
                total += 8 * int(np.prod([self.dim_sizes[d] for d in dims], dtype=np.int64))
        return int(total)

    def check_space(self, option: str = "--out") -> None:
        """Refuse (:class:`bsrflow.io.paths.OutputPathError`, one line naming ``option``) a file
        that the free space of its folder cannot hold (:meth:`planned_bytes`): checked before a
        run starts and before the file is written, so that a full disk is a clear error rather
        than HDF5's failure in the middle of a write."""
        from .paths import check_free_space

        check_free_space(self.path, self.planned_bytes(), option,
                         f"{max(self.expected, self.n)} snapshots of {len(self._time_vars)} variables")

    def _publish(self):
        """Write the whole file (schema + rows in memory) to a temporary file, rename it over the
        target, and reopen it for appending."""
        import h5netcdf
        import h5py

        self.check_space()
        if self._h5 is not None:
            self._h5.close()
            self._h5 = None
        tmp = f"{self.path}.tmp{os.getpid()}"
        n = self.n
        try:
            with h5netcdf.File(tmp, "w") as f:
                f.dimensions = {"time": None, **self.dim_sizes}
                for name, (dims, units, long_name) in self.schema.items():
                    if dims[0] == "time":
                        row_shape = tuple(self.dim_sizes[d] for d in dims[1:])
                        per_row = 8 * int(np.prod(row_shape)) if row_shape else 8
                        chunks = (self._chunk_rows(per_row),) + tuple(max(1, s) for s in row_shape)
                        v = f.create_variable(name, dims, "f8", chunks=chunks, fillvalue=np.nan)
                    elif np.asarray(self.coords[name]).dtype.kind == "i":
                        v = f.create_variable(name, dims, "i4")
                    else:
                        v = f.create_variable(name, dims, "f8")
                    v.attrs["units"] = units
                    v.attrs["long_name"] = long_name
                for name, values in self.coords.items():
                    f.variables[name][:] = values
                for k, val in self.attrs.items():
                    f.attrs[k] = val
                f.resize_dimension("time", n)
                if n:
                    for k in self._time_vars:
                        f.variables[k][...] = np.asarray(self._rows[k], dtype=float).reshape(
                            f.variables[k].shape)
            with open(tmp, "rb+") as fh:
                os.fsync(fh.fileno())
            os.replace(tmp, self.path)
        finally:
            if os.path.exists(tmp):
                os.remove(tmp)
        self._rows = None
        self._h5 = h5py.File(self.path, "r+", locking=False)
        self._ds = {k: self._h5[k] for k in self._time_vars}


def _add_state_fields(state, schema, sizes, coords):
    """Add the variables ``state_<name>`` of the state fields ``state = (field_schema, source)``
    to ``schema``, their dimensions' sizes (from the arrays ``source()`` returns) to ``sizes``,
    and the coordinates of the dimensions ``point``, ``face``, ``cell``, ``grid_x/_y/_z`` (indices)
    and ``lag`` (1..L) to ``coords``."""
    field_schema, source = state
    values = source()
    if set(values) != set(field_schema):
        raise ValueError(f"the state fields {sorted(values)} are not those of the schema {sorted(field_schema)}")
    for name, (dims, _, _) in field_schema.items():
        shape = np.shape(values[name])
        if len(shape) != len(dims):
            raise ValueError(f"state field {name}: shape {shape} for the dimensions {dims}")
        for d, n in zip(dims, shape):
            if sizes.setdefault(d, n) != n:
                raise ValueError(f"state field {name}: dimension {d} of size {n}, elsewhere {sizes[d]}")
    labels = {"point": ("1", "material point index (from the floor, 0-based)", 0),
              "lag": ("1", "bond lag: a bond of lag l joins a point to the l-th point below it", 1),
              "face": ("1", "Lagrangian cell face index (from the floor, 0-based)", 0),
              "cell": ("1", "Lagrangian cell index (from the floor, 0-based)", 0),
              "grid_x": ("1", "Eulerian cell index along x (0-based; centre at (i + 1/2) grid_cell_size_m[0])", 0),
              "grid_y": ("1", "Eulerian cell index along y (0-based; centre at (j + 1/2) grid_cell_size_m[1])", 0),
              "grid_z": ("1", "Eulerian cell index along z from the floor (0-based; centre at (k + 1/2) "
                              "grid_cell_size_m[2])", 0)}
    for d, (units, long_name, first) in labels.items():
        if d in sizes and d not in coords:
            schema[d] = ((d,), units, long_name)
            coords[d] = np.arange(first, first + sizes[d], dtype=np.int32)
    for name, (dims, units, long_name) in field_schema.items():
        schema[f"state_{name}"] = (("time",) + tuple(dims), units, long_name)


_AXES = {1: ("z",), 2: ("x", "z"), 3: ("x", "y", "z")}


def schema_nd(dim: int, n_tracers: int = 0, per_depth: bool = False, tracer_axes=None) -> dict:
    """Variables of an n-D run's file (:class:`NetCDFWriterND`), dim = 1 (axis z: a column),
    2 (x, z) or 3 (x, y, z; z vertical, from the floor): name -> (dims, units, long_name).  With tracers
    (``n_tracers`` > 0) also ``tracer`` (the index) and ``tracer_x`` (, ``tracer_y``),
    ``tracer_z`` (time, tracer) [m]: their positions, the height in the lab frame as the 1-D
    file's ``tracer_height``.  A 2-D run is either a planar continuum (the seed kernel's layers:
    ``rho`` in kg m-2, mass in kg) or, with ``per_depth``, a 3-D material uniform in y (the
    packing bed: ``rho`` in kg m-3, mass and kinetic energy per metre of depth).  ``tracer_axes``:
    the tracers' axes when they are not the file's (the vibrated bed's Eulerian grid, whose file
    is a column)."""
    axes = _AXES[dim]
    depth = per_depth and dim == 2
    per = "m-1" if depth else ""
    out = {"time": (("time",), "s", "simulated time")}
    for a in axes:
        where = "height above the floor" if a == "z" else f"horizontal position ({a})"
        out[a] = ((a,), "m", f"{where} of the cell centre (floor frame)")
    out["rho"] = (("time",) + axes, "kg m-3" if depth else f"kg m-{dim}",
                  "density (mass per unit volume, uniform in depth)" if depth else
                  {1: "line density (mass per unit length)", 2: "density (mass per unit area)",
                   3: "density (mass per unit volume)"}[dim])
    for a in axes:
        out[f"u_{a}"] = (("time",) + axes, "m s-1", f"velocity component {a} relative to the floor")
    if n_tracers > 0:
        out["tracer"] = (("tracer",), "1", "tracer index")
        for a in (axes if tracer_axes is None else tracer_axes):
            out[f"tracer_{a}"] = (("time", "tracer"), "m", "tracer height (lab frame)" if a == "z"
                                  else f"tracer position {a}")
    out["floor"] = (("time",), "m", "floor position (lab frame)")
    out["mass_centre"] = (("time",), "m", "height of the mass centre (lab frame)")
    out["mass"] = (("time",), ("kg " + per).strip(), "total mass" + (" per unit depth" if per else ""))
    out["kinetic_energy"] = (("time",), ("J " + per).strip(), "kinetic energy (floor frame)"
                             + (" per unit depth" if per else ""))
    return out


class NetCDFWriterND(NetCDFWriter):
    """The n-D run's writer: the crash-safe snapshot-by-snapshot file of :class:`NetCDFWriter`
    (the same creation, append, flush and close; the module docstring) with the variables of
    :func:`schema_nd`.  An observer ``obs(t, u, rho, tracers)`` of :meth:`SimulationND.run` (u
    of shape (n, *shape) [m/s], rho (*shape) [kg/m^n], tracers (n_tracers, n) [m] floor frame or
    None; user layout).

    grid : :class:`bsrflow.numerics.grid_nd.GridND`; floor : ``floor(t) -> ϑ(t)`` [m];
    attrs, expected_snapshots : as for :class:`NetCDFWriter`; n_tracers : tracers per snapshot
    (0: the file has no tracer variables); tracer_axes : their axes, when not the grid's (e.g.
    ("x", "y", "z") for the 3-D bed whose file is a column)."""

    def __init__(self, path, grid, floor, attrs=None, expected_snapshots=None, n_tracers=0, per_depth=False,
                 state=None, tracer_axes=None):
        self.path = os.fspath(path)
        self.grid = grid
        self.dim = int(grid.dim)
        self.floor = floor
        self.attrs = {"bsrflow_version": __version__, "scenario": f"layer_{self.dim}d", "created": _now()}
        self.attrs.update(attrs or {})
        self.attrs["status"] = "running"
        self.expected = max(1, int(expected_snapshots or 1))
        self.axes = _AXES[self.dim]
        coords = {a: np.asarray(grid.centres(k), dtype=float) for k, a in enumerate(self.axes)}
        self.n_tracers = int(n_tracers)
        sizes = dict(zip(self.axes, grid.shape))
        if self.n_tracers > 0:
            coords["tracer"] = np.arange(self.n_tracers, dtype=np.int32)
            sizes["tracer"] = self.n_tracers
        self.tracer_axes = tuple(self.axes if tracer_axes is None else tracer_axes)
        schema = schema_nd(self.dim, self.n_tracers, per_depth, self.tracer_axes)
        self.state = state
        if state is not None:
            _add_state_fields(state, schema, sizes, coords)
        self._init_schema(schema, sizes, coords)
        self.attrs["time_variables"] = " ".join(self._time_vars)
        self.cell_volume = float(grid.cell_volume)
        self.height = coords["z"] - grid.lower[-1]          # above the grid's floor
        self._h5 = None
        self._ds = {}
        self.n = 0
        self.closed = False

    @classmethod
    def resume(cls, path, keep_before, grid, floor, expected_snapshots=None, n_tracers=0, per_depth=False,
               state=None, tracer_axes=None):
        """Reopen a partial n-D file, keep its snapshots with time < ``keep_before`` [s] (the
        grid, the number of tracers and the state fields must match) and return a writer that
        appends after them."""
        data, attrs = read_snapshots(path)
        w = cls(path, grid, floor, expected_snapshots=expected_snapshots, n_tracers=n_tracers, per_depth=per_depth,
                state=state, tracer_axes=tracer_axes)
        if ("tracer_z" in data) != (w.n_tracers > 0) or ("tracer" in data and data["tracer"].size != w.n_tracers):
            raise ValueError(f"{os.fspath(path)}: its tracers differ from this run's")
        for a in w.axes:
            if a not in data or not np.array_equal(data[a], w.coords[a]):
                raise ValueError(f"{os.fspath(path)}: its grid ({a}) differs from this run's")
        w._check_variables(path, data)
        return w._keep(data, attrs, data["time"] < keep_before)

    def __call__(self, t, u, rho, tracers=None):
        """Append the snapshot at t [s] and flush it to disk."""
        if self.closed:
            raise RuntimeError(f"{self.path}: writer is closed")
        self._append(self._row(float(t), u, rho, tracers))

    def _row(self, t, u, rho, tracers=None):
        fl = float(self.floor(t))
        if self.n_tracers > 0:
            tr = np.asarray(tracers, dtype=float) if tracers is not None else None
            nt = len(self.tracer_axes)
            if tr is None or tr.shape != (self.n_tracers, nt):
                raise ValueError(f"{self.path}: expected tracers of shape ({self.n_tracers}, {nt}), got "
                                 f"{None if tr is None else tr.shape}")
        u = np.asarray(u, dtype=float)
        rho = np.asarray(rho, dtype=float)
        mass = float(rho.sum()) * self.cell_volume
        row = {"time": t, "rho": rho.copy(), "floor": fl, "mass": mass,
               "mass_centre": float((rho * self.height).sum()) * self.cell_volume / mass + fl if mass > 0 else np.nan,
               "kinetic_energy": 0.5 * float((rho * (u ** 2).sum(axis=0)).sum()) * self.cell_volume}
        for a, comp in zip(self.axes, u):
            row[f"u_{a}"] = comp.copy()
        if self.n_tracers > 0:
            for k, a in enumerate(self.tracer_axes):
                row[f"tracer_{a}"] = tr[:, k] + (fl if a == "z" else 0.0)
        self._add_state_row(row)
        return row


def finished_snapshots(path):
    """The snapshots of an output whose run finished (status "ok"), as :func:`read_snapshots`'s
    ``data``; None when ``path`` does not exist, cannot be read or did not finish (what
    ``--resume`` on a finished output checks, for every kind of run)."""
    if not os.path.exists(path):
        return None
    try:
        data, attrs = read_snapshots(path)
    except Exception:  # noqa: BLE001 - not a readable output: not a finished one
        return None
    return data | {"attrs": attrs} if attrs.get("status") == "ok" else None


def read_snapshots(path):
    """Read an output file: ``(data, attrs)`` with every variable of ``SCHEMA`` as a NumPy array and
    the global attributes as a dict (what ``--resume`` uses; for analysis use xarray).  Only
    complete snapshots are returned (a snapshot cut short by a kill is dropped; module docstring)."""
    import h5py

    with h5py.File(os.fspath(path), "r", locking=False) as h:
        listed = h.attrs.get("time_variables")       # written by NetCDFWriterND
        if listed is not None:
            time_vars = (listed.decode() if isinstance(listed, bytes) else str(listed)).split()
            names = time_vars + [str(c) for c in ("x", "y", "z", "tracer") if c in h]
        else:
            time_vars, names = _TIME_VARS, list(SCHEMA)
        n = min(h[k].shape[0] for k in time_vars)       # equal unless a write was cut short
        # a last snapshot cut short inside the flush can also show as the fill value NaN in a
        # value that a complete snapshot never leaves NaN (not top and mass_centre: those are
        # NaN in a complete snapshot of a run without tracers or without mass)
        while n > 0 and not all(np.all(np.isfinite(h[k][n - 1]))
                                for k in time_vars if k not in ("top", "mass_centre")):
            n -= 1
        data = {}
        for k in names:
            arr = h[k][...]
            data[k] = arr[:n] if k in time_vars else arr
        attrs = {}
        for k, v in h.attrs.items():
            if k.startswith("_NC"):
                continue
            if isinstance(v, bytes):
                v = v.decode()
            elif isinstance(v, np.ndarray) and v.shape == ():
                v = v.item()
            elif isinstance(v, np.generic):
                v = v.item()
            attrs[k] = v
    return data, attrs
