"""Discrete mechanics of a system under a scheme: DEL (Lagrange–d'Alembert) residuals, Legendre transforms.

A discrete Lagrangian approximates the action over one step,
``L_d(q_k, q_{k+1}; Z_k, h) ≈ ∫_{t_k}^{t_k+h} L(q, q̇, t) dt``, where ``Z_k`` are
optional internal stage values of the step (empty for the two-point schemes); the scheme
(:mod:`castrajectory.discretise.schemes`) owns its formula, its quadrature and its stage times.
With non-conservative forces ``Q(q, q̇, t)`` the scheme's quadrature of the virtual work gives
the discrete forces ``f⁻_k`` (on ``q_k``), ``f⁺_k`` (on ``q_{k+1}``) and ``f^Z_k`` (on the stages),
and the discrete Lagrange–d'Alembert principle ``δΣL_d + Σ f·δq = 0`` holds when

* every stage satisfies ``∂L_d/∂Z_k + f^Z_k = 0``, and
* every interior node satisfies the forced discrete Euler–Lagrange (DEL) equation
  ``D₂L_d(q_{k−1}, q_k) + f⁺_{k−1} + D₁L_d(q_k, q_{k+1}) + f⁻_k = 0``.

Without forces these are the DEL equations, with the very expressions of an unforced scheme:
a scene carries only the terms it needs.  Discrete Legendre transforms give the momenta at the
ends of a step, ``p_k⁺ = −D₁L_d(q_k, q_{k+1}) − f⁻_k`` and ``p_{k+1}⁻ = D₂L_d(q_k, q_{k+1}) + f⁺_k``;
the DEL equation says ``p_k⁻ = p_k⁺``.  The initial-value problem fixes ``q_0`` and
``p_0 = ∂L/∂q̇(q_0, q̇_0, 0)`` and imposes ``p_0 = p_0⁺``.

Every element takes the time (the node's time ``t_k``; the quadrature's times are ``t_k + τ_i h``) and the
step's controls, which a time-independent system's expressions do not read and an uncontrolled system's
leave empty: one signature for every scene (:class:`DiscreteMechanics`).

Holonomic constraints ``c(q, t) = 0`` are added to the action by the scheme's
constraint quadrature, ``−h Σ_k W_k λ_k·c(q_k)`` with ``W_k`` the node's total weight
(``1`` for midpoint/trapezoid, ``1/3`` for Simpson), and ``−h w_s ν_k·c(Z_k)``
at interior control points, so the DEL residual gains ``−∇c(q_k)ᵀ λ_k`` and ``λ_k`` is the
physical multiplier (force per unit ``∇c``).

Every residual is divided by ``h`` so it stays O(1) as ``h → 0``
(mass × acceleration + force).  All derivatives come from CasADi's AD.
"""
from __future__ import annotations

import copy
import hashlib
from typing import Dict

import casadi as ca
import numpy as np

from ..models.mechanics import LagrangianSystem
from .schemes import SCHEMES, Scheme, scheme  # noqa: F401  (the registry lives with the schemes)


#: RK4 substeps per step of an integrated guess (rk4_step): the trajectory guesses' first (solve/guesses.py) and the
#: contact program's event-located guess (discretise/contact/elements.py)
GUESS_SUBSTEPS = 4


def rk4_step(f, x, dt, t=None):
    """One classical Runge–Kutta step ``x ↦ x + dt/6 (k₁ + 2k₂ + 2k₃ + k₄)`` of ``ẋ = f(x)``, or of
    ``ẋ = f(x, t)`` from the time ``t`` when one is given (CasADi expressions): the integrator of the
    time-stepping baselines and of the guesses."""
    if t is None:
        k1 = f(x)
        k2 = f(x + dt / 2 * k1)
        k3 = f(x + dt / 2 * k2)
        k4 = f(x + dt * k3)
    else:
        k1 = f(x, t)
        k2 = f(x + dt / 2 * k1, t + dt / 2)
        k3 = f(x + dt / 2 * k2, t + dt / 2)
        k4 = f(x + dt * k3, t + dt)
    return x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)



class DiscreteMechanics:
    """CasADi functions of the discrete mechanics of ``system`` under ``scheme`` (a name or a
    :class:`~castrajectory.discretise.schemes.Scheme`).

    Every element has one signature: the nodes and stages it joins and its multipliers, then the step
    ``h``, the time ``t`` (the step's start; the node's time in the node rows) and the controls ``u`` of
    its step (``nu`` values, an empty column for a system without controls).  A time-independent
    system's elements do not read ``t``, and an uncontrolled one's ``u`` is empty: every caller passes
    the same arguments, and each scene's expressions hold only its own terms.  (``n = nq``,
    ``s = stages * n``, ``m = nc``.)

    * ``Ld(a, Z, b, h, t)`` — discrete Lagrangian; ``D1``, ``D2`` its gradients in ``a`` and ``b``;
    * ``p_plus(a, Z, b, h, t, u) = −D₁L_d − f⁻``, ``p_minus(a, Z, b, h, t, u) = D₂L_d + f⁺``;
    * ``del_residual(qm, Zm, q, Zp, qp, lam, h, t, um, u)`` — ``[p⁻(qm, q) − p⁺(q, qp)]/h − 2w ∇c(q)ᵀλ``
      (``w`` the end-node quadrature weight, so ``2w = 1`` for the two-point schemes; ``um`` the controls
      of the step before the node);
    * ``stage_residual(a, Z, b, nu, h, t, u)`` — ``(∂L_d/∂Z + f^Z) / h − w ∇c(Z)ᵀν`` (``None`` if ``s = 0``);
    * ``initial_residual(q0, Z0, q1, p0, lam0, h, t, u)`` — ``[p0 − p⁺(q0, q1)]/h − w∇c(q0)ᵀλ0``;
    * ``final_residual(qm, Zm, q, pN, lam, h, t, u)`` — ``[p⁻(qm, q) − pN]/h − w∇c(q)ᵀλ``;
    * ``constraint_rows(q, t)`` at a node, ``stage_constraint_rows[j](z, t, h)`` at stage ``j`` of a step;
    * ``work(a, Z, b, h, t)`` — the scheme's quadrature over the step of the forces' power ``Q·q̇`` and of
      the time dependence's ``−∂L/∂t`` (post-processing: the energy balance).
    """

    def __init__(self, system: LagrangianSystem, scheme_name, control_points: str = "step"):
        self.system = system
        self.scheme = S = scheme(scheme_name)
        n = system.nq
        self.n, self.s, self.m = n, S.stages * n, system.nc
        self.timed, self.forced = bool(system.time_dependent), bool(system.forced)
        self.controls = list(system.controls)
        #: control values per step: one ("step", constant on the step) or one at each of the scheme's
        #: quadrature nodes ("quadrature", so that the forces' and the cost's quadrature keep the order)
        self.control_points = control_points
        self.nqu = S.nodes.size if control_points == "quadrature" else 1
        self.nu1 = int(sum(c.size for c in self.controls))
        self.nu = self.nu1 * self.nqu
        sym = ca.SX.sym
        self._a, self._b, self._Z, self._h, self._t = sym("a", n), sym("b", n), sym("Z", self.s), sym("h"), sym("t")
        self._U = sym("u", self.nu)
        self._X = [self._a] + [self._Z[j * n:(j + 1) * n] for j in range(S.stages)] + [self._b]
        self._step_elements()
        self._node_rows()
        self._constraint_rows()

    def _step_elements(self) -> None:
        """``Ld``, ``D1``, ``D2``, ``p_plus``, ``p_minus`` of one step, and the stages' ``∂L_d/∂Z + f^Z``."""
        S, system = self.scheme, self.system
        a, b, Z, h, t, U, X = self._a, self._b, self._Z, self._h, self._t, self._U, self._X
        Ld = S.discrete_lagrangian(system.L, X, h, t)
        self.Ld = ca.Function("Ld", [a, Z, b, h, t], [Ld])
        D1, D2 = ca.gradient(Ld, a), ca.gradient(Ld, b)
        DZ = ca.gradient(Ld, Z) if self.s else ca.SX(0, 1)
        self.D1 = ca.Function("D1", [a, Z, b, h, t], [D1])
        self.D2 = ca.Function("D2", [a, Z, b, h, t], [D2])
        if self.forced:  # Q(q, q̇, t, u), each quadrature node with its control (control_at)
            Qu = system.actuated_force
            f = S.discrete_forces(self.control_at(lambda q, v, tt, u: Qu(q, v, tt, u), U), X, h, t)
            fm, fp = f[0], f[-1]
            self._stage_rows = (DZ + ca.vertcat(*f[1:-1])) / h if self.s else ca.SX(0, 1)
        else:
            fm = fp = None
            self._stage_rows = DZ / h
        self._forces = fm is not None
        self.p_plus = ca.Function("p_plus", [a, Z, b, h, t, U], [-D1 if fm is None else -D1 - fm])
        self.p_minus = ca.Function("p_minus", [a, Z, b, h, t, U], [D2 if fp is None else D2 + fp])

    def _grad_c(self, q, lam, t):
        """``∇c(q, t)ᵀ λ`` (zeros without constraints)."""
        if not self.m:
            return ca.SX.zeros(self.n)
        return ca.mtimes(self.system.constraint(q, t)[1].T, lam)

    def _node_rows(self) -> None:
        """The DEL row of an interior node, the initial and the final Legendre rows, and the stage rows."""
        S, n, h, t, U = self.scheme, self.n, self._h, self._t, self._U
        sym = ca.SX.sym
        qm, q, qp, p0 = sym("qm", n), sym("q", n), sym("qp", n), sym("p0", n)
        Zm, Zp, Um = sym("Zm", self.s), sym("Zp", self.s), sym("um", self.nu)
        lam = sym("lam", self.m)
        # the node's time t: the step before it starts at t − h; an interior node closes two steps, so its
        # constraint weight is twice the end weight (1 for midpoint/trapezoid, 1/3 for Simpson) and lam is
        # the physical multiplier.  Without forces p⁻ − p⁺ is D₂L_d + D₁L_d, written as such.
        if self._forces:
            r = (self.p_minus(qm, Zm, q, h, t - h, Um) - self.p_plus(q, Zp, qp, h, t, U)) / h
            r0 = (p0 - self.p_plus(q, Zp, qp, h, t, U)) / h
        else:
            r = (self.D2(qm, Zm, q, h, t - h) + self.D1(q, Zp, qp, h, t)) / h
            r0 = (p0 + self.D1(q, Zp, qp, h, t)) / h
        w = S.node_weight
        self.del_residual = ca.Function("del", [qm, Zm, q, Zp, qp, lam, h, t, Um, U],
                                        [r - 2 * w * self._grad_c(q, lam, t)])
        self.initial_residual = ca.Function("del0", [q, Zp, qp, p0, lam, h, t, U], [r0 - w * self._grad_c(q, lam, t)])
        # the final node's momentum, p_N⁻ − p_N, for a boundary velocity at the end (optimal control)
        # (the end node's half of a DEL row: p_N⁻ − w∇c(q_N)ᵀλ_N = p_N)
        self.final_residual = ca.Function("delN", [qm, Zm, q, p0, lam, h, t, U],
                                          [(self.p_minus(qm, Zm, q, h, t - h, U) - p0) / h
                                           - w * self._grad_c(q, lam, t)])
        self.stage_residual = None
        if self.s:
            a, b, Z = self._a, self._b, self._Z
            nu = sym("nu", self.m * S.stages)
            rz = self._stage_rows
            if self.m:
                for j in range(S.stages):
                    tj = t + float(S.stage_times[j]) * h
                    rz[j * n:(j + 1) * n] -= S.stage_weights[j] * self._grad_c(Z[j * n:(j + 1) * n],
                                                                               nu[j * self.m:(j + 1) * self.m], tj)
            self.stage_residual = ca.Function("stage", [a, Z, b, nu, h, t, U], [rz])

    def _constraint_rows(self) -> None:
        """The constraint rows for the NLP: at a node (its time), and at stage ``j`` of a step (the step's start
        and ``h``)."""
        if not self.m:
            return
        S, n, h, t = self.scheme, self.n, self._h, self._t
        cfun = self.system.constraint
        q, zj = ca.SX.sym("q", n), ca.SX.sym("zj", n)
        self.constraint_rows = ca.Function("c", [q, t], [cfun(q, t)[0]])
        self.stage_constraint_rows = [ca.Function(f"c_stage{j}", [zj, t, h], [cfun(zj, t + float(S.stage_times[j]) * h)[0]])
                                      for j in range(S.stages)]

    def control_at(self, fn, U):
        """``fn(q, v, t, u)`` as ``g(q, v, t)`` for a quadrature, the control at its i-th node being ``U``'s
        i-th block (the quadratures call their integrand once per node, in order; a step's one control
        serves every node)."""
        calls = iter(range(10 ** 9))
        nu1, nqu = self.nu1, self.nqu

        def g(q, v, t):
            i = next(calls) % nqu
            return fn(q, v, t, U[i * nu1:(i + 1) * nu1])
        return g

    # --------------------------------------------------------------- helpers
    def node_times(self, N: int, h: float, t0: float = 0.0) -> np.ndarray:
        """``t_k = t0 + k h`` for ``k = 0..N``."""
        return t0 + h * np.arange(N + 1)

    def stage_guess(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """A stage guess for each step from its end nodes (the straight line, at the scheme's stage times)."""
        return self.scheme.stage_guess(a, b)

    def first_step_guess(self, q0, qd0, h, t0: float = 0.0):
        """``q_1 ≈ q_0 + h q̇_0 + ½h² q̈_0`` (the Legendre equation then makes it exact)."""
        qdd = self.system.index1_values(q0, qd0, t0)[0]
        return np.asarray(q0) + h * np.asarray(qd0) + 0.5 * h * h * qdd

    def momenta(self, q: np.ndarray, Z: np.ndarray, h: float, t0: float = 0.0, U=None) -> np.ndarray:
        """Nodal momenta: ``p_k⁺ = −D₁L_d(q_k, q_{k+1}) − f⁻_k`` for k < N and ``p_N⁻ = D₂L_d(q_{N−1}, q_N) + f⁺``,
        under the controls ``U`` (``(N, nu)``; none for a system without controls).

        (At a DEL solution ``p_k⁺ = p_k⁻`` for interior nodes.)
        """
        N = q.shape[0] - 1
        tk = self.node_times(N, h, t0)
        U = np.zeros((N, 0)) if U is None else np.asarray(U, float).reshape(N, self.nu)
        pp = np.asarray(self.p_plus.map(N)(q[:-1].T, Z.T, q[1:].T, h, tk[None, :-1], U.T)).T
        pN = np.asarray(self.p_minus(q[-2], Z[-1], q[-1], h, tk[-2], U[-1])).reshape(1, -1)
        return np.vstack([pp, pN])

    def velocities(self, q: np.ndarray, p: np.ndarray, t=0.0) -> np.ndarray:
        """Inverse Legendre transform ``q̇ = M(q, t)⁻¹ (p − ∂L/∂q̇(q, 0, t))``, projected onto
        ``C(q) q̇ + ∂c/∂t = 0`` when constrained (``t``: a number or one per row)."""
        sysm, K, n = self.system, q.shape[0], self.n
        tt = np.broadcast_to(np.asarray(t, float), (K,)).reshape(1, -1)
        M = np.asarray(sysm.mass_matrix.map(K)(q.T, tt)).reshape(n, K, n).transpose(1, 0, 2)
        if self.timed:  # a moving frame's part of the momentum, p(q, 0, t)
            p = p - np.asarray(sysm.momentum.map(K)(q.T, np.zeros((n, K)), tt)).T
        v = np.linalg.solve(M, p[..., None])
        if self.m:
            C = np.asarray(sysm.constraint.map(K)(q.T, tt)[1]).reshape(self.m, K, n).transpose(1, 0, 2)
            MiCt = np.linalg.solve(M, C.transpose(0, 2, 1))
            Cv = C @ v
            if self.timed:
                Cv = Cv + np.asarray(sysm.constraint_rate.map(K)(q.T, tt)).T[..., None]
            v = v - MiCt @ np.linalg.solve(C @ MiCt, Cv)
        return v[..., 0]

    def work(self, q: np.ndarray, Z: np.ndarray, h: float, t0: float = 0.0) -> np.ndarray:
        """Cumulative work at the nodes, ``(N+1, 2)``: of the forces (``∫Q·q̇ dt``) and of the time
        dependence (``−∫∂L/∂t dt``), each by the scheme's quadrature on the solved steps; their sum is
        the change of the energy function."""
        N = q.shape[0] - 1
        tk = self.node_times(N, h, t0)
        if not hasattr(self, "_work"):
            X, a, Zs, b, hs, ts = self._X, self._a, self._Z, self._b, self._h, self._t
            pw = self.system.power
            work = self.scheme.step_integral(lambda qq, v, t: ca.vertcat(*pw(qq, v, t)), X, hs, ts)
            self._work = ca.Function("work", [a, Zs, b, hs, ts], [work])
        w = np.asarray(self._work.map(N)(q[:-1].T, Z.T, q[1:].T, h, tk[None, :-1])).T
        return np.vstack([np.zeros((1, 2)), np.cumsum(w, axis=0)])


_CACHE: Dict[tuple, DiscreteMechanics] = {}


def _form(fn: ca.Function) -> str:
    return hashlib.sha256(fn.serialize().encode()).hexdigest()


def discrete_mechanics(system: LagrangianSystem, scheme_name, control_points: str = "step") -> DiscreteMechanics:
    """:class:`DiscreteMechanics` of ``system`` under ``scheme_name``, its functions shared with an earlier
    system of the same Lagrangian, constraints and forces (found by their serialised forms): every
    ``simulate()`` builds its system afresh, and forming the discrete functions again cost 7 ms of a
    60 ms run (galerkin12, double pendulum) besides the derivatives and compiled code keyed by them.
    The copy is bound to ``system`` (its names, points and terms)."""
    key = (scheme(scheme_name).name, _form(system.L), _form(system.constraint) if system.nc else None,
           _form(system.force) if system.forced else None, bool(system.time_dependent),
           control_points if system.controls else None)
    hit = _CACHE.get(key)
    if hit is None:
        if len(_CACHE) > 64:
            _CACHE.clear()
        hit = _CACHE[key] = DiscreteMechanics(system, scheme_name, control_points)
    dm = copy.copy(hit)
    dm.system = system
    return dm
