"""A rectangle bouncing in a bowl y = x²/(2R): curved ground, four corner contacts, whole trajectory.

The seed's example of a body in a bowl.  Each corner's gap is its height
above the bowl, φ_j = y_j − x_j²/(2R) ≥ 0; impulses act along M⁻¹∇φ_jᵀ and
impacts obey Newton restitution e on ∇φ_j q̇.  With e = 1 the energy is
conserved (the variational scheme, --scheme, keeps it bounded between impacts,
and each impact conserves kinetic energy exactly).

    python problems/bowl.py --T 4 --animate bowl.gif
"""
import sys

import numpy as np

from castrajectory import cli
from castrajectory.models import collision
from castrajectory.solve import trajectory
from castrajectory.problems.rectangle_drop import add_body_flags, friction, impact_panel, initial_state
from castrajectory.validation import finite, positive


def parser():
    p = cli.scene_parser("bowl.py", __doc__.splitlines()[0])
    add_body_flags(p, 0.4, 0.2, 0.5, 0.6, 0.2, 0.0, 0.0, 0.0, T=3.0, n=1500)
    p.add_argument("--radius", type=float, default=2.0, help="bowl radius of curvature R at the bottom (> 0)")
    return p


def run(args):
    cli.check_animation_path(args.animate)
    R = positive("radius", args.radius)
    body = collision.Body(args.mass, args.width, args.height)
    system = collision.rectangle_contact_system(body, finite("g", args.g), args.restitution, collision.bowl_ground(R),
                                                friction(args))
    q0, qd0 = initial_state(args)
    tr = trajectory.solve_initial_value(system, q0, qd0, args.T, args.n, args.scheme,
                                        options=cli.ipopt_options(args), verbose=args.verbose, **cli.accuracy(args))
    lines = [f"bowl: R = {R:g}, body {args.width:g} x {args.height:g}, e = {args.restitution:g}, "
             f"scheme {args.scheme}, N = {args.n}, T = {args.T:g} s",
             f"{len(tr.impacts)} impacts; energy drift max |E - E0| = {np.max(np.abs(tr.energy - tr.energy[0])):.2e}"]
    fr = cli.friction_summary(system, tr, args.friction)
    lines += cli.friction_lines(fr)
    for imp in tr.impacts[:6]:
        lines.append(f"  t = {imp.t:.5f} s  {system.contact.names[imp.contact]:11s} μ = {imp.mu:.6g}")
    data = {"t": tr.t, "q": tr.q, "gap": tr.gap.min(axis=1), "mu": tr.node_impulse, "mu_sub": tr.mu,
            "t_sub": tr.t_sub, "energy": tr.energy, "radius": R, "friction": args.friction, **fr,
            "impacts": [{"t": i.t, "corner": system.contact.names[i.contact], "contact": i.contact, "mu": i.mu,
                         "q": i.q, "v_before": i.v_before, "v_after": i.v_after, "caught": i.caught, "mu_t": i.mu_t}
                        for i in tr.impacts]}
    out = cli.contact_outcome("body in a bowl", system, tr, data, lines, ground=bowl_curve(R))
    out.writers["plot"] = lambda path: figure(out, system).savefig(path)
    return out


def bowl_curve(R, n=2401):
    """The bowl y = x²/(2R) as a polyline over |x| ≤ 3R."""
    xs = np.linspace(-3 * R, 3 * R, n)
    return np.stack([xs, xs ** 2 / (2 * R)], axis=1)


def figure(out, system):
    """The --plot picture: the body drawn at each impact over the bowl (the corner that struck marked,
    the centre's path under it), beside the smallest gap and the impulses against time."""
    from castrajectory.inspect import plotting
    d = out.data
    return plotting.contact_plot(
        d["t"], {"smallest gap": d["gap"]}, d["t"], np.sum(d["mu"], axis=1), title="body in a bowl",
        impacts=impact_panel(out, system, bowl_curve(d["radius"]), "bowl y = x²/(2R)"))


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
