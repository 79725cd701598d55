"""Issue #19: the packing continuum in 2-D / 3-D from a config (``[layer] kind = "packing_bed"``):
the n-D netCDF and VTK output, named fields through the checkpoint and a bit-for-bit resume,
the stiffness option (its one-line refusals are in test_layer_run.py), and a bed uniform in y equal to the 2-D bed."""
import os

import numpy as np
import pytest
import xarray as xr

from conftest import interrupt_and_resume
from bsrflow.cli import main
from bsrflow.io.layer_runner import load_layer_config, run_layer_config
from bsrflow.io.netcdf import read_snapshots
from bsrflow.numerics.packing_nd import PackingLawND, run_packing_nd
from bsrflow.numerics.solver import save_schedule
from bsrflow.physics.packing import PackingLaw
from bsrflow.physics.packing_bed import PackingBed

pytestmark = pytest.mark.usefixtures("one_numba_thread")

CONFIG = """[layer]
kind = "packing_bed"
dim = 2
box_width = 0.01
bed_height = 0.015
cells_per_diameter = 2
settle_time = 0.05
t_end = 0.12
save_every = 0.01
surface_perturbation = 0.2
[output]
vtk = true
checkpoint_every = 0.05
[tracers]
positions = [[0.003, 0.0025], [0.007, 0.0125]]
"""


def test_packing_bed_config_runs_into_netcdf_and_vtk(tmp_path, run_layer_file):
    import meshio

    ds = run_layer_file(CONFIG, "bed", "packing_bed_2d", per_depth=True)
    assert ds.attrs["kernel"] == "packing"
    setup = load_layer_config(tmp_path / "bed.toml").setup
    assert ds["mass"].values[0] == pytest.approx(setup.mass(), rel=1e-14)
    # the floor moved the bed: it left the floor (the mass centre rose by more than a tenth of d)
    rise = ds["mass_centre"].values - ds["mass_centre"].values[0]
    assert rise.max() > 0.1 * setup.diameter
    assert float(np.abs(ds["u_x"]).max()) > 0.0          # the undulated top is not uniform in x
    last = meshio.read(tmp_path / "bed_vtk" / "layer_000012.vtu")
    np.testing.assert_array_equal(last.cell_data["density [kg/m^3]"][0], ds["rho"].values[-1].ravel())
    # the tracers: written in the lab frame, moved by the bed (the upper one flew with it)
    assert ds["tracer_z"].dims == ("time", "tracer") and ds["tracer_z"].attrs["units"] == "m"
    np.testing.assert_allclose(ds["tracer_z"].values[0] - ds["floor"].values[0], [0.0025, 0.0125], rtol=1e-12)
    assert np.all((ds["tracer_x"].values >= 0.0) & (ds["tracer_x"].values < setup.box_width))   # wrapped
    tz = ds["tracer_z"].values - ds["floor"].values[:, None]
    assert tz[:, 1].max() - tz[0, 1] > 0.1 * setup.diameter
    assert np.all(tz > 0.0) and np.all(tz[:, 0] < tz[:, 1])
    tr_last = meshio.read(tmp_path / "bed_vtk" / "layer_tracers_000012.vtu")
    np.testing.assert_allclose(tr_last.points[:, [0, 2]], np.stack([ds["tracer_x"].values[-1], tz[-1]], axis=1),
                               rtol=0, atol=1e-12)
    ds.close()
    assert not (tmp_path / "bed.nc.ckpt").exists()


def test_interrupted_packing_bed_resumes_bit_for_bit(tmp_path):
    """The checkpoint holds the named fields (history included); the resumed run equals the
    uninterrupted one bit for bit."""
    cfgfile = tmp_path / "bed.toml"
    cfgfile.write_text(CONFIG.replace("vtk = true", "vtk = false"))
    cfg = load_layer_config(cfgfile)
    full = tmp_path / "full.nc"
    run_layer_config(cfg, full)
    part = tmp_path / "part.nc"

    def check(ck):
        assert set(ck.fields) == {"rho", "momentum_x", "momentum_z", "rho_delta_max"}
        assert np.max(ck.fields["rho_delta_max"]) > 0.0   # the settled bed is compressed: history carried
        assert ck.tracers.shape == (2, 2)

    outcome = interrupt_and_resume(cfg, part, between=check)
    assert outcome.resumed_from == pytest.approx(0.05)
    a, _ = read_snapshots(full)
    b, _ = read_snapshots(part)
    for k in ("time", "rho", "u_x", "u_z", "mass_centre", "tracer_x", "tracer_z"):
        np.testing.assert_array_equal(a[k], b[k])


def test_reduced_stiffness_is_reported(tmp_path, capsys):
    cfg = tmp_path / "bed.toml"
    cfg.write_text(CONFIG.replace("t_end = 0.12", "t_end = 0.01").replace("vtk = true", "vtk = false")
                   .replace("checkpoint_every = 0.05", "checkpoint_every = 0.01")
                   .replace("[output]", "stiffness_factor = 0.25\n[output]"))
    assert main(["run", str(cfg), "--out", str(tmp_path / "bed.nc")]) == 0
    out = capsys.readouterr().out
    assert "reduced contact stiffness: K x 0.25" in out and "impact Mach number" in out


def test_bed_uniform_in_y_equals_the_2d_bed():
    """In 2-D the fields are a 3-D bed's uniform in y (per metre of depth): the 3-D run of that
    bed equals the 2-D run bit for bit (the y fluxes of equal states are exactly 0)."""
    kw = dict(box_width=0.01, bed_height=0.01, cells_per_diameter=2, settle_time=0.005, t_end=0.03,
              save_every=0.01, surface_perturbation=0.2, cfl=0.15)
    b2, b3 = PackingBed(dim=2, **kw), PackingBed(dim=3, **kw)
    d2 = b2.discretisation()
    g3 = b3.grid()
    rho3 = np.broadcast_to(b2.initial_density()[:, None, :], g3.shape)
    from bsrflow.numerics.packing_nd import EulerianPackingND
    d3 = EulerianPackingND(b3.law(), g3, b3.motion(), b3.gravity, rho3, cfl=0.15)
    saves = save_schedule(0.0, kw["t_end"], kw["save_every"])
    t2, u2, r2, _ = run_packing_nd(d2, kw["t_end"], saves)
    t3, u3, r3, _ = run_packing_nd(d3, kw["t_end"], saves)
    for j in range(g3.shape[1]):
        np.testing.assert_array_equal(r3[:, :, j, :], r2)
        np.testing.assert_array_equal(u3[:, 2, :, j, :], u2[:, 1])
        np.testing.assert_array_equal(u3[:, 0, :, j, :], u2[:, 0])
    assert np.max(np.abs(u3[:, 1])) == 0.0 and np.ptp(u2[:, 1]) > 0.01


def test_stiffness_option_of_the_nd_law():
    """The n-D law's stiffness factor scales loading and unloading as the 1-D law's; from_1d keeps
    it (so the embedding of a reduced-stiffness column is the same arithmetic); the bed's
    suggested factor gives the asked impact Mach number and takes fewer steps."""
    law1 = PackingLaw(1.366e7, 0.88, 0.022, 1200.0, stiffness_factor=0.01)
    nd = PackingLawND.from_1d(law1)
    assert nd.k1 == law1.k1 and nd.k2 == law1.k2 and nd.stiffness_factor == 0.01
    assert nd.wave_speed() == law1.wave_speed()
    with pytest.raises(ValueError, match="stiffness_factor"):
        PackingLawND(1.0, 0.9, 0.005, 700.0, stiffness_factor=1.5)
    bed = PackingBed(dim=2, box_width=0.01, bed_height=0.01, cells_per_diameter=2, settle_time=0.005,
                     t_end=0.02, stiffness=5e6)
    phi = bed.suggest_stiffness_factor(0.01)
    assert 0.0 < phi < 1.0
    reduced = bed.with_(stiffness_factor=phi)
    assert reduced.impact_mach() == pytest.approx(0.01, rel=1e-12)
    assert reduced.law().k1 == pytest.approx(phi * bed.law().k1, rel=1e-15)
    # a bed at rest still meets itself at the free-fall speed of one diameter (the column's rule)
    still = bed.with_(gamma=0.0)
    assert still.impact_speed() == pytest.approx((2 * 9.81 * 0.005) ** 0.5, rel=1e-14)
    assert still.with_(stiffness_factor=still.suggest_stiffness_factor(0.01)).impact_mach() == pytest.approx(0.01)
    full_steps, reduced_steps = [], []
    for s, steps in ((bed, full_steps), (reduced, reduced_steps)):
        disc = s.discretisation()
        disc.advance(0.0, s.t_end)
        steps.append(disc.steps)
    # Δt ∝ 1/c ∝ 1/√φ (the velocity term of the CFL bound is small against c)
    assert full_steps[0] / reduced_steps[0] == pytest.approx(phi ** -0.5, rel=0.05)


@pytest.mark.parametrize("dim, cells", [(2, "cubic"), (3, "cubic"), (2, "flat"), (3, "flat")])
def test_tracer_velocity_matches_numpy(dim, cells):
    """The compiled interpolation of the tracers' velocity equals its NumPy twin to 1e-12 at
    points everywhere in the box: near the floor, the lid, across the periodic sides, in vacuum;
    on cubic cells (the packing solver's) and on cells wider than tall (the bed's Eulerian grid)."""
    from bsrflow.numerics.packing_reference import tracer_velocity_numpy
    from bsrflow.numerics.tracers import tracer_velocity
    rng = np.random.default_rng(dim)
    NX, NY, NZ = 5, (1 if dim == 2 else 4), 7
    h = 0.002
    dxs = np.array([h, h, h]) if cells == "cubic" else np.array([3.1 * h, 2.3 * h, h])
    dx = h
    q = np.zeros((5, NX, NY, NZ))
    q[0] = rng.uniform(0.0, 800.0, (NX, NY, NZ))
    q[0, :, :, 5] = 0.0                                    # a vacuum layer, and material again in the top cell
    q[1:4] = rng.normal(0.0, 1.0, (3, NX, NY, NZ)) * q[0]
    if dim == 2:
        q[2] = 0.0
    lo = np.array([0.0, 0.0, 0.0])
    hx, hy = dxs[0], dxs[1]
    pts = np.stack([rng.uniform(0, NX * hx, 40), rng.uniform(0, NY * hy, 40) if dim == 3 else np.zeros(40),
                    rng.uniform(0, NZ * dx, 40)], axis=1)
    pts[:4, 2] = [0.0, 0.2 * dx, NZ * dx, 6.9 * dx]          # the floor, the lid (the top cell is not empty)
    pts[8:10, 2] = 5.5 * dx                                  # a vacuum cell's centre
    pts[4:8, 0] = [0.0, NX * hx, 0.1 * hx, (NX - 0.1) * hx]
    ref = tracer_velocity_numpy(q, pts, lo, dxs, 1e-9)
    out = np.zeros(3)
    scale = np.max(np.abs(ref))
    for p, r in zip(pts, ref):
        tracer_velocity(q, p[0], p[1], p[2], lo, dxs, 1e-9, out)
        np.testing.assert_allclose(out, r, rtol=0, atol=1e-12 * scale)
    assert np.all(ref[pts[:, 2] == 0.0, 2] == 0.0)         # the floor's mirror: no vertical velocity
    assert np.all(ref[pts[:, 2] == NZ * dx, 2] == 0.0)     # the lid's mirror: no vertical velocity
    assert np.all(np.abs(ref[pts[:, 2] == NZ * dx, 0]) > 0.0)
    assert np.all(ref[pts[:, 2] == 5.5 * dx] == 0.0)       # a vacuum cell's centre


def _tracer_steps(q, tr, dt, n, lo, box, has_y):
    """n SSP-RK3 steps of the tracers alone on a fixed state q (the three stages on q)."""
    from bsrflow.numerics.tracers import tracer_combine, tracer_stage
    vt = np.zeros((3, tr.shape[0], 3))
    top = lo[2] + box[2]
    dx = np.full(3, box[0] / q.shape[1])
    for _ in range(n):
        for st in range(3):
            tracer_stage(q, tr, vt, st, dt, lo, top, dx, 1e-12)
        tracer_combine(tr, vt, dt, lo, box, top, has_y)
    return tr


def test_tracer_integrator_is_third_order_and_wraps_the_periodic_sides():
    """The tracers' stages and weights are the fields' SSP-RK3: on a steady field u_z = λz (which
    the interpolation reproduces exactly) the error falls at third order; on a uniform horizontal
    flow the tracers cross the periodic sides and come back in at the other one."""
    NX, NZ, dx, lam = 4, 40, 0.01, 2.0
    zc = (np.arange(NZ) + 0.5) * dx
    q = np.zeros((5, NX, 1, NZ))
    q[0] = 1.0
    q[3] = lam * zc
    lo, box = np.zeros(3), np.array([NX * dx, 1.0, NZ * dx])
    exact = 0.1 * np.exp(lam * 0.2)
    errs = [abs(_tracer_steps(q, np.array([[0.005, 0.0, 0.1]]), dt, int(round(0.2 / dt)), lo, box, False)[0, 2] - exact)
            for dt in (0.02, 0.01, 0.005)]
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(orders > 2.8), orders
    q3 = np.zeros((5, NX, 3, NZ))
    q3[0], q3[1], q3[2] = 1.0, -3.0, 2.0
    box3 = np.array([NX * dx, 3 * dx, NZ * dx])
    tr = _tracer_steps(q3, np.array([[0.001, 0.001, 0.1]]), 0.001, 10, lo, box3, True)
    np.testing.assert_allclose(tr[0], [(0.001 - 0.03) % 0.04, (0.001 + 0.02) % 0.03, 0.1], rtol=0, atol=1e-15)


def test_tracers_of_a_uniform_bed_follow_its_material_lines():
    """A flat bed is horizontally uniform, so its material lines are its mass coordinates: the
    tracers, moved with the interpolated velocity, stay on them through launch, flight and
    landing, closer on the finer grid, and their horizontal positions do not move at all.  The
    distance measures the scheme's numerical mass diffusion, largest at the bed's top, where the
    first-order compaction faces of the landing smear it (bench/check_bed_tracers.py, 2026-12-02:
    at 2 / 4 / 8 cells per diameter 0.078 / 0.025 / 0.018 d, 0.075 / 0.033 / 0.003 d and
    0.276 / 0.160 / 0.057 d for the tracers starting 0.5, 1.5 and 2.5 d up, 1.166 / 0.918 / 0.546 d
    for the one in the top cell; 0.042 / 0.037 / 0.051 / 0.376 d at 4 before those faces)."""
    import sys
    sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "bench"))
    from check_bed_tracers import material_line_errors
    coarse, fine = material_line_errors(2), material_line_errors(4)
    assert coarse["horizontal_drift_m"] == 0.0 and fine["horizontal_drift_m"] == 0.0
    assert np.all(np.array(fine["max_distance_d"]) < np.array(coarse["max_distance_d"]))
    assert max(fine["max_distance_d"][:2]) < 0.05            # deep in the bed
    assert fine["max_distance_d"][2] < 0.2 and fine["max_distance_d"][3] < 1.0


def test_tracers_refused_on_a_column():
    from bsrflow.numerics.grid_nd import GridND
    from bsrflow.numerics.packing_nd import EulerianPackingND
    bed = PackingBed(dim=2)
    grid = GridND((40,), 0.001, bc_lower="floor", bc_upper="vacuum", bc_horizontal="periodic")
    with pytest.raises(ValueError, match="^tracers: the n-D packing solver moves tracers in 2-D / 3-D only"):
        EulerianPackingND(bed.law(), grid, bed.motion(), 9.81, np.zeros(40), tracers=[[0.01]])


def test_3d_bed_writes_its_tracers(tmp_path):
    """A 3-D bed with tracers writes tracer_x, tracer_y, tracer_z (the height in the lab frame)."""
    text = (CONFIG.replace("dim = 2", "dim = 3").replace("t_end = 0.12", "t_end = 0.07")
            .replace("vtk = true", "vtk = false")
            .replace("positions = [[0.003, 0.0025], [0.007, 0.0125]]", "positions = [[0.003, 0.009, 0.0025], [0.007, 0.001, 0.0125]]"))
    cfg = tmp_path / "bed3.toml"
    cfg.write_text(text)
    out = tmp_path / "bed3.nc"
    assert main(["run", str(cfg), "--out", str(out), "--quiet"]) == 0
    with xr.open_dataset(out) as ds:
        assert ds["rho"].dims == ("time", "x", "y", "z")
        for k in ("tracer_x", "tracer_y", "tracer_z"):
            assert ds[k].dims == ("time", "tracer") and ds[k].attrs["units"] == "m"
        np.testing.assert_allclose(ds["tracer_y"].values[0], [0.009, 0.001], rtol=1e-12)
        tz = ds["tracer_z"].values - ds["floor"].values[:, None]
        assert tz[:, 1].max() - tz[0, 1] > 0.05 * 0.005           # the bed was thrown
        assert np.all((ds["tracer_y"].values >= 0.0) & (ds["tracer_y"].values < 0.01))
