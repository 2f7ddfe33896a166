"""Minimum-time move by optimal control on the discrete action (DMOC): ẍ = u, |u| ≤ u_max, from rest at 0
to rest at d, minimising the final time T (free).

The closed form: T* = 2√(d/u_max), bang-bang with the switch at T*/2.  For an even N the discrete
minimum time is T* itself (the switch falls on a node).

    python problems/min_time.py
    python problems/min_time.py --distance 3 --u-max 0.5 --n 40 --json
"""
import math
import sys

import casadi as ca
import numpy as np

from castrajectory import cli
from castrajectory.models.mechanics import Force, LagrangianSystem, MassMatrix
from castrajectory.models.control import Control
from castrajectory.solve.optimal_control import OptimalControl
from castrajectory.validation import InputError


def parser():
    p = cli.scene_parser("min_time.py", __doc__.splitlines()[0])
    p.add_argument("--distance", type=float, default=1.0, help="distance d (m, > 0)")
    p.add_argument("--u-max", type=float, default=1.0, help="the control's bound |u| <= u_max (> 0)")
    cli.add_control_flags(p, n=40)
    return p


def run(args):
    cli.finite_flags(args, "distance", "u_max")
    if args.distance <= 0 or args.u_max <= 0:
        raise InputError("--distance and --u-max must be positive")
    cli.check_animation_path(args.animate)
    d, umax, N = args.distance, args.u_max, args.n
    u = Control("u", 1, lower=-umax, upper=umax)
    x = ca.SX.sym("x", 1)
    system = LagrangianSystem(x, MassMatrix(1.0), [Force(u)], names=["x"],
                                 points_expr=[ca.vertcat(x[0], 0)])
    Ts = 2.0 * math.sqrt(d / umax)
    ocp = OptimalControl(system, T=(0.1 * Ts, 10.0 * Ts), N=N, scheme=args.scheme, controls=args.controls)
    ocp.initial(q=[0.0], qd=[0.0])
    ocp.final(q=[d], qd=[0.0])
    ocp.minimize(final=ocp.T_symbol)
    sol = ocp.solve(options=cli.ipopt_options(args), verbose=args.verbose)
    neg = np.nonzero(sol.u[:, 0] < 0)[0] if sol.success else np.zeros(0, int)
    # the switch: between the last positive control point and the first negative one
    sw = float(0.5 * (sol.t_u[neg[0] - 1] + sol.t_u[neg[0]])) if neg.size and neg[0] > 0 else float("nan")
    lines = [f"T* = 2 sqrt(d/u_max) = {Ts:.12g}; T − T* = {sol.T - Ts:.2e}; the control switches sign at "
             f"t = {sw:.6g} (T*/2 = {Ts / 2:.6g})"]
    return cli.control_outcome("minimum-time move", system, sol, extra={
        "error_vs_exact": abs(sol.T - Ts), "exact_T": Ts, "switch_time": sw}, extra_lines=lines,
        exact_u=lambda t: np.where(t < Ts / 2, umax, -umax))


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
