"""Rigid bodies in 3-D: orientation as a unit quaternion, the inertia, the free body and the heavy top.

Representation
--------------
The orientation is a quaternion ``q = (w, x, y, z)`` with the holonomic constraint
``(qᵀq − 1)/2 = 0``, and the body-to-space rotation is the *quadratic* map

    R(q) v = q ⊗ v ⊗ q̄,      R(q) = |q|² × (the rotation by q/|q|),

so every configuration space of the package (flat coordinates plus holonomic constraints)
carries it unchanged: atoms ``x_a = R(q) d_a + c`` and gravity, springs and potentials on
body points are ordinary expressions of ``q``, and the midpoint, trapezoid and galerkin4
discrete Lagrangians apply as they are, the constraint rows keeping ``|q| = 1`` at every
node (and galerkin4 stage) to solver tolerance.  ``R`` is a group homomorphism,
``R(p ⊗ q) = R(p) R(q)``, and left and right multiplication by a unit quaternion are linear
isometries of ℝ⁴: a rotation-invariant Lagrangian gives a rotation-invariant discrete
Lagrangian for every scheme, and the discrete Noether theorem conserves the matching
momentum exactly (``docs/derivations.md``, "Rigid bodies in 3-D").

Kinetic energy from an inertia
------------------------------
With principal moments ``I = (I₁, I₂, I₃)`` about the reference point and second moments
``J_i = ∫ d_i² dm = (I_j + I_k − I_i)/2`` (≥ 0 exactly when the triangle inequality holds),

    K_rot = ½ Σ_i J_i |Ṙ(q) e_i|²        (= ½ ωᵀ I ω on |q| = 1),

the atoms' formula ``Σ ½ m_a |ẋ_a|²`` summed over the body.  Off the sphere ``|q| = 1`` this
quadratic form stays positive definite (a radial velocity scales ``R``), so the mass matrix
in ℝ⁴ is regular and the constraint removes the radial direction.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence

import casadi as ca
import numpy as np

from ..validation import InputError, finite, positive
from .mechanics import Contact, Gravity, LagrangianSystem


# ----------------------------------------------------------------------------- quaternion algebra
def quat_multiply(p, q):
    """Hamilton product ``p ⊗ q`` of quaternions ``(w, x, y, z)`` (CasADi or numpy, last axis 4)."""
    if isinstance(p, (ca.SX, ca.MX, ca.DM)) or isinstance(q, (ca.SX, ca.MX, ca.DM)):
        pw, pv, qw, qv = p[0], p[1:4], q[0], q[1:4]
        return ca.vertcat(pw * qw - ca.dot(pv, qv), pw * qv + qw * pv + ca.cross(pv, qv))
    p, q = np.asarray(p, float), np.asarray(q, float)
    pw, pv, qw, qv = p[..., :1], p[..., 1:], q[..., :1], q[..., 1:]
    return np.concatenate([pw * qw - np.sum(pv * qv, axis=-1, keepdims=True),
                           pw * qv + qw * pv + np.cross(pv, qv)], axis=-1)


def quat_conjugate(q):
    """``q̄ = (w, −x, −y, −z)``."""
    if isinstance(q, (ca.SX, ca.MX, ca.DM)):
        return ca.vertcat(q[0], -q[1:4])
    q = np.asarray(q, float)
    return np.concatenate([q[..., :1], -q[..., 1:]], axis=-1)


def rotation(q):
    """The quadratic rotation map ``R(q)`` (3 × 3), ``R(q) v = q ⊗ v ⊗ q̄``; CasADi or numpy (…, 4).
    For a unit quaternion it is the rotation matrix from body to world axes.

    >>> import numpy as np, castrajectory as ct
    >>> R = ct.rotation(ct.models.rigidbody.axis_angle([0, 0, 1], np.pi / 2))
    >>> np.round(R @ [1.0, 0.0, 0.0], 12).tolist()
    [0.0, 1.0, 0.0]
    """
    sym = isinstance(q, (ca.SX, ca.MX, ca.DM))
    w, x, y, z = (q[0], q[1], q[2], q[3]) if sym else np.moveaxis(np.asarray(q, float), -1, 0)
    rows = [[w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z]]
    if sym:
        return ca.vertcat(*[ca.horzcat(*r) for r in rows])
    return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)


def body_point(quat, point: Sequence[float], origin=None):
    """World position ``origin + R(quat) point`` of a point fixed in a body (``point`` in body axes from the
    body's reference point ``origin``, the world origin by default); CasADi expressions or numpy rows.

    The centre of mass of a top pivoted at the origin, 0.3 along its symmetry axis, tilted 90° about x:

    >>> import numpy as np, castrajectory as ct
    >>> quat = ct.models.rigidbody.axis_angle([1, 0, 0], np.pi / 2)
    >>> np.round(ct.body_point(quat, [0.0, 0.0, 0.3]), 12).tolist()
    [0.0, -0.3, 0.0]
    """
    R = rotation(quat)
    if isinstance(R, (ca.SX, ca.MX, ca.DM)):
        x = ca.mtimes(R, ca.DM(np.asarray(point, float)) if not isinstance(point, (ca.SX, ca.MX, ca.DM)) else point)
        return x if origin is None else origin + x
    x = R @ np.asarray(point, float)
    return x if origin is None else np.asarray(origin, float) + x


def angular_velocity(quat: np.ndarray, quat_rate: np.ndarray, frame: str = "body") -> np.ndarray:
    """Angular velocity of a body from its orientation quaternions and their rates (rows, e.g. a run's
    ``q`` and ``v`` columns of the quaternion, or CasADi expressions such as ``ct.velocity(quat)`` for a
    declared quantity): ``ω = 2 Im(q̄ ⊗ q̇)`` in body axes, or ``R ω`` in space (``frame="space"``).

    >>> import numpy as np, castrajectory as ct
    >>> q = np.array([1.0, 0.0, 0.0, 0.0])
    >>> ct.angular_velocity(q, ct.quaternion_rate(q, [0.0, 0.0, 2.0])).tolist()
    [0.0, 0.0, 2.0]
    """
    if frame not in ("body", "space"):
        raise InputError(f"frame must be 'body' or 'space' (got {frame!r})")
    if isinstance(quat, (ca.SX, ca.MX)) or isinstance(quat_rate, (ca.SX, ca.MX)):  # an expression (a quantity)
        w = 2.0 * quat_multiply(quat_conjugate(quat), quat_rate)[1:4]
        return w if frame == "body" else ca.mtimes(rotation(quat), w)
    w = body_rates(np.asarray(quat, float), np.asarray(quat_rate, float))
    return w if frame == "body" else np.einsum("...ij,...j->...i", rotation(quat), w)


def angular_momentum(quat: np.ndarray, quat_momentum: np.ndarray, frame: str = "space") -> np.ndarray:
    """Angular momentum of a body from its quaternions and their conjugate momenta ``p = ∂L/∂q̇`` (rows,
    e.g. a run's ``q`` and ``p`` columns of the quaternion): the momentum map of spatial rotations
    (``frame="space"``, conserved by a free body, exactly by the discrete solution) or of body rotations
    (``"body"``).  A radial momentum (the unit-norm constraint's force) contributes nothing.

    >>> import numpy as np, casadi as ca, castrajectory as ct
    >>> quat = ca.SX.sym("q", 4)
    >>> body = ct.LagrangianSystem(quat, ct.RigidBody(quat, ct.Inertia(1.0, 2.0, 3.0)), constraints=[ct.unit_norm(quat)])
    >>> q0 = np.array([1.0, 0, 0, 0])
    >>> run = ct.simulate(body, q0, ct.quaternion_rate(q0, [0.1, 1.0, 0.1]), T=5.0, N=500, scheme="galerkin4")
    >>> L = ct.angular_momentum(run.q, run.p)
    >>> np.round(L[0], 12).tolist(), bool(np.max(np.abs(L - L[0])) < 1e-11)
    ([0.1, 2.0, 0.3], True)
    """
    if frame not in ("body", "space"):
        raise InputError(f"frame must be 'body' or 'space' (got {frame!r})")
    out = (spatial_momentum if frame == "space" else body_momentum)(np.asarray(quat, float), np.asarray(quat_momentum, float))
    return out if np.ndim(quat) > 1 else out.reshape(3)


def axis_angle(axis: Sequence[float], angle: float) -> np.ndarray:
    """The unit quaternion of a rotation by ``angle`` about ``axis``."""
    a = np.asarray(axis, float)
    a = a / np.linalg.norm(a)
    return np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * a])


def body_rates(q: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """Body angular velocity ``ω = 2 Im(q̄ ⊗ q̇)`` for rows of unit quaternions and their rates."""
    return 2.0 * quat_multiply(quat_conjugate(q), qd)[..., 1:]


def tilt_precession(q: np.ndarray):
    """Tilt (nutation) ``θ = arccos a_z`` and unwrapped precession ``φ = atan2(a_x, −a_y)`` of the body
    axis ``a = R(q) e₃ = (sin φ sin θ, −cos φ sin θ, cos θ)`` (z–x–z Euler angles), for rows of ``q``."""
    a = rotation(q)[..., :, 2]
    return np.arccos(np.clip(a[..., 2], -1.0, 1.0)), np.unwrap(np.arctan2(a[..., 0], -a[..., 1]))


def quaternion_rate(q: np.ndarray, omega_body: np.ndarray) -> np.ndarray:
    """``q̇ = ½ q ⊗ (0, ω)`` for a body angular velocity ``ω``: the initial velocity of a quaternion body.

    >>> import castrajectory as ct
    >>> ct.quaternion_rate([1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 2.0]).tolist()
    [0.0, 0.0, 0.0, 1.0]
    """
    q = np.asarray(q, float)
    w = np.concatenate([np.zeros(q.shape[:-1] + (1,)), np.asarray(omega_body, float)], axis=-1)
    return 0.5 * quat_multiply(q, w)


def _momentum_map(q, p, side: str) -> np.ndarray:
    """``J_i = pᵀ(½ ê_i ⊗ q)`` (``side = "left"``: spatial rotations) or ``pᵀ(½ q ⊗ ê_i)`` ("right": body)."""
    q, p = np.atleast_2d(q), np.atleast_2d(p)
    out = np.empty(q.shape[:-1] + (3,))
    for i in range(3):
        xi = np.zeros(4)
        xi[i + 1] = 1.0
        gen = quat_multiply(xi, q) if side == "left" else quat_multiply(q, xi)
        out[..., i] = 0.5 * np.sum(p * gen, axis=-1)
    return out


def spatial_momentum(q: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Spatial angular momentum from quaternion momenta: the momentum map of ``q ↦ u ⊗ q``.

    The generator of a spatial rotation ``ξ`` is ``δq = ½ ξ̂ ⊗ q``, so ``L·ξ = pᵀ(½ ξ̂ ⊗ q)``.
    A radial momentum (the constraint force ``λ q``) contributes nothing.
    """
    return _momentum_map(q, p, "left")


def body_momentum(q: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Body angular momentum ``Π = pᵀ(½ q ⊗ ê_i)``: the momentum map of ``q ↦ q ⊗ u`` (body rotations)."""
    return _momentum_map(q, p, "right")


# ----------------------------------------------------------------------------- inertia
@dataclass(frozen=True)
class Inertia:
    """Principal moments of inertia ``(I₁, I₂, I₃)`` about the body's reference point, checked once.

    Refused: a non-finite or non-positive moment, and a moment larger than the sum of the
    other two (the triangle inequality ``I_i ≤ I_j + I_k``: a real mass distribution has
    non-negative second moments ``J_i = (I_j + I_k − I_i)/2``).

    >>> import castrajectory as ct
    >>> ct.Inertia.box(1.0, 2.0, 3.0, mass=12.0).moments.tolist()
    [13.0, 10.0, 5.0]
    """

    I1: float
    I2: float
    I3: float

    def __post_init__(self):
        for name in ("I1", "I2", "I3"):
            object.__setattr__(self, name, positive(f"inertia {name}", getattr(self, name)))
        m = self.moments
        for i in range(3):
            j, k = (i + 1) % 3, (i + 2) % 3
            if m[j] + m[k] < m[i] * (1.0 - 1e-12):
                raise InputError(f"inertia I{j + 1} + I{k + 1} < I{i + 1} ({m[j]:g} + {m[k]:g} < {m[i]:g}): "
                                 f"no mass distribution has these moments (triangle inequality)")

    @classmethod
    def box(cls, width: float, height: float, depth: float, mass: float) -> "Inertia":
        """Uniform box with edges ``width``, ``height``, ``depth`` along the body axes x, y, z."""
        w, h, d = positive("box width", width), positive("box height", height), positive("box depth", depth)
        m = positive("mass", mass)
        return cls(m * (h * h + d * d) / 12.0, m * (w * w + d * d) / 12.0, m * (w * w + h * h) / 12.0)

    @property
    def moments(self) -> np.ndarray:
        return np.array([self.I1, self.I2, self.I3])

    @property
    def second_moments(self) -> np.ndarray:
        """``J_i = ∫ d_i² dm = (I_j + I_k − I_i)/2`` (non-negative by the triangle inequality)."""
        m = self.moments
        return np.maximum(0.5 * (m.sum() - 2.0 * m), 0.0)

    def about(self, mass: float, offset: Sequence[float]) -> "Inertia":
        """The moments about a pivot at ``offset`` (body axes) from the centre of mass, for a body of ``mass``
        whose moments these are about its centre of mass (Steiner: ``I_i + m(|d|² − d_i²)``).  The pivot
        must lie on a principal axis through the centre of mass (otherwise the axes change, and products
        of inertia appear that principal moments cannot hold): refused, with a message, elsewhere.

        A top of mass 2 pivoted 0.5 below its centre of mass on its symmetry axis:

        >>> import castrajectory as ct
        >>> ct.Inertia(0.1, 0.1, 0.05).about(2.0, [0.0, 0.0, 0.5]).moments.tolist()
        [0.6, 0.6, 0.05]
        """
        m = positive("mass", mass)
        try:
            d = np.asarray(offset, float).reshape(3)
        except (TypeError, ValueError):
            raise InputError(f"offset must be 3 numbers (got {offset!r})") from None
        if not np.all(np.isfinite(d)):
            raise InputError(f"offset must be finite (got {d.tolist()})")
        if np.count_nonzero(d) > 1:
            raise InputError(f"the pivot offset {d.tolist()} is not on a principal axis: the products of inertia "
                             "it brings change the principal axes; give the offset along one body axis")
        return Inertia(*(self.moments + m * (float(d @ d) - d * d)))

    def shifted(self, mass: float, offset: Sequence[float]) -> "Inertia":
        """:meth:`about` (its earlier name)."""
        return self.about(mass, offset)


# ----------------------------------------------------------------------------- the kinetic term
@dataclass
class RigidBody:
    """Kinetic energy of a rigid body with orientation quaternion ``quat`` (4 SX symbols of q).

    ``K = ½ Σ_i J_i |Ṙ(quat) e_i|² + ½ mass |ċ|²`` with ``J`` the :attr:`Inertia.second_moments`
    (about the reference point) and, when ``center`` (3 SX expressions of q) and ``mass`` are
    given, the translation of the reference point.  Composes with other kinetic terms in a
    :class:`~castrajectory.models.mechanics.LagrangianSystem` (a list of terms); the quaternion's
    norm is a holonomic constraint (:func:`unit_norm`).  A free body spun about its middle axis flips
    (the Dzhanibekov effect), its spatial angular momentum kept by the discrete Noether theorem:

    >>> import casadi as ca, numpy as np, castrajectory as ct
    >>> from castrajectory.models.rigidbody import quaternion_rate, unit_norm
    >>> q = ca.SX.sym("q", 4)
    >>> body = ct.LagrangianSystem(q, ct.RigidBody(q, ct.Inertia(1.0, 2.0, 3.0)), constraints=[unit_norm(q)])
    >>> q0 = np.array([1.0, 0, 0, 0])
    >>> run = ct.simulate(body, q0, quaternion_rate(q0, [1e-3, 1.0, 1e-3]), T=20.0, N=800)
    >>> run.success, float(np.max(np.abs(np.sum(run.q ** 2, axis=1) - 1))) < 1e-10
    (True, True)
    """

    quat: object
    inertia: Inertia
    center: Optional[object] = None
    mass: Optional[float] = None

    def energy(self, q, qd):
        Rq = rotation(self.quat)
        K = ca.SX(0)
        for i, Ji in enumerate(self.inertia.second_moments):
            if Ji > 0.0:
                v = ca.mtimes(ca.jacobian(Rq[:, i], q), qd)
                K += 0.5 * float(Ji) * ca.dot(v, v)
        if self.center is not None:
            v = ca.mtimes(ca.jacobian(self.center, q), qd)
            K += 0.5 * float(self.mass) * ca.dot(v, v)
        return K


def unit_norm(quat):
    """The holonomic constraint ``(qᵀq − 1)/2 = 0`` of an orientation quaternion.

    >>> import casadi as ca, castrajectory as ct
    >>> float(ct.unit_norm(ca.DM([0.6, 0.8, 0.0, 0.0])))
    0.0
    """
    return (ca.dot(quat, quat) - 1.0) / 2.0


def box_points(quat, size: Sequence[float], center=None):
    """World positions of a box's 8 corners, for pictures (SX expressions)."""
    R = rotation(quat)
    c = ca.SX.zeros(3) if center is None else center
    half = 0.5 * np.asarray(size, float)
    pts = [c + ca.mtimes(R, ca.DM(half * np.array(s))) for s in
           [(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1), (-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)]]
    return pts


QUAT_NAMES = ["qw", "qx", "qy", "qz"]


def free_body(inertia: Inertia, size: Optional[Sequence[float]] = None) -> LagrangianSystem:
    """A torque-free rigid body (orientation only): ``L = ½ ωᵀ I ω``, constraint ``|q| = 1``.

    ``size`` (box edges along the body axes) gives the points drawn in pictures; by default a
    box with the same principal moments (unit mass).
    """
    q = ca.SX.sym("q", 4)
    if size is None:
        size = equivalent_box(inertia)
    return LagrangianSystem(q, RigidBody(q, inertia), constraints=[unit_norm(q)], names=QUAT_NAMES,
                            points_expr=box_points(q, size))


def equivalent_box(inertia: Inertia, mass: float = 1.0) -> np.ndarray:
    """Edges of the uniform box of ``mass`` with these principal moments (for pictures)."""
    J = inertia.second_moments / mass  # = edge²/12
    return np.sqrt(np.maximum(12.0 * J, 1e-6 * max(12.0 * J.max(), 1e-300)))


#: The box's corners in the order of :func:`box_points` (signs of the half edges along x, y, z).
BOX_CORNERS = ["---", "+--", "++-", "-+-", "--+", "+-+", "+++", "-++"]


def box_in_bowl(mass: float, size: Sequence[float], radius: float, g: float = 9.81,
                restitution: float = 1.0, friction: float = 0.0) -> LagrangianSystem:
    """A box free in space over the paraboloid bowl ``z = (x² + y²)/(2R)``: ``q = (c, quat)``, the
    centre and the orientation quaternion (constraint ``|quat| = 1``), gravity ``g`` along ``−e_z``
    (left out for ``g = 0``), and one contact per corner with restitution ``e``.

    The gaps are the corners' heights above the bowl, ``φ_j = z_j − (x_j² + y_j²)/(2R)`` (a vertical
    distance: its gradient is normal to the bowl, so the impulses act along the normal, as for the
    planar bowl of :func:`castrajectory.models.collision.bowl`).  ``size`` are the edges along the
    body axes; the kinetic energy is that of the uniform box (:meth:`Inertia.box`).  With Coulomb ``friction``
    (> 0) each corner slips on the tangent plane of the bowl's level set through it: its velocity along two
    orthonormal tangents, ``t₁ ∝ e_x − (e_x·n) n`` and ``t₂ = n × t₁`` (``n`` the unit normal), the isotropic cone.
    """
    m = positive("mass", mass)
    size = [positive(f"box edge {i + 1}", v) for i, v in enumerate(size)]
    if len(size) != 3:
        raise InputError(f"a box needs 3 edges (got {len(size)})")
    R = positive("bowl radius", radius)
    g = finite("g", g)
    q = ca.SX.sym("q", 7)
    c, quat = q[:3], q[3:]
    corners = box_points(quat, size, c)
    gaps = [p[2] - (p[0] ** 2 + p[1] ** 2) / (2.0 * R) for p in corners]
    terms = [Gravity(g, heights=[c[2]], masses=[m])] if g != 0.0 else []
    slip = None
    if finite("friction", friction) > 0:
        from .mechanics import velocity
        qd = velocity(q)
        slip = []
        for p in corners:
            n = ca.vertcat(-p[0] / R, -p[1] / R, 1.0)
            n = n / ca.norm_2(n)
            t1 = ca.DM([1.0, 0.0, 0.0]) - n[0] * n
            t1 = t1 / ca.norm_2(t1)
            t2 = ca.cross(n, t1)
            pd = ca.mtimes(ca.jacobian(p, q), qd)
            slip.append(ca.vertcat(ca.dot(t1, pd), ca.dot(t2, pd)))
    return LagrangianSystem(q, RigidBody(quat, Inertia.box(*size, m), center=c, mass=m), terms, [unit_norm(quat)],
                            names=["x", "y", "z"] + QUAT_NAMES, points_expr=corners,
                            contact=Contact(gaps, restitution, BOX_CORNERS, friction=friction, slip=slip))


def sphere_on_floor(mass: float, radius: float, mu: float, g: float = 9.81, restitution: float = 0.0,
                    shell: bool = False) -> LagrangianSystem:
    """A uniform sphere (or a thin shell, I = 2/3 m R²) on the floor ``z = 0``: ``q = (c, quat)`` on SO(3)
    (constraint ``|quat| = 1``), gravity along ``−e_z``, the gap ``c_z − R ≥ 0`` with Coulomb friction ``mu`` on
    the tangent plane: the contact point's slip ``(ċ_x − R ω_y, ċ_y + R ω_x)`` (``ω`` in space axes), two
    components, the isotropic (circular) cone."""
    from .mechanics import velocity
    m, R = positive("mass", mass), positive("radius", radius)
    g = finite("g", g)
    q = ca.SX.sym("q", 7)
    c, quat = q[:3], q[3:]
    qd = velocity(q)
    w = angular_velocity(quat, qd[3:], frame="space")
    slip = ca.vertcat(qd[0] - R * w[1], qd[1] + R * w[0])
    k = 2.0 / 3.0 if shell else 0.4
    inertia = Inertia(k * m * R * R, k * m * R * R, k * m * R * R)
    terms = [Gravity(g, heights=[c[2]], masses=[m])] if g != 0.0 else []
    marks = [c + ca.mtimes(rotation(quat), ca.DM(R * np.array(d, float))) for d in
             [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]]
    return LagrangianSystem(q, RigidBody(quat, inertia, center=c, mass=m), terms, [unit_norm(quat)],
                            names=["x", "y", "z"] + QUAT_NAMES, points_expr=marks,
                            contact=Contact([c[2] - R], restitution, ["floor"], friction=mu, slip=[slip]))


def sphere_in_bowl(mass: float, radius: float, bowl: float, mu: float, g: float = 9.81) -> LagrangianSystem:
    """A uniform sphere inside a spherical bowl of radius ``bowl`` centred at the origin: ``q = (c, quat)`` on SO(3),
    the gap ``(R_b − r) − |c| ≥ 0`` with Coulomb friction ``mu`` on its tangent plane: the contact point
    ``c + r n`` (``n = c/|c|``) slips at ``ċ + ω × (r n)``, along the tangents ``t₁ ∝ e_x − (e_x·n) n`` and
    ``t₂ = n × t₁`` (smooth away from ``n ∥ e_x``, so for a sphere near the bowl's bottom).  Rolling is nonholonomic
    here: its slip is not the rate of a function of q."""
    from .mechanics import velocity
    m, r, Rb = positive("mass", mass), positive("radius", radius), positive("bowl", bowl)
    if Rb <= r:
        raise InputError(f"the bowl's radius must exceed the sphere's (got {Rb:g} <= {r:g})")
    g = finite("g", g)
    q = ca.SX.sym("q", 7)
    c, quat = q[:3], q[3:]
    qd = velocity(q)
    w = angular_velocity(quat, qd[3:], frame="space")
    dist = ca.norm_2(c)
    n = c / dist
    ex = ca.DM([1.0, 0.0, 0.0])
    t1 = ex - ca.dot(ex, n) * n
    t1 = t1 / ca.norm_2(t1)
    t2 = ca.cross(n, t1)
    point_velocity = qd[:3] + ca.cross(w, r * n)
    slip = ca.vertcat(ca.dot(t1, point_velocity), ca.dot(t2, point_velocity))
    inertia = Inertia(0.4 * m * r * r, 0.4 * m * r * r, 0.4 * m * r * r)
    terms = [Gravity(g, heights=[c[2]], masses=[m])] if g != 0.0 else []
    marks = [c + ca.mtimes(rotation(quat), ca.DM(r * np.array(d, float))) for d in
             [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]]
    return LagrangianSystem(q, RigidBody(quat, inertia, center=c, mass=m), terms, [unit_norm(quat)],
                            names=["x", "y", "z"] + QUAT_NAMES, points_expr=marks,
                            contact=Contact([(Rb - r) - dist], 0.0, ["bowl"], friction=mu, slip=[slip]))


def heavy_top(mass: float, inertia: Inertia, distance: float, g: float = 9.81) -> LagrangianSystem:
    """A symmetric top with its pivot fixed at the origin, the centre of mass at ``distance``
    along the body axis ``e₃``, gravity ``g`` along ``−e_z`` (z up).

    ``inertia`` is about the centre of mass (``I₁ = I₂``); the kinetic term uses the moments
    about the pivot (Steiner).  Gravity is the ordinary :class:`~castrajectory.models.mechanics.Gravity`
    term on the centre of mass's height ``(R(q) l e₃)_z``; with ``g = 0`` it is left out.
    """
    m = positive("mass", mass)
    ell = positive("distance", distance)
    g = finite("g", g)
    if abs(inertia.I1 - inertia.I2) > 1e-12 * max(inertia.I1, inertia.I2):
        raise InputError(f"a symmetric top needs I1 = I2 (got {inertia.I1:g}, {inertia.I2:g})")
    q = ca.SX.sym("q", 4)
    pivot_inertia = inertia.about(m, [0.0, 0.0, ell])
    com = ca.mtimes(rotation(q), ca.DM([0.0, 0.0, ell]))
    terms = [Gravity(g, heights=[com[2]], masses=[m])] if g != 0.0 else []
    r = 0.5 * np.sqrt(max(inertia.I1, 1e-300) / m)
    points = [ca.SX.zeros(3), com] + [com + ca.mtimes(rotation(q), ca.DM(r * np.array(d)))
                                      for d in [(1, 0, 0), (0, 1, 0), (-1, 0, 0), (0, -1, 0), (1, 0, 0)]]
    return LagrangianSystem(q, RigidBody(q, pivot_inertia), terms, [unit_norm(q)], names=QUAT_NAMES,
                            points_expr=points)


# ----------------------------------------------------------------------------- oracles
def elliptic_k(m: float, complement: Optional[float] = None) -> float:
    """Complete elliptic integral of the first kind ``K(m) = ∫₀^{π/2} dθ/√(1 − m sin²θ)`` (AGM).

    ``complement``: ``1 − m`` given directly, which keeps its relative accuracy near ``m = 1``
    (where ``K ≈ ln(4/√(1 − m))``); ``m`` is then ignored."""
    m1 = 1.0 - m if complement is None else float(complement)
    if not 0.0 < m1 <= 1.0:
        raise ValueError("K(m) needs 0 <= m < 1")
    a, b = 1.0, math.sqrt(m1)
    for _ in range(100):
        if abs(a - b) <= 1e-16 * a:
            break
        a, b = 0.5 * (a + b), math.sqrt(a * b)
    return math.pi / (2.0 * a)


def _flip_parameters(inertia: Inertia, omega0: Sequence[float]):
    """``(1 − m, s, r, I_a, I_b, I_c, 2E)`` of :func:`flip_interval`, or ``None`` (separatrix,
    symmetric body).  ``1 − m`` is formed without cancellation: with ``r = L²/2E``,
    ``1 − m = (I_c − I_a)(r − I_b)/((I_c − I_b)(r − I_a))`` for ``r > I_b`` (and the mirror image for
    ``r < I_b``), where ``2E (r − I_b) = I_c(I_c − I_b)ω_c² − I_a(I_b − I_a)ω_a²`` -- two small terms
    near the intermediate axis, not a difference of the O(1) invariants."""
    I = inertia.moments
    w = np.asarray(omega0, float)
    order = np.argsort(I)
    Ia, Ib, Ic = I[order]
    wa, _, wc = w[order]
    if not (Ia < Ib < Ic):
        return None
    E2 = float(np.sum(I * w * w))
    L2 = float(np.sum((I * w) ** 2))
    if E2 <= 0.0:
        return None
    d = (Ic * (Ic - Ib) * wc * wc - Ia * (Ib - Ia) * wa * wa) / E2  # r - I_b
    r = Ib + d
    if d > 0:
        m1 = (Ic - Ia) * d / ((Ic - Ib) * (r - Ia))
        s = math.sqrt((Ic - Ib) * (L2 - E2 * Ia) / (Ia * Ib * Ic))
    elif d < 0:
        m1 = (Ic - Ia) * (-d) / ((Ib - Ia) * (Ic - r))
        s = math.sqrt((Ib - Ia) * (E2 * Ic - L2) / (Ia * Ib * Ic))
    else:
        return None
    if not 0.0 < m1 <= 1.0 or s == 0.0:
        return None
    return m1, s, r, Ia, Ib, Ic, E2


def flip_interval(inertia: Inertia, omega0: Sequence[float]) -> float:
    """Time between two sign changes of the intermediate-axis rate (Landau–Lifshitz §37): ``2K(m)/s``.

    With the moments sorted ``I_a < I_b < I_c`` (``I_b`` the intermediate one), energy ``2E = Σ I_i ω_i²``
    and ``L² = Σ I_i² ω_i²``: for ``L² > 2E I_b``
    ``m = (I_b − I_a)(2E I_c − L²)/((I_c − I_b)(L² − 2E I_a))``,
    ``s = √((I_c − I_b)(L² − 2E I_a)/(I_a I_b I_c))``; otherwise the roles of ``I_a`` and ``I_c`` swap.
    ``2K/s`` is the half-period of the two oscillating rates (the intermediate one always); whether
    their sign changes are flips depends on the axis the spin starts on
    (:func:`castrajectory.inspect.rigidbody.free_body`).  ``inf`` on the separatrix.  ``1 − m`` is
    computed without cancellation (:func:`_flip_parameters`), so the value keeps its relative
    accuracy near the separatrix, where ``K`` grows like ``ln(4/√(1 − m))``.
    """
    par = _flip_parameters(inertia, omega0)
    if par is None:
        return math.inf
    m1, s = par[0], par[1]
    return 2.0 * elliptic_k(0.0, complement=m1) / s


def flip_interval_sensitivity(inertia: Inertia, omega0: Sequence[float]) -> np.ndarray:
    """``∂T/∂ω₀`` (seconds per rad/s, one entry per body axis) of the flip interval ``T`` of
    :func:`flip_interval`, by central differences of its cancellation-free form.

    Near the intermediate axis ``T ≈ (1/s) ln(16/(1 − m))`` and ``1 − m`` is proportional to the
    squares of the two small rates, so ``T`` is sensitive to their *absolute* error: for
    I = (1, 2, 3), ω₀ = (1e-3, 1, 1e-3) the entries are (1.7e3, −24, −5.2e3) s per rad/s.  A method
    whose small rates carry an absolute error ``δ`` (a solver residual on O(1) unknowns divided by
    the step, or a rounding of them) moves the interval by about ``5e3 δ`` per such error."""
    w = np.asarray(omega0, float)
    out = np.zeros(3)
    for k in range(3):
        d = 1e-6 * max(abs(w[k]), 1e-3 * float(np.max(np.abs(w))))
        wp, wm = w.copy(), w.copy()
        wp[k] += d
        wm[k] -= d
        out[k] = (flip_interval(inertia, wp) - flip_interval(inertia, wm)) / (2 * d)
    return out


def intermediate_axis(inertia: Inertia) -> int:
    """Index of the intermediate principal axis (0, 1 or 2)."""
    return int(np.argsort(inertia.moments)[1])


def sign_changes(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Times where ``y`` changes sign, located between nodes by cubic interpolation through the
    four nearest nodes (second-order root of the local cubic; fourth-order accurate in ``h``)."""
    t, y = np.asarray(t, float), np.asarray(y, float)
    idx = np.where(np.sign(y[:-1]) * np.sign(y[1:]) < 0)[0]
    out = []
    for k in idx:
        lo = min(max(k - 1, 0), len(t) - 4) if len(t) >= 4 else 0
        ts, ys = t[lo:lo + 4], y[lo:lo + 4]
        a, b = t[k], t[k + 1]
        # the linear root, then Newton on the cubic through the four nodes
        x = a - y[k] * (b - a) / (y[k + 1] - y[k])
        if len(ts) == 4:
            c = np.polyfit(ts - a, ys, 3)
            dc = np.polyder(c)
            for _ in range(20):
                f, df = np.polyval(c, x - a), np.polyval(dc, x - a)
                if df == 0:
                    break
                step = f / df
                x = min(max(x - step, a), b)
                if abs(step) <= 1e-15 * max(1.0, abs(x)):
                    break
        out.append(x)
    return np.array(out)
