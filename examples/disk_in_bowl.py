"""A disk rocking in a circular bowl, rolling (μ = 1) or sliding (a small μ) under Coulomb friction.

A uniform disk (mass m, radius r, I = m r²/2) lies on the inside of a circular bowl of radius R centred at
the origin; q = (x, y, θ), its centre and its angle (counter-clockwise).  The contact's gap is
φ = (R − r) − |c|, c = (x, y); the contact point c + r n (n = c/|c|) slips at u = t·ċ + r θ̇ along the
tangent t = (−n_y, n_x).  Written φ from the bottom, c = (R − r)(sin φ, −cos φ), u = (R − r) φ̇ + r θ̇.

The oracle, while the disk rolls without slipping (u = 0, which friction μ = 1 holds from a start at rest at
φ₀ = 0.5 rad: rolling needs |F|/N ≈ tan φ / 3 ≤ 0.19): the reduced equation
(3/2)(R − r) φ̈ = −g sin φ, and θ = −(R − r)(φ − φ₀)/r.  scripts/estimate_battery.py integrates it with
DOP853 at 1e-13.  With μ = 0.05 the disk slides, its slip reversing as it rocks.

    castrajectory system examples/disk_in_bowl.py --n 400
"""
import math

import casadi as ca
import castrajectory as ct

m, r, R, g = 1.0, 0.2, 1.0, 9.81
mu = 1.0
phi0 = 0.5
title = "disk in a circular bowl"
T, n = 2.0, 400
q0 = [(R - r) * math.sin(phi0), -(R - r) * math.cos(phi0), 0.0]
qd0 = [0.0, 0.0, 0.0]


def system(friction: float = mu):
    q = ca.SX.sym("q", 3)
    v = ct.velocity(q)
    c = q[:2]
    dist = ca.norm_2(c)
    tangent = ca.vertcat(-c[1], c[0]) / dist
    rim = [c + r * ca.vertcat(ca.cos(q[2] + a), ca.sin(q[2] + a)) for a in (0.0, math.pi / 2, math.pi, 1.5 * math.pi)]
    return ct.LagrangianSystem(q, ct.MassMatrix(ca.diag(ca.vertcat(m, m, 0.5 * m * r * r))),
                               [ct.Potential(m * g * q[1], "gravity")], names=["x", "y", "theta"], points_expr=rim,
                               contact=ct.Contact([(R - r) - dist], restitution=0.0, friction=friction,
                                                  slip=[ca.dot(tangent, v[:2]) + r * v[2]], names=["bowl"]))
