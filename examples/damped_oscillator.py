"""A mass on a spring with linear damping, driven by a periodic force: m ẍ + c ẋ + k x = A cos(Ωt).

The spring is a potential, the damping a Rayleigh term (``ct.Damping(c)``: the force −c ẋ) and the drive
a time-dependent force (``ct.Force`` of ``ct.time()``).  After the transient dies out (over 2m/c) the
mass follows the drive at the amplitude A/√((k − mΩ²)² + c²Ω²); the printed energy balance
E(t) − E(0) − W(t) holds to the scheme's order.

    castrajectory system examples/damped_oscillator.py --scheme galerkin8 --plot oscillator.png
"""
import casadi as ca
import castrajectory as ct

m, k, c, A, W = 1.0, 4.0, 0.3, 0.5, 1.7
title = "damped, driven oscillator"
T, n = 30.0, 300
q0 = [1.0]
qd0 = [0.0]


def system():
    x = ca.SX.sym("x", 1)
    return ct.LagrangianSystem(x, ct.MassMatrix(m), [ct.Potential(0.5 * k * x[0] ** 2, "spring"), ct.Damping(c),
                                                     ct.Force(A * ca.cos(W * ct.time()), "drive")], names=["x"])
