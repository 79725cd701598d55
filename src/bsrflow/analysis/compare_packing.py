"""The packing continuum against the DEM, with nothing fitted (issue #18).

``bsrflow compare --kernel packing --json PATH --figures DIR`` runs, for every case of
:data:`PACKING_CASES` (d = 5, 10, 22 mm at a/d = 0.5, 0.75, 1.0, 1.5, single taps; three taps
with period 1.0 s at d = 22 mm, a/d = 0.75 and 1.0), the package's DEM and the packing
continuum (:mod:`bsrflow.physics.packing`) in each model of ``models`` (:data:`PACKING_MODELS`,
(formulation, R/d) pairs: by default the nonlocal interaction over one diameter in both
formulations).  Only the contact law's K and e, d, the material density,
N and g enter the continuum: no calibration step, and the JSON says so with
``"fitted_constants": {}``.

Metrics per case and model (heights from the floor at rest, in d): the top sphere's maximum after
each tap and its time (continuum: the tracer at the top sphere's centre, i.e. at mass coordinate
(N − ½) m), their relative differences from the DEM's (time from the run's start, as in today's
compare JSON; also the rise time from the tap's start), the relative error of the rise (top
maximum minus the top at rest: the stricter measure), with several taps the largest over the
taps, and the RMS difference of the mass-centre heights over the whole run.

Figures: the tracer trajectories of every model beside the DEM's sphere trajectories; top and
mass centre against time; density snapshots of the continuum beside the DEM's coarse-grained
density (a Gaussian kernel average of the sphere centres of standard deviation d/2, i.e. about
one diameter wide, the MercuryCG way; the continuum is shown both as it is and coarse-grained with
the same kernel) at the same times.
"""

from __future__ import annotations

import math
import os
import time

import numpy as np

from ..numerics.solver import SimulationError
from ..physics.column import ColumnSetup, model_label, run_bsr_column

__all__ = ["PACKING_CASES", "PACKING_MODELS", "case_setup", "compare_packing", "coarse_grained_density",
           "format_packing_table", "demo_packing", "format_demo_table", "model_label", "parse_models"]

PACKING_MODELS = (("lagrangian", 1.0), ("eulerian", 1.0))
"""The packing models compared by default, (formulation, R/d): the package's packing continuum, the
nonlocal interaction (R = d), in both formulations (the local limit, R = 0, with ``--models``)."""


def parse_models(text: str):
    """'lagrangian:1,eulerian:0' -> (("lagrangian", 1.0), ("eulerian", 0.0)); a formulation without
    ':R' takes the default range, 1.  ValueError naming ``--models`` on bad
    input (an unknown formulation, a range outside [0, 4] or a model given twice).  A nonlocal
    range with the Eulerian formulation runs :class:`~bsrflow.numerics.packing.StaggeredEulerianPacking`."""
    from ..physics.packing import MAX_RANGE_OVER_D
    out = []
    for item in text.split(","):
        form, colon, rng = item.strip().partition(":")
        if colon and not rng.strip():
            raise ValueError(f"--models: {item!r}: the range after ':' is missing (a number in "
                             f"[0, {MAX_RANGE_OVER_D:g}], or leave out ':' for the formulation's default)")
        if form not in ("eulerian", "lagrangian"):
            raise ValueError(f"--models: {item!r}: the formulation is not one of eulerian, lagrangian "
                             "(format FORMULATION:R_OVER_D, comma-separated)")
        try:
            r = float(rng) if rng else 1.0
        except ValueError:
            raise ValueError(f"--models: {item!r}: the range {rng!r} is not a number in [0, {MAX_RANGE_OVER_D:g}]") from None
        if not (math.isfinite(r) and 0.0 <= r <= MAX_RANGE_OVER_D):
            raise ValueError(f"--models: {item!r}: the range {r!r} is outside the valid range [0, {MAX_RANGE_OVER_D:g}]")
        if (form, r) in out:
            raise ValueError(f"--models: {item!r} is given twice")
        out.append((form, r))
    return tuple(out)

PACKING_CASES = ([dict(name=f"d{int(round(d * 1000))}mm_a{a}", diameter=d, a_over_d=a, n_taps=1)
                  for d in (0.005, 0.010, 0.022) for a in (0.5, 0.75, 1.0, 1.5)]
                 + [dict(name=f"d22mm_a{a}_three_taps", diameter=0.022, a_over_d=a, n_taps=3, tap_period=1.0)
                    for a in (0.75, 1.0)])


def case_setup(case: dict, base: ColumnSetup | None = None, **kw) -> ColumnSetup:
    """The column of a case: t_end covers the flight of a sphere launched at 2.2 aω after the
    last tap, plus 0.15 s of settling (the DEM's top sphere leaves at about 2.05 aω)."""
    base = base or ColumnSetup()
    s = base.with_(kernel_name="packing", diameter=case["diameter"], a_over_d=case["a_over_d"],
                   n_taps=case["n_taps"], tap_period=case.get("tap_period", base.tap_period), **kw)
    last = s.tap_start + (s.n_taps - 1) * s.tap_period + 0.5 / s.frequency
    flight = 2.0 * 2.2 * s.amplitude * s.omega / s.gravity
    t_end = math.ceil((last + flight + 0.15) / s.save_every) * s.save_every
    return s.with_(t_end=round(t_end, 9))


def coarse_grained_density(centres, mass, heights, width):
    """Line density [kg/m] at ``heights`` [m] of point masses ``mass`` [kg] (a number or one per
    point) at ``centres`` [m]:
    Σ_k m φ(y − y_k) with φ a Gaussian of standard deviation ``width`` [m]."""
    z = (np.asarray(heights)[:, None] - np.asarray(centres)[None, :]) / width
    w = np.broadcast_to(np.asarray(mass, dtype=float), np.shape(centres))
    return (np.exp(-0.5 * z * z) @ w) / (width * math.sqrt(2.0 * math.pi))


def _metrics(t, top, centre, setup):
    """Top maximum [d] and its time [s] (from the run's start) after the first tap, its rise
    time (from the tap's start), the top at rest; with several taps also each tap's peak in its
    window [t_k, t_k + period) ("taps"), and the headline values are the first tap's (the peaks
    of later taps are nearly equal, so an overall argmax would jump between them)."""
    d = setup.diameter
    starts = setup.tap_times()
    peaks = []
    for i, t0 in enumerate(starts):
        t1 = starts[i + 1] if i + 1 < len(starts) else np.inf
        window = (t >= t0 - 1e-12) & (t < t1 - 1e-12)
        k = int(np.argmax(np.where(window, top, -np.inf)))
        peaks.append({"top_max_over_d": float(top[k] / d), "t_top_max": float(t[k]), "t_rise": float(t[k] - t0)})
    out = dict(peaks[0]) | {"top_rest_over_d": float(top[0] / d)}
    if len(peaks) > 1:
        out["taps"] = peaks
    return out


def _differences(m, dem_m):
    """Relative differences of the top maximum, its time (from the run's start, as in today's
    compare JSON), its rise time and the rise (top maximum minus the top at rest); with several
    taps, the largest over the taps."""
    pairs = list(zip(m.get("taps", [m]), dem_m.get("taps", [dem_m])))
    def worst(values):
        return max(values, key=abs)
    return {
        "top_max_rel_diff": worst([a["top_max_over_d"] / b["top_max_over_d"] - 1.0 for a, b in pairs]),
        "t_top_max_rel_diff": worst([a["t_top_max"] / b["t_top_max"] - 1.0 for a, b in pairs]),
        "t_rise_rel_diff": worst([a["t_rise"] / b["t_rise"] - 1.0 for a, b in pairs]),
        "rise_rel_diff": worst([(a["top_max_over_d"] - m["top_rest_over_d"])
                                / (b["top_max_over_d"] - dem_m["top_rest_over_d"]) - 1.0 for a, b in pairs]),
    }


def _run_against_dem(name, s, dem, dem_m, dem_wall):
    """Run the packing continuum of setup ``s`` and compare it with the DEM run ``dem``
    (t, positions, floor) whose metrics are ``dem_m``; returns (ColumnRun, JSON entry)."""
    t_d, pos, _ = dem
    d = s.diameter
    w = time.perf_counter()
    run = run_bsr_column(s)
    wall = time.perf_counter() - w
    m = _metrics(run.t, run.top, run.mass_centre, s)
    rms = float(np.sqrt(np.mean(((np.interp(t_d, run.t, run.mass_centre) - pos.mean(axis=1)) / d) ** 2)))
    entry = {
        "name": name, "formulation": s.formulation, "range_over_d": s.interaction_range(),
        "model": model_label(s.formulation, s.interaction_range()), "d": d, "a_over_d": s.a_over_d, "taps": s.n_taps,
        "tap_period": s.tap_period, "t_end": s.t_end, "points_per_diameter": s.points_per_diameter,
        "stiffness_factor": s.stiffness_factor, "calibrated_on": False,
        "bsr": m | {"wall_s": wall, "steps": run.steps,
                    "mass_drift": float(np.max(np.abs(run.mass - run.mass[0])) / run.mass[0]),
                    "min_density": float(run.rho.min())},
        "dem": dem_m | {"wall_s": dem_wall},
        "mass_centre_rms_over_d": rms,
    } | _differences(m, dem_m)
    return run, entry


def _run_task(name, setup, dem, dem_m, dem_wall):
    """One (case, model) run in a worker process: ("ok", run, entry) or, when a monitor stops it,
    ("stopped", message, time, position) (a SimulationError does not survive pickling)."""
    try:
        return ("ok",) + _run_against_dem(name, setup, dem, dem_m, dem_wall)
    except SimulationError as exc:
        return ("stopped", str(exc), exc.time, exc.position)


def _log_entry(log, c, entry, dem_m, dem_wall):
    if log:
        log(f"  {c['name']:22s} {entry['model']:16s}: top {entry['bsr']['top_max_over_d']:.2f} d at "
            f"{entry['bsr']['t_top_max']:.3f} s | DEM {dem_m['top_max_over_d']:.2f} d at "
            f"{dem_m['t_top_max']:.3f} s | dtop {100 * entry['top_max_rel_diff']:+.1f}% rise "
            f"{100 * entry['rise_rel_diff']:+.1f}% | mc RMS {entry['mass_centre_rms_over_d']:.3f} d | "
            f"{entry['bsr']['wall_s']:.1f} s, DEM {dem_wall:.1f} s")


def _partial(models, out_cases, **why) -> dict:
    """The JSON of the runs finished before a stop or an interrupt (``why``: "stopped" or
    "interrupted" and its message), for the caller to keep."""
    return {"fitted_constants": {}, "models": [model_label(*mdl) for mdl in models], "cases": out_cases, **why}


def _stopped(c, form, rng, message, models, out_cases):
    """The SimulationError of a run a monitor stopped: which case and model, and the finished
    cases (``partial``) for the caller to keep."""
    exc = SimulationError(f"case {c['name']}, {model_label(form, rng)}: {message}", None, None, None, "stopped")
    exc.partial = _partial(models, out_cases, stopped=exc.args[0])
    return exc


def _compare_in_workers(cases, base, models, auto_stiffness, workers, log, out_cases, fig_runs):
    """The runs of :func:`compare_packing` on ``workers`` processes (the DEM runs here, each case's
    models there); the same entries in the same order as the serial loop."""
    from ..physics.column import suggest_stiffness_factor
    from .compare import run_dem_column
    from .worker_pool import worker_pool
    prepared = []
    for c in cases:
        s0 = case_setup(c, base)
        w = time.perf_counter()
        dem = run_dem_column(s0.with_(stiffness_factor=1.0))
        if auto_stiffness:
            s0 = s0.with_(stiffness_factor=suggest_stiffness_factor(s0))
        dem_wall = time.perf_counter() - w
        prepared.append((c, s0, dem, _metrics(dem[0], dem[1][:, -1], dem[1].mean(axis=1), s0), dem_wall))
    with worker_pool(workers) as pool:
        pending = [[pool.apply_async(_run_task, (c["name"], s0.with_(formulation=form, range_over_d=rng), dem,
                                                  dem_m, dem_wall)) for form, rng in models]
                   for c, s0, dem, dem_m, dem_wall in prepared]
        for (c, s0, dem, dem_m, dem_wall), futures in zip(prepared, pending):
            runs = {}
            for (form, rng), fut in zip(models, futures):
                got = fut.get()
                if got[0] == "stopped":
                    raise _stopped(c, form, rng, got[1], models, out_cases)
                _, run, entry = got
                runs[entry["model"]] = run
                out_cases.append(entry)
                _log_entry(log, c, entry, dem_m, dem_wall)
            fig_runs[c["name"]] = (s0, runs, dem)


def _compare_serial(cases, base, models, auto_stiffness, log, out_cases, fig_runs):
    """The runs of :func:`compare_packing` one after the other in this process."""
    from ..physics.column import suggest_stiffness_factor
    from .compare import run_dem_column
    for c in cases:
        s0 = case_setup(c, base)
        w = time.perf_counter()
        dem = run_dem_column(s0.with_(stiffness_factor=1.0))       # the DEM at its true stiffness
        if auto_stiffness:
            s0 = s0.with_(stiffness_factor=suggest_stiffness_factor(s0))
        dem_wall = time.perf_counter() - w
        dem_m = _metrics(dem[0], dem[1][:, -1], dem[1].mean(axis=1), s0)
        runs = {}
        for form, rng in models:
            try:
                run, entry = _run_against_dem(c["name"], s0.with_(formulation=form, range_over_d=rng), dem, dem_m,
                                              dem_wall)
            except SimulationError as exc:     # say which run stopped; keep the finished cases for the caller
                exc.args = (f"case {c['name']}, {model_label(form, rng)}: {exc.args[0] if exc.args else exc}",)
                exc.partial = _partial(models, out_cases, stopped=exc.args[0])
                raise
            runs[entry["model"]] = run
            out_cases.append(entry)
            _log_entry(log, c, entry, dem_m, dem_wall)
        fig_runs[c["name"]] = (s0, runs, dem)


def compare_packing(base: ColumnSetup | None = None, cases=None, models=PACKING_MODELS, figures=None, log=print,
                    auto_stiffness=False, workers=1):
    """Run the comparison; returns the JSON-ready dict (module docstring).  ``models``: the
    (formulation, R/d) pairs to run (:data:`PACKING_MODELS`).  ``auto_stiffness``: each case at the
    reduced stiffness of impact Mach number 0.01 (``suggest_stiffness_factor``).  ``workers`` > 1:
    the continuum runs on that many processes (the same numbers, each run being serial and
    deterministic; the wall times then those of a shared machine).  A monitor's stop
    (SimulationError) or an interrupt (KeyboardInterrupt) carries the finished runs as
    ``partial`` (the JSON's form, with "stopped" or "interrupted")."""
    base = base or ColumnSetup()
    cases = PACKING_CASES if cases is None else cases
    t0 = time.perf_counter()
    out_cases, fig_runs = [], {}
    try:
        if workers > 1:
            _compare_in_workers(cases, base, models, auto_stiffness, workers, log, out_cases, fig_runs)
        else:
            _compare_serial(cases, base, models, auto_stiffness, log, out_cases, fig_runs)
    except KeyboardInterrupt as exc:         # Ctrl-C / SIGTERM: the finished runs for the caller to keep
        exc.partial = _partial(models, out_cases, interrupted=" ".join(str(exc).split()) or "interrupted")
        raise
    result = {"d": base.diameter, "scheme": "packing", "kernel": "packing", "calibration": None,
              "fitted_constants": {}, "models": [model_label(*mdl) for mdl in models], "cases": out_cases,
              "setup": base.with_(kernel_name="packing").to_dict(),
              "wall_time_s": time.perf_counter() - t0}
    if figures:
        from .. import plots
        os.makedirs(figures, exist_ok=True)
        for name, (s0, runs, dem) in fig_runs.items():
            plots.packing_case_figures(name, s0, runs, dem, figures)
        result["figures"] = sorted(os.listdir(figures))
    return result


def format_packing_table(result) -> str:
    lines = ["packing continuum against the DEM, nothing fitted (fitted_constants = {})",
             f"{'case':22s} {'model':16s} {'top/d':>7s} {'t [s]':>6s} {'DEM top/d':>9s} {'t [s]':>6s} "
             f"{'dtop':>7s} {'dt':>7s} {'drise':>7s} {'mc RMS/d':>8s}"]
    for c in result["cases"]:
        lines.append(f"{c['name']:22s} {c['model']:16s} {c['bsr']['top_max_over_d']:7.2f} "
                     f"{c['bsr']['t_top_max']:6.3f} {c['dem']['top_max_over_d']:9.2f} {c['dem']['t_top_max']:6.3f} "
                     f"{100 * c['top_max_rel_diff']:6.1f}% {100 * c['t_top_max_rel_diff']:6.1f}% "
                     f"{100 * c['rise_rel_diff']:6.1f}% {c['mass_centre_rms_over_d']:8.3f}")
    return "\n".join(lines)


DEMO_MODELS = (("lagrangian", 1.0), ("eulerian", 1.0))
"""The packing models of ``make demo``: the nonlocal interaction in both formulations."""


def demo_packing(seed_result: dict, base: ColumnSetup, figures=None, models=DEMO_MODELS, log=print) -> dict:
    """``make demo``: the packing continuum (nothing fitted) on the cases of the seed comparison
    ``seed_result`` (:func:`bsrflow.analysis.compare.compare`), with the calibrated seed kernel
    and the DEM on the same figures; returns ``seed_result`` with ``"packing"`` (a list of case
    entries as in :func:`compare_packing`) and ``"packing_fitted_constants": {}`` added. A stop
    or an interrupt carries ``seed_result`` with the finished entries as ``exc.partial``."""
    entries = []
    try:
        _demo_packing_runs(seed_result, base, figures, models, log, entries)
    except (SimulationError, KeyboardInterrupt) as exc:
        exc.partial = seed_result | {"packing": entries, "packing_fitted_constants": {}}
        raise
    seed_result["packing"] = entries
    seed_result["packing_fitted_constants"] = {}
    if figures:
        seed_result["figures_packing"] = sorted(os.listdir(figures))
    return seed_result


def _demo_packing_runs(seed_result, base, figures, models, log, entries):
    from .compare import CASES, run_dem_column
    cal = seed_result["calibration"]
    for c in CASES:
        s0 = base.with_(a_over_d=c["a_over_d"], n_taps=c["n_taps"], t_end=c["t_end"])
        seed_run = run_bsr_column(s0.with_(m0=cal["m0"], kernel_dissipation=cal["kernel_dissipation"]))
        w = time.perf_counter()
        dem = run_dem_column(s0)
        dem_wall = time.perf_counter() - w
        dem_m = _metrics(dem[0], dem[1][:, -1], dem[1].mean(axis=1), s0)
        runs = {}
        for form, rng in models:
            run, entry = _run_against_dem(c["name"], s0.with_(kernel_name="packing", formulation=form,
                                                              range_over_d=rng), dem, dem_m, dem_wall)
            runs[entry["model"]] = run
            entries.append(entry)
            if log:
                log(f"  packing {entry['model']:16s} {c['name']}: top {entry['bsr']['top_max_over_d']:.2f} d at "
                    f"{entry['bsr']['t_top_max']:.3f} s, mc RMS {entry['mass_centre_rms_over_d']:.3f} d, "
                    f"{entry['bsr']['wall_s']:.1f} s")
        if figures:
            from .. import plots
            plots.packing_case_figures(c["name"], s0, runs, dem, figures, seed_run=seed_run)


def format_demo_table(result) -> str:
    """One table: the seed kernel (calibrated) and the packing continuum (nothing fitted)."""
    lines = [f"{'case':18s} {'model':40s} {'top/d':>7s} {'t [s]':>6s} {'DEM top/d':>9s} {'t [s]':>6s} "
             f"{'dtop':>7s} {'dt':>7s} {'mc RMS/d':>8s}"]
    rows = [(c, "seed kernel (m0, eps fitted)") for c in result["cases"]]
    rows += [(c, f"packing {c.get('model', c['formulation'])} (none fitted)") for c in result.get("packing", [])]
    for c, model in sorted(rows, key=lambda r: r[0]["name"]):
        lines.append(f"{c['name']:18s} {model:40s} {c['bsr']['top_max_over_d']:7.2f} {c['bsr']['t_top_max']:6.3f} "
                     f"{c['dem']['top_max_over_d']:9.2f} {c['dem']['t_top_max']:6.3f} "
                     f"{100 * c['top_max_rel_diff']:6.1f}% {100 * c['t_top_max_rel_diff']:6.1f}% "
                     f"{c['mass_centre_rms_over_d']:8.3f}")
    return "\n".join(lines)
