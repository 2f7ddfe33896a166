"""Droplet on a table: minimise interface energy at fixed area (Exercise 2.1).

Solves the discretised free-surface problem with Ipopt and compares it with the
analytic circular cap (Young's angle, Laplace pressure).  ``--span A_FIXED``
pins the contact span instead of leaving it free.

    python problems/droplet.py                       # default scene, summary table
    python problems/droplet.py --json                # one JSON object on stdout
    python problems/droplet.py --formulation graph --n 2000 --plot drop.png
"""
import math
import sys

from castrajectory import cli
from castrajectory.solve import droplet
from castrajectory.inspect import plotting


def parser():
    p = cli.scene_parser("droplet.py", __doc__.splitlines()[0])
    p.add_argument("--gamma-gl", type=float, default=1.0, help="liquid–gas tension γ_gl (> 0)")
    p.add_argument("--gamma-sl", type=float, default=0.5, help="solid–liquid tension γ_sl")
    p.add_argument("--gamma-sg", type=float, default=1.0, help="solid–gas tension γ_sg")
    p.add_argument("--area", type=float, default=1.0, help="drop area A (> 0)")
    p.add_argument("--n", type=int, default=400, help="number of segments N (>= 3)")
    p.add_argument("--formulation", choices=droplet.FORMULATIONS, default="curve",
                   help="curve: polyline, any angle; graph: y(x), angles below 90°")
    p.add_argument("--span", type=float, default=None, metavar="A_FIXED",
                   help="pin the contact span to this value (fixed-span mode)")
    cli.add_plot(p)
    return p


def run(args):
    # describe
    drop = droplet.Droplet(args.gamma_gl, args.gamma_sl, args.gamma_sg, args.area, args.span)
    # discretise + solve
    sol = droplet.solve(drop, args.n, args.formulation, options=cli.ipopt_options(args), verbose=args.verbose)
    # inspect
    cap, e = sol.analytic, sol.errors
    deg = math.degrees
    summary = cli.table([
        ["quantity", "discrete", "analytic", "error"],
        ["contact angle (deg)", cli.fmt(deg(sol.contact_angle)), cli.fmt(deg(cap.contact_angle)),
         cli.fmt(deg(e["contact_angle"]), ".3e")],
        ["span a", cli.fmt(sol.span), cli.fmt(cap.span), cli.fmt(e["span"], ".3e") + " rel"],
        ["pressure (area multiplier)", cli.fmt(sol.pressure), cli.fmt(cap.pressure),
         cli.fmt(e["pressure"], ".3e") + " rel"],
        ["energy", cli.fmt(sol.energy), cli.fmt(cap.energy), cli.fmt(e["energy"], ".3e") + " rel"],
        ["radius", "", cli.fmt(cap.radius), ""],
        ["shape (max dist / R)", "", "", cli.fmt(e["shape"], ".3e")],
    ])
    mode = "free span" if drop.span is None else f"pinned span a = {drop.span:g}"
    young = ("Young residual γ_gl cos θ + γ_sl − γ_sg = " + cli.fmt(sol.young_residual, ".3e")
             if sol.young_residual is not None else "Young's law does not apply: the span is pinned")
    summary = [f"droplet: {sol.formulation} formulation, N = {sol.n}, {mode}", *summary, young,
               cli.status_line(sol.status, sol)]
    return cli.Outcome.of(sol, summary=summary, writers={"plot": lambda path: plotting.droplet_shape(sol, path)})


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
