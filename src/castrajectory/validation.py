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

A message quotes a value the user gave by an excerpt (:func:`quoted`, :func:`cut`: at most :data:`EXCERPT`
characters, and of a long list the first entry at fault), never whole: a 200 MB ``q0`` is one short line.

Code below those edges trusts what it receives: a :class:`Body` is not re-checked by the
functions that take one, and the contact solver applies the impact law
(:func:`~castrajectory.models.collision.impact_law`) to computed values without checks.
"""
from __future__ import annotations

import math
import reprlib

import numpy as np


class InputError(ValueError):
    """Bad input: a physically meaningless or unsupported parameter."""


#: The longest excerpt of a value or of a user's exception that a message quotes (a 200 MB ``q0`` with one word
#: in it was quoted whole: a 125 MB "line" on stderr).
EXCERPT = 80

_repr = reprlib.Repr()
_repr.maxlist = _repr.maxtuple = _repr.maxarray = _repr.maxset = _repr.maxdict = 6
_repr.maxstring = _repr.maxother = _repr.maxlong = EXCERPT
_repr.maxlevel = 3


def cut(text: str, limit: int = EXCERPT) -> str:
    """The first line of ``text``, at most ``limit`` characters: longer text ends in an ellipsis."""
    line = str(text).split("\n", 1)[0].rstrip("\r")
    if len(line) > limit or "\n" in str(text):
        line = line[:max(limit - 1, 1)].rstrip() + "…"
    return line


def quoted(value, limit: int = EXCERPT) -> str:
    """``repr(value)`` cut to ``limit`` characters (:func:`cut`), without writing the whole of a huge value
    first (lists, tuples and strings are abbreviated by :mod:`reprlib`)."""
    if isinstance(value, (float, int, bool, type(None))) or isinstance(value, np.generic):
        text = repr(value.item() if isinstance(value, np.generic) else value)
    else:
        text = _repr.repr(value)
    return cut(text, limit)


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
        raise InputError(f"{name} must be a number, not the text {quoted(value)}")
    try:
        v = float(value)
    except OverflowError:  # an int beyond double precision (10**400)
        raise InputError(f"{name} must be finite (got a number beyond double precision)") from None
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number (got {quoted(value)})") from None
    if not math.isfinite(v):
        raise InputError(f"{name} must be finite (got {cut(value)})")
    return v


def positive(name: str, value) -> float:
    v = finite(name, value)
    if v <= 0.0:
        raise InputError(f"{name} must be positive (got {cut(value)})")
    return v


def integer_at_least(name: str, value, minimum: int) -> int:
    v = finite(name, value)
    if v != int(v) or v < minimum:
        raise InputError(f"{name} must be an integer >= {minimum} (got {cut(value)})")
    return int(v)


def one_of(name: str, value, choices) -> str:
    if value not in choices:
        options = cut(", ".join(map(str, choices)), 4 * EXCERPT)
        raise InputError(f"{name} must be one of {options} (got {quoted(value)})")
    return value


def _not_a_number(value) -> bool:
    try:
        float(value)
    except (TypeError, ValueError):
        return True
    return False


def _offender(value, bad) -> str:
    """``"entry i is X"`` for the first entry of a flat sequence for which ``bad`` holds (a value of millions of
    numbers is then named by its one offender), else ``"got X"``; ``X`` quoted and cut (:func:`quoted`)."""
    if isinstance(value, (list, tuple)) or (isinstance(value, np.ndarray) and value.ndim == 1):
        for i, v in enumerate(value):
            if bad(v):
                return f"entry {i} is {quoted(v)}"
    return f"got {quoted(value)}"


def state_vector(name: str, value, n: int, names=None) -> np.ndarray:
    """``value`` as a vector of ``n`` finite numbers, one per coordinate (``names``, for the message).

    A nested value is refused even when its total size is ``n`` (``[[0.1, 0.2], [0.3, 0.4]]`` for four
    coordinates is not a state); a column or row (``n × 1``, ``1 × n``, e.g. a CasADi ``DM``) is a vector.  Text
    is refused (``["0.5"]`` is not a number, though NumPy would read it as one)."""
    if _holds_text(value):
        raise InputError(f"{name} must be a list of {n} numbers, not text ({_offender(value, _holds_text)})")
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a list of {n} numbers ({_offender(value, _not_a_number)})") from None
    if arr.ndim > 2 or (arr.ndim == 2 and min(arr.shape) != 1):
        raise InputError(f"{name} must be a flat list of {n} numbers, one per coordinate (got an array of shape "
                         f"{arr.shape})")
    arr = arr.reshape(-1)
    if arr.size != n:
        which = f" ({cut(', '.join(names), 2 * EXCERPT)})" if names else ""
        raise InputError(f"{name} has {arr.size} values, the system has {n} coordinates{which}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name} must be finite ({_offender(arr, lambda v: not np.isfinite(v))})")
    return arr
