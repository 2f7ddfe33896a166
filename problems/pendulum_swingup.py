"""Pendulum swing-up by optimal control on the discrete action (DMOC): a bounded torque pumps a damped
pendulum from hanging to upright at least ∫10u² dt (the problem of examples/pendulum_swingup.py, with flags).

A bob of mass m on a rod of length l, pivot damping b, |u| ≤ u_max, from θ = 0 to θ = π at rest in T.  With
m = 1, l = 0.5, b = 0.1, u_max = 3, T = 4 (the torque cannot lift the bob directly: m g l = 4.9 > 3) a local
optimum has J* = 65.48558; the midpoint DMOC converges to it at second order.

    python problems/pendulum_swingup.py
    python problems/pendulum_swingup.py --n 400 --animate swingup.gif
"""
import sys

import casadi as ca
import numpy as np

from castrajectory import cli
from castrajectory.models.mechanics import Atoms, Damping, Force, Gravity, LagrangianSystem
from castrajectory.models.control import Control
from castrajectory.solve.optimal_control import OptimalControl
from castrajectory.validation import InputError

REFERENCE = 65.48558


def parser():
    p = cli.scene_parser("pendulum_swingup.py", __doc__.splitlines()[0])
    p.add_argument("--mass", type=float, default=1.0, help="bob mass m (> 0)")
    p.add_argument("--length", type=float, default=0.5, help="rod length l (> 0)")
    p.add_argument("--damping", type=float, default=0.1, help="pivot damping b (>= 0)")
    p.add_argument("--u-max", type=float, default=3.0, help="|u| <= u_max (> 0)")
    p.add_argument("--T", type=float, default=4.0, help="horizon T in s (> 0)")
    p.add_argument("--g", type=float, default=9.81, help="gravity")
    cli.add_control_flags(p, n=200)
    return p


def run(args):
    cli.finite_flags(args, "mass", "length", "damping", "u_max", "T", "g")
    for flag in ("mass", "length", "u_max", "T"):
        if getattr(args, flag) <= 0:
            raise InputError(f"--{flag.replace('_', '-')} must be positive (got {getattr(args, flag):g})")
    if args.damping < 0:
        raise InputError(f"--damping must not be negative (got {args.damping:g})")
    cli.check_animation_path(args.animate)
    u = Control("u", 1, lower=-args.u_max, upper=args.u_max)
    th = ca.SX.sym("theta", 1)
    bob = ca.vertcat(args.length * ca.sin(th[0]), -args.length * ca.cos(th[0]))
    terms = [Gravity(args.g)] + ([Damping(args.damping)] if args.damping else []) + [Force(u)]
    system = LagrangianSystem(th, Atoms([bob], [args.mass]), terms, names=["theta"])
    ocp = OptimalControl(system, T=args.T, N=args.n, scheme=args.scheme, controls=args.controls)
    ocp.initial(q=[0.0], qd=[0.0])
    ocp.final(q=[ca.pi], qd=[0.0])
    ocp.minimize(running=10 * u ** 2)
    sol = ocp.solve(options=cli.ipopt_options(args), verbose=args.verbose)
    default = (args.mass, args.length, args.damping, args.u_max, args.T, args.g) == (1.0, 0.5, 0.1, 3.0, 4.0, 9.81)
    extra, lines = {}, [f"max |u| = {np.max(np.abs(sol.u)):.4g} (bound {args.u_max:g})"]
    if default:
        extra = {"error_vs_exact": abs(sol.cost - REFERENCE), "reference_cost": REFERENCE}
        lines.append(f"the local optimum J* = {REFERENCE}; J − J* = {sol.cost - REFERENCE:.3e}")
    return cli.control_outcome("pendulum swing-up", system, sol, extra=extra, extra_lines=lines)


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
