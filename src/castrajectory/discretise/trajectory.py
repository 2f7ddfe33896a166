"""The whole-trajectory transcription: all discrete Euler–Lagrange equations of one grid in one program.

Two modes on a uniform grid ``t_k = k h``, ``h = T/N``:

* **initial value**: ``q_0`` and ``q̇_0`` given.  Unknowns ``q_1..q_N`` (plus stages and
  multipliers); equations: the initial discrete Legendre condition
  ``p_0 + D₁L_d(q_0, q_1) = 0``, the DEL equation at every interior node, stage equations
  and constraint rows.  The system is square (as many equations as unknowns) and has a
  zero objective: Ipopt performs a globalised Newton method on it.
* **two-point boundary**: ``q_0`` and ``q_N`` given.  The objective is the discrete action
  ``S_d/h`` over the interior nodes — least action proper; its stationarity conditions are
  the DEL equations and the constraint multipliers are the solver's.

Every family of equations is added as one element family
(:meth:`~castrajectory.discretise.program.Program.equal_elements`), so building is
vectorised (one ``map`` per family, element-wise derivatives) rather than a Python loop of
symbolic calls.  How the program is solved (coarse to fine, horizon windows) is
:mod:`castrajectory.solve.trajectory`.
"""
from __future__ import annotations

from typing import Dict

import casadi as ca
import numpy as np

from .lagrangians import DiscreteMechanics
from .program import P, Program, X


class TrajectoryTranscription:
    """Every discrete Euler–Lagrange equation of one grid as rows of one program (see module docstring).

    Initial value: unknowns ``q_1..q_N`` (plus stages and multipliers), rows ``initial``
    (``p_0 + D₁L_d(q_0, q_1) = 0``), ``del`` at every interior node, ``stage`` and
    ``constraint`` rows, zero objective.  Boundary: the discrete action ``S_d/h`` as the
    objective over the interior nodes, constraint rows.  ``q_0`` (and ``q_N``) are fixed by
    the bounds of :meth:`fixed_bounds`.  ``program`` is the class of the program written
    (:class:`~castrajectory.discretise.program.Program`; the solve layer's subclass uses its NLP).
    """

    program = Program

    def __init__(self, dm: DiscreteMechanics, N: int, T: float, mode: str, q0, end, t0: float = 0.0):
        self.dm, self.N, self.T, self.mode = dm, N, T, mode
        self.h = h = T / N
        n, s, m = dm.n, dm.s, dm.m
        st = dm.scheme.stages
        # Initial value: a square feasibility problem, so the zero Hessian is exact (see Program).
        self.nlp = nlp = self.program(hessian="zero" if mode == "initial_value" else "exact")
        q_init = np.tile(q0, N + 1)
        nlp.variable("q", (N + 1) * n, init=q_init)
        if s:
            nlp.variable("Z", N * s)
        if m and mode == "initial_value":
            # boundary mode: the constraint multipliers are Ipopt's own (see _finish)
            nlp.variable("lam", N * m)
            if s:
                nlp.variable("nu", N * st * m)
        Q = nlp.index("q").reshape(N + 1, n)
        Zi = nlp.index("Z").reshape(N, s) if s else np.zeros((N, 0), dtype=np.int64)
        ivp_m = m and mode == "initial_value"
        Li = nlp.index("lam").reshape(-1, m) if ivp_m else None
        Ni = nlp.index("nu").reshape(N, st * m) if (ivp_m and s) else None
        none = np.zeros(0)
        hh = np.array([h])
        zarg = (lambda rows: X(Zi[rows])) if s else (lambda rows: none)
        self.Q, self.Zi, self.Li, self.Ni = Q, Zi, Li, Ni
        # every element takes the time and its step's controls (none here: an empty column)
        nou = lambda rows: np.zeros((np.size(rows), 0) if np.ndim(rows) else 0)  # noqa: E731
        if dm.timed:
            # the node times are parameters, so that one NLP serves windows that start at other times
            nlp.parameter("t", N + 1, value=dm.node_times(N, h, t0))
            Ti = nlp.parameter_index("t")
            targ = lambda rows: P(Ti[rows][:, None] if np.ndim(rows) else Ti[[rows]])  # noqa: E731
        else:  # a time-independent system's elements do not read the time: constants
            targ = lambda rows: (h * np.asarray(rows, float))[:, None] if np.ndim(rows) else np.array([h * rows])  # noqa: E731
        self._targ = targ

        if mode == "initial_value":
            # p0 is a parameter so that one NLP serves many initial momenta (horizon windows)
            nlp.parameter("p0", n, value=end)
            lam0 = X(Li[0]) if m else none
            nlp.equal_elements("initial", dm.initial_residual,
                               [X(Q[0]), zarg(0), X(Q[1]), P(nlp.parameter_index("p0")), lam0, hh, targ(0), nou(0)])
            if N > 1:
                k = np.arange(1, N)
                lam = X(Li[k]) if m else none
                nlp.equal_elements("del", dm.del_residual,
                                   [X(Q[k - 1]), zarg(k - 1), X(Q[k]), zarg(k), X(Q[k + 1]), lam, hh, targ(k),
                                    nou(k), nou(k)])
            nlp.minimize(ca.SX(0))
        else:
            a, b, Zs = ca.SX.sym("a", n), ca.SX.sym("b", n), ca.SX.sym("Z", s)
            ts = ca.SX.sym("t")
            act = ca.Function("action", [a, Zs, b, ts], [dm.Ld(a, Zs, b, h, ts) / h])
            k = np.arange(N)
            nlp.minimize_elements("action", act, [X(Q[k]), zarg(k), X(Q[k + 1]), targ(k)])
        if s and mode == "initial_value":
            k = np.arange(N)
            nu = X(Ni[k]) if (m and s) else np.zeros(0)
            nlp.equal_elements("stage", dm.stage_residual, [X(Q[k]), X(Zi[k]), X(Q[k + 1]), nu, hh, targ(k), nou(k)])
        if m:
            nodes = np.arange(1, N + 1) if mode == "initial_value" else np.arange(1, N)
            nlp.equal_elements("constraint", dm.constraint_rows, [X(Q[nodes]), targ(nodes)])
            if s:
                k = np.arange(N)
                for j in range(st):
                    nlp.equal_elements(f"stage_constraint{j}", dm.stage_constraint_rows[j],
                                       [X(Zi[:, j * n:(j + 1) * n]), targ(k), hh])
        self.set_start(q0, end, t0)

    def set_start(self, q0, end, t0: float = 0.0) -> None:
        """New ``q0`` and ``p0`` (initial value) or ``q_N`` (boundary), and start time, without rebuilding."""
        self.q0 = np.asarray(q0, float)
        self.end = np.asarray(end, float)
        self.t0 = float(t0)
        if self.mode == "initial_value":
            self.nlp.set_parameter("p0", self.end)
        if self.dm.timed:
            self.nlp.set_parameter("t", self.dm.node_times(self.N, self.h, self.t0))

    @property
    def times(self) -> np.ndarray:
        """The node times ``t0 + k h``."""
        return self.dm.node_times(self.N, self.h, getattr(self, "t0", 0.0))

    def fixed_bounds(self) -> Dict[str, tuple]:
        """Bounds fixing ``q_0`` (and ``q_N`` in boundary mode); Ipopt removes fixed unknowns."""
        N, n = self.N, self.dm.n
        qlo = np.full((N + 1, n), -np.inf)
        qhi = np.full((N + 1, n), np.inf)
        qlo[0] = qhi[0] = self.q0
        if self.mode == "boundary":
            qlo[N] = qhi[N] = self.end
        return {"q": (qlo.reshape(-1), qhi.reshape(-1))}
