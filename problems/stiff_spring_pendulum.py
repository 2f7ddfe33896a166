"""Stiff elastic pendulum: a point mass on a linear spring, solved over the whole trajectory.

The stiffness ratio ``k l0 / (m g)`` sets how stiff the spring is against
gravity (up to 1e6 and beyond).  The radial oscillation has period
``2π √(m/k)``; with a step far longer than that, the variational schemes
stay stable and keep the energy bounded, while explicit RK4 blows up.

    python problems/stiff_spring_pendulum.py --ratio 1e6
    python problems/stiff_spring_pendulum.py --ratio 1e6 --method rk4     # the explicit baseline fails
"""
import math
import sys

from castrajectory import cli
from castrajectory.inspect import plotting
from castrajectory.models import pendulum
from castrajectory.solve import simulate
from castrajectory.validation import InputError, finite, positive


def parser():
    p = cli.scene_parser("stiff_spring_pendulum.py", __doc__.splitlines()[0])
    p.add_argument("--mass", type=float, default=1.0, help="mass (> 0)")
    p.add_argument("--rest", type=float, default=1.0, help="spring rest length l0 (> 0)")
    p.add_argument("--ratio", type=float, default=1e4, help="stiffness ratio k l0 / (m g) (> 0)")
    p.add_argument("--g", type=float, default=9.81, help="gravity (> 0: the ratio is relative to it)")
    p.add_argument("--theta", type=float, default=1.0, help="initial angle from the downward vertical (rad)")
    p.add_argument("--stretch", type=float, default=1e-3, help="initial extra stretch of the spring, relative")
    cli.add_trajectory_flags(p, T=5.0, n=1000)
    return p


def run(args):
    cli.check_animation_path(args.animate)
    positive("g", args.g)
    positive("ratio", args.ratio)
    k = args.ratio * positive("mass", args.mass) * args.g / positive("rest", args.rest)
    system = pendulum.spring_pendulum(args.mass, args.rest, k, args.g)
    # start at the static stretch under gravity (plus a small extra stretch) at rest
    r0 = args.rest * (1 + math.cos(args.theta) / args.ratio + finite("stretch", args.stretch))
    if not r0 > 0.0:
        raise InputError(f"the initial spring length rest × (1 + cos θ/ratio + stretch) = {r0:.3g} must be positive")
    res = simulate.simulate(system, [r0, args.theta], [0.0, 0.0], args.T, args.n, args.scheme, args.method,
                            options=cli.ipopt_options(args), verbose=args.verbose,
                            **cli.accuracy(args))
    period = 2 * math.pi * math.sqrt(args.mass / k)
    h = args.T / args.n
    lines = [f"stiffness k = {k:.6g} (ratio {args.ratio:g}); radial period {period:.3e} s, "
             f"step h = {h:.3e} s (h ω = {2 * math.pi * h / period:.3g})"]
    out = cli.trajectory_outcome("stiff spring pendulum", system, res,
                                 extra={"stiffness": k, "radial_period": period}, extra_lines=lines)
    out.writers["plot"] = lambda path: figure(out).savefig(path)
    return out


def figure(out):
    """The --plot picture: the angle and the spring length against time (q = (r, θ)) over the energy error."""
    d = out.data
    how = f"{d['method']}" + (f", {d['scheme']}" if d["scheme"] else "")
    return plotting.trajectory_plot(d["t"], d["q"], ["r", "θ"], panels=[("angle (rad)", [1]), ("length r", [0])],
                                    energies={how: d["energy"]}, title=f"stiff spring pendulum ({how})")


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
