"""Dzhanibekov effect: a free rigid body spun near its intermediate axis flips, by least action.

The orientation is a unit quaternion (norm as a holonomic constraint), the kinetic energy
½ ωᵀ I ω comes from the body's second moments, and the whole trajectory is one
stationary-action problem.  The flips are located between nodes and their interval is
compared with Landau–Lifshitz's 2K(m)/s; the spatial angular momentum from the discrete
Legendre transform is conserved to solver tolerance (discrete Noether).

    python problems/dzhanibekov.py --inertia 1 2 3 --omega 1e-3 1 1e-3 --T 100
    python problems/dzhanibekov.py --box 0.3 1 2 --mass 1 --plot omega.png --animate flip.gif
    python problems/dzhanibekov.py --omega 1e-3 1e-3 1      # near the major axis: stable, no flips
"""
import sys

import numpy as np

from castrajectory import cli
from castrajectory.inspect import rigidbody as readings
from castrajectory.models import rigidbody as rb
from castrajectory.solve import simulate
from castrajectory.validation import InputError, finite


def parser():
    p = cli.scene_parser("dzhanibekov.py", __doc__.splitlines()[0])
    p.add_argument("--inertia", type=float, nargs=3, metavar=("I1", "I2", "I3"), default=None,
                   help="principal moments of inertia (> 0, triangle inequality); default 1 2 3")
    p.add_argument("--box", type=float, nargs=3, metavar=("W", "H", "D"), default=None,
                   help="a uniform box's edges along the body axes, instead of --inertia (with --mass)")
    p.add_argument("--mass", type=float, default=1.0, help="mass of the --box (> 0)")
    p.add_argument("--omega", type=float, nargs=3, metavar=("W1", "W2", "W3"), default=[1e-3, 1.0, 1e-3],
                   help="initial body angular velocity (rad/s), in the order of the moments; not zero")
    cli.add_trajectory_flags(p, T=100.0, n=4000)
    return p


def body(args):
    """The inertia and the box drawn, from --inertia or --box (checked once, here and in Inertia)."""
    if args.inertia is not None and args.box is not None:
        raise InputError("give --inertia or --box, not both")
    if args.box is not None:
        inertia = rb.Inertia.box(*args.box, args.mass)
        return inertia, np.array(args.box, float)
    inertia = rb.Inertia(*(args.inertia if args.inertia is not None else (1.0, 2.0, 3.0)))
    return inertia, rb.equivalent_box(inertia)


def initial_rates(values):
    w = np.array([finite(f"omega {i + 1}", v) for i, v in enumerate(values)])
    if not np.any(w != 0.0):
        raise InputError("omega must not be zero: a body at rest has nothing to flip")
    return w


def run(args):
    cli.check_animation_path(args.animate)
    inertia, size = body(args)
    w0 = initial_rates(args.omega)
    # describe
    system = rb.free_body(inertia, size)
    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    qd0 = rb.quaternion_rate(q0, w0)
    # discretise + solve
    res = simulate.simulate(system, q0, qd0, args.T, args.n, args.scheme, args.method,
                            options=cli.ipopt_options(args), verbose=args.verbose,
                            **cli.accuracy(args))
    # inspect
    r = readings.free_body(system, res, inertia, w0)
    flips, exact = r["flip_times"], r["flip_interval_exact"]
    lines = [f"inertia ({inertia.I1:g}, {inertia.I2:g}, {inertia.I3:g}), ω₀ = {w0.tolist()}, "
             f"spin axis {r['flip_axis'] + 1}",
             f"{flips.size} flips" + (f" at t = {np.round(flips, 4).tolist()[:8]}" if flips.size else
                                      " (a stable spin)" if exact is None else "")]
    if exact is not None:
        measured = "-" if r["flip_interval"] is None else f"{r['flip_interval']:.9g}"
        lines.append(f"flip interval {measured} (analytic 2K(m)/s = {exact:.9g}; error "
                     f"{cli.fmt(r['flip_interval_error'], '.2e')})")
    lines.append(f"spatial angular momentum: max |L - L0|/|L0| = {r['angular_momentum_drift']:.2e}; "
                 f"|q| - 1 at most {r['quaternion_norm_error']:.1e}")
    extra = {"quaternion": res.q, **{k: v for k, v in r.items() if k != "flip_axis"},
             "flip_axis": r["flip_axis"] + 1, "inertia": inertia.moments, "omega0": w0}
    out = cli.trajectory_outcome("Dzhanibekov flip", system, res, extra=extra, extra_lines=lines)

    def plot(path):
        from castrajectory.inspect import plotting
        labels = tuple(f"ω{i + 1} (I{i + 1} = {m:g})" for i, m in enumerate(inertia.moments))
        fig = plotting.rigid_body_rates(res.t, r["omega"], flips, labels, flip_interval_exact=exact,
                                        title=f"Dzhanibekov flip, {res.method}"
                                              + (f" {res.scheme}" if res.scheme else "") + f", N = {args.n}")
        fig.savefig(path)

    def animate(path):
        from castrajectory.inspect import plotting
        plotting.animate_rigid_body(res.t, rb.rotation(res.q), path, size, momentum=r["angular_momentum"][0],
                                    title="Dzhanibekov flip")

    out.writers.update(plot=plot, animate=animate)
    return out


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
