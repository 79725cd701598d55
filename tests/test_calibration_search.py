"""The seed kernel's calibration refinement (``compass_search``, analysis/compare.py): it finds
the minimum of a known function to its final step, keeps to its bounds and its budget, never
evaluates a point twice, survives failed points, and its end point is set by the function's
values alone (the reason it replaced ``scipy.optimize.least_squares``, whose end point moved
from SciPy 1.17 to 1.18)."""
import math

import numpy as np
import pytest

from bsrflow.analysis.compare import compass_search

LOWER, UPPER = [-10.0, -10.0], [10.0, 10.0]


def _bowl(centre):
    def cost(p):
        return float((p[0] - centre[0]) ** 2 + 4.0 * (p[1] - centre[1]) ** 2)
    return cost


def test_it_finds_a_bowls_minimum_to_its_final_step():
    centre = (1.234, -0.567)
    x, fx, n = compass_search(_bowl(centre), [0.0, 0.0], step=[0.5, 0.5], lower=LOWER, upper=UPPER,
                              min_step=[1e-3, 1e-3], max_evals=500)
    assert abs(x[0] - centre[0]) < 1e-3 and abs(x[1] - centre[1]) < 1e-3
    assert fx == pytest.approx(_bowl(centre)(x), abs=0)
    assert n < 500                                           # stopped by the step, not the budget


def test_it_keeps_to_the_bounds_and_ends_at_the_nearest_one():
    calls = []

    def cost(p):
        calls.append(tuple(p))
        return _bowl((5.0, 0.3))(p)
    x, _, _ = compass_search(cost, [0.0, 0.0], step=[0.4, 0.1], lower=[-1.0, -1.0], upper=[2.0, 1.0],
                             min_step=[1e-4, 1e-4], max_evals=400)
    assert all(-1.0 <= a <= 2.0 and -1.0 <= b <= 1.0 for a, b in calls)
    assert x[0] == pytest.approx(2.0, abs=1e-4) and x[1] == pytest.approx(0.3, abs=1e-4)


def test_the_budget_counts_every_evaluation_and_no_point_is_evaluated_twice():
    calls = []

    def cost(p):
        calls.append(tuple(float(v) for v in p))
        return _bowl((3.0, 3.0))(p)
    _, _, n = compass_search(cost, [0.0, 0.0], step=[0.01, 0.01], lower=LOWER, upper=UPPER,
                             min_step=[1e-6, 1e-6], max_evals=25)
    assert n == len(calls) == 25
    assert len(set(calls)) == len(calls)


def test_failed_points_are_steps_away_from_not_minima():
    """A run that stops early is an infinite cost: the search goes around it."""
    def cost(p):
        return math.inf if p[0] > 0.75 else _bowl((1.0, 0.0))(p)
    x, fx, _ = compass_search(cost, [0.0, 0.5], step=[0.5, 0.5], lower=LOWER, upper=UPPER,
                              min_step=[1e-3, 1e-3], max_evals=300)
    assert math.isfinite(fx) and 0.75 - 1e-3 <= x[0] <= 0.75 and abs(x[1]) < 1e-3


def test_the_end_point_depends_only_on_the_values():
    """Same values, same path: a rough function (a staircase on a bowl, like tops on the saves)
    gives the same end point every time, and ties keep the first polled point (+ before −,
    the first coordinate before the second)."""
    def rough(p):
        return float(np.floor(20.0 * ((p[0] - 0.3) ** 2 + (p[1] + 0.2) ** 2)) / 20.0)
    runs = [compass_search(rough, [1.0, 1.0], step=[0.25, 0.25], lower=LOWER, upper=UPPER,
                           min_step=[1e-3, 1e-3], max_evals=200) for _ in range(2)]
    assert np.array_equal(runs[0][0], runs[1][0]) and runs[0][1:] == runs[1][1:]
    x, _, _ = compass_search(lambda p: 0.0 if p[0] != 0.0 or p[1] != 0.0 else 1.0, [0.0, 0.0],
                             step=[1.0, 1.0], lower=LOWER, upper=UPPER, min_step=[0.5, 0.5], max_evals=10)
    assert list(x) == [1.0, 0.0]                             # all four neighbours tie: the first (+x) wins


def test_calibrate_refines_its_grids_best_point_on_a_small_column():
    """The whole calibration on a small column: the refined point is no worse than the grid's
    best, inside the search's bounds, and its run count is the grid's plus the search's."""
    from bsrflow.analysis.compare import _residuals, calibrate, run_dem_column
    from bsrflow.physics.column import ColumnSetup
    s = ColumnSetup(n_spheres=6, a_over_d=0.75, tap_start=0.05, t_end=0.35, points_per_diameter=4,
                    save_every=0.005)
    dem = run_dem_column(s)
    grid_m0, grid_eps = (150.0, 600.0), (0.5, 0.9)
    costs = [float(r @ r) for r in (_residuals(s, dem, m, e) for m in grid_m0 for e in grid_eps) if r is not None]
    cal = calibrate(s, dem, log=None, grid_m0=grid_m0, grid_eps=grid_eps)
    assert costs and cal["rms_residual_over_d"] ** 2 * 2 <= min(costs) * (1 + 1e-12)
    assert 20.0 <= cal["m0"] <= 1e5 and 0.0 <= cal["kernel_dissipation"] <= 0.9
    assert 4 < cal["bsr_runs"] <= 4 + 60
