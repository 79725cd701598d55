"""The tapped-column scenario: initial state, conservation, positivity, presets, seed constants."""
import numpy as np
import pytest

from bsrflow.numerics.solver import SimulationError
from bsrflow.physics.column import ColumnSetup, initial_density, run_bsr_column

CAL = dict(m0=410.0, kernel_dissipation=0.5)     # near the calibrated constants


def test_initial_density_is_the_stacked_spheres():
    s = ColumnSetup()
    g = s.grid()
    rho = initial_density(s, g.x)
    line = s.particle_mass / s.diameter
    assert abs(rho.sum() * g.dx / (s.n_spheres * s.particle_mass) - 1) < 1e-12
    inner = (g.x > 2 * s.diameter) & (g.x < (s.n_spheres - 2) * s.diameter)
    assert np.allclose(rho[inner], line, rtol=1e-12)
    assert np.all(rho[g.x > (s.n_spheres + 0.5) * s.diameter] == 0)


@pytest.mark.parametrize("scheme", ["seed", "accurate"])
@pytest.mark.parametrize("a_over_d", [0.75, 1.0])
def test_tapped_column_runs_conserves_mass_and_stays_positive(scheme, a_over_d):
    s = ColumnSetup(a_over_d=a_over_d, t_end=0.9, **CAL)
    run = run_bsr_column(s, scheme=scheme)
    line = s.particle_mass / s.diameter
    assert run.t[-1] == pytest.approx(0.9)
    assert np.max(np.abs(run.mass - run.mass[0])) / run.mass[0] < 1e-12
    assert run.rho.min() > -1e-6 * line                      # non-negative to round-off
    assert np.all(run.tracers - run.floor[:, None] >= 0)      # tracers never below the floor
    # the tap lifts the material: its mass centre rises above that of the same column untapped
    rest = run_bsr_column(s.with_(n_taps=0), scheme=scheme)
    after = run.t > s.tap_start
    assert np.max(run.mass_centre[after] - rest.mass_centre[after]) > 0.1 * s.diameter


def test_three_taps_run():
    s = ColumnSetup(n_taps=3, t_end=2.0, **CAL)
    run = run_bsr_column(s)
    assert run.t[-1] == pytest.approx(2.0)
    assert np.max(np.abs(run.mass - run.mass[0])) / run.mass[0] < 1e-12


def test_seed_constants_as_printed_expand_the_column():
    """m0 = 22 kg: the hydrostatic height sqrt(2 λ R³ M / (3 g)) is 3 m (136 d): during the settling
    phase, before any tap, the stacked column expands far above its 20 d."""
    s = ColumnSetup(m0=22.0, impulses=False, t_end=0.3)
    run = run_bsr_column(s)
    assert run.top.max() > 40 * s.diameter


@pytest.mark.parametrize("field, value", [("diameter", -0.01), ("restitution", 1.5), ("kernel_dissipation", 1.0),
                                          ("points_per_diameter", 1), ("n_spheres", 0), ("a_over_d", -1),
                                          ("domain_height", 0.1), ("m0", 0.0)])
def test_bad_column_parameters(field, value):
    with pytest.raises(ValueError, match=field):
        ColumnSetup(**{field: value})


@pytest.mark.slow
def test_energy_study_unfiltered_breaks_down():
    from bsrflow.analysis.energy import energy_study
    out = energy_study(figures=None, log=None)
    assert out["runs"]["moving_average"]["completed"]
    assert not out["runs"]["no_moving_average"]["completed"]
    assert np.nanmax(out["wave_speed"]["top_tracer_m_s"]) > 0
