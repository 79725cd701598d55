"""The run controller shared by every discretisation: the seed kernel's grid solver
(:class:`bsrflow.numerics.solver.Simulation`) and the packing continuum's two formulations
(:mod:`bsrflow.numerics.packing`).

A run is a sequence of events: the save times, the velocity jumps of the applied motion (the
impulses of the floor frame, (3.15)) and further event times such as checkpoints.  Between two
events the discretisation advances on its own (it lands exactly on the next event); at an event
the controller calls, in this order, ``on_event(t)`` (extra events only: the state before the
jump and the save, as checkpoints need), ``apply_jump(Δ)`` (the floor velocity jumps by Δ, the
velocity relative to the floor by −Δ) and ``save(t)``.  A resumed run starts at an event and
applies its jump itself (``jumps_between`` is half-open, [t_start, t_end)), so an interrupted
and resumed run takes the same steps as an uninterrupted one.
"""

from __future__ import annotations

import numpy as np

__all__ = ["drive_events", "restore_named_fields"]


def drive_events(t_start, t_end, save_times, jumps, extra_event_times, *, advance, apply_jump, save,
                 on_event=None) -> None:
    """Run the event loop of the module docstring.

    t_start, t_end [s]; save_times [s] (sorted, within [t_start, t_end]); jumps: list of
    (time [s], floor velocity jump [m/s]) in [t_start, t_end); extra_event_times [s]: only those
    strictly inside (t_start, t_end) are used.  ``advance(t, t_event)`` integrates from t to
    exactly t_event (it raises to stop the run); the other callables as in the module
    docstring."""
    save_times = np.asarray(save_times, dtype=float)
    extra = {float(te) for te in extra_event_times if t_start < te < t_end}
    events = sorted(set(save_times.tolist()) | {tj for tj, _ in jumps} | extra)
    save_set = set(save_times.tolist())
    jump_at: dict[float, float] = {}
    for tj, dv in jumps:
        jump_at[tj] = jump_at.get(tj, 0.0) + dv
    t = float(t_start)
    for ev in events:
        if ev > t:
            advance(t, ev)
            t = ev
        if ev in extra and on_event is not None:
            on_event(ev)
        if ev in jump_at:
            apply_jump(jump_at[ev])
        if ev in save_set:
            save(ev)


def restore_named_fields(target: dict, fields: dict) -> None:
    """Copy a checkpoint's named ``fields`` into the arrays of ``target`` (a discretisation's
    named state, its ``fields``), all or none: ValueError (one line) naming the first that is
    missing or of another shape.  Every discretisation's ``load_fields``."""
    for name, arr in target.items():
        v = fields.get(name)
        if v is None or np.shape(v) != arr.shape:
            raise ValueError(f"state field {name}: {'missing' if v is None else np.shape(v)}, expected "
                             f"{arr.shape}")
    for name, arr in target.items():
        arr[...] = np.asarray(fields[name], dtype=float)
