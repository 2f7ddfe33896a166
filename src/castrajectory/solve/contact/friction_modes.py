"""The friction modes of a step (Coulomb, maximal dissipation) for its contact modes, by the search's greedy rule and
then every combination of the slots' modes; the stages' forces, ratios and slips read from a step's unknowns (the
contact modes' search is :mod:`.search`, the held contacts' timed transitions :mod:`.transitions`)."""
from __future__ import annotations

import functools
from itertools import product

import numpy as np

from .modes import CLOSES, DOWN, FIX, FREE, HELD, SLIDE, STICK, UP, I, slips_after
from .step import _Step


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
    slips = slips_after(modes)
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


def _slow_arrivals(step: _Step, q, p, h):
    """Per contact: approaching the surface slower than ``impact_speed_steps`` steps' worth of its normal
    acceleration at the step's node (the arrivals an answer does not list as impacts, :mod:`.solution`)."""
    cm = step.cm
    v = np.linalg.solve(np.asarray(cm.system.mass_matrix(q)), p)
    an = np.abs(np.asarray(cm.acc_normal(q, v, *step.uarg)).reshape(-1))
    return -(np.asarray(cm.system.gap(q)[1]) @ v) <= step.o.impact_speed_steps * an * h


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
