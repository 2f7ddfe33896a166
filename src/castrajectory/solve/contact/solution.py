"""The solution of a contact trajectory: the result contract, its impacts, and how it is read from the NLP."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import List, Optional

import numpy as np

from ...result import HomotopyStep, NLPResult, Result
from ...discretise.contact.elements import ContactMechanics
from ...discretise.contact.transcription import LOOKAHEAD, TOUCH_TOL
from .nlp import ContactNLP
from .options import ContactOptions



@dataclass
class SubNodeImpact:
    """One impact found in a solution (at a sub-node; the law itself is :mod:`castrajectory.models.impact`): step ``k``, time, contact, impulse and velocities."""

    step: int
    t: float
    contact: int
    mu: float
    q: np.ndarray
    v_before: np.ndarray
    v_after: np.ndarray
    #: the contact is closed again at the next node: the body is caught (plastic, Newton's law
    #: waived; the accumulation of Zeno bouncing or rocking), not a bounce
    caught: bool = False
    #: at the node ``step`` itself (a flight that landed on a node: Newton's law at the node, its impulse
    #: the node's h ν), not at a sub-node
    at_node: bool = False
    #: the tangential (friction) impulse along the contact's slip direction (0 without friction)
    mu_t: float = 0.0
    #: per contact, the share of the point's impulses that supports contacts held through the part after it, moved
    #: out of the impact (:func:`_held_share`: the held contacts' normal velocity after it zero, the leaving contacts'
    #: kept; non-zero for a leaving contact too): ``v_after − v_before = M⁻¹ Jᵀ (μ + held_share)``
    held_share: Optional[np.ndarray] = None

    def as_dict(self) -> dict:
        return {"step": self.step, "t": self.t, "contact": self.contact, "mu": self.mu,
                "q": self.q, "v_before": self.v_before, "v_after": self.v_after, "caught": self.caught,
                "at_node": self.at_node, "mu_t": self.mu_t,
                "held_share": None if self.held_share is None else np.asarray(self.held_share, float)}


@dataclass
class Release:
    """A contact that leaves without an impact of its own (a lift-off): step ``k`` (the last node at which it was
    closed), its time and contact; ``at_impact``: released by another contact's impact at that time (the force it
    held jumps to zero there), otherwise where its held force vanishes (:func:`_releases`); ``timed``: that time is
    the sub-node of its step, where the march's mode E made the force of the continuous motion vanish (a time of the
    scheme's order; otherwise a second-order reading of the node forces)."""

    step: int
    t: float
    contact: int
    at_impact: bool = False
    timed: bool = False

    def as_dict(self) -> dict:
        return {"step": self.step, "t": self.t, "contact": self.contact, "at_impact": self.at_impact,
                "timed": self.timed}


@dataclass(kw_only=True)
class ContactTrajectory(Result):
    """Solution of a contact trajectory (fields as :class:`castrajectory.solve.trajectory.Trajectory`, plus contact data)."""

    t: np.ndarray
    q: np.ndarray
    p: np.ndarray               # node momenta: mean of p_k⁻ and p_k⁺ (see _finish); p_0 as given
    v: np.ndarray
    energy: np.ndarray
    t_sub: np.ndarray           # sub-node times t_k + α_k h, one per step
    q_sub: np.ndarray
    mu: np.ndarray              # (N, contacts) sub-node impulses
    nu: np.ndarray              # (N + 1, contacts) node impulses h ν_k (last row: the look-ahead's node force at T)
    node_impulse: np.ndarray    # (N + 1, contacts) Λ_k: impulse per node (sub-node impulses lumped, see _finish)
    gap: np.ndarray             # (N + 1, contacts) gaps at the nodes
    gap_sub: np.ndarray         # (N, contacts) gaps at the sub-nodes
    impacts: List[SubNodeImpact]
    complementarity_residual: float
    scheme: str
    homotopy: List[HomotopyStep] = field(default_factory=list)
    attempts: List[dict] = field(default_factory=list)
    mode: str = "initial_value"
    method: str = "whole"
    #: steps of the base grid (``t`` has more nodes where steps were halved around crowded impacts)
    n: int = 0
    #: what the answer's NLP carries (see :attr:`castrajectory.solve.trajectory.Trajectory.program`)
    program: dict = field(default_factory=dict)
    #: Coulomb friction (a contact with a positive coefficient): per step and contact the ratio of the
    #: tangential to the normal force, (N, contacts, 2) for [node force, sub-node impulse], and the slip
    #: velocities each opposes (same shape: ContactMechanics.slip: each part's displacement with D at its midpoint); None without
    friction_ratio: Optional[np.ndarray] = None
    slip: Optional[np.ndarray] = None
    #: the friction impulse per node, lumped as ``node_impulse`` is (the node's ρ h ν and its shares of the
    #: sub-node impulses' ρ μ): (N + 1, contacts), or (N + 1, contacts, 2) on tangent planes; None without friction
    friction_impulse: Optional[np.ndarray] = None
    #: the friction coefficients per contact (None without friction)
    friction_coefficients: Optional[np.ndarray] = None
    #: the slips that stop (``"stop"``: the contact then sticks) or turn (``"turn"``: it slides back) at a sub-node,
    #: and the sticks that end there (``"start"``: the friction force reached the cone), which their step timed:
    #: ``(t, contact, kind)``
    slip_turns: Optional[list] = None
    #: per contact, the intervals of one state, ``(from, to, state)``: open, held (frictionless), stick, slide+ / slide-
    #: (planar) or slide (a tangent plane); their ends are the nodes and sub-nodes, where the march times the events
    intervals: Optional[list] = None
    #: the lift-offs: contacts that leave without an impact of their own (:class:`Release`, by time)
    releases: List["Release"] = field(default_factory=list)
    #: the contact force per node, ``node_impulse`` over the node's dual cell (``[t_k − h/2, t_k + h/2]``; node 0's
    #: from 0, node N's into the look-ahead step): (N + 1, contacts); a resting body's weight exactly
    contact_force: Optional[np.ndarray] = None

    def slip_stops(self, contact: int = 0) -> List[float]:
        """The times at which contact ``contact`` stops sliding (and sticks or rolls): :meth:`slip_events`' stops."""
        return self.slip_events(contact)[0]

    def slip_reversals(self, contact: int = 0) -> List[float]:
        """The times at which contact ``contact``'s slip reverses (it slides back without sticking):
        :meth:`slip_events`' reversals."""
        return self.slip_events(contact)[1]

    def slip_events(self, contact: int = 0):
        """``(stops, reversals)`` of contact ``contact``'s slip: the times at which it stops sliding (and sticks or
        rolls), and those at which its slip reverses without sticking.  Those its step's sub-node timed (the
        march's mode W, ``slip_turns``) are that sub-node's times.  The others are read from the discrete
        solution's impulses: the friction is impulsive, acting at the nodes and sub-nodes, so a node whose friction
        ratio falls inside the cone ends a slide.  If the node after it slides the other way, the slip reversed
        inside the cell: ``Φ/Λ = μ(2f − 1)(−ŝ)``, ``f`` the fraction of the cell slid the first way (a reversal
        read as a stop made the label change with N: the disk in the bowl at μ = 0.05 reversed at 0.71 s, a
        "stop" at N = 400 where the march had not timed it, a "turn" at N = 100 where it had).  Otherwise the slip
        stops inside the cells from that node until the sticking ratio settles, after the fraction ``f`` of them
        in which Coulomb's full ``μ`` acted, ``ΣΦ/ΣΛ = f (−μ ŝ) + (1 − f) r_s`` (``Φ``, ``Λ`` the nodes' friction
        and normal impulses, ``ŝ`` the slip's direction before, ``r_s`` the settled sticking ratio after; where it
        has not settled within 20 nodes, the first cell alone, and the ringing is skipped).  For a constant normal
        force the total friction impulse up to the stop is exact in the discrete solution (the slip's balance), so
        the time is too; the nodes themselves resolve the stop to a step only."""
        if self.friction_impulse is None:
            return [], []
        timed = [t for t, j, kind in (self.slip_turns or []) if j == contact and kind == "stop"]
        timed_turns = [t for t, j, kind in (self.slip_turns or []) if j == contact and kind == "turn"]
        near = [t for t, j, kind in (self.slip_turns or []) if j == contact]
        mu = float(self.friction_coefficients[contact])
        Lam = np.asarray(self.node_impulse, float)[:, contact]
        Phi = np.asarray(self.friction_impulse, float)[:, contact]
        Phi = Phi.reshape(Lam.size, -1)
        t = np.asarray(self.t, float)
        edges = np.concatenate([[t[0]], 0.5 * (t[1:] + t[:-1]), [t[-1]]])        # the nodes' cells
        ratio = np.where(Lam[:, None] > 0, Phi / np.where(Lam > 0, Lam, 1.0)[:, None], 0.0)
        rn = np.linalg.norm(ratio, axis=1)
        sliding = (Lam > 1e-12 * max(float(np.max(Lam)), 1e-300)) & (rn >= mu * (1 - 1e-9))
        stops, turns, skip = [], [], 0
        for k in range(1, Lam.size):
            if k <= skip:
                continue
            if sliding[k - 1] and not sliding[k] and Lam[k] > 0:
                d = ratio[k - 1] / max(rn[k - 1], 1e-300)                      # −ŝ: the sliding ratio's direction
                untimed = not any(edges[max(k - 2, 0)] <= tt <= edges[min(k + 3, edges.size - 1)] for tt in near)
                if k + 1 < Lam.size and sliding[k + 1] and float(np.dot(ratio[k + 1], d)) < 0.0:
                    # it slides the other way from the next node on: a reversal inside cell k
                    f = min(max(0.5 * (1.0 + float(np.dot(ratio[k], d)) / mu), 0.0), 1.0)
                    if untimed:
                        turns.append(float(edges[k] + f * (edges[k + 1] - edges[k])))
                    skip = k + 1
                    continue
                # the stop's cells: from k until the sticking ratio has settled (two stuck nodes agree: a stop
                # on an incline rings for two nodes about tan α; up to 20 nodes, a slip back within them included), the settled ratio r_s after them
                K, r_s, skip = k, np.zeros_like(d), k + 20     # (unsettled: the first cell alone, the ringing skipped)
                for K2 in range(k, min(k + 20, Lam.size - 2)):
                    a1, a2 = ratio[K2 + 1], ratio[K2 + 2]
                    if not (sliding[K2 + 1] or sliding[K2 + 2]) and np.max(np.abs(a1 - a2)) <= 1e-9 * mu:
                        K, r_s, skip = K2, a1, K2
                        break
                cells = slice(k, K + 1)
                mean = Phi[cells].sum(axis=0) / max(float(Lam[cells].sum()), 1e-300)
                a = mu * d - r_s
                f = float(np.dot(mean - r_s, a) / max(np.dot(a, a), 1e-300))
                f = min(max(f, 0.0), 1.0)
                t_stop = float(edges[k] + f * (edges[K + 1] - edges[k]))
                if untimed:
                    stops.append(t_stop)
        return sorted(stops + timed), sorted(turns + timed_turns)

    def slip_starts(self, contact: int = 0) -> List[float]:
        """The times at which contact ``contact`` starts sliding again after a stop (:meth:`slip_stops`): the first
        node that slides after it, and the next one the same way, after stuck nodes (a ratio inside the cone, a
        normal impulse).  A node's ratio is its cell's mean, so the first sliding node's cell slides throughout and
        the stick ends inside the cell before it; there the parabola through the ratios (along the slide's
        direction) of the three stuck nodes before that cell reaches ``μ`` (the line through two).  The disk in
        the bowl at μ = 0.05 slides again at 2.6038, 3.7049 and 4.8297 s (an event-driven reference).  A start the
        march timed (mode G: the sticking force reached the cone at its step's sub-node; ``slip_turns`` with kind
        ``"start"``) is at that sub-node's time, of the scheme's order."""
        if self.friction_impulse is None:
            return []
        mu = float(self.friction_coefficients[contact])
        Lam = np.asarray(self.node_impulse, float)[:, contact]
        Phi = np.asarray(self.friction_impulse, float)[:, contact].reshape(Lam.size, -1)
        t = np.asarray(self.t, float)
        ratio = np.where(Lam[:, None] > 0, Phi / np.where(Lam > 0, Lam, 1.0)[:, None], 0.0)
        rn = np.linalg.norm(ratio, axis=1)
        loaded = Lam > 1e-12 * max(float(np.max(Lam)), 1e-300)
        sliding = loaded & (rn >= mu * (1 - 1e-9))
        stuck = loaded & ~sliding
        stops, out = list(self.slip_stops(contact)), []
        starts = [x for x, j, kind in (self.slip_turns or []) if j == contact and kind == "start"]
        for k in range(3, Lam.size - 1):
            if not stops or stops[0] >= t[k - 1]:
                continue                                          # (a start needs a stop before it)
            d = ratio[k] / max(rn[k], 1e-300)
            if not (sliding[k] and sliding[k + 1] and float(np.dot(ratio[k + 1], d)) > 0.0 and stuck[k - 1]):
                continue
            stops = [x for x in stops if x >= t[k]]               # this start answers every stop before it
            held = [i for i in range(k - 4, k - 1) if i >= 0 and stuck[i] and t[i] > max(t[0], t[k] - 5 * (t[k] - t[k - 1]))]
            when = float(t[k - 1])
            timed = [x for x in starts if t[max(k - 2, 0)] <= x <= t[k + 1]]
            if timed:       # the march timed it at its step's sub-node (mode G)
                out.append(timed[0])
                continue
            if len(held) >= 2:
                roots = np.roots(np.polyfit(t[held] - t[k - 1], ratio[held] @ d - mu, len(held) - 1))
                roots = roots[np.isreal(roots)].real
                roots = roots[(roots >= t[k - 2] - t[k - 1]) & (roots <= t[k] - t[k - 1])]
                if roots.size:
                    when = float(t[k - 1] + roots[np.argmin(np.abs(roots))])
            out.append(when)
        return out

    def as_dict(self) -> dict:
        return {**super().as_dict(), "solver_status": self.solver_status,
                "scheme": self.scheme, "method": self.method, "t": self.t, "q": self.q,
                "energy": self.energy, "t_sub": self.t_sub, "mu": self.mu, "nu": self.nu,
                "node_impulse": self.node_impulse,
                "gap": self.gap, "complementarity_residual": self.complementarity_residual,
                "impacts": [i.as_dict() for i in self.impacts],
                "releases": [r.as_dict() for r in self.releases], "contact_force": self.contact_force,
                "friction_ratio": self.friction_ratio, "slip": self.slip,
                # each contact's slip events (friction only): [stops, reversals, starts]
                "slip_events": None if self.friction_impulse is None else
                [[*self.slip_events(j), self.slip_starts(j)] for j in range(len(self.friction_coefficients))],
                # each contact's intervals of one state (open, held, stick, slide)
                "contact_intervals": None if self.intervals is None else
                [[{"from": a, "to": b, "state": st} for a, b, st in iv] for iv in self.intervals],
                # JSON keys of the earlier second sub-node per step, kept for existing readers: a step
                # now holds one sub-node (the grid is halved instead), so they are always empty
                "steps_sub2": [], "t_sub2": [], "mu_sub2": [],
                "homotopy": [vars(s) for s in self.homotopy], "attempts": self.attempts, "program": self.program}


def _finish(cm: ContactMechanics, tn: ContactNLP, res: NLPResult, N: int, h: float, attempts,
            guess_time: float, p0: np.ndarray) -> ContactTrajectory:
    n, c, sysm = cm.n, cm.c, cm.system
    co = tn.settings
    # the reported horizon: the first N steps (the look-ahead steps are not part of the answer)
    q = res.values["q"][:(N + 1) * n].reshape(N + 1, n)
    S = res.values["qs"][:N * n].reshape(N, n)
    B = res.values["beta"][:N].reshape(N)
    MU = res.values["mu"][:N * c].reshape(N, c)
    # the stages of each step's two parts (none for a two-point scheme)
    ZM, ZP = ([z[:N] for z in part] for part in tn._stages(res.values))
    # step lengths (a refined grid where impacts crowd; h everywhere otherwise)
    H = tn.H
    hv = H[:N]
    NL = N + LOOKAHEAD
    p, pp, half, force, closed, gap, nu_full = _node_momenta(cm, tn, res, N, q, S, B, ZM, ZP, p0)
    t = np.concatenate([[0.0], np.cumsum(H[:N])])
    if np.all(H == h):
        t = np.linspace(0.0, N * h, N + 1)
    t_sub = t[:-1] + (0.5 + B) * H[:N]
    # Impacts (_impacts_at): at the sub-nodes, and at interior nodes where a flight landed on the node (the
    # march's mode N: the node's impulse h ν); the node's momentum is then the one after it, not the mean
    impacts = _impacts(cm, tn, res, N, q, S, B, MU, ZM, ZP, H, t, t_sub, gap, closed, force, half, pp, p)
    simultaneous = _simultaneous_warnings(cm, impacts)
    # velocities M⁻¹p, tangent to the holonomic constraints where there are any, and to the contacts held at the node
    v = _held_velocities(cm, q, cm.dm.velocities(q, p), closed, cm.gaps(S) <= TOUCH_TOL * tn.scales_ell)
    energy = sysm.energies(q, v)
    gap_sub = np.asarray(sysm.gap.map(N)(S.T)[0]).reshape(c, N).T
    # Impulse per node: Λ_k = h ν_k + (1 − α_k) μ_k + α_{k−1} μ_{k−1}, each sub-node impulse shared
    # between its two nodes by linear (hat-function) interpolation of its time; node N takes the
    # look-ahead step's node force and sub-node share (its dual cell reaches past T).  For a body
    # resting on the ground Λ_k = m g h exactly whatever the sub-nodes do (derivation, "Resting
    # contact"); Λ_0 covers the half cell [0, h/2].
    alpha_full = 0.5 + res.values["beta"][:NL]
    mu_full = res.values["mu"][:NL * c].reshape(NL, c)
    lam = nu_full[:N + 1] + (1.0 - alpha_full[:N + 1, None]) * mu_full[:N + 1]
    lam[1:] += alpha_full[:N, None] * mu_full[:N]
    nu = nu_full[:N + 1].copy()
    total_iter = sum(a["iterations"] for a in attempts)
    fratio, slip, fimp = _friction_parts(cm, tn, res, N, NL, nu_full, alpha_full, mu_full, q, S, B, hv)
    warnings = simultaneous + _elastic_loss_warning(cm, energy, impacts, H[:N], co.elastic_loss_tol)
    # the nodes' dual cells: node 0's is half a step; node N's reaches past T into the look-ahead step, as its Λ does
    cell = 0.5 * (np.concatenate([[0.0], H[:N]]) + H[:N + 1])
    contact_force = lam / cell[:, None]
    releases = _releases(t, closed, contact_force, impacts,
                         {(k, j): float(t_sub[k]) for k, j in getattr(tn, "lifts", []) if k < N})
    return ContactTrajectory(
        warnings=warnings,
        t=t, q=q, p=p, v=v, energy=energy, t_sub=t_sub, q_sub=S, mu=MU, nu=nu, gap=gap, gap_sub=gap_sub,
        node_impulse=lam, impacts=impacts, complementarity_residual=float(res.complementarity_residual),
        releases=releases, contact_force=contact_force,
        status=res.status, success=res.success, message=res.message, solver_status=res.solver_status,
        iterations=int(total_iter),
        build_time_s=float(sum(a["build_time_s"] for a in attempts)),
        solve_time_s=float(guess_time + sum(a["solve_time_s"] for a in attempts)),
        scheme=cm.dm.scheme.name, homotopy=list(res.homotopy), attempts=attempts, n=int(round(float(t[-1]) / h)),
        friction_ratio=fratio, slip=slip, friction_impulse=fimp,
        friction_coefficients=cm.mu_f.copy() if cm.friction else None,
        slip_turns=[(float(t_sub[k]), j, kind) for k, j, kind in
                    list(getattr(tn, "turns", [])) + [(k, j, "start") for k, j in getattr(tn, "grips", [])]
                    if k < N] if cm.friction else None,
        program={"terms": sysm.terms(), "steps": int(tn.L), **tn.nlp.anatomy()},
        intervals=_intervals(cm, t, t_sub, closed, gap_sub <= TOUCH_TOL * tn.scales_ell, fratio))


def _intervals(cm: ContactMechanics, t, t_sub, closed, closed_sub, fratio) -> List[list]:
    """Per contact, the answer's time split into intervals of one state: ``open``, ``held`` (frictionless), and with
    friction ``stick``, ``slide+``/``slide-`` (the planar slip's sign) or ``slide`` (on a tangent plane).  Each part of
    each step has one state: held where the contact is closed at both of its ends, sticking or sliding by its friction
    slot's ratio (the node's for the first part, the sub-node's for the second: inside the cone, or on its edge against
    the slip).  A part's ends are nodes and sub-nodes, so every event the march timed (an impact, a release, a slip's
    stop, turn or start) is an interval's end at its own time.  ``[(from, to, state), ...]`` by contact."""
    N, c = t_sub.size, cm.c
    out = []
    for j in range(c):
        pieces = []
        for k in range(N):
            for part, (a, b) in enumerate(((t[k], t_sub[k]), (t_sub[k], t[k + 1]))):
                held = closed[k, j] and closed_sub[k, j] if part == 0 else closed_sub[k, j] and closed[k + 1, j]
                state = "open"
                if held:
                    state = "held"
                    if cm.friction and cm.mu_f[j] > 0:
                        r = np.atleast_1d(np.asarray(fratio[k, j, part], float))
                        rn = float(np.linalg.norm(r))
                        state = ("stick" if rn < cm.mu_f[j] * (1 - 1e-9) else "slide" if r.size > 1 else
                                 "slide+" if r[0] < 0 else "slide-")
                if b <= a:
                    continue
                if pieces and pieces[-1][2] == state:
                    pieces[-1][1] = float(b)
                else:
                    pieces.append([float(a), float(b), state])
        out.append([tuple(p) for p in pieces])
    return out


def _held_velocities(cm: ContactMechanics, q, v, closed, closed_sub):
    """The node velocities ``v`` projected (in the kinetic metric, with the holonomic constraints) onto the tangent
    space of the contacts held at each node: closed there and at the sub-nodes on either side (held through both parts
    that meet at the node; a flight leaves one of them open).  The one-sided momenta of a held node differ by its
    impulse ``h∇φᵀν``, along the held normals: their projection is one velocity, the scheme's, where their mean kept
    a normal velocity of the impulse's split (second order)."""
    N = q.shape[0] - 1
    before = np.vstack([closed_sub[:1], closed_sub])[:N + 1]
    after = np.vstack([closed_sub, closed_sub[-1:]])[:N + 1]
    held = closed & before & after
    out = np.array(v, float)
    for k in np.flatnonzero(np.any(held, axis=1)):
        M = np.asarray(cm.system.mass_matrix(q[k]))
        C = np.asarray(cm.system.constraint(q[k])[1]) if cm.m else np.zeros((0, cm.n))
        G = np.vstack([C, np.asarray(cm.system.gap(q[k])[1])[held[k]]])
        MiGt = np.linalg.solve(M, G.T)
        out[k] = v[k] - MiGt @ np.linalg.lstsq(G @ MiGt, G @ v[k], rcond=None)[0]
    return out


def _node_momenta(cm: ContactMechanics, tn: ContactNLP, res: NLPResult, N: int, q, S, B, ZM, ZP, p0):
    """The node momenta of an answer, ``(p, p⁺, half the node forces' impulse, the node forces, closed, gaps, h ν)``.

    A node force h ν_k makes the one-sided momenta differ, p_k⁺ = p_k⁻ + h ∇φ(q_k)ᵀ ν_k; the node's momentum is the
    forced discrete Legendre transform, which gives each part that meets at the node its quadrature's share of that
    impulse, in proportion to the part's length: ``p_k = p_k⁻ + τ_l/(τ_l + τ_r) · h∇φᵀν`` (``τ_l``, ``τ_r`` the parts
    before and after the node; their mean for equal parts, and for a body resting on the ground p_k⁻ = −p_k⁺ gives 0,
    not ±m g h/4; a slip's turn timed inside a step makes the parts unequal, where the mean left a first-order error
    of the node's velocity).  Without a node force p_k⁻ = p_k⁺ (DEL).  At t = 0 the given p_0; at T the look-ahead
    step supplies ν_N."""
    n, c, sysm, H = cm.n, cm.c, cm.system, tn.H
    NL = N + LOOKAHEAD
    nu_full = H[:NL, None] * res.values["nu"][:NL * c].reshape(NL, c)
    gN, Jn = (np.asarray(x) for x in sysm.gap.map(N + 1)(q.T))    # gaps (c, N + 1) and Jacobians (c, (N + 1) n)
    gap = gN.reshape(c, N + 1).T
    Jn = Jn.reshape(c, N + 1, n).transpose(1, 0, 2)                  # (N + 1, c, n)
    # only closed contacts (gap within TOUCH_TOL): on an open one ν is interior-point noise below the
    # complementarity tolerance, left on p⁺ as before
    closed = gap <= TOUCH_TOL * tn.scales_ell
    force = np.where(closed, nu_full[:N + 1], 0.0)
    half = 0.5 * np.einsum("kcn,kc->kn", Jn, force)
    if cm.friction:
        # the friction force at the node, ρ h ν along the slip directions D(q_k), splits the momenta too
        d = cm.fd
        RHO = res.values["fratio"][:NL * 2 * c * d].reshape(NL, 2 * c * d)[:, :c * d]   # the node forces' ratios
        Dn = np.asarray(sysm.tangent.map(N + 1)(q.T)).reshape(c * d, N + 1, n).transpose(1, 0, 2)
        half += 0.5 * np.einsum("kcn,kc->kn", Dn, RHO[:N + 1] * np.repeat(force, d, axis=1))
    U, T0 = tn._controls(res.values)[0], tn.step_starts()
    pp = np.asarray(cm.p_node_plus.map(N)(q[:-1].T, S.T, B, H[:N], *[z.T for z in ZM], T0[None, :N], U[:N].T)).T
    pN = np.asarray(cm.p_node_minus(S[-1], B[-1], q[-1], H[N - 1], *[z[-1] for z in ZP], T0[N - 1],
                                    U[N - 1])).reshape(1, -1)
    # each node's share of its impulse that belongs to the part after it, τ_r / (τ_l + τ_r)
    alpha = 0.5 + res.values["beta"][:NL].reshape(-1)
    tau_r = alpha[:N + 1] * H[:N + 1]
    tau_l = np.concatenate([[0.0], (1.0 - alpha[:N]) * H[:N]])
    right = np.where(tau_l + tau_r > 0, tau_r / np.maximum(tau_l + tau_r, 1e-300), 0.5)[:, None]
    p = np.vstack([pp - 2.0 * right[:N] * half[:N], pN + 2.0 * (1.0 - right[N:]) * half[N:]])
    p[0] = p0
    return p, pp, half, force, closed, gap, nu_full


def _impacts(cm, tn, res, N, q, S, B, MU, ZM, ZP, H, t, t_sub, gap, closed, force, half, pp, p) -> list:
    """The answer's impacts (:func:`_impacts_at`), sorted by time: at the sub-nodes, and at interior nodes where a
    flight landed on the node (the march's mode N: the node's impulse h ν), whose momentum ``p`` is then set, in
    place, to the one after it, not the mean."""
    c, sysm = cm.c, cm.system
    tol = tn.settings.impulse_tol * tn.scales_p / tn.scales_ell
    co = tn.settings
    impacts = []
    # (friction: the ratios of the sub-node impulses and of the node forces, for the tangential impulses)
    fd = cm.fd
    RS = (res.values["fratio"][:N * 2 * c * fd].reshape(N, 2 * c, fd) if cm.friction else np.zeros((N, 2 * c, 1)))
    RS = RS[..., 0] if fd == 1 else RS
    # a contact that arrives from flight (open at the step's node) and is open at one of the two nodes after its
    # impulse (beyond a resting body's hop, a h²/8): the impulse sent it off
    # (the first part's closing impulses μ⁻: a contact released at its step's impact takes its share of its force
    # there, which the momentum before the impact carries and which is no impact; a plastic arrival with friction
    # takes Stronge's impulse there, its impact, the contact closed after it by the second part's μ)
    REL = getattr(tn, "release", np.zeros((tn.L, c)))[:N] > 0
    MUL = res.values["mul"][:N * c].reshape(N, c)
    FL = res.values["fleft"][:N * c * fd].reshape(N, c, fd) if cm.friction else np.zeros((N, c, fd))
    FL = FL[..., 0] if fd == 1 else FL
    gap_subs = np.asarray(sysm.gap.map(N)(S.T)[0]).reshape(c, N).T
    gap_sub_k = lambda k: gap_subs[k]  # noqa: E731  (the gaps at step k's sub-node)
    U, T0 = tn._controls(res.values)[0], tn.step_starts()
    for k in np.flatnonzero(np.any((MU > tol) | (MUL > tol), axis=1)):
        pm = np.asarray(cm.p_minus(q[k], S[k], B[k], H[k], *[z[k] for z in ZM], T0[k], U[k])).reshape(-1)
        pl = np.asarray(cm.p_plus(S[k], q[k + 1], B[k], H[k], *[z[k] for z in ZP], T0[k], U[k])).reshape(-1)
        sh = np.where(REL[k], MUL[k], 0.0)
        if np.any(sh):
            pm = pm + np.asarray(sysm.gap(S[k])[1]).T @ sh
            if cm.friction:
                pm = pm + np.asarray(sysm.tangent(S[k])).T @ (FL[k].reshape(-1) * np.repeat(sh, fd))
        imp_k = np.where(REL[k], 0.0, MU[k] + MUL[k])
        ratio_k = RS[k, c:]
        if cm.friction and np.any(MUL[k] > 0):
            # (a K arrival's impulse: Stronge's μ⁻ with its ratio, and the held share after it with its own)
            w = np.where(REL[k], 0.0, MUL[k])
            tang = RS[k, c:].reshape(c, -1) * MU[k][:, None] + FL[k].reshape(c, -1) * w[:, None]
            ratio_k = (tang / np.where(imp_k > 0, imp_k, 1.0)[:, None]).reshape(RS[k, c:].shape)
        impacts += _impacts_at(cm, k, float(t_sub[k]), S[k], pm, pl, imp_k, tol, H[k], co, at_node=False,
                               ratios=ratio_k, leaves=(np.max(gap[k + 1:k + 3], axis=0) > tn.open_gap)
                               & (gap[k] > TOUCH_TOL * tn.scales_ell),
                               held=closed[k + 1] & (gap_sub_k(k) <= TOUCH_TOL * tn.scales_ell))
    for k in np.flatnonzero(np.any(force[1:N] > tol, axis=1)) + 1:
        at = _impacts_at(cm, k, float(t[k]), q[k], pp[k] - 2 * half[k], pp[k], force[k], tol, H[k], co,
                         at_node=True,
                         ratios=RS[k, :c] if k < N else np.zeros_like(RS[0, :c]),
                         held=closed[k] & closed[k + 1])
        if at:
            impacts += at
            p[k] = pp[k]
    impacts.sort(key=lambda i: (i.t, i.contact))
    return impacts


def _friction_parts(cm, tn, res, N, NL, nu_full, alpha_full, mu_full, q, S, B, hv):
    """``(friction ratios, slips, friction impulses per node)`` of the answer, ``None`` each without friction."""
    c = cm.c
    fratio = slip = fimp = None
    if cm.friction:
        # the friction impulses per node, lumped like Λ: the node's ρ h ν and the hat-function shares of ρ μ
        fdim = cm.fd
        RF = res.values["fratio"][:NL * 2 * c * fdim].reshape(NL, 2, c, fdim)
        fimp = RF[:N + 1, 0] * nu_full[:N + 1, :, None] + (1.0 - alpha_full[:N + 1, None, None]) * RF[:N + 1, 1] \
            * mu_full[:N + 1, :, None]
        fimp[1:] += alpha_full[:N, None, None] * RF[:N, 1] * mu_full[:N, :, None]
        # (the first parts' closing impulses μ⁻ with their ratios: the node before takes them, as the part they close)
        MULf = res.values["mul"][:N * c].reshape(N, c)
        FLf = res.values["fleft"][:N * c * fdim].reshape(N, c, fdim)
        fimp[:N] += (1.0 - alpha_full[:N, None, None]) * FLf * MULf[:, :, None]
        fimp[1:N + 1] += alpha_full[:N, None, None] * FLf * MULf[:, :, None]
        fimp = fimp[..., 0] if fdim == 1 else fimp
        fd = cm.fd
        fratio = res.values["fratio"][:N * 2 * c * fd].reshape(N, 2, c, fd).transpose(0, 2, 1, 3)
        arrive = getattr(tn, "arrive", np.zeros((tn.L, c)))[:N]
        ZM, ZP = ([z[:N] for z in part] for part in tn._stages(res.values))
        slip = np.asarray(cm.slip_row.map(N)(q[:-1].T, S.T, q[1:].T, B, hv, arrive.T, *[z.T for z in ZM],
                                             *[z.T for z in ZP])).reshape(2 * c * fd, N).T
        slip = slip.reshape(N, 2, c, fd).transpose(0, 2, 1, 3)
        if fd == 1:       # planar: (N, contacts, 2) for [node force, sub-node impulse]
            fratio, slip = fratio[..., 0], slip[..., 0]
    return fratio, slip, fimp


def _releases(t: np.ndarray, closed: np.ndarray, force: np.ndarray, impacts, lifts=None) -> List[Release]:
    """The lift-offs: a contact closed with a force at node ``a`` and open at node ``a + 1``, without an impact of its
    own between them.  Where another contact's impact lies in ``(t_a, t_{a+1}]`` it released it (the force it held
    jumps to zero there: the rimless wheel's back spoke as the front one lands); otherwise the held force fell to
    zero inside node ``a``'s cell, and the release is where the parabola through the forces of the three nodes
    before ``a`` (whose cells it filled) vanishes (the line through two where only two were held; the node's time
    where fewer).  The node forces are second-order values of the force, so the time is second order (the ladder
    sliding down a wall: 2.9e-5, 1.8e-5, 4.1e-6, 1.2e-6 s from sin θ = (2/3) sin θ₀ at N = 70 to 560).  A release the
    march timed (mode E; ``lifts`` maps its step and contact to its sub-node's time) is at that time."""
    out = []
    for j in range(closed.shape[1]):
        # (a contact may stay within the touching band for some nodes after its force vanished: a grazing release,
        # whose gap grows as (t − t*)³, the ladder's wall at N = 1600, was listed as no release at all; the release is
        # at the last node with a force before it opens)
        for b in np.flatnonzero(closed[:-1, j] & ~closed[1:, j]):
            a = int(b)
            while a > 0 and force[a, j] <= 0.0 and closed[a - 1, j]:
                a -= 1
            if force[a, j] <= 0.0:
                continue
            # (its own impact in the step, or at node a where a flight landed on the node: a bounce, no release)
            own = [i for i in impacts if i.contact == j and t[a] <= i.t <= t[b + 1]]
            if own:
                continue
            if (a, j) in (lifts or {}):     # timed at its sub-node (mode E)
                out.append(Release(int(a), lifts[(a, j)], int(j), timed=True))
                continue
            others = [i.t for i in impacts if t[a] <= i.t <= t[a + 1]]
            if others:
                out.append(Release(int(a), float(min(others)), int(j), at_impact=True))
                continue
            held = [i for i in range(a - 3, a) if i >= 0 and closed[i, j] and force[i, j] > 0.0]
            when = float(t[a])
            if len(held) >= 2:
                coeffs = np.polyfit(t[held] - t[a], force[held, j], len(held) - 1)
                roots = np.roots(coeffs)
                roots = roots[np.isreal(roots)].real
                roots = roots[(roots >= t[a - 1] - t[a]) & (roots <= t[a + 1] - t[a])]   # between the neighbours
                if roots.size:
                    when = float(t[a] + roots[np.argmin(np.abs(roots))])
            out.append(Release(int(a), when, int(j)))
    return sorted(out, key=lambda r: (r.t, r.contact))


def _held_share(cm: ContactMechanics, x, p_after, held, kept=None, slip_floor=None):
    """The impulses that take out of the momentum after an impact at ``x`` the share of its impulse that supports a
    contact held through the part after it: ``(normal, kinetic, momentum)``, the normal impulses per contact (≤ 0
    where the contact is held), the ratios of the friction they carry ``(contacts, d)`` (0 but where the contact
    slides after the impact) and the momentum they carry.

    The discrete momentum at the start of a part is its Legendre transform, ``p⁺ = M Δq/h + (h/2) F``: for a body
    in flight ``M v`` to O(h²), but a held contact's support acts at the part's end node (its ``h ν``), not in the
    part, so after a plastic landing on a floor ``p⁺ = m g h/2``: ``v_after`` was ``g h/2`` upward (8e-3 m/s at
    N = 800) where Newton's law says 0, and the landing was flagged *caught*.  A contact held through the part
    (closed at ``x`` and at the next node: its gap does not change over the part) has no normal velocity after the
    impact, ``J_h v⁺ = 0``; the velocity after is the one that meets it with an impulse along the held normals,
    ``J_h M⁻¹ J_hᵀ δ = −J_h M⁻¹ p⁺``, moved from the impact to the support.  A held contact that slides after the
    impact (its slip there above ``slip_floor``) carries its kinetic friction with its support, ``−μ_f δ ŝ`` along
    its slip ``s``: without it a held corner sliding through the other corner's landing had ``v_after``'s slip
    4.6e-5 m/s off its part's at N = 100, μ = 0.01.  (Not the impulse's own ratio: at the cone it is Stronge's for an
    arrival that stops sliding in the impact, 5.6e-5 m/s off a body at rest after it.  A sticking contact's static
    share is not known, and is left in the impact.)

    ``kept``: the contacts at ``x`` that take an impulse and leave (open at the next node).  The program holds
    Newton's law at each of them on the discrete momenta, so the share moved out must not change their normal
    velocity: with them, ``[J_h; J_k] M⁻¹ [J_h; J_k]ᵀ [δ_h; δ_k] = [−J_h M⁻¹ p⁺; 0]`` (``δ_k`` the change
    of their impulse that carries the support's share through the body's coupling).  Along the held normals alone,
    a rectangle resting on one corner while the other bounced (battery scene 007, e = 0.268, N = 2000) had the
    bounce's ``v_after`` moved by 1.6e-3 m/s, 0.8 % of its arrival: Newton's law missed, and the bounce was listed
    caught, a catch the grid resolves, where the solution (the same to the bit) bounces it by the law."""
    held = np.asarray(held, bool)
    c, d = held.size, cm.fd
    p_after = np.asarray(p_after, float)
    if not np.any(held):
        return np.zeros(c), np.zeros((c, d)), np.zeros_like(p_after)
    kept = np.zeros(c, bool) if kept is None else np.asarray(kept, bool) & ~held
    js = np.flatnonzero(held | kept)
    x = np.asarray(x, float)
    J = np.asarray(cm.system.gap(x)[1], float)

    def share(W):
        probes = np.vstack([p_after, p_after + W[js]])                     # p⁺ and p⁺ + W_jᵀ per contact
        V = cm.dm.velocities(np.repeat(x[None], probes.shape[0], axis=0), probes)
        G = (V[1:] - V[0]).T                                                # columns M⁻¹ W_jᵀ (projected)
        rhs = np.where(held[js], -J[js] @ V[0], 0.0)                        # held: J v⁺ = 0; kept: unchanged
        delta = np.zeros(c)
        # (least squares: dependent normals, e.g. a box's face held on its four corners, make J M⁻¹ Jᵀ singular)
        delta[js] = np.linalg.lstsq(J[js] @ G, rhs, rcond=None)[0]
        return delta, W.T @ delta

    delta, shift = share(J)
    rho = np.zeros((c, d))
    if cm.friction and slip_floor is not None:
        D = np.asarray(cm.system.tangent(x), float).reshape(c, d, -1)
        v = cm.dm.velocities(x[None], (p_after + shift)[None])[0]
        slip = D @ v                                                        # (c, d): the slips after
        size = np.linalg.norm(slip, axis=1)
        slides = held & (cm.mu_f > 0) & (size > np.asarray(slip_floor, float))
        if np.any(slides):
            rho[slides] = -cm.mu_f[slides, None] * slip[slides] / size[slides, None]
            delta, shift = share(J + np.einsum("jd,jdn->jn", rho, D))
    return delta, rho, shift


def _support_moved_out(cm: ContactMechanics, x, p_after, impulses, ratios, held, tol: float, h: float):
    """An impact's momentum after it, its normal and tangential impulses (the latter shaped as ``ratios``) with the
    share that supports the contacts held through the part after it moved out (:func:`_held_share`), and that
    share (None where no contact is held).  A share moved out keeps its impulse's ratio, but where its contact slides
    after the impact it carries the kinetic friction instead."""
    tangential = ratios * (impulses if ratios.ndim == 1 else impulses[:, None])
    if held is None or not np.any(impulses > tol):
        return p_after, impulses, tangential, None
    held = np.asarray(held, bool) & (impulses > tol)
    # (a held contact slides after the impact where its slip exceeds a step's worth of its normal acceleration)
    v = cm.dm.velocities(np.asarray(x, float)[None], np.asarray(p_after, float)[None])[0]
    floor = np.abs(np.asarray(cm.acc_normal(x, v, np.zeros(cm.nu))).reshape(-1)) * h
    delta, kinetic, shift = _held_share(cm, x, p_after, held, kept=(impulses > tol) & ~held, slip_floor=floor)
    if not np.any(delta):
        return p_after, impulses, tangential, delta
    after = np.maximum(impulses + delta, 0.0)
    rho = ratios.reshape(after.size, -1)
    tang = rho * after[:, None]
    slides = np.any(kinetic != 0.0, axis=1)
    tang[slides] = rho[slides] * impulses[slides, None] + kinetic[slides] * delta[slides, None]
    return np.asarray(p_after, float) + shift, after, tang.reshape(ratios.shape), delta


def _impacts_at(cm: ContactMechanics, k: int, t: float, x, p_before, p_after, impulses, tol: float, h: float,
                co: ContactOptions,
                at_node: bool, ratios=None, leaves=None, held=None) -> List[SubNodeImpact]:
    """The impacts at one point ``x`` (a sub-node, or a node where a flight landed) with the momenta on either
    side and the contacts' impulses there.  A contact whose impulse meets an arrival faster than a step's worth
    of its normal acceleration takes an impact (slower "impacts" are the discrete form of persistent contact);
    where one does, so does every contact whose impulse alone would change its normal velocity by more than
    that (an impact carried on through contacts already closed: a ball resting against the next one in
    Newton's cradle, no approach, yet an impulse).  An impact is *caught* where Newton's law is waived (the
    arrival stopped, not reversed by e: the transcription allows it only where the contact is closed at the
    next node).  With friction (``ratios``: the tangential impulse over the normal one per contact) an impact
    follows Stronge's law, not Newton's: it is caught where the contact does not leave faster than that scale.
    An arrival slower than that scale is an impact too where it bounces (``leaves``: the contact is open at
    the next node, and its normal velocity turned from approach to separation): a coarse grid's slow bounce
    (a pendulum's second arrival at 0.915 rad/s against 2 |a_n| h = 0.98 at N = 40 was not listed).  ``held``: the
    contacts closed at ``x`` and at the next node: their support's share of the impulse is not the impact's
    (:func:`_held_share`)."""
    js = np.flatnonzero(impulses > tol)
    ratios = np.zeros(impulses.size) if ratios is None else np.asarray(ratios, float)   # (contacts,) or (contacts, 2)
    p_after, impulses, tangential, delta = _support_moved_out(cm, x, p_after, impulses, ratios, held, tol, h)
    if js.size == 0:
        return []
    vb, va = cm.dm.velocities(np.array([x, x]), np.array([p_before, p_after]))
    Jx = np.asarray(cm.system.gap(x)[1])
    caught_law = co.caught_law
    # each contact's inverse effective mass along its normal (a unit impulse's change of its normal velocity)
    W = np.einsum("jn,jn->j", Jx, cm.dm.velocities(np.repeat(np.asarray(x, float)[None], Jx.shape[0], axis=0), Jx))
    # (a step's worth of the normal acceleration, and no less than the change the impulse tolerance makes: a held
    # contact whose free normal acceleration vanishes -- the ladder's wall at its start, gravity along the wall --
    # read its rounding-level approach as an impact at N = 3200)
    scale = np.maximum(co.march_options.impact_speed_steps
                       * np.abs(np.asarray(cm.acc_normal(x, vb, np.zeros(cm.nu))).reshape(-1)) * h, tol * W)
    bounce = np.zeros(impulses.size, bool) if leaves is None else \
        np.asarray(leaves, bool) & (Jx @ vb < 0) & (Jx @ va > 0)
    if not any(-float(Jx[j] @ vb) > scale[j] or bounce[j] for j in js):
        return []
    out = []
    for j in js:
        vn_b, vn_a = float(Jx[j] @ vb), float(Jx[j] @ va)
        if -vn_b > scale[j] or bounce[j] or impulses[j] * W[j] > scale[j]:
            frictional = bool(np.any(ratios[j] != 0.0))
            # (with friction: caught where it does not leave faster than the scale that separates an impact from
            # persistent contact -- a plastic landing, whose discrete v⁺ carries the support of the step's rest)
            caught = vn_a <= scale[j] if frictional else abs(vn_a + cm.e * vn_b) > caught_law * max(abs(vn_b), 1e-300)
            out.append(SubNodeImpact(int(k), t, int(j), float(impulses[j]), np.array(x, float).copy(), vb, va,
                                     caught=bool(caught), at_node=at_node,
                                     mu_t=(float(tangential[j]) if np.ndim(tangential[j]) == 0
                                           else np.asarray(tangential[j], float).copy()),
                                     held_share=None if delta is None else delta.copy()))
    return out


def _simultaneous_warnings(cm: ContactMechanics, impacts) -> List[str]:
    """A warning for each impact that two or more contacts take: its outcome depends on the impact law,
    which the warning names."""
    names, law = cm.system.contact.names, cm.system.contact.law
    how = ("the simultaneous Newton law, each contact's normal velocity reversed by e" if law == "simultaneous"
           else "the sequential law, one contact after the other, the fastest approach first")
    groups: dict = {}
    for imp in impacts:
        groups.setdefault((imp.step, imp.at_node), []).append(imp)
    out = []
    for imps in groups.values():
        if len(imps) < 2:
            continue
        note = ""
        if law == "simultaneous" and np.any(cm.mu_f[[i.contact for i in imps]] > 0):
            note = ("; friction is not applied at an impact that several contacts take under the simultaneous "
                    "law (no classical law holds there): Contact(law='sequential') applies it contact by contact")
        out.append(f"a simultaneous impact at t = {imps[0].t:.6g}: {', '.join(names[i.contact] for i in imps)} take "
                   f"impulses in one step; its outcome depends on the impact law (here {how}; Contact(law=...))"
                   + note)
    return out


def elastic_loss(system, energy) -> float:
    """The energy an answer of an elastic (e = 1), frictionless and unforced contact system lost, ``E_0 − min E``
    (0 for any other system): such impacts conserve the energy exactly, so a loss is the grid's catches of bounces
    it does not resolve -- an error of the answer, not physics."""
    c = system.contact
    if (c is None or c.restitution != 1.0 or system.forced or np.any(np.asarray(c.friction, float) > 0)
            or energy.size < 2 or not np.all(np.isfinite(energy))):
        return 0.0
    return max(0.0, float(energy[0]) - float(np.min(energy)))


def _elastic_loss_warning(cm: ContactMechanics, energy, impacts, H, tol: float) -> List[str]:
    """For e = 1: the fraction of the energy lost, if above ``tol`` (``ContactOptions.elastic_loss_tol``).  Elastic impacts
    conserve the energy exactly (docs, contact §3); a loss means arrivals were caught, i.e. bounces the
    grid does not resolve -- a step longer than the flights (the answer is the grid's, not the physics')."""
    E0 = float(energy[0]) if energy.size else 0.0
    loss = elastic_loss(cm.system, energy) / max(abs(E0), 1e-300)
    if loss <= tol:
        return []
    return [f"an elastic contact (e = 1) lost {100 * loss:.3g} % of the energy: arrivals were caught because "
            f"the step (up to {float(np.max(H)):.3g} s) is longer than the bounces' flights; refine n"]

