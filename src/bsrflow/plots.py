"""Matplotlib figures (non-interactive backend): tapped-column comparisons like the seed's
Figures 4.8-4.17.  Every axis is labelled with its quantity and unit."""

from __future__ import annotations

import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

SNAPSHOT_TIMES = (0.4, 0.5, 0.55, 0.6, 0.65, 0.7, 0.75, 0.8)   # the seed's Figure 4.8


def density_snapshots(run, path, times=SNAPSHOT_TIMES, title=""):
    """Normalised density ρ d/m against height/d at several times (Figure 4.8/4.9)."""
    s = run.setup
    d, line = s.diameter, s.particle_mass / s.diameter
    fig, axes = plt.subplots(2, 4, figsize=(13, 6), sharex=True, sharey=True)
    occupied = (run.x[None, :] + run.floor[:, None])[run.rho > 1e-3 * line]
    top = (occupied.max() if occupied.size else run.x[-1]) / d
    for ax, tt in zip(axes.ravel(), times):
        ax.set_xlim(0.0, 1.15 * top)
        k = int(np.argmin(np.abs(run.t - tt)))
        ax.plot((run.x + run.floor[k]) / d, run.rho[k] / line, color="C0")
        ax.set_title(f"t = {run.t[k]:.2f} s")
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("height above the floor at rest, y/d")
    for ax in axes[:, 0]:
        ax.set_ylabel("normalised density ρ d / m")
    fig.suptitle(title or "BSR density snapshots")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def trajectories_side_by_side(run, dem, path, title=""):
    """BSR tracer trajectories (left) and DEM sphere trajectories with the mass centre (right),
    Figures 4.10/4.11 (:func:`trajectories_figure`)."""
    fig = trajectories_figure(run, dem, title)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def _legend_below(ax, ncol=2):
    """A legend under the axes (outside them, so that it hides no data; the peaks of repeated
    taps reach every corner of the axes)."""
    return ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=ncol, frameon=False)


def trajectories_figure(run, dem, title=""):
    """The figure of :func:`trajectories_side_by_side`, returned open."""
    s = run.setup
    d = s.diameter
    t_d, pos, floor = dem
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(13, 5), sharey=True)
    a1.plot(run.t, run.tracers / d, color="C0", lw=0.8)
    a1.plot(run.t, run.mass_centre / d, color="k", lw=2, label="mass centre")
    a1.plot(run.t, run.floor / d, color="C3", lw=1, label="floor")
    a1.set_title("BSR continuum: tracers from the sphere centres")
    a2.plot(t_d, pos / d, color="C1", lw=0.8)
    a2.plot(t_d, pos.mean(axis=1) / d, color="k", lw=2, label="mass centre")
    a2.plot(t_d, floor / d, color="C3", lw=1, label="floor")
    a2.set_title("DEM: sphere centres")
    for ax in (a1, a2):
        ax.set_xlabel("time t [s]")
        ax.grid(alpha=0.3)
        _legend_below(ax)
        for tt in s.tap_times():
            ax.axvline(tt, color="grey", ls=":", lw=1)
    a1.set_ylabel("height above the floor at rest, y/d")
    fig.suptitle(title)
    fig.tight_layout()
    return fig


def top_and_centre_figure(run, dem, title=""):
    """The figure of :func:`top_and_centre` (returned open, for inspection).  The DEM top is
    the highest sphere centre at each time, ``pos.max(axis=1)``, the quantity of the metrics
    (``top_max_over_d``) of ``bsrflow compare`` and ``compare-dump``: for the package's 1-D DEM
    that is the last sphere, for a dump whatever the order of its atom ids."""
    d = run.setup.diameter
    t_d, pos, _ = dem
    fig, ax = plt.subplots(figsize=(8, 5.6))
    ax.plot(run.t, run.top / d, "C0", label="BSR top (tracer from top sphere centre)")
    ax.plot(t_d, pos.max(axis=1) / d, "C1", label="DEM top (highest sphere centre)")
    ax.plot(run.t, run.mass_centre / d, "C0--", label="BSR mass centre")
    ax.plot(t_d, pos.mean(axis=1) / d, "C1--", label="DEM mass centre")
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("height above the floor at rest, y/d")
    ax.grid(alpha=0.3)
    _legend_below(ax)
    ax.set_title(title)
    fig.tight_layout()
    return fig


def top_and_centre(run, dem, path, title=""):
    """Top and mass-centre heights, BSR against DEM (:func:`top_and_centre_figure`)."""
    fig = top_and_centre_figure(run, dem, title)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def compare_figures(runs: dict, outdir: str):
    """All comparison figures for the cases in ``runs`` = {name: (setup, ColumnRun, dem)}."""
    os.makedirs(outdir, exist_ok=True)
    for name, (s, run, dem) in runs.items():
        label = f"{name}: a/d = {s.a_over_d}, f = {s.frequency} Hz, {s.n_taps} tap(s), d = {s.diameter} m"
        if s.n_taps == 1:
            times = SNAPSHOT_TIMES if s.a_over_d < 0.9 else (0.4, 0.5, 0.55, 0.6, 0.7, 0.8, 0.9, 1.05)
            density_snapshots(run, os.path.join(outdir, f"{name}_density.png"), times, label)
        trajectories_side_by_side(run, dem, os.path.join(outdir, f"{name}_trajectories.png"), label)
        top_and_centre(run, dem, os.path.join(outdir, f"{name}_top_centre.png"), label)


_MODEL_COLOURS = {"lagrangian R=1d": "C2", "eulerian local": "C0", "lagrangian local": "C9", "seed": "C4"}


def _model_colour(model: str, k: int) -> str:
    return _MODEL_COLOURS.get(model, f"C{(5 + k) % 10}")


def packing_case_figures(name, setup, runs: dict, dem, outdir: str, seed_run=None):
    """Figures of one case of the packing comparison (:mod:`bsrflow.analysis.compare_packing`):
    ``runs`` = {model label (:func:`~bsrflow.analysis.compare_packing.model_label`): ColumnRun};
    ``seed_run``: the calibrated seed-kernel run of the same case, drawn on the same axes when given
    (``make demo``)."""
    from .analysis.compare_packing import coarse_grained_density
    os.makedirs(outdir, exist_ok=True)
    s = setup
    d, m = s.diameter, s.particle_mass
    line = m / d
    t_d, pos, floor = dem
    label = (f"{name}: d = {1000 * d:g} mm, a/d = {s.a_over_d}, f = {s.frequency:g} Hz, {s.n_taps} tap(s); "
             "packing continuum not calibrated")
    models = dict(runs)
    if seed_run is not None:
        models["seed"] = seed_run
    names = {k: ("seed kernel (m0, ε calibrated)" if k == "seed" else f"packing, {k}") for k in models}
    colours = {k: _model_colour(k, i) for i, k in enumerate(models)}
    # trajectories side by side
    fig, axes = plt.subplots(1, len(models) + 1, figsize=(4.6 * (len(models) + 1), 4.8), sharey=True)
    for ax, (form, run) in zip(axes, models.items()):
        ax.plot(run.t, run.tracers / d, color=colours[form], lw=0.7)
        ax.plot(run.t, run.mass_centre / d, color="k", lw=2, label="mass centre")
        ax.set_title(f"{names[form]}: tracers at sphere centres", fontsize=9)
    axes[-1].plot(t_d, pos / d, color="C1", lw=0.7)
    axes[-1].plot(t_d, pos.mean(axis=1) / d, color="k", lw=2, label="mass centre")
    axes[-1].set_title("DEM: sphere centres", fontsize=9)
    for ax in axes:
        ax.plot(t_d, floor / d, color="C3", lw=1, label="floor")
        ax.set_xlabel("time t [s]")
        ax.grid(alpha=0.3)
        ax.legend(loc="upper left", fontsize=8)
    axes[0].set_ylabel("height above the floor at rest, y/d")
    fig.suptitle(label, fontsize=10)
    fig.tight_layout()
    fig.savefig(os.path.join(outdir, f"{name}_trajectories.png"), dpi=100)
    plt.close(fig)
    # top and mass centre
    fig, ax = plt.subplots(figsize=(9, 5))
    for form, run in models.items():
        c = colours[form]
        ax.plot(run.t, run.top / d, color=c, lw=1.2, label=f"{names[form]}: top sphere centre")
        ax.plot(run.t, run.mass_centre / d, color=c, lw=1.2, ls="--", label=f"{names[form]}: mass centre")
    ax.plot(t_d, pos[:, -1] / d, color="C1", lw=2, alpha=0.7, label="DEM: top sphere centre")
    ax.plot(t_d, pos.mean(axis=1) / d, color="C1", lw=2, ls="--", alpha=0.7, label="DEM: mass centre")
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("height above the floor at rest, y/d")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    ax.set_title(label, fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(outdir, f"{name}_top_centre.png"), dpi=100)
    plt.close(fig)
    # density snapshots beside the DEM's coarse-grained density
    k_peak = int(np.argmax(np.where(t_d >= s.tap_start, pos[:, -1], -np.inf)))
    t_hi = min(t_d[-1], s.tap_start + 2.0 * (t_d[k_peak] - s.tap_start) + 0.05)
    times = np.linspace(s.tap_start, t_hi, 8)
    top = float(pos[:, -1].max() + d)
    y = np.linspace(0.0, 1.1 * top, 600)
    xmax = 1.1 * top / d
    width = 0.5 * d
    fig, axes = plt.subplots(2, 4, figsize=(14, 6.4), sharex=True, sharey=True)
    for ax, tt in zip(axes.ravel(), times):
        k = int(np.argmin(np.abs(t_d - tt)))
        ax.plot(y / d, coarse_grained_density(pos[k], m, y, width) / line, color="C1", lw=2, alpha=0.8,
                label="DEM, coarse-grained")
        for form, run in models.items():
            j = int(np.argmin(np.abs(run.t - tt)))
            ylab = run.x + run.floor[j]
            c = colours[form]
            ax.plot(ylab / d, run.rho[j] / line, color=c, lw=0.8, alpha=0.6, label=f"{names[form]}")
            cg = coarse_grained_density(ylab, run.rho[j] * (run.x[1] - run.x[0]), y, width)
            ax.plot(y / d, cg / line, color=c, lw=1.2, ls="--", label=f"{names[form]}, coarse-grained")
        ax.set_title(f"t = {t_d[k]:.3f} s", fontsize=9)
        ax.set_xlim(0.0, xmax)
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("height above the floor at rest, y/d")
    for ax in axes[:, 0]:
        ax.set_ylabel("normalised density ρ d / m")
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=8)
    fig.suptitle(label + f"; coarse-graining: Gaussian, standard deviation d/2", fontsize=9)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    fig.savefig(os.path.join(outdir, f"{name}_density.png"), dpi=100)
    plt.close(fig)
