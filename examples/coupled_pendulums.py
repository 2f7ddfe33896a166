"""Two pendulums coupled by a spring between their bobs: energy passes back and forth (beats).

Each pendulum has length l and a bob of mass m, hung from pivots a distance d apart; a spring of
stiffness k and rest length d joins the bobs.  For small angles the normal modes are in phase,
ω₁ = √(g/l), and in antiphase, ω₂ = √(g/l + 2k/m); starting one pendulum at θ₀ and the other at rest,
θ₁(t) ≈ θ₀/2 (cos ω₁t + cos ω₂t): the energy moves to the second pendulum and back with the beat
period 2π/(ω₂ − ω₁).

    castrajectory system examples/coupled_pendulums.py --animate beats.gif
"""
import casadi as ca
import castrajectory as ct

m, l, d, k, g = 1.0, 1.0, 1.0, 0.5, 9.81
title = "spring-coupled pendulums"
T, n = 20.0, 2000          # optional: the horizon and the number of steps
q0 = [0.05, 0.0]           # angles from the downward vertical (rad)
qd0 = [0.0, 0.0]
links = False              # pictures: draw the bobs, not a chain from the origin


def system():
    q = ca.SX.sym("theta", 2)
    left = ca.vertcat(l * ca.sin(q[0]), -l * ca.cos(q[0]))
    right = ca.vertcat(d + l * ca.sin(q[1]), -l * ca.cos(q[1]))
    return ct.LagrangianSystem(q, ct.Atoms([left, right], [m, m]),
                               [ct.Gravity(g), ct.Spring(k, d, left, right)], names=["theta1", "theta2"])
