"""N-link pendulum by least action over the whole trajectory.

A planar chain of equal point masses on equal massless rods, released at rest
with every link at the same angle from the downward vertical.

    python problems/n_link_pendulum.py --links 5 --animate chain.gif
"""
import sys

from castrajectory import cli
from castrajectory.inspect import plotting
from castrajectory.models import pendulum
from castrajectory.solve import simulate
from castrajectory.validation import InputError, integer_at_least


def parser():
    p = cli.scene_parser("n_link_pendulum.py", __doc__.splitlines()[0])
    p.add_argument("--links", type=int, default=4, help="number of links (>= 1)")
    p.add_argument("--mass", type=float, default=1.0, help="mass of each bob (> 0)")
    p.add_argument("--length", type=float, default=1.0, help="length of each link (> 0)")
    p.add_argument("--theta", type=float, default=1.5, help="initial angle of every link (rad)")
    p.add_argument("--g", type=float, default=9.81, help="gravity (0 drops the gravity term)")
    cli.add_trajectory_flags(p, T=5.0, n=2000)
    return p


#: Time to build and solve a short run grows as links^2.7 (measured: 0.64 s, 1.9 s and 12.1 s for 10, 20
#: and 40 links at n = 50; 0.10, 0.17 and 0.88 GB): more links than this are refused.
MAX_LINKS = 170


def run(args):
    cli.check_animation_path(args.animate)
    k = integer_at_least("links", args.links, 1)
    if k > MAX_LINKS:
        est = 12.1 * (k / 40.0) ** 2.7
        raise InputError(f"--links {k} would take about {est / 3600:.2g} h to build (12 s for 40 links, growing as "
                         f"links^2.7, measured); at most {MAX_LINKS} links (about 10 min)")
    system = pendulum.n_link_pendulum([args.mass] * k, [args.length] * k, args.g)
    res = simulate.simulate(system, [args.theta] * k, [0.0] * k, args.T, args.n, args.scheme, args.method,
                            options=cli.ipopt_options(args), verbose=args.verbose,
                            **cli.accuracy(args))
    out = cli.trajectory_outcome(f"{k}-link pendulum", system, res, extra={"links": k})
    out.writers["plot"] = lambda path: figure(out, system).savefig(path)
    return out


def figure(out, system=None):
    """The --plot picture: every link's angle against time over the energy error and, with the ``system``,
    the bobs' paths in the plane."""
    d = out.data
    k = d["links"]
    how = f"{d['method']}" + (f", {d['scheme']}" if d["scheme"] else "")
    return plotting.trajectory_plot(d["t"], d["q"], [f"θ{i + 1}" for i in range(k)],
                                    panels=[("angle (rad)", range(k))], energies={how: d["energy"]},
                                    title=f"{k}-link pendulum ({how}): angles",
                                    plane=None if system is None else system.positions(d["q"]))


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
