"""Contact-implicit optimal control: the contact transcription with controls, a cost and boundary conditions.

The program is the initial-value contact program of :mod:`.transcription` (the same node, sub-node, stage
and impact-law rows, the same exact ℓ1 penalties of the complementarity pairs) on ``N`` steps with no
look-ahead, and on top of it, as in DMOC (:mod:`..optimal_control`):

* the controls of step ``k``: one value on both of its parts, or on a scheme with stages a value at each node of
  each part's quadrature (``controls="quadrature"``, :class:`.elements.ContactMechanics`; bounds on the variables),
  in every row that holds the step's forces;
* the running cost, the scheme's quadrature of ``ℓ(q, q̇, u)`` over each part of every step (``[q_k, q̃_k]`` of
  length ``αh``, ``[q̃_k, q_{k+1}]`` of ``(1 − α)h``), and a final cost ``φ(q_N, q̇_N, T)``;
* the end: the given entries of ``q_N`` fixed by bounds; a given final velocity by the end node's momentum
  balance ``p_N⁻ + h(∇φ(q_N)ᵀ + D(q_N)ᵀρ_N)ν_N = p(q_N, q̇_N)``: the end node's contact force ``ν_N ≥ 0``
  (complementary to ``φ(q_N)``, an ℓ1 penalty like every node's) is what lets a body end at rest on a
  surface that pushes it (without it ``p_N⁻ = 0`` would ask the last part of the step to be free of gravity);
* Coulomb friction (planar, one slip component per contact) by maximal dissipation as complementarity: each
  slot's slip velocity ``s`` (the rows :meth:`ContactMechanics.slip` of the initial-value program, whose modes
  there come from the march) splits as ``s/v_ref = s⁺ − s⁻``, ``s± ≥ 0``, with ``(μ_f + ρ) ⟂ s⁺`` and
  ``(μ_f − ρ) ⟂ s⁻`` in the penalty: a slot that slides has its ratio on the cone's edge against its slip, one
  that sticks any ratio inside it.

A point of this program with every penalty term zero is a solution of the contact program under its own
controls: the march of those controls (:mod:`castrajectory.solve.contact.march`) must reproduce it, which
is the certificate (``docs/derivations.md``, "Contact-implicit DMOC").
"""
from __future__ import annotations

from typing import Optional

import casadi as ca
import numpy as np

from ..program import P, X
from .elements import ContactMechanics
from .transcription import ContactTranscription


class ContactControlTranscription(ContactTranscription):
    """One grid of a contact-implicit optimal-control problem (see the module docstring).

    ``T`` the horizon (``h = T/N``); ``scales`` as for :class:`ContactTranscription`; ``end_velocity``: whether
    the final velocity is given (its momentum is the parameter ``pN``); ``running(q, v, u)`` and
    ``final(q, v, T)``: CasADi functions of the costs (``None``: none; ``running(q, v, u, t)``); ``u_bounds``: ``(lo, hi)`` per control;
    ``free_time``: ``(lo, hi)`` of a free final time (the step length ``h`` is then an unknown, ``T`` its guess);
    ``start_velocity``: the initial velocity is an unknown ``v0`` (its given entries fixed by bounds), the initial
    row's momentum ``p(q_0, v0)``.
    """

    def __init__(self, cm: ContactMechanics, N: int, T: float, scales, end_velocity: bool,
                 running: Optional[ca.Function], final: Optional[ca.Function], u_bounds=None, free_time=None,
                 start_velocity: bool = False, path=()):
        self.free_time, self.start_velocity = free_time, start_velocity
        super().__init__(cm, N, T / N, scales, u_bounds=u_bounds)
        self.N, self.T = N, float(T)
        self.scales_v, self.scales_pref = scales[2], scales[1]
        self.end_velocity = end_velocity
        self._launch_and_law()
        self._slip_complementarity()
        if end_velocity:
            self._end_rows()
        self._costs(running, final, path)

    def _control_blocks(self):
        """``(Q, S, B, k, Hc, rho, HA, UA, ZM, ZP)``: the index blocks and arguments the control problem's rows take."""
        Q, S, B = self._blocks()[:3]
        return (Q, S, B, np.arange(self.L), self.H.reshape(-1, 1), P(self.nlp.parameter_index("rho")), self._HA,
                self._UA, self._ZM, self._ZP)

    def _launch_and_law(self) -> None:
        """The launch and the catch pairs, and Newton's law of a bounce, exactly (see the comments)."""
        cm, nlp, L, c, h = self.cm, self.nlp, self.L, self.cm.c, self.h
        vref, pref = self.scales_v, self.scales_pref
        Q, S, B, k, Hc, rho, HA, UA, ZM, ZP = self._control_blocks()
        # a node force acts only on a contact that stays closed through the step's first part: φ(q̃_k) ⟂ ν_k.  (The
        # initial-value program needs no such pair, its march picks the branch; here the cost would otherwise
        # buy a launch: a node force at a closed node that throws the body off, saving the friction of sliding.)
        NU = nlp.index("nu").reshape(L, c)
        # (both factors' scales: φ(q̃_k) of a launch is O(v h), so the product φ ν is scaled by v_ref p_ref: a product
        # scaled as the node pair's, φ h ν/(ℓ p_ref), priced a launch at O(h) and the cost bought it at N = 40)
        # (waived where the node force is an impact at the node itself, the parameter "node_impact": a flight that
        # lands on a node, the march's mode N -- bounces at equal intervals, e = 1, land on nodes)
        nlp.parameter("node_impact", L * c, value=0.0)
        NI = P(nlp.parameter_index("node_impact").reshape(L, c))
        nlp.minimize_elements("launch_penalty", self._catch_penalty(cm),
                              [X(S[k]), X(NU[k]), NI, rho, np.array([vref * pref])])
        nlp.declared_pairs.update({"launch": L * c})
        # Newton's law, and the catch.  Each sub-node impulse is a bounce (the parameter "bounce" 1: a contact that
        # arrives and leaves again, the march's mode I), where Newton's law holds exactly, μ r = 0 (an ℓ1 slack
        # penalty), or else holds the body (resting, or caught: the march's H and C), where the contact is closed
        # again at the next node, φ(q_{k+1}) ⟂ μ_k.  Which impulses are bounces is read from each answer (the solve's
        # timing rounds).  (The initial-value program weighs one law by φ(q_{k+1})/δ for both; here that weight let
        # a late bounce (small next gap) leave with its law violated by 0.11 on the bounce to a target, and a launch
        # from rest by a sub-node impulse met it only weakly, which the cost bought.)  The initial-value program's
        # weighted law stays, with δ = v_ref h (the next node's gap after a bounce; δ = ℓ weighs it by O(h)).
        nlp.parameter("timed", L * c, value=0.0)
        nlp.parameter("bounce", L * c, value=0.0)
        BO = P(nlp.parameter_index("bounce").reshape(L, c))
        MU = nlp.index("mu").reshape(L, c)
        TM = P(nlp.parameter_index("timed").reshape(L, c))
        nlp.minimize_elements("catch_penalty", self._catch_penalty(cm), [X(Q[k + 1]), X(MU[k]), TM, rho,
                                                                         vref * pref * Hc])
        nlp.variable("law_plus", L * c, lb=0.0)
        nlp.variable("law_minus", L * c, lb=0.0)
        REL = P(nlp.parameter_index("release").reshape(L, c))
        nlp.equal_elements("exact_law", self._exact_law(cm),
                           [X(Q[k]), X(S[k]), X(Q[k + 1]), X(B[k]), X(MU[k]), HA(k), self._argument("mul", c)(k),
                            self._argument("fleft", cm.nfl)(k), REL, ZM(k), ZP(k), self._TA(k), UA(k), BO,
                            X(nlp.index("law_plus").reshape(L, c)), X(nlp.index("law_minus").reshape(L, c)),
                            np.array([self.scales_law])])
        nlp.minimize_elements("exact_law_penalty", cm.slack_penalty,
                              [X(nlp.index("law_plus").reshape(L, c)), X(nlp.index("law_minus").reshape(L, c)), rho])
        self.delta = vref * h
        nlp.declared_pairs.update({"exact_law": L * c})
        nlp.declared_pairs.update({"catch": L * c})
        if cm.sc:
            # and a part held at its ends is held at its stages, as the march holds it: a node force holds the first
            # part's stages on the surface, φ(Z⁻_j) ⟂ ν_k, and a sub-node impulse that holds the body the second part's,
            # φ(Z⁺_j) ⟂ μ_k (waived as the launch and the catch pairs are).  (Without them a held part's stage could
            # leave the surface, its force and so its friction zero, the node forces carrying the weight: the block
            # push at N = 20 with galerkin4 hopped so at its first stage, below the cone, a motion the march does not have)
            nlp.minimize_elements("stage_hold_penalty", self._stage_hold_penalty(cm),
                                  [ZM(k), ZP(k), X(NU[k]), X(nlp.index("mu").reshape(L, c)), NI, TM, rho,
                                   np.array([vref * pref])])
            nlp.declared_pairs["stage_hold"] = L * 2 * cm.sc

    def _slip_complementarity(self) -> None:
        """Maximal dissipation as complementarity: the slip split into its signs (planar friction)."""
        cm, nlp, L, c = self.cm, self.nlp, self.L, self.cm.c
        if not cm.friction:
            return
        Q, S, B, k, Hc, rho, HA, UA, ZM, ZP = self._control_blocks()
        vref = self.scales_v
        if cm.fd != 1:
            raise ValueError("contact-implicit optimal control takes planar friction (one slip component)")
        # maximal dissipation as complementarity: the slip split into its signs, s/v_ref = s⁺ − s⁻
        nlp.variable("slip_plus", L * 2 * c, lb=0.0)
        nlp.variable("slip_minus", L * 2 * c, lb=0.0)
        AR = P(nlp.parameter_index("arrive").reshape(L, c))
        nlp.equal_elements("slip_split", self._slip_split(cm, vref),
                           [X(Q[k]), X(S[k]), X(Q[k + 1]), X(B[k]), HA(k), AR, ZM(k), ZP(k),
                            X(nlp.index("slip_plus").reshape(L, 2 * c)),
                            X(nlp.index("slip_minus").reshape(L, 2 * c))])
        if cm.nfz:
            # the stages' friction likewise: a stage's displacement from its part's start (its sticking row, the
            # march's) split into its signs, against the stage's ratio
            nz = cm.nfz
            nlp.variable("stage_slip_plus", L * nz, lb=0.0)
            nlp.variable("stage_slip_minus", L * nz, lb=0.0)
            SP, SM = (X(nlp.index(name).reshape(L, nz)) for name in ("stage_slip_plus", "stage_slip_minus"))
            nlp.equal_elements("stage_slip_split", self._stage_slip_split(cm, vref),
                               [X(Q[k]), X(S[k]), X(Q[k + 1]), X(B[k]), HA(k), ZM(k), ZP(k), SP, SM])
            nlp.minimize_elements("stage_slip_penalty", self._slip_penalty(cm, stages=True),
                                  [X(nlp.index("fstage").reshape(L, nz)), SP, SM, rho])
            nlp.declared_pairs["stage_slip"] = L * 2 * nz
            # and each part's stages slide as its slot does (the march's: one mode per part): a held stage's tangential
            # force at the cone's edge against the slot's slip, (μ_f λ^c_j ± ρ^Z_j λ^c_j) ⟂ s±, the slot the node's for
            # the first part and the sub-node's for the second.  (Without it each stage chose its own branch: a block
            # pushed from rest below the cone slid at N = 20 with galerkin4, its first part's slot forward and a stage's
            # friction pushing it, a motion the march, one mode per part, does not have: certificate 4.9e-3.  Weighted
            # by the stage's normal force, the pair binds only where the contact is held, so a flight whose tangential
            # velocity turns inside a part meets no conflict with the stage pairs above)
            # The converse holds the stages of a part whose slot sticks: a stage's displacement from its part's start
            # against the slot's ratio, (μ_f ± ρ_slot) λ^c_j ⟂ χ±_j.  (Without it a part held at both ends had its
            # stage slide forward and back inside it, its friction at the cone against a quadratic path through the
            # part's ends: the launched block push, galerkin4 at N = 20, stopped with the second part of its stop's
            # step 1.3 mm ahead at its stage and a force of μmg/2 pushing the stuck block, 5.7e-2 above J*, certified,
            # since the march's nodes are the same)
            nlp.minimize_elements("stage_tie_penalty", self._stage_tie_penalty(cm),
                                  [X(nlp.index("lam_cstage").reshape(L, 2 * cm.sc)),
                                   X(nlp.index("fstage").reshape(L, nz)),
                                   X(nlp.index("slip_plus").reshape(L, 2 * c)),
                                   X(nlp.index("slip_minus").reshape(L, 2 * c)),
                                   X(nlp.index("fratio").reshape(L, 2 * c)), SP, SM, rho, Hc / self.scales_pref])
            nlp.declared_pairs["stage_tie"] = L * 4 * nz
        # (an open contact's slot has no force, so its ratio is free: the pair sets it against a flight's slip, and
        # nothing follows from it.  Weighted by the slot's normal force, three factors, the penalty stopped being
        # exact: Ipopt converged with residuals of 0.1-50 on the push to a target, the friction pushing forward)
        nlp.minimize_elements("slip_penalty", self._slip_penalty(cm),
                              [X(nlp.index("fratio").reshape(L, 2 * c)), X(nlp.index("slip_plus").reshape(L, 2 * c)),
                               X(nlp.index("slip_minus").reshape(L, 2 * c)), rho])
        nlp.declared_pairs.update({"slip": L * 4 * c})

    def _end_rows(self) -> None:
        """The end node's contact force and its friction ratio, and the final momentum row (bounds by the final slip:
        :func:`castrajectory.solve.contact.control._end_bounds`)."""
        cm, nlp, L, n, c, h = self.cm, self.nlp, self.L, self.cm.n, self.cm.c, self.h
        Q, S, B, k, Hc, rho, HA, UA, ZM, ZP = self._control_blocks()
        ell, pref = self.scales_ell, self.scales_pref
        # the end node's contact force and its friction ratio (bounds by the final slip: _end_bounds)
        nlp.variable("nu_end", c, lb=0.0)
        if cm.friction:
            nlp.variable("fratio_end", c, lb=-cm.mu_f, ub=cm.mu_f)
        nlp.parameter("pN", n)
        nlp.equal_elements("final_momentum", self._end_row(cm),
                           [X(S[L - 1]), X(B[L - 1]), X(Q[L]), HA(L - 1), X(nlp.index("nu_end")),
                            P(nlp.parameter_index("pN")), X(nlp.index("fratio_end")) if cm.friction else np.zeros(0),
                            ZP(L - 1), self._TA(L - 1), UA(L - 1)])
        nlp.minimize_elements("end_node_penalty", cm.product_penalty,
                              [X(Q[L]), X(nlp.index("nu_end")), rho, np.array([ell * pref / h])])
        nlp.declared_pairs.update({"end_node": c})

    def _costs(self, running, final, path) -> None:
        """The running and final costs, and the path constraints."""
        cm, nlp, L, N = self.cm, self.nlp, self.L, self.N
        Q, S, B, k, Hc, rho, HA, UA, ZM, ZP = self._control_blocks()
        self.running_fn = self._running(cm, running) if running is not None else None
        self.final_fn = self._final(cm, final, N) if final is not None else None
        if running is not None:
            nlp.minimize_elements("running", self.running_fn,
                                  [X(Q[k]), X(S[k]), X(Q[k + 1]), X(B[k]), HA(k), k[:, None] * 1.0, ZM(k), ZP(k), UA(k)])
        # path constraints g(q, u, t) in [lb, ub]: at every node (the control of the step it starts; the last node's
        # its step's) and at every sub-node (its step's control, at its time t_k + αh)
        kn = np.arange(L + 1)
        for j, (fn, lb, ub) in enumerate(path):
            gn, gs = self._path_elements(cm, fn)
            nlp.inequality_elements(f"path{j}", gn, [X(Q[kn]), HA(np.minimum(kn, L - 1)), kn[:, None] * 1.0,
                                                     UA(np.minimum(kn, L - 1))], lb=np.tile(lb, L + 1), ub=np.tile(ub, L + 1))
            nlp.inequality_elements(f"path{j}_sub", gs, [X(S[k]), X(B[k]), HA(k), k[:, None] * 1.0, UA(k)],
                                    lb=np.tile(lb, L), ub=np.tile(ub, L))
        if final is not None:
            nlp.minimize_elements("final", self.final_fn,
                                  [X(S[L - 1]), X(B[L - 1]), X(Q[L]), HA(L - 1), ZP(L - 1), self._TA(L - 1), UA(L - 1)])


    def cost(self, V) -> float:
        """The running and final costs at the values ``V`` (the objective without the penalties)."""
        L, n = self.L, self.cm.n
        Q, S, B = V["q"].reshape(L + 1, n), V["qs"].reshape(L, n), V["beta"].reshape(L)
        zm, zp = self._stages(V)
        U = self._controls(V)
        total = 0.0
        if self.running_fn is not None:
            total += float(np.sum(np.asarray(self.running_fn.map(L)(Q[:-1].T, S.T, Q[1:].T, B, self.steps(V),
                                                                     np.arange(L, dtype=float)[None, :],
                                                                     *[z.T for z in zm + zp], *[u.T for u in U]))))
        if self.final_fn is not None:
            total += float(self.final_fn(S[-1], B[-1], Q[-1], self.steps(V)[-1], *[z[-1] for z in zp],
                                         self.step_starts(self.steps(V))[-1], *[u[-1] for u in U]))
        return total

    # ------------------------------------------------------------------ a free final time, a free start
    def _step_argument(self, nlp, Hc):
        if self.free_time is None:
            return super()._step_argument(nlp, Hc)
        lo, hi = self.free_time
        nlp.variable("h", 1, lb=lo / self.L, ub=hi / self.L, init=self.h)
        hx = X(nlp.index("h"))
        return lambda rows: hx

    def _initial_element(self, nlp):
        if not self.start_velocity:
            return super()._initial_element(nlp)
        cm = self.cm
        f = cm.initial
        ins = [ca.SX.sym(f"a{j}", f.size1_in(j), f.size2_in(j)) for j in range(f.n_in())]
        v0 = ca.SX.sym("v0", cm.n)
        p0 = cm.system.momentum(ins[0], v0)
        fn = ca.Function("c_initial_v", ins[:3] + [v0] + ins[4:], [f(*(ins[:3] + [p0] + ins[4:]))])
        nlp.variable("v0", cm.n)
        return fn, X(nlp.index("v0"))

    def steps(self, values) -> np.ndarray:
        if self.free_time is None:
            return self.H
        return np.full(self.L, float(np.asarray(values["h"]).reshape(-1)[0]))

    def residual(self, values) -> float:
        """The initial-value program's complementarity residual, and this program's own pairs: the launch and
        catch pairs, the friction's slips against their ratios and the end node's force against its gap (each
        scaled as in its penalty)."""
        cm, L, c = self.cm, self.L, self.cm.c
        out = [super().residual(values)]
        g = cm.gaps
        n = cm.n
        Q, S = values["q"].reshape(L + 1, n), values["qs"].reshape(L, n)
        NU, MU = values["nu"].reshape(L, c), values["mu"].reshape(L, c)
        bo = np.asarray(self.nlp.parameter_value("bounce"), float).reshape(L, c)
        out.append(float(np.max(np.abs(bo * self._raw_law(values)[0]))) / self.scales_law)
        tm = np.asarray(self.nlp.parameter_value("timed"), float).reshape(L, c)
        ni = np.asarray(self.nlp.parameter_value("node_impact"), float).reshape(L, c)
        vp = self.scales_v * self.scales_pref          # the launch pair's scale; the catch pair's is v_p h
        out.append(float(np.max(np.abs((1 - ni) * g(S) * NU))) / vp)
        out.append(float(np.max(np.abs((1 - tm) * g(Q[1:]) * MU) / self.steps(values)[:, None])) / vp)
        if cm.sc:       # (the stages against the forces that hold their parts)
            zm, zp = self._stages(values)
            gz = np.asarray(cm.stage_gap.map(L)(*[z.T for z in zm + zp])).T.reshape(L, 2, -1, c)
            out.append(float(np.max(np.abs((1 - ni)[:, None] * gz[:, 0] * NU[:, None]),
                                    initial=0.0)) / vp)
            out.append(float(np.max(np.abs((1 - tm)[:, None] * gz[:, 1] * MU[:, None]), initial=0.0)) / vp)
        if cm.friction:
            r = values["fratio"].reshape(L, 2 * c)
            muf = np.concatenate([cm.mu_f, cm.mu_f])[None, :]
            sp, sm = values["slip_plus"].reshape(L, 2 * c), values["slip_minus"].reshape(L, 2 * c)
            out.append(float(np.max(np.abs((muf + r) * sp) + np.abs((muf - r) * sm))))
            if cm.nfz:
                rz = values["fstage"].reshape(L, cm.nfz)
                mz = cm._stage_mu()[None, :]
                zp_, zm_ = (values[name].reshape(L, cm.nfz) for name in ("stage_slip_plus", "stage_slip_minus"))
                out.append(float(np.max(np.abs((mz + rz) * zp_) + np.abs((mz - rz) * zm_))))
                ties = self._stage_ties(cm, values["lam_cstage"].reshape(L, -1).T, rz.T, sp.T, sm.T, r.T, zp_.T, zm_.T)
                out.append(float(np.max(sum(np.abs(t) for t in ties))) * float(np.max(self.steps(values)))
                           / self.scales_pref)
        if self.end_velocity:
            out.append(float(np.max(np.abs(g(Q[L:]) * values["nu_end"]))) * self.h / self.scales_p)
        return float(max(out))

    # ------------------------------------------------------------------ the elements of the control problem
    @staticmethod
    def _slip_split(cm: ContactMechanics, vref: float) -> ca.Function:
        """``s/v_ref − s⁺ + s⁻`` per slot (node and sub-node of every contact)."""
        sym, n, c = ca.SX.sym, cm.n, cm.c
        qk, qs, qn, b, h, arrive = sym("q", n), sym("qs", n), sym("qn", n), sym("b"), sym("h"), sym("arrive", c)
        zm, zp = sym("zm", cm.s), sym("zp", cm.s)
        sp, sm = sym("sp", 2 * c), sym("sm", 2 * c)
        return ca.Function("c_slip_split", [qk, qs, qn, b, h, arrive, zm, zp, sp, sm],
                           [cm.slip(qk, qs, qn, b, h, arrive, zm, zp) / vref - sp + sm])

    @staticmethod
    def _stage_slip_split(cm: ContactMechanics, vref: float) -> ca.Function:
        """``χ/v_ref − s⁺ + s⁻`` per stage slot (:meth:`ContactMechanics.stage_slips`)."""
        sym, n = ca.SX.sym, cm.n
        qk, qs, qn, b, h = sym("q", n), sym("qs", n), sym("qn", n), sym("b"), sym("h")
        zm, zp = sym("zm", cm.s), sym("zp", cm.s)
        sp, sm = sym("sp", cm.nfz), sym("sm", cm.nfz)
        return ca.Function("c_stage_slip_split", [qk, qs, qn, b, h, zm, zp, sp, sm],
                           [cm.stage_slips(qk, qs, qn, b, h, zm, zp)[0] / vref - sp + sm])

    @staticmethod
    def _stage_hold_penalty(cm: ContactMechanics) -> ca.Function:
        """``ρ Σ_j [(1 − w⁻) φ(Z⁻_j) ν + (1 − w⁺) φ(Z⁺_j) μ] / scale`` per contact: a step's stages against the forces
        that hold its parts (``w⁻`` the impacts at the node, ``w⁺`` the timed arrivals)."""
        sym, c = ca.SX.sym, cm.c
        zm, zp = sym("zm", cm.s), sym("zp", cm.s)
        nu, mu, wn, wt, rho, sc = sym("nu", c), sym("mu", c), sym("wn", c), sym("wt", c), sym("rho"), sym("scale")
        g = cm.stage_gaps(zm, zp)
        half = g.numel() // 2
        total = 0
        for j in range(cm.dm.scheme.stages):
            total = total + ca.dot((1 - wn) * g[j * c:(j + 1) * c], nu) \
                + ca.dot((1 - wt) * g[half + j * c:half + (j + 1) * c], mu)
        return ca.Function("c_stage_hold_pen", [zm, zp, nu, mu, wn, wt, rho, sc], [rho * total / sc])

    @staticmethod
    def _stage_ties(cm: ContactMechanics, lc, rz, sp, sm, rs, zp, zm):
        """The pairs that give each part of a step one friction mode, as the march's parts have, per stage slot:
        ``(μ_f + ρ^Z_j) λ^c_j s⁺_slot``, ``(μ_f − ρ^Z_j) λ^c_j s⁻_slot`` (a stage slides as its part's slot slides) and
        ``(μ_f + ρ_slot) λ^c_j χ⁺_j``, ``(μ_f − ρ_slot) λ^c_j χ⁻_j`` (a stage sticks where its slot sticks: ``χ±`` its
        displacement from the part's start); the first part's stages take the node slot, the second's the sub-node
        slot.  Weighted by the stage's normal force ``λ^c_j``, they bind only where the contact is held."""
        c, st = cm.c, cm.dm.scheme.stages
        muz = cm._stage_mu().reshape(-1, 1)
        if isinstance(lc, ca.SX):
            muz = ca.DM(muz)
        slot = np.concatenate([np.tile(np.arange(c), st) + part * c for part in (0, 1)]).tolist()
        plus, minus, r = sp[slot], sm[slot], rs[slot]
        return ((muz + rz) * lc * plus, (muz - rz) * lc * minus, (muz + r) * lc * zp, (muz - r) * lc * zm)

    @classmethod
    def _stage_tie_penalty(cm_cls, cm: ContactMechanics) -> ca.Function:
        """``ρ w Σ`` of a step's stage-tie pairs (:meth:`_stage_ties`; ``w`` the scale, ``h/p_ref``)."""
        sym = ca.SX.sym
        lc, rz, sp, sm = sym("lc", 2 * cm.sc), sym("rz", cm.nfz), sym("sp", 2 * cm.c), sym("sm", 2 * cm.c)
        rs, zp, zm = sym("rs", 2 * cm.c), sym("zp", cm.nfz), sym("zm", cm.nfz)
        w, sc = sym("rho"), sym("scale")
        ties = cm_cls._stage_ties(cm, lc, rz, sp, sm, rs, zp, zm)
        return ca.Function("c_stage_tie_pen", [lc, rz, sp, sm, rs, zp, zm, w, sc], [w * sc * sum(ca.sum1(t) for t in ties)])

    @staticmethod
    def _slip_penalty(cm: ContactMechanics, stages: bool = False) -> ca.Function:
        """``ρ Σ [(μ_f + r) s⁺ + (μ_f − r) s⁻]`` over a step's slots (``r`` their friction ratios; ``stages``: over its
        stage slots)."""
        sym = ca.SX.sym
        muf = ca.DM(cm._stage_mu() if stages else np.concatenate([cm.mu_f, cm.mu_f]))
        k = muf.numel()
        r, sp, sm, w = sym("r", k), sym("sp", k), sym("sm", k), sym("rho")
        return ca.Function("c_slip_pen", [r, sp, sm, w], [w * (ca.dot(muf + r, sp) + ca.dot(muf - r, sm))])

    @staticmethod
    def _exact_law(cm: ContactMechanics) -> ca.Function:
        """``bounce · μ r / scale − s⁺ + s⁻`` per contact: Newton's law of a bounce, unweighted."""
        f = cm.law_check
        ins = [ca.SX.sym(f"a{j}", f.size1_in(j), f.size2_in(j)) for j in range(f.n_in())]
        sym, c = ca.SX.sym, cm.c
        bo, sp, sm, sc = sym("bounce", c), sym("sp", c), sym("sm", c), sym("scale")
        return ca.Function("c_exact_law", ins + [bo, sp, sm, sc], [bo * f(*ins)[0] / sc - sp + sm])

    @staticmethod
    def _catch_penalty(cm: ContactMechanics) -> ca.Function:
        """``ρ Σ_j (1 − w_j) φ_j(q) λ_j / scale``: a pair waived where ``w`` is 1 (the catch: ``q = q_{k+1}``, ``λ = μ_k``,
        ``w`` the bounces; the launch: ``q = q̃_k``, ``λ = ν_k``, ``w`` the impacts at the node)."""
        sym, c = ca.SX.sym, cm.c
        q, mu, tm, w, sc = sym("q", cm.n), sym("mu", c), sym("bounce", c), sym("rho"), sym("scale")
        return ca.Function("c_catch_pen", [q, mu, tm, w, sc], [w * ca.dot((1 - tm) * cm.system.gap(q)[0], mu) / sc])

    @staticmethod
    def _end_row(cm: ContactMechanics) -> ca.Function:
        """``(p_N⁻ + h(∇φ(q_N)ᵀ + D(q_N)ᵀρ_N)ν_N − p_N)/h``: the end node's momentum balance."""
        sym, n, c = ca.SX.sym, cm.n, cm.c
        qs, b, q, h, nu, pN = sym("qs", n), sym("b"), sym("q", n), sym("h"), sym("nu", c), sym("pN", n)
        r = sym("r", c if cm.friction else 0)    # the end node's friction ratios (none without friction)
        zp, t, u = sym("zp", cm.s), sym("t"), cm._U        # (t: the last step's start)
        pm = cm.p_node_minus(qs, b, q, h, zp, t, u)
        J = cm.system.gap(q)[1]
        imp = ca.mtimes(J.T, nu)
        if cm.friction:
            imp = imp + ca.mtimes(cm.system.tangent(q).T, r * nu)
        return ca.Function("c_end", [qs, b, q, h, nu, pN, r, zp, t, u], [(pm + h * imp - pN) / h])

    @staticmethod
    def _running(cm: ContactMechanics, running: ca.Function) -> ca.Function:
        """The scheme's quadrature of ``ℓ(q, q̇, u, t)`` over both parts of a step ``k`` (its input, as a number: the
        parts start at ``t_k = k h`` and ``t_k + αh``)."""
        sym, n, s = ca.SX.sym, cm.n, cm.s
        st = cm.dm.scheme
        qk, qs, qn, b, h, kk = sym("q", n), sym("qs", n), sym("qn", n), sym("b"), sym("h"), sym("k")
        zm, zp = sym("zm", s), sym("zp", s)
        u = cm._U
        a = 0.5 + b
        # (each part's quadrature node with its control: the step's one value, or the part's own per node)
        f = [cm.dm.control_at(lambda q, v, t, uu: running(q, v, uu, t), cm.part_controls(u, part)) for part in (0, 1)]
        parts = [[qk] + [zm[j * n:(j + 1) * n] for j in range(st.stages)] + [qs],
                 [qs] + [zp[j * n:(j + 1) * n] for j in range(st.stages)] + [qn]]
        tk = kk * h
        val = st.discrete_lagrangian(f[0], parts[0], a * h, tk) + st.discrete_lagrangian(f[1], parts[1], (1 - a) * h,
                                                                                         tk + a * h)
        return ca.Function("c_running", [qk, qs, qn, b, h, kk, zm, zp, u], [val])

    @staticmethod
    def _path_elements(cm: ContactMechanics, fn: ca.Function):
        """``g(q_k, u, k h)`` at a node and ``g(q̃_k, u_k, (k + ½ + β) h)`` at a sub-node (controls per part: the step's
        first part's at its start, the second part's at its start)."""
        sym, n = ca.SX.sym, cm.n
        q, b, h, k = sym("q", n), sym("b"), sym("h"), sym("k")
        u = cm._U
        return (ca.Function("c_path", [q, h, k, u], [fn(q, cm.instant_control(u, 0, 0.0), k * h)]),
                ca.Function("c_path_sub", [q, b, h, k, u], [fn(q, cm.instant_control(u, 1, 0.0), (k + 0.5 + b) * h)]))

    @staticmethod
    def _final(cm: ContactMechanics, final: ca.Function, N: int) -> ca.Function:
        """``φ(q_N, q̇_N, T)``, ``q̇_N = M⁻¹p_N⁻`` (the last part's momentum; no holonomic constraints here)."""
        sym, n, s = ca.SX.sym, cm.n, cm.s
        qs, b, q, h = sym("qs", n), sym("b"), sym("q", n), sym("h")
        zp, t, u = sym("zp", s), sym("t"), cm._U          # (t: the last step's start)
        v = ca.solve(cm.system.mass_matrix(q), cm.p_node_minus(qs, b, q, h, zp, t, u))
        return ca.Function("c_final", [qs, b, q, h, zp, t, u], [final(q, v, N * h)])
