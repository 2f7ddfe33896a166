"""Tests of contact trajectories (castrajectory.solve.contact) against independent oracles.

* bouncing ball: bounce times, impulses 2mV / (1+e)mV, apex heights e^(2k) H (re-derived below, not
  taken from the library), kinetic energy across an elastic impact, total energy between impacts;
* KKT signs (μ, ν ≥ −tol), the complementarity residual, no penetration, homotopy bookkeeping;
* resting contact: the ball stays on the ground and the ground carries m g h per step;
* Zeno-like bouncing (e = 0.3) settles without penetrating;
* rectangle drop: every velocity jump is μ M⁻¹∇φᵀ with μ ≥ 0 and equals the closed-form corner impact;
* bowl (curved ground), scenes without contact, bad input and the script's refusal.

Known deviations of the library from the issue's tolerances are kept at the issue's tolerance and marked
``xfail(strict=True)`` (they turn into failures once fixed, so the marker gets removed).
"""
from __future__ import annotations

import functools
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from castrajectory.models import collision as col
from castrajectory.solve import contact, simulate, trajectory
from castrajectory.models import mechanics, pendulum
from castrajectory.models import rigidbody as rb
from castrajectory.discretise.lagrangians import DiscreteMechanics
from castrajectory.problems import bouncing_ball
from castrajectory.validation import InputError

ROOT = Path(__file__).resolve().parents[1]
ENV = dict(os.environ, MPLBACKEND="Agg")
G = 9.81
KKT_TOL = 1e-9          # multipliers ≥ −tol, gaps ≥ −tol
MAX_PENALTY_STEPS = 8


# ----------------------------------------------------------------------------- independent oracles
def ball_bounces(H: float, g: float, e: float, T: float):
    """Bounce times, impact speeds and apexes of a ball dropped from rest at height H.

    Free fall to the ground: t₁ = √(2H/g), speed V = √(2gH).  Bounce k (k = 1, 2, ...) leaves with
    e^k V, flies 2 e^k V / g and peaks at (e^k V)²/(2g) = e^(2k) H.
    """
    V = math.sqrt(2 * g * H)
    t, k = math.sqrt(2 * H / g), 0
    times, speeds = [], []
    while t < T and e ** k * V > 1e-12 * V:
        times.append(t)
        speeds.append(e ** k * V)
        k += 1
        t += 2 * e ** k * V / g
    apexes = [e ** (2 * k) * H for k in range(len(times) + 1)]
    return np.array(times), np.array(speeds), np.array(apexes)


def apexes_from_impacts(tr, H: float, g: float) -> np.ndarray:
    """Apex of each flight: H, then (height at the impact) + v⁺²/(2g) (parabolic flight after each impact)."""
    return np.array([H] + [float(i.q[0]) + float(i.v_after[0]) ** 2 / (2 * g) for i in tr.impacts])


def rel(a, b) -> float:
    return abs(a - b) / abs(b)


# ----------------------------------------------------------------------------- cached solves
@functools.lru_cache(maxsize=None)
def ball(H: float, e: float, T: float, N: int, v0: float = 0.0, m: float = 1.0):
    return trajectory.solve_initial_value(col.bouncing_ball(m, G, e), [H], [v0], T, N)


@functools.lru_cache(maxsize=None)
def rectangle(e: float):
    system = col.rectangle_drop(1.0, 2.0, 1.0, G, e)
    return system, trajectory.solve_initial_value(system, [0.0, 2.0, 0.3], [0.5, 0.0, 1.0], 1.5, 600)


@functools.lru_cache(maxsize=None)
def bowl():
    return trajectory.solve_initial_value(col.bowl(), [0.5, 0.6, 0.2], [0.0, 0.0, 0.0], 2.0, 800)


def check_kkt(tr, gap_tol: float = KKT_TOL):
    """Signs, complementarity, no penetration and homotopy bookkeeping shared by every contact solve."""
    assert tr.success, (tr.status, tr.message)
    assert np.min(tr.mu) >= -KKT_TOL and np.min(tr.nu) >= -KKT_TOL
    assert tr.complementarity_residual <= contact.COMPLEMENTARITY_TOL
    # complementarity recomputed from the returned arrays, against fixed numbers (not the code's
    # tolerance), in m N s: sub-node gap times impulse (measured at most 1.0e-11), node gap times node
    # impulse (at most 1.5e-8: a block resting on its edge, gap 1e-9 m at the interior point's last barrier)
    assert np.max(np.abs(tr.gap_sub * tr.mu)) <= 1e-9
    assert np.max(np.abs(tr.gap * tr.nu)) <= 1e-7
    assert min(np.min(tr.gap), np.min(tr.gap_sub)) >= -gap_tol
    assert 1 <= len(tr.homotopy) <= MAX_PENALTY_STEPS
    for step in tr.homotopy:
        assert step.iterations >= 0 and isinstance(step.status, str) and step.status
        assert step.sigma >= 0 and step.solve_time_s >= 0
    # the reported residual is the last step's; the iteration count covers every attempt
    assert tr.homotopy[-1].complementarity_residual == pytest.approx(tr.complementarity_residual, rel=1e-12)
    assert tr.iterations >= sum(s.iterations for s in tr.homotopy)


# ----------------------------------------------------------------------------- independent oracle sanity
def test_oracle_agrees_with_library_ball_oracle():
    for e in (1.0, 0.7, 0.3):
        t, v, a = ball_bounces(1.3, G, e, 3.0)
        t2, a2, v2 = col.ball_oracle(1.3, 0.0, G, e, 3.0)
        k = min(len(t), len(t2))
        assert k >= 3
        np.testing.assert_allclose(t[:k], t2[:k], rtol=1e-13)
        np.testing.assert_allclose(v[:k], v2[:k], rtol=1e-13)
        np.testing.assert_allclose(a[:k + 1], a2[:k + 1], rtol=1e-12)


# ----------------------------------------------------------------------------- 1. elastic ball
@pytest.mark.parametrize("m", [1.0, 2.5])
def test_elastic_ball(m):
    H, T, N = 1.0, 2.5, 600
    tr = ball(H, 1.0, T, N, 0.0, m)
    check_kkt(tr)
    times, speeds, _ = ball_bounces(H, G, 1.0, T)
    assert len(times) == 3 and len(tr.impacts) == 3
    V = math.sqrt(2 * G * H)
    for imp, t_ex in zip(tr.impacts, times):
        # the sub-node time is an unknown (not locked to the grid): the midpoint rule is exact on a
        # parabola, so the impact time is exact up to the solver tolerance
        assert abs(imp.t - t_ex) <= 1e-6
        assert imp.contact == 0
        assert rel(imp.mu, 2 * m * V) <= 1e-6
        assert abs(abs(imp.v_after[0]) - abs(imp.v_before[0])) <= 1e-8
        assert imp.v_before[0] < 0 < imp.v_after[0]
        assert abs(imp.q[0]) <= 1e-9
    # total energy at the nodes: exact for the midpoint rule on a parabola, conserved by the impact law
    E0 = m * G * H
    assert np.max(np.abs(tr.energy - E0)) <= 1e-6 * E0
    # the flight between impacts: heights at the nodes are the analytic bouncing ball
    np.testing.assert_allclose(tr.q[:, 0], col.ball_height(H, 0.0, G, 1.0, tr.t), atol=1e-7)


def test_elastic_ball_cross_check_of_fields():
    tr = ball(1.0, 1.0, 2.5, 600)
    N = len(tr.t) - 1
    assert tr.q.shape == (N + 1, 1) and tr.mu.shape == (N, 1) and tr.nu.shape == (N + 1, 1)
    assert tr.gap.shape == (N + 1, 1) and tr.gap_sub.shape == (N, 1) and tr.q_sub.shape == (N, 1)
    # the ball's gap is its height
    np.testing.assert_array_equal(tr.gap[:, 0], tr.q[:, 0])
    np.testing.assert_array_equal(tr.gap_sub[:, 0], tr.q_sub[:, 0])
    # sub-nodes lie inside their steps; the last node (in flight) carries no node force
    h = tr.t[1] - tr.t[0]
    assert np.all(tr.t_sub > tr.t[:-1]) and np.all(tr.t_sub < tr.t[1:])
    assert tr.gap[-1, 0] > 0.1 and abs(tr.nu[-1, 0]) <= 1e-9
    # every impact sits at the sub-node of its step with the step's sub-node impulse
    for imp in tr.impacts:
        assert tr.t[imp.step] <= imp.t <= tr.t[imp.step] + h
        assert imp.mu == tr.mu[imp.step, imp.contact]
    # discrete momentum balance over the whole horizon: p_N - p_0 = -m g T + Σ impulses (exact identity
    # of the midpoint discrete Euler–Lagrange equations: gravity contributes -m g τ per sub-interval)
    assert abs(tr.p[-1, 0] - 0.0 - (-G * tr.t[-1] + tr.mu.sum() + tr.nu.sum())) <= 1e-8


# ----------------------------------------------------------------------------- 2. apex heights
@pytest.mark.parametrize("e", [0.5, 0.7])
def test_apex_heights_follow_e_squared(e):
    H, T, N = 1.0, 2.0, 600
    system, tr, cmp_ = bouncing_ball.solve(H, 0.0, e, 1.0, G, T, N)
    check_kkt(tr)
    times, speeds, apex_ex = ball_bounces(H, G, e, T)
    assert len(tr.impacts) >= 4
    apex = cmp_["apex_heights"]
    np.testing.assert_allclose(apex, apexes_from_impacts(tr, H, G), rtol=1e-14)
    # the midpoint flight under gravity is exact, so the solution is the closed form up to rounding
    # (measured: apexes 3.9e-15, times 1.1e-15 s, speeds and impulses 2.0e-15 relative)
    for k in range(5):   # H and the apexes after the first 4 bounces
        assert rel(apex[k], e ** (2 * k) * H) <= 1e-13, (k, apex[k])
    for imp, t_ex, v_ex in list(zip(tr.impacts, times, speeds))[:4]:
        assert abs(imp.t - t_ex) <= 1e-13
        assert rel(-imp.v_before[0], v_ex) <= 1e-13
        assert rel(imp.v_after[0], e * v_ex) <= 1e-13         # Newton restitution
        assert rel(imp.mu, (1 + e) * v_ex) <= 1e-13            # impulse (1 + e) m v
    # energy is lost only at impacts: E after impact k = e^(2k) m g H (between impacts it is exact)
    for k, imp in enumerate(tr.impacts[:4]):
        nodes = (tr.t > imp.t) & (tr.t < (tr.impacts[k + 1].t if k + 1 < len(tr.impacts) else tr.t[-1]))
        np.testing.assert_allclose(tr.energy[nodes], e ** (2 * k + 2) * G * H, rtol=1e-12)  # 1.1e-14 measured


# ----------------------------------------------------------------------------- 3. Zeno-like bouncing
ZENO = dict(H=1.0, e=0.3, T=2.0, N=800)


def zeno():
    return ball(ZENO["H"], ZENO["e"], ZENO["T"], ZENO["N"])


def test_zeno_bouncing_settles_without_penetrating():
    tr = zeno()
    check_kkt(tr)
    H, e, T, N = ZENO["H"], ZENO["e"], ZENO["T"], ZENO["N"]
    h = T / N
    V = math.sqrt(2 * G * H)
    t_inf = math.sqrt(2 * H / G) + 2 * e * V / (G * (1 - e))      # accumulation time of the bounces
    assert t_inf < 0.5 * T
    settled = tr.t > t_inf + 4 * h
    # on the ground from the accumulation time on, to the last node
    assert np.max(np.abs(tr.q[settled, 0])) <= 1e-9
    # at rest up to the discrete resting orbit: node velocities of one step's worth of gravity at most
    assert np.max(np.abs(tr.v[settled, 0])) <= G * h
    assert abs(tr.v[-1, 0]) <= G * h
    # the first apexes: H, e² H, e⁴ H (first 3 flights)
    apex = apexes_from_impacts(tr, H, G)
    assert len(apex) >= 3
    for k in range(2):   # measured 9e-16
        assert rel(apex[k], e ** (2 * k) * H) <= 1e-13, (k, apex[k])
    # the accumulation ends in a catch only where a bounce would come back within its step
    _catches_unresolvable(col.bouncing_ball(1.0, G, e), tr, e)


def test_zeno_third_apex():
    # Regression: with the law weighted by the next node's gap, an impact at 97.5 % of its step
    # had restitution 0.30030 and the 3rd apex was 2.0e-3 high.
    tr = zeno()
    H, e = ZENO["H"], ZENO["e"]
    apex = apexes_from_impacts(tr, H, G)
    assert rel(apex[2], e ** 4 * H) <= 1e-13, apex[2]   # 1.9e-15 measured


def test_zeno_settled_node_impulses_carry_the_weight():
    # after the accumulation time every node (the last one too) carries m g h: the lumped node
    # impulse obeys Λ_k = m g h + m (q_{k+1} - 2 q_k + q_{k-1}) / h exactly, and the nodes sit at 0
    tr = zeno()
    H, e, T, N = ZENO["H"], ZENO["e"], ZENO["T"], ZENO["N"]
    h = T / N
    V = math.sqrt(2 * G * H)
    t_inf = math.sqrt(2 * H / G) + 2 * e * V / (G * (1 - e))
    settled = np.where(tr.t > t_inf + 4 * h)[0]
    lam = tr.node_impulse[settled, 0]
    bound = 4 * np.max(np.abs(tr.q[settled[0] - 1:, 0])) / h      # m = 1
    assert np.max(np.abs(lam - G * h)) <= bound + 1e-12 * G * h
    assert np.max(np.abs(lam / (G * h) - 1)) <= 1e-6


# ----------------------------------------------------------------------------- 4. resting contact
REST = dict(m=1.0, T=1.0, N=200)


@pytest.mark.parametrize("e", [1.0, 0.3])
def test_resting_ball_stays_on_the_ground(e):
    m, T, N = REST["m"], REST["T"], REST["N"]
    h = T / N
    tr = ball(0.0, e, T, N, 0.0, m)
    check_kkt(tr)
    assert tr.impacts == []
    # no jitter: every node stays on the ground, the last one too, to the interior point's final
    # barrier (gap x force ~ its last mu: 1.2e-10 m measured)
    assert np.max(np.abs(tr.q[:, 0])) <= 1e-9
    # the sub-nodes rest too: a sub-node between two ground nodes could also hop to the apex of the
    # step's midpoint flight, g h²/8 = 3e-5 m at h = 5e-3 (an exact discrete solution with all the
    # weight at the nodes); the guess starts on the branch without motion and the solver keeps it
    assert np.max(tr.q_sub[:, 0]) <= 1e-9
    # The ground carries m g h per node.  The lumped node impulse obeys, whatever the sub-nodes do,
    #   Λ_k = m g h + m (q_{k+1} - 2 q_k + q_{k-1}) / h   (k ≥ 1),   Λ_0 = m g h / 2 + m (q_1 - q_0) / h - p_0
    # (test_node_impulse_is_the_momentum_balance), so node heights at the solver's tolerance bound
    # the deviation by 4 m max|q| / h; node 0's dual cell is [0, h/2].
    mgh = m * G * h
    lam = tr.node_impulse[:, 0]
    bound = 4 * m * np.max(np.abs(tr.q[:, 0])) / h + 1e-12 * mgh  # (+ rounding, for an exact rest)
    assert abs(lam[0] - mgh / 2) <= bound
    assert np.max(np.abs(lam[1:] - mgh)) <= bound
    assert np.max(np.abs(lam[1:] / mgh - 1)) <= 1e-6, np.max(np.abs(lam[1:] / mgh - 1))
    # and at rest: the node velocities (mean of the one-sided momenta, whose jump is the node
    # impulse) vanish up to the noise of the node heights (2.3e-6 g h measured, at node 1), and so
    # does the energy; the one-sided velocities would be ±g h/2
    assert np.max(np.abs(tr.v[:, 0])) <= 1e-5 * G * h
    assert np.max(np.abs(tr.energy)) <= 1e-6 * m * (G * h) ** 2


@pytest.mark.parametrize("H, e", [(1.0, 1.0), (1.0, 0.3), (0.0, 1.0)])
def test_node_impulse_is_the_momentum_balance(H, e):
    # Independent of the contact logic: summing the node and sub-node DEL equations of the ball with
    # the hat-function weights of Λ eliminates the sub-nodes and splits; what is left is the discrete
    # momentum balance of a lumped mass.  It holds at every node: flight, impacts, rest.
    m, T, N = 1.0, 2.0, 400
    h = T / N
    tr = ball(H, e, T, N, 0.0, m)
    q, lam = tr.q[:, 0], tr.node_impulse[:, 0]
    d2 = np.empty(N + 1)
    d2[1:-1] = q[2:] - 2 * q[1:-1] + q[:-2]
    expected = m * G * h + m * d2 / h
    expected[0] = m * G * h / 2 + m * (q[1] - q[0]) / h - 0.0      # p_0 = 0
    scale = max(m * G * h, max(float(i.mu) for i in tr.impacts) if tr.impacts else 0.0)
    np.testing.assert_allclose(lam[:-1], expected[:-1], rtol=0, atol=1e-9 * scale)
    # the total impulse over the horizon balances gravity and the momentum change:
    # Σ_k<N Λ_k + α_{N-1} μ_{N-1} + h ν_N / 2 = m g T + p_N - p_0, with p_N the mean of p_N^± (the
    # look-ahead step's share of Λ_N left out)
    alpha_last = tr.t_sub[-1] / h - (N - 1)
    total = lam[:-1].sum() + alpha_last * tr.mu[-1, 0] + 0.5 * tr.nu[-1, 0]
    assert abs(total - (m * G * T + tr.p[-1, 0])) <= 1e-9 * scale * N


@pytest.mark.parametrize("e", [1.0, 0.5])
def test_rectangle_resting_on_its_edge_slides_without_friction(e):
    # Both lower corners on the ground, moving sideways at 1 m/s: frictionless contact gives the
    # exact motion x = t, y = h/2, θ = 0, each lower corner carrying half the weight per node.
    m, w, hgt, T, N = 1.0, 2.0, 1.0, 1.0, 200
    h = T / N
    tr = trajectory.solve_initial_value(col.rectangle_drop(m, w, hgt, G, e), [0.0, hgt / 2, 0.0], [1.0, 0.0, 0.0], T, N)
    check_kkt(tr)
    assert tr.impacts == []
    np.testing.assert_allclose(tr.q[:, 0], tr.t, rtol=0, atol=1e-12)
    assert np.max(np.abs(tr.q[:, 1] - hgt / 2)) <= 1e-9 and np.max(np.abs(tr.q[:, 2])) <= 1e-9
    assert np.max(np.abs(tr.q_sub[:, 1] - hgt / 2)) <= 1e-9      # no hop between the nodes
    lam = tr.node_impulse / (m * G * h)
    np.testing.assert_allclose(lam[0, :2], 0.25, rtol=0, atol=1e-5)       # node 0: half a cell
    np.testing.assert_allclose(lam[1:, :2], 0.5, rtol=0, atol=1e-5)
    assert np.max(np.abs(lam[:, 2:])) <= 1e-8                            # upper corners: no force
    E0 = 0.5 * m * 1.0 + m * G * hgt / 2
    np.testing.assert_allclose(tr.energy, E0, rtol=1e-9)


@functools.lru_cache(maxsize=None)
def rocking_block():
    # the default rectangle drop with e = 0.5: bounces, then rocking on the long edge with corner
    # impacts in successive steps (caught by the guess's look-ahead), then sliding flat
    system = col.rectangle_drop(1.0, 2.0, 1.0, G, 0.5)
    return system, trajectory.solve_initial_value(system, [0.0, 2.0, 0.3], [0.5, 0.0, 1.0], 3.0, 1000)


def test_rocking_block_settles_flat_and_slides():
    m, w, hgt, e = 1.0, 2.0, 1.0, 0.5
    system, tr = rocking_block()
    check_kkt(tr)
    # frictionless flat ground: no horizontal impulse ever, so x(t) = x0 + vx0 t at every node
    np.testing.assert_allclose(tr.q[:, 0], 0.5 * tr.t, rtol=0, atol=1e-12)
    # every bounce obeys the closed-form corner law (a catch, if any, ends the rocking: plastic)
    bounces = [i for i in tr.impacts if not i.caught]
    assert len(bounces) >= 10
    cs = col.corners(w, hgt)
    for imp in bounces:
        if np.count_nonzero(tr.mu[imp.step] > 1e-12) == 1:     # a single impulse at that sub-node
            law = col.rectangle_impact(m, w, hgt, imp.q[2], imp.v_before, e, cs[imp.contact])
            np.testing.assert_allclose(imp.v_after, law.v_after, rtol=0, atol=1e-6)
    # flat and at rest vertically after the last impact, to the interior point's last barrier
    # (gap x force ~ its final mu: 1.1e-9 m measured)
    after = tr.t > max(i.t for i in tr.impacts) + 0.05
    assert np.sum(after) > 300
    assert np.max(np.abs(tr.q[after, 1] - hgt / 2)) <= 1e-8 and np.max(np.abs(tr.q[after, 2])) <= 1e-8
    # energy: never gained (impacts with e < 1 only lose), and at the end exactly the sliding rest state
    assert np.all(np.diff(tr.energy) <= 1e-7 * tr.energy[0])
    lift = np.max(np.abs(tr.q[after, 1] - hgt / 2))
    assert abs(tr.energy[-1] - (0.5 * m * 0.5 ** 2 + m * G * hgt / 2)) <= m * G * lift + 1e-10
    # resting on the edge, each lower corner carries half the weight per node
    lam = tr.node_impulse[after] / (m * G * (tr.t[1] - tr.t[0]))
    np.testing.assert_allclose(lam[:, :2], 0.5, rtol=0, atol=1e-5)


def _rocking_checks(tr, e, m=1.0, w=2.0, hgt=1.0, vx=0.5, x_tol=1e-12):
    """A block rocking down on flat frictionless ground: no penetration, x(t) = x0 + vx0 t (no horizontal
    impulse ever; to the rows' accuracy), every single bounce on the closed-form corner law, energy
    never gained."""
    assert tr.success, (tr.status, tr.message)
    assert np.min(tr.mu) >= -KKT_TOL and np.min(tr.nu) >= -KKT_TOL
    assert tr.complementarity_residual <= contact.COMPLEMENTARITY_TOL
    assert min(np.min(tr.gap), np.min(tr.gap_sub)) >= -KKT_TOL
    np.testing.assert_allclose(tr.q[:, 0], vx * tr.t, rtol=0, atol=x_tol)
    bounces = [i for i in tr.impacts if not i.caught]
    cs = col.corners(w, hgt)
    checked = 0
    for imp in bounces:
        if np.count_nonzero(tr.mu[imp.step] > 1e-12) == 1:     # a single impulse at that sub-node
            law = col.rectangle_impact(m, w, hgt, imp.q[2], imp.v_before, e, cs[imp.contact])
            np.testing.assert_allclose(imp.v_after, law.v_after, rtol=0, atol=1e-6)
            checked += 1
    # no energy gain between nodes (1e-7 E0); next to a catch -- an arrival slower than the grid resolves,
    # taken plastically -- the gain is bounded by the normal kinetic energy of one step of gravity,
    # ½ m (g h)² (1.1e-4 J measured at h = 3 ms, e = 0.3, against 4.3e-4 J)
    h = tr.t[1] - tr.t[0]
    gain = np.diff(tr.energy)
    near = np.zeros(gain.size, bool)
    for imp in tr.impacts:
        if imp.caught:
            near[max(imp.step - 1, 0):imp.step + 4] = True
    assert np.all(gain[~near] <= 1e-7 * tr.energy[0])
    assert np.all(gain[near] <= 0.5 * m * (G * h) ** 2)
    return bounces, checked


@functools.lru_cache(maxsize=None)
def rocking_block_e03():
    system = col.rectangle_drop(1.0, 2.0, 1.0, G, 0.3)
    return trajectory.solve_initial_value(system, [0.0, 2.0, 0.3], [0.5, 0.0, 1.0], 3.0, 1000)


def _catches_unresolvable(system, tr, e):
    """Every caught impact is one the grid cannot resolve: its bounce, e |v_n⁻|, would come back within
    its step, e |v_n⁻| ≤ |φ̈| h_k (φ̈ the corner's normal acceleration, rotation included, by a
    central difference of the gap along the flight).  Returns how many were caught."""
    caught = [i for i in tr.impacts if i.caught]
    for imp in caught:
        J = np.asarray(system.gap(imp.q)[1])[imp.contact]
        a = np.asarray(system.acceleration(imp.q, imp.v_before)).ravel()
        f = lambda s: float(np.asarray(system.gap(imp.q + imp.v_before * s + 0.5 * a * s * s)[0]).ravel()[imp.contact])  # noqa: E731
        eps = 1e-4
        phidd = abs(f(eps) - 2 * f(0.0) + f(-eps)) / eps ** 2
        assert e * abs(J @ imp.v_before) <= phidd * (tr.t[imp.step + 1] - tr.t[imp.step]), imp
    return len(caught)


def test_rocking_block_e03_catch_must_hold():
    """e = 0.3: every bounce that leaves obeys the corner law, a catch (if any) only where the grid
    cannot resolve the bounce, and the block settles flat."""
    m, hgt, e = 1.0, 1.0, 0.3
    tr = rocking_block_e03()
    assert tr.success, tr.message
    _catches_unresolvable(col.rectangle_drop(1.0, 2.0, 1.0, G, e), tr, e)
    # x(t) = x0 + vx0 t: no horizontal impulse on frictionless ground (1.7e-14 m measured)
    bounces, checked = _rocking_checks(tr, e, x_tol=1e-12)
    assert checked >= 8
    # flat and at rest vertically from shortly after the last impact, sliding at vx0
    after = tr.t > max(i.t for i in tr.impacts) + 0.05
    assert np.sum(after) > 600
    assert np.max(np.abs(tr.q[after, 1] - hgt / 2)) <= 1e-8 and np.max(np.abs(tr.q[after, 2])) <= 1e-8
    assert abs(tr.energy[-1] - (0.5 * m * 0.5 ** 2 + m * G * hgt / 2)) <= 1e-7
    lam = tr.node_impulse[after] / (m * G * (tr.t[1] - tr.t[0]))
    np.testing.assert_allclose(lam[:, :2], 0.5, rtol=0, atol=1e-5)


def test_rocking_block_e08_long_rocking():
    """e = 0.8, T = 4, N = 1500: a long rocking sequence; every bounce obeys the corner law, with no
    penetration, no energy gain and complementarity to tolerance."""
    system = col.rectangle_drop(1.0, 2.0, 1.0, G, 0.8)
    tr = trajectory.solve_initial_value(system, [0.0, 2.0, 0.3], [0.5, 0.0, 1.0], 4.0, 1500)
    assert tr.success, tr.message
    bounces, checked = _rocking_checks(tr, 0.8)
    assert checked >= 15


# ----------------------------------------------------------------------------- 5. admissible velocity jump
@pytest.mark.parametrize("e", [1.0, 0.5])
def test_rectangle_velocity_jump_is_admissible(e):
    m, w, hgt = 1.0, 2.0, 1.0
    system, tr = rectangle(e)
    check_kkt(tr)
    assert len(tr.impacts) >= 2
    M = col.rectangle_mass_matrix(m, w, hgt)
    Minv = np.linalg.inv(M)
    ke = lambda v: 0.5 * v @ M @ v  # noqa: E731
    for imp in tr.impacts:
        corner = col.corners(w, hgt)[imp.contact]
        # J: gradient of the corner's height, from the system's CasADi gap and by hand
        J = np.asarray(system.gap(imp.q)[1])[imp.contact]
        th = imp.q[2]
        J_hand = np.array([0.0, 1.0, math.cos(th) * corner[0] - math.sin(th) * corner[1]])
        np.testing.assert_allclose(J, J_hand, rtol=1e-13, atol=1e-14)
        # the corner touches the ground at the impact
        assert abs(imp.q[1] + math.sin(th) * corner[0] + math.cos(th) * corner[1]) <= 1e-9
        d = Minv @ J
        dv = imp.v_after - imp.v_before
        coef = float(dv @ d / (d @ d))
        assert coef >= 0.0
        np.testing.assert_allclose(dv, coef * d, rtol=0, atol=1e-8)     # parallel to M⁻¹Jᵀ
        assert abs(coef - imp.mu) <= 1e-8 * max(1.0, imp.mu)
        # the corner was approaching and leaves with -e times its normal velocity
        vn = float(J @ imp.v_before)
        assert vn < 0 and abs(float(J @ imp.v_after) + e * vn) <= 1e-8 * abs(vn)
        # the closed-form corner impact of Exercise 2.2 from the same pre-impact state
        ref = col.rectangle_impact(m, w, hgt, angle=th, v_before=imp.v_before, e=e, corner=corner)
        np.testing.assert_allclose(imp.v_after, ref.v_after, rtol=0, atol=1e-7)
        if e == 1.0:
            assert abs(ke(imp.v_after) - ke(imp.v_before)) <= 1e-9 * ke(imp.v_before)
        else:
            assert ke(imp.v_after) < ke(imp.v_before)
    if e == 1.0:
        E0 = tr.energy[0]
        assert np.max(np.abs(tr.energy - E0)) <= 1e-5 * abs(E0)
    else:
        # energy never rises (up to the solver tolerance) and is constant between impacts
        assert np.all(np.diff(tr.energy) <= 1e-8 * abs(tr.energy[0]))


def test_rectangle_flight_before_the_first_impact_is_a_parabola():
    """Until the first impact the rectangle flies freely: c(t) = c₀ + v₀ t − ½ g t² e_y, θ = θ₀ + ω t."""
    _, tr = rectangle(1.0)
    t1 = tr.impacts[0].t
    k = tr.t < t1 - 1e-12
    t = tr.t[k]
    np.testing.assert_allclose(tr.q[k, 0], 0.5 * t, atol=1e-9)
    np.testing.assert_allclose(tr.q[k, 1], 2.0 - 0.5 * G * t * t, atol=1e-9)
    np.testing.assert_allclose(tr.q[k, 2], 0.3 + t, atol=1e-9)
    # the first impact time: the lowest corner's height reaches 0 (bisection on the analytic flight)
    def lowest(t):
        th = 0.3 + t
        return min(2.0 - 0.5 * G * t * t + math.sin(th) * d[0] + math.cos(th) * d[1] for d in col.corners(2.0, 1.0))
    lo, hi = 0.0, 1.0
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if lowest(mid) > 0 else (lo, mid)
    assert abs(t1 - hi) <= 1e-6


def rectangle_cascade(th0: float, y0: float, e: float, count: int, m=1.0, w=2.0, hgt=1.0):
    """Event-driven oracle: exact parabolic flight of a rectangle dropped from rest at angle θ₀,
    the earliest corner crossing located by a 10 µs scan and bisection, ``resolve_impact`` there.

    Returns ``count`` impacts as (time, corner, v⁻, v⁺).
    """
    M = col.rectangle_mass_matrix(m, w, hgt)
    cs = col.corners(w, hgt)
    q, v, t, out = np.array([0.0, y0, th0]), np.zeros(3), 0.0, []

    def gaps(s):
        s = np.atleast_1d(s)
        th = q[2] + v[2] * s
        y = q[1] + v[1] * s - 0.5 * G * s * s
        return np.array([y + np.sin(th) * d[0] + np.cos(th) * d[1] for d in cs])

    s = np.arange(1, 100001) * 1e-5          # 1 s after each impact, in 10 µs steps
    while len(out) < count:
        g = gaps(s)
        first = {j: int(np.argmax(g[j] < 0)) for j in range(len(cs)) if np.any(g[j] < 0)}
        j = min(first, key=lambda j: first[j])
        i = first[j]
        lo, hi = (s[i - 1] if i else 0.0), s[i]
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if gaps(mid)[j, 0] > 0 else (lo, mid)
        q = q + v * lo + np.array([0.0, -0.5 * G * lo * lo, 0.0])
        v = v + np.array([0.0, -G * lo, 0.0])
        t += lo
        imp = col.resolve_impact(M, col.corner_jacobian(q[2], cs[j]), v, e)
        out.append((t, j, v.copy(), imp.v_after))
        v = imp.v_after
    return out


def test_nearly_flat_landing_resolves_the_three_impact_cascade():
    """θ₀ = 1e-3: corner A, corner B 0.25 ms later, corner A again 0.49 ms after that (h = 1.5 ms,
    so the last two fall into one step).  Times and post-impact velocities match the event-driven
    cascade; the elastic impacts conserve the energy."""
    m, w, hgt, th0, e = 1.0, 2.0, 1.0, 1e-3, 1.0
    exact = rectangle_cascade(th0, 1.5, e, 3)
    tr = trajectory.solve_initial_value(col.rectangle_drop(m, w, hgt, G, e), [0.0, 1.5, th0], [0.0, 0.0, 0.0],
                                        1.5, 1000)
    assert tr.success, tr.message
    check_kkt(tr)
    assert tr.complementarity_residual <= contact.COMPLEMENTARITY_TOL
    assert min(np.min(tr.gap), np.min(tr.gap_sub)) >= -KKT_TOL
    cs = col.corners(w, hgt)
    for imp, (t_ex, j, vb, va) in zip(tr.impacts[:3], exact):
        assert imp.contact == j and not imp.caught
        assert abs(imp.t - t_ex) <= 1e-8
        np.testing.assert_allclose(imp.v_before, vb, rtol=0, atol=1e-6)
        np.testing.assert_allclose(imp.v_after, va, rtol=0, atol=1e-6)
        ref = col.rectangle_impact(m, w, hgt, imp.q[2], imp.v_before, e, cs[imp.contact])
        np.testing.assert_allclose(imp.v_after, ref.v_after, rtol=0, atol=1e-7)
    np.testing.assert_allclose(tr.impacts[2].v_after, [0.0, 4.2301, 2.0123], atol=1e-4)
    # elastic: the energy is conserved, across the cascade too
    assert np.max(np.abs(tr.energy - tr.energy[0])) <= 1e-7 * tr.energy[0]
    # the impulse per node lumps every sub-node impulse (hat weights of its time) and node force: in
    # total they are the impulses of the sub-nodes and nodes of the horizon (the last step's share of
    # its sub-node reaches past T)
    last = (tr.t_sub[-1] - tr.t[-2]) / (tr.t[-1] - tr.t[-2])
    total = tr.nu.sum() + tr.mu.sum() - (1 - last) * tr.mu[-1].sum()
    assert abs(tr.node_impulse.sum() - total) <= 1e-12 * total


# ----------------------------------------------------------------------------- 6. bowl
def test_bowl():
    tr = bowl()
    check_kkt(tr)
    assert len(tr.impacts) >= 1
    # gaps are vertical distances to y = x²/(2R): recompute them from the node poses
    R, w, hgt = 2.0, 0.4, 0.2
    for j, d in enumerate(col.corners(w, hgt)):
        c, s = np.cos(tr.q[:, 2]), np.sin(tr.q[:, 2])
        x = tr.q[:, 0] + c * d[0] - s * d[1]
        y = tr.q[:, 1] + s * d[0] + c * d[1]
        np.testing.assert_allclose(tr.gap[:, j], y - x * x / (2 * R), rtol=0, atol=1e-12)
    E0 = tr.energy[0]
    assert E0 == pytest.approx(1.0 * G * 0.6, rel=1e-12)      # at rest: potential energy m g c_y only
    assert np.max(np.abs(tr.energy - E0)) <= 1e-5 * abs(E0)
    M = col.rectangle_mass_matrix(1.0, w, hgt)
    for imp in tr.impacts:
        assert imp.mu > 0
        J = np.asarray(col.bowl().gap(imp.q)[1])[imp.contact]
        assert float(J @ imp.v_before) < 0                                   # approaching
        d = np.linalg.solve(M, J)
        np.testing.assert_allclose(imp.v_after - imp.v_before, imp.mu * d, rtol=0, atol=1e-8)
        # kinetic energy across each impact: test_bowl_elastic_impacts_conserve_kinetic_energy


def _ke(M, v):
    return 0.5 * v @ M @ v


def test_bowl_elastic_impacts_conserve_kinetic_energy():
    # every impact conserves K to 1e-9, also the one at alpha = 0.990 of its step (next node open by
    # 1.2e-4 m), which lost 1.1e-6 while the law's weight length was l everywhere (see law_lengths)
    tr = bowl()
    M = col.rectangle_mass_matrix(1.0, 0.4, 0.2)
    for imp in tr.impacts:
        assert abs(_ke(M, imp.v_after) - _ke(M, imp.v_before)) <= 1e-9 * _ke(M, imp.v_before), imp.step


# ----------------------------------------------------------------------------- 7. contact variables
def test_scene_without_contact_builds_no_contact_variables():
    system = pendulum.double_pendulum()
    assert system.contact is None
    q0, qd0 = [0.3, -0.2], [0.0, 0.0]
    tr = trajectory.solve_initial_value(system, q0, qd0, 1.0, 40)
    assert isinstance(tr, trajectory.Trajectory) and not isinstance(tr, contact.ContactTrajectory)
    assert tr.success
    dm = DiscreteMechanics(system, "midpoint")
    p0 = np.asarray(system.momentum(q0, qd0)).reshape(-1)
    names = trajectory.TrajectoryNLP(dm, 40, 1.0, "initial_value", np.array(q0), p0).nlp.variable_names
    assert "q" in names
    for name in names:
        assert "mu" not in name and "nu" not in name and "qs" not in name and "beta" not in name


def test_contact_scene_builds_contact_variables():
    system = col.bouncing_ball()
    cm = contact.ContactMechanics(system, "midpoint")
    names = contact.ContactNLP(cm, 10, 0.01, (1.0, 1.0, 1.0, 9.81)).nlp.variable_names
    assert {"q", "qs", "mu", "nu"} <= set(names)


# ----------------------------------------------------------------------------- 8. bad input
@pytest.mark.parametrize("make,q0,qd0", [
    (lambda: col.bouncing_ball(), [-0.1], [0.0]),
    (lambda: col.rectangle_drop(1.0, 2.0, 1.0, G, 1.0), [0.0, 0.1, 0.3], [0.0, 0.0, 0.0]),
    (lambda: col.bowl(), [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]),
], ids=["ball", "rectangle", "bowl"])
def test_body_inside_the_ground_is_refused(make, q0, qd0):
    with pytest.raises(InputError, match="penetrates contact '.+': its gap is -"):
        trajectory.solve_initial_value(make(), q0, qd0, 1.0, 50)


@pytest.mark.parametrize("e", [-0.1, 1.01, float("nan"), float("inf")])
def test_restitution_outside_unit_interval_is_refused(e):
    with pytest.raises(InputError):
        mechanics.Contact([0.0], e)
    with pytest.raises(InputError):
        col.bouncing_ball(1.0, G, e)
    with pytest.raises(InputError):
        col.rectangle_drop(1.0, 2.0, 1.0, G, e)


@pytest.mark.parametrize("method", ["rk4", "march", "implicit-euler"])
def test_baseline_steppers_refuse_contact(method):
    with pytest.raises(InputError, match="contact"):
        simulate.simulate(col.bouncing_ball(), [1.0], [0.0], 1.0, 50, method=method)


@pytest.mark.parametrize("args,needle", [
    (["--height", "-1"], "inside the ground"),
    (["--restitution", "1.5"], "restitution"),
])
def test_script_refuses_bad_input(args, needle):
    p = subprocess.run([sys.executable, str(ROOT / "problems" / "bouncing_ball.py"), *args, "--n", "50"],
                       capture_output=True, text=True, env=ENV, cwd=ROOT, timeout=120)
    assert p.returncode == 2, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0] and "Traceback" not in p.stderr
    assert p.stdout == ""


# ----------------------------------------------------------------------------- work-precision study
def test_spring_ball_bounce_times_converge_at_second_order_and_beat_moreau_jean():
    """Ball on a spring (harmonic flight, e = 0.9): the sub-node locates every bounce of the
    midpoint flight, so the bounce-time error is the flight's O(h²); Moreau–Jean impacts at steps, O(h)."""
    from castrajectory.inspect import study
    ns = [250, 500, 1000]
    rows = study.contact_work_precision(ns, cases=["spring_ball"])
    whole = [r for r in rows if r["method"] == "whole"]
    mj = [r for r in rows if r["method"] == "moreau-jean"]
    assert all(r["status"] == "ok" for r in rows)
    order = -study.loglog_slope(ns, [r["impact_time_error"] for r in whole])
    assert 1.8 < order < 2.2, order
    for w, b in zip(whole, mj):
        assert w["impact_time_error"] < 0.05 * b["impact_time_error"]
        assert w["apex_error"] < 1e-6 < b["apex_error"]


# ----------------------------------------------------------------------------- the branch the guess identifies
@pytest.mark.parametrize("e,H,v0,T,N", [(0.744, 2.8, 1.783, 4.5, 4000),   # failed after 441 iterations before
                                        (0.855, 1.2, -0.5, 3.0, 600)])
def test_ball_bounces_exact_against_the_closed_form(e, H, v0, T, N):
    """Inelastic bounces, a rising start: every impact time and post-impact speed on the closed form, the
    complementarity recomputed from the returned arrays (gaps times impulses) at rounding."""
    tr = ball(H, e, T, N, v0)
    assert tr.success, tr.message
    times, _, speeds = col.ball_oracle(H, v0, G, e, T)
    assert len(tr.impacts) == len(times) >= 3
    for imp, t, s in zip(tr.impacts, times, speeds):
        # the midpoint flight under gravity is exact: measured 8e-15 s, 1e-15 m/s
        assert abs(imp.t - t) <= 1e-11
        assert imp.v_before[0] == pytest.approx(-s, abs=1e-10)
        assert imp.v_after[0] == pytest.approx(e * s, abs=1e-10)
    comp = max(np.max(np.abs(tr.gap * tr.nu)), np.max(np.abs(tr.gap_sub * tr.mu)))
    assert comp <= 1e-12
    assert min(np.min(tr.gap), np.min(tr.gap_sub)) >= -1e-12


@pytest.mark.parametrize("e", [1.0, 0.5])
def test_rectangle_drop_against_the_event_driven_reference(e):
    """Every impact of the drop (2 for e = 1, 7 for e = 0.5 within 1.5 s), its contact, time and post-impact
    velocity against the event-driven reference (exact flight, crossings bisected to rounding, the corner
    law at each).  The midpoint flight under gravity is exact: measured 7.8e-16 s and 1.5e-12 m/s."""
    from castrajectory.baselines.events import event_driven

    system, tr = rectangle(e)
    check_kkt(tr)
    ref = event_driven(system, [0.0, 2.0, 0.3], [0.5, 0.0, 1.0], 1.5)
    assert ref.reason == "horizon" and len(ref.events) == (2 if e == 1.0 else 7)
    assert [(i.contact,) for i in tr.impacts] == [ev.contacts for ev in ref.events]
    for imp, ev in zip(tr.impacts, ref.events):
        assert abs(imp.t - ev.t) <= 1e-13
        np.testing.assert_allclose(imp.v_after, ev.v_after, rtol=0, atol=1e-10)


# ----------------------------------------------------------------------------- 7. a box in a 3-D bowl
@functools.lru_cache(maxsize=None)
def box_in_bowl(e: float):
    """The 0.4 × 0.3 × 0.2 box of problems/bowl3d.py (defaults), dropped spinning into R = 2, 1 s."""
    system = rb.box_in_bowl(1.0, [0.4, 0.3, 0.2], 2.0, G, e)
    quat = rb.axis_angle([1.0, 0.5, 0.2], 0.4)
    q0 = np.concatenate([[0.3, -0.2, 0.8], quat])
    qd0 = np.concatenate([[0.0, 0.0, 0.0], rb.quaternion_rate(quat, np.array([2.0, -1.0, 3.0]))])
    return system, trajectory.solve_initial_value(system, q0, qd0, 1.0, 400)


def _tangent_map(system, q):
    """Π = M⁻¹ − M⁻¹Cᵀ(CM⁻¹Cᵀ)⁻¹CM⁻¹: momentum to the velocity tangent to |quat| = 1."""
    M = np.asarray(system.mass_matrix(q))
    C = np.asarray(system.constraint(q)[1])
    Mi = np.linalg.inv(M)
    return Mi - Mi @ C.T @ np.linalg.solve(C @ Mi @ C.T, C @ Mi)


@pytest.mark.parametrize("e", [1.0, 0.5])
def test_box_in_a_3d_bowl(e):
    """SO(3) with translation and eight corner contacts: no penetration, impulses ≥ 0, complementarity
    from the arrays, the quaternion on its constraint, every velocity jump in Π ∇φᵀ μ (the impulse
    set of Exercise 2.2 on the constraint), Newton's law at every bounce, and for e = 1 the energy
    across every impact."""
    system, tr = box_in_bowl(e)
    assert tr.success, tr.message
    assert min(np.min(tr.gap), np.min(tr.gap_sub)) >= -1e-12
    assert np.min(tr.mu) >= 0.0 and np.min(tr.nu) >= 0.0
    # measured 3e-14 (e = 1) and 2e-13 (e = 0.5), in m N s
    assert max(np.max(np.abs(tr.gap * tr.nu)), np.max(np.abs(tr.gap_sub * tr.mu))) <= 1e-10
    assert np.max(np.abs(np.linalg.norm(tr.q[:, 3:], axis=1) - 1.0)) <= 1e-14
    assert len(tr.impacts) >= (2 if e == 1.0 else 5)      # measured 2 and 7 in this second
    for imp in tr.impacts:
        J = np.asarray(system.gap(imp.q)[1])
        jump = _tangent_map(system, imp.q) @ J.T @ tr.mu[imp.step]
        np.testing.assert_allclose(imp.v_after - imp.v_before, jump, rtol=0,
                                   atol=1e-9 * np.max(np.abs(imp.v_before)))
        np.testing.assert_allclose(np.asarray(system.constraint(imp.q)[1]) @ imp.v_after, 0.0, atol=1e-12)
        vb, va = J[imp.contact] @ imp.v_before, J[imp.contact] @ imp.v_after
        if not imp.caught:
            assert abs(va + e * vb) <= 1e-8 * abs(vb)
    if e == 1.0:
        # the elastic box: bounded by the midpoint scheme between impacts (3e-14 measured, 1000 steps)
        E = tr.energy
        assert np.max(np.abs(E - E[0])) <= 1e-6 * abs(E[0])
        assert not any(i.caught for i in tr.impacts)
    else:
        assert tr.energy[-1] < tr.energy[0]


# ----------------------------------------------------------------------------- 8. settings and the fallback
def test_fallback_without_the_march_solves_the_ball_and_the_drop():
    """ContactOptions(march=False): the event-located guess's branch and the penalty continuation alone
    still give the exact bounce times of the ball and the event-driven corner impacts of the drop."""
    from castrajectory.baselines.events import event_driven
    off = contact.ContactOptions(march=False)
    tr = trajectory.solve_initial_value(col.bouncing_ball(1.0, G, 0.7), [1.0], [0.0], 3.0, 1500, contact=off)
    check_kkt(tr)
    t_ex, _, _ = ball_bounces(1.0, G, 0.7, 3.0)
    times = [i.t for i in tr.impacts]
    for k in range(4):                      # the first bounces, resolved by the grid
        assert abs(times[k] - t_ex[k]) <= 1e-9
    system = col.rectangle_drop(1.0, 2.0, 1.0, G, 1.0)
    tr = trajectory.solve_initial_value(system, [0.0, 2.0, 0.3], [0.5, 0.0, 1.0], 1.5, 600, contact=off)
    check_kkt(tr)
    ref = event_driven(system, [0.0, 2.0, 0.3], [0.5, 0.0, 1.0], 1.5)
    assert [(i.contact,) for i in tr.impacts] == [ev.contacts for ev in ref.events]
    for imp, ev in zip(tr.impacts, ref.events):
        assert abs(imp.t - ev.t) <= 1e-9


@pytest.mark.parametrize("kw,needle", [
    ({"max_splits": -1}, "max_splits"), ({"certify_tol": 0.0}, "certify_tol"),
    ({"branch_max_iter": -3}, "branch_max_iter"), ({"penalties": (10.0, 1.0)}, "penalties"),
    ({"penalties": ()}, "penalties"), ({"penalties": (float("nan"),)}, "penalties")])
def test_contact_options_refuse_bad_settings(kw, needle):
    with pytest.raises(InputError, match=needle):
        contact.ContactOptions(**kw)


#: Plastic boxes dropped spinning into bowls (seeded random scenes whose step mode search once cycled:
#: two held edges and a third corner arriving); edges, radius, rotation axis and angle, centre, body
#: rates, velocity.
PLASTIC_BOXES = [
    ([0.4709, 0.4611, 0.2094], 3.4556, [0.2764, 0.7005, -0.4448], 1.3464, [0.7152, 1.0463, 0.7842],
     [3.498, -1.061, -0.203], [-0.707, 0.397, -0.416]),
    ([0.4839, 0.5688, 0.3691], 0.8287, [0.8137, 0.6448, 1.6952], 0.7438, [0.1121, -0.0628, 0.6423],
     [2.039, -1.917, -1.281], [0.531, -0.01, 0.568]),
]


@pytest.mark.parametrize("size,R,axis,angle,pos,omega,v", [
    PLASTIC_BOXES[0],
    # the second box in the slow run (15 s: the default run is near its 10-minute guideline, and the first
    # box keeps the oracle; session 14 added the spectral drop's tests)
    pytest.param(*PLASTIC_BOXES[1], marks=pytest.mark.slow)])
def test_plastic_box_in_a_3d_bowl(size, R, axis, angle, pos, omega, v):
    """e = 0: every arrival is plastic (Newton's law with e = 0, or caught), the body comes to rest
    or slides in the bowl; no penetration, complementarity, impulses in Π ∇φᵀ μ, energy only lost."""
    system = rb.box_in_bowl(1.0, size, R, G, 0.0)
    quat = rb.axis_angle(axis, angle)
    tr = trajectory.solve_initial_value(system, np.concatenate([pos, quat]),
                                        np.concatenate([v, rb.quaternion_rate(quat, np.array(omega))]), 2.0, 600)
    assert tr.success, tr.message
    assert min(np.min(tr.gap), np.min(tr.gap_sub)) >= -1e-12
    assert max(np.max(np.abs(tr.gap * tr.nu)), np.max(np.abs(tr.gap_sub * tr.mu))) <= 1e-10
    assert len(tr.impacts) >= 5
    for imp in tr.impacts:
        J = np.asarray(system.gap(imp.q)[1])
        # the jump is the sub-node's impulses, but for a contact held until the impact and released there (open
        # at the next node, not an impact itself): its impulse is a share of its force before the impact, which
        # the velocity before already carries
        listed = [i.contact for i in tr.impacts if i.step == imp.step and i.at_node == imp.at_node]
        released = (tr.gap[imp.step + 1] > 1e-12) & ~np.isin(np.arange(J.shape[0]), listed)
        mu = np.where(released, 0.0, tr.mu[imp.step]) if not imp.at_node else tr.mu[imp.step]
        # (less the share that supports contacts held through the part after the impact: not the impact's)
        mu = mu + (0.0 if imp.held_share is None else imp.held_share)
        np.testing.assert_allclose(imp.v_after - imp.v_before, _tangent_map(system, imp.q) @ J.T @ mu,
                                   rtol=0, atol=1e-9 * np.max(np.abs(imp.v_before)))
        assert J[imp.contact] @ imp.v_after >= -1e-9 * abs(J[imp.contact] @ imp.v_before)   # it does not go on in
    E = tr.energy
    assert E[-1] < 0.9 * E[0] and np.max(E) <= E[0] * (1 + 1e-6)


def _cradle(gap23: float = 0.0, N: int = 301):
    import casadi as ca
    import castrajectory as ct
    x = ca.SX.sym("x", 3)
    s = ct.LagrangianSystem(x, ct.Atoms([ca.vertcat(x[i], 0) for i in range(3)], [1.0] * 3), [],
                            names=["x1", "x2", "x3"],
                            contact=ct.Contact([x[1] - x[0] - 1, x[2] - x[1] - 1], restitution=1.0, names=["1-2", "2-3"]))
    return ct.simulate(s, [-1.0, 1.0, 2.0 + gap23], [1.0, 0.0, 0.0], 3.0, N)


def test_a_simultaneous_impact_lists_every_contact_and_warns():
    """Three unit balls in a row, the last two touching, the first arriving at speed 1 (e = 1): the
    simultaneous Newton law (each contact's normal velocity reversed) gives (−1/3, 2/3, 2/3) with impulses
    4/3 and 2/3 at the two contacts, energy kept; both contacts are listed at t = 1, and the answer warns
    that the outcome depends on the law (measured to 1e-15)."""
    run = _cradle()
    assert run.success
    assert np.max(np.abs(run.v[-1] - [-1 / 3, 2 / 3, 2 / 3])) < 1e-12
    first = [i for i in run.detail.impacts if abs(i.t - 1.0) < 1e-9]
    assert sorted(i.contact for i in first) == [0, 1]
    assert abs(sorted(i.mu for i in first)[0] - 2 / 3) < 1e-12 and abs(sorted(i.mu for i in first)[1] - 4 / 3) < 1e-12
    assert abs(run.energy[-1] - 0.5) < 1e-12
    assert any("simultaneous impact at t = 1" in w and "1-2, 2-3" in w for w in run.warnings)
    # a gap between the last two balls: two impacts apart in time, no such warning
    separate = _cradle(gap23=0.5)
    assert separate.success and not any("simultaneous" in w for w in separate.warnings)


@pytest.mark.parametrize("N", [150, 300, 600])
def test_an_impact_exactly_on_a_node_bounces(N):
    """A ball dropped from g/2 lands at t = 1, a node of every grid N = 150, 300, 600 over T = 1.5 (e = 0.8):
    Newton's law at the node (the march's mode N) sends it off at 0.8 g, v(T) = 0.8 g − g/2 (measured
    2.1e-12, 1.9e-11, 5.2e-11; the impulse 1.8 g m to 3e-12 of itself), the impact listed at t = 1 itself.  (Before, the node's force caught it plastically: v(T) = 0,
    reported ok.)"""
    import casadi as ca
    import castrajectory as ct
    y = ca.SX.sym("y", 1)
    s = ct.LagrangianSystem(y, ct.Atoms([ca.vertcat(0, y[0])], [1.0]), [ct.Gravity(9.81)], names=["y"],
                            contact=ct.Contact([y[0]], restitution=0.8))
    run = ct.simulate(s, [9.81 / 2], [0.0], 1.5, N)
    assert run.success and abs(run.v[-1, 0] - (0.8 * 9.81 - 9.81 / 2)) < 2e-10
    (imp,) = run.detail.impacts
    assert imp.at_node and imp.t == 1.0 and not imp.caught and abs(imp.mu - 1.8 * 9.81) < 1e-11 * imp.mu


def test_two_balls_colliding_on_a_node_exchange_velocities():
    """Equal balls, e = 1, the first arriving at speed 1 so that they touch at t = 1 (node 100 of N = 300, T = 3):
    the velocities are exchanged (0, 1), the energy kept, the impact listed at the node (before: (½, ½),
    half the energy lost)."""
    import casadi as ca
    import castrajectory as ct
    x = ca.SX.sym("x", 2)
    s = ct.LagrangianSystem(x, ct.Atoms([ca.vertcat(x[i], 0) for i in range(2)], [1.0] * 2), [], names=["x1", "x2"],
                            contact=ct.Contact([x[1] - x[0] - 1], restitution=1.0))
    run = ct.simulate(s, [-1.0, 1.0], [1.0, 0.0], 3.0, 300)
    assert run.success and np.max(np.abs(run.v[-1] - [0.0, 1.0])) < 1e-13 and abs(run.energy[-1] - 0.5) < 1e-13
    assert [(i.t, i.at_node) for i in run.detail.impacts] == [(1.0, True)] and not run.warnings
