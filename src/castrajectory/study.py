"""Error-against-run-time studies (work–precision sweeps).

A sweep solves one scene over a list of sizes and records, per run, the
errors against the analytic oracle and the wall times.  Runs go through an
``Executor``-like object with a ``map`` method; the default runs them one after
another in this process, which is what timing needs (parallel runs on a
two-core machine would distort each other's wall times).
"""
from __future__ import annotations

import csv
import math
from typing import Callable, Iterable, List, Optional, Sequence

import numpy as np

from . import droplet

DROPLET_ERRORS = ("shape", "contact_angle", "span", "energy", "pressure")


class SerialExecutor:
    """Runs tasks in order in this process (the default: fair wall times)."""

    def map(self, fn, *iterables):
        return map(fn, *iterables)


def droplet_run(drop: droplet.Droplet, formulation: str, n: int) -> dict:
    """One row of a droplet sweep."""
    sol = droplet.solve(drop, n, formulation)
    r = sol.result
    row = {"formulation": formulation, "n": n, "status": sol.status, "iterations": r.iterations,
           "build_time_s": r.build_time_s, "solve_time_s": r.solve_time_s,
           "total_time_s": r.build_time_s + r.solve_time_s}
    row.update({f"err_{k}": v for k, v in sol.errors.items()})
    return row


def droplet_sweep(ns: Sequence[int], formulations: Iterable[str] = droplet.FORMULATIONS,
                  drop: Optional[droplet.Droplet] = None, executor=None,
                  progress: Optional[Callable[[dict], None]] = None) -> List[dict]:
    """Solve the droplet for every formulation and ``n``; return one row per run."""
    drop = drop or droplet.Droplet()
    executor = executor or SerialExecutor()
    tasks = [(f, int(n)) for f in formulations for n in ns]
    rows = []
    for row in executor.map(lambda t: droplet_run(drop, *t), tasks):
        rows.append(row)
        if progress:
            progress(row)
    return rows


def loglog_slope(x: Sequence[float], y: Sequence[float]) -> float:
    """Least-squares slope of ``log y`` against ``log x``."""
    lx, ly = np.log(np.asarray(x, float)), np.log(np.asarray(y, float))
    return float(np.polyfit(lx, ly, 1)[0])


def observed_orders(rows: List[dict], formulation: str, n_min: int = 32, floor: float = 1e-12) -> dict:
    """Order ``p`` in ``err ~ N^-p`` for each error, fitted over ``N >= n_min`` and errors above ``floor``.

    Errors at the round-off floor carry no information about the order, hence the cut.
    """
    out = {}
    sel = [r for r in rows if r["formulation"] == formulation and r["n"] >= n_min and r["status"] == "ok"]
    for k in DROPLET_ERRORS:
        pts = [(r["n"], r[f"err_{k}"]) for r in sel if r[f"err_{k}"] > floor]
        out[k] = -loglog_slope(*zip(*pts)) if len(pts) >= 2 else math.nan
    return out


def write_csv(rows: List[dict], path: str) -> None:
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def sweep_sizes(n_max: int = 100_000, n_min: int = 8) -> List[int]:
    """Roughly geometric sizes from ``n_min`` to ``n_max`` (both included), factor ~2."""
    ns = [n_min]
    while ns[-1] * 2 < n_max:
        ns.append(ns[-1] * 2)
    ns.append(n_max)
    return ns
