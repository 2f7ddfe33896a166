"""The report's stability section: one table of stiff and extreme cases for every family (each scene's
cases from the registry, judged by their own oracles) and the contact battery's line."""
from __future__ import annotations

import time

from .. import stability
from .common import Context

TITLE = "stability"
TIMED = False

#: The report's slice of the contact battery (scripts/contact_battery.py): seed and scenes drawn.  (Default 6: the
#: 12 scenes, twins included, took 42 s of the default report's 444, on a loaded machine)
BATTERY_SEED, BATTERY_COUNT = 13, {"quick": 3, "default": 6, "full": 30}


def run(ctx: Context):
    """One stability table for every family (:mod:`castrajectory.cli.stability`): each case through its
    problem script, judged by its own oracle; a failed row is shown as failed and fails the report
    (``quick``: the first case of each family)."""
    progress, size = ctx.progress, ctx.size
    rows = []
    cases = stability.CASES if size != "quick" else list({c.family: c for c in reversed(stability.CASES)}.values())
    for case in cases:
        row = stability.run_case(case)
        rows.append(row)
        progress(f"stability: {case.family}: {case.title}", "solved" if row.passed else "FAILED", row.time_s)
    solved = sum(r.passed for r in rows)
    lines = ["## Stability on stiff and extreme cases", "",
             "Each case runs its problem script (the command shown) and is judged by its own oracle; a case "
             "passes only if the run ended as expected *and* the oracle holds. Drift: the energy's largest "
             "deviation over its largest size (contact: E(0) → E(T), which restitution below 1 lowers by design), "
             "or the spatial angular momentum's; error estimate: the answer's own (relative, Richardson).", "",
             *stability.table(rows), "", f"{solved} of {len(rows)} cases pass.", ""]
    return solved == len(rows), lines


def run_battery(ctx: Context):
    """The contact battery's line, a section of its own after the table (the report's pool runs the two side by
    side: together they were its longest section, 89 s of a 150 s default report)."""
    t1 = time.perf_counter()
    good, battery = battery_line(ctx.size)
    ctx.progress("stability: contact battery", "solved" if good else "FAILED", time.perf_counter() - t1)
    return good, [battery, ""]


def battery_line(size: str):
    """The contact battery's summary line: a seeded random set of ball, rectangle and bowl scenes, each
    solved in its own process and checked (gaps, complementarity, Newton's law, caught arrivals, elastic
    energy) with its impact times against the event-driven reference."""
    import numpy as np

    from ...inspect.battery import battery_task, draw_scenes
    t0 = time.perf_counter()
    scenes = draw_scenes(BATTERY_SEED, BATTERY_COUNT[size])
    # no wall-clock limit: a scene that a loaded machine runs slowly is measured, not failed (every solve stops at
    # its iteration limit)
    rows = [battery_task((sc, None)) for sc in scenes]
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
