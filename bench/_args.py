"""Argument types shared by the bench scripts: a bad value is a clear argparse error that names
the option and the valid range."""

from __future__ import annotations

import argparse


def positive_int(text: str) -> int:
    """An integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value} outside the valid range [1, inf)")
    return value


def positive_float(text: str) -> float:
    """A finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not 0.0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"{value} outside the valid range (0, inf)")
    return value


def list_of(item):
    """A comma-separated list of values of the argument type ``item`` (e.g. ``positive_int``)."""
    def parse(text: str) -> list:
        return [item(part) for part in text.split(",")]
    parse.__name__ = f"comma-separated list of {item.__name__}"
    return parse


def merge_json(path: str, key: str, value) -> None:
    """Put ``value`` under ``key`` in the JSON file ``path`` (kept: the other keys there) and say so."""
    import json
    import os

    data = {}
    if os.path.exists(path):
        with open(path) as fh:
            data = json.load(fh)
    data[key] = value
    with open(path, "w") as fh:
        json.dump(data, fh, indent=2)
    print(f"wrote {path} (key {key})")


def output_json(text: str) -> str:
    """An output file path under the package's rule (:func:`bsrflow.io.paths.check_output_file`:
    its folder must exist and be writable; missing folders are not created), checked before the
    benchmark runs."""
    from bsrflow.io.paths import OutputPathError, check_output_file
    try:
        return check_output_file(text, "--json")
    except OutputPathError as exc:
        raise argparse.ArgumentTypeError(str(exc).partition(": ")[2] or str(exc)) from None
