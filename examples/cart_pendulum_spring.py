"""A pendulum hanging from a cart that is tied to a wall by a spring.

The cart (mass M, position x) slides without friction; a spring of stiffness k pulls it back to x = 0;
a pendulum of length l with a bob of mass m hangs from it (angle θ from the downward vertical).  The
cart's oscillation and the pendulum's swing exchange energy through the pivot's acceleration.

    castrajectory system examples/cart_pendulum_spring.py --animate cart.gif --plot cart.png
"""
import casadi as ca

import castrajectory as ct

M, m, l, k, g = 2.0, 0.5, 1.0, 20.0, 9.81
title = "pendulum on a spring-tied cart"
T, n = 10.0, 2000
q0 = [0.2, 0.6]          # x (m), θ (rad)
qd0 = [0.0, 0.0]
links = [(0, 1)]         # pictures: a line from the cart (atom 0) to the bob (atom 1)


def system():
    q = ca.SX.sym("q", 2)
    x, th = q[0], q[1]
    cart = ca.vertcat(x, 0)
    bob = cart + l * ca.vertcat(ca.sin(th), -ca.cos(th))
    return ct.LagrangianSystem(q, ct.Atoms([cart, bob], [M, m]),
                               [ct.Gravity(g), ct.Spring(k, 0.0, cart, ca.DM.zeros(2))], names=["x", "theta"])
