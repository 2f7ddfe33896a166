"""Numerical checks of formulas stated in docs/derivations.md.

* Least action, §7 ("Extrapolated guesses"): the Richardson correction. From
  ``u_H = u* + C H^r`` the two levels give ``C H_f^r = (I u_c − u_f)/((H_c/H_f)^r − 1)``;
  the extrapolated value is ``u_f − C H_f^r`` (to ``h → 0``) or
  ``u_f − C H_f^r (1 − (h/H_f)^r)`` (to a new step ``h``, what ``_extrapolate`` returns).
  Checked on the scalar model itself, on ``_extrapolate`` with synthetic level solutions
  that follow the model exactly, and on real solves of a simple pendulum.

The order of the 3-stage Lobatto IIIA–IIIB pair (galerkin4, order ``2s − 2 = 4``) is not
re-tested here: ``tests/test_trajectory.py::test_whole_trajectory_order`` fits it for the
whole-trajectory solve (slope in [3.8, 4.2]) and
``tests/test_stepping.py::test_observed_order_double_pendulum`` for ``march``.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from castrajectory.solve import trajectory as tr
from castrajectory.models.pendulum import n_link_pendulum


def richardson(u_c, u_f, ratio, r, h_over_hf=0.0):
    """The derivation's formula: ``u_f − C H_f^r (1 − (h/H_f)^r)`` with
    ``C H_f^r = (u_c − u_f)/(ratio^r − 1)``, ``ratio = H_c/H_f`` (``u_c`` on the fine grid)."""
    c_hf = (u_c - u_f) / (ratio ** r - 1.0)
    return u_f - c_hf * (1.0 - h_over_hf ** r)


def opposite_sign(u_c, u_f, ratio, r, h_over_hf=0.0):
    """The sign the referee found in the text: ``C H_f^r = (u_f − u_c)/(ratio^r − 1)``."""
    c_hf = (u_f - u_c) / (ratio ** r - 1.0)
    return u_f - c_hf * (1.0 - h_over_hf ** r)


# ----------------------------------------------------------------------------- the scalar model
def test_richardson_formula_recovers_limit():
    """u* = 0.25, C = 1.5, r = 2, H_f = 2^-1/2, H_c = 2 H_f: u_f = 1, u_c = 3.25.

    The correct sign gives u* = 0.25; the opposite one gives 1.75."""
    u_star, C, r = 0.25, 1.5, 2
    H_f = 2.0 ** -0.5
    H_c = 2.0 * H_f
    u_f, u_c = u_star + C * H_f ** r, u_star + C * H_c ** r
    assert u_f == pytest.approx(1.0) and u_c == pytest.approx(3.25)
    assert richardson(u_c, u_f, H_c / H_f, r) == pytest.approx(u_star, abs=1e-15)
    assert opposite_sign(u_c, u_f, H_c / H_f, r) == pytest.approx(1.75, abs=1e-15)


@pytest.mark.parametrize("r,ratio", [(2, 2.0), (4, 2.0), (2, 3.0), (4, 1.5)])
def test_richardson_formula_to_new_step(r, ratio):
    """Extrapolated to a new step h (not to 0), the formula gives the level-h value u* + C h^r."""
    u_star, C, H_f = -0.7, 2.3, 0.1
    H_c = ratio * H_f
    u_f, u_c = u_star + C * H_f ** r, u_star + C * H_c ** r
    for h in (0.0, H_f / 8, H_f / 2):
        assert richardson(u_c, u_f, ratio, r, h / H_f) == pytest.approx(u_star + C * h ** r, rel=1e-13, abs=1e-15)
        # the opposite sign moves u_f away from the level-h value: worse than no correction
        # (at h = H_f both signs return u_f, which is why h < H_f here)
        want = u_star + C * h ** r
        assert abs(opposite_sign(u_c, u_f, ratio, r, h / H_f) - want) > abs(u_f - want) > 0.0


# ----------------------------------------------------------------------------- _extrapolate itself
T = 1.0
Q0 = 0.4


def _u_star(t):
    """Limit trajectory: a quintic with u*(0) = q0 (the stencils of _extrapolate are quintic,
    so every interpolation in it is exact on these data)."""
    return Q0 + 0.3 * t - 0.8 * t ** 2 + 0.5 * t ** 3 + 0.2 * t ** 4 - 0.1 * t ** 5


def _g(t):
    """Error profile of a level, zero at t = 0 (q0 is exact on every level)."""
    return t - 0.6 * t ** 2 + 0.25 * t ** 5


def _level(dm, N, r, C, p0):
    """A TrajectoryNLP on N steps with synthetic 'solved' values u* + C h^r g(t) (stages too)."""
    tn = tr.TrajectoryNLP(dm, N, T, "initial_value", np.array([Q0]), p0)
    t = np.linspace(0.0, T, N + 1)
    vals = {"q": _u_star(t) + C * tn.h ** r * _g(t)}
    if dm.s:
        ts = t[:-1] + tn.h / 2  # the galerkin4 stage sits at mid-step
        vals["Z"] = _u_star(ts) + C * tn.h ** r * _g(ts)
    return tn, vals


@pytest.mark.parametrize("scheme", ["midpoint", "galerkin4"])
def test_extrapolate_on_model_levels(scheme):
    """_extrapolate of two levels that follow u_H = u* + C H^r exactly returns u* + C h^r
    on the new grid (to round-off); the opposite sign does not."""
    system = n_link_pendulum([1.0], [1.0])
    dm = tr.DiscreteMechanics(system, scheme)
    r = dm.scheme.order
    assert r == {"midpoint": 2, "galerkin4": 4}[scheme]
    p0 = np.zeros(1)
    C = 3.0
    coarse = _level(dm, 16, r, C, p0)
    fine = _level(dm, 32, r, C, p0)
    target, want = _level(dm, 128, r, C, p0)
    got = tr._extrapolate(coarse, fine, target)
    np.testing.assert_allclose(got["q"], want["q"], rtol=0, atol=1e-12)
    if dm.s:
        np.testing.assert_allclose(got["Z"], want["Z"], rtol=0, atol=1e-12)
    # the text's former sign: C H_f^r = (u_f − I u_c)/(...) lands far off
    (tc, vc), (tf, vf) = coarse, fine
    vc_f = tr._refine(tc, vc, tf, tr.EXTRAPOLATION_POINTS)
    w = (1.0 - (target.h / tf.h) ** r) / ((tc.h / tf.h) ** r - 1.0)
    wrong = tr._refine(tf, {"q": vf["q"] - w * (vf["q"] - vc_f["q"])}, target, tr.EXTRAPOLATION_POINTS)["q"]
    assert np.max(np.abs(wrong - want["q"])) > 1e3 * 1e-12


def test_extrapolate_real_levels_beats_interpolation():
    """Simple pendulum (θ0 = 1 at rest, T = 2, midpoint), levels of 50 and 100 steps, target 400.

    The level-h error is C h² + O(h⁴), so the guess from plain interpolation of the 100-step
    solution is off by about C H_f²(1 − (h/H_f)²) against the 400-step solution, and the
    extrapolated guess only by the O(H⁴) remainder: at least ten times less.  The opposite
    sign doubles the interpolation's error instead (the correction points the wrong way)."""
    system, q0, T2 = n_link_pendulum([1.0], [1.0]), np.array([1.0]), 2.0
    dm = tr.DiscreteMechanics(system, "midpoint")
    p0 = np.asarray(system.momentum(q0, np.zeros(1))).reshape(-1)
    levels = []
    for n in (50, 100):
        sol = tr.solve_initial_value(system, q0, [0.0], T2, n, "midpoint")
        assert sol.success, sol.message
        levels.append((tr.TrajectoryNLP(dm, n, T2, "initial_value", q0, p0), {"q": sol.q.reshape(-1)}))
    target = tr.TrajectoryNLP(dm, 400, T2, "initial_value", q0, p0)
    exact = tr.solve_initial_value(system, q0, [0.0], T2, 400, "midpoint")
    assert exact.success, exact.message
    exact = exact.q.reshape(-1)
    interpolated = np.abs(tr._refine(*levels[1], target, tr.EXTRAPOLATION_POINTS)["q"] - exact).max()
    extrapolated = np.abs(tr._extrapolate(*levels, target)["q"] - exact).max()
    (tc, vc), (tf, vf) = levels
    vc_f = tr._refine(tc, vc, tf, tr.EXTRAPOLATION_POINTS)
    w = (1.0 - (target.h / tf.h) ** 2) / ((tc.h / tf.h) ** 2 - 1.0)
    flipped = tr._refine(tf, {"q": vf["q"] - w * (vf["q"] - vc_f["q"])}, target, tr.EXTRAPOLATION_POINTS)["q"]
    wrong = np.abs(flipped - exact).max()
    assert extrapolated < interpolated / 10, (extrapolated, interpolated)
    assert wrong > 1.5 * interpolated, (wrong, interpolated)
    assert math.isfinite(extrapolated)
