"""A heavy symmetric top on a fixed pivot, written with the public names only: a 3-D body on a quaternion.

The top has mass m, moments (I₁ = I₂, I₃) about its centre of mass, which sits a distance l up its symmetry
axis from the pivot at the origin; z points up.  Two rotations leave it unchanged -- about the vertical
(gravity's axis) and about its own symmetry axis -- so the vertical angular momentum L_z and the spin
momentum L_3 are conserved, exactly by the discrete solution (discrete Noether); the energy is kept
bounded.  Started tilted 0.5 rad, spinning fast about its axis, it precesses and nutates (Lagrange's top).

    castrajectory system examples/heavy_top.py --scheme galerkin4 --plot top.png
    castrajectory derive examples/heavy_top.py --out top.md
"""
import casadi as ca
import numpy as np
import castrajectory as ct

m, l, g = 1.0, 0.5, 9.81
inertia = ct.Inertia(0.05, 0.05, 0.02)          # about the centre of mass
title = "heavy symmetric top"
T, n = 3.0, 1500
tilt = 0.5
q0 = [np.cos(tilt / 2), np.sin(tilt / 2), 0.0, 0.0]            # tilted about x
qd0 = ct.quaternion_rate(q0, [0.0, 0.0, 40.0]).tolist()        # spinning about its own axis


def system():
    quat = ca.SX.sym("quat", 4)
    pivot = inertia.about(m, [0.0, 0.0, l])                     # Steiner: the moments about the pivot
    com = ct.body_point(quat, [0.0, 0.0, l])                    # the centre of mass in world axes
    w = ct.angular_velocity(quat, ct.velocity(quat))            # body angular velocity
    Lb = ca.DM(pivot.moments) * w                               # body angular momentum about the pivot
    return ct.LagrangianSystem(
        quat, ct.RigidBody(quat, pivot), [ct.Gravity(g, heights=[com[2]], masses=[m])],
        constraints=[ct.unit_norm(quat)], names=["qw", "qx", "qy", "qz"],
        points_expr=[ca.SX.zeros(3), com],
        quantities={"L_z": ca.mtimes(ct.rotation(quat), Lb)[2], "L_3": Lb[2]})
