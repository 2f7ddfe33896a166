"""Kapitza's pendulum: the pivot oscillates vertically as a cos(ωt), and the inverted position is stable.

The pivot is an atom position that holds ``ct.time()``; nothing else is needed: the kinetic energy of
the moving bob, and with it the Lagrangian, depends on time.  With a²ω² = 100 > 2gl = 19.6 the
pendulum started 0.2 rad from upright stays up; at ω = 35 (a²ω² = 12.25) it falls.

    castrajectory system examples/kapitza_pendulum.py --animate kapitza.gif
"""
import math

import casadi as ca
import castrajectory as ct

l, g, a, w = 1.0, 9.81, 0.1, 100.0
title = "Kapitza pendulum"
T, n = 5.0, 2000
q0 = [math.pi - 0.2]
qd0 = [0.0]
links = [(0, 1)]            # draw the rod from the moving pivot (atom 0) to the bob (atom 1)


def system():
    th = ca.SX.sym("theta", 1)
    t = ct.time()
    pivot = ca.vertcat(0, a * ca.cos(w * t))
    bob = pivot + l * ca.vertcat(ca.sin(th), -ca.cos(th))
    return ct.LagrangianSystem(th, ct.Atoms([bob], [1.0]), [ct.Gravity(g)], names=["theta"],
                               points_expr=[pivot, bob])
