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

Unilateral contact is one more term, :class:`~castrajectory.models.contact.Contact`
(:mod:`castrajectory.models.contact`): gap expressions ``φ_j(q) ≥ 0`` (one per contact point), a
restitution coefficient, the impact law and Coulomb friction.  A system without it builds no contact
variables anywhere (:mod:`castrajectory.solve.contact` transcribes it).

Example (planar pendulum, one atom)::

    q = casadi.SX.sym("q", 1)
    bob = casadi.vertcat(casadi.sin(q[0]), -casadi.cos(q[0]))
    pendulum = LagrangianSystem(q, Atoms([bob], [1.0]), [Gravity(9.81)])
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

import casadi as ca
import numpy as np

from ..validation import InputError, finite
from .contact import Contact  # noqa: F401  (the contact term; re-exported: it stands beside the other terms)

# ----------------------------------------------------------------------------- time and velocity symbols
_TIME = ca.SX.sym("t")
_VELOCITIES: dict = {}


def time() -> ca.SX:
    """The time symbol: an atom, potential, constraint or force that holds it depends on time.

    A pendulum whose pivot moves up and down as ``a cos(ωt)`` is an atom position holding ``t``:

    >>> import casadi as ca, castrajectory as ct
    >>> th, t = ca.SX.sym("theta", 1), ct.time()
    >>> bob = ca.vertcat(ca.sin(th), 0.1 * ca.cos(30 * t) - ca.cos(th))
    >>> kapitza = ct.LagrangianSystem(th, ct.Atoms([bob], [1.0]), [ct.Gravity(9.81)])
    >>> kapitza.time_dependent
    True
    """
    return _TIME


def _key(q) -> tuple:
    return tuple(q[i].element_hash() for i in range(q.numel()))


def velocity(q) -> ca.SX:
    """The velocity symbol ``q̇`` of the coordinates ``q`` (one per coordinate column): the symbol a
    :class:`Force` or :class:`Dissipation` is written in, and the one the system built on ``q`` uses.

    >>> import casadi as ca, castrajectory as ct
    >>> x = ca.SX.sym("x", 1)
    >>> v = ct.velocity(x)
    >>> drag = ct.LagrangianSystem(x, ct.MassMatrix(2.0), [ct.Force(-0.5 * v * ca.fabs(v), "quadratic drag")])
    >>> float(drag.acceleration([0.0], [2.0], 0.0))      # -0.5·2·|2| / 2
    -1.0
    """
    if not isinstance(q, ca.SX) or not q.is_column() or not q.is_valid_input():
        raise InputError("velocity(q) needs the column of SX symbols of the coordinates")
    key = _key(q)
    if key not in _VELOCITIES:
        _VELOCITIES[key] = ca.SX.sym("qd", q.numel())
    return _VELOCITIES[key]


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
            if ca.depends_on(ca.SX(x), _TIME):  # a moving atom: its velocity has the part ∂x/∂t
                v = v + ca.jacobian(x, _TIME)
            K += 0.5 * m * ca.dot(v, v)
        return K


# ----------------------------------------------------------------------------- potential terms
@dataclass
class Gravity:
    """Uniform gravity of strength ``g`` along the unit vector of ``direction``: ``U = −Σ m_a g d̂·x_a``.

    Planar atoms (2 coordinates) are pulled along ``−e_y`` unless a direction is given.  Atoms in
    3-D need the direction (a z-up model wants ``direction=(0, 0, -1)``, a y-up one ``(0, -1, 0)``):
    it is refused rather than guessed.  For a :class:`MassMatrix` system give ``heights``
    (expressions, measured against gravity) and ``masses`` explicitly.  A scene without gravity
    leaves the term out (``g = 0`` adds nothing):

    >>> import casadi as ca, castrajectory as ct
    >>> y = ca.SX.sym("y", 1)
    >>> ball = ct.LagrangianSystem(y, ct.Atoms([ca.vertcat(0, y)], [1.0]), [ct.Gravity(9.81)])
    >>> float(ball.acceleration([1.0], [0.0]))
    -9.81
    >>> z = ca.SX.sym("z", 1)   # z up, in 3-D
    >>> ball3 = ct.LagrangianSystem(z, ct.Atoms([ca.vertcat(0, 0, z)], [1.0]),
    ...                             [ct.Gravity(9.81, direction=(0, 0, -1))])
    >>> float(ball3.acceleration([1.0], [0.0]))
    -9.81
    """

    g: float
    heights: Optional[Sequence[object]] = None
    masses: Optional[Sequence[float]] = None
    direction: Optional[Sequence[float]] = None

    def __post_init__(self):
        self.g = finite("g", self.g)
        if self.direction is not None:
            try:
                d = np.asarray(self.direction, dtype=float)
            except (TypeError, ValueError):
                raise InputError(f"Gravity direction must be a vector of numbers (got {self.direction!r})") from None
            if d.ndim != 1 or d.size < 1 or not np.all(np.isfinite(d)) or not np.any(d != 0.0):
                raise InputError(f"Gravity direction must be a finite, nonzero vector (got {self.direction!r})")
            if self.heights is not None:
                raise InputError("Gravity takes either heights (a mass-matrix system) or a direction, not both")
            self.direction = tuple(float(v) for v in d)

    def energy(self, system: "LagrangianSystem"):
        if self.heights is not None:
            hs, ms = self.heights, self.masses
            return sum(m * self.g * h for m, h in zip(ms, hs))
        if not isinstance(system.kinetic, Atoms):
            raise InputError("Gravity on a mass-matrix system needs explicit heights and masses")
        xs, ms = system.kinetic.positions, system.kinetic.masses
        dims = sorted({int(ca.SX(x).numel()) for x in xs})
        if self.direction is None:
            if dims != [2]:
                raise InputError(f"Gravity on atoms of {' and '.join(map(str, dims))} coordinates needs a direction, "
                                 f"e.g. ct.Gravity({self.g:g}, direction=(0, 0, -1)) for z up (only planar atoms "
                                 f"default to -y)")
            return sum(m * self.g * x[1] for m, x in zip(ms, xs))  # U = Σ m g y (the planar default)
        d = np.asarray(self.direction)
        if dims != [d.size]:
            raise InputError(f"Gravity direction has {d.size} components, the atoms {' and '.join(map(str, dims))} "
                             f"coordinates")
        d = d / np.linalg.norm(d)
        # the height of an atom is −d̂·x; zero components add no terms (the expressions stay as short
        # as a hand-written one: −1 · x is −x)
        return sum(m * self.g * sum(-float(dj) * ca.SX(x)[j] for j, dj in enumerate(d) if dj != 0.0)
                   for m, x in zip(ms, xs))


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


# ----------------------------------------------------------------------------- forces
@dataclass
class Force:
    """A generalised force ``Q(q, q̇, t)`` (a column of one entry per coordinate) that does not come
    from a potential: it enters the motion by the Lagrange–d'Alembert principle,
    ``δ∫L dt + ∫Q·δq dt = 0``, so ``d/dt ∂L/∂q̇ − ∂L/∂q = Q``.  It is an expression in the coordinates,
    their velocity :func:`velocity` and the time :func:`time`.

    A mass on a spring driven at its resonance:

    >>> import casadi as ca, castrajectory as ct
    >>> x = ca.SX.sym("x", 1)
    >>> osc = ct.LagrangianSystem(x, ct.MassMatrix(1.0), [ct.Potential(0.5 * x[0] ** 2, "spring"),
    ...                                                  ct.Force(ca.cos(ct.time()), "drive")])
    >>> float(osc.acceleration([0.5], [0.0], 0.0))        # -x + cos(0)
    0.5
    """

    expr: object
    name: str = "force"

    def force(self, system: "LagrangianSystem"):
        Q = ca.SX(self.expr)
        if Q.size2() != 1:  # a row (or a matrix) is not a generalised force; vec() would read it silently
            raise InputError(f"the force {self.name!r} is a {Q.size1()}x{Q.size2()} matrix: a generalised force is "
                             f"a column, one entry per coordinate (ca.vertcat(...))")
        return Q


@dataclass
class Dissipation:
    """A Rayleigh dissipation function ``R(q, q̇, t)``: the force ``Q = −∂R/∂q̇`` (written in the
    velocity symbol :func:`velocity`); ``R ≥ 0`` and convex in ``q̇`` dissipates energy at the rate
    ``q̇·∂R/∂q̇`` (``2R`` when ``R`` is quadratic in ``q̇``).

    Air drag ``R = c|v|³/3`` (the force ``−c|v|v``) on a falling ball:

    >>> import casadi as ca, castrajectory as ct
    >>> y = ca.SX.sym("y", 1)
    >>> v = ct.velocity(y)
    >>> ball = ct.LagrangianSystem(y, ct.MassMatrix(1.0), [ct.Potential(9.81 * y[0], "gravity"),
    ...                                                   ct.Dissipation(0.1 * ca.fabs(v[0]) ** 3 / 3)])
    >>> round(float(ball.acceleration([0.0], [-10.0], 0.0)), 12)     # -9.81 + 0.1·10²
    0.19
    """

    R: object
    name: str = "dissipation"

    def force(self, system: "LagrangianSystem"):
        return -ca.gradient(ca.SX(self.R), system.qd)


@dataclass
class Damping:
    """Linear damping, the Rayleigh function ``R = ½ q̇ᵀ C q̇`` (``c`` a number, a number per coordinate
    or a symmetric positive semi-definite matrix): the force ``Q = −C q̇``.

    >>> import casadi as ca, castrajectory as ct
    >>> x = ca.SX.sym("x", 1)
    >>> damped = ct.LagrangianSystem(x, ct.MassMatrix(1.0), [ct.Potential(0.5 * x[0] ** 2), ct.Damping(0.2)])
    >>> float(damped.acceleration([0.0], [1.0], 0.0))      # -0.2·1
    -0.2
    """

    c: object
    name: str = "damping"

    def __post_init__(self):
        C = np.atleast_1d(np.asarray(self.c, dtype=float))
        if not np.all(np.isfinite(C)):
            raise InputError(f"damping must be finite (got {self.c!r})")
        if C.ndim == 1:
            if np.any(C < 0):
                raise InputError(f"damping must not be negative (got {self.c!r}): a negative damping feeds energy in")
        else:
            if C.ndim != 2 or C.shape[0] != C.shape[1] or not np.allclose(C, C.T):
                raise InputError("a damping matrix must be square and symmetric")
            if np.min(np.linalg.eigvalsh(C)) < -1e-12 * max(1.0, np.max(np.abs(C))):
                raise InputError("a damping matrix must be positive semi-definite (a negative eigenvalue feeds "
                                 "energy in)")
        self.matrix = C

    def force(self, system: "LagrangianSystem"):
        n, C = system.nq, self.matrix
        if C.ndim == 1:
            if C.size not in (1, n):
                raise InputError(f"damping needs 1 or {n} coefficients or an {n}x{n} matrix (got {C.size})")
            return -ca.DM(np.broadcast_to(C, (n,)).copy()) * system.qd
        if C.shape != (n, n):
            raise InputError(f"a damping matrix for {n} coordinates must be {n}x{n} (got {C.shape[0]}x{C.shape[1]})")
        return -ca.mtimes(ca.DM(C), system.qd)


# ----------------------------------------------------------------------------- the system
#: :meth:`LagrangianSystem.index1_values` solves the index-1 equations numerically from this many unknowns
#: (coordinates and multipliers) up; below, the compiled symbolic solution is used.
SYMBOLIC_INDEX1 = 24


class _Timed(ca.Function):
    """A CasADi function whose last input is the time.  ``optional``: a call may leave the time out
    (a time-independent system's functions, which do not depend on it); otherwise it must be given,
    so no caller evaluates a moving system at a silent ``t = 0``."""

    def __init__(self, fn: ca.Function, optional: bool):
        super().__init__(fn)
        self._optional = optional

    def __call__(self, *args, **kw):
        if not kw and len(args) == self.n_in() - 1:
            if not self._optional:
                raise TypeError(f"{self.name()} depends on the time: pass t as its last argument")
            args = args + (0.0,)
        return super().__call__(*args, **kw)


def _symbol_names(q: ca.SX) -> List[str]:
    """The coordinates' default names: their symbols' (``theta_0, theta_1`` for ``SX.sym("theta", 2)``),
    or ``q[0], q[1], …`` where two symbols share a name -- never ``q0``, which a system file uses for its
    initial coordinates."""
    names = [q[i].name() for i in range(q.numel())]
    return names if len(set(names)) == len(names) else [f"q[{i}]" for i in range(q.numel())]


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
    quantities: optional ``{name: expression}`` of quantities of the user's own (scalar SX expressions of
        the coordinates, their velocities ``ct.velocity(q)`` and the time), e.g. an angular momentum in
        Cartesian coordinates: their values at every node are reported (:meth:`quantity_values`, the
        JSON, the plot) and the derivation says which of them the discrete solution conserves.
    """

    q: object
    kinetic: object
    potentials: Sequence[object] = ()
    constraints: Sequence[object] = ()
    names: Optional[Sequence[str]] = None
    points_expr: Optional[Sequence[object]] = None
    contact: Optional[Contact] = None
    quantities: Optional[Dict[str, object]] = None
    _fn: dict = field(default_factory=dict, init=False, repr=False)

    def __post_init__(self):
        if not isinstance(self.q, ca.SX) or not self.q.is_column() or not self.q.is_valid_input():
            raise ValueError("q must be a column of SX symbols")
        self.qd = velocity(self.q)
        self.t = _TIME
        if self.names is not None and len(list(self.names)) != self.nq:
            raise InputError(f"names has {len(list(self.names))} entries, the system has {self.nq} coordinates")
        self.names = [str(n) for n in self.names] if self.names else _symbol_names(self.q)
        if self.points_expr is None and isinstance(self.kinetic, Atoms):
            self.points_expr = list(self.kinetic.positions)
        self.potentials = list(self.potentials)
        #: the non-conservative force terms (those with a ``force`` method), and the potential terms
        self.force_terms = [term for term in self.potentials if hasattr(term, "force")]
        self.potential_terms = [term for term in self.potentials if not hasattr(term, "force")]
        self._check_symbols()

    def _check_symbols(self) -> None:
        """Every expression may hold the coordinates and the time; the kinetic energy and the forces also
        the velocities.  Anything else is refused here, by name (it made a CasADi traceback in the solve)."""
        from .control import is_control_symbol
        allowed = {e.element_hash() for e in ca.symvar(ca.vertcat(self.q, self.qd, self.t))}
        qd = {e.element_hash() for e in ca.symvar(self.qd)}

        def check(expr, what, rates=False, controls=False):
            for v in ca.symvar(ca.SX(expr)):
                hsh = v.element_hash()
                if hsh in qd and not rates:
                    raise InputError(f"{what} depends on the velocity {v}: a velocity-dependent force is a "
                                     "ct.Force or ct.Dissipation term")
                if controls and is_control_symbol(v):
                    continue
                if hsh not in allowed:
                    if is_control_symbol(v):
                        raise InputError(f"{what} depends on the control {v}: controls enter through forces "
                                         "(ct.Force)")
                    raise InputError(f"{what} depends on the symbol {v}, which is neither a coordinate, its "
                                     "velocity (ct.velocity(q)) nor the time (ct.time())")

        check(self.kinetic_expr(), "the kinetic energy", rates=True)
        for term in self.potential_terms:
            check(term.energy(self), f"the potential term {self._term_name(term)!r}")
        for term in self.force_terms:
            Q = term.force(self)
            if Q.numel() != self.nq:
                raise InputError(f"the force {self._term_name(term)!r} has {Q.numel()} entries; it needs one per "
                                 f"coordinate ({self.nq})")
            check(Q, f"the force {self._term_name(term)!r}", rates=True, controls=True)
        for k, c in enumerate(self.constraints):
            check(c, f"constraint {k}")
        if self.contact is not None:
            self.contact.validate(self.q, self.qd, self.t, check)
        if self.points_expr:
            for k, pnt in enumerate(self.points_expr):
                check(pnt, f"plotted point {k}")
        if self.quantities is not None:
            if not isinstance(self.quantities, dict):
                raise InputError("quantities must be a dict {name: expression}")
            for name, expr in self.quantities.items():
                e = ca.SX(expr)
                if e.numel() != 1:
                    raise InputError(f"the quantity {name!r} must be a scalar expression (it has {e.numel()} entries)")
                check(e, f"the quantity {name!r}", rates=True)
            self.quantities = {str(k): ca.SX(v) for k, v in self.quantities.items()}

    @staticmethod
    def _term_name(term) -> str:
        return getattr(term, "name", type(term).__name__)

    @property
    def time_dependent(self) -> bool:
        """Does the Lagrangian, a constraint or a force hold the time?"""
        def key():
            exprs = [self.lagrangian_expr(), self.constraint_expr()] + [term.force(self) for term in self.force_terms]
            return any(ca.depends_on(ca.SX(e), self.t) for e in exprs if ca.SX(e).numel())
        return self._get("time_dependent", key)

    @property
    def moving_constraints(self) -> bool:
        """Does a holonomic constraint hold the time (its reaction then does work)?"""
        return bool(self.nc) and bool(ca.depends_on(self.constraint_expr(), self.t))

    @property
    def forced(self) -> bool:
        """Does the system hold non-conservative forces?"""
        return bool(self.force_terms)

    @property
    def controls(self) -> list:
        """The :class:`~castrajectory.models.control.Control` inputs in the forces, in creation order."""
        from .control import controls_in
        return self._get("controls", lambda: controls_in(self.force_expr()) if self.forced else [])

    @property
    def control_vector(self) -> ca.SX:
        """All control entries as one column (empty without controls)."""
        cs = self.controls
        return ca.vertcat(*[ca.SX(c) for c in cs]) if cs else ca.SX(0, 1)

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
        for t in self.potential_terms:
            out.append({"Gravity": "gravity", "Spring": "spring"}.get(type(t).__name__, getattr(t, "name", "potential")))
        for t in self.force_terms:
            out.append(f"force: {self._term_name(t)}")
        if self.time_dependent:
            out.append("time-dependent")
        if self.nc:
            out.append(f"{self.nc} holonomic constraint{'s' if self.nc > 1 else ''}")
        if self.contact is not None:
            out.append(self.contact.describe())
        return out

    # -- symbolic pieces (expressions in self.q, self.qd)
    def kinetic_expr(self):
        return self._get("K_expr", lambda: self.kinetic.energy(self.q, self.qd))

    def potential_expr(self):
        def build():
            U = ca.SX(0)
            for term in self.potential_terms:
                U += term.energy(self)
            return U
        return self._get("U_expr", build)

    def force_expr(self):
        """The sum of the non-conservative forces ``Q(q, q̇, t)`` (zeros without force terms)."""
        def build():
            Q = ca.SX.zeros(self.nq)
            for term in self.force_terms:
                Q += term.force(self)
            return Q
        return self._get("Q_expr", build)

    def lagrangian_expr(self):
        return self._get("L_expr", lambda: self.kinetic_expr() - self.potential_expr())

    def constraint_expr(self):
        return ca.vertcat(*[ca.vec(c) for c in self.constraints]) if self.constraints else ca.SX(0, 1)

    # -- numerical functions (built once)
    def derived(self, key, build):
        """The object derived from this system under ``key``, built by ``build()`` on first use and kept with the
        system (its functions, and what the layers above derive from it once, as the contact elements of a
        scheme): it lives and dies with the system, and nothing is keyed by the system's ``id``."""
        if key not in self._fn:
            self._fn[key] = build()
        return self._fn[key]

    _get = derived

    # Every function below takes the time as its last input; a time-independent system's may be called
    # without it (see _Timed), a time-dependent system's may not.
    def _timed(self, fn: ca.Function) -> ca.Function:
        return _Timed(fn, optional=not self.time_dependent)

    @property
    def L(self) -> ca.Function:
        """``L(q, q̇, t)``."""
        return self._get("L", lambda: self._timed(ca.Function("L", [self.q, self.qd, self.t], [self.lagrangian_expr()])))

    def energy_expr(self):
        """The energy function ``E = q̇·∂L/∂q̇ − L`` (Jacobi's integral: ``K + U`` for a kinetic energy that is
        a quadratic form in the rates, which every time-independent system here has).  It is conserved
        when ``L`` does not hold the time and no force acts; otherwise ``dE/dt = Q·q̇ − ∂L/∂t``."""
        if not self.time_dependent:
            return self.kinetic_expr() + self.potential_expr()
        L = self.lagrangian_expr()
        return ca.dot(self.qd, ca.gradient(L, self.qd)) - L

    @property
    def energy(self) -> ca.Function:
        """The energy function ``E(q, q̇, t)`` (:meth:`energy_expr`)."""
        return self._get("E", lambda: self._timed(ca.Function("E", [self.q, self.qd, self.t], [self.energy_expr()])))

    @property
    def power(self) -> ca.Function:
        """``(q, q̇, t) ↦ (Q·q̇, −∂L/∂t + λ·∂c/∂t)``: the power of the forces and of the time dependence,
        whose integral is the change of the energy function (:meth:`energy_expr`).  The second part holds
        the power of a moving constraint's reaction, ``−λ·C q̇ = λ·∂c/∂t`` with the multipliers of the
        index-1 equations (:attr:`multiplier`), when a constraint holds the time."""
        def build():
            L = self.lagrangian_expr()
            timed = -ca.jacobian(L, self.t)
            if self.moving_constraints:
                lam = self._index1_exprs()[1]
                timed = timed + ca.dot(lam, ca.jacobian(self.constraint_expr(), self.t))
            return self._timed(ca.Function("power", [self.q, self.qd, self.t],
                                           [ca.dot(self.force_expr(), self.qd), timed]))
        return self._get("power", build)

    @property
    def potential(self) -> ca.Function:
        return self._get("U", lambda: self._timed(ca.Function("U", [self.q, self.t], [self.potential_expr()])))

    @property
    def force(self) -> ca.Function:
        """The non-conservative force ``Q(q, q̇, t)``."""
        if self.controls:  # a controlled system's force takes the controls after the time: Q(q, q̇, t, u)
            return self.actuated_force
        return self._get("Q", lambda: self._timed(ca.Function("Q", [self.q, self.qd, self.t], [self.force_expr()])))

    @property
    def actuated_force(self) -> ca.Function:
        """``Q(q, q̇, t, u)`` with the controls ``u`` an input whether or not the system has any (an empty column
        without controls, an unread ``t`` without time): the one signature the discrete elements call."""
        return self._get("Qu", lambda: ca.Function("Q", [self.q, self.qd, self.t, self.control_vector],
                                                   [self.force_expr()]))

    @property
    def mass_matrix(self) -> ca.Function:
        """``M(q, t) = ∂²K/∂q̇²``."""
        return self._get("M", lambda: self._timed(ca.Function(
            "M", [self.q, self.t], [ca.densify(ca.hessian(self.kinetic_expr(), self.qd)[0])])))

    @property
    def momentum(self) -> ca.Function:
        """Continuous Legendre transform ``p = ∂L/∂q̇ (q, q̇, t)``."""
        return self._get("p", lambda: self._timed(ca.Function(
            "p", [self.q, self.qd, self.t], [ca.gradient(self.lagrangian_expr(), self.qd)])))

    @property
    def constraint(self) -> ca.Function:
        """``c(q, t)`` and its Jacobian ``C(q, t) = ∂c/∂q``."""
        c = self.constraint_expr()
        return self._get("c", lambda: self._timed(ca.Function("c", [self.q, self.t],
                                                              [c, ca.densify(ca.jacobian(c, self.q))])))

    @property
    def constraint_rate(self) -> ca.Function:
        """``∂c/∂t (q, t)``: the constraint's own motion (zeros for a fixed constraint), so that an admissible
        velocity has ``C q̇ + ∂c/∂t = 0``."""
        c = self.constraint_expr()
        return self._get("ct", lambda: self._timed(ca.Function("c_t", [self.q, self.t],
                                                                [ca.densify(ca.jacobian(c, self.t))])))

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
    def tangent(self) -> ca.Function:
        """The slip Jacobian ``D(q)`` (contacts × coordinates), ``slip = D(q) q̇`` (a :class:`Contact` with
        friction; rows of zeros for a contact without a slip expression)."""
        if self.contact is None:
            raise ValueError("this system has no contact term")

        def build():
            return ca.Function("tangent", [self.q], [self.contact.slip_jacobian(self.qd)])
        return self._get("tangent", build)

    @property
    def acceleration(self) -> ca.Function:
        """Euler–Lagrange right-hand side ``q̈(q, q̇, t)``.

        Unconstrained: ``M q̈ = ∂L/∂q − (∂²L/∂q̇∂q) q̇ − ∂²L/∂q̇∂t + Q``.  With holonomic
        constraints the index-1 system ``[M Cᵀ; C 0] [q̈; λ] = [f; γ]`` is solved, ``γ`` the part of
        ``c̈`` without ``q̈`` (used by the time-stepping baselines and the integrated guesses).
        """
        return self._get("index1", self._index1)[0]

    @property
    def multiplier(self) -> ca.Function:
        """The constraint multipliers ``λ(q, q̇, t)`` of the index-1 system (``M q̈ + Cᵀλ = f``): the
        same sign and scale as the discrete multipliers of the trajectory NLP.  Empty without constraints."""
        return self._get("index1", self._index1)[1]

    def dynamics_exprs(self):
        """``(M, f)`` as expressions of ``(q, q̇, t)`` and the controls: the Euler–Lagrange equations
        ``M q̈ = f`` without the constraints' forces, ``f = ∂L/∂q − (∂²L/∂q̇∂q) q̇ − ∂²L/∂q̇∂t + Q``."""
        def build():
            L = self.lagrangian_expr()
            dLdqd = ca.gradient(L, self.qd)
            M = ca.hessian(L, self.qd)[0]
            f = ca.gradient(L, self.q) - ca.mtimes(ca.jacobian(dLdqd, self.q), self.qd)
            if self.time_dependent:
                f = f - ca.jacobian(dLdqd, self.t)
            if self.force_terms:
                f = f + self.force_expr()
            return M, f
        return self._get("dynamics_expr", build)

    def _index1_matrix_exprs(self):
        """The index-1 system's matrix and right-hand side, ``[M Cᵀ; C 0]`` and ``[f; γ]`` (``M`` and ``f``
        without constraints), as expressions of ``(q, q̇, t)``."""
        def build():
            M, f = self.dynamics_exprs()
            if not self.nc:
                return M, f
            c = self.constraint_expr()
            C = ca.jacobian(c, self.q)
            cdot = ca.mtimes(C, self.qd)
            if ca.depends_on(c, self.t):
                cdot = cdot + ca.jacobian(c, self.t)
            gamma = -ca.mtimes(ca.jacobian(cdot, self.q), self.qd)
            if ca.depends_on(cdot, self.t):
                gamma = gamma - ca.jacobian(cdot, self.t)
            return ca.blockcat([[M, C.T], [C, ca.SX(self.nc, self.nc)]]), ca.vertcat(f, gamma)
        return self._get("index1_matrix_expr", build)

    @property
    def index1_system(self) -> ca.Function:
        """``(q, q̇, t) ↦ (K, b)``: the index-1 equations ``K (q̈, λ) = b`` (:meth:`acceleration`) before they are
        solved, ``K`` sparse: for a numerical sparse solve where the symbolic one grows as the cube of the
        unknowns (a chain of many bodies)."""
        return self._get("index1_system", lambda: ca.Function(
            "index1_system", [self.q, self.qd, self.t], list(self._index1_matrix_exprs())))

    def index1_values(self, q, qd, t=0.0) -> Tuple[np.ndarray, np.ndarray]:
        """``(q̈, λ)`` of the index-1 equations at one state, as numbers: from the compiled symbolic solution
        (:attr:`acceleration`, :attr:`multiplier`) where the equations have fewer than :data:`SYMBOLIC_INDEX1`
        unknowns, otherwise from :attr:`index1_system` and a numerical solve (the symbolic solution of a chain's
        equations grows as the cube of its unknowns: 1.6 s to build for 32 rods in maximal coordinates)."""
        if self.nq + self.nc < SYMBOLIC_INDEX1:
            return (np.asarray(self.acceleration(q, qd, t), float).reshape(-1),
                    np.asarray(self.multiplier(q, qd, t), float).reshape(-1) if self.nc else np.zeros(0))
        K, b = self.index1_system(q, qd, t)
        with np.errstate(all="ignore"):
            x = np.linalg.solve(np.asarray(K, float), np.asarray(b, float).reshape(-1))
        return x[:self.nq], x[self.nq:]

    def _index1_exprs(self):
        """The index-1 system's ``(q̈, λ)`` as expressions of ``(q, q̇, t)``."""
        def build():
            K, b = self._index1_matrix_exprs()
            sol = ca.solve(K, b)
            return sol[:self.nq], sol[self.nq:]
        return self._get("index1_expr", build)

    def _index1(self):
        qdd, lam = self._index1_exprs()
        return (self._timed(ca.Function("qdd", [self.q, self.qd, self.t], [qdd])),
                self._timed(ca.Function("lam", [self.q, self.qd, self.t], [lam])))

    @property
    def points(self) -> Optional[ca.Function]:
        """Positions of the plotted points (atoms by default) as a function of q, stacked as rows."""
        if not self.points_expr:
            return None
        return self._get("pts", lambda: self._timed(ca.Function(
            "pts", [self.q, self.t], [ca.horzcat(*[ca.vec(p) for p in self.points_expr]).T])))

    def positions(self, q: np.ndarray, t=0.0) -> np.ndarray:
        """Point positions for each row of ``q`` (at the times ``t``: a number or one per row): array of
        shape (len(q), n_points, dim)."""
        fn = self.points
        if fn is None:
            raise ValueError("this system has no points to show")
        q = np.atleast_2d(q)
        F = fn.map(q.shape[0])
        out = np.asarray(F(q.T, np.broadcast_to(np.asarray(t, float), (q.shape[0],)).reshape(1, -1)))  # (n_points, len(q) * dim), one dim-block per row of q
        npts = len(self.points_expr)
        return out.reshape(npts, q.shape[0], -1).transpose(1, 0, 2)

    def quantity_values(self, q: np.ndarray, qd: np.ndarray, t=0.0) -> Dict[str, np.ndarray]:
        """The declared :attr:`quantities` at the states ``(q, q̇)`` (one row per node) and times ``t``."""
        if not self.quantities:
            return {}
        q = np.atleast_2d(np.asarray(q, float))
        qd = np.atleast_2d(np.asarray(qd, float))
        tt = np.broadcast_to(np.asarray(t, float), (q.shape[0],))
        fn = self._get("quantities_fn", lambda: ca.Function(
            "quantities", [self.q, self.qd, self.t], [ca.vertcat(*self.quantities.values())]))
        vals = np.asarray(fn.map(q.shape[0])(q.T, qd.T, tt[None, :]), float)
        return {name: vals[i] for i, name in enumerate(self.quantities)}

    def momenta(self, q: np.ndarray, qd: np.ndarray, t=0.0) -> np.ndarray:
        """The momenta ``p = ∂L/∂q̇`` for each row of ``(q, q̇)`` at the times ``t``: one row each."""
        q, qd = np.atleast_2d(np.asarray(q, float)), np.atleast_2d(np.asarray(qd, float))
        t = np.broadcast_to(np.asarray(t, float), (q.shape[0],)).reshape(1, -1)
        return np.asarray(self.momentum.map(q.shape[0])(q.T, qd.T, t), float).T

    def energies(self, q: np.ndarray, qd: np.ndarray, t=0.0) -> np.ndarray:
        """The energy function for each row of ``(q, q̇)`` at the times ``t`` (a number or one per row)."""
        q, qd = np.atleast_2d(q), np.atleast_2d(qd)
        t = np.broadcast_to(np.asarray(t, float), (q.shape[0],)).reshape(1, -1)
        return np.asarray(self.energy.map(q.shape[0])(q.T, qd.T, t)).reshape(-1)
