"""Cart-pole swing-up by optimal control on the discrete action (DMOC): a force on the cart swings the pole up
while the cart moves to a target, at least ∫u² dt (Kelly, SIAM Review 59 (2017) §6).

A cart of mass m₁ on a rail, a pole bob of mass m₂ on a massless rod of length l (θ from hanging down);
from rest at x = 0, θ = 0 to rest at x = target, θ = π in T, |x| ≤ x_max, |u| ≤ u_max.  With Kelly's
numbers (1 kg, 0.3 kg, 0.5 m, T = 2, target 1, x_max 2, u_max 20) a local optimum has
J* = 58.8076674582 (Hermite–Simpson at N = 800 and 1600, extrapolated at its 4th order; the bounds
inactive, max |u| = 13.98); the midpoint DMOC converges to it at second order.

    python problems/cartpole_swingup.py
    python problems/cartpole_swingup.py --n 400 --animate cartpole.gif
"""
import sys

import casadi as ca
import numpy as np

from castrajectory import cli
from castrajectory.models.mechanics import Atoms, Force, Gravity, LagrangianSystem
from castrajectory.models.control import Control
from castrajectory.solve.optimal_control import OptimalControl
from castrajectory.validation import InputError

KELLY = 58.8076674582


def parser():
    p = cli.scene_parser("cartpole_swingup.py", __doc__.splitlines()[0])
    p.add_argument("--cart-mass", type=float, default=1.0, help="cart mass m1 (> 0)")
    p.add_argument("--pole-mass", type=float, default=0.3, help="pole bob mass m2 (> 0)")
    p.add_argument("--length", type=float, default=0.5, help="pole length l (> 0)")
    p.add_argument("--g", type=float, default=9.81, help="gravity")
    p.add_argument("--T", type=float, default=2.0, help="horizon T in s (> 0)")
    p.add_argument("--target", type=float, default=1.0, help="the cart's final position")
    p.add_argument("--x-max", type=float, default=2.0, help="|x| <= x_max (> 0)")
    p.add_argument("--u-max", type=float, default=20.0, help="|u| <= u_max (> 0)")
    cli.add_control_flags(p, n=200)
    return p


def problem(m1, m2, l, g, T, target, x_max, u_max, N, scheme="midpoint", controls="quadrature"):
    u = Control("u", 1, lower=-u_max, upper=u_max)
    q = ca.SX.sym("q", 2)
    cart = ca.vertcat(q[0], 0)
    bob = ca.vertcat(q[0] + l * ca.sin(q[1]), -l * ca.cos(q[1]))
    system = LagrangianSystem(q, Atoms([cart, bob], [m1, m2]), [Gravity(g), Force(ca.vertcat(u, 0))],
                                 names=["x", "theta"])
    ocp = OptimalControl(system, T=T, N=N, scheme=scheme, controls=controls)
    ocp.initial(q=[0.0, 0.0], qd=[0.0, 0.0])
    ocp.final(q=[target, ca.pi], qd=[0.0, 0.0])
    ocp.minimize(running=u ** 2)
    ocp.subject_to(-x_max <= q[0], q[0] <= x_max)
    return system, ocp


def run(args):
    cli.finite_flags(args, "cart_mass", "pole_mass", "length", "g", "T", "target", "x_max", "u_max")
    for flag in ("cart_mass", "pole_mass", "length", "T", "x_max", "u_max"):
        if getattr(args, flag) <= 0:
            raise InputError(f"--{flag.replace('_', '-')} must be positive (got {getattr(args, flag):g})")
    if abs(args.target) > args.x_max:
        raise InputError(f"--target {args.target:g} lies outside |x| <= --x-max {args.x_max:g}")
    cli.check_animation_path(args.animate)
    system, ocp = problem(args.cart_mass, args.pole_mass, args.length, args.g, args.T, args.target, args.x_max,
                          args.u_max, args.n, args.scheme, args.controls)
    sol = ocp.solve(options=cli.ipopt_options(args), verbose=args.verbose)
    kelly = (args.cart_mass, args.pole_mass, args.length, args.g, args.T, args.target, args.x_max, args.u_max) == \
        (1.0, 0.3, 0.5, 9.81, 2.0, 1.0, 2.0, 20.0)
    extra, lines = {}, [f"max |u| = {np.max(np.abs(sol.u)):.4g}"]
    if kelly:
        extra = {"error_vs_exact": abs(sol.cost - KELLY), "reference_cost": KELLY}
        lines.append(f"Kelly's local optimum J* = {KELLY}; J − J* = {sol.cost - KELLY:.3e}")
    return cli.control_outcome("cart-pole swing-up", system, sol, extra=extra, extra_lines=lines)


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
