"""The search for a step's contact and friction modes: greedy (one change per solve, at the most violated
condition), then every combination of the involved contacts' modes; the impact laws (Newton's, the sequential
cascade, Stronge's with friction) and the slip that stops or turns inside a step (:mod:`.march`'s docstring)."""
from __future__ import annotations

import functools

from itertools import product

import numpy as np

from ...discretise.contact.transcription import ALPHA_MIN
from ...models.impact import (frictional_impact, frictional_impact_plane, sequential_frictional_impact,
                               sequential_impact)
from .modes import (AT_SUB, CLOSES, DOWN, FIX, FREE, GAP_TIMED, HELD, KEPT_OUT, PUSHING, SLIDE,
                    STICK, UP, C, E, F, G, H, I, K, N, O, P, R, T, W, releases, turn_fraction)
from .step import _Step, restage



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
    return "split" if not finest else (why, tuple(modes))


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
    got = _try(step, q, p, h, modes, x0, np.asarray(xh, float).copy(), None)
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


def _try(step: _Step, q, p, h, modes, x0, x, frac):
    """Solve the step in ``modes`` (from ``x``; a newly timed impact from its estimated crossing
    fraction ``frac``): ``(x, gaps at q̃, gaps at q_{k+1}, ν, μ, β, modes used)``, or None if Newton fails
    (the modes used differ where an impact with friction took its impulse from its law: T or P, FIX)."""
    n, c = step.n, step.c
    gapf = step.cm.system.gap
    start = x.copy()
    if frac is not None:
        # a newly timed impact: the sub-node starts at the estimated crossing
        start[2 * n] = min(max(frac - 0.5, ALPHA_MIN - 0.5), 0.5 - ALPHA_MIN)
        start[:n] = q + frac * (x[n:2 * n] - q)
        start = restage(step.cm, start, q)
    xn, ok = step.solve(start, q, p, h, modes)
    timed = [j for j, m in enumerate(modes) if m in GAP_TIMED]
    if timed and not (ok and ALPHA_MIN - 0.5 <= xn[2 * n] <= 0.5 - ALPHA_MIN):
        # Newton on the timing row left the step (its rows go like 1/α near α = 0): the time
        # of the impact by a bracketed search on the gap instead
        xn, ok = _timed_by_bracket(step, x, q, p, h, modes, timed[0])
    if not ok:
        xn, ok = step.solve(x0.copy(), q, p, h, modes)
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




def _friction(step: _Step, q, p, h, modes, x, mufix=None, rfix=None, mufixl=None, rfixl=None):
    """The step's friction modes (Coulomb, maximal dissipation) for its normal modes, by the same greedy
    search: a contact held on the surface (H or R) with a positive coefficient starts as it ended the
    previous step (sticking if it was free); sticking fails where the ratio |ρ| exceeds μ_f (it then slides
    against ρ), sliding fails where the slip velocity has the wrong sign (it then sticks).  The slip velocity
    grows with ρ, so one of the three holds: stick ``s = 0, |ρ| ≤ μ_f``, slide ``ρ = −μ_f, s ≥ 0`` or
    ``ρ = μ_f, s ≤ 0``.  Slots with a ratio in ``rfix`` (not NaN: an impact's, :func:`_impact_law`) keep it
    (mode FIX), and ``mufix`` goes with the normal modes F, T and P.  The modes found are
    ``step.last_fmodes``; the point, or None."""
    c = step.c
    step.last_fmodes = [FREE] * (2 * c)
    if not step.nf:
        return x
    cm = step.cm
    # slots: the node's force of each contact (held or released: ν free), then its sub-node impulse (held)
    # (a caught arrival, C, holds its contact from the sub-node on: its impulse has friction like a held one's,
    # against the slip after the sub-node)
    # (an arrival too slow to be an impact, I below impact_speed_steps |a_n| h, is the discrete form of persistent
    # contact: its impulse has a held one's friction too, and no impact law, _impact_law)
    # (a contact released at the step's impact: its share of the first part's force slides or sticks as its node slot,
    # ContactMechanics.left_velocity; a K arrival's friction after its sub-node is a held one's, like C's)
    slow = _slow_arrivals(step, q, p, h) if any(mj == I for mj in modes) else np.zeros(c, bool)
    active = [mj in HELD and cm.mu_f[j] > 0 for j, mj in enumerate(modes)] + \
        [(mj in CLOSES or (mj == I and slow[j])) and cm.mu_f[j] > 0 for j, mj in enumerate(modes)]
    muf = np.concatenate([cm.mu_f, cm.mu_f])
    d = step.fd
    # (a slot starts as it ended the previous step; free, or fixed there by an impact's law, it starts sticking)
    fm = [(step.fprev[i] if step.fprev[i] not in (FREE, FIX) else STICK) if active[i] else FREE for i in range(2 * c)]
    if rfix is not None:
        fixed = np.isfinite(np.asarray(rfix, float).reshape(2 * c, d)[:, 0])
        fm = [FIX if fixed[i] else f for i, f in enumerate(fm)]
        rfix = np.where(np.isfinite(rfix), rfix, 0.0)
    slips = np.array([m in AT_SUB for m in modes], float)
    judge = functools.partial(_friction_judged, step, q, p, h, modes, slips, muf,
                              dict(mufix=mufix, rfix=rfix, mufixl=mufixl, rfixl=rfixl))
    seen = set()
    start = x
    for _ in range(step.o.friction_rounds):
        key = tuple(fm)
        if key in seen:
            break
        seen.add(key)
        got = judge(fm, x)
        if got is None:
            break
        xf, pick = got
        if pick is None:
            step.last_fmodes = fm
            return xf
        fm = list(fm)
        fm[pick[0]] = pick[1]
        x = xf
    # the greedy search cycled or stalled (a slip that stops or turns within the step, where the slots of the
    # node and the sub-node interact): every combination of the free slots' modes, fewest changes first
    slots = [i for i in range(2 * c) if active[i] and fm[i] != FIX]
    choices = (STICK, UP, DOWN) if d == 1 else (STICK, SLIDE)
    combos = sorted(product(choices, repeat=len(slots)), key=lambda ch: sum(a != fm[i] for a, i in zip(ch, slots)))
    for ch in combos[:step.o.max_combinations]:
        trial = list(fm)
        for i, f in zip(slots, ch):
            trial[i] = f
        if tuple(trial) in seen:
            continue
        got = judge(trial, start)
        if got is not None and got[1] is None:
            step.last_fmodes = trial
            return got[0]
    return None


def _friction_judged(step: _Step, q, p, h, modes, slips, muf, fixed: dict, fm, x0):
    """The step solved in the friction modes ``fm`` from ``x0`` (:func:`_friction`): ``(x, the most violated slot and
    its new mode)``, the pick ``None`` where every slot holds; ``None`` where Newton fails.  Sticking fails where the
    ratio leaves the cone (it then slides against it), sliding where the slip has the wrong sign or, on a tangent
    plane, has vanished (it then sticks)."""
    cm, n, c, d = step.cm, step.n, step.c, step.fd
    xf, ok = step.solve(x0, q, p, h, modes, fmodes=fm, **fixed)
    if not ok:
        return None
    rho = xf[cm.layout["fratio"]]
    slip = np.asarray(cm.slip_row(q, xf[:n], xf[n:2 * n], xf[2 * n], h, slips,
                                  *_parts(cm, xf))).reshape(-1)
    tol = 1e-12 * step.vref
    worst, pick = 0.0, None
    rz, vz = _stage_friction(cm, q, h, xf)
    if d == 2:
        # the circular cone: sticking fails outside it (it then slides), sliding where the slip has vanished (at the
        # slot or at a stage of its part)
        rn = np.maximum(np.linalg.norm(rho.reshape(2 * c, d), axis=1), np.max(np.linalg.norm(rz, axis=2), axis=0, initial=0.0))
        sn = np.minimum(np.linalg.norm(slip.reshape(2 * c, d), axis=1), np.min(np.linalg.norm(vz, axis=2), axis=0, initial=np.inf))
        for j, f in enumerate(fm):
            if f == STICK and rn[j] > muf[j] * (1 + 1e-10):
                viol, new = rn[j] - muf[j], SLIDE
            elif f == SLIDE and sn[j] <= 1e-10 * step.vref:     # the slip has (all but) vanished: sticks
                viol, new = muf[j], STICK
            else:
                continue
            if viol > worst:
                worst, pick = viol, (j, new)
        return xf, pick
    # (planar: each slot's ratio and slip with its part's stages: the largest ratio, the slip's extremes)
    allr = np.vstack([rho[None, :], rz[..., 0]])
    rext = allr[np.argmax(np.abs(allr), axis=0), np.arange(2 * c)]
    slo = np.minimum(slip, np.min(vz[..., 0], axis=0, initial=np.inf))
    shi = np.maximum(slip, np.max(vz[..., 0], axis=0, initial=-np.inf))
    for j, f in enumerate(fm):
        if f == STICK and abs(rext[j]) > muf[j] * (1 + 1e-10):
            viol, new = abs(rext[j]) - muf[j], (DOWN if rext[j] > 0 else UP)
        elif f == UP and slo[j] < -tol:
            viol, new = -slo[j] / step.vref, STICK
        elif f == DOWN and shi[j] > tol:
            viol, new = shi[j] / step.vref, STICK
        else:
            continue
        if viol > worst:
            worst, pick = viol, (j, new)
    return xf, pick


def _stage_friction(cm, q, h, x):
    """The stages' friction ratios and slip velocities of a step's unknowns ``x``, each ``(stages, 2c, d)`` by the slot
    whose part the stage is in (node slots first; none for a two-point scheme or without friction)."""
    c, d, n = cm.c, cm.fd, cm.n
    if not cm.nfz:
        return np.zeros((0, 2 * c, d)), np.zeros((0, 2 * c, d))
    st = cm.dm.scheme.stages
    vel = np.asarray(cm.stage_vel_row(q, x[:n], x[n:2 * n], x[2 * n], h, *_parts(cm, x))).reshape(-1)

    def by_slot(v):
        v = v.reshape(2, st, c, d)
        return np.concatenate([v[0], v[1]], axis=1)
    return by_slot(x[cm.layout["fstage"]]), by_slot(vel)


def _slip_turn(step: _Step, q, p, h, modes, x, fmodes):
    """A held contact whose slip stops or turns inside the step (planar friction, no impact in the step): the step
    again with its sub-node timed there (mode W: the slip velocity at the sub-node, after the contact's share of
    the first part's force, vanishes), the first part sliding as its node slot did and the second sticking or
    sliding the other way.  Found where the node slot slides and the slip at the step's end has turned, and where the
    search let a contact that slid into the step's node stick from it while its slip there still runs (a stop just
    after the node).  ``(x, modes, gaps at q_{k+1}, friction modes)``, or None where no slip turns, or the
    timed step does not solve with valid modes (the step as it was then stands: the turn inside it, first order)."""
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
            if frac is None and step.o.time_held_events and fm[c + j] != slid and sg * s0[j] > 0.0 > sg * s1[j]:
                # (the node momenta's slips bracket the turn, which their half-impulse offset put before the step)
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
                judged = _friction_judged(step, q, p, h, new, np.array([m in AT_SUB for m in new], float),
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
        valid = _friction_judged(step, q, p, h, new, np.array([m in AT_SUB for m in new], float),
                                 np.concatenate([cm.mu_f, cm.mu_f]), {}, trial, xw)
        valid = valid is not None and valid[1] is None
    return (xw, new, gn, trial) if valid else None


def _slow_arrivals(step: _Step, q, p, h):
    """Per contact: approaching the surface slower than ``impact_speed_steps`` steps' worth of its normal
    acceleration at the step's node (the arrivals an answer does not list as impacts, :mod:`.solution`)."""
    cm = step.cm
    v = np.linalg.solve(np.asarray(cm.system.mass_matrix(q)), p)
    an = np.abs(np.asarray(cm.acc_normal(q, v, *step.uarg)).reshape(-1))
    return -(np.asarray(cm.system.gap(q)[1]) @ v) <= step.o.impact_speed_steps * an * h


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


def _parts(cm, x):
    """``[Z⁻, Z⁺]``: the stages of a step's two parts in its unknowns ``x`` (empty for a two-point scheme)."""
    zs = x[cm.layout["zs"]]
    return [zs[:cm.s], zs[cm.s:]]


def _stage_forces(cm, x):
    """The smallest force of each contact at the stages of a step's first and of its second part, ``(c,)`` each
    (zeros for a two-point scheme)."""
    if not cm.sc:
        return np.full(cm.c, np.inf), np.full(cm.c, np.inf)
    lc = x[cm.layout["lam_cstage"]].reshape(2, -1, cm.c)
    return lc[0].min(axis=0), lc[1].min(axis=0)


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
