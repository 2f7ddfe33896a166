"""Rectangle dropped at an angle onto the ground: four corner contacts, whole-trajectory contact NLP.

A uniform w × h rectangle, q = (c_x, c_y, θ), falls under gravity onto y = 0.
Each corner j has a gap y_j(q) ≥ 0 and an impulse μ_j ≥ 0 along M⁻¹∇y_jᵀ
(Exercise 2.2); impacts obey Newton restitution e on the corner's normal
velocity, at a sub-node whose time is an unknown.  Every impact is compared
with the closed-form corner impact law of collision.rectangle_impact.

With ``--friction μ`` each corner has Coulomb friction along the ground: a bounce follows Stronge's energetic
restitution with friction (models.impact.frictional_impact), and each is compared with that law applied to
its own arrival, with the kinetic energy never gained (``impact_energy_gain``, at most 0) and the tangential
impulse in the cone (``friction_cone``, at most 0).  A corner straight under the centroid bounces like a
round body (k = 1/3): it leaves rolling iff (k/(1+k))|u| ≤ μ(1+e)|v_n|.

    python problems/rectangle_drop.py --friction 0.5 --restitution 0.5 --T 1.5 --n 600

    python problems/rectangle_drop.py --angle 0.3 --restitution 1 --T 3
    python problems/rectangle_drop.py --angle 0.001 --omega 0 --vx 0     # nearly flat landing
"""
import sys

import numpy as np

from castrajectory import cli
from castrajectory.models import collision
from castrajectory.solve import trajectory
from castrajectory.models.impact import simultaneous_impact
from castrajectory.validation import InputError, finite

CORNER_NAMES = ["lower left", "lower right", "upper right", "upper left"]


def add_body_flags(p, width, height, x, y, angle, vx, vy, omega, T, n):
    p.add_argument("--mass", type=float, default=1.0, help="mass m (> 0)")
    p.add_argument("--width", type=float, default=width, help="width w (> 0)")
    p.add_argument("--height", type=float, default=height, help="height h (> 0)")
    p.add_argument("--x", type=float, default=x, help="initial centroid x")
    p.add_argument("--y", type=float, default=y, help="initial centroid y")
    p.add_argument("--angle", type=float, default=angle, help="initial angle θ in rad")
    p.add_argument("--vx", type=float, default=vx, help="initial velocity v_x")
    p.add_argument("--vy", type=float, default=vy, help="initial velocity v_y")
    p.add_argument("--omega", type=float, default=omega, help="initial angular velocity ω in rad/s")
    p.add_argument("--restitution", type=float, default=1.0, help="restitution coefficient e in [0, 1]")
    p.add_argument("--g", type=float, default=9.81, help="gravity (0 drops the gravity term)")
    p.add_argument("--T", type=float, default=T, help="duration T in s (> 0)")
    p.add_argument("--n", type=int, default=n, help="number of time steps N (>= 2)")
    cli.add_scheme(p)
    p.add_argument("--friction", type=float, default=0.0,
                   help="Coulomb friction coefficient at the corners (>= 0; 0: frictionless)")
    cli.add_accuracy(p)
    cli.add_plot(p)
    p.add_argument("--animate", metavar="PATH", help="write an animation (.gif, or .mp4 when ffmpeg is present)")


def parser():
    p = cli.scene_parser("rectangle_drop.py", __doc__.splitlines()[0])
    add_body_flags(p, 2.0, 1.0, 0.0, 2.0, 0.3, 0.5, 0.0, 1.0, T=3.0, n=1000)
    return p


def friction(args) -> float:
    """``--friction``, checked (finite, >= 0)."""
    mu = finite("friction", args.friction)
    if mu < 0:
        raise InputError(f"--friction must be >= 0 (got {mu:g})")
    return mu


def initial_state(args):
    q0 = [finite("x", args.x), finite("y", args.y), finite("angle", args.angle)]
    qd0 = [finite("vx", args.vx), finite("vy", args.vy), finite("omega", args.omega)]
    return q0, qd0


def impact_table(tr, body, e):
    """Impacts with the closed-form corner law's post-impact velocity (rectangle on flat ground).

    Corners with an impulse at the same sub-node (a flat landing, or a corner held on the ground
    while another hits) are compared with the simultaneous law ``J v⁺ + e J v⁻ ≥ 0 ⟂ μ ≥ 0``
    instead.  A caught impact (Newton's law waived because the corner is closed at the next node:
    the end of a rocking or bouncing accumulation, plastic) is listed without a comparison.
    """
    rows, worst = [], 0.0
    cs, M = body.corners, body.mass_matrix
    for imp in tr.impacts:
        if imp.caught:
            rows.append({"t": imp.t, "corner": cs[imp.contact], "corner_name": CORNER_NAMES[imp.contact],
                         "contact": imp.contact, "q": imp.q, "angle": float(imp.q[2]), "v_before": imp.v_before, "v_after": imp.v_after,
                         "mu": imp.mu, "mu_exact": None, "v_after_exact": None, "law_error": None,
                         "simultaneous": False, "caught": True})
            continue
        # every corner with an impulse at this sub-node (a held corner too: it arrives at rest)
        same = [int(j) for j in np.where(tr.mu[imp.step] > 1e-9 * max(1.0, imp.mu))[0]]
        if len(same) == 1:
            exact = collision.corner_impact(body, imp.q[2], imp.v_before, e, cs[imp.contact])
            mu_exact, v_exact = exact.mu, exact.v_after
        else:
            J = np.array([body.corner_jacobian(imp.q[2], cs[j]) for j in same])
            mus, v_exact = simultaneous_impact(M, J, imp.v_before, e)
            mu_exact = float(mus[same.index(imp.contact)])
        err = float(np.max(np.abs(v_exact - imp.v_after)))
        worst = max(worst, err)
        rows.append({"t": imp.t, "corner": cs[imp.contact], "corner_name": CORNER_NAMES[imp.contact],
                     "contact": imp.contact, "q": imp.q, "angle": float(imp.q[2]), "v_before": imp.v_before, "v_after": imp.v_after, "mu": imp.mu,
                     "mu_exact": mu_exact, "v_after_exact": v_exact, "law_error": err,
                     "simultaneous": len(same) > 1, "caught": False})
    return rows, worst


def run(args):
    cli.check_animation_path(args.animate)
    body = collision.Body(args.mass, args.width, args.height)
    system = collision.rectangle_contact_system(body, finite("g", args.g), args.restitution, collision.flat_ground,
                                                friction(args))
    e = system.contact.restitution
    q0, qd0 = initial_state(args)
    tr = trajectory.solve_initial_value(system, q0, qd0, args.T, args.n, args.scheme,
                                        options=cli.ipopt_options(args), verbose=args.verbose, **cli.accuracy(args))
    fr = cli.friction_summary(system, tr, args.friction)
    # (with friction the frictionless corner law is not the oracle: friction_summary's law is)
    rows, worst = impact_table(tr, body, e) if not fr else ([], 0.0)
    lines = [f"rectangle drop: {args.width:g} x {args.height:g}, m = {args.mass:g}, e = {e:g}, "
             f"friction {args.friction:g}, scheme {args.scheme}, N = {args.n}, T = {args.T:g} s"]
    if fr:
        lines += [f"{len(tr.impacts)} impacts ({sum(i.caught for i in tr.impacts)} caught, plastic)"] + cli.friction_lines(fr)
        lines += [f"  t = {i.t:.5f} s  {CORNER_NAMES[i.contact]:11s} θ = {i.q[2]:+.4f}  μ = {i.mu:.6g}  μ_t = {i.mu_t:+.6g}"
                  f"{'  (caught)' if i.caught else ''}" for i in tr.impacts[:8]]
    else:
        lines.append(f"{len(rows)} impacts ({sum(r['caught'] for r in rows)} caught, plastic); "
                     f"max |v⁺ - closed-form corner law| over the bounces = {worst:.2e}")
    for r in rows[:8]:
        law = "caught" if r["caught"] else f"law {r['mu_exact']:.6g}"
        lines.append(f"  t = {r['t']:.5f} s  {r['corner_name']:11s} θ = {r['angle']:+.4f}  μ = {r['mu']:.6g} "
                     f"({law})  v⁺ = {np.round(r['v_after'], 5).tolist()}")
    data = {"t": tr.t, "q": tr.q, "mu": tr.node_impulse, "mu_sub": tr.mu, "t_sub": tr.t_sub, "nu": tr.nu,
            "mass": body.mass, "width": body.width, "height": body.height, "restitution": e,
            "impacts": rows, "impact_law_error": worst, "energy": tr.energy, "gap": tr.gap.min(axis=1),
            "friction": args.friction, **fr}
    out = cli.contact_outcome("rectangle drop", system, tr, data, lines, ground=GROUND,
                              series={"c_y": tr.q[:, 1], "smallest corner gap": tr.gap.min(axis=1)})
    out.writers["plot"] = lambda path: figure(out, system).savefig(path)
    return out


#: The ground y = 0, as a polyline wider than any motion (plots clip it to their window).
GROUND = np.array([[-1e3, 0.0], [1e3, 0.0]])


def impact_panel(out, system, ground, ground_label: str) -> dict:
    """What the impacts panel draws (plotting.contact_plot's ``impacts``): the body's outline at each impact,
    the corner that struck, the centre's path and the ground (shared by this scene and the bowl)."""
    d = out.data
    imps = d["impacts"]
    qs = np.array([i["q"] for i in imps], float).reshape(-1, 3)
    outlines = system.positions(qs) if len(imps) else np.zeros((0, 5, 2))
    return {"outlines": list(outlines), "times": [i["t"] for i in imps], "ground": ground,
            "path": np.asarray(d["q"], float)[:, :2], "contacts": [o[i["contact"]] for o, i in zip(outlines, imps)],
            "ground_label": ground_label}


def figure(out, system):
    """The --plot picture: the body drawn at each impact over the ground (the corner that struck marked,
    the centroid's path under it), beside its height and smallest gap and the impulses against time."""
    from castrajectory.inspect import plotting
    d = out.data
    q = np.asarray(d["q"], float)
    return plotting.contact_plot(
        d["t"], {"c_y": q[:, 1], "smallest corner gap": d["gap"]}, d["t"], np.sum(d["mu"], axis=1),
        title="rectangle drop", impacts=impact_panel(out, system, GROUND, "ground y = 0"))


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
