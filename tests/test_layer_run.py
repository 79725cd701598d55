"""Issue #19: `bsrflow run` of a 2-D / 3-D layer config: the n-D netCDF file and VTK files,
one-line refusals, and an interrupted run resumed from its checkpoint bit for bit."""

import numpy as np
import pytest
import xarray as xr

from conftest import interrupt_and_resume
from bsrflow.cli import main
from bsrflow.io.layer_runner import load_layer_config, run_layer_config
from bsrflow.io.netcdf import read_snapshots

CONFIG = """[layer]
kind = "tapped_layer"
dim = 2
t_end = 0.12
save_every = 0.01
[output]
vtk = true
checkpoint_every = 0.05
"""


pytestmark = pytest.mark.usefixtures("one_numba_thread")


def test_layer_config_runs_into_netcdf_and_vtk(tmp_path, run_layer_file):
    import meshio

    ds = run_layer_file(CONFIG, "layer", "layer_2d")
    last = meshio.read(tmp_path / "layer_vtk" / "layer_000012.vtu")
    np.testing.assert_array_equal(last.cell_data["density [kg/m^2]"][0], ds["rho"].values[-1].ravel())
    ds.close()
    assert not (tmp_path / "layer.nc.ckpt").exists()


@pytest.mark.parametrize("text, field", [
    ("[layer]\nkind = 'box'\n", "layer.kind"),
    ("[layer]\nnosuch = 1\n", "layer.nosuch"),
    ("[layer]\ndim = 4\n", "layer.dim"),
    ("[layer]\ndim = 2\nt_end = 1e9\n", "layer.save_every"),
    ("[layer]\n[output]\nvtk = 1\n", "output.vtk"),
    ("[layer]\n[extra]\n", "extra"),
    ("[layer]\ndim = 2\n[tracers]\npositions = [[0.01]]\n", "tracers.positions"),
    ("[layer]\ndim = 2\n[tracers]\npositions = [[0.01, -0.5]]\n", "tracers.positions"),
    ("[layer]\ndim = 2\n[tracers]\nwhere = 1\n", "tracers.where"),
    # kind = "packing_bed" (issue #19: the packing continuum in 2-D / 3-D)
    ("[layer]\nkind = 'packing_bed'\nnosuch = 1\n", "layer.nosuch"),
    ("[layer]\nkind = 'packing_bed'\ndim = 1\n", "layer.dim"),
    ("[layer]\nkind = 'packing_bed'\nstiffness_factor = 0\n", "layer.stiffness_factor"),
    ("[layer]\nkind = 'packing_bed'\nrestitution = 1.5\n", "layer.restitution"),
    ("[layer]\nkind = 'packing_bed'\nphi_c = 0.8\n", "layer.phi_c"),
    ("[layer]\nkind = 'packing_bed'\ngamma = -1\n", "layer.gamma"),
    ("[layer]\nkind = 'packing_bed'\ncfl = 0.3\n", "layer.cfl"),
    ("[layer]\nkind = 'packing_bed'\ncells_per_diameter = 0\n", "layer.cells_per_diameter"),
    ("[layer]\nkind = 'packing_bed'\ndomain_height = 0.01\n", "layer.domain_height"),
    ("[layer]\nkind = 'packing_bed'\n[tracers]\npositions = [[0.01, 0.01, 0.5]]\n", "tracers.positions"),
    ("[layer]\nkind = 'packing_bed'\n[tracers]\npositions = [[0.01, 0.01]]\n", "tracers.positions"),
    # ranges a review found open (2026-12-02): a box that is not whole cells was rounded silently,
    # an absurd stiffness ran for ever or failed in its first step, a huge coordination was
    # reported as an infinite stiffness
    ("[layer]\nkind = 'packing_bed'\nbox_width = 0.0113\n", "layer.box_width"),
    ("[layer]\nkind = 'tapped_layer'\nbox_width = 0.0491\n", "layer.box_width"),
    ("[layer]\nkind = 'packing_bed'\nstiffness = 1e300\n", "layer.stiffness"),
    ("[layer]\nkind = 'packing_bed'\nstiffness = 1e-3\n", "layer.stiffness"),
    ("[layer]\nkind = 'packing_bed'\nstiffness = 1e-300\n", "layer.stiffness"),
    ("[layer]\nkind = 'packing_bed'\ncoordination = 1e300\n", "layer.coordination"),
    ("[layer]\nkind = 'packing_bed'\ndensity = 1e300\n", "layer.density"),
    # types and sizes (an audit found tracebacks here)
    ("[layer]\nkind = 'packing_bed'\ndim = 2.0\n", "layer.dim"),
    ("[layer]\nkind = 'packing_bed'\ngamma = true\n", "layer.gamma"),
    ("[layer]\nkind = 'packing_bed'\nrestitution = 'x'\n", "layer.restitution"),
    ("[layer]\nkind = 'packing_bed'\ncells_per_diameter = inf\n", "layer.cells_per_diameter"),
    ("[layer]\nkind = 'packing_bed'\ncells_per_diameter = 100000\n", "layer"),
    ("layer = 5\n", "layer"),
    ("tracers = 5\n[layer]\n", "tracers"),
    ("[layer]\nkind = 'packing_bed'\nt_end = 0.01\nsave_every = 0.02\n", "layer.save_every"),
    ("[layer]\nkind = 'packing_bed'\nt_end = 0.01\n[output]\ncheckpoint_every = 5.0\n", "output.checkpoint_every"),
    # a second audit: the message named the internal parameter (period, hyperdiffusion), or none
    ("[layer]\nn_taps = 3\ntap_period = -1.0\n", "layer.tap_period"),
    ("[layer]\nn_taps = 3\ntap_period = 0.001\n", "layer.tap_period"),
    ("[layer]\nscheme = 'accurate'\n", "layer.scheme"),
    ("[layer]\nkind = 'packing_bed'\nrestitution = 0.001\n", "layer.restitution"),
    # a third review (2026-12-03): "cannot convert float infinity to integer", an errno tuple, no key
    ("[layer]\ndim = 2\nfrequency = 1e300\n", "layer.frequency: frequency = 1e+300 is outside the valid range"),
    ("[layer]\nkind = 'vibrated_box'\ndim = 2\nfrequency = 1e-4\n", "layer.frequency"),
    ("[layer]\nkind = 'packing_bed'\nfrequency = 1e300\n", "layer.frequency"),
    ("[layer]\nkind = 'packing_bed'\ngamma = 1e300\n", "layer.gamma: 1e+300 gives the floor"),
    ("[layer]\nkind = 'vibrated_box'\ndim = 2\namplitude = 1e300\n", "layer.amplitude"),
    ("[layer]\ndim = 2\naverage = 'foo'\n", "layer.average"),
    ("[layer]\ndim = 2\ndomain_height = 0.001\n", "layer.domain_height: domain_height = 0.001 m is outside"),
    # kind = "granular_bed" (2026-12-03; the settings no run could use from a review of the new kind)
    ("[layer]\nkind = \"granular_bed\"\ngamma = -1\n", "layer.gamma"),
    ("[layer]\nkind = \"granular_bed\"\noutput_height = 0\n", "layer.output_height"),
    ("[layer]\nkind = \"granular_bed\"\nn_cells = 2\n", "layer.n_cells"),
    ("[layer]\nkind = \"granular_bed\"\n[output]\nvtk = true\n", "output.vtk"),
    ("[layer]\nkind = \"granular_bed\"\n[tracers]\npositions = [[0.01]]\n", "tracers"),
    # checks across fields name the field the config gives and its range there (2026-12-05, a fuzzing review:
    # they blamed stiffness, cfl or n_spheres, fields not given, or gave an empty range)
    ("[layer]\nkind = \"granular_bed\"\ncycles = 10000000\n",
     "layer.cycles: cycles = 10000000 is outside the valid range at these settings (at most 19076 with the other"),
    ("[layer]\nkind = \"granular_bed\"\nside = 100.0\n",
     "layer.side: side = 100.0 m is outside the valid range at these settings, (0, 0.2028] m (with n_spheres = 2000"),
    ("[layer]\nkind = \"granular_bed_eulerian\"\ndimension = 1\nn_spheres = 10000000\n",
     "layer.n_spheres: n_spheres = 10000000 is outside the valid range at these settings (at most 1768442 with"),
    ("[layer]\nkind = \"granular_bed_eulerian\"\ndimension = 1\ncells_per_d = 1\ncycles = 10000000\n",
     "layer.cycles: cycles = 10000000 is outside the valid range at these settings (at most"),
    # two given fields either of which mends it: the first in the config's order (not a set's, a review)
    ("[layer]\nkind = \"granular_bed_eulerian\"\ndimension = 1\ncycles = 100\nstiffness = 1e12\n",
     "layer.cycles: cycles = 100 is outside the valid range at these settings (at most 21 with the other fields"),
    ("[layer]\nkind = \"granular_bed_eulerian\"\ndimension = 1\nstiffness = 1e12\ncycles = 100\n",
     "layer.stiffness: stiffness = 1000000000000.0 is outside the valid range at these settings (at most"),
    # a lid less than a diameter above the bed at rest (the run would stop on it; a review)
    ("[layer]\nkind = \"granular_bed_eulerian\"\ndimension = 1\nn_spheres = 600\noutput_height = 0.0175\n",
     "layer.output_height: output_height = 0.0175 is outside the valid range at these settings, [0.02, 100] m"),
    # kind = "granular_bed_eulerian" takes tracers (2026-12-05): z in 1-D, (x, z), (x, y, z), inside its grid
    ("[layer]\nkind = \"granular_bed_eulerian\"\ndimension = 2\n[tracers]\npositions = [[0.01]]\n",
     "tracers.positions: must be a non-empty list of 2-element lists"),
    ("[layer]\nkind = \"granular_bed_eulerian\"\ndimension = 1\n[tracers]\npositions = [[0.01, 0.02]]\n",
     "tracers.positions: must be a non-empty list of 1-element lists of finite numbers [m] ([z] per tracer)"),
    ("[layer]\nkind = \"granular_bed_eulerian\"\ndimension = 3\n[tracers]\npositions = [[0.01, 0.1, 0.01]]\n",
     "tracers.positions: tracer 0 at [0.01, 0.1, 0.01] m is outside the box"),
    ("[layer]\nkind = \"granular_bed_eulerian\"\ndimension = 1\n[tracers]\npositions = [[5.0]]\n",
     "tracers.positions: tracer 0 at [5.0] m is outside the box"),
    ("[layer]\nkind = \"granular_bed\"\nbox_width = 0.1\n", "layer.box_width"),
    ("[layer]\nkind = \"granular_bed\"\nstiffness = 1\n", "layer.stiffness"),          # overlap 2.8 d
    ("[layer]\nkind = \"granular_bed\"\noutput_height = 0.02\n", "layer.output_height"),   # below the bed
    ("[layer]\nkind = \"granular_bed\"\noutput_height = 0.001\n", "layer.output_height"),
    ("[layer]\nkind = \"granular_bed\"\nn_spheres = 1\n", "layer.n_spheres"),          # 0.005 d deep
    ("[layer]\nkind = \"granular_bed\"\nfrequency = 0.1\n", "layer.frequency"),        # a 1-km column
    ("[layer]\nkind = \"granular_bed\"\ncfl = 1e-9\n", "layer.cfl"),                   # 1e14 steps
    ("[layer]\nkind = \"granular_bed\"\nn_cells = 5000000\n", "layer.n_cells"),
    ("[layer]\nkind = \"granular_bed\"\nfrequency = 10000\ncycles = 2\n", "layer.save_every: not given: its default 0.001 s"),
])
def test_bad_layer_configs_exit_2_with_one_line(text, field, tmp_path, capsys):
    cfg = tmp_path / "bad.toml"
    cfg.write_text(text)
    assert main(["run", str(cfg), "--out", str(tmp_path / "bad.nc")]) == 2
    err = capsys.readouterr().err.strip()
    assert f"error: {field}" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "bad.nc").exists()
    assert not (tmp_path / "bad.nc").exists()




def test_interrupted_layer_run_resumes_bit_for_bit(tmp_path):
    cfgfile = tmp_path / "layer.toml"
    cfgfile.write_text(CONFIG.replace("vtk = true", "vtk = false"))
    cfg = load_layer_config(cfgfile)
    full = tmp_path / "full.nc"
    run_layer_config(cfg, full)
    part = tmp_path / "part.nc"
    outcome = interrupt_and_resume(cfg, part)
    assert outcome.resumed_from == pytest.approx(0.05)
    a, _ = read_snapshots(full)
    b, _ = read_snapshots(part)
    for k in ("time", "rho", "u_x", "u_z", "mass_centre"):
        np.testing.assert_array_equal(a[k], b[k])


def test_layer_tracers_are_written_and_resume_bit_for_bit(tmp_path):
    """Tracers of a layer config ([tracers] positions) go into the netCDF file with their units
    (height in the lab frame) and through the checkpoint: a resumed run equals the full one."""
    cfgfile = tmp_path / "layer.toml"
    cfgfile.write_text(CONFIG.replace("vtk = true", "vtk = false")
                       + "[tracers]\npositions = [[0.01, 0.004], [0.02, 0.012], [0.03, 0.02]]\n")
    cfg = load_layer_config(cfgfile)
    full = tmp_path / "full.nc"
    run_layer_config(cfg, full)
    ds = xr.open_dataset(full)
    assert ds["tracer_z"].dims == ("time", "tracer") and ds["tracer_z"].attrs["units"] == "m"
    assert ds.sizes["tracer"] == 3
    np.testing.assert_allclose(ds["tracer_x"].values[0], [0.01, 0.02, 0.03], rtol=1e-14)
    # lab frame: the floor's position is added to the height
    np.testing.assert_allclose(ds["tracer_z"].values[0] - ds["floor"].values[0], [0.004, 0.012, 0.02], rtol=1e-12)
    rise = ds["tracer_z"].values - ds["floor"].values[:, None]
    assert np.ptp(rise[:, 2]) > 1e-5                    # the tap moves them
    ds.close()
    part = tmp_path / "part.nc"
    interrupt_and_resume(cfg, part)
    a, _ = read_snapshots(full)
    b, _ = read_snapshots(part)
    for k in ("time", "rho", "tracer_x", "tracer_z"):
        np.testing.assert_array_equal(a[k], b[k])


def test_layer_tracers_in_the_vtk_files(tmp_path):
    """With VTK output the tracers are a point cloud per snapshot (part 1 of the .pvd)."""
    import meshio

    cfgfile = tmp_path / "layer.toml"
    cfgfile.write_text(CONFIG.replace("t_end = 0.12", "t_end = 0.03").replace("checkpoint_every = 0.05", "checkpoint_every = 0.02")
                       + "[tracers]\npositions = [[0.01, 0.004], [0.02, 0.012]]\n")
    out = tmp_path / "layer.nc"
    run_layer_config(load_layer_config(cfgfile), out)
    pvd = (tmp_path / "layer_vtk" / "layer.pvd").read_text()
    assert pvd.count('part="1"') == 4 and "layer_tracers_000003.vtu" in pvd
    cloud = meshio.read(tmp_path / "layer_vtk" / "layer_tracers_000003.vtu")
    ds = xr.open_dataset(out)
    np.testing.assert_allclose(cloud.points[:, 0], ds["tracer_x"].values[3], rtol=1e-12)
    np.testing.assert_allclose(cloud.points[:, 2], ds["tracer_z"].values[3] - ds["floor"].values[3], rtol=1e-12)
    np.testing.assert_array_equal(cloud.point_data["tracer [1]"], [0.0, 1.0])
    ds.close()


def test_resume_of_a_finished_layer_run_does_nothing(tmp_path, capsys):
    """`--resume` on a finished layer output leaves it as it is and says so (exit 0), as for a
    column; without the finished file it is refused in one line."""
    cfg = tmp_path / "layer.toml"
    cfg.write_text(CONFIG.replace("vtk = true", "vtk = false").replace("t_end = 0.12", "t_end = 0.03")
                   .replace("checkpoint_every = 0.05", "checkpoint_every = 0.02"))
    out = tmp_path / "layer.nc"
    assert main(["run", str(cfg), "--out", str(out), "--quiet"]) == 0
    before = out.read_bytes()
    capsys.readouterr()
    assert main(["run", str(cfg), "--out", str(out), "--resume"]) == 0
    assert "complete already" in capsys.readouterr().out
    assert out.read_bytes() == before
    assert main(["run", str(cfg), "--out", str(tmp_path / "other.nc"), "--resume"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "no checkpoint" in lines[0]
    cfg.write_text(cfg.read_text().replace("t_end = 0.03", "t_end = 0.05"))
    assert main(["run", str(cfg), "--out", str(out), "--resume"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "another config" in lines[0]
    assert out.read_bytes() == before


def test_layer_resume_refuses_a_foreign_or_unreadable_output(tmp_path, capsys):
    """A layer's checkpoint beside an output another config wrote, or beside a file that is not
    an output: one line, exit 2 (the foreign file was continued; the unreadable one gave a
    traceback)."""
    import os

    def stop(t):
        if t > 0.055:
            raise KeyboardInterrupt()
    texts = {"a": CONFIG.replace("vtk = true", "vtk = false"),
             "b": CONFIG.replace("vtk = true", "vtk = false").replace("t_end = 0.12", "t_end = 0.11")}
    for stem, text in texts.items():
        (tmp_path / f"{stem}.toml").write_text(text)
        with pytest.raises(KeyboardInterrupt):
            run_layer_config(load_layer_config(tmp_path / f"{stem}.toml"), tmp_path / f"{stem}.nc", progress=stop)
    os.replace(tmp_path / "b.nc", tmp_path / "a.nc")        # a's checkpoint, b's output
    argv = ["run", str(tmp_path / "a.toml"), "--out", str(tmp_path / "a.nc"), "--resume", "--quiet"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "was written by another config" in err[0]
    (tmp_path / "a.nc").write_bytes(b"garbage")
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot reopen" in err[0] and "--resume" in err[0]


@pytest.mark.parametrize("text", [
    "[layer]\nkind = 'tapped_layer'\ndim = 2\n",
    "[layer]\nkind = 'vibrated_box'\ndim = 3\nsides = 'wall'\n",
    "[layer]\nkind = 'packing_bed'\ndim = 2\ngamma = 2.5\n[output]\ncheckpoint_every = 0.05\n"
    "[tracers]\npositions = [[0.01, 0.005], [0.02, 0.01]]\n",
    "[layer]\nkind = 'granular_bed'\ngamma = 2.5\n",
    "[layer]\nkind = 'granular_bed_eulerian'\ndimension = 3\n",
], ids=["tapped_layer", "vibrated_box", "packing_bed", "granular_bed", "granular_bed_eulerian"])
def test_resolved_config_lists_every_field_and_loads_to_the_same_setup(tmp_path, text):
    """The output's `config_resolved` holds every field, defaults included, and loading it
    gives the scenario that ran (the user's own text stays in `config`)."""
    import dataclasses
    (tmp_path / "a.toml").write_text(text)
    cfg = load_layer_config(tmp_path / "a.toml")
    resolved = cfg.resolved_text()
    from bsrflow.io.layer_runner import _NOT_OPTIONS
    kind = text.split("kind = '")[1].split("'")[0]
    for f in dataclasses.fields(cfg.setup):
        if f.name in _NOT_OPTIONS.get(kind, ()):          # a field its config refuses: not written
            assert f"{f.name} = " not in resolved, f.name
            continue
        assert f"{f.name} = " in resolved or f"# {f.name}: not given" in resolved, f.name
    (tmp_path / "b.toml").write_text(resolved)
    again = load_layer_config(tmp_path / "b.toml")
    assert again.setup == cfg.setup
    assert (again.vtk, again.checkpoint_every) == (cfg.vtk, cfg.checkpoint_every)
    assert (again.tracers is None) == (cfg.tracers is None)
    if cfg.tracers is not None:
        np.testing.assert_array_equal(again.tracers, cfg.tracers)
    assert again.resolved_text() == resolved


def test_layer_output_carries_the_resolved_config(tmp_path):
    cfg_file = tmp_path / "bed.toml"
    cfg_file.write_text("[layer]\nkind = 'packing_bed'\ndim = 2\nbox_width = 0.01\nbed_height = 0.01\n"
                        "t_end = 0.002\nsave_every = 0.001\n")
    assert main(["run", str(cfg_file), "--out", str(tmp_path / "bed.nc"), "--quiet"]) == 0
    with xr.open_dataset(tmp_path / "bed.nc") as ds:
        assert ds.attrs["config"] == cfg_file.read_text()
        assert "restitution = 0.9\n" in ds.attrs["config_resolved"]
        assert "stiffness = 50000.0\n" in ds.attrs["config_resolved"]


def test_set_overrides_a_layer_config(tmp_path, capsys):
    """`bsrflow run LAYER.toml --set KEY=VALUE` works as for a column (it was refused): layer fields
    (dotted or bare), output keys; the file's `config` is the config as run, which a `--resume` with the
    same overrides continues and one without them refuses naming the field; bad items are one line, exit 2."""
    import os
    cfg = tmp_path / "layer.toml"
    cfg.write_text(CONFIG.replace("vtk = true", "vtk = false"))
    out = tmp_path / "a.nc"
    argv = ["run", str(cfg), "--out", str(out), "--quiet", "--set", "t_end=0.03", "--set", "output.checkpoint_every=0.02"]
    assert main(argv) == 0
    with xr.open_dataset(out) as ds:
        assert float(ds["time"].values[-1]) == pytest.approx(0.03)
        assert "t_end = 0.03" in ds.attrs["config"] and "checkpoint_every = 0.02" in ds.attrs["config"]
        assert "t_end = 0.03" in ds.attrs["config_resolved"]
    capsys.readouterr()
    assert main([a for a in argv if a != "--quiet"] + ["--resume"]) == 0
    assert "complete already" in capsys.readouterr().out
    assert main(["run", str(cfg), "--out", str(out), "--resume", "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "layer.t_end" in err[0], err
    for bad, words in [(["--set", "layer.gamma=2"], "layer.gamma: unknown key"),
                       (["--set", "layer.t_end=-1"], "layer.t_end"),
                       (["--set", "tracers.positions=[[0.01, 0.01]]"], "--set tracers.positions"),
                       (["--set", "t_end=0.02", "--set", "layer.t_end=0.03"], "given twice"),
                       (["--set", "t_end"], "not KEY=VALUE"),
                       (["--scheme", "accurate"], "--set layer.scheme")]:
        assert main(["run", str(cfg), "--out", str(tmp_path / "b.nc"), "--quiet", *bad]) == 2, bad
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and words in err[0], (bad, err)
    assert not os.path.exists(tmp_path / "b.nc")
    # an entry that is not a table is the file's one-line error with --set too (it was a traceback)
    for text, words in [("layer = 5\n", "layer: 5 must be a table"),
                        ('output = 5\n[layer]\nkind = "packing_bed"\n', "output: 5 must be a table"),
                        ("[[layer]]\ndim = 2\n", "must be a table")]:
        (tmp_path / "odd.toml").write_text(text)
        assert main(["run", str(tmp_path / "odd.toml"), "--out", str(tmp_path / "b.nc"), "--quiet",
                     "--set", "t_end=0.1"]) == 2, text
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and words in err[0], (text, err)


def test_a_short_layer_run_has_checkpoints_by_default():
    """Without checkpoint_every a layer run checkpoints about every 0.1 s or every t_end/10 when
    that is shorter (a 0.1 s bed run that took 85 s of wall time had none)."""
    from bsrflow.io.layer_runner import _checkpoint_times, default_checkpoint_interval

    assert default_checkpoint_interval(2.0) == 0.1 and default_checkpoint_interval(0.1) == 0.01
    saves = np.round(np.arange(0, 101) * 1e-3, 12)                     # t_end 0.1 s, every 1 ms
    np.testing.assert_allclose(_checkpoint_times(saves, None), saves[10::10])
    saves = np.round(np.arange(0, 201) * 1e-2, 12)                     # t_end 2 s, every 10 ms
    np.testing.assert_allclose(_checkpoint_times(saves, None), saves[10::10])
    assert _checkpoint_times(saves, 0.0).size == 0
