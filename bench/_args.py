"""Argument handling shared by the bench scripts, under the package's rule for bad input: one line
on stderr that names the option and its valid range, exit code 2, before any work starts.

- :class:`Parser`: argparse with that one-line error (no usage block; ``--help`` gives it);
- :func:`int_in`, :func:`float_in`, :func:`list_of`: argument types that carry their whole valid
  range, so that the range a message states is the range the script accepts;
- :func:`output_json`, :func:`merge_target`: a JSON output path checked up front (the latter
  also: an existing file must hold a JSON object to merge into); :func:`merge_json` merges;
- :func:`scratch_dir`, :func:`make_scratch_dir`: a folder for the script's own files, checked
  with the arguments and created once they are all read;
- :func:`repo_path`: a default path relative to the repository's root, so that the scripts'
  defaults work from the root and from bench/ alike.
"""

from __future__ import annotations

import argparse
import math
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


class Parser(argparse.ArgumentParser):
    """argparse whose errors are one line, ``PROG: error: MESSAGE``, exit code 2.  A negative
    number such as ``-5e-6`` or ``-inf`` is read as a value (argparse took it for an option), so
    that the option's range check names it."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$|^-(inf|infinity|nan)$",
                                                   re.IGNORECASE)

    def _get_value(self, action, arg_string):
        """A value of a ``choices=`` option that does not even parse lists the choices."""
        try:
            return super()._get_value(action, arg_string)
        except argparse.ArgumentError:
            if action.choices is None:
                raise
            raise argparse.ArgumentError(action, f"{arg_string!r} is not one of the choices: "
                                                 f"{', '.join(map(str, action.choices))}") from None

    def _check_value(self, action, value):
        if action.choices is not None and value not in action.choices:
            raise argparse.ArgumentError(action, f"{value!r} is not one of the choices: "
                                                 f"{', '.join(map(str, action.choices))}")

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {' '.join(str(message).split())}\n")


def _bound(value) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


class _InRange:
    """An argument type: a number of ``kind`` (int or float) within [lo, hi] (either end open,
    or None: unbounded).  NaN is never in range."""

    def __init__(self, kind, lo, hi, lo_open, hi_open):
        self.kind, self.lo, self.hi, self.lo_open, self.hi_open = kind, lo, hi, lo_open, hi_open
        left = "(-inf" if lo is None else ("(" if lo_open else "[") + _bound(lo)
        right = "inf)" if hi is None else _bound(hi) + (")" if hi_open else "]")
        self.valid = f"{left}, {right}"
        self.__name__ = f"{'integer' if kind is int else 'number'} in {self.valid}"

    def contains(self, value) -> bool:
        if isinstance(value, float) and math.isnan(value):
            return False
        if self.lo is not None and (value <= self.lo if self.lo_open else value < self.lo):
            return False
        if self.hi is not None and (value >= self.hi if self.hi_open else value > self.hi):
            return False
        return not (isinstance(value, float) and math.isinf(value))

    def __call__(self, text: str):
        try:
            value = self.kind(text)
        except (TypeError, ValueError):
            noun = "an integer" if self.kind is int else "a number"
            raise argparse.ArgumentTypeError(f"{text!r} is not {noun}; valid range {self.valid}") from None
        if not self.contains(value):
            raise argparse.ArgumentTypeError(f"{text} is outside the valid range {self.valid}")
        return value

    def __repr__(self):
        return self.__name__


def int_in(lo: int | None = 1, hi: int | None = None) -> _InRange:
    """An integer in [lo, hi] (None: unbounded on that side)."""
    return _InRange(int, lo, hi, False, False)


def float_in(lo: float | None = None, hi: float | None = None, lo_open: bool = False,
             hi_open: bool = False) -> _InRange:
    """A finite number between lo and hi (None: unbounded), each end closed unless ``*_open``."""
    return _InRange(float, lo, hi, lo_open, hi_open)


positive_int = int_in(1)
positive_float = float_in(0.0, lo_open=True)


def list_of(item):
    """A comma-separated list of values of the argument type ``item`` (e.g. ``int_in(1, 16)``);
    a bad one is named with the item's range."""
    def parse(text: str) -> list:
        return [item(part.strip()) for part in text.split(",")]
    parse.__name__ = f"comma-separated list of {getattr(item, '__name__', 'values')}"
    return parse


def repo_path(relative: str) -> str:
    """``relative`` (e.g. ``bench/results.json``) taken from the repository's root, written
    relative to the current folder when that is inside the repository (the same text as before
    when run from the root), else absolute."""
    full = os.path.join(ROOT, relative)
    try:
        short = os.path.relpath(full)
    except ValueError:                      # another drive (Windows)
        return full
    return full if short.startswith(os.pardir) else short


def output_json(text: str) -> str:
    """An output file path under the package's rule (:func:`bsrflow.io.paths.check_output_file`:
    its folder must exist and be writable; missing folders are not created), checked before the
    benchmark runs."""
    from bsrflow.io.paths import OutputPathError, check_output_file
    try:
        return check_output_file(text, "--json")
    except OutputPathError as exc:
        raise argparse.ArgumentTypeError(str(exc).partition(": ")[2] or str(exc)) from None


def scratch_dir(text: str) -> str:
    """A folder for a script's own files (argument type): an existing writable folder, or a
    missing one whose nearest existing parent is a writable folder. Nothing is created here
    (argparse also applies this to the default, and a later bad argument must leave no folder
    behind): :func:`make_scratch_dir` creates it once every argument is read."""
    if not text.strip():
        raise argparse.ArgumentTypeError("empty path; give a directory")
    if os.path.exists(text):
        if not os.path.isdir(text):
            raise argparse.ArgumentTypeError(f"{text} is a file; give a directory")
        if not os.access(text, os.W_OK | os.X_OK):
            raise argparse.ArgumentTypeError(f"the directory {text} is not writable")
        return text
    parent = os.path.dirname(os.path.abspath(text))
    while not os.path.exists(parent):
        parent = os.path.dirname(parent)
    if not os.path.isdir(parent) or not os.access(parent, os.W_OK | os.X_OK):
        raise argparse.ArgumentTypeError(f"cannot create the directory {text}: {parent} is not a writable folder")
    return text


def make_scratch_dir(parser: argparse.ArgumentParser, path: str) -> str:
    """Create the folder ``path`` (checked by :func:`scratch_dir`) with its parents, after the
    arguments are read and before any work; a failure is the parser's one-line error."""
    try:
        os.makedirs(path, exist_ok=True)
    except OSError as exc:
        parser.error(f"argument --dir: cannot create the directory {path} ({exc.strerror or type(exc).__name__})")
    return path


def _read_object(path: str) -> dict:
    """The JSON object in ``path`` ({} if there is no such file); ValueError if it holds something
    else, OSError if it cannot be read."""
    import json

    if not os.path.exists(path):
        return {}
    with open(path, encoding="utf-8") as fh:
        data = json.load(fh)
    if not isinstance(data, dict):
        raise ValueError(f"it holds a JSON {type(data).__name__}, not an object")
    return data


def merge_target(text: str) -> str:
    """:func:`output_json`, and an existing file must hold a JSON object (the results are merged
    into it by :func:`merge_json`), checked before the benchmark runs."""
    import json

    path = output_json(text)
    try:
        _read_object(path)
    except (OSError, ValueError) as exc:
        why = f"not JSON ({exc})" if isinstance(exc, json.JSONDecodeError) else str(exc)
        raise argparse.ArgumentTypeError(f"{path} exists but cannot be merged into: {why}; valid: a file "
                                         "holding a JSON object, or a new file") from None
    return path


def merge_json(path: str, key: str, value) -> str:
    """Put ``value`` under ``key`` in the JSON file ``path`` (kept: the other keys there) and say
    so; returns the file written.  If ``path`` can no longer be read as a JSON object (it changed
    during the run), the results go to a new file beside it, and a line on stderr says so."""
    import json

    try:
        data = _read_object(path)
    except (OSError, ValueError) as exc:
        stem, ext = os.path.splitext(path)
        n = 1
        while os.path.exists(alt := f"{stem}.{key}{'' if n == 1 else f'.{n}'}{ext or '.json'}"):
            n += 1
        with open(alt, "w") as fh:
            json.dump({key: value}, fh, indent=2)
        print(f"{os.path.basename(sys.argv[0]) or 'bench'}: warning: --json {path} could not be merged into "
              f"({type(exc).__name__}: {' '.join(str(exc).split())}); wrote the results to {alt} instead "
              f"(key {key})", file=sys.stderr)
        return alt
    data[key] = value
    with open(path, "w") as fh:
        json.dump(data, fh, indent=2)
    print(f"wrote {path} (key {key})")
    return path


def write_json(path: str, data) -> None:
    """Write ``data`` to the JSON file ``path`` (replaced) and say so."""
    import json

    with open(path, "w") as fh:
        json.dump(data, fh, indent=1)
    print(f"wrote {path}")

