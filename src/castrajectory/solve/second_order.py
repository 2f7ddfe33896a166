"""Second-order conditions at a solution: is the KKT point Ipopt returned a minimum?

Ipopt stops at a first-order point.  Whether it is a strict local minimum is decided by the Hessian
of the Lagrangian ``∇²L = ∇²f + Σ λ_i ∇²g_i`` (the Hessian Ipopt itself used, the program's
``hess_lag``) on the tangent space of the active constraints: with ``Z`` an orthonormal basis of the
null space of the active rows' Jacobian (on the free variables), the point is a strict local minimum
when the reduced Hessian ``Zᵀ ∇²L Z`` is positive definite, and not a minimum when it has a negative
eigenvalue.  A family of minima that loses this property as a parameter moves has reached a fold
(the reduced Hessian is singular there, and so is the KKT matrix).

Dense linear algebra (symmetric eigen-decompositions of ``JᵀJ``, for ``Z``, and of ``Zᵀ∇²L Z``): meant
for programs of a few thousand unknowns, such as a droplet's profile.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..result import NLPResult

#: Multipliers (bounds, inequalities) larger than this count as active (relative to the largest one).
ACTIVE_TOL = 1e-8


@dataclass
class ReducedHessian:
    """The reduced Hessian's spectrum at a solution: its ``dimension`` (free unknowns minus active rows),
    its ``smallest`` eigenvalues (ascending) and its largest one in magnitude."""

    dimension: int
    smallest: np.ndarray
    largest: float

    @property
    def min_eigenvalue(self) -> float:
        return float(self.smallest[0]) if self.smallest.size else float("inf")

    @property
    def positive_definite(self) -> bool:
        """Every eigenvalue above rounding (``1e-12`` of the largest)."""
        return self.min_eigenvalue > 1e-12 * max(self.largest, 1e-300)

    def as_dict(self) -> dict:
        return {"dimension": self.dimension, "min_eigenvalue": self.min_eigenvalue,
                "max_abs_eigenvalue": self.largest, "positive_definite": self.positive_definite}


def _dense(M) -> np.ndarray:
    """A sparse CasADi matrix as a dense numpy array (from its triplets: ``DM.full`` is slow)."""
    r, c = M.sparsity().get_triplet()
    out = np.zeros((M.size1(), M.size2()))
    out[np.asarray(r, dtype=np.int64), np.asarray(c, dtype=np.int64)] = np.asarray(M.nonzeros(), dtype=float)
    return out


def reduced_hessian(nlp, res: NLPResult, keep: int = 4) -> ReducedHessian:
    """``Zᵀ ∇²L Z`` at ``res`` (a solution of ``nlp``, an :class:`~castrajectory.solve.nlp.NLP` of element
    families): its ``keep`` smallest eigenvalues.  Fixed variables (equal bounds) and variables held at an
    active bound are left out; equality rows and active inequality rows are the constraints."""
    funcs = nlp.functions()
    if not funcs:
        raise ValueError("reduced_hessian needs an NLP of element families (its assembled hess_lag)")
    a = nlp._arguments(None, res, None)
    x, lam_g, lam_x = res.x, res.lam_g, res.lam_x
    p = np.concatenate([b.init for b in nlp._params]) if nlp._params else np.zeros(0)
    scale_x = max(float(np.max(np.abs(lam_x), initial=0.0)), 1.0)
    scale_g = max(float(np.max(np.abs(lam_g), initial=0.0)), 1.0)
    free = np.where((a["lbx"] < a["ubx"]) & (np.abs(lam_x) <= ACTIVE_TOL * scale_x))[0]
    rows = np.where((a["lbg"] == a["ubg"]) | (np.abs(lam_g) > ACTIVE_TOL * scale_g))[0]
    H = _dense(funcs["hess_lag"](x, p, 1.0, lam_g))
    H = H + np.triu(H, 1).T  # hess_lag is the upper triangle
    J = _dense(funcs["jac_g"](x, p)[1])[np.ix_(rows, free)]
    Hf = H[np.ix_(free, free)]
    # null space of J: the eigenvectors of JᵀJ with the len(free) - rank smallest eigenvalues (J has full row
    # rank at a regular point).  A symmetric eigen-solver, not a QR: OpenBLAS's threaded QR ran 40 times
    # slower on a loaded machine (0.2 s against 5 ms for 300 × 200), its symmetric eigen-solver did not.
    w, V = np.linalg.eigh(J.T @ J)
    rank = int(np.sum(w > 1e-12 * max(float(w.max(initial=0.0)), 1e-300)))
    Z = V[:, :free.size - rank]
    ev = np.linalg.eigvalsh(Z.T @ Hf @ Z) if Z.shape[1] else np.zeros(0)
    return ReducedHessian(int(Z.shape[1]), ev[:keep], float(np.max(np.abs(ev), initial=0.0)))
