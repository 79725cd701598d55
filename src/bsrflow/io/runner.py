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

import os
import tomllib

import numpy as np

from ..numerics.solver import SimulationError
from ..physics.column import initial_density
from .config import Config, ConfigError, saved_config
from .driver import (OTHER_KIND, RunJob, RunOutcome, check_checkpoint_version, drive, first_difference, output_attrs,
                     write_failed)
from .netcdf import NetCDFWriter

__all__ = ["run_config", "RunOutcome", "column_simulation", "ColumnJob", "PackingColumnJob",
           "check_checkpoint_version", "output_attrs", "write_failed"]


def column_simulation(config: Config):
    """(setup, grid, model, Simulation) of the configuration, with the monitors of
    :func:`bsrflow.physics.column.run_bsr_column` (vacuum threshold 1e-4 m/d, top tolerance
    1e-3 m/d [kg/m]); a run of it without checkpoints equals ``run_bsr_column`` bit for bit
    (tested)."""
    setup = config.column_setup()
    sim = setup.simulation(config.scheme())
    return setup, sim.grid, sim.model, sim


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
    kept, whether ``--resume`` can continue) and ``exit_code`` 128 + the signal number.  The
    run goes through the driver every run shares, :func:`bsrflow.io.driver.drive`.
    """
    job_class = PackingColumnJob if config["model.kernel"] == "packing" else ColumnJob
    return drive(job_class(config, out), resume=resume, progress=progress, log=log)


class _ColumnBase(RunJob):
    """What the two column jobs share: the config, its schedules, the comparison of configs, the
    1-D netCDF writer (:class:`bsrflow.io.netcdf.NetCDFWriter`)."""

    checkpoint_option = "run.checkpoint_every"

    def __init__(self, config: Config, out):
        self.config = config
        self.out = os.fspath(out)
        self.setup = config.column_setup()
        self.diameter = float(self.setup.diameter)
        self.t_end = float(config.run.t_end)
        self.save_times = config.save_times()
        self.checkpoint_times = config.checkpoint_times()
        self.checkpoint_interval = config.checkpoint_interval()
        self.config_text = config.to_toml()
        self.n_tracers = self.setup.n_spheres

    def config_difference(self, text, where):
        try:
            return first_difference(self.config.to_dict(), saved_config(text).to_dict(), where)
        except (ValueError, tomllib.TOMLDecodeError):
            return OTHER_KIND

    def _floor(self, t):
        return self.motion.state(t)[0]

    def _attrs(self) -> dict:
        return {"config": self.config_text, "diameter": self.diameter}

    def _state(self):
        """(field schema, source) of the state fields the file holds too (``run.write_state``), or None."""
        return None

    def new_writer(self):
        return NetCDFWriter(self.out, self.grid.x, self.grid.dx, self.n_tracers, self._floor, self._attrs(),
                            expected_snapshots=self.save_times.size, state=self._state())

    def reopen_writer(self, t_checkpoint):
        return NetCDFWriter.resume(self.out, t_checkpoint, self.grid.x, self.grid.dx, self.n_tracers, self._floor,
                                   expected_snapshots=self.save_times.size, state=self._state())


class ColumnJob(_ColumnBase):
    """The seed's kernel (or any grid kernel) on the 1-D grid: :class:`bsrflow.numerics.solver.Simulation`,
    checkpoints of (u, ρ, tracers) and the step counters, adaptive steps' rejections counted."""

    name = "solver"
    compile_note = "; about 10 s"

    def prepare(self):
        _, self.grid, model, self.sim = column_simulation(self.config)
        self.motion = model.motion
        self.adaptive = self.sim.scheme.rtol is not None
        self.u = np.zeros(self.grid.n_cells)
        self.rho = initial_density(self.setup, self.grid.x)
        self.tracers = self.setup.sphere_centres()
        self.steps0, self.rejected0, self.steps_run = 0, 0, 0
        self.rejected_start = int(self.sim.counters[0])
        self.restart = False

    def _attrs(self):
        return {**super()._attrs(), "scheme": self.sim.scheme.name}

    def restore(self, ck):
        u, rho = _grid_fields(ck, (self.grid.n_cells,), (self.grid.n_cells,))
        if ck.tracers.shape != (self.n_tracers,):
            raise ConfigError("--resume", "the checkpoint's tracers do not match the config")
        self.u, self.rho, self.tracers = u, rho, ck.tracers
        self.steps0, self.rejected0, self.restart = ck.steps, ck.rejected_steps, True

    def compile(self, t0):
        self.sim.advance(np.array(self.u, float), np.array(self.rho, float), t0, t0, np.array(self.tracers, float))
        self.rejected_start = int(self.sim.counters[0])

    def integrate(self, t0, save_times, checkpoint_times, observers, progress, on_checkpoint):
        def on_event(t, u, rho, tr, steps):
            self.steps_run = steps
            on_checkpoint(t, {"u": u, "rho": rho}, tr)

        run_counting_steps(self, self.sim.run, self.u, self.rho, self.t_end, t_start=t0, save_times=save_times,
                           tracers=self.tracers, observers=observers, progress=progress,
                           extra_event_times=checkpoint_times, on_event=on_event, restart=self.restart)

    def total_steps(self):
        return self.steps0 + self.steps_run

    def rejected_steps(self):
        return self.rejected0 + int(self.sim.counters[0]) - self.rejected_start



class PackingColumnJob(_ColumnBase):
    """``model.kernel = "packing"``: either formulation (:meth:`ColumnSetup.packing_discretisation`)
    through the packing controller :func:`bsrflow.numerics.packing.run_packing`; checkpoints of
    the discretisation's named fields, history included."""

    def prepare(self):
        self.disc = self.setup.packing_discretisation()
        self.grid, self.motion = self.disc.grid, self.disc.motion
        self.name = f"{self.disc.name} packing solver"

    def _attrs(self):
        d = self.disc
        return {**super()._attrs(), "scheme": f"packing_{d.name}", "kernel": "packing", "formulation": d.name,
                "range_over_d": float(d.law.range_over_d)}

    def _state(self):
        if not self.config["run.write_state"]:
            return None
        return self.disc.field_schema, lambda: self.disc.fields

    def restore(self, ck):
        try:
            self.disc.load_fields(ck.fields)
        except ValueError as exc:
            raise ConfigError("--resume", f"the checkpoint's state does not match the config: {exc}") from None
        self.disc.counters[0] = ck.steps
        self.disc.steps = ck.steps

    def notes(self):
        return [stiffness_note(self.setup)] if self.setup.stiffness_factor < 1.0 else []

    def compile(self, t0):
        self.disc.advance(t0, t0)

    def integrate(self, t0, save_times, checkpoint_times, observers, progress, on_checkpoint):
        from ..numerics.packing import run_packing
        run_packing(self.disc, self.t_end, save_times, t_start=t0, observers=observers, progress=progress,
                    extra_event_times=checkpoint_times,
                    on_event=lambda t, d: on_checkpoint(t, d.fields))

    def total_steps(self):
        return int(self.disc.counters[0])


def run_counting_steps(job, run, *args, **kwargs):
    """``run(*args, **kwargs)`` of a grid solver (:meth:`Simulation.run`, :meth:`SimulationND.run`)
    for ``job``, setting ``job.steps_run`` to the steps of the segment, also when a monitor stops
    it (the stop's ``result``), so that the output's count is the steps to the stop."""
    try:
        res = run(*args, **kwargs)
    except SimulationError as exc:
        job.steps_run = getattr(exc.result, "steps", job.steps_run)
        raise
    job.steps_run = res.steps


def _grid_fields(ck, u_shape, rho_shape):
    """(u, ρ) of a checkpoint of the seed's grid, refused in one line unless both are there with
    the grid's shapes (n-D: u has the components first)."""
    u, rho = ck.fields.get("u"), ck.fields.get("rho")
    if u is None or rho is None or u.shape != u_shape or rho.shape != rho_shape:
        raise ConfigError("--resume", f"the checkpoint's state ({', '.join(sorted(ck.fields)) or 'no fields'}) "
                          "does not match the grid of the config")
    return u, rho


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

