"""Every scheme's order, confirmed by a fitted slope against closed forms; the scheme objects' contract.

The orders are read from the scheme objects (``ct.schemes()``): this file holds no table of them.
Two oracles: the damped oscillator driven at a frequency of its own (linear, forced and time-dependent:
the Lagrange–d'Alembert forces and the time inputs in every element), and the nonlinear pendulum
released from rest, ``θ(t) = 2 arcsin(k cd(ω₀t | k²))``, ``k = sin(θ₀/2)``.
"""
import math

import casadi as ca
import numpy as np
import pytest

import castrajectory as ct
from castrajectory.discretise import schemes as S
from castrajectory.models import oscillator
from castrajectory.validation import InputError

SCHEMES = ct.schemes()

# m ẍ + c ẋ + k x = A cos(Ωt): underdamped, driven off resonance
OSC = dict(mass=1.0, stiffness=4.0, damping=0.3, amplitude=0.5, frequency=1.7)
X0, V0, T_OSC = 1.0, 0.0, 6.0


def _walk(error_of, order, n0, lo=1e-13, hi=1e-2, n_max=3000):
    """Errors on grids growing by ``2^(3/order)`` (each about 8x more accurate) from ``n0`` until the
    error is below ``lo``; returns the (n, error) pairs with ``lo < error < hi``."""
    factor = 2.0 ** (3.0 / order)
    n, out = n0, []
    while n <= n_max:
        e = error_of(n)
        if lo < e < hi:
            out.append((n, e))
        if e <= lo:
            break
        n = max(n + 1, int(round(n * factor)))
    return out


def _slope(points):
    """The order fitted by least squares to every point of the window: ``error ∝ n^(−order)``."""
    n, e = np.array(points, float).T
    return -float(np.polyfit(np.log(n), np.log(e), 1)[0])


#: the fitted slope may differ from the order by this (a fraction of it): the error constant of a high
#: order oscillates with n (measured local orders of galerkin16: 8.7 to 25 between neighbours; the fit
#: over the window: within 1.2 of 16)
SLOPE_TOL = 0.1


@pytest.mark.parametrize("name", list(SCHEMES))
def test_order_on_the_driven_damped_oscillator(name):
    order = SCHEMES[name]
    system = oscillator.damped_oscillator(**OSC)
    # a longer horizon (20 periods) for the high orders, which reach rounding on a few steps of 3 periods
    T, n0 = (T_OSC, 4) if order <= 12 else (40.0, 8)

    def err(n):
        r = ct.simulate(system, [X0], [V0], T, n, name)
        assert r.success, r.message
        x, _ = oscillator.exact(r.t, *OSC.values(), X0, V0)
        return float(np.max(np.abs(r.q[:, 0] - x)))

    pts = _walk(err, order, n0)
    assert len(pts) >= 4, pts
    slope = _slope(pts)
    assert abs(slope - order) < SLOPE_TOL * order + 0.2, (name, order, slope, pts)


def _pendulum_exact(t, theta0, w0):
    from scipy.special import ellipj, ellipk
    k = math.sin(theta0 / 2)
    m = k * k
    K = ellipk(m)
    sn, cn, dn, _ = ellipj(K - w0 * np.asarray(t), m)  # cd(u) = sn(K - u)
    return 2 * np.arcsin(k * sn)


@pytest.mark.parametrize("name", [n for n in SCHEMES if SCHEMES[n] <= 12])
def test_order_on_the_nonlinear_pendulum(name):
    pytest.importorskip("scipy")
    order = SCHEMES[name]
    th = ca.SX.sym("theta", 1)
    g = 9.81
    system = ct.LagrangianSystem(th, ct.Atoms([ca.vertcat(ca.sin(th), -ca.cos(th))], [1.0]), [ct.Gravity(g)])
    theta0, T = 1.0, 3.0

    def err(n):
        r = ct.simulate(system, [theta0], [0.0], T, n, name)
        assert r.success, r.message
        return float(np.max(np.abs(r.q[:, 0] - _pendulum_exact(r.t, theta0, math.sqrt(g)))))

    # the asymptotic window of the high orders starts late on a nonlinear motion: below 1e-5 (from
    # θ₀ = 2, galerkin8 fitted 9.9 from 1.8e-4 down); above the reference's and the solve's rounding (1e-12)
    pts = _walk(err, order, n0=4, lo=1e-12, hi=1e-2 if order <= 4 else 1e-5)
    assert len(pts) >= 4, pts
    slope = _slope(pts)
    assert abs(slope - order) < SLOPE_TOL * order + 0.2, (name, order, slope, pts)


def test_energy_balance_converges_at_the_order():
    """E(t) − E(0) − W(t) of the driven damped oscillator: the work of damping and drive by the scheme's
    quadrature; at the scheme's order for the Lobatto family, to rounding for the Gauss family."""
    system = oscillator.damped_oscillator(**OSC)
    for name in ("trapezoid", "galerkin4", "galerkin6"):
        b = []
        for n in (40, 80):
            r = ct.simulate(system, [X0], [V0], T_OSC, n, name)
            b.append(float(np.max(np.abs(r.energy - r.energy[0] - r.detail.work))))
        assert abs(math.log2(b[0] / b[1]) - SCHEMES[name]) < 0.3, (name, b)
    for name in ("midpoint", "gauss4", "gauss8"):
        r = ct.simulate(system, [X0], [V0], T_OSC, 40, name)
        assert np.max(np.abs(r.energy - r.energy[0] - r.detail.work)) < 1e-13 * np.max(np.abs(r.energy))


def test_scheme_objects_own_their_stage_times_and_quadrature():
    for name in SCHEMES:
        s = S.scheme(name)
        assert s.order == 2 * s.degree and s.stages == s.degree - 1
        assert s.stage_times.size == s.stages and np.all(np.diff(s.control) > 0)
        # the quadrature integrates polynomials up to degree 2r - 1 exactly on [0, 1]
        for p in range(2 * s.degree):
            assert abs(np.dot(s.weights, s.nodes ** p) - 1.0 / (p + 1)) < 1e-13, (name, p)
        # the constraint quadrature on the control points is exact to degree r (Lobatto: 2r - 1)
        for p in range(s.degree + 1):
            assert abs(np.dot(s.constraint_weights, s.control ** p) - 1.0 / (p + 1)) < 1e-12, (name, p)
        assert s.latex()


def test_discrete_forces_are_the_quadrature_of_the_virtual_work():
    """f_j = h Σ_i w_i ℓ_j(τ_i) Q(q(τ_i), q̇(τ_i), t_i), derived by AD, checked against that sum written out."""
    s = S.scheme("galerkin6")
    rng = np.random.default_rng(1)
    X = [ca.DM(rng.standard_normal(2)) for _ in range(s.degree + 1)]
    h, t0 = 0.3, 1.1
    Q = lambda q, v, t: ca.vertcat(q[0] * v[1] + ca.sin(t), -v[0] ** 2 + q[1])  # noqa: E731
    f = s.discrete_forces(Q, X, h, t0)
    qs, vs = s.path(X, h)
    for j in range(s.degree + 1):
        want = sum(h * s.weights[i] * s.basis[i, j] * np.asarray(ca.evalf(Q(qs[i], vs[i], t0 + s.nodes[i] * h))).ravel()
                   for i in range(s.nodes.size))
        np.testing.assert_allclose(np.asarray(ca.evalf(f[j])).ravel(), want, rtol=1e-13, atol=1e-14)


def test_unknown_scheme_is_refused():
    with pytest.raises(ValueError, match="unknown scheme"):
        S.scheme("galerkin5")
    x = ca.SX.sym("x", 1)
    system = ct.LagrangianSystem(x, ct.MassMatrix(1.0), [ct.Potential(x[0] ** 2)])
    with pytest.raises(InputError, match="galerkin40"):
        ct.simulate(system, [1.0], [0.0], 1.0, 10, "galerkin40")


@pytest.mark.parametrize("name", [n for n in SCHEMES if SCHEMES[n] <= 8])
def test_order_with_a_holonomic_constraint(name):
    """The pendulum in Cartesian coordinates held by ``(|x|² − 1)/2 = 0``: the constraint rows at the
    control points, weighted by their Lobatto weights, keep every scheme's order (measured: 2.0, 4.0,
    6.0, 8.0 for both families between N = 40 and 80)."""
    pytest.importorskip("scipy")
    order = SCHEMES[name]
    x = ca.SX.sym("x", 2)
    g, theta0, T = 9.81, 1.0, 3.0
    cart = ct.LagrangianSystem(x, ct.Atoms([x], [1.0]), [ct.Gravity(g)], constraints=[(ca.dot(x, x) - 1.0) / 2])

    def err(n):
        r = ct.simulate(cart, [math.sin(theta0), -math.cos(theta0)], [0.0, 0.0], T, n, name)
        assert r.success, r.message
        assert np.max(np.abs(np.sum(r.q ** 2, axis=1) - 1.0)) < 1e-12   # on the circle at every node
        th = np.arctan2(r.q[:, 0], -r.q[:, 1])
        return float(np.max(np.abs(th - _pendulum_exact(r.t, theta0, math.sqrt(g)))))

    # (midpoint does not converge on 8 steps of h ω = 1.2 from rest at the side: the coarse grid is refused
    # honestly, Maximum_Iterations_Exceeded; the sweep starts where the grid resolves the swing)
    # (and the answer's error estimate solves N/2 and N/4: from 32 steps, as the answer on 16 needs 8)
    pts = _walk(err, order, n0=32 if order <= 2 else 16 if order <= 4 else 8, lo=1e-12, hi=1e-2 if order <= 4 else 1e-5)
    assert len(pts) >= 3, pts
    slope = _slope(pts)
    assert abs(slope - order) < SLOPE_TOL * order + 0.2, (name, order, slope, pts)
