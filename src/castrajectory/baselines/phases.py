"""Persistent contact for the event-driven reference (:mod:`castrajectory.baselines.events`): the phases in
which contacts are held, with Coulomb friction, between the impacts.

A phase is a mode per contact: open (``o``), held without friction (``h``), held sticking (``k``) or held
sliding in the direction ``σ = ±1`` of its slip (``+``, ``-``).  Its dynamics is the index-1 system

    M q̈ = f + Σ_held ∇φ_jᵀ λ_j + Σ_stick D_jᵀ τ_j − Σ_slide μ_j σ_j D_jᵀ λ_j,
    ∇φ_j q̈ + (∇φ_j q̇)_q q̇ = 0 (held),   D_j q̈ + (D_j q̇)_q q̇ = 0 (sticking),

(``f`` the Euler–Lagrange right-hand side without the accelerations, ``D_j`` the slip Jacobian), flown by the
reference's Gragg–Bulirsch–Stoer integrator of order 16.  The phase ends at the first of its events, each a
function that is positive while the phase holds: an open contact's gap (an impact), a held contact's normal
force ``λ_j`` (it lifts off), a sliding contact's slip ``σ_j s_j`` (its slip stops), a sticking contact's cone
margin ``μ_j λ_j − |τ_j|`` (it starts to slip).

The next phase is chosen by enumeration (:func:`select`): every combination of the options of the contacts
that are closed and at rest in the normal direction (open, held; sticking or sliding either way from rest, or
sliding on where the contact slips) is solved, and kept where it is consistent: ``λ ≥ 0``, an open contact
does not accelerate into the ground, a sticking force within the cone, a slip from rest in the direction of
its own acceleration.  The mode the event ended is excluded.  Where the consistent phases disagree on the
accelerations (Painlevé's paradox) or none is consistent, the reference stops and says so.

Rows that depend on others (two corners of a box sticking on the same line) are kept once: a dropped sticking
row whose slip Jacobian is parallel to a kept one is attached to it, and their cone is the pair's (the sum of
``μ λ`` against the one tangential force).  Dependent normal rows (a statically indeterminate set of held
contacts) stop the reference.  Friction here is planar (one slip component per contact).
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Dict, List, Optional, Tuple

import casadi as ca
import numpy as np

#: The options of a candidate contact.  (Held contacts without friction are ``h``.)
OPEN, HELD, STICK, UP, DOWN = "o", "h", "k", "+", "-"
#: Relative tolerances of the consistency checks (forces, accelerations) and of rank decisions.
CONSISTENCY_TOL = 1e-9
RANK_TOL = 1e-10
#: Two consistent phases whose accelerations differ by more than this (relative) are a genuine ambiguity.
AGREE_TOL = 1e-7


def _sign(m: str) -> float:
    return 1.0 if m == UP else -1.0


@dataclass(frozen=True)
class Signature:
    """A phase: each contact's mode, and the dropped sticking rows attached to a kept one (``(k, j)``)."""

    modes: Tuple[str, ...]
    attached: Tuple[Tuple[int, int], ...] = ()

    @property
    def held(self):
        return [j for j, m in enumerate(self.modes) if m != OPEN]

    def kept_sticks(self):
        dropped = {k for k, _ in self.attached}
        return [j for j, m in enumerate(self.modes) if m == STICK and j not in dropped]

    def describe(self, names) -> str:
        word = {OPEN: "open", HELD: "held", STICK: "sticking", UP: "sliding +", DOWN: "sliding -"}
        return ", ".join(f"{names[j]} {word[m]}" for j, m in enumerate(self.modes) if m != OPEN) or "flight"


class Parts:
    """The numeric pieces of the phase dynamics at a state: ``M, f, J, γ_n, D, γ_t`` (and the gaps, slips)."""

    def __init__(self, system):
        q, qd = system.q, system.qd
        L = system.lagrangian_expr()
        dLdqd = ca.gradient(L, qd)
        M = ca.hessian(L, qd)[0]
        f = ca.gradient(L, q) - ca.mtimes(ca.jacobian(dLdqd, q), qd)
        if system.force_terms:
            f = f + system.force_expr()
        phi = ca.vertcat(*system.contact.gaps)
        J = ca.jacobian(phi, q)
        D = system.contact.slip_jacobian(qd)
        gn = ca.mtimes(ca.jacobian(ca.mtimes(J, qd), q), qd)
        gt = ca.mtimes(ca.jacobian(ca.mtimes(D, qd), q), qd)
        self.exprs = dict(M=ca.densify(M), f=ca.densify(f), J=ca.densify(J), gn=ca.densify(gn), D=ca.densify(D),
                          gt=ca.densify(gt), phi=ca.densify(phi))
        self.fn = ca.Function("parts", [q, qd], list(self.exprs.values()))
        self.q, self.qd = q, qd
        self.mu = np.asarray(system.contact.friction, float)
        self.n, self.c = system.nq, system.contact.count

    def __call__(self, q, v) -> Dict[str, np.ndarray]:
        out = self.fn(q, v)
        return {k: np.asarray(x) for k, x in zip(self.exprs, out)}


def _assemble(P, sig: Signature, lib):
    """The phase's linear system ``K z = r`` in ``z = (q̈, λ_held, τ_kept sticks)``, with ``P`` numeric (numpy,
    ``lib = np``) or symbolic (CasADi, ``lib = ca``)."""
    held, sticks = sig.held, sig.kept_sticks()
    n = P["M"].shape[0]
    mu = P["mu"]
    cols = []
    for j in held:
        col = -P["J"][j, :].T
        if sig.modes[j] in (UP, DOWN):
            col = col + mu[j] * _sign(sig.modes[j]) * P["D"][j, :].T
        cols.append(col)
    cols += [-P["D"][j, :].T for j in sticks]
    rows = [P["J"][j, :] for j in held] + [P["D"][j, :] for j in sticks]
    rhs2 = [-P["gn"][j] for j in held] + [-P["gt"][j] for j in sticks]
    m = len(rows)
    if lib is np:
        K = np.zeros((n + m, n + m))
        K[:n, :n] = P["M"]
        for i, col in enumerate(cols):
            K[:n, n + i] = np.ravel(col)
            K[n + i, :n] = np.ravel(rows[i])
        r = np.concatenate([np.ravel(P["f"]), np.ravel(np.array(rhs2, float))]) if m else np.ravel(P["f"])
        return K, r
    if not m:
        return P["M"], P["f"]
    K = ca.blockcat([[P["M"], ca.horzcat(*cols)], [ca.vertcat(*rows), ca.SX(m, m)]])
    return K, ca.vertcat(P["f"], *rhs2)


def _forces(sig: Signature, z, n, c, mu, lib):
    """``(q̈, λ, τ)`` per contact from the solution ``z`` (zeros where a contact carries none)."""
    held, sticks = sig.held, sig.kept_sticks()
    qdd = z[:n]
    lam = [0.0] * c
    tau = [0.0] * c
    for i, j in enumerate(held):
        lam[j] = z[n + i]
        if sig.modes[j] in (UP, DOWN):
            tau[j] = -mu[j] * _sign(sig.modes[j]) * z[n + i]
    for i, j in enumerate(sticks):
        tau[j] = z[n + len(held) + i]
    if lib is np:
        return qdd, np.array(lam, float), np.array(tau, float)
    return qdd, ca.vertcat(*lam), ca.vertcat(*tau)


def _cone_margins(sig: Signature, lam, tau, mu):
    """Each kept sticking row's cone margin ``μ λ (+ the attached rows' μ λ) − |τ|``."""
    out = []
    for j in sig.kept_sticks():
        cap = mu[j] * lam[j]
        for k, jj in sig.attached:
            if jj == j:
                cap = cap + mu[k] * lam[k]
        out.append((j, cap - ca.fabs(tau[j]) if isinstance(tau, ca.SX) else cap - abs(tau[j])))
    return out


class Phase:
    """A phase's compiled dynamics ``q̈(q, q̇)`` and its event functions (see the module doc)."""

    def __init__(self, parts: Parts, sig: Signature, gap_floor: float):
        self.sig = sig
        n, c, mu = parts.n, parts.c, parts.mu
        E = dict(parts.exprs, mu=mu)
        K, r = _assemble(E, sig, ca)
        z = ca.solve(K, r)
        qdd, lam, tau = _forces(sig, z, n, c, mu, ca)
        s = ca.mtimes(E["D"], parts.qd)
        events, kinds = [], []
        for j, m in enumerate(sig.modes):
            if m == OPEN:
                events.append(E["phi"][j] + gap_floor)
                kinds.append(("impact", j))
            else:
                events.append(lam[j])
                kinds.append(("lift-off", j))
            if m in (UP, DOWN):
                events.append(_sign(m) * s[j])
                kinds.append(("stop", j))
        for j, margin in _cone_margins(sig, lam, tau, mu):
            events.append(margin)
            kinds.append(("slip", j))
        self.kinds = kinds
        self.dyn = ca.Function("phase_qdd", [parts.q, parts.qd], [qdd])
        self.events = ca.Function("phase_events", [parts.q, parts.qd], [ca.vertcat(*events)])
        self.forces = ca.Function("phase_forces", [parts.q, parts.qd], [lam, tau])


def _rank(A: np.ndarray) -> int:
    if A.size == 0:
        return 0
    s = np.linalg.svd(A, compute_uv=False)
    return int(np.sum(s > RANK_TOL * max(s[0], 1e-300)))


def _attach(P, modes: Tuple[str, ...]) -> Optional[Tuple[Tuple[int, int], ...]]:
    """The sticking rows dropped as dependent, each attached to a kept parallel one; ``None`` where the held
    rows are dependent in another way (statically indeterminate normals)."""
    held = [j for j, m in enumerate(modes) if m != OPEN]
    J = P["J"][held, :] if held else np.zeros((0, P["M"].shape[0]))
    if _rank(J) < len(held):
        return None
    kept, attached = [], []
    for j in (j for j, m in enumerate(modes) if m == STICK):
        rows = np.vstack([J] + [P["D"][[k], :] for k in kept] + [P["D"][[j], :]])
        if _rank(rows) == rows.shape[0]:
            kept.append(j)
            continue
        d = P["D"][j, :]
        for k in kept:
            dk = P["D"][k, :]
            if abs(abs(d @ dk) - np.linalg.norm(d) * np.linalg.norm(dk)) <= RANK_TOL * np.linalg.norm(d) * np.linalg.norm(dk):
                attached.append((j, k))
                break
        else:
            return None
    return tuple(attached)


@dataclass
class Choice:
    """The outcome of :func:`select`: the phase, or why there is none."""

    sig: Optional[Signature]
    reason: str = ""


def _options(j, P, phi_tol, v_tol, vn, s):
    """The options of contact ``j`` at this state (open only where it is not closed and at rest)."""
    if not (P["phi"][j, 0] <= phi_tol and abs(vn[j]) <= v_tol):
        return (OPEN,)
    if P["mu"][j] <= 0.0:
        return (HELD, OPEN)
    if abs(s[j]) <= v_tol:
        return (STICK, UP, DOWN, OPEN)
    return (UP if s[j] > 0 else DOWN, OPEN)


def select(parts: Parts, q, v, phi_tol: float, v_tol: float, a_scale: float,
           exclude: Optional[Tuple[int, str]] = None) -> Choice:
    """The phase that continues from ``(q, v)`` (see the module doc); ``exclude``: the contact and mode whose
    event just fired."""
    P = dict(parts(q, v), mu=parts.mu)
    n, c, mu = parts.n, parts.c, parts.mu
    vn = np.ravel(P["J"] @ v)
    s = np.ravel(P["D"] @ v)
    opts = [_options(j, P, phi_tol, v_tol, vn, s) for j in range(c)]
    f_scale = float(np.max(np.abs(P["M"]))) * a_scale
    found: List[Tuple[Signature, np.ndarray]] = []
    for modes in itertools.product(*opts):
        if exclude is not None and modes[exclude[0]] == exclude[1]:
            continue
        attached = _attach(P, modes)
        if attached is None:
            return Choice(None, "statically indeterminate contacts (dependent normal rows)")
        sig = Signature(tuple(modes), attached)
        K, r = _assemble(P, sig, np)
        try:
            z = np.linalg.solve(K, r)
        except np.linalg.LinAlgError:
            continue
        qdd, lam, tau = _forces(sig, z, n, c, mu, np)
        an = np.ravel(P["J"] @ qdd) + np.ravel(P["gn"])
        at = np.ravel(P["D"] @ qdd) + np.ravel(P["gt"])
        ok = True
        for j, m in enumerate(modes):
            if m == OPEN:
                if opts[j] != (OPEN,) and an[j] < -CONSISTENCY_TOL * a_scale:
                    ok = False
            elif lam[j] < -CONSISTENCY_TOL * f_scale:
                ok = False
            elif m in (UP, DOWN) and STICK in opts[j] and _sign(m) * at[j] < -CONSISTENCY_TOL * a_scale:
                ok = False        # a slip from rest goes the way its own acceleration drives it
        for j, margin in _cone_margins(sig, lam, tau, mu):
            if margin < -CONSISTENCY_TOL * f_scale:
                ok = False
        if ok:
            found.append((sig, qdd))
    if not found:
        return Choice(None, "no consistent contact mode (a Painlevé inconsistency)")
    base = found[0][1]
    for sig, qdd in found[1:]:
        if np.max(np.abs(qdd - base)) > AGREE_TOL * a_scale:
            return Choice(None, "contact modes with different motions are all consistent (a Painlevé ambiguity)")
    return Choice(found[0][0])
