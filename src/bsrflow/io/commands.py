"""``bsrflow init`` and ``bsrflow run``: configuration files and runs into netCDF files.

    bsrflow init column.toml                   # commented default config (refuses to overwrite)
    bsrflow run column.toml --out column.nc    # validate, run, write snapshots as it goes
    bsrflow run column.toml --resume           # continue a killed run from <out>.ckpt

Exit codes (``bsrflow.cli``): 0 ok; 2 invalid input, one line on stderr
``bsrflow run: error: <field>: <problem>``; 3 the simulation stopped early (the file keeps the
snapshots saved so far, its ``status`` attribute says why); 130 interrupted by Ctrl-C, 143 by
SIGTERM (both handled alike: status "interrupted ...", and a message saying what was kept and
whether ``--resume`` can continue).
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading

from .config import Config, ConfigError, default_config_text, load_config, parse_override
from .paths import check_output_file

__all__ = ["add_parser"]

_LAYER_KINDS = ("tapped_layer", "vibrated_box", "packing_bed", "granular_bed", "granular_bed_eulerian")
"""The kinds of ``bsrflow init --layer`` (:data:`bsrflow.io.layer_runner.KINDS`, tested equal; not imported
here so that ``bsrflow --help`` stays fast)."""


def add_parser(sub):
    p = sub.add_parser("init", help="write a commented default config (TOML) for `bsrflow run`",
                       description="Write a commented default configuration of the tapped column "
                                   "(units and valid ranges in the comments).")
    p.add_argument("path", metavar="PATH", help="file to write, e.g. column.toml (its folder must exist)")
    p.add_argument("--force", action="store_true", help="overwrite PATH if it exists and is a bsrflow config (or empty)")
    p.add_argument("--kernel", choices=("seed", "packing"), default=None,
                   help="the interaction of the config: the seed's kernel (default; m0 and kernel_dissipation "
                        "calibrated) or the packing continuum (nothing fitted)")
    p.add_argument("--layer", metavar="KIND", choices=_LAYER_KINDS, default=None,
                   help="write a 2-D / 3-D layer or vibrated-bed config of this kind instead of a column's: "
                        + ", ".join(_LAYER_KINDS) + " (every field with its default, valid range and unit)")
    p.set_defaults(func=_init)

    p = sub.add_parser("run", help="run a config (TOML) into a netCDF file, with checkpoints and --resume",
                       description="Validate CONFIG, run the tapped column (or, for a config with a "
                                   "[layer] table, a 2-D / 3-D layer, with optional VTK output, or "
                                   "kind = \"granular_bed\", the vibrated bed of compare-bed, or "
                                   "\"granular_bed_eulerian\", that bed on a 1-, 2- or 3-D Eulerian grid; "
                                   "bsrflow.io.layer_runner) and write snapshots to a netCDF4 file as "
                                   "the run goes.")
    p.add_argument("config", metavar="CONFIG", help="TOML config (see `bsrflow init`)")
    p.add_argument("--out", metavar="FILE.nc", help="output file (default: CONFIG with the suffix .nc; "
                   "its folder must exist), replaced if it exists (unless --resume); checkpoints go to "
                   "FILE.nc.ckpt")
    p.add_argument("--resume", action="store_true", help="continue from FILE.nc.ckpt (same config)")
    p.add_argument("--quiet", action="store_true", help="no progress bar, no summary")
    p.add_argument("--scheme", choices=("seed", "accurate"), help="override numerics.scheme (column configs)")
    p.add_argument("--set", metavar="KEY=VALUE", action="append", default=[],
                   help="override a config value, e.g. --set tap.a_over_d=0.5 or --set f=12 (repeatable); "
                   "for a layer config layer.<field>, a bare field or output.<key>, e.g. --set gamma=4; "
                   "--resume takes the same items")
    p.set_defaults(func=_run)


class _Terminated(KeyboardInterrupt):
    """SIGTERM, handled like Ctrl-C (the run's file gets status "interrupted ..."); exit code 143
    unless the run words it otherwise."""

    signal_name = "SIGTERM"
    signal_number = int(signal.SIGTERM)
    exit_code = 128 + int(signal.SIGTERM)

    def __init__(self, *args):
        super().__init__(*(args or ("interrupted by SIGTERM",)))


_PENDING_SIGNALS: list = []
"""Signals received inside :func:`_sigterm_as_interrupt` whose interrupt has not reached the
command yet.  An exception raised while numba compiles, inside one of llvmlite's ctypes callbacks,
is swallowed there (Python prints "Exception ignored ..." with a traceback and goes on; a review,
2026-12-02), so the handler does not raise in such a callback: it records the signal and sends it
again 0.25 s later (:func:`_resend_later`) until it arrives in ordinary Python code, where it
raises.  :func:`_raise_pending` raises a recorded one at a command's progress call."""

_RESEND = {"timer": None, "resent": False, "raised": False, "lock": threading.RLock()}
"""The lock is reentrant: a second signal can run the handler again in the main thread while the
first still holds it (GNU ``timeout`` sends SIGTERM to the command and then to its process group,
so the command gets two at once); with a plain lock the inner handler waited for good (a sweep
hung so, 2026-12-04)."""
RESEND_DELAY_S = 0.25


def _in_swallowing_callback(frame) -> bool:
    """True when the signal arrived where an exception may be swallowed (printed as "Exception
    ignored in ..." with a traceback, and the program goes on): llvmlite's Python code (numba
    compiling; its ctypes callbacks), a weakref callback (weakref.py, called by the garbage
    collector: seen in a review, 3 of 16 SIGTERMs to a running `bsrflow run`), a ``__del__``."""
    if frame is None:
        return False
    code = frame.f_code
    return "llvmlite" in code.co_filename or code.co_filename.endswith("weakref.py") or code.co_name == "__del__"


def _resend_later(signum) -> None:
    """Send ``signum`` to this process again after RESEND_DELAY_S, unless an interrupt has been
    raised by then."""
    def resend():
        with _RESEND["lock"]:
            _RESEND["timer"] = None
            if _RESEND["raised"] or not _PENDING_SIGNALS:
                return
            _RESEND["resent"] = True
        os.kill(os.getpid(), signum)
    with _RESEND["lock"]:
        if _RESEND["timer"] is None and not _RESEND["raised"]:
            _RESEND["timer"] = threading.Timer(RESEND_DELAY_S, resend)
            _RESEND["timer"].daemon = True
            _RESEND["timer"].start()


def _mark_raised() -> None:
    with _RESEND["lock"]:
        _RESEND["raised"] = True
        if _RESEND["timer"] is not None:
            _RESEND["timer"].cancel()
            _RESEND["timer"] = None


def _raise_pending():
    """Raise the interrupt of a signal recorded in :data:`_PENDING_SIGNALS` (and forget it)."""
    with _RESEND["lock"]:
        signum = _PENDING_SIGNALS[-1] if _PENDING_SIGNALS else None
        _PENDING_SIGNALS.clear()
    if signum is not None:
        _mark_raised()
        raise _Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()


_HOLD = {"depth": 0}


@contextlib.contextmanager
def signals_held():
    """Inside :func:`_sigterm_as_interrupt`, a Ctrl-C or SIGTERM that arrives while the block
    runs is raised when it ends, so that a group of writes (one snapshot's netCDF and VTK files)
    is never cut in between; an exception of the block's own goes out as it is (a signal pending
    then is dropped: the run ends with that error, not as interrupted)."""
    _HOLD["depth"] += 1
    try:
        yield
    finally:
        _HOLD["depth"] -= 1
    if _HOLD["depth"] == 0:
        _raise_pending()


def together(*observers):
    """One observer that calls ``observers`` in order inside :func:`signals_held` (a snapshot
    written to every output, or, if interrupted, the interrupt raised after all of them)."""
    def observe(*args, **kwargs):
        with signals_held():
            for obs in observers:
                obs(*args, **kwargs)
    return observe


@contextlib.contextmanager
def _sigterm_as_interrupt():
    """While the block runs, SIGTERM raises :class:`_Terminated` (a KeyboardInterrupt) in the
    main thread, so a terminated run closes its file as an interrupted one does; a signal that
    arrives while numba compiles is delivered again once the compiler is back in ordinary code
    (:data:`_PENDING_SIGNALS`).  `bsrflow.cli.main` runs every command inside it."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        with _RESEND["lock"]:
            if _RESEND["resent"]:
                _RESEND["resent"] = False
                if _RESEND["raised"]:
                    return                  # the resent copy of a signal raised meanwhile
            if signum not in _PENDING_SIGNALS:
                _PENDING_SIGNALS.append(signum)
        if _in_swallowing_callback(frame):
            _resend_later(signum)           # not raised here: the callback would swallow it
            return
        if _HOLD["depth"] > 0:
            return                          # raised at the end of signals_held()
        _mark_raised()
        raise _Terminated() if signum == signal.SIGTERM else KeyboardInterrupt()

    with _RESEND["lock"]:
        _PENDING_SIGNALS.clear()
        _RESEND["resent"] = _RESEND["raised"] = False
    old_term = signal.signal(signal.SIGTERM, handler)
    old_int = signal.signal(signal.SIGINT, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old_term)
        signal.signal(signal.SIGINT, old_int)
        with _RESEND["lock"]:
            _PENDING_SIGNALS.clear()
            if _RESEND["timer"] is not None:
                _RESEND["timer"].cancel()
                _RESEND["timer"] = None


def _replaceable_config(path: str) -> bool:
    """True for a file ``bsrflow init --force`` may replace: empty, or TOML (comments only, too) whose tables are all
    bsrflow's (a column config's or a layer config's), so that --force never overwrites another
    kind of file (an audit, running as root, overwrote /etc/passwd with it)."""
    import tomllib

    from .config import FIELDS
    try:
        with open(path, "rb") as fh:
            raw = fh.read()
        if not raw.strip():
            return True
        data = tomllib.loads(raw.decode("utf-8"))
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError):
        return False
    tables = {f.name.split(".")[0] for f in FIELDS} | {"layer", "output", "tracers"}
    return all(isinstance(v, dict) and k in tables for k, v in data.items())


def _init(args) -> int:
    path = check_output_file(args.path, "PATH")
    if os.path.exists(path) and not args.force:
        raise ConfigError(path, "exists; use --force to overwrite it")
    if os.path.exists(path) and not _replaceable_config(path):
        raise ConfigError(path, "exists and is not a bsrflow config (not empty, not TOML with bsrflow's tables): "
                          "--force replaces only configs; remove it yourself or choose another path")
    if args.layer is not None and args.kernel is not None:
        raise ConfigError("--kernel", "is not taken with --layer (the layer's kind sets its interaction)")
    if args.layer is not None:
        from .layer_runner import default_layer_config_text
        text = default_layer_config_text(args.layer)
    else:
        text = default_config_text(args.kernel or "seed")
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(text)
    print(f"wrote {path}; run it with: bsrflow run {path}")
    return 0


def _progress_bar(total, show_bar):
    """A tqdm bar of simulated time [s] and its rate [simulated s per wall s], started at its
    first call (after the solver is compiled); returns (progress(t), close())."""
    bar = None

    def progress(t):
        nonlocal bar
        _raise_pending()                     # a Ctrl-C / SIGTERM swallowed while compiling
        if not show_bar:
            return
        if bar is None:
            from tqdm import tqdm
            bar = tqdm(total=float(total), initial=float(t), unit="sim-s", desc="bsrflow run",
                       file=sys.stderr, leave=False, dynamic_ncols=True,
                       bar_format="{desc}: {percentage:3.0f}%|{bar}| t = {n:.4g}/{total:.4g} s "
                                  "[{elapsed}<{remaining}, {rate_noinv_fmt}]")
        bar.update(max(0.0, t - bar.n))

    def close():
        if bar is not None:
            bar.close()

    return progress, close


def _output_path(args) -> str:
    """``--out`` (default: CONFIG with the suffix .nc), refused when it or its checkpoint
    ``<out>.ckpt`` is the config file itself (the run would overwrite its own config)."""
    from .checkpoint import checkpoint_path
    out = args.out if args.out is not None else os.path.splitext(args.config)[0] + ".nc"
    config = os.path.realpath(args.config)
    if os.path.realpath(out) == config:
        raise ConfigError("--out", f"{out} is the config file itself; give another file name (e.g. .nc)")
    if os.path.realpath(checkpoint_path(out)) == config:
        raise ConfigError("--out", f"the checkpoint file {checkpoint_path(out)} of this output is the config file "
                                   "itself; give another file name")
    return out


def _run_layer(args) -> int:
    """`bsrflow run` of a 2-D / 3-D layer config (a [layer] table; :mod:`bsrflow.io.layer_runner`)."""
    from .layer_runner import load_layer_config, run_layer_config

    if args.scheme:
        raise ConfigError("--scheme", "is an option of column configs; for a layer use --set layer.scheme=NAME "
                          "(tapped_layer, vibrated_box)")
    cfg = load_layer_config(args.config, args.set)
    out = _output_path(args)
    progress, close = _progress_bar(cfg.setup.t_end, not args.quiet and sys.stderr.isatty())

    def log(msg):
        if not args.quiet:
            print(f"bsrflow run: {msg}", flush=True)

    try:
        outcome = run_layer_config(cfg, out, resume=args.resume, progress=progress, log=log)
    finally:
        close()
    if not args.quiet:
        print(f"bsrflow run: {outcome.summary()}")
    return 0


def _run(args) -> int:
    from .layer_runner import is_layer_config
    from .runner import run_config

    if is_layer_config(args.config):
        return _run_layer(args)
    from ..tools.setup_source import check_given_once

    config = load_config(args.config)
    overrides = dict(parse_override(item) for item in args.set)
    # option "--set:": the "<field>: <problem>" form of every `bsrflow run` error
    check_given_once((("--set:", item.strip()) for item in args.set), key=Config.resolve_key)
    if args.scheme:
        if overrides.get("numerics.scheme", args.scheme) != args.scheme:
            raise ConfigError("--scheme", f"{args.scheme} contradicts --set numerics.scheme="
                              f"{overrides['numerics.scheme']}; give one of the two")
        overrides["numerics.scheme"] = args.scheme
    if overrides:
        config = config.with_overrides(overrides)
    if config["model.kernel"] == "seed" and "column.restitution" in overrides:
        raise ConfigError("--set column.restitution", "the seed kernel's continuum does not use it (its "
                          "dissipation is column.kernel_dissipation; e is the DEM's and the packing law's): leave it out")
    if config["model.kernel"] == "packing":
        given = "--scheme" if args.scheme else next((f"--set {k}" for k in overrides if k == "numerics.scheme"), None)
        if given:
            raise ConfigError(given, "the scheme preset is an option of the seed kernel only; the packing "
                              "continuum has its own discretisation (numerics.formulation): leave it out")
    out = _output_path(args)
    quiet = bool(args.quiet)
    note = config.taps_not_reached()
    if note:
        print(f"bsrflow run: {note}", file=sys.stderr, flush=True)
    progress, close_bar = _progress_bar(config.run.t_end, not quiet and sys.stderr.isatty())

    def log(msg):
        if not quiet:
            print(f"bsrflow run: {msg}", flush=True)

    try:
        outcome = run_config(config, out, resume=args.resume, progress=progress, log=log)
    finally:
        close_bar()
    if not quiet:
        print(f"bsrflow run: {outcome.summary()}")
    return 0
