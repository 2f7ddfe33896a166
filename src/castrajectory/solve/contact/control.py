"""Contact-implicit optimal control, solved whole by Ipopt and certified by the contact march.

The program is :class:`castrajectory.discretise.contact.control.ContactControlTranscription`.  The solve:

1. **Guess**: the controls' guess (zero, clipped to the bounds, or the user's) is marched from the initial
   state with the contact march (:func:`.march.discrete_march`): a motion of the system with its impacts,
   contact forces and friction already consistent, so the homotopy starts from a feasible motion.
2. **Timing**: the sub-node of a step is where an impact is timed; it is free (``β`` an unknown) only in the
   steps where a contact arrives (open at ``q_k``, closed at ``q̃_k`` or ``q_{k+1}``), and centred (``β = 0``)
   elsewhere, as in the march.  (A free ``β`` in every step would be a control of its own: two midpoint parts
   of lengths ``αh`` and ``(1 − α)h`` are a different step map, and the cost moved ``β`` to its bounds.)  A timed
   step's sub-node is its arrival's, on the surface.  The steps where a held contact's slip stops or turns are timed
   too, as the march times them (its mode W, :func:`slip_turns`): the sub-node at the turn, where the slip velocity
   vanishes.  A timed sub-node stays :data:`EDGE` of its step from the nodes, inside the window where the march
   times an event.  Which steps arrive or turn is read from the solution and the program solved again, warm, until
   it no longer changes (:data:`TIMING_ROUNDS`); the steps whose events changed start the next round from their
   one-step marches, which time those events (:func:`_restart`).
3. **Penalty ladder**: the exact ℓ1 penalties of the complementarity pairs rise (``PENALTY``), each solve warm
   started from the last, until the scaled complementarity residual is at most ``COMPLEMENTARITY_TOL``.
4. **Certificate** (:mod:`.certificate`): every step of the answer is marched by the contact march from the answer's own node and
   incoming momentum under its control, and must land on the answer's next node (relative distance at most
   :data:`CERTIFICATE_TOL`): every step is then a step of the system under its own controls, impacts and friction
   included (the one-step certificate, as DMOC's).  Where a step does not, the program is solved again on a branch
   of the march (step 5): first the answer's own steps' (each step's modes those of its one-step march), then that
   of the optimal controls marched from the initial state.  An answer not certified is a failure,
   with the distance in its message.  The whole march from the initial state is reported beside it
   (``march_distance``): it adds the motion's own amplification of rounding (and a sliding block's neutral drift).
5. **B-stationarity**, a measured proxy (:func:`b_stationarity`): at every pair whose both factors vanish, no
   multiplier says the cost would fall by flipping that pair's branch.
"""
from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field
from typing import List, Optional

import casadi as ca
import numpy as np

from ...discretise.contact.control import ContactControlTranscription
from ...discretise.contact.elements import ContactMechanics
from ...discretise.contact.transcription import TOUCH_TOL
from ...discretise.optimal_control import split_controls
from ...result import NLPResult
from .. import budget
from ..nlp import NLP
from ...result import SUCCESS_STATUSES, ControlResult
from ...validation import InputError
from .certificate import (CERTIFICATE_TOL, EDGE, STEP_VALUES, _branch, _local, _polish, _slips,
                          _start_of, _zparts)
from . import modes as M
from .march import discrete_march
from .nlp import CONTACT_IPOPT, ContactNLP
from .strategy import _length_scale
from .strategy import _scales as strategy_scales

#: Ipopt options of the contact-implicit solve, on top of CONTACT_IPOPT.  The initial-value program starts its barrier
#: at 1e-8 (its guess is the answer); here the guess is a motion far from the optimum, and from there a small
#: barrier let the first iterations throw the block off the floor into a local minimum of the penalties (N = 20:
#: Ipopt's default barrier start solved it, 253 iterations).  The adaptive barrier: 75 iterations (N = 20), and
#: on the ladder of grids 15 on N = 80, 23 on N = 160, where the monotone one took 607 there and stopped on
#: a worse motion (cost +0.41).
#: The optimality tolerance is Ipopt's default, 1e-8 (the initial-value program's 1e-10 is a feasibility
#: problem's): the hopper at N = 40 stopped at Ipopt's acceptable level on every branch at 1e-10, its dual
#: infeasibility about 1e-9, and solved to 1e-8 in 7 s, certified to 7e-12.  (It costs the bounce to a target
#: four digits of its launch speed, 1.5e-11 against 2e-15.  Accepting the acceptable level with its tolerances
#: tightened to 1e-8 instead ground the hopper's branches to their iteration limits)
OCP_CONTACT_IPOPT = {"tol": 1e-8, "max_iter": 3000, "mumps_pivtol": 1e-8, "mu_init": 1e-1, "mu_strategy": "adaptive",
                     "bound_push": 1e-2, "bound_frac": 1e-2, "slack_bound_push": 1e-2, "slack_bound_frac": 1e-2}
#: Ipopt's warm start of a timing round from the last round's primal-dual point: a small barrier, nothing pushed
WARM_IPOPT = {"warm_start_init_point": "yes", "mu_init": 1e-6, "warm_start_bound_push": 1e-9,
              "warm_start_mult_bound_push": 1e-9, "warm_start_bound_frac": 1e-9, "warm_start_slack_bound_push": 1e-9,
              "warm_start_slack_bound_frac": 1e-9}
#: Ipopt's start of the ladder of grids' first round, from a motion near the optimum: a small barrier (adaptive, as
#: the homotopy's), nothing pushed off its bounds.  (Monotone from 1e-8, as a branch's first try, it stopped with
#: the block pushes' costs 2.5e-7 off their exact discrete optima, at the barrier's own perturbation)
NEAR_IPOPT = {"mu_init": 1e-6, "bound_push": 1e-8, "bound_frac": 1e-8, "slack_bound_push": 1e-8,
              "slack_bound_frac": 1e-8}
#: The penalty ladder of the contact-implicit solve.
OCP_PENALTY = (1e3, 1e4, 1e5, 1e6)
#: Ipopt iterations of one contact-implicit solve in all (its rounds, rungs, branches and coarser grids), where the
#: run sets no budget of its own.  (Certified answers took at most 6740 over the batteries' seeds 1 and 2 with the
#: hopper, 44 s; a hopper goal that did not certify ran 9873, 65 s, past the battery's 60, and at 8000 it took 60.4 s
#: with two batteries sharing the machine's two cores)
ITERATION_BUDGET = 7000
#: Solves with the arrivals read from the last answer, at most (step 2 of the module docstring).
TIMING_ROUNDS = 6
#: Timing rounds beyond TIMING_ROUNDS while an event pinned at its window's edge moves to the next step
#: (_move_edge_arrivals).  (The ball off a wall walks its impact 4 steps in 4 rounds)
MOVE_ROUNDS = 6
#: Ipopt iterations of a restarted round's warm solve (:func:`_restart`), after which it starts from the last answer
#: (restarted rounds took at most 451 on the hopper's goals 0.53, 0.7, 0.85 and 0.98)
RESTART_ITER = 500
#: Ipopt iterations of one step of the end conditions' continuation (keep_modes).
CONTINUATION_ITER = 150
#: A grid of more steps than this starts from the controls of the answer on half as many (see solve_contact_control).
LADDER_MAX = 32
#: The contact-implicit ladder's complementarity target (ContactNLP.complementarity_target; it fails above
#: COMPLEMENTARITY_TOL only)
COMPLEMENTARITY_TARGET = 1e-11
#: A node force above this fraction of the largest closes its node (arrivals)
NODE_FORCE = 1e-6
#: A biactive pair's multiplier of the descent sign above this (relative to max(1, |cost|)) is a descent found by
#: flipping the pair's branch (b_stationarity); Ipopt's multipliers hold to its dual tolerance
B_TOL = 1e-6


class _Program(ContactControlTranscription, ContactNLP):
    program = NLP
    #: (the certificate's march takes a contact as touching within TOUCH_TOL ℓ: a held contact's gap, at
    #: a scaled product of 1e-8 with its force, was 2e-9 on the hopper, and the march flew from it.  At 1e-11 the
    #: products leave gaps below the march's tolerance)
    complementarity_target = COMPLEMENTARITY_TARGET
    #: the one-step marches of the last values certified (:func:`.certificate._local`): ``(key, {step: march})``
    local_memo = None


def mechanics(system, scheme: str) -> ContactMechanics:
    """The contact elements of ``system`` and ``scheme``, built once per pair and kept with the system."""
    return system.derived(("contact elements", scheme), lambda: ContactMechanics(system, scheme))


@dataclass(kw_only=True)
class ContactControlResult(ControlResult):
    """A contact-implicit optimal control's answer: :class:`ControlResult`, plus the sub-node configurations
    ``qs`` (``(N, n)``) and their times ``t_sub``, the impulses ``mu`` at the sub-nodes and the node forces ``nu``
    (``(N, c)`` each), the friction ratios ``fratio`` (``(N, 2c)``: node and sub-node slots), the impacts
    (``impact_times``, one list per contact: the sub-node times of the steps where the contact arrives with an
    impulse), ``complementarity``: the scaled complementarity residual at the answer (the penalties' pairs, as
    the initial-value program measures it), ``homotopy``: the penalty steps of every timing round, ``certificate``:
    each step of the optimal controls marched from the answer's own node against its next one (``CERTIFICATE_TOL``),
    and ``march_distance``: the whole march from the initial state against the answer."""

    qs: Optional[np.ndarray] = None
    t_sub: Optional[np.ndarray] = None
    mu: Optional[np.ndarray] = None
    nu: Optional[np.ndarray] = None
    fratio: Optional[np.ndarray] = None
    impact_times: List[List[float]] = field(default_factory=list)
    complementarity: float = math.nan
    homotopy: list = field(default_factory=list)
    timing_rounds: int = 0
    #: the cost's error estimated from the ladder's previous grid (half the steps) at order 2, |J_N − J_{N/2}|/3
    #: (NaN without a previous grid); the cost's order is the scheme's at most, and 2 where a contact switches inside
    #: a step's part
    cost_estimate: float = math.nan
    #: the B-stationarity proxy (:func:`b_stationarity`): the pairs whose both factors vanish, the largest multiplier
    #: there that signals a descent by flipping the pair's branch (relative to max(1, |cost|)), and whether it is at
    #: most B_TOL (no descent found)
    biactive: int = 0
    b_violation: float = math.nan
    b_stationary: bool = False
    #: the events held at an edge of their step's timing window (:func:`pinned`): ``{"step", "t", "edge"}`` each; an
    #: answer with one is not a solution of the continuous problem, and fails (``Event_Pinned``)
    pinned: List[dict] = field(default_factory=list)

    def as_dict(self) -> dict:
        return {**super().as_dict(), "qs": self.qs, "t_sub": self.t_sub, "mu": self.mu, "nu": self.nu,
                "fratio": self.fratio, "impact_times": self.impact_times, "complementarity": self.complementarity,
                "cost_estimate": self.cost_estimate, "biactive": self.biactive, "b_violation": self.b_violation,
                "b_stationary": self.b_stationary, "pinned": self.pinned,
                "timing_rounds": self.timing_rounds,
                "homotopy": [vars(h) for h in self.homotopy]}


def _scales(system, q0, v0, length: float, u, T: float):
    """The initial-value program's scales (:func:`.strategy._scales`) from the acceleration under the controls' guess
    ``u`` (``system.acceleration`` has no controls), mass-weighted: the largest generalized force ``|M q̈|`` over the
    largest inertia, since the penalties weigh momenta (``p_ref = m_ref v_ref``); and at least ``length/T²``, a
    motion over the scene's length in the horizon ``T``.  (The hopper's leg, 0.1 kg against the body's 1.1, is
    accelerated at 108 m/s² by the guess's leg force, which set v_ref = 10.4 m/s where the motion's speeds are
    about 1: its solves stalled at Ipopt's acceptable level with dual infeasibilities up to 1e13, and no answer
    certified; weighted, v_ref = 3.1, and the N = 40 answer certifies to 7e-12.  A weightless block pushed from
    rest by a zero guess has no acceleration of its own: v_ref was 1e-8, and Ipopt stopped at its iteration limit,
    cost 6e5 against 12.03)."""
    qdd = ca.substitute(system._index1_exprs()[0], system.control_vector, ca.DM(u))
    M = np.asarray(system.mass_matrix(q0))
    a = np.asarray(ca.Function("acc", [system.q, system.qd], [qdd])(q0, v0)).reshape(-1)
    acc = float(np.max(np.abs(M @ a))) / float(np.max(np.diag(M)))
    return strategy_scales(system, q0, v0, length, max(acc, length / T ** 2))


def arrivals(cm: ContactMechanics, Q, S, tol: float, NU=None, p_ref: float = 0.0) -> np.ndarray:
    """Per step and contact: the contact arrives in the step (open at ``q_k``, closed at ``q̃_k`` or ``q_{k+1}``).
    With the node forces ``NU`` (``(L, c)``), a node whose force is above ``NODE_FORCE`` of the largest (and of the
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
        opened &= NU <= NODE_FORCE * max(float(np.max(NU, initial=0.0)), float(p_ref), 1e-300)
    return opened & (np.minimum(gs, gq[1:]) <= tol)


def bounces(prog, Q, timed: np.ndarray) -> np.ndarray:
    """Per step and contact: an arrival (``timed``) after which the contact is open again at one of the next two nodes
    by more than a resting body's hop (the march's mode I: Newton's law holds), not caught (mode C)."""
    g = prog.cm.gaps(Q)
    nxt, nxt2 = g[1:], np.vstack([g[2:], g[-1:]])
    return timed & ((nxt > prog.open_gap) | (nxt2 > prog.open_gap))


def solve_contact_control(system, T, N: int, scheme: str, start, end, running, final, u_bounds,
                          controls, guess: Optional[dict] = None, options: Optional[dict] = None,
                          verbose: bool = False, keep_modes: bool = False, path=()) -> ContactControlResult:
    """Solve a contact-implicit optimal-control problem (:func:`_solve_contact_control`) within
    :data:`ITERATION_BUDGET` Ipopt iterations in all, or a run's own budget (``--max-iter``) where one is set."""
    args = (system, T, N, scheme, start, end, running, final, u_bounds, controls, guess, options, verbose, keep_modes,
            path)
    if budget.remaining() is not None:
        return _solve_contact_control(*args)
    with budget.iterations(ITERATION_BUDGET):
        out = _solve_contact_control(*args)
        if not out.success and budget.remaining() == 0:
            out.message = f"{out.message} (the solve's budget of {ITERATION_BUDGET} Ipopt iterations is spent)"
    return out


def _solve_contact_control(system, T, N: int, scheme: str, start, end, running, final, u_bounds,
                           controls, guess: Optional[dict] = None, options: Optional[dict] = None,
                           verbose: bool = False, keep_modes: bool = False, path=(),
                           elastic: bool = True) -> ContactControlResult:
    """Solve a contact-implicit optimal-control problem (module docstring).  ``T``: the horizon, or ``(lo, hi)`` for
    a free final time; ``start``, ``end``: ``(q, q̇)`` with NaN for a free entry (``q̇`` ``None``: free; the start's
    ``q`` given in full, NaN entries of its ``q̇`` are unknowns); ``running(q, v, u, t)``, ``final(q, v, T)``: CasADi
    functions or ``None``; ``u_bounds``: ``(lo, hi)``; ``controls``: the system's :class:`Control` list (for the
    answer's ``controls`` by name); ``guess``: any of ``u`` (per step), ``T`` and ``qd0`` (the free start's);
    ``path``: ``[(g(q, u, t), lb, ub)]``, rows at every node and sub-node;
    ``keep_modes``: the answer keeps the contact modes of the guess's march (its impacts in their steps, its holds
    and slides), solved on that branch alone: the number and order of the impacts are the guess's choice (a bounce
    to a target after k bounces), and no homotopy runs."""
    t_all = _time.perf_counter()
    free_time = tuple(T) if isinstance(T, (tuple, list)) else None
    rungs: List[int] = []
    prior = None
    if guess is None and N > LADDER_MAX:
        # the ladder of grids (as for the smooth problem, OptimalControl.solve): the answer on half the steps, its
        # controls interpolated at this grid's steps (and its horizon and start), is the guess here
        prior = solve_contact_control(system, T, (N + 1) // 2, scheme, start, end, running, final, u_bounds, controls,
                                      None, options, verbose, keep_modes, path) if not keep_modes else None
        if prior is not None and prior.success:
            tu = prior.T / N * (np.arange(N) + 0.5)
            guess = {"T": prior.T, "qd0": prior.v[0]}
            if prior.u is not None and np.size(prior.u):      # (a system without controls has none to interpolate)
                guess["u"] = np.column_stack([np.interp(tu, prior.t_u, prior.u[:, j]) for j in range(prior.u.shape[1])])
            rungs = prior.grids
    cm = mechanics(system, scheme)
    (q0, v0), (qN, vN) = start, end
    n, nu = cm.n, cm.nu
    lo, hi = u_bounds
    guess = dict(guess or {})
    unknown = sorted(set(guess) - {"u", "T", "qd0"})
    if unknown:
        raise InputError(f"the guess of a contact-implicit problem takes u, T and qd0 (the free start's velocity); "
                         f"got {', '.join(map(repr, unknown))}")
    Tg = float(guess.get("T", T if free_time is None else 0.5 * sum(free_time)))
    if free_time is not None:
        Tg = min(max(Tg, free_time[0]), free_time[1])
    h = Tg / N
    free_v = np.isnan(v0)
    v0g = np.where(free_v, np.asarray(guess.get("qd0", np.zeros(n)), float).reshape(n), v0)
    U0 = np.tile(np.clip(0.0, lo, hi), (N, 1)) if nu else np.zeros((N, 0))
    if nu and "u" in guess:
        U0 = np.clip(np.asarray(guess["u"], float).reshape(N, nu), lo, hi)
    length = _length_scale(system, q0)
    scales = _scales(system, q0, v0g, length, U0[0] if nu else np.zeros(0), Tg)
    tol = TOUCH_TOL * length
    p0 = np.asarray(system.momentum(q0, v0g)).reshape(-1)
    t_guess = _time.perf_counter()
    point = discrete_march(cm, q0, p0, N, h, scales, controls=U0 if nu else None)
    if point is not None and point["steps"].size != N:
        point = None          # the march halved a step (two impacts in it): its grid is not the program's
    marched = point
    if point is None:
        if keep_modes:
            raise InputError("keep_modes needs the guess's march on the program's grid (it stopped, or halved a "
                             "step for two impacts in it): give another guess or more steps")
        point = _straight(cm, q0, qN, N)
    guess_time = _time.perf_counter() - t_guess
    prog = _Program(cm, N, Tg, scales, vN is not None, running, final, (lo, hi), free_time=free_time,
                    start_velocity=bool(np.any(free_v)), path=path)
    prog.nlp.set_parameter("split", 0.0)
    if vN is not None:
        prog.nlp.set_parameter("pN", np.asarray(system.momentum(qN, vN)).reshape(-1))
    init = prog._start(q0, p0, {k: v for k, v in point.items() if k in prog.nlp.variable_names})
    if nu:
        init["u"] = U0.reshape(-1)
    bounds = {"q": _q_bounds(prog, q0, qN)}
    if free_time is not None:
        init["h"] = np.array([h])
    if prog.start_velocity:
        init["v0"] = v0g.copy()
        bounds["v0"] = (np.where(free_v, -np.inf, v0g), np.where(free_v, np.inf, v0g))
    if cm.friction:
        init.update(_slips(cm, prog, init, scales[2]))
    if vN is not None and cm.friction:
        bounds["fratio_end"] = _end_ratio_bounds(cm, qN, vN, scales[2])
    opts = {**CONTACT_IPOPT, **OCP_CONTACT_IPOPT, **(options or {})}
    steps, res, rounds, seen, answers = [], None, 0, set(), []
    if keep_modes:
        res = _continued(cm, prog, q0, marched, init, bounds, opts, verbose, scales, qN, vN, steps)
        rounds = TIMING_ROUNDS + 1          # (no timing rounds)
    # each round's bounces (arrivals that leave again: Newton's law) are read from the point it starts from.  (Freeing
    # the split of the arrivals' neighbours too, so that an impact could move by a step within a round, took 188
    # iterations where 42 did on the push to a target at N = 40, and is not needed where the impacts' steps are kept)
    if not keep_modes:
        timed, bounce, turn, fturn = _events(cm, prog, init, q0, tol, scales)
    held, restarted, moves, before = None, False, [], None
    limit = TIMING_ROUNDS
    while rounds < limit and not keep_modes:
        rounds += 1
        seen.add((timed.tobytes(), bounce.tobytes(), turn.tobytes()))
        prog.nlp.set_parameter("timed", timed.astype(float).reshape(-1))
        prog.nlp.set_parameter("bounce", bounce.astype(float).reshape(-1))
        free = np.any(timed | turn, axis=1)
        if res is not None:
            init = {k: v.copy() for k, v in res.values.items()}
            last = {k: v.copy() for k, v in init.items()}
            changed = np.any((timed | turn) != held, axis=1)
            # (an event moved across a node starts there, the rest of the answer kept: _shift)
            for k, to in moves:
                _shift(cm, init, k, to, N)
                changed[[k, to]] = False
            restarted = _restart(cm, prog, init, q0, scales, changed)
        held = timed | turn
        round_bounds = {**bounds, "beta": (np.where(free, EDGE - 0.5, 0.0), np.where(free, 0.5 - EDGE, 0.0)),
                        **_event_bounds(cm, prog, turn, fturn, timed, init)}
        for start in (init, last) if restarted else (init,):
            start["beta"] = np.where(free, np.clip(start["beta"], EDGE - 0.5, 0.5 - EDGE), 0.0)
            _event_start(cm, turn, fturn, start)
        if restarted and cm.friction:
            init.update(_slips(cm, prog, init, scales[2]))
        # (a later round starts from the last one's primal-dual point with a small barrier; where that fails,
        # cold.  Measured on the hopper at N = 40: goal 0.5's second round, cold, stopped at 3000 iterations, and
        # warm it solved in 835 (certified, 12 s; capped at 500 it did not); goal 0.7 certified in 5.2 s where
        # it took 7.0)
        if res is not None:
            # (a restarted round that does not converge within RESTART_ITER starts again from the last answer
            # itself.  Measured on the hopper to goal 0.9 at N = 40: its second round, restarted, ran to Ipopt's
            # limit, and cold again, spending the budget; from the answer it solved)
            warm = prog._ladder(init, {**opts, **WARM_IPOPT,
                                       **({"max_iter": RESTART_ITER} if restarted or before is not None else {})},
                                round_bounds, OCP_PENALTY, verbose, "rho", "Ipopt", warm=res)
            if before is not None and not warm.continuable:
                steps.extend(warm.homotopy)
                break                       # (a moved round that does not converge warm ends the moves)
            if restarted and not warm.continuable:
                steps.extend(warm.homotopy)
                warm = prog._ladder(last, {**opts, **WARM_IPOPT}, round_bounds, OCP_PENALTY, verbose, "rho", "Ipopt",
                                    warm=res)
        elif rungs:
            # (the ladder of grids' first round starts from the march of the coarser answer's controls, near the
            # optimum: with a small barrier, nothing pushed off its bounds, which keeps its complementarity; where
            # that fails, as any first round.  Measured on the battery's pushes to a target at N = 80: the default
            # start, its barrier at 0.1, lost the march's contacts and stopped at penalty minima with residuals
            # of 0.3 to 1.5)
            warm = prog._ladder(init, {**opts, **NEAR_IPOPT}, round_bounds, OCP_PENALTY, verbose, "rho", "Ipopt")
        else:
            warm = None
        if warm is not None and warm.continuable:
            res = warm
        else:
            steps.extend(warm.homotopy if warm is not None else [])
            res = prog._ladder(last if restarted else init, opts, round_bounds, OCP_PENALTY, verbose, "rho", "Ipopt")
        steps.extend(res.homotopy)
        if res.continuable and before is None:
            answers.append((res, {name: prog.nlp.parameter_value(name) for name in prog.nlp.parameter_names}))
        # (a round Ipopt solved only to its acceptable level is read as the others are: the next round starts from
        # it with its arrivals.  Measured on the hopper at N = 40: its third round stopped so with its landing untimed,
        # and the fourth and fifth settled it, cost 10.346 where the answer of the third was 10.478)
        if not res.continuable:
            # (a later rung of the ladder failed -- restoration, or its iteration limit -- after an earlier one
            # converged short of complementarity: that one's controls are the polish's to march and solve on their
            # branch, as for any answer short of complementarity.  Measured on the battery's seed 1 with the hopper:
            # a push whose second rung failed in restoration, at a residual of 1.5)
            if prog.last_good is not None and res.solver_status not in SUCCESS_STATUSES:
                res = prog.last_good[1]
            break
        # the events read from the answer; once they settle with an event pinned against its window's edge, the
        # moves (_move_edge_arrivals): each round then moves such an event one step, up to MOVE_ROUNDS rounds
        edges = pinned(prog, res) if before is not None else []
        now, bnow, tnow, fnow = _events(cm, prog, res.values, q0, tol, scales, edges)
        if np.array_equal(now, timed) and np.array_equal(bnow, bounce) and np.array_equal(tnow, turn):
            edges = pinned(prog, res) if before is None else []
            if not edges:
                break
            now, bnow, tnow, fnow = _events(cm, prog, res.values, q0, tol, scales, edges)
            if np.array_equal(now, timed):
                break                       # (nowhere to move)
            before = (res, {name: prog.nlp.parameter_value(name) for name in prog.nlp.parameter_names})
            limit = rounds + MOVE_ROUNDS
        moves = [(k, k + side) for k, side in edges if 0 <= k + side < N and np.any(now[k + side] & ~now[k])
                 and not np.any(timed[k + side])]
        if (now.tobytes(), bnow.tobytes(), tnow.tobytes()) in seen:
            res.fail("Timing_Cycles", "the steps that hold an impact or a slip's turn changed back to an earlier set: "
                     "the events' steps did not settle")
            break
        timed, bounce, turn, fturn = now, bnow, tnow, fnow
    else:
        if not keep_modes:
            res.fail("Timing_Not_Settled", f"the steps that hold an impact still changed after {limit} solves")
    if before is not None:
        res = _kept_moves(prog, res, *before)
    cert = marched = math.nan
    if res.continuable or res.solver_status in SUCCESS_STATUSES:
        # (also where the homotopy converged short of complementarity, a local minimum of the penalties: its
        # controls, marched, are a motion, and the program on that motion's branch is solved from it; measured on
        # the battery, 2 of 30 pushes to a target stopped so, at residuals 5.8e-3 and 0.45)
        answers = [a for a in answers if a[0] is not res]
        res, cert, marched, polished = _polish(cm, prog, res, q0, N, scales, bounds, opts, verbose, steps)
        rounds = (1 if keep_modes else rounds) + polished
    # where the last round's answer does not certify (or the rounds did not settle), the other rounds' answers are
    # polished in turn, the latest first: each is a converged point of the program with its own events timed, and
    # the first certified one is the answer.  (Measured on the battery's seed 2 with the hopper: goals 0.53 and
    # 0.98, whose last rounds' branches did not certify, certified from earlier rounds.  Polished after every round
    # instead, the rounds stopping at the first certified answer, the hopper's answers cost up to 5 % more (goal
    # 0.46: 11.78 against 11.18), and the B-stationarity proxy failed on 7 of 57 answers against 3 of 55)
    kept = {name: prog.nlp.parameter_value(name) for name in prog.nlp.parameter_names}
    for earlier, params in reversed(answers):
        if cert <= CERTIFICATE_TOL and res.success:
            break
        for name, val in params.items():
            prog.nlp.set_parameter(name, val)
        got = _polish(cm, prog, earlier, q0, N, scales, bounds, opts, verbose, steps)
        rounds += got[3]
        if got[1] <= CERTIFICATE_TOL and got[0].success:
            res, cert, marched = got[:3]
            kept = {}
    for name, val in kept.items():          # (none certified: the program as the answer reported left it)
        prog.nlp.set_parameter(name, val)
    on_node = []
    if not keep_modes and cert <= CERTIFICATE_TOL and res.success:
        res, cert, marched, moved, on_node = _across(cm, prog, res, cert, marched, q0, N, scales, bounds, opts,
                                                     verbose, steps)
        rounds += moved
    out = _answer(system, cm, prog, res, steps, rounds, q0, N, controls, cert,
                  _time.perf_counter() - t_all, guess_time, keep_modes, on_node)
    out.march_distance = marched
    out.grids = rungs + [N]
    if prior is not None and prior.success and out.success:
        out.cost_estimate = abs(out.cost - prior.cost) / 3.0
    if elastic and not out.success and not keep_modes and (bool(np.any(~np.isnan(qN))) or vN is not None):
        alt = _elastic(system, T, N, scheme, (q0, v0), (qN, vN), running, final, u_bounds, controls, guess, options,
                       verbose, path, length)
        if alt is not None:
            alt.iterations += out.iterations
            alt.solve_time_s = _time.perf_counter() - t_all - alt.build_time_s
            alt.timing_rounds += out.timing_rounds
            return alt
    return out


#: The weight of the end conditions in the elastic mode's cost (:func:`_elastic`), per squared length (of the scene's
#: length scale) and squared velocity (of its velocity scale), relative to the cost's scale
ELASTIC_WEIGHT = 1.0


def _elastic(system, T, N, scheme, start, end, running, final, u_bounds, controls, guess, options, verbose, path,
             length) -> Optional[ContactControlResult]:
    """The end conditions' elastic mode (as an SQP solver's, SNOPT's): the problem solved with its given end state
    moved into the cost (``ELASTIC_WEIGHT`` times its squared distance, on top of the cost), then solved again with
    the end conditions from that answer (its controls, horizon and free start).

    The timing rounds hold each event in a step read from a motion.  With the end state given, a round whose events
    sit in the wrong steps has no feasible point (a launch whose impact the end needs several steps later), and it
    stops at a penalty minimum; with the end state in the cost every round is feasible, and an event held against its
    window's edge moves to the next step (:func:`_move_edge_arrivals`) until the events sit where the end needs them.
    (Measured on a ball launched with a free velocity to bounce off a wall to (0.2, 0) at T = 1.2, e = 0.8, N = 45,
    from a guess that hits the wall 4 steps early: the rounds stopped at a complementarity residual of 0.06, the
    launch 0.42 m/s off; the elastic mode's rounds walk the impact to its step, and the end-conditions solve from
    there meets the closed form.)  ``None`` where either solve fails."""
    (q0, v0), (qN, vN) = start, end
    n = system.nq
    q, v, Ts = ca.SX.sym("q", n), ca.SX.sym("v", n), ca.SX.sym("T")
    given = np.where(~np.isnan(qN))[0]
    vref = max(float(np.max(np.abs(np.nan_to_num(np.asarray(v0, float))), initial=0.0)), 1e-8)
    miss = ca.sumsqr(q[given.tolist()] - ca.DM(qN[given])) / length ** 2 if given.size else 0
    if vN is not None:
        miss = miss + ca.sumsqr(v - ca.DM(np.asarray(vN, float))) / max(vref, length / np.mean(np.atleast_1d(T))) ** 2
    cost = final(q, v, Ts) if final is not None else 0
    soft = ca.Function("phi_elastic", [q, v, Ts], [cost + ELASTIC_WEIGHT * miss])
    free_end = (np.full(n, np.nan), None)
    first = _solve_contact_control(system, T, N, scheme, start, free_end, running, soft, u_bounds, controls, guess,
                                   options, verbose, False, path, elastic=False)
    if not first.success:
        return None
    g = {"T": first.T, "qd0": first.v[0], **({"u": first.u} if first.u is not None and np.size(first.u) else {})}
    out = _solve_contact_control(system, T, N, scheme, start, end, running, final, u_bounds, controls, g, options,
                                 verbose, False, path, elastic=False)
    if not out.success:
        return None
    out.iterations += first.iterations
    out.timing_rounds += first.timing_rounds
    return out


    return None


def _events(cm: ContactMechanics, prog, V, q0, tol: float, scales, edges=()):
    """The events a timing round holds, read from the values ``V``: ``(arrivals, bounces, slip turns, the turns'
    node ratios)`` (:func:`arrivals`, :func:`bounces`, :func:`slip_turns`); the arrivals pinned at an edge of their
    window (``edges``, :func:`pinned`) moved to the neighbouring step (:func:`_move_edge_arrivals`)."""
    N, n = prog.L, cm.n
    Q = np.asarray(V["q"], float).reshape(N + 1, n)
    timed = arrivals(cm, Q, np.asarray(V["qs"], float).reshape(N, n), tol, V.get("nu"), scales[1])
    turn, ratio = slip_turns(cm, prog, V, q0, timed, scales)
    _move_edge_turns(prog, V, timed, turn, ratio)
    _move_edge_arrivals(prog, edges, timed, turn)
    return timed, bounces(prog, Q, timed), turn, ratio


def at_edge(B) -> np.ndarray:
    """``-1``, ``+1`` or ``0`` per step: its sub-node sits at the start or the end of its timing window
    (``β = ±(½ − EDGE)``, to 1e-6), or inside it."""
    B = np.asarray(B, float)
    return np.where(B >= 0.5 - EDGE - 1e-6, 1, np.where(B <= EDGE - 0.5 + 1e-6, -1, 0))


#: A sub-node this close to its step's edge whose bound multiplier is above B_TOL counts as held there (:func:`pinned`):
#: an interior point stops short of an active bound (by 1.2e-3 and 3.9e-3 measured), and a multiplier of the
#: penalty homotopy can be far from zero where no bound is near (β = 0.34)
NEAR_EDGE = 1e-2


def pinned(prog, res: NLPResult) -> List[tuple]:
    """The events the answer ``res`` holds against an edge of their step's window: ``(step, +1 or -1)`` for every step
    whose sub-node the last round timed (an arrival or a slip's turn) and whose ``β`` sits at an edge of its bounds
    (:func:`at_edge`) or carries a bound multiplier of Ipopt's above :data:`B_TOL` of the cost's scale (an interior
    point stops short of an active bound: 1.2e-3 from the step's end, its multiplier 0.05, on a ball launched at a
    wall whose impact the optimum wants one step later).  The window is the transcription's, not the problem's: such
    an answer is no solution of the continuous problem, whose optimum wants the event beyond the edge."""
    N = prog.L
    V = res.values
    timed = np.asarray(prog.nlp.parameter_value("timed"), float).reshape(N, -1) > 0
    turn = np.asarray(prog.nlp.parameter_value("release"), float).reshape(N, -1) > 0
    B = np.asarray(V["beta"], float).reshape(N)
    side = at_edge(B)
    lam = np.asarray((res.bound_multipliers or {}).get("beta", np.zeros(N)), float).reshape(-1)
    if lam.size == N:
        scale = max(1.0, abs(float(prog.cost(V))))
        near = np.abs(B) >= 0.5 - NEAR_EDGE
        side = np.where((side == 0) & near & (np.abs(lam) > B_TOL * scale), np.sign(B).astype(int), side)
    return [(int(k), int(side[k])) for k in np.where(np.any(timed | turn, axis=1) & (side != 0))[0]]


def _move_edge_arrivals(prog, edges, timed, turn) -> None:
    """An arrival the round held against an edge of its step's window (:func:`pinned`: ``edges``): the optimum wants
    the impact beyond, in the next step (or the one before), which one round cannot give.  The next round holds it
    there instead (``timed`` moved in place), one step per round, as :func:`_move_edge_turns` moves a slip's turn;
    the rounds go on while an event moves (:func:`_solve_contact_control`).  (Measured on a ball launched with a free
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


def _kept_moves(prog, res: NLPResult, start: NLPResult, params: dict) -> NLPResult:
    """The answer of the rounds that moved pinned events (:func:`_move_edge_arrivals`) where it is converged,
    complementary, off its windows' edges and no costlier than the answer ``start`` they moved from; else ``start``,
    with the program's parameters ``params`` set back (its pinned events then say so in the answer's warnings).
    (Measured on the hopper at N = 40, goal 0.7: moved round by round, its pinned landing and lift-off ran away from
    each other, the rounds spent the budget and ended uncertified at a cost of 14.8 against 11.22)"""
    c0 = prog.cost(start.values)
    if (res.continuable and res.success and not pinned(prog, res)
            and float(prog.residual(res.values)) <= COMPLEMENTARITY_TARGET
            and prog.cost(res.values) <= c0 + 1e-9 * max(1.0, abs(c0))):
        return res
    for name, val in params.items():
        prog.nlp.set_parameter(name, val)
    return start


#: Certified answers with a pinned event that :func:`_across` moves across its node, one after another, at most.
#: (Each round tries every pinned event and keeps the cheapest move.  Keeping the first certified improvement
#: instead, up to 16 rounds, cost fewer iterations per round but walked the hopper's events on another path: goal
#: 0.7 at N = 40 reached 10.721 and was still walking after 16 rounds (4980 iterations), where this rule ends
#: unpinned at 10.826 after 6; goal 0.98 reached the same 9.504 in 4300 iterations against 7000)
ACROSS_ROUNDS = 8


def _across(cm, prog, res: NLPResult, cert, marched, q0, N: int, scales, bounds, opts, verbose, steps):
    """A certified answer whose events are pinned at their windows' edges (:func:`pinned`), each event moved across
    its node in turn: the program solved warm with that event held in the neighbouring step (:func:`_shift`), its
    answer polished and certified (:func:`_polish`).  The cheapest certified answer below the answer's cost is taken
    and its own pinned events moved, up to :data:`ACROSS_ROUNDS` times.  ``(result, certificate, march distance,
    solves, on the node)``: where no move lowers the cost the answer is kept, and its pinned events whose move
    converged to a costlier answer are held on their node (``on the node``, as ``(step, side)``): from either side
    the program's optimum wants the event at the node they share, a local optimum over the event's step.  The
    others, not moved (the horizon's end, a neighbour already holding an event) or whose moved solve failed, stay
    pinned, and :func:`_answer` fails the answer.  (Measured on the hopper at N = 40: its landing pinned at the end
    of step 1, moved to step 2, settles inside it at a cost of 10.969 against 11.220; six rounds later no event is
    pinned, cost 10.826, in 2313 iterations against 878 without the moves)"""
    solves, on_node = 0, []
    for _ in range(ACROSS_ROUNDS):
        edges = pinned(prog, res)
        on_node = []
        if not edges:
            break
        c0 = prog.cost(res.values)
        params = {name: prog.nlp.parameter_value(name) for name in prog.nlp.parameter_names}
        best = None
        for edge in edges:
            for name, val in params.items():
                prog.nlp.set_parameter(name, val)
            k, side = edge
            to = k + side
            timed, bounce, turn, fturn = _held(cm, prog, res.values)
            if not 0 <= to < N or np.any(timed[to] | turn[to]):
                continue                                    # (nowhere to move: the horizon's end, or a held step)
            for flags in (timed, bounce, turn):             # (the event moved, the answer's other events kept)
                flags[to], flags[k] = flags[k].copy(), False
            fturn[to], fturn[k] = fturn[k].copy(), 0.0
            prog.nlp.set_parameter("timed", timed.astype(float).reshape(-1))
            prog.nlp.set_parameter("bounce", bounce.astype(float).reshape(-1))
            prog.nlp.set_parameter("node_impact", np.zeros(N * cm.c))
            init = {key: v.copy() for key, v in res.values.items()}
            _shift(cm, init, k, k + side, N)
            free = np.any(timed | turn, axis=1)
            window = {**bounds, "beta": (np.where(free, EDGE - 0.5, 0.0), np.where(free, 0.5 - EDGE, 0.0)),
                      **_event_bounds(cm, prog, turn, fturn, timed, init)}
            init["beta"] = np.where(free, np.clip(init["beta"], EDGE - 0.5, 0.5 - EDGE), 0.0)
            _event_start(cm, turn, fturn, init)
            # (from the shifted answer's primal values alone, with a small barrier: its multipliers, the other
            # branch's, cost the hopper's first move at N = 40 1879 iterations where without them it took 96, to the
            # same answer)
            got = prog._ladder(init, {**opts, **WARM_IPOPT, "max_iter": RESTART_ITER}, window, OCP_PENALTY, verbose,
                               "rho", "Ipopt")
            steps.extend(got.homotopy)
            solves += 1
            if got.success and prog.cost(got.values) >= c0 - 1e-9 * max(1.0, abs(c0)):
                on_node.append(edge)          # (converged across the node, and no cheaper there)
            if not (got.continuable and prog.cost(got.values) < c0 - 1e-9 * max(1.0, abs(c0))):
                continue
            got, c, m, polished = _polish(cm, prog, got, q0, N, scales, bounds, opts, verbose, steps)
            solves += polished
            cost = prog.cost(got.values)
            if got.success and c <= CERTIFICATE_TOL and cost < c0 - 1e-9 * max(1.0, abs(c0)) and \
                    (best is None or cost < best[0]):
                best = (cost, got, c, m, {name: prog.nlp.parameter_value(name) for name in prog.nlp.parameter_names})
        chosen = params if best is None else best[4]
        for name, val in chosen.items():
            prog.nlp.set_parameter(name, val)
        if best is None:
            break
        _, res, cert, marched, _ = best
    else:
        on_node = []                          # (the rounds ran out: the last answer's events not tried)
    return res, cert, marched, solves, on_node


def _held(cm: ContactMechanics, prog, V):
    """The events the program holds now (its last solve's branch or round), as :func:`_events` reads them from an
    answer: ``(arrivals, bounces, slip turns, the turns' ratios)``, the ratios those of the values ``V``."""
    N, c = prog.L, cm.c
    flag = lambda name: np.asarray(prog.nlp.parameter_value(name), float).reshape(N, c) > 0  # noqa: E731
    turn = flag("release")
    ratio = np.where(turn, np.asarray(V["fleft"], float).reshape(N, c), 0.0) if cm.friction else np.zeros((N, c))
    return flag("timed"), flag("bounce"), turn, ratio


def _shift(cm: ContactMechanics, init, k: int, to: int, N: int) -> None:
    """A round's start, in place, where the event timed at an edge of step ``k`` moves to the neighbouring step ``to``
    (:func:`_move_edge_arrivals`): its sub-node moves across the node they share, to the same edge of ``to``'s window
    (the event at the same time, to ``2 EDGE h``), with its impulses; ``k``'s sub-node goes to its middle, untimed.
    The nodes stay the last answer's, a motion with the event at that node.  (Started from the one-step marches of
    :func:`_restart` instead, the ball off a wall held its impact at a grazing sub-node a step away)"""
    n = cm.n
    Q = np.asarray(init["q"], float).reshape(N + 1, n)
    S = init["qs"].reshape(N, n)
    B = init["beta"].reshape(N)
    shared = max(k, to)                         # the node the two steps share
    S[to] = Q[shared]
    S[k] = 0.5 * (Q[k] + Q[k + 1])
    B[to] = (EDGE - 0.5) if to > k else (0.5 - EDGE)
    B[k] = 0.0
    for key in ("mu", "mul"):
        if key in init:
            v = init[key].reshape(N, -1)
            v[to], v[k] = v[k].copy(), 0.0
    if "fratio" in init and cm.friction:
        r = init["fratio"].reshape(N, -1)
        r[to, cm.c:], r[k, cm.c:] = r[k, cm.c:].copy(), 0.0


def _restart(cm: ContactMechanics, prog, init, q0, scales, changed) -> bool:
    """A later round's start, in place: the steps whose held events ``changed`` take their unknowns
    (:data:`.certificate.STEP_VALUES`: sub-node, split, forces, impulses, ratios) from their one-step marches
    from the last answer's nodes (those :func:`slip_turns` ran to read its events are not run again), which time those
    events; the nodes stay the answer's.  (The last answer itself violates the new round's rows there: a turn newly
    held at a sub-node that sat elsewhere, an event no longer held whose step keeps its timed ``β``.  Measured on the
    hopper at N = 20: from the answer the rounds started at a primal infeasibility of 13.9 and took 54 to 135
    iterations each.)  Whether any step was restarted."""
    N, ks = prog.L, np.where(changed)[0]
    if not ks.size:
        return False
    # (the steps slip_turns did not march, the arrivals' among them, marched here)
    _, marches = _local(cm, prog, init, q0, N, scales, steps=ks)
    for k in ks:
        pt = marches[k]
        if pt is None or np.asarray(pt["steps"]).size != 1:
            continue
        for key in STEP_VALUES:
            if key in pt and key in init:
                row = np.asarray(pt[key], float).reshape(-1)
                init[key].reshape(N, -1)[k] = row
    return True


def _move_edge_turns(prog, V, timed, turn, ratio) -> None:
    """A turn the round held (its step's sub-node timing it) whose sub-node sits at an edge of the step's window
    (``β = ±(½ − EDGE)``): the optimum wants it beyond, in the next step (or the one before), which one round cannot
    give, since a round holds each event in its step.  The next round holds it there instead (``turn`` and ``ratio``
    moved in place), one step per round.  (Measured on the battery's seed 2: a block pushed over the whole horizon
    stopped at the end of step 74 of 80 and stuck, its stop at the window's edge in two rounds, and cost 18 % above
    the exact discrete optimum of sliding to the end)"""
    if not np.any(turn):
        return
    N, c = turn.shape
    held = np.asarray(prog.nlp.parameter_value("release"), float).reshape(N, c) > 0
    B = np.asarray(V["beta"], float).reshape(N)
    for k, j in zip(*np.where(turn & held)):
        step = 1 if B[k] >= 0.5 - EDGE - 1e-6 else -1 if B[k] <= EDGE - 0.5 + 1e-6 else 0
        to = k + step
        if not step or not 0 <= to < N or np.any(timed[to]) or turn[to, j]:
            continue
        turn[k, j] = False
        if not (to == N - 1 and prog.end_velocity):       # (there the end node's force stops the slip: not held)
            turn[to, j], ratio[to, j] = True, ratio[k, j]


def slip_turns(cm: ContactMechanics, prog, V, q0, timed, scales):
    """Per step and contact: a held contact whose slip stops or turns inside the step, where the march times it
    (mode W): each step of ``V`` marched from its own node (:func:`_local`), in the steps without an arrival
    (``timed``).  ``(turns, the sliding node slots' ratios)``: the program's round times such a step's sub-node at
    the turn too (:func:`_event_bounds`).  (Read from the slip velocities at the step's ends instead, as the march
    first does, the sliding block's stop was a turn where the march's timed step has no valid modes and it keeps
    the untimed one: the round then held a timed stop, and the block push that sticks cost 16.83 against the
    untimed answer's 16.49, at N = 40)"""
    N, c = prog.L, cm.c
    out, ratio = np.zeros((N, c), bool), np.zeros((N, c))
    if not cm.friction or cm.fd != 1:
        return out, ratio
    # (a slip turns only at a contact that touches at the step's start, q_k: the other steps are not marched)
    Q = np.asarray(V["q"], float).reshape(N + 1, cm.n)
    touch = np.any(cm.gaps(Q[:-1]) <= TOUCH_TOL * scales[0], axis=1) & ~np.any(timed, axis=1)
    _, marches = _local(cm, prog, V, q0, N, scales, steps=np.where(touch)[0])
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


def _event_bounds(cm: ContactMechanics, prog, turn, ratio, timed, init) -> dict:
    """A round's rows of its events: a timed step's arriving contact on the surface at its sub-node, and the slips
    that turn (:func:`slip_turns`) as the march's mode W
    (:meth:`ContactNLP.mode_bounds`): the step's sub-node at the turn, where the slip velocity after the contact's
    share ``μ⁻`` of the first part's force vanishes (``left_slip``), its normal velocity too (``release``), the
    share's ratio the node slot's, and the sub-node slot's slip the second part's (``arrive``).  Sets the round's
    ``release`` and ``arrive`` parameters (``init``'s sub-nodes pick each timed step's arriving contact; a start is
    moved into these bounds by :func:`_event_start`)."""
    L, c = prog.L, cm.c
    t = turn.reshape(-1)
    prog.nlp.set_parameter("release", turn.astype(float).reshape(-1))
    out = {"mul": (np.zeros(L * c), np.where(t, np.inf, 0.0)),
           "release": (np.where(t, 0.0, -np.inf), np.where(t, 0.0, np.inf))}
    if cm.friction:
        prog.nlp.set_parameter("arrive", (timed | turn).astype(float).reshape(-1))
        fl = np.where(t, ratio.reshape(-1), 0.0)
        out["fleft"] = (fl, fl)
        out["left_slip"] = (np.where(t, 0.0, -np.inf), np.where(t, 0.0, np.inf))
    # a timed step's sub-node is its arrival's, on the surface, as in the march (its timing row φ(q̃) = 0): the arriving
    # contact closest to the surface at q̃ in the round's start.  (With the sub-node free to stay open, a flight that
    # lands on the next node kept β free, a control of its own: the hopper's answer at N = 40 landed exactly on a
    # node by it, which the march, its flight a plain step, missed by 3e-9)
    gs = np.where(timed, cm.gaps(np.asarray(init["qs"], float).reshape(L, cm.n)), np.inf)
    first = timed & (np.arange(c)[None, :] == np.argmin(gs, axis=1)[:, None])
    # (and a turn's contact is held through its step, closed at q̃_k and q_{k+1}, as the march's W)
    out["sub_gap"] = (np.zeros(L * c), np.where((first | turn).reshape(-1), 0.0, np.inf))
    out["node_gap"] = (np.zeros(L * c), np.where(t, 0.0, np.inf))
    return out


def _event_start(cm: ContactMechanics, turn, ratio, start) -> None:
    """A round's start moved into its events' bounds (:func:`_event_bounds`), in place: the turns' shares ``μ⁻`` kept
    and their ratios the node slots', every other share zero."""
    t = turn.reshape(-1)
    if cm.friction:
        start["fleft"] = np.where(t, ratio.reshape(-1), 0.0)
    start["mul"] = np.where(t, np.asarray(start.get("mul", np.zeros(t.size)), float).reshape(-1), 0.0)


def _march_end(cm, prog, point, values):
    """The end node and its incoming momentum of a march ``point`` (the controls of ``values``)."""
    N, n = prog.L, cm.n
    Qg = np.asarray(point["q"], float).reshape(N + 1, n)
    h = float(prog.steps(values)[0])
    zp = cm.stage_parts(np.asarray(point["zs"]).reshape(N, -1)[-1])[1] if cm.s else []
    U = [np.asarray(values["u"]).reshape(N, cm.nu)[-1]] if cm.nu else []
    pg = np.asarray(cm.p_node_minus(np.asarray(point["qs"]).reshape(N, n)[-1], float(np.asarray(point["beta"])[-1]),
                                    Qg[-1], h, *zp, *U)).reshape(-1)
    return Qg[-1], pg


def _continued(cm, prog, q0, point, init, bounds, opts, verbose, scales, qN, vN, steps):
    """The branch of the guess's march (``keep_modes``), its end moved from the march's own end state to the asked
    one: a continuation in the end conditions (the step doubled after a success, halved after a failure, down to
    1/1024), each solve warm from the last.  The guess's march ends where it ends, not where it is asked to: the bounce
    to a target from a launch at √(2gp) with k = 5, e = 0.7 needs a launch 6 times faster, which the branch solved
    directly did not find (Ipopt: infeasible after 1175 iterations)."""
    N, n = prog.L, cm.n
    end, pg = _march_end(cm, prog, point, init)
    given = ~np.isnan(qN)
    qlo, qhi = (b.reshape(N + 1, n).copy() for b in bounds["q"])
    pN = np.asarray(cm.system.momentum(qN, vN)).reshape(-1) if vN is not None else None
    s, ds, values, res = 0.0, 1.0, init, None
    # (each step's Ipopt capped: a step too long fails fast and is halved; an uncapped one ran 3000 iterations)
    opts = dict(opts, max_iter=min(int(opts.get("max_iter", 3000)), CONTINUATION_ITER))
    while s < 1.0:
        t = min(1.0, s + ds)
        qlo[N, given] = qhi[N, given] = (1 - t) * end[given] + t * qN[given]
        stage = dict(bounds, q=(qlo.reshape(-1), qhi.reshape(-1)))
        if pN is not None:
            prog.nlp.set_parameter("pN", (1 - t) * pg + t * pN)
        got = _branch(cm, prog, q0, point, values, stage, opts, OCP_PENALTY[0], verbose, scales, warm=res is not None)
        steps.extend(got.homotopy)
        if got.success:
            s, values, res = t, got.values, got
            ds = min(2 * ds, 1.0)
        else:
            ds /= 2
            if ds < 1.0 / 1024:
                got.fail(got.solver_status, f"the continuation of the end conditions stopped at {s:.3g} of the way "
                         f"from the guess's end ({got.message})")
                return got
    return res


def b_stationarity(prog, res: NLPResult, scale: float):
    """A measured proxy of B-stationarity: ``(biactive pairs, the largest multiplier that signals descent)``.

    At a pair ``a ⟂ b`` (``a, b ≥ 0``) where both vanish, the point is B-stationary (MPCC-LICQ assumed) where the
    multipliers of ``a ≥ 0`` and ``b ≥ 0`` both have the sign of a lower bound: a multiplier of the other sign says the
    cost falls as that factor grows, a descent on the branch where the pair's other factor is zero -- flipping that
    pair's branch.  The factors: each node's and sub-node's gap against its force or impulse, and each friction
    slot's ``μ_f ± ρ`` against its slip's part ``s±``; the multipliers Ipopt's at the answer (CasADi's sign: positive
    where an upper bound holds).  A KKT point of the penalty program meets this by construction (the penalty's
    gradient vanishes at a biactive pair, and the factors have lower bounds only); a branch solve, which fixes a
    factor at zero by both bounds, may not.  ``scale``: the cost's scale; ``(0, 0.0)`` without multipliers."""
    if res.lam_x is None or res.lam_g is None:
        return 0, 0.0
    cm, L, c = prog.cm, prog.L, prog.cm.c
    V = res.values
    raw_x = {k: -np.asarray(v, float).reshape(-1) for k, v in res.bound_multipliers.items()}
    raw_g = {k: -np.asarray(v, float).reshape(-1) for k, v in res.multipliers.items()}
    tol_f = 1e-8 * max(float(np.max(np.abs(V["nu"]), initial=0.0)), float(np.max(np.abs(V["mu"]), initial=0.0)), 1.0)
    tol_g = TOUCH_TOL * prog.scales_ell
    g = cm.gaps
    Q, S = V["q"].reshape(L + 1, cm.n), V["qs"].reshape(L, cm.n)
    NU, MU = V["nu"].reshape(L, c), V["mu"].reshape(L, c)
    count, worst = 0, 0.0
    # (gap of node k + 1, its force ν_{k+1}) for k < L − 1; (gap of sub-node k, its impulse μ_k)
    pairs = [(g(Q[1:L]), NU[1:], raw_g["node_gap"].reshape(L, c)[:L - 1], raw_x["nu"].reshape(L, c)[1:]),
             (g(S), MU, raw_g["sub_gap"].reshape(L, c), raw_x["mu"].reshape(L, c))]
    for ga, lam, mg, ml in pairs:
        both = (ga <= tol_g) & (lam <= tol_f)
        count += int(np.sum(both))
        if np.any(both):
            worst = max(worst, float(np.max(np.maximum(mg[both], 0.0))), float(np.max(np.maximum(ml[both], 0.0))))
    if cm.friction and "slip_plus" in V:
        r = V["fratio"].reshape(-1)
        muf = np.tile(np.concatenate([cm.mu_f, cm.mu_f]), L)
        for sgn, sl in ((1.0, "slip_plus"), (-1.0, "slip_minus")):
            a = muf + sgn * r
            b = V[sl].reshape(-1)
            both = (a <= 1e-8 * np.maximum(muf, 1e-300)) & (b <= 1e-8) & (muf > 0)
            count += int(np.sum(both))
            if np.any(both):
                # a = μ_f ± ρ grows as ρ moves away from its bound: its multiplier's descent sign is ±'s
                worst = max(worst, float(np.max(np.maximum(sgn * raw_x["fratio"][both], 0.0))),
                            float(np.max(np.maximum(raw_x[sl][both], 0.0))))
    return count, worst / max(1.0, scale)


def _straight(cm: ContactMechanics, q0, qN, N: int) -> dict:
    """The fallback guess: the straight line from ``q0`` to ``q_N`` (its given entries), every force zero."""
    b = np.where(np.isnan(qN), q0, qN)
    w = np.linspace(0.0, 1.0, N + 1)[:, None]
    Q = q0[None, :] + w * (b - q0)[None, :]
    return {"q": Q.reshape(-1), "qs": (0.5 * (Q[:-1] + Q[1:])).reshape(-1), "beta": np.zeros(N)}


def _q_bounds(prog, q0, qN):
    N, n = prog.L, prog.cm.n
    qlo = np.full((N + 1, n), -np.inf)
    qhi = np.full((N + 1, n), np.inf)
    qlo[0] = qhi[0] = q0
    given = ~np.isnan(qN)
    qlo[N, given] = qhi[N, given] = qN[given]
    return qlo.reshape(-1), qhi.reshape(-1)


def _end_ratio_bounds(cm: ContactMechanics, qN, vN, vref):
    """The end node's friction ratios: against the given final slip, in the cone where it vanishes."""
    s = np.asarray(cm.system.tangent(qN)).reshape(cm.c, -1) @ vN
    lo, hi = -cm.mu_f.copy(), cm.mu_f.copy()
    slide = np.abs(s) > 1e-12 * vref
    lo[slide] = hi[slide] = -cm.mu_f[slide] * np.sign(s[slide])
    return lo, hi


def _answer(system, cm, prog, res: NLPResult, steps, rounds, q0, N, controls, cert, wall,
            guess_time, keep_modes: bool = False, on_node=()) -> ContactControlResult:
    n, c, nu = cm.n, cm.c, cm.nu
    V = res.values
    h, p0, U = _start_of(prog, V, q0)
    Q, S = V["q"].reshape(N + 1, n), V["qs"].reshape(N, n)
    B = V["beta"].reshape(N)
    MU, NU = V["mu"].reshape(N, c), V["nu"].reshape(N, c)
    times = h * np.arange(N + 1)
    t_sub = times[:-1] + (0.5 + B) * h
    # the cost: the running and final terms at the answer (the objective also holds the penalties)
    cost = prog.cost(V)
    arr = arrivals(cm, Q, S, TOUCH_TOL * max(1.0, float(np.max(np.abs(q0)))), NU, prog.scales_pref)
    # (and the impacts at a node: a flight that landed on it, its node force an impulse, the march's mode N)
    node = np.asarray(prog.nlp.parameter_value("node_impact"), float).reshape(N, c) > 0
    impact_times = [sorted([float(t_sub[k]) for k in range(N) if arr[k, j] and MU[k, j] > 0.0]
                           + [float(times[k]) for k in range(N) if node[k, j] and NU[k, j] > 0.0]) for j in range(c)]
    # velocities: the mean of the one-sided momenta at each node (the node's impulse split between them)
    ua = [U.T] if nu else []
    pp = np.asarray(cm.p_node_plus.map(N)(Q[:-1].T, S.T, B, h, *_zparts(cm, V, N, 0), *ua)).T
    pm = np.asarray(cm.p_node_minus.map(N)(S.T, B, Q[1:].T, h, *_zparts(cm, V, N, 1), *ua)).T
    p = np.vstack([p0[None, :], 0.5 * (pp[1:] + pm[:-1]), pm[-1:]])
    if prog.end_velocity:            # the end node's momentum after its own force: the given final one
        p[-1] = np.asarray(prog.nlp.parameter_value("pN"), float).reshape(-1)
    v = cm.dm.velocities(Q, p)
    out = ContactControlResult(
        success=res.success, solver_status=res.solver_status, message=res.message, iterations=sum(st.iterations for st in steps),
        build_time_s=res.build_time_s, solve_time_s=wall - res.build_time_s, cost=cost, T=N * h, t=times, q=Q, v=v,
        u=U, t_u=times[:-1] + 0.5 * h, controls=split_controls(U, controls, N), certificate=cert, march_distance=cert,
        scheme=cm.dm.scheme.name, qs=S, t_sub=t_sub, mu=MU, nu=NU,
        fratio=V["fratio"].reshape(N, -1) if cm.friction else None, impact_times=impact_times,
        complementarity=float(prog.residual(V)), homotopy=steps, timing_rounds=rounds)
    out.biactive, out.b_violation = b_stationarity(prog, res, abs(cost))
    edges = pinned(prog, res)
    node = [e for e in edges if e in on_node]
    held = [e for e in edges if e not in on_node]
    out.pinned = [{"step": k, "t": float(t_sub[k]), "edge": "end" if side > 0 else "start",
                   "held": "node" if (k, side) in on_node else "window"} for k, side in edges]
    # (an event the window holds is a multiplier the proxy does not see: no B-stationary point.  One held on its
    # node from both sides is a local optimum over its step: _across)
    out.b_stationary = bool(out.b_violation <= B_TOL) and not held
    for k, side in node:
        t_node = times[k + (1 if side > 0 else 0)]
        out.warnings.append(
            f"the event timed in step {k} sits on the node at t = {t_node:.6g} s: moved across it into step "
            f"{k + side} the optimum costs more, so the program holds it on the node from both sides; its time "
            f"is resolved to the step, h = {h:.3g} s (refine N to resolve it further)")
    if held and not (res.success and cert <= CERTIFICATE_TOL):
        # (an answer that failed otherwise: where its events stopped, for the next attempt's guess)
        out.warnings.extend(f"the event timed in step {k} sits at the {'end' if side > 0 else 'start'} of its step's "
                            f"window (t = {t_sub[k]:.6g} s, β = {B[k]:+.4f}), held by a bound of the transcription"
                            for k, side in held)
    if res.success and held and cert <= CERTIFICATE_TOL:
        where = "; ".join(f"step {k}'s at the {'end' if side > 0 else 'start'} of its window (t = {t_sub[k]:.6g} s, "
                          f"β = {B[k]:+.4f})" for k, side in held)
        out.fail("Event_Pinned",
                 f"an event is held by a bound of the transcription, not of the problem: {where}; the optimum of the "
                 f"continuous problem wants it beyond, so this motion (certified to {cert:.2g}) is no optimum of "
                 "it; " + ("keep_modes holds each event in its guess's step: solve without it, or start from a guess "
                           "whose events lie nearer the optimum's" if keep_modes else
                           "moved across its node it did not converge, or could not move: start from a guess whose "
                           "events lie nearer the optimum's, or refine N"))
    if res.success and not (cert <= CERTIFICATE_TOL):
        out.fail("Certificate_Failed", f"a step of the optimal controls, marched by the contact march from the answer's "
                                       f"own node, departs from the answer by {cert:.3g} (relative): not a motion of "
                                       f"the system")
    return out


