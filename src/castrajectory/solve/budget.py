"""Iteration budgets: a :class:`Budget` is shared by every solve it is given to (Ipopt's iterations, and Newton's on a
square initial-value system, :meth:`castrajectory.solve.nlp.NLP.newton`).

A strategy may solve many NLPs (coarse-to-fine levels, horizon windows, penalty rungs, branches).  A budget caps the
total of their Ipopt iterations: each solve may use at most what is left, and once nothing is left a solve returns
``Maximum_Iterations_Exceeded`` without running.  A strategy passes its budget down explicitly: it sets the budget of
the programs it builds (``NLP.budget``), as the contact-implicit optimal control does with its
``ContactControlOptions.iteration_budget``.  A run's own budget (``--max-iter``) is the one of :func:`iterations`, which
the command opens around the run: a program without a budget of its own draws on it (:func:`current`), and a strategy
that would set its own takes the run's instead.
"""
from __future__ import annotations

import contextlib
from typing import Optional


class Budget:
    """``n`` Ipopt iterations, spent by every solve that holds this budget."""

    def __init__(self, n: int):
        self.left = int(n)
        self.size = int(n)

    def remaining(self) -> int:
        return self.left

    def spend(self, k: int) -> None:
        self.left = max(0, self.left - int(k))


_run: Optional[Budget] = None


@contextlib.contextmanager
def iterations(n: Optional[int]):
    """The run's budget: cap the Ipopt iterations of everything solved in the block at ``n`` (no cap for None)."""
    global _run
    saved = _run
    _run = None if n is None else Budget(n)
    try:
        yield
    finally:
        _run = saved


def current() -> Optional[Budget]:
    """The run's budget (:func:`iterations`), or None."""
    return _run


def remaining() -> Optional[int]:
    """Iterations left of the run's budget (None: no budget)."""
    return None if _run is None else _run.remaining()
