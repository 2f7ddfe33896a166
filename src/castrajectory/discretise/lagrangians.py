"""Discrete Lagrangians, discrete Euler–Lagrange residuals and discrete Legendre transforms.

A discrete Lagrangian approximates the action over one step,
``L_d(q_k, q_{k+1}; Z_k, h) ≈ ∫_{t_k}^{t_k+h} L(q, q̇) dt``, where ``Z_k`` are
optional internal stage values of the step (empty for the two-point schemes).
The discrete action ``S_d = Σ_k L_d`` is stationary when

* every stage satisfies ``∂L_d/∂Z_k = 0``, and
* every interior node satisfies the discrete Euler–Lagrange (DEL) equation
  ``D₂L_d(q_{k−1}, q_k) + D₁L_d(q_k, q_{k+1}) = 0``.

Discrete Legendre transforms give the momenta at the ends of a step,
``p_k⁺ = −D₁L_d(q_k, q_{k+1})`` and ``p_{k+1}⁻ = D₂L_d(q_k, q_{k+1})``; the DEL
equation says ``p_k⁻ = p_k⁺``.  The initial-value problem fixes ``q_0`` and
``p_0 = ∂L/∂q̇(q_0, q̇_0)`` and imposes ``p_0 = −D₁L_d(q_0, q_1)``.

Holonomic constraints ``c(q) = 0`` are added to the action by the scheme's
quadrature, ``−h Σ_k W_k λ_k·c(q_k)`` with ``W_k`` the node's total weight
(``1`` for midpoint/trapezoid, ``1/3`` for Simpson), and ``−h w_s ν_k·c(Z_k)``
at interior quadrature nodes, so the DEL residual gains ``−∇c(q_k)ᵀ λ_k`` and ``λ_k`` is the
physical multiplier (force per unit ``∇c``).

Every residual is divided by ``h`` so it stays O(1) as ``h → 0``
(mass × acceleration + force).  All derivatives come from CasADi's AD.

Schemes (each states its order of accuracy for q):

========== ===== ======================================================
name       order L_d
========== ===== ======================================================
midpoint   2     ``h L((a+b)/2, (b−a)/h)``
trapezoid  2     ``h/2 [L(a, (b−a)/h) + L(b, (b−a)/h)]``
galerkin4  4     quadratic Galerkin: ``q(τ)`` through ``a, Z, b`` at
                 ``τ = 0, ½, 1``, Lobatto (Simpson) quadrature
                 ``h [L₀ + 4 L_½ + L₁]/6``; equivalent to the Lobatto
                 IIIA–IIIB partitioned Runge–Kutta pair
========== ===== ======================================================
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Tuple

import casadi as ca
import numpy as np

from ..models.mechanics import LagrangianSystem


@dataclass(frozen=True)
class Scheme:
    """A discrete Lagrangian family.

    ``stages`` internal configurations per step, quadrature ``weights`` for
    (start node, stages..., end node) used to weight holonomic constraints.
    """

    name: str
    order: int
    stages: int
    node_weight: float  # weight of each end node in the constraint quadrature (per step)
    stage_weights: Tuple[float, ...] = ()

    def discrete_lagrangian(self, L: ca.Function, a, b, Z, h):
        if self.name == "midpoint":
            return h * L((a + b) / 2, (b - a) / h)
        if self.name == "trapezoid":
            v = (b - a) / h
            return h / 2 * (L(a, v) + L(b, v))
        if self.name == "galerkin4":
            m = Z
            v0 = (-3 * a + 4 * m - b) / h
            vm = (b - a) / h
            v1 = (a - 4 * m + 3 * b) / h
            return h * (L(a, v0) + 4 * L(m, vm) + L(b, v1)) / 6
        raise ValueError(self.name)


def rk4_step(f, x, dt):
    """One classical Runge–Kutta step ``x ↦ x + dt/6 (k₁ + 2k₂ + 2k₃ + k₄)`` of ``ẋ = f(x)`` (CasADi
    expressions): the integrator of the time-stepping baselines and of the guesses."""
    k1 = f(x)
    k2 = f(x + dt / 2 * k1)
    k3 = f(x + dt / 2 * k2)
    k4 = f(x + dt * k3)
    return x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)


SCHEMES: Dict[str, Scheme] = {
    "midpoint": Scheme("midpoint", 2, 0, 0.5),
    "trapezoid": Scheme("trapezoid", 2, 0, 0.5),
    "galerkin4": Scheme("galerkin4", 4, 1, 1.0 / 6.0, (4.0 / 6.0,)),
}


def scheme(name: str) -> Scheme:
    try:
        return SCHEMES[name]
    except KeyError:
        raise ValueError(f"unknown scheme {name!r}; choose from {', '.join(SCHEMES)}") from None


class DiscreteMechanics:
    """CasADi functions of the discrete mechanics of ``system`` under ``scheme``.

    Functions (``n = nq``, ``s = stages * n``, ``m = nc``):

    * ``Ld(a, Z, b, h)`` — discrete Lagrangian;
    * ``del_residual(qm, Zm, q, Zp, qp, lam, h)`` — ``[D₂L_d(qm,q) + D₁L_d(q,qp)]/h − 2w ∇c(q)ᵀλ``
      (``w`` the end-node quadrature weight, so ``2w = 1`` for the two-point schemes);
    * ``stage_residual(a, Z, b, nu, h)`` — ``∂L_d/∂Z / h − w ∇c(Z)ᵀν`` (only if ``s > 0``);
    * ``initial_residual(q0, Z0, q1, p0, lam0, h)`` — ``[p0 + D₁L_d(q0,q1)]/h − w∇c(q0)ᵀλ0``;
    * ``p_plus(a, Z, b, h) = −D₁L_d``, ``p_minus(a, Z, b, h) = D₂L_d``.
    """

    def __init__(self, system: LagrangianSystem, scheme_name: str):
        self.system = system
        self.scheme = scheme(scheme_name)
        n, S = system.nq, self.scheme
        self.n, self.s, self.m = n, S.stages * n, system.nc
        a, b = ca.SX.sym("a", n), ca.SX.sym("b", n)
        Z = ca.SX.sym("Z", self.s)
        h = ca.SX.sym("h")
        L = system.L
        Ld = S.discrete_lagrangian(L, a, b, Z, h)
        self.Ld = ca.Function("Ld", [a, Z, b, h], [Ld])
        D1, D2 = ca.gradient(Ld, a), ca.gradient(Ld, b)
        DZ = ca.gradient(Ld, Z) if self.s else ca.SX(0, 1)
        self.D1 = ca.Function("D1", [a, Z, b, h], [D1])
        self.D2 = ca.Function("D2", [a, Z, b, h], [D2])
        self.p_plus = ca.Function("p_plus", [a, Z, b, h], [-D1])
        self.p_minus = ca.Function("p_minus", [a, Z, b, h], [D2])

        cfun = system.constraint if self.m else None

        def grad_c(q, lam):
            if not self.m:
                return ca.SX.zeros(n)
            c, C = cfun(q)
            return ca.mtimes(C.T, lam)

        qm, q, qp = ca.SX.sym("qm", n), ca.SX.sym("q", n), ca.SX.sym("qp", n)
        Zm, Zp = ca.SX.sym("Zm", self.s), ca.SX.sym("Zp", self.s)
        lam = ca.SX.sym("lam", self.m)
        # An interior node closes two steps, so its constraint weight is twice the end weight
        # (1 for midpoint/trapezoid, 1/3 for Simpson): lam_k is then the physical multiplier.
        r = (self.D2(qm, Zm, q, h) + self.D1(q, Zp, qp, h)) / h - 2 * S.node_weight * grad_c(q, lam)
        self.del_residual = ca.Function("del", [qm, Zm, q, Zp, qp, lam, h], [r])
        p0 = ca.SX.sym("p0", n)
        r0 = (p0 + self.D1(q, Zp, qp, h)) / h - S.node_weight * grad_c(q, lam)
        self.initial_residual = ca.Function("del0", [q, Zp, qp, p0, lam, h], [r0])
        if self.s:
            nu = ca.SX.sym("nu", self.m * S.stages)
            rz = DZ / h
            if self.m:
                for j in range(S.stages):
                    rz[j * n:(j + 1) * n] -= S.stage_weights[j] * grad_c(Z[j * n:(j + 1) * n],
                                                                         nu[j * self.m:(j + 1) * self.m])
            self.stage_residual = ca.Function("stage", [a, Z, b, nu, h], [rz])
        else:
            self.stage_residual = None
        # Constraint rows, for the NLP
        if self.m:
            self.constraint_rows = ca.Function("c", [q], [cfun(q)[0]])

    # --------------------------------------------------------------- helpers
    def stage_guess(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """A stage guess for each step from its end nodes (linear interpolation)."""
        if not self.s:
            return np.zeros((a.shape[0], 0))
        k = self.scheme.stages
        return np.hstack([a + (j + 1) / (k + 1) * (b - a) for j in range(k)])

    def first_step_guess(self, q0, qd0, h):
        """``q_1 ≈ q_0 + h q̇_0 + ½h² q̈_0`` (the Legendre equation then makes it exact)."""
        qdd = np.asarray(self.system.acceleration(q0, qd0)).reshape(-1)
        return np.asarray(q0) + h * np.asarray(qd0) + 0.5 * h * h * qdd

    def momenta(self, q: np.ndarray, Z: np.ndarray, h: float) -> np.ndarray:
        """Nodal momenta: ``p_k⁺ = −D₁L_d(q_k, q_{k+1})`` for k < N and ``p_N⁻ = D₂L_d(q_{N−1}, q_N)``.

        (At a DEL solution ``p_k⁺ = p_k⁻`` for interior nodes.)
        """
        N = q.shape[0] - 1
        pp = np.asarray(self.p_plus.map(N)(q[:-1].T, Z.T, q[1:].T, h)).T
        pN = np.asarray(self.p_minus(q[-2], Z[-1], q[-1], h)).reshape(1, -1)
        return np.vstack([pp, pN])

    def velocities(self, q: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Inverse Legendre transform ``q̇ = M(q)⁻¹ p``, projected onto ``C(q) q̇ = 0`` when constrained."""
        sysm, K, n = self.system, q.shape[0], self.n
        M = np.asarray(sysm.mass_matrix.map(K)(q.T)).reshape(n, K, n).transpose(1, 0, 2)
        v = np.linalg.solve(M, p[..., None])
        if self.m:
            C = np.asarray(sysm.constraint.map(K)(q.T)[1]).reshape(self.m, K, n).transpose(1, 0, 2)
            MiCt = np.linalg.solve(M, C.transpose(0, 2, 1))
            v = v - MiCt @ np.linalg.solve(C @ MiCt, C @ v)
        return v[..., 0]
