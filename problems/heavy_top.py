"""Heavy symmetric top with a fixed pivot, by least action over the whole trajectory.

The orientation is a unit quaternion; gravity is the ordinary Gravity term on the centre
of mass's height, so the pivot and the weight compose with the rotation.  The discrete
Lagrangian is invariant under rotations about the vertical and about the symmetry axis, so
L_z and L₃ from the discrete Legendre transform are conserved to solver tolerance.  Tilt
(nutation) and precession are compared with Euler–Poisson integrated by CVODES.

    python problems/heavy_top.py --spin 100 --tilt 0.3 --T 2 --plot top.png
    python problems/heavy_top.py --precession 2.5 --animate top.gif
"""
import sys

import numpy as np

from castrajectory import cli
from castrajectory.baselines import rigidbody as euler
from castrajectory.inspect import rigidbody as readings
from castrajectory.models import rigidbody as rb
from castrajectory.solve import simulate
from castrajectory.validation import finite


def parser():
    p = cli.scene_parser("heavy_top.py", __doc__.splitlines()[0])
    p.add_argument("--mass", type=float, default=1.0, help="mass m (> 0)")
    p.add_argument("--inertia", type=float, nargs=2, metavar=("IT", "IA"), default=[0.002, 0.004],
                   help="transverse and axial moments about the centre of mass (> 0, IA <= 2 IT)")
    p.add_argument("--distance", type=float, default=0.1, help="pivot to centre of mass, along the axis (> 0)")
    p.add_argument("--g", type=float, default=9.81, help="gravity along -z (0 drops the gravity term)")
    p.add_argument("--tilt", type=float, default=0.3, help="initial angle of the axis from the vertical (rad)")
    p.add_argument("--spin", type=float, default=100.0, help="initial spin about the symmetry axis (rad/s)")
    p.add_argument("--precession", type=float, default=0.0, help="initial precession rate about z (rad/s)")
    p.add_argument("--reference", action="store_true",
                   help="also compare tilt and precession with Euler–Poisson (CVODES, rtol 1e-12)")
    cli.add_trajectory_flags(p, T=2.0, n=4000)
    return p


def initial_state(tilt: float, spin: float, precession: float):
    """``q₀`` = a tilt about x (z–x–z Euler angles ``(0, θ₀, 0)``) and ``q̇₀`` from ``ω = φ̇ e_z + ψ̇ a``."""
    q0 = rb.axis_angle([1.0, 0.0, 0.0], tilt)
    R = rb.rotation(q0)
    omega_space = precession * np.array([0.0, 0.0, 1.0]) + spin * R[:, 2]
    omega_body = R.T @ omega_space
    return q0, rb.quaternion_rate(q0, omega_body), omega_body


def reference(args, inertia, t):
    """Tilt and precession of Euler–Poisson (CVODES) at the times ``t``."""
    pivot = inertia.about(args.mass, [0.0, 0.0, args.distance])
    q0, _, w0 = initial_state(args.tilt, args.spin, args.precession)
    q, _ = euler.euler_reference(pivot.moments, q0, w0, t, weight=args.mass * args.g,
                                 com=[0.0, 0.0, args.distance])
    return rb.tilt_precession(q)


def run(args):
    cli.check_animation_path(args.animate)
    inertia = rb.Inertia(args.inertia[0], args.inertia[0], args.inertia[1])
    tilt, spin, prec = (finite(n, v) for n, v in (("tilt", args.tilt), ("spin", args.spin),
                                                   ("precession", args.precession)))
    # describe
    system = rb.heavy_top(args.mass, inertia, args.distance, args.g)
    q0, qd0, _ = initial_state(tilt, spin, prec)
    # discretise + solve
    res = simulate.simulate(system, q0, qd0, args.T, args.n, args.scheme, args.method,
                            options=cli.ipopt_options(args), verbose=args.verbose,
                            **cli.accuracy(args))
    # inspect
    r = readings.heavy_top(system, res)
    lines = [f"heavy top: m = {args.mass:g}, I = ({inertia.I1:g}, {inertia.I3:g}) about the centre of mass, "
             f"l = {args.distance:g}, g = {args.g:g}; tilt {tilt:g} rad, spin {spin:g} rad/s, "
             f"precession {prec:g} rad/s",
             f"tilt in [{r['tilt'].min():.6f}, {r['tilt'].max():.6f}] rad; precession at T "
             f"{r['precession'][-1]:.9f} rad",
             f"L_z drift {r['angular_momentum_vertical_drift']:.2e}, L₃ drift {r['angular_momentum_axis_drift']:.2e} "
             f"(relative); |q| - 1 at most {r['quaternion_norm_error']:.1e}"]
    extra = {"quaternion": res.q, **r}
    if args.reference and res.success:
        tilt_ref, prec_ref = reference(args, inertia, res.t)
        extra.update(tilt_error=float(abs(r["tilt"][-1] - tilt_ref[-1])),
                     precession_error=float(abs(r["precession"][-1] - prec_ref[-1])))
        lines.append(f"against Euler–Poisson (CVODES): tilt at T off by {extra['tilt_error']:.2e}, "
                     f"precession at T off by {extra['precession_error']:.2e} rad")
    out = cli.trajectory_outcome("heavy top", system, res, extra=extra, extra_lines=lines)

    def plot(path):
        from castrajectory.inspect import plotting
        fig = plotting.heavy_top_angles(res.t, r["tilt"], r["precession"],
                                        title=f"heavy top, {res.method}" + (f" {res.scheme}" if res.scheme else ""))
        fig.savefig(path)

    def animate(path):
        from castrajectory.inspect import plotting
        size = [0.8 * args.distance, 0.8 * args.distance, 0.15 * args.distance]
        centre = rb.rotation(res.q)[:, :, 2] * args.distance
        plotting.animate_rigid_body(res.t, rb.rotation(res.q), path, size, momentum=[0.0, 0.0, 1.0],
                                    center=centre, title="heavy top")

    out.writers.update(plot=plot, animate=animate)
    return out


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
