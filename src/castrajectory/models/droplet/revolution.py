"""Drops of revolution (3-D): the spherical cap, the Young–Laplace shooting in arc length, the sessile and pendant
profiles and the pendant fold (docs/derivations.md, Droplet §10)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, Optional

import numpy as np

from .scene import Droplet, distance_to_reference, young_angle
from .heavy import BeyondFold


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


#: The largest ``log b`` the sessile shooting brackets (``b³`` overflows near ``e^236``): a puddle's top flattens
#: as ``e^(-r_c)`` (θ = 8°, V = 3.2e4 l_c³ needs b ≈ e^268).
MAX_LOG_APEX_RADIUS = 200.0


def _sessile_revolution(theta: float, volume: float) -> tuple:
    """``(profile, b)`` of the sessile drop of unit volume ``volume`` (units of l_c): its volume rises with
    the apex radius ``b``; Illinois regula falsi in ``log b`` from the spherical cap's radius."""
    f = lambda lb: _unit_revolution(theta, 1, math.exp(lb))[1] / volume - 1.0  # noqa: E731
    lo = math.log((volume / cap_volume_factor(theta)) ** (1.0 / 3.0))  # the weightless cap: too small a drop
    flo = f(lo)
    hi, stride = lo + 1.0, 1.0
    fhi = f(hi)
    while fhi <= 0.0:
        if hi >= MAX_LOG_APEX_RADIUS:
            raise ValueError(f"the sessile drop of revolution at {math.degrees(theta):.6g} degrees and volume "
                             f"{volume:.6g} l_c³ is a puddle whose apex radius exceeds e^{MAX_LOG_APEX_RADIUS:g} l_c "
                             "(its top flattens exponentially in its radius): beyond the shooting from the apex")
        stride *= 2.0  # a puddle's volume grows only as (log b)²: widen the bracket geometrically
        lo, flo, hi = hi, fhi, min(hi + stride, MAX_LOG_APEX_RADIUS)
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
