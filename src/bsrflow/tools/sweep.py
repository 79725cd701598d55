"""Parameter sweeps of the tapped column on dask.distributed.

``bsrflow sweep [CONFIG] --param a_over_d=0.25:1.5:11 --param f=5,10,20 [--set NAME=VALUE]
[--scheduler ADDRESS] [--workers 2] [--out sweep.nc] [--figure F.png]``

* ``--param name=start:stop:num`` sweeps ``numpy.linspace(start, stop, num)`` (num an integer
  >= 1); ``--param name=v1,v2,...`` sweeps the listed values (numbers, true/false or words such
  as scheme names).  Names are ColumnSetup fields or their aliases (``f`` = frequency, ``d`` =
  diameter, ``N`` = n_spheres, ``ppd`` = points_per_diameter, ``eps`` = kernel_dissipation,
  ...); with the configuration module ``bsrflow.io.config``, whatever its ``with_overrides``
  accepts.  ``--set`` fixes a parameter for every case.
* The cases are the Cartesian product of the swept values, in the order the ``--param``
  options are given.  Each runs :func:`run_case` on a dask worker: by default a
  ``LocalCluster(n_workers=--workers, threads_per_worker=1, processes=True)``, or the cluster of
  the scheduler at ``--scheduler`` (its workers need bsrflow installed).  Each worker process
  compiles the solver once (about 10 s) before its first case.
* A case that fails is recorded with its status and message and the others still run:
  ``invalid`` (a parameter value outside its valid range), ``stopped`` (the solver stopped early,
  :class:`~bsrflow.numerics.solver.SimulationError`), ``failed`` (any other exception, or a lost
  worker).  Ctrl-C or SIGTERM stops the sweep: the finished cases are written to ``--out``
  (the others with status ``interrupted``; attribute ``interrupted``), exit code 130 / 143.
* The results are gathered into one :class:`xarray.Dataset` with one dimension per swept
  parameter (coordinates with ``units``/``long_name``), written as netCDF (``--out``), and a figure
  of the top height against the first parameter, one line per value of the second (``--figure``).

Exit code 0 when every case succeeded, 3 when some did not (the file is still written), 2 for a
malformed ``--param``/``--set``, an unknown parameter name, a case whose configuration is
invalid (every case is checked before the cluster starts), a scheduler that cannot be reached
(5 s timeout) or an unusable output path (checked first).

The base configuration comes from :class:`bsrflow.tools.setup_source.SetupSource`:
``bsrflow.io.config.load_config(CONFIG).with_overrides(overrides).column_setup()`` when that
module exists, else a fallback TOML reader building ``ColumnSetup(**values | overrides)``.
"""

from __future__ import annotations

import datetime
import itertools
import json
import math
import os
import re
import sys
import time

import numpy as np

from ..cli import Number, max_workers, workers_range
from ..io.config import field_range
from .setup_source import (SetupSource, canonical_name, check_given_once, check_no_run_outputs, coerce_value,
                           parameter_info, parse_value)
from ..physics.column import continuum_label

__all__ = ["parse_param", "parse_params", "make_cases", "check_cases", "check_scheduler", "run_case", "run_sweep", "to_dataset", "sweep_figure",
           "RESULTS", "add_parser"]

RESULTS = {
    # name: (units, long_name, dtype)
    "top_max": ("m", "maximum height of the top tracer after the first tap (lab frame, from the floor at rest)", float),
    "top_max_over_d": ("1", "maximum top height after the first tap over d", float),
    "t_top_max": ("s", "time of the maximum top height", float),
    "mass_centre_max": ("m", "maximum mass-centre height after the first tap", float),
    "mass_centre_max_over_d": ("1", "maximum mass-centre height after the first tap over d", float),
    "final_mass": ("kg", "mass at the last saved time", float),
    "mass_drift": ("1", "largest relative mass change", float),
    "t_final": ("s", "last saved time (a stopped case: the time of the stop)", float),
    "steps": ("1", "time steps taken", int),
    "wall_time": ("s", "wall-clock time of the case (including compilation on a fresh worker)", float),
}
"""Scalar results of :func:`run_case`: (units, long_name, type)."""

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_.]*$")
_INT = re.compile(r"^[+-]?\d+$")


MAX_CASES = 100_000
"""Most cases one sweep accepts (a review's sweep of 20 000 seed-kernel cases ran; one of 1e8
was building its case list for minutes without a word)."""


def _valid_range(name: str) -> str:
    """"; valid range ..." for a numeric parameter the config knows (its field's range), else ""."""
    rng = field_range(name, numeric=True)
    return f"; valid range {rng}" if rng else ""


def parse_param(spec: str) -> tuple[str, list]:
    """Parse ``name=start:stop:num`` (linspace, num integer >= 1) or ``name=v1,v2,...``.

    Returns (name, values).  Values are coerced to the type of the ColumnSetup field the name
    refers to (integers for n_spheres etc.).  ValueError with a one-line message for a malformed
    spec.
    """
    name, sep, rhs = spec.partition("=")
    name, rhs = name.strip(), rhs.strip()
    if not sep or not name or not rhs:
        raise ValueError(f"--param {spec!r} is not NAME=START:STOP:NUM or NAME=V1,V2,...")
    if not _NAME.match(name):
        raise ValueError(f"--param {spec!r}: {name!r} is not a valid parameter name")
    if ":" in rhs:
        parts = rhs.split(":")
        if len(parts) != 3:
            raise ValueError(f"--param {spec!r}: a range is START:STOP:NUM (three fields), got {len(parts)}")
        try:
            start, stop = float(parts[0]), float(parts[1])
        except ValueError:
            raise ValueError(f"--param {spec!r}: START and STOP must be numbers{_valid_range(name)}") from None
        if not (math.isfinite(start) and math.isfinite(stop)):
            raise ValueError(f"--param {spec!r}: START and STOP must be finite")
        if not _INT.match(parts[2].strip()) or not 1 <= int(parts[2]) <= MAX_CASES:
            raise ValueError(f"--param {spec!r}: NUM must be an integer in [1, {MAX_CASES}], got {parts[2]!r}")
        raw = list(np.linspace(start, stop, int(parts[2])))
        raw = [float(v) for v in raw]
    else:
        items = [v.strip() for v in rhs.split(",")]
        if any(not v for v in items):
            raise ValueError(f"--param {spec!r}: empty value in the list")
        raw = [parse_value(v) for v in items]
    try:
        values = [coerce_value(name, v) for v in raw]
    except ValueError as exc:
        raise ValueError(f"--param {spec!r}: {exc}{_valid_range(name)}") from None
    if len(set(map(repr, values))) != len(values):
        raise ValueError(f"--param {spec!r}: repeated values")
    kinds = {type(v) for v in values}
    if len(kinds) > 1 and not kinds <= {int, float}:
        raise ValueError(f"--param {spec!r}: mixes numbers and words")
    return name, values


def parse_params(specs) -> dict:
    """{name: values} from several specs, in order; ValueError for a repeated name."""
    parsed = [parse_param(spec) for spec in specs]
    check_given_once(("--param", spec.strip()) for spec in specs)
    out = dict(parsed)
    if not out:
        raise ValueError("no --param given: nothing to sweep")
    n = math.prod(len(v) for v in out.values())
    if n > MAX_CASES:
        raise ValueError(f"--param: the sweep would have {n} cases ({' × '.join(str(len(v)) for v in out.values())}); "
                         f"valid: at most {MAX_CASES} (split it into several sweeps)")
    return out


def make_cases(params: dict) -> list[tuple[tuple, dict]]:
    """The Cartesian product of the swept values: a list of (index tuple, overrides dict), the
    last parameter varying fastest."""
    names = list(params)
    ranges = [range(len(params[n])) for n in names]
    return [(idx, {n: params[n][i] for n, i in zip(names, idx)}) for idx in itertools.product(*ranges)]


def _empty_result(status, message, wall=float("nan")):
    r = {k: (0 if typ is int else float("nan")) for k, (_u, _l, typ) in RESULTS.items()}
    r.update(status=status, error=message, wall_time=wall)
    return r


def run_case(overrides: dict, source: SetupSource | None = None) -> dict:
    """Run one column case and return its scalar results (:data:`RESULTS`, SI units) with
    ``status`` ("ok", "invalid", "stopped", "failed") and ``error`` (the message, '' if ok).

    overrides : {parameter name: value} applied to the base configuration.
    source : the base configuration (:class:`SetupSource`; None: the ColumnSetup defaults).

    Never raises for a failing case: the failure is the result.  Maxima are taken over the saved
    times t >= tap_start (the whole run if it ends before the first tap), as ``bsrflow compare``
    does for the top height.  A case that stops early ("stopped") has the results of the
    snapshots saved before the stop and the steps taken up to it (NaN only where there is no
    snapshot at all, and for "invalid" and "failed" cases).
    """
    from ..numerics.solver import SimulationError
    from ..physics.column import run_bsr_column

    start = time.perf_counter()
    source = source or SetupSource()
    try:
        setup, scheme = source.setup_and_scheme(overrides)
    except (ValueError, TypeError, KeyError) as exc:
        return _empty_result("invalid", _one_line(exc), time.perf_counter() - start)
    try:
        run = run_bsr_column(setup, scheme=scheme)
    except SimulationError as exc:
        partial = getattr(exc, "column_run", None)
        if partial is not None:         # the results of the snapshots saved before the stop
            r = _column_results(setup, partial, start)
            r.update(status="stopped", error=_one_line(exc))
        else:
            r = _empty_result("stopped", _one_line(exc), time.perf_counter() - start)
        if exc.time is not None and np.isfinite(exc.time):
            r["t_final"] = float(exc.time)
        if exc.result is not None:
            r["steps"] = int(exc.result.steps)
        return r
    except Exception as exc:  # noqa: BLE001 - recorded, the sweep goes on
        return _empty_result("failed", f"{type(exc).__name__}: {_one_line(exc)}", time.perf_counter() - start)
    return _column_results(setup, run, start)


def _column_results(setup, run, start) -> dict:
    """The scalar results (:data:`RESULTS`) of a column run (whole or up to a stop)."""
    d = setup.diameter
    after = run.t >= setup.tap_start - 1e-12
    if not after.any():
        after = np.ones_like(run.t, dtype=bool)
    k = int(np.argmax(np.where(after, run.top, -np.inf)))
    kc = int(np.argmax(np.where(after, run.mass_centre, -np.inf)))
    return {
        "status": "ok", "error": "",
        "top_max": float(run.top[k]), "top_max_over_d": float(run.top[k] / d), "t_top_max": float(run.t[k]),
        "mass_centre_max": float(run.mass_centre[kc]), "mass_centre_max_over_d": float(run.mass_centre[kc] / d),
        "final_mass": float(run.mass[-1]),
        "mass_drift": float(np.max(np.abs(run.mass - run.mass[0])) / run.mass[0]),
        "t_final": float(run.t[-1]), "steps": int(run.steps), "wall_time": time.perf_counter() - start,
    }


def _one_line(exc) -> str:
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def run_sweep(params: dict, source: SetupSource | None = None, scheduler: str | None = None, n_workers: int = 2,
              log=print):
    """Run every case of the sweep on dask.distributed and return the :func:`to_dataset` Dataset.

    params : {name: values} (:func:`parse_params`).
    source : base configuration (None: ColumnSetup defaults).
    scheduler : address of a running dask scheduler; None starts a ``LocalCluster`` of
        ``n_workers`` single-threaded worker processes for the duration of the sweep.
    log : progress callback (one line per finished case) or None.
    """
    import logging

    from dask.distributed import Client, LocalCluster, as_completed

    source = source or SetupSource()
    source.check_names({n: v[0] for n, v in params.items()})
    cases = make_cases(params)
    if not (isinstance(n_workers, int) and n_workers >= 1):
        raise ValueError(f"--workers {n_workers!r} is outside the valid range: integers >= 1")
    try:                                   # the workers must be able to rebuild the configuration
        import cloudpickle
        cloudpickle.loads(cloudpickle.dumps(source))
    except Exception as exc:  # noqa: BLE001
        raise RuntimeError(f"the configuration cannot be sent to dask workers: {type(exc).__name__}: "
                           f"{_one_line(exc)}") from None
    t0 = time.perf_counter()
    cluster = None
    if scheduler:
        try:
            client = Client(scheduler, timeout=f"{SCHEDULER_TIMEOUT:g}s")
        except Exception as exc:  # noqa: BLE001 - refused, timed out, or not a dask scheduler at all
            raise ValueError(f"--scheduler {scheduler}: cannot connect to a dask scheduler "
                             f"({type(exc).__name__}: {_one_line(exc)}; is a dask scheduler listening there?)") from None
    else:
        # no dashboard; the scheduler's own small HTTP server on a free port (on its default, 8787,
        # a second sweep or a Jupyter cluster made dask print a 4-line warning)
        cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True, dashboard_address=None,
                               silence_logs=logging.ERROR, scheduler_kwargs={"dashboard_address": ":0"})
        client = Client(cluster)
    results = [None] * len(cases)
    interrupted = None
    address = scheduler
    try:
        address = client.scheduler.address if scheduler is None else scheduler
        futures = client.map(run_case, [ov for _idx, ov in cases], source=source, pure=False)
        where = {f.key: i for i, f in enumerate(futures)}
        for done, fut in enumerate(as_completed(futures), start=1):
            i = where[fut.key]
            try:
                res = fut.result()
            except Exception as exc:  # noqa: BLE001 - a lost worker or an unpicklable result
                res = _empty_result("failed", f"{type(exc).__name__}: {_one_line(exc)}")
            results[i] = res
            if log:
                log(f"[{done}/{len(cases)}] {_case_label(cases[i][1])}: {_summary(res)}")
    except KeyboardInterrupt as exc:   # Ctrl-C or SIGTERM: keep the finished cases (below)
        interrupted = exc
    finally:
        try:
            client.close()
            if cluster is not None:
                cluster.close()
        except KeyboardInterrupt as exc:   # the signal can also land while the cluster shuts down
            interrupted = interrupted or exc
    if interrupted is not None:
        results = [r if r is not None else
                   _empty_result("interrupted", "the sweep was interrupted before this case finished")
                   for r in results]
    ds = to_dataset(params, cases, results, source)
    ds.attrs.update(scheduler=str(scheduler or f"LocalCluster ({n_workers} processes) at {address}"),
                    wall_time_s=time.perf_counter() - t0)
    if interrupted is not None:
        n_done = sum(r["status"] != "interrupted" for r in results)
        ds.attrs["interrupted"] = f"after {n_done} of {len(cases)} cases"
        interrupted.partial = ds          # the command writes it before it exits
        raise interrupted
    return ds


def check_cases(params: dict, source: SetupSource) -> None:
    """Validate the configuration of every case of the sweep (cheap: no run); ValueError with
    the first invalid case and its one-line error.  The command line calls this before it
    starts a cluster; :func:`run_sweep` itself records invalid cases as "invalid" instead."""
    source.check_names({n: v[0] for n, v in params.items()})
    for _idx, overrides in make_cases(params):
        try:
            source.setup_and_scheme(overrides)
        except (ValueError, TypeError, KeyError) as exc:
            raise ValueError(f"--param: the case {_case_label(overrides)} is invalid: {_one_line(exc)}") from None


SCHEDULER_TIMEOUT = 5.0
"""Seconds to wait for a connection to ``--scheduler`` before giving up."""


def check_scheduler(address: str, timeout: float = SCHEDULER_TIMEOUT) -> None:
    """A TCP connection to the dask scheduler at ``address`` (``tcp://host:port`` or
    ``host:port``) can be opened within ``timeout`` seconds; ValueError (one line) otherwise.
    Other protocols (tls://, ucx://, ...) are left to dask."""
    import socket
    from urllib.parse import urlsplit

    text = address if "://" in address else f"tcp://{address}"
    parts = urlsplit(text)
    if parts.scheme != "tcp":
        return
    try:
        host, port = parts.hostname, parts.port or 8786
    except ValueError as exc:
        raise ValueError(f"--scheduler {address!r} is not an address tcp://HOST:PORT ({exc})") from None
    if not host:
        raise ValueError(f"--scheduler {address!r} is not an address tcp://HOST:PORT")
    try:
        with socket.create_connection((host, port), timeout=timeout):
            pass
    except OSError as exc:
        why = "timed out" if isinstance(exc, TimeoutError) else (exc.strerror or type(exc).__name__)
        raise ValueError(f"--scheduler {address}: cannot connect to a dask scheduler at {host}:{port} ({why}, "
                         f"{timeout:g} s timeout); start one there or leave out --scheduler for a local "
                         "cluster") from None


def _case_label(overrides) -> str:
    return ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in overrides.items())


def _summary(res) -> str:
    if res["status"] == "ok":
        return (f"ok, top {res['top_max_over_d']:.2f} d at {res['t_top_max']:.3f} s, {res['steps']} steps, "
                f"{res['wall_time']:.2f} s")
    return f"{res['status']}: {res['error']}"


def to_dataset(params: dict, cases, results, source: SetupSource | None = None):
    """Gather case results into an xarray Dataset: one dimension per swept parameter (coordinate
    values as given, ``units``/``long_name`` attributes), the :data:`RESULTS` variables, ``status``
    and ``error`` strings; attributes describe the configuration and the counts."""
    import xarray as xr

    from .. import __version__

    names = list(params)
    shape = tuple(len(params[n]) for n in names)
    coords = {}
    for n in names:
        units, long_name = parameter_info(n)
        values = params[n]
        arr = np.array(values, dtype=object if isinstance(values[0], str) else None)
        if arr.dtype == object:
            arr = arr.astype(str)
        coords[n] = xr.Variable((n,), arr, attrs={"units": units, "long_name": long_name} if units else
                                {"long_name": long_name})
    data = {}
    for key, (units, long_name, typ) in RESULTS.items():
        a = np.zeros(shape, dtype=np.int64 if typ is int else float)
        for (idx, _ov), res in zip(cases, results):
            a[idx] = res[key] if res is not None else (0 if typ is int else np.nan)
        data[key] = xr.Variable(names, a, attrs={"units": units, "long_name": long_name})
    status = np.empty(shape, dtype=object)
    error = np.empty(shape, dtype=object)
    for (idx, _ov), res in zip(cases, results):
        status[idx] = res["status"] if res is not None else "failed"
        error[idx] = res["error"] if res is not None else "no result"
    data["status"] = xr.Variable(names, status.astype(str),
                                 attrs={"long_name": "case status: ok, invalid, stopped, failed or interrupted"})
    data["error"] = xr.Variable(names, error.astype(str), attrs={"long_name": "error message ('' if ok)"})
    source = source or SetupSource()
    try:
        base_setup = source.column_setup({})
        base_json = json.dumps(base_setup.to_dict())
        model = continuum_label(base_setup)
    except Exception as exc:  # noqa: BLE001 - only provenance
        base_json = model = f"unavailable: {_one_line(exc)}"
    n_ok = int(np.sum(status == "ok"))
    attrs = {
        "title": "bsrflow parameter sweep of the tapped column",
        "bsrflow_version": __version__,
        "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "swept_parameters": " ".join(names),
        "cases": len(cases), "cases_ok": n_ok, "cases_failed": len(cases) - n_ok,
        "config_path": source.path or "",
        "config_reader": ("bsrflow.io.config" if source.uses_config_module else
                          ("fallback TOML reader" if source.path else "ColumnSetup defaults")),
        "config": source.text,
        "base_setup": base_json,
        "model": model,
        "fixed_overrides": json.dumps(source.fixed),
    }
    return xr.Dataset(data, coords=coords, attrs=attrs)


def write_dataset(ds, path):
    """Write the sweep Dataset as netCDF (xarray's default engine)."""
    d = os.path.dirname(os.path.abspath(path))
    os.makedirs(d, exist_ok=True)
    ds.to_netcdf(path)


def sweep_figure(ds, path, variable: str = "top_max_over_d"):
    """Top height (``variable``) against the first swept parameter, one line per value of the
    second (per combination of the others); failed cases are gaps, counted in the title."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = ds.attrs["swept_parameters"].split()
    first, rest = names[0], names[1:]
    xv = ds[first].values
    numeric = np.issubdtype(xv.dtype, np.number)
    xs = xv if numeric else np.arange(xv.size)
    y = ds[variable]
    fig, ax = plt.subplots(figsize=(8, 5))
    combos = list(itertools.product(*[range(ds.sizes[n]) for n in rest])) or [()]
    for combo in combos:
        sel = {n: i for n, i in zip(rest, combo)}
        line = y.isel(sel).values
        label = ", ".join(f"{n} = {_fmt(ds[n].values[i])}{_unit(ds[n])}" for n, i in sel.items()) or None
        ax.plot(xs, line, "o-", label=label)
    if not numeric:
        ax.set_xticks(xs, [str(v) for v in xv])
    units, long_name = ds[first].attrs.get("units", ""), ds[first].attrs.get("long_name", first)
    ax.set_xlabel(f"{long_name} [{units}]" if units else long_name)
    yu = y.attrs.get("units", "")
    ax.set_ylabel("maximum top height / d" if variable == "top_max_over_d" else
                  (f"{y.attrs.get('long_name', variable)} [{yu}]" if yu else variable))
    failed = int(ds.attrs.get("cases_failed", 0))
    ax.set_title(f"parameter sweep: {ds.attrs.get('cases', '?')} cases"
                 + (f", {failed} failed (gaps)" if failed else ""))
    ax.grid(alpha=0.3)
    if combos != [()]:
        ax.legend(fontsize=8)
    fig.tight_layout()
    d = os.path.dirname(os.path.abspath(path))
    os.makedirs(d, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _unit(coord) -> str:
    u = coord.attrs.get("units", "")
    return f" {u}" if u and u != "1" else ""


def _fmt(v):
    return f"{v:g}" if isinstance(v, (float, np.floating)) else str(v)


# ----------------------------------------------------------------------------- command line


def add_parser(sub):
    helptext = "parameter sweep of the tapped column on dask.distributed (netCDF of scalar results, figure)"
    p = sub.add_parser("sweep", help=helptext, description=helptext)
    p.add_argument("config", metavar="CONFIG", nargs="?", default=None,
                   help="column configuration (TOML); default: the built-in ColumnSetup defaults")
    p.add_argument("--param", action="append", default=[], metavar="NAME=START:STOP:NUM|NAME=V1,V2,...",
                   help="a swept parameter (repeatable; one dimension each)")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="fix a parameter for every case (repeatable)")
    p.add_argument("--scheduler", metavar="ADDRESS", default=None,
                   help="address of a running dask scheduler (default: start a LocalCluster)")
    p.add_argument("--workers", type=Number(int, workers_range), default=None,
                   help="LocalCluster worker processes (default 2; at most 4 per CPU; not with --scheduler)")
    p.add_argument("--out", default="sweep.nc", metavar="FILE.nc",
                   help="netCDF output (default sweep.nc; its folder must exist)")
    p.add_argument("--figure", default=None, metavar="F.png",
                   help="write the top-height figure here (its folder must exist)")
    p.set_defaults(func=_main)


def _check_figure_format(path) -> None:
    """``--figure``'s suffix is an image format matplotlib writes (checked before the sweep)."""
    from matplotlib.figure import Figure

    formats = sorted(Figure().canvas.get_supported_filetypes())
    ext = os.path.splitext(path)[1].lower().lstrip(".")
    if ext not in formats:
        raise ValueError(f"--figure {path}: the suffix {('.' + ext) if ext else '(none)'} is not an image "
                         f"format (valid: {', '.join('.' + f for f in formats)})")


def _main(args) -> int:
    from ..io.paths import check_distinct, check_output_file

    check_distinct(("CONFIG", args.config), ("--out", args.out), ("--figure", args.figure))
    check_output_file(args.out, "--out")
    if args.figure:
        check_output_file(args.figure, "--figure")
        _check_figure_format(args.figure)
    if args.scheduler and args.workers is not None:
        raise ValueError("--workers sets the size of the LocalCluster; with --scheduler the scheduler's own "
                         "workers run the cases: leave --workers out")
    workers = 2 if args.workers is None else args.workers
    if not 1 <= workers <= max_workers():
        raise ValueError(f"--workers {workers} is outside the valid range {workers_range()}")
    check_given_once(("--set", item.strip()) for item in args.set)
    check_no_run_outputs("sweep cases write", [(opt, item.partition("=")[0].strip())
                                               for opt, items in (("--param", args.param), ("--set", args.set))
                                               for item in items])
    params = parse_params(args.param)
    fixed = {}
    for item in args.set:
        key, sep, value = item.partition("=")
        key, value = key.strip(), value.strip()
        if not sep or not key or not value:
            raise ValueError(f"--set {item!r} is not NAME=VALUE")
        if canonical_name(key) in {canonical_name(n) for n in params}:
            raise ValueError(f"--set {key}: the parameter is also swept with --param")
        fixed[key] = coerce_value(key, parse_value(value))
    source = SetupSource.load(args.config)
    config = getattr(source, "config", None)
    check_no_run_outputs("sweep cases write", (), config, args.config)
    if fixed:
        source = source.with_fixed(fixed)
    n = int(np.prod([len(v) for v in params.values()]))
    check_cases(params, source)                        # every case, before any cluster starts
    swept = {canonical_name(n) for n in params}
    if "restitution" in swept and not swept & {"kernel", "kernel_name"}:
        if source.column_setup({}).kernel_name == "seed":
            raise ValueError("--param restitution: the seed kernel's continuum does not use it (its dissipation is "
                             "kernel_dissipation; e is the DEM's and the packing law's): sweep kernel_dissipation")
    set_restitution = next((k for k in fixed if canonical_name(k) == "restitution"), None)
    if set_restitution is not None and not swept & {"kernel", "kernel_name"}:
        if source.column_setup({}).kernel_name == "seed":
            raise ValueError(f"--set {set_restitution}: the seed kernel's continuum does not use it (its dissipation "
                             "is kernel_dissipation; e is the DEM's and the packing law's): leave it out")
    if args.scheduler:
        check_scheduler(args.scheduler)
    where = args.scheduler or f"a LocalCluster of {workers} worker processes"
    try:
        if {canonical_name(n) for n in params} & {"kernel", "kernel_name", "formulation", "range_over_d"}:
            model = " (the continuum itself is swept)"
        else:
            model = f" of the {continuum_label(source.column_setup({}))}"
    except Exception:  # noqa: BLE001 - the cases were checked; only the wording
        model = ""
    print(f"bsrflow sweep: {n} case(s){model} over {', '.join(params)} on {where}"
          + (f"; config {args.config} ({'bsrflow.io.config' if source.uses_config_module else 'fallback reader'})"
             if args.config else ""))
    try:                                     # SIGTERM raises as Ctrl-C does: bsrflow.cli.main
        ds = run_sweep(params, source, scheduler=args.scheduler, n_workers=workers)
    except KeyboardInterrupt as exc:
        partial = getattr(exc, "partial", None)
        how = "by SIGTERM" if getattr(exc, "signal_name", "") == "SIGTERM" else "by Ctrl-C (SIGINT)"
        if partial is None:
            exc.args = (f"interrupted {how} before any case finished; {args.out} was not written",)
        else:
            write_dataset(partial, args.out)
            exc.args = (f"interrupted {how} {partial.attrs['interrupted']}: {args.out} keeps the finished "
                        "cases' results (the others have status \"interrupted\"; run them again)",)
        exc.exit_code = 128 + int(getattr(exc, "signal_number", 2))
        raise
    write_dataset(ds, args.out)
    print(f"wrote {args.out}")
    if args.figure:
        sweep_figure(ds, args.figure)
        print(f"wrote {args.figure}")
    failed = int(ds.attrs["cases_failed"])
    if failed:
        print(f"bsrflow sweep: {failed} of {n} case(s) did not succeed (status and error recorded in {args.out})",
              file=sys.stderr)
        return 3
    return 0
