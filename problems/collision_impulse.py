"""Rectangle corner hits the ground: impulse along M⁻¹Jᵀ, closed form (Exercise 2.2).

A uniform w × h rectangle, q = (c_x, c_y, θ), touches y = 0 with a body point
d (default: the lower-left corner).  The impulse μ ≥ 0 changes the velocity by
μ M⁻¹Jᵀ = μ·(0, 1/m, (d_x cos θ − d_y sin θ)/I), where J = ∂y/∂q is derived with
CasADi.  Restitution e reverses the corner's normal velocity, J v⁺ = −e J v⁻;
with e = 1 the kinetic energy is conserved.

    python problems/collision_impulse.py --json
    python problems/collision_impulse.py --angle 0 --vx 0 --omega 0 --restitution 0
"""
import sys
import time

import numpy as np

from castrajectory import cli
from castrajectory.models import collision
from castrajectory.validation import InputError, finite


def parser():
    p = cli.scene_parser("collision_impulse.py", __doc__.splitlines()[0])
    p.add_argument("--mass", type=float, default=1.0, help="mass m (> 0)")
    p.add_argument("--width", type=float, default=2.0, help="width w (> 0)")
    p.add_argument("--height", type=float, default=1.0, help="height h (> 0)")
    p.add_argument("--angle", type=float, default=0.3, help="rotation angle θ in rad")
    p.add_argument("--corner", type=float, nargs=2, metavar=("DX", "DY"), default=None,
                   help="contact point in the body frame (default: lower-left corner (-w/2, -h/2))")
    p.add_argument("--vx", type=float, default=1.0, help="pre-impact centroid velocity v_x")
    p.add_argument("--vy", type=float, default=-2.0, help="pre-impact centroid velocity v_y")
    p.add_argument("--omega", type=float, default=0.0, help="pre-impact angular velocity ω in rad/s")
    p.add_argument("--restitution", type=float, default=1.0, help="restitution coefficient e in [0, 1]")
    return p


def run(args):
    body = collision.Body(args.mass, args.width, args.height)
    m, w, h = body.mass, body.width, body.height
    theta = finite("angle", args.angle)
    v = [finite("vx", args.vx), finite("vy", args.vy), finite("omega", args.omega)]
    corner = None if args.corner is None else [finite("corner DX", args.corner[0]),
                                               finite("corner DY", args.corner[1])]
    if corner is not None and (abs(corner[0]) > w / 2 * (1 + 1e-12)
                               or abs(corner[1]) > h / 2 * (1 + 1e-12)):
        raise InputError(f"the contact point ({corner[0]:g}, {corner[1]:g}) lies outside the "
                         f"{w:g} x {h:g} body (|DX| <= w/2, |DY| <= h/2)")
    e = collision.restitution(args.restitution)

    t0 = time.perf_counter()
    fn = collision.admissible_direction_function()
    build = time.perf_counter() - t0
    t0 = time.perf_counter()
    imp = collision.corner_impact(body, theta, np.array(v), e, None if corner is None else np.array(corner))
    solve = time.perf_counter() - t0
    derived = np.asarray(fn([0.0, 0.0, theta], imp.corner, m, imp.inertia)).reshape(-1)
    mismatch = float(np.max(np.abs(derived - imp.direction)))

    dx, dy = imp.corner
    arm = dx * np.cos(theta) - dy * np.sin(theta)
    vb, va = imp.v_before, imp.v_after
    cb, ca_ = imp.point_velocity(vb), imp.point_velocity(va)
    f = cli.fmt
    summary = [
        f"collision_impulse: {w:g} x {h:g} rectangle, m = {m:g}, I = {f(imp.inertia)}, θ = {theta:g}, "
        f"contact point d = ({dx:g}, {dy:g}), e = {e:g}",
        *cli.table([
            ["quantity", "before", "after"],
            ["v_x", f(vb[0]), f(va[0])],
            ["v_y", f(vb[1]), f(va[1])],
            ["ω", f(vb[2]), f(va[2])],
            ["corner velocity x", f(cb[0]), f(ca_[0])],
            ["corner velocity y (J v)", f(cb[1]), f(ca_[1])],
            ["kinetic energy", f(imp.ke_before), f(imp.ke_after)],
            ["impulse μ", "", f(imp.mu)],
        ]),
        f"admissible Δv = μ·(0, 1/m, (d_x cos θ − d_y sin θ)/I)"
        f" = μ·(0, 1/{m:g}, {arm:.10g}/{imp.inertia:.10g})"
        f" = μ·({imp.direction[0]:.10g}, {imp.direction[1]:.10g}, {imp.direction[2]:.10g})",
        f"CasADi-derived M⁻¹(∂y/∂q)ᵀ − closed form: max |diff| = {mismatch:.1e}; "
        f"J v⁺ + e J v⁻ = {imp.normal_velocity_after + e * imp.normal_velocity_before:.1e}; "
        f"KE after − before = {imp.ke_after - imp.ke_before:.3e}",
        f"status: ok (closed form, no Ipopt solve); build {build:.3f} s, solve {solve:.4f} s",
    ]
    data = {**imp.as_dict(), "admissible_direction_casadi": derived, "admissible_direction_mismatch": mismatch}
    return cli.Outcome(success=True, message="closed form, no Ipopt solve", iterations=0, build_time_s=build,
                       solve_time_s=solve, data=data, summary=summary)


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
