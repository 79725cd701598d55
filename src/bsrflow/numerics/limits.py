"""Limits shared by the configuration checks (:mod:`bsrflow.io.config`) and the Python API
(:class:`bsrflow.numerics.solver.Scheme`, :meth:`Simulation.run`): the measured stability
limits of the steppers and the largest number of snapshots of a run.  One table each, here.

The CFL limits are the largest stable Courant numbers found by ``bsrflow stability``
(:func:`bsrflow.analysis.stability.cfl_limit`), rounded to 4 decimals here, each
confirmed by running the solver at 0.98x and 1.02x the limit (``tests/test_stability.py``, which
also checks this table against the analysis).  Plain data, no imports, so that the
configuration reader can use it without loading the solver.
"""

from __future__ import annotations

__all__ = ["CFL_LIMITS", "STEPPER_FAMILY", "cfl_limit", "MAX_SNAPSHOTS"]

MAX_SNAPSHOTS = 1_000_000
"""The most snapshots a run may save (``run.save_every`` of a configuration, ``save_every`` /
``save_times`` of :meth:`bsrflow.numerics.solver.Simulation.run`)."""

CFL_LIMITS: dict[tuple[str, bool], float] = {
    ("euler", True): 0.7071,
    ("heun", True): 1.5289,
    ("kutta3", True): 2.3388,
    ("kutta3", False): 1.7321,
    ("rk4", True): 3.1010,
    ("rk4", False): 2.8284,
    ("euler", False): 0.0,
    ("heun", False): 0.0,
}
"""Largest stable Courant number ν = max(|u|+c) Δt/Δx of the scheme as implemented (central
differences in every Runge-Kutta stage; ``bsrflow stability``, README "Stability"), keyed by
(stepper, moving average after every step).  0: unstable at every ν.  ``bs32`` has the stability
polynomial of every 3-stage 3rd-order method, so its limits are those of ``kutta3``;
``rk4_0.4_0.25`` that of every 4-stage 4th-order method, so its limits are those of ``rk4``."""

STEPPER_FAMILY = {"rk3": "kutta3", "bs32": "kutta3", "rk4_0.4_0.25": "rk4"}
"""Steppers sharing the stability polynomial of a stepper of :data:`CFL_LIMITS`."""


def cfl_limit(stepper: str, filter: bool) -> float:
    """The measured CFL limit of ``stepper`` with (``filter=True``) or without the moving
    average after every step; 0.0 if unstable at every Courant number.  KeyError for a stepper
    without a measured limit."""
    return CFL_LIMITS[(STEPPER_FAMILY.get(stepper, stepper), bool(filter))]
