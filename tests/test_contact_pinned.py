"""Contact-implicit optimal control: an event held at its step's window is no solution (issue 41, part 2).

A ball (unit mass, g = 9.81) is launched from the origin with a free velocity and must be at (0.2, 0) at T = 1.2,
bouncing once off the wall x = 1 (restitution e).  The closed form, by the mirror image with the return leg
stretched by 1/e: the horizontal launch speed (1 + 0.8/e)/T, the vertical gT/2, the impact at 1/vₓ.  The guess
launches at vₓ = 2, hitting the wall 4 steps of N = 45 early; the program's timing rounds hold each impact in one
step, with its sub-node inside the step's window, and the answer must not stop against that window.
"""
import casadi as ca
import numpy as np
import pytest

import castrajectory as ct
from castrajectory.solve.optimal_control import OptimalControl

G, T = 9.81, 1.2


def _wall(e, N, target=(0.2, 0.0), least_squares=False):
    q = ca.SX.sym("q", 2)
    ball = ct.LagrangianSystem(q, ct.Atoms([q], [1.0]), [ct.Gravity(G)], names=["x", "y"],
                               contact=ct.Contact([1.0 - q[0]], restitution=e, names=["wall"]))
    ocp = OptimalControl(ball, T=T, N=N, scheme="midpoint")
    ocp.initial(q=[0.0, 0.0], qd=[None, None])
    if least_squares:
        ocp.minimize(final=(q[0] - target[0]) ** 2 + (q[1] - target[1]) ** 2)
    else:
        ocp.final(q=list(target))
        ocp.minimize(final=0 * ocp.T_symbol)          # a feasibility problem: its point is isolated
    return ocp


@pytest.mark.parametrize("e,N", [(0.8, 45), pytest.param(0.5, 40, marks=pytest.mark.slow)])
def test_bounce_off_a_wall_reaches_the_closed_form_from_a_guess_in_the_wrong_step(e, N):
    """The impact must move from the guess's step to the optimum's (4 steps at e = 0.8): the end conditions' elastic
    mode lets the rounds move an event pinned at its window's edge, and the answer meets the closed form."""
    sol = _wall(e, N).solve(guess={"qd0": [2.0, G * T / 2]})
    vx = (1.0 + 0.8 / e) / T
    assert sol.success, sol.message
    assert abs(sol.v[0, 0] - vx) <= 1e-6 and abs(sol.v[0, 1] - G * T / 2) <= 1e-6
    assert sol.impact_times[0] == [pytest.approx(1.0 / vx, abs=1e-6)]
    assert sol.certificate <= 1e-7 and sol.b_stationary and sol.pinned == []
    # the answer is the motion: the end where it was asked
    assert np.max(np.abs(sol.q[-1] - [0.2, 0.0])) <= 1e-8


def test_an_event_pinned_at_its_window_fails_and_is_named():
    """keep_modes holds the impact in the guess's step, where the least-squares optimum (cost 0 at the closed form)
    wants it 4 steps later: the answer is a motion (every step certified), but its impact sits against the step's
    end, held by the transcription's window.  It is no optimum of the continuous problem: not ok
    (``Event_Pinned``), not B-stationary, and it says which event is pinned and where."""
    sol = _wall(0.8, 45, least_squares=True).solve(guess={"qd0": [2.0, G * T / 2]}, keep_modes=True)
    assert sol.certificate <= 1e-7            # (the motion itself is right: only its event is held)
    assert not sol.success and sol.status == "Event_Pinned"
    assert not sol.b_stationary
    (p,) = sol.pinned
    h = T / 45
    assert p["edge"] == "end" and p["held"] == "window"
    assert p["t"] == pytest.approx((p["step"] + 1) * h, abs=2e-3 * h)
    assert f"step {p['step']}'s at the end of its window" in sol.message
    assert sol.cost > 1e-3                     # the closed form's cost is 0
    # without keep_modes the rounds move the impact to its step, and the closed form is the answer
    free = _wall(0.8, 45, least_squares=True).solve(guess={"qd0": [2.0, G * T / 2]})
    assert free.success and free.pinned == [] and free.b_stationary
    assert abs(free.v[0, 0] - (1.0 + 0.8 / 0.8) / T) <= 1e-6 and free.cost <= 1e-12


def test_a_contact_problem_without_controls_takes_the_ladder_and_refuses_unknown_guess_keys():
    """N > 32 without a guess goes through the ladder of grids, which interpolated controls the ball has none of
    (a ValueError traceback); a guess key the solve does not read is refused, not ignored."""
    from castrajectory.validation import InputError
    sol = _wall(0.5, 40).solve()
    assert sol.grids == [20, 40]
    with pytest.raises(InputError, match="'q'"):
        _wall(0.5, 40).solve(guess={"q": np.zeros((41, 2)), "qd0": [2.0, 5.9]})
