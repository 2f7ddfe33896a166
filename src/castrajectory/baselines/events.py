"""Event-driven reference for contact scenes: impacts, persistent contact and Coulomb friction.

The oracle of the contact battery and tests: exact flight between events, each event located to
rounding and resolved by the impact law of :mod:`castrajectory.models.impact`.  It is a baseline,
not the library's method (which solves the whole trajectory at once, :mod:`castrajectory.solve`).

Scope.  Systems with a constant mass matrix and constant generalised forces (a rigid body under
uniform gravity: the ball, the rectangle over flat or curved ground) fly the parabola
``q(t) = q + v t + ½ a t²`` with no integration error.  Any other system without holonomic constraints, and every
phase of persistent contact whose acceleration is not constant (a pendulum against a joint limit, a double pendulum against a wall, Newton's cradle) flies by
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

Persistent contact and Coulomb friction (:mod:`castrajectory.baselines.phases`).  Between the impacts a contact
that is closed and at rest in the normal direction may be held: the motion is then a phase of the index-1
contact dynamics (held contacts sticking, or sliding against the friction ``μ λ``), flown by the same
extrapolation (or the parabola, where the phase's acceleration is constant: a block or a wheel on a flat floor).
A phase ends at the first of its events, located like the impacts: an impact of an open contact, a held contact's
normal force reaching zero (``"lift-off"``), a slip reaching zero (``"stop"``: sticking or reversing, the
sliding-to-rolling transition), a sticking force reaching the cone (``"slip"``), or a contact arriving at rest
(``"arrival"``); the next phase is the consistent one (:func:`~castrajectory.baselines.phases.select`).  An
impact with friction at one contact is Stronge's law (:func:`~castrajectory.models.impact.frictional_impact`);
held contacts that it lifts take no impulse (the rimless wheel's old spoke).  Friction here is planar.

Where it stops.  The reference holds up to ``horizon``: ``T``, or the start of an accumulation (Zeno bouncing,
a block rocking to rest: impacts closer than ``MIN_FLIGHT`` or more than ``max_events``), or where rigid-body
theory has no single answer: an impact that several contacts with friction take under the simultaneous law,
contact modes that are all consistent with different motions or none consistent (Painlevé), a statically
indeterminate set of held contacts.  ``reason`` says which.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import List, Tuple

import casadi as ca
import numpy as np

from ..models.impact import (frictional_impact, impact_law, sequential_frictional_impact, sequential_impact,
                             simultaneous_impact)
from ..models.mechanics import LagrangianSystem
from ..result import Result
from ..validation import InputError
from .phases import OPEN, Parts, Phase, Signature, select

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
    #: the tangential impulses (friction) of the contacts that took the impact
    tangential: np.ndarray = None
    #: whether friction acted (Stronge's law); False for a frictionless law
    frictional: bool = False


#: Velocities within this fraction of the state's speed scale count as zero: a contact at rest in the normal
#: direction (persistent contact may begin), a contact point at rest (it may stick).
SWITCH_TOL = 1e-9


@dataclass
class Switch:
    """A switch of the persistent contact: at ``t`` contact ``contact`` ``"stop"``s slipping, starts to
    ``"slip"`` from sticking, ``"lift-off"``s, or touches down at rest (``"arrival"``); ``mode`` is its mode
    before (:mod:`castrajectory.baselines.phases`)."""

    t: float
    kind: str
    contact: int
    q: np.ndarray
    v: np.ndarray
    mode: str


@dataclass(kw_only=True)
class EventDriven(Result):
    """The event-driven reference (see the module doc); ``horizon`` is where it holds up to."""

    events: List[Event] = field(default_factory=list)
    switches: List[Switch] = field(default_factory=list)
    #: the pieces of the motion: ``(t0, q, v, flight, phase)``, each flown from its start
    segments: list = field(default_factory=list)
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
        """``(q, v)`` at time ``t ≤ horizon`` (the exact flight of the phase that holds at ``t``)."""
        if t > self.horizon * (1 + 1e-12):
            raise ValueError(f"the reference holds up to t = {self.horizon:g} s ({self.reason})")
        t0, q, v, fly, _ = self.segments[0]
        for seg in self.segments[1:]:
            if seg[0] > t:
                break
            t0, q, v, fly, _ = seg
        return fly(q, v, t - t0)

    def switch_times(self, kind: str, contact: int = None) -> np.ndarray:
        """The times of the persistent contact's switches of one kind (``"stop"``: a slip ends, the
        sliding-to-rolling transition; ``"slip"``, ``"lift-off"``, ``"arrival"``), of one contact or all."""
        return np.array([s.t for s in self.switches if s.kind == kind and (contact is None or s.contact == contact)])


def _constant(fn, q0: np.ndarray, v0: np.ndarray):
    """``fn(q0, v0)`` where ``fn`` takes the same value at a few other states, else ``None``."""
    x0 = np.asarray(fn(q0, v0))
    rng = np.random.default_rng(0)
    for _ in range(3):
        dq = rng.standard_normal(q0.size) * (1.0 + np.abs(q0))
        dv = rng.standard_normal(q0.size) * (1.0 + np.abs(v0))
        if np.max(np.abs(np.asarray(fn(q0 + dq, v0 + dv)) - x0)) > 1e-12 * (1.0 + float(np.max(np.abs(x0)))):
            return None
    return x0


def _constant_acceleration(dyn: ca.Function, q0: np.ndarray, v0: np.ndarray):
    """A phase's acceleration where it is the same at a few states (a body sliding or rolling on a flat floor
    under gravity: then its flight is the exact parabola), else ``None``."""
    a = _constant(dyn, q0, v0)
    return None if a is None else a.reshape(-1)


def _constant_dynamics(system: LagrangianSystem, q0: np.ndarray, v0: np.ndarray):
    """``(M, a)``, checked constant at a few states, or ``None``."""
    M = _constant(lambda q, v: system.mass_matrix(q), q0, v0)
    a = _constant(system.acceleration, q0, v0)
    return None if M is None or a is None else (M, a.reshape(-1))


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
    (:func:`gbs_step`) of ``q̈ = a(q, q̇)`` (a CasADi function) over ``s``, in pieces of at most
    ``FLIGHT_STEP · t_char``."""

    def __init__(self, acc: ca.Function, n: int, t_char: float):
        x, d = ca.MX.sym("x", 2 * n), ca.MX.sym("d")
        self.F = ca.Function("flight", [x, d], [gbs_step(lambda z: ca.vertcat(z[n:], acc(z[:n], z[n:])), x, d)])
        self.n, self.dmax = n, FLIGHT_STEP * t_char

    def __call__(self, q, v, s):
        X = np.concatenate([q, v])
        pieces = max(1, int(math.ceil(s / self.dmax)))
        for _ in range(pieces):
            X = np.asarray(self.F(X, s / pieces)).reshape(-1)
        return X[:self.n], X[self.n:]


class _Parabola:
    """The closed-form flight of constant dynamics: ``q + v s + ½ a s²``."""

    def __init__(self, a):
        self.a = a

    def __call__(self, q, v, s):
        return q + v * s + 0.5 * self.a * s * s, v + self.a * s


def _one_law(M, J, D, vc, j, mu, e):
    """One contact's impact: Newton's law, or with friction Stronge's (normal impulse, tangential, v_after)."""
    if mu > 0.0:
        W = np.vstack([J[j], D[j]])
        MiW = np.linalg.solve(M, W.T)
        imp = frictional_impact(W @ MiW, W @ vc, mu, e)
        return imp.P[0], imp.P[1], vc + MiW @ imp.P
    imp = impact_law(M, J[j], vc, e)
    return imp.mu, 0.0, imp.v_after


def _impact(system, M, J, D, vc, take, approach, e):
    """The impact taken by the contacts ``take`` (closed, not separating) at velocity ``vc``, of which
    ``approach`` (a mask on ``take``) approach: ``(normal impulses, tangential impulses, v_after, frictional)``.

    Where one contact approaches, its own law (Newton's, or with friction Stronge's,
    :func:`~castrajectory.models.impact.frictional_impact`) is the impact if every other closed contact then
    separates or stays at rest (a held contact the impact lifts: the rimless wheel's old spoke).  Otherwise the
    system's law over all of them: the simultaneous law (frictionless, as the library's march resolves it; with
    friction where one contact alone takes an impulse) or the cascade (with friction, each firing Stronge's)."""
    mu = np.asarray(system.contact.friction, float)[take]
    zeros = np.zeros(take.size)
    tol = 1e-12 * max(1.0, float(np.max(np.abs(J[take] @ vc))))
    if np.count_nonzero(approach) == 1:
        i = int(np.flatnonzero(approach)[0])
        pn, pt, v1 = _one_law(M, J, D, vc, take[i], mu[i], e)
        if np.all(J[take] @ v1 >= -tol):
            out_n, out_t = zeros.copy(), zeros.copy()
            out_n[i], out_t[i] = pn, pt
            return out_n, out_t, v1, bool(mu[i] > 0.0)
    if system.contact.law == "sequential":
        if np.any(mu > 0):
            W = np.vstack([J[take], D[take]])
            MiW = np.linalg.solve(M, W.T)
            Pn, Pt = sequential_frictional_impact(W @ MiW, W @ vc, mu, e)
            return Pn, Pt, vc + MiW @ np.concatenate([Pn, Pt]), True
        MiJt = np.linalg.solve(M, J[take].T)
        mus, _ = sequential_impact(J[take] @ MiJt, J[take] @ vc, e)
        return mus, zeros, vc + MiJt @ mus, False
    mus, v_after = simultaneous_impact(M, J[take], vc, e)
    if np.count_nonzero(mus > 0.0) == 1 and mu[mus > 0.0][0] > 0.0:
        # one contact takes the whole impact: its law with friction, if the others stay closed
        i = int(np.flatnonzero(mus > 0.0)[0])
        pn, pt, v1 = _one_law(M, J, D, vc, take[i], mu[i], e)
        if np.all(J[take] @ v1 >= -tol):
            out_n, out_t = zeros.copy(), zeros.copy()
            out_n[i], out_t[i] = pn, pt
            return out_n, out_t, v1, True
    if np.any(mu[mus > 0.0] > 0.0):
        return None          # several contacts with friction take it: no classical law (the reference stops)
    return mus, zeros, v_after, False


def event_driven(system: LagrangianSystem, q0, v0, T: float, max_events: int = 2000) -> EventDriven:
    """The event-driven reference of a contact scene over ``[0, T]`` (see the module doc)."""
    if system.contact is None:
        raise InputError("the event-driven reference needs a system with a contact term")
    if system.time_dependent:
        raise InputError("the event-driven reference integrates autonomous systems (no time in L or the forces)")
    friction = np.asarray(system.contact.friction, float)
    if np.any(friction > 0) and system.contact.slip_dim != 1:
        raise InputError("the event-driven reference's friction is planar (one slip component per contact)")
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
    t_char = min(t_char, T)
    parts = Parts(system)
    gap_floor = CLOSE_TOL * ell
    a_scale = max(float(np.max(np.abs(a))), ell / t_char ** 2)
    phases = {}

    def phase(sig):
        if sig not in phases:
            ph = Phase(parts, sig, gap_floor)
            acc = _constant_acceleration(ph.dyn, q0, v0)
            ph.fly = _Parabola(acc) if acc is not None else _Flight(ph.dyn, system.nq, t_char)
            ph.offsets = np.array([gap_floor if k == "impact" else 0.0 for k, _ in ph.kinds])
            phases[sig] = ph
        return phases[sig]
    free = Signature(tuple(OPEN for _ in range(c)))
    parabola = _Parabola(a) if const is not None else None
    flight = None if const is not None else phase(free).fly

    q, v, t = q0.copy(), v0.copy(), 0.0
    events: List[Event] = []
    switches: List[Switch] = []
    segments = []
    reason = "horizon"
    t_start = T
    exclude = None
    while True:
        rest = T - t
        if rest <= 0:
            break
        v_tol = SWITCH_TOL * max(float(np.max(np.abs(v))), ell / t_char)
        choice = select(parts, q, v, 10 * gap_floor, v_tol, a_scale, exclude)
        exclude = None
        if choice.sig is None:
            reason, t_start = choice.reason, t
            break
        sig = choice.sig
        if system.nc and sig != free:
            reason, t_start = "persistent contact with holonomic constraints (not modelled)", t
            break
        ph = phase(sig)
        fly = parabola if (sig == free and parabola is not None) else ph.fly
        segments.append((t, q, v, fly, sig))
        # scan for the earliest event, then bisect it to rounding
        rate = float(np.max(np.abs(v))) + 1e-300
        found = None
        s0 = 0.0
        if fly is parabola:
            dt = min(t_char / SCAN, 1e-3 * ell / rate, rest)
            while s0 < rest and found is None:
                s = np.unique(np.minimum(s0 + dt * np.arange(1, 4097), rest))
                Q = q[None, :] + s[:, None] * v[None, :] + 0.5 * (s * s)[:, None] * a[None, :]
                below = phis(Q) < -gap_floor
                hit = np.where(below.any(axis=0))[0]
                if hit.size:
                    i = int(hit[0])
                    found = (s[i - 1] if i else s0, s[i], np.where(below[:, i])[0])
                s0 = s[-1]
            base = (q, v, 0.0)
            offsets = np.full(c, 0.0)

            def values(qq, vv):
                return phis(qq[None, :])[:, 0]
        else:
            # step by step along the numerical flight; the bracket's start state is kept, so the
            # bisection integrates only inside it
            dt = min(NUMERIC_SCAN * t_char, 1e-2 * ell / rate, rest)
            qs_, vs_ = q, v
            offsets = ph.offsets

            def values(qq, vv):
                return np.asarray(ph.events(qq, vv)).reshape(-1) - offsets
            while s0 < rest and found is None:
                d = min(dt, rest - s0)
                qn_, vn_ = fly(qs_, vs_, d)
                below = values(qn_, vn_) + offsets < 0.0
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
            return float(np.min(values(*fly(qb, vb, s))[crossing]))
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
        t_new = t + s
        fired = [int(i) for i in crossing if values(qc, vc)[i] < 0.0] or [int(crossing[0])]
        kinds = [("impact", int(i)) for i in fired] if fly is parabola else [ph.kinds[i] for i in fired]
        if not any(k == "impact" for k, _ in kinds):
            # a switch of the persistent contact: the slip stops, a sticking contact slips, a contact lifts off
            if len(switches) + len(events) >= max_events or \
                    len(switches) >= 3 and t_new - switches[-3].t < MIN_FLIGHT * max(T, 1.0):
                reason, t_start = "accumulation of contact switches", t_new
                break
            kind, j = kinds[0]
            switches.append(Switch(t_new, kind, j, qc, vc, sig.modes[j]))
            q, v, t = qc, vc, t_new
            exclude = (j, sig.modes[j])
            continue
        Mc = M if M is not None else np.asarray(system.mass_matrix(qc))
        phi, J = (np.asarray(x) for x in gap(qc))
        phi = phi.reshape(-1)
        vn = J @ vc
        closed = phi <= gap_floor
        vt = SWITCH_TOL * max(float(np.max(np.abs(vc))), ell / t_char)
        # the contacts that approach take the impact, and with them every closed contact that does not
        # separate (a row of touching balls carries the impact on: the law decides how; a held contact)
        take = np.where(closed & (vn <= vt))[0] if np.any(closed & (vn < -vt)) else np.zeros(0, dtype=int)
        if take.size == 0:
            # no approaching contact at the crossing: a graze (rounding), or an arrival at rest (persistent
            # contact begins: the next phase decides)
            if np.any(closed & (vn < 0)):
                j = int(np.argmin(np.where(closed, vn, np.inf)))
                if len(switches) >= 3 and t_new - switches[-3].t < MIN_FLIGHT * max(T, 1.0):
                    reason, t_start = "accumulation of contact switches", t_new
                    break
                switches.append(Switch(t_new, "arrival", j, qc, vc, OPEN))
                q, v, t = qc, vc, t_new
                continue
            if events and t_new - events[-1].t < 1e3 * MIN_FLIGHT * max(T, 1.0):
                # ... unless it follows an impact within a scan step: a flight below rounding, the end
                # of an accumulation
                reason, t_start = "accumulation", events[-1].t
                break
            q, v = fly(qb, vb, scan_hi)
            t = t + sb + scan_hi
            continue
        D = np.asarray(system.tangent(qc)) if np.any(friction > 0) else np.zeros((c, system.nq))
        law = _impact(system, Mc, J, D, vc, take, vn[take] < -vt, e)
        if law is None:
            reason, t_start = "an impact that several contacts take with friction (no classical law)", t_new
            break
        mus, taus, v_after, frictional = law
        if events and t_new - events[-1].t < MIN_FLIGHT * max(T, 1.0):
            reason, t_start = "accumulation", events[-1].t
            break
        keep = (mus > 0.0) | (vn[take] < -vt)        # a closed contact that took no impulse is not listed
        take, mus, taus = take[keep], mus[keep], taus[keep]
        events.append(Event(t_new, tuple(int(j) for j in take), mus, qc, vc, v_after, taus, frictional))
        q, v, t = qc, v_after, t_new
        if len(events) + len(switches) >= max_events:
            reason, t_start = "accumulation", t_new
            break
    horizon = T if reason == "horizon" else t_start
    return EventDriven(success=True, status="ok", solver_status="ok", message=f"event-driven reference to "
                       f"t = {horizon:g} s ({reason}), {len(events)} impacts, {len(switches)} contact switches",
                       iterations=0, build_time_s=0.0, solve_time_s=0.0, events=events, switches=switches,
                       q0=q0, v0=v0, acceleration=a, horizon=horizon, reason=reason, flight=flight,
                       segments=segments)
