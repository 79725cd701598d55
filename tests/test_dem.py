"""The DEM reference: restitution, energy conservation, static overlaps, tapped column."""
import numpy as np
import pytest

from bsrflow.physics.dem import DEMColumn, run_dem, static_overlaps, static_positions
from bsrflow.physics.motion import HalfSineTaps, Rest


@pytest.mark.parametrize("e", [0.9, 0.5])
def test_single_sphere_rebounds_with_restitution(e):
    col = DEMColumn(n_spheres=1, restitution=e)
    res = run_dem(col, Rest(), 0.2, sample_interval=1e-5, initial_positions=[0.5 * col.diameter + 0.01])
    v = res.velocities[:, 0]
    i = np.argmin(v)                       # impact speed (just before the contact)
    ratio = -v[i:].max() / v[i]
    assert abs(ratio / e - 1) < 0.01


def test_energy_conserved_with_elastic_contacts():
    """e = 1: total energy (kinetic + gravitational + elastic) conserved within 1e-6 over 1 s.
    Velocity Verlet's energy error is O(dt^2): 1000 steps per contact period are needed
    (2.7e-4 at 50 steps, 5.5e-6 at 200, 3.0e-7 at 1000)."""
    col = DEMColumn(n_spheres=3, restitution=1.0, steps_per_contact=1000)
    y0 = (np.arange(3) + 0.5) * col.diameter + np.array([0.004, 0.008, 0.012])
    res = run_dem(col, Rest(), 1.0, sample_interval=1e-3, initial_positions=y0)
    E = res.energy
    assert np.max(np.abs(E - E[0])) / E[0] < 1e-6


def test_column_at_static_overlaps_stays_at_rest():
    col = DEMColumn()
    res = run_dem(col, Rest(), 0.2, initial_positions=static_positions(col))
    ov = np.concatenate([[0.5 * col.diameter - res.positions[-1, 0]], col.diameter - np.diff(res.positions[-1])])
    assert np.max(np.abs(ov / static_overlaps(col) - 1)) < 1e-3


def test_settled_column_forces_balance_the_weights():
    """Dropped from touching contact, the column settles on the unloading branches (Walton-Braun
    hysteresis), so the overlaps differ from the loading-line prediction, but the contact
    forces still carry the weight above each contact."""
    col = DEMColumn(restitution=0.5)
    res = run_dem(col, Rest(), 3.0)
    y = res.positions[-1]
    # contact force between spheres k and k+1 from the momentum balance of the spheres above
    from bsrflow.physics.dem import _contact
    k1, k2 = col.stiffness, col.unloading_stiffness
    assert np.max(np.abs(res.velocities[-1])) < 2e-3
    assert np.all(np.diff(y) < col.diameter)         # all contacts closed
    weights = (col.n_spheres - np.arange(col.n_spheres)) * col.mass * col.gravity
    ov = np.concatenate([[0.5 * col.diameter - y[0]], col.diameter - np.diff(y)])
    # on the unloading line F = K2 (δ - δ0) lies between 0 and K1 δ: bounds on the forces
    assert np.all(k1 * ov >= weights * (1 - 1e-3))


@pytest.mark.parametrize("a_over_d, expected", [(0.75, 30.0), (1.0, 38.0)])
def test_tapped_column_reaches_seed_heights(a_over_d, expected):
    """d = 2.2 cm: the top sphere centre reaches about 30 d (a/d = 0.75) and 38 d (a/d = 1.0), the
    heights the seed reports for its DEM; the column lands back and nothing enters the floor."""
    col = DEMColumn()
    d = col.diameter
    res = run_dem(col, HalfSineTaps(a_over_d * d, 10.0, start=0.4), 1.4)
    top = res.top() / d
    assert abs(top.max() - expected) < 1.0
    assert np.all(res.positions[:, 0] - res.floor > 0.4 * d)
    assert abs(res.mass_centre()[-1] / d - 10.0) < 0.1


def test_bad_dem_inputs():
    with pytest.raises(ValueError, match="restitution"):
        DEMColumn(restitution=1.2)
    with pytest.raises(ValueError, match="diameter"):
        DEMColumn(diameter=-1)
    with pytest.raises(ValueError, match="t_end"):
        run_dem(DEMColumn(), Rest(), -1.0)
