"""The report's contact work-precision study: bounce times and apexes against run time."""
from __future__ import annotations

import os

from ...inspect import files, plotting, study
from .common import Context

TITLE = 'contact work-precision'
TIMED = True


def run(ctx: Context):
    out, size = ctx.out, ctx.size
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
