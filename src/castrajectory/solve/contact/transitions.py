"""The held contacts' transitions timed inside a step, at its sub-node (docs/derivations.md, "Contact trajectories",
§7): a slip's stop or turn (mode W), a release (E) and a stick's end (G).  Each is tried on a step the search
(:mod:`.search`) solved, where the solved modes show the transition inside the step; the step is solved again with its
sub-node timed by the transition's row, and kept where its modes hold."""
from __future__ import annotations

import numpy as np

from ...discretise.contact.transcription import ALPHA_MIN
from .friction_modes import _friction_judged, _stage_forces
from .modes import CLOSES, DOWN, FREE, HELD, SLIDE, STICK, UP, E, G, H, O, R, W, slips_after, turn_fraction
from .step import _Step, restage


def _slip_turn(step: _Step, q, p, h, modes, x, fmodes, through: bool = False):
    """A held contact whose slip stops or turns inside the step (planar friction, no impact in the step): the step
    again with its sub-node timed there (mode W: the slip velocity at the sub-node, after the contact's share of
    the first part's force, vanishes), the first part sliding as its node slot did and the second sticking or
    sliding the other way.  Found where the node slot slides and the slip at the step's end has turned, and where the
    search let a contact that slid into the step's node stick from it while its slip there still runs (a stop just
    after the node).  ``(x, modes, gaps at q_{k+1}, friction modes)``, or None where no slip turns, or the
    timed step does not solve with valid modes (the step as it was then stands: the turn inside it, first order).
    ``through``: ``x`` slid through the whole step unjudged (no untimed mode solved it,
    :func:`.search._turn_of_a_slide`), and a slip whose ends bracket zero stops inside it."""
    cm, n, c = step.cm, step.n, step.c
    if not step.nf or step.fd != 1 or any(m not in (O, H) for m in modes):
        return None
    fm = list(fmodes)
    qn = x[n:2 * n]
    pn = np.asarray(cm.p_node_minus(x[:n], float(x[2 * n]), qn, h, *cm.stage_parts(x[cm.layout["zs"]])[1],
                                    step.t0, *step.uarg)).reshape(-1)
    v0 = cm.dm.velocities(q[None, :], p[None, :])[0]
    v1 = cm.dm.velocities(qn[None, :], pn[None, :])[0]
    s0 = np.asarray(cm.system.tangent(q)).reshape(-1, n) @ v0
    s1 = np.asarray(cm.system.tangent(qn)).reshape(-1, n) @ v1
    before = getattr(step, "fprev_start", [FREE] * c)
    for j in range(c):
        if modes[j] != H or cm.mu_f[j] <= 0:
            continue
        if step.o.time_held_events and before[j] in (UP, DOWN) and fm[j] != before[j] and step.held_start[j]:
            # it slid into the node and sticks or slides back from it, its slip at the node still running the old way
            slid = before[j]
            sg = 1.0 if slid == UP else -1.0
            frac = (min(sg * s0[j] / (sg * s0[j] - sg * s1[j]), 0.5) if sg * s1[j] < 0.0 else 0.5) \
                if sg * s0[j] > 1e-12 * step.vref else None
        elif fm[j] in (UP, DOWN):
            slid = fm[j]
            sg = 1.0 if slid == UP else -1.0
            frac = turn_fraction(sg * s0[j], sg * s1[j])
            if (through or (frac is None and step.o.time_held_events and fm[c + j] != slid)) \
                    and sg * s0[j] > 0.0 > sg * s1[j]:
                # (the node momenta's slips bracket the turn, which their half-impulse offset put before the step; and
                # a slide through the step, its friction never reversed, turns at the straight line's zero: the
                # offset's estimate started the spring-held block's stop at N = 40 where Newton left the window)
                frac = sg * s0[j] / (sg * s0[j] - sg * s1[j])
        else:
            continue
        if frac is None:
            continue
        frac = min(max(frac, ALPHA_MIN), 1.0 - ALPHA_MIN)
        new = list(modes)
        new[j] = W
        start = restage(cm, np.concatenate([q + frac * (qn - q), x[n:2 * n], [frac - 0.5], x[2 * n + 1:]]), q)
        for after in (STICK, DOWN if sg > 0 else UP):
            trial = list(fm)
            trial[j], trial[c + j] = slid, after
            xw, ok = step.solve(start, q, p, h, new, fmodes=trial)
            if not ok or not (ALPHA_MIN - 0.5 <= xw[2 * n] <= 0.5 - ALPHA_MIN):
                continue
            o = 2 * n + 1
            nu, mu, mul = xw[o:o + c], xw[o + c:o + 2 * c], xw[cm.layout["mul"]]
            lc1, lc2 = _stage_forces(cm, xw)
            held = [i for i, m in enumerate(new) if m in (H, W)]
            valid = all(nu[i] >= 0.0 and mu[i] >= 0.0 and lc1[i] >= 0.0 and lc2[i] >= 0.0 for i in held) \
                and mul[j] >= 0.0
            if valid:
                # every slot's friction mode holds, with the stages of its part (sticking inside the cone, sliding with
                # its slip's sign)
                judged = _friction_judged(step, q, p, h, new, slips_after(new),
                                          np.concatenate([cm.mu_f, cm.mu_f]), {}, trial, xw)
                valid = judged is not None and judged[1] is None
            if valid:
                return xw, new, np.asarray(cm.system.gap(xw[n:2 * n])[0]).reshape(-1), trial
    return None


def _end_forces(step: _Step, q, p, h, modes, x):
    """Each contact's normal force of the continuous motion (:attr:`ContactMechanics.held_force`) at the step's start
    ``(q_k, p_k⁻)`` with the contacts held there, and at its end ``(q_{k+1}, p_{k+1}⁻)`` with the contacts that close
    there and the contact itself (``(c,)`` each; at the end, a contact released in the step is then held on a point
    that its flight has left by O(h³): the force the motion would need there to keep it)."""
    cm, n, c = step.cm, step.n, step.c
    start = np.asarray(step.held_start, float)
    closes = np.array([m in CLOSES for m in modes], float)
    qs, qn, b = x[:n], x[n:2 * n], float(x[2 * n])
    zp = cm.stage_parts(x[cm.layout["zs"]])[1]
    pn = np.asarray(cm.p_node_minus(qs, b, qn, h, *zp, step.t0, *step.uarg)).reshape(-1)
    force = lambda qq, pp, mask: np.asarray(cm.held_force(qq, pp, mask, *step.uarg)).reshape(-1)  # noqa: E731
    F0 = force(q, p, start)
    F1 = np.array([force(qn, pn, np.maximum(closes, np.eye(c)[j]))[j] for j in range(c)])
    return F0, F1


def _release_timing(step: _Step, q, p, h, modes, x, fmodes):
    """A contact held at the step's start whose normal force reaches zero inside the step (no impact in it,
    frictionless contacts): the step again with its sub-node timed there (mode E: the force of the continuous motion
    at the sub-node vanishes, :attr:`ContactMechanics.held_force`), the contact held through the first part and open
    through the second.  A contact the search released at the step's node (its node force ν pulls) or at its
    sub-node (R, untimed) while its force at the node still pushes is released inside the step, as is one held
    through it whose force at the step's end pulls.  ``(x, modes, gaps at q_{k+1}, friction modes)``, or None where no
    force reaches zero in the step or the timed step does not solve with valid modes (the step as it was then
    stands: the release at a sub-node or a node, untimed)."""
    cm, n = step.cm, step.n
    if not step.o.time_held_events or any(m not in (O, H, R) for m in modes):
        return None
    start = np.asarray(step.held_start, bool)
    if not np.any(start):
        return None
    try:
        F0, F1 = _end_forces(step, q, p, h, modes, x)
    except RuntimeError as exc:
        # (dependent held rows: their forces are not functions of the state, _forces_hold)
        if "Evaluation failed" not in str(exc):
            raise
        return None
    cand = [j for j, m in enumerate(modes) if start[j] and cm.mu_f[j] <= 0 and F0[j] > 0.0 and (F1[j] < 0.0 or m != H)]
    if not cand:
        return None
    frac = {j: F0[j] / (F0[j] - F1[j]) if F1[j] < 0.0 else 1.0 - ALPHA_MIN for j in cand}
    j = min(cand, key=lambda i: frac[i])
    f = min(max(frac[j], ALPHA_MIN), 1.0 - ALPHA_MIN)
    new = list(modes)
    new[j] = E
    for i in cand:          # (the others released in the step are held through it: each is timed in its own step)
        if i != j and new[i] == O:
            new[i] = H
    start_x = restage(cm, np.concatenate([q + f * (x[n:2 * n] - q), x[n:2 * n], [f - 0.5], x[2 * n + 1:]]), q)
    got = _timed_solve(step, q, p, h, new, fmodes, start_x)
    if got is None:
        return None
    xw, nu, mu, lc1, lc2, gs, gn = got
    pen = 1e-12 * step.ell
    valid = all((nu[i] >= 0.0 and lc1[i] >= 0.0 if m in HELD else True) and
                (mu[i] >= 0.0 and lc2[i] >= 0.0 if m in CLOSES else True) and
                (gs[i] >= -pen if m not in HELD else True) and (gn[i] >= -pen if m not in CLOSES else True)
                for i, m in enumerate(new))
    return (xw, new, gn, list(fmodes) if fmodes is not None else None) if valid else None


def _timed_solve(step: _Step, q, p, h, modes, fmodes, start_x):
    """The step in ``modes`` with its sub-node timed, from ``start_x``: ``(x, ν, μ, the smallest stage forces of each
    part, the gaps at q̃ and at q_{k+1})``, or None where Newton fails or the sub-node leaves its window."""
    cm, n, c = step.cm, step.n, step.c
    xw, ok = step.solve(start_x, q, p, h, modes, fmodes=fmodes)
    if not ok or not (ALPHA_MIN - 0.5 <= xw[2 * n] <= 0.5 - ALPHA_MIN):
        return None
    o = 2 * n + 1
    lc1, lc2 = _stage_forces(cm, xw)
    return (xw, xw[o:o + c], xw[o + c:o + 2 * c], lc1, lc2, np.asarray(cm.system.gap(xw[:n])[0]).reshape(-1),
            np.asarray(cm.system.gap(xw[n:2 * n])[0]).reshape(-1))


def _grip_timing(step: _Step, q, p, h, modes, x, fmodes):
    """A held contact that sticks at the step's start and whose friction force of the continuous motion reaches its cone
    inside the step (no impact in it): the step again with its sub-node timed there (mode G: the cone margin at the
    sub-node vanishes, :attr:`ContactMechanics.cone_margin`, with the contacts held and sticking through the first
    part), the contact sticking through the first part and sliding through the second, in the direction its force at the
    cone pushes.  Found where the search let a contact that stuck through the previous step slide from the step's node,
    or stick through the step while its margin at the step's end is negative.  ``(x, modes, gaps at q_{k+1}, friction
    modes)``, or None (the step as it was then stands: the stick's end at a node, untimed)."""
    cm, n, c, d = step.cm, step.n, step.c, step.fd
    if not (step.o.time_held_events and step.nf) or any(m not in (O, H) for m in modes):
        return None
    start = np.asarray(step.held_start, bool)
    stuck0 = np.array([start[j] and step.fprev_start[j] == STICK for j in range(c)])
    fm = list(fmodes)
    cand = [j for j in range(c) if modes[j] == H and stuck0[j] and cm.mu_f[j] > 0 and
            (fm[j] != STICK or fm[c + j] != STICK)]
    closes = np.array([m == H for m in modes], float)
    zp = cm.stage_parts(x[cm.layout["zs"]])[1]
    pn = np.asarray(cm.p_node_minus(x[:n], float(x[2 * n]), x[n:2 * n], h, *zp, step.t0, *step.uarg)).reshape(-1)
    ends = [j for j in range(c) if modes[j] == H and stuck0[j] and cm.mu_f[j] > 0 and fm[j] == STICK and
            fm[c + j] == STICK]
    if not cand and not ends:
        return None
    try:
        best = _grip_candidate(step, q, p, x, pn, cand + ends, closes, stuck0, start)
    except RuntimeError as exc:
        # (dependent held or sticking rows, _forces_hold)
        if "Evaluation failed" not in str(exc):
            raise
        return None
    if best is None:
        return None
    j, frac, sgj = best
    f = min(max(frac, ALPHA_MIN), 1.0 - ALPHA_MIN)
    new = list(modes)
    new[j] = G
    trial = list(fm)
    trial[j] = STICK
    trial[c + j] = (UP if sgj > 0 else DOWN) if d == 1 else SLIDE
    return _grip_solved(step, q, p, h, new, trial, x, j, f)


def _grip_candidate(step: _Step, q, p, x, pn, cands, closes, stuck0, start):
    """The earliest stick's end among the contacts ``cands`` (:func:`_grip_timing`): ``(contact, fraction of the step,
    the sign of the slip it starts)``, or None."""
    cm, n, c, d = step.cm, step.n, step.c, step.fd
    stick0 = stuck0.astype(float)
    held0 = start.astype(float)
    best = None
    for j in cands:
        # the direction the contact starts to slip in: against its friction force at the cone (the force's sign at the
        # step's end, sticking there)
        f1 = np.asarray(cm.contact_forces(x[n:2 * n], pn, closes, np.maximum(stick0, np.eye(c)[j]), *step.uarg)).reshape(-1)
        tj = f1[c + j * d:c + (j + 1) * d]
        sg = np.zeros(c)
        sg[j] = -1.0 if (d == 1 and tj[0] > 0) else 1.0
        m0 = float(np.asarray(cm.cone_margin(q, p, held0, stick0, sg, *step.uarg)).reshape(-1)[j])
        m1 = float(np.asarray(cm.cone_margin(x[n:2 * n], pn, closes, np.maximum(stick0, np.eye(c)[j]), sg,
                                             *step.uarg)).reshape(-1)[j])
        if m0 > 0.0 and m1 < 0.0:
            frac = m0 / (m0 - m1)
            if best is None or frac < best[1]:
                best = (j, frac, sg[j])
    return best


def _grip_solved(step: _Step, q, p, h, new, trial, x, j: int, f: float):
    """The step in the modes ``new`` (contact ``j`` in mode G) and friction modes ``trial``, its sub-node started at the
    fraction ``f``: ``(x, modes, gaps at q_{k+1}, friction modes)`` where it solves with valid modes, else None."""
    cm, n, c, d = step.cm, step.n, step.c, step.fd
    start_x = restage(cm, np.concatenate([q + f * (x[n:2 * n] - q), x[n:2 * n], [f - 0.5], x[2 * n + 1:]]), q)
    # (the sub-node's impulse split by the parts' lengths, the first part's share with the node's sticking ratio: its
    # ratio and its impulse multiply, and Newton from a zero share is singular)
    lay = cm.layout
    mu0 = start_x[lay["mu"]][j]
    start_x[lay["mul"].start + j], start_x[lay["mu"].start + j] = f * mu0, (1.0 - f) * mu0
    fl = start_x[lay["fleft"]].reshape(c, d)
    fl[j] = start_x[lay["fratio"]].reshape(2 * c, d)[j]
    start_x[lay["fleft"]] = fl.reshape(-1)
    got = _timed_solve(step, q, p, h, new, trial, start_x)
    if got is None:
        return None
    xw, nu, mu, lc1, lc2, _, gn = got
    valid = all(nu[i] >= 0.0 and mu[i] >= 0.0 and lc1[i] >= 0.0 and lc2[i] >= 0.0 for i, m in enumerate(new) if m != O)
    if valid:
        # every slot's friction holds (the node slots and the first part's stages inside the cone, the sliding ones
        # with their slips' signs)
        valid = _friction_judged(step, q, p, h, new, slips_after(new),
                                 np.concatenate([cm.mu_f, cm.mu_f]), {}, trial, xw)
        valid = valid is not None and valid[1] is None
    return (xw, new, gn, trial) if valid else None
