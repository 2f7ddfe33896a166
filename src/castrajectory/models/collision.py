"""Impulsive contact of a planar rigid body, and the corner impact law (the analytic oracle).

Coordinates ``q = (c_x, c_y, θ)``: centroid ``c`` and rotation angle ``θ``.  A
body point with body-frame offset ``d`` sits at ``x(q) = c + R(θ) d`` with
``R(θ) = [[cos θ, −sin θ], [sin θ, cos θ]]``; its height is

    y(c, θ) = c_y + sin θ d_x + cos θ d_y.

Mass matrix, two ways (they must agree; ``tests/test_collision.py`` checks it):

* :func:`rectangle_atoms` — the seed's definition: ``K = ∫ ½|ẋ|² dm`` over a
  uniform ``w × h`` rectangle, by Gauss–Legendre quadrature.  The atoms are the
  quadrature points, with masses ``m ×`` the (normalised) weights.  The
  integrand is quadratic in the body coordinates, so two points per direction
  are already exact.  ``LagrangianSystem.mass_matrix`` then gives ``M``.
* :func:`rectangle_mass_matrix` — the closed form ``M = diag(m, m, I)`` with
  ``I = m (w² + h²)/12 = m|d|²/3`` for the corner ``d = (w/2, h/2)``.

The seed's equation (8) gives ``m|d|²/3`` as the (3,3) entry of ``M/2``, which
is twice the uniform-rectangle value.  Integrate the seed's own kinetic energy
``∫ ½|ẋ|² dm`` with ``ẋ = ċ + θ̇ R'(θ) d``.  The cross term vanishes because
``∫ d dm = 0`` about the centroid, and ``|R'(θ) d| = |d|``.  What is left is
``K = ½ m|ċ|² + ½ θ̇² ∫|d|² dm``, and for a uniform rectangle
``∫|d|² dm = m (w² + h²)/12 = m|d|²/3``.  So ``m|d|²/3`` is the moment of inertia
``I`` itself: it is the (3,3) entry of ``M``, and the entry of ``M/2`` is
``m|d|²/6``.  Equation (8) dropped the factor ½ on the rotational term.  Used
as written, it doubles the body's resistance to spinning, which halves the
angular part of the admissible direction ``M⁻¹Jᵀ`` and changes every impact
outcome.  This module uses the physical ``M = diag(m, m, m|d|²/3)``, which the
atom quadrature reproduces to round-off.

Admissible change of velocity at a contact with gap ``y(q) ≥ 0``: the impulse
acts along ``M⁻¹ (dy|_q)ᵀ``, so ``Δq̇ ∈ {μ M⁻¹ Jᵀ | μ ≥ 0}`` with ``J = ∂y/∂q``.
For the rectangle's point ``d`` (:func:`admissible_direction_function`
derives it with CasADi; :func:`admissible_direction` is the closed form)

    J = (0, 1, d_x cos θ − d_y sin θ),      M⁻¹Jᵀ = (0, 1/m, (d_x cos θ − d_y sin θ)/I).

Impact law (:func:`resolve_impact`, any ``(M, J)`` pair): restitution ``e``
reverses the contact's normal velocity, ``J v⁺ = −e J v⁻``, with
``v⁺ = v⁻ + μ M⁻¹Jᵀ``, so

    μ = −(1 + e) J v⁻ / (J M⁻¹ Jᵀ)   when J v⁻ < 0 (approaching),   μ = 0 otherwise.

With ``e = 1`` kinetic energy is conserved.  ``ΔK = μ (J v⁻ + ½ μ J M⁻¹ Jᵀ)``
has two roots: ``μ = 0`` (trivial) and this ``μ``.  A point that is already
separating (``J v⁻ ≥ 0``) gets ``μ = 0`` and keeps its velocity.  ``μ ≥ 0`` always.

Flat fall onto a corner (the test oracle): ``θ = 0``, ``d = (−w/2, −h/2)``,
``v⁻ = (0, −v, 0)``.  Then ``J = (0, 1, −w/2)``, ``J M⁻¹ Jᵀ = (4w² + h²)/(m (w² + h²))``, and

    μ = (1 + e) m v (w² + h²)/(4w² + h²),   v_y⁺ = −v + μ/m,   ω⁺ = −(w/2) μ / I.

For a thin rod (``h → 0``) with ``e = 0`` this is the textbook
``μ = m v/4``, ``v_y⁺ = −3v/4``, ``ω⁺ = −3v/(2w)``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence

import casadi as ca
import numpy as np

from .impact import (  # noqa: F401  (the impact law lives in models.impact; these names stay importable here)
    Impact, _finite_vector, impact_law, resolve_impact, restitution, simultaneous_impact, system_impact)
from .mechanics import Atoms, Contact, Gravity, LagrangianSystem, MassMatrix, Potential
from ..validation import InputError, finite, integer_at_least, positive

NAMES = ["cx", "cy", "theta"]


# ----------------------------------------------------------------------------- parameters, checked once
@dataclass(frozen=True)
class Body:
    """A uniform ``width × height`` rectangle of mass ``mass``: the parameters of every rectangle scene.

    Checked once, when it is made; everything that receives a :class:`Body` trusts it.
    """

    mass: float
    width: float
    height: float

    def __post_init__(self):
        for name in ("mass", "width", "height"):
            object.__setattr__(self, name, positive(name, getattr(self, name)))

    @property
    def inertia(self) -> float:
        """``I = m (w² + h²)/12 = m|d|²/3`` (corner ``d = (w/2, h/2)``) about the centroid."""
        return self.mass * (self.width ** 2 + self.height ** 2) / 12.0

    @property
    def mass_matrix(self) -> np.ndarray:
        """Closed form ``M = diag(m, m, I)``."""
        return np.diag([self.mass, self.mass, self.inertia])

    @property
    def corners(self) -> np.ndarray:
        """The four body-frame corners, counter-clockwise from the lower left."""
        return corners(self.width, self.height)

    def corner_jacobian(self, angle: float, corner) -> np.ndarray:
        """``J = ∂y/∂q = (0, 1, d_x cos θ − d_y sin θ)`` of the body point ``corner`` at ``angle``."""
        return _corner_jacobian(angle, corner)


def default_corner(width: float, height: float) -> np.ndarray:
    """The lower-left corner ``(−w/2, −h/2)`` in the body frame."""
    return np.array([-width / 2.0, -height / 2.0])


# ----------------------------------------------------------------------------- geometry (symbolic)
def rotation(theta):
    """``R(θ) = [[cos θ, −sin θ], [sin θ, cos θ]]`` (CasADi)."""
    c, s = ca.cos(theta), ca.sin(theta)
    return ca.vertcat(ca.horzcat(c, -s), ca.horzcat(s, c))


def body_point(q, d):
    """World position ``c + R(θ) d`` of the body-frame point ``d`` (CasADi expression)."""
    return q[0:2] + ca.mtimes(rotation(q[2]), ca.vertcat(d[0], d[1]))


def point_height(q, d):
    """Height ``y(c, θ) = c_y + sin θ d_x + cos θ d_y`` of the body-frame point ``d``."""
    return body_point(q, d)[1]


# ----------------------------------------------------------------------------- mass matrix, two ways
def rectangle_inertia(mass: float, width: float, height: float) -> float:
    """``I = m (w² + h²)/12 = m|d|²/3`` (corner ``d = (w/2, h/2)``) about the centroid."""
    return Body(mass, width, height).inertia


def rectangle_mass_matrix(mass: float, width: float, height: float) -> np.ndarray:
    """Closed form ``M = diag(m, m, I)``."""
    return Body(mass, width, height).mass_matrix


def rectangle(mass: float, width: float, height: float) -> LagrangianSystem:
    """Free planar rectangle with the closed-form mass matrix (no potential terms)."""
    q = ca.SX.sym("q", 3)
    return LagrangianSystem(q, MassMatrix(ca.SX(Body(mass, width, height).mass_matrix)), names=NAMES)


def rectangle_atoms(mass: float, width: float, height: float, points: int = 2) -> LagrangianSystem:
    """Free planar rectangle whose kinetic energy is the seed's ``∫ ½|ẋ|² dm``.

    The integral is taken by a ``points × points`` Gauss–Legendre rule: atom
    ``(i, j)`` sits at body offset ``d = (w ξ_i/2, h ξ_j/2)`` with mass
    ``m ω_i ω_j / 4``.  Any ``points ≥ 2`` is exact for this quadratic integrand.
    """
    b = Body(mass, width, height)
    m, w, h = b.mass, b.width, b.height
    n = integer_at_least("quadrature points", points, 2)
    xi, wt = np.polynomial.legendre.leggauss(n)
    q = ca.SX.sym("q", 3)
    positions, masses = [], []
    for i in range(n):
        for j in range(n):
            positions.append(body_point(q, (0.5 * w * xi[i], 0.5 * h * xi[j])))
            masses.append(m * wt[i] * wt[j] / 4.0)
    return LagrangianSystem(q, Atoms(positions, masses), names=NAMES)


# ----------------------------------------------------------------------------- admissible direction
def admissible_direction_function() -> ca.Function:
    """CasADi-derived ``M⁻¹ (dy|_q)ᵀ`` per unit ``μ``, for the rectangle's body point ``d``.

    Returns ``f(q, d, m, I) -> M⁻¹Jᵀ`` (3-vector), where ``J`` is
    ``ca.jacobian`` of :func:`point_height` with respect to ``q``, and
    ``M = diag(m, m, I)``.  Compare :func:`admissible_direction` (closed form).
    """
    q, d = ca.SX.sym("q", 3), ca.SX.sym("d", 2)
    m, inertia = ca.SX.sym("m"), ca.SX.sym("I")
    J = ca.jacobian(point_height(q, d), q)  # 1 x 3
    M = ca.diag(ca.vertcat(m, m, inertia))
    return ca.Function("admissible_direction", [q, d, m, inertia], [ca.solve(M, J.T)],
                       ["q", "d", "m", "I"], ["direction"])


def _corner_jacobian(th: float, d) -> np.ndarray:
    return np.array([0.0, 1.0, d[0] * np.cos(th) - d[1] * np.sin(th)])


def corner_jacobian(theta: float, corner: Sequence[float]) -> np.ndarray:
    """Closed form ``J = ∂y/∂q = (0, 1, d_x cos θ − d_y sin θ)``."""
    return _corner_jacobian(finite("angle", theta), _finite_vector("corner", corner, 2))


def admissible_direction(mass: float, inertia: float, theta: float, corner: Sequence[float]) -> np.ndarray:
    """Closed form ``M⁻¹Jᵀ = (0, 1/m, (d_x cos θ − d_y sin θ)/I)`` per unit ``μ``."""
    m, inertia = positive("mass", mass), positive("inertia", inertia)
    return corner_jacobian(theta, corner) / np.array([m, m, inertia])


# ----------------------------------------------------------------------------- impact law
@dataclass
class CornerImpact(Impact):
    """:class:`Impact` of a rectangle's body point, with the body data."""

    mass: float = 0.0
    width: float = 0.0
    height: float = 0.0
    inertia: float = 0.0
    angle: float = 0.0
    corner: Optional[np.ndarray] = None

    def point_velocity(self, v) -> np.ndarray:
        """World velocity ``ċ + ω R'(θ) d`` of the body point."""
        dx, dy = self.corner
        s, c = np.sin(self.angle), np.cos(self.angle)
        return np.array([v[0] + v[2] * (-s * dx - c * dy), v[1] + v[2] * (c * dx - s * dy)])

    def as_dict(self) -> dict:
        vb, va = self.v_before, self.v_after
        return {
            "status": "ok", "mu": self.mu,
            "vx": va[0], "vy": va[1], "omega": va[2],
            "v_before": vb, "v_after": va,
            "ke_before": self.ke_before, "ke_after": self.ke_after,
            "admissible_direction": self.direction, "jacobian": self.jacobian,
            "corner_velocity_before": self.point_velocity(vb), "corner_velocity_after": self.point_velocity(va),
            "corner_normal_velocity_before": self.normal_velocity_before,
            "corner_normal_velocity_after": self.normal_velocity_after,
            "mass": self.mass, "width": self.width, "height": self.height, "inertia": self.inertia,
            "angle": self.angle, "corner": self.corner, "restitution": self.restitution,
        }


def rectangle_impact(mass: float, width: float, height: float, angle: float, v_before,
                     e: float, corner: Optional[Sequence[float]] = None) -> CornerImpact:
    """Impact of a uniform rectangle's body point ``corner`` (default lower-left) on the ground ``y = 0``.

    ``v_before = (v_x, v_y, ω)``; closed-form ``M`` and ``J``, general law :func:`resolve_impact`.
    """
    body = Body(mass, width, height)
    th = finite("angle", angle)
    d = None if corner is None else _finite_vector("corner", corner, 2)
    return corner_impact(body, th, _finite_vector("velocity", v_before, 3), restitution(e), d)


def corner_impact(body: Body, angle: float, v_before: np.ndarray, e: float,
                  corner: Optional[np.ndarray] = None) -> CornerImpact:
    """:func:`rectangle_impact` on checked values (a :class:`Body`, a finite angle and velocity, ``e ∈ [0, 1]``)."""
    d = default_corner(body.width, body.height) if corner is None else np.asarray(corner, float)
    r = impact_law(body.mass_matrix, _corner_jacobian(angle, d), np.asarray(v_before, float), e)
    return CornerImpact(**vars(r), mass=body.mass, width=body.width, height=body.height, inertia=body.inertia,
                        angle=float(angle), corner=d)


# ----------------------------------------------------------------------------- contact scenes
def corners(width: float, height: float) -> np.ndarray:
    """The four body-frame corners, counter-clockwise from the lower left."""
    w, h = width / 2.0, height / 2.0
    return np.array([[-w, -h], [w, -h], [w, h], [-w, h]])


def bouncing_ball(mass: float = 1.0, g: float = 9.81, restitution_coefficient: float = 1.0,
                  stiffness: float = 0.0, anchor: float = 1.0) -> LagrangianSystem:
    """Point mass at height ``y`` above the ground ``y = 0``: ``L = ½ m ẏ² − m g y``, gap ``φ = y``.

    Gravity is omitted when ``g = 0``; with ``stiffness = k > 0`` a linear spring
    ``½ k (y − anchor)²`` pulls the ball towards the height ``anchor`` (then the
    free flight is harmonic, which the midpoint rule does not integrate exactly:
    the scene for convergence orders).  The :class:`~castrajectory.models.mechanics.Contact`
    term is the only contact machinery.
    """
    m = positive("mass", mass)
    g = finite("g", g)
    k = finite("stiffness", stiffness)
    if k < 0:
        raise InputError(f"stiffness must be >= 0 (got {stiffness})")
    y = ca.SX.sym("y", 1)
    point = ca.vertcat(0, y[0])
    terms = [Gravity(g)] if g != 0.0 else []
    if k > 0:
        terms.append(Potential(0.5 * k * (y[0] - finite("anchor", anchor)) ** 2, "spring"))
    return LagrangianSystem(y, Atoms([point], [m]), terms, names=["y"],
                            contact=Contact([y[0]], restitution_coefficient, ["ball"]))


def ball_oracle(height: float, velocity: float, g: float, e: float, T: float):
    """Analytic bounce times, apex heights and impact speeds of a ball dropped from ``height`` with ``velocity``.

    First impact at ``t₁ = (v₀ + √(v₀² + 2gH))/g`` with speed ``V = √(v₀² + 2gH)``;
    then speeds ``eᵏV``, flights ``2eᵏV/g`` and apexes ``(eᵏV)²/(2g)``.  Returns
    ``(times, apexes, speeds)`` of the bounces before ``T`` (apexes[0] is the first
    flight's apex ``H + v₀²/2g`` when ``v₀ ≥ 0``, else ``H``).
    """
    V = math.sqrt(velocity ** 2 + 2 * g * height)
    t = (velocity + V) / g
    times, apexes, speeds = [], [height + max(velocity, 0.0) ** 2 / (2 * g)], []
    k = 0
    while t < T and k < 10000 and e ** k * V > 1e-12 * V:
        times.append(t)
        speeds.append(e ** k * V)
        apexes.append((e ** (k + 1) * V) ** 2 / (2 * g))
        t += 2 * e ** (k + 1) * V / g
        k += 1
    return np.array(times), np.array(apexes), np.array(speeds)


def spring_ball_oracle(height: float, velocity: float, g: float, stiffness: float, mass: float, anchor: float,
                       e: float, T: float):
    """Analytic impacts of the ball on a spring (see :func:`bouncing_ball`): times and impact speeds before ``T``.

    Between impacts ``y(τ) = y_eq + (y₀ − y_eq) cos ωτ + (v₀/ω) sin ωτ`` with
    ``ω = √(k/m)`` and ``y_eq = anchor − m g/k``; the next impact is the first
    ``τ > 0`` with ``y(τ) = 0``, where ``v → −e v``.
    """
    w = math.sqrt(stiffness / mass)
    yeq = anchor - mass * g / stiffness
    t, y0, v0 = 0.0, float(height), float(velocity)
    times, speeds = [], []
    while t < T and len(times) < 10000:
        A, B = y0 - yeq, v0 / w
        R = math.hypot(A, B)
        if R <= abs(yeq) or R == 0.0:
            break  # oscillates without reaching the ground
        phase = math.atan2(B, A)
        c = math.acos(-yeq / R)
        cands = [(phase + s * c + 2 * math.pi * n) / w for s in (1, -1) for n in range(-1, 3)]
        cands = [x for x in cands if x > 1e-12 / w]
        tau = min(cands)
        v_hit = -A * w * math.sin(w * tau) + B * w * math.cos(w * tau)
        t += tau
        if t >= T:
            break
        times.append(t)
        speeds.append(-v_hit)
        y0, v0 = 0.0, -e * v_hit
        if v0 <= 1e-12 * abs(v_hit):
            break
    return np.array(times), np.array(speeds)


def ball_height(height: float, velocity: float, g: float, e: float, t) -> np.ndarray:
    """Analytic height of the bouncing ball at times ``t`` (0 after the Zeno accumulation time)."""
    t = np.asarray(t, float)
    times, _, speeds = ball_oracle(height, velocity, g, e, float(t.max()) + 1.0)
    y = np.zeros_like(t)
    first = t < (times[0] if times.size else np.inf)
    y[first] = height + velocity * t[first] - 0.5 * g * t[first] ** 2
    for k, t0 in enumerate(times):
        v = e * speeds[k]
        t1 = times[k + 1] if k + 1 < times.size else t0 + 2 * v / g
        sel = (t >= t0) & (t < t1)
        y[sel] = v * (t[sel] - t0) - 0.5 * g * (t[sel] - t0) ** 2
    return np.maximum(y, 0.0)


#: Names of the rectangle's corners, in the order of :func:`corners`.
CORNER_NAMES = ["lower left", "lower right", "upper right", "upper left"]


def rectangle_contact_system(body: Body, g: float, e, ground, friction=0.0) -> LagrangianSystem:
    """A :class:`Body` (checked) under gravity ``g`` (finite; 0 drops the term) over the ground whose gap
    at a world point ``p`` is ``ground(p)``; ``e`` is checked by the :class:`Contact` term it builds.
    With Coulomb ``friction`` (> 0) each corner slips at its velocity along the ground's tangent there,
    ``t = (∂φ/∂y, −∂φ/∂x)/|∇φ|`` (the ground's level set through the corner)."""
    q = ca.SX.sym("q", 3)
    pts = [body_point(q, d) for d in body.corners]
    gaps = [ground(p) for p in pts]
    terms = [Gravity(g, heights=[q[1]], masses=[body.mass])] if g != 0.0 else []
    slip = None
    if np.any(np.asarray(friction, float) > 0):
        from .mechanics import velocity
        qd = velocity(q)
        P = ca.SX.sym("p", 2)
        n = ca.Function("n", [P], [ca.gradient(ground(P), P)])
        slip = []
        for p in pts:
            nv = n(p)
            t = ca.vertcat(nv[1], -nv[0]) / ca.norm_2(nv)
            slip.append(ca.dot(t, ca.mtimes(ca.jacobian(p, q), qd)))
    return LagrangianSystem(q, MassMatrix(ca.SX(body.mass_matrix)), terms, names=NAMES,
                            points_expr=pts + [pts[0]],
                            contact=Contact(gaps, e, CORNER_NAMES, friction=friction, slip=slip))


def flat_ground(p):
    """Gap of a world point ``p`` above the ground ``y = 0``."""
    return p[1]


def bowl_ground(radius: float):
    """Gap ``φ = y − x²/(2R)`` of a world point above the parabolic bowl ``y = x²/(2R)`` (``R`` checked)."""
    return lambda p: p[1] - p[0] ** 2 / (2 * radius)


def rectangle_drop(mass: float = 1.0, width: float = 2.0, height: float = 1.0, g: float = 9.81,
                   restitution_coefficient: float = 1.0, friction=0.0) -> LagrangianSystem:
    """Rigid ``w × h`` rectangle over the ground ``y = 0``: four corner gaps ``y_j(q) ≥ 0`` (Coulomb
    ``friction`` on each corner's horizontal velocity)."""
    return rectangle_contact_system(Body(mass, width, height), finite("g", g), restitution_coefficient,
                                    flat_ground, friction)


def bowl(mass: float = 1.0, width: float = 0.4, height: float = 0.2, g: float = 9.81,
         restitution_coefficient: float = 1.0, radius: float = 2.0, friction=0.0) -> LagrangianSystem:
    """Rectangle in the parabolic bowl ``y = x²/(2R)``: corner gaps ``φ_j = y_j − x_j²/(2R)``.

    The gap is the vertical distance to the bowl, whose gradient is normal to the
    bowl's level set ``y − x²/2R = 0``: the impulse acts along ``M⁻¹∇φᵀ``.
    """
    R = positive("bowl radius", radius)
    return rectangle_contact_system(Body(mass, width, height), finite("g", g), restitution_coefficient,
                                    bowl_ground(R), friction)


# ----------------------------------------------------------------------------- friction scenes
#: I / (m R²) of the rolling bodies
ROLLING_SHAPES = {"disk": 0.5, "sphere": 0.4}


def sliding_block(mass: float, mu: float, alpha: float, g: float) -> LagrangianSystem:
    """A point mass on a plane inclined at ``alpha``: ``q = (s, y)``, s up the plane, the gap ``y ≥ 0`` with
    Coulomb friction ``mu`` and the slip velocity ``ṡ`` (gravity ``g`` at ``alpha`` from the plane's normal)."""
    from .mechanics import velocity
    q = ca.SX.sym("q", 2)
    return LagrangianSystem(q, Atoms([q], [mass]), [Gravity(g, direction=(-math.sin(alpha), -math.cos(alpha)))],
                            names=["s", "y"], points_expr=[q],
                            contact=Contact([q[1]], restitution=0.0, friction=mu, slip=[velocity(q)[0]],
                                            names=["floor"]))


def rolling_body(shape: str, mass: float, radius: float, mu: float, g: float,
                 restitution: float = 0.0) -> LagrangianSystem:
    """A disk or a sphere (``ROLLING_SHAPES``) moving in the plane on the floor: ``q = (x, y, θ)``
    (θ counter-clockwise), the gap ``y − R ≥ 0`` with friction ``mu``, the contact point's slip ``ẋ + R θ̇`` and
    Newton's ``restitution`` for a bounce (the body dropped with spin)."""
    from .mechanics import velocity
    q = ca.SX.sym("q", 3)
    k = ROLLING_SHAPES[shape]
    qd = velocity(q)
    R = radius
    rim = [ca.vertcat(q[0] + R * ca.cos(q[2] + a), q[1] + R * ca.sin(q[2] + a))
           for a in np.linspace(0, 2 * np.pi, 9)[:-1]]
    return LagrangianSystem(q, MassMatrix(ca.diag(ca.vertcat(mass, mass, k * mass * R * R))),
                            [Potential(mass * g * q[1], "gravity")], names=["x", "y", "theta"], points_expr=rim,
                            contact=Contact([q[1] - R], restitution=restitution, friction=mu, slip=[qd[0] + R * qd[2]],
                                            names=["floor"]))


def sliding_block_oracle(v0, mu, alpha, g, t):
    """The sliding block's closed form: ``s(t)`` and the stop time (None if it never comes to rest):
    launched up it decelerates at g(sin α + μ cos α), then sticks if tan α <= μ or slides back at
    g(sin α − μ cos α); launched down or from rest likewise."""
    sa, ca_ = math.sin(alpha), math.cos(alpha)
    down = g * (sa - mu * ca_)                      # the acceleration down the slope while sliding down
    t = np.asarray(t, float)
    if v0 > 0:
        dec = g * (sa + mu * ca_)
        t1 = v0 / dec
        up = v0 * t - 0.5 * dec * t * t
        top = v0 * v0 / (2 * dec)
        if down <= 0:
            return np.where(t < t1, up, top), t1
        return np.where(t < t1, up, top - 0.5 * down * (t - t1) ** 2), None
    if v0 < 0:   # launched downhill: s̈ = −down while it slides down
        if down < 0:
            t1 = v0 / down
            return np.where(t < t1, v0 * t - 0.5 * down * t * t, v0 * t1 - 0.5 * down * t1 * t1), t1
        return v0 * t - 0.5 * down * t * t, None
    if down <= 0:
        return np.zeros_like(t), 0.0
    return -0.5 * down * t * t, None


def rolling_oracle(shape, v0, w0, R, mu, g):
    """A sliding disk or sphere: the time at which it starts rolling, ``|u0| k/((1 + k) μ g)``, and its final
    speed ``(v0 + k R ω0)/(1 + k)`` (slip u0 = v0 − R ω0, ω clockwise, k = I/(m R²))."""
    k = ROLLING_SHAPES[shape]
    u0 = v0 - R * w0
    t_roll = abs(u0) * k / ((1 + k) * mu * g)
    v_final = (v0 + k * R * w0) / (1 + k)
    return t_roll, v_final


# ----------------------------------------------------------------------------- the rimless wheel
def rimless_wheel(spokes: int = 8, length: float = 1.0, slope: float = 0.08, mass: float = 1.0, g: float = 9.8,
                  inertia: float = 0.01, mu: float = 1.0) -> LagrangianSystem:
    """McGeer's rimless wheel: a hub of mass ``m`` with ``spokes`` massless spokes of length ``l`` (half-angle
    ``α = π/spokes`` between neighbours) on a slope ``γ``, in the slope's frame (``x`` downhill, ``y`` along
    its normal), ``q = (x, y, θ)``; the hub's own inertia ``I = inertia · m l²`` (the rigid body needs one;
    0.01 leaves the limit cycle within 0.5 % of the point-mass one).  Each spoke tip is a contact (``e = 0``,
    Coulomb ``mu``: its slip is the tip's velocity along the slope), spoke ``i`` pointing along
    ``φ_i = θ + 2α i`` from the downward normal."""
    spokes = integer_at_least("spokes", spokes, 3)
    l, m = positive("length", length), positive("mass", mass)
    gam, kap = finite("slope", slope), finite("inertia", inertia)
    if not 0.0 <= gam < math.pi / 2:
        raise InputError(f"the slope must be in [0, pi/2) rad (got {slope})")
    if kap <= 0:
        raise InputError(f"the hub's inertia (in units of m l^2) must be > 0 (got {inertia})")
    from .mechanics import velocity
    q = ca.SX.sym("q", 3)
    qd = velocity(q)
    a = math.pi / spokes
    phis = [q[2] + 2 * a * i for i in range(spokes)]
    tips = [ca.vertcat(q[0] + l * ca.sin(f), q[1] - l * ca.cos(f)) for f in phis]
    gaps = [tip[1] for tip in tips]
    slip = [qd[0] + l * ca.cos(f) * qd[2] for f in phis]
    pts = []
    for tip in tips:
        pts += [ca.vertcat(q[0], q[1]), tip]
    return LagrangianSystem(q, MassMatrix(ca.diag(ca.vertcat(m, m, kap * m * l * l))),
                            [Potential(m * finite("g", g) * (q[1] * math.cos(gam) - q[0] * math.sin(gam)), "gravity")],
                            names=["x", "y", "theta"], points_expr=pts,
                            contact=Contact(gaps, restitution=0.0, friction=mu, slip=slip,
                                            names=[f"spoke{i}" for i in range(spokes)]))


def rimless_wheel_start(spokes: int, length: float, omega0: float):
    """``(q0, q̇0)``: spoke 0 planted at the origin, its tip ahead of the hub by ``α`` (a step starts), the
    wheel rolling downhill at ``ω0`` about that tip (``θ̇ = −ω0``)."""
    a = math.pi / spokes
    l = length
    return (np.array([-l * math.sin(a), l * math.cos(a), a]),
            np.array([l * math.cos(a) * omega0, l * math.sin(a) * omega0, -omega0]))


def rimless_wheel_oracle(spokes: int, length: float, slope: float, g: float, inertia: float, omega0: float,
                         steps: int):
    """The wheel's angular rates just after each of ``steps`` touchdowns, and the limit cycle's: at a
    touchdown the new tip sticks (plastic), the old one leaves, and the angular momentum about the new tip
    is kept, ``ω⁺ = ω⁻ (cos 2α + κ)/(1 + κ)`` (``κ`` the hub's inertia over ``m l²``); a stance from ``+α``
    to ``−α`` gains ``ω⁻² = ω⁺² + 4 (g/l) sin α sin γ / (1 + κ)``.  The fixed point is
    ``ω* = c √(4 (g/l) sin α sin γ / ((1 + κ)(1 − c²)))``, ``c = (cos 2α + κ)/(1 + κ)``, which for ``κ → 0`` is
    McGeer's ``cot 2α √(4 (g/l) sin α sin γ)`` (1.0949 rad/s for l = 1, g = 9.8, α = π/8, γ = 0.08).
    ``None`` for a touchdown not reached (the wheel stops and rocks back: ω0 too small)."""
    a = math.pi / spokes
    kap = inertia
    c = (math.cos(2 * a) + kap) / (1 + kap)
    gain = 4 * (g / length) * math.sin(a) * math.sin(slope) / (1 + kap)
    rates, w = [], omega0
    for _ in range(steps):
        w = c * math.sqrt(w * w + gain)
        rates.append(w)
    return np.array(rates), c * math.sqrt(gain / (1 - c * c))


def spring_ball_height(t, height: float, g: float, stiffness: float, mass: float, anchor: float, e: float, T: float):
    """The analytic height of the ball on a spring (dropped from rest at ``height``) at the times ``t``: harmonic
    flights between the impacts of :func:`spring_ball_oracle`.  ``(heights, impact times)``."""
    times, _ = spring_ball_oracle(height, 0.0, g, stiffness, mass, anchor, e, T)
    w, yeq = math.sqrt(stiffness / mass), anchor - mass * g / stiffness
    starts = np.concatenate([[0.0], times])
    y0s, v0s = [height], [0.0]
    for tk in times:  # the state after each impact
        tau = tk - starts[len(y0s) - 1]
        A, B = y0s[-1] - yeq, v0s[-1] / w
        v_hit = -A * w * math.sin(w * tau) + B * w * math.cos(w * tau)
        y0s.append(0.0)
        v0s.append(-e * v_hit)
    t = np.asarray(t, float)
    i = np.searchsorted(starts, t, side="right") - 1
    tau = t - starts[i]
    A, B = np.array(y0s)[i] - yeq, np.array(v0s)[i] / w
    return yeq + A * np.cos(w * tau) + B * np.sin(w * tau), times
