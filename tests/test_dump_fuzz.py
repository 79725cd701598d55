"""Bad dump files given to ``bsrflow compare-dump``: one line on stderr, exit 2, no traceback,
and the BSR run never started (issue #20, "Dumps").  Plus a random fuzz of the reader: whatever
the damage, ``read_dump`` returns or raises ValueError, nothing else."""

import gzip
import random

import numpy as np
import pytest

from bsrflow.cli import main
from bsrflow.io.lammps import read_dump


def _snapshot(step, zs, time=None, ys=None, n=None):
    ys = [0.0] * len(zs) if ys is None else ys
    n = len(zs) if n is None else n
    head = "" if time is None else f"ITEM: TIME\n{time!r}\n"
    rows = "".join(f"{k + 1} 1 0.0 {y} {z}\n" for k, (y, z) in enumerate(zip(ys, zs)))
    return (head + f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n{n}\nITEM: BOX BOUNDS ff ff ff\n"
            "-1.0 1.0\n-1.0 1.0\n0.0 2.0\nITEM: ATOMS id type x y z\n" + rows)


GOOD = _snapshot(0, [0.011, 0.033, 0.055]) + _snapshot(1000, [0.012, 0.034, 0.058]) + \
    _snapshot(2000, [0.013, 0.036, 0.060])
TIMED = _snapshot(0, [0.011, 0.033], time=0.0) + _snapshot(1000, [0.012, 0.034], time=0.01) + \
    _snapshot(2000, [0.013, 0.036], time=0.02)


def _bad_files(tmp_path):
    """(case, path, extra arguments, a word the message must contain)."""
    cases = []

    def add(case, name, data, args=(), word=""):
        p = tmp_path / name
        if data is None:
            p.mkdir()
        else:
            p.write_bytes(data if isinstance(data, bytes) else data.encode())
        cases.append((case, str(p), list(args), word))

    add("gz_not_gzip", "plain.dump.gz", GOOD, ["--dt", "1e-5"], "not gzip")
    add("gz_truncated", "cut.dump.gz", gzip.compress(GOOD.encode())[:-40], ["--dt", "1e-5"], "truncated gzip")
    add("gz_garbage", "noise.dump.gz", b"\x1f\x8b" + bytes(range(256)) * 4, ["--dt", "1e-5"], "gzip")
    add("nan_coordinate", "nan.dump", GOOD.replace("0.034", "nan"), ["--dt", "1e-5"], "line 23")
    add("inf_coordinate", "inf.dump", GOOD.replace("0.055", "-inf"), ["--dt", "1e-5"], "line 12")
    add("zero_atoms", "empty.dump", _snapshot(0, []) + _snapshot(1000, []), ["--dt", "1e-5"], "NUMBER OF ATOMS is 0")
    add("one_frame", "one.dump", _snapshot(0, [0.011, 0.033, 0.055]), ["--dt", "1e-5"], "only one snapshot")
    add("constant_axis", "flat.dump", GOOD, ["--dt", "1e-5", "--axis", "y"], "--axis y")
    add("conflicting_dt", "timed.dump", TIMED, ["--dt", "2e-4"], "contradicts")
    add("no_times", "untimed.dump", GOOD, [], "--dt")
    add("floor_above_spheres", "low.dump", GOOD, ["--dt", "1e-5", "--floor-offset", "1.0", "--tap-start", "0.005"],
        "--floor-offset 1.0")
    add("directory", "adir.dump", None, ["--dt", "1e-5"], "cannot be read")
    # a review (2026-12-03): a NaN offset was checked only after the run, a count mismatch only warned
    add("floor_nan", "good.dump", GOOD, ["--dt", "1e-5", "--floor-offset", "nan"], "--floor-offset nan")
    add("time_offset_inf", "good2.dump", GOOD, ["--dt", "1e-5", "--time-offset", "inf"], "--time-offset inf")
    add("floor_minus_inf", "good3.dump", GOOD, ["--dt", "1e-5", "--floor-offset", "-inf"], "--floor-offset -inf is")
    add("atoms_not_spheres", "two.dump", TIMED, [], "contradicts the dump's 2 atoms")
    return cases


CASES = ["gz_not_gzip", "gz_truncated", "gz_garbage", "nan_coordinate", "inf_coordinate", "zero_atoms",
         "one_frame", "constant_axis", "conflicting_dt", "no_times", "floor_above_spheres", "directory",
         "floor_nan", "time_offset_inf", "floor_minus_inf", "atoms_not_spheres"]


@pytest.mark.parametrize("case", CASES)
def test_bad_dump_gives_one_line_and_exit_2_before_any_run(tmp_path, capsys, monkeypatch, case):
    import bsrflow.physics.column as column

    def no_run(*a, **k):
        raise AssertionError("the BSR run started before the dump was checked")

    monkeypatch.setattr(column, "run_bsr_column", no_run)
    _, path, extra, word = {c[0]: c for c in _bad_files(tmp_path)}[case]
    code = main(["compare-dump", path, *extra, "--n-spheres", "3", "--t-end", "0.01",
                 "--json", str(tmp_path / "out.json")])
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert code == 2, (case, captured)
    assert len(err) == 1, err
    assert err[0].startswith("bsrflow compare-dump: error: "), err
    assert "Traceback" not in captured.err + captured.out
    assert word in err[0], err[0]
    assert not (tmp_path / "out.json").exists()


def test_nan_message_names_file_line_and_value(tmp_path):
    p = tmp_path / "nan.dump"
    p.write_text(GOOD.replace("0.034", "nan"))
    with pytest.raises(ValueError, match=r"nan\.dump, line 23: column 'z' holds 'nan'"):
        read_dump(p, timestep_size=1e-5)


def test_conflicting_dt_says_by_how_much(tmp_path, capsys):
    p = tmp_path / "timed.dump"
    p.write_text(TIMED)
    # dt 2e-4 s: the last snapshot at timestep 2000 would be at 0.4 s, the file says 0.02 s
    assert main(["compare-dump", str(p), "--dt", "2e-4", "--n-spheres", "2"]) == 2
    err = capsys.readouterr().err
    assert "by up to 0.38 s" in err and "timestep 2000: 0.4 s against 0.02 s" in err and "20x" in err


def test_consistent_dt_and_time_items_agree(tmp_path):
    """A --dt that agrees with ITEM: TIME is accepted and the file's own times are kept."""
    p = tmp_path / "timed.dump"
    p.write_text(TIMED)
    d = read_dump(p, timestep_size=1e-5)
    np.testing.assert_array_equal(d.t, [0.0, 0.01, 0.02])
    with pytest.raises(ValueError, match="timestep_size = 2e-05 s contradicts the file's ITEM: TIME"):
        read_dump(p, timestep_size=2e-5)


def test_gzip_recognised_by_content(tmp_path):
    """A gzip file is read whatever its name; the plain text of a .gz-named file is refused."""
    p = tmp_path / "packed.dump"
    p.write_bytes(gzip.compress(GOOD.encode()))
    ref = tmp_path / "ref.dump"
    ref.write_text(GOOD)
    np.testing.assert_array_equal(read_dump(p).positions, read_dump(ref).positions)


def test_random_damage_never_escapes_as_another_exception(tmp_path):
    """200 damaged copies of a good dump (cut at a random byte, a random byte changed, a random
    number replaced by nan/inf/garbage, gzip cut or flipped): read_dump either returns finite
    coordinates or raises ValueError."""
    rng = random.Random(20)
    raw = GOOD.encode()
    packed = gzip.compress(raw)
    tokens = GOOD.split(" ")
    outcomes = {"ok": 0, "ValueError": 0}
    for k in range(200):
        kind = k % 5
        if kind == 0:
            data = raw[:rng.randrange(len(raw))]
        elif kind == 1:
            b = bytearray(raw)
            b[rng.randrange(len(b))] = rng.randrange(256)
            data = bytes(b)
        elif kind == 2:
            t = list(tokens)
            t[rng.randrange(len(t))] = rng.choice(["nan", "inf", "-inf", "1e400", "x", ""])
            data = " ".join(t).encode()
        elif kind == 3:
            data = packed[:rng.randrange(len(packed))]
        else:
            b = bytearray(packed)
            b[rng.randrange(2, len(b))] ^= 1 << rng.randrange(8)
            data = bytes(b)
        p = tmp_path / f"fuzz{k}.dump{'.gz' if kind >= 3 else ''}"
        p.write_bytes(data)
        try:
            d = read_dump(p, timestep_size=1e-5)
        except ValueError as exc:
            assert str(exc).startswith(str(p)) and "\n" not in str(exc), str(exc)
            outcomes["ValueError"] += 1
            continue
        assert d.n_atoms > 0 and np.all(np.isfinite(d.heights()))
        outcomes["ok"] += 1
    assert outcomes["ValueError"] > 50 and outcomes["ok"] > 5, outcomes


def test_real_command_line_prints_no_traceback(tmp_path):
    """The installed command itself (a separate process): a truncated gzip and a NaN coordinate."""
    import subprocess
    import sys

    cut = tmp_path / "cut.dump.gz"
    cut.write_bytes(gzip.compress(GOOD.encode())[:-40])
    nan = tmp_path / "nan.dump"
    nan.write_text(GOOD.replace("0.055", "nan"))
    for p in (cut, nan):
        r = subprocess.run([sys.executable, "-m", "bsrflow.cli", "compare-dump", str(p), "--dt", "1e-5"],
                           capture_output=True, text=True, timeout=120)
        assert r.returncode == 2, r
        assert len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr, r.stderr
        assert str(p) in r.stderr
