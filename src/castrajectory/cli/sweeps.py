"""Flags shared by the scripts that run sweeps: where the runs go and how progress is shown.

``--workers N`` (a local process pool of N processes; 1, the default, runs them one after another
in this process: fair wall times), ``--dask-scheduler ADDRESS`` (a Dask cluster: the ``dist``
extra), ``--quiet`` (no progress bar, no line per run) and ``--progress`` (a bar on stderr even
when stderr is not a terminal).  The executor itself is
:func:`castrajectory.inspect.study.executor_for`.
"""
from __future__ import annotations

import argparse
import sys

from ..inspect import study
from ..validation import InputError


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


def executor(args, prog: str):
    """The executor the flags ask for; bad flags print one line on stderr and exit with code 2."""
    try:
        return study.executor_for(args.workers, args.dask_scheduler)
    except InputError as err:
        print(f"{prog}: error: {err}", file=sys.stderr)
        raise SystemExit(2) from None
