"""The heavy drop in 2-D: the closed form in incomplete elliptic integrals, sessile and pendant, and the pendant
family's fold (docs/derivations.md, Droplet §9)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict

import numpy as np

from ..elliptic import carlson_rd, carlson_rf, incomplete
from .scene import Droplet, distance_to_reference, young_angle


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
        k = max(64, 4 * n) + 1
        # (a puddle's flat top lies at tangent angles below about κ_a, which a uniform grid of u does not reach:
        # its arclength jumps there, and the points of the flat top were not equally spaced (the shape error of
        # a drop of Bond number 100 at N = 400 read 0.8 of its height); a geometric grid down to κ_a/1e6 does)
        u = np.unique(np.concatenate([np.linspace(0.0, 1.0, k),
                                      np.geomspace(max(1e-6 * min(unit.kappa_a, 1.0), 1e-300), 1.0, k)]))
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
