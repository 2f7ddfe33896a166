"""The impact law: Newton's restitution for one contact and for several at once.

One law for the whole package (the guesses, the oracles, the checks of a solution, the scenes):

* one contact (:func:`impact_law`; :func:`resolve_impact` checks its arguments first): the impulse acts
  along ``M⁻¹Jᵀ``, ``v⁺ = v⁻ + μ M⁻¹Jᵀ`` with ``μ = −(1 + e) J v⁻ / (J M⁻¹ Jᵀ)`` when the contact
  approaches (``J v⁻ < 0``), ``μ = 0`` otherwise; ``J v⁺ = −e J v⁻``, and for ``e = 1`` the kinetic
  energy is kept (``ΔK = μ (J v⁻ + ½ μ J M⁻¹ Jᵀ)`` vanishes at that ``μ``);
* several contacts at the same instant (:func:`simultaneous_impact`): ``J v⁺ + e J v⁻ ≥ 0 ⟂ μ ≥ 0``,
  ``v⁺ = v⁻ + M⁻¹Jᵀμ``, by projected Gauss–Seidel;
* several contacts one after the other (:func:`sequential_impact`): the cascade, each firing the one-contact
  law on the contact approaching fastest at that moment, until none approaches -- the limit of vanishing
  gaps between the contacts (Newton's cradle: the last ball leaves, the others stop).

The derivation is in ``docs/derivations.md`` (Collisions, §3).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import casadi as ca
import numpy as np

from .mechanics import LagrangianSystem
from ..validation import InputError, finite


def restitution(value) -> float:
    """Restitution coefficient ``e ∈ [0, 1]`` (checked; the one check of a user's ``e``)."""
    e = finite("restitution", value)
    if not 0.0 <= e <= 1.0:
        raise InputError(f"restitution must be between 0 and 1 (got {value})")
    return e


def _finite_vector(name: str, value, n: Optional[int] = None) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a vector of numbers (got {value!r})") from None
    if n is not None and v.size != n:
        raise InputError(f"{name} must have {n} components (got {v.size})")
    if not np.all(np.isfinite(v)):
        raise InputError(f"{name} must be finite (got {v.tolist()})")
    return v


@dataclass
class Impact:
    """One resolved impact: ``v⁺ = v⁻ + μ M⁻¹Jᵀ``."""

    mu: float
    v_before: np.ndarray
    v_after: np.ndarray
    direction: np.ndarray          # M⁻¹Jᵀ, the velocity change per unit μ
    jacobian: np.ndarray           # J = ∂gap/∂q
    ke_before: float
    ke_after: float
    restitution: float

    @property
    def normal_velocity_before(self) -> float:
        return float(self.jacobian @ self.v_before)

    @property
    def normal_velocity_after(self) -> float:
        return float(self.jacobian @ self.v_after)


def resolve_impact(M, J, v_before, e: float) -> Impact:
    """Impulsive contact of a system with mass matrix ``M`` and contact-gap gradient ``J``.

    ``M`` (n × n, symmetric positive definite) and ``J`` (n, or 1 × n) are
    numbers, for example ``LagrangianSystem.mass_matrix(q)`` and the Jacobian
    of a gap at ``q`` (see :func:`system_impact`).  The impulse acts along
    ``M⁻¹Jᵀ`` with ``μ = −(1 + e) J v⁻ / (J M⁻¹ Jᵀ)`` when the contact is
    approaching (``J v⁻ < 0``), and ``μ = 0`` otherwise.  Checks its arguments once and
    applies :func:`impact_law`.
    """
    e = restitution(e)
    v = _finite_vector("velocity", v_before)
    n = v.size
    try:
        M = np.asarray(M, dtype=float)
    except (TypeError, ValueError):
        raise InputError("mass matrix must be a matrix of numbers") from None
    if M.shape != (n, n):
        raise InputError(f"mass matrix must be {n} x {n} to match the velocity (got shape {M.shape})")
    if not np.all(np.isfinite(M)):
        raise InputError("mass matrix must be finite")
    if not np.allclose(M, M.T, rtol=1e-12, atol=0.0):
        raise InputError("mass matrix must be symmetric")
    try:
        np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        raise InputError("mass matrix must be positive definite") from None
    J = _finite_vector("contact Jacobian", J, n)
    if not np.any(J != 0.0):
        raise InputError("contact Jacobian must be nonzero")
    return impact_law(M, J, v, e)


def impact_law(M: np.ndarray, J: np.ndarray, v: np.ndarray, e: float) -> Impact:
    """Newton's law for one contact, on values already checked (``M`` SPD, ``J ≠ 0``, ``e ∈ [0, 1]``):
    ``μ = −(1 + e) J v⁻ / (J M⁻¹ Jᵀ)`` when approaching, ``v⁺ = v⁻ + μ M⁻¹Jᵀ``."""
    chol = np.linalg.cholesky(M)
    direction = np.linalg.solve(chol.T, np.linalg.solve(chol, J))   # M⁻¹Jᵀ
    a = float(J @ direction)                                         # J M⁻¹ Jᵀ
    vn = float(J @ v)
    mu = -(1.0 + e) * vn / a if vn < 0.0 else 0.0
    v_after = v + mu * direction if mu > 0.0 else v.copy()
    return Impact(mu, v, v_after, direction, J, 0.5 * float(v @ M @ v), 0.5 * float(v_after @ M @ v_after), e)


def system_impact(system: LagrangianSystem, gap, q, v_before, e: float) -> Impact:
    """:func:`resolve_impact` for a :class:`LagrangianSystem` and a gap expression ``gap(system.q) ≥ 0``."""
    qv = _finite_vector("q", q, system.nq)
    J = ca.Function("J", [system.q], [ca.densify(ca.jacobian(gap, system.q))])
    return resolve_impact(np.asarray(system.mass_matrix(qv)), np.asarray(J(qv)).reshape(-1), v_before, e)


def simultaneous_impact(M, J, v, e, sweeps: int = 200):
    """Newton's law at several contacts at once: ``J v⁺ + e J v⁻ ≥ 0 ⟂ μ ≥ 0``, ``v⁺ = v⁻ + M⁻¹Jᵀμ`` (PGS)."""
    MiJt = np.linalg.solve(M, J.T)
    W = J @ MiJt
    target = -e * (J @ v)
    mu = np.zeros(J.shape[0])
    for _ in range(sweeps):
        for i in range(mu.size):
            r = J[i] @ (v + MiJt @ mu) - target[i]
            mu[i] = max(0.0, mu[i] - r / W[i, i])
    return mu, v + MiJt @ mu


def sequential_impact(W: np.ndarray, vn: np.ndarray, e: float, max_firings: int = 100000):
    """The cascade of one-contact impacts, in the contacts' normal velocities: ``W = J Π Jᵀ`` (the
    inverse effective mass, ``Π = M⁻¹`` or its restriction to the constraints), ``vn = J v⁻``.  While some
    contact approaches (``vn_i < 0``, beyond rounding), the fastest one fires ``Newton's law`` on its own,
    ``δμ_i = −(1 + e) vn_i / W_ii`` and ``vn += W[:, i] δμ_i``.  Returns ``(μ, vn⁺)``.

    For ``e = 1`` each firing keeps the kinetic energy, for ``e < 1`` loses some, so the cascade ends;
    equal balls in a row, the first at speed V: ``vn⁺`` sends the last off at V and stops the others."""
    vn = np.asarray(vn, float).copy()
    mu = np.zeros(vn.size)
    floor = 1e-14 * max(float(np.max(np.abs(vn))), 1e-300)
    for _ in range(max_firings):
        i = int(np.argmin(vn))
        if vn[i] >= -floor:
            return mu, vn
        d = -(1.0 + e) * vn[i] / W[i, i]
        mu[i] += d
        vn += W[:, i] * d
    raise RuntimeError(f"the impact cascade did not end within {max_firings} firings")



@dataclass
class FrictionalImpact:
    """One contact's impact with Coulomb friction (:func:`frictional_impact`): the normal and tangential
    impulses, the contact's velocities ``(w_n, w_t)`` after, the normal work of compression and of
    restitution (``W_r = −e² W_c``), and whether the contact point sticks at the end."""

    P: np.ndarray
    w_after: np.ndarray
    work_compression: float
    work_restitution: float
    sticks: bool
    phases: int


def frictional_impact(G, w_before, mu: float, e: float, max_phases: int = 16) -> FrictionalImpact:
    """A planar impact of one contact with Coulomb friction and Stronge's energetic restitution, by
    Darboux–Keller integration in the normal impulse ``p``.

    ``G`` is the contact's 2 × 2 Delassus matrix (normal, tangent: ``W Π Wᵀ`` for the rows ``W = [∇φ; D]``),
    ``w_before = (w_n < 0, w_t)`` its velocities before.  Along the impact ``dw = G (1, r) dp`` with the
    friction ratio ``r = dP_t/dp``: ``−μ sgn(w_t)`` while the contact point slides, ``−G_nt/G_tt`` while it
    sticks (when that lies in the cone; otherwise it slides on, in the direction ``sgn G_nt``).  Between the
    events (the slip stops, the compression ends at ``w_n = 0``) every quantity is linear or quadratic in
    ``p``, so each phase is exact.  The impact ends when the normal impulse's work in restitution is
    ``−e²`` times its work in compression (Stronge 1990).

    The kinetic energy changes by ``∫ wᵀdP = W_c (1 − e²) + ∫ w_t dP_t``, and the friction's work is never
    positive (it opposes the slip or the slip is zero): an impact never gains energy, also where the
    normal and tangential directions are coupled (``G_nt ≠ 0``), where Newton's kinematic law with Coulomb
    friction can (Kane and Levinson's double pendulum).  Without coupling it is Newton's law with
    Coulomb's: a ball with spin leaves rolling iff the impulse that stops its slip fits in ``μ (1 + e) |m v_n|``.
    """
    G = np.asarray(G, float).reshape(2, 2)
    w = np.asarray(w_before, float).reshape(2).copy()
    mu, e = float(mu), float(e)
    if not w[0] < 0.0:
        return FrictionalImpact(np.zeros(2), w, 0.0, 0.0, abs(w[1]) == 0.0, 0)
    Gnn, Gnt, Gtt = G[0, 0], G[0, 1], G[1, 1]
    scale = abs(w[0]) + abs(w[1])
    tol = 1e-14 * scale
    P = np.zeros(2)
    W = 0.0                      # ∫ w_n dp so far
    Wc = None                    # the compression's work, once it has ended
    for phase in range(1, max_phases + 1):
        slide = abs(w[1]) > tol
        if slide:
            s = np.sign(w[1])
            r = -mu * s
        elif Gtt > 0 and abs(Gnt) <= mu * Gtt:
            s, r = 0.0, -Gnt / Gtt          # sticking: the slip stays zero
            w[1] = 0.0
        else:
            s = np.sign(Gnt) if Gnt != 0 else 1.0
            r = -mu * s                     # the slip restarts, in the direction the coupling drives it
            slide = True
        an, at = Gnn + Gnt * r, Gnt + Gtt * r
        ends = []
        if slide and at * s < 0:                       # the slip stops
            ends.append((-w[1] / at, "stop"))
        if Wc is None:
            if an > 0:
                ends.append((-w[0] / an, "compressed"))
        else:
            # W + w_n d + ½ a_n d² = (1 − e²) W_c: the restitution's work reaches −e² W_c
            target = (1.0 - e * e) * Wc - W          # the work still to come (≥ 0)
            if target <= 0.0:
                ends.append((0.0, "done"))
            elif an == 0.0:
                ends.append((target / max(w[0], 1e-300), "done"))
            else:
                disc = w[0] * w[0] + 2.0 * an * target
                # (a_n < 0 with too little approach left: the separation stops first, w_n = 0, and there it ends)
                ends.append(((-w[0] + np.sqrt(disc)) / an if disc >= 0.0 else -w[0] / an, "done"))
        if not ends:
            raise RuntimeError("the impact jams: the approach grows while the contact slides (a Painlevé-type "
                               "impact, outside rigid-body impact laws)")
        d, what = min(ends, key=lambda x: x[0])
        d = max(d, 0.0)
        W += w[0] * d + 0.5 * an * d * d
        P += np.array([1.0, r]) * d
        w = w + np.array([an, at]) * d
        if what == "stop":
            w[1] = 0.0
        elif what == "compressed":
            w[0] = 0.0
            Wc = W
            if e == 0.0:
                return FrictionalImpact(P, w, Wc, 0.0, abs(w[1]) <= tol, phase)
        elif what == "done":
            return FrictionalImpact(P, w, Wc, W - Wc, abs(w[1]) <= tol, phase)
    raise RuntimeError(f"the frictional impact did not end within {max_phases} phases")


def sequential_frictional_impact(G: np.ndarray, w: np.ndarray, mu, e: float, max_firings: int = 100000):
    """The cascade of one-contact impacts (:func:`sequential_impact`) with friction: each firing is
    :func:`frictional_impact` on the contact approaching fastest, with its own 2 × 2 block of the Delassus
    matrix ``G`` of the rows ``[∇φ_1..∇φ_k; D_1..D_k]`` (normals first, then the tangents), and moves every
    contact's velocities ``w`` (same order) by ``G`` times its impulse.  Returns the normal and tangential
    impulses per contact.  Each firing never gains energy, so neither does the cascade."""
    w = np.asarray(w, float).copy()
    k = w.size // 2
    mu = np.broadcast_to(np.asarray(mu, float), (k,))
    Pn, Pt = np.zeros(k), np.zeros(k)
    floor = 1e-14 * max(float(np.max(np.abs(w[:k]))), 1e-300)
    for _ in range(max_firings):
        i = int(np.argmin(w[:k]))
        if w[i] >= -floor:
            return Pn, Pt
        idx = [i, k + i]
        imp = frictional_impact(G[np.ix_(idx, idx)], w[idx], mu[i], e)
        Pn[i] += imp.P[0]
        Pt[i] += imp.P[1]
        w += G[:, idx] @ imp.P
    raise RuntimeError(f"the impact cascade did not end within {max_firings} firings")


def frictional_impact_plane(G, w_before, mu: float, e: float, steps: int = 400) -> FrictionalImpact:
    """:func:`frictional_impact` on a tangent plane (3-D contact: ``G`` 3 × 3 for the normal and two
    orthonormal tangents, ``w_before = (w_n < 0, w_t1, w_t2)``): Darboux–Keller integration in the normal
    impulse with the isotropic cone, ``r = −μ w_t/|w_t|`` while the contact point slides (its direction turns
    where the directions couple), ``r = −G_tt⁻¹G_tn`` while it sticks (if inside the cone).  Sliding is
    integrated by RK4 in ``p`` (``steps`` per compression, halving towards a stop so that the slip reaches
    zero geometrically, and each end -- compression, restitution -- bisected to rounding); sticking and an
    uncoupled slide are linear, so exact.  Stronge's end and the energy identity as in the planar law."""
    G = np.asarray(G, float).reshape(3, 3)
    w = np.asarray(w_before, float).reshape(3).copy()
    mu, e = float(mu), float(e)
    if not w[0] < 0.0:
        return FrictionalImpact(np.zeros(3), w, 0.0, 0.0, float(np.linalg.norm(w[1:])) == 0.0, 0)
    scale = float(np.max(np.abs(w)))
    tol = 1e-14 * scale
    Gtt, Gtn = G[1:, 1:], G[1:, 0]
    r_stick = -np.linalg.solve(Gtt, Gtn)
    can_stick = float(np.linalg.norm(r_stick)) <= mu * (1 + 1e-12)

    def ratio(wt):
        n = float(np.linalg.norm(wt))
        if n > tol:
            return -mu * wt / n
        if can_stick:
            return r_stick
        # the slip restarts where the coupling drives it: the direction s with s ∥ G_tn − μ G_tt s (fixed point)
        s = Gtn / max(float(np.linalg.norm(Gtn)), 1e-300)
        for _ in range(100):
            v = Gtn - mu * Gtt @ s
            s = v / max(float(np.linalg.norm(v)), 1e-300)
        return -mu * s

    def rate(y):          # y = (w (3), W, P_t (2)); d/dp
        r = ratio(y[1:3])
        dw = G @ np.concatenate([[1.0], r])
        return np.concatenate([dw, [y[0]], r])

    def rk4(y, dp):
        k1 = rate(y)
        k2 = rate(y + 0.5 * dp * k1)
        k3 = rate(y + 0.5 * dp * k2)
        k4 = rate(y + dp * k3)
        return y + dp / 6 * (k1 + 2 * k2 + 2 * k3 + k4)

    y = np.concatenate([w, [0.0], [0.0, 0.0]])
    p, Wc = 0.0, None
    for _ in range(1000 * steps):
        wt = y[1:3]
        nt = float(np.linalg.norm(wt))
        sticking = nt <= tol and can_stick
        if sticking:
            y[1:3] = 0.0
        # a step that changes the contact's velocities by a 1/steps-th of their size (sticking and an uncoupled
        # slide are linear in p, which RK4 integrates exactly; a turning slip to its own truncation)
        speed = float(np.linalg.norm(rate(y)[:3]))
        dp = (float(np.linalg.norm(y[:3])) + 1e-3 * scale) / max(speed, 1e-300) / steps
        if not sticking and nt > tol:
            # towards a stop: at most half the slip per step (the slip then reaches zero geometrically)
            dt = rate(y)[1:3]
            closing = -float(wt @ dt) / nt
            if closing > 0:
                dp = min(dp, 0.5 * nt / closing)

        def end(yy):      # > 0 once the phase's end is passed
            return yy[0] if Wc is None else yy[3] - (1.0 - e * e) * Wc
        yn = rk4(y, dp)
        if end(yn) >= 0.0 and not (Wc is not None and e == 0.0):
            lo, hi = 0.0, dp
            for _ in range(200):
                mid = 0.5 * (lo + hi)
                if end(rk4(y, mid)) >= 0.0:
                    hi = mid
                else:
                    lo = mid
                if hi - lo <= 1e-16 * max(p + hi, 1e-300):
                    break
            y, p = rk4(y, hi), p + hi
            if Wc is None:
                y[0] = 0.0
                Wc = float(y[3])
                if e == 0.0:
                    return FrictionalImpact(np.concatenate([[p], y[4:6]]), y[:3], Wc, 0.0,
                                            float(np.linalg.norm(y[1:3])) <= tol, 1)
                continue
            return FrictionalImpact(np.concatenate([[p], y[4:6]]), y[:3], Wc, float(y[3]) - Wc,
                                    float(np.linalg.norm(y[1:3])) <= tol, 1)
        y, p = yn, p + dp
        if not sticking and float(np.linalg.norm(y[1:3])) <= tol:
            y[1:3] = 0.0
    raise RuntimeError("the frictional impact on a tangent plane did not end")
