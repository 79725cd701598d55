"""The interaction interface (bsrflow.physics.interaction): every interaction states the fields it
reads at both points and its own wave-speed bound, the compiled loops take the bound from it, and
fast paths are registered specialisations."""

import math

import numpy as np
import pytest

from bsrflow.numerics.compiled import direct_integral
from bsrflow.numerics.fast_integral import walton_braun_integral
from bsrflow.numerics.grid import Grid1D
from bsrflow.numerics.packing_nd import PackingLawND
from bsrflow.numerics.solver import Scheme, Simulation
from bsrflow.physics.interaction import (Interaction, constant_wave_speed, fast_integral_for,
                                         register_fast_integral)
from bsrflow.physics.kernels import Kernel, _walton_braun, walton_braun
from bsrflow.physics.kernels_nd import walton_braun_nd
from bsrflow.physics.model import BSRModel
from bsrflow.physics.packing import PackingLaw


def _interactions():
    law = PackingLaw(1.366e7, 0.9, 0.022, 1200.0)
    return {"seed": walton_braun(2.0e5, 0.105, 0.022), "seed_nd": walton_braun_nd(2.0e5, 0.105, 0.022),
            "packing": law, "packing_nd": PackingLawND.from_1d(law)}


@pytest.mark.parametrize("name", ["seed", "seed_nd", "packing", "packing_nd"])
def test_every_interaction_states_its_fields_and_bound(name):
    it = _interactions()[name]
    assert isinstance(it, Interaction)
    assert it.state_fields and all(isinstance(f, str) for f in it.state_fields)
    assert it.radius == pytest.approx(0.022)
    rho = np.array([0.0, 3.0, 7.5, 2.0])
    state = {"rho": rho, "u": np.zeros((3, rho.size))} if name == "seed_nd" else {"rho": rho, "u": 0 * rho}
    fn, p = it.compiled_wave_speed()
    c_compiled = fn(float(rho.max()), p)
    c = it.wave_speed_bound(state)
    assert c > 0 and math.isfinite(c)
    assert c_compiled == pytest.approx(c, rel=1e-12)
    assert "name" in it.describe()


def test_seed_bound_is_the_linear_sound_speed():
    k = walton_braun(2.0e5, 0.105, 0.022)
    # κ = λR³/3 for Walton–Braun (Appendix A, corrected): c² = κ max ρ
    kappa = 2.0e5 * 0.022 ** 3 / 3
    assert k.stiffness_moment() == pytest.approx(kappa, rel=1e-6)
    assert k.wave_speed_bound({"rho": [1.0, 4.0]}) == pytest.approx(math.sqrt(kappa * 4.0), rel=1e-6)
    with pytest.raises(ValueError, match="rho"):
        k.wave_speed_bound({"u": [0.0]})


def test_nd_moment_against_the_closed_form():
    k = walton_braun_nd(3.0, 0.1, 0.01)
    assert k.stiffness_moment(3) == pytest.approx(math.pi * 3.0 * 0.01 ** 5 / 15, rel=2e-3)
    assert k.stiffness_moment(2) == pytest.approx(math.pi * 3.0 * 0.01 ** 4 / 12, rel=2e-3)


def test_packing_bound_is_the_close_packing_sound_speed():
    law = PackingLaw(1.366e7, 0.9, 0.022, 1200.0)
    c = law.wave_speed_bound({"rho": np.array([0.5, 2.0]) * law.close_packing_density})
    assert c == pytest.approx(law.diameter * math.sqrt(law.k2 / law.particle_mass), rel=1e-14)


class _DeclaredSpeed(Kernel):
    """A kernel whose interaction declares a wave-speed bound of its own (here a constant)."""

    def compiled_wave_speed(self):
        return constant_wave_speed, np.array([50.0])


def test_the_time_loop_takes_the_bound_from_the_interaction():
    base = walton_braun(2.0e5, 0.105, 0.022)
    declared = _DeclaredSpeed(base.fn, base.params.copy(), base.radius, name="declared")
    grid = Grid1D(0.0, 0.44, 200, "floor", "vacuum")
    rho = np.full(grid.n_cells, 0.1)
    dts = {}
    for name, k in (("seed", base), ("declared", declared)):
        sim = Simulation(BSRModel(kernel=k, gravity=0.0), grid, Scheme.preset("seed"))
        _, steps, status, _, dt = sim.advance(np.zeros(grid.n_cells), rho.copy(), 0.0, 1.0, max_steps=1)
        assert status == 4 and steps == 1
        dts[name] = dt
    assert dts["declared"] == pytest.approx(0.5 * grid.dx / 50.0, rel=1e-14)
    assert dts["seed"] == pytest.approx(0.5 * grid.dx / base.wave_speed_bound({"rho": rho}), rel=1e-14)


def test_fast_paths_are_registered_by_kernel_function():
    k = walton_braun(2.0e5, 0.105, 0.022)
    assert fast_integral_for(k) is walton_braun_integral
    # a kernel built on the same function by hand finds the same fast path
    same = Kernel(_walton_braun, k.params.copy(), k.radius, name="by_hand")
    assert fast_integral_for(same) is walton_braun_integral
    grid = Grid1D(0.0, 0.44, 200, "floor", "vacuum")
    sim = Simulation(BSRModel(kernel=same), grid)
    assert sim.integral_name == "walton_braun_integral"

    def other(z, u_here, u_there, p):
        return -p[0] * np.sign(z) * np.maximum(p[1] - np.abs(z), 0.0)

    user = Kernel(other, [1e3, 0.022], 0.022, name="user")
    assert fast_integral_for(user) is None
    assert Simulation(BSRModel(kernel=user), grid).integral_name == "integral"
    with pytest.raises(ValueError, match="register_fast_integral"):
        register_fast_integral(other, None)
    # the direct sum is the registered path's reference
    assert direct_integral(k.compiled) is not walton_braun_integral
