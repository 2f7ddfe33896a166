"""Event-driven reference for contact scenes whose free flight has a closed form.

The oracle of the contact battery and tests: exact flight between impacts, each impact located to
rounding and resolved by the impact law of :mod:`castrajectory.models.impact`.  It is a baseline,
not the library's method (which solves the whole trajectory at once, :mod:`castrajectory.solve`).

Scope.  Systems with a constant mass matrix and constant generalised forces (a rigid body under
uniform gravity: the ball, the rectangle over flat or curved ground) fly the parabola
``q(t) = q + v t + ½ a t²`` with no integration error.  Any other system without holonomic constraints
(a pendulum against a joint limit, a double pendulum against a wall, Newton's cradle) flies by
Gragg–Bulirsch–Stoer extrapolation of order 16 (``FLIGHT_STEP`` per step, :func:`gbs_step`):
``NUMERIC_FLIGHT_ERROR`` (a pendulum's flight to a joint limit within 2e-14 rad, its impact times
within 1e-14 s of the elliptic quadrature) instead of rounding.  That integrator is explicit, with exact
rational coefficients, and independent of the library's schemes.  (CasADi's Gauss–Legendre collocation,
used before, carries its collocation points to about 1e-13: its error grew with the number of steps, to
2e-11 s on the pendulum's second impact.)  The gaps may be any
expressions of ``q`` (the bowl's curved ground included).

Events.  From each state the earliest crossing of a gap is found on the exact flight: a scan fine
enough to resolve the flight (``SCAN`` points per flight of a typical length, and at least one
per ``1e-3`` of a rotation), then bisection to rounding (``2⁻⁶⁰`` of the bracket).  Every contact
within ``CLOSE_TOL · ℓ`` of closing at that time and approaching (``J v < 0``) takes the impact:
one contact by :func:`~castrajectory.models.impact.impact_law`, several by the system's law
(``Contact.law``): the simultaneous law :func:`~castrajectory.models.impact.simultaneous_impact`
(``J v⁺ + e J v⁻ ≥ 0 ⟂ μ ≥ 0``) or the cascade :func:`~castrajectory.models.impact.sequential_impact`.  A
cascade in time (corner A, then B, then A again within microseconds) is just a sequence of such events.

Where it stops.  The reference holds up to ``horizon``: ``T``, or the start of an accumulation
(Zeno bouncing, a block rocking to rest: impacts closer than ``MIN_FLIGHT`` or more than
``max_events``), after which persistent contact follows, which the closed-form flight does not
model.  ``reason`` says which.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import List, Tuple

import casadi as ca
import numpy as np

from ..models.impact import impact_law, sequential_impact, simultaneous_impact
from ..models.mechanics import LagrangianSystem
from ..result import Result
from ..validation import InputError

#: Scan points per characteristic flight time (bisection refines each bracket to rounding).
SCAN = 2000
#: Contacts within this many length scales of closing at an impact take part in it.
CLOSE_TOL = 1e-9
#: Two impacts closer than this (seconds, relative to the horizon) start an accumulation.  (1e-9
#: let a Zeno sequence run on to flights of 6e-9 s, whose crossings the scan then stepped past as
#: grazes, and the reference went on from below the ground.)
MIN_FLIGHT = 1e-7
#: The largest time step of a numerical flight (seconds, relative to the characteristic time), and the
#: accuracy it reaches (Gragg–Bulirsch–Stoer of order 16; a pendulum's impact times to 1e-14 s).
FLIGHT_STEP = 5e-2
NUMERIC_FLIGHT_ERROR = 1e-13
#: The scan step of a numerical flight for gap crossings (relative to the characteristic time).
NUMERIC_SCAN = 1e-2


@dataclass
class Event:
    """One impact of the reference: time, the contacts that took an impulse, and the state."""

    t: float
    contacts: Tuple[int, ...]
    mu: np.ndarray
    q: np.ndarray
    v_before: np.ndarray
    v_after: np.ndarray


@dataclass(kw_only=True)
class EventDriven(Result):
    """The event-driven reference (see the module doc); ``horizon`` is where it holds up to."""

    events: List[Event] = field(default_factory=list)
    q0: np.ndarray = None
    v0: np.ndarray = None
    acceleration: np.ndarray = None
    horizon: float = 0.0
    reason: str = "horizon"
    #: the flight ``(q, v, s) -> (q, v)`` where it is not the closed-form parabola (else None)
    flight: object = None

    @property
    def times(self) -> np.ndarray:
        return np.array([ev.t for ev in self.events])

    def state(self, t: float):
        """``(q, v)`` at time ``t ≤ horizon`` (the exact flight from the last event before it)."""
        if t > self.horizon * (1 + 1e-12):
            raise ValueError(f"the reference holds up to t = {self.horizon:g} s ({self.reason})")
        q, v, t0 = self.q0, self.v0, 0.0
        for ev in self.events:
            if ev.t > t:
                break
            q, v, t0 = ev.q, ev.v_after, ev.t
        s = t - t0
        if self.flight is not None:
            return self.flight(q, v, s)
        return q + v * s + 0.5 * self.acceleration * s * s, v + self.acceleration * s


def _constant_dynamics(system: LagrangianSystem, q0: np.ndarray, v0: np.ndarray):
    """``(M, a)``, checked constant at a few states, or ``None``."""
    M0 = np.asarray(system.mass_matrix(q0))
    a0 = np.asarray(system.acceleration(q0, np.zeros_like(q0))).reshape(-1)
    rng = np.random.default_rng(0)
    for _ in range(3):
        dq = rng.standard_normal(q0.size) * (1.0 + np.abs(q0))
        dv = rng.standard_normal(q0.size) * (1.0 + np.abs(v0))
        M = np.asarray(system.mass_matrix(q0 + dq))
        a = np.asarray(system.acceleration(q0 + dq, v0 + dv)).reshape(-1)
        scale = 1.0 + float(np.max(np.abs(a0)))
        if np.max(np.abs(M - M0)) > 1e-12 * np.max(np.abs(M0)) or np.max(np.abs(a - a0)) > 1e-12 * scale:
            return None
    return M0, a0


#: The step numbers of the extrapolation's columns (Gragg–Bulirsch–Stoer: order 2 × 8 = 16).
GBS_STEPS = (2, 4, 6, 8, 10, 12, 14, 16)


def gbs_step(f, x, H, steps=GBS_STEPS):
    """One Gragg–Bulirsch–Stoer step of ``ẋ = f(x)`` over ``H`` (CasADi expressions): Gragg's modified
    midpoint rule with ``n_j`` substeps for each ``n_j`` of ``steps``, smoothed, and Aitken–Neville
    extrapolation in ``h²`` to order ``2 len(steps)``.  Its coefficients are exact rationals, so its error
    is truncation (far below rounding at the steps used) and rounding: a pendulum's flight to a joint limit
    lands within 2e-14 rad of the exact one whether it takes 3 or 300 steps."""
    T = []
    for nj in steps:
        hh = H / nj
        z0, z1 = x, x + hh * f(x)
        for _ in range(1, nj):
            z0, z1 = z1, z0 + 2 * hh * f(z1)
        T.append(0.5 * (z1 + z0 + hh * f(z1)))
    for k in range(1, len(T)):
        for j in range(len(T) - 1, k - 1, -1):
            T[j] = T[j] + (T[j] - T[j - 1]) / ((steps[j] / steps[j - k]) ** 2 - 1)
    return T[-1]


class _Flight:
    """A numerical flight ``(q, v, s) -> (q, v)``: Gragg–Bulirsch–Stoer extrapolation of order 16
    (:func:`gbs_step`) of ``q̈ = a(q, q̇)`` over ``s``, in pieces of at most ``FLIGHT_STEP · t_char``."""

    def __init__(self, system: LagrangianSystem, t_char: float):
        n = system.nq
        x, d = ca.SX.sym("x", 2 * n), ca.SX.sym("d")
        acc = system.acceleration
        self.F = ca.Function("flight", [x, d], [gbs_step(lambda z: ca.vertcat(z[n:], acc(z[:n], z[n:])), x, d)])
        self.n, self.dmax = n, FLIGHT_STEP * t_char

    def __call__(self, q, v, s):
        X = np.concatenate([q, v])
        pieces = max(1, int(math.ceil(s / self.dmax)))
        for _ in range(pieces):
            X = np.asarray(self.F(X, s / pieces)).reshape(-1)
        return X[:self.n], X[self.n:]


def event_driven(system: LagrangianSystem, q0, v0, T: float, max_events: int = 2000) -> EventDriven:
    """The event-driven reference of a contact scene over ``[0, T]`` (see the module doc)."""
    if system.contact is None:
        raise InputError("the event-driven reference needs a system with a contact term")
    q0 = np.asarray(q0, float).reshape(-1)
    v0 = np.asarray(v0, float).reshape(-1)
    const = _constant_dynamics(system, q0, v0)
    if const is None and system.nc:
        raise InputError("the event-driven reference integrates unconstrained coordinates: a system with "
                         "holonomic constraints needs a constant mass matrix and constant forces (closed-form flight)")
    M, a = const if const is not None else (None, np.asarray(system.acceleration(q0, v0)).reshape(-1))
    e = system.contact.restitution
    gap = system.gap
    c = system.contact.count
    phi_map = ca.Function("phi", [system.q], [ca.vertcat(*system.contact.gaps)])
    scan_fns = {}

    def phis(Q):  # gaps of many configurations (rows)
        k = Q.shape[0]
        if k not in scan_fns:
            scan_fns[k] = phi_map.map(k)
        return np.asarray(scan_fns[k](Q.T)).reshape(c, k)

    ell = max(1.0, float(np.max(np.abs(q0))))
    t_char = math.sqrt(2 * ell / max(float(np.max(np.abs(a))), 1e-12)) if np.any(a) else T
    flight = _Flight(system, min(t_char, T)) if const is None else None

    def fly(q, v, s):                 # the flight from (q, v) over s
        if flight is not None:
            return flight(q, v, s)
        return q + v * s + 0.5 * a * s * s, v + a * s
    q, v, t = q0.copy(), v0.copy(), 0.0
    events: List[Event] = []
    reason = "horizon"
    t_start = T
    while True:
        rest = T - t
        if rest <= 0:
            break
        # scan the exact flight for the earliest gap crossing, then bisect it to rounding
        rate = float(np.max(np.abs(v))) + 1e-300
        dt = min(t_char / SCAN, 1e-3 * ell / rate, rest) if flight is None else \
            min(NUMERIC_SCAN * t_char, 1e-2 * ell / rate, rest)
        found = None
        s0 = 0.0
        if flight is None:
            while s0 < rest and found is None:
                s = np.unique(np.minimum(s0 + dt * np.arange(1, 4097), rest))
                Q = q[None, :] + s[:, None] * v[None, :] + 0.5 * (s * s)[:, None] * a[None, :]
                below = phis(Q) < -CLOSE_TOL * ell
                hit = np.where(below.any(axis=0))[0]
                if hit.size:
                    i = int(hit[0])
                    found = (s[i - 1] if i else s0, s[i], np.where(below[:, i])[0])
                s0 = s[-1]
            base = (q, v, 0.0)
        else:
            # step by step along the numerical flight; the bracket's start state is kept, so the
            # bisection integrates only inside it
            qs_, vs_ = q, v
            while s0 < rest and found is None:
                d = min(dt, rest - s0)
                qn_, vn_ = flight(qs_, vs_, d)
                below = phis(qn_[None, :])[:, 0] < -CLOSE_TOL * ell
                if np.any(below):
                    found = (0.0, d, np.where(below)[0])
                    base = (qs_, vs_, s0)
                else:
                    qs_, vs_ = qn_, vn_
                s0 += d
        if found is None:
            break
        lo, hi, crossing = found
        # the bracket [lo, hi] is measured from the base state (qb, vb), which lies sb after (q, v)
        qb, vb, sb = base

        def worst(s):
            return float(np.min(phis(fly(qb, vb, s)[0][None, :])[crossing, 0]))
        scan_hi = hi
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if worst(mid) < 0.0:
                hi = mid
            else:
                lo = mid
            if hi - lo <= 4e-16 * max(t + sb + hi, 1.0):
                break
        qc, vc = fly(qb, vb, hi)
        s = sb + hi
        Mc = M if M is not None else np.asarray(system.mass_matrix(qc))
        phi, J = (np.asarray(x) for x in gap(qc))
        phi = phi.reshape(-1)
        vn = J @ vc
        closed = phi <= CLOSE_TOL * ell
        # the contacts that approach take the impact, and with them every closed contact that does not
        # separate (a row of touching balls carries the impact on: the law decides how)
        take = np.where(closed & (vn <= 0))[0] if np.any(closed & (vn < 0)) else np.zeros(0, dtype=int)
        if take.size == 0:  # no approaching contact at the crossing (rounding at a graze): go on past it
            if events and t + s - events[-1].t < 1e3 * MIN_FLIGHT * max(T, 1.0):
                # ... unless it follows an impact within a scan step: a flight below rounding, the end
                # of an accumulation
                reason, t_start = "accumulation", events[-1].t
                break
            q, v = fly(qb, vb, scan_hi)
            t = t + sb + scan_hi
            continue
        if take.size == 1:
            imp = impact_law(Mc, J[take[0]], vc, e)
            mus, v_after = np.array([imp.mu]), imp.v_after
        elif system.contact.law == "sequential":
            MiJt = np.linalg.solve(Mc, J[take].T)
            mus, _ = sequential_impact(J[take] @ MiJt, J[take] @ vc, e)
            v_after = vc + MiJt @ mus
        else:
            mus, v_after = simultaneous_impact(Mc, J[take], vc, e)
        t_new = t + s
        if events and t_new - events[-1].t < MIN_FLIGHT * max(T, 1.0):
            reason, t_start = "accumulation", events[-1].t
            break
        keep = (mus > 0.0) | (vn[take] < 0)        # a closed contact that took no impulse is not listed
        take, mus = take[keep], mus[keep]
        events.append(Event(t_new, tuple(int(j) for j in take), mus, qc, vc, v_after))
        q, v, t = qc, v_after, t_new
        if len(events) >= max_events:
            reason, t_start = "accumulation", t_new
            break
    horizon = T if reason == "horizon" else t_start
    return EventDriven(success=True, status="ok", solver_status="ok", message=f"event-driven reference to "
                       f"t = {horizon:g} s ({reason}), {len(events)} impacts", iterations=0, build_time_s=0.0,
                       solve_time_s=0.0, events=events, q0=q0, v0=v0, acceleration=a, horizon=horizon,
                       reason=reason, flight=flight)
