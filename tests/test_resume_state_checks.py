"""``--resume`` refuses a checkpoint whose state no run reaches (a fuzzing review, 2026-12-05: a
negative θ, faces out of order, a negative density or an empty Eulerian bed, δ_max < 0, Δt < 0
and a time that is not a checkpoint time were resumed, some to exit 0 with other numbers; string
values and tracers outside the grid gave messages naming the wrong thing): one line naming the
checkpoint and what is wrong, exit 2, before the output is touched."""

import os
from dataclasses import replace

import numpy as np
import pytest

from bsrflow.cli import main
from bsrflow.io.checkpoint import read_checkpoint, write_checkpoint
from bsrflow.io.layer_runner import load_layer_config, run_layer_config

BED = ('[layer]\nkind = "granular_bed"\ngamma = 3.0\ncycles = 2\nn_cells = 40\nsave_every = 0.001\nsettle = 0.005\n'
       '[output]\ncheckpoint_every = 0.05\n')
EULERIAN = ('[layer]\nkind = "granular_bed_eulerian"\ndimension = 1\ncells_per_d = 1\ngamma = 3.0\ncycles = 2\n'
            'save_every = 0.001\nsettle = 0.005\n[tracers]\npositions = [[0.01], [0.03]]\n'
            '[output]\ncheckpoint_every = 0.05\n')


def _stopped(tmp_path, text):
    """(config, output, checkpoint) of ``text``'s run stopped by Ctrl-C after t = 0.075 s."""
    cfg = tmp_path / "bed.toml"
    cfg.write_text(text)
    out = tmp_path / "bed.nc"

    def stop(t):
        if t > 0.075:
            raise KeyboardInterrupt()
    with pytest.raises(KeyboardInterrupt):
        run_layer_config(load_layer_config(cfg), out, progress=stop)
    return cfg, out, f"{out}.ckpt"


@pytest.fixture(scope="module")
def bed_run(tmp_path_factory):
    return _stopped(tmp_path_factory.mktemp("bed"), BED)


@pytest.fixture(scope="module")
def eulerian_run(tmp_path_factory):
    return _stopped(tmp_path_factory.mktemp("eul"), EULERIAN)


def _refused(tmp_path, capsys, run, edit):
    """Copy the stopped ``run``, edit its checkpoint (``edit(ck)`` gives the fields to replace),
    resume: the one line of the refusal (the output and the checkpoint unchanged)."""
    cfg, out, ck_file = run
    for src in (cfg, out, ck_file):
        (tmp_path / os.path.basename(src)).write_bytes(open(src, "rb").read())
    out, ck_file = tmp_path / os.path.basename(out), str(tmp_path / os.path.basename(ck_file))
    if callable(edit):
        ck = read_checkpoint(ck_file)
        write_checkpoint(ck_file, replace(ck, **edit(ck)))
    else:                                # the file's arrays edited as they are stored (write_checkpoint refuses)
        z = dict(np.load(ck_file))
        z.update(edit[0](z))
        with open(ck_file, "wb") as fh:
            np.savez(fh, **z)
    before = out.read_bytes(), open(ck_file, "rb").read()
    capsys.readouterr()
    assert main(["run", str(tmp_path / os.path.basename(cfg)), "--out", str(out), "--resume", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"bsrflow run: error: --resume: the checkpoint {ck_file}"), err
    assert err[0].endswith("; run without --resume to start over")
    assert (out.read_bytes(), open(ck_file, "rb").read()) == before
    return err[0]


def _field(name, fn):
    return lambda ck: {"fields": {**ck.fields, name: fn(np.array(ck.fields[name], copy=True))}}


@pytest.mark.parametrize("edit, words", [
    (_field("theta", lambda a: -np.abs(a) - 1.0), "(theta: cell 0 holds -"),
    (_field("face_height", lambda a: a[::-1].copy()), "(face_height: face 1 at"),
    (_field("face_height", lambda a: a * 0.0), "(face_height: face 1 at 0 m is not above"),
    (_field("delta_max", lambda a: a * 0.0 - 1.0), "(delta_max: cell 0 holds -1, outside the valid range [0, inf))"),
    (_field("dt_next", lambda a: a * 0.0 - 1e-6), "(dt_next = -1e-06 s, outside the valid range (0, inf) s)"),
    (lambda ck: {"t": ck.t + 3e-4}, "s, which is not one of this config's checkpoint times"),
])
def test_a_lagrangian_bed_checkpoint_no_run_reaches_is_refused(bed_run, tmp_path, capsys, edit, words):
    assert words in _refused(tmp_path, capsys, bed_run, edit)


def test_a_checkpoint_field_of_text_is_refused(bed_run, tmp_path, capsys):
    err = _refused(tmp_path, capsys, bed_run, (lambda z: {"field_theta": np.array(["a"] * z["field_theta"].size)},))
    assert "has values that are not numbers in its field 'theta'" in err


@pytest.mark.parametrize("edit, words", [
    (_field("q", lambda a: (a.__setitem__((0, Ellipsis), -1.0), a)[1]), "(q: the density is negative in"),
    (_field("q", lambda a: a * 0.0), "(q: the bed's mass is 0 of the config's"),
    (_field("q", lambda a: (a.__setitem__((4, 0, 0, 0), -1.0), a)[1]), "(q: the energy is negative in 1 cell(s))"),
    (lambda ck: {"tracers": np.array([[5.0], [-1.0]])}, "'s tracers: tracer 0 at [5.0] m is outside the grid"),
])
def test_an_eulerian_bed_checkpoint_no_run_reaches_is_refused(eulerian_run, tmp_path, capsys, edit, words):
    assert words in _refused(tmp_path, capsys, eulerian_run, edit)


def test_the_untouched_checkpoints_resume(bed_run, eulerian_run, tmp_path):
    """The same copies, unedited, resume to the end (the checks refuse only what no run writes)."""
    for k, run in enumerate((bed_run, eulerian_run)):
        folder = tmp_path / str(k)
        folder.mkdir()
        for src in run:
            (folder / os.path.basename(src)).write_bytes(open(src, "rb").read())
        cfg = folder / os.path.basename(run[0])
        assert main(["run", str(cfg), "--out", str(folder / "bed.nc"), "--resume", "--quiet"]) == 0
