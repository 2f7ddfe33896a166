"""Error-against-run-time studies (work–precision sweeps).

A sweep solves one scene over a list of sizes and records, per run, the
errors against the analytic oracle and the wall times.

Executors.  Every run of a sweep is a *task*: a module-level function with
plain-data arguments (numbers, strings, dicts, a picklable system factory such
as ``pendulum.double_pendulum``), never a lambda or a CasADi object (CasADi's SX
expressions do not pickle; a task builds its system where it runs).  Tasks go
through a :class:`concurrent.futures.Executor`, which :func:`executor_for`
picks: :class:`SerialExecutor` (the default: one after another in this
process, which is what timing needs, since parallel runs on a two-core machine
distort each other's wall times), a local process pool, or a Dask cluster.
Rows come back in task order and hold the same values whichever executor ran
them; only the timing columns (:data:`TIMING_COLUMNS`) differ.

Progress.  A sweep draws a tqdm bar on stderr when stderr is a terminal (or
when asked with ``bar=True``); ``quiet=True`` silences it.  Nothing is written
to stdout.
"""
from __future__ import annotations

import concurrent.futures as cf
import csv
import functools
import math
import sys
from typing import Callable, Iterable, List, Optional, Sequence

import numpy as np

from ..models import collision
from ..solve import droplet
from ..baselines import stepping
from ..solve import trajectory
from ..validation import InputError
from . import files

DROPLET_ERRORS = ("shape", "contact_angle", "span", "energy", "pressure")

#: Columns of sweep rows that measure time (they differ from run to run; everything else must not).
TIMING_COLUMNS = frozenset({"build_time_s", "solve_time_s", "total_time_s", "time_s", "wall_time_s", "wall_s"})


# ----------------------------------------------------------------------------- executors
class SerialExecutor(cf.Executor):
    """Runs tasks in order in this process (the default: fair wall times).

    ``submit`` runs the call at once and returns a finished future; ``map`` is
    lazy, like the built-in ``map``.
    """

    def submit(self, fn, /, *args, **kwargs):
        fut = cf.Future()
        try:
            fut.set_result(fn(*args, **kwargs))
        except Exception as exc:  # noqa: BLE001 - handed to whoever reads the future
            fut.set_exception(exc)
        return fut

    def map(self, fn, *iterables, timeout=None, chunksize=1):
        return map(fn, *iterables)


class _DaskExecutor(cf.Executor):
    """``Client.get_executor()`` that also closes its client on ``shutdown``."""

    def __init__(self, client):
        self.client = client
        self._ex = client.get_executor(pure=False)   # pure=False: two equal tasks are two runs

    def submit(self, fn, /, *args, **kwargs):
        return self._ex.submit(fn, *args, **kwargs)

    def map(self, fn, *iterables, timeout=None, chunksize=1):
        return self._ex.map(fn, *iterables, timeout=timeout)

    def shutdown(self, wait=True, *, cancel_futures=False):
        try:
            self._ex.shutdown(wait=wait and not cancel_futures)
        finally:
            self.client.close()

    def __repr__(self):
        return f"<Dask executor on {self.client.scheduler.address}>"


def executor_for(workers: Optional[int] = None, dask_scheduler: Optional[str] = None) -> cf.Executor:
    """The executor of a sweep: serial, a local process pool or a Dask cluster.

    * ``workers`` None or 1 and no ``dask_scheduler``: :class:`SerialExecutor`;
    * ``workers = N > 1``: ``concurrent.futures.ProcessPoolExecutor(N)``;
    * ``dask_scheduler = "tcp://host:8786"``: the executor of a
      ``distributed.Client`` connected to that scheduler (the ``dist`` extra:
      ``pip install "castrajectory[dist]"``); its ``shutdown`` closes the client.

    Use it as a context manager (``with executor_for(...) as ex:``) so that
    the pool or the client is released.  Raises :class:`InputError` (one
    sentence) for ``workers < 1``, both arguments at once, a missing ``dist``
    extra or a scheduler that cannot be reached.
    """
    if dask_scheduler is not None:
        if workers not in (None, 1):
            raise InputError("give --workers or --dask-scheduler, not both "
                             "(the Dask cluster decides how many workers run)")
        try:
            import distributed
        except ImportError:
            raise InputError("--dask-scheduler needs Dask: pip install \"castrajectory[dist]\" "
                             "(or pip install \"dask[distributed]\")") from None
        try:
            client = distributed.Client(dask_scheduler, timeout="10s")
        except (OSError, TimeoutError, ValueError) as err:
            raise InputError(f"cannot reach the Dask scheduler at {dask_scheduler}: "
                             f"{str(err).splitlines()[0] if str(err) else type(err).__name__}") from None
        return _DaskExecutor(client)
    if workers is None or workers == 1:
        return SerialExecutor()
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise InputError(f"--workers must be a whole number >= 1 (got {workers!r})")
    return cf.ProcessPoolExecutor(max_workers=workers)


def _needs_pickling(executor) -> bool:
    return not isinstance(executor, (SerialExecutor, cf.ThreadPoolExecutor))


def progress_bar(total: int, desc: str, bar: Optional[bool] = None, quiet: bool = False):
    """A tqdm bar on stderr: shown when ``bar`` is True, or when ``bar`` is None and stderr
    is a terminal; never with ``quiet``.  Returns a disabled bar otherwise (same methods)."""
    show = (not quiet) and (bar if bar is not None else _isatty(sys.stderr))
    return _bar_class()(total=total, desc=desc, unit="run", file=sys.stderr, disable=not show,
                        dynamic_ncols=True, leave=True, smoothing=0.1, miniters=1)


@functools.lru_cache(maxsize=None)
def _bar_class():
    """tqdm without its monitor thread (``miniters=1`` makes it unnecessary), so that a sweep's
    process forks no extra thread into a process pool's workers."""
    from tqdm import tqdm

    class Bar(tqdm):
        monitor_interval = 0

    return Bar


def _isatty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def run_tasks(fn: Callable, tasks: Sequence, executor: Optional[cf.Executor] = None,
              progress: Optional[Callable[[object], None]] = None, bar: Optional[bool] = None,
              quiet: bool = False, desc: str = "sweep", label: Optional[Callable[[object], str]] = None) -> list:
    """``[fn(t) for t in tasks]`` through ``executor`` (serial by default), in task order.

    ``progress(result)`` is called as each task finishes (in task order when
    serial, in order of completion otherwise), with the bar (see
    :func:`progress_bar`) lifted off the terminal while it prints.
    ``label(result)``, if given, is shown after the bar.  The first task that
    raises cancels those not yet started and re-raises.
    """
    from tqdm import tqdm

    tasks = list(tasks)
    executor = executor or SerialExecutor()
    results: list = [None] * len(tasks)
    with progress_bar(len(tasks), desc, bar, quiet) as pb:
        def done(i, res):
            results[i] = res
            if progress is not None:
                if pb.disable:
                    progress(res)
                else:
                    with tqdm.external_write_mode():
                        progress(res)
            if label is not None and not pb.disable:
                pb.set_postfix_str(label(res), refresh=False)
            pb.update(1)

        if isinstance(executor, SerialExecutor):
            for i, t in enumerate(tasks):
                done(i, fn(t))
            return results
        futures = {executor.submit(fn, t): i for i, t in enumerate(tasks)}
        try:
            for fut in cf.as_completed(futures):
                done(futures[fut], fut.result())
        except BaseException:
            for fut in futures:
                fut.cancel()
            raise
    return results


# ----------------------------------------------------------------------------- droplet
def droplet_run(drop: droplet.Droplet, formulation: str, n: int) -> dict:
    """One row of a droplet sweep."""
    sol = droplet.solve(drop, n, formulation)
    r = sol.result
    row = {"formulation": formulation, "n": n, "status": sol.status, "iterations": r.iterations,
           "build_time_s": r.build_time_s, "solve_time_s": r.solve_time_s,
           "total_time_s": r.build_time_s + r.solve_time_s}
    row.update({f"err_{k}": v for k, v in sol.errors.items()})
    return row


def _droplet_task(drop: droplet.Droplet, task) -> dict:
    formulation, n = task
    return droplet_run(drop, formulation, n)


def droplet_sweep(ns: Sequence[int], formulations: Iterable[str] = droplet.POLYLINES,
                  drop: Optional[droplet.Droplet] = None, executor: Optional[cf.Executor] = None,
                  progress: Optional[Callable[[dict], None]] = None, bar: Optional[bool] = None,
                  quiet: bool = False) -> List[dict]:
    """Solve the droplet for every formulation and ``n``; return one row per run (in task order).

    ``executor``: see :func:`executor_for` (serial by default); ``progress(row)`` as each run
    finishes; ``bar`` / ``quiet``: the progress bar (:func:`progress_bar`).
    """
    drop = drop or droplet.Droplet()
    tasks = [(f, int(n)) for f in formulations for n in ns]
    return run_tasks(functools.partial(_droplet_task, drop), tasks, executor, progress, bar, quiet,
                     desc="droplet", label=lambda r: f"{r['formulation']} N={r['n']}")


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
    """``rows`` as a CSV file, written atomically (:mod:`.files`)."""
    def write(tmp):
        with open(tmp, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(dict.fromkeys(k for r in rows for k in r)), restval="")
            w.writeheader()
            w.writerows(rows)
    files.write_atomically(path, write)


def sweep_sizes(n_max: int = 100_000, n_min: int = 8) -> List[int]:
    """Roughly geometric sizes from ``n_min`` to ``n_max`` (both included), factor ~2."""
    ns = [n_min]
    while ns[-1] * 2 < n_max:
        ns.append(ns[-1] * 2)
    ns.append(n_max)
    return ns


# ----------------------------------------------------------------------------- trajectories
# Work–precision of the trajectory methods (:func:`castrajectory.solve.simulate.simulate`) against
# the CVODES reference, and long-horizon energy behaviour.

#: Methods whose runs do not depend on a discrete-Lagrangian scheme.
SCHEMELESS_METHODS = ("rk4", "implicit-euler")


def trajectory_label(method: str, scheme: Optional[str]) -> str:
    """``"whole-galerkin4"``, ``"march-midpoint"``, ``"rk4"`` …: one name per curve."""
    return method if (scheme is None or method in SCHEMELESS_METHODS) else f"{method}-{scheme}"


def _system_of(system_or_factory):
    """``(system, factory)``: a ``LagrangianSystem`` is used as is; anything else is called."""
    from ..models.mechanics import LagrangianSystem

    if isinstance(system_or_factory, LagrangianSystem):
        return system_or_factory, None
    if callable(system_or_factory):
        return system_or_factory(), system_or_factory
    raise TypeError("system must be a LagrangianSystem or a function returning one")


def _ns_for(ns, method: str, scheme: Optional[str]) -> List[int]:
    """The sizes of ``(method, scheme)``: ``ns`` is a list for all, or a dict keyed by
    ``(method, scheme)``, ``trajectory_label(method, scheme)`` or ``method``."""
    if not isinstance(ns, dict):
        return [int(n) for n in ns]
    for key in ((method, scheme), trajectory_label(method, scheme), method):
        if key in ns:
            return [int(n) for n in ns[key]]
    raise KeyError(f"no sizes given for method {method!r} with scheme {scheme!r}")


def _nan_row_errors(row: dict) -> dict:
    row.update(error_final=math.nan, energy_error_max=math.nan)
    return row


def trajectory_run(system, q0, qd0, T: float, n: int, method: str, scheme: Optional[str],
                   q_ref_final: np.ndarray, E0: float, options: Optional[dict] = None) -> dict:
    """One row of a trajectory work–precision sweep (see :func:`work_precision_sweep`).

    ``system`` is a ``LagrangianSystem`` or a factory (a fresh system per run, so
    that every run pays for building its own CasADi functions).  A run that
    fails, or raises anything but an ``InputError``, gives a row with
    ``status != "ok"`` and NaN errors.
    """
    import time

    from ..solve.simulate import simulate
    from ..validation import InputError

    sys_, _ = _system_of(system)
    row = {"label": trajectory_label(method, scheme), "method": method,
           "scheme": None if method in SCHEMELESS_METHODS else scheme, "n": int(n), "h": T / n}
    wall = time.perf_counter()
    try:
        run = simulate(sys_, q0, qd0, T, int(n), scheme or "midpoint", method, options=options)
    except InputError:
        raise
    except Exception as err:  # noqa: BLE001 - a crashed run is a failed row, not a crashed sweep
        row.update(status=f"exception: {type(err).__name__}: {err}", success=False, iterations=0,
                   levels=0, build_time_s=math.nan, solve_time_s=math.nan, time_s=math.nan,
                   wall_time_s=time.perf_counter() - wall)
        return _nan_row_errors(row)
    wall = time.perf_counter() - wall
    levels = len(getattr(run.detail, "levels", None) or [])
    row.update(status=run.status, success=bool(run.success and run.status == "ok"),
               iterations=int(run.iterations), levels=levels,
               build_time_s=float(run.build_time_s), solve_time_s=float(run.solve_time_s),
               time_s=float(run.build_time_s + run.solve_time_s), wall_time_s=wall)
    q_end = np.asarray(run.q, float)[-1]
    if not row["success"] or not np.all(np.isfinite(q_end)):
        row["success"] = False
        if row["status"] == "ok":
            row["status"] = "non-finite"
        return _nan_row_errors(row)
    row["error_final"] = float(np.max(np.abs(q_end - q_ref_final)))
    row["energy_error_max"] = float(np.max(np.abs(np.asarray(run.energy, float) - E0)))
    return row


def _trajectory_task(system, q0, qd0, T, q_ref, E0, options, task):
    method, scheme, n = task
    return trajectory_run(system, q0, qd0, T, n, method, scheme, q_ref, E0, options)


def work_precision_sweep(system, q0, qd0, T: float, methods_schemes: Sequence[tuple], ns,
                         executor: Optional[cf.Executor] = None, reference_rtol: float = 1e-13,
                         reference_atol: Optional[float] = None, options: Optional[dict] = None,
                         warmup: bool = True, progress: Optional[Callable[[dict], None]] = None,
                         bar: Optional[bool] = None, quiet: bool = False) -> List[dict]:
    """Solve one initial-value problem with every ``(method, scheme)`` and every ``N``.

    ``system``: a ``LagrangianSystem``, or a function returning one (then each
    run gets a fresh system and pays for all of its own function building).
    A process pool or a Dask cluster (``executor``, see :func:`executor_for`)
    needs the function, and a picklable one (a module-level factory such as
    ``pendulum.double_pendulum``, or a ``functools.partial`` of one): CasADi
    expressions do not pickle.  ``methods_schemes``:
    pairs such as ``("whole", "galerkin4")`` or ``("rk4", None)`` (the scheme
    of ``rk4`` / ``implicit-euler`` is ignored).  ``ns``: a list of step
    counts for every pair, or a dict keyed by ``(method, scheme)``, by the
    label ``"whole-galerkin4"`` or by the method.

    One row per run (in task order) with ``label, method, scheme, n, h,
    status, success, iterations, levels, build_time_s, solve_time_s, time_s``
    (build + solve), ``wall_time_s`` (the whole ``simulate`` call),
    ``error_final`` = max-abs error of ``q(T)`` against CVODES (computed once,
    :func:`castrajectory.baselines.stepping.reference` at ``reference_rtol``;
    ``reference_atol`` defaults to the same) and ``energy_error_max`` =
    ``max_k |E_k − E(q0, q̇0)|``.  Failed runs keep their row with
    ``status != "ok"``, ``success = False`` and NaN errors.

    ``warmup``: first run every pair once at ``N = 64``, untimed and in this
    process, so loading the Ipopt plugin and first-call set-up are billed to
    no row.  ``progress(row)`` is called as each run finishes; ``bar`` /
    ``quiet``: the progress bar (:func:`progress_bar`).
    """
    from ..baselines.stepping import reference

    sys0, factory = _system_of(system)
    executor = executor or SerialExecutor()
    if factory is None and _needs_pickling(executor):
        raise TypeError("work_precision_sweep: a process pool or a Dask cluster needs a picklable function "
                        "returning the system (e.g. pendulum.double_pendulum), not a built system")
    q0 = np.asarray(q0, float).reshape(-1)
    qd0 = np.asarray(qd0, float).reshape(-1)
    atol = reference_rtol if reference_atol is None else reference_atol
    q_ref = reference(sys0, q0, qd0, [T], rtol=reference_rtol, atol=atol)[0][-1]
    E0 = float(sys0.energy(q0, qd0))
    shared = factory if factory is not None else sys0
    pairs = [(m, s) for m, s in methods_schemes]
    if warmup:
        for m, s in pairs:
            trajectory_run(shared, q0, qd0, T, 64, m, s, q_ref, E0, options)
    tasks = [(m, s, n) for m, s in pairs for n in _ns_for(ns, m, s)]
    fn = functools.partial(_trajectory_task, shared, q0, qd0, T, q_ref, E0, options)
    return run_tasks(fn, tasks, executor, progress, bar, quiet, desc="work-precision",
                     label=lambda r: f"{r['label']} N={r['n']}")


def _select(rows: List[dict], label: str, key: str) -> List[dict]:
    """Successful rows of ``label`` with a finite positive ``key``, sorted by ``n``."""
    out = [r for r in rows if r.get("label") == label and r.get("status") == "ok"
           and np.isfinite(r.get(key, math.nan)) and r[key] > 0]
    return sorted(out, key=lambda r: r["n"])


def time_to_error(rows: List[dict], label: str, target: float, key: str = "error_final",
                  cost: str = "time_s") -> dict:
    """Cost for ``label``'s runs to reach ``key <= target``, interpolated in log-log.

    Walks the successful runs in order of ``n`` and takes the first one whose
    error is ``<= target``; the cost is interpolated linearly in
    ``(log cost, log error)`` between it and the run before.  Returns
    ``{"cost", "n", "note"}``: ``note`` is ``"interpolated"``, ``"at smallest
    N"`` (the first run already reached it: ``cost`` is an upper bound) or
    ``"not reached"`` (``cost`` and ``n`` are NaN).
    """
    sel = _select(rows, label, key)
    sel = [r for r in sel if np.isfinite(r.get(cost, math.nan)) and r[cost] > 0]
    for j, r in enumerate(sel):
        if r[key] <= target:
            if j == 0:
                return {"cost": float(r[cost]), "n": float(r["n"]), "note": "at smallest N"}
            a = sel[j - 1]
            le0, le1 = math.log(a[key]), math.log(r[key])
            w = (math.log(target) - le0) / (le1 - le0) if le1 != le0 else 1.0
            c = math.exp(math.log(a[cost]) + w * (math.log(r[cost]) - math.log(a[cost])))
            n = math.exp(math.log(a["n"]) + w * (math.log(r["n"]) - math.log(a["n"])))
            return {"cost": c, "n": n, "note": "interpolated"}
    return {"cost": math.nan, "n": math.nan, "note": "not reached"}


def trajectory_order(rows: List[dict], label: str, key: str = "error_final",
                     floor: float = 1e-11, ceiling: float = 1e-2, last: int = 3,
                     agree: float = 0.08) -> dict:
    """Observed order ``p`` in ``error ~ N^-p`` for ``label``, fitted on the asymptotic range.

    Candidates are the successful runs (in order of ``n``) with ``floor < error < ceiling``: above
    ``ceiling`` a chaotic trajectory is not yet resolved, below ``floor`` the reference and round-off
    dominate.  The fit uses the finest window of ``last`` consecutive candidates whose local orders
    ``log(e_{j-1}/e_j) / log(n_j/n_{j-1})`` agree within ``agree`` (relative to their mean): the
    asymptotic range.  A floor of the method (a solver tolerance amplified by a chaotic motion)
    bends the finest local orders (galerkin4 on the double pendulum at T = 5: 4.00, 4.00, 4.80, 0.62
    from N = 2000 to 16000; the old rule, a 1.5x stall test, kept the 4.80 pair and reported 2.72).
    Returns ``{"order", "points", "n_min", "n_max", "stalled_at", "note"}``; ``order`` is NaN, and
    ``note`` says why, when no window agrees (``"pre-asymptotic"`` when every error is above
    ``ceiling``: implicit Euler's 2.45 -> 0.83 over N = 250-8000).
    """
    allruns = _select(rows, label, key)
    sel = [r for r in allruns if floor < r[key] < ceiling]
    nan = {"order": math.nan, "points": len(sel), "n_min": math.nan, "n_max": math.nan, "stalled_at": math.nan}
    if len(sel) < 2:
        above = [r for r in allruns if r[key] >= ceiling]
        note = (f"pre-asymptotic: error >= {min(r[key] for r in above):.2g} up to N = {above[-1]['n']}"
                if above and len(above) == len(allruns) else "fewer than two runs in the asymptotic range")
        return {**nan, "note": note}
    local = [math.log(sel[j - 1][key] / sel[j][key]) / math.log(sel[j]["n"] / sel[j - 1]["n"])
             for j in range(1, len(sel))]
    width = max(1, min(last, len(sel)) - 1)  # local orders in a window
    for end in range(len(local), width - 1, -1):
        win = local[end - width:end]
        mean = sum(win) / len(win)
        if mean > 0 and all(abs(v - mean) <= agree * mean for v in win):
            pts = sel[end - width:end + 1]
            p = -loglog_slope([r["n"] for r in pts], [r[key] for r in pts])
            stalled = float(sel[end + 1]["n"]) if end + 1 < len(sel) else math.nan
            return {"order": p, "points": len(pts), "n_min": pts[0]["n"], "n_max": pts[-1]["n"],
                    "stalled_at": stalled, "note": "asymptotic window"}
    return {**nan, "note": "local orders do not settle: " + ", ".join(f"{v:.2f}" for v in local)}


def reading(rows: List[dict], labels: Sequence[str], targets: Sequence[float] = (1e-4, 1e-6, 1e-8),
            key: str = "error_final", cost: str = "time_s") -> str:
    """One measured line: at each target error, which method got there cheapest (interpolated in
    log-log, :func:`time_to_error`) and by how much, and which did not get there."""
    parts = []
    for target in targets:
        got = {lab: time_to_error(rows, lab, target, key, cost) for lab in labels}
        ok = sorted(((v["cost"], lab) for lab, v in got.items() if v["note"] != "not reached"))
        if not ok:
            parts.append(f"at {target:g} none of them")
            continue
        best = f"at {target:g} {ok[0][1]} wins ({ok[0][0]:.3g} s"
        best += f", {ok[1][0] / ok[0][0]:.1f}x ahead of {ok[1][1]})" if len(ok) > 1 else ", the only one)"
        parts.append(best)
    missed = [lab for lab in labels if time_to_error(rows, lab, min(targets), key, cost)["note"] == "not reached"]
    if len(missed) == len(labels):
        missed = []  # said above: none of them
    return "; ".join(parts) + (f"; {', '.join(missed)} never reached {min(targets):g} in the sweep" if missed else "") + "."


def peer_sweep(system, q0, qd0, T: float, methods: Sequence[str] = ("DOP853", "RK45"),
               rtols: Sequence[float] = (1e-4, 1e-6, 1e-8, 1e-10, 1e-12), reference_rtol: float = 1e-13,
               rhs: Optional[Callable] = None, suffix: str = "") -> List[dict]:
    """scipy's ``solve_ivp`` on the Euler–Lagrange ODE (the peers a user would otherwise reach for), in the
    rows of :func:`work_precision_sweep`: label ``scipy-<method><suffix>``, ``n`` its right-hand-side
    evaluations, ``time_s`` its wall time, ``error_final`` against the same CVODES reference.  The
    right-hand side is the system's compiled CasADi acceleration, or ``rhs(t, y)`` (``y = (q, q̇)``; e.g.
    the equations written by hand).  ``[]`` without scipy (the ``bench`` extra)."""
    try:
        from scipy.integrate import solve_ivp
    except ImportError:
        return []
    import time

    from ..baselines.stepping import reference

    sys0, _ = _system_of(system)
    q0 = np.asarray(q0, float).reshape(-1)
    qd0 = np.asarray(qd0, float).reshape(-1)
    nq = q0.size
    q_ref = reference(sys0, q0, qd0, [T], rtol=reference_rtol, atol=reference_rtol)[0][-1]
    E0 = float(sys0.energy(q0, qd0))
    acc = sys0.acceleration

    def casadi_rhs(t, y):
        return np.concatenate([y[nq:], np.asarray(acc(y[:nq], y[nq:]), float).reshape(-1)])

    rhs = rhs or casadi_rhs

    rows = []
    for method in methods:
        for rtol in rtols:
            t0 = time.perf_counter()
            sol = solve_ivp(rhs, (0.0, T), np.concatenate([q0, qd0]), method=method, rtol=rtol, atol=rtol)
            wall = time.perf_counter() - t0
            row = {"label": f"scipy-{method}{suffix}", "method": f"scipy-{method}", "scheme": None, "n": int(sol.nfev),
                   "h": math.nan, "rtol": rtol, "status": "ok" if sol.success else sol.message,
                   "success": bool(sol.success), "iterations": 0, "levels": 0, "build_time_s": 0.0,
                   "solve_time_s": wall, "time_s": wall, "wall_time_s": wall}
            if not sol.success:
                rows.append(_nan_row_errors(row))
                continue
            yT = sol.y[:, -1]
            row["error_final"] = float(np.max(np.abs(yT[:nq] - q_ref)))
            E = np.asarray(sys0.energies(sol.y[:nq].T, sol.y[nq:].T), float)
            row["energy_error_max"] = float(np.max(np.abs(E - E0)))
            rows.append(row)
    return rows


def energy_drift_summary(t, energy, E0: float, tail_fraction: float = 0.1) -> dict:
    """Long-horizon energy behaviour of one run: ``dE = |E − E0|`` against ``t``.

    ``max_first_half``, ``max_second_half``, ``max``: maxima of ``dE`` over the
    first and second half of the time span and overall; ``drift_slope``: slope
    of a least-squares line through ``(t, dE)`` (energy per unit time);
    ``first_tail_max`` / ``last_tail_max``: maxima of ``dE`` over the first and
    last ``tail_fraction`` of the span and ``tail_ratio`` their quotient
    (≈ 1 for a bounded oscillating error, ≫ 1 for a secular drift).
    """
    t = np.asarray(t, float).reshape(-1)
    dE = np.abs(np.asarray(energy, float).reshape(-1) - E0)
    if t.size != dE.size or t.size < 4:
        raise ValueError("energy_drift_summary: need matching t and energy with at least 4 samples")
    t0, t1 = t[0], t[-1]
    mid = t0 + 0.5 * (t1 - t0)
    first, second = dE[t <= mid], dE[t > mid]
    a, b = t0 + tail_fraction * (t1 - t0), t1 - tail_fraction * (t1 - t0)
    head, tail = dE[t <= a], dE[t >= b]
    finite = bool(np.all(np.isfinite(dE)))
    slope = float(np.polyfit(t, dE, 1)[0]) if finite else math.nan
    hmax, tmax = float(np.max(head)), float(np.max(tail))
    return {"max_first_half": float(np.max(first)), "max_second_half": float(np.max(second)),
            "max": float(np.max(dE)), "drift_slope": slope, "first_tail_max": hmax,
            "last_tail_max": tmax, "tail_ratio": tmax / hmax if hmax > 0 else math.inf}


def long_horizon_run(system, q0, qd0, T: float, n: int, method: str, scheme: Optional[str] = None,
                     options: Optional[dict] = None, tail_fraction: float = 0.1):
    """One long run and its energy summary: ``(row, run)``.

    ``row`` holds ``label, method, scheme, n, h, T, status, success,
    iterations, build_time_s, solve_time_s, time_s, wall_time_s, E0`` and the
    fields of :func:`energy_drift_summary` (NaN if the run failed); ``run`` is
    the :class:`~castrajectory.solve.simulate.Run`.
    ``E0`` is the exact initial energy ``E(q0, q̇0)``.
    """
    import time

    from ..solve.simulate import simulate

    sys_, _ = _system_of(system)
    E0 = float(sys_.energy(np.asarray(q0, float), np.asarray(qd0, float)))
    row = {"label": trajectory_label(method, scheme), "method": method,
           "scheme": None if method in SCHEMELESS_METHODS else scheme, "n": int(n), "h": T / n, "T": T}
    wall = time.perf_counter()
    run = simulate(sys_, q0, qd0, T, int(n), scheme or "midpoint", method, options=options)
    wall = time.perf_counter() - wall
    row.update(status=run.status, success=bool(run.success and run.status == "ok"),
               iterations=int(run.iterations), levels=len(getattr(run.detail, "levels", None) or []),
               build_time_s=float(run.build_time_s), solve_time_s=float(run.solve_time_s),
               time_s=float(run.build_time_s + run.solve_time_s), wall_time_s=wall, E0=E0)
    keys = ("max_first_half", "max_second_half", "max", "drift_slope", "first_tail_max",
            "last_tail_max", "tail_ratio")
    if row["success"] and np.all(np.isfinite(run.energy)):
        row.update(energy_drift_summary(run.t, run.energy, E0, tail_fraction))
    else:
        row["success"] = False
        row.update({k: math.nan for k in keys})
    return row, run


def _long_horizon_task(system, q0, qd0, T, n, options, tail_fraction, pair):
    """One long run for an executor: ``(row, t, energy)`` (plain arrays: a ``Run`` holds CasADi objects)."""
    method, scheme = pair
    row, run = long_horizon_run(system, q0, qd0, T, n, method, scheme, options, tail_fraction)
    return row, np.asarray(run.t, float), np.asarray(run.energy, float)


def long_horizon_sweep(system, q0, qd0, T: float, n: int, pairs: Sequence[tuple],
                       executor: Optional[cf.Executor] = None, options: Optional[dict] = None,
                       tail_fraction: float = 0.1, progress: Optional[Callable[[tuple], None]] = None,
                       bar: Optional[bool] = None, quiet: bool = False) -> List[tuple]:
    """:func:`long_horizon_run` for every ``(method, scheme)`` in ``pairs``: ``[(row, t, energy)]`` in order.

    ``system`` as in :func:`work_precision_sweep` (a picklable factory for a process pool or
    a Dask cluster); ``progress((row, t, energy))`` as each run finishes.
    """
    _, factory = _system_of(system)
    executor = executor or SerialExecutor()
    if factory is None and _needs_pickling(executor):
        raise TypeError("long_horizon_sweep: a process pool or a Dask cluster needs a picklable function "
                        "returning the system, not a built system")
    fn = functools.partial(_long_horizon_task, factory or system, list(np.asarray(q0, float).reshape(-1)),
                           list(np.asarray(qd0, float).reshape(-1)), T, int(n), options, tail_fraction)
    return run_tasks(fn, [tuple(p) for p in pairs], executor, progress, bar, quiet, desc="long horizon",
                     label=lambda r: r[0]["label"])


# ----------------------------------------------------------------------------- contact: work-precision
#: Contact work-precision cases: bouncing ball under gravity (flight exact in the midpoint rule)
#: and the ball on a spring (harmonic flight: the discretisation error is visible).
CONTACT_CASES = {
    "ball": dict(height=1.0, velocity=0.0, g=9.81, e=1.0, stiffness=0.0, anchor=0.0, T=2.5, impacts=3),
    "spring_ball": dict(height=1.0, velocity=0.0, g=9.81, e=0.9, stiffness=50.0, anchor=0.3, T=2.5, impacts=5),
}


def _contact_oracle(c: dict):
    if c["stiffness"] > 0:
        return collision.spring_ball_oracle(c["height"], c["velocity"], c["g"], c["stiffness"], 1.0,
                                            c["anchor"], c["e"], c["T"])
    times, _, speeds = collision.ball_oracle(c["height"], c["velocity"], c["g"], c["e"], c["T"])
    return times, speeds


def contact_run(case: str, n: int, method: str) -> dict:
    """One contact run: impact times and speeds against the analytic ones, and wall time.

    ``method`` is ``"whole"`` (the contact NLP) or ``"moreau-jean"`` (the baseline,
    whose impacts happen within a step: their time is taken as the step's midpoint).
    """
    c = CONTACT_CASES[case]
    system = collision.bouncing_ball(1.0, c["g"], c["e"], c["stiffness"], c["anchor"])
    t_ex, v_ex = _contact_oracle(c)
    K = min(c["impacts"], len(t_ex))
    if method == "whole":
        res = tr = trajectory.solve_initial_value(system, [c["height"]], [c["velocity"]], c["T"], n)
        ti = np.array([i.t for i in tr.impacts])
        vi = np.array([-float(i.v_before[0]) for i in tr.impacts])
        yo = np.array([float(i.q[0]) for i in tr.impacts])          # state leaving each impact
        vo = np.array([float(i.v_after[0]) for i in tr.impacts])
    else:
        res = st = stepping.moreau_jean(system, [c["height"]], [c["velocity"]], c["T"], n)
        v = st.qd[:, 0]
        jump = np.where((v[:-1] < 0) & (v[1:] > 0))[0]
        ti = st.t[jump] + 0.5 * st.h
        vi = -v[jump]
        yo, vo = st.q[jump + 1, 0], v[jump + 1]
    k = min(K, len(ti))
    t_err = float(np.max(np.abs(ti[:k] - t_ex[:k]))) if k == K else float("nan")
    v_err = float(np.max(np.abs(vi[:k] - v_ex[:k]) / v_ex[:k])) if k == K else float("nan")
    # apex of each flight after an impact, from the state leaving it (exact flight: parabola or
    # harmonic), against the analytic apex after the analytic impact
    apex = _flight_apex(c, yo[:k], vo[:k])
    apex_ex = _flight_apex(c, np.zeros(k), c["e"] * v_ex[:k])
    a_err = float(np.max(np.abs(apex - apex_ex))) if k == K else float("nan")
    return {"case": case, "method": method, "n": n, "status": res.status, "iterations": res.iterations,
            "build_time_s": res.build_time_s, "solve_time_s": res.solve_time_s, "impact_time_error": t_err,
            "impact_speed_error": v_err, "apex_error": a_err, "impacts": int(len(ti))}


def _flight_apex(c: dict, y, v):
    """Highest point of the free flight from height ``y`` with upward velocity ``v`` (unit mass)."""
    y, v = np.asarray(y, float), np.asarray(v, float)
    if c["stiffness"] > 0:
        w = math.sqrt(c["stiffness"])
        yeq = c["anchor"] - c["g"] / c["stiffness"]
        return yeq + np.hypot(y - yeq, v / w)
    return y + v * v / (2 * c["g"])


def _contact_task(task) -> dict:
    case, method, n = task
    return contact_run(case, n, method)


def contact_work_precision(ns: Sequence[int], cases: Iterable[str] = tuple(CONTACT_CASES),
                           methods: Iterable[str] = ("whole", "moreau-jean"),
                           executor: Optional[cf.Executor] = None, progress: Optional[Callable[[dict], None]] = None,
                           bar: Optional[bool] = None, quiet: bool = False) -> List[dict]:
    """Rows of :func:`contact_run` for every case × method × N (in that order; ``executor``:
    see :func:`executor_for`, serial by default)."""
    tasks = [(c, m, int(n)) for c in cases for m in methods for n in ns]
    return run_tasks(_contact_task, tasks, executor, progress, bar, quiet, desc="contact",
                     label=lambda r: f"{r['case']} {r['method']} N={r['n']}")


# ----------------------------------------------------------------------------- rigid bodies
#: The free body of the work-precision study: I = (1, 2, 3), a spin near the intermediate axis,
#: four flips in T = 100 s (flip interval 27.530841 s).
RIGID_BODY_CASE = {"inertia": (1.0, 2.0, 3.0), "omega0": (1e-3, 1.0, 1e-3), "T": 100.0}


def rigid_body_run(n: int, method: str, scheme: Optional[str] = None, case: Optional[dict] = None) -> dict:
    """One run of the free body: flip-interval error, energy error, |L| drift and |q| error, wall time.

    ``method`` is ``"whole"``, ``"march"`` (the schemes) or ``"rk4-euler"`` (RK4 on Euler's
    equations with quaternion kinematics, not renormalised).
    """
    import time as _time

    from ..baselines import rigidbody as euler
    from ..models import rigidbody as rb
    from ..solve.simulate import Run, simulate
    from . import rigidbody as readings

    c = case or RIGID_BODY_CASE
    inertia = rb.Inertia(*c["inertia"])
    w0 = np.asarray(c["omega0"], float)
    system = rb.free_body(inertia)
    q0 = np.array([1.0, 0.0, 0.0, 0.0])
    t0 = _time.perf_counter()
    if method == "rk4-euler":
        st = euler.euler_rk4(system, inertia.moments, q0, w0, c["T"], n)
        run = Run(t=st.t, q=st.q, v=st.qd, energy=st.energy, scheme=None, method=method, detail=st, **st.contract())
    else:
        run = simulate(system, q0, rb.quaternion_rate(q0, w0), c["T"], n, scheme, method)
    wall = _time.perf_counter() - t0
    r = readings.free_body(system, run, inertia, w0)
    E = np.asarray(run.energy, float)
    return {"label": trajectory_label(method, scheme), "method": method, "scheme": scheme, "n": n,
            "status": run.status, "success": bool(run.success), "iterations": run.iterations,
            "build_time_s": run.build_time_s, "solve_time_s": run.solve_time_s,
            "time_s": run.build_time_s + run.solve_time_s, "wall_s": wall,
            "flips": int(r["flip_times"].size),
            "flip_interval_error": math.nan if r["flip_interval_error"] is None else r["flip_interval_error"],
            "energy_error_max": float(np.max(np.abs(E - E[0]))) if np.all(np.isfinite(E)) else math.nan,
            "angular_momentum_drift": r["angular_momentum_norm_drift"],
            "quaternion_norm_error": r["quaternion_norm_error"]}


def rigid_body_work_precision(ns: Sequence[int], pairs: Sequence[tuple] = (
        ("whole", "midpoint"), ("whole", "trapezoid"), ("whole", "galerkin4"), ("march", "galerkin4"),
        ("rk4-euler", None)), executor: Optional[cf.Executor] = None,
        progress: Optional[Callable[[dict], None]] = None, bar: Optional[bool] = None,
        quiet: bool = False) -> List[dict]:
    """:func:`rigid_body_run` for every (method, scheme) and N (``executor``: see
    :func:`executor_for`, serial by default)."""
    tasks = [(m, s, int(n)) for m, s in pairs for n in ns]
    return run_tasks(_rigid_body_task, tasks, executor, progress, bar, quiet, desc="rigid body",
                     label=lambda r: f"{r['label']} N={r['n']}")


def _rigid_body_task(task):
    m, s, n = task
    return rigid_body_run(n, m, s)
