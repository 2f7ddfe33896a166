"""Tests of the whole-trajectory solves (castrajectory.solve.trajectory) and the element NLP families.

* observed order of the whole-trajectory initial-value solve against CVODES (log-log slope);
* small-oscillation normal modes of the equal double pendulum (frequencies derived here);
* whole-trajectory and marched solutions of the same DEL equations agree (moderate and chaotic);
* boundary mode: the free-fall parabola is reproduced exactly at the nodes; a nonlinear
  pendulum boundary problem agrees with the initial-value solve and with CVODES shooting;
* holonomic constraints: Cartesian pendulum against the angle form, the multiplier is the rod force;
* energy bounded over hundreds of periods (RK4 at the same step drifts);
* refused input, honest failure reporting and a complete record of the solves;
* element families of castrajectory.solve.nlp against the same NLP written with plain expressions.
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from castrajectory.baselines import stepping as st
from castrajectory.solve import trajectory as tr
from castrajectory.solve.nlp import NLP, X
from castrajectory.models.pendulum import cartesian_pendulum, double_pendulum, n_link_pendulum, point_mass
from castrajectory.result import SUCCESS_STATUSES
from castrajectory.validation import InputError

from helpers import energy_growth, free_fall, observed_order, pendulum_rod_force, sampled_frequency

G = 9.81
SCHEMES = ["midpoint", "trapezoid", "galerkin4"]
ORDER = {"midpoint": 2, "trapezoid": 2, "galerkin4": 4}
REF_TOL = 1e-14  # CVODES tolerance where it serves as the exact solution of an order test


# ----------------------------------------------------------------------------- 1. convergence order
# Double pendulum from (1.0, 0.5) at rest, T = 2.  N ranges in the asymptotic regime and
# above the solver floor: the whole-trajectory solution differs from the exact DEL solution
# by ~1e-10..1e-9 (Ipopt's tol 1e-10 acts on gradient-scaled rows), which spoils galerkin4's
# slope from the gentler start (0.5, 0.3), where its error at N = 200 is only 1.7e-9.
# Measured slopes (at T / max over nodes): midpoint 1.993/1.993, trapezoid 1.991/1.991,
# galerkin4 3.967/3.968.
ORDER_Q0 = [1.0, 0.5]
ORDER_NS = {"midpoint": [50, 100, 200, 400], "trapezoid": [50, 100, 200, 400], "galerkin4": [25, 50, 100, 200]}
# error bound at the finest N (a converging but wrong answer would not pass): measured
# midpoint 1.6e-4, trapezoid 1.1e-4, galerkin4 1.5e-7
FINEST_ERR = {"midpoint": 5e-4, "trapezoid": 5e-4, "galerkin4": 5e-7}
SLOPE_BAND = {2: (1.9, 2.1), 4: (3.8, 4.2)}


@pytest.mark.parametrize("scheme", SCHEMES)
def test_whole_trajectory_order(scheme):
    system = double_pendulum()
    ns = ORDER_NS[scheme]
    err_T, err_max = [], []
    for N in ns:
        r = tr.solve_initial_value(system, ORDER_Q0, [0.0, 0.0], 2.0, N, scheme)
        assert r.success, r.message
        assert r.q.shape == (N + 1, 2) and r.t.shape == (N + 1,)
        assert r.mode == "initial_value" and r.scheme == scheme
        np.testing.assert_array_equal(r.q[0], ORDER_Q0)
        q_ref, _ = st.reference(system, ORDER_Q0, [0.0, 0.0], r.t, rtol=REF_TOL, atol=REF_TOL)
        err_T.append(np.max(np.abs(r.q[-1] - q_ref[-1])))
        err_max.append(np.max(np.abs(r.q - q_ref)))
    lo, hi = SLOPE_BAND[ORDER[scheme]]
    for what, errs in (("at T", err_T), ("max over nodes", err_max)):
        slope = observed_order(ns, errs)
        assert lo <= slope <= hi, f"{scheme} {what}: slope {slope:.3f}, errors {errs}"
    assert err_max[-1] < FINEST_ERR[scheme], err_max


# ----------------------------------------------------------------------------- 2. normal modes
def _linear_modes(g, l):
    """Equal masses m and lengths l, angles from the vertical.  Linearised about the bottom:

        K = ½ m l² (2 θ̇1² + 2 θ̇1 θ̇2 + θ̇2²),  U ≈ ½ m g l (2 θ1² + θ2²)
        => M = m l² [[2, 1], [1, 1]],  K = m g l diag(2, 1).

    det(K − ω² M) = 0 with x = ω² l / g:  2 (1 − x)² = x²  =>  x = 2 ∓ √2;
    second row: −x v1 + (1 − x) v2 = 0  =>  v2 / v1 = x / (1 − x) = ±√2.
    """
    w2 = np.array([2.0 - math.sqrt(2.0), 2.0 + math.sqrt(2.0)]) * g / l
    shapes = np.array([[1.0, math.sqrt(2.0)], [1.0, -math.sqrt(2.0)]])
    Mm, Kk = np.array([[2.0, 1.0], [1.0, 1.0]]), g / l * np.diag([2.0, 1.0])
    for w2i, v in zip(w2, shapes):  # the derivation, checked numerically
        assert np.allclose((Kk - w2i * Mm) @ v, 0.0, atol=1e-12)
    return np.sqrt(w2), shapes, Mm


# Discrete frequency of each scheme on a linear oscillator ẍ = −ω² x (nodes only):
#   midpoint:  (Δ²x)/h² + ω² (x₊ + 2x + x₋)/4 = 0   =>  tan(ω_d h/2) = ω h/2
#   trapezoid: (Δ²x)/h² + ω² x = 0                 =>  sin(ω_d h/2) = ω h/2
# (insert x_k = cos(ω_d k h)); galerkin4 is only bounded: |ω_d/ω − 1| <= (ω h)⁴ / 1000
# (measured coefficient 3.5e-4).  The linear modes decouple, so each mode obeys its formula.
def _predicted_frequency(scheme, w, h):
    if scheme == "midpoint":
        return 2.0 / h * math.atan(w * h / 2.0)
    if scheme == "trapezoid":
        return 2.0 / h * math.asin(w * h / 2.0)
    return w


MODE_A = 1e-3


@pytest.mark.parametrize("mode", [0, 1], ids=["slow", "fast"])
@pytest.mark.parametrize("scheme,N", [("midpoint", 400), ("trapezoid", 400), ("galerkin4", 100)])
def test_normal_mode(scheme, N, mode):
    """Start on a mode shape at rest: the motion stays on it, q ≈ A v cos(ω_d t).

    Oracle: ω² = (2 ∓ √2) g / l (derived above).  The amplitude 1e-3 shifts the true
    frequency by O(A²) ~ 1e-6 relative; that shift is measured on a CVODES run and removed,
    so midpoint and trapezoid must hit their exact discrete frequency to 1e-7 relative
    (measured 2e-10 slow, 3e-8 fast).
    """
    l = 1.0
    w_all, shapes, Mm = _linear_modes(G, l)
    w, v, v_other = w_all[mode], shapes[mode], shapes[1 - mode]
    T = 3 * 2 * math.pi / w_all[0]  # three slow periods (7.2 fast ones)
    system = double_pendulum(l1=l, l2=l, g=G)
    r = tr.solve_initial_value(system, MODE_A * v, [0.0, 0.0], T, N, scheme)
    assert r.success, r.message
    h = T / N

    # modal coordinates (M-orthogonal projection)
    eta = r.q @ Mm @ v / (v @ Mm @ v)
    eta_other = r.q @ Mm @ v_other / (v_other @ Mm @ v_other)
    assert np.max(np.abs(eta_other)) <= 1e-5 * MODE_A  # measured 1.4e-7..2.6e-7 A: no mode mixing

    # amplitude-induced frequency shift of the true (nonlinear) motion, from CVODES
    t_fine = np.linspace(0.0, T, 4001)
    q_ref, _ = st.reference(system, MODE_A * v, [0.0, 0.0], t_fine)
    shift = sampled_frequency(q_ref @ Mm @ v / (v @ Mm @ v), t_fine[1]) / w - 1.0
    assert abs(shift) <= 3e-6  # O(A²): measured -8.5e-8 slow, -1.9e-6 fast

    w_d = sampled_frequency(eta, h)
    pred = _predicted_frequency(scheme, w, h)
    if scheme == "galerkin4":
        assert abs(w_d / w - 1.0 - shift) <= (w * h) ** 4 / 1000.0, (w_d / w - 1.0, shift)
        w_fit = w
    else:
        assert abs(w_d / pred - 1.0 - shift) <= 1e-7, (w_d / pred - 1.0, shift)
        # the discretisation's own error has the scheme's sign and size: ∓(ωh)²/12, +(ωh)²/24
        assert abs(pred / w - 1.0) == pytest.approx((w * h) ** 2 / (12 if scheme == "midpoint" else 24), rel=0.02)
        w_fit = pred
    # the whole motion: A v cos(ω t), error = phase drift from the frequency error
    exact = MODE_A * np.cos(w_fit * r.t)[:, None] * v
    rel = np.max(np.abs(r.q - exact)) / MODE_A
    freq_err = (w * h) ** 4 / 1000.0 if scheme == "galerkin4" else 0.0  # left in w_fit
    bound = w * T * (freq_err + 3e-6) + 1e-5
    assert rel <= bound, (rel, bound)  # measured 2e-6 .. 1.2e-4 (fast mode: the O(A²) shift)
    # and against the continuous oracle itself, within the scheme's frequency error
    rel0 = np.max(np.abs(r.q - MODE_A * np.cos(w * r.t)[:, None] * v)) / MODE_A
    assert rel0 <= 1.5 * w * T * (abs(pred / w - 1.0) + freq_err + 3e-6) + 1e-5, rel0


def test_normal_mode_galerkin4_fourth_order():
    """Fast mode: galerkin4's frequency error falls by 2⁴ when h halves (measured 15.9-16.0)."""
    w_all, shapes, Mm = _linear_modes(G, 1.0)
    w, v = w_all[1], shapes[1]
    T = 3 * 2 * math.pi / w_all[0]
    system = double_pendulum()
    t_fine = np.linspace(0.0, T, 4001)
    q_ref, _ = st.reference(system, MODE_A * v, [0.0, 0.0], t_fine)
    w_true = sampled_frequency(q_ref @ Mm @ v / (v @ Mm @ v), t_fine[1])
    errs = []
    for N in (100, 200):
        r = tr.solve_initial_value(system, MODE_A * v, [0.0, 0.0], T, N, "galerkin4")
        assert r.success, r.message
        errs.append(abs(sampled_frequency(r.q @ Mm @ v / (v @ Mm @ v), T / N) / w_true - 1.0))
    assert math.log2(errs[0] / errs[1]) == pytest.approx(4.0, abs=0.3), errs


# ----------------------------------------------------------------------------- 3. whole vs marched
# Both methods solve exactly the same DEL equations (discrete.DiscreteMechanics), one node at a
# time (march: Newton to 1e-12 plus a polishing step) or all at once (Ipopt, tol 1e-10 on
# gradient-scaled rows).  Their difference is therefore only solver error, amplified by the
# dynamics.  Moderate amplitude over T = 2, moving start: measured |Δq| ≤ 1.7e-11, |Δp| ≤ 5.6e-11,
# |Δv| ≤ 1.2e-10 (but 5e-10 in q for galerkin4 at N = 200 from (0.5, 0.3) at rest, where Ipopt
# stops after one iteration with DEL residuals of 7e-9): asserted ≤ 1e-8 in q.
MODERATE_Q0, MODERATE_QD0 = [1.0, 0.5], [0.3, -0.4]


@pytest.mark.parametrize("scheme", SCHEMES)
def test_whole_equals_march_moderate(scheme):
    system = double_pendulum()
    N = 100 if scheme == "galerkin4" else 200
    w = tr.solve_initial_value(system, MODERATE_Q0, MODERATE_QD0, 2.0, N, scheme)
    m = st.march(system, MODERATE_Q0, MODERATE_QD0, 2.0, N, scheme)
    assert w.success and m.success, (w.message, m.message)
    assert np.max(np.abs(w.q - m.q)) <= 1e-8
    assert np.max(np.abs(w.p - m.p)) <= 1e-7
    assert np.max(np.abs(w.v - m.qd)) <= 1e-7
    assert np.max(np.abs(w.energy - m.energy)) <= 1e-6
    if scheme == "galerkin4":
        # the stage sits at mid-step (τ = ½ of the quadratic piece): compare with the exact motion there
        t_mid = w.t[:-1] + 0.5 * (2.0 / N)
        q_mid, _ = st.reference(system, MODERATE_Q0, MODERATE_QD0, t_mid, rtol=REF_TOL, atol=REF_TOL)
        assert np.max(np.abs(w.stages - q_mid)) <= 1e-5  # measured 2.5e-6, as accurate as the nodes


@pytest.mark.parametrize("scheme", SCHEMES)
def test_whole_equals_march_chaotic(scheme):
    """The chaotic default θ = (2, 1), T = 5, N = 2000.

    Here a perturbation of the state grows by a factor ~100 over the horizon (measured below,
    as the sensitivity of the march to its initial angle), so the per-node solver error
    (≤ ~1e-9 for either method) may reach ~1e-7 at late times.  The tolerance is that
    product; measured differences: midpoint 2.6e-11, trapezoid 4.6e-12, galerkin4 1.8e-9.
    """
    system = double_pendulum()
    q0, T, N = [2.0, 1.0], 5.0, 2000
    w = tr.solve_initial_value(system, q0, [0.0, 0.0], T, N, scheme)
    m = st.march(system, q0, [0.0, 0.0], T, N, scheme)
    assert w.success and m.success, (w.message, m.message)
    delta = 1e-8
    mp = st.march(system, [q0[0] + delta, q0[1]], [0.0, 0.0], T, N, scheme)
    amplification = np.max(np.abs(mp.q - m.q)) / delta
    assert amplification > 10.0  # the motion is sensitive: a looser tolerance is warranted
    tol = 1e-9 * amplification
    diff = np.max(np.abs(w.q - m.q), axis=1)
    assert diff.max() <= tol, (diff.max(), tol)
    # the error grows with time, as amplified solver error should (early nodes agree closely)
    assert diff[: N // 10].max() <= 1e-9


# ----------------------------------------------------------------------------- 4. boundary mode
# Free flight: L = ½ m |ẋ|² − m g y.  The exact path is quadratic in t, and all three schemes
# reproduce it exactly at the nodes:
# * midpoint and trapezoid integrate L exactly for a piecewise-linear path (|ẋ|² constant on a
#   step, y linear), so S_d is the exact action restricted to piecewise-linear paths: a linear
#   finite-element Galerkin method for m ÿ = −m g.  In 1-D the Green's function of d²/dt² with
#   fixed ends is piecewise linear with its kink at the node, so linear elements are exact at
#   the nodes (nodal superconvergence), for any right-hand side.
# * galerkin4 uses quadratic pieces with Simpson's rule, exact for the cubic integrand of a
#   quadratic path; the exact parabola is itself in the trial space and is stationary for the
#   exact action, hence for S_d (strictly convex: unique stationary point).  It is exact
#   everywhere, including its stage at mid-step.
# Velocities from the discrete Legendre transform are exact too (checked).
@pytest.mark.parametrize("N", [7, 40, 100])
@pytest.mark.parametrize("scheme", SCHEMES)
def test_boundary_free_fall_parabola(scheme, N):
    m, L, H, T = 2.5, 3.0, 1.0, 1.2
    system = point_mass(m=m, g=G)
    r = tr.solve_boundary(system, [0.0, 0.0], [L, H], T, N, scheme)
    assert r.success, r.message
    assert r.mode == "boundary"
    q, qd = free_fall(r.t, [0.0, 0.0], [L, H], T, G)
    assert np.max(np.abs(r.q - q)) <= 1e-9  # measured ≤ 1.3e-13
    assert np.max(np.abs(r.v - qd)) <= 1e-9
    if scheme == "galerkin4":
        zq, _ = free_fall(r.t[:-1] + T / N / 2, [0.0, 0.0], [L, H], T, G)
        assert np.max(np.abs(r.stages - zq)) <= 1e-9


@pytest.mark.parametrize("N", [1000, 4000])
def test_boundary_free_fall_large_n(N):
    """Regression: the h-scaled action gradient has a round-off floor ~ eps M / h² that exceeded
    Ipopt's tol at N >= ~512 (Search_Direction_Becomes_Too_Small although the answer was exact);
    the objective is now scaled to a position-level quantity."""
    r = tr.solve_boundary(point_mass(g=G), [0.0, 0.0], [3.0, 1.0], 1.2, N, "midpoint")
    q, _ = free_fall(r.t, [0.0, 0.0], [3.0, 1.0], 1.2, G)
    assert r.success, r.message
    assert np.max(np.abs(r.q - q)) <= 1e-9


def _shooting_velocity(system, q0, qT, T, v_guess):
    """Initial velocity with q(T) = qT by the secant method on CVODES solutions."""
    def miss(v):
        q, _ = st.reference(system, [q0], [v], [0.0, T])
        return q[-1, 0] - qT
    v0, v1 = v_guess, v_guess * 1.01
    f0, f1 = miss(v0), miss(v1)
    for _ in range(30):
        v0, v1, f0 = v1, v1 - f1 * (v1 - v0) / (f1 - f0), f1
        f1 = miss(v1)
        if abs(f1) < 1e-13:
            break
    assert abs(f1) < 1e-11
    return v1


# discretisation bounds at N = 100 on the initial velocity (measured: midpoint 1.2e-3,
# trapezoid 4.6e-4, galerkin4 6.7e-9) and on the nodes (4.2e-4, 2.4e-4, 1.4e-9)
V0_TOL = {"midpoint": 2.5e-3, "trapezoid": 1e-3, "galerkin4": 2e-8}
BVP_Q_TOL = {"midpoint": 1e-3, "trapezoid": 6e-4, "galerkin4": 5e-9}


@pytest.mark.parametrize("scheme", SCHEMES)
def test_boundary_pendulum_matches_initial_value(scheme):
    """Simple pendulum from θ = 0.3 to θ = −0.2 in T = 1 (just under half a small-oscillation
    period, so the action is still a minimum).

    The boundary solution satisfies the DEL equations at every interior node; its initial
    velocity v0 = M⁻¹ p0⁺ reproduces p0⁺ = −D₁L_d(q0, q1) exactly, so the initial-value solve
    from (θ0, v0) must retrace it to solver tolerance (measured ≤ 1.7e-12).  Both differ from
    the true motion by discretisation error only: v0 against CVODES shooting.
    """
    system = n_link_pendulum([1.0], [1.0], G)
    N, T = 100, 1.0
    b = tr.solve_boundary(system, [0.3], [-0.2], T, N, scheme)
    assert b.success, b.message
    assert b.q[0, 0] == 0.3 and b.q[-1, 0] == -0.2
    v0 = float(b.v[0, 0])
    i = tr.solve_initial_value(system, [0.3], [v0], T, N, scheme)
    assert i.success, i.message
    assert np.max(np.abs(i.q - b.q)) <= 1e-7
    assert abs(i.q[-1, 0] - (-0.2)) <= 1e-7
    v_star = _shooting_velocity(system, 0.3, -0.2, T, v0)
    assert abs(v0 - v_star) <= V0_TOL[scheme], (v0, v_star)
    q_ref, _ = st.reference(system, [0.3], [v_star], b.t)
    assert np.max(np.abs(b.q - q_ref)) <= BVP_Q_TOL[scheme]


# ----------------------------------------------------------------------------- 5. holonomic constraints
PEND_M, PEND_L = 1.3, 0.8
CART_NS = {"midpoint": [50, 100, 200], "trapezoid": [50, 100, 200], "galerkin4": [25, 50, 100]}


def _cartesian_state(theta, omega, l):
    return ([l * math.sin(theta), -l * math.cos(theta)],
            [l * omega * math.cos(theta), l * omega * math.sin(theta)])


@pytest.mark.parametrize("scheme", SCHEMES)
def test_cartesian_pendulum_against_angle_form(scheme):
    """(x, y) with c = (x² + y² − l²)/2 = 0 against θ: same physics, different unknowns.

    The constraint is an equation of the NLP, so it holds to solver tolerance at every node
    (and at galerkin4's stages).  Both discretisations converge to the same motion, so
    their difference converges at the scheme's order (measured 2.00, 2.00, 4.00).
    """
    th0, om0, T = 1.0, 0.5, 2.0
    cart = cartesian_pendulum(m=PEND_M, l=PEND_L, g=G)
    ang = n_link_pendulum([PEND_M], [PEND_L], G)
    x0, v0 = _cartesian_state(th0, om0, PEND_L)
    ns = CART_NS[scheme]
    err_ref, diff = [], []
    for N in ns:
        rc = tr.solve_initial_value(cart, x0, v0, T, N, scheme)
        ra = tr.solve_initial_value(ang, [th0], [om0], T, N, scheme)
        assert rc.success and ra.success, (rc.message, ra.message)
        res = 0.5 * np.abs(np.sum(rc.q ** 2, axis=1) - PEND_L ** 2)
        assert res.max() <= 1e-9, res.max()  # measured ≤ 4e-12
        if scheme == "galerkin4":
            assert 0.5 * np.abs(np.sum(rc.stages ** 2, axis=1) - PEND_L ** 2).max() <= 1e-9
        assert np.max(np.abs(np.sum(rc.q * rc.v, axis=1))) <= 1e-9  # velocities tangent
        assert rc.multipliers.shape == (N, 1)
        th, _ = st.reference(ang, [th0], [om0], rc.t, rtol=REF_TOL, atol=REF_TOL)
        xy_ref = np.column_stack([PEND_L * np.sin(th[:, 0]), -PEND_L * np.cos(th[:, 0])])
        xy_ang = np.column_stack([PEND_L * np.sin(ra.q[:, 0]), -PEND_L * np.cos(ra.q[:, 0])])
        err_ref.append(np.max(np.abs(rc.q - xy_ref)))
        diff.append(np.max(np.abs(rc.q - xy_ang)))
    p = ORDER[scheme]
    assert observed_order(ns, err_ref) == pytest.approx(p, abs=0.2), err_ref
    assert observed_order(ns, diff) == pytest.approx(p, abs=0.2), diff
    assert diff[-1] <= (1e-3 if p == 2 else 1e-6), diff  # measured 7.4e-4 / 2.5e-7


@pytest.mark.parametrize("scheme", SCHEMES)
def test_cartesian_pendulum_multiplier_is_rod_force(scheme):
    """Released from the bottom with angular velocity ω0.

    Sign convention (discrete.py): the DEL residual gains −∇c(q)ᵀλ, i.e. the continuous limit
    is M q̈ = −∇U − λ ∇c with ∇c = (x, y).  At the bottom (0, −l):
    m l ω0² = −m g + λ l  (centripetal acceleration points up)  =>  λ = m (g + l ω0²) / l > 0.
    Along the motion λ(t) = m (g cos θ + l θ̇²) / l, θ(t) from CVODES on the angle form.
    Multipliers converge at second order for every scheme (measured 2.00).
    """
    om0, T = 2.0, 1.0
    cart = cartesian_pendulum(m=PEND_M, l=PEND_L, g=G)
    ang = n_link_pendulum([PEND_M], [PEND_L], G)
    lam0_exact = pendulum_rod_force(PEND_M, PEND_L, G, 0.0, om0) / PEND_L
    assert lam0_exact == pytest.approx(PEND_M * (G + PEND_L * om0 ** 2) / PEND_L)
    ns, err0, err_all = [50, 100], [], []
    for N in ns:
        r = tr.solve_initial_value(cart, [0.0, -PEND_L], [PEND_L * om0, 0.0], T, N, scheme)
        assert r.success, r.message
        lam = r.multipliers[:, 0]  # row k: multiplier at node t_k, k = 0..N-1
        assert np.all(lam > 0)
        th, thd = st.reference(ang, [0.0], [om0], r.t[:-1], rtol=1e-13, atol=1e-13)
        lam_exact = pendulum_rod_force(PEND_M, PEND_L, G, th[:, 0], thd[:, 0]) / PEND_L
        err0.append(abs(lam[0] - lam0_exact))
        err_all.append(np.max(np.abs(lam - lam_exact)))
    assert err0[-1] <= 1e-4 * lam0_exact, err0  # measured 2.5e-5 .. 5.4e-5 relative at N = 100
    assert err_all[-1] <= 1e-4 * lam0_exact, err_all
    assert observed_order(ns, err_all) == pytest.approx(2.0, abs=0.2), err_all


# ----------------------------------------------------------------------------- 6. energy
# Simple pendulum, amplitude 0.1 rad, 1000 periods at 20 steps per period (N = 20 000): the
# whole-trajectory solve takes 2-3 s per scheme.  Measured: the energy error of the
# variational schemes is flat (second/first half 1.000, last/first tenth 1.000; largest error
# 2.0e-5 (midpoint), 3.4e-5 (galerkin4), 2.5e-2 (trapezoid) of the swing energy m g l (1 − cos A));
# RK4 at the same step loses energy linearly (second/first half 1.88, last/first tenth 8.9,
# 23 % of the swing energy gone at the end).
AMP, STEPS_PER_PERIOD, PERIODS = 0.1, 20, 1000


def _long_run_args(periods):
    T = periods * 2 * math.pi / math.sqrt(G)
    return n_link_pendulum([1.0], [1.0], G), [AMP], [0.0], T, periods * STEPS_PER_PERIOD


@pytest.mark.parametrize("scheme", SCHEMES)
def test_energy_bounded_long_horizon(scheme):
    args = _long_run_args(PERIODS)
    r = tr.solve_initial_value(*args, scheme=scheme)
    assert r.success, r.message
    swing = G * (1.0 - math.cos(AMP))
    dE = r.energy - r.energy[0]
    halves, tenths = energy_growth(dE)
    assert halves <= 1.5 and tenths <= 1.5, (halves, tenths)
    assert np.max(np.abs(dE)) <= 0.05 * swing
    rk = st.rk4(*args)
    assert rk.success, rk.message
    dR = rk.energy - rk.energy[0]
    rk_halves, rk_tenths = energy_growth(dR)
    assert rk_tenths > 3.0 and rk_halves > 1.5, (rk_halves, rk_tenths)
    assert np.all(np.diff(rk.energy[:: STEPS_PER_PERIOD * 10]) < 0)  # monotone loss, every 10 periods
    if scheme != "trapezoid":  # the symplectic schemes beat RK4's error at the same step outright
        assert np.max(np.abs(dE)) < 0.01 * np.max(np.abs(dR))


# ----------------------------------------------------------------------------- 7. refused input
BAD_IVP = [
    dict(T=0.0), dict(T=-1.0), dict(T=float("nan")), dict(T=float("inf")),
    dict(N=1), dict(N=0), dict(N=-5), dict(N=2.5),
    dict(q0=[float("nan"), 0.0]), dict(q0=[0.1]), dict(q0=[0.1, 0.2, 0.3]),
    dict(qd0=[0.0, float("inf")]), dict(qd0=[0.0]),
]


def _label(d):
    return ",".join(f"{k}={v}" for k, v in d.items())


@pytest.mark.parametrize("bad", BAD_IVP, ids=_label)
def test_initial_value_bad_input_refused(bad):
    args = dict(q0=[0.5, 0.3], qd0=[0.0, 0.0], T=1.0, N=10) | bad
    with pytest.raises(InputError):
        tr.solve_initial_value(double_pendulum(), args["q0"], args["qd0"], args["T"], args["N"])


BAD_BVP = [dict(T=0.0), dict(T=-2.0), dict(N=1), dict(N=3.5),
           dict(q0=[float("nan"), 0.0]), dict(qT=[0.0, float("inf")]), dict(qT=[1.0])]


@pytest.mark.parametrize("bad", BAD_BVP, ids=_label)
def test_boundary_bad_input_refused(bad):
    args = dict(q0=[0.0, 0.0], qT=[1.0, 1.0], T=1.0, N=10) | bad
    with pytest.raises(InputError):
        tr.solve_boundary(point_mass(g=G), args["q0"], args["qT"], args["T"], args["N"])


@pytest.mark.parametrize("q0,qd0", [([0.8, -0.8], [0.0, 0.0]),         # off the circle
                                    ([0.0, -0.8 * (1 + 1e-6)], [1.0, 0.0]),  # barely off
                                    ([0.0, -0.8], [0.0, 1.0])],        # velocity along the rod
                         ids=["position", "position_1e-6", "velocity"])
def test_cartesian_inconsistent_start_refused(q0, qd0):
    with pytest.raises(InputError):
        tr.solve_initial_value(cartesian_pendulum(l=0.8), q0, qd0, 1.0, 10)


@pytest.mark.parametrize("masses,lengths", [([0.0], [1.0]), ([-1.0], [1.0]), ([1.0], [0.0]),
                                            ([1.0, 1.0], [1.0, -2.0]), ([float("nan")], [1.0]),
                                            ([1.0, 1.0], [1.0]), ([], [])])
def test_n_link_pendulum_bad_parameters(masses, lengths):
    with pytest.raises(InputError):
        n_link_pendulum(masses, lengths)


@pytest.mark.parametrize("solve", [tr.solve_initial_value, tr.solve_boundary], ids=["ivp", "bvp"])
def test_unknown_scheme(solve):
    with pytest.raises(ValueError, match="scheme"):
        solve(double_pendulum(), [0.5, 0.3], [0.0, 0.0], 1.0, 10, "leapfrog")


# ----------------------------------------------------------------------------- 8. honest results
@pytest.fixture
def solve_log(monkeypatch):
    """Every TrajectoryNLP.solve and .check call (levels, windows, checks of an assembly), in order."""
    calls = []

    def counting(original):
        def call(self, *args, **kwargs):
            res = original(self, *args, **kwargs)
            calls.append((self.N, res.solver_status, res.iterations))
            return res
        return call

    monkeypatch.setattr(tr.TrajectoryNLP, "solve", counting(tr.TrajectoryNLP.solve))
    monkeypatch.setattr(tr.TrajectoryNLP, "check", counting(tr.TrajectoryNLP.check))
    return calls


def _check_levels(r, calls, N):
    assert len(r.levels) == len(calls) >= 1
    assert [lv.status for lv in r.levels] == [c[1] for c in calls]
    assert [lv.iterations for lv in r.levels] == [c[2] for c in calls]
    assert r.iterations == sum(c[2] for c in calls)
    # the answer's solve is the last towards it; the error estimate's coarser grid may follow
    last = [lv for lv in r.levels if lv.purpose == "solve"][-1]
    assert last.n == N and last.horizon == N and last.status == r.solver_status
    assert all(lv.n < N for lv in r.levels[r.levels.index(last) + 1:])
    assert all(lv.horizon <= lv.n for lv in r.levels)


@pytest.mark.parametrize("N", [40, 64])
def test_unconverged_solve_reported(solve_log, N):
    r = tr.solve_initial_value(double_pendulum(), [2.0, 1.0], [0.0, 0.0], 5.0, N, options={"max_iter": 1})
    assert r.success is False
    assert r.status != "Solve_Succeeded" and r.status not in SUCCESS_STATUSES
    assert r.status in r.message
    assert all(c[2] <= 1 for c in solve_log)  # the caller's max_iter is honoured by every solve
    _check_levels(r, solve_log, N)


def test_windowed_solve_recorded(solve_log):
    """Chaotic start over T = 10 s: every sub-solve is counted, and the answer is the solution of the
    discrete equations (the march of the same scheme agrees to 5e-10 measured)."""
    N = 200
    r = tr.solve_initial_value(double_pendulum(), [2.0, 1.0], [0.0, 0.0], 10.0, N)
    # (the estimate's grid N = 100 does not converge even in windows: an answer whose error cannot be estimated is
    # not ok, issue 41; the answer is the discrete solution all the same)
    assert r.success or (r.status == "Error_Not_Estimated" and "N = 100" in r.message), r.message
    _check_levels(r, solve_log, N)
    marched = st.march(double_pendulum(), [2.0, 1.0], [0.0, 0.0], 10.0, N)
    assert np.max(np.abs(r.q - marched.q)) < 1e-7
    assert r.time_s == pytest.approx(r.build_time_s + r.solve_time_s)


def test_boundary_levels_recorded(solve_log):
    r = tr.solve_boundary(n_link_pendulum([1.0], [1.0], G), [0.3], [-0.2], 1.0, 128)
    assert r.success, r.message
    _check_levels(r, solve_log, 128)
    ns = [lv.n for lv in r.levels]
    assert ns == sorted(ns) and len(ns) >= 2  # coarse to fine, every level listed


@pytest.mark.parametrize("scheme", ["midpoint", "galerkin4"])
def test_extrapolated_guess_beats_interpolation(scheme):
    """Richardson extrapolation of two levels to the new step: a much closer guess than interpolation.

    Double pendulum from (1.0, 0.5) at rest, T = 2 (asymptotic regime); levels of 100 and
    200 steps, target 1600 steps, errors against the 1600-step solution.  Measured: midpoint
    6.2e-4 -> 2.9e-6, galerkin4 6.7e-7 -> 4.7e-8 (quintic stencils; cubic ones left galerkin4
    at 6.1e-7, limited by the interpolation error, of the scheme's own order).
    """
    system, q0, T = double_pendulum(), np.array([1.0, 0.5]), 2.0
    dm = tr.DiscreteMechanics(system, scheme)
    p0 = np.asarray(system.momentum(q0, np.zeros(2))).reshape(-1)
    levels = []
    for n in (100, 200):
        r = tr.solve_initial_value(system, q0, [0.0, 0.0], T, n, scheme)
        values = {"q": r.q.reshape(-1), "Z": r.stages.reshape(-1)}
        levels.append((tr.TrajectoryNLP(dm, n, T, "initial_value", q0, p0), values))
    target = tr.TrajectoryNLP(dm, 1600, T, "initial_value", q0, p0)
    exact = tr.solve_initial_value(system, q0, [0.0, 0.0], T, 1600, scheme).q.reshape(-1)
    interpolated = np.abs(tr._refine(*levels[1], target)["q"] - exact).max()
    extrapolated = np.abs(tr._extrapolate(*levels, target)["q"] - exact).max()
    assert extrapolated < interpolated / 10, (extrapolated, interpolated)
    from_extrapolated = target.solve(tr._extrapolate(*levels, target))
    from_interpolated = target.solve(tr._refine(*levels[1], target))
    assert from_extrapolated.success and from_interpolated.success
    assert from_extrapolated.iterations == 1  # measured: interpolation needs 2 (midpoint)
    assert from_extrapolated.iterations <= from_interpolated.iterations


def test_ladder_jumps_to_n():
    """Chaotic double pendulum: once a level converges in one Newton step, the next level is N."""
    r = tr.solve_initial_value(double_pendulum(), [2.0, 1.0], [0.0, 0.0], 5.0, 16000)
    assert r.success, r.message
    solves = [lv for lv in r.levels if lv.purpose == "solve"]
    ns = sorted({lv.n for lv in solves})
    assert ns[-1] == 16000 and ns[-2] <= 2000  # no levels between the jump and N
    assert solves[-1].iterations <= 2
    assert all(0.0 <= lv.function_time_s <= lv.solve_time_s for lv in r.levels)


# ----------------------------------------------------------------------------- 9. element families
# Chained Rosenbrock in 6 unknowns:
#   min  Σ_i 100 (x_{i+1} − x_i²)² + (1 − x_i)²  +  Σ_{j∈{2,3}} 0.1 (x_j·x_j − 0.5)²
#   s.t. x_i² + x_{i+1}² <= 1                        (element inequality, several active)
#        x_1·x_1 + sin(x_1)·x_1² <= 0.5              (element on indices [[1, 1]])
#        Σ x = 4                                     (ordinary expression equality)
# At the solution two disk rows and the twin row are active (multipliers −7.6, −0.40, −52.6).
# The last objective family and the "twin" inequality feed one global unknown to both local
# slots, so their derivatives must sum both contributions (∂/∂x f(x, x) = f_a + f_b).
NX = 6
X_INIT = np.linspace(-1.2, 1.0, NX)
TWIN = [2, 3]


def _element_functions():
    a, b = ca.SX.sym("a"), ca.SX.sym("b")
    z = ca.SX.sym("z", 2)
    return (ca.Function("rosen", [a, b], [100 * (b - a ** 2) ** 2 + (1 - a) ** 2]),
            ca.Function("disk", [a, b], [a ** 2 + b ** 2]),
            ca.Function("twin", [z], [z[0] * z[1] + ca.sin(z[0]) * z[1] ** 2]),
            ca.Function("pair", [z], [0.1 * (z[0] * z[1] - 0.5) ** 2]))


def _rosenbrock_nlp(elements: bool):
    nlp = NLP()
    x = nlp.variable("x", NX, init=X_INIT)
    i = nlp.index("x")
    rosen, disk, twin, pair = _element_functions()
    if elements:
        nlp.minimize_elements("rosen", rosen, [X(i[:-1, None]), X(i[1:, None])])
        nlp.minimize_elements("pair", pair, [X(np.column_stack([i[TWIN], i[TWIN]]))])
        nlp.inequality_elements("disk", disk, [X(i[:-1, None]), X(i[1:, None])], ub=1.0)
        nlp.inequality_elements("twin", twin, [X([[i[1], i[1]]])], ub=0.5)
    else:
        nlp.minimize(sum(100 * (x[k + 1] - x[k] ** 2) ** 2 + (1 - x[k]) ** 2 for k in range(NX - 1))
                     + sum(0.1 * (x[j] * x[j] - 0.5) ** 2 for j in TWIN))
        nlp.inequality("disk", ca.vertcat(*[x[k] ** 2 + x[k + 1] ** 2 for k in range(NX - 1)]), ub=1.0)
        nlp.inequality("twin", x[1] * x[1] + ca.sin(x[1]) * x[1] ** 2, ub=0.5)
    nlp.equal("sum", ca.sum1(x), 4.0)
    return nlp


def _reference_expressions():
    """Objective and constraint rows (in the NLPs' row order) written out by hand."""
    x = ca.SX.sym("x", NX)
    f = sum(100 * (x[k + 1] - x[k] ** 2) ** 2 + (1 - x[k]) ** 2 for k in range(NX - 1)) \
        + sum(0.1 * (x[j] ** 2 - 0.5) ** 2 for j in TWIN)
    g = ca.vertcat(*[x[k] ** 2 + x[k + 1] ** 2 for k in range(NX - 1)],
                   x[1] ** 2 + ca.sin(x[1]) * x[1] ** 2, ca.sum1(x))
    return x, f, g


def test_element_families_solve_like_expressions():
    re, rx = _rosenbrock_nlp(True).solve(), _rosenbrock_nlp(False).solve()
    assert re.success and rx.success, (re.message, rx.message)
    assert re.iterations == rx.iterations
    np.testing.assert_allclose(re["x"], rx["x"], rtol=0, atol=1e-10)
    assert re.objective == pytest.approx(rx.objective, rel=1e-10)
    assert set(re.multipliers) == set(rx.multipliers) == {"disk", "twin", "sum"}
    for name in rx.multipliers:
        np.testing.assert_allclose(re.multipliers[name], rx.multipliers[name], rtol=1e-8, atol=1e-10)
    # the problem exercises what it claims: some disk rows and the twin row are active
    x = rx["x"]
    disk = x[:-1] ** 2 + x[1:] ** 2
    assert np.sum(np.abs(disk - 1.0) < 1e-8) >= 2 and np.sum(rx.multipliers["disk"] < -1e-2) >= 2
    assert abs(x[1] ** 2 + math.sin(x[1]) * x[1] ** 2 - 0.5) < 1e-8 and rx.multipliers["twin"][0] < -1e-3


def test_element_families_derivatives_match_casadi():
    xs, f, g = _reference_expressions()
    lf, lg = ca.SX.sym("lf"), ca.SX.sym("lg", g.numel())
    ref = ca.Function("ref", [xs, lf, lg],
                      [g, ca.densify(ca.jacobian(g, xs)), ca.densify(ca.triu(ca.hessian(lf * f + ca.dot(lg, g), xs)[0]))])
    rng = np.random.default_rng(7)
    for elements in (True, False):
        nlp = _rosenbrock_nlp(elements)
        solver = nlp.build()
        jac_g, hess_l = solver.get_function("nlp_jac_g"), solver.get_function("nlp_hess_l")
        for _ in range(3):
            x = rng.uniform(-1.5, 1.5, NX)
            sig, lam = rng.uniform(0.5, 2.0), rng.normal(size=g.numel())
            g_ref, J_ref, H_ref = (np.asarray(v) for v in ref(x, sig, lam))
            gv, J = jac_g(x, np.zeros(0))
            H = np.asarray(ca.densify(hess_l(x, np.zeros(0), sig, lam)))
            np.testing.assert_allclose(np.asarray(gv).reshape(-1), g_ref.reshape(-1), rtol=1e-12, atol=1e-12)
            np.testing.assert_allclose(np.asarray(ca.densify(J)), J_ref, rtol=1e-12, atol=1e-12)
            np.testing.assert_allclose(H, H_ref, rtol=1e-12, atol=1e-11)
            assert np.all(np.tril(H, -1) == 0.0)  # upper triangle only, as Ipopt's interface expects
    # the repeated index really is there: d²/dx1² of the twin row is 2 + 2 sin(x1) + 4 x1 cos(x1) − x1² sin(x1)
    x = np.full(NX, 0.3)
    lam = np.zeros(g.numel())
    lam[NX - 1] = 1.0  # twin row
    H = np.asarray(ca.densify(_rosenbrock_nlp(True).build().get_function("nlp_hess_l")(x, np.zeros(0), 0.0, lam)))
    x1 = 0.3
    assert H[1, 1] == pytest.approx(2 + 2 * math.sin(x1) + 4 * x1 * math.cos(x1) - x1 ** 2 * math.sin(x1), rel=1e-12)
