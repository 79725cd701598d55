"""Bad input in a layer config (`bsrflow run CONFIG.toml` with a `[layer]` table) is one line,
exit code 2, naming the field as the config writes it (`layer.<field>`) and its valid range,
refused before any work starts and without a file written (an audit's findings, 2026-12: huge
sizes gave tracebacks or a cell count wrapped around in int64, errors named another field or an
empty range, type errors gave no range, `domain_height = 0` ran, `settle_time = 1e300` ran)."""

import dataclasses
import re

import pytest

from bsrflow.cli import main
from bsrflow.io.config import ConfigError
from bsrflow.io.layer_runner import KINDS, LayerJob, _RANGES, _kind_classes, load_layer_config

AT_SETTINGS = re.compile(r"valid range at these settings, (?:integers in )?([\[(])([^,\]]+), ([^\])]+)[\])]")


def refused(tmp_path, capsys, text):
    """Run the config ``text``; assert exit 2, one line, no traceback, no output; return the line."""
    cfg = tmp_path / "bad.toml"
    cfg.write_text(text)
    out = tmp_path / "o" / "bad.nc"
    out.parent.mkdir(exist_ok=True)
    assert main(["run", str(cfg), "--quiet", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert list(out.parent.iterdir()) == []         # no output, no checkpoint, no VTK folder
    return err


def stated_range(err):
    """(lo, hi) of the "valid range at these settings, [lo, hi]" of ``err``, checked non-empty."""
    m = AT_SETTINGS.search(err)
    assert m, err
    lo, hi = float(m.group(2)), float(m.group(3))
    assert 0.0 <= lo <= hi < float("inf"), err
    return lo, hi


def loads(tmp_path, text):
    cfg = tmp_path / "ok.toml"
    cfg.write_text(text)
    return load_layer_config(cfg)


# -- 1. sizes: computed in Python numbers, refused before anything is allocated ------------------------

@pytest.mark.parametrize("kind", ["packing_bed", "tapped_layer", "vibrated_box"])
@pytest.mark.parametrize("width", ["1e300", "1e10", "1e7"])
def test_a_huge_box_names_box_width_and_its_range(kind, width, tmp_path, capsys):
    err = refused(tmp_path, capsys, f'[layer]\nkind = "{kind}"\nbox_width = {width}\n')
    assert err.startswith("bsrflow run: error: layer.box_width: ") and "cells" in err
    lo, hi = stated_range(err)
    assert hi < 10.0
    # the upper end of the stated range is accepted, one cell more is refused
    dx = float(re.search(r"Δx = ([0-9.e+-]+) m", err).group(1))
    assert loads(tmp_path, f'[layer]\nkind = "{kind}"\nbox_width = {hi!r}\n').setup.box_width == hi
    with pytest.raises(ConfigError, match="layer.box_width"):
        loads(tmp_path, f'[layer]\nkind = "{kind}"\nbox_width = {round(hi / dx + 1) * dx!r}\n')


def test_the_stated_cell_count_grows_with_the_box(tmp_path, capsys):
    counts = []
    for width in ("1e7", "1e8", "1e9"):
        err = refused(tmp_path, capsys, f'[layer]\nkind = "packing_bed"\nbox_width = {width}\n')
        counts.append(float(re.search(r"the grid would have ([0-9.e+]+) cells", err).group(1)))
    assert counts[1] == pytest.approx(100 * counts[0], rel=1e-2)      # 3-D: the box squared
    assert counts[2] == pytest.approx(100 * counts[1], rel=1e-2)


@pytest.mark.parametrize("text, field", [
    ('kind = "packing_bed"\nbed_height = 1e300', "bed_height"),
    ('kind = "packing_bed"\ncells_per_diameter = 100000', "cells_per_diameter"),
    ('kind = "packing_bed"\ndiameter = 1e-9', "diameter"),
    ('kind = "packing_bed"\ndomain_height = 1e10', "domain_height"),
    ('kind = "packing_bed"\ngamma = 1e100', "gamma"),
    ('kind = "packing_bed"\nfrequency = 0.001', "frequency"),
    ('kind = "tapped_layer"\nlayer_height = 1e300', "layer_height"),
    ('kind = "tapped_layer"\ndomain_height = 1e300', "domain_height"),
    ('kind = "vibrated_box"\namplitude = 1e100', "amplitude"),
    # a tall, narrow layer: the grid fits, the dense solve of its rest state (828 GiB) did not
    ('kind = "tapped_layer"\ndim = 2\nbox_width = 0.012\nlayer_height = 1000.0', "layer_height"),
])
def test_a_grid_too_large_names_the_field_that_sets_it(text, field, tmp_path, capsys):
    err = refused(tmp_path, capsys, f"[layer]\n{text}\n")
    assert err.startswith(f"bsrflow run: error: layer.{field}: "), err
    stated_range(err)


def test_a_packing_box_narrower_than_three_cells_names_box_width(tmp_path, capsys):
    err = refused(tmp_path, capsys, '[layer]\nkind = "packing_bed"\nbox_width = 0.0025\n')
    assert err.startswith("bsrflow run: error: layer.box_width: 0.0025 m is outside")
    assert stated_range(err)[0] == pytest.approx(0.00375)


@pytest.mark.parametrize("kind", ["tapped_layer", "vibrated_box"])
def test_a_field_outside_its_own_range_is_named_before_the_grid_size(kind, tmp_path, capsys):
    """gravity = 1e-9 raises the energy bound's domain height past any grid; the message blamed the
    grid's size without naming gravity (a fuzzing review's note, mended 2026-12-05)."""
    err = refused(tmp_path, capsys, f'[layer]\nkind = "{kind}"\ngravity = 1e-9\n')
    assert err == "bsrflow run: error: layer.gravity: gravity = 1e-09 is outside the valid range [0.001, 10000] m/s^2"


@pytest.mark.parametrize("dim", [2, 3])
def test_a_box_under_three_cells_that_no_box_mends_is_not_given_a_range(dim, tmp_path, capsys):
    """box_width = 1e-7 m with cells_per_diameter = 100000: the box is 2 cells of 5e-8 m, and at 3
    cells the grid (3-D) or the number of steps (2-D) is too large. The message gave
    cells_per_diameter (then box_width) a range that the other check refused; it now says that both
    must change (a fuzzing review's note, mended 2026-12-05)."""
    text = f'[layer]\nkind = "packing_bed"\ndim = {dim}\ncells_per_diameter = 100000\nbox_width = 1e-7\n'
    err = refused(tmp_path, capsys, text)
    assert err.startswith("bsrflow run: error: layer: box_width = 1e-07 m is less than 3 cells of Δx = diameter / "
                          "cells_per_diameter = 5e-08 m, and at 3 cells the "), err
    assert err.endswith("lower cells_per_diameter and keep box_width >= 3 diameter / cells_per_diameter")
    assert ("grid would have" if dim == 3 else "time steps") in err
    with pytest.raises(ConfigError):                 # the box at 3 cells alone does not mend it
        loads(tmp_path, text.replace("1e-7", "1.5e-7"))


def test_a_box_under_three_cells_states_a_range_whose_ends_load(tmp_path, capsys):
    text = '[layer]\nkind = "packing_bed"\ncells_per_diameter = 10\nbox_width = 1e-7\n'
    err = refused(tmp_path, capsys, text)
    assert err.startswith("bsrflow run: error: layer.box_width: 1e-07 m is outside the valid range at these "
                          "settings, [0.0015, "), err
    lo, hi = stated_range(err)
    for width in (lo, hi):
        assert loads(tmp_path, text.replace("1e-7", repr(width)))


# -- 2. the field the user set, with a non-empty range ----------------------------------------------

@pytest.mark.parametrize("text, field", [
    ('kind = "packing_bed"\nt_end = 1e300', "t_end"),
    ('kind = "packing_bed"\nt_end = 1e5', "t_end"),
    ('kind = "packing_bed"\nt_end = 1e5\nstiffness = 1e4', "t_end"),    # no stiffness would do
    ('kind = "packing_bed"\nbed_height = 1e300', "bed_height"),
    ('kind = "packing_bed"\ngravity = 1e300', "gravity"),
    ('kind = "packing_bed"\ngravity = 1e5', "gravity"),
    ('kind = "packing_bed"\ndiameter = 1e300', "diameter"),
    ('kind = "packing_bed"\ndiameter = 0.04', "diameter"),
    ('kind = "packing_bed"\ndim = 2\nbed_height = 60.0\ncells_per_diameter = 1', "bed_height"),   # overlap
    ('kind = "packing_bed"\nstiffness_factor = 1e-9', "stiffness_factor"),
    ('kind = "packing_bed"\ncfl = 1e-9', "cfl"),
    ('kind = "tapped_layer"\ndiameter = 1e300', "diameter"),
])
def test_errors_name_the_field_the_config_sets(text, field, tmp_path, capsys):
    err = refused(tmp_path, capsys, f"[layer]\n{text}\n")
    assert err.startswith(f"bsrflow run: error: layer.{field}: "), err
    assert "stiffness = 50000.0 N/m is outside" not in err
    stated_range(err)


@pytest.mark.parametrize("text", [
    'dim = 2\ncells_per_diameter = 100000\nbox_width = 0.02',
    'cells_per_diameter = 100000\nbox_width = 0.02\nbed_height = 0.01',
])
def test_a_packing_grid_too_large_names_the_field_far_off_its_default(text, tmp_path, capsys):
    """cells_per_diameter = 100000 with the box at its default blamed box_width (a fuzzing review:
    "box_width: 0.02 m is outside the valid range at these settings, [1.5e-07, 3.5e-07] m"): the
    given field furthest from its default is named, with its range, and its upper end runs."""
    err = refused(tmp_path, capsys, f'[layer]\nkind = "packing_bed"\n{text}\n')
    assert err.startswith("bsrflow run: error: layer.cells_per_diameter: 100000 is outside the valid range at these "
                          "settings, integers in [1, "), err
    assert "box_width" not in err
    _, hi = stated_range(err)
    assert loads(tmp_path, f'[layer]\nkind = "packing_bed"\n{text.replace("100000", str(int(hi)))}\n')


def test_an_eulerian_bed_names_lateral_cells_not_the_cells_per_d_it_does_not_give(tmp_path, capsys):
    """lateral_cells (default None: 4 in 2-D / 3-D) was not re-blamed, so the message named
    cells_per_d, which the config does not give, with no range (a fuzzing review)."""
    text = '[layer]\nkind = "granular_bed_eulerian"\ndimension = 3\nlateral_cells = {}\n'
    err = refused(tmp_path, capsys, text.format(256))
    m = re.match(r"bsrflow run: error: layer\.lateral_cells: lateral_cells = 256 is outside the valid range at these "
                 r"settings \(at most (\d+) with the other fields as given\): the run would take about [0-9.e+]+ "
                 r"cell-steps", err)
    assert m, err
    assert "cells_per_d = 4" not in err
    n = int(m.group(1))
    assert loads(tmp_path, text.format(n)).setup.lateral_cells == n
    with pytest.raises(ConfigError, match=r"^layer\.lateral_cells: "):
        loads(tmp_path, text.format(n + 1))


@pytest.mark.parametrize("kind, field", [
    ("granular_bed", "diameter"), ("granular_bed", "side"),
    ("granular_bed", "restitution"), ("packing_bed", "coordination"),
    ("packing_bed", "t_end"),
])
def test_a_value_that_divides_by_zero_names_the_field_and_its_bound(kind, field, tmp_path, capsys):
    """1e-300 made the bed kinds' checks divide by zero or overflow: a traceback, exit 1 (a
    fuzzing review); now the field's bound at these settings, one line, exit 2."""
    err = refused(tmp_path, capsys, f'[layer]\nkind = "{kind}"\n{field} = 1e-300\n')
    m = re.match(rf"bsrflow run: error: layer\.{field}: {field} = 1e-300 is outside the valid range at these settings "
                 r"\(at least ([0-9.e+-]+) with the other fields as given\)", err)
    assert m and float(m.group(1)) > 1e-300, err
    assert "ZeroDivisionError" in err or "OverflowError" in err


@pytest.mark.parametrize("kind", ["granular_bed", "granular_bed_eulerian", "packing_bed", "tapped_layer"])
def test_every_layer_kind_takes_the_floor_frequency_in_one_range(kind, tmp_path, capsys):
    """The floor's frequency has one range for every kind and for the motions, [1e-3, 1e4] Hz (the
    bed kinds took (0, 1e4] and the bed then refused 5e-4 Hz inside the run's setup; 1e-300
    divided by zero in their checks)."""
    for value in ("1e-300", "0.0005", "20000.0"):
        err = refused(tmp_path, capsys, f'[layer]\nkind = "{kind}"\nfrequency = {value}\n')
        assert err.startswith(f"bsrflow run: error: layer.frequency: frequency = {value} is outside the valid range "
                              "[0.001, 10000] Hz"), err


def test_the_stated_t_end_bound_is_accepted(tmp_path, capsys):
    err = refused(tmp_path, capsys, '[layer]\nkind = "packing_bed"\nt_end = 1e300\n')
    _, hi = stated_range(err)
    assert loads(tmp_path, f'[layer]\nkind = "packing_bed"\nt_end = {hi!r}\nsave_every = 1.0\n').setup.t_end == hi


def test_a_diameter_that_splits_the_box_names_diameter(tmp_path, capsys):
    for kind in ("packing_bed", "tapped_layer"):
        err = refused(tmp_path, capsys, f'[layer]\nkind = "{kind}"\ndiameter = 0.007\n')
        assert err.startswith("bsrflow run: error: layer.diameter: 0.007 m is outside the valid range"), err
        assert "whole number of cells" in err and "e.g." in err


def test_one_tap_with_a_zero_period_names_tap_period(tmp_path, capsys):
    err = refused(tmp_path, capsys, '[layer]\nkind = "tapped_layer"\ntap_period = 0\n')
    assert err.startswith("bsrflow run: error: layer.tap_period: 0 is outside the valid range (0, inf) s"), err
    err = refused(tmp_path, capsys, '[layer]\nkind = "tapped_layer"\nn_taps = 3\ntap_period = 0\n')
    assert "layer.tap_period" in err and "[0.05, inf) s" in err


def test_the_stiffness_is_still_named_when_the_config_sets_it(tmp_path, capsys):
    err = refused(tmp_path, capsys, '[layer]\nkind = "packing_bed"\nstiffness = 1e-3\n')
    assert err.startswith("bsrflow run: error: layer.stiffness: ")
    lo, hi = (float(v) for v in re.search(r"\[([0-9.e+-]+), ([0-9.e+-]+)\] N/m", err).groups())
    assert lo <= hi


# -- 3. type errors state the range --------------------------------------------------------------------

@pytest.mark.parametrize("text, words", [
    ('kind = "packing_bed"\ndiameter = nan', "layer.diameter: nan must be a finite number; valid range: (0, inf) m"),
    ('kind = "granular_bed"\nn_spheres = "abc"', "layer.n_spheres: 'abc' must be an integer; valid range: "
                                                 "integers in [1, 1e+07]"),
    ('kind = "packing_bed"\ngamma = true', "layer.gamma: True must be a finite number; valid range: [0, inf)"),
    ('kind = "tapped_layer"\ncells_per_diameter = 2.5', "valid range: integers >= 2"),
    ('kind = "vibrated_box"\nbottom_density = inf', "valid range: [1e-06, 1e+06] kg/m^n"),
    ('kind = "packing_bed"\ndomain_height = "x"', "valid range: [energy bound, inf) m (or not given"),
    ('kind = "granular_bed"\ngamma = nan', "layer.gamma: nan must be a finite number; valid range: [0, 20]"),
    ('kind = "tapped_layer"\nsides = 5', "layer.sides: 5 must be a string; valid: 'wall' or 'periodic'"),
    ('kind = "tapped_layer"\n[output]\ncheckpoint_every = "0.1"',
     "output.checkpoint_every: '0.1' must be a finite number; valid range: [0, t_end = 0.2] s"),
])
def test_type_errors_state_the_valid_range(text, words, tmp_path, capsys):
    err = refused(tmp_path, capsys, f"[layer]\n{text}\n")
    assert words in err, err


def test_an_output_table_without_a_layer_table_names_the_layer_table(tmp_path, capsys):
    (tmp_path / "c.toml").write_text("[output]\nvtk = true\n")
    assert main(["run", str(tmp_path / "c.toml"), "--out", str(tmp_path / "c.nc")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("bsrflow run: error: output: unknown table")
    assert "needs a [layer] table" in err[0]


def test_every_field_of_every_kind_has_a_stated_range():
    """Every field a kind's config takes (its class's fields but those it does not take,
    ``_NOT_OPTIONS``) has a stated range."""
    from bsrflow.io.layer_runner import _NOT_OPTIONS
    assert _NOT_OPTIONS == {"granular_bed_eulerian": ("n_cells",)}
    for kind in KINDS:
        fields = {f.name for f in dataclasses.fields(_kind_classes()[kind])} - set(_NOT_OPTIONS.get(kind, ()))
        assert fields == set(_RANGES[kind]), kind


# -- 4. domain_height = 0 -----------------------------------------------------------------------------

@pytest.mark.parametrize("kind", ["tapped_layer", "vibrated_box", "packing_bed"])
def test_a_zero_domain_height_is_refused_by_every_kind(kind, tmp_path, capsys):
    err = refused(tmp_path, capsys, f'[layer]\nkind = "{kind}"\ndomain_height = 0\n')
    assert re.search(r"error: layer\.domain_height: domain_height = 0 m is outside the valid range "
                     r"\[0\.0\d+, inf\) m \(energy bound", err), err


def test_a_domain_height_not_given_is_the_energy_bound(tmp_path):
    cfg = loads(tmp_path, '[layer]\nkind = "tapped_layer"\n')
    assert cfg.setup.domain_height is None
    assert cfg.setup.grid().upper[-1] >= cfg.setup.energy_bound_height()


# -- 5. settle_time -----------------------------------------------------------------------------------

@pytest.mark.parametrize("kind", ["packing_bed", "tapped_layer", "vibrated_box"])
@pytest.mark.parametrize("value", ["1e300", "-1.0", "2e5"])
def test_settle_time_is_bounded(kind, value, tmp_path, capsys):
    err = refused(tmp_path, capsys, f'[layer]\nkind = "{kind}"\nsettle_time = {value}\n')
    assert "error: layer.settle_time: " in err and "valid range [0, 100000] s" in err, err


def test_a_settle_time_after_t_end_is_a_settling_run_with_a_note(tmp_path):
    """Not refused (the defaults' short runs settle only, and `config_resolved` writes the
    default settle_time out), but a settle_time the config gives at or after t_end is noted."""
    text = '[layer]\nkind = "tapped_layer"\ndim = 2\nt_end = 0.03\n'
    job = LayerJob(loads(tmp_path, text), tmp_path / "a.nc")
    assert job.notes() == []                                # the default settle_time 0.1 s
    job = LayerJob(loads(tmp_path, text + "settle_time = 0.05\n"), tmp_path / "a.nc")
    assert len(job.notes()) == 1 and "layer.settle_time = 0.05 s is at or after layer.t_end = 0.03 s" in job.notes()[0]
    resolved = loads(tmp_path, text).resolved_text()
    assert loads(tmp_path, resolved).setup == loads(tmp_path, text).setup


def test_a_tap_period_with_one_tap_is_noted_not_used(tmp_path):
    text = '[layer]\nkind = "tapped_layer"\ndim = 2\nt_end = 0.3\n'
    assert LayerJob(loads(tmp_path, text + "tap_period = 0.0001\n"), tmp_path / "a.nc").notes() == [
        "note: layer.tap_period = 0.0001 s is not used: n_taps = 1 (one tap has no period)"]
    assert LayerJob(loads(tmp_path, text), tmp_path / "a.nc").notes() == []
    assert LayerJob(loads(tmp_path, text + "n_taps = 2\ntap_period = 0.1\n"), tmp_path / "a.nc").notes() == []


def test_a_box_of_exactly_the_least_cells_and_the_stated_least_height_are_accepted(tmp_path, capsys):
    """box_width = 0.009 m is 3 cells of 0.003 m, but 0.009 / 0.003 = 2.9999999999999996 was refused
    as "at least 0.009 m"; the least layer height stated was 0.01 m, itself refused (the layer's
    cells are round(H / Δx))."""
    base = 'kind = "tapped_layer"\ndim = 2\ndiameter = 0.006\ncells_per_diameter = 2\n'
    loads(tmp_path, f"[layer]\n{base}box_width = 0.009\n")
    err = refused(tmp_path, capsys, f"[layer]\n{base}layer_height = 0.0104\n")
    assert "layer.layer_height" in err and "at least 0.0105 m" in err, err
    loads(tmp_path, f"[layer]\n{base}layer_height = 0.0105\n")


# -- the bed kinds: stated ranges that hold (a fuzzing review, 2026-12-05) -------------------------

@pytest.mark.parametrize("text, field", [
    ('kind = "granular_bed"\nn_spheres = 1\nside = 100', "side"),
    ('kind = "granular_bed"\nside = 100', "side"),
    ('kind = "granular_bed_eulerian"\ndimension = 2\nn_spheres = 10000000\nside = 100', "side"),
])
def test_a_bed_too_wide_for_any_number_of_spheres_names_the_side(text, field, tmp_path, capsys):
    """n_spheres was given the empty range [485868211, 1e7]: no number of spheres makes a bed a
    diameter deep in a box of 100 m; the side is named, and the end of its range is accepted."""
    err = refused(tmp_path, capsys, f"[layer]\n{text}\n")
    assert err.startswith(f"bsrflow run: error: layer.{field}: side = 100 m is outside the valid range at these "
                          "settings, (0, "), err
    hi = float(re.search(r"\(0, ([0-9.e+-]+)\] m", err).group(1))
    assert loads(tmp_path, f"[layer]\n{text.replace('side = 100', f'side = {hi!r}')}\ncycles = 1\n")


@pytest.mark.parametrize("cells_per_d", [3, 4])
def test_the_eulerian_lid_bound_is_stated_first_and_accepted(cells_per_d, tmp_path, capsys):
    """output_height = 1e-300 was given the base's (0.04871, 100] m, and 0.0488 then refused with
    the grid's [0.05375, 100] m: the grid's bound is stated, rounded up, and accepted."""
    head = f'[layer]\nkind = "granular_bed_eulerian"\ndimension = 1\ncycles = 1\ncells_per_d = {cells_per_d}\n'
    bounds = set()
    for h in ("1e-300", "0.0488"):
        err = refused(tmp_path, capsys, f"{head}output_height = {h}\n")
        lo, hi = stated_range(err)
        bounds.add(lo)
        assert hi == 100.0 and loads(tmp_path, f"{head}output_height = {lo!r}\n")
    assert len(bounds) == 1


def test_the_stated_save_every_bound_is_accepted(tmp_path, capsys):
    """save_every = 5e-8 s, the stated lower end of [5e-08, inf) s, was refused (0.05 / 5e-8 is
    one ulp above 1e6 intervals), and the upper bound (t_end here) was not stated."""
    head = '[layer]\nkind = "granular_bed"\ncycles = 1\n'
    err = refused(tmp_path, capsys, f"{head}save_every = 1e-300\n")
    assert "valid range [5e-08, 0.05] s (at most 1000000 snapshots)" in err, err
    from bsrflow.numerics.solver import save_schedule
    assert save_schedule(0.0, 0.05, 5e-8).size == 1_000_001


@pytest.mark.parametrize("text", ['kind = "granular_bed"\ngamma = 3\ncycles = 1\nfrequency = 81.1',
                                  'kind = "tapped_layer"\nt_end = 0.0123456789'])
def test_the_stated_save_every_range_is_accepted_at_both_ends(text, tmp_path, capsys):
    """Printed to four digits, the ends were rounded outwards (1.233e-08 for 1.2330...e-08; t_end
    0.0123457 for 0.0123456789) and refused (a review): each end is rounded inwards."""
    err = refused(tmp_path, capsys, f"[layer]\n{text}\nsave_every = 1e-300\n")
    m = re.search(r"valid range \[([0-9.e+-]+), ([0-9.e+-]+)\] s", err)
    assert m, err
    for end in m.groups():
        assert loads(tmp_path, f"[layer]\n{text}\nsave_every = {end}\n")


@pytest.mark.parametrize("kind, key, name", [
    ("granular_bed_eulerian", "dim", "dimension"), ("granular_bed_eulerian", "cells_per_diameter", "cells_per_d"),
    ("packing_bed", "dimension", "dim"), ("tapped_layer", "cells_per_d", "cells_per_diameter"),
    ("packing_bed", "settle", "settle_time"), ("packing_bed", "box_widht", "box_width"),
])
def test_a_key_of_another_layer_kind_or_misspelt_names_this_kinds_key(kind, key, name, tmp_path, capsys):
    """The layer kinds name some settings differently (dim / dimension, cells_per_diameter /
    cells_per_d, settle_time / settle): the refusal names this kind's key, as it does for a typo."""
    err = refused(tmp_path, capsys, f'[layer]\nkind = "{kind}"\n{key} = 2\n')
    assert f"layer.{key}: unknown key for kind = '{kind}' (did you mean {name}?); valid: " in err, err


@pytest.mark.parametrize("kind, key, other", [
    ("granular_bed", "perturbation", "granular_bed_eulerian"), ("tapped_layer", "coordination", "packing_bed"),
    ("granular_bed_eulerian", "n_cells", "granular_bed"), ("packing_bed", "dissipation", "tapped_layer"),
])
def test_a_setting_of_another_kind_only_is_named_as_such(kind, key, other, tmp_path, capsys):
    """A setting that only another kind has is said to be that kind's, not matched to a look-alike
    of this kind (difflib offered restitution for perturbation, dissipation for coordination)."""
    err = refused(tmp_path, capsys, f'[layer]\nkind = "{kind}"\n{key} = 1\n')
    assert f"layer.{key}: unknown key for kind = '{kind}' (a key of kind = '{other}'); valid: " in err, err


@pytest.mark.parametrize("kind", KINDS)
def test_init_writes_a_commented_layer_config_of_every_kind_that_loads_to_its_defaults(kind, tmp_path, capsys):
    """`bsrflow init PATH --layer KIND` writes every field the kind's config takes with its default and,
    in a comment, the range its one-line error states; the file loads to the default scenario (the
    same resolved config as the class's defaults)."""
    from bsrflow.io.commands import _LAYER_KINDS
    from bsrflow.io.layer_runner import GRANULAR_BED_SAVE_EVERY, BED_KINDS, LayerConfig, _range_text

    assert _LAYER_KINDS == KINDS
    path = tmp_path / f"{kind}.toml"
    assert main(["init", str(path), "--layer", kind]) == 0
    text = path.read_text()
    cfg = load_layer_config(path)
    cls = _kind_classes()[kind]
    default = cls(**({"save_every": GRANULAR_BED_SAVE_EVERY} if kind in BED_KINDS else {}))
    expected = LayerConfig(setup=default, vtk=False, checkpoint_every=None, text="").resolved_text()
    assert cfg.resolved_text() == expected
    assert f"frequency = {cfg.setup.frequency!r}" in text and f"# valid: {_range_text(_RANGES[kind]['frequency'])}" in text
    assert main(["init", str(tmp_path / "x.toml"), "--layer", kind, "--kernel", "packing"]) == 2
    assert "--kernel: is not taken with --layer" in capsys.readouterr().err


def test_an_unknown_output_key_is_answered_with_the_near_one(tmp_path, capsys):
    err = refused(tmp_path, capsys, '[layer]\nkind = "tapped_layer"\n[output]\nvtkk = true\n')
    assert "output.vtkk: unknown key (did you mean vtk?); valid: vtk, checkpoint_every, state" in err, err


def test_a_field_whose_error_states_a_fixed_range_is_not_said_twice(tmp_path, capsys):
    """An error that already names the field and its range ({1, 2, 3}, "integers in [a, b]") is
    passed on as it is, not wrapped in "at these settings (at most 3 ...)" and repeated."""
    err = refused(tmp_path, capsys, '[layer]\nkind = "granular_bed_eulerian"\ndimension = 4\n')
    assert err == "bsrflow run: error: layer.dimension: dimension = 4 is outside the valid range {1, 2, 3}", err
    err = refused(tmp_path, capsys, '[layer]\nkind = "granular_bed_eulerian"\ncells_per_d = 65\n')
    assert err == "bsrflow run: error: layer.cells_per_d: cells_per_d = 65 is outside the valid range: integers in [1, 64]", err
