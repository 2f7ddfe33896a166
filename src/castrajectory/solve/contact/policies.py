"""Start policies of a timing round (:mod:`.control`): where a round's solve starts from.

A policy takes the problem and the round (:class:`.state.Round`) and returns the solve's result, or ``None`` where it
does not apply to that round.  :func:`solve_round` tries the policies named in ``ContactControlOptions.starts`` in
order until one converges (to Ipopt's tolerance or its acceptable level, ``NLPResult.continuable``); every try's
homotopy steps are recorded.  The last one, ``cold``, always applies.

Adding a policy is one function here and its name in ``STARTS``; a user then lists it in ``starts``::

    def from_guess_controls(P, R):
        '''The round from the answer with its controls zeroed (an illustration).'''
        if R.res is None:
            return None
        init = {k: v.copy() for k, v in R.init.items()}
        init["u"] = np.zeros_like(init["u"])
        return P.ladder(init, P.o.warm_ipopt, R.bounds)
"""
from __future__ import annotations

from functools import partial
from typing import Callable, Dict, Optional, Sequence, Tuple

from ...result import NLPResult
from .state import Problem, Round


def near(P: Problem, R: Round) -> Optional[NLPResult]:
    """The first round on a finer grid of the ladder, from the march of the coarser answer's controls (near the
    optimum): a small barrier, nothing pushed off its bounds, which keeps the march's complementarity."""
    if R.res is not None or not R.near:
        return None
    return P.ladder(R.init, P.o.near_ipopt, R.bounds)


def warm(P: Problem, R: Round) -> Optional[NLPResult]:
    """A later round from the last answer's primal-dual point with a small barrier; capped at ``restart_iter``
    iterations where steps were restarted or an event moves."""
    if R.res is None:
        return None
    cap = {"max_iter": P.o.restart_iter} if R.restarted or R.moving else {}
    return P.ladder(R.init, {**P.o.warm_ipopt, **cap}, R.bounds, warm=R.res)


def from_last(P: Problem, R: Round) -> Optional[NLPResult]:
    """A restarted round whose warm start did not converge: from the last answer itself (its primal values moved into
    the round's bounds, its multipliers), with the warm start's small barrier."""
    if R.res is None or not R.restarted:
        return None
    return P.ladder(R.last, P.o.warm_ipopt, R.bounds, warm=R.res)


def cold(P: Problem, R: Round) -> NLPResult:
    """The homotopy's own barrier, from the round's start (the last answer, where steps were restarted)."""
    return P.ladder(R.last if R.restarted else R.init, {}, R.bounds)


#: The start policies by name (``ContactControlOptions.starts``).
STARTS: Dict[str, Callable[[Problem, Round], Optional[NLPResult]]] = {
    "near": near, "warm": warm, "from_last": from_last, "cold": cold}


def first_accepted(tries: Sequence[Tuple[str, Callable[[], Optional[NLPResult]]]],
                   accept: Callable[[NLPResult], bool], record: Callable[[str, NLPResult], None]) -> Optional[NLPResult]:
    """The loop of both contact paths: each named try in order (``None``: it does not apply), every result recorded;
    the first that ``accept`` takes is the answer, else the last one tried (``None`` where none applied).  A timing
    round's starts (:func:`solve_round`) and the initial-value strategy's fallbacks (:func:`.strategy._solve_once`:
    the guess's branch, then the penalty continuation) are its two uses."""
    got = None
    for name, attempt in tries:
        out = attempt()
        if out is None:
            continue
        got = out
        record(name, got)
        if accept(got):
            break
    return got


def solve_round(P: Problem, R: Round, names: Sequence[str]) -> Optional[NLPResult]:
    """The round solved from the first of the policies ``names`` that converges (to Ipopt's tolerance or its acceptable
    level); else the last one tried (``None`` where none applied)."""
    return first_accepted([(name, partial(STARTS[name], P, R)) for name in names], lambda got: got.continuable,
                          lambda name, got: P.steps.extend(got.homotopy))
