"""Unilateral contact, a term of a :class:`~castrajectory.models.mechanics.LagrangianSystem`: the gaps
``φ_j(q) ≥ 0``, Newton's restitution, the law of an impact at several contacts at once, and Coulomb
friction along each contact's slip velocity.  How contact is discretised and solved is
:mod:`castrajectory.discretise.contact` and :mod:`castrajectory.solve.contact`; the derivation is
``docs/derivations.md``, "Contact trajectories".
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence

import casadi as ca
import numpy as np

from ..validation import InputError, finite


@dataclass
class Contact:
    """Unilateral contacts: gaps ``φ_j(q) ≥ 0`` (SX expressions of q) with Newton restitution ``e``.

    An impact of contact ``j`` reverses its normal velocity ``∇φ_j q̇`` by the
    factor ``e`` (``e = 1``: elastic, the default); impulses act along
    ``M⁻¹∇φ_jᵀ`` with ``μ_j ≥ 0``.  ``names`` label the contact points in output.  ``law`` says how
    an impact at several contacts at once is resolved (simultaneous or sequential; see the field).
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
    #: how an impact at several contacts at once is resolved: ``"simultaneous"`` (Newton's law at every
    #: contact together, ``J v⁺ + e J v⁻ ≥ 0 ⟂ μ ≥ 0``) or ``"sequential"`` (a cascade of one-contact
    #: impacts, the fastest approach first: the limit of vanishing gaps, the textbook Newton's cradle)
    law: str = "simultaneous"
    #: Coulomb friction coefficients, one number for every contact or one per contact (0: frictionless,
    #: the rows of a frictionless contact exactly)
    friction: object = 0.0
    #: each contact's slip velocity, the tangential velocity of its contact point: an expression linear in
    #: the velocity (``ct.velocity(q)``), needed where the friction is positive: one number per contact in the
    #: plane, or two (the components along two orthonormal tangents, a vector expression) on a tangent plane in
    #: 3-D, where the friction is isotropic (Coulomb's circular cone)
    slip: Optional[Sequence[object]] = None

    def __post_init__(self):
        if self.law not in ("simultaneous", "sequential"):
            raise InputError(f"the impact law must be 'simultaneous' or 'sequential' (got {self.law!r})")
        count = len(self.gaps)
        try:
            fr = np.broadcast_to(np.asarray(self.friction, dtype=float), (count,)).copy()
        except (TypeError, ValueError):
            raise InputError(f"friction must be a number or one number per contact ({count}); got "
                             f"{self.friction!r}") from None
        if not np.all(np.isfinite(fr)) or np.any(fr < 0):
            raise InputError(f"friction coefficients must be finite and >= 0 (got {self.friction!r})")
        self.friction = fr
        if np.any(fr > 0):
            if self.slip is None or len(self.slip) != count:
                raise InputError(f"friction needs each contact's slip velocity: Contact(..., slip=[...]) with "
                                 f"{count} expression{'s' if count > 1 else ''} in the velocity")
            self.slip = [ca.vec(ca.SX(v) if not isinstance(v, ca.SX) else v) for v in self.slip]
            dims = {v.numel() for v in self.slip}
            if len(dims) != 1 or not dims <= {1, 2}:
                raise InputError("a slip velocity is one number per contact (planar friction) or two (the "
                                 "tangent plane in 3-D), the same for every contact")
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

    @property
    def slip_dim(self) -> int:
        """Components of each contact's slip: 1 in the plane, 2 on a tangent plane (1 without friction)."""
        return int(self.slip[0].numel()) if self.slip else 1

    # ------------------------------------------------------------------ used by LagrangianSystem
    def validate(self, q, qd, t, check) -> None:
        """The system's checks of this term: every gap an expression of ``q`` alone (``check``: the system's
        symbol check), every slip velocity linear in ``qd``, ``D(q) q̇``, with no other term and no time."""
        for k, v in enumerate(self.slip or []):
            name = self.names[k]
            check(v, f"the slip velocity of {name!r}", rates=True)
            D = ca.jacobian(v, qd)
            rest = ca.substitute(v, qd, ca.SX.zeros(qd.numel()))
            if ca.depends_on(D, qd) or ca.depends_on(D, t) or not rest.is_zero():
                raise InputError(f"the slip velocity of {name!r} must be linear in the velocity, D(q) q̇ "
                                 "(no other term, no time)")
        for k, g in enumerate(self.gaps):
            check(g, f"the gap of {self.names[k]!r}")
            if not ca.depends_on(g, q):
                raise InputError(f"the gap of {self.names[k]!r} does not depend on the coordinates: a contact whose "
                                 "gap never changes can never act (a body would pass through it)")
            if ca.depends_on(g, t):
                raise InputError(f"the gap of {self.names[k]!r} depends on time: moving obstacles are "
                                 "not supported yet")

    def slip_jacobian(self, qd) -> ca.SX:
        """``D(q)`` (contacts × slip components, contact by contact, × coordinates), ``slip = D(q) q̇``; rows of
        zeros without slip expressions."""
        rows = [ca.jacobian(v, qd) for v in self.slip] if self.slip else [ca.SX(1, qd.numel()) for _ in self.gaps]
        return ca.densify(ca.vertcat(*rows))

    def describe(self) -> str:
        """One line for the report's table of what a scene carries."""
        fr = self.friction
        friction = "" if not np.any(fr > 0) else (f", μ = {fr[0]:g}" if np.all(fr == fr[0]) else
                                                    ", μ = " + "/".join(f"{x:g}" for x in fr))
        return f"contact: {self.count} gap{'s' if self.count > 1 else ''}, e = {self.restitution:g}{friction}"
