"""Satellite slew by optimal control on the discrete action (DMOC): a rigid body on SO(3) (a unit quaternion
with its norm as a holonomic constraint), turned from rest to rest by an angle Θ about an axis in T by a body
torque τ, minimising ∫|τ|² dt.

The torque enters as the generalised force of its virtual work, Q = ∂(τ·ω)/∂q̇ with ω = 2 Im(q̄ ⊗ q̇) the
body angular velocity.  For a spherical inertia j the optimum turns about the fixed axis with cubic timing:
J* = 12 j² Θ² / T³; for an asymmetric body the optimum and its convergence are reported.

    python problems/satellite_slew.py
    python problems/satellite_slew.py --inertia 1 2 3 --angle 2 --axis 0 0 1 --T 4 --n 200 --json
"""
import sys

import casadi as ca
import numpy as np

from castrajectory import cli
from castrajectory.models.mechanics import Force, LagrangianSystem, velocity
from castrajectory.models.control import Control
from castrajectory.models.rigidbody import Inertia, RigidBody, angular_velocity, axis_angle, body_point, unit_norm
from castrajectory.solve.optimal_control import OptimalControl
from castrajectory.validation import InputError


def parser():
    p = cli.scene_parser("satellite_slew.py", __doc__.splitlines()[0])
    p.add_argument("--inertia", type=float, nargs=3, default=[1.0, 1.0, 1.0], metavar=("I1", "I2", "I3"),
                   help="principal moments of inertia (> 0, triangle inequality)")
    p.add_argument("--angle", type=float, default=1.0, help="slew angle Θ in rad")
    p.add_argument("--axis", type=float, nargs=3, default=[1.0, 1.0, 0.0], metavar=("X", "Y", "Z"),
                   help="slew axis (world = body axes at the start; normalised)")
    p.add_argument("--T", type=float, default=2.0, help="horizon T in s (> 0)")
    cli.add_control_flags(p, n=80)
    return p


def run(args):
    cli.finite_flags(args, "angle", "T")
    axis = np.asarray(args.axis, float)
    if not np.all(np.isfinite(axis)) or np.linalg.norm(axis) == 0:
        raise InputError(f"--axis must be a finite, nonzero vector (got {args.axis})")
    if args.T <= 0:
        raise InputError(f"--T must be positive (got {args.T:g})")
    inertia = Inertia(*args.inertia)
    cli.check_animation_path(args.animate)
    tau = Control("tau", 3)
    q = ca.SX.sym("quat", 4)
    omega = angular_velocity(q, velocity(q))
    Q = ca.jacobian(ca.dot(tau, omega), velocity(q)).T          # the torque's generalised force
    points = [body_point(q, [0.0, 0.0, 0.0])] + [body_point(q, e) for e in np.eye(3)]
    body = LagrangianSystem(q, RigidBody(q, inertia), [Force(Q)], constraints=[unit_norm(q)],
                               names=["qw", "qx", "qy", "qz"], points_expr=points)
    ocp = OptimalControl(body, T=args.T, N=args.n, scheme=args.scheme, controls=args.controls)
    ocp.initial(q=[1.0, 0.0, 0.0, 0.0], qd=[0.0] * 4)
    ocp.final(q=axis_angle(axis, args.angle).tolist(), qd=[0.0] * 4)
    ocp.minimize(running=ca.sumsqr(tau))
    sol = ocp.solve(options=cli.ipopt_options(args), verbose=args.verbose)
    extra, lines = {}, []
    m = inertia.moments
    if np.allclose(m, m[0], rtol=1e-12):
        J = 12.0 * m[0] ** 2 * args.angle ** 2 / args.T ** 3
        extra = {"error_vs_exact": abs(sol.cost - J), "exact_cost": J}
        lines = [f"spherical inertia: J* = 12 j² Θ²/T³ = {J:.12g}; J − J* = {sol.cost - J:.3e}"]
    else:
        lines = ["asymmetric inertia: no closed form (the optimum's convergence: tests/test_optimal_control.py)"]
    return cli.control_outcome("satellite slew", body, sol, extra=extra, extra_lines=lines)


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
