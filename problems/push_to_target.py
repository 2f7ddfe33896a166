"""Push to a target: a particle falls onto a floor with friction and is pushed along it to a target, at rest at
T, minimising ∫u² dt (nosnoc's inelastic 2-D optimal-control example), contact-implicit and certified.

A unit point mass starts at rest at (0, y0) above the floor y >= 0 (inelastic: restitution 0; Coulomb friction μ)
and a horizontal force |u| <= u_max brings it to (goal, 0) at rest at T.  The optimum pushes at the bound while
the particle falls (no friction in the air), slides after it lands and may stick before T.  The whole MPCC is one
program; the answer is certified by marching its controls with the contact march.  Oracles: the landing is the
free fall's, √(2 y0/g), whatever the push (exact on the midpoint rule: constant acceleration); the cost converges
at second order (its estimate: the ladder's previous grid), and the benchmark (scripts/bench_contact_ocp.py)
compares it with nosnoc's in the same run.

    python problems/push_to_target.py
    python problems/push_to_target.py --n 160 --json
"""
import math
import sys

import numpy as np

from castrajectory import cli
from castrajectory.models.block_push import pushed_particle
from castrajectory.solve.optimal_control import OptimalControl
from castrajectory.validation import InputError


def parser():
    p = cli.scene_parser("push_to_target.py", __doc__.splitlines()[0])
    p.add_argument("--y0", type=float, default=1.5, help="starting height in m (>= 0)")
    p.add_argument("--goal", type=float, default=3.0, help="the target's x in m")
    p.add_argument("--mu", type=float, default=0.6, help="friction coefficient μ (>= 0)")
    p.add_argument("--u-max", type=float, default=10.0, help="bound on the force |u| (> 0)")
    p.add_argument("--T", type=float, default=2.0, help="horizon T in s (> 0)")
    p.add_argument("--g", type=float, default=9.81, help="gravity (> 0)")
    p.add_argument("--n", type=int, default=80, help="number of time steps N (>= 2)")
    cli.add_scheme(p)
    cli.add_plot(p)
    p.add_argument("--animate", metavar="PATH", help="write an animation (.gif, or .mp4 when ffmpeg is present)")
    return p


def problem(y0, goal, mu, u_max, T, g, n, scheme="midpoint"):
    """The particle over its floor and its optimal-control problem."""
    system = pushed_particle(1.0, mu, g, u_max)
    u = system.controls[0]
    ocp = OptimalControl(system, T=T, N=n, scheme=scheme)
    ocp.initial(q=[0.0, y0], qd=[0.0, 0.0])
    ocp.final(q=[goal, 0.0], qd=[0.0, 0.0])
    ocp.minimize(running=u ** 2)
    return system, ocp


def run(args):
    cli.finite_flags(args, "y0", "goal", "mu", "u_max", "T", "g")
    for flag in ("u_max", "T", "g"):
        if getattr(args, flag) <= 0:
            raise InputError(f"--{flag.replace('_', '-')} must be positive (got {getattr(args, flag):g})")
    if args.y0 < 0 or args.mu < 0:
        raise InputError("--y0 and --mu must be >= 0")
    cli.check_animation_path(args.animate)
    system, ocp = problem(args.y0, args.goal, args.mu, args.u_max, args.T, args.g, args.n, args.scheme)
    sol = ocp.solve(options=cli.ipopt_options(args), verbose=args.verbose)
    landing = math.sqrt(2.0 * args.y0 / args.g)
    impacts = sol.impact_times[0] if sol.impact_times else []
    land_err = abs(impacts[0] - landing) if impacts else float("nan")
    rest = np.abs(sol.v[:, 0]) <= 1e-9 * max(1.0, float(np.max(np.abs(sol.v[:, 0]))))
    stuck = float(np.sum(rest[:-1] & rest[1:] & (np.abs(sol.q[:-1, 1]) <= 1e-9))) * args.T / args.n
    est = "-" if not np.isfinite(sol.cost_estimate) else f"{sol.cost_estimate:.1e}"
    lines = [f"landing at {impacts[0] if impacts else float('nan'):.12g} s; the free fall's √(2 y0/g) = {landing:.12g} s "
             f"(error {land_err:.1e}); {len(impacts)} impact(s)",
             f"cost's error estimate (the previous grid, order 2) {est}; at rest on the floor {stuck:.4g} s before T; "
             f"complementarity {sol.complementarity:.1e}"]
    extra = {"landing_time": landing, "landing_error": land_err, "stuck_time": stuck,
             "complementarity": sol.complementarity, "cost_estimate": sol.cost_estimate}
    return cli.control_outcome("push to a target", system, sol, extra=extra, extra_lines=lines)


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
