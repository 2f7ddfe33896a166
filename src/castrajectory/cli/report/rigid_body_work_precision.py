"""The report's rigid-body work-precision study: the flip interval against run time."""
from __future__ import annotations

import math
import os

from ...inspect import files, plotting, study
from .common import Context

TITLE = 'rigid-body work-precision'
TIMED = True


def run(ctx: Context):
    out, size = ctx.out, ctx.size
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
