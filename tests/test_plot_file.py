"""`bsrflow plot FILE.nc`: figures from an output netCDF file (synthetic files of the schema)."""

import os

import numpy as np
import pytest
import xarray as xr

from bsrflow.tools.plot_file import load_output, plot_file

D = 0.022          # sphere diameter [m]
KINDS = ("density", "tracers", "top_centre", "kinetic_energy")


def synthetic(nt=40, nx=120, n_tracers=5, diameter=True):
    """A column of 5 spheres thrown up by a floor tap: uniform density m/d below the column top
    H(t), floor a half-sine bump, tracers at fixed fractions of the column."""
    t = np.linspace(0.0, 0.4, nt)
    x = (np.arange(nx) + 0.5) * (0.5 / nx)                     # cell centres [m], floor frame
    floor = np.where((t > 0.1) & (t < 0.15), 0.0165 * np.sin(np.pi * (t - 0.1) / 0.05), 0.0)
    H = 5 * D * (1 + 2.0 * np.clip(np.sin(np.pi * (t - 0.1) / 0.3), 0, None) * (t > 0.1))
    line = 1200 * np.pi / 6 * D ** 3 / D
    rho = np.where(x[None, :] < H[:, None], line * 5 * D / H[:, None], 0.0)
    u = np.gradient(H, t)[:, None] * x[None, :] / H[:, None]
    frac = (np.arange(n_tracers) + 0.5) / n_tracers
    tracer = floor[:, None] + frac[None, :] * H[:, None]
    ds = xr.Dataset(
        {"rho": (("time", "x"), rho, {"units": "kg m-1", "long_name": "line density"}),
         "u": (("time", "x"), u, {"units": "m s-1"}),
         "tracer_height": (("time", "tracer"), tracer, {"units": "m"}),
         "floor": ("time", floor, {"units": "m"}),
         "top": ("time", tracer[:, -1], {"units": "m"}),
         "mass_centre": ("time", floor + H / 2, {"units": "m"}),
         "mass": ("time", np.full(nt, line * 5 * D), {"units": "kg"}),
         "kinetic_energy": ("time", 0.5 * (rho * u ** 2).sum(axis=1) * (x[1] - x[0]), {"units": "J"})},
        coords={"time": ("time", t, {"units": "s"}), "x": ("x", x, {"units": "m"})},
        attrs={"config": "n_spheres = 5\n", "bsrflow_version": "0.1.0"})
    if diameter:
        ds.attrs["diameter"] = D
    return ds


def _check_pngs(paths, out, stem, kinds=KINDS):
    assert [os.path.basename(p) for p in paths] == [f"{stem}_{k}.png" for k in kinds]
    for p in paths:
        assert os.path.dirname(p) == str(out)
        with open(p, "rb") as fh:
            assert fh.read(8) == b"\x89PNG\r\n\x1a\n"
        assert os.path.getsize(p) > 5000


def test_full_file_all_figures(tmp_path):
    path = tmp_path / "run.nc"
    synthetic().to_netcdf(path)
    out = tmp_path / "figs"
    paths = plot_file(str(path), str(out), log=None)
    _check_pngs(paths, out, "run")


def test_single_snapshot_and_no_diameter(tmp_path):
    path = tmp_path / "one.nc"
    synthetic(diameter=False).isel(time=[5]).to_netcdf(path)
    paths = plot_file(str(path), str(tmp_path), log=None)
    _check_pngs(paths, tmp_path, "one")


def test_partially_written_file(tmp_path, capsys):
    """A file still being written: the unlimited time axis holds 12 entries of which 9 have a time
    and only 6 have density rows (the rest are netCDF fill values); no kinetic_energy yet."""
    netCDF4 = pytest.importorskip("netCDF4")
    full = synthetic(nt=12)
    path = tmp_path / "partial.nc"
    with netCDF4.Dataset(path, "w") as nc:
        nc.createDimension("time", None)
        nc.createDimension("x", full.sizes["x"])
        nc.createDimension("tracer", full.sizes["tracer"])
        nc.diameter = D
        v = {}
        for name in ("time", "x", "rho", "u", "tracer_height", "floor", "top", "mass_centre", "mass"):
            v[name] = nc.createVariable(name, "f8", full[name].dims)
        v["x"][:] = full["x"].values
        v["time"][:9] = full["time"].values[:9]
        for name in ("floor", "top", "mass_centre", "mass"):
            v[name][:9] = full[name].values[:9]
        v["tracer_height"][:9] = full["tracer_height"].values[:9]
        v["rho"][:6] = full["rho"].values[:6]
        v["u"][:6] = full["u"].values[:6]
        v["time"][11] = np.float64(9.969209968386869e36)     # the fill value, written explicitly
    ds, keep = load_output(str(path))
    np.testing.assert_array_equal(keep, np.arange(9))
    paths = plot_file(str(path), None, log=None)             # default: next to the file
    _check_pngs(paths, tmp_path, "partial", KINDS[:3])
    assert "kinetic_energy" in capsys.readouterr().err


def test_plot_command(tmp_path, capsys):
    from bsrflow.cli import main

    path = tmp_path / "cmd.nc"
    synthetic(nt=8).to_netcdf(path)
    assert main(["plot", str(path), "--out", str(tmp_path / "o")]) == 0
    printed = capsys.readouterr().out.split()
    assert printed == [str(tmp_path / "o" / f"cmd_{k}.png") for k in KINDS]
    assert all(os.path.exists(p) for p in printed)
    # not a netCDF file, a missing file, a file without time: exit 2, one line
    bad = tmp_path / "bad.nc"
    bad.write_text("not netcdf")
    for arg in (str(bad), str(tmp_path / "missing.nc")):
        assert main(["plot", arg]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("bsrflow plot: error:")
    xr.Dataset({"a": ("n", [1.0])}).to_netcdf(tmp_path / "notime.nc")
    assert main(["plot", str(tmp_path / "notime.nc")]) == 2
    assert "no 'time'" in capsys.readouterr().err


def test_layer_files_are_plotted_with_the_horizontal_average(tmp_path, capsys):
    """A 2-D layer's file (rho(time, x, z), tracer_z): the density map is the average over x, the
    tracers are its tracer_z; four figures, exit 0 (it failed with a traceback before)."""
    from bsrflow.cli import main
    from bsrflow.tools.plot_file import vertical_density

    rng = np.random.default_rng(3)
    rho = rng.uniform(0.0, 5.0, (4, 6, 9))
    rho[1, :, 2] = np.nan
    ds = xr.Dataset({"rho": (("time", "x", "z"), rho)}, coords={"time": np.arange(4.0), "x": np.arange(6.0),
                                                                "z": np.arange(9.0)})
    name, avg, averaged = vertical_density(ds, rho)
    assert name == "z" and averaged and avg.shape == (4, 9)
    np.testing.assert_allclose(avg[0], rho[0].mean(axis=0), rtol=1e-15)
    assert np.isnan(avg[1, 2]) and np.isfinite(np.delete(avg, 2, axis=1)).all()
    cfg = tmp_path / "l.toml"
    cfg.write_text('[layer]\nkind = "tapped_layer"\ndim = 2\nt_end = 0.02\nsave_every = 0.01\n'
                   '[tracers]\npositions = [[0.002, 0.001], [0.004, 0.002]]\n')
    out = tmp_path / "l.nc"
    assert main(["run", str(cfg), "--out", str(out), "--quiet"]) == 0
    capsys.readouterr()
    assert main(["plot", str(out), "--out", str(tmp_path / "fig")]) == 0
    assert capsys.readouterr().err == ""
    for kind in KINDS:
        assert os.path.getsize(tmp_path / "fig" / f"l_{kind}.png") > 1000


@pytest.mark.parametrize("status, shown", [("running", "status: running"),
                                           ("interrupted by Ctrl-C (SIGINT) after 8 snapshots",
                                            "status: interrupted by Ctrl-C (SIGINT) after 8 snapshots"),
                                           ("ok", None)])
def test_figures_of_an_unfinished_run_say_so_in_their_title(tmp_path, monkeypatch, status, shown):
    """The stderr warning is lost once the PNGs are passed on: every figure's title says it."""
    import matplotlib.figure

    titles = []
    real = matplotlib.figure.Figure.savefig

    def recording(fig, *a, **k):
        titles.append(fig._suptitle.get_text() if fig._suptitle is not None else "")
        return real(fig, *a, **k)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", recording)
    ds = synthetic(nt=8)
    ds.attrs["status"] = status
    path = tmp_path / "run.nc"
    ds.to_netcdf(path)
    plot_file(str(path), str(tmp_path / "f"), log=None)
    assert len(titles) == len(KINDS)
    for title in titles:
        if shown is None:
            assert "UNFINISHED" not in title
        else:
            assert f"UNFINISHED RUN ({shown}): 8 snapshot(s) up to t = 0.4 s" in title, title


def test_a_file_that_is_not_netcdf_is_named_so(tmp_path):
    """xarray's message for an unknown format ends in a URL on its second line, which the
    one-line error cut off mid-sentence; the package says what the file is not."""
    path = tmp_path / "col.toml"
    path.write_text("[run]\nt_end = 0.1\n")
    with pytest.raises(ValueError, match=r"col\.toml: cannot be read as netCDF \(ValueError: not a netCDF file "
                                         r"\(no installed reader recognises its format\)\)$"):
        load_output(str(path))
