"""Newton's cradle: equal balls on pendulums in a row, the first lifted and released; the impact law decides.

n balls of mass m and radius r hang on strings of length L from pivots 2r + gap apart; ball 1 is lifted
to the angle --lift and released at rest.  It swings down and strikes the row.  With gaps, the impacts
come one after the other and every law gives the same motion.  Touching balls (--gap 0) take one
simultaneous impact, whose outcome depends on the impact law (--law):

* sequential: a cascade of two-ball impacts, the fastest approach first (the limit of vanishing gaps):
  for e = 1 the last ball leaves with the first's speed V = 2√(gL) sin(lift/2), the others stop;
* simultaneous: Newton's law at every contact at once (J v⁺ + e J v⁻ ≥ 0 ⟂ μ ≥ 0): for three balls,
  e = 1, (−1/3, 2/3, 2/3) V.

Oracles: the first impact's time, sqrt(L/g) ∫ dφ / sqrt(1 − k² sin²φ) from −π/2 to the contact angle
(k = sin(lift/2)), and, touching, the speeds just after it by the law (the cascade or the linear
complementarity problem of the chain, solved here by enumeration of its active sets).

    python problems/newtons_cradle.py --balls 5 --law sequential
    python problems/newtons_cradle.py --balls 3 --law simultaneous --json
    python problems/newtons_cradle.py --gap 1e-3 --animate cradle.gif
"""
import itertools
import math
import sys

import casadi as ca
import numpy as np

from castrajectory import cli
from castrajectory.inspect import plotting
from castrajectory.models.mechanics import Atoms, Contact, Gravity, LagrangianSystem
from castrajectory.solve import trajectory
from castrajectory.validation import InputError


def parser():
    p = cli.scene_parser("newtons_cradle.py", __doc__.splitlines()[0])
    p.add_argument("--balls", type=int, default=5, help="number of balls n (2 to 8)")
    p.add_argument("--lift", type=float, default=0.5, help="the first ball's release angle in rad (0 < lift < pi/2)")
    p.add_argument("--gap", type=float, default=0.0, help="gap between neighbouring balls at rest (>= 0)")
    p.add_argument("--length", type=float, default=1.0, help="string length L (> 0)")
    p.add_argument("--radius", type=float, default=0.05, help="ball radius r (> 0)")
    p.add_argument("--mass", type=float, default=1.0, help="ball mass m (> 0)")
    p.add_argument("--restitution", type=float, default=1.0, help="restitution coefficient e in [0, 1]")
    p.add_argument("--law", choices=("simultaneous", "sequential"), default="sequential",
                   help="how an impact at several contacts at once is resolved")
    p.add_argument("--g", type=float, default=9.81, help="gravity (> 0)")
    p.add_argument("--T", type=float, default=None, help="duration in s (default: twice the first impact's time)")
    p.add_argument("--n", type=int, default=400, help="number of time steps N (>= 2)")
    cli.add_scheme(p)
    cli.add_accuracy(p)
    cli.add_plot(p)
    p.add_argument("--animate", metavar="PATH", help="write an animation (.gif, or .mp4 when ffmpeg is present)")
    return p


def cradle(n, m, L, r, gap, e, law, g) -> LagrangianSystem:
    """The cradle: angles θ_i from the vertical, pivots at x_i = i (2r + gap), gaps |c_{i+1} − c_i| − 2r."""
    th = ca.SX.sym("theta", n)
    centres = [ca.vertcat(i * (2 * r + gap) + L * ca.sin(th[i]), -L * ca.cos(th[i])) for i in range(n)]
    gaps = [ca.norm_2(centres[i + 1] - centres[i]) - 2 * r for i in range(n - 1)]
    return LagrangianSystem(th, Atoms(centres, [m] * n), [Gravity(g)], names=[f"theta{i + 1}" for i in range(n)],
                            contact=Contact(gaps, restitution=e, names=[f"{i + 1}-{i + 2}" for i in range(n - 1)],
                                            law=law))


def first_impact_time(lift, gap, L, g) -> float:
    """Ball 1 from −lift at rest meets ball 2 (at rest) when L sin θ = gap:
    t = sqrt(L/g) ∫ dφ / sqrt(1 − k² sin²φ) over [−π/2, φ*], sin(θ/2) = k sin φ, k = sin(lift/2)
    (Gauss–Legendre, 60 points: the integrand is smooth for k < 1)."""
    k = math.sin(lift / 2)
    theta = math.asin(gap / L)
    phi_star = math.asin(math.sin(theta / 2) / k)
    x, w = np.polynomial.legendre.leggauss(60)
    a, b = -math.pi / 2, phi_star
    phi = 0.5 * (b - a) * x + 0.5 * (a + b)
    return math.sqrt(L / g) * 0.5 * (b - a) * float(np.sum(w / np.sqrt(1 - k * k * np.sin(phi) ** 2)))


def chain_after(v, e, law):
    """Speeds of equal balls in a touching row just after the impact, by the law (independent of the
    library's solvers): the sequential cascade of two-ball impacts, or the simultaneous law's linear
    complementarity problem J v⁺ + e J v⁻ ≥ 0 ⟂ μ ≥ 0 solved by enumerating its active sets."""
    v = np.asarray(v, float).copy()
    n = v.size
    if law == "sequential":
        for _ in range(100000):
            vn = v[1:] - v[:-1]
            i = int(np.argmin(vn))
            if vn[i] >= -1e-15 * np.max(np.abs(v)):
                return v
            d = -(1 + e) * vn[i] / 2               # equal masses: W_ii = 2/m, the impulse per unit mass
            v[i] -= d
            v[i + 1] += d
        raise RuntimeError("the cascade did not end")
    J = np.zeros((n - 1, n))
    for i in range(n - 1):
        J[i, i], J[i, i + 1] = -1.0, 1.0
    W, vn = J @ J.T, J @ v
    for size in range(n):
        for S in itertools.combinations(range(n - 1), size + 1):
            S = list(S)
            mu = np.zeros(n - 1)
            mu[S] = np.linalg.solve(W[np.ix_(S, S)], -(1 + e) * vn[S])
            after = vn + W @ mu
            if np.all(mu >= -1e-14) and np.all(after + e * vn >= -1e-12):
                return v + J.T @ mu
    raise RuntimeError("no active set solves the chain's complementarity problem")


def run(args):
    cli.check_animation_path(args.animate)
    cli.finite_flags(args, "lift", "gap", "length", "radius", "mass", "restitution", "g")
    if not 2 <= args.balls <= 8:
        raise InputError(f"--balls must be between 2 and 8 (got {args.balls})")
    if not 0 < args.lift < math.pi / 2:
        raise InputError(f"--lift must lie in (0, pi/2) rad (got {args.lift:g})")
    for flag in ("length", "radius", "mass", "g"):
        if getattr(args, flag) <= 0:
            raise InputError(f"--{flag} must be positive (got {getattr(args, flag):g})")
    if args.gap < 0 or args.gap >= args.length * math.sin(args.lift):
        raise InputError(f"--gap must be >= 0 and below L sin(lift) = {args.length * math.sin(args.lift):.3g}, "
                         f"or ball 1 never reaches ball 2 (got {args.gap:g})")
    if 2 * args.radius >= args.length:
        raise InputError("--radius must be below L/2")
    t1 = first_impact_time(args.lift, args.gap, args.length, args.g)
    T = args.T if args.T is not None else 2 * t1
    if not (math.isfinite(T) and T > 0):
        raise InputError(f"--T must be positive (got {T:g})")
    n, L = args.balls, args.length
    system = cradle(n, args.mass, L, args.radius, args.gap, args.restitution, args.law, args.g)
    q0 = np.zeros(n)
    q0[0] = -args.lift
    tr = trajectory.solve_initial_value(system, q0, np.zeros(n), T, args.n, args.scheme,
                                        options=cli.ipopt_options(args), verbose=args.verbose, **cli.accuracy(args))
    V = 2 * math.sqrt(args.g * L) * math.sin(args.lift / 2)
    imps = sorted(tr.impacts, key=lambda i: (i.t, i.contact))
    data = {"t": tr.t, "q": tr.q, "v": tr.v, "energy": tr.energy, "law": args.law,
            "first_impact_time_exact": t1, "impact_speed_exact": V}
    lines = [f"Newton's cradle: {n} balls, lift {args.lift:g} rad, gap {args.gap:g} m, e = {args.restitution:g}, "
             f"{args.law} law, scheme {args.scheme}, N = {args.n}, T = {T:.6g} s"]
    if imps:
        first = [i for i in imps if i.t <= imps[0].t + 1e-9 * T]
        # the speeds just after the first impact (all its contacts at once), L θ̇, or after the first
        # cascade through the row when there are gaps (its impacts within a tenth of t1)
        last = [i for i in imps if i.t <= imps[0].t + 0.1 * t1][-1] if args.gap > 0 else first[-1]
        after = L * np.asarray(last.v_after, float)
        data.update(first_impact_time=imps[0].t, first_impact_contacts=[system.contact.names[i.contact] for i in first],
                    speeds_after=after)
        err_t = abs(imps[0].t - t1)
        lines.append(f"first impact at t = {imps[0].t:.12g} s (exact {t1:.12g}, error {err_t:.2e}); contacts "
                     f"{', '.join(data['first_impact_contacts'])}")
        v_in = np.zeros(n)
        v_in[0] = V
        expect = chain_after(v_in, args.restitution, args.law)
        data["speeds_after_exact"] = expect
        err_v = float(np.max(np.abs(after - expect)))
        which = ("the vanishing-gap limit (sequential)" if args.gap > 0 else f"the {args.law} law")
        if args.gap > 0:
            expect = chain_after(v_in, args.restitution, "sequential")
            data["speeds_after_exact"] = expect
            err_v = float(np.max(np.abs(after - expect)))
        else:
            data["error_vs_exact"] = max(err_t, err_v / V)
        data["speeds_error"] = err_v
        lines.append("speeds after it (L θ̇): " + ", ".join(f"{s:+.6f}" for s in after)
                     + f"; {which}: " + ", ".join(f"{s:+.6f}" for s in expect) + f" (error {err_v:.2e} m/s)")
    else:
        lines.append("no impact within T")
    lines += [f"energy {tr.energy[0]:.9g} -> {tr.energy[-1]:.9g} J; complementarity residual "
              f"{tr.complementarity_residual:.1e}", cli.status_line(tr.status, tr)]

    def plot(path):
        series = {f"θ{i + 1}": tr.q[:, i] for i in range(n)}
        fig = plotting.contact_plot(tr.t, series, tr.t_sub, np.sum(tr.mu, axis=1) + np.sum(tr.nu[:-1], axis=1),
                                    ylabel="angle (rad)", title=f"Newton's cradle, {n} balls, {args.law} law")
        fig.savefig(path)

    def animate(path):
        pts = system.positions(tr.q)
        plotting.animate_points(pts, tr.t, path, links=False, pivot=None, trail=False, title="Newton's cradle")

    return cli.Outcome.of(tr, data, lines, writers={"plot": plot, "animate": animate})


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
