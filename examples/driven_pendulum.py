"""The damped, driven pendulum θ̈ + γθ̇ + ω₀² sin θ = A cos(Ωt) in the chaotic regime.

A unit bob on a unit rod under the gravity ω₀², a Rayleigh damping ``ct.Damping(γ)`` and the drive as a
torque that holds the time.  Over T = 20 the motion is still predictable (the whole-trajectory answer
agrees with DOP853 at rtol 1e-12 to 1e-9 rad at n = 2000, galerkin4); over thousands of seconds it
wanders on the strange attractor.

    castrajectory system examples/driven_pendulum.py --scheme galerkin4 --animate driven.gif
"""
import casadi as ca
import castrajectory as ct

gamma, omega0, A, Omega = 0.5, 1.0, 1.2, 2.0 / 3.0
title = "damped, driven pendulum"
T, n = 20.0, 2000
q0 = [0.0]
qd0 = [0.0]


def system():
    th = ca.SX.sym("theta", 1)
    bob = ca.vertcat(ca.sin(th), -ca.cos(th))
    return ct.LagrangianSystem(th, ct.Atoms([bob], [1.0]),
                               [ct.Gravity(omega0 ** 2), ct.Damping(gamma),
                                ct.Force(A * ca.cos(Omega * ct.time()), "drive")], names=["theta"])
