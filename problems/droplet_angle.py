"""Droplet reduced to its contact angle: minimise E(θ) as a one-variable NLP.

The cap of half-angle θ and area A has R(θ) = sqrt(A / (θ − sin 2θ / 2)),
span a = 2R sin θ and arc length S = 2Rθ; E(θ) = γ_gl S + (γ_sl − γ_sg) a is
built as a CasADi graph and minimised by Ipopt.  The minimiser must satisfy
Young's equation γ_gl cos θ + γ_sl − γ_sg = 0.

    python problems/droplet_angle.py --json
    python problems/droplet_angle.py --gamma-sl 1.2 --plot energy.png
"""
import math
import sys

from castrajectory import cli
from castrajectory.solve import droplet
from castrajectory.inspect import plotting


def parser():
    p = cli.scene_parser("droplet_angle.py", __doc__.splitlines()[0])
    p.add_argument("--gamma-gl", type=float, default=1.0, help="liquid–gas tension γ_gl (> 0)")
    p.add_argument("--gamma-sl", type=float, default=0.5, help="solid–liquid tension γ_sl")
    p.add_argument("--gamma-sg", type=float, default=1.0, help="solid–gas tension γ_sg")
    p.add_argument("--area", type=float, default=1.0, help="drop area A (> 0)")
    cli.add_plot(p)
    return p


def run(args):
    drop = droplet.Droplet(args.gamma_gl, args.gamma_sl, args.gamma_sg, args.area)
    sol = droplet.solve_angle(drop, options=cli.ipopt_options(args), verbose=args.verbose)
    young = droplet.young_angle(drop.gamma_gl, drop.gamma_sl, drop.gamma_sg)
    summary = [
        "droplet_angle: reduced problem min E(θ)",
        *cli.table([
            ["quantity", "Ipopt", "analytic"],
            ["contact angle (deg)", cli.fmt(math.degrees(sol.contact_angle), ".12g"),
             cli.fmt(math.degrees(young), ".12g")],
            ["radius", cli.fmt(sol.radius), cli.fmt(math.sqrt(drop.area / droplet.segment_area_factor(young)))],
            ["span", cli.fmt(sol.span), ""],
            ["energy", cli.fmt(sol.energy), ""],
        ]),
        f"Young residual γ_gl cos θ + γ_sl − γ_sg = {sol.young_residual:.3e}",
        cli.status_line(sol.status, sol),
    ]
    return cli.Outcome.of(sol, summary=summary, writers={"plot": lambda path: plotting.reduced_energy(sol, path)})


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
