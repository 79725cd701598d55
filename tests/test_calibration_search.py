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


def test_a_step_back_is_the_same_point_and_is_not_run_again():
    """x + h − h is not always x in floating point; the search's points lie on a lattice built
    from integers, so going back to a point finds it in the cache (a review found 2 of 38 runs of
    the real calibration repeated one ulp away, with a different cost)."""
    calls = []

    def cost(p):
        calls.append(tuple(float(v) for v in p))
        return float((p[0] - 0.3) ** 2 + (p[1] - 0.7) ** 2)
    compass_search(cost, [0.1, 0.1], step=[0.2, 0.05], lower=LOWER, upper=UPPER,
                   min_step=[0.002, 0.0005], max_evals=500)
    assert len(set(calls)) == len(calls)
    near = {tuple(np.round(c, 9)) for c in calls}
    assert len(near) == len(calls)                           # no two within 1e-9 of each other


def test_a_known_start_cost_is_used_not_evaluated():
    calls = []

    def cost(p):
        calls.append(tuple(p))
        return _bowl((0.0, 0.0))(p)
    x, fx, n = compass_search(cost, [0.0, 0.0], step=[0.5, 0.5], lower=LOWER, upper=UPPER,
                              min_step=[0.25, 0.25], max_evals=100, f0=0.0)
    assert (0.0, 0.0) not in calls and n == len(calls) == 8 and fx == 0.0 and list(x) == [0.0, 0.0]


def test_a_nan_cost_counts_as_a_failed_point():
    """A NaN at the start (which compares lower than nothing) froze the search."""
    x, fx, _ = compass_search(lambda p: math.nan if p[0] == 0.0 else _bowl((1.0, 0.0))(p), [0.0, 0.0],
                              step=[0.5, 0.5], lower=LOWER, upper=UPPER, min_step=[1e-3, 1e-3], max_evals=200)
    assert abs(x[0] - 1.0) < 1e-3 and fx < 1e-5
    x, fx, _ = compass_search(_bowl((1.0, 0.0)), [0.0, 0.0], step=[0.5, 0.5], lower=LOWER, upper=UPPER,
                              min_step=[1e-3, 1e-3], max_evals=200, f0=math.nan)
    assert abs(x[0] - 1.0) < 1e-3


@pytest.mark.parametrize("kw, text", [
    (dict(min_step=[0.0, 1e-3]), "min_step must be finite and > 0"),
    (dict(step=[-1.0, 1.0]), "step and min_step"),
    (dict(x0=[11.0, 0.0]), "outside [lower, upper]"),
    (dict(max_evals=0), "max_evals"),
])
def test_arguments_that_would_never_end_or_mean_nothing_are_refused(kw, text):
    args = dict(x0=[0.0, 0.0], step=[0.5, 0.5], lower=LOWER, upper=UPPER, min_step=[1e-3, 1e-3], max_evals=10)
    args.update(kw)
    with pytest.raises(ValueError, match=text.replace("[", r"\[")):
        compass_search(_bowl((1.0, 0.0)), **args)


def test_calibrate_refines_its_grids_best_point_on_a_small_column(monkeypatch):
    """The whole calibration on a small column: the refined point is no worse than the grid's
    best, inside the search's bounds, and its run count is the number of runs made, none twice."""
    import bsrflow.analysis.compare as compare_module
    from bsrflow.analysis.compare import _residuals, calibrate, run_dem_column
    from bsrflow.physics.column import ColumnSetup
    s = ColumnSetup(n_spheres=6, a_over_d=0.75, tap_start=0.05, t_end=0.35, points_per_diameter=4,
                    save_every=0.005)
    dem = run_dem_column(s)
    grid_m0, grid_eps = (150.0, 600.0), (0.5, 0.9)
    costs = [float(r @ r) for r in (_residuals(s, dem, m, e) for m in grid_m0 for e in grid_eps) if r is not None]
    runs = []

    def counted(*args):
        runs.append(args[2:])
        return _residuals(*args)
    monkeypatch.setattr(compare_module, "_residuals", counted)
    cal = calibrate(s, dem, log=None, grid_m0=grid_m0, grid_eps=grid_eps)
    assert costs and cal["rms_residual_over_d"] ** 2 * 2 <= min(costs)
    assert 20.0 <= cal["m0"] <= 1e5 and 0.0 <= cal["kernel_dissipation"] <= 0.9
    assert cal["bsr_runs"] == len(runs) and 4 < len(runs) <= 4 + 60
    assert len(set(runs)) == len(runs)                      # the grid's best point is not run again
