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


class InputError(ValueError):
    """Bad input: a physically meaningless or unsupported parameter."""


def finite(name: str, value) -> float:
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
