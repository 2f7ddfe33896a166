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


def _expm(M: np.ndarray) -> np.ndarray:
    """e^M by scaling and squaring of a Taylor series (M small: 4×4 here, any eigenstructure, defective or not)."""
    s = max(0, int(np.ceil(np.log2(max(np.abs(M).sum(axis=0).max(), 1e-300)))) + 1)
    A = M / 2.0 ** s
    E, term = np.eye(len(M)), np.eye(len(M))
    for j in range(1, 25):
        term = term @ A / j
        E = E + term
    for _ in range(s):
        E = E @ E
    return E


class Optimum:
    """The closed-form optimum of ż = A z + B u, z = (x, ẋ), from rest at 0 to rest at d in T, least ∫u²:
    ``u*(t) = Bᵀ e^{Aᵀ(T−t)} W⁻¹ r``, ``z*(t) = W(t) e^{Aᵀ(T−t)} W⁻¹ r`` (r = (d, 0), W(t) the Gramian on
    [0, t], by Van Loan's block exponential), ``J* = rᵀ W⁻¹ r``, and the costate of the velocity
    ``λ_v(t) = −2 u*(t)`` (H = u² + λᵀ(Az + Bu))."""

    def __init__(self, c, k, T, d):
        self.A = np.array([[0.0, 1.0], [-k, -c]])
        self.B = np.array([[0.0], [1.0]])
        self.T = float(T)
        r = np.array([d, 0.0])
        self.Winv_r = np.linalg.solve(self.gramian(T), r)
        self.J = float(r @ self.Winv_r)

    def gramian(self, t):
        A, B = self.A, self.B
        F = _expm(np.block([[-A, B @ B.T], [np.zeros((2, 2)), A.T]]) * t)
        return F[2:, 2:].T @ F[:2, 2:]

    def _adjoint(self, t):
        return _expm(self.A.T * (self.T - t)) @ self.Winv_r

    def u(self, t):
        return np.array([float(self.B[:, 0] @ self._adjoint(ti)) for ti in np.atleast_1d(t)])

    def z(self, t):
        return np.array([self.gramian(ti) @ self._adjoint(ti) for ti in np.atleast_1d(t)])


def gramian_cost(c, k, T, d):
    """J* = rᵀ W⁻¹ r with r = (d, 0) (from rest at 0)."""
    return Optimum(c, k, T, d).J


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
    opt = Optimum(args.damping, args.stiffness, args.T, args.distance)
    J = opt.J
    lines = [f"J* (controllability Gramian) = {J:.12g}; J − J* = {sol.cost - J:.3e}"]
    extra = {"error_vs_exact": abs(sol.cost - J), "exact_cost": J}
    if sol.success:
        # the closed form at the control points and the nodes; the costates at the interior nodes
        z = opt.z(sol.t)
        extra["control_error"] = float(np.max(np.abs(sol.u[:, 0] - opt.u(sol.t_u))))
        extra["state_error"] = float(max(np.max(np.abs(sol.q[:, 0] - z[:, 0])), np.max(np.abs(sol.v[:, 0] - z[:, 1]))))
        if sol.costates is not None:
            extra["costate_error"] = float(np.max(np.abs(sol.costates[:, 0] + 2 * opt.u(sol.t[1:-1]))))
        lines.append(f"max error against the closed form: u {extra['control_error']:.2e}, (x, ẋ) at the nodes "
                     f"{extra['state_error']:.2e}, costate {extra.get('costate_error', float('nan')):.2e}")
    return cli.control_outcome("damped transfer", system, sol, extra=extra, extra_lines=lines)


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
