"""The hopper (nosnoc's): a body on a telescopic leg, which hops along a floor with Coulomb friction.

Coordinates ``q = (x, y, θ, l)``: the body's position, the leg's angle from the vertical and the leg's length; the
foot is at ``(x + l sin θ, y − l cos θ)``.  As in nosnoc's ``hopper_ocp`` (MATLAB ``examples/time_freezing/
time_freezing_hopper_ocp``; nosnoc_py ``examples/hopper_robot``): a constant mass matrix ``M = diag(m_b + m_l,
m_b + m_l, I_b + I_l, m_l)`` with ``m_b = 1``, ``m_l = 0.1``, ``I_b = 0.25``, ``I_l = 0.025``, gravity ``(m_b + m_l) g``
on ``y``, and the controls through ``B(q) = [[0, −sin θ], [0, cos θ], [1, 0], [0, 1]]``: ``u₁`` a torque on the leg's
angle, ``u₂`` a force along the leg, both in ``[−50, 50]``.  The foot's gap is ``y − l cos θ ≥ 0`` (restitution 0),
its slip the foot's horizontal velocity ``ẋ + l̇ sin θ + l θ̇ cos θ`` (nosnoc's ``J_t``), the friction ``μ = 0.45``.  (nosnoc's third
control is a slack of its no-slip formulation, and its stance is no-slip; here the stance is Coulomb's, sticking
inside the cone.)

The optimal-control problem (``problems/hopper.py``, ``problem()``) is nosnoc's: from ``(0.1, 0.5, 0, 0.5)`` at rest over ``T = 1.5``,
minimise ``∫ (z − z_ref)ᵀQ(z − z_ref) + uᵀRu dt + (z_N − z_end)ᵀQ_T(z_N − z_end)``, ``z = (q, q̇)``, with ``Q = diag(50,
50, 20, 50, 0.1, 0.1, 0.1, 0.1)``, ``R = diag(0.01, 0.01)``, ``Q_T = diag(300, 300, 300, 300, 0.1, 0.1, 0.1, 0.1)``; the
reference constant on each of 20 stages, ``z_ref,k = P(k/19)``, ``P`` the parabola through ``z0`` at 0, ``z_mid =
(0.4, 0.8, 0, 0.1, 0, …)`` at ½ and ``z_end = (goal, 0.5, 0, 0.5, 0, …)`` at 1; the bounds ``0 ≤ x ≤ goal + 0.1``,
``0 ≤ y ≤ 1.5``, ``|θ| ≤ π``, ``0.1 ≤ l ≤ 0.5``.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from .contact import Contact
from .control import Control
from .mechanics import Force, LagrangianSystem, MassMatrix, Potential, velocity

MB, ML, IB, IL, MU, G = 1.0, 0.1, 0.25, 0.025, 0.45, 9.81
#: The start (at rest), and the reference's middle (its x is the goal's and the start's mean)
START = (0.1, 0.5, 0.0, 0.5)
MID_HEIGHT, MID_LEG = 0.8, 0.1
#: Weights of the tracking cost on (q, q̇), of the controls, and of the end
Q_RUN = (50.0, 50.0, 20.0, 50.0, 0.1, 0.1, 0.1, 0.1)
Q_END = (300.0, 300.0, 300.0, 300.0, 0.1, 0.1, 0.1, 0.1)
R_RUN = (0.01, 0.01)
#: The reference's stages
STAGES = 20


def hopper(mu: float = MU, g: float = G, u_max: float = 50.0) -> LagrangianSystem:
    """The hopper as a system: q = (x, y, θ, l), the controls ``u`` (torque, leg force), the foot on the floor."""
    q = ca.SX.sym("q", 4)
    u = Control("u", 2, lower=-u_max, upper=u_max)
    x, y, th, leg = q[0], q[1], q[2], q[3]
    B = ca.vertcat(ca.horzcat(0, -ca.sin(th)), ca.horzcat(0, ca.cos(th)), ca.horzcat(1, 0), ca.horzcat(0, 1))
    v = velocity(q)
    # the foot at (x + l sin θ, y − l cos θ): the leg force u₂ pushes the body along (−sin θ, cos θ), from the foot
    # (nosnoc's B, its J_n and J_t; its example's animation draws the foot at x − l sin θ, which does not match them)
    slip = v[0] + v[3] * ca.sin(th) + leg * v[2] * ca.cos(th)
    foot = ca.vertcat(x + leg * ca.sin(th), y - leg * ca.cos(th))
    return LagrangianSystem(q, MassMatrix(ca.diag(ca.DM([MB + ML, MB + ML, IB + IL, ML]))),
                            [Potential((MB + ML) * g * y, "gravity"), Force(ca.mtimes(B, u))],
                            names=["x", "y", "theta", "leg"], points_expr=[ca.vertcat(x, y), foot],
                            contact=Contact([y - leg * ca.cos(th)], restitution=0.0, friction=mu, slip=[slip],
                                            names=["foot"]))


def reference(goal: float, T: float):
    """``z_ref(t)``: the parabola ``P`` through the start, the middle and the end, constant on each stage (as nosnoc's
    reference is per control stage), as a CasADi function of ``t``; and ``z_end``."""
    z0 = np.r_[START, np.zeros(4)]
    zm = np.r_[0.5 * (START[0] + goal), MID_HEIGHT, 0.0, MID_LEG, np.zeros(4)]
    ze = np.r_[goal, START[1], 0.0, START[3], np.zeros(4)]
    t = ca.SX.sym("t")
    s = ca.fmin(ca.floor(t / (T / STAGES) + 1e-9), STAGES - 1) / (STAGES - 1)
    P = ca.DM(z0) * (1 - s) * (1 - 2 * s) + 4 * ca.DM(zm) * s * (1 - s) + ca.DM(ze) * s * (2 * s - 1)
    return ca.Function("z_ref", [t], [P]), ze
