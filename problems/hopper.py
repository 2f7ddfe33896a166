"""Hopper: nosnoc's hopping robot (a body on a telescopic leg, Coulomb friction at the foot) tracks a hop to a goal,
contact-implicit, against nosnoc's own solution (scripts/bench_contact_ocp.py --hopper).

The model is castrajectory.models.hopper, the problem nosnoc's hopper_ocp (problem() below: T = 1.5, goal x = 0.7,
the staged parabolic reference, the tracking weights, the bounds 0.1 <= l <= 0.5), its answer certified by the
contact march of its controls.  nosnoc's stance is no-slip, this one Coulomb's: the foot may slide.  At the
defaults (N = 40) the answer is certified; other goals and grids are not all (#27's note): an answer that is not
is reported as a failure, exit 1, with the certificate's distance.

    python problems/hopper.py
    python problems/hopper.py --goal 0.5 --n 40 --animate hopper.gif
"""
import sys

import casadi as ca
import numpy as np

from castrajectory import cli
from castrajectory.models import hopper as model
from castrajectory.solve.optimal_control import OptimalControl
from castrajectory.validation import InputError


def parser():
    p = cli.scene_parser("hopper.py", __doc__.splitlines()[0])
    p.add_argument("--goal", type=float, default=0.7, help="the reference's end x in m (> 0.1)")
    p.add_argument("--T", type=float, default=1.5, help="horizon T in s (> 0)")
    p.add_argument("--mu", type=float, default=model.MU, help="friction coefficient at the foot (>= 0)")
    p.add_argument("--n", type=int, default=40, help="number of time steps N (a multiple of 20 keeps each step in one "
                                                     "stage of the reference)")
    cli.add_scheme(p)
    cli.add_plot(p)
    p.add_argument("--animate", metavar="PATH", help="write an animation (.gif, or .mp4 when ffmpeg is present)")
    return p


def problem(goal: float = 0.7, T: float = 1.5, N: int = 40, scheme: str = "midpoint", mu: float = model.MU):
    """nosnoc's hopper optimal-control problem (castrajectory.models.hopper's doc) as an OptimalControl, with its
    controls' guess (``ocp.guess``: the leg holding the body, u = (0, (m_b + m_l) g)); ``N`` a multiple of the
    reference's 20 stages keeps each step inside one stage."""
    system = model.hopper(mu)
    q, qd, u = system.q, system.qd, system.controls[0]
    zref, ze = model.reference(goal, T)
    dz = ca.vertcat(q, qd) - zref(system.t)
    running = ca.dot(ca.DM(model.Q_RUN) * dz, dz) + ca.dot(ca.DM(model.R_RUN) * u, u)
    dze = ca.vertcat(q, qd) - ca.DM(ze)
    ocp = OptimalControl(system, T=T, N=N, scheme=scheme)
    ocp.initial(q=list(model.START), qd=[0.0] * 4)
    ocp.minimize(running=running, final=ca.dot(ca.DM(model.Q_END) * dze, dze))
    ocp.subject_to(0 <= q[0], q[0] <= goal + 0.1, 0 <= q[1], q[1] <= 1.5, -np.pi <= q[2], q[2] <= np.pi,
                   0.1 <= q[3], q[3] <= 0.5)
    ocp.guess = {"u": np.tile([0.0, (model.MB + model.ML) * model.G], (N, 1))}
    return ocp


def run(args):
    cli.finite_flags(args, "goal", "T", "mu")
    if args.goal <= 0.1 or args.T <= 0 or args.mu < 0:
        raise InputError("--goal must be above 0.1, --T positive and --mu >= 0")
    cli.check_animation_path(args.animate)
    ocp = problem(goal=args.goal, T=args.T, N=args.n, scheme=args.scheme, mu=args.mu)
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
