"""Bad input: :class:`InputError` and the checks that raise it.

Every refusal raises :class:`InputError` with one sentence that names the
offending quantity; problem scripts turn it into one line on stderr and exit
code 2, before any solve.

Where values are checked (once, where they enter):

* a model's parameter object or factory checks the parameters a user gives it
  (:class:`~castrajectory.models.droplet.Droplet`, :class:`~castrajectory.models.collision.Body`,
  :class:`~castrajectory.models.mechanics.Contact`, the pendulum factories, ...);
* the solve and baseline entry points check the run's own arguments (``q0``, ``q̇0``,
  ``T``, ``N``, scheme, method);
* a problem script checks only what its scene adds (a start above the ground, ``g ≥ 0``).

Code below those edges trusts what it receives: a :class:`Body` is not re-checked by the
functions that take one, and the contact solver applies the impact law
(:func:`~castrajectory.models.collision.impact_law`) to computed values without checks.
"""
from __future__ import annotations

import math

import numpy as np


class InputError(ValueError):
    """Bad input: a physically meaningless or unsupported parameter."""


def _holds_text(value) -> bool:
    """Does ``value`` hold a string anywhere (``float("0.5")`` and NumPy's conversion would read it silently)?"""
    if isinstance(value, (str, bytes)):
        return True
    if isinstance(value, np.ndarray):
        return value.dtype.kind in "USa" or (value.dtype.kind == "O" and any(map(_holds_text, value.flat)))
    if isinstance(value, (list, tuple)):
        return any(_holds_text(v) for v in value)
    return False


def finite(name: str, value) -> float:
    if _holds_text(value):
        raise InputError(f"{name} must be a number, not the text {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number (got {value!r})") from None
    if not math.isfinite(v):
        raise InputError(f"{name} must be finite (got {value})")
    return v


def positive(name: str, value) -> float:
    v = finite(name, value)
    if v <= 0.0:
        raise InputError(f"{name} must be positive (got {value})")
    return v


def integer_at_least(name: str, value, minimum: int) -> int:
    v = finite(name, value)
    if v != int(v) or v < minimum:
        raise InputError(f"{name} must be an integer >= {minimum} (got {value})")
    return int(v)


def one_of(name: str, value, choices) -> str:
    if value not in choices:
        raise InputError(f"{name} must be one of {', '.join(map(str, choices))} (got {value!r})")
    return value


def state_vector(name: str, value, n: int, names=None) -> np.ndarray:
    """``value`` as a vector of ``n`` finite numbers, one per coordinate (``names``, for the message).

    A nested value is refused even when its total size is ``n`` (``[[0.1, 0.2], [0.3, 0.4]]`` for four
    coordinates is not a state); a column or row (``n × 1``, ``1 × n``, e.g. a CasADi ``DM``) is a vector.  Text
    is refused (``["0.5"]`` is not a number, though NumPy would read it as one)."""
    if _holds_text(value):
        raise InputError(f"{name} must be a list of {n} numbers, not text (got {value!r})".splitlines()[0])
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a list of {n} numbers (got {value!r})".splitlines()[0]) from None
    if arr.ndim > 2 or (arr.ndim == 2 and min(arr.shape) != 1):
        raise InputError(f"{name} must be a flat list of {n} numbers, one per coordinate (got an array of shape "
                         f"{arr.shape})")
    arr = arr.reshape(-1)
    if arr.size != n:
        which = f" ({', '.join(names)})" if names else ""
        raise InputError(f"{name} has {arr.size} values, the system has {n} coordinates{which}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name} must be finite (got {arr.tolist()})")
    return arr
