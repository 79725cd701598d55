"""``bsrflow run`` for 2-D / 3-D layers (issue #19): a TOML config with a ``[layer]`` table runs a
scenario of :mod:`bsrflow.physics.scenarios_nd` through the shared controller into the n-D
netCDF file (:class:`bsrflow.io.netcdf.NetCDFWriterND`), optionally VTK files for ParaView
(:class:`bsrflow.io.vtk.VTKWriter`), with checkpoints and ``--resume`` as the 1-D runs::

    [layer]
    kind = "tapped_layer"        # or "vibrated_box", or "packing_bed" (the packing continuum)
    dim = 3                      # and any field of TappedLayer / VibratedBox / PackingBed (SI units)
    t_end = 0.2
    [output]
    vtk = true                   # <out stem>_vtk/layer_*.vtu and layer.pvd
    checkpoint_every = 0.05      # [s], on snapshot times; 0: none; default about every 0.1 s (t_end/10 if shorter)
    state = true                 # packing_bed, granular_bed (default there): state fields (state_<name>, units)
    [tracers]
    positions = [[0.01, 0.005], [0.01, 0.015]]   # initial positions [m] (floor frame, x (y) z)

``kind = "packing_bed"`` (:class:`bsrflow.physics.packing_bed.PackingBed`) runs the n-D packing
continuum (:class:`bsrflow.numerics.packing_nd.EulerianPackingND`) into the same files; its
checkpoint holds the discretisation's named fields (history included).

``kind = "granular_bed"`` (:class:`bsrflow.physics.granular_bed.BedSetup`: its fields, e.g.
``gamma``, ``cycles``, ``n_cells``, ``output_height``, ``floor_restitution``, ``floor_loss``) runs the vibrated bed of packing stress
and granular temperature that ``bsrflow compare-bed`` compares with LIGGGHTS, horizontally
uniform, on its Lagrangian cells (:class:`bsrflow.numerics.bed_lagrangian.GranularBedColumn`):
snapshots every ``save_every`` = 1 ms unless given (compare-bed's 0.1 ms would make 118 MB for
11 cycles); the file is a column's (``rho`` the bed's mass per metre of height [kg/m], ``u_z``,
on bins of d/10) with, by default (``[output] state``), the cells' state (``state_face_height``,
``state_solid_fraction``, ``state_theta``, ``state_delta_max``) and ``state_floor_force`` [N];
no VTK, no tracers (refused in one line).

``kind = "granular_bed_eulerian"`` (:class:`bsrflow.physics.granular_bed.EulerianBedSetup`: the
same fields but ``n_cells``, and ``dimension``, ``cells_per_d``, ``lateral_cells``,
``perturbation``) runs the same bed on the Eulerian grid of
:class:`bsrflow.numerics.bed_eulerian.EulerianBed` (1-, 2- or 3-D, periodic sides) into the same
column file (``rho``, ``u_z``: the grid's mass per metre of height and its mean vertical velocity on
the d/10 bins) with, by default, the grid's fields as ``state_solid_fraction``,
``state_velocity_x/_y/_z``, ``state_theta``, ``state_delta_max`` on the dimensions ``grid_x``,
``grid_y``, ``grid_z`` (the cell sizes in the attribute ``grid_cell_size_m``) and
``state_floor_force``; checkpoints of its conserved fields; ``[output] vtk`` writes the grid's
cells (solid fraction, velocity, granular temperature) for ParaView.  Its ``[tracers]`` are z
(1-D), [x, z] (2-D) or [x, y, z] (3-D) inside the grid ([0, L] across, up to the lid), placed on
the settled bed at t = 0 and moved by :func:`bsrflow.numerics.bed_eulerian.bed_advance`; the
file's ``tracer_x`` (``tracer_y``), ``tracer_z`` are the grid's axes, not the column's.

Tracers (optional) are moved with the interpolated velocity by the scheme's tracer integrator
(:meth:`bsrflow.numerics.solver_nd.SimulationND.run`; for the packing bed and the granular bed's
Eulerian grid the fields' SSP-RK3 stages with the mass-weighted interpolation of
:func:`bsrflow.numerics.tracers.tracer_velocity`)
and written as ``tracer_x`` (``tracer_y``), ``tracer_z`` (lab frame) to the netCDF file;
checkpoints carry them.

Every key is checked before the run: an unknown table or key, a value of the wrong type or
outside its range, is one line ``layer.<key>: <problem>`` with the key's valid range (exit code
2).  The size of the grid (at most :data:`MAX_LAYER_CELLS` cells; a ``tapped_layer`` /
``vibrated_box`` resting layer at most :data:`MAX_RESTING_CELLS` cells tall) is computed in
Python numbers before anything is allocated, and a setting that only fails together with others
(the grid's size, a packing bed's stiffness check: its weight's overlap and its number of time
steps, the cells of the box for a diameter) names the field the config gives, with its valid
range at these settings.  ``domain_height`` not given is the energy bound; 0 is refused, as any
height below that bound.  ``settle_time`` is at most ``MAX_SETTLE_TIME`` (the scenarios'); one at or after
``t_end`` makes a run that only settles (a note when the config gives it).  A checkpoint ``<out>.ckpt`` holds the
state before the jump and the save at its time (the 1-D format, :mod:`bsrflow.io.checkpoint`,
with the n-D arrays), removed when the run finishes; ``--resume`` with the same config
continues bit for bit.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import os
import re
import tomllib
from dataclasses import dataclass

import numpy as np

from .._bounds import printed_bound
from .checkpoint import Checkpoint, checkpoint_path
from .config import ConfigError, _suggest
from .driver import OTHER_KIND, RunJob, RunOutcome, drive, first_difference
from ..physics.motion import MAX_SETTLE_TIME

__all__ = ["is_layer_config", "load_layer_config", "run_layer_config", "LayerOutcome"]

_LAYER_SYNONYMS = {
    "dim": ("dimension",), "dimension": ("dim",),
    "cells_per_d": ("cells_per_diameter",), "cells_per_diameter": ("cells_per_d",),
    "settle": ("settle_time",), "settle_time": ("settle",),
}
"""The layer kinds' names for the same setting (the n-D layers' ``dim``, ``cells_per_diameter``,
``settle_time``; the Eulerian bed's ``dimension``, ``cells_per_d``, ``settle``): a key of another
kind is answered with this kind's name."""

KINDS = ("tapped_layer", "vibrated_box", "packing_bed", "granular_bed", "granular_bed_eulerian")
BED_KINDS = ("granular_bed", "granular_bed_eulerian")
"""The kinds of the vibrated bed of packing stress and granular temperature (the column file)."""
_OUTPUT_KEYS = {"vtk": bool, "checkpoint_every": float, "state": bool}


def is_layer_config(path) -> bool:
    """True when the TOML file at ``path`` has a ``[layer]`` table (a 2-D / 3-D run)."""
    try:
        with open(path, "rb") as fh:
            return "layer" in tomllib.load(fh)
    except (OSError, tomllib.TOMLDecodeError, UnicodeDecodeError):
        return False        # load_config then names the file and the problem


@dataclass
class LayerConfig:
    setup: object
    vtk: bool
    checkpoint_every: float | None
    text: str
    tracers: np.ndarray | None = None
    state: bool = False

    def resolved_text(self, comment=None) -> str:
        """The config with every field of the scenario, the defaults included, as TOML (the
        output's ``config_resolved`` attribute: what ran, in full; ``config`` is the file as
        given, or with ``--set`` overrides the config as run, regenerated with a comment naming
        them).  Loading it gives the same scenario.  ``comment(table, key)``: an optional
        comment [str or None] after each field (``bsrflow init --layer`` gives ranges and units)."""
        import json
        kind = {v: k for k, v in _kind_classes().items()}[type(self.setup)]
        lines = ["[layer]", f"kind = {json.dumps(kind)}"]

        def add(table, key, text):
            note = comment(table, key) if comment is not None else None
            if note is None:
                lines.append(text)
            elif text.startswith("#"):                    # a field not given: the note on the same line
                lines.append(f"{text}; {note}")
            else:
                lines.append(f"{text:<40s} # {note}")

        for name in _option_fields(kind):
            value = getattr(self.setup, name)
            add("layer", name, f"# {name}: not given (derived by the scenario)" if value is None
                else f"{name} = {_toml_value(value)}")
        lines.append("[output]")
        add("output", "vtk", f"vtk = {_toml_value(self.vtk)}")
        add("output", "state", f"state = {_toml_value(self.state)}")
        add("output", "checkpoint_every",
            "# checkpoint_every: not given (about every 0.1 s, or t_end/10 if shorter, on snapshot times)"
            if self.checkpoint_every is None else f"checkpoint_every = {_toml_value(self.checkpoint_every)}")
        if self.tracers is not None:
            rows = ", ".join("[" + ", ".join(_toml_value(float(v)) for v in row) + "]" for row in self.tracers)
            lines += ["[tracers]", f"positions = [{rows}]"]
        return "\n".join(lines) + "\n"


def default_layer_config_text(kind: str) -> str:
    """A commented layer config of ``kind`` (one of :data:`KINDS`) for ``bsrflow init --layer``:
    every field its config takes, with its default (the scenario class's, as ``config_resolved``
    writes them) and, in a comment, its valid range and unit as its one-line errors state them.
    Loading it gives the default scenario of that kind."""
    if kind not in KINDS:
        raise ConfigError("--layer", f"{kind!r} is not one of {', '.join(KINDS)}")
    cls = _kind_classes()[kind]
    setup = cls(**({"save_every": GRANULAR_BED_SAVE_EVERY} if kind in BED_KINDS else {}))
    ranges = _RANGES[kind]
    output_notes = {"vtk": "true: a VTK file per snapshot in <out stem>_vtk/ (ParaView: its .pvd)",
                    "state": "true: also the discretisation's state fields, state_<name> with units",
                    "checkpoint_every": "[s], 0: no checkpoints"}

    def comment(table, key):
        if table == "layer":
            return f"valid: {_range_text(ranges[key])}" if key in ranges else None
        return output_notes.get(key)

    head = [f"# bsrflow layer config, kind = {kind!r}: every field with its default; the valid range and",
            "# unit of each in its comment (SI units; the scenario narrows some ranges at the other",
            "# fields' values and says so when it refuses one).  Run it with: bsrflow run <this file>"]
    body = LayerConfig(setup=setup, vtk=False, checkpoint_every=None, text="").resolved_text(comment)
    return "\n".join(head) + "\n" + body


def _option_fields(kind: str) -> dict:
    """The fields of ``kind``'s scenario class that its config takes (name -> dataclass field, in
    the class's order; :data:`_NOT_OPTIONS` left out)."""
    return {f.name: f for f in dataclasses.fields(_kind_classes()[kind]) if f.name not in _NOT_OPTIONS.get(kind, ())}


def _toml_value(value) -> str:
    import json
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return repr(float(value))
    return json.dumps(str(value))


def _kind_classes() -> dict:
    from ..physics.granular_bed import BedSetup, EulerianBedSetup
    from ..physics.packing_bed import PackingBed
    from ..physics.scenarios_nd import TappedLayer, VibratedBox
    return {"tapped_layer": TappedLayer, "vibrated_box": VibratedBox, "packing_bed": PackingBed,
            "granular_bed": BedSetup, "granular_bed_eulerian": EulerianBedSetup}


def load_layer_config(path, overrides=()) -> LayerConfig:
    """Read and check a layer config (module docstring); ConfigError on the first problem.
    ``overrides``: ``"KEY=VALUE"`` items (``bsrflow run --set``), KEY ``layer.<field>``,
    ``output.<key>`` or a bare field of the scenario, VALUE a TOML value; applied before the
    checks, and the config's text (the ``config`` attribute and the checkpoint's) is then the
    file's with them applied."""
    with open(path, "rb") as fh:
        raw = fh.read()
    return _layer_config_from_text(raw.decode("utf-8"), overrides, os.path.basename(os.fspath(path)))


def _layer_config_from_text(text: str, overrides=(), name: str = "the config") -> LayerConfig:
    """The checked layer config of a TOML ``text`` (a file's, a checkpoint's or an output's) with
    the ``--set`` ``overrides`` applied (:func:`load_layer_config`)."""
    raw = text.encode("utf-8")
    data = tomllib.loads(text)
    _check_tables(data)
    if overrides:
        data = _with_overrides(data, overrides)
        raw = (f"# {name} with --set " + " ".join(o.strip() for o in overrides)
               + "\n" + _dump_layer_toml(data)).encode("utf-8")
    if "layer" not in data:
        raise ConfigError("layer", "no [layer] table: not a layer config")
    layer = dict(data["layer"])
    kind = layer.pop("kind", "tapped_layer")
    if kind not in KINDS:
        raise ConfigError("layer.kind", f"{kind!r} is not one of {', '.join(KINDS)}")
    cls = _kind_classes()[kind]
    names = _option_fields(kind)
    kw = {}
    if kind in BED_KINDS:
        kw["save_every"] = GRANULAR_BED_SAVE_EVERY      # a config run's default (compare-bed saves every 0.1 ms)
    ranges = _RANGES[kind]
    for key, value in layer.items():
        if key not in names:
            near = next((n for n in _LAYER_SYNONYMS.get(key, ()) if n in names), "")
            other = next((k for k in KINDS if k != kind and key in _option_fields(k)), "")
            if near:
                hint = f" (did you mean {near}?)"
            elif other:                                     # not this kind's setting: no near name
                hint = f" (a key of kind = {other!r})"
            else:
                near = _suggest(key, names)
                hint = f" (did you mean {near}?)" if near else ""
            raise ConfigError(f"layer.{key}", f"unknown key for kind = {kind!r}{hint}; valid: {', '.join(sorted(names))}")
        _check_type(f"layer.{key}", value, str(names[key].type), ranges[key])
        kw[key] = value
    given = frozenset(layer)
    _check_layer_bounds(kind, kw)
    try:
        setup = cls(**kw)
    except (ValueError, TypeError, ArithmeticError) as exc:     # (1e-300: a division by zero)
        msg = str(exc).splitlines()[0]
        if isinstance(exc, ArithmeticError):
            msg = f"the setup's numbers overflow or divide by zero ({type(exc).__name__})"
        problem = None
        if kind not in BED_KINDS:        # a grid too large, or a bound of the field the user set
            raw = _unchecked_setup(cls, kw)
            problem = _size_problem(kind, raw, given) or _reblamed(kind, raw, given, msg)
        if problem is None and (kind in BED_KINDS or isinstance(exc, ArithmeticError)):
            problem = _bed_reblamed(cls, kw, given, msg)     # a check across fields: the given field that mends it
        if problem:
            raise ConfigError(*problem) from None
        field = next((k for k in kw if msg.startswith(k)), None)
        raise ConfigError(f"layer.{field}" if field else "layer", msg) from None
    if kind in ("tapped_layer", "vibrated_box") and setup.domain_height == 0:   # (the class takes 0 as not given)
        raise ConfigError("layer.domain_height", f"domain_height = {setup.domain_height!r} m is outside the valid "
                          f"range [{setup.energy_bound_height():.4g}, inf) m (energy bound; not given: the energy "
                          "bound)")
    height = setup.domain_height or setup.energy_bound_height()
    if not math.isfinite(height):
        drive = "amplitude" if kind in ("tapped_layer", "vibrated_box") else "gamma"
        raise ConfigError(f"layer.{drive}", f"{kw.get(drive, getattr(setup, drive))!r} gives the floor a largest speed "
                          f"of {setup.floor_speed():.3g} m/s and an unbounded domain (the energy bound (3aω)²/(2g)); "
                          f"valid: a finite floor speed, at most {MAX_LAYER_CELLS:.0e} cells in the grid")
    problem = None if kind in BED_KINDS else _size_problem(kind, setup, given)
    if problem:                          # before the grid is made (Python floats: no overflow)
        raise ConfigError(*problem)
    try:
        cells = math.prod(setup.grid().shape)       # Python ints: exact (no int64 overflow)
    except (ValueError, TypeError, OverflowError) as exc:
        msg = str(exc).splitlines()[0]
        field = next((k for k in names if msg.startswith(f"{k} = ")), None)
        if msg.startswith("shape = ") and kind == "packing_bed" and {"box_width", "diameter"} & given:
            raise ConfigError(*_narrow_box_problem(setup, given)) from None
        raise ConfigError(f"layer.{field}" if field else "layer", msg) from None
    if cells > MAX_LAYER_CELLS:          # (the checks above refuse it first, naming a field)
        raise ConfigError("layer", f"the grid would have {_count_text(cells)} cells; at most {MAX_LAYER_CELLS:.0e} "
                          "(reduce the box, the heights, the cells per diameter or the floor's speed, which sets the "
                          "domain height by the energy bound)")
    out = dict(data.get("output", {}))
    for key, value in out.items():
        if key not in _OUTPUT_KEYS:
            near = _suggest(key, _OUTPUT_KEYS)
            raise ConfigError(f"output.{key}", "unknown key" + (f" (did you mean {near}?)" if near else "")
                              + f"; valid: {', '.join(_OUTPUT_KEYS)}")
    vtk = out.get("vtk", False)
    if not isinstance(vtk, bool):
        raise ConfigError("output.vtk", f"{vtk!r} must be true or false")
    state = out.get("state", kind in BED_KINDS)
    if not isinstance(state, bool):
        raise ConfigError("output.state", f"{state!r} must be true or false")
    if kind == "granular_bed":
        if vtk:
            raise ConfigError("output.vtk", "true: not an option of kind = \"granular_bed\" (a horizontally uniform "
                              "bed: its profiles are in the netCDF file; VTK is for 2-D / 3-D fields)")
        if "tracers" in data:
            raise ConfigError("tracers", "not an option of kind = \"granular_bed\" (its Lagrangian cells' faces, "
                              "state_face_height in the file, are its material lines)")
    if state and kind not in ("packing_bed",) + BED_KINDS:
        raise ConfigError("output.state", f"true: an option of kind = \"packing_bed\", \"granular_bed\" or \"granular_bed_eulerian\" (the state of {kind!r}, "
                          "rho and u on the grid, is written in every file)")
    t_end = float(setup.t_end)
    if float(setup.save_every) > t_end:
        if "save_every" not in layer:
            why = " (t_end = cycles / frequency)" if kind in BED_KINDS else ""
            raise ConfigError("layer.save_every", f"not given: its default {setup.save_every:g} s is outside the "
                              f"valid range (0, t_end = {t_end:g}] s{why}; set it")
        raise ConfigError("layer.save_every", f"{setup.save_every!r} is outside the valid range (0, t_end = {t_end:g}] s")
    ck = out.get("checkpoint_every")
    if ck is not None:
        if isinstance(ck, bool) or not isinstance(ck, (int, float)):
            raise ConfigError("output.checkpoint_every", f"{ck!r} must be a finite number; valid range: [0, t_end = "
                              f"{t_end:g}] s (0: no checkpoints)")
        if not (math.isfinite(ck) and 0.0 <= ck <= t_end):
            raise ConfigError("output.checkpoint_every", f"{ck!r} is outside the valid range [0, t_end = {t_end:g}] s "
                              "(0: no checkpoints)")
    return LayerConfig(setup, vtk, None if ck is None else float(ck), raw.decode("utf-8"),
                       _tracer_positions(data.get("tracers"), setup), state)


def _check_tables(data: dict) -> None:
    """One line unless every top-level entry of a layer config is one of its tables."""
    for table in data:
        if table not in ("layer", "output", "tracers"):
            raise ConfigError(str(table), "unknown table in a layer config; valid: [layer], [output], [tracers]")
        if not isinstance(data[table], dict):
            raise ConfigError(str(table), f"{data[table]!r} must be a table ([{table}] with its keys)")


def _with_overrides(data: dict, overrides) -> dict:
    """The config tables ``data`` with the ``--set`` items applied (:func:`load_layer_config`)."""
    from ..tools.setup_source import check_given_once
    data = {k: dict(v) if isinstance(v, dict) else v for k, v in data.items()}
    layer = data.get("layer", {})
    kind = layer.get("kind", "tapped_layer")
    fields = {f.name for f in dataclasses.fields(_kind_classes()[kind])} if kind in KINDS else set()

    def dotted(key):
        key = key.strip()
        if "." in key:
            return key
        return f"output.{key}" if key in _OUTPUT_KEYS and key not in fields else f"layer.{key}"

    check_given_once((("--set", item.strip()) for item in overrides), key=dotted)
    for item in overrides:
        key, sep, value = item.partition("=")
        if not sep or not key.strip() or not value.strip():
            raise ConfigError("--set", f"{item!r} is not KEY=VALUE (e.g. layer.gamma=4)")
        table, _, name = dotted(key).partition(".")
        if table not in ("layer", "output") or not name or "." in name:
            raise ConfigError(f"--set {key.strip()}", "a layer config takes layer.<field> or output.<key> "
                              "(tracer positions: edit the [tracers] table)")
        try:
            parsed = tomllib.loads(f"v = {value.strip()}")["v"]
        except tomllib.TOMLDecodeError:
            parsed = value.strip()
        data.setdefault(table, {})[name] = parsed
    return data


def _dump_layer_toml(data: dict) -> str:
    """TOML text of the tables of a layer config (the keys in their order, values by
    :func:`_toml_value`; tracer positions as a list of lists)."""
    lines = []
    for table in ("layer", "output", "tracers"):
        if table not in data:
            continue
        lines.append(f"[{table}]")
        for key, value in data[table].items():
            if isinstance(value, (list, tuple)):
                text = "[" + ", ".join("[" + ", ".join(_toml_value(v) for v in row) + "]" if isinstance(row, (list, tuple))
                                       else _toml_value(row) for row in value) + "]"
            else:
                text = _toml_value(value)
            lines.append(f"{key} = {text}")
    return "\n".join(lines) + "\n"


GRANULAR_BED_SAVE_EVERY = 1e-3
"""A ``granular_bed`` config's default ``save_every`` [s]: 1 ms (``BedSetup``'s 0.1 ms, which
compare-bed's flight detection needs, would write 5 500 snapshots, 118 MB, for 11 cycles)."""

MAX_LAYER_CELLS = 1e7
"""The most cells a layer config may ask for (a 215³ grid).  A 2-D packing bed of 8e6 cells took
9.8 GB in an audit's run (about 1.2 kB per cell with the stepper's stage arrays), so 1e7 cells
stay within a 24-GB machine."""



MAX_RESTING_CELLS = 10_000
"""The tallest resting layer of ``tapped_layer`` / ``vibrated_box`` [cells, at the crests of the
surface undulation]: its rest state is a dense linear solve of that size (10 000 cells: a 0.8-GB
matrix; :func:`bsrflow.physics.scenarios_nd.resting_profile`)."""


@dataclass(frozen=True)
class _Range:
    """A numeric field's valid range (its one-line errors)."""
    lo: float
    hi: float = math.inf
    unit: str = ""
    lo_open: bool = False
    hi_open: bool = False
    integer: bool = False
    note: str = ""


def _g(x) -> str:
    return "inf" if x == math.inf else f"{x:g}"


def _range_text(spec, lo: str | None = None, hi: str | None = None, note: bool = True) -> str:
    """``spec`` (a :class:`_Range` or the text of a non-numeric field's range) as text; ``lo``,
    ``hi``: bounds at these settings (closed), formatted, in place of the static ones."""
    if isinstance(spec, str):
        return spec
    lo_s = _g(spec.lo) if lo is None else lo
    hi_s = _g(spec.hi) if hi is None else hi
    if spec.integer:
        text = f"integers >= {lo_s}" if hi_s == "inf" else f"integers in [{lo_s}, {hi_s}]"
    else:
        left = "(" if lo is None and spec.lo_open else "["
        right = ")" if hi is None and (spec.hi_open or spec.hi == math.inf) else "]"
        text = f"{left}{lo_s}, {hi_s}{right}" + (f" {spec.unit}" if spec.unit else "")
    return text + (f" {spec.note}" if note and spec.note else "")


_INF = math.inf
_HEIGHT_NOTE = "(or not given: the energy bound)"
_LAYER_RANGES = {
    "dim": "{2, 3}",
    "box_width": _Range(0, _INF, "m", lo_open=True, note="(whole cells of Δx = diameter / cells_per_diameter, at "
                        "least cells_per_diameter + 1 of them; at most 1e+07 cells in the grid)"),
    "layer_height": _Range(0, _INF, "m", lo_open=True, note="(at least cells_per_diameter + 1 cells, at most "
                           f"{MAX_RESTING_CELLS})"),
    "diameter": _Range(0, _INF, "m", lo_open=True),
    "cells_per_diameter": _Range(2, _INF, integer=True),
    "bottom_density": _Range(1e-6, 1e6, "kg/m^n"),
    "dissipation": _Range(0, 1, hi_open=True),
    "gravity": _Range(1e-3, 1e4, "m/s^2"),
    "sides": "'wall' or 'periodic'",
    "surface_perturbation": _Range(0, 0.5),
    "settle_time": _Range(0, MAX_SETTLE_TIME, "s"),
    "t_end": _Range(0, _INF, "s", lo_open=True),
    "save_every": "(0, t_end] s",
    "scheme": "'seed'",
    "average": "'na' or 'tensor'",
    "domain_height": f"[energy bound, inf) m {_HEIGHT_NOTE}",
    "positivity": "true or false",
    "amplitude": _Range(0, _INF, "m"),
    "frequency": _Range(1e-3, 1e4, "Hz"),
}
_RANGES = {
    "tapped_layer": {**_LAYER_RANGES, "n_taps": _Range(1, _INF, integer=True),
                     "tap_period": _Range(0, _INF, "s", lo_open=True,
                                          note="(at least 1/(2 frequency) with n_taps > 1)")},
    "vibrated_box": dict(_LAYER_RANGES),
    "packing_bed": {
        "dim": "{2, 3}",
        "box_width": _Range(0, _INF, "m", lo_open=True, note="(whole cells of Δx = diameter / cells_per_diameter, at "
                            "least 3 of them; at most 1e+07 cells in the grid)"),
        "bed_height": _Range(0, _INF, "m", lo_open=True, note="(at least two cells)"),
        "diameter": _Range(0, _INF, "m", lo_open=True),
        "density": _Range(0, 1e5, "kg/m^3", lo_open=True),
        "stiffness": _Range(0, _INF, "N/m", lo_open=True, note="(narrowed at these settings by the bed's weight and "
                            "the number of time steps)"),
        "restitution": _Range(0.01, 1),
        "phi_c": _Range(0, 0.75, lo_open=True, hi_open=True),
        "coordination": _Range(0, 12, lo_open=True),
        "cells_per_diameter": _Range(1, _INF, integer=True),
        "frequency": _Range(1e-3, 1e4, "Hz"),
        "gamma": _Range(0, _INF),
        "settle_time": _Range(0, MAX_SETTLE_TIME, "s"),
        "t_end": _Range(0, _INF, "s", lo_open=True),
        "save_every": "(0, t_end] s",
        "stiffness_factor": _Range(0, 1, lo_open=True),
        "surface_perturbation": _Range(0, 0.5),
        "cfl": "(0, 0.5/dim] (or not given: 0.4/dim)",
        "gravity": _Range(0, _INF, "m/s^2", lo_open=True),
        "domain_height": f"[energy bound, inf) m {_HEIGHT_NOTE}",
    },
    "granular_bed": {
        "n_spheres": _Range(1, 1e7, integer=True),
        "diameter": _Range(0, 1, "m", lo_open=True),
        "density": _Range(0, 1e5, "kg/m^3", lo_open=True),
        "stiffness": _Range(0, 1e12, "N/m", lo_open=True),
        "restitution": _Range(0, 1, lo_open=True, hi_open=True),
        "friction": _Range(0, 1),
        "side": _Range(0, 100, "m", lo_open=True),
        "phi_c": _Range(0, 0.74, lo_open=True, hi_open=True),
        "coordination": _Range(0, 12, lo_open=True),
        "gravity": _Range(0, 1e3, "m/s^2", lo_open=True),
        "frequency": _Range(1e-3, 1e4, "Hz"),
        "gamma": _Range(0, 20),
        "cycles": _Range(1, 1e7, integer=True),
        "settle": _Range(0, 10, "s"),
        "n_cells": _Range(4, 1e7, integer=True),
        "cfl": _Range(0, 0.5, lo_open=True),
        "theta_seed": _Range(0, 1, "m^2/s^2"),
        "save_every": _Range(0, 1, "s", lo_open=True),
        "output_height": _Range(0, 100, "m", lo_open=True,
                                note="(or not given: the rest height + (3aω)²/(2g) + 10 d)"),
        "floor_restitution": _Range(0, 1, lo_open=True, note="(or not given: the spheres' restitution)"),
        "floor_loss": "'kinetic_pressure' or 'floor_reaction' (not given: 'kinetic_pressure')",
    },
}
_RANGES["granular_bed_eulerian"] = {**{k: v for k, v in _RANGES["granular_bed"].items() if k != "n_cells"},
                                    "dimension": _Range(1, 3, integer=True),
                                    "cells_per_d": _Range(1, 64, integer=True),
                                    "lateral_cells": _Range(1, 256, integer=True,
                                                            note="(1 for a column, at least 2 in 2-D / 3-D; "
                                                                 "not given: 1 for a column, else 4)"),
                                    "perturbation": _Range(0, 0.05, note="(0 for a column)"),
                                    "floor_loss": "'kinetic_pressure' (not given: 'kinetic_pressure'; "
                                                  "'floor_reaction' is an option of kind = \"granular_bed\")"}
_NOT_OPTIONS = {"granular_bed_eulerian": ("n_cells",)}
"""Fields of a kind's class that its config does not take (the Eulerian bed has no Lagrangian cells)."""
"""Each kind's fields' valid ranges, as its one-line errors state them (the scenario classes check
them; those that depend on other fields are narrowed there)."""


def _check_type(name, value, annotation, valid):
    """One line naming ``name`` and its valid range ``valid`` (:func:`_range_text`) unless
    ``value`` has the field's TOML type (``annotation`` as the dataclass gives it: "int", "float",
    "float | None", "bool", "str")."""
    rng = _range_text(valid)
    if annotation.startswith("int"):
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(name, f"{value!r} must be an integer; valid range: {rng}")
    elif annotation.startswith("float"):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ConfigError(name, f"{value!r} must be a finite number; valid range: {rng}")
    elif annotation.startswith("bool"):
        if not isinstance(value, bool):
            raise ConfigError(name, f"{value!r} must be true or false")
    elif annotation.startswith("str"):
        if not isinstance(value, str):
            raise ConfigError(name, f"{value!r} must be a string; valid: {rng}")


def _check_layer_bounds(kind: str, kw: dict) -> None:
    """The bound of a layer config that its scenario class leaves to the taps' motion, which names
    its own parameter (``period``): a single tap's ``tap_period`` > 0, named as the config's key."""
    tp = kw.get("tap_period")
    if kind == "tapped_layer" and tp is not None and kw.get("n_taps", 1) == 1 and not tp > 0.0:
        raise ConfigError("layer.tap_period", f"{tp!r} is outside the valid range "
                          f"{_range_text(_RANGES[kind]['tap_period'])}")


def _unchecked_setup(cls, kw: dict):
    """An instance of the scenario class ``cls`` with the fields ``kw`` (defaults for the others)
    that is not checked (``__post_init__`` not run): what the grid checks compute with when the
    class refuses the fields."""
    obj = cls.__new__(cls)
    for f in dataclasses.fields(cls):
        value = kw[f.name] if f.name in kw else f.default
        if value is dataclasses.MISSING:
            value = f.default_factory() if f.default_factory is not dataclasses.MISSING else None
        object.__setattr__(obj, f.name, value)
    return obj


def _with(setup, name: str, value):
    """A copy of the (unchecked) ``setup`` with one field changed."""
    other = copy.copy(setup)
    object.__setattr__(other, name, value)
    return other


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _height_field(kind: str) -> str:
    return "bed_height" if kind == "packing_bed" else "layer_height"


def _size_inputs_ok(kind: str, s) -> bool:
    """True when the fields that set the grid of the layer ``s`` are each in their range (so its
    size can be computed; the scenario class names any other problem)."""
    from ..physics.motion import FREQUENCY_RANGE
    drive = "gamma" if kind == "packing_bed" else "amplitude"
    c = s.cells_per_diameter
    return (s.dim in (2, 3) and not isinstance(s.dim, bool)
            and isinstance(c, int) and not isinstance(c, bool) and c >= (1 if kind == "packing_bed" else 2)
            and all(_finite(getattr(s, k)) and getattr(s, k) > 0
                    for k in ("box_width", "diameter", _height_field(kind), "gravity"))
            and _finite(s.surface_perturbation) and 0.0 <= s.surface_perturbation <= 0.5
            and _finite(s.frequency) and FREQUENCY_RANGE[0] <= s.frequency <= FREQUENCY_RANGE[1]
            and _finite(getattr(s, drive)) and getattr(s, drive) >= 0.0
            and (s.domain_height is None or (_finite(s.domain_height) and s.domain_height > 0))
            and all(_in_static_range(_RANGES[kind].get(k), getattr(s, k)) for k in _SIZE_FIELDS[kind]))


def _in_static_range(spec, value) -> bool:
    """True when ``value`` lies in the static range ``spec`` (a :class:`_Range`; anything else is
    not checked here): a field outside its own range is named by the scenario class, not blamed
    for the grid's size (``gravity = 1e-9`` raises the energy bound's domain height)."""
    if not isinstance(spec, _Range) or value is None:
        return True
    if not _finite(value):
        return False
    above = value > spec.lo if spec.lo_open else value >= spec.lo
    below = value < spec.hi if spec.hi_open else value <= spec.hi
    return above and below


def _grid_size(kind: str, s):
    """(cells of the grid, cells of the resting layer's crests (None for a packing bed), Δx [m],
    domain height [m]) of the layer ``s``, in Python floats (inf where they overflow; nothing is
    allocated)."""
    dx = s.diameter / s.cells_per_diameter
    bound = s.energy_bound_height()
    height = bound if s.domain_height is None else s.domain_height
    nh, nz = s.box_width / dx, height / dx
    cells = math.inf
    if math.isfinite(nh) and math.isfinite(nz):
        cells = float(math.ceil(nz - 1e-9))
        for _ in range(s.dim - 1):
            cells *= float(round(nh))          # a product of floats overflows to inf, no exception
    rest = None
    if kind != "packing_bed":
        top = s.layer_height * (1.0 + s.surface_perturbation) / dx
        rest = float(round(top)) if math.isfinite(top) else math.inf
    return cells, rest, dx, height


def _grid_fits(kind: str, s) -> bool:
    """True when the grid of the layer ``s`` is not too large and its box and height hold the
    fewest cells the scenario class accepts (the bounds of :func:`_diameter_max`), so that a range
    stated for one field is one the class accepts too."""
    try:
        cells, rest, dx, _ = _grid_size(kind, s)
        d_max = _diameter_max(kind, s)
    except (ArithmeticError, TypeError, ValueError):
        return False
    return (cells <= MAX_LAYER_CELLS and (rest is None or rest <= MAX_RESTING_CELLS)
            and s.diameter <= d_max * (1.0 + 1e-12))


def _count_text(n) -> str:
    n = float(n) if not isinstance(n, int) or n < 1e300 else math.inf
    return "more than 1e+300" if n == math.inf else f"{n:.3g}"


_SIZE_FIELDS = {
    "packing_bed": ("box_width", "bed_height", "domain_height", "cells_per_diameter", "diameter", "gamma",
                    "frequency", "gravity", "surface_perturbation"),
    "tapped_layer": ("box_width", "layer_height", "domain_height", "cells_per_diameter", "diameter", "amplitude",
                     "frequency", "gravity", "surface_perturbation"),
}
_SIZE_FIELDS["vibrated_box"] = _SIZE_FIELDS["tapped_layer"]


def _size_problem(kind: str, s, given):
    """(field, message) when the grid of the layer ``s`` would have more than
    :data:`MAX_LAYER_CELLS` cells (or its resting layer more than :data:`MAX_RESTING_CELLS`),
    computed in Python floats before anything is allocated; the field is the first of those the
    config gives (``given``) that sets the size and is outside its valid range at these settings
    (stated), else ``layer``.  None when the grid fits or its fields are not in range (the class
    names those)."""
    if not _size_inputs_ok(kind, s):
        return None
    try:
        cells, rest, dx, height = _grid_size(kind, s)
        bound = s.energy_bound_height()
    except (ArithmeticError, TypeError, ValueError):
        return None
    if not math.isfinite(height) or (s.domain_height is not None and s.domain_height < bound):
        return None                      # an unbounded domain, a domain below the energy bound: named below
    if cells <= MAX_LAYER_CELLS and (rest is None or rest <= MAX_RESTING_CELLS):
        return None
    if cells > MAX_LAYER_CELLS:
        reason = f"the grid would have {_count_text(cells)} cells of Δx = {dx:.4g} m (at most {MAX_LAYER_CELLS:.0e})"
    else:
        reason = (f"the resting layer would be {_count_text(rest)} cells tall (at most {MAX_RESTING_CELLS}: its rest "
                  "state is a dense linear solve of that size)")
    blamed = _most_off_default(kind, s, _SIZE_FIELDS[kind], given)
    if blamed:
        name, rng = blamed
        return f"layer.{name}", f"{_value_text(kind, s, name)} is outside the valid range at these settings, {rng}: {reason}"
    return "layer", (f"{reason}; reduce the box, the heights, the cells per diameter or the floor's speed, which sets "
                     "the domain height by the energy bound")


def _most_off_default(kind: str, s, names, given, which: str | None = None):
    """(field, its valid range at these settings) of the fields ``names`` the config gives
    (``given``) that some value of their own mends: the one furthest from its default in orders
    of magnitude (``cells_per_diameter = 100000`` rather than the box at its default, which a box
    of 3 cells would mend too), the first of ``names`` among equals; None when none mends it."""
    defaults = {f.name: f.default for f in dataclasses.fields(_kind_classes()[kind])}
    best = None
    for i, name in enumerate(names):
        if name not in given:
            continue
        rng = _first_range(kind, s, name, which)
        if not rng:
            continue
        value, default = getattr(s, name), defaults.get(name)
        off = abs(math.log(value / default)) if _finite(default) and default > 0 and value > 0 else 0.0
        if best is None or off > best[0]:
            best = (off, name, rng)
    return None if best is None else best[1:]


def _value_text(kind: str, s, name: str) -> str:
    spec = _RANGES[kind].get(name)
    unit = spec.unit if isinstance(spec, _Range) else ("m" if name.endswith("height") else "")
    return f"{getattr(s, name)!r}" + (f" {unit}" if unit else "")


def _fmt(x: float, down: bool) -> str:
    """``x`` to four significant digits, rounded inwards (:func:`bsrflow._bounds.printed_bound`)."""
    return printed_bound(x, down)


def _edge(fits, good, bad, integer: bool = False):
    """The value next to the boundary between ``good`` (fits) and ``bad`` (does not) on the good
    side, by bisection (geometric for numbers > 0; fits monotone between them)."""
    for _ in range(2200):                # enough for integers up to 2**2000
        if integer:
            if abs(bad - good) <= 1:
                break
            mid = (good + bad) // 2
        else:
            mid = math.sqrt(good) * math.sqrt(bad)
            if not min(good, bad) < mid < max(good, bad) or abs(bad - good) <= 1e-9 * abs(good):
                break
        if fits(mid):
            good = mid
        else:
            bad = mid
    return good


def _spec(kind: str, s, name: str):
    """The :class:`_Range` of field ``name`` of the layer ``s`` at its settings (its lower bound
    for the heights, the box and the CFL number; None for a field without one)."""
    spec = _RANGES[kind].get(name)
    if name == "cfl":
        return _Range(0.0, 0.5 / s.dim, lo_open=True)
    if name == "domain_height":
        return _Range(s.energy_bound_height(), _INF, "m")
    if name == "bed_height":
        return _Range(2 * s.dx / (1.0 - s.surface_perturbation), _INF, "m")
    if name == "layer_height":           # round(H/Δx) (1 - δ) >= c + 1 (LayerSetup)
        return _Range((s.least_layer_cells() - 0.5 + 1e-6) * s.dx, _INF, "m")
    if name == "diameter":
        return _Range(0.0, _diameter_max(kind, s), "m", lo_open=True)
    return spec if isinstance(spec, _Range) else None


def _field_range(kind: str, s, name: str, fits) -> str | None:
    """The valid range at these settings (text) of field ``name`` of the layer ``s`` for the
    constraint ``fits`` (a function of a setup, monotone in the field), when the field's value
    does not fit and some value in its range does; else None."""
    value = getattr(s, name)
    if name == "box_width":              # whole cells of Δx
        dx = s.dx
        n_lo = 3 if kind == "packing_bed" else s.cells_per_diameter + 1
        n_user = round(value / dx) if math.isfinite(value / dx) else 2 ** 1000

        def fits_n(n):
            try:
                return fits(_with(s, name, n * dx))
            except OverflowError:        # int too large to convert to float
                return False
        if fits_n(n_user) or not fits_n(n_lo):
            return None
        n_hi = _edge(fits_n, n_lo, n_user, integer=True)
        return f"[{n_lo * dx:.6g}, {n_hi * dx:.6g}] m (whole cells of Δx = {dx:.6g} m)"
    spec = _spec(kind, s, name)
    if spec is None or value is None or fits(s):
        return None
    if spec.integer:
        lo, hi = int(spec.lo), (int(spec.hi) if math.isfinite(spec.hi) else 2 ** 62)
    else:
        lo, hi = (spec.lo if spec.lo > 0 else 1e-300), (spec.hi if math.isfinite(spec.hi) else 1e300)

    def fits_v(v):
        return fits(_with(s, name, v))
    good_lo, good_hi = fits_v(lo), fits_v(hi)
    if good_lo == good_hi:
        return None                      # no value of this field alone fits (or it does not matter)
    edge = _edge(fits_v, lo if good_lo else hi, value, integer=spec.integer)
    if spec.integer:
        return _range_text(spec, hi=str(edge), note=False) if good_lo else _range_text(spec, lo=str(edge), note=False)
    if good_lo:
        lo_text = None if spec.lo <= 0 else _fmt(spec.lo, down=False)
        if spec.lo > 0 and float(lo_text) > edge:
            return None
        return _range_text(spec, lo=lo_text, hi=_fmt(edge, down=True), note=False)
    exact = not math.isfinite(spec.hi) or float(_g(spec.hi)) <= spec.hi
    hi_text = None if exact and name != "diameter" else _fmt(spec.hi, down=True)
    text = _range_text(spec, lo=_fmt(edge, down=False), hi=hi_text, note=False)
    if name == "diameter":
        text += " (and the box a whole number of cells of Δx = diameter / cells_per_diameter)"
    return text


def _reblamed(kind: str, s, given, msg: str):
    """(field, message) naming the field the config gives when the scenario class, refusing the
    unchecked layer ``s`` with ``msg``, names one it does not (a packing bed's stiffness, the
    heights or the box for a diameter), or a range that no value fills; else None."""
    if kind == "packing_bed" and "box_width" in given and _size_inputs_ok(kind, s) \
            and round(s.box_width / s.dx) < 3:
        return _narrow_box_problem(s, given)     # (the class leaves 1-2 cells to the grid's check, after its others)
    if kind == "packing_bed" and msg.startswith("stiffness = "):
        return _stiffness_reblamed(s, given)
    for blamed in ("box_width", "bed_height", "layer_height"):
        if (msg.startswith(f"{blamed} = ") and blamed not in given and "diameter" in given
                and _size_inputs_ok(kind, s)):
            return _diameter_reblamed(kind, s, msg)
    return None


def _bed_reblamed(cls, kw: dict, given, msg: str):
    """(layer.<field>, message) for a bed kind's setup refused with ``msg`` by a check across
    fields, when ``msg`` blames a field the config does not give, or one whose default does not
    mend it, or states no valid range: the given field whose default mends the config, with its
    valid range at the other settings (the edge by bisection between the default and the given
    value, printed inside the range); None when no single given field mends it."""
    def valid(values) -> bool:
        try:
            cls(**values)
        except (ValueError, TypeError, ArithmeticError):
            return False
        return True

    fields = {f.name: f for f in dataclasses.fields(cls)}
    blamed = next((k for k in fields if msg.startswith(f"{k} = ")), None)
    without = {k: v for k, v in kw.items() if k != blamed}
    states_range = re.search(r"valid range(: integers in)?[^:]*[\[({]", msg) is not None      # [a, b], (a, b), {1, 2, 3}
    if blamed in given and states_range and valid(without):
        return None                                   # the message already names the field and its range
    order = ([blamed] if blamed in given else []) + [k for k in kw if k in given and k != blamed]   # config order
    for name in order:
        value, default = kw.get(name), fields[name].default
        if default is None:              # derived when not given (lateral_cells: 1 for a column, else 4)
            default = _derived_default(cls, kw, name)
        if (not _finite(value) or not _finite(default) or default == value
                or not valid({k: v for k, v in kw.items() if k != name})):
            continue
        integer = str(fields[name].type).startswith("int")
        if not integer and not (value > 0 and default > 0):
            continue
        edge = _edge(lambda v: valid({**kw, name: v}), default, value, integer)
        side = "at most" if value > default else "at least"
        bound = str(edge) if integer else _fmt(edge, down=value > default)
        # not the field twice, nor a field the config does not give without a range of its own
        why = msg.split(": ", 1)[1] if (name == blamed or (blamed not in given and not states_range)) and ": " in msg \
            else msg
        return (f"layer.{name}", f"{name} = {value!r} is outside the valid range at these settings ({side} {bound} "
                             f"with the other fields as given): {why}")
    return None


def _derived_default(cls, kw: dict, name: str):
    """The value a bed kind's class gives field ``name`` (default None) when the config leaves it
    out and the other fields are as given; None when it derives none or refuses those fields."""
    try:
        return getattr(cls(**{k: v for k, v in kw.items() if k != name}), name)
    except (ValueError, TypeError, ArithmeticError):
        return None


def _diameter_max(kind: str, s) -> float:
    """The largest diameter [m] whose cells Δx = d / cells_per_diameter the layer ``s`` fits: its
    height at least two cells (packing bed) or cells_per_diameter + 1 (a layer, also in the
    troughs of the surface undulation), its box at least 3 or cells_per_diameter + 1 cells."""
    c, delta = s.cells_per_diameter, s.surface_perturbation
    if kind == "packing_bed":
        return min(s.bed_height * (1.0 - delta) * c / 2.0, s.box_width * c / 3.0)
    return min(s.layer_height * c / (s.least_layer_cells() - 0.5 + 1e-6), s.box_width * c / (c + 1.0))


def _diameter_range_text(kind: str, s) -> str | None:
    """The valid range of the diameter of the layer ``s`` at its settings: up to
    :func:`_diameter_max`, down to the smallest one whose grid fits (None when none fits)."""
    d_max, tiny = _diameter_max(kind, s), 1e-300

    def fits(v):
        return _grid_fits(kind, _with(s, "diameter", v))
    if not fits(d_max):
        return None
    lo = "(0" if fits(tiny) else "[" + _fmt(_edge(fits, d_max, tiny), down=False)
    return (f"{lo}, {_fmt(d_max, down=True)}] m (and the box a whole number of cells of Δx = diameter / "
            "cells_per_diameter)")


def _diameter_reblamed(kind: str, s, msg: str):
    """(layer.diameter, message) when the diameter the config gives makes Δx too coarse for the
    heights or the box, or the box not a whole number of cells."""
    d, c = s.diameter, s.cells_per_diameter
    d_max = _diameter_max(kind, s)
    n_min = 3 if kind == "packing_bed" else c + 1
    if d > d_max:
        rng = _diameter_range_text(kind, s)
        if rng is None:
            return None
        return "layer.diameter", f"{d!r} m is outside the valid range at these settings, {rng}: {msg}"
    n = s.box_width * c / d
    if "not a whole number of cells" in msg and math.floor(n) >= n_min:
        return "layer.diameter", (f"{d!r} m is outside the valid range at these settings: box_width = "
                                  f"{s.box_width!r} m must be a whole number of cells of Δx = diameter / "
                                  f"cells_per_diameter ({n:.4g} cells); valid are box_width × cells_per_diameter / n "
                                  f"for whole n, e.g. {s.box_width * c / math.ceil(n):.6g} or "
                                  f"{s.box_width * c / math.floor(n):.6g} m")
    return None


def _packing_measures(t):
    """(overlap of the bottom contacts under the bed's weight [m], time steps of the run, the
    packing law, the CFL number) of the (unchecked) packing bed ``t``, as
    :meth:`bsrflow.physics.packing_bed.PackingBed._check_stiffness` computes them."""
    law = t.law()
    overlap = law.close_packing_density * t.gravity * t.bed_height / law.k1
    cfl = 0.4 / t.dim if t.cfl is None else t.cfl
    steps = t.t_end * law.wave_speed() / (cfl * t.dx)
    return overlap, steps, law, cfl


def _packing_fits(t, overlap: bool = True, steps: bool = True) -> bool:
    """True when the packing bed ``t``'s grid fits and (``overlap``, ``steps``) its weight's
    overlap and its number of time steps are within the bounds of its stiffness check."""
    from ..physics.packing_bed import MAX_STATIC_OVERLAP, MAX_STEPS
    if not _grid_fits("packing_bed", t):
        return False
    try:
        o, n, _, _ = _packing_measures(t)
    except (ArithmeticError, TypeError, ValueError):
        return False
    return (not overlap or o <= MAX_STATIC_OVERLAP * t.diameter) and (not steps or n <= MAX_STEPS)


def _fits_functions(kind: str, which: str | None = None):
    """The constraints a field's range at these settings is computed for: every one the layer has
    (its grid; a packing bed's stiffness check too), then, when no value of the field satisfies
    them all, only its grid and ``which`` ("overlap", "steps") of the stiffness check."""
    if kind != "packing_bed":
        return (lambda t: _grid_fits(kind, t),)
    return (_packing_fits, lambda t: _packing_fits(t, overlap=which == "overlap", steps=which == "steps"))


def _first_range(kind: str, s, name: str, which: str | None = None) -> str | None:
    for fits in _fits_functions(kind, which):
        rng = _field_range(kind, s, name, fits)
        if rng:
            return rng
    return None


def _stiffness_reblamed(s, given):
    """A packing bed's stiffness check (:meth:`bsrflow.physics.packing_bed.PackingBed._check_stiffness`)
    failed on the unchecked bed ``s``: (field, message) naming the field the config gives that
    makes the bed's weight overlap its contacts too far or the run too long, with its valid range
    at these settings, when the config does not give the stiffness or no stiffness would do; else
    None (the class's message stands)."""
    from ..physics.packing_bed import MAX_STATIC_OVERLAP, MAX_STEPS
    try:
        overlap, steps, law, cfl = _packing_measures(s)
        k_used = s.stiffness * s.stiffness_factor
        k_min = k_used * overlap / (MAX_STATIC_OVERLAP * s.diameter)
        k_max = (MAX_STEPS * cfl * s.dx / (s.t_end * law.wave_speed() / math.sqrt(k_used))) ** 2
    except (ArithmeticError, TypeError, ValueError):
        return None
    if "stiffness" in given and k_min <= k_max:
        return None                      # the class names the stiffness with its (non-empty) range
    if overlap > MAX_STATIC_OVERLAP * s.diameter:
        which, names = "overlap", ("stiffness_factor", "bed_height", "gravity", "density", "coordination")
        reason = (f"the bed's weight would overlap its bottom contacts by {overlap / s.diameter:.3g} d (at most "
                  f"{MAX_STATIC_OVERLAP:g} d; stiffness = {s.stiffness!r} N/m)")
    elif steps > MAX_STEPS:
        which, names = "steps", ("t_end", "cfl", "cells_per_diameter", "stiffness_factor", "restitution", "density",
                                 "coordination")
        reason = f"the run would take about {steps:.2g} time steps (at most {MAX_STEPS:.0e})"
    else:
        return None
    blamed = _most_off_default("packing_bed", s, names, given, which)
    if blamed:
        name, rng = blamed
        return (f"layer.{name}", f"{_value_text('packing_bed', s, name)} is outside the valid range at these "
                f"settings, {rng}: {reason}")
    return None


def _narrow_box_problem(setup, given):
    """(field, message) of a packing bed whose box is narrower than the three cells a grid needs:
    the box width if the config gives it and a box of 3 or more cells mends the bed, else the
    diameter if its range is not empty, else the layer with what else must change."""
    from ..physics.packing_bed import MAX_STEPS
    dx = setup.dx
    three = _with(setup, "box_width", 3 * dx)
    cells = _grid_size("packing_bed", three)[0]
    try:
        steps = _packing_measures(three)[1]
    except (ArithmeticError, TypeError, ValueError):
        steps = None                     # (a diameter of 1e300: the grid's check below refuses it)
    too_many_steps = steps is not None and steps > MAX_STEPS
    if "box_width" in given and not too_many_steps and _grid_fits("packing_bed", three):
        n_hi = _edge(lambda n: _grid_fits("packing_bed", _with(setup, "box_width", n * dx)), 3, 2 ** 62, integer=True)
        return "layer.box_width", (f"{setup.box_width!r} m is outside the valid range at these settings, "
                                   f"[{3 * dx:.6g}, {n_hi * dx:.6g}] m (whole cells of Δx = {dx:.6g} m): the grid "
                                   "needs at least 3 cells across")
    rng = _diameter_range_text("packing_bed", setup)
    if rng is not None and not too_many_steps and ("diameter" in given or "box_width" not in given):
        return "layer.diameter", (f"{setup.diameter!r} m is outside the valid range at these settings, {rng}: the box "
                                  f"(box_width = {setup.box_width!r} m) must be at least 3 cells of Δx = diameter / "
                                  "cells_per_diameter")
    fix = "lower cells_per_diameter and keep box_width >= 3 diameter / cells_per_diameter"
    if cells > MAX_LAYER_CELLS:
        why = f"the grid would have {_count_text(cells)} cells (at most {MAX_LAYER_CELLS:.0e})"
    elif too_many_steps:
        why = f"the run would take about {steps:.2g} time steps (at most {MAX_STEPS:.0e})"
    else:
        why = f"the bed (bed_height = {setup.bed_height!r} m) would be less than two cells tall"
        fix = "the box needs at least 3 and the bed 2 cells of Δx"
    return "layer", (f"box_width = {setup.box_width!r} m is less than 3 cells of Δx = diameter / cells_per_diameter "
                     f"= {dx:.6g} m, and at 3 cells {why}: {fix}")


def _tracer_positions(table, setup):
    """The ``[tracers]`` table's ``positions``: an (n, dim) array [m] inside the layer's box, or None."""
    if table is None:
        return None
    for key in table:
        if key != "positions":
            raise ConfigError(f"tracers.{key}", "unknown key; valid: positions")
    if "positions" not in table:
        raise ConfigError("tracers.positions", "missing: a list of [x, z] (2-D) or [x, y, z] (3-D) positions [m] "
                          "([z] for a granular_bed_eulerian column)")
    pos = table["positions"]
    from ..physics.granular_bed import EulerianBedSetup
    if isinstance(setup, EulerianBedSetup):       # (z in 1-D, (x, z), (x, y, z); from the floor and the side)
        dim = setup.dimension
        hi = np.array(setup.grid_upper())
        lo = np.zeros(dim)
    else:
        dim = setup.dim
        grid = setup.grid()
        lo, hi = np.asarray(grid.lower, float), np.asarray(grid.upper, float)
    layout = {1: "[z]", 2: "[x, z]", 3: "[x, y, z]"}[dim]
    ok = (isinstance(pos, list) and len(pos) > 0
          and all(isinstance(p, list) and len(p) == dim
                  and all(isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c) for c in p)
                  for p in pos))
    if not ok:
        raise ConfigError("tracers.positions", f"must be a non-empty list of {dim}-element lists of finite "
                          f"numbers [m] ({layout} per tracer)")
    arr = np.array(pos, dtype=float)
    for k, p in enumerate(arr):
        if np.any(p < lo) or np.any(p > hi):
            raise ConfigError("tracers.positions", f"tracer {k} at {p.tolist()} m is outside the box "
                              f"[{lo.tolist()}, {hi.tolist()}] m")
    return arr


LayerOutcome = RunOutcome
"""The outcome of a layer run: the one outcome of every run (:class:`bsrflow.io.driver.RunOutcome`;
``top_max_over_d`` is None, ``vtk`` the ParaView collection of a run with VTK output)."""


DEFAULT_CHECKPOINT_INTERVAL = 0.1
"""[s] of simulated time between a layer run's checkpoints when ``checkpoint_every`` is not given
(at most a tenth of ``t_end``: a bed run of 0.1 s took 85 s of wall time and had none)."""


def default_checkpoint_interval(t_end: float) -> float:
    """The checkpoint interval [s] of a layer config without ``checkpoint_every``: 0.1 s, or
    t_end / 10 when that is shorter (rounded to whole snapshots by :func:`_checkpoint_times`)."""
    return min(DEFAULT_CHECKPOINT_INTERVAL, float(t_end) / 10.0)


def _checkpoint_times(save_times, interval):
    """Checkpoints on snapshot times, about every ``interval`` s (None: the default,
    :func:`default_checkpoint_interval`; 0: none)."""
    if interval == 0.0 or len(save_times) < 2:
        return np.array([])
    interval = default_checkpoint_interval(save_times[-1]) if interval is None else interval
    step = max(1, int(round(interval / (save_times[1] - save_times[0]))))
    return np.asarray(save_times[step::step], dtype=float)


def run_layer_config(cfg: LayerConfig, out, *, resume=False, progress=None, log=None) -> RunOutcome:
    """Run a layer config into ``out`` (module docstring) through the driver every run shares,
    :func:`bsrflow.io.driver.drive` (checkpoints, ``--resume``, what stops a run)."""
    from ..physics.granular_bed import BedSetup
    from ..physics.packing_bed import PackingBed
    job_class = (PackingBedJob if isinstance(cfg.setup, PackingBed) else GranularBedJob
                 if isinstance(cfg.setup, BedSetup) else LayerJob)
    return drive(job_class(cfg, out), resume=resume, progress=progress, log=log)


class _LayerBase(RunJob):
    """What the two layer jobs share: the config and its schedules, the n-D netCDF writer
    (:class:`bsrflow.io.netcdf.NetCDFWriterND`), the VTK files, the tracers of a ``[tracers]``
    table."""

    checkpoint_option = "output.checkpoint_every"
    per_depth = False

    def __init__(self, cfg: LayerConfig, out):
        self.cfg = cfg
        self.out = os.fspath(out)
        self.setup = cfg.setup
        self.t_end = float(cfg.setup.t_end)
        self.config_text = cfg.text
        self.tracers = None if cfg.tracers is None else np.array(cfg.tracers, dtype=float)
        self.n_tracers = 0 if self.tracers is None else self.tracers.shape[0]
        self.checkpoint_interval = (default_checkpoint_interval(self.t_end) if cfg.checkpoint_every is None
                                    else float(cfg.checkpoint_every))
        self.vtk_writer = None

    def check_paths(self):
        self.save_times, self.checkpoint_times, _, self.vtk_stem = _run_files(self.cfg, self.out)

    def config_difference(self, text, where):
        """Key by key on the resolved configs (every field with its default; comments, layout and a
        default written out are no difference), as a column's config is compared."""
        try:
            then = _layer_config_from_text(text)
        except (ConfigError, ValueError, tomllib.TOMLDecodeError):
            return OTHER_KIND
        return first_difference(tomllib.loads(self.cfg.resolved_text()), tomllib.loads(then.resolved_text()), where)

    def _floor(self, t):
        return self.motion.state(t)[0]

    def _state(self):
        """(field schema, source) of the state fields the file holds too (``[output] state``), or None."""
        return None

    def _tracer_axes(self):
        """The axes of the tracers' positions in the file (None: the grid's)."""
        return None

    def new_writer(self):
        from .netcdf import NetCDFWriterND
        return NetCDFWriterND(self.out, self.grid, self._floor, self._attrs(), expected_snapshots=self.save_times.size,
                              n_tracers=self.n_tracers, per_depth=self.per_depth, state=self._state(),
                              tracer_axes=self._tracer_axes())

    def reopen_writer(self, t_checkpoint):
        from .netcdf import NetCDFWriterND
        return NetCDFWriterND.resume(self.out, t_checkpoint, self.grid, self._floor,
                                     expected_snapshots=self.save_times.size, n_tracers=self.n_tracers,
                                     per_depth=self.per_depth, state=self._state(), tracer_axes=self._tracer_axes())

    def _restored_tracers(self, ck):
        if self.tracers is None:
            return None
        return _checkpoint_tracers(ck, self.tracers, checkpoint_path(self.out))

    def observers(self, writer, resumed_at):
        from .commands import together
        self.vtk_writer = _vtk_writer(self.vtk_stem, self.grid, resumed_at, per_depth=self.per_depth)
        # one snapshot in both files or in neither: an interrupt between the two writes left the
        # VTK series one snapshot behind the netCDF file (an audit, 2026-12-06)
        return [together(writer, self.vtk_writer)] if self.vtk_writer else [writer]

    def vtk_collection(self):
        return self.vtk_writer.pvd.as_posix() if self.vtk_writer else None

    def notes(self):
        """Notes (not errors) on fields the config gives that this run does not use: a
        ``settle_time`` at or after ``t_end`` (the floor does not move: a settling run; the column
        notes taps after ``run.t_end`` the same way), a ``tap_period`` with ``n_taps = 1`` (one
        tap has no period; ``config_resolved`` writes every field, so this is not refused)."""
        try:
            layer = tomllib.loads(self.cfg.text).get("layer", {})
        except (tomllib.TOMLDecodeError, AttributeError):
            layer = {}
        notes = []
        st = getattr(self.setup, "settle_time", None)
        if st is not None and st >= self.t_end and "settle_time" in layer:
            notes.append(f"note: layer.settle_time = {st:g} s is at or after layer.t_end = {self.t_end:g} s: the "
                         "floor does not move in this run (it only settles)")
        if "tap_period" in layer and getattr(self.setup, "n_taps", None) == 1:
            notes.append(f"note: layer.tap_period = {self.setup.tap_period:g} s is not used: n_taps = 1 (one tap "
                         "has no period)")
        return notes


class LayerJob(_LayerBase):
    """A 2-D / 3-D layer of the seed's kernel (``tapped_layer``, ``vibrated_box``):
    :class:`bsrflow.numerics.solver_nd.SimulationND`, checkpoints of (u, ρ, tracers)."""

    name = "n-D solver"

    def prepare(self):
        from ..numerics.solver import Scheme
        from ..numerics.solver_nd import SimulationND
        setup = self.setup
        self.grid = setup.grid()
        self.scheme = Scheme.preset(setup.scheme, positivity=bool(setup.positivity))
        model = setup.model()
        self.sim = SimulationND(model, self.grid, self.scheme, average=setup.average,
                                vacuum_density=1e-4 * setup.bottom_density,
                                top_tolerance=1e-3 * setup.bottom_density)
        self.motion = model.motion
        self.u, self.rho = setup.initial_state(self.grid)
        self.steps0, self.steps_run, self.restart = 0, 0, False

    def _attrs(self):
        return {"config": self.cfg.text, "config_resolved": self.cfg.resolved_text(), "scheme": self.scheme.name,
                "dimension": self.grid.dim, "diameter": float(self.setup.diameter)}

    def restore(self, ck):
        from .runner import _grid_fields
        self.u, self.rho = _grid_fields(ck, self.u.shape, self.rho.shape)
        self.steps0, self.restart = int(ck.steps), True
        self.tracers = self._restored_tracers(ck)

    def compile(self, t0):
        from ..numerics.solver_nd import to_internal
        ui, ri = to_internal(self.grid, np.array(self.u, float), np.array(self.rho, float))
        tracers = None if self.tracers is None else np.zeros((len(self.tracers), 3))
        self.sim.advance_internal(ui, ri, t0, t0, tracers=tracers)        # no step: compiles the loop

    def integrate(self, t0, save_times, checkpoint_times, observers, progress, on_checkpoint):
        dim = self.grid.dim

        def on_event(t, u, rho, tr, steps):
            self.steps_run = steps
            on_checkpoint(t, {"u": u, "rho": rho}, np.zeros((0, dim)) if tr is None else tr)

        from .runner import run_counting_steps
        run_counting_steps(self, self.sim.run, self.u, self.rho, self.t_end, t_start=t0, save_times=save_times,
                           observers=observers, progress=progress, extra_event_times=checkpoint_times,
                           on_event=on_event, restart=self.restart, tracers=self.tracers)

    def total_steps(self):
        return self.steps0 + self.steps_run


class _ControllerJob(_LayerBase):
    """What the jobs of the discretisations driven by the packing controller share
    (:func:`bsrflow.numerics.controller.drive_events`): ``self.disc`` with ``advance``,
    ``apply_velocity_jump``, ``observe``, named ``fields`` / ``load_fields``, ``counters`` and
    ``tracer_positions`` (None or an empty array without tracers); checkpoints of its named fields."""

    def restore(self, ck):
        try:
            self.disc.load_fields(ck.fields)
        except ValueError as exc:
            raise ConfigError("--resume", f"the checkpoint's state does not match the config: {exc}") from None
        problem = self.disc.state_problem() if hasattr(self.disc, "state_problem") else None
        if problem:
            raise ConfigError("--resume", f"the checkpoint {checkpoint_path(self.out)} holds a state no run reaches "
                              f"({problem}); run without --resume to start over")
        if self.tracers is not None:
            try:
                self.disc.set_tracers(self._restored_tracers(ck))
            except ValueError as exc:
                raise ConfigError("--resume", f"the checkpoint {checkpoint_path(self.out)}'s {exc}; run without "
                                  "--resume to start over") from None
        self.disc.counters[0] = int(ck.steps)
        self.disc.steps = int(ck.steps)

    def compile(self, t0):
        self.disc.advance(t0, t0)

    def integrate(self, t0, save_times, checkpoint_times, observers, progress, on_checkpoint):
        from ..numerics.controller import drive_events
        disc, n_tr = self.disc, self.n_tracers

        def save(t):
            u, rho = disc.observe()
            tr = disc.tracer_positions() if n_tr else None
            for obs in observers:
                obs(t, u, rho, tr)
            if progress is not None:
                progress(t)

        drive_events(t0, self.t_end, save_times, self.motion.jumps_between(t0, self.t_end), checkpoint_times,
                     advance=disc.advance, apply_jump=disc.apply_velocity_jump, save=save,
                     on_event=lambda t: on_checkpoint(t, disc.fields, disc.tracer_positions()))

    def total_steps(self):
        return int(self.disc.counters[0])


class PackingBedJob(_ControllerJob):
    """``kind = "packing_bed"``: the n-D packing continuum
    (:class:`bsrflow.numerics.packing_nd.EulerianPackingND`) through the packing controller
    :func:`bsrflow.numerics.controller.drive_events`; checkpoints of its named fields (the
    conserved state, history included) and its tracers; a 2-D bed's units per metre of depth."""

    per_depth = True

    def prepare(self):
        self.disc = self.setup.discretisation(self.tracers)
        self.grid, self.motion = self.disc.grid, self.disc.motion
        self.name = f"{self.grid.dim}-D packing solver"

    def _attrs(self):
        return {"config": self.cfg.text, "config_resolved": self.cfg.resolved_text(),
                "scheme": f"packing_{self.disc.name}", "kernel": "packing", "dimension": self.grid.dim,
                "scenario": f"packing_bed_{self.grid.dim}d", "diameter": float(self.setup.diameter)}

    def _state(self):
        if not self.cfg.state:
            return None
        return self.disc.field_schema(per_depth=True), lambda: self.disc.fields

    def notes(self):
        if self.setup.stiffness_factor >= 1.0:
            return super().notes()
        return super().notes() + [f"reduced contact stiffness: K x {self.setup.stiffness_factor:.4g}, impact Mach number "
                f"M = {self.setup.impact_mach():.3g}; its cost is measured on the 1-D column only (docs/model.md, "
                "\"Stiffness\")"]


class GranularBedJob(_ControllerJob):
    """``kind = "granular_bed"``: the vibrated bed of packing stress and granular temperature
    (:class:`bsrflow.physics.granular_bed.BedSetup`, the model of ``bsrflow compare-bed``) on its
    Lagrangian cells (:class:`bsrflow.numerics.bed_lagrangian.GranularBedColumn`) through the
    packing controller; the file holds its line density and velocity on a fixed column of bins
    of d/10 and (``[output] state``, on by default) the cells' state with θ and the floor's
    force; checkpoints of the cells' state and the next step's Δt."""

    name = "granular bed solver (horizontally uniform, Lagrangian cells)"

    def prepare(self):
        from ..numerics.bed_eulerian import EulerianBed
        from ..numerics.bed_lagrangian import GranularBedColumn
        from ..physics.granular_bed import EulerianBedSetup
        if isinstance(self.setup, EulerianBedSetup):
            self.disc = EulerianBed.from_setup(self.setup)             # settled in integrate (a resume does not)
            self.name = (f"granular bed solver (Eulerian grid, {self.setup.dimension}-D, "
                         f"{' x '.join(str(n) for n in self.disc.shape)} cells)")
        else:
            self.disc = GranularBedColumn(self.setup, settle=False)
        self.grid, self.motion = self.disc.grid, self.disc.motion
        self.restored = False

    def restore(self, ck):
        super().restore(ck)
        self.restored = True

    def compile(self, t0):
        from ..numerics.bed_lagrangian import _compile_bed
        if self.disc.name == "granular_bed_eulerian":
            self.disc.advance(t0, t0)                      # (no step: compiles the loop)
        else:
            _compile_bed()

    def integrate(self, t0, save_times, checkpoint_times, observers, progress, on_checkpoint):
        if not self.restored:
            self.disc.settle()
            if self.tracers is not None:           # placed on the settled bed, at t = 0
                self.disc.set_tracers(self.tracers)
        self.disc.t = t0
        super().integrate(t0, save_times, checkpoint_times, observers, progress, on_checkpoint)

    def _attrs(self):
        eulerian = self.disc.name == "granular_bed_eulerian"
        extra = ({"grid_dimension": int(self.setup.dimension), "grid_shape": list(self.disc.shape),
                  "grid_cell_size_m": [float(v) for v in self.disc.dx],
                  "dimension_note": "dimension is that of rho and u_z, the bed's profile over z (the "
                                    "horizontal mean); grid_dimension is the Eulerian grid's"} if eulerian else {})
        return {**extra, "config": self.cfg.text, "config_resolved": self.cfg.resolved_text(),
                "scheme": "granular_bed_eulerian" if eulerian else "granular_bed_lagrangian", "kernel": "granular_bed",
                "dimension": 1,
                "scenario": "granular_bed", "diameter": float(self.setup.diameter),
                "bed_area_m2": float(self.setup.area),
                "rho_note": "rho is the bed's mass per metre of height (rho_s phi times the box's area)"}

    def _state(self):
        if not self.cfg.state:
            return None
        return self.disc.output_schema(), self.disc.output_fields

    def _tracer_axes(self):
        """The Eulerian grid's axes (its tracers' positions), not the file's column's."""
        return self.disc.TRACER_AXES[self.disc.dim] if self.disc.name == "granular_bed_eulerian" else None

    def observers(self, writer, resumed_at):
        """The file, and for the Eulerian grid with ``[output] vtk`` its cells' fields in VTK
        (:meth:`bsrflow.numerics.bed_eulerian.EulerianBed.vtk_fields`) at every save."""
        if self.disc.name != "granular_bed_eulerian" or not self.vtk_stem:
            return super().observers(writer, resumed_at)
        self.vtk_writer = _vtk_writer(self.vtk_stem, self.disc.vtk_grid(), resumed_at)
        vtk = self.vtk_writer
        from .commands import together
        return [together(writer, lambda t, u, rho, tracers=None: vtk.write_fields(t, self.disc.vtk_fields(), tracers))]


def _run_files(cfg: LayerConfig, out):
    """(save times [s], checkpoint times [s], checkpoint file, VTK folder or None) of a layer run."""
    from ..numerics.solver import save_schedule
    try:
        kind = {v: k for k, v in _kind_classes().items()}[type(cfg.setup)]
        spec = _RANGES[kind].get("save_every")
        hi = (min(spec.hi, cfg.setup.t_end) if isinstance(spec, _Range)       # (the bed kinds: also <= t_end)
              else cfg.setup.t_end if "t_end" in str(spec) else np.inf)
        save_times = save_schedule(0.0, cfg.setup.t_end, cfg.setup.save_every, save_every_max=hi)
    except ValueError as exc:                    # too many snapshots: name the fields
        raise ConfigError("layer.save_every", f"{exc} (layer.t_end = {cfg.setup.t_end!r} s)") from None
    vtk_stem = os.path.splitext(out)[0] + "_vtk" if cfg.vtk else None
    if vtk_stem is not None:                # the VTK folder, checked before the run (created by _vtk_writer)
        from .paths import check_output_dir
        check_output_dir(vtk_stem, "output.vtk (its folder, --out's name with _vtk)")
    return save_times, _checkpoint_times(save_times, cfg.checkpoint_every), checkpoint_path(out), vtk_stem


def _checkpoint_tracers(ck: Checkpoint, tracers, ck_file):
    """The checkpoint's tracer positions, refused in one line when their number is not the
    config's."""
    if ck.tracers.shape != tracers.shape:
        what = (f"{ck.tracers.shape[0]} tracers, the config {tracers.shape[0]}" if ck.tracers.shape[0] != tracers.shape[0]
                else f"tracer positions of shape {ck.tracers.shape}, the config {tracers.shape}")
        raise ConfigError("--resume", f"{ck_file} holds {what}; run without --resume")
    return ck.tracers


def _vtk_writer(vtk_stem, grid, keep_before, per_depth=False):
    """The VTK observer of a layer run (None without ``vtk_stem``); a resumed run keeps the
    files before ``keep_before`` [s]."""
    if not vtk_stem:
        return None
    from .paths import check_output_dir
    from .vtk import VTKWriter
    check_output_dir(vtk_stem, "output.vtk (its folder, --out's name with _vtk)", create=True)
    w = VTKWriter(grid, os.path.join(vtk_stem, "layer"), per_depth=per_depth)
    if keep_before is not None:
        w.keep_before(keep_before)
    return w
