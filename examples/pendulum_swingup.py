"""A pendulum swung up by a bounded torque, at least effort: optimal control on the discrete action.

A bob of mass m on a massless rod of length l, pivot damping b, a torque |u| <= u_max at the pivot; from
hanging at rest (θ = 0) to upright at rest (θ = π) in T, minimising ∫ 10 u² dt.  With m = 1, l = 0.5,
b = 0.1, u_max = 3 and T = 4 the torque cannot lift the bob straight up (m g l = 4.9 > 3): the optimum
pumps it, swinging back and forth, and its cost converges to J* = 65.48558 (a local optimum).

    castrajectory control examples/pendulum_swingup.py --plot swingup.png
"""
import casadi as ca
import castrajectory as ct

m, l, b, g, u_max, T = 1.0, 0.5, 0.1, 9.81, 3.0, 4.0
title = "pendulum swing-up"


def problem(N=200, scheme="midpoint"):
    u = ct.Control("u", 1, lower=-u_max, upper=u_max)              # the torque at the pivot
    th = ca.SX.sym("theta", 1)
    bob = ca.vertcat(l * ca.sin(th[0]), -l * ca.cos(th[0]))
    pendulum = ct.LagrangianSystem(th, ct.Atoms([bob], [m]), [ct.Gravity(g), ct.Damping(b), ct.Force(u)],
                                   names=["theta"])
    ocp = ct.OptimalControl(pendulum, T=T, N=N, scheme=scheme)
    ocp.initial(q=[0.0], qd=[0.0])
    ocp.final(q=[ca.pi], qd=[0.0])
    ocp.minimize(running=10 * u ** 2)
    return ocp
