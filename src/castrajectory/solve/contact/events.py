"""The events of a contact-implicit optimal control (:mod:`.control`): which steps hold an impact or a slip's turn,
read from an answer (:func:`read_branch`), the round's rows that hold them (:func:`_event_bounds`), and the events
pinned at their windows' edges moved to the neighbouring step: by the rounds (:func:`_move_edge_arrivals`,
:func:`_move_edge_turns`) and across their nodes on the certified answer (:func:`_across`)."""
from __future__ import annotations

from typing import List, Optional

import numpy as np

from ...discretise.contact.elements import ContactMechanics
from ...discretise.contact.transcription import TOUCH_TOL
from ...result import Certificate, NLPResult
from . import modes as M
from .certificate import STEP_VALUES, _branch, _local, _start_of, certify
from .march import discrete_march
from .options import ContactControlOptions
from .state import Attempt, Branch, Problem


def arrivals(cm: ContactMechanics, Q, S, tol: float, NU=None, p_ref: float = 0.0,
             node_force: float = ContactControlOptions.node_force) -> np.ndarray:
    """Per step and contact: the contact arrives in the step (open at ``q_k``, closed at ``q̃_k`` or ``q_{k+1}``).
    With the node forces ``NU`` (``(L, c)``), a node whose force is above ``node_force`` of the largest (and of the
    momentum scale ``p_ref``) is closed whatever its gap: an interior point leaves a held contact's gap at ``1e-9``
    (its product with the force at Ipopt's tolerance), and read as open, the hopper's stance was an arrival at every
    such node.  (Measured against the largest force alone, a motion with no held contact -- a ball off a wall, every
    node force an interior point's 1e-10 -- closed the node with the largest of them: its impact, in that step, was
    not read, and the next round lost it)"""
    L = S.shape[0]
    if not L:
        return np.zeros((0, cm.c), bool)
    g = cm.gaps
    gq, gs = g(Q), g(S)
    opened = gq[:-1] > tol
    if NU is not None:
        NU = np.asarray(NU, float).reshape(L, cm.c)
        opened &= NU <= node_force * max(float(np.max(NU, initial=0.0)), float(p_ref), 1e-300)
    return opened & (np.minimum(gs, gq[1:]) <= tol)


def bounces(prog, Q, timed: np.ndarray) -> np.ndarray:
    """Per step and contact: an arrival (``timed``) after which the contact is open again at one of the next two nodes
    by more than a resting body's hop (the march's mode I: Newton's law holds), not caught (mode C)."""
    g = prog.cm.gaps(Q)
    nxt, nxt2 = g[1:], np.vstack([g[2:], g[-1:]])
    return timed & ((nxt > prog.open_gap) | (nxt2 > prog.open_gap))


def read_branch(P: Problem, V, edges=(), prev: Optional[Branch] = None) -> Branch:
    """The branch a timing round holds, read from the values ``V``: the arrivals, their bounces, the slips' turns and
    the turns' node ratios (:func:`arrivals`, :func:`bounces`, :func:`slip_turns`); the arrivals pinned at an edge of
    their window (``edges``, :func:`pinned`) moved to the neighbouring step (:func:`_move_edge_arrivals`); the parts
    held at their stages (:func:`stage_holds`, on top of those the last round ``prev`` held)."""
    cm, prog, N, n = P.cm, P.prog, P.N, P.cm.n
    Q = np.asarray(V["q"], float).reshape(N + 1, n)
    timed = arrivals(cm, Q, np.asarray(V["qs"], float).reshape(N, n), P.tol, V.get("nu"), P.scales[1], P.o.node_force)
    turn, ratio = slip_turns(P, V, timed)
    _move_edge_turns(P, V, timed, turn, ratio)
    _move_edge_arrivals(prog, edges, timed, turn)
    holds = stage_holds(P, V, None if prev is None else prev.holds) if cm.sc else None
    return Branch(timed, bounces(prog, Q, timed), turn, ratio, holds)


def at_edge(B, edge: float) -> np.ndarray:
    """``-1``, ``+1`` or ``0`` per step: its sub-node sits at the start or the end of its timing window
    (``β = ±(½ − edge)``, to 1e-6), or inside it."""
    B = np.asarray(B, float)
    return np.where(B >= 0.5 - edge - 1e-6, 1, np.where(B <= edge - 0.5 + 1e-6, -1, 0))


def pinned(P: Problem, res: NLPResult) -> List[tuple]:
    """The events the answer ``res`` holds against an edge of their step's window: ``(step, +1 or -1)`` for every step
    whose sub-node the last round timed (an arrival or a slip's turn) and whose ``β`` sits at an edge of its bounds
    (:func:`at_edge`), or lies within ``near_edge`` of it with a bound multiplier of Ipopt's above ``b_tol`` of the
    cost's scale (an interior
    point stops short of an active bound: 1.2e-3 from the step's end, its multiplier 0.05, on a ball launched at a
    wall whose impact the optimum wants one step later).  The window is the transcription's, not the problem's: such
    an answer is no solution of the continuous problem, whose optimum wants the event beyond the edge."""
    prog, N, o = P.prog, P.N, P.o
    V = res.values
    timed = np.asarray(prog.nlp.parameter_value("timed"), float).reshape(N, -1) > 0
    turn = np.asarray(prog.nlp.parameter_value("release"), float).reshape(N, -1) > 0
    B = np.asarray(V["beta"], float).reshape(N)
    side = at_edge(B, o.edge)
    lam = np.asarray((res.bound_multipliers or {}).get("beta", np.zeros(N)), float).reshape(-1)
    if lam.size == N:
        scale = max(1.0, abs(float(prog.cost(V))))
        near = np.abs(B) >= 0.5 - o.near_edge
        side = np.where((side == 0) & near & (np.abs(lam) > o.b_tol * scale), np.sign(B).astype(int), side)
    return [(int(k), int(side[k])) for k in np.where(np.any(timed | turn, axis=1) & (side != 0))[0]]


def _move_edge_arrivals(prog, edges, timed, turn) -> None:
    """An arrival the round held against an edge of its step's window (:func:`pinned`: ``edges``): the optimum wants
    the impact beyond, in the next step (or the one before), which one round cannot give.  The next round holds it
    there instead (``timed`` moved in place), one step per round, as :func:`_move_edge_turns` moves a slip's turn;
    the rounds go on while an event moves (:func:`.control._timing_rounds`).  (Measured on a ball launched with a free
    velocity at a wall, to be at (0.2, 0) at T = 1.2 by least squares, e = 0.8, N = 45, from a guess that hits the
    wall 4 steps early: the impact stayed against its step's end, certified, the launch 0.31 m/s off the closed
    form's and the cost 0.087 where it is 0)"""
    N = timed.shape[0]
    held = np.asarray(prog.nlp.parameter_value("timed"), float).reshape(N, -1) > 0
    for k, side in edges:
        to = k + side
        if not 0 <= to < N or np.any(timed[to]) or np.any(turn[to]):
            continue
        # (the contact the round held there: the answer, its sub-node against the edge, may no longer read as an
        # arrival in that step)
        for j in np.where(held[k])[0]:
            timed[k, j], timed[to, j] = False, True


def _kept_moves(P: Problem, res: NLPResult, before: Attempt) -> NLPResult:
    """The answer of the rounds that moved pinned events (:func:`_move_edge_arrivals`) where it is converged,
    complementary, off its windows' edges and no costlier than the answer ``before`` they moved from; else that one,
    with the program's parameters set back (its pinned events then say so in the answer's warnings): moved round
    by round without that test, two pinned events can run away from each other (docs/notes.md)."""
    prog = P.prog
    c0 = prog.cost(before.res.values)
    if (res.continuable and res.success and not pinned(P, res)
            and float(prog.residual(res.values)) <= P.o.complementarity_target
            and prog.cost(res.values) <= c0 + 1e-9 * max(1.0, abs(c0))):
        return res
    prog.restore(before.params)
    return before.res


def _across(P: Problem, res: NLPResult, C: Certificate):
    """A certified answer whose events are pinned at their windows' edges (:func:`pinned`), each event moved across
    its node in turn (:func:`_move_across`).  The cheapest certified answer below the answer's cost is taken and its
    own pinned events moved, up to ``across_rounds`` times.  ``(result, certificate, solves, on the node)``: where no move lowers the cost the answer is kept, and its pinned events whose move converged to a
    costlier answer are held on their node (``on the node``, as ``(step, side)``): from either side the program's
    optimum wants the event at the node they share, a local optimum over the event's step.  The others, not moved
    (the horizon's end, a neighbour already holding an event) or whose moved solve failed, stay pinned, and
    :func:`.control._answer` fails the answer."""
    solves, on_node = 0, []
    for _ in range(P.o.across_rounds):
        edges = pinned(P, res)
        on_node = []
        if not edges:
            break

        def across(c0, edge):
            got, spent, held = _move_across(P, res, edge, c0)
            if held:
                on_node.append(edge)          # (converged across the node, and no cheaper there)
            return got, spent
        best, spent = _cheapest(P, res, [lambda c0, e=edge: across(c0, e) for edge in edges])
        solves += spent
        if best is None:
            break
        res, C = best.res, best.certificate
    else:
        on_node = []                          # (the rounds ran out: the last answer's events not tried)
    return res, C, solves, on_node


def _cheapest(P: Problem, res: NLPResult, moves):
    """Each of ``moves`` (``move(c0) -> (a certified Attempt cheaper than c0 or None, solves)``) tried from the
    program as the answer ``res`` left it: ``(the cheapest Attempt or None, solves)``, the program left as that
    Attempt's (or as it was)."""
    prog = P.prog
    c0 = prog.cost(res.values)
    params = prog.parameters()
    best, solves = None, 0
    for move in moves:
        prog.restore(params)
        got, spent = move(c0)
        solves += spent
        if got is not None and (best is None or prog.cost(got.res.values) < prog.cost(best.res.values)):
            best = got
    prog.restore(params if best is None else best.params)
    return best, solves


def _move_across(P: Problem, res: NLPResult, edge, c0: float):
    """The certified answer ``res`` with its event pinned at ``edge`` (``(step, side)``) held in the neighbouring step
    instead (:meth:`.state.Branch.moved`), the answer's other events kept: the program solved from the shifted answer's
    primal values (:func:`_shift`) with a small barrier, then certified (:func:`.certificate.certify`); not from its
    multipliers, which are the other branch's (docs/notes.md).  ``(a certified Attempt cheaper than c0 or None, solves, held on its node: the moved
    solve converged no cheaper)``."""
    cm, prog, N, o = P.cm, P.prog, P.N, P.o
    k, side = edge
    to = k + side
    branch = held_branch(P, res.values)
    if not 0 <= to < N or np.any(branch.events[to]):
        return None, 0, False                 # (nowhere to move: the horizon's end, or a held step)
    branch = branch.moved(k, to)
    prog.hold(timed=branch.timed, bounce=branch.bounce, node_impact=np.zeros(N * cm.c))
    init = {key: v.copy() for key, v in res.values.items()}
    _shift(P, init, k, to)
    window = {**P.bounds, "beta": P.window(branch.free), **_event_bounds(P, branch, init)}
    P.clip(init, branch.free)
    _event_start(cm, branch.turn, branch.ratio, init)
    got = P.ladder(init, {**o.warm_ipopt, "max_iter": o.restart_iter}, window)
    P.steps.extend(got.homotopy)
    drop = c0 - 1e-9 * max(1.0, abs(c0))
    held = bool(got.success and prog.cost(got.values) >= drop)
    if not (got.continuable and prog.cost(got.values) < drop):
        return None, 1, held
    got, C, resolves = certify(P, got)
    if got.success and C.holds(o.certificate_tol) and prog.cost(got.values) < drop:
        return Attempt(got, prog.parameters(), C), 1 + resolves, held
    return None, 1 + resolves, held


def held_branch(P: Problem, V) -> Branch:
    """The branch the program holds now (its last solve's round or branch), as :func:`read_branch` reads one from an
    answer; the turns' ratios those of the values ``V``."""
    N, c = P.N, P.cm.c
    flag = lambda name: np.asarray(P.prog.nlp.parameter_value(name), float).reshape(N, c) > 0  # noqa: E731
    turn = flag("release")
    ratio = np.where(turn, np.asarray(V["fleft"], float).reshape(N, c), 0.0) if P.cm.friction else np.zeros((N, c))
    return Branch(flag("timed"), flag("bounce"), turn, ratio)


def _shift(P: Problem, init, k: int, to: int) -> None:
    """A round's start, in place, where the event timed at an edge of step ``k`` moves to the neighbouring step ``to``
    (:func:`_move_edge_arrivals`): its sub-node moves across the node they share, to the same edge of ``to``'s window
    (the event at the same time, to ``2 edge h``), with its impulses; ``k``'s sub-node goes to its middle, untimed.
    The nodes stay the last answer's, a motion with the event at that node.  (Started from the one-step marches of
    :func:`_restart` instead, the ball off a wall held its impact at a grazing sub-node a step away)"""
    cm, N, e = P.cm, P.N, P.o.edge
    n = cm.n
    Q = np.asarray(init["q"], float).reshape(N + 1, n)
    S = init["qs"].reshape(N, n)
    B = init["beta"].reshape(N)
    shared = max(k, to)                         # the node the two steps share
    S[to] = Q[shared]
    S[k] = 0.5 * (Q[k] + Q[k + 1])
    B[to] = (e - 0.5) if to > k else (0.5 - e)
    B[k] = 0.0
    for key in ("mu", "mul"):
        if key in init:
            v = init[key].reshape(N, -1)
            v[to], v[k] = v[k].copy(), 0.0
    if "fratio" in init and cm.friction:
        r = init["fratio"].reshape(N, -1)
        r[to, cm.c:], r[k, cm.c:] = r[k, cm.c:].copy(), 0.0


def _restart(P: Problem, init, changed) -> bool:
    """A later round's start, in place: the steps whose held events ``changed`` take their unknowns
    (:data:`.certificate.STEP_VALUES`: sub-node, split, forces, impulses, ratios) from their one-step marches
    from the last answer's nodes (those :func:`slip_turns` ran to read its events are not run again), which time those
    events; the nodes stay the answer's.  (The last answer itself violates the new round's rows there: a turn newly
    held at a sub-node that sat elsewhere, an event no longer held whose step keeps its timed ``β``.)  Whether any
    step was restarted."""
    N, ks = P.N, np.where(changed)[0]
    if not ks.size:
        return False
    # (the steps slip_turns did not march, the arrivals' among them, marched here)
    _, marches = _local(P, init, steps=ks)
    for k in ks:
        pt = marches[k]
        if pt is None or np.asarray(pt["steps"]).size != 1:
            continue
        for key in STEP_VALUES:
            if key in pt and key in init:
                row = np.asarray(pt[key], float).reshape(-1)
                init[key].reshape(N, -1)[k] = row
    return True


def _move_edge_turns(P: Problem, V, timed, turn, ratio) -> None:
    """A turn the round held (its step's sub-node timing it) whose sub-node sits at an edge of the step's window
    (``β = ±(½ − edge)``): the optimum wants it beyond, in the next step (or the one before), which one round cannot
    give, since a round holds each event in its step.  The next round holds it there instead (``turn`` and ``ratio``
    moved in place), one step per round.  (Measured on the battery's seed 2: a block pushed over the whole horizon
    stopped at the end of step 74 of 80 and stuck, its stop at the window's edge in two rounds, and cost 18 % above
    the exact discrete optimum of sliding to the end)"""
    if not np.any(turn):
        return
    prog = P.prog
    N, c = turn.shape
    held = np.asarray(prog.nlp.parameter_value("release"), float).reshape(N, c) > 0
    B = np.asarray(V["beta"], float).reshape(N)
    side = at_edge(B, P.o.edge)
    for k, j in zip(*np.where(turn & held)):
        step = int(side[k])
        to = k + step
        if not step or not 0 <= to < N or np.any(timed[to]) or turn[to, j]:
            continue
        turn[k, j] = False
        if not (to == N - 1 and prog.end_velocity):       # (there the end node's force stops the slip: not held)
            turn[to, j], ratio[to, j] = True, ratio[k, j]


def slip_turns(P: Problem, V, timed):
    """Per step and contact: a held contact whose slip stops or turns inside the step, where the march times it
    (mode W): each step of ``V`` marched from its own node (:func:`_local`), in the steps without an arrival
    (``timed``).  ``(turns, the sliding node slots' ratios)``: the program's round times such a step's sub-node at
    the turn too (:func:`_event_bounds`).  (Read from the slip velocities at the step's ends instead, as the march
    first does, the sliding block's stop was a turn where the march's timed step has no valid modes and it keeps
    the untimed one: the round then held a timed stop, and the block push that sticks cost 16.83 against the
    untimed answer's 16.49, at N = 40)"""
    cm, prog, N, c = P.cm, P.prog, P.N, P.cm.c
    out, ratio = np.zeros((N, c), bool), np.zeros((N, c))
    if not cm.friction or cm.fd != 1:
        return out, ratio
    # (a slip turns only at a contact that touches at the step's start, q_k: the other steps are not marched)
    Q = np.asarray(V["q"], float).reshape(N + 1, cm.n)
    touch = np.any(cm.gaps(Q[:-1]) <= TOUCH_TOL * P.scales[0], axis=1) & ~np.any(timed, axis=1)
    _, marches = _local(P, V, steps=np.where(touch)[0])
    for k, pt in enumerate(marches):
        if pt is None or np.asarray(pt["steps"]).size != 1:          # (not marched: no touch, or an arrival)
            continue
        if k == N - 1 and prog.end_velocity:
            # (a given final velocity: the end node's force stops the last step's slip, at the node.  Timed as a
            # turn, a block that slides to rest at T had its stop at the step's edge, and the rounds' and
            # branches' solves stopped at Ipopt's acceptable level, at N = 40 and 80)
            continue
        modes = np.asarray(pt["modes"]).reshape(-1)
        fm = np.asarray(pt["fmodes"]).reshape(-1)
        for j in np.where(modes == M.W)[0]:
            out[k, j], ratio[k, j] = True, (-cm.mu_f[j] if fm[j] == M.UP else cm.mu_f[j])
    return out, ratio


def _event_bounds(P: Problem, branch: Branch, init) -> dict:
    """A round's rows of its events: a timed step's arriving contact on the surface at its sub-node, and the slips
    that turn (:func:`slip_turns`) as the march's mode W
    (:meth:`ContactNLP.mode_bounds`): the step's sub-node at the turn, where the slip velocity after the contact's
    share ``μ⁻`` of the first part's force vanishes (``left_slip``), its normal velocity too (``release``), the
    share's ratio the node slot's, and the sub-node slot's slip the second part's (``arrive``).  Sets the round's
    ``release`` and ``arrive`` parameters (``init``'s sub-nodes pick each timed step's arriving contact; a start is
    moved into these bounds by :func:`_event_start`)."""
    cm, prog, L, c = P.cm, P.prog, P.N, P.cm.c
    timed, turn, ratio = branch.timed, branch.turn, branch.ratio
    t = turn.reshape(-1)
    prog.hold(release=turn, arrive=(timed | turn) if cm.friction else None)
    out = {"mul": (np.zeros(L * c), np.where(t, np.inf, 0.0)),
           "release": (np.where(t, 0.0, -np.inf), np.where(t, 0.0, np.inf))}
    if cm.friction:
        fl = np.where(t, ratio.reshape(-1), 0.0)
        out["fleft"] = (fl, fl)
        out["left_slip"] = (np.where(t, 0.0, -np.inf), np.where(t, 0.0, np.inf))
    # a timed step's sub-node is its arrival's, on the surface, as in the march (its timing row φ(q̃) = 0): the arriving
    # contact closest to the surface at q̃ in the round's start.  (With the sub-node free to stay open, a flight that
    # lands on the next node kept β free, a control of its own, which the march, its flight a plain step, does not
    # have: docs/notes.md)
    gs = np.where(timed, cm.gaps(np.asarray(init["qs"], float).reshape(L, cm.n)), np.inf)
    first = timed & (np.arange(c)[None, :] == np.argmin(gs, axis=1)[:, None])
    # (and a turn's contact is held through its step, closed at q̃_k and q_{k+1}, as the march's W)
    out["sub_gap"] = (np.zeros(L * c), np.where((first | turn).reshape(-1), 0.0, np.inf))
    out["node_gap"] = (np.zeros(L * c), np.where(t, 0.0, np.inf))
    if cm.sc:
        h = np.zeros(L * 2 * cm.sc, bool) if branch.holds is None else branch.holds.reshape(-1)
        out["stage_hold"] = (np.where(h, 0.0, -np.inf), np.where(h, 0.0, np.inf))
    return out


def stage_holds(P: Problem, V, before=None) -> np.ndarray:
    """The parts a round holds at their stages (``(N, 2·stages·c)``, the rows of
    :meth:`ContactMechanics.stage_holds`), as the march holds them: those the last round held (``before``) and those
    whose contact the values ``V`` lift off at a stage while both the part's ends touch the surface (gaps within the
    touch tolerance), while both ends still touch.  (As pairs alone, the stages' gap against the part's end impulses, a
    block pushed along its floor with galerkin4 hopped over the second parts of two steps, a ballistic arc of
    g(h/2)²/8 over the part, and stayed there from ρ = 1e3 to 1e6: the arc and the held stage are two minima of the
    penalties, between which the stage's own pair φ(Z)λ^c rises.  Held in every part that touches at both ends from
    the first round on, the block pushed over the whole horizon, exact at N = 10 with galerkin4, lost its certificate
    at N = 20)"""
    cm, N, st = P.cm, P.N, P.cm.dm.scheme.stages
    Q = np.asarray(V["q"], float).reshape(N + 1, cm.n)
    S = np.asarray(V["qs"], float).reshape(N, cm.n)
    closed = lambda X: cm.gaps(X) <= P.tol  # noqa: E731
    ends = np.concatenate([np.tile(closed(Q[:-1]) & closed(S), (1, st)), np.tile(closed(S) & closed(Q[1:]), (1, st))],
                          axis=1)
    zm, zp = P.prog._stages(V)
    gz = np.asarray(cm.stage_gap.map(N)(*[z.T for z in zm + zp])).T.reshape(N, -1)
    lifted = gz > P.tol
    held = lifted if before is None else (lifted | np.asarray(before, bool).reshape(N, -1))
    return ends & held


def _event_start(cm: ContactMechanics, turn, ratio, start) -> None:
    """A round's start moved into its events' bounds (:func:`_event_bounds`), in place: the turns' shares ``μ⁻`` kept
    and their ratios the node slots', every other share zero."""
    t = turn.reshape(-1)
    if cm.friction:
        start["fleft"] = np.where(t, ratio.reshape(-1), 0.0)
    start["mul"] = np.where(t, np.asarray(start.get("mul", np.zeros(t.size)), float).reshape(-1), 0.0)


def controls_at(t, tu, U) -> np.ndarray:
    """The controls ``U`` (a row per time ``tu``) interpolated linearly at the times ``t``: ``(len(t), columns)``."""
    U = np.asarray(U, float).reshape(len(tu), -1)
    return np.column_stack([np.interp(t, tu, U[:, i]) for i in range(U.shape[1])]) if U.size \
        else np.zeros((len(t), 0))


def node_stops(P: Problem, V) -> List[tuple]:
    """The slips that stop on a node, untimed: ``(k, contact, ratio)`` where a held contact slides through step
    ``k − 1``'s second part (its sub-node slot's slip) and sticks through step ``k``'s first (its node slot's), at an
    interior node ``k`` whose neighbouring steps hold no event; ``ratio`` the sliding slot's friction ratio.  The
    optimum may want the stop inside either step, a turn the rounds do not read: neither step's march, from its own
    node, times it (:func:`slip_turns`)."""
    cm, N, c = P.cm, P.N, P.cm.c
    if not cm.friction or cm.fd != 1:
        return []
    Q = np.asarray(V["q"], float).reshape(N + 1, cm.n)
    NU = np.asarray(V["nu"], float).reshape(N, c)
    sp, sm = (np.asarray(V[k], float).reshape(N, 2 * c) for k in ("slip_plus", "slip_minus"))
    held = cm.gaps(Q[1:N]) <= P.tol
    flag = lambda name: np.asarray(P.prog.nlp.parameter_value(name), float).reshape(N, c) > 0  # noqa: E731
    events = flag("timed") | flag("release")
    tol = 1e-6
    out = []
    for k in range(1, N):
        if np.any(events[k - 1]) or np.any(events[k]):
            continue
        for j in range(c):
            slid = max(sp[k - 1, c + j], sm[k - 1, c + j])
            stuck = max(sp[k, j], sm[k, j]) <= tol * max(slid, 1e-300)
            if held[k - 1, j] and NU[k, j] > 0 and slid > tol and stuck and cm.mu_f[j] > 0:
                out.append((k, j, float(-cm.mu_f[j] if sp[k - 1, c + j] > sm[k - 1, c + j] else cm.mu_f[j])))
    return out


def _onto_steps(P: Problem, res: NLPResult, C: Certificate):
    """A certified answer whose slips stop on nodes (:func:`node_stops`), each stop moved into the step after its node
    and into the step before (:func:`_onto`); the cheapest certified answer below the answer's cost is taken, and its
    own stops on nodes moved, up to ``across_rounds`` times.  ``(result, certificate, solves, moved)``.  (The launched block
    push with galerkin4 at N = 20 stopped on the node at t = 1.2, the optimum's stop 0.0097 s later: 6.5e-4 above J*;
    moved, 6.3e-13)"""
    solves, moved = 0, False
    for _ in range(P.o.across_rounds):
        stops = node_stops(P, res.values)
        if not stops:
            break
        best, spent = _cheapest(P, res, [lambda c0, m=(k, j, ratio, to): _onto(P, res, *m, c0)
                                         for k, j, ratio in stops for to in (k, k - 1)])
        solves += spent
        if best is None:
            break
        res, C, moved = best.res, best.certificate, True
    return res, C, solves, moved


def _onto(P: Problem, res: NLPResult, k: int, j: int, ratio: float, to: int, c0: float):
    """The answer ``res`` with its stop on node ``k`` moved a quarter step into step ``to`` (``k``: after the node;
    ``k − 1``: before it): the answer's controls warped in time (the motion up to the node stretched or shrunk onto
    the quarter step, the rest of the horizon onto what is left) and marched from the start, which times the stop
    there (mode W); the program solved on that march's branch (:func:`.certificate._branch`) and certified from its
    modes.  ``(a certified Attempt cheaper than c0 or None, solves)``.  (Started from the answer itself with the turn
    held in step ``to``, its block at rest on the node, the round held the stop at its window's edge next to the
    node, 1.1e-3 costlier than the stop on the node, where the stop's optimum is a tenth of the step inside it; so
    did the penalty round from the warped controls' march)"""
    cm, prog, N, o = P.cm, P.prog, P.N, P.o
    V = res.values
    h, p0, U = _start_of(prog, V, P.q0)
    t = h * np.arange(N + 1)
    T, tk = t[-1], t[k]
    ts = tk + (0.25 if to == k else -0.25) * h
    tu = cm.control_times(t[:-1], np.full(N, h), np.asarray(V["beta"], float).reshape(N)).reshape(-1)
    tn = cm.control_times(t[:-1], np.full(N, h), np.zeros(N)).reshape(-1)
    warped = np.where(tn <= ts, tn * tk / ts, tk + (tn - ts) * (T - tk) / (T - ts))
    Un = controls_at(warped, tu, np.asarray(U, float).reshape(tu.size, -1)).reshape(N, -1)
    point = discrete_march(cm, P.q0, p0, N, h, P.scales, controls=Un, options=o.march_options)
    if point is None or np.asarray(point["steps"]).size != N:
        return None, 0
    modes = np.asarray(point["modes"]).reshape(N, cm.c)
    if modes[to, j] != M.W:
        return None, 0                # (the march did not stop there)
    values = {key: np.asarray(v, float).copy() for key, v in V.items()}
    values["u"] = Un.reshape(-1)
    got = _branch(P, point, values, P.bounds, P.ipopt, o.penalties[0])
    P.steps.extend(got.homotopy)
    drop = c0 - 1e-9 * max(1.0, abs(c0))
    if not (got.continuable and prog.cost(got.values) < drop):
        return None, 1
    # (its steps marched from the branch's modes first: a stop just after a node is also a stick from the node, the
    # node's friction impulse taking the slip, which the march keeps where the branch does not say otherwise)
    got, Cg, resolves = certify(P, got, (point["modes"], point["fmodes"]))
    # (and off its window's edges: a stop that the moved round holds at its window's edge next to the node wants the
    # node, where the midpoint rule's block push stopped at N = 40 and T = 1, and a move that ends so is no answer)
    if got.success and Cg.holds(o.certificate_tol) and prog.cost(got.values) < drop and not pinned(P, got):
        return Attempt(got, prog.parameters(), Cg), 1 + resolves
    return None, 1 + resolves
