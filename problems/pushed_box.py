"""Pushed box: a horizontal force at a height pushes a box resting on a floor with friction; it slides, tips or rests.

A uniform box of mass m, width b and height H stands on the floor y = 0 on its two bottom corners, each a
contact with Coulomb friction μ.  A constant horizontal force F pushes its left face at the height h_p.
Statics decides (the oracle):

* it slides when F > μ m g and μ < b/(2 h_p): friction gives way before the front corner takes the weight;
* it tips about its front corner when F > m g b/(2 h_p) and μ > b/(2 h_p);
* otherwise it rests.

``outcome`` reads the motion: "tips" if the box turned by more than 1e-3 rad, "slides" if it moved by more
than 1e-6 of its width, else "rests".  The force is a ct.Force on the box's coordinates (x, y, θ).

    python problems/pushed_box.py --mu 0.3 --force 4       # slides (μ m g = 2.94 N)
    python problems/pushed_box.py --mu 0.8 --force 5       # tips (m g b/(2 h_p) = 4.905 N for b = 0.5, h_p = 0.5)
"""
import sys

import casadi as ca
import numpy as np

from castrajectory import cli
from castrajectory.inspect import plotting
from castrajectory.models.mechanics import Contact, Force, LagrangianSystem, MassMatrix, Potential, velocity
from castrajectory.solve import trajectory
from castrajectory.validation import InputError


def parser():
    p = cli.scene_parser("pushed_box.py", __doc__.splitlines()[0])
    p.add_argument("--mu", type=float, default=0.3, help="friction coefficient (>= 0)")
    p.add_argument("--width", type=float, default=0.5, help="box width b (> 0)")
    p.add_argument("--height", type=float, default=1.0, help="box height H (> 0)")
    p.add_argument("--push-height", type=float, default=0.5, help="height h_p of the push above the floor, in (0, H]")
    p.add_argument("--force", type=float, default=4.0, help="the push F in N (>= 0)")
    p.add_argument("--mass", type=float, default=1.0, help="mass m (> 0)")
    p.add_argument("--g", type=float, default=9.81, help="gravity (> 0)")
    p.add_argument("--T", type=float, default=0.5, help="duration T in s (> 0)")
    p.add_argument("--n", type=int, default=200, help="number of time steps N (>= 2)")
    cli.add_scheme(p)
    cli.add_accuracy(p)
    cli.add_plot(p)
    p.add_argument("--animate", metavar="PATH", help="write an animation (.gif, or .mp4 when ffmpeg is present)")
    return p


def box(m, b, H, hp, F, mu, g):
    """The box: centroid (x, y), angle θ; corners from the lower left, counter-clockwise; the push at the
    left face's point (−b/2, h_p − H/2) in the body."""
    q = ca.SX.sym("q", 3)
    x, y, th = q[0], q[1], q[2]
    R = ca.vertcat(ca.horzcat(ca.cos(th), -ca.sin(th)), ca.horzcat(ca.sin(th), ca.cos(th)))
    c = ca.vertcat(x, y)
    body = lambda u, w: c + ca.mtimes(R, ca.vertcat(u, w))  # noqa: E731
    corners = [body(-b / 2, -H / 2), body(b / 2, -H / 2), body(b / 2, H / 2), body(-b / 2, H / 2)]
    push = body(-b / 2, hp - H / 2)
    Q = ca.mtimes(ca.jacobian(push, q).T, ca.vertcat(F, 0.0))
    qd = velocity(q)
    slips = [ca.mtimes(ca.jacobian(p[0], q), qd) for p in corners[:2]]
    I = m * (b * b + H * H) / 12.0
    terms = [Potential(m * g * y, "gravity"), Force(Q)]
    return LagrangianSystem(q, MassMatrix(ca.diag(ca.vertcat(m, m, I))), terms, names=["x", "y", "theta"],
                            points_expr=corners,
                            contact=Contact([corners[0][1], corners[1][1]], restitution=0.0, friction=mu,
                                            slip=slips, names=["back corner", "front corner"]))


def oracle(m, b, hp, F, mu, g) -> str:
    slide, tip = mu * m * g, m * g * b / (2 * hp)
    if mu < b / (2 * hp):
        return "slides" if F > slide else "rests"
    return "tips" if F > tip else "rests"


def run(args):
    cli.check_animation_path(args.animate)
    cli.finite_flags(args, "mu", "width", "height", "push_height", "force", "mass", "g", "T")
    if args.mu < 0 or args.force < 0:
        raise InputError("--mu and --force must be >= 0")
    for flag in ("width", "height", "mass", "g", "T"):
        if getattr(args, flag) <= 0:
            raise InputError(f"--{flag} must be positive (got {getattr(args, flag):g})")
    if not 0 < args.push_height <= args.height:
        raise InputError(f"--push-height must lie in (0, --height] (got {args.push_height:g})")
    m, b, H, hp = args.mass, args.width, args.height, args.push_height
    system = box(m, b, H, hp, args.force, args.mu, args.g)
    tr = trajectory.solve_initial_value(system, [0.0, H / 2, 0.0], [0.0, 0.0, 0.0], args.T, args.n, args.scheme,
                                        options=cli.ipopt_options(args), verbose=args.verbose, **cli.accuracy(args))
    turn = float(np.max(np.abs(tr.q[:, 2])))
    shift = float(np.max(np.abs(tr.q[:, 0])))
    outcome = "tips" if turn > 1e-3 else "slides" if shift > 1e-6 * b else "rests"
    expect = oracle(m, b, hp, args.force, args.mu, args.g)
    data = {"t": tr.t, "q": tr.q, "v": tr.v, "outcome": outcome, "outcome_exact": expect,
            "slide_force": args.mu * m * args.g, "tip_force": m * args.g * b / (2 * hp), "turn": turn, "shift": shift}
    lines = [f"pushed box: F = {args.force:g} N at h_p = {hp:g} m, μ = {args.mu:g}, b × H = {b:g} × {H:g} m, "
             f"scheme {args.scheme}, N = {args.n}, T = {args.T:g} s",
             f"outcome: {outcome} (statics: {expect}; slides above μ m g = {data['slide_force']:.4g} N when "
             f"μ < b/(2h_p) = {b / (2 * hp):.4g}, tips above m g b/(2h_p) = {data['tip_force']:.4g} N)",
             f"largest turn {turn:.3e} rad, shift {shift:.3e} m", cli.status_line(tr.status, tr)]
    if outcome != expect:
        lines.append(f"the motion ({outcome}) disagrees with statics ({expect})")

    def plot(path):
        fig = plotting.contact_plot(tr.t, {"x (m)": tr.q[:, 0], "θ (rad)": tr.q[:, 2]}, tr.t_sub,
                                    np.sum(tr.mu, axis=1) + np.sum(tr.nu[:-1], axis=1), ylabel="x, θ",
                                    title=f"pushed box, F = {args.force:g} N, μ = {args.mu:g}")
        fig.savefig(path)

    def animate(path):
        pts = system.positions(tr.q)
        lo, hi = float(np.min(pts[..., 0])) - 0.5, float(np.max(pts[..., 0])) + 0.5
        plotting.animate_points(pts, tr.t, path, links=True, pivot=None, trail=False,
                                ground=np.array([[lo, 0.0], [hi, 0.0]]), title="pushed box")

    return cli.Outcome.of(tr, data, lines, writers={"plot": plot, "animate": animate})


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
