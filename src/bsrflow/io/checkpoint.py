"""Checkpoints of a run: the state at an event time, enough to continue bit for bit.

A checkpoint is an ``.npz`` file ``<out>.ckpt`` (``checkpoint_path``) written to a temporary file,
flushed to disk and renamed over the previous one (``os.replace``), so a kill leaves either the
old or the new checkpoint, never a partial one.  It holds the state *before* the velocity jump
and the save at its time t (``Simulation.run``'s ``on_event``), which the resumed run then applies
itself; see :mod:`bsrflow.io.runner`.  Every kind of run writes the same format (the one run
driver, :mod:`bsrflow.io.driver`): its state as named fields (the seed's grid: ``u``, ``rho``; the
packing discretisations: their conserved fields or material points, history included), its
tracers, its step counts and the config.
"""

from __future__ import annotations

import os
import zipfile
from dataclasses import dataclass

import numpy as np

from .. import __version__

__all__ = ["Checkpoint", "checkpoint_path", "write_checkpoint", "read_checkpoint"]

_FORMAT = 2          # 1: the seed's (u, rho) apart from the other fields (before 2026-12-03)


@dataclass
class Checkpoint:
    """State of a run at time ``t``.

    t : time [s] (an event of the run: a checkpoint time).
    fields : the named state fields of the discretisation (field name -> array): the seed's
    grid ``u`` (velocity relative to the floor [m/s]) and ``rho`` (density [kg/m], n-D [kg/m^d]);
    the packing formulations ``EulerianPacking.fields``, ``LagrangianPacking.fields``,
    ``EulerianPackingND.fields`` (history included);
    tracers : tracer positions [m] (floor frame); all before the jump/save at t.
    steps : time steps taken from t = 0 to t; rejected_steps : rejected adaptive steps;
    wall_time : wall-clock time [s] spent up to t (all segments); n_snapshots : snapshots saved
    before t; config : the run's TOML text; version : bsrflow version that wrote it.
    """

    t: float
    fields: dict
    tracers: np.ndarray
    steps: int
    rejected_steps: int
    wall_time: float
    n_snapshots: int
    config: str
    version: str = __version__


def checkpoint_path(out) -> str:
    """The checkpoint file of output ``out``: ``<out>.ckpt``."""
    return os.fspath(out) + ".ckpt"


def write_checkpoint(path, ck: Checkpoint) -> None:
    """Write ``ck`` atomically to ``path`` (temporary file, fsync, ``os.replace``)."""
    path = os.fspath(path)
    tmp = f"{path}.tmp{os.getpid()}"
    try:
        with open(tmp, "wb") as fh:
            np.savez(fh, format=np.int64(_FORMAT), t=np.float64(ck.t), tracers=np.asarray(ck.tracers, float),
                     steps=np.int64(ck.steps), rejected_steps=np.int64(ck.rejected_steps),
                     wall_time=np.float64(ck.wall_time), n_snapshots=np.int64(ck.n_snapshots),
                     config=np.str_(ck.config), version=np.str_(ck.version),
                     **{f"field_{k}": np.asarray(v, float) for k, v in ck.fields.items()})
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except OSError as exc:                  # name the checkpoint (numpy's writes name no file)
        raise OSError(exc.errno, f"cannot write the checkpoint ({exc.strerror or exc})", path) from exc
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


def read_checkpoint(path) -> Checkpoint:
    """Read a checkpoint written by :func:`write_checkpoint`.  ValueError if it is not one."""
    path = os.fspath(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            if int(z["format"]) != _FORMAT:
                raise ValueError(f"{path}: checkpoint format {int(z['format'])}, expected {_FORMAT}")
            return Checkpoint(t=float(z["t"]), fields={k[6:]: z[k].copy() for k in z.files if k.startswith("field_")},
                              tracers=z["tracers"].copy(), steps=int(z["steps"]),
                              rejected_steps=int(z["rejected_steps"]), wall_time=float(z["wall_time"]),
                              n_snapshots=int(z["n_snapshots"]), config=str(z["config"]),
                              version=str(z["version"]))
    except (OSError, KeyError, EOFError, zipfile.BadZipFile) as exc:
        raise ValueError(f"{path}: not a readable bsrflow checkpoint ({type(exc).__name__}: {exc})") from None
    except ValueError as exc:
        if str(exc).startswith(path):               # the format check above
            raise
        # numpy's own refusal of another kind of file (e.g. "pickled (object) data"): not ours
        raise ValueError(f"{path}: not a bsrflow checkpoint (not the .npz file `bsrflow run` writes)") from None
