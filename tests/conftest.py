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


@pytest.fixture
def run_layer_file(tmp_path):
    """``run(text, stem, scenario, per_depth=False)``: write a layer config, run it with
    ``bsrflow run --quiet`` into ``<stem>.nc`` and open the file, after the checks every 2-D layer
    run shares: status ok, the scenario, ``rho`` on (time, x, z) in kg m-2 with the mass in kg
    (a planar continuum) or, ``per_depth`` (the packing bed, uniform in depth), in kg m-3 with
    the mass in kg m-1, 13 snapshots, ρ >= 0, mass conserved to 1e-12.  Returns the open
    dataset (the caller closes it)."""
    import xarray as xr

    from bsrflow.cli import main

    def run(text, stem, scenario, per_depth=False):
        cfg = tmp_path / f"{stem}.toml"
        cfg.write_text(text)
        out = tmp_path / f"{stem}.nc"
        assert main(["run", str(cfg), "--out", str(out), "--quiet"]) == 0
        ds = xr.open_dataset(out)
        assert ds.attrs["status"] == "ok" and ds.attrs["scenario"] == scenario
        assert ds["rho"].dims == ("time", "x", "z")
        assert (ds["rho"].attrs["units"], ds["mass"].attrs["units"]) == (("kg m-3", "kg m-1") if per_depth
                                                                         else ("kg m-2", "kg"))
        assert ds.sizes["time"] == 13 and float(ds["rho"].min()) >= 0.0
        np.testing.assert_allclose(ds["mass"].values, ds["mass"].values[0], rtol=1e-12)
        return ds

    return run


def interrupt_and_resume(cfg, part, between=None):
    """Run the layer config ``cfg`` into ``part``, interrupted after t = 0.075 s (Ctrl-C), call
    ``between(checkpoint)`` on the checkpoint it left, then ``--resume`` it; returns the outcome."""
    import os

    from bsrflow.io.checkpoint import read_checkpoint
    from bsrflow.io.layer_runner import run_layer_config

    def stop(t):
        if t > 0.075:
            raise KeyboardInterrupt()

    with pytest.raises(KeyboardInterrupt, match="--resume"):
        run_layer_config(cfg, part, progress=stop)
    assert os.path.exists(f"{part}.ckpt")
    if between is not None:
        between(read_checkpoint(f"{part}.ckpt"))
    return run_layer_config(cfg, part, resume=True)
