"""Kepler's orbit in closed form: the oracle of a point mass around a unit central mass (GM = 1).

From perihelion ``x = (1, 0)`` with velocity ``(0, v₀)`` the orbit is an ellipse of eccentricity ``e = v₀² − 1``
and semi-major axis ``a = 1/(2 − v₀²)``; its position at time ``t`` follows from Kepler's equation
``E − e sin E = M``, ``M = t a^{−3/2}``, solved by Newton's method to rounding (``examples/kepler.py``).
"""
from __future__ import annotations

import math

import numpy as np


def kepler_orbit(t, v0: float = 1.2) -> np.ndarray:
    """Positions ``(len(t), 2)`` of the bound orbit from perihelion (1, 0) with speed ``v0`` (``1 <= v0 < √2``).

    >>> import numpy as np
    >>> bool(np.allclose(kepler_orbit([0.0], 1.2), [[1.0, 0.0]]))
    True
    """
    e, a = v0 ** 2 - 1.0, 1.0 / (2.0 - v0 ** 2)
    M = np.asarray(t, float) * a ** -1.5
    E = M.copy()
    for _ in range(60):
        E = E - (E - e * np.sin(E) - M) / (1.0 - e * np.cos(E))
    return np.column_stack([a * (np.cos(E) - e), a * math.sqrt(1.0 - e * e) * np.sin(E)])
