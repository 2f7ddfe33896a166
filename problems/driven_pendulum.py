"""Damped, driven pendulum over the whole trajectory (Lagrange–d'Alembert): the route to chaos.

``θ̈ + γθ̇ + ω₀² sin θ = A cos(Ωt)``: the pendulum's Lagrangian, the Rayleigh damping ``½γθ̇²`` and the
drive as a time-dependent force.  The defaults (ω₀ = 1, γ = 0.5, Ω = 2/3, A = 1.2) are the classic
chaotic regime; ``--plot`` draws θ(t) and the Poincaré section, the state sampled once per drive
period (a long run, e.g. ``--T 3000 --n 60000``, draws the strange attractor).

    python problems/driven_pendulum.py
    python problems/driven_pendulum.py --T 3000 --n 60000 --scheme galerkin4 --plot attractor.png
    python problems/driven_pendulum.py --amplitude 0.9 --json
"""
import math
import sys

from castrajectory import cli
from castrajectory.inspect import plotting
from castrajectory.models import pendulum
from castrajectory.validation import InputError


def parser():
    p = cli.scene_parser("driven_pendulum.py", __doc__.splitlines()[0])
    p.add_argument("--gamma", type=float, default=0.5, help="damping rate γ (>= 0; 0 drops the term)")
    p.add_argument("--omega0", type=float, default=1.0, help="natural frequency ω₀ (0 drops gravity)")
    p.add_argument("--amplitude", type=float, default=1.2, help="drive amplitude A (0 drops the drive)")
    p.add_argument("--drive-frequency", type=float, default=2.0 / 3.0, help="drive angular frequency Ω (> 0)")
    p.add_argument("--theta0", type=float, default=0.0, help="initial angle (rad)")
    p.add_argument("--omega", type=float, default=0.0, help="initial angular velocity (rad/s)")
    cli.add_trajectory_flags(p, T=20.0, n=2000, scheme="galerkin4")
    return p


def check(args):
    cli.finite_flags(args, "gamma", "omega0", "amplitude", "drive_frequency", "theta0", "omega")
    if args.gamma < 0:
        raise InputError(f"--gamma must not be negative (got {args.gamma:g}): a negative damping feeds energy in")
    if args.drive_frequency <= 0:
        raise InputError(f"--drive-frequency must be positive (got {args.drive_frequency:g})")


def run(args):
    check(args)
    cli.check_animation_path(args.animate)
    system = pendulum.driven_pendulum(args.gamma, args.omega0, args.amplitude, args.drive_frequency)
    res = cli.solve_trajectory(system, [args.theta0], [args.omega], args)
    period = 2 * math.pi / args.drive_frequency
    ts, x, v = plotting.poincare_section(res.t, res.q[:, 0], res.v[:, 0], period)
    lines = [f"drive period {period:.6g} s: {ts.size} Poincaré points (θ mod 2π, θ̇) in the run"]
    out = cli.trajectory_outcome("driven pendulum", system, res, extra={
        "drive_period": period, "poincare_t": ts, "poincare_theta": x, "poincare_omega": v}, extra_lines=lines)
    out.writers["plot"] = lambda path: plotting.poincare_plot(
        res.t, res.q[:, 0], res.v[:, 0], period, skip=min(10, ts.size // 10),
        title=f"driven pendulum: γ = {args.gamma:g}, ω₀ = {args.omega0:g}, A = {args.amplitude:g}, "
              f"Ω = {args.drive_frequency:.4g} ({res.scheme}, N = {len(res.t) - 1})").savefig(path)
    return out


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
