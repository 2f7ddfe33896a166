"""Optimal control on the discrete action (DMOC), solved whole by Ipopt, and certified.

The public face, in the style of CasADi's ``Opti`` and rockit::

    u = ct.Control("u", 1, lower=-20, upper=20)
    sys = ct.LagrangianSystem(q, ct.Atoms(...), [ct.Gravity(9.81), ct.Force(ca.vertcat(u, 0))])
    ocp = ct.OptimalControl(sys, T=2.0, N=100, scheme="midpoint")     # T=(lo, hi): free final time
    ocp.initial(q=[0, 0], qd=[0, 0])
    ocp.final(q=[1, ca.pi], qd=[0, 0])                                # any entry None: free
    ocp.minimize(running=u ** 2)                                      # and/or final=..., in q, qd, T
    ocp.subject_to(-2 <= q[0], q[0] <= 2)                             # at nodes and quadrature nodes
    sol = ocp.solve()

The transcription is :mod:`castrajectory.discretise.optimal_control`.  Controls are given at the scheme's
quadrature nodes (``controls="quadrature"``, the default: each node of the forces' and the cost's
quadrature has its own value, so the cost converges at the scheme's order -- galerkin4 4, galerkin6 6;
midpoint has one node, a value per step) or constant per step (``controls="step"``: a piecewise-constant
control caps every scheme's cost and controls at order 2).  See ``docs/derivations.md``.

Every answer is **certified**: its controls are marched forward, step by step, with the same discrete
equations (a Newton solve per step), and every step must reproduce the optimal trajectory's next node
(``certificate``, the one-step distance; an answer beyond CERTIFICATE_TOL is a failure).  The whole march
from the initial state is reported beside it (``march_distance``): an unstable motion amplifies rounding
along it at its own rate, which no answer can avoid.
"""
from __future__ import annotations

import copy
import math
import time as _time
from typing import Dict, List, Optional

import casadi as ca
import numpy as np

from ..discretise.lagrangians import SCHEMES, discrete_mechanics
from ..discretise.optimal_control import ControlTranscription, split_controls
from ..models.mechanics import LagrangianSystem
from ..result import ACCEPTABLE, CERTIFICATE_TOL, Certificate, ControlResult, motion_scale
from ..validation import InputError, integer_at_least, one_of
from . import ladder, memory
from .nlp import NLP
from .trajectory import check_inertia

#: Ipopt settings of the DMOC solve (exact Hessian; MUMPS scaling off as for every program here).
OCP_IPOPT = {"tol": 1e-10, "max_iter": 3000, "mumps_pivtol": 1e-8, "bound_relax_factor": 0.0}
#: A grid of more steps than this starts from the answer of a grid half as fine (see OptimalControl.solve).
LADDER_MAX = 64
#: Where Ipopt stops at its acceptable level (the requested ``tol`` out of reach of the grid's rounding: the acrobot,
#: galerkin8, N >= 160 at 1e-10, its scaled dual infeasibility 2.4e-10), the answer is measured: one warm re-solve
#: from it at this tolerance, Ipopt's own test of the scaled KKT residuals (stationarity, feasibility and
#: complementarity), then the certificate's march.  Both hold: the answer is ok, with a warning naming the
#: tolerance reached and how far the re-solve moved the cost (see :func:`_judge_acceptable`).
ACCEPTABLE_TOL = 1e-8
#: Ipopt iterations of that re-solve at most (it took 0 on the acrobot at N = 160 and 320, 4 on the minimum-time
#: move stopped at its first acceptable iterate)
ACCEPTABLE_ITER = 20
#: The re-solve's warm start: the acceptable point's primal and dual values, barely moved off their bounds
_REMEASURE_IPOPT = {"warm_start_init_point": "yes", "mu_init": 1e-11, "warm_start_bound_push": 1e-12,
                    "warm_start_bound_frac": 1e-12, "warm_start_slack_bound_push": 1e-12,
                    "warm_start_slack_bound_frac": 1e-12, "warm_start_mult_bound_push": 1e-12}


class _Transcription(ControlTranscription):
    program = NLP


def _vector(name, value, n, names, allow_none=True):
    """A boundary value: ``n`` entries, each a number or ``None`` (free): NaN for a free one."""
    if value is None:
        return None
    try:
        seq = list(np.asarray(value, dtype=object).reshape(-1))
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a list of {n} numbers (or None for a free entry)") from None
    if len(seq) != n:
        raise InputError(f"{name} has {len(seq)} values, the system has {n} coordinates ({', '.join(names)})")
    out = np.full(n, np.nan)
    for i, v in enumerate(seq):
        if v is None:
            if not allow_none:
                raise InputError(f"{name}: every entry must be given")
            continue
        try:
            out[i] = float(v)
        except (TypeError, ValueError):
            raise InputError(f"{name}[{i}] must be a number or None (got {v!r})") from None
        if not math.isfinite(out[i]):
            raise InputError(f"{name}[{i}] must be finite (got {v!r})")
    return out


class OptimalControl:
    """An optimal-control problem on the discrete action of ``system`` (see the module docstring).

    ``T``: the horizon, or ``(lo, hi)`` for a free final time (``0 < lo <= hi``); ``N`` steps; ``scheme``: any
    of ``ct.schemes()``; ``controls``: ``"quadrature"`` (a value at each of the scheme's quadrature nodes:
    the scheme's order; midpoint has one node) or ``"step"`` (one value per step: order 2 at most).  :attr:`T_symbol` is the final time in a final cost (``minimize(final=ocp.T_symbol)``
    is the minimum-time problem).

    A block of unit mass moved by 1 in 1 s at least effort (``J* = 12``; midpoint on N steps: ``12N²/(N²−1)``):

    >>> import casadi as ca, castrajectory as ct
    >>> u = ct.Control("u", 1)
    >>> x = ca.SX.sym("x", 1)
    >>> block = ct.LagrangianSystem(x, ct.MassMatrix(1.0), [ct.Force(u)])
    >>> ocp = ct.OptimalControl(block, T=1.0, N=10)
    >>> ocp.initial(q=[0.0], qd=[0.0]); ocp.final(q=[1.0], qd=[0.0]); ocp.minimize(running=u ** 2)
    >>> sol = ocp.solve()
    >>> sol.success, round(sol.cost, 9) == round(12 * 100 / 99, 9), sol.certificate < 1e-9
    (True, True, True)
    """

    def __init__(self, system: LagrangianSystem, T, N: int, scheme: str = "midpoint", controls: str = "quadrature"):
        if not isinstance(system, LagrangianSystem):
            raise InputError(f"system must be a LagrangianSystem (got {type(system).__name__})")
        if not system.controls and system.contact is None:
            raise InputError("the system has no control: put a ct.Control in a ct.Force")
        self.system = system
        self.N = integer_at_least("N", N, 2)
        self.scheme = one_of("scheme", scheme, tuple(SCHEMES))
        self.control_points = one_of("controls", controls, ("step", "quadrature"))
        if isinstance(T, (tuple, list)):
            if len(T) != 2:
                raise InputError(f"a free final time is an interval (lo, hi) (got {T!r})")
            lo, hi = (float(v) for v in T)
            if not (math.isfinite(lo) and math.isfinite(hi)) or lo <= 0 or lo > hi:
                raise InputError(f"the free final time needs 0 < lo <= hi (got ({lo:g}, {hi:g}))")
            self.T = (lo, hi)
            if system.time_dependent:
                raise InputError("a free final time needs a time-independent system (its node times move)")
        else:
            try:
                Tv = float(T)
            except (TypeError, ValueError):
                raise InputError(f"T must be a number or an interval (lo, hi) (got {T!r})") from None
            if not math.isfinite(Tv) or Tv <= 0:
                raise InputError(f"T must be positive (got {T!r})")
            self.T = Tv
        self.T_symbol = ca.SX.sym("T")
        n = system.nq
        self._start = (np.full(n, np.nan), None)
        self._end = (np.full(n, np.nan), None)
        self._running = None
        self._final = None
        self._path: List[tuple] = []
        self._controls = system.controls
        self._u = system.control_vector

    # -------------------------------------------------------------- the problem
    def initial(self, q=None, qd=None) -> None:
        """The initial configuration and velocity (``None``, or an entry ``None``: free)."""
        self._start = self._boundary("initial", q, qd)

    def final(self, q=None, qd=None) -> None:
        """The final configuration and velocity (``None``, or an entry ``None``: free)."""
        self._end = self._boundary("final", q, qd)

    def _boundary(self, which, q, qd):
        s = self.system
        qv = _vector(f"{which} q", q, s.nq, s.names)
        qv = np.full(s.nq, np.nan) if qv is None else qv
        # (an entry None of the initial velocity: an unknown, with contact: a launch to be found)
        vv = _vector(f"{which} qd", qd, s.nq, s.names, allow_none=which == "initial" and s.contact is not None)
        if vv is not None and np.any(np.isnan(qv)):
            raise InputError(f"a {which} velocity needs the {which} configuration given in full")
        if which == "initial" and not np.any(np.isnan(qv)):
            check_inertia(s, qv)  # a negative or a missing mass: refused as simulate and system files refuse it
        if s.nc and not np.any(np.isnan(qv)):
            c, C = (np.asarray(x, float) for x in s.constraint(qv, 0.0))
            if np.max(np.abs(c)) > 1e-9 * (1.0 + np.max(np.abs(qv))):
                raise InputError(f"the {which} configuration violates the holonomic constraints "
                                 f"(|c| = {np.max(np.abs(c)):.3g})")
            if vv is not None and np.max(np.abs(C @ vv)) > 1e-9 * (1.0 + np.max(np.abs(vv))):
                raise InputError(f"the {which} velocity is not tangent to the holonomic constraints "
                                 f"(|C qd| = {np.max(np.abs(C @ vv)):.3g})")
        return qv, vv

    def _check_expr(self, expr, what: str, rates: bool, final: bool = False) -> ca.SX:
        from ..models.control import is_control_symbol
        e = ca.SX(expr)
        if e.numel() != 1:
            raise InputError(f"the {what} must be a scalar (it has {e.numel()} entries)")
        s = self.system
        allowed = {v.element_hash() for v in ca.symvar(s.q if final else ca.vertcat(s.q, s.t))}
        if rates:
            allowed |= {v.element_hash() for v in ca.symvar(s.qd)}
        if final:
            allowed.add(self.T_symbol.element_hash())
        mine = {v.element_hash() for v in ca.symvar(self._u)} if self._u.numel() else set()
        for v in ca.symvar(e):
            hsh = v.element_hash()
            if hsh in allowed or (not final and hsh in mine):
                continue
            if is_control_symbol(v):
                raise InputError(f"the {what} holds the control {v}, which appears in no force of the system")
            raise InputError(f"the {what} depends on the symbol {v}, which is not a coordinate"
                             + (", its velocity" if rates else "") + (" or the final time T (ocp.T_symbol)" if final
                                                                    else ", a control or the time"))
        return e

    def minimize(self, running=None, final=None) -> None:
        """The cost: ``∫ running(q, q̇, u, t) dt + final(q_N, q̇_N, T)`` (``T``: :attr:`T_symbol`; ``q̇_N`` the final
        velocity of the discrete motion, its last step's Legendre transform)."""
        if running is None and final is None:
            raise InputError("minimize() needs a running or a final cost")
        if running is not None:
            self._running = self._check_expr(running, "running cost", rates=True)
        if final is not None:
            self._final = self._check_expr(final, "final cost", rates=True, final=True)

    def subject_to(self, *constraints) -> None:
        """Path constraints ``a <= b``, ``a >= b`` or ``a == b`` (CasADi comparisons) in ``q``, the controls and
        the time: one in ``q`` and ``t`` holds at every node and at each step's interior quadrature nodes, one in
        the controls at every quadrature node with that node's control (see ``docs/derivations.md``, DMOC §3)."""
        for con in constraints:
            e = ca.SX(con)
            for i in range(e.numel()):
                ei = e[i]
                if ei.is_op(ca.OP_LE) or ei.is_op(ca.OP_LT):
                    g, lb, ub = ei.dep(0) - ei.dep(1), -np.inf, 0.0
                elif ei.is_op(ca.OP_EQ):
                    g, lb, ub = ei.dep(0) - ei.dep(1), 0.0, 0.0
                else:
                    raise InputError("subject_to() takes comparisons such as q[0] <= 2 (CasADi expressions)")
                self._check_expr(g, "path constraint", rates=False)
                if self._is_free_time() and ca.depends_on(g, self.system.t):
                    raise InputError("a path constraint in t needs a fixed final time")
                self._path.append((g, lb, ub))

    def _is_free_time(self) -> bool:
        return isinstance(self.T, tuple)

    # -------------------------------------------------------------- the solve
    def solve(self, guess: Optional[Dict[str, np.ndarray]] = None, options: Optional[dict] = None,
              verbose: bool = False, keep_modes: bool = False, contact=None) -> ControlResult:
        """Solve the whole DMOC program with Ipopt from ``guess`` (``{"q": (N+1, n), "u": (N, nu), "T": …}``,
        any part; the rest: the boundary conditions interpolated, zero controls clipped to their bounds),
        then certify the answer (see the module docstring).

        Without a guess, a grid of more than LADDER_MAX steps starts from the answer of the same problem on a
        grid half as fine (recursively; its nodes and controls interpolated in t/T): a ladder of grids, the
        usual mesh continuation.  Every grid then lands on the local optimum of the coarsest, so a refinement
        study follows one optimum (the cart-pole from the straight-line guess lands on two different local
        optima at N = 100 and N = 200 without it), and the fine grid needs a few iterations (7-9 instead of
        39-289 on the cart-pole).  A rung that fails is dropped: the grid then starts from the boundary
        conditions.  ``grids`` lists the grids solved.

        A system with contact is solved whole through its contacts (:mod:`castrajectory.solve.contact.control`);
        ``contact`` takes that solve's settings, a :class:`~castrajectory.solve.contact.options.ContactControlOptions`
        (its start policies, penalties, rounds, certificate tolerance; the library's by default)."""
        why = self._inconsistency()
        if why:
            raise InputError(f"the problem is inconsistent: {why}; nothing was solved")
        memory.check_control(self)  # a grid this process cannot hold: refused before anything is built
        if self.system.contact is not None:
            return self._solve_contact(guess, options, verbose, keep_modes, contact)
        if contact is not None:
            raise InputError("contact= takes the settings of a contact-implicit solve: this system has no contact")
        if keep_modes:
            raise InputError("keep_modes is for a system with contact (the contact modes of the guess's march)")
        def coarser(M):
            coarse = copy.copy(self)
            coarse.N = M
            return coarse.solve(options=options)

        rung = ladder.below(self.N, LADDER_MAX, guess, coarser, self._interpolated)
        out = self._solve_grid(rung.guess, options, verbose)
        out.grids = rung.grids + [self.N]
        spent = rung.seconds
        if rung.grids:
            out.solve_time_s += spent
        return out

    def _solve_contact(self, guess, options, verbose, keep_modes=False, contact=None) -> "ControlResult":
        """Contact-implicit optimal control (:mod:`castrajectory.solve.contact.control`): the whole MPCC in one
        program, its guess the contact march of the controls' guess, its answer certified by the march."""
        from .contact.control import solve_contact_control
        s = self.system
        if self._running is None and self._final is None:
            raise InputError("no cost: call minimize() first")
        (q0, v0), (qN, vN) = self._start, self._end
        if v0 is None or np.any(np.isnan(q0)):
            raise InputError("optimal control through contact needs the initial state given in full "
                             "(ocp.initial(q=..., qd=...))")
        if s.nc:
            raise InputError("optimal control through contact takes no holonomic constraints yet")
        if s.contact.friction is not None and np.any(np.asarray(s.contact.friction) > 0) and s.contact.slip_dim != 1:
            raise InputError("optimal control through contact takes planar friction (one slip direction per contact)")
        phi0 = np.asarray(s.gap(q0)[0]).reshape(-1)
        if np.any(phi0 < -1e-9 * max(1.0, float(np.max(np.abs(q0))))):
            raise InputError(f"the initial configuration penetrates a contact (gap {float(np.min(phi0)):.3g})")
        q, qd, u = s.q, s.qd, self._u
        running = ca.Function("l", [q, qd, u, s.t], [self._running]) if self._running is not None else None
        final = ca.Function("phi", [q, qd, self.T_symbol], [self._final]) if self._final is not None else None
        lo = np.concatenate([c.lower for c in self._controls]) if self._controls else np.zeros(0)
        hi = np.concatenate([c.upper for c in self._controls]) if self._controls else np.zeros(0)
        path = [(ca.Function(f"g{j}", [q, u, s.t], [g]), lb, ub) for j, (g, lb, ub) in enumerate(self._path)]
        return solve_contact_control(s, self.T, self.N, self.scheme, (q0, v0), (qN, vN), running, final, (lo, hi),
                                     self._controls, guess, options, verbose, keep_modes, path, contact,
                                     control_points=self.control_points)

    def _inconsistency(self) -> Optional[str]:
        """What the inputs prove inconsistent before any solve (``None``: nothing proved; Ipopt's
        ``Infeasible_Problem_Detected`` is local, and proves nothing).  Two proofs:

        * bounds that cross: the path constraints affine in one coordinate or control entry (``a v + c`` within
          its bounds) and the controls' own bounds leave that entry no value;
        * a given boundary configuration outside a path constraint in ``q`` (and ``t``), which holds at every
          node, the first and the last included (not checked with contact, whose transcription places its rows
          itself)."""
        s = self.system
        entries = [(s.q[i], f"{s.names[i]}") for i in range(s.nq)]
        entries += [(self._u[j], f"control entry {self._u[j]}") for j in range(self._u.numel())]
        interval = {}   # entry's hash -> [lo, why lo, hi, why hi, label]
        for v, label in entries:
            interval[v.element_hash()] = [-np.inf, "", np.inf, "", label]
        k = 0
        for c in self._controls:
            for j in range(c.size):
                iv = interval[self._u[k].element_hash()]
                iv[0], iv[1] = float(c.lower[j]), f"the lower bound of control {c.name}"
                iv[2], iv[3] = float(c.upper[j]), f"the upper bound of control {c.name}"
                k += 1
        for g, lb, ub in self._path:
            vs = ca.symvar(g)
            if len(vs) != 1 or vs[0].element_hash() not in interval:
                continue
            v = vs[0]
            a_expr = ca.jacobian(g, v)
            if ca.depends_on(a_expr, v):
                continue
            a, c = float(ca.evalf(a_expr)), float(ca.evalf(ca.substitute(g, v, ca.SX(0))))
            if a == 0.0:
                continue
            with np.errstate(invalid="ignore"):
                lo, hi = sorted(((lb - c) / a, (ub - c) / a))
            iv = interval[v.element_hash()]
            text = f"the path constraint {g} {'==' if lb == ub else '<='} 0"
            if lo > iv[0]:
                iv[0], iv[1] = lo, text
            if hi < iv[2]:
                iv[2], iv[3] = hi, text
        for lo, why_lo, hi, why_hi, label in interval.values():
            if lo > hi + 1e-12 * max(1.0, abs(lo), abs(hi)):
                return f"{label} must be at least {lo:g} ({why_lo}) and at most {hi:g} ({why_hi})"
        if s.contact is not None:
            return None
        ends = [("initial", self._start[0], 0.0), ("final", self._end[0], None if self._is_free_time() else self.T)]
        for g, lb, ub in self._path:
            if self._u.numel() and ca.depends_on(g, self._u):
                continue
            gf = ca.Function("g", [s.q, s.t], [g])
            for which, qv, tv in ends:
                if tv is None and ca.depends_on(g, s.t):
                    continue
                with np.errstate(invalid="ignore"):
                    val = float(gf(qv, 0.0 if tv is None else tv))
                tol = 1e-9 * max(1.0, abs(val))
                if np.isfinite(val) and (val < lb - tol or val > ub + tol):
                    return (f"the {which} configuration {np.asarray(qv).tolist()} violates the path constraint "
                            f"{g} {'==' if lb == ub else '<='} 0 (its value {val:.6g}), which holds at every node")
        return None

    def _interpolated(self, prior: "ControlResult") -> Dict[str, np.ndarray]:
        """A coarser answer on this grid: nodes and controls interpolated linearly in ``t/T``."""
        N, dm = self.N, discrete_mechanics(self.system, self.scheme, self.control_points)
        s = np.linspace(0.0, 1.0, N + 1)
        su = _control_times(dm, s)
        sq, squ = prior.t / prior.T, prior.t_u / prior.T
        Q = np.column_stack([np.interp(s, sq, prior.q[:, j]) for j in range(prior.q.shape[1])])
        U = np.column_stack([np.interp(su, squ, prior.u[:, j]) for j in range(prior.u.shape[1])])
        g = {"q": Q, "u": U.reshape(N, -1)}
        if self._is_free_time():
            g["T"] = prior.T
        return g

    def _solve_grid(self, guess, options, verbose) -> "ControlResult":
        if self._running is None and self._final is None:
            raise InputError("no cost: call minimize() first")
        s, N = self.system, self.N
        n, nu = s.nq, self._u.numel()
        dm = discrete_mechanics(s, self.scheme, self.control_points)
        q, qd, t, u = s.q, s.qd, s.t, self._u
        running = ca.Function("l", [q, qd, u, t], [self._running]) if self._running is not None else None
        final = ca.Function("phi", [q, qd, self.T_symbol], [self._final]) if self._final is not None else None
        path = [(ca.Function(f"g{j}", [q, u, t], [g]), lb, ub) for j, (g, lb, ub) in enumerate(self._path)]
        lo = np.concatenate([c.lower for c in self._controls])
        hi = np.concatenate([c.upper for c in self._controls])
        t0 = _time.perf_counter()
        tr = _Transcription(dm, N, self.T, self._start, self._end, running, final, path, (lo, hi))
        (q0, v0), (qN, vN) = self._start, self._end
        if v0 is not None:
            tr.nlp.set_parameter("p0", np.asarray(s.momentum(q0, v0, 0.0)).reshape(-1))
        if vN is not None:
            T_end = self.T if not self._is_free_time() else self.T[1]
            tr.nlp.set_parameter("pN", np.asarray(s.momentum(qN, vN, T_end)).reshape(-1))
        init = self._guess(dm, guess, lo, hi)
        opts = {**OCP_IPOPT, **(options or {})}
        res = tr.nlp.solve(init, options=opts, verbose=verbose, bounds=tr.bounds())
        acceptable = None
        if res.solver_status == ACCEPTABLE:
            res, acceptable = _remeasure(tr, res, opts, verbose)
        wall = _time.perf_counter() - t0
        vals = res.values
        Q = vals["q"].reshape(N + 1, n)
        Z = vals["Z"].reshape(N, dm.s) if dm.s else np.zeros((N, 0))
        U = vals["u"].reshape(N, dm.nu)         # per step: the control at each control point
        h = float(vals["h"][0]) if self._is_free_time() else self.T / N
        T = h * N
        times = h * np.arange(N + 1)
        p = dm.momenta(Q, Z, h, 0.0, U)
        v = dm.velocities(Q, p, times)
        # costate_k = ∂J*/∂p_k: an impulse ι at node k is the DEL row's right-hand side −ι/h, and the row's
        # multiplier is ∂J*/∂rhs
        costates = -res.multipliers["del"].reshape(N - 1, n) / h if "del" in res.multipliers else None
        measured = res.success or acceptable is not None
        C = certify(dm, Q, Z, U, h, times, p[0]) if measured else Certificate()
        out = ControlResult(success=res.success, solver_status=res.solver_status, message=res.message, iterations=res.iterations, build_time_s=res.build_time_s,
                            solve_time_s=wall - res.build_time_s, cost=float(res.objective), T=T, t=times, q=Q,
                            v=v, u=U.reshape(N * dm.nqu, nu), t_u=_control_times(dm, times),
                            controls=split_controls(U.reshape(N * dm.nqu, nu), self._controls, N * dm.nqu),
                            costates=costates,
                            certificate=C.local, march_distance=C.march, scheme=self.scheme,
                            q_stages=Z.reshape(N, dm.scheme.stages, n) if dm.s else None)
        if acceptable is not None:
            _judge_acceptable(out, acceptable, C)
        elif res.success and not C.holds():
            out.fail("Certificate_Failed", f"the march of the optimal controls departs from the optimal "
                                           f"trajectory by {C.local:.3g} (relative): not a motion of the system")
        return out

    def _guess(self, dm, guess, lo, hi) -> Dict[str, np.ndarray]:
        s, N = self.system, self.N
        n = s.nq
        (q0, _), (qN, _) = self._start, self._end
        a = np.where(np.isnan(q0), np.where(np.isnan(qN), 0.0, qN), q0)
        b = np.where(np.isnan(qN), a, qN)
        w = np.linspace(0.0, 1.0, N + 1)[:, None]
        Q = a[None, :] + w * (b - a)[None, :]
        U = np.tile(np.clip(0.0, lo, hi), (N, dm.nqu))
        g = {"q": Q, "u": U}
        if self._is_free_time():
            g["T"] = 0.5 * sum(self.T)
        for k, val in (guess or {}).items():
            g[k] = np.asarray(val, float)
        Q = np.asarray(g["q"], float).reshape(N + 1, n)
        out = {"q": Q.reshape(-1), "u": np.asarray(g["u"], float).reshape(-1)}
        if out["u"].size != N * dm.nu:
            raise InputError(f"the guess of u needs {N * dm.nu} values ({N} steps of {dm.nu}), got {out['u'].size}")
        if dm.s:
            out["Z"] = dm.stage_guess(Q[:-1], Q[1:]).reshape(-1)
        if self._is_free_time():
            out["h"] = np.array([float(g["T"]) / N])
        return out


def _remeasure(tr, res, opts, verbose):
    """Ipopt stopped at its acceptable level (``res``): re-solve warm from that point at ACCEPTABLE_TOL (or the
    requested ``tol`` where that is looser), at most ACCEPTABLE_ITER iterations, so that Ipopt itself measures the
    point's scaled KKT residuals.  Returns ``(answer, record)``: the re-solve's answer where it converged (the
    acceptable point's otherwise), and what was measured (``requested`` tol, ``tol`` of the re-solve, its
    ``status`` and ``iterations``, the ``cost_change`` from the acceptable point)."""
    requested = float(opts.get("tol", 1e-8))
    tol = max(ACCEPTABLE_TOL, requested)
    # (acceptable_iter 0: no acceptable level of its own, the re-solve meets tol or fails)
    again = tr.nlp.solve(warm=res, options={**opts, **_REMEASURE_IPOPT, "tol": tol, "max_iter": ACCEPTABLE_ITER,
                                            "acceptable_iter": 0}, verbose=verbose, bounds=tr.bounds())
    last = (tr.nlp.last_stats or {}).get("iterations") or {}
    # the scaled residuals Ipopt printed at its last iterate (feasibility and stationarity; its complementarity is
    # not recorded)
    residual = max((float(last[k][-1]) for k in ("inf_pr", "inf_du") if last.get(k)), default=math.nan)
    record = {"requested": requested, "tol": tol, "status": again.solver_status, "iterations": again.iterations,
              "cost_change": abs(again.objective - res.objective), "first": res, "residual": residual}
    ans = again if again.success else res
    # the counters and times of both solves
    ans.iterations = res.iterations + again.iterations
    ans.solve_time_s = res.solve_time_s + again.solve_time_s
    return ans, record


def _judge_acceptable(out: ControlResult, m: dict, C: Certificate) -> None:
    """The verdict on an answer Ipopt solved only to its acceptable level, from what was measured (``m``, see
    :func:`_remeasure`, and the certificate ``C``): ok when the warm re-solve converged at its tolerance (the
    scaled KKT residuals within it) and the march certifies the answer; otherwise a failure that says what would
    make it succeed."""
    first, cert = m["first"], C.local
    if m["status"] == "Solve_Succeeded" and C.holds():
        out.success, out.status = True, "ok"
        out.solver_status = first.solver_status     # (Ipopt's word for the first solve, for the record)
        resolve = ("the acceptable point itself meets it (a warm re-solve stopped at once)" if not m["iterations"]
                   else f"a warm re-solve met it in {m['iterations']} iterations, the cost moving by "
                        f"{m['cost_change']:.2g}")
        out.message = (f"Ipopt converged to tol = {m['tol']:g}, not the requested {m['requested']:g}: it stopped at "
                       f"its acceptable level, and {resolve}; certified by the march to {cert:.2g}")
        out.warnings.append(f"the requested tol = {m['requested']:g} was not reached (Ipopt stopped at its "
                            f"acceptable level): the answer holds its KKT conditions to tol = {m['tol']:g}; pass "
                            f"options={{'tol': {m['tol']:g}}} to ask for what this grid resolves")
        return
    r = m["residual"]
    if m["status"] != "Solve_Succeeded":
        why = (f"a warm re-solve did not meet tol = {m['tol']:g} either ({m['status']} after {m['iterations']} "
               f"iterations; scaled feasibility and stationarity residual {r:.2g})")
        # (a residual within tol: the complementarity or the iteration cap stopped it; ask for ten times looser)
        loose = max(10.0 ** math.ceil(math.log10(r)), 10.0 * m["tol"]) if r > 0 and math.isfinite(r) else 1e-6
        what = (f"set options={{'tol': {loose:g}}} to accept an answer at this residual, or start from a better "
                f"guess (the answer on a coarser grid, interpolated)")
    else:
        why = f"its march departs from the answer by {cert:.3g} (relative; at most {CERTIFICATE_TOL:g} certifies)"
        what = "refine the grid (N) or start from a better guess; a looser tol does not make it a motion"
    out.fail(ACCEPTABLE,
             f"Ipopt stopped at its acceptable level (the requested tol = {m['requested']:g} not reached), and "
             f"{why}: not ok (cost {first.objective:.12g}); {what}")


def _control_times(dm, times) -> np.ndarray:
    """The time of each control value: the step's midpoint for a control per step, the quadrature nodes'
    times otherwise."""
    t0, h = times[:-1], times[1] - times[0]
    if dm.nqu == 1:
        return t0 + 0.5 * h
    return (t0[:, None] + h * dm.scheme.nodes[None, :]).reshape(-1)


def certify(dm, Q, Z, U, h, times, p0) -> Certificate:
    """The smooth :class:`~castrajectory.result.Certificate`: march the controls ``U`` with the same discrete equations
    from ``(q_0, p_0⁺)``, each step a Newton solve (CasADi's rootfinder) of the DEL row at the node (the initial
    Legendre row first), the stage rows and the constraint rows at the new node.  ``local``: each step marched from the
    answer's own nodes; ``march``: the whole motion from the start (which an unstable motion amplifies from rounding:
    the pendulum held upright at the end of a swing-up, 7e-8 on 400 steps where the local one is 1e-13)."""
    n, s, m, st, nu = dm.n, dm.s, dm.m, dm.scheme.stages, dm.nu
    N = Q.shape[0] - 1
    w = ca.SX.sym("w", n + s + m + st * m)
    qn, Zk, lam, nuk = w[:n], w[n:n + s], w[n + s:n + s + m], w[n + s + m:]
    qm, Zm, qk = ca.SX.sym("qm", n), ca.SX.sym("Zm", s), ca.SX.sym("qk", n)
    um, uk = ca.SX.sym("um", nu), ca.SX.sym("uk", nu)
    p0s, tk = ca.SX.sym("p0", n), ca.SX.sym("t")
    none = ca.SX(0, 1)
    rows_first = [dm.initial_residual(qk, Zk if s else none, qn, p0s, lam, h, tk, uk)]
    rows_next = [dm.del_residual(qm, Zm if s else none, qk, Zk if s else none, qn, lam, h, tk, um, uk)]
    common = []
    if s:
        common.append(dm.stage_residual(qk, Zk, qn, nuk if m else none, h, tk, uk))
    if m:
        common.append(dm.constraint_rows(qn, tk + h))
        common += [dm.stage_constraint_rows[j](Zk[j * n:(j + 1) * n], tk, h) for j in range(st)]
    par = ca.vertcat(qm, Zm, qk, um, uk, p0s, tk)
    G0 = ca.Function("g0", [w, par], [ca.vertcat(*(rows_first + common))])
    G1 = ca.Function("g1", [w, par], [ca.vertcat(*(rows_next + common))])
    R0 = ca.rootfinder("march0", "newton", G0, {"abstol": 1e-13, "max_iter": 50, "error_on_fail": False})
    R1 = ca.rootfinder("march1", "newton", G1, {"abstol": 1e-13, "max_iter": 50, "error_on_fail": False})
    scale = motion_scale(Q)

    def march(local: bool):
        qs = [Q[0]]
        Zprev = np.zeros(s)
        worst = 0.0
        for k in range(N):
            # local: each step from the optimal trajectory's own nodes (the one-step defect, which an
            # unstable motion does not amplify); global: from the march's own
            qk = Q[k] if local else qs[k]
            qprev = (Q[k - 1] if local else qs[k - 1]) if k else np.zeros(n)
            Zp = (Z[k - 1] if (local and k and s) else Zprev)
            ukv = U[k] if nu else np.zeros(0)
            umv = U[k - 1] if (nu and k) else np.zeros(nu)
            p = np.concatenate([qprev, Zp, qk, umv, ukv, p0, [times[k]]])
            # the Newton solve starts from the extrapolated motion, not from the optimum it is checked against
            qg = 2 * qk - qprev if k else qk
            guess = np.concatenate([qg, np.tile(qg, st) if s else [], np.zeros(m + st * m)])
            wk = np.asarray((R0 if k == 0 else R1)(guess, p)).reshape(-1)
            if not np.all(np.isfinite(wk)):
                return math.inf
            qs.append(wk[:n])
            Zprev = wk[n:n + s]
            worst = max(worst, float(np.max(np.abs(wk[:n] - Q[k + 1]))))
        return worst / scale

    return Certificate(march(True), march(False))
