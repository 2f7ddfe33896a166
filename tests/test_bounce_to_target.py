"""The closed form of the bounce to a target (models/bounce.py), the oracle of issue #27's first scene.

Independent checks: rockit's published feasible point, and the contact march itself (ct.simulate of the ball
launched at the closed form's speed: its impact times, and height and speed at the horizon)."""
from __future__ import annotations


import casadi as ca
import numpy as np
import pytest

import castrajectory as ct
from castrajectory.models.bounce import bounce_to_target
from castrajectory.validation import InputError


def test_rockit_feasible_point():
    """rockit's bounce.py (g = 9.81, p = 0.5, k = 2, e = 0.9): v0 = 3.86678 m/s, flights 0.788334, 0.709501 and
    0.319275 s, total 1.817111 s (the digits rockit prints)."""
    b = bounce_to_target(0.5, 2, 0.9, 9.81)
    assert abs(b.launch_speed - 3.86678) < 5e-6
    assert np.allclose(b.flights, (0.788334, 0.709501, 0.319275), atol=5e-7)
    assert abs(b.horizon - 1.817111) < 5e-7


@pytest.mark.parametrize("p, k, e", [(0.5, 2, 0.9), (1.3, 3, 0.7), (0.2, 0, 0.5), (0.8, 1, 1.0)])
def test_the_march_of_the_launch_reaches_the_target_at_rest(p, k, e):
    """The ball launched at v0 from the floor, marched through its bounces (N = 400, midpoint, exact for a constant
    acceleration; the impacts located inside their steps): impact times within 1.2e-14 s of the closed form, and
    at T height p and speed 0 within 4e-15 m and 1.1e-13 m/s (measured)."""
    b = bounce_to_target(p, k, e)
    y = ca.SX.sym("y", 1)
    ball = ct.LagrangianSystem(y, ct.Atoms([ca.vertcat(0, y)], [1.0]), [ct.Gravity(9.81)],
                               contact=ct.Contact([y[0]], restitution=e))
    run = ct.simulate(ball, [0.0], [b.launch_speed], T=b.horizon, N=400)
    assert run.success, run.message
    times = [i.t for i in run.detail.impacts if i.t > 1e-9]  # (the launch from the floor is no bounce)
    assert len(times) == k
    assert np.allclose(times, b.impact_times, rtol=0.0, atol=100 * 1.2e-14)
    assert abs(run.q[-1, 0] - p) < 100 * 4e-15 and abs(run.v[-1, 0]) < 100 * 1.1e-13


@pytest.mark.parametrize("kw", [dict(height=-1, bounces=2, restitution=0.9), dict(height=1, bounces=1.5, restitution=0.9),
                                dict(height=1, bounces=2, restitution=0.0), dict(height=1, bounces=2, restitution=1.2)])
def test_bad_input_is_refused(kw):
    with pytest.raises(InputError):
        bounce_to_target(**kw)
