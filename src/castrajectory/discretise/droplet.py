"""The droplet's discretisations: the polyline ``curve`` and the height ``graph``, as element families.

* :class:`Curve`: polyline ``(x_i, y_i)`` with equal segments, every contact angle in ``(0, pi)``;
* :class:`Graph`: heights ``y(x_i)`` on a uniform grid, contact angles below 90°;
* :class:`Revolution`: the half profile ``(r_i, z_i)`` of a drop of revolution, from the apex on the axis
  to the contact line, with equal chords; surface, volume and weight weighted by ``2 pi r`` (Pappus).

Each writes its unknowns and rows (surface length, equal chords, the area) into a
:class:`~castrajectory.discretise.program.Program` in scaled units (``A = 1``,
``gamma_gl = 1``) and returns the :class:`Geometry` that reads the vertices back.
A scene adds the terms it needs on top: :func:`add_gravity` (the weight, over the same pieces
as the area), :func:`add_pattern` (the wetting energy of a patterned table, split at its step).
:func:`contact_angle_estimate` reads the contact angle off the vertices to second order.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, Optional

import casadi as ca
import numpy as np

from ..models.droplet import arc_points, segment_area_factor
from .program import Constraint, P, Program, X

#: The discretisations by name (:data:`DISCRETISATIONS` holds their classes).
FORMULATIONS = ("curve", "graph", "spectral")  # spectral: discretise/droplet_spectral.py
#: The formulations whose error is a power of N (the polylines): what the convergence studies sweep (the
#: spectral profile holds a weightless drop to rounding at every degree).
POLYLINES = ("curve", "graph")

#: Smallest number of segments: the contact-angle estimator needs two chords per end.
MIN_N = 3

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
    #: the element arguments of the area's pieces (one per chord or cell), and the element that gives a
    #: piece's first moment ``∫∫ y dA`` (times a weight): what a term weighted by the liquid's height needs
    #: (a name of this module's elements, or the function itself)
    pieces: tuple = ()
    moment: object = ""
    #: the wetted measure as an expression of the span's symbol, where it is not the span itself (a drop of
    #: revolution: the disc ``pi r_c²``); None: the span (2-D)
    wetted: object = None

    def vertices(self, res):
        """``(x, y, span)`` in scaled units from a result of this NLP."""
        x = res.x[self.x_index] if self.graph_n is None else \
            res.x[self.span_index] * np.arange(self.graph_n + 1) / self.graph_n
        return x, res.x[self.y_index], float(res.x[self.span_index])


#: Scene-independent element functions (built once; the same functions serve every size, so their
#: compiled code, see :mod:`castrajectory.solve.jit`, is cached once).
_ELEMENTS: Dict[str, ca.Function] = {}


def _element(name: str) -> ca.Function:
    if name not in _ELEMENTS:
        p0, p1, p2 = ca.SX.sym("p0", 2), ca.SX.sym("p1", 2), ca.SX.sym("p2", 2)
        y0, y1, a, n = ca.SX.sym("y0"), ca.SX.sym("y1"), ca.SX.sym("a"), ca.SX.sym("n")
        c0, c1, s = ca.SX.sym("c0"), ca.SX.sym("c1"), ca.SX.sym("s")
        sq = lambda u, v: ca.sumsqr(v - u)  # noqa: E731
        tri = 0.5 * (p1[0] * p0[1] - p0[0] * p1[1])  # shoelace piece of the chord p0 -> p1
        # the area under the chord p0 -> p1, ∫ y dx: the same sum as the shoelace's over a curve that starts and
        # ends on the table y = 0, but free of the origin (a puddle 100 long and 0.01 high: x y products of
        # order 1 cancelling to 1e-4 pieces in the shoelace)
        under = 0.5 * (p1[0] - p0[0]) * (p0[1] + p1[1])
        trap = 0.5 * (a / n) * (y0 + y1)  # trapezoid piece of the cell [y0, y1]
        fns = {
            # curve: chord length, equal consecutive chords (scaled by s), area link, the area under the chord
            "chord": ([p0, p1], ca.sqrt(sq(p0, p1))),
            "equal_chords": ([p0, p1, p2, s], s * (sq(p1, p2) - sq(p0, p1))),
            # graded chords: consecutive chords in the ratio w1 : w0 (c0, c1 the weights, held as c0 and c1)
            "graded_chords": ([p0, p1, p2, s, c0, c1], s * (sq(p1, p2) / (c1 * c1) - sq(p0, p1) / (c0 * c0))),
            "curve_link": ([c0, c1, p0, p1, n], n * (c1 - c0 - under)),
            "curve_last": ([c0, p0, p1, n], c0 + under),
            # graph: cell length, area link, trapezoid piece
            "cell": ([y0, y1, a, n], ca.sqrt((a / n) ** 2 + (y1 - y0) ** 2)),
            "graph_link": ([c0, c1, y0, y1, a, n], n * (c1 - c0 - trap)),
            "graph_last": ([c0, y0, y1, a, n], c0 + trap),
            # first moments ∫∫ y dA of a piece, times the weight w: exact for the polygon (the chord's or the
            # trapezoid cell's ∫ y²/2 dx)
            "curve_moment": ([p0, p1, s], s * (p1[0] - p0[0]) * (p0[1] * p0[1] + p0[1] * p1[1] + p1[1] * p1[1]) / 6.0),
            "graph_moment": ([y0, y1, a, n, s], s * (a / n) * (y0 * y0 + y0 * y1 + y1 * y1) / 6.0),
            # a drop of revolution (p = (r, z)): the chord's frustum, pi (r0 + r1) l; the volume the shoelace
            # triangle (0, p0, p1) sweeps about the axis, 2 pi tri (r0 + r1) / 3 (Pappus: its centroid is at
            # r = (r0 + r1) / 3); its first moment 2 pi ∫∫ r z dA (the triangle's edge-midpoint rule, exact
            # for the quadratic r z), times the weight s
            "frustum": ([p0, p1], math.pi * (p0[0] + p1[0]) * ca.sqrt(sq(p0, p1))),
            "revolution_link": ([c0, c1, p0, p1, n], n * (c1 - c0 - 2.0 * math.pi / 3.0 * tri * (p0[0] + p1[0]))),
            "revolution_last": ([c0, p0, p1, n], c0 + 2.0 * math.pi / 3.0 * tri * (p0[0] + p1[0])),
            "revolution_moment": ([p0, p1, s], s * math.pi / 6.0 * tri * (
                2.0 * p0[0] * p0[1] + 2.0 * p1[0] * p1[1] + p0[0] * p1[1] + p1[0] * p0[1])),
        }
        for key, (args, out) in fns.items():
            _ELEMENTS[key] = ca.Function(key, args, [out])
    return _ELEMENTS[name]


def _cumulative_area(nlp: Program, link: str, last: str, args, init_pieces) -> Constraint:
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


def _chords(nlp: Program, P: np.ndarray, seg0: float, name: str, element: str,
            weights: Optional[np.ndarray] = None) -> np.ndarray:
    """A polyline's surface term ``name`` (one ``element`` per chord) and its gauge rows (scaled by the guess's
    mean chord ``seg0``): equal chords, or chords in the ratios of ``weights`` (one per chord, mean 1: see
    :func:`chord_weights`); returns the chords' indices."""
    k = np.arange(P.shape[0] - 1)
    nlp.minimize_elements(name, _element(element), [X(P[k]), X(P[k + 1])])
    j = np.arange(P.shape[0] - 2)
    scale = np.array([1.0 / (2.0 * seg0 ** 2)])
    if weights is None:
        nlp.equal_elements("equal_segments", _element("equal_chords"), [X(P[j]), X(P[j + 1]), X(P[j + 2]), scale])
    else:
        w = np.asarray(weights, dtype=float)[:, None]
        nlp.equal_elements("equal_segments", _element("graded_chords"),
                           [X(P[j]), X(P[j + 1]), X(P[j + 2]), scale, w[j], w[j + 1]])
    return k


def chord_weights(n: int, capillary: float, length: float) -> np.ndarray:
    """The chords of a heavy drop's polyline, graded toward its contact lines (mean 1, symmetric).

    Under gravity the curvature of a drop larger than its capillary length ``capillary`` (``l_c``, scaled
    units) gathers within a few ``l_c`` of each contact line and decays like ``exp(−σ/l_c)`` with the distance
    ``σ`` from it; the top is flat.  Equal chords then leave the contact line unresolved (Bond number 1e4,
    N = 400: chords of 25 l_c, a contact angle of 4.7° for Young's 60°).  The chords equidistribute the
    monitor ``M(σ) = 1/length + exp(−σ / 2 l_c) / (4 l_c)`` (``length``: an estimate of the whole curve's):
    ``M ∝ sqrt(κ)`` near the contact line (each chord's deviation ``κ h²`` from the curve alike), uniform
    where the drop is flat.  Each edge holds half as many nodes as the rest, whatever the Bond number (its
    chords ``8 l_c / N`` at the contact line once ``l_c`` is small against the drop), and as ``l_c`` grows
    beyond the drop the chords become equal.  The weights depend on the drop alone, not on ``n`` (a fixed map
    of the index: the error keeps its order 2)."""
    half_len = 0.5 * length

    def cumulative(sigma):  # ∫_0^σ M
        return sigma / length + 0.5 * (1.0 - np.exp(-sigma / (2.0 * capillary)))

    total = 2.0 * cumulative(half_len)
    targets = np.minimum(np.arange(n + 1), n - np.arange(n + 1)) / n * total  # from the nearer end
    lo, hi = np.zeros(n + 1), np.full(n + 1, half_len)
    for _ in range(100):  # bisection: cumulative is increasing
        mid = 0.5 * (lo + hi)
        below = cumulative(mid) < targets
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    sigma = 0.5 * (lo + hi)
    s = np.where(np.arange(n + 1) <= n / 2, sigma, length - sigma)
    w = np.diff(s)
    return w / w.mean()


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
    optimum and it only conditions the Newton systems; a heavy drop's chords are instead in the fixed
    ratios ``weights``, :func:`chord_weights`, graded toward the contact lines), and the area as the sum of
    the trapezoids under the chords.  The length is the sum of the segment lengths.  No graph assumption is
    made, so overhanging drops (``theta > 90°``) are fine.

    Every piece is an element family of :class:`~castrajectory.solve.nlp.NLP` (one chord,
    one pair of chords, one area link), differentiated once per element type.

    Default initial guess: the half-disc (``theta = 90°``) of the given area,
    or the half-ellipse of the given area over a pinned span; neither uses the
    answer (Young's angle or the pinned arc).
    """

    name = "curve"

    def __init__(self, n: int, guess: Optional[np.ndarray] = None, weights: Optional[np.ndarray] = None):
        self.n = n
        self.guess = guess  # (n + 1, 2) vertices in scaled units, or None for the default
        self.weights = weights  # the chords' ratios (chord_weights), or None: equal chords

    def build(self, nlp: Program, span: Optional[float]) -> Geometry:
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
        if self.weights is not None:  # every guess re-spaced along itself to the gauge's chords
            guess = respace_polyline(guess[:, 0], guess[:, 1], self.weights)
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
        k = _chords(nlp, P, seg0, "length", "chord", self.weights)
        gx, gy = guess[:, 0], guess[:, 1]
        _cumulative_area(nlp, "curve_link", "curve_last", lambda r: [X(P[r]), X(P[r + 1])],
                         0.5 * (gx[1:] - gx[:-1]) * (gy[:-1] + gy[1:]))
        return Geometry(P[:, 0], P[:, 1], int(P[-1, 0]), xs[n], pieces=(X(P[k]), X(P[k + 1])),
                        moment="curve_moment")


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

    def build(self, nlp: Program, span: Optional[float]) -> Geometry:
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
        return Geometry(None, Y[:, 0], int(A[0]), a, graph_n=n, pieces=(X(Y[k]), X(Y[k + 1]), X(A), nn),
                        moment="graph_moment")


class Revolution:
    """A drop of revolution: its half profile ``(r_i, z_i)``, ``i = 0..n``, from the apex ``(0, h)`` on the
    axis to the contact line ``(r_c, 0)``, with equal chords (the :class:`Curve`'s gauge).

    The axis: ``r_0 = 0`` is fixed by its bounds and ``z_0`` (the height) is free.  Nothing else is imposed
    there: the symmetry condition (the profile horizontal at the apex) is natural, since every term carries
    the weight ``2 pi r``, which vanishes on the axis (``docs/derivations.md``, Droplet §10).

    Every term is a sum over chords, exact for the polyline of revolution (a stack of cone frusta): the
    surface ``sum pi (r_i + r_{i+1}) l_i`` (the ``surface`` family), the volume as a running sum of the
    swept shoelace triangles (the constraint keeps the name ``area``: its multiplier is ``dE*/dV``), and for a heavy drop the moment
    element ``revolution_moment``.  The wetted disc ``pi r_c²`` is :attr:`Geometry.wetted`.

    Default initial guess: the spherical cap of volume 1 and contact angle ``angle`` (the hemisphere unless
    told), equally spaced in arclength.  The scenes pass the weightless drop's angle (Young's, or Gibbs' on a
    pattern), which a heavy drop's continuation starts from anyway.  From the hemisphere, Ipopt did not reach a flat drop of
    revolution (theta = 10°: 200 iterations at N = 20, 40 and 100, where the 2-D polyline reaches 2°).
    """

    name = "curve"

    def __init__(self, n: int, guess: Optional[np.ndarray] = None, angle: float = 0.5 * math.pi,
                 weights: Optional[np.ndarray] = None):
        self.n = n
        self.guess = guess  # (n + 1, 2) profile points (r, z) from the apex, scaled units, or None
        self.angle = angle
        self.weights = weights  # the chords' ratios from the apex (graded toward the rim), or None: equal chords

    def build(self, nlp: Program, span: Optional[float]) -> Geometry:
        if span is not None:
            raise ValueError("a drop of revolution with a pinned contact radius is not discretised")
        n = self.n
        if self.guess is not None:
            guess = np.array(self.guess, dtype=float)
        else:
            t = self.angle
            radius = (3.0 / (math.pi * (2.0 - 3.0 * math.cos(t) + math.cos(t) ** 3))) ** (1.0 / 3.0)
            alpha = t * np.arange(n + 1) / n
            guess = radius * np.column_stack([np.sin(alpha), np.cos(alpha) - math.cos(t)])
        if self.weights is not None:  # every guess re-spaced along itself to the gauge's chords
            guess = respace_polyline(guess[:, 0], guess[:, 1], self.weights)
        guess[0, 0] = 0.0
        guess[-1, 1] = 0.0
        seg0 = float(np.hypot(*np.diff(guess, axis=0).T).mean())
        free_r = np.ones(n + 1, dtype=bool)
        free_r[0] = False  # the apex on the axis
        free_z = np.ones(n + 1, dtype=bool)
        free_z[-1] = False  # the contact line on the table
        lbr, ubr = _fixed(guess[:, 0], free_r)
        lbr[-1] = 1e-8
        rs = nlp.variable("r", n + 1, lb=lbr, ub=ubr, init=guess[:, 0])
        nlp.variable("z", n + 1, *_fixed(guess[:, 1], free_z), init=guess[:, 1])
        P = np.column_stack([nlp.index("r"), nlp.index("z")])
        k = _chords(nlp, P, seg0, "surface", "frustum", self.weights)
        gr, gz = guess[:, 0], guess[:, 1]
        tri = 0.5 * (gr[1:] * gz[:-1] - gr[:-1] * gz[1:])
        _cumulative_area(nlp, "revolution_link", "revolution_last", lambda r: [X(P[r]), X(P[r + 1])],
                         2.0 * math.pi / 3.0 * tri * (gr[:-1] + gr[1:]))
        return Geometry(P[:, 0], P[:, 1], int(P[-1, 0]), rs[n], pieces=(X(P[k]), X(P[k + 1])),
                        moment="revolution_moment", wetted=math.pi * rs[n] ** 2)


DISCRETISATIONS = {"curve": Curve, "graph": Graph}


# ---------------------------------------------------------------------------- terms a scene adds
def add_gravity(nlp: Program, geo: Geometry, weight: float) -> None:
    """The weight ``weight ∫∫ y dA`` in the objective: one element family over the geometry's pieces.

    In scaled units ``weight`` is the signed Bond number ``±rho g A / gamma_gl`` (``+`` sessile, ``-``
    pendant).  It is a parameter of the program (``"gravity"``), so a continuation in the area changes
    it between solves without rebuilding the solver.  The term asks the geometry only for its pieces and
    their moment element: a discretisation whose liquid is weighted otherwise (a body of revolution,
    ``2 pi r``) supplies its own moment element, and this term does not change.
    """
    nlp.parameter("gravity", 1, weight)
    moment = geo.moment if isinstance(geo.moment, ca.Function) else _element(geo.moment)
    nlp.minimize_elements("gravity", moment, [*geo.pieces, P(nlp.parameter_index("gravity"))])


def add_pattern(nlp: Program, geo: Geometry, wetting_in: float, wetting_out: float, step: float):
    """The wetting energy of a patterned table, whose kink at the step is held exactly without a kink.

    The wetted measure ``m`` (the span, or the disc ``pi r_c²`` of a drop of revolution: :attr:`Geometry.wetted`)
    is split into an inside part ``m_in`` in ``[0, step]`` and an outside part ``m_out >= 0``, ``m_in + m_out = m``
    (the row ``wetted_split``), and the wetting energy is linear in the parts, ``wetting_in m_in + wetting_out
    m_out``.  With ``wetting_out > wetting_in`` (the pattern the more wettable part) its least value over the
    splits of ``m`` is the kinked ``wetting_in min(m, step) + wetting_out max(m − step, 0)``, and every KKT point
    has ``m_out (step − m_in) = 0``: the complementarity of the split holds without being imposed (Droplet §11).
    The pinning bound ``m_in <= step`` is a bound of the unknown ``wetted_inside``; its multiplier is the
    pinning force.  Returns the wetting energy (an expression for the objective)."""
    wet = geo.span if geo.wetted is None else geo.wetted
    # start from the split of the guess's wetted measure (the kinked energy's own split)
    x0 = np.concatenate([b.init for b in nlp._vars])
    p0 = np.concatenate([b.init for b in nlp._params]) if nlp._params else np.zeros(0)
    m0 = float(nlp.evaluator(wet)(x0, p0))
    inside = nlp.variable("wetted_inside", 1, lb=0.0, ub=step, init=min(m0, step))
    outside = nlp.variable("wetted_outside", 1, lb=0.0, init=max(m0 - step, 0.0))
    nlp.equal("wetted_split", inside + outside - wet)
    return wetting_in * inside + wetting_out * outside


# ---------------------------------------------------------------------------- inspect helpers
def _end_angle(px, py) -> float:
    """The contact angle at the first vertex of ``(px, py)``: the first two chords' angles extrapolated
    linearly in arclength to the contact point (see :func:`contact_angle_estimate`)."""
    dx, dy = np.diff(px[:3]), np.diff(py[:3])
    phi = np.arctan2(dy, dx)
    l0, l1 = np.hypot(dx[0], dy[0]), np.hypot(dx[1], dy[1])
    return phi[0] + (phi[0] - phi[1]) * l0 / (l0 + l1)


def contact_angle_at_rim(r, z) -> float:
    """The contact angle of a half profile from the apex (``r, z``) at its last vertex, the contact line
    (the profile mirrored so that the contact comes first and the liquid lies to its right)."""
    r, z = np.asarray(r, float), np.asarray(z, float)
    return float(_end_angle(-(r[::-1] - r[-1]), z[::-1]))


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
    left = _end_angle(x, y)
    right = _end_angle(-(x[::-1] - x[-1]), y[::-1])
    return 0.5 * (left + right)



def resample_polyline(x: np.ndarray, y: np.ndarray, n: int) -> np.ndarray:
    """``n + 1`` points along the polyline ``(x, y)`` (ends kept), equally spaced in its vertex index: equally
    spaced in arclength along a polyline of equal chords, and graded as it is along a graded one (the grading
    of :func:`chord_weights` is a map of the index, so a coarser or finer grid keeps it)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    u = np.linspace(0.0, 1.0, x.size)
    t = np.linspace(0.0, 1.0, n + 1)
    return np.column_stack([np.interp(t, u, x), np.interp(t, u, y)])


def respace_polyline(x: np.ndarray, y: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """``len(weights) + 1`` points along the polyline ``(x, y)`` (ends kept) whose chords along it are in the
    ratios ``weights``."""
    s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))])
    c = np.concatenate([[0.0], np.cumsum(weights)])
    t = s[-1] * c / c[-1]
    return np.column_stack([np.interp(t, s, x), np.interp(t, s, y)])
