"""Block move by optimal control on the discrete action (DMOC): ẍ = u, from rest at 0 to rest at d in T,
minimising ∫u² dt.

The closed form (mass m): J* = 12 m² d²/T³, u*(t) = m (6 − 12 t/T) d/T², x*(t) = d (3 − 2t/T)(t/T)².  The midpoint
DMOC optimum on N steps is exactly J_N = J*·N²/(N² − 1) (a discrete optimum, to solver tolerance); the
controls and costates converge at second order, the costates to λ_v = −2u*.

    python problems/block_move.py
    python problems/block_move.py --distance 2 --T 3 --n 200 --json
"""
import sys

import casadi as ca
import numpy as np

from castrajectory import cli
from castrajectory.models.mechanics import Force, LagrangianSystem, MassMatrix
from castrajectory.models.control import Control
from castrajectory.solve.optimal_control import OptimalControl
from castrajectory.validation import InputError


def parser():
    p = cli.scene_parser("block_move.py", __doc__.splitlines()[0])
    p.add_argument("--distance", type=float, default=1.0, help="distance d (m)")
    p.add_argument("--T", type=float, default=1.0, help="horizon T in s (> 0)")
    p.add_argument("--mass", type=float, default=1.0, help="mass m (> 0)")
    cli.add_control_flags(p, n=50)
    return p


def problem(d, T, m, n, scheme, controls="quadrature"):
    u = Control("u", 1)
    x = ca.SX.sym("x", 1)
    system = LagrangianSystem(x, MassMatrix(m), [Force(u)], names=["x"],
                                 points_expr=[ca.vertcat(x[0], 0)])
    ocp = OptimalControl(system, T=T, N=n, scheme=scheme, controls=controls)
    ocp.initial(q=[0.0], qd=[0.0])
    ocp.final(q=[d], qd=[0.0])
    ocp.minimize(running=u ** 2)
    return system, ocp


def run(args):
    cli.finite_flags(args, "distance", "T", "mass")
    if args.T <= 0 or args.mass <= 0:
        raise InputError("--T and --mass must be positive")
    cli.check_animation_path(args.animate)
    d, T, m, N = args.distance, args.T, args.mass, args.n
    system, ocp = problem(d, T, m, N, args.scheme, args.controls)
    sol = ocp.solve(options=cli.ipopt_options(args), verbose=args.verbose)
    J = 12.0 * m * m * d * d / T ** 3           # ∫u² with u = m ẍ*
    u_exact = lambda t: m * (6.0 - 12.0 * t / T) * d / T ** 2  # noqa: E731
    JN = J * N * N / (N * N - 1)
    err_u = float(np.max(np.abs(sol.u[:, 0] - u_exact(sol.t_u)))) if sol.success else float("nan")
    lines = [f"J* = 12 m² d²/T³ = {J:.12g}; J − J* = {sol.cost - J:.2e}; the discrete optimum of controls constant "
             f"per step J_N = J*·N²/(N²−1) = {JN:.12g}; max |u − u*| at the control points {err_u:.2e}"]
    return cli.control_outcome("block move", system, sol, extra={
        "error_vs_exact": abs(sol.cost - J), "exact_cost": J, "discrete_optimum": JN, "control_error": err_u},
        extra_lines=lines, exact_u=u_exact)


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
