"""Which of numba's threading layers runs the package's parallel loops.

numba picks, by default, the first of tbb, omp and workqueue that it can load.  On this project's
VM (numba 0.68.1, the system's libtbb) every launch of a parallel region under tbb kept about
7 kB that was never freed: 20 000 launches of a trivial ``prange`` loop grew the process by
141 MB, from Python as from compiled code, and a 3-D Eulerian bed, whose steps launch a dozen
regions each, grew by 25 MB per 300 steps and ran 5× slower after 5000 steps (2026-12-05;
``tests/test_numba_threads.py`` repeats the trivial case).  omp and workqueue kept the memory
flat, and omp stepped that bed 2.2× faster than one thread against workqueue's 1.2×.

:func:`prefer_leak_free_layers` therefore sets numba's priority to omp, workqueue, tbb before
any parallel loop runs, unless the user chose with ``NUMBA_THREADING_LAYER`` or
``NUMBA_THREADING_LAYER_PRIORITY`` (then the user's choice stands).  omp needs the GNU OpenMP
runtime (``libgomp``); where it is missing numba falls back to workqueue.  The package's
worker pools spawn their processes (omp is not fork-safe), and its Dask sweeps run single-
threaded worker processes (workqueue is not thread-safe).

:func:`prefer_passive_omp_wait` sets ``OMP_WAIT_POLICY=PASSIVE`` unless the user set it: GNU
OpenMP's threads otherwise spin between parallel regions, and where another process shares the
cores a 16 × 16 × 49 Eulerian bed stepped slower on two threads than on one (5.5–6.2 s against
3.4–4.2 s for the same span, load about 4 on this 2-core VM; passive 3.5–4.3 s).  On the quiet
machine passive lost nothing (two threads 1.05 s against 1.14 s spinning; the 64³ packing step's
2-thread efficiency 0.98 against 0.92; one-off runs of 2026-12-05).
"""

from __future__ import annotations

import os

PRIORITY = ["omp", "workqueue", "tbb"]


def prefer_leak_free_layers() -> list | None:
    """Set ``numba.config.THREADING_LAYER_PRIORITY`` to :data:`PRIORITY` (module docstring);
    returns it, or None when the user's environment chose a layer or an order."""
    if os.environ.get("NUMBA_THREADING_LAYER") or os.environ.get("NUMBA_THREADING_LAYER_PRIORITY"):
        return None
    import numba

    numba.config.THREADING_LAYER_PRIORITY = list(PRIORITY)
    return list(PRIORITY)


def prefer_passive_omp_wait() -> str | None:
    """Set ``OMP_WAIT_POLICY=PASSIVE`` in the environment (read by GNU OpenMP once, when it loads:
    with numba's omp layer, at the first parallel loop, after this) unless the user set it or GNU
    OpenMP is loaded already (by another library imported first; then setting it would change
    nothing here and only the child processes), module docstring; returns the value set, or None."""
    if os.environ.get("OMP_WAIT_POLICY") or _gomp_loaded():
        return None
    os.environ["OMP_WAIT_POLICY"] = "PASSIVE"
    return "PASSIVE"


def _gomp_loaded() -> bool:
    """True when this process has GNU OpenMP (libgomp) loaded (Linux: /proc/self/maps; False
    where that cannot be read)."""
    try:
        with open("/proc/self/maps") as fh:
            return "libgomp" in fh.read()
    except OSError:
        return False

