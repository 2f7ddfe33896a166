"""The bounce to a target: the closed form that ``problems/bounce_to_target.py`` (issue #27) is measured against.

A ball launched vertically from the floor with speed ``v₀`` flies ``2v₀/g``, lands with ``v₀`` and leaves with
``e v₀`` (Newton's restitution); after ``i`` bounces it leaves with ``eⁱ v₀`` and flies ``2eⁱv₀/g``.  It is to
be at rest (the apex of its flight) at height ``p`` just after ``k`` bounces: ``(eᵏv₀)² = 2gp``, so

    v₀ = √(2gp) / eᵏ,   flights 2eⁱv₀/g (i = 0 … k−1), then the rise eᵏv₀/g to the apex,

and the horizon ``T = (2v₀/g)(1 − eᵏ)/(1 − e) + eᵏv₀/g`` (``2kv₀/g + v₀/g`` at ``e = 1``).  The point is the only
feasible one: the number of bounces and the apex condition fix the speed, and the speed fixes every flight.
rockit's ``bounce.py`` (g = 9.81, p = 0.5, k = 2, e = 0.9): v₀ = 3.86678 m/s, flights 0.788334, 0.709501 and
0.319275 s, T = 1.817111 s.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Tuple

from ..validation import InputError, finite, positive


@dataclass(frozen=True)
class BounceToTarget:
    """The closed form of the bounce to a target (see the module's doc); times in seconds from the launch."""

    height: float
    bounces: int
    restitution: float
    g: float

    @property
    def launch_speed(self) -> float:
        """``v₀ = √(2gp) / eᵏ``."""
        return math.sqrt(2.0 * self.g * self.height) / self.restitution ** self.bounces

    @property
    def flights(self) -> Tuple[float, ...]:
        """The ``k`` flights between floor contacts, ``2eⁱv₀/g``, and the last rise to the apex, ``eᵏv₀/g``."""
        v0, e, g = self.launch_speed, self.restitution, self.g
        return tuple(2.0 * e ** i * v0 / g for i in range(self.bounces)) + (e ** self.bounces * v0 / g,)

    @property
    def impact_times(self) -> Tuple[float, ...]:
        """The ``k`` bounce times."""
        out, t = [], 0.0
        for f in self.flights[:-1]:
            t += f
            out.append(t)
        return tuple(out)

    @property
    def horizon(self) -> float:
        """``T``: the launch to the apex of the last flight, where the ball is at rest at height ``p``."""
        return sum(self.flights)

    def as_dict(self) -> dict:
        return {"v0": self.launch_speed, "T": self.horizon, "impact_times": list(self.impact_times),
                "flights": list(self.flights)}


def bounce_to_target(height: float, bounces: int, restitution: float, g: float = 9.81) -> BounceToTarget:
    """The closed form of the launch that comes to rest at ``height`` after ``bounces`` bounces (checked input:
    ``height > 0``, ``bounces >= 0`` an integer, ``0 < restitution <= 1``, ``g > 0``)."""
    positive("height", height)
    positive("g", g)
    finite("restitution", restitution)
    if not 0.0 < restitution <= 1.0:
        raise InputError(f"the restitution must lie in (0, 1] for the ball to rise again (got {restitution})")
    if isinstance(bounces, bool) or int(bounces) != bounces or bounces < 0:
        raise InputError(f"bounces must be a whole number >= 0 (got {bounces})")
    return BounceToTarget(float(height), int(bounces), float(restitution), float(g))
