import numpy as np
import pytest


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture(scope="module")
def one_numba_thread():
    """Run a module on one numba thread (``pytestmark = pytest.mark.usefixtures(...)``): the
    n-D results are thread-count independent (tested in test_nd.py), and on a shared,
    oversubscribed machine OpenMP barriers make small parallel runs erratically slow."""
    import numba

    n0 = numba.get_num_threads()
    numba.set_num_threads(1)
    yield
    numba.set_num_threads(n0)
