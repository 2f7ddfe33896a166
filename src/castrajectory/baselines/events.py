"""Event-driven reference for contact scenes whose free flight has a closed form.

The oracle of the contact battery and tests: exact flight between impacts, each impact located to
rounding and resolved by the impact law of :mod:`castrajectory.models.impact`.  It is a baseline,
not the library's method (which solves the whole trajectory at once, :mod:`castrajectory.solve`).

Scope.  Systems with a constant mass matrix and constant generalised forces (a rigid body under
uniform gravity: the ball, the rectangle over flat or curved ground), so that the flight is the
parabola ``q(t) = q + v t + ½ a t²`` with no integration error.  The gaps may be any expressions
of ``q`` (the bowl's curved ground included).

Events.  From each state the earliest crossing of a gap is found on the exact flight: a scan fine
enough to resolve the flight (``SCAN`` points per flight of a typical length, and at least one
per ``1e-3`` of a rotation), then bisection to rounding (``2⁻⁶⁰`` of the bracket).  Every contact
within ``CLOSE_TOL · ℓ`` of closing at that time and approaching (``J v < 0``) takes the impact:
one contact by :func:`~castrajectory.models.impact.impact_law`, several by the simultaneous law
:func:`~castrajectory.models.impact.simultaneous_impact` (``J v⁺ + e J v⁻ ≥ 0 ⟂ μ ≥ 0``).  A
cascade (corner A, then B, then A again within microseconds) is just a sequence of such events.

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

from ..models.impact import impact_law, simultaneous_impact
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
        return q + v * s + 0.5 * self.acceleration * s * s, v + self.acceleration * s


def _constant_dynamics(system: LagrangianSystem, q0: np.ndarray, v0: np.ndarray):
    """``(M, a)``, checked constant at a few states, or :class:`InputError`."""
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
            raise InputError("the event-driven reference needs a constant mass matrix and constant forces "
                             "(free flight in closed form)")
    return M0, a0


def event_driven(system: LagrangianSystem, q0, v0, T: float, max_events: int = 2000) -> EventDriven:
    """The event-driven reference of a contact scene over ``[0, T]`` (see the module doc)."""
    if system.contact is None:
        raise InputError("the event-driven reference needs a system with a contact term")
    q0 = np.asarray(q0, float).reshape(-1)
    v0 = np.asarray(v0, float).reshape(-1)
    M, a = _constant_dynamics(system, q0, v0)
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
        dt = min(t_char / SCAN, 1e-3 * ell / rate, rest)
        found = None
        s0 = 0.0
        while s0 < rest and found is None:
            s = np.unique(np.minimum(s0 + dt * np.arange(1, 4097), rest))
            Q = q[None, :] + s[:, None] * v[None, :] + 0.5 * (s * s)[:, None] * a[None, :]
            below = phis(Q) < -CLOSE_TOL * ell
            hit = np.where(below.any(axis=0))[0]
            if hit.size:
                i = int(hit[0])
                found = (s[i - 1] if i else s0, s[i], np.where(below[:, i])[0])
            s0 = s[-1]
        if found is None:
            break
        lo, hi, crossing = found
        scan_hi = hi

        def worst(s):
            Qs = q + v * s + 0.5 * a * s * s
            return float(np.min(phis(Qs[None, :])[crossing, 0]))

        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if worst(mid) < 0.0:
                hi = mid
            else:
                lo = mid
            if hi - lo <= 4e-16 * max(t + hi, 1.0):
                break
        s = hi
        qc = q + v * s + 0.5 * a * s * s
        vc = v + a * s
        phi, J = (np.asarray(x) for x in gap(qc))
        phi = phi.reshape(-1)
        vn = J @ vc
        take = np.where((phi <= CLOSE_TOL * ell) & (vn < 0))[0]
        if take.size == 0:  # no approaching contact at the crossing (rounding at a graze): go on past it
            if events and t + s - events[-1].t < 1e3 * MIN_FLIGHT * max(T, 1.0):
                # ... unless it follows an impact within a scan step: a flight below rounding, the end
                # of an accumulation
                reason, t_start = "accumulation", events[-1].t
                break
            s = scan_hi
            q, v, t = q + v * s + 0.5 * a * s * s, v + a * s, t + s
            continue
        if take.size == 1:
            imp = impact_law(M, J[take[0]], vc, e)
            mus, v_after = np.array([imp.mu]), imp.v_after
        else:
            mus, v_after = simultaneous_impact(M, J[take], vc, e)
        t_new = t + s
        if events and t_new - events[-1].t < MIN_FLIGHT * max(T, 1.0):
            reason, t_start = "accumulation", events[-1].t
            break
        events.append(Event(t_new, tuple(int(j) for j in take), mus, qc, vc, v_after))
        q, v, t = qc, v_after, t_new
        if len(events) >= max_events:
            reason, t_start = "accumulation", t_new
            break
    horizon = T if reason == "horizon" else t_start
    return EventDriven(success=True, status="ok", solver_status="ok", message=f"event-driven reference to "
                       f"t = {horizon:g} s ({reason}), {len(events)} impacts", iterations=0, build_time_s=0.0,
                       solve_time_s=0.0, events=events, q0=q0, v0=v0, acceleration=a, horizon=horizon,
                       reason=reason)
