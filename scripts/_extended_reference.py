"""An extended-precision reference for the trajectory benchmarks (not a test; used by bench_trajectory.py).

Classical RK4 in ``numpy.longdouble`` (x87 80-bit: 64-bit significand, eps 1.1e-19) on ``M`` and ``2M``
steps, Richardson-extrapolated at the coarse nodes (``y = y_2M + (y_2M − y_M)/15``), then evaluated
anywhere by the quintic Hermite interpolant of ``(q, q̇, q̈)`` on the ``M`` grid (interpolation error
``h⁶ |q⁽⁶⁾| / 720``, below 1e-25 at ``h = 1e-4``).  Its own error is bounded by the difference of two
such references (``M/2, M`` against ``M, 2M``), printed by the benchmark.  DOP853 at rtol 1e-13 is
itself 3.5e-12 off the double pendulum's motion (issue #22), too coarse to judge 1e-12.
"""
from __future__ import annotations

import numpy as np

LD = np.longdouble


def rk4_longdouble(rhs, y0, T: float, M: int) -> np.ndarray:
    """``M`` RK4 steps of ``y' = rhs(y)`` over ``[0, T]`` in extended precision: the states, ``(M + 1, d)``."""
    h = LD(T) / M
    y = np.array(y0, dtype=LD)
    out = np.empty((M + 1, y.size), dtype=LD)
    out[0] = y
    for k in range(M):
        k1 = rhs(y)
        k2 = rhs(y + h / 2 * k1)
        k3 = rhs(y + h / 2 * k2)
        k4 = rhs(y + h * k3)
        y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        out[k + 1] = y
    return out


class Reference:
    """``q(t)`` of a second-order system ``y = (q, q̇)`` to about 1e-16 (see the module docstring)."""

    def __init__(self, rhs, y0, T: float, M: int):
        coarse = rk4_longdouble(rhs, y0, T, M)
        fine = rk4_longdouble(rhs, y0, T, 2 * M)[::2]
        self.y = fine + (fine - coarse) / 15
        self.n = len(y0) // 2
        self.T, self.M = float(T), int(M)
        self.f = np.array([rhs(row) for row in self.y], dtype=LD)

    def q(self, t) -> np.ndarray:
        """The configuration at the times ``t`` (float64 rows)."""
        t = np.asarray(t, dtype=LD).reshape(-1)
        h = LD(self.T) / self.M
        k = np.clip((t / h).astype(np.int64), 0, self.M - 1)
        s = (t - k * h) / h
        n = self.n
        q0, q1 = self.y[k, :n], self.y[k + 1, :n]
        d0, d1 = self.y[k, n:] * h, self.y[k + 1, n:] * h
        a0, a1 = self.f[k, n:] * h * h, self.f[k + 1, n:] * h * h
        s = s[:, None]
        s2, s3 = s * s, s * s * s
        s4, s5 = s3 * s, s3 * s2
        H0 = 1 - 10 * s3 + 15 * s4 - 6 * s5
        H1 = s - 6 * s3 + 8 * s4 - 3 * s5
        H2 = (s2 - 3 * s3 + 3 * s4 - s5) / 2
        H5 = 10 * s3 - 15 * s4 + 6 * s5
        H4 = -4 * s3 + 7 * s4 - 3 * s5
        H3 = (s3 - 2 * s4 + s5) / 2
        return np.asarray(H0 * q0 + H1 * d0 + H2 * a0 + H3 * a1 + H4 * d1 + H5 * q1, dtype=float)
