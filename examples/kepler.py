"""Kepler's problem in Cartesian coordinates, with the quantities a user watches: the angular momentum,
the energy and the Runge–Lenz vector's direction.

A unit mass around a unit central mass (GM = 1), U = −1/|x|.  From x = (1, 0) with velocity (0, v₀) the
orbit is an ellipse of eccentricity e = v₀² − 1 and period 2π a^{3/2}, a = 1/(2 − v₀²).  Every
coordinate appears in L, so no coordinate is cyclic; the rotation in the (x, y) plane is a symmetry all the
same, and its momentum L_z = x ẏ − y ẋ is conserved -- exactly by the discrete solution (the derivation
finds the symmetry from L and says so).  The energy is kept bounded; the Runge–Lenz vector, a hidden
symmetry's, precesses slowly on the discrete orbit.

    castrajectory system examples/kepler.py --scheme galerkin4 --plot kepler.png
    castrajectory derive examples/kepler.py --out kepler.md
"""
import casadi as ca
import castrajectory as ct

v0 = 1.2
title = "Kepler orbit"
T, n = 20.0, 4000
q0 = [1.0, 0.0]
qd0 = [0.0, v0]


def system():
    x = ca.SX.sym("x", 2)
    v = ct.velocity(x)
    r = ca.norm_2(x)
    L_z = x[0] * v[1] - x[1] * v[0]
    return ct.LagrangianSystem(
        x, ct.Atoms([x], [1.0]), [ct.Potential(-1.0 / r, "gravity")], names=["x", "y"],
        quantities={"L_z": L_z, "E": 0.5 * ca.dot(v, v) - 1.0 / r,
                    "Runge-Lenz angle": ca.atan2(-L_z * v[0] - x[1] / r, L_z * v[1] - x[0] / r)})
