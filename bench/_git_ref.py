"""A module of the package as an earlier commit had it, for the A/B scripts (``ab_step.py``,
``ab_bed_step.py``): read with ``git show`` and compiled beside the working tree's."""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys


def load_module_at(ref: str, module: str, tmp: str):
    """``bsrflow.numerics.<module>`` of commit ``ref`` as a standalone module ``ref_<module>``
    written into the folder ``tmp``: its numba cache off, its relative imports made absolute.
    CalledProcessError when git cannot show it."""
    root = subprocess.run(["git", "rev-parse", "--show-toplevel"], capture_output=True, text=True, check=True,
                          cwd=os.path.dirname(os.path.abspath(__file__))).stdout.strip()
    src = subprocess.run(["git", "show", f"{ref}:src/bsrflow/numerics/{module}.py"], capture_output=True,
                         text=True, check=True, cwd=root).stdout
    src = (src.replace("cache=True", "cache=False").replace("from ..", "from bsrflow.")
           .replace("from . import ", "from bsrflow.numerics import ").replace("from .", "from bsrflow.numerics."))
    path = os.path.join(tmp, f"ref_{module}.py")
    with open(path, "w") as fh:
        fh.write(src)
    spec = importlib.util.spec_from_file_location(f"ref_{module}", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod                  # dataclasses look their module up
    spec.loader.exec_module(mod)
    return mod
