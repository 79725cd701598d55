"""The package's numba cache is versioned by the compiled source (bsrflow._numba_cache): a
change to any module that uses numba starts a fresh cache folder, so a cached function never
runs an old version of a function it calls from another module (numba's own cache checks only
the function's own file; a review saw the 2-D solver keep an old flux after an edit)."""
import os

import numba
import pytest

import bsrflow
from bsrflow import _numba_cache


def _package(root, flux="1.0"):
    (root / "pkg" / "sub").mkdir(parents=True, exist_ok=True)
    (root / "pkg" / "kernels.py").write_text(f"import numba\n\n@numba.njit(cache=True)\ndef flux(x):\n    return {flux} * x\n")
    (root / "pkg" / "sub" / "solver.py").write_text("import numba\nfrom ..kernels import flux\n")
    (root / "pkg" / "cli.py").write_text("print('no compiled code here')\n")
    return root / "pkg"


def test_the_hash_follows_the_compiled_modules_only(tmp_path):
    pkg = _package(tmp_path)
    h0 = _numba_cache.source_hash(pkg)
    (pkg / "cli.py").write_text("print('changed, no compiled code')\n")
    assert _numba_cache.source_hash(pkg) == h0
    _package(tmp_path, flux="2.0")                      # the callee of another module changes
    assert _numba_cache.source_hash(pkg) != h0


def test_cache_folder_per_version_and_old_ones_pruned(tmp_path, monkeypatch):
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setattr(numba.config, "CACHE_DIR", numba.config.CACHE_DIR)   # restored after the test
    made = []
    for k in range(5):
        pkg = _package(tmp_path, flux=f"{k}.0")
        made.append(_numba_cache.use_versioned_cache_dir(pkg))
        assert numba.config.CACHE_DIR == made[-1]
        assert os.path.basename(made[-1]) == _numba_cache.source_hash(pkg)
        os.utime(made[-1], (1e9 + k, 1e9 + k))          # distinct ages
    left = sorted(os.listdir(tmp_path / "cache" / "bsrflow" / "numba"))
    assert len(made) == len(set(made)) == 5
    assert left == sorted(os.path.basename(p) for p in made[-_numba_cache.KEEP:])


def test_the_users_numba_cache_dir_is_left_alone(tmp_path, monkeypatch):
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "mine"))
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path / "mine"))
    assert _numba_cache.use_versioned_cache_dir(_package(tmp_path)) is None
    assert numba.config.CACHE_DIR == str(tmp_path / "mine")


def test_the_package_uses_its_versioned_folder():
    if os.environ.get("NUMBA_CACHE_DIR"):
        pytest.skip("NUMBA_CACHE_DIR set by the user")
    if bsrflow.NUMBA_CACHE_DIR is None:
        pytest.skip("no writable cache folder on this machine")
    from pathlib import Path
    assert os.path.basename(bsrflow.NUMBA_CACHE_DIR) == _numba_cache.source_hash(Path(bsrflow.__file__).parent)
