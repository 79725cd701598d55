"""The comparisons' worker pool (bsrflow.analysis.worker_pool): results in the order asked, and a
body that raises ends the workers still running promptly, leaving none of its processes behind
(the pool on multiprocessing.Pool hung once in the suite at that point, 2026-12-04).  The checks
look at the pool's own processes: other tests' process pools (Dask's) may still be ending."""
import time

import pytest

from bsrflow.analysis.worker_pool import worker_pool


def test_results_come_back_in_the_order_asked():
    with worker_pool(2) as pool:
        pending = [pool.apply_async(pow, (k, 2)) for k in range(6)]
        assert [p.get() for p in pending] == [0, 1, 4, 9, 16, 25]
    assert len(pool.processes) == 2 and not any(p.is_alive() for p in pool.processes)


def test_a_body_that_raises_ends_the_running_workers_promptly():
    t0 = time.perf_counter()
    with pytest.raises(RuntimeError, match="stop"):
        with worker_pool(2) as pool:
            pending = [pool.apply_async(time.sleep, (60.0,)) for _ in range(3)]
            time.sleep(0.5)                       # the first two sleeping in the workers
            raise RuntimeError("stop")
    assert time.perf_counter() - t0 < 30.0
    assert len(pool.processes) == 2 and not any(p.is_alive() for p in pool.processes)
    assert all(p.exitcode is not None for p in pool.processes)
    assert pending[2]._future.cancelled() or pending[2]._future.done()


def test_an_error_in_a_run_reaches_the_caller():
    with worker_pool(1) as pool:
        with pytest.raises(ZeroDivisionError):
            pool.apply_async(divmod, (1, 0)).get()
