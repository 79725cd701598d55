"""One run driver for every discretisation and dimension: what ``bsrflow run`` does with a config.

Every ``bsrflow run`` (a 1-D column of the seed's kernel on its grid, a packing column in either
formulation, a 2-D / 3-D layer of the seed's kernel, a 2-D / 3-D packing bed) goes through
:func:`drive`.  The driver owns everything about the run that is not the discretisation's:

* the output paths, checked before any work (``--out``, its checkpoint ``<out>.ckpt``, and what
  the job adds, e.g. a VTK folder);
* a new output (a stale checkpoint of an earlier run removed, the planned size checked against
  the free space) or, with ``--resume``, the checkpoint of the same config and bsrflow version,
  the output reopened with exactly the snapshots before it; ``--resume`` on a finished output
  of the same config does nothing and says so;
* checkpoints at the job's checkpoint times, one format for every run (its named state fields,
  tracers, the steps, the wall time and the snapshots so far; written atomically), the progress callback, the compile step before the time loop;
* what stops a run: a monitor (:class:`bsrflow.numerics.solver.SimulationError`: the file keeps
  every snapshot and its ``status`` is the message), Ctrl-C or SIGTERM (status "interrupted ...",
  one line on what was kept and whether ``--resume`` can continue, exit code 128 + the signal),
  a failed write (one line naming the file, exit 1), anything else ("failed: ...");
* the outcome (:class:`RunOutcome`).

What differs between discretisations is a :class:`RunJob`: the state it starts from or restores,
its writer, its time loop (the grid solvers' ``run`` or the packing controller
:func:`bsrflow.numerics.controller.drive_events`), and its state's named fields (the seed's grid:
``u``, ``rho``; the packing discretisations: theirs, history included).  The
jobs are :class:`bsrflow.io.runner.ColumnJob`, :class:`bsrflow.io.runner.PackingColumnJob`,
:class:`bsrflow.io.layer_runner.LayerJob` and :class:`bsrflow.io.layer_runner.PackingBedJob`.
"""

from __future__ import annotations

import abc
import contextlib
import errno
import os
import time
from dataclasses import dataclass

import numpy as np

from ..numerics.solver import SimulationError
from .checkpoint import Checkpoint, checkpoint_path, read_checkpoint, write_checkpoint
from .config import ConfigError
from .netcdf import finished_snapshots
from .paths import OutputPathError, check_output_file

__all__ = ["RunJob", "RunOutcome", "drive", "first_difference", "output_attrs", "write_failed", "check_checkpoint_version",
           "OTHER_KIND"]

OTHER_KIND = "everything: it is not a config of this kind of run (or cannot be read)"
"""What :meth:`RunJob.config_difference` says of a text that is not a config of the job's kind."""


@dataclass
class RunOutcome:
    """What a run wrote, for every kind of run.

    path : the netCDF file; status : "ok" or "complete already" (``--resume`` on a finished file);
    n_snapshots : snapshots in the file; t_end [s]; steps : accepted time steps from t = 0;
    wall_time [s] : wall-clock time of the time loop over all segments (without compiling);
    top_max_over_d : maximum lab-frame height of the top tracer in units of d, at ``t_top_max``
    [s] (columns; None for layers); resumed_from [s] : checkpoint time or None;
    compile_time [s] : compiling the time loop in this process; rejected_steps : rejected
    adaptive steps from t = 0 (``adaptive``: the scheme has error control); vtk : the ParaView
    collection (``.pvd``) of a run with VTK output, or None.
    """

    path: str
    status: str
    n_snapshots: int
    t_end: float
    steps: int
    wall_time: float
    top_max_over_d: float | None = None
    t_top_max: float | None = None
    resumed_from: float | None = None
    compile_time: float = 0.0
    rejected_steps: int = 0
    adaptive: bool = False
    vtk: str | None = None

    def summary(self) -> str:
        """One line: snapshots, steps, top max over d (columns), wall time, files."""
        top = (f"; top max {self.top_max_over_d:.4g} d at t = {self.t_top_max:.4g} s"
               if self.top_max_over_d is not None else "")
        if self.status != "ok":
            return f"{self.status}: {self.n_snapshots} snapshots to t = {self.t_end:.6g} s{top}; file {self.path}"
        resumed = f" (resumed from t = {self.resumed_from:.6g} s)" if self.resumed_from is not None else ""
        rejected = f" ({self.rejected_steps} rejected)" if self.adaptive else ""
        vtk = f"; VTK {self.vtk}" if self.vtk else ""
        return (f"{self.status}: {self.n_snapshots} snapshots to t = {self.t_end:.6g} s, {self.steps} steps"
                f"{rejected}{resumed}{top}; wall time {self.wall_time:.3g} s{' over all segments' if resumed else ''} "
                f"(+ {self.compile_time:.3g} s compiling); wrote {self.path}{vtk}")


class RunJob(abc.ABC):
    """The discretisation's part of a run (module docstring).  Attributes set by the job:

    out : the netCDF output; t_end [s]; save_times [s] : the whole save schedule from t = 0 (a
    resumed run keeps the part from its checkpoint on); checkpoint_times [s] : the events at which
    checkpoints are written (events of every run of the config, so that a resumed run equals an
    uninterrupted one); checkpoint_option : the config field of their interval (for messages);
    checkpoint_interval [s] : 0 when there are none; config_text : the config as written to the
    checkpoint; name : what is compiled (for the log line); diameter [m] or None : the scale of
    ``top`` in the outcome (columns).
    """

    out: str
    t_end: float
    save_times: np.ndarray
    checkpoint_times: np.ndarray
    checkpoint_option: str
    checkpoint_interval: float
    config_text: str
    name: str
    diameter: float | None = None
    adaptive: bool = False
    compile_note: str = ""

    def check_paths(self) -> None:
        """Further output paths (e.g. a VTK folder), checked before any work."""

    def prepare(self) -> None:
        """Build the discretisation (after the paths are checked, before the state is set)."""

    @abc.abstractmethod
    def config_difference(self, text: str, where: str) -> str:
        """'' when the config ``text`` (of a checkpoint or an output) is this run's, else the first
        difference in words, e.g. "run.t_end (0.5 in the checkpoint, 0.6 now)", or
        :data:`OTHER_KIND` when ``text`` is not a config of this kind of run."""

    @abc.abstractmethod
    def new_writer(self):
        """The netCDF writer of a new output (its global attributes included)."""

    @abc.abstractmethod
    def reopen_writer(self, t_checkpoint: float):
        """The writer of the existing output, keeping the snapshots before ``t_checkpoint``."""

    @abc.abstractmethod
    def restore(self, ck: Checkpoint) -> None:
        """Set the state (and the step counters) from the checkpoint; ConfigError ("--resume",
        one line) when it does not fit the config."""

    def observers(self, writer, resumed_at: float | None) -> list:
        """The observers of the saves: the writer, and what else the job writes (VTK files)."""
        return [writer]

    def notes(self) -> list:
        """Informational lines before the run (e.g. a reduced contact stiffness and its cost)."""
        return []

    def compile(self, t0: float) -> None:
        """Compile the time loop (a no-op advance), so that it is not done under the progress bar."""

    @abc.abstractmethod
    def integrate(self, t0, save_times, checkpoint_times, observers, progress, on_checkpoint) -> None:
        """Run from ``t0`` to ``t_end``, saving to ``observers`` at ``save_times`` and calling
        ``on_checkpoint(t, fields, tracers)`` (the state before the jump and the save at t, as named
        fields) at ``checkpoint_times``."""

    @abc.abstractmethod
    def total_steps(self) -> int:
        """Accepted steps from t = 0 (the resumed part included)."""

    def rejected_steps(self) -> int:
        """Rejected adaptive steps from t = 0."""
        return 0

    def stop_attrs(self) -> dict:
        """Attributes written with the status of a run a monitor stopped: the steps from t = 0 to
        the stop (:meth:`total_steps` counts them there too)."""
        return {"steps": np.int64(self.total_steps()), "rejected_steps": np.int64(self.rejected_steps())}

    def vtk_collection(self) -> str | None:
        """The ``.pvd`` file of the VTK output, or None."""
        return None


def first_difference(now: dict, then: dict, where: str) -> str:
    """'' when the (nested) config tables ``now`` and ``then`` hold the same values, else the first
    differing dotted key in words, e.g. "run.t_end (0.5 in the checkpoint, 0.6 now)" (a key
    missing on one side shows as None).  Every job compares its resolved configs with it."""
    def flat(d, prefix=""):
        items = {}
        for k, v in d.items():
            if isinstance(v, dict):
                items.update(flat(v, f"{prefix}{k}."))
            else:
                items[f"{prefix}{k}"] = v
        return items
    fa, fb = flat(now), flat(then)
    for key in sorted(set(fa) | set(fb)):
        if fa.get(key) != fb.get(key):
            return f"{key} ({fb.get(key)!r} in {where}, {fa.get(key)!r} now)"
    return ""


def drive(job: RunJob, *, resume: bool = False, progress=None, log=None) -> RunOutcome:
    """Run ``job`` into its output with checkpoints, or continue it with ``resume`` (module
    docstring).  Raises ConfigError (one line) for an unusable path or a resume that cannot be
    done, SimulationError when a monitor stops the run, KeyboardInterrupt (one-line message,
    ``exit_code``) on Ctrl-C / SIGTERM, OSError (one line) when a write fails."""
    log = log or (lambda msg: None)
    out = job.out = check_output_file(job.out, "--out")          # before any work
    ckpt_file = checkpoint_path(out)
    if os.path.isdir(ckpt_file):
        raise ConfigError("--out", f"the checkpoint file {ckpt_file} of this output is a directory")
    job.check_paths()
    if resume and not os.path.exists(ckpt_file):
        done = _complete_output(job, log)
        if done is not None:
            return done
        raise ConfigError("--resume", f"no checkpoint {ckpt_file} to resume from (checkpoints are written "
                          f"unless {job.checkpoint_option} = 0); run without --resume to start over")
    job.prepare()
    t0, wall0 = 0.0, 0.0
    if resume:
        if not os.path.exists(out):
            raise ConfigError("--resume", f"the checkpoint {ckpt_file} exists but the output {out} does not; "
                              "run without --resume to start over")
        ck = _read_matching_checkpoint(job, ckpt_file)
        job.restore(ck)
        writer = _reopen_output(job, ck.t)
        t0, wall0 = float(ck.t), float(ck.wall_time)
        log(f"resuming from the checkpoint at t = {t0:.6g} s ({writer.n} snapshots kept in {out})")
    else:
        if os.path.exists(ckpt_file):
            os.remove(ckpt_file)                     # stale: belongs to an earlier run
        writer = job.new_writer()
        writer.check_space()                        # a full disk refused before the run
    for note in job.notes():
        log(note)
    save_times = job.save_times[job.save_times >= t0]
    ckpt_times = job.checkpoint_times[job.checkpoint_times > t0]
    last_ckpt = [t0 if resume else None]            # time of the checkpoint on disk
    clock = {"start": time.perf_counter()}

    def on_checkpoint(t, fields, tracers=None):
        write_checkpoint(ckpt_file, Checkpoint(
            t=t, fields={k: np.array(v, copy=True) for k, v in fields.items()},
            tracers=np.zeros(0) if tracers is None else tracers, steps=job.total_steps(),
            rejected_steps=job.rejected_steps(), wall_time=wall0 + time.perf_counter() - clock["start"],
            n_snapshots=writer.n, config=job.config_text))
        last_ckpt[0] = t
        if progress is not None:
            progress(t)

    with _closing_on_failure(job, writer, lambda exc: _interrupted(exc, job, writer, resume, last_ckpt[0], t0)):
        observers = job.observers(writer, t0 if resume else None)
        log(f"compiling the {job.name} (once per process{job.compile_note})")
        compile_start = time.perf_counter()
        job.compile(t0)
        clock["start"] = time.perf_counter()
        compile_time = clock["start"] - compile_start
        if progress is not None:
            progress(t0)
        job.integrate(t0, save_times, ckpt_times, observers, progress, on_checkpoint)
    wall = wall0 + time.perf_counter() - clock["start"]
    writer.close("ok", steps=np.int64(job.total_steps()), rejected_steps=np.int64(job.rejected_steps()))
    if os.path.exists(ckpt_file):
        os.remove(ckpt_file)                        # the run is complete
    times = writer.series("time")
    top, t_top = _top(job, times, writer.series("top") if job.diameter is not None else None)
    return RunOutcome(out, "ok", writer.n, float(times[-1]) if times.size else float(job.t_end),
                      job.total_steps(), wall, top, t_top, resumed_from=t0 if resume else None,
                      compile_time=compile_time, rejected_steps=job.rejected_steps(), adaptive=job.adaptive,
                      vtk=job.vtk_collection())


def _top(job: RunJob, times, top):
    """(the top's maximum in d, its time [s]) of a column's output, (None, None) for a layer."""
    if top is None or job.diameter is None or not times.size:
        return None, None
    top = np.asarray(top, float) / job.diameter
    i = int(np.nanargmax(top)) if np.any(np.isfinite(top)) else 0
    return float(top[i]), float(times[i])


def _complete_output(job: RunJob, log) -> RunOutcome | None:
    """The outcome of ``--resume`` on an output whose run finished (status "ok"; its checkpoint
    was removed) by this config: nothing to do, the file as it is.  None when the output is not
    such a file; refused (one line) when another config wrote it."""
    data = finished_snapshots(job.out)
    if data is None:
        return None
    diff = job.config_difference(str(data["attrs"].get("config", "")), "the output")
    if diff:
        raise ConfigError("--resume", f"{job.out} was finished by another config (it differs in {diff}); run "
                          "without --resume to start over")
    log(f"{job.out} is complete already (status ok); nothing to resume")
    top, t_top = _top(job, data["time"], data.get("top") if job.diameter is not None else None)
    return RunOutcome(job.out, "complete already", int(data["time"].size), float(data["time"][-1]),
                      int(data["attrs"].get("steps", 0)), 0.0, top, t_top)


def _read_matching_checkpoint(job: RunJob, ckpt_file) -> Checkpoint:
    """The checkpoint of a resume, refused (one line) unless this config and this bsrflow
    version wrote it."""
    try:
        ck = read_checkpoint(ckpt_file)
    except ValueError as exc:
        raise ConfigError("--resume", f"cannot read the checkpoint: {exc}; run without --resume to start "
                          "over") from None
    diff = job.config_difference(ck.config, "the checkpoint")
    if diff:
        raise ConfigError("--resume", f"the config differs from the checkpoint's in {diff}; resume with "
                          "the same config or run without --resume to start over")
    check_checkpoint_version(ck, ckpt_file)
    check_checkpoint_values(ck, ckpt_file, float(job.t_end), job.checkpoint_times)
    return ck


def check_checkpoint_values(ck: Checkpoint, ckpt_file, t_end: float, checkpoint_times=None) -> None:
    """Refuse (one line naming the checkpoint) numbers that no run writes, a hand-edited or damaged
    file's: a time outside (0, t_end) (t = -1 was resumed) or, given the run's
    ``checkpoint_times`` [s], not one of them (a checkpoint is written only there: t = 0.5003 s
    was resumed as if the state were of that time), a field or tracer that is not a finite number
    (a NaN field wrote a NaN snapshot before the monitor stopped the run), negative counts."""
    def refuse(what):
        return ConfigError("--resume", f"the checkpoint {ckpt_file} {what}; run without --resume to start over")
    if not (np.isfinite(ck.t) and 0.0 < ck.t < t_end):
        raise refuse(f"has t = {ck.t!r} s, outside the valid range (0, t_end = {t_end:g}) s")
    if checkpoint_times is not None and not np.any(np.asarray(checkpoint_times, float) == ck.t):
        raise refuse(f"has t = {ck.t!r} s, which is not one of this config's checkpoint times (a layer config "
                     "without checkpoint_every checkpoints at min(0.1 s, t_end/10) since 2026-12-06: a "
                     "checkpoint of an earlier version may not match)")
    for name, values in [*ck.fields.items(), ("tracers", ck.tracers)]:
        what = "its tracer positions" if name == "tracers" else f"its field {name!r}"
        try:
            values = np.asarray(values, float)
        except (TypeError, ValueError):
            raise refuse(f"has values that are not numbers in {what}") from None
        bad = int(np.count_nonzero(~np.isfinite(values)))
        if bad:
            raise refuse(f"has {bad} non-finite value(s) (NaN or inf) of {values.size} in {what}")
    for name in ("steps", "rejected_steps", "n_snapshots"):
        if getattr(ck, name) < 0:
            raise refuse(f"has {name} = {getattr(ck, name)!r}, outside the valid range: integers >= 0")
    if not (np.isfinite(ck.wall_time) and ck.wall_time >= 0.0):
        raise refuse(f"has wall_time = {ck.wall_time!r} s, outside the valid range [0, inf) s")


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


def _reopen_output(job: RunJob, t_ck: float):
    """Reopen the output of a resumed run, keeping its snapshots before the checkpoint time
    ``t_ck``; refused (one line) when another config wrote it or its snapshots are not exactly
    the expected ones."""
    out = job.out
    diff = job.config_difference(str(output_attrs(out).get("config", "")), "the output")
    if diff:
        raise ConfigError("--resume", f"{out} was written by another config (it differs in {diff}); run "
                          "without --resume to start over")
    expected = job.save_times[job.save_times < t_ck]

    def check_kept(kept):
        if kept.size != expected.size or not np.array_equal(kept, expected):
            raise ConfigError("--resume", f"{out} holds {kept.size} snapshots before the checkpoint time "
                              f"t = {t_ck:.6g} s, expected {expected.size}; run without --resume to start over")
    times = output_times(out)
    check_kept(times[times < t_ck])                # before the file is rewritten: a refusal leaves it as it was
    try:
        writer = job.reopen_writer(t_ck)
    except OutputPathError:                        # no room for the rewritten file: one line as it is
        raise
    except Exception as exc:                       # unreadable or foreign file
        raise ConfigError("--resume", f"cannot reopen {out}: {type(exc).__name__}: {exc}; run without "
                          "--resume to start over") from None
    try:
        check_kept(writer.series("time"))
    except ConfigError:
        writer.close("resume failed: snapshots missing before the checkpoint")
        raise
    return writer


def output_times(path) -> np.ndarray:
    """The ``time`` variable of an output file [s] (read alone); ConfigError ("--resume", one
    line) when it cannot be read."""
    import h5py
    try:
        with h5py.File(os.fspath(path), "r", locking=False) as h:
            return np.asarray(h["time"][...], dtype=float).reshape(-1)
    except Exception as exc:                       # truncated, garbage, not HDF5, no time variable
        raise ConfigError("--resume", f"cannot reopen {path}: {type(exc).__name__}: {exc}; run without "
                          "--resume to start over") from None


@contextlib.contextmanager
def _closing_on_failure(job: RunJob, writer, interrupted):
    """Close ``writer`` with what stopped the run, then re-raise: a monitor's message (with the
    job's ``stop_attrs``), an interrupt (``interrupted(exc)`` closes it and words the message), a
    failed write (:func:`write_failed`), or "failed: ..."; nothing written so far is lost."""
    try:
        yield
    except SimulationError as exc:
        writer.close(str(exc), **job.stop_attrs())
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
    leave the file unreadable; :meth:`NetCDFWriter.close_as_is`), and return an OSError whose
    one-line message says what failed and what the output keeps (`bsrflow` prints it, exit code 1)."""
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


def _interrupted(exc, job: RunJob, writer, resume, last_ckpt_t, t0):
    """Close the file of an interrupted run (Ctrl-C or SIGTERM) with status "interrupted ..." and
    give ``exc`` one line saying what was kept and whether ``--resume`` can continue."""
    out, ckpt_file = job.out, checkpoint_path(job.out)
    signame = getattr(exc, "signal_name", None) or "SIGINT"
    how = "by SIGTERM" if signame == "SIGTERM" else "by Ctrl-C (SIGINT)"
    times = writer.series("time")
    kept = (f"{out} keeps {writer.n} snapshot(s) up to t = {times[-1]:.6g} s" if writer.n else
            f"no snapshot was written ({out} {'was kept as it was' if resume else 'was not written'})")
    writer.close(f"interrupted {how} after {writer.n} snapshots" +
                 (f", up to t = {times[-1]:.6g} s" if writer.n else ""))
    if last_ckpt_t is not None and os.path.exists(ckpt_file):
        cont = (f"checkpoint {ckpt_file} at t = {last_ckpt_t:.6g} s: `--resume` continues from there "
                f"(snapshots after it are recomputed)")
    elif job.checkpoint_interval <= 0.0:
        cont = (f"no checkpoint ({job.checkpoint_option} = 0): `--resume` cannot continue; run again to "
                "start over")
    else:
        first = job.checkpoint_times[job.checkpoint_times > t0]
        due = (f" (the first was due at t = {first[0]:.6g} s)" if first.size else
               f" (the run is shorter than {job.checkpoint_option})")
        cont = f"no checkpoint written yet{due}: `--resume` cannot continue; run again to start over"
    exc.args = (f"interrupted {how}: {kept}; {cont}",)
    exc.exit_code = 128 + int(getattr(exc, "signal_number", 2))
