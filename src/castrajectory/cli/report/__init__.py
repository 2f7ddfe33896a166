"""``castrajectory report --out DIR``: solve every implemented scene at its defaults and write a report.

Writes, into ``DIR``: one JSON summary and one picture per scene run, the studies (CSV and plots) and
``summary.md`` linking them, and the same as one page, ``index.html``.  Returns exit code 0 only if every
solve converged and every stability case passed.

The report is a list of sections (:data:`SECTIONS`), one module each: a section is ``run(ctx) ->
(ok, lines)`` (:class:`.common.Context` holds the folder, the size and the progress printer), with its
``TITLE`` and ``TIMED`` (the runner prints its progress line; the scene sections print one per scene).
The scene sections show the scenes the registry (:mod:`castrajectory.cli.registry`) puts in them; a new
section is one module and one entry here.  The sections run in a pool of ``jobs`` processes (one per core by
default), the longest first; the summary keeps their order.
"""
from __future__ import annotations

import glob
import importlib
import multiprocessing
import os
import shutil
import signal
import tempfile
import time
from typing import List, Optional

from ...inspect import files
from ...solve import interrupt
from . import (carries, collisions, contact, contact_battery, contact_control, contact_work_precision, derivations,
               droplet, drops_gravity, headline, long_horizon, mechanics, optimal_control, rigid_bodies,
               rigid_body_work_precision, stability_table, work_precision)
from .common import Context

#: The sections, in the report's order.
SECTIONS = [droplet, drops_gravity, collisions, contact, contact_work_precision, mechanics, work_precision, long_horizon,
            rigid_bodies, rigid_body_work_precision, optimal_control, contact_control, stability_table, contact_battery,
            derivations]

#: Seconds each section took in a default report (measured in one run, warm compile cache, 2 processes on 2 cores;
#: the sections not named took under 10 s): the pool starts the longest first, so that no long one starts last.
SECONDS = {stability_table: 54.0, contact_battery: 35.0, drops_gravity: 34.0, contact_control: 33.0,
           rigid_body_work_precision: 26.0, mechanics: 20.0, work_precision: 12.0, contact: 10.0}


def _progress_printer(quiet: bool):
    """One line per finished scene or study on stdout (name, status, seconds); nothing when ``quiet``."""
    def progress(name: str, status: str, seconds: float) -> None:
        interrupt.check()  # a Ctrl-C that Python dropped inside a callback stops the report here
        if not quiet:
            print(f"  {name:60s} {status:28s} {seconds:7.2f} s", flush=True)
    return progress


#: The report's sizes: ``quick`` (the tests), ``default`` (138 s wall and 251 s of CPU on 2 cores with a warm compile
#: cache, measured for issue 41; see docs/notes.md), ``full`` (the larger sweeps: the droplet to N = 10⁵, the pendulum to 16 000
#: steps).  No size has a time limit: the exit code says whether the answers are right, never how fast they came.
SIZES = ("quick", "default", "full")


def _section(name: str, out: str, size: str, quiet: bool):
    """Run the section module ``name``: ``(ok, lines, carried)`` (in the pool's workers too)."""
    section = importlib.import_module(name)
    ctx = Context(out, size, _progress_printer(quiet))
    t1 = time.perf_counter()
    good, sec = section.run(ctx)
    if section.TIMED:
        ctx.progress(section.TITLE, "ok" if good else "FAILED", time.perf_counter() - t1)
    return good, sec, ctx.carried


def _worker_init() -> None:
    # a Ctrl-C is the parent's to handle: it stops the pool (terminate: SIGTERM, whose default ends a worker at
    # once, inside Ipopt too), and no worker prints a traceback; what a worker was writing lies in the report's
    # partial folder, which the parent removes
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    # and a report killed outright (SIGKILL) takes its workers with it: on Linux the kernel sends them SIGKILL
    # when the parent dies (they solved on for 26 s, holding the caller's pipes open)
    try:
        import ctypes
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)      # PR_SET_PDEATHSIG = 1
    except (OSError, AttributeError):
        pass


def _run_sections(out: str, size: str, quiet: bool, jobs: int) -> list:
    """Every section's ``(ok, lines, carried)``, in :data:`SECTIONS`' order."""
    names = [s.__name__ for s in SECTIONS]
    if jobs <= 1:
        return [_section(name, out, size, quiet) for name in names]
    pool = multiprocessing.get_context("spawn").Pool(jobs, initializer=_worker_init)
    try:
        started = {}
        for s in sorted(SECTIONS, key=lambda s: -SECONDS.get(s, 0.0)):
            started[s.__name__] = pool.apply_async(_section, (s.__name__, out, size, quiet))
        pool.close()
        results = []
        for name in names:
            r = started[name]
            while not r.ready():        # (waits that a Ctrl-C can interrupt)
                r.wait(0.2)
                interrupt.check()
            results.append(r.get())
        pool.join()
        return results
    finally:
        pool.terminate()


def write_report(out: str, size: str = "default", quiet: bool = False, jobs: Optional[int] = None) -> int:
    """Solve every scene and study at ``size`` and write ``DIR/summary.md`` (0: every solve converged and
    every stability case passed; 1 otherwise, after the whole report is written).  ``jobs``: processes that run
    the sections (default: one per core; 1 runs them in this process).  The report is written into a hidden
    folder beside ``out`` and moved into place when it is whole (:func:`_move_into_place`): an interrupted,
    terminated or killed run leaves an earlier report in ``out`` as it was."""
    if size not in SIZES:
        raise ValueError(f"size must be one of {SIZES}")
    if os.path.exists(out) and not os.path.isdir(out):
        raise ValueError(f"--out {out}: a file, not a folder")
    jobs = min(len(SECTIONS), os.cpu_count() or 1) if jobs is None else int(jobs)
    interrupt.install()
    t0 = time.perf_counter()
    final = out
    out = _partial_folder(final)
    try:
        code = _write(out, size, quiet, jobs)
        _move_into_place(out, final)
    except BaseException:
        shutil.rmtree(out, ignore_errors=True)
        raise
    print(f"report written to {os.path.join(final, 'summary.md')} and index.html in {time.perf_counter() - t0:.1f} s "
          f"({'every solve converged, every stability case passed' if code == 0 else 'SOME SOLVES OR CASES FAILED'})")
    return code


def _partial_folder(final: str) -> str:
    """A new hidden folder beside ``final`` (same file system) that the report is written into, named by this
    process; those of processes that are gone (a report killed with SIGKILL) are removed first."""
    parent, base = os.path.split(os.path.abspath(final))
    os.makedirs(parent, exist_ok=True)
    for old in glob.glob(os.path.join(parent, f".{glob.escape(base)}.partial-*")):
        pid = os.path.basename(old)[len(base) + 10:].split("-")[0]
        if pid.isdigit() and not _alive(int(pid)):
            shutil.rmtree(old, ignore_errors=True)
    tmp = tempfile.mkdtemp(prefix=f".{base}.partial-{os.getpid()}-", dir=parent)
    mask = os.umask(0)
    os.umask(mask)
    os.chmod(tmp, 0o777 & ~mask)      # (mkdtemp's is private; the report's folder gets an ordinary one's mode)
    return tmp


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True


def _move_into_place(partial: str, final: str) -> None:
    """The finished report moved from ``partial`` into ``final``: the whole folder where ``final`` is new, else
    file by file (each rename atomic) with ``summary.md`` and ``index.html`` last, so that a report stopped
    before this point leaves the earlier one as it was, never beside files of its own."""
    if not os.path.exists(final):
        os.replace(partial, final)
        return
    last = ("summary.md", "index.html")
    names = sorted(os.listdir(partial), key=lambda n: (n in last, last.index(n) if n in last else 0, n))
    for name in names:
        src, dst = os.path.join(partial, name), os.path.join(final, name)
        if os.path.isdir(src) and os.path.isdir(dst):
            shutil.rmtree(dst)
        os.replace(src, dst)
    os.rmdir(partial)


def _write(out: str, size: str, quiet: bool, jobs: int) -> int:
    """The report written into the folder ``out`` (:func:`write_report`)."""
    t0 = time.perf_counter()
    lines: List[str] = ["# castrajectory report", ""]
    ok, carried = True, []
    for good, sec, car in _run_sections(out, size, quiet, jobs):
        ok &= good
        lines += sec
        carried += car
    lines += carries.table(carried)

    interrupt.check()
    elapsed = time.perf_counter() - t0
    lines += [f"Report ({size}) written in {elapsed:.1f} s by {jobs} process{'es' if jobs > 1 else ''}; every solve "
              f"converged and every stability case passed: {ok}."]
    passed = next((ln for ln in lines if ln.endswith("cases pass.")), "")
    lines[2:2] = ["What was solved, how accurately and at what cost (the scenes' own answers below; "
                  f"{size} report, {elapsed:.0f} s in all):", "", *headline.lines(out, f"Stability: {passed}")]
    files.write_text(os.path.join(out, "summary.md"), "\n".join(lines) + "\n")
    from .. import html  # the same content as one self-contained page: figures inline, animations playing
    html.write_index(out, "\n".join(lines) + "\n")
    return 0 if ok else 1
