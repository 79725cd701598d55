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
    [tracers]
    positions = [[0.01, 0.005], [0.01, 0.015]]   # initial positions [m] (floor frame, x (y) z)

``kind = "packing_bed"`` (:class:`bsrflow.physics.packing_bed.PackingBed`) runs the n-D packing
continuum (:class:`bsrflow.numerics.packing_nd.EulerianPackingND`) into the same files; its
checkpoint holds the discretisation's named fields (history included).

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

import contextlib
import dataclasses
import math
import os
import time
import tomllib
from dataclasses import dataclass

import numpy as np

from .checkpoint import Checkpoint, checkpoint_path, read_checkpoint, write_checkpoint
from .config import ConfigError
from .paths import OutputPathError

__all__ = ["is_layer_config", "load_layer_config", "run_layer_config", "LayerOutcome"]

KINDS = ("tapped_layer", "vibrated_box", "packing_bed")
_OUTPUT_KEYS = {"vtk": bool, "checkpoint_every": float}


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

    def resolved_text(self) -> str:
        """The config with every field of the scenario, the defaults included, as TOML (the
        output's ``config_resolved`` attribute: what ran, in full; ``config`` is the file as
        given).  Loading it gives the same scenario."""
        import json
        kind = {v: k for k, v in _kind_classes().items()}[type(self.setup)]
        lines = ["[layer]", f"kind = {json.dumps(kind)}"]
        for f in dataclasses.fields(self.setup):
            value = getattr(self.setup, f.name)
            if value is None:
                lines.append(f"# {f.name}: not given (derived by the scenario)")
            else:
                lines.append(f"{f.name} = {_toml_value(value)}")
        lines += ["[output]", f"vtk = {_toml_value(self.vtk)}"]
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
    from ..physics.packing_bed import PackingBed
    from ..physics.scenarios_nd import TappedLayer, VibratedBox
    return {"tapped_layer": TappedLayer, "vibrated_box": VibratedBox, "packing_bed": PackingBed}


def load_layer_config(path) -> LayerConfig:
    """Read and check a layer config (module docstring); ConfigError on the first problem."""
    with open(path, "rb") as fh:
        raw = fh.read()
    data = tomllib.loads(raw.decode("utf-8"))
    for table in data:
        if table not in ("layer", "output", "tracers"):
            raise ConfigError(str(table), "unknown table in a layer config; valid: [layer], [output], [tracers]")
        if not isinstance(data[table], dict):
            raise ConfigError(str(table), f"{data[table]!r} must be a table ([{table}] with its keys)")
    layer = dict(data["layer"])
    kind = layer.pop("kind", "tapped_layer")
    if kind not in KINDS:
        raise ConfigError("layer.kind", f"{kind!r} is not one of {', '.join(KINDS)}")
    cls = _kind_classes()[kind]
    names = {f.name: f for f in dataclasses.fields(cls)}
    kw = {}
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
    try:
        cells = int(np.prod(setup.grid().shape))
    except (ValueError, TypeError, OverflowError) as exc:
        raise ConfigError("layer", str(exc).splitlines()[0]) from None
    if cells > MAX_LAYER_CELLS:
        raise ConfigError("layer", f"the grid would have {cells:.3g} cells; at most {MAX_LAYER_CELLS:.0e} (reduce the "
                          "box, the heights or the cells per diameter)")
    out = dict(data.get("output", {}))
    for key, value in out.items():
        if key not in _OUTPUT_KEYS:
            raise ConfigError(f"output.{key}", f"unknown key; valid: {', '.join(_OUTPUT_KEYS)}")
    vtk = out.get("vtk", False)
    if not isinstance(vtk, bool):
        raise ConfigError("output.vtk", f"{vtk!r} must be true or false")
    t_end = float(setup.t_end)
    if float(setup.save_every) > t_end:
        raise ConfigError("layer.save_every", f"{setup.save_every!r} is outside the valid range (0, t_end = {t_end:g}] s")
    ck = out.get("checkpoint_every")
    if ck is not None:
        if (isinstance(ck, bool) or not isinstance(ck, (int, float))
                or not (math.isfinite(ck) and 0.0 <= ck <= t_end)):
            raise ConfigError("output.checkpoint_every", f"{ck!r} is outside the valid range [0, t_end = {t_end:g}] s "
                              "(0: no checkpoints)")
    return LayerConfig(setup, vtk, None if ck is None else float(ck), raw.decode("utf-8"),
                       _tracer_positions(data.get("tracers"), setup))


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


@dataclass
class LayerOutcome:
    path: str
    status: str
    n_snapshots: int
    t_end: float
    steps: int
    wall_time: float
    resumed_from: float | None
    vtk: str | None

    def summary(self) -> str:
        if self.status != "ok":
            return f"{self.status}: {self.n_snapshots} snapshots to t = {self.t_end:.6g} s; file {self.path}"
        resumed = f" (resumed from t = {self.resumed_from:.6g} s)" if self.resumed_from is not None else ""
        vtk = f"; VTK {self.vtk}" if self.vtk else ""
        return (f"{self.status}: {self.n_snapshots} snapshots to t = {self.t_end:.6g} s, {self.steps} steps{resumed}; "
                f"wall time {self.wall_time:.3g} s; wrote {self.path}{vtk}")


def _checkpoint_times(save_times, interval):
    """Checkpoints on snapshot times, about every ``interval`` s (None: 0.1 s; 0: none)."""
    if interval == 0.0 or len(save_times) < 2:
        return np.array([])
    interval = 0.1 if interval is None else interval
    step = max(1, int(round(interval / (save_times[1] - save_times[0]))))
    return np.asarray(save_times[step::step], dtype=float)


def run_layer_config(cfg: LayerConfig, out, *, resume=False, progress=None, log=None) -> LayerOutcome:
    """Run a layer config into ``out`` (module docstring)."""
    from ..physics.packing_bed import PackingBed
    from .paths import check_output_file
    if resume and not os.path.exists(checkpoint_path(check_output_file(out, "--out"))):
        done = _complete_layer(out, cfg, log or (lambda msg: None))
        if done is not None:
            return done
    if isinstance(cfg.setup, PackingBed):
        return _run_packing_bed(cfg, out, resume=resume, progress=progress, log=log)
    from ..numerics.solver import Scheme
    from ..numerics.solver_nd import SimulationND
    from .netcdf import read_snapshots
    from .paths import check_output_file

    out = check_output_file(out, "--out")
    save_times, ck_times, ck_file, vtk_stem = _run_files(cfg, out)
    setup = cfg.setup
    grid = setup.grid()
    scheme = Scheme.preset(setup.scheme, positivity=bool(setup.positivity))
    sim = SimulationND(setup.model(), grid, scheme, average=setup.average,
                       vacuum_density=1e-4 * setup.bottom_density, top_tolerance=1e-3 * setup.bottom_density)
    motion = setup.model().motion
    floor = lambda t: motion.state(t)[0]  # noqa: E731
    t0, steps0, resumed, wall0 = 0.0, 0, None, 0.0
    u0, rho0 = setup.initial_state(grid)
    attrs = {"config": cfg.text, "config_resolved": cfg.resolved_text(), "scheme": scheme.name, "dimension": grid.dim,
             "diameter": float(setup.diameter)}
    tracers = None if cfg.tracers is None else np.array(cfg.tracers, dtype=float)
    n_tr = 0 if tracers is None else tracers.shape[0]
    if resume:
        ck = _read_layer_checkpoint(ck_file, cfg)
        t0, steps0, resumed, wall0 = float(ck.t), int(ck.steps), float(ck.t), float(ck.wall_time)
        u0, rho0 = ck.u, ck.rho
        if tracers is not None:
            tracers = _checkpoint_tracers(ck, tracers, ck_file)
    writer, save_times = _layer_writer(out, grid, floor, attrs, save_times, n_tr, ck_file, t0 if resume else None)
    vtk_writer = _vtk_writer(vtk_stem, grid, t0 if resume else None)
    observers = [writer] + ([vtk_writer] if vtk_writer else [])
    last = {"t": None}

    def on_checkpoint(t, u, rho, tr, steps):
        write_checkpoint(ck_file, Checkpoint(t, u, rho, np.zeros((0, grid.dim)) if tr is None else tr,
                                             steps0 + steps, 0, wall0 + time.perf_counter() - wall, writer.n, cfg.text))
        last["t"] = t

    wall = time.perf_counter()
    with _closing_on_failure(writer, out, ck_file, last):
        res = sim.run(u0, rho0, setup.t_end, t_start=t0, save_times=save_times, observers=observers,
                      progress=progress, extra_event_times=ck_times[ck_times > t0], on_event=on_checkpoint,
                      restart=resume, tracers=tracers)
    writer.close("ok", steps=int(steps0 + res.steps))
    if os.path.exists(ck_file):
        os.remove(ck_file)                            # the run is complete
    data, _ = read_snapshots(out)
    return LayerOutcome(out, "ok", int(data["time"].size), float(setup.t_end), int(steps0 + res.steps),
                        wall0 + time.perf_counter() - wall, resumed, vtk_writer.pvd.as_posix() if vtk_writer else None)


def _run_packing_bed(cfg: LayerConfig, out, *, resume=False, progress=None, log=None) -> LayerOutcome:
    """:func:`run_layer_config` for ``kind = "packing_bed"``: the n-D packing continuum
    (:class:`bsrflow.numerics.packing_nd.EulerianPackingND`) through the shared controller into
    the same n-D netCDF file (and VTK files), with checkpoints of its named fields (the
    conserved state, history included) and ``--resume`` bit for bit."""
    from ..numerics.controller import drive_events
    from .netcdf import read_snapshots
    from .paths import check_output_file

    out = check_output_file(out, "--out")
    save_times, ck_times, ck_file, vtk_stem = _run_files(cfg, out)
    log = log or (lambda msg: None)
    setup = cfg.setup
    tracers = None if cfg.tracers is None else np.array(cfg.tracers, dtype=float)
    n_tr = 0 if tracers is None else tracers.shape[0]
    disc = setup.discretisation(tracers)
    grid = disc.grid
    motion = disc.motion
    floor = lambda t: motion.state(t)[0]  # noqa: E731
    t0, steps0, resumed, wall0 = 0.0, 0, None, 0.0
    attrs = {"config": cfg.text, "config_resolved": cfg.resolved_text(), "scheme": f"packing_{disc.name}",
             "kernel": "packing", "dimension": grid.dim, "scenario": f"packing_bed_{grid.dim}d",
             "diameter": float(setup.diameter)}
    if resume:
        ck = _read_layer_checkpoint(ck_file, cfg)
        try:
            disc.load_fields(ck.fields or {})
        except (KeyError, ValueError) as exc:
            raise ConfigError("--resume", f"the checkpoint's state does not match the config: {exc}") from None
        if tracers is not None:
            disc.set_tracers(_checkpoint_tracers(ck, tracers, ck_file))
        t0, steps0, resumed, wall0 = float(ck.t), int(ck.steps), float(ck.t), float(ck.wall_time)
        disc.counters[0] = steps0
        disc.steps = steps0
    writer, save_times = _layer_writer(out, grid, floor, attrs, save_times, n_tr, ck_file, t0 if resume else None,
                                       per_depth=True)
    vtk_writer = _vtk_writer(vtk_stem, grid, t0 if resume else None, per_depth=True)
    observers = [writer] + ([vtk_writer] if vtk_writer else [])
    if setup.stiffness_factor < 1.0:
        log(f"reduced contact stiffness: K x {setup.stiffness_factor:.4g}, impact Mach number "
            f"M = {setup.impact_mach():.3g}; its cost is measured on the 1-D column only (docs/model.md, "
            "\"Stiffness\")")
    last = {"t": None}

    def save(t):
        u, rho = disc.observe()
        tr = disc.tracer_positions() if n_tr else None
        for obs in observers:
            obs(t, u, rho, tr)
        if progress is not None:
            progress(t)

    def on_checkpoint(t):
        write_checkpoint(ck_file, Checkpoint(t, np.zeros(0), np.zeros(0), disc.tracer_positions(), int(disc.counters[0]),
                                             0, wall0 + time.perf_counter() - wall, writer.n, cfg.text,
                                             fields={k: v.copy() for k, v in disc.fields.items()}))
        last["t"] = t
        if progress is not None:
            progress(t)

    wall = time.perf_counter()
    with _closing_on_failure(writer, out, ck_file, last):
        log(f"compiling the {grid.dim}-D packing solver (once per process)")
        disc.advance(t0, t0)
        wall = time.perf_counter()
        if progress is not None:
            progress(t0)
        drive_events(t0, float(setup.t_end), save_times, motion.jumps_between(t0, setup.t_end), ck_times[ck_times > t0],
                     advance=disc.advance, apply_jump=disc.apply_velocity_jump, save=save, on_event=on_checkpoint)
    steps = int(disc.counters[0])
    writer.close("ok", steps=steps)
    if os.path.exists(ck_file):
        os.remove(ck_file)                            # the run is complete
    data, _ = read_snapshots(out)
    return LayerOutcome(out, "ok", int(data["time"].size), float(setup.t_end), steps,
                        wall0 + time.perf_counter() - wall, resumed, vtk_writer.pvd.as_posix() if vtk_writer else None)


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


def _complete_layer(out, cfg: LayerConfig, log) -> LayerOutcome | None:
    """The outcome of ``--resume`` on a layer output whose run finished (status "ok"; its
    checkpoint was removed) by this config: nothing to do.  None when ``out`` is not such a file;
    refused (one line) when another config wrote it."""
    from .netcdf import finished_snapshots
    data = finished_snapshots(out)
    if data is None:
        return None
    if str(data["attrs"].get("config", "")) != cfg.text:
        raise ConfigError("--resume", f"{out} was finished by another config; run without --resume to start over")
    log(f"{out} is complete already (status ok); nothing to resume")
    return LayerOutcome(os.fspath(out), "complete already", int(data["time"].size), float(data["time"][-1]),
                        int(data["attrs"].get("steps", 0)), 0.0, None, None)


def _read_layer_checkpoint(ck_file, cfg: LayerConfig) -> Checkpoint:
    """The checkpoint a ``--resume`` continues from, refused in one line when it is missing or
    was written by another config."""
    if not os.path.exists(ck_file):
        raise ConfigError("--resume", f"no checkpoint {ck_file}; run without --resume")
    ck = read_checkpoint(ck_file)
    if ck.config != cfg.text:
        raise ConfigError("--resume", f"{ck_file} was written by another config; run without --resume")
    from .runner import check_checkpoint_version
    check_checkpoint_version(ck, ck_file)
    return ck


def _checkpoint_tracers(ck: Checkpoint, tracers, ck_file):
    """The checkpoint's tracer positions, refused in one line when their number is not the
    config's."""
    if ck.tracers.shape != tracers.shape:
        raise ConfigError("--resume", f"{ck_file} holds {ck.tracers.shape[0]} tracers, the config "
                          f"{tracers.shape[0]}; run without --resume")
    return ck.tracers


def _layer_writer(out, grid, floor, attrs, save_times, n_tracers, ck_file, resumed_at, per_depth=False):
    """(the n-D netCDF writer, the save times still to come) of a layer run: a new file (a stale
    checkpoint of an earlier run removed), or with ``resumed_at`` [s] the file kept up to it.
    ``per_depth``: a 2-D run of a material uniform in depth (the packing bed; units per metre of
    depth, :func:`bsrflow.io.netcdf.schema_nd`)."""
    from .netcdf import NetCDFWriterND
    from .runner import output_attrs
    if resumed_at is not None:
        if not os.path.exists(out):
            raise ConfigError("--resume", f"the checkpoint {ck_file} exists but the output {out} does not; "
                              "run without --resume to start over")
        if str(output_attrs(out).get("config", "")) != attrs["config"]:
            raise ConfigError("--resume", f"{out} was written by another config; run without --resume to "
                              "start over")
        try:
            writer = NetCDFWriterND.resume(out, resumed_at, grid, floor, expected_snapshots=save_times.size,
                                           n_tracers=n_tracers, per_depth=per_depth)
        except OutputPathError:                     # no room for the rewritten file
            raise
        except Exception as exc:                    # an unreadable or foreign file
            raise ConfigError("--resume", f"cannot reopen {out}: {type(exc).__name__}: {exc}; run without "
                              "--resume to start over") from None
        return writer, save_times[save_times >= resumed_at]
    if os.path.exists(ck_file):
        os.remove(ck_file)                            # stale: belongs to an earlier run
    writer = NetCDFWriterND(out, grid, floor, attrs, expected_snapshots=save_times.size, n_tracers=n_tracers,
                            per_depth=per_depth)
    writer.check_space()                              # a full disk refused before the run
    return writer, save_times


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


@contextlib.contextmanager
def _closing_on_failure(writer, out, ck_file, last):
    """Close the netCDF ``writer`` with what stopped a layer run, then re-raise: a monitor's
    message, an interrupt (Ctrl-C or SIGTERM: one line on what was kept and whether ``--resume``
    can continue from the checkpoint at ``last["t"]``, exit code 128 + the signal), or "failed"."""
    from ..numerics.solver import SimulationError
    try:
        yield
    except SimulationError as exc:
        writer.close(f"stopped: {exc}")
        raise
    except KeyboardInterrupt as exc:
        how = "by SIGTERM" if getattr(exc, "signal_name", "") == "SIGTERM" else "by Ctrl-C (SIGINT)"
        writer.close(f"interrupted {how} after {writer.n} snapshots")
        cont = (f"checkpoint {ck_file} at t = {last['t']:.6g} s: `--resume` continues from there"
                if last["t"] is not None else "no checkpoint written yet: run again to start over")
        exc.args = (f"interrupted {how}: {out} keeps {writer.n} snapshot(s); {cont}",)
        exc.exit_code = 128 + int(getattr(exc, "signal_number", 2))
        raise
    except OSError as exc:
        if isinstance(exc, BrokenPipeError):        # `| head` went away: not a failed write of ours
            writer.close("failed")
            raise
        from .runner import write_failed
        raise write_failed(writer, exc) from exc
    except BaseException:
        writer.close("failed")
        raise
