"""Issue #19: the n-D solver states which scheme options it acts on and refuses every other one
with a one-line error naming it (no option silently ignored); the `accurate` preset is refused
in n-D. The table below must classify every Scheme field, so a new option cannot slip past."""
from dataclasses import fields

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


@pytest.mark.parametrize("option", sorted(NON_DEFAULT))
def test_every_option_is_used_or_refused(option):
    scheme = Scheme(**NON_DEFAULT[option])
    if option in SCHEME_OPTIONS_ND:
        sim = _sim(scheme)
        assert sim.scheme is scheme
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
