"""Read (and write) LAMMPS / LIGGGHTS text ``dump`` files of per-atom data.

A text dump is a sequence of snapshots, each written by LAMMPS as::

    ITEM: UNITS                     (optional, first snapshot only: dump_modify units yes)
    si
    ITEM: TIME                      (optional: dump_modify time yes; in the time unit of the run)
    0.0125
    ITEM: TIMESTEP
    1000
    ITEM: NUMBER OF ATOMS
    20
    ITEM: BOX BOUNDS ff ff fm       (orthogonal: "lo hi" on each of 3 lines)
    ITEM: BOX BOUNDS xy xz yz pp pp pp   (restricted triclinic: "lo_bound hi_bound tilt")
    ITEM: BOX BOUNDS abc origin pp pp pp (general triclinic: "ax ay az origin_x", ...)
    ITEM: ATOMS id type x y z vx ...
    <one line per atom, in any order>

The boundary flags after BOX BOUNDS are optional (old versions write none).  The per-atom
columns may come in any order; positions are taken, per axis, from the first of

    xu (unscaled, unwrapped)  >  x (unscaled, wrapped; plus image flags ix iy iz if present)
    >  xsu (scaled, unwrapped)  >  xs (scaled, wrapped; plus image flags)

that the snapshot has, using that snapshot's box (shrink-wrapped boxes change every snapshot):
with the box's edge vectors A, B, C (rows of the cell matrix H) and origin o,

    r = o + (s + i) H      (scaled s, image flags i),        r = x + i H    (unscaled, wrapped).

For a restricted triclinic box H = [[lx, 0, 0], [xy, ly, 0], [xz, yz, lz]] and o = (xlo, ylo,
zlo), where LAMMPS writes the bounding box xlo_bound = xlo + min(0, xy, xz, xy + xz),
xhi_bound = xhi + max(0, xy, xz, xy + xz), ylo_bound = ylo + min(0, yz), yhi_bound = yhi +
max(0, yz) (inverted here).

Units: positions are returned in metres.  LAMMPS writes lengths in the unit of its ``units``
style; if the file has an ``ITEM: UNITS`` block its style is converted (si, cgs, metal, real,
micro, nano, electron), otherwise the file is taken to be in SI units (LIGGGHTS' usual ``units
si``) unless ``length_scale`` [m per file length unit] is given.  ``lj`` units need
``length_scale``.

Atoms are matched between snapshots by their ``id`` and returned sorted by id; every snapshot
must hold the same set of ids (a clear ``ValueError`` naming the file and line says which
appeared or disappeared).  Gzip-compressed files are read transparently (recognised by their
content; a file named ``*.gz`` must be gzip).  Coordinates must be finite numbers and a dump
must hold at least one atom.
"""

from __future__ import annotations

import gzip
import math
import os
import re
import zlib
from dataclasses import dataclass, field, replace

import numpy as np

__all__ = ["DumpTrajectories", "read_dump", "write_dump", "time_mismatch", "LENGTH_UNITS", "TIME_UNITS"]

LENGTH_UNITS = {"si": 1.0, "cgs": 1e-2, "metal": 1e-10, "real": 1e-10, "micro": 1e-6, "nano": 1e-9,
                "electron": 5.29177210903e-11}
"""Metres per length unit of each LAMMPS ``units`` style (``lj`` has none)."""

TIME_UNITS = {"si": 1.0, "cgs": 1.0, "metal": 1e-12, "real": 1e-15, "micro": 1e-6, "nano": 1e-9,
              "electron": 1e-15}
"""Seconds per time unit of each LAMMPS ``units`` style (``lj`` has none)."""

_AXES = {"x": 0, "y": 1, "z": 2, 0: 0, 1: 1, 2: 2}
_KINDS = ("u", "", "su", "s")          # suffix after x/y/z: unwrapped > wrapped > scaled unwrapped > scaled
_IMAGE = ("ix", "iy", "iz")
_POSITION_COLUMNS = {f"{a}{k}" for a in "xyz" for k in _KINDS}


def _axis_index(axis) -> int:
    try:
        return _AXES[axis.lower() if isinstance(axis, str) else axis]
    except (KeyError, AttributeError):
        raise ValueError(f"axis = {axis!r} is not one of 'x', 'y', 'z' (or 0, 1, 2)") from None


@dataclass
class DumpTrajectories:
    """Per-atom trajectories read from a LAMMPS/LIGGGHTS dump (arrays sorted by atom id).

    Attributes
    ----------
    path : the file read.
    timestep : (nt,) int64 LAMMPS step numbers of the snapshots.
    t : (nt,) times [s]: the ``ITEM: TIME`` values (converted to s) when the file has them,
        else ``timestep * timestep_size`` when a step size was given, else None.
    ids : (n_atoms,) int64 atom ids, increasing.
    positions : (nt, n_atoms, 3) centres [m] (unwrapped where the file allows, see the module
        docstring); NaN for an axis the file has no column for.
    types : (n_atoms,) atom types from the first snapshot, or None without a ``type`` column.
    origin : (nt, 3) box origin [m] (NaN if the snapshot had no box).
    cell : (nt, 3, 3) box edge vectors A, B, C as rows [m] (NaN if no box).
    boundary : boundary flags of the first snapshot, e.g. ``"pp pp fm"`` ('' if none written).
    units : the ``ITEM: UNITS`` style, or None.
    length_scale : metres per file length unit used for the conversion.
    fields : other numeric per-atom columns, name -> (nt, n_atoms) array, values as in the file
        (no unit conversion), e.g. ``fields["radius"]``, ``fields["vz"]``.
    axis : the default axis of :meth:`heights` ('x', 'y' or 'z').
    """

    path: str
    timestep: np.ndarray
    t: np.ndarray | None
    ids: np.ndarray
    positions: np.ndarray
    types: np.ndarray | None = None
    origin: np.ndarray | None = None
    cell: np.ndarray | None = None
    boundary: str = ""
    units: str | None = None
    length_scale: float = 1.0
    fields: dict = field(default_factory=dict)
    axis: str = "z"

    @property
    def n_atoms(self) -> int:
        return int(self.ids.size)

    @property
    def n_snapshots(self) -> int:
        return int(self.timestep.size)

    def heights(self, axis=None) -> np.ndarray:
        """(nt, n_atoms) coordinates along ``axis`` [m] (default: the axis given to
        :func:`read_dump`), columns in id order."""
        k = _axis_index(self.axis if axis is None else axis)
        return self.positions[:, :, k]

    def top(self, axis=None) -> np.ndarray:
        """(nt,) highest atom centre along ``axis`` [m] (for a 1-D column this is the top
        sphere's centre, :meth:`bsrflow.physics.dem.DEMResult.top`)."""
        return self.heights(axis).max(axis=1)

    def mass_centre(self, axis=None) -> np.ndarray:
        """(nt,) centre of mass along ``axis`` [m].  Atoms of equal mass (no ``mass`` column, or
        all masses equal): the mean of the centres, as :meth:`DEMResult.mass_centre`;
        otherwise weighted by the ``mass`` column."""
        h = self.heights(axis)
        m = self.fields.get("mass")
        if m is None or np.all(m == m.flat[0]):
            return h.mean(axis=1)
        return (h * m).sum(axis=1) / m.sum(axis=1)

    def diameters(self) -> np.ndarray | None:
        """(nt, n_atoms) sphere diameters [m] from a ``diameter`` or ``radius`` column (LIGGGHTS
        writes ``radius``), or None."""
        if "diameter" in self.fields:
            return self.fields["diameter"] * self.length_scale
        if "radius" in self.fields:
            return 2.0 * self.fields["radius"] * self.length_scale
        return None

    def select(self, keep) -> "DumpTrajectories":
        """A copy with only some atoms: ``keep`` is a boolean mask over ``ids`` or an iterable of
        atom types (e.g. ``select([1])`` drops wall particles of other types)."""
        keep = np.asarray(keep)
        if keep.dtype != bool:
            if self.types is None:
                raise ValueError(f"{self.path}: no 'type' column to select atom types by")
            keep = np.isin(self.types, keep)
        if keep.shape != self.ids.shape:
            raise ValueError(f"selection mask has shape {keep.shape}, expected {self.ids.shape}")
        if not keep.any():
            raise ValueError(f"{self.path}: the selection keeps no atoms")
        return replace(self, ids=self.ids[keep], positions=self.positions[:, keep],
                       types=None if self.types is None else self.types[keep],
                       fields={k: v[:, keep] for k, v in self.fields.items()})


# ----------------------------------------------------------------------------- reading


class _Lines:
    """Line iterator with 1-based line numbers and one line of look-ahead."""

    def __init__(self, fh, path):
        self.fh = fh
        self.path = path
        self.number = 0
        self._peeked = None

    def error(self, message, line=None):
        return ValueError(f"{self.path}, line {line or self.number}: {message}")

    def peek(self):
        if self._peeked is None:
            self._peeked = self.fh.readline()
        return self._peeked

    def next(self, what=None):
        line = self.peek()
        self._peeked = None
        if not line:
            if what:
                raise self.error(f"file ends where {what} was expected", self.number + 1)
            return None
        self.number += 1
        return line.rstrip("\r\n")

    def skip_blank(self):
        while True:
            line = self.peek()
            if not line or line.strip():
                return
            self.next()


def _parse_int(lines, what):
    text = lines.next(what)
    tokens = text.split()
    try:
        if len(tokens) != 1:
            raise ValueError
        return int(tokens[0])
    except ValueError:
        raise lines.error(f"expected one integer ({what}), found {text!r}") from None


def _parse_floats(lines, what, count):
    text = lines.next(what)
    tokens = text.split()
    try:
        if len(tokens) != count:
            raise ValueError
        return [float(v) for v in tokens]
    except ValueError:
        raise lines.error(f"expected {count} numbers ({what}), found {text!r}") from None


def _parse_box(lines, header):
    """(origin (3,), cell (3, 3), boundary string) from a BOX BOUNDS block, in file units."""
    words = header.split()[3:]                       # after "ITEM: BOX BOUNDS"
    if words[:2] == ["abc", "origin"]:
        rows = [_parse_floats(lines, f"box edge vector {n} and origin", 4) for n in "ABC"]
        cell = np.array([r[:3] for r in rows])
        origin = np.array([r[3] for r in rows])
        return origin, cell, " ".join(words[2:])
    if words[:3] == ["xy", "xz", "yz"]:
        (xlb, xhb, xy), (ylb, yhb, xz), (zlo, zhi, yz) = (
            _parse_floats(lines, f"{a}lo_bound {a}hi_bound tilt", 3) for a in "xyz")
        xlo = xlb - min(0.0, xy, xz, xy + xz)
        xhi = xhb - max(0.0, xy, xz, xy + xz)
        ylo = ylb - min(0.0, yz)
        yhi = yhb - max(0.0, yz)
        cell = np.array([[xhi - xlo, 0.0, 0.0], [xy, yhi - ylo, 0.0], [xz, yz, zhi - zlo]])
        return np.array([xlo, ylo, zlo]), cell, " ".join(words[3:])
    lo_hi = [_parse_floats(lines, f"{a}lo {a}hi", 2) for a in "xyz"]
    origin = np.array([b[0] for b in lo_hi])
    cell = np.diag([b[1] - b[0] for b in lo_hi])
    return origin, cell, " ".join(words)


def _atom_block(lines, n_atoms, columns, header_line):
    """The n_atoms lines after an ATOMS header as a (n_atoms, n_columns) array: float when every
    value is a number, else str (non-numeric columns such as ``element``)."""
    first = lines.number + 1
    rows = []
    for k in range(n_atoms):
        text = lines.next()
        if text is None:
            raise lines.error(f"file ends after {k} of the {n_atoms} atom lines of the snapshot whose "
                              f"ATOMS header is on line {header_line}", lines.number + 1)
        if text.startswith("ITEM:"):
            raise lines.error(f"found {text.strip()!r} after {k} atom lines, but NUMBER OF ATOMS of the "
                              f"snapshot whose ATOMS header is on line {header_line} says {n_atoms}")
        rows.append(text)
    if n_atoms:
        try:                                   # fast path: every value a number, every line complete
            block = np.loadtxt(rows, dtype=np.float64, ndmin=2, comments=None)
            if block.shape == (n_atoms, len(columns)):
                return block, first
        except ValueError:
            pass
    tokens = " ".join(rows).split()
    if len(tokens) != n_atoms * len(columns):
        for k, text in enumerate(rows):
            if len(text.split()) != len(columns):
                raise lines.error(f"atom line has {len(text.split())} values, the ATOMS header on line "
                                  f"{header_line} names {len(columns)} columns ({' '.join(columns)})",
                                  first + k)
    return np.array(tokens, dtype=str).reshape(n_atoms, len(columns)), first


def _column_values(block, j, name, lines, first, integer=False, finite=False):
    """Column j as float (or int64) array; ValueError naming the first bad line (not a number,
    not an integer with ``integer``, NaN or infinite with ``finite``)."""
    try:
        values = block[:, j].astype(np.float64)         # a no-op copy on the fast path
    except ValueError:
        for k, v in enumerate(block[:, j]):
            try:
                float(v)
            except ValueError:
                raise lines.error(f"column {name!r} holds {str(v)!r}, not a number", first + k) from None
        raise
    if integer:
        if not np.all(np.isfinite(values)) or np.any(values != np.round(values)):
            k = int(np.argmax(~np.isfinite(values) | (values != np.round(values))))
            raise lines.error(f"column {name!r} holds {str(block[k, j])!r}, not an integer", first + k)
        return values.astype(np.int64)
    if finite and not np.all(np.isfinite(values)):
        k = int(np.argmax(~np.isfinite(values)))
        raise lines.error(f"column {name!r} holds {str(block[k, j])!r}: a coordinate must be a finite number",
                          first + k)
    return values


def _positions(cols, origin, cell, n_atoms, lines, header_line):
    """(n_atoms, 3) positions in file length units from the columns of one snapshot."""
    pos = np.full((n_atoms, 3), np.nan)
    kinds = []
    for k, a in enumerate("xyz"):
        kind = next((s for s in _KINDS if f"{a}{s}" in cols), None)
        kinds.append(kind)
    images = np.column_stack([cols.get(n, np.zeros(n_atoms)) for n in _IMAGE])
    has_images = any(n in cols for n in _IMAGE)
    needs_box = any(k in ("s", "su") for k in kinds) or (has_images and "" in kinds)
    if needs_box and (origin is None or not np.all(np.isfinite(cell))):
        raise lines.error("scaled coordinates or image flags need the snapshot's BOX BOUNDS, which is "
                          "missing", header_line)
    triclinic = cell is not None and np.any(cell[~np.eye(3, dtype=bool)] != 0.0)
    if not triclinic:
        for k, (a, kind) in enumerate(zip("xyz", kinds)):
            if kind is None:
                continue
            v = cols[f"{a}{kind}"]
            L = cell[k, k] if cell is not None else np.nan
            if kind == "u":
                pos[:, k] = v
            elif kind == "":
                pos[:, k] = v + images[:, k] * L if has_images else v
            elif kind == "su":
                pos[:, k] = origin[k] + v * L
            else:
                pos[:, k] = origin[k] + (v + images[:, k]) * L
        return pos
    # triclinic: scaled coordinates and image flags mix the axes, so one complete kind is needed
    if all(k == "u" for k in kinds if k is not None) or (not has_images and all(k in ("u", "") for k in kinds)):
        for k, (a, kind) in enumerate(zip("xyz", kinds)):
            if kind is not None:
                pos[:, k] = cols[f"{a}{kind}"]
        return pos
    kind = next((s for s in _KINDS if all(f"{a}{s}" in cols for a in "xyz")), None)
    if kind is None:
        raise lines.error("a triclinic box with scaled coordinates or image flags needs all three "
                          "coordinates of one kind (x y z, xu yu zu, xs ys zs or xsu ysu zsu)", header_line)
    v = np.column_stack([cols[f"{a}{kind}"] for a in "xyz"])
    if kind == "u":
        return v
    if kind == "":
        return v + images @ cell
    if kind == "su":
        return origin + v @ cell
    return origin + (v + images) @ cell


_GZIP_MAGIC = b"\x1f\x8b"


def _open_text(path):
    """A text stream of the file: gzip-compressed files (recognised by their first two bytes,
    whatever their name) are decompressed; a file named ``.gz`` that is not gzip raises
    ValueError, as does any file that cannot be read (a directory, no permission)."""
    try:
        with open(path, "rb") as fh:
            magic = fh.read(2)
    except OSError as exc:
        raise ValueError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    if magic == _GZIP_MAGIC:
        return gzip.open(path, "rt", encoding="utf-8", errors="replace")
    if str(path).endswith(".gz"):
        raise ValueError(f"{path}: the name ends in .gz but the file is not gzip-compressed "
                         f"(it starts with {magic!r}, not {_GZIP_MAGIC!r}); rename it without .gz or compress it")
    return open(path, "r", encoding="utf-8", errors="replace")


def read_dump(path, timestep_size: float | None = None, axis="z", *, length_scale: float | None = None,
              drop_incomplete: bool = False) -> DumpTrajectories:
    """Read a LAMMPS/LIGGGHTS text dump (``dump atom`` or ``dump custom``) with any number of
    snapshots.

    Parameters
    ----------
    path : the dump file (``.gz`` read transparently).
    timestep_size : the run's time step Δt [s]; then ``t = timestep * Δt`` for a file without
        ``ITEM: TIME`` blocks.  A file with them (in a units style with a time unit) keeps its
        own times, and a Δt that contradicts them (``timestep * Δt`` off by more than 1e-6 of
        the largest time, see :func:`time_mismatch`) raises ValueError saying by how much.
        Without Δt, ``t`` comes from the ``ITEM: TIME`` blocks if the file has them (and its
        units style has a time unit in seconds, i.e. not ``lj``), else it is None.
    axis : the vertical axis ('x', 'y' or 'z'), the default of :meth:`DumpTrajectories.heights`;
        the file must have a coordinate column for it.
    length_scale : metres per file length unit; default from ``ITEM: UNITS`` if present, else 1
        (SI).
    drop_incomplete : if True, a last snapshot cut short (a dump still being written) is dropped
        instead of raising.

    Returns
    -------
    :class:`DumpTrajectories`, atoms sorted by id.

    Raises
    ------
    FileNotFoundError if the file does not exist; ValueError naming the file (and the line
    where there is one) for a file that cannot be read (a directory, no permission, a ``.gz``
    name on a file that is not gzip, damaged or truncated gzip data), a malformed file, a
    coordinate that is NaN or infinite, a dump without atoms, a snapshot whose atoms differ from
    the first snapshot's, a missing ``id`` or coordinate column, time steps that do not
    increase, or a ``timestep_size`` contradicting the file's ``ITEM: TIME``.
    """
    path = os.fspath(path)
    k_axis = _axis_index(axis)
    if timestep_size is not None and not (math.isfinite(timestep_size) and timestep_size > 0):
        raise ValueError(f"timestep_size = {timestep_size!r} is outside the valid range (0, inf) s")
    if length_scale is not None and not (math.isfinite(length_scale) and length_scale > 0):
        raise ValueError(f"length_scale = {length_scale!r} is outside the valid range (0, inf) m")
    if not os.path.exists(path):
        raise FileNotFoundError(f"{path}: no such file")

    try:
        result = _read_snapshots(path, k_axis, drop_incomplete)
    except (EOFError, zlib.error, gzip.BadGzipFile) as exc:       # a damaged or truncated gzip stream
        raise ValueError(f"{path}: damaged or truncated gzip data ({exc})") from None
    except OSError as exc:
        raise ValueError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    steps, times, positions, origins, cells, extra, ids0, types0, boundary, units, first_line = result
    if not steps:
        raise ValueError(f"{path}: no snapshot found (not a LAMMPS text dump?)")
    if ids0.size == 0:
        raise ValueError(f"{path}, line {first_line}: NUMBER OF ATOMS is 0: the dump holds no atoms")
    return _assemble(path, k_axis, timestep_size, length_scale, steps, times, positions, origins, cells,
                     extra, ids0, types0, boundary, units)


def _read_snapshots(path, k_axis, drop_incomplete):
    """The per-snapshot lists of :func:`read_dump` (no unit conversion)."""
    steps, times, positions, origins, cells, extra = [], [], [], [], [], {}
    ids0 = types0 = None
    boundary, units = "", None
    first_line = None
    with _open_text(path) as fh:
        lines = _Lines(fh, path)
        while True:
            lines.skip_blank()
            if not lines.peek():
                break
            snap = dict(time=None, step=None, n=None, origin=None, cell=None)
            start_line = lines.number + 1
            try:
                columns, header_line = _read_header(lines, snap, start_line)
                if snap["units"] is not None:
                    units = snap["units"]
                if columns is None:
                    raise lines.error("file ends before the ITEM: ATOMS block of the snapshot starting "
                                      f"on line {start_line}", lines.number + 1)
                block, first = _atom_block(lines, snap["n"], columns, header_line)
            except ValueError as exc:
                if drop_incomplete and "file ends" in str(exc) and steps:
                    break
                raise
            if not steps:
                boundary = snap.get("boundary", "")
                first_line = snap["n_line"]
            cols = {}
            if "id" not in columns:
                raise lines.error("the ATOMS header has no 'id' column: atoms cannot be matched between "
                                  f"snapshots (columns: {' '.join(columns)})", header_line)
            for j, name in enumerate(columns):
                if name in cols:
                    continue                          # a repeated column name (e.g. LIGGGHTS' "type type")
                if name in ("id", "type", "ix", "iy", "iz"):
                    cols[name] = _column_values(block, j, name, lines, first, integer=True)
                elif name in _POSITION_COLUMNS:
                    cols[name] = _column_values(block, j, name, lines, first, finite=True)
                else:
                    try:
                        cols[name] = block[:, j].astype(np.float64)
                    except ValueError:
                        pass                          # non-numeric column (e.g. element): not kept
            ids = cols["id"]
            order = np.argsort(ids, kind="stable")
            ids = ids[order]
            dup = ids[1:][ids[1:] == ids[:-1]]
            if dup.size:
                raise lines.error(f"atom id {int(dup[0])} appears twice in the snapshot at timestep "
                                  f"{snap['step']}", header_line)
            axis_name = "xyz"[k_axis]
            if not any(f"{axis_name}{s}" in cols for s in _KINDS):
                raise lines.error(f"no coordinate column for axis {axis_name!r}: need one of "
                                  f"{', '.join(axis_name + s for s in _KINDS)} (columns: {' '.join(columns)})",
                                  header_line)
            if ids0 is None:
                ids0 = ids
                types0 = cols["type"][order] if "type" in cols else None
            elif ids.size != ids0.size or np.any(ids != ids0):
                gone = np.setdiff1d(ids0, ids)
                new = np.setdiff1d(ids, ids0)
                parts = []
                if gone.size:
                    parts.append(f"atom id(s) {_few(gone)} disappeared")
                if new.size:
                    parts.append(f"atom id(s) {_few(new)} appeared")
                raise lines.error(f"the snapshot at timestep {snap['step']} has {ids.size} atoms, the first "
                                  f"has {ids0.size}: " + " and ".join(parts) + " (atoms must persist)",
                                  start_line)
            if steps and snap["step"] <= steps[-1]:
                raise lines.error(f"timestep {snap['step']} does not increase (previous snapshot: "
                                  f"{steps[-1]})", start_line)
            pos = _positions(cols, snap["origin"], snap["cell"], ids.size, lines, header_line)[order]
            steps.append(snap["step"])
            times.append(snap["time"])
            positions.append(pos)
            origins.append(snap["origin"] if snap["origin"] is not None else np.full(3, np.nan))
            cells.append(snap["cell"] if snap["cell"] is not None else np.full((3, 3), np.nan))
            for name, v in cols.items():
                if name in ("id",) or name in _POSITION_COLUMNS:
                    continue
                series = extra.setdefault(name, [])
                if len(series) != len(steps) - 1:       # column absent from an earlier snapshot
                    series.extend([np.full(ids.size, np.nan)] * (len(steps) - 1 - len(series)))
                series.append(v[order])
    return steps, times, positions, origins, cells, extra, ids0, types0, boundary, units, first_line


def _assemble(path, k_axis, timestep_size, length_scale, steps, times, positions, origins, cells, extra,
              ids0, types0, boundary, units) -> DumpTrajectories:
    if length_scale is None:
        if units is None:
            length_scale = 1.0
        elif units in LENGTH_UNITS:
            length_scale = LENGTH_UNITS[units]
        else:
            raise ValueError(f"{path}: units style {units!r} has no length unit in metres; pass "
                             "length_scale (metres per file length unit)")
    nt = len(steps)
    fields = {}
    for name, series in extra.items():
        series = series + [np.full(ids0.size, np.nan)] * (nt - len(series))
        fields[name] = np.array(series)
    timestep = np.array(steps, dtype=np.int64)
    has_times = all(v is not None for v in times)
    t_file = None
    if has_times and (units is None or units in TIME_UNITS):
        t_file = np.array(times, dtype=float) * TIME_UNITS.get(units or "si", 1.0)
    if t_file is not None:
        t = t_file
        if timestep_size is not None:
            bad = time_mismatch(timestep, t_file, timestep_size)
            if bad:
                raise ValueError(f"{path}: timestep_size = {timestep_size!r} s contradicts the file's ITEM: TIME: "
                                 f"{bad}; leave timestep_size out (the file's times are used)")
    elif timestep_size is not None:
        t = timestep * float(timestep_size)
    else:
        t = None           # no times, or ITEM: TIME in a style without a time unit in seconds (lj)
    return DumpTrajectories(path=path, timestep=timestep, t=t, ids=ids0,
                            positions=np.array(positions) * length_scale, types=types0,
                            origin=np.array(origins) * length_scale, cell=np.array(cells) * length_scale,
                            boundary=boundary, units=units, length_scale=float(length_scale), fields=fields,
                            axis="xyz"[k_axis])


def time_mismatch(timestep, t_file, timestep_size, rtol=1e-6) -> str:
    """'' if ``timestep * timestep_size`` reproduces the times ``t_file`` [s] of the file's
    ITEM: TIME blocks to ``rtol`` of the largest |time| (and 1e-6 of one step), else a phrase
    saying by how much they differ (the largest difference and where)."""
    timestep = np.asarray(timestep, dtype=np.int64)
    t_file = np.asarray(t_file, dtype=float)
    t_dt = timestep * float(timestep_size)
    diff = np.abs(t_dt - t_file)
    tol = rtol * max(float(np.max(np.abs(t_file))), float(np.max(np.abs(t_dt)))) + 1e-6 * float(timestep_size)
    k = int(np.argmax(diff))
    if diff[k] <= tol:
        return ""
    span = float(t_file[-1] - t_file[0])
    rel = f" ({float(t_dt[-1] - t_dt[0]) / span:.4g}x the file's time span)" if span > 0 else ""
    return (f"timestep x dt differs from the file's times by up to {diff[k]:.4g} s (timestep {int(timestep[k])}: "
            f"{t_dt[k]:.6g} s against {t_file[k]:.6g} s){rel}")


def _few(values, n=5):
    shown = ", ".join(str(int(v)) for v in values[:n])
    return shown + (f", ... ({values.size} in all)" if values.size > n else "")


_ITEM = re.compile(r"^ITEM:\s*(.*?)\s*$")


def _read_header(lines, snap, start_line):
    """Read the items of one snapshot up to and including the ATOMS header; fills ``snap``.
    Returns (column names, line number of the ATOMS header), or (None, None) at end of file."""
    snap["units"] = None
    while True:
        text = lines.next()
        if text is None:
            return None, None
        if not text.strip():
            continue
        m = _ITEM.match(text.strip())
        if not m:
            raise lines.error(f"expected an 'ITEM:' line, found {text.strip()[:60]!r}")
        item = m.group(1)
        upper = item.upper()
        if upper == "UNITS":
            snap["units"] = lines.next("the units style").strip().lower()
        elif upper == "TIME":
            snap["time"] = _parse_floats(lines, "the simulation time", 1)[0]
        elif upper == "TIMESTEP":
            if snap["step"] is not None:
                raise lines.error(f"a second ITEM: TIMESTEP in the snapshot starting on line {start_line} "
                                  "(the previous snapshot's ATOMS block is missing)")
            snap["step"] = _parse_int(lines, "the timestep")
        elif upper == "NUMBER OF ATOMS":
            n = _parse_int(lines, "the number of atoms")
            if n < 0:
                raise lines.error(f"negative number of atoms {n}")
            snap["n"] = n
            snap["n_line"] = lines.number
        elif upper.startswith("BOX BOUNDS"):
            snap["origin"], snap["cell"], snap["boundary"] = _parse_box(lines, "ITEM: " + item)
        elif upper.startswith("ATOMS"):
            header_line = lines.number
            columns = item.split()[1:]
            if not columns:
                raise lines.error("the ATOMS header names no columns")
            if snap["step"] is None or snap["n"] is None:
                missing = [w for w, k in (("TIMESTEP", "step"), ("NUMBER OF ATOMS", "n")) if snap[k] is None]
                raise lines.error(f"ITEM: ATOMS before ITEM: {' and ITEM: '.join(missing)}")
            return columns, header_line
        else:
            raise lines.error(f"'ITEM: {item}' is not part of a per-atom dump (dump atom/custom)")


# ----------------------------------------------------------------------------- writing


def write_dump(path, timesteps, positions, ids=None, types=None, box=None, boundary="ff ff ff",
               fields=None, time=None, units=None):
    """Write per-atom trajectories as a LAMMPS ``dump custom`` text file (columns
    ``id type x y z`` plus ``fields``), one snapshot per time step, in the exact layout LAMMPS
    writes (box bounds as ``%1.16e``), with numbers printed to full double precision (17
    significant digits) so that :func:`read_dump` gives back the same floats.

    Parameters
    ----------
    path : output file.
    timesteps : (nt,) integer step numbers, increasing.
    positions : (nt, n_atoms, 3) centres, or (nt, n_atoms) heights (written as z with x = y = 0),
        in the file's length unit (metres for ``units=None`` or ``"si"``).
    ids : (n_atoms,) atom ids (default 1..n_atoms).
    types : (n_atoms,) atom types (default 1).
    box : ((xlo, xhi), (ylo, yhi), (zlo, zhi)) orthogonal box (default: the positions' bounding
        box widened by 1 in every direction).
    boundary : boundary flags written after BOX BOUNDS.
    fields : extra columns, name -> (nt, n_atoms) array (e.g. ``{"radius": ...}``).
    time : (nt,) simulation times written as ``ITEM: TIME`` blocks (optional).
    units : units style written once as ``ITEM: UNITS`` (optional).
    """
    timesteps = np.asarray(timesteps)
    pos = np.asarray(positions, dtype=float)
    if pos.ndim == 2:
        pos = np.stack([np.zeros_like(pos), np.zeros_like(pos), pos], axis=-1)
    nt, n = pos.shape[:2]
    if timesteps.shape != (nt,):
        raise ValueError(f"timesteps has shape {timesteps.shape}, expected ({nt},)")
    ids = np.arange(1, n + 1) if ids is None else np.asarray(ids)
    types = np.ones(n, dtype=int) if types is None else np.asarray(types)
    fields = dict(fields or {})
    if box is None:
        lo = np.nanmin(pos, axis=(0, 1)) - 1.0
        hi = np.nanmax(pos, axis=(0, 1)) + 1.0
        box = tuple(zip(lo, hi))
    names = ["id", "type", "x", "y", "z", *fields]
    with open(path, "w") as fh:
        if units:
            fh.write(f"ITEM: UNITS\n{units}\n")
        for i in range(nt):
            if time is not None:
                fh.write(f"ITEM: TIME\n{float(time[i]):.16g}\n")
            fh.write(f"ITEM: TIMESTEP\n{int(timesteps[i])}\nITEM: NUMBER OF ATOMS\n{n}\n")
            fh.write(f"ITEM: BOX BOUNDS {boundary}\n".replace(" \n", "\n"))
            for lo, hi in box:
                fh.write(f"{lo:1.16e} {hi:1.16e}\n")
            fh.write(f"ITEM: ATOMS {' '.join(names)}\n")
            extra = [fields[k][i] for k in fields]
            for j in range(n):
                vals = [f"{v:.17g}" for v in pos[i, j]] + [f"{e[j]:.17g}" for e in extra]
                fh.write(f"{int(ids[j])} {int(types[j])} {' '.join(vals)}\n")
