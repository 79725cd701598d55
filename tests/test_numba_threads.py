"""The package's choice of numba's threading layer (bsrflow._numba_threads): not tbb, whose every
parallel launch kept memory here, unless the user's environment chose."""

import os
import resource
import subprocess
import sys

import numba
import numpy as np
import pytest

import bsrflow
from bsrflow._numba_threads import PRIORITY, prefer_leak_free_layers


@numba.njit(parallel=True, cache=False)
def _touch(a):
    for i in numba.prange(a.shape[0]):
        a[i] += 1.0


@pytest.mark.skipif(bool(os.environ.get("NUMBA_THREADING_LAYER") or os.environ.get("NUMBA_THREADING_LAYER_PRIORITY")),
                    reason="the user's environment chose numba's threading layer")
def test_the_package_prefers_a_layer_that_keeps_the_memory_flat():
    assert bsrflow.NUMBA_THREADING_LAYER_PRIORITY == PRIORITY == ["omp", "workqueue", "tbb"]
    a = np.zeros(64)
    _touch(a)
    assert numba.threading_layer() in ("omp", "workqueue")
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss            # [kB] on Linux
    for _ in range(5000):                                                  # tbb kept ~7 kB per launch here: 35 MB
        _touch(a)
    assert a[0] == 5001.0
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 8 * 1024


def test_a_user_choice_of_layer_stands(monkeypatch):
    monkeypatch.setenv("NUMBA_THREADING_LAYER", "workqueue")
    assert prefer_leak_free_layers() is None
    out = subprocess.run([sys.executable, "-c", "import bsrflow; print(bsrflow.NUMBA_THREADING_LAYER_PRIORITY)"],
                         capture_output=True, text=True, check=True, env=dict(os.environ, NUMBA_THREADING_LAYER_PRIORITY="tbb omp workqueue"))
    assert out.stdout.strip() == "None"


def test_openmp_waits_passively_unless_the_user_chose():
    """OMP_WAIT_POLICY=PASSIVE is set before numba's omp layer starts (spinning threads slowed a
    shared machine's runs); a value the user set stands."""
    code = "import os, bsrflow; print(bsrflow.OMP_WAIT_POLICY, os.environ['OMP_WAIT_POLICY'])"
    env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env)
    assert out.stdout.split() == ["PASSIVE", "PASSIVE"]
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env=dict(env, OMP_WAIT_POLICY="ACTIVE"))
    assert out.stdout.split() == ["None", "ACTIVE"]


def test_the_wait_policy_is_not_claimed_once_openmp_is_loaded():
    """GNU OpenMP reads OMP_WAIT_POLICY once, when it loads: loaded first (here by numba's omp
    layer), the package sets nothing and says so (None), as a review found it claimed PASSIVE."""
    code = ("import numba, numpy as np\n"
            "numba.config.THREADING_LAYER = 'omp'\n"
            "@numba.njit(parallel=True)\n"
            "def f(a):\n"
            "    for i in numba.prange(a.size):\n"
            "        a[i] += 1\n"
            "f(np.zeros(8))\n"
            "import os, bsrflow\n"
            "print(bsrflow.OMP_WAIT_POLICY, os.environ.get('OMP_WAIT_POLICY'))\n")
    env = {k: v for k, v in os.environ.items() if k not in ("OMP_WAIT_POLICY", "NUMBA_THREADING_LAYER")}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    if out.returncode != 0 and "omp" in out.stderr.lower():
        pytest.skip("numba's omp layer is not available here")
    assert out.stdout.split() == ["None", "None"], out.stderr
