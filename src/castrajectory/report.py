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

from . import droplet, plotting, study
from .cli import jsonable


def _droplet_entry(out: str, name: str, title: str, drop: droplet.Droplet, n: int, formulation: str):
    sol = droplet.solve(drop, n, formulation)
    with open(os.path.join(out, f"{name}.json"), "w") as fh:
        json.dump(jsonable(sol.as_dict()), fh, allow_nan=False)
    if sol.success:
        plotting.droplet_shape(sol, os.path.join(out, f"{name}.png"))
    e, r = sol.errors, sol.result
    row = (f"| {title} | {formulation} | {n} | {sol.status} | {r.iterations} | "
           f"{r.build_time_s:.3f} | {r.solve_time_s:.3f} | {math.degrees(sol.contact_angle):.6f} | "
           f"{math.degrees(sol.analytic.contact_angle):.6f} | {e['shape']:.2e} | {e['contact_angle']:.2e} | "
           f"{e['span']:.2e} | {e['energy']:.2e} | {e['pressure']:.2e} |")
    return sol.success, row, f"![{title}]({name}.png)" if sol.success else f"*{title}: no picture (solve failed)*"


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
    with open(os.path.join(out, "droplet_angle.json"), "w") as fh:
        json.dump(jsonable(ang.as_dict()), fh, allow_nan=False)
    if ang.success:
        plotting.reduced_energy(ang, os.path.join(out, "droplet_angle.png"))
    lines += ["### Reduced problem in θ", "",
              f"θ* = {math.degrees(ang.contact_angle):.12f}° ({ang.status}, {ang.result.iterations} iterations), "
              f"Young residual {ang.young_residual:.2e}, R = {ang.radius:.10g}, E = {ang.energy:.10g}.", "",
              "![E(θ)](droplet_angle.png)", ""]

    # ---- convergence sweep
    ns = study.sweep_sizes(2048 if quick else 100_000)
    rows = study.droplet_sweep(ns)
    ok &= all(r["status"] == "ok" for r in rows)
    study.write_csv(rows, os.path.join(out, "droplet_convergence.csv"))
    plotting.droplet_convergence(rows, os.path.join(out, "droplet_convergence.png"))
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

    lines += [f"Report written in {time.perf_counter() - t0:.1f} s; every solve converged: {ok}."]
    with open(os.path.join(out, "summary.md"), "w") as fh:
        fh.write("\n".join(lines) + "\n")
    print(f"report written to {os.path.join(out, 'summary.md')} (all converged: {ok})")
    return 0 if ok else 1
