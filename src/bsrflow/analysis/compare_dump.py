"""BSR continuum against an external DEM (LAMMPS / LIGGGHTS dump) for the tapped column.

``bsrflow compare-dump DUMP --dt SECONDS [--config CONFIG.toml] [--kernel packing] ...`` reads the
dump (:func:`bsrflow.io.lammps.read_dump`), runs the continuum column of the configuration to the
dump's last time (the seed's kernel, or with ``--kernel packing`` / ``model.kernel = "packing"``
the packing continuum, nothing fitted; its ``model`` in the JSON and the printed line) and
reports the metrics and figures that ``bsrflow compare`` reports for the package's own DEM
(:mod:`bsrflow.analysis.compare`):

* ``top_max_over_d``, ``t_top_max``: maximum of the top height over t >= tap_start (the first
  tap) and its time [s], from ``compare._metrics``; the DEM top is the highest sphere centre
  (for a 1-D column the top sphere, as ``DEMResult.top``);
* ``mass_centre_rms_over_d``: RMS over the dump's snapshot times of the difference of the
  mass-centre heights (BSR interpolated linearly to those times), in units of d;
* ``top_max_rel_diff``, ``t_top_max_rel_diff``: BSR over DEM minus 1.

Heights are measured from the floor at rest: a dump coordinate c becomes c - ``floor`` (the
floor's rest position in the dump's frame, ``--floor-offset``), and the dump's time t becomes
t - ``time_offset``.  Only snapshots inside the BSR run's time range are used.  The mass-centre
RMS and relative differences are computed exactly as ``compare.compare`` does inline (that code
is not a function there, so :func:`case_metrics` restates it).
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import os
import types

import numpy as np

from ..cli import Number
from ..physics.column import continuum_label
from .compare import _metrics

__all__ = ["case_metrics", "compare_with_dump", "check_dump", "case_name", "dump_floor", "add_parser"]

DUMP_SUFFIXES = (".dump", ".lammpstrj", ".lammps")
"""File-name endings of text dumps left out of a case name (before an optional ``.gz``)."""


def case_name(path) -> str:
    """The case name of a dump file, used in the JSON and the figure file names: the whole
    file name without a known dump ending (:data:`DUMP_SUFFIXES`); a gzip-compressed file's
    ``.gz`` becomes ``_gz``, so that ``x.dump`` -> "x" and ``x.dump.gz`` -> "x_gz" do not
    overwrite each other's figures; ``dump.z`` stays "dump.z"."""
    base = os.path.basename(os.fspath(path))
    gz = base.endswith(".gz") and len(base) > 3
    if gz:
        base = base[:-3]
    for suffix in DUMP_SUFFIXES:
        if base.endswith(suffix) and len(base) > len(suffix):
            base = base[:-len(suffix)]
            break
    return (base or "dump") + ("_gz" if gz else "")


def check_dump(dump, axis=None, time_offset: float = 0.0, what_axis: str = "axis") -> None:
    """ValueError (one line, naming the dump) unless the dump can be compared: times known, at
    least two snapshots, at least one of them at t - time_offset > 0, and a vertical axis along
    which the sphere centres vary.  Cheap: run it before the BSR run."""
    if dump.t is None:
        raise ValueError(f"{dump.path}: the dump's times are unknown (no ITEM: TIME blocks): give the time "
                         "step size (--dt SECONDS)")
    if dump.n_snapshots < 2:
        raise ValueError(f"{dump.path}: the dump has only one snapshot (timestep {int(dump.timestep[0])}); "
                         "a comparison of trajectories needs at least two")
    t_last = float(dump.t[-1]) - float(time_offset)
    if not t_last > 0:
        raise ValueError(f"{dump.path}: the dump's last time minus the time offset is {t_last:g} s "
                         f"(last time {float(dump.t[-1]):g} s, offset {float(time_offset):g} s): need > 0")
    name = dump.axis if axis is None else str(axis)
    h = dump.heights(axis)
    if np.ptp(h) == 0.0:
        k = "xyz".index(name) if name in "xyz" else int(name)
        varying = [f"{a} by {np.ptp(dump.positions[:, :, j]):.3g} m" for j, a in enumerate("xyz")
                   if j != k and np.all(np.isfinite(dump.positions[:, :, j])) and np.ptp(dump.positions[:, :, j]) > 0]
        raise ValueError(f"{dump.path}: {what_axis} {'xyz'[k]}: the {'xyz'[k]} coordinate of every atom is "
                         f"{float(h.flat[0]):g} m in every snapshot, so it cannot be the vertical axis"
                         + (f" (varying: {', '.join(varying)})" if varying else ""))


def case_metrics(run, t_dem, top_dem, centre_dem, diameter=None) -> dict:
    """The comparison metrics of ``bsrflow compare`` for one case.

    run : :class:`bsrflow.physics.column.ColumnRun` (lab-frame heights from the floor at rest).
    t_dem, top_dem, centre_dem : (nt,) DEM sample times [s], top-sphere-centre and mass-centre
        heights [m] from the floor at rest.
    diameter : d [m] for the heights in units of d (default ``run.setup.diameter``).

    Returns {"bsr": {top_max_over_d, t_top_max}, "dem": {...}, "mass_centre_rms_over_d",
    "top_max_rel_diff", "t_top_max_rel_diff"}.
    """
    s = run.setup
    d = float(diameter or s.diameter)
    ref = types.SimpleNamespace(diameter=d, tap_start=s.tap_start)      # what _metrics reads
    bsr = _metrics(run.t, run.top, run.mass_centre, ref)
    dem = _metrics(np.asarray(t_dem), np.asarray(top_dem), np.asarray(centre_dem), ref)
    if not dem["top_max_over_d"] > 0:
        raise ValueError(f"the DEM top height reaches at most {dem['top_max_over_d']:.4g} d above the floor at rest "
                         "after the first tap: the relative difference is undefined (check the floor offset and "
                         "the axis)")
    rms = float(np.sqrt(np.mean(((np.interp(t_dem, run.t, run.mass_centre) - centre_dem) / d) ** 2)))
    return {"bsr": bsr, "dem": dem, "mass_centre_rms_over_d": rms,
            "top_max_rel_diff": bsr["top_max_over_d"] / dem["top_max_over_d"] - 1.0,
            "t_top_max_rel_diff": (bsr["t_top_max"] / dem["t_top_max"] - 1.0) if dem["t_top_max"] != 0 else None}


def dump_floor(setup, t) -> np.ndarray:
    """Floor position ϑ(t) [m] of the setup's applied motion at times ``t`` [s]."""
    motion = setup.motion()
    return np.array([float(motion.fn(float(tt), motion.params)[0]) for tt in np.asarray(t)])


def compare_with_dump(run, dump, floor: float = 0.0, diameter: float | None = None, axis=None,
                      time_offset: float = 0.0, figures: str | None = None, name: str | None = None) -> dict:
    """Compare a BSR column run with the sphere trajectories of a LAMMPS/LIGGGHTS dump.

    Parameters
    ----------
    run : :class:`~bsrflow.physics.column.ColumnRun` of the same column and taps.
    dump : :class:`~bsrflow.io.lammps.DumpTrajectories` with times (``dump.t`` not None: read it
        with ``timestep_size``).
    floor : rest position [m] of the floor along ``axis`` in the dump's coordinates; heights are
        coordinate - floor.
    diameter : d [m] for heights in units of d (default ``run.setup.diameter``).
    axis : vertical axis of the dump (default ``dump.axis``).
    time_offset : subtracted from the dump's times [s] (e.g. a settling phase run before t = 0 of
        the BSR run).
    figures : directory for the figures of ``bsrflow compare`` (density snapshots, trajectories
        side by side, top and mass centre), written by :func:`bsrflow.plots.compare_figures`.
    name : case name used in the figure file names (default: the dump file's stem).

    Returns
    -------
    JSON-ready dict: the metrics of :func:`case_metrics`, ``dump`` (file, atoms, snapshots used,
    offsets), ``bsr_run`` (wall time, steps, mass drift, min density), ``setup``, ``warnings``
    (atom count or sphere diameter differing from the setup's) and ``figures``.
    """
    check_dump(dump, axis, time_offset)
    s = run.setup
    d = float(diameter or s.diameter)
    if not (math.isfinite(d) and d > 0):
        raise ValueError(f"diameter = {diameter!r} is outside the valid range (0, inf) m")
    name = name or case_name(dump.path)
    t_all = np.asarray(dump.t, dtype=float) - float(time_offset)
    tol = 1e-9 * max(1.0, abs(run.t[-1]))
    use = (t_all >= run.t[0] - tol) & (t_all <= run.t[-1] + tol)
    if use.sum() < 2:
        raise ValueError(f"{dump.path}: {int(use.sum())} snapshot(s) lie in the BSR run's time range "
                         f"[{run.t[0]:g}, {run.t[-1]:g}] s, at least two are needed (dump times {t_all[0]:g} to "
                         f"{t_all[-1]:g} s after the time offset {time_offset:g} s)")
    t_d = t_all[use]
    heights = dump.heights(axis)[use] - float(floor)
    top = heights.max(axis=1)
    centre = dump.mass_centre(axis)[use] - float(floor)
    out = {"name": name, "model": continuum_label(s), "a_over_d": s.a_over_d, "taps": s.n_taps, "d": d}
    out.update(case_metrics(run, t_d, top, centre, d))
    warnings = []
    if dump.n_atoms != s.n_spheres:
        warnings.append(f"the dump has {dump.n_atoms} atoms, the setup {s.n_spheres} spheres")
    diam = dump.diameters()
    if diam is not None and np.isfinite(diam).any():
        dd = float(np.nanmedian(diam))
        if abs(dd / s.diameter - 1.0) > 1e-3:
            warnings.append(f"the dump's spheres have diameter {dd:.6g} m, the setup {s.diameter:.6g} m")
    if use.sum() < t_all.size:
        warnings.append(f"{t_all.size - int(use.sum())} snapshot(s) outside the BSR run's time range were left out")
    out["dump"] = {"path": dump.path, "atoms": dump.n_atoms, "snapshots": dump.n_snapshots,
                   "snapshots_used": int(use.sum()), "timestep_first": int(dump.timestep[0]),
                   "timestep_last": int(dump.timestep[-1]), "axis": dump.axis if axis is None else str(axis),
                   "floor_offset_m": float(floor), "time_offset_s": float(time_offset),
                   "t_first_s": float(t_d[0]), "t_last_s": float(t_d[-1]), "units": dump.units}
    out["bsr_run"] = {"wall_s": run.wall_time, "steps": run.steps,
                      "mass_drift": float(np.max(np.abs(run.mass - run.mass[0])) / run.mass[0]),
                      "min_density": float(run.rho.min())}
    out["setup"] = s.to_dict()
    out["warnings"] = warnings
    if figures:
        from .. import plots
        plots.compare_figures({name: (s, run, (t_d, heights, dump_floor(s, t_d)))}, figures)
        kinds = (["density"] if s.n_taps == 1 else []) + ["trajectories", "top_centre"]
        out["figures"] = [f"{name}_{k}.png" for k in kinds]
    return out


def format_line(result) -> str:
    """One-line summary in the layout of ``bsrflow compare``'s table."""
    b, m = result["bsr"], result["dem"]
    dt = result["t_top_max_rel_diff"]
    return (f"{result['name']}: {result.get('model', 'BSR')} top {b['top_max_over_d']:.2f} d at {b['t_top_max']:.3f} s | "
            f"dump top {m['top_max_over_d']:.2f} d at {m['t_top_max']:.3f} s | "
            f"dtop {100 * result['top_max_rel_diff']:.1f}% | dt {'n/a' if dt is None else f'{100 * dt:.1f}%'} | "
            f"mass-centre RMS {result['mass_centre_rms_over_d']:.3f} d")


# ----------------------------------------------------------------------------- command line

_SETUP_OPTIONS = [
    # (option, ColumnSetup field, type, help)
    ("--n-spheres", "n_spheres", int, "number of spheres N"),
    ("--diameter", "diameter", float, "sphere diameter d [m] (also the unit of the heights)"),
    ("--density", "density", float, "sphere material density [kg/m^3]"),
    ("--stiffness", "stiffness", float, "contact stiffness K [N/m]"),
    ("--a-over-d", "a_over_d", float, "tap amplitude a/d"),
    ("--frequency", "frequency", float, "tap frequency f [Hz]"),
    ("--tap-start", "tap_start", float, "time of the first tap [s]"),
    ("--n-taps", "n_taps", int, "number of taps"),
    ("--tap-period", "tap_period", float, "time between taps [s]"),
    ("--m0", "m0", float, "kernel characteristic mass m0 [kg]"),
    ("--eps", "kernel_dissipation", float, "kernel dissipation epsilon"),
    ("--ppd", "points_per_diameter", int, "grid points per diameter"),
    ("--scheme", "scheme", str, "scheme preset (seed or accurate)"),
    ("--t-end", "t_end", float, "end of the BSR run [s] (default: the dump's last time)"),
]


def _config_key(field: str) -> str:
    """The config's dotted key of a ColumnSetup field (``m0`` -> ``column.m0``), or the field."""
    from ..io.config import Config, ConfigError
    try:
        return Config.resolve_key(field)
    except ConfigError:
        return field


def _option_range(field: str) -> str:
    """The valid range of the column field ``field`` as the config states it."""
    from ..io.config import FIELDS
    key = _config_key(field)
    return next(f.range_text() for f in FIELDS if f.name == key)


def add_parser(sub):
    helptext = "BSR against a LAMMPS/LIGGGHTS dump of the tapped column (metrics and figures of 'compare')"
    p = sub.add_parser("compare-dump", help=helptext, description=helptext)
    p.add_argument("dump", metavar="DUMP", help="LAMMPS/LIGGGHTS text dump (dump atom/custom; .gz allowed)")
    p.add_argument("--config", metavar="CONFIG.toml",
                   help="column configuration (TOML); options below override it")
    p.add_argument("--dt", type=Number(float, "(0, inf) s"), metavar="SECONDS",
                   help="the DEM run's time step [s]: t = timestep * dt, needed unless the dump has ITEM: TIME "
                        "(then the dump's times are used and a --dt contradicting them is refused)")
    p.add_argument("--name", metavar="NAME",
                   help="case name in the JSON and the figure file names (default: the file name without "
                        ".dump/.lammpstrj/.lammps; .gz becomes _gz)")
    p.add_argument("--axis", default="z", choices=("x", "y", "z"), help="vertical axis of the dump (default z)")
    p.add_argument("--floor-offset", type=Number(float, "finite values [m]"), default=0.0, metavar="M",
                   help="rest position of the floor in the dump's coordinates [m] (default 0)")
    p.add_argument("--time-offset", type=Number(float, "finite values [s]"), default=0.0, metavar="S",
                   help="subtracted from the dump's times [s] (default 0)")
    p.add_argument("--type", type=Number(int, "integers >= 1 (the dump's atom types)"), action="append", dest="types",
                   metavar="T",
                   help="use only atoms of this type (repeatable; default all)")
    p.add_argument("--kernel", choices=("seed", "packing"), default=None,
                   help="the continuum: the seed's kernel (m0, eps) or the packing continuum (the contact "
                        "law, nothing fitted; Lagrangian, R = d unless the config or --set say otherwise); "
                        "default: the config's model.kernel, else seed")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="override any column parameter (repeatable), e.g. --set restitution=0.8")
    for opt, _field, typ, h in _SETUP_OPTIONS:
        p.add_argument(opt, type=typ if typ is str else Number(typ, functools.partial(_option_range, _field)),
                       default=None, dest=_field, metavar="N" if typ is int else "VALUE", help=h)
    p.add_argument("--json", metavar="PATH", help="write the results as JSON (its folder must exist)")
    p.add_argument("--figures", metavar="DIR", help="write the figures to DIR (created if missing; "
                   "the folder holding it must exist)")
    p.set_defaults(func=_main)


def _main(args) -> int:
    from ..io.lammps import read_dump, time_mismatch
    from ..physics.column import run_bsr_column
    from ..io.paths import check_distinct, check_output_dir, check_output_file
    from ..tools.setup_source import SetupSource, parse_value

    check_distinct(("DUMP", args.dump), ("--config", args.config), ("--json", args.json),
                   ("--figures", args.figures))
    if args.json is not None:
        check_output_file(args.json, "--json")
    if args.figures is not None:
        check_output_dir(args.figures, "--figures")
    if args.dt is not None and not (math.isfinite(args.dt) and args.dt > 0):
        raise ValueError(f"--dt {args.dt!r} is outside the valid range (0, inf) s")
    for opt, v, unit in (("--floor-offset", args.floor_offset, "m"), ("--time-offset", args.time_offset, "s")):
        if not math.isfinite(v):
            raise ValueError(f"{opt} {v!r} is outside the valid range: finite values [{unit}]")
    if args.name is not None and (not args.name.strip() or os.sep in args.name or args.name.startswith(".")):
        raise ValueError(f"--name {args.name!r}: need a non-empty name without {os.sep!r}, not starting with '.' "
                         "(it starts the figure file names)")
    dump = read_dump(args.dump, axis=args.axis)
    if dump.t is not None and args.dt is not None:
        bad = time_mismatch(dump.timestep, dump.t, args.dt)
        if bad:
            raise ValueError(f"--dt {args.dt!r} contradicts the dump's own ITEM: TIME: {bad}; leave --dt out "
                             "(the dump's times are used)")
    elif dump.t is None:
        if args.dt is None:
            raise ValueError(f"{args.dump}: the dump has no ITEM: TIME blocks; give the time step with --dt SECONDS")
        dump = dataclasses.replace(dump, t=dump.timestep * float(args.dt))
        span = float(dump.t[-1] - dump.t[0]) if len(dump.t) else 0.0
        if not (math.isfinite(span) and span <= 1e5):
            raise ValueError(f"--dt {args.dt!r} is outside the valid range at this dump: the dump's last time step "
                             f"{int(dump.timestep[-1])} times --dt must stay within 1e5 s (the run's t_end range)")
    if args.types:
        dump = dump.select(args.types)
    check_dump(dump, args.axis, args.time_offset, what_axis="--axis")
    from ..tools.setup_source import canonical_name, check_given_once, check_no_run_outputs
    overrides = {}
    for item in args.set:
        key, sep, value = item.partition("=")
        if not sep or not key.strip() or not value.strip():
            raise ValueError(f"--set {item!r} is not NAME=VALUE")
        overrides[key.strip()] = parse_value(value)
    set_as = check_given_once(("--set", item.strip()) for item in args.set)
    check_no_run_outputs("compare-dump writes", [("--set", key) for key in overrides])
    for opt, fld, _typ, _h in _SETUP_OPTIONS:
        v = getattr(args, fld)
        if v is not None:
            if canonical_name(fld) in set_as:
                raise ValueError(f"{opt} {v} contradicts {' '.join(set_as[canonical_name(fld)])}; give one of the two")
            overrides[fld] = v
    if args.kernel is not None:
        given = set_as.get(canonical_name("kernel"))          # --set kernel=... or model.kernel=...
        if given is not None:
            key = given[1].partition("=")[0].strip()
            if overrides[key] != args.kernel:
                raise ValueError(f"--kernel {args.kernel} contradicts --set {given[1]}; give one of the two")
            del overrides[key]
        overrides["kernel"] = args.kernel
    if "t_end" not in overrides:
        overrides["t_end"] = float(dump.t[-1] - args.time_offset)
    source = SetupSource.load(args.config)
    source.check_names(overrides)
    check_no_run_outputs("compare-dump writes", (), getattr(source, "config", None), args.config)
    seed_only = ("m0", "kernel_dissipation", "scheme", "stepper", "rtol", "atol")
    seed_given = [opt for opt, fld, _t, _h in _SETUP_OPTIONS if fld in seed_only and getattr(args, fld) is not None]
    seed_given += [f"--set {k}" for k in (item.partition("=")[0].strip() for item in args.set)
                   if canonical_name(k) in seed_only]
    refusal = (f"{seed_given[0]} is an option of the seed kernel only; the packing continuum has no m0, eps or "
               "scheme options: leave it out") if seed_given else ""
    try:
        setup, scheme = source.setup_and_scheme(overrides)
    except ValueError as exc:
        msg = str(exc)
        # the config refuses the seed's options with the packing kernel: name the option
        if seed_given and "packing" in msg and msg.startswith((
                "column.m0:", "column.kernel_dissipation:", "numerics.scheme:", "numerics.stepper:",
                "numerics.rtol:", "numerics.atol:")):
            raise ValueError(refusal) from None
        # a value of this command line out of its range: name the option it came from
        for opt, fld, _t, _h in _SETUP_OPTIONS:
            if getattr(args, fld) is not None and msg.startswith(_config_key(fld) + ":"):
                raise ValueError(f"{opt}: {msg.partition(':')[2].strip()}") from None
        raise
    if setup.kernel_name == "packing" and seed_given:        # e.g. --scheme seed, which the config allows
        raise ValueError(refusal)
    if dump.n_atoms != setup.n_spheres:
        kept = f" of type {', '.join(map(str, args.types))}" if args.types else ""
        raise ValueError(f"--n-spheres {setup.n_spheres} (the column's n_spheres: this option, --set or the config; "
                         f"default 20) contradicts the dump's {dump.n_atoms} atoms{kept}: give --n-spheres "
                         f"{dump.n_atoms}, or select the spheres with --type")
    t_rel = dump.t - args.time_offset
    after = (t_rel >= setup.tap_start - 1e-12) & (t_rel <= setup.t_end + 1e-9 * max(1.0, setup.t_end))
    if after.any():
        highest = float(np.max(dump.heights(args.axis)[after]) - args.floor_offset)
        if not highest > 0:
            raise ValueError(f"--floor-offset {args.floor_offset!r}: the highest sphere centre of the dump after the "
                             f"first tap is {highest:g} m above the floor at rest, not above it; check the floor "
                             "offset and --axis")
    print(f"bsrflow compare-dump: {args.dump}: {dump.n_atoms} atoms, {dump.n_snapshots} snapshots, "
          f"t = {dump.t[0]:g} to {dump.t[-1]:g} s; {continuum_label(setup)} to t = {setup.t_end:g} s"
          + ("" if setup.kernel_name == "packing" else f", scheme {setup.scheme if scheme is None else scheme.name}")
          + ("" if args.config is None else
             f" (config {args.config}{'' if source.uses_config_module else ', fallback reader'})"))
    run = run_bsr_column(setup, scheme=scheme)
    result = compare_with_dump(run, dump, floor=args.floor_offset, axis=args.axis, time_offset=args.time_offset,
                               figures=args.figures, name=args.name)
    result["config"] = args.config
    print(format_line(result))
    for w in result["warnings"]:
        print(f"warning: {w}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(result, fh, indent=2)
        print(f"wrote {args.json}")
    if args.figures:
        for f in result.get("figures", []):
            print(os.path.join(args.figures, f))
    return 0
