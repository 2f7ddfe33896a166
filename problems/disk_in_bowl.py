"""Disk in a bowl: a disk rocks inside a circular bowl, rolling or sliding under Coulomb friction, against its
references.

A uniform disk (mass m, radius r) lies inside a circular bowl of radius R, let go from rest at the angle φ₀ from the
bottom.  Where the friction holds it (μ ≥ tan φ₀ / 3) it rolls: (3/2)(R − r) φ̈ = −g sin φ, integrated here by
Gragg–Bulirsch–Stoer extrapolation of order 16 (``baselines.events.gbs_step``).  With a small μ it slides, its slip
reversing, stopping and starting again; the reference is then the event-driven integrator of
``baselines.events``, which locates each of those events to rounding.  The contact is held at the scheme's stages with
its friction there, and every stop, reversal and start is timed inside its step (docs/derivations.md, "Contact
trajectories", §7).

    python problems/disk_in_bowl.py
    python problems/disk_in_bowl.py --mu 0.05 --T 5 --n 500 --json
"""
import math
import sys

import numpy as np

from castrajectory import cli
from castrajectory.baselines.events import event_driven, gbs_step
from castrajectory.inspect import plotting
from castrajectory.models import held
from castrajectory.solve import trajectory
from castrajectory.validation import InputError


def parser():
    p = cli.scene_parser("disk_in_bowl.py", __doc__.splitlines()[0])
    p.add_argument("--mu", type=float, default=1.0, help="friction coefficient (> 0)")
    p.add_argument("--phi0", type=float, default=0.5, help="the start's angle from the bottom in rad, in (0, pi/2)")
    p.add_argument("--radius", type=float, default=0.2, help="the disk's radius r (> 0)")
    p.add_argument("--bowl", type=float, default=1.0, help="the bowl's radius R (> r)")
    p.add_argument("--mass", type=float, default=1.0, help="mass m (> 0)")
    p.add_argument("--g", type=float, default=9.81, help="gravity (> 0)")
    p.add_argument("--T", type=float, default=2.0, help="duration T in s (> 0)")
    p.add_argument("--n", type=int, default=100, help="number of time steps N (>= 2)")
    cli.add_scheme(p, default="galerkin4")
    cli.add_accuracy(p)
    cli.add_plot(p)
    p.add_argument("--animate", metavar="PATH", help="write an animation (.gif, or .mp4 when ffmpeg is present)")
    return p


def rolling_reference(t, phi0, radius, bowl, g):
    """The rolling disk's ``(φ, θ)`` at the times ``t``: (3/2)(R − r) φ̈ = −g sin φ from rest at φ₀ by GBS steps of at
    most 1 ms, θ = −(R − r)(φ − φ₀)/r."""
    Rr = bowl - radius
    f = lambda y: np.array([y[1], -g * math.sin(y[0]) / (1.5 * Rr)])  # noqa: E731
    y, now, out = np.array([phi0, 0.0]), 0.0, []
    for tt in np.asarray(t, float):
        while now < tt:
            H = min(1e-3, tt - now)
            y, now = gbs_step(f, y, H), now + H
        out.append(y[0])
    phi = np.array(out)
    return phi, -Rr * (phi - phi0) / radius


def run(args):
    cli.check_animation_path(args.animate)
    cli.finite_flags(args, "mu", "phi0", "radius", "bowl", "mass", "g", "T")
    if args.mu <= 0:
        raise InputError(f"--mu must be positive (got {args.mu:g})")
    if not 0 < args.phi0 < math.pi / 2:
        raise InputError(f"--phi0 must lie in (0, pi/2) rad (got {args.phi0:g})")
    for flag in ("radius", "mass", "g", "T"):
        if getattr(args, flag) <= 0:
            raise InputError(f"--{flag} must be positive (got {getattr(args, flag):g})")
    if args.bowl <= args.radius:
        raise InputError(f"--bowl must exceed --radius (got R = {args.bowl:g}, r = {args.radius:g})")
    system = held.disk_in_bowl(args.mass, args.radius, args.bowl, args.g, args.mu)
    q0, qd0 = held.disk_start(args.phi0, args.radius, args.bowl)
    tr = trajectory.solve_initial_value(system, q0, qd0, args.T, args.n, args.scheme, options=cli.ipopt_options(args),
                                        verbose=args.verbose, **cli.accuracy(args))
    rolls = held.disk_rolls(args.phi0, args.mu)
    events, events_ref = sorted((t, k) for t, _, k in (tr.slip_turns or [])), []
    if rolls:
        phi, theta = rolling_reference(tr.t, args.phi0, args.radius, args.bowl, args.g)
        Rr = args.bowl - args.radius
        qref = np.stack([Rr * np.sin(phi), -Rr * np.cos(phi), theta], axis=1)
        how = "the rolling disk's reduced equation"
    else:
        ref = event_driven(system, np.array(q0), np.array(qd0), args.T)
        qref = np.array([ref.state(t)[0] for t in tr.t])
        events_ref = sorted(s.t for s in ref.switches if s.kind in ("stop", "slip"))
        how = "the event-driven reference"
    err = float(np.max(np.abs(tr.q - qref)))
    ev_err = (max(abs(a - b) for (a, _), b in zip(events, events_ref))
              if events and len(events) == len(events_ref) else None)
    data = {"rolls": rolls, "error_vs_reference": err, "reference": how, "slip_events": [[t, k] for t, k in events],
            "slip_events_reference": events_ref, "slip_event_error": ev_err, "energy": tr.energy}
    lines = [f"disk in a bowl: μ = {args.mu:g}, φ₀ = {args.phi0:g} rad, r = {args.radius:g} m, R = {args.bowl:g} m, "
             f"scheme {args.scheme}, N = {args.n}, T = {args.T:g} s",
             f"{'rolls throughout' if rolls else 'slides'}: max |q − q_ref| = {err:.2e} against {how}",
             *([f"slip events (timed in their steps): {', '.join(f'{k} {t:.9g} s' for t, k in events)}"
                + (f"; worst against the reference {ev_err:.2e} s" if ev_err is not None else "")] if events else []),
             *cli.interval_lines(system, tr),
             cli.status_line(tr.status, tr)]

    def plot(path):
        phi = np.arctan2(tr.q[:, 0], -tr.q[:, 1])
        phi_ref = np.arctan2(qref[:, 0], -qref[:, 1])
        fig = plotting.contact_plot(tr.t, {"φ (discrete)": phi}, tr.t, tr.node_impulse[:, 0],
                                    reference={"φ reference": (tr.t, phi_ref)}, ylabel="φ (rad)",
                                    title=f"disk in a bowl, μ = {args.mu:g}: the bowl's impulses below",
                                    intervals=cli.contact_intervals(system, tr))
        fig.savefig(path)

    def animate(path):
        a = np.linspace(-math.pi / 2 - 1.2, -math.pi / 2 + 1.2, 80)
        bowl = np.stack([args.bowl * np.cos(a), args.bowl * np.sin(a)], axis=1)
        plotting.animate_points(system.positions(tr.q), tr.t, path, links=True, pivot=None, trail=False, ground=bowl,
                                title="disk in a bowl")

    return cli.Outcome.of(tr, {**cli.state_keys(system, tr), **data}, lines, writers={"plot": plot, "animate": animate})


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
