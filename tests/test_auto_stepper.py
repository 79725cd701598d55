"""The stepper 'auto' (the 'accurate' preset's): RK4 for kernels smooth in the velocities,
Kutta's RK3 for kernels with the friction switch and for adaptive steps."""
import numpy as np
import pytest

from bsrflow import Grid1D, Simulation
from bsrflow.analysis import verify
from bsrflow.io.config import Config
from bsrflow.numerics.solver import Scheme
from bsrflow.numerics.steppers import get_stepper, resolve_stepper
from bsrflow.physics.column import ColumnSetup
from bsrflow.physics.kernels import Kernel, walton_braun, zero_kernel
from bsrflow.physics.kernels_nd import walton_braun_nd
from bsrflow.physics.model import BSRModel


def test_resolve_stepper_rule():
    assert resolve_stepper("auto", True) == "rk4"
    assert resolve_stepper("auto", False) == "kutta3"
    assert resolve_stepper("auto", True, adaptive=True) == "kutta3"
    for name in ("euler", "heun", "kutta3", "rk3", "rk4", "bs32"):
        assert resolve_stepper(name, True) == resolve_stepper(name, False) == name
    with pytest.raises(ValueError, match="auto"):
        resolve_stepper("rk5", True)
    with pytest.raises(ValueError, match="resolve"):
        get_stepper("auto")


def test_kernel_smoothness_follows_its_parameters():
    k = walton_braun(1e3, 0.0, 0.02)
    assert k.is_smooth_in_velocity() and zero_kernel().is_smooth_in_velocity()
    k.params[1] = 0.5                    # parameters are runtime values (sweeps change them)
    assert not k.is_smooth_in_velocity()
    assert not Kernel(lambda z, a, b, p: 0.0 * z, [0.0], 0.02).is_smooth_in_velocity()   # user default
    assert walton_braun_nd(1e3, 0.0, 0.02).is_smooth_in_velocity()
    assert not walton_braun_nd(1e3, 0.1, 0.02).is_smooth_in_velocity()


def test_simulation_resolves_auto_per_model():
    g = Grid1D(0.0, 1.0, 64, "periodic", "periodic")
    acc = Scheme.preset("accurate")
    assert acc.stepper == "auto"
    assert Simulation(verify.smooth_model(), g, acc).stepper == "rk4"
    assert Simulation(verify.smooth_model(0.3), g, acc).stepper == "kutta3"
    assert Simulation(BSRModel(), g, acc).stepper == "rk4"
    adaptive = Scheme.preset("accurate", rtol=1e-3)
    assert Simulation(verify.smooth_model(), g, adaptive).stepper == "kutta3"
    assert Simulation(verify.smooth_model(), g, Scheme.preset("seed")).stepper == "kutta3"
    # the tapped column (ε > 0): the preset runs Kutta's RK3
    s = ColumnSetup(points_per_diameter=4)
    assert Simulation(s.model(), s.grid(), acc).stepper == "kutta3"


def test_auto_is_exactly_the_resolved_stepper():
    g = Grid1D(0.0, 1.0, 64, "periodic", "periodic")
    u0, r0 = verify.smooth_initial(g.x)
    for m, name in ((verify.smooth_model(), "rk4"), (verify.smooth_model(0.3), "kutta3")):
        a = Simulation(m, g, Scheme.preset("accurate")).run(u0, r0, 0.02)
        b = Simulation(m, g, Scheme.preset("accurate", stepper=name)).run(u0, r0, 0.02)
        assert np.array_equal(a.u, b.u) and np.array_equal(a.rho, b.rho)


def test_config_accepts_auto_and_adaptive_accurate():
    cfg = Config.from_dict({"numerics": {"scheme": "accurate", "rtol": 1e-3}})
    assert cfg.scheme().stepper == "auto" and cfg.scheme().rtol == 1e-3
    cfg = Config.from_dict({"numerics": {"scheme": "seed", "stepper": "auto"}})
    assert cfg.scheme().stepper == "auto"
