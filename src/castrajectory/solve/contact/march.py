"""The discrete march: the transcription's own rows solved step by step, each step's contact modes by
an active-set search (see the package docstring, step 1).

Every step ``k`` of the contact program has the unknowns ``(q̃_k, q_{k+1}, β_k, ν_k, μ_k)`` and, given the
node ``q_k`` and its incoming momentum ``p_k⁻ = D₂L_d(q̃_{k−1}, q_k)``, the node row, the sub-node row and
one complementarity pair per contact.  An initial-value program is block lower-triangular in the steps,
so the whole program is solved by solving its steps in order, provided each step picks the branch of
its pairs that the whole program's solution has.  Each contact is in one of these modes:

* ``O``, open: ``ν = μ = 0``;
* ``H``, held (touching at ``q_k``): ``φ(q̃) = 0``, ``φ(q_{k+1}) = 0``, ``ν ≥ 0`` and ``μ ≥ 0`` free;
* ``R``, released at the sub-node (touching at ``q_k``): ``φ(q̃) = 0`` with ``ν ≥ 0``, ``μ = 0``;
* ``I``, impact from flight: ``φ(q̃) = 0`` fixes the sub-node's time ``β`` and Newton's law ``r = 0``
  its impulse ``μ ≥ 0``;
* ``C``, caught from flight: ``φ(q̃) = 0`` and ``φ(q_{k+1}) = 0`` (the law waived: the bounce would
  not clear the next node, the grid does not resolve its flight).
* ``N``, an impact at the node ``q_k`` itself (a flight that landed on it, to within ``ALPHA_MIN`` of the
  step, arriving faster than two steps' worth of its normal acceleration): Newton's law at the node fixes
  the node's impulse ``h ν ≥ 0``, ``μ = 0``.

A step starts from the modes the previous step ended in (held contacts held, the others open) and
changes one contact's mode per Newton solve, the one whose gap or multiplier is most violated, until
every gap is ≥ 0 and every multiplier ≥ 0 (each set of modes is tried once); if that cycles, every
combination of the involved contacts' modes is tried (:mod:`.search`).  A step that would need two
impacts at different times is halved, down to ``h / 2**max_splits``.  Steps that keep their modes are
marched many at a time (:meth:`.step._Step.chunk`).  A step that no search solves stops the march: the
caller then falls back to the event-located guess.
"""
from __future__ import annotations

from typing import Dict, Optional

import numpy as np

from ...discretise.contact.elements import ContactMechanics
from ...discretise.contact.transcription import TOUCH_TOL
from . import modes as _modes
from .modes import FIX, FREE, STICK, H, I, O
from .search import _march_step
from .options import ContactOptions, MarchOptions
from .step import _Step



def discrete_march(cm: ContactMechanics, q0, p0, L: int, h: float, scales,
                   max_splits: int = ContactOptions.max_splits, trace: Optional[list] = None, controls=None,
                   starts=None, options: Optional[MarchOptions] = None) -> Optional[Dict[str, np.ndarray]]:
    """The contact program's point for ``L`` steps of ``h`` from ``(q0, p0)``, solved step by step (module
    docstring), on a grid refined where a step would hold two impacts: the point's arrays, ``steps``
    (the step lengths) and ``base`` (the index of each step's base step); ``None`` where a step's mode
    search fails.  ``controls``: the control of every step, ``(L, nu)``, for a system with controls (a
    halved step keeps its base step's).  ``starts``: each step's ``(modes, friction modes, unknowns)``, tried
    before its search (:func:`.search._started`; a halved step searches its own), the steps marched one by one.
    ``options``: the march's settings (:class:`.options.MarchOptions`, the library's by default)."""
    step = _Step(cm, scales, options)
    # the controls of every step, (L, nu): an empty row per step without controls
    U = np.zeros((L, 0)) if controls is None else np.asarray(controls, float).reshape(L, cm.nu)
    # (a chunk's function has a fixed length: its steps past L take the last control, unused)
    U = np.vstack([U, np.repeat(U[-1:], step.o.chunk_steps, axis=0)])
    tol = TOUCH_TOL * scales[0]          # touching: gap within this
    rows = {key: [] for key in _ROWS}
    q, p = np.asarray(q0, float).copy(), np.asarray(p0, float).copy()
    g_q = np.asarray(cm.system.gap(q)[0]).reshape(-1)
    held_prev = g_q <= tol
    rows["q"].append(q)
    k, span, t = 0, 8, 0.0
    while k < L:
        touch = g_q <= tol
        # (with friction the held contacts' slots keep the modes they ended the previous step in: sticking or
        # sliding, each step checked)
        held = touch & held_prev
        fm = [FREE] * (2 * cm.c)
        if cm.friction:
            act = [bool(held[j % cm.c]) and cm.mu_f[j % cm.c] > 0 for j in range(2 * cm.c)]
            fm = [(step.fprev[i] if step.fprev[i] not in (FREE, FIX) else STICK) if act[i] else FREE
                  for i in range(2 * cm.c)]
        step.uarg, step.t0 = [U[k]], t
        if L - k >= 2 and np.all(~touch | held_prev) and starts is None:
            got = _chunk(step, rows, q, p, h, held, fm, k, min(span, L - k), span, U, tol)
            if got is not None:
                i, span, after = got
                if i:
                    q, p, g_q = after
                    held_prev = held.copy()
                    k, t = k + i, t + i * h
                    continue
        got = _one_step(step, rows, q, p, h, k, g_q, held_prev, tol, max_splits,
                        starts[k] if starts is not None else None, trace)
        if got is None:
            return None
        q, p, g_q, held_prev = got
        k, t = k + 1, t + h
    return _arrays(cm, rows)


def _chunk(step: _Step, rows, q, p, h, held, fm, k: int, K: int, span: int, U, tol: float):
    """Steps that keep their modes (open contacts stay open, held ones held: free flight, a body resting or sliding),
    many in one call (:meth:`_Step.chunk` with those modes: the same rows, Newton to rounding), accepted up to the
    first step that touches or crosses with an open contact, pulls on a held one, or does not converge; the accepted
    ones recorded in ``rows``.  Chunks run 8 to ``chunk_steps`` steps: ``span`` doubles after a chunk accepted whole
    (``K`` of its steps used), and goes back to 8 after a break; one function per length and system.  ``None`` where
    the chunk's Newton system was singular, else ``(steps accepted, the next span, (q, p, gaps) after them)``."""
    cm = step.cm
    c, lay = cm.c, cm.layout
    x0 = np.zeros(cm.nx)
    for name, sl in lay.items():       # the last step's values start the chunk's first Newton
        if rows.get(name) and name not in ("q", "qs", "beta", "zs"):
            x0[sl] = np.asarray(rows[name][-1], float).reshape(-1)[:sl.stop - sl.start]
    try:
        Qn, Pn, X, Gs, Gn, Rr, SL, VZ = (a[:, :K] if a.ndim == 2 else a[:K]
                                     for a in step.chunk(span, q, p, h, held, fm, x0,
                                                         U[k:k + span]))
    except RuntimeError as exc:
        # (a singular Newton system: friction rows at zero force, no step before the chunk yet.  Only CasADi's failed
        # evaluation is that; a call the chunk's function refuses is a defect, raised)
        if "Evaluation failed" not in str(exc):
            raise
        return None
    NU, MU = X[lay["nu"]], X[lay["mu"]]
    NU[~held], MU[~held] = 0.0, 0.0          # open: their rows ν = μ = 0, exactly
    ok = (Rr <= step.o.chunk_tol * (1.0 + np.max(np.abs(X), axis=0)))
    ok &= np.all((Gs > tol) & (Gn > tol) | held[:, None], axis=0)
    ok &= np.all((NU >= 0.0) & (MU >= 0.0) | ~held[:, None], axis=0)
    if cm.sc:   # (and its forces at the stages)
        LC = X[lay["lam_cstage"]].reshape(-1, c, X.shape[1])
        ok &= np.all((LC >= 0.0) | ~held[None, :, None], axis=(0, 1))
    if step.o.time_held_events and np.any(held):
        # a held contact whose force of the continuous motion falls below zero by the step's end is released inside
        # it, and a sticking one whose friction force leaves its cone starts to slide inside it: that step is marched
        # alone, where its sub-node times the event (modes E and G, transitions._release_timing and _grip_timing)
        stuck = np.array([held[j] and fm[j] == STICK and fm[c + j] == STICK for j in range(c)]) if cm.friction \
            else np.zeros(c, bool)
        ok &= _forces_hold(cm, Qn, Pn, held, stuck, U[k:k + K])
    if cm.friction:
        ok &= step.friction_holds(fm, X[lay["fratio"]], SL, X[lay["fstage"]], VZ)
        # a sliding contact whose slip turns inside a step (planar): that step is marched alone, where its
        # sub-node times the turn (mode W, transitions._slip_turn)
        ok &= ~_turns(cm, fm, held, np.column_stack([q, Qn]), np.column_stack([p, Pn]))
    i = int(np.argmin(ok)) if not np.all(ok) else K
    span = min(2 * span, step.o.chunk_steps) if i == K else 8
    if not i:
        return 0, span, None
    modes = [H if hj else O for hj in held]
    for j in range(i):
        vals = {name: X[sl, j] for name, sl in lay.items()}
        vals.update(q=Qn[:, j], beta=0.0, nu=NU[:, j], mu=MU[:, j],
                    fratio=X[lay["fratio"], j] if cm.friction else np.zeros(2 * c))
        _record(rows, vals, np.zeros(c, bool), h, k + j, modes, list(fm))
    step.fprev = list(fm)
    return i, span, (Qn[:, i - 1].copy(), Pn[:, i - 1].copy(), Gn[:, i - 1].copy())


def _forces_hold(cm: ContactMechanics, Qn, Pn, held, stuck, U) -> np.ndarray:
    """Per chunk step (columns of its end nodes ``Qn`` and momenta ``Pn``): the continuous motion's forces there push at
    every held contact, and keep every sticking one inside its cone (:attr:`ContactMechanics.contact_forces`)."""
    c, d, K = cm.c, cm.fd, Qn.shape[1]
    try:
        if not cm.friction:
            F = np.asarray(cm.held_force.map(K)(Qn, Pn, held.astype(float), U.T)).reshape(c, K)
            return np.all((F >= 0.0) | ~held[:, None], axis=0)
        out = np.asarray(cm.contact_forces.map(K)(Qn, Pn, held.astype(float), stuck.astype(float), U.T)).reshape(-1, K)
    except RuntimeError as exc:
        # (the held contacts' rows are dependent -- a box on two corners of one edge, statically indeterminate: their
        # forces are not functions of the state, and no event of theirs is timed by them)
        if "Evaluation failed" not in str(exc):
            raise
        return np.ones(K, bool)
    lam, tt = out[:c], out[c:].reshape(c, d, K)
    margin = cm.mu_f[:, None] * lam - np.linalg.norm(tt, axis=1)
    return np.all((lam >= 0.0) | ~held[:, None], axis=0) & np.all((margin >= 0.0) | ~stuck[:, None], axis=0)


def _one_step(step: _Step, rows, q, p, h, k: int, g_q, held_prev, tol: float, max_splits: int, start, trace):
    """Step ``k`` marched alone (:func:`_march_step`), halved where it would hold two impacts, its parts recorded in
    ``rows``: ``(q, p, gaps, held)`` at its end, or ``None`` where a part's mode search fails (``trace`` told why).
    ``start``: the step's ``(modes, friction modes, unknowns)`` to try first (a halved part searches its own)."""
    cm = step.cm
    pending = [h]
    while pending:
        hk = pending.pop(0)
        t_part = step.t0                # (this part's start; a halved step's second part starts after its first)
        out = _march_step(step, q, p, hk, g_q, held_prev, tol, finest=hk < h / 2 ** max_splits * 1.5,
                          start=start if hk == h else None)
        if out == "split":
            pending[:0] = [0.5 * hk, 0.5 * hk]
            continue
        if isinstance(out, tuple) and len(out) == 2:
            if trace is not None:
                trace.append((k, hk) + out + (q, p, g_q, held_prev))
            return None
        modes, gn, fmodes = out["modes"], out["gn"], out["fmodes"]
        _record(rows, out, np.array([m == I for m in modes]) & (gn > tol), hk, k, modes, fmodes)
        step.fprev = list(fmodes)
        qn = out["q"]
        p = np.asarray(cm.p_node_minus(out["qs"], out["beta"], qn, hk,
                                       *cm.stage_parts(out["zs"])[1], t_part, *step.uarg)).reshape(-1)
        step.t0 = t_part + hk
        held_prev = np.array([m in _modes.CLOSES for m in modes])
        q, g_q = qn, gn
    return q, p, g_q, held_prev


def _arrays(cm: ContactMechanics, rows) -> Dict[str, np.ndarray]:
    """The march's rows as the program's point: flat arrays, without the entries the system does not have."""
    out = {key: np.asarray(val) for key, val in rows.items()}
    for key in _VALUES:
        if key != "beta":
            out[key] = out[key].reshape(-1)
    if not cm.m:
        del out["lam"], out["lam_sub"]
    if not cm.friction:
        del out["fratio"], out["fmodes"], out["fleft"]
    if not cm.s:
        del out["zs"]
    if not (cm.s and cm.m):
        del out["lam_stage"]
    if not cm.sc:
        del out["lam_cstage"]
    if not cm.nfz:
        del out["fstage"]
    return out


def _turns(cm, fm, held, Q, Pm) -> np.ndarray:
    """Per chunk step (columns of its nodes ``Q`` and momenta ``p⁻`` there, the step's start first): a held contact
    sliding through the step (its node slot UP or DOWN, planar friction) has its slip turn or stop inside it
    (:func:`.modes.turn_fraction`)."""
    K = Q.shape[1] - 1
    out = np.zeros(K, bool)
    if cm.fd != 1:
        return out
    sl = [(j, 1.0 if fm[j] == _modes.UP else -1.0) for j in range(cm.c) if held[j] and fm[j] in (_modes.UP, _modes.DOWN)]
    if not sl:
        return out
    V = cm.dm.velocities(Q.T, Pm.T)
    S = np.array([np.asarray(cm.system.tangent(Q[:, k])) @ V[k] for k in range(K + 1)])
    for k in range(K):
        out[k] = any(_modes.turn_fraction(sg * S[k, j], sg * S[k + 1, j]) is not None for j, sg in sl)
    return out


#: The per-step values of the march by the transcription's names (``q`` is the step's end node) ...
_VALUES = ("q", "qs", "beta", "nu", "mu", "lam", "lam_sub", "fratio", "zs", "lam_stage", "mul", "fleft", "lam_cstage",
           "fstage")
#: ... and the march's own records.
_ROWS = _VALUES + ("bounced", "steps", "base", "modes", "fmodes")


def _record(rows, values, bounced, h, base, modes, fmodes) -> None:
    """Append one step: its ``values`` by name (:data:`_VALUES`) and the march's records."""
    for key in _VALUES:
        rows[key].append(values[key])
    for key, val in zip(("bounced", "steps", "base", "modes", "fmodes"), (bounced, h, base, modes, fmodes)):
        rows[key].append(np.array(val) if key in ("modes", "fmodes") else val)

