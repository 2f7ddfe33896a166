"""A ladder sliding down a frictionless wall on a frictionless floor: a held-contact benchmark.

A uniform rod of length L and mass m leans against the wall x = 0 at the angle θ₀ from the floor and is
let go from rest.  While both ends touch, it has one degree of freedom: its centre moves on the circle
of radius L/2 about the corner, and θ̈ = −(3g / 2L) cos θ, θ̇² = (3g/L)(sin θ₀ − sin θ).  The wall's force
vanishes, and the top leaves the wall, when sin θ = (2/3) sin θ₀ (the classical lift-off).  Until then
both contacts are *held*: their forces act at the scheme's stages, so the held phase has the scheme's order, and
the lift-off is timed inside its step where the wall's force reaches zero (``problems/sliding_ladder.py`` is the
same scene with its closed form).

    castrajectory system examples/sliding_ladder.py --scheme galerkin4 --n 400
"""
import math

import casadi as ca
import castrajectory as ct

m, L, g = 1.0, 1.0, 9.81
theta0 = math.radians(70.0)
title = "ladder sliding down a frictionless wall"
T, n = 0.4, 200            # lift-off from the wall at t = 0.4225 s for θ₀ = 70°
q0 = [0.5 * L * math.cos(theta0), 0.5 * L * math.sin(theta0), theta0]   # centre (x, y), angle from the floor
qd0 = [0.0, 0.0, 0.0]


def system():
    q = ca.SX.sym("q", 3)
    x, y, th = q[0], q[1], q[2]
    top = ca.vertcat(x - 0.5 * L * ca.cos(th), y + 0.5 * L * ca.sin(th))
    bottom = ca.vertcat(x + 0.5 * L * ca.cos(th), y - 0.5 * L * ca.sin(th))
    return ct.LagrangianSystem(q, ct.MassMatrix(ca.diag(ca.vertcat(m, m, m * L ** 2 / 12))), [ct.Gravity(g, heights=[y], masses=[m])],
                               names=["x", "y", "theta"],
                               contact=ct.Contact([top[0], bottom[1]], restitution=0.0, names=["wall", "floor"]))


def lift_off_angle() -> float:
    """sin θ* = (2/3) sin θ₀."""
    return math.asin(2.0 / 3.0 * math.sin(theta0))
