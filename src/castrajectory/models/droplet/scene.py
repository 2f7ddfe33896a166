"""The drop's scene (:class:`Droplet`, checked once) and the weightless cap, its oracle; the other oracles are
:mod:`.heavy`, :mod:`.revolution` and :mod:`.pattern`, and :func:`castrajectory.models.droplet.analytic` picks one."""
from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from typing import Dict, Optional

import casadi as ca
import numpy as np

from ...validation import InputError, finite, positive


# ---------------------------------------------------------------------------- describe
@dataclass(frozen=True)
class Droplet:
    """The scene: tensions, area, (optionally) a pinned span ``a``, and gravity.

    Free span (``span=None``) requires partial wetting,
    ``|gamma_sg - gamma_sl| < gamma_gl``; see :meth:`validate`.  ``rho_g`` is the weight density
    (``rho g``; 0: the weightless drop of Exercise 2.1); ``pendant`` reverses gravity: the drop hangs
    under a ceiling (``y`` is then measured downwards from the ceiling).
    """

    gamma_gl: float = 1.0
    gamma_sl: float = 0.5
    gamma_sg: float = 1.0
    area: float = 1.0
    span: Optional[float] = None
    rho_g: float = 0.0
    pendant: bool = False
    #: a drop of revolution about the vertical axis: ``area`` is then its volume, ``span`` its contact radius
    axisymmetric: bool = False
    #: a patterned table: ``gamma_sl`` holds on the pattern, a strip ``|x| < pattern_width / 2`` centred under
    #: the drop (a disc of diameter ``pattern_width`` for a drop of revolution), ``gamma_sl_out`` outside it
    pattern_width: Optional[float] = None
    gamma_sl_out: Optional[float] = None

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
        """The unit of the scaled program: ``sqrt(A)``, or ``V^(1/3)`` for a drop of revolution."""
        return self.area ** (1.0 / 3.0) if self.axisymmetric else math.sqrt(self.area)

    @property
    def measure(self) -> str:
        """What ``area`` measures: ``"area"`` (2-D) or ``"volume"`` (a drop of revolution)."""
        return "volume" if self.axisymmetric else "area"

    def area_for_bond(self, bond: float) -> float:
        """The area (2-D) or volume (3-D) whose Bond number is ``bond`` (inverse of :attr:`bond_number`)."""
        scaled = bond * self.gamma_gl / self.rho_g
        return scaled ** 1.5 if self.axisymmetric else scaled

    @property
    def capillary_length(self) -> float:
        """``l_c = sqrt(gamma_gl / rho_g)`` (infinite without gravity)."""
        return math.sqrt(self.gamma_gl / self.rho_g) if self.rho_g > 0.0 else math.inf

    @property
    def bond_number(self) -> float:
        """``Bo = rho_g A / gamma_gl = (sqrt(A) / l_c)²``: the weight of the scaled problem (0 without gravity);
        for a drop of revolution ``rho_g V^(2/3) / gamma_gl = (V^(1/3) / l_c)²``."""
        if self.axisymmetric:
            return self.rho_g * self.length_scale ** 2 / self.gamma_gl
        return self.rho_g * self.area / self.gamma_gl

    @property
    def gravity_sign(self) -> int:
        """+1 for a sessile drop (gravity towards the wall), -1 for a pendant one (away from it)."""
        return -1 if self.pendant else 1

    @property
    def patterned(self) -> bool:
        """A table whose ``gamma_sl`` steps at the pattern's edge (:class:`PatternedCap`)."""
        return self.pattern_width is not None

    @property
    def wetting_out(self) -> float:
        """Coefficient of the wetted measure outside the pattern: ``gamma_sl_out - gamma_sg``."""
        return self.gamma_sl_out - self.gamma_sg

    def validate(self) -> None:
        positive("gamma_gl", self.gamma_gl)
        finite("gamma_sl", self.gamma_sl)
        finite("gamma_sg", self.gamma_sg)
        positive("area", self.area)
        if finite("rho_g", self.rho_g) < 0.0:
            raise InputError(f"rho_g (the weight density rho g, --gravity) must be >= 0 (got {self.rho_g})")
        if self.pendant and self.rho_g == 0.0:
            raise InputError("a pendant drop needs gravity (rho_g > 0): without it a drop under a ceiling is "
                             "the weightless drop")
        if (self.pattern_width is None) != (self.gamma_sl_out is None):
            raise InputError("a pattern needs both its width and the outside's gamma_sl (--pattern W GAMMA_SL_OUT)")
        if self.patterned:
            self._validate_pattern()
        if self.axisymmetric and self.span is not None:
            raise InputError("a pinned contact radius of a drop of revolution has no oracle yet; leave the span free")
        if self.rho_g > 0.0 and self.span is not None:
            raise InputError("a pinned span under gravity has no oracle yet; leave the span free")
        if self.span is not None:
            positive("span", self.span)
            radius = arc_on_span(self.area, self.span)[1]
            if not self.gamma_gl / radius >= sys.float_info.min:
                log_r = 3.0 * math.log10(self.span) - math.log10(12.0 * self.area)  # R = a³ / (12 A) when flat
                raise InputError(f"span {self.span:g} with area {self.area:g} is an arc of radius about 1e{log_r:.0f}, "
                                 "whose pressure gamma_gl / R is beyond double precision")
            return
        if self.spreading_coefficient >= 0.0:
            raise InputError(
                f"complete wetting: the spreading coefficient S = gamma_sg - gamma_sl - gamma_gl = "
                f"{self.spreading_coefficient:g} >= 0, so the drop spreads without bound and no minimiser exists")
        if self.wetting >= self.gamma_gl:
            raise InputError(
                f"complete non-wetting: gamma_sl - gamma_sg = {self.wetting:g} >= gamma_gl = {self.gamma_gl:g} "
                "gives Young's angle pi, where the drop touches the table at a single point")

    def _validate_pattern(self) -> None:
        positive("pattern width", self.pattern_width)
        finite("gamma_sl_out (the pattern's outside)", self.gamma_sl_out)
        if self.span is not None:
            raise InputError("a pattern and a pinned span exclude each other: the pattern decides where the edge "
                             "pins; leave the span free")
        if self.rho_g > 0.0:
            raise InputError("a patterned table under gravity has no oracle yet; use a weightless drop (--gravity 0)")
        if self.gamma_sl_out == self.gamma_sl:
            raise InputError(f"the pattern's gamma_sl_out = {self.gamma_sl_out:g} equals gamma_sl: both Young angles "
                             "are equal and the table has no pattern")
        if self.gamma_sl_out < self.gamma_sl:
            raise InputError(f"the pattern must be the more wettable part: gamma_sl_out = {self.gamma_sl_out:g} must "
                             f"exceed gamma_sl = {self.gamma_sl:g} (a more wettable outside does not pin the edge: "
                             "the step is then an energy maximum for it)")


def young_angle(gamma_gl: float, gamma_sl: float, gamma_sg: float) -> float:
    """Young's contact angle ``arccos((gamma_sg - gamma_sl) / gamma_gl)``."""
    return math.acos((gamma_sg - gamma_sl) / gamma_gl)


def segment_area_factor(theta):
    """``theta - sin(2 theta)/2``: area of a circular cap of half-angle theta divided by R².

    For a float or an array it is evaluated without cancellation: below ``2 theta = 1`` as the series of
    ``(u - sin u) / 2`` in ``u = 2 theta`` (``2 theta³ / 3`` for a flat cap, where the difference of the two
    terms kept no digit: at theta = 6e-12 it read 0 for 1.44e-34)."""
    if isinstance(theta, (ca.SX, ca.MX)):
        return theta - 0.5 * ca.sin(2.0 * theta)
    t = np.asarray(theta, dtype=float)
    u = 2.0 * t
    small = np.abs(u) < 1.0
    us = np.where(small, u, 0.0)
    term = us ** 3 / 6.0
    series = term.copy()
    for k in range(1, 12):  # u - sin u = u³/3! - u⁵/5! + ...: 12 terms reach rounding for |u| < 1
        term = -term * us ** 2 / ((2 * k + 2) * (2 * k + 3))
        series = series + term
    out = np.where(small, 0.5 * series, t - 0.5 * np.sin(u))
    return float(out) if out.ndim == 0 else out


def _aspect(t: float) -> float:
    """``A / a²`` of a cap of half-angle ``t`` in (0, pi/2]: ``(t - sin t cos t) / (4 sin² t)``."""
    return segment_area_factor(t) / (4.0 * math.sin(t) ** 2)


def _aspect_beyond(s: float) -> float:
    """``A / a²`` of a cap of half-angle ``pi - s``, ``s`` in (0, pi/2]: no cancellation near a full circle."""
    return (math.pi - s + math.sin(s) * math.cos(s)) / (4.0 * math.sin(s) ** 2)


def _bisect(f, lo: float, hi: float, target: float, increasing: bool) -> float:
    """The root of the monotone ``f(x) = target`` in ``[lo, hi]``, to the last bit."""
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        if (f(mid) < target) == increasing:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def arc_on_span(area: float, span: float) -> tuple:
    """``(theta, R)``: the half-angle and radius of the circular cap of area ``A`` on the span ``a``, the root of
    ``(t - sin(2t)/2) / (4 sin² t) = A / a²`` on (0, pi), which is monotone, and ``R = a / (2 sin t)``.

    It is solved without cancellation at both ends, so that a flat cap (a huge span) and a nearly round one
    (a tiny span) keep their digits:

    * below a semicircle (``A / a² <= pi/8``) on t, whose root lies in ``[4, 6] A / a²`` (``A/a² / t`` runs from
      1/6 at t -> 0 to 1/4 at pi/2), and is ``6 A / a²`` to rounding below ``A / a² = 1e-9`` (the next term is
      ``2 t² / 15``);
    * beyond it on ``s = pi - t``, whose root lies in ``[0.78, 0.97]^(1/2) / sqrt(A / a²)`` (``A/a² s²`` runs
      from pi/4 to 0.969), and ``sin theta`` is ``sin s`` (``pi - t`` rounded keeps no digit of a small ``s``);
      above ``A / a² = 1e18`` the cap is a full circle, ``R = sqrt(A / pi)``, to rounding.

    ``A / a²`` is formed as two quotients (``a ** 2`` overflows beyond 1e154).  ``R`` is ``inf`` where it is
    beyond double precision (:meth:`Droplet.validate` refuses that span)."""
    r = area / span / span
    if r <= math.pi / 8.0:
        if r < 1e-9:
            t = 6.0 * (area / span) / span
        else:
            t = _bisect(_aspect, 3.9 * r, min(6.1 * r, 0.5 * math.pi), r, increasing=True)
        sin_t = math.sin(t)
    else:
        if r > 1e18:  # a full circle: R = sqrt(A / pi), whatever s underflows to
            return math.pi - 0.5 * span * math.sqrt(math.pi / area), math.sqrt(area / math.pi)
        s = _bisect(_aspect_beyond, min(math.sqrt(0.78 / r), 0.5 * math.pi),
                    min(math.sqrt(0.97 / r), 0.5 * math.pi), r, increasing=False)
        t, sin_t = math.pi - s, math.sin(s)
    return t, (0.5 * span / sin_t if sin_t > 0.0 else math.inf)


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





def reduced_energy(drop: Droplet):
    """``E(theta)`` as a CasADi function: ``R = sqrt(A / (theta - sin(2 theta)/2))``, ``a = 2 R sin theta``,
    ``S = 2 R theta``, ``E = gamma_gl S + (gamma_sl - gamma_sg) a``."""
    th = ca.SX.sym("theta")
    R = ca.sqrt(drop.area / segment_area_factor(th))
    E = drop.gamma_gl * 2.0 * R * th + drop.wetting * 2.0 * R * ca.sin(th)
    return ca.Function("E", [th], [E], ["theta"], ["E"]), ca.Function("R", [th], [R])

def distance_to_reference(x, y, ref: np.ndarray) -> np.ndarray:
    """Distance of the vertices ``(x, y)`` (in order along the profile) from the nearest chord of the finely
    sampled reference polyline ``ref`` (``(m + 1) x 2``, in the same order), searched in a window around
    the vertex's fraction of the arclength."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    n, m = x.size - 1, ref.shape[0] - 1
    d = np.diff(ref, axis=0)
    seg2 = np.maximum(np.sum(d * d, axis=1), 1e-300)
    frac = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))])
    frac = frac / frac[-1]
    window = 4 * (m // max(n, 1)) + 16
    centre = np.clip(np.round(frac * m).astype(int), 0, m - 1)
    k = np.clip(centre[:, None] + np.arange(-window, window + 1)[None, :], 0, m - 1)
    px, py = x[:, None] - ref[k, 0], y[:, None] - ref[k, 1]
    tt = np.clip((px * d[k, 0] + py * d[k, 1]) / seg2[k], 0.0, 1.0)
    return np.min(np.hypot(px - tt * d[k, 0], py - tt * d[k, 1]), axis=1)
