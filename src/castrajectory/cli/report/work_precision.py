"""The report's double-pendulum work-precision study, scipy's DOP853 and RK45 beside."""
from __future__ import annotations

import os

from ...inspect import files, plotting, study
from .common import Context

TITLE = 'double pendulum work-precision'
TIMED = True


def run(ctx: Context):
    """Double pendulum (T = 5 s, θ = (2, 1)): error at T and energy error against run time."""
    out, size = ctx.out, ctx.size
    import numpy as np

    from ...models import pendulum
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
