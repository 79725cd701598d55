"""TOML configs: defaults and round trip, overrides, and validation of every field before a run
(exit code 2 and one line on stderr naming the field)."""
import math

import numpy as np
import subprocess
import sys

import pytest

from bsrflow.cli import main
from bsrflow.io.config import CFL_LIMITS, Config, ConfigError, default_config_text, load_config, saved_config
from bsrflow.physics.column import ColumnSetup

TINY = {"column": {"n_spheres": 3}, "tap": {"start": 0.02},
        "run": {"t_end": 0.1, "save_every": 0.01}, "numerics": {"points_per_diameter": 4}}


def _lit(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v + '"'
    if isinstance(v, float) and math.isnan(v):
        return "nan"
    if isinstance(v, float) and math.isinf(v):
        return "inf" if v > 0 else "-inf"
    if isinstance(v, list):
        return "[" + ", ".join(_lit(x) for x in v) + "]"
    return repr(v)


def to_toml(d):
    lines = []
    for table, body in d.items():
        if not isinstance(body, dict):
            lines.insert(0, f"{table} = {_lit(body)}")
            continue
        lines.append(f"[{table}]")
        lines += [f"{k} = {_lit(v)}" for k, v in body.items()]
    return "\n".join(lines) + "\n"


def merged(**tables):
    out = {t: dict(b) for t, b in TINY.items()}
    for t, b in tables.items():
        if isinstance(b, dict) and isinstance(out.get(t), dict):
            out[t].update(b)
        else:
            out[t] = b
    return out


# -- defaults, round trip, overrides ------------------------------------------------------------
def test_init_writes_the_defaults_and_load_round_trips(tmp_path, capsys):
    path = tmp_path / "column.toml"
    assert main(["init", str(path)]) == 0
    cfg = load_config(path)
    assert cfg == Config.default()
    assert cfg.column.m0 == 406.0 and cfg.column.kernel_dissipation == 0.9
    # everything else is the package default
    pkg = ColumnSetup(m0=406.0, kernel_dissipation=0.9)
    assert cfg.column_setup().to_dict() == pkg.to_dict()
    assert cfg.scheme().to_dict() == __import__("bsrflow").Scheme.preset("seed").to_dict()
    # checkpoints on by default: every 0.1 s (20 snapshots), on snapshot times; 0 turns them off
    assert cfg.run.checkpoint_every is None and cfg.numerics.cfl is None
    assert cfg.checkpoint_interval() == pytest.approx(0.1)
    assert np.array_equal(cfg.checkpoint_times(), cfg.save_times()[20:-1:20])
    assert cfg.with_overrides({"checkpoint_every": 0.0}).checkpoint_times().size == 0
    long = cfg.with_overrides({"t_end": 1000.0, "save_every": 0.03})        # at most 1000 by default
    assert long.checkpoint_interval() == pytest.approx(1.02) and long.checkpoint_times().size == 980
    assert cfg.with_overrides({"t_end": 0.05}).checkpoint_times().size == 0   # shorter than the interval
    # to_toml -> load gives the same values, also after overrides
    other = cfg.with_overrides({"a_over_d": 0.5, "f": 12, "numerics.cfl": 0.4, "stepper": "bs32",
                                "rtol": 1e-4, "atol": [1e-3, 1e-2], "checkpoint_every": 0.1})
    p2 = tmp_path / "other.toml"
    p2.write_text(other.to_toml())
    assert load_config(p2) == other
    assert "[kg]" in default_config_text() and "valid:" in default_config_text()


def test_init_refuses_to_overwrite_without_force(tmp_path, capsys):
    path = tmp_path / "c.toml"
    path.write_text("# mine\n")
    assert main(["init", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--force" in err[0]
    assert path.read_text() == "# mine\n"
    assert main(["init", str(path), "--force"]) == 0
    assert load_config(path) == Config.default()


def test_packing_config_refuses_the_seed_kernels_constants(tmp_path, capsys):
    """m0 and kernel_dissipation do not enter the packing continuum: a packing config that sets
    them (in its tables or by an override) is refused in one line naming the field, never run with
    them silently ignored; `init --kernel packing` writes a config without them that runs, and an
    override of another field keeps them unset."""
    path = tmp_path / "p.toml"
    assert main(["init", str(path), "--kernel", "packing"]) == 0
    cfg = load_config(path)
    assert cfg.model.kernel == "packing" and cfg.formulation == "lagrangian"
    assert "\nm0 =" not in path.read_text() and "# m0 = 406.0" in path.read_text()
    assert cfg.with_overrides({"a_over_d": 0.5}).tap.a_over_d == 0.5
    for key, val in (("m0", 406.0), ("eps", 0.5), ("column.kernel_dissipation", 0.9)):
        with pytest.raises(ConfigError, match=r"^column\.(m0|kernel_dissipation): .*remove it"):
            cfg.with_overrides({key: val})
    with pytest.raises(ConfigError, match=r"^column\.m0: "):
        Config.from_dict({"column": {"m0": 406.0}, "model": {"kernel": "packing"}})
    seed = tmp_path / "s.toml"                          # the seed's config, switched on the command line
    assert main(["init", str(seed)]) == 0
    capsys.readouterr()
    assert main(["run", str(seed), "--out", str(tmp_path / "x.nc"), "--set", "model.kernel=packing"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "column.m0" in err[0] and not (tmp_path / "x.nc").exists()
    with pytest.raises(ConfigError, match=r"^model\.stiffness_mach: .*give one of the two"):
        Config.from_dict({"model": {"kernel": "packing", "stiffness_mach": 0.01, "stiffness_factor": 1.0}})
    switched = load_config(seed).with_overrides({"kernel": "packing", "m0": None, "eps": None})
    assert switched == cfg
    # an output written before the refusal (a packing config with m0 in its TOML) still reads back
    old = cfg.to_toml().replace("# m0 = 406.0", "m0 = 406.0")
    assert saved_config(old) == cfg


def test_overrides_dotted_short_and_aliases():
    cfg = Config.from_dict(TINY)
    assert cfg.with_overrides({"tap.a_over_d": 0.5}).tap.a_over_d == 0.5
    assert cfg.with_overrides({"a_over_d": 0.25})["tap.a_over_d"] == 0.25
    assert cfg.with_overrides({"f": 5}).tap.frequency == 5.0
    assert cfg.with_overrides({"frequency": 6.0}).tap.frequency == 6.0
    assert cfg.with_overrides({"tap_start": 0.1}).tap.start == 0.1
    c2 = cfg.with_overrides({"cfl": 0.3})
    assert c2.numerics.cfl == 0.3 and c2.scheme().cfl == 0.3
    assert c2.with_overrides({"cfl": None}).numerics.cfl is None
    assert cfg.tap.a_over_d == 0.75                                   # immutable
    with pytest.raises(ConfigError, match=r"^frequncy: unknown key; did you mean tap\.frequency\?"):
        cfg.with_overrides({"frequncy": 1.0})
    with pytest.raises(ConfigError, match=r"^tap\.a_over_d: "):
        cfg.with_overrides({"a_over_d": -1.0})
    with pytest.raises(AttributeError):
        cfg.tap.a_over_d = 1.0


def test_cfl_limits_are_enforced_per_stepper():
    for (stepper, filt), limit in CFL_LIMITS.items():
        scheme = "seed" if filt else "accurate"
        if limit == 0.0:
            with pytest.raises(ConfigError, match="^numerics.stepper: .*unstable"):
                Config.from_dict(merged(numerics={"scheme": scheme, "stepper": stepper}))
            continue
        Config.from_dict(merged(numerics={"scheme": scheme, "stepper": stepper, "cfl": limit}))
        with pytest.raises(ConfigError, match=r"^numerics.cfl: .*stability limit"):
            Config.from_dict(merged(numerics={"scheme": scheme, "stepper": stepper, "cfl": limit * 1.001}))
    # steppers that share another's stability polynomial use its limits (the accurate preset's
    # rk4_0.4_0.25 those of rk4, bs32 those of kutta3)
    for alias, base in (("rk4_0.4_0.25", "rk4"), ("bs32", "kutta3")):
        for scheme, filt in (("seed", True), ("accurate", False)):
            limit = CFL_LIMITS[(base, filt)]
            Config.from_dict(merged(numerics={"scheme": scheme, "stepper": alias, "cfl": limit}))
            with pytest.raises(ConfigError, match=r"^numerics.cfl: .*stability limit"):
                Config.from_dict(merged(numerics={"scheme": scheme, "stepper": alias, "cfl": limit * 1.001}))


# -- invalid configs through `bsrflow run` --------------------------------------------------------
INVALID = [
    # (id, config dict or raw text, field named in the message)
    ("n_spheres_zero", merged(column={"n_spheres": 0}), "column.n_spheres"),
    ("n_spheres_float", merged(column={"n_spheres": 3.0}), "column.n_spheres"),
    ("n_spheres_string", merged(column={"n_spheres": "3"}), "column.n_spheres"),
    ("n_spheres_bool", merged(column={"n_spheres": True}), "column.n_spheres"),
    ("diameter_negative", merged(column={"diameter": -0.01}), "column.diameter"),
    ("diameter_zero", merged(column={"diameter": 0.0}), "column.diameter"),
    ("density_string", merged(column={"density": "heavy"}), "column.density"),
    ("stiffness_zero", merged(column={"stiffness": 0.0}), "column.stiffness"),
    ("restitution_zero", merged(column={"restitution": 0.0}), "column.restitution"),
    ("restitution_above_one", merged(column={"restitution": 1.5}), "column.restitution"),
    ("m0_negative", merged(column={"m0": -406.0}), "column.m0"),
    ("m0_tiny_domain_too_tall", merged(column={"m0": 1e-9}), "column.m0"),
    ("stiffness_seed_settles_below_one_diameter", merged(column={"stiffness": 1e3}), "column.stiffness"),
    ("m0_seed_settles_below_one_diameter", merged(column={"m0": 1e6}), "column.m0"),
    ("kernel_dissipation_one", merged(column={"kernel_dissipation": 1.0}), "column.kernel_dissipation"),
    ("kernel_dissipation_negative", merged(column={"kernel_dissipation": -0.1}), "column.kernel_dissipation"),
    ("gravity_zero", merged(column={"gravity": 0.0}), "column.gravity"),
    ("gravity_nan", merged(column={"gravity": float("nan")}), "column.gravity"),
    ("a_over_d_negative", merged(tap={"a_over_d": -0.5}), "tap.a_over_d"),
    ("a_over_d_inf", merged(tap={"a_over_d": float("inf")}), "tap.a_over_d"),
    ("frequency_zero", merged(tap={"frequency": 0.0}), "tap.frequency"),
    ("tap_start_negative", merged(tap={"start": -1.0}), "tap.start"),
    ("n_taps_negative", merged(tap={"n_taps": -1}), "tap.n_taps"),
    ("n_taps_float", merged(tap={"n_taps": 2.5}), "tap.n_taps"),
    ("period_shorter_than_tap", merged(tap={"n_taps": 2, "period": 0.01}), "tap.period"),
    ("impulses_string", merged(tap={"impulses": "yes"}), "tap.impulses"),
    ("t_end_zero", merged(run={"t_end": 0.0}), "run.t_end"),
    ("t_end_negative", merged(run={"t_end": -1.0}), "run.t_end"),
    ("t_end_array", merged(run={"t_end": [1.0]}), "run.t_end"),
    ("save_every_above_t_end", merged(run={"save_every": 1.0}), "run.save_every"),
    ("save_every_zero", merged(run={"save_every": 0.0}), "run.save_every"),
    ("checkpoint_every_above_t_end", merged(run={"checkpoint_every": 0.5}), "run.checkpoint_every"),
    ("checkpoint_every_negative", merged(run={"checkpoint_every": -0.1}), "run.checkpoint_every"),
    ("scheme_unknown", merged(numerics={"scheme": "fast"}), "numerics.scheme"),
    ("ppd_one", merged(numerics={"points_per_diameter": 1}), "numerics.points_per_diameter"),
    ("ppd_float", merged(numerics={"points_per_diameter": 4.0}), "numerics.points_per_diameter"),
    ("cfl_above_kutta3_filter", merged(numerics={"cfl": 2.5}), "numerics.cfl"),
    ("cfl_above_kutta3_nofilter", merged(numerics={"scheme": "accurate", "stepper": "kutta3", "cfl": 1.8}),
     "numerics.cfl"),
    ("cfl_above_euler_filter", merged(numerics={"stepper": "euler", "cfl": 0.8}), "numerics.cfl"),
    ("cfl_string", merged(numerics={"cfl": "0.5"}), "numerics.cfl"),
    ("euler_without_filter", merged(numerics={"scheme": "accurate", "stepper": "euler"}), "numerics.stepper"),
    ("heun_without_filter", merged(numerics={"scheme": "accurate", "stepper": "heun"}), "numerics.stepper"),
    ("stepper_unknown", merged(numerics={"stepper": "rk5"}), "numerics.stepper"),
    ("rtol_without_embedded_pair", merged(numerics={"scheme": "accurate", "stepper": "rk4", "rtol": 1e-3}),
     "numerics.rtol"),
    ("rtol_zero", merged(numerics={"rtol": 0.0}), "numerics.rtol"),
    ("atol_without_rtol", merged(numerics={"atol": [1e-3, 1e-3]}), "numerics.atol"),
    ("atol_not_a_pair", merged(numerics={"rtol": 1e-3, "atol": [1e-3]}), "numerics.atol"),
    ("domain_below_energy_bound", merged(numerics={"domain_height": 0.05}), "numerics.domain_height"),
    ("unknown_table", merged(taps={"n_taps": 2}), "taps"),
    ("unknown_key", merged(tap={"amplitude": 0.01}), "tap.amplitude"),
    ("misspelt_key", merged(column={"diamter": 0.01}), "column.diamter"),
    ("key_in_wrong_table", merged(tap={"t_end": 1.0}), "tap.t_end"),
    ("key_outside_tables", merged(t_end=1.0), "t_end"),
    ("table_given_a_value", merged(tap=3), "tap"),
    ("toml_syntax_error", "[column]\nn_spheres = 3\nd iameter = 0.02\n", "{path}"),
    ("toml_unclosed_table", "[column\nn_spheres = 3\n", "{path}"),
]
SUGGESTS = {"unknown_table": "did you mean [tap]", "misspelt_key": "did you mean column.diameter",
            "key_in_wrong_table": "run.t_end", "key_outside_tables": "run.t_end",
            "toml_syntax_error": "line 3", "toml_unclosed_table": "line 1",
            "scheme_unknown": "seed", "cfl_above_kutta3_filter": "2.3388", "cfl_above_euler_filter": "0.7071",
            "cfl_above_kutta3_nofilter": "1.7321", "ppd_one": "2 cells",
            "n_spheres_float": "float", "n_spheres_string": "string", "n_spheres_bool": "boolean",
            "kernel_dissipation_one": "[0, 1)", "restitution_zero": "[0.01, 1]",
            "stiffness_seed_settles_below_one_diameter": "[9.052e+04, 1e+12] N/m here: the seed kernel's continuum "
                                                         "would settle under its weight to sqrt(2 N d c0^2/g) = 0.105 d",
            "m0_seed_settles_below_one_diameter": "[1e-12, 6.127e+04] kg"}


def _write(tmp_path, name, cfg):
    path = tmp_path / f"{name}.toml"
    path.write_text(cfg if isinstance(cfg, str) else to_toml(cfg))
    return path


@pytest.mark.parametrize("name, cfg, field", INVALID, ids=[c[0] for c in INVALID])
def test_invalid_config_exit_2_one_line_naming_the_field(tmp_path, capsys, name, cfg, field):
    path = _write(tmp_path, name, cfg)
    field = field.format(path=path)
    code = main(["run", str(path), "--out", str(tmp_path / "out.nc")])
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert code == 2, err
    assert len(lines) == 1, err
    assert lines[0].startswith(f"bsrflow run: error: {field}: "), lines[0]
    if name in SUGGESTS:
        assert SUGGESTS[name] in lines[0], lines[0]
    assert not (tmp_path / "out.nc").exists()                 # nothing ran


def test_at_least_30_distinct_invalid_configs():
    assert len({c[0] for c in INVALID}) >= 30


@pytest.mark.parametrize("argv, field", [
    (["--set", "tap.a_over_d=-1"], "tap.a_over_d"),
    (["--set", "bogus=1"], "bogus"),
    (["--set", "n_spheres=2.5"], "column.n_spheres"),
    (["--set", "stepper=heun", "--scheme", "accurate"], "numerics.stepper"),
    (["--set", "t_end=0.05", "--set", "run.t_end=0.02"], "--set"),            # given twice
    (["--scheme", "seed", "--set", "numerics.scheme=accurate"], "--scheme"),  # contradictory
])
def test_invalid_overrides_on_the_command_line(tmp_path, capsys, argv, field):
    path = _write(tmp_path, "ok", TINY)
    code = main(["run", str(path), "--out", str(tmp_path / "o.nc")] + argv)
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith(f"bsrflow run: error: {field}: "), lines


def test_missing_config_file(tmp_path, capsys):
    path = tmp_path / "nope.toml"
    assert main(["run", str(path)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"bsrflow run: error: {path}: no such config file")


def test_output_directory_missing(tmp_path, capsys):
    path = _write(tmp_path, "ok", TINY)
    assert main(["run", str(path), "--out", str(tmp_path / "no" / "o.nc")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("bsrflow run: error: --out: directory")


@pytest.mark.parametrize("text, field", [
    ("[numerics]\ncfl = 9.0\n", "numerics.cfl"),
    ("[tap]\nfreq = 3.0\n", "tap.freq"),
    ("[run\n", "{path}"),
])
def test_invalid_config_in_a_subprocess(tmp_path, text, field):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    field = field.format(path=path)
    p = subprocess.run([sys.executable, "-m", "bsrflow.cli", "run", str(path)], capture_output=True, text=True,
                       timeout=120)
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 2, p.stderr
    assert len(lines) == 1 and lines[0].startswith(f"bsrflow run: error: {field}: "), p.stderr


def test_config_pickles_for_dask_workers():
    import pickle

    from bsrflow.io.config import Config
    cfg = Config.default().with_overrides({"tap.a_over_d": 0.5})
    back = pickle.loads(pickle.dumps(cfg))
    assert back.to_dict() == cfg.to_dict()
    assert back.tap.a_over_d == 0.5


def test_a_config_that_is_not_utf8_is_named_on_the_command_line(tmp_path, capsys):
    """The check for a [layer] table read the file first and failed with the decoder's message,
    naming no file; now load_config's line, naming the file, is what the user sees."""
    path = tmp_path / "u.toml"
    path.write_bytes(b"[run]\nt_end = 0.05\n# \xff\n")
    assert main(["run", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"error: {path}: invalid TOML: the file is not UTF-8 text" in err[0], err


@pytest.mark.parametrize("tap, t_end, note", [
    ({"start": 0.02}, 0.1, None),
    ({"start": 0.2}, 0.1, "1 of the 1 tap(s) start at or after run.t_end = 0.1 s"),
    ({"start": 0.02, "n_taps": 3, "period": 0.05}, 0.1, "1 of the 3 tap(s) start at or after run.t_end = 0.1 s"),
    ({"start": 0.02, "n_taps": 2, "period": 0.05}, 0.1, None),
    ({"start": 0.2, "n_taps": 0}, 0.1, None),
])
def test_taps_the_run_never_reaches_are_noted(tap, t_end, note):
    """A tap the config sets that starts at or after run.t_end is not silently dropped: `bsrflow
    run` prints the note on stderr (not an error: an init-written file sets every tap field)."""
    cfg = Config.from_dict(merged(tap=tap, run={"t_end": t_end, "save_every": 0.01}))
    got = cfg.taps_not_reached()
    # the default tap (0.4 s) of a config without tap fields: a settling run, nothing to note
    assert Config.from_dict({"run": {"t_end": t_end, "save_every": 0.01}}).taps_not_reached() is None
    if note is None:
        assert got is None
    else:
        assert got.startswith("note: " + note) and "\n" not in got


def test_run_prints_the_taps_note_on_stderr(tmp_path, capsys):
    path = tmp_path / "c.toml"
    path.write_text("[column]\nn_spheres = 3\n[tap]\nstart = 0.2\n[run]\nt_end = 0.02\nsave_every = 0.01\n"
                    "[numerics]\npoints_per_diameter = 4\n")
    assert main(["run", str(path), "--out", str(tmp_path / "c.nc"), "--quiet"]) == 0
    err = capsys.readouterr().err
    assert err.startswith("bsrflow run: note: 1 of the 1 tap(s) start at or after run.t_end = 0.02 s")
