"""``castrajectory report --out DIR``: solve every implemented scene at its defaults and write a report.

Writes, into ``DIR``: one JSON summary and one picture per scene run, the studies (CSV and plots) and
``summary.md`` linking them, and the same as one page, ``index.html``.  Returns exit code 0 only if every
solve converged and every stability case passed.

The report is a list of sections (:data:`SECTIONS`), one module each: a section is ``run(ctx) ->
(ok, lines)`` (:class:`.common.Context` holds the folder, the size and the progress printer), with its
``TITLE`` and ``TIMED`` (the runner prints its progress line; the scene sections print one per scene).
The scene sections show the scenes the registry (:mod:`castrajectory.cli.registry`) puts in them; a new
section is one module and one entry here.
"""
from __future__ import annotations

import os
import time
from typing import List

from ...inspect import files
from ...solve import interrupt
from . import (carries, collisions, contact, contact_control, contact_work_precision, derivations, droplet, drops_gravity,
               headline, long_horizon, mechanics, optimal_control, rigid_bodies, rigid_body_work_precision,
               stability_table, work_precision)
from .common import Context

#: The sections, in the report's order.
SECTIONS = [droplet, drops_gravity, collisions, contact, contact_work_precision, mechanics, work_precision, long_horizon,
            rigid_bodies, rigid_body_work_precision, optimal_control, contact_control, stability_table, derivations]


def _progress_printer(quiet: bool):
    """One line per finished scene or study on stdout (name, status, seconds); nothing when ``quiet``."""
    def progress(name: str, status: str, seconds: float) -> None:
        interrupt.check()  # a Ctrl-C that Python dropped inside a callback stops the report here
        if not quiet:
            print(f"  {name:60s} {status:28s} {seconds:7.2f} s", flush=True)
    return progress


#: The report's sizes: ``quick`` (the tests), ``default`` (225 s of CPU with a warm compile cache, measured for
#: issue 41; see docs/notes.md), ``full`` (the larger sweeps: the droplet to N = 10⁵, the pendulum to 16 000
#: steps).  No size has a time limit: the exit code says whether the answers are right, never how fast they came.
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
    ctx = Context(out, size, progress)
    lines: List[str] = ["# castrajectory report", ""]
    ok = True
    for section in SECTIONS:
        t1 = time.perf_counter()
        good, sec = section.run(ctx)
        if section.TIMED:
            progress(section.TITLE, "ok" if good else "FAILED", time.perf_counter() - t1)
        ok &= good
        lines += sec
    lines += carries.table(ctx.carried)

    interrupt.check()
    elapsed = time.perf_counter() - t0
    lines += [f"Report ({size}) written in {elapsed:.1f} s; every solve converged and every stability case "
              f"passed: {ok}."]
    passed = next((ln for ln in lines if ln.endswith("cases pass.")), "")
    lines[2:2] = ["What was solved, how accurately and at what cost (the scenes' own answers below; "
                  f"{size} report, {elapsed:.0f} s in all):", "", *headline.lines(out, f"Stability: {passed}")]
    files.write_text(os.path.join(out, "summary.md"), "\n".join(lines) + "\n")
    from .. import html  # the same content as one self-contained page: figures inline, animations playing
    html.write_index(out, "\n".join(lines) + "\n")
    print(f"report written to {os.path.join(out, 'summary.md')} and index.html in {elapsed:.1f} s "
          f"({'every solve converged, every stability case passed' if ok else 'SOME SOLVES OR CASES FAILED'})")
    return 0 if ok else 1
