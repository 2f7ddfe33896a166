"""Input checks shared by the physics modules.

Every refusal raises :class:`InputError` with one sentence that names the
offending quantity; problem scripts turn it into one line on stderr and exit
code 2.
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
