"""The damped, driven harmonic oscillator, with its closed form (the oracle of every scheme's order).

::

    m ẍ + c ẋ + k x = A cos(Ω t),        x(0) = x₀,  ẋ(0) = v₀

is the Lagrangian ``½ m ẋ² − ½ k x²`` with the Rayleigh damping ``½ c ẋ²`` and the force ``A cos(Ωt)``:
a time-dependent, non-conservative system, under-, critically or over-damped.  Its solution is the
steady response to the drive plus the decaying free motion (:func:`exact`).
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from .mechanics import Damping, Force, LagrangianSystem, MassMatrix, Potential, time


def damped_oscillator(mass: float = 1.0, stiffness: float = 4.0, damping: float = 0.0, amplitude: float = 0.0,
                      frequency: float = 1.0) -> LagrangianSystem:
    """``m ẍ + c ẋ + k x = A cos(Ωt)``; each term only if its coefficient is non-zero (no damping term for
    ``c = 0``, no drive for ``A = 0``, no spring for ``k = 0``).

    >>> import castrajectory as ct
    >>> from castrajectory.models.oscillator import damped_oscillator
    >>> damped_oscillator(1.0, 4.0, 0.5, 1.0, 2.0).terms()
    ['kinetic: mass matrix', 'spring', 'force: damping', 'force: drive', 'time-dependent']
    """
    x = ca.SX.sym("x", 1)
    terms = []
    if stiffness:
        terms.append(Potential(0.5 * stiffness * x[0] ** 2, "spring"))
    if damping:
        terms.append(Damping(damping))
    if amplitude:
        terms.append(Force(amplitude * ca.cos(frequency * time()), "drive"))
    return LagrangianSystem(x, MassMatrix(ca.DM(mass)), terms, names=["x"])


def _free(t, a, disc):
    """``(φ(t), φ'(t))`` with ``φ = e^{−a t} S(t)``, ``S = sin(ω t)/ω``, ``sinh(β t)/β`` or ``t`` for
    ``disc = a² − ω₀²`` negative (``ω² = −disc``), positive (``β² = disc``) or zero: stable near critical
    damping, where the two exponentials' difference would cancel."""
    e = np.exp(-a * t)
    if disc < 0:
        w = np.sqrt(-disc)
        S, C = np.sin(w * t) / w, np.cos(w * t)
    elif disc > 0:
        b = np.sqrt(disc)
        S, C = np.sinh(b * t) / b, np.cosh(b * t)
    else:
        S, C = t, np.ones_like(t)
    return e * S, e * (C - a * S)


def exact(t, mass: float, stiffness: float, damping: float, amplitude: float, frequency: float,
          x0: float, v0: float):
    """The closed form ``(x(t), ẋ(t))`` of ``m ẍ + c ẋ + k x = A cos(Ωt)`` from ``(x₀, v₀)``.

    The particular solution is ``X cos Ωt + Y sin Ωt`` with ``(X, Y) = A (k − mΩ², cΩ)/((k − mΩ²)² + c²Ω²)``,
    or ``A t sin(Ωt)/(2 m Ω)`` at undamped resonance; the free motion ``u`` solves ``m ü + c u̇ + k u = 0``
    from the remaining initial state, ``u = u₀ (φ' + 2a φ) + u̇₀ φ`` with ``a = c/2m`` (:func:`_free`).
    """
    t = np.asarray(t, float)
    m, k, c, A, W = float(mass), float(stiffness), float(damping), float(amplitude), float(frequency)
    den = (k - m * W * W) ** 2 + (c * W) ** 2
    if A == 0.0:
        xp = vp = np.zeros_like(t)
        xp0 = vp0 = 0.0
    elif den > 0.0:
        X, Y = A * (k - m * W * W) / den, A * c * W / den
        xp = X * np.cos(W * t) + Y * np.sin(W * t)
        vp = W * (Y * np.cos(W * t) - X * np.sin(W * t))
        xp0, vp0 = X, W * Y
    else:  # undamped resonance: the amplitude grows linearly
        xp = A * t * np.sin(W * t) / (2 * m * W)
        vp = A * (np.sin(W * t) + W * t * np.cos(W * t)) / (2 * m * W)
        xp0, vp0 = 0.0, 0.0
    a = c / (2 * m)
    disc = a * a - k / m
    phi, dphi = _free(t, a, disc)
    # φ'' = −2a φ' − ω₀² φ
    ddphi = -2 * a * dphi - (k / m) * phi
    u0, du0 = x0 - xp0, v0 - vp0
    x = xp + u0 * (dphi + 2 * a * phi) + du0 * phi
    v = vp + u0 * (ddphi + 2 * a * dphi) + du0 * dphi
    return x, v
