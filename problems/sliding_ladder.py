"""Sliding ladder: a rod slides down a frictionless wall on a frictionless floor and leaves the wall, against the
closed form.

A uniform rod (length L, mass m) leans against the wall at the angle θ₀ from the floor and is let go from rest.
While both ends touch it has one degree of freedom, θ̈ = −(3g / 2L) cos θ; the wall's force vanishes and the top
leaves the wall when sin θ* = (2/3) sin θ₀, at the time t* = ∫ dθ/θ̇ (``models.held.ladder_lift_off``).  Both contacts
are held at the scheme's stages, and the lift-off is timed inside its step, where the wall's force of the continuous
motion reaches zero (docs/derivations.md, "Contact trajectories", §7): the angle before the lift-off and the
lift-off's time converge at the scheme's order.

    python problems/sliding_ladder.py
    python problems/sliding_ladder.py --theta0 1.4 --scheme galerkin6 --n 20 --json
"""
import math
import sys

import numpy as np

from castrajectory import cli
from castrajectory.inspect import plotting
from castrajectory.models import held
from castrajectory.solve import trajectory
from castrajectory.validation import InputError


def parser():
    p = cli.scene_parser("sliding_ladder.py", __doc__.splitlines()[0])
    p.add_argument("--theta0", type=float, default=math.radians(70.0),
                   help="the start's angle from the floor θ₀ in rad, in (0, pi/2) (default 70°)")
    p.add_argument("--length", type=float, default=1.0, help="the rod's length L (> 0)")
    p.add_argument("--mass", type=float, default=1.0, help="mass m (> 0)")
    p.add_argument("--g", type=float, default=9.81, help="gravity (> 0)")
    p.add_argument("--T", type=float, default=0.5, help="duration T in s (> 0)")
    p.add_argument("--n", type=int, default=50, help="number of time steps N (>= 2)")
    cli.add_scheme(p, default="galerkin4")
    cli.add_accuracy(p)
    cli.add_plot(p)
    p.add_argument("--animate", metavar="PATH", help="write an animation (.gif, or .mp4 when ffmpeg is present)")
    return p


def run(args):
    cli.check_animation_path(args.animate)
    cli.finite_flags(args, "theta0", "length", "mass", "g", "T")
    if not 0 < args.theta0 < math.pi / 2:
        raise InputError(f"--theta0 must lie in (0, pi/2) rad (got {args.theta0:g})")
    for flag in ("length", "mass", "g", "T"):
        if getattr(args, flag) <= 0:
            raise InputError(f"--{flag} must be positive (got {getattr(args, flag):g})")
    system = held.sliding_ladder(args.mass, args.length, args.g)
    q0, qd0 = held.ladder_start(args.theta0, args.length)
    tr = trajectory.solve_initial_value(system, q0, qd0, args.T, args.n, args.scheme, options=cli.ipopt_options(args),
                                        verbose=args.verbose, **cli.accuracy(args))
    t_star, th_star = held.ladder_lift_off(args.theta0, args.length, args.g)
    lifts = [r for r in tr.releases if r.contact == 0]
    lift = lifts[0].t if lifts else None
    before = tr.t < t_star
    theta_ref = held.ladder_angle(tr.t[before], args.theta0, args.length, args.g)
    theta_err = float(np.max(np.abs(tr.q[before, 2] - theta_ref))) if np.any(before) else float("nan")
    data = {"lift_off_time": lift, "lift_off_time_exact": t_star if t_star <= args.T else None,
            "lift_off_error": None if lift is None or t_star > args.T else abs(lift - t_star),
            "lift_off_timed": bool(lifts and lifts[0].timed), "lift_off_angle_exact": th_star,
            "theta_error": theta_err, "energy": tr.energy}
    lines = [f"sliding ladder: θ₀ = {args.theta0:.6g} rad, L = {args.length:g} m, scheme {args.scheme}, N = {args.n}, "
             f"T = {args.T:g} s",
             f"lift-off from the wall at t = {cli.fmt(lift, '.12g')} s (exact {t_star:.12g} s"
             + (f", error {abs(lift - t_star):.2e} s" if lift is not None else "") + ")"
             + (" timed in its step" if data["lift_off_timed"] else ""),
             f"θ before the lift-off: max |θ − θ_exact| = {theta_err:.2e} rad",
             *cli.interval_lines(system, tr),
             cli.status_line(tr.status, tr)]

    def plot(path):
        fig = plotting.contact_plot(tr.t, {"θ (discrete)": tr.q[:, 2], "wall gap": tr.gap[:, 0]}, tr.t,
                                    tr.node_impulse[:, 0], reference={"θ exact (held)": (tr.t[before], theta_ref)},
                                    ylabel="θ (rad), gap (m)", title="sliding ladder: the wall's impulses below",
                                    intervals=cli.contact_intervals(system, tr))
        fig.savefig(path)

    def animate(path):
        wall = np.array([[0.0, 1.1 * args.length], [0.0, 0.0], [1.1 * args.length, 0.0]])
        plotting.animate_points(system.positions(tr.q), tr.t, path, links=True, pivot=None, trail=False, ground=wall,
                                title="sliding ladder")

    return cli.Outcome.of(tr, {**cli.state_keys(system, tr), **data}, lines, writers={"plot": plot, "animate": animate})


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
