"""Kinetic energy with and without the moving average (seed Figures 5.5, 5.6) and the local wave
speed along tracer trajectories (Appendix A, Figures A.1, A.2) for the tapped column.

``bsrflow energy --json PATH --figures DIR``:

* runs the seed preset on the single tap a/d = 1.0 (the case of Figures A.1/A.2) with the
  moving average after every step and without it; the kinetic energy Σ ½ ρ u² Δx [J] (floor
  frame) of each run is normed by its own maximum; a run that stops early reports when and why;
  snapshots with negative densities, where that sum is no energy and can be negative, are
  reported (``t_first_negative_density_s``, ``min_density_over_line``) and shaded in the figure;
* along the tracers started at the top sphere and at the middle sphere, computes the local
  wave speed c² = -dΦ/d log ρ (Appendix A with the sign of (A.3) corrected, see
  :mod:`bsrflow.analysis.wavespeed`) from the interaction acceleration of the saved fields, for
  0.4 s <= t <= 0.9 s.

The continuum constants are m0 = 410 kg, ε = 0.83 (:data:`DEFAULT_CALIBRATION`, printed by
the command), or those of a ``bsrflow compare`` JSON given with ``--calibration``.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import replace

import numpy as np

from ..io.paths import DIR_RULE, FILE_RULE, check_distinct, check_output_dir, check_output_file
from ..numerics.solver import Scheme, Simulation, SimulationError
from ..physics.column import ColumnSetup, column_run_from_result, initial_density
from ..physics.model import BSRModel
from .wavespeed import local_wave_speed

__all__ = ["energy_study", "add_parser"]

DEFAULT_CALIBRATION = {"m0": 410.0, "kernel_dissipation": 0.83}
"""The fixed (m0 [kg], ε) of `bsrflow energy` without --calibration; not re-fitted (`bsrflow
compare` calibrates its own values, docs/seed-kernel.md)."""


def _run(setup, scheme):
    grid = setup.grid()
    sim = setup.simulation(scheme)
    try:
        res = sim.run(np.zeros(grid.n_cells), initial_density(setup, grid.x), setup.t_end,
                      save_every=setup.save_every, tracers=setup.sphere_centres())
        return grid, res, None
    except SimulationError as exc:
        return grid, exc.result, exc


def _interaction(setup, grid, u, rho):
    """Interaction acceleration ∫ρΘ dz [m/s²] on the grid (no gravity, no inertial terms)."""
    sim = Simulation(BSRModel(kernel=setup.kernel()), grid, Scheme(filter=False))
    du, _ = sim.rhs(u, rho, 0.0)
    G = np.concatenate([[-u[0]], u, [u[-1]]])
    return du + u * (G[2:] - G[:-2]) / (2 * grid.dx)


def energy_study(calibration=None, figures=None, log=print) -> dict:
    cal = calibration or DEFAULT_CALIBRATION
    if log:
        log(f"  m0 = {cal['m0']:g} kg, eps = {cal['kernel_dissipation']:g} "
            + ("(from the calibration given)" if calibration else "(the defaults; --calibration COMPARE_JSON to use a "
               "`bsrflow compare` calibration)"))
    setup = ColumnSetup(a_over_d=1.0, t_end=1.4, save_every=0.0025, m0=cal["m0"],
                        kernel_dissipation=cal["kernel_dissipation"])
    out = {"setup": setup.to_dict(), "runs": {}}
    runs = {}
    for label, filt in (("moving_average", True), ("no_moving_average", False)):
        grid, res, exc = _run(setup, Scheme.preset("seed", filter=filt))
        ke = res.kinetic_energy(grid.dx)
        runs[label] = (grid, res)
        neg = negative_density_snapshots(setup, res)
        info = {"t": res.t.tolist(), "kinetic_normed": (ke / ke.max()).tolist(), "kinetic_max_J": float(ke.max()),
                "completed": exc is None,
                "min_density_over_line": float(res.rho.min() / (setup.particle_mass / setup.diameter)),
                "t_first_negative_density_s": float(res.t[np.argmax(neg)]) if neg.any() else None}
        if exc is not None:
            info["stopped_at_s"] = exc.time
            info["message"] = str(exc)
        out["runs"][label] = info
        if log:
            log(f"  {label}: " + ("completed" if exc is None else f"stopped at t = {exc.time:.4f} s: {exc}")
                + ("" if info["t_first_negative_density_s"] is None else
                   f"; negative densities from t = {info['t_first_negative_density_s']:.4g} s on "
                   f"(min {info['min_density_over_line']:.3g} m/d)"))
    # local wave speed along the top and middle tracers of the filtered run
    grid, res = runs["moving_average"]
    line = setup.particle_mass / setup.diameter
    track = {"top": setup.n_spheres - 1, "middle": setup.n_spheres // 2 - 1}
    speeds = {k: [] for k in track}
    times = []
    for k, t in enumerate(res.t):
        if not (0.4 - 1e-9 <= t <= 0.9 + 1e-9) or k % 4:
            continue
        rho, u = res.rho[k], res.u[k]
        mat = rho > 1e-2 * line
        idx = np.flatnonzero(mat)
        if idx.size < 8:
            continue
        sl = slice(idx[0], idx[-1] + 1)
        if np.any(rho[sl] <= 0):
            continue
        F = _interaction(setup, grid, u, rho)
        lw = local_wave_speed(grid.x[sl], rho[sl], F[sl], half_width=2)
        ok = lw.valid & np.isfinite(lw.c)
        if ok.sum() < 2:
            continue
        times.append(float(t))
        for name, j in track.items():
            # the value at the valid point nearest to the tracer
            xs = grid.x[sl][ok]
            speeds[name].append(float(lw.c[ok][np.argmin(np.abs(xs - res.tracers[k, j]))]))
    out["wave_speed"] = {"t": times, "top_tracer_m_s": speeds["top"], "middle_tracer_m_s": speeds["middle"],
                         "long_wave_speed_at_stacked_density_m_s": setup.sound_speed()}
    if figures:
        _figures(out, runs, setup, figures)
    return out


NEGATIVE_DENSITY = 1e-9
"""A snapshot has negative densities when min ρ < -NEGATIVE_DENSITY m/d (far above round-off,
about 1e-15 m/d): then Σ ½ ρ u² Δx is no longer an energy (it can be negative)."""


def negative_density_snapshots(setup, res) -> np.ndarray:
    """(nt,) bool: the saved snapshots with min ρ < -NEGATIVE_DENSITY m/d."""
    line = setup.particle_mass / setup.diameter
    return res.rho.min(axis=1) < -NEGATIVE_DENSITY * line


def kinetic_energy_figure(out, runs, setup):
    """The kinetic-energy figure (seed Figures 5.5/5.6), returned open: Σ ½ ρ u² Δx [J] of the
    column (floor frame) of each run, normed by its own maximum.  Snapshots with negative
    densities (:func:`negative_density_snapshots`) are shaded and said so in the legend and
    the title: there the normed 'energy' can go below zero, which a kinetic energy cannot."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8), sharey=True)
    for ax, (label, title) in zip(axes, (("moving_average", "with the moving average (Fig. 5.5)"),
                                         ("no_moving_average", "without the moving average (Fig. 5.6)"))):
        r = out["runs"][label]
        t = np.asarray(r["t"])
        ax.plot(t, r["kinetic_normed"], color="C0", label=f"Σ ½ρu²Δx / {r['kinetic_max_J']:.3g} J")
        neg = negative_density_snapshots(setup, runs[label][1])
        if neg.any():
            first = float(t[np.argmax(neg)])
            dt = np.diff(t).min() if t.size > 1 else 0.0
            for k in np.flatnonzero(neg):
                ax.axvspan(t[k] - 0.5 * dt, t[k] + 0.5 * dt, color="C3", alpha=0.15, lw=0,
                           label="ρ < 0 somewhere: not an energy" if k == np.argmax(neg) else None)
            title += f"\nρ < 0 from t = {first:.3f} s (min {r['min_density_over_line']:.2g} m/d)"
        k_low = int(np.argmin(r["kinetic_normed"]))
        if r["kinetic_normed"][k_low] < 0:
            ax.annotate(f"{r['kinetic_normed'][k_low]:.3g} at t = {t[k_low]:.3f} s:\nbelow 0 because ρ < 0",
                        xy=(t[k_low], r["kinetic_normed"][k_low]), xytext=(0.45, 0.35), textcoords="axes fraction",
                        arrowprops=dict(arrowstyle="->", color="C3"), color="C3")
        if not r["completed"]:
            ax.axvline(r["stopped_at_s"], color="C3", ls="--", label=f"stopped at {r['stopped_at_s']:.3f} s")
        ax.legend(loc="lower left")
        ax.set_xlabel("time t [s]")
        ax.set_title(title)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("kinetic energy of the column / its maximum [1]")
    fig.tight_layout()
    return fig


def _figures(out, runs, setup, outdir):
    import matplotlib.pyplot as plt
    os.makedirs(outdir, exist_ok=True)
    fig = kinetic_energy_figure(out, runs, setup)
    fig.savefig(os.path.join(outdir, "kinetic_energy.png"), dpi=110)
    plt.close(fig)
    grid, res = runs["moving_average"]
    w = out["wave_speed"]
    fig, axes = plt.subplots(2, 2, figsize=(12, 7), sharex=True)
    for col, (name, j) in enumerate((("top", setup.n_spheres - 1), ("middle", setup.n_spheres // 2 - 1))):
        axes[0, col].plot(res.t, (res.tracers[:, j] + res.floor) / setup.diameter)
        axes[0, col].set_ylabel("tracer height y/d")
        axes[0, col].set_title(f"{name} tracer (Fig. A.{col + 1})")
        axes[1, col].plot(w["t"], w[f"{name}_tracer_m_s"], "o-", ms=3)
        axes[1, col].set_ylabel("local wave speed c [m/s]")
        axes[1, col].set_xlabel("time t [s]")
        for ax in axes[:, col]:
            ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(outdir, "local_wave_speed.png"), dpi=110)
    plt.close(fig)


def read_calibration(path) -> dict:
    """m0 [kg] and kernel_dissipation of a ``bsrflow compare --json`` file (its "calibration"
    object).  ValueError, one line naming the file and what is wrong (unreadable, not JSON, a
    missing key, a value out of range)."""
    path = os.fspath(path)
    where = f"--calibration {path}"
    try:
        with open(path, encoding="utf-8") as fh:
            data = json.load(fh)
    except FileNotFoundError:
        raise ValueError(f"{where}: no such file") from None
    except IsADirectoryError:
        raise ValueError(f"{where}: is a directory, not a JSON file") from None
    except OSError as exc:
        raise ValueError(f"{where}: cannot be read ({exc.strerror or type(exc).__name__})") from None
    except UnicodeDecodeError:
        raise ValueError(f"{where}: not a JSON text file (not UTF-8)") from None
    except json.JSONDecodeError as exc:
        raise ValueError(f"{where}: not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})") from None
    expect = "expected the JSON written by `bsrflow compare --json`"
    if not isinstance(data, dict) or "calibration" not in data:
        raise ValueError(f"{where}: no key 'calibration' at the top level ({expect})")
    cal = data["calibration"]
    if not isinstance(cal, dict):
        raise ValueError(f"{where}: 'calibration' is not an object with m0 and kernel_dissipation ({expect})")
    for key in ("m0", "kernel_dissipation"):
        if key not in cal:
            raise ValueError(f"{where}: no key 'calibration.{key}' ({expect})")
    checks = (("m0", lambda v: 0.0 < v <= 1e12, "(0, 1e+12] kg"),
              ("kernel_dissipation", lambda v: 0.0 <= v < 1.0, "[0, 1)"))
    out = {}
    for key, ok, rng in checks:
        v = cal[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not ok(v):
            raise ValueError(f"{where}: calibration.{key} = {v!r} is outside the valid range {rng}")
        out[key] = float(v)
    return out


def add_parser(sub):
    p = sub.add_parser("energy", help="kinetic energy with/without the moving average; local wave speed",
                       description=__doc__.split("\n\n")[0])
    p.add_argument("--json", metavar="PATH", help=f"write results as JSON ({FILE_RULE})")
    p.add_argument("--figures", metavar="DIR", help=f"write figures to DIR ({DIR_RULE})")
    p.add_argument("--calibration", metavar="COMPARE_JSON", help="take m0 and eps from the JSON of `bsrflow compare --json` (its \"calibration\" object)")
    p.set_defaults(func=_main)


def _main(args) -> int:
    check_distinct(("--calibration", args.calibration), ("--json", args.json), ("--figures", args.figures))
    if args.json is not None:
        check_output_file(args.json, "--json")
    if args.figures is not None:
        check_output_dir(args.figures, "--figures")
    cal = read_calibration(args.calibration) if args.calibration else None
    out = energy_study(cal, args.figures)
    for label, r in out["runs"].items():
        print(f"{label:18s} " + ("completed to 1.4 s" if r["completed"] else f"broke down at t = {r['stopped_at_s']:.4f} s"))
    w = out["wave_speed"]
    if w["t"]:
        print(f"local wave speed, top tracer: {np.nanmin(w['top_tracer_m_s']):.3g}..{np.nanmax(w['top_tracer_m_s']):.3g} m/s; "
              f"middle tracer: {np.nanmin(w['middle_tracer_m_s']):.3g}..{np.nanmax(w['middle_tracer_m_s']):.3g} m/s "
              f"(long-wave speed at the stacked density {w['long_wave_speed_at_stacked_density_m_s']:.3g} m/s)")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=1)
        print(f"wrote {args.json}")
    return 0
