"""The event-driven reference (baselines/events.py) against independent oracles: the ball's closed
form, and the rectangle cascade of tests/test_contact.py (its own scan and bisection)."""
from __future__ import annotations

import numpy as np
import pytest

from castrajectory.baselines.events import event_driven
from castrajectory.models import collision as col
from castrajectory.validation import InputError

from test_contact import rectangle_cascade

G = 9.81


@pytest.mark.parametrize("e,v0", [(1.0, 0.0), (0.5, 0.0), (0.8, 1.5)])
def test_ball_against_the_closed_form(e, v0):
    ref = event_driven(col.bouncing_ball(1.0, G, e), [1.3], [v0], 3.8)
    times, _, speeds = col.ball_oracle(1.3, v0, G, e, ref.horizon)
    n = min(len(times), len(ref.events))
    assert n >= 3
    # measured 3e-15 (e = 1) to 8e-14 s (e = 0.5, near the accumulation)
    np.testing.assert_allclose(ref.times[:n], times[:n], rtol=0, atol=1e-12)
    np.testing.assert_allclose([ev.v_before[0] for ev in ref.events[:n]], -speeds[:n], rtol=1e-10, atol=1e-12)
    t_inf = times[0] + 2 * e * speeds[0] / G / (1 - e) if e < 1 else np.inf  # the accumulation point
    if t_inf < 3.8:
        assert ref.reason == "accumulation"
        assert abs(ref.horizon - t_inf) < 1e-6
    else:
        assert ref.reason == "horizon" and ref.horizon == 3.8


def test_rectangle_cascade_against_the_tests_oracle():
    exact = rectangle_cascade(1e-3, 1.5, 1.0, 3)
    ref = event_driven(col.rectangle_drop(1.0, 2.0, 1.0, G, 1.0), [0.0, 1.5, 1e-3], [0.0, 0.0, 0.0], 1.5)
    for ev, (t, j, vb, va) in zip(ref.events[:3], exact):
        assert ev.contacts == (j,)
        assert abs(ev.t - t) <= 1e-12
        np.testing.assert_allclose(ev.v_after, va, rtol=0, atol=1e-10)


def test_flat_landing_is_one_simultaneous_impact():
    ref = event_driven(col.rectangle_drop(1.0, 2.0, 1.0, G, 1.0), [0.0, 1.5, 0.0], [0.0, 0.0, 0.0], 1.0)
    ev = ref.events[0]
    assert ev.contacts == (0, 1)
    assert abs(ev.t - np.sqrt(2 * 1.0 / G)) <= 1e-12
    np.testing.assert_allclose(ev.v_after, [0.0, np.sqrt(2 * G), 0.0], atol=1e-12)  # elastic, no spin


def test_state_is_the_exact_flight_between_events():
    ref = event_driven(col.bouncing_ball(1.0, G, 1.0), [1.0], [0.0], 1.0)
    t1 = np.sqrt(2 / G)
    q, v = ref.state(t1 + 0.1)
    vp = np.sqrt(2 * G)
    assert q[0] == pytest.approx(vp * 0.1 - 0.5 * G * 0.01, abs=1e-12)
    assert v[0] == pytest.approx(vp - G * 0.1, abs=1e-12)


def test_refuses_systems_without_closed_form_flight():
    with pytest.raises(InputError, match="constant"):
        event_driven(col.bouncing_ball(1.0, G, 1.0, stiffness=10.0), [1.0], [0.0], 1.0)
