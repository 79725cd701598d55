"""Issue #19, one code path: every kind of `bsrflow run` (a column of the seed's kernel, a packing
column, a 2-D layer of the seed's kernel, a 2-D packing bed) goes through the one driver
(bsrflow.io.driver.drive), so its interrupts, refusals and outcome read alike."""
import pytest
import xarray as xr

import bsrflow.io.driver as driver
from bsrflow.cli import main
from bsrflow.io.layer_runner import LayerJob, PackingBedJob
from bsrflow.io.runner import ColumnJob, PackingColumnJob

SEED = "[run]\nt_end = 0.05\nsave_every = 0.01\ncheckpoint_every = 0.02\n"
PACKING = '[model]\nkernel = "packing"\n[run]\nt_end = 0.05\nsave_every = 0.01\ncheckpoint_every = 0.02\n'
LAYER = ('[layer]\nkind = "tapped_layer"\ndim = 2\nt_end = 0.05\nsave_every = 0.01\n'
         '[output]\ncheckpoint_every = 0.02\n')
BED = ('[layer]\nkind = "packing_bed"\ndim = 2\nbox_width = 0.01\nbed_height = 0.01\n'
       't_end = 0.005\nsave_every = 0.001\n[output]\ncheckpoint_every = 0.002\n')
KINDS = {"seed": (SEED, ColumnJob, 0.02, 0.01), "packing": (PACKING, PackingColumnJob, 0.02, 0.01),
         "layer": (LAYER, LayerJob, 0.02, 0.01), "bed": (BED, PackingBedJob, 0.002, 0.001)}

pytestmark = pytest.mark.usefixtures("one_numba_thread")


@pytest.mark.parametrize("kind", list(KINDS))
def test_every_kind_of_run_goes_through_the_driver(tmp_path, monkeypatch, kind):
    """`bsrflow run` of each kind builds its job and hands it to bsrflow.io.driver.drive."""
    text, job_class, _, _ = KINDS[kind]
    seen = []
    real = driver.drive

    def spy(job, **kw):
        seen.append(type(job))
        return real(job, **kw)

    import bsrflow.io.layer_runner as layer_runner
    import bsrflow.io.runner as runner
    monkeypatch.setattr(runner, "drive", spy)
    monkeypatch.setattr(layer_runner, "drive", spy)
    (tmp_path / "c.toml").write_text(text)
    assert main(["run", str(tmp_path / "c.toml"), "--out", str(tmp_path / "c.nc"), "--quiet"]) == 0
    assert seen == [job_class]
    with xr.open_dataset(tmp_path / "c.nc") as ds:
        assert ds.attrs["status"] == "ok" and int(ds.attrs["steps"]) > 0


@pytest.mark.parametrize("kind", list(KINDS))
@pytest.mark.parametrize("when", ["before", "after"], ids=["before_first_checkpoint", "after_a_checkpoint"])
def test_an_interrupt_reads_alike_for_every_kind(tmp_path, capsys, monkeypatch, kind, when):
    """Ctrl-C before the first checkpoint says when it was due and that --resume cannot continue; after
    one, which checkpoint --resume continues from; the file keeps its snapshots with the same status words
    (the layer runs said less: no times, no due checkpoint)."""
    text, _, t_ck, dt_save = KINDS[kind]
    # the progress callback runs at every save and after every checkpoint is written: stop at the first
    # save (before the first checkpoint) or at the save after the first checkpoint
    stop_after = 0.5 * dt_save if when == "before" else t_ck + 0.5 * dt_save
    real = driver.drive

    def stopping(job, **kw):
        def progress(t):
            if t > stop_after:
                raise KeyboardInterrupt()
        kw["progress"] = progress
        return real(job, **kw)

    import bsrflow.io.layer_runner as layer_runner
    import bsrflow.io.runner as runner
    monkeypatch.setattr(runner, "drive", stopping)
    monkeypatch.setattr(layer_runner, "drive", stopping)
    (tmp_path / "c.toml").write_text(text)
    out = tmp_path / "c.nc"
    assert main(["run", str(tmp_path / "c.toml"), "--out", str(out), "--quiet"]) == 130
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"bsrflow run: interrupted by Ctrl-C (SIGINT): {out} keeps ")
    with xr.open_dataset(out) as ds:
        n, t_last = ds.sizes["time"], float(ds["time"].values[-1])
        assert ds.attrs["status"] == f"interrupted by Ctrl-C (SIGINT) after {n} snapshots, up to t = {t_last:.6g} s"
    assert f"keeps {n} snapshot(s) up to t = {t_last:.6g} s" in lines[0]
    if when == "before":
        assert f"no checkpoint written yet (the first was due at t = {t_ck:.6g} s)" in lines[0], lines[0]
        assert not (tmp_path / "c.nc.ckpt").exists()
    else:
        assert f"checkpoint {out}.ckpt at t = {t_ck:.6g} s: `--resume` continues from there" in lines[0], lines[0]


@pytest.mark.parametrize("kind", ["layer", "bed"])
def test_a_layer_resume_compares_the_resolved_configs(tmp_path, capsys, kind):
    """A layer's checkpoint is compared with the config key by key on the resolved configs (as a column's
    is): a changed value is named in the one-line refusal; a comment, a blank line or a field written out
    at its default is no difference; a column config's run on the finished output is refused as another
    kind of run."""
    import dataclasses
    import bsrflow.io.layer_runner as layer_runner
    from bsrflow.io.layer_runner import load_layer_config
    text, _, t_ck, _ = KINDS[kind]
    cfg = tmp_path / "c.toml"
    cfg.write_text(text)
    out = tmp_path / "c.nc"

    def stop(t):
        if t > 1.5 * t_ck:
            raise KeyboardInterrupt()
    with pytest.raises(KeyboardInterrupt):
        layer_runner.run_layer_config(load_layer_config(cfg), out, progress=stop)
    changed = text.replace("t_end = 0.05", "t_end = 0.06").replace("t_end = 0.005", "t_end = 0.006")
    (tmp_path / "d.toml").write_text(changed)
    assert main(["run", str(tmp_path / "d.toml"), "--out", str(out), "--resume", "--quiet"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "the config differs from the checkpoint's in layer.t_end" in lines[0], lines
    gravity = next(f.default for f in dataclasses.fields(load_layer_config(cfg).setup) if f.name == "gravity")
    cfg.write_text("# the same run, commented\n" + text.replace("save_every", "\n# the snapshots\nsave_every")
                   .replace("[output]", f"gravity = {gravity!r}\n[output]"))
    assert main(["run", str(cfg), "--out", str(out), "--resume", "--quiet"]) == 0
    with xr.open_dataset(out) as ds:
        assert ds.attrs["status"] == "ok"
    col = tmp_path / "col.toml"
    col.write_text(SEED)
    assert main(["run", str(col), "--out", str(out), "--resume", "--quiet"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "not a config of this kind of run" in lines[0], lines


@pytest.mark.parametrize("kind, names", [("seed", {"u", "rho"}), ("packing", {"position", "velocity", "delta_max"}),
                                         ("layer", {"u", "rho"}),
                                         ("bed", {"rho", "momentum_x", "momentum_z", "rho_delta_max"})])
def test_every_checkpoint_holds_named_fields_and_resumes(tmp_path, capsys, kind, names):
    """One restart format: every kind of run checkpoints its state as named fields (the seed's grid u and
    rho, the packing discretisations theirs, history included); --resume from it finishes the run.  A
    checkpoint of the old format (1: the seed's u and rho apart) is refused in one line, as is one whose
    fields are not the run's."""
    import numpy as np
    from bsrflow.io.checkpoint import read_checkpoint, write_checkpoint
    from dataclasses import replace
    text, _, t_ck, dt_save = KINDS[kind]
    real = driver.drive
    cfg, out = tmp_path / "c.toml", tmp_path / "c.nc"
    cfg.write_text(text)

    def stop(t):
        if t > t_ck + 0.5 * dt_save:
            raise KeyboardInterrupt()
    import bsrflow.io.layer_runner as layer_runner
    import bsrflow.io.runner as runner
    with pytest.MonkeyPatch.context() as mp:
        for mod in (runner, layer_runner):
            mp.setattr(mod, "drive", lambda job, **kw: real(job, **{**kw, "progress": stop}))
        assert main(["run", str(cfg), "--out", str(out), "--quiet"]) == 130
    ck_file = tmp_path / "c.nc.ckpt"
    ck = read_checkpoint(ck_file)
    assert set(ck.fields) == names and ck.t == t_ck
    assert all(np.all(np.isfinite(v)) for v in ck.fields.values())
    bad = replace(ck, fields={k: v for k, v in ck.fields.items() if k != sorted(names)[0]})
    write_checkpoint(ck_file, bad)
    capsys.readouterr()
    assert main(["run", str(cfg), "--out", str(out), "--resume", "--quiet"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "checkpoint" in lines[0] and "does not match" in lines[0], lines
    with open(ck_file, "wb") as fh:       # the format before 2026-12-03
        np.savez(fh, format=np.int64(1), t=np.float64(t_ck), u=np.zeros(3), rho=np.ones(3))
    assert main(["run", str(cfg), "--out", str(out), "--resume", "--quiet"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "checkpoint format 1, expected 2" in lines[0], lines
    write_checkpoint(ck_file, ck)
    assert main(["run", str(cfg), "--out", str(out), "--resume", "--quiet"]) == 0
    with xr.open_dataset(out) as ds:
        assert ds.attrs["status"] == "ok"


def test_a_monitor_stop_records_the_steps_to_the_stop(tmp_path, capsys):
    """A layer stopped by its monitor (a far too strong tap without dissipation: the step collapses) has
    the monitor's message as its status and, as `steps`, the steps of the message (it had the count at
    the last checkpoint); a seed column stopped so has its steps too."""
    import re
    cfg = tmp_path / "l.toml"
    cfg.write_text('[layer]\nkind = "tapped_layer"\ndim = 2\nbox_width = 0.012\namplitude = 0.05\nfrequency = 50.0\ndissipation = 0.0\n'
                   'positivity = false\nsettle_time = 0.012\nt_end = 0.05\nsave_every = 0.005\n'
                   '[output]\ncheckpoint_every = 0.005\n')
    assert main(["run", str(cfg), "--out", str(tmp_path / "l.nc"), "--quiet"]) == 3
    with xr.open_dataset(tmp_path / "l.nc") as ds:
        status = ds.attrs["status"]
        said = int(re.search(r"(\d+) steps", status).group(1))
        assert int(ds.attrs["steps"]) == said > 0, status
        assert "None" not in status                     # no "near x = None m" where no cell is to blame



