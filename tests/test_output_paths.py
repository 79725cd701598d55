"""Every output option of every command: an unwritable place, the wrong kind of path (a
directory where a file is expected, a file where a directory is expected, a path through a
file) and a missing parent folder give one line naming the option, exit code 2, and nothing is
computed first (the functions that do the work are replaced by ones that fail the test).

"Unwritable" must fail for root too (the tests may run as root, who may write in a chmod-ed
folder): ``/proc`` takes no new files."""
import os
import subprocess
import sys

import numpy as np
import pytest

from bsrflow.cli import build_parser, main
from bsrflow.io.paths import OutputPathError, check_output_dir, check_output_file

pytestmark = pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux /proc")

# (command argv before the output option, option, kind of output)
OUTPUTS = [
    (["init"], None, "file"),                         # positional PATH
    (["run", "{cfg}", "--out"], "--out", "file"),
    (["plot", "{nc}", "--out"], "--out", "dir"),
    (["demo", "--out"], "--out", "dir"),
    (["verify", "--json"], "--json", "file"),
    (["stability", "--json"], "--json", "file"),
    (["stability", "--figures"], "--figures", "dir"),
    (["energy", "--json"], "--json", "file"),
    (["energy", "--figures"], "--figures", "dir"),
    (["compare", "--json"], "--json", "file"),
    (["compare", "--figures"], "--figures", "dir"),
    (["compare-dump", "{dump}", "--dt", "1e-5", "--json"], "--json", "file"),
    (["compare-dump", "{dump}", "--dt", "1e-5", "--figures"], "--figures", "dir"),
    (["compare-bed", "--json"], "--json", "file"),
    (["compare-bed", "--figures"], "--figures", "dir"),
    (["run", "{layer}", "--out"], "--out", "file"),     # a 2-D / 3-D layer config
    (["sweep", "--param", "a_over_d=0.5,1", "--out"], "--out", "file"),
    (["sweep", "--param", "a_over_d=0.5,1", "--figure"], "--figure", "file"),
]
BAD = ["unwritable", "wrong_kind", "through_a_file", "missing_parent"]


def _bad_path(kind, bad, tmp):
    if bad == "unwritable":
        return "/proc/bsrflow-test-output" + (".json" if kind == "file" else "")
    if bad == "wrong_kind":                            # a directory for a file, a file for a directory
        return str(tmp / ("a_dir" if kind == "file" else "a_file"))
    if bad == "through_a_file":
        return str(tmp / "a_file" / "out")
    return str(tmp / "no_such_folder" / "out")


@pytest.fixture
def no_work(monkeypatch):
    """Replace everything that computes, reads inputs or starts a cluster by a test failure."""
    # modules that bind a patched function by name at import: imported before the patches, or a
    # later test would find the fake in them (compare_packing's run_bsr_column, found 2026-12-05)
    import bsrflow.analysis.compare_packing  # noqa: F401
    import bsrflow.analysis.compare as compare
    import bsrflow.analysis.compare_bed as compare_bed
    from bsrflow.numerics.solver_nd import SimulationND
    import bsrflow.analysis.energy as energy
    import bsrflow.analysis.stability as stability
    import bsrflow.analysis.verify as verify
    import bsrflow.io.commands as commands
    import bsrflow.io.lammps as lammps
    import bsrflow.io.runner as runner
    import bsrflow.physics.column as column
    import bsrflow.tools.plot_file as plot_file
    import bsrflow.tools.sweep as sweep
    from bsrflow.numerics.solver import Simulation

    def fail(*a, **k):
        raise AssertionError("work started before the output path was checked")

    for mod, name in [(verify, "run_cases"), (stability, "cfl_table"), (energy, "energy_study"),
                      (compare, "compare"), (lammps, "read_dump"), (column, "run_bsr_column"),
                      (runner, "column_simulation"), (runner, "initial_density"), (plot_file, "plot_file"),
                      (plot_file, "load_output"), (sweep, "run_sweep"), (sweep, "parse_params"),
                      (commands, "default_config_text"), (Simulation, "run"), (Simulation, "advance"),
                      (compare_bed, "compare_bed"), (compare_bed, "check_reference"),
                      (compare_bed, "reference_bed"), (SimulationND, "run"), (SimulationND, "__init__")]:
        monkeypatch.setattr(mod, name, fail)


@pytest.mark.parametrize("bad", BAD)
@pytest.mark.parametrize("argv, option, kind", OUTPUTS, ids=[" ".join(o[0][:1] + [o[1] or "PATH"]) for o in OUTPUTS])
def test_bad_output_path_one_line_exit_2_before_any_work(tmp_path, capsys, no_work, argv, option, kind, bad):
    (tmp_path / "a_dir").mkdir()
    (tmp_path / "a_file").write_text("x")
    cfg = tmp_path / "c.toml"
    cfg.write_text("[run]\nt_end = 0.1\n")
    nc = tmp_path / "r.nc"
    nc.write_bytes(b"not read before the check")
    dump = tmp_path / "d.dump"
    dump.write_text("not read before the check")
    layer = tmp_path / "layer.toml"
    layer.write_text("[layer]\ndim = 2\n")
    path = _bad_path(kind, bad, tmp_path)
    args = [a.format(cfg=cfg, nc=nc, dump=dump, layer=layer) for a in argv] + [path]
    code = main(args)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2, err
    assert len(err) == 1, err
    assert err[0].startswith(f"bsrflow {argv[0]}: error: {option or 'PATH'}: "), err[0]
    problem = {"unwritable": "cannot write in the directory /proc",
               "wrong_kind": "is a directory; give a file name" if kind == "file" else "is a file; give a directory",
               "through_a_file": "a_file is a file, not a directory",
               "missing_parent": "no_such_folder does not exist"}[bad]
    assert problem in err[0], err[0]
    assert not (tmp_path / "no_such_folder").exists()   # missing folders are never created
    assert sorted(os.listdir(tmp_path)) == ["a_dir", "a_file", "c.toml", "d.dump", "layer.toml", "r.nc"]
    assert os.listdir(tmp_path / "a_dir") == []


FILE_OUTPUTS = [o for o in OUTPUTS if o[2] == "file"]


@pytest.mark.parametrize("argv, option, kind", FILE_OUTPUTS,
                         ids=[" ".join(o[0][:1] + [o[1] or "PATH"]) for o in FILE_OUTPUTS])
def test_a_file_name_without_room_for_its_side_files_is_refused_before_any_work(tmp_path, capsys, no_work, argv,
                                                                                 option, kind):
    """A legal file name too long for the checkpoint and temporary files written beside it
    (``<out>.ckpt.tmp<pid>``) is refused up front, naming the option and the valid length (a fuzzing
    review: a 255-character ``--out`` failed after the work, with exit code 1)."""
    cfg = tmp_path / "c.toml"
    cfg.write_text("[run]\nt_end = 0.1\n")
    layer = tmp_path / "layer.toml"
    layer.write_text("[layer]\ndim = 2\n")
    nc, dump = tmp_path / "r.nc", tmp_path / "d.dump"
    nc.write_bytes(b"x")
    dump.write_text("x")
    path = str(tmp_path / ("a" * 245 + ".out"))
    args = [a.format(cfg=cfg, nc=nc, dump=dump, layer=layer) for a in argv] + [path]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"bsrflow {argv[0]}: error: {option or 'PATH'}: "), err
    from bsrflow.io.paths import SIDE_FILE_SUFFIX_ROOM, _name_max
    limit = _name_max(str(tmp_path)) - SIDE_FILE_SUFFIX_ROOM               # 255 - 19 on common file systems
    assert limit < 249
    assert f"the file name is 249 bytes long (UTF-8); the valid range is 1 to {limit} bytes" in err[0], err[0]
    assert sorted(os.listdir(tmp_path)) == ["c.toml", "d.dump", "layer.toml", "r.nc"]


def test_every_output_option_of_every_command_is_covered():
    """The list above names every option of `bsrflow --help` that writes something."""
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    writers = {"--out", "--json", "--figures", "--figure"}
    found = set()
    for name, p in sub.choices.items():
        for a in p._actions:
            for opt in a.option_strings:
                if opt in writers:
                    found.add((name, opt))
    found.add(("init", None))
    assert found == {(argv[0], option) for argv, option, _ in OUTPUTS}


def test_the_check_itself(tmp_path):
    (tmp_path / "f").write_text("x")
    assert check_output_file(tmp_path / "new.json", "--json") == str(tmp_path / "new.json")
    assert check_output_file(tmp_path / "f", "--json") == str(tmp_path / "f")      # replaced later
    assert check_output_dir(tmp_path / "figs", "--figures") == str(tmp_path / "figs")
    assert not (tmp_path / "figs").exists()
    check_output_dir(tmp_path / "figs", "--figures", create=True)
    assert (tmp_path / "figs").is_dir() and os.listdir(tmp_path / "figs") == []
    with pytest.raises(OutputPathError, match=r"^--out: /dev/null exists and is not a regular file"):
        check_output_file("/dev/null", "--out")
    with pytest.raises(OutputPathError, match="cannot write in the directory /proc"):
        check_output_dir("/proc/x", "--figures")
    assert sorted(os.listdir(tmp_path)) == ["f", "figs"]                    # no probe left behind


def test_run_out_on_an_unwritable_place_in_a_subprocess(tmp_path):
    """The real command line (no traceback from h5py): one line, exit 2."""
    cfg = tmp_path / "c.toml"
    cfg.write_text("[run]\nt_end = 0.1\n")
    p = subprocess.run([sys.executable, "-m", "bsrflow.cli", "run", str(cfg), "--out", "/proc/bsrflow-x.nc"],
                       capture_output=True, text=True, timeout=120)
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 2 and len(lines) == 1, p.stderr
    assert lines[0].startswith("bsrflow run: error: --out: cannot write in the directory /proc"), lines


def test_sweep_no_longer_creates_a_missing_folder(tmp_path, capsys):
    """The rule is the same as `run`'s: the folder holding an output must exist."""
    out = tmp_path / "new" / "s.nc"
    assert main(["sweep", "--param", "a_over_d=0.5,1", "--out", str(out)]) == 2
    assert "--out: directory" in capsys.readouterr().err and not out.parent.exists()


def test_demo_refuses_a_file_in_place_of_its_figures_folder(tmp_path, capsys, no_work):
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "figures").write_text("x")
    assert main(["demo", "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--out: " in err[0] and "figures is a file" in err[0], err
    np.testing.assert_equal(sorted(os.listdir(tmp_path / "out")), ["figures"])


@pytest.mark.parametrize("argv, option", [
    (["stability", "--json", "{x}", "--figures", "{x}"], "--figures"),
    (["energy", "--json", "{x}", "--figures", "{x}"], "--figures"),
    (["compare", "--json", "{x}", "--figures", "{x}"], "--figures"),
    (["compare", "--kernel", "packing", "--json", "{x}", "--figures", "{x}"], "--figures"),
    (["compare-dump", "{dump}", "--dt", "1e-5", "--json", "{x}", "--figures", "{x}"], "--figures"),
    (["compare-dump", "{dump}", "--dt", "1e-5", "--json", "{dump}"], "--json"),
    (["compare-bed", "--json", "{x}", "--figures", "{x}"], "--figures"),
    (["sweep", "{cfg}", "--param", "a_over_d=0.5,1", "--out", "{cfg}"], "--out"),
    (["sweep", "{cfg}", "--param", "a_over_d=0.5,1", "--out", "{x}", "--figure", "{x}"], "--figure"),
])
def test_two_options_naming_one_place_are_refused_before_any_work(tmp_path, capsys, no_work, argv, option):
    """`--json x --figures x` failed with a traceback after the whole computation, and `sweep
    --out CONFIG` overwrote the config: refused up front, one line naming the second option."""
    cfg = tmp_path / "c.toml"
    cfg.write_text("[run]\nt_end = 0.1\n")
    dump = tmp_path / "d.dump"
    dump.write_text("not read before the check")
    args = [a.format(x=tmp_path / "x", dump=dump, cfg=cfg) for a in argv]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"error: {option}: " in err[0] and "is also given as" in err[0], err
    assert sorted(os.listdir(tmp_path)) == ["c.toml", "d.dump"]
    assert cfg.read_text() == "[run]\nt_end = 0.1\n"


@pytest.mark.parametrize("extra, words", [
    (["--figure", "{t}/f.txt"], "--figure"),
    (["--scheduler", "tcp://127.0.0.1:1", "--workers", "3"], "--workers"),
    (["--workers", "100000"], "--workers 100000 is outside the valid range"),
    (["--param", "checkpoint_every=0.01,0.02"], "--param checkpoint_every"),
    (["--set", "run.checkpoint_every=0.01"], "--set run.checkpoint_every"),
    (["--set", "a_over_d=0.5", "--set", "tap.a_over_d=0.7"], "given twice"),
])
def test_sweep_refuses_options_without_effect_or_a_bad_figure_up_front(tmp_path, capsys, no_work, extra, words):
    cfg = tmp_path / "c.toml"
    cfg.write_text("[run]\nt_end = 0.1\n")
    args = ["sweep", str(cfg), "--param", "f=10,12", "--out", str(tmp_path / "s.nc")]
    assert main(args + [a.format(t=tmp_path) for a in extra]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0], err
    assert sorted(os.listdir(tmp_path)) == ["c.toml"]


def test_layer_vtk_folder_is_checked_before_the_run(tmp_path, capsys, no_work):
    """A file where a layer run's VTK folder goes failed with a traceback; refused up front."""
    cfg = tmp_path / "l.toml"
    cfg.write_text('[layer]\nkind = "tapped_layer"\ndim = 2\n[output]\nvtk = true\n')
    (tmp_path / "o_vtk").write_text("x")
    assert main(["run", str(cfg), "--out", str(tmp_path / "o.nc")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "output.vtk" in err[0] and "o_vtk is a file" in err[0], err
    assert sorted(os.listdir(tmp_path)) == ["l.toml", "o_vtk"]
