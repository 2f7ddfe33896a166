"""Discrete mechanics and optimal control (DMOC): the forced discrete Euler–Lagrange equations of a whole
trajectory, with controls, a cost and boundary conditions, as one program.

Ober-Blöbaum, Junge and Marsden (ESAIM: COCV 17, 2011): the dynamics are the discrete Lagrange–d'Alembert
principle with the controls in the forces; the cost is the scheme's own quadrature of the running cost
along each step's polynomial (the same quadrature as the discrete Lagrangian); the boundary velocities
enter through the discrete Legendre transforms.  On a uniform grid ``t_k = k h``, ``h = T/N``:

* unknowns: ``q_0..q_N`` (entries of ``q_0``/``q_N`` that are given are fixed by bounds), the stages
  ``Z_k`` of a higher-order scheme, the constraint multipliers, the controls ``u_k`` (constant on step
  ``k``: the force's quadrature sees one value per step), and ``h`` when the final time is free;
* rows: the DEL equation at every interior node (the controls of both steps at the node), the stage
  equations, the holonomic constraints, ``p(q_0, q̇_0) = p_0⁺`` when ``q̇_0`` is given and
  ``p_N⁻ = p(q_N, q̇_N)`` when ``q̇_N`` is, the path constraints (in ``q``: at the nodes and the steps'
  interior quadrature nodes; in the controls: at every quadrature node, see ``_path_nodes``);
* objective: ``Σ_k h Σ_i w_i ℓ(q(τ_i), q̇(τ_i), u_k, t_i) + φ(q_N, q̇_N, T)``, ``q̇_N`` from the last step's
  discrete Legendre transform.

The multipliers of the DEL rows are the **discrete costates** (their sign: see
:class:`castrajectory.result.NLPResult`, ``∂J*/∂rhs``; a DEL row is a force balance divided by ``h``).
"""
from __future__ import annotations

from typing import List, Optional, Sequence

import casadi as ca
import numpy as np

from .lagrangians import DiscreteMechanics
from .program import P, Program, X


class ControlTranscription:
    """One grid of a DMOC problem (see the module docstring).

    ``start``, ``end``: ``(q, q̇)`` pairs of arrays with NaN for a free entry (``q̇`` may be ``None``: free);
    ``T``: a number, or ``(lo, hi)`` for a free final time; ``running(q, v, u, t)`` and ``final(q, v, T)``:
    CasADi functions of the costs (``None``: none); ``path``: ``[(function(q, u, t), lb, ub)]`` (where they
    hold: :meth:`_path_nodes`).
    """

    program = Program

    def __init__(self, dm: DiscreteMechanics, N: int, T, start, end, running: Optional[ca.Function],
                 final: Optional[ca.Function], path: Sequence = (), u_bounds=None):
        self.dm, self.N = dm, int(N)
        self.free_time = not np.isscalar(T)
        self.T_spec = T
        self.nlp = self.program(hessian="exact")
        (q0, v0), (qN, vN) = start, end
        self.q0, self.v0, self.qN, self.vN = q0, v0, qN, vN
        self._variables(T, u_bounds)
        self._dynamics()
        self._boundaries()
        self._constraints()
        self._paths(path)
        self._costs(running, final)

    def _variables(self, T, u_bounds) -> None:
        """The unknowns (nodes, stages, multipliers, controls, a free step length) and the element arguments: every
        element takes its time and its step's controls (an empty column without controls); the node times are
        constants (a time-dependent system's final time is fixed; a free one moves only the unread times of a
        time-independent system)."""
        dm, nlp, N = self.dm, self.nlp, self.N
        n, s, m, st, nu = dm.n, dm.s, dm.m, dm.scheme.stages, dm.nu
        v0, vN = self.v0, self.vN
        nlp.variable("q", (N + 1) * n)
        if s:
            nlp.variable("Z", N * s)
        if m:
            nlp.variable("lam", (N - 1) * m)
            if s:
                nlp.variable("nu", N * st * m)
            if v0 is not None:
                nlp.variable("lam0", m)
            if vN is not None:
                nlp.variable("lamN", m)
        lo, hi = u_bounds if u_bounds is not None else (np.full(dm.nu1, -np.inf), np.full(dm.nu1, np.inf))
        lo, hi = np.tile(lo, dm.nqu), np.tile(hi, dm.nqu)           # the same bounds at every control point
        nlp.variable("u", N * nu, lb=np.tile(lo, N), ub=np.tile(hi, N),
                     init=np.tile(np.clip(0.0, lo, hi), N))
        if self.free_time:
            tlo, thi = T
            nlp.variable("h", 1, lb=tlo / N, ub=thi / N, init=0.5 * (tlo + thi) / N)
            hh = X(nlp.index("h"))
        else:
            hh = np.array([float(T) / N])
        self.hh = hh
        Q = nlp.index("q").reshape(N + 1, n)
        Zi = nlp.index("Z").reshape(N, s) if s else np.zeros((N, 0), dtype=np.int64)
        Ui = nlp.index("u").reshape(N, nu)
        self.Q, self.Zi, self.Ui = Q, Zi, Ui
        self._zarg = (lambda rows: X(Zi[rows])) if s else (lambda rows: np.zeros(0))  # noqa: E731
        self._uarg = lambda rows: X(Ui[rows])  # noqa: E731  (an OptimalControl refuses a system without controls)
        self._targ = lambda rows: _node_times(self, rows)  # noqa: E731

    def _dynamics(self) -> None:
        """The DEL rows at the interior nodes (the controls of both steps) and the stage rows."""
        dm, nlp, N = self.dm, self.nlp, self.N
        s, m, st = dm.s, dm.m, dm.scheme.stages
        Q, Zi, hh = self.Q, self.Zi, self.hh
        zarg, uarg, targ, none = self._zarg, self._uarg, self._targ, np.zeros(0)
        interior = np.arange(1, N)
        # dynamics: the DEL rows at the interior nodes, the controls of both steps
        if N > 1:
            Li = nlp.index("lam").reshape(N - 1, m) if m else None
            nlp.equal_elements("del", dm.del_residual,
                               [X(Q[interior - 1]), zarg(interior - 1), X(Q[interior]), zarg(interior),
                                X(Q[interior + 1]), X(Li) if m else none, hh, targ(interior),
                                uarg(interior - 1), uarg(interior)])
        if s:
            k = np.arange(N)
            Ni = nlp.index("nu").reshape(N, st * m) if m else None
            nlp.equal_elements("stage", dm.stage_residual,
                               [X(Q[k]), X(Zi[k]), X(Q[k + 1]), X(Ni) if m else none, hh, targ(k), uarg(k)])

    def _boundaries(self) -> None:
        """Given boundary velocities, through the discrete Legendre transforms."""
        dm, nlp, N = self.dm, self.nlp, self.N
        n, m = dm.n, dm.m
        Q, hh = self.Q, self.hh
        zarg, uarg, targ, none = self._zarg, self._uarg, self._targ, np.zeros(0)
        sysm = dm.system
        if self.v0 is not None:
            nlp.parameter("p0", n, value=np.zeros(n))
            self._p0_fn = sysm.momentum
            nlp.equal_elements("initial", dm.initial_residual,
                               [X(Q[0]), zarg(0), X(Q[1]), P(nlp.parameter_index("p0")),
                                X(nlp.index("lam0")) if m else none, hh, targ(0), uarg(0)])
        if self.vN is not None:
            nlp.parameter("pN", n, value=np.zeros(n))
            nlp.equal_elements("final", dm.final_residual,
                               [X(Q[N - 1]), zarg(N - 1), X(Q[N]), P(nlp.parameter_index("pN")),
                                X(nlp.index("lamN")) if m else none, hh, targ(N), uarg(N - 1)])

    def _constraints(self) -> None:
        """The holonomic constraints at every node with a free entry, and at the stages."""
        dm, nlp, N = self.dm, self.nlp, self.N
        n, s, m, st = dm.n, dm.s, dm.m, dm.scheme.stages
        Q, Zi, hh, targ = self.Q, self.Zi, self.hh, self._targ
        # holonomic constraints at every node with a free entry, and at the stages
        if m:
            nodes = [k for k in range(N + 1) if not (k == 0 and _all_fixed(self.q0)) and not (k == N and _all_fixed(self.qN))]
            nodes = np.array(nodes)
            nlp.equal_elements("constraint", dm.constraint_rows, [X(Q[nodes]), targ(nodes)])
            if s:
                for j in range(st):
                    nlp.equal_elements(f"stage_constraint{j}", dm.stage_constraint_rows[j],
                                       [X(Zi[:, j * n:(j + 1) * n]), targ(np.arange(N)), hh])

    def _paths(self, path) -> None:
        """The path constraints (where they hold: :meth:`_path_nodes`)."""
        dm, nlp, N = self.dm, self.nlp, self.N
        Q, Ui, hh = self.Q, self.Ui, self.hh
        zarg, uarg, targ = self._zarg, self._uarg, self._targ
        # path constraints: see _path_nodes
        for j, (fn, lb, ub) in enumerate(path):
            at_nodes, tau = self._path_nodes(fn)
            if at_nodes:
                k = np.arange(N + 1)
                ku = np.minimum(k, N - 1)
                args = [X(Q[k]), X(Ui[ku][:, :dm.nu1]), targ(k)]
                nlp.inequality_elements(f"path{j}", fn, args, lb=np.tile(lb, N + 1), ub=np.tile(ub, N + 1))
            if tau.size:
                k = np.arange(N)
                nlp.inequality_elements(f"path{j}_steps", self._path_element(fn, tau),
                                        [X(Q[k]), zarg(k), X(Q[k + 1]), targ(k), hh, uarg(k)],
                                        lb=np.tile(lb, N * tau.size), ub=np.tile(ub, N * tau.size))

    def _costs(self, running, final) -> None:
        """The running cost (the scheme's quadrature) and the final cost."""
        nlp, N = self.nlp, self.N
        Q, hh = self.Q, self.hh
        zarg, uarg, targ = self._zarg, self._uarg, self._targ
        # the cost
        if running is not None:
            k = np.arange(N)
            nlp.minimize_elements("running", self._running_element(running),
                                  [X(Q[k]), zarg(k), X(Q[k + 1]), hh, (np.arange(N) * 1.0)[:, None], uarg(k)])
        if final is not None:
            # φ(q_N, q̇_N, T), q̇_N from the last step's discrete Legendre transform p_N⁻
            nlp.minimize_elements("final", self._final_element(final),
                                  [X(Q[N - 1]), zarg(N - 1), X(Q[N]), hh, targ(N - 1), uarg(N - 1)])
        if running is None and final is None:
            nlp.minimize(ca.SX(0))

    def _running_element(self, running: ca.Function) -> ca.Function:
        """``h Σ w_i ℓ(q(τ_i), q̇(τ_i), u, t_i)`` over one step (the scheme's quadrature), ``t_i = (k + τ_i) h``."""
        dm = self.dm
        n, s, nu = dm.n, dm.s, dm.nu
        a, b, Z, h, k = ca.SX.sym("a", n), ca.SX.sym("b", n), ca.SX.sym("Z", s), ca.SX.sym("h"), ca.SX.sym("k")
        u = ca.SX.sym("u", nu)
        Xs = [a] + [Z[j * n:(j + 1) * n] for j in range(dm.scheme.stages)] + [b]
        val = dm.scheme.discrete_lagrangian(dm.control_at(lambda q, v, t, uu: running(q, v, uu, t), u), Xs, h, k * h)
        return ca.Function("running", [a, Z, b, h, k, u], [val])

    def _path_nodes(self, fn: ca.Function):
        """Where a path constraint ``g(q, u, t)`` holds: ``(at the grid nodes?, the quadrature nodes' indices)``.

        A constraint in ``q`` and ``t`` alone holds at every grid node and at each step's interior quadrature
        nodes (on the step's polynomial).  One in the controls holds at every quadrature node, with that
        node's control: a control has values only there (a Lobatto step's end nodes each carry their own),
        so a grid node is not a point where it is defined.  (Rows at both a grid node and a quadrature node
        at the same point would be identical, which Ipopt's step does not like when they are active.)"""
        tau = np.asarray(self.dm.scheme.nodes, float)
        in_u = self.dm.nu1 > 0 and fn.jac_sparsity(0, 1).nnz() > 0
        if in_u:
            return False, np.arange(tau.size)
        inner = np.flatnonzero((tau > 1e-12) & (tau < 1 - 1e-12))
        # a constraint affine in q at a point that is a convex combination of the step's end nodes alone
        # (midpoint's q(½) = ½(q_k + q_{k+1})) is implied by the nodes' rows: it is not added (the redundant
        # rows stalled Ipopt at Solved_To_Acceptable_Level on the cart-pole at N = 6400)
        qs = ca.SX.sym("q", self.dm.n)
        g = fn(qs, ca.SX.zeros(fn.size1_in(1), fn.size2_in(1)), ca.SX.zeros(fn.size1_in(2), fn.size2_in(2)))
        if not ca.depends_on(ca.jacobian(g, qs), qs):
            basis = np.asarray(self.dm.scheme.basis, float)
            implied = [i for i in inner if np.all(basis[i, 1:-1] == 0) and basis[i, 0] >= 0 and basis[i, -1] >= 0]
            inner = np.array([i for i in inner if i not in implied], dtype=int)
        return True, inner

    def _path_element(self, fn: ca.Function, nodes: np.ndarray) -> ca.Function:
        """A path constraint ``g(q(τ_i), u_i, t_k + τ_i h)`` at a step's quadrature nodes ``τ_i`` (``nodes``):
        the configuration of the step's polynomial there, and the control of that node (the step's one
        control when the controls are constant per step)."""
        dm = self.dm
        n, s, nu = dm.n, dm.s, dm.nu
        a, b, Z, h, t = ca.SX.sym("a", n), ca.SX.sym("b", n), ca.SX.sym("Z", s), ca.SX.sym("h"), ca.SX.sym("t")
        u = ca.SX.sym("u", nu)
        qs, _ = dm.scheme.path([a] + [Z[j * n:(j + 1) * n] for j in range(dm.scheme.stages)] + [b], h)
        tau = np.asarray(dm.scheme.nodes, float)
        rows = []
        for i in nodes:
            ui = u[(i % dm.nqu) * dm.nu1:(i % dm.nqu + 1) * dm.nu1]
            rows.append(fn(qs[i], ui, t + tau[i] * h))
        return ca.Function("path_steps", [a, Z, b, t, h, u], [ca.vertcat(*rows)])

    def _final_element(self, final: ca.Function) -> ca.Function:
        """``φ(q_N, q̇_N, T)`` with ``q̇_N`` the inverse Legendre transform of ``p_N⁻`` (the last step's), on the
        constraints' tangent space: ``[M Cᵀ; C 0] [q̇; μ] = [p − p(q, 0); −∂c/∂t]``."""
        dm = self.dm
        n, s, m = dm.n, dm.s, dm.m
        sysm = dm.system
        a, Z, q, h = ca.SX.sym("a", n), ca.SX.sym("Z", s), ca.SX.sym("q", n), ca.SX.sym("h")
        t = ca.SX.sym("t")
        u = ca.SX.sym("u", dm.nu)
        p = dm.p_minus(a, Z, q, h, t, u)
        T = h * self.N
        tN = T if not dm.timed else t + h   # a free final time's T = N h (its system is time-independent)
        M = sysm.mass_matrix(q, tN)
        rhs = p - sysm.momentum(q, ca.SX.zeros(n), tN)
        if m:
            C = sysm.constraint(q, tN)[1]
            K = ca.vertcat(ca.horzcat(M, C.T), ca.horzcat(C, ca.SX.zeros(m, m)))
            v = ca.solve(K, ca.vertcat(rhs, -sysm.constraint_rate(q, tN)))[:n]
        else:
            v = ca.solve(M, rhs)
        return ca.Function("final", [a, Z, q, h, t, u], [final(q, v, T)])

    def bounds(self):
        """Bounds fixing the given entries of ``q_0`` and ``q_N``."""
        N, n = self.N, self.dm.n
        qlo = np.full((N + 1, n), -np.inf)
        qhi = np.full((N + 1, n), np.inf)
        for k, qk in ((0, self.q0), (N, self.qN)):
            given = ~np.isnan(qk)
            qlo[k, given] = qhi[k, given] = qk[given]
        return {"q": (qlo.reshape(-1), qhi.reshape(-1))}


def _all_fixed(q) -> bool:
    return bool(np.all(~np.isnan(q)))


def _node_times(tr: ControlTranscription, k):
    """The times of the nodes ``k`` as element arguments, ``(E, 1)`` for an array of nodes and ``(1,)`` for one:
    constants for a fixed final time.  A free final time moves the nodes, and only a time-independent system
    may have one (its elements do not read the time; ``t`` is refused in its path constraints, see
    :mod:`castrajectory.solve.optimal_control`): its times are given at the interval's upper end."""
    T = tr.T_spec if not tr.free_time else tr.T_spec[1]
    t = np.asarray(k) * (float(T) / tr.N)
    return t[:, None] if t.ndim else t.reshape(1)


def split_controls(values: np.ndarray, controls: List, N: int) -> dict:
    """The control vector per step, ``(N, nu)``, split by control name: ``{name: (N, size)}``."""
    U = np.asarray(values, float).reshape(N, -1)
    out, j = {}, 0
    for c in controls:
        out[c.name] = U[:, j:j + c.size]
        j += c.size
    return out
