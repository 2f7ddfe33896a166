"""Incomplete elliptic integrals from Carlson's symmetric forms (no scipy: numpy only).

``F(φ | m) = ∫₀^φ dt / √(1 − m sin²t)`` and ``E(φ | m) = ∫₀^φ √(1 − m sin²t) dt`` in the parameter
convention of Abramowitz & Stegun (and scipy's ``ellipkinc``/``ellipeinc``), for ``|φ| <= π/2`` and any
``m`` with ``m sin²φ <= 1``: negative ``m`` (the sessile drop's ``m = −4/(κ_a l_c)²``) and ``m > 1`` up to
the amplitude where the integrand's root sits (the pendant drop's neck) both work.  They are

    F = sin φ · R_F(cos²φ, 1 − m sin²φ, 1),
    F − E = (m/3) sin³φ · R_D(cos²φ, 1 − m sin²φ, 1),

with Carlson's ``R_F`` and ``R_D`` computed by the duplication theorem (B. C. Carlson, "Numerical
computation of real or complex elliptic integrals", Numer. Algorithms 10, 1995): each duplication
divides the arguments' spread by four; once it is below ``ERRTOL`` the fifth-order Taylor series of
the symmetric form is exact to rounding (truncation error about ``ERRTOL⁶ / 4``).  Vectorised over
numpy arrays; ``F − E`` is returned as its own term, because the drop's formulas need it where
``F`` and ``E`` nearly cancel.
"""
from __future__ import annotations

import numpy as np

#: Largest relative spread of the arguments at which the series is taken (Carlson 1995; Numerical
#: Recipes' values for double precision: the truncation error is below 1e-16).
RF_ERRTOL = 0.0025
RD_ERRTOL = 0.0015
#: Duplications at most (each divides the spread by 4; 4⁻⁴⁰ ≈ 1e-24 reaches the tolerance from any start)
MAX_DUPLICATIONS = 60


def _arrays(*args):
    return [np.array(a, dtype=float) for a in np.broadcast_arrays(*args)]


def carlson_rf(x, y, z):
    """``R_F(x, y, z) = ½ ∫₀^∞ dt / √((t+x)(t+y)(t+z))``: ``x, y, z >= 0``, at most one of them zero."""
    x, y, z = _arrays(x, y, z)
    for _ in range(MAX_DUPLICATIONS):
        mu = (x + y + z) / 3.0
        spread = np.max(np.abs(np.stack([x, y, z]) - mu) / mu, initial=0.0)
        if not spread > RF_ERRTOL:  # (NaN stops too)
            break
        sx, sy, sz = np.sqrt(x), np.sqrt(y), np.sqrt(z)
        lam = sx * sy + sy * sz + sz * sx
        x, y, z = 0.25 * (x + lam), 0.25 * (y + lam), 0.25 * (z + lam)
    mu = (x + y + z) / 3.0
    X, Y = 1.0 - x / mu, 1.0 - y / mu
    Z = -X - Y
    e2, e3 = X * Y - Z * Z, X * Y * Z
    return (1.0 - e2 / 10.0 + e3 / 14.0 + e2 * e2 / 24.0 - 3.0 * e2 * e3 / 44.0) / np.sqrt(mu)


def carlson_rd(x, y, z):
    """``R_D(x, y, z) = (3/2) ∫₀^∞ dt / ((t+z) √((t+x)(t+y)(t+z)))``: ``x, y >= 0`` (not both zero), ``z > 0``."""
    x, y, z = _arrays(x, y, z)
    total, scale = np.zeros_like(x), 1.0
    for _ in range(MAX_DUPLICATIONS):
        mu = (x + y + 3.0 * z) / 5.0
        spread = np.max(np.abs(np.stack([x, y, z]) - mu) / mu, initial=0.0)
        if not spread > RD_ERRTOL:
            break
        sx, sy, sz = np.sqrt(x), np.sqrt(y), np.sqrt(z)
        lam = sx * sy + sy * sz + sz * sx
        total = total + scale / (sz * (z + lam))
        scale *= 0.25
        x, y, z = 0.25 * (x + lam), 0.25 * (y + lam), 0.25 * (z + lam)
    mu = (x + y + 3.0 * z) / 5.0
    X, Y = 1.0 - x / mu, 1.0 - y / mu
    Z = -(X + Y) / 3.0
    ea, eb = X * Y, Z * Z
    e2 = ea - 6.0 * eb
    e3 = (3.0 * ea - 8.0 * eb) * Z
    e4 = 3.0 * (ea - eb) * eb
    e5 = ea * eb * Z
    series = (1.0 - 3.0 * e2 / 14.0 + e3 / 6.0 + 9.0 * e2 * e2 / 88.0 - 3.0 * e4 / 22.0
              - 9.0 * e2 * e3 / 52.0 + 3.0 * e5 / 26.0)
    return 3.0 * total + scale * series / (mu * np.sqrt(mu))


def incomplete(phi, m):
    """``(F(φ|m), F(φ|m) − E(φ|m))`` for ``|φ| <= π/2`` and ``m sin²φ <= 1`` (a negative ``1 − m sin²φ``
    within rounding is taken as 0; beyond that the result is NaN)."""
    phi, m = _arrays(phi, m)
    s, c = np.sin(phi), np.cos(phi)
    d = 1.0 - m * s * s
    d = np.where((d < 0.0) & (d > -1e-13), 0.0, d)
    d = np.where(d < 0.0, np.nan, d)
    c2 = c * c
    F = s * carlson_rf(c2, d, 1.0)
    return F, m * s ** 3 * carlson_rd(c2, d, 1.0) / 3.0


def ellipf(phi, m):
    """Incomplete elliptic integral of the first kind ``F(φ | m)`` (see :func:`incomplete`)."""
    return incomplete(phi, m)[0]


def ellipe(phi, m):
    """Incomplete elliptic integral of the second kind ``E(φ | m)`` (see :func:`incomplete`)."""
    F, D = incomplete(phi, m)
    return F - D
