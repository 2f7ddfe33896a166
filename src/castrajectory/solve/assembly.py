"""Element assembly: derivatives of structured NLPs without whole-graph AD.

Many NLPs here are sums of small, identical pieces ("elements"): one discrete
Euler–Lagrange equation per time node, one length constraint per polyline
segment.  CasADi's automatic path differentiates the whole symbolic graph and
pays tens of microseconds per variable just to create the solver.  Here each
element type is differentiated once, symbolically and densely in its few local
unknowns; the element derivatives are evaluated for all elements with one
``Function.map`` and scattered into the global sparse Jacobian and Hessian by a
constant 0/1 matrix computed with numpy.  The cost of building is then a few
array operations per nonzero.

This module only deals with patterns and scatter matrices; :mod:`castrajectory.solve.nlp`
decides what is an element.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence, Tuple

import casadi as ca
import numpy as np


@dataclass
class Contribution:
    """Nonzero values of one piece of a global sparse matrix.

    ``values`` is a column (MX) of length ``rows.size``; entry ``i`` adds to
    global position ``(rows[i], cols[i])``.
    """

    values: object
    rows: np.ndarray
    cols: np.ndarray


def _csc(nrow: int, ncol: int, col_of_entry: np.ndarray, row_of_entry: np.ndarray) -> ca.Sparsity:
    """Sparsity from (row, col) pairs already sorted by (col, row) and unique."""
    colind = np.zeros(ncol + 1, dtype=np.int64)
    np.cumsum(np.bincount(col_of_entry, minlength=ncol), out=colind[1:])
    return ca.Sparsity(nrow, ncol, colind.tolist(), row_of_entry.astype(np.int64).tolist())


def assemble(contribs: Sequence[Contribution], shape: Tuple[int, int], triu: bool = False):
    """Sum contributions into one sparse MX with a precomputed pattern.

    With ``triu=True`` the contributions are entries of a symmetric matrix
    given in full (both triangles); only entries with ``row <= col`` are kept,
    which yields the upper triangle CasADi's Ipopt interface expects.
    Returns the MX matrix (structural pattern = union of all positions).
    """
    nrow, ncol = shape
    contribs = [c for c in contribs if c.rows.size]
    if not contribs:
        return ca.MX(nrow, ncol)
    rows = np.concatenate([c.rows for c in contribs]).astype(np.int64)
    cols = np.concatenate([c.cols for c in contribs]).astype(np.int64)
    vals = ca.densify(ca.vertcat(*[c.values for c in contribs]))
    ent = np.arange(rows.size, dtype=np.int64)
    if triu:
        keep = rows <= cols
        rows, cols, ent = rows[keep], cols[keep], ent[keep]
    key = cols * nrow + rows
    # Column-major (CSC) order of the entries; one stable sort serves both cases below.
    perm = np.argsort(key, kind="stable")
    skey = key[perm]
    new = np.empty(skey.size, dtype=bool)
    new[:1] = True
    np.not_equal(skey[1:], skey[:-1], out=new[1:])
    uniq = skey[new]
    sp = _csc(nrow, ncol, (uniq // nrow), (uniq % nrow))
    nent = vals.size1()
    if uniq.size == ent.size:
        # No two entries share a position: the scatter is a permutation (a gather).
        order = ent[perm]
        nz = vals if np.array_equal(order, np.arange(nent)) else vals[order.tolist()]
    else:
        inv = np.empty(key.size, dtype=np.int64)
        inv[perm] = np.cumsum(new) - 1
        # Scatter matrix S (nnz x n_entries), one 1 per kept entry: nz = S @ vals (sums duplicates).
        counts = np.zeros(nent, dtype=np.int64)
        counts[ent] = 1
        colind = np.concatenate([[0], np.cumsum(counts)])
        S = ca.DM(ca.Sparsity(uniq.size, nent, colind.tolist(), inv.astype(np.int64).tolist()), 1.0)
        nz = ca.mtimes(S, vals)
    return ca.sparsity_cast(nz, sp)


def dense_vector(contribs: Sequence[Contribution], n: int):
    """Sum contributions (``cols`` ignored) into a dense column of length ``n``."""
    contribs = [c for c in contribs if c.rows.size]
    if not contribs:
        return ca.densify(ca.MX(n, 1))
    m = assemble([Contribution(c.values, c.rows, np.zeros_like(c.rows)) for c in contribs], (n, 1))
    return ca.densify(m)
