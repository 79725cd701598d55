"""Issue #19: the n-D run's outputs: the netCDF file (NetCDFWriterND, the 1-D writer's crash-safe
machinery with the n-D variables and their units), VTK files read back with meshio, and
checkpoint/restart through the shared controller, bit for bit."""
import numpy as np
import pytest
import xarray as xr

from bsrflow.io.netcdf import NetCDFWriterND, read_snapshots
from bsrflow.io.vtk import VELOCITY_NAME, VTKWriter, density_name
from bsrflow.numerics.solver import Scheme
from bsrflow.numerics.solver_nd import SimulationND
from bsrflow.physics.scenarios_nd import TappedLayer


pytestmark = pytest.mark.usefixtures("one_numba_thread")


def _layer(dim, **kw):
    setup = TappedLayer(dim=dim, t_end=0.13, save_every=0.01, **kw)
    grid = setup.grid()
    sim = SimulationND(setup.model(), grid, Scheme.preset("seed", positivity=True),
                       vacuum_density=1e-4 * setup.bottom_density)
    u0, rho0 = setup.initial_state(grid)
    return setup, grid, sim, u0, rho0


@pytest.mark.parametrize("dim", [2, 3])
def test_netcdf_nd_holds_every_snapshot_with_units(dim, tmp_path):
    setup, grid, sim, u0, rho0 = _layer(dim)
    path = tmp_path / f"layer{dim}.nc"
    motion = setup.model().motion
    with NetCDFWriterND(path, grid, lambda t: motion.state(t)[0], attrs={"config": "test"}) as w:
        res = sim.run(u0, rho0, setup.t_end, save_every=setup.save_every, observers=[w])
        w.close("ok")
    ds = xr.open_dataset(path)
    axes = ("x", "z") if dim == 2 else ("x", "y", "z")
    assert ds["rho"].dims == ("time",) + axes
    assert ds["rho"].attrs["units"] == f"kg m-{dim}"
    assert ds["u_z"].attrs["units"] == "m s-1" and ds["z"].attrs["units"] == "m"
    assert ds.attrs["status"] == "ok"
    np.testing.assert_array_equal(ds["time"].values, res.t)
    np.testing.assert_array_equal(ds["rho"].values, res.rho)
    for k, a in enumerate(axes):
        np.testing.assert_array_equal(ds[f"u_{a}"].values, res.u[:, k])
    np.testing.assert_allclose(ds["mass"].values, res.mass(), rtol=1e-13)
    np.testing.assert_allclose(ds["mass_centre"].values, res.centre_of_mass_height() + res.floor, rtol=1e-12)
    ds.close()
    data, attrs = read_snapshots(path)
    assert data["rho"].shape == res.rho.shape and attrs["status"] == "ok"


def test_netcdf_nd_resume_keeps_the_snapshots_before_the_restart(tmp_path):
    setup, grid, sim, u0, rho0 = _layer(2)
    path = tmp_path / "layer.nc"
    floor = lambda t: setup.model().motion.state(t)[0]  # noqa: E731
    w = NetCDFWriterND(path, grid, floor)
    res = sim.run(u0, rho0, setup.t_end, save_every=setup.save_every, observers=[w])
    w.close("ok")
    w2 = NetCDFWriterND.resume(path, 0.055, grid, floor)
    assert w2.n == int(np.sum(res.t < 0.055))
    w2.close("ok")
    data, _ = read_snapshots(path)
    np.testing.assert_array_equal(data["rho"], res.rho[res.t < 0.055])
    bad = SimulationND(_layer(3)[0].model(), _layer(3)[1])
    with pytest.raises(ValueError, match="grid"):
        NetCDFWriterND.resume(path, 0.055, bad.grid, floor)


@pytest.mark.parametrize("dim", [2, 3])
def test_vtk_files_read_back_with_meshio_and_carry_units(dim, tmp_path):
    import meshio

    setup, grid, sim, u0, rho0 = _layer(dim)
    w = VTKWriter(grid, tmp_path / "layer")
    res = sim.run(u0, rho0, 0.03, save_every=0.01, observers=[w])
    assert len(w.files) == len(res.t) == 4
    for k, f in enumerate(w.files):
        mesh = meshio.read(f)
        assert mesh.points.shape[0] == int(np.prod(np.array(grid.shape) + 1))
        assert mesh.cells[0].type == ("quad" if dim == 2 else "hexahedron")
        assert mesh.cells[0].data.shape[0] == grid.n_cells
        rho = mesh.cell_data[density_name(dim)][0]
        vel = mesh.cell_data[VELOCITY_NAME][0]
        np.testing.assert_array_equal(rho, res.rho[k].ravel())
        np.testing.assert_array_equal(vel[:, -1], res.u[k, -1].ravel())
        # a cell's centre is where the grid says: first cell at half a spacing from the corner
        first = mesh.points[mesh.cells[0].data[0]].mean(axis=0)
        np.testing.assert_allclose(first[[0, 2]], [grid.centres(0)[0], grid.centres(dim - 1)[0]])
    pvd = (tmp_path / "layer.pvd").read_text()
    assert pvd.count("<DataSet") == 4 and "layer_000003.vtu" in pvd
    import re
    times = [float(x) for x in re.findall(r'timestep="([^"]+)"', pvd)]
    assert times == res.t.tolist()
    with pytest.raises(ValueError, match="folder"):
        VTKWriter(grid, tmp_path / "missing" / "layer")


def test_nd_restart_from_a_checkpoint_event_is_bit_for_bit():
    setup, grid, sim, u0, rho0 = _layer(3)
    saves = np.round(np.arange(0.0, setup.t_end + 1e-12, setup.save_every), 12)
    kept = {}
    t_ck = 0.063

    def grab(t, u, rho, tracers, steps):
        assert tracers is None                   # a run without tracers
        kept.update(t=t, u=u.copy(), rho=rho.copy(), steps=steps)

    # the run with the checkpoint event (a step ends there) is the reference, as in 1-D
    full = sim.run(u0, rho0, setup.t_end, save_times=saves, extra_event_times=[t_ck], on_event=grab)
    assert kept["t"] == t_ck and kept["steps"] > 0
    rest = sim.run(kept["u"], kept["rho"], setup.t_end, t_start=t_ck, save_times=saves[saves >= t_ck],
                   restart=True)
    np.testing.assert_array_equal(rest.rho, full.rho[full.t >= t_ck])
    np.testing.assert_array_equal(rest.u, full.u[full.t >= t_ck])


def test_a_columns_netcdf_file_through_the_nd_writer(tmp_path):
    """The n-D writers take a column (dim = 1) too: netCDF with rho on (time, z) in kg m-1, u_z,
    tracers; VTK with line cells along z, the density in kg/m and the tracers as points on z."""
    import meshio
    import xarray as xr

    from bsrflow.io.netcdf import NetCDFWriterND
    from bsrflow.io.vtk import VTKWriter
    from bsrflow.numerics.grid_nd import GridND
    from bsrflow.numerics.solver_nd import SimulationND
    from bsrflow.physics.kernels_nd import BSRModelND, walton_braun_nd
    from bsrflow.physics.motion import HalfSineTaps

    grid = GridND((100,), 0.002)
    sim = SimulationND(BSRModelND(walton_braun_nd(1e6, 0.1, 0.02), HalfSineTaps(0.005, 10.0, start=0.01), 9.81),
                       grid, vacuum_density=1e-6)
    rho0 = np.where(grid.z < 0.05, 0.3, 0.0)
    floor = lambda t: sim.model.motion.state(t)[0]  # noqa: E731
    path = tmp_path / "column.nc"
    vtk = VTKWriter(grid, tmp_path / "col")
    with NetCDFWriterND(path, grid, floor, expected_snapshots=6, n_tracers=2) as w:
        res = sim.run(np.zeros((1, 100)), rho0, 0.05, save_every=0.01, observers=[w, vtk],
                      tracers=[[0.01], [0.04]])
        w.close("ok")
    ds = xr.open_dataset(path)
    assert ds["rho"].dims == ("time", "z") and ds["rho"].attrs["units"] == "kg m-1"
    np.testing.assert_array_equal(ds["rho"].values, res.rho)
    np.testing.assert_array_equal(ds["u_z"].values, res.u[:, 0])
    np.testing.assert_allclose(ds["tracer_z"].values - ds["floor"].values[:, None], res.tracers[:, :, 0], rtol=1e-12)
    np.testing.assert_allclose(ds["mass"].values, ds["mass"].values[0], rtol=1e-12)
    ds.close()
    assert len(vtk.files) == 6 and (tmp_path / "col.pvd").read_text().count('part="1"') == 6
    for k, f in enumerate(vtk.files):
        mesh = meshio.read(f)
        assert mesh.cells[0].type == "line" and mesh.cells[0].data.shape == (100, 2)
        np.testing.assert_array_equal(mesh.cell_data["density [kg/m]"][0], res.rho[k])
        np.testing.assert_array_equal(mesh.cell_data[VELOCITY_NAME][0][:, 2], res.u[k, 0])
        assert not mesh.cell_data[VELOCITY_NAME][0][:, :2].any()
        centres = mesh.points[mesh.cells[0].data].mean(axis=1)
        np.testing.assert_allclose(centres[:, 2], grid.z, rtol=0, atol=1e-15)
        assert not centres[:, :2].any()
        pts = meshio.read(vtk.tracer_files[k]).points
        np.testing.assert_array_equal(pts[:, 2], res.tracers[k, :, 0])
        assert not pts[:, :2].any()
