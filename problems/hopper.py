"""Hopper: nosnoc's hopping robot (a body on a telescopic leg, Coulomb friction at the foot) tracks a hop to a goal,
contact-implicit, against nosnoc's own solution (scripts/bench_contact_ocp.py --hopper).

The model and the problem are castrajectory.models.hopper (nosnoc's hopper_ocp: T = 1.5, goal x = 0.7, the staged
parabolic reference, the tracking weights, the bounds 0.1 <= l <= 0.5).  Not yet certified: the answer's stance
slides and its slip reverses inside steps, which the contact march times at a sub-node (its mode W) and the program
does not, so the march of the answer's controls departs from it; the run then exits 1 with the certificate's
distance.  nosnoc's stance is no-slip, this one Coulomb's.

    python problems/hopper.py
    python problems/hopper.py --goal 0.5 --n 40 --animate hopper.gif
"""
import sys

import numpy as np

from castrajectory import cli
from castrajectory.models import hopper as model
from castrajectory.validation import InputError


def parser():
    p = cli.scene_parser("hopper.py", __doc__.splitlines()[0])
    p.add_argument("--goal", type=float, default=0.7, help="the reference's end x in m (> 0.1)")
    p.add_argument("--T", type=float, default=1.5, help="horizon T in s (> 0)")
    p.add_argument("--mu", type=float, default=model.MU, help="friction coefficient at the foot (>= 0)")
    p.add_argument("--n", type=int, default=60, help="number of time steps N (a multiple of 20 keeps each step in one "
                                                     "stage of the reference)")
    cli.add_scheme(p)
    cli.add_plot(p)
    p.add_argument("--animate", metavar="PATH", help="write an animation (.gif, or .mp4 when ffmpeg is present)")
    return p


def run(args):
    cli.finite_flags(args, "goal", "T", "mu")
    if args.goal <= 0.1 or args.T <= 0 or args.mu < 0:
        raise InputError("--goal must be above 0.1, --T positive and --mu >= 0")
    cli.check_animation_path(args.animate)
    ocp = model.problem(goal=args.goal, T=args.T, N=args.n, scheme=args.scheme, mu=args.mu)
    sol = ocp.solve(guess=ocp.guess, options=cli.ipopt_options(args), verbose=args.verbose)
    imp = sol.impact_times[0] if sol.impact_times else []
    lines = [f"end x = {sol.q[-1, 0]:.6g} (goal {args.goal:g}); {len(imp)} landing(s) at "
             + ", ".join(f"{t:.4g}" for t in imp) + f" s; leg length in [{np.min(sol.q[:, 3]):.3g}, "
             f"{np.max(sol.q[:, 3]):.3g}]; complementarity {sol.complementarity:.1e}"]
    extra = {"end_x": float(sol.q[-1, 0]), "impact_times": imp, "complementarity": sol.complementarity}
    return cli.control_outcome("hopper", ocp.system, sol, extra=extra, extra_lines=lines)


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
