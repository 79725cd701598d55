"""``bsrflow plot FILE.nc [--out DIR]``: the standard figures of a column run (or of a 2-D /
3-D layer run) from its netCDF output.

Expected schema (the package's output files): dimensions ``time``, ``x``, ``tracer``;
coordinates ``time`` [s] and ``x`` [m] (cell centres, floor frame); variables ``rho(time, x)``
[kg m-1], ``u(time, x)`` [m s-1] (floor frame), ``tracer_height(time, tracer)`` [m] (lab frame),
``floor(time)``, ``top(time)``, ``mass_centre(time)`` [m] (lab frame), ``mass(time)`` [kg],
``kinetic_energy(time)`` [J]; attributes ``diameter`` [m], ``config``, ``bsrflow_version``.

Figures (PNG, written to DIR, default the file's directory, named ``<stem>_<figure>.png``):

* ``density``: space-time map of ρ, lab-frame height x + floor(t) on the vertical axis;
  a single snapshot gives the profile ρ against height instead;
* ``tracers``: tracer trajectories with the floor and the mass centre;
* ``top_centre``: top and mass-centre heights against time;
* ``kinetic_energy``: kinetic energy against time.

A layer file (``rho(time, x, [y,] z)``, ``tracer_z``; :mod:`bsrflow.io.layer_runner`) gives the
same figures with the density averaged over the horizontal axes (its fields in 3-D are for
ParaView, from the VTK files).

Heights are in units of d when the file has a ``diameter`` attribute, else in metres.  A file
still being written (or cut short) is read as far as it goes: snapshots whose time is missing
(netCDF fill value or NaN) are dropped, missing values inside variables are left as gaps, and a
figure whose variables are absent is skipped with a note on stderr.  A warning line on stderr,
and a second line of every figure's title, say when the file's ``status`` attribute is not
"ok" (``running``: the run was killed or is
still going) and when ρ is NaN everywhere; the figures are drawn all the same.  Labels use the variables'
``long_name``/``units`` attributes when present.
"""

from __future__ import annotations

import os
import sys

import numpy as np

from ..io.paths import DIR_RULE, check_output_dir

__all__ = ["plot_file", "add_parser", "load_output", "vertical_density"]

_NC_FILL = 9.0e36          # netCDF default fill values are 9.97e36 (float and double)


def _clean(a) -> np.ndarray:
    """float array with netCDF fill values (and anything beyond ±9e36) as NaN."""
    a = np.array(a, dtype=float)
    a[~np.isfinite(a) | (np.abs(a) >= _NC_FILL)] = np.nan
    return a


def _edges(c) -> np.ndarray:
    """Cell edges (n+1,) around increasing centres c (n >= 2): midpoints, ends extrapolated."""
    mid = 0.5 * (c[1:] + c[:-1])
    return np.concatenate([[c[0] - (mid[0] - c[0])], mid, [c[-1] + (c[-1] - mid[-1])]])


def load_output(path):
    """Open an output netCDF file and return (dataset loaded in memory, index array of the
    usable snapshots: those with a finite, increasing time).  ValueError if the file cannot be
    read or has no usable snapshot."""
    import xarray as xr

    os.environ.setdefault("HDF5_USE_FILE_LOCKING", "FALSE")    # a file still open for writing
    path = os.fspath(path)
    if not os.path.exists(path):
        raise FileNotFoundError(f"{path}: no such file")
    try:
        with xr.open_dataset(path, decode_times=False, mask_and_scale=True) as ds:
            ds = ds.load()
    except Exception as exc:  # noqa: BLE001 - any reader error becomes one clear line
        first = str(exc).splitlines()[0] if str(exc) else ""
        if "did not find a match in any of xarray's currently installed IO backends" in first:
            first = "not a netCDF file (no installed reader recognises its format)"  # xarray's hint is cut
        raise ValueError(f"{path}: cannot be read as netCDF ({type(exc).__name__}: {first})") from None
    if "time" not in ds.variables:
        raise ValueError(f"{path}: no 'time' variable (not a bsrflow output file?)")
    t = _clean(ds["time"].values).reshape(-1)
    keep = []
    last = -np.inf
    for i, v in enumerate(t):
        if np.isfinite(v) and v > last:
            keep.append(i)
            last = v
        elif np.isfinite(v):
            break                       # time going backwards: the rest is not trustworthy
    if not keep:
        raise ValueError(f"{path}: no snapshot with a valid time (empty or not yet written)")
    return ds, np.array(keep)


def _label(ds, name, default_long, default_units, scale_units=None):
    v = ds[name] if name in ds.variables else None
    long_name = (v.attrs.get("long_name") if v is not None else None) or default_long
    units = scale_units or ((v.attrs.get("units") if v is not None else None) or default_units)
    return f"{long_name} [{units}]" if units else long_name


def vertical_density(ds, rho):
    """(name of the vertical coordinate, ρ on (time, vertical), whether it is an average): a
    column's ρ(time, x) (or ρ(time, z)) as it is; a layer's ρ(time, x, [y,] z) averaged over the
    horizontal axes (NaN values left out; a column of NaN stays NaN).  ``rho`` is the
    variable's values (snapshots selected, fill values as NaN) or None."""
    if rho is None or "rho" not in ds.variables or ds["rho"].ndim < 2:
        return "x", rho, False
    if rho.ndim <= 2:
        return ds["rho"].dims[-1], rho, False
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return ds["rho"].dims[-1], np.nanmean(rho, axis=tuple(range(1, rho.ndim - 1))), True


def plot_file(path, out: str | None = None, log=print) -> list[str]:
    """Draw the standard figures of the output file ``path`` into ``out`` (default: the file's
    directory).  Returns the paths of the PNG files written."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ds, keep = load_output(path)
    out = out if out is not None else (os.path.dirname(os.path.abspath(path)))
    os.makedirs(out, exist_ok=True)
    stem = os.path.splitext(os.path.basename(path))[0]
    t = _clean(ds["time"].values)[keep]
    d = ds.attrs.get("diameter")
    try:
        d = float(d) if d is not None else None
    except (TypeError, ValueError):
        d = None
    if d is not None and not (np.isfinite(d) and d > 0):
        d = None
    hscale = d if d else 1.0
    hlabel = "height above the floor at rest, y/d" if d else "height above the floor at rest, y [m]"
    title = f"{os.path.basename(path)}" + (f" (bsrflow {ds.attrs['bsrflow_version']})"
                                           if "bsrflow_version" in ds.attrs else "")
    written = []

    def series(name):
        if name not in ds.variables:
            return None
        a = _clean(ds[name].values)
        if a.ndim == 0 or a.shape[0] < keep[-1] + 1:
            return None
        return a[keep]

    def note(msg):
        print(f"bsrflow plot: {msg}", file=sys.stderr)

    def save(fig, kind):
        p = os.path.join(out, f"{stem}_{kind}.png")
        fig.savefig(p, dpi=110)
        plt.close(fig)
        written.append(p)
        if log:
            log(p)

    status = ds.attrs.get("status")
    if isinstance(status, bytes):
        status = status.decode(errors="replace")
    upto = f"the figures show the {t.size} snapshot(s) up to t = {t[-1]:.6g} s"
    if status == "running":
        note(f"warning: {path}: status \"running\": the run was killed (or is still going); {upto}")
    elif status is not None and status != "ok":
        note(f"warning: {path}: the run did not finish (status: {' '.join(str(status).split())}); {upto}")
    if status is not None and status != "ok":
        # the figures say it too: a PNG is often looked at without the terminal's warning
        said = " ".join(str(status).split())
        said = said if len(said) <= 70 else said[:67] + "..."
        title += (f"\nUNFINISHED RUN (status: {said}): "
                  f"{t.size} snapshot(s) up to t = {t[-1]:.6g} s")
    rho_all = series("rho")
    if rho_all is not None and not np.isfinite(rho_all).any():
        note(f"warning: {path}: rho is NaN in every snapshot: the density figure is empty")

    floor = series("floor")
    floor_missing = floor is None
    if floor is None:
        floor = np.zeros_like(t)
    floor_filled = np.where(np.isfinite(floor), floor, 0.0)
    marker = "o" if t.size == 1 else None

    # 1. space-time density map (a 2-D / 3-D layer: the density averaged over its horizontal axes)
    vertical, rho, averaged = vertical_density(ds, series("rho"))
    if vertical == "z":
        hlabel = hlabel.replace(", y", ", z")
    if rho is None or vertical not in ds.variables:
        note(f"no rho(time, {vertical}) (or {vertical}) in the file: density figure skipped")
    else:
        x = _clean(ds[vertical].values)
        fig, ax = plt.subplots(figsize=(9, 5.5))
        units = ds["rho"].attrs.get("units", "kg m-1")
        rlabel = _label(ds, "rho", "line density ρ", "kg m-1")
        if averaged:
            axes = " and ".join(ds["rho"].dims[1:-1])
            rlabel = f"density averaged over {axes} [{units}]"
        finite = np.isfinite(rho)
        top_occ = None
        if finite.any():
            rmax = np.nanmax(rho)
            occupied = (x[None, :] + floor_filled[:, None])[finite & (rho > 1e-3 * rmax)]
            top_occ = occupied.max() if occupied.size else None
        if t.size == 1:
            ax.plot(rho[0], (x + floor_filled[0]) / hscale, color="C0")
            ax.set_xlabel(rlabel)
            ax.set_ylabel(hlabel)
            ax.set_title(f"density at t = {t[0]:.4g} s")
        else:
            # cell corners: time edges halfway between snapshots, height edges halfway between cell
            # centres, shifted by the floor interpolated to the time edges (cells are slanted quads)
            te, xe = _edges(t), _edges(x)
            fe = np.interp(te, t, floor_filled)
            X = np.broadcast_to(te[:, None], (te.size, xe.size))
            Y = (xe[None, :] + fe[:, None]) / hscale
            mesh = ax.pcolormesh(X, Y, np.ma.masked_invalid(rho), shading="flat", cmap="viridis", rasterized=True)
            fig.colorbar(mesh, ax=ax, label=rlabel)
            ax.plot(t, floor_filled / hscale, color="w", lw=1, label="floor")
            ax.set_xlabel("time t [s]")
            ax.set_ylabel(hlabel)
            ax.set_title("density, space-time (lab frame)" + (", horizontal average" if averaged else ""))
        if top_occ is not None:
            lo = min(0.0, np.nanmin(floor_filled)) / hscale
            ax.set_ylim(lo, 1.15 * top_occ / hscale + (0.5 if d else 0.0))
        fig.suptitle(title, fontsize=9)
        fig.tight_layout()
        save(fig, "density")

    # 2. tracer trajectories
    tracers = series("tracer_height")
    if tracers is None:
        tracers = series("tracer_z")                     # a 2-D / 3-D layer's tracers (lab-frame height)
    centre = series("mass_centre")
    if tracers is None:
        note("no tracer_height(time, tracer) or tracer_z in the file: tracer figure skipped")
    else:
        fig, ax = plt.subplots(figsize=(9, 5.5))
        ax.plot(t, tracers / hscale, color="C0", lw=0.8, marker=marker)
        if centre is not None:
            ax.plot(t, centre / hscale, color="k", lw=2, label="mass centre", marker=marker)
        if not floor_missing:
            ax.plot(t, floor / hscale, color="C3", lw=1, label="floor", marker=marker)
        ax.set_xlabel("time t [s]")
        ax.set_ylabel(hlabel)
        ax.set_title(f"tracer trajectories ({tracers.shape[1]} tracers)")
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="upper right")
        fig.suptitle(title, fontsize=9)
        fig.tight_layout()
        save(fig, "tracers")

    # 3. top and mass centre
    top = series("top")
    if top is None and centre is None:
        note("no top(time) or mass_centre(time) in the file: top/centre figure skipped")
    else:
        fig, ax = plt.subplots(figsize=(8, 5))
        if top is not None:
            ax.plot(t, top / hscale, "C0", label="top", marker=marker)
        if centre is not None:
            ax.plot(t, centre / hscale, "C0--", label="mass centre", marker=marker)
        if not floor_missing:
            ax.plot(t, floor / hscale, "C3", lw=1, label="floor", marker=marker)
        ax.set_xlabel("time t [s]")
        ax.set_ylabel(hlabel)
        ax.grid(alpha=0.3)
        ax.legend()
        ax.set_title(" and ".join(n for n, v in (("top", top), ("mass-centre", centre)) if v is not None)
                     + " height" + ("s" if top is not None and centre is not None else "")
                     + ("" if top is not None else " (no top in this file)"))
        fig.suptitle(title, fontsize=9)
        fig.tight_layout()
        save(fig, "top_centre")

    # 4. kinetic energy
    ke = series("kinetic_energy")
    if ke is None:
        note("no kinetic_energy(time) in the file: kinetic-energy figure skipped")
    else:
        fig, ax = plt.subplots(figsize=(8, 5))
        ax.plot(t, ke, "C0", marker=marker)
        ax.set_xlabel("time t [s]")
        ax.set_ylabel(_label(ds, "kinetic_energy", "kinetic energy", "J"))
        ax.grid(alpha=0.3)
        ax.set_title("kinetic energy")
        fig.suptitle(title, fontsize=9)
        fig.tight_layout()
        save(fig, "kinetic_energy")

    if not written:
        raise ValueError(f"{path}: none of rho, tracer_height, top, mass_centre, kinetic_energy could be plotted")
    return written


def add_parser(sub):
    helptext = "draw the standard figures (density map, tracers, top/mass centre, kinetic energy) of an output file"
    p = sub.add_parser("plot", help=helptext, description=helptext)
    p.add_argument("file", metavar="FILE.nc", help="netCDF output of a column or layer run")
    p.add_argument("--out", metavar="DIR", default=None,
                   help=f"directory for the PNG files (default: the file's; {DIR_RULE})")
    p.set_defaults(func=_main)


def _main(args) -> int:
    out = args.out if args.out is not None else os.path.dirname(os.path.abspath(args.file))
    check_output_dir(out, "--out" if args.out is not None else "--out (default: the file's directory)")
    plot_file(args.file, out)
    return 0
