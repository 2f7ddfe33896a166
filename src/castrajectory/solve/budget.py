"""An Ipopt iteration budget for a whole run (``--max-iter``), shared by every solve a strategy makes.

A strategy may solve many NLPs (coarse-to-fine levels, horizon windows, penalty rungs).  Within
:func:`iterations` the total of their Ipopt iterations is capped: each solve may use at most what is
left, and once nothing is left a solve returns ``Maximum_Iterations_Exceeded`` without running.
"""
from __future__ import annotations

import contextlib
from typing import Optional

_remaining: Optional[int] = None


@contextlib.contextmanager
def iterations(n: Optional[int]):
    """Cap the Ipopt iterations of everything solved in the block at ``n`` (no cap for None)."""
    global _remaining
    saved = _remaining
    _remaining = None if n is None else int(n)
    try:
        yield
    finally:
        _remaining = saved


def remaining() -> Optional[int]:
    """Iterations left (None: no budget)."""
    return _remaining


def spend(k: int) -> None:
    global _remaining
    if _remaining is not None:
        _remaining = max(0, _remaining - int(k))
