"""``castrajectory report --out DIR``: solve every implemented scene at its defaults and write a report.

Writes, into ``DIR``: one JSON summary and one picture per scene run, the
droplet convergence sweep (CSV and plot) and ``summary.md`` linking them.
Returns exit code 0 only if every solve converged.
"""
from __future__ import annotations

import json
import math
import os
import time
from typing import List

from ..solve import droplet
from ..inspect import plotting
from ..inspect import files, study
from .scene import SCENES, jsonable


def _droplet_entry(out: str, name: str, title: str, drop: droplet.Droplet, n: int, formulation: str):
    sol = droplet.solve(drop, n, formulation)
    files.write_text(os.path.join(out, f"{name}.json"), json.dumps(jsonable(sol.as_dict()), allow_nan=False))
    if sol.success:
        files.write_atomically(os.path.join(out, f"{name}.png"), lambda p: plotting.droplet_shape(sol, p))
    e, r = sol.errors, sol.result
    row = (f"| {title} | {formulation} | {n} | {sol.status} | {r.iterations} | "
           f"{r.build_time_s:.3f} | {r.solve_time_s:.3f} | {math.degrees(sol.contact_angle):.6f} | "
           f"{math.degrees(sol.analytic.contact_angle):.6f} | {e['shape']:.2e} | {e['contact_angle']:.2e} | "
           f"{e['span']:.2e} | {e['energy']:.2e} | {e['pressure']:.2e} |")
    return sol.success, row, f"![{title}]({name}.png)" if sol.success else f"*{title}: no picture (solve failed)*"


#: (file stem, scene module, arguments, title, animate?) of the mechanics scenes in the report.
MECHANICS_SCENES = [
    ("double_pendulum", "double_pendulum", [], "double pendulum, θ = (2, 1) at rest, T = 10 s (chaotic)", True),
    ("double_pendulum_galerkin4", "double_pendulum", ["--T", "5", "--n", "2000", "--scheme", "galerkin4"],
     "double pendulum, galerkin4, T = 5 s", False),
    ("n_link_pendulum", "n_link_pendulum", [], "4-link pendulum", True),
    ("stiff_spring_1e4", "stiff_spring_pendulum", ["--ratio", "1e4"], "stiff spring pendulum, k l/(m g) = 1e4", True),
    ("stiff_spring_1e6", "stiff_spring_pendulum", ["--ratio", "1e6"],
     "stiff spring pendulum, k l/(m g) = 1e6 (h ω ≈ 16)", False),
    ("thrown_ball", "thrown_ball", [], "thrown ball (two-point boundary, least action)", False),
]


#: Collision scenes in the report (same tuple layout).
COLLISION_SCENES = [
    ("collision_impulse", "collision_impulse", [], "corner impact of a 2 × 1 rectangle, e = 1", False),
    ("collision_impulse_flat", "collision_impulse",
     ["--angle", "0", "--vx", "0", "--vy", "-1", "--restitution", "0"],
     "flat fall onto a corner, e = 0 (oracle μ = 5/17)", False),
]


#: Contact scenes in the report (same tuple layout); their plot is the contact plot.
CONTACT_SCENES = [
    ("bouncing_ball", "bouncing_ball", [], "bouncing ball, e = 1, N = 3000 (3 bounces)", True),
    ("bouncing_ball_e07", "bouncing_ball", ["--restitution", "0.7", "--T", "5", "--n", "2000"],
     "bouncing ball, e = 0.7, T = 5 s (settles)", False),
    ("rectangle_drop", "rectangle_drop", [], "rectangle drop, θ₀ = 0.3, e = 1", True),
    ("bowl", "bowl", [], "rectangle in a bowl y = x²/(2R), e = 1", True),
    ("bowl3d", "bowl3d", [], "box on SO(3) in the bowl z = (x² + y²)/(2R), e = 1, eight corners", False),
]

#: Rigid-body scenes in the report (same tuple layout); their plot is the scene's own.
RIGIDBODY_SCENES = [
    ("dzhanibekov", "dzhanibekov", [], "Dzhanibekov flip: I = (1, 2, 3), ω₀ = (1e-3, 1, 1e-3), T = 100 s", True),
    ("heavy_top", "heavy_top", ["--reference"], "heavy top: spin 100 rad/s, tilt 0.3 rad, T = 2 s, "
     "against Euler–Poisson (CVODES)", True),
]

#: Extreme rigid-body cases of the stability table: (title, scene, arguments, what is checked).
RIGIDBODY_EXTREMES = [
    ("nearly symmetric body, I = (1, 2.999, 3): flips every 391 s", "dzhanibekov",
     ["--inertia", "1", "2.999", "3", "--T", "1000", "--n", "20000"], "flip interval against 2K(m)/s"),
    ("fast spin, |ω| = 100 rad/s at the default N (h|ω| = 2.5 rad per step)", "dzhanibekov",
     ["--omega", "1e-3", "100", "1e-3"], "an unresolved grid fails and says which N resolves it"),
    ("fast spin, |ω| = 100 rad/s over T = 5 s at the default N (h|ω| = 0.125)", "dzhanibekov",
     ["--omega", "1e-3", "100", "1e-3", "--T", "5"], "12 flips against 2K(m)/s"),
    ("20 flips (T = 560 s, N = 11200)", "dzhanibekov", ["--T", "560", "--n", "11200"],
     "energy bounded, |L| and |q| to solver tolerance"),
    ("spin exactly on the intermediate axis, ω₀ = (0, 1, 0)", "dzhanibekov", ["--omega", "0", "1", "0"],
     "the unstable equilibrium is kept exactly: no round-off seeds a flip (derivation, rigid bodies §5)"),
]

#: Extreme contact cases of the stability table: (title, scene module, arguments, what is checked).
CONTACT_EXTREMES = [
    ("high-speed impact (443 m/s, 100× the default)", "bouncing_ball",
     ["--velocity", "-442.9", "--T", "0.5", "--n", "1000"], "impact speed and energy"),
    ("grazing corner (g = 0, spinning, 1e-4 m overlap of the sweep)", "rectangle_drop",
     ["--g", "0", "--y", "1.1179339887", "--angle", "0", "--vx", "0", "--vy", "0", "--omega", "2",
      "--T", "1.5", "--n", "1000"], "no penetration, impact law"),
    ("resting contact (ball at rest on the ground)", "bouncing_ball",
     ["--height", "0", "--T", "1", "--n", "200"], "no jitter, impulse m g h per node"),
    ("Zeno-like bouncing, e = 0.3", "bouncing_ball",
     ["--restitution", "0.3", "--T", "3", "--n", "1500"], "settles without penetrating"),
    ("flat rectangle landing (θ₀ = 0: two corners at once)", "rectangle_drop",
     ["--angle", "0", "--vx", "0", "--omega", "0", "--y", "1.5", "--T", "1.5", "--n", "1000"],
     "simultaneous impact law"),
    ("nearly flat rectangle landing (θ₀ = 0.01: corners land 2.5 ms apart, h = 1.5 ms)", "rectangle_drop",
     ["--angle", "0.01", "--vx", "0", "--omega", "0", "--y", "1.5", "--T", "1.5", "--n", "1000"],
     "sequential corner impacts, impact law"),
    ("flatter landing (θ₀ = 1e-3: a three-impact cascade within 0.74 ms, h = 1.5 ms)", "rectangle_drop",
     ["--angle", "0.001", "--vx", "0", "--omega", "0", "--y", "1.5", "--T", "1.5", "--n", "1000"],
     "two impacts within one step (the step halved there), impact law, energy"),
    ("rocking block (default drop with e = 0.5, T = 3 s: rocking accumulation on the edge)", "rectangle_drop",
     ["--restitution", "0.5"], "bounces obey the corner law through the rocking accumulation, then slides flat"),
    ("rocking block, e = 0.3 (the same drop)", "rectangle_drop",
     ["--restitution", "0.3"], "bounces obey the corner law; a catch only where a bounce would not clear the "
     "next node, then slides flat"),
]


def _run_case(scene: str, argv):
    """Run a scene's problem script in process at ``argv``: ``(outcome, wall time)``."""
    import importlib

    mod = importlib.import_module(SCENES[scene])
    t0 = time.perf_counter()
    outcome = mod.run(mod.parser().parse_args(argv))
    return outcome, time.perf_counter() - t0


def _contact_stability(out: str):
    """Stability table: the extreme contact cases, each through its problem script."""
    import numpy as np

    lines = ["### Stability on extreme contact cases", "",
             "Each case runs its problem script; a failure is recorded here (status column) and counted "
             "below, not hidden.", "",
             "| case | command | status | iterations | time (s) | impacts | lowest gap | complementarity "
             "| energy E(0) → E(T) | measured | checked |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    solved = 0
    for title, scene, argv, what in CONTACT_EXTREMES:
        outcome, wall = _run_case(scene, argv)
        solved += outcome.success
        d = outcome.data
        gap = min(np.min(d["gap"]) if "gap" in d else np.inf,
                  d.get("min_gap", np.inf))
        n_imp = len(d["impacts"]) if "impacts" in d and isinstance(d["impacts"], list) else \
            len(d.get("impact_times", []))
        E = np.asarray(d["energy"], float)
        keys = [("impact_law_error", "v⁺ off the impact law by"),
                ("resting_impulse_error", "impulse per node at rest off m g h by (relative)")]
        if n_imp:
            keys = [("impact_time_error", "bounce times off by (s)"), ("apex_error", "apexes off by (m)")] + keys
        figures = [f"{label} {d[key]:.1e}" for key, label in keys if d.get(key) is not None]
        lines.append(f"| {title} | `{scene}.py {' '.join(argv)}` | {d['status']} | {d['iterations']} | {wall:.2f} | "
                     f"{n_imp} | {gap:.1e} | {d['complementarity_residual']:.1e} | {E[0]:.6g} → {E[-1]:.6g} "
                     f"| {'; '.join(figures) or '-'} | {what} |")
    lines += ["", f"{solved} of {len(CONTACT_EXTREMES)} extreme cases solved.", ""]
    return True, lines


def _contact_work_precision(out: str, quick: bool):
    ns = [250, 500, 1000] if quick else [250, 500, 1000, 2000, 4000]
    rows = study.contact_work_precision(ns)
    study.write_csv(rows, os.path.join(out, "contact_work_precision.csv"))
    files.save_figure(plotting.contact_work_precision(rows, title="bounce times against the analytic ones"),
                      os.path.join(out, "contact_work_precision.png"))
    lines = ["### Error against run time (bounce times and apex heights)", "",
             "Ball under gravity (e = 1, 3 bounces: the midpoint rule is exact on parabolas) and ball on a "
             "spring (k = 50, e = 0.9, 5 bounces: harmonic flight); whole-trajectory contact NLP against the "
             f"Moreau–Jean time-stepping baseline; N = {ns[0]} … {ns[-1]}; data in `contact_work_precision.csv`.", "",
             "| case | method | observed order (impact time) | impact-time error at N = " + str(ns[0])
             + " | at N = " + str(ns[-1]) + " | apex error at N = " + str(ns[0]) + " | at N = " + str(ns[-1])
             + " | time at N = " + str(ns[-1]) + " (s) |", "|---|---|---|---|---|---|---|---|"]
    ok = True
    for case in study.CONTACT_CASES:
        for method in ("whole", "moreau-jean"):
            sel = [r for r in rows if r["case"] == case and r["method"] == method]
            ok &= all(r["status"] == "ok" for r in sel)
            errs = [r["impact_time_error"] for r in sel]
            good = [r for r in sel if r["impact_time_error"] > 1e-9]
            order = -study.loglog_slope([r["n"] for r in good], [r["impact_time_error"] for r in good]) \
                if len(good) >= 2 else float("nan")
            order_s = "solver tolerance" if len(good) < 2 else f"{order:.2f}"
            lines.append(f"| {case} | {method} | {order_s} | {errs[0]:.2e} | {errs[-1]:.2e} | "
                         f"{sel[0]['apex_error']:.2e} | {sel[-1]['apex_error']:.2e} | "
                         f"{sel[-1]['build_time_s'] + sel[-1]['solve_time_s']:.3f} |")
    lines += ["", "![contact work-precision](contact_work_precision.png)", ""]
    return ok, lines


def _rigid_body_stability(out: str):
    """Stability table of the rigid-body extremes, each through its problem script."""
    lines = ["### Stability on extreme rigid-body cases", "",
             "Each case runs its problem script; a failure is shown as failed, with the solver's message.", "",
             "| case | command | status | iterations | time (s) | flips | flip interval error | max |L − L₀|/|L₀| "
             "| max ||q|| − 1 | max |E − E₀|/|E₀| | checked |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for title, scene, argv, what in RIGIDBODY_EXTREMES:
        outcome, wall = _run_case(scene, argv)
        d = outcome.data
        fe = d.get("flip_interval_error")
        status = d["status"] if outcome.success else f"failed: {outcome.message}"
        lines.append(f"| {title} | `{scene}.py {' '.join(argv)}` | {status} | {d['iterations']} | {wall:.2f} | "
                     f"{len(d['flip_times'])} | {'-' if fe is None else f'{fe:.2e}'} | "
                     f"{d['angular_momentum_drift']:.1e} | {d['quaternion_norm_error']:.1e} | "
                     f"{d['energy_drift']:.1e} | {what} |")
    return True, lines + [""]


def _rigid_body_work_precision(out: str, quick: bool):
    ns = [1000, 2000, 4000] if quick else [1000, 2000, 4000, 8000, 16000]
    rows = study.rigid_body_work_precision(ns)
    study.write_csv(rows, os.path.join(out, "rigidbody_work_precision.csv"))
    fig = plotting.work_precision_panels(rows, error="flip_interval_error",
                                         title="free body near the intermediate axis, 4 flips in T = 100 s")
    files.save_figure(fig, os.path.join(out, "rigidbody_work_precision.png"))
    ok = all(r["success"] for r in rows if r["method"] == "whole")
    lines = ["### Error against run time (flip interval and energy)", "",
             f"I = (1, 2, 3), ω₀ = (1e-3, 1, 1e-3), T = 100 s, N = {ns[0]} … {ns[-1]}; the flip-interval error is "
             "against 2K(m)/s; RK4 integrates Euler's equations with quaternion kinematics, not renormalised; "
             "data in `rigidbody_work_precision.csv`.", "",
             "| method | observed order (flip interval) | time to 1e-6 (s) | max |L − L₀|/|L₀| over the sweep "
             "| max ||q|| − 1 | all converged |", "|---|---|---|---|---|---|"]
    for label in dict.fromkeys(r["label"] for r in rows):
        sel = [r for r in rows if r["label"] == label]
        order = study.trajectory_order(rows, label, key="flip_interval_error", ceiling=1.0)["order"]
        t6 = study.time_to_error(rows, label, 1e-6, key="flip_interval_error")["cost"]
        lines.append(f"| {label} | {order:.2f} | {'not reached' if not math.isfinite(t6) else f'{t6:.3g}'} | "
                     f"{max(r['angular_momentum_drift'] for r in sel):.1e} | "
                     f"{max(r['quaternion_norm_error'] for r in sel):.1e} | {all(r['success'] for r in sel)} |")
    lines += ["", "![rigid-body work-precision](rigidbody_work_precision.png)", ""]
    return ok, lines


def _mechanics_scenes(out: str):
    return _script_scenes(out, "## Mechanics: least action over the whole trajectory (Exercise 2.3)",
                          "Each scene is solved by its problem script at the arguments shown; the energy plot "
                          "shows |E − E(0)| over the run.", MECHANICS_SCENES)


def _script_scenes(out: str, heading: str, intro: str, scenes, plot_name: str = "energy"):
    lines = [heading, "", intro, ""]
    ok = True
    for stem, scene, argv, title, animate in scenes:
        outcome, _ = _run_case(scene, argv)
        ok &= outcome.success
        files.write_text(os.path.join(out, f"{stem}.json"), json.dumps(jsonable(outcome.data), allow_nan=False))
        lines += [f"### {title}", "", f"`python problems/{scene}.py {' '.join(argv)}`".replace(" `", "`"), "",
                  "```", *outcome.summary, "```", ""]
        if outcome.success and "plot" in outcome.writers:
            files.write_atomically(os.path.join(out, f"{stem}_{plot_name}.png"), outcome.writers["plot"])
            lines += [f"![{title}: {plot_name}]({stem}_{plot_name}.png)", ""]
            if animate:
                files.write_atomically(os.path.join(out, f"{stem}.gif"), outcome.writers["animate"])
                lines += [f"![{title}: animation]({stem}.gif)", ""]
    return ok, lines


def _work_precision(out: str, quick: bool):
    """Double pendulum (T = 5 s, θ = (2, 1)): error at T and energy error against run time."""
    import numpy as np

    from ..models import pendulum
    schemes = ("midpoint", "trapezoid", "galerkin4")
    pairs = [("whole", s) for s in schemes] + [("march", s) for s in ("midpoint", "galerkin4")] \
        + [("rk4", None), ("implicit-euler", None)]
    top = 4000 if quick else 16000
    base = [n for n in (250, 500, 1000, 2000, 4000, 8000, 16000) if n <= top]
    ns = {"whole": base, "march": base, "rk4": base + [2 * top], "implicit-euler": base}
    rows = study.work_precision_sweep(pendulum.double_pendulum, [2.0, 1.0], [0.0, 0.0], 5.0, pairs, ns,
                                      reference_rtol=1e-14)
    study.write_csv([{k: v for k, v in r.items() if not isinstance(v, (list, dict))} for r in rows],
                    os.path.join(out, "work_precision.csv"))
    fig = plotting.work_precision_panels(rows, title="double pendulum, T = 5 s, θ = (2, 1)")
    files.save_figure(fig, os.path.join(out, "work_precision.png"))
    ok = all(r["success"] for r in rows if r["method"] == "whole")
    lines = ["## Error against run time (double pendulum, T = 5 s, θ = (2, 1) at rest)", "",
             f"N = {base[0]} … {top}; reference: CVODES at rtol 1e-14; data in `work_precision.csv`. "
             "Time = build + solve (whole: every level and window).", "",
             "| method | observed order | time to error 1e-6 (s) | time to 1e-8 (s) | all converged |",
             "|---|---|---|---|---|"]
    for m, sch in pairs:
        label = study.trajectory_label(m, sch)
        sel = [r for r in rows if r["label"] == label]
        order = study.trajectory_order(rows, label)["order"]
        t6 = study.time_to_error(rows, label, 1e-6)["cost"]
        t8 = study.time_to_error(rows, label, 1e-8)["cost"]
        f = (lambda v: "not reached" if v is None or not np.isfinite(v) else f"{v:.3g}")  # noqa: E731
        lines.append(f"| {label} | {order:.2f} | {f(t6)} | {f(t8)} | {all(r['success'] for r in sel)} |")
    lines += ["", "![work-precision](work_precision.png)", ""]
    return ok, lines


def _long_horizon(out: str, quick: bool):
    """Small-amplitude pendulum over many periods: bounded energy (variational) against RK4 drift."""
    import math as _m

    from ..models import pendulum
    periods = 100 if quick else 1000
    steps = 20
    g, amp = 9.81, 0.1
    period = 2 * _m.pi / _m.sqrt(g)
    T, N = periods * period, periods * steps
    system = pendulum.n_link_pendulum([1.0], [1.0], g)
    runs = [("whole", "midpoint"), ("whole", "galerkin4"), ("march", "midpoint"), ("rk4", None)]
    series, tseries, rows = {}, {}, []
    for m, sch in runs:
        row, run = study.long_horizon_run(system, [amp], [0.0], T, N, m, sch)
        rows.append(row)
        if row["success"]:
            series[row["label"]] = run.energy - row["E0"]
            tseries[row["label"]] = run.t
    study.write_csv(rows, os.path.join(out, "long_horizon.csv"))
    fig = plotting.long_horizon_plot(tseries, series, period=period,
                                     title=f"pendulum, amplitude {amp} rad, {periods} periods, {steps} steps/period")
    files.save_figure(fig, os.path.join(out, "long_horizon.png"))
    lines = ["## Long horizon: energy over " + f"{periods} periods", "",
             "| method | status | time (s) | max |ΔE| first half | max |ΔE| second half | ratio |",
             "|---|---|---|---|---|---|"]
    ok = True
    for r in rows:
        ok &= r["success"]
        ratio = r["max_second_half"] / r["max_first_half"] if r["success"] else float("nan")
        lines.append(f"| {r['label']} | {r['status']} | {r['time_s']:.2f} | {r['max_first_half']:.2e} | "
                     f"{r['max_second_half']:.2e} | {ratio:.2f} |")
    lines += ["", "![long horizon](long_horizon.png)", ""]
    return ok, lines


def write_report(out: str, quick: bool = False) -> int:
    os.makedirs(out, exist_ok=True)
    t0 = time.perf_counter()
    lines: List[str] = ["# castrajectory report", ""]
    ok = True

    # ---- droplet scenes
    lines += ["## Droplet (Exercise 2.1)", "",
              "| scene | formulation | N | status | iterations | build (s) | solve (s) | θ (deg) | Young θ (deg) "
              "| shape err | angle err (rad) | span err | energy err | pressure err |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    pictures = []
    scenes = [
        ("droplet_curve", "default drop (θ = 60°)", droplet.Droplet(), 400, "curve"),
        ("droplet_graph", "default drop, graph form", droplet.Droplet(), 400, "graph"),
        ("droplet_overhang", "overhanging drop (θ = 135°)",
         droplet.Droplet(1.0, 1.0 + math.sqrt(0.5), 1.0, 1.0), 400, "curve"),
        ("droplet_fixed_span", "pinned span a = 1.5", droplet.Droplet(span=1.5), 400, "curve"),
    ]
    for name, title, drop, n, form in scenes:
        good, row, pic = _droplet_entry(out, name, title, drop, n, form)
        ok &= good
        lines.append(row)
        pictures.append(pic)
    lines += [""] + [p + "\n" for p in pictures]

    # ---- reduced problem
    ang = droplet.solve_angle(droplet.Droplet())
    ok &= ang.success
    files.write_text(os.path.join(out, "droplet_angle.json"), json.dumps(jsonable(ang.as_dict()), allow_nan=False))
    if ang.success:
        files.write_atomically(os.path.join(out, "droplet_angle.png"), lambda p: plotting.reduced_energy(ang, p))
    lines += ["### Reduced problem in θ", "",
              f"θ* = {math.degrees(ang.contact_angle):.12f}° ({ang.status}, {ang.result.iterations} iterations), "
              f"Young residual {ang.young_residual:.2e}, R = {ang.radius:.10g}, E = {ang.energy:.10g}.", "",
              "![E(θ)](droplet_angle.png)", ""]

    # ---- convergence sweep
    ns = study.sweep_sizes(2048 if quick else 100_000)
    rows = study.droplet_sweep(ns)
    ok &= all(r["status"] == "ok" for r in rows)
    study.write_csv(rows, os.path.join(out, "droplet_convergence.csv"))
    files.write_atomically(os.path.join(out, "droplet_convergence.png"), lambda p: plotting.droplet_convergence(rows, p))
    lines += ["### Error against N and against run time", "",
              f"N = {ns[0]} … {ns[-1]}; data in `droplet_convergence.csv`.  Observed orders (fit over N ≥ 32):", "",
              "| formulation | " + " | ".join(study.DROPLET_ERRORS) + " | max iterations | all converged |",
              "|---|" + "---|" * (len(study.DROPLET_ERRORS) + 2)]
    for f in droplet.FORMULATIONS:
        orders = study.observed_orders(rows, f)
        sel = [r for r in rows if r["formulation"] == f]
        lines.append(f"| {f} | " + " | ".join(f"{orders[k]:.2f}" for k in study.DROPLET_ERRORS)
                     + f" | {max(r['iterations'] for r in sel)} | {all(r['status'] == 'ok' for r in sel)} |")
    lines += ["", "![convergence](droplet_convergence.png)", ""]

    # ---- mechanics scenes (run through the problem scripts themselves)
    good, col_lines = _script_scenes(out, "## Collisions (Exercise 2.2)",
                                     "Closed-form impulse of a corner impact (no Ipopt solve).", COLLISION_SCENES)
    ok &= good
    lines += col_lines
    good, con_lines = _script_scenes(
        out, "## Contact trajectories (complementarity-constrained discrete action)",
        "One whole-trajectory NLP per scene: collision sub-nodes with unknown impact times, gap ⟂ impulse "
        "by exact penalties, Newton restitution on the discrete momenta (docs/derivations.md). The plot shows "
        "heights/gaps over the impulses per node.", CONTACT_SCENES, plot_name="contact")
    ok &= good
    lines += con_lines
    for part in (_contact_stability(out), _contact_work_precision(out, quick)):
        ok &= part[0]
        lines += part[1]
    good, mech_lines = _mechanics_scenes(out)
    ok &= good
    lines += mech_lines
    good, wp_lines = _work_precision(out, quick)
    ok &= good
    lines += wp_lines
    good, lh_lines = _long_horizon(out, quick)
    ok &= good
    lines += lh_lines
    good, rb_lines = _script_scenes(
        out, "## Rigid bodies in 3-D (the Dzhanibekov flip and the heavy top)",
        "Orientation as a unit quaternion with its norm as a holonomic constraint; one whole-trajectory "
        "stationary-action problem per scene. The Dzhanibekov plot shows the body rates with the located flips, "
        "the top's its tilt and precession.", RIGIDBODY_SCENES, plot_name="plot")
    ok &= good
    lines += rb_lines
    for part in (_rigid_body_work_precision(out, quick), _rigid_body_stability(out)):
        ok &= part[0]
        lines += part[1]

    lines += [f"Report written in {time.perf_counter() - t0:.1f} s; every solve converged: {ok}."]
    files.write_text(os.path.join(out, "summary.md"), "\n".join(lines) + "\n")
    print(f"report written to {os.path.join(out, 'summary.md')} (all converged: {ok})")
    return 0 if ok else 1
