"""`bsrflow run`: netCDF output written as the run goes, checkpoints, --resume (bit for bit), a
SIGKILLed run, a run that stops early, and the writer's crash safety.

Tiny columns (3 spheres, 4 points per diameter, 0.1 s) keep this fast; the compiled time loop is
built once per process (about 9 s), so the runs here share one build except the subprocesses.
"""
import os
import random
import signal
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest
import xarray as xr

from bsrflow.cli import main
from bsrflow.io.config import Config, load_config
from bsrflow.io.netcdf import SCHEMA, NetCDFWriter, read_snapshots
from bsrflow.io.runner import column_simulation, run_config
from bsrflow.physics.column import run_bsr_column

TINY = """\
[column]
n_spheres = 3
[tap]
start = {start}
[run]
t_end = 0.1
save_every = 0.01
checkpoint_every = {ckpt}
[numerics]
points_per_diameter = 4
{extra}
"""
VARS = [k for k in SCHEMA]


def write_config(path, start=0.02, ckpt=0.03, extra=""):
    path.write_text(TINY.format(start=start, ckpt=ckpt, extra=extra))
    return path


def load(path):
    with xr.open_dataset(path) as ds:
        ds.load()
        return ds


def assert_same_variables(a, b):
    da, db = load(a), load(b)
    for k in VARS:
        assert np.array_equal(da[k].values, db[k].values), k
    return da, db


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """An uninterrupted run of the tiny config with checkpoints every 0.03 s."""
    d = tmp_path_factory.mktemp("ref")
    cfg = write_config(d / "tiny.toml")
    out = d / "ref.nc"
    assert main(["run", str(cfg), "--out", str(out), "--quiet"]) == 0
    return cfg, out


def test_run_writes_netcdf_with_schema_and_units(reference):
    cfg_path, out = reference
    ds = load(out)
    cfg = load_config(cfg_path)
    assert set(ds.dims) == {"time", "x", "tracer"}
    assert set(ds.coords) == {"time", "x", "tracer"}
    assert set(ds.data_vars) == {k for k in VARS if k not in ("time", "x", "tracer")}
    for k, (dims, units, long_name) in SCHEMA.items():
        assert ds[k].dims == dims
        assert ds[k].attrs["units"] == units and ds[k].attrs["long_name"] == long_name
    assert ds.u.attrs["units"] == "m s-1" and ds.rho.attrs["long_name"] == "line density"
    assert np.array_equal(ds.time.values, cfg.save_times())
    for a in ("bsrflow_version", "config", "scenario", "scheme", "diameter", "status", "created"):
        assert a in ds.attrs
    assert ds.attrs["status"] == "ok" and ds.attrs["scenario"] == "tapped_column"
    assert ds.attrs["scheme"] == "seed" and ds.attrs["diameter"] == 0.022
    assert Config.from_dict(__import__("tomllib").loads(ds.attrs["config"])) == cfg
    assert not os.path.exists(str(out) + ".ckpt")                  # removed after success
    # derived variables
    dx = float(ds.x[1] - ds.x[0])
    assert np.allclose(ds.mass, ds.rho.sum("x") * dx, rtol=1e-12)
    assert np.array_equal(ds.top.values, ds.tracer_height.values[:, -1])
    assert np.allclose(ds.kinetic_energy, 0.5 * (ds.rho * ds.u ** 2).sum("x") * dx, rtol=1e-12)


def test_netcdf_equals_run_bsr_column_bit_for_bit(tmp_path):
    cfg = load_config(write_config(tmp_path / "c.toml", ckpt=0.0))
    out = tmp_path / "c.nc"
    run_config(cfg, out)
    ref = run_bsr_column(cfg.column_setup(), cfg.scheme())
    ds = load(out)
    assert np.array_equal(ds.time.values, ref.t)
    assert np.array_equal(ds.rho.values, ref.rho) and np.array_equal(ds.u.values, ref.u)
    assert np.array_equal(ds.tracer_height.values, ref.tracers)
    assert np.array_equal(ds.floor.values, ref.floor)
    assert np.allclose(ds.mass_centre.values, ref.mass_centre, rtol=1e-14, atol=0)
    assert np.allclose(ds.kinetic_energy.values, ref.kinetic, rtol=1e-13, atol=0)


class _Stop(KeyboardInterrupt):
    pass


@pytest.mark.parametrize("start, ckpt, extra", [
    (0.03, 0.03, ""),                                       # a velocity jump exactly at a checkpoint
    (0.02, 0.025, ""),                                      # checkpoints between save times
    (0.02, 0.03, 'stepper = "bs32"\nrtol = 1e-3\natol = [1e-3, 1e-3]'),  # adaptive stepping
    (0.02, 0.03, 'scheme = "accurate"'),
])
def test_interrupted_then_resumed_equals_uninterrupted(tmp_path, start, ckpt, extra):
    cfg = load_config(write_config(tmp_path / "c.toml", start=start, ckpt=ckpt, extra=extra))
    full = run_config(cfg, tmp_path / "full.nc")
    assert cfg.checkpoint_times().size >= 3

    def stop_after(t):
        if t >= 0.075:
            raise _Stop()
    part = tmp_path / "part.nc"
    with pytest.raises(_Stop):
        run_config(cfg, part, progress=stop_after)
    data, attrs = read_snapshots(part)
    assert attrs["status"].startswith("interrupted") and data["time"][-1] >= 0.07
    assert os.path.exists(str(part) + ".ckpt")
    resumed = run_config(cfg, part, resume=True)
    assert resumed.resumed_from in cfg.checkpoint_times() and resumed.resumed_from >= 0.05
    assert resumed.steps == full.steps
    assert resumed.rejected_steps == full.rejected_steps
    adaptive = "rtol" in extra
    assert full.adaptive == adaptive and ("rejected)" in full.summary()) == adaptive
    da, db = assert_same_variables(part, tmp_path / "full.nc")
    assert da.attrs["status"] == "ok"
    assert da.attrs["steps"] == db.attrs["steps"] == full.steps
    assert da.attrs["rejected_steps"] == db.attrs["rejected_steps"] == full.rejected_steps
    assert not os.path.exists(str(part) + ".ckpt")


SLOW_RUN = textwrap.dedent("""
    import sys, time
    from bsrflow.io import netcdf
    _call = netcdf.NetCDFWriter.__call__
    def slow(self, *a):
        _call(self, *a)
        time.sleep(0.25)              # slow the run down so the test can kill it mid-way
    netcdf.NetCDFWriter.__call__ = slow
    from bsrflow.cli import main
    sys.exit(main(sys.argv[1:]))
""")


def test_sigkill_leaves_a_readable_file_and_resume_completes_it(tmp_path, reference, capsys):
    cfg_path, ref_out = reference
    out = tmp_path / "killed.nc"
    proc = subprocess.Popen([sys.executable, "-c", SLOW_RUN, "run", str(cfg_path), "--out", str(out), "--quiet"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.time() + 120
        n = 0
        while time.time() < deadline and proc.poll() is None:
            if out.exists() and os.path.exists(str(out) + ".ckpt"):
                with xr.open_dataset(out) as ds:             # readable while the run goes
                    n = ds.sizes["time"]
                if n >= 5:
                    break
            time.sleep(0.05)
        assert proc.poll() is None, proc.stderr.read()
        assert n >= 5
        proc.send_signal(signal.SIGKILL)
        proc.wait(30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    ds = load(out)                                            # every flushed snapshot is there
    assert ds.attrs["status"] == "running"
    k = ds.sizes["time"]
    assert 5 <= k < 11
    ref = load(ref_out)
    for v in VARS:
        exp = ref[v].values[:k] if "time" in SCHEMA[v][0] else ref[v].values
        assert np.array_equal(ds[v].values, exp), v
    # resume: drops snapshots after the checkpoint, continues, equals the uninterrupted run
    assert main(["run", str(cfg_path), "--out", str(out), "--resume"]) == 0
    assert "resumed from t = 0.03" in capsys.readouterr().out
    da, _ = assert_same_variables(out, ref_out)
    assert da.attrs["status"] == "ok"


def test_resume_refuses_a_changed_config_and_a_missing_checkpoint(tmp_path, capsys):
    cfg_path = write_config(tmp_path / "c.toml")
    out = tmp_path / "c.nc"
    cfg = load_config(cfg_path)

    def stop(t):
        if t >= 0.05:
            raise _Stop()
    with pytest.raises(_Stop):
        run_config(cfg, out, progress=stop)
    assert main(["run", str(cfg_path), "--out", str(out), "--resume", "--set", "t_end=0.2"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("bsrflow run: error: --resume: ") and "run.t_end" in lines[0]
    assert main(["run", str(cfg_path), "--out", str(tmp_path / "other.nc"), "--resume"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "no checkpoint" in lines[0]


def test_resume_refuses_an_output_written_by_another_config(tmp_path, capsys):
    """The checkpoint matches the config, the output beside it does not (another run's file):
    refused in one line (it was continued, the file then mixing the two runs)."""
    def stop(t):
        if t >= 0.05:
            raise _Stop()
    cfg_path = write_config(tmp_path / "c.toml")
    other_path = write_config(tmp_path / "o.toml", start=0.03)
    out, other = tmp_path / "c.nc", tmp_path / "o.nc"
    for path, nc in ((cfg_path, out), (other_path, other)):
        with pytest.raises(_Stop):
            run_config(load_config(path), nc, progress=stop)
    os.replace(other, out)                        # the checkpoint is c's, the output o's
    assert main(["run", str(cfg_path), "--out", str(out), "--resume"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "was written by another config" in lines[0] and "tap.start" in lines[0]
    out.write_bytes(b"not a netCDF file")
    assert main(["run", str(cfg_path), "--out", str(out), "--resume"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "cannot reopen" in lines[0]


def test_run_that_stops_keeps_snapshots_and_sets_status(tmp_path, capsys):
    # accepted by the validator (CFL 2.3 is below the linear limit 2.3388), but without kernel
    # dissipation a strong tap makes the time step collapse at t = 0.0216 s
    cfg_path = write_config(tmp_path / "blow.toml", extra="cfl = 2.3")
    cfg_path.write_text(cfg_path.read_text().replace("[column]\n", "[column]\nkernel_dissipation = 0.0\n")
                        .replace("[tap]\n", "[tap]\na_over_d = 5.0\n"))
    out = tmp_path / "blow.nc"
    assert main(["run", str(cfg_path), "--out", str(out), "--quiet"]) == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("bsrflow run: simulation stopped at t = ")
    ds = load(out)
    assert ds.sizes["time"] == 3 and np.all(np.isfinite(ds.rho.values))
    assert ds.attrs["status"].startswith("simulation stopped at t = 0.0215")
    assert "time step collapsed" in ds.attrs["status"]


def test_writer_resume_keeps_snapshots_before_the_time(tmp_path):
    x = (np.arange(5) + 0.5) * 0.1
    p = tmp_path / "w.nc"
    w = NetCDFWriter(p, x, 0.1, 2, lambda t: 0.5 * t, {"config": "", "scheme": "seed", "diameter": 0.1},
                     expected_snapshots=4)
    for k in range(4):
        w(0.1 * k, np.full(5, k), np.full(5, 1.0 + k), np.array([0.1, 0.2]))
    w.close("ok")
    created = load(p).attrs["created"]
    w = NetCDFWriter.resume(p, 0.2, x, 0.1, 2, lambda t: 0.5 * t)
    assert w.n == 2 and load(p).attrs["status"] == "running"
    w(0.2, np.zeros(5), np.ones(5), np.array([0.1, 0.2]))
    w.close("ok")
    ds = load(p)
    assert np.allclose(ds.time, [0.0, 0.1, 0.2]) and ds.attrs["created"] == created
    assert np.array_equal(ds.floor.values, 0.5 * ds.time.values)
    assert np.allclose(ds.tracer_height[:, 1], 0.2 + 0.5 * ds.time.values)
    assert np.allclose(ds.mass, [5 * 0.1 * 1.0, 5 * 0.1 * 2.0, 5 * 0.1 * 1.0])


STRESS_WRITER = textwrap.dedent("""
    import sys, numpy as np
    from bsrflow.io.netcdf import NetCDFWriter
    nx = 584
    x = (np.arange(nx) + 0.5) * 0.01
    w = NetCDFWriter(sys.argv[1], x, 0.01, 3, lambda t: 0.001 * t, {"config": "a = 1"}, expected_snapshots=5000)
    rng = np.random.default_rng(0)
    for k in range(5000):                  # snapshots back to back: kills land inside writes
        w(k * 0.01, rng.random(nx), rng.random(nx) + 1.0, rng.random(3))
    w.close("ok")
""")


def test_writer_killed_at_random_moments_leaves_readable_files(tmp_path):
    rnd = random.Random(7)
    sizes = []
    for i in range(6):
        p = tmp_path / f"k{i}.nc"
        proc = subprocess.Popen([sys.executable, "-c", STRESS_WRITER, str(p)])
        t0 = time.time()
        while not p.exists() and time.time() - t0 < 60:
            time.sleep(0.005)
        time.sleep(rnd.uniform(0.0, 0.4))
        proc.send_signal(signal.SIGKILL)
        proc.wait(30)
        # our reader: complete snapshots only, every one of them intact
        data, attrs = read_snapshots(p)
        m = data["time"].size
        assert m >= 1 and attrs["status"] == "running"
        assert np.array_equal(data["time"], np.arange(m) * 0.01)
        for k in ("rho", "u", "mass", "floor", "kinetic_energy", "tracer_height"):
            assert np.all(np.isfinite(data[k])), k
        for engine in ("netcdf4", "h5netcdf"):
            with xr.open_dataset(p, engine=engine) as ds:
                ds.load()
                n = ds.sizes["time"]
                assert ds.attrs["status"] == "running"
                # every snapshot but possibly the last is complete, and equals what we read; a
                # kill inside the flush of an append can leave the last one incomplete (some
                # variables one row short, read as the fill value NaN; module docstring), and
                # then our reader drops it
                assert m in (n, n - 1)
                for k in ("time", "rho", "u", "mass", "floor", "kinetic_energy", "tracer_height"):
                    assert np.array_equal(ds[k].values[:m], data[k]), (engine, k)
                if m == n - 1:
                    assert not all(np.all(np.isfinite(ds[k].values[-1])) for k in SCHEMA if k not in ("x", "tracer"))
        sizes.append(m)
    assert max(sizes) > 1


@pytest.mark.parametrize("short", ["mass", "time", "rho"])
def test_reader_drops_a_snapshot_cut_short(tmp_path, short):
    """The state a kill inside an append's flush can leave (one variable a row short, or its
    last value still the fill value): xarray shows the row with NaN, read_snapshots drops it."""
    import h5py

    p = tmp_path / "cut.nc"
    nx = 20
    x = (np.arange(nx) + 0.5) * 0.01
    w = NetCDFWriter(p, x, 0.01, 2, lambda t: 0.0, {"config": "a = 1"}, expected_snapshots=10)
    for k in range(4):
        w(k * 0.01, np.zeros(nx), np.ones(nx), np.array([0.1, 0.2]))
    w._h5.flush()
    w._h5[short].resize(3, axis=0)          # as if the flush stopped before this extent
    w._h5.flush()
    w._h5.close()
    with xr.open_dataset(p, engine="netcdf4") as ds:
        assert ds.sizes["time"] == 4
        assert not np.all(np.isfinite(ds[short].values))
    data, _ = read_snapshots(p)
    assert np.array_equal(data["time"], np.arange(3) * 0.01)
    # the same with the row present but still holding the fill value
    with h5py.File(p, "r+", locking=False) as h:
        h[short].resize(4, axis=0)
        h[short][3] = np.nan
    data, _ = read_snapshots(p)
    assert np.array_equal(data["time"], np.arange(3) * 0.01)


# -- interruptions: SIGTERM and SIGINT like Ctrl-C, checkpoints on by default ----------------------
SLOW_RUN_ENV = SLOW_RUN.replace("time.sleep(0.25)", "time.sleep(float(__import__('os').environ['SLOW_SAVE']))")


def _start_slow(args, sleep):
    env = dict(os.environ, SLOW_SAVE=str(sleep))
    return subprocess.Popen([sys.executable, "-c", SLOW_RUN_ENV] + args, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, env=env)


def _wait_for(proc, out, n_min, timeout=180):
    """Wait until ``out`` and its checkpoint exist and ``out`` holds at least n_min snapshots."""
    deadline = time.time() + timeout
    n = 0
    failed = 0
    while time.time() < deadline and proc.poll() is None:
        if out.exists() and os.path.exists(str(out) + ".ckpt"):
            try:
                n = read_snapshots(out)[0]["time"].size
                failed = 0
            except (OSError, KeyError):
                # read while the other process is writing: HDF5 may find a metadata block half
                # written ("incorrect metadata checksum"); the next poll reads it whole; 40 failed
                # reads in a row (2 s) are a real error
                failed += 1
                if failed >= 40:
                    raise
                time.sleep(0.05)
                continue
            if n >= n_min:
                return n
        time.sleep(0.05)
    raise AssertionError(f"the run did not get to {n_min} snapshots (got {n}): {proc.poll()} "
                         f"{proc.stderr.read() if proc.poll() is not None else ''}")


def _kill_after(proc, out, n_min):
    """SIGKILL ``proc`` once ``out`` and its checkpoint exist and ``out`` holds n_min snapshots."""
    try:
        _wait_for(proc, out, n_min)
        proc.send_signal(signal.SIGKILL)
        proc.wait(30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_sigterm_is_handled_like_ctrl_c_and_says_what_was_kept(tmp_path, reference, capsys):
    cfg_path, ref_out = reference
    out = tmp_path / "term.nc"
    proc = _start_slow(["run", str(cfg_path), "--out", str(out), "--quiet"], 0.25)
    try:
        _wait_for(proc, out, 5)
        proc.send_signal(signal.SIGTERM)
        err = proc.communicate(timeout=60)[1]
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 128 + signal.SIGTERM, err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    data, attrs = read_snapshots(out)
    k = data["time"].size
    assert attrs["status"].startswith("interrupted by SIGTERM after ") and str(k) in attrs["status"]
    assert lines[0].startswith(f"bsrflow run: interrupted by SIGTERM: {out} keeps {k} snapshot(s) up to "
                               f"t = {data['time'][-1]:.6g} s; checkpoint {out}.ckpt at t = 0.03 s: "
                               "`--resume` continues from there"), lines[0]
    assert main(["run", str(cfg_path), "--out", str(out), "--resume", "--quiet"]) == 0
    da, _ = assert_same_variables(out, ref_out)
    assert da.attrs["status"] == "ok"


@pytest.mark.parametrize("ckpt", [0.03, 0.0])
def test_sigint_says_what_was_kept_and_whether_resume_can_continue(tmp_path, capsys, monkeypatch, ckpt):
    """A real SIGINT (Python raises KeyboardInterrupt, as on Ctrl-C) after the 6th snapshot."""
    # Python's own Ctrl-C handler, also where the test process was started with SIGINT ignored
    # (a background job of a non-interactive shell), so that the signal reaches the run
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        _sigint_after_six_snapshots(tmp_path, capsys, monkeypatch, ckpt)
    finally:
        signal.signal(signal.SIGINT, previous)


def _sigint_after_six_snapshots(tmp_path, capsys, monkeypatch, ckpt):
    cfg_path = write_config(tmp_path / "c.toml", ckpt=ckpt)
    out = tmp_path / "c.nc"
    call = NetCDFWriter.__call__

    def interrupting(self, *a):
        call(self, *a)
        if self.n == 6:
            signal.raise_signal(signal.SIGINT)
    monkeypatch.setattr(NetCDFWriter, "__call__", interrupting)
    assert main(["run", str(cfg_path), "--out", str(out), "--quiet"]) == 130
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    data, attrs = read_snapshots(out)
    assert data["time"].size == 6
    assert attrs["status"] == "interrupted by Ctrl-C (SIGINT) after 6 snapshots, up to t = 0.05 s"
    kept = f"bsrflow run: interrupted by Ctrl-C (SIGINT): {out} keeps 6 snapshot(s) up to t = 0.05 s; "
    if ckpt:
        assert lines[0] == kept + (f"checkpoint {out}.ckpt at t = 0.03 s: `--resume` continues from there "
                                   "(snapshots after it are recomputed)")
    else:
        assert lines[0] == kept + ("no checkpoint (run.checkpoint_every = 0): `--resume` cannot continue; "
                                   "run again to start over")
        assert not os.path.exists(str(out) + ".ckpt")


@pytest.mark.slow       # 28 s; the tiny config's SIGKILL-and-resume test covers the same path by default
def test_default_config_checkpoints_and_resumes_after_sigkill_bit_for_bit(tmp_path, capsys):
    """The config `bsrflow init` writes, unchanged: checkpoints are on by default (every 0.1 s,
    on snapshot times, so they change no step) and a SIGKILLed run resumes to the uninterrupted
    run's file bit for bit."""
    cfg_path = tmp_path / "default.toml"
    assert main(["init", str(cfg_path)]) == 0
    cfg = load_config(cfg_path)
    assert cfg.checkpoint_interval() == pytest.approx(0.1)
    assert set(cfg.checkpoint_times()) <= set(cfg.save_times()) and cfg.checkpoint_times().size == 12
    full = tmp_path / "full.nc"
    assert main(["run", str(cfg_path), "--out", str(full), "--quiet"]) == 0
    # the checkpoints add no event: the run equals run_bsr_column's (which has none) bit for bit
    ref = run_bsr_column(cfg.column_setup(), cfg.scheme())
    assert np.array_equal(load(full).rho.values, ref.rho) and load(full).attrs["steps"] == ref.steps
    out = tmp_path / "killed.nc"
    proc = _start_slow(["run", str(cfg_path), "--out", str(out), "--quiet"], 0.02)
    _kill_after(proc, out, 30)                       # past the first checkpoint (t = 0.1 s, snapshot 21)
    assert load(out).attrs["status"] == "running" and load(out).sizes["time"] < 261
    capsys.readouterr()
    assert main(["run", str(cfg_path), "--out", str(out), "--resume"]) == 0
    assert "resumed from t = 0." in capsys.readouterr().out
    da, db = assert_same_variables(out, full)
    assert da.attrs["status"] == "ok" and da.attrs["steps"] == db.attrs["steps"]


@pytest.mark.parametrize("form", ["lagrangian", "eulerian"])
def test_packing_run_resumes_after_sigkill_bit_for_bit(tmp_path, capsys, form):
    """The packing continuum through the same writer and checkpoints: a SIGKILLed run resumes
    from its checkpoint of the named fields (the history included) to the uninterrupted file
    bit for bit (issue #18)."""
    cfg_path = tmp_path / "packing.toml"
    assert main(["init", str(cfg_path), "--kernel", "packing"]) == 0
    sets = ["--set", f"numerics.formulation={form}", "--set", "column.n_spheres=6",
            "--set", "numerics.points_per_diameter=4", "--set", "tap.start=0.05", "--set", "run.t_end=0.3"]
    full = tmp_path / "full.nc"
    assert main(["run", str(cfg_path), "--out", str(full), "--quiet"] + sets) == 0
    out = tmp_path / "killed.nc"
    proc = _start_slow(["run", str(cfg_path), "--out", str(out), "--quiet"] + sets, 0.02)
    _kill_after(proc, out, 30)                       # past the first checkpoint (t = 0.1 s, snapshot 21)
    assert load(out).attrs["status"] == "running" and load(out).sizes["time"] < 61
    capsys.readouterr()
    assert main(["run", str(cfg_path), "--out", str(out), "--resume"] + sets) == 0
    assert "resumed from t = 0." in capsys.readouterr().out
    da, db = assert_same_variables(out, full)
    assert da.attrs["status"] == "ok" and da.attrs["steps"] == db.attrs["steps"]
    assert da.attrs["kernel"] == "packing" and da.attrs["formulation"] == form


@pytest.mark.parametrize("kind", ["seed", "packing"])
def test_resume_of_a_finished_run_does_nothing(tmp_path, capsys, kind):
    """`--resume` on an output whose run finished (status ok, checkpoint removed) leaves it as it
    is and says so, for the seed's kernel and the packing continuum alike (exit 0); without the
    finished file it is refused in one line."""
    cfg_path = write_config(tmp_path / "c.toml", extra="formulation = \"lagrangian\"" if kind == "packing" else "")
    if kind == "packing":
        cfg_path.write_text(cfg_path.read_text() + "[model]\nkernel = \"packing\"\n")
    out = tmp_path / "c.nc"
    assert main(["run", str(cfg_path), "--out", str(out), "--quiet"]) == 0
    before = out.read_bytes()
    capsys.readouterr()
    assert main(["run", str(cfg_path), "--out", str(out), "--resume"]) == 0
    assert "complete already" in capsys.readouterr().out
    assert out.read_bytes() == before
    assert main(["run", str(cfg_path), "--out", str(tmp_path / "other.nc"), "--resume"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "no checkpoint" in lines[0]
    # another config's finished file is not "complete already" for this one
    assert main(["run", str(cfg_path), "--out", str(out), "--resume", "--set", "run.t_end=0.2"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "another config" in lines[0] and "run.t_end" in lines[0]
    assert out.read_bytes() == before


def _run_stopped_halfway(tmp_path):
    """(config path, output path, checkpoint path) of the default column run stopped at t = 0.05 s."""
    def stop(t):
        if t >= 0.05:
            raise _Stop()
    cfg_path = write_config(tmp_path / "c.toml")
    out = tmp_path / "c.nc"
    with pytest.raises(_Stop):
        run_config(load_config(cfg_path), out, progress=stop)
    return cfg_path, out, str(out) + ".ckpt"


def test_resume_refuses_a_checkpoint_of_another_version(tmp_path, capsys):
    from dataclasses import replace

    from bsrflow.io.checkpoint import read_checkpoint, write_checkpoint

    cfg_path, out, ck_file = _run_stopped_halfway(tmp_path)
    write_checkpoint(ck_file, replace(read_checkpoint(ck_file), version="0.0.1"))
    assert main(["run", str(cfg_path), "--out", str(out), "--resume"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "written by bsrflow 0.0.1" in lines[0]


@pytest.mark.parametrize("edit, words", [
    (lambda ck: {"t": -1.0}, "has t = -1.0 s, outside the valid range (0, t_end = 0.1) s"),
    (lambda ck: {"t": float("nan")}, "has t = nan s, outside the valid range (0, t_end = 0.1) s"),
    (lambda ck: {"fields": {**ck.fields, "u": np.where(np.arange(ck.fields["u"].size) == 3, np.nan, ck.fields["u"])}},
     "has 1 non-finite value(s) (NaN or inf) of 584 in its field 'u'"),
    (lambda ck: {"fields": {**ck.fields, "rho": np.full_like(ck.fields["rho"], np.inf)}},
     "has 584 non-finite value(s) (NaN or inf) of 584 in its field 'rho'"),
    (lambda ck: {"steps": -5}, "has steps = -5, outside the valid range: integers >= 0"),
])
def test_resume_refuses_a_hand_edited_checkpoint(tmp_path, capsys, edit, words):
    """A checkpoint with t = -1 was resumed (exit 0), one with NaN fields ran (a NaN snapshot
    before the stop, a fuzzing review): refused up front in one line naming the checkpoint and
    what is wrong, exit 2, the output and the checkpoint left as they were."""
    from dataclasses import replace

    from bsrflow.io.checkpoint import read_checkpoint, write_checkpoint

    cfg_path, out, ck_file = _run_stopped_halfway(tmp_path)
    ck = read_checkpoint(ck_file)
    write_checkpoint(ck_file, replace(ck, **edit(ck)))
    before = out.read_bytes(), open(ck_file, "rb").read()
    assert main(["run", str(cfg_path), "--out", str(out), "--resume"]) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert lines == [f"bsrflow run: error: --resume: the checkpoint {ck_file} {words}; run without --resume to "
                     "start over"], lines
    assert captured.out == ""
    assert (out.read_bytes(), open(ck_file, "rb").read()) == before
    assert sorted(os.listdir(tmp_path)) == ["c.nc", "c.nc.ckpt", "c.toml"]


def test_a_refused_resume_leaves_the_output_as_it_was(tmp_path, capsys):
    """An output whose snapshots before the checkpoint are not the expected ones (a time set to
    NaN) was refused only after the file had been rewritten without them (854 snapshots became
    799, a fuzzing review): the snapshots are checked before the file is touched."""
    import h5py

    cfg_path, out, ck_file = _run_stopped_halfway(tmp_path)
    with h5py.File(out, "r+") as h:
        h["time"][1] = np.nan                     # before the checkpoint time (0.03 s)
    before = out.read_bytes()
    assert main(["run", str(cfg_path), "--out", str(out), "--resume"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "snapshots before the checkpoint time" in lines[0], lines
    assert out.read_bytes() == before


def test_a_packing_run_that_stops_records_its_steps(tmp_path, capsys):
    """A packing run stopped by its monitor (points crossed: a tap of 20 d on a contact 1000
    times too soft) exits 3, keeps its snapshots and records its steps (the attribute was
    missing)."""
    cfg_path = tmp_path / "p.toml"
    assert main(["init", str(cfg_path), "--kernel", "packing"]) == 0
    out = tmp_path / "p.nc"
    argv = ["run", str(cfg_path), "--out", str(out), "--quiet", "--set", "stiffness_factor=1e-3",
            "--set", "a_over_d=20", "--set", "n_spheres=3", "--set", "t_end=0.6"]
    assert main(argv) == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    ds = load(out)
    assert ds.attrs["status"] in err[0] and "crossed" in ds.attrs["status"]
    assert ds.sizes["time"] >= 1 and int(ds.attrs["steps"]) > 0
