"""Symmetries of a system and their conserved momenta (Noether), found from the Lagrangian itself.

A cyclic coordinate is the simplest symmetry; most are not: a central force written in Cartesian
coordinates conserves its angular momentum though every coordinate appears in ``L``.  This module
looks for the **affine** symmetries ``ξ(q) = A q + b`` -- translations, rotations, and any other linear
vector field -- under which the system is invariant:

* the Lagrangian: ``∂L/∂q · ξ(q) + ∂L/∂q̇ · A q̇ = 0`` for every state (and time);
* the forces do no work along it: ``Q · ξ = 0``;
* the holonomic constraints and the contact gaps are preserved: ``∇c · ξ = 0`` and ``∇φ · ξ = 0``
  on the constraint manifold.

Each condition is linear in ``(A, b)``.  At random states (on the constraint manifold, with
velocities tangent to it) the conditions are rows of a linear system, whose null space is the
algebra of affine symmetries; its reduced row-echelon basis gives sparse generators.  Each generator's
momentum ``J = ∂L/∂q̇ · ξ(q)`` is conserved by the motion, and **exactly by the discrete solution** of
every scheme here: an affine map commutes with the polynomial interpolation of a step and with the
time derivative, so the discrete Lagrangian (a quadrature of ``L`` along that polynomial) is invariant
too, the discrete forces' quadrature of ``Q · ξ`` vanishes, and the discrete Noether theorem holds
(Marsden and West, Acta Numerica 2001, §1.3).  Non-affine symmetries are not searched.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional

import casadi as ca
import numpy as np

#: Systems with more coordinates are not searched (the unknowns are n² + n).
MAX_COORDINATES = 24
#: A singular value below this fraction of the largest spans the null space (the rows are normalised).
NULL_TOL = 1e-9


@dataclass
class Symmetry:
    """An affine symmetry ``ξ(q) = A q + b`` and its momentum ``J(q, q̇) = ∂L/∂q̇ · ξ(q)`` (an SX expression)."""

    A: np.ndarray
    b: np.ndarray
    momentum: object
    description: str


def _rref(B: np.ndarray, tol: float = 1e-8) -> np.ndarray:
    """Reduced row-echelon form of the rows of ``B`` (a basis of a subspace: sparse generators)."""
    B = B.copy()
    rows, cols = B.shape
    r = 0
    for c in range(cols):
        if r >= rows:
            break
        piv = r + int(np.argmax(np.abs(B[r:, c])))
        if abs(B[piv, c]) < tol:
            continue
        B[[r, piv]] = B[[piv, r]]
        B[r] /= B[r, c]
        for i in range(rows):
            if i != r:
                B[i] -= B[i, c] * B[r]
        r += 1
    B[np.abs(B) < tol] = 0.0
    return B[:r]


def _describe(A: np.ndarray, b: np.ndarray, names: List[str]) -> str:
    n = len(names)
    if not np.any(A) and np.count_nonzero(b) == 1:
        return f"translation of {names[int(np.nonzero(b)[0][0])]}"
    if not np.any(A):
        return "translation along (" + ", ".join(f"{v:.3g}" for v in b) + ")"
    S = A + A.T
    if np.allclose(S, 0.0) and not np.any(b):
        pairs = [(i, j) for i in range(n) for j in range(i + 1, n) if A[i, j] != 0.0]
        if len(pairs) == 1:
            i, j = pairs[0]
            return f"rotation in the ({names[i]}, {names[j]}) plane"
        return "rotation mixing (" + ", ".join(sorted({names[k] for p in pairs for k in p})) + ")"
    return "linear vector field"


def _manifold_points(system, rng, count: int, q_ref: np.ndarray) -> np.ndarray:
    """Random configurations near ``q_ref``, projected onto the constraints (Gauss–Newton, least change)."""
    n = system.nq
    scale = 0.5 * (1.0 + np.abs(q_ref))
    pts = q_ref[None, :] + rng.standard_normal((count, n)) * scale[None, :]
    if not system.nc:
        return pts
    out = []
    for q in pts:
        for _ in range(30):
            c, C = (np.asarray(x, float) for x in system.constraint(q, 0.0))
            c = c.reshape(-1)
            if np.max(np.abs(c)) < 1e-13 * (1.0 + np.max(np.abs(q))):
                break
            q = q - np.linalg.lstsq(C, c, rcond=None)[0]
        else:
            continue
        out.append(q)
    return np.array(out)


def _tangent_velocity(system, q: np.ndarray, rng) -> np.ndarray:
    """A random velocity at ``q`` tangent to the holonomic constraints."""
    if not system.nc:
        return rng.standard_normal(system.nq)
    C = np.asarray(system.constraint(q, 0.0)[1], float)
    _, _, Vt = np.linalg.svd(C)
    return Vt[system.nc:].T @ rng.standard_normal(system.nq - system.nc)


def affine_symmetries(system, q_ref=None, samples: Optional[int] = None, seed: int = 7) -> List[Symmetry]:
    """The affine symmetries of ``system`` (see the module docstring), sampled near ``q_ref`` (default:
    zeros, or the first point of the constraint manifold found); ``[]`` for a system with more than
    :data:`MAX_COORDINATES` coordinates."""
    n = system.nq
    if n > MAX_COORDINATES:
        return []
    rng = np.random.default_rng(seed)
    q_ref = np.zeros(n) if q_ref is None else np.asarray(q_ref, float).reshape(-1)
    unknowns = n * n + n
    count = samples or max(4 * unknowns, 24)
    Q = _manifold_points(system, rng, count, q_ref)
    if Q.shape[0] < unknowns:
        return []
    q, qd, t = system.q, system.qd, system.t
    L = system.lagrangian_expr()
    dLq, dLv = ca.gradient(L, q), ca.gradient(L, qd)
    blocks = [ca.horzcat(dLq, dLv)]            # invariance of L: rows (dL/dq, dL/dq̇)
    if system.forced:
        blocks.append(ca.horzcat(system.force_expr(), ca.SX.zeros(n, 1)))
    grads = []
    if system.nc:
        grads.append(ca.jacobian(system.constraint_expr(), q))
    if system.contact is not None:
        grads.append(ca.jacobian(ca.vertcat(*system.contact.gaps), q))
    fn = ca.Function("sym_rows", [q, qd, t], [ca.vertcat(*[ca.vec(b) for b in blocks])] +
                     [ca.vec(G) for G in grads])
    rows = []
    for qk in Q:
        vk = _tangent_velocity(system, qk, rng)
        tk = float(rng.uniform(0.0, 1.0))
        outs = fn.call([qk, vk, tk])
        vals = np.asarray(outs[0], float).reshape(-1)
        k = 0
        for b in blocks:
            g = vals[k:k + n]
            h = vals[k + n:k + 2 * n]
            k += 2 * n
            # ξ = A q + b: g·(A q + b) + h·(A q̇)  -> coefficients of A_ij: g_i q_j + h_i q̇_j; of b_i: g_i
            rows.append(np.concatenate([(np.outer(g, qk) + np.outer(h, vk)).reshape(-1), g]))
        for G, m in zip(outs[1:], [system.nc] * bool(system.nc) + ([system.contact.count] if system.contact else [])):
            Gm = np.asarray(G, float).reshape(n, m).T if m else np.zeros((0, n))
            for gj in Gm:
                rows.append(np.concatenate([np.outer(gj, qk).reshape(-1), gj]))
    R = np.array(rows)
    norms = np.linalg.norm(R, axis=1)
    R = R[norms > 0] / norms[norms > 0, None]
    if R.shape[0] < unknowns or not np.all(np.isfinite(R)):
        return []
    _, sv, Vt = np.linalg.svd(R, full_matrices=True)
    smax = sv[0] if sv.size else 1.0
    rank = int(np.sum(sv > NULL_TOL * smax))
    null = Vt[rank:]
    if null.shape[0] == 0:
        return []
    basis = _rref(null)
    out = []
    for row in basis:
        A, b = row[:n * n].reshape(n, n), row[n * n:]
        A = np.where(np.abs(A) < 1e-9, 0.0, A)
        b = np.where(np.abs(b) < 1e-9, 0.0, b)
        xi = ca.mtimes(ca.DM(A), q) + ca.DM(b)
        out.append(Symmetry(A=A, b=b, momentum=ca.dot(dLv, xi), description=_describe(A, b, system.names)))
    return out


def conserved_by(system, expr, symmetries: List[Symmetry], q_ref=None, seed: int = 11) -> Optional[Symmetry]:
    """Whether the scalar ``expr(q, q̇, t)`` is, up to a constant factor and an additive constant, the momentum
    of one of ``symmetries`` or a combination of them: the combination's coefficients found by least squares
    at random states (``None`` where it is not)."""
    if not symmetries:
        return None
    n = system.nq
    rng = np.random.default_rng(seed)
    q_ref = np.zeros(n) if q_ref is None else np.asarray(q_ref, float).reshape(-1)
    Q = _manifold_points(system, rng, 40 + 4 * len(symmetries), q_ref)
    q, qd, t = system.q, system.qd, system.t
    fn = ca.Function("cons", [q, qd, t], [ca.vertcat(ca.SX(expr), *[s.momentum for s in symmetries])])
    rows, rhs = [], []
    for qk in Q:
        vk = _tangent_velocity(system, qk, rng)
        vals = np.asarray(fn(qk, vk, float(rng.uniform())), float).reshape(-1)
        rhs.append(vals[0])
        rows.append(np.concatenate([vals[1:], [1.0]]))
    M, y = np.array(rows), np.array(rhs)
    coef, *_ = np.linalg.lstsq(M, y, rcond=None)
    resid = np.max(np.abs(M @ coef - y))
    if resid > 1e-8 * max(1.0, float(np.max(np.abs(y)))) or np.allclose(coef[:-1], 0.0):
        return None
    used = [(c, s) for c, s in zip(coef[:-1], symmetries) if abs(c) > 1e-9 * max(1.0, float(np.max(np.abs(coef))))]
    if len(used) == 1:  # one symmetry's momentum, up to a factor
        return used[0][1]
    A = sum(c * s.A for c, s in zip(coef[:-1], symmetries))
    b = sum(c * s.b for c, s in zip(coef[:-1], symmetries))
    return Symmetry(A=A, b=b, momentum=sum(c * s.momentum for c, s in zip(coef[:-1], symmetries)),
                    description=" + ".join(f"{c:.3g} × ({s.description})" for c, s in zip(coef[:-1], symmetries)
                                           if abs(c) > 1e-12))
