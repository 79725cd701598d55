"""The bench scripts' bad input (audit 2026-12-05, V02, V03, V13): one line on stderr naming the
option and its valid range, exit code 2, at parse time (before any work); the argument types of
bench/_args.py accept the ends of the range they state."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "bench"
sys.path.insert(0, str(BENCH))

import _args  # noqa: E402
from _args import float_in, int_in, list_of  # noqa: E402


def _refused(script, *argv, cwd=BENCH):
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src") + os.pathsep + os.environ.get("PYTHONPATH", ""))
    p = subprocess.run([sys.executable, str(BENCH / script), *argv], cwd=cwd, env=env, capture_output=True,
                       text=True, timeout=60)
    assert p.returncode == 2, (p.returncode, p.stderr)
    assert p.stdout == ""
    lines = p.stderr.splitlines()
    assert len(lines) == 1, p.stderr
    assert lines[0].startswith(f"{script}: error: "), p.stderr
    return lines[0]


@pytest.mark.parametrize("script, argv, texts", [
    # V02: the solver's range, refused before the timings
    ("bench_bed_eulerian.py", ["--lateral", "257"], ["--lateral", "257", "[2, 256]"]),
    ("bench_bed_eulerian.py", ["--lateral", "1"], ["--lateral", "[2, 256]"]),
    # V13: the range stated is the range accepted, for both ends and for unparseable text
    ("bench_bed_eulerian.py", ["--cells-per-d", "65"], ["--cells-per-d", "65", "[1, 64]"]),
    ("check_eulerian_floor_force.py", ["--cells-per-d", "0"], ["--cells-per-d", "[1, 16]"]),
    ("check_eulerian_floor_force.py", ["--cells-per-d", "4,17"], ["--cells-per-d", "17", "[1, 16]"]),
    ("check_eulerian_floor_force.py", ["--cells-per-d", "abc"], ["'abc' is not an integer", "[1, 16]"]),
    ("check_eulerian_floor_force.py", ["--cycle", "12"], ["--cycle", "[1, 11]"]),
    ("check_eulerian_bed_tracers.py", ["--cycles", "0"], ["--cycles", "[1, 50]"]),
    ("check_face_wave_speed.py", ["--gamma", "inf"], ["--gamma", "(0, 8]"]),
    ("check_face_wave_speed.py", ["--gamma", "9"], ["--gamma", "(0, 8]"]),
    ("check_face_wave_speed.py", ["--gamma", "-1e-3"], ["--gamma", "(0, 8]"]),
    ("check_face_wave_speed.py", ["--gamma", "nan"], ["--gamma", "(0, 8]"]),
    ("check_face_wave_speed.py", ["--gamma", "abc"], ["'abc' is not a number", "(0, 8]"]),
    ("check_face_wave_speed.py", ["--dim", "abc"], ["--dim", "'abc'", "1, 3"]),
    ("check_face_wave_speed.py", ["--dim", "2"], ["--dim", "1, 3"]),
    ("check_bed_1d.py", ["--restitution", "0.7"], ["--restitution", "0.9, 0.5"]),
    ("scan_kutta4.py", ["--perturb", "0.01"], ["--perturb", "[0, 0.001]"]),
    ("check_face_wave_speed.py", ["--no-such-option"], ["unrecognized arguments"]),
    # an audit of 2026-12-06: tracebacks (a scheme preset, a sleep) and an orphaned child before them
    ("check_time_order.py", ["--scheme", "bogus"], ["--scheme", "'bogus'", "seed, accurate"]),
    ("check_density_floor.py", ["--scheme", "bogus"], ["--scheme", "seed, accurate"]),
    ("ab_step.py", ["--ref", "HEAD", "--scheme", "bogus"], ["--scheme", "seed, accurate"]),
    ("check_signals.py", ["--delays", "-1"], ["--delays", "[0, 600]"]),
    ("check_signals.py", ["--delays", "nan"], ["--delays", "[0, 600]"]),
    ("check_signals.py", ["--handler-after", "abc"], ["--handler-after", "[0, 600]"]),
    ("check_signals.py", ["--commands", "bogus"], ["--commands", "energy, verify, stability"]),
    ("check_kill_rate.py", ["--dir", "/proc/no/such/dir"], ["--dir", "cannot create the directory"]),
    ("check_checkpoint_cost.py", ["--dir", "/proc/no/such/dir"], ["--dir", "cannot create the directory"]),
])
def test_a_bad_value_is_one_line_naming_the_range(script, argv, texts):
    err = _refused(script, *argv)
    for text in texts:
        assert text in err, err


def test_an_existing_non_json_file_is_refused_up_front(tmp_path):
    """V03: the whole benchmark ran, then the merge failed and the results were lost."""
    bad = tmp_path / "results.json"
    bad.write_text("{not json")
    err = _refused("bench_bed_eulerian.py", "--json", str(bad))
    assert "--json" in err and "not JSON" in err and "JSON object" in err, err
    bad.write_text("[1, 2]")
    assert "JSON list, not an object" in _refused("bench_bed_eulerian.py", "--json", str(bad))
    assert bad.read_text() == "[1, 2]"


@pytest.mark.parametrize("cwd", [ROOT, BENCH])
def test_the_defaults_work_from_the_root_and_from_bench(cwd):
    """V13: from bench/, the default ``bench/results.json`` was refused ("directory .../bench/bench
    does not exist") and hid the real bad value."""
    assert "--cells-per-d" in _refused("bench_bed_eulerian.py", "--cells-per-d", "65", cwd=cwd)
    old = os.getcwd()
    try:
        os.chdir(cwd)
        path = _args.repo_path("bench/results.json")
        assert os.path.abspath(path) == str(BENCH / "results.json")
        assert _args.output_json(path) == path
    finally:
        os.chdir(old)


def test_the_range_ends_are_accepted():
    t = int_in(1, 16)
    assert (t("1"), t("16")) == (1, 16)
    for text in ("0", "17", "abc", "1.0", ""):
        with pytest.raises(argparse.ArgumentTypeError, match=r"valid range \[1, 16\]"):
            t(text)
    assert int_in(4)("4") == 4 and int_in(4)("1000000000") == 10 ** 9
    with pytest.raises(argparse.ArgumentTypeError, match=r"\[4, inf\)"):
        int_in(4)("3")

    g = float_in(0.0, 8.0, lo_open=True)
    assert g("8") == 8.0 and g("1e-300") == 1e-300
    for text in ("0", "-0.0", "8.000001", "inf", "nan", "abc"):
        with pytest.raises(argparse.ArgumentTypeError, match=r"valid range \(0, 8\]"):
            g(text)

    closed = float_in(0.0, 1e-3)
    assert closed("0") == 0.0 and closed("1e-3") == 1e-3
    open_both = float_in(0.0, 1.0, lo_open=True, hi_open=True)
    assert open_both("0.5") == 0.5
    for text in ("0", "1"):
        with pytest.raises(argparse.ArgumentTypeError, match=r"\(0, 1\)"):
            open_both(text)
    unbounded = float_in(0.0, lo_open=True)
    assert unbounded("1e300") == 1e300
    with pytest.raises(argparse.ArgumentTypeError, match=r"\(0, inf\)"):
        unbounded("inf")


def test_the_list_type_checks_each_value_against_the_range():
    t = list_of(int_in(1, 16))
    assert t("1,16") == [1, 16] and t("4") == [4]
    with pytest.raises(argparse.ArgumentTypeError, match=r"17 is outside the valid range \[1, 16\]"):
        t("1,17")
    with pytest.raises(argparse.ArgumentTypeError, match=r"'' is not an integer; valid range \[1, 16\]"):
        t("1,,2")
    assert list_of(float_in(0.0, 1.0, lo_open=True))("0.003,1") == [0.003, 1.0]


def test_a_merge_that_fails_at_the_end_keeps_the_results(tmp_path, capsys):
    """The file checked up front is no longer a JSON object at the end: the results go to a new
    file beside it, and stderr says where."""
    target = tmp_path / "results.json"
    target.write_text('{"other": 1}')
    assert _args.merge_target(str(target)) == str(target)
    _args.merge_json(str(target), "k", {"x": 1})
    assert json.loads(target.read_text()) == {"other": 1, "k": {"x": 1}}
    target.write_text("{broken")
    alt = _args.merge_json(str(target), "k", {"x": 2})
    assert alt != str(target) and Path(alt).parent == tmp_path
    assert json.loads(Path(alt).read_text()) == {"k": {"x": 2}}
    assert target.read_text() == "{broken"
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and alt in err and str(target) in err, err
    assert _args.merge_json(str(target), "k", {"x": 3}) != alt         # never overwrites an earlier one


def test_a_scratch_dir_that_is_a_file_is_refused_and_a_new_one_is_made(tmp_path):
    """``--dir`` of the kill-rate and checkpoint-cost scripts: a file is refused in one line; a
    missing folder (with its parents) is created when the arguments are read."""
    f = tmp_path / "file.txt"
    f.write_text("x")
    assert "is a file" in _refused("check_kill_rate.py", "--dir", str(f))
    new = tmp_path / "a" / "b"
    assert _args.scratch_dir(str(new)) == str(new) and not (tmp_path / "a").exists()   # checked, not made
    assert _args.make_scratch_dir(_args.Parser(prog="x"), str(new)) == str(new) and new.is_dir()
    with pytest.raises(argparse.ArgumentTypeError, match="empty path"):
        _args.scratch_dir(" ")


@pytest.mark.parametrize("script, argv", [
    ("check_kill_rate.py", ["--bogus"]), ("check_kill_rate.py", ["--dir", "{tmp}/a/x", "--kills", "0"]),
    ("check_checkpoint_cost.py", ["--dir", "{tmp}/a/x", "--repeats", "0"]),
])
def test_a_refused_command_line_leaves_no_folder(script, argv, tmp_path):
    """argparse also types the default ``--dir``: a bad argument after it must not leave
    ``out/...`` (or the given folder) behind."""
    err = _refused(script, *[a.replace("{tmp}", str(tmp_path)) for a in argv], cwd=tmp_path)
    assert err and not (tmp_path / "out").exists() and not (tmp_path / "a").exists()


def test_every_bench_script_describes_itself_and_every_option():
    """Read from the sources (running 32 ``--help`` would cost a minute of imports): every option
    of every script has a help text, and a description taken from the docstring's first line is
    a whole sentence (the others take its whole first paragraph)."""
    import ast
    for path in sorted(BENCH.glob("*.py")):
        if path.name.startswith("_"):
            continue
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "add_argument":
                assert any(k.arg == "help" for k in node.keywords), (path.name, node.lineno)
        assert "__doc__.splitlines()[0]" not in path.read_text() or \
            path.read_text().split('"""')[1].splitlines()[0].rstrip().endswith((".", "?", ":", ")")), path.name
