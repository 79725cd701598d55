"""Bad input to the commands (issue #20, "Commands"): one line, exit code 2, before any work;
`plot` warns about killed or all-NaN files; `initial_density` is linear in spheres + cells and
equal to the plain loop bit for bit.  (SIGTERM/SIGINT and default checkpoints: test_run_io.py.)"""
import json
import time

import numpy as np
import pytest

from bsrflow.cli import main


def _fail(*a, **k):
    raise AssertionError("work started before the input was checked")


def _one_line(capsys, prefix):
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    assert err[0].startswith(prefix), err[0]
    return err[0]


# -- verify --------------------------------------------------------------------------------------
def test_verify_unknown_case_lists_the_valid_names(capsys, monkeypatch):
    import bsrflow.analysis.verify as verify

    for name in ("case_example_a", "case_example_b", "case_smooth_space", "case_smooth_time"):
        monkeypatch.setattr(verify, name, _fail)
    assert main(["verify", "--case", "example_a", "--case", "nosuch"]) == 2
    line = _one_line(capsys, "bsrflow verify: error: --case 'nosuch' is not a verification case; valid names: ")
    for name in ("example_a", "example_b_unfiltered", "smooth_time_friction_kutta3", "embedding"):
        assert name in line


# -- energy --calibration --------------------------------------------------------------------------
@pytest.mark.parametrize("text, problem", [
    ('{"cases": []}', "no key 'calibration' at the top level"),
    ('{"calibration": {"m0": 410.0}}', "no key 'calibration.kernel_dissipation'"),
    ('{"calibration": [1, 2]}', "'calibration' is not an object"),
    ('{"calibration": {"m0": -1, "kernel_dissipation": 0.5}}', "calibration.m0 = -1 is outside the valid range"),
    ('{"calibration": {"m0": 400, "kernel_dissipation": "x"}}', "calibration.kernel_dissipation = 'x' is outside"),
    ("{not json", "not valid JSON (line 1, column 2: "),
    ("[1, 2", "not valid JSON (line 1, column 6: "),
    (b"\xff\xfe\x00garbage", "not a JSON text file"),
])
def test_energy_calibration_file_problems_name_the_file(tmp_path, capsys, monkeypatch, text, problem):
    import bsrflow.analysis.energy as energy

    monkeypatch.setattr(energy, "energy_study", _fail)
    path = tmp_path / "cal.json"
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    assert main(["energy", "--calibration", str(path)]) == 2
    line = _one_line(capsys, f"bsrflow energy: error: --calibration {path}: ")
    assert problem in line, line


def test_energy_calibration_missing_file_and_a_good_one(tmp_path, capsys, monkeypatch):
    import bsrflow.analysis.energy as energy

    monkeypatch.setattr(energy, "energy_study", _fail)
    assert main(["energy", "--calibration", str(tmp_path / "nope.json")]) == 2
    _one_line(capsys, f"bsrflow energy: error: --calibration {tmp_path / 'nope.json'}: no such file")
    good = tmp_path / "compare.json"
    good.write_text(json.dumps({"calibration": {"m0": 410.0, "kernel_dissipation": 0.83, "case": "x"}}))
    assert energy.read_calibration(good) == {"m0": 410.0, "kernel_dissipation": 0.83}


# -- sweep ---------------------------------------------------------------------------------------
def test_sweep_unreachable_scheduler_one_line_quickly(tmp_path, capsys, monkeypatch):
    import bsrflow.tools.sweep as sweep

    monkeypatch.setattr(sweep, "run_case", _fail)
    t0 = time.perf_counter()
    code = main(["sweep", "--param", "a_over_d=0.5,1", "--scheduler", "tcp://127.0.0.1:1",
                 "--out", str(tmp_path / "s.nc")])
    wall = time.perf_counter() - t0
    assert code == 2
    line = _one_line(capsys, "bsrflow sweep: error: --scheduler tcp://127.0.0.1:1: cannot connect")
    assert "127.0.0.1:1" in line and wall < sweep.SCHEDULER_TIMEOUT + 3
    assert not (tmp_path / "s.nc").exists()


@pytest.mark.parametrize("values, bad", [("-1,50", "a_over_d=-1"), ("0.5,1,50", "a_over_d=50")])
def test_sweep_checks_every_case_before_starting_a_cluster(tmp_path, capsys, monkeypatch, values, bad):
    import dask.distributed

    import bsrflow.tools.sweep as sweep

    monkeypatch.setattr(sweep, "run_sweep", _fail)
    monkeypatch.setattr(dask.distributed, "LocalCluster", _fail)
    monkeypatch.setattr(dask.distributed, "Client", _fail)
    assert main(["sweep", "--param", f"a_over_d={values}", "--param", "f=10,20",
                 "--out", str(tmp_path / "s.nc")]) == 2
    line = _one_line(capsys, f"bsrflow sweep: error: --param: the case {bad}, f=10 is invalid: tap.a_over_d: ")
    assert "valid range [0, 20]" in line
    assert not (tmp_path / "s.nc").exists()


# -- plot ------------------------------------------------------------------------------------------
def _file(path, rho_nan=False, status="ok"):
    from bsrflow.io.netcdf import NetCDFWriter

    x = (np.arange(20) + 0.5) * 0.01
    w = NetCDFWriter(path, x, 0.01, 2, lambda t: 0.0, {"config": "", "diameter": 0.022}, expected_snapshots=5)
    for k in range(5):
        rho = np.full(20, np.nan) if rho_nan else np.linspace(1.0, 0.0, 20)
        w(0.01 * k, np.zeros(20), rho, np.array([0.01, 0.02 + 0.001 * k]))
    if status == "running":                     # as a killed run leaves it: never closed
        w._h5.close()
    else:
        w.close(status)
    return path


@pytest.mark.parametrize("rho_nan, status, warnings", [
    (False, "ok", []),
    (False, "running", ['status "running": the run was killed (or is still going); the figures show the '
                        '5 snapshot(s) up to t = 0.04 s']),
    (False, "interrupted by SIGTERM after 5 snapshots", ["the run did not finish (status: interrupted by "
                                                          "SIGTERM after 5 snapshots); the figures show"]),
    (True, "ok", ["rho is NaN in every snapshot: the density figure is empty"]),
])
def test_plot_warns_about_a_killed_or_all_nan_file_and_still_draws(tmp_path, capsys, rho_nan, status, warnings):
    path = _file(tmp_path / "r.nc", rho_nan, status)
    assert main(["plot", str(path), "--out", str(tmp_path / "figs")]) == 0
    err = [ln for ln in capsys.readouterr().err.strip().splitlines() if ln]
    assert len(err) == len(warnings), err
    for line, w in zip(err, warnings):
        assert line.startswith(f"bsrflow plot: warning: {path}: ") and w in line, line
    assert len(list((tmp_path / "figs").glob("r_*.png"))) == 4          # drawn all the same


# -- initial_density ---------------------------------------------------------------------------------
def _loop_density(setup, x):
    """The former formula: every sphere's bump evaluated on every cell (cost spheres x cells)."""
    d, m = setup.diameter, setup.particle_mass
    rho = np.zeros_like(x, dtype=float)
    for yk in setup.sphere_centres():
        for centre in (yk, -yk):
            s = (x - centre) / d
            rho += np.where(np.abs(s) < 1.0, m / d * np.cos(0.5 * np.pi * s) ** 2, 0.0)
    return rho


@pytest.mark.parametrize("n, ppd, kw", [(2, 2, {}), (3, 4, {}), (20, 10, {}), (7, 13, {"diameter": 0.01}),
                                        (50, 3, {"m0": 400.0}), (200, 10, {"m0": 406.0})])
def test_initial_density_equals_the_loop_bit_for_bit(n, ppd, kw):
    from bsrflow.physics.column import ColumnSetup, initial_density

    s = ColumnSetup(n_spheres=n, points_per_diameter=ppd, **kw)
    x = s.grid().x
    assert np.array_equal(initial_density(s, x), _loop_density(s, x))
    xs = x[::-1].copy()                                  # not increasing: the loop itself
    assert np.array_equal(initial_density(s, xs), _loop_density(s, xs))
    assert initial_density(s, x).sum() * (x[1] - x[0]) == pytest.approx(n * s.particle_mass, rel=1e-12)


def test_initial_density_is_linear_in_spheres_plus_cells():
    """100000 spheres on a million cells: under a few seconds (the loop needed 2e11 cell
    updates, minutes to hours)."""
    from bsrflow.physics.column import ColumnSetup, initial_density

    s = ColumnSetup(n_spheres=100000, m0=406.0)
    x = s.grid().x
    assert x.size > 1_000_000
    t0 = time.perf_counter()
    rho = initial_density(s, x)
    assert time.perf_counter() - t0 < 10.0
    line = s.particle_mass / s.diameter
    inside = (x > s.diameter) & (x < (s.n_spheres - 1) * s.diameter)
    # the bumps sum to m/d inside; (x - c)/d loses digits at heights of 1e5 d (the ulp of x = 2200 m
    # is 4.5e-13 m, 2e-11 d): relative round-off up to 3e-11 there, 1e-16 near the floor
    np.testing.assert_allclose(rho[inside], line, rtol=1e-10)
    low = inside & (x < 100 * s.diameter)
    np.testing.assert_allclose(rho[low], line, rtol=1e-13)
    assert np.all(rho[x > (s.n_spheres + 0.5) * s.diameter + 1e-9] == 0.0)     # above the top bump


def test_a_closed_standard_output_ends_quietly_with_141(monkeypatch, capsys):
    """`bsrflow ... | head`: when the reader of stdout goes away the command stops with exit code
    141 (the shell's code for SIGPIPE) and no traceback."""
    import argparse

    import bsrflow.cli as cli

    def build():
        p = argparse.ArgumentParser(prog="bsrflow")
        sub = p.add_subparsers(dest="command")
        q = sub.add_parser("talk")

        def talk(args):
            print("first line")
            raise BrokenPipeError(32, "Broken pipe")
        q.set_defaults(func=talk)
        return p
    monkeypatch.setattr(cli, "build_parser", build)
    assert cli.main(["talk"]) == 141
    captured = capsys.readouterr()
    assert captured.err == "" and captured.out == "first line\n"


@pytest.mark.parametrize("argv", [["--foo"], ["run"], ["compare-bed", "--cells", "abc"],
                                  ["compare-dump", "x.dump", "--kernel", "foo"], ["compare", "--ppd", "2.5"]])
def test_argument_errors_are_one_line_exit_2(argv, capsys):
    """The parser's own errors (unknown option, missing argument, wrong type or choice) are one
    line on stderr naming the argument, exit 2, as every other bad input."""
    from bsrflow.cli import main
    try:                                   # argparse exits; words it does not know come back as 2
        rc = main(argv)
    except SystemExit as exc:
        rc = exc.code
    assert rc == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and ": error: " in err[0]


def test_packing_compare_that_stops_names_the_run_and_keeps_the_finished_cases(tmp_path, capsys, monkeypatch):
    """A continuum run that stops in `compare --kernel packing`: exit 3, the message names the case
    and the model, and --json keeps the cases finished before it with the message."""
    import json

    import bsrflow.analysis.compare_packing as cp
    from bsrflow.cli import main
    from bsrflow.numerics.solver import SimulationError

    real = cp.run_bsr_column
    calls = []

    def stop_second(setup, *a, **k):
        calls.append(setup)
        if len(calls) == 2:
            raise SimulationError("monitor stop at t = 0.5 s", None, 0.5, 0.0, "stopped")
        return real(setup.with_(t_end=0.45), *a, **k)
    monkeypatch.setattr(cp, "run_bsr_column", stop_second)
    js = tmp_path / "c.json"
    argv = ["compare", "--kernel", "packing", "--cases", "d22mm_a0.5,d22mm_a0.75", "--models", "lagrangian:0",
            "--json", str(js)]
    assert main(argv) == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "case d22mm_a0.75, lagrangian local: monitor stop" in err[0]
    kept = json.loads(js.read_text())
    assert [c["name"] for c in kept["cases"]] == ["d22mm_a0.5"] and "d22mm_a0.75" in kept["stopped"]
    assert kept["fitted_constants"] == {}


@pytest.mark.parametrize("argv, option", [(["compare", "--ppd", "0"], "--ppd"),
                                          (["compare", "--kernel", "packing", "--ppd", "1"], "--ppd"),
                                          (["compare", "--diameter", "-1"], "--diameter")])
def test_compare_names_the_option_of_a_bad_value(argv, option, capsys, tmp_path):
    """A value of `compare` that the column refuses is named by its command-line option, not by
    the field it sets; one line, exit 2, before any run (the JSON is not written)."""
    from bsrflow.cli import main
    js = tmp_path / "c.json"
    assert main(argv + ["--json", str(js)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"error: {option} = " in err[0] and "valid range" in err[0]
    assert not js.exists()


@pytest.mark.parametrize("signame", ["SIGTERM", "SIGINT"])
def test_an_interrupt_swallowed_while_compiling_is_raised_at_the_next_progress_call(signame):
    """llvmlite calls back into Python while numba compiles and swallows an exception raised
    there ("Exception ignored ..."): a Ctrl-C or SIGTERM in the first seconds of a run was lost
    and the run went on.  The signal is recorded and raised again at the next progress call."""
    import os
    import signal
    import time

    from bsrflow.io import commands

    with commands._sigterm_as_interrupt():
        try:                                          # the swallowing callback
            os.kill(os.getpid(), getattr(signal, signame))
            time.sleep(0.5)
        except KeyboardInterrupt:
            pass
        progress, close = commands._progress_bar(1.0, False)
        with pytest.raises(KeyboardInterrupt) as caught:
            progress(0.0)
        assert getattr(caught.value, "signal_name", "SIGINT") == signame
        progress(0.1)                                 # raised once
        close()
    assert commands._PENDING_SIGNALS == []


@pytest.mark.parametrize("argv, option", [
    (["init", "{tmp}/a.toml", "--kernel", "seed", "--kernel", "packing"], "--kernel"),
    (["init", "{tmp}/a.toml", "--kernel=seed", "--kernel", "packing"], "--kernel"),
    (["compare-bed", "--gammas", "3", "--gammas", "4"], "--gammas"),
    (["verify", "--json", "{tmp}/a.json", "--json", "{tmp}/b.json"], "--json"),
])
def test_a_single_valued_option_given_twice_is_refused(tmp_path, capsys, argv, option):
    """argparse keeps the last of two values silently (a walk-through's `init --kernel seed
    --kernel packing` wrote a packing config); repeatable options (--set, --param) are not
    affected."""
    from bsrflow.cli import main
    code = main([a.format(tmp=tmp_path) for a in argv])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and err == [f"bsrflow {argv[0]}: error: {option} is given twice; give it once"]
    assert list(tmp_path.iterdir()) == []


def test_a_negative_number_in_exponent_form_is_a_value(tmp_path, capsys):
    """`--dt -5e-6` was taken for an option ("expected one argument"); it is a value whose
    range check names it, as `--dt -0.5` always was."""
    from bsrflow.cli import main
    for value in ("-5e-6", "-0.5", "-1E+2", "-inf", "-NaN"):
        assert main(["compare-dump", str(tmp_path / "x.dump"), "--dt", value]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        shown = "--dt nan" if value == "-NaN" else "--dt -"               # float("-NaN") is nan
        assert len(err) == 1 and shown in err[0] and "outside the valid range (0, inf)" in err[0], err


@pytest.mark.parametrize("workers", [1, 2])
def test_compare_ends_on_sigterm_with_one_line(workers):
    """`bsrflow compare` (the main job's command) on SIGTERM: one line, exit 143, and with --workers no
    worker process left (before, the serial compare died silently with -15 and the workers ran on)."""
    import os
    import signal
    import subprocess
    import sys
    import time
    cmd = [sys.executable, "-m", "bsrflow", "compare", "--kernel", "packing", "--cases", "d22mm_a0.5",
           "--models", "eulerian:0", "--workers", str(workers)]
    p = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    first = p.stdout.readline()                          # the header: the command is under way
    assert first.startswith("bsrflow compare --kernel packing: 1 cases"), first
    time.sleep(3.0)
    os.kill(p.pid, signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 143, (p.returncode, err)
    assert err.strip().splitlines() == ["bsrflow compare: interrupted by SIGTERM"], err
    time.sleep(1.0)
    # the command's session (start_new_session: its id is p.pid): no worker of it is left (other
    # tests' lingering processes do not count)
    ps = subprocess.run(["ps", "-o", "pid=,stat=,args=", "-s", str(p.pid)], capture_output=True, text=True)
    left = [line for line in ps.stdout.splitlines() if line.split()[1][0] != "Z"]   # zombies wait for init
    assert left == [], left


def test_an_interrupted_packing_compare_keeps_its_finished_runs(tmp_path, monkeypatch, capsys):
    """Ctrl-C (or SIGTERM) in `bsrflow compare --kernel packing --json PATH` writes the finished case-model
    runs to PATH with "interrupted" and says so in its one line (before, everything was lost)."""
    import bsrflow.analysis.compare as compare_cli
    real = compare_cli._log
    seen = []

    def log(msg):
        real(msg)
        if msg.lstrip().startswith("d22mm_a0.5"):
            seen.append(msg)
            if len(seen) == 2:                       # after the second run of the first case
                raise KeyboardInterrupt()
    monkeypatch.setattr(compare_cli, "_log", log)
    out = tmp_path / "p.json"
    argv = ["compare", "--kernel", "packing", "--cases", "d22mm_a0.5,d22mm_a1.0", "--models", "lagrangian:1,lagrangian:0",
            "--json", str(out)]
    assert main(argv) == 130
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"bsrflow compare: interrupted by Ctrl-C (SIGINT); {out} keeps the 2 finished case-model run(s)"], err
    data = json.loads(out.read_text())
    assert data["interrupted"].startswith("interrupted by Ctrl-C") and data["fitted_constants"] == {}
    assert [(c["name"], c["model"]) for c in data["cases"]] == [("d22mm_a0.5", "lagrangian R=1d"),
                                                                  ("d22mm_a0.5", "lagrangian local")]


@pytest.mark.parametrize("command, stop_at, kept", [
    ("compare", "  single_tap_a1.0:", "the calibration and 2 seed-kernel case(s)"),
    ("demo", "  packing lagrangian", "the calibration, 3 seed-kernel case(s) and 1 packing run(s)")])
def test_an_interrupted_seed_compare_or_demo_keeps_what_it_finished(command, stop_at, kept, tmp_path, monkeypatch,
                                                                    capsys):
    """Ctrl-C (or SIGTERM) in `bsrflow compare --json PATH` (the seed kernel) or `bsrflow demo`
    writes the calibration and the finished runs to the JSON with "interrupted" and says so in its
    one line; before, both kept nothing. The calibration is patched to the demo's (a minute saved)."""
    import bsrflow.analysis.compare as compare_cli
    monkeypatch.setattr(compare_cli, "calibrate", lambda *a, **k: {"m0": 423.9, "kernel_dissipation": 0.8812})
    real = compare_cli._log

    def log(msg):
        real(msg)
        if msg.startswith(stop_at):
            raise KeyboardInterrupt()
    monkeypatch.setattr(compare_cli, "_log", log)
    if command == "compare":
        out = tmp_path / "c.json"
        argv = ["compare", "--json", str(out)]
    else:
        argv = ["demo", "--out", str(tmp_path / "demo")]
        out = tmp_path / "demo" / "compare.json"
    assert main(argv) == 130
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"bsrflow {command}: interrupted by Ctrl-C (SIGINT); {out} keeps {kept}"], err
    data = json.loads(out.read_text())
    assert data["interrupted"].startswith("interrupted by Ctrl-C")
    assert data["calibration"] == {"m0": 423.9, "kernel_dissipation": 0.8812}
    if command == "compare":
        assert [c["name"] for c in data["cases"]] == ["single_tap_a0.75", "single_tap_a1.0"]
        assert data["cases"][0]["bsr"]["top_max_over_d"] > 20 and "packing" not in data
    else:
        assert len(data["cases"]) == 3 and data["packing_fitted_constants"] == {}
        assert [(c["name"], c["model"]) for c in data["packing"]] == [("single_tap_a0.75", "lagrangian R=1d")]


def test_compare_bed_shows_progress_and_keeps_its_finished_runs_on_sigterm(tmp_path):
    """`bsrflow compare-bed` prints a line per finished run (it was silent for its 3–4 minutes), and a
    real SIGTERM ends it with one line, exit 143, its --json keeping the finished runs with
    "interrupted" (before, SIGTERM killed it without a word and nothing was kept)."""
    import os
    import signal
    import subprocess
    import sys
    out = tmp_path / "bed.json"
    cmd = [sys.executable, "-m", "bsrflow", "compare-bed", "--gammas", "3", "2.5", "2", "--no-extra", "--json", str(out)]
    p = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert p.stdout.readline().startswith("bsrflow compare-bed: 3 Γ of the LIGGGHTS runs")
    first = p.stdout.readline()                      # the first run's line: Γ = 3 is done
    assert first.startswith("  Γ = 3, e = 0.9: flight 25.3 ms (LIGGGHTS 27.2 ms)"), first
    os.kill(p.pid, signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 143, (p.returncode, err)
    assert err.strip().splitlines() == [f"bsrflow compare-bed: interrupted by SIGTERM; {out} keeps 1 finished run(s)"], err
    data = json.loads(out.read_text())
    assert data["interrupted"] == "interrupted by SIGTERM" and data["fitted_constants"] == {}
    assert [c["gamma"] for c in data["cases"]] == [3.0] and data["extra_cases"] == []
    assert abs(data["cases"][0]["flight_time_rel_diff"] + 0.0686) < 5e-4


@pytest.mark.parametrize("where", ["/site-packages/llvmlite/binding/fake.py", "/usr/lib/python3.11/weakref.py"])
def test_a_signal_during_numbas_compile_is_sent_again_not_swallowed(where):
    """A SIGTERM that arrives in llvmlite's Python code (numba compiling, where a ctypes callback
    would swallow the exception with an "Exception ignored" traceback; or in a weakref callback of the
    garbage collector) is not raised there: it is
    recorded and sent again 0.25 s later, and raises once the program is back in ordinary code."""
    import signal
    import time

    from bsrflow.io.commands import _sigterm_as_interrupt, _Terminated
    fake = {}
    exec(compile("import signal\ndef callback():\n    signal.raise_signal(signal.SIGTERM)\n    return 'went on'\n",
                 where, "exec"), fake)
    before = signal.getsignal(signal.SIGTERM)
    t0 = time.perf_counter()
    with pytest.raises(_Terminated):
        with _sigterm_as_interrupt():
            assert fake["callback"]() == "went on"           # not raised inside the "callback"
            time.sleep(5.0)                                 # the resent signal lands here
    assert 0.2 < time.perf_counter() - t0 < 3.0
    assert signal.getsignal(signal.SIGTERM) is before     # the handler is restored


def test_a_second_signal_inside_the_handlers_lock_still_interrupts():
    """A signal that arrives while the handler's lock is held in the main thread (the handler of a
    first signal, as GNU ``timeout`` sends two) runs the handler again there: it must raise, not
    wait for the lock (a sweep hung so).  In a subprocess, so that a regression fails instead of
    hanging the suite."""
    import subprocess
    import sys

    code = ("import os, signal, time\n"
            "from bsrflow.io import commands\n"
            "try:\n"
            "    with commands._sigterm_as_interrupt():\n"
            "        with commands._RESEND['lock']:\n"
            "            os.kill(os.getpid(), signal.SIGTERM)\n"
            "            time.sleep(5)\n"
            "except commands._Terminated:\n"
            "    print('interrupted')\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.stdout.strip() == "interrupted", out.stderr


def test_an_interrupt_inside_a_snapshot_waits_for_all_its_writes():
    """``together(netcdf, vtk)``: a SIGINT or SIGTERM that lands during the first write is raised
    after the second (an interrupted layer run's VTK series was one snapshot behind its netCDF
    file); outside the group a signal still raises at once.  In a subprocess (real signals)."""
    import subprocess
    import sys

    code = ("import os, signal, time\n"
            "from bsrflow.io import commands\n"
            "done = []\n"
            "def first(t):\n"
            "    os.kill(os.getpid(), signal.SIG{sig})\n"
            "    time.sleep(0.2)\n"
            "    done.append('netcdf')\n"
            "def second(t):\n"
            "    done.append('vtk')\n"
            "try:\n"
            "    with commands._sigterm_as_interrupt():\n"
            "        commands.together(first, second)(0.0)\n"
            "        done.append('after')\n"
            "except KeyboardInterrupt as exc:\n"
            "    print(type(exc).__name__, done)\n"
            "try:\n"
            "    with commands._sigterm_as_interrupt():\n"
            "        os.kill(os.getpid(), signal.SIG{sig})\n"
            "        time.sleep(5)\n"
            "except KeyboardInterrupt:\n"
            "    print('at once')\n")
    for sig, name in (("INT", "KeyboardInterrupt"), ("TERM", "_Terminated")):
        out = subprocess.run([sys.executable, "-c", code.format(sig=sig)], capture_output=True, text=True,
                             timeout=60)
        assert out.stdout.splitlines() == [f"{name} ['netcdf', 'vtk']", "at once"], out.stderr


SEED_TOML = "[run]\nt_end = 0.02\nsave_every = 0.01\n"
PACKING_TOML = '[model]\nkernel = "packing"\n' + SEED_TOML
LAYER_TOML = '[layer]\nkind = "tapped_layer"\ndim = 2\nt_end = 0.02\nsave_every = 0.01\n'


@pytest.mark.parametrize("argv, rc, text", [
    (["run", "{seed}", "--set", "d=5"], 2, "tap.a_over_d: 0.75 is outside the valid range [0, 0.4673]"),
    (["run", "{seed}", "--out", "{tmp}/a.nc", "--ou", "{tmp}/b.nc"], 2, "unrecognized arguments: --ou"),
    (["run", "{seed}", "--out", "{seed}.nc", ], 0, None),
    (["run", "{seed}", "--set", "e=0.5"], 2, "--set column.restitution: the seed kernel's continuum does not use it"),
    (["run", "{packing}", "--scheme", "seed"], 2, "--scheme: the scheme preset is an option of the seed kernel only"),
    (["run", "{layer}", "--set", "bottom_density=1e308"], 2, "bottom_density = 1e+308 is outside the valid range"),
    (["run", "{layer}", "--set", "gravity=1e300"], 2, "gravity = 1e+300 is outside the valid range [0.001, 10000]"),
    (["sweep", "{seed}", "--param", "e=0.3,0.9", "--out", "{tmp}/s.nc"], 2, "--param restitution: the seed kernel"),
    (["compare", "--diameter", "1e-6"], 2, "the DEM would take 4.79e+12 steps"),
    (["compare", "--diameter", "5"], 2, "--diameter: d = 5 m is outside the valid range [1e-06, 0.701] m"),
    (["compare", "--scheme", "foo"], 2, "error: --scheme 'foo' is not one of"),
    (["compare-bed", "--reference", "{tmp}/ref", "--json", "{tmp}/ref/params.json"], 2, "is inside --reference"),
])
def test_inputs_found_by_the_robustness_review(argv, rc, text, tmp_path, capsys):
    """Inputs a review (2026-12-03) found to give a traceback (d = 5 m), to be silently ignored
    (an abbreviated option given twice, e for the seed kernel, --scheme for the packing kernel), an
    infinite output (bottom_density), an unstoppable run (d = 1e-6 m) or an input overwritten
    (compare-bed's reference): one line, exit 2 (3 for a DEM that stops), nothing written."""
    import shutil
    from pathlib import Path
    for name, text_ in (("seed", SEED_TOML), ("packing", PACKING_TOML), ("layer", LAYER_TOML)):
        (tmp_path / f"{name}.toml").write_text(text_)
    if "{tmp}/ref" in " ".join(argv):
        shutil.copytree(Path(__file__).parent.parent / "reference" / "liggghts_bed", tmp_path / "ref",
                        ignore=shutil.ignore_patterns("results", "work"))
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    argv = [a.replace("{seed}", str(tmp_path / "seed.toml")).replace("{packing}", str(tmp_path / "packing.toml"))
            .replace("{layer}", str(tmp_path / "layer.toml")).replace("{tmp}", str(tmp_path)) for a in argv]
    if text is None:                                  # the control: a valid run of the same config
        assert main(argv + ["--quiet"]) == 0
        return
    try:
        got = main(argv)
    except SystemExit as exc:                         # argparse's own refusals
        got = exc.code
    assert got == rc
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and text in err[0], err
    assert all(p.read_bytes() == b for p, b in before.items())      # no input overwritten
    assert not list(tmp_path.glob("*.nc"))


def test_a_checkpoint_that_would_overwrite_the_config_is_refused(tmp_path, capsys):
    """`bsrflow run c.nc.ckpt --out c.nc`: the checkpoint <out>.ckpt would overwrite the config (and
    the finished run delete it); refused in one line, exit 2, the config untouched."""
    cfg = tmp_path / "c.nc.ckpt"
    cfg.write_text(SEED_TOML)
    assert main(["run", str(cfg), "--out", str(tmp_path / "c.nc")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "is the config file itself" in err[0] and "checkpoint" in err[0], err
    assert cfg.read_text() == SEED_TOML


def test_no_command_is_one_line_on_stderr(capsys):
    """`bsrflow` alone: one line on stderr naming what is missing, exit 2 (it printed the whole
    help on stdout)."""
    assert main([]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.strip().splitlines() == ["bsrflow: error: a COMMAND is required; `bsrflow --help` "
                                                       "lists them"]


@pytest.mark.parametrize("text", ["", "# my column, to be written\n\n   \n"])
def test_an_empty_config_is_refused_pointing_at_init(tmp_path, capsys, text):
    """A config without tables (a zero-byte file, only comments) ran the default tapped column
    silently (a fuzzing review: most likely a mistyped or unsaved file): one line, exit 2, no output."""
    cfg = tmp_path / "c.toml"
    cfg.write_text(text)
    assert main(["run", str(cfg), "--out", str(tmp_path / "c.nc")]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.strip().splitlines() == [
        f"bsrflow run: error: {cfg}: the config has no tables (it is empty or only comments); `bsrflow init "
        "NEW.toml` writes one with every field and its default"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.toml"]


# -- argument words the commands do not take (an audit, 2026-12-06) ----------------------------------
@pytest.mark.parametrize("argv, expected", [
    (["run", "x.toml", "--ou", "b.nc"],
     "bsrflow run: error: unrecognized arguments: --ou b.nc (options are not abbreviated; `bsrflow run --help`"),
    (["compare", "--ou", "out"],
     "bsrflow compare: error: unrecognized arguments: --ou out (options are not abbreviated;"),
    (["run", "x.toml", "a.nc", "extra"], "bsrflow run: error: unrecognized arguments: a.nc extra (`bsrflow run --help`"),
    (["--bogus"], "bsrflow: error: unrecognized arguments: --bogus (options are not abbreviated;"),
    (["--bogus", "run", "x.toml"], "bsrflow: error: unrecognized arguments: --bogus (options"),
    (["--vers"], "bsrflow: error: unrecognized arguments: --vers (options are not abbreviated;"),
])
def test_unrecognized_arguments_name_the_command_and_say_abbreviations_are_refused(argv, expected, capsys):
    """An abbreviated option (`--ou` for `--out`) was refused by a line that named neither the
    command nor the reason: now both, exit 2, before any work."""
    assert main(argv) == 2
    _one_line(capsys, expected)
