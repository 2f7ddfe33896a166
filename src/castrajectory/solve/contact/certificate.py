"""The certificate of a contact-implicit optimal-control answer, and its branch re-solves (steps 4 and 5 of :mod:`.control`).

Every step of the answer is marched by the contact march from the answer's own node and incoming momentum under its
control (:func:`_local`), and must land on the answer's next node (relative distance at most
``certificate_tol``).  Where a step does not, the program is solved again on a branch of the march
(:func:`_branch`: its modes fixed, the controls free) and certified again (:func:`certify`); a branch's answer is
marched from the branch's own modes (:func:`.search._started`).  The timing rounds and the answer are
:mod:`.control`'s.
"""
from __future__ import annotations

import math

import numpy as np

from ...discretise.contact.elements import ContactMechanics
from ...result import Certificate, motion_scale
from . import modes as M
from .march import discrete_march
from .state import Problem

#: A step's unknowns of the program that a one-step march gives (its nodes and stages apart): a restarted round takes
#: these (:func:`.events._restart`), the branch point (:func:`_local_point`) these and the stages
STEP_VALUES = ("qs", "beta", "nu", "mu", "mul", "fleft", "fratio")
#: ... and a step's stages and their multipliers, which a restarted round does not take: a one-step march's stages
#: sit on another branch of the stage rows than the answer's neighbours (docs/notes.md, issue 43's measurements)
STAGE_VALUES = ("zs", "lam", "lam_sub", "lam_stage", "lam_cstage", "fstage")


def _start_of(prog, V, q0):
    """``(h, p0, U)`` of the values ``V``: the step length, the initial momentum and the controls per step."""
    cm = prog.cm
    h = float(prog.steps(V)[0])
    if prog.start_velocity:
        p0 = np.asarray(cm.system.momentum(q0, V["v0"])).reshape(-1)
    else:
        p0 = np.asarray(prog.nlp.parameter_value("p0"), float).reshape(-1)
    U = prog._controls(V)[0]
    return h, p0, U


def certify(P: Problem, res, hint=None):
    """Step 5: certify the answer, each of its steps marched from its own node (:func:`_local`); where a step does not
    reproduce it, solve the program again on a branch of the march (its modes fixed, :meth:`ContactNLP.mode_bounds`;
    the controls free) and certify again.  The first branch is the answer's own steps' (:func:`_local_point`: each
    step's modes those of its one-step march from the answer's node, the answer's nodes kept), the next ones that of
    the march of the answer's controls from the start.  A branch's answer is marched from the branch's modes
    (:func:`.search._started`: each step's search starts there, and keeps them where they pass its tests), so that
    a step with two solutions -- a slip that turns at its very start, a landing at its very end -- is checked on the
    side the branch holds.  ``(result, certificate, solves)``: the :class:`~castrajectory.result.Certificate`'s
    ``local`` is the last one-step distance, its ``march`` that of the whole march from the initial state (``inf``
    where a march stopped).  ``hint``: the modes of the branch ``res`` was solved on (``(modes, friction modes)`` per
    step), its steps marched from those first."""
    cm, prog, q0, N, scales, o = P.cm, P.prog, P.q0, P.N, P.scales, P.o
    rho = float(np.asarray(prog.nlp.parameter_value("rho")).reshape(-1)[0])
    solves, last = 0, math.inf
    while True:
        cert, local = _local(P, res.values, hint)
        # (a frictional impact's law (modes T, K): the branch fixes its impulse at the march's value, and the answer's
        # motion moves the law's; each branch from the last answer's march shrinks that mismatch, so the re-solves go
        # on while they contract: resolve_rounds, resolve_contracting in docs/notes.md)
        if (cert <= o.certificate_tol and res.success) or solves >= o.resolve_contracting or \
                (solves >= o.resolve_rounds and not cert < 0.5 * last):
            break
        last = cert
        point = _local_point(cm, res.values, local, N) if solves == 0 else None
        if point is None:
            h, p0, U = _start_of(prog, res.values, q0)
            point = discrete_march(cm, q0, p0, N, h, scales, controls=U, options=o.march_options)
            if point is None or point["steps"].size != N:
                break
        solves += 1
        got = _branch(P, point, res.values, P.bounds, P.ipopt, rho)
        P.steps.extend(got.homotopy)
        if not got.continuable:
            if solves == 1:
                continue          # (the whole march's branch next)
            break
        # (a branch solved only to Ipopt's acceptable level is certified again and solved from there: measured on a
        # sticking block push, where the first branch stopped so)
        res = got
        # its steps are marched from the branch's modes first (:func:`.search._started`): where a step has two
        # solutions, the march checks the one the branch holds
        hint = (point["modes"], point["fmodes"] if "fmodes" in point else
                np.full((N, 2 * cm.c), M.FREE))
    h, p0, U = _start_of(prog, res.values, q0)
    marched = _distance(discrete_march(cm, q0, p0, N, h, scales, controls=U,
                                       options=o.march_options, starts=_starts(cm, res.values, N, hint)),
                        res.values["q"].reshape(N + 1, cm.n), N, h)
    return res, Certificate(cert, marched), solves


def _starts(cm, V, N, hint):
    """Each step's ``(modes, friction modes, unknowns)`` of the values ``V`` solved on the branch of the modes
    ``hint`` (:func:`.search._started`), or None without a branch."""
    if hint is None:
        return None
    X = _step_unknowns(cm, V, N)
    M, F = np.asarray(hint[0]).reshape(N, -1), np.asarray(hint[1]).reshape(N, -1)
    return [(list(M[k]), list(F[k]), X[k]) for k in range(N)]


def _local(P: Problem, V, hint=None, steps=None):
    """The one-step certificate: every step of the answer marched by the contact march from the answer's own node
    ``q_k`` and incoming momentum ``p_k⁻`` under its control, its end against the answer's ``q_{k+1}``; the largest
    distance relative to ``max(1, max |q|)`` (``inf`` where a step's march fails), and the steps' marches (``None``
    where one failed).  As DMOC's: every step is a step of the system under its control, which an unstable motion
    does not amplify (the whole march from the start, the march distance, drifts by 2e-6 over 320 steps on the push
    to a target, where every step lands within 1e-10).  ``steps``: only those steps marched (the others' marches
    None, and the distance theirs alone)."""
    # (the same values are marched twice where the rounds settle: their turns read, then the certificate;
    # each step's march is kept for the values' next call, which marches only the steps not marched yet)
    key = b"".join(np.ascontiguousarray(V[k], float).tobytes() for k in sorted(V)) + \
        (b"" if hint is None else np.asarray(hint[0]).tobytes() + np.asarray(hint[1]).tobytes())
    memo = P.prog.local_memo
    if memo is None or memo[0] != key:
        memo = P.prog.local_memo = (key, {})
    return _local_marches(P, V, hint, range(P.N) if steps is None else steps, memo[1])


def _local_marches(P: Problem, V, hint, steps, done):
    cm, prog, q0, N, scales = P.cm, P.prog, P.q0, P.N, P.scales
    n = cm.n
    h, p0, U = _start_of(prog, V, q0)
    Q, S, B = V["q"].reshape(N + 1, n), V["qs"].reshape(N, n), V["beta"].reshape(N)
    zp = _zparts(prog, V, 1)
    pin = np.asarray(cm.p_node_minus.map(N)(S.T, B, Q[1:].T, h, *zp, prog.step_starts(np.full(N, h))[None, :], U.T)).T
    starts = _starts(cm, V, N, hint)
    worst, marches = 0.0, [None] * N
    for k in steps:
        if k not in done:
            p = p0 if k == 0 else pin[k - 1]
            done[k] = discrete_march(cm, Q[k], p, 1, h, scales, controls=U[k:k + 1],
                                     options=P.o.march_options,
                                     starts=None if starts is None else starts[k:k + 1])
        pt = marches[k] = done[k]
        if pt is None:
            worst = math.inf
            continue
        qn = np.asarray(pt["q"], float).reshape(-1, n)[-1]
        worst = max(worst, float(np.max(np.abs(qn - Q[k + 1]))))
    return worst / motion_scale(Q), marches


def _step_unknowns(cm, V, N) -> np.ndarray:
    """Each step's unknowns of the march (:attr:`ContactMechanics.layout`) from the program's values ``V``, ``(N, nx)``
    (the end node ``q_{k+1}`` for the step's ``q``)."""
    X = np.zeros((N, cm.nx))
    for name, sl in cm.layout.items():
        if sl.stop > sl.start and name in V:
            vals = np.asarray(V[name], float).reshape(-1)
            X[:, sl] = vals[-N * (sl.stop - sl.start):].reshape(N, -1) if name == "q" else vals.reshape(N, -1)
    return X


def _local_point(cm, V, marches, N):
    """The branch point of the answer's own steps: each step's values, modes and friction modes its one-step march's
    (from the answer's node and incoming momentum), the nodes the answer's; ``None`` where a step's march failed or
    halved the step.  Where the march times a slip's turn (mode W) or resolves an arrival at a step's end otherwise
    than the answer (the hopper: the answer's landing at the last sub-node a step allows, the march's at the next
    node), the branch holds the march's modes and its solve moves the answer onto them; the march from the start
    instead drifts from the answer where its motion is unstable (0.13 on the hopper at N = 40, a landing a step
    later)."""
    if any(pt is None or np.asarray(pt["steps"]).size != 1 for pt in marches):
        return None
    out = {"q": np.asarray(V["q"], float).reshape(-1).copy(), "steps": np.concatenate([pt["steps"] for pt in marches])}
    for key in STEP_VALUES + STAGE_VALUES + ("bounced", "modes", "fmodes"):
        if key in marches[0]:
            rows = np.concatenate([np.asarray(pt[key]).reshape(1, -1) for pt in marches])
            out[key] = rows if key in ("modes", "fmodes") else rows.reshape(-1)
    return out


def _branch(P: Problem, point, values, bounds, opts, rho, warm=False):
    """The program on the branch of the march ``point`` (its modes fixed, :meth:`ContactNLP.mode_bounds`; the
    controls, a free final time and a free start free), from ``point`` (the rest from ``values``)."""
    cm, prog, q0, N, verbose, e = P.cm, P.prog, P.q0, P.N, P.verbose, P.o.edge
    branch = prog.mode_bounds(q0, point)
    # (its timed sub-nodes inside the march's window, as a round's: ``edge``)
    branch["beta"] = tuple(np.clip(b, e - 0.5, 0.5 - e) for b in branch["beta"])
    branch.update(bounds)
    if cm.friction:
        # a slot without friction force (an open contact: no force, so its ratio is free; the march fixes it at 0)
        # keeps its ratio in the cone, where the slip pair sets it against the slip
        free = np.asarray(point["fmodes"]).reshape(-1) == M.FREE
        lo_r, hi_r = branch["fratio"]
        muf = np.tile(np.concatenate([cm.mu_f, cm.mu_f]), N)
        branch["fratio"] = (np.where(free, -muf, lo_r), np.where(free, muf, hi_r))
    modes = np.asarray(point["modes"]).reshape(N, cm.c)
    arrive = np.isin(modes, M.SUB_IMPACT)
    prog.hold(timed=arrive, bounce=(modes == M.I) & np.asarray(point["bounced"], bool).reshape(N, cm.c),
              node_impact=np.isin(modes, M.AT_NODE))
    if warm:       # (a continuation's next step: from the last answer on the same branch)
        init = {k: np.asarray(v, float).copy() for k, v in values.items()}
    else:
        init = {k: np.asarray(v, float).reshape(-1).copy() for k, v in point.items() if k in prog.nlp.variable_names}
        for k, v in values.items():
            init.setdefault(k, np.asarray(v, float).copy())
        if cm.friction:
            init.update(_slips(cm, prog, init, P.scales[2]))
    prog.set_law_lengths(point)
    # (the branch starts from a motion that satisfies its rows.  Two barriers, measured on the push to a target: the
    # initial-value branch's small start (1e-8, pushes 1e-8) keeps that point and solved the branch of a slip that
    # stops inside a step at N = 320, where the homotopy's (0.1 adaptive, pushes 1e-2) spent 3000 iterations; at
    # N = 80 the other way round.  The small one first, capped, then the homotopy's)
    got = prog._ladder(init, _small(opts, prog.settings.ipopt, P.o.branch_small_iter), branch, [rho], verbose, "branch",
                       "the march's branch")
    # (one solved only to Ipopt's acceptable level is certify's to check and solve again from, rather than the
    # homotopy's barrier from the march's point, which leaves it: branch_small_iter in docs/notes.md)
    if got.continuable:
        return got
    again = prog._ladder(init, opts, branch, [rho], verbose, "branch", "the march's branch")
    again.homotopy = list(got.homotopy) + list(again.homotopy)
    return again


def _small(opts, base: dict, cap: int) -> dict:
    """``opts`` with the initial-value program's small barrier start (``base``: nothing pushed off its bounds),
    monotone, capped at ``cap`` iterations: a solve from a motion that satisfies its rows."""
    return {**opts, **{k: base[k] for k in ("mu_init", "bound_push", "bound_frac", "slack_bound_push",
                                                     "slack_bound_frac")}, "mu_strategy": "monotone",
            "max_iter": min(int(opts.get("max_iter", 3000)), cap)}


def _slips(cm: ContactMechanics, prog, init, vref) -> dict:
    """The slip splits ``s⁺, s⁻`` of the initial point (its slip velocities' signs)."""
    N, n, c = prog.L, cm.n, cm.c
    Q, S = init["q"].reshape(N + 1, n), init["qs"].reshape(N, n)
    ar = np.asarray(prog.nlp.parameter_value("arrive"), float).reshape(N, c)
    sl = np.asarray(cm.slip_row.map(N)(Q[:-1].T, S.T, Q[1:].T, init["beta"].reshape(N), prog.steps(init), ar.T,
                                       *_zparts(prog, init, 0), *_zparts(prog, init, 1))).T / vref
    out = {"slip_plus": np.maximum(sl, 0.0).reshape(-1), "slip_minus": np.maximum(-sl, 0.0).reshape(-1)}
    if cm.nfz:      # (and the stages' displacements, ContactControlTranscription's stage slip split)
        H = prog.steps(init)
        sz = np.asarray(cm.stage_slip_row.map(N)(Q[:-1].T, S.T, Q[1:].T, init["beta"].reshape(N), H,
                                                 *_zparts(prog, init, 0), *_zparts(prog, init, 1))).T / vref
        out.update(stage_slip_plus=np.maximum(sz, 0.0).reshape(-1), stage_slip_minus=np.maximum(-sz, 0.0).reshape(-1))
    return out


def _zparts(prog, V, part):
    """The stages of each step's first (``part`` 0) or second part as the elements' mapped input, ``[(s, N)]``."""
    return [prog._stages(V)[part][0].T]


def _distance(point, Q, N: int, h: float) -> float:
    """The march ``point`` against the optimal nodes ``Q``: the largest distance at the grid's nodes, relative to
    ``max(1, max |Q|)`` (``inf`` where the march stopped)."""
    if point is None:
        return math.inf
    steps = np.asarray(point["steps"], float)
    Qm = np.asarray(point["q"], float).reshape(steps.size + 1, -1)
    tm = np.concatenate([[0.0], np.cumsum(steps)])
    k = np.rint(tm / h)
    at = np.abs(tm - k * h) <= 1e-9 * h
    Qm, k = Qm[at], k[at].astype(int)
    if k.size != N + 1:
        return math.inf
    return float(np.max(np.abs(Qm - Q[k]))) / motion_scale(Q)
