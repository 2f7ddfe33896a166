"""The contact strategy: the discrete march and its certificate, else the guess's branch and the penalty ladder (package docstring)."""
from __future__ import annotations

import math
import time
from typing import Dict, List, Optional

import numpy as np

from ...models.mechanics import LagrangianSystem
from ...result import NLPResult
from ...validation import InputError
from .. import estimate
from ...discretise.contact.elements import ContactMechanics
from ...discretise.lagrangians import SCHEMES
from ...discretise.contact.transcription import LOOKAHEAD, TOUCH_TOL, _v_zeno
from .guess import event_guess
from .march import discrete_march
from .nlp import ContactNLP
from .options import ContactOptions
from .policies import first_accepted
from .solution import ContactTrajectory, _finish, elastic_loss


# ----------------------------------------------------------------------------- driver
def _length_scale(system: LagrangianSystem, q0) -> float:
    """A length for gap tolerances and penalty scales: ``max(1, max |q0|)``."""
    return max(1.0, float(np.max(np.abs(q0))) if np.size(q0) else 1.0)


def _scales(system: LagrangianSystem, q0, qd0, length: float, acc: Optional[float] = None):
    """(length, momentum, velocity, acceleration) scales of the scene for the penalty terms; ``acc`` the largest
    acceleration at the start (default: the system's own, with no controls)."""
    if acc is None:
        acc = float(np.max(np.abs(system.index1_values(q0, qd0)[0]))) if system.nq else 0.0
    vref = max(float(np.max(np.abs(qd0))), math.sqrt(acc * length), 1e-8)
    mref = float(np.max(np.diag(np.asarray(system.mass_matrix(q0)))))
    return length, mref * vref, vref, acc


def solve_contact(system: LagrangianSystem, q0, qd0, T: float, N: int, scheme: str = "midpoint",
                  options: Optional[dict] = None, verbose: bool = False,
                  contact: Optional[ContactOptions] = None, rtol: Optional[float] = None,
                  n_limit: Optional[int] = None) -> ContactTrajectory:
    """Initial-value contact trajectory over ``[0, T]`` on ``N`` steps (strategy in the module docstring).

    ``options`` are Ipopt's (for the solves that use it), ``contact`` the contact solve's own settings
    (:class:`ContactOptions`; the library's defaults when omitted).

    The answer's error is estimated from the same scene on ``N/2`` steps (:func:`_estimate`: the
    configuration at the shared nodes, the energy, the impact times).  ``rtol``: the grid doubles
    (by the power of two the estimate predicts) until the estimated relative error is at most
    ``rtol``, up to ``n_limit`` steps; a run that stops above it fails with the estimate in its message."""
    co = ContactOptions() if contact is None else contact
    if not isinstance(co, ContactOptions):
        raise InputError("contact must be a ContactOptions")
    fine = _solve_once(system, q0, qd0, T, N, scheme, options, verbose, co)
    if not fine.success:
        fine.error_estimate = estimate.ErrorEstimate.none("the solve did not converge")
        return fine
    grids = [_solve_once(system, q0, qd0, T, m, scheme, options, verbose, co, certify=False)
             for m in estimate.coarser(N)]
    runs = [fine] + grids
    limit = N if n_limit is None else n_limit
    order = SCHEMES[scheme].order
    fine, est, N, short = estimate.refine_runs(
        rtol, grids, fine, N, order, limit,
        lambda n: _solve_once(system, q0, qd0, T, n, scheme, options, verbose, co),
        lambda cs, f: _estimate(cs, f, order, system), runs)
    return estimate.conclude(fine, est, runs, rtol, N, limit, short)


def _impact_difference(coarse: ContactTrajectory, fine: ContactTrajectory) -> Dict[str, float]:
    """The largest difference of the impact times of two grids, paired in order (where the grids resolve
    different numbers, the tail of an accumulation caught on one grid a bounce earlier, the unpaired ones are
    tiny bounces whose effect the configuration at the shared nodes carries)."""
    tc = [i.t for i in coarse.impacts if not i.caught]
    tf = [i.t for i in fine.impacts if not i.caught]
    n = min(len(tc), len(tf))
    return {"impact_times": float(np.max(np.abs(np.array(tc[:n]) - np.array(tf[:n]))))} if n else {}


def _estimate(grids: List[ContactTrajectory], fine: ContactTrajectory, order: int,
              fine_system: LagrangianSystem) -> "estimate.ErrorEstimate":
    """The estimate of a contact trajectory from the same scene on two coarser grids (coarsest first;
    :func:`castrajectory.solve.estimate.trajectory_estimate`): the configuration at the shared nodes, the
    energy, and the impact times."""
    if not grids:
        return estimate.ErrorEstimate.none(f"N = {fine.n} has no coarser grid")
    for g in grids:
        if not g.success:
            return estimate.ErrorEstimate.none(f"the grid N = {g.n} for the estimate did not converge "
                                               f"({g.solver_status})")
    chain = list(grids) + [fine]
    diffs = [_impact_difference(a, b) for a, b in zip(chain[:-1], chain[1:])]
    extra = None
    if diffs[-1]:
        diffs = [d if d else {"impact_times": float("nan")} for d in diffs]
        extra = (diffs, {"impact_times": float(fine.t[-1])})
    est = estimate.trajectory_estimate(list(grids), fine, order, smooth=False, extra=extra,
                                       energy_scale=estimate.kinetic_scale(fine_system, fine.q, fine.v),
                                       levels=tuple(g.n for g in chain), system=fine_system)
    counts = [len([i for i in g.impacts if not i.caught]) for g in chain]
    if len(set(counts)) > 1:
        est.note += f"; the grids resolve {', '.join(map(str, counts))} impacts (paired in order)"
    # an elastic system's lost energy is the grid's (its catches of bounces it does not resolve): an error the grids
    # cannot show where every grid catches alike
    lost = elastic_loss(fine_system, np.asarray(fine.energy, float))
    if lost > 0.0 and est.available and est.scales.get("energy", 0.0) > 0.0:
        est.errors["energy"] = max(est.errors.get("energy", 0.0), lost)
        est.relative = max(est.relative, lost / est.scales["energy"])
        est.note += f"; the elastic contacts lost {lost:.3g} of energy, which Newton's law with e = 1 keeps"
    return est


def _solve_once(system: LagrangianSystem, q0, qd0, T: float, N: int, scheme: str, options: Optional[dict],
                verbose: bool, co: ContactOptions, certify: bool = True) -> ContactTrajectory:
    """One contact solve on ``N`` steps: the march and its certificate, else the guess's branch and the ladder.

    ``certify = False`` (the coarser grid of an estimate): the march's point is read as it is, without
    the certificate's Newton step and KKT check (it differs from the certified point by the march's
    rounding drift, 1e-12 relative), which halves the estimate's cost (the ball on 3000 steps: 0.27 ->
    0.20 s in all)."""
    cm = ContactMechanics(system, scheme)
    q0, qd0 = np.asarray(q0, float), np.asarray(qd0, float)
    phi0 = np.asarray(system.gap(q0)[0]).reshape(-1)
    length = _length_scale(system, q0)
    if np.any(phi0 < -TOUCH_TOL * length):
        j = int(np.argmin(phi0))
        raise InputError(f"the start penetrates contact {system.contact.names[j]!r}: its gap is {phi0[j]:.3g} "
                         f"(every gap must be >= 0 at q0)")
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
    point = discrete_march(cm, q0, p0, N + LOOKAHEAD, h, scales, co.max_splits,
                           options=co.march_options) if co.march else None
    march_time = time.perf_counter() - t_march
    if point is not None:
        # the grid refined where impacts crowd: the steps of the first N base steps are reported
        steps, base = point.pop("steps"), point.pop("base")
        marched = ContactNLP(cm, steps.size, h, scales, steps=steps, lifts=bool(np.any(np.isin(point["modes"], ("E", "G")))))
        marched.settings = co
        if not certify:
            init = marched._start(q0, p0, point)
            res = NLPResult(values=init, multipliers={}, bound_multipliers={}, objective=0.0, success=True,
                            solver_status="Marched", message="the discrete march, not certified",
                            complementarity_residual=float(marched.residual(init)))
            attempts.append(_attempt("march", res))
            return _finish(cm, marched, res, int(np.sum(base < N)), h, attempts, march_time, p0)
        res = marched.solve_modes(q0, p0, point, options, verbose, co.certify_tol, co.branch_max_iter)
        attempts.append(_attempt("march", res))
        if res.success:
            return _finish(cm, marched, res, int(np.sum(base < N)), h, attempts, march_time, p0)
    # friction and the sequential law are resolved by the march only: the fallback's program holds neither
    # (its answer would be refused), so it is not tried, and the march's failure is the answer
    needs = (("Friction_Needs_The_March", "Coulomb friction is resolved by the discrete march, which failed on "
              "this problem") if cm.friction else
             ("Sequential_Law_Needs_The_March", "the sequential impact law is resolved by the discrete march, which "
              "failed on this problem") if system.contact.law == "sequential" else None)
    if needs is not None and point is not None:
        res.fail(needs[0], f"{needs[1]} (its point was not certified: {res.message})")
        return _finish(cm, marched, res, int(np.sum(base < N)), h, attempts, march_time, p0)
    # the march failed (or its branch did not certify): the branch of the event-located guess on the
    # uniform grid, then the penalty continuation from that guess
    t_guess = time.perf_counter()
    # (a scheme with stages guesses with its guide's two-point rows; its stages start on straight lines)
    guess = event_guess(cm.guide, q0, qd0, N + LOOKAHEAD, h, length, _v_zeno(cm, h, scales), co)
    guess_time = time.perf_counter() - t_guess + march_time
    whole = ContactNLP(cm, N + LOOKAHEAD, h, scales)
    whole.settings = co
    if needs is not None:
        init = whole._start(q0, p0, guess)
        for name in whole.nlp.variable_names:
            init.setdefault(name, np.zeros(whole.nlp.index(name).size))
        res = NLPResult(values=init, multipliers={}, bound_multipliers={}, objective=float("nan"), success=False,
                        solver_status=needs[0], message=f"{needs[1]}; the answer is the event-located guess, not a "
                        "solution", complementarity_residual=float("nan"))
        return _finish(cm, whole, res, N, h, attempts, guess_time, p0)
    res = first_accepted([("branch", lambda: whole.solve_branch(q0, p0, guess, options, verbose, co.branch_max_iter,
                                                                co.penalties)),
                          ("penalty", lambda: whole.solve(q0, p0, guess, co.penalties, options, verbose))],
                         lambda got: got.success, lambda name, got: attempts.append(_attempt(name, got)))
    return _finish(cm, whole, res, N, h, attempts, guess_time, p0)


def _attempt(stage: str, res: NLPResult) -> dict:
    return {"stage": stage, "status": res.solver_status, "iterations": res.iterations,
            "build_time_s": res.build_time_s, "solve_time_s": res.solve_time_s,
            "complementarity_residual": res.complementarity_residual,
            "penalty_steps": len(res.homotopy)}
