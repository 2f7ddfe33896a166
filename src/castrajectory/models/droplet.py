"""A two-dimensional droplet on a table (Exercise 2.1): the model and its analytic oracle.

A drop of cross-sectional area ``A`` sits on the table ``y = 0`` and touches it
on ``0 <= x <= a``.  Up to the constant ``gamma_sg * L`` its energy is

    E = gamma_gl * S + (gamma_sl - gamma_sg) * a,          S = length of the free surface,

minimised subject to ``∫ y dx = A``.  The Euler–Lagrange equation makes the free
surface a circular arc of curvature ``lambda / gamma_gl`` (``lambda`` the area
multiplier, the Laplace pressure); with ``a`` free, the contact angle obeys
Young's equation ``gamma_gl cos(theta) + gamma_sl - gamma_sg = 0``.  The
derivation is in ``docs/derivations.md``.

A heavy drop (``rho_g > 0``) adds ``rho_g ∫∫ y dA`` (sessile: the drop stands on the table) or
``-rho_g ∫∫ y dA`` (``pendant``: it hangs under a ceiling; ``y`` is always measured from the wall into
the liquid).  The area multiplier is then the pressure at the wall, and the oracle is the closed form
in incomplete elliptic integrals (:class:`HeavyDrop`, :func:`heavy_drop`; the pendant family's fold,
:func:`pendant_fold`).

:class:`Droplet` holds the scene's parameters (checked once, when it is made);
:func:`analytic` is the oracle (a :class:`CircularCap`, or a :class:`HeavyDrop` under gravity);
:func:`reduced_energy` is the weightless energy as a function of the contact angle alone.  The
discretisations are :mod:`castrajectory.discretise.droplet`, the solves :mod:`castrajectory.solve.droplet`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, Optional, Union

import casadi as ca
import numpy as np

from ..validation import InputError, finite, positive
from .elliptic import carlson_rd, carlson_rf, incomplete


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


def analytic(drop: Droplet) -> Union[CircularCap, "HeavyDrop"]:
    """The exact minimiser: Young's angle for a free span, the arc through (0,0),(a,0) for a fixed one;
    under gravity the heavy drop (:func:`heavy_drop`); a drop of revolution: the spherical cap
    (:class:`SphericalCap`), or under gravity the Young–Laplace profile (:func:`axisymmetric_drop`); on a
    patterned table the cap of Gibbs' criterion (:func:`patterned_cap`)."""
    if drop.patterned:
        return patterned_cap(drop)
    if drop.axisymmetric:
        return axisymmetric_drop(drop) if drop.rho_g > 0.0 else spherical_cap(drop)
    if drop.rho_g > 0.0:
        return heavy_drop(drop)
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


# ---------------------------------------------------------------------------- the heavy drop (gravity, 2-D)
class BeyondFold(ValueError):
    """No pendant drop of this area: the family of stable pendant drops ends at its fold (:func:`pendant_fold`)."""


@dataclass(frozen=True)
class _UnitDrop:
    """The heavy drop in units of the capillary length (``gamma = rho g = 1``); see :class:`HeavyDrop`.

    ``g`` is +1 (sessile) or -1 (pendant); ``kappa_a`` the apex curvature, ``pressure`` the pressure
    at the wall ``P = kappa_a + g h``; ``m = -4 g / kappa_a²`` the parameter of the elliptic integrals.
    A pendant drop with ``P < 0`` has a neck: its tangent angle rises past the contact angle to
    ``phi_max = 2 t_max`` (where the curvature vanishes, ``sin t_max = kappa_a / 2``) and falls back to it.
    """

    theta: float
    g: int
    kappa_a: float
    pressure: float
    height: float

    @property
    def m(self) -> float:
        return -4.0 * self.g / self.kappa_a ** 2

    @property
    def neck(self) -> bool:
        return self.g < 0 and self.pressure < 0.0

    @property
    def t_max(self) -> float:
        """Half the largest tangent angle of a necked drop (``asin(kappa_a / 2)``; needs ``kappa_a <= 2``)."""
        return math.asin(min(1.0, 0.5 * self.kappa_a))

    def _pieces(self, t):
        """Half width ``x(t)`` and half length ``s(t)`` from the apex to the tangent angle ``2t``
        (``t <= t_max`` on the rising part): ``s = 2F/κ_a``, ``x = (2/κ_a)(F − 2(F − E)/m)``."""
        F, D = incomplete(t, self.m)
        return 2.0 / self.kappa_a * (F - 2.0 * D / self.m), 2.0 * F / self.kappa_a

    def _turn(self):
        """``(x, s)`` at the turn of a necked drop, ``t = t_max``: there ``1 − m sin²t = 0`` exactly (computed as
        ``1 − m sin²t``, its rounding would cost half the digits: the integrals have a square-root branch there)."""
        sn = 0.5 * self.kappa_a
        c2 = 1.0 - sn * sn
        F = sn * float(carlson_rf(c2, 0.0, 1.0))
        D = self.m * sn ** 3 * float(carlson_rd(c2, 0.0, 1.0)) / 3.0
        return 2.0 / self.kappa_a * (F - 2.0 * D / self.m), 2.0 * F / self.kappa_a

    def _along(self, t_end):
        """``(x, s)`` along the whole half profile to the amplitude ``t_end`` (through the neck if any)."""
        x, s = self._pieces(t_end)
        if not self.neck:
            return x, s
        xm, sm = self._turn()
        return 2.0 * xm - x, 2.0 * sm - s

    @property
    def half_span(self) -> float:
        return float(self._along(0.5 * self.theta)[0])

    @property
    def half_length(self) -> float:
        return float(self._along(0.5 * self.theta)[1])

    @property
    def area(self) -> float:
        """The vertical force balance: ``A = 2 g (X P − sin θ)`` (the weight is the pressure on the wall
        minus the pull of the two contact lines, for a sessile drop)."""
        return 2.0 * self.g * (self.half_span * self.pressure - math.sin(self.theta))

    def profile(self, u):
        """Points ``(x, z)`` of the half profile (``x`` from the axis, ``z`` down from the apex) at the path
        parameter ``u`` in ``[0, 1]`` (apex to contact); regular in arclength also through a neck."""
        u = np.asarray(u, dtype=float)
        half = 0.5 * self.theta
        pendant_turn = self.g < 0 and self.kappa_a <= 2.0
        if not pendant_turn:
            t, rising = u * half, np.ones_like(u, dtype=bool)
        else:  # t = t_max - v², v from -sqrt(t_max) (apex) to the contact: s is smooth in v at the turn
            tm = self.t_max
            v_end = math.copysign(math.sqrt(abs(tm - half)), -self.pressure)
            v = -math.sqrt(tm) + u * (v_end + math.sqrt(tm))
            t, rising = np.clip(tm - v * v, 0.0, tm), v <= 0.0
        x, _ = self._pieces(t)
        kap = np.sqrt(np.maximum(self.kappa_a ** 2 + 4.0 * self.g * np.sin(t) ** 2, 0.0))
        if not pendant_turn:
            return x, 4.0 * np.sin(t) ** 2 / (kap + self.kappa_a)
        xm = self._turn()[0]
        z = np.where(rising, 4.0 * np.sin(t) ** 2 / (kap + self.kappa_a), self.kappa_a + kap)
        return np.where(rising, x, 2.0 * xm - x), z

    def arclength(self, u):
        """Arclength from the apex at the path parameter ``u`` (see :meth:`profile`)."""
        u = np.asarray(u, dtype=float)
        half = 0.5 * self.theta
        if not (self.g < 0 and self.kappa_a <= 2.0):
            return self._pieces(u * half)[1]
        tm = self.t_max
        v_end = math.copysign(math.sqrt(abs(tm - half)), -self.pressure)
        v = -math.sqrt(tm) + u * (v_end + math.sqrt(tm))
        _, s = self._pieces(np.clip(tm - v * v, 0.0, tm))
        _, sm = self._turn()
        return np.where(v <= 0.0, s, 2.0 * sm - s)


def _unit_sessile(theta: float, kappa_a: float) -> _UnitDrop:
    s2 = math.sin(0.5 * theta) ** 2
    P = math.sqrt(kappa_a ** 2 + 4.0 * s2)
    return _UnitDrop(theta, 1, kappa_a, P, 4.0 * s2 / (P + kappa_a))


def _unit_pendant(theta: float, pressure: float) -> _UnitDrop:
    """The pendant drop whose pressure at the ceiling is ``pressure``: ``κ_a = sqrt(P² + 4 sin²(θ/2))``,
    ``h = κ_a − P``; the family runs from ``P = +∞`` (a small cap) through ``P = 0`` (the neck appears)."""
    s2 = math.sin(0.5 * theta) ** 2
    k = math.sqrt(pressure ** 2 + 4.0 * s2)
    h = 4.0 * s2 / (k + pressure) if pressure > 0.0 else k - pressure
    return _UnitDrop(theta, -1, k, pressure, h)


def _bisect(f, lo: float, hi: float) -> float:
    """The root of ``f`` between ``lo`` and ``hi`` (``f(lo)``, ``f(hi)`` of opposite signs), to rounding."""
    flo = f(lo)
    for _ in range(400):
        mid = 0.5 * (lo + hi)
        if mid in (lo, hi):
            break
        fm = f(mid)
        if (fm > 0.0) == (flo > 0.0):
            lo, flo = mid, fm
        else:
            hi = mid
    return 0.5 * (lo + hi)


#: The smallest apex curvature (log, units 1/l_c) of the closed form: ``m = −4/κ_a²`` and Carlson's
#: duplications must stay finite (about 650 l_c² of a puddle at 90°).
_LOG_KAPPA_MIN = math.log(1e-100)


def _sessile_for_area(theta: float, area: float) -> _UnitDrop:
    """The sessile drop of unit area ``area``: its area falls from ∞ to 0 as κ_a rises; bisection in ``log κ_a``."""
    f = lambda lk: _unit_sessile(theta, math.exp(lk)).area - area  # noqa: E731
    lo = hi = 0.0
    while f(lo) <= 0.0:
        lo -= 2.0
        if lo < _LOG_KAPPA_MIN:
            raise ValueError(f"a puddle of area {area:.6g} l_c²: its apex curvature is below 1e-100 / l_c, "
                             "beyond the range of this closed form in double precision")
    while f(hi) >= 0.0:
        hi += 2.0
    return _unit_sessile(theta, math.exp(_bisect(f, lo, hi)))


#: Golden-section steps of :func:`_unit_fold` (the interval shrinks to rounding long before).
_GOLDEN_STEPS = 200


def _unit_fold(theta: float) -> _UnitDrop:
    """The pendant drop of largest area (the fold): ``max_P A(P)`` over the necked and unnecked family,
    ``P`` from ``−2 cos(θ/2)`` (``κ_a = 2``: beyond it the profile curls over itself) up; a scan, then
    golden-section search."""
    lo_p = -2.0 * math.cos(0.5 * theta)
    grid = np.linspace(lo_p, 4.0, 241)
    areas = [_unit_pendant(theta, p).area for p in grid]
    j = int(np.nanargmax(areas))
    a, b = grid[max(j - 1, 0)], grid[min(j + 1, len(grid) - 1)]
    r = 0.5 * (math.sqrt(5.0) - 1.0)
    c, d = b - r * (b - a), a + r * (b - a)
    fc, fd = _unit_pendant(theta, c).area, _unit_pendant(theta, d).area
    for _ in range(_GOLDEN_STEPS):
        if fc > fd:
            b, d, fd = d, c, fc
            c = b - r * (b - a)
            fc = _unit_pendant(theta, c).area
        else:
            a, c, fc = c, d, fd
            d = a + r * (b - a)
            fd = _unit_pendant(theta, d).area
        if b - a <= 4e-16 * max(1.0, abs(a)):
            break
    fold = _unit_pendant(theta, 0.5 * (a + b))
    width = fold.profile(np.linspace(0.0, 1.0, 401))[0]
    # below the widest point the profile must stay clear of the axis: the neck and the contact span open
    if j == 0 or np.min(width[np.argmax(width):]) <= 0.0:
        raise ValueError(f"the pendant family at theta = {math.degrees(theta):.4g} degrees pinches off (its neck "
                         "or its contact span closes) before it folds; its closed form here does not cover it")
    return fold


def _pendant_for_area(theta: float, area: float, fold: _UnitDrop) -> _UnitDrop:
    """The stable pendant drop of unit area ``area``: between the fold and ``P = ∞`` the area falls
    monotonically with ``P``; bisection in ``P``."""
    f = lambda p: _unit_pendant(theta, p).area - area  # noqa: E731
    hi = fold.pressure + 1.0
    while f(hi) >= 0.0:
        hi = fold.pressure + 2.0 * (hi - fold.pressure)
    return _unit_pendant(theta, _bisect(f, fold.pressure, hi))


@dataclass(frozen=True)
class HeavyDrop:
    """The 2-D drop under gravity, in closed form (``docs/derivations.md``, Droplet §9).

    In units of the capillary length ``l_c = sqrt(gamma / rho g)``, with ``g = +1`` sessile and ``-1``
    pendant, ``m = -4 g / kappa_a²``, ``F = F(theta/2 | m)``, ``E = E(theta/2 | m)``:

    * height ``h = g (P − κ_a)`` with the pressure at the wall ``P = κ_a + g h``;
    * half span ``X = 2F/κ_a + g κ_a (F − E)`` (a necked pendant drop: through the neck, §9);
    * area ``A = 2 g (X P − sin θ)``; energy ``(2/3)(γ S + (γ_sl − γ_sg) a + P A)``.

    Lengths here are physical (times ``l_c``); ``unit`` holds the dimensionless drop.  The drop stands
    with its left contact at the origin, ``y`` measured from the wall into the liquid.
    """

    unit: _UnitDrop
    gamma_gl: float
    rho_g: float
    wetting: float

    @property
    def pendant(self) -> bool:
        return self.unit.g < 0

    @property
    def capillary_length(self) -> float:
        return math.sqrt(self.gamma_gl / self.rho_g)

    @property
    def contact_angle(self) -> float:
        return self.unit.theta

    @property
    def apex_curvature(self) -> float:
        return self.unit.kappa_a / self.capillary_length

    @property
    def height(self) -> float:
        return self.unit.height * self.capillary_length

    @property
    def span(self) -> float:
        return 2.0 * self.unit.half_span * self.capillary_length

    @property
    def area(self) -> float:
        return self.unit.area * self.capillary_length ** 2

    @property
    def length(self) -> float:
        return 2.0 * self.unit.half_length * self.capillary_length

    @property
    def pressure(self) -> float:
        """The area multiplier ``dE*/dA``: the pressure at the wall, ``gamma κ_a + g rho_g h``."""
        return self.unit.pressure * self.gamma_gl / self.capillary_length

    @property
    def pressure_at_table(self) -> float:
        return self.pressure

    @property
    def energy(self) -> float:
        """``gamma S + (gamma_sl − gamma_sg) a + g rho_g ∫∫ y dA``, by the dilation identity
        ``gamma S + w a + 3 g rho_g M = 2 P A`` (§9): ``(2/3)(gamma S + w a + P A)``."""
        return 2.0 / 3.0 * (self.gamma_gl * self.length + self.wetting * self.span + self.pressure * self.area)

    @property
    def moment(self) -> float:
        """``∫∫ y dA`` (the first moment of the liquid about the wall)."""
        return self.unit.g * (2.0 * self.pressure * self.area - self.gamma_gl * self.length
                              - self.wetting * self.span) / (3.0 * self.rho_g)

    def points(self, n: int) -> np.ndarray:
        """``n + 1`` points of the profile from (0, 0) to (a, 0), equally spaced in arclength (to the
        interpolation of a table of ``s(u)``; every point lies on the profile exactly)."""
        unit, lc = self.unit, self.capillary_length
        u = np.linspace(0.0, 1.0, max(64, 4 * n) + 1)
        for _ in range(3):  # a table of u against s, nearly uniform in s
            s = unit.arclength(u)
            u = np.interp(np.linspace(0.0, s[-1], u.size), s, u)
        s = unit.arclength(u)
        sv = np.linspace(-s[-1], s[-1], n + 1)  # arclength from the apex, left contact first
        xh, z = unit.profile(np.interp(np.abs(sv), s, u))
        pts = lc * np.column_stack([unit.half_span + np.sign(sv) * xh, unit.height - z])
        pts[0], pts[-1] = (0.0, 0.0), (2.0 * unit.half_span * lc, 0.0)
        return pts

    def distance(self, x, y) -> np.ndarray:
        """Distance of the vertices ``(x, y)`` of a drop (in order, contact to contact) from the profile:
        to the nearest chord of the profile sampled at ``max(20000, 128 N)`` points (a chord's sagitta,
        ``κ Δs²/8``, is far below any discretisation error measured here)."""
        x, y = np.asarray(x, float), np.asarray(y, float)
        n = x.size - 1
        m = max(20000, 128 * n)
        return distance_to_reference(x, y, self.points(m))

    def as_dict(self) -> Dict[str, float]:
        return {"contact_angle": self.contact_angle, "span": self.span, "height": self.height,
                "apex_curvature": self.apex_curvature, "pressure": self.pressure,
                "pressure_at_table": self.pressure_at_table, "energy": self.energy, "area": self.area,
                "capillary_length": self.capillary_length}


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


def _heavy(drop: Droplet, unit: _UnitDrop) -> HeavyDrop:
    return HeavyDrop(unit, drop.gamma_gl, drop.rho_g, drop.wetting)


def heavy_drop(drop: Droplet) -> HeavyDrop:
    """The closed-form drop under gravity (free span, Young's angle): the apex curvature (sessile) or the
    pressure at the ceiling (pendant) solved from the area by bisection, to rounding.  A pendant drop
    beyond the fold raises :class:`BeyondFold`."""
    theta = young_angle(drop.gamma_gl, drop.gamma_sl, drop.gamma_sg)
    area = drop.area / drop.capillary_length ** 2
    if not drop.pendant:
        return _heavy(drop, _sessile_for_area(theta, area))
    fold = _unit_fold(theta)
    if area > fold.area:
        raise BeyondFold(f"no pendant drop of area {drop.area:g}: the family folds at A* = "
                         f"{fold.area * drop.capillary_length ** 2:.7g} (θ = {math.degrees(theta):.6g}°)")
    return _heavy(drop, _pendant_for_area(theta, area, fold))


def pendant_fold(drop: Droplet) -> HeavyDrop:
    """The largest pendant drop (the fold of the family) for the drop's tensions and gravity (its area is ignored)."""
    return _heavy(drop, _unit_fold(young_angle(drop.gamma_gl, drop.gamma_sl, drop.gamma_sg)))


def puddle_height(drop: Droplet) -> float:
    """The limit of a sessile drop's height as its area grows: ``2 l_c sin(θ/2)``."""
    return 2.0 * drop.capillary_length * math.sin(0.5 * young_angle(drop.gamma_gl, drop.gamma_sl, drop.gamma_sg))


# ---------------------------------------------------------------------------- drops of revolution (3-D)
@dataclass(frozen=True)
class SphericalCap:
    """The weightless drop of revolution: a spherical cap of radius ``R`` standing on the table with
    Young's angle; its half profile runs from the apex ``(0, h)`` on the axis to the contact ``(r_c, 0)``.
    ``area`` is the volume (the constrained measure, as :attr:`Droplet.area` of a drop of revolution)."""

    contact_angle: float
    radius: float
    gamma_gl: float
    wetting: float

    @property
    def volume(self) -> float:
        c = math.cos(self.contact_angle)
        return math.pi * self.radius ** 3 * (2.0 - 3.0 * c + c ** 3) / 3.0

    area = volume

    @property
    def span(self) -> float:
        """The contact diameter ``2 r_c`` (what a side view shows; the 2-D drop's span)."""
        return 2.0 * self.contact_radius

    @property
    def contact_radius(self) -> float:
        return self.radius * math.sin(self.contact_angle)

    @property
    def height(self) -> float:
        return self.radius * (1.0 - math.cos(self.contact_angle))

    @property
    def apex_curvature(self) -> float:
        return 1.0 / self.radius

    @property
    def pressure(self) -> float:
        """The Laplace pressure ``2 gamma_gl / R``: the volume multiplier ``dE*/dV``."""
        return 2.0 * self.gamma_gl / self.radius

    pressure_at_table = pressure

    @property
    def surface_area(self) -> float:
        return 2.0 * math.pi * self.radius ** 2 * (1.0 - math.cos(self.contact_angle))

    @property
    def energy(self) -> float:
        """``gamma_gl S + (gamma_sl − gamma_sg) pi r_c²``."""
        return self.gamma_gl * self.surface_area + self.wetting * math.pi * self.contact_radius ** 2

    @property
    def capillary_length(self) -> float:
        return math.inf

    def points(self, n: int) -> np.ndarray:
        """``n + 1`` points ``(r, z)`` of the half profile, equally spaced in arclength from the apex."""
        a = self.contact_angle * np.arange(n + 1) / n
        pts = np.column_stack([self.radius * np.sin(a), self.height - self.radius * (1.0 - np.cos(a))])
        pts[-1] = (self.contact_radius, 0.0)
        return pts

    def distance(self, r, z) -> np.ndarray:
        return np.abs(np.hypot(np.asarray(r), np.asarray(z) - (self.height - self.radius)) - self.radius)

    def as_dict(self) -> Dict[str, float]:
        return {"contact_angle": self.contact_angle, "contact_radius": self.contact_radius, "height": self.height,
                "radius": self.radius, "apex_curvature": self.apex_curvature, "pressure": self.pressure,
                "pressure_at_table": self.pressure, "volume": self.volume, "energy": self.energy}


def cap_volume_factor(theta: float) -> float:
    """``V / R³`` of a spherical cap of contact angle ``theta``: ``pi (2 − 3 cos θ + cos³ θ) / 3``."""
    c = math.cos(theta)
    return math.pi * (2.0 - 3.0 * c + c ** 3) / 3.0


def spherical_cap(drop: Droplet) -> SphericalCap:
    theta = young_angle(drop.gamma_gl, drop.gamma_sl, drop.gamma_sg)
    return SphericalCap(theta, (drop.area / cap_volume_factor(theta)) ** (1.0 / 3.0), drop.gamma_gl, drop.wetting)


#: Steps of the Young–Laplace shooting per unit arclength, the unit being the smaller of the apex radius
#: and the capillary length (classical RK4; at 512 the profile agrees with scipy's DOP853 at rtol 1e-12 to
#: about 1e-12 of its size, see tests/test_droplet_axisymmetric.py).
YL_STEPS = 512
#: The shooting gives up when the profile has not reached its end after this arclength (apex radii).
YL_MAX_LENGTH = 60.0


class NoContact(ValueError):
    """The Young–Laplace profile closes on the axis (or runs too long) before its tangent reaches the angle."""


def _yl_rhs(bg: float, q) -> tuple:
    """``d/ds`` of ``(r, z, φ, V, S, M)`` along the profile from the apex (units of the apex radius ``b``;
    ``z`` down from the apex, ``bg = ±Bo``): ``φ' = 2 + bg z − sin φ / r`` (``1 + bg z / 2`` on the axis),
    ``V' = π r² sin φ``, ``S' = 2π r``, ``M' = π r² z sin φ`` (volume, surface, ``∫ z dV`` above the depth z)."""
    r, z, phi = q[0], q[1], q[2]
    c, s = math.cos(phi), math.sin(phi)
    k = 1.0 + 0.5 * bg * z if r == 0.0 else 2.0 + bg * z - s / r
    v = math.pi * r * r * s
    return (c, s, k, v, 2.0 * math.pi * r, v * z)


def _rk4(bg: float, q, h: float) -> tuple:
    k1 = _yl_rhs(bg, q)
    k2 = _yl_rhs(bg, tuple(a + 0.5 * h * b for a, b in zip(q, k1)))
    k3 = _yl_rhs(bg, tuple(a + 0.5 * h * b for a, b in zip(q, k2)))
    k4 = _yl_rhs(bg, tuple(a + h * b for a, b in zip(q, k3)))
    return tuple(a + h / 6.0 * (b1 + 2.0 * b2 + 2.0 * b3 + b4) for a, b1, b2, b3, b4 in zip(q, k1, k2, k3, k4))


@dataclass(frozen=True)
class YoungLaplaceProfile:
    """A profile of revolution from its apex, in units of its apex radius ``b`` (:func:`young_laplace`): the
    nodes ``s, r, z, phi`` (``z`` down from the apex) and, at the end, the volume ``V = ∫ π r² dz``, the
    surface ``S = ∫ 2π r ds`` and ``M = ∫ z dV`` (all from the apex down to the end's depth)."""

    bond: float
    g: int
    s: np.ndarray
    r: np.ndarray
    z: np.ndarray
    phi: np.ndarray
    volume: float
    surface: float
    moment: float

    def at(self, s) -> tuple:
        """``(r, z)`` at the arclengths ``s`` (cubic Hermite between the nodes, with ``r' = cos φ``,
        ``z' = sin φ``: fourth order, like the integrator)."""
        s = np.asarray(s, dtype=float)
        i = np.clip(np.searchsorted(self.s, s, side="right") - 1, 0, self.s.size - 2)
        h = self.s[i + 1] - self.s[i]
        t = np.where(h > 0.0, (s - self.s[i]) / np.where(h > 0.0, h, 1.0), 0.0)
        h00, h10 = 2 * t ** 3 - 3 * t ** 2 + 1, t ** 3 - 2 * t ** 2 + t
        h01, h11 = -2 * t ** 3 + 3 * t ** 2, t ** 3 - t ** 2
        out = []
        for y, dy in ((self.r, np.cos(self.phi)), (self.z, np.sin(self.phi))):
            out.append(h00 * y[i] + h10 * h * dy[i] + h01 * y[i + 1] + h11 * h * dy[i + 1])
        return out[0], out[1]


def young_laplace(bond: float, g: int = 1, theta: Optional[float] = None, crossing: int = 0,
                  s_end: Optional[float] = None, steps: int = YL_STEPS) -> YoungLaplaceProfile:
    """Shoot the axisymmetric Young–Laplace equation from the apex, in units of the apex radius ``b``:

        dr/ds = cos φ,   dz/ds = sin φ,   dφ/ds = 2 + g Bo z − sin φ / r,

    ``Bo = rho g b² / gamma`` and ``g = +1`` a sessile drop (``z`` down from the apex, the pressure rising
    with depth), ``-1`` a pendant one (``z`` up from the apex towards the ceiling; OpenDrop's convention).
    Classical RK4 at fixed steps (``steps`` per unit of ``min(b, l_c)``), numpy-free in the loop.  It ends
    at the arclength ``s_end``, or where ``φ`` crosses ``theta`` for the ``crossing``-th time (0: the first),
    located inside its step by Newton's method on the step length.  Raises :class:`NoContact` when the
    profile closes on the axis or runs past ``YL_MAX_LENGTH`` first."""
    bg = g * bond
    h = 1.0 / (steps * max(1.0, math.sqrt(bond)))
    if s_end is not None:
        m = max(1, int(math.ceil(s_end / h)))
        h = s_end / m
    q, s = (0.0,) * 6, 0.0
    ss, rs, zs, ps = [0.0], [0.0], [0.0], [0.0]
    seen = 0
    while True:
        step = h if s_end is None else min(h, s_end - s)
        nq = _rk4(bg, q, step)
        if theta is not None and (q[2] - theta) * (nq[2] - theta) <= 0.0 and nq[2] != q[2] and s > 0.0 or (
                theta is not None and s == 0.0 and nq[2] >= theta):
            if seen == crossing:
                tau = step * (theta - q[2]) / (nq[2] - q[2])
                for _ in range(8):  # Newton on the step length: φ(τ) = θ
                    e = _rk4(bg, q, tau)
                    dtau = (e[2] - theta) / _yl_rhs(bg, e)[2]
                    tau -= dtau
                    if abs(dtau) <= 1e-15 * max(h, tau):
                        break
                nq, step = _rk4(bg, q, tau), tau
                ss.append(s + step), rs.append(nq[0]), zs.append(nq[1]), ps.append(nq[2])
                break
            seen += 1
        q, s = nq, s + step
        ss.append(s), rs.append(q[0]), zs.append(q[1]), ps.append(q[2])
        if s_end is not None and s >= s_end:
            break
        if q[0] <= 0.0 or s > YL_MAX_LENGTH:
            raise NoContact(f"the Young–Laplace profile (Bo = {bond:.6g}) closes on the axis before its tangent "
                            f"turns to {theta if theta is None else math.degrees(theta):.6g} degrees")
    q = nq if theta is not None else q
    return YoungLaplaceProfile(bond, g, np.array(ss), np.array(rs), np.array(zs), np.array(ps), q[3], q[4], q[5])


@dataclass(frozen=True)
class AxisymmetricDrop:
    """The drop of revolution under gravity, from a Young–Laplace shooting (:func:`young_laplace`).

    ``profile`` is in units of the apex radius ``b`` (physical here); ``y = h − z`` is the height above the
    wall into the liquid.  Pressure at the wall ``P = gamma 2/b + g rho g h``; the vertical force balance
    ``g rho g V = P pi r_c² − 2 pi r_c gamma sin θ`` holds exactly for the profile (the tests check it as
    an identity of the integration).  ``area`` is the volume (the constrained measure)."""

    profile: YoungLaplaceProfile
    apex_radius: float
    contact_angle: float
    gamma_gl: float
    rho_g: float
    wetting: float

    @property
    def g(self) -> int:
        return self.profile.g

    @property
    def pendant(self) -> bool:
        return self.g < 0

    @property
    def capillary_length(self) -> float:
        return math.sqrt(self.gamma_gl / self.rho_g)

    @property
    def height(self) -> float:
        return self.apex_radius * float(self.profile.z[-1])

    @property
    def span(self) -> float:
        """The contact diameter ``2 r_c`` (what a side view shows; the 2-D drop's span)."""
        return 2.0 * self.contact_radius

    @property
    def contact_radius(self) -> float:
        return self.apex_radius * float(self.profile.r[-1])

    @property
    def volume(self) -> float:
        return self.apex_radius ** 3 * self.profile.volume

    area = volume

    @property
    def surface_area(self) -> float:
        return self.apex_radius ** 2 * self.profile.surface

    @property
    def apex_curvature(self) -> float:
        return 1.0 / self.apex_radius

    @property
    def pressure(self) -> float:
        """The volume multiplier ``dE*/dV``: the pressure at the wall, ``2 gamma / b + g rho_g h``."""
        return 2.0 * self.gamma_gl / self.apex_radius + self.g * self.rho_g * self.height

    pressure_at_table = pressure

    @property
    def moment(self) -> float:
        """``∫ y dV`` about the wall: ``h V − ∫ z dV``."""
        return self.height * self.volume - self.apex_radius ** 4 * self.profile.moment

    @property
    def energy(self) -> float:
        """``gamma S + (gamma_sl − gamma_sg) pi r_c² + g rho_g ∫ y dV``."""
        return (self.gamma_gl * self.surface_area + self.wetting * math.pi * self.contact_radius ** 2
                + self.g * self.rho_g * self.moment)

    def points(self, n: int) -> np.ndarray:
        """``n + 1`` points ``(r, y)`` of the half profile, equally spaced in arclength from the apex."""
        r, z = self.profile.at(np.linspace(0.0, self.profile.s[-1], n + 1))
        pts = self.apex_radius * np.column_stack([r, self.profile.z[-1] - z])
        pts[0, 0], pts[-1, 1] = 0.0, 0.0
        return pts

    def distance(self, r, y) -> np.ndarray:
        return distance_to_reference(r, y, self.points(max(20000, 128 * (np.size(r) - 1))))

    def as_dict(self) -> Dict[str, float]:
        return {"contact_angle": self.contact_angle, "contact_radius": self.contact_radius, "height": self.height,
                "apex_radius": self.apex_radius, "apex_curvature": self.apex_curvature, "pressure": self.pressure,
                "pressure_at_table": self.pressure, "volume": self.volume, "energy": self.energy,
                "capillary_length": self.capillary_length}


def _illinois(f, lo: float, hi: float, flo: float, fhi: float, rtol: float = 4e-16) -> float:
    """The root of ``f`` in ``[lo, hi]`` (``flo``, ``fhi`` of opposite signs) by the Illinois regula falsi."""
    side = 0
    for _ in range(200):
        x = (lo * fhi - hi * flo) / (fhi - flo)
        if not lo < x < hi or hi - lo <= rtol * abs(hi):
            return x if lo < x < hi else 0.5 * (lo + hi)
        fx = f(x)
        if fx == 0.0:
            return x
        if (fx > 0.0) == (fhi > 0.0):
            hi, fhi = x, fx
            if side == 1:
                flo *= 0.5
            side = 1
        else:
            lo, flo = x, fx
            if side == -1:
                fhi *= 0.5
            side = -1
    return x


def _unit_revolution(theta: float, g: int, b: float, crossing: int = 0):
    """The profile in units of ``l_c`` with apex radius ``b``: ``(profile, volume)``."""
    prof = young_laplace(b * b, g, theta, crossing)
    return prof, b ** 3 * prof.volume


def _sessile_revolution(theta: float, volume: float) -> tuple:
    """``(profile, b)`` of the sessile drop of unit volume ``volume`` (units of l_c): its volume rises with
    the apex radius ``b``; Illinois regula falsi in ``log b`` from the spherical cap's radius."""
    f = lambda lb: _unit_revolution(theta, 1, math.exp(lb))[1] / volume - 1.0  # noqa: E731
    lo = math.log((volume / cap_volume_factor(theta)) ** (1.0 / 3.0))  # the weightless cap: too small a drop
    flo = f(lo)
    hi = lo + 1.0
    fhi = f(hi)
    while fhi <= 0.0:
        lo, flo, hi = hi, fhi, hi + 1.0
        fhi = f(hi)
    while flo > 0.0:
        lo -= 1.0
        flo = f(lo)
    b = math.exp(_illinois(f, lo, hi, flo, fhi))
    return _unit_revolution(theta, 1, b)[0], b


#: The pendant family's parameter ``u`` (units of l_c): the apex radius ``b = u`` up to the tangency
#: ``b_t`` (where the largest tangent angle of the profile just reaches θ), then ``b = 2 b_t − u`` on the
#: second crossing of θ (the contact beyond the widest point, through a neck).
def _pendant_member(theta: float, u: float, b_t: float):
    if u <= b_t:
        return _unit_revolution(theta, -1, u, 0), u
    return _unit_revolution(theta, -1, 2.0 * b_t - u, 1), 2.0 * b_t - u


def _crosses(theta: float, b: float) -> bool:
    try:
        young_laplace(b * b, -1, theta, 0)
        return True
    except NoContact:
        return False


@dataclass(frozen=True)
class _RevolutionFold:
    theta: float
    b_t: float
    u: float  # the fold's family parameter
    volume: float


_FOLDS: Dict[float, _RevolutionFold] = {}


def _revolution_fold(theta: float) -> _RevolutionFold:
    """The pendant drop of revolution of largest volume (units of l_c; cached per angle): the tangency
    ``b_t`` by bisection, a scan of the family, then golden-section search."""
    if theta in _FOLDS:
        return _FOLDS[theta]
    lo, hi = 0.05, 0.1
    while _crosses(theta, hi):
        lo, hi = hi, 2.0 * hi
        if hi > 1e3:
            raise ValueError(f"the pendant family at theta = {math.degrees(theta):.4g} degrees has no tangency")
    while hi - lo > 1e-12 * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _crosses(theta, mid) else (lo, mid)
    b_t = lo
    vol = lambda u: _pendant_member(theta, u, b_t)[0][1]  # noqa: E731
    grid = np.linspace(0.5 * b_t, 1.5 * b_t, 21)
    vals = []
    for u in grid:
        try:
            vals.append(vol(u))
        except NoContact:
            vals.append(-math.inf)
    j = int(np.argmax(vals))
    if j in (0, grid.size - 1):
        raise ValueError(f"the pendant family at theta = {math.degrees(theta):.4g} degrees does not fold inside "
                         "the scanned range; no closed form of its fold here")
    a, c = grid[j - 1], grid[j + 1]
    r = 0.5 * (math.sqrt(5.0) - 1.0)
    x1, x2 = c - r * (c - a), a + r * (c - a)
    f1, f2 = vol(x1), vol(x2)
    while c - a > 1e-9 * c:
        if f1 > f2:
            c, x2, f2 = x2, x1, f1
            x1 = c - r * (c - a)
            f1 = vol(x1)
        else:
            a, x1, f1 = x1, x2, f2
            x2 = a + r * (c - a)
            f2 = vol(x2)
    u = 0.5 * (a + c)
    _FOLDS[theta] = _RevolutionFold(theta, b_t, u, vol(u))
    return _FOLDS[theta]


def _revolution(drop: Droplet, prof: YoungLaplaceProfile, b_unit: float) -> AxisymmetricDrop:
    lc = drop.capillary_length
    return AxisymmetricDrop(prof, b_unit * lc, young_angle(drop.gamma_gl, drop.gamma_sl, drop.gamma_sg),
                            drop.gamma_gl, drop.rho_g, drop.wetting)


def axisymmetric_drop(drop: Droplet) -> AxisymmetricDrop:
    """The drop of revolution under gravity of the drop's volume (``drop.area``), by shooting: the apex radius
    solved from the volume to rounding.  A pendant drop beyond the family's fold raises :class:`BeyondFold`."""
    theta = young_angle(drop.gamma_gl, drop.gamma_sl, drop.gamma_sg)
    volume = drop.area / drop.capillary_length ** 3
    if not drop.pendant:
        return _revolution(drop, *_sessile_revolution(theta, volume))
    fold = _revolution_fold(theta)
    if volume > fold.volume:
        raise BeyondFold(f"no pendant drop of volume {drop.area:g}: the family of drops of revolution folds at "
                         f"V* = {fold.volume * drop.capillary_length ** 3:.7g} (θ = {math.degrees(theta):.6g}°)")
    f = lambda u: _pendant_member(theta, u, fold.b_t)[0][1] / volume - 1.0  # noqa: E731
    hi = min(fold.u, (volume / cap_volume_factor(theta)) ** (1.0 / 3.0))  # gravity swells a pendant drop
    fhi = f(hi)
    lo = 0.5 * hi
    flo = f(lo)
    while flo > 0.0:
        lo *= 0.5
        flo = f(lo)
    if fhi < 0.0:
        lo, flo, hi, fhi = hi, fhi, fold.u, f(fold.u)
    u = _illinois(f, lo, hi, flo, fhi) if fhi != 0.0 else hi
    (prof, _), b = _pendant_member(theta, u, fold.b_t)
    return _revolution(drop, prof, b)


def revolution_fold(drop: Droplet) -> AxisymmetricDrop:
    """The largest pendant drop of revolution for the drop's tensions and gravity (its volume is ignored)."""
    theta = young_angle(drop.gamma_gl, drop.gamma_sl, drop.gamma_sg)
    fold = _revolution_fold(theta)
    (prof, _), b = _pendant_member(theta, fold.u, fold.b_t)
    return _revolution(drop, prof, b)


# ---------------------------------------------------------------------------- a patterned table (Gibbs' criterion)
#: The regimes of a drop on a patterned table, by growing area: its edge inside the pattern at the inner Young
#: angle, pinned at the step at an apparent angle between the two Young angles, spread beyond it at the outer one.
REGIMES = ("inside", "pinned", "spread")


def outer_young_angle(drop: Droplet) -> float:
    """Young's angle outside the pattern; ``pi`` when the outside does not wet at all
    (``gamma_sl_out - gamma_sg >= gamma_gl``: the edge then never depins)."""
    return math.acos(max(-1.0, -drop.wetting_out / drop.gamma_gl))


def step_measure(drop: Droplet) -> float:
    """The wetted measure at which the edge reaches the step: the pattern's width (2-D) or its disc's area."""
    return math.pi * (0.5 * drop.pattern_width) ** 2 if drop.axisymmetric else drop.pattern_width


def pinned_area(theta: float, width: float, axisymmetric: bool = False) -> float:
    """The area of the weightless cap of contact angle ``theta`` whose edges sit at ``±width/2``:
    ``(w/2)² (θ − sin θ cos θ) / sin² θ``; for a drop of revolution its volume, ``π (w/2)³ (2 − 3 cos θ + cos³ θ) /
    (3 sin³ θ)``.  Increasing in ``theta`` (``docs/derivations.md``, Droplet §5), infinite at ``pi``."""
    s = math.sin(theta)
    if theta >= math.pi:
        return math.inf
    if axisymmetric:
        return cap_volume_factor(theta) * (0.5 * width / s) ** 3
    return segment_area_factor(theta) * (0.5 * width / s) ** 2


@dataclass(frozen=True)
class PatternedCap:
    """The weightless drop on a patterned table: a cap (:class:`CircularCap`, or :class:`SphericalCap` for a
    drop of revolution) in one of three regimes (:data:`REGIMES`), ``docs/derivations.md``, Droplet §11.

    ``angles`` are the inner and outer Young angles, ``areas`` the areas (volumes) where the regimes change:
    the edge reaches the step at the inner angle, and depins at the outer one (:func:`pinned_area`).  The
    energy counts the wetted measure at ``gamma_sl - gamma_sg`` inside the pattern and ``gamma_sl_out - gamma_sg``
    outside.  :attr:`pinning_multiplier` is the multiplier of the pinning bound (the inside's wetted measure
    at most the step's): ``gamma (cos θ_in − cos θ)``, in ``[0, gamma_sl_out − gamma_sl]``."""

    regime: str
    cap: Union[CircularCap, "SphericalCap"]
    width: float
    gamma_gl: float
    wetting: float
    wetting_out: float
    angles: tuple
    areas: tuple

    @property
    def axisymmetric(self) -> bool:
        return isinstance(self.cap, SphericalCap)

    def __getattr__(self, name):  # the cap's own readings: span, radius, pressure, points, distance, ...
        if name.startswith("__"):
            raise AttributeError(name)
        return getattr(self.cap, name)

    @property
    def contact_angle(self) -> float:
        """The apparent contact angle."""
        return self.cap.contact_angle

    @property
    def wetted(self) -> float:
        """The wetted measure: the span (2-D) or the disc ``pi r_c²``."""
        return math.pi * self.cap.contact_radius ** 2 if self.axisymmetric else self.cap.span

    @property
    def step(self) -> float:
        return math.pi * (0.5 * self.width) ** 2 if self.axisymmetric else self.width

    @property
    def energy(self) -> float:
        """``gamma S + (gamma_sl − gamma_sg) min(m, m_step) + (gamma_sl_out − gamma_sg) max(m − m_step, 0)``, ``m``
        the wetted measure."""
        surface = self.cap.surface_area if self.axisymmetric else self.cap.length
        m, step = self.wetted, self.step
        return self.gamma_gl * surface + self.wetting * min(m, step) + self.wetting_out * max(m - step, 0.0)

    @property
    def pinning_multiplier(self) -> float:
        """``gamma (cos θ_in − cos θ)``: 0 inside the pattern, the jump ``gamma_sl_out − gamma_sl`` when spread."""
        return self.gamma_gl * (math.cos(self.angles[0]) - math.cos(self.contact_angle))

    def as_dict(self) -> Dict[str, float]:
        return {**self.cap.as_dict(), "energy": self.energy, "regime": self.regime,
                "apparent_angle": self.contact_angle, "pinning_multiplier": self.pinning_multiplier,
                "young_angles": list(self.angles), "regime_areas": list(self.areas)}


def patterned_cap(drop: Droplet) -> PatternedCap:
    """The exact minimiser on a patterned table (weightless; 2-D or of revolution).  By growing area: the Young
    cap at the inner angle while its edge lies inside the pattern; the cap pinned at the step, its angle solved
    from the area (bisection, to rounding), while that angle lies between the two Young angles; the Young cap
    at the outer angle beyond."""
    th_in, th_out = young_angle(drop.gamma_gl, drop.gamma_sl, drop.gamma_sg), outer_young_angle(drop)
    w, axi = drop.pattern_width, drop.axisymmetric
    a_in, a_out = float(pinned_area(th_in, w, axi)), float(pinned_area(th_out, w, axi))
    if drop.area <= a_in:
        regime, theta = "inside", th_in
    elif drop.area >= a_out:
        regime, theta = "spread", th_out
    else:
        regime = "pinned"
        theta = _bisect(lambda t: pinned_area(t, w, axi) - drop.area, th_in, th_out)
    if axi:
        cap = SphericalCap(theta, (drop.area / cap_volume_factor(theta)) ** (1.0 / 3.0), drop.gamma_gl, drop.wetting)
    else:
        cap = CircularCap(theta, math.sqrt(drop.area / segment_area_factor(theta)), drop.gamma_gl, drop.wetting)
    return PatternedCap(regime, cap, w, drop.gamma_gl, drop.wetting, drop.wetting_out, (th_in, th_out),
                        (a_in, a_out))
