"""A two-dimensional droplet on a table (Exercise 2.1): calculus of variations as an NLP.

Physics
-------
A drop of cross-sectional area ``A`` sits on the table ``y = 0`` and touches it
on ``0 <= x <= a``.  Up to the constant ``gamma_sg * L`` its energy is

    E = gamma_gl * S + (gamma_sl - gamma_sg) * a,          S = length of the free surface,

minimised subject to ``∫ y dx = A``.  The Euler–Lagrange equation makes the free
surface a circular arc of curvature ``lambda / gamma_gl`` (``lambda`` the area
multiplier, the Laplace pressure); with ``a`` free, the contact angle obeys
Young's equation ``gamma_gl cos(theta) + gamma_sl - gamma_sg = 0``.  The
derivation is in ``docs/derivations.md``.

Layers
------
* describe: :class:`Droplet` (tensions, area, optional fixed span) and its
  analytic oracle :func:`analytic` (a :class:`CircularCap`);
* discretise: :class:`Curve` (polyline ``(x_i, y_i)`` with equal segments,
  every ``theta`` in ``(0, pi)``) and :class:`Graph` (``y(x_i)`` on a uniform
  grid, ``theta < 90°``);
* solve: :func:`solve` builds one :class:`~castrajectory.nlp.NLP` and returns a
  :class:`DropletSolution` with the errors against the oracle;
* the reduced one-dimensional problem in ``theta`` is :func:`solve_angle`.

All NLPs are posed in units where ``A = 1`` and ``gamma_gl = 1`` (length unit
``sqrt(A)``, energy unit ``gamma_gl sqrt(A)``); results are converted back.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Dict, Optional

import casadi as ca
import numpy as np

from .nlp import NLP, Constraint, X
from .result import Result
from .validation import InputError, finite, integer_at_least, one_of, positive

FORMULATIONS = ("curve", "graph")
#: Ipopt options for the droplet NLPs.  ``constr_mult_init_max = 0`` starts every constraint multiplier
#: at zero instead of Ipopt's least-squares estimate: at the default guesses that estimate of the area
#: multiplier is far off (-0.48 against -1.72 for a pinned span), the first step then overshoots and
#: Ipopt spends dozens of iterations with a huge Hessian regularisation (measured: graph at 20° and
#: N = 100 failed; pinned overhanging curves needed iterations growing with N).  Zero multipliers made
#: every case of a 2°–178° sweep converge in at most 15 iterations.  ``mu_init = 1e-9``: the only
#: inequality is the free span's ``a >= 1e-8``, far from active, so the barrier has nothing to do and
#: Ipopt's default ``mu_init = 0.1`` only costs iterations spent lowering it (a sweep over both forms,
#: 2°–178°, N = 8–2000 and pinned spans: 478 -> 438 iterations in total, 22 cases fewer, 1 case one more).
SOLVER_OPTIONS = {"constr_mult_init_max": 0.0, "mu_init": 1e-9}
#: Smallest number of segments: the contact-angle estimator needs two chords per end.
MIN_N = 3


# ---------------------------------------------------------------------------- describe
@dataclass(frozen=True)
class Droplet:
    """The scene: tensions, area and (optionally) a pinned span ``a``.

    Free span (``span=None``) requires partial wetting,
    ``|gamma_sg - gamma_sl| < gamma_gl``; see :meth:`validate`.
    """

    gamma_gl: float = 1.0
    gamma_sl: float = 0.5
    gamma_sg: float = 1.0
    area: float = 1.0
    span: Optional[float] = None

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
        return math.sqrt(self.area)

    def validate(self) -> None:
        positive("gamma_gl", self.gamma_gl)
        finite("gamma_sl", self.gamma_sl)
        finite("gamma_sg", self.gamma_sg)
        positive("area", self.area)
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


def analytic(drop: Droplet) -> CircularCap:
    """The exact minimiser: Young's angle for a free span, the arc through (0,0),(a,0) for a fixed one."""
    if drop.span is None:
        theta = young_angle(drop.gamma_gl, drop.gamma_sl, drop.gamma_sg)
        radius = math.sqrt(drop.area / segment_area_factor(theta))
    else:
        theta = _angle_from_aspect(drop.area / drop.span ** 2)
        radius = drop.span / (2.0 * math.sin(theta))
    return CircularCap(theta, radius, drop.gamma_gl, drop.wetting)


# ---------------------------------------------------------------------------- discretise
@dataclass
class Geometry:
    """What a discretisation leaves in the NLP: where the vertices are, and how to read them back.

    ``x_index``/``y_index`` are the positions of the ``n + 1`` vertex coordinates in
    the decision vector (the contact points, and a pinned span, are unknowns fixed
    by their bounds; Ipopt removes fixed unknowns, so the problem it solves has
    only the free ones).  ``span_index`` is the position of the span ``a``.
    """

    x_index: Optional[np.ndarray]
    y_index: np.ndarray
    span_index: int
    span: object  # the span's symbol (for the wetting term of the energy)
    graph_n: Optional[int] = None  # graph form: x_i = i a / n (x is not stored)

    def vertices(self, res: Result):
        """``(x, y, span)`` in scaled units from a result of this NLP."""
        x = res.x[self.x_index] if self.graph_n is None else \
            res.x[self.span_index] * np.arange(self.graph_n + 1) / self.graph_n
        return x, res.x[self.y_index], float(res.x[self.span_index])


#: Scene-independent element functions (built once; the same functions serve every size, so their
#: compiled code, see :mod:`castrajectory.jit`, is cached once).
_ELEMENTS: Dict[str, ca.Function] = {}


def _element(name: str) -> ca.Function:
    if name not in _ELEMENTS:
        p0, p1, p2 = ca.SX.sym("p0", 2), ca.SX.sym("p1", 2), ca.SX.sym("p2", 2)
        y0, y1, a, n = ca.SX.sym("y0"), ca.SX.sym("y1"), ca.SX.sym("a"), ca.SX.sym("n")
        c0, c1, s = ca.SX.sym("c0"), ca.SX.sym("c1"), ca.SX.sym("s")
        sq = lambda u, v: ca.sumsqr(v - u)  # noqa: E731
        tri = 0.5 * (p1[0] * p0[1] - p0[0] * p1[1])  # shoelace piece of the chord p0 -> p1
        trap = 0.5 * (a / n) * (y0 + y1)  # trapezoid piece of the cell [y0, y1]
        fns = {
            # curve: chord length, equal consecutive chords (scaled by s), area link, shoelace piece
            "chord": ([p0, p1], ca.sqrt(sq(p0, p1))),
            "equal_chords": ([p0, p1, p2, s], s * (sq(p1, p2) - sq(p0, p1))),
            "curve_link": ([c0, c1, p0, p1, n], n * (c1 - c0 - tri)),
            "curve_last": ([c0, p0, p1, n], c0 + tri),
            # graph: cell length, area link, trapezoid piece
            "cell": ([y0, y1, a, n], ca.sqrt((a / n) ** 2 + (y1 - y0) ** 2)),
            "graph_link": ([c0, c1, y0, y1, a, n], n * (c1 - c0 - trap)),
            "graph_last": ([c0, y0, y1, a, n], c0 + trap),
        }
        for key, (args, out) in fns.items():
            _ELEMENTS[key] = ca.Function(key, args, [out])
    return _ELEMENTS[name]


def _cumulative_area(nlp: NLP, link: str, last: str, args, init_pieces) -> Constraint:
    """Area as a running sum ``c_k = c_{k-1} + t_k`` with ``c`` as unknowns, ending in the ``area`` row.

    Summing all ``n`` pieces into one constraint would give the Jacobian a dense
    row; the running sum keeps every row local (a banded KKT matrix), and the
    multiplier of the last link (the ``area`` constraint) is still ``dE*/dA``.
    ``args(rows)`` returns the element arguments of the pieces ``rows``; the links
    are ``n (c_k - c_{k-1} - t_{k-1}) = 0`` for ``k = 1..n-1`` with ``c_0 = 0``.
    """
    n = init_pieces.size
    init = np.concatenate([[0.0], np.cumsum(init_pieces)[:-1]])
    lb = np.full(n, -np.inf)
    lb[0] = 0.0
    nlp.variable("partial_area", n, lb=lb, ub=-lb, init=init)  # c_0 fixed at 0 by its bounds
    c = nlp.index("partial_area")
    k = np.arange(1, n)
    nn = np.array([float(n)])
    nlp.equal_elements("area_links", _element(link), [X(c[k - 1, None]), X(c[k, None]), *args(k - 1), nn])
    return nlp.equal_elements("area", _element(last), [X(c[n - 1:]), *args(np.array([n - 1])), nn], 1.0)


def _fixed(values, free):
    """Bounds that fix every entry where ``free`` is False at ``values``."""
    values = np.asarray(values, dtype=float)
    lb = np.where(free, -np.inf, values)
    return lb, np.where(free, np.inf, values)


class Curve:
    """Polyline ``(x_i, y_i)``, ``i = 0..n``, from contact point to contact point.

    Unknowns: the ``n - 1`` interior vertices and the span ``a = x_n`` (unless
    pinned).  Constraints: consecutive segments have equal length,
    ``(|p_{i+1} - p_i|² - |p_i - p_{i-1}|²) / (2 l_ref²) = 0`` (a gauge
    condition that removes the tangential sliding of vertices; stationarity
    alone already makes the chords equal, so its multipliers are zero at the
    optimum and it only conditions the Newton systems), and the shoelace area.  The length is the sum of
    the segment lengths.  No graph assumption is made, so overhanging drops
    (``theta > 90°``) are fine.

    Every piece is an element family of :class:`~castrajectory.nlp.NLP` (one chord,
    one pair of chords, one area link), differentiated once per element type.

    Default initial guess: the half-disc (``theta = 90°``) of the given area,
    or the half-ellipse of the given area over a pinned span; neither uses the
    answer (Young's angle or the pinned arc).
    """

    name = "curve"

    def __init__(self, n: int, guess: Optional[np.ndarray] = None):
        self.n = n
        self.guess = guess  # (n + 1, 2) vertices in scaled units, or None for the default

    def build(self, nlp: NLP, span: Optional[float]) -> Geometry:
        n = self.n
        if self.guess is not None:
            guess = np.array(self.guess, dtype=float)
        elif span is None:
            guess = arc_points(0.5 * math.pi, math.sqrt(1.0 / segment_area_factor(0.5 * math.pi)), n)
        else:  # half-ellipse of area 1 over the pinned span, resampled to equal arc length
            phi = np.linspace(math.pi, 0.0, 64 * n + 1)
            ell = np.column_stack([0.5 * span * (1.0 + np.cos(phi)), 4.0 / (math.pi * span) * np.sin(phi)])
            s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(ell, axis=0).T))])
            t = np.linspace(0.0, s[-1], n + 1)
            guess = np.column_stack([np.interp(t, s, ell[:, 0]), np.interp(t, s, ell[:, 1])])
        guess[0] = 0.0
        guess[-1, 1] = 0.0
        if span is not None:
            guess[-1, 0] = span
        seg0 = float(np.hypot(*np.diff(guess, axis=0).T).mean())
        free = np.ones(n + 1, dtype=bool)
        free[0] = False
        free_x = free.copy()
        free[-1] = False
        if span is not None:
            free_x[-1] = False
        lbx, ubx = _fixed(guess[:, 0], free_x)
        if span is None:
            lbx[-1] = 1e-8
        xs = nlp.variable("x", n + 1, lb=lbx, ub=ubx, init=guess[:, 0])
        nlp.variable("y", n + 1, *_fixed(guess[:, 1], free), init=guess[:, 1])
        P = np.column_stack([nlp.index("x"), nlp.index("y")])  # (n + 1, 2) positions of the vertices
        k = np.arange(n)
        nlp.minimize_elements("length", _element("chord"), [X(P[k]), X(P[k + 1])])
        j = np.arange(n - 1)
        nlp.equal_elements("equal_segments", _element("equal_chords"),
                           [X(P[j]), X(P[j + 1]), X(P[j + 2]), np.array([1.0 / (2.0 * seg0 ** 2)])])
        gx, gy = guess[:, 0], guess[:, 1]
        _cumulative_area(nlp, "curve_link", "curve_last", lambda r: [X(P[r]), X(P[r + 1])],
                         0.5 * (gx[1:] * gy[:-1] - gx[:-1] * gy[1:]))
        return Geometry(P[:, 0], P[:, 1], int(P[-1, 0]), xs[n])


class Graph:
    """Graph ``y(x_i)`` on the uniform grid ``x_i = i h``, ``h = a / n``, of ``[0, a]``.

    Unknowns: the ``n - 1`` interior heights and the span ``a`` (unless pinned).  Length
    ``sum sqrt(h² + (y_{i+1} - y_i)²)``, area by the trapezoid rule.  A graph
    cannot overhang: contact angles of 90° or more are refused.

    Default initial guess: the cap of contact angle 45° and the given area, or
    the parabola of the given area over a pinned span; neither uses the answer.
    """

    name = "graph"
    guess_angle = 0.25 * math.pi

    def __init__(self, n: int):
        self.n = n

    def build(self, nlp: NLP, span: Optional[float]) -> Geometry:
        n = self.n
        if span is None:
            t = self.guess_angle
            radius = math.sqrt(1.0 / segment_area_factor(t))
            a0 = 2.0 * radius * math.sin(t)
            xs = a0 * np.arange(n + 1) / n
            ys = np.sqrt(np.maximum(radius ** 2 - (xs - 0.5 * a0) ** 2, 0.0)) - radius * math.cos(t)
        else:  # parabola over the pinned span with area 1
            a0 = span
            xs = a0 * np.arange(n + 1) / n
            ys = 6.0 / a0 ** 3 * xs * (a0 - xs)
        ys = np.maximum(ys, 0.0)
        ys[[0, -1]] = 0.0
        free = np.ones(n + 1, dtype=bool)
        free[[0, -1]] = False
        nlp.variable("y", n + 1, *_fixed(ys, free), init=ys)
        if span is None:
            a = nlp.variable("span", 1, lb=1e-8, init=a0)
        else:
            a = nlp.variable("span", 1, lb=span, ub=span, init=span)
        Y, A = nlp.index("y")[:, None], nlp.index("span")
        nn = np.array([float(n)])
        k = np.arange(n)
        nlp.minimize_elements("length", _element("cell"), [X(Y[k]), X(Y[k + 1]), X(A), nn])
        _cumulative_area(nlp, "graph_link", "graph_last", lambda r: [X(Y[r]), X(Y[r + 1]), X(A)],
                         0.5 * (a0 / n) * (ys[:-1] + ys[1:]))
        return Geometry(None, Y[:, 0], int(A[0]), a, graph_n=n)


DISCRETISATIONS = {"curve": Curve, "graph": Graph}


# ---------------------------------------------------------------------------- inspect helpers
def contact_angle_estimate(x, y) -> float:
    """Contact angle from the vertices, second-order accurate in 1/N.

    The first chord's angle ``phi_0`` is the tangent angle at the chord's
    middle, half a segment inside the contact point, so it lags the contact
    angle by half the turning per segment (about ``theta / N``).  Extrapolating
    the chord angles ``phi_0, phi_1`` linearly in arc length to the contact
    point removes that lag; the estimate is exact for vertices on a circle with
    equal chords.  Both ends are estimated (the right end mirrored) and
    averaged.
    """
    x, y = np.asarray(x, float), np.asarray(y, float)

    def one_end(px, py):
        dx, dy = np.diff(px[:3]), np.diff(py[:3])
        phi = np.arctan2(dy, dx)
        l0, l1 = np.hypot(dx[0], dy[0]), np.hypot(dx[1], dy[1])
        return phi[0] + (phi[0] - phi[1]) * l0 / (l0 + l1)

    left = one_end(x, y)
    right = one_end(-(x[::-1] - x[-1]), y[::-1])
    return 0.5 * (left + right)


# ---------------------------------------------------------------------------- solve
@dataclass
class DropletSolution:
    """The discrete drop, its physical readings and their errors against the oracle."""

    drop: Droplet
    formulation: str
    n: int
    result: Result
    x: np.ndarray
    y: np.ndarray
    contact_angle: float
    span: float
    pressure: float
    energy: float
    young_residual: Optional[float]
    analytic: CircularCap
    errors: Dict[str, float] = field(default_factory=dict)

    @property
    def success(self) -> bool:
        return self.result.success

    @property
    def status(self) -> str:
        return "ok" if self.result.success else self.result.status

    def as_dict(self) -> dict:
        """The JSON object of ``problems/droplet.py --json``."""
        r = self.result
        return {
            "status": self.status,
            "message": r.message,
            "formulation": self.formulation,
            "n": self.n,
            "mode": "free-span" if self.drop.span is None else "fixed-span",
            "iterations": r.iterations,
            "build_time_s": r.build_time_s,
            "solve_time_s": r.solve_time_s,
            "contact_angle": self.contact_angle,
            "span": self.span,
            "pressure": self.pressure,
            "energy": self.energy,
            "young_residual": self.young_residual,
            "analytic": self.analytic.as_dict(),
            "errors": dict(self.errors),
            "x": self.x.tolist(),
            "y": self.y.tolist(),
        }


def resample_polyline(x: np.ndarray, y: np.ndarray, n: int) -> np.ndarray:
    """``n + 1`` points equally spaced in arclength along the polyline ``(x, y)`` (ends kept)."""
    s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))])
    t = np.linspace(0.0, s[-1], n + 1)
    return np.column_stack([np.interp(t, s, x), np.interp(t, s, y)])


#: Coarse grid of the fallback ladder (see :func:`solve`).
COARSE_N = 40
#: Iteration budget of the direct curve solve before the ladder takes over.
FIRST_ATTEMPT_MAX_ITER = 30
#: Curve solves with at least this many segments start from a coarse solve on PRESOLVE_N segments.
PRESOLVE_MIN_N = 2000
PRESOLVE_N = 200


def _check_formulation(drop: Droplet, formulation: str) -> None:
    one_of("formulation", formulation, FORMULATIONS)
    cap = analytic(drop)
    if formulation == "graph" and cap.contact_angle >= 0.5 * math.pi:
        raise InputError(
            f"the graph formulation y(x) cannot represent contact angles of 90 degrees or more "
            f"(this drop's angle is {math.degrees(cap.contact_angle):.4g} degrees); use the curve formulation")


def make_nlp(drop: Droplet, n: int, formulation: str = "curve", guess: Optional[np.ndarray] = None):
    """Build (but do not solve) the droplet NLP in scaled units; return ``(nlp, geometry, area_constraint)``."""
    n = integer_at_least("n", n, MIN_N)
    _check_formulation(drop, formulation)
    L = drop.length_scale
    nlp = NLP()
    disc = Curve(n, guess) if formulation == "curve" else DISCRETISATIONS[formulation](n)
    # The scene's terms: surface tension (the length elements, added by the discretisation) always;
    # the wetting term only when the span is free and it is non-zero.
    geo = disc.build(nlp, None if drop.span is None else drop.span / L)
    w = drop.wetting / drop.gamma_gl
    if drop.span is None and w != 0.0:
        nlp.minimize(w * geo.span)
    return nlp, geo, nlp.constraint("area")


def solve(drop: Droplet, n: int = 400, formulation: str = "curve", *, options: Optional[dict] = None,
          verbose: bool = False) -> DropletSolution:
    """Minimise the discrete droplet energy; never raises on non-convergence (see ``Result``).

    Strategy (curve form):

    * from ``PRESOLVE_MIN_N`` segments on, the drop is first solved on ``PRESOLVE_N``
      segments (from the default guess) and that polyline, resampled by arclength,
      starts the fine solve: it then needs about half the Newton iterations, and each
      fine iteration costs far more than the whole coarse solve;
    * if a solve fails, a ladder of coarser solves (``COARSE_N``, doubling up to ``n``) is run,
      each resampled by arclength as the next guess.

    The reported times and iterations include every solve; the status is that of the
    final solve at ``n``.
    """
    n = integer_at_least("n", n, MIN_N)
    _check_formulation(drop, formulation)
    opts = {**SOLVER_OPTIONS, **(options or {})}
    res, nlp, geo = _solve_scaled(drop, n, formulation, opts, verbose)
    L, g = drop.length_scale, drop.gamma_gl
    xs, ys, span = geo.vertices(res)
    x, y = L * xs, L * ys
    span, length = L * span, L * float(np.sum(np.hypot(np.diff(xs), np.diff(ys))))
    cap = analytic(drop)
    theta = contact_angle_estimate(x, y)
    pressure = g / L * float(res.multipliers["area"][0])
    energy = g * length + drop.wetting * span
    young = None if drop.span is not None else g * math.cos(theta) + drop.wetting
    errors = {
        "shape": float(np.max(np.abs(cap.distance(x, y)))) / cap.radius,
        "contact_angle": abs(theta - cap.contact_angle),
        "span": abs(span - cap.span) / cap.span,
        "energy": abs(energy - cap.energy) / abs(cap.energy),
        "pressure": abs(pressure - cap.pressure) / cap.pressure,
    }
    return DropletSolution(drop, formulation, n, res, x, y, theta, span, pressure, energy, young, cap, errors)


def _solve_scaled(drop: Droplet, n: int, formulation: str, opts: dict, verbose: bool):
    """The strategy of :func:`solve`; returns ``(result, nlp, geometry)`` in scaled units."""
    ladder = formulation == "curve" and n > COARSE_N
    first = dict(opts)
    if ladder:  # a good start converges in <= 15 iterations; do not spend a long failing run
        first["max_iter"] = min(int(opts.get("max_iter", 200)), FIRST_ATTEMPT_MAX_ITER)
    guess, spent = None, []
    if formulation == "curve" and n >= PRESOLVE_MIN_N:
        coarse, cnlp, cgeo = _solve_scaled(drop, PRESOLVE_N, "curve", opts, verbose)
        spent.append(coarse)
        if coarse.success:
            xs, ys, _ = cgeo.vertices(coarse)
            guess = resample_polyline(xs, ys, n)
    nlp, geo, _ = make_nlp(drop, n, formulation, guess)
    res = nlp.solve(options=first, verbose=verbose)
    if not res.success and ladder:
        res, nlp, geo = _coarse_to_fine(drop, n, opts, verbose, res)
    for r in spent:
        res.build_time_s += r.build_time_s
        res.solve_time_s += r.solve_time_s
        res.iterations += r.iterations
    return res, nlp, geo


def _coarse_to_fine(drop: Droplet, n: int, opts: dict, verbose: bool, failed: Result):
    """Fallback ladder COARSE_N, 2 COARSE_N, ..., n; every solve's time and iterations are counted."""
    build, solve_t, iters = failed.build_time_s, failed.solve_time_s, failed.iterations
    guess, m = None, COARSE_N
    while True:
        nlp, geo, _ = make_nlp(drop, m, "curve", guess)
        res = nlp.solve(options=opts, verbose=verbose)
        build, solve_t, iters = build + res.build_time_s, solve_t + res.solve_time_s, iters + res.iterations
        if not res.success or m == n:
            break
        xs, ys, _ = geo.vertices(res)
        m = min(2 * m, n)
        guess = resample_polyline(xs, ys, m)
    res.build_time_s, res.solve_time_s, res.iterations = build, solve_t, iters
    return res, nlp, geo


# ---------------------------------------------------------------------------- reduced problem in theta
@dataclass
class AngleSolution:
    """Minimiser of the reduced energy ``E(theta)``."""

    drop: Droplet
    result: Result
    contact_angle: float
    radius: float
    span: float
    energy: float
    young_residual: float
    energy_function: ca.Function  # theta -> E(theta), physical units

    @property
    def success(self) -> bool:
        return self.result.success

    @property
    def status(self) -> str:
        return "ok" if self.result.success else self.result.status

    def as_dict(self) -> dict:
        return {"status": self.status, "message": self.result.message, "contact_angle": self.contact_angle,
                "young_residual": self.young_residual, "radius": self.radius, "span": self.span,
                "energy": self.energy, "iterations": self.result.iterations,
                "build_time_s": self.result.build_time_s, "solve_time_s": self.result.solve_time_s}


def reduced_energy(drop: Droplet):
    """``E(theta)`` as a CasADi function: ``R = sqrt(A / (theta - sin(2 theta)/2))``, ``a = 2 R sin theta``,
    ``S = 2 R theta``, ``E = gamma_gl S + (gamma_sl - gamma_sg) a``."""
    th = ca.SX.sym("theta")
    R = ca.sqrt(drop.area / segment_area_factor(th))
    E = drop.gamma_gl * 2.0 * R * th + drop.wetting * 2.0 * R * ca.sin(th)
    return ca.Function("E", [th], [E], ["theta"], ["E"]), ca.Function("R", [th], [R])


def solve_angle(drop: Droplet, *, options: Optional[dict] = None, verbose: bool = False) -> AngleSolution:
    """Minimise ``E(theta)`` over ``theta`` in ``(0, pi)`` as a one-variable NLP (scaled: A = gamma_gl = 1)."""
    if drop.span is not None:
        raise InputError("the reduced problem in theta is posed for a free span; drop the span")
    unit = Droplet(1.0, drop.wetting / drop.gamma_gl, 0.0, 1.0)
    E_unit, _ = reduced_energy(unit)
    nlp = NLP()
    th = nlp.variable("theta", 1, lb=1e-6, ub=math.pi - 1e-6, init=0.5 * math.pi)
    nlp.minimize(E_unit(th))
    res = nlp.solve(options={"tol": 1e-12, **(options or {})}, verbose=verbose)
    theta = float(res["theta"][0])
    E, Rf = reduced_energy(drop)
    radius = float(Rf(theta))
    return AngleSolution(drop, res, theta, radius, 2.0 * radius * math.sin(theta), float(E(theta)),
                         drop.gamma_gl * math.cos(theta) + drop.wetting, E)
