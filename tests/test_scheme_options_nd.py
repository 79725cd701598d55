"""Issue #19: the n-D solver states which scheme options it acts on and refuses every other one
with a one-line error naming it (no option silently ignored); the `accurate` preset is refused
in n-D. The table below must classify every Scheme field, so a new option cannot slip past."""
from dataclasses import fields

import numpy as np
import pytest

from bsrflow.numerics.grid_nd import GridND
from bsrflow.numerics.solver import Scheme
from bsrflow.numerics.solver_nd import SCHEME_OPTIONS_ND, SimulationND
from bsrflow.physics.kernels_nd import BSRModelND, walton_braun_nd
from bsrflow.physics.motion import HalfSineTaps

DX = 0.004

# a valid value away from the default for every Scheme field (with what it needs to be valid)
NON_DEFAULT = {
    "stepper": dict(stepper="rk4"),
    "filter": dict(filter=False, stepper="rk4", cfl=0.2),
    "quadrature": dict(quadrature="boole"),
    "cfl": dict(cfl=0.3),
    "dt": dict(dt=1e-4),
    "tracer_integrator": dict(tracer_integrator="euler"),
    "hyperdiffusion": dict(hyperdiffusion=0.01),
    "positivity": dict(positivity=True),
    "selective_filter": dict(selective_filter=0.02),
    "sensor_dissipation": dict(selective_filter=0.02, sensor_dissipation=0.25),
    "rtol": dict(rtol=1e-3),
    "atol": dict(atol=(1e-5, 1e-5)),
    "name": dict(name="mine"),
    "check_cfl": dict(check_cfl=False),
}


def _sim(scheme):
    model = BSRModelND(walton_braun_nd(2e8, 0.2, 2 * DX), HalfSineTaps(0.002, 10.0, start=0.004), 9.81)
    return SimulationND(model, GridND((8, 8), DX), scheme)


def test_the_table_covers_every_scheme_option():
    assert set(NON_DEFAULT) == {f.name for f in fields(Scheme)}
    assert SCHEME_OPTIONS_ND <= set(NON_DEFAULT)


def _short_run(scheme, t_end=0.004):
    """4 ms of a layer (ρ = 1000 kg/m² below 4.5 cells, modulated along x) with two tracers,
    saves every 2 ms."""
    x = (np.arange(8) + 0.5) * DX
    rho = np.where(x[None, :] < 0.018, 1000.0, 0.0) * (1 + 0.3 * np.cos(2 * np.pi * x[:, None] / 0.032))
    tracers = np.array([[0.01, 0.02], [0.01, 0.012]])
    return _sim(scheme).run(np.zeros((2, 8, 8)), rho, t_end, tracers=tracers, save_every=0.002)


def _acts(option, scheme):
    """What the option does to a run, against the same run with Scheme()'s default."""
    base = _short_run(Scheme())
    run = _short_run(scheme)
    moved = np.abs(run.rho - base.rho).max() / base.rho.max()
    if option == "name":                                # a label: the run is the default's
        assert run.rho.tobytes() == base.rho.tobytes() and _sim(scheme).scheme.name == "mine"
    elif option == "tracer_integrator":                 # the tracers only
        assert run.rho.tobytes() == base.rho.tobytes()
        assert np.abs(run.tracers - base.tracers).max() > 1e-4        # m (measured 1.1e-3)
    elif option == "dt":
        assert run.steps == 40 != base.steps and moved > 1e-3           # 4 ms in 1e-4 s; 0.043
    elif option == "check_cfl":                         # lets a CFL number above the limit through
        with pytest.raises(ValueError, match="above the stability limit"):
            Scheme(cfl=3.0)
        fast = _short_run(Scheme(cfl=3.0, check_cfl=False), t_end=0.0005)
        slow = _short_run(Scheme(), t_end=0.0005)
        assert fast.steps < slow.steps
    elif option == "positivity":                        # acts where the density dips below 0
        unfixed = _short_run(Scheme(stepper="rk4", filter=False, cfl=0.2), t_end=0.002)
        fixed = _short_run(Scheme(stepper="rk4", filter=False, cfl=0.2, positivity=True), t_end=0.002)
        assert unfixed.rho.min() < 0 <= fixed.rho.min()
    else:                                               # stepper, filter, cfl: another run
        assert moved > 1e-4, (option, moved)            # measured 9.2e-4, 0.45, 0.041


@pytest.mark.parametrize("option", sorted(NON_DEFAULT))
def test_every_option_is_used_or_refused(option):
    scheme = Scheme(**NON_DEFAULT[option])
    if option in SCHEME_OPTIONS_ND:
        sim = _sim(scheme)
        assert sim.scheme is scheme
        _acts(option, scheme)
    else:
        with pytest.raises(ValueError) as err:
            _sim(scheme)
        msg = str(err.value)
        unsupported = [k for k in NON_DEFAULT[option] if k not in SCHEME_OPTIONS_ND]   # option first
        assert any(msg.startswith(f"scheme option {k} = ") for k in unsupported), msg
        assert "not supported by the n-D solver" in msg
        assert "\n" not in msg


def test_accurate_preset_is_refused_in_nd_and_named():
    with pytest.raises(ValueError, match="preset 'accurate'"):
        _sim(Scheme.preset("accurate"))


def test_seed_preset_and_default_are_accepted():
    assert _sim(Scheme.preset("seed")).scheme.name == "seed"
    assert _sim(None).scheme.name == "seed"
