"""Coulomb friction on a tangent plane (3-D contact, issue #25): the isotropic (circular) cone at held contacts and
at impacts (models.impact.frictional_impact_plane), a sphere on SO(3) that slides and rolls, bounces with spin,
and a box with friction in a paraboloid bowl.

Oracles: a sphere on a plane keeps its slip's direction while it slides (no coupling), so it rolls from
t* = k|u0|/((1+k) μ g) at v0 − μ g t* û (k = 2/5), its spin about the vertical untouched; its bounce is the
decoupled closed form (rolls iff (k/(1+k))|u| <= μ(1+e)|v_n|); the planar law where the second tangent
decouples; the energy, never gained by an impact."""
from __future__ import annotations

import numpy as np
import pytest

from castrajectory.models import rigidbody as rb
from castrajectory.models.impact import frictional_impact, frictional_impact_plane
from castrajectory.solve import trajectory

G = 9.81


def test_the_plane_law_against_the_closed_form_and_the_planar_law():
    """A sphere's bounce (G = diag(1, 1 + 1/k, 1 + 1/k)) in both regimes to 1e-14, and the planar law where the
    second tangent decouples, over 15 random coupled in-plane matrices (measured agreement 6.5e-14)."""
    k, e, mu, vn = 0.4, 0.5, 0.3, -2.0
    Gd = np.diag([1.0, 1.0 + 1.0 / k, 1.0 + 1.0 / k])
    for u in ([0.3, 0.4], [3.0, 4.0], [10.0, -2.0]):
        u = np.array(u)
        imp = frictional_impact_plane(Gd, [vn, *u], mu, e)
        rolls = (k / (1 + k)) * np.linalg.norm(u) <= mu * (1 + e) * abs(vn)
        Pt = -(k / (1 + k)) * u if rolls else -mu * (1 + e) * abs(vn) * u / np.linalg.norm(u)
        np.testing.assert_allclose(imp.P, [(1 + e) * abs(vn), *Pt], rtol=0, atol=1e-13)
        assert imp.sticks == rolls
    rng = np.random.default_rng(0)
    for _ in range(15):
        A = rng.standard_normal((2, 3))
        G2 = A @ A.T
        w = np.array([-abs(rng.standard_normal()), rng.standard_normal()])
        mu, e = rng.uniform(0, 2), rng.uniform(0, 1)
        G3 = np.zeros((3, 3))
        G3[:2, :2], G3[2, 2] = G2, 1.0
        P2 = frictional_impact(G2, w, mu, e).P
        P3 = frictional_impact_plane(G3, [w[0], w[1], 0.0], mu, e).P
        assert np.max(np.abs(P3[:2] - P2)) <= 1e-12 * max(1.0, np.max(np.abs(P2))) and P3[2] == 0.0


def test_a_coupled_impact_on_a_plane_never_gains_energy():
    """30 random coupled 3 × 3 Delassus matrices, approaches, μ in [0, 2], e in [0, 1]: the impulse in the
    circular cone, the contact separating, the kinetic energy never grown (measured worst −2e-4 of the normal
    kinetic energy, a loss)."""
    rng = np.random.default_rng(1)
    for _ in range(30):
        A = rng.standard_normal((3, 4))
        Gd = A @ A.T
        w = np.array([-abs(rng.standard_normal()), *rng.standard_normal(2)])
        mu, e = rng.uniform(0, 2), rng.uniform(0, 1)
        imp = frictional_impact_plane(Gd, w, mu, e)
        P = imp.P
        assert np.linalg.norm(P[1:]) <= mu * P[0] * (1 + 1e-9) + 1e-14
        assert imp.w_after[0] >= -1e-12 * abs(w[0])
        assert P @ w + 0.5 * P @ Gd @ P <= 1e-13 * (0.5 * w @ np.linalg.solve(Gd, w))


def _sphere_start(v0, w0, height=0.0, R=0.1):
    quat = np.array([1.0, 0.0, 0.0, 0.0])
    return (np.concatenate([[0.0, 0.0, R + height], quat]),
            np.concatenate([v0, rb.quaternion_rate(quat, np.asarray(w0, float))]))


def test_a_sphere_on_so3_slides_then_rolls():
    """A sphere (R = 0.1, μ = 0.3) launched at (2, 0.5) m/s with spin (5, −3, 7) rad/s: its slip (2.3, 1) keeps its
    direction, it rolls from t* = 0.2435 s on at v0 − μ g t* û (measured 3.5e-5, 8.8e-6 and 2.2e-6 m/s at N = 100, 200, 400:
    order 2), its vertical spin is kept (4e-14), the friction stays in the circular cone, and the rolling starts
    within two steps of t*."""
    m, R, mu = 1.0, 0.1, 0.3
    s = rb.sphere_on_floor(m, R, mu, G)
    v0, w0 = np.array([2.0, 0.5, 0.0]), np.array([5.0, -3.0, 7.0])
    q0, qd0 = _sphere_start(v0, w0, R=R)
    u0 = np.array([v0[0] - R * w0[1], v0[1] + R * w0[0]])
    k = 0.4
    tstar = k * np.linalg.norm(u0) / ((1 + k) * mu * G)
    v_end = v0[:2] - mu * G * tstar * u0 / np.linalg.norm(u0)
    errs = []
    for N in (100, 200):
        tr = trajectory.solve_initial_value(s, q0, qd0, 0.5, N)
        assert tr.success, tr.message
        errs.append(np.max(np.abs(tr.v[-1, :2] - v_end)))
        w = rb.angular_velocity(tr.q[-1, 3:], tr.v[-1, 3:], frame="space")
        assert abs(w[2] - w0[2]) <= 1e-11
        assert np.max(np.linalg.norm(tr.friction_ratio, axis=-1)) <= mu * (1 + 1e-9)
        assert np.max(np.abs(np.linalg.norm(tr.q[:, 3:], axis=1) - 1.0)) <= 1e-13
        rolling = np.linalg.norm(tr.slip[:, 0, 0, :], axis=1) <= 1e-9
        t_roll = tr.t[int(np.argmax(rolling))]
        assert np.all(rolling[int(np.argmax(rolling)):])
        assert 0.0 <= t_roll - tstar <= 2 * 0.5 / N
    assert 1.7 <= np.log2(errs[0] / errs[1]) <= 2.3 and errs[1] < 1e-4


@pytest.mark.parametrize("mu,v0,w0", [(0.3, [1.0, 0.5, 0.0], [5.0, -3.0, 7.0]), (0.05, [2.0, 0.5, 0.0], [5.0, -30.0, 7.0])])
def test_a_spinning_sphere_bounces_on_a_plane(mu, v0, w0):
    """Dropped 0.5 m (e = 0.6) with a drift and a spin about a tilted axis: it lands at √(2H/g) and leaves at
    e |v_n| with the closed form's tangential impulse, rolling (μ = 0.3) or still sliding (μ = 0.05) (measured
    1.7e-13 and 1.5e-13 m/s)."""
    m, R, e, H = 1.0, 0.1, 0.6, 0.5
    s = rb.sphere_on_floor(m, R, mu, G, restitution=e)
    q0, qd0 = _sphere_start(np.array(v0), w0, height=H, R=R)
    u0 = np.array([v0[0] - R * w0[1], v0[1] + R * w0[0]])
    k, vn = 0.4, np.sqrt(2 * G * H)
    rolls = (k / (1 + k)) * np.linalg.norm(u0) <= mu * (1 + e) * vn
    Pt = -(k / (1 + k)) * m * u0 if rolls else -mu * (1 + e) * m * vn * u0 / np.linalg.norm(u0)
    tr = trajectory.solve_initial_value(s, q0, qd0, 0.5, 100)
    assert tr.success
    imp = tr.impacts[0]
    assert abs(imp.t - np.sqrt(2 * H / G)) <= 1e-12 and not imp.caught
    np.testing.assert_allclose(imp.v_after[:3], [v0[0] + Pt[0], v0[1] + Pt[1], e * vn], rtol=0, atol=1e-11)
    np.testing.assert_allclose(imp.mu_t, Pt, rtol=0, atol=1e-11)


def test_a_box_in_a_3d_bowl_with_friction():
    """The box of bowl3d (0.4 × 0.3 × 0.2, R = 2, e = 0.5) with friction μ = 0.5 on its corners' tangent planes:
    certified, every bounce keeps or loses kinetic energy (measured at most −0.0036 of it), every friction
    ratio in the circular cone, the quaternion on its constraint."""
    s = rb.box_in_bowl(1.0, [0.4, 0.3, 0.2], 2.0, G, 0.5, friction=0.5)
    quat = rb.axis_angle([1.0, 0.5, 0.2], 0.4)
    q0 = np.concatenate([[0.3, -0.2, 0.8], quat])
    qd0 = np.concatenate([[0.0, 0.0, 0.0], rb.quaternion_rate(quat, np.array([2.0, -1.0, 3.0]))])
    tr = trajectory.solve_initial_value(s, q0, qd0, 0.7, 200)
    assert tr.success, tr.message
    bounces = [i for i in tr.impacts if not i.caught]
    assert len(bounces) >= 2
    for i in bounces:
        M = np.asarray(s.mass_matrix(i.q))
        assert 0.5 * i.v_after @ M @ i.v_after <= 0.5 * i.v_before @ M @ i.v_before * (1 + 1e-12)
    assert np.max(np.linalg.norm(tr.friction_ratio, axis=-1)) <= 0.5 * (1 + 1e-9)
    assert np.max(np.abs(np.linalg.norm(tr.q[:, 3:], axis=1) - 1.0)) <= 1e-13
