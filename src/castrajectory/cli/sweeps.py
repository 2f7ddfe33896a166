"""What the scripts that run sweeps share: their flags, their executor, and how a sweep stops.

Flags: ``--workers N`` (a local process pool of N processes; 1, the default, runs them one after another
in this process: fair wall times), ``--dask-scheduler ADDRESS`` (a Dask cluster: the ``dist``
extra), ``--quiet`` (no progress bar, no line per run) and ``--progress`` (a bar on stderr even
when stderr is not a terminal).  The executor itself is
:func:`castrajectory.inspect.study.executor_for`.

Stopping.  A script runs its ``main`` through :func:`command` and its sweep through :func:`run`:

* SIGINT (Ctrl-C) or SIGTERM stops the sweep within about a second: a process pool's workers are
  ended at once (they ignore SIGINT, which is this process's to handle, and keep SIGTERM's default),
  a scene's child process ends with its worker, the rows of the runs that finished are written
  (atomically, to the script's usual CSV), and the script prints one line on stderr ("contact_battery.py:
  interrupted after 7 of 30 scenes; their rows are in battery/battery.csv") and exits 130 (143 for
  SIGTERM).  Outside the sweep an interrupt is the same one line and exit code, without rows.
* An executor that is lost midway (a Dask scheduler that dies, a pool's worker killed) keeps what
  finished the same way; the one line says what was lost and how many runs were not run; exit 1.
"""
from __future__ import annotations

import argparse
import concurrent.futures as cf
import logging
import signal
import sys
import threading
from typing import Callable, List, Optional

from ..inspect import study
from ..solve import interrupt
from ..validation import InputError
from .scene import _interrupted    # (a KeyboardInterrupt, or an error CasADi raised while a signal was pending)


def add_sweep_flags(p: argparse.ArgumentParser, workers_aliases=()) -> None:
    """Add ``--workers``, ``--dask-scheduler``, ``--quiet`` and ``--progress`` to ``p``."""
    p.add_argument("--workers", *workers_aliases, type=int, default=None, metavar="N",
                   help="run the sweep on a local pool of N processes (default 1: one after another in this "
                        "process, fair wall times; parallel runs on few cores disturb each other's times)")
    p.add_argument("--dask-scheduler", default=None, metavar="ADDRESS",
                   help="run the sweep on a Dask cluster, e.g. tcp://host:8786 (needs the 'dist' extra)")
    p.add_argument("--quiet", action="store_true", help="no progress bar and no line per run")
    p.add_argument("--progress", action="store_true", help="progress bar on stderr even when it is not a terminal")


def bar(args) -> bool | None:
    """The ``bar`` argument of a sweep: True with ``--progress``, else None (a bar when stderr is a terminal)."""
    return True if args.progress else None


def _worker_init() -> None:
    # a Ctrl-C (sent to the whole process group by a terminal) is the parent's to handle: it ends the pool with
    # SIGTERM, whose default ends a worker at once, inside Ipopt too, and no worker prints a traceback
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def executor(args, prog: str):
    """The executor the flags ask for; bad flags print one line on stderr and exit with code 2.  A process
    pool's workers leave signals to this process (see the module docstring): use it with :func:`run`."""
    try:
        ex = study.executor_for(args.workers, args.dask_scheduler)
    except InputError as err:
        print(f"{prog}: error: {err}", file=sys.stderr)
        raise SystemExit(2) from None
    if isinstance(ex, cf.ProcessPoolExecutor):
        # the same pool (none of its processes has started yet), with workers that ignore Ctrl-C
        ex.shutdown(wait=False)
        ex = cf.ProcessPoolExecutor(max_workers=args.workers, initializer=_worker_init)
    return ex


def command(main: Callable[..., int], prog: str, argv=None) -> int:
    """``main(argv)`` as a script's command: SIGINT and SIGTERM are interrupts (:func:`interrupt.install`), and
    one that stops ``main`` outside :func:`run` prints ``PROG: interrupted`` (``terminated``) on stderr and
    gives 130 (143), with no traceback.  Use as ``sys.exit(sweeps.command(main, "name.py"))``."""
    interrupt.install()
    try:
        return main(argv)
    except BaseException as exc:       # noqa: BLE001 - an interrupt is one line; anything else is raised again
        if isinstance(exc, SystemExit) or not _interrupted(exc):
            raise
        print(f"{prog}: {interrupt.what()}", file=sys.stderr)
        return interrupt.exit_code()


def run(prog: str, executor, sweep: Callable[[Callable], list], write: Callable[[list], str],
        total: Optional[int] = None, noun: str = "runs", progress: Optional[Callable] = None) -> list:
    """``sweep(on_result)`` on ``executor``, which this function shuts down; its results when every run finished.

    ``sweep`` calls the study's sweep with ``progress=on_result`` (and the same ``executor``); ``progress(result)``
    is the script's own line per run (None: no line).  If the sweep stops (a signal, a lost executor), the
    executor is stopped at once, ``write(finished)`` writes the results of the runs that finished (in the
    order they finished; called only if there are any) and returns the path it wrote them to, one line goes
    to stderr (``total`` runs of ``noun`` in all, for the count) and this raises ``SystemExit``: 130 for
    SIGINT, 143 for SIGTERM, 1 for a lost executor.  Any other error (a bug in a task) is raised again,
    after the finished rows are written and a note naming their file is added to it."""
    finished: List = []

    def on_result(result):
        # a signal that Python or CasADi dropped is acted on here; the run that just returned with it pending
        # may be the one it stopped (a failed row), so it is not kept
        interrupt.check()
        finished.append(result)
        if progress is not None:
            progress(result)

    logs = _HeldLogs(executor)
    try:
        results = sweep(on_result)
        interrupt.check()
    except BaseException as exc:      # noqa: BLE001 - every way out writes what finished
        _stopped(prog, exc, executor, logs, finished, write, total, noun)
        raise                          # (not reached: _stopped raises)
    try:
        executor.shutdown(wait=True)
    finally:
        logs.release()
    return results


# ----------------------------------------------------------------------------- a sweep that stopped
def _is_dask(executor) -> bool:
    return getattr(executor, "client", None) is not None


def _lost(exc: BaseException, executor) -> Optional[str]:
    """What was lost, if ``exc`` says the executor was (not a task's own error); else None."""
    if isinstance(exc, cf.BrokenExecutor):
        return "a worker process of the pool died"
    if _is_dask(executor):
        client = executor.client
        # the client cancels every future when it loses the scheduler (a task's own error is not a cancellation)
        if isinstance(exc, cf.CancelledError) or str(getattr(client, "status", "running")) != "running":
            try:
                where = f" at {client.scheduler.address}"
            except Exception:  # noqa: BLE001 - the address is only for the message
                where = ""
            return f"lost the Dask scheduler{where}"
    return None


def _stop(executor) -> None:
    """Stop ``executor`` now: no run waits for another; a process pool's workers are ended (SIGTERM)."""
    try:
        if isinstance(executor, cf.ProcessPoolExecutor):
            _end_pool(executor)
        else:
            executor.shutdown(wait=False, cancel_futures=True)
    except Exception:  # noqa: BLE001 - a broken executor may fail to shut down; the sweep stops anyway
        pass


def _end_pool(pool: cf.ProcessPoolExecutor) -> None:
    """End the pool's workers (SIGTERM) and wait for them and the pool's manager thread (a few hundredths of a
    second; ``shutdown(wait=True)`` would wait for the runs in progress to finish: 6 to 23 s measured)."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    manager = getattr(pool, "_executor_manager_thread", None)
    previous = threading.excepthook

    def hook(args):
        # CPython 3.11's manager thread, finding a worker gone, sets an exception on every pending future, the
        # cancelled ones too, and dies printing InvalidStateError's traceback (3.12 ignores those)
        if not issubclass(args.exc_type, cf.InvalidStateError):
            previous(args)

    threading.excepthook = hook
    try:
        for p in procs:
            if p.is_alive():
                p.terminate()
        pool.shutdown(wait=False, cancel_futures=True)
        for p in procs:
            p.join(2.0)
        if manager is not None:
            manager.join(2.0)
    finally:
        threading.excepthook = previous


def _stopped(prog, exc, executor, logs, finished, write, total, noun):
    """Stop the executor, write what finished, say so in one line and exit (see :func:`run`)."""
    interrupted = _interrupted(exc)
    if interrupted:
        code, what = interrupt.exit_code(), interrupt.what()
    lost = None if interrupted else _lost(exc, executor)     # (before the client is closed)
    path, unwritten = None, None
    try:
        _stop(executor)
        logs.drop()
        if interrupted:
            interrupt.install()     # (the signal is acted on: a write's own safe point must not stop it again)
        if finished:
            try:
                path = write(finished)
            except Exception as err:  # noqa: BLE001 - the one line says so
                unwritten = f"writing them failed: {type(err).__name__}: {(str(err).splitlines() or [''])[0]}"
    except KeyboardInterrupt:       # a second Ctrl-C while stopping or writing: the write is left undone
        unwritten = unwritten or "a second interrupt stopped the write"
    k = len(finished)
    of = f" of {total}" if total is not None else ""
    if path is not None:
        kept = f"their rows are in {path}"
    elif k:
        kept = f"their rows were not written ({unwritten})"
    else:
        kept = "nothing written"
    if interrupted:
        when = f"after {k}{of} {noun}" if k else f"before any{of} {noun} finished"
        print(f"{prog}: {what} {when}; {kept}", file=sys.stderr)
        raise SystemExit(code)
    if lost is not None:
        not_run = f"{total - k} of {total}" if total is not None else "the rest of the"
        print(f"{prog}: {lost}; {not_run} {noun} not run; {k} finished, {kept}", file=sys.stderr)
        raise SystemExit(1)
    if k and hasattr(exc, "add_note"):
        exc.add_note(f"{prog}: {k}{of} {noun} finished; {kept}")
    raise exc


class _HeldLogs(logging.Filter):
    """On a Dask executor, Dask's warnings and errors while the sweep runs are held back: passed on if the sweep
    finishes (:meth:`release`), dropped if it stops (:meth:`drop`), whose one line says what happened (a lost
    scheduler made ``distributed.client`` log two tracebacks, 35 lines, before the sweep's own)."""

    def __init__(self, executor):
        super().__init__()
        self.records: list = []
        self.handlers: list = []
        if not _is_dask(executor):
            return
        names = ["distributed"] + [n for n in list(logging.root.manager.loggerDict) if n.startswith("distributed.")]
        for name in names:
            for h in logging.getLogger(name).handlers:
                if h not in self.handlers:
                    h.addFilter(self)
                    self.handlers.append(h)

    def filter(self, record) -> bool:
        if record.levelno >= logging.WARNING:
            self.records.append(record)
            return False
        return True

    def drop(self) -> None:
        for h in self.handlers:
            h.removeFilter(self)
        self.handlers, self.records = [], []

    def release(self) -> None:
        records = self.records
        self.drop()
        for r in records:
            logging.getLogger(r.name).handle(r)
