"""The sensor-switched second-difference dissipation (Scheme.sensor_dissipation, κ2): off on
smooth data, on at jumps, conservative, and zero mass flux through a floor."""
import numpy as np

from bsrflow.numerics.grid import Grid1D
from bsrflow.numerics.solver import Scheme, Simulation
from bsrflow.physics.kernels import walton_braun
from bsrflow.physics.model import BSRModel


def _rhs_pair(grid, u, rho, tau=0.02, k2=0.25):
    model = BSRModel(kernel=walton_braun(40.0, 0.2, 0.1), gravity=9.81)
    plain = Simulation(model, grid, Scheme(filter=False, selective_filter=tau))
    sensed = Simulation(model, grid, Scheme(filter=False, selective_filter=tau, sensor_dissipation=k2))
    return plain.rhs(u, rho, 0.0), sensed.rhs(u, rho, 0.0)


def test_off_on_smooth_data():
    g = Grid1D(0.0, 1.0, 200, "periodic", "periodic")
    u = 0.3 * np.sin(2 * np.pi * g.x)
    rho = 2.0 + np.cos(2 * np.pi * g.x)
    (du0, dr0), (du1, dr1) = _rhs_pair(g, u, rho)
    assert np.array_equal(du0, du1) and np.array_equal(dr0, dr1)


def test_on_at_a_jump_conservative_and_no_flux_through_the_floor():
    g = Grid1D(0.0, 1.0, 200, "floor", "vacuum")
    rho = np.where(g.x < 0.5, 3.0, 0.0)
    u = np.where(g.x < 0.5, -0.2, 0.0)
    (du0, dr0), (du1, dr1) = _rhs_pair(g, u, rho)
    extra = dr1 - dr0
    changed = np.flatnonzero(np.abs(extra) > 0)
    assert changed.size > 0 and np.all(np.abs(g.x[changed] - 0.5) < 3 * g.dx)   # only at the jump
    assert abs(extra.sum()) <= 1e-12 * np.abs(extra).sum()                        # a flux difference
    # it smooths: mass moves from the dense side of the jump to the empty side
    i = np.searchsorted(g.x, 0.5)
    assert extra[i - 1] < 0 < extra[i]


def test_no_mass_flux_through_the_floor():
    g = Grid1D(0.0, 1.0, 200, "floor", "vacuum")
    rho = np.where(g.x < g.dx, 8.0, 3.0) * (g.x < 0.5)    # a jump at the floor cell (ρ0 != ρ1)
    u = np.where(g.x < 0.5, -2.0, 0.0)                     # moving into the floor: odd images flag cell 0
    (_, dr0), (_, dr1) = _rhs_pair(g, u, rho)
    extra = dr1 - dr0
    assert np.any(extra[:4] != 0.0)                                  # switched on at the floor
    assert abs(extra.sum()) <= 1e-12 * np.abs(extra).sum()           # no mass enters or leaves
