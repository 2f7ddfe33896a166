"""The named state of a contact-implicit optimal-control solve (:mod:`.control`).

* :class:`Problem`: what every part of one solve reads (the elements, the program, the start, the grid, the scales,
  the fixed bounds, Ipopt's options, the settings) and the record of every homotopy step;
* :class:`Branch`: the events a round of the program holds, per step and contact;
* :class:`Round`: one round's start (its branch, bounds, start points, and how it came about);
* :class:`Attempt`: a converged point of the program with the parameters it was solved on.

The loop is ``attempt = solve(branch, start)`` (:func:`.policies.solve_round`), ``branch = read(attempt)``
(:func:`.events.read_branch`), ``certify(attempt)`` (:func:`.certificate.certify`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import List, Optional

import numpy as np

from ...discretise.contact.elements import ContactMechanics
from ...result import Certificate, HomotopyStep, NLPResult
from .options import ContactControlOptions


@dataclass
class Problem:
    """One contact-implicit solve's fixed data.  ``prog``: the program (a ``ContactNLP``, which owns its parameters);
    ``bounds``: the bounds every solve keeps (the nodes' ends, a free start, the end's friction ratios); ``ipopt``: the
    options of every solve; ``o``: the settings; ``tol``: the touch tolerance (``TOUCH_TOL ℓ``); ``steps``: every
    homotopy step solved, in order."""

    cm: ContactMechanics
    prog: object
    q0: np.ndarray
    N: int
    scales: tuple
    bounds: dict
    ipopt: dict
    o: ContactControlOptions
    verbose: bool
    tol: float
    steps: List[HomotopyStep] = field(default_factory=list)

    def ladder(self, init, extra: dict, bounds: dict, warm: Optional[NLPResult] = None) -> NLPResult:
        """The penalty ladder from ``init`` (and ``warm``'s primal-dual point) with Ipopt's options and ``extra``."""
        return self.prog._ladder(init, {**self.ipopt, **extra}, bounds, self.o.penalties, self.verbose, "rho", "Ipopt",
                                 warm=warm)

    def window(self, free) -> tuple:
        """The split ``β``'s bounds: inside ``[edge − ½, ½ − edge]`` in the steps ``free`` (timed), 0 elsewhere."""
        e = self.o.edge
        return np.where(free, e - 0.5, 0.0), np.where(free, 0.5 - e, 0.0)

    def clip(self, start, free) -> None:
        """``start``'s splits moved into :meth:`window`, in place."""
        e = self.o.edge
        start["beta"] = np.where(free, np.clip(start["beta"], e - 0.5, 0.5 - e), 0.0)


@dataclass
class Branch:
    """The events a round holds, per step and contact (``(N, c)`` each): an arrival timed at the step's sub-node
    (``timed``), Newton's law there (``bounce``), a held contact's slip that stops or turns at the sub-node (``turn``,
    with its node slot's friction ratio ``ratio``).  Every other pair is left to the penalties."""

    timed: np.ndarray
    bounce: np.ndarray
    turn: np.ndarray
    ratio: np.ndarray
    #: per step, the parts' stage slots (``(N, 2·stages·c)``) whose contact the round holds at the stages
    #: (:func:`.events.stage_holds`); None: none
    holds: Optional[np.ndarray] = None

    @property
    def key(self) -> bytes:
        return self.timed.tobytes() + b"|" + self.bounce.tobytes() + b"|" + self.turn.tobytes() + b"|" + (
            b"" if self.holds is None else self.holds.tobytes())

    @property
    def events(self) -> np.ndarray:
        """Per step and contact: an event (an arrival or a turn) that times the sub-node."""
        return self.timed | self.turn

    @property
    def free(self) -> np.ndarray:
        """Per step: its sub-node is timed (its split free within the window)."""
        return np.any(self.events, axis=1)

    def same(self, other: "Branch") -> bool:
        return (np.array_equal(self.timed, other.timed) and np.array_equal(self.bounce, other.bounce)
                and np.array_equal(self.turn, other.turn)
                and (self.holds is None) == (other.holds is None)
                and (self.holds is None or np.array_equal(self.holds, other.holds)))

    def moved(self, k: int, to: int) -> "Branch":
        """The branch with step ``k``'s events held in step ``to`` instead (the others kept)."""
        out = Branch(self.timed.copy(), self.bounce.copy(), self.turn.copy(), self.ratio.copy(),
                     None if self.holds is None else self.holds.copy())
        for flags in (out.timed, out.bounce, out.turn):
            flags[to], flags[k] = flags[k].copy(), False
        out.ratio[to], out.ratio[k] = out.ratio[k].copy(), 0.0
        return out


@dataclass
class Round:
    """One round's start: the branch it holds and its bounds, its start point ``init`` (the last answer's values, the
    moved events shifted and the changed steps re-marched), the last answer's values moved into the bounds
    (``last``), the last answer (``res``), whether steps were restarted from their marches (``restarted``), whether
    the round moves a pinned event (``moving``), and whether it is the first round on a finer grid of the ladder,
    started from the coarser answer's march (``near``)."""

    branch: Branch
    bounds: dict
    init: dict
    last: Optional[dict] = None
    res: Optional[NLPResult] = None
    restarted: bool = False
    moving: bool = False
    near: bool = False


@dataclass
class Attempt:
    """A converged point of the program (``res``) with the parameters it was solved on (``params``: its branch, the
    program's :meth:`parameters`), and once certified its :class:`~castrajectory.result.Certificate`."""

    res: NLPResult
    params: dict
    certificate: Certificate = field(default_factory=Certificate)
