"""Command-line interface: ``bsrflow <command> [options]``.

Each command lives in its own module that defines ``add_parser(subparsers)``; the parser it
adds sets ``func(args) -> int``.  Exit codes: 0 success, 2 invalid input (one line on
stderr naming the problem), 3 a simulation stopped early (the message says when and where;
outputs written so far are kept), 130 (143) interrupted by Ctrl-C (SIGTERM), 141 the reader of
the standard output went away (``| head``), 1 a write that failed during the work (a full disk:
one line) or anything unexpected.
"""

from __future__ import annotations

import argparse
import importlib
import os
import re
import sys

from . import __version__

# (module defining add_parser) -- one line per command
COMMAND_MODULES = [
    "bsrflow.analysis.verify",
    "bsrflow.analysis.compare",
    "bsrflow.analysis.energy",
    "bsrflow.analysis.stability",
    "bsrflow.analysis.compare_dump",
    "bsrflow.analysis.compare_bed",
    "bsrflow.tools.plot_file",
    "bsrflow.tools.sweep",
    "bsrflow.io.commands",
]


class Number:
    """The ``type`` of a numeric option: parses as ``kind`` (int or float) and carries the option's
    valid range ``valid`` (text, or a function giving it when the range is known only at run time)
    for the one-line error of a value that does not parse (``--cells abc``: the range, not only
    "invalid int value").  The command checks the range of a parsed value itself, as before."""

    def __init__(self, kind, valid):
        self.kind, self._valid = kind, valid
        self.__name__ = kind.__name__          # argparse names the type by it

    def __call__(self, text):
        return self.kind(text)

    @property
    def valid(self) -> str:
        return self._valid() if callable(self._valid) else self._valid


def max_workers() -> int:
    """The most worker processes a command takes: 4 per CPU of this machine."""
    return 4 * (os.cpu_count() or 1)


def workers_range() -> str:
    return f"[1, {max_workers()}] (4 per CPU of this machine)"


class _OneLineErrors(argparse.ArgumentParser):
    """argparse with the package's error form: one line on stderr, ``prog: error: message``,
    exit code 2 (no usage block; ``--help`` gives it).  A negative number in exponent form
    (``--dt -5e-6``) or ``-inf`` / ``-nan`` is read as a value, as ``-0.5`` is, so that its range
    check names it (argparse took it for an option: "expected one argument")."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = re.compile(r"^-((\d+\.?\d*|\.\d+)([eE][-+]?\d+)?|inf|infinity|nan)$",
                                                   re.IGNORECASE)

    def _get_value(self, action, arg_string):
        """A value that does not parse as the option's number is one line naming the option and its
        valid range (:class:`Number`'s, or the option's choices)."""
        try:
            return super()._get_value(action, arg_string)
        except argparse.ArgumentError:
            if isinstance(action.type, Number):
                valid = action.type.valid
            elif action.choices is not None and action.type in (int, float):
                valid = "{" + ", ".join(map(str, action.choices)) + "}"
            else:
                raise
            noun = "an integer" if getattr(action.type, "__name__", "") == "int" else "a number"
            name = "/".join(action.option_strings) or action.metavar or action.dest
            raise argparse.ArgumentError(None, f"{name} {arg_string!r} is not {noun}; valid range: "
                                               f"{valid}") from None

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {' '.join(str(message).split())}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _OneLineErrors(
        prog="bsrflow",
        description="Granular flows with the BSR integro-PDE model (Blackmore-Samulyak-Rosato).")
    parser.add_argument("--version", action="version", version=f"bsrflow {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        importlib.import_module(name).add_parser(sub)
    parser.allow_abbrev = False                 # `bsrflow --vers` is not --version either
    for command_parser in sub.choices.values():
        # no abbreviated options: `--ou b.nc` after `--out a.nc` would set --out twice past the
        # "given twice" check (argparse keeps the last), and an abbreviation that a later option
        # makes ambiguous would break scripts
        command_parser.allow_abbrev = False
    return parser


def _given_twice(parser, argv) -> str | None:
    """The first single-valued option of the chosen command that ``argv`` gives twice (argparse
    would keep the last silently; repeatable options such as ``--set`` are ``append`` actions)."""
    sub = next((a for a in parser._actions if isinstance(a, argparse._SubParsersAction)), None)
    command = next((w for w in argv if not w.startswith("-")), None)
    if sub is None or command not in sub.choices:
        return None
    words = [w.split("=", 1)[0] for w in argv[argv.index(command) + 1:] if w.startswith("--")]
    for action in sub.choices[command]._actions:
        if isinstance(action, (argparse._AppendAction, argparse._CountAction, argparse._HelpAction)):
            continue
        if sum(words.count(o) for o in action.option_strings) > 1:
            return "/".join(action.option_strings)
    return None


def _empty_value(parser, args) -> str | None:
    """The first option or argument of the chosen command given as an empty (or blank) string:
    no command takes one (an empty path was silently taken as "not given", or named nothing)."""
    sub = next((a for a in parser._actions if isinstance(a, argparse._SubParsersAction)), None)
    if sub is None or args.command not in sub.choices:
        return None
    for action in sub.choices[args.command]._actions:
        if isinstance(action, argparse._HelpAction) or action.dest in (argparse.SUPPRESS, None):
            continue
        value = getattr(args, action.dest, None)
        if value is action.default:
            continue
        values = value if isinstance(value, list) else [value]
        if any(isinstance(v, str) and not v.strip() for v in values):
            return action.option_strings[0] if action.option_strings else (action.metavar or action.dest)
    return None


def main(argv=None) -> int:
    from .io.commands import _sigterm_as_interrupt
    # SIGTERM ends every command as Ctrl-C does (one line, exit 143 / 130), from before the
    # command modules are imported (a signal in the first ~0.4 s, while Python imports numba,
    # still meets Python's defaults)
    with _sigterm_as_interrupt():
        return _main(argv)


def _interrupted(prefix, exc) -> int:
    """One line for a Ctrl-C / SIGTERM (its message, or what it was), and its exit code."""
    print(f"{prefix}: {' '.join(str(exc).split()) or 'interrupted by Ctrl-C (SIGINT)'}", file=sys.stderr)
    return int(getattr(exc, "exit_code", 130))


def _main(argv) -> int:
    try:
        parser = build_parser()
    except KeyboardInterrupt as exc:
        return _interrupted("bsrflow", exc)
    argv = list(sys.argv[1:] if argv is None else argv)
    args, unknown = parser.parse_known_args(argv)
    if unknown:
        command = getattr(args, "command", None)
        at = argv.index(command) if command in argv else len(argv)
        before = any(w in argv[:at] for w in unknown)       # words before the command are bsrflow's
        where = f"bsrflow {command}" if command and not before else "bsrflow"
        hint = "options are not abbreviated; " if any(w.startswith("--") for w in unknown) else ""
        print(f"{where}: error: unrecognized arguments: {' '.join(unknown)} ({hint}`{where} --help` lists "
              f"what it takes)", file=sys.stderr)
        return 2
    if not getattr(args, "func", None):
        print("bsrflow: error: a COMMAND is required; `bsrflow --help` lists them", file=sys.stderr)
        return 2
    twice = _given_twice(parser, argv)
    if twice:
        print(f"bsrflow {args.command}: error: {twice} is given twice; give it once", file=sys.stderr)
        return 2
    empty = _empty_value(parser, args)
    if empty:
        hint = "give a value or leave the option out" if empty.startswith("-") else "give a value"
        print(f"bsrflow {args.command}: error: {empty} is empty; {hint}", file=sys.stderr)
        return 2
    from .numerics.solver import SimulationError
    try:
        return int(args.func(args) or 0)
    except SimulationError as exc:
        print(f"bsrflow {args.command}: {exc}", file=sys.stderr)
        return 3
    except (ValueError, FileNotFoundError) as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        print(f"bsrflow {args.command}: error: {msg}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:
        # the commands put what was kept (and for a run whether --resume can continue)
        return _interrupted(f"bsrflow {args.command}", exc)
    except BrokenPipeError:
        # the reader of the standard output went away (``bsrflow ... | head``): stop quietly with
        # the shell's code for SIGPIPE, as Unix tools do; stdout goes to /dev/null so that the
        # interpreter's final flush does not fail again
        try:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (OSError, ValueError):
            pass
        return 141
    except OSError as exc:
        # a write that failed during the work (a full disk, a file system gone read-only):
        # one line; `bsrflow run` words it with what the output keeps (bsrflow.io.runner.write_failed)
        print(f"bsrflow {args.command}: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
