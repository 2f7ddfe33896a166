"""The search for a step's contact modes: greedy (one change per solve, at the most violated condition), then every
combination of the involved contacts' modes; the impact laws (Newton's, the sequential cascade, Stronge's with
friction) (:mod:`.march`'s docstring).  The friction modes of a step are :mod:`.friction_modes`, the held contacts'
transitions timed inside it (a slip's stop or turn, a release, a stick's end) :mod:`.transitions`."""
from __future__ import annotations

from itertools import product

import numpy as np

from ...discretise.contact.transcription import ALPHA_MIN
from ...models.impact import (frictional_impact, frictional_impact_plane, sequential_frictional_impact,
                               sequential_impact)
from .friction_modes import _friction, _slow_arrivals, _stage_forces
from .modes import (CLOSES, DOWN, FREE, GAP_TIMED, HELD, KEPT_OUT, PUSHING, STICK, UP, C, E, F, G, H, I, K, N,
                    O, P, R, T, W, releases)
from .step import _Step, restage
from .transitions import _grip_timing, _release_timing, _slip_turn


def _timed_by_bracket(step: _Step, x, q, p, h, modes, j: int):
    """The step with contact ``j`` timing its sub-node, by regula falsi (Illinois) on ``β``: each trial
    solves the step with ``β`` fixed, and the sub-node's gap of ``j`` is positive at the step's start
    (``α = ALPHA_MIN``) and negative at the crossing the free flight showed.  ``(x, ok)``."""
    n = step.n
    gapf = step.cm.system.gap

    def f(b, start):
        xb, ok = step.solve(start, q, p, h, modes, bfix=b)
        return (float(np.asarray(gapf(xb[:n])[0]).reshape(-1)[j]) if ok else np.nan), xb

    lo, hi = ALPHA_MIN - 0.5, 0.5 - ALPHA_MIN
    flo, xlo = f(lo, x)
    fhi, xhi = f(0.0, x)
    if fhi >= 0.0:
        lo, flo, xlo = 0.0, fhi, xhi
        fhi, xhi = f(hi, x)
    else:
        hi = 0.0
    if not (flo > 0.0 and fhi < 0.0):
        return x, False
    side = 0
    for _ in range(100):
        b = hi - fhi * (hi - lo) / (fhi - flo)
        fb, xb = f(b, xlo if side <= 0 else xhi)
        if not np.isfinite(fb):
            return x, False
        if abs(fb) <= 1e-15 * step.ell or hi - lo <= 1e-15:
            break
        if fb > 0.0:
            lo, flo, xlo = b, fb, xb
            if side > 0:
                fhi *= 0.5
            side = 1
        else:
            hi, fhi, xhi = b, fb, xb
            if side < 0:
                flo *= 0.5
            side = -1
    # the timed rows from there (one or two Newton steps); the bracket's point if Newton leaves it
    xt, ok = step.solve(xb, q, p, h, modes)
    if ok and ALPHA_MIN - 0.5 <= xt[2 * n] <= 0.5 - ALPHA_MIN:
        return xt, True
    return xb, abs(fb) <= 1e-12 * step.ell


def _crossing_fraction(g0, gs, gn, alpha):
    """Estimated time fraction in the step at which a gap that is positive at ``q_k`` crosses zero, from
    its values at the node, the sub-node (fraction ``alpha``) and the next node (linear pieces)."""
    if gs < 0.0:
        return alpha * g0 / (g0 - gs)
    return alpha + (1.0 - alpha) * gs / (gs - gn) if gn < 0.0 else 1.0


def _march_step(step: _Step, q, p, h, g_q, held_prev, tol, finest: bool, start=None):
    """One step from ``(q, p)``: ``(q̃, q_{k+1}, β, ν, μ, λ, λ̃, modes, gaps at q_{k+1}, friction ratios,
    friction modes)`` (:func:`_result`), ``"split"`` if
    it needs two impacts at different times (and is not the finest step), or ``(reason, detail)``.

    The modes are searched greedily (one change per solve, at the most violated condition); if that
    cycles or stalls, every combination of modes of the contacts involved (touching at ``q_k``, or seen
    crossing) is tried, fewest changes first (:func:`_enumerate`).  ``start``: ``(modes, friction modes, x)``
    tried first, from ``x`` (:func:`_started`)."""
    c = step.c
    pen = 1e-12 * step.ell
    touch = g_q <= tol
    step.held_start = touch & held_prev
    # (the friction modes the previous step ended in: which contacts stuck at the step's start)
    step.fprev_start = list(step.fprev[step.c:]) if step.nf else [FREE] * step.c
    v = np.linalg.solve(np.asarray(step.cm.system.mass_matrix(q)), p)
    x0 = restage(step.cm, np.concatenate([q + 0.5 * h * v, q + h * v, np.zeros(step.cm.nx - 2 * step.n)]), q)
    if start is not None:
        got = _started(step, q, p, h, g_q, tol, finest, x0, start)
        if got is not None:
            return got
    # a flight that landed on this node (to rounding) arrives with its impact here: Newton's law at the node
    an = np.abs(np.asarray(step.cm.acc_normal(q, v, *step.uarg)).reshape(-1))
    arriving = touch & ~held_prev & (-(np.asarray(step.cm.system.gap(q)[1]) @ v) > step.o.impact_speed_steps * an * h)
    modes0 = [N if arriving[j] else H if (touch[j] and held_prev[j]) else O for j in range(c)]
    modes, tried, crossed = list(modes0), set(), set()
    x, frac, why = x0, None, "rounds"
    for _ in range(step.o.mode_rounds):
        key = tuple(modes)
        if key in tried:
            why = "cycle"
            break
        tried.add(key)
        got = _try(step, q, p, h, modes, x0, x, frac)
        if got is None:
            why = "newton"
            break
        x, gs, gn, nu, mu, b, used = got
        crossed |= set(np.where((gs < -pen) | (gn < -pen))[0].tolist())
        change = _next_modes(modes, touch, g_q, gs, gn, nu, mu, b, pen, tol, step, finest)
        if change is None:
            out = _solved(step, q, p, h, x, used, gn, tol)
            if out is not None:
                return out
            why = "the sequential law"
            break
        if change == "split":
            return "split" if not finest else ("split at the finest step", key)
        modes, frac = change
    found = _enumerate(step, q, p, h, g_q, touch, modes0, crossed, x0, pen, tol, finest)
    if found is not None:
        return found
    turned = _turn_of_a_slide(step, q, p, h, modes0, x0)
    if turned is not None:
        return turned
    return "split" if not finest else (why, tuple(modes))


def _turn_of_a_slide(step: _Step, q, p, h, modes, x0):
    """A step no untimed mode solves, where a contact slid into it: the step solved with its slots sliding as they
    did, unjudged, and its slip's stop or turn timed from that (:func:`_slip_turn`); the timed step's result, or None.
    (A stop early in the step's first part has no untimed friction modes: sliding through the step turns its slip,
    and sticking from the node needs a node impulse beyond the cone.  The search then halved the step until the
    stop fell in a part some mode solved: the launched block push with galerkin4 and its optimal force at its
    quadrature nodes, N = 20, stopped at 0.097 of step 12, and the march's grid, four parts there, was not the
    program's)"""
    if not step.nf or step.fd != 1 or any(m not in (O, H) for m in modes):
        return None
    c = step.c
    active = [modes[i % c] == H and step.cm.mu_f[i % c] > 0 for i in range(2 * c)]
    # (each held slot slides as the step before left it; a march's first step has none, docs/notes.md)
    fm = [(step.fprev[i] if step.fprev[i] in (UP, DOWN) else STICK) if active[i] else FREE for i in range(2 * c)]
    if not any(fm[j] in (UP, DOWN) for j in range(c)):
        return None
    xs, ok = step.solve(x0.copy(), q, p, h, modes, fmodes=fm)
    if not ok:
        return None
    # (the turn's first estimate then the slips' at the step's ends, s₀/(s₀ − s₁), not the half-impulse offset of
    # turn_fraction, which the slide through the turn, its friction never reversed, doubles)
    turned = _slip_turn(step, q, p, h, modes, xs, fm, through=True)
    return None if turned is None else _result(step, *turned)


def _base_mode(m: str, touching: bool):
    """The mode a step's search starts from for the mode ``m`` found before, or None where it cannot hold: the modes
    an impact law sets (T timing the sub-node, F taking part, P at the node, K caught) go back to the arrival's (the
    law is the search's to apply again); a held, released, turning or node-impact contact touches at ``q_k``, an
    arrival from flight does not."""
    if m == F:
        m = H if touching else I
    m = {T: I, K: C, P: N, E: H, G: H}.get(m, m)
    if m == O or (m in (H, R, W, N)) == touching:
        return m
    return None


def _started(step: _Step, q, p, h, g_q, tol, finest, x0, start):
    """The step in given modes (a solved program's own, :func:`.certificate.certify`): ``start = (modes, friction modes,
    x)``, solved from ``x`` by the step's Newton and judged by the search's own tests -- every force and multiplier
    of its sign, every gap open, every friction slot in its cone or sliding with its slip (:func:`_friction`, which
    starts from the given friction modes), the impact laws applied again (:func:`_cascade`, :func:`_impact_law`),
    a slip that turns inside an untimed step timed (:func:`_slip_turn`).  The step's result where they all hold,
    else None (and the search runs as without ``start``).  Where a step has two solutions (a slip that turns at a
    step's very start: timed there or sticking from the node), the given one is the one the search checks.  A given
    impact whose bounce ends inside the touching band stays an impact where its gap is not negative (the search's
    catch, :func:`_next_modes`, is its choice for a flight the grid does not resolve, not a condition of the step:
    the hopper's landing at the last sub-node a step allows, its foot 9.5e-10 above the floor at the next node,
    cycled there between the impact and the catch, whose hold pulls)."""
    hint, fhint, xh = start
    touch = g_q <= tol
    modes = [_base_mode(m, bool(touch[j])) for j, m in enumerate(hint)]
    if any(m is None for m in modes):
        return None
    saved = list(step.fprev)
    step.fprev = list(fhint)
    slip_timed = any(m in (W, G) for m in modes)
    got = _try(step, q, p, h, modes, x0, np.asarray(xh, float).copy(), None, fmodes=list(fhint) if slip_timed else None)
    if got is not None and slip_timed and not ALPHA_MIN - 0.5 <= got[5] <= 0.5 - ALPHA_MIN:
        got = None          # (its timed sub-node left the step)
    if got is not None:
        x, gs, gn, nu, mu, b, used = got
        if _next_modes(modes, touch, g_q, gs, gn, nu, mu, b, 1e-12 * step.ell, tol, step, finest,
                       catch=False) is None:
            out = _solved(step, q, p, h, x, used, gn, tol)
            if out is not None:
                return out
    step.fprev = saved
    return None


def _solved(step: _Step, q, p, h, x, used, gn, tol):
    """A step whose modes ``used`` pass the search's tests, finished: the impact laws applied (:func:`_cascade`), a
    slip that turns inside an untimed step timed (:func:`_slip_turn`); its result (:func:`_result`), or None where
    the sequential law rejects it."""
    law = _cascade(step, q, p, h, x, used, tol)
    if law == "rejected":
        return None
    if not law:
        turned = _slip_turn(step, q, p, h, used, x, step.last_fmodes)
        if turned is not None:
            return _result(step, *turned)
        lifted = _release_timing(step, q, p, h, used, x, step.last_fmodes)
        if lifted is not None:
            return _result(step, *lifted)
        gripped = _grip_timing(step, q, p, h, used, x, step.last_fmodes)
        if gripped is not None:
            return _result(step, *gripped)
    return law or _result(step, x, used, gn, step.last_fmodes)


def _try(step: _Step, q, p, h, modes, x0, x, frac, fmodes=None):
    """Solve the step in ``modes`` (from ``x``; a newly timed impact from its estimated crossing
    fraction ``frac``): ``(x, gaps at q̃, gaps at q_{k+1}, ν, μ, β, modes used)``, or None if Newton fails
    (the modes used differ where an impact with friction took its impulse from its law: T or P, FIX).  ``fmodes``:
    the friction modes of the first solve (frictionless without them; a slip's stop timed at the sub-node, mode W or
    G, needs its own: solved frictionless, the spring-held block push's stop at 0.58 of its step went to β = −17)."""
    n, c = step.n, step.c
    gapf = step.cm.system.gap
    start = x.copy()
    if frac is not None:
        # a newly timed impact: the sub-node starts at the estimated crossing
        start[2 * n] = min(max(frac - 0.5, ALPHA_MIN - 0.5), 0.5 - ALPHA_MIN)
        start[:n] = q + frac * (x[n:2 * n] - q)
        start = restage(step.cm, start, q)
    xn, ok = step.solve(start, q, p, h, modes, fmodes=fmodes)
    timed = [j for j, m in enumerate(modes) if m in GAP_TIMED]
    if timed and not (ok and ALPHA_MIN - 0.5 <= xn[2 * n] <= 0.5 - ALPHA_MIN):
        # Newton on the timing row left the step (its rows go like 1/α near α = 0): the time
        # of the impact by a bracketed search on the gap instead
        xn, ok = _timed_by_bracket(step, x, q, p, h, modes, timed[0])
    if not ok:
        xn, ok = step.solve(x0.copy(), q, p, h, modes, fmodes=fmodes)
        if not ok:
            return None
    xn = _friction(step, q, p, h, modes, xn)
    if xn is None:
        return None
    used = list(modes)
    if step.nf:
        # an impact with friction: its impulse by the frictional impact law, the step solved again with it
        law = _impact_law(step, q, p, h, xn, modes, cascade=False)
        if law == "failed":
            return None
        if law is not None:
            xn, used = law
    o = 2 * n + 1
    step.last_mul = xn[step.cm.layout["mul"]] * releases(used)
    step.last_lc = _stage_forces(step.cm, xn)
    return (xn, np.asarray(gapf(xn[:n])[0]).reshape(-1), np.asarray(gapf(xn[n:2 * n])[0]).reshape(-1),
            xn[o:o + c], xn[o + c:o + 2 * c], float(xn[2 * n]), used)


def _result(step: _Step, x, modes, gn, fmodes=None):
    """The step's values by the transcription's names (:attr:`ContactMechanics.layout`), its modes, the gaps at
    its end node and its friction modes."""
    out = {name: x[sl] for name, sl in step.cm.layout.items()}
    out["beta"] = float(x[2 * step.n])
    if not step.nf:
        out["fratio"] = np.zeros(2 * step.c * step.fd)
    out.update(modes=list(modes), gn=gn, fmodes=list(fmodes) if fmodes is not None else [FREE] * (2 * step.c))
    return out


def _enumerate(step: _Step, q, p, h, g_q, touch, modes0, crossed, x0, pen, tol, finest):
    """Every combination of modes of the contacts involved -- touching at ``q_k`` (H, R or O) or seen
    crossing (O, I or C; at most one timed) -- fewest changes from ``modes0`` first; the first whose
    solve meets every condition, or None."""
    cand = sorted(set(np.where(touch)[0].tolist()) | set(crossed))
    opts = [((N, H, R, O) if modes0[j] == N else (H, R, O)) if touch[j] else (O, I, C) for j in cand]
    combos = []
    for choice in product(*opts):
        if sum(1 for j, mj in zip(cand, choice) if not touch[j] and mj in GAP_TIMED) > 1:
            continue
        modes = list(modes0)
        for j, mj in zip(cand, choice):
            modes[j] = mj
        combos.append((sum(a != b for a, b in zip(modes, modes0)), modes))
    combos.sort(key=lambda t: t[0])
    free = _try(step, q, p, h, modes0, x0, x0, None)
    for _, modes in combos[:step.o.max_combinations]:
        timed = [j for j, mj in enumerate(modes) if mj in GAP_TIMED]
        frac = None
        if timed and free is not None:
            j = timed[0]
            frac = _crossing_fraction(g_q[j], free[1][j], free[2][j], 0.5) if g_q[j] > 0 else ALPHA_MIN
        got = _try(step, q, p, h, modes, x0, x0, frac)
        if got is None:
            continue
        x, gs, gn, nu, mu, b, used = got
        if _next_modes(modes, touch, g_q, gs, gn, nu, mu, b, pen, tol, step, finest) is None:
            law = _cascade(step, q, p, h, x, used, tol)
            if law != "rejected":
                return law or _result(step, x, used, gn, step.last_fmodes)
    return None


def _cascade(step: _Step, q, p, h, x, modes, tol):
    """The sequential law's cascade on a solved step (:func:`_impact_law`), if it changes the step: its
    result; None where it does not apply; ``"rejected"`` where it applies but its step does not solve or ends
    below a surface by more than the touching tolerance ``tol`` (the step is then not solved in these modes:
    the simultaneous law's answer is not this law's, and is never reported as one).  (Contacts the cascade leaves at rest
    against each other stay touching: a higher-order scheme's step then ends them within 1e-9 of the
    surface rather than on it, 2.3e-10 below for galerkin4's cradle, which the stricter 1e-12 refused.)"""
    got = _impact_law(step, q, p, h, x, modes, cascade=True)
    if got is None:
        return None
    if got == "failed":
        return "rejected"
    xs, new = got
    gn = np.asarray(step.cm.system.gap(xs[step.n:2 * step.n])[0]).reshape(-1)
    if np.any(gn < -tol):
        return "rejected"
    return _result(step, xs, new, gn, step.last_fmodes)


def _impact_law(step: _Step, q, p, h, x, modes, cascade: bool):
    """The impact law where it is not the step's own (Newton's law on each contact's normal velocity, in
    the rows): the sequential law's cascade of an impact that several contacts take, and Coulomb friction
    at an impact (:func:`castrajectory.models.impact.frictional_impact`, Stronge's energetic restitution).
    The impulses come from the sub-node's state, which does not depend on them (its time and place, and
    the momentum before it), so the step is solved again with them fixed and only its end moves: the
    contacts in modes T (the one timing the sub-node) and F, at a node's impact P, and each frictional
    impact's friction ratio in mode FIX.  ``cascade``: the sequential law at an impact that several contacts
    take (with friction, each firing the frictional law); else one contact's impact with friction.
    Returns ``(x, modes)``, ``None`` where the law does not change the step (the simultaneous law without
    friction, one frictionless contact, a caught arrival, no impact), or ``"failed"`` where the step with
    the law's impulses does not solve.

    Under the simultaneous law an impact at several contacts is frictionless (no classical law holds
    there); the answer says so (:func:`.solution._simultaneous_warnings`)."""
    cm = step.cm
    seq = cm.system.contact.law == "sequential"
    if not (seq or step.nf):
        return None
    c = step.c
    got = _before_impact(step, q, p, h, x, modes)
    if got is None:
        return None                  # no impact
    involved, qs, pm, at_node = got
    # (an arrival too slow to be an impact is persistent contact: no law; a caught one with friction and e = 0 takes
    # Stronge's law as the first part's closing impulse, mode K, and stays closed after it; with e > 0 a caught
    # arrival is the end of an accumulation, whose law is waived)
    slow = _slow_arrivals(step, q, p, h) if not at_node else np.zeros(c, bool)
    caught = (not cascade and not at_node and step.nf and cm.e == 0.0 and len(involved) == 1
              and modes[involved[0]] == C and cm.mu_f[involved[0]] > 0 and not slow[involved[0]])
    fric = step.nf and any(cm.mu_f[j] > 0 for j in involved) and \
        (at_node or any(modes[j] == I for j in involved) or caught) and \
        not (not cascade and not at_node and not caught and np.all(slow[[j for j in involved if modes[j] == I]]))
    if not involved or (len(involved) >= 2) != cascade or (cascade and not seq) or (not cascade and not fric):
        return None
    got = _law_impulses(step, qs, pm, involved, fric)
    if got is None:
        return "failed"          # a cascade on tangent planes: not modelled (the step fails, and says so)
    Pn, Pt = got
    d = step.fd
    if caught:
        j = involved[0]
        mufixl, rfixl = np.zeros(c), np.zeros((c, d))
        mufixl[j] = Pn[0]
        rfixl[j] = Pt[0] / Pn[0] if Pn[0] > 0 else 0.0
        new = [K if i == j else m for i, m in enumerate(modes)]
        xs = _friction(step, q, p, h, new, x, mufixl=mufixl, rfixl=rfixl.reshape(-1))
        return "failed" if xs is None else (xs, new)
    mufix, rfix = np.zeros(c), np.full((2 * c, d), np.nan)
    slot = 0 if at_node else c
    for j, pn, pt in zip(involved, Pn, Pt):
        if fric and cm.mu_f[j] > 0:
            rfix[slot + j] = pt / pn if pn > 0 else 0.0
    rfix = rfix.reshape(-1)
    if at_node:
        mufix[involved] = Pn / h                  # the node's force: impulse per step
        new = [P if j in involved else m for j, m in enumerate(modes)]
    else:
        mufix[involved] = Pn
        timing = next(j for j, m in enumerate(modes) if m in GAP_TIMED)
        new = [T if j == timing else F if j in involved else m for j, m in enumerate(modes)]
    if step.nf:
        xs = _friction(step, q, p, h, new, x, mufix=mufix, rfix=rfix)
        if xs is None:
            return "failed"
    else:
        xs, ok = step.solve(x, q, p, h, new, mufix=mufix)
        if not ok:
            return "failed"
    return xs, new


def _before_impact(step: _Step, q, p, h, x, modes):
    """The state just before the step's impact (:func:`_impact_law`): ``(the contacts involved, the configuration,
    the momentum before it, whether it is at the node)``, or ``None`` where the step has no impact.  At the node
    ``q_k`` the impulses are h ν and the momentum before is the incoming p; at the sub-node, p̃⁻ with the released
    contacts' shares (ContactMechanics.release_row)."""
    cm = step.cm
    n, c = step.n, step.c
    o = 2 * n + 1
    nu, mu = x[o:o + c], x[o + c:o + 2 * c]
    at_node = any(m == N for m in modes)
    if at_node:
        # an impact at the node q_k: its impulses h ν, the momentum before it the incoming p
        involved = [j for j, m in enumerate(modes) if (m == N or m in (H, R)) and nu[j] > 0.0]
        qs, pm = q, p
    else:
        involved = [j for j, m in enumerate(modes) if m in PUSHING and mu[j] > 0.0]
        if not any(modes[j] in GAP_TIMED for j in involved):
            return None
        qs, b = x[:n], float(x[2 * n])
        # the momentum before the impact: p̃⁻ and the released contacts' shares (ContactMechanics.release_row)
        pm = np.asarray(cm.p_minus(q, qs, b, h, *cm.stage_parts(x[cm.layout["zs"]])[0], step.t0, *step.uarg)).reshape(-1)
        sh = x[cm.layout["mul"]] * releases(modes)
        if np.any(sh):
            pm = pm + np.asarray(cm.system.gap(qs)[1]).T @ sh
            if step.nf:
                pm = pm + np.asarray(cm.system.tangent(qs)).T @ (x[cm.layout["fleft"]] * np.repeat(sh, step.fd))
    return involved, qs, pm, at_node


def _law_impulses(step: _Step, qs, pm, involved, fric: bool):
    """The impact law's normal and tangential impulses ``(Pn, Pt)`` of the contacts ``involved`` at ``qs`` from the
    momentum ``pm``: with friction Stronge's frictional law (one contact) or its sequential cascade (planar), else the
    sequential law; ``None`` for a frictional cascade on tangent planes (not modelled)."""
    cm, c = step.cm, step.c
    # the law in the contacts' velocities: Π = M⁻¹ on the constraints' tangent space (velocities)
    Jx = np.asarray(cm.system.gap(qs)[1])[involved]
    v = cm.dm.velocities(qs[None, :], pm[None, :])[0]
    d = step.fd
    if fric:
        Dall = np.asarray(cm.system.tangent(qs)).reshape(c, d, -1)
        Wr = np.vstack([Jx] + [Dall[involved, a] for a in range(d)])     # normals, then each tangent component
        G = Wr @ cm.dm.velocities(np.repeat(qs[None, :], Wr.shape[0], axis=0), Wr).T
        if len(involved) == 1:
            law = frictional_impact if d == 1 else frictional_impact_plane
            imp = law(G, Wr @ v, cm.mu_f[involved[0]], cm.e)
            Pn, Pt = imp.P[:1], imp.P[1:].reshape(1, d)
        elif d == 1:
            Pn, Pt = sequential_frictional_impact(G, Wr @ v, cm.mu_f[involved], cm.e)
            Pt = Pt.reshape(-1, 1)
        else:
            return None
    else:
        PiJt = cm.dm.velocities(np.repeat(qs[None, :], len(involved), axis=0), Jx)
        Pn, _ = sequential_impact(Jx @ PiJt.T, Jx @ v, cm.e)
        Pt = np.zeros((Pn.size, d))
    return Pn, Pt


def _next_modes(modes, touch, g0, gs, gn, nu, mu, b, pen, tol, step, finest, catch=True):
    """The modes after one change (the most violated condition), ``None`` if the step is solved, or
    ``"split"`` if it needs two impacts at different times.  ``catch``: an impact whose bounce ends within the
    touching tolerance of the surface is caught there (mode C; the search's choice where the grid does not resolve
    the flight); without it, such a step is solved as it is (its gap is not negative)."""
    pick = _multiplier_pick(modes, nu, mu, step)
    if pick is not None:
        return _changed(modes, pick), None
    if b < ALPHA_MIN - 0.5 - 1e-12 or b > 0.5 - ALPHA_MIN + 1e-12:
        return "split"
    got = _gap_pick(modes, touch, gs, gn, pen, tol, catch)
    if got == "split":
        return "split"
    pick, crossing = got
    if pick is not None:
        return _changed(modes, pick), None
    return _crossing_change(modes, crossing, g0, gs, gn, 0.5 + b, step, finest)


def _changed(modes, pick):
    j, m = pick
    out = list(modes)
    out[j] = m
    return out


def _multiplier_pick(modes, nu, mu, step):
    """The most violated sign of a contact's force or impulse (scaled), as ``(contact, its new mode)``; ``None`` where
    none is violated beyond 1e-12.  A held contact's force at a stage of the step's first part counts as its node force
    ν, at a stage of the second part as its sub-node impulse μ (each part's forces hold it through that part)."""
    worst, pick = 0.0, None
    lc1, lc2 = step.last_lc
    nu = np.minimum(nu, np.where(np.isin(modes, HELD), lc1, np.inf))
    mu = np.minimum(mu, np.where(np.isin(modes, CLOSES), lc2 * step.smu / step.snu, np.inf))
    for j, m in enumerate(modes):
        if m in (H, R, N) and nu[j] < 0.0:
            viol = -nu[j] / step.snu
            if viol > worst:
                worst, pick = viol, (j, O)
        if m in (H, I, C, W) and mu[j] < 0.0:
            viol = -mu[j] / step.smu
            if viol > worst:
                worst, pick = viol, (j, {H: R, I: O, C: I, W: R}[m])
        if m == W and (nu[j] < 0.0 or step.last_mul[j] < 0.0):
            # (a turn, given to the search (_started): its node force and its share of the first part's
            # force push, as the march's own turn (_slip_turn) checks)
            viol = -min(nu[j] / step.snu, step.last_mul[j] / step.smu)
            if viol > worst:
                worst, pick = viol, (j, H)
        if m == R and step.last_mul[j] < 0.0:
            # (a released contact's share that pulls at the impact: it leaves at the step's node instead)
            viol = -step.last_mul[j] / step.smu
            if viol > worst:
                worst, pick = viol, (j, O)
    return pick if worst > 1e-12 else None


def _gap_pick(modes, touch, gs, gn, pen, tol, catch):
    """The most violated gap, as ``((contact, its new mode) or None, the open contacts that cross the surface in the
    step)``; ``"split"`` where a contact that must stay out penetrates at the sub-node."""
    worst, pick = pen, None
    crossing = []
    for j, m in enumerate(modes):
        if m == N and (gs[j] < -pen or gn[j] < -pen):
            # the node's impact does not send it off (e = 0, or a slow arrival): held from the node on
            viol = -min(gs[j], gn[j])
            if viol > worst:
                worst, pick = viol, (j, H)
        elif m == O and (gs[j] < -pen or gn[j] < -pen):
            if touch[j]:
                cand = R if gs[j] < -pen and gn[j] >= -pen else H
                viol = -min(gs[j], gn[j])
                if viol > worst:
                    worst, pick = viol, (j, cand)
            else:
                crossing.append(j)
        elif m == R and gn[j] < -pen:
            viol = -gn[j]
            if viol > worst:
                worst, pick = viol, (j, H)
        elif m == I and gn[j] < (tol if catch else -pen):
            # the bounce does not clear the next node (its flight is shorter than the rest of the step:
            # the end of a Zeno accumulation) or lands exactly on it: caught there
            viol = tol - gn[j]
            if viol > worst:
                worst, pick = viol, (j, C)
        elif m in KEPT_OUT and gs[j] < -pen:
            return "split"
    return pick, crossing


def _crossing_change(modes, crossing, g0, gs, gn, alpha, step, finest):
    """The first open contact that crosses the surface in the step arrives (mode I, with its crossing's fraction of
    the step), or is simultaneous with the step's impact, or the step splits for a second impact; ``None`` where none
    crosses."""
    if crossing:
        timed = [j for j, m in enumerate(modes) if m in GAP_TIMED]
        fr = {j: _crossing_fraction(g0[j], gs[j], gn[j], alpha) for j in crossing}
        # a crossing closer to the next node than a sub-node may sit (1 − ALPHA_MIN of the step): the flight
        # lands on the node, whose impact the next step takes (mode N)
        crossing = [j for j in crossing if fr[j] < 1.0 - ALPHA_MIN]
    if crossing:
        first = min(crossing, key=lambda j: fr[j])
        if timed:
            # a crossing after the sub-node's impact: simultaneous with it, or a second impact
            out = list(modes)
            if abs(gs[first]) <= step.o.simultaneous_gap * step.ell:
                out[first] = I
                return out, None
            t = timed[0]
            if not finest:
                return "split"
            if modes[t] == I:
                # the bounce does not let the step end before another contact closes: caught (the
                # accumulation of rocking, which the grid does not resolve)
                out[t] = C
                return out, None
            return "split"
        out = list(modes)
        out[first] = I
        return out, fr[first]
    return None
