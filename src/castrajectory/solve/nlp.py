"""One NLP handed to Ipopt: CasADi ``nlpsol`` on a :class:`~castrajectory.discretise.program.Program`.

:class:`NLP` is a :class:`~castrajectory.discretise.program.Program` (named
variables and constraints, element families) that can also be solved::

    nlp = NLP()
    x = nlp.variable("x", 3, lb=0.0, init=1.0)
    nlp.minimize(casadi.sumsqr(x - 2))
    nlp.equal("budget", casadi.sum1(x), 3.0)
    res = nlp.solve()
    res["x"], res.multipliers["budget"]      # d f*/d(budget) (see castrajectory.result)

The sign of every multiplier is documented once, in :mod:`castrajectory.result`:
``multiplier = d f*/d bound``.

The Ipopt solver is created once, on the first call to :meth:`NLP.solve`, and
reused by later calls (new initial guesses, parameter values or relaxation
steps), so construction cost is paid once and reported as ``build_time_s``.

A program with element families is differentiated element by element
(:mod:`castrajectory.solve.assembly`), so building the solver costs a few array
operations per nonzero instead of whole-graph AD; large families run compiled
element functions (:mod:`castrajectory.solve.jit`).

Complementarity is not this module's: the contact transcription poses its pairs with exact ℓ1 penalties and
runs its own penalty ladder (:meth:`castrajectory.solve.contact.nlp.ContactNLP._ladder`).
"""
from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass
from typing import Dict, Optional

import casadi as ca
import numpy as np

from . import budget, interrupt, jit
from .triangular import BlockTriangular
from .assembly import Contribution, assemble, dense_vector
from ..discretise.program import (  # noqa: F401  (X, P, Constraint: re-exported)
    Constraint, P, Program, X, _column, _Group, _nz)
from ..result import SUCCESS_STATUSES, NLPResult

#: Ipopt options used unless the caller overrides them.
#: MUMPS scaling is switched off: on the large, sparse, square systems of this
#: library the default scaling made MUMPS fail at the first iteration
#: (see docs/notes.md); without it the same problems converge in a few
#: iterations.
DEFAULT_IPOPT_OPTIONS: Dict[str, object] = {
    "tol": 1e-10,
    "max_iter": 200,
    "mumps_scaling": 0,
    "mumps_permuting_scaling": 0,
    # AMD ordering: on the banded KKT systems here it halved the solve time
    # (double pendulum N = 32000: 1.25 s -> 0.6 s; droplet N = 1e4: 0.44 s -> 0.35 s).
    "mumps_pivot_order": 0,
}


#: How element families are evaluated: CasADi ``map`` parallelization and thread count.
MAP_PARALLELIZATION = "serial"
MAP_THREADS = 1
#: Compile element functions to machine code (:mod:`castrajectory.solve.jit`: disk-cached, falls back to
#: CasADi's virtual machine when no C compiler works; ``CASTRAJECTORY_JIT=0`` also switches it off).
JIT = True
#: Families with at least this many elements compile their element functions (about 0.1-0.5 s
#: once per element type and machine, then loaded from the disk cache in a few milliseconds);
#: smaller families use a compiled version only when one is cached already.  Below this size
#: the virtual machine costs less than a compilation.
JIT_MIN_ELEMENTS = 1000
#: ... or whose evaluation over the family costs at least this many virtual-machine instructions
#: (elements x instructions of the kernel): the heavy elements of a high-order scheme on few steps
#: (galerkin10's stage Jacobian on 200 steps) compile too.
JIT_MIN_WORK = 1_000_000


#: Elements per compiled chunk: a family of E elements runs E // CHUNK calls of one compiled loop
#: over CHUNK elements plus E % CHUNK calls of the compiled element, so the per-call overhead of
#: CasADi's ``map`` is paid once per chunk and the compiled code does not depend on E.
CHUNK = 64
#: Smallest family evaluated in chunks (below it the plain map of the compiled element is as fast,
#: and the graph is smaller to build).
CHUNK_MIN_ELEMENTS = 8 * CHUNK
#: :meth:`NLP.newton`'s iterations at most: from a level's guess (the coarser level's answer, an integrated
#: motion) Newton's method contracts quadratically within a few; a guess it does not is Ipopt's to solve
NEWTON_MAX_ITER = 12
#: ... and the size of the largest diagonal block from which it pays: each block is solved by a call from Python
#: (some 50 µs), where Ipopt's factorisation of a small block costs microseconds.  Measured: with every
#: initial-value level by Newton, tests/test_trajectory.py took 40 s against 5.8 s (galerkin4 trajectories of
#: 10⁴ steps of blocks of 4 to 12 unknowns); a 24-link chain in maximal coordinates (blocks of 288 unknowns)
#: solves its level in 0.21 s against 0.65 s
NEWTON_MIN_BLOCK = 48
#: Halvings of a Newton step whose rows' scaled violation grows (the last one is taken as it is)
NEWTON_BACKTRACKS = 4
#: Newton stops at the rows' rounding floor: where the violation stops halving after converging to within
#: NEWTON_FLOOR times the tolerance, that is the floor, and the point the discrete solution to rounding.  A 64-rod
#: chain (galerkin8, N = 240) went 7.3e-8, 1.89e-12, 1.87e-12 against tol 1e-12 (its last step, 1.4e-9 relative,
#: the blocks' conditioning times the rows' rounding), and Ipopt from there ran for minutes (its factorisation is
#: cubic in the bodies); the answer's estimate measures the floor.
NEWTON_FLOOR = 10.0


class _Mapped:
    """One element function evaluated for E elements, compiled when that pays (see :data:`JIT`).

    A family of at least :data:`JIT_MIN_ELEMENTS` elements compiles the element (and a loop
    over :data:`CHUNK` elements); smaller families use a compiled version only if one is
    already cached, and CasADi's virtual machine otherwise.
    """

    def __init__(self, fn: ca.Function, compile_: bool):
        self.fn = fn
        self.compile_ = compile_
        self.el = self.chunk = None  # compiled versions, once available
        # the disk cache was searched for the element / the chunk: a miss is not searched again (generating
        # the C code to look it up cost 28 ms per level build for galerkin10's kernels)
        self.el_looked = self.chunk_looked = False
        self.work = fn.n_instructions() if fn.is_a("SXFunction") else 0
        self.maps: Dict[tuple, ca.Function] = {}

    def _compiled(self, E: int) -> None:
        build = E >= JIT_MIN_ELEMENTS or E * self.work >= JIT_MIN_WORK
        if self.el is None and (build or not self.el_looked):
            el = jit.compiled(self.fn, build)
            self.el = el if el is not self.fn else None
            self.el_looked = True
        if self.el is not None and self.chunk is None and E >= CHUNK_MIN_ELEMENTS and (build or not self.chunk_looked):
            m = self.fn.map(CHUNK, "serial")
            c = jit.compiled(m, build)
            self.chunk = c if c is not m else None
            self.chunk_looked = True

    def _map(self, f, E):
        if E <= 1:
            return f
        key = (id(f), E, MAP_PARALLELIZATION, MAP_THREADS)
        m = self.maps.get(key)
        if m is None:  # creating a map costs O(E); the same sizes recur (levels, windows, repeats)
            if len(self.maps) > 64:
                self.maps.clear()
            m = self.maps[key] = f.map(E, MAP_PARALLELIZATION, MAP_THREADS)
        return m

    def __call__(self, E: int, args: list):
        """``fn`` for every element; ``args`` have E columns (one per element) or one (shared)."""
        if self.compile_ and self.fn.is_a("SXFunction") and jit.enabled():  # (jit compiles SX functions only;
            self._compiled(E)  # looking an MX one up serialised it, 2.3 s for the spectral drop at degree 24)
        el = self.el if self.compile_ and self.el is not None else self.fn
        if not self.compile_ or self.chunk is None or E < CHUNK_MIN_ELEMENTS:
            return self._map(el, E)(*args)
        q, r = divmod(E, CHUNK)
        k = q * CHUNK
        main = self._map(self.chunk, q)(*[a[:, :k] if a.size2() == E else a for a in args])
        if not r:
            return main
        rest = self._map(el, r)(*[a[:, k:] if a.size2() == E else a for a in args])
        return ca.horzcat(main, rest)


@dataclass
class _Kernels:
    """Value, Jacobian and Hessian functions of one element type (see :func:`_kernels`)."""

    fn: ca.Function  # kept alive: the cache key holds its id
    keep: list  # the arguments with at least one entry (empty ones are left out of the kernels)
    value: _Mapped
    jac: _Mapped
    jac_rc: tuple
    hess: Optional[_Mapped]
    hess_rc: Optional[tuple]


_KERNELS: Dict[tuple, _Kernels] = {}
_KERNELS_MAX = 256


def _kernels(fn: ca.Function, kinds: tuple, hessian: bool, compile_: bool) -> _Kernels:
    """Element derivatives of ``fn`` with respect to its arguments marked ``"x"`` in ``kinds``.

    Cached per process (by function identity), so NLPs rebuilt with the same element
    function (coarse-to-fine levels, horizon windows, repeated solves) differentiate
    and compile it once.
    """
    key = (id(fn), kinds, hessian, compile_, CHUNK)
    hit = _KERNELS.get(key)
    if hit is not None and hit.fn is fn:
        return hit
    # the same element of another system object (every simulate() builds its system afresh): found by its
    # serialised form, so its derivatives are not formed, nor its compiled code looked up, again
    # (galerkin10 on the double pendulum: 0.049 -> s per build)
    form = (hashlib.sha256(fn.serialize().encode()).hexdigest(), kinds, hessian, compile_, CHUNK) \
        if fn.is_a("SXFunction") else None
    hit = _KERNELS.get(form) if form is not None else None
    if hit is not None:
        _KERNELS[key] = _Kernels(fn, hit.keep, hit.value, hit.jac, hit.jac_rc, hit.hess, hit.hess_rc)
        return _KERNELS[key]
    syms = [ca.SX.sym(f"a{i}", fn.size1_in(i) * fn.size2_in(i)) for i in range(fn.n_in())]
    out = ca.vec(fn(*[ca.reshape(s, fn.size1_in(i), fn.size2_in(i)) for i, s in enumerate(syms)]))
    # Empty arguments (e.g. no stage variables) are dropped: every kernel argument costs O(E) when
    # the mapped kernel is called symbolically.
    keep = [i for i, s in enumerate(syms) if s.numel()]
    args = [syms[i] for i in keep]
    z = ca.vertcat(*[s for s, k in zip(syms, kinds) if k == "x"]) if "x" in kinds else ca.SX(0, 1)
    J = ca.jacobian(out, z)
    rc = lambda M: tuple(np.asarray(v, dtype=np.int64) for v in M.sparsity().get_triplet())  # noqa: E731
    hess = hess_rc = None
    if hessian:
        w = ca.SX.sym("w", out.numel())
        H = ca.hessian(ca.dot(w, out), z)[0]
        hess, hess_rc = _Mapped(ca.Function("el_hess", args + [w], [_nz(H)]), compile_), rc(H)
    kern = _Kernels(fn, keep, _Mapped(ca.Function("el", args, [out]), compile_),
                    _Mapped(ca.Function("el_jac", args, [_nz(J)]), compile_), rc(J), hess, hess_rc)
    if len(_KERNELS) >= _KERNELS_MAX:
        _KERNELS.clear()
    _KERNELS[key] = kern
    if form is not None:
        _KERNELS[form] = kern
    return kern


def _evenly_spaced(flat: np.ndarray) -> bool:
    return flat.size < 2 or (flat[1] > flat[0] and bool(np.all(np.diff(flat) == flat[1] - flat[0])))


def _gather(src, flat: np.ndarray):
    """``src[flat]`` for an MX column; a slice when the positions are evenly spaced (much cheaper)."""
    if flat.size > 1 and _evenly_spaced(flat):
        return src[int(flat[0]):int(flat[-1]) + 1:int(flat[1] - flat[0])]
    if flat.size == 1:
        return src[int(flat[0])]
    return src[flat.tolist()]


def _gather_columns(src, idx: np.ndarray, n: int):
    """Element argument matrix ``(n, E)`` (or ``(n, 1)`` for a shared row) read from ``src`` at ``idx``.

    When every column of ``idx`` (one local entry over all elements) is evenly spaced but the
    rows are not, the matrix is stacked from ``n`` slices instead of one list gather (for
    many elements; for a few the list is cheaper).
    """
    flat = idx.reshape(-1)
    if idx.ndim == 2 and n > 1 and idx.shape[0] >= 256 and not _evenly_spaced(flat) \
            and all(_evenly_spaced(idx[:, j]) for j in range(n)):
        return ca.vertcat(*[ca.transpose(_gather(src, idx[:, j])) for j in range(n)])
    return ca.reshape(_gather(src, flat), n, idx.shape[0] if idx.ndim == 2 else 1)




class NLP(Program):
    """A :class:`~castrajectory.discretise.program.Program` that Ipopt solves (see module docstring)."""

    #: Compile the element kernels (:data:`JIT`).  An NLP whose functions are evaluated a few times only
    #: (a point certified without Ipopt) sets it False: compiling a new system's kernels cost 3.4 s for
    #: a 0.03 s gain on a 4000-step block drop.
    compile_elements: bool = True
    #: The Ipopt iteration budget of this program's solves (:class:`~castrajectory.solve.budget.Budget`, shared with
    #: the other programs of the strategy that set it); None: the run's (``--max-iter``), if any.
    budget = None
    #: Ipopt's statistics of the last solve (empty before one, or when a spent budget skipped it).
    last_stats: dict = {}

    # ------------------------------------------------------------------ solving
    def _ipopt_options(self, options, verbose):
        ipopt = dict(DEFAULT_IPOPT_OPTIONS)
        ipopt.update(options or {})
        if not verbose:
            ipopt.setdefault("print_level", 0)
            ipopt["sb"] = "yes"
        else:
            ipopt.setdefault("print_level", 5)
        return ipopt

    def build(self, options: Optional[dict] = None, verbose: bool = False, expand: bool = False):
        """Create the Ipopt solver (done implicitly by :meth:`solve`)."""
        key = (tuple(sorted((options or {}).items())), verbose, expand)
        if self._solver is not None and key == self._solver_key:
            return self._solver
        if self._f is None and not self._f_groups:
            raise ValueError("no objective: call minimize() first")
        if self._f_groups or any(isinstance(g, _Group) for g in self._g):
            return self._build_assembled(options, verbose, key)
        x = ca.vertcat(*[b.sym for b in self._vars])
        p = ca.vertcat(*[b.sym for b in self._params]) if self._params else self._sym(0, 1)
        g = ca.vertcat(*self._g) if self._g else self._sym(0, 1)
        opts = {"ipopt": self._ipopt_options(options, verbose), "print_time": bool(verbose),
                "error_on_fail": False}
        if expand:
            opts["expand"] = True
        t = time.perf_counter()
        self._solver = ca.nlpsol("castrajectory", "ipopt", {"x": x, "f": self._f, "g": g, "p": p}, opts)
        self._solver_key = key
        # Build time = symbolic description (NLP creation to its last variable/constraint/objective)
        # + creation of the Ipopt solver; time spent between description and solve is not counted.
        self._build_time = (self._t_described - self._t0) + (time.perf_counter() - t)
        return self._solver

    def _assemble(self):
        """The decision and parameter symbols, objective, rows and the derivative functions handed to Ipopt
        (``grad_f``, ``jac_g``, ``hess_lag``), assembled from the element families' derivatives."""
        nx = sum(b.init.size for b in self._vars)
        npar = sum(b.init.size for b in self._params)
        Xm, Pm = ca.MX.sym("x", nx), ca.MX.sym("p", npar)
        lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", self._ng)
        ps = ca.vertcat(*[b.sym for b in self._params]) if self._params else ca.SX(0, 1)
        expr_rows = [(c.slice, g) for c, g in zip(self._cons.values(), self._g) if not isinstance(g, _Group)]
        f_expr = ca.SX(self._f) if self._f is not None else ca.SX(0)
        f_const = f_expr.is_constant() or not any(ca.depends_on(f_expr, b.sym) for b in self._vars)

        exact_hessian = self._hessian == "exact"
        if not exact_hessian and (not f_const or self._f_groups):
            raise ValueError("hessian='zero' needs a constant objective (a square feasibility problem)")
        g_parts, jac, hess, grad = [], [], [], []
        f_total = ca.MX(0)
        # Expression part: ordinary SX automatic differentiation on the (small) expression rows.
        if f_const and not expr_rows:
            # Nothing symbolic to differentiate: a constant objective and only element families.
            f_total = f_total + ca.Function("f0", [ps], [f_expr])(Pm)
            g_expr_by_slice = {}
        elif expr_rows or self._f is not None:
            fv, g_expr_by_slice = self._expression_derivatives(Xm, Pm, lam_f, lam_g, ps, expr_rows, f_expr,
                                                               exact_hessian, jac, hess, grad)
            f_total = f_total + fv
        else:
            g_expr_by_slice = {}

        for con, g in zip(self._cons.values(), self._g):
            if isinstance(g, _Group):
                gv, jc_, hc_ = self._element_derivatives(g, Xm, Pm, lam_g[con.slice.start:con.slice.stop],
                                                         con.slice.start, exact_hessian, self.compile_elements)
                g_parts.append(gv)
                jac.append(jc_)
                if hc_ is not None:
                    hess.append(hc_)
            else:
                g_parts.append(g_expr_by_slice[con.slice.start])
        for grp in self._f_groups:
            fv, gc_, hc_ = self._element_derivatives(grp, Xm, Pm, lam_f, None, exact_hessian, self.compile_elements)
            f_total = f_total + fv
            grad.append(gc_)
            hess.append(hc_)  # objective families only exist with the exact Hessian

        f_total = ca.densify(f_total)
        G = ca.densify(ca.vertcat(*g_parts)) if g_parts else ca.MX(0, 1)
        Jg = assemble(jac, (self._ng, nx))
        Hl = assemble(hess, (nx, nx), triu=True) if exact_hessian else ca.MX(nx, nx)
        gf = dense_vector(grad, nx)
        funcs = {
            "grad_f": ca.Function("grad_f", [Xm, Pm], [f_total, gf], ["x", "p"], ["f", "grad_f_x"]),
            "jac_g": ca.Function("jac_g", [Xm, Pm], [G, Jg], ["x", "p"], ["g", "jac_g_x"]),
            "hess_lag": ca.Function("hess_lag", [Xm, Pm, lam_f, lam_g], [Hl],
                                    ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"]),
        }
        return Xm, Pm, f_total, G, funcs

    def _expression_derivatives(self, Xm, Pm, lam_f, lam_g, ps, expr_rows, f_expr, exact_hessian, jac, hess, grad):
        """The expression part of the program (rows and objective written as expressions, not element families):
        ordinary SX automatic differentiation, its Jacobian, Hessian and gradient contributions appended to ``jac``,
        ``hess`` and ``grad``.  ``(the objective's value, the rows' values by their first row)``."""
        ge = ca.vertcat(*[g for _, g in expr_rows]) if expr_rows else ca.SX(0, 1)
        rows_of_ge = np.concatenate([np.arange(s.start, s.stop) for s, _ in expr_rows]) if expr_rows \
            else np.zeros(0, dtype=np.int64)
        le = ca.SX.sym("le", ge.numel())
        sf = ca.SX.sym("sf")
        # Differentiate with respect to the variables the expressions use (positions zpos, increasing),
        # not all of them: the cost then does not grow with the size of the element families.
        z, zpos = self._used_variables(ca.vertcat(f_expr, ge))
        Xz = _gather(Xm, zpos)
        Je = ca.jacobian(ge, z)
        ge_grad = ca.gradient(f_expr, z)
        fe = ca.Function("expr", [z, ps],
                         [f_expr, ge, _nz(Je), _nz(ge_grad)])
        fv, gv, jv, gfv = fe(Xz, Pm)
        jr, jc = (np.asarray(v, dtype=np.int64) for v in Je.sparsity().get_triplet())
        jac.append(Contribution(jv, rows_of_ge[jr], zpos[jc]))
        if exact_hessian:
            He = ca.triu(ca.hessian(sf * f_expr + ca.dot(le, ge), z)[0])
            fh = ca.Function("expr_hess", [z, ps, sf, le], [_nz(He)])
            lam_e = lam_g[rows_of_ge.tolist()] if rows_of_ge.size else ca.MX(0, 1)
            hr, hc = (np.asarray(v, dtype=np.int64) for v in He.sparsity().get_triplet())
            # He is the upper triangle in z; zpos is increasing, so it maps to the global upper triangle.
            hess.append(Contribution(fh(Xz, Pm, lam_f, lam_e), zpos[hr], zpos[hc]))
        gr, _ = ge_grad.sparsity().get_triplet()
        grad.append(Contribution(gfv, zpos[np.asarray(gr, dtype=np.int64)], np.zeros(len(gr), dtype=np.int64)))
        g_expr_by_slice = {s.start: gv[i0:i0 + (s.stop - s.start)]
                           for (s, _), i0 in zip(expr_rows, np.cumsum([0] + [s.stop - s.start for s, _ in expr_rows]))}
        return fv, g_expr_by_slice

    def _build_assembled(self, options, verbose, key):
        """Build the solver from element derivatives (see :mod:`castrajectory.solve.assembly`)."""
        t = time.perf_counter()
        # (the assembled functions depend on the program's structure only, not on Ipopt's options: a solve with
        # other options reuses them.  Measured on the hopper at N = 20: its rounds' two option sets each assembled
        # them, 0.09 s a build)
        shape = (sum(b.init.size for b in self._vars), sum(b.init.size for b in self._params), self._ng,
                 len(self._g), len(self._f_groups), id(self._f), self._hessian, self.compile_elements, jit.enabled())
        cached = getattr(self, "_assembled", None)
        if cached is not None and cached[0] == shape:
            Xm, Pm, f_total, G, funcs = cached[1]
        else:
            Xm, Pm, f_total, G, funcs = self._assemble()
            self._assembled = (shape, (Xm, Pm, f_total, G, funcs))
        self._functions = funcs
        # no_nlp_grad: CasADi would otherwise differentiate the whole graph once more (slow to build,
        # and impossible through compiled element functions); Ipopt's own f, g and multipliers are used.
        opts = {"ipopt": self._ipopt_options(options, verbose), "print_time": bool(verbose),
                "error_on_fail": False, "calc_lam_p": False, "no_nlp_grad": True, **funcs}
        self._solver = ca.nlpsol("castrajectory", "ipopt", {"x": Xm, "p": Pm, "f": f_total, "g": G}, opts)
        self._solver_key = key
        self._build_time = (self._t_described - self._t0) + (time.perf_counter() - t)
        return self._solver

    def _used_variables(self, e):
        """The variable symbols ``e`` depends on, stacked, and their positions in the decision vector."""
        syms, pos, off = [], [], 0
        for b in self._vars:
            n = b.init.size
            if ca.depends_on(e, b.sym):
                dep = np.flatnonzero(ca.which_depends(e, b.sym, 1, False))
                syms.append(b.sym[dep.tolist()])
                pos.append(off + dep)
            off += n
        if not syms:
            return ca.SX(0, 1), np.zeros(0, dtype=np.int64)
        return ca.vertcat(*syms), np.concatenate(pos).astype(np.int64)

    @staticmethod
    def _element_derivatives(grp: _Group, Xm, Pm, weight, row0, hessian: bool = True, compile_: bool = True):
        """Values, first-derivative and Hessian contributions of one element family.

        ``row0`` is the first constraint row (None for an objective family, whose
        first derivative is a gradient).  ``weight`` is the multiplier slice
        (constraints) or the objective factor.  With ``hessian=False`` no Hessian is
        formed and the third contribution is None.
        """
        fn, E, r = grp.fn, grp.count, grp.size
        kinds = tuple("x" if isinstance(a, X) and not isinstance(a, P) else "o" for a in grp.args)
        kern = _kernels(fn, kinds, hessian, JIT and compile_)
        call_args, var_idx = [], []
        for i, a in enumerate(grp.args):
            n = fn.size1_in(i) * fn.size2_in(i)
            if isinstance(a, X):
                src = Pm if isinstance(a, P) else Xm
                idx = a.index
                call_args.append(_gather_columns(src, idx, n))
                if not isinstance(a, P):
                    var_idx.append(idx)
            else:
                call_args.append(ca.DM(a.T if a.ndim == 2 else a.reshape(-1, 1)))
        # Global position of each local unknown, per element: (E, nz).
        zidx = np.hstack([np.broadcast_to(idx.reshape(-1, idx.shape[-1]), (E, idx.shape[-1])) for idx in var_idx]) \
            if var_idx else np.zeros((E, 0), dtype=np.int64)
        call_args = [call_args[i] for i in kern.keep]
        values = ca.vec(kern.value(E, call_args))
        jv = ca.vec(kern.jac(E, call_args))
        jr, jc = kern.jac_rc
        hcon = None
        if hessian:
            wv = weight if row0 is None else ca.reshape(weight, r, E)
            hv = ca.vec(kern.hess(E, call_args + [wv]))
            hr, hc = kern.hess_rc
            hcon = Contribution(hv, zidx[:, hr].reshape(-1), zidx[:, hc].reshape(-1))
        if row0 is None:
            # Objective family: value is the sum, first derivative is a gradient.
            fsum = ca.sum1(values)
            gcon = Contribution(jv, zidx[:, jc].reshape(-1), np.zeros(E * jc.size, dtype=np.int64))
            return fsum, gcon, hcon
        rows = (row0 + np.arange(E, dtype=np.int64)[:, None] * r + jr[None, :]).reshape(-1)
        jcon = Contribution(jv, rows, zidx[:, jc].reshape(-1))
        return values, jcon, hcon

    def functions(self) -> Dict[str, ca.Function]:
        """The derivative functions handed to Ipopt (``grad_f``, ``jac_g``, ``hess_lag``).

        Only NLPs with element families assemble them (built on first use); others return ``{}``.
        """
        if self._solver is None:
            self.build()
        return dict(self._functions)

    def _arguments(self, init, warm, bounds) -> dict:
        """Ipopt's ``x0, lbx, ubx, lbg, ubg`` from a guess by name, a warm start and bound overrides."""
        x0 = np.concatenate([b.init for b in self._vars])
        if warm is not None and warm.x is not None:
            x0 = warm.x.copy()
        if init:
            offsets, i = {}, 0
            for b in self._vars:
                offsets[b.name] = (i, b.init.size)
                i += b.init.size
            for name, val in init.items():
                i, n = offsets[name]
                x0[i:i + n] = _column(val, n, f"init[{name}]")
        lbx = np.concatenate([b.lb for b in self._vars])
        ubx = np.concatenate([b.ub for b in self._vars])
        lbg = np.concatenate(self._glb) if self._glb else np.zeros(0)
        ubg = np.concatenate(self._gub) if self._gub else np.zeros(0)
        if bounds:
            lbx, ubx, lbg, ubg = lbx.copy(), ubx.copy(), lbg.copy(), ubg.copy()
            for name, (lo, hi) in bounds.items():
                if name in self._cons:
                    sl = self._cons[name].slice
                    n = sl.stop - sl.start
                    lbg[sl], ubg[sl] = _column(lo, n, f"{name}.lb"), _column(hi, n, f"{name}.ub")
                else:
                    idx = self.index(name)
                    lbx[idx], ubx[idx] = _column(lo, idx.size, f"{name}.lb"), _column(hi, idx.size, f"{name}.ub")
        return dict(x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)

    def _rows_and_gradients(self, x: np.ndarray):
        """Every row ``g(x)`` and each row's largest ``|∂g/∂x|`` (what Ipopt's gradient-based
        scaling reads), from the compiled element kernels the solver uses.  An element's
        derivative entries are taken one by one (a variable entering an element twice is not summed)."""
        p = np.concatenate([b.init for b in self._params]) if self._params else np.zeros(0)
        g, grad = np.empty(self._ng), np.zeros(self._ng)
        exprs = [(c.slice, e) for c, e in zip(self._cons.values(), self._g) if not isinstance(e, _Group)]
        if exprs:
            if getattr(self, "_row_jac_fun", None) is None:
                ge = ca.vertcat(*[e for _, e in exprs])
                self._row_jac_fun = self.evaluator(ge, ca.jacobian(ge, ca.vertcat(*[b.sym for b in self._vars])))
            vals, jac = self._row_jac_fun(x, p)
            vals, jmax = np.asarray(vals).reshape(-1), np.abs(np.asarray(jac)).max(axis=1)
            i = 0
            for sl, _ in exprs:
                n = sl.stop - sl.start
                g[sl], grad[sl] = vals[i:i + n], jmax[i:i + n]
                i += n
        for c, grp in zip(self._cons.values(), self._g):
            if not isinstance(grp, _Group):
                continue
            E, r = grp.count, grp.size
            kinds = tuple("x" if isinstance(a, X) and not isinstance(a, P) else "o" for a in grp.args)
            kern = _kernels(grp.fn, kinds, False, JIT and self.compile_elements)
            call = [ca.DM(v) for v in self._element_values(grp, x, p)]
            call = [call[i] for i in kern.keep]
            g[c.slice] = np.asarray(kern.value(E, call)).reshape(-1, order="F")
            jr, _ = kern.jac_rc
            if jr.size:
                jv = np.abs(np.asarray(kern.jac(E, call))).reshape(jr.size, E, order="F")
                m = np.zeros((r, E))
                for row in np.unique(jr):
                    m[row] = jv[jr == row].max(axis=0)
                grad[c.slice] = m.reshape(-1, order="F")
        return g, grad

    def check(self, init: Dict[str, object], tol: float, bounds: Optional[Dict[str, tuple]] = None) -> NLPResult:
        """Check a point computed elsewhere (e.g. piece by piece) against every row, without Ipopt.

        Only for a *square feasibility problem* (constant objective, no complementarity): there a
        point where every row and bound holds within ``tol`` is a KKT point with zero multipliers
        (``∇f = 0 = ∇gᵀλ``), and it is returned with status ``Rows_Verified``.  Otherwise the
        result fails with ``Rows_Not_Verified`` and the caller solves.  Costs one evaluation of
        the rows, a small fraction of building the solver.
        """
        if self._f_groups or (
                self._f is not None and not ca.SX(self._f).is_constant()):
            raise ValueError("check() is for square feasibility problems (constant objective, no complementarity)")
        t = time.perf_counter()
        a = self._arguments(init, None, bounds)
        x = a["x0"]
        # Ipopt's acceptance: rows scaled as its gradient-based scaling does, within tol; unscaled
        # within constr_viol_tol
        viol, rows = self._row_violation(a, x)
        ok = bool(np.isfinite(viol) and viol <= tol and np.max(rows, initial=0.0) <= 1e-4)
        status = "Rows_Verified" if ok else "Rows_Not_Verified"
        message = NLPResult.describe_status(status) if ok else \
            f"the assembled point misses a row by {viol:.3g} (tolerance {tol:g}); worst row {int(np.argmax(rows))} of {self._ng}"
        f = float(ca.evalf(ca.SX(self._f))) if self._f is not None else 0.0
        return NLPResult(
            values=self._split(x, self._vars), multipliers={c.name: np.zeros(c.size) for c in self._cons.values()},
            bound_multipliers=self._split(np.zeros_like(x), self._vars), objective=f, solver_status=status,
            success=ok, message=message, iterations=0, build_time_s=0.0, solve_time_s=time.perf_counter() - t,
            x=x, lam_x=np.zeros_like(x), lam_g=np.zeros(self._ng))

    def newton(self, init: Dict[str, object], tol: float, bounds: Optional[Dict[str, tuple]] = None,
               max_iter: int = NEWTON_MAX_ITER) -> Optional[NLPResult]:
        """Newton's method on a *square feasibility problem* whose Jacobian has a block triangular form (an
        initial-value trajectory, block triangular in time: :mod:`.triangular`), without Ipopt: from ``init``,
        every row of every step updated at each iteration, its linear solve block by block.  It stops where every
        row and bound holds within ``tol`` as :meth:`check` measures it (Ipopt's scaled rows), with status
        ``Rows_Verified``.  ``None`` where it does not apply (not square, inequality rows, a constant objective
        missing, or one block: a whole factorisation is then as good) or does not get there within ``max_iter``
        contracting iterations (the caller solves with Ipopt, from ``init``); also where its largest block is smaller
        than :data:`NEWTON_MIN_BLOCK`, whose blocks Ipopt factors faster than Python calls them."""
        if self._f_groups or (self._f is not None and not ca.SX(self._f).is_constant()):
            return None
        interrupt.check()
        # (its iterations draw on the iteration budget as Ipopt's do: this program's own, else the run's)
        held = self.budget if self.budget is not None else budget.current()
        if held is not None:
            max_iter = min(max_iter, held.remaining())
        t = time.perf_counter()
        self.newton_iterations = 0
        funcs = self.functions()
        if not funcs or max_iter <= 0:
            return None
        a = self._arguments(init, None, bounds)
        free = np.where(a["lbx"] < a["ubx"])[0]
        eq = np.where(a["lbg"] == a["ubg"])[0]
        if eq.size != free.size or not eq.size or eq.size != a["lbg"].size:
            return None
        x, p = a["x0"].copy(), (np.concatenate([b.init for b in self._params]) if self._params else np.zeros(0))
        gv, Jg = funcs["jac_g"](x, p)
        plan = self._block_plan(Jg.sparsity(), free)
        if plan is None:
            return None
        bt, idx, row_of = plan
        last, it, floor = np.inf, 0, False
        while True:
            g = np.asarray(gv).reshape(-1)
            nz = np.asarray(Jg.nonzeros(), float)
            r = g - a["lbg"]
            # Ipopt's gradient-based scaling of each row, at this point (as check() reads it)
            jmax = np.zeros(g.size)
            np.maximum.at(jmax, row_of, np.abs(nz))
            viol = float(np.max(np.abs(r) * np.minimum(1.0, 100.0 / np.maximum(jmax, 1e-300)), initial=0.0))
            if not np.isfinite(viol):
                break
            if viol <= tol and float(np.max(np.abs(r), initial=0.0)) <= 1e-4:
                break
            if it >= 2 and viol > 0.5 * last and viol <= NEWTON_FLOOR * tol:
                floor = True          # (stalled just above the tolerance: the rows' rounding floor)
                break
            if it >= max_iter or (it >= 2 and viol > 0.5 * last):
                break                 # (not contracting: Ipopt's, from init)
            dx = bt.solve(nz[idx], r)
            if dx is None:
                break
            # a damped step: halved while the rows' largest scaled violation grows (Newton's full step from a
            # guess far from the discrete motion overshoots before it contracts)
            step, x0 = 1.0, x.copy()
            for _ in range(NEWTON_BACKTRACKS + 1):
                x[free] = x0[free] - step * dx
                gv, Jg = funcs["jac_g"](x, p)
                g1 = np.asarray(gv).reshape(-1) - a["lbg"]
                v1 = float(np.max(np.abs(g1) * np.minimum(1.0, 100.0 / np.maximum(jmax, 1e-300)), initial=0.0))
                if np.isfinite(v1) and v1 < viol:
                    break
                step *= 0.5
            last, it = viol, it + 1
        if held is not None:
            held.spend(it)
        #: the iterations of the last Newton attempt (counted with the solve that follows a failed one)
        self.newton_iterations = it
        if not ((viol <= tol or (floor and viol <= NEWTON_FLOOR * tol)) and float(np.max(np.abs(r), initial=0.0)) <= 1e-4):
            return None
        f = float(ca.evalf(ca.SX(self._f))) if self._f is not None else 0.0
        return NLPResult(
            values=self._split(x, self._vars), multipliers={c.name: np.zeros(c.size) for c in self._cons.values()},
            bound_multipliers=self._split(np.zeros_like(x), self._vars), objective=f, solver_status="Rows_Verified",
            success=True, message=f"Newton's method on the square system converged in {it} iterations, each "
            "linear solve block by block in its block triangular form; every row holds to the requested tolerance",
            iterations=it, build_time_s=0.0, solve_time_s=time.perf_counter() - t,
            x=x, lam_x=np.zeros_like(x), lam_g=np.zeros(self._ng))

    def _block_plan(self, sp: ca.Sparsity, free: np.ndarray, build: bool = True):
        """``(BlockTriangular of J_EF, J's nonzeros of J_EF in its order, each nonzero's row)``, kept per pattern
        (every row an equality); None where the form has no use (one block, blocks smaller than
        :data:`NEWTON_MIN_BLOCK`, or not triangular), or, without ``build``, where none was made before."""
        key = (sp.size1(), sp.size2(), sp.nnz(), free.tobytes())
        cache = self.__dict__.setdefault("_block_plans", {})
        if key in cache or not build:
            return cache.get(key)
        rows, cols = (np.asarray(v, int) for v in sp.get_triplet())
        col_of = np.full(sp.size2(), -1)
        col_of[free] = np.arange(free.size)
        keep = np.flatnonzero(col_of[cols] >= 0)
        r, c = rows[keep], col_of[cols[keep]]
        order = np.lexsort((r, c))                     # column-major, as CasADi stores a pattern
        sub = ca.Sparsity.triplet(int(sp.size1()), int(free.size), r[order].tolist(), c[order].tolist())
        bt = BlockTriangular(sub, min_block=NEWTON_MIN_BLOCK)
        plan = (bt, keep[order], rows) if bt.applies else None
        cache[key] = plan
        return plan

    def certify(self, init: Dict[str, object], tol: float, bounds: Optional[Dict[str, tuple]] = None,
                newton: bool = True) -> NLPResult:
        """Certify a point computed elsewhere as a KKT point of this NLP, without Ipopt.

        For a *square branch* (after ``bounds``: as many equality rows as free variables), e.g. a
        complementarity problem whose every pair is decided and a point solved row by row.  The point
        must satisfy every row and bound within ``tol`` (scaled as Ipopt scales rows, as in
        :meth:`check`); the multipliers of the equality rows then follow from stationarity on the free
        variables, ``J_EFᵀ λ_E = −∇_F f`` (one sparse QR), inequality rows and free bounds get zero
        multipliers (they hold; weakly active ones are not needed), and fixed variables take what is
        left, ``λ_x = −(∇f + Jᵀλ)``.  The result is ``Rows_Verified`` (a success, with multipliers
        and objective) when that solve leaves a stationarity residual within ``tol`` (per variable,
        relative to ``|∇f| + |J|ᵀ|λ|``: a backward error); otherwise ``Rows_Not_Verified`` and the caller solves.  With ``newton``, the
        point first takes one Newton step of the whole square system (``J_EF Δx = −g_E``).
        """
        t = time.perf_counter()
        funcs = self.functions()
        if not funcs:
            raise ValueError("certify() needs an NLP of element families")
        a = self._arguments(init, None, bounds)
        x = a["x0"]
        p = np.concatenate([b.init for b in self._params]) if self._params else np.zeros(0)
        free = np.where(a["lbx"] < a["ubx"])[0]
        eq = np.where(a["lbg"] == a["ubg"])[0]
        if newton and eq.size == free.size:
            x = self._newton_step(funcs, a, x, p, free, eq, tol)
        viol, _ = self._row_violation(a, x)
        gv, Jg = funcs["jac_g"](x, p)
        f, gf = funcs["grad_f"](x, p)
        gf = np.asarray(gf).reshape(-1)
        lam_g = np.zeros(self._ng)
        resid = np.inf
        why = f"the point misses a row by {viol:.3g} (tolerance {tol:g})"
        # rows as Ipopt scales them (a row of a very short step has large derivatives and rounding
        # to match: its unscaled size says nothing)
        if viol <= tol:
            if eq.size != free.size:
                why = f"not a square branch ({eq.size} equality rows, {free.size} free variables)"
            elif not np.any(gf[free]):
                # a constant objective on the free variables: zero multipliers are exact
                lam, resid = np.zeros(eq.size), 0.0
            else:
                A = Jg[eq.tolist(), free.tolist()]
                try:
                    lam = np.asarray(ca.solve(A.T, ca.DM(-gf[free]), "qr")).reshape(-1)
                except RuntimeError as exc:
                    interrupt.reraise(exc)
                    lam = np.full(eq.size, np.nan)
                lam_g[eq] = lam
                stat = gf + np.asarray(ca.mtimes(Jg.T, ca.DM(lam_g))).reshape(-1)
                # backward error: each variable's stationarity relative to the size of its terms
                # (rows of very short steps have derivatives ~ 1/h², and rounding to match)
                size = np.abs(gf) + np.asarray(ca.mtimes(ca.fabs(Jg).T, ca.DM(np.abs(lam_g)))).reshape(-1)
                back = np.abs(stat[free]) / np.maximum(size[free], 1e-300)
                resid = float(np.max(back, initial=0.0))
                worst = int(free[np.argmax(back)]) if back.size else 0
                why = (f"stationarity holds only to {resid:.3g} (tolerance {tol:g}) at variable "
                       f"{self._variable_name(worst)}: a singular branch")
        ok = bool(np.isfinite(resid) and resid <= tol)
        lam_x = np.zeros_like(x)
        if ok:
            lam_x = -(gf + np.asarray(ca.mtimes(Jg.T, ca.DM(lam_g))).reshape(-1))
            lam_x[free] = 0.0
        status = "Rows_Verified" if ok else "Rows_Not_Verified"
        message = NLPResult.describe_status(status) if ok else why
        return NLPResult(
            values=self._split(x, self._vars),
            multipliers={c.name: lam_g[c.slice] for c in self._cons.values()},
            bound_multipliers=self._split(lam_x, self._vars), objective=float(f), solver_status=status,
            success=ok, message=message, iterations=0, build_time_s=self._build_time,
            solve_time_s=time.perf_counter() - t, x=x, lam_x=lam_x, lam_g=lam_g)

    def _newton_step(self, funcs, a: dict, x: np.ndarray, p: np.ndarray, free, eq, tol: float) -> np.ndarray:
        """One Newton step of the square system ``J_EF Δx = −g_E`` from ``x``: a point solved piece by
        piece carries each piece's rounding forward (a march drifts by 3e-12 m over 176 steps of a free
        fall), and Ipopt stops at ``tol`` on rows it scales down by up to ``100/|∇g|`` (a whole
        trajectory on short steps: an unscaled residual 10⁵ times ``tol``, which a chaotic motion then
        amplifies); the whole system's step removes both.  Sparse QR (CasADi's CSparse LU has no fill-
        reducing ordering: 17 GB for a galerkin4 trajectory of 32000 steps).  Kept unless it makes the
        rows worse beyond rounding (scaled as Ipopt scales them, ``min(1, 100/max_j |J_ij|)``; a nearly
        singular branch).  Returns the new ``x``."""
        gv, Jg = funcs["jac_g"](x, p)
        rows, _ = Jg.sparsity().get_triplet()
        jmax = np.zeros(Jg.size1())
        np.maximum.at(jmax, np.asarray(rows, int), np.abs(np.asarray(Jg.nonzeros(), float)))
        scale = np.minimum(1.0, 100.0 / np.maximum(jmax[eq], 1e-300))
        dx, r = self._newton_direction(gv, Jg, a, free, eq)
        before = float(np.max(np.abs(r) * scale, initial=0.0))
        if dx is None:
            return x
        xn = x.copy()
        xn[free] -= dx
        after = np.asarray(funcs["jac_g"](xn, p)[0]).reshape(-1)[eq] - a["lbg"][eq]
        bounds_ok = np.all(xn[free] >= a["lbx"][free] - 1e-3 * tol) and np.all(xn[free] <= a["ubx"][free] + 1e-3 * tol)
        if bounds_ok and float(np.max(np.abs(after) * scale, initial=0.0)) <= max(before, 1e-3 * tol):
            return xn
        return x

    def _newton_direction(self, gv, Jg, a: dict, free, eq):
        """``(Δx, g_E)``: the Newton step ``J_EF⁻¹ g_E`` of the square system's equality rows (``None`` where the
        sparse QR fails or gives non-finite values), and their residual against their right-hand sides.  Block by
        block where every row is an equality and the Jacobian has a block triangular form (:mod:`.triangular`:
        an initial-value trajectory; the whole sparse QR took 0.37 s on a 24-link chain in maximal coordinates)."""
        r = np.asarray(gv).reshape(-1)[eq] - a["lbg"][eq]
        # (the plan of a Newton solve of this program, where one ran: its form is not looked for here, where the
        # whole QR is as good for the small steps that Newton leaves to Ipopt)
        plan = self._block_plan(Jg.sparsity(), free, build=False) if eq.size == np.asarray(gv).size else None
        if plan is not None:
            bt, idx, _ = plan
            dx = bt.solve(np.asarray(Jg.nonzeros(), float)[idx], r)
            return dx, r
        try:
            dx = np.asarray(ca.solve(Jg[eq.tolist(), free.tolist()], ca.DM(r), "qr")).reshape(-1)
        except RuntimeError as exc:
            interrupt.reraise(exc)
            return None, r
        return (dx if np.all(np.isfinite(dx)) else None), r

    def _square(self, init: Dict[str, object], bounds: Optional[Dict[str, tuple]]):
        """``(functions, arguments, x, parameters, free variables, equality rows)`` at ``init``, or ``None`` where
        the problem has no element functions or is not square (as many equality rows as free variables)."""
        funcs = self.functions()
        if not funcs:
            return None
        a = self._arguments(init, None, bounds)
        free = np.where(a["lbx"] < a["ubx"])[0]
        eq = np.where(a["lbg"] == a["ubg"])[0]
        if eq.size != free.size or not free.size:
            return None
        p = np.concatenate([b.init for b in self._params]) if self._params else np.zeros(0)
        return funcs, a, a["x0"], p, free, eq

    def polish(self, init: Dict[str, object], tol: float, bounds: Optional[Dict[str, tuple]] = None
               ) -> Dict[str, np.ndarray]:
        """The values of ``init`` after one Newton step of the square system (see :meth:`_newton_step`);
        ``init`` itself where the problem is not square or the step does not help."""
        sq = self._square(init, bounds)
        if sq is None:
            return self._split(self._arguments(init, None, bounds)["x0"], self._vars)
        funcs, a, x, p, free, eq = sq
        return self._split(self._newton_step(funcs, a, x, p, free, eq, tol), self._vars)

    def floor(self, init: Dict[str, object], bounds: Optional[Dict[str, tuple]] = None
              ) -> Optional[Dict[str, np.ndarray]]:
        """How far ``init`` is from the exact solution of the square system's rows, per variable: the
        size of the Newton step ``|J_EF⁻¹ g_E|`` at it (one sparse factorisation; ``None`` where the
        problem is not square).  At a converged point the computed residual ``g_E`` is the solver's
        tolerance and the rows' evaluation rounding, and ``J⁻¹`` amplifies both by the conditioning
        (a chaotic horizon's growth included): no difference of grids can be trusted below it.  (A
        synthetic rounding residual ``u |J| |x|`` overstates the rows' rounding by ``|q| / |Δq|`` on
        short steps, where ``q_{k+1} − q_k`` is computed exactly: 16x the true error on the chaotic
        double pendulum at N = 16000.)  Fixed variables get 0."""
        sq = self._square(init, bounds)
        if sq is None:
            return None
        funcs, a, x, p, free, eq = sq
        d, _ = self._newton_direction(*funcs["jac_g"](x, p), a, free, eq)
        if d is None:
            return None
        out = np.zeros_like(x)
        out[free] = np.abs(d)
        return self._split(out, self._vars)

    def _variable_name(self, i: int) -> str:
        """``name[j]`` of entry ``i`` of the variable vector."""
        for b in self._vars:
            if i < b.init.size:
                return f"{b.name}[{i}]"
            i -= b.init.size
        return f"x[{i}]"

    def _row_violation(self, a: dict, x: np.ndarray):
        """Largest scaled violation of the rows and bounds of ``a`` at ``x`` (Ipopt's gradient-based
        scaling: a row whose largest derivative exceeds 100 is divided by it / 100), and the unscaled
        row violations."""
        g, grad = self._rows_and_gradients(x)
        scale = np.minimum(1.0, 100.0 / np.maximum(grad, 1e-300))
        rows = np.maximum(a["lbg"] - g, g - a["ubg"])
        viol = max(float(np.max(rows * scale, initial=0.0)),
                   float(np.max(np.maximum(a["lbx"] - x, x - a["ubx"]), initial=0.0)))
        return viol, rows

    def solve(self, init: Optional[Dict[str, object]] = None, *, warm: Optional[NLPResult] = None,
              options: Optional[dict] = None, verbose: bool = False, expand: bool = False,
              bounds: Optional[Dict[str, tuple]] = None) -> NLPResult:
        """Solve and return a :class:`~castrajectory.result.NLPResult` (never raises on non-convergence).

        Parameters
        ----------
        init: initial guesses by variable name (defaults: the ``init`` given to :meth:`variable`).
        warm: a previous result of this NLP; its primal and dual values start the solve.
        options: Ipopt options overriding :data:`DEFAULT_IPOPT_OPTIONS`.
        verbose: stream Ipopt's banner and iteration log.
        bounds: ``{name: (lb, ub)}`` overriding, for this solve only, the bounds of a
            variable block or a constraint (``(-inf, inf)`` switches a constraint off;
            ``lb == ub`` fixes variables, which Ipopt then removes).
        """
        interrupt.check()           # (a signal a finaliser or CasADi dropped since the last solve stops here)
        # the iteration budget (solve.budget): this program's own, else the run's; at most what is left, and nothing
        # once it is spent
        held = self.budget if self.budget is not None else budget.current()
        if held is not None:
            cap = int((options or {}).get("max_iter", DEFAULT_IPOPT_OPTIONS.get("max_iter", 3000)))
            options = dict(options or {}, max_iter=min(cap, max(held.remaining(), 1)))
        solver = self.build(options, verbose, expand)
        build_time = self._build_time
        args = self._arguments(init, warm, bounds)
        if warm is not None and warm.lam_g is not None:
            args.update(lam_x0=warm.lam_x, lam_g0=warm.lam_g)

        p = np.concatenate([b.init for b in self._params]) if self._params else np.zeros(0)
        t = time.perf_counter()
        if held is not None and held.remaining() == 0:
            # the iteration budget is spent: not solved, and Ipopt not started
            nx = np.asarray(args["x0"]).size
            sol = {"x": args["x0"], "lam_x": np.zeros(nx), "lam_g": np.zeros(self._ng), "f": float("nan")}
            status, iters = "Maximum_Iterations_Exceeded", 0
        else:
            # an interrupt stops Ipopt between iterations and is raised here, not reported as a
            # failed solve that a strategy would retry (solve.interrupt)
            with interrupt.watching():
                sol = solver(p=p, **args)
            interrupt.raise_if_interrupted()
            stats = self.last_stats = solver.stats()
            status = stats.get("return_status", "unknown")
            iters = int(stats.get("iter_count", 0))
            if held is not None:
                held.spend(iters)
        total_time = time.perf_counter() - t

        x = np.asarray(sol["x"]).reshape(-1)
        lam_x = np.asarray(sol["lam_x"]).reshape(-1)
        lam_g = np.asarray(sol["lam_g"]).reshape(-1)
        success = status in SUCCESS_STATUSES
        message = NLPResult.describe_status(status)
        res = NLPResult(
            values=self._split(x, self._vars),
            multipliers={c.name: -lam_g[c.slice] for c in self._cons.values()},
            bound_multipliers=self._split(-lam_x, self._vars),
            objective=float(sol["f"]),
            solver_status=status,
            success=success,
            message=message,
            iterations=iters,
            build_time_s=build_time,
            solve_time_s=total_time,
            x=x, lam_x=lam_x, lam_g=lam_g,
        )
        return res
