"""Issue #18, the named state in the output: with `run.write_state = true` a packing column's netCDF
file holds the discretisation's state fields (`state_<name>`, with units), the same fields as its
checkpoints, and a resumed run writes them bit for bit as an uninterrupted one."""
import numpy as np
import pytest
import xarray as xr

from bsrflow.cli import main

BASE = ('[model]\nkernel = "packing"\n[numerics]\nformulation = "{form}"\n'
        '[run]\nt_end = 0.5\nsave_every = 0.025\ncheckpoint_every = 0.1\nwrite_state = true\n')


def _config_text(form):
    """The config of ``form``: eulerian (the local limit, R = 0: finite volumes), lagrangian, or
    eulerian_nonlocal (the default range R = d: the staggered grid with a tracked surface)."""
    if form == "eulerian":                       # the local limit's finite volumes; 6 spheres (its cost)
        return (BASE.format(form="eulerian").replace('kernel = "packing"\n', 'kernel = "packing"\nrange_over_d = 0.0\n')
                + "[column]\nn_spheres = 6\n")
    if form == "eulerian_nonlocal":              # 6 spheres: the form costs 13-30x the Lagrangian one
        return BASE.format(form="eulerian") + "[column]\nn_spheres = 6\n"
    return BASE.format(form=form)


def _run(tmp_path, form, name="a", argv=()):
    cfg = tmp_path / f"{name}.toml"
    cfg.write_text(_config_text(form))
    out = tmp_path / f"{name}.nc"
    assert main(["run", str(cfg), "--out", str(out), "--quiet", *argv]) == 0
    return out


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("state")
    return {form: _run(tmp, form, form) for form in ("eulerian", "lagrangian", "eulerian_nonlocal")}


def test_eulerian_state_fields_are_the_grid_state(files):
    """The finite volumes' state on the grid: state_rho is the file's rho, momentum / rho its u where
    there is material, rho_delta_max / rho the history, which the tap at 0.4 s loads (> 0) and which is
    never more than the largest overlap a contact can reach here (1 % of d)."""
    with xr.open_dataset(files["eulerian"]) as ds:
        assert ds.attrs["time_variables"].split()[-3:] == ["state_rho", "state_momentum", "state_rho_delta_max"]
        assert [ds[f"state_{k}"].attrs["units"] for k in ("rho", "momentum", "rho_delta_max")] == \
            ["kg m-1", "kg s-1", "kg"]
        np.testing.assert_array_equal(ds["state_rho"].values, ds["rho"].values)
        rho, mom = ds["state_rho"].values, ds["state_momentum"].values
        full = rho > 1e-6 * rho.max()
        np.testing.assert_allclose(mom[full] / rho[full], ds["u"].values[full], rtol=1e-12, atol=1e-12)
        hist = np.where(full, ds["state_rho_delta_max"].values / np.where(full, rho, 1.0), 0.0)
        d = float(ds.attrs["diameter"])
        assert hist.min() >= 0.0 and 0.0 < hist.max() < 0.01 * d


def test_lagrangian_state_fields_are_the_material_points(files):
    """The material points: their positions give the file's sphere-centre tracers (the mass coordinate
    (k + 1/2) m interpolated between them, as the formulation does) to round-off, they stay ordered, and
    the bond histories (lag, point) are non-negative and loaded by the tap."""
    with xr.open_dataset(files["lagrangian"]) as ds:
        x = ds["state_position"].values
        assert ds["state_delta_max"].dims == ("time", "lag", "point")
        assert list(ds["lag"].values) == list(range(1, ds.sizes["lag"] + 1))
        assert "the l-th point below it" in ds["lag"].attrs["long_name"]
        assert ds["state_position"].attrs["units"] == "m" and ds["state_velocity"].attrs["units"] == "m s-1"
        assert np.all(np.diff(x, axis=1) > 0.0)
        n_pts, n_sph = ds.sizes["point"], ds.sizes["tracer"]
        ppd = n_pts // n_sph
        d = float(ds.attrs["diameter"])
        for k in range(ds.sizes["time"]):
            nodes = np.concatenate([[0.0], x[k], [x[k, -1] + 0.5 * d / ppd]])
            cum = np.concatenate([[0.0], np.arange(n_pts) + 0.5, [n_pts]])          # in point masses
            centres = np.interp((np.arange(n_sph) + 0.5) * ppd, cum, nodes)
            tracers = ds["tracer_height"].values[k] - ds["floor"].values[k]
            np.testing.assert_allclose(centres, tracers, rtol=0, atol=1e-12 * d)
        hist = ds["state_delta_max"].values
        assert hist.min() >= 0.0 and hist.max() > 0.0


@pytest.mark.parametrize("form", ["eulerian", "lagrangian", "eulerian_nonlocal"])
def test_state_fields_resume_bit_for_bit(tmp_path, files, form):
    """Interrupted after a checkpoint and resumed: every variable of the file, the state fields included,
    equals the uninterrupted run's bit for bit."""
    import bsrflow.io.driver as driver
    import bsrflow.io.runner as runner

    real = driver.drive

    def stop(t):
        if t > 0.26:
            raise KeyboardInterrupt()
    cfg = tmp_path / "p.toml"
    cfg.write_text(_config_text(form))
    out = tmp_path / "p.nc"
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(runner, "drive", lambda job, **kw: real(job, **{**kw, "progress": stop}))
        assert main(["run", str(cfg), "--out", str(out), "--quiet"]) == 130
    assert main(["run", str(cfg), "--out", str(out), "--resume", "--quiet"]) == 0
    with xr.open_dataset(out) as a, xr.open_dataset(files[form]) as b:
        assert set(a.data_vars) == set(b.data_vars)
        for k in a.data_vars:
            np.testing.assert_array_equal(a[k].values, b[k].values, err_msg=k)


def test_nonlocal_eulerian_state_fields_are_its_grid_and_surface(files):
    """The Eulerian form of the nonlocal interaction: the cells' masses give the file's rho (the
    top cell spread over the grid cells it reaches), the surface is above the top tracer, the
    bond histories are non-negative and loaded by the tap."""
    with xr.open_dataset(files["eulerian_nonlocal"]) as ds:
        assert ds["state_velocity"].dims == ("time", "face") and ds["state_delta_max"].dims[1] == "lag"
        dx = float(ds["x"].values[1] - ds["x"].values[0])
        mass = ds["state_cell_mass"].values
        np.testing.assert_allclose(mass.sum(axis=1), ds["rho"].values.sum(axis=1) * dx, rtol=1e-12)
        surface = ds["state_surface"].values
        top_tracer = ds["tracer_height"].values[:, -1] - ds["floor"].values
        assert np.all(surface[:, 1] > top_tracer)
        hist = ds["state_delta_max"].values
        assert hist.min() >= 0.0 and hist.max() > 0.0


def test_write_state_is_refused_where_it_does_not_apply(tmp_path, capsys):
    """The seed kernel's state is the file's u and rho: `run.write_state = true` is refused in one line
    (exit 2); a sweep writes no files, so `--set run.write_state=true` is refused there."""
    cfg = tmp_path / "s.toml"
    cfg.write_text("[run]\nt_end = 0.05\nwrite_state = true\n")
    assert main(["run", str(cfg), "--out", str(tmp_path / "s.nc")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "run.write_state" in err[0] and 'model.kernel = "packing"' in err[0], err
    assert not (tmp_path / "s.nc").exists()
    cfg.write_text("[run]\nt_end = 0.05\n")
    assert main(["sweep", str(cfg), "--param", "tap.a_over_d=0.5,1.0", "--set", "run.write_state=true",
                 "--out", str(tmp_path / "sw.nc")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "write_state" in err[0] and "no netCDF files" in err[0], err
    cfg.write_text('[model]\nkernel = "packing"\n[run]\nt_end = 0.05\nwrite_state = true\n')
    assert main(["sweep", str(cfg), "--param", "tap.a_over_d=0.5,1.0", "--out", str(tmp_path / "sw.nc")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "run.write_state = true in" in err[0] and "remove it" in err[0], err


def test_a_packing_bed_writes_its_state_fields_and_resumes_them(tmp_path, capsys):
    """`[output] state = true` on a packing bed: the n-D file holds the conserved fields on the grid's
    axes with units per metre of depth in 2-D (state_rho is the file's rho; momentum / rho its velocity);
    an interrupted and resumed run writes them bit for bit; refused for a seed kernel's layer."""
    import bsrflow.io.driver as driver
    import bsrflow.io.layer_runner as layer_runner
    text = ('[layer]\nkind = "packing_bed"\ndim = 2\nbox_width = 0.01\nbed_height = 0.01\nt_end = 0.006\n'
            'save_every = 0.001\n[output]\ncheckpoint_every = 0.002\nstate = true\n')
    cfg = tmp_path / "b.toml"
    cfg.write_text(text)
    assert main(["run", str(cfg), "--out", str(tmp_path / "full.nc"), "--quiet"]) == 0
    real = driver.drive

    def stop(t):
        if t > 0.0035:
            raise KeyboardInterrupt()
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(layer_runner, "drive", lambda job, **kw: real(job, **{**kw, "progress": stop}))
        assert main(["run", str(cfg), "--out", str(tmp_path / "part.nc"), "--quiet"]) == 130
    assert main(["run", str(cfg), "--out", str(tmp_path / "part.nc"), "--resume", "--quiet"]) == 0
    with xr.open_dataset(tmp_path / "full.nc") as a, xr.open_dataset(tmp_path / "part.nc") as b:
        assert {"state_rho", "state_momentum_x", "state_momentum_z", "state_rho_delta_max"} <= set(a.data_vars)
        assert a["state_rho"].dims == ("time", "x", "z") and a["state_rho"].attrs["units"] == "kg m-3"
        assert a["state_momentum_z"].attrs["units"] == "kg m-2 s-1"
        assert a["state_rho_delta_max"].attrs["units"] == "kg m-2"
        np.testing.assert_array_equal(a["state_rho"].values, a["rho"].values)
        rho = a["rho"].values
        full = rho > 1e-6 * rho.max()
        np.testing.assert_allclose(a["state_momentum_z"].values[full] / rho[full], a["u_z"].values[full],
                                   rtol=1e-12, atol=1e-12)
        assert float(a["state_rho_delta_max"].max()) > 0.0            # the settled bed is compressed
        for k in a.data_vars:
            np.testing.assert_array_equal(a[k].values, b[k].values, err_msg=k)
    capsys.readouterr()
    seed = tmp_path / "s.toml"
    seed.write_text('[layer]\nkind = "tapped_layer"\ndim = 2\nt_end = 0.01\n[output]\nstate = true\n')
    assert main(["run", str(seed), "--out", str(tmp_path / "s.nc"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "output.state" in err[0] and "packing_bed" in err[0], err
