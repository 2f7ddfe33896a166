"""A double pendulum hung from a cart that rolls freely on a horizontal rail.

The cart (mass m₀) moves along x; from it hangs a chain of two massless links of lengths l₁, l₂ with bobs
m₁, m₂; θ₁ and θ₂ are the links' angles from the downward vertical.  With c_i = cos θ_i, s_i = sin θ_i,
c₁₂ = cos(θ₁ − θ₂), s₁₂ = sin(θ₁ − θ₂), the Euler–Lagrange equations are M(q) q̈ = f(q, q̇):

    M = [[m₀+m₁+m₂,      (m₁+m₂) l₁ c₁,    m₂ l₂ c₂    ],
         [(m₁+m₂) l₁ c₁, (m₁+m₂) l₁²,      m₂ l₁ l₂ c₁₂],
         [m₂ l₂ c₂,      m₂ l₁ l₂ c₁₂,     m₂ l₂²      ]]
    f = [(m₁+m₂) l₁ s₁ θ̇₁² + m₂ l₂ s₂ θ̇₂²,
         −m₂ l₁ l₂ s₁₂ θ̇₂² − (m₁+m₂) g l₁ s₁,
          m₂ l₁ l₂ s₁₂ θ̇₁² − m₂ g l₂ s₂]

written out by hand in :func:`equations` (not from the package): scripts/estimate_battery.py integrates
them with scipy's DOP853 at rtol = atol = 1e-13 as the oracle, and checks first that they agree with the
package's own ``system().acceleration(q, q̇)`` at random states.  No horizontal force acts: the total
horizontal momentum (m₀+m₁+m₂) ẋ + (m₁+m₂) l₁ c₁ θ̇₁ + m₂ l₂ c₂ θ̇₂ is conserved (x is cyclic), and so is
the energy.  From θ = (1.0, 0.5) at rest the motion is irregular within a few seconds.

    castrajectory system examples/cart_double_pendulum.py --scheme galerkin8 --n 100
"""
import casadi as ca
import numpy as np

import castrajectory as ct

m0, m1, m2, l1, l2, g = 1.0, 1.0, 1.0, 1.0, 1.0, 9.81
title = "double pendulum on a cart"
T, n = 3.0, 300
q0 = [0.0, 1.0, 0.5]        # cart position (m), link angles from the downward vertical (rad)
qd0 = [0.0, 0.0, 0.0]


def system():
    q = ca.SX.sym("q", 3)
    x, t1, t2 = q[0], q[1], q[2]
    cart = ca.vertcat(x, 0)
    bob1 = cart + l1 * ca.vertcat(ca.sin(t1), -ca.cos(t1))
    bob2 = bob1 + l2 * ca.vertcat(ca.sin(t2), -ca.cos(t2))
    return ct.LagrangianSystem(q, ct.Atoms([cart, bob1, bob2], [m0, m1, m2]), [ct.Gravity(g)],
                               names=["x", "theta1", "theta2"])


def equations(q, qd):
    """``(M, f)`` of the docstring at one state (numpy, written by hand)."""
    _, t1, t2 = q
    _, w1, w2 = qd
    c1, s1, c2, s2 = np.cos(t1), np.sin(t1), np.cos(t2), np.sin(t2)
    c12, s12 = np.cos(t1 - t2), np.sin(t1 - t2)
    M = np.array([[m0 + m1 + m2, (m1 + m2) * l1 * c1, m2 * l2 * c2],
                  [(m1 + m2) * l1 * c1, (m1 + m2) * l1 ** 2, m2 * l1 * l2 * c12],
                  [m2 * l2 * c2, m2 * l1 * l2 * c12, m2 * l2 ** 2]])
    f = np.array([(m1 + m2) * l1 * s1 * w1 ** 2 + m2 * l2 * s2 * w2 ** 2,
                  -m2 * l1 * l2 * s12 * w2 ** 2 - (m1 + m2) * g * l1 * s1,
                  m2 * l1 * l2 * s12 * w1 ** 2 - m2 * g * l2 * s2])
    return M, f
