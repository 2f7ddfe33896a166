"""The report's droplet section (Exercise 2.1): four drops against the analytic cap, the reduced problem in
θ, and the convergence sweep (error against N and against run time)."""
from __future__ import annotations

import json
import math
import os
import time

from ...inspect import files, plotting, study
from ...solve import droplet
from ..scene import jsonable
from .common import Context

TITLE = "droplet"
TIMED = False


def _entry(out: str, name: str, title: str, drop: droplet.Droplet, n: int, formulation: str, carried):
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


def run(ctx: Context):
    out, size, progress = ctx.out, ctx.size, ctx.progress
    ok = True
    # ---- droplet scenes
    lines = ["## Droplet (Exercise 2.1)", "",
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
        good, row, pic = _entry(out, name, title, drop, n, form, ctx.carried)
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
    for f in droplet.POLYLINES:
        orders = study.observed_orders(rows, f)
        sel = [r for r in rows if r["formulation"] == f]
        lines.append(f"| {f} | " + " | ".join(f"{orders[k]:.2f}" for k in study.DROPLET_ERRORS)
                     + f" | {max(r['iterations'] for r in sel)} | {all(r['status'] == 'ok' for r in sel)} |")
    timed = [{**r, "label": r["formulation"], "time_s": r["total_time_s"]} for r in rows]
    lines += ["", "Reading (measured in this run, the shape error): "
              + study.reading(timed, list(droplet.POLYLINES), (1e-4, 1e-6, 1e-8), key="err_shape"), "",
              "![convergence](droplet_convergence.png)", ""]

    return ok, lines
