"""Bouncing ball: contact as a complementarity-constrained discrete action (whole trajectory).

A point mass falls from --height onto the ground y = 0 and bounces with Newton
restitution e.  The whole trajectory is one NLP (castrajectory.solve.contact): every
step has a collision sub-node whose time is an unknown, the gap and the
impulse are complementary, and the impact law acts on the exact discrete
momenta.  Compared with the analytic bounce times t_k, apex heights e^(2k) H
and impact speeds.  JSON ``mu``: the impulse per node Λ_k (each sub-node impulse
shared between its two nodes by the hat-function weights of its time; m g h per
node for a body at rest, docs/derivations.md, "Contact trajectories" §2).

    python problems/bouncing_ball.py --restitution 0.7 --T 3
    python problems/bouncing_ball.py --height 0 --T 1          # resting contact
"""
import sys

import numpy as np

from castrajectory import cli
from castrajectory.models import collision
from castrajectory.inspect import plotting
from castrajectory.solve import trajectory
from castrajectory.validation import InputError, finite


def parser():
    p = cli.scene_parser("bouncing_ball.py", __doc__.splitlines()[0])
    p.add_argument("--height", type=float, default=1.0, help="initial height H (>= 0)")
    p.add_argument("--velocity", type=float, default=0.0, help="initial vertical velocity (negative: downwards)")
    p.add_argument("--restitution", type=float, default=1.0, help="restitution coefficient e in [0, 1]")
    p.add_argument("--mass", type=float, default=1.0, help="mass m (> 0)")
    p.add_argument("--g", type=float, default=9.81, help="gravity (>= 0; 0 drops the gravity term)")
    p.add_argument("--T", type=float, default=2.5, help="duration T in s (> 0)")
    p.add_argument("--n", type=int, default=3000, help="number of time steps N (>= 2)")
    cli.add_scheme(p)
    cli.add_accuracy(p)
    cli.add_plot(p)
    p.add_argument("--animate", metavar="PATH", help="write an animation (.gif, or .mp4 when ffmpeg is present)")
    return p


def solve(height, velocity, e, mass, g, T, n, options=None, verbose=False, rtol=None, n_max=None, *,
          scheme="midpoint"):
    """Solve the scene with the discrete Lagrangian ``scheme``; returns (system, trajectory, summary dict
    of comparisons)."""
    H = finite("height", height)
    v0 = finite("velocity", velocity)
    if g < 0:  # the scene's own condition; the model checks that g is finite
        raise InputError(f"g must be >= 0 (gravity points down; got {g})")
    if H < 0:
        raise InputError(f"the ball starts inside the ground: height {H} < 0")
    system = collision.bouncing_ball(mass, g, e)
    tr = trajectory.solve_initial_value(system, [H], [v0], T, n, scheme, options=options, verbose=verbose,
                                        rtol=rtol, n_max=n_max)
    return system, tr, compare(tr, H, v0, float(g), system.contact.restitution, float(mass))


def compare(tr, H, v0, g, e, m):
    """Bounce times, apexes and impact speeds of the discrete solution against the analytic ones."""
    imps = tr.impacts
    t_imp = np.array([i.t for i in imps])
    speeds = np.array([-float(i.v_before[0]) for i in imps])
    # apex of each flight: the first from the start; later ones from the post-impact velocity
    # (every scheme is exact on a parabola -- midpoint and trapezoid at the nodes, the Galerkin and Gauss
    # families through their quadratic stages -- so y + v²/2g is the discrete flight's apex)
    apex = [H + max(v0, 0.0) ** 2 / (2 * g) if g > 0 else float("nan")]
    apex += [float(i.q[0]) + float(i.v_after[0]) ** 2 / (2 * g) if g > 0 else float("nan") for i in imps]
    t_ex, apex_ex, speed_ex = collision.ball_oracle(H, v0, g, e, tr.t[-1]) if g > 0 else (np.zeros(0),) * 3
    k = min(len(t_imp), len(t_ex))
    apex = np.array(apex)
    ka = min(len(apex), len(apex_ex))
    # resting contact: the impulse per node Λ_k against m g h on the nodes that lie on the ground
    # with both neighbours (settled, not the landing itself); node 0's cell is half a step
    h = tr.t[1] - tr.t[0]
    impulse_node = tr.node_impulse[:, 0]
    on = tr.gap[:, 0] <= 1e-9
    ground = on.copy()
    ground[1:] &= on[:-1]
    ground[:-1] &= on[1:]
    ground[0] = False
    rest_err = float(np.max(np.abs(impulse_node[ground] / (m * g * h) - 1))) if g > 0 and ground.any() else None
    return {
        "impact_times": t_imp, "impact_times_exact": t_ex,
        "impact_time_error": float(np.max(np.abs(t_imp[:k] - t_ex[:k]))) if k else None,
        "impact_speeds": speeds, "impact_speeds_exact": speed_ex,
        "apex_heights": apex, "apex_heights_exact": apex_ex,
        "apex_error": float(np.max(np.abs(apex[:ka] - apex_ex[:ka]))) if ka else None,
        "impulses": np.array([i.mu for i in imps]), "impulses_exact": (1 + e) * m * speed_ex,
        "mu_node": impulse_node,
        "min_gap": float(min(tr.gap.min(), tr.gap_sub.min())),
        "resting_nodes": int(ground.sum()), "resting_impulse_error": rest_err,
        "max_height_at_rest": float(np.max(np.abs(tr.q[ground, 0]))) if ground.any() else None,
    }


def run(args):
    cli.check_animation_path(args.animate)
    system, tr, cmp_ = solve(args.height, args.velocity, args.restitution, args.mass, args.g, args.T, args.n,
                             options=cli.ipopt_options(args), verbose=args.verbose, scheme=args.scheme,
                             **cli.accuracy(args))
    n_b = len(cmp_["impact_times"])
    lines = [f"bouncing ball: H = {args.height:g} m, e = {args.restitution:g}, scheme {args.scheme}, "
             f"N = {args.n}, T = {args.T:g} s",
             f"{n_b} impacts; max |t - t_exact| = {cli.fmt(cmp_['impact_time_error'], '.3e')} s; "
             f"max |apex - e^(2k) H| = {cli.fmt(cmp_['apex_error'], '.3e')} m"]
    for i, (ti, a) in enumerate(zip(cmp_["impact_times"][:6], cmp_["apex_heights"][1:7])):
        ex = cmp_["impact_times_exact"][i] if i < len(cmp_["impact_times_exact"]) else float("nan")
        ax = cmp_["apex_heights_exact"][i + 1] if i + 1 < len(cmp_["apex_heights_exact"]) else float("nan")
        lines.append(f"  impact {i + 1}: t = {ti:.6f} s (exact {ex:.6f}), next apex {a:.6g} m (exact {ax:.6g})")
    if cmp_["resting_impulse_error"] is not None:
        lines.append(f"at rest on {cmp_['resting_nodes']} nodes: impulse per node / (m g h) - 1 at most "
                     f"{cmp_['resting_impulse_error']:.1e}; highest node {cmp_['max_height_at_rest']:.1e} m")
    lines += [f"lowest gap {cmp_['min_gap']:.2e} m; complementarity residual {tr.complementarity_residual:.1e}; "
              f"energy {tr.energy[0]:.6g} -> {tr.energy[-1]:.6g} J",
              f"relaxation (penalty) steps: {len(tr.homotopy)}; attempts: {len(tr.attempts)}",
              cli.status_line(tr.status, tr)]
    data = {"t": tr.t, "q": tr.q[:, 0], "mu": cmp_["mu_node"],
            "mu_sub": tr.mu[:, 0], "t_sub": tr.t_sub, "nu": tr.nu[:, 0],
            "apex_heights": cmp_["apex_heights"], "energy": tr.energy,
            **{k: v for k, v in cmp_.items() if k not in ("mu_node",)}}

    def plot(path):
        ref = {}
        if args.g > 0:
            tt = np.linspace(0, tr.t[-1], 2000)
            ref["analytic"] = (tt, collision.ball_height(args.height, args.velocity, args.g,
                                                        collision.restitution(args.restitution), tt))
        fig = plotting.contact_plot(tr.t, {"discrete (nodes)": tr.q[:, 0]}, tr.t_sub, tr.mu[:, 0] + tr.nu[:-1, 0],
                                    reference=ref, title=f"bouncing ball, e = {args.restitution:g}, N = {args.n}")
        fig.savefig(path)

    def animate(path):
        plotting.animate_points(system.positions(tr.q), tr.t, path, links=False, pivot=None,
                                ground=np.array([[-0.5, 0.0], [0.5, 0.0]]), title="bouncing ball")

    return cli.Outcome.of(tr, data, lines, writers={"plot": plot, "animate": animate})


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
