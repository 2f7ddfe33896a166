"""Block push: contact-implicit optimal control of a block on a floor with Coulomb friction, from rest (or launched
at --v0) at 0 to rest at d in T, minimising ∫u² dt, against the closed form.

The block (a point of mass m on the floor y >= 0, friction μ) is moved by a horizontal force |u| <= u_max.  The
whole MPCC (the floor's gap ⟂ its forces, the friction's slips ⟂ the cone) is one program; the answer is
certified by marching its controls with the contact march.  Closed form (castrajectory.models.block_push): the
optimum slides for τ = min(T, τ*), τ* = √(6d/(μg)), and sticks the rest of the horizon, at the cost
J* = 12m²d²/τ³ + (μmg)²τ; while it slides the whole horizon the midpoint optimum on N steps is exactly
(12m²d²/T³)N²/(N²−1) + (μmg)²T.  Launched at v0 > 0 the slide starts at once and its duration is the positive
root of (μg)²τ⁴ − 4v0²τ² + 24v0dτ − 36d² = 0 (models/block_push.py).  An answer that costs more than J* by 5 % (or
ten times its own estimate from the coarser grid) is another local optimum, and fails (Worse_Local_Optimum).

    python problems/block_push.py
    python problems/block_push.py --T 2 --n 160 --json          # sticks for T − τ* = 0.57 s
    python problems/block_push.py --T 2 --v0 0.7 --n 40         # launched: stops at τ* = 1.21 s
"""
import sys

import numpy as np

from castrajectory import cli
from castrajectory.models.block_push import BlockPush, pushed_particle
from castrajectory.solve.optimal_control import OptimalControl
from castrajectory.validation import InputError


def parser():
    p = cli.scene_parser("block_push.py", __doc__.splitlines()[0])
    p.add_argument("--distance", type=float, default=1.0, help="distance d in m")
    p.add_argument("--T", type=float, default=1.0, help="horizon T in s (> 0)")
    p.add_argument("--mass", type=float, default=1.0, help="mass m (> 0)")
    p.add_argument("--mu", type=float, default=0.3, help="friction coefficient μ (> 0)")
    p.add_argument("--g", type=float, default=9.81, help="gravity (> 0)")
    p.add_argument("--u-max", type=float, default=20.0, help="bound on the force |u| (> 0)")
    p.add_argument("--v0", type=float, default=0.0, help="initial velocity toward the target (>= 0; 0: from rest)")
    p.add_argument("--n", type=int, default=40, help="number of time steps N (>= 2)")
    cli.add_scheme(p)
    cli.add_plot(p)
    p.add_argument("--animate", metavar="PATH", help="write an animation (.gif, or .mp4 when ffmpeg is present)")
    return p


def problem(d, T, m, mu, g, u_max, n, scheme="midpoint", v0=0.0):
    """The block on its floor and its optimal-control problem (launched at ``v0``)."""
    system = pushed_particle(m, mu, g, u_max)
    u = system.controls[0]
    ocp = OptimalControl(system, T=T, N=n, scheme=scheme)
    ocp.initial(q=[0.0, 0.0], qd=[v0, 0.0])
    ocp.final(q=[d, 0.0], qd=[0.0, 0.0])
    ocp.minimize(running=u ** 2)
    return system, ocp


def run(args):
    cli.finite_flags(args, "distance", "T", "mass", "mu", "g", "u_max", "v0")
    if args.v0 < 0 or (args.v0 > 0 and args.distance <= 0):
        raise InputError(f"--v0 must be >= 0, toward a positive --distance (got {args.v0:g}, {args.distance:g})")
    for flag in ("T", "mass", "mu", "g", "u_max"):
        if getattr(args, flag) <= 0:
            raise InputError(f"--{flag.replace('_', '-')} must be positive (got {getattr(args, flag):g})")
    cli.check_animation_path(args.animate)
    d, T, m, mu, g, N = args.distance, args.T, args.mass, args.mu, args.g, args.n
    exact = BlockPush(m, mu, d, T, g, args.u_max, args.v0)
    system, ocp = problem(d, T, m, mu, g, args.u_max, N, args.scheme, args.v0)
    sol = ocp.solve(options=cli.ipopt_options(args), verbose=args.verbose)
    rest = np.abs(sol.v[:, 0]) <= 1e-9 * max(1.0, float(np.max(np.abs(sol.v[:, 0]))))
    stuck = float(np.sum(rest[:-1] & rest[1:])) * T / N          # the steps at rest at both ends
    JN = exact.discrete_cost(N) if args.scheme == "midpoint" else float("nan")
    lines = [f"closed form: slides {exact.slide:.6g} s of {T:g} (τ* = {'√(6d/(μg)) = ' if not args.v0 else ''}"
             f"{exact.free_slide:.6g} s), "
             f"J* = {exact.cost:.12g}; J − J* = {sol.cost - exact.cost:.2e}"
             + (f"; the midpoint optimum on N steps {JN:.12g}, J − J_N = {sol.cost - JN:.2e}" if JN == JN else ""),
             f"the answer is at rest for {stuck:.4g} s (the closed form: {T - exact.slide:.4g} s); complementarity "
             f"{sol.complementarity:.1e}"]
    # (the closed form is the problem's optimum where its force stays within the bound and its slide goes forward: an
    # answer that costs clearly more is another local optimum -- the launched block that stops, sticks and slides
    # again, 16.3 where J* = 9.02 -- and no answer to this problem; "clearly": 5 % of J*, or 10 times the cost's own
    # estimate from the coarser grid)
    excess = sol.cost - exact.cost
    est = getattr(sol, "cost_estimate", float("nan"))
    if sol.success and exact.bound_inactive and exact.slides_forward and \
            excess > max(0.05 * abs(exact.cost), 10 * est if est == est else 0.0):
        sol.fail("Worse_Local_Optimum", f"the answer costs {sol.cost:.6g}, {excess:.3g} above the closed form's optimum "
                                        f"J* = {exact.cost:.6g}: a local optimum of the discrete problem, not the "
                                        "problem's (start from a guess nearer the closed form's motion, or another N)")
    if not exact.slides_forward:
        lines.append("the closed form's slide turns back inside it: it is not this problem's optimum")
    if not exact.bound_inactive:
        lines.append(f"the closed form's peak force {exact.peak_force:.4g} exceeds --u-max: it is not this "
                     f"problem's optimum")
    extra = {**exact.as_dict(), "error_vs_exact": abs(sol.cost - exact.cost), "discrete_optimum": JN,
             "stuck_time": stuck, "complementarity": sol.complementarity}
    return cli.control_outcome("block push", system, sol, extra=extra, extra_lines=lines, exact_u=exact.control)


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
