"""Named nonlinear programs, solved with CasADi ``nlpsol`` and Ipopt.

An :class:`NLP` collects named decision variables, parameters, constraints
(equalities, inequalities and complementarity pairs) and one objective::

    nlp = NLP()
    x = nlp.variable("x", 3, lb=0.0, init=1.0)
    nlp.minimize(casadi.sumsqr(x - 2))
    nlp.equal("budget", casadi.sum1(x), 3.0)
    res = nlp.solve()
    res["x"], res.multipliers["budget"]      # d f*/d(budget) = -2/3 * ... (see result.py)

The sign of every multiplier is documented once, in :mod:`castrajectory.result`:
``multiplier = d f*/d bound``.

The Ipopt solver is created once, on the first call to :meth:`NLP.solve`, and
reused by later calls (new initial guesses, parameter values or relaxation
steps), so construction cost is paid once and reported as ``build_time_s``.

Complementarity pairs ``0 <= a  ⟂  b >= 0`` are relaxed in the Scholtes way,
``a >= 0, b >= 0, a_i b_i <= sigma``, and solved by a homotopy ``sigma -> 0``
that warm-starts each step from the last (see :meth:`NLP.solve`).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Dict, Iterable, List, Optional, Sequence, Union

import casadi as ca
import numpy as np

from .result import SUCCESS_STATUSES, HomotopyStep, Result

Number = Union[float, int]
Expr = Union[ca.SX, ca.MX, ca.DM, float, np.ndarray]

#: Ipopt options used unless the caller overrides them.
#: MUMPS scaling is switched off: on the large, sparse, square systems of this
#: library the default scaling made MUMPS fail at the first iteration
#: (see shared design notes); without it the same problems converge in a few
#: iterations.
DEFAULT_IPOPT_OPTIONS: Dict[str, object] = {
    "tol": 1e-10,
    "max_iter": 200,
    "mumps_scaling": 0,
    "mumps_permuting_scaling": 0,
}


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


def _column(value, n: int, what: str) -> np.ndarray:
    arr = np.asarray(value, dtype=float).reshape(-1)
    if arr.size == 1:
        arr = np.full(n, float(arr[0]))
    if arr.size != n:
        raise ValueError(f"{what}: expected {n} values, got {arr.size}")
    return arr


class NLP:
    """A nonlinear program with named variables and constraints.

    Parameters
    ----------
    symbolic:
        ``casadi.SX`` (default: fastest for scalar-heavy expressions) or
        ``casadi.MX`` (for graphs built with ``map``).
    """

    def __init__(self, symbolic=ca.SX):
        self._sym = symbolic
        self._t0 = time.perf_counter()
        self._t_described = self._t0  # end of the last description call
        self._vars: List[_Block] = []
        self._params: List[_Block] = []
        self._g: List[object] = []
        self._glb: List[np.ndarray] = []
        self._gub: List[np.ndarray] = []
        self._cons: Dict[str, Constraint] = {}
        self._ng = 0
        self._comps: List[tuple] = []  # (name, a, b) expressions
        self._f = None
        self._solver = None
        self._solver_key = None
        self._build_time = None

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

    def complementarity(self, name: str, a, b) -> Constraint:
        """Add the pairs ``0 <= a_i  ⟂  b_i >= 0``.

        The multipliers of ``a >= 0`` and ``b >= 0`` are reported as
        ``"<name>.a"`` and ``"<name>.b"``; the relaxed products as ``"<name>"``.
        """
        if a.numel() != b.numel():
            raise ValueError(f"{name}: both sides of a complementarity pair need the same size")
        n = a.numel()
        self._add(f"{name}.a", "inequality", a, np.zeros(n), np.full(n, np.inf))
        self._add(f"{name}.b", "inequality", b, np.zeros(n), np.full(n, np.inf))
        if "__sigma" not in [p.name for p in self._params]:
            self.parameter("__sigma", 1, 0.0)
        sigma = [p.sym for p in self._params if p.name == "__sigma"][0]
        con = self._add(name, "inequality", a * b - sigma, np.full(n, -np.inf), np.zeros(n))
        self._comps.append((name, a, b))
        return con

    @property
    def has_complementarity(self) -> bool:
        return bool(self._comps)

    def constraint(self, name: str) -> Constraint:
        return self._cons[name]

    @property
    def variable_names(self) -> List[str]:
        return [b.name for b in self._vars]

    @property
    def constraint_names(self) -> List[str]:
        return list(self._cons)

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
        n = expr.numel()
        con = Constraint(name, kind, n, slice(self._ng, self._ng + n))
        self._g.append(ca.vec(expr))
        self._glb.append(lb)
        self._gub.append(ub)
        self._cons[name] = con
        self._ng += n
        self._t_described = time.perf_counter()
        return con

    # ------------------------------------------------------------------ solving
    def _ipopt_options(self, options, verbose):
        ipopt = dict(DEFAULT_IPOPT_OPTIONS)
        if self._comps:
            ipopt["bound_relax_factor"] = 0.0
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
        if self._f is None:
            raise ValueError("no objective: call minimize() first")
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

    def _split(self, vec, blocks) -> Dict[str, np.ndarray]:
        out, i = {}, 0
        for b in blocks:
            n = b.init.size
            out[b.name] = vec[i:i + n].copy()
            i += n
        return out

    def evaluator(self, *exprs) -> ca.Function:
        """A CasADi function ``(x, p) -> exprs`` of the stacked variables and parameters."""
        xs = ca.vertcat(*[b.sym for b in self._vars])
        ps = ca.vertcat(*[b.sym for b in self._params]) if self._params else self._sym(0, 1)
        return ca.Function("evaluate", [xs, ps], list(exprs))

    def evaluate(self, result: Result, *exprs) -> list:
        """Values of expressions of this NLP's symbols at a result, as flat numpy arrays."""
        p = np.concatenate([b.init for b in self._params]) if self._params else np.zeros(0)
        out = self.evaluator(*exprs)(result.x, p)
        out = out if isinstance(out, (list, tuple)) else [out]
        return [np.asarray(v, float).reshape(-1) for v in out]

    def _comp_residual(self, x: np.ndarray, p: np.ndarray) -> Optional[float]:
        if not self._comps:
            return None
        if getattr(self, "_comp_fun", None) is None:
            self._comp_fun = self.evaluator(ca.vertcat(*[ca.fabs(a * b) for _, a, b in self._comps]))
        vals = np.asarray(self._comp_fun(x, p)).reshape(-1)
        return float(vals.max()) if vals.size else 0.0

    def solve(self, init: Optional[Dict[str, object]] = None, *, warm: Optional[Result] = None,
              options: Optional[dict] = None, verbose: bool = False, expand: bool = False,
              homotopy: Sequence[float] = (1e-1, 1e-2, 1e-3, 1e-5, 1e-7, 0.0)) -> Result:
        """Solve and return a :class:`~castrajectory.result.Result` (never raises on non-convergence).

        Parameters
        ----------
        init: initial guesses by variable name (defaults: the ``init`` given to :meth:`variable`).
        warm: a previous result of this NLP; its primal and dual values start the solve.
        options: Ipopt options overriding :data:`DEFAULT_IPOPT_OPTIONS`.
        verbose: stream Ipopt's banner and iteration log.
        homotopy: relaxation values ``sigma`` used when the NLP has complementarity pairs;
            each step warm-starts from the previous one.
        """
        solver = self.build(options, verbose, expand)
        build_time = self._build_time
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
        args = dict(x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
        if warm is not None and warm.lam_g is not None:
            args.update(lam_x0=warm.lam_x, lam_g0=warm.lam_g)

        sigmas = list(homotopy) if self._comps else [None]
        steps: List[HomotopyStep] = []
        total_iter, total_time = 0, 0.0
        sol, status = None, "Not_Solved"
        for k, sigma in enumerate(sigmas):
            if sigma is not None:
                self.set_parameter("__sigma", sigma)
            p = np.concatenate([b.init for b in self._params]) if self._params else np.zeros(0)
            t = time.perf_counter()
            sol = solver(p=p, **args)
            dt = time.perf_counter() - t
            stats = solver.stats()
            status = stats.get("return_status", "unknown")
            iters = int(stats.get("iter_count", 0))
            total_iter += iters
            total_time += dt
            xk = np.asarray(sol["x"]).reshape(-1)
            if sigma is not None:
                steps.append(HomotopyStep(sigma, status, iters, dt, self._comp_residual(xk, p)))
            if status not in SUCCESS_STATUSES:
                break
            args.update(x0=sol["x"], lam_x0=sol["lam_x"], lam_g0=sol["lam_g"])

        x = np.asarray(sol["x"]).reshape(-1)
        lam_x = np.asarray(sol["lam_x"]).reshape(-1)
        lam_g = np.asarray(sol["lam_g"]).reshape(-1)
        p = np.concatenate([b.init for b in self._params]) if self._params else np.zeros(0)
        success = status in SUCCESS_STATUSES
        message = Result.describe_status(status)
        if self._comps and success and steps[-1].sigma != 0.0:
            message += f"; relaxation stopped at sigma = {steps[-1].sigma:g}"
        res = Result(
            values=self._split(x, self._vars),
            multipliers={c.name: -lam_g[c.slice] for c in self._cons.values()},
            bound_multipliers=self._split(-lam_x, self._vars),
            objective=float(sol["f"]),
            status=status,
            success=success,
            message=message,
            iterations=total_iter,
            build_time_s=build_time,
            solve_time_s=total_time,
            complementarity_residual=self._comp_residual(x, p),
            homotopy=steps,
            x=x, lam_x=lam_x, lam_g=lam_g,
        )
        return res
