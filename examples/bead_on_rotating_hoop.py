"""A bead on a hoop that spins about its vertical diameter, in the hoop's rotating frame.

The bead (mass m) slides without friction on a hoop of radius R spinning at ω about the vertical axis.
Its position in the hoop's plane is (x, z), held on the circle by the holonomic constraint
x² + z² = R²; in the rotating frame the centrifugal potential −½ m ω² x² pushes it outwards.  Above the
critical speed ω² > g/R the bottom is unstable and the bead oscillates about cos θ* = g/(R ω²).

    castrajectory system examples/bead_on_rotating_hoop.py --animate bead.gif
"""
import math

import casadi as ca

import castrajectory as ct

m, R, omega, g = 1.0, 1.0, 5.0, 9.81
title = "bead on a rotating hoop"
T, n = 5.0, 1000
theta0 = 0.2
q0 = [R * math.sin(theta0), -R * math.cos(theta0)]
qd0 = [0.0, 0.0]
links = True             # draw the hoop's centre -> the bead


def system():
    q = ca.SX.sym("xz", 2)
    x, z = q[0], q[1]
    return ct.LagrangianSystem(q, ct.Atoms([q], [m]),
                               [ct.Potential(m * g * z, "gravity"),
                                ct.Potential(-0.5 * m * omega ** 2 * x ** 2, "centrifugal")],
                               constraints=[(x ** 2 + z ** 2 - R ** 2) / 2], names=["x", "z"])
