"""Where numba keeps the package's compiled functions: one folder per version of the compiled
source, so that a cached function never outlives a change of code it calls.

numba's on-disk cache (``cache=True``) checks only the source file of the function it caches:
a function of ``packing_nd.py`` that calls one of ``packing_kernels.py`` (compiled into it)
kept running the old callee after ``packing_kernels.py`` changed (a review, 2026-12-02: the 1-D
solver recompiled, the 2-D one went on with the old flux).  :func:`use_versioned_cache_dir`
therefore points numba at ``<cache>/bsrflow/numba/<hash>``, the hash of every module of the
package that uses numba; a change to any of them (an edit, a ``git pull``, an upgrade) starts a
fresh cache, compiled once (about a minute for everything), and the folders of older versions
are removed but for the two most recent.  ``<cache>`` is ``$XDG_CACHE_HOME`` or ``~/.cache``.
A ``NUMBA_CACHE_DIR`` set by the user is left alone (its staleness is then the user's), and
where no cache folder can be written numba's own default is kept.
"""

from __future__ import annotations

import hashlib
import os
import shutil
from pathlib import Path

KEEP = 3
"""Cache folders kept (the current one and the two most recently used before it)."""


def source_hash(package: Path) -> str:
    """SHA-1 (16 hex digits) of the modules under ``package`` that use numba, with their paths."""
    h = hashlib.sha1()
    for path in sorted(package.rglob("*.py")):
        text = path.read_bytes()
        if b"numba" in text:
            h.update(path.relative_to(package).as_posix().encode())
            h.update(b"\0")
            h.update(text)
    return h.hexdigest()[:16]


def use_versioned_cache_dir(package: Path | None = None) -> str | None:
    """Set ``numba.config.CACHE_DIR`` (module docstring) before any compiled function of the
    package is defined; returns the folder, or None when the default is kept."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return None
    package = Path(package or Path(__file__).resolve().parent)
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "bsrflow" / "numba"
    try:
        target = base / source_hash(package)
        target.mkdir(parents=True, exist_ok=True)
        probe = target / f".write-test-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
        os.utime(target)                                   # most recently used
    except OSError:
        return None
    import numba

    numba.config.CACHE_DIR = str(target)
    try:
        old = sorted((p for p in base.iterdir() if p.is_dir() and p != target),
                     key=lambda p: p.stat().st_mtime, reverse=True)
        for p in old[KEEP - 1:]:
            shutil.rmtree(p, ignore_errors=True)
    except OSError:
        pass
    return str(target)
