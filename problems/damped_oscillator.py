"""Damped, driven oscillator by the Lagrange–d'Alembert principle over the whole trajectory.

``m ẍ + c ẋ + k x = A cos(Ωt)``: the Lagrangian ``½ m ẋ² − ½ k x²``, the Rayleigh damping ``½ c ẋ²``
and the drive ``A cos(Ωt)`` as a force.  The discrete forces are the scheme's quadrature of the
virtual work, so every scheme keeps its order; the answer is compared with the closed form
(under-, critically or over-damped, at resonance too) and the energy balance
``E(t) − E(0) − W(t)`` (W: the work of damping and drive) is printed.

    python problems/damped_oscillator.py
    python problems/damped_oscillator.py --damping 0 --drive-amplitude 0.5 --drive-frequency 2 --T 30
    python problems/damped_oscillator.py --scheme galerkin8 --n 100 --json
"""
import sys

import numpy as np

from castrajectory import cli
from castrajectory.inspect import plotting
from castrajectory.models import oscillator
from castrajectory.validation import InputError


def parser():
    p = cli.scene_parser("damped_oscillator.py", __doc__.splitlines()[0])
    p.add_argument("--mass", type=float, default=1.0, help="mass m (> 0)")
    p.add_argument("--stiffness", type=float, default=4.0, help="spring constant k (>= 0; 0 drops the spring)")
    p.add_argument("--damping", type=float, default=0.3, help="damping coefficient c (>= 0; 0 drops the term)")
    p.add_argument("--drive-amplitude", type=float, default=0.5, help="drive amplitude A (0 drops the drive)")
    p.add_argument("--drive-frequency", type=float, default=1.7, help="drive angular frequency Ω (rad/s)")
    p.add_argument("--x0", type=float, default=1.0, help="initial position")
    p.add_argument("--v0", type=float, default=0.0, help="initial velocity")
    cli.add_trajectory_flags(p, T=10.0, n=200)
    return p


def check(args):
    """The scene's parameters, checked at the edge (exit 2 with one line)."""
    cli.finite_flags(args, "mass", "stiffness", "damping", "drive_amplitude", "drive_frequency", "x0", "v0")
    if args.mass <= 0:
        raise InputError(f"--mass must be positive (got {args.mass:g})")
    if args.stiffness < 0:
        raise InputError(f"--stiffness must not be negative (got {args.stiffness:g})")
    if args.damping < 0:
        raise InputError(f"--damping must not be negative (got {args.damping:g}): a negative damping feeds energy in")


def run(args):
    check(args)
    cli.check_animation_path(args.animate)
    if args.animate:
        raise InputError("the oscillator has no points to animate; use --plot")
    # describe
    par = (args.mass, args.stiffness, args.damping, args.drive_amplitude, args.drive_frequency)
    system = oscillator.damped_oscillator(*par)
    # discretise + solve
    res = cli.solve_trajectory(system, [args.x0], [args.v0], args)
    # inspect
    x, v = oscillator.exact(res.t, *par, args.x0, args.v0)
    err = float(np.max(np.abs(res.q[:, 0] - x))) if res.success else float("nan")
    verr = float(np.max(np.abs(res.v[:, 0] - v))) if res.success else float("nan")
    regime = _regime(*par)
    lines = [f"{regime}; max |x - exact| over the nodes = {err:.3e}, max |v - exact| = {verr:.3e}"]
    out = cli.trajectory_outcome("damped oscillator", system, res, extra={
        "error_vs_exact": err, "velocity_error_vs_exact": verr, "regime": regime, "x_exact": x}, extra_lines=lines)
    out.writers["plot"] = lambda path: figure(out).savefig(path)
    return out


def _regime(m, k, c, A, W) -> str:
    disc = (c / (2 * m)) ** 2 - k / m
    kind = "undamped" if c == 0 else ("underdamped" if disc < 0 else "critically damped" if disc == 0 else "overdamped")
    if A == 0:
        return kind + ", free"
    res = " at resonance" if abs(m * W * W - k) <= 1e-12 * max(k, 1.0) else ""
    return f"{kind}, driven{res}"


def figure(out):
    """The --plot picture: x(t) over the closed form, and the energy balance's error."""
    d = out.data
    t, q = np.asarray(d["t"], float), np.asarray(d["q"], float)
    e, w = np.asarray(d["energy"], float), np.asarray(d["work"], float)
    how = f"{d['method']}" + (f", {d['scheme']}" if d["scheme"] else "")
    return plotting.trajectory_plot(t, np.column_stack([q[:, 0], d["x_exact"]]), ["x", "closed form"],
                                    panels=[("position", [0, 1])], energies={how: e - w},
                                    title=f"damped oscillator ({how}, {d['regime']})")


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
