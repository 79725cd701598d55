"""The compiled 1-D DEM (bsrflow.physics.dem): restitution, energy, statics, a tapped column."""
import math

import numpy as np
import pytest

from bsrflow.physics.dem import (DEMColumn, make_dem_loop, run_dem, settle, static_overlaps,
                                 static_positions)
from bsrflow.physics.motion import HalfSineTaps, Rest


def _speeds_at_contact(col, y, v, i):
    """Speed of a free-flying sphere (sample i) where it touches the resting floor, y = d/2:
    free flight under gravity conserves v² + 2 g y."""
    return math.sqrt(v[i] ** 2 + 2.0 * col.gravity * (y[i] - 0.5 * col.diameter))


@pytest.mark.parametrize("e", [0.9, 0.5])
def test_single_sphere_rebounds_with_the_set_restitution(e):
    """Dropped from d/2 above the touching position; the speeds before and after the first
    contact (taken from free-flight samples, carried to the touching height) have ratio e.
    The residual difference is the gravity acting during the contact, O(g / (ω v))."""
    col = DEMColumn(n_spheres=1, restitution=e)
    h = 0.5 * col.diameter
    res = run_dem(col, Rest(), 0.12, initial_positions=[0.5 * col.diameter + h])
    y, v = res.positions[:, 0], res.velocities[:, 0]
    after = int(np.argmax(v > 0))                      # first sample moving up
    before = after - 1
    assert after > 0 and res.overlaps()[[before, after], 0].max() < 0   # both in free flight
    v_in = _speeds_at_contact(col, y, v, before)
    v_out = _speeds_at_contact(col, y, v, after)
    assert v_in == pytest.approx(math.sqrt(2 * col.gravity * h), rel=1e-6)
    ratio = v_out / v_in
    print(f"e = {e}: rebound/impact = {ratio:.6f}, relative error {ratio / e - 1:+.2e}")
    assert abs(ratio / e - 1) < 0.01

    # without gravity the contact alone is tested: only the time discretisation is left
    col0 = DEMColumn(n_spheres=1, restitution=e, gravity=0.0)
    res0 = run_dem(col0, Rest(), 1e-3, initial_positions=[0.5 * col0.diameter + 1e-4],
                   initial_velocities=[-0.5])
    ratio0 = res0.velocities[-1, 0] / 0.5
    print(f"e = {e}, g = 0: ratio {ratio0:.6f}, relative error {ratio0 / e - 1:+.2e}")
    assert abs(ratio0 / e - 1) < 2e-4


def _energy_error(col, y0, t_end=1.0):
    res = run_dem(col, Rest(), t_end, initial_positions=y0)
    E = res.energy
    return float(np.max(np.abs(E - E[0])) / E[0]), res


@pytest.mark.parametrize("n", [1, 3])
def test_energy_is_conserved_with_elastic_contacts(n):
    """e = 1, resting floor: kinetic + gravitational + elastic energy is constant within 1e-6
    (relative, every sample over 1 s) with 1000 steps per contact period.  Velocity Verlet's
    error is a random walk of O((ω Δt)²) kicks at the contact kinks, so the default 50 steps
    give ~1e-4; the error falls roughly like Δt²."""
    gaps = 1e-3 * np.arange(1, n + 1)                  # 1 mm; for 3 spheres 1, 2, 3 mm
    fine = DEMColumn(n_spheres=n, restitution=1.0, steps_per_contact=1000)
    y0 = (np.arange(n) + 0.5) * fine.diameter + gaps
    err_fine, res = _energy_error(fine, y0)
    err_default, _ = _energy_error(DEMColumn(n_spheres=n, restitution=1.0), y0)
    touching = np.mean(res.elastic > 0)
    print(f"N = {n}: relative energy error over 1 s: {err_default:.2e} at 50 steps/contact, "
          f"{err_fine:.2e} at 1000 (dt = {res.dt:.3g} s); samples in contact: {touching:.1%}")
    assert np.all(res.elastic >= 0) and touching > 0            # the contacts were exercised
    assert np.ptp(res.kinetic) > 0.5 * res.kinetic.max() > 0    # real bouncing
    assert err_fine < 1e-6
    assert err_fine < err_default / 20


@pytest.mark.parametrize("e", [0.9, 0.5])
def test_settled_column_has_the_static_overlaps(e):
    """20 spheres, gravity switched on smoothly (settle): the overlaps equal the force balance
    δ_j = (N - j) m g / K1 within 1e-3, the column is at rest, and restarting from the settled
    state (with the contact memory) keeps it there."""
    col = DEMColumn(restitution=e)
    res = settle(col, 0.3)
    expected = static_overlaps(col)
    rel = res.overlaps()[-1] / expected - 1
    print(f"e = {e}: settled overlaps, max relative error {np.abs(rel).max():.2e}")
    assert np.abs(rel).max() < 1e-3
    assert np.abs(res.velocities[-1]).max() < 1e-6            # m/s
    assert res.positions[-1] == pytest.approx(static_positions(col), abs=1e-3 * expected[-1])
    again = run_dem(col, Rest(), 0.05, initial_positions=res.positions[-1],
                    initial_velocities=res.velocities[-1], initial_delta_max=res.delta_max)
    assert np.abs(again.overlaps() / expected - 1).max() < 1e-3


def test_released_column_keeps_the_walton_braun_memory():
    """Released at once from touching contact, the column overshoots to δ_max ≈ 2 W/K1 and
    then vibrates along the unloading (K2) lines about δ = δ_max - (K1 δ_max - W)/K2, above
    the static W/K1 (the hysteresis remembers the overshoot)."""
    col = DEMColumn(restitution=0.9)
    res = run_dem(col, Rest(), 2.0, sample_interval=1e-4)
    W = static_overlaps(col) * col.stiffness                  # weight carried by each contact
    dm = res.delta_max
    k2_line = dm - (col.stiffness * dm - W) / col.unloading_stiffness
    mean = res.overlaps()[-5000:].mean(axis=0)                # last 0.5 s
    lower = slice(0, 15)                                      # the top contacts open at times
    print("mean overlap / static:", np.round(mean / (W / col.stiffness), 3))
    assert np.all(dm[lower] > 1.5 * W[lower] / col.stiffness)
    assert mean[lower] == pytest.approx(k2_line[lower], rel=0.01)
    assert np.all(mean[lower] > 1.1 * W[lower] / col.stiffness)


@pytest.mark.parametrize("a_over_d", [0.75, 1.0])
def test_tapped_column(a_over_d):
    """One half-sine tap (f = 10 Hz, d = 0.022 m) at 0.4 s under 20 spheres.  For orientation
    (not asserted): the dissertation reports the top centre at about 30 d (a/d = 0.75) and
    38 d (a/d = 1.0)."""
    col = DEMColumn()
    d = col.diameter
    t_tap = 0.4
    res = run_dem(col, HalfSineTaps(a_over_d * d, 10.0, start=t_tap), 1.5)
    floor0 = res.floor[0]
    top = (res.top() - floor0) / d
    centre = (res.mass_centre() - floor0) / d
    k = int(np.argmax(top))
    print(f"a/d = {a_over_d}: top centre max {top[k]:.3f} d at t = {res.t[k]:.3f} s; mass centre "
          f"max {centre.max():.3f} d at {res.t[np.argmax(centre)]:.3f} s; largest overlap "
          f"{res.max_overlap / d:.2e} d; dt = {res.dt:.3g} s")
    before = res.t < t_tap
    # at rest before the tap: the column is compressed by ~1e-7 m only
    assert np.abs(top[before] - (col.n_spheres - 0.5)).max() < 1e-4
    # nothing penetrates the floor or another sphere by more than a small fraction of d
    assert res.max_overlap < 0.01 * d
    assert np.all(res.positions[:, 0] - res.floor > 0.49 * d)
    assert np.all(np.diff(res.positions, axis=1) > 0.99 * d)
    # the tap throws the column up: the peak comes after the tap, well above the rest height
    assert res.t[k] > t_tap + 0.05 and top[k] > col.n_spheres + 2
    assert centre.max() > centre[0] + 2
    # ... and it lands back: at the end it rests again where it started
    assert abs(centre[-1] - centre[0]) < 1e-3
    assert abs(top[-1] - top[0]) < 1e-3
    assert np.abs(res.velocities[-1]).max() < 0.01              # m/s
    # the floor only moved during the tap and by at most a
    tapping = (res.t >= t_tap) & (res.t <= t_tap + 0.05 + 1e-9)
    assert np.all(res.floor[~tapping] == 0.0)
    assert res.floor.max() <= a_over_d * d * (1 + 1e-12)


def test_walton_braun_force_law_cycle():
    """Load to 2 µm on K1, unload on K2 to zero force, reload on K2 back to the K1 line,
    load further, open (memory reset)."""
    from bsrflow.physics.dem import _walton_braun
    k1, e = 1e7, 0.5
    k2 = k1 / e ** 2
    dm = 0.0
    f, dm = _walton_braun(2e-6, dm, k1, k2)
    assert (f, dm) == pytest.approx((k1 * 2e-6, 2e-6))                     # loading line
    d0 = 2e-6 * (1 - k1 / k2)                                              # 1.5e-6
    f, dm = _walton_braun(1.8e-6, dm, k1, k2)
    assert (f, dm) == pytest.approx((k2 * (1.8e-6 - d0), 2e-6))            # unloading on K2
    f, dm = _walton_braun(1.0e-6, dm, k1, k2)
    assert (f, dm) == (0.0, pytest.approx(2e-6))                          # clipped, still closed
    f, dm = _walton_braun(1.9e-6, dm, k1, k2)
    assert f == pytest.approx(k2 * (1.9e-6 - d0))                          # reloading on K2
    f, dm = _walton_braun(2.5e-6, dm, k1, k2)
    assert (f, dm) == pytest.approx((k1 * 2.5e-6, 2.5e-6))                 # back on K1
    f, dm = _walton_braun(-1e-9, dm, k1, k2)
    assert (f, dm) == (0.0, 0.0)                                           # open: reset
    f, dm = _walton_braun(1e-6, dm, k1, k2)
    assert f == pytest.approx(k1 * 1e-6)                                   # fresh contact loads


def test_static_overlaps_indexing():
    col = DEMColumn(n_spheres=3)
    w = col.mass * col.gravity / col.stiffness
    assert static_overlaps(col) == pytest.approx([3 * w, 2 * w, w])      # floor contact first
    y = static_positions(col)
    assert y[0] == pytest.approx(0.5 * col.diameter - 3 * w)
    assert np.diff(y) == pytest.approx(col.diameter - np.array([2 * w, w]))


def test_compiled_loop_is_built_once_per_motion_function():
    assert make_dem_loop(Rest().fn) is make_dem_loop(Rest().fn)


@pytest.mark.parametrize("kwargs, name", [
    (dict(restitution=1.2), "restitution"),
    (dict(restitution=0.0), "restitution"),
    (dict(diameter=-0.01), "diameter"),
    (dict(density=float("nan")), "density"),
    (dict(stiffness=0), "stiffness"),
    (dict(gravity=-9.81), "gravity"),
    (dict(n_spheres=0), "n_spheres"),
    (dict(n_spheres=2.5), "n_spheres"),
    (dict(steps_per_contact=3), "steps_per_contact"),
])
def test_bad_column_parameters_are_rejected(kwargs, name):
    with pytest.raises(ValueError, match=name) as info:
        DEMColumn(**kwargs)
    assert "valid range" in str(info.value)


def test_bad_run_arguments_are_rejected():
    col = DEMColumn(n_spheres=2)
    with pytest.raises(ValueError, match="t_end"):
        run_dem(col, Rest(), -1.0)
    with pytest.raises(ValueError, match="t_end"):
        run_dem(col, Rest(), 0.0)
    with pytest.raises(ValueError, match="sample_interval"):
        run_dem(col, Rest(), 0.1, sample_interval=0.5)
    with pytest.raises(ValueError, match="initial_positions"):
        run_dem(col, Rest(), 0.1, initial_positions=[0.011])
    with pytest.raises(ValueError, match="initial_positions"):
        run_dem(col, Rest(), 0.1, initial_positions=[0.033, 0.011])
    with pytest.raises(ValueError, match="gravity_ramp"):
        run_dem(col, Rest(), 0.1, gravity_ramp=-1.0)
    with pytest.raises(ValueError, match="ramp_time"):
        settle(col, 0.1, ramp_time=0.2)


@pytest.mark.parametrize("period", [None, 0.6, 2.0])
def test_a_single_tap_longer_than_the_tap_period_runs_to_its_end(period):
    """One tap ignores the tap period (the train's spacing): a 0.4 Hz tap (1.25 s) with the default
    1-s period, or a 0.6-s one, is a whole half sine, continuous, with its velocity jumps at its
    ends (it dropped to 0 at t0 + period)."""
    a, f, t0 = 0.01, 0.4, 0.1
    m = HalfSineTaps(a, f, start=t0, period=period)
    w = 2.0 * math.pi * f
    for t in (t0 + 0.3, t0 + 0.6, t0 + 0.999999, t0 + 1.0, t0 + 1.2):
        z, v, acc = m.state(t)
        assert z == pytest.approx(a * math.sin(w * (t - t0)), rel=1e-12)
        assert v == pytest.approx(a * w * math.cos(w * (t - t0)), rel=1e-12)
    assert m.state(t0 + 1.26) == (0.0, 0.0, 0.0)
    assert [tj for tj, _ in m.jumps] == pytest.approx([t0, t0 + 0.5 / f])
