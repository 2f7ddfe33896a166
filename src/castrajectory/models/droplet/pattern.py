"""A patterned table: the cap of Gibbs' criterion, inside, pinned or spread (docs/derivations.md, Droplet §11)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, Union

from .scene import CircularCap, Droplet, segment_area_factor, young_angle
from .heavy import _bisect
from .revolution import SphericalCap, cap_volume_factor


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
