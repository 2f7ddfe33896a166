"""CasADi element functions of the contact transcription, for one system and any scheme.

:class:`ContactMechanics` builds, once per system and scheme, every small function the contact
program is made of: the initial, node and sub-node momentum rows, the stage rows, gaps, Newton's impact
law (weighted and with its ℓ1 slacks), the penalty terms, the sub-node momenta, and the RK4 flow
used by the event-located guess.  The rows they form are :mod:`.transcription`; the
derivation is ``docs/derivations.md``, "Contact trajectories".

Every scheme: a step is split at its sub-node ``q̃_k`` into two parts, ``[q_k, q̃_k]`` of length ``αh`` and
``[q̃_k, q_{k+1}]`` of length ``(1 − α)h``, and each part is one step of the scheme with its own stages
(``Z⁻_k`` and ``Z⁺_k``, ``stages · n`` values each; none for midpoint and trapezoid, whose element functions
are then exactly the two-point ones).  An impact at the sub-node therefore sits between two smooth
pieces, each integrated at the scheme's order.
"""
from __future__ import annotations

from types import SimpleNamespace
from typing import Dict

import casadi as ca
import numpy as np

from ...models.mechanics import LagrangianSystem
from ...validation import InputError
from ..lagrangians import GUESS_SUBSTEPS, DiscreteMechanics, rk4_step
from . import forces


#: Weight of Σβ² (the split of impact-free steps), far below the penalties.
SPLIT_WEIGHT = 1e-6


class ContactMechanics:
    """CasADi element functions of the contact transcription for one system and scheme."""

    def __init__(self, system: LagrangianSystem, scheme: str, controls: str = "step"):
        if system.contact is None:
            raise ValueError("the system has no contact term")
        if system.time_dependent:
            raise InputError("contact with a time-dependent system is not supported yet; remove the time from the "
                             "contact scene")
        dm = DiscreteMechanics(system, scheme, control_points="step")
        #: the controls of a step: one value for both parts ("step"), or with ``controls="quadrature"`` on a scheme with
        #: stages one at each node of each part's quadrature (the first part's, then the second's), so that the
        #: forces' and the cost's quadratures keep the scheme's order on each part, a step split at an event included
        self.per_part = controls == "quadrature" and bool(dm.s) and bool(dm.nu)
        if self.per_part:
            dm = DiscreteMechanics(system, scheme, control_points="quadrature")
        self.system, self.dm = system, dm
        self._derived: Dict[str, object] = {}
        self.n, self.c, self.e = dm.n, system.ncontact, system.contact.restitution
        #: stage values per part of a step (each step has two parts, split at its sub-node), and the
        #: constraint multipliers at those stages (none for the two-point schemes)
        self.s = dm.s
        self.ms = dm.scheme.stages * dm.m if self.s else 0
        #: the contact forces at the stages of each part of a step, one per stage and contact (none for the two-point
        #: schemes): a contact held through a part has its gap closed at the part's stages and its force there
        #: (stage_rows), as the holonomic constraints have theirs
        self.sc = dm.scheme.stages * self.c if self.s else 0
        #: the two-point functions of the event-located guess (the fallback's guess flies with RK4 and holds
        #: contacts with the midpoint's rows; the stages then start on the straight lines, stage_guess)
        self.guide = self if not self.s else ContactMechanics(system, "midpoint")
        self._z = ca.SX(0, 1)       # the stages of a two-point scheme's part: none
        self._constraints()
        self._momenta()
        self._friction_sizes()
        x = self._symbols()
        self._kinematics = lambda xp, xx, xn, tau_m, tau_p, Zm, Zp: _sub_node_kinematics(  # noqa: E731
            lambda *a: self._D1(*a, part=1), self._D2, self._J, system.mass_matrix, self._C, self.e, xp, xx, xn, tau_m,
            tau_p, Zm, Zp, self._t)
        self._step_rows(x)
        self._friction_functions(x)
        self._law_rows(x)
        self._objective_functions()
        self._momentum_functions(x)
        if not self.s and not self.nu:
            self._guess_functions(x)
        # the contact forces of the continuous motion (the timing of a release or a stick's end, .forces)
        self.forces = forces.held_forces(self)
        self.contact_forces, self.held_force = self.forces.contact_forces, self.forces.held_force
        self.cone_margin, self.timed_force = self.forces.cone_margin, self.forces.timed_force
        self._march_function(x.phi)
        self.node_law_fn = ca.Function("c_node_law", [x.p0, x.qk, x.qs, x.b, x.h, x.zm, x.t, x.U],
                                       [self.node_law(x.p0, x.qk, x.qs, x.b, x.h, x.zm)])
        self._normal_acceleration(x)

    def _constraints(self) -> None:
        """Holonomic constraints ``c(q) = 0`` (``m`` of them; multipliers at the nodes and the sub-nodes): their row and
        their Jacobian ``C(q)`` (no rows without)."""
        n, m = self.n, self.dm.m
        self.m = m
        cfun = self.system.constraint if m else None
        self._C = (lambda q: cfun(q)[1]) if m else (lambda q: ca.SX(0, n))  # noqa: E731
        qc = ca.SX.sym("qc", n)
        self.constraint_row = ca.Function("c_con", [qc], [cfun(qc)[0] if m else ca.SX(0, 1)])

    def _momenta(self) -> None:
        """The time, the controls and the discrete momenta of a part of a step.

        Time: every element that holds a step's dynamics takes the step's start ``t_k`` (its first part starts there,
        its second at ``t_k + αh``; the node row's previous part at ``t_k − (1 − α_{k−1})h_{k−1}``), the input before
        the controls.  A contact system is time-independent (refused above), so no element reads it: the signature is
        the discrete mechanics' (:class:`~castrajectory.discretise.lagrangians.DiscreteMechanics`), and callers pass
        the steps' start times.

        Controls (optimal control through contact): the step's control values ``u_k``, the last input of every element
        whose rows hold the forces of a step, zero-size without controls (one signature: a caller passes the step's
        controls, an empty column for a scene without them, and the program is the same); the node row holds the
        forces of two steps, ``u_{k−1}`` and ``u_k``.  One value for both parts, or per part (:attr:`per_part`) a value
        at each node of each part's quadrature, the first part's block then the second's (:meth:`part_controls`; the
        index-1 system's control at a point of a part: :meth:`instant_control`).  With forces (Force, Damping;
        no time) the discrete Lagrange–d'Alembert momenta over each part of a step, ``p⁺ = −D₁L_d − f⁻`` and
        ``p⁻ = D₂L_d + f⁺``, stand where ``D₁L_d`` and ``D₂L_d`` stand without them."""
        dm = self.dm
        self.nu1 = dm.nu1
        self.nu = 2 * dm.nu if self.per_part else dm.nu
        U = self._U = ca.SX.sym("u", self.nu)
        self._t = ca.SX.sym("t")
        # (a, Z, b, the part's length, the part's start time[, the step's controls, the part: 0 the first, 1 the second])
        if self.system.forced:
            self._D1 = lambda a, Z, b, tau, t0, u=U, part=0: -dm.p_plus(  # noqa: E731
                a, Z, b, tau, t0, self.part_controls(u, part))
            self._D2 = lambda a, Z, b, tau, t0, u=U, part=0: dm.p_minus(  # noqa: E731
                a, Z, b, tau, t0, self.part_controls(u, part))
        else:
            self._D1 = lambda a, Z, b, tau, t0, u=None, part=0: dm.D1(a, Z, b, tau, t0)  # noqa: E731
            self._D2 = lambda a, Z, b, tau, t0, u=None, part=0: dm.D2(a, Z, b, tau, t0)  # noqa: E731
        self._J = lambda q: self.system.gap(q)[1]  # noqa: E731

    def part_controls(self, u, part: int):
        """The controls of one part of a step (0 the first, 1 the second) from the step's ``u``: the part's block of
        values at its quadrature nodes (per part), or the step's one value."""
        if not self.per_part:
            return u
        k = self.dm.nu
        return u[part * k:(part + 1) * k]

    def instant_control(self, u, part: int, tau: float):
        """The control at the fraction ``tau`` of a part of a step (per part: the Lagrange interpolant of the part's
        values at its quadrature nodes; the step's one value otherwise): the control of the continuous motion's
        index-1 system there."""
        if not self.per_part:
            return u
        c, k = np.asarray(self.dm.scheme.nodes, float), self.nu1
        v = self.part_controls(u, part)
        w = [float(np.prod([(tau - c[m]) / (c[i] - c[m]) for m in range(c.size) if m != i])) for i in range(c.size)]
        return sum(w[i] * v[i * k:(i + 1) * k] for i in range(c.size))

    def control_times(self, t0, h, beta) -> np.ndarray:
        """The times of each step's control values, ``(N, values)``: the step's midpoint for one value per step; per
        part, the nodes of each part's quadrature (``t0`` the steps' starts, ``h`` their lengths, ``beta`` their
        splits)."""
        t0, h, beta = (np.asarray(x, float).reshape(-1) for x in (t0, h, beta))
        if not self.per_part:
            return (t0 + 0.5 * h)[:, None]
        c = np.asarray(self.dm.scheme.nodes, float)[None, :]
        a = (0.5 + beta)[:, None] * h[:, None]
        return np.hstack([t0[:, None] + a * c, t0[:, None] + a + (h[:, None] - a) * c])

    def _friction_sizes(self) -> None:
        """Coulomb friction, only where a coefficient is positive (a frictionless system keeps its rows and element
        functions exactly): the tangential force is ρ times the normal one, at the node (ρ ν) and at the sub-node (ρ μ),
        ``|ρ| ≤ μ_f``; see :meth:`node_row`, :meth:`sub_row` and :meth:`slip`."""
        system, c = self.system, self.c
        self.mu_f = np.asarray(system.contact.friction, float)
        self.friction = bool(np.any(self.mu_f > 0))
        self._D = system.tangent if self.friction else None
        #: components of each contact's slip: 1 in the plane, 2 on a tangent plane in 3-D (the isotropic cone)
        self.fd = d = system.contact.slip_dim if self.friction else 1
        #: entries of a step's friction ratios [ρ_node; ρ_sub] and of its first part's closing ratios (none without
        #: friction)
        self.nfr, self.nfl = (2 * c * d, c * d) if self.friction else (0, 0)
        #: friction slots per step, two per contact (node force, sub-node impulse; none without friction)
        self.nfs = 2 * c if self.friction else 0
        #: the friction ratios at the stages of both parts of a step, per stage, contact and component (ρ^Z: the
        #: tangential force ρ^Z λ^c at a held contact's stage; none without friction or stages)
        self.nfz = 2 * self.sc * d if self.friction else 0
        if self.s:
            self._cdot, self._aint = _control_quadrature(self.dm.scheme)

    def _symbols(self) -> SimpleNamespace:
        """The symbols of the element functions, one namespace for the methods that build them."""
        n, c, m, s, sym = self.n, self.c, self.m, self.s, ca.SX.sym
        gapf = self.system.gap
        x = SimpleNamespace(phi=lambda q: gapf(q)[0], U=self._U, Um=sym("um", self.nu), t=self._t)
        x.q0, x.qk, x.qs, x.qsm, x.qk1 = sym("q0", n), sym("q", n), sym("qs", n), sym("qsm", n), sym("qk1", n)
        x.b, x.bm, x.h, x.hp = sym("beta"), sym("betam"), sym("h"), sym("hp")
        x.mu, x.nu, x.p0 = sym("mu", c), sym("nu", c), sym("p0", n)
        # constraint forces −C(q)ᵀλ at the nodes and −C(q̃)ᵀλ̃ at the sub-nodes (the sign of the smooth
        # transcription's DEL rows); λ, λ̃ are inputs of every element that holds them, with no entries without
        # constraints (one signature: a caller passes an empty column, and the rows are the same)
        x.lam, x.lams = sym("lam", m), sym("lams", m)
        # the held contacts' forces at the stages of the step's two parts (none for a two-point scheme), and their
        # friction ratios (none without friction)
        x.lc, x.rz = sym("lamc", 2 * self.sc), sym("rhoz", self.nfz)
        x.a, x.am = 0.5 + x.b, 0.5 + x.bm
        # the stages of the step's two parts (Z⁻ on [q_k, q̃_k], Z⁺ on [q̃_k, q_{k+1}]) and of the previous
        # step's second part (Z⁺_{k−1}, for the node row): inputs of every element, empty for a two-point scheme
        x.zm, x.zp, x.zpm = (sym(nm, s) for nm in ("zm", "zp", "zpm"))
        # two ratios per contact and step, [ρ_node; ρ_sub] (each with d components): the node's force ν and the
        # sub-node's impulse μ each carry their own friction, against the slip of their own part of the step (slip);
        # an input of every element that holds them, with no entries without friction (like λ above)
        x.rho = sym("rho", self.nfr)
        cd = c * self.fd
        x.frn, x.frs = (x.rho[:cd], x.rho[cd:]) if self.friction else (None, None)
        # the sub-node's impulse from the first part, μ⁻ with its ratios ρ⁻ (0 but where the march's modes set it): a
        # contact released at an impact's sub-node takes there its share of its force over the first part
        # (release_row), and an arrival caught with friction there takes Stronge's impulse; μ is then the second
        # part's (see sub_row).  (rel: 1 for the contacts released at the step's impact, whose μ⁻ are shares)
        x.mul, x.rl, x.rel = sym("mul", c), sym("rl", self.nfl), sym("rel", c)
        x.rll = x.rl if self.friction else None
        x.left = [x.mul, x.rl, x.rel]
        return x

    def _step_rows(self, x) -> None:
        """Every node and sub-node row of the program (the held step's and the march's are the same :meth:`node_row`
        and :meth:`sub_row`), the release rows and the stage rows."""
        D1, D2 = self._D1, self._D2
        qk, qs, qk1, b, h, zm, zp, t, U = x.qk, x.qs, x.qk1, x.b, x.h, x.zm, x.zp, x.t, x.U
        self.initial = ca.Function("c_initial", [x.q0, qs, b, x.p0, x.nu, h, x.lam, x.rho, zm, t, U],
                                   [self.node_row(x.p0, x.q0, qs, b, x.nu, x.lam, h, x.frn, zm)])
        self.node = ca.Function("c_node", [x.qsm, x.bm, qk, qs, b, x.nu, x.hp, h, x.lam, x.rho, x.zpm, zm, t, x.Um, U],
                                [self.node_row(D2(x.qsm, x.zpm, qk, (1 - x.am) * x.hp, t - (1 - x.am) * x.hp, x.Um, part=1),
                                               qk, qs, b, x.nu, x.lam, h, x.frn, zm)])
        sub_row, x.r = self.sub_row(qk, qs, qk1, b, x.mu, x.lams, h, x.frs, zm, zp, x.mul, x.rll, x.rel)
        # the momenta on either side of q̃
        x.pm, x.pp = D2(qk, zm, qs, x.a * h, t), -D1(qs, zp, qk1, (1 - x.a) * h, t + x.a * h, part=1)
        self.sub = ca.Function("c_sub", [qk, qs, qk1, b, x.mu, h, x.mul, x.rl, x.lams, x.rho, zm, zp, t, U], [sub_row])
        #: the contacts' normal velocities at the sub-node before its impact, after the released contacts' shares
        self.release = ca.Function("c_release", [qk, qs, b, h] + x.left + [zm, t, U],
                                   [self.release_row(qk, qs, b, h, x.mul, x.rll, x.rel, zm)])
        if self.friction:
            #: ... and the slip velocities there (against which a released contact's share sticks or slides)
            self.left_slip = ca.Function("c_left_slip", [qk, qs, b, h] + x.left + [zm, t, U],
                                         [self.left_velocity(qk, qs, b, h, x.mul, x.rll, x.rel, zm)])
        if self.s:
            #: the stage rows of both parts of a step (stage_rows) and the constraints at their stages
            lz = ca.SX.sym("lamz", 2 * self.ms)
            self.stage = ca.Function("c_stage", [qk, qs, qk1, b, h, zm, zp, lz, x.lc, x.rz, t, U],
                                     [self.stage_rows(qk, qs, qk1, b, h, zm, zp, lz, x.lc, x.rz)])
            if self.m:
                self.stage_constraint = ca.Function("c_stage_con", [zm, zp], [self.stage_constraints(zm, zp)])
            #: the gaps at the stages of both parts, ``[φ(Z⁻_j); φ(Z⁺_j)]`` (stage by stage, each with its contacts)
            self.stage_gap = ca.Function("c_stage_gap", [zm, zp], [self.stage_gaps(zm, zp)])
            #: ... and the rows that hold a contact there (:meth:`stage_holds`)
            self.stage_hold = ca.Function("c_stage_hold", [qk, qs, qk1, zm, zp], [self.stage_holds(qk, qs, qk1, zm, zp)])
            rho_p, scale = ca.SX.sym("rho"), ca.SX.sym("scale")
            #: ``ρ Σ_j φ(Z_j)·λ^c_j / scale``: the stages' complementarity penalty
            self.stage_penalty = ca.Function("c_stage_pen", [zm, zp, x.lc, rho_p, scale],
                                             [rho_p * ca.dot(self.stage_gaps(zm, zp), x.lc) / scale])

    def _friction_functions(self, x) -> None:
        """The slip velocities the friction opposes, [node part; sub-node part] (:meth:`slip`), and on a tangent plane
        the isotropic cone's rows for the certificate: ``μ_f² − |ρ|² ≥ 0`` per slot, and sliding's
        ``ρ + μ_f s/|s| = 0`` per component (:meth:`friction_rows`)."""
        if not self.friction:
            return
        c, d = self.c, self.fd
        qk, qs, qk1, b, h, rho = x.qk, x.qs, x.qk1, x.b, x.h, x.rho
        arrive = ca.SX.sym("arrive", c)
        zm, zp = x.zm, x.zp
        self.slip_row = ca.Function("c_slip", [qk, qs, qk1, b, h, arrive, zm, zp],
                                    [self.slip(qk, qs, qk1, b, h, arrive, zm, zp)])
        if self.s:
            #: at the stages of both parts: the contact point's displacement from its part's start over the part's
            #: length (a sticking stage's row), and its slip velocity there (a sliding stage's direction), each
            #: ``2 · stages · c · d`` (:meth:`stage_slips`)
            chi, vel = self.stage_slips(qk, qs, qk1, b, h, zm, zp)
            self.stage_slip_row = ca.Function("c_stage_slip", [qk, qs, qk1, b, h, zm, zp], [chi])
            self.stage_vel_row = ca.Function("c_stage_vel", [qk, qs, qk1, b, h, zm, zp], [vel])
            if d == 2:
                one = ca.DM.ones(2 * self.sc)
                muz = self._stage_mu()
                self.stage_cone_row = ca.Function("c_stage_cone", [x.rz], [ca.DM(muz ** 2) - ca.transpose(
                    ca.sum1(ca.reshape(x.rz, d, -1) ** 2))])
                self.stage_slide_row = ca.Function("c_stage_slide", [qk, qs, qk1, b, h, zm, zp, x.rz], [
                    self.friction_rows(vel, x.rz, 0 * one, one, 0 * one, ca.DM.zeros(self.nfz), 1.0, muz)])
        if d == 2:
            R2 = ca.reshape(rho, d, -1)
            muf2 = np.concatenate([self.mu_f, self.mu_f])
            self.cone_row = ca.Function("c_cone", [rho], [ca.DM(muf2 ** 2) - ca.transpose(ca.sum1(R2 * R2))])
            one = ca.DM.ones(2 * c)
            self.slide_row = ca.Function("c_slide", [qk, qs, qk1, b, h, arrive, zm, zp, rho], [self.friction_rows(
                self.slip(qk, qs, qk1, b, h, arrive, zm, zp), rho, 0 * one, one, 0 * one, ca.DM.zeros(2 * c * d), 1.0)])

    def _law_rows(self, x) -> None:
        """Newton's law on the normal velocity at the sub-node, weighted by ``W = φ(q_{k+1})/δ``: the law holds unless
        the contact is closed again at the next node, where the body is caught (the accumulation point of Zeno
        bouncing, where no step-resolved flight is left, or a body at rest).  δ is a parameter per step and contact
        (:meth:`ContactNLP.law_lengths`): ℓ, or for a bounce of the guess its next-node gap, so that ``W ≈ 1`` also
        for a bounce late in its step.  (A global small δ, ℓ/100 or a saturating W with δ = a h²/8, made Ipopt fail on
        the bowl and on a grazing corner.)  The unweighted law of every real impact is checked separately
        (:meth:`ContactNLP.residual`, :attr:`law_check`); the gap and pair rows; the split's weight."""
        qk, qs, qk1, b, mu, h, phi = x.qk, x.qs, x.qk1, x.b, x.mu, x.h, x.phi
        ell = ca.SX.sym("delta", self.c)
        self.impact_law, self.law_slack = self._law_functions(
            "", [qk, qs, qk1, b, mu], [h, ell] + x.left + [x.zm, x.zp], mu * x.r * phi(qk1) / ell, [x.t, x.U])
        # the unweighted law and the next node's gaps, for the residual of real (not caught) impacts
        self.law_check = ca.Function("c_law_check", [qk, qs, qk1, b, mu, h] + x.left + [x.zm, x.zp, x.t, x.U],
                                     [mu * x.r, phi(qk1)])
        self.pair = ca.Function("c_pair", [qk, x.nu], [ca.vertcat(phi(qk), x.nu)])
        self.gap_row = ca.Function("c_gap", [qk], [phi(qk)])
        w = ca.SX.sym("w")
        self.split = ca.Function("c_split", [b, w], [w * b * b])

    def _momentum_functions(self, x) -> None:
        """The momenta either side of a sub-node (``p_minus``, ``p_plus``) and at the nodes (``p_node_plus``,
        ``p_node_minus``)."""
        D1, D2, t, U, h = self._D1, self._D2, x.t, x.U, x.h
        self.p_minus = ca.Function("p_minus_sub", [x.qk, x.qs, x.b, h, x.zm, t, U], [x.pm])
        self.p_plus = ca.Function("p_plus_sub", [x.qs, x.qk1, x.b, h, x.zp, t, U], [x.pp])
        self.p_node_plus = ca.Function("p_node_plus", [x.qk, x.qs, x.b, h, x.zm, t, U],
                                       [-D1(x.qk, x.zm, x.qs, x.a * h, t)])
        # (the step's second part, from its sub-node to the node that ends it: t is the step's start)
        self.p_node_minus = ca.Function("p_node_minus", [x.qsm, x.bm, x.qk, h, x.zp, t, U],
                                        [D2(x.qsm, x.zp, x.qk, (1 - x.am) * h, t + x.am * h, part=1)])

    def _guess_functions(self, x) -> None:
        """The event-located guess's functions (a two-point scheme without controls; a scheme with stages guesses with
        its guide's, the midpoint's).

        A held step (α = ½): the node row with the incoming momentum p, the sub-node row, and, for the contacts held
        (mask 1), both gaps closed; the others' force and impulse pinned to 0.  Square in (q̃, q_{k+1}, ν, μ): the
        discrete motion with the held contacts as constraints (``docs/derivations.md``, "Contact trajectories", §5,
        "Held contacts").  A free sub-node (no impact, α = ½): its Newton function.  The RK4 flow over τ with
        ``GUESS_SUBSTEPS`` substeps."""
        n, sym, phi = self.n, ca.SX.sym, x.phi
        qk, qs, qk1, nu, mu, h, p0 = x.qk, x.qs, x.qk1, x.nu, x.mu, x.h, x.p0
        mask = sym("mask", self.c)
        xh = ca.vertcat(qs, qk1, nu, mu)
        zm0 = ca.SX.zeros(self.m)
        Rh = ca.vertcat(self.node_row(p0, qk, qs, 0.0, nu * mask, zm0, h),
                        self.sub_row(qk, qs, qk1, 0.0, mu * mask, zm0, h)[0],
                        mask * phi(qs) + (1 - mask) * mu, mask * phi(qk1) + (1 - mask) * nu)
        self.held_step = ca.Function("held_step", [xh, qk, p0, mask, h, x.t], [Rh, ca.jacobian(Rh, xh)])
        z = ca.SX(0, 1)
        F = self._D2(qk, z, qs, 0.5 * h, x.t) + self._D1(qs, z, qk1, 0.5 * h, x.t + 0.5 * h, part=1)
        self.free_sub = ca.Function("free_sub", [qk, qs, qk1, h, x.t], [F, ca.jacobian(F, qs)])
        v, tau = sym("v", n), sym("tau")
        acc = self.system.acceleration
        y, dt = ca.vertcat(qk, v), tau / GUESS_SUBSTEPS
        f = lambda y: ca.vertcat(y[n:], acc(y[:n], y[n:]))  # noqa: E731
        for _ in range(GUESS_SUBSTEPS):
            y = rk4_step(f, y, dt)
        self.flow = ca.Function("flow", [qk, v, tau], [y[:n], y[n:], phi(y[:n])])
        self._flights: Dict[int, ca.Function] = {}

    def _normal_acceleration(self, x) -> None:
        """The contacts' normal accelerations ``J(q) q̈`` (under the step's control: the march's test of an arrival at a
        node)."""
        system, J, U, qk = self.system, self._J, x.U, x.qk
        v = ca.SX.sym("v", self.n)
        if not self.nu:
            acc = system.acceleration
            self.acc_normal = self.guide.acc_normal if self.s else ca.Function(
                "acc_normal", [qk, v, U], [ca.mtimes(J(qk), acc(qk, v))])
        else:
            # (the control at the step's start: the march tests an arrival at its node)
            qdd = ca.substitute(system._index1_exprs()[0], system.control_vector, self.instant_control(U, 0, 0.0))
            acc = ca.Function("qdd_u", [system.q, system.qd, U], [qdd])
            self.acc_normal = ca.Function("acc_normal", [qk, v, U], [ca.mtimes(J(qk), acc(qk, v, U))])

    # ------------------------------------------------------------------ stages
    def derived(self, key: str, build):
        """What the layers above derive from these functions once (the compiled march step, its chunks), built by
        ``build()`` on first use and kept with them."""
        if key not in self._derived:
            self._derived[key] = build()
        return self._derived[key]

    def stage_guess(self, Q, S) -> np.ndarray:
        """Stages ``(L, 2s)`` on the straight lines of each step's parts, ``q_k → q̃_k`` and ``q̃_k → q_{k+1}``
        (``Q`` the ``L + 1`` nodes, ``S`` the ``L`` sub-nodes), at the scheme's stage times."""
        Q, S = np.atleast_2d(Q), np.atleast_2d(S)
        st = self.dm.scheme
        return np.hstack([st.stage_guess(Q[:-1], S), st.stage_guess(S, Q[1:])])

    def stage_parts(self, Z):
        """``([Z⁻], [Z⁺])`` of stage rows ``Z`` (``(…, 2s)``): the arguments the element functions take
        (of no column for a two-point scheme)."""
        Z = np.asarray(Z)
        return [Z[..., :self.s]], [Z[..., self.s:]]

    def stage_rows(self, qk, qs, qn, b, h, zm, zp, lz, lc, rz=None):
        """The stationarity of the action in the stages of both parts of a step, with the forces on the
        stages, the constraint forces and the held contacts' forces there: each part's
        ``(∂L_d/∂Z + f^Z)/h − (τ/h) w_j ∇c(Z_j)ᵀν_j + (τ/h) w_j ∇φ(Z_j)ᵀλ^c_j``
        (:attr:`DiscreteMechanics.stage_residual`, over the part's length τ, scaled by τ/h so every
        row of a step is a momentum per ``h``; ``w_j`` the constraint quadrature's weight of stage j).  ``λ^c_j ≥ 0``
        is the contact's force at the stage: the scheme's quadrature of its virtual work ``∫ λ ∇φ(q)·δq dt`` over a
        part that holds it, whose ends carry the node force ν and the sub-node's impulse μ (``docs/derivations.md``,
        "Held contacts at the stages").  With friction ``rz`` holds the ratios ``ρ^Z_j`` of the tangential forces
        there, ``w_j D(Z_j)ᵀ(ρ^Z_j λ^c_j)``."""
        a, ms, sc = 0.5 + b, self.ms, self.sc
        sr = self.dm.stage_residual
        l1, l2 = (lz[:ms], lz[ms:]) if self.m else (ca.SX(0, 1), ca.SX(0, 1))
        U, t = self._U, self._t
        r1, r2 = (rz[:self.nfz // 2], rz[self.nfz // 2:]) if self.nfz else (None, None)
        U1, U2 = self.part_controls(U, 0), self.part_controls(U, 1)
        return ca.vertcat((sr(qk, zm, qs, l1, a * h, t, U1) + self._stage_forces(zm, lc[:sc], r1)) * a,
                          (sr(qs, zp, qn, l2, (1 - a) * h, t + a * h, U2) + self._stage_forces(zp, lc[sc:], r2)) * (1 - a))

    def _stage_forces(self, Z, lc, rz=None):
        """``w_j [∇φ(Z_j)ᵀλ^c_j + D(Z_j)ᵀ(ρ^Z_j λ^c_j)]`` at each stage of one part (stage by stage; the friction where
        ``rz`` is given)."""
        n, c, cd = self.n, self.c, self.c * self.fd
        w = self.dm.scheme.stage_weights
        out = []
        for j in range(self.dm.scheme.stages):
            Zj, lj = Z[j * n:(j + 1) * n], lc[j * c:(j + 1) * c]
            f = ca.mtimes(self._J(Zj).T, lj)
            if rz is not None:
                f = f + ca.mtimes(self._D(Zj).T, rz[j * cd:(j + 1) * cd] * self._per_component(lj))
            out.append(w[j] * f)
        return ca.vertcat(*out)

    def _stage_mu(self) -> np.ndarray:
        """The friction coefficient of every stage slot (both parts, stage by stage, each contact)."""
        return np.tile(self.mu_f, 2 * self.dm.scheme.stages)

    def part_slips(self, qa, Z, qb, tau):
        """The contact points' slip over one part ``[q_a, q_b]`` of length τ, on its polynomial path through the
        control points ``X = (q_a, Z_1 … Z_s, q_b)``: the slip velocities ``s_i = D(X_i) Ẋ_i`` at the control points
        (``Ẋ_i`` the path's rate there), and the displacements from the part's start to each control point after it,
        ``χ_j = ∫_0^{c_j} s dσ``, by the interpolatory quadrature of ``s`` on the control points (Lobatto's at the
        part's end).  Returns ``(χ_1/τ … χ_s/τ, χ_end/τ)`` and ``(s_1 … s_s)`` as lists (``c · d`` each):
        displacements over the part's length, in the units of a velocity.  For a rolling contact whose slip is
        integrable, ``D = ∇ψ``, ``χ_j = ψ(Z_j) − ψ(q_a)`` to the quadrature's order: sticking holds ψ at the stages as
        a holonomic constraint holds its own (``docs/derivations.md``, "Held contacts at the stages")."""
        n, st = self.n, self.dm.scheme.stages
        X = [qa] + [Z[j * n:(j + 1) * n] for j in range(st)] + [qb]
        rates = [sum(float(self._cdot[i, m]) * X[m] for m in range(st + 2)) / tau for i in range(st + 2)]
        sv = [ca.mtimes(self._D(X[i]), rates[i]) for i in range(st + 2)]
        chi = [sum(float(self._aint[j, i]) * sv[i] for i in range(st + 2)) for j in range(st + 1)]
        return chi, sv[1:-1]

    def stage_slips(self, qk, qs, qn, b, h, zm, zp):
        """``(χ, s)`` at the stages of both parts of a step (:meth:`part_slips`; first part, then second, stage by
        stage, each ``c · d``)."""
        a = 0.5 + b
        c1, v1 = self.part_slips(qk, zm, qs, a * h)
        c2, v2 = self.part_slips(qs, zp, qn, (1 - a) * h)
        return ca.vertcat(*(c1[:-1] + c2[:-1])), ca.vertcat(*(v1 + v2))

    def stage_gaps(self, zm, zp):
        """``[φ(Z⁻_j); φ(Z⁺_j)]``: the gaps at every stage of both parts of a step."""
        n, st, gap = self.n, self.dm.scheme.stages, self.system.gap
        return ca.vertcat(*[gap(Z[j * n:(j + 1) * n])[0] for Z in (zm, zp) for j in range(st)])

    def stage_holds(self, qk, qs, qn, zm, zp):
        """The rows that hold a contact at the stages of a part: each stage's gap less the straight line between the
        part's end gaps at the stage's time, ``φ(Z_j) − (1 − c_j) φ(a) − c_j φ(b)`` (``[q_k, q̃_k]``, then
        ``[q̃_k, q_{k+1}]``).  A part that starts and ends on the surface (its end rows hold both) has its gap zero at
        the stages; one that starts inside the touching band (a node left a rounding's depth inside by an impact's
        cascade) is brought onto the surface along it, without a pull at the stages."""
        n, ct, gap = self.n, self.dm.scheme.stage_times, self.system.gap
        g = [gap(x)[0] for x in (qk, qs, qn)]
        return ca.vertcat(*[gap(Z[j * n:(j + 1) * n])[0] - (1 - float(c)) * g[i] - float(c) * g[i + 1]
                            for i, Z in enumerate((zm, zp)) for j, c in enumerate(ct)])

    def stage_constraints(self, zm, zp):
        """``c(Z_j) = 0`` at every stage of both parts of a step."""
        n, st = self.n, self.dm.scheme.stages
        return ca.vertcat(*[self.constraint_row(Z[j * n:(j + 1) * n]) for Z in (zm, zp) for j in range(st)])


    # ------------------------------------------------------------------ the rows, built once
    def gaps(self, Q) -> np.ndarray:
        """The gaps at the configurations ``Q`` (rows), one row each: ``(len(Q), c)``."""
        Q = np.asarray(Q, float)
        return np.asarray(self.gap_row.map(Q.shape[0])(Q.T)).reshape(self.c, -1).T

    def slip(self, qk, qs, qn, b, h, arrive, zm=None, zp=None):
        """The slip velocities per contact that the step's friction opposes (maximal dissipation: the friction
        force opposes its slip, or the slip vanishes): for the node's force, the first part of the step,
        ``D(q̄₁)(q̃_k − q_k)/(αh)``; for the sub-node's impulse of a contact held through the step, the whole
        step around it, ``[D(q̄₁)(q̃_k − q_k) + D(q̄₂)(q_{k+1} − q̃_k)]/h`` (sticking on both holds the contact point
        still through the step); for a contact that arrives at the sub-node (``arrive`` 1: an impact), the part
        after it, ``D(q̄₂)(q_{k+1} − q̃_k)/((1 − α)h)``, the slip after the impact, which Coulomb's law at an impact
        opposes (the contact point moved freely before it).  ``q̄₁, q̄₂`` are the parts' midpoints: the contact
        point's displacement over a part is then its midpoint rule, exact to O(h³), where ``D`` at the part's start
        left an O(h²) drift that the tangential impulses fought with O(1) of the wrong share (a pivot's sub-node
        slot slid ten steps before the cone was reached, and the motion converged at first order).  A scheme with
        stages takes each part's displacement by its own quadrature on the part's path (:meth:`part_slips`), of the
        scheme's order."""
        a = 0.5 + b
        if self.s:
            first = a * h * self.part_slips(qk, zm, qs, a * h)[0][-1]
            second = (1 - a) * h * self.part_slips(qs, zp, qn, (1 - a) * h)[0][-1]
        else:
            first = ca.mtimes(self._D(0.5 * (qk + qs)), qs - qk)
            second = ca.mtimes(self._D(0.5 * (qs + qn)), qn - qs)
        arr = self._per_component(arrive)
        sub = arr * second / ((1 - a) * h) + (1 - arr) * (first + second) / h
        return ca.vertcat(first / (a * h), sub)

    def _per_component(self, v):
        """A value per contact repeated for each of its slip components (contact by contact)."""
        return v if self.fd == 1 else ca.vec(ca.repmat(ca.transpose(v), self.fd, 1))

    def node_row(self, p_in, qk, qs, b, nu, lam, h, rho=None, zm=None):
        """The momentum balance at a node ``q_k`` with the incoming momentum ``p_in`` (``p_0`` at the start,
        ``D₂L_d`` of the previous sub-interval elsewhere): ``(p_in + D₁L_d(q_k, q̃_k, αh))/h + ∇φ(q_k)ᵀν
        − ∇c(q_k)ᵀλ``, α = ½ + β; ``ν`` the contact forces (weighted by the step), ``λ`` the constraint
        multipliers (no entries without constraints); ``zm`` the stages of the step's first part (none
        for a two-point scheme).  The transcription's initial and node rows, the held step and the march
        step are all this row."""
        row = (p_in + self._D1(qk, self._z if zm is None else zm, qs, (0.5 + b) * h, self._t)) / h + ca.mtimes(self._J(qk).T, nu)
        if rho is not None:   # friction: the tangential force ρ ν along the slip directions D(q_k)
            row = row + ca.mtimes(self._D(qk).T, rho * self._per_component(nu))
        return row - ca.mtimes(self._C(qk).T, lam)

    def sub_row(self, qk, qs, qn, b, mu, lams, h, rho=None, zm=None, zp=None, mul=None, rl=None, rel=None):
        """The momentum balance at the sub-node ``q̃_k`` between ``q_k`` and ``q_{k+1}``, with the impulses
        ``μ``: ``(p̃⁻ − p̃⁺ + ∇φ(q̃)ᵀμ)/h − ∇c(q̃)ᵀλ̃``; and Newton's law residual ``r`` there (see
        :func:`_sub_node_kinematics`; ``zm``, ``zp`` the stages of the parts either side).  Returns
        ``(row, r)``.

        ``mul`` (with its friction ratios ``rl``): the impulses that close the first part, ``S⁻ = ∇φᵀμ⁻ + Dᵀ(ρ⁻μ⁻)``
        (:meth:`_left`), beside ``μ`` that opens the second: a released contact's share (:meth:`release_row`), an
        arrival's impulse by Stronge's law where its contact stays closed after.  The momentum before the impact is
        then ``p̃⁻`` with the released contacts' shares (``rel``), and Newton's law reads
        ``r = ∇φ Π (p̃⁺ + e (p̃⁻ + S⁻_rel))``."""
        a = 0.5 + b
        pm, pp, r = self._kinematics(qk, qs, qn, a * h, (1 - a) * h, self._z if zm is None else zm,
                                     self._z if zp is None else zp)
        row = pm - pp + ca.mtimes(self._J(qs).T, mu)
        if rho is not None:   # friction: the tangential impulse ρ μ
            row = row + ca.mtimes(self._D(qs).T, rho * self._per_component(mu))
        if mul is not None:
            row = row + self._left(qs, mul, rl)
            if rel is not None:
                S = self._left(qs, rel * mul, rl)
                r = r + self.e * ca.mtimes(self._J(qs), _tangent_velocity(self.system.mass_matrix(qs), self._C(qs), S))
        return row / h - ca.mtimes(self._C(qs).T, lams), r

    def _left(self, qs, mul, rl=None):
        """``S⁻ = ∇φ(q̃)ᵀμ⁻ + D(q̃)ᵀ(ρ⁻μ⁻)``: the impulses that close a step's first part."""
        S = ca.mtimes(self._J(qs).T, mul)
        if rl is not None:
            S = S + ca.mtimes(self._D(qs).T, rl * self._per_component(mul))
        return S

    def _before(self, qk, qs, b, h, mul, rl=None, rel=None, zm=None):
        """The velocity at the sub-node before its impact, ``Π(q̃)(p̃⁻ + S⁻_rel)`` (the released contacts' shares)."""
        pm = self._D2(qk, self._z if zm is None else zm, qs, (0.5 + b) * h, self._t) + self._left(qs, rel * mul, rl)
        return _tangent_velocity(self.system.mass_matrix(qs), self._C(qs), pm)

    def release_row(self, qk, qs, b, h, mul, rl=None, rel=None, zm=None):
        """The normal velocities at the sub-node ``q̃`` before its impact, ``∇φ(q̃) Π (p̃⁻ + S⁻)``: zero for a contact
        that releases there.  A contact held through the first part of the step and released at an impact has its
        force over that part at both of the part's ends, the node force ``ν`` at ``q_k`` and a share ``μ⁻`` at
        ``q̃`` (RATTLE's projection of the velocity onto the constraint): without the share the part's whole force
        sat at ``q_k``, the momentum before the impact kept an ``O(h)`` normal velocity at the held contact, and
        the impact's law took it -- the rimless wheel's touchdown lost energy at first order."""
        return ca.mtimes(self._J(qs), self._before(qk, qs, b, h, mul, rl, rel, zm))

    def left_velocity(self, qk, qs, b, h, mul, rl=None, rel=None, zm=None):
        """The slip velocities at the sub-node before its impact, ``D(q̃) Π (p̃⁻ + S⁻)``: a released contact's share
        sticks (zero) or slides against it, as its contact did through the first part."""
        return ca.mtimes(self._D(qs), self._before(qk, qs, b, h, mul, rl, rel, zm))

    def node_law(self, p_in, qk, qs, b, h, zm=None):
        """Newton's law at the node ``q_k`` itself: ``∇φ(q_k) Π(q_k) (p_k⁺ + e p_in)`` with ``p_k⁺ =
        −D₁L_d(q_k, q̃_k, αh)`` (the node row makes ``p_k⁺ − p_in`` the node's impulse ``h∇φᵀν``).  A flight
        that lands exactly on a node (to rounding) has its impact there: the sub-nodes, strictly inside
        their steps, cannot time it, and the node's force ``ν`` would otherwise stop the arrival plastically."""
        pp = -self._D1(qk, self._z if zm is None else zm, qs, (0.5 + b) * h, self._t)
        return ca.mtimes(self._J(qk), _tangent_velocity(self.system.mass_matrix(qk), self._C(qk), pp + self.e * p_in))

    @property
    def layout(self) -> Dict[str, slice]:
        """Slices of the march step's unknowns (:meth:`_march_function`) by the transcription's names."""
        if not hasattr(self, "_layout"):
            n, c, m = self.n, self.c, self.m
            sizes = [("qs", n), ("q", n), ("beta", 1), ("nu", c), ("mu", c), ("lam", m), ("lam_sub", m),
                     ("fratio", self.nfr), ("zs", 2 * self.s),
                     ("lam_stage", 2 * self.ms), ("mul", c), ("fleft", self.nfl), ("lam_cstage", 2 * self.sc),
                     ("fstage", self.nfz)]
            out, o = {}, 0
            for name, size in sizes:
                out[name] = slice(o, o + size)
                o += size
            self._layout, self._nx = out, o
        return self._layout

    @property
    def nx(self) -> int:
        """The number of unknowns of one march step."""
        self.layout
        return self._nx

    def _march_function(self, phi):
        """One step of the transcription's own rows, each contact in a mode given by masks (the march).

        Unknowns ``x = (q̃, q_{k+1}, β, ν, μ, λ_k, λ̃_k, ρ, Z⁻, Z⁺, λ_Z)`` (:attr:`layout`: the multipliers
        of the holonomic constraints, whose rows ``c(q̃) = 0``, ``c(q_{k+1}) = 0`` close the step; the
        friction ratios; the stages of both parts, whose rows are :meth:`stage_rows`, and the constraint
        multipliers there; each empty where the scene has no such term); inputs the node ``q_k``, its incoming momentum
        ``p_k⁻``, ``h``, the length ``ℓ`` and the scales of ν and μ, and per contact the masks
        ``t`` (the contact that times the sub-node: ``φ_t(q̃) = 0`` replaces ``β = β_fix``),
        ``held`` (``φ(q̃) = 0`` replaces ``ν = 0``), ``closed`` (``φ(q_{k+1}) = 0`` replaces
        ``μ = 0``), ``law`` (Newton's law ``r = 0`` replaces ``μ = 0``) and ``node`` (an impact at the node
        ``q_k`` itself, Newton's law there, :meth:`node_law`, replaces ``ν = 0``); ``fixed`` with ``mufix``
        (``μ = mufix`` replaces ``μ = 0``: an impulse decided outside the step, the sequential law's cascade)
        and ``nfixed`` (``ν = mufix`` replaces ``ν = 0``: the same at the node); for the first part's closing
        impulses ``μ⁻``, ``release`` (a contact held until an impact's sub-node and open after it: its share,
        :meth:`release_row`, replaces ``μ⁻ = 0``) and ``leftfix`` with ``mufixl`` (``μ⁻ = mufixl``: an arrival's
        impulse by Stronge's law, its contact closed after); ``tslip`` (a held contact whose slip stops or turns at the
        sub-node: its slip velocity there after its share, :meth:`left_velocity`, vanishes, replacing ``β = β_fix``;
        it is then also a ``release`` for its share, and its slip after the sub-node is the second part's).  The rows are the node
        and sub-node rows of the transcription (:meth:`node_row`, :meth:`sub_row`), so a point solved step by step satisfies the whole
        program's rows (``docs/derivations.md``, "Contact trajectories", "The march").
        """
        n, c, sym = self.n, self.c, ca.SX.sym
        L = self.layout
        x = sym("x", self.nx)
        qs, qn, b = x[L["qs"]], x[L["q"]], x[2 * n]
        nu, mu, lam, lams = x[L["nu"]], x[L["mu"]], x[L["lam"]], x[L["lam_sub"]]
        rho = x[L["fratio"]] if self.friction else None
        cd = c * self.fd
        rho_n, rho_s = (rho[:cd], rho[cd:]) if self.friction else (None, None)
        zm, zp = (x[L["zs"]][:self.s], x[L["zs"]][self.s:]) if self.s else (None, None)
        con = self.constraint_row
        qk, p, h, ell = sym("q", n), sym("p", n), sym("h"), sym("ell")
        snu, smu, vref, bfix = sym("snu"), sym("smu"), sym("vref"), sym("bfix")
        t, held, closed, law = sym("t", c), sym("held", c), sym("closed", c), sym("law", c)
        node, fixed, mufix, nfixed = sym("node", c), sym("fixed", c), sym("mufix", c), sym("nfixed", c)
        release, leftfix, mufixl = sym("release", c), sym("leftfix", c), sym("mufixl", c)
        # (tslip: a held contact whose slip stops or turns at the sub-node, which it times: its slip velocity there,
        # after its share of the first part's force, vanishes -- planar friction)
        tslip = sym("tslip", c)
        # (tlift: a held contact released at the sub-node, which it times: its force there, held_force with the contacts
        # held through the first part, vanishes; its share of the first part's force is then zero)
        tlift = sym("tlift", c)
        # (tgrip: a held contact that sticks through the first part and slides from the sub-node on, which it times: its
        # friction force there reaches the cone, cone_margin with the first part's held and sticking contacts; the force
        # is continuous there, so no share)
        tgrip = sym("tgrip", c)
        # the friction's modes per slot (below)
        nfs = self.nfs
        stick, sgn, fix, rfix = sym("stick", nfs), sym("sgn", nfs), sym("fix", nfs), sym("rfix", self.nfr)
        mul = x[L["mul"]]
        rl = x[L["fleft"]] if self.friction else None
        sub_row, r = self.sub_row(qk, qs, qn, b, mu, lams, h, rho_s, zm, zp, mul, rl, release)
        free = 1 - held - node - nfixed
        other = 1 - closed - law - fixed
        R = ca.vertcat(self.node_row(p, qk, qs, b, nu, lam, h, rho_n, zm), sub_row,
                       (1 - ca.sum1(t) - ca.sum1(tslip) - ca.sum1(tlift) - ca.sum1(tgrip)) * (b - bfix)
                       + ca.dot(t, phi(qs)) / ell
                       + (ca.dot(tslip, self.left_velocity(qk, qs, b, h, mul, rl, release, zm)) / vref
                          if self.friction and self.fd == 1 else 0),
                       held * phi(qs) / ell + node * self.node_law(p, qk, qs, b, h, zm) / vref
                       + nfixed * (nu - mufix) / snu + free * nu / snu,
                       closed * phi(qn) / ell + law * r / vref + fixed * (mu - mufix) / smu + other * mu / smu,
                       release * self.release_row(qk, qs, b, h, mul, rl, release, zm) / vref + leftfix * (mul - mufixl) / smu
                       + (1 - release - leftfix) * mul / smu,
                       con(qs), con(qn))
        lc = x[L["lam_cstage"]]
        rz = x[L["fstage"]] if self.nfz else None
        if self.s:
            R = ca.vertcat(R, self._stage_march_rows(qk, qs, qn, b, h, zm, zp, x[L["lam_stage"]], lc, rz, held, closed,
                                                     ell, snu))
        # the friction's modes per slot: inputs of the step whether or not it has friction (no entries without)
        # (per contact: stick (the slip vanishes), slide (ρ = −sgn μ_f, sgn the slip's sign), or no friction force
        # (ρ = 0: an open contact, or a frictionless one); fix: ρ = rfix, a ratio decided outside the step, the
        # frictional impact law's tangential impulse; a tangent plane, d = 2: sgn is the mask of sliding, whose rows
        # are ρ + μ_f s/|s| = 0, the ratio against the slip's direction on the circular cone, see friction_rows)
        arrive, rfixl = sym("arrive", nfs // 2), sym("rfixl", self.nfl)
        if self.friction:
            R = ca.vertcat(R, self._friction_march_rows(qk, qs, qn, b, h, zm, zp, rho, rz, mul, rl, arrive, release,
                                                        leftfix, stick, sgn, fix, rfix, rfixl, vref))
        ins = [x, qk, p, h, ell, snu, smu, vref, bfix, t, held, closed, law, node, fixed, mufix, nfixed, release, leftfix,
               mufixl, tslip, tlift, tgrip, stick, sgn, fix, rfix, arrive, rfixl, self._t, self._U]
        self.march_step = ca.Function("march_step", ins, [R, ca.jacobian(R, x)])
        #: (the step's rows without the timed forces, and where the timing row sits in them: march_step_timed)
        self._march_rows = ca.Function("march_rows", ins, [R])
        self._timing_row = 2 * n

    def _stage_march_rows(self, qk, qs, qn, b, h, zm, zp, lz, lc, rz, held, closed, ell, snu):
        """The march step's rows of the stages: their stationarity (:meth:`stage_rows`), the constraints there, and a
        contact held through a part (its first: ``held``; its second: ``closed``) closed at the part's stages with its
        force there free (:meth:`stage_holds`); elsewhere its stage forces vanish."""
        R = self.stage_rows(qk, qs, qn, b, h, zm, zp, lz, lc, rz)
        if self.m:
            R = ca.vertcat(R, self.stage_constraints(zm, zp))
        st = self.dm.scheme.stages
        hold = ca.vertcat(*([held] * st + [closed] * st))
        return ca.vertcat(R, hold * self.stage_holds(qk, qs, qn, zm, zp) / ell + (1 - hold) * lc / snu)

    def _friction_march_rows(self, qk, qs, qn, b, h, zm, zp, rho, rz, mul, rl, arrive, release, leftfix, stick, sgn,
                             fix, rfix, rfixl, vref):
        """The march step's friction rows: the slots' (:meth:`friction_rows` of the step's slips), the stages' (each
        part's stages in its slot's mode: sticking, the contact point's displacement from the part's start vanishes
        there; sliding, the ratio opposes the stage's slip velocity at the cone's edge), and the first part's closing
        impulses μ⁻ (a released contact's share sticks or slides as its node slot did through that part, against the
        slip velocity before the impact; a law's, ``leftfix``, ratio is fixed at ``rfixl``)."""
        c = self.c
        R = self.friction_rows(self.slip(qk, qs, qn, b, h, arrive, zm, zp), rho, stick, sgn, fix, rfix, vref)
        if self.nfz:
            st = self.dm.scheme.stages
            chi, vel = self.stage_slips(qk, qs, qn, b, h, zm, zp)
            zs = lambda v: ca.vertcat(*([v[:c]] * st + [v[c:]] * st))  # noqa: E731
            R = ca.vertcat(R, self.friction_rows(chi, rz, zs(stick), zs(sgn), ca.DM.zeros(2 * self.sc),
                                                 ca.DM.zeros(self.nfz), vref, self._stage_mu(), slide_slip=vel))
        return ca.vertcat(R, self.friction_rows(self.left_velocity(qk, qs, b, h, mul, rl, release, zm), rl,
                                                stick[:c] * release, sgn[:c] * release, leftfix, rfixl, vref, self.mu_f))

    @property
    def timed_force_rows(self) -> ca.Function:
        """:attr:`timed_force` as an expression, the element of the program's rows (:func:`.forces.timed_force_rows`),
        built on first use."""
        return self.derived("timed rows", lambda: forces.timed_force_rows(self))

    @property
    def march_step_timed(self) -> ca.Function:
        """The march step with the timed contact forces (modes E and G; :func:`.forces.march_step_timed`), built on
        first use: the same inputs and outputs as :attr:`march_step`."""
        return self.derived("timed", lambda: forces.march_step_timed(self))

    def friction_rows(self, slip, rho, stick, sgn, fix, rfix, vref, muf=None, slide_slip=None):
        """The friction's rows of a step, per slot (contact and part; masks per slot, values per component):
        sticking, the slip vanishes; sliding, the ratio opposes the slip at the cone's edge -- in the plane
        ``ρ = −sgn μ_f`` (sgn the slip's sign), on a tangent plane ``ρ + μ_f s/|s| = 0`` (sgn then the mask of
        sliding); ``fix``, ``ρ = rfix``; otherwise no friction force, ``ρ = 0``.  ``slide_slip``: the slip whose
        direction a sliding slot opposes, where it is not the one a sticking slot holds (a stage's velocity against
        its displacement)."""
        d = self.fd
        muf = np.concatenate([self.mu_f, self.mu_f]) if muf is None else np.asarray(muf, float)
        ss = slip if slide_slip is None else slide_slip
        if d == 1:
            slide = sgn * sgn
            return stick * slip / vref + slide * (rho + sgn * ca.DM(muf)) + fix * (rho - rfix) \
                + (1 - stick - slide - fix) * rho
        rep = lambda v: ca.vec(ca.repmat(ca.transpose(v), d, 1))  # noqa: E731
        # |s| per slot, smoothed below 1e-12 of the velocity scale (Newton's derivative at s = 0); the sliding
        # row is ρ + μ_f s/|s| (ρ on the cone's edge against the slip: written as ρ|s| + μ_f s it would leave ρ
        # free as s → 0, and a slot whose slip had vanished kept |ρ| = 3.5 μ_f in our trials)
        S = ca.reshape(ss, d, -1)
        norm = ca.transpose(ca.sqrt(ca.sum1(S * S) + (1e-12 * vref) ** 2))
        slide = sgn
        return rep(stick) * slip / vref + rep(slide) * (rho + ca.DM(np.repeat(muf, d)) * ss / rep(norm)) \
            + rep(fix) * (rho - rfix) + (1 - rep(stick) - rep(slide) - rep(fix)) * rho

    def flights(self, K: int) -> ca.Function:
        """``K`` RK4 steps of length ``h`` from ``(q, v)``: nodes, velocities and gaps as columns."""
        if K not in self._flights:
            q, v, h = ca.MX.sym("q", self.n), ca.MX.sym("v", self.n), ca.MX.sym("h")
            step = ca.Function("step", [q, v, h], self.flow(q, v, h))
            acc = step.mapaccum("flights", K, [0, 1], [0, 1])
            Qs, Vs, Ps = acc(q, v, h)
            self._flights[K] = ca.Function(f"flights{K}", [q, v, h], [Qs, Vs, Ps])
        return self._flights[K]

    def _law_functions(self, suffix: str, head, tail, law, xu=()):
        """Newton's law row ``law`` (inputs ``head + tail``, ``head`` ending with ``μ``) and its
        ℓ1 slack form ``law/scale − s⁺ + s⁻`` (inputs ``head + [s⁺, s⁻] + tail + [scale]``).

        Scales enter as element arguments, so every ContactNLP (the whole trajectory and every
        horizon window) shares the same functions, and their derivatives are formed once.
        """
        sym, c = ca.SX.sym, self.c
        sp, sm, scale = sym("sp", c), sym("sm", c), sym("scale")
        xu = list(xu)
        return (ca.Function(f"c_law{suffix}", head + tail + xu, [law]),
                ca.Function(f"c_law_slack{suffix}", head + [sp, sm] + tail + [scale] + xu, [law / scale - sp + sm]))

    def _objective_functions(self):
        """The objective terms (penalties), built once per system; scales are element arguments."""
        sym, c = ca.SX.sym, self.c
        rho, sp, sm, scale = sym("rho"), sym("sp", c), sym("sm", c), sym("scale")
        q, lam = sym("q", self.n), sym("lam", c)
        #: ``ρ Σ_j φ_j(q) λ_j / scale`` for a gap and its impulse (or force)
        self.product_penalty = ca.Function("c_pen", [q, lam, rho, scale],
                                           [rho * ca.dot(self.system.gap(q)[0], lam) / scale])
        #: ``ρ Σ (s⁺ + s⁻)``
        self.slack_penalty = ca.Function("c_slack_pen", [sp, sm, rho], [rho * ca.sum1(sp + sm)])


def _control_quadrature(S):
    """On a step's control points ``c_0 = 0 < c_1 … < c_r = 1`` (of the scheme ``S``): the Lagrange basis' rates
    there, ``R[i, m] = ℓ_m'(c_i)``, and the integration matrix ``A[j, i] = ∫_0^{c_{j+1}} ℓ_i(σ) dσ`` (``j = 0 … r − 1``:
    the control points after the first; its last row is the interpolatory quadrature on the control points)."""
    from numpy.polynomial import polynomial as Pn
    c = np.asarray(S.control, float)
    r1 = c.size
    R = np.zeros((r1, r1))
    A = np.zeros((r1 - 1, r1))
    for i in range(r1):
        others = np.delete(c, i)
        coef = Pn.polyfromroots(others) / np.prod(c[i] - others)
        R[:, i] = Pn.polyval(c, Pn.polyder(coef))
        integral = Pn.polyint(coef)
        A[:, i] = Pn.polyval(c[1:], integral) - Pn.polyval(0.0, integral)
    return R, A


def _sub_node_kinematics(D1, D2, J, Mf, C, e, xp, x, xn, tau_m, tau_p, Zm, Zp, t0):
    """Momenta on both sides of a sub-node ``x`` between ``xp`` and ``xn`` (sub-intervals ``tau_m``,
    ``tau_p``), ``p̃⁻ = D₂L_d(xp, x)`` and ``p̃⁺ = −D₁L_d(x, xn)``, and Newton's law residual
    ``r = ∇φ(x) Π(x) (p̃⁺ + e p̃⁻)`` (zero for every contact that obeys the law).

    ``Π = M⁻¹ − M⁻¹Cᵀ(CM⁻¹Cᵀ)⁻¹CM⁻¹`` maps a momentum to the velocity tangent to the holonomic
    constraints (``M⁻¹`` without them): the law acts on the velocities the constraints allow, and for
    ``e = 1`` their kinetic energy ``½ v̄ᵀMv̄`` is the same on both sides of the impact."""
    pm = D2(xp, Zm, x, tau_m, t0)
    pp = -D1(x, Zp, xn, tau_p, t0 + tau_m)
    return pm, pp, ca.mtimes(J(x), _tangent_velocity(Mf(x), C(x), pp + e * pm))


def _tangent_velocity(M, C, p):
    """``Π p``: the velocity ``M⁻¹p`` restricted to the constraints' tangent space,
    ``Π = M⁻¹ − M⁻¹Cᵀ(CM⁻¹Cᵀ)⁻¹CM⁻¹`` (``M⁻¹`` without constraints)."""
    v = ca.solve(M, p)
    if C.size1():
        MiCt = ca.solve(M, C.T)
        v = v - ca.mtimes(MiCt, ca.solve(ca.mtimes(C, MiCt), ca.mtimes(C, v)))
    return v
