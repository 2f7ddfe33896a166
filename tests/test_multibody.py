"""The multibody builder (issue 45): bodies and joints as a LagrangianSystem, in maximal coordinates (each body its
own (x, y, θ), joints as constraints) and in joint coordinates (recursive kinematics), against closed forms: the
compound double pendulum's mass matrix, a pivoted rod's small-oscillation period, the cart with a pole, a welded
body's composite inertia, and a four-bar linkage's energy."""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

import castrajectory as ct
from castrajectory.validation import InputError

G = 9.81


def rod_chain(n, m=1.0, length=1.0, g=G):
    """n uniform rods hinged end to end, the first hanging from the origin (relative joint angles)."""
    mb = ct.Multibody(g=g)
    parent = mb.world
    for i in range(n):
        link = mb.body(f"link{i + 1}", mass=m, inertia=m * length ** 2 / 12,
                       outline=[(0.0, 0.5 * length), (0.0, -0.5 * length)])
        mb.revolute(parent, link, parent_point=(0.0, 0.0) if i == 0 else (0.0, -0.5 * length),
                    child_point=(0.0, 0.5 * length), name=f"j{i + 1}")
        parent = link
    return mb


def _reduced_mass_matrix(mb, qj):
    """The maximal system's mass matrix pulled back to the joint coordinates, Jᵀ M J (J = ∂q_max/∂q_joint)."""
    s = ca.SX.sym("s", len(mb.joint_names()))
    q, _ = mb.state(qj)
    system = mb.system()
    eps = 1e-6
    J = np.column_stack([(mb.state(qj + eps * e)[0] - mb.state(qj - eps * e)[0]) / (2 * eps)
                         for e in np.eye(s.numel())])
    return J.T @ np.asarray(system.mass_matrix(q)) @ J


def test_the_compound_double_pendulum_mass_matrix():
    """Two uniform rods (m = 1, 2; l = 1, 0.5), absolute angles θ: M_θ = [[m₁l₁²/3 + m₂l₁², ½m₂l₁l₂ cos(θ₁ − θ₂)],
    [·, m₂l₂²/3]]; the joint coordinates are φ = (θ₁, θ₂ − θ₁), so M_φ = Aᵀ M_θ A.  Both formulations give it: the
    joint one to rounding, the maximal one pulled back through the kinematics (to the central difference's 1e-9)."""
    m1, m2, l1, l2 = 1.0, 2.0, 1.0, 0.5
    mb = ct.Multibody(g=G)
    a = mb.body("a", m1, m1 * l1 ** 2 / 12)
    b = mb.body("b", m2, m2 * l2 ** 2 / 12)
    mb.revolute(mb.world, a, (0.0, 0.0), (0.0, 0.5 * l1))
    mb.revolute(a, b, (0.0, -0.5 * l1), (0.0, 0.5 * l2))
    phi = np.array([0.7, -1.1])
    th = np.array([phi[0], phi[0] + phi[1]])
    c = math.cos(th[0] - th[1])
    M_th = np.array([[m1 * l1 ** 2 / 3 + m2 * l1 ** 2, 0.5 * m2 * l1 * l2 * c], [0.5 * m2 * l1 * l2 * c, m2 * l2 ** 2 / 3]])
    A = np.array([[1.0, 0.0], [1.0, 1.0]])
    expected = A.T @ M_th @ A
    joint = mb.system("joint")
    assert np.max(np.abs(np.asarray(joint.mass_matrix(phi)) - expected)) < 1e-14
    assert np.max(np.abs(_reduced_mass_matrix(mb, phi) - expected)) < 1e-8
    # the potential: the centres of mass at −(l₁/2) cos θ₁ and −l₁ cos θ₁ − (l₂/2) cos θ₂
    U = -G * (m1 * 0.5 * l1 * math.cos(th[0]) + m2 * (l1 * math.cos(th[0]) + 0.5 * l2 * math.cos(th[1])))
    q0, v0 = mb.state(phi)
    assert float(mb.system().energy(q0, v0)) == pytest.approx(U, abs=1e-13)
    assert float(joint.energy(phi, np.zeros(2))) == pytest.approx(U, abs=1e-13)


@pytest.mark.parametrize("formulation", ["maximal", "joint"])
def test_a_pivoted_rod_swings_at_its_small_oscillation_period(formulation):
    """A uniform rod (l = 1) on a pin at its end: ω² = 3g/(2l).  From 1e-3 rad at rest the angle crosses zero at a
    quarter period (the amplitude's correction (1 + θ₀²/16) is 6e-8); galerkin6 on 40 steps of the half period."""
    mb = rod_chain(1)
    omega = math.sqrt(3 * G / 2)
    T = math.pi / omega
    q0, v0 = mb.state([1e-3], formulation=formulation)
    run = ct.simulate(mb.system(formulation), q0, v0, T, 40, scheme="galerkin6")
    assert run.success
    angle = np.array([mb.joint_positions(q)[0] for q in run.q]) if formulation == "maximal" else run.q[:, 0]
    assert angle[-1] == pytest.approx(-1e-3, rel=1e-6)
    assert angle[20] == pytest.approx(0.0, abs=1e-9)


def test_a_cart_with_a_pole_on_a_prismatic_joint():
    """A cart (mass 2) on a horizontal slider with a uniform pole (m = 0.5, l = 1) standing on a pin (its centre at
    (x − ½ l sin φ, ½ l cos φ)): in the joint coordinates (x, φ) M = [[M + m, −½ m l cos φ], [−½ m l cos φ, m l²/3]];
    both formulations march the same motion
    (galerkin6, N = 80 over 1.5 s: measured 1.8e-9 apart), and the horizontal momentum (no horizontal force) is kept
    (to 1.8e-13)."""
    mb = ct.Multibody(g=G)
    cart = mb.body("cart", 2.0, 0.1, outline=[(-0.2, 0.0), (0.2, 0.0)])
    pole = mb.body("pole", 0.5, 0.5 / 12, outline=[(0.0, 0.5), (0.0, -0.5)])
    mb.prismatic(mb.world, cart, axis=(1.0, 0.0), name="x")
    mb.revolute(cart, pole, (0.0, 0.0), (0.0, -0.5), name="phi")
    assert mb.joint_names() == ["x", "phi"]
    phi = 0.4
    M = np.asarray(mb.system("joint").mass_matrix([0.3, phi]))
    assert np.max(np.abs(M - np.array([[2.5, -0.25 * math.cos(phi)], [-0.25 * math.cos(phi), 0.5 / 3]]))) < 1e-14
    runs = {}
    for form in ("maximal", "joint"):
        q0, v0 = mb.state([0.3, 0.2], [0.5, 0.0], formulation=form)
        runs[form] = ct.simulate(mb.system(form), q0, v0, 1.5, 80, scheme="galerkin6")
        assert runs[form].success
    mx = np.array([mb.joint_positions(q) for q in runs["maximal"].q])
    assert np.max(np.abs(mx - runs["joint"].q)) < 1e-8
    # horizontal momentum: the cart's and the pole's centre's velocities (maximal coordinates)
    v = runs["maximal"].v
    px = 2.0 * v[:, 0] + 0.5 * v[:, 3]
    assert np.ptp(px) < 1e-11


def test_a_welded_body_is_one_body_with_its_composite_inertia():
    """Two rods welded into an L (a: m = 1, l = 1 along y; b: m = 2, l = 0.6 along x from a's lower end) on a pin at
    a's top: one rigid body of mass 3, its centre of mass and moment about the pin by the parallel-axis theorem.  Its
    joint system has one coordinate and the pendulum's mass I_pin and potential −m g d cos(φ + φ_c)."""
    mb = ct.Multibody(g=G)
    a = mb.body("a", 1.0, 1.0 / 12)
    b = mb.body("b", 2.0, 2.0 * 0.36 / 12)
    mb.revolute(mb.world, a, (0.0, 0.0), (0.0, 0.5), name="pin")
    mb.weld(a, b, (0.0, -0.5), (-0.3, 0.0))
    # about the pin: a's centre at (0, −0.5), b's at (0.3, −1)
    I_pin = 1.0 / 12 + 1.0 * 0.25 + 2.0 * 0.36 / 12 + 2.0 * (0.09 + 1.0)
    c = (1.0 * np.array([0.0, -0.5]) + 2.0 * np.array([0.3, -1.0])) / 3.0
    joint = mb.system("joint")
    assert joint.nq == 1
    assert float(joint.mass_matrix([0.3])[0, 0]) == pytest.approx(I_pin, abs=1e-14)
    R = np.array([[math.cos(0.3), -math.sin(0.3)], [math.sin(0.3), math.cos(0.3)]])
    assert float(joint.energy([0.3], [0.0])) == pytest.approx(3.0 * G * (R @ c)[1], abs=1e-13)
    q0, v0 = mb.state([0.3], [1.0])
    run = ct.simulate(mb.system(), q0, v0, 2.0, 60, scheme="galerkin4")
    ref = ct.simulate(joint, [0.3], [1.0], 2.0, 60, scheme="galerkin4")
    assert run.success and ref.success
    assert np.max(np.abs(np.array([mb.joint_positions(q)[0] for q in run.q]) - ref.q[:, 0])) < 1e-6


def test_a_four_bar_linkage_closes_its_loop_and_keeps_its_energy():
    """A parallelogram four-bar (cranks of length 1 pinned at (0, 0) and (1, 0), a coupler of length 1): the third
    joint closes the loop, a constraint in both formulations; the coupler stays horizontal (a parallelogram), and the
    energy drifts only by the scheme's error (galerkin4, N = 100 over 2 s: measured 2.4e-7 J in either formulation)."""
    mb = ct.Multibody(g=G)
    left = mb.body("left", 1.0, 1.0 / 12)
    coupler = mb.body("coupler", 1.0, 1.0 / 12)
    right = mb.body("right", 1.0, 1.0 / 12)
    mb.revolute(mb.world, left, (0.0, 0.0), (0.0, 0.5))
    mb.revolute(left, coupler, (0.0, -0.5), (-0.5, 0.0))
    mb.revolute(mb.world, right, (1.0, 0.0), (0.0, 0.5))
    closing = mb.revolute(coupler, right, (0.5, 0.0), (0.0, -0.5))
    assert not closing.tree
    # the loop closes where both cranks have the same angle and the coupler keeps its orientation
    with pytest.raises(InputError, match="loops"):
        mb.state([0.5, 0.0, 0.2])
    for form in ("maximal", "joint"):
        q0, v0 = mb.state([0.5, -0.5, 0.5], [1.0, -1.0, 1.0], formulation=form)
        run = ct.simulate(mb.system(form), q0, v0, 2.0, 100, scheme="galerkin4")
        assert run.success, run.message
        assert np.ptp(run.energy) < 1e-6
        if form == "maximal":
            assert np.max(np.abs(run.q[:, 5])) < 1e-10          # the coupler's angle


def test_bad_bodies_and_joints_are_refused():
    mb = ct.Multibody()
    a = mb.body("a", 1.0, 0.1)
    with pytest.raises(InputError, match="exists already"):
        mb.body("a", 1.0, 0.1)
    with pytest.raises(InputError, match="mass"):
        mb.body("b", -1.0, 0.1)
    with pytest.raises(InputError, match="inertia"):
        mb.body("b", 1.0, 0.0)
    with pytest.raises(InputError, match="itself"):
        mb.revolute(a, a)
    other = ct.Multibody().body("x", 1.0, 0.1)
    with pytest.raises(InputError, match="not a body of this Multibody"):
        mb.revolute(mb.world, other)
    mb.revolute(mb.world, a, name="pin")
    with pytest.raises(InputError, match="unknown joint coordinates"):
        mb.state({"nope": 1.0})
    with pytest.raises(InputError, match="formulation"):
        mb.system("minimal")
    with pytest.raises(InputError, match="axis"):
        mb.prismatic(mb.world, mb.body("c", 1.0, 0.1), axis=(0.0, 0.0))


def test_a_constrained_systems_fastest_frequency_is_on_its_tangent_space():
    """The linearised frequency of a constrained system comes from its constraint forces' curvature: a pendulum
    in Cartesian coordinates at rest at θ₀ has ω² = g cos θ₀ / l (the tension's λ on the tangent), as in its
    angle; a rod chain hanging at rest has the same fastest normal mode in maximal and in joint coordinates (in
    maximal ones the gravity is linear, and it was 0).  (Away from an equilibrium the two linearisations differ:
    the maximal one's tensions hold the chain's acceleration; 9.8 against 10.8 rad/s at one state of 4 rods.)"""
    from castrajectory.solve.trajectory import _fastest_frequency
    l, th0 = 2.0, 0.4
    x = ca.SX.sym("x", 2)
    cart = ct.LagrangianSystem(x, ct.Atoms([x], [3.0]), [ct.Gravity(G)], constraints=[(ca.dot(x, x) - l * l) / 2])
    q0 = l * np.array([math.sin(th0), -math.cos(th0)])
    assert _fastest_frequency(cart, q0, np.zeros(2)) == pytest.approx(math.sqrt(G * math.cos(th0) / l), rel=1e-12)
    mb = rod_chain(4)
    w = [_fastest_frequency(mb.system(f), *mb.state(formulation=f)) for f in ("maximal", "joint")]
    assert w[0] > 1.0 and w[0] == pytest.approx(w[1], rel=1e-10)


def test_the_index1_solution_in_numbers_is_the_symbolic_one():
    """A 5-rod chain in maximal coordinates (15 coordinates, 10 multipliers) is past the size where the index-1
    equations are solved numerically: the same accelerations and multipliers as their symbolic solution."""
    from castrajectory.models import mechanics
    mb = rod_chain(5)
    system = mb.system()
    q0, v0 = mb.state([0.5, 0.1, -0.2, 0.3, 0.0], [0.3, -0.1, 0.2, 0.0, 0.5])
    assert system.nq + system.nc >= mechanics.SYMBOLIC_INDEX1
    a, lam = system.index1_values(q0, v0)
    scale = np.max(np.abs(a))
    assert np.max(np.abs(a - np.asarray(system.acceleration(q0, v0)).reshape(-1))) < 1e-12 * scale
    assert np.max(np.abs(lam - np.asarray(system.multiplier(q0, v0)).reshape(-1))) < 1e-12 * np.max(np.abs(lam))


@pytest.mark.slow
def test_a_32_rod_chain_compiles_every_element(tmp_path, monkeypatch):
    """Issue 45: no element function of a 32-body chain falls back to CasADi's virtual machine (their code is
    linear in the bodies; past LARGE_CODE_CHARS it compiles at -O1: 7 s for four functions, measured), and the
    answer converges.  A fresh compile cache, so that nothing is loaded from an earlier run."""
    from castrajectory.solve import jit
    monkeypatch.setenv("CASTRAJECTORY_CACHE_DIR", str(tmp_path))
    mb = rod_chain(32)
    before = dict(jit.stats)
    run = ct.simulate(mb.system(), *mb.state(np.r_[0.5, np.zeros(31)]), T=3.0, N=120, scheme="galerkin8")
    assert run.success, run.message
    assert jit.stats["fallbacks"] == before["fallbacks"] and jit.stats["compiled"] > before["compiled"]


@pytest.mark.parametrize("dim", [2, 3])
def test_a_joint_effort_turns_a_rod_at_its_torque_over_its_inertia(dim):
    """A rod (m = 1, l = 1) on a pin at its end, without gravity, under a constant torque τ = 0.3 on the pin: its
    angle is τ t² / (2 m l²/3) in both formulations, in the plane and in space (joint: galerkin6 integrates the
    quadratic to rounding; maximal, where the rod's centre moves on a circle: 4.9e-13 and 5.0e-13 at N = 20,
    3.1e-11 at N = 10, the scheme's order 6); a controlled effort is a control of the optimal-control problem."""
    mb = ct.Multibody(g=0.0, dim=dim)
    if dim == 2:
        rod = mb.body("rod", 1.0, 1.0 / 12)
        mb.revolute(mb.world, rod, child_point=(0.0, 0.5), name="pin")
    else:
        rod = mb.body("rod", 1.0, [1.0 / 12, 1.0 / 12, 1e-3])
        mb.revolute(mb.world, rod, child_point=(0.0, 0.0, 0.5), axis=(1.0, 0.0, 0.0), name="pin")
    for form in ("maximal", "joint"):
        run = ct.simulate(mb.system(form, efforts={"pin": 0.3}), *mb.state(formulation=form), T=1.0, N=20,
                          scheme="galerkin6")
        angle = np.array([mb.joint_positions(q)[0] for q in run.q]) if form == "maximal" else run.q[:, 0]
        assert np.max(np.abs(angle - 0.3 * run.t ** 2 / (2.0 / 3.0))) < (2e-11 if form == "maximal" else 1e-13)
    u = ct.Control("u", 1, lower=-5.0, upper=5.0)
    ocp = ct.OptimalControl(mb.system("joint", efforts={"pin": u}), T=1.0, N=20, scheme="galerkin4")
    ocp.initial(q=[0.0], qd=[0.0])
    ocp.final(q=[0.5], qd=[0.0])
    ocp.minimize(running=u ** 2)
    sol = ocp.solve()
    # rest to rest through 0.5 rad, min ∫u²: u = I θ̈ with θ the cubic 0.5 (3s² − 2s³): ∫u² = 12 I² 0.5² (I = 1/3)
    assert sol.success and sol.cost == pytest.approx(12 * (1 / 3) ** 2 * 0.25, rel=1e-6)
