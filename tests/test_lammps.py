"""LAMMPS/LIGGGHTS dump reader (bsrflow.io.lammps) and the BSR-vs-dump comparison."""

import dataclasses
import gzip
import json
import os

import numpy as np
import pytest

from bsrflow.io.lammps import read_dump, write_dump

# Three snapshots in LAMMPS's `dump custom` layout: columns in a non-standard order, atoms
# shuffled differently in every snapshot, boundary flags, a repeated column name (LIGGGHTS
# scripts often say "type type"), an extra blank line at the end.
CUSTOM = """\
ITEM: TIMESTEP
0
ITEM: NUMBER OF ATOMS
4
ITEM: BOX BOUNDS pp pp fm
-5.0000000000000000e-02 5.0000000000000000e-02
-5.0000000000000000e-02 5.0000000000000000e-02
0.0000000000000000e+00 1.0000000000000000e+00
ITEM: ATOMS type z id x y radius type
1 0.033 3 0.001 -0.002 0.011 1
1 0.011 1 0 0 0.011 1
2 0.077 7 0.003 0.0 0.011 2
1 0.055 5 -0.001 0.002 0.011 1
ITEM: TIMESTEP
1000
ITEM: NUMBER OF ATOMS
4
ITEM: BOX BOUNDS pp pp fm
-5.0000000000000000e-02 5.0000000000000000e-02
-5.0000000000000000e-02 5.0000000000000000e-02
0.0000000000000000e+00 1.0000000000000000e+00
ITEM: ATOMS type z id x y radius type
2 0.080 7 0.003 0.0 0.011 2
1 0.012 1 0 0 0.011 1
1 0.058 5 -0.001 0.002 0.011 1
1 0.035 3 0.001 -0.002 0.011 1
ITEM: TIMESTEP
2000
ITEM: NUMBER OF ATOMS
4
ITEM: BOX BOUNDS pp pp fm
-5.0000000000000000e-02 5.0000000000000000e-02
-5.0000000000000000e-02 5.0000000000000000e-02
0.0000000000000000e+00 1.0000000000000000e+00
ITEM: ATOMS type z id x y radius type
1 0.060 5 -0.001 0.002 0.011 1
1 0.036 3 0.001 -0.002 0.011 1
1 0.013 1 0 0 0.011 1
2 0.083 7 0.003 0.0 0.011 2

"""


def _write(tmp_path, text, name="test.dump"):
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def test_custom_dump_shuffled_ids_any_column_order(tmp_path):
    path = _write(tmp_path, CUSTOM)
    d = read_dump(path, timestep_size=1e-5)
    assert d.n_snapshots == 3 and d.n_atoms == 4
    np.testing.assert_array_equal(d.timestep, [0, 1000, 2000])
    np.testing.assert_allclose(d.t, [0.0, 0.01, 0.02], rtol=0, atol=1e-15)
    np.testing.assert_array_equal(d.ids, [1, 3, 5, 7])
    np.testing.assert_array_equal(d.types, [1, 1, 1, 2])
    np.testing.assert_array_equal(d.heights(), [[0.011, 0.033, 0.055, 0.077],
                                                [0.012, 0.035, 0.058, 0.080],
                                                [0.013, 0.036, 0.060, 0.083]])
    np.testing.assert_array_equal(d.positions[1, :, 0], [0, 0.001, -0.001, 0.003])
    np.testing.assert_array_equal(d.top(), [0.077, 0.080, 0.083])
    np.testing.assert_allclose(d.mass_centre(), d.heights().mean(axis=1))
    np.testing.assert_allclose(d.diameters(), 0.022)
    assert d.boundary == "pp pp fm" and d.units is None and d.length_scale == 1.0
    np.testing.assert_array_equal(d.heights("x"), d.positions[:, :, 0])
    # the selection of one atom type (e.g. dropping wall particles)
    only1 = d.select([1])
    np.testing.assert_array_equal(only1.ids, [1, 3, 5])
    np.testing.assert_array_equal(only1.top(), [0.055, 0.058, 0.060])
    # without a step size and without ITEM: TIME the times are unknown
    assert read_dump(path).t is None
    # gzip-compressed (dump custom/gz) and a non-numeric column (element names), which is skipped
    gz = tmp_path / "test.dump.gz"
    with gzip.open(gz, "wt") as fh:
        fh.write(CUSTOM.replace("radius type\n", "radius element\n").replace(" 0.011 1\n", " 0.011 Fe\n")
                 .replace(" 0.011 2\n", " 0.011 Ni\n"))
    z = read_dump(gz, timestep_size=1e-5)
    np.testing.assert_array_equal(z.positions, d.positions)
    assert "element" not in z.fields and "radius" in z.fields


def test_dump_atom_scaled_coordinates_with_image_flags(tmp_path):
    # `dump atom` with `dump_modify image yes`: id type xs ys zs ix iy iz, box [0,2]x[-1,1]x[1,5]
    text = """ITEM: TIMESTEP
10
ITEM: NUMBER OF ATOMS
2
ITEM: BOX BOUNDS pp pp pp
0.0000000000000000e+00 2.0000000000000000e+00
-1.0000000000000000e+00 1.0000000000000000e+00
1.0000000000000000e+00 5.0000000000000000e+00
ITEM: ATOMS id type xs ys zs ix iy iz
2 1 0.5 0.25 0.75 0 0 1
1 1 0.25 0.5 0.5 -1 0 0
"""
    d = read_dump(_write(tmp_path, text), axis="z")
    # atom 1: x = 0 + (0.25 - 1) * 2, y = -1 + 0.5 * 2, z = 1 + 0.5 * 4
    # atom 2: x = 0 + 0.5 * 2,         y = -1 + 0.25 * 2, z = 1 + (0.75 + 1) * 4
    np.testing.assert_allclose(d.positions[0], [[-1.5, 0.0, 3.0], [1.0, -0.5, 8.0]])


def test_triclinic_box_scaled_and_unwrapped_priority(tmp_path):
    # restricted triclinic box xlo=0 xhi=4, ylo=0 yhi=2, zlo=0 zhi=3, tilts xy=1 xz=-0.5 yz=0.25;
    # LAMMPS writes the bounding box: xlo_bound = 0 + min(0, 1, -0.5, 0.5) = -0.5,
    # xhi_bound = 4 + max(0, 1, -0.5, 0.5) = 5, ylo_bound = 0, yhi_bound = 2.25
    text = """ITEM: TIMESTEP
0
ITEM: NUMBER OF ATOMS
1
ITEM: BOX BOUNDS xy xz yz pp pp pp
-5.0000000000000000e-01 5.0000000000000000e+00 1.0000000000000000e+00
0.0000000000000000e+00 2.2500000000000000e+00 -5.0000000000000000e-01
0.0000000000000000e+00 3.0000000000000000e+00 2.5000000000000000e-01
ITEM: ATOMS id xs ys zs
1 0.5 0.5 0.5
"""
    d = read_dump(_write(tmp_path, text))
    # r = o + s H, H rows (4,0,0), (1,2,0), (-0.5,0.25,3)
    np.testing.assert_allclose(d.positions[0, 0], [2.0 + 0.5 - 0.25, 1.0 + 0.125, 1.5])
    np.testing.assert_allclose(d.cell[0], [[4, 0, 0], [1, 2, 0], [-0.5, 0.25, 3]])
    # unwrapped columns win over wrapped and scaled ones
    both = text.replace("id xs ys zs", "id xs ys zs x y z xu yu zu").replace(
        "1 0.5 0.5 0.5", "1 0.5 0.5 0.5 9 9 9 7 8 6")
    np.testing.assert_array_equal(read_dump(_write(tmp_path, both, "b.dump")).positions[0, 0], [7, 8, 6])


def test_units_and_time_blocks(tmp_path):
    # dump_modify units yes time yes: UNITS once, TIME before every TIMESTEP; cgs = cm, s
    text = """ITEM: UNITS
cgs
ITEM: TIME
0
ITEM: TIMESTEP
0
ITEM: NUMBER OF ATOMS
1
ITEM: BOX BOUNDS ff ff ff
0.0000000000000000e+00 1.0000000000000000e+01
0.0000000000000000e+00 1.0000000000000000e+01
0.0000000000000000e+00 1.0000000000000000e+01
ITEM: ATOMS id type x y z
1 1 1.0 2.0 3.5
ITEM: TIME
0.0025000000000000001
ITEM: TIMESTEP
50
ITEM: NUMBER OF ATOMS
1
ITEM: BOX BOUNDS ff ff ff
0.0000000000000000e+00 1.0000000000000000e+01
0.0000000000000000e+00 1.0000000000000000e+01
0.0000000000000000e+00 1.0000000000000000e+01
ITEM: ATOMS id type x y z
1 1 1.0 2.0 4.5
"""
    d = read_dump(_write(tmp_path, text))
    assert d.units == "cgs" and d.length_scale == 0.01
    np.testing.assert_allclose(d.heights(), [[0.035], [0.045]])
    np.testing.assert_allclose(d.t, [0.0, 0.0025])
    np.testing.assert_allclose(d.cell[0], np.diag([0.1, 0.1, 0.1]))
    with pytest.raises(ValueError, match="length_scale"):
        read_dump(_write(tmp_path, text.replace("cgs", "lj"), "lj.dump"))
    np.testing.assert_allclose(read_dump(_write(tmp_path, text.replace("cgs", "lj"), "lj2.dump"), timestep_size=1e-4,
                                         length_scale=2.0).heights(), [[7.0], [9.0]])


def _snapshot(step, rows, columns="id type x y z", n=None):
    n = len(rows) if n is None else n
    return (f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n{n}\nITEM: BOX BOUNDS ff ff ff\n"
            "0.0 1.0\n0.0 1.0\n0.0 1.0\n"
            f"ITEM: ATOMS {columns}\n" + "".join(r + "\n" for r in rows))


@pytest.mark.parametrize("text, line, match", [
    # a non-numeric coordinate: the line of the atom
    (_snapshot(0, ["1 1 0 0 0.1", "2 1 0 0 abc"]), 11, "column 'z' holds 'abc'"),
    # an atom line with a missing value
    (_snapshot(0, ["1 1 0 0 0.1", "2 1 0 0"]), 11, "has 4 values"),
    # atom 2 disappears and atom 3 appears: the start of the second snapshot
    (_snapshot(0, ["1 1 0 0 0.1", "2 1 0 0 0.2"]) + _snapshot(5, ["1 1 0 0 0.1", "3 1 0 0 0.2"]), 12,
     r"atom id\(s\) 2 disappeared and atom id\(s\) 3 appeared"),
    # an atom lost without its id reappearing: fewer atoms
    (_snapshot(0, ["1 1 0 0 0.1", "2 1 0 0 0.2"]) + _snapshot(5, ["2 1 0 0 0.2"]), 12, "disappeared"),
    # no id column
    (_snapshot(0, ["1 0 0 0.1"], columns="type x y z"), 9, "no 'id' column"),
    # no coordinate for the vertical axis
    (_snapshot(0, ["1 1 0 0"], columns="id type x y"), 9, "no coordinate column for axis 'z'"),
    # NUMBER OF ATOMS says 3 but the next snapshot starts after 2 atom lines
    (_snapshot(0, ["1 1 0 0 0.1", "2 1 0 0 0.2"], n=3) + _snapshot(5, ["1 1 0 0 0.1"]), 12, "NUMBER OF ATOMS"),
    # time steps going backwards
    (_snapshot(5, ["1 1 0 0 0.1"]) + _snapshot(5, ["1 1 0 0 0.2"]), 11, "does not increase"),
    # a duplicated atom
    (_snapshot(0, ["1 1 0 0 0.1", "1 1 0 0 0.2"]), 9, "appears twice"),
    # not an ITEM line where one is due
    ("ITEM: TIMESTEP\n0\nhello\n", 3, "expected an 'ITEM:' line"),
    # a bad timestep
    ("ITEM: TIMESTEP\n0.5\n", 2, "expected one integer"),
    # a local dump is not a per-atom dump
    ("ITEM: TIMESTEP\n0\nITEM: NUMBER OF ENTRIES\n3\n", 3, "not part of a per-atom dump"),
])
def test_malformed_dumps_name_file_and_line(tmp_path, text, line, match):
    path = _write(tmp_path, text, "bad.dump")
    with pytest.raises(ValueError, match=match) as info:
        read_dump(path)
    assert str(info.value).startswith(f"{path}, line {line}:"), str(info.value)


def test_truncated_dump_and_drop_incomplete(tmp_path):
    good = _snapshot(0, ["1 1 0 0 0.1", "2 1 0 0 0.2"])
    path = _write(tmp_path, good + _snapshot(5, ["1 1 0 0 0.1"], n=2), "cut.dump")
    with pytest.raises(ValueError, match=r"line 22: file ends after 1 of the 2 atom lines"):
        read_dump(path)
    d = read_dump(path, drop_incomplete=True)
    assert d.n_snapshots == 1
    with pytest.raises(ValueError, match="no snapshot"):
        read_dump(_write(tmp_path, "\n\n", "empty.dump"))
    with pytest.raises(FileNotFoundError):
        read_dump(tmp_path / "missing.dump")
    with pytest.raises(ValueError, match="axis"):
        read_dump(path, axis="w")


@pytest.fixture(scope="module")
def small_setup():
    from bsrflow.physics.column import ColumnSetup
    return ColumnSetup(n_spheres=3, points_per_diameter=4, t_end=0.2, tap_start=0.02, m0=400.0, save_every=0.005)


@pytest.fixture(scope="module")
def dem_result(small_setup):
    from bsrflow.physics.dem import DEMColumn, run_dem
    s = small_setup
    col = DEMColumn(n_spheres=s.n_spheres, diameter=s.diameter, density=s.density, stiffness=s.stiffness,
                    restitution=s.restitution, gravity=s.gravity)
    return run_dem(col, s.motion(), s.t_end, sample_interval=s.save_every)


def _dump_of(res, path, offset=0.0, **kw):
    """Write a DEMResult as a dump: one LAMMPS step per DEM step, x = y = 0."""
    steps_per_sample = int(round((res.t[1] - res.t[0]) / res.dt))
    write_dump(path, np.arange(res.t.size) * steps_per_sample, res.positions + offset, **kw)
    return res.dt


def test_round_trip_reproduces_dem_top_and_mass_centre_exactly(tmp_path, dem_result):
    res = dem_result
    path = str(tmp_path / "dem.dump")
    dt = _dump_of(res, path, fields={"radius": np.full(res.positions.shape, res.column.diameter / 2)})
    d = read_dump(path, timestep_size=dt)
    np.testing.assert_array_equal(d.top(), res.top())
    np.testing.assert_array_equal(d.mass_centre(), res.mass_centre())
    np.testing.assert_array_equal(d.heights(), res.positions)
    np.testing.assert_allclose(d.t, res.t, rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(d.diameters(), res.column.diameter)
    assert res.top().max() > res.top()[0] + res.column.diameter     # the tap really threw the column


@pytest.fixture(scope="module")
def bsr_run(small_setup):
    from bsrflow.physics.column import run_bsr_column
    return run_bsr_column(small_setup)


def test_compare_with_dump_gives_the_compare_metrics(tmp_path, small_setup, dem_result, bsr_run):
    from bsrflow.analysis.compare import _metrics
    from bsrflow.analysis.compare_dump import compare_with_dump

    res, run, s = dem_result, bsr_run, small_setup
    d = s.diameter
    # what bsrflow compare computes for the built-in DEM (compare.compare, inline)
    expect_dem = _metrics(res.t, res.top(), res.mass_centre(), s)
    expect_bsr = _metrics(run.t, run.top, run.mass_centre, s)
    expect_rms = float(np.sqrt(np.mean(((np.interp(res.t, run.t, run.mass_centre) - res.mass_centre()) / d) ** 2)))

    path = str(tmp_path / "col.dump")
    dt = _dump_of(res, path)
    dump = read_dump(path, timestep_size=dt)
    figs = str(tmp_path / "fig")
    out = compare_with_dump(run, dump, figures=figs)
    assert out["dem"] == pytest.approx(expect_dem, rel=1e-12)
    assert out["bsr"] == expect_bsr
    assert out["mass_centre_rms_over_d"] == pytest.approx(expect_rms, rel=1e-12)
    assert out["top_max_rel_diff"] == pytest.approx(expect_bsr["top_max_over_d"] / expect_dem["top_max_over_d"] - 1)
    assert out["t_top_max_rel_diff"] == pytest.approx(expect_bsr["t_top_max"] / expect_dem["t_top_max"] - 1)
    assert out["warnings"] == [] and out["dump"]["snapshots_used"] == res.t.size
    assert sorted(out["figures"]) == ["col_density.png", "col_top_centre.png", "col_trajectories.png"]
    for f in out["figures"]:
        assert os.path.getsize(os.path.join(figs, f)) > 10000
    json.dumps(out)

    # a floor at z = 0.25 m in the DEM's frame and a settling phase of 0.1 s before the BSR's t = 0
    path2 = str(tmp_path / "shifted.dump")
    steps_per_sample = int(round((res.t[1] - res.t[0]) / res.dt))
    pre = int(round(0.1 / res.dt))
    write_dump(path2, pre + np.arange(res.t.size) * steps_per_sample, res.positions + 0.25)
    shifted = compare_with_dump(run, read_dump(path2, timestep_size=res.dt), floor=0.25, time_offset=pre * res.dt)
    assert shifted["dem"]["top_max_over_d"] == pytest.approx(expect_dem["top_max_over_d"], rel=1e-12)
    assert shifted["dem"]["t_top_max"] == pytest.approx(expect_dem["t_top_max"], abs=1e-12)
    assert shifted["mass_centre_rms_over_d"] == pytest.approx(expect_rms, rel=1e-9)

    # snapshots after the end of the BSR run are left out, with a warning
    shorter = dataclasses.replace(run, t=run.t[:20], top=run.top[:20], mass_centre=run.mass_centre[:20])
    partial = compare_with_dump(shorter, dump)
    assert partial["dump"]["snapshots_used"] == 20 and "left out" in partial["warnings"][0]
    with pytest.raises(ValueError, match="time step"):
        compare_with_dump(run, read_dump(path))


def test_compare_dump_command(tmp_path, dem_result, bsr_run, capsys):
    from bsrflow.cli import main

    res = dem_result
    path = str(tmp_path / "cli.dump")
    dt = _dump_of(res, path, offset=0.1)
    (tmp_path / "out").mkdir()            # the folder of an output must exist (bsrflow.io.paths)
    js = str(tmp_path / "out" / "c.json")
    figs = str(tmp_path / "out" / "fig")
    args = ["compare-dump", path, "--dt", repr(dt), "--floor-offset", "0.1", "--n-spheres", "3", "--ppd", "4",
            "--tap-start", "0.02", "--m0", "400", "--eps", "0.105", "--set", "save_every=0.005", "--json", js, "--figures", figs]
    assert main(args) == 0
    printed = capsys.readouterr().out
    result = json.load(open(js))
    assert result["setup"]["t_end"] == pytest.approx(res.t[-1])
    assert result["dem"]["top_max_over_d"] == pytest.approx(
        res.top()[res.t >= 0.02 - 1e-12].max() / res.column.diameter, rel=1e-9)
    assert result["bsr"]["top_max_over_d"] == pytest.approx(bsr_run.top[bsr_run.t >= 0.02 - 1e-12].max() / 0.022)
    assert os.path.join(figs, "cli_top_centre.png") in printed
    # no time step and no ITEM: TIME: exit 2 with one line
    assert main(["compare-dump", path, "--n-spheres", "3"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--dt" in err[0]
    assert main(["compare-dump", path, "--dt", "1e-6", "--set", "bogus=1"]) == 2
    assert "bogus" in capsys.readouterr().err


def test_top_is_the_highest_sphere_in_metrics_figure_and_json(tmp_path, small_setup, dem_result, bsr_run):
    """Atom ids numbered from the top (id 1 the top sphere): the metrics, the JSON and the
    top-height figure all use the highest sphere centre, not the sphere with the highest id."""
    from bsrflow.analysis.compare import _metrics
    from bsrflow.analysis.compare_dump import compare_with_dump
    from bsrflow.plots import top_and_centre_figure

    res, run, s = dem_result, bsr_run, small_setup
    # the package's own DEM keeps its spheres in order, so its last sphere is the highest one
    # (what bsrflow compare's metrics use, positions[:, -1])
    assert np.all(np.diff(res.positions, axis=1) > 0)
    path = str(tmp_path / "fromtop.dump")
    steps_per_sample = int(round((res.t[1] - res.t[0]) / res.dt))
    n = res.positions.shape[1]
    write_dump(path, np.arange(res.t.size) * steps_per_sample, res.positions, ids=np.arange(n, 0, -1))
    dump = read_dump(path, timestep_size=res.dt)
    assert np.array_equal(dump.heights()[:, 0], res.positions[:, -1])      # id 1 is the top sphere
    out = compare_with_dump(run, dump, figures=str(tmp_path / "fig"))
    assert out["dem"] == pytest.approx(_metrics(res.t, res.top(), res.mass_centre(), s), rel=1e-12)
    assert json.loads(json.dumps(out))["dem"]["top_max_over_d"] == out["dem"]["top_max_over_d"]
    fig = top_and_centre_figure(run, (dump.t, dump.heights(), None))
    (line,) = [ln for ln in fig.axes[0].lines if ln.get_label().startswith("DEM top")]
    np.testing.assert_array_equal(line.get_ydata(), res.top() / s.diameter)
    after = dump.t >= s.tap_start - 1e-12
    assert line.get_ydata()[after].max() == pytest.approx(out["dem"]["top_max_over_d"], rel=1e-12)
    import matplotlib.pyplot as plt
    plt.close(fig)


@pytest.mark.parametrize("file_name, name", [
    ("dump.z", "dump.z"), ("x.dump", "x"), ("x.dump.gz", "x_gz"), ("run.lammpstrj", "run"),
    ("tap.column.dump", "tap.column"), ("dump", "dump"), (".dump", ".dump"), ("a/b/col.dump.gz", "col_gz"),
])
def test_case_names_from_the_whole_file_name(file_name, name):
    from bsrflow.analysis.compare_dump import case_name
    assert case_name(file_name) == name


def test_compare_dump_name_option_and_distinct_default_names(tmp_path, dem_result, capsys):
    """x.dump and x.dump.gz give different figure names; --name sets the name."""
    from bsrflow.cli import main

    res = dem_result
    plain = str(tmp_path / "x.dump")
    dt = _dump_of(res, plain)
    with open(plain, "rb") as fh, gzip.open(str(tmp_path / "x.dump.gz"), "wb") as gz:
        gz.write(fh.read())
    common = ["--dt", repr(dt), "--n-spheres", "3", "--ppd", "4", "--tap-start", "0.02", "--m0", "400",
              "--t-end", "0.05", "--set", "save_every=0.005"]
    names = []
    for p, extra in ((plain, []), (plain + ".gz", []), (plain, ["--name", "mine"])):
        js = str(tmp_path / "r.json")
        assert main(["compare-dump", p, *common, *extra, "--json", js]) == 0
        names.append(json.load(open(js))["name"])
    assert names == ["x", "x_gz", "mine"]
    capsys.readouterr()
    assert main(["compare-dump", plain, *common, "--name", "a/b"]) == 2
    assert "--name" in capsys.readouterr().err


def test_compare_dump_runs_the_packing_continuum(tmp_path, small_setup, dem_result, capsys):
    """`--kernel packing`: the packing continuum (Lagrangian, R = d, nothing fitted) against the
    dump, named in the printed line and the JSON; its metrics are compare_with_dump's of that
    run; the seed kernel's parameters are refused with it in one line (exit 2)."""
    from bsrflow.analysis.compare_dump import compare_with_dump
    from bsrflow.cli import main
    from bsrflow.physics.column import run_bsr_column

    res = dem_result
    path = str(tmp_path / "pk.dump")
    dt = _dump_of(res, path)
    js = str(tmp_path / "pk.json")
    common = ["compare-dump", path, "--dt", repr(dt), "--n-spheres", "3", "--ppd", "4", "--tap-start", "0.02",
              "--set", "save_every=0.005"]
    assert main(common + ["--kernel", "packing", "--json", js]) == 0
    assert "packing lagrangian R=1d top" in capsys.readouterr().out
    result = json.load(open(js))
    assert result["model"] == "packing lagrangian R=1d" and result["setup"]["kernel_name"] == "packing"
    s = small_setup.with_(kernel_name="packing", formulation="lagrangian", t_end=result["setup"]["t_end"])
    expect = compare_with_dump(run_bsr_column(s), read_dump(path, timestep_size=dt))
    assert result["bsr"] == expect["bsr"] and result["dem"] == pytest.approx(expect["dem"], rel=1e-12)
    assert result["mass_centre_rms_over_d"] == pytest.approx(expect["mass_centre_rms_over_d"], rel=1e-12)
    for extra, word in ((["--m0", "400"], "--m0"), (["--set", "eps=0.5"], "--set eps"),
                        (["--set", "kernel=seed"], "contradicts"),
                        (["--set", "model.kernel=seed"], "--kernel packing contradicts --set model.kernel=seed"),
                        (["--scheme", "seed"], "--scheme"),
                        (["--scheme", "accurate"], "--scheme"), (["--set", "n_spheres=5"], "--n-spheres 3 contradicts"),
                        (["--set", "ppd=5", "--set", "points_per_diameter=6"], "given twice")):
        assert main(common + ["--kernel", "packing"] + extra) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and word in err[0]
