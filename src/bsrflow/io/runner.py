"""Run a tapped-column configuration into a netCDF file, with checkpoints and resume.

:func:`run_config` is what ``bsrflow run`` does::

    from bsrflow.io import load_config, run_config
    outcome = run_config(load_config("column.toml"), "column.nc")        # raises SimulationError
    outcome = run_config(cfg, "column.nc", resume=True)                   # after a kill

How a resumed run equals an uninterrupted one bit for bit
----------------------------------------------------------
* The checkpoint times (every ``run.checkpoint_every`` from t = 0) are events of *every* run of
  the configuration, interrupted or not (``Simulation.run(extra_event_times=...)``): a step
  ends exactly there.  Everything else about the step sequence is a function of the state and
  the next event: ``advance`` starts afresh at every event (the adaptive stepper's step-size
  proposal is *not* carried across events, so nothing else needs storing).
* A checkpoint holds the state at its time t *before* the velocity jump and the save at t
  (``on_event`` runs first).  The resumed run starts at t_start = t and applies the jump at t
  itself (``jumps_between`` is half-open, [t, t_end), so it includes t, once) and saves at t.
* The save schedule is computed from the original t = 0 (``Config.save_times``) and filtered to
  the times >= t, not recomputed from the resume time.
* The output file keeps the snapshots with time < t and appends from there (``NetCDFWriter.resume``).
"""

from __future__ import annotations

import contextlib
import errno
import os
import time as _time
import tomllib
from dataclasses import dataclass

import numpy as np

from ..numerics.solver import SimulationError
from ..physics.column import initial_density
from .checkpoint import Checkpoint, checkpoint_path, read_checkpoint, write_checkpoint
from .config import Config, ConfigError, saved_config
from .netcdf import NetCDFWriter, finished_snapshots
from .paths import OutputPathError, check_output_file

__all__ = ["run_config", "RunOutcome", "column_simulation"]


@dataclass
class RunOutcome:
    """What a finished run wrote.

    path : the netCDF file; status : "ok" or "complete already" (``--resume`` on a finished file);
    n_snapshots : snapshots in the file; t_end [s]; steps : accepted time steps from t = 0;
    rejected_steps : rejected adaptive steps from t = 0 (``adaptive``: the scheme has error control);
    wall_time [s] : wall-clock time of the time loop over all segments (without compiling);
    compile_time [s] : compiling the time loop in this process; top_max_over_d : maximum lab-frame height of
    the top tracer in units of d, at ``t_top_max`` [s]; resumed_from [s] : checkpoint time or None.
    """

    path: str
    status: str
    n_snapshots: int
    t_end: float
    steps: int
    wall_time: float
    top_max_over_d: float
    t_top_max: float
    resumed_from: float | None = None
    compile_time: float = 0.0
    rejected_steps: int = 0
    adaptive: bool = False

    def summary(self) -> str:
        """One line: top max over d, steps, wall time, file."""
        top = f"top max {self.top_max_over_d:.4g} d at t = {self.t_top_max:.4g} s"
        if self.status != "ok":
            return f"{self.status}: {self.n_snapshots} snapshots to t = {self.t_end:.6g} s; {top}; file {self.path}"
        resumed = f" (resumed from t = {self.resumed_from:.6g} s)" if self.resumed_from is not None else ""
        rejected = f" ({self.rejected_steps} rejected)" if self.adaptive else ""
        return (f"{self.status}: {self.n_snapshots} snapshots to t = {self.t_end:.6g} s, {self.steps} steps"
                f"{rejected}{resumed}; {top}; wall time {self.wall_time:.3g} s (+ {self.compile_time:.3g} s "
                f"compiling); wrote {self.path}")


def column_simulation(config: Config):
    """(setup, grid, model, Simulation) of the configuration, with the monitors of
    :func:`bsrflow.physics.column.run_bsr_column` (vacuum threshold 1e-4 m/d, top tolerance
    1e-3 m/d [kg/m]); a run of it without checkpoints equals ``run_bsr_column`` bit for bit
    (tested)."""
    setup = config.column_setup()
    sim = setup.simulation(config.scheme())
    return setup, sim.grid, sim.model, sim


def _config_difference(a: Config, b: Config, where: str = "the checkpoint") -> str:
    da, db = a.to_dict(), b.to_dict()
    for table in da:
        for key in sorted(set(da[table]) | set(db[table])):
            va, vb = da[table].get(key), db[table].get(key)
            if va != vb:
                return f"{table}.{key} ({vb!r} in {where}, {va!r} now)"
    return ""


def run_config(config: Config, out, *, resume: bool = False, progress=None, log=None) -> RunOutcome:
    """Run ``config`` and write snapshots to the netCDF file ``out`` as the run goes.

    Checkpoints go to ``<out>.ckpt`` every ``run.checkpoint_every`` seconds of simulated time
    (removed when the run finishes).  ``resume=True`` continues from that checkpoint: the
    config must be the one of the checkpoint, ``out`` must hold the snapshots before it.
    progress : callable ``progress(t)`` [s] called at every save and checkpoint;
    log : callable ``log(message)`` for informational lines.
    Raises ConfigError (a ValueError; one line) for an unusable output path or a resume that
    cannot be done, and :class:`SimulationError` when a monitor stops the run: the file keeps
    every snapshot saved and its ``status`` attribute is the message.  A KeyboardInterrupt
    (Ctrl-C; ``bsrflow run`` raises one with ``signal_name = "SIGTERM"`` on SIGTERM) closes the
    file with status "interrupted ..." and is re-raised with one line as its message (what was
    kept, whether ``--resume`` can continue) and ``exit_code`` 128 + the signal number.
    """
    out = os.fspath(out)
    log = log or (lambda msg: None)
    check_output_file(out, "--out")                   # before any work (bsrflow.io.paths)
    ckpt_file = checkpoint_path(out)
    if os.path.isdir(ckpt_file):
        raise ConfigError("--out", f"the checkpoint file {ckpt_file} of this output is a directory")
    if resume and not os.path.exists(ckpt_file):
        done = _complete_output(out, config, log)
        if done is not None:
            return done
        raise ConfigError("--resume", f"no checkpoint {ckpt_file} to resume from (checkpoints are "
                          "written unless run.checkpoint_every = 0); run without --resume to start over")
    if config["model.kernel"] == "packing":
        return _run_packing_config(config, out, resume=resume, progress=progress, log=log)
    setup, grid, model, sim = column_simulation(config)
    save_times = config.save_times()
    ckpt_times = config.checkpoint_times()
    t_end = float(config.run.t_end)
    n_tr = setup.n_spheres
    motion = model.motion

    def floor(t):
        return motion.state(t)[0]

    steps0, rejected0, wall0, t0 = 0, 0, 0.0, 0.0
    if resume:
        if not os.path.exists(out):
            raise ConfigError("--resume", f"the checkpoint {ckpt_file} exists but the output {out} does not; "
                              "run without --resume to start over")
        ck = _read_matching_checkpoint(config, ckpt_file)
        if ck.u.shape != (grid.n_cells,) or ck.tracers.shape != (n_tr,):
            raise ConfigError("--resume", f"the checkpoint's state does not match the grid of the config")
        writer, kept = _reopen_output(out, ck.t, grid, n_tr, floor, save_times, config)
        u0, rho0, tr0, t0 = ck.u, ck.rho, ck.tracers, ck.t
        steps0, rejected0, wall0 = ck.steps, ck.rejected_steps, ck.wall_time
        log(f"resuming from the checkpoint at t = {t0:.6g} s ({kept.size} snapshots kept in {out})")
    else:
        if os.path.exists(ckpt_file):
            os.remove(ckpt_file)                       # stale: belongs to an earlier run
        attrs = {"config": config.to_toml(), "scheme": sim.scheme.name, "diameter": float(setup.diameter)}
        writer = NetCDFWriter(out, grid.x, grid.dx, n_tr, floor, attrs, expected_snapshots=save_times.size)
        writer.check_space()                          # a full disk refused before the run
        u0, rho0, tr0 = np.zeros(grid.n_cells), initial_density(setup, grid.x), setup.sphere_centres()

    last_ckpt = [t0 if resume else None]             # time of the checkpoint on disk
    toml_text = config.to_toml()
    rejected_start = int(sim.counters[0])
    wall_start = _time.perf_counter()

    def on_checkpoint(t, u, rho, tr, steps):
        write_checkpoint(ckpt_file, Checkpoint(
            t=t, u=u, rho=rho, tracers=tr, steps=steps0 + steps,
            rejected_steps=rejected0 + int(sim.counters[0]) - rejected_start,
            wall_time=wall0 + _time.perf_counter() - wall_start, n_snapshots=writer.n, config=toml_text))
        last_ckpt[0] = t
        if progress is not None:
            progress(t)

    stop_attrs = lambda: {"rejected_steps": np.int64(rejected0 + int(sim.counters[0]) - rejected_start)}  # noqa: E731
    with _closing_on_failure(writer, stop_attrs,
                             lambda exc: _interrupted(exc, writer, out, resume, config, last_ckpt[0], ckpt_file,
                                                      ckpt_times, t0)):
        # compile the time loop now (a no-op advance: t_end = t), not in the middle of the progress bar
        log("compiling the solver (once per process; about 10 s)")
        compile_start = _time.perf_counter()
        sim.advance(np.array(u0, float), np.array(rho0, float), t0, t0, np.array(tr0, float))
        wall_start = _time.perf_counter()
        compile_time = wall_start - compile_start
        rejected_start = int(sim.counters[0])
        if progress is not None:
            progress(t0)
        res = sim.run(u0, rho0, t_end, t_start=t0, save_times=save_times[save_times >= t0], tracers=tr0,
                      observers=[writer], progress=progress, extra_event_times=ckpt_times[ckpt_times > t0],
                      on_event=on_checkpoint, restart=resume)
    rejected = rejected0 + int(sim.counters[0]) - rejected_start
    writer.close("ok", steps=np.int64(steps0 + res.steps), rejected_steps=np.int64(rejected))
    if os.path.exists(ckpt_file):
        os.remove(ckpt_file)
    t = writer.series("time")
    top = writer.series("top") / setup.diameter
    i = int(np.nanargmax(top)) if np.any(np.isfinite(top)) else 0
    return RunOutcome(out, "ok", writer.n, float(t[-1]), steps0 + res.steps,
                      wall0 + _time.perf_counter() - wall_start, float(top[i]), float(t[i]),
                      resumed_from=t0 if resume else None, compile_time=compile_time,
                      rejected_steps=rejected, adaptive=sim.scheme.rtol is not None)


def _complete_output(out, config: Config, log) -> RunOutcome | None:
    """The outcome of ``--resume`` on an output whose run finished (status "ok"; its checkpoint
    was removed) by this config: nothing to do, the file as it is.  None when ``out`` is not
    such a file; refused (one line) when another config wrote it.  The same for every column run
    (the seed's kernel and both packing formulations)."""
    data = finished_snapshots(out)
    if data is None:
        return None
    try:
        diff = _config_difference(config, saved_config(str(data["attrs"].get("config", ""))))
    except (ValueError, tomllib.TOMLDecodeError):
        diff = "its config, which cannot be read"
    if diff:
        raise ConfigError("--resume", f"{out} was finished by another config (it differs in {diff}); run "
                          "without --resume to start over")
    top = data["top"] / config.column_setup().diameter
    i = int(np.nanargmax(top)) if np.any(np.isfinite(top)) else 0
    log(f"{out} is complete already (status ok); nothing to resume")
    return RunOutcome(out, "complete already", int(data["time"].size), float(data["time"][-1]), 0, 0.0,
                      float(top[i]), float(data["time"][i]))


def _read_matching_checkpoint(config: Config, ckpt_file) -> Checkpoint:
    """The checkpoint of a resume, refused (one line) unless it was written by this config."""
    try:
        ck = read_checkpoint(ckpt_file)
        old = saved_config(ck.config)
    except (ValueError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError("--resume", f"cannot read the checkpoint: {exc}") from None
    diff = _config_difference(config, old)
    if diff:
        raise ConfigError("--resume", f"the config differs from the checkpoint's in {diff}; resume with "
                          "the same config or run without --resume to start over")
    check_checkpoint_version(ck, ckpt_file)
    return ck


def check_checkpoint_version(ck: Checkpoint, ckpt_file) -> None:
    """Refuse (one line) a checkpoint that another bsrflow version wrote: a resumed run equals an
    uninterrupted one bit for bit only when the same code computes both parts."""
    from .. import __version__
    if ck.version != __version__:
        raise ConfigError("--resume", f"{ckpt_file} was written by bsrflow {ck.version}, this is {__version__}; "
                          "run without --resume to start over")


def output_attrs(path) -> dict:
    """The global attributes of an output file (read alone, without its data); ConfigError
    ("--resume", one line) when it cannot be read."""
    import h5py
    try:
        with h5py.File(os.fspath(path), "r", locking=False) as h:
            return {k: (v.decode() if isinstance(v, bytes) else v) for k, v in h.attrs.items()}
    except Exception as exc:                       # truncated, garbage, not HDF5
        raise ConfigError("--resume", f"cannot reopen {path}: {type(exc).__name__}: {exc}; run without "
                          "--resume to start over") from None


def _reopen_output(out, t_ck, grid, n_tr, floor, save_times, config: Config):
    """Reopen the output of a resumed run, keeping its snapshots before the checkpoint time
    ``t_ck``; refused (one line) when another config wrote it or its snapshots are not exactly
    the expected ones."""
    text = str(output_attrs(out).get("config", ""))     # ConfigError when unreadable
    try:
        diff = _config_difference(config, saved_config(text), "the output")
    except (ValueError, tomllib.TOMLDecodeError):
        diff = "its config, which cannot be read"
    if diff:
        raise ConfigError("--resume", f"{out} was written by another config (it differs in {diff}); run "
                          "without --resume to start over")
    expected = save_times[save_times < t_ck]
    try:
        writer = NetCDFWriter.resume(out, t_ck, grid.x, grid.dx, n_tr, floor, expected_snapshots=save_times.size)
    except OutputPathError:                        # no room for the rewritten file: one line as it is
        raise
    except Exception as exc:                       # unreadable or foreign file
        raise ConfigError("--resume", f"cannot reopen {out}: {type(exc).__name__}: {exc}") from None
    kept = writer.series("time")
    if kept.size != expected.size or not np.array_equal(kept, expected):
        writer.close("resume failed: snapshots missing before the checkpoint")
        raise ConfigError("--resume", f"{out} holds {kept.size} snapshots before the checkpoint time "
                          f"t = {t_ck:.6g} s, expected {expected.size}; run without --resume to start over")
    return writer, kept


@contextlib.contextmanager
def _closing_on_failure(writer, stop_attrs, interrupted):
    """Close ``writer`` with what stopped the run, then re-raise: a monitor's message (with the
    attributes ``stop_attrs()``), an interrupt (``interrupted(exc)`` closes it and words the
    message), or "failed: ..."; nothing written so far is lost."""
    try:
        yield
    except SimulationError as exc:
        writer.close(str(exc), **stop_attrs())
        raise
    except KeyboardInterrupt as exc:
        interrupted(exc)
        raise
    except OSError as exc:
        if isinstance(exc, BrokenPipeError):       # `| head` went away: not a failed write of ours
            writer.close(f"failed: {type(exc).__name__}: {exc}")
            raise
        raise write_failed(writer, exc) from exc
    except BaseException as exc:
        writer.close(f"failed: {type(exc).__name__}: {exc}")
        raise


def write_failed(writer, exc: OSError) -> OSError:
    """A write that failed in the middle of a run (a full disk, a file system gone read-only, a
    checkpoint or VTK file that cannot be written): close ``writer`` with status "failed: ...",
    or on a full (or read-only) disk as it is (status "running": writing the status could
    leave the file unreadable; :meth:`NetCDFWriter.close_as_is`), and return an OSError whose one-line message says what
    failed and what the output keeps (`bsrflow` prints it, exit code 1)."""
    full = exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EIO)
    try:
        if full:              # a new status needs space: a failed metadata write breaks the file
            writer.close_as_is()
        else:
            writer.close(f"failed: {exc}")
    except Exception:
        pass
    times = writer.series("time")
    kept = f"{writer.path} keeps {writer.n} snapshot(s)" + (f" up to t = {times[-1]:.6g} s" if writer.n else "")
    if full and writer.n:
        kept += ' (its status attribute left at "running")'
    what = f"{exc.strerror or exc}" + (f": {exc.filename}" if exc.filename else "")
    return OSError(exc.errno, f"{what}; the run stopped, {kept}")


def _interrupted(exc, writer, out, resume, config, last_ckpt_t, ckpt_file, ckpt_times, t0):
    """Close the file of an interrupted run (Ctrl-C or SIGTERM) with status "interrupted ..." and
    give ``exc`` one line saying what was kept and whether ``--resume`` can continue."""
    signame = getattr(exc, "signal_name", None) or "SIGINT"
    how = "by SIGTERM" if signame == "SIGTERM" else "by Ctrl-C (SIGINT)"
    times = writer.series("time")
    kept = (f"{out} keeps {writer.n} snapshot(s) up to t = {times[-1]:.6g} s" if writer.n else
            f"no snapshot was written ({out} {'was kept as it was' if resume else 'was not written'})")
    writer.close(f"interrupted {how} after {writer.n} snapshots" +
                 (f", up to t = {times[-1]:.6g} s" if writer.n else ""))
    interval = config.checkpoint_interval()
    if last_ckpt_t is not None and os.path.exists(ckpt_file):
        cont = (f"checkpoint {ckpt_file} at t = {last_ckpt_t:.6g} s: `--resume` continues from there "
                f"(snapshots after it are recomputed)")
    elif interval <= 0.0:
        cont = "no checkpoint (run.checkpoint_every = 0): `--resume` cannot continue; run again to start over"
    else:
        first = ckpt_times[ckpt_times > t0]
        due = f" (the first was due at t = {first[0]:.6g} s)" if first.size else " (the run is shorter than run.checkpoint_every)"
        cont = f"no checkpoint written yet{due}: `--resume` cannot continue; run again to start over"
    exc.args = (f"interrupted {how}: {kept}; {cont}",)
    exc.exit_code = 128 + int(getattr(exc, "signal_number", 2))


def _run_packing_config(config: Config, out, *, resume=False, progress=None, log=None) -> RunOutcome:
    """:func:`run_config` for ``model.kernel = "packing"``: the same netCDF output, checkpoints
    of the discretisation's named fields (history included) and resume, through the packing
    controller :func:`bsrflow.numerics.packing.run_packing`."""
    from ..numerics.packing import run_packing
    setup = config.column_setup()
    disc = setup.packing_discretisation()
    grid = disc.grid
    ckpt_file = checkpoint_path(out)
    save_times, ckpt_times = config.save_times(), config.checkpoint_times()
    t_end = float(config.run.t_end)
    n_tr = setup.n_spheres
    motion = disc.motion

    def floor(t):
        return motion.state(t)[0]

    steps0, wall0, t0 = 0, 0.0, 0.0
    if resume:
        if not os.path.exists(out):
            raise ConfigError("--resume", f"the checkpoint {ckpt_file} exists but the output {out} does not; "
                              "run without --resume to start over")
        ck = _read_matching_checkpoint(config, ckpt_file)
        try:
            disc.load_fields(ck.fields or {})
        except (KeyError, ValueError) as exc:
            raise ConfigError("--resume", f"the checkpoint's state does not match the config: {exc}") from None
        disc.counters[0] = ck.steps
        disc.steps = ck.steps
        writer, kept = _reopen_output(out, ck.t, grid, n_tr, floor, save_times, config)
        t0, steps0, wall0 = ck.t, ck.steps, ck.wall_time
        log(f"resuming from the checkpoint at t = {t0:.6g} s ({kept.size} snapshots kept in {out})")
    else:
        if os.path.exists(ckpt_file):
            os.remove(ckpt_file)
        attrs = {"config": config.to_toml(), "scheme": f"packing_{disc.name}", "diameter": float(setup.diameter),
                 "kernel": "packing", "formulation": disc.name, "range_over_d": float(disc.law.range_over_d)}
        writer = NetCDFWriter(out, grid.x, grid.dx, n_tr, floor, attrs, expected_snapshots=save_times.size)
        writer.check_space()                          # a full disk refused before the run
    if setup.stiffness_factor < 1.0:
        log(stiffness_note(setup))
    last_ckpt = [t0 if resume else None]             # time of the checkpoint on disk

    def on_checkpoint(t, d):
        last_ckpt[0] = t
        write_checkpoint(ckpt_file, Checkpoint(
            t=t, u=np.zeros(0), rho=np.zeros(0), tracers=np.zeros(0), steps=int(d.counters[0]), rejected_steps=0,
            wall_time=wall0 + _time.perf_counter() - wall_start, n_snapshots=writer.n, config=config.to_toml(),
            fields={k: v.copy() for k, v in d.fields.items()}))
        if progress is not None:
            progress(t)

    wall_start = _time.perf_counter()
    stop_attrs = lambda: {"steps": np.int64(disc.counters[0]), "rejected_steps": np.int64(0)}  # noqa: E731
    with _closing_on_failure(writer, stop_attrs,
                             lambda exc: _interrupted(exc, writer, out, resume, config, last_ckpt[0], ckpt_file,
                                                      ckpt_times, t0)):
        log(f"compiling the {disc.name} packing solver (once per process)")
        compile_start = _time.perf_counter()
        disc.advance(t0, t0)
        wall_start = _time.perf_counter()
        if progress is not None:
            progress(t0)
        run_packing(disc, t_end, save_times[save_times >= t0], t_start=t0, observers=[writer], progress=progress,
                    extra_event_times=ckpt_times[ckpt_times > t0], on_event=on_checkpoint)
    steps = int(disc.counters[0])
    writer.close("ok", steps=np.int64(steps), rejected_steps=np.int64(0))
    if os.path.exists(ckpt_file):
        os.remove(ckpt_file)
    t = writer.series("time")
    top = writer.series("top") / setup.diameter
    i = int(np.nanargmax(top)) if np.any(np.isfinite(top)) else 0
    return RunOutcome(out, "ok", writer.n, float(t[-1]), steps, wall0 + _time.perf_counter() - wall_start,
                      float(top[i]), float(t[i]), resumed_from=t0 if resume else None,
                      compile_time=wall_start - compile_start)


def stiffness_note(setup) -> str:
    """One line on the reduced stiffness of a packing run and its documented cost (the bound of
    its model, :data:`bsrflow.physics.column.STIFFNESS_ERROR_BOUNDS`)."""
    from ..physics.column import STIFFNESS_ERROR_BOUNDS, STIFFNESS_MACH, impact_mach, stiffness_model
    mach = impact_mach(setup)
    model = stiffness_model(setup)
    b = STIFFNESS_ERROR_BOUNDS.get(model)
    if b is None:
        cost = f"no documented bound for the packing model {model} (bench/packing_stiffness.py measures one)"
    elif mach <= STIFFNESS_MACH * (1 + 1e-9):
        cost = (f"documented cost at M <= {STIFFNESS_MACH:g} ({model}): top maximum within "
                f"{100 * b['top_max_rel']:g} % and mass-centre RMS within {b['mass_centre_rms_over_d']:g} d of the "
                "true stiffness's")
    else:
        top, rms = b["measured_at_mach_0.03"]
        cost = (f"above M = {STIFFNESS_MACH:g} the documented bound does not apply (measured at M = 0.03: up to "
                f"{100 * top:g} % in the top maximum and {rms:g} d in the mass centre; bench/packing_stiffness.py)")
    return (f"reduced contact stiffness: K x {setup.stiffness_factor:.4g}, impact Mach number M = {mach:.3g}; "
            + cost)

