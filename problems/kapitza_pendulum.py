"""Kapitza's pendulum over the whole trajectory: a pivot driven up and down holds the pendulum inverted.

The pivot moves as ``(0, a cos(ωt))``: an atom position that holds the time, so the Lagrangian does.
Averaged over the fast drive, the inverted position θ = π is stable when ``a²ω² > 2 g l``
(Landau–Lifshitz, Mechanics §30); the run starts near it at rest and reports whether the pendulum
stayed up, beside that prediction.

    python problems/kapitza_pendulum.py                      # a²ω²/2gl = 5.1: stays up
    python problems/kapitza_pendulum.py --frequency 35       # 0.62: falls
    python problems/kapitza_pendulum.py --animate kapitza.gif
"""
import sys

import numpy as np

from castrajectory import cli
from castrajectory.models import pendulum
from castrajectory.validation import InputError

#: "stayed up": the angle never left π by more than this (rad) -- a fall swings through π/2 at least
UP = 1.0


def parser():
    p = cli.scene_parser("kapitza_pendulum.py", __doc__.splitlines()[0])
    p.add_argument("--length", type=float, default=1.0, help="rod length l (> 0)")
    p.add_argument("--g", type=float, default=9.81, help="gravity (0 drops the gravity term)")
    p.add_argument("--amplitude", type=float, default=0.1, help="pivot amplitude a")
    p.add_argument("--frequency", type=float, default=100.0, help="pivot angular frequency ω (rad/s)")
    p.add_argument("--theta0", type=float, default=float(np.pi) - 0.2, help="initial angle from the downward vertical (rad)")
    p.add_argument("--omega", type=float, default=0.0, help="initial angular velocity (rad/s)")
    cli.add_trajectory_flags(p, T=5.0, n=2000, scheme="galerkin4")
    return p


def check(args):
    cli.finite_flags(args, "length", "g", "amplitude", "frequency", "theta0", "omega")
    if args.length <= 0:
        raise InputError(f"--length must be positive (got {args.length:g})")


def run(args):
    check(args)
    cli.check_animation_path(args.animate)
    system = pendulum.kapitza_pendulum(args.length, args.g, args.amplitude, args.frequency)
    res = cli.solve_trajectory(system, [args.theta0], [args.omega], args)
    ratio = pendulum.kapitza_threshold(args.length, args.g, args.amplitude, args.frequency) if args.g > 0 else float("inf")
    dev = float(np.max(np.abs(res.q[:, 0] - np.pi))) if res.success else float("nan")
    stayed = bool(dev < UP)
    lines = [f"a²ω²/(2gl) = {ratio:.4g}: the inverted position is {'stable' if ratio > 1 else 'unstable'} by the "
             f"averaged theory; the pendulum {'stayed up' if stayed else 'fell'} (max |θ − π| = {dev:.3g} rad)"]
    extra = {"stability_ratio": ratio, "inverted_stable_predicted": bool(ratio > 1), "stayed_up": stayed,
             "max_deviation_from_inverted": dev}
    return cli.trajectory_outcome("Kapitza pendulum", system, res, extra=extra, extra_lines=lines)


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
