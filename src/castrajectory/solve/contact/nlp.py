"""The contact program handed to Ipopt: the branch the guess identifies, and the penalty ladder."""
from __future__ import annotations

from typing import Dict, List, Optional

import numpy as np

from ...result import HomotopyStep, NLPResult
from ...discretise.contact.elements import SPLIT_WEIGHT
from ...discretise.contact.transcription import (ALPHA_MIN, COMPLEMENTARITY_TOL, PENALTY, TOUCH_TOL,
                                                 ContactTranscription)
from ..nlp import NLP
from . import modes as M
from .options import ContactOptions




class ContactNLP(ContactTranscription):
    """The contact transcription written into an Ipopt :class:`~castrajectory.solve.nlp.NLP`, and its solve."""

    program = NLP
    #: the penalty ladder rises until the scaled complementarity residual is at most this (and fails above
    #: COMPLEMENTARITY_TOL after its last rung)
    complementarity_target = COMPLEMENTARITY_TOL
    #: the contact solve's settings (Ipopt's options, the branch's budget and pivot tolerance, the certificate's
    #: tolerance): the library's unless the solve sets its own
    settings = ContactOptions()

    def solve(self, q0, p0, guess: Dict[str, np.ndarray], penalties=None, options=None, verbose=False):
        """Solve from ``guess``, raising the penalty until complementarity holds.

        Returns the :class:`NLPResult` of the last penalty step (see :meth:`_ladder`).
        """
        opts = dict(self.settings.ipopt)
        opts.update(options or {})
        return self._ladder(self._start(q0, p0, guess), opts, {"q": self._q_bounds(q0)}, penalties or PENALTY,
                            verbose, "rho", "Ipopt")

    def solve_modes(self, q0, p0, point: Dict[str, np.ndarray], options=None, verbose=False,
                    certify_tol: Optional[float] = None, max_iter: Optional[int] = None) -> NLPResult:
        """Solve the branch of the discrete march's modes (``point["modes"]``, one letter per step and
        contact, :mod:`.march`): every pair decided, a square system whose solution ``point`` already is
        (to the march's Newton tolerance).  Held and caught contacts keep their gap rows as equalities
        (sub-node and next node), a timed impact its sub-node gap; free forces and impulses are those of
        the modes (the rest fixed at 0), ``β = 0`` in a step without a timed impact, and Newton's law is
        exact at every impact whose contact leaves.  Ipopt then only confirms the point and forms the
        multipliers."""
        bounds = self.mode_bounds(q0, point)
        init = self._start(q0, p0, point)
        opts = self._branch_options(options, max_iter)
        certify_tol = self.settings.certify_tol if certify_tol is None else certify_tol
        # every pair decided with exact zero products and every β fixed or timed: a square feasibility
        # problem, no penalty and no selection term (its point is then a KKT point with zero multipliers)
        self.nlp.set_parameter("rho", 0.0)
        self.set_split_weight(0.0)
        # a few evaluations only (Ipopt, if it runs, evaluates the VM's kernels): nothing to compile
        self.nlp.compile_elements = False
        self.nlp.build(opts, verbose)
        res = self.nlp.certify(init, certify_tol, bounds)
        if res.success:
            resid = self.residual(res.values)
            res.complementarity_residual = resid
            res.homotopy = [HomotopyStep(0.0, res.solver_status, 0, res.solve_time_s, resid, parameter="modes")]
            if resid <= COMPLEMENTARITY_TOL:
                return res
        try:
            return self._ladder(init, opts, bounds, [0.0], verbose, "modes", "the march's branch")
        finally:
            self.set_split_weight(SPLIT_WEIGHT)

    def mode_bounds(self, q0, point: Dict[str, np.ndarray]) -> Dict[str, tuple]:
        """The bounds that hold the program on the branch of the march's modes (:meth:`solve_modes`), and the
        parameters of that branch set (``release``, ``arrive``; ``law_exempt`` and ``turns`` for the residual and
        the answer)."""
        c, L = self.cm.c, self.L
        modes = np.asarray(point["modes"]).reshape(L, c)
        timed = np.isin(modes, M.TIMES_SUB)
        # the first timed contact of a step fixes its sub-node (simultaneous ones share it); a held contact whose slip
        # stops or turns there (W) times it by its slip (left_slip, below)
        first = timed & (np.cumsum(timed, axis=1) == 1)
        turns = modes == M.W
        # a release timed at its sub-node (E): its force there vanishes, with the contacts held through the first part;
        # a stick's end timed there (G): its friction force reaches the cone
        lifts, grips = modes == M.E, modes == M.G
        self.lifts = [(int(k), int(j)) for k, j in zip(*np.where(lifts))]
        self.grips = [(int(k), int(j)) for k, j in zip(*np.where(grips))]
        # (which slips stop or turn at a sub-node, for the answer: stop where the second part sticks)
        fm_all = np.asarray(point.get("fmodes", np.full((L, 2 * c), M.FREE)), dtype=object).reshape(L, 2 * c)
        self.turns = [(int(k), int(j), "stop" if fm_all[k, c + j] == M.STICK else "turn") for k, j in zip(*np.where(turns))]
        held = np.isin(modes, M.HELD)
        closes = np.isin(modes, M.CLOSES)
        law = (modes == M.I) & np.asarray(point["bounced"], bool).reshape(L, c)
        node = np.isin(modes, M.AT_NODE).reshape(-1)
        fixed = np.isin(modes, M.SEQUENTIAL).reshape(-1)
        # the first part's closing impulses μ⁻: a contact released at its step's impact (R with an impact at the
        # sub-node) takes its share of the first part's force there (free, its release row zero); a plastic arrival
        # with friction (K) Stronge's impulse, fixed at the march's (ContactMechanics.sub_row)
        release = (modes == M.R) & np.any(np.isin(modes, M.SUB_IMPACT), axis=1, keepdims=True) | turns | grips
        leftfix = modes == M.K
        self.release = release.astype(float)
        if np.any(lifts | grips) and not self.has_lifts:
            raise ValueError("the march timed a release or a stick's end (mode E, G) that this program has no rows for: "
                             "build it with lifts=True")
        self.hold(release=self.release)
        if self.has_lifts:
            fm = np.asarray(point.get("fmodes", np.full((L, 2 * c), M.FREE)), dtype=object).reshape(L, 2 * c)
            self.nlp.set_parameter("held", held.astype(float).reshape(-1))
            self.nlp.set_parameter("stuck", (fm[:, :c] == M.STICK).astype(float).reshape(-1))
            self.nlp.set_parameter("slide_sign", np.select([np.isin(fm[:, c:], M.SLIDING_UP), fm[:, c:] == M.DOWN],
                                                           [1.0, -1.0], 0.0).reshape(-1))
        self.law_exempt = np.isin(modes, M.LAW_FIXED)
        mul_march = np.asarray(point["mul"], float).reshape(-1)
        mu_march = np.asarray(point["mu"], float).reshape(-1)
        nu_march = np.asarray(point["nu"], float).reshape(-1)
        zero = np.zeros(L * c)
        untimed = ~np.any(timed | turns | lifts | grips, axis=1)
        blo = np.where(untimed, 0.0, ALPHA_MIN - 0.5)
        bhi = np.where(untimed, 0.0, 0.5 - ALPHA_MIN)
        bounds = {
            "q": self._q_bounds(q0),
            "beta": (blo, bhi),
            # an impact at a node (mode N): its force is the march's, which Newton's law at the node fixed
            "nu": (np.where(node, nu_march, 0.0), np.where(held.reshape(-1), np.inf, np.where(node, nu_march, 0.0))),
            # the sequential law's impulses (modes F and T) are the march's cascade
            "mu": (np.where(fixed, mu_march, 0.0),
                   np.where(np.isin(modes, M.FREE_IMPULSE).reshape(-1), np.inf, np.where(fixed, mu_march, 0.0))),
            "mul": (np.where(leftfix.reshape(-1), mul_march, 0.0),
                    np.where(release.reshape(-1), np.inf, np.where(leftfix.reshape(-1), mul_march, 0.0))),
            "release": (np.where(release.reshape(-1), 0.0, -np.inf), np.where(release.reshape(-1), 0.0, np.inf)),
            "s_plus": (zero, zero), "s_minus": (zero, zero),
            "node_gap": (zero, np.where(closes.reshape(-1), 0.0, np.inf)),
            "sub_gap": (zero, np.where((held | first).reshape(-1), 0.0, np.inf)),
            "impact_law": (np.where(law.reshape(-1), 0.0, -np.inf), np.where(law.reshape(-1), 0.0, np.inf)),
        }
        if self.has_lifts:
            on = np.concatenate([lifts, grips], axis=1).reshape(-1)
            bounds["timed_force"] = (np.where(on, 0.0, -np.inf), np.where(on, 0.0, np.inf))
        bounds.update(self._stage_bounds(held, closes))
        if self.cm.friction:
            bounds.update(self._friction_bounds(point, modes, release, leftfix, turns))
        return bounds

    def _stage_bounds(self, first, second) -> Dict[str, tuple]:
        """The stages' pairs of a decided branch: a contact held through a part (``first``, ``second``: per step and
        contact) has its gap closed at the part's stages and its force there free (≥ 0); elsewhere the force is 0
        and the stage's gap is not a row of the branch (the march checks the gaps at the nodes and sub-nodes)
        (:meth:`ContactMechanics.stage_holds`)."""
        cm = self.cm
        if not cm.sc:
            return {}
        st = cm.dm.scheme.stages
        # (per step: the first part's stages, each with its contacts, then the second's)
        hold = np.concatenate([np.tile(first, (1, st)), np.tile(second, (1, st))], axis=1).reshape(-1)
        return {"lam_cstage": (np.zeros(hold.size), np.where(hold, np.inf, 0.0)),
                "stage_gap": (np.full(hold.size, -np.inf), np.full(hold.size, np.inf)),
                "stage_hold": (np.where(hold, 0.0, -np.inf), np.where(hold, 0.0, np.inf))}

    def _friction_bounds(self, point, modes, release, leftfix, turns) -> Dict[str, tuple]:
        """The friction's part of :meth:`mode_bounds` (and its ``arrive`` parameter): each slot's ratio and slip by
        its friction mode, a released contact's share, and on a tangent plane the circular cone's rows."""
        c, L = self.cm.c, self.L
        bounds = {}
        # the friction's modes: sticking, the slip row vanishes (ρ within the cone); sliding, ρ = ∓μ_f and
        # the slip has the matching sign; no friction force, ρ = 0
        d = self.cm.fd
        fm = np.asarray(point["fmodes"]).reshape(L, 2 * c)
        muf = np.tile(np.concatenate([self.cm.mu_f, self.cm.mu_f]), L).reshape(L, 2 * c)
        # (an impact's ratio, mode X, is the frictional impact law's: fixed at the march's value)
        rx = np.asarray(point["fratio"], float).reshape(L, 2 * c, d)
        fmd, mud = np.repeat(fm[..., None], d, axis=2), np.repeat(muf[..., None], d, axis=2)
        rlo = np.select([fmd == M.STICK, fmd == M.UP, fmd == M.DOWN, fmd == M.FIX, fmd == M.SLIDE], [-mud, -mud, mud, rx, -mud], 0.0)
        rhi = np.select([fmd == M.STICK, fmd == M.UP, fmd == M.DOWN, fmd == M.FIX, fmd == M.SLIDE], [mud, -mud, mud, rx, mud], 0.0)
        slo = np.select([fmd == M.STICK, fmd == M.UP], [0.0, 0.0], -np.inf)
        shi = np.select([fmd == M.STICK, fmd == M.DOWN], [0.0, 0.0], np.inf)
        bounds["fratio"] = (rlo.reshape(-1), rhi.reshape(-1))
        # the contacts that arrive at their sub-node (an impact, caught or fixed by a law): slip after it
        self.arrive = M.slips_after(modes)
        self.hold(arrive=self.arrive)
        bounds["slip"] = (slo.reshape(-1), shi.reshape(-1))
        # a released contact's share: its ratio and the slip before the impact as its node slot's mode (stick, or
        # slide with the node's ratio); a K arrival's ratio Stronge's (the march's)
        fn = np.repeat(fm[:, :c, None], d, axis=2)
        rel_d = np.repeat(release[..., None], d, axis=2)
        fl_march = np.asarray(point["fleft"], float).reshape(L, c, d)
        kd = np.repeat(leftfix[..., None], d, axis=2)
        flo = np.where(kd, fl_march, np.where(rel_d, np.select([fn == M.STICK, fn == M.UP, fn == M.DOWN, fn == M.SLIDE],
                                                               [-mud[:, :c], -mud[:, :c], mud[:, :c], fl_march],
                                                               0.0), 0.0))
        fhi = np.where(kd, fl_march, np.where(rel_d, np.select([fn == M.STICK, fn == M.UP, fn == M.DOWN, fn == M.SLIDE],
                                                               [mud[:, :c], -mud[:, :c], mud[:, :c], fl_march],
                                                               0.0), 0.0))
        bounds["fleft"] = (flo.reshape(-1), fhi.reshape(-1))
        turn_d = np.repeat(turns[..., None], d, axis=2)
        bounds["left_slip"] = (np.where(turn_d | rel_d & np.isin(fn, (M.STICK, M.UP)), 0.0, -np.inf).reshape(-1),
                               np.where(turn_d | rel_d & np.isin(fn, (M.STICK, M.DOWN)), 0.0, np.inf).reshape(-1))
        if d == 2:
            # the circular cone: |ρ| ≤ μ_f sticking or sliding; sliding, ρ|s| + μ_f s = 0
            on = np.isin(fm, (M.STICK, M.SLIDE))
            bounds["cone"] = (np.where(on, 0.0, -np.inf).reshape(-1), np.full(L * 2 * c, np.inf))
            sl = np.repeat((fm == M.SLIDE)[..., None], d, axis=2).reshape(-1)
            bounds["slide"] = (np.where(sl, 0.0, -np.inf), np.where(sl, 0.0, np.inf))
        if self.cm.nfz:
            bounds.update(self._stage_friction_bounds(fm))
        return bounds

    def _stage_friction_bounds(self, fm) -> Dict[str, tuple]:
        """The stages' friction on the branch: each part's stages in its slot's mode (the first part's the node slot's,
        the second's the sub-node slot's; ``fm`` per step and slot).  Sticking, the displacement from the part's start
        vanishes and the ratio keeps in the cone; sliding, the ratio is at the cone's edge against the stage's slip
        velocity (in the plane ``ρ = ∓μ_f`` with the velocity's sign); otherwise no friction force."""
        cm, L, c, d = self.cm, self.L, self.cm.c, self.cm.fd
        st = cm.dm.scheme.stages
        # (per step: the first part's stages, each with its contacts, then the second's)
        zm = np.concatenate([np.tile(fm[:, :c], (1, st)), np.tile(fm[:, c:], (1, st))], axis=1)
        mu = np.tile(cm._stage_mu(), (L, 1))
        fmd, mud = np.repeat(zm[..., None], d, axis=2), np.repeat(mu[..., None], d, axis=2)
        modes = [M.STICK, M.UP, M.DOWN, M.SLIDE]
        out = {"fstage": (np.select([fmd == m for m in modes], [-mud, -mud, mud, -mud], 0.0).reshape(-1),
                          np.select([fmd == m for m in modes], [mud, -mud, mud, mud], 0.0).reshape(-1)),
               "stage_slip": (np.where(fmd == M.STICK, 0.0, -np.inf).reshape(-1),
                              np.where(fmd == M.STICK, 0.0, np.inf).reshape(-1)),
               "stage_vel": (np.where(fmd == M.UP, 0.0, -np.inf).reshape(-1),
                             np.where(fmd == M.DOWN, 0.0, np.inf).reshape(-1))}
        if d == 2:
            on = np.isin(zm, (M.STICK, M.SLIDE)).reshape(-1)
            out["stage_cone"] = (np.where(on, 0.0, -np.inf), np.full(on.size, np.inf))
            sl = np.repeat((zm == M.SLIDE)[..., None], d, axis=2).reshape(-1)
            out["stage_slide"] = (np.where(sl, 0.0, -np.inf), np.where(sl, 0.0, np.inf))
        return out

    def solve_branch(self, q0, p0, guess: Dict[str, np.ndarray], options=None, verbose=False,
                     max_iter: Optional[int] = None, penalties=PENALTY) -> NLPResult:
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
        on = bounced.reshape(-1)
        bounds["impact_law"] = (np.where(on, 0.0, -np.inf), np.where(on, 0.0, np.inf))
        # a part between two closed points holds its contact at its stages
        sub_closed = gs <= tol
        bounds.update(self._stage_bounds(node_closed[:L] & sub_closed, sub_closed & node_closed[1:]))
        init = self._start(q0, p0, guess)
        opts = self._branch_options(options, max_iter)
        # the undecided pairs (if any) by the penalty ladder, warm-started; decided ones are exact
        ladder = penalties if (np.any(node_free) or np.any(sub_free)) else penalties[:1]
        return self._ladder(init, opts, bounds, ladder, verbose, "branch", "the branch")

    def _branch_options(self, options, max_iter: Optional[int]) -> dict:
        """Ipopt's options of a decided branch: the settings' with the branch's budget (at most ``max_iter``) and
        MUMPS' pivot tolerance, then ``options``."""
        s = self.settings
        opts = {**s.ipopt, "max_iter": s.branch_max_iter, "mumps_pivtol": s.branch_pivtol, **(options or {})}
        opts["max_iter"] = min(int(opts["max_iter"]), s.branch_max_iter if max_iter is None else max_iter)
        return opts

    def _ladder(self, init, opts, bounds, penalties, verbose, parameter: str, who: str, warm=None) -> NLPResult:
        """Solve at each penalty ρ of ``penalties`` in turn, warm-started, until complementarity holds
        (or a solve fails); every step recorded (``HomotopyStep``, ``parameter``).  The result sums the
        steps' iterations and times; ``build_time_s`` is 0 unless this call (re)built the solver, and
        ``last_good`` holds (ρ, result) of the last step Ipopt solved.  ``warm``: a result whose primal and dual
        values start the first step (``init`` over its primal ones)."""
        before = self.nlp._solver
        steps: List[HomotopyStep] = []
        res, build = None, 0.0
        self.last_good = None
        for rho in penalties:
            self.nlp.set_parameter("rho", rho)
            res = self.nlp.solve(init=init if res is None else None, warm=warm if res is None else res, options=opts,
                                 verbose=verbose, bounds=bounds)
            if self.nlp._solver is not before and build == 0.0:
                build = res.build_time_s
            resid = self.residual(res.values)
            steps.append(HomotopyStep(rho, res.solver_status, res.iterations, res.solve_time_s, resid,
                                      parameter=parameter))
            if res.success:
                self.last_good = (rho, res)
            if not res.success or resid <= self.complementarity_target:
                break
        res.build_time_s = build
        res.iterations = sum(st.iterations for st in steps)
        res.solve_time_s = sum(st.solve_time_s for st in steps)
        res.homotopy = steps
        res.complementarity_residual = resid = steps[-1].complementarity_residual
        if res.success and resid > COMPLEMENTARITY_TOL:
            res.fail("Complementarity_Not_Reached",
                     f"{who} converged but the complementarity residual {resid:.2e} exceeds {COMPLEMENTARITY_TOL:g}")
        return res

    # ------------------------------------------------------------------ the program's parameters, set here only
    def hold(self, timed=None, bounce=None, node_impact=None, release=None, arrive=None) -> None:
        """Set the branch parameters given (per step and contact, 0/1): the contacts whose arrival times the sub-node
        (``timed``), Newton's law there (``bounce``), the impacts at a node (``node_impact``), the first part's closing
        impulses free (``release``: a contact released at the step's impact, or a slip's turn), the slips counted after
        the sub-node (``arrive``).  Every strategy sets them through this method (or :meth:`mode_bounds`, which also sets
        the timed forces' masks)."""
        for name, v in (("timed", timed), ("bounce", bounce), ("node_impact", node_impact), ("release", release),
                        ("arrive", arrive)):
            if v is not None:
                self.nlp.set_parameter(name, np.asarray(v, float).reshape(-1))

    def set_end_momentum(self, pN) -> None:
        """The given final momentum (the end conditions' ``pN``)."""
        self.nlp.set_parameter("pN", np.asarray(pN, float).reshape(-1))

    def set_split_weight(self, w: float) -> None:
        """The weight of Σβ² (the selection term of the impact-free steps' splits)."""
        self.nlp.set_parameter("split", float(w))

    def set_law_lengths(self, point) -> np.ndarray:
        """The impact law rows' lengths from the march ``point`` (:meth:`law_lengths`), returned.  (The residual
        keeps the start's lengths, :meth:`_start`.)"""
        lengths = self.law_lengths(point)
        self.nlp.set_parameter("law_length", lengths.reshape(-1))
        return lengths

    def parameters(self) -> dict:
        """Every parameter's value now, by name (a branch's snapshot, :meth:`restore`)."""
        return {name: self.nlp.parameter_value(name) for name in self.nlp.parameter_names}

    def restore(self, values: dict) -> None:
        """Set the parameters of a snapshot (:meth:`parameters`)."""
        for name, val in values.items():
            self.nlp.set_parameter(name, val)

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
        self._law_length = self.set_law_lengths(guess)
        init = {k: np.asarray(v, float).reshape(-1).copy() for k, v in guess.items()
                if k in self.nlp.variable_names}
        init["q"][:n] = q0
        if self.cm.s and "zs" not in init:
            # a guess without stages (the event-located one): the straight lines of each step's two parts
            init["zs"] = self.cm.stage_guess(init["q"].reshape(self.L + 1, n),
                                             init["qs"].reshape(self.L, n)).reshape(-1)
        if "s_plus" not in init:
            init["s_plus"] = np.zeros(self.L * c)
            init["s_minus"] = np.zeros(self.L * c)
        return init
