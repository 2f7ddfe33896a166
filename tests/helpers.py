"""Independent oracles and small utilities shared by the test modules.

Nothing here imports castrajectory's analytic formulas: the circular-cap
geometry, Young's angle and the pinned-span arc are re-derived from scratch so
that the tests compare the library against an independent answer.

Circular cap of half-angle theta (contact angle) and radius R standing on y = 0:

    area      A = R² (theta - sin(2 theta) / 2)
    span      a = 2 R sin(theta)
    free arc  S = 2 R theta
    pressure  p = gamma_gl / R                 (Laplace)
    energy    E = gamma_gl S + (gamma_sl - gamma_sg) a
              = 2 gamma_gl A / R               (only at Young's angle)
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


# ----------------------------------------------------------------------------- convergence
def loglog_slope(ns, errs) -> float:
    """Least-squares slope of log(err) against log(N) (negative for a converging error)."""
    ns = np.asarray(ns, dtype=float)
    errs = np.asarray(errs, dtype=float)
    if np.any(errs <= 0.0) or not np.all(np.isfinite(errs)):
        raise ValueError(f"errors must be positive and finite for a log-log fit, got {errs}")
    design = np.column_stack([np.log(ns), np.ones_like(ns)])
    coef, *_ = np.linalg.lstsq(design, np.log(errs), rcond=None)
    return float(coef[0])


def observed_order(ns, errs) -> float:
    """Observed order of convergence p in err ~ C N^-p (least squares over all N)."""
    return -loglog_slope(ns, errs)


# ----------------------------------------------------------------------------- circles
@dataclass(frozen=True)
class Circle:
    cx: float
    cy: float
    r: float

    def distance(self, x, y) -> np.ndarray:
        return np.hypot(np.asarray(x) - self.cx, np.asarray(y) - self.cy) - self.r


def fit_circle(x, y, refine: int = 20) -> Circle:
    """Least-squares circle through points.

    Algebraic (Kåsa) fit ``x² + y² + D x + E y + F = 0`` as a start, then
    Gauss–Newton on the geometric residuals ``|p_i - c| - r``.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    M = np.column_stack([x, y, np.ones_like(x)])
    (D, E, F), *_ = np.linalg.lstsq(M, -(x * x + y * y), rcond=None)
    cx, cy = -0.5 * D, -0.5 * E
    r = math.sqrt(cx * cx + cy * cy - F)
    for _ in range(refine):
        dx, dy = x - cx, y - cy
        rho = np.hypot(dx, dy)
        res = rho - r
        J = np.column_stack([-dx / rho, -dy / rho, -np.ones_like(x)])
        step, *_ = np.linalg.lstsq(J, -res, rcond=None)
        cx, cy, r = cx + step[0], cy + step[1], r + step[2]
        if np.max(np.abs(step)) < 1e-15 * max(1.0, abs(r)):
            break
    return Circle(float(cx), float(cy), float(r))


def circle_points(theta: float, radius: float, n: int) -> np.ndarray:
    """``n + 1`` vertices equally spaced in angle on the cap of half-angle ``theta``.

    Left contact point at the origin; the circle's centre is at
    ``(R sin theta, -R cos theta)``.  Written independently of the library.
    """
    cx, cy = radius * math.sin(theta), -radius * math.cos(theta)
    # angle of the left contact point seen from the centre: pi/2 + theta, sweeping clockwise
    phi = (math.pi / 2 + theta) - 2.0 * theta * np.arange(n + 1) / n
    return np.column_stack([cx + radius * np.cos(phi), cy + radius * np.sin(phi)])


# ----------------------------------------------------------------------------- droplet oracles
def young_angle(g_gl: float, g_sl: float, g_sg: float) -> float:
    """Young: ``g_gl cos(theta) = g_sg - g_sl``."""
    return math.acos((g_sg - g_sl) / g_gl)


def tensions_for_angle(theta: float, g_gl: float = 1.0, g_sl: float = 0.3):
    """``(g_gl, g_sl, g_sg)`` with ``g_sg - g_sl = g_gl cos(theta)``."""
    return g_gl, g_sl, g_sl + g_gl * math.cos(theta)


def cap_area(theta: float, radius: float) -> float:
    return radius ** 2 * (theta - 0.5 * math.sin(2.0 * theta))


@dataclass(frozen=True)
class Cap:
    """Oracle values for a circular cap."""

    theta: float
    radius: float
    span: float
    arc_length: float
    pressure: float
    energy: float

    def circle(self) -> Circle:
        return Circle(0.5 * self.span, -self.radius * math.cos(self.theta), self.radius)


def free_cap(g_gl: float, g_sl: float, g_sg: float, area: float) -> Cap:
    """Minimiser with a free span: Young's angle, radius from the area."""
    theta = young_angle(g_gl, g_sl, g_sg)
    radius = math.sqrt(area / (theta - 0.5 * math.sin(2.0 * theta)))
    span = 2.0 * radius * math.sin(theta)
    energy = 2.0 * g_gl * area / radius
    # consistency with the general energy expression (a check of the derivation itself)
    general = g_gl * 2.0 * radius * theta + (g_sl - g_sg) * span
    assert abs(general - energy) <= 1e-12 * abs(energy) + 1e-14
    return Cap(theta, radius, span, 2.0 * radius * theta, g_gl / radius, energy)


def pinned_angle(area: float, span: float) -> float:
    """Half-angle of the arc through (0,0), (span,0) enclosing ``area`` above the table.

    With R = a / (2 sin t): A / a² = (t - sin(2t)/2) / (4 sin² t), increasing on (0, pi).
    Solved by Newton on t with a bracketing safeguard.
    """
    target = area / span ** 2

    def h(t):
        return (t - 0.5 * math.sin(2.0 * t)) / (4.0 * math.sin(t) ** 2) - target

    lo, hi = 1e-9, math.pi - 1e-9
    t = 0.5 * math.pi
    for _ in range(200):
        ht = h(t)
        if ht > 0:
            hi = t
        else:
            lo = t
        # dh/dt by a central difference (sufficient: the bracket guarantees progress)
        d = 1e-7
        slope = (h(t + d) - h(t - d)) / (2 * d)
        nt = t - ht / slope if slope > 0 else 0.5 * (lo + hi)
        if not (lo < nt < hi):
            nt = 0.5 * (lo + hi)
        if abs(nt - t) < 1e-16:
            t = nt
            break
        t = nt
    return t


def pinned_cap(g_gl: float, g_sl: float, g_sg: float, area: float, span: float) -> Cap:
    """Minimiser with a pinned span: the circular arc through the two contact points."""
    theta = pinned_angle(area, span)
    radius = span / (2.0 * math.sin(theta))
    assert abs(cap_area(theta, radius) - area) <= 1e-11 * area
    arc = 2.0 * radius * theta
    return Cap(theta, radius, span, arc, g_gl / radius, g_gl * arc + (g_sl - g_sg) * span)


def droplet_errors(sol, cap: Cap) -> dict:
    """Errors of a DropletSolution against an independent oracle (same definitions as documented)."""
    circ = cap.circle()
    return {
        "shape": float(np.max(np.abs(circ.distance(sol.x, sol.y)))) / cap.radius,
        "contact_angle": abs(sol.contact_angle - cap.theta),
        "span": abs(sol.span - cap.span) / cap.span,
        "energy": abs(sol.energy - cap.energy) / abs(cap.energy),
        "pressure": abs(sol.pressure - cap.pressure) / cap.pressure,
    }


# ----------------------------------------------------------------------------- mechanics oracles
def free_fall(t, x0, xT, T: float, g: float):
    """Free flight under gravity ``-g e_y`` from ``x0`` at t = 0 to ``xT`` at t = T.

    ``ẍ = 0, ÿ = -g`` with both ends fixed: the unique solution is the chord plus
    the parabola that vanishes at both ends, ``y = chord_y(t) - g t (t - T) / 2``
    (check: ``ÿ = -g``, zero correction at t = 0 and t = T).  Returns
    ``(q, qd)`` of shape ``(len(t), 2)``.
    """
    t = np.asarray(t, dtype=float)
    x0, xT = np.asarray(x0, float), np.asarray(xT, float)
    q = x0[None, :] + (t[:, None] / T) * (xT - x0)[None, :]
    q[:, 1] -= 0.5 * g * t * (t - T)
    qd = np.tile((xT - x0) / T, (t.size, 1))
    qd[:, 1] -= 0.5 * g * (2.0 * t - T)
    return q, qd


def sampled_frequency(eta, h: float) -> float:
    """Angular frequency of a uniformly sampled sinusoid ``eta_k = a cos(w t_k) + b sin(w t_k)``.

    Any such sequence satisfies ``eta_{k+1} + eta_{k-1} = 2 cos(w h) eta_k`` exactly;
    ``cos(w h)`` is fitted by least squares over all interior samples.
    """
    eta = np.asarray(eta, dtype=float)
    c = np.sum(eta[1:-1] * (eta[2:] + eta[:-2])) / (2.0 * np.sum(eta[1:-1] ** 2))
    return math.acos(c) / h


def pendulum_rod_force(m: float, l: float, g: float, theta, omega):
    """Magnitude of the rod force on a pendulum bob (theta from the downward vertical).

    Radial balance: ``T - m g cos(theta) = m l omega²`` (centripetal), so
    ``T = m (g cos(theta) + l omega²)``.  For the constraint ``c = (x² + y² - l²)/2``
    (``∇c = (x, y)``, length ``l``) the force ``-λ ∇c`` equals the tension pulling the
    bob towards the pivot when ``λ = T / l``.
    """
    return m * (g * np.cos(theta) + l * np.asarray(omega) ** 2)


def energy_growth(dE, fraction: float = 0.1):
    """``(second half / first half, last fraction / first fraction)`` of max |energy error|."""
    dE = np.abs(np.asarray(dE, dtype=float))
    half = dE.size // 2
    k = max(1, int(round(fraction * dE.size)))
    return dE[half:].max() / dE[:half].max(), dE[-k:].max() / dE[:k].max()


def run_tutorial_command(command: str, tmp_path, root) -> None:
    """Run one ``castrajectory …`` command of a tutorial in a scratch folder holding a copy of examples/, and
    check it exits 0 and writes every picture or document it names."""
    import os
    import shlex
    import shutil
    import subprocess
    import sys
    shutil.copytree(os.path.join(root, "examples"), tmp_path / "examples")
    argv = shlex.split(command)
    assert argv[0] == "castrajectory"
    p = subprocess.run([sys.executable, "-m", "castrajectory.cli", *argv[1:]], capture_output=True, text=True,
                       cwd=tmp_path, env={**os.environ, "MPLBACKEND": "Agg"}, timeout=600)
    assert p.returncode == 0, p.stderr
    for token in argv:
        if token.endswith((".png", ".gif", ".md")):
            assert (tmp_path / token).stat().st_size > 0
