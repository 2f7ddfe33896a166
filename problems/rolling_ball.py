"""Rolling ball: a disk or a sphere launched sliding on a floor with friction, until it rolls.

A body of mass m and radius R (a disk, I = m R²/2, or a sphere, I = 2 m R²/5, moving in the plane) is
launched on the floor y = 0 with speed v0 and spin ω0 (clockwise: the rolling direction for v0 > 0).
Its contact point slips at u = v − R ω; friction μ m g opposes the slip until it vanishes, and the body
rolls from then on.  Oracles (u0 = v0 − R ω0): rolling starts at t* = 2 u0/(7 μ g) for the sphere and
u0/(3 μ g) for the disk; the final speed is (5 v0 + 2 R ω0)/7 and (2 v0 + R ω0)/3.

The contact is the gap y − R ≥ 0 of the centre's height with the contact point's slip velocity
ẋ + R θ̇ (θ counter-clockwise); ``rolling_time`` is the time the slip ends, inside its step, read from the
impulses (``ContactTrajectory.slip_stops``: the friction impulse until then is μ times the normal impulse over
the sliding time, exact here); ``rolling_node_time`` is the first node from which the slip stays zero.  ``--body sphere`` moves in the plane
(its rotation about the axis normal to it); ``--body sphere3d`` is the sphere on SO(3) (a unit quaternion)
with friction on its tangent plane (the isotropic cone), launched the same way and with an optional spin
about the vertical (``--top-spin``), which friction at the contact point cannot change.

    python problems/rolling_ball.py --body disk --mu 0.3 --v0 2 --spin 0
    python problems/rolling_ball.py --body sphere --v0 1 --spin 30 --json      # topspin: it speeds up to 11/7
    python problems/rolling_ball.py --body sphere3d --top-spin 10            # on SO(3): the same, ω_z kept
"""
import sys

import numpy as np

from castrajectory import cli
from castrajectory.inspect import plotting
from castrajectory.models import collision
from castrajectory.models.mechanics import LagrangianSystem
from castrajectory.solve import trajectory
from castrajectory.validation import InputError

SHAPES = collision.ROLLING_SHAPES     # I / (m R²)
BODIES = tuple(SHAPES) + ("sphere3d",)


def parser():
    p = cli.scene_parser("rolling_ball.py", __doc__.splitlines()[0])
    p.add_argument("--body", choices=BODIES, default="sphere",
                   help="the body: disk or sphere (in the plane), or sphere3d (on SO(3), friction on its tangent plane)")
    p.add_argument("--top-spin", type=float, default=0.0, help="sphere3d: spin about the vertical in rad/s")
    p.add_argument("--mu", type=float, default=0.3, help="friction coefficient (> 0)")
    p.add_argument("--v0", type=float, default=2.0, help="launch speed in m/s")
    p.add_argument("--spin", type=float, default=0.0, help="launch spin ω0 in rad/s, clockwise (rolling for v0 = R ω0)")
    p.add_argument("--radius", type=float, default=0.1, help="radius R (> 0)")
    p.add_argument("--mass", type=float, default=1.0, help="mass m (> 0)")
    p.add_argument("--g", type=float, default=9.81, help="gravity (> 0)")
    p.add_argument("--T", type=float, default=1.0, help="duration T in s (> 0)")
    p.add_argument("--n", type=int, default=400, help="number of time steps N (>= 2)")
    cli.add_scheme(p)
    cli.add_accuracy(p)
    cli.add_plot(p)
    p.add_argument("--animate", metavar="PATH", help="write an animation (.gif, or .mp4 when ffmpeg is present)")
    return p


def ball(shape, m, R, mu, g) -> LagrangianSystem:
    return collision.rolling_body(shape, m, R, mu, g)


def oracle(shape, v0, w0, R, mu, g):
    return collision.rolling_oracle(shape, v0, w0, R, mu, g)


def run(args):
    cli.check_animation_path(args.animate)
    cli.finite_flags(args, "mu", "v0", "spin", "radius", "mass", "g", "T", "top_spin")
    if args.body == "sphere3d":
        return run3d(args)
    if args.top_spin:
        raise InputError("--top-spin needs --body sphere3d (a planar body has no vertical spin)")
    for flag in ("mu", "radius", "mass", "g", "T"):
        if getattr(args, flag) <= 0:
            raise InputError(f"--{flag} must be positive (got {getattr(args, flag):g})")
    R = args.radius
    system = ball(args.body, args.mass, R, args.mu, args.g)
    # θ counter-clockwise: a clockwise spin ω0 is θ̇ = −ω0
    tr = trajectory.solve_initial_value(system, [0.0, R, 0.0], [args.v0, 0.0, -args.spin], args.T, args.n,
                                        args.scheme, options=cli.ipopt_options(args), verbose=args.verbose,
                                        **cli.accuracy(args))
    t, v, w = tr.t, tr.v[:, 0], -tr.v[:, 2]
    slip = v - R * w
    t_ex, v_ex = oracle(args.body, args.v0, args.spin, R, args.mu, args.g)
    rolling = np.abs(slip) <= 1e-9 * max(abs(args.v0), R * abs(args.spin), 1e-12)
    sliding = np.where(~rolling)[0]
    t_node = None if not rolling[-1] else float(t[sliding[-1] + 1] if sliding.size else 0.0)
    stops = tr.slip_stops(0)          # the slip's end inside its step, from the impulses
    t_roll = stops[-1] if t_node is not None and t_node > 0 and stops else t_node
    data = {"t": t, "q": tr.q, "v": v, "omega": w, "slip": slip, "rolling_time": t_roll, "rolling_time_exact": t_ex,
            "rolling_node_time": t_node,
            "final_speed": float(v[-1]), "final_speed_exact": v_ex,
            "error_vs_exact": abs(float(v[-1]) - v_ex) if t_ex < args.T else None}
    lines = [f"rolling {args.body}: v0 = {args.v0:g} m/s, spin {args.spin:g} rad/s (clockwise), μ = {args.mu:g}, "
             f"R = {R:g} m, scheme {args.scheme}, N = {args.n}, T = {args.T:g} s",
             f"rolls from t = {cli.fmt(t_roll, '.12g')} s (exact {t_ex:.12g} s; one step is {args.T / args.n:.3g} s)",
             f"final speed {v[-1]:.12g} m/s (exact {v_ex:.12g})", cli.status_line(tr.status, tr)]

    def plot(path):
        fig = plotting.contact_plot(t, {"v (m/s)": v, "R ω (m/s)": R * w, "slip (m/s)": slip}, tr.t_sub,
                                    tr.mu[:, 0] + tr.nu[:-1, 0], ylabel="speed", title=f"rolling {args.body}, μ = {args.mu:g}")
        fig.savefig(path)

    def animate(path):
        pts = system.positions(tr.q)
        lo, hi = float(np.min(pts[..., 0])) - 0.2, float(np.max(pts[..., 0])) + 0.2
        plotting.animate_points(pts, t, path, links=True, pivot=None, trail=False,
                                ground=np.array([[lo, 0.0], [hi, 0.0]]), title=f"rolling {args.body}")

    return cli.Outcome.of(tr, data, lines, writers={"plot": plot, "animate": animate})


def run3d(args):
    """The sphere on SO(3): the same launch, its slip (v − R ω_y, R ω_x) on the tangent plane."""
    from castrajectory.models import rigidbody as rb
    for flag in ("mu", "radius", "mass", "g", "T"):
        if getattr(args, flag) <= 0:
            raise InputError(f"--{flag} must be positive (got {getattr(args, flag):g})")
    R = args.radius
    system = rb.sphere_on_floor(args.mass, R, args.mu, args.g)
    quat = np.array([1.0, 0.0, 0.0, 0.0])
    w0 = np.array([0.0, args.spin, args.top_spin])         # clockwise seen from +y: ω_y = spin rolls along +x
    q0 = np.concatenate([[0.0, 0.0, R], quat])
    qd0 = np.concatenate([[args.v0, 0.0, 0.0], rb.quaternion_rate(quat, w0)])
    tr = trajectory.solve_initial_value(system, q0, qd0, args.T, args.n, args.scheme,
                                        options=cli.ipopt_options(args), verbose=args.verbose, **cli.accuracy(args))
    t = tr.t
    w = rb.angular_velocity(tr.q[:, 3:], tr.v[:, 3:], frame="space")
    v = tr.v[:, 0]
    slip = np.linalg.norm(tr.slip[:, 0, 0, :], axis=1)
    t_ex, v_ex = oracle("sphere", args.v0, args.spin, R, args.mu, args.g)
    scale = max(abs(args.v0), R * abs(args.spin), 1e-12)
    rolling = slip <= 1e-9 * scale
    sliding = np.where(~rolling)[0]
    t_node = None if not rolling[-1] else float(t[min(sliding[-1] + 1, t.size - 1)] if sliding.size else 0.0)
    stops = tr.slip_stops(0)
    t_roll = stops[-1] if t_node is not None and t_node > 0 and stops else t_node
    data = {"t": t, "q": tr.q, "v": v, "omega": w, "slip": slip, "rolling_time": t_roll, "rolling_time_exact": t_ex,
            "rolling_node_time": t_node,
            "final_speed": float(v[-1]), "final_speed_exact": v_ex,
            "error_vs_exact": abs(float(v[-1]) - v_ex) if t_ex < args.T else None,
            "top_spin_final": float(w[-1, 2]), "quaternion_norm_error": float(np.max(np.abs(
                np.linalg.norm(tr.q[:, 3:], axis=1) - 1.0)))}
    lines = [f"rolling sphere on SO(3): v0 = {args.v0:g} m/s, spin {args.spin:g} rad/s, top spin {args.top_spin:g} rad/s, "
             f"μ = {args.mu:g}, R = {R:g} m, scheme {args.scheme}, N = {args.n}, T = {args.T:g} s",
             f"rolls from t = {cli.fmt(t_roll, '.12g')} s (exact {t_ex:.12g} s; one step is {args.T / args.n:.3g} s)",
             f"final speed {v[-1]:.12g} m/s (exact {v_ex:.12g}); top spin {w[-1, 2]:.12g} rad/s (kept: {args.top_spin:g})",
             cli.status_line(tr.status, tr)]
    return cli.Outcome.of(tr, data, lines)


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
