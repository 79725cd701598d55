"""A pool of worker processes for the comparisons' independent runs (``compare --kernel packing
--workers``, ``compare-bed --workers``): spawned processes (no fork of a numba-compiled parent),
Ctrl-C and SIGTERM handled by the parent alone, the workers ended with it.

Built on :class:`concurrent.futures.ProcessPoolExecutor`, which notices a worker that dies and
ends its pool cleanly.  ``multiprocessing.Pool`` was used before 2026-12-04; its ``terminate``
can hang for good when a worker is ended while it holds one of the pool's queue locks (seen once
in the test suite: the parent waiting on a lock, both workers gone)."""

from __future__ import annotations

import concurrent.futures
import contextlib
import multiprocessing
import signal
import threading

__all__ = ["worker_pool"]


def _ignore_sigint():
    """Initializer of the worker processes: Ctrl-C is the parent's to handle (it stops them)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


class _Pending:
    """A submitted run: ``get()`` waits for its result (or raises its exception)."""

    def __init__(self, future):
        self._future = future

    def get(self):
        return self._future.result()


class _Pool:
    """What the callers use of a pool: ``apply_async(fn, args)`` -> an object with ``get()``."""

    def __init__(self, executor):
        self._executor = executor
        self.processes = []
        """The pool's worker processes, recorded when the pool ends (all joined by then)."""

    def apply_async(self, fn, args=()):
        return _Pending(self._executor.submit(fn, *args))


@contextlib.contextmanager
def worker_pool(workers: int):
    """A pool of ``workers`` spawned processes for the body of the ``with`` (``apply_async(fn,
    args).get()``).  Meanwhile SIGTERM raises KeyboardInterrupt("interrupted by SIGTERM") in the
    parent with ``exit_code`` 143 (the callers keep their finished runs and exit with it).  On
    leaving by the end of the body the workers finish and exit; by an exception the runs still
    waiting are cancelled and the workers still running are ended, then joined."""
    main_thread = threading.current_thread() is threading.main_thread()

    def on_term(signum, frame):
        exc = KeyboardInterrupt("interrupted by SIGTERM")
        exc.exit_code = 128 + int(signum)
        raise exc
    old_term = signal.signal(signal.SIGTERM, on_term) if main_thread else None
    executor = pool = None
    finished = False
    try:
        # the workers start with Ctrl-C ignored: an ignored signal stays ignored across their exec
        # and Python leaves it so, so that a Ctrl-C while they import prints no traceback of theirs
        # (a blocked mask is not kept across the spawn); the parent ignores it only while it
        # starts them, a few milliseconds
        old_int = signal.signal(signal.SIGINT, signal.SIG_IGN) if main_thread else None
        try:
            executor = concurrent.futures.ProcessPoolExecutor(
                workers, mp_context=multiprocessing.get_context("spawn"), initializer=_ignore_sigint)
            # start every worker now, while Ctrl-C is ignored here: with "spawn" the executor
            # would start them one by one at the first submits (CPython's own start-up routine,
            # the one it uses under "fork"; called before any submit, as it requires; a Python
            # without it starts them at the submits, Ctrl-C then reaching their imports)
            launch = getattr(executor, "_launch_processes", None)
            if launch is not None:
                launch()
        finally:
            if main_thread:
                signal.signal(signal.SIGINT, old_int)
        pool = _Pool(executor)
        yield pool
        finished = True
    finally:
        if main_thread:
            signal.signal(signal.SIGTERM, old_term)
        if executor is not None:
            procs = list((executor._processes or {}).values())
            if not finished:
                # end the running workers; the executor sees them gone, fails the runs left, and
                # its shutdown(wait=True) joins its own thread, which reaps them (a shutdown with
                # wait=False first would let that thread reap them while the loop below waits on
                # the same processes: a child reaped twice looks alive for good)
                for proc in procs:
                    if proc.is_alive():
                        proc.terminate()
            executor.shutdown(wait=True, cancel_futures=not finished)
            for proc in procs:                  # joined here: no process of the pool outlives it
                proc.join(timeout=10.0)
                if proc.is_alive():
                    proc.kill()
                    proc.join()
            if pool is not None:
                pool.processes = procs
