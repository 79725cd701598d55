"""A pool of worker processes for the comparisons' independent runs (``compare --kernel packing
--workers``, ``compare-bed --workers``): spawned processes (no fork of a numba-compiled parent),
Ctrl-C and SIGTERM handled by the parent alone, the workers ended with it."""

from __future__ import annotations

import contextlib
import multiprocessing
import signal
import threading

__all__ = ["worker_pool"]


def _ignore_sigint():
    """Initializer of the worker processes: Ctrl-C is the parent's to handle (it stops them)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextlib.contextmanager
def worker_pool(workers: int):
    """``multiprocessing`` pool of ``workers`` spawned processes for the body of the ``with``.
    Meanwhile SIGTERM raises KeyboardInterrupt("interrupted by SIGTERM") in the parent with
    ``exit_code`` 143 (the callers keep their finished runs and exit with it); on leaving, by the
    end of the body or by any exception, the pool is terminated, ending the runs still going."""
    main_thread = threading.current_thread() is threading.main_thread()

    def on_term(signum, frame):
        exc = KeyboardInterrupt("interrupted by SIGTERM")
        exc.exit_code = 128 + int(signum)
        raise exc
    old_term = signal.signal(signal.SIGTERM, on_term) if main_thread else None
    pool = None
    try:
        # the workers start with Ctrl-C ignored: an ignored signal stays ignored across their exec
        # and Python leaves it so, so that a Ctrl-C while they import prints no traceback of theirs
        # (a blocked mask is not kept across the spawn); the parent ignores it only while it
        # starts them, a few milliseconds
        old_int = signal.signal(signal.SIGINT, signal.SIG_IGN) if main_thread else None
        try:
            pool = multiprocessing.get_context("spawn").Pool(workers, initializer=_ignore_sigint)
        finally:
            if main_thread:
                signal.signal(signal.SIGINT, old_int)
        yield pool
        pool.close()
    finally:
        if main_thread:
            signal.signal(signal.SIGTERM, old_term)
        if pool is not None:
            pool.terminate()
            pool.join()
