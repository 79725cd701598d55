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
    checkpoint_every = 0.05      # [s], on snapshot times; 0: none; default about every 0.1 s
    state = true                 # packing_bed, granular_bed (default there): state fields (state_<name>, units)
    [tracers]
    positions = [[0.01, 0.005], [0.01, 0.015]]   # initial positions [m] (floor frame, x (y) z)

``kind = "packing_bed"`` (:class:`bsrflow.physics.packing_bed.PackingBed`) runs the n-D packing
continuum (:class:`bsrflow.numerics.packing_nd.EulerianPackingND`) into the same files; its
checkpoint holds the discretisation's named fields (history included).

``kind = "granular_bed"`` (:class:`bsrflow.physics.granular_bed.BedSetup`: its fields, e.g.
``gamma``, ``cycles``, ``n_cells``, ``output_height``) runs the vibrated bed of packing stress
and granular temperature that ``bsrflow compare-bed`` compares with LIGGGHTS, horizontally
uniform, on its Lagrangian cells (:class:`bsrflow.numerics.bed_lagrangian.GranularBedColumn`):
snapshots every ``save_every`` = 1 ms unless given (compare-bed's 0.1 ms would make 118 MB for
11 cycles); the file is a column's (``rho`` the bed's mass per metre of height [kg/m], ``u_z``,
on bins of d/10) with, by default (``[output] state``), the cells' state (``state_face_height``,
``state_solid_fraction``, ``state_theta``, ``state_delta_max``) and ``state_floor_force`` [N];
no VTK, no tracers (refused in one line).

Tracers (optional) are moved with the interpolated velocity by the scheme's tracer integrator
(:meth:`bsrflow.numerics.solver_nd.SimulationND.run`; for the packing bed the fields' SSP-RK3
stages with the mass-weighted interpolation of :func:`bsrflow.numerics.packing_nd.tracer_velocity`)
and written as ``tracer_x`` (``tracer_y``), ``tracer_z`` (lab frame) to the netCDF file;
checkpoints carry them.

Every key is checked before the run: an unknown table or key, or a value outside its range,
is one line ``layer.<key>: <problem>`` (exit code 2).  A checkpoint ``<out>.ckpt`` holds the
state before the jump and the save at its time (the 1-D format, :mod:`bsrflow.io.checkpoint`,
with the n-D arrays), removed when the run finishes; ``--resume`` with the same config
continues bit for bit.
"""

from __future__ import annotations

import dataclasses
import math
import os
import tomllib
from dataclasses import dataclass

import numpy as np

from .checkpoint import Checkpoint, checkpoint_path
from .config import ConfigError
from .driver import OTHER_KIND, RunJob, RunOutcome, drive, first_difference

__all__ = ["is_layer_config", "load_layer_config", "run_layer_config", "LayerOutcome"]

KINDS = ("tapped_layer", "vibrated_box", "packing_bed", "granular_bed")
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

    def resolved_text(self) -> str:
        """The config with every field of the scenario, the defaults included, as TOML (the
        output's ``config_resolved`` attribute: what ran, in full; ``config`` is the file as
        given, or with ``--set`` overrides the config as run, regenerated with a comment naming
        them).  Loading it gives the same scenario."""
        import json
        kind = {v: k for k, v in _kind_classes().items()}[type(self.setup)]
        lines = ["[layer]", f"kind = {json.dumps(kind)}"]
        for f in dataclasses.fields(self.setup):
            value = getattr(self.setup, f.name)
            if value is None:
                lines.append(f"# {f.name}: not given (derived by the scenario)")
            else:
                lines.append(f"{f.name} = {_toml_value(value)}")
        lines += ["[output]", f"vtk = {_toml_value(self.vtk)}", f"state = {_toml_value(self.state)}"]
        if self.checkpoint_every is None:
            lines.append("# checkpoint_every: not given (about every 0.1 s on snapshot times)")
        else:
            lines.append(f"checkpoint_every = {_toml_value(self.checkpoint_every)}")
        if self.tracers is not None:
            rows = ", ".join("[" + ", ".join(_toml_value(float(v)) for v in row) + "]" for row in self.tracers)
            lines += ["[tracers]", f"positions = [{rows}]"]
        return "\n".join(lines) + "\n"


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
    from ..physics.granular_bed import BedSetup
    from ..physics.packing_bed import PackingBed
    from ..physics.scenarios_nd import TappedLayer, VibratedBox
    return {"tapped_layer": TappedLayer, "vibrated_box": VibratedBox, "packing_bed": PackingBed,
            "granular_bed": BedSetup}


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
    names = {f.name: f for f in dataclasses.fields(cls)}
    kw = {}
    if kind == "granular_bed":
        kw["save_every"] = GRANULAR_BED_SAVE_EVERY      # a config run's default (compare-bed saves every 0.1 ms)
    for key, value in layer.items():
        if key not in names:
            raise ConfigError(f"layer.{key}", f"unknown key for kind = {kind!r}; valid: {', '.join(sorted(names))}")
        _check_type(f"layer.{key}", value, str(names[key].type))
        kw[key] = value
    try:
        setup = cls(**kw)
    except (ValueError, TypeError) as exc:
        msg = str(exc).splitlines()[0]
        field = next((k for k in kw if msg.startswith(k)), None)
        raise ConfigError(f"layer.{field}" if field else "layer", msg) from None
    height = setup.domain_height or setup.energy_bound_height()
    if not math.isfinite(height):
        drive = "amplitude" if kind in ("tapped_layer", "vibrated_box") else "gamma"
        raise ConfigError(f"layer.{drive}", f"{kw.get(drive, getattr(setup, drive))!r} gives the floor a largest speed "
                          f"of {setup.floor_speed():.3g} m/s and an unbounded domain (the energy bound (3aω)²/(2g)); "
                          f"valid: a finite floor speed, at most {MAX_LAYER_CELLS:.0e} cells in the grid")
    try:
        cells = int(np.prod(setup.grid().shape))
    except (ValueError, TypeError, OverflowError) as exc:
        msg = str(exc).splitlines()[0]
        field = next((k for k in names if msg.startswith(f"{k} = ")), None)
        raise ConfigError(f"layer.{field}" if field else "layer", msg) from None
    if cells > MAX_LAYER_CELLS:
        raise ConfigError("layer", f"the grid would have {cells:.3g} cells; at most {MAX_LAYER_CELLS:.0e} (reduce the "
                          "box, the heights, the cells per diameter or the floor's speed, which sets the domain height "
                          "by the energy bound)")
    out = dict(data.get("output", {}))
    for key, value in out.items():
        if key not in _OUTPUT_KEYS:
            raise ConfigError(f"output.{key}", f"unknown key; valid: {', '.join(_OUTPUT_KEYS)}")
    vtk = out.get("vtk", False)
    if not isinstance(vtk, bool):
        raise ConfigError("output.vtk", f"{vtk!r} must be true or false")
    state = out.get("state", kind == "granular_bed")
    if not isinstance(state, bool):
        raise ConfigError("output.state", f"{state!r} must be true or false")
    if kind == "granular_bed":
        if vtk:
            raise ConfigError("output.vtk", "true: not an option of kind = \"granular_bed\" (a horizontally uniform "
                              "bed: its profiles are in the netCDF file; VTK is for 2-D / 3-D fields)")
        if "tracers" in data:
            raise ConfigError("tracers", "not an option of kind = \"granular_bed\" (its Lagrangian cells' faces, "
                              "state_face_height in the file, are its material lines)")
    if state and kind not in ("packing_bed", "granular_bed"):
        raise ConfigError("output.state", f"true: an option of kind = \"packing_bed\" or \"granular_bed\" (the state of {kind!r}, "
                          "rho and u on the grid, is written in every file)")
    t_end = float(setup.t_end)
    if float(setup.save_every) > t_end:
        if kind == "granular_bed" and "save_every" not in layer:
            raise ConfigError("layer.save_every", f"not given: its default {GRANULAR_BED_SAVE_EVERY:g} s is outside the "
                              f"valid range (0, t_end = {t_end:g}] s (t_end = cycles / frequency); set it")
        raise ConfigError("layer.save_every", f"{setup.save_every!r} is outside the valid range (0, t_end = {t_end:g}] s")
    ck = out.get("checkpoint_every")
    if ck is not None:
        if (isinstance(ck, bool) or not isinstance(ck, (int, float))
                or not (math.isfinite(ck) and 0.0 <= ck <= t_end)):
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


def _check_type(name, value, annotation):
    """One line naming ``name`` unless ``value`` has the field's TOML type (``annotation`` as the
    dataclass gives it: "int", "float", "float | None", "bool", "str")."""
    if annotation.startswith("int"):
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(name, f"{value!r} must be an integer")
    elif annotation.startswith("float"):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ConfigError(name, f"{value!r} must be a finite number")
    elif annotation.startswith("bool"):
        if not isinstance(value, bool):
            raise ConfigError(name, f"{value!r} must be true or false")
    elif annotation.startswith("str"):
        if not isinstance(value, str):
            raise ConfigError(name, f"{value!r} must be a string")


def _tracer_positions(table, setup):
    """The ``[tracers]`` table's ``positions``: an (n, dim) array [m] inside the layer's box, or None."""
    if table is None:
        return None
    for key in table:
        if key != "positions":
            raise ConfigError(f"tracers.{key}", "unknown key; valid: positions")
    if "positions" not in table:
        raise ConfigError("tracers.positions", "missing: a list of [x, z] (2-D) or [x, y, z] (3-D) positions [m]")
    pos = table["positions"]
    dim = setup.dim
    ok = (isinstance(pos, list) and len(pos) > 0
          and all(isinstance(p, list) and len(p) == dim
                  and all(isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c) for c in p)
                  for p in pos))
    if not ok:
        raise ConfigError("tracers.positions", f"must be a non-empty list of {dim}-element lists of finite "
                          f"numbers [m] ({'[x, z]' if dim == 2 else '[x, y, z]'} per tracer)")
    arr = np.array(pos, dtype=float)
    grid = setup.grid()
    lo, hi = np.asarray(grid.lower, float), np.asarray(grid.upper, float)
    for k, p in enumerate(arr):
        if np.any(p < lo) or np.any(p > hi):
            raise ConfigError("tracers.positions", f"tracer {k} at {p.tolist()} m is outside the box "
                              f"[{lo.tolist()}, {hi.tolist()}] m")
    return arr


LayerOutcome = RunOutcome
"""The outcome of a layer run: the one outcome of every run (:class:`bsrflow.io.driver.RunOutcome`;
``top_max_over_d`` is None, ``vtk`` the ParaView collection of a run with VTK output)."""


def _checkpoint_times(save_times, interval):
    """Checkpoints on snapshot times, about every ``interval`` s (None: 0.1 s; 0: none)."""
    if interval == 0.0 or len(save_times) < 2:
        return np.array([])
    interval = 0.1 if interval is None else interval
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
        self.checkpoint_interval = 0.1 if cfg.checkpoint_every is None else float(cfg.checkpoint_every)
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

    def new_writer(self):
        from .netcdf import NetCDFWriterND
        return NetCDFWriterND(self.out, self.grid, self._floor, self._attrs(), expected_snapshots=self.save_times.size,
                              n_tracers=self.n_tracers, per_depth=self.per_depth, state=self._state())

    def reopen_writer(self, t_checkpoint):
        from .netcdf import NetCDFWriterND
        return NetCDFWriterND.resume(self.out, t_checkpoint, self.grid, self._floor,
                                     expected_snapshots=self.save_times.size, n_tracers=self.n_tracers,
                                     per_depth=self.per_depth, state=self._state())

    def _restored_tracers(self, ck):
        if self.tracers is None:
            return None
        return _checkpoint_tracers(ck, self.tracers, checkpoint_path(self.out))

    def observers(self, writer, resumed_at):
        self.vtk_writer = _vtk_writer(self.vtk_stem, self.grid, resumed_at, per_depth=self.per_depth)
        return [writer] + ([self.vtk_writer] if self.vtk_writer else [])

    def vtk_collection(self):
        return self.vtk_writer.pvd.as_posix() if self.vtk_writer else None


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
    ``tracer_positions`` (None without tracers); checkpoints of its named fields."""

    def restore(self, ck):
        try:
            self.disc.load_fields(ck.fields)
        except ValueError as exc:
            raise ConfigError("--resume", f"the checkpoint's state does not match the config: {exc}") from None
        if self.tracers is not None:
            self.disc.set_tracers(self._restored_tracers(ck))
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
            return []
        return [f"reduced contact stiffness: K x {self.setup.stiffness_factor:.4g}, impact Mach number "
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
        from ..numerics.bed_lagrangian import GranularBedColumn
        self.disc = GranularBedColumn(self.setup, settle=False)      # settled in integrate (a resume does not)
        self.grid, self.motion = self.disc.grid, self.disc.motion
        self.restored = False

    def restore(self, ck):
        super().restore(ck)
        self.restored = True

    def compile(self, t0):
        from ..numerics.bed_lagrangian import _compile_bed
        _compile_bed()

    def integrate(self, t0, save_times, checkpoint_times, observers, progress, on_checkpoint):
        if not self.restored:
            self.disc.settle()
        self.disc.t = t0
        super().integrate(t0, save_times, checkpoint_times, observers, progress, on_checkpoint)

    def _attrs(self):
        return {"config": self.cfg.text, "config_resolved": self.cfg.resolved_text(),
                "scheme": "granular_bed_lagrangian", "kernel": "granular_bed", "dimension": 1,
                "scenario": "granular_bed", "diameter": float(self.setup.diameter),
                "bed_area_m2": float(self.setup.area),
                "rho_note": "rho is the bed's mass per metre of height (rho_s phi times the box's area)"}

    def _state(self):
        if not self.cfg.state:
            return None
        return self.disc.output_schema(), self.disc.output_fields


def _run_files(cfg: LayerConfig, out):
    """(save times [s], checkpoint times [s], checkpoint file, VTK folder or None) of a layer run."""
    from ..numerics.solver import save_schedule
    try:
        save_times = save_schedule(0.0, cfg.setup.t_end, cfg.setup.save_every)
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
        raise ConfigError("--resume", f"{ck_file} holds {ck.tracers.shape[0]} tracers, the config "
                          f"{tracers.shape[0]}; run without --resume")
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
