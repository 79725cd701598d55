"""BSR continuum against DEM for the tapped column (seed section 4.4, Figures 4.8-4.17).

``bsrflow compare --json PATH --figures DIR`` (also ``bsrflow demo``):

1. runs the package's DEM for each case (``bsrflow.physics.dem``);
2. calibrates the continuum constants on ONE case (single tap, a/d = 0.75): the kernel's
   characteristic mass m0 and dissipation ε are fitted by least squares to the DEM mass-centre
   and top trajectories over the whole run,
       minimise Σ_i [(z_c^BSR(t_i) - z_c^DEM(t_i))² + (z_top^BSR(t_i) - z_top^DEM(t_i))²] / d²
   over (log m0, ε), a coarse grid search followed by a bounded compass (pattern) search
   (``compass_search``: a fixed poll order and step halving, so its end point depends only on
   the objective's values, not on a library's optimiser); z_top is the top sphere centre (DEM)
   and the tracer started at the top sphere's centre (BSR);
3. freezes them and predicts the other cases (single tap a/d = 1.0, three taps a/d = 0.75);
4. also runs the seed's parameters as printed (m0 = 22 kg, forcing a ω² sin ωt without the
   impulses of the pulse) and reports what they do;
5. writes figures and JSON.

Reported metrics: ``top_max_over_d`` and ``t_top_max`` are the maximum of the top height over
the time after the first tap and its time from the start of the run; ``mass_centre_rms_over_d``
is the RMS difference of the mass-centre heights over the whole run.  Heights from the floor at
rest, in units of d.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import time

import numpy as np

from ..cli import Number, max_workers, workers_range
from ..io.paths import DIR_RULE, FILE_RULE, check_distinct, check_output_dir, check_output_file
from ..numerics.solver import SimulationError
from ..physics.column import ColumnSetup, run_bsr_column

__all__ = ["CASES", "run_dem_column", "compass_search", "calibrate", "compare", "add_parser"]

CASES = [
    dict(name="single_tap_a0.75", a_over_d=0.75, n_taps=1, t_end=1.3, calibrated_on=True),
    dict(name="single_tap_a1.0", a_over_d=1.0, n_taps=1, t_end=1.4, calibrated_on=False),
    dict(name="three_taps_a0.75", a_over_d=0.75, n_taps=3, t_end=2.5, calibrated_on=False),
]


def run_dem_column(setup: ColumnSetup):
    """DEM of the same column and motion; returns (t, positions (nt, N), floor)."""
    from ..physics.dem import DEMColumn, run_dem
    col = DEMColumn(n_spheres=setup.n_spheres, diameter=setup.diameter, density=setup.density,
                    stiffness=setup.stiffness, restitution=setup.restitution, gravity=setup.gravity)
    try:
        res = run_dem(col, setup.motion(), setup.t_end, sample_interval=setup.save_every)
    except RuntimeError as exc:                       # spheres passed through each other: a stop, one line
        raise SimulationError(f"the DEM column (d = {setup.diameter:g} m, a/d = {setup.a_over_d:g}) stopped: {exc}",
                              None, float("nan"), float("nan"), "stopped") from None
    return np.asarray(res.t), np.asarray(res.positions), np.asarray(res.floor)


def _metrics(t, top, centre, setup):
    d = setup.diameter
    after = t >= setup.tap_start - 1e-12
    k = np.argmax(np.where(after, top, -np.inf))
    return {"top_max_over_d": float(top[k] / d), "t_top_max": float(t[k])}


def _on(t_src, y, t_dst):
    return np.interp(t_dst, t_src, y)


def _residuals(setup, dem, m0, eps):
    t_d, pos, _ = dem
    try:
        run = run_bsr_column(setup.with_(m0=float(m0), kernel_dissipation=float(eps)))
    except SimulationError:
        return None
    d = setup.diameter
    rc = (_on(run.t, run.mass_centre, t_d) - pos.mean(axis=1)) / d
    rt = (_on(run.t, run.top, t_d) - pos[:, -1]) / d
    return np.concatenate([rc, rt]) / math.sqrt(t_d.size)


def compass_search(cost, x0, step, lower, upper, min_step, max_evals, f0=None):
    """Minimise ``cost(x)`` by a compass (coordinate pattern) search; returns (x, cost, evals).

    From x, poll x ± h_k e_k for each coordinate k in a fixed order (+ before −, k ascending),
    skipping points outside [lower, upper]; move to the lowest polled point if it is lower than
    x (ties keep the first), otherwise halve every h_k; stop when every h_k < min_step_k, or
    when ``max_evals`` calls of ``cost`` are spent (then only points already known are polled).
    The points lie on the lattice x0 + n_k u_k (n_k integers, u_k the last step polled), each
    computed afresh from its integers, so that a point reached twice (a step back) is the same
    number and is never evaluated twice. ``f0``: the cost of x0 when the caller has it (not
    evaluated again, not counted). The end point depends only on the values ``cost`` returns,
    not on an optimisation library. ``cost`` may return inf (or NaN, taken as inf) for a point
    that failed."""
    x0 = np.asarray(x0, dtype=float)
    step, lower, upper, min_step = (np.asarray(v, dtype=float) for v in (step, lower, upper, min_step))
    if not (np.all(step > 0) and np.all(min_step > 0) and np.all(np.isfinite(step))):
        raise ValueError("compass_search: step and min_step must be finite and > 0")
    if not np.all((lower <= x0) & (x0 <= upper)):
        raise ValueError(f"compass_search: x0 = {x0.tolist()} is outside [lower, upper]")
    if int(max_evals) < 1:
        raise ValueError(f"compass_search: max_evals = {max_evals!r} must be ≥ 1")
    levels = 1                                  # step sizes polled: step / 2^j, j < levels
    while np.any(step / 2.0 ** levels >= min_step):
        levels += 1
    unit = step / 2.0 ** (levels - 1)
    seen = {}
    calls = 0

    def point(n):
        return x0 + np.asarray(n, dtype=float) * unit

    def value(n):
        nonlocal calls
        if n not in seen:
            calls += 1
            v = float(cost(point(n)))
            seen[n] = math.inf if math.isnan(v) else v
        return seen[n]

    n = (0,) * x0.size
    if f0 is not None:
        seen[n] = math.inf if math.isnan(float(f0)) else float(f0)
    fx = value(n)                                     # max_evals ≥ 1: x0 is always known
    for level in range(levels):
        stride = 2 ** (levels - 1 - level)
        while True:
            best = None
            for k in range(x0.size):
                for sign in (1, -1):
                    m = list(n)
                    m[k] += sign * stride
                    m = tuple(m)
                    p = point(m)
                    if p[k] < lower[k] or p[k] > upper[k]:
                        continue
                    if calls >= max_evals and m not in seen:
                        continue                      # the budget is spent: only known points
                    fm = value(m)
                    if fm < fx and (best is None or fm < best[1]):
                        best = (m, fm)
            if best is None:
                break                                 # no lower neighbour at this step: halve it
            n, fx = best
    return point(n), fx, calls


def calibrate(setup: ColumnSetup, dem, log=print, grid_m0=None, grid_eps=(0.1, 0.4, 0.7, 0.9)):
    """Fit (m0, ε) to the DEM trajectories of ``setup`` (see module docstring).

    The grid is 8 values of m0 (geometric) times 4 of ε, up to the search's bound ε = 0.9. It
    covers m0 in [150, 3000] kg: the resting column's hydrostatic height is
    H = sqrt(2 λ R³ M / (3 g)) with λ = K/(m m0), so its mass centre H/3 is 10 d (the DEM's) at
    m0 ≈ 450 kg, 17 d at 150 kg and 4 d at 3000 kg; stiffer kernels are also the costly ones
    (taller domain, smaller steps). The refinement is ``compass_search`` over (ln m0, ε) from
    the grid's best point (its cost passed in, not run again): steps 0.2 in ln m0 and 0.05 in ε,
    halved while at least 0.002 and 0.0005 (the last polled 0.003125 and 0.00078125), within
    ln m0 ∈ [ln 20, ln 1e5] and ε ∈ [0, 0.9], at most 60 runs. A run that stops, or whose cost is
    not finite, counts as infinitely bad; at the grid's point the result is the grid's m0
    itself (not exp(ln m0))."""
    if grid_m0 is None:
        grid_m0 = np.geomspace(150.0, 3000.0, 8)
    best = None
    evals = 0
    for m0 in grid_m0:
        for eps in grid_eps:
            r = _residuals(setup, dem, m0, eps)
            evals += 1
            if r is None:
                continue
            cost = float(r @ r)
            if not math.isfinite(cost):
                continue
            if best is None or cost < best[0]:
                best = (cost, m0, eps)
    if best is None:
        raise SimulationError("calibration failed: every trial run stopped early", None, float("nan"),
                              float("nan"), 0)
    if log:
        log(f"  calibration grid search: best m0 = {best[1]:.4g} kg, eps = {best[2]:.3g}, "
            f"rms = {math.sqrt(best[0] / 2):.3f} d")

    def cost(p):
        r = _residuals(setup, dem, math.exp(p[0]), p[1])
        return math.inf if r is None else float(r @ r)

    x0 = np.array([math.log(best[1]), best[2]])
    x, fx, n = compass_search(cost, x0, step=[0.2, 0.05], lower=[math.log(20.0), 0.0], upper=[math.log(1e5), 0.9],
                              min_step=[0.002, 0.0005], max_evals=60, f0=best[0])
    m0 = float(best[1]) if x[0] == x0[0] else float(math.exp(x[0]))
    eps = float(x[1])
    rms = math.sqrt(fx / 2.0)          # the residual vector holds both trajectories: mean over 2 n_t
    if log:
        log(f"  calibration refined: m0 = {m0:.4g} kg, eps = {eps:.4f}, rms residual = {rms:.3f} d "
            f"({evals + n} BSR runs)")
    return {"m0": m0, "kernel_dissipation": eps, "rms_residual_over_d": rms, "bsr_runs": evals + n,
            "method": "grid search then compass search on mass-centre and top trajectories",
            "case": "single_tap_a0.75"}


def compare(base: ColumnSetup | None = None, scheme="seed", figures=None, log=print, calibration=None,
            include_seed_as_printed=True):
    """Run the comparison; returns the JSON-ready dict. A stop (SimulationError) or an interrupt
    (KeyboardInterrupt, also SIGTERM) carries what was finished as ``exc.partial``: the JSON's form
    with the calibration (``None`` before it ended) and the finished cases."""
    base = base or ColumnSetup(scheme=scheme)
    base = base.with_(scheme=scheme)
    out_cases, state = [], {"calibration": calibration}
    try:
        return _compare(base, scheme, figures, log, include_seed_as_printed, out_cases, state)
    except (SimulationError, KeyboardInterrupt) as exc:
        exc.partial = {"d": base.diameter, "scheme": scheme, "calibration": state["calibration"], "cases": out_cases,
                       "setup": base.to_dict()}
        raise


def _compare(base, scheme, figures, log, include_seed_as_printed, out_cases, state):
    d = base.diameter
    t0 = time.perf_counter()
    setups = {c["name"]: base.with_(a_over_d=c["a_over_d"], n_taps=c["n_taps"], t_end=c["t_end"]) for c in CASES}
    dems = {}
    for c in CASES:
        w = time.perf_counter()
        dems[c["name"]] = run_dem_column(setups[c["name"]])
        if log:
            log(f"  DEM {c['name']}: {time.perf_counter() - w:.1f} s")
    calibration = state["calibration"]
    if calibration is None:
        cal_case = next(c for c in CASES if c["calibrated_on"])
        calibration = state["calibration"] = calibrate(setups[cal_case["name"]], dems[cal_case["name"]], log=log)
    runs = {}
    for c in CASES:
        s = setups[c["name"]].with_(m0=calibration["m0"], kernel_dissipation=calibration["kernel_dissipation"])
        w = time.perf_counter()
        run = run_bsr_column(s)
        wall = time.perf_counter() - w
        t_d, pos, floor = dems[c["name"]]
        runs[c["name"]] = (s, run, dems[c["name"]])
        rms = float(np.sqrt(np.mean(((_on(run.t, run.mass_centre, t_d) - pos.mean(axis=1)) / d) ** 2)))
        out_cases.append({
            "name": c["name"], "a_over_d": c["a_over_d"], "taps": c["n_taps"], "calibrated_on": c["calibrated_on"],
            "bsr": _metrics(run.t, run.top, run.mass_centre, s) | {"wall_s": wall, "steps": run.steps,
                                                                   "mass_drift": float(np.max(np.abs(run.mass - run.mass[0])) / run.mass[0]),
                                                                   "min_density": float(run.rho.min())},
            "dem": _metrics(t_d, pos[:, -1], pos.mean(axis=1), s),
            "mass_centre_rms_over_d": rms,
        })
        cc = out_cases[-1]
        cc["top_max_rel_diff"] = cc["bsr"]["top_max_over_d"] / cc["dem"]["top_max_over_d"] - 1.0
        cc["t_top_max_rel_diff"] = cc["bsr"]["t_top_max"] / cc["dem"]["t_top_max"] - 1.0
        if log:
            log(f"  {c['name']}: BSR top {cc['bsr']['top_max_over_d']:.2f} d at {cc['bsr']['t_top_max']:.3f} s | "
                f"DEM top {cc['dem']['top_max_over_d']:.2f} d at {cc['dem']['t_top_max']:.3f} s | "
                f"mass-centre RMS {rms:.3f} d | BSR {wall:.1f} s")
    result = {"d": d, "scheme": scheme, "calibration": calibration, "cases": out_cases,
              "setup": base.to_dict()}
    if include_seed_as_printed:
        result["seed_as_printed"] = seed_as_printed(base, log=log)
    result["wall_time_s"] = time.perf_counter() - t0
    if figures:
        from .. import plots
        plots.compare_figures(runs, figures)
        result["figures"] = sorted(os.listdir(figures))
    return result


def seed_as_printed(base: ColumnSetup, log=print) -> dict:
    """The seed's constants as printed: m0 = 22 kg and the smooth forcing a ω² sin ωt only."""
    s = base.with_(m0=22.0, impulses=False, a_over_d=0.75, n_taps=1, t_end=1.3)
    try:
        run = run_bsr_column(s)
        info = {"status": "ok", "top_max_over_d": float(run.top.max() / s.diameter)}
    except SimulationError as exc:
        info = {"status": "stopped", "message": str(exc), "time": exc.time}
        r = exc.result
        if r is not None and len(r.t):
            centre = (r.rho * r.x).sum(axis=1) / r.rho.sum(axis=1)
            info["mass_centre_over_d_at_stop"] = float(centre[-1] / s.diameter)
            info["initial_mass_centre_over_d"] = float(centre[0] / s.diameter)
    hyd = math.sqrt(2 * s.kernel().params[0] * s.diameter ** 3 * s.n_spheres * s.particle_mass / (3 * s.gravity))
    info["hydrostatic_height_m"] = hyd
    info["hydrostatic_height_over_d"] = hyd / s.diameter
    info["explanation"] = ("with m0 = 22 kg the kernel is so stiff that the resting column's hydrostatic "
                           "height sqrt(2 lambda R^3 M / (3 g)) is metres: the stacked column expands "
                           "upwards during the settling phase, before any tap, and its dilute top is "
                           "thrown far higher")
    if log:
        log(f"  seed as printed (m0 = 22 kg): {info['status']}; hydrostatic height {hyd:.2f} m "
            f"= {hyd / s.diameter:.0f} d")
    return info


def add_parser(sub):
    for name, helptext in (("compare", "BSR against DEM for the tapped column (calibrate, predict, figures)"),
                           ("demo", "the main job: the tapped-column comparison with figures, on the defaults")):
        p = sub.add_parser(name, help=helptext, description=helptext)
        if name == "demo":
            p.add_argument("--out", default="out", metavar="DIR",
                           help=f"output directory for compare.json and figures/ (default: out; {DIR_RULE})")
        else:
            p.add_argument("--json", metavar="PATH", help=f"write the results as JSON ({FILE_RULE})")
            p.add_argument("--figures", metavar="DIR", help=f"write the figures to DIR ({DIR_RULE})")
        p.add_argument("--scheme", default="seed", help="scheme preset of the seed kernel (default: seed)")
        if name == "compare":
            p.add_argument("--kernel", default="seed", help="seed (the seed's kernel, calibrated on one case; "
                           "default) or packing (the contact law's continuum, nothing fitted, both "
                           "formulations, the cases of bsrflow.analysis.compare_packing)")
            p.add_argument("--models", default=None, metavar="F:R,...",
                           help="packing only: the models to run, FORMULATION[:R_OVER_D] comma-separated, "
                           "R_OVER_D 0 or a whole number of point spacings, the formulation's default when "
                           "absent, 1 (default lagrangian:1,eulerian:1: the nonlocal interaction over one "
                           "diameter in both formulations; eulerian:0,lagrangian:0 is its local limit)")
            p.add_argument("--formulation", default=None, help="packing only: keep only the models of these "
                           "formulations, eulerian, lagrangian or both (comma-separated)")
            p.add_argument("--cases", default=None, help="packing only: comma-separated case names (default all)")
            p.add_argument("--stiffness-factor", default=None,
                           help="packing only: contact stiffness K times this factor in (0, 1] (default 1), "
                           "or 'auto': per case the factor of impact Mach number 0.01 "
                           "(bsrflow.physics.column.suggest_stiffness_factor; documented cost: top maximum "
                           "within 1 %%, mass-centre RMS within 0.15 d of the true stiffness's (lagrangian, "
                           "R = d), 1.5 %%, 0.25 d (lagrangian, local), 1 %%, 1.2 d (eulerian))")
            p.add_argument("--workers", type=Number(int, workers_range), default=None, metavar="N",
                           help="packing only: run the continuum's cases on N processes (default 1; at most 4 per "
                           "CPU); the same numbers, the wall times then those of a shared machine")
        p.add_argument("--diameter", type=Number(float, "[1e-06, 10] m"), default=None,
                       help="sphere diameter d [m] (default 0.022)")
        p.add_argument("--ppd", type=Number(int, "integers in [2, 1000]"), default=None,
                       help="grid points per diameter (default 10)")
        p.set_defaults(func=_main)


def _packing_main(args) -> int:
    from .compare_packing import (PACKING_CASES, PACKING_MODELS, compare_packing, format_packing_table, model_label,
                                  parse_models)
    check_distinct(("--json", args.json), ("--figures", args.figures))
    requested = PACKING_MODELS if args.models is None else parse_models(args.models)
    forms = tuple(("eulerian,lagrangian" if args.formulation is None else args.formulation).split(","))
    bad = [f for f in forms if f not in ("eulerian", "lagrangian")]
    if bad:
        raise ValueError(f"--formulation = {bad[0]!r} is not one of eulerian, lagrangian")
    models = tuple(mdl for mdl in requested if mdl[0] in forms)
    if not models:
        raise ValueError(f"--formulation = {args.formulation!r} leaves none of the models "
                         f"{', '.join(model_label(*mdl) for mdl in requested)}")
    cases = PACKING_CASES
    if args.cases is not None:
        names = args.cases.split(",")
        known = {c["name"] for c in PACKING_CASES}
        for n in names:
            if n not in known:
                raise ValueError(f"--cases: {n!r} is not a case; valid: {', '.join(sorted(known))}")
        cases = [c for c in PACKING_CASES if c["name"] in names]
    kw = {}
    if args.ppd is not None:
        kw["points_per_diameter"] = args.ppd
    auto = args.stiffness_factor == "auto"
    if args.stiffness_factor is not None and not auto:
        try:
            kw["stiffness_factor"] = float(args.stiffness_factor)
        except ValueError:
            raise ValueError(f"--stiffness-factor = {args.stiffness_factor!r} is not a number in (0, 1] or 'auto'") from None
        if not (0.0 < kw["stiffness_factor"] <= 1.0):
            raise ValueError(f"--stiffness-factor = {args.stiffness_factor!r} is outside the valid range (0, 1] "
                             "(or 'auto')")
    if args.diameter is not None:
        raise ValueError("--diameter is not an option of --kernel packing (its cases set d = 5, 10, 22 mm)")
    workers = 1 if args.workers is None else args.workers
    if not 1 <= workers <= max_workers():
        raise ValueError(f"--workers {workers} is outside the valid range {workers_range()}")
    if args.scheme != "seed":
        raise ValueError("--scheme is an option of the seed kernel only (valid with --kernel packing: none)")
    base = _setup_from_options(kernel_name="packing", **kw)
    for form, rng in models:                       # every model checked before the first run
        try:
            base.with_(formulation=form, range_over_d=rng)
        except ValueError as exc:
            raise ValueError(f"--models: {model_label(form, rng)}: {exc}") from None
    if args.json is not None:
        check_output_file(args.json, "--json")
    if args.figures is not None:
        check_output_dir(args.figures, "--figures", create=True)
    print(f"bsrflow compare --kernel packing: {len(cases)} cases, models {', '.join(model_label(*mdl) for mdl in models)}, "
          f"{base.points_per_diameter} points per diameter, stiffness factor "
          f"{'auto (impact Mach number 0.01)' if auto else format(base.stiffness_factor, 'g')}")
    with _keeping_partial(args.json, lambda p: f"the {len(p['cases'])} finished case-model run(s)"):
        result = compare_packing(base, cases=cases, models=models, figures=args.figures, auto_stiffness=auto,
                                 workers=workers, log=_log)
    print(format_packing_table(result))
    if args.json:
        _write_json(args.json, result)
        print(f"wrote {args.json}")
    return 0


_OPTION_OF = {"points_per_diameter": "--ppd", "diameter": "--diameter", "stiffness_factor": "--stiffness-factor"}


@contextlib.contextmanager
def _keeping_partial(json_path, finished):
    """Keep the runs finished before a stop (SimulationError) or an interrupt (Ctrl-C, SIGTERM):
    the exception's ``partial`` (the JSON's form) is written to ``json_path`` with "stopped" or
    "interrupted" and its message; ``finished(partial)`` says in words what it holds."""
    try:
        yield
    except SimulationError as exc:
        partial = getattr(exc, "partial", None)
        if json_path is not None and partial is not None:
            partial.setdefault("stopped", " ".join(str(exc).split()))
            _write_json(json_path, partial)
            print(f"wrote {json_path} (the runs before the stop: {finished(partial)})")
        raise
    except KeyboardInterrupt as exc:
        partial = getattr(exc, "partial", None)
        msg = " ".join(str(exc).split()) or "interrupted by Ctrl-C (SIGINT)"
        if json_path is not None and partial is not None:
            partial["interrupted"] = msg
            _write_json(json_path, partial)
            msg += f"; {json_path} keeps {finished(partial)}"
        exc.args = (msg,)
        raise


def _write_json(path, result) -> None:
    with open(path, "w") as fh:
        json.dump(result, fh, indent=2)


def _seed_finished(partial) -> str:
    """What a partial seed-kernel comparison (or demo) holds, in words."""
    words = ["the calibration" if partial.get("calibration") else "no calibration",
             f"{len(partial['cases'])} seed-kernel case(s)"]
    if "packing" in partial:
        words.append(f"{len(partial['packing'])} packing run(s)")
    return ", ".join(words[:-1]) + " and " + words[-1]


def _setup_from_options(**kw) -> ColumnSetup:
    """ColumnSetup(**kw); its one-line ValueError names the command-line option that set the field."""
    try:
        return ColumnSetup(**kw)
    except ValueError as exc:
        name, sep, rest = str(exc).partition(" = ")
        if sep and name in _OPTION_OF and name in kw:
            raise ValueError(f"{_OPTION_OF[name]} = {rest}") from None
        raise


DEM_MAX_IMPACT_OVERLAP = 0.25
"""The DEM column's spheres, meeting the floor at its largest speed in the cases (a ω with the
largest a/d of :data:`CASES`), may overlap it by at most this fraction of d (a sphere's binary
impact, δ = v √(m/K)); the DEM stops at d/2.  At the default K, ρ and f this allows d ≤ 0.70 m
(d = 0.6 m runs, 2.3 m stopped at its first tap; 2026-12-04)."""


def _check_dem_overlap(s: ColumnSetup, option: str) -> None:
    """Refuse, before any run, a column whose DEM spheres would overlap the floor by more than
    :data:`DEM_MAX_IMPACT_OVERLAP` d at the taps' largest floor speed, naming the diameter range at
    the other settings (the overlap over d grows as d^1.5)."""
    speed = max(c["a_over_d"] for c in CASES) * s.diameter * 2.0 * math.pi * s.frequency
    ratio = speed * math.sqrt(s.particle_mass / s.stiffness) / s.diameter
    if ratio > DEM_MAX_IMPACT_OVERLAP:
        d_max = s.diameter * (DEM_MAX_IMPACT_OVERLAP / ratio) ** (2.0 / 3.0)
        raise ValueError(f"{option}: d = {s.diameter:g} m is outside the valid range [1e-06, {d_max:.3g}] m at these "
                         f"settings: a DEM sphere meeting the floor at the taps' speed ({speed:.3g} m/s) would overlap "
                         f"it by {ratio:.2g} d (at most {DEM_MAX_IMPACT_OVERLAP:g} d at K = {s.stiffness:g} N/m)")


def _log(msg) -> None:
    """Print a progress line of `bsrflow compare` / `demo`, then raise a Ctrl-C or SIGTERM that
    numba swallowed while it compiled (:func:`bsrflow.io.commands._raise_pending`)."""
    from ..io.commands import _raise_pending
    print(msg, flush=True)
    _raise_pending()


def _main(args) -> int:
    """`bsrflow compare` / `demo` (SIGTERM and Ctrl-C: :func:`bsrflow.cli.main`; a signal numba
    swallowed while compiling takes effect at the next progress line, :func:`_log`)."""
    if getattr(args, "kernel", "seed") not in ("seed", "packing"):
        raise ValueError(f"--kernel = {args.kernel!r} is not one of seed, packing")
    if getattr(args, "kernel", "seed") == "packing":
        return _packing_main(args)
    for opt in ("formulation", "models", "cases", "stiffness_factor", "workers"):
        if getattr(args, opt, None) is not None:
            raise ValueError(f"--{opt.replace('_', '-')} is an option of --kernel packing only")
    kw = {}
    if args.diameter is not None:
        kw["diameter"] = args.diameter
    if args.ppd is not None:
        kw["points_per_diameter"] = args.ppd
    base = _setup_from_options(**kw)
    _check_dem_overlap(base, "--diameter" if args.diameter is not None else "the column")
    from ..numerics.solver import Scheme
    try:
        Scheme.preset(args.scheme)                 # an unknown preset is refused before the DEM runs
    except ValueError as exc:
        raise ValueError(f"--scheme {str(exc).removeprefix('scheme = ')}") from None
    if args.command == "demo":
        check_output_dir(args.out, "--out", create=True)
        json_path = check_output_file(os.path.join(args.out, "compare.json"), "--out")
        figures = check_output_dir(os.path.join(args.out, "figures"), "--out", create=True)
        check_output_dir(os.path.join(args.out, "figures_packing"), "--out", create=True)
    else:
        json_path, figures = args.json, args.figures
        check_distinct(("--json", json_path), ("--figures", figures))
        if json_path:
            check_output_file(json_path, "--json")
        if figures:
            check_output_dir(figures, "--figures", create=True)
    print(f"bsrflow {args.command}: tapped column, d = {base.diameter} m, scheme {args.scheme}")
    with _keeping_partial(json_path, _seed_finished):
        result = compare(base, scheme=args.scheme, figures=figures, log=_log)
        print(format_table(result))
        if args.command == "demo":
            from .compare_packing import demo_packing, format_demo_table
            print("the packing continuum on the same cases (nothing fitted): the nonlocal interaction over one "
                  "diameter, lagrangian and eulerian:")
            result = demo_packing(result, base, figures=os.path.join(args.out, "figures_packing"), log=_log)
            print(format_demo_table(result))
    if json_path:
        _write_json(json_path, result)
        print(f"wrote {json_path}")
    if figures:
        print(f"figures in {figures}/" + (f" and {os.path.join(args.out, 'figures_packing')}/"
                                         if args.command == "demo" else ""))
    return 0


def format_table(result) -> str:
    cal = result["calibration"]
    lines = [f"calibrated on single_tap_a0.75: m0 = {cal['m0']:.4g} kg, kernel eps = {cal['kernel_dissipation']:.4f}",
             f"{'case':18s} {'cal':4s} {'BSR top/d':>9s} {'t [s]':>6s} {'DEM top/d':>9s} {'t [s]':>6s} "
             f"{'dtop':>7s} {'dt':>7s} {'mc RMS/d':>8s}"]
    for c in result["cases"]:
        lines.append(f"{c['name']:18s} {'yes' if c['calibrated_on'] else 'no':4s} {c['bsr']['top_max_over_d']:9.2f} "
                     f"{c['bsr']['t_top_max']:6.3f} {c['dem']['top_max_over_d']:9.2f} {c['dem']['t_top_max']:6.3f} "
                     f"{100 * c['top_max_rel_diff']:6.1f}% {100 * c['t_top_max_rel_diff']:6.1f}% "
                     f"{c['mass_centre_rms_over_d']:8.3f}")
    return "\n".join(lines)
