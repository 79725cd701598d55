"""`bsrflow compare-bed` refuses a bad --reference folder or option before any work: one line on
stderr naming the option (and the file, relative to the reference folder) and what is expected,
exit 2, no banner, no --figures folder, no JSON (a fuzzing review, 2026-12: V04, V05, V06, V10,
V14).  The damaged folders are symlinks to the committed data with the damaged file written in."""

import os
from pathlib import Path

import pytest

from bsrflow.analysis.compare_bed import REFERENCE, check_eulerian_options, check_reference, reference_bed
from bsrflow.cli import main

RUN = "gamma_3.00_N2000_L13d"
"""The main LIGGGHTS run at Γ = 3, the one `--gammas 3` reads."""


def damaged_reference(tmp_path, top=None, run=(), results=True, run_name=RUN) -> Path:
    """A reference folder of symlinks to the committed one: ``top`` {name: text or None (left out)}
    replaces files at the top, ``run`` {name: text or None} files of the run ``run_name`` (None:
    the run folder left out); ``results``: False leaves results/ empty, "file" makes it a plain
    file."""
    ref = tmp_path / "ref"
    ref.mkdir()
    for p in REFERENCE.iterdir():
        if p.name in ("results", "work") or p.name in (top or {}):
            continue
        os.symlink(p, ref / p.name)
    for name, text in (top or {}).items():
        if text is not None:
            (ref / name).write_text(text)
    if results == "file":
        (ref / "results").write_text("not a folder\n")
        return ref
    (ref / "results").mkdir()
    if not results:
        return ref
    for p in (REFERENCE / "results").iterdir():
        if p.name != run_name or run == ():
            os.symlink(p, ref / "results" / p.name)
    if run is None or run == ():
        return ref
    (ref / "results" / run_name).mkdir()
    for p in (REFERENCE / "results" / run_name).iterdir():
        if p.name not in run:
            os.symlink(p, ref / "results" / run_name / p.name)
    for name, text in run.items():
        if text is not None:
            (ref / "results" / run_name / name).write_text(text)
    return ref


def refused(capsys, tmp_path, argv, *texts):
    """Runs compare-bed with --json and --figures in tmp_path: exit 2, one line on stderr holding
    every text, nothing on stdout (no banner), neither output written."""
    figs, out = tmp_path / "figs", tmp_path / "out.json"
    assert main(["compare-bed"] + argv + ["--json", str(out), "--figures", str(figs)]) == 2
    got = capsys.readouterr()
    lines = got.err.strip().splitlines()
    assert len(lines) == 1, got.err
    assert lines[0].startswith("bsrflow compare-bed: error: ")
    for text in texts:
        assert text in lines[0], lines[0]
    assert got.out == ""
    assert not figs.exists() and not out.exists()
    return lines[0]


def _trajectory_rows(n=3):
    lines = (REFERENCE / "results" / RUN / "trajectory.csv").read_text().splitlines(keepends=True)
    return lines[:2 + n]


# V04: a reference without the runs the command compares with (it gave "LIGGGHTS nan ms", exit 0)
@pytest.mark.parametrize("kind, text", [
    ("results_empty", f"no results/{RUN}/ there (the main LIGGGHTS run at Γ = 3"),
    ("results_file", "results is not a folder"),
    ("run_missing", f"no results/{RUN}/ there"),
    ("trajectory_missing", f"no results/{RUN}/trajectory.csv there"),
    ("summary_missing", f"no results/{RUN}/summary.json there"),
])
def test_a_reference_without_the_run_is_refused(kind, text, tmp_path, capsys):
    ref = damaged_reference(tmp_path, **{
        "results_empty": {"results": False}, "results_file": {"results": "file"}, "run_missing": {"run": None},
        "trajectory_missing": {"run": {"trajectory.csv": None}}, "summary_missing": {"run": {"summary.json": None}},
    }[kind])
    refused(capsys, tmp_path, ["--reference", str(ref), "--gammas", "3", "--no-extra"], f"--reference {ref}: ", text)


# V05: a damaged file of the run (refused after the banner and the continuum run, some naming no file)
@pytest.mark.parametrize("run, text", [
    ({"summary.json": "{bad"}, f"results/{RUN}/summary.json is not JSON (Expecting property name"),
    ({"summary.json": "[1, 2]"}, f"results/{RUN}/summary.json is not a JSON object"),
    ({"summary.json": '{"flight_time_per_cycle_s": [0.02]}'}, f"results/{RUN}/summary.json has no key 'n'"),
    ({"summary.json": '{"flight_time_per_cycle_s": [null], "n": 2000, "com_rel_mean_over_d": 5, '
                      '"top99_rel_max_over_d": 14, "wall_time_s": 1}'},
     f"results/{RUN}/summary.json: flight_time_per_cycle_s is [null], expected a list"),
    ({"summary.json": '{"flight_time_per_cycle_s": [0.02], "n": 2000, "com_rel_mean_over_d": NaN, '
                      '"top99_rel_max_over_d": 14, "wall_time_s": 1}'},
     f"results/{RUN}/summary.json: com_rel_mean_over_d is NaN, expected a finite number"),
    ({"flights.csv": "# c\nx,y\n1,2\n"}, f"results/{RUN}/flights.csv has no column t_takeoff_s (its header, "
                                         "line 2: 'x,y'; expected a comment line, then a header naming t_takeoff_s"),
    ({"temperature.csv": "# c\nx,y\n1,2\n"}, f"results/{RUN}/temperature.csv has no column phase_cycles"),
    ({"trajectory.csv": ""}, f"results/{RUN}/trajectory.csv is empty (expected a comment line, then a header naming "
                             "t_s, com_rel_m"),
    ({"floor_force.csv": ""}, f"results/{RUN}/floor_force.csv is empty"),
    ({"floor_force.csv": "# c\nt_s,z_floor_m,F_floor_N\n"},
     f"results/{RUN}/floor_force.csv has no rows under its header"),
    ({"floor_force.csv": "# c\nt_s,z_floor_m,F_floor_N\n0.0,0,1.5\n0.001,0,abc\n"},
     f"results/{RUN}/floor_force.csv line 4: F_floor_N = 'abc' is not a finite number"),
    ({"trajectory.csv": "".join(_trajectory_rows()) + "1,2,3\n"},
     f"results/{RUN}/trajectory.csv is not a CSV of the LIGGGHTS data folder"),
])
def test_a_damaged_run_file_is_refused_before_the_work(run, text, tmp_path, capsys):
    ref = damaged_reference(tmp_path, run=run)
    refused(capsys, tmp_path, ["--reference", str(ref), "--gammas", "3", "--no-extra"], f"--reference {ref}: ", text)


def test_figures_need_the_profiles_columns(tmp_path, capsys):
    """The files only the figures read are checked when --figures is given (and only then)."""
    ref = damaged_reference(tmp_path, run={"profiles.csv": "# c\nz_rel_over_d,phi_phase0\n0,0.5\n"})
    refused(capsys, tmp_path, ["--reference", str(ref), "--gammas", "3", "--no-extra"],
            f"results/{RUN}/profiles.csv has no column phi_phase_pi2")
    check_reference(ref, [3.0], include_extra=False, figures=False)         # not read without --figures


def test_a_damaged_run_taken_where_present_is_refused_too(tmp_path, capsys):
    """Without --no-extra, a run that compare-bed takes where present (the spring-dashpot bed) is
    checked as well, before any run."""
    ref = damaged_reference(tmp_path, run={"summary.json": "{"}, run_name="gamma_3.00_N2000_L13d_hooke")
    refused(capsys, tmp_path, ["--reference", str(ref), "--gammas", "3"],
            "results/gamma_3.00_N2000_L13d_hooke/summary.json is not JSON")


# V06: a bad Γ in the reference's CSVs blamed `gamma` or --gammas, not the file
@pytest.mark.parametrize("value, argv", [("nan", ["--no-extra"]), ("abc", ["--gammas", "3", "--no-extra"]),
                                         ("abc", ["--no-extra"]), ("25", ["--gammas", "2", "--no-extra"])])
def test_a_bad_gamma_in_the_reference_csv_names_the_file(value, argv, tmp_path, capsys):
    text = (REFERENCE / "flight_vs_gamma.csv").read_text().replace("\n3.00,", f"\n{value},")
    ref = damaged_reference(tmp_path, top={"flight_vs_gamma.csv": text})
    line = refused(capsys, tmp_path, ["--reference", str(ref)] + argv,
                   f"--reference {ref}: flight_vs_gamma.csv line 6: gamma = ")
    assert "--gammas" not in line
    assert (f"gamma = '{value}' is not a number in the valid range [0, 20]" in line if value != "25"
            else "gamma = 25.0 is outside the valid range [0, 20]" in line)


def test_a_bad_gamma_of_the_extra_runs_names_its_file(tmp_path, capsys):
    text = (REFERENCE / "flight_vs_gamma_e0.5.csv").read_text().replace("\n3.25,", "\nabc,")
    ref = damaged_reference(tmp_path, top={"flight_vs_gamma_e0.5.csv": text})
    refused(capsys, tmp_path, ["--reference", str(ref), "--gammas", "3"],
            "flight_vs_gamma_e0.5.csv line 4: gamma = 'abc' is not a finite number")


# V10: the Eulerian grid's cost check named --eulerian-cells-per-d (not given) with an empty range
@pytest.mark.parametrize("argv, text, bound", [
    ([], "--eulerian-lateral-cells 256 is outside the valid range at these settings, integers in [2, ", 124),
    (["--eulerian-cells-per-d", "1"], "--eulerian-lateral-cells 256 is outside the valid range at these settings, "
                                      "integers in [2, ", 210),
    (["--eulerian-cells-per-d", "64"], "--eulerian-lateral-cells 256 is outside the valid range at these settings, "
                                       "integers in [2, ", 18),
])
def test_eulerian_cost_names_the_option_that_mends_it(argv, text, bound, tmp_path, capsys):
    line = refused(capsys, tmp_path, ["--eulerian", "3", "--eulerian-lateral-cells", "256", "--gammas", "3",
                                      "--no-extra"] + argv, text + f"{bound}] with the other options as given")
    assert "none fits" not in line
    # the stated range holds: its top fits, one more does not
    base = reference_bed(REFERENCE)[2].with_(gamma=3.0)
    cells_per_d = int(argv[1]) if argv else 4
    given = {"dimension", "lateral_cells"} | ({"cells_per_d"} if argv else set())
    grid = {"dim": 3, "cells_per_d": cells_per_d, "perturbation": 0.0}
    check_eulerian_options(base, {**grid, "lateral_cells": bound}, given)
    with pytest.raises(ValueError, match="is outside the valid range at these settings, integers in"):
        check_eulerian_options(base, {**grid, "lateral_cells": bound + 1}, given)


def test_eulerian_cells_per_d_keeps_its_own_range_when_it_has_one(tmp_path, capsys):
    refused(capsys, tmp_path, ["--eulerian", "3", "--eulerian-lateral-cells", "100", "--eulerian-cells-per-d", "8",
                               "--no-extra"],
            "--eulerian-cells-per-d 8 is outside the valid range at these settings, integers in [1, 3]")


# V14: --gammas without a value said "expected at least one argument", with no valid values
def test_gammas_without_a_value_states_the_references_gammas(tmp_path, capsys):
    refused(capsys, tmp_path, ["--gammas", "--no-extra"],
            "--gammas needs at least one value: the LIGGGHTS runs' Γ, 1.5, 2, 2.5, 3, 3.5, 4, 4.5, 5, 5.5, 6, 6.5, 7, "
            "7.5, 8")


@pytest.mark.parametrize("kw", [{}, {"figures": True}, {"gammas": [3.0], "include_extra": False, "figures": True}])
def test_the_committed_reference_passes_the_checks(kw):
    """Every file of the committed data that any comparison reads passes (symlinked folders too)."""
    check_reference(REFERENCE, **kw)


def test_a_period_doubling_estimate_that_is_not_a_number_is_refused_up_front(capsys, tmp_path):
    """{"estimate": "none"} in params.json passed the check and ended the command after every run
    with "Unknown format code 'g'" naming no file (a review)."""
    import json
    params = json.loads((REFERENCE / "params.json").read_text())
    params["period_doubling_gamma"] = {"estimate": "none"}
    ref = damaged_reference(tmp_path, top={"params.json": json.dumps(params)})
    refused(capsys, tmp_path, ["--reference", str(ref), "--gammas", "3", "--no-extra"],
            "--reference", "params.json: period_doubling_gamma is", "expected an object")


@pytest.mark.parametrize("text, expected", [
    ("# c\nphase,measured_loss_W\n0.0,0.1\n0.025,abc\n",
     f"results/{RUN}/floor_loss_by_phase.csv line 4: measured_loss_W = 'abc' is not a finite number"),
    ("# c\nphase,measured_loss_W\n0.0,0.1\n0.025,0.2\n",
     f"results/{RUN}/floor_loss_by_phase.csv has 2 rows, expected 40"),
])
def test_a_damaged_floor_loss_file_is_refused_before_the_work(text, expected, tmp_path, capsys):
    """The sphere–floor contacts' measured loss (floor_loss_by_phase.csv, which the energy budget
    subtracts) is checked as the run's other files: a bad value or another number of phase bins is
    refused up front (a review found NaN in the JSON with exit 0, and a short file dropped the keys
    without a word)."""
    ref = damaged_reference(tmp_path, run={"floor_loss_by_phase.csv": text})
    refused(capsys, tmp_path, ["--reference", str(ref), "--gammas", "3", "--no-extra"], f"--reference {ref}: ",
            expected)


@pytest.mark.parametrize("settled, expected", [
    ('{"phi_interior_cg": 1.5, "Z_mean_pairs": 4.9}', "settled_N2000_L13d_K200000.json: not the settled bed's statistics"),
    ('{"Z_mean_pairs": 4.9}', "settled_N2000_L13d_K200000.json: not the settled bed's statistics (KeyError"),
    ("{", "settled_N2000_L13d_K200000.json: not the settled bed's statistics"),
])
def test_the_stiffer_beds_inputs_are_checked_up_front(settled, expected, tmp_path, capsys):
    """Without --no-extra the bed of four times the stiffness is checked before any run: its run's
    files as every run's taken where present, and its settled bed's φ_c and Z (out of range, missing
    or not JSON: one line naming --reference and the file)."""
    ref = damaged_reference(tmp_path, top={"settled_N2000_L13d_K200000.json": settled})
    refused(capsys, tmp_path, ["--reference", str(ref), "--gammas", "3"], f"--reference {ref}: ", expected)
    (tmp_path / "b").mkdir()
    ref2 = damaged_reference(tmp_path / "b", run={"flights.csv": "# c\nx,y\n1,2\n"},
                             run_name="gamma_3.00_N2000_L13d_K200000")
    refused(capsys, tmp_path / "b", ["--reference", str(ref2), "--gammas", "3"],
            "results/gamma_3.00_N2000_L13d_K200000/flights.csv has no column t_takeoff_s")


def test_a_floor_loss_the_run_cannot_take_is_refused(tmp_path, capsys):
    """--floor-loss: one of the closures (argparse's one line, exit 2), and floor_reaction not with
    --eulerian (the Eulerian grid has only the kinetic pressure's floor loss)."""
    refused(capsys, tmp_path, ["--floor-loss", "floor_reaction", "--eulerian", "1", "--gammas", "3", "--no-extra"],
            "--floor-loss floor_reaction is an option of the Lagrangian cells", "kinetic_pressure")
    with pytest.raises(SystemExit) as info:
        main(["compare-bed", "--floor-loss", "reaction", "--gammas", "3", "--no-extra"])
    assert info.value.code == 2
    got = capsys.readouterr()
    assert got.out == "" and got.err.count("\n") == 1
    assert "--floor-loss" in got.err and "'kinetic_pressure', 'floor_reaction'" in got.err
