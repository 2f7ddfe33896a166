"""Pendulum-type systems (factories) and their analytic facts.

Each factory returns a :class:`~castrajectory.models.mechanics.LagrangianSystem`
holding only the terms the scene needs (no :class:`Gravity` when ``g == 0``).

* :func:`double_pendulum` — two point masses on massless rods, angles from the
  downward vertical::

        o pivot
         \\ l1
          ● m1
           \\ l2
            ● m2

  Equal masses and lengths: small-oscillation normal modes
  ``ω² = (2 ∓ √2) g / l`` (:func:`double_pendulum_modes`).
* :func:`n_link_pendulum` — the same with ``n`` links.
* :func:`spring_pendulum` — a point mass on a linear spring (polar coordinates
  r, θ); stiff when ``k l / (m g)`` is large.  Radial frequency ``√(k/m)``.
* :func:`cartesian_pendulum` — one point mass in (x, y) with the holonomic
  constraint ``(x² + y² − l²)/2 = 0``; must match the angle form.
* :func:`point_mass` — a free point mass in a uniform field (the boundary-mode
  parabola).
"""
from __future__ import annotations

import math
from typing import Sequence

import casadi as ca
import numpy as np

from .mechanics import Atoms, Gravity, LagrangianSystem, Spring
from ..validation import InputError, finite, positive


def _gravity(g: float):
    finite("g", g)
    return [Gravity(g)] if g != 0 else []


def n_link_pendulum(masses: Sequence[float], lengths: Sequence[float], g: float = 9.81) -> LagrangianSystem:
    """Planar chain of point masses; ``q_i`` is link i's angle from the downward vertical."""
    if len(masses) != len(lengths) or len(masses) < 1:
        raise InputError("give one mass per link length (at least one link)")
    for i, (m, l) in enumerate(zip(masses, lengths)):
        positive(f"mass {i + 1}", m)
        positive(f"length {i + 1}", l)
    n = len(masses)
    q = ca.SX.sym("theta", n)
    pts, p = [], ca.SX.zeros(2)
    for i in range(n):
        p = p + lengths[i] * ca.vertcat(ca.sin(q[i]), -ca.cos(q[i]))
        pts.append(p)
    return LagrangianSystem(q, Atoms(pts, list(map(float, masses))), _gravity(g),
                            names=[f"theta{i + 1}" for i in range(n)])


def double_pendulum(m1=1.0, m2=1.0, l1=1.0, l2=1.0, g=9.81) -> LagrangianSystem:
    return n_link_pendulum([m1, m2], [l1, l2], g)


def double_pendulum_modes(g: float, l: float):
    """Angular frequencies of the equal-mass, equal-length double pendulum's normal modes,
    with mode shapes ``(1, ±√2)`` (in-phase slow mode first)."""
    w2 = np.array([(2 - math.sqrt(2)) * g / l, (2 + math.sqrt(2)) * g / l])
    shapes = np.array([[1.0, math.sqrt(2)], [1.0, -math.sqrt(2)]])
    return np.sqrt(w2), shapes


def spring_pendulum(m=1.0, rest=1.0, k=100.0, g=9.81) -> LagrangianSystem:
    """Point mass on a spring from the origin; ``q = (r, θ)``, θ from the downward vertical."""
    positive("mass", m)
    positive("rest length", rest)
    positive("stiffness", k)
    q = ca.SX.sym("q", 2)
    x = q[0] * ca.vertcat(ca.sin(q[1]), -ca.cos(q[1]))
    terms = _gravity(g) + [Spring(k, rest, x, ca.SX.zeros(2))]
    return LagrangianSystem(q, Atoms([x], [m]), terms, names=["r", "theta"])


def cartesian_pendulum(m=1.0, l=1.0, g=9.81) -> LagrangianSystem:
    """Point mass at (x, y) on a rigid rod: constraint ``(x² + y² − l²)/2 = 0``."""
    positive("mass", m)
    positive("length", l)
    q = ca.SX.sym("xy", 2)
    return LagrangianSystem(q, Atoms([q], [m]), _gravity(g), [(ca.dot(q, q) - l * l) / 2],
                            names=["x", "y"])


def point_mass(m=1.0, g=9.81, dim=2) -> LagrangianSystem:
    """Free point mass in ``dim`` dimensions under gravity along ``-e_y``."""
    positive("mass", m)
    q = ca.SX.sym("x", dim)
    return LagrangianSystem(q, Atoms([q], [m]), _gravity(g), names=["x", "y", "z"][:dim])
