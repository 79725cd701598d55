"""A full disk: the output a run will write is checked against the free space of its folder
before the run starts (one line naming --out, exit code 2, nothing written), and a write that
fails in the middle of a run (a checkpoint on a disk that filled up meanwhile) stops it with
one line saying what failed and what the output keeps (exit code 1), the file closed with
status "failed: ..."."""
import collections
import errno
import os

import pytest
import xarray as xr

import bsrflow.io.paths as paths
from bsrflow.cli import main
from bsrflow.io.netcdf import NetCDFWriter

SEED = "[run]\nt_end = 0.05\nsave_every = 0.01\ncheckpoint_every = 0.02\n"
PACKING = '[model]\nkernel = "packing"\n[run]\nt_end = 0.05\nsave_every = 0.01\ncheckpoint_every = 0.02\n'
LAYER = ('[layer]\nkind = "packing_bed"\ndim = 2\nbox_width = 0.01\nbed_height = 0.01\n'
         't_end = 0.004\nsave_every = 0.001\n[output]\ncheckpoint_every = 0.002\n')
_Usage = collections.namedtuple("_Usage", "total used free")


@pytest.fixture
def small_disk(monkeypatch):
    """The folders look as if they had 100 KiB free."""
    monkeypatch.setattr(paths.shutil, "disk_usage", lambda folder: _Usage(10 ** 9, 10 ** 9, 100 * 1024))


@pytest.fixture
def no_run(monkeypatch):
    """The time loops of every kind of run fail the test: the check comes first."""
    import bsrflow.numerics.controller as controller       # the packing runs import it when they run
    import bsrflow.numerics.solver as solver

    def fail(*a, **k):
        raise AssertionError("the run started before the free space was checked")

    for mod in (controller, solver):
        monkeypatch.setattr(mod, "drive_events", fail)
    monkeypatch.setattr(solver.Simulation, "advance", fail)


@pytest.mark.parametrize("text", [SEED, PACKING, LAYER], ids=["seed", "packing", "layer"])
def test_an_output_the_disk_cannot_hold_is_refused_before_the_run(tmp_path, capsys, small_disk, no_run, text):
    cfg = tmp_path / "c.toml"
    cfg.write_text(text)
    code = main(["run", str(cfg), "--out", str(tmp_path / "r.nc"), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert err[0].startswith(f"bsrflow run: error: --out: {tmp_path / 'r.nc'} needs about "), err[0]
    assert "but " in err[0] and "100.0 KiB free" in err[0], err[0]
    assert sorted(os.listdir(tmp_path)) == ["c.toml"]                  # nothing written


def test_planned_size_is_the_size_of_the_file(tmp_path):
    """The estimate the check uses is the file's size within a few per cent."""
    import numpy as np
    x = (np.arange(400) + 0.5) * 1e-3
    w = NetCDFWriter(tmp_path / "a.nc", x, 1e-3, 20, lambda t: 0.0, {"config": "x"}, expected_snapshots=300)
    planned = w.planned_bytes()
    for k in range(300):
        w(0.01 * k, np.zeros(400), np.ones(400), np.arange(20.0))
    w.close("ok")
    size = os.path.getsize(tmp_path / "a.nc")
    assert 0.97 * size < planned < 1.1 * size, (planned, size)


def test_resume_into_a_full_disk_is_refused(tmp_path, monkeypatch):
    import numpy as np
    x = (np.arange(400) + 0.5) * 1e-3
    w = NetCDFWriter(tmp_path / "a.nc", x, 1e-3, 0, lambda t: 0.0, expected_snapshots=300)
    for k in range(3):
        w(0.01 * k, np.zeros(400), np.ones(400), np.zeros(0))
    w.close("interrupted")
    monkeypatch.setattr(paths.shutil, "disk_usage", lambda folder: _Usage(10 ** 9, 10 ** 9, 1000))
    with pytest.raises(paths.OutputPathError, match=r"^--out: .*a\.nc needs about .* but .* has 1000 bytes free"):
        NetCDFWriter.resume(tmp_path / "a.nc", 0.015, x, 1e-3, 0, lambda t: 0.0, expected_snapshots=300)


@pytest.mark.parametrize("err, words", [(errno.ENOSPC, "No space left on device"), (errno.EACCES, "Permission denied")])
@pytest.mark.parametrize("text", [SEED, PACKING, LAYER], ids=["seed", "packing", "layer"])
def test_a_write_failing_in_the_run_stops_it_with_one_line(tmp_path, capsys, monkeypatch, text, err, words):
    """The first checkpoint (t = 0.02 s, a layer's 0.002 s) fails; the two snapshots before it stay in the file,
    which is closed with status "failed: ..." or, on a full disk, as it is ("running").  Every run writes its
    checkpoints through the one driver (bsrflow.io.driver)."""
    import bsrflow.io.driver as mod

    def failing(path, ck):
        raise OSError(err, words, str(path))

    monkeypatch.setattr(mod, "write_checkpoint", failing)
    cfg = tmp_path / "c.toml"
    cfg.write_text(text)
    out = tmp_path / "r.nc"
    code = main(["run", str(cfg), "--out", str(out), "--quiet"])
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(lines) == 1, lines
    last = "0.001" if text is LAYER else "0.01"
    assert lines[0].startswith(f"bsrflow run: error: [Errno {err}] {words}: {out}.ckpt; the run stopped, "
                               f"{out} keeps 2 snapshot(s) up to t = {last} s"), lines[0]
    with xr.open_dataset(out) as ds:
        assert ds.sizes["time"] == 2
        if err == errno.ENOSPC:
            assert ds.attrs["status"] == "running" and 'status attribute left at "running"' in lines[0]
        else:
            assert ds.attrs["status"].startswith(f"failed: [Errno {err}] {words}")


def test_checkpoint_and_vtk_write_errors_name_their_file(tmp_path, monkeypatch):
    """numpy's and meshio's writes raise errors without a file name: the package adds it."""
    import numpy as np
    from bsrflow.io import checkpoint, vtk
    from bsrflow.io.checkpoint import Checkpoint, write_checkpoint

    def full(*a, **k):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(checkpoint.np, "savez", full)
    ck = Checkpoint(t=0.0, fields={"u": np.zeros(3), "rho": np.ones(3)}, tracers=np.zeros(0), steps=0, rejected_steps=0,
                    wall_time=0.0, n_snapshots=0, config="")
    with pytest.raises(OSError, match=r"cannot write the checkpoint \(No space left on device\)") as info:
        write_checkpoint(tmp_path / "a.ckpt", ck)
    assert info.value.filename == str(tmp_path / "a.ckpt") and info.value.errno == errno.ENOSPC
    with pytest.raises(OSError, match=r"cannot write the VTK file \(No space left on device\)") as info:
        vtk._replace_atomically(tmp_path / "a.vtu", full)
    assert info.value.filename == str(tmp_path / "a.vtu")
    assert sorted(os.listdir(tmp_path)) == []                  # no temporary file left
