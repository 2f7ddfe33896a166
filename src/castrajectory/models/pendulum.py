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
* :func:`driven_pendulum` — the damped, driven pendulum ``θ̈ + γθ̇ + ω₀² sin θ = A cos(Ωt)``
  (chaotic at ``ω₀ = 1, γ = 0.5, Ω = 2/3, A = 1.2``).
* :func:`kapitza_pendulum` — a pendulum whose pivot moves vertically as ``a cos(ωt)``: the
  inverted position is stable when ``a²ω² > 2 g l`` (:func:`kapitza_threshold`).
"""
from __future__ import annotations

import math
from typing import Sequence

import casadi as ca
import numpy as np

from .mechanics import Atoms, Damping, Force, Gravity, LagrangianSystem, Spring, time
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


def driven_pendulum(gamma: float = 0.5, omega0: float = 1.0, amplitude: float = 1.2,
                    drive_frequency: float = 2.0 / 3.0) -> LagrangianSystem:
    """``θ̈ + γθ̇ + ω₀² sin θ = A cos(Ωt)``: a unit bob on a unit rod under the gravity ``ω₀²``, the damping
    ``γ`` (Rayleigh, ``½γθ̇²``) and the drive ``A cos(Ωt)`` as a torque; each term only if it is non-zero.

    >>> from castrajectory.models.pendulum import driven_pendulum
    >>> p = driven_pendulum()
    >>> p.terms(), float(p.acceleration([0.0], [1.0], 0.0))      # -0.5·1 + 1.2·cos 0
    (['kinetic: 1 atom', 'gravity', 'force: damping', 'force: drive', 'time-dependent'], 0.7)
    """
    for name, v in (("gamma", gamma), ("omega0", omega0), ("amplitude", amplitude),
                    ("drive frequency", drive_frequency)):
        finite(name, v)
    if gamma < 0:
        raise InputError(f"gamma must not be negative (got {gamma:g}): a negative damping feeds energy in")
    th = ca.SX.sym("theta", 1)
    bob = ca.vertcat(ca.sin(th), -ca.cos(th))
    terms = _gravity(omega0 ** 2)
    if gamma:
        terms.append(Damping(gamma))
    if amplitude:
        terms.append(Force(amplitude * ca.cos(drive_frequency * time()), "drive"))
    return LagrangianSystem(th, Atoms([bob], [1.0]), terms, names=["theta"])


def kapitza_pendulum(length: float = 1.0, g: float = 9.81, amplitude: float = 0.1, frequency: float = 100.0,
                     mass: float = 1.0) -> LagrangianSystem:
    """A bob on a rod of ``length`` whose pivot moves as ``(0, a cos(ωt))``; ``θ`` from the downward
    vertical.  The atom's position holds the time, so the Lagrangian does:
    ``L = ½ m (l²θ̇² + 2 l a ω sin(ωt) sin θ θ̇ + a²ω² sin²(ωt)) + m g (l cos θ − a cos ωt)``.

    >>> from castrajectory.models.pendulum import kapitza_pendulum, kapitza_threshold
    >>> kapitza_pendulum().time_dependent, round(kapitza_threshold(1.0, 9.81, 0.1, 100.0), 4)
    (True, 5.0968)
    """
    positive("length", length)
    positive("mass", mass)
    finite("amplitude", amplitude)
    finite("frequency", frequency)
    th = ca.SX.sym("theta", 1)
    pivot = ca.vertcat(0, amplitude * ca.cos(frequency * time()))
    bob = pivot + length * ca.vertcat(ca.sin(th), -ca.cos(th))
    return LagrangianSystem(th, Atoms([bob], [float(mass)]), _gravity(g), names=["theta"], points_expr=[pivot, bob])


def kapitza_threshold(length: float, g: float, amplitude: float, frequency: float) -> float:
    """``a²ω² / (2 g l)``: the inverted Kapitza pendulum is stable (averaged over the fast drive, to first
    order in ``a/l``) when this exceeds 1 (Landau–Lifshitz, Mechanics §30)."""
    return amplitude ** 2 * frequency ** 2 / (2.0 * g * length)
