"""Bounce to a target: a ball launched vertically from the floor is to reach the height p at rest after k bounces;
its launch speed and the horizon are the unknowns, against the closed form (rockit's bounce example).

A ball (restitution e, gravity g) leaves the floor y = 0 with the unknown speed v0 and must be at rest at y = p
at the unknown time T, having bounced k times.  The whole program (the flights, the floor's gap ⟂ its impulses,
Newton's law at each bounce, the end at rest) is one NLP in (v0, T) and the trajectory; the answer is certified
by marching it with the contact march.  The number of bounces is a discrete choice: it is the guess's (a launch at
√(2gp) followed to its apex after the k-th bounce, scaled by the flights' similarity to reach p) and is kept
(keep_modes: the answer's impacts stay in the guess's steps; they move inside them, and the horizon scales).  Closed form
(castrajectory.models.bounce): v0 = √(2gp)/e^k, flights 2 e^i v0/g, T = Σ flights + e^k v0/g; rockit's case
(g = 9.81, p = 0.5, k = 2, e = 0.9): v0 = 3.86678 m/s, T = 1.817111 s.

    python problems/bounce_to_target.py
    python problems/bounce_to_target.py --bounces 3 --restitution 0.8 --json
"""
import math
import sys

import casadi as ca
import numpy as np

from castrajectory import cli
from castrajectory.models.bounce import bounce_to_target
from castrajectory.models.contact import Contact
from castrajectory.models.mechanics import Atoms, Gravity, LagrangianSystem
from castrajectory.solve.optimal_control import OptimalControl
from castrajectory.solve.simulate import simulate
from castrajectory.validation import InputError


def parser():
    p = cli.scene_parser("bounce_to_target.py", __doc__.splitlines()[0])
    p.add_argument("--height", type=float, default=0.5, help="target height p in m (> 0)")
    p.add_argument("--bounces", type=int, default=2, help="number of bounces k (>= 0)")
    p.add_argument("--restitution", type=float, default=0.9, help="restitution e, in (0, 1]")
    p.add_argument("--g", type=float, default=9.81, help="gravity (> 0)")
    p.add_argument("--n", type=int, default=60, help="number of time steps N (>= 2)")
    cli.add_scheme(p)
    cli.add_plot(p)
    p.add_argument("--animate", metavar="PATH", help="write an animation (.gif, or .mp4 when ffmpeg is present)")
    return p


def ball(e, g) -> LagrangianSystem:
    y = ca.SX.sym("y", 1)
    return LagrangianSystem(y, Atoms([ca.vertcat(0, y)], [1.0]), [Gravity(g)], names=["y"],
                            contact=Contact([y[0]], restitution=e, names=["floor"]))


def launch_guess(system, p, k, g):
    """The guess: a launch at √(2gp) (as if no energy were lost), simulated to its apex after the k-th bounce (the
    time of that bounce plus its speed after it over g), then scaled by the flights' similarity (under gravity alone
    a trajectory launched c times faster is the same one with times c and heights c² times larger) so that apex is
    at p.  One shooting step: its digits are the simulation's (1e-4 or so); the program's answer is exact.  (From
    the unscaled launch the branch needs the end moved from the guess's apex to p, which took a continuation of 20
    or more steps and failed for k = 5, e = 0.7, where the launch is 6 times faster.)"""
    v0 = math.sqrt(2.0 * g * p)
    if k == 0:
        return v0, v0 / g
    run = simulate(system, [0.0], [v0], T=(2 * k + 1) * v0 / g, N=200 * (2 * k + 1))
    impacts = [imp for imp in (run.detail.impacts if run.success else []) if not getattr(imp, "caught", False)]
    if len(impacts) < k:
        raise InputError(f"the guess's launch at {v0:.4g} m/s bounces {len(impacts)} times before it is caught, "
                         f"fewer than {k}: lower --bounces or raise --restitution")
    imp = impacts[k - 1]
    up = float(np.asarray(imp.v_after).reshape(-1)[0])
    c = math.sqrt(p / (up * up / (2 * g)))
    return c * v0, c * (imp.t + up / g)


def problem(p, k, e, g, n, scheme="midpoint", scale=1.0):
    """The ball, its launch guess (``scale`` times the scene's: a launch that much faster, followed to its apex
    after k bounces) and the optimal-control problem in (v0, T): ``(system, ocp, guess)``."""
    system = ball(e, g)
    v0g, Tg = launch_guess(system, p, k, g)
    v0g, Tg = scale * v0g, scale * Tg
    ocp = OptimalControl(system, T=(1e-3 * Tg, 1e3 * Tg), N=n, scheme=scheme)
    ocp.initial(q=[0.0], qd=[None])
    ocp.final(q=[p], qd=[0.0])
    ocp.minimize(final=0 * ocp.T_symbol)            # a feasibility problem: its point is isolated
    return system, ocp, {"qd0": [v0g], "T": Tg}


def run(args):
    cli.finite_flags(args, "height", "restitution", "g")
    if args.height <= 0 or args.g <= 0:
        raise InputError("--height and --g must be positive")
    if not 0 < args.restitution <= 1:
        raise InputError(f"--restitution must lie in (0, 1] (got {args.restitution:g})")
    if args.bounces < 0:
        raise InputError(f"--bounces must be >= 0 (got {args.bounces})")
    cli.check_animation_path(args.animate)
    p, k, e, g = args.height, args.bounces, args.restitution, args.g
    exact = bounce_to_target(p, k, e, g)
    system, ocp, guess = problem(p, k, e, g, args.n, args.scheme)
    v0g, Tg = guess["qd0"][0], guess["T"]
    sol = ocp.solve(guess=guess, options=cli.ipopt_options(args), verbose=args.verbose, keep_modes=True)
    v0 = float(sol.v[0, 0])
    impacts = sol.impact_times[0] if sol.impact_times else []
    ok = len(impacts) == len(exact.impact_times)
    imp_err = float(np.max(np.abs(np.array(impacts) - np.array(exact.impact_times)))) if ok and impacts else (
        0.0 if ok else float("nan"))
    lines = [f"v0 = {v0:.12g} m/s (closed form {exact.launch_speed:.12g}, error {abs(v0 - exact.launch_speed):.1e}); "
             f"T = {sol.T:.12g} s (closed form {exact.horizon:.12g}, error {abs(sol.T - exact.horizon):.1e})",
             f"{len(impacts)} bounce(s) at " + ", ".join(f"{t:.9g}" for t in impacts)
             + f" s; against the closed form's: {imp_err:.1e} s; complementarity {sol.complementarity:.1e}",
             f"the guess: a launch at {v0g:.6g} m/s to the apex after {k} bounce(s), T = {Tg:.6g} s"]
    extra = {**exact.as_dict(), "v0": v0, "T": sol.T, "impact_times": impacts, "exact": exact.as_dict(),
             "v0_error": abs(v0 - exact.launch_speed), "T_error": abs(sol.T - exact.horizon),
             "impact_time_error": imp_err, "complementarity": sol.complementarity}
    return cli.control_outcome("bounce to a target", system, sol, extra=extra, extra_lines=lines)


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
