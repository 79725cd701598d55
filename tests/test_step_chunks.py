"""2-D / 3-D runs advance in chunks of steps, so that Ctrl-C and SIGTERM (which Python handles only
between compiled calls) end a long run within about a second: the chunking does not change a
result (every step is chosen from the state alone), and a real SIGTERM inside what would be one
long compiled segment ends a `bsrflow run` of a layer promptly, with its file kept."""
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from bsrflow.numerics.packing_nd import EulerianPackingND, run_packing_nd
from bsrflow.numerics.solver import Scheme, save_schedule
from bsrflow.numerics.solver_nd import SimulationND
from bsrflow.physics.packing_bed import PackingBed
from bsrflow.physics.scenarios_nd import TappedLayer

pytestmark = pytest.mark.usefixtures("one_numba_thread")


def test_packing_nd_chunks_give_the_same_run_bit_for_bit(monkeypatch):
    kw = dict(dim=2, box_width=0.01, bed_height=0.01, cells_per_diameter=2, settle_time=0.005, t_end=0.02,
              save_every=0.01, surface_perturbation=0.2)
    saves = save_schedule(0.0, kw["t_end"], kw["save_every"])
    runs = []
    for chunk in (1 << 40, 1):              # one call per save interval / one step per call
        monkeypatch.setattr(EulerianPackingND, "STEP_CHUNK_CELL_STEPS", chunk)
        bed = PackingBed(**kw)
        disc = bed.discretisation()
        t, u, rho, _ = run_packing_nd(disc, kw["t_end"], saves)
        runs.append((t, u, rho, disc.steps, disc.q.copy()))
    (t1, u1, r1, s1, q1), (t2, u2, r2, s2, q2) = runs
    assert s1 == s2 and s1 > 100
    np.testing.assert_array_equal(t1, t2)
    np.testing.assert_array_equal(q1, q2)
    np.testing.assert_array_equal(r1, r2)
    np.testing.assert_array_equal(u1, u2)
    assert np.ptp(u1[-1][1]) > 0.0           # the bed moved


def test_seed_kernel_nd_chunks_give_the_same_run_bit_for_bit(monkeypatch):
    setup = TappedLayer(dim=2, t_end=0.03, settle_time=0.01, save_every=0.01)
    grid = setup.grid()
    u0, rho0 = setup.initial_state(grid)
    tr0 = np.column_stack([np.full(2, 0.5 * grid.upper[0]), np.array([0.3, 0.7]) * setup.layer_height])
    results = []
    for chunk in (1 << 40, 1):
        monkeypatch.setattr(SimulationND, "STEP_CHUNK_CELL_STEPS", chunk)
        sim = SimulationND(setup.model(), grid, Scheme.preset("seed", positivity=True))
        results.append(sim.run(u0, rho0, setup.t_end, save_every=setup.save_every, tracers=tr0))
    a, b = results
    assert a.steps == b.steps and a.steps > 10
    np.testing.assert_array_equal(a.rho, b.rho)
    np.testing.assert_array_equal(a.u, b.u)
    np.testing.assert_array_equal(a.tracers, b.tracers)
    # the step budget still stops the run where it did (status 4), chunked or not
    for chunk in (1 << 40, 3):
        monkeypatch.setattr(SimulationND, "STEP_CHUNK_CELL_STEPS", chunk)
        sim = SimulationND(setup.model(), grid, Scheme.preset("seed", positivity=True), max_steps=7)
        with pytest.raises(Exception, match="maximum number of steps reached.*7 steps"):
            sim.run(u0, rho0, setup.t_end, save_every=setup.save_every)


LONG_BED = """[layer]
kind = "packing_bed"
dim = 3
box_width = 0.03
bed_height = 0.03
cells_per_diameter = 4
settle_time = 0.0
t_end = 1.0
save_every = 1.0
[output]
checkpoint_every = 0
"""


def test_sigterm_inside_a_long_segment_ends_a_layer_run_promptly(tmp_path):
    """A 3-D bed saved only at t = 0 and t = 1 s: its one segment takes many minutes (1.5e5 cells
    at microsecond steps).  SIGTERM a few seconds into it ends the run within seconds (exit 143),
    the file keeps its first snapshot and says it was interrupted."""
    from bsrflow.io.netcdf import read_snapshots

    cfg = tmp_path / "bed.toml"
    cfg.write_text(LONG_BED)
    out = tmp_path / "bed.nc"
    proc = subprocess.Popen([sys.executable, "-m", "bsrflow", "run", str(cfg), "--out", str(out), "--quiet"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            env=dict(os.environ, NUMBA_NUM_THREADS="1"))
    try:
        deadline = time.time() + 180
        while not out.exists() and proc.poll() is None and time.time() < deadline:
            time.sleep(0.1)
        assert out.exists() and proc.poll() is None, proc.stderr.read() if proc.poll() is not None else "no file"
        time.sleep(3.0)                           # inside the segment from t = 0 to t = 1 s
        sent = time.time()
        proc.send_signal(signal.SIGTERM)
        err = proc.communicate(timeout=60)[1]
        waited = time.time() - sent
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 128 + signal.SIGTERM, err
    assert waited < 20.0, waited
    data, attrs = read_snapshots(out)
    assert data["time"].size == 1 and attrs["status"].startswith("interrupted by SIGTERM")
    assert len(err.strip().splitlines()) == 1
