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
        # the workers start with Ctrl-C blocked (the mask is kept across their exec), so that a
        # Ctrl-C while they import prints no traceback of theirs; one that reaches the parent
        # meanwhile is delivered when it unblocks it, inside this try
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            pool = multiprocessing.get_context("spawn").Pool(workers, initializer=_ignore_sigint)
        finally:
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
        yield pool
        pool.close()
    finally:
        if main_thread:
            signal.signal(signal.SIGTERM, old_term)
        if pool is not None:
            pool.terminate()
            pool.join()
