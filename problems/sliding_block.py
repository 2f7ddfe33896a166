"""Sliding block: Coulomb friction on a flat floor or an incline, against the closed forms.

A block (a point mass m) on a plane inclined at ALPHA, s measured up the plane, launched at v0 along it,
friction coefficient μ.  Oracles:

* flat (ALPHA = 0): it stops after v0/(μg), at v0²/(2μg);
* from rest on an incline: it sticks iff tan ALPHA <= μ, else slides down at g(sin ALPHA − μ cos ALPHA);
* launched uphill: it stops after v0/(g(sin ALPHA + μ cos ALPHA)) at v0²/(2g(sin ALPHA + μ cos ALPHA)), then
  sticks if tan ALPHA <= μ, or slides back down at g(sin ALPHA − μ cos ALPHA).

The contact is the plane's gap y >= 0 with its slip velocity ṡ; the friction's stick and slide are modes
of the contact march (docs/derivations.md, "Contact trajectories").  ``stop_time`` is the first node from
which the block stays at rest, timed inside its step from the impulses: the friction impulse until the stop is
μ times the normal impulse over the sliding time (``ContactTrajectory.slip_stops``; ``stop_node_time`` is the
first node at rest).

    python problems/sliding_block.py --mu 0.5 --v0 2
    python problems/sliding_block.py --incline 0.6 --mu 0.5 --v0 2 --json
"""
import math
import sys

import numpy as np

from castrajectory import cli
from castrajectory.inspect import plotting
from castrajectory.models import collision
from castrajectory.models.mechanics import LagrangianSystem
from castrajectory.solve import trajectory
from castrajectory.validation import InputError


def parser():
    p = cli.scene_parser("sliding_block.py", __doc__.splitlines()[0])
    p.add_argument("--mu", type=float, default=0.5, help="friction coefficient (>= 0)")
    p.add_argument("--v0", type=float, default=2.0, help="launch speed along the plane, up the slope positive")
    p.add_argument("--incline", type=float, default=0.0, help="the plane's angle ALPHA in rad, in [0, pi/2)")
    p.add_argument("--mass", type=float, default=1.0, help="mass m (> 0)")
    p.add_argument("--g", type=float, default=9.81, help="gravity (> 0)")
    p.add_argument("--T", type=float, default=1.0, help="duration T in s (> 0)")
    p.add_argument("--n", type=int, default=400, help="number of time steps N (>= 2)")
    cli.add_scheme(p)
    cli.add_accuracy(p)
    cli.add_plot(p)
    p.add_argument("--animate", metavar="PATH", help="write an animation (.gif, or .mp4 when ffmpeg is present)")
    return p


def block(mass, mu, alpha, g) -> LagrangianSystem:
    return collision.sliding_block(mass, mu, alpha, g)


def exact(v0, mu, alpha, g, t):
    return collision.sliding_block_oracle(v0, mu, alpha, g, t)


def run(args):
    cli.check_animation_path(args.animate)
    cli.finite_flags(args, "mu", "v0", "incline", "mass", "g", "T")
    if args.mu < 0:
        raise InputError(f"--mu must be >= 0 (got {args.mu:g})")
    if not 0 <= args.incline < math.pi / 2:
        raise InputError(f"--incline must lie in [0, pi/2) rad (got {args.incline:g})")
    for flag in ("mass", "g", "T"):
        if getattr(args, flag) <= 0:
            raise InputError(f"--{flag} must be positive (got {getattr(args, flag):g})")
    system = block(args.mass, args.mu, args.incline, args.g)
    tr = trajectory.solve_initial_value(system, [0.0, 0.0], [args.v0, 0.0], args.T, args.n, args.scheme,
                                        options=cli.ipopt_options(args), verbose=args.verbose, **cli.accuracy(args))
    t, s, v = tr.t, tr.q[:, 0], tr.v[:, 0]
    s_ex, stop_ex = exact(args.v0, args.mu, args.incline, args.g, t)
    h = args.T / args.n
    rest = np.abs(v) <= 1e-12 * max(abs(args.v0), args.g * h)
    # the first node from which the block stays at rest
    moving = np.where(~rest)[0]
    stop_node = None if rest.size == 0 or not rest[-1] else float(t[moving[-1] + 1] if moving.size else 0.0)
    # the stop itself, inside its step: read from the friction and normal impulses (ContactTrajectory.slip_stops)
    stops = tr.slip_stops(0)
    stop = stops[-1] if stop_node is not None and stop_node > 0 and stops else stop_node
    err = float(np.max(np.abs(s - s_ex)))
    data = {"t": t, "s": s, "v": v, "stop_time": stop, "stop_time_exact": stop_ex, "stop_node_time": stop_node,
            "s_exact": s_ex,
            "error_vs_exact": err, "energy": tr.energy}
    lines = [f"sliding block: μ = {args.mu:g}, incline {args.incline:g} rad, v0 = {args.v0:g} m/s, "
             f"scheme {args.scheme}, N = {args.n}, T = {args.T:g} s",
             f"s(T) = {s[-1]:.9g} m (exact {s_ex[-1]:.9g}); max |s − s_exact| = {err:.2e} m",
             f"at rest from t = {cli.fmt(stop, '.6g')} s (exact {cli.fmt(stop_ex, '.6g')} s; one step is {h:.3g} s)",
             cli.status_line(tr.status, tr)]

    def plot(path):
        fig = plotting.contact_plot(t, {"s (discrete)": s, "v (discrete)": v}, tr.t_sub,
                                    tr.mu[:, 0] + tr.nu[:-1, 0], reference={"s exact": (t, s_ex)},
                                    ylabel="s (m), v (m/s)", title=f"sliding block, μ = {args.mu:g}")
        fig.savefig(path)

    def animate(path):
        ca_, sa = math.cos(args.incline), math.sin(args.incline)
        pts = np.stack([np.stack([s * ca_, s * sa], axis=1)], axis=1)
        lo, hi = float(np.min(s)) - 0.5, float(np.max(s)) + 0.5
        ground = np.array([[lo * ca_, lo * sa], [hi * ca_, hi * sa]])
        plotting.animate_points(pts, t, path, links=False, pivot=None, ground=ground, title="sliding block")

    return cli.Outcome.of(tr, data, lines, writers={"plot": plot, "animate": animate})


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
