"""The droplet's spectral discretisation: the half profile by its tangent angle, a polynomial of degree ``p``.

The polyline of :mod:`castrajectory.discretise.droplet` converges at order 2 (and its apex, on the axis of
a drop of revolution, as ``h² log h``: the radial problem is a 2-D one, where linear elements lose the
log in the maximum norm).  A drop's profile is analytic, so a global polynomial converges faster than any
power of ``1/p``.  The profile is written by its arclength ``s = L t``, ``t`` in ``[0, 1]`` from the apex
(``L`` the half length, an unknown) and its tangent angle ``psi(t)``, a polynomial of degree ``p`` held by
its values at the ``p + 1`` Legendre–Gauss–Lobatto nodes::

    r(t) = L ∫_0^t cos psi,    depth(t) = L ∫_0^t sin psi,    h = depth(1),    z = h - depth,

with the integrals by the spectral integration matrix (exact for the polynomial's own degree), and every
term by the nodes' Lobatto quadrature:

* surface: ``2 pi L ∫ r dt`` (revolution), the length ``2 L`` (2-D, both halves);
* measure: ``pi L ∫ r² sin psi dt`` (volume), ``2 L ∫ r sin psi dt`` (area);
* first moment ``∫ z dV``: ``pi L ∫ r² z sin psi dt``, ``2 L ∫ r z sin psi dt``;
* wetted measure: ``pi r_c²``, or the span ``2 r_c`` (``r_c = r(1)``).

The arclength parametrisation is exact by construction (``|x'| = L`` identically), so no gauge rows are
needed, and ``psi(0) = 0`` (a bound) is the apex's symmetry.  The contact angle is ``psi(1)``: a reading
of the unknowns, not of a finite difference.  Each term is one element over all the nodes (a dense block
of ``p + 2`` unknowns): at the degrees that pay (``p`` <= 64) the whole KKT matrix is small.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Dict, Optional, Tuple

import casadi as ca
import numpy as np
from numpy.polynomial import legendre

from .droplet import Geometry
from .program import Program, X

#: The degrees offered (``n`` of the spectral formulation): below 4 the profile has no interior node to
#: bend with, above 200 the Lobatto nodes' integration matrix loses digits for nothing.
MIN_DEGREE, MAX_DEGREE = 4, 200


@functools.lru_cache(maxsize=64)
def lobatto(p: int) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(t, w, Q)`` on ``[0, 1]``: the ``p + 1`` Legendre–Gauss–Lobatto nodes, their weights (exact for
    degree ``2p − 1``), and the integration matrix ``Q`` with ``(Q f)_i = ∫_0^{t_i} f`` for every
    polynomial ``f`` of degree ``p`` given by its node values."""
    c = np.zeros(p + 1)
    c[-1] = 1.0
    x = np.concatenate([[-1.0], np.sort(legendre.legroots(legendre.legder(c))), [1.0]])
    w = 2.0 / (p * (p + 1) * legendre.legval(x, c) ** 2)
    coeffs = np.linalg.solve(legendre.legvander(x, p), np.eye(p + 1))  # column j: the j-th Lagrange basis
    Q = np.column_stack([legendre.legval(x, legendre.legint(coeffs[:, j], lbnd=-1.0)) for j in range(p + 1)])
    return 0.5 * (x + 1.0), 0.5 * w, 0.5 * Q


#: The element functions per (degree, revolution): one object per key, so their derivatives are formed once.
_FUNCTIONS: Dict[tuple, Dict[str, ca.Function]] = {}

#: The integrands are evaluated at the Lobatto nodes of degree ``OVER_INTEGRATION * p`` (over-integration):
#: at the degree's own nodes the quadrature sees only the node values, and an unresolved profile wiggled
#: between them to price itself below the drop (Bond 100, degree 16: an energy 60 below the elliptic drop's,
#: height 2.5 against 1.41).
OVER_INTEGRATION = 2


@functools.lru_cache(maxsize=64)
def _grids(p: int):
    """``(t, tq, w, Q, interp, back)``: the degree's nodes ``t``, the finer nodes ``tq`` with their weights
    and integration matrix, ``interp`` (node values of degree p to the finer nodes) and ``back`` (finer-grid
    polynomials of degree m read at the degree's nodes)."""
    t = lobatto(p)[0]
    m = OVER_INTEGRATION * p
    tq, w, Q = lobatto(m)
    interp = legendre.legvander(2.0 * tq - 1.0, p) @ np.linalg.solve(legendre.legvander(2.0 * t - 1.0, p),
                                                                       np.eye(p + 1))
    back = legendre.legvander(2.0 * t - 1.0, m) @ np.linalg.solve(legendre.legvander(2.0 * tq - 1.0, m),
                                                                   np.eye(m + 1))
    return t, tq, w, Q, interp, back


def _profile(p: int, revolution: bool) -> Dict[str, ca.Function]:
    """The element functions of degree ``p`` (built once per degree and kind).

    Lifted: the tangent angle ``psi_q``, the positions ``r`` and the depths ``d`` at the finer nodes are
    unknowns, tied by the rows ``interp`` (``psi_q = I psi``, linear) and ``profile`` (``r = L Q cos psi_q``,
    ``d = L Q sin psi_q``).  Every term is then a sum over the finer nodes of a function of one node's
    ``(psi_q, L, r, d)``, and every Hessian is diagonal but for ``L``: forming them is O(m²), not the
    O(p² m²) of the terms written through ``psi`` alone (58 s to build at p = 48, 4.3 s at 32)."""
    key = (p, revolution)
    if key not in _FUNCTIONS:
        _, _, w, Q, interp, _ = _grids(p)
        m = OVER_INTEGRATION * p
        psi, L, s = ca.SX.sym("psi", p + 1), ca.SX.sym("L"), ca.SX.sym("s")
        q, r, d = ca.SX.sym("q", m + 1), ca.SX.sym("r", m + 1), ca.SX.sym("d", m + 1)
        W = ca.DM(w)
        rows = ca.vertcat(r[1:] - L * ca.mtimes(ca.DM(Q[1:]), ca.cos(q)),
                          d[1:] - L * ca.mtimes(ca.DM(Q[1:]), ca.sin(q)))
        sin, z = ca.sin(q), d[m] - d
        if revolution:
            surface = 2.0 * math.pi * L * ca.dot(W, r)
            measure = math.pi * L * ca.dot(W, r * r * sin)
            moment = math.pi * L * ca.dot(W, r * r * z * sin)
        else:
            surface = 2.0 * L + 0.0 * r[0]
            measure = 2.0 * L * ca.dot(W, r * sin)
            moment = 2.0 * L * ca.dot(W, r * z * sin)
        _FUNCTIONS[key] = {
            # (node 0: both fixed at 0 by their bounds, a row 0 = 0 that only made the Jacobian rank-deficient)
            "interp": ca.Function(f"spectral_interp_{p}", [psi, q], [q[1:] - ca.mtimes(ca.DM(interp[1:]), psi)]),
            "rows": ca.Function(f"spectral_profile_{p}", [q, L, r, d], [rows]),
            "surface": ca.Function(f"spectral_surface_{p}", [L, r], [surface]),
            "measure": ca.Function(f"spectral_measure_{p}", [q, L, r], [measure]),
            "moment": ca.Function(f"spectral_moment_{p}", [q, L, r, d, s], [s * moment])}
    return _FUNCTIONS[key]


def lift(psi: np.ndarray, length: float):
    """``(psi_q, r, d)`` at the finer nodes of the degree of ``psi`` (node values), by the spectral integration."""
    p = len(psi) - 1
    _, _, _, Q, interp, _ = _grids(p)
    psiq = interp @ np.asarray(psi, dtype=float)
    return psiq, length * (Q @ np.cos(psiq)), length * (Q @ np.sin(psiq))


@dataclass
class SpectralGeometry(Geometry):
    """A spectral profile in the NLP: ``psi_index`` and ``length_index`` are the positions of the tangent
    angles and the half length; ``revolution`` tells the drop of revolution from the 2-D drop."""

    psi_index: np.ndarray = None
    length_index: int = 0
    degree: int = 0
    revolution: bool = False

    r_index: np.ndarray = None
    d_index: np.ndarray = None

    def half_profile(self, res) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(r, z, psi)`` at the degree's nodes, from the apex to the contact line (scaled units)."""
        psi = np.asarray(res.x[self.psi_index], dtype=float)
        back = _grids(self.degree)[5]
        r, d = back @ np.asarray(res.x[self.r_index]), back @ np.asarray(res.x[self.d_index])
        r[0], d[0] = 0.0, 0.0
        return r, float(res.x[self.d_index][-1]) - d, psi

    def measure(self, res) -> float:
        """The area (2-D) or volume the profile encloses, in scaled units."""
        q = _grids(self.degree)[4] @ np.asarray(res.x[self.psi_index], dtype=float)
        return float(_profile(self.degree, self.revolution)["measure"](
            q, float(res.x[self.length_index]), np.asarray(res.x[self.r_index], dtype=float)))

    def vertices(self, res):
        """As :meth:`Geometry.vertices`: the half profile ``(r, z, r_c)`` of a drop of revolution; the whole
        2-D profile mirrored about its axis, ``(x, y, span)`` with ``x`` from 0 to the span."""
        r, z, _ = self.half_profile(res)
        return self.outline(r, z)

    def outline(self, r: np.ndarray, z: np.ndarray):
        """:meth:`vertices` from the half profile's ``(r, z)``."""
        if self.revolution:
            return r, z, float(r[-1])
        x = np.concatenate([r[-1] - r[::-1], r[-1] + r[1:]])
        return x, np.concatenate([z[::-1], z[1:]]), 2.0 * float(r[-1])


class Spectral:
    """The half profile by its tangent angle, a polynomial of degree ``n`` (see the module's doc).

    Default initial guess: the circular cap (the spherical one for a drop of revolution) of area (volume) 1
    and contact angle ``angle``, whose tangent angle is linear in arclength; the scenes pass the weightless
    drop's angle (a heavy drop's continuation starts there anyway).  A pinned span (2-D) is the row
    ``2 r(1) = span``.
    """

    name = "spectral"

    def __init__(self, n: int, revolution: bool, angle: float = 0.5 * math.pi, guess=None):
        self.n, self.revolution, self.angle = n, revolution, angle
        self.guess = guess  # (psi at this degree's nodes, L), or None for the cap

    @staticmethod
    def resample(psi: np.ndarray, degree: int) -> np.ndarray:
        """The tangent angle given at the Lobatto nodes of its own degree, evaluated at those of ``degree``."""
        x = 2.0 * lobatto(len(psi) - 1)[0] - 1.0
        coeffs = np.linalg.solve(legendre.legvander(x, len(psi) - 1), psi)
        return legendre.legval(2.0 * lobatto(degree)[0] - 1.0, coeffs)

    def build(self, nlp: Program, span: Optional[float]) -> SpectralGeometry:
        p, t = self.n, self.angle
        if span is not None and self.revolution:
            raise ValueError("a drop of revolution with a pinned contact radius is not discretised")
        if self.revolution:
            radius = (3.0 / (math.pi * (2.0 - 3.0 * math.cos(t) + math.cos(t) ** 3))) ** (1.0 / 3.0)
        else:
            radius = 1.0 / math.sqrt(t - math.sin(t) * math.cos(t))
        nodes = lobatto(p)[0]
        lb = np.full(p + 1, -np.inf)
        lb[0] = 0.0  # psi(0) = 0: the apex is horizontal (the profile's symmetry)
        psi0, length0 = (t * nodes, radius * t) if self.guess is None else self.guess
        psi0 = np.array(psi0, dtype=float)
        psi0[0] = 0.0
        nlp.variable("psi", p + 1, lb=lb, ub=-lb, init=psi0)
        nlp.variable("length", 1, lb=1e-8, init=float(length0))
        fns = _profile(p, self.revolution)
        q0, r0, d0 = lift(psi0, float(length0))
        fixed0 = np.full(r0.size, -np.inf)
        fixed0[0] = 0.0  # psi, r and d vanish at the apex
        nlp.variable("psi_q", q0.size, lb=fixed0, ub=-fixed0, init=q0)
        r = nlp.variable("r", r0.size, lb=fixed0, ub=-fixed0, init=r0)
        nlp.variable("d", d0.size, lb=fixed0, ub=-fixed0, init=d0)
        a_psi, a_q, a_len, a_r, a_d = (X(nlp.index(k)) for k in ("psi", "psi_q", "length", "r", "d"))
        nlp.equal_elements("interp", fns["interp"], [a_psi, a_q])
        nlp.equal_elements("profile", fns["rows"], [a_q, a_len, a_r, a_d])
        nlp.minimize_elements("surface", fns["surface"], [a_len, a_r])
        nlp.equal_elements("area", fns["measure"], [a_q, a_len, a_r], 1.0)
        rc = r[r0.size - 1]
        if span is not None:
            nlp.equal("pinned_span", 2.0 * rc - span)
        return SpectralGeometry(None, np.zeros(0, dtype=np.int64), -1, 2.0 * rc, pieces=(a_q, a_len, a_r, a_d),
                                moment=fns["moment"], wetted=math.pi * rc ** 2 if self.revolution else None,
                                psi_index=nlp.index("psi"), length_index=int(nlp.index("length")[0]), degree=p,
                                revolution=self.revolution, r_index=nlp.index("r"), d_index=nlp.index("d"))
