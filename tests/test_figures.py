"""Figures (issue #20, "Figures"): the kinetic-energy panel says where densities went negative,
labels read as physical quantities with units, legends hide no data."""

import types

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from bsrflow.analysis.energy import kinetic_energy_figure, negative_density_snapshots  # noqa: E402
from bsrflow.physics.column import ColumnSetup  # noqa: E402


def _energy_inputs():
    s = ColumnSetup()
    line = s.particle_mass / s.diameter
    t = np.linspace(0.0, 0.4, 41)
    rho_ok = np.full((t.size, 50), line)
    rho_bad = rho_ok.copy()
    rho_bad[30:, 10] = -0.5 * line                     # negative densities from t = 0.3 s on
    rho_bad[5, 3] = -1e-15 * line                      # round-off: not counted
    ke_ok = np.sin(np.pi * t / 0.4) ** 2
    ke_bad = ke_ok.copy()
    ke_bad[35] = -11.0
    out = {"runs": {
        "moving_average": {"t": t.tolist(), "kinetic_normed": ke_ok.tolist(), "kinetic_max_J": 0.128,
                           "completed": True, "min_density_over_line": 0.0},
        "no_moving_average": {"t": t.tolist(), "kinetic_normed": ke_bad.tolist(), "kinetic_max_J": 0.422,
                              "completed": False, "stopped_at_s": 0.4, "min_density_over_line": -0.5}}}
    runs = {"moving_average": (None, types.SimpleNamespace(rho=rho_ok)),
            "no_moving_average": (None, types.SimpleNamespace(rho=rho_bad))}
    return out, runs, s, t


def test_negative_densities_are_found_above_round_off():
    out, runs, s, t = _energy_inputs()
    neg = negative_density_snapshots(s, runs["no_moving_average"][1])
    assert np.array_equal(np.flatnonzero(neg), np.arange(30, 41))
    assert not negative_density_snapshots(s, runs["moving_average"][1]).any()


def test_kinetic_energy_panel_marks_negative_densities():
    out, runs, s, t = _energy_inputs()
    fig = kinetic_energy_figure(out, runs, s)
    ok, bad = fig.axes
    assert ok.get_ylabel() == "kinetic energy of the column / its maximum [1]"
    assert "sum(" not in ok.get_ylabel()
    # the panel with negative densities: shaded snapshots, a legend entry, the title and a note
    spans = [p for p in bad.patches if p.get_facecolor()[3] > 0]
    assert len(spans) == 11
    left = min(p.get_x() for p in spans)
    assert left == pytest.approx(0.3 - 0.005)
    labels = [txt.get_text() for txt in bad.get_legend().get_texts()]
    assert "ρ < 0 somewhere: not an energy" in labels and "Σ ½ρu²Δx / 0.422 J" in labels
    assert "ρ < 0 from t = 0.300 s" in bad.get_title()
    notes = [c.get_text() for c in bad.texts]
    assert any("-11 at t = 0.350 s" in n and "below 0 because ρ < 0" in n for n in notes), notes
    # the panel without: none of that
    assert len(ok.patches) == 0
    assert "ρ < 0" not in ok.get_title() and len(ok.texts) == 0
    plt.close(fig)


def test_netcdf_kinetic_energy_label_is_physical():
    from bsrflow.io.netcdf import SCHEMA
    dims, units, long_name = SCHEMA["kinetic_energy"]
    assert units == "J" and long_name == "kinetic energy of the column (floor frame)"


@pytest.fixture(scope="module")
def three_taps():
    from bsrflow.analysis.compare import run_dem_column
    from bsrflow.physics.column import run_bsr_column
    s = ColumnSetup(n_spheres=3, points_per_diameter=4, t_end=0.5, tap_start=0.02, n_taps=3, tap_period=0.15,
                    m0=400.0, save_every=0.005)
    return s, run_bsr_column(s), run_dem_column(s)


@pytest.mark.parametrize("which", ["top_and_centre_figure", "trajectories_figure"])
def test_legends_hide_no_data(three_taps, which):
    """The legends sit outside the axes, so they cover none of the curves (in the three-tap
    comparison the legend used to sit on the third DEM peak)."""
    from bsrflow import plots
    s, run, dem = three_taps
    fig = getattr(plots, which)(run, dem, "three taps")
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    for ax in fig.axes:
        legend = ax.get_legend()
        assert legend is not None
        box, frame = legend.get_window_extent(renderer), ax.get_window_extent(renderer)
        assert not box.overlaps(frame), (which, box, frame)
        assert box.y1 <= frame.y0                                    # below the axes
    plt.close(fig)
