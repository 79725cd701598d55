"""The package's DEM against a real, independent engine: LIGGGHTS 3.8.0 runs of the tapped
column (issue #18's 14 cases and the demo's three taps), reduced by
``reference/liggghts_column/run_liggghts_column.py`` into small committed CSV files, so these
tests need no LIGGGHTS.  Same contact law (Walton-Braun: LIGGGHTS's edinburgh/stiffness in its
linear limit), same column, taps and samples; different code, integrator details and floor (a
moving mesh)."""
import gzip
import json
from pathlib import Path

import numpy as np
import pytest

from bsrflow.analysis.compare import run_dem_column
from bsrflow.analysis.compare_packing import PACKING_CASES, case_setup
from bsrflow.physics.column import ColumnSetup

REF = Path(__file__).resolve().parents[1] / "reference" / "liggghts_column"
SUMMARY = json.loads((REF / "summary.json").read_text())
DEMO = {"name": "demo_three_taps_a0.75", "diameter": ColumnSetup().diameter, "a_over_d": 0.75,
        "n_taps": 3, "tap_period": 0.6}
CASES = {c["name"]: c for c in list(PACKING_CASES) + [DEMO]}

# the criteria, set before comparing: the DEM's own time-step error in the top maximum is
# 0.004-0.006 d (README, "DEM step"), the two engines should agree to a few times that
TOP_TOL_D = 0.05          # top maximum [d]
RMS_TOL_D = 0.05          # mass-centre and top RMS over the whole run [d]


def _liggghts(name):
    return np.loadtxt(REF / "results" / f"{name}.csv", delimiter=",")


@pytest.mark.parametrize("name", sorted(CASES))
def test_package_dem_equals_liggghts(name):
    s = case_setup(CASES[name])
    ref = SUMMARY["cases"][name]
    assert (ref["diameter_m"], ref["a_over_d"], ref["n_taps"], ref["t_end_s"]) == \
        (s.diameter, s.a_over_d, s.n_taps, s.t_end)              # the committed run is this case
    t, pos, floor = run_dem_column(s)
    lig = _liggghts(name)
    np.testing.assert_allclose(lig[:, 0], t, rtol=0, atol=1e-12)   # the same samples
    d = s.diameter
    assert np.max(np.abs(lig[:, 1] - floor)) < 1e-3 * d             # the same floor motion
    top, centre = pos.max(axis=1), pos.mean(axis=1)
    for k, t0 in enumerate(s.tap_times()):                       # every tap's peak
        t1 = s.tap_times()[k + 1] if k + 1 < s.n_taps else np.inf
        w = (t >= t0 - 1e-12) & (t < t1)
        i, j = np.argmax(np.where(w, top, -np.inf)), np.argmax(np.where(w, lig[:, 2], -np.inf))
        assert abs(top[i] - lig[j, 2]) / d < TOP_TOL_D, (k, top[i] / d, lig[j, 2] / d)
        assert abs(t[i] - lig[j, 0]) <= s.save_every + 1e-12, (k, t[i], lig[j, 0])
    assert np.sqrt(np.mean((centre - lig[:, 3]) ** 2)) / d < RMS_TOL_D
    assert np.sqrt(np.mean((top - lig[:, 2]) ** 2)) / d < RMS_TOL_D


def test_every_case_has_its_liggghts_run():
    assert set(SUMMARY["cases"]) == set(CASES)
    for name in CASES:
        assert (REF / "results" / f"{name}.csv").is_file()


def test_reader_on_the_real_liggghts_dump():
    """`read_dump` on LIGGGHTS's own output (gzip, dump custom with id type x y z vz, no
    ITEM: TIME): the heights the reduction committed, and the time from --dt."""
    from bsrflow.io.lammps import read_dump

    path = REF / "results" / "d22mm_a0.75.dump.gz"
    with gzip.open(path, "rt") as fh:
        assert fh.readline().strip() == "ITEM: TIMESTEP"
    dt = SUMMARY["cases"]["d22mm_a0.75"]["dt_s"]
    traj = read_dump(path, timestep_size=dt)
    lig = _liggghts("d22mm_a0.75")
    assert traj.n_atoms == 20 and traj.n_snapshots == lig.shape[0]
    np.testing.assert_allclose(traj.t, lig[:, 0], rtol=0, atol=1e-9)
    np.testing.assert_array_equal(traj.top(), lig[:, 2])
    np.testing.assert_allclose(traj.mass_centre(), lig[:, 3], rtol=1e-12)
