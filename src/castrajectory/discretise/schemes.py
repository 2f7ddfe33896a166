"""Schemes: how one step of a trajectory becomes finitely many unknowns, each scheme one object.

A scheme is a *Galerkin* discrete Lagrangian: on the step ``[t_k, t_k + h]`` the path is the
polynomial ``q(τ) = Σ_j ℓ_j(τ) X_j`` through its control points ``X_0 = q_k``, ``X_1..X_{r−1} = Z_k``
(the step's stages) and ``X_r = q_{k+1}`` at the times ``c_0 = 0 < c_1 < … < c_r = 1`` (in units of
``h``), and the action over the step is a quadrature with nodes ``τ_i`` and weights ``w_i``::

    L_d(q_k, Z_k, q_{k+1}) = h Σ_i w_i L(q(τ_i), q̇(τ_i), t_k + τ_i h)

The discrete forces are the same quadrature of the virtual work, differentiated with respect to the
control points' variations (automatic differentiation, one mechanism for every scheme)::

    f_j = ∂/∂δX_j  h Σ_i w_i Q(q(τ_i), q̇(τ_i), t_k + τ_i h) · δq(τ_i),     δq(τ) = Σ_j ℓ_j(τ) δX_j

so ``f⁻_k = f_0`` (the step's start), ``f⁺_k = f_r`` (its end) and ``f_1..f_{r−1}`` act on the stages.
Holonomic constraints are imposed at the control points and weighted by the Lobatto weights of
those points (:attr:`Scheme.constraint_weights`), so their multipliers are the physical ones.

How to add a scheme
===================
1. Choose the control times ``c`` (``c[0] = 0``, ``c[-1] = 1``; the interior ones are the stage
   times, and every guess of the stages is read from them, never assumed elsewhere) and a
   quadrature on ``[0, 1]`` (``nodes``, ``weights``).
2. Make it a :class:`Scheme`: ``Scheme(name, order, control, nodes, weights, latex=...)``; the
   polynomial basis, the discrete Lagrangian, the discrete forces, the work quadrature and the
   stage guesses all follow from these.  A family is a function of its parameter, as
   :func:`lobatto` (Lobatto IIIA–IIIB, order ``2r``) and :func:`gauss` (order ``2r``).
3. Register it in :data:`SCHEMES` (``register(scheme)``).  ``simulate``, every scene's ``--scheme``,
   ``castrajectory system`` and :func:`castrajectory.schemes` list it from there, and the order
   tests (``tests/test_schemes.py``) fit its convergence slope against :attr:`Scheme.order`:
   nothing else names a scheme.
4. State its order honestly: the tests read it from the object and fail if the fitted slope
   disagrees.

Nothing outside this module branches on a scheme's name.
"""
from __future__ import annotations

from fractions import Fraction
from typing import Callable, Dict, List, Optional, Sequence

import casadi as ca
import numpy as np

# ----------------------------------------------------------------------------- points and weights


def _polish_roots(p: np.polynomial.Legendre, x: np.ndarray) -> np.ndarray:
    dp = p.deriv()
    for _ in range(3):
        x = x - p(x) / dp(x)
    return x


def gauss_lobatto(r: int):
    """The ``r + 1`` Gauss–Lobatto points on ``[0, 1]`` and their weights (exact for degree ``2r − 1``)."""
    if r < 1:
        raise ValueError("Gauss–Lobatto needs r >= 1")
    P = np.polynomial.Legendre.basis(r)
    inner = np.sort(_polish_roots(P.deriv(), np.sort(P.deriv().roots().real))) if r > 1 else np.zeros(0)
    x = np.concatenate([[-1.0], inner, [1.0]])
    w = 2.0 / (r * (r + 1) * P(x) ** 2)
    x = 0.5 * (x + 1.0)
    x[0], x[-1] = 0.0, 1.0
    x = 0.5 * (x + (1.0 - x[::-1]))  # symmetric to rounding
    w = 0.25 * (w + w[::-1])
    return x, w


def gauss_legendre(r: int):
    """The ``r`` Gauss–Legendre points on ``(0, 1)`` and their weights (exact for degree ``2r − 1``)."""
    x, w = np.polynomial.legendre.leggauss(r)
    x = 0.5 * (x + 1.0)
    x = 0.5 * (x + (1.0 - x[::-1]))
    return x, 0.25 * (w + w[::-1])


def _lagrange(c: np.ndarray, tau: np.ndarray):
    """Values ``B[i, j] = ℓ_j(τ_i)`` and derivatives ``D[i, j] = ℓ_j'(τ_i)`` of the Lagrange basis on ``c``."""
    r1 = c.size
    B = np.zeros((tau.size, r1))
    D = np.zeros((tau.size, r1))
    for j in range(r1):
        others = np.delete(c, j)
        den = np.prod(c[j] - others)
        for i, t in enumerate(tau):
            d = t - others
            B[i, j] = np.prod(d) / den
            s = 0.0
            for m in range(others.size):
                s += np.prod(np.delete(d, m))
            D[i, j] = s / den
    return B, D


_SNAPPED: dict = {}


def _snap(values: np.ndarray, max_den: int = 1000):
    """``(numerators, denominator)`` if every value is a rational with a small common denominator (to
    rounding), else ``None``: the schemes with rational coefficients (midpoint, trapezoid, galerkin4)
    are then written with exact integer coefficients, the expressions they always had.  Remembered per
    row of values (every system's discretisation asks for the same few rows)."""
    key = (tuple(float(v) for v in np.ravel(values)), np.shape(values), max_den)
    if key not in _SNAPPED:
        _SNAPPED[key] = _snap_uncached(values, max_den)
    return _SNAPPED[key]


def _snap_uncached(values, max_den):
    fr = [Fraction(float(v)).limit_denominator(max_den) for v in np.ravel(values)]
    if any(abs(float(f) - float(v)) > 1e-13 * max(1.0, abs(float(v))) for f, v in zip(fr, np.ravel(values))):
        return None
    den = 1
    for f in fr:
        den = den * f.denominator // np.gcd(den, f.denominator)
    if den > max_den:
        return None
    return np.array([int(f * den) for f in fr]).reshape(np.shape(values)), int(den)


def _combine(coefs, X: Sequence) -> object:
    """``Σ_j coefs[j] X_j`` as a CasADi expression: integer coefficients over a common denominator where
    they are rational (zeros skipped, ±1 as a sign; a leading −1 is subtracted last, so ``[−1, 1]`` is
    ``b − a``), floating-point ones otherwise."""
    snapped = _snap(np.asarray(coefs, float))
    if snapped is not None:
        num, den = snapped
        terms = [(int(n), x) for n, x in zip(num, X) if n != 0]
        if len(terms) > 1 and terms[0][0] == -1:
            terms = terms[1:] + terms[:1]
        out = None
        for n, x in terms:
            if out is None:
                out = x if n == 1 else (-x if n == -1 else n * x)
            else:
                out = out + x if n == 1 else (out - x if n == -1 else (out + n * x if n > 0 else out - (-n) * x))
        out = out if out is not None else 0 * X[0]
        return out if den == 1 else out / den
    out = None
    for cj, x in zip(coefs, X):
        if cj == 0.0:
            continue
        out = cj * x if out is None else out + cj * x
    return out if out is not None else 0 * X[0]


class Scheme:
    """One discrete Lagrangian (see the module docstring for the recipe).

    Parameters
    ----------
    name, order: the scheme's name and its order of accuracy for ``q`` at the nodes.
    control: control times ``c`` on ``[0, 1]`` (``c[0] = 0``, ``c[-1] = 1``); ``r = len(c) − 1`` is
        the polynomial degree and the ``r − 1`` interior times are the stage times.
    nodes, weights: the quadrature on ``[0, 1]``.
    latex: the discrete Lagrangian in LaTeX (for the derivation).
    family: the family's name and parameter, for listings.
    """

    def __init__(self, name: str, order: int, control, nodes, weights, latex: str = "", family: str = "",
                 constraint_weights=None):
        self.name, self.order, self.family = name, int(order), family
        self.control = np.asarray(control, float)
        self.nodes = np.asarray(nodes, float)
        self.weights = np.asarray(weights, float)
        if self.control[0] != 0.0 or self.control[-1] != 1.0 or np.any(np.diff(self.control) <= 0):
            raise ValueError(f"{name}: control times must rise from 0 to 1")
        if self.nodes.size != self.weights.size or abs(self.weights.sum() - 1.0) > 1e-13:
            raise ValueError(f"{name}: quadrature weights must match the nodes and sum to 1")
        self.degree = self.control.size - 1
        #: ℓ_j(τ_i) and ℓ_j'(τ_i) at the quadrature nodes
        self.basis, self.basis_rate = _lagrange(self.control, self.nodes)
        #: the constraint quadrature: weights of the control points (the interpolatory quadrature on them
        #: unless given: Lobatto's for Lobatto points), exact fractions where they are rational
        cw = _interpolatory_weights(self.control) if constraint_weights is None else np.asarray(constraint_weights, float)
        snapped = _snap(cw)
        self.constraint_weights = cw if snapped is None else np.array([n / snapped[1] for n in snapped[0]])
        self._latex = latex

    # -- what the rest of the package reads
    @property
    def stages(self) -> int:
        """Stage configurations per step (``r − 1``)."""
        return self.degree - 1

    @property
    def stage_times(self) -> np.ndarray:
        """Times of the stages in the step, in units of ``h`` (the interior control times)."""
        return self.control[1:-1]

    @property
    def node_weight(self) -> float:
        """Weight of each end node in the constraint quadrature of one step."""
        return float(self.constraint_weights[0])

    @property
    def stage_weights(self) -> tuple:
        return tuple(float(w) for w in self.constraint_weights[1:-1])

    def __repr__(self) -> str:
        return f"Scheme({self.name!r}, order={self.order}, stages={self.stages})"

    # -- the path of one step
    def path(self, X: Sequence, h):
        """Configurations and rates at the quadrature nodes from the control points ``X`` (list of columns)."""
        memo: dict = {}

        def once(row, scale):  # identical rows share one expression (trapezoid's one velocity)
            key = (tuple(row), scale)
            if key not in memo:
                memo[key] = _combine(row, X) if scale is None else _combine(row, X) / scale
            return memo[key]
        qs = [once(self.basis[i], None) for i in range(self.nodes.size)]
        vs = [once(self.basis_rate[i], h) for i in range(self.nodes.size)]
        return qs, vs

    def _quadrature(self, values: List, h):
        snapped = _snap(self.weights)
        if snapped is not None:
            num, den = snapped
            total = None
            for n, v in zip(num, values):
                term = v if n == 1 else n * v
                total = term if total is None else total + term
            if den == 1:
                return h * total
            # h / den is exact for a power of two (the trapezoid's h/2 [L₀ + L₁])
            return h / den * total if den & (den - 1) == 0 else h * total / den
        total = None
        for w, v in zip(self.weights, values):
            total = w * v if total is None else total + w * v
        return h * total

    def times(self, t0, h) -> list:
        """The quadrature times ``t_k + τ_i h`` (``None`` for a time-independent system)."""
        if t0 is None:
            return [None] * self.nodes.size
        return [t0 + float(tau) * h for tau in self.nodes]

    def discrete_lagrangian(self, L: Callable, X: Sequence, h, t0=None):
        """``L_d = h Σ w_i L(q(τ_i), q̇(τ_i), t_k + τ_i h)``; ``L(q, v, t)`` with ``t = None`` when
        the system does not depend on time."""
        qs, vs = self.path(X, h)
        ts = self.times(t0, h)
        return self._quadrature([L(q, v, t) for q, v, t in zip(qs, vs, ts)], h)

    def discrete_forces(self, Q: Callable, X: Sequence, h, t0=None) -> list:
        """``[f_0, …, f_r]``: the gradients of the virtual work's quadrature with respect to the control
        points' variations (see the module docstring); ``Q(q, v, t)`` the generalised force."""
        n = X[0].numel()
        dX = [ca.SX.sym(f"dX{j}", n) for j in range(len(X))]
        qs, vs = self.path(X, h)
        dqs, _ = self.path(dX, h)
        ts = self.times(t0, h)
        W = self._quadrature([ca.dot(Q(q, v, t), dq) for q, v, t, dq in zip(qs, vs, ts, dqs)], h)
        out = []
        for d in dX:
            f = ca.gradient(W, d)
            # W is linear in the variations: the gradient does not hold them
            out.append(ca.substitute(f, ca.vertcat(*dX), ca.SX.zeros(n * len(dX))))
        return out

    def step_integral(self, P: Callable, X: Sequence, h, t0=None):
        """The scheme's quadrature ``h Σ w_i P(q(τ_i), q̇(τ_i), t_i)`` of a power ``P(q, v, t)`` over one step."""
        qs, vs = self.path(X, h)
        ts = self.times(t0, h)
        return self._quadrature([P(q, v, t) for q, v, t in zip(qs, vs, ts)], h)

    # -- guesses
    def stage_guess(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Stage guesses of every step (rows) on the straight line between its end nodes, at the stage times."""
        if not self.stages:
            return np.zeros((a.shape[0], 0))
        return np.hstack([a + c * (b - a) for c in self.stage_times])

    # -- derivation
    def latex(self) -> str:
        """The discrete Lagrangian in LaTeX."""
        if self._latex:
            return self._latex
        nodes = ", ".join(f"{c:.6g}" for c in self.control)
        return (r"L_d(q_k, Z_k, q_{k+1}) = h \sum_{i} w_i\, L\big(q(\tau_i), \dot q(\tau_i), t_k + \tau_i h\big),\ "
                rf"q(\tau) \text{{ of degree {self.degree} through }} q_k, Z_k, q_{{k+1}} \text{{ at }} \tau = {nodes}")


def _interpolatory_weights(c: np.ndarray) -> np.ndarray:
    """Weights of the interpolatory quadrature on the points ``c`` of ``[0, 1]`` (Lobatto weights for
    Lobatto points; 1/2, 1/2 for the two ends)."""
    r1 = c.size
    V = np.vander(c, r1, increasing=True).T  # V[k, j] = c_j^k
    moments = 1.0 / np.arange(1, r1 + 1)
    return np.linalg.solve(V, moments)


# ----------------------------------------------------------------------------- the families
#: Largest degree of either family offered (order 2r = 24); see docs/derivations.md on what limits it.
MAX_DEGREE = 12


def lobatto(r: int, name: Optional[str] = None, latex: str = "") -> Scheme:
    """Galerkin with a polynomial of degree ``r`` through the ``r + 1`` Gauss–Lobatto points and their
    quadrature: Lobatto IIIA–IIIB, order ``2r`` (``r = 1``: trapezoid; ``r = 2``: galerkin4)."""
    x, w = gauss_lobatto(r)
    return Scheme(name or f"galerkin{2 * r}", 2 * r, x, x, w, latex,
                  family=f"Galerkin, Lobatto quadrature (Lobatto IIIA-IIIB), r = {r}", constraint_weights=w)


def gauss(r: int, name: Optional[str] = None, latex: str = "") -> Scheme:
    """Galerkin with a polynomial of degree ``r`` through the ``r + 1`` Gauss–Lobatto points and the
    ``r``-point Gauss quadrature: order ``2r`` (``r = 1``: midpoint)."""
    c, cw = gauss_lobatto(r)
    x, w = gauss_legendre(r)
    return Scheme(name or f"gauss{2 * r}", 2 * r, c, x, w, latex,
                  family=f"Galerkin, Gauss quadrature, r = {r}", constraint_weights=cw)


SCHEMES: Dict[str, Scheme] = {}


def register(s: Scheme) -> Scheme:
    if s.name in SCHEMES:
        raise ValueError(f"a scheme named {s.name!r} exists")
    SCHEMES[s.name] = s
    return s


register(gauss(1, "midpoint", r"L_d(q_k, q_{k+1}) = h\,L\!\left(\tfrac{q_k + q_{k+1}}{2},\ \tfrac{q_{k+1} - q_k}{h},"
                              r"\ t_k + \tfrac h2\right)"))
register(lobatto(1, "trapezoid", r"L_d(q_k, q_{k+1}) = \tfrac{h}{2}\left[L\!\left(q_k, \tfrac{q_{k+1} - q_k}{h}, t_k"
                                 r"\right) + L\!\left(q_{k+1}, \tfrac{q_{k+1} - q_k}{h}, t_{k+1}\right)\right]"))
register(lobatto(2, "galerkin4", r"L_d(q_k, Z_k, q_{k+1}) = \tfrac{h}{6}\left[L(q(0), \dot q(0), t_k) + "
                                 r"4 L(q(\tfrac12), \dot q(\tfrac12), t_k + \tfrac h2) + L(q(1), \dot q(1), t_{k+1})"
                                 r"\right],\ q(\tau) \text{ quadratic through } q_k, Z_k, q_{k+1}"))
for _r in range(3, MAX_DEGREE + 1):
    register(lobatto(_r))
for _r in range(2, MAX_DEGREE + 1):
    register(gauss(_r))


def scheme(name) -> Scheme:
    """The scheme of ``name`` (a :class:`Scheme` passes through)."""
    if isinstance(name, Scheme):
        return name
    try:
        return SCHEMES[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown scheme {name!r}; choose from {', '.join(SCHEMES)}") from None


def listing() -> Dict[str, int]:
    """Every scheme's name and order, in registration order."""
    return {k: s.order for k, s in SCHEMES.items()}
