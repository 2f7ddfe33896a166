"""Droplet on a table: minimise interface energy at fixed area (Exercise 2.1).

Solves the discretised free-surface problem with Ipopt and compares it with the
analytic circular cap (Young's angle, Laplace pressure).  ``--span A_FIXED``
pins the contact span instead of leaving it free.  ``--gravity RHO_G`` adds the
drop's weight (the oracle is then the heavy drop in elliptic integrals, and the
area multiplier the pressure at the table); ``--pendant`` hangs it under a
ceiling: beyond the fold of the pendant family there is no stable drop, and the
run says so and exits 1.  ``--axisymmetric`` makes it a drop of revolution
(3-D; ``--area`` is then its volume): a spherical cap without gravity, the
Young–Laplace profile with it.  ``--pattern W GAMMA_SL_OUT`` puts the drop on a
patterned table: γ_sl on a strip of width W under the drop (a disc of diameter W
for a drop of revolution), GAMMA_SL_OUT outside it; the drop sits inside the
pattern, pinned at its edge (Gibbs' criterion) or spread beyond it.

    python problems/droplet.py                       # default scene, summary table
    python problems/droplet.py --json                # one JSON object on stdout
    python problems/droplet.py --formulation graph --n 2000 --plot drop.png
    python problems/droplet.py --gravity 1 --gamma-sl 1 --area 2 --pendant
    python problems/droplet.py --axisymmetric --gravity 1 --gamma-sl 1 --area 10
    python problems/droplet.py --pattern 1 1.5 --area 0.5 --json
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
    p.add_argument("--n", type=int, default=400,
                   help="number of segments N (>= 3); with --formulation spectral, the degree (4 to 200; 12-32 "
                        "reach rounding for a drop a few capillary lengths across)")
    p.add_argument("--formulation", choices=droplet.FORMULATIONS, default="curve",
                   help="curve: polyline, any angle; graph: y(x), angles below 90°; spectral: the tangent angle a "
                        "polynomial of degree --n (any angle, converges faster than any power; not on a pattern)")
    p.add_argument("--span", type=float, default=None, metavar="A_FIXED",
                   help="pin the contact span to this value (fixed-span mode)")
    p.add_argument("--gravity", type=float, default=0.0, metavar="RHO_G",
                   help="weight density ρg (>= 0; capillary length sqrt(γ_gl/ρg)); 0: the weightless drop")
    p.add_argument("--pendant", action="store_true",
                   help="reverse gravity: the drop hangs under a ceiling (needs --gravity > 0)")
    p.add_argument("--axisymmetric", action="store_true",
                   help="a drop of revolution (3-D): --area is then its volume; curve or spectral formulation")
    p.add_argument("--pattern", type=float, nargs=2, default=None, metavar=("W", "GAMMA_SL_OUT"),
                   help="a patterned table: γ_sl on a strip of width W (> 0) under the drop, GAMMA_SL_OUT "
                        "(> γ_sl: less wettable) outside it; weightless drops")
    cli.add_plot(p)
    return p


def _size(sol) -> str:
    """``N = ...`` segments, or the spectral profile's degree."""
    return f"degree {sol.n}" if sol.formulation == "spectral" else f"N = {sol.n}"


def run(args):
    # describe
    width, gamma_out = args.pattern if args.pattern is not None else (None, None)
    drop = droplet.Droplet(args.gamma_gl, args.gamma_sl, args.gamma_sg, args.area, args.span, args.gravity,
                           args.pendant, args.axisymmetric, width, gamma_out)
    # discretise + solve
    sol = droplet.solve(drop, args.n, args.formulation, options=cli.ipopt_options(args), verbose=args.verbose)
    # inspect
    if drop.patterned:
        return _pattern_outcome(sol)
    if drop.axisymmetric:
        return _revolution_outcome(sol)
    if drop.rho_g > 0.0:
        return _heavy_outcome(sol)
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
    summary = [f"droplet: {sol.formulation} formulation, {_size(sol)}, {mode}", *summary, young,
               cli.status_line(sol.status, sol)]
    return cli.Outcome.of(sol, summary=summary, writers={"plot": lambda path: plotting.droplet_shape(sol, path)})


def _heavy_outcome(sol):
    """The summary of a drop under gravity: its readings against the closed form (when there is one)."""
    drop, cap, e = sol.drop, sol.analytic, sol.errors
    deg = math.degrees
    kind = "pendant (under a ceiling)" if drop.pendant else "sessile"
    head = [f"droplet under gravity, {kind}: {sol.formulation} formulation, {_size(sol)}, ρg = {drop.rho_g:g}, "
            f"l_c = {drop.capillary_length:.6g}, Bond number A/l_c² = {drop.bond_number:.6g}"]
    fold = (sol.stability or {}).get("fold")
    if fold is not None:
        rows = [["fold of the pendant family", "discrete", "closed form", "error"],
                ["largest stable area A*", cli.fmt(fold["area"]), cli.fmt(fold["analytic_area"]),
                 cli.fmt(e.get("fold_area"), ".3e") + " rel"],
                ["first area refused", cli.fmt(fold["refused_area"]), "", ""],
                ["A* extrapolated (λ_min² → 0)", cli.fmt(fold["extrapolated_area"]), "", ""]]
        return cli.Outcome.of(sol, summary=head + cli.table(rows) + [cli.status_line(sol.status, sol)],
                              writers={"plot": lambda path: plotting.droplet_shape(sol, path)})

    def row(name, mine, key, rel=True):
        ref = None if cap is None else getattr(cap, key)
        err = e.get("pressure" if key == "pressure_at_table" else key)
        scale = deg if key == "contact_angle" else (lambda v: v)
        return [name, cli.fmt(scale(mine)), cli.fmt(None if ref is None else scale(ref)),
                "" if err is None else cli.fmt(scale(err), ".3e") + (" rel" if rel else "")]

    rows = [["quantity", "discrete", "closed form", "error"],
            row("contact angle (deg)", sol.contact_angle, "contact_angle", rel=False),
            row("height h", sol.height, "height"),
            row("span a", sol.span, "span"),
            row("apex curvature κ_a", sol.apex_curvature, "apex_curvature"),
            row("pressure at the table (area multiplier)", sol.pressure_at_table, "pressure_at_table"),
            row("energy", sol.energy, "energy"),
            ["shape (max dist / h)", "", "", "" if "shape" not in e else cli.fmt(e["shape"], ".3e")]]
    lines = head + cli.table(rows)
    lines.append("P = γκ_a " + ("−" if drop.pendant else "+") + " ρg h from the discrete readings: "
                 + cli.fmt(drop.gamma_gl * sol.apex_curvature + drop.gravity_sign * drop.rho_g * sol.height))
    if not drop.pendant:
        lines.append(f"puddle limit of the height, 2 l_c sin(θ/2) = {cli.fmt(droplet.puddle_height(drop))}")
    hess = (sol.stability or {}).get("reduced_hessian")
    if hess is not None:
        lines.append(f"stability: reduced Hessian Zᵀ∇²L Z {'positive definite' if hess['positive_definite'] else 'indefinite'}"
                     f" (smallest eigenvalue {hess['min_eigenvalue']:.3e}, dimension {hess['dimension']}): "
                     + ("a stable drop" if hess["positive_definite"] else "not a minimum"))
    lines.append(cli.status_line(sol.status, sol))
    return cli.Outcome.of(sol, summary=lines, writers={"plot": lambda path: plotting.droplet_shape(sol, path)})


def _revolution_outcome(sol):
    """The summary of a drop of revolution: its readings against the spherical cap or the Young–Laplace shooting."""
    drop, cap, e = sol.drop, sol.analytic, sol.errors
    plot = {"plot": lambda path: plotting.droplet_shape(sol, path)}
    kind = ("pendant (under a ceiling)" if drop.pendant else "sessile") if drop.rho_g > 0.0 else "weightless"
    head = [f"drop of revolution, {kind}: {sol.formulation} formulation, {_size(sol)}, volume {drop.area:g}"
            + (f", ρg = {drop.rho_g:g}, l_c = {drop.capillary_length:.6g}, Bond number V^(2/3)/l_c² = "
               f"{drop.bond_number:.6g}" if drop.rho_g > 0.0 else "")]
    fold = (sol.stability or {}).get("fold")
    if fold is not None:
        rows = [["fold of the pendant family", "discrete", "shooting", "error"],
                ["largest stable volume V*", cli.fmt(fold["area"]), cli.fmt(fold["analytic_area"]),
                 cli.fmt(e.get("fold_area"), ".3e") + " rel"],
                ["first volume refused", cli.fmt(fold["refused_area"]), "", ""]]
        return cli.Outcome.of(sol, summary=head + cli.table(rows) + [cli.status_line(sol.status, sol)], writers=plot)

    def row(name, mine, key, scale=lambda v: v, rel=" rel"):
        ref = None if cap is None else getattr(cap, key)
        err = e.get(key)
        return [name, cli.fmt(scale(mine)), cli.fmt(None if ref is None else scale(ref)),
                "" if err is None else cli.fmt(scale(err), ".3e") + rel]

    rows = [["quantity", "discrete", "spherical cap" if drop.rho_g == 0.0 else "shooting", "error"],
            row("contact angle (deg)", sol.contact_angle, "contact_angle", math.degrees, ""),
            row("height h", sol.height, "height"),
            row("contact radius r_c", sol.contact_radius, "contact_radius"),
            row("pressure at the table (volume multiplier)", sol.pressure_at_table, "pressure"),
            row("apex curvature 1/b (P − g ρg h)/2γ", sol.apex_curvature, "apex_curvature"),
            row("energy", sol.energy, "energy"),
            ["volume of the discrete profile", cli.fmt(sol.volume), cli.fmt(drop.area), ""],
            ["shape (max dist / h)", "", "", "" if "shape" not in e else cli.fmt(e["shape"], ".3e")]]
    lines = head + cli.table(rows)
    hess = (sol.stability or {}).get("reduced_hessian")
    if hess is not None:
        lines.append(f"stability: reduced Hessian Zᵀ∇²L Z {'positive definite' if hess['positive_definite'] else 'indefinite'}"
                     f" (smallest eigenvalue {hess['min_eigenvalue']:.3e}, dimension {hess['dimension']})")
    lines.append(cli.status_line(sol.status, sol))
    return cli.Outcome.of(sol, summary=lines, writers=plot)


def _pattern_outcome(sol):
    """The summary of a drop on a patterned table: its regime, apparent angle and pinning multiplier against
    Gibbs' criterion (the cap inside, pinned at the step, or spread)."""
    drop, cap, e, pat = sol.drop, sol.analytic, sol.errors, sol.pattern
    deg = math.degrees
    th_in, th_out = pat["young_angles"]
    what = "volume" if drop.axisymmetric else "area"
    head = [f"droplet on a patterned table{' (of revolution)' if drop.axisymmetric else ''}: {sol.formulation} "
            f"formulation, {_size(sol)}, {what} {drop.area:g}, pattern width {drop.pattern_width:g}, "
            f"γ_sl = {drop.gamma_sl:g} inside, {drop.gamma_sl_out:g} outside",
            f"Young angles {deg(th_in):.6g}° inside, {deg(th_out):.6g}° outside; the edge pins for {what}s "
            f"{cap.areas[0]:.6g} to {cap.areas[1]:.6g}"]

    def row(name, mine, ref, key, scale=lambda v: v, rel=" rel"):
        err = e.get(key)
        return [name, cli.fmt(scale(mine)), cli.fmt(scale(ref)), "" if err is None else cli.fmt(scale(err), ".3e") + rel]

    rows = [["quantity", "discrete", "analytic", "error"],
            ["regime", pat["regime"], cap.regime, ""],
            row("apparent angle (deg)", sol.contact_angle, cap.contact_angle, "contact_angle", deg, ""),
            row("contact radius r_c" if drop.axisymmetric else "span a",
                sol.contact_radius if drop.axisymmetric else sol.span,
                cap.contact_radius if drop.axisymmetric else cap.span,
                "contact_radius" if drop.axisymmetric else "span"),
            row(f"pressure ({what} multiplier)", sol.pressure, cap.pressure, "pressure"),
            row("energy", sol.energy, cap.energy, "energy"),
            ["pinning multiplier γ(cos θ_in − cos θ)", cli.fmt(pat["pinning_multiplier"]),
             cli.fmt(cap.pinning_multiplier), cli.fmt(e.get("pinning_multiplier"), ".3e") + " of Δγ_sl"]]
    lines = head + cli.table(rows)
    lines.append(f"the pinning multiplier lies in [0, γ_sl_out − γ_sl] = [0, {pat['pinning_bounds'][1]:.6g}]; "
                 f"the outside's bound carries the rest, {pat['outside_multiplier']:.6g}")
    lines.append(cli.status_line(sol.status, sol))
    return cli.Outcome.of(sol, summary=lines, writers={"plot": lambda path: plotting.droplet_shape(sol, path)})


def main(argv=None):
    return cli.run_scene(parser(), run, argv)


if __name__ == "__main__":
    sys.exit(main())
