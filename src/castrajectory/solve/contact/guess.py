"""The event-located guess of a contact trajectory (see the package docstring, step 1)."""
from __future__ import annotations

from typing import Dict, Optional

import numpy as np

from ...models.impact import impact_law, simultaneous_impact
from ...discretise.contact.elements import ContactMechanics
from ...discretise.contact.transcription import ALPHA_MIN, REST_SPEED_STEPS, TOUCH_TOL
from .options import ContactOptions

#: The controls' and the stages' inputs of an element, for the guess (its functions are the two-point guide's, of a
#: system without controls: the initial-value problem)
NO_CONTROL = NO_STAGES = np.zeros(0)





# ----------------------------------------------------------------------------- event-located guess
def _bisect_crossing(cm: ContactMechanics, q, v, tau_hi, active):
    """Earliest time in (0, tau_hi] at which an active gap reaches zero (bisection on the RK4 flow)."""
    lo, hi = 0.0, tau_hi
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        _, _, ph = cm.flow(q, v, mid)
        if np.min(np.asarray(ph).reshape(-1)[active]) < 0.0:
            hi = mid
        else:
            lo = mid
        if hi - lo < 1e-14 * max(tau_hi, 1.0):
            break
    return hi


def _hold(cm: ContactMechanics, q, v, active, iterations: int = 4):
    """Project ``(q, v)`` onto the held contacts: ``φ_j(q) = 0`` (Newton, M-metric) and ``J_j v = 0``."""
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
        return q, v          # a guess that left the reals: the branch solve will say so
    M = np.asarray(cm.system.mass_matrix(q))
    try:
        for _ in range(iterations):
            phi, J = (np.asarray(x) for x in cm.system.gap(q))
            phi, J = phi.reshape(-1)[active], J[active]
            MiJt = np.linalg.solve(M, J.T)
            q = q - MiJt @ np.linalg.lstsq(J @ MiJt, phi, rcond=None)[0]
        J = np.asarray(cm.system.gap(q)[1])[active]
        MiJt = np.linalg.solve(M, J.T)
        v = v - MiJt @ np.linalg.lstsq(J @ MiJt, J @ v, rcond=None)[0]
    except np.linalg.LinAlgError:
        pass
    return q, v


def _held_step(cm: ContactMechanics, q, p, active, h, v, t, iterations: int = 20):
    """One step (starting at the time ``t``) of the discrete motion with the ``active`` contacts held closed
    (``ContactMechanics.held_step``, Newton from the free flight): ``(q̃, q_{k+1}, ν, μ, p_{k+1}⁻)``, or ``None`` if Newton does not converge
    or a held contact would pull (``ν`` or ``μ`` < 0: it is released, the caller flies freely)."""
    n, c = cm.n, cm.c
    mask = active.astype(float)
    x = np.concatenate([q + 0.5 * h * v, q + h * v, np.zeros(c), np.zeros(c)])
    scale = 1.0 + float(np.max(np.abs(p)))
    for _ in range(iterations):
        r, Jr = cm.held_step(x, q, p, mask, h, t)
        r = np.asarray(r).reshape(-1)
        try:
            dx = np.linalg.solve(np.asarray(Jr), -r)
        except np.linalg.LinAlgError:
            return None
        x = x + dx
        if np.max(np.abs(dx)) <= 1e-12 * (1.0 + float(np.max(np.abs(x)))):
            break
    r = np.asarray(cm.held_step(x, q, p, mask, h, t)[0]).reshape(-1)
    # momentum rows (divided by h) and gap rows (lengths) each to their own scale
    length = 1.0 + float(np.max(np.abs(q)))
    if not np.all(np.isfinite(x)) or np.max(np.abs(r[:2 * n])) > 1e-9 * scale / h or \
            np.max(np.abs(r[2 * n:])) > 1e-12 * length:
        return None
    qs, qn, nu, mu = x[:n], x[n:2 * n], x[2 * n:2 * n + c], x[2 * n + c:]
    if np.any(nu[active] < 0) or np.any(mu[active] < 0):
        return None
    p_next = np.asarray(cm.p_node_minus(qs, 0.0, qn, h, NO_STAGES, t, NO_CONTROL)).reshape(-1)
    return qs, qn, nu, np.where(active, mu, 0.0), p_next


def event_guess(cm: ContactMechanics, q0: np.ndarray, v0: np.ndarray, L: int, h: float,
                length: float, v_zeno: float, co: Optional[ContactOptions] = None) -> Dict[str, np.ndarray]:
    """Guess for ``L`` steps from ``(q0, v0)``: RK4 flight with located impacts (see module docstring).

    One impact per step: a second crossing in the same step is not looked for (the flight continues
    through it).  ``co``: the settings (``simultaneous_tol``, ``lookahead_catch``, ``guess_chunk``).
    """
    co = co if co is not None else ContactOptions()
    n, c = cm.n, cm.c
    p0 = np.asarray(cm.system.mass_matrix(q0)) @ np.asarray(v0, float)
    gapf = cm.system.gap
    Q = np.zeros((L + 1, n))
    S = np.zeros((L, n))
    B = np.zeros(L)
    MU = np.zeros((L, c))
    event = np.zeros(L, dtype=bool)
    BOUNCED = np.zeros((L, c), dtype=bool)      # impacts resolved with restitution (not caught, not resting)
    q, v = np.asarray(q0, float).copy(), np.asarray(v0, float).copy()
    Q[0] = q
    # contacts held closed (caught, or resting from the start): the guess then flies constrained
    # to φ_j = 0 for them (plastic), sliding freely along the ground, until the free flight would
    # lift one off
    active = np.zeros(c, dtype=bool)
    tol = TOUCH_TOL * length
    k = 0
    p_held = None  # discrete momentum at the node, while the guess marches the held contacts
    while k < L:
        if np.any(active):
            q, v, p_held, active = _while_held(cm, q, v, p_held, active, h, k, (S, B, MU, event), tol)
            Q[k + 1] = q
            k += 1
            continue
        phi0, J0 = (np.asarray(x) for x in gapf(q))
        phi0 = phi0.reshape(-1)
        touching = phi0 <= tol
        if not np.any(touching):
            # fast path: free flight over a chunk of steps (one mapaccum call) up to the first crossing
            K = min(co.guess_chunk, L - k)
            Qc, Vc, Pc = (np.asarray(x) for x in cm.flights(K)(q, v, h))
            bad = np.where(np.any(Pc < -tol, axis=0))[0]
            i = int(bad[0]) if bad.size else K
            if i:
                Q[k + 1:k + i + 1] = Qc[:, :i].T
                q, v = Qc[:, i - 1].copy(), Vc[:, i - 1].copy()
                k += i
                continue
        else:
            vn0 = J0[touching] @ v
            an0 = np.asarray(cm.acc_normal(q, v, NO_CONTROL)).reshape(-1)[touching]
            if np.all(vn0 <= tol / h) and np.any(an0 < 0) and \
                    np.max(np.abs(J0 @ v)) <= REST_SPEED_STEPS * float(np.max(-an0)) * h:
                # in contact, not separating, pressed on and no fast normal motion anywhere
                # on the body: the guess holds the touching contacts from here
                active = touching.copy()
                q, v = _hold(cm, q, v, active)
                continue
        qn, vn, ph = (np.asarray(x).reshape(-1) for x in cm.flow(q, v, h))
        # contacts that start touching and separate are not crossings
        crossing = ~((phi0 <= tol) & (ph >= -tol))
        if np.any(ph[crossing] < -tol):
            caught, qn, vn = _arrival(cm, q, v, h, k, crossing, (S, B, MU, event, BOUNCED), tol, length, v_zeno, co)
            if caught is not None:
                active = caught
        q, v = qn, vn
        Q[k + 1] = q
        k += 1
    NU = _rest(cm, Q, S, B, MU, event, h, p0, tol)
    out = {"q": Q.reshape(-1), "qs": S.reshape(-1), "beta": B, "mu": MU.reshape(-1), "nu": NU.reshape(-1),
           "bounced": BOUNCED}
    return out


def _arrival(cm: ContactMechanics, q, v, h: float, k: int, crossing, rows, tol: float, length: float, v_zeno: float,
             co: ContactOptions):
    """Step ``k`` of the guess, where an open contact crosses the surface: the crossing located (its sub-node, at
    most ALPHA_MIN of the step from its nodes), and the impact there recorded in ``rows`` (``S, B, MU, event,
    BOUNCED``, in place).  ``(the contacts caught and held from here on, or None for a bounce, the end node and
    velocity)``: a slow arrival (a Zeno accumulation, or a rocking one) is caught together with every contact
    within a slow step's travel; a bounce takes the impact law (one simultaneous impact for contacts that close
    together)."""
    S, B, MU, event, BOUNCED = rows
    c, e = cm.c, cm.e
    Mf, gapf = cm.system.mass_matrix, cm.system.gap
    # the sub-node's time fraction is bounded: an earlier or later crossing is placed at the bound
    tc = min(max(_bisect_crossing(cm, q, v, h, crossing), ALPHA_MIN * h), (1 - ALPHA_MIN) * h)
    qc, vc, phc = (np.asarray(x).reshape(-1) for x in cm.flow(q, v, tc))
    j = int(np.argmin(np.where(crossing, phc, np.inf)))
    Jall = np.asarray(gapf(qc)[1])
    Jc = Jall[j]
    Mc = np.asarray(Mf(qc))
    event[k] = True
    B[k] = tc / h - 0.5
    S[k] = qc
    an = float(np.asarray(cm.acc_normal(qc, vc, NO_CONTROL)).reshape(-1)[j])
    # slow: an arrival the grid does not resolve (below v_z) of a contact that is pressed on
    # (a_n < 0: a bounce would come back, the accumulation of Zeno bouncing or of a pivoting
    # corner).  The rest of the body may move fast (a block pivoting on this corner).
    slow = an < 0 and -float(Jc @ vc) <= v_zeno
    if not slow and e < 1.0:
        # a rocking accumulation: the bounce would barely lift the contact (below v_z h) before
        # another contact closes within LOOKAHEAD_CATCH steps
        bounce = impact_law(Mc, Jc, vc, e)
        _, _, Pf = (np.asarray(x) for x in cm.flights(co.lookahead_catch)(qc, bounce.v_after, h))
        others = np.arange(c) != j
        slow = bool(np.any(Pf[others] < -tol)) and float(np.max(Pf[j])) <= v_zeno * h
    if slow:
        # Zeno accumulation: a slow arrival (below v_zeno, where the NLP may waive the
        # impact law, see ContactNLP) while every contact of the body moves slowly along
        # the normal (sliding along the ground does not count).  It is caught, together
        # with every contact within a slow step's travel: held closed from here on.
        near = crossing & (phc <= phc[j] + v_zeno * h)
        mus, v_after = simultaneous_impact(Mc, Jall[near], vc, 0.0)
        MU[k, near] = mus
        qn, vn, _ = (np.asarray(x).reshape(-1) for x in cm.flow(qc, v_after, h - tc))
        qn, vn = _hold(cm, qn, vn, near)
        return near.copy(), qn, vn
    imp = impact_law(Mc, Jc, vc, e)
    MU[k, j] = imp.mu
    BOUNCED[k, j] = True
    together = np.where(crossing & (phc <= phc[j] + co.simultaneous_tol * length))[0]
    if together.size > 1:
        # contacts that close together (a flat landing): one simultaneous impact
        mus, v_after = simultaneous_impact(Mc, Jall[together], vc, e)
        MU[k, together] = mus
        BOUNCED[k, together] = mus > 0
        imp.v_after = v_after
    qn, vn, ph = (np.asarray(x).reshape(-1) for x in cm.flow(qc, imp.v_after, h - tc))
    return None, qn, vn


def _rest(cm: ContactMechanics, Q, S, B, MU, event, h: float, p0, tol: float) -> np.ndarray:
    """The guess's sub-nodes off the events and its node forces, ``S`` and ``MU`` in place: free sub-nodes (α = ½)
    by a few Newton steps; a resting step's sub-node resting too, with its share of the weight; the node forces
    where the guess touches, by least squares on the node equations, clipped at 0 (returned, ``(L, c)``)."""
    n, c, L = cm.n, cm.c, B.size
    gapf = cm.system.gap
    # (holonomic constraints: the guess leaves their multipliers at 0, the branch solve forms them; friction: the
    # guess's rows carry no friction force, the march resolves it)
    lam0, rho0, rl0 = np.zeros(cm.m), np.zeros(cm.nfr), np.zeros(cm.nfl)
    # free sub-nodes (α = ½) from the nodes: a few Newton steps, all steps at once
    free = ~event
    if np.any(free):
        kk = np.where(free)[0]
        F = cm.free_sub.map(kk.size)
        Z = 0.5 * (Q[kk] + Q[kk + 1])
        for _ in range(4):
            r, Jr = F(Q[kk].T, Z.T, Q[kk + 1].T, h, (kk * h)[None, :])
            r = np.asarray(r).T
            Jr = np.asarray(Jr).reshape(n, kk.size, n).transpose(1, 0, 2)
            Z = Z - np.linalg.solve(Jr, r[..., None])[..., 0]
        S[kk] = Z
    gq = np.asarray(gapf.map(L + 1)(Q.T)[0]).reshape(c, L + 1).T
    # steps that start and end on the ground (a resting body): the sub-node rests too, carrying its
    # share of the weight (least squares on the sub-node equation, clipped at 0), rather than
    # hopping to the apex of a free midpoint flight: both are exact discrete solutions, and this
    # one has no motion at all between the nodes (docs/derivations.md, "Contact trajectories", §2, "A resting ball")
    for k in np.where(~event & (np.min(gq[:-1], axis=1) <= tol) & (np.min(gq[1:], axis=1) <= tol))[0]:
        S[k] = 0.5 * (Q[k] + Q[k + 1])
        r = np.asarray(cm.sub(Q[k], S[k], Q[k + 1], B[k], np.zeros(c), h, np.zeros(c), rl0, lam0, rho0, NO_STAGES, NO_STAGES,
                              k * h, NO_CONTROL)).reshape(-1) * h
        Js = np.asarray(gapf(S[k])[1])
        act = np.asarray(gapf(S[k])[0]).reshape(-1) <= tol
        if np.any(act):
            MU[k, act] = np.maximum(np.linalg.lstsq(Js[act].T, -r, rcond=None)[0], 0.0)
    # node forces where the guess touches: least squares on the node equations, clipped at 0
    NU = np.zeros((L, c))
    gq = gq[:L]
    touching = np.where(np.min(gq, axis=1) <= tol)[0]
    for k in touching:
        if k == 0:
            r = np.asarray(cm.initial(Q[0], S[0], B[0], p0, np.zeros(c), h, lam0, rho0, NO_STAGES, 0.0, NO_CONTROL)).reshape(-1)
        else:
            r = np.asarray(cm.node(S[k - 1], B[k - 1], Q[k], S[k], B[k], np.zeros(c), h, h, lam0, rho0, NO_STAGES,
                                   NO_STAGES, k * h, NO_CONTROL, NO_CONTROL)).reshape(-1)
        J = np.asarray(gapf(Q[k])[1])
        act = gq[k] <= tol
        sol = np.linalg.lstsq(J[act].T, -r, rcond=None)[0]
        NU[k, act] = np.maximum(sol, 0.0)
    return NU


def _while_held(cm: ContactMechanics, q, v, p_held, active, h: float, k: int, rows, tol: float):
    """Step ``k`` of the guess while contacts are held closed (``active``; caught, or resting from the start): the
    discrete motion with the held contacts as constraints (:func:`_held_step`) while it keeps pressing on them and no
    other contact crosses; else a free flight that releases the contacts it lifts off and catches those it crosses.
    Records the step in ``rows`` (``S, B, MU, event``, in place).  ``(q, v, the discrete momentum at the node while
    held or None, the contacts held)``."""
    S, B, MU, event = rows
    Mf, gapf = cm.system.mass_matrix, cm.system.gap
    pk = p_held if p_held is not None else np.asarray(Mf(q)) @ v
    step = _held_step(cm, q, pk, active, h, v, k * h)
    if step is not None:
        phn = np.asarray(gapf(step[1])[0]).reshape(-1)
        closing = ~active & (phn < -tol)
        if np.any(closing):
            # another contact closes during the held step: caught too, held from the step's middle
            step = _held_step(cm, q, pk, active | closing, h, v, k * h)
            if step is not None:
                phn = np.asarray(gapf(step[1])[0]).reshape(-1)
                active = active | closing
    if step is not None:
        qs_k, qn, nu_k, mu_k, p_next = step
        if np.all(phn[~active] >= -tol):
            # the discrete motion with the held contacts (it keeps pressing on them)
            S[k], B[k], event[k] = qs_k, 0.0, True
            MU[k] = mu_k
            return qn, np.linalg.solve(np.asarray(Mf(qn)), p_next), p_next, active
    qn, vn, ph = (np.asarray(x).reshape(-1) for x in cm.flow(q, v, h))
    active &= ~(ph > tol)                        # the free flight lifts it off: released
    closing = ~active & (ph < -tol)              # crossings while held: caught too (a guess)
    if np.any(closing):
        active |= closing
        S[k] = 0.5 * (q + qn)
        B[k] = 0.0
        event[k] = True
        Jc = np.asarray(gapf(S[k])[1])[closing]
        vc = 0.5 * (v + vn)
        MU[k, closing] = simultaneous_impact(np.asarray(Mf(S[k])), Jc, vc, 0.0)[0]
    if np.any(active):
        qn, vn = _hold(cm, qn, vn, active)
    return qn, vn, None, active
