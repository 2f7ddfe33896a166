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

from ..solve import droplet, interrupt
from ..inspect import plotting
from ..inspect import files, study
from . import stability
from .scene import SCENES, jsonable


def _droplet_entry(out: str, name: str, title: str, drop: droplet.Droplet, n: int, formulation: str, carried):
    sol = droplet.solve(drop, n, formulation)
    carried.append((name, sol.program))
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
    ("double_pendulum_g0", "double_pendulum", ["--g", "0", "--omega1", "1", "--T", "5", "--n", "1000"],
     "double pendulum without gravity (g = 0: the system has no gravity term)", False),
    ("damped_oscillator", "damped_oscillator", ["--scheme", "galerkin6"],
     "damped, driven oscillator (Lagrange–d'Alembert), galerkin6, against the closed form", False),
    ("driven_pendulum", "driven_pendulum", [], "damped, driven pendulum, chaotic regime, T = 20 s", False),
    ("kapitza_pendulum", "kapitza_pendulum", [], "Kapitza pendulum: a²ω²/2gl = 5.1, started 0.2 rad off upright",
     True),
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

def _run_case(scene: str, argv):
    """Run a scene's problem script in process at ``argv``: ``(outcome, wall time)``."""
    import importlib

    mod = importlib.import_module(SCENES[scene])
    t0 = time.perf_counter()
    outcome = mod.run(mod.parser().parse_args(argv))
    return outcome, time.perf_counter() - t0


def _contact_work_precision(out: str, size: str):
    ns = {"quick": [250, 500, 1000], "default": [250, 500, 1000, 2000], "full": [250, 500, 1000, 2000, 4000]}[size]
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
    timed = [{**r, "label": f"{r['case']}: {r['method']}", "time_s": r["build_time_s"] + r["solve_time_s"]}
             for r in rows]
    spring = [lab for lab in dict.fromkeys(r["label"] for r in timed) if lab.startswith("spring_ball")]
    lines += ["", "Reading (measured in this run, the ball on a spring): "
              + study.reading(timed, spring, (1e-3, 1e-5, 1e-7), key="impact_time_error"), "",
              "![contact work-precision](contact_work_precision.png)", ""]
    return ok, lines


def _stability(out: str, progress, size: str):
    """One stability table for every family (:mod:`castrajectory.cli.stability`): each case through its
    problem script, judged by its own oracle; a failed row is shown as failed and fails the report
    (``quick``: the first case of each family)."""
    rows = []
    cases = stability.CASES if size != "quick" else list({c.family: c for c in reversed(stability.CASES)}.values())
    for case in cases:
        row = stability.run_case(case)
        rows.append(row)
        progress(f"stability: {case.family}: {case.title}", "solved" if row.passed else "FAILED", row.time_s)
    solved = sum(r.passed for r in rows)
    t1 = time.perf_counter()
    good, battery_line = _battery_line(size)
    progress("stability: contact battery", "solved" if good else "FAILED", time.perf_counter() - t1)
    lines = ["## Stability on stiff and extreme cases", "",
             "Each case runs its problem script (the command shown) and is judged by its own oracle; a case "
             "passes only if the run ended as expected *and* the oracle holds. Drift: the energy's largest "
             "deviation over its largest size (contact: E(0) → E(T), which restitution below 1 lowers by design), "
             "or the spatial angular momentum's; error estimate: the answer's own (relative, Richardson).", "",
             *stability.table(rows), "", f"{solved} of {len(rows)} cases pass.", "", battery_line, ""]
    return solved == len(rows) and good, lines


def _derivations(out: str):
    """The built-in mechanics scenes' derivations, generated from the expressions the solver uses
    (:mod:`castrajectory.inspect.derivation`; the ``derive`` extra), one Markdown file each, linked here."""
    from ..models import pendulum, rigidbody
    from ..validation import InputError
    scenes = [("double_pendulum", "double pendulum", pendulum.double_pendulum()),
              ("n_link_pendulum", "4-link pendulum", pendulum.n_link_pendulum([1.0] * 4, [1.0] * 4, 9.81)),
              ("stiff_spring_pendulum", "spring pendulum (k l/(m g) = 1e4)",
               pendulum.spring_pendulum(1.0, 1.0, 1e4 * 9.81, 9.81)),
              ("dzhanibekov", "free rigid body, I = (1, 2, 3)", rigidbody.free_body(rigidbody.Inertia(1.0, 2.0, 3.0)))]
    lines = ["## Derivations, generated", "",
             "Each written by `castrajectory.inspect.derivation` from the CasADi expressions the solver uses "
             "(coordinates, K, U, L, M(q), the Euler–Lagrange equations with the constraints' multipliers, the "
             "discrete equations, the conserved quantities); the same as `castrajectory derive FILE.py`.", ""]
    try:
        from ..inspect import derivation
        for stem, title, system in scenes:
            files.write_text(os.path.join(out, f"derivation_{stem}.md"), derivation.markdown(system, title))
            lines.append(f"- [{title}](derivation_{stem}.md)")
    except InputError as exc:   # sympy missing: say so, the rest of the report stands
        lines.append(f"*Not generated: {exc}.*")
    return True, lines + [""]


#: The report's slice of the contact battery (scripts/contact_battery.py): seed and scenes drawn.
BATTERY_SEED, BATTERY_COUNT = 13, {"quick": 3, "default": 12, "full": 30}


def _battery_line(size: str):
    """The contact battery's summary line: a seeded random set of ball, rectangle and bowl scenes, each
    solved in its own process and checked (gaps, complementarity, Newton's law, caught arrivals, elastic
    energy) with its impact times against the event-driven reference."""
    import numpy as np

    from ..inspect.battery import battery_task, draw_scenes
    t0 = time.perf_counter()
    scenes = draw_scenes(BATTERY_SEED, BATTERY_COUNT[size])
    rows = [battery_task((sc, 120.0)) for sc in scenes]
    solved = sum(bool(r.get("solved")) for r in rows)
    times = np.array([r.get("time_s", np.nan) for r in rows], float)
    errs = [r["impact_time_error"] for r in rows if isinstance(r.get("impact_time_error"), float)
            and np.isfinite(r["impact_time_error"])]
    line = (f"Contact battery (`python scripts/contact_battery.py --seed {BATTERY_SEED} --count "
            f"{BATTERY_COUNT[size]}`): {solved} of {len(rows)} random ball, rectangle and bowl scenes solved with "
            f"every residual check; solve time median {np.nanmedian(times):.2f} s, worst {np.nanmax(times):.2f} s; "
            f"worst impact-time error against the event-driven reference {max(errs, default=float('nan')):.1e} s "
            f"({time.perf_counter() - t0:.0f} s in all). The full battery: 66 scenes, scripts/contact_battery.py.")
    return solved == len(rows), line


def _rigid_body_work_precision(out: str, size: str):
    ns = {"quick": [1000, 2000, 4000], "default": [1000, 2000, 4000, 8000],
          "full": [1000, 2000, 4000, 8000, 16000]}[size]
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
             "| method | observed order (flip interval) | time to 1e-6 (s) | max ‖L − L₀‖/‖L₀‖ over the sweep "
             "| max ‖q‖ − 1 | all converged |", "|---|---|---|---|---|---|"]
    for label in dict.fromkeys(r["label"] for r in rows):
        sel = [r for r in rows if r["label"] == label]
        order = study.trajectory_order(rows, label, key="flip_interval_error", ceiling=1.0)["order"]
        t6 = study.time_to_error(rows, label, 1e-6, key="flip_interval_error")["cost"]
        lines.append(f"| {label} | {order:.2f} | {'not reached' if not math.isfinite(t6) else f'{t6:.3g}'} | "
                     f"{max(r['angular_momentum_drift'] for r in sel):.1e} | "
                     f"{max(r['quaternion_norm_error'] for r in sel):.1e} | {all(r['success'] for r in sel)} |")
    labels = list(dict.fromkeys(r["label"] for r in rows))
    lines += ["", "Reading (measured in this run): " + study.reading(rows, labels, (1e-3, 1e-5, 1e-6),
                                                                     key="flip_interval_error"), "",
              "![rigid-body work-precision](rigidbody_work_precision.png)", ""]
    return ok, lines


def _mechanics_scenes(out: str, progress, carried):
    return _script_scenes(out, "## Mechanics: least action over the whole trajectory (Exercise 2.3)",
                          "Each scene is solved by its problem script at the arguments shown; the energy plot "
                          "shows |E − E(0)| over the run.", MECHANICS_SCENES, progress=progress, carried=carried)


def _carries(entries) -> List[str]:
    """The table of what each scene's NLP carries, read from the ``program`` its answer reports (the built
    NLP's own description: :meth:`castrajectory.discretise.program.Program.anatomy`)."""
    lines = ["## What each scene carries", "",
             "Read from each scene's built NLP (`program` in its JSON): the system's terms, and the program's "
             "variables, rows and complementarity pairs, in total and per step (node), and its element "
             "families (elements × SX instructions of the element function). A scene holds only the terms it "
             "lists: no complementarity without contact, no gravity when g = 0.", "",
             "| scene | terms | steps | variables (per step) | equality rows (per step) | inequality rows (per step) "
             "| complementarity pairs (per step) | element families |", "|---|---|---|---|---|---|---|---|"]
    for stem, prog in entries:
        if not prog:
            lines.append(f"| {stem} | closed form or time stepping: no NLP | - | - | - | - | - | - |")
            continue
        n = max(int(prog.get("steps", 1)), 1)
        per = (lambda k: f"{prog[k]} ({prog[k] / n:.3g})")  # noqa: E731
        fams = ", ".join(f"{f['name']} {f['elements']}×{f['instructions']}" for f in prog["families"])
        lines.append(f"| {stem} | {', '.join(prog['terms'])} | {n} | {per('variables')} | {per('equality_rows')} | "
                     f"{per('inequality_rows')} | {per('complementarity_pairs')} | {fams} |")
    return lines + [""]


def _script_scenes(out: str, heading: str, intro: str, scenes, plot_name: str = "energy", progress=None,
                   carried=None):
    lines = [heading, "", intro, ""]
    ok = True
    for stem, scene, argv, title, animate in scenes:
        outcome, wall = _run_case(scene, argv)
        ok &= outcome.success
        if carried is not None:
            carried.append((stem, outcome.data.get("program")))
        if progress is not None:
            progress(stem, outcome.status, wall)
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


def _work_precision(out: str, size: str):
    """Double pendulum (T = 5 s, θ = (2, 1)): error at T and energy error against run time."""
    import numpy as np

    from ..models import pendulum
    schemes = ("midpoint", "trapezoid", "galerkin4")
    pairs = [("whole", s) for s in schemes] + [("march", s) for s in ("midpoint", "galerkin4")] \
        + [("rk4", None), ("implicit-euler", None)]
    top = {"quick": 4000, "default": 8000, "full": 16000}[size]
    base = [n for n in (250, 500, 1000, 2000, 4000, 8000, 16000) if n <= top]
    ns = {"whole": base, "march": base, "rk4": base + [2 * top], "implicit-euler": base}
    rows = study.work_precision_sweep(pendulum.double_pendulum, [2.0, 1.0], [0.0, 0.0], 5.0, pairs, ns,
                                      reference_rtol=1e-14, quiet=True)
    peers = study.peer_sweep(pendulum.double_pendulum, [2.0, 1.0], [0.0, 0.0], 5.0, reference_rtol=1e-14)
    rows += peers
    study.write_csv([{k: v for k, v in r.items() if not isinstance(v, (list, dict))} for r in rows],
                    os.path.join(out, "work_precision.csv"))
    fig = plotting.work_precision_panels(rows, title="double pendulum, T = 5 s, θ = (2, 1)")
    files.save_figure(fig, os.path.join(out, "work_precision.png"))
    ok = all(r["success"] for r in rows if r["method"] == "whole")
    lines = ["## Error against run time (double pendulum, T = 5 s, θ = (2, 1) at rest)", "",
             f"N = {base[0]} … {top}; reference: CVODES at rtol 1e-14; data in `work_precision.csv`. "
             "Time = build + solve (whole: every level and window, and the error estimate's coarser grid). "
             + ("scipy's DOP853 and RK45 (the peers a user would otherwise reach for; rtol = atol = 1e-4 … 1e-12, "
                "N = their right-hand-side evaluations) on the same axes." if peers else
                "scipy is not installed (the `bench` extra): its DOP853 and RK45 are not shown."), "",
             "| method | observed order (fit range) | time to error 1e-6 (s) | time to 1e-8 (s) | all converged |",
             "|---|---|---|---|---|"]
    labels = [study.trajectory_label(m, sch) for m, sch in pairs] + list(dict.fromkeys(r["label"] for r in peers))
    for label in labels:
        sel = [r for r in rows if r["label"] == label]
        o = study.trajectory_order(rows, label)
        order = (f"{o['order']:.2f} (N = {o['n_min']} … {o['n_max']}"
                 + (f"; a floor from N = {o['stalled_at']:.0f}" if np.isfinite(o["stalled_at"]) else "") + ")"
                 if np.isfinite(o["order"]) else o["note"]) if not label.startswith("scipy") else "adaptive"
        t6 = study.time_to_error(rows, label, 1e-6)["cost"]
        t8 = study.time_to_error(rows, label, 1e-8)["cost"]
        f = (lambda v: "not reached" if v is None or not np.isfinite(v) else f"{v:.3g}")  # noqa: E731
        lines.append(f"| {label} | {order} | {f(t6)} | {f(t8)} | {all(r['success'] for r in sel)} |")
    lines += ["", "Reading (measured in this run): " + study.reading(rows, labels), "",
              "![work-precision](work_precision.png)", ""]
    return ok, lines


def _long_horizon(out: str, size: str):
    """Small-amplitude pendulum over many periods: bounded energy (variational) against RK4 drift."""
    import math as _m

    from ..models import pendulum
    periods = 100 if size == "quick" else 1000
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
             "| method | status | time (s) | max ΔE first half | max ΔE second half | ratio |",
             "|---|---|---|---|---|---|"]
    ok = True
    for r in rows:
        ok &= r["success"]
        ratio = r["max_second_half"] / r["max_first_half"] if r["success"] else float("nan")
        lines.append(f"| {r['label']} | {r['status']} | {r['time_s']:.2f} | {r['max_first_half']:.2e} | "
                     f"{r['max_second_half']:.2e} | {ratio:.2f} |")
    lines += ["", "![long horizon](long_horizon.png)", ""]
    return ok, lines


def _headline(out: str, stability_line: str) -> List[str]:
    """The top of the report: what was solved, how accurately, at what cost; one line per exercise,
    read from the scenes' JSON written below."""
    def load(stem):
        try:
            with open(os.path.join(out, f"{stem}.json")) as fh:
                return json.load(fh)
        except (OSError, ValueError):
            return None

    def cost(d):
        if "solve_time_s" not in d:
            return "closed form"
        return f"{d.get('build_time_s', 0.0) + d['solve_time_s']:.3f} s, {d.get('iterations', 0)} iterations"

    rows = []
    d = load("droplet_curve")
    if d:
        rows.append(("2.1 droplet (free span, θ = 60°)", f"θ = {math.degrees(d['contact_angle']):.6f}°, pressure "
                     f"{d['pressure']:.6f}", f"angle {d['errors']['contact_angle']:.1e} rad, pressure "
                     f"{d['errors']['pressure']:.1e} (relative) against the circle and Young", cost(d)))
    d = load("collision_impulse")
    if d:
        law = abs(d["corner_normal_velocity_after"] + d["restitution"] * d["corner_normal_velocity_before"])
        rows.append(("2.2 collision (corner impact, e = 1)", f"μ = {d['mu']:.6f}",
                     f"impact law to {law:.1e} m/s, kinetic energy {d['ke_before']:g} → {d['ke_after']:.12g} J",
                     cost(d)))
    d = load("bouncing_ball")
    if d:
        rows.append(("contact (bouncing ball, N = 3000)", f"{len(d['impacts'])} impacts",
                     f"bounce times {d['impact_time_error']:.1e} s against the closed form", cost(d)))
    d = load("double_pendulum_galerkin4")
    if d:
        e = d["error_estimate"]
        rows.append(("2.3 least action (double pendulum, galerkin4, T = 5 s)", f"θ(T) = {d['q'][-1][0]:.6f}, "
                     f"{d['q'][-1][1]:.6f}", f"estimated {e['relative']:.1e} relative (Richardson)", cost(d)))
    d = load("thrown_ball")
    if d:
        rows.append(("2.3 least action (thrown ball, two-point boundary)", "the parabola",
                     f"{d['parabola_error']:.1e} m against it", cost(d)))
    d = load("dzhanibekov")
    if d and d.get("flip_interval_error") is not None:
        rows.append(("3-D rigid body (Dzhanibekov flip)", f"{len(d['flip_times'])} flips, interval "
                     f"{d['flip_interval']:.6f} s", f"{d['flip_interval_error'] / d['flip_interval_exact']:.1e} "
                     "relative against 2K(m)/s", cost(d)))
    return ["| exercise | answer | accuracy | cost |", "|---|---|---|---|",
            *[f"| {a} | {b} | {c} | {t} |" for a, b, c, t in rows], "", stability_line, ""]


def _progress_printer(quiet: bool):
    """One line per finished scene or study on stdout (name, status, seconds); nothing when ``quiet``."""
    def progress(name: str, status: str, seconds: float) -> None:
        interrupt.check()  # a Ctrl-C that Python dropped inside a callback stops the report here
        if not quiet:
            print(f"  {name:60s} {status:28s} {seconds:7.2f} s", flush=True)
    return progress


#: The report's sizes: ``quick`` (the tests), ``default`` (under 90 s on 2 cores with a warm compile
#: cache), ``full`` (the larger sweeps: the droplet to N = 10⁵, the pendulum to 16 000 steps).
SIZES = ("quick", "default", "full")


def write_report(out: str, size: str = "default", quiet: bool = False) -> int:
    """Solve every scene and study at ``size`` and write ``DIR/summary.md`` (0: every solve converged and
    every stability case passed; 1 otherwise, after the whole report is written)."""
    if size not in SIZES:
        raise ValueError(f"size must be one of {SIZES}")
    os.makedirs(out, exist_ok=True)
    interrupt.install()
    t0 = time.perf_counter()
    progress = _progress_printer(quiet)
    carried: List[tuple] = []  # (scene, program) of every scene run, for the table of what each carries

    def section(name, fn, *args):
        t1 = time.perf_counter()
        good, sec = fn(*args)
        progress(name, "ok" if good else "FAILED", time.perf_counter() - t1)
        return good, sec
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
        t1 = time.perf_counter()
        good, row, pic = _droplet_entry(out, name, title, drop, n, form, carried)
        progress(name, "ok" if good else "FAILED", time.perf_counter() - t1)
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
    t1 = time.perf_counter()
    ns = study.sweep_sizes({"quick": 2048, "default": 16384, "full": 100_000}[size])
    rows = study.droplet_sweep(ns)
    progress("droplet convergence sweep", "ok" if all(r["status"] == "ok" for r in rows) else "FAILED",
             time.perf_counter() - t1)
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
    timed = [{**r, "label": r["formulation"], "time_s": r["total_time_s"]} for r in rows]
    lines += ["", "Reading (measured in this run, the shape error): "
              + study.reading(timed, list(droplet.FORMULATIONS), (1e-4, 1e-6, 1e-8), key="err_shape"), "",
              "![convergence](droplet_convergence.png)", ""]

    # ---- the scenes through their problem scripts, the studies, the stability table: in this order
    parts = [
        lambda: _script_scenes(out, "## Collisions (Exercise 2.2)",
                               "Closed-form impulse of a corner impact (no Ipopt solve).", COLLISION_SCENES,
                               progress=progress, carried=carried),
        lambda: _script_scenes(
            out, "## Contact trajectories (complementarity-constrained discrete action)",
            "One whole-trajectory NLP per scene: collision sub-nodes with unknown impact times, gap ⟂ impulse "
            "by exact penalties, Newton restitution on the discrete momenta (docs/derivations.md). The plot shows "
            "heights/gaps over the impulses per node.", CONTACT_SCENES, plot_name="contact",
            progress=progress, carried=carried),
        lambda: section("contact work-precision", _contact_work_precision, out, size),
        lambda: _mechanics_scenes(out, progress, carried),
        lambda: section("double pendulum work-precision", _work_precision, out, size),
        lambda: section("long horizon", _long_horizon, out, size),
        lambda: _script_scenes(
            out, "## Rigid bodies in 3-D (the Dzhanibekov flip and the heavy top)",
            "Orientation as a unit quaternion with its norm as a holonomic constraint; one whole-trajectory "
            "stationary-action problem per scene. The Dzhanibekov plot shows the body rates with the located "
            "flips, the top's its tilt and precession.", RIGIDBODY_SCENES, plot_name="plot", progress=progress,
            carried=carried),
        lambda: section("rigid-body work-precision", _rigid_body_work_precision, out, size),
        lambda: _stability(out, progress, size),
        lambda: section("generated derivations", _derivations, out),
    ]
    for part in parts:
        good, sec = part()
        ok &= good
        lines += sec
    lines += _carries(carried)

    interrupt.check()
    elapsed = time.perf_counter() - t0
    lines += [f"Report ({size}) written in {elapsed:.1f} s; every solve converged and every stability case "
              f"passed: {ok}."]
    passed = next((ln for ln in lines if ln.endswith("cases pass.")), "")
    lines[2:2] = ["What was solved, how accurately and at what cost (the scenes' own answers below; "
                  f"{size} report, {elapsed:.0f} s in all):", "", *_headline(out, f"Stability: {passed}")]
    files.write_text(os.path.join(out, "summary.md"), "\n".join(lines) + "\n")
    from . import html  # the same content as one self-contained page: figures inline, animations playing
    html.write_index(out, "\n".join(lines) + "\n")
    print(f"report written to {os.path.join(out, 'summary.md')} and index.html in {elapsed:.1f} s "
          f"({'every solve converged, every stability case passed' if ok else 'SOME SOLVES OR CASES FAILED'})")
    return 0 if ok else 1
