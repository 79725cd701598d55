"""The packing continuum in the package's workflow (issue #18): config fields, `bsrflow run` output
and restart with the history field, the comparison's JSON, the two formulations against each other
and against the DEM, the stiffness option's documented bound.

Small columns and coarse resolutions keep this fast; the numbers of the README and docs/packing-column.md come from
`bsrflow compare --kernel packing` and the bench scripts, not from here.
"""
import json
import math

import numpy as np
import pytest
import xarray as xr

from bsrflow.analysis.compare import run_dem_column
from bsrflow.analysis.compare_packing import PACKING_CASES, compare_packing
from bsrflow.cli import main
from bsrflow.io.config import Config, ConfigError
from bsrflow.io.runner import run_config
from bsrflow.numerics.solver import SimulationError
from bsrflow.physics.column import (STIFFNESS_ERROR_BOUNDS, ColumnSetup, impact_mach, run_bsr_column,
                                    stiffness_model, suggest_stiffness_factor)

SMALL = dict(kernel_name="packing", n_spheres=6, diameter=0.022, a_over_d=0.75, tap_start=0.05, t_end=0.35,
             points_per_diameter=4, save_every=0.005)


def _top_peak(run, s):
    k = int(np.argmax(np.where(run.t >= s.tap_start, run.top, -np.inf)))
    return run.top[k] / s.diameter, run.t[k]


@pytest.mark.parametrize("form,rng", [("eulerian", None), ("eulerian", 0.0), ("lagrangian", None), ("lagrangian", 0.0)])
def test_small_column_mass_positivity_and_flight(form, rng):
    s = ColumnSetup(**SMALL, formulation=form, range_over_d=rng)
    r = run_bsr_column(s)
    assert r.info["status"] == "ok"
    assert np.max(np.abs(r.mass / r.mass[0] - 1)) < 1e-12
    assert r.rho.min() >= 0.0
    assert np.all(np.isfinite(r.rho)) and np.all(np.isfinite(r.u))
    top, t = _top_peak(r, s)
    assert top > r.top[0] / s.diameter + 2.0          # the tap throws the top sphere up by several d
    # tracers: one per sphere centre, ordered, the top sphere last
    assert r.tracers.shape[1] == s.n_spheres
    assert np.all(np.diff(r.tracers, axis=1) > 0)
    assert np.allclose(r.tracers[0] / s.diameter, np.arange(s.n_spheres) + 0.5, atol=1e-3)


def test_formulations_agree_and_follow_the_dem_mass_centre():
    # the seed's column (20 spheres, d = 2.2 cm) at 5 points per diameter, the coarsest grid of
    # the convergence table, with the tap early and the run ending after the peak: the local
    # limit in both formulations agrees within 2 %; the nonlocal interaction (the Lagrangian
    # default) throws the top sphere higher, to within 3 % of the DEM's
    s = ColumnSetup(**(SMALL | dict(n_spheres=20, points_per_diameter=5, tap_start=0.1, t_end=0.5)))
    runs = {f: run_bsr_column(s.with_(formulation=f, range_over_d=0.0)) for f in ("eulerian", "lagrangian")}
    runs["nonlocal"] = run_bsr_column(s.with_(formulation="lagrangian"))
    tops = {f: _top_peak(r, s)[0] for f, r in runs.items()}
    assert abs(tops["eulerian"] / tops["lagrangian"] - 1) < 0.02
    t_d, pos, _ = run_dem_column(s)
    dem_top = pos[t_d >= s.tap_start, -1].max() / s.diameter
    assert tops["nonlocal"] > tops["lagrangian"]
    assert abs(tops["nonlocal"] / dem_top - 1) < 0.03
    for r in runs.values():
        rms = np.sqrt(np.mean(((np.interp(t_d, r.t, r.mass_centre) - pos.mean(axis=1)) / s.diameter) ** 2))
        assert rms < 0.5


@pytest.mark.parametrize("form,rng", [("lagrangian", None), ("lagrangian", 0.0), ("eulerian", None), ("eulerian", 0.0)])
def test_stiffness_option_within_its_documented_bound(form, rng):
    s = ColumnSetup(**(SMALL | dict(n_spheres=20, t_end=0.9, tap_start=0.1)), formulation=form, range_over_d=rng)
    phi = suggest_stiffness_factor(s)
    assert 0.0 < phi < 0.5                              # a real reduction here
    reduced = s.with_(stiffness_factor=phi)
    assert math.isclose(impact_mach(reduced), 0.01, rel_tol=1e-9)
    true, red = run_bsr_column(s), run_bsr_column(reduced)
    assert red.steps < 0.8 * true.steps
    t0, t1 = _top_peak(true, s)[0], _top_peak(red, s)[0]
    bound = STIFFNESS_ERROR_BOUNDS[stiffness_model(s)]
    assert abs(t1 / t0 - 1) <= bound["top_max_rel"]
    rms = np.sqrt(np.mean(((np.interp(true.t, red.t, red.mass_centre) - true.mass_centre) / s.diameter) ** 2))
    assert rms <= bound["mass_centre_rms_over_d"]
    assert suggest_stiffness_factor(s, mach=1e-9) == 1.0     # never stiffer than the contact law
    with pytest.raises(ValueError, match="mach"):
        suggest_stiffness_factor(s, mach=0.0)


def test_compare_json_has_no_fitted_constants(tmp_path):
    case = dict(name="small", diameter=0.022, a_over_d=0.75, n_taps=1)
    base = ColumnSetup(n_spheres=6, points_per_diameter=4, tap_start=0.05)
    res = compare_packing(base, cases=[case], models=(("lagrangian", 1.0), ("lagrangian", 0.0)),
                          figures=str(tmp_path / "fig"), log=None)
    assert res["fitted_constants"] == {}
    assert res["calibration"] is None
    for key in ("d", "scheme", "cases", "setup", "wall_time_s", "figures"):
        assert key in res
    c = res["cases"][0]
    for key in ("name", "a_over_d", "taps", "calibrated_on", "bsr", "dem", "mass_centre_rms_over_d",
                "top_max_rel_diff", "t_top_max_rel_diff", "rise_rel_diff", "formulation", "range_over_d", "model"):
        assert key in c
    assert c["calibrated_on"] is False
    assert [(e["model"], e["range_over_d"]) for e in res["cases"]] == [("lagrangian R=1d", 1.0),
                                                                       ("lagrangian local", 0.0)]
    assert {"small_density.png", "small_trajectories.png", "small_top_centre.png"} <= set(res["figures"])
    json.dumps(res)                                        # JSON-ready


def test_case_list_is_the_issues():
    names = {c["name"] for c in PACKING_CASES}
    assert len(PACKING_CASES) == 14
    for d in (5, 10, 22):
        for a in (0.5, 0.75, 1.0, 1.5):
            assert f"d{d}mm_a{a}" in names
    three = [c for c in PACKING_CASES if c["n_taps"] == 3]
    assert {c["a_over_d"] for c in three} == {0.75, 1.0}
    assert all(c["tap_period"] == 1.0 and c["diameter"] == 0.022 for c in three)


def test_config_fields_and_refusals():
    c = Config.default().with_overrides({"model.kernel": "packing", "numerics.formulation": "lagrangian"})
    s = c.column_setup()
    assert (s.kernel_name, s.formulation) == ("packing", "lagrangian")
    auto = c.with_overrides({"model.stiffness_mach": 0.01}).column_setup()
    assert auto.stiffness_factor == pytest.approx(suggest_stiffness_factor(s, 0.01))
    # both formulations take the reduced stiffness (each with its documented bound)
    assert ColumnSetup(kernel_name="packing", formulation="eulerian", stiffness_factor=0.5).stiffness_factor == 0.5
    eul = Config.default().with_overrides({"model.kernel": "packing", "numerics.formulation": "eulerian",
                                           "model.stiffness_mach": 0.01}).column_setup()
    assert eul.formulation == "eulerian" and eul.stiffness_factor == pytest.approx(suggest_stiffness_factor(eul, 0.01))
    # defaults: a packing config is the Lagrangian formulation with R = d; the Eulerian one is local
    dflt = Config.default().with_overrides({"model.kernel": "packing"}).column_setup()
    assert (dflt.formulation, dflt.interaction_range()) == ("lagrangian", 1.0)
    assert eul.interaction_range() == 1.0                 # the nonlocal interaction in both formulations
    assert Config.default().column_setup().formulation == "eulerian"           # the seed kernel's
    local = Config.default().with_overrides({"model.kernel": "packing", "model.range_over_d": 0.0}).column_setup()
    assert local.packing_law().range_over_d == 0.0
    for over, field in [({"model.kernel": "nope"}, "model.kernel"),
                        ({"numerics.formulation": "lagrangian"}, "numerics.formulation"),
                        ({"model.stiffness_factor": 0.5}, "model.stiffness_factor"),
                        ({"model.kernel": "packing", "numerics.scheme": "accurate"}, "numerics.scheme"),
                        ({"model.kernel": "packing", "numerics.stepper": "rk4"}, "numerics.stepper"),
                        ({"model.kernel": "packing", "numerics.formulation": "eulerian", "numerics.cfl": 0.6},
                         "numerics.cfl"),
                        ({"model.kernel": "packing", "numerics.cfl": 0.95}, "numerics.cfl"),
                        ({"model.kernel": "packing", "model.stiffness_factor": 1.5}, "model.stiffness_factor"),
                        ({"model.kernel": "packing", "model.stiffness_factor": 0.5, "model.stiffness_mach": 0.01},
                         "model.stiffness_mach"),
                        ({"model.stiffness_mach": 0.01}, "model.stiffness_mach"),
                        ({"model.range_over_d": 1.0}, "model.range_over_d"),
                        ({"model.kernel": "packing", "model.range_over_d": 5.0}, "model.range_over_d"),
                        ({"model.kernel": "packing", "numerics.formulation": "eulerian", "model.range_over_d": 0.05},
                         "model.range_over_d")]:
        with pytest.raises(ConfigError) as exc:
            Config.default().with_overrides(over)
        assert str(exc.value).startswith(field), (over, str(exc.value))


def test_compare_on_worker_processes_gives_the_same_numbers(tmp_path):
    """`compare_packing(workers=2)` (`bsrflow compare --kernel packing --workers 2`) runs the continuum's
    cases on two processes: the same entries in the same order, equal but for the wall times; a run a
    monitor stops there is reported as in the serial loop, with the finished cases kept."""
    cases = [dict(name="small", diameter=0.022, a_over_d=0.75, n_taps=1),
             dict(name="small_b", diameter=0.022, a_over_d=1.0, n_taps=1)]
    base = ColumnSetup(n_spheres=6, points_per_diameter=4, tap_start=0.05)
    models = (("lagrangian", 1.0), ("lagrangian", 0.0))

    def no_walls(x):
        if isinstance(x, dict):
            return {k: no_walls(v) for k, v in x.items() if k not in ("wall_s", "wall_time_s")}
        return [no_walls(v) for v in x] if isinstance(x, list) else x
    serial = compare_packing(base, cases=cases, models=models, log=None)
    parallel = compare_packing(base, cases=cases, models=models, log=None, workers=2)
    assert no_walls(parallel) == no_walls(serial)
    # a tap of 20 d on a contact 1000 times too soft: points cross, the monitor stops the run
    soft = base.with_(kernel_name="packing", stiffness_factor=1e-3)
    hard_taps = [dict(case, a_over_d=20.0) for case in cases]
    for workers in (1, 2):
        with pytest.raises(SimulationError, match="case small, lagrangian R=1d: material points crossed") as info:
            compare_packing(soft, cases=hard_taps, models=models, log=None, workers=workers)
        assert info.value.partial["cases"] == []


def test_cli_unknown_kernel_and_formulation_exit_2(tmp_path, capsys):
    cfg = tmp_path / "col.toml"
    assert main(["init", str(cfg)]) == 0
    for opt in ("model.kernel=foo", "numerics.formulation=bar"):
        rc = main(["run", str(cfg), "--out", str(tmp_path / "x.nc"), "--quiet", "--set", opt])
        err = capsys.readouterr().err.strip().splitlines()
        assert rc == 2 and len(err) == 1 and opt.split("=")[0] in err[0]
    assert main(["compare", "--kernel", "foo"]) == 2
    assert main(["compare", "--kernel", "packing", "--formulation", "upwind"]) == 2
    assert main(["compare", "--kernel", "packing", "--models", "eulerian:9"]) == 2
    assert "--models" in capsys.readouterr().err
    assert main(["compare", "--kernel", "packing", "--models", "upwind:0"]) == 2
    assert main(["compare", "--kernel", "packing", "--models", "lagrangian:x"]) == 2
    assert main(["compare", "--models", "lagrangian:1"]) == 2                # a packing-only option
    assert main(["compare", "--kernel", "packing", "--models", "lagrangian:1,lagrangian:1.0"]) == 2
    assert "twice" in capsys.readouterr().err
    assert main(["compare", "--kernel", "packing", "--models", "lagrangian:1", "--formulation", "eulerian"]) == 2
    assert "--formulation" in capsys.readouterr().err
    assert main(["compare", "--kernel", "packing", "--models", "lagrangian:0.05"]) == 2   # not a whole spacing
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--models" in err[0] and "range_over_d" in err[0]
    assert main(["compare", "--kernel", "packing", "--cases", "nosuch"]) == 2
    assert main(["compare", "--formulation", "eulerian"]) == 2       # a packing-only option
    assert main(["compare", "--kernel", "packing", "--stiffness-factor", "2"]) == 2
    assert "--stiffness-factor" in capsys.readouterr().err
    assert main(["compare", "--kernel", "packing", "--workers", "0"]) == 2
    assert "--workers 0 is outside the valid range [1, " in capsys.readouterr().err
    assert main(["compare", "--workers", "2"]) == 2                   # a packing-only option
    assert "--workers is an option of --kernel packing only" in capsys.readouterr().err
    assert not (tmp_path / "x.nc").exists()


@pytest.mark.parametrize("form,rng", [("eulerian", None), ("eulerian", 0.0), ("lagrangian", None), ("lagrangian", 0.0)])
def test_run_output_and_restart_bit_for_bit(tmp_path, form, rng):
    over = {"model.kernel": "packing", "numerics.formulation": form, "column.n_spheres": 6,
            "tap.start": 0.05, "run.t_end": 0.3, "run.save_every": 0.01, "run.checkpoint_every": 0.05,
            "numerics.points_per_diameter": 4}
    if rng is not None:
        over["model.range_over_d"] = rng
    cfg = Config.default().with_overrides(over)
    full = run_config(cfg, tmp_path / "full.nc")
    assert full.status == "ok"
    with xr.open_dataset(tmp_path / "full.nc") as ds:
        a = ds.load()
    assert a.attrs["kernel"] == "packing" and a.attrs["formulation"] == form
    assert a.attrs["range_over_d"] == (1.0 if rng is None else rng)
    assert a["tracer_height"].shape == (31, 6) and a["tracer_height"].attrs["units"] == "m"
    assert np.allclose(a["top"].values, a["tracer_height"].values[:, -1])
    assert a["mass_centre"].attrs["units"] == "m"

    class Stop(Exception):
        pass

    def stop_late(t):
        if t > 0.17:
            raise Stop()

    with pytest.raises(Stop):
        run_config(cfg, tmp_path / "part.nc", progress=stop_late)
    assert (tmp_path / "part.nc.ckpt").exists()
    from bsrflow.io.checkpoint import read_checkpoint
    fields = read_checkpoint(tmp_path / "part.nc.ckpt").fields
    hist = fields["delta_max" if form == "lagrangian" or rng is None else "rho_delta_max"]
    # the nonlocal default keeps one history per bond: (L, points), L = ppd R/d = 4; on the
    # staggered grid (L + 2, faces + 1), the surface's bonds being one or two lags longer
    if (form, rng) == ("lagrangian", None):
        assert hist.shape == (4, 24)
    elif rng is None:
        assert hist.shape == (6, fields["cell_mass"].size + 2)
    else:
        assert hist.ndim == 1
    resumed = run_config(cfg, tmp_path / "part.nc", resume=True)
    assert resumed.resumed_from == pytest.approx(0.15)
    with xr.open_dataset(tmp_path / "part.nc") as ds:
        b = ds.load()
    for k in ("rho", "u", "tracer_height", "mass_centre", "top", "kinetic_energy"):
        assert np.array_equal(a[k].values, b[k].values), k
    assert int(a.attrs["steps"]) == int(b.attrs["steps"])


def test_sweep_and_compare_dump_take_packing_configs():
    """The setups of `bsrflow sweep` and `compare-dump` come from SetupSource: a packing config gives
    no seed scheme, and a sweep case runs (the packing's schemes are its formulation's)."""
    from bsrflow.tools.setup_source import SetupSource
    from bsrflow.tools.sweep import run_case
    src = SetupSource.load().with_fixed({"model.kernel": "packing", "numerics.formulation": "lagrangian",
                                         "column.n_spheres": 4, "numerics.points_per_diameter": 3,
                                         "tap.start": 0.05, "run.t_end": 0.2})
    setup, scheme = src.setup_and_scheme({"tap.a_over_d": 0.5})
    assert setup.kernel_name == "packing" and scheme is None
    r = run_case({"tap.a_over_d": 0.5}, src)
    assert r["status"] == "ok", r
    seed_setup, seed_scheme = SetupSource.load().setup_and_scheme({})
    assert seed_setup.kernel_name == "seed" and seed_scheme is not None


@pytest.mark.parametrize("kw, name, why", [
    (dict(stiffness=100.0), "stiffness", "overlap its bottom contact by 0.597 d"),
    (dict(stiffness_factor=1e-12), "stiffness_factor", "overlap its bottom contact"),
    (dict(stiffness=2000.0, stiffness_factor=0.1), "stiffness_factor", "overlap its bottom contact by 0.298 d"),
    (dict(stiffness=500.0, stiffness_factor=0.5), "stiffness", "(× stiffness_factor 0.5)"),
    (dict(stiffness=1e12, t_end=100.0), "stiffness", "time steps"),
    (dict(formulation="lagrangian", restitution=1.0, cfl=0.5), "cfl", "with restitution = 1"),
])
def test_packing_column_refuses_a_contact_it_cannot_run_up_front(kw, name, why):
    """A packing column whose weight alone would overlap its bottom contact by more than 5 % of d
    (material points crossed later, at run time), one that would need more than 1e9 steps, and
    the elastic Lagrangian form above its energy-conserving cfl are refused when set up, with
    the valid range; the ends of the stated stiffness range are accepted."""
    import re
    base = dict(kernel_name="packing", formulation="eulerian")
    base.update(kw)
    with pytest.raises(ValueError, match=re.escape(why)) as info:
        ColumnSetup(**base)
    msg = str(info.value)
    assert msg.startswith(f"{name} = ") and "valid range" in msg and "\n" not in msg
    if name != "cfl":
        lo, hi = (float(v) for v in re.search(r"\[([^,]+), ([^\]]+)\]", msg).groups())
        for v in (lo * 1.01, hi * 0.99):
            ColumnSetup(**{**base, name: v})


@pytest.mark.parametrize("formulation, range_over_d, restitution, cls_name, cfl", [
    ("eulerian", None, 0.9, "StaggeredEulerianPacking", 0.25),
    ("eulerian", 0, 0.9, "EulerianPacking", 0.4),
    ("lagrangian", None, 0.9, "LagrangianPacking", 0.5),
    ("lagrangian", None, 1.0, "LagrangianPacking", 0.25),
])
def test_default_cfl_is_the_discretisations_own(formulation, range_over_d, restitution, cls_name, cfl):
    """The CFL number a column runs with by default is its discretisation's ``default_cfl``, the
    one the set-up's stiffness check counts the steps with (not a copy of its value)."""
    setup = ColumnSetup(kernel_name="packing", formulation=formulation, range_over_d=range_over_d,
                        restitution=restitution)
    cls = setup.packing_class()
    assert cls.__name__ == cls_name
    assert cls.default_cfl(restitution) == cfl
    assert setup.packing_discretisation().cfl == cfl
