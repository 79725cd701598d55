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
