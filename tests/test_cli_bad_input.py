"""Bad input found by an audit of the command line (2026-12-04): each is refused before any work
with one line naming the option, exit code 2."""

from __future__ import annotations

from pathlib import Path

import pytest

from bsrflow.cli import main

DUMP = Path(__file__).resolve().parents[1] / "reference" / "liggghts_column" / "results" / "d22mm_a0.75.dump.gz"


def _refused(capsys, argv, *texts):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    for text in texts:
        assert text in err, err
    return err


@pytest.mark.parametrize("argv, name", [
    (["compare", "--json", ""], "--json"),
    (["compare", "--figures", " "], "--figures"),
    (["energy", "--calibration", ""], "--calibration"),
    (["stability", "--json", ""], "--json"),
    (["sweep", "--param", "a_over_d=0.5,1", "--scheduler", "", "--out", "sweep.nc"], "--scheduler"),
    (["sweep", "--param", "a_over_d=0.5,1", "--set", "", "--out", "sweep.nc"], "--set"),
    (["run", ""], "CONFIG"),
    (["plot", ""], "FILE.nc"),
])
def test_an_empty_value_is_refused_naming_it(tmp_path, monkeypatch, capsys, argv, name):
    """An empty string was taken as "not given" (``--json ""`` ran and wrote nothing) or gave a
    message naming nothing (``run ""``: ": no such config file")."""
    monkeypatch.chdir(tmp_path)
    _refused(capsys, argv, f"{name} is empty")
    assert list(tmp_path.iterdir()) == []


def test_a_folder_as_the_configuration_is_refused(tmp_path, capsys):
    """sweep and compare-dump read their CONFIG through the setup source: a folder gave exit 1 and
    a raw ``[Errno 21]``."""
    _refused(capsys, ["sweep", str(tmp_path), "--param", "a_over_d=0.5,1", "--out", str(tmp_path / "s.nc")],
             "is a directory, not a configuration file")
    _refused(capsys, ["compare-dump", str(DUMP), "--dt", "8.848e-7", "--config", str(tmp_path)],
             "is a directory, not a configuration file")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("option, value, text", [
    ("--m0", "-1", "[1e-12, 1e+12] kg"), ("--m0", "nan", "[1e-12, 1e+12] kg"), ("--eps", "1", "[0, 1)"),
    ("--scheme", "bogus", "valid values"),
])
def test_compare_dump_names_a_seed_option_out_of_range(capsys, option, value, text):
    """With the seed kernel (the default) a bad --m0 / --eps / --scheme was refused as "an option
    of the seed kernel only" (the packing kernel's refusal): now its own range, under its own name."""
    err = _refused(capsys, ["compare-dump", str(DUMP), "--dt", "8.848e-7", "--kernel", "seed", option, value],
                   f"{option}: ", text)
    assert "seed kernel only" not in err
    # with the packing kernel the seed's options are still refused as such
    _refused(capsys, ["compare-dump", str(DUMP), "--dt", "8.848e-7", "--kernel", "packing", "--m0", "1"],
             "--m0 is an option of the seed kernel only")


def test_compare_dump_names_a_time_step_that_puts_the_run_out_of_range(capsys):
    """--dt 1e300 was refused as ``run.t_end`` (derived from it)."""
    _refused(capsys, ["compare-dump", str(DUMP), "--dt", "1e300"], "--dt 1e+300", "1e5 s")


def test_compare_dump_refuses_a_name_that_hides_its_figures(tmp_path, capsys):
    """--name . wrote ``._density.png`` and the like."""
    _refused(capsys, ["compare-dump", str(DUMP), "--dt", "8.848e-7", "--name", ".", "--figures", str(tmp_path / "f")],
             "--name '.'", "not starting with '.'")
    assert not (tmp_path / "f").exists()


def test_a_tiny_courant_number_is_refused_before_the_run(tmp_path, capsys):
    """numerics.cfl = 1e-300 ran 16 s before the step collapsed (exit 3): now [0.001, limit], as the
    packing kernel had it."""
    cfg = tmp_path / "col.toml"
    assert main(["init", str(cfg)]) == 0
    capsys.readouterr()
    _refused(capsys, ["run", str(cfg), "--set", "cfl=1e-300", "--out", str(tmp_path / "o.nc")],
             "numerics.cfl", "[0.001, 4]")
    assert not (tmp_path / "o.nc").exists()


def test_an_integer_far_out_of_range_gets_no_hint_to_write_it(tmp_path, capsys):
    """``n_spheres = 1e300`` suggested writing the 301-digit integer, itself out of range."""
    cfg = tmp_path / "col.toml"
    assert main(["init", str(cfg)]) == 0
    capsys.readouterr()
    err = _refused(capsys, ["run", str(cfg), "--set", "n_spheres=1e300", "--out", str(tmp_path / "o.nc")],
                   "column.n_spheres", "[2, 100000]")
    assert "write" not in err
    _refused(capsys, ["run", str(cfg), "--set", "n_spheres=20.0", "--out", str(tmp_path / "o.nc")], "(write 20)")


def test_sweep_refuses_a_fixed_restitution_for_the_seed_kernel(tmp_path, capsys):
    """``--param restitution`` was refused for the seed kernel (its continuum does not use e), but
    ``--set restitution=0.5`` ran the sweep and recorded it."""
    _refused(capsys, ["sweep", "--param", "a_over_d=0.5,1", "--set", "restitution=0.5", "--out",
                      str(tmp_path / "s.nc")], "--set restitution", "does not use it")
    assert not (tmp_path / "s.nc").exists()


@pytest.mark.parametrize("command", ["compare", "demo"])
def test_a_diameter_the_dem_cannot_tap_is_refused_before_the_runs(tmp_path, capsys, command):
    """--diameter 10 (inside ColumnSetup's [1e-06, 10] m) ran, then the DEM stopped at its first
    tap (an overlap past d/2, exit 3): now the range at these settings, before any run."""
    argv = [command, "--diameter", "10"] + (["--out", str(tmp_path / "demo")] if command == "demo" else [])
    _refused(capsys, argv, "--diameter", "[1e-06, 0.701] m")
    assert not (tmp_path / "demo").exists()


def test_init_force_replaces_only_a_config(tmp_path, capsys):
    """``init PATH --force`` overwrote any file (an audit, as root, overwrote /etc/passwd): it now
    replaces an empty file or a bsrflow config only."""
    other = tmp_path / "notes.txt"
    other.write_text("root:x:0:0:root:/root:/bin/bash\n")
    _refused(capsys, ["init", str(other), "--force"], "is not a bsrflow config")
    assert other.read_text() == "root:x:0:0:root:/root:/bin/bash\n"
    cfg = tmp_path / "col.toml"
    for text in ("", '[layer]\nkind = "packing_bed"\n', "[run]\nt_end = 0.5\n"):
        cfg.write_text(text)
        assert main(["init", str(cfg), "--force"]) == 0
        assert "[column]" in cfg.read_text()


@pytest.mark.parametrize("argv, line", [
    (["compare-bed", "--cells", "abc"], "bsrflow compare-bed: error: --cells 'abc' is not an integer; valid range: [4, 1000]"),
    (["compare-bed", "--cells=1e3"], "bsrflow compare-bed: error: --cells '1e3' is not an integer; valid range: [4, 1000]"),
    (["compare-bed", "--eulerian", "x"], "bsrflow compare-bed: error: --eulerian 'x' is not an integer; valid range: {1, 2, 3}"),
    (["compare-bed", "--eulerian", "2", "--eulerian-perturbation", "1%"],
     "bsrflow compare-bed: error: --eulerian-perturbation '1%' is not a number; valid range: [0, 0.05]"),
    (["compare-bed", "--gammas", "3", "x"], "bsrflow compare-bed: error: --gammas 'x' is not a number; valid range: "
                                           "the LIGGGHTS runs' Γ, 1.5 to 8"),
    (["compare", "--ppd", "ten"], "bsrflow compare: error: --ppd 'ten' is not an integer; valid range: integers in "
                                  "[2, 1000]"),
    (["demo", "--diameter", "2cm"], "bsrflow demo: error: --diameter '2cm' is not a number; valid range: [1e-06, 10] m"),
    (["compare-dump", "x.dump", "--n-spheres", "many"],
     "bsrflow compare-dump: error: --n-spheres 'many' is not an integer; valid range: [2, 100000] (integers)"),
    (["compare-dump", "x.dump", "--dt", "1ms"], "bsrflow compare-dump: error: --dt '1ms' is not a number; valid range: "
                                                "(0, inf) s"),
    (["sweep", "--workers", "1.5"], "bsrflow sweep: error: --workers '1.5' is not an integer; valid range: [1, "),
])
def test_a_number_that_does_not_parse_names_the_valid_range(tmp_path, monkeypatch, capsys, argv, line):
    """argparse said only "argument --cells: invalid int value: 'abc'" (a fuzzing review): now the
    option's valid range too, one line, exit 2, before any work."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exc:              # argparse's refusal
        main(argv)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith(line), err
    assert list(tmp_path.iterdir()) == []


def test_every_numeric_option_states_its_range():
    """Every int / float option of every command is a ``Number`` (its range for a value that does
    not parse) or has choices; the range of a parsed value is still the command's check."""
    import argparse

    from bsrflow.cli import Number, build_parser
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    for name, parser in sub.choices.items():
        for action in parser._actions:
            if action.type in (int, float):
                assert action.choices is not None, (name, action.option_strings)
            if isinstance(action.type, Number):
                assert action.type.valid.strip(), (name, action.option_strings)


def test_a_parsed_value_out_of_range_is_still_the_commands_check(capsys):
    _refused(capsys, ["compare-bed", "--cells", "0"], "--cells 0 is outside the valid range [4, 1000]")
