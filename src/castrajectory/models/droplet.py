"""A two-dimensional droplet on a table (Exercise 2.1): the model and its analytic oracle.

A drop of cross-sectional area ``A`` sits on the table ``y = 0`` and touches it
on ``0 <= x <= a``.  Up to the constant ``gamma_sg * L`` its energy is

    E = gamma_gl * S + (gamma_sl - gamma_sg) * a,          S = length of the free surface,

minimised subject to ``∫ y dx = A``.  The Euler–Lagrange equation makes the free
surface a circular arc of curvature ``lambda / gamma_gl`` (``lambda`` the area
multiplier, the Laplace pressure); with ``a`` free, the contact angle obeys
Young's equation ``gamma_gl cos(theta) + gamma_sl - gamma_sg = 0``.  The
derivation is in ``docs/derivations.md``.

:class:`Droplet` holds the scene's parameters (checked once, when it is made);
:func:`analytic` is the oracle (a :class:`CircularCap`); :func:`reduced_energy` is the
energy as a function of the contact angle alone.  The discretisations are
:mod:`castrajectory.discretise.droplet`, the solves :mod:`castrajectory.solve.droplet`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, Optional

import casadi as ca
import numpy as np

from ..validation import InputError, finite, positive


# ---------------------------------------------------------------------------- describe
@dataclass(frozen=True)
class Droplet:
    """The scene: tensions, area and (optionally) a pinned span ``a``.

    Free span (``span=None``) requires partial wetting,
    ``|gamma_sg - gamma_sl| < gamma_gl``; see :meth:`validate`.
    """

    gamma_gl: float = 1.0
    gamma_sl: float = 0.5
    gamma_sg: float = 1.0
    area: float = 1.0
    span: Optional[float] = None

    def __post_init__(self):
        self.validate()

    @property
    def wetting(self) -> float:
        """Coefficient of the span in the energy: ``gamma_sl - gamma_sg``."""
        return self.gamma_sl - self.gamma_sg

    @property
    def spreading_coefficient(self) -> float:
        """``S = gamma_sg - gamma_sl - gamma_gl``; ``S >= 0`` means complete wetting."""
        return self.gamma_sg - self.gamma_sl - self.gamma_gl

    @property
    def length_scale(self) -> float:
        return math.sqrt(self.area)

    def validate(self) -> None:
        positive("gamma_gl", self.gamma_gl)
        finite("gamma_sl", self.gamma_sl)
        finite("gamma_sg", self.gamma_sg)
        positive("area", self.area)
        if self.span is not None:
            positive("span", self.span)
            return
        if self.spreading_coefficient >= 0.0:
            raise InputError(
                f"complete wetting: the spreading coefficient S = gamma_sg - gamma_sl - gamma_gl = "
                f"{self.spreading_coefficient:g} >= 0, so the drop spreads without bound and no minimiser exists")
        if self.wetting >= self.gamma_gl:
            raise InputError(
                f"complete non-wetting: gamma_sl - gamma_sg = {self.wetting:g} >= gamma_gl = {self.gamma_gl:g} "
                "gives Young's angle pi, where the drop touches the table at a single point")


def young_angle(gamma_gl: float, gamma_sl: float, gamma_sg: float) -> float:
    """Young's contact angle ``arccos((gamma_sg - gamma_sl) / gamma_gl)``."""
    return math.acos((gamma_sg - gamma_sl) / gamma_gl)


def segment_area_factor(theta):
    """``theta - sin(2 theta)/2``: area of a circular cap of half-angle theta divided by R²."""
    return theta - 0.5 * np.sin(2.0 * theta) if not isinstance(theta, (ca.SX, ca.MX)) \
        else theta - 0.5 * ca.sin(2.0 * theta)


def _angle_from_aspect(area_over_span2: float) -> float:
    """Solve ``(t - sin(2t)/2) / (4 sin² t) = A / a²`` for ``t`` in (0, pi) by bisection (monotone)."""
    lo, hi = 1e-12, math.pi - 1e-12
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if segment_area_factor(mid) / (4.0 * math.sin(mid) ** 2) < area_over_span2:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


@dataclass(frozen=True)
class CircularCap:
    """A circular cap standing on ``y = 0`` with its left contact point at the origin."""

    contact_angle: float
    radius: float
    gamma_gl: float
    wetting: float

    @property
    def span(self) -> float:
        return 2.0 * self.radius * math.sin(self.contact_angle)

    @property
    def area(self) -> float:
        return self.radius ** 2 * segment_area_factor(self.contact_angle)

    @property
    def length(self) -> float:
        return 2.0 * self.radius * self.contact_angle

    @property
    def pressure(self) -> float:
        """Laplace pressure ``gamma_gl / R``."""
        return self.gamma_gl / self.radius

    @property
    def energy(self) -> float:
        """``gamma_gl S + (gamma_sl - gamma_sg) a`` (equals ``2 gamma_gl A / R`` at Young's angle)."""
        return self.gamma_gl * self.length + self.wetting * self.span

    @property
    def center(self) -> tuple:
        return (0.5 * self.span, -self.radius * math.cos(self.contact_angle))

    def points(self, n: int) -> np.ndarray:
        """``n + 1`` points equally spaced in arc length, from (0, 0) to (a, 0)."""
        return arc_points(self.contact_angle, self.radius, n)

    def distance(self, x, y) -> np.ndarray:
        """Signed distance of points from the circle (positive outside)."""
        cx, cy = self.center
        return np.hypot(np.asarray(x) - cx, np.asarray(y) - cy) - self.radius

    def as_dict(self) -> Dict[str, float]:
        return {"contact_angle": self.contact_angle, "span": self.span, "radius": self.radius,
                "pressure": self.pressure, "energy": self.energy}


def arc_points(theta: float, radius: float, n: int) -> np.ndarray:
    """Vertices of a circular cap of half-angle ``theta``: ``(n + 1) x 2``, left contact at the origin."""
    alpha = 0.5 * math.pi + theta - 2.0 * theta * np.arange(n + 1) / n
    cx, cy = radius * math.sin(theta), -radius * math.cos(theta)
    pts = np.column_stack([cx + radius * np.cos(alpha), cy + radius * np.sin(alpha)])
    pts[0] = (0.0, 0.0)
    pts[-1] = (2.0 * cx, 0.0)
    return pts


def analytic(drop: Droplet) -> CircularCap:
    """The exact minimiser: Young's angle for a free span, the arc through (0,0),(a,0) for a fixed one."""
    if drop.span is None:
        theta = young_angle(drop.gamma_gl, drop.gamma_sl, drop.gamma_sg)
        radius = math.sqrt(drop.area / segment_area_factor(theta))
    else:
        theta = _angle_from_aspect(drop.area / drop.span ** 2)
        radius = drop.span / (2.0 * math.sin(theta))
    return CircularCap(theta, radius, drop.gamma_gl, drop.wetting)



def reduced_energy(drop: Droplet):
    """``E(theta)`` as a CasADi function: ``R = sqrt(A / (theta - sin(2 theta)/2))``, ``a = 2 R sin theta``,
    ``S = 2 R theta``, ``E = gamma_gl S + (gamma_sl - gamma_sg) a``."""
    th = ca.SX.sym("theta")
    R = ca.sqrt(drop.area / segment_area_factor(th))
    E = drop.gamma_gl * 2.0 * R * th + drop.wetting * 2.0 * R * ca.sin(th)
    return ca.Function("E", [th], [E], ["theta"], ["E"]), ca.Function("R", [th], [R])
