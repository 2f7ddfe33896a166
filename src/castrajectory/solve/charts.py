"""Singular charts: where a solved motion passes near a configuration at which its coordinates lose
their inertia (the mass matrix degenerates), and its answer cannot be trusted.

A spherical pendulum in angles ``(θ, φ)`` has ``M = diag(1, sin²θ)``, singular at the pole; Euler angles
have gimbal lock.  Near such a point a coordinate's rate grows without bound while the motion itself is
smooth, so a grid that does not resolve the passage conserves its discrete momentum at whichever node
lands nearest the singularity: two grids then "agree" while both are wrong (measured, a spherical
pendulum passing 1e-3 rad from the pole, galerkin4 on 4000 steps: 21 % off, an estimate of 1.9e-4).

The watch (:func:`singular_chart`): along the solved nodes, the condition number of the mass matrix on
the tangent space of the holonomic constraints (a quaternion's mass matrix is singular along ``q``,
which its unit-norm constraint removes).  The chart is near singular where it exceeds
:data:`COND_RATIO` times the motion's best-conditioned node: the growth, not the value, marks a chart
singularity (a system of masses 1 and 1e6 is ill-conditioned everywhere and resolved everywhere).
"""
from __future__ import annotations

from typing import Optional

import numpy as np

#: A node whose mass matrix (on the constraints' tangent space) is this many times worse conditioned
#: than the motion's best node is near a singular chart.  Measured on a spherical pendulum swinging past
#: the pole at a distance d (T = 3, galerkin4, N = 1000 and 4000, against the same motion in Cartesian
#: coordinates): d = 1e-2 (ratio 7e3) errors 1.6e-2 / 8.4e-5 estimated 8.8e-3 / 1.8e-5; d = 1e-3 and
#: closer (ratio >= 1.5e5) errors 0.2-1.1 estimated 1e-2-1.5e-7.
COND_RATIO = 1e4


def conditioning(system, t: np.ndarray, q: np.ndarray):
    """Per node: the condition number of the mass matrix on the constraints' tangent space, and the
    unit direction (in the coordinates) of its smallest eigenvalue.  ``(cond (N,), direction (N, n))``."""
    q = np.asarray(q, float)
    t = np.asarray(t, float).reshape(-1)
    N, n = q.shape
    fn = system.mass_matrix.map(N)
    M = np.asarray(fn(q.T, t[None, :]), float).reshape(n, N, n).transpose(1, 0, 2)  # (N, n, n)
    M = 0.5 * (M + M.transpose(0, 2, 1))
    P = None
    if system.nc:
        C = np.stack([np.asarray(system.constraint(q[k], float(t[k]))[1], float) for k in range(N)]) \
            if N <= 64 else _constraint_jacobians(system, q, t)
        _, _, Vt = np.linalg.svd(C)                  # rows nc.. of Vt span the tangent space
        P = Vt[:, system.nc:, :].transpose(0, 2, 1)  # (N, n, n - nc)
        M = P.transpose(0, 2, 1) @ M @ P
    with np.errstate(all="ignore"):
        lam, vec = np.linalg.eigh(M)
        cond = np.where(lam[:, 0] > 0, lam[:, -1] / lam[:, 0], np.inf)
    d = vec[:, :, 0]
    if P is not None:
        d = np.einsum("kij,kj->ki", P, d)
    return cond, d


def _unconstrained_bound(system, t, q) -> float:
    """The largest condition number of the mass matrix itself over the nodes: a bound on its condition number
    on any subspace (the eigenvalues of ``Pᵀ M P`` with orthonormal ``P`` lie within ``M``'s), so that where it
    is at most :data:`COND_RATIO` no node's tangent conditioning can be that ratio above another's, and the
    per-node projection (an SVD of the constraint Jacobian: cubic in the coordinates, 0.24 s of a 32-rod chain's
    1.7 s run in maximal coordinates, whose mass matrix is constant) is not needed."""
    q = np.asarray(q, float)
    t = np.asarray(t, float).reshape(-1)
    N, n = q.shape
    M = np.asarray(system.mass_matrix.map(N)(q.T, t[None, :]), float).reshape(n, N, n).transpose(1, 0, 2)
    with np.errstate(all="ignore"):
        lam = np.linalg.eigvalsh(0.5 * (M + M.transpose(0, 2, 1)))
        cond = np.where(lam[:, 0] > 0, lam[:, -1] / lam[:, 0], np.inf)
    return float(np.max(cond))


def _constraint_jacobians(system, q: np.ndarray, t: np.ndarray) -> np.ndarray:
    import casadi as ca
    N, n = q.shape
    qs, ts = ca.SX.sym("q", n), ca.SX.sym("t")
    Cj = ca.Function("C", [qs, ts], [system.constraint(qs, ts)[1]]).map(N)
    return np.asarray(Cj(q.T, t[None, :]), float).reshape(system.nc, N, n).transpose(1, 0, 2)


def singular_chart(system, t, q) -> Optional[str]:
    """The warning for a motion that passes near a singular chart (see the module docstring), naming
    the coordinates that lose their inertia, the time and the condition number; ``None`` if it does not."""
    q = np.asarray(q, float)
    if q.ndim != 2 or q.shape[0] < 2 or not np.all(np.isfinite(q)):
        return None
    if system.nc and _unconstrained_bound(system, t, q) <= COND_RATIO:
        return None
    cond, d = conditioning(system, t, q)
    finite = cond[np.isfinite(cond)]
    best = float(np.min(finite)) if finite.size else np.inf
    k = int(np.argmax(np.where(np.isfinite(cond), cond, np.inf)))
    worst = float(cond[k])
    if not (worst > COND_RATIO * best) or not np.isfinite(best):
        return None
    names = _chart_coordinates(system, float(np.asarray(t)[k]), q[k], d[k])
    return (f"the coordinates ({', '.join(names)}) are near a singular chart at t = {float(np.asarray(t)[k]):.4g}: "
            f"cond M = {worst:.1e}, {worst / best:.1e} times the motion's best (the chart's inertia vanishes "
            f"there, and neither the answer nor its error estimate can be trusted): use another chart, Cartesian "
            f"coordinates with a constraint, or a quaternion")


def _chart_coordinates(system, t: float, q: np.ndarray, d: np.ndarray):
    """The coordinates of the singularity at ``q``: those along the direction ``d`` that loses its inertia,
    and those whose change moves the smallest eigenvalue most (log-derivative, by differences): for the
    spherical pendulum at its pole, φ and θ."""
    w = np.abs(d)
    pick = set(np.nonzero(w >= 0.1 * np.max(w))[0].tolist())
    cond0, _ = conditioning(system, [t], q[None, :])
    g = np.zeros(q.size)
    for i in range(q.size):
        dq = 1e-6 * (1.0 + abs(q[i]))
        qp = q.copy()
        qp[i] += dq
        c, _ = conditioning(system, [t], qp[None, :])
        with np.errstate(all="ignore"):
            g[i] = abs(np.log(c[0]) - np.log(cond0[0])) / dq
    if np.all(np.isfinite(g)) and np.max(g) > 0:
        pick |= set(np.nonzero(g >= 0.1 * np.max(g))[0].tolist())
    return [system.names[i] for i in sorted(pick)]
