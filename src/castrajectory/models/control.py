"""Control inputs: CasADi symbols with bounds, which enter a system through its forces.

A :class:`Control` *is* a column of SX symbols (arithmetic on it gives ordinary expressions), with its
bounds and name attached, and registered so that a system can tell its controls from stray symbols:

    u = ct.Control("u", 1, lower=-20, upper=20)
    cart_pole = ct.LagrangianSystem(q, ct.Atoms(...), [ct.Gravity(9.81), ct.Force(ca.vertcat(u, 0))])

The dynamics are then the Lagrange–d'Alembert equations with the control in the force; a system with
controls is solved by :class:`castrajectory.OptimalControl`, not simulated.
"""
from __future__ import annotations

from typing import Dict, List

import casadi as ca
import numpy as np

from ..validation import InputError, integer_at_least

#: element hash of each control symbol -> (the control, its row); the symbols stay alive with it
_REGISTRY: Dict[int, tuple] = {}


class Control(ca.SX):
    """A control input of ``size`` entries named ``name``, bounded by ``lower`` and ``upper`` (numbers or one
    per entry; ``None``: unbounded).  It is a column of CasADi symbols: use it in a ``ct.Force``.

    >>> import casadi as ca, castrajectory as ct
    >>> u = ct.Control("u", 1, lower=-2.0, upper=2.0)
    >>> x = ca.SX.sym("x", 1)
    >>> block = ct.LagrangianSystem(x, ct.MassMatrix(1.0), [ct.Force(u)])
    >>> [c.name for c in block.controls], u.lower.tolist(), u.upper.tolist()
    (['u'], [-2.0], [2.0])
    """

    def __init__(self, name: str, size: int = 1, lower=None, upper=None):
        size = integer_at_least("control size", size, 1)
        if not isinstance(name, str) or not name:
            raise InputError("a control needs a name")
        super().__init__(ca.SX.sym(name, size))
        self.name = name
        self.size = size
        self.lower = _bound(lower, size, -np.inf, f"control {name} lower")
        self.upper = _bound(upper, size, np.inf, f"control {name} upper")
        if np.any(self.lower > self.upper):
            raise InputError(f"control {name}: a lower bound is above its upper bound "
                             f"({self.lower.tolist()} > {self.upper.tolist()})")
        self._order = len(_REGISTRY)  # creation order (controls_in sorts by it)
        for i in range(size):
            _REGISTRY[self[i].element_hash()] = (self, i)

    def __reduce__(self):  # pragma: no cover - a symbol is not meant to be pickled
        raise TypeError("a Control is a CasADi symbol and cannot be pickled")


def _bound(value, size: int, default: float, what: str) -> np.ndarray:
    if value is None:
        return np.full(size, default)
    try:
        v = np.broadcast_to(np.asarray(value, dtype=float), (size,)).copy()
    except (TypeError, ValueError):
        raise InputError(f"{what} bound must be a number or {size} numbers (got {value!r})") from None
    if np.any(np.isnan(v)):
        raise InputError(f"{what} bound must not be NaN")
    return v


def controls_in(expr) -> List[Control]:
    """The controls whose symbols appear in ``expr``, in the order they were created (each once)."""
    found = {}
    for v in ca.symvar(ca.SX(expr)):
        hit = _REGISTRY.get(v.element_hash())
        if hit is not None:
            found[id(hit[0])] = hit[0]
    return sorted(found.values(), key=lambda c: c._order)


def is_control_symbol(v) -> bool:
    """Is the scalar symbol ``v`` an entry of a :class:`Control`?"""
    return v.element_hash() in _REGISTRY
