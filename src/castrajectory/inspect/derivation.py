"""The derivation of a system, generated from the very CasADi expressions the solver uses.

:func:`to_sympy` walks a CasADi SX function's algorithm (its instructions: inputs, constants, unary
and binary operations) into sympy expressions, so nothing is written twice: the Lagrangian the
whole-trajectory NLP discretises is the one printed.  :func:`equations` forms, in sympy, the
Euler–Lagrange equations ``M(q) q̈ = f(q, q̇) (+ Cᵀλ)`` and the conserved quantities the Lagrangian's
symmetries give; :func:`markdown` writes them as a document (LaTeX math) together with the scheme's
discrete Lagrangian, discrete Euler–Lagrange equations and discrete Legendre transforms.

sympy is the optional ``derive`` extra: a computer-algebra system to simplify and print with, which
the package would otherwise have to write itself.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence

import casadi as ca
import numpy as np


def _sympy():
    try:
        import sympy
    except ImportError:  # pragma: no cover - the extra is installed in CI
        from ..validation import InputError
        raise InputError("the derivation needs sympy: pip install 'castrajectory[derive]'") from None
    return sympy


def _ops(sp):
    """CasADi operation code -> sympy (unary or binary)."""
    table = {
        ca.OP_ADD: lambda a, b: a + b, ca.OP_SUB: lambda a, b: a - b, ca.OP_MUL: lambda a, b: a * b,
        ca.OP_DIV: lambda a, b: a / b, ca.OP_POW: lambda a, b: a ** b, ca.OP_CONSTPOW: lambda a, b: a ** b,
        ca.OP_ATAN2: sp.atan2, ca.OP_FMIN: sp.Min, ca.OP_FMAX: sp.Max, ca.OP_HYPOT: lambda a, b: sp.sqrt(a ** 2 + b ** 2),
        ca.OP_NEG: lambda a: -a, ca.OP_SQ: lambda a: a ** 2, ca.OP_SQRT: sp.sqrt, ca.OP_TWICE: lambda a: 2 * a,
        ca.OP_INV: lambda a: 1 / a, ca.OP_EXP: sp.exp, ca.OP_LOG: sp.log, ca.OP_SIN: sp.sin, ca.OP_COS: sp.cos,
        ca.OP_TAN: sp.tan, ca.OP_ASIN: sp.asin, ca.OP_ACOS: sp.acos, ca.OP_ATAN: sp.atan, ca.OP_SINH: sp.sinh,
        ca.OP_COSH: sp.cosh, ca.OP_TANH: sp.tanh, ca.OP_FABS: sp.Abs, ca.OP_SIGN: sp.sign, ca.OP_ASSIGN: lambda a: a,
        ca.OP_FLOOR: sp.floor, ca.OP_CEIL: sp.ceiling,
    }
    return table


def to_sympy(fn: ca.Function, inputs: Sequence) -> List:
    """The outputs of the SX function ``fn`` as sympy expressions of ``inputs`` (one list of sympy
    symbols per input, in its nonzero order); each output as a flat list of its nonzeros."""
    sp = _sympy()
    if not fn.is_a("SXFunction"):
        fn = fn.expand()
    ops = _ops(sp)
    work: Dict[int, object] = {}
    outs = [[sp.Integer(0)] * fn.nnz_out(i) for i in range(fn.n_out())]
    for k in range(fn.n_instructions()):
        op, ins, outk = fn.instruction_id(k), fn.instruction_input(k), fn.instruction_output(k)
        if op == ca.OP_INPUT:
            work[outk[0]] = inputs[ins[0]][ins[1]]
        elif op == ca.OP_OUTPUT:
            outs[outk[0]][outk[1]] = work[ins[0]]
        elif op == ca.OP_CONST:
            work[outk[0]] = _constant(sp, float(fn.instruction_constant(k)))
        elif op in ops:
            args = [work[i] for i in ins[:2 if op in _BINARY else 1]]
            work[outk[0]] = ops[op](*args)
        else:
            raise NotImplementedError(f"CasADi operation {op} has no sympy form here")
    return outs


def _constant(sp, c: float):
    """An exact rational where the double is one with a small power-of-two denominator (0.5, 0.25: the
    ½ of a kinetic energy), else the float itself (9.81 stays 9.81)."""
    if c.is_integer() and abs(c) < 1e15:
        return sp.Integer(int(c))
    for d in (2, 4, 8, 16, 32, 64):
        if (c * d).is_integer() and abs(c * d) < 1e15:
            return sp.Rational(int(c * d), d)
    return sp.Float(c)


_BINARY = {ca.OP_ADD, ca.OP_SUB, ca.OP_MUL, ca.OP_DIV, ca.OP_POW, ca.OP_CONSTPOW, ca.OP_ATAN2, ca.OP_FMIN,
           ca.OP_FMAX, ca.OP_HYPOT}


@dataclass
class Equations:
    """The Lagrangian mechanics of a system in sympy (see :func:`equations`)."""

    q: list
    qd: list
    qdd: list
    lam: list
    K: object
    U: object
    L: object
    M: object
    forces: object                  # f(q, q̇, t) in M q̈ = f + Cᵀλ (the non-conservative Q included)
    C: object                       # constraint Jacobian (m × n), or None
    c: list                         # constraint expressions c(q, t)
    positions: list = field(default_factory=list)   # atom positions, if the system has atoms
    cyclic: List[int] = field(default_factory=list)  # coordinates absent from L (their momenta are conserved)
    momenta: list = field(default_factory=list)
    t: object = None                # the time symbol
    Q: object = None                # the non-conservative generalised force Q(q, q̇, t), or None
    time_dependent: bool = False


def equations(system, simplify: bool = True) -> Equations:
    """The Euler–Lagrange equations of ``system`` from its own CasADi expressions:
    ``M q̈ = f(q, q̇, t) + C(q, t)ᵀλ`` with ``f = ∂L/∂q − (∂²L/∂q̇∂q) q̇ − ∂²L/∂q̇∂t + Q``, ``c(q, t) = 0``
    (``d/dt ∂L/∂q̇ − ∂L/∂q = Q + Cᵀλ``: the Lagrange–d'Alembert equations with the forces ``Q``)."""
    sp = _sympy()
    n = system.nq
    names = [_latex_name(s) for s in system.names]
    q = list(sp.symbols(" ".join(names), real=True)) if n > 1 else [sp.Symbol(names[0], real=True)]
    qd = [sp.Symbol(r"\dot{" + nm + "}", real=True) for nm in names]
    qdd = [sp.Symbol(r"\ddot{" + nm + "}", real=True) for nm in names]
    t = sp.Symbol("t", real=True)
    f_K = ca.Function("K", [system.q, system.qd, system.t], [system.kinetic_expr()])
    f_U = ca.Function("U", [system.q, system.t], [system.potential_expr()])
    K = to_sympy(f_K, [q, qd, [t]])[0][0]
    U = to_sympy(f_U, [q, [t]])[0][0]
    S = (lambda e: sp.simplify(e)) if simplify else (lambda e: e)  # noqa: E731
    K, U = S(K), S(U)
    L = K - U
    p = [sp.diff(L, v) for v in qd]
    M = sp.Matrix(n, n, lambda i, j: S(sp.diff(p[i], qd[j])))
    Q = None
    if system.forced:
        f_Q = ca.Function("Q", [system.q, system.qd, system.t], [system.force_expr()])
        Q = sp.Matrix([S(e) for e in to_sympy(f_Q, [q, qd, [t]])[0]])
    f = sp.Matrix([S(sp.diff(L, q[i]) - sum(sp.diff(p[i], q[j]) * qd[j] for j in range(n)) - sp.diff(p[i], t)
                     + (Q[i] if Q is not None else 0)) for i in range(n)])
    c, C, lam = [], None, []
    if system.nc:
        f_c = ca.Function("c", [system.q, system.t], [system.constraint_expr()])
        c = [S(e) for e in to_sympy(f_c, [q, [t]])[0]]
        C = sp.Matrix([[sp.diff(ci, qj) for qj in q] for ci in c])
        lam = list(sp.symbols(" ".join(fr"\lambda_{i + 1}" for i in range(len(c))))) if len(c) > 1 \
            else [sp.Symbol(r"\lambda")]
    positions = []
    if getattr(system.kinetic, "positions", None) is not None:
        for x in system.kinetic.positions:
            fx = ca.Function("x", [system.q, system.t], [ca.vec(ca.SX(x))])
            positions.append([S(e) for e in to_sympy(fx, [q, [t]])[0]])
    # a cyclic coordinate's momentum is conserved only if no force acts along it
    cyclic = [i for i in range(n) if sp.diff(L, q[i]) == 0 and (Q is None or Q[i] == 0)]
    return Equations(q, qd, qdd, lam, K, U, L, M, f, C, c, positions, cyclic, [S(pi) for pi in p], t, Q,
                     bool(system.time_dependent))


def accelerations(eq: Equations):
    """A numpy function ``(q, q̇[, t]) -> q̈`` from the printed equations, lambdified, to compare with the
    package's own acceleration: ``M q̈ = f`` or, with constraints, ``M q̈ − Cᵀλ = f`` and
    ``C q̈ = −d/dt(C q̇ + ∂c/∂t)`` without its ``q̈`` (the constraints' second derivative)."""
    sp = _sympy()
    n = len(eq.q)
    t = eq.t if eq.t is not None else sp.Symbol("t", real=True)
    if eq.C is None:
        fn = sp.lambdify([eq.q, eq.qd, t], [eq.M, eq.forces], "numpy")
    else:
        qd = sp.Matrix(eq.qd)
        cdot = eq.C * qd + sp.Matrix([sp.diff(ci, t) for ci in eq.c])
        gamma = -cdot.jacobian(eq.q) * qd - sp.diff(cdot, t)
        fn = sp.lambdify([eq.q, eq.qd, t], [eq.M, eq.forces, eq.C, gamma], "numpy")

    def acc(qv, qdv, tv=0.0):
        out = fn(list(qv), list(qdv), tv)
        M, f = np.asarray(out[0], float), np.asarray(out[1], float).reshape(-1)
        if eq.C is None:
            return np.linalg.solve(M, f)
        C, g = np.asarray(out[2], float), np.asarray(out[3], float).reshape(-1)
        m = C.shape[0]
        K = np.block([[M, -C.T], [C, np.zeros((m, m))]])
        return np.linalg.solve(K, np.concatenate([f, g]))[:n]
    return acc


def _latex_name(name: str) -> str:
    greek = {"theta", "phi", "psi", "alpha", "beta", "gamma", "delta", "omega", "lambda", "mu", "nu", "rho",
             "sigma", "tau", "xi", "eta", "zeta", "chi"}
    base = name.rstrip("0123456789")
    idx = name[len(base):]
    base = "\\" + base if base in greek else base
    return f"{base}_{{{idx}}}" if idx else base


def markdown(system, title: str, scheme: str = "midpoint", simplify: bool = True) -> str:
    """The derivation of ``system`` as Markdown with LaTeX math (see module docstring)."""
    sp = _sympy()
    eq = equations(system, simplify)
    tex = sp.latex
    n = len(eq.q)
    lines = [f"# {title}: the derivation", "",
             "Generated by castrajectory from the CasADi expressions its solver uses (not written by hand).", "",
             "## Coordinates", "", "$$q = (" + ", ".join(tex(v) for v in eq.q) + ")$$", ""]
    if eq.positions:
        lines += ["The atoms' positions $x_a = f_a(q)$:", ""]
        rows = " \\\\ "
        for a, x in enumerate(eq.positions):
            body = rows.join(tex(e) for e in x)
            lines.append(f"$$x_{{{a + 1}}} = \\begin{{pmatrix}}{body}\\end{{pmatrix}}$$")
        lines.append("")
    lines += ["## Energies and the Lagrangian", "",
              f"$$K = {tex(eq.K)}$$", "", f"$$U = {tex(eq.U)}$$", "", r"$$L = K - U$$", "",
              "The mass matrix $M(q) = \\partial^2 L / \\partial\\dot q^2$:", "", f"$$M(q) = {tex(eq.M)}$$", "",
              *(["The non-conservative generalised force (Lagrange–d'Alembert: "
                 r"$\delta\!\int L\,dt + \int Q\cdot\delta q\,dt = 0$):", "",
                 "$$Q = " + tex(eq.Q.T) + "^{\\mathsf T}$$", ""] if eq.Q is not None else []),
              "## The Euler–Lagrange equations", "",
              r"$$\frac{d}{dt}\frac{\partial L}{\partial \dot q} - \frac{\partial L}{\partial q} = "
              + " + ".join(([] if eq.Q is None else ["Q"]) + ([r"C^{\mathsf T}\lambda"] if eq.C is not None else [])
                           or ["0"]) + "$$", "",
              "written out as $M\\,\\ddot q = f(q, \\dot q" + (", t" if eq.time_dependent else "") + ")"
              + (" + C^{\\mathsf T}\\lambda" if eq.C is not None else "") + "$"
              + (" (the force $Q$ included in $f$)" if eq.Q is not None else "") + ":", ""]
    rhs = eq.forces + (eq.C.T * sp.Matrix(eq.lam) if eq.C is not None else sp.zeros(n, 1))
    lhs = eq.M * sp.Matrix(eq.qdd)
    for i in range(n):
        lines.append(f"$${tex(sp.expand(lhs[i]))} = {tex(rhs[i])}$$")
    lines.append("")
    if eq.C is not None:
        lines += ["with the holonomic constraints and their multipliers $\\lambda$:", ""]
        lines += [f"$${tex(ci)} = 0$$" for ci in eq.c] + [""]
    from ..discretise.schemes import scheme as scheme_of
    sch = scheme_of(scheme)
    lines += ["## The discrete problem", "",
              f"The `{sch.name}` discrete Lagrangian (order {sch.order}: {sch.family}), on the grid $t_k = k h$:", "",
              f"$${sch.latex()}$$", ""]
    if eq.Q is None:
        lines += ["The discrete action $S_d = \\sum_k L_d$ is stationary when, at every interior node, the discrete "
                  "Euler–Lagrange equations hold:", "",
                  r"$$D_2 L_d(q_{k-1}, q_k) + D_1 L_d(q_k, q_{k+1}) = 0,$$", "",
                  "and the discrete Legendre transforms give the momenta at the nodes, the first of which is set by "
                  "the initial condition:", "",
                  r"$$p_k^- = D_2 L_d(q_{k-1}, q_k), \qquad p_k^+ = -D_1 L_d(q_k, q_{k+1}), \qquad "
                  r"p_0^+ = \frac{\partial L}{\partial \dot q}(q_0, \dot q_0, 0).$$", ""]
    else:
        lines += ["The discrete forces are the scheme's quadrature of the virtual work, differentiated with respect "
                  "to the end points' variations (the same quadrature as $L_d$, nodes $\\tau_i$ and weights $w_i$; "
                  "$\\ell_0, \\ell_1$ the polynomial's basis functions of $q_k$ and $q_{k+1}$):", "",
                  r"$$f_k^- = h \sum_i w_i\, \ell_0(\tau_i)\, Q\big(q(\tau_i), \dot q(\tau_i), t_k + \tau_i h\big), "
                  r"\qquad f_k^+ = h \sum_i w_i\, \ell_1(\tau_i)\, Q\big(q(\tau_i), \dot q(\tau_i), "
                  r"t_k + \tau_i h\big),$$", "",
                  "and the discrete Lagrange–d'Alembert principle "
                  "$\\delta \\sum_k L_d + \\sum_k (f_k^- \\cdot \\delta q_k + f_k^+ \\cdot \\delta q_{k+1}) = 0$ "
                  "gives, at every interior node, the forced discrete Euler–Lagrange equations", "",
                  r"$$D_2 L_d(q_{k-1}, q_k) + f_{k-1}^+ + D_1 L_d(q_k, q_{k+1}) + f_k^- = 0,$$", "",
                  "with the forced discrete Legendre transforms", "",
                  r"$$p_k^- = D_2 L_d(q_{k-1}, q_k) + f_{k-1}^+, \qquad p_k^+ = -D_1 L_d(q_k, q_{k+1}) - f_k^-, "
                  r"\qquad p_0^+ = \frac{\partial L}{\partial \dot q}(q_0, \dot q_0, 0).$$", ""]
    if eq.Q is None and not eq.time_dependent:
        lines += ["## Energy", "",
                  "$L$ does not depend on time, so the energy $E = \\dot q^{\\mathsf T} \\partial L/\\partial \\dot q - L "
                  "= K + U$ is conserved; the variational scheme keeps its discrete counterpart bounded.", ""]
    else:
        lines += ["## The energy balance", "",
                  "The energy function $E = \\dot q^{\\mathsf T} \\partial L/\\partial \\dot q - L$ changes as",
                  "", r"$$\frac{dE}{dt} = Q \cdot \dot q - \frac{\partial L}{\partial t},$$", "",
                  "so $E(t) - E(0) - W(t) = 0$ with $W$ the integral of that power; the solver reports $W$ by the "
                  "scheme's quadrature, and the balance's error converges at the scheme's order.", ""]
    lines += _symmetry_lines(system, eq, sp, simplify)
    return "\n".join(lines) + "\n"


def _symmetry_lines(system, eq, sp, simplify: bool) -> List[str]:
    """The symmetries (affine, found from L itself: :mod:`castrajectory.models.symmetries`), their
    momenta, and which of the system's declared quantities the discrete solution conserves."""
    from ..models.symmetries import affine_symmetries, conserved_by
    tex = sp.latex
    S = (lambda e: sp.simplify(e)) if simplify else (lambda e: e)  # noqa: E731
    q0 = np.zeros(system.nq)
    syms = affine_symmetries(system)

    def sym(expr):
        f = ca.Function("J", [system.q, system.qd, system.t], [ca.SX(expr)])
        return S(sp.nsimplify(to_sympy(f, [eq.q, eq.qd, [eq.t]])[0][0], rational=True))
    lines = ["## Symmetries and conserved quantities", ""]
    if syms:
        lines += ["The system is invariant under these affine vector fields $\\xi(q) = A q + b$ (found from $L$, the "
                  "forces, the constraints and the contact gaps: each leaves them unchanged). By Noether's theorem "
                  "each momentum $J = \\partial L/\\partial \\dot q \\cdot \\xi(q)$ is conserved, and **exactly by the "
                  "discrete solution**: an affine map commutes with the scheme's polynomial interpolation, so the "
                  "discrete Lagrangian is invariant too (discrete Noether theorem).", ""]
        for k, sy in enumerate(syms):
            lines.append(f"- {sy.description}: $J_{{{k + 1}}} = {tex(sym(sy.momentum))}$")
        lines.append("")
    else:
        lines += ["No affine symmetry (translation, rotation or other linear vector field) leaves $L$, the forces "
                  "and the constraints unchanged, so no momentum is conserved by Noether's theorem.", ""]
    for i in eq.cyclic:
        lines.append(f"${tex(eq.q[i])}$ does not appear in $L$ (cyclic): its momentum "
                     f"$p_{{{tex(eq.q[i])}}} = {tex(eq.momenta[i])}$ is conserved, exactly by the discrete "
                     "Noether theorem.")
    if eq.cyclic:
        lines.append("")
    for name, expr in (system.quantities or {}).items():
        what = conserved_by(system, expr, syms, q0)
        head = f"The declared quantity **{name}** $= {tex(sym(expr))}$"
        if what is not None:
            lines.append(f"{head} is the momentum of the symmetry {what.description}: the discrete solution "
                         "conserves it exactly (to the solver's tolerance).")
        elif _is_energy(system, expr):
            lines.append(f"{head} is the energy: conserved by the motion; the variational scheme keeps its "
                         "error bounded, not exactly zero.")
        else:
            lines.append(f"{head} is not the momentum of an affine symmetry: the discrete solution need not "
                         "conserve it.")
        lines.append("")
    return lines


def _is_energy(system, expr) -> bool:
    """Is ``expr`` the energy function (up to a constant) of an unforced, time-independent system?"""
    if system.forced or system.time_dependent:
        return False
    rng = np.random.default_rng(5)
    f = ca.Function("e", [system.q, system.qd, system.t], [ca.SX(expr) - system.energy_expr()])
    vals = [float(f(rng.standard_normal(system.nq), rng.standard_normal(system.nq), 0.0)) for _ in range(12)]
    return bool(np.ptp(vals) <= 1e-9 * max(1.0, max(abs(v) for v in vals)))
