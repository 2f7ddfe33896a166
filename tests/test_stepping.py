"""Tests of the time-stepping baselines (castrajectory.baselines.stepping).

* observed order of every stepper against the CVODES reference (log-log slope);
* the reference itself against the double pendulum's slow normal mode;
* energy: bounded for the marched variational integrators, drifting for RK4;
* constrained march (Cartesian pendulum) against the angle form;
* failure reporting (NaN never counts as success) and refused input;
* construction and march cost at N = 32 000 (no Python loop per step).
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from castrajectory.baselines import stepping as st
from castrajectory.models.mechanics import LagrangianSystem, MassMatrix, Potential
from castrajectory.models.pendulum import (cartesian_pendulum, double_pendulum, double_pendulum_modes,
                                    n_link_pendulum)
from castrajectory.validation import InputError

from helpers import observed_order

G = 9.81
Q0 = [0.5, 0.3]   # double pendulum start, at rest
T_ORDER = 2.0
REF_TOL = 1e-14   # CVODES tolerance for the order tests (agrees with fine RK4 to ~2e-13)


def _march(scheme):
    def run(system, q0, qd0, T, N):
        return st.march(system, q0, qd0, T, N, scheme)
    return run


# ----------------------------------------------------------------------------- convergence order
# Error = max over the nodes of |q - q_ref| (more robust than the final node
# alone, whose error can pass near zero).  N ranges chosen in the asymptotic
# regime and well above round-off (galerkin4 at N = 400: error 1e-10).
ORDER_CASES = [
    ("rk4", st.rk4, [50, 100, 200, 400], 4, 0.3),
    ("implicit_euler", st.implicit_euler, [400, 800, 1600, 3200], 1, 0.2),
    ("midpoint", _march("midpoint"), [50, 100, 200, 400], 2, 0.2),
    ("trapezoid", _march("trapezoid"), [50, 100, 200, 400], 2, 0.2),
    ("galerkin4", _march("galerkin4"), [50, 100, 200, 400], 4, 0.4),
]


@pytest.mark.parametrize("name,stepper,ns,order,slack", ORDER_CASES, ids=[c[0] for c in ORDER_CASES])
def test_observed_order_double_pendulum(name, stepper, ns, order, slack):
    system = double_pendulum()
    errs = []
    for N in ns:
        r = stepper(system, Q0, [0.0, 0.0], T_ORDER, N)
        assert r.success, r.message
        assert r.q.shape == (N + 1, 2) and r.qd.shape == (N + 1, 2) and r.energy.shape == (N + 1,)
        q_ref, _ = st.reference(system, Q0, [0.0, 0.0], r.t, rtol=REF_TOL, atol=REF_TOL)
        errs.append(np.max(np.abs(r.q - q_ref)))
    p = observed_order(ns, errs)
    assert order - slack <= p <= order + slack, f"{name}: observed order {p:.3f}, errors {errs}"


@pytest.mark.parametrize("scheme", ["midpoint", "galerkin4"])
def test_march_velocities_converge(scheme):
    """Velocities from the discrete Legendre transform converge to the reference ones."""
    system = double_pendulum()
    errs = []
    ns = [100, 200, 400]
    for N in ns:
        r = st.march(system, Q0, [0.0, 0.0], T_ORDER, N, scheme)
        _, qd_ref = st.reference(system, Q0, [0.0, 0.0], r.t, rtol=REF_TOL, atol=REF_TOL)
        errs.append(np.max(np.abs(r.qd - qd_ref)))
    assert observed_order(ns, errs) >= st.SCHEMES[scheme].order - 0.3, errs


# ----------------------------------------------------------------------------- reference vs normal mode
def test_reference_small_oscillation_slow_mode():
    """Equal masses and lengths, amplitude 1e-3 along (1, √2): q(t) = A (1, √2) cos(ω t),
    ω² = (2 − √2) g / l (derived independently: M = [[2, 1], [1, 1]], K = g diag(2, 1))."""
    l = 1.0
    w_slow = math.sqrt((2.0 - math.sqrt(2.0)) * G / l)
    # independent derivation: generalised eigenvalues of K v = ω² M v
    M, K = np.array([[2.0, 1.0], [1.0, 1.0]]), G / l * np.diag([2.0, 1.0])
    assert min(np.linalg.eigvals(np.linalg.solve(M, K)).real) == pytest.approx(w_slow ** 2, rel=1e-12)
    w, shapes = double_pendulum_modes(G, l)
    assert w[0] == pytest.approx(w_slow, rel=1e-12)
    shape = np.array([1.0, math.sqrt(2.0)])
    assert np.allclose(shapes[0], shape)

    A = 1e-3
    period = 2 * math.pi / w_slow
    t = np.linspace(0.0, 3 * period, 601)
    q, qd = st.reference(double_pendulum(l1=l, l2=l), A * shape, [0.0, 0.0], t)
    exact = A * np.cos(w_slow * t)[:, None] * shape
    assert np.max(np.abs(q - exact)) <= 1e-3 * A * math.sqrt(2.0)
    assert np.max(np.abs(qd + A * w_slow * np.sin(w_slow * t)[:, None] * shape)) <= 1e-3 * A * w_slow * 2
    # zero crossings of theta1 are half a period apart
    x = q[:, 0]
    i = np.nonzero(np.sign(x[:-1]) != np.sign(x[1:]))[0]
    tz = t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])
    assert len(tz) >= 5
    assert np.allclose(np.diff(tz), period / 2, rtol=1e-5)


# ----------------------------------------------------------------------------- energy behaviour
PERIODS = 200
AMP = 0.3
N_LONG = 3000  # 15 steps per period: coarse on purpose


def _long_pendulum_run(stepper):
    T = PERIODS * 2 * math.pi / math.sqrt(G)
    return stepper(n_link_pendulum([1.0], [1.0], G), [AMP], [0.0], T, N_LONG)


@pytest.mark.parametrize("scheme", ["midpoint", "trapezoid", "galerkin4"])
def test_march_energy_bounded(scheme):
    r = _long_pendulum_run(_march(scheme))
    assert r.success, r.message
    dE = np.abs(r.energy - r.energy[0])
    half = N_LONG // 2
    assert dE[half:].max() <= 2.0 * dE[:half].max()
    assert dE.max() < 0.05 * abs(G * (1 - math.cos(AMP)))  # a few per cent of the swing energy at most


def test_rk4_energy_drifts():
    r = _long_pendulum_run(st.rk4)
    assert r.success, r.message
    dE = np.abs(r.energy - r.energy[0])
    per = N_LONG // PERIODS
    assert dE[-per:].max() > 10.0 * dE[:per].max()
    # energy sampled every 5 periods decreases monotonically (RK4 damps the oscillator)
    assert np.all(np.diff(r.energy[::5 * per]) < 0)


# ----------------------------------------------------------------------------- constrained march
@pytest.mark.parametrize("scheme,order", [("midpoint", 2), ("galerkin4", 4)])
def test_constrained_march_cartesian_pendulum(scheme, order):
    """(x, y) with (x² + y² − 1)/2 = 0 against the angle form's reference."""
    theta0 = 1.0
    cart, angle = cartesian_pendulum(), n_link_pendulum([1.0], [1.0], G)
    x0 = [math.sin(theta0), -math.cos(theta0)]
    ns, errs = [50, 100, 200], []
    for N in ns:
        r = st.march(cart, x0, [0.0, 0.0], T_ORDER, N, scheme)
        assert r.success, r.message
        assert r.lam.shape == (N, 1)
        assert np.max(np.abs(0.5 * (np.sum(r.q ** 2, axis=1) - 1.0))) < 1e-12
        assert np.max(np.abs(np.sum(r.q * r.qd, axis=1))) < 1e-12  # velocities tangent
        th, _ = st.reference(angle, [theta0], [0.0], r.t, rtol=REF_TOL, atol=REF_TOL)
        errs.append(np.max(np.abs(r.q - np.column_stack([np.sin(th[:, 0]), -np.cos(th[:, 0])]))))
    assert observed_order(ns, errs) == pytest.approx(order, abs=0.3), errs


def test_constrained_inputs():
    cart = cartesian_pendulum()
    with pytest.raises(ValueError, match="unconstrained"):
        st.reference(cart, [0.0, -1.0], [1.0, 0.0], [0.0, 1.0])
    with pytest.raises(InputError, match="q0"):
        st.march(cart, [1.0, 1.0], [0.0, 0.0], 1.0, 10)
    with pytest.raises(InputError, match="qd0"):
        st.march(cart, [0.0, -1.0], [0.0, 1.0], 1.0, 10)


# ----------------------------------------------------------------------------- failure reporting
def _sqrt_well():
    """1-D particle, U = −√q: leaves the model's domain (q < 0 gives NaN) when thrown towards 0."""
    q = ca.SX.sym("q", 1)
    return LagrangianSystem(q, MassMatrix(1.0), [Potential(-ca.sqrt(q[0]))])


@pytest.mark.parametrize("stepper", [st.rk4, st.implicit_euler, _march("midpoint"), _march("galerkin4")],
                         ids=["rk4", "implicit_euler", "midpoint", "galerkin4"])
def test_nan_is_never_success(stepper):
    r = stepper(_sqrt_well(), [1.0], [-10.0], 1.0, 10)
    assert not r.success
    assert "non-finite" in r.message or "did not converge" in r.message


@pytest.mark.parametrize("stepper,N", [(st.implicit_euler, 5), (_march("galerkin4"), 3)],
                         ids=["implicit_euler", "galerkin4"])
def test_newton_failure_is_reported(stepper, N):
    """A step of a second or more on the chaotic double pendulum: Newton does not converge (no NaN)."""
    r = stepper(double_pendulum(), [2.0, 1.0], [0.0, 0.0], 5.0, N)
    assert not r.success
    assert "did not converge" in r.message and "increase N" in r.message


# ----------------------------------------------------------------------------- input validation
BAD = [
    dict(T=0.0), dict(T=-1.0), dict(T=float("nan")),
    dict(N=1), dict(N=0), dict(N=2.5),
    dict(q0=[float("nan"), 0.0]), dict(q0=[0.1]), dict(qd0=[0.0, float("inf")]),
]


@pytest.mark.parametrize("stepper", [st.rk4, st.implicit_euler, _march("midpoint")],
                         ids=["rk4", "implicit_euler", "march"])
@pytest.mark.parametrize("bad", BAD, ids=lambda d: ",".join(f"{k}={v}" for k, v in d.items()))
def test_bad_input_refused(stepper, bad):
    args = dict(q0=[0.5, 0.3], qd0=[0.0, 0.0], T=1.0, N=10) | bad
    with pytest.raises(InputError):
        stepper(double_pendulum(), args["q0"], args["qd0"], args["T"], args["N"])


def test_bad_scheme_and_times_refused():
    s = double_pendulum()
    with pytest.raises(InputError, match="scheme"):
        st.march(s, Q0, [0.0, 0.0], 1.0, 10, "leapfrog")
    for t_eval in ([], [1.0, 0.5], [-1.0, 1.0], [0.0, float("nan")]):
        with pytest.raises(InputError):
            st.reference(s, Q0, [0.0, 0.0], t_eval)
    with pytest.raises(InputError):
        st.reference(s, Q0, [0.0, 0.0], [0.0, 1.0], rtol=0.0)


# ----------------------------------------------------------------------------- cost
def test_large_n_cost():
    """N = 32 000 (double pendulum, T = 5, chaotic start): building stays cheap, the march is one C-level call."""
    s = double_pendulum()
    r = st.rk4(s, [2.0, 1.0], [0.0, 0.0], 5.0, 32000)
    assert r.success and r.build_time_s < 1.0 and r.solve_time_s < 1.0
    v = st.march(s, [2.0, 1.0], [0.0, 0.0], 5.0, 32000, "midpoint")
    assert v.success and v.build_time_s < 1.0 and v.solve_time_s < 5.0
    assert np.max(np.abs(v.q - r.q)) < 1e-3  # both close to the truth (midpoint error ~1e-5 here)
