"""Contact trajectories solved: the event-located guess, the penalty ladder, held catches and windows.

The program is written by :class:`castrajectory.discretise.contact.transcription.ContactTranscription`
(its docstring states the transcription); :func:`solve_contact` solves it.  A system without a
contact term never reaches this module (:func:`castrajectory.solve.trajectory.solve_initial_value`
dispatches).

Solution strategy (chosen by the library)
-----------------------------------------
1. **Event-located guess.**  The smooth equations of motion are integrated
   (RK4) from the start; every gap crossing is located by bisection, the
   impact law of :func:`castrajectory.models.collision.impact_law` is applied
   there and the flight continues.  The sub-node of that step is placed at the
   crossing with the impact's ``μ``; a second crossing in the rest of that step gets a second
   impact and sub-node (whole solve only).  A slow arrival (normal speed below
   ``v_z = max(2, 1/e) a h``, ``a`` the scene's acceleration scale) while every
   contact of the body moves slowly along the normal is caught instead (the
   accumulation point of Zeno bouncing): a plastic impact, after which the
   caught contacts are *held* (each RK4 step projected back onto ``φ_j = 0``,
   ``J_j v = 0``: the body rests or slides) until the free flight would lift one off.
2. **The branch the guess identifies** (:meth:`ContactNLP.solve_branch`): every complementarity
   pair decided by the guess (touching contacts keep their gap rows as equalities, open ones have no
   force or impulse; Newton's law exact at the guess's bounces), a nearly square NLP whose solution is
   a solution of the complementarity problem.  From the event-located guess it converges in a few
   iterations; a wrong decision stops it within :data:`BRANCH_IPOPT`'s budget.
3. Otherwise the **whole solve** of all ``N`` steps from that guess with the penalty ladder.
   If it fails where the residual's unweighted check of Newton's law rejects
   the last point Ipopt solved (a *loophole*: the law's weight small there, or
   the waiver used for a catch that lifts off again), those laws are weighted
   by ``φ(q_{k+2})/ℓ`` as well (a catch must hold) and the whole solve restarts
   from the guess (at most :data:`HELD_ROUNDS` rounds; :meth:`ContactNLP.loopholes`).
4. If that fails too, **horizon windows** (small contact NLPs marched over the
   horizon, each with its own event-located guess and iteration budget, its branch first) whose
   assembled solution starts a final whole solve (its branch first).  If every window converged
   but that final solve does not, the assembled point itself is the answer
   provided it satisfies the whole NLP (scaled rows within
   :data:`ASSEMBLED_ROW_TOL`, residual within :data:`COMPLEMENTARITY_TOL`),
   reported with the status ``Assembled_From_Windows``.

Otherwise the reported status is that of the last whole-trajectory solve.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Dict, List, Optional

import numpy as np

from ..models.impact import impact_law, simultaneous_impact  # noqa: F401  (re-exported)
from ..models.mechanics import LagrangianSystem
from ..result import HomotopyStep, NLPResult, Result
from ..validation import InputError
from ..discretise.contact.elements import ContactMechanics  # noqa: F401  (re-exported)
from ..discretise.contact.transcription import (
    ALPHA_MIN, COMPLEMENTARITY_TOL, LOOKAHEAD, PENALTY, REST_SPEED_STEPS, TOUCH_TOL,
    ContactTranscription, _v_zeno)
from .nlp import NLP


#: Ipopt options of contact solves: bound_relax_factor 0 (impulses, forces and gaps stay exactly
#: non-negative), tiny bound and slack pushes so guesses on the ground are not pushed away.
CONTACT_IPOPT = {"tol": 1e-10, "max_iter": 200, "bound_relax_factor": 0.0,
                 "bound_push": 1e-8, "bound_frac": 1e-8, "slack_bound_push": 1e-8, "slack_bound_frac": 1e-8,
                 "mu_init": 1e-8, "constr_mult_init_max": 0}
#: A sub-node impulse counts as an impact when the contact approaches faster than this many
#: steps' worth of its normal acceleration (resting contact approaches at about ½ step's worth).
IMPACT_SPEED_STEPS = 2.0
#: ... and its impulse exceeds this fraction of the momentum scale (interior-point noise is far below).
IMPULSE_TOL = 1e-6
#: Contacts whose gaps close within this (times the length scale) of each other at a located
#: crossing take one simultaneous impact in the guess (a flat landing).
SIMULTANEOUS_TOL = 1e-9
#: Steps looked ahead after a bounce for the rocking-accumulation catch of the guess.
LOOKAHEAD_CATCH = 3
#: Steps of free flight integrated per call in the event-located guess.
GUESS_CHUNK = 64



@dataclass
class Impact:
    """One impact found in a solution: step ``k``, time, contact, impulse and velocities."""

    step: int
    t: float
    contact: int
    mu: float
    q: np.ndarray
    v_before: np.ndarray
    v_after: np.ndarray
    #: the contact is closed again at the next node: the body is caught (plastic, Newton's law
    #: waived; the accumulation of Zeno bouncing or rocking), not a bounce
    caught: bool = False
    #: which sub-node of the step: 0 (the first, ``q_sub``), 1 (the second, ``q_sub2``)
    sub: int = 0

    def as_dict(self) -> dict:
        return {"step": self.step, "t": self.t, "contact": self.contact, "mu": self.mu,
                "q": self.q, "v_before": self.v_before, "v_after": self.v_after, "caught": self.caught,
                "sub": self.sub}


@dataclass(kw_only=True)
class ContactTrajectory(Result):
    """Solution of a contact trajectory (fields as :class:`castrajectory.solve.trajectory.Trajectory`, plus contact data)."""

    t: np.ndarray
    q: np.ndarray
    p: np.ndarray               # node momenta: mean of p_k⁻ and p_k⁺ (see _finish); p_0 as given
    v: np.ndarray
    energy: np.ndarray
    t_sub: np.ndarray           # sub-node times t_k + α_k h, one per step
    q_sub: np.ndarray
    mu: np.ndarray              # (N, contacts) sub-node impulses
    nu: np.ndarray              # (N + 1, contacts) node impulses h ν_k (last row: the look-ahead's node force at T)
    node_impulse: np.ndarray    # (N + 1, contacts) Λ_k: impulse per node (sub-node impulses lumped, see _finish)
    gap: np.ndarray             # (N + 1, contacts) gaps at the nodes
    gap_sub: np.ndarray         # (N, contacts) gaps at the sub-nodes
    impacts: List[Impact]
    complementarity_residual: float
    scheme: str
    homotopy: List[HomotopyStep] = field(default_factory=list)
    attempts: List[dict] = field(default_factory=list)
    mode: str = "initial_value"
    method: str = "whole"
    #: Steps with a second sub-node (where the event-located guess found two impacts in one step;
    #: empty otherwise) and, as rows over these steps, its time t_k + α₂ h, configuration, impulses
    #: and gaps.  In those steps ``t_sub``, ``q_sub``, ``mu`` hold the first sub-node.
    steps_sub2: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    t_sub2: np.ndarray = field(default_factory=lambda: np.zeros(0))
    q_sub2: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    mu_sub2: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    gap_sub2: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))

    def as_dict(self) -> dict:
        return {**super().as_dict(), "solver_status": self.solver_status,
                "scheme": self.scheme, "method": self.method, "t": self.t, "q": self.q,
                "energy": self.energy, "t_sub": self.t_sub, "mu": self.mu, "nu": self.nu,
                "node_impulse": self.node_impulse,
                "gap": self.gap, "complementarity_residual": self.complementarity_residual,
                "impacts": [i.as_dict() for i in self.impacts],
                "steps_sub2": self.steps_sub2, "t_sub2": self.t_sub2, "mu_sub2": self.mu_sub2,
                "homotopy": [vars(s) for s in self.homotopy], "attempts": self.attempts}


#: Options of the branch solve (:meth:`ContactNLP.solve_branch`) on top of CONTACT_IPOPT.  From a guess
#: that identifies the branch it converges in 6-25 iterations (measured over the battery); a branch that
#: needs more is a wrong decision, and its iterations grow expensive (restoration on a degenerate KKT
#: matrix: 2 s each with MUMPS' default pivot tolerance, 0.46 s with 1e-8, on a 4000-step block drop).
BRANCH_IPOPT = {"max_iter": 30, "mumps_pivtol": 1e-8}


class ContactNLP(ContactTranscription):
    """The contact transcription written into an Ipopt :class:`~castrajectory.solve.nlp.NLP`, and its solve."""

    program = NLP


    def solve(self, q0, p0, guess: Dict[str, np.ndarray], penalties=None, options=None, verbose=False):
        """Solve from ``guess``, raising the penalty until complementarity holds.

        Returns ``(NLPResult, steps)``; ``NLPResult.build_time_s`` is 0 unless this call (re)built the solver.
        """
        before = self.nlp._solver
        qlo, qhi = self._q_bounds(q0)
        opts = dict(CONTACT_IPOPT)
        opts.update(options or {})
        init = self._start(q0, p0, guess)
        steps: List[HomotopyStep] = []
        res, build = None, 0.0
        self.last_good = None            # (ρ, NLPResult) of the last penalty step Ipopt solved
        for rho in (penalties or PENALTY):
            self.nlp.set_parameter("rho", rho)
            res = self.nlp.solve(init=init if res is None else None, warm=res, options=opts, verbose=verbose,
                                 bounds={"q": (qlo, qhi)})
            if self.nlp._solver is not before and build == 0.0:
                build = res.build_time_s
            resid = self.residual(res.values)
            steps.append(HomotopyStep(rho, res.solver_status, res.iterations, res.solve_time_s, resid, parameter="rho"))
            if res.success:
                self.last_good = (rho, res)
            if not res.success or resid <= COMPLEMENTARITY_TOL:
                break
        res.build_time_s = build
        res.iterations = sum(st.iterations for st in steps)
        res.solve_time_s = sum(st.solve_time_s for st in steps)
        res.complementarity_residual = steps[-1].complementarity_residual
        res.homotopy = steps
        if res.success and steps[-1].complementarity_residual > COMPLEMENTARITY_TOL:
            res.fail("Complementarity_Not_Reached",
                     f"Ipopt converged but the complementarity residual "
                     f"{steps[-1].complementarity_residual:.2e} exceeds {COMPLEMENTARITY_TOL:g}")
        return res

    def solve_branch(self, q0, p0, guess: Dict[str, np.ndarray], options=None, verbose=False) -> NLPResult:
        """Solve the branch of the complementarity problem that ``guess`` identifies.

        Each pair is decided by the event-located guess: a contact that touches at a node (gap within
        ``TOUCH_TOL ℓ``) keeps its gap row as an equality and its force free (≥ 0); an open one has its
        force fixed at 0 and its gap row ≥ 0.  A sub-node with an impulse in the guess sits on the
        ground (gap row = 0, impulse ≥ 0); the others have no impulse.  Newton's law holds exactly
        (slacks fixed at 0) at the guess's bounces, and its rows are off elsewhere (no impulse there,
        or a catch, whose next node is held closed).  Every product of the branch is zero by
        construction, so a converged branch is a solution of the complementarity problem (gaps ≥ 0,
        impulses ≥ 0 by the bounds, the law exact at the bounces); the objective left is the selection
        term.  A wrong decision makes the branch infeasible, and the caller falls back to the penalty
        continuation (:meth:`solve`).
        """
        n, c, L = self.cm.n, self.cm.c, self.L
        tol = TOUCH_TOL * self.scales_ell
        Q = np.asarray(guess["q"], float).reshape(L + 1, n)
        gapf = self.cm.system.gap
        S = np.asarray(guess["qs"], float).reshape(L, n)
        gq = np.asarray(gapf.map(L + 1)(Q.T)[0]).reshape(c, L + 1).T
        gs = np.asarray(gapf.map(L)(S.T)[0]).reshape(c, L).T
        closed = gq <= tol                                   # (L + 1, c)
        MU = np.asarray(guess["mu"], float).reshape(L, c)
        NU = np.asarray(guess["nu"], float).reshape(L, c)
        hit = MU > 0.0
        bounced = hit & ~closed[1:]      # an impulse after which the contact is open at the next node
        # a pair the guess leaves undecided -- touching, but without force or impulse (a contact being
        # released, or grazing) -- stays a complementarity pair, penalised in the objective and
        # checked by the residual below; every other pair is decided
        press = np.zeros((L + 1, c), bool)
        press[:L] = NU > 0.0
        press[L] = closed[L] & closed[L - 1] & press[L - 1]
        node_closed = closed & press
        node_free = closed & ~press
        sub_free = (gs <= tol) & ~hit
        zero = np.zeros(L * c)
        bounds = {
            "q": self._q_bounds(q0),
            "nu": (zero, np.where((node_closed | node_free)[:L].reshape(-1), np.inf, 0.0)),
            "mu": (zero, np.where((hit | sub_free).reshape(-1), np.inf, 0.0)),
            "s_plus": (zero, zero), "s_minus": (zero, zero),
            "node_gap": (zero, np.where(node_closed[1:].reshape(-1), 0.0, np.inf)),
            "sub_gap": (zero, np.where(hit.reshape(-1), 0.0, np.inf)),
        }
        K2 = self.k2
        k1 = np.setdiff1d(np.arange(L), np.union1d(K2, self.k_next))
        on = bounced[k1].reshape(-1)
        bounds["impact_law"] = (np.where(on, 0.0, -np.inf), np.where(on, 0.0, np.inf))
        if K2.size:
            m2 = K2.size
            MU2 = np.asarray(guess["mu2"], float).reshape(m2, c)
            hit2 = MU2 > 0.0
            b2 = hit2 & ~closed[K2 + 1]
            z2 = np.zeros(m2 * c)
            bounds.update({"mu2": (z2, np.where(hit2.reshape(-1), np.inf, 0.0)), "s_plus2": (z2, z2),
                           "s_minus2": (z2, z2), "sub_gap2": (z2, np.where(hit2.reshape(-1), 0.0, np.inf))})
            on1, on2 = bounced[K2].reshape(-1), b2.reshape(-1)
            bounds["impact_law_first"] = (np.where(on1, 0.0, -np.inf), np.where(on1, 0.0, np.inf))
            bounds["impact_law_second"] = (np.where(on2, 0.0, -np.inf), np.where(on2, 0.0, np.inf))
        init = self._start(q0, p0, guess)
        opts = {**CONTACT_IPOPT, **BRANCH_IPOPT, **(options or {})}
        opts["max_iter"] = min(int(opts["max_iter"]), BRANCH_IPOPT["max_iter"])
        before = self.nlp._solver
        steps: List[HomotopyStep] = []
        res, build = None, 0.0
        # the undecided pairs (if any) by the penalty ladder, warm-started; decided ones are exact
        for rho in PENALTY:
            self.nlp.set_parameter("rho", rho)
            res = self.nlp.solve(init=init if res is None else None, warm=res, options=opts, verbose=verbose,
                                 bounds=bounds)
            if self.nlp._solver is not before and build == 0.0:
                build = res.build_time_s
            resid = self.residual(res.values)
            steps.append(HomotopyStep(rho, res.solver_status, res.iterations, res.solve_time_s, resid,
                                      parameter="branch"))
            if not res.success or resid <= COMPLEMENTARITY_TOL or not (np.any(node_free) or np.any(sub_free)):
                break
        res.build_time_s = build
        res.iterations = sum(st.iterations for st in steps)
        res.solve_time_s = sum(st.solve_time_s for st in steps)
        res.homotopy = steps
        res.complementarity_residual = resid = steps[-1].complementarity_residual
        if res.success and resid > COMPLEMENTARITY_TOL:
            res.fail("Complementarity_Not_Reached",
                     f"the branch converged but the complementarity residual {resid:.2e} exceeds {COMPLEMENTARITY_TOL:g}")
        return res

    def _q_bounds(self, q0):
        n = self.cm.n
        qlo = np.full((self.L + 1, n), -np.inf)
        qhi = np.full((self.L + 1, n), np.inf)
        qlo[0] = qhi[0] = q0
        return qlo.reshape(-1), qhi.reshape(-1)

    def _start(self, q0, p0, guess):
        """Set ``p0`` and the law lengths from ``guess``; the initial point by name."""
        n, c = self.cm.n, self.cm.c
        self.nlp.set_parameter("p0", p0)
        self._law_length = self.law_lengths(guess)
        self.nlp.set_parameter("law_length", self._law_length.reshape(-1))
        init = {k: np.asarray(v, float).reshape(-1).copy() for k, v in guess.items()
                if k in self.nlp.variable_names}
        init["q"][:n] = q0
        if "s_plus" not in init:
            init["s_plus"] = np.zeros(self.L * c)
            init["s_minus"] = np.zeros(self.L * c)
        if self.k2.size:
            self._law_length2 = self.law_lengths2(guess)
            self.nlp.set_parameter("law_length2", self._law_length2.reshape(-1))
            if "s_plus2" not in init:
                init["s_plus2"] = np.zeros(self.k2.size * c)
                init["s_minus2"] = np.zeros(self.k2.size * c)
        return init

    def row_violation(self, p0, values) -> float:
        """Largest scaled violation of this NLP's rows at ``values`` (all of its variables, e.g.
        assembled from horizon windows): the momentum rows (``initial``, ``node``, ``sub``, ...)
        relative to the force scale ``p_ref/h``, the gap rows relative to ``ℓ``, the law rows
        (already scaled) as they are, and the bounds relative to ``ℓ``."""
        nlp = self.nlp
        nlp.set_parameter("p0", p0)
        x = np.concatenate([np.asarray(values[b.name], float).reshape(-1) for b in nlp._vars])
        p = np.concatenate([b.init for b in nlp._params])
        g = np.asarray(nlp.functions()["jac_g"](x, p)[0]).reshape(-1)
        lbg, ubg = np.concatenate(nlp._glb), np.concatenate(nlp._gub)
        worst = 0.0
        for name, con in nlp._cons.items():
            sl = con.slice
            v = np.maximum(lbg[sl] - g[sl], 0.0) + np.maximum(g[sl] - ubg[sl], 0.0)
            if not v.size:
                continue
            if "gap" in name or name == "sub_order":
                v = v / self.scales_ell
            elif not name.startswith("impact_law"):
                v = v / (self.scales_p / self.scales_ell / self.h)
            worst = max(worst, float(np.max(v)))
        lbx = np.concatenate([b.lb for b in nlp._vars])
        ubx = np.concatenate([b.ub for b in nlp._vars])
        bnd = np.maximum(lbx - x, 0.0) + np.maximum(x - ubx, 0.0)
        return max(worst, float(np.max(bnd)) / self.scales_ell)



# ----------------------------------------------------------------------------- event-located guess
def _bisect_crossing(cm: ContactMechanics, q, v, tau_hi, active):
    """Earliest time in (0, tau_hi] at which an active gap reaches zero (bisection on the RK4 flow)."""
    lo, hi = 0.0, tau_hi
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        _, _, ph = cm.flow(q, v, mid)
        if np.min(np.asarray(ph).reshape(-1)[active]) < 0.0:
            hi = mid
        else:
            lo = mid
        if hi - lo < 1e-14 * max(tau_hi, 1.0):
            break
    return hi


def _hold(cm: ContactMechanics, q, v, active, iterations: int = 4):
    """Project ``(q, v)`` onto the held contacts: ``φ_j(q) = 0`` (Newton, M-metric) and ``J_j v = 0``."""
    M = np.asarray(cm.system.mass_matrix(q))
    for _ in range(iterations):
        phi, J = (np.asarray(x) for x in cm.system.gap(q))
        phi, J = phi.reshape(-1)[active], J[active]
        MiJt = np.linalg.solve(M, J.T)
        q = q - MiJt @ np.linalg.lstsq(J @ MiJt, phi, rcond=None)[0]
    J = np.asarray(cm.system.gap(q)[1])[active]
    MiJt = np.linalg.solve(M, J.T)
    v = v - MiJt @ np.linalg.lstsq(J @ MiJt, J @ v, rcond=None)[0]
    return q, v


def _held_step(cm: ContactMechanics, q, p, active, h, v, iterations: int = 8):
    """One step of the discrete motion with the ``active`` contacts held closed (``ContactMechanics.held_step``,
    Newton from the free flight): ``(q̃, q_{k+1}, ν, μ, p_{k+1}⁻)``, or ``None`` if Newton does not converge
    or a held contact would pull (``ν`` or ``μ`` < 0: it is released, the caller flies freely)."""
    n, c = cm.n, cm.c
    mask = active.astype(float)
    x = np.concatenate([q + 0.5 * h * v, q + h * v, np.zeros(c), np.zeros(c)])
    scale = 1.0 + float(np.max(np.abs(p)))
    for _ in range(iterations):
        r, Jr = cm.held_step(x, q, p, mask, h)
        r = np.asarray(r).reshape(-1)
        try:
            dx = np.linalg.solve(np.asarray(Jr), -r)
        except np.linalg.LinAlgError:
            return None
        x = x + dx
        if np.max(np.abs(dx)) <= 1e-12 * (1.0 + float(np.max(np.abs(x)))):
            break
    r = np.asarray(cm.held_step(x, q, p, mask, h)[0]).reshape(-1)
    if not np.all(np.isfinite(x)) or np.max(np.abs(r)) > 1e-9 * scale / h:
        return None
    qs, qn, nu, mu = x[:n], x[n:2 * n], x[2 * n:2 * n + c], x[2 * n + c:]
    if np.any(nu[active] < 0) or np.any(mu[active] < 0):
        return None
    p_next = np.asarray(cm.p_node_minus(qs, 0.0, qn, h)).reshape(-1)
    return qs, qn, nu, np.where(active, mu, 0.0), p_next


def event_guess(cm: ContactMechanics, q0: np.ndarray, v0: np.ndarray, L: int, h: float,
                length: float, v_zeno: float, two_impacts: bool = True) -> Dict[str, np.ndarray]:
    """Guess for ``L`` steps from ``(q0, v0)``: RK4 flight with located impacts (see module docstring).

    With ``two_impacts``, the rest of a bounce step is searched for a second crossing, which gets
    a second impact (restitution e) in that step: the steps ``k2`` with their second sub-node
    ``qs2``, ``beta2``, ``mu2``, ``bounced2`` (rows over ``k2``).  A third crossing in the same
    step is not looked for (the flight continues through it).
    """
    n, c, e = cm.n, cm.c, cm.e
    p0 = np.asarray(cm.system.mass_matrix(q0)) @ np.asarray(v0, float)
    Mf, gapf = cm.system.mass_matrix, cm.system.gap
    Q = np.zeros((L + 1, n))
    S = np.zeros((L, n))
    B = np.zeros(L)
    MU = np.zeros((L, c))
    event = np.zeros(L, dtype=bool)
    BOUNCED = np.zeros((L, c), dtype=bool)      # impacts resolved with restitution (not caught, not resting)
    second: Dict[int, tuple] = {}               # step -> (β₂, x₂, μ₂ row, bounced₂ row)
    q, v = np.asarray(q0, float).copy(), np.asarray(v0, float).copy()
    Q[0] = q
    # contacts held closed (caught, or resting from the start): the guess then flies constrained
    # to φ_j = 0 for them (plastic), sliding freely along the ground, until the free flight would
    # lift one off
    active = np.zeros(c, dtype=bool)
    tol = TOUCH_TOL * length
    k = 0
    p_held = None  # discrete momentum at the node, while the guess marches the held contacts
    while k < L:
        if np.any(active):
            pk = p_held if p_held is not None else np.asarray(Mf(q)) @ v
            step = _held_step(cm, q, pk, active, h, v)
            if step is not None:
                phn = np.asarray(gapf(step[1])[0]).reshape(-1)
                closing = ~active & (phn < -tol)
                if np.any(closing):
                    # another contact closes during the held step: caught too, held from the step's middle
                    step = _held_step(cm, q, pk, active | closing, h, v)
                    if step is not None:
                        phn = np.asarray(gapf(step[1])[0]).reshape(-1)
                        active = active | closing
            if step is not None:
                qs_k, qn, nu_k, mu_k, p_next = step
                if np.all(phn[~active] >= -tol):
                    # the discrete motion with the held contacts (it keeps pressing on them)
                    S[k], B[k], event[k] = qs_k, 0.0, True
                    MU[k] = mu_k
                    q, p_held = qn, p_next
                    v = np.linalg.solve(np.asarray(Mf(q)), p_next)
                    Q[k + 1] = q
                    k += 1
                    continue
            p_held = None
            qn, vn, ph = (np.asarray(x).reshape(-1) for x in cm.flow(q, v, h))
            active &= ~(ph > tol)                        # the free flight lifts it off: released
            closing = ~active & (ph < -tol)              # crossings while held: caught too (a guess)
            if np.any(closing):
                active |= closing
                S[k] = 0.5 * (q + qn)
                B[k] = 0.0
                event[k] = True
                Jc = np.asarray(gapf(S[k])[1])[closing]
                vc = 0.5 * (v + vn)
                MU[k, closing] = simultaneous_impact(np.asarray(Mf(S[k])), Jc, vc, 0.0)[0]
            if np.any(active):
                qn, vn = _hold(cm, qn, vn, active)
            q, v = qn, vn
            Q[k + 1] = q
            k += 1
            continue
        phi0, J0 = (np.asarray(x) for x in gapf(q))
        phi0 = phi0.reshape(-1)
        touching = phi0 <= tol
        if not np.any(touching):
            # fast path: free flight over a chunk of steps (one mapaccum call) up to the first crossing
            K = min(GUESS_CHUNK, L - k)
            Qc, Vc, Pc = (np.asarray(x) for x in cm.flights(K)(q, v, h))
            bad = np.where(np.any(Pc < -tol, axis=0))[0]
            i = int(bad[0]) if bad.size else K
            if i:
                Q[k + 1:k + i + 1] = Qc[:, :i].T
                q, v = Qc[:, i - 1].copy(), Vc[:, i - 1].copy()
                k += i
                continue
        else:
            vn0 = J0[touching] @ v
            an0 = np.asarray(cm.acc_normal(q, v)).reshape(-1)[touching]
            if np.all(vn0 <= tol / h) and np.any(an0 < 0) and \
                    np.max(np.abs(J0 @ v)) <= REST_SPEED_STEPS * float(np.max(-an0)) * h:
                # in contact, not separating, pressed on and no fast normal motion anywhere
                # on the body: the guess holds the touching contacts from here
                active = touching.copy()
                q, v = _hold(cm, q, v, active)
                continue
        qn, vn, ph = (np.asarray(x).reshape(-1) for x in cm.flow(q, v, h))
        # contacts that start touching and separate are not crossings
        crossing = ~((phi0 <= tol) & (ph >= -tol))
        if np.any(ph[crossing] < -tol):
            # the sub-node's time fraction is bounded: an earlier or later crossing is placed at the bound
            tc = min(max(_bisect_crossing(cm, q, v, h, crossing), ALPHA_MIN * h), (1 - ALPHA_MIN) * h)
            qc, vc, phc = (np.asarray(x).reshape(-1) for x in cm.flow(q, v, tc))
            j = int(np.argmin(np.where(crossing, phc, np.inf)))
            Jall = np.asarray(gapf(qc)[1])
            Jc = Jall[j]
            Mc = np.asarray(Mf(qc))
            event[k] = True
            B[k] = tc / h - 0.5
            S[k] = qc
            an = float(np.asarray(cm.acc_normal(qc, vc)).reshape(-1)[j])
            slow = an < 0 and -float(Jc @ vc) <= v_zeno and np.max(np.abs(Jall @ vc)) <= 2 * v_zeno
            if not slow and e < 1.0:
                # a rocking accumulation: the bounce would barely lift the contact (below v_z h) before
                # another contact closes within LOOKAHEAD_CATCH steps
                bounce = impact_law(Mc, Jc, vc, e)
                _, _, Pf = (np.asarray(x) for x in cm.flights(LOOKAHEAD_CATCH)(qc, bounce.v_after, h))
                others = np.arange(c) != j
                slow = bool(np.any(Pf[others] < -tol)) and float(np.max(Pf[j])) <= v_zeno * h
            if slow:
                # Zeno accumulation: a slow arrival (below v_zeno, where the NLP may waive the
                # impact law, see ContactNLP) while every contact of the body moves slowly along
                # the normal (sliding along the ground does not count).  It is caught, together
                # with every contact within a slow step's travel: held closed from here on.
                near = crossing & (phc <= phc[j] + v_zeno * h)
                mus, v_after = simultaneous_impact(Mc, Jall[near], vc, 0.0)
                MU[k, near] = mus
                active = near.copy()
                qn, vn, _ = (np.asarray(x).reshape(-1) for x in cm.flow(qc, v_after, h - tc))
                qn, vn = _hold(cm, qn, vn, active)
                q, v = qn, vn
                Q[k + 1] = q
                k += 1
                continue
            imp = impact_law(Mc, Jc, vc, e)
            MU[k, j] = imp.mu
            BOUNCED[k, j] = True
            together = np.where(crossing & (phc <= phc[j] + SIMULTANEOUS_TOL * length))[0]
            if together.size > 1:
                # contacts that close together (a flat landing): one simultaneous impact
                mus, v_after = simultaneous_impact(Mc, Jall[together], vc, e)
                MU[k, together] = mus
                BOUNCED[k, together] = mus > 0
                imp.v_after = v_after
            qn, vn, ph = (np.asarray(x).reshape(-1) for x in cm.flow(qc, imp.v_after, h - tc))
            # a second crossing in the rest of the step (another contact, or the same one again)
            crossing2 = ~((phc <= tol) & (ph >= -tol))
            if two_impacts and tc < (1 - 2 * ALPHA_MIN) * h and np.any(ph[crossing2] < -tol):
                tc2 = tc + _bisect_crossing(cm, qc, imp.v_after, h - tc, crossing2)
                tc2 = min(max(tc2, tc + ALPHA_MIN * h), (1 - ALPHA_MIN) * h)
                qc2, vc2, phc2 = (np.asarray(x).reshape(-1) for x in cm.flow(qc, imp.v_after, tc2 - tc))
                j2 = int(np.argmin(np.where(crossing2, phc2, np.inf)))
                Jall2 = np.asarray(gapf(qc2)[1])
                Mc2 = np.asarray(Mf(qc2))
                imp2 = impact_law(Mc2, Jall2[j2], vc2, e)
                mu2, b2 = np.zeros(c), np.zeros(c, dtype=bool)
                mu2[j2], b2[j2] = imp2.mu, True
                together = np.where(crossing2 & (phc2 <= phc2[j2] + SIMULTANEOUS_TOL * length))[0]
                if together.size > 1:
                    mus, v_after = simultaneous_impact(Mc2, Jall2[together], vc2, e)
                    mu2[together] = mus
                    b2[together] = mus > 0
                    imp2.v_after = v_after
                second[k] = (tc2 / h - 0.5, qc2, mu2, b2)
                qn, vn, _ = (np.asarray(x).reshape(-1) for x in cm.flow(qc2, imp2.v_after, h - tc2))
        q, v = qn, vn
        Q[k + 1] = q
        k += 1
    # free sub-nodes (α = ½) from the nodes: a few Newton steps, all steps at once
    free = ~event
    if np.any(free):
        kk = np.where(free)[0]
        F = cm.free_sub.map(kk.size)
        Z = 0.5 * (Q[kk] + Q[kk + 1])
        for _ in range(4):
            r, Jr = F(Q[kk].T, Z.T, Q[kk + 1].T, h)
            r = np.asarray(r).T
            Jr = np.asarray(Jr).reshape(n, kk.size, n).transpose(1, 0, 2)
            Z = Z - np.linalg.solve(Jr, r[..., None])[..., 0]
        S[kk] = Z
    gq = np.asarray(gapf.map(L + 1)(Q.T)[0]).reshape(c, L + 1).T
    # steps that start and end on the ground (a resting body): the sub-node rests too, carrying its
    # share of the weight (least squares on the sub-node equation, clipped at 0), rather than
    # hopping to the apex of a free midpoint flight: both are exact discrete solutions, and this
    # one has no motion at all between the nodes (docs/derivations.md, "Contact trajectories", §2, "A resting ball")
    for k in np.where(~event & (np.min(gq[:-1], axis=1) <= tol) & (np.min(gq[1:], axis=1) <= tol))[0]:
        S[k] = 0.5 * (Q[k] + Q[k + 1])
        r = np.asarray(cm.sub(Q[k], S[k], Q[k + 1], B[k], np.zeros(c), h)).reshape(-1) * h
        Js = np.asarray(gapf(S[k])[1])
        act = np.asarray(gapf(S[k])[0]).reshape(-1) <= tol
        if np.any(act):
            MU[k, act] = np.maximum(np.linalg.lstsq(Js[act].T, -r, rcond=None)[0], 0.0)
    # node forces where the guess touches: least squares on the node equations, clipped at 0
    NU = np.zeros((L, c))
    gq = gq[:L]
    touching = np.where(np.min(gq, axis=1) <= tol)[0]
    for k in touching:
        if k == 0:
            r = np.asarray(cm.initial(Q[0], S[0], B[0], p0, np.zeros(c), h)).reshape(-1)
        else:
            sp, bp = (second[k - 1][1], second[k - 1][0]) if k - 1 in second else (S[k - 1], B[k - 1])
            r = np.asarray(cm.node(sp, bp, Q[k], S[k], B[k], np.zeros(c), h)).reshape(-1)
        J = np.asarray(gapf(Q[k])[1])
        act = gq[k] <= tol
        sol = np.linalg.lstsq(J[act].T, -r, rcond=None)[0]
        NU[k, act] = np.maximum(sol, 0.0)
    out = {"q": Q.reshape(-1), "qs": S.reshape(-1), "beta": B, "mu": MU.reshape(-1), "nu": NU.reshape(-1),
           "bounced": BOUNCED}
    if second:
        k2 = np.array(sorted(second), dtype=np.int64)
        out.update(k2=k2, beta2=np.array([second[k][0] for k in k2]),
                   qs2=np.array([second[k][1] for k in k2]).reshape(-1),
                   mu2=np.array([second[k][2] for k in k2]).reshape(-1),
                   bounced2=np.array([second[k][3] for k in k2]))
    return out


# ----------------------------------------------------------------------------- driver
def _length_scale(system: LagrangianSystem, q0) -> float:
    """A length for gap tolerances and penalty scales: ``max(1, max |q0|)``."""
    return max(1.0, float(np.max(np.abs(q0))) if np.size(q0) else 1.0)


def _scales(system: LagrangianSystem, q0, qd0, length: float):
    """(length, momentum, velocity, acceleration) scales of the scene for the penalty terms."""
    acc = float(np.max(np.abs(np.asarray(system.acceleration(q0, qd0))))) if system.nq else 0.0
    vref = max(float(np.max(np.abs(qd0))), math.sqrt(acc * length), 1e-8)
    mref = float(np.max(np.diag(np.asarray(system.mass_matrix(q0)))))
    return length, mref * vref, vref, acc


def solve_contact(system: LagrangianSystem, q0, qd0, T: float, N: int, scheme: str = "midpoint",
                  options: Optional[dict] = None, verbose: bool = False,
                  penalties: Optional[List[float]] = None) -> ContactTrajectory:
    """Initial-value contact trajectory over ``[0, T]`` on ``N`` steps (strategy in the module docstring)."""
    cm = ContactMechanics(system, scheme)
    q0, qd0 = np.asarray(q0, float), np.asarray(qd0, float)
    phi0 = np.asarray(system.gap(q0)[0]).reshape(-1)
    length = _length_scale(system, q0)
    if np.any(phi0 < -TOUCH_TOL * length):
        j = int(np.argmin(phi0))
        raise InputError(f"the body starts inside the ground: gap of {system.contact.names[j]} is {phi0[j]:.3g}")
    h = T / N
    p0 = np.asarray(system.momentum(q0, qd0)).reshape(-1)
    scales = _scales(system, q0, qd0, length)
    attempts: List[dict] = []
    t_guess = time.perf_counter()
    guess = event_guess(cm, q0, qd0, N + LOOKAHEAD, h, length, _v_zeno(cm, h, scales))
    guess_time = time.perf_counter() - t_guess
    # a second sub-node only in the steps where the guess has two impacts (none: the one-sub-node NLP)
    whole = ContactNLP(cm, N + LOOKAHEAD, h, scales, k2=guess.get("k2"))
    # the branch of the complementarity problem that the guess identifies, then the penalty continuation
    res = whole.solve_branch(q0, p0, guess, options, verbose)
    attempts.append(_attempt("branch", res))
    if not res.success:
        res = whole.solve(q0, p0, guess, penalties, options, verbose)
        attempts.append(_attempt("whole", res))
    held = np.zeros((whole.L, cm.c), dtype=bool)
    for _ in range(HELD_ROUNDS if not res.success else 0):
        # the law used as a loophole at the last point Ipopt solved (ContactNLP.loopholes): there
        # the law is weighted by φ(q_{k+2})/ℓ as well, a catch must hold; the whole solve again
        # from the guess (docs/derivations.md, "Contact trajectories", §4, "Catches that hold")
        if whole.last_good is None:
            break
        new = whole.loopholes(whole.last_good[1].values) & ~held
        if not np.any(new):
            break
        held |= new
        whole = ContactNLP(cm, N + LOOKAHEAD, h, scales, k2=guess.get("k2"), held=held)
        res = whole.solve(q0, p0, guess, penalties, options, verbose)
        attempts.append(_attempt("whole-held", res))
        if res.success:
            break
    if not res.success:
        cur = _windows(cm, q0, p0, N, h, length, scales, penalties, options, verbose, attempts)
        if cur is not None:
            # the windows have one sub-node per step: the second sub-nodes start from the guess
            cur.update({key: guess[key] for key in ("k2", "qs2", "beta2", "mu2", "bounced2") if key in guess})
            res = whole.solve_branch(q0, p0, cur, options, verbose)
            attempts.append(_attempt("branch-after-windows", res))
            if not res.success:
                res = whole.solve(q0, p0, cur, penalties, options, verbose)
                attempts.append(_attempt("whole-after-windows", res))
            if not res.success:
                res = _assembled(whole, p0, cur, res)
    return _finish(cm, whole, res, N, h, attempts, guess_time, p0)


#: Largest scaled row violation (ContactNLP.row_violation) of a point assembled from horizon windows
#: that is reported in place of a failed whole solve.
ASSEMBLED_ROW_TOL = 1e-9


def _assembled(whole: ContactNLP, p0, cur: dict, res: NLPResult) -> NLPResult:
    """The point assembled from horizon windows that all converged, as the answer, if it satisfies the
    whole NLP to tolerance (scaled rows within :data:`ASSEMBLED_ROW_TOL`, the complementarity residual
    with the whole NLP's law lengths within :data:`COMPLEMENTARITY_TOL`) where the whole solve from it
    did not converge; ``res`` (that failed solve) otherwise.  Reported with the status
    ``Assembled_From_Windows``."""
    # the law slacks of second sub-nodes are not part of the windows' point: zero (the check then sees the law)
    values = {b.name: (np.asarray(cur[b.name], float).reshape(-1) if b.name in cur else
                       np.zeros(b.init.size) if b.name.startswith("s_") else None) for b in whole.nlp._vars}
    if any(v is None for v in values.values()):
        return res
    whole._law_length = whole.law_lengths(cur)
    if whole.k2.size:
        whole._law_length2 = whole.law_lengths2(cur)
    rows, resid = whole.row_violation(p0, values), whole.residual(values)
    if rows > ASSEMBLED_ROW_TOL or resid > COMPLEMENTARITY_TOL:
        return res
    return NLPResult(values=values, multipliers={}, bound_multipliers={}, objective=float("nan"),
                     solver_status="Assembled_From_Windows", success=True,
                     message=(f"every horizon window converged; their assembled trajectory satisfies the whole NLP "
                           f"(rows to {rows:.1e}, complementarity residual {resid:.1e}), where the whole solve "
                           f"from it stopped with {res.solver_status} (residual {res.complementarity_residual:.2e})"),
                     iterations=0, build_time_s=0.0, solve_time_s=0.0, complementarity_residual=resid,
                     homotopy=list(res.homotopy))


def _attempt(stage: str, res: NLPResult) -> dict:
    return {"stage": stage, "status": res.solver_status, "iterations": res.iterations,
            "build_time_s": res.build_time_s, "solve_time_s": res.solve_time_s,
            "complementarity_residual": res.complementarity_residual,
            "penalty_steps": len(res.homotopy)}


#: Rounds of re-solves with the catches that do not hold weighted by the gap after next.
HELD_ROUNDS = 3

#: Shortest horizon window tried before giving up.
MIN_WINDOW = 8
#: Iteration budget of one window, and of all windows together (a failure must not take minutes).
WINDOW_MAX_ITER = 80
WINDOWS_MAX_ITER_TOTAL = 2000


def _windows(cm, q0, p0, N, h, length, scales, penalties, options, verbose, attempts):
    """Horizon windows: contact NLPs of L steps marched over the horizon, each from its own event guess."""
    n, c = cm.n, cm.c
    Mf = cm.system.mass_matrix
    # windows of L reported steps, each solved with its look-ahead; the last window's look-ahead is kept
    # (the whole solve after the windows has N + LOOKAHEAD steps)
    NL = N + LOOKAHEAD
    out = {"q": np.zeros((NL + 1, n)), "qs": np.zeros((NL, n)), "beta": np.zeros(NL),
           "mu": np.zeros((NL, c)), "nu": np.zeros((NL, c)), "s_plus": np.zeros((NL, c)), "s_minus": np.zeros((NL, c))}
    out["q"][0] = q0
    cache: Dict[int, ContactNLP] = {}
    K, L = 0, 1 << max(3, int(math.log2(max(8, N // 8))))
    qK, pK = np.asarray(q0, float), np.asarray(p0, float)
    while K < N:
        L = min(L, N - K)
        if L not in cache:
            cache[L] = ContactNLP(cm, L + LOOKAHEAD, h, scales)
        w = cache[L]
        vK = np.linalg.solve(np.asarray(Mf(qK)), pK)
        wguess = event_guess(cm, qK, vK, L + LOOKAHEAD, h, length, w.v_zeno, two_impacts=False)
        wopts = dict(options or {}, max_iter=min(WINDOW_MAX_ITER, int((options or {}).get("max_iter", WINDOW_MAX_ITER))))
        r = w.solve_branch(qK, pK, wguess, wopts, verbose)
        attempts.append(_attempt(f"window {K}:{K + L} branch", r))
        if not r.success:
            r = w.solve(qK, pK, wguess, penalties, wopts, verbose)
            attempts.append(_attempt(f"window {K}:{K + L}", r))
        if sum(a["iterations"] for a in attempts if a["stage"].startswith("window")) > WINDOWS_MAX_ITER_TOTAL:
            return None
        if r.success:
            keep = L + LOOKAHEAD if K + L == N else L
            for key, arr in out.items():
                if key == "q":
                    arr[K + 1:K + keep + 1] = r.values["q"].reshape(L + LOOKAHEAD + 1, n)[1:keep + 1]
                else:
                    arr[K:K + keep] = r.values[key].reshape((L + LOOKAHEAD,) + arr.shape[1:])[:keep]
            qK = out["q"][K + L]
            pK = np.asarray(cm.p_node_minus(out["qs"][K + L - 1], out["beta"][K + L - 1], qK, h)).reshape(-1)
            K, L = K + L, 2 * L
        else:
            if L <= MIN_WINDOW:
                return None
            L //= 2
    return {k: v.reshape(-1) for k, v in out.items()}


def _finish(cm: ContactMechanics, tn: ContactNLP, res: NLPResult, N: int, h: float, attempts,
            guess_time: float, p0: np.ndarray) -> ContactTrajectory:
    n, c, sysm = cm.n, cm.c, cm.system
    # the reported horizon: the first N steps (the look-ahead steps are not part of the answer)
    q = res.values["q"][:(N + 1) * n].reshape(N + 1, n)
    S = res.values["qs"][:N * n].reshape(N, n)
    B = res.values["beta"][:N].reshape(N)
    MU = res.values["mu"][:N * c].reshape(N, c)
    hv = np.array([h])
    # Node momenta: a node force h ν_k makes the one-sided momenta differ, p_k⁺ = p_k⁻ + h ∇φ(q_k)ᵀ ν_k;
    # the node's momentum is their mean where the contact is closed (for a body resting on the
    # ground p_k⁻ = −p_k⁺, so it is 0, not ±m g h/4).  Without a node force p_k⁻ = p_k⁺ (DEL).  At t = 0 the given p_0; at T the
    # look-ahead step supplies ν_N.
    NL = N + LOOKAHEAD
    nu_full = h * res.values["nu"][:NL * c].reshape(NL, c)
    Jn = np.asarray(sysm.gap.map(N + 1)(q.T)[1])                    # (c, (N + 1) n)
    Jn = Jn.reshape(c, N + 1, n).transpose(1, 0, 2)                  # (N + 1, c, n)
    # only closed contacts (gap within TOUCH_TOL): on an open one ν is interior-point noise below the
    # complementarity tolerance, left on p⁺ as before
    closed = np.asarray(sysm.gap.map(N + 1)(q.T)[0]).reshape(c, N + 1).T <= TOUCH_TOL * tn.scales_ell
    half = 0.5 * np.einsum("kcn,kc->kn", Jn, np.where(closed, nu_full[:N + 1], 0.0))
    # second sub-nodes (steps tn.k2; only those of the reported horizon are reported)
    K2 = tn.k2
    m2 = K2.size
    if m2:
        S2a, B2a, MU2a = (res.values["qs2"].reshape(m2, n), res.values["beta2"].reshape(m2),
                          res.values["mu2"].reshape(m2, c))
    else:
        S2a, B2a, MU2a = np.zeros((0, n)), np.zeros(0), np.zeros((0, c))
    rep2 = K2 < N
    last = {int(k): i for i, k in enumerate(K2)}
    pp = np.asarray(cm.p_node_plus.map(N)(q[:-1].T, S.T, B, hv)).T
    if N - 1 in last:
        pN = np.asarray(cm.p_node_minus(S2a[last[N - 1]], B2a[last[N - 1]], q[-1], h)).reshape(1, -1)
    else:
        pN = np.asarray(cm.p_node_minus(S[-1], B[-1], q[-1], h)).reshape(1, -1)
    p = np.vstack([pp - half[:N], pN + half[N:]])
    p[0] = p0
    M = np.asarray(sysm.mass_matrix.map(N + 1)(q.T)).reshape(n, N + 1, n).transpose(1, 0, 2)
    v = np.linalg.solve(M, p[..., None])[..., 0]
    energy = sysm.energies(q, v)
    gap = np.asarray(sysm.gap.map(N + 1)(q.T)[0]).reshape(c, N + 1).T
    gap_sub = np.asarray(sysm.gap.map(N)(S.T)[0]).reshape(c, N).T
    t = np.linspace(0.0, N * h, N + 1)
    t_sub = t[:-1] + (0.5 + B) * h
    # Impacts: sub-node impulses of a contact that approaches faster than a step's worth of its
    # normal acceleration (slower "impacts" are the discrete form of persistent contact).
    # caught: closed again at the next two nodes (the look-ahead step supplies node N + 1)
    q_full = res.values["q"].reshape(-1, n)[:N + 2]
    gap_full = np.asarray(sysm.gap.map(N + 2)(q_full.T)[0]).reshape(c, N + 2).T
    impacts = []
    cands = [(int(k), 0, int(j)) for k, j in zip(*np.where(MU > IMPULSE_TOL * tn.scales_p / tn.scales_ell))]
    cands += [(int(K2[i]), 1, int(j)) for i, j in zip(*np.where(MU2a > IMPULSE_TOL * tn.scales_p / tn.scales_ell))
              if K2[i] < N]
    for k, sub, j in sorted(cands):
        if sub == 0 and k in last:          # first of two sub-nodes: its next point is the second
            i = last[k]
            x, tk, muk = S[k], float(t_sub[k]), float(MU[k, j])
            pm = np.asarray(cm.p_minus(q[k], S[k], B[k], h)).reshape(-1)
            pl = np.asarray(cm.p_plus_g(S[k], S2a[i], B[k], B2a[i], h)).reshape(-1)
        elif sub == 1:
            i = last[k]
            x, tk, muk = S2a[i], float(t[k] + (0.5 + B2a[i]) * h), float(MU2a[i, j])
            pm = np.asarray(cm.p_minus_g(S[k], S2a[i], B[k], B2a[i], h)).reshape(-1)
            pl = np.asarray(cm.p_plus_g(S2a[i], q[k + 1], B2a[i], 0.5, h)).reshape(-1)
        else:
            x, tk, muk = S[k], float(t_sub[k]), float(MU[k, j])
            pm = np.asarray(cm.p_minus(q[k], S[k], B[k], h)).reshape(-1)
            pl = np.asarray(cm.p_plus(S[k], q[k + 1], B[k], h)).reshape(-1)
        Ms = np.asarray(sysm.mass_matrix(x))
        vb, va = np.linalg.solve(Ms, pm), np.linalg.solve(Ms, pl)
        Jj = np.asarray(sysm.gap(x)[1])[j]
        an = abs(float(np.asarray(cm.acc_normal(x, vb)).reshape(-1)[j]))
        if -float(Jj @ vb) > IMPACT_SPEED_STEPS * an * h:
            impacts.append(Impact(int(k), tk, int(j), muk, np.array(x, float).copy(), vb, va,
                                  caught=bool(max(gap_full[k + 1, j], gap_full[k + 2, j]) <= tn.open_gap),
                                  sub=sub))
    # Impulse per node: Λ_k = h ν_k + (1 − α_k) μ_k + α_{k−1} μ_{k−1}, each sub-node impulse shared
    # between its two nodes by linear (hat-function) interpolation of its time; node N takes the
    # look-ahead step's node force and sub-node share (its dual cell reaches past T).  For a body
    # resting on the ground Λ_k = m g h exactly whatever the sub-nodes do (derivation, "Resting
    # contact"); Λ_0 covers the half cell [0, h/2].
    alpha_full = 0.5 + res.values["beta"][:NL]
    mu_full = res.values["mu"][:NL * c].reshape(NL, c)
    lam = nu_full[:N + 1] + (1.0 - alpha_full[:N + 1, None]) * mu_full[:N + 1]
    lam[1:] += alpha_full[:N, None] * mu_full[:N]
    for i, k in enumerate(K2):
        # the second sub-node's impulse, shared by the hat weights of its time fraction α₂
        a2 = 0.5 + B2a[i]
        if k <= N:
            lam[k] += (1.0 - a2) * MU2a[i]
        if k + 1 <= N:
            lam[k + 1] += a2 * MU2a[i]
    nu = nu_full[:N + 1].copy()
    steps2 = K2[rep2]
    t_sub2 = t[steps2] + (0.5 + B2a[rep2]) * h
    gap_sub2 = (np.asarray(sysm.gap.map(int(rep2.sum()))(S2a[rep2].T)[0]).reshape(c, -1).T if rep2.any()
                else np.zeros((0, c)))
    total_iter = sum(a["iterations"] for a in attempts)
    return ContactTrajectory(
        t=t, q=q, p=p, v=v, energy=energy, t_sub=t_sub, q_sub=S, mu=MU, nu=nu, gap=gap, gap_sub=gap_sub,
        node_impulse=lam, impacts=impacts, complementarity_residual=float(res.complementarity_residual),
        status=res.status, success=res.success, message=res.message, solver_status=res.solver_status,
        iterations=int(total_iter),
        build_time_s=float(sum(a["build_time_s"] for a in attempts)),
        solve_time_s=float(guess_time + sum(a["solve_time_s"] for a in attempts)),
        scheme=cm.dm.scheme.name, homotopy=list(res.homotopy), attempts=attempts,
        steps_sub2=steps2, t_sub2=t_sub2, q_sub2=S2a[rep2], mu_sub2=MU2a[rep2], gap_sub2=gap_sub2)
