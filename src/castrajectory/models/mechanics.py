"""Lagrangian systems: coordinates, kinetic energy, potential terms, holonomic constraints.

A :class:`LagrangianSystem` describes the physics only; how it is discretised
(:mod:`castrajectory.discretise.lagrangians`) and solved (:mod:`castrajectory.solve.trajectory`,
:mod:`castrajectory.baselines.stepping`) lives elsewhere.

Kinetic energy comes in one of two forms:

* :class:`MassMatrix` — ``K = ½ q̇ᵀ M(q) q̇``;
* :class:`Atoms` — the seed's definition: atom positions ``x_a = f_a(q)``
  (CasADi expressions) with masses ``m_a``, ``K = Σ ½ m_a |J_a(q) q̇|²``.
  Point masses of a linkage or quadrature points of a body are atoms.

Potential energy is a list of terms, each a small object with an
``energy(system)`` method: :class:`Gravity`, :class:`Spring`,
:class:`Potential` (a user expression).  A system holds only the terms its
scene names; in particular a scene with ``g = 0`` simply omits
:class:`Gravity`.

Holonomic constraints ``c(q) = 0`` are a list of expressions; their
multipliers are unknowns of the trajectory NLP.

Unilateral contact is one more term, :class:`Contact`: gap expressions
``φ_j(q) ≥ 0`` (one per contact point) and a restitution coefficient.  A
system without it builds no contact variables anywhere
(:mod:`castrajectory.solve.contact` transcribes it).

Example (planar pendulum, one atom)::

    q = casadi.SX.sym("q", 1)
    bob = casadi.vertcat(casadi.sin(q[0]), -casadi.cos(q[0]))
    pendulum = LagrangianSystem(q, Atoms([bob], [1.0]), [Gravity(9.81)])
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import List, Optional, Sequence

import casadi as ca
import numpy as np

from ..validation import InputError, finite


# ----------------------------------------------------------------------------- kinetic energy
@dataclass
class MassMatrix:
    """``K = ½ q̇ᵀ M(q) q̇`` for a symmetric positive definite ``M`` (SX expression of q or constant).

    A planar rigid body, coordinates ``(x, y, θ)``, mass 2 and inertia 0.5 about its centre:

    >>> import casadi as ca, castrajectory as ct
    >>> q = ca.SX.sym("q", 3)
    >>> body = ct.LagrangianSystem(q, ct.MassMatrix(ca.diag(ca.DM([2.0, 2.0, 0.5]))),
    ...                            [ct.Gravity(9.81, heights=[q[1]], masses=[2.0])])
    >>> float(body.energy([0, 1, 0], [1, 0, 2]))   # ½·2·1² + ½·0.5·2² + 2·9.81·1
    21.62
    """

    matrix: object

    def energy(self, q, qd):
        M = ca.SX(self.matrix) if not isinstance(self.matrix, ca.SX) else self.matrix
        return 0.5 * ca.dot(qd, ca.mtimes(M, qd))


@dataclass
class Atoms:
    """Atoms at positions ``x_a = f_a(q)`` with masses ``m_a``: ``K = Σ ½ m_a |J_a q̇|²``.

    A pendulum of length 2 (angle from the downward vertical), its bob of mass 3:

    >>> import casadi as ca, castrajectory as ct
    >>> th = ca.SX.sym("theta", 1)
    >>> bob = 2.0 * ca.vertcat(ca.sin(th), -ca.cos(th))
    >>> pendulum = ct.LagrangianSystem(th, ct.Atoms([bob], [3.0]), [ct.Gravity(9.81)])
    >>> float(pendulum.energy([0.0], [1.0]))       # ½·3·(2·1)² − 3·9.81·2
    -52.86
    """

    positions: Sequence[object]
    masses: Sequence[float]

    def __post_init__(self):
        if len(self.positions) != len(self.masses):
            raise ValueError("one mass per atom position is needed")
        if any(not np.isfinite(m) or m <= 0 for m in self.masses):
            raise ValueError("atom masses must be positive and finite")

    def energy(self, q, qd):
        K = ca.SX(0)
        for x, m in zip(self.positions, self.masses):
            v = ca.mtimes(ca.jacobian(x, q), qd)
            K += 0.5 * m * ca.dot(v, v)
        return K


# ----------------------------------------------------------------------------- potential terms
@dataclass
class Gravity:
    """Uniform gravity ``g`` acting along ``-e_y`` on every atom: ``U = Σ m_a g y_a``.

    For a :class:`MassMatrix` system give ``heights`` (expressions) and ``masses``
    explicitly.  A scene without gravity leaves the term out (``g = 0`` adds nothing):

    >>> import casadi as ca, castrajectory as ct
    >>> y = ca.SX.sym("y", 1)
    >>> ball = ct.LagrangianSystem(y, ct.Atoms([ca.vertcat(0, y)], [1.0]), [ct.Gravity(9.81)])
    >>> float(ball.acceleration([1.0], [0.0]))
    -9.81
    """

    g: float
    heights: Optional[Sequence[object]] = None
    masses: Optional[Sequence[float]] = None

    def energy(self, system: "LagrangianSystem"):
        if self.heights is not None:
            hs, ms = self.heights, self.masses
        elif isinstance(system.kinetic, Atoms):
            hs = [x[1] for x in system.kinetic.positions]
            ms = system.kinetic.masses
        else:
            raise ValueError("Gravity on a mass-matrix system needs explicit heights and masses")
        return sum(m * self.g * h for m, h in zip(ms, hs))


@dataclass
class Spring:
    """Linear spring of stiffness ``k`` and rest length ``rest`` between points ``a`` and ``b``.

    A mass on a spring of rest length 1 hung from the origin, released at length 1.5:

    >>> import casadi as ca, castrajectory as ct
    >>> x = ca.SX.sym("x", 2)
    >>> s = ct.LagrangianSystem(x, ct.Atoms([x], [1.0]), [ct.Spring(100.0, 1.0, x, ca.DM.zeros(2))])
    >>> (s.acceleration([0.0, -1.5], [0.0, 0.0]).full().ravel().round(9) + 0.0).tolist()   # k (1.5 − 1) / m up
    [0.0, 50.0]
    """

    stiffness: float
    rest: float
    a: object
    b: object

    def energy(self, system):
        d = self.a - self.b
        return 0.5 * self.stiffness * (ca.sqrt(ca.dot(d, d)) - self.rest) ** 2


@dataclass
class Potential:
    """A user-supplied potential energy expression of ``q`` (``name`` labels it in tables).

    >>> import casadi as ca, castrajectory as ct
    >>> x = ca.SX.sym("x", 1)
    >>> quartic = ct.LagrangianSystem(x, ct.MassMatrix(1.0), [ct.Potential(x[0] ** 4, "quartic well")])
    >>> float(quartic.acceleration([2.0], [0.0])), quartic.terms()
    (-32.0, ['kinetic: mass matrix', 'quartic well'])
    """

    expr: object
    name: str = "potential"

    def energy(self, system):
        return self.expr


# ----------------------------------------------------------------------------- contact
@dataclass
class Contact:
    """Unilateral contacts: gaps ``φ_j(q) ≥ 0`` (SX expressions of q) with Newton restitution ``e``.

    An impact of contact ``j`` reverses its normal velocity ``∇φ_j q̇`` by the
    factor ``e`` (``e = 1``: elastic, the default); impulses act along
    ``M⁻¹∇φ_jᵀ`` with ``μ_j ≥ 0``.  ``names`` label the contact points in output.
    A ball dropped from 1 m bounces at ``t = √(2/g)``:

    >>> import casadi as ca, castrajectory as ct
    >>> y = ca.SX.sym("y", 1)
    >>> ball = ct.LagrangianSystem(y, ct.Atoms([ca.vertcat(0, y)], [1.0]), [ct.Gravity(9.81)],
    ...                            contact=ct.Contact([y[0]], restitution=0.8))
    >>> run = ct.simulate(ball, [1.0], [0.0], T=0.6, N=120)
    >>> run.success, round(run.detail.impacts[0].t, 9) == round((2 / 9.81) ** 0.5, 9)
    (True, True)
    """

    gaps: Sequence[object]
    restitution: float = 1.0
    names: Optional[Sequence[str]] = None

    def __post_init__(self):
        e = finite("restitution", self.restitution)
        if not 0.0 <= e <= 1.0:
            raise InputError(f"restitution must be between 0 and 1 (got {self.restitution})")
        self.restitution = e
        self.gaps = [ca.SX(g) if not isinstance(g, ca.SX) else g for g in self.gaps]
        if not self.gaps or any(g.numel() != 1 for g in self.gaps):
            raise ValueError("a Contact needs at least one scalar gap expression")
        self.names = list(self.names) if self.names else [f"contact{j}" for j in range(len(self.gaps))]

    @property
    def count(self) -> int:
        return len(self.gaps)


# ----------------------------------------------------------------------------- the system
@dataclass
class LagrangianSystem:
    """``L(q, q̇) = K(q, q̇) − U(q)`` with optional holonomic constraints ``c(q) = 0``.

    A pendulum written in Cartesian coordinates, held on its circle by a constraint; its multiplier
    is the rod's tension per unit length:

    >>> import casadi as ca, castrajectory as ct
    >>> x = ca.SX.sym("x", 2)
    >>> p = ct.LagrangianSystem(x, ct.Atoms([x], [1.0]), [ct.Gravity(9.81)],
    ...                         constraints=[(ca.dot(x, x) - 1.0) / 2], names=["x", "y"])
    >>> run = ct.simulate(p, [1.0, 0.0], [0.0, 0.0], T=0.5, N=200)
    >>> run.success, abs(float(sum(run.q[-1] ** 2)) - 1.0) < 1e-12
    (True, True)

    Parameters
    ----------
    q: SX column of generalised coordinates.
    kinetic: :class:`MassMatrix` or :class:`Atoms`.
    potentials: potential-energy terms (only those the scene needs).
    constraints: holonomic constraint expressions ``c_i(q) = 0``.
    names: coordinate names, for output.
    points: optional SX points (e.g. atom positions) returned by :meth:`points` for plots.
    contact: optional :class:`Contact` term (unilateral gaps with restitution).
    """

    q: object
    kinetic: object
    potentials: Sequence[object] = ()
    constraints: Sequence[object] = ()
    names: Optional[Sequence[str]] = None
    points_expr: Optional[Sequence[object]] = None
    contact: Optional[Contact] = None
    _fn: dict = field(default_factory=dict, init=False, repr=False)

    def __post_init__(self):
        if not isinstance(self.q, ca.SX) or not self.q.is_column() or not self.q.is_valid_input():
            raise ValueError("q must be a column of SX symbols")
        self.qd = ca.SX.sym("qd", self.nq)
        self.names = list(self.names) if self.names else [f"q{i}" for i in range(self.nq)]
        if self.points_expr is None and isinstance(self.kinetic, Atoms):
            self.points_expr = list(self.kinetic.positions)

    # -- sizes
    @property
    def nq(self) -> int:
        return self.q.numel()

    @property
    def nc(self) -> int:
        return int(sum(ca.vec(c).numel() for c in self.constraints))

    @property
    def ncontact(self) -> int:
        """Number of contact points (0 without a :class:`Contact` term)."""
        return self.contact.count if self.contact is not None else 0

    def terms(self) -> List[str]:
        """What the system holds, one entry per term: its kinetic form, each potential term, its
        holonomic constraints, its contact (for the report's table of what each scene carries)."""
        kin = type(self.kinetic).__name__
        na = len(getattr(self.kinetic, "masses", []))
        out = [{"Atoms": f"kinetic: {na} atom{'s' if na != 1 else ''}",
                "MassMatrix": "kinetic: mass matrix",
                "RigidBody": "kinetic: rigid body (rotation, inertia)"}.get(kin, f"kinetic: {kin}")]
        for t in self.potentials:
            out.append({"Gravity": "gravity", "Spring": "spring"}.get(type(t).__name__, getattr(t, "name", "potential")))
        if self.nc:
            out.append(f"{self.nc} holonomic constraint{'s' if self.nc > 1 else ''}")
        if self.contact is not None:
            out.append(f"contact: {self.ncontact} gap{'s' if self.ncontact > 1 else ''}, e = {self.contact.restitution:g}")
        return out

    # -- symbolic pieces (expressions in self.q, self.qd)
    def kinetic_expr(self):
        return self.kinetic.energy(self.q, self.qd)

    def potential_expr(self):
        U = ca.SX(0)
        for term in self.potentials:
            U += term.energy(self)
        return U

    def lagrangian_expr(self):
        return self.kinetic_expr() - self.potential_expr()

    def constraint_expr(self):
        return ca.vertcat(*[ca.vec(c) for c in self.constraints]) if self.constraints else ca.SX(0, 1)

    # -- numerical functions (built once)
    def _get(self, key, build):
        if key not in self._fn:
            self._fn[key] = build()
        return self._fn[key]

    @property
    def L(self) -> ca.Function:
        """``L(q, q̇)``."""
        return self._get("L", lambda: ca.Function("L", [self.q, self.qd], [self.lagrangian_expr()]))

    @property
    def energy(self) -> ca.Function:
        """Total energy ``K + U`` as a function of ``(q, q̇)``."""
        return self._get("E", lambda: ca.Function(
            "E", [self.q, self.qd], [self.kinetic_expr() + self.potential_expr()]))

    @property
    def potential(self) -> ca.Function:
        return self._get("U", lambda: ca.Function("U", [self.q], [self.potential_expr()]))

    @property
    def mass_matrix(self) -> ca.Function:
        """``M(q) = ∂²K/∂q̇²``."""
        return self._get("M", lambda: ca.Function(
            "M", [self.q], [ca.densify(ca.hessian(self.kinetic_expr(), self.qd)[0])]))

    @property
    def momentum(self) -> ca.Function:
        """Continuous Legendre transform ``p = ∂L/∂q̇``."""
        return self._get("p", lambda: ca.Function(
            "p", [self.q, self.qd], [ca.gradient(self.lagrangian_expr(), self.qd)]))

    @property
    def constraint(self) -> ca.Function:
        """``c(q)`` and its Jacobian ``C(q) = ∂c/∂q``."""
        c = self.constraint_expr()
        return self._get("c", lambda: ca.Function("c", [self.q], [c, ca.densify(ca.jacobian(c, self.q))]))

    @property
    def gap(self) -> ca.Function:
        """Contact gaps ``φ(q)`` and their Jacobian ``∂φ/∂q`` (only with a :class:`Contact` term)."""
        if self.contact is None:
            raise ValueError("this system has no contact term")
        def build():
            phi = ca.vertcat(*self.contact.gaps)
            return ca.Function("gap", [self.q], [phi, ca.densify(ca.jacobian(phi, self.q))])
        return self._get("gap", build)

    @property
    def acceleration(self) -> ca.Function:
        """Euler–Lagrange right-hand side ``q̈(q, q̇)``.

        Unconstrained: ``M q̈ = ∂L/∂q − (∂²L/∂q̇∂q) q̇``.  With holonomic
        constraints the index-1 system ``[M Cᵀ; C 0] [q̈; λ] = [f; −(∂(C q̇)/∂q) q̇]``
        is solved (used by the time-stepping baselines and the integrated guesses).
        """
        return self._get("index1", self._index1)[0]

    @property
    def multiplier(self) -> ca.Function:
        """The constraint multipliers ``λ(q, q̇)`` of the index-1 system (``M q̈ + Cᵀλ = f``): the
        same sign and scale as the discrete multipliers of the trajectory NLP.  Empty without constraints."""
        return self._get("index1", self._index1)[1]

    def _index1(self):
        L = self.lagrangian_expr()
        dLdqd = ca.gradient(L, self.qd)
        M = ca.hessian(L, self.qd)[0]
        f = ca.gradient(L, self.q) - ca.mtimes(ca.jacobian(dLdqd, self.q), self.qd)
        if self.nc:
            c = self.constraint_expr()
            C = ca.jacobian(c, self.q)
            gamma = -ca.mtimes(ca.jacobian(ca.mtimes(C, self.qd), self.q), self.qd)
            K = ca.blockcat([[M, C.T], [C, ca.SX(self.nc, self.nc)]])
            sol = ca.solve(K, ca.vertcat(f, gamma))
            qdd, lam = sol[:self.nq], sol[self.nq:]
        else:
            qdd, lam = ca.solve(M, f), ca.SX(0, 1)
        return (ca.Function("qdd", [self.q, self.qd], [qdd]),
                ca.Function("lam", [self.q, self.qd], [lam]))

    @property
    def points(self) -> Optional[ca.Function]:
        """Positions of the plotted points (atoms by default) as a function of q, stacked as rows."""
        if not self.points_expr:
            return None
        return self._get("pts", lambda: ca.Function(
            "pts", [self.q], [ca.horzcat(*[ca.vec(p) for p in self.points_expr]).T]))

    def positions(self, q: np.ndarray) -> np.ndarray:
        """Point positions for each row of ``q``: array of shape (len(q), n_points, dim)."""
        fn = self.points
        if fn is None:
            raise ValueError("this system has no points to show")
        q = np.atleast_2d(q)
        F = fn.map(q.shape[0])
        out = np.asarray(F(q.T))  # (n_points, len(q) * dim), one dim-block per row of q
        npts = len(self.points_expr)
        return out.reshape(npts, q.shape[0], -1).transpose(1, 0, 2)

    def energies(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """Total energy for each row of ``(q, q̇)``."""
        q, qd = np.atleast_2d(q), np.atleast_2d(qd)
        return np.asarray(self.energy.map(q.shape[0])(q.T, qd.T)).reshape(-1)
