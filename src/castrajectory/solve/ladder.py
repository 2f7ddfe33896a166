"""The ladder of grids: a fine grid starts from the answer of the same problem on a grid half as fine.

One mechanism for every whole-horizon solve that has a guess to gain (the smooth optimal control,
:meth:`castrajectory.solve.optimal_control.OptimalControl.solve`, and the contact-implicit one,
:func:`castrajectory.solve.contact.control.solve_contact_control`): without a guess of the user's, a grid of more
than ``ladder_max`` steps first solves the same problem on ``(N + 1) // 2`` steps (which does the same, recursively),
and that answer, interpolated onto the ``N`` steps, is the guess.  Every grid then lands on the local optimum of the
coarsest, so a refinement study follows one optimum, and the fine grid needs few iterations.  A rung that fails is
dropped: the grid then starts from its default guess.  Each problem class sets its own ``ladder_max`` (the smooth
problem's 64, the contact problem's 32: ``ContactControlOptions.ladder_max``).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, List, Optional


@dataclass
class Rung:
    """The rung below a grid: the coarser answer (``prior``, None where none was solved), the guess it gives (the
    user's where there was one, None where the rung failed), the grids solved below (``grids``) and their time."""

    prior: Optional[object] = None
    guess: Optional[dict] = None
    grids: List[int] = field(default_factory=list)
    seconds: float = 0.0


def below(N: int, ladder_max: int, guess: Optional[dict], solve: Callable[[int], object],
          interpolate: Callable[[object], dict]) -> Rung:
    """The rung below a grid of ``N`` steps (module docstring): ``solve(M)`` answers the problem on ``M`` steps (a
    result with ``success`` and ``grids``), ``interpolate(prior)`` turns an answer into this grid's guess."""
    if guess is not None or N <= ladder_max:
        return Rung(guess=guess)
    t0 = time.perf_counter()
    prior = solve((N + 1) // 2)
    seconds = time.perf_counter() - t0
    if not prior.success:
        return Rung(prior=prior, seconds=seconds)
    return Rung(prior=prior, guess=interpolate(prior), grids=list(prior.grids), seconds=seconds)
