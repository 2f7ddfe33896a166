"""Stability on stiff and extreme cases, for every family: each case runs its problem script and is
judged by its own oracle.

A :class:`Case` is a command (scene and arguments) and a check: a function of the scene's JSON data
returning ``(error against the oracle, tolerance, what was compared)``.  :func:`run_case` runs it
in process and returns a :class:`Row`: the solve's outcome, iterations and time, the worst
constraint or complementarity residual the scene reports, the energy or invariant drift, the error
estimate, and whether the oracle passed.  A row passes only if the solve converged *and* the oracle
holds: a converged wrong answer is a failed row.  The report prints one table of every case
(:func:`table`); ``tests/test_stability.py`` runs each case on its own.  The cases themselves are
declared with their scenes, in the scene registry (:mod:`castrajectory.cli.registry`).

The tolerances are the measured errors with a margin (the measured values are in each check's
docstring or comment); they state what the case shows, not a bound on the method.
"""
from __future__ import annotations

import importlib
import math
import time
from dataclasses import dataclass
from typing import List, Optional

import numpy as np

from .cases import Case
from .registry import cases, module


@dataclass
class Row:
    case: Case
    success: bool
    status: str
    iterations: int
    time_s: float
    residual: Optional[float]
    drift: Optional[str]
    estimate: Optional[float]
    error: float
    tolerance: float
    what: str

    @property
    def passed(self) -> bool:
        return bool(self.success and math.isfinite(self.error) and self.error <= self.tolerance)


# ----------------------------------------------------------------------------- the cases
#: every scene's stability cases, declared with the scenes in the registry (:mod:`castrajectory.cli.registry`)
CASES: List[Case] = cases()


def run_case(case: Case) -> Row:
    """Run ``case`` in process through its problem script; the oracle is applied only to a converged run."""
    mod = importlib.import_module(module(case.scene))
    t0 = time.perf_counter()
    out = mod.run(mod.parser().parse_args(list(case.argv)))
    wall = time.perf_counter() - t0
    d = out.data
    residual = None
    for key in ("complementarity_residual", "quaternion_norm_error", "young_residual"):
        if d.get(key) is not None:
            residual = abs(float(d[key])) if residual is None else max(residual, abs(float(d[key])))
    E = np.asarray(d["energy"], float) if d.get("energy") is not None and np.ndim(d["energy"]) == 1 else None
    if d.get("angular_momentum_drift") is not None:
        drift = f"‖L‖ {float(d['angular_momentum_drift']):.1e} relative"
    elif E is not None and case.family == "contact":  # restitution below 1 loses energy by design
        drift = f"E {E[0]:.4g} → {E[-1]:.4g}"
    elif E is not None:
        drift = f"E {float(np.max(np.abs(E - E[0])) / max(float(np.max(np.abs(E))), 1e-300)):.1e} relative"
    else:
        drift = None
    est = d.get("error_estimate") or {}
    estimate = est.get("relative") if est.get("available") else None
    if case.expect == "unresolved":
        # the run must fail, and its message must name the N that resolves the motion
        named = not out.success and "resolves it" in out.message and "N >=" in out.message
        return Row(case, True, out.status, int(out.iterations), wall, None, None, None, 0.0 if named else math.inf,
                   0.0, "fails and names the N that resolves the motion" + ("" if out.success else
                                                                           f": {out.message.split('; ')[-1]}"))
    if case.expect == "no_stable_drop":
        # beyond the fold the verdict "no stable drop" is the answer; the check judges the fold it found
        verdict = out.status == "No_Stable_Drop"
        err, tol, what = case.check(d) if verdict else (math.inf, math.nan, out.message)
        return Row(case, verdict, out.status, int(out.iterations), wall, residual, drift, estimate, float(err),
                   float(tol), what)
    if out.success:
        err, tol, what = case.check(d)
    else:
        err, tol, what = math.inf, math.nan, out.message
    return Row(case, bool(out.success), out.status, int(out.iterations), wall, residual, drift, estimate,
               float(err), float(tol), what)


def table(rows: List[Row]) -> List[str]:
    """The report's stability table (Markdown)."""
    f = (lambda v, s=".1e": "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else format(v, s))  # noqa: E731
    lines = ["| family | case | command | outcome | iterations | time (s) | worst residual | drift "
             "| error estimate | oracle error (tolerance) | checked |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        solved = "no stable drop (the verdict expected)" if r.case.expect == "no_stable_drop" else "solved"
        outcome = (solved if r.passed else "FAILED: " + (r.status if not r.success else "oracle missed"))
        drift = r.drift or "-"
        lines.append(f"| {r.case.family} | {r.case.title} | `{r.case.command}` | {outcome} | {r.iterations} | "
                     f"{r.time_s:.2f} | {f(r.residual)} | {drift} | {f(r.estimate)} | "
                     f"{f(r.error)} ({f(r.tolerance, '.0e')}) | {r.what} |")
    return lines
