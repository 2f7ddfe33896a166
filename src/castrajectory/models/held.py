"""Held-contact scenes with their closed forms: a ladder sliding down a frictionless wall, and a disk rocking in a
circular bowl, rolling or sliding under Coulomb friction.

* The ladder: a uniform rod of length L and mass m leans against the wall x = 0 at the angle θ₀ from the floor
  and is let go from rest; q = (x, y, θ), its centre and its angle.  While both ends touch, its centre moves on the
  circle of radius L/2 about the corner: θ̈ = −(3g / 2L) cos θ, θ̇² = (3g/L)(sin θ₀ − sin θ).  The wall's force
  vanishes, and the top leaves the wall, when sin θ* = (2/3) sin θ₀ (:func:`ladder_lift_off`).
* The disk: a uniform disk (mass m, radius r, I = m r²/2) inside a circular bowl of radius R centred at the origin;
  q = (x, y, θ).  Its gap is φ = (R − r) − |c|, c = (x, y), and its contact point slips at u = t·ċ + r θ̇ along
  the tangent t.  Written φ from the bottom, while it rolls (u = 0): (3/2)(R − r) φ̈ = −g sin φ, θ = −(R − r)(φ − φ₀)/r;
  rolling from rest at φ₀ needs |F|/N ≤ tan φ₀ / 3 (:func:`disk_rolls`).
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np

from .contact import Contact
from .mechanics import LagrangianSystem, MassMatrix, Potential, velocity


def sliding_ladder(mass: float = 1.0, length: float = 1.0, g: float = 9.81) -> LagrangianSystem:
    """The ladder between a frictionless wall (contact ``wall``, its top's x) and floor (``floor``, its foot's y)."""
    q = ca.SX.sym("q", 3)
    x, y, th = q[0], q[1], q[2]
    top = ca.vertcat(x - 0.5 * length * ca.cos(th), y + 0.5 * length * ca.sin(th))
    foot = ca.vertcat(x + 0.5 * length * ca.cos(th), y - 0.5 * length * ca.sin(th))
    return LagrangianSystem(q, MassMatrix(ca.diag(ca.vertcat(mass, mass, mass * length ** 2 / 12))),
                            [Potential(mass * g * y, "gravity")], names=["x", "y", "theta"], points_expr=[top, foot],
                            contact=Contact([top[0], foot[1]], restitution=0.0, names=["wall", "floor"]))


def ladder_start(theta0: float, length: float = 1.0):
    """``(q0, q̇0)``: the ladder at rest against the wall at the angle θ₀."""
    return [0.5 * length * math.cos(theta0), 0.5 * length * math.sin(theta0), theta0], [0.0, 0.0, 0.0]


def _gauss(f, a: float, b: float, n: int = 64) -> float:
    """``∫_a^b f`` by the n-point Gauss–Legendre rule (a smooth integrand: exact to rounding for n = 64)."""
    x, w = np.polynomial.legendre.leggauss(n)
    xs = 0.5 * (b - a) * x + 0.5 * (b + a)
    return float(0.5 * (b - a) * np.sum(w * f(xs)))


def ladder_lift_off(theta0: float, length: float = 1.0, g: float = 9.81):
    """``(t*, θ*)``: the lift-off from the wall, sin θ* = ⅔ sin θ₀, at ``t* = ∫_θ*^θ₀ dθ / θ̇`` with
    ``θ̇² = (3g/L)(sin θ₀ − sin θ)``, written in ``u = √(θ₀ − θ)`` so that the integrand is smooth (Gauss–Legendre)."""
    ths = math.asin(2.0 / 3.0 * math.sin(theta0))
    return _gauss(_ladder_rate(theta0, length, g), 0.0, math.sqrt(theta0 - ths)), ths


def _ladder_rate(theta0: float, length: float, g: float):
    """``dt/du`` along the held ladder, ``u = √(θ₀ − θ)``: ``2u / √(k (sin θ₀ − sin θ))``, the difference of sines
    written ``2 cos(θ₀ − u²/2) sin(u²/2)`` (no cancellation near the start; its limit ``2/√(k cos θ₀)`` at u = 0)."""
    k = 3.0 * g / length

    def f(u):
        u = np.asarray(u, float)
        half = 0.5 * u * u
        d = 2.0 * k * np.cos(theta0 - half) * np.sin(half)
        small = u < 1e-150
        return np.where(small, 2.0 / math.sqrt(k * math.cos(theta0)), 2.0 * u / np.sqrt(np.where(small, 1.0, d)))
    return f


def ladder_angle(t, theta0: float, length: float = 1.0, g: float = 9.81) -> np.ndarray:
    """θ(t) while both ends touch (t ≤ t*): the inverse of ``t(θ) = ∫_θ^θ₀ dθ'/θ̇``, by Newton on the quadrature."""
    f = _ladder_rate(theta0, length, g)
    out = []
    for tt in np.atleast_1d(np.asarray(t, float)):
        if tt <= 0.0:
            out.append(theta0)
            continue
        # (near the start θ ≈ θ₀ − (3g cos θ₀ / 4L) t²)
        u = math.sqrt(max(0.75 * g * math.cos(theta0) / length * tt * tt, 1e-300))
        for _ in range(60):
            r = _gauss(f, 0.0, u) - tt
            du = r / float(f(np.array([u]))[0])
            u -= du
            if abs(du) <= 1e-16 * max(u, 1e-300):
                break
        out.append(theta0 - u * u)
    return np.array(out)


def disk_in_bowl(mass: float = 1.0, radius: float = 0.2, bowl: float = 1.0, g: float = 9.81,
                 mu: float = 1.0) -> LagrangianSystem:
    """The disk inside the bowl, its contact ``bowl`` with Coulomb friction ``mu`` along the contact point's slip."""
    q = ca.SX.sym("q", 3)
    v = velocity(q)
    c = q[:2]
    dist = ca.norm_2(c)
    tangent = ca.vertcat(-c[1], c[0]) / dist
    rim = [c + radius * ca.vertcat(ca.cos(q[2] + a), ca.sin(q[2] + a)) for a in (0.0, math.pi / 2, math.pi, 1.5 * math.pi)]
    return LagrangianSystem(q, MassMatrix(ca.diag(ca.vertcat(mass, mass, 0.5 * mass * radius * radius))),
                            [Potential(mass * g * q[1], "gravity")], names=["x", "y", "theta"], points_expr=rim,
                            contact=Contact([(bowl - radius) - dist], restitution=0.0, friction=mu,
                                            slip=[ca.dot(tangent, v[:2]) + radius * v[2]], names=["bowl"]))


def disk_start(phi0: float, radius: float = 0.2, bowl: float = 1.0):
    """``(q0, q̇0)``: the disk at rest on the bowl at the angle φ₀ from the bottom."""
    return [(bowl - radius) * math.sin(phi0), -(bowl - radius) * math.cos(phi0), 0.0], [0.0, 0.0, 0.0]


def disk_rolls(phi0: float, mu: float) -> bool:
    """Rolling from rest at φ₀ needs the friction ``|F|/N = tan φ / 3`` (largest at φ₀) within the cone."""
    return math.tan(abs(phi0)) / 3.0 <= mu
