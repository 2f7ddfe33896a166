"""The contact strategy: the discrete march and its certificate, else the guess's branch and the penalty ladder (package docstring)."""
from __future__ import annotations

import math
import time
from typing import List, Optional

import numpy as np

from ...models.mechanics import LagrangianSystem
from ...result import NLPResult
from ...validation import InputError
from ...discretise.contact.elements import ContactMechanics
from ...discretise.contact.transcription import LOOKAHEAD, TOUCH_TOL, _v_zeno
from .guess import event_guess
from .march import discrete_march
from .nlp import ContactNLP
from .options import ContactOptions
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
                  contact: Optional[ContactOptions] = None) -> ContactTrajectory:
    """Initial-value contact trajectory over ``[0, T]`` on ``N`` steps (strategy in the module docstring).

    ``options`` are Ipopt's (for the solves that use it), ``contact`` the contact solve's own settings
    (:class:`ContactOptions`; the library's defaults when omitted)."""
    co = ContactOptions() if contact is None else contact
    if not isinstance(co, ContactOptions):
        raise InputError("contact must be a ContactOptions")
    cm = ContactMechanics(system, scheme)
    q0, qd0 = np.asarray(q0, float), np.asarray(qd0, float)
    phi0 = np.asarray(system.gap(q0)[0]).reshape(-1)
    length = _length_scale(system, q0)
    if np.any(phi0 < -TOUCH_TOL * length):
        j = int(np.argmin(phi0))
        raise InputError(f"the body starts inside the ground: gap of {system.contact.names[j]} is {phi0[j]:.3g}")
    if cm.m:
        c0, C0 = (np.asarray(x) for x in system.constraint(q0))
        if np.max(np.abs(c0)) > 1e-9 * length:
            raise InputError(f"the initial configuration violates the holonomic constraints by {np.max(np.abs(c0)):.3g}")
        if np.max(np.abs(C0 @ qd0)) > 1e-9 * (1.0 + float(np.max(np.abs(qd0)))):
            raise InputError("the initial velocity is not tangent to the holonomic constraints "
                             f"(C q̇ = {np.max(np.abs(C0 @ qd0)):.3g})")
    h = T / N
    p0 = np.asarray(system.momentum(q0, qd0)).reshape(-1)
    scales = _scales(system, q0, qd0, length)
    attempts: List[dict] = []
    t_march = time.perf_counter()
    point = discrete_march(cm, q0, p0, N + LOOKAHEAD, h, scales, co.max_splits) if co.march else None
    march_time = time.perf_counter() - t_march
    if point is not None:
        # the grid refined where impacts crowd: the steps of the first N base steps are reported
        steps, base = point.pop("steps"), point.pop("base")
        marched = ContactNLP(cm, steps.size, h, scales, steps=steps)
        res = marched.solve_modes(q0, p0, point, options, verbose, co.certify_tol, co.branch_max_iter)
        attempts.append(_attempt("march", res))
        if res.success:
            return _finish(cm, marched, res, int(np.sum(base < N)), h, attempts, march_time, p0)
    # the march failed (or its branch did not certify): the branch of the event-located guess on the
    # uniform grid, then the penalty continuation from that guess
    t_guess = time.perf_counter()
    guess = event_guess(cm, q0, qd0, N + LOOKAHEAD, h, length, _v_zeno(cm, h, scales))
    guess_time = time.perf_counter() - t_guess + march_time
    whole = ContactNLP(cm, N + LOOKAHEAD, h, scales)
    res = whole.solve_branch(q0, p0, guess, options, verbose, co.branch_max_iter, co.penalties)
    attempts.append(_attempt("branch", res))
    if not res.success:
        res = whole.solve(q0, p0, guess, co.penalties, options, verbose)
        attempts.append(_attempt("penalty", res))
    return _finish(cm, whole, res, N, h, attempts, guess_time, p0)


def _attempt(stage: str, res: NLPResult) -> dict:
    return {"stage": stage, "status": res.solver_status, "iterations": res.iterations,
            "build_time_s": res.build_time_s, "solve_time_s": res.solve_time_s,
            "complementarity_residual": res.complementarity_residual,
            "penalty_steps": len(res.homotopy)}
