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
   vanishes.  A timed sub-node stays ``edge`` (:class:`.options.ContactControlOptions`) of its step from the nodes, inside the window where the march
   times an event.  Which steps arrive or turn is read from the solution and the program solved again, warm, until
   it no longer changes (``timing_rounds``); the steps whose events changed start the next round from their
   one-step marches, which time those events (:func:`_restart`).
3. **Penalty ladder**: the exact ℓ1 penalties of the complementarity pairs rise (``PENALTY``), each solve warm
   started from the last, until the scaled complementarity residual is at most ``COMPLEMENTARITY_TOL``.
4. **Certificate** (:mod:`.certificate`): every step of the answer is marched by the contact march from the answer's own node and
   incoming momentum under its control, and must land on the answer's next node (relative distance at most
   ``certificate_tol``): every step is then a step of the system under its own controls, impacts and friction
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
from ...result import Certificate, NLPResult
from .. import budget, ladder
from ..nlp import NLP
from ...result import SUCCESS_STATUSES, ControlResult
from ...validation import InputError
from .certificate import _branch, _slips, _start_of, _zparts, certify
from .events import (_across, _event_bounds, _event_start, _kept_moves, _onto_steps, _restart, _shift, arrivals,
                     controls_at, pinned, read_branch)
from .march import discrete_march
from .nlp import ContactNLP
from .options import ContactControlOptions
from .policies import STARTS, solve_round
from .state import Attempt, Branch, Problem, Round
from .strategy import _length_scale
from .strategy import _scales as strategy_scales

class _Program(ContactControlTranscription, ContactNLP):
    program = NLP
    #: (the certificate's march takes a contact as touching within TOUCH_TOL ℓ: the products are driven until a
    #: held contact's gap is below it; complementarity_target in docs/notes.md)
    complementarity_target = ContactControlOptions.complementarity_target
    #: the one-step marches of the last values certified (:func:`.certificate._local`): ``(key, {step: march})``
    local_memo = None


def mechanics(system, scheme: str, controls: str = "step") -> ContactMechanics:
    """The contact elements of ``system`` and ``scheme`` with ``controls`` ("step" or "quadrature",
    :class:`ContactMechanics`), built once per triple and kept with the system."""
    return system.derived(("contact elements", scheme, controls), lambda: ContactMechanics(system, scheme, controls))


@dataclass(kw_only=True)
class ContactControlResult(ControlResult):
    """A contact-implicit optimal control's answer: :class:`ControlResult`, plus the sub-node configurations
    ``qs`` (``(N, n)``) and their times ``t_sub``, the impulses ``mu`` at the sub-nodes and the node forces ``nu``
    (``(N, c)`` each), the friction ratios ``fratio`` (``(N, 2c)``: node and sub-node slots), the impacts
    (``impact_times``, one list per contact: the sub-node times of the steps where the contact arrives with an
    impulse), ``complementarity``: the scaled complementarity residual at the answer (the penalties' pairs, as
    the initial-value program measures it), ``homotopy``: the penalty steps of every timing round, ``certificate``:
    each step of the optimal controls marched from the answer's own node against its next one (``certificate_tol``),
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
    #: most ``b_tol`` (no descent found)
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


def solve_contact_control(system, T, N: int, scheme: str, start, end, running, final, u_bounds,
                          controls, guess: Optional[dict] = None, options: Optional[dict] = None,
                          verbose: bool = False, keep_modes: bool = False, path=(),
                          contact: Optional[ContactControlOptions] = None,
                          control_points: str = "step") -> ContactControlResult:
    """Solve a contact-implicit optimal-control problem (:func:`_solve_contact_control`) within the settings'
    ``iteration_budget`` Ipopt iterations in all, or a run's own budget (``--max-iter``) where one is set.
    ``options``: Ipopt's options on top of the settings' ``ipopt``; ``contact``: the settings
    (:class:`ContactControlOptions`, the library's by default); ``control_points``: ``"step"`` (one control value per
    step) or ``"quadrature"`` (on a scheme with stages, a value at each node of each part's quadrature, so that the
    cost and the motion keep the scheme's order: :class:`ContactMechanics`)."""
    o = contact if contact is not None else ContactControlOptions()
    if not isinstance(o, ContactControlOptions):
        raise InputError(f"contact takes a ContactControlOptions (got {type(o).__name__})")
    unknown = [name for name in o.starts if name not in STARTS]
    if unknown:
        raise InputError(f"unknown start policies {unknown}: the policies are {sorted(STARTS)}")
    run = budget.current()
    B = run if run is not None else budget.Budget(o.iteration_budget)
    out = _solve_contact_control(system, T, N, scheme, start, end, running, final, u_bounds, controls, guess, options,
                                 verbose, keep_modes, path, o, B, control_points=control_points)
    if run is None and not out.success and B.remaining() == 0:
        out.message = f"{out.message} (the solve's budget of {o.iteration_budget} Ipopt iterations is spent)"
    return out


def _solve_contact_control(system, T, N: int, scheme: str, start, end, running, final, u_bounds,
                           controls, guess, options, verbose: bool, keep_modes: bool, path,
                           o: ContactControlOptions, B: budget.Budget, elastic: bool = True,
                           control_points: str = "step") -> ContactControlResult:
    """Solve a contact-implicit optimal-control problem (module docstring).  ``T``: the horizon, or ``(lo, hi)`` for
    a free final time; ``start``, ``end``: ``(q, q̇)`` with NaN for a free entry (``q̇`` ``None``: free; the start's
    ``q`` given in full, NaN entries of its ``q̇`` are unknowns); ``running(q, v, u, t)``, ``final(q, v, T)``: CasADi
    functions or ``None``; ``u_bounds``: ``(lo, hi)``; ``controls``: the system's :class:`Control` list (for the
    answer's ``controls`` by name); ``guess``: any of ``u`` (per step), ``T`` and ``qd0`` (the free start's);
    ``path``: ``[(g(q, u, t), lb, ub)]``, rows at every node and sub-node;
    ``keep_modes``: the answer keeps the contact modes of the guess's march (its impacts in their steps, its holds
    and slides), solved on that branch alone: the number and order of the impacts are the guess's choice (a bounce
    to a target after k bounces), and no homotopy runs.  ``B``: the Ipopt iteration budget every solve of it
    draws on, the coarser grids' and the elastic mode's included."""
    t_all = _time.perf_counter()
    problem = (system, T, scheme, start, end, running, final, u_bounds, controls, control_points)
    rung = ladder.Rung(guess=guess)
    if not keep_modes:
        # the ladder of grids (solve.ladder): the answer on half the steps, its controls interpolated at this grid's
        # steps (and its horizon and start), is the guess here
        rung = ladder.below(N, o.ladder_max, guess, lambda M: _solve_contact_control(
            system, T, M, scheme, start, end, running, final, u_bounds, controls, None, options, verbose, keep_modes,
            path, o, B, control_points=control_points),
            lambda prior: _interpolated(mechanics(system, scheme, control_points), prior, N))
    prior, rungs, guess = rung.prior, rung.grids, rung.guess
    P, init, marched, guess_time = _setup(problem, N, guess, options, verbose, keep_modes, path, o, B)
    (qN, vN) = end
    if keep_modes:
        res, rounds, answers = _continued(P, marched, init, qN, vN), 1, []
    else:
        res, rounds, answers = _timing_rounds(P, init, near=bool(rungs))
    res, C, rounds = _certified(P, res, answers, rounds, keep_modes)
    on_node = []
    if not keep_modes and C.holds(o.certificate_tol) and res.success:
        res, C, moved, on_node = _across(P, res, C)
        res, C, onto, stopped = _onto_steps(P, res, C)
        rounds += moved + onto
        if stopped:               # (a stop moved into a step may sit at its window's edge: moved on across its node)
            res, C, moved, on_node = _across(P, res, C)
            rounds += moved
    out = _answer(system, P, res, rounds, controls, C, _time.perf_counter() - t_all, guess_time, keep_modes,
                  on_node)
    out.grids = rungs + [N]
    if prior is not None and prior.success and out.success:
        out.cost_estimate = abs(out.cost - prior.cost) / 3.0
    if elastic and not out.success and not keep_modes and (bool(np.any(~np.isnan(qN))) or vN is not None):
        alt = _elastic(problem, N, dict(guess or {}), options, verbose, path, o, B, _length_scale(system, start[0]))
        if alt is not None:
            if out.solver_status in SUCCESS_STATUSES and math.isfinite(out.cost) \
                    and out.cost < alt.cost - 1e-3 * max(1.0, abs(alt.cost)):
                # (the elastic mode's rounds may move events to another optimum: the launched spring-held push,
                # galerkin4, N = 40, failed its certificate by 6.5e-6 at 3.3535 and the elastic answer cost 11.92)
                alt.warnings.append(
                    f"a cheaper motion was found before the elastic mode: cost {out.cost:.10g} against "
                    f"{alt.cost:.10g}, not certified ({out.message}); this answer is another local optimum")
            alt.iterations += out.iterations
            alt.solve_time_s = _time.perf_counter() - t_all - alt.build_time_s
            alt.timing_rounds += out.timing_rounds
            return alt
    return out


def _interpolated(cm: ContactMechanics, prior: ContactControlResult, N: int) -> dict:
    """The guess of an ``N``-step grid from the answer ``prior`` on a coarser one: its horizon, its start's velocity,
    and its controls interpolated at this grid's control times (the ladder of grids; its sub-nodes centred)."""
    h = prior.T / N
    tu = cm.control_times(h * np.arange(N), np.full(N, h), np.zeros(N)).reshape(-1)
    guess = {"T": prior.T, "qd0": prior.v[0]}
    if prior.u is not None and np.size(prior.u):      # (a system without controls has none to interpolate)
        guess["u"] = controls_at(tu, prior.t_u, prior.u).reshape(N, -1)
    return guess


def _setup(problem, N: int, guess, options, verbose: bool, keep_modes: bool, path, o: ContactControlOptions,
           B: budget.Budget):
    """The program of one grid and its start: ``(Problem, the start point, the guess's march or None, the guess's
    time)``.  The controls' guess (the user's, else zero clipped to the bounds) is marched from the initial state by
    the contact march; where that fails (or halves a step), the straight line from the start to the end."""
    system, T, scheme, (q0, v0), (qN, vN), running, final, (lo, hi), _, control_points = problem
    free_time = tuple(T) if isinstance(T, (tuple, list)) else None
    cm = mechanics(system, scheme, control_points)
    n, nu, reps = cm.n, cm.nu, cm.nu // max(cm.nu1, 1)
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
    # (a guess per step, (N, controls), serves each of the step's control values; one per value is taken as it is)
    lo_all, hi_all = np.tile(lo, reps), np.tile(hi, reps)
    U0 = np.tile(np.clip(0.0, lo_all, hi_all), (N, 1)) if nu else np.zeros((N, 0))
    if nu and "u" in guess:
        Ug = np.asarray(guess["u"], float)
        if Ug.size == N * cm.nu1 and reps > 1:
            Ug = np.tile(Ug.reshape(N, cm.nu1), (1, reps))
        if Ug.size != N * nu:
            raise InputError(f"the guess's u needs {N} rows of {cm.nu1} (one per step) or of {nu} (one per control "
                             f"value of a step); got {Ug.size} values")
        U0 = np.clip(Ug.reshape(N, nu), lo_all, hi_all)
    length = _length_scale(system, q0)
    scales = _scales(system, q0, v0g, length, U0[0][:cm.nu1], Tg)
    p0 = np.asarray(system.momentum(q0, v0g)).reshape(-1)
    t_guess = _time.perf_counter()
    point = discrete_march(cm, q0, p0, N, h, scales, controls=U0, options=o.march_options)
    if point is not None and point["steps"].size != N:
        point = None          # the march halved a step (two impacts in it): its grid is not the program's
    if point is None and keep_modes:
        raise InputError("keep_modes needs the guess's march on the program's grid (it stopped, or halved a "
                         "step for two impacts in it): give another guess or more steps")
    guess_time = _time.perf_counter() - t_guess
    prog = _Program(cm, N, Tg, scales, vN is not None, running, final, (lo, hi), free_time=free_time,
                    start_velocity=bool(np.any(free_v)), path=path)
    prog.complementarity_target = o.complementarity_target
    prog.nlp.budget = B
    prog.set_split_weight(0.0)
    if vN is not None:
        prog.set_end_momentum(system.momentum(qN, vN))
    start_point = point if point is not None else _straight(cm, q0, qN, N)
    init = prog._start(q0, p0, {k: v for k, v in start_point.items() if k in prog.nlp.variable_names})
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
    ipopt = {**prog.settings.ipopt, **o.ipopt, **(options or {})}
    P = Problem(cm, prog, q0, N, scales, bounds, ipopt, o, verbose, TOUCH_TOL * length)
    return P, init, point, guess_time


def _timing_rounds(P: Problem, init: dict, near: bool):
    """Step 2 of the module docstring: rounds of the program, each on the branch read from the last answer
    (:func:`read_branch`), until the branch settles; then the rounds that move events pinned at their windows' edges
    (:func:`pinned`, :func:`_move_edge_arrivals`), one step per round.  ``(result, rounds, converged attempts)``."""
    prog, o = P.prog, P.o
    # (each round's bounces -- arrivals that leave again: Newton's law -- are read from the point it starts from)
    branch = read_branch(P, init)
    res, held, moves, before, seen, answers = None, None, [], None, set(), []
    rounds, limit = 0, o.timing_rounds
    while rounds < limit:
        rounds += 1
        seen.add(branch.key)
        R = _prepare(P, branch, init, res, held, moves, moving=before is not None, near=near)
        held = branch.events
        got = solve_round(P, R, ("warm",) if R.moving else o.starts)
        if R.moving and not got.continuable:
            break                       # (a moved round that does not converge warm ends the moves)
        res = got
        if res.continuable and before is None:
            answers.append(Attempt(res, prog.parameters()))
        if not res.continuable and res.solver_status in SUCCESS_STATUSES and P.cm.sc:
            # (converged short of complementarity with a stage lifted off a part held at its ends, a minimum of the
            # penalties: the next round holds that part at its stages, from this answer)
            now = read_branch(P, res.values, prev=branch)
            if now.holds is not None and np.any(now.holds & ~(branch.holds if branch.holds is not None else False)) \
                    and now.key not in seen:
                branch = now
                continue
        if not res.continuable:
            # (a later rung of the ladder failed after an earlier one converged short of complementarity: that one's
            # controls are the certificate's to march and solve on their branch)
            if prog.last_good is not None and res.solver_status not in SUCCESS_STATUSES:
                res = prog.last_good[1]
            break
        # the events read from the answer; once they settle with an event pinned against its window's edge, the
        # moves: each round then moves such an event one step, up to move_rounds rounds
        edges = pinned(P, res) if before is not None else []
        now = read_branch(P, res.values, edges, prev=branch)
        if now.same(branch):
            edges = pinned(P, res) if before is None else []
            if not edges:
                break
            now = read_branch(P, res.values, edges, prev=branch)
            if np.array_equal(now.timed, branch.timed):
                break                       # (nowhere to move)
            before = Attempt(res, prog.parameters())
            limit = rounds + o.move_rounds
        moves = [(k, k + side) for k, side in edges if 0 <= k + side < P.N and np.any(now.timed[k + side] &
                                                                                     ~now.timed[k])
                 and not np.any(branch.timed[k + side])]
        if now.key in seen:
            res.fail("Timing_Cycles", "the steps that hold an impact or a slip's turn changed back to an earlier set: "
                     "the events' steps did not settle")
            break
        branch = now
    else:
        res.fail("Timing_Not_Settled", f"the steps that hold an impact still changed after {limit} solves")
    if before is not None:
        res = _kept_moves(P, res, before)
    return res, rounds, answers


def _prepare(P: Problem, branch: Branch, init: dict, res, held, moves, moving: bool, near: bool) -> Round:
    """A round's start on ``branch``: the program holds it (its parameters and bounds, :func:`_event_bounds`), and a
    later round starts from the last answer ``res`` with the events ``moves`` shifted across their nodes
    (:func:`_shift`) and the steps whose events changed since ``held`` restarted from their one-step marches
    (:func:`_restart`)."""
    cm, prog = P.cm, P.prog
    prog.hold(timed=branch.timed, bounce=branch.bounce)
    last, restarted = None, False
    if res is not None:
        init = {k: v.copy() for k, v in res.values.items()}
        last = {k: v.copy() for k, v in init.items()}
        changed = np.any(branch.events != held, axis=1)
        # (an event moved across a node starts there, the rest of the answer kept: _shift)
        for k, to in moves:
            _shift(P, init, k, to)
            changed[[k, to]] = False
        restarted = _restart(P, init, changed)
    bounds = {**P.bounds, "beta": P.window(branch.free), **_event_bounds(P, branch, init)}
    for start in (init, last) if restarted else (init,):
        P.clip(start, branch.free)
        _event_start(cm, branch.turn, branch.ratio, start)
    if restarted and cm.friction:
        init.update(_slips(cm, prog, init, P.scales[2]))
    return Round(branch, bounds, init, last, res, restarted, moving, near)


def _certified(P: Problem, res, answers: List[Attempt], rounds: int, keep_modes: bool):
    """Steps 4 and 5 of the module docstring: the answer certified, re-solved on the march's branches where it does not certify (:func:`.certificate.certify`); where
    it does not certify, the earlier rounds' converged answers in turn, the latest first, each with its own events
    timed, and the first certified one is the answer.  ``(result, certificate, rounds)``."""
    prog, tol = P.prog, P.o.certificate_tol
    C = Certificate()
    if res.continuable or res.solver_status in SUCCESS_STATUSES:
        # (also where the homotopy converged short of complementarity, a local minimum of the penalties: its
        # controls, marched, are a motion, and the program on that motion's branch is solved from it)
        answers = [a for a in answers if a.res is not res]
        res, C, resolves = certify(P, res)
        rounds = (1 if keep_modes else rounds) + resolves
    kept = prog.parameters()
    for earlier in reversed(answers):
        if C.holds(tol) and res.success:
            break
        prog.restore(earlier.params)
        got, Cg, resolves = certify(P, earlier.res)
        rounds += resolves
        if Cg.holds(tol) and got.success:
            res, C = got, Cg
            kept = {}
    prog.restore(kept)          # (none certified: the program as the answer reported left it)
    return res, C, rounds


def _elastic(problem, N, guess, options, verbose, path, o: ContactControlOptions, B: budget.Budget,
             length) -> Optional[ContactControlResult]:
    """The end conditions' elastic mode (as an SQP solver's, SNOPT's): the problem solved with its given end state
    moved into the cost (``elastic_weight`` times its squared distance, on top of the cost), then solved again with
    the end conditions from that answer (its controls, horizon and free start).

    The timing rounds hold each event in a step read from a motion.  With the end state given, a round whose events
    sit in the wrong steps has no feasible point (a launch whose impact the end needs several steps later), and it
    stops at a penalty minimum; with the end state in the cost every round is feasible, and an event held against its
    window's edge moves to the next step (:func:`_move_edge_arrivals`) until the events sit where the end needs them.
    ``None`` where either solve fails."""
    system, T, scheme, (q0, v0), (qN, vN), running, final, u_bounds, controls, control_points = problem
    n = system.nq
    q, v, Ts = ca.SX.sym("q", n), ca.SX.sym("v", n), ca.SX.sym("T")
    given = np.where(~np.isnan(qN))[0]
    vref = max(float(np.max(np.abs(np.nan_to_num(np.asarray(v0, float))), initial=0.0)), 1e-8)
    miss = ca.sumsqr(q[given.tolist()] - ca.DM(qN[given])) / length ** 2 if given.size else 0
    if vN is not None:
        miss = miss + ca.sumsqr(v - ca.DM(np.asarray(vN, float))) / max(vref, length / np.mean(np.atleast_1d(T))) ** 2
    cost = final(q, v, Ts) if final is not None else 0
    soft = ca.Function("phi_elastic", [q, v, Ts], [cost + o.elastic_weight * miss])
    free_end = (np.full(n, np.nan), None)
    first = _solve_contact_control(system, T, N, scheme, (q0, v0), free_end, running, soft, u_bounds, controls, guess,
                                   options, verbose, False, path, o, B, elastic=False, control_points=control_points)
    if not first.success:
        return None
    g = {"T": first.T, "qd0": first.v[0],
         **({"u": first.u.reshape(N, -1)} if first.u is not None and np.size(first.u) else {})}
    out = _solve_contact_control(system, T, N, scheme, (q0, v0), (qN, vN), running, final, u_bounds, controls, g,
                                 options, verbose, False, path, o, B, elastic=False, control_points=control_points)
    if not out.success:
        return None
    out.iterations += first.iterations
    out.timing_rounds += first.timing_rounds
    return out


def _march_end(cm, prog, point, values):
    """The end node and its incoming momentum of a march ``point`` (the controls of ``values``)."""
    N, n = prog.L, cm.n
    Qg = np.asarray(point["q"], float).reshape(N + 1, n)
    h = float(prog.steps(values)[0])
    zp = cm.stage_parts(np.asarray(point.get("zs", np.zeros((N, 0)))).reshape(N, -1)[-1])[1]
    U = [prog._controls(values)[0][-1]]
    pg = np.asarray(cm.p_node_minus(np.asarray(point["qs"]).reshape(N, n)[-1], float(np.asarray(point["beta"])[-1]),
                                    Qg[-1], h, *zp, (N - 1) * h, *U)).reshape(-1)
    return Qg[-1], pg


def _continued(P: Problem, point, init, qN, vN):
    """The branch of the guess's march (``keep_modes``), its end moved from the march's own end state to the asked
    one: a continuation in the end conditions (the step doubled after a success, halved after a failure, down to
    1/1024), each solve warm from the last.  The guess's march ends where it ends, not where it is asked to: the bounce
    to a target from a launch at √(2gp) with k = 5, e = 0.7 needs a launch 6 times faster, which the branch solved
    directly did not find (Ipopt: infeasible after 1175 iterations)."""
    cm, prog, N, n, bounds = P.cm, P.prog, P.N, P.cm.n, P.bounds
    end, pg = _march_end(cm, prog, point, init)
    given = ~np.isnan(qN)
    qlo, qhi = (b.reshape(N + 1, n).copy() for b in bounds["q"])
    pN = np.asarray(cm.system.momentum(qN, vN)).reshape(-1) if vN is not None else None
    s, ds, values, res = 0.0, 1.0, init, None
    # (each step's Ipopt capped: a step too long fails fast and is halved; an uncapped one ran 3000 iterations)
    opts = dict(P.ipopt, max_iter=min(int(P.ipopt.get("max_iter", 3000)), P.o.continuation_iter))
    while s < 1.0:
        t = min(1.0, s + ds)
        qlo[N, given] = qhi[N, given] = (1 - t) * end[given] + t * qN[given]
        stage = dict(bounds, q=(qlo.reshape(-1), qhi.reshape(-1)))
        if pN is not None:
            prog.set_end_momentum((1 - t) * pg + t * pN)
        got = _branch(P, point, values, stage, opts, P.o.penalties[0], warm=res is not None)
        P.steps.extend(got.homotopy)
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


def _answer(system, P: Problem, res: NLPResult, rounds, controls, C: Certificate, wall,
            guess_time, keep_modes: bool = False, on_node=()) -> ContactControlResult:
    cm, prog, q0, N, o, steps = P.cm, P.prog, P.q0, P.N, P.o, P.steps
    n, c = cm.n, cm.c
    V = res.values
    h, p0, U = _start_of(prog, V, q0)
    Q, S = V["q"].reshape(N + 1, n), V["qs"].reshape(N, n)
    B = V["beta"].reshape(N)
    MU, NU = V["mu"].reshape(N, c), V["nu"].reshape(N, c)
    times = h * np.arange(N + 1)
    t_sub = times[:-1] + (0.5 + B) * h
    # the cost: the running and final terms at the answer (the objective also holds the penalties)
    cost = prog.cost(V)
    arr = arrivals(cm, Q, S, TOUCH_TOL * max(1.0, float(np.max(np.abs(q0)))), NU, prog.scales_pref, o.node_force)
    # (and the impacts at a node: a flight that landed on it, its node force an impulse, the march's mode N)
    node = np.asarray(prog.nlp.parameter_value("node_impact"), float).reshape(N, c) > 0
    impact_times = [sorted([float(t_sub[k]) for k in range(N) if arr[k, j] and MU[k, j] > 0.0]
                           + [float(times[k]) for k in range(N) if node[k, j] and NU[k, j] > 0.0]) for j in range(c)]
    # velocities: the mean of the one-sided momenta at each node (the node's impulse split between them)
    ua = [U.T]
    T0 = prog.step_starts(np.full(N, h))[None, :]
    pp = np.asarray(cm.p_node_plus.map(N)(Q[:-1].T, S.T, B, h, *_zparts(prog, V, 0), T0, *ua)).T
    pm = np.asarray(cm.p_node_minus.map(N)(S.T, B, Q[1:].T, h, *_zparts(prog, V, 1), T0, *ua)).T
    p = np.vstack([p0[None, :], 0.5 * (pp[1:] + pm[:-1]), pm[-1:]])
    if prog.end_velocity:            # the end node's momentum after its own force: the given final one
        p[-1] = np.asarray(prog.nlp.parameter_value("pN"), float).reshape(-1)
    v = cm.dm.velocities(Q, p)
    # (each control value its own row, at its time t_u: one per step, or per node of each part's quadrature)
    Uv = U.reshape(-1, cm.nu1) if cm.nu else U
    out = ContactControlResult(
        success=res.success, solver_status=res.solver_status, message=res.message,
        # (a failure found after the solver converged keeps its name: Complementarity_Not_Reached was reported as
        # Ipopt's Solve_Succeeded with success False)
        status="" if res.success else res.status, iterations=sum(st.iterations for st in steps),
        build_time_s=res.build_time_s, solve_time_s=wall - res.build_time_s, cost=cost, T=N * h, t=times, q=Q, v=v,
        u=Uv, t_u=cm.control_times(times[:-1], np.full(N, h), B).reshape(-1),
        controls=split_controls(Uv, controls, Uv.shape[0]),
        certificate=C.local, march_distance=C.march,
        scheme=cm.dm.scheme.name, qs=S, t_sub=t_sub, mu=MU, nu=NU,
        fratio=V["fratio"].reshape(N, -1) if cm.friction else None, impact_times=impact_times,
        complementarity=float(prog.residual(V)), homotopy=steps, timing_rounds=rounds)
    out.biactive, out.b_violation = b_stationarity(prog, res, abs(cost))
    edges = pinned(P, res)
    node = [e for e in edges if e in on_node]
    held = [e for e in edges if e not in on_node]
    out.pinned = [{"step": k, "t": float(t_sub[k]), "edge": "end" if side > 0 else "start",
                   "held": "node" if (k, side) in on_node else "window"} for k, side in edges]
    # (an event the window holds is a multiplier the proxy does not see: no B-stationary point.  One held on its
    # node from both sides is a local optimum over its step: _across)
    out.b_stationary = bool(out.b_violation <= o.b_tol) and not held
    for k, side in node:
        t_node = times[k + (1 if side > 0 else 0)]
        out.warnings.append(
            f"the event timed in step {k} sits on the node at t = {t_node:.6g} s: moved across it into step "
            f"{k + side} the optimum costs more, so the program holds it on the node from both sides; its time "
            f"is resolved to the step, h = {h:.3g} s (refine N to resolve it further)")
    if held and not (res.success and C.holds(o.certificate_tol)):
        # (an answer that failed otherwise: where its events stopped, for the next attempt's guess)
        out.warnings.extend(f"the event timed in step {k} sits at the {'end' if side > 0 else 'start'} of its step's "
                            f"window (t = {t_sub[k]:.6g} s, β = {B[k]:+.4f}), held by a bound of the transcription"
                            for k, side in held)
    if res.success and held and C.holds(o.certificate_tol):
        where = "; ".join(f"step {k}'s at the {'end' if side > 0 else 'start'} of its window (t = {t_sub[k]:.6g} s, "
                          f"β = {B[k]:+.4f})" for k, side in held)
        out.fail("Event_Pinned",
                 f"an event is held by a bound of the transcription, not of the problem: {where}; the optimum of the "
                 f"continuous problem wants it beyond, so this motion (certified to {C.local:.2g}) is no optimum of "
                 "it; " + ("keep_modes holds each event in its guess's step: solve without it, or start from a guess "
                           "whose events lie nearer the optimum's" if keep_modes else
                           "moved across its node it did not converge, or could not move: start from a guess whose "
                           "events lie nearer the optimum's, or refine N"))
    if res.success and not C.holds(o.certificate_tol):
        out.fail("Certificate_Failed", f"a step of the optimal controls, marched by the contact march from the answer's "
                                       f"own node, departs from the answer by {C.local:.3g} (relative): not a motion of "
                                       f"the system")
    return out


