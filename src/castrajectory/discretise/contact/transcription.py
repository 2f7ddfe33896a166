"""The contact transcription: the whole-trajectory discrete action under unilateral gaps.

A :class:`~castrajectory.models.mechanics.LagrangianSystem` with a
:class:`~castrajectory.models.mechanics.Contact` term (gaps ``φ_j(q) ≥ 0``,
restitution ``e``) is transcribed here into one program; a system without one never
reaches this module.  How the program is solved (the event-located guess, the penalty
ladder, horizon windows) is :mod:`castrajectory.solve.contact`.

Transcription (initial value; derivation in ``docs/derivations.md``, "Contact trajectories".  Written
here with the two-point ``L_d``; a scheme with stages gives each part of a step its own stages and stage
rows, :mod:`.elements`)
-----------------------------------------------------------------------------
Every step ``k`` of the grid (``t_{k+1} = t_k + h_k``; ``h_k = h`` unless refined) holds a *collision sub-node* ``q̃_k``
at ``t_k + α_k h`` with ``α_k = ½ + β_k ∈ [ε, 1 − ε]`` (as in Fetecau, Marsden,
Ortiz and West 2003, the impact time is an unknown, not a grid node; unlike
their integrator, ``α_k`` is fixed by the gap and Newton's law below, not by
varying the action in the collision time).  The discrete
action is ``S_d = Σ_k L_d(q_k, q̃_k; α_k h) + L_d(q̃_k, q_{k+1}; (1 − α_k) h)``.
Its stationarity under the unilateral constraints gives, with ``D₁, D₂`` the
slot derivatives of ``L_d``:

* sub-node ``k``: ``D₂L_d(q_k, q̃_k) + D₁L_d(q̃_k, q_{k+1}) + ∇φ(q̃_k)ᵀ μ_k = 0``
  with ``0 ≤ φ(q̃_k) ⟂ μ_k ≥ 0`` — ``μ_k`` is the impulse of an impact inside
  step ``k``: the sub-node momenta ``p̃⁻ = D₂L_d(q_k, q̃_k)`` and
  ``p̃⁺ = −D₁L_d(q̃_k, q_{k+1})`` jump by ``∇φᵀμ``, the set ``M⁻¹∇φᵀμ, μ ≥ 0``
  of Exercise 2.2;
* node ``k``: ``D₂L_d(q̃_{k−1}, q_k) + D₁L_d(q_k, q̃_k) + h ∇φ(q_k)ᵀ ν_k = 0``
  with ``0 ≤ φ(q_k) ⟂ ν_k ≥ 0`` — ``ν_k`` is a contact *force* (impulse
  ``h ν_k`` per node): persistent contact, e.g. a body resting on the ground,
  where ``h ν_k = m g h``;
* impact law (Newton restitution on the contact's normal velocity, evaluated
  with the exact discrete momenta at the sub-node):
  ``μ_{jk} · r_{jk} · φ_j(q_{k+1})/δ_{jk} = 0`` with
  ``r = ∇φ_j(q̃_k) M(q̃_k)⁻¹ (p̃⁺ + e p̃⁻)``: the law holds for every impact after
  which the body leaves, and is waived when the contact is closed again at the
  next node (the body is caught: the accumulation point of Zeno bouncing, or a
  body at rest).  With ``e = 1`` the kinetic energy ``½ p̃ᵀM⁻¹p̃`` is the same on
  both sides of the impact, exactly.  ``δ_{jk} = ℓ``, except at a bounce of
  the event-located guess, where it is the guess's next-node gap (so the weight
  is about 1 also for an impact late in its step); the unweighted ``|μ r|`` of
  every impact whose next node is open is checked separately (:data:`LAW_TOL`);
* centred splits: a tiny objective ``w_β Σ β_k²`` picks ``α_k = ½`` in steps without impact;
* a non-uniform grid: the step lengths ``h_k`` may differ (the march halves a step that would hold two
  impacts at different times, :mod:`castrajectory.solve.contact.march`); node ``k``'s row then reads
  ``D₂L_d(q̃_{k−1}, q_k; (1 − α_{k−1}) h_{k−1}) + D₁L_d(q_k, q̃_k; α_k h_k) + h_k ∇φ(q_k)ᵀ ν_k = 0`` (divided
  by ``h_k``), and every other row takes its own step's ``h_k``;
* look-ahead step: the NLP has ``N + LOOKAHEAD`` steps and only the first ``N`` are reported, and
  the last node force is complementary to the end gap too (``ρ φ(q_L)·h ν_{L−1}``).  The end node
  of an NLP has no successor, so a force there could otherwise "launch" the body into it; with
  the look-ahead every reported node keeps its row, force and successor.

Reported per node: ``Λ_k = h ν_k + (1 − α_k) μ_k + α_{k−1} μ_{k−1}`` (sub-node impulses shared
between their two nodes by the hat-function weights of their time), which for a ball is exactly
the lumped momentum balance ``m g h + m (q_{k+1} − 2 q_k + q_{k−1})/h`` whatever the sub-nodes do,
and node momenta that are the mean of the one-sided ones at a closed contact.

Complementarity is imposed by exact (ℓ1) penalties rather than by relaxed
product constraints: the objective gains ``ρ (Σ φ(q_k)·h ν_k + Σ φ(q̃_k)·μ_k)``
(both factors are bounded below by 0, so each product is ≥ 0) and
``ρ Σ (s⁺ + s⁻)`` for the impact law written as ``μ r − s⁺ + s⁻ = 0``,
``s± ≥ 0``; ``bound_relax_factor = 0``.  (The steps are recorded as
:class:`~castrajectory.result.HomotopyStep` with ``parameter = "rho"``.)  Every constraint then has a gradient
that never vanishes, whereas the relaxed products ``|μ r| ≤ σ`` are degenerate
wherever ``μ = r = 0`` (every sub-node of a resting body), where Ipopt's
multipliers diverged in our trials.  ``ρ`` rises (10, 100, ...) with warm
starts until the scaled residual is at most :data:`COMPLEMENTARITY_TOL`.
"""
from __future__ import annotations

import numpy as np

from ..program import P, Program, X
from .elements import SPLIT_WEIGHT, ContactMechanics

#: The sub-node's time fraction stays in [ALPHA_MIN, 1 − ALPHA_MIN].
ALPHA_MIN = 1e-6
#: Gap tolerance (relative to the body's length scale) below which a guess counts as touching.
TOUCH_TOL = 1e-9
#: Penalty weights tried in turn (each warm-started from the last) until the scaled
#: complementarity residual is at most COMPLEMENTARITY_TOL.
PENALTY = (10.0, 100.0, 1e3, 1e4)
#: Scaled complementarity residual accepted as exact (products over gap × impulse scales).
COMPLEMENTARITY_TOL = 1e-8
#: Newton's law of every impact after which the body leaves, unweighted: |μ r| / (p_ref v_ref)
#: at most this (it enters the reported residual scaled by COMPLEMENTARITY_TOL / LAW_TOL).
LAW_TOL = 1e-6
#: The guess lets a touching body rest when its whole velocity is below this many steps' worth
#: of its normal acceleration, and catches a slow arrival below v_z = max(this, 1/e) a h.
REST_SPEED_STEPS = 2.0
#: An impact "leaves" (its unweighted Newton law is checked, LAW_TOL) when the next node is open by
#: more than this fraction of a h² (a h²/8 is the hop of a resting body between two nodes).
CLOSING_FRACTION = 0.125
#: Steps solved beyond the reported horizon (see module docstring, "Look-ahead step").
LOOKAHEAD = 1


def _rows_of(values: np.ndarray):
    """``rows -> element argument`` of one number per step (``(E, 1)`` for an array of rows, ``(1,)`` for one)."""
    return lambda rows: values[rows][:, None] if np.ndim(rows) else np.array([values[rows]])


def _v_zeno(cm: ContactMechanics, h: float, scales) -> float:
    """Slow-arrival speed under which the guess lets the body be caught (event_guess).

    v_z = a h / e: above it a bounce leaves at e v ≥ a h, so its flight lasts at least two steps and
    clears the next node (by ½ a h² after one step); below it the bounce would come back within two
    steps, the grid cannot resolve it, and the arrival is the end of an accumulation.  For e = 0 every
    arrival is caught (plastic: Newton's law itself).  (A floor of 2 a h, used before, also caught
    bounces the grid resolves, e.g. an arrival at 0.112 m/s with e = 0.5, h = 3 ms.)
    """
    ell, pref, vref, aref = scales
    factor = 1.0 / cm.e if cm.e > 0 else 1e12
    return max(factor * aref * h, 1e-12 * vref)


class ContactTranscription:
    """Initial-value contact program over ``L`` steps of length ``h`` (see module docstring).

    ``scales = (length, momentum, velocity)`` normalise the penalty terms.  ``program`` is the
    class of the program written (the solve layer's subclass uses its NLP).
    """

    program = Program

    def __init__(self, cm: ContactMechanics, L: int, h: float, scales, steps=None, u_bounds=None, lifts: bool = False):
        self.cm, self.L, self.h = cm, L, h
        #: the program holds releases and stick ends timed at their sub-nodes (the march's modes E and G): the rows of
        #: the contacts' forces at the sub-nodes (only where one is timed: a program without one carries none)
        self.has_lifts = bool(lifts)
        # step lengths h_k (a grid refined where impacts crowd, see solve.contact.march); h by default
        self.H = np.full(L, float(h)) if steps is None else np.asarray(steps, float).reshape(L)
        ell, pref, vref, aref = scales
        self.scales_p = ell * pref
        self.scales_ell = ell
        self.scales_law = pref * vref
        self.v_zeno = _v_zeno(cm, h, scales)
        #: impulses decided by another law (the sequential cascade of the march, steps × contacts): their
        #: sub-nodes are exempt from the one-contact Newton law in :meth:`residual`
        self.law_exempt = np.zeros((L, cm.c), dtype=bool)
        #: the contacts that arrive at their sub-node, per step (friction: their slip is the one after it)
        self.arrive = np.zeros((L, cm.c))
        #: the contacts released at their step's impact, per step (their sub-node impulse is a share, no impact)
        self.release = np.zeros((L, cm.c))
        #: the held contacts whose slip stops or turns at their step's sub-node (step, contact, "stop" or "turn")
        self.turns = []
        #: the held contacts released at their step's sub-node, timed by their force (step, contact), and the sticking
        #: ones that start to slide there (the same)
        self.lifts, self.grips = [], []
        # weight length of the law where the guess has no bounce: W = φ(q_{k+1})/δ with δ = ℓ
        # (law_lengths sets a shorter δ at the guess's bounces)
        self.delta = ell
        self.open_gap = max(CLOSING_FRACTION * aref * h * h, 1e-12 * ell)
        self.nlp = self.program(hessian="exact")
        self._variables(u_bounds)
        self._UA = self._argument("u", cm.nu)
        self._parameters()
        self._momentum_rows()
        self._friction_rows()
        self._contact_rows()
        self._penalties()

    def _blocks(self):
        """The index blocks of the per-step unknowns: nodes ``Q``, sub-nodes ``S``, splits ``B``, impulses ``MU``, node
        forces ``NU``, the law's slacks ``SP``, ``SM``."""
        nlp, L, n, c = self.nlp, self.L, self.cm.n, self.cm.c
        return (nlp.index("q").reshape(L + 1, n), nlp.index("qs").reshape(L, n), nlp.index("beta").reshape(L, 1),
                nlp.index("mu").reshape(L, c), nlp.index("nu").reshape(L, c), nlp.index("s_plus").reshape(L, c),
                nlp.index("s_minus").reshape(L, c))

    def _variables(self, u_bounds) -> None:
        """The unknowns: nodes, sub-nodes and their splits, impulses and node forces, the law's slacks; friction ratios,
        constraint multipliers, stages and controls where the scene has them."""
        cm, nlp, L = self.cm, self.nlp, self.L
        n, c = cm.n, cm.c
        nlp.variable("q", (L + 1) * n)
        nlp.variable("qs", L * n)
        nlp.variable("beta", L, lb=ALPHA_MIN - 0.5, ub=0.5 - ALPHA_MIN)
        nlp.variable("mu", L * c, lb=0.0)
        nlp.variable("nu", L * c, lb=0.0)
        nlp.variable("s_plus", L * c, lb=0.0)
        nlp.variable("s_minus", L * c, lb=0.0)
        # Coulomb friction: the ratio ρ of tangential to normal force per step and contact, |ρ| ≤ μ_f
        # (only with friction: a frictionless system builds no friction variable)
        if cm.friction:
            muf2 = np.repeat(np.concatenate([cm.mu_f, cm.mu_f]), cm.fd)
            nlp.variable("fratio", L * 2 * c * cm.fd, lb=np.tile(-muf2, L), ub=np.tile(muf2, L))
        # each sub-node's impulses that close its first part, and their ratios: 0 (fixed) but in the march's branch,
        # where a contact released at its step's impact takes its share there and a plastic arrival with friction
        # Stronge's impulse (ContactMechanics.sub_row, ContactNLP.solve_modes)
        nlp.variable("mul", L * c, lb=0.0, ub=0.0)
        if cm.friction:
            nlp.variable("fleft", L * c * cm.fd, lb=0.0, ub=0.0)
        # multipliers of the holonomic constraints at the nodes 0..L-1 and the sub-nodes (none without)
        m = cm.m
        if m:
            nlp.variable("lam", L * m)
            nlp.variable("lam_sub", L * m)
        # a scheme with stages: the stages of both parts of every step, and their constraint multipliers
        s = cm.s
        if s:
            nlp.variable("zs", L * 2 * s)
            if m:
                nlp.variable("lam_stage", L * 2 * cm.ms)
            # the contacts' forces at the stages (held through a part: its gap closed there, ContactMechanics.stage_rows)
            nlp.variable("lam_cstage", L * 2 * cm.sc, lb=0.0)
            # ... and their friction ratios, |ρ^Z| ≤ μ_f
            if cm.nfz:
                muz = np.repeat(cm._stage_mu(), cm.fd)
                nlp.variable("fstage", L * cm.nfz, lb=np.tile(-muz, L), ub=np.tile(muz, L))
        # controls (optimal control through contact): one value per step, an input of every row that holds the
        # step's forces (ContactMechanics); a system without controls passes an empty one (the same signature)
        if cm.nu:
            lo, hi = u_bounds if u_bounds is not None else (np.full(cm.nu1, -np.inf), np.full(cm.nu1, np.inf))
            # (each control value of a step: one per step, or one per node of each part's quadrature)
            lo, hi = (np.tile(np.asarray(x, float).reshape(-1), cm.nu // cm.nu1) for x in (lo, hi))
            nlp.variable("u", L * cm.nu, lb=np.tile(lo, L), ub=np.tile(hi, L), init=np.tile(np.clip(0.0, lo, hi), L))

    def _parameters(self) -> None:
        """The initial momentum, the penalty weight, the split's weight and the law's weight lengths."""
        nlp, L, n, c = self.nlp, self.L, self.cm.n, self.cm.c
        nlp.parameter("p0", n)
        nlp.parameter("rho", 1, value=PENALTY[0])
        # weight of the centred-split term (0 where every β is fixed or timed: a decided branch)
        nlp.parameter("split", 1, value=SPLIT_WEIGHT)
        # weight length of Newton's law per step and contact (law_lengths)
        nlp.parameter("law_length", L * c, value=self.delta)

    def _momentum_rows(self) -> None:
        """The discrete momentum balance: the initial, node and sub-node rows, the release rows, the stage rows."""
        cm, nlp, L = self.cm, self.nlp, self.L
        c, m, s = cm.c, cm.m, cm.s
        Q, S, B, MU, NU, _, _ = self._blocks()
        UA = self._UA
        # the constraint multipliers and the friction ratios (empty columns without constraints, without friction)
        LAM, LAMS, RHO = self._argument("lam", m), self._argument("lam_sub", m), self._argument("fratio", cm.nfr)
        # the first part's closing impulses μ⁻ of every sub-node, and their ratios (0 outside the march's branch)
        MUL, FL = self._argument("mul", c), self._argument("fleft", cm.nfl)
        # which contacts release at their step's impact (the march's modes, ContactNLP.solve_modes; 0 elsewhere): their
        # μ⁻ are shares of their force before it, which the momentum before the impact carries
        nlp.parameter("release", L * c, value=0.0)
        REL = P(nlp.parameter_index("release").reshape(L, c))
        # the stages of a step's first part (ZM) and second part (ZP), none for a two-point scheme
        ZM, ZP = self._ZM, self._ZP = self._argument("zs", 2 * s, slice(0, s)), self._argument("zs", 2 * s, slice(s, 2 * s))
        Hc = self.H.reshape(-1, 1)
        # the step lengths as element arguments (numbers; an unknown h for a free final time, _step_argument), and the
        # steps' start times (numbers: a contact system's elements do not read them)
        HA = self._HA = self._step_argument(nlp, Hc)
        TA = self._TA = _rows_of(self.step_starts())
        k = np.arange(L)
        fn0, p0arg = self._initial_element(nlp)
        nlp.equal_elements("initial", fn0,
                           [X(Q[0]), X(S[0]), X(B[0]), p0arg, X(NU[0]), HA(0), LAM(0), RHO(0), ZM(0), TA(0), UA(0)])
        if L > 1:
            i = np.arange(1, L)
            nlp.equal_elements("node", cm.node, [X(S[i - 1]), X(B[i - 1]), X(Q[i]), X(S[i]), X(B[i]),
                                                 X(NU[i]), HA(i - 1), HA(i), LAM(i), RHO(i), ZP(i - 1), ZM(i),
                                                 TA(i), UA(i - 1), UA(i)])
        nlp.equal_elements("sub", cm.sub, [X(Q[k]), X(S[k]), X(Q[k + 1]), X(B[k]), X(MU[k]), HA(k), MUL(k), FL(k),
                                           LAMS(k), RHO(k), ZM(k), ZP(k), TA(k), UA(k)])
        # the normal (and slip) velocities before each sub-node's impact, after its first part's closing impulses:
        # zero for a contact released there (its share; the bounds are the march's modes, ContactNLP.solve_modes)
        nlp.inequality_elements("release", cm.release, [X(Q[k]), X(S[k]), X(B[k]), HA(k), MUL(k), FL(k), REL, ZM(k),
                                                        TA(k), UA(k)], lb=-np.inf, ub=np.inf)
        if cm.friction:
            nlp.inequality_elements("left_slip", cm.left_slip, [X(Q[k]), X(S[k]), X(B[k]), HA(k), MUL(k), FL(k), REL,
                                                                ZM(k), TA(k), UA(k)], lb=-np.inf, ub=np.inf)
        if s:
            nlp.equal_elements("stage", cm.stage, [X(Q[k]), X(S[k]), X(Q[k + 1]), X(B[k]), HA(k), ZM(k), ZP(k),
                                                   self._argument("lam_stage", 2 * cm.ms)(k),
                                                   self._argument("lam_cstage", 2 * cm.sc)(k),
                                                   self._argument("fstage", cm.nfz)(k), TA(k), UA(k)])
            if m:
                nlp.equal_elements("stage_constraint", cm.stage_constraint, [ZM(k), ZP(k)])

    def _friction_rows(self) -> None:
        """The step's slip velocity (its bounds are the friction's modes), and on a tangent plane the cone's rows."""
        if not self.cm.friction:
            return
        cm, nlp, L, c = self.cm, self.nlp, self.L, self.cm.c
        Q, S, B = self._blocks()[:3]
        k = np.arange(L)
        HA, RHO = self._HA, self._argument("fratio", cm.nfr)
        # (which contacts arrive at their sub-node: their slip is the one after it, ContactMechanics.slip)
        nlp.parameter("arrive", L * c, value=0.0)
        AR = P(nlp.parameter_index("arrive").reshape(L, c))
        ZM, ZP = self._ZM, self._ZP
        nlp.inequality_elements("slip", cm.slip_row, [X(Q[k]), X(S[k]), X(Q[k + 1]), X(B[k]), HA(k), AR, ZM(k), ZP(k)],
                                lb=-np.inf, ub=np.inf)
        if cm.fd == 2:
            # the tangent plane's circular cone, and sliding against the slip (bounds by the modes)
            nlp.inequality_elements("cone", cm.cone_row, [RHO(k)], lb=-np.inf, ub=np.inf)
            nlp.inequality_elements("slide", cm.slide_row, [X(Q[k]), X(S[k]), X(Q[k + 1]), X(B[k]), HA(k), AR, ZM(k),
                                                            ZP(k), RHO(k)], lb=-np.inf, ub=np.inf)
        if cm.nfz:
            # the stages' friction: a sticking stage's displacement and a sliding one's velocity (bounds by the modes),
            # and on a tangent plane the cone and the sliding rows
            RZ = self._argument("fstage", cm.nfz)
            nlp.inequality_elements("stage_slip", cm.stage_slip_row, [X(Q[k]), X(S[k]), X(Q[k + 1]), X(B[k]), HA(k),
                                                                      ZM(k), ZP(k)], lb=-np.inf, ub=np.inf)
            nlp.inequality_elements("stage_vel", cm.stage_vel_row, [X(Q[k]), X(S[k]), X(Q[k + 1]), X(B[k]), HA(k),
                                                                    ZM(k), ZP(k)], lb=-np.inf, ub=np.inf)
            if cm.fd == 2:
                nlp.inequality_elements("stage_cone", cm.stage_cone_row, [RZ(k)], lb=-np.inf, ub=np.inf)
                nlp.inequality_elements("stage_slide", cm.stage_slide_row, [X(Q[k]), X(S[k]), X(Q[k + 1]), X(B[k]),
                                                                            HA(k), ZM(k), ZP(k), RZ(k)],
                                        lb=-np.inf, ub=np.inf)

    def _contact_rows(self) -> None:
        """The holonomic constraints at the nodes and sub-nodes, the gaps, and Newton's law with its slacks."""
        cm, nlp, L = self.cm, self.nlp, self.L
        c = cm.c
        Q, S, B, MU, _, SP, SM = self._blocks()
        k = np.arange(L)
        HA, UA, ZM, ZP = self._HA, self._UA, self._ZM, self._ZP
        MUL, FL = self._argument("mul", c), self._argument("fleft", cm.nfl)
        REL = P(nlp.parameter_index("release").reshape(L, c))
        if cm.m:
            nlp.equal_elements("node_constraint", cm.constraint_row, [X(Q[1:])])
            nlp.equal_elements("sub_constraint", cm.constraint_row, [X(S)])
        nlp.inequality_elements("node_gap", cm.gap_row, [X(Q[1:])], lb=0.0)
        nlp.inequality_elements("sub_gap", cm.gap_row, [X(S)], lb=0.0)
        if cm.sc:
            nlp.inequality_elements("stage_gap", cm.stage_gap, [ZM(k), ZP(k)], lb=0.0)
            # (the rows that hold a contact at a part's stages: bounds by the march's modes, free elsewhere)
            nlp.inequality_elements("stage_hold", cm.stage_hold, [X(Q[k]), X(S[k]), X(Q[k + 1]), ZM(k), ZP(k)],
                                    lb=-np.inf, ub=np.inf)
        # the contacts' forces of the continuous motion at each sub-node, with the contacts held through the step's
        # first part (the parameter "held"): zero for a contact released there (its bounds are the march's modes)
        if self.has_lifts:
            # the contacts' forces of the continuous motion at each sub-node, with the contacts held ("held") and
            # sticking ("stuck") through the step's first part: a release's normal force and a stick's cone margin (in
            # the direction "slide_sign" it slides after), zero where the march timed one there (bounds by its modes)
            for name in ("held", "stuck", "slide_sign"):
                nlp.parameter(name, L * c, value=0.0)
            par = [P(nlp.parameter_index(name).reshape(L, c)) for name in ("held", "stuck", "slide_sign")]
            nlp.inequality_elements("timed_force", cm.timed_force_rows, [X(Q[k]), X(S[k]), X(B[k]), HA(k), ZM(k), *par,
                                                                    self._TA(k), UA(k)], lb=-np.inf, ub=np.inf)
        LL = P(nlp.parameter_index("law_length").reshape(L, c))
        nlp.equal_elements("impact_law", cm.law_slack,
                           [X(Q[k]), X(S[k]), X(Q[k + 1]), X(B[k]), X(MU[k]), X(SP[k]), X(SM[k]), HA(k), LL,
                            MUL(k), FL(k), REL, ZM(k), ZP(k), np.array([self.scales_law]), self._TA(k), UA(k)])

    def _penalties(self) -> None:
        """The exact (ℓ1) penalties: the complementarity products and the impact law's slacks, and the split's weight."""
        cm, nlp, L = self.cm, self.nlp, self.L
        Q, S, B, MU, NU, SP, SM = self._blocks()
        k = np.arange(L)
        p, Hc = self.scales_p, self.H.reshape(-1, 1)        # (ℓ p_ref, the products' scale)
        rho = P(nlp.parameter_index("rho"))
        nlp.minimize_elements("node_penalty", cm.product_penalty, [X(Q[k]), X(NU[k]), rho, p / Hc])
        nlp.minimize_elements("sub_penalty", cm.product_penalty, [X(S[k]), X(MU[k]), rho, np.array([p])])
        nlp.minimize_elements("law_penalty", cm.slack_penalty, [X(SP[k]), X(SM[k]), rho])
        if cm.sc:
            nlp.minimize_elements("stage_penalty", cm.stage_penalty, [self._ZM(k), self._ZP(k),
                                                                      self._argument("lam_cstage", 2 * cm.sc)(k), rho,
                                                                      p / Hc])
        nlp.minimize_elements("split", cm.split, [X(B[k]), P(nlp.parameter_index("split"))])
        # terminal condition: the last node force may not launch the body (its gap at the end node
        # q_L would otherwise be free; see the module docstring, "Look-ahead step")
        nlp.minimize_elements("end_penalty", cm.product_penalty, [X(Q[L]), X(NU[L - 1]), rho, p / Hc[L - 1]])
        # the pairs those penalties hold, per contact: gap ⟂ node force, sub-node gap ⟂ impulse, Newton's
        # law ⟂ impulse (the slacks), and the end node's gap ⟂ the last node force
        nlp.declared_pairs.update({"node": L * cm.c, "sub": L * cm.c, "impact_law": L * cm.c, "end": cm.c})
        if cm.sc:
            nlp.declared_pairs["stage"] = L * 2 * cm.sc

    def step_starts(self, H=None) -> np.ndarray:
        """The steps' start times ``t_k`` (k = 0..L−1) for the step lengths ``H`` (the grid's by default): the elements'
        time argument."""
        H = self.H if H is None else np.asarray(H, float)
        return np.concatenate([[0.0], np.cumsum(H)[:-1]])

    def _argument(self, name: str, width: int, cols: slice = slice(None)):
        """``rows -> element argument`` of the per-step unknowns ``name`` (``width`` entries per step, the columns
        ``cols`` of them): their indices, or an empty column where the scene has none of them (no constraints, no
        friction, no stages, no controls), so that every element call has one argument list."""
        if not width:
            return lambda rows: np.zeros(0)
        idx = self.nlp.index(name).reshape(self.L, width)[:, cols]
        return lambda rows: X(idx[rows])

    # ------------------------------------------------------------------ hooks of the control problem
    def _step_argument(self, nlp, Hc):
        """The step lengths as element arguments, ``rows -> argument`` (here the numbers ``H``)."""
        return lambda rows: Hc[rows]

    def _initial_element(self, nlp):
        """The initial row's function and its momentum argument (here the parameter ``p0``)."""
        return self.cm.initial, P(nlp.parameter_index("p0"))

    def steps(self, values) -> np.ndarray:
        """The step lengths of a point (here ``H``, fixed)."""
        return self.H

    def law_lengths(self, guess) -> np.ndarray:
        """Weight length δ_kj of Newton's law, ``W = φ_j(q_{k+1})/δ_kj``, per step and contact.

        δ = ℓ, except for a bounce of contact j in step k of the guess, where δ is that next-node
        gap of the guess (at least a h²/8): W is then about 1 at the guess, also for a bounce late
        in its step, and still vanishes if the solution catches the body at the next node
        instead.  Bounces are the impacts :func:`event_guess` resolved with restitution (not the
        catches, nor the impulses of resting sub-nodes); for an assembled solution (horizon
        windows), an impulse of a contact open at nodes k and k + 1.
        """
        n, c, L = self.cm.n, self.cm.c, self.L
        out = np.full((L, c), self.delta)
        if "q" not in guess or "mu" not in guess:
            return out
        Q = np.asarray(guess["q"], float).reshape(L + 1, n)
        MU = np.asarray(guess["mu"], float).reshape(L, c)
        gnext = self.cm.gaps(Q[1:])
        if "bounced" in guess:       # the event-located guess says which impulses are bounces
            bounce = np.asarray(guess["bounced"], bool).reshape(L, c) & (gnext > TOUCH_TOL * self.scales_ell)
        else:                        # an assembled solution: an impulse arriving from flight, leaving
            gnow = self.cm.gaps(Q[:-1])
            tol = TOUCH_TOL * self.scales_ell
            bounce = (MU > 0.0) & (gnext > tol) & (gnow > tol)
        out[bounce] = np.clip(gnext[bounce], self.open_gap, self.delta)
        return out

    def _raw_law(self, values):
        """Unweighted Newton law ``μ r`` per step and contact (one-sub-node form; at a node with an
        impact, ``h ν`` times the node's law), and where the body leaves after the impulse: one of the next two nodes open by more than the hop of a resting
        body, a h²/8.  Its check holds an impact late in its step (small next-node gap, small
        weight) to the same tolerance, and rejects a "catch" that lifts off again."""
        cm, L, H, c = self.cm, self.L, self.steps(values), self.cm.c
        Q = values["q"].reshape(L + 1, cm.n)
        S = values["qs"].reshape(L, cm.n)
        MU = values["mu"].reshape(L, c)
        B = values["beta"].reshape(L)
        zm, zp = self._stages(values)
        U = self._controls(values)
        T0 = self.step_starts(H)
        raw, nxt = (np.asarray(v).reshape(c, L).T for v in cm.law_check.map(L)(Q[:-1].T, S.T, Q[1:].T, B, MU.T, H,
                                                                               *self._law_extras(values), *[z.T for z in zm + zp],
                                                                               T0[None, :], *[u.T for u in U]))
        nxt2 = np.vstack([nxt[1:], nxt[-1:]])
        leaves = (nxt > self.open_gap) | (nxt2 > self.open_gap)
        # ... if the contact arrived faster than the grid resolves (v_z = a h / e): a slower arrival
        # would bounce back within two steps, and its plastic catch is the discrete end of an
        # accumulation even where the contact opens again soon after
        ks = np.where(np.any(leaves & (MU > 0), axis=1))[0]
        if ks.size:
            pm = np.asarray(cm.p_minus.map(ks.size)(Q[ks].T, S[ks].T, B[ks], H[ks], *[z[ks].T for z in zm],
                                                    T0[None, ks], *[u[ks].T for u in U])).T
            for i, k in enumerate(ks):
                J = np.asarray(cm.system.gap(S[k])[1])
                vn = J @ np.linalg.solve(np.asarray(cm.system.mass_matrix(S[k])), pm[i])
                leaves[k] &= -vn > self.v_zeno
        # Newton's law at the nodes (the march's mode N): a node impulse h ν on an arrival faster than v_z
        # after which the contact leaves is an impact at the node, and its law is checked the same way
        NU = values["nu"].reshape(L, c)
        for k, j in zip(*np.where(NU[1:L] > 0.0)):
            k += 1
            if not (nxt[k, j] > self.open_gap or nxt2[k, j] > self.open_gap):
                continue
            p_in = np.asarray(cm.p_node_minus(S[k - 1], B[k - 1], Q[k], H[k - 1], *[z[k - 1] for z in zp],
                                              T0[k - 1], *[u[k - 1] for u in U])).reshape(-1)
            J = np.asarray(cm.system.gap(Q[k])[1])[j]
            if -(J @ np.linalg.solve(np.asarray(cm.system.mass_matrix(Q[k])), p_in)) > self.v_zeno:
                r = float(np.asarray(cm.node_law_fn(p_in, Q[k], S[k], B[k], H[k], *[z[k] for z in zm], T0[k],
                                                    *[u[k] for u in U])).reshape(-1)[j])
                raw[k, j] = max(abs(raw[k, j]), abs(H[k] * NU[k, j] * r))
                leaves[k, j] = True
        return raw, leaves

    def _law_extras(self, values):
        """The law's inputs after ``h`` (and ``δ``): the first parts' closing impulses and their ratios (columns)."""
        cm, L = self.cm, self.L
        fleft = np.asarray(values["fleft"], float).reshape(L, -1) if cm.nfl else np.zeros((L, 0))
        return [np.asarray(values["mul"], float).reshape(L, cm.c).T, fleft.T,
                np.asarray(self.nlp.parameter_value("release"), float).reshape(L, cm.c).T]

    def _controls(self, values):
        """``[U]``, the controls per step ``(L, nu)`` (``nu`` = 0 without controls: an empty column per step)."""
        if not self.cm.nu:
            return [np.zeros((self.L, 0))]
        return [np.asarray(values["u"], float).reshape(self.L, self.cm.nu)]

    def _stages(self, values):
        """``([Z⁻], [Z⁺])`` per step, ``(L, s)`` each (of no column for a two-point scheme)."""
        if not self.cm.s:
            return [np.zeros((self.L, 0))], [np.zeros((self.L, 0))]
        return self.cm.stage_parts(np.asarray(values["zs"], float).reshape(self.L, 2 * self.cm.s))

    def residual(self, values) -> float:
        """Largest complementarity violation: |φ ν h|, |φ μ| and |μ r| (scaled as in the penalties)."""
        cm, L, H = self.cm, self.L, self.steps(values)
        n, c = cm.n, cm.c
        Q = values["q"].reshape(L + 1, n)
        S = values["qs"].reshape(L, n)
        MU = values["mu"].reshape(L, c)
        NU = values["nu"].reshape(L, c)
        B = values["beta"].reshape(L)
        gq = cm.gaps(Q[:-1])
        gs = cm.gaps(S)
        zm, zp = self._stages(values)
        law = np.asarray(cm.impact_law.map(L)(Q[:-1].T, S.T, Q[1:].T, B, MU.T, H,
                                              self._law_length.T, *self._law_extras(values),
                                              *[z.T for z in zm + zp], self.step_starts(H)[None, :],
                                              *[u.T for u in self._controls(values)])).reshape(c, L).T
        # Newton's law of every impact after which the body leaves, unweighted (_raw_law)
        raw, leaves = self._raw_law(values)
        law = np.where(self.law_exempt, 0.0, law)
        leaves &= ~self.law_exempt
        raw_max = float(np.max(np.abs(raw[leaves]))) if np.any(leaves) else 0.0
        g_end = np.asarray(cm.gap_row(Q[L])).reshape(-1)
        # (a contact whose release the last step times, mode E, leaves by its own force's zero: not a launch)
        g_end = np.where([(L - 1, j) in self.lifts for j in range(c)], 0.0, g_end)
        stage = 0.0
        if cm.sc:   # the stages' pairs, φ(Z_j) λ^c_j h
            gz = np.asarray(cm.stage_gap.map(L)(*[z.T for z in zm + zp])).T
            lcz = np.asarray(values["lam_cstage"], float).reshape(L, 2 * cm.sc)
            stage = float(np.max(np.abs(gz * lcz * H[:, None]))) / self.scales_p
        return float(max(stage, np.max(np.abs(gq * NU * H[:, None])) / self.scales_p, np.max(np.abs(gs * MU)) / self.scales_p,
                         float(np.max(np.abs(g_end * NU[L - 1] * H[L - 1]))) / self.scales_p,
                         np.max(np.abs(law)) / self.scales_law,
                         raw_max / self.scales_law * COMPLEMENTARITY_TOL / LAW_TOL))
