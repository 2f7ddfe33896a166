"""Thrown ball by least action proper: the two-point boundary problem.

A point mass leaves (0, 0) and must be at (distance, height) after time T.
Ipopt minimises the discrete action with both ends fixed; the answer is
compared with the analytic parabola ``x(t) = x0 + (x1 - x0) t/T``,
``y(t) = y0 + (y1 - y0) t/T + g t (T - t) / 2`` and its launch velocity.

    python problems/thrown_ball.py --distance 10 --height 2 --T 1.5
"""
import sys

import numpy as np

from castrajectory import cli
from castrajectory.inspect import plotting
from castrajectory.models import pendulum
from castrajectory.solve import trajectory


def parser():
    p = cli.scene_parser("thrown_ball.py", __doc__.splitlines()[0])
    p.add_argument("--distance", type=float, default=10.0, help="horizontal distance to the target")
    p.add_argument("--height", type=float, default=2.0, help="height of the target")
    p.add_argument("--mass", type=float, default=0.5, help="mass (> 0)")
    p.add_argument("--g", type=float, default=9.81, help="gravity (0 drops the gravity term)")
    cli.add_trajectory_flags(p, T=1.5, n=200, methods=False)
    return p


def parabola(t, x1, y1, T, g):
    """Analytic free flight from (0, 0) to (x1, y1) in time T."""
    return np.stack([x1 * t / T, y1 * t / T + g * t * (T - t) / 2], axis=1)


def run(args):
    cli.check_animation_path(args.animate)
    system = pendulum.point_mass(args.mass, args.g)
    traj = trajectory.solve_boundary(system, [0.0, 0.0], [args.distance, args.height], args.T, args.n,
                                     args.scheme, options=cli.ipopt_options(args), verbose=args.verbose)
    exact = parabola(traj.t, args.distance, args.height, traj.t[-1], args.g)
    v0_exact = np.array([args.distance / args.T, args.height / args.T + args.g * args.T / 2])
    err = float(np.max(np.abs(traj.q - exact)))
    v0_err = float(np.max(np.abs(traj.v[0] - v0_exact)))
    traj.method = "whole (boundary)"
    lines = [f"max |q - parabola| over the nodes = {err:.3e}",
             f"launch velocity {np.round(traj.v[0], 10).tolist()} (analytic {np.round(v0_exact, 10).tolist()}), "
             f"error {v0_err:.3e}"]
    extra = {"parabola_error": err, "launch_velocity": traj.v[0], "launch_velocity_exact": v0_exact,
             "launch_velocity_error": v0_err, "action": traj.action}
    out = cli.trajectory_outcome("thrown ball", system, traj, extra=extra, extra_lines=lines, links=False)
    out.writers["plot"] = lambda path: figure(out, args).savefig(path)
    return out


def figure(out, args):
    """The --plot picture: the computed path (the nodes) over the analytic parabola at the same times."""
    t, q = np.asarray(out.data["t"], float), np.asarray(out.data["q"], float)
    return plotting.path_plot(q, parabola(t, args.distance, args.height, t[-1], args.g),
                              label=f"least action ({out.data['scheme']}, N = {len(t) - 1})",
                              reference_label="analytic parabola",
                              title=f"thrown ball: to ({args.distance:g}, {args.height:g}) in T = {t[-1]:g} s, "
                                    f"g = {args.g:g}")


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
