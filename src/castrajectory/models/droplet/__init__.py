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

The package keeps one oracle per room: this module the scene and the weightless cap, :mod:`.heavy` the heavy drop
in 2-D, :mod:`.revolution` the drops of revolution, :mod:`.pattern` the patterned table (their names are
importable from here).
"""
from __future__ import annotations

import math
from typing import Union

from .scene import (CircularCap, Droplet, arc_on_span, arc_points, distance_to_reference,  # noqa: F401
                    reduced_energy, segment_area_factor, young_angle)
from .heavy import BeyondFold, HeavyDrop, _unit_pendant, heavy_drop, pendant_fold, puddle_height  # noqa: F401
from .revolution import (AxisymmetricDrop, NoContact, SphericalCap, YoungLaplaceProfile, _illinois,  # noqa: F401
                         axisymmetric_drop, cap_volume_factor, revolution_fold, spherical_cap, young_laplace)
from .pattern import (REGIMES, PatternedCap, outer_young_angle, patterned_cap, pinned_area,  # noqa: F401
                      step_measure)

def analytic(drop: Droplet) -> Union[CircularCap, HeavyDrop, SphericalCap, AxisymmetricDrop, PatternedCap]:
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
        theta, radius = arc_on_span(drop.area, drop.span)
    return CircularCap(theta, radius, drop.gamma_gl, drop.wetting)
