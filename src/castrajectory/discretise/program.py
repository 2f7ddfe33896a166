"""The named program: decision variables, parameters, constraints and one objective, by name.

A :class:`Program` is what a discretisation writes: it collects named decision
variables, parameters, constraints (equalities, inequalities and complementarity
pairs) and one objective, each as an expression or as an *element family* (one
small CasADi function evaluated for every element on index arrays into the
decision vector: :meth:`Program.equal_elements` and friends)::

    nlp = NLP()                                   # castrajectory.solve.nlp.NLP is a Program
    x = nlp.variable("x", 3, lb=0.0, init=1.0)
    nlp.minimize(casadi.sumsqr(x - 2))
    nlp.equal("budget", casadi.sum1(x), 3.0)

Nothing here calls Ipopt: :class:`castrajectory.solve.nlp.NLP` adds the hand-off
(assembled derivatives, compiled elements, the solve and its result).  The sign
of every multiplier is documented once, in :mod:`castrajectory.result`:
``multiplier = d f*/d bound``.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Union

import casadi as ca
import numpy as np

Number = Union[float, int]
Expr = Union[ca.SX, ca.MX, ca.DM, float, np.ndarray]


@dataclass(frozen=True)
class Constraint:
    """Handle returned when a constraint is added; look multipliers up by ``name``."""

    name: str
    kind: str  # "equality", "inequality"
    size: int
    slice: slice


@dataclass
class _Block:
    name: str
    sym: object
    lb: np.ndarray
    ub: np.ndarray
    init: np.ndarray


class X:
    """Element argument read from the decision vector at ``index``.

    ``index`` has shape ``(E, n)`` (row ``e`` feeds element ``e``) or ``(n,)``
    (the same entries for every element).  Positions come from :meth:`NLP.index`.
    """

    def __init__(self, index):
        self.index = np.asarray(index, dtype=np.int64)


class P(X):
    """Element argument read from the parameter vector at ``index`` (see :meth:`NLP.parameter_index`)."""


@dataclass
class _Group:
    """A family of ``count`` identical constraints or objective terms."""

    name: str
    fn: ca.Function
    args: list  # X, P or constant arrays of shape (E, n) / (n,)
    count: int
    size: int  # outputs per element


def _element_args(fn: ca.Function, args: Sequence, where: str):
    if fn.n_out() != 1:
        raise ValueError(f"{where}: the element function must have exactly one output")
    if len(args) != fn.n_in():
        raise ValueError(f"{where}: {fn.n_in()} arguments expected, got {len(args)}")
    count, out = None, []
    for i, a in enumerate(args):
        n = fn.size1_in(i) * fn.size2_in(i)
        if isinstance(a, X):
            arr = a.index
        else:
            arr = np.asarray(a, dtype=float)
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"{where}: argument {i} is not finite")
        if arr.ndim == 0:
            arr = arr.reshape(1)
        if arr.ndim == 1:
            if arr.size != n:
                raise ValueError(f"{where}: argument {i} needs {n} entries per element, got {arr.size}")
        elif arr.ndim == 2:
            if arr.shape[1] != n:
                raise ValueError(f"{where}: argument {i} needs {n} columns, got {arr.shape[1]}")
            if count is not None and arr.shape[0] != count:
                raise ValueError(f"{where}: argument {i} has {arr.shape[0]} elements, expected {count}")
            count = arr.shape[0]
        else:
            raise ValueError(f"{where}: argument {i} must be 1-D or 2-D")
        out.append(type(a)(arr) if isinstance(a, X) else arr)
    if count is None:
        count = 1
    return out, count


def _nz(M):
    """The structural nonzeros of an SX matrix as a dense column (constant zeros kept)."""
    return ca.densify(ca.vertcat(*M.nonzeros())) if M.nnz() else ca.SX(0, 1)


def _column(value, n: int, what: str) -> np.ndarray:
    arr = np.asarray(value, dtype=float).reshape(-1)
    if arr.size == 1:
        arr = np.full(n, float(arr[0]))
    if arr.size != n:
        raise ValueError(f"{what}: expected {n} values, got {arr.size}")
    return arr



class Program:
    """A nonlinear program with named variables and constraints (the description; see module doc).

    Parameters
    ----------
    symbolic:
        ``casadi.SX`` (default: fastest for scalar-heavy expressions) or
        ``casadi.MX`` (for graphs built with ``map``).
    hessian:
        ``"exact"`` (default) or ``"zero"``.  ``"zero"`` hands the solver a zero
        Hessian of the Lagrangian.  It is exact for a *square feasibility
        problem* (objective ≡ 0, as many independent equalities as unknowns):
        there ``∇gᵀλ = 0`` forces ``λ = 0``, the Lagrangian's Hessian vanishes at
        the solution and the primal Newton step ``-J⁻¹g`` does not depend on it.
        It saves the most expensive derivative evaluation (element families only).
    """

    def __init__(self, symbolic=ca.SX, hessian: str = "exact"):
        if hessian not in ("exact", "zero"):
            raise ValueError("hessian must be 'exact' or 'zero'")
        self._sym = symbolic
        self._hessian = hessian
        self._t0 = time.perf_counter()
        self._t_described = self._t0  # end of the last description call
        self._vars: List[_Block] = []
        self._params: List[_Block] = []
        self._g: List[object] = []
        self._glb: List[np.ndarray] = []
        self._gub: List[np.ndarray] = []
        self._cons: Dict[str, Constraint] = {}
        self._ng = 0
        #: complementarity pairs the program holds by other means than complementarity() (an exact
        #: penalty of the products, say), declared by name and count by whoever writes them
        self.declared_pairs: Dict[str, int] = {}
        self._f = None
        self._f_groups: List[_Group] = []
        self._solver = None
        self._solver_key = None
        self._build_time = None
        self._functions: Dict[str, ca.Function] = {}

    # ------------------------------------------------------------------ description
    def variable(self, name: str, size: int = 1, lb: Number = -np.inf, ub: Number = np.inf, init=0.0):
        """Add a column of ``size`` decision variables; return its symbol."""
        self._check_new(name)
        sym = self._sym.sym(name, size)
        self._vars.append(_Block(name, sym, _column(lb, size, f"{name}.lb"), _column(ub, size, f"{name}.ub"),
                                 _column(init, size, f"{name}.init")))
        self._t_described = time.perf_counter()
        return sym

    def parameter(self, name: str, size: int = 1, value=0.0):
        """Add a column of parameters (fixed during a solve, changeable between solves)."""
        self._check_new(name)
        sym = self._sym.sym(name, size)
        v = _column(value, size, f"{name}.value")
        self._params.append(_Block(name, sym, v, v, v))
        return sym

    def set_parameter(self, name: str, value) -> None:
        for p in self._params:
            if p.name == name:
                p.init = _column(value, p.init.size, f"{name}.value")
                return
        raise KeyError(name)

    def parameter_value(self, name: str) -> np.ndarray:
        """The current value of parameter block ``name``."""
        for p in self._params:
            if p.name == name:
                return np.array(p.init, float).reshape(-1)
        raise KeyError(name)

    def minimize(self, expr) -> None:
        if self._f is not None:
            raise ValueError("the objective is already set")
        self._f = expr
        self._t_described = time.perf_counter()

    def equal(self, name: str, expr, rhs=0.0) -> Constraint:
        """Add ``expr == rhs``; its multiplier is ``d f*/d rhs``."""
        n = expr.numel()
        r = _column(rhs, n, f"{name}.rhs")
        return self._add(name, "equality", expr, r, r)

    def inequality(self, name: str, expr, lb=-np.inf, ub=np.inf) -> Constraint:
        """Add ``lb <= expr <= ub``; its multiplier is ``d f*/d(active bound)``."""
        n = expr.numel()
        lo, hi = _column(lb, n, f"{name}.lb"), _column(ub, n, f"{name}.ub")
        if np.any(lo > hi):
            raise ValueError(f"{name}: lower bound above upper bound")
        return self._add(name, "inequality", expr, lo, hi)

    # ------------------------------------------------------------------ element families
    @staticmethod
    def _position(blocks, name: str) -> np.ndarray:
        i = 0
        for b in blocks:
            if b.name == name:
                return np.arange(i, i + b.init.size)
            i += b.init.size
        raise KeyError(name)

    def index(self, name: str) -> np.ndarray:
        """Positions of variable block ``name`` in the stacked decision vector."""
        return self._position(self._vars, name)

    def parameter_index(self, name: str) -> np.ndarray:
        """Positions of parameter block ``name`` in the stacked parameter vector."""
        return self._position(self._params, name)

    def _group(self, name, fn, args) -> _Group:
        if self._sym is not ca.SX:
            raise ValueError("element families need an SX-based NLP (the default)")
        args, count = _element_args(fn, args, name)
        return _Group(name, fn, args, count, fn.size1_out(0) * fn.size2_out(0))

    def equal_elements(self, name: str, fn: ca.Function, args: Sequence, rhs=0.0) -> Constraint:
        """Add ``fn(args_e) == rhs`` for every element ``e``; rows are element-major.

        Each entry of ``args`` is :class:`X` (decision variables), :class:`P`
        (parameters) or a constant array, with one row per element or one row
        shared by all elements.
        """
        grp = self._group(name, fn, args)
        n = grp.count * grp.size
        r = _column(rhs, n, f"{name}.rhs")
        return self._add(name, "equality", grp, r, r)

    def inequality_elements(self, name: str, fn: ca.Function, args: Sequence, lb=-np.inf, ub=np.inf) -> Constraint:
        """Add ``lb <= fn(args_e) <= ub`` for every element (see :meth:`equal_elements`)."""
        grp = self._group(name, fn, args)
        n = grp.count * grp.size
        lo, hi = _column(lb, n, f"{name}.lb"), _column(ub, n, f"{name}.ub")
        if np.any(lo > hi):
            raise ValueError(f"{name}: lower bound above upper bound")
        return self._add(name, "inequality", grp, lo, hi)

    def minimize_elements(self, name: str, fn: ca.Function, args: Sequence) -> None:
        """Add ``sum_e fn(args_e)`` (scalar ``fn``) to the objective."""
        grp = self._group(name, fn, args)
        if grp.size != 1:
            raise ValueError(f"{name}: an objective element must be scalar")
        self._f_groups.append(grp)
        self._t_described = time.perf_counter()

    def constraint(self, name: str) -> Constraint:
        return self._cons[name]

    @property
    def variable_names(self) -> List[str]:
        return [b.name for b in self._vars]

    @property
    def parameter_names(self) -> List[str]:
        return [b.name for b in self._params]

    @property
    def constraint_names(self) -> List[str]:
        return list(self._cons)

    def sizes(self) -> Dict[str, int]:
        """What the program carries: decision variables, parameters, equality and inequality rows."""
        rows = {"equality": 0, "inequality": 0}
        for c in self._cons.values():
            rows[c.kind] += c.size
        return {"variables": int(sum(b.init.size for b in self._vars)),
                "parameters": int(sum(b.init.size for b in self._params)),
                "equality_rows": rows["equality"], "inequality_rows": rows["inequality"]}

    def jacobian_nonzeros(self) -> int:
        """Structural nonzeros of the constraint Jacobian carried by the element families (each element's
        Jacobian with respect to its variable inputs, times the family's count): what the linear solver's
        memory grows with."""
        total = 0
        for g in self._g:
            if not isinstance(g, _Group):
                continue
            per = 0
            for i, a in enumerate(g.args):
                if isinstance(a, X) and not isinstance(a, P):  # variables, not parameters
                    per += g.fn.sparsity_jac(i, 0).nnz()
            total += per * int(g.count)
        return int(total)

    def anatomy(self) -> dict:
        """What the program carries, read from its description: variables, equality and inequality rows,
        complementarity pairs (:attr:`declared_pairs`: a transcription that poses pairs, as the contact one
        does with its exact penalties, declares them), and each element family: its kind, elements, inputs and outputs per
        element, and the size of its function (SX instructions)."""
        pairs = sum(int(v) for v in self.declared_pairs.values())
        kinds = {}
        for c, g in zip(self._cons.values(), self._g):
            if isinstance(g, _Group):
                kinds[g.name] = c.kind
        families = []
        for g in [g for g in self._g if isinstance(g, _Group)] + list(self._f_groups):
            fn = g.fn
            families.append({"name": g.name, "kind": kinds.get(g.name, "objective"), "elements": int(g.count),
                             "inputs": int(sum(fn.nnz_in(i) for i in range(fn.n_in()))), "outputs": int(g.size),
                             "instructions": int(fn.n_instructions()) if fn.is_a("SXFunction") else None})
        return {**self.sizes(), "complementarity_pairs": int(pairs), "families": families}

    def _check_new(self, name: str) -> None:
        if self._solver is not None:
            raise RuntimeError("the NLP cannot change after its solver was built")
        if any(b.name == name for b in self._vars + self._params):
            raise ValueError(f"duplicate name {name!r}")

    def _add(self, name, kind, expr, lb, ub) -> Constraint:
        if self._solver is not None:
            raise RuntimeError("the NLP cannot change after its solver was built")
        if name in self._cons:
            raise ValueError(f"duplicate constraint name {name!r}")
        if isinstance(expr, _Group):
            n = expr.count * expr.size
            self._g.append(expr)
        else:
            n = expr.numel()
            self._g.append(ca.vec(expr))
        con = Constraint(name, kind, n, slice(self._ng, self._ng + n))
        self._glb.append(lb)
        self._gub.append(ub)
        self._cons[name] = con
        self._ng += n
        self._t_described = time.perf_counter()
        return con

    def _split(self, vec, blocks) -> Dict[str, np.ndarray]:
        out, i = {}, 0
        for b in blocks:
            n = b.init.size
            out[b.name] = vec[i:i + n].copy()
            i += n
        return out

    def row_values(self, x: np.ndarray, p: Optional[np.ndarray] = None) -> np.ndarray:
        """Every row ``g(x)`` of the program at the stacked primal ``x`` (numbers, in row order).

        Element families are evaluated element by element (mapped), expressions by one function;
        nothing is differentiated.
        """
        if p is None:
            p = np.concatenate([b.init for b in self._params]) if self._params else np.zeros(0)
        x = np.asarray(x, float).reshape(-1)
        out = np.empty(self._ng)
        exprs = [(c.slice, g) for c, g in zip(self._cons.values(), self._g) if not isinstance(g, _Group)]
        if exprs:
            if getattr(self, "_row_fun", None) is None:
                self._row_fun = self.evaluator(ca.vertcat(*[g for _, g in exprs]))
            vals, i = np.asarray(self._row_fun(x, p)).reshape(-1), 0
            for sl, _ in exprs:
                out[sl] = vals[i:i + sl.stop - sl.start]
                i += sl.stop - sl.start
        for c, g in zip(self._cons.values(), self._g):
            if isinstance(g, _Group):
                fn = g.fn.map(g.count) if g.count > 1 else g.fn
                out[c.slice] = np.asarray(fn(*self._element_values(g, x, p))).reshape(-1, order="F")
        return out

    @staticmethod
    def _element_values(g: _Group, x: np.ndarray, p: np.ndarray) -> list:
        """The arguments of an element family at ``(x, p)``: one column per element (or one shared)."""
        call = []
        for a in g.args:
            if isinstance(a, X):
                v = (p if isinstance(a, P) else x)[a.index]
                call.append(v.T if v.ndim == 2 else v.reshape(-1, 1))
            else:
                call.append(a.T if a.ndim == 2 else a.reshape(-1, 1))
        return call

    def evaluator(self, *exprs) -> ca.Function:
        """A CasADi function ``(x, p) -> exprs`` of the stacked variables and parameters."""
        xs = ca.vertcat(*[b.sym for b in self._vars])
        ps = ca.vertcat(*[b.sym for b in self._params]) if self._params else self._sym(0, 1)
        return ca.Function("evaluate", [xs, ps], list(exprs))

    def evaluate(self, result, *exprs) -> list:
        """Values of expressions of this program's symbols at a result (its stacked primal ``x``), as flat numpy arrays."""
        p = np.concatenate([b.init for b in self._params]) if self._params else np.zeros(0)
        out = self.evaluator(*exprs)(result.x, p)
        out = out if isinstance(out, (list, tuple)) else [out]
        return [np.asarray(v, float).reshape(-1) for v in out]
