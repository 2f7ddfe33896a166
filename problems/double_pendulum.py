"""Double pendulum by least action over the whole trajectory (Exercise 2.3).

Two point masses on massless rods, angles from the downward vertical.  The
default start, θ = (2, 1) rad at rest over T = 10 s, is chaotic: the default grid,
galerkin4 on 16000 steps, resolves it to about 1e-7 of its excursion, where midpoint
on 2000 steps is 8 rad off and says so (``Not_Resolved``, exit 1).  The library's
method (``--method whole``) solves every discrete Euler–Lagrange equation of
the trajectory in one Ipopt NLP; ``march``, ``rk4`` and ``implicit-euler`` are
time-stepping baselines for comparison.

    python problems/double_pendulum.py
    python problems/double_pendulum.py --scheme galerkin4 --T 5 --n 4000 --json
    python problems/double_pendulum.py --animate dp.gif --plot energy.png
"""
import sys

from castrajectory import cli
from castrajectory.inspect import plotting
from castrajectory.models import pendulum
from castrajectory.solve import simulate


def parser():
    p = cli.scene_parser("double_pendulum.py", __doc__.splitlines()[0])
    p.add_argument("--theta1", type=float, default=2.0, help="initial angle of link 1 (rad)")
    p.add_argument("--theta2", type=float, default=1.0, help="initial angle of link 2 (rad)")
    p.add_argument("--omega1", type=float, default=0.0, help="initial angular velocity of link 1 (rad/s)")
    p.add_argument("--omega2", type=float, default=0.0, help="initial angular velocity of link 2 (rad/s)")
    p.add_argument("--m1", type=float, default=1.0, help="mass 1 (> 0)")
    p.add_argument("--m2", type=float, default=1.0, help="mass 2 (> 0)")
    p.add_argument("--l1", type=float, default=1.0, help="length of link 1 (> 0)")
    p.add_argument("--l2", type=float, default=1.0, help="length of link 2 (> 0)")
    p.add_argument("--g", type=float, default=9.81, help="gravity (0 drops the gravity term)")
    cli.add_trajectory_flags(p, T=10.0, n=16000, scheme="galerkin4")
    return p


def run(args):
    cli.check_animation_path(args.animate)
    # describe
    system = pendulum.double_pendulum(args.m1, args.m2, args.l1, args.l2, args.g)
    # discretise + solve
    res = simulate.simulate(system, [args.theta1, args.theta2], [args.omega1, args.omega2], args.T, args.n,
                            args.scheme, args.method, options=cli.ipopt_options(args), verbose=args.verbose,
                            **cli.accuracy(args))
    # inspect
    out = cli.trajectory_outcome("double pendulum", system, res)
    out.writers["plot"] = lambda path: figure(out, system).savefig(path)
    return out


def figure(out, system=None):
    """The --plot picture: both angles against time over the energy error and, with the ``system``, the
    bobs' paths in the plane."""
    d = out.data
    how = f"{d['method']}" + (f", {d['scheme']}" if d["scheme"] else "")
    return plotting.trajectory_plot(d["t"], d["q"], ["θ1", "θ2"], panels=[("angle (rad)", [0, 1])],
                                    energies={how: d["energy"]}, title=f"double pendulum ({how}): angles",
                                    plane=None if system is None else system.positions(d["q"]))


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
