"""The block push: the closed form that ``problems/block_push.py`` (issue #27) is measured against.

A block of mass ``m`` rests on a floor with Coulomb friction ``μ``; a horizontal force ``u`` moves it from rest
at 0 to rest at ``d`` in the time ``T``, minimising ``∫u² dt``.

While the block slides forward the friction is the constant ``−μmg``, so ``m ẍ = u − μmg``.  Write ``u = μmg +
w``: over a slide from rest to rest of duration ``τ`` the momentum returns to zero, ``∫w = 0``, so ``∫u² = ∫w² +
(μmg)²τ``, and the least ``∫w²`` that moves a free mass by ``d`` from rest to rest in ``τ`` is ``12m²d²/τ³``
(``w = m(6d/τ²)(1 − 2t/τ)``, whose velocity ``(6d/τ²)(t − t²/τ)`` is positive inside the slide: the block
never sticks in it).  While it sticks, ``u = 0`` costs nothing.  A motion that slides in several pieces of
total duration ``τ`` costs more than one slide of ``τ`` (two equal pieces: four times the ``∫w²``), so

    J(τ) = 12 m² d²/τ³ + (μmg)² τ,   minimised over the slide's duration τ ≤ T.

``J`` falls while ``τ⁴ < 36d²/(μg)²``: the optimum slides the whole horizon when ``T ≤ τ* = √(6d/(μg))``, and
otherwise slides for ``τ*`` and sticks for ``T − τ*`` (where in ``[0, T]`` the slide sits is free: every
placement costs the same), with ``J* = (4/3)(μmg)² τ*``.  The peak force ``μmg + 6md/τ²`` must be within the
bound ``u_max`` for this to be the optimum of the bounded problem (:attr:`BlockPush.bound_inactive`).

On the midpoint rule with ``N`` steps (controls constant per step) and a slide over the whole horizon, the
friction's impulse per step is ``μmgh`` exactly, and the discrete optimum is the frictionless one plus the
friction's share: ``J_N = (12m²d²/T³) N²/(N² − 1) + (μmg)² T``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np

from .contact import Contact
from .control import Control
from .mechanics import Atoms, Force, Gravity, LagrangianSystem, velocity


def pushed_particle(mass: float = 1.0, friction: float = 0.3, g: float = 9.81, u_max: float = math.inf,
                    restitution: float = 0.0) -> LagrangianSystem:
    """A point of mass ``m`` in the plane, ``q = (x, y)``, over the floor ``y ≥ 0`` (restitution ``e``, Coulomb
    friction ``μ`` against the slip ``ẋ``), under gravity and a horizontal force ``u``, ``|u| ≤ u_max``: the block
    of the block push, and the particle of the push to a target."""
    q = ca.SX.sym("q", 2)
    u = Control("u", 1, lower=-u_max, upper=u_max)
    return LagrangianSystem(q, Atoms([q], [mass]), [Gravity(g), Force(ca.vertcat(u, 0))], names=["x", "y"],
                            contact=Contact([q[1]], restitution=restitution, friction=friction,
                                            slip=[velocity(q)[0]], names=["floor"]))


@dataclass(frozen=True)
class BlockPush:
    """The closed form of the block push (see the module's doc)."""

    mass: float
    friction: float
    distance: float
    T: float
    g: float = 9.81
    u_max: float = math.inf

    @property
    def free_slide(self) -> float:
        """``τ* = √(6d/(μg))``: the duration of the cheapest slide (``inf`` without friction)."""
        if self.friction <= 0:
            return math.inf
        return math.sqrt(6.0 * abs(self.distance) / (self.friction * self.g))

    @property
    def slide(self) -> float:
        """The optimum's sliding time, ``min(T, τ*)``."""
        return min(self.T, self.free_slide)

    @property
    def sticks(self) -> bool:
        """Does the optimum stick for part of the horizon (``T > τ*``)?"""
        return self.T > self.free_slide

    @property
    def cost(self) -> float:
        """``J* = 12m²d²/τ³ + (μmg)²τ`` at the optimum's slide ``τ``."""
        m, d, tau = self.mass, self.distance, self.slide
        return 12.0 * m * m * d * d / tau ** 3 + (self.friction * m * self.g) ** 2 * tau

    def discrete_cost(self, N: int) -> float:
        """The midpoint optimum on ``N`` steps when the block slides the whole horizon (``nan`` when it sticks)."""
        if self.sticks:
            return math.nan
        m, d, T = self.mass, self.distance, self.T
        return 12.0 * m * m * d * d / T ** 3 * N * N / (N * N - 1.0) + (self.friction * m * self.g) ** 2 * T

    @property
    def peak_force(self) -> float:
        """``μmg + 6m|d|/τ²``: the largest force of the optimum (at the start of its slide)."""
        return self.friction * self.mass * self.g + 6.0 * self.mass * abs(self.distance) / self.slide ** 2

    @property
    def bound_inactive(self) -> bool:
        """Is the closed form the optimum of the bounded problem (its peak force within ``u_max``)?"""
        return self.peak_force <= self.u_max

    def control(self, t) -> np.ndarray:
        """The optimal force with the slide first, ``μmg + m(6d/τ²)(1 − 2t/τ)`` on ``[0, τ)``, 0 after."""
        t = np.asarray(t, float)
        m, d, tau = self.mass, self.distance, self.slide
        s = np.sign(d) if d else 1.0
        return np.where(t < tau, s * self.friction * m * self.g + m * 6.0 * d / tau ** 2 * (1.0 - 2.0 * t / tau), 0.0)

    def position(self, t) -> np.ndarray:
        """The optimal position with the slide first: ``d (3 − 2t/τ)(t/τ)²`` on the slide, ``d`` after."""
        t = np.minimum(np.asarray(t, float), self.slide) / self.slide
        return self.distance * (3.0 - 2.0 * t) * t * t

    def as_dict(self) -> dict:
        return {"exact_cost": self.cost, "slide_time": self.slide, "free_slide": self.free_slide,
                "sticks": self.sticks, "peak_force": self.peak_force, "bound_inactive": self.bound_inactive}
