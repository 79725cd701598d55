"""Butcher tableaux: order conditions, Kutta's four-stage family, the accurate preset's member."""
from fractions import Fraction as F

import numpy as np
import pytest

from bsrflow.io.config import CFL_LIMITS, _cfl_limit
from bsrflow.numerics.steppers import STEPPERS, get_stepper, kutta4_family, order_residual


def test_every_tableau_meets_its_order_conditions():
    for name, tb in STEPPERS.items():
        assert order_residual(tb.a, tb.b, tb.c, tb.order) < 1e-14, name
        assert np.allclose(tb.a.sum(axis=1), tb.c), name           # row-sum condition
        if tb.b_embedded is not None:
            assert order_residual(tb.a, tb.b_embedded, tb.c, tb.embedded_order) < 1e-14, name


def test_kutta4_family_is_exact_and_contains_the_three_eighths_rule():
    a, b, c = kutta4_family(F(1, 3), F(2, 3))
    assert b == [F(1, 8), F(3, 8), F(3, 8), F(1, 8)]
    assert a[3][:3] == [1, -1, 1] and a[2][:2] == [F(-1, 3), 1]
    a, b, c = kutta4_family(F(2, 5), F(1, 4))
    assert b == [F(1, 4), F(125, 108), F(-16, 27), F(5, 27)]
    assert a[2][:2] == [F(31, 64), F(-15, 64)] and a[3][:3] == [F(2, 5), 3, F(-12, 5)]
    tb = get_stepper("rk4_0.4_0.25")
    assert np.array_equal(tb.b, np.array([float(x) for x in b]))
    assert list(tb.c) == [0.0, 0.4, 0.25, 1.0]


@pytest.mark.parametrize("c2, c3", [(0.5, 0.3), (0.3, 0.3), (0.0, 0.4), (0.3, 1.0), (1.5, 0.3), (0.3, -0.2)])
def test_kutta4_family_rejects_special_nodes(c2, c3):
    with pytest.raises(ValueError, match="outside the general case"):
        kutta4_family(c2, c3)


def test_four_stage_member_has_the_rk4_stability_limits():
    """Every four-stage fourth-order method has R(z) = Σ_{k<=4} z^k/k!, so the config uses the
    limits of classical RK4 for it."""
    tb, rk4 = get_stepper("rk4_0.4_0.25"), get_stepper("rk4")
    z = np.linspace(-3, 3, 13)[:, None] + 1j * np.linspace(-3, 3, 13)[None, :]
    assert np.allclose(tb.stability_polynomial(z), rk4.stability_polynomial(z), rtol=1e-13, atol=1e-13)
    for filt in (True, False):
        assert _cfl_limit("rk4_0.4_0.25", filt) == CFL_LIMITS[("rk4", filt)]
