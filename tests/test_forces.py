"""Time, forces and dissipation (Lagrange–d'Alembert) in every element, against closed forms and peers.

Oracles: the damped oscillator's closed form in every regime; DOP853 at rtol 1e-12 on the damped,
driven pendulum (T = 20, predictable); Kapitza's averaged stability threshold ``a²ω² = 2gl``; the same
moving-pivot pendulum written two ways (an atom that holds the time, and Cartesian coordinates with a
time-dependent constraint); the equations printed by the derivation against the package's own.
"""
import math

import casadi as ca
import numpy as np
import pytest

import castrajectory as ct
from castrajectory.models import oscillator, pendulum
from castrajectory.solve import trajectory as tr
from castrajectory.validation import InputError


@pytest.mark.parametrize("par,x0,v0,T", [
    ((1.0, 4.0, 4.0, 0.0, 1.0), 1.0, 0.0, 5.0),       # critically damped, free
    ((1.0, 4.0, 10.0, 0.0, 1.0), 1.0, -2.0, 5.0),     # overdamped
    ((2.0, 8.0, 0.0, 1.0, 2.0), 0.0, 0.0, 10.0),      # undamped, driven at resonance: the amplitude grows ∝ t
    ((1.0, 0.0, 0.7, 1.0, 3.0), 0.5, 1.0, 5.0),       # no spring: a damped particle under a periodic force
])
def test_every_regime_against_the_closed_form(par, x0, v0, T):
    system = oscillator.damped_oscillator(*par)
    errs = {}
    for name in ("midpoint", "galerkin4", "galerkin8"):
        r = ct.simulate(system, [x0], [v0], T, 200, name)
        assert r.success
        x, v = oscillator.exact(r.t, *par, x0, v0)
        errs[name] = float(np.max(np.abs(r.q[:, 0] - x)))
        # the error estimate tells the true error to a factor 3 where it is above the solve's floor
        if errs[name] > 1e-10:
            assert 1 / 3 < r.error_estimate.errors["q"] / errs[name] < 3, (name, r.error_estimate.errors, errs)
    scale = max(1.0, float(np.max(np.abs(x))))
    # measured: midpoint 3e-5 to 1e-2, galerkin4 2e-8 to 4e-7, galerkin8 3e-15 to 1e-13
    assert errs["midpoint"] < 3e-2 * scale and errs["galerkin4"] < 5e-6 * scale and errs["galerkin8"] < 1e-11 * scale


def test_resonance_grows_linearly():
    par = (1.0, 4.0, 0.0, 0.5, 2.0)  # A t sin(2t) / 4
    r = ct.simulate(oscillator.damped_oscillator(*par), [0.0], [0.0], 40.0, 800, "galerkin6")
    np.testing.assert_allclose(r.q[:, 0], 0.5 * r.t * np.sin(2 * r.t) / 4, atol=2e-8)


def test_baselines_carry_time_and_forces():
    par = (1.0, 4.0, 0.3, 0.5, 1.7)
    system = oscillator.damped_oscillator(*par)
    for method, scheme, order in (("rk4", "midpoint", 4), ("march", "galerkin4", 4), ("march", "midpoint", 2),
                                  ("implicit-euler", "midpoint", 1)):
        e = []
        for n in (200, 400):
            r = ct.simulate(system, [1.0], [0.0], 6.0, n, scheme, method)
            x, _ = oscillator.exact(r.t, *par, 1.0, 0.0)
            e.append(float(np.max(np.abs(r.q[:, 0] - x))))
            bal = np.max(np.abs(r.energy - r.energy[0] - r.detail.work))
            assert bal < 10 * e[-1] + 1e-12, (method, bal, e)
        assert abs(math.log2(e[0] / e[1]) - order) < 0.3, (method, scheme, e)


def test_driven_pendulum_against_dop853():
    scipy = pytest.importorskip("scipy.integrate")
    g, w0, A, W = 0.5, 1.0, 1.2, 2.0 / 3.0
    r = ct.simulate(pendulum.driven_pendulum(g, w0, A, W), [0.0], [0.0], 20.0, 2000, "galerkin4")
    assert r.success
    sol = scipy.solve_ivp(lambda t, y: [y[1], -g * y[1] - w0 ** 2 * math.sin(y[0]) + A * math.cos(W * t)],
                          (0.0, 20.0), [0.0, 0.0], "DOP853", rtol=1e-12, atol=1e-12, t_eval=r.t)
    err = float(np.max(np.abs(sol.y[0] - r.q[:, 0])))
    assert err < 1e-8, err    # measured 1.0e-9
    assert 1 / 3 < r.error_estimate.errors["q"] / err < 3


def test_windows_start_at_their_own_time():
    """Horizon windows of a driven system: each window's elements read its own times (a window that
    started at t = 0 would feel the drive's phase at its start, not its own)."""
    system = pendulum.driven_pendulum()
    dm = tr.DiscreteMechanics(system, "galerkin4")
    N, T = 400, 20.0
    whole = ct.simulate(system, [0.3], [0.0], T, N, "galerkin4")
    tn = tr.TrajectoryNLP(dm, N, T, "initial_value", np.array([0.3]),
                          np.asarray(system.momentum([0.3], [0.0], 0.0)).ravel())
    guess = tr._initial_guess(tn, np.array([0.0]))
    log = []
    res = tr._solve_level(tn, guess, None, False, log, allow_windows=True, windows_first=True)
    assert res.success and len(log) > 2   # solved window by window
    q = res.values["q"].reshape(N + 1, 1)
    assert np.max(np.abs(q[:, 0] - whole.q[:, 0])) < 1e-9


@pytest.mark.parametrize("frequency,stays_up", [(100.0, True), (60.0, True), (35.0, False), (25.0, False)])
def test_kapitza_threshold(frequency, stays_up):
    """Both sides of a²ω² = 2gl (a = 0.1, l = 1: ω* = 44.3), each from 0.2 rad off upright at rest, T = 5."""
    a, l, g = 0.1, 1.0, 9.81
    assert (pendulum.kapitza_threshold(l, g, a, frequency) > 1) == stays_up
    r = ct.simulate(pendulum.kapitza_pendulum(l, g, a, frequency), [math.pi - 0.2], [0.0], 5.0, 2000, "galerkin4")
    assert r.success and r.error_estimate.relative < 1e-3
    dev = float(np.max(np.abs(r.q[:, 0] - math.pi)))
    assert (dev < 1.0) == stays_up, dev


def test_moving_constraint_is_the_moving_atom():
    """A pendulum whose pivot moves as (0, a cos ωt), written as an angle with a moving atom and as
    Cartesian coordinates with the time-dependent constraint |x − pivot(t)|² = l²: the same motion."""
    a, w, l, g = 0.1, 20.0, 1.0, 9.81
    th0, T, N = 1.0, 2.0, 800
    angle = pendulum.kapitza_pendulum(l, g, a, w)
    ra = ct.simulate(angle, [th0], [0.0], T, N, "galerkin4")
    x = ca.SX.sym("x", 2)
    t = ct.time()
    pivot = ca.vertcat(0, a * ca.cos(w * t))
    d = x - pivot
    cart = ct.LagrangianSystem(x, ct.Atoms([x], [1.0]), [ct.Gravity(g)], constraints=[(ca.dot(d, d) - l * l) / 2])
    x0 = [l * math.sin(th0), a - l * math.cos(th0)]
    # at t = 0 the pivot is at rest (its velocity -aω sin 0 = 0): the bob starts at rest too
    rc = ct.simulate(cart, x0, [0.0, 0.0], T, N, "galerkin4")
    assert ra.success and rc.success
    th_c = np.arctan2(rc.q[:, 0], -(rc.q[:, 1] - a * np.cos(w * rc.t)))
    assert np.max(np.abs(th_c - ra.q[:, 0])) < 1e-6     # both schemes' errors: 2e-7 measured
    # the constraint holds at every node to solver tolerance
    dd = rc.q - np.stack([np.zeros_like(rc.t), a * np.cos(w * rc.t)], axis=1)
    assert np.max(np.abs(np.sum(dd ** 2, axis=1) - l * l)) < 1e-11
    # the moving constraint's reaction does work (λ·∂c/∂t): the balance counts it, and both forms balance
    for r in (ra, rc):
        assert np.max(np.abs(r.energy - r.energy[0] - r.detail.work)) < 1e-6   # 5.3e-8 and 3.5e-8 measured


def test_the_moving_constraints_work_converges_at_the_order():
    """E − E(0) − W with W holding the reaction's power λ·∂c/∂t (index-1 multipliers along the discrete
    path): measured 2.0 (midpoint), 4.0 (galerkin4 and RK4) in log2 of the ratio from N = 400 to 800."""
    a, w, l, g = 0.1, 20.0, 1.0, 9.81
    x = ca.SX.sym("x", 2)
    d = x - ca.vertcat(0, a * ca.cos(w * ct.time()))
    cart = ct.LagrangianSystem(x, ct.Atoms([x], [1.0]), [ct.Gravity(g)], constraints=[(ca.dot(d, d) - l * l) / 2])
    assert cart.moving_constraints
    x0 = [l * math.sin(1.0), a - l * math.cos(1.0)]
    for method, scheme, order in (("whole", "midpoint", 2), ("whole", "galerkin4", 4), ("rk4", "midpoint", 4)):
        b = []
        for n in (400, 800):
            r = ct.simulate(cart, x0, [0.0, 0.0], 2.0, n, scheme, method)
            b.append(float(np.max(np.abs(r.energy - r.energy[0] - r.detail.work))))
        assert abs(math.log2(b[0] / b[1]) - order) < 0.3, (method, scheme, b)


def test_the_derivation_prints_the_forced_time_dependent_equations():
    pytest.importorskip("sympy")
    from castrajectory.inspect import derivation
    rng = np.random.default_rng(3)
    for system in (pendulum.driven_pendulum(), pendulum.kapitza_pendulum(), oscillator.damped_oscillator(1, 4, .3, .5, 1.7)):
        acc = derivation.accelerations(derivation.equations(system))
        for _ in range(3):
            q, v, t = rng.standard_normal(1), rng.standard_normal(1), float(rng.uniform(0, 5))
            np.testing.assert_allclose(acc(q, v, t), np.asarray(system.acceleration(q, v, t)).ravel(),
                                       rtol=1e-12, atol=1e-12)
        text = derivation.markdown(system, "x", "galerkin6")
        assert "Lagrange–d'Alembert" in text or "energy balance" in text


def test_a_conservative_scene_builds_no_time_and_no_force():
    r = ct.simulate(pendulum.double_pendulum(), [1.0, 0.5], [0.0, 0.0], 1.0, 100)
    prog = r.as_dict()["program"]
    assert prog["parameters"] == 2                           # p0 only: no node times
    assert not any("time" in term or "force" in term for term in prog["terms"])
    assert prog["families"][1]["instructions"] == 173        # the midpoint DEL element it always had
    assert np.all(r.detail.work == 0.0)
    f = ct.simulate(oscillator.damped_oscillator(1, 4, .3, .5, 1.7), [1.0], [0.0], 1.0, 100).as_dict()["program"]
    assert f["parameters"] == 1 + 101 and "time-dependent" in f["terms"] and "force: damping" in f["terms"]


def test_bad_input_is_refused_with_one_line():
    x = ca.SX.sym("x", 1)
    stray = ca.SX.sym("k")
    with pytest.raises(InputError, match="symbol k"):
        ct.LagrangianSystem(x, ct.MassMatrix(1.0), [ct.Potential(stray * x[0] ** 2)])
    with pytest.raises(InputError, match="velocity"):
        ct.LagrangianSystem(x, ct.MassMatrix(1.0), [ct.Potential(ct.velocity(x)[0] ** 2)])
    with pytest.raises(InputError, match="2 entries; it needs one per coordinate"):
        ct.LagrangianSystem(x, ct.MassMatrix(1.0), [ct.Force(ca.vertcat(1, 2))])
    with pytest.raises(InputError, match="negative"):
        ct.Damping(-0.1)
    with pytest.raises(InputError, match="semi-definite"):
        ct.Damping([[1.0, 0.0], [0.0, -1.0]])
    with pytest.raises(InputError, match="symbol"):
        ct.LagrangianSystem(x, ct.MassMatrix(1.0), [ct.Force(stray)])
    ok = ct.LagrangianSystem(x, ct.MassMatrix(1.0), [ct.Force(-ct.velocity(x) + ca.sin(ct.time()))])
    assert ok.forced and ok.time_dependent


def test_contact_refuses_a_time_dependent_system_for_now():
    """Forces (Force, Damping) now enter the contact rows (tests/test_events.py: a damped ball against the
    reference); the time does not yet."""
    y = ca.SX.sym("y", 1)
    ball = ct.LagrangianSystem(y, ct.Atoms([ca.vertcat(0, y)], [1.0]), [ct.Gravity(9.81),
                                                                        ct.Force(ca.sin(ct.time()) * ca.SX.ones(1))],
                               contact=ct.Contact([y[0]]))
    with pytest.raises(InputError, match="not supported yet"):
        ct.simulate(ball, [1.0], [0.0], 1.0, 100)
