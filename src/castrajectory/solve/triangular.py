"""Linear solves with a square sparse matrix through its block triangular form (issue 45).

An initial-value trajectory's Jacobian is block triangular in time: the rows of step k hold the unknowns of step k
(``q_{k+1}``, its stages and multipliers) and of the steps before it.  A sparse factorisation of the whole matrix
does not see that, and a symmetric one of Ipopt's augmented system fills every time block's Schur complement along
the bodies of a multibody chain (n³ per step).  Factored block by block -- each diagonal block by its own sparse QR,
the blocks solved in order, each with the ones before it moved to the right-hand side -- there is no fill outside
the blocks, and a chain in maximal coordinates costs a multiple of its bodies (docs/notes.md, issue 45).

The blocks are CasADi's Dulmage–Mendelsohn decomposition (``Sparsity.btf``, CSparse's ``cs_dmperm``): the
strongly connected components of the matrix's graph, found from its pattern alone, so that any square system
with such structure is treated alike.
"""
from __future__ import annotations

from typing import Dict, Optional

import casadi as ca
import numpy as np


#: CasADi's linear solver plugin for each diagonal block
LINSOL = "qr"


class BlockTriangular:
    """The block triangular form of a square sparsity pattern and a solver on it: :meth:`solve` takes the
    matrix's nonzeros (in the pattern's column-major order) and a right-hand side.  ``blocks``: the number of
    diagonal blocks (1: no structure to use); ``largest``: the largest block's size."""

    def __init__(self, sp: ca.Sparsity, min_block: int = 1):
        if sp.size1() != sp.size2():
            raise ValueError("a block triangular form needs a square pattern")
        nb, rowperm, colperm, rowblock, colblock, _, _ = sp.btf()
        self.n = sp.size1()
        self.blocks = int(nb)
        rowperm, colperm = np.asarray(rowperm, int), np.asarray(colperm, int)
        rowblock, colblock = np.asarray(rowblock, int), np.asarray(colblock, int)
        self.largest = int(np.max(np.diff(rowblock), initial=0))
        self.square = bool(np.array_equal(np.diff(rowblock), np.diff(colblock)))
        self.applies = self.square and self.blocks > 1 and self.largest >= min_block
        if not self.applies:
            return
        rows, cols = (np.asarray(v, int) for v in sp.get_triplet())
        # each row's and column's block, and its place in its block (the block's rows and columns in index order)
        rb, cb = np.empty(self.n, int), np.empty(self.n, int)
        rb[rowperm] = np.repeat(np.arange(self.blocks), np.diff(rowblock))
        cb[colperm] = np.repeat(np.arange(self.blocks), np.diff(colblock))
        rsort, csort = np.lexsort((np.arange(self.n), rb)), np.lexsort((np.arange(self.n), cb))
        rloc, cloc = np.empty(self.n, int), np.empty(self.n, int)
        rloc[rsort] = np.arange(self.n) - rowblock[rb[rsort]]
        cloc[csort] = np.arange(self.n) - colblock[cb[csort]]
        nzb_r, nzb_c = rb[rows], cb[cols]
        upper, lower = bool(np.all(nzb_r <= nzb_c)), bool(np.all(nzb_r >= nzb_c))
        if not (upper or lower):
            self.applies = False
            return
        # solved from the block whose columns no other row block needs: the last for an upper form, the first for a
        # lower one
        self.order = list(range(self.blocks))[::-1] if upper and not lower else list(range(self.blocks))
        # the nonzeros by row block, each block's diagonal ones column-major (as CasADi stores a pattern)
        by = np.lexsort((rloc[rows], cloc[cols], nzb_c != nzb_r, nzb_r))
        starts = np.searchsorted(nzb_r[by], np.arange(self.blocks + 1))
        self._rows = np.split(rsort, rowblock[1:-1])
        self._cols = np.split(csort, colblock[1:-1])
        self._cb, self._cloc, self._nnz = cb, cloc, rows.size
        self._fn = None
        self._diag, self._off = [], []
        patterns: Dict[tuple, ca.Sparsity] = {}
        for b in range(self.blocks):
            nzs = by[starts[b]:starts[b + 1]]
            diag = nzs[nzb_c[nzs] == b]
            off = nzs[nzb_c[nzs] != b]
            size = int(rowblock[b + 1] - rowblock[b])
            key = (size, rloc[rows[diag]].tobytes(), cloc[cols[diag]].tobytes())
            if key not in patterns:
                patterns[key] = ca.Sparsity.triplet(size, size, rloc[rows[diag]].tolist(), cloc[cols[diag]].tolist())
            bsp = patterns[key]
            self._diag.append((bsp, diag))
            self._off.append((rloc[rows[off]], cols[off], off))
        self.patterns = len(patterns)

    def _function(self) -> ca.Function:
        """The forward substitution as one CasADi function of the nonzeros and the right-hand side: each block's
        right-hand side less its products with the blocks solved before (sparse), then its own sparse QR solve
        (CasADi's ``qr`` linear solver), all in one call.  (Block by block from Python, the conversions between
        numpy and CasADi matrices cost as much as the factorisations: a 32-rod chain's 720 block solves spent
        0.46 s in QR and 0.5 s in conversions.)"""
        nz, rhs = ca.MX.sym("nz", self._nnz), ca.MX.sym("rhs", self.n)
        xs = {}
        for b in self.order:
            bsp, idx = self._diag[b]
            lr, gc, oi = self._off[b]
            r = rhs[self._rows[b].tolist()]
            if oi.size:
                owner = self._cb[gc]
                for c in np.unique(owner):
                    sel = np.flatnonzero(owner == c)
                    rr, cc = lr[sel], self._cloc[gc[sel]]
                    order = np.lexsort((rr, cc))          # (column-major, as CasADi stores a pattern)
                    S = ca.Sparsity.triplet(len(self._rows[b]), len(self._cols[c]), rr[order].tolist(),
                                            cc[order].tolist())
                    r = r - ca.mtimes(ca.MX(S, nz[oi[sel][order].tolist()]), xs[c])
            xs[b] = ca.solve(ca.MX(bsp, nz[idx.tolist()]), r, LINSOL)
        stacked = ca.vertcat(*[xs[b] for b in range(self.blocks)])
        where = np.empty(self.n, int)
        where[np.concatenate(self._cols)] = np.arange(self.n)
        return ca.Function("block_triangular_solve", [nz, rhs], [stacked[where.tolist()]])

    def solve(self, nonzeros: np.ndarray, rhs: np.ndarray) -> Optional[np.ndarray]:
        """``x`` with ``A x = rhs`` for the matrix ``A`` of this pattern with ``nonzeros``; None where a diagonal
        block is singular or the result is not finite."""
        if self._fn is None:
            self._fn = self._function()
        try:
            x = np.asarray(self._fn(np.asarray(nonzeros, float), np.asarray(rhs, float))).reshape(-1)
        except RuntimeError:
            return None
        return x if np.all(np.isfinite(x)) else None
