"""The contact strategy: guess, branch, penalty ladder, held catches, horizon windows (package docstring)."""
from __future__ import annotations

import math
import time
from typing import Dict, List, Optional

import numpy as np

from ...models.mechanics import LagrangianSystem
from ...result import NLPResult
from ...validation import InputError
from ...discretise.contact.elements import ContactMechanics
from ...discretise.contact.transcription import COMPLEMENTARITY_TOL, LOOKAHEAD, TOUCH_TOL, _v_zeno
from .guess import event_guess
from .march import discrete_march
from .nlp import ContactNLP
from .solution import ContactTrajectory, _finish


# ----------------------------------------------------------------------------- driver
def _length_scale(system: LagrangianSystem, q0) -> float:
    """A length for gap tolerances and penalty scales: ``max(1, max |q0|)``."""
    return max(1.0, float(np.max(np.abs(q0))) if np.size(q0) else 1.0)


def _scales(system: LagrangianSystem, q0, qd0, length: float):
    """(length, momentum, velocity, acceleration) scales of the scene for the penalty terms."""
    acc = float(np.max(np.abs(np.asarray(system.acceleration(q0, qd0))))) if system.nq else 0.0
    vref = max(float(np.max(np.abs(qd0))), math.sqrt(acc * length), 1e-8)
    mref = float(np.max(np.diag(np.asarray(system.mass_matrix(q0)))))
    return length, mref * vref, vref, acc


def solve_contact(system: LagrangianSystem, q0, qd0, T: float, N: int, scheme: str = "midpoint",
                  options: Optional[dict] = None, verbose: bool = False,
                  penalties: Optional[List[float]] = None) -> ContactTrajectory:
    """Initial-value contact trajectory over ``[0, T]`` on ``N`` steps (strategy in the module docstring)."""
    cm = ContactMechanics(system, scheme)
    q0, qd0 = np.asarray(q0, float), np.asarray(qd0, float)
    phi0 = np.asarray(system.gap(q0)[0]).reshape(-1)
    length = _length_scale(system, q0)
    if np.any(phi0 < -TOUCH_TOL * length):
        j = int(np.argmin(phi0))
        raise InputError(f"the body starts inside the ground: gap of {system.contact.names[j]} is {phi0[j]:.3g}")
    h = T / N
    p0 = np.asarray(system.momentum(q0, qd0)).reshape(-1)
    scales = _scales(system, q0, qd0, length)
    attempts: List[dict] = []
    t_march = time.perf_counter()
    point = discrete_march(cm, q0, p0, N + LOOKAHEAD, h, scales)
    march_time = time.perf_counter() - t_march
    if point is not None:
        # the grid refined where impacts crowd: the steps of the first N base steps are reported
        steps, base = point.pop("steps"), point.pop("base")
        marched = ContactNLP(cm, steps.size, h, scales, steps=steps)
        res = marched.solve_modes(q0, p0, point, options, verbose)
        attempts.append(_attempt("march", res))
        if res.success:
            return _finish(cm, marched, res, int(np.sum(base < N)), h, attempts, march_time, p0)
    t_guess = time.perf_counter()
    guess = event_guess(cm, q0, qd0, N + LOOKAHEAD, h, length, _v_zeno(cm, h, scales))
    guess_time = time.perf_counter() - t_guess + march_time
    # a second sub-node only in the steps where the guess has two impacts (none: the one-sub-node NLP)
    whole = ContactNLP(cm, N + LOOKAHEAD, h, scales, k2=guess.get("k2"))
    # the branch of the complementarity problem that the guess identifies, then the penalty continuation
    res = whole.solve_branch(q0, p0, guess, options, verbose)
    attempts.append(_attempt("branch", res))
    if not res.success:
        res = whole.solve(q0, p0, guess, penalties, options, verbose)
        attempts.append(_attempt("whole", res))
    held = np.zeros((whole.L, cm.c), dtype=bool)
    for _ in range(HELD_ROUNDS if not res.success else 0):
        # the law used as a loophole at the last point Ipopt solved (ContactNLP.loopholes): there
        # the law is weighted by φ(q_{k+2})/ℓ as well, a catch must hold; the whole solve again
        # from the guess (docs/derivations.md, "Contact trajectories", §4, "Catches that hold")
        if whole.last_good is None:
            break
        new = whole.loopholes(whole.last_good[1].values) & ~held
        if not np.any(new):
            break
        held |= new
        whole = ContactNLP(cm, N + LOOKAHEAD, h, scales, k2=guess.get("k2"), held=held)
        res = whole.solve(q0, p0, guess, penalties, options, verbose)
        attempts.append(_attempt("whole-held", res))
        if res.success:
            break
    if not res.success:
        cur = _windows(cm, q0, p0, N, h, length, scales, penalties, options, verbose, attempts)
        if cur is not None:
            # the windows have one sub-node per step: the second sub-nodes start from the guess
            cur.update({key: guess[key] for key in ("k2", "qs2", "beta2", "mu2", "bounced2") if key in guess})
            res = whole.solve_branch(q0, p0, cur, options, verbose)
            attempts.append(_attempt("branch-after-windows", res))
            if not res.success:
                res = whole.solve(q0, p0, cur, penalties, options, verbose)
                attempts.append(_attempt("whole-after-windows", res))
            if not res.success:
                res = _assembled(whole, p0, cur, res)
    return _finish(cm, whole, res, N, h, attempts, guess_time, p0)


#: Largest scaled row violation (ContactNLP.row_violation) of a point assembled from horizon windows
#: that is reported in place of a failed whole solve.
ASSEMBLED_ROW_TOL = 1e-9


def _assembled(whole: ContactNLP, p0, cur: dict, res: NLPResult) -> NLPResult:
    """The point assembled from horizon windows that all converged, as the answer, if it satisfies the
    whole NLP to tolerance (scaled rows within :data:`ASSEMBLED_ROW_TOL`, the complementarity residual
    with the whole NLP's law lengths within :data:`COMPLEMENTARITY_TOL`) where the whole solve from it
    did not converge; ``res`` (that failed solve) otherwise.  Reported with the status
    ``Assembled_From_Windows``."""
    # the law slacks of second sub-nodes are not part of the windows' point: zero (the check then sees the law)
    values = {b.name: (np.asarray(cur[b.name], float).reshape(-1) if b.name in cur else
                       np.zeros(b.init.size) if b.name.startswith("s_") else None) for b in whole.nlp._vars}
    if any(v is None for v in values.values()):
        return res
    whole._law_length = whole.law_lengths(cur)
    if whole.k2.size:
        whole._law_length2 = whole.law_lengths2(cur)
    rows, resid = whole.row_violation(p0, values), whole.residual(values)
    if rows > ASSEMBLED_ROW_TOL or resid > COMPLEMENTARITY_TOL:
        return res
    return NLPResult(values=values, multipliers={}, bound_multipliers={}, objective=float("nan"),
                     solver_status="Assembled_From_Windows", success=True,
                     message=(f"every horizon window converged; their assembled trajectory satisfies the whole NLP "
                           f"(rows to {rows:.1e}, complementarity residual {resid:.1e}), where the whole solve "
                           f"from it stopped with {res.solver_status} (residual {res.complementarity_residual:.2e})"),
                     iterations=0, build_time_s=0.0, solve_time_s=0.0, complementarity_residual=resid,
                     homotopy=list(res.homotopy))


def _attempt(stage: str, res: NLPResult) -> dict:
    return {"stage": stage, "status": res.solver_status, "iterations": res.iterations,
            "build_time_s": res.build_time_s, "solve_time_s": res.solve_time_s,
            "complementarity_residual": res.complementarity_residual,
            "penalty_steps": len(res.homotopy)}


#: Rounds of re-solves with the catches that do not hold weighted by the gap after next.
HELD_ROUNDS = 3

#: Shortest horizon window tried before giving up.
MIN_WINDOW = 8
#: Iteration budget of one window, and of all windows together (a failure must not take minutes).
WINDOW_MAX_ITER = 80
WINDOWS_MAX_ITER_TOTAL = 2000


def _windows(cm, q0, p0, N, h, length, scales, penalties, options, verbose, attempts):
    """Horizon windows: contact NLPs of L steps marched over the horizon, each from its own event guess."""
    n, c = cm.n, cm.c
    Mf = cm.system.mass_matrix
    # windows of L reported steps, each solved with its look-ahead; the last window's look-ahead is kept
    # (the whole solve after the windows has N + LOOKAHEAD steps)
    NL = N + LOOKAHEAD
    out = {"q": np.zeros((NL + 1, n)), "qs": np.zeros((NL, n)), "beta": np.zeros(NL),
           "mu": np.zeros((NL, c)), "nu": np.zeros((NL, c)), "s_plus": np.zeros((NL, c)), "s_minus": np.zeros((NL, c))}
    out["q"][0] = q0
    cache: Dict[int, ContactNLP] = {}
    K, L = 0, 1 << max(3, int(math.log2(max(8, N // 8))))
    qK, pK = np.asarray(q0, float), np.asarray(p0, float)
    while K < N:
        L = min(L, N - K)
        if L not in cache:
            cache[L] = ContactNLP(cm, L + LOOKAHEAD, h, scales)
        w = cache[L]
        vK = np.linalg.solve(np.asarray(Mf(qK)), pK)
        wguess = event_guess(cm, qK, vK, L + LOOKAHEAD, h, length, w.v_zeno, two_impacts=False)
        wopts = dict(options or {}, max_iter=min(WINDOW_MAX_ITER, int((options or {}).get("max_iter", WINDOW_MAX_ITER))))
        r = w.solve_branch(qK, pK, wguess, wopts, verbose)
        attempts.append(_attempt(f"window {K}:{K + L} branch", r))
        if not r.success:
            r = w.solve(qK, pK, wguess, penalties, wopts, verbose)
            attempts.append(_attempt(f"window {K}:{K + L}", r))
        if sum(a["iterations"] for a in attempts if a["stage"].startswith("window")) > WINDOWS_MAX_ITER_TOTAL:
            return None
        if r.success:
            keep = L + LOOKAHEAD if K + L == N else L
            for key, arr in out.items():
                if key == "q":
                    arr[K + 1:K + keep + 1] = r.values["q"].reshape(L + LOOKAHEAD + 1, n)[1:keep + 1]
                else:
                    arr[K:K + keep] = r.values[key].reshape((L + LOOKAHEAD,) + arr.shape[1:])[:keep]
            qK = out["q"][K + L]
            pK = np.asarray(cm.p_node_minus(out["qs"][K + L - 1], out["beta"][K + L - 1], qK, h)).reshape(-1)
            K, L = K + L, 2 * L
        else:
            if L <= MIN_WINDOW:
                return None
            L //= 2
    return {k: v.reshape(-1) for k, v in out.items()}
