"""The report's long-horizon study: bounded energy over many periods against RK4's drift."""
from __future__ import annotations

import os

from ...inspect import files, plotting, study
from .common import Context

TITLE = 'long horizon'
TIMED = True


def run(ctx: Context):
    """Small-amplitude pendulum over many periods: bounded energy (variational) against RK4 drift."""
    out, size = ctx.out, ctx.size
    import math as _m

    from ...models import pendulum
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
