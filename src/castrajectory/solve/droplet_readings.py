"""What a droplet solve reads off its result, and the checks of that reading.

* :func:`readings`: the physical readings (contact angle, span or contact radius, pressure, energy, height,
  apex curvature; the pattern's regime and pinning force) of each discretisation, in the drop's units;
* :func:`errors_against`: those readings against an oracle (relative, but the contact angle's, in radians);
* :func:`check_profile`: a converged answer whose profile is no drop (it crosses its axis, loops, or passes
  below the table) is turned into a failure.

Split from :mod:`castrajectory.solve.droplet`, which poses and solves the programs.
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import Dict

import numpy as np

from ..discretise.droplet import contact_angle_at_rim, contact_angle_estimate
from ..discretise.droplet_spectral import SpectralGeometry
from ..models.droplet import (AxisymmetricDrop, Droplet, HeavyDrop, PatternedCap, SphericalCap, outer_young_angle,
                              step_measure, young_angle)
from ..result import NLPResult


def readings(drop: Droplet, res: NLPResult, geo) -> dict:
    """The physical readings of a solve, in the drop's units."""
    if isinstance(geo, SpectralGeometry):
        return _spectral_readings(drop, res, geo)
    if drop.patterned:
        return pattern_readings(drop, res, geo)
    if drop.axisymmetric:
        return _revolution_readings(drop, res, geo)
    L, g = drop.length_scale, drop.gamma_gl
    xs, ys, span = geo.vertices(res)
    x, y = L * xs, L * ys
    span, length = L * span, L * float(np.sum(np.hypot(np.diff(xs), np.diff(ys))))
    energy = g * length + drop.wetting * span
    if drop.rho_g > 0.0:  # the polygon's first moment ∫∫ y dA, exactly (its edges' ∫ y²/2 dx)
        moment = float(np.sum(np.diff(x) * (y[:-1] ** 2 + y[:-1] * y[1:] + y[1:] ** 2))) / 6.0
        energy += drop.gravity_sign * drop.rho_g * moment
    return {"x": x, "y": y, "xs": xs, "ys": ys, "contact_angle": contact_angle_estimate(x, y), "span": span,
            "pressure": g / L * float(res.multipliers["area"][0]), "energy": energy,
            "height": float(np.max(y)), "apex_curvature": apex_curvature(x, y)}


def _spectral_readings(drop: Droplet, res: NLPResult, geo: SpectralGeometry) -> dict:
    """The readings of a spectral profile: the energy is the program's objective (its quadratures, in the
    drop's units), the contact angle the tangent angle at the rim, the height the apex's; the apex curvature
    is the Laplace relation, as for the polyline of revolution."""
    L, g = drop.length_scale, drop.gamma_gl
    dim = 2 if geo.revolution else 1
    rs, zs, psi = geo.half_profile(res)
    xs, ys, span = geo.outline(rs, zs)
    pressure = g / L * float(res.multipliers["area"][0])
    height = L * float(zs[0])
    energy = g * L ** dim * float(res.objective)
    if drop.span is not None:  # a pinned span's wetting is a constant the program leaves out
        energy += drop.wetting * L * span
    out = {"x": L * xs, "y": L * ys, "xs": xs, "ys": ys, "contact_angle": float(psi[-1]), "span": L * span,
           "pressure": pressure, "energy": energy, "height": height,
           "apex_curvature": (pressure - drop.gravity_sign * drop.rho_g * height) / (dim * g),
           "psi": psi, "length": float(res.x[geo.length_index]), "half_r": rs}
    if geo.revolution:
        out.update(contact_radius=L * float(rs[-1]), volume=L ** 3 * geo.measure(res))
    return out


def _revolution_readings(drop: Droplet, res: NLPResult, geo) -> dict:
    """The readings of a drop of revolution: every integral is the polyline of revolution's, exactly (its
    frustums' area, the swept triangles' volume and moment); the height is the apex vertex on the axis, the
    contact angle read at the rim; ``span`` is the contact diameter ``2 r_c``.  The apex curvature is the
    Laplace relation at the apex, ``(P − g ρg h) / 2γ``, not the vertices' own: their errors near the axis,
    O(h² log h), are too large for a three-point curvature there (it stays 1/3 off; Droplet §10)."""
    L, g = drop.length_scale, drop.gamma_gl
    rs, zs, rc = geo.vertices(res)
    r, y = L * rs, L * zs
    tri = 0.5 * (r[1:] * y[:-1] - r[:-1] * y[1:])
    surface = math.pi * float(np.sum((r[:-1] + r[1:]) * np.hypot(np.diff(r), np.diff(y))))
    energy = g * surface + drop.wetting * math.pi * (L * rc) ** 2
    if drop.rho_g > 0.0:
        moment = math.pi / 6.0 * float(np.sum(tri * (2.0 * r[:-1] * y[:-1] + 2.0 * r[1:] * y[1:] + r[:-1] * y[1:]
                                                     + r[1:] * y[:-1])))
        energy += drop.gravity_sign * drop.rho_g * moment
    pressure = g / L * float(res.multipliers["area"][0])
    return {"x": r, "y": y, "xs": rs, "ys": zs, "contact_angle": contact_angle_at_rim(r, y), "span": 2.0 * L * rc,
            "contact_radius": L * rc, "volume": 2.0 * math.pi / 3.0 * float(np.sum(tri * (r[:-1] + r[1:]))),
            "pressure": pressure, "energy": energy, "height": float(y[0]),
            "apex_curvature": (pressure - drop.gravity_sign * drop.rho_g * float(y[0])) / (2.0 * g)}


#: A part of the wetted measure within this fraction of the step from its bound counts as at the bound (the
#: regime's reading; Ipopt ends within about 1e-10 of an active bound).
REGIME_RTOL = 1e-6
def pattern_readings(drop: Droplet, res: NLPResult, geo) -> dict:
    """The readings of a drop on a patterned table: the plain drop's (the wetting energy replaced by the split
    one), and ``pattern``: the regime read off the split (the inside part below its bound: ``inside``; the
    outside part above zero: ``spread``; both at their bounds: ``pinned``), the apparent angle, the parts of the
    wetted measure and the multipliers of their bounds, ``pinning_multiplier = −dE*/d(step)`` (per unit length
    of contact line; Droplet §11) and ``outside_multiplier`` (their sum is ``gamma_sl_out − gamma_sl``)."""
    plain = replace(drop, pattern_width=None, gamma_sl_out=None)
    r = _revolution_readings(plain, res, geo) if drop.axisymmetric else readings(plain, res, geo)
    L, g = drop.length_scale, drop.gamma_gl
    unit = L ** 2 if drop.axisymmetric else L
    inside, outside = float(res["wetted_inside"][0]) * unit, float(res["wetted_outside"][0]) * unit
    step = step_measure(drop)
    measure = math.pi * r["contact_radius"] ** 2 if drop.axisymmetric else r["span"]
    r["energy"] += drop.wetting * (min(measure, step) - measure) + drop.wetting_out * max(measure - step, 0.0)
    regime = "inside" if step - inside > REGIME_RTOL * step else (
        "spread" if outside > REGIME_RTOL * step else "pinned")
    pin = -g * float(res.bound_multipliers["wetted_inside"][0])
    out = g * float(res.bound_multipliers["wetted_outside"][0])
    r["pattern"] = {"regime": regime, "apparent_angle": r["contact_angle"], "pinning_multiplier": pin,
                    "outside_multiplier": out, "pinning_bounds": [0.0, drop.gamma_sl_out - drop.gamma_sl],
                    "wetted_inside": inside, "wetted_outside": outside, "step": step, "width": drop.pattern_width,
                    "gamma_sl_out": drop.gamma_sl_out,
                    "young_angles": [young_angle(g, drop.gamma_sl, drop.gamma_sg), outer_young_angle(drop)]}
    return r


def apex_curvature(x, y) -> float:
    """The curvature of the circle through the highest vertex and its two neighbours (second order at the
    apex of a symmetric drop, where the curvature is stationary)."""
    i = int(np.clip(np.argmax(y), 1, len(y) - 2))
    p = np.column_stack([x[i - 1:i + 2], y[i - 1:i + 2]])
    a, b, c = p[1] - p[0], p[2] - p[1], p[2] - p[0]
    cross = a[0] * b[1] - a[1] * b[0]
    return float(-2.0 * cross / (np.hypot(*a) * np.hypot(*b) * np.hypot(*c)))


def errors_against(r: dict, cap) -> Dict[str, float]:
    """The readings' errors against the oracle (relative, but the contact angle's, in radians)."""
    if isinstance(cap, PatternedCap):  # the cap's errors; the energy with the split wetting; the pinning force
        errors = errors_against(r, cap.cap)
        errors["energy"] = abs(r["energy"] - cap.energy) / abs(cap.energy)
        errors["pinning_multiplier"] = abs(r["pattern"]["pinning_multiplier"] - cap.pinning_multiplier) / (
            cap.wetting_out - cap.wetting)
        return errors
    if isinstance(cap, (SphericalCap, AxisymmetricDrop)):
        curv = cap.apex_curvature + 1.0 / cap.capillary_length  # (1/l_c = 0 without gravity)
        return {"shape": float(np.max(np.abs(cap.distance(r["x"], r["y"])))) / cap.height,
                "contact_angle": abs(r["contact_angle"] - cap.contact_angle),
                "contact_radius": abs(r["contact_radius"] - cap.contact_radius) / cap.contact_radius,
                "height": abs(r["height"] - cap.height) / cap.height,
                "apex_curvature": abs(r["apex_curvature"] - cap.apex_curvature) / curv,
                # (a pendant drop's pressure passes through zero: the scale of its two parts, 2γ/b and ρg h)
                "pressure": abs(r["pressure"] - cap.pressure) / (2.0 * cap.gamma_gl * cap.apex_curvature + (
                    0.0 if isinstance(cap, SphericalCap) else cap.rho_g * cap.height)),
                "energy": abs(r["energy"] - cap.energy) / abs(cap.energy)}
    errors = {
        "shape": float(np.max(np.abs(cap.distance(r["x"], r["y"])))) / (
            cap.height if isinstance(cap, HeavyDrop) else cap.radius),
        "contact_angle": abs(r["contact_angle"] - cap.contact_angle),
        "span": abs(r["span"] - cap.span) / cap.span,
        "energy": abs(r["energy"] - cap.energy) / abs(cap.energy),
        "pressure": abs(r["pressure"] - cap.pressure) / cap.pressure,
    }
    if isinstance(cap, HeavyDrop):
        # a pendant drop's pressure passes through zero: its scale is that of its two parts, γκ_a and ρg h
        errors["pressure"] = abs(r["pressure"] - cap.pressure) / (
            cap.gamma_gl * cap.apex_curvature + cap.rho_g * cap.height)
        errors["height"] = abs(r["height"] - cap.height) / cap.height
        # (a puddle's apex curvature vanishes exponentially with its span: the scale is at least 1/l_c)
        errors["apex_curvature"] = abs(r["apex_curvature"] - cap.apex_curvature) / (
            cap.apex_curvature + 1.0 / cap.capillary_length)
    return errors


#: How far below the table (relative to the drop's size) a node may sit before the profile is refused.
BELOW_TABLE_RTOL = 1e-9


def check_profile(drop: Droplet, res: NLPResult, r: dict) -> None:
    """Fail a converged answer whose profile is no drop: the energy's integrals are signed, so a profile that
    crosses the axis (a drop of revolution; the frustum's area pi (r_i + r_{i+1}) l turns negative) or loops
    under the table (its weight turns negative) can price below the drop, whatever Ipopt says (the spectral
    profile at Bond 100, degree 64: an energy 24 % below the drop's, its tangent turned to -5.5 rad)."""
    if not res.success:
        return
    xs, ys = np.asarray(r["xs"]), np.asarray(r["ys"])
    half = r.get("half_r", xs if drop.axisymmetric else None)  # a half profile's distance from its axis
    if half is not None and np.any(half[1:] <= 0.0):
        res.fail("Profile_Crossed_Axis", f"the profile reached its axis at {int(np.sum(half[1:] <= 0.0))} node(s) "
                 "besides the apex: no drop; supply a better initial guess or refine n")
    elif "psi" in r and np.any(np.abs(r["psi"]) > math.pi):
        res.fail("Profile_Looped", f"the profile's tangent turned to {float(np.max(np.abs(r['psi']))):.4g} rad (beyond "
                 "pi: it loops over itself): no drop; the degree does not resolve it: raise n, or use the curve "
                 "formulation (a puddle's edge)")
    elif np.any(ys < -BELOW_TABLE_RTOL * np.max(np.abs(ys))):
        res.fail("Profile_Below_Table", f"the profile passed below the {'ceiling' if drop.pendant else 'table'} at "
                 f"{int(np.sum(ys < 0.0))} node(s): no drop (its signed weight priced it below the drop); refine n "
                 "or use the curve formulation")
