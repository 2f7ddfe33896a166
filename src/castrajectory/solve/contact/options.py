"""The contact solve's settings in one object (instead of module constants)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Tuple

from ...discretise.contact.transcription import PENALTY
from ...validation import InputError


@dataclass(frozen=True)
class ContactOptions:
    """Settings of :func:`~castrajectory.solve.contact.solve_contact`; the defaults are the library's.

    * ``march``: solve by the discrete march and its certificate first (``False``: straight to the
      fallback, the event-located guess's branch and the penalty continuation);
    * ``max_splits``: halvings of a step where impacts crowd (the finest step is ``h / 2**max_splits``);
    * ``certify_tol``: scaled row violation and stationarity backward error within which the marched
      point is certified as a KKT point of its branch;
    * ``branch_max_iter``: Ipopt's iteration budget of a decided branch (the march's or the guess's);
    * ``penalties``: the rungs ρ of the penalty continuation, each warm-started from the last.
    """

    march: bool = True
    max_splits: int = 20
    certify_tol: float = 1e-9
    branch_max_iter: int = 30
    penalties: Tuple[float, ...] = PENALTY

    def __post_init__(self):
        if not isinstance(self.max_splits, int) or not 0 <= self.max_splits <= 40:
            raise InputError(f"max_splits must be an integer in [0, 40] (got {self.max_splits!r})")
        if not 0.0 < float(self.certify_tol) < 1e-3:
            raise InputError(f"certify_tol must be in (0, 1e-3) (got {self.certify_tol!r})")
        if not isinstance(self.branch_max_iter, int) or self.branch_max_iter < 0:
            raise InputError(f"branch_max_iter must be a non-negative integer (got {self.branch_max_iter!r})")
        pen = tuple(float(p) for p in self.penalties)
        if not pen or any(not p > 0.0 or p != p or p == float("inf") for p in pen) or list(pen) != sorted(pen):
            raise InputError(f"penalties must be finite, positive and increasing (got {self.penalties!r})")
        object.__setattr__(self, "penalties", pen)
