"""The contact forces of the continuous motion at a state, for the held contacts' transitions timed inside a step
(docs/derivations.md, "Contact trajectories", §7).

At ``(q, p)``, with the contacts ``held`` (mask) kept closed and those ``stick`` (mask) kept from slipping, the
index-1 system

    M q̈ = f + Ĵᵀλ + D_Sᵀt − Cᵀλ_c,   ∇φ_H q̈ + (∇φ_H q̇)_q q̇ = 0,   D_S q̈ + (D_S q̇)_q q̇ = 0,   C q̈ + (C q̇)_q q̇ = 0

(a held contact that slides with friction pushes along ``Ĵ_j = ∇φ_j − μ_j ŝ_jᵀ D_j``, Coulomb's force against its slip
direction) gives the normal forces ``λ`` and the sticking contacts' friction forces ``t``, at the velocity
``q̇ = Π M⁻¹p`` that keeps the held contacts, the sticking ones and the constraints.  A release's time is where its
``λ_j`` reaches zero, a stick's end where its cone margin ``μ_f λ_j − |t_j|`` does: the state at a sub-node is the
scheme's, of its order, and so is the time where a smooth function of it vanishes.

The masked system holds every contact and slip component; solved symbolically its expression grows as their number
cubed (the march step of a box on eight corners with friction: 2.8 million nodes).  So it is one linear-solve node of
an MX function (:func:`held_forces`), evaluated by the march only in a step that times an event
(:func:`march_step_timed`); the program's rows, formed in SX, take the symbolic solve (:func:`timed_force_rows`), and
only a program whose march timed an event holds them.
"""
from __future__ import annotations

from types import SimpleNamespace

import casadi as ca


def _index1_system(cm, tau: float = 0.0) -> ca.Function:
    """``(A, b)`` of the masked index-1 system at ``(q, p, held, stick, u)``, ``A Λ = −b`` (constraints first, then the
    contacts' normal forces, then the sticking ones' friction forces; a masked row is ``Λ_i = 0``)."""
    system, n, c, m, d = cm.system, cm.n, cm.c, cm.m, cm.fd
    q, qd = system.q, system.qd
    M, f = system.dynamics_exprs()
    held, stick, p = ca.SX.sym("held", c), ca.SX.sym("stick", c), ca.SX.sym("p", n)
    J = system.gap(q)[1]
    rows, reg = [cm._C(q), ca.mtimes(ca.diag(held), J)], [ca.SX(m, m), ca.diag(1 - held)]
    if cm.friction:
        Dm, srep = cm._D(q), cm._per_component(stick)
        rows.append(ca.mtimes(ca.diag(srep), Dm))
        reg.append(ca.diag(1 - srep))
    G, R = ca.vertcat(*rows), ca.diagcat(*reg)
    MiGt = ca.solve(M, G.T)
    vfree = ca.solve(M, p)
    v = vfree - ca.mtimes(MiGt, ca.solve(ca.mtimes(G, MiGt) + R, ca.mtimes(G, vfree)))
    Gf = G
    if cm.friction:
        # a held contact sliding with friction pushes along ∇φ_j − μ_j ŝ_jᵀ D_j (its slip direction at v)
        S = ca.reshape(ca.mtimes(Dm, v), d, c)
        norm = ca.sqrt(ca.sum1(S * S) + 1e-300)
        slide = held * (1 - stick) * ca.DM(cm.mu_f)
        pushed = [J[j, :] - slide[j] * ca.mtimes((S[:, j] / norm[j]).T, Dm[j * d:(j + 1) * d, :]) for j in range(c)]
        Gf = ca.vertcat(cm._C(q), ca.mtimes(ca.diag(held), ca.vertcat(*pushed)), rows[2])
    rhs = ca.substitute(ca.vertcat(f, ca.jtimes(ca.mtimes(G, qd), q, qd)), qd, v)
    A = ca.mtimes(G, ca.solve(M, Gf.T)) + R
    b = ca.mtimes(G, ca.solve(M, rhs[:n])) + rhs[n:]
    U = ca.SX.sym("u", cm.nu)
    if cm.nu:
        # (the step's controls at the fraction tau of its first part: its start, or the sub-node that ends it)
        ui = cm.instant_control(U, 0, tau)
        A, b = ca.substitute(A, system.control_vector, ui), ca.substitute(b, system.control_vector, ui)
    return ca.Function("c_index1", [q, p, held, stick, U], [A, b])


def _margin(cm, lam, forces, sgn):
    """The sticking contacts' cone margins ``μ_f λ − |t|`` (in the plane ``μ_f λ + sgn t``, ``sgn`` the sign of the slip
    a contact would start), ``forces`` their friction forces (``c·d``); SX or MX."""
    tt = ca.reshape(forces, cm.fd, cm.c)
    if cm.fd == 1:
        return ca.DM(cm.mu_f) * lam + sgn * ca.transpose(tt)
    return ca.DM(cm.mu_f) * lam - ca.transpose(ca.sqrt(ca.sum1(tt * tt) + 1e-300))


def _sub_node_momentum(cm) -> ca.Function:
    """``p̃⁻(q_k, Z⁻, q̃, β, h, t, u)``: the momentum that ends a step's first part."""
    n, sym = cm.n, ca.SX.sym
    q, z, qs, b, h = sym("q", n), sym("zm", cm.s), sym("qs", n), sym("beta"), sym("h")
    return ca.Function("c_pm", [q, z, qs, b, h, cm._t, cm._U],
                       [cm._D2(q, z if cm.s else cm._z, qs, (0.5 + b) * h, cm._t, cm._U)])


def held_forces(cm) -> SimpleNamespace:
    """The contact forces as functions (MX, one linear-solve node): ``contact_forces(q, p, held, stick, u)`` →
    ``[λ (c); t (c·d)]``; ``held_force(q, p, held, u)``, its normal part with nothing sticking; ``cone_margin(q, p, held,
    stick, sgn, u)`` (with friction); ``timed_force(q_k, q̃, β, h, Z⁻, held, stick, sgn, t, u)`` → ``[λ; margin]`` at
    the sub-node, with the momentum ``p̃⁻`` (zeros for the margins without friction).  Also ``index1`` (the system's
    matrix and right-hand side) and ``momentum`` (``p̃⁻``), for :func:`timed_force_rows`."""
    n, c, m = cm.n, cm.c, cm.m
    index1, momentum = _index1_system(cm), _sub_node_momentum(cm)
    index1_sub = _index1_system(cm, 1.0) if cm.per_part else index1
    q, p, hm, sm, um, sgn = (ca.MX.sym(nm, k) for nm, k in (("q", n), ("p", n), ("held", c), ("stick", c),
                                                             ("u", cm.nu), ("sgn", c)))
    A, b = index1(q, p, hm, sm, um)
    out = -ca.solve(A, b)[m:]
    contact = ca.Function("c_contact_forces", [q, p, hm, sm, um], [out])
    contact_sub = contact
    if cm.per_part:     # (at the sub-node, with the control there)
        As, bs = index1_sub(q, p, hm, sm, um)
        contact_sub = ca.Function("c_contact_forces_sub", [q, p, hm, sm, um], [-ca.solve(As, bs)[m:]])
    held = ca.Function("c_held_force", [q, p, hm, um], [contact(q, p, hm, 0 * sm, um)[:c]])
    margin = ca.Function("c_cone_margin", [q, p, hm, sm, sgn, um], [_margin(cm, out[:c], out[c:], sgn)]) \
        if cm.friction else None
    qk, qs, bb, h, zm, t = (ca.MX.sym(nm, k) for nm, k in (("q", n), ("qs", n), ("beta", 1), ("h", 1), ("zm", cm.s),
                                                           ("t", 1)))
    pm = momentum(qk, zm, qs, bb, h, t, um)
    fs = contact_sub(qs, pm, hm, sm if cm.friction else 0 * sm, um)
    timed = ca.vertcat(fs[:c], _margin(cm, fs[:c], fs[c:], sgn) if cm.friction else ca.MX.zeros(c))
    return SimpleNamespace(index1=index1_sub, momentum=momentum, contact_forces=contact, held_force=held,
                           cone_margin=margin,
                           timed_force=ca.Function("c_timed_force", [qk, qs, bb, h, zm, hm, sm, sgn, t, um], [timed]))


def timed_force_rows(cm) -> ca.Function:
    """:attr:`ContactMechanics.timed_force` as an expression (its index-1 system solved symbolically): the element of
    the program's rows, which are formed in SX (:mod:`.transcription`, only for a program whose march timed a release
    or a stick's end)."""
    f = cm.timed_force
    ins = [ca.SX.sym(f"a{i}", f.sparsity_in(i)) for i in range(f.n_in())]
    qk, qs, b, h, zm, held, stick, sgn, t, U = ins
    pm = cm.forces.momentum(qk, zm, qs, b, h, t, U)
    A, bb = cm.forces.index1(qs, pm, held, stick if cm.friction else 0 * held, U)
    out = -ca.solve(A, bb)[cm.m:]
    lam = out[:cm.c]
    margin = _margin(cm, lam, out[cm.c:], sgn) if cm.friction else ca.SX.zeros(cm.c)
    return ca.Function("c_timed_force_rows", ins, [ca.vertcat(lam, margin)])


def march_step_timed(cm) -> ca.Function:
    """The march step with the timing rows of the contact forces added to its sub-node's timing row: a release's normal
    force (``tlift``, mode E) and a stick's cone margin (``tgrip``, mode G), with the contacts held (and, with friction,
    sticking: the node slots) through the step's first part, over the force scale.  The same inputs and outputs as
    :attr:`ContactMechanics.march_step` (an MX function: its index-1 system one linear-solve node)."""
    base = cm._march_rows
    ins = [ca.MX.sym(f"a{i}", base.sparsity_in(i)) for i in range(base.n_in())]
    n, c, L = cm.n, cm.c, cm.layout
    # (the inputs by position, as ContactMechanics._march_function lists them)
    xx, qk, h, snu, held, tlift, tgrip, stick, sgn, t, U = (ins[i] for i in (0, 1, 3, 5, 10, 21, 22, 23, 24, 29, 30))
    zm = xx[L["zs"]][:cm.s] if cm.s else ca.MX(0, 1)
    zero = ca.MX.zeros(c)
    timed = cm.timed_force(qk, xx[L["qs"]], xx[2 * n], h, zm, held, stick[:c] if cm.friction else zero,
                           sgn[c:] if cm.friction else zero, t, U)
    e = ca.DM.zeros(base.sparsity_out(0).numel())
    e[cm._timing_row] = 1.0
    R = base(*ins) + e * (ca.dot(tlift, timed[:c]) + ca.dot(tgrip, timed[c:])) / snu
    return ca.Function("march_step_timed", ins, [R, ca.jacobian(R, xx)])
