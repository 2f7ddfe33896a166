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

Launched at ``v0 > 0`` (``BlockPush.v0``), the slide starts at once and its placement is no longer free.  With
``u = μmg + m a``, ``∫u² = (μmg)²τ − 2μm²g v0 + m² E(τ)`` (``∫a = −v0``), where the least ``∫a²`` that takes a free
mass from ``(0, v0)`` to ``(d, 0)`` in ``τ`` is ``E(τ) = 4v0²/τ − 12v0d/τ² + 12d²/τ³`` (``a`` linear in t); the
cheapest slide's ``τ*`` is the positive root of ``(μg)²τ⁴ − 4v0²τ² + 24v0dτ − 36d² = 0``.  The formula holds while
the slide's velocity stays positive inside it (:attr:`BlockPush.slides_forward`).  The block push launched at
``v0`` has one event, the stop at ``τ*``, whose time the optimum fixes: a test of the stop's timing that the
resting start's free placement does not give.

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
    #: the initial velocity (toward d; 0: from rest)
    v0: float = 0.0

    @property
    def free_slide(self) -> float:
        """``τ*``: the duration of the cheapest slide, ``√(6d/(μg))`` from rest, else the positive root of
        ``(μg)²τ⁴ − 4v0²τ² + 24v0dτ − 36d² = 0`` (``inf`` without friction)."""
        if self.friction <= 0:
            return math.inf
        d, v0, mg = abs(self.distance), abs(self.v0), self.friction * self.g
        if v0 == 0.0:
            return math.sqrt(6.0 * d / mg)
        r = np.roots([mg * mg, 0.0, -4.0 * v0 * v0, 24.0 * v0 * d, -36.0 * d * d])
        return float(np.max(r[(np.abs(r.imag) < 1e-9 * np.abs(r)) & (r.real > 0)].real))

    def _accel(self, tau: float):
        """``(c0, c1)``: the slide's least-effort acceleration ``a = c0 + c1 t`` from ``(0, v0)`` to ``(d, 0)`` in ``τ``."""
        d, v0 = self.distance, self.v0
        return (6.0 * d - 4.0 * v0 * tau) / tau ** 2, (6.0 * v0 * tau - 12.0 * d) / tau ** 3

    @property
    def slides_forward(self) -> bool:
        """Does the slide's velocity keep its sign inside it (the closed form's assumption)?"""
        tau = self.slide
        c0, c1 = self._accel(tau)
        t = np.linspace(0.0, tau, 2001)[1:-1]
        v = self.v0 + c0 * t + 0.5 * c1 * t * t
        s = np.sign(self.distance) if self.distance else 1.0
        return bool(np.all(s * v > 0))

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
        """``J* = (μmg)²τ − 2μm²g v0 + m² E(τ)`` at the optimum's slide ``τ`` (``12m²d²/τ³ + (μmg)²τ`` from rest)."""
        m, d, tau, v0 = self.mass, self.distance, self.slide, self.v0
        s = np.sign(d) if d else 1.0
        E = 4.0 * v0 * v0 / tau - 12.0 * v0 * d / tau ** 2 + 12.0 * d * d / tau ** 3
        return float((self.friction * m * self.g) ** 2 * tau - 2.0 * s * self.friction * m * m * self.g * v0 + m * m * E)

    def discrete_cost(self, N: int) -> float:
        """The midpoint optimum on ``N`` steps when the block slides the whole horizon from rest (``nan`` when it
        sticks or is launched)."""
        if self.sticks or self.v0:
            return math.nan
        m, d, T = self.mass, self.distance, self.T
        return 12.0 * m * m * d * d / T ** 3 * N * N / (N * N - 1.0) + (self.friction * m * self.g) ** 2 * T

    @property
    def peak_force(self) -> float:
        """The largest |force| of the optimum (at an end of its slide: ``μmg + 6m|d|/τ²`` from rest)."""
        c0, c1 = self._accel(self.slide)
        s = np.sign(self.distance) if self.distance else 1.0
        ends = (c0, c0 + c1 * self.slide)
        return float(max(abs(s * self.friction * self.mass * self.g + self.mass * a) for a in ends))

    @property
    def bound_inactive(self) -> bool:
        """Is the closed form the optimum of the bounded problem (its peak force within ``u_max``)?"""
        return self.peak_force <= self.u_max

    def control(self, t) -> np.ndarray:
        """The optimal force with the slide first, ``μmg + m(c0 + c1 t)`` on ``[0, τ)`` (``μmg + m(6d/τ²)(1 − 2t/τ)``
        from rest), 0 after."""
        t = np.asarray(t, float)
        m, tau = self.mass, self.slide
        c0, c1 = self._accel(tau)
        s = np.sign(self.distance) if self.distance else 1.0
        return np.where(t < tau, s * self.friction * m * self.g + m * (c0 + c1 * t), 0.0)

    def position(self, t) -> np.ndarray:
        """The optimal position with the slide first: ``v0 t + c0 t²/2 + c1 t³/6`` on the slide (``d (3 − 2t/τ)(t/τ)²``
        from rest), ``d`` after."""
        t = np.minimum(np.asarray(t, float), self.slide)
        c0, c1 = self._accel(self.slide)
        return self.v0 * t + 0.5 * c0 * t * t + c1 * t ** 3 / 6.0

    def as_dict(self) -> dict:
        return {"exact_cost": self.cost, "slide_time": self.slide, "free_slide": self.free_slide,
                "sticks": self.sticks, "peak_force": self.peak_force, "bound_inactive": self.bound_inactive,
                "v0": self.v0, "slides_forward": self.slides_forward}
