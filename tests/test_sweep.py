"""`bsrflow sweep`: parameter parsing, the configuration adapter, case failures, and a real
two-worker dask LocalCluster sweep of tiny cases."""

import os

import numpy as np
import pytest
import xarray as xr

from bsrflow.numerics.solver import SimulationError
from bsrflow.tools.setup_source import SetupSource, check_given_once
from bsrflow.tools.sweep import make_cases, parse_param, parse_params, run_case, sweep_figure, to_dataset

# tiny cases: 3 spheres, 4 points per diameter, 0.1 s with a tap at 0.02 s (about 0.02 s each,
# plus the solver's compilation on every fresh worker process)
TINY = {"n_spheres": 3, "points_per_diameter": 4, "t_end": 0.1, "tap_start": 0.02, "m0": 400.0}


def test_parse_ranges_and_lists():
    name, v = parse_param("a_over_d=0.25:1.5:11")
    assert name == "a_over_d" and len(v) == 11
    np.testing.assert_allclose(v, np.linspace(0.25, 1.5, 11))
    assert all(type(x) is float for x in v)
    assert parse_param("f=5,10,20") == ("f", [5.0, 10.0, 20.0])          # frequency is a float field
    assert parse_param("n_spheres=2:6:3") == ("n_spheres", [2, 4, 6])    # integer field
    assert parse_param("N=3,5") == ("N", [3, 5])
    assert parse_param("scheme=seed,accurate") == ("scheme", ["seed", "accurate"])
    assert parse_param("impulses=true,false") == ("impulses", [True, False])
    assert parse_param("m0=400:400:1") == ("m0", [400.0])
    assert parse_param(" t_end = 0.5 ") == ("t_end", [0.5])
    params = parse_params(["a_over_d=0.5,1", "f=10,20,30"])
    cases = make_cases(params)
    assert len(cases) == 6
    assert cases[0] == ((0, 0), {"a_over_d": 0.5, "f": 10.0})
    assert cases[-1] == ((1, 2), {"a_over_d": 1.0, "f": 30.0})


@pytest.mark.parametrize("spec, match", [
    ("a_over_d", "is not NAME="),
    ("a_over_d=", "is not NAME="),
    ("=1,2", "is not NAME="),
    ("a_over_d=1:2", "three fields"),
    ("a_over_d=1:2:3:4", "three fields"),
    ("a_over_d=1:2:0", r"NUM must be an integer in \[1, 100000\]"),
    ("a_over_d=1:2:2.5", "NUM must be an integer in"),
    ("a_over_d=0:1:100000000", "NUM must be an integer in"),      # a review's: minutes without a word
    ("a_over_d=x:2:3", "START and STOP must be numbers"),
    ("a_over_d=1:inf:3", "finite"),
    ("a_over_d=1,,2", "empty value"),
    ("a_over_d=1,1", "repeated values"),
    ("n_spheres=1:2:3", "not an integer"),
    ("frequency=ten", "not a number"),
    ("a-b=1", "not a valid parameter name"),
])
def test_malformed_specs(spec, match):
    with pytest.raises(ValueError, match=match):
        parse_param(spec)


def test_repeated_names():
    with pytest.raises(ValueError, match="given twice"):
        parse_params(["f=1,2", "f=3"])
    with pytest.raises(ValueError, match=r"^--param frequency=3 is given twice \(also as f=1,2\); give it once$"):
        parse_params(["f=1,2", "frequency=3"])
    with pytest.raises(ValueError, match="nothing to sweep"):
        parse_params([])
    with pytest.raises(ValueError, match=r"would have 1000000 cases \(1000 × 1000\); valid: at most 100000"):
        parse_params(["a_over_d=0:1:1000", "f=1:2:1000"])


def test_command_rejects_bad_input_with_exit_2(capsys):
    from bsrflow.cli import main

    for argv, match in ((["sweep", "--param", "a_over_d=1:2"], "three fields"),
                        (["sweep", "--param", "bogus=1,2"], "unknown parameter 'bogus'"),
                        (["sweep", "--param", "f=1,2", "--set", "frequency=3"], "also swept"),
                        (["sweep", "--param", "f=1,2", "--set", "m0"], "not NAME=VALUE"),
                        (["sweep", "--param", "f=1,2", "--workers", "0"], "--workers"),
                        (["sweep", "missing.toml", "--param", "f=1,2"], "missing.toml")):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and match in err[0], (argv, err)


def test_fallback_config_reader(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text('n_spheres = 3\n[tap]\nf = 12.5\na_over_d = 1\n[numerics]\nppd = 4\nscheme = "accurate"\n')
    src = SetupSource.load(cfg, use_config_module=False)
    assert not src.uses_config_module and src.text.startswith("n_spheres")
    s = src.column_setup({"m0": 300})
    assert (s.n_spheres, s.frequency, s.a_over_d, s.points_per_diameter, s.scheme, s.m0) == (3, 12.5, 1.0, 4,
                                                                                             "accurate", 300.0)
    assert src.with_fixed({"m0": 200}).column_setup({}).m0 == 200.0
    assert src.with_fixed({"m0": 200}).column_setup({"m0": 100}).m0 == 100.0
    bad = tmp_path / "bad.toml"
    bad.write_text("[tap]\nwobble = 1\n")
    with pytest.raises(ValueError, match="'tap.wobble' is not a column parameter"):
        SetupSource.load(bad, use_config_module=False)
    bad.write_text("n_spheres = \n")
    with pytest.raises(ValueError, match="not valid TOML"):
        SetupSource.load(bad, use_config_module=False)
    bad.write_text("f = 10\n[tap]\nfrequency = 12\n")       # the same parameter in two tables
    with pytest.raises(ValueError, match=r"bad.toml: key tap.frequency is given twice \(also as f\); give it once$"):
        SetupSource.load(bad, use_config_module=False)


def test_check_given_once():
    """One parameter under two names (aliases, table prefixes, =VALUE) is refused with one line
    naming the option and both spellings; distinct parameters pass and are returned by key."""
    given = [("--set", "tap.f=5"), ("--set", "ppd=4"), ("--param", "a_over_d=1,2")]
    assert check_given_once(given) == {"frequency": ("--set", "tap.f=5"), "points_per_diameter": ("--set", "ppd=4"),
                                       "a_over_d": ("--param", "a_over_d=1,2")}
    assert check_given_once([]) == {}
    assert check_given_once(iter([("--set", "f=1")])) == {"frequency": ("--set", "f=1")}   # any iterable
    cases = [
        ([("--set", "numerics.cfl"), ("--set", "numerics.cfl")], "--set numerics.cfl is given twice; give it once"),
        ([("--set", "tap.f=5"), ("--set", "frequency=6")], "--set frequency=6 is given twice (also as tap.f=5); give it once"),
        ([("--set", "f=5"), ("--set", "n=1"), ("--set", "f=5")], "--set f=5 is given twice; give it once"),
        ([("--param", "f=1,2"), ("--set", "frequency=3")],
         "--set frequency=3 is given twice (also as --param f=1,2); give it once"),
        ([("--set", "N = 3"), ("--set", "n_spheres=4")], "--set n_spheres=4 is given twice (also as N = 3); give it once"),
    ]
    for given, message in cases:
        with pytest.raises(ValueError) as err:
            check_given_once(given)
        assert str(err.value) == message
    # the key decides what counts as the same parameter: with str, aliases are distinct
    assert len(check_given_once([("--set", "f=1"), ("--set", "frequency=2")], key=str)) == 2
    with pytest.raises(ValueError, match=r"^--set F=2 is given twice \(also as f=1\)"):
        check_given_once([("--set", "f=1"), ("--set", "F=2")], key=str.lower)


def test_run_case_records_failures(monkeypatch):
    src = SetupSource().with_fixed(TINY)
    r = run_case({"a_over_d": 30.0}, src)
    assert r["status"] == "invalid" and "a_over_d" in r["error"] and np.isnan(r["top_max"])

    import bsrflow.physics.column as column

    def stops(setup, *a, **k):
        raise SimulationError("simulation stopped at t = 0.05 s near x = 0.1 m: density above the bound",
                              None, 0.05, 0.1, "rho_max")

    monkeypatch.setattr(column, "run_bsr_column", stops)
    r = run_case({"a_over_d": 0.5}, src)
    assert r["status"] == "stopped" and r["t_final"] == 0.05 and "density above" in r["error"]

    def breaks(setup, *a, **k):
        raise RuntimeError("boom\nsecond line")

    monkeypatch.setattr(column, "run_bsr_column", breaks)
    r = run_case({"a_over_d": 0.5}, src)
    assert r["status"] == "failed" and r["error"] == "RuntimeError: boom"


def test_dataset_and_figure_with_word_coordinates(tmp_path):
    params = {"scheme": ["seed", "accurate"], "f": [10.0, 20.0]}
    cases = make_cases(params)
    ok = {"status": "ok", "error": "", "top_max": 0.2, "top_max_over_d": 9.0, "t_top_max": 0.6,
          "mass_centre_max": 0.1, "mass_centre_max_over_d": 4.5, "final_mass": 0.1, "mass_drift": 1e-16,
          "t_final": 1.0, "steps": 100, "wall_time": 0.5}
    results = [ok, ok | {"top_max_over_d": 10.0}, ok | {"status": "stopped", "error": "x", "top_max_over_d": np.nan},
               ok | {"top_max_over_d": 11.0}]
    ds = to_dataset(params, cases, results)
    assert ds["top_max_over_d"].dims == ("scheme", "f")
    assert ds["f"].attrs["units"] == "Hz" and ds.attrs["cases_failed"] == 1
    assert list(ds["status"].values.ravel()) == ["ok", "ok", "stopped", "ok"]
    ds.to_netcdf(tmp_path / "s.nc")
    back = xr.open_dataset(tmp_path / "s.nc")
    assert list(back["scheme"].values) == ["seed", "accurate"]
    sweep_figure(back, str(tmp_path / "s.png"))
    assert os.path.getsize(tmp_path / "s.png") > 5000


def test_two_worker_local_cluster_sweep(tmp_path, capsys):
    """3 x 2 = 6 tiny cases on a 2-process LocalCluster, without kernel dissipation at CFL 2.3
    (valid: below the linear limit 2.3388); at a/d = 5 the time step collapses at t = 0.021 s,
    so those 2 cases stop (with the results of their snapshots before the stop); the other 4
    succeed; exit code 3; file and figure.  (A case with an
    invalid value, e.g. a/d = 30, is refused before the cluster starts: test_commands.py.)"""
    from bsrflow.cli import main

    out, fig = tmp_path / "sweep.nc", tmp_path / "sweep.png"
    argv = ["sweep", "--param", "a_over_d=0.5,1,5", "--param", "f=10,12", "--workers", "2",
            "--out", str(out), "--figure", str(fig), "--set", "eps=0", "--set", "cfl=2.3"]
    for k, v in TINY.items():
        argv += ["--set", f"{k}={v}"]
    assert main(argv) == 3
    captured = capsys.readouterr()
    assert "2 of 6 case(s) did not succeed" in captured.err
    assert captured.out.count("] a_over_d=") == 6
    ds = xr.open_dataset(out)
    assert dict(ds.sizes) == {"a_over_d": 3, "f": 2}
    assert ds["a_over_d"].attrs["long_name"] and ds["f"].attrs["units"] == "Hz"
    assert ds["top_max"].attrs["units"] == "m" and ds["t_top_max"].attrs["units"] == "s"
    status = ds["status"].values
    assert (status[:2] == "ok").all() and (status[2] == "stopped").all()
    assert all(e.startswith("simulation stopped at t = 0.021") and "time step collapsed" in e
               for e in ds["error"].values[2])
    assert (ds["error"].values[:2] == "").all()
    ok = ds.isel(a_over_d=slice(0, 2))
    assert np.all(ok["top_max_over_d"] > 1.5) and np.all(ok["steps"] > 0)
    np.testing.assert_allclose(ok["top_max"] / 0.022, ok["top_max_over_d"])
    np.testing.assert_allclose(ok["t_final"], 0.1)
    assert np.all(ok["mass_drift"] < 1e-12)
    # a stopped case keeps the results of its snapshots before the stop (no NaN) and its steps
    stopped = ds.isel(a_over_d=2)
    assert np.isfinite(stopped["top_max"].values).all() and (stopped["top_max"].values > 0).all()
    assert np.all((stopped["t_final"].values >= 0.021) & (stopped["t_final"].values < 0.022))   # the stop
    assert (stopped["steps"].values > 0).all() and np.all(stopped["mass_drift"].values < 1e-12)
    # tapping harder throws the column higher
    assert np.all(ok["top_max_over_d"].values[1] > ok["top_max_over_d"].values[0])
    assert ds.attrs["cases"] == 6 and ds.attrs["cases_ok"] == 4 and "LocalCluster" in ds.attrs["scheduler"]
    assert os.path.getsize(fig) > 10000


def test_adapter_uses_the_config_module_interface(tmp_path, monkeypatch):
    """With a module bsrflow.io.config providing load_config(path) -> Config,
    Config.with_overrides(dict) -> Config and Config.column_setup() -> ColumnSetup, the adapter
    goes through it (a stand-in module here; the real one is being written)."""
    import sys
    import types

    from bsrflow.physics.column import ColumnSetup

    calls = []

    class Config:
        def __init__(self, values):
            self.values = values

        def with_overrides(self, overrides):
            calls.append(dict(overrides))
            unknown = set(overrides) - set(ColumnSetup.__dataclass_fields__)
            if unknown:
                raise KeyError(f"unknown key {sorted(unknown)[0]}")
            return Config(self.values | overrides)

        def column_setup(self):
            return ColumnSetup(**self.values)

    fake = types.ModuleType("bsrflow.io.config")
    fake.load_config = lambda path: Config({"n_spheres": 4, "m0": 300.0})
    monkeypatch.setitem(sys.modules, "bsrflow.io.config", fake)
    cfg = tmp_path / "c.toml"
    cfg.write_text("# whatever the config module reads\n")
    src = SetupSource.load(cfg)
    assert src.uses_config_module
    s = src.column_setup({"f": 12, "a_over_d": 1})
    assert (s.n_spheres, s.m0, s.frequency, s.a_over_d) == (4, 300.0, 12.0, 1.0)
    assert calls[-1] == {"frequency": 12.0, "a_over_d": 1.0}             # aliases resolved
    with pytest.raises(ValueError, match="unknown parameter 'bogus'"):
        src.check_names({"bogus": 1})
    src.check_names({"a_over_d": 99.0})       # a bad value is left to the case, not a name error
    r = run_case({"a_over_d": 99.0}, src)
    assert r["status"] == "invalid" and "a_over_d" in r["error"]


def test_connects_to_a_running_scheduler():
    """--scheduler ADDRESS: the sweep uses an existing cluster (here an in-process one; both
    cases are invalid, so nothing needs compiling) and leaves it running."""
    import logging

    from dask.distributed import LocalCluster

    from bsrflow.tools.sweep import run_sweep

    with LocalCluster(n_workers=1, processes=False, dashboard_address=None, silence_logs=logging.ERROR) as cluster:
        ds = run_sweep({"a_over_d": [30.0, 40.0]}, SetupSource().with_fixed(TINY),
                       scheduler=cluster.scheduler_address, log=None)
        assert cluster.scheduler is not None and cluster.status.name == "running"
    assert list(ds["status"].values) == ["invalid", "invalid"]
    assert ds.attrs["scheduler"] == cluster.scheduler_address and ds.attrs["cases_failed"] == 2


def test_adapter_with_the_real_config_module():
    """The same through bsrflow.io.config itself (being written alongside; skipped without it)."""
    from bsrflow.tools.setup_source import config_module

    if config_module() is None:
        pytest.skip("bsrflow.io.config is not there yet")
    src = SetupSource.load(None)                      # Config.default(): what `bsrflow init` writes
    assert src.uses_config_module and src.text
    setup, scheme = src.setup_and_scheme({"f": 12, "tap_start": 0.1, "n_spheres": 4})
    assert (setup.frequency, setup.tap_start, setup.n_spheres) == (12.0, 0.1, 4)
    with pytest.raises(ValueError, match="unknown parameter 'bogus'"):
        src.check_names({"bogus": 1})
    src.check_names({"a_over_d": 99.0, "tap.start": 0.2, "numerics.cfl": 0.3})
    setup, scheme = src.setup_and_scheme({"numerics.cfl": 0.3})
    assert scheme is not None and scheme.cfl == 0.3        # scheme overrides reach the run
    r = run_case({"a_over_d": 99.0}, src)
    assert r["status"] == "invalid" and "a_over_d" in r["error"]
    # dask pickles the source for its workers
    import pickle

    import cloudpickle

    for dumps in (pickle.dumps, cloudpickle.dumps):
        back = pickle.loads(dumps(src.with_fixed({"m0": 300.0})))
        assert back.uses_config_module and back.column_setup({"f": 12}).m0 == 300.0
        assert back.setup_and_scheme({"f": 12})[0] == src.setup_and_scheme({"f": 12, "m0": 300.0})[0]


def test_an_interrupted_sweep_writes_its_finished_cases(tmp_path, monkeypatch, capsys):
    """Ctrl-C after the first finished case (the interrupt raised in the loop over the finished
    futures): exit 130, one line, and --out holds that case's results with the others marked
    "interrupted" (before, every finished case was lost)."""
    import dask.distributed
    import xarray as xr

    from bsrflow.cli import main

    real = dask.distributed.as_completed

    def one_then_interrupt(futures):
        it = iter(real(futures))
        yield next(it)
        raise KeyboardInterrupt()

    monkeypatch.setattr(dask.distributed, "as_completed", one_then_interrupt)
    real_cluster = dask.distributed.LocalCluster                # in-process workers, and a case that
    monkeypatch.setattr(dask.distributed, "LocalCluster",       # needs no solver (the interrupt is tested)
                        lambda **kw: real_cluster(**{**kw, "processes": False}))
    import bsrflow.tools.sweep as sweep

    def quick_case(overrides, source=None):
        res = sweep._empty_result("ok", "")
        res.update(top_max=0.5, top_max_over_d=22.0, t_top_max=0.6, steps=1, wall_time=0.0)
        return res

    monkeypatch.setattr(sweep, "run_case", quick_case)
    out = tmp_path / "s.nc"
    args = ["sweep", "--param", "a_over_d=0.5,0.75,1.0", "--workers", "1", "--out", str(out)]
    for k, v in TINY.items():
        args += ["--set", f"{k}={v}"]
    code = main(args)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 130 and len(err) == 1, err
    assert err[0] == (f"bsrflow sweep: interrupted by Ctrl-C (SIGINT) after 1 of 3 cases: {out} keeps the "
                      "finished cases' results (the others have status \"interrupted\"; run them again)"), err[0]
    with xr.open_dataset(out) as ds:
        status = list(ds["status"].values)
        assert sorted(status) == ["interrupted", "interrupted", "ok"], status
        assert ds.attrs["interrupted"] == "after 1 of 3 cases" and ds.attrs["cases_ok"] == 1
        assert np.isfinite(ds["top_max"].values[status.index("ok")])


def test_sweep_refuses_checkpoint_every_from_its_config_file(tmp_path, capsys):
    """Sweep cases write no checkpoints: `run.checkpoint_every` in the sweep's config file is refused
    in one line (exit 2, nothing written) as `--set run.checkpoint_every=...` is; it was ignored."""
    from bsrflow.cli import main
    cfg = tmp_path / "s.toml"
    cfg.write_text("[run]\nt_end = 0.05\ncheckpoint_every = 0.01\n")
    out = tmp_path / "sw.nc"
    assert main(["sweep", str(cfg), "--param", "tap.a_over_d=0.5,1.0", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"run.checkpoint_every = 0.01 in {cfg}" in err[0] and "no checkpoints" in err[0], err
    assert not out.exists()
    assert main(["sweep", str(cfg), "--param", "tap.a_over_d=0.5,1.0", "--set", "run.checkpoint_every=0.02",
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--set run.checkpoint_every" in err[0] and "no checkpoints" in err[0], err


@pytest.mark.parametrize("spec, expected", [
    ("a_over_d=abc", "a_over_d = 'abc' is not a number; valid range [0, 20]"),
    ("tap.a_over_d=0.5,abc", "tap.a_over_d = 'abc' is not a number; valid range [0, 20]"),
    ("n_spheres=abc", "n_spheres = 'abc' is not an integer; valid range [2, 100000] (integers)"),
    ("a_over_d=x:1:3", "START and STOP must be numbers; valid range [0, 20]"),
    ("f=10,abc", "f = 'abc' is not a number; valid range [0.001, 10000] Hz"),
    ("tap.f=abc", "tap.f = 'abc' is not a number; valid range [0.001, 10000] Hz"),
    ("column.N=abc", "column.N = 'abc' is not an integer; valid range [2, 100000] (integers)"),
    ("model.eps=abc", "model.eps = 'abc' is not a number; valid range [0, 1)"),
    ("scheme=x:1:3", "START and STOP must be numbers"),              # a word field: no numeric range
    ("impulses=abc", "impulses = 'abc' is not true or false"),
])
def test_a_value_that_is_not_a_number_names_the_parameters_valid_range(spec, expected):
    """`--param NAME=abc` named no range while an out-of-range number did (an audit, 2026-12-06)."""
    with pytest.raises(ValueError) as info:
        parse_param(spec)
    assert str(info.value) == f"--param {spec!r}: {expected}"
