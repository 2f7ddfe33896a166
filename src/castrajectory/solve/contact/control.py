"""Contact-implicit optimal control, solved whole by Ipopt and certified by the contact march.

The program is :class:`castrajectory.discretise.contact.control.ContactControlTranscription`.  The solve:

1. **Guess**: the controls' guess (zero, clipped to the bounds, or the user's) is marched from the initial
   state with the contact march (:func:`.march.discrete_march`): a motion of the system with its impacts,
   contact forces and friction already consistent, so the homotopy starts from a feasible motion.
2. **Timing**: the sub-node of a step is where an impact is timed; it is free (``β`` an unknown) only in the
   steps where a contact arrives (open at ``q_k``, closed at ``q̃_k`` or ``q_{k+1}``), and centred (``β = 0``)
   elsewhere, as in the march.  (A free ``β`` in every step would be a control of its own: two midpoint parts
   of lengths ``αh`` and ``(1 − α)h`` are a different step map, and the cost moved ``β`` to its bounds.)  Which
   steps arrive is read from the solution and the program solved again, warm, until it no longer changes
   (:data:`TIMING_ROUNDS`).
3. **Penalty ladder**: the exact ℓ1 penalties of the complementarity pairs rise (``PENALTY``), each solve warm
   started from the last, until the scaled complementarity residual is at most ``COMPLEMENTARITY_TOL``.
4. **Certificate**: the optimal controls are marched from the initial state with the contact march, and the
   march must reproduce the optimal nodes (relative distance at most :data:`CERTIFICATE_TOL`): the answer is then
   a motion of the system under its own controls, impacts and friction included.  An answer the march does not
   reproduce is a failure, with the distance in its message.
"""
from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field
from typing import Dict, List, Optional

import casadi as ca
import numpy as np

from ...discretise.contact.control import ContactControlTranscription
from ...discretise.contact.elements import ContactMechanics
from ...discretise.contact.transcription import ALPHA_MIN, TOUCH_TOL
from ...discretise.optimal_control import split_controls
from ...result import NLPResult
from ..nlp import NLP
from ...result import ControlResult
from .march import discrete_march
from .nlp import CONTACT_IPOPT, ContactNLP
from .strategy import _length_scale

#: Ipopt options of the contact-implicit solve, on top of CONTACT_IPOPT.  The initial-value program starts its barrier
#: at 1e-8 (its guess is the answer); here the guess is a motion far from the optimum, and from there a small
#: barrier let the first iterations throw the block off the floor into a local minimum of the penalties (N = 20:
#: Ipopt's default barrier start solved it, 253 iterations).  The adaptive barrier: 75 iterations (N = 20), and
#: on the ladder of grids 15 on N = 80, 23 on N = 160, where the monotone one took 607 there and stopped on
#: a worse motion (cost +0.41).
OCP_CONTACT_IPOPT = {"max_iter": 3000, "mumps_pivtol": 1e-8, "mu_init": 1e-1, "mu_strategy": "adaptive",
                     "bound_push": 1e-2, "bound_frac": 1e-2, "slack_bound_push": 1e-2, "slack_bound_frac": 1e-2}
#: The penalty ladder of the contact-implicit solve.
OCP_PENALTY = (1e3, 1e4, 1e5, 1e6)
#: Solves with the arrivals read from the last answer, at most (step 2 of the module docstring).
TIMING_ROUNDS = 6
#: Solves on the march's branch at most (step 5 of the module docstring).
POLISH_ROUNDS = 3
#: A grid of more steps than this starts from the controls of the answer on half as many (see solve_contact_control).
LADDER_MAX = 32
#: The march of the optimal controls must reproduce the optimal nodes to this, relative to their scale.
CERTIFICATE_TOL = 1e-7


class _Program(ContactControlTranscription, ContactNLP):
    program = NLP


_CACHE: Dict[tuple, ContactMechanics] = {}


def mechanics(system, scheme: str) -> ContactMechanics:
    """The contact elements of ``system`` and ``scheme``, built once per pair."""
    key = (id(system), scheme)
    if key not in _CACHE or _CACHE[key].system is not system:
        _CACHE[key] = ContactMechanics(system, scheme)
    return _CACHE[key]


@dataclass(kw_only=True)
class ContactControlResult(ControlResult):
    """A contact-implicit optimal control's answer: :class:`ControlResult`, plus the sub-node configurations
    ``qs`` (``(N, n)``) and their times ``t_sub``, the impulses ``mu`` at the sub-nodes and the node forces ``nu``
    (``(N, c)`` each), the friction ratios ``fratio`` (``(N, 2c)``: node and sub-node slots), the impacts
    (``impact_times``, one list per contact: the sub-node times of the steps where the contact arrives with an
    impulse), ``complementarity``: the scaled complementarity residual at the answer (the penalties' pairs, as
    the initial-value program measures it), ``homotopy``: the penalty steps of every timing round, and
    ``certificate``: the march of the optimal controls against the optimal nodes (``CERTIFICATE_TOL``)."""

    qs: Optional[np.ndarray] = None
    t_sub: Optional[np.ndarray] = None
    mu: Optional[np.ndarray] = None
    nu: Optional[np.ndarray] = None
    fratio: Optional[np.ndarray] = None
    impact_times: List[List[float]] = field(default_factory=list)
    complementarity: float = math.nan
    homotopy: list = field(default_factory=list)
    timing_rounds: int = 0

    def as_dict(self) -> dict:
        return {**super().as_dict(), "qs": self.qs, "t_sub": self.t_sub, "mu": self.mu, "nu": self.nu,
                "fratio": self.fratio, "impact_times": self.impact_times, "complementarity": self.complementarity,
                "timing_rounds": self.timing_rounds,
                "homotopy": [vars(h) for h in self.homotopy]}


def _scales(system, cm: ContactMechanics, q0, v0, length: float, u):
    """(length, momentum, velocity, acceleration) scales for the penalties: as the initial-value program's, the
    acceleration under the controls' guess."""
    qdd = ca.substitute(system._index1_exprs()[0], system.control_vector, ca.DM(u))
    acc_fn = ca.Function("acc", [system.q, system.qd], [qdd])
    acc = float(np.max(np.abs(np.asarray(acc_fn(q0, v0)))))
    vref = max(float(np.max(np.abs(v0))), math.sqrt(acc * length), 1e-8)
    mref = float(np.max(np.diag(np.asarray(system.mass_matrix(q0)))))
    return length, mref * vref, vref, acc


def arrivals(cm: ContactMechanics, Q, S, tol: float) -> np.ndarray:
    """Per step and contact: the contact arrives in the step (open at ``q_k``, closed at ``q̃_k`` or ``q_{k+1}``)."""
    L = S.shape[0]
    g = lambda A: np.asarray(cm.gap_row.map(A.shape[0])(A.T)).reshape(cm.c, -1).T  # noqa: E731
    gq, gs = g(Q), g(S)
    return (gq[:-1] > tol) & (np.minimum(gs, gq[1:]) <= tol) if L else np.zeros((0, cm.c), bool)


def solve_contact_control(system, T: float, N: int, scheme: str, start, end, running, final, u_bounds,
                          controls, guess: Optional[dict] = None, options: Optional[dict] = None,
                          verbose: bool = False) -> ContactControlResult:
    """Solve a contact-implicit optimal-control problem (module docstring).  ``start``, ``end``: ``(q, q̇)``
    with NaN for a free entry (``q̇`` ``None``: free; the start must be given in full); ``running(q, v, u)``,
    ``final(q, v, T)``: CasADi functions or ``None``; ``u_bounds``: ``(lo, hi)``; ``controls``: the system's
    :class:`Control` list (for the answer's ``controls`` by name)."""
    t_all = _time.perf_counter()
    rungs: List[int] = []
    if guess is None and N > LADDER_MAX:
        # the ladder of grids (as for the smooth problem, OptimalControl.solve): the answer on half the steps, its
        # controls interpolated at this grid's steps, is the controls' guess here
        prior = solve_contact_control(system, T, (N + 1) // 2, scheme, start, end, running, final, u_bounds, controls,
                                      None, options, verbose)
        if prior.success:
            tu = T / N * (np.arange(N) + 0.5)
            guess = {"u": np.column_stack([np.interp(tu, prior.t_u, prior.u[:, j]) for j in range(prior.u.shape[1])])}
            rungs = prior.grids
    cm = mechanics(system, scheme)
    (q0, v0), (qN, vN) = start, end
    n, nu = cm.n, cm.nu
    lo, hi = u_bounds
    h = T / N
    U0 = np.tile(np.clip(0.0, lo, hi), (N, 1))
    if guess and "u" in guess:
        U0 = np.clip(np.asarray(guess["u"], float).reshape(N, nu), lo, hi)
    length = _length_scale(system, q0)
    scales = _scales(system, cm, q0, v0, length, U0[0])
    tol = TOUCH_TOL * length
    p0 = np.asarray(system.momentum(q0, v0)).reshape(-1)
    t_guess = _time.perf_counter()
    point = discrete_march(cm, q0, p0, N, h, scales, controls=U0)
    if point is not None and point["steps"].size != N:
        point = None          # the march halved a step (two impacts in it): its grid is not the program's
    if point is None:
        point = _straight(cm, q0, qN, N)
    guess_time = _time.perf_counter() - t_guess
    prog = _Program(cm, N, T, scales, vN is not None, running, final, (lo, hi))
    prog.nlp.set_parameter("split", 0.0)
    if vN is not None:
        prog.nlp.set_parameter("pN", np.asarray(system.momentum(qN, vN)).reshape(-1))
    init = prog._start(q0, p0, {k: v for k, v in point.items() if k in prog.nlp.variable_names})
    init["u"] = U0.reshape(-1)
    if cm.friction:
        init.update(_slips(cm, prog, init, scales[2]))
    bounds = {"q": _q_bounds(prog, q0, qN)}
    if vN is not None and cm.friction:
        bounds["fratio_end"] = _end_ratio_bounds(cm, qN, vN, scales[2])
    opts = {**CONTACT_IPOPT, **OCP_CONTACT_IPOPT, **(options or {})}
    Q, S = init["q"].reshape(N + 1, n), init["qs"].reshape(N, n)
    timed = arrivals(cm, Q, S, tol)
    steps, res, rounds, seen = [], None, 0, set()
    while rounds < TIMING_ROUNDS:
        rounds += 1
        seen.add(timed.tobytes())
        prog.nlp.set_parameter("timed", timed.astype(float).reshape(-1))
        if cm.friction:
            prog.nlp.set_parameter("arrive", timed.astype(float).reshape(-1))
        free = np.any(timed, axis=1)
        bounds["beta"] = (np.where(free, ALPHA_MIN - 0.5, 0.0), np.where(free, 0.5 - ALPHA_MIN, 0.0))
        if res is not None:
            init = {k: v.copy() for k, v in res.values.items()}
        init["beta"] = np.where(free, init["beta"], 0.0)
        res = prog._ladder(init, opts, bounds, OCP_PENALTY, verbose, "rho", "Ipopt")
        steps.extend(res.homotopy)
        if not res.success:
            break
        V = res.values
        now = arrivals(cm, V["q"].reshape(N + 1, n), V["qs"].reshape(N, n), tol)
        if np.array_equal(now, timed):
            break
        if now.tobytes() in seen:
            res.fail("Timing_Cycles", "the steps that hold an impact changed back to an earlier set: the impacts' "
                     "steps did not settle")
            break
        timed = now
    else:
        res.fail("Timing_Not_Settled", f"the steps that hold an impact still changed after {TIMING_ROUNDS} solves")
    cert = math.nan
    if res.success:
        res, cert, polished = _polish(cm, prog, res, q0, p0, N, h, scales, bounds, opts, verbose, steps)
        rounds += polished
    out = _answer(system, cm, prog, res, steps, rounds, q0, p0, N, h, controls, cert,
                  _time.perf_counter() - t_all, guess_time)
    out.grids = rungs + [N]
    return out


def _polish(cm, prog, res, q0, p0, N, h, scales, bounds, opts, verbose, steps):
    """Step 5: march the answer's controls; where the march does not reproduce the answer, solve again on the
    march's branch (its modes fixed, :meth:`ContactNLP.mode_bounds`; the controls free), and march again.
    ``(result, certificate, solves)``: the certificate is the last march's distance (``inf`` where it stopped)."""
    rho = float(np.asarray(prog.nlp.parameter_value("rho")).reshape(-1)[0])
    solves = 0
    while True:
        U = res.values["u"].reshape(N, cm.nu)
        point = discrete_march(cm, q0, p0, N, h, scales, controls=U)
        cert = _distance(point, res.values["q"].reshape(N + 1, cm.n), N, h)
        if cert <= CERTIFICATE_TOL or solves >= POLISH_ROUNDS or point is None or point["steps"].size != N:
            return res, cert, solves
        solves += 1
        branch = prog.mode_bounds(q0, point)
        branch.update({k: v for k, v in bounds.items() if k != "beta"})
        if cm.friction:
            # a slot without friction force (an open contact: no force, so its ratio is free; the march fixes it at 0)
            # keeps its ratio in the cone, where the slip pair sets it against the slip
            free = np.asarray(point["fmodes"]).reshape(-1) == "-"
            lo_r, hi_r = branch["fratio"]
            muf = np.tile(np.concatenate([cm.mu_f, cm.mu_f]), N)
            branch["fratio"] = (np.where(free, -muf, lo_r), np.where(free, muf, hi_r))
        arrive = np.isin(np.asarray(point["modes"]).reshape(N, cm.c), ("I", "C", "T", "F", "K"))
        prog.nlp.set_parameter("timed", arrive.astype(float).reshape(-1))
        init = {k: np.asarray(v, float).reshape(-1).copy() for k, v in point.items() if k in prog.nlp.variable_names}
        for k, v in res.values.items():
            init.setdefault(k, v.copy())
        init["u"] = U.reshape(-1)
        if cm.friction:
            init.update(_slips(cm, prog, init, scales[2]))
        prog.nlp.set_parameter("law_length", prog.law_lengths(point).reshape(-1))
        got = prog._ladder(init, opts, branch, [rho], verbose, "branch", "the march's branch")
        steps.extend(got.homotopy)
        if not got.success:
            return res, _distance(point, res.values["q"].reshape(N + 1, cm.n), N, h), solves
        res = got


def _straight(cm: ContactMechanics, q0, qN, N: int) -> dict:
    """The fallback guess: the straight line from ``q0`` to ``q_N`` (its given entries), every force zero."""
    b = np.where(np.isnan(qN), q0, qN)
    w = np.linspace(0.0, 1.0, N + 1)[:, None]
    Q = q0[None, :] + w * (b - q0)[None, :]
    return {"q": Q.reshape(-1), "qs": (0.5 * (Q[:-1] + Q[1:])).reshape(-1), "beta": np.zeros(N)}


def _slips(cm: ContactMechanics, prog, init, vref) -> dict:
    """The slip splits ``s⁺, s⁻`` of the initial point (its slip velocities' signs)."""
    N, n, c = prog.L, cm.n, cm.c
    Q, S = init["q"].reshape(N + 1, n), init["qs"].reshape(N, n)
    ar = np.asarray(prog.nlp.parameter_value("arrive"), float).reshape(N, c)
    sl = np.asarray(cm.slip_row.map(N)(Q[:-1].T, S.T, Q[1:].T, init["beta"].reshape(N), prog.H, ar.T)).T / vref
    return {"slip_plus": np.maximum(sl, 0.0).reshape(-1), "slip_minus": np.maximum(-sl, 0.0).reshape(-1)}


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


def _answer(system, cm, prog, res: NLPResult, steps, rounds, q0, p0, N, h, controls, cert, wall,
            guess_time) -> ContactControlResult:
    n, c, nu = cm.n, cm.c, cm.nu
    V = res.values
    Q, S = V["q"].reshape(N + 1, n), V["qs"].reshape(N, n)
    B = V["beta"].reshape(N)
    U = V["u"].reshape(N, nu)
    MU, NU = V["mu"].reshape(N, c), V["nu"].reshape(N, c)
    times = h * np.arange(N + 1)
    t_sub = times[:-1] + (0.5 + B) * h
    # the cost: the running and final terms at the answer (the objective also holds the penalties)
    cost = prog.cost(V)
    arr = arrivals(cm, Q, S, TOUCH_TOL * max(1.0, float(np.max(np.abs(q0)))))
    impact_times = [[float(t_sub[k]) for k in range(N) if arr[k, j] and MU[k, j] > 0.0] for j in range(c)]
    # velocities: the mean of the one-sided momenta at each node (the node's impulse split between them)
    pp = np.asarray(cm.p_node_plus.map(N)(Q[:-1].T, S.T, B, h, *_zparts(cm, V, N, 0), U.T)).T
    pm = np.asarray(cm.p_node_minus.map(N)(S.T, B, Q[1:].T, h, *_zparts(cm, V, N, 1), U.T)).T
    p = np.vstack([p0[None, :], 0.5 * (pp[1:] + pm[:-1]), pm[-1:]])
    if prog.end_velocity:            # the end node's momentum after its own force: the given final one
        p[-1] = np.asarray(prog.nlp.parameter_value("pN"), float).reshape(-1)
    v = cm.dm.velocities(Q, p)
    march = cert
    out = ContactControlResult(
        success=res.success, solver_status=res.solver_status, message=res.message, iterations=sum(st.iterations for st in steps),
        build_time_s=res.build_time_s, solve_time_s=wall - res.build_time_s, cost=cost, T=N * h, t=times, q=Q, v=v,
        u=U, t_u=times[:-1] + 0.5 * h, controls=split_controls(U, controls, N), certificate=cert, march_distance=march,
        scheme=cm.dm.scheme.name, qs=S, t_sub=t_sub, mu=MU, nu=NU,
        fratio=V["fratio"].reshape(N, -1) if cm.friction else None, impact_times=impact_times,
        complementarity=float(prog.residual(V)), homotopy=steps, timing_rounds=rounds)
    if res.success and not (cert <= CERTIFICATE_TOL):
        out.fail("Certificate_Failed", f"the contact march of the optimal controls departs from the optimal "
                                       f"trajectory by {cert:.3g} (relative): not a motion of the system")
    return out


def _zparts(cm, V, N, part):
    if not cm.s:
        return []
    Z = V["zs"].reshape(N, 2 * cm.s)
    return [(Z[:, :cm.s] if part == 0 else Z[:, cm.s:]).T]


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
    return float(np.max(np.abs(Qm - Q[k]))) / max(1.0, float(np.max(np.abs(Q))))
