"""Damped transfer by optimal control on the discrete action (DMOC): ẍ + c ẋ + k x = u, from rest at 0 to rest
at d in T, minimising ∫u² dt.

The closed form: the linear system ż = A z + B u, z = (x, ẋ), reaches z_T = (d, 0) at least cost
J* = (z_T − e^{AT} z_0)ᵀ W⁻¹ (z_T − e^{AT} z_0) with the controllability Gramian
W = ∫₀ᵀ e^{A(T−s)} B Bᵀ e^{Aᵀ(T−s)} ds (1.674735875385 for c = 0.5, k = 1, T = 2, d = 1).  The damping is
a Rayleigh force, the spring a potential: the forced discrete Euler–Lagrange equations of the scheme.

    python problems/damped_transfer.py
    python problems/damped_transfer.py --damping 0.2 --stiffness 4 --T 3 --distance 0.5 --json
"""
import sys

import casadi as ca
import numpy as np

from castrajectory import cli
from castrajectory.models.mechanics import Damping, Force, LagrangianSystem, MassMatrix, Potential
from castrajectory.models.control import Control
from castrajectory.solve.optimal_control import OptimalControl
from castrajectory.validation import InputError


def parser():
    p = cli.scene_parser("damped_transfer.py", __doc__.splitlines()[0])
    p.add_argument("--damping", type=float, default=0.5, help="damping c (>= 0)")
    p.add_argument("--stiffness", type=float, default=1.0, help="stiffness k (>= 0)")
    p.add_argument("--T", type=float, default=2.0, help="horizon T in s (> 0)")
    p.add_argument("--distance", type=float, default=1.0, help="distance d (m)")
    cli.add_control_flags(p, n=100)
    return p


def gramian_cost(c, k, T, d, steps=4000):
    """J* = rᵀ W⁻¹ r with r = (d, 0) (from rest at 0), W by the matrix exponential and Simpson's rule."""
    A = np.array([[0.0, 1.0], [-k, -c]])
    B = np.array([[0.0], [1.0]])
    s = np.linspace(0.0, T, steps + 1)
    w = np.ones(steps + 1)
    w[1:-1:2], w[2:-1:2] = 4.0, 2.0
    w *= (T / steps) / 3.0
    lam, V = np.linalg.eig(A)
    Vi = np.linalg.inv(V)
    W = np.zeros((2, 2))
    for si, wi in zip(s, w):
        E = np.real(V @ np.diag(np.exp(lam * (T - si))) @ Vi) @ B
        W += wi * (E @ E.T)
    r = np.array([d, 0.0])
    return float(r @ np.linalg.solve(W, r))


def run(args):
    cli.finite_flags(args, "damping", "stiffness", "T", "distance")
    if args.damping < 0 or args.stiffness < 0 or args.T <= 0:
        raise InputError("--damping and --stiffness must not be negative, --T must be positive")
    cli.check_animation_path(args.animate)
    u = Control("u", 1)
    x = ca.SX.sym("x", 1)
    terms = [Force(u)]
    if args.stiffness:
        terms.insert(0, Potential(0.5 * args.stiffness * x[0] ** 2, "spring"))
    if args.damping:
        terms.insert(-1, Damping(args.damping))
    system = LagrangianSystem(x, MassMatrix(1.0), terms, names=["x"], points_expr=[ca.vertcat(x[0], 0)])
    ocp = OptimalControl(system, T=args.T, N=args.n, scheme=args.scheme, controls=args.controls)
    ocp.initial(q=[0.0], qd=[0.0])
    ocp.final(q=[args.distance], qd=[0.0])
    ocp.minimize(running=u ** 2)
    sol = ocp.solve(options=cli.ipopt_options(args), verbose=args.verbose)
    J = gramian_cost(args.damping, args.stiffness, args.T, args.distance)
    lines = [f"J* (controllability Gramian) = {J:.12g}; J − J* = {sol.cost - J:.3e}"]
    return cli.control_outcome("damped transfer", system, sol, extra={"error_vs_exact": abs(sol.cost - J),
                                                                      "exact_cost": J}, extra_lines=lines)


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
