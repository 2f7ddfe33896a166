"""A box tumbling in a 3-D bowl z = (x² + y²)/(2R): SO(3) with translation, eight corner contacts, whole trajectory.

The seed's "body bouncing in a bowl" in 3-D.  The box's orientation is a unit quaternion (its norm a
holonomic constraint, as for the free body of dzhanibekov.py), its centre moves freely, gravity
acts along −z.  Each corner's gap is its height above the paraboloid, φ_j = z_j − (x_j² + y_j²)/(2R);
impulses act along Π∇φ_jᵀ (Π: M⁻¹ projected on the quaternion constraint) and impacts obey Newton
restitution e on the normal velocity.  With e = 1 the energy is conserved: the variational scheme
(--scheme) keeps it bounded between impacts and every impact conserves the kinetic energy exactly.

    python problems/bowl3d.py --T 2 --animate bowl3d.gif
    python problems/bowl3d.py --restitution 0.5 --omega 4 -2 6 --json
"""
import sys

import numpy as np

from castrajectory import cli
from castrajectory.models import rigidbody as rb
from castrajectory.solve import trajectory
from castrajectory.validation import InputError, finite, positive


def parser():
    p = cli.scene_parser("bowl3d.py", __doc__.splitlines()[0])
    p.add_argument("--mass", type=float, default=1.0, help="mass m (> 0)")
    p.add_argument("--size", type=float, nargs=3, default=[0.4, 0.3, 0.2], metavar=("W", "H", "D"),
                   help="the box's edges along its body axes (> 0)")
    p.add_argument("--radius", type=float, default=2.0, help="bowl radius of curvature R at the bottom (> 0)")
    p.add_argument("--position", type=float, nargs=3, default=[0.3, -0.2, 0.8], metavar=("X", "Y", "Z"),
                   help="initial centre of the box")
    p.add_argument("--axis", type=float, nargs=3, default=[1.0, 0.5, 0.2], metavar=("AX", "AY", "AZ"),
                   help="axis of the initial rotation from the body frame (not zero)")
    p.add_argument("--angle", type=float, default=0.4, help="angle of the initial rotation in rad")
    p.add_argument("--velocity", type=float, nargs=3, default=[0.0, 0.0, 0.0], metavar=("VX", "VY", "VZ"),
                   help="initial velocity of the centre")
    p.add_argument("--omega", type=float, nargs=3, default=[2.0, -1.0, 3.0], metavar=("W1", "W2", "W3"),
                   help="initial angular velocity in the body frame, rad/s")
    p.add_argument("--restitution", type=float, default=1.0, help="restitution coefficient e in [0, 1]")
    p.add_argument("--friction", type=float, default=0.0,
                   help="Coulomb friction at the corners, on the bowl's tangent plane (>= 0; 0: frictionless)")
    p.add_argument("--g", type=float, default=9.81, help="gravity along -z (0 drops the gravity term)")
    p.add_argument("--T", type=float, default=1.5, help="duration T in s (> 0)")
    p.add_argument("--n", type=int, default=1000, help="number of time steps N (>= 2)")
    cli.add_scheme(p)
    cli.add_accuracy(p)
    cli.add_plot(p)
    p.add_argument("--animate", metavar="PATH", help="write an animation (.gif, or .mp4 when ffmpeg is present)")
    return p


def initial_state(args):
    """``(q0, q̇0)``: centre and unit quaternion, velocity and the quaternion rate of the body rates."""
    axis = np.array([finite(f"axis {c}", v) for c, v in zip("xyz", args.axis)])
    if not np.any(axis != 0.0):
        raise InputError("axis must not be zero")
    quat = rb.axis_angle(axis, finite("angle", args.angle))
    c = [finite(f"position {a}", v) for a, v in zip("xyz", args.position)]
    v = [finite(f"velocity {a}", v) for a, v in zip("xyz", args.velocity)]
    w = np.array([finite(f"omega {i + 1}", v) for i, v in enumerate(args.omega)])
    return np.concatenate([c, quat]), np.concatenate([v, rb.quaternion_rate(quat, w)])


def run(args):
    cli.check_animation_path(args.animate)
    R = positive("radius", args.radius)
    mu = finite("friction", args.friction)
    if mu < 0:
        raise InputError(f"--friction must be >= 0 (got {mu:g})")
    system = rb.box_in_bowl(args.mass, args.size, R, finite("g", args.g), args.restitution, friction=mu)
    q0, qd0 = initial_state(args)
    tr = trajectory.solve_initial_value(system, q0, qd0, args.T, args.n, args.scheme,
                                        options=cli.ipopt_options(args), verbose=args.verbose, **cli.accuracy(args))
    names = system.contact.names
    drift = float(np.max(np.abs(tr.energy - tr.energy[0])))
    lines = [f"box {' x '.join(f'{s:g}' for s in args.size)} in the bowl z = (x² + y²)/(2R), R = {R:g}, "
             f"e = {args.restitution:g}, scheme {args.scheme}, N = {args.n} ({len(tr.t) - 1} steps after "
             f"refinement), T = {args.T:g} s",
             f"{len(tr.impacts)} impacts; energy drift max |E - E0| = {drift:.2e}; "
             f"|quaternion| - 1 at most {np.max(np.abs(np.linalg.norm(tr.q[:, 3:], axis=1) - 1)):.1e}"]
    fr = cli.friction_summary(system, tr, mu)
    lines += cli.friction_lines(fr)
    for imp in tr.impacts[:6]:
        lines.append(f"  t = {imp.t:.5f} s  corner {names[imp.contact]}  μ = {imp.mu:.6g}"
                     + ("  (caught)" if imp.caught else ""))
    data = {"t": tr.t, "position": tr.q[:, :3], "quaternion": tr.q[:, 3:], "q": tr.q,
            "gap": tr.gap.min(axis=1), "mu": tr.node_impulse, "mu_sub": tr.mu, "t_sub": tr.t_sub,
            "energy": tr.energy, "radius": R, "corners": names, "friction": mu, **fr,
            "impacts": [{"t": i.t, "corner": names[i.contact], "contact": i.contact, "mu": i.mu,
                         "q": i.q, "v_before": i.v_before, "v_after": i.v_after, "caught": i.caught, "mu_t": i.mu_t}
                        for i in tr.impacts]}
    out = cli.contact_outcome("box in a 3-D bowl", system, tr, data, lines)

    def animate(path):
        from castrajectory.inspect import plotting
        xs = np.linspace(-1.5, 1.5, 25) * max(np.max(np.abs(tr.q[:, :2])) + max(args.size), 0.5)
        X, Y = np.meshgrid(xs, xs)
        plotting.animate_rigid_body(tr.t, rb.rotation(tr.q[:, 3:]), path, args.size, center=tr.q[:, :3],
                                    title="box in a 3-D bowl", surface=(X, Y, (X ** 2 + Y ** 2) / (2 * R)))

    out.writers["animate"] = animate
    return out


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
