"""The contact transcription: the whole-trajectory discrete action under unilateral gaps.

A :class:`~castrajectory.models.mechanics.LagrangianSystem` with a
:class:`~castrajectory.models.mechanics.Contact` term (gaps ``φ_j(q) ≥ 0``,
restitution ``e``) is transcribed here into one program; a system without one never
reaches this module.  How the program is solved (the event-located guess, the penalty
ladder, horizon windows) is :mod:`castrajectory.solve.contact`.

Transcription (initial value, two-point schemes; derivation in
``docs/derivations.md``, "Contact trajectories")
-----------------------------------------------------------------------------
Every step ``k`` of the grid ``t_k = k h`` holds a *collision sub-node* ``q̃_k``
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
* two sub-nodes in a step: in the steps ``k2`` where the event-located guess has two impacts (none:
  the NLP above, unchanged), a second sub-node ``x₂`` at ``t_k + α₂ h`` (``α_k + ε ≤ α₂ ≤ 1 − ε``,
  impulse ``μ₂``, its own law and slacks) makes the chain ``q_k → q̃_k → x₂ → q_{k+1}``: the sub-node
  rows of ``q̃_k`` (next point ``x₂``) and ``x₂`` (previous point ``q̃_k``), and node ``k + 1`` takes
  ``x₂`` as its previous point.  A third impact in the same step is not representable;
* look-ahead step: the NLP has ``N + LOOKAHEAD`` steps and only the first ``N`` are reported, and
  the last node force is complementary to the end gap too (``ρ φ(q_L)·h ν_{L−1}``).  The end node
  of an NLP has no successor, so a force there could otherwise "launch" the body into it; with
  the look-ahead every reported node keeps its row, force and successor.

Reported per node: ``Λ_k = h ν_k + (1 − α_k) μ_k + α_{k−1} μ_{k−1}`` (sub-node impulses shared
between their two nodes by the hat-function weights of their time; a second sub-node's likewise), which for a ball is exactly
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

    def __init__(self, cm: ContactMechanics, L: int, h: float, scales, k2=None, held=None, steps=None):
        self.cm, self.L, self.h = cm, L, h
        # step lengths h_k (a grid refined where impacts crowd, see solve.contact.march); h by default
        self.H = np.full(L, float(h)) if steps is None else np.asarray(steps, float).reshape(L)
        n, c = cm.n, cm.c
        ell, pref, vref, aref = scales
        self.scales_p = ell * pref
        self.scales_ell = ell
        self.scales_law = pref * vref
        self.v_zeno = _v_zeno(cm, h, scales)
        # steps with a second sub-node (sorted); empty: the one-sub-node NLP, unchanged
        self.k2 = np.unique(np.asarray([] if k2 is None else k2, dtype=np.int64))
        if self.k2.size and (self.k2[0] < 0 or self.k2[-1] >= L):
            raise ValueError("second sub-node steps out of range")
        # catches that must hold (ContactNLP.loopholes): per step and contact, the law also weighted by
        # φ(q_{k+2})/ℓ; not in the steps with two sub-nodes nor in the last step (no q_{k+2})
        self.held = np.zeros((L, cm.c), dtype=bool)
        if held is not None:
            self.held[:] = np.asarray(held, bool).reshape(L, cm.c)
            self.held[self.k2] = False
            self.held[L - 1] = False
        self.k_next = np.where(np.any(self.held, axis=1))[0]
        # weight length of the law where the guess has no bounce: W = φ(q_{k+1})/δ with δ = ℓ
        # (law_lengths sets a shorter δ at the guess's bounces)
        self.delta = ell
        self.open_gap = max(CLOSING_FRACTION * aref * h * h, 1e-12 * ell)
        self.nlp = nlp = self.program(hessian="exact")
        nlp.variable("q", (L + 1) * n)
        nlp.variable("qs", L * n)
        nlp.variable("beta", L, lb=ALPHA_MIN - 0.5, ub=0.5 - ALPHA_MIN)
        nlp.variable("mu", L * c, lb=0.0)
        nlp.variable("nu", L * c, lb=0.0)
        nlp.variable("s_plus", L * c, lb=0.0)
        nlp.variable("s_minus", L * c, lb=0.0)
        nlp.parameter("p0", n)
        nlp.parameter("rho", 1, value=PENALTY[0])
        # weight of the centred-split term (0 where every β is fixed or timed: a decided branch)
        nlp.parameter("split", 1, value=SPLIT_WEIGHT)
        # weight length of Newton's law per step and contact (law_lengths)
        nlp.parameter("law_length", L * c, value=self.delta)
        Q = nlp.index("q").reshape(L + 1, n)
        S = nlp.index("qs").reshape(L, n)
        B = nlp.index("beta").reshape(L, 1)
        MU = nlp.index("mu").reshape(L, c)
        NU = nlp.index("nu").reshape(L, c)
        SP = nlp.index("s_plus").reshape(L, c)
        SM = nlp.index("s_minus").reshape(L, c)
        Hc = self.H.reshape(-1, 1)
        k = np.arange(L)
        rho = P(nlp.parameter_index("rho"))
        nlp.equal_elements("initial", cm.initial,
                           [X(Q[0]), X(S[0]), X(B[0]), P(nlp.parameter_index("p0")), X(NU[0]), Hc[0]])
        K2 = self.k2
        # steps with one sub-node: the sub-node row and law as in the module docstring
        KN = self.k_next
        k1 = np.setdiff1d(k, np.union1d(K2, KN)) if K2.size or KN.size else k
        # the point before node i: the last sub-node of step i − 1 (its second one in a K2 step)
        S_last, B_last = S.copy(), B.copy()
        if K2.size:
            m2 = K2.size
            nlp.variable("qs2", m2 * n)
            nlp.variable("beta2", m2, lb=ALPHA_MIN - 0.5, ub=0.5 - ALPHA_MIN)
            nlp.variable("mu2", m2 * c, lb=0.0)
            nlp.variable("s_plus2", m2 * c, lb=0.0)
            nlp.variable("s_minus2", m2 * c, lb=0.0)
            nlp.parameter("law_length2", m2 * c, value=self.delta)
            S2 = nlp.index("qs2").reshape(m2, n)
            B2 = nlp.index("beta2").reshape(m2, 1)
            MU2 = nlp.index("mu2").reshape(m2, c)
            SP2 = nlp.index("s_plus2").reshape(m2, c)
            SM2 = nlp.index("s_minus2").reshape(m2, c)
            S_last[K2], B_last[K2] = S2, B2
        if L > 1:
            i = np.arange(1, L)
            nlp.equal_elements("node", cm.node, [X(S_last[i - 1]), X(B_last[i - 1]), X(Q[i]), X(S[i]), X(B[i]),
                                                 X(NU[i]), Hc[i - 1], Hc[i]])
        nlp.equal_elements("sub", cm.sub, [X(Q[k1]), X(S[k1]), X(Q[k1 + 1]), X(B[k1]), X(MU[k1]), Hc[k1]])
        nlp.inequality_elements("node_gap", cm.gap_row, [X(Q[1:])], lb=0.0)
        nlp.inequality_elements("sub_gap", cm.gap_row, [X(S)], lb=0.0)
        LL = P(nlp.parameter_index("law_length").reshape(L, c))
        law_args = [X(Q[k1]), X(S[k1]), X(Q[k1 + 1]), X(B[k1]), X(MU[k1]), X(SP[k1]), X(SM[k1]), Hc[k1],
                    LL if not (K2.size or KN.size) else P(LL.index[k1]), np.array([self.scales_law])]
        nlp.equal_elements("impact_law", cm.law_slack, law_args)
        if KN.size:
            self.kappa = np.where(self.held, 1.0 / ell, 0.0)
            nlp.equal_elements("impact_law_next", cm.law_slack_next,
                               [X(Q[KN]), X(S[KN]), X(Q[KN + 1]), X(Q[KN + 2]), X(B[KN]), X(MU[KN]), X(SP[KN]),
                                X(SM[KN]), Hc[KN], P(LL.index[KN]), self.kappa[KN], np.array([self.scales_law])])
        if K2.size:
            lo, hi = np.array([-0.5]), np.array([0.5])
            LL2 = P(nlp.parameter_index("law_length2").reshape(m2, c))
            # x₁ between q_k and x₂, x₂ between x₁ and q_{k+1}; both laws weighted by φ(q_{k+1})
            nlp.equal_elements("sub_first", cm.sub_g,
                               [X(Q[K2]), X(S[K2]), X(S2), lo, X(B[K2]), X(B2), X(MU[K2]), Hc[K2]])
            nlp.equal_elements("sub_second", cm.sub_g,
                               [X(S[K2]), X(S2), X(Q[K2 + 1]), X(B[K2]), X(B2), hi, X(MU2), Hc[K2]])
            nlp.inequality_elements("sub_gap2", cm.gap_row, [X(S2)], lb=0.0)
            nlp.inequality_elements("sub_order", cm.order, [X(B[K2]), X(B2)], lb=ALPHA_MIN)
            scl = np.array([self.scales_law])
            nlp.equal_elements("impact_law_first", cm.law_slack_g,
                               [X(Q[K2]), X(S[K2]), X(S2), lo, X(B[K2]), X(B2), X(MU[K2]), X(SP[K2]), X(SM[K2]),
                                X(Q[K2 + 1]), Hc[K2], P(LL.index[K2]), scl])
            nlp.equal_elements("impact_law_second", cm.law_slack_g,
                               [X(S[K2]), X(S2), X(Q[K2 + 1]), X(B[K2]), X(B2), hi, X(MU2), X(SP2), X(SM2),
                                X(Q[K2 + 1]), Hc[K2], LL2, scl])
        # exact (l1) penalties: complementarity products and the impact-law slacks
        nlp.minimize_elements("node_penalty", cm.product_penalty, [X(Q[k]), X(NU[k]), rho, ell * pref / Hc])
        nlp.minimize_elements("sub_penalty", cm.product_penalty, [X(S[k]), X(MU[k]), rho, np.array([ell * pref])])
        nlp.minimize_elements("law_penalty", cm.slack_penalty, [X(SP[k]), X(SM[k]), rho])
        nlp.minimize_elements("split", cm.split, [X(B[k]), P(nlp.parameter_index("split"))])
        if K2.size:
            nlp.minimize_elements("sub_penalty2", cm.product_penalty, [X(S2), X(MU2), rho, np.array([ell * pref])])
            nlp.minimize_elements("law_penalty2", cm.slack_penalty, [X(SP2), X(SM2), rho])
        # terminal condition: the last node force may not launch the body (its gap at the end node
        # q_L would otherwise be free; see the module docstring, "Look-ahead step")
        nlp.minimize_elements("end_penalty", cm.product_penalty, [X(Q[L]), X(NU[L - 1]), rho, ell * pref / Hc[L - 1]])

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
        gnext = np.asarray(self.cm.gap_row.map(L)(Q[1:].T)).reshape(c, L).T
        if "bounced" in guess:       # the event-located guess says which impulses are bounces
            bounce = np.asarray(guess["bounced"], bool).reshape(L, c) & (gnext > TOUCH_TOL * self.scales_ell)
        else:                        # an assembled solution: an impulse arriving from flight, leaving
            gnow = np.asarray(self.cm.gap_row.map(L)(Q[:-1].T)).reshape(c, L).T
            tol = TOUCH_TOL * self.scales_ell
            bounce = (MU > 0.0) & (gnext > tol) & (gnow > tol)
        out[bounce] = np.clip(gnext[bounce], self.open_gap, self.delta)
        return out

    def law_lengths2(self, guess) -> np.ndarray:
        """δ of the second sub-nodes' laws (steps ``k2``): as :meth:`law_lengths`, from the guess's
        ``bounced2`` (its second impacts) and next-node gaps; ℓ without them."""
        n, c, L = self.cm.n, self.cm.c, self.L
        out = np.full((self.k2.size, c), self.delta)
        if "q" not in guess or "bounced2" not in guess:
            return out
        Q = np.asarray(guess["q"], float).reshape(L + 1, n)
        gnext = np.asarray(self.cm.gap_row.map(self.k2.size)(Q[self.k2 + 1].T)).reshape(c, -1).T
        bounce = np.asarray(guess["bounced2"], bool).reshape(-1, c) & (gnext > TOUCH_TOL * self.scales_ell)
        out[bounce] = np.clip(gnext[bounce], self.open_gap, self.delta)
        return out

    def loopholes(self, values) -> np.ndarray:
        """Where the residual's unweighted check of Newton's law rejects ``values``, per step and
        contact: an impulse after which the contact is open at node k + 1 or k + 2 (beyond the hop
        a h²/8 of a resting body) whose law misses by more than :data:`LAW_TOL`.  Either the weight
        ``φ(q_{k+1})/δ`` is small there, or the waiver was used for a catch that does not hold
        (closed at node k + 1, open again at k + 2).  Steps with two sub-nodes and the last step are
        left out."""
        raw, leaves = self._raw_law(values)
        out = (np.abs(raw) > LAW_TOL * self.scales_law) & leaves
        out[self.k2] = False
        out[self.L - 1] = False
        return out

    def _raw_law(self, values):
        """Unweighted Newton law ``μ r`` per step and contact (one-sub-node form), and where the body
        leaves after the impulse: one of the next two nodes open by more than the hop of a resting
        body, a h²/8.  Its check holds an impact late in its step (small next-node gap, small
        weight) to the same tolerance, and rejects a "catch" that lifts off again."""
        cm, L, H, c = self.cm, self.L, self.H, self.cm.c
        Q = values["q"].reshape(L + 1, cm.n)
        S = values["qs"].reshape(L, cm.n)
        MU = values["mu"].reshape(L, c)
        B = values["beta"].reshape(L)
        raw, nxt = (np.asarray(v).reshape(c, L).T for v in cm.law_check.map(L)(Q[:-1].T, S.T, Q[1:].T, B, MU.T, H))
        nxt2 = np.vstack([nxt[1:], nxt[-1:]])
        leaves = (nxt > self.open_gap) | (nxt2 > self.open_gap)
        # ... if the contact arrived faster than the grid resolves (v_z = a h / e): a slower arrival
        # would bounce back within two steps, and its plastic catch is the discrete end of an
        # accumulation even where the contact opens again soon after
        ks = np.where(np.any(leaves & (MU > 0), axis=1))[0]
        if ks.size:
            pm = np.asarray(cm.p_minus.map(ks.size)(Q[ks].T, S[ks].T, B[ks], H[ks])).T
            for i, k in enumerate(ks):
                J = np.asarray(cm.system.gap(S[k])[1])
                vn = J @ np.linalg.solve(np.asarray(cm.system.mass_matrix(S[k])), pm[i])
                leaves[k] &= -vn > self.v_zeno
        return raw, leaves

    def _second(self, values):
        """The second sub-nodes' arrays (steps ``k2``): x₂, β₂, μ₂ and, per step, x₁, β₁, μ₁, q_k, q_{k+1}."""
        n, c, K2 = self.cm.n, self.cm.c, self.k2
        m2 = K2.size
        Q = values["q"].reshape(self.L + 1, n)
        return (values["qs2"].reshape(m2, n), values["beta2"].reshape(m2), values["mu2"].reshape(m2, c),
                values["qs"].reshape(self.L, n)[K2], values["beta"].reshape(self.L)[K2],
                values["mu"].reshape(self.L, c)[K2], Q[K2], Q[K2 + 1])

    def _residual2(self, values):
        """Terms of the residual at the steps with two sub-nodes: (|φ(x₂) μ₂|, weighted law, raw law, next gaps)
        over both sub-nodes of those steps, and the raw law of x₁ (which :meth:`residual` replaces)."""
        cm, c, m2 = self.cm, self.cm.c, self.k2.size
        h = self.H[self.k2]
        S2, B2, MU2, S1, B1, MU1, Qk, Qk1 = self._second(values)
        lo, hi = -0.5 * np.ones(m2), 0.5 * np.ones(m2)
        gs2 = np.asarray(cm.gap_row.map(m2)(S2.T)).reshape(c, m2).T
        F = cm.impact_law_g.map(m2)
        w1 = np.asarray(F(Qk.T, S1.T, S2.T, lo, B1, B2, MU1.T, Qk1.T, h, self._law_length[self.k2].T)).reshape(c, m2).T
        w2 = np.asarray(F(S1.T, S2.T, Qk1.T, B1, B2, hi, MU2.T, Qk1.T, h, self._law_length2.T)).reshape(c, m2).T
        G = cm.law_check_g.map(m2)
        raw1, _ = (np.asarray(v).reshape(c, m2).T for v in G(Qk.T, S1.T, S2.T, lo, B1, B2, MU1.T, Qk1.T, h))
        raw2, _ = (np.asarray(v).reshape(c, m2).T for v in G(S1.T, S2.T, Qk1.T, B1, B2, hi, MU2.T, Qk1.T, h))
        return gs2 * MU2, w1, w2, raw1, raw2

    def residual(self, values) -> float:
        """Largest complementarity violation: |φ ν h|, |φ μ| and |μ r| (scaled as in the penalties)."""
        cm, L, H = self.cm, self.L, self.H
        n, c = cm.n, cm.c
        Q = values["q"].reshape(L + 1, n)
        S = values["qs"].reshape(L, n)
        MU = values["mu"].reshape(L, c)
        NU = values["nu"].reshape(L, c)
        B = values["beta"].reshape(L)
        gq = np.asarray(cm.gap_row.map(L)(Q[:-1].T)).reshape(c, L).T
        gs = np.asarray(cm.gap_row.map(L)(S.T)).reshape(c, L).T
        law = np.asarray(cm.impact_law.map(L)(Q[:-1].T, S.T, Q[1:].T, B, MU.T, H,
                                              self._law_length.T)).reshape(c, L).T
        if self.k_next.size:
            KN = self.k_next
            law[KN] = np.asarray(cm.impact_law_next.map(KN.size)(
                Q[KN].T, S[KN].T, Q[KN + 1].T, Q[KN + 2].T, B[KN], MU[KN].T, H[KN], self._law_length[KN].T,
                self.kappa[KN].T)).reshape(c, KN.size).T
        # Newton's law of every impact after which the body leaves, unweighted (_raw_law)
        raw, leaves = self._raw_law(values)
        extra = []
        if self.k2.size:
            # steps with two sub-nodes: x₁'s law has x₂ as its next point (replacing the one-sub-node
            # terms), x₂'s pair and law are added; both are checked when the body leaves after the step
            pair2, w1, w2, raw1, raw2 = self._residual2(values)
            law[self.k2], raw[self.k2] = w1, raw1
            l2 = leaves[self.k2]
            extra = [np.max(np.abs(pair2)) / self.scales_p, np.max(np.abs(w2)) / self.scales_law,
                     (float(np.max(np.abs(raw2[l2]))) if np.any(l2) else 0.0)
                     / self.scales_law * COMPLEMENTARITY_TOL / LAW_TOL]
        raw_max = float(np.max(np.abs(raw[leaves]))) if np.any(leaves) else 0.0
        g_end = np.asarray(cm.gap_row(Q[L])).reshape(-1)
        return float(max(np.max(np.abs(gq * NU * H[:, None])) / self.scales_p, np.max(np.abs(gs * MU)) / self.scales_p,
                         float(np.max(np.abs(g_end * NU[L - 1] * H[L - 1]))) / self.scales_p,
                         np.max(np.abs(law)) / self.scales_law,
                         raw_max / self.scales_law * COMPLEMENTARITY_TOL / LAW_TOL, *extra))
