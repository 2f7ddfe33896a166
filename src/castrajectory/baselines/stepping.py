"""Time-stepping baselines and a reference solution.

The library's own method solves for a whole trajectory at once
(:mod:`castrajectory.solve.trajectory`).  The steppers here exist only to compare
against: they march one step after another, the way a user would otherwise
integrate the Euler–Lagrange equations.

* :func:`rk4` — classical explicit Runge–Kutta 4 on the first-order form
  ``x = (q, q̇)``, ``ẋ = (q̇, q̈(q, q̇))`` (order 4, not symplectic: energy drifts);
* :func:`implicit_euler` — backward Euler on the same first-order form, one
  Newton solve per step (order 1, dissipative);
* :func:`march` — the variational integrator of :mod:`castrajectory.discretise.lagrangians`
  (midpoint, trapezoid: order 2; galerkin4: order 4) marched step by step:
  the discrete Legendre condition gives ``q_1``, then each DEL equation gives
  the next node (energy stays bounded);
* :func:`reference` — CVODES at tight tolerances, the oracle for the others.

Speed: every stepper builds one CasADi function for one step and wraps it in
``Function.mapaccum(N)``, so the whole march is a single call into CasADi's
C++ virtual machine; there is no Python loop over steps.  ``build_time_s``
(forming the functions) and ``solve_time_s`` (the march itself) are reported
separately; post-processing (momenta, velocities, energies) is in neither.

Implicit steps use CasADi's ``rootfinder(..., 'newton', ...)`` with
``abstol = abstolStep = 1e-12`` followed by one polishing Newton step (see
:func:`_implicit_solver` for why that matters).  CasADi's statistics are not
reachable per step inside ``mapaccum``, so convergence is verified afterwards
in one mapped call: at every step the remaining Newton correction
``‖J⁻¹ r‖∞`` must be below ``1e-9 (1 + ‖unknowns‖∞)`` (see
:func:`_correction`).  A run counts as successful only if every value is
finite and every step passes.  A failed run does not raise: it returns a
:class:`Stepped` with ``success = False`` and a ``message`` saying where and
what to try.

Constrained systems (``system.nc > 0``): :func:`rk4` and
:func:`implicit_euler` integrate the index-1 form of
:attr:`LagrangianSystem.acceleration` (the constraint drifts at the order of
the method); :func:`march` solves for the multipliers together with the
nodes, imposing ``c(q_{k+1}) = 0`` (and ``c(Z_k) = 0`` at galerkin4's stage),
so the constraint holds at every node to the Newton tolerance;
:func:`reference` refuses them.  The initial state must be consistent:
``c(q0) = 0`` and ``C(q0) q̇0 = 0``.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Optional, Tuple
from types import SimpleNamespace

import casadi as ca
import numpy as np

from ..discretise.lagrangians import SCHEMES, DiscreteMechanics, rk4_step
from ..models.mechanics import LagrangianSystem
from ..result import Result
from ..validation import InputError, integer_at_least, one_of, positive, state_vector

__all__ = ["Stepped", "rk4", "implicit_euler", "march", "reference"]

#: Newton options for every implicit step.
NEWTON_ABSTOL = 1e-12
NEWTON_ABSTOL_STEP = 1e-12
NEWTON_MAX_ITER = 50
#: CasADi rootfinder plugin.  "newton" has a line search; "fast_newton" (no line
#: search) marched the double pendulum about twice as fast in a quick test.
NEWTON_PLUGIN = "newton"

#: A step counts as converged when its remaining Newton correction satisfies
#: ``‖J⁻¹ r‖∞ <= NEWTON_ACCEPT * (1 + ‖unknowns‖∞)``.
NEWTON_ACCEPT = 1e-9


# ----------------------------------------------------------------------------- result
@dataclass(kw_only=True)
class Stepped(Result):
    """A marched trajectory (the contract of :class:`castrajectory.result.Result`, plus these).

    ``t`` (N+1,), ``q`` and ``qd`` (N+1, n), ``energy`` (N+1,).  For the
    variational integrator ``qd`` comes from the discrete Legendre transform
    (``q̇ = M(q)⁻¹ p``, projected onto the constraint tangent) and ``p``
    holds the nodal momenta.  ``lam`` (N, nc), constrained marches only: row 0
    is the multiplier of ``initial_residual``, row k ≥ 1 that of
    ``del_residual`` at node k; both are the physical multipliers
    (see :class:`~castrajectory.discretise.lagrangians.DiscreteMechanics`).  ``newton_error`` is the largest remaining
    Newton correction ``‖J⁻¹ r‖∞`` over all steps of an implicit method — the
    solve error of the step unknowns (NaN for RK4 and for non-finite runs).
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    energy: np.ndarray
    method: str
    scheme: Optional[str]
    newton_error: float = float("nan")
    p: Optional[np.ndarray] = None
    lam: Optional[np.ndarray] = None
    #: work of the forces and of the time dependence up to each node (forced or time-dependent systems)
    work: Optional[np.ndarray] = None

    @property
    def h(self) -> float:
        return float(self.t[1] - self.t[0])

    def as_dict(self) -> dict:
        return {**super().as_dict(), "scheme": self.scheme, "method": self.method, "t": self.t, "q": self.q,
                "qd": self.qd, "energy": self.energy}


# ----------------------------------------------------------------------------- input checks
def _check_state(system: LagrangianSystem, q0, qd0) -> Tuple[np.ndarray, np.ndarray]:
    if not isinstance(system, LagrangianSystem):
        raise InputError(f"system must be a LagrangianSystem (got {type(system).__name__})")
    n = system.nq
    q0, qd0 = state_vector("q0", q0, n, system.names), state_vector("qd0", qd0, n, system.names)
    if system.nc:
        c, C = system.constraint(q0, 0.0)
        c, C = np.asarray(c).reshape(-1), np.asarray(C)
        if np.max(np.abs(c)) > 1e-8 * (1.0 + np.max(np.abs(q0))):
            raise InputError(f"q0 violates the holonomic constraints (|c(q0)| = {np.max(np.abs(c)):.3g})")
        Cv = C @ qd0 + np.asarray(system.constraint_rate(q0, 0.0)).reshape(-1)
        if np.max(np.abs(Cv)) > 1e-8 * (1.0 + np.max(np.abs(qd0))):
            raise InputError(f"qd0 is not tangent to the constraints (|C(q0) qd0| = {np.max(np.abs(Cv)):.3g})")
    return q0, qd0


def _check(system, q0, qd0, T, N):
    q0, qd0 = _check_state(system, q0, qd0)
    T = positive("T", T)
    N = integer_at_least("N", N, 2)
    return q0, qd0, T, N


# ----------------------------------------------------------------------------- helpers
def _first_order(system: LagrangianSystem, work: bool = False):
    """SX state ``x = (q, q̇)``, the time ``t`` and the right-hand side expression ``(q̇, q̈(q, q̇, t))``;
    ``work``: the state also holds the work of the forces and of the time dependence, whose rates are
    ``(Q·q̇, −∂L/∂t)`` (:attr:`LagrangianSystem.power`), integrated by the same method."""
    n = system.nq
    x, t = ca.SX.sym("x", 2 * n + (2 if work else 0)), ca.SX.sym("t")
    f = ca.vertcat(x[n:2 * n], system.acceleration(x[:n], x[n:2 * n], t))
    if work:
        f = ca.vertcat(f, *system.power(x[:n], x[n:2 * n], t))
    return x, t, f


def _carries_work(system: LagrangianSystem) -> bool:
    return bool(system.forced or system.time_dependent)


def _implicit_solver(name: str, residual, y, par) -> ca.Function:
    """``(guess, par) -> y`` solving ``residual(y, par) = 0``: CasADi Newton, then one polishing step.

    CasADi's Newton stops when a step falls below ``abstolStep`` *without taking
    it*, so its answer is off by up to that much.  In a march such a per-step
    error acts like a velocity kick of ``abstolStep / h`` and, in a chaotic
    system, grows: at h = 1.6e-4 it cost galerkin4 four orders of magnitude of
    accuracy.  One more Newton step ``y − J⁻¹ r`` (quadratic convergence) takes
    the answer to round-off for the price of one Jacobian.
    """
    g = ca.Function(f"{name}_residual", [y, par], [residual])
    newton = ca.rootfinder(f"{name}_newton", NEWTON_PLUGIN, g, {
        "abstol": NEWTON_ABSTOL, "abstolStep": NEWTON_ABSTOL_STEP,
        "max_iter": NEWTON_MAX_ITER, "error_on_fail": False,
        "show_eval_warnings": False})  # a NaN step is reported once, in the result's message
    polish = ca.Function(f"{name}_polish", [y, par], [y - ca.solve(ca.jacobian(residual, y), residual)])
    G, P = ca.MX.sym("guess", y.numel()), ca.MX.sym("par", par.numel())
    return ca.Function(f"{name}_solve", [G, P], [polish(newton(G, P), P)])


def _correction(residual, y, par) -> ca.Function:
    """``(y, par) -> (‖J⁻¹ r‖∞, ‖y‖∞)`` for a step residual ``r(y, par)``.

    ``J⁻¹ r`` is the Newton step still to be taken at ``y``: the error of the
    solved unknowns.  Unlike the residual itself (which for the h-scaled DEL
    equations sits at round-off ``~ eps |q| M / h²``), it is ``~ eps |y|`` at a
    converged point whatever ``h`` is, so one threshold fits every step size.
    """
    d = ca.solve(ca.jacobian(residual, y), residual)
    return ca.Function("newton_correction", [y, par], [ca.norm_inf(d), ca.norm_inf(y)])


def _corrections(fn: ca.Function, Y: np.ndarray, P: np.ndarray) -> np.ndarray:
    """Evaluate :func:`_correction` for every row of ``Y``/``P`` in one mapped call: (K, 2)."""
    d, ynorm = fn.map(Y.shape[0])(Y.T, P.T)
    return np.column_stack([np.asarray(d).reshape(-1), np.asarray(ynorm).reshape(-1)])


def _timed_march(march_fn: ca.Function, x0: np.ndarray, T: float, N: int):
    """Run a ``mapaccum`` march from ``x0``: ``(t, states with x0 as row 0, wall time of the march)``."""
    t0 = time.perf_counter()
    Xs = march_fn(x0)
    solve = time.perf_counter() - t0
    return np.linspace(0.0, T, N + 1), np.vstack([x0, np.asarray(Xs).T]), solve


def _first_bad(arr: np.ndarray) -> int:
    """Index of the first row of ``arr`` with a non-finite entry (or -1)."""
    bad = ~np.all(np.isfinite(arr.reshape(arr.shape[0], -1)), axis=1)
    return int(np.argmax(bad)) if bad.any() else -1


def _verdict(t, x: np.ndarray, corr: Optional[np.ndarray], what: str) -> Tuple[bool, str, float]:
    """``success, message, largest correction`` for a march.

    ``x``: states, one row per node (row k at ``t[k]``); ``corr``: (K, 2) rows
    ``(‖J⁻¹r‖∞, ‖y‖∞)`` of the implicit steps, row k for the step that produced
    node k + 1 (None for explicit methods).
    """
    k = _first_bad(x)
    if k >= 0:
        return False, (f"{what}: non-finite state at t = {t[k]:.6g} (node {k}); "
                       "reduce the step (increase N) or check the model's domain"), float("nan")
    if corr is None:
        return True, f"{what}: ok", float("nan")
    d, ynorm = corr[:, 0], corr[:, 1]
    worst = float(np.max(d)) if np.all(np.isfinite(d)) else float("nan")
    bad = ~(d <= NEWTON_ACCEPT * (1.0 + ynorm))
    if bad.any():
        k = int(np.argmax(bad))
        return False, (f"{what}: Newton did not converge in step {k} (t = {t[k]:.6g} -> {t[k + 1]:.6g}, "
                       f"remaining correction {d[k]:.3g}); increase N"), worst
    return True, f"{what}: ok (largest remaining Newton correction {worst:.2g})", worst


# ----------------------------------------------------------------------------- RK4
def rk4(system: LagrangianSystem, q0, qd0, T: float, N: int) -> Stepped:
    """Classical RK4 with ``N`` equal steps over ``[0, T]`` from ``(q0, q̇0)``."""
    q0, qd0, T, N = _check(system, q0, qd0, T, N)
    n, h = system.nq, T / N
    t0 = time.perf_counter()
    cw = _carries_work(system)
    x, ts, f = _first_order(system, cw)
    nx = x.numel()
    rhs = ca.Function("rhs", [x, ts], [f])
    # the state carries its time (x, t): a time-dependent system's steps each start at their own time
    xt = ca.SX.sym("xt", nx + 1)
    step = ca.Function("rk4_step", [xt], [ca.vertcat(rk4_step(rhs, xt[:nx], h, xt[nx]), xt[nx] + h)])
    march_fn = step.mapaccum("rk4_march", N)
    build = time.perf_counter() - t0

    t, X, solve = _timed_march(march_fn, np.concatenate([q0, qd0, np.zeros(nx - 2 * n), [0.0]]), T, N)
    W = X[:, 2 * n] + X[:, 2 * n + 1] if cw else None
    X = X[:, :2 * n]
    ok, msg, _ = _verdict(t, X, None, "rk4")
    q, qd = X[:, :n], X[:, n:]
    return Stepped(t=t, q=q, qd=qd, energy=system.energies(q, qd, t), method="rk4", scheme=None, build_time_s=build,
                   solve_time_s=solve, success=ok, message=msg, work=W)


# ----------------------------------------------------------------------------- implicit Euler
def implicit_euler(system: LagrangianSystem, q0, qd0, T: float, N: int) -> Stepped:
    """Backward Euler ``x_{k+1} = x_k + h f(x_{k+1})``; Newton per step from the explicit-Euler guess."""
    q0, qd0, T, N = _check(system, q0, qd0, T, N)
    n, h = system.nq, T / N
    t0 = time.perf_counter()
    cw = _carries_work(system)
    x, ts, f = _first_order(system, cw)
    nx = x.numel()
    rhs = ca.Function("rhs", [x, ts], [f])
    xo = ca.SX.sym("x_old", nx + 1)  # the old state and its time
    r = x - xo[:nx] - h * ca.substitute(f, ts, xo[nx] + h)
    newton = _implicit_solver("ie", r, x, xo)
    X = ca.MX.sym("x", nx + 1)
    Xn = newton(X[:nx] + h * rhs(X[:nx], X[nx]), X)
    step = ca.Function("ie_step", [X], [ca.vertcat(Xn, X[nx] + h)])
    march_fn = step.mapaccum("ie_march", N)
    build = time.perf_counter() - t0

    t, Xt, solve = _timed_march(march_fn, np.concatenate([q0, qd0, np.zeros(nx - 2 * n), [0.0]]), T, N)
    W = Xt[:, 2 * n] + Xt[:, 2 * n + 1] if cw else None
    X = Xt[:, :nx]
    corr = _corrections(_correction(r, x, xo), X[1:], Xt[:-1]) if _first_bad(X) < 0 else None
    ok, msg, worst = _verdict(t, X, corr, "implicit_euler")
    q, qd = X[:, :n], X[:, n:2 * n]
    return Stepped(t=t, q=q, qd=qd, energy=system.energies(q, qd, t), method="implicit_euler", scheme=None,
                   build_time_s=build, solve_time_s=solve, success=ok, message=msg, newton_error=worst, work=W)


# ----------------------------------------------------------------------------- variational integrator
def _vi_functions(dm: DiscreteMechanics, h: float, N: int) -> SimpleNamespace:
    """The variational integrator's step functions: the first step's Newton solve ``first((q0, p0)) -> y0``, the march
    of the others ``march_fn`` (a mapaccum of N − 1 steps over the state ``S = (q_{k−1}, y_{k−1}, t_k)``), and the rows
    ``r0``, ``r`` with their unknowns ``y = (Z, q_next, lam, nu)`` and parameters, for the corrections."""
    n, s, m, ns = dm.n, dm.s, dm.m, dm.scheme.stages
    nmult = m + m * ns  # node multipliers lam, stage multipliers nu

    # unknowns of one step: y = (Z, q_next, lam, nu)
    ny = s + n + nmult
    y = ca.SX.sym("y", ny)
    Zy, qy, lamy, nuy = y[:s], y[s:s + n], y[s + n:s + n + m], y[s + n + m:]
    none = np.zeros(0)   # the elements' controls: a baseline marches a system without controls

    def closing_rows(a, tk):
        """Stage equations and constraint rows of the step that starts at node ``a`` at the time ``tk``."""
        rows = [dm.stage_residual(a, Zy, qy, nuy, h, tk, none)] if s else []
        if m:
            rows += [dm.constraint_rows(qy, tk + h)]
            rows += [dm.stage_constraint_rows[j](Zy[j * n:(j + 1) * n], tk, h) for j in range(ns)]
        return rows

    # step 0: parameters (q0, p0) -> y0 = (Z0, q1, lam0, nu0)
    q0s, p0s = ca.SX.sym("q0", n), ca.SX.sym("p0", n)
    par0 = ca.vertcat(q0s, p0s)
    r0 = ca.vertcat(dm.initial_residual(q0s, Zy, qy, p0s, lamy, h, 0.0, none), *closing_rows(q0s, 0.0))
    first = _implicit_solver("vi_first", r0, y, par0)

    # step k >= 1: state S = (q_{k-1}, y_{k-1}, t_k) = (q_{k-1}, Z_{k-1}, q_k, lam_{k-1}, nu_{k-1}, t_k) -> (q_k, y_k, t_{k+1})
    S = ca.SX.sym("S", n + ny + 1)
    qm, Zm, qk, tk = S[:n], S[n:n + s], S[n + s:2 * n + s], S[n + ny]
    r = ca.vertcat(dm.del_residual(qm, Zm, qk, Zy, qy, lamy, h, tk, none, none), *closing_rows(qk, tk))
    newton = _implicit_solver("vi", r, y, S)
    Sx = ca.MX.sym("S", n + ny + 1)
    qm_, Zm_, qk_, mult_ = Sx[:n], Sx[n:n + s], Sx[n + s:2 * n + s], Sx[2 * n + s:n + ny]
    Zg = Zm_ + ca.repmat(qk_ - qm_, ns, 1) if s else Zm_  # Z_k ≈ Z_{k-1} + (q_k - q_{k-1})
    guess = ca.vertcat(Zg, 2 * qk_ - qm_, mult_)
    step = ca.Function("vi_step", [Sx], [ca.vertcat(qk_, newton(guess, Sx), Sx[n + ny] + h)])
    march_fn = step.mapaccum("vi_march", N - 1)
    return SimpleNamespace(first=first, march_fn=march_fn, r0=r0, r=r, y=y, par0=par0, S=S, nmult=nmult)


def march(system: LagrangianSystem, q0, qd0, T: float, N: int, scheme: str = "midpoint") -> Stepped:
    """The variational integrator of ``scheme`` (see :mod:`castrajectory.discretise.lagrangians`) marched step by step.

    Step 0 solves the discrete Legendre condition
    ``p0 + D₁L_d(q0, Z0, q1) = 0`` (with ``p0 = ∂L/∂q̇(q0, q̇0)``) for ``(Z0, q1)``;
    step k ≥ 1 solves the DEL equation at node k for ``(Z_k, q_{k+1})``.  With
    stages (galerkin4) the stage equations ``∂L_d/∂Z_k = 0`` join in; with
    constraints the multipliers ``λ_k`` (and stage ``ν_k``) are unknowns too,
    and ``c(q_{k+1}) = 0`` (and ``c(Z_k) = 0``) close the system.  Newton
    starts from linear extrapolation.  Velocities come from the nodal momenta
    ``p_k⁺ = −D₁L_d(q_k, q_{k+1})`` (``p_N⁻ = D₂L_d(q_{N−1}, q_N)``).
    """
    q0, qd0, T, N = _check(system, q0, qd0, T, N)
    one_of("scheme", scheme, tuple(SCHEMES))
    h = T / N
    t0 = time.perf_counter()
    dm = DiscreteMechanics(system, scheme)
    n, s, m = dm.n, dm.s, dm.m
    vi = _vi_functions(dm, h, N)
    first, march_fn, r0, r, y, par0, S, nmult = vi.first, vi.march_fn, vi.r0, vi.r, vi.y, vi.par0, vi.S, vi.nmult
    build = time.perf_counter() - t0

    t0 = time.perf_counter()
    p0 = np.asarray(system.momentum(q0, qd0, 0.0)).reshape(-1)
    q1g = dm.first_step_guess(q0, qd0, h, 0.0)
    y0g = np.concatenate([dm.stage_guess(q0[None, :], q1g[None, :]).reshape(-1), q1g, np.zeros(nmult)])
    y0 = np.asarray(first(y0g, np.concatenate([q0, p0]))).reshape(-1)
    S1 = np.concatenate([q0, y0, [h]])
    Ss = march_fn(S1)
    solve = time.perf_counter() - t0

    Sall = np.vstack([S1, np.asarray(Ss).T])[:, :-1]  # row k = (q_k, y_k), k = 0..N-1
    Y = Sall[:, n:]                                    # row k = (Z_k, q_{k+1}, lam_k, nu_k)
    Z, lam = Y[:, :s], Y[:, s + n:s + n + m]
    q = np.vstack([q0, Y[:, s:s + n]])
    t = np.linspace(0.0, T, N + 1)
    what = f"march({scheme})"
    nan_nodes = np.full_like(q, np.nan)
    k = _first_bad(Y)
    if k >= 0:
        msg = (f"{what}: non-finite values in step {k} (t = {t[k]:.6g} -> {t[k + 1]:.6g}); "
               "increase N or check the model's domain")
        return Stepped(t=t, q=q, qd=nan_nodes, energy=np.full(N + 1, np.nan), method="variational", scheme=scheme,
                       build_time_s=build, solve_time_s=solve, success=False, message=msg, p=nan_nodes,
                       lam=lam if m else None)
    Sk = np.hstack([Sall[:-1], t[1:N, None]])  # the state of step k >= 1 with its node time t_k
    corr = np.vstack([_corrections(_correction(r0, y, par0), y0[None, :], np.concatenate([q0, p0])[None, :]),
                      _corrections(_correction(r, y, S), Y[1:], Sk)])
    p = dm.momenta(q, Z, h)
    qd = dm.velocities(q, p, t)
    ok, msg, worst = _verdict(t, np.hstack([q, qd]), corr, what)
    wk = dm.work(q, Z, h) if _carries_work(system) else None
    return Stepped(t=t, q=q, qd=qd, energy=system.energies(q, qd, t), method="variational", scheme=scheme,
                   build_time_s=build, solve_time_s=solve, success=ok, message=msg, newton_error=worst, p=p,
                   lam=lam if m else None, work=None if wk is None else wk.sum(axis=1))


# ----------------------------------------------------------------------------- reference
def reference(system: LagrangianSystem, q0, qd0, t_eval, rtol: float = 1e-12,
              atol: float = 1e-12, stiff: bool = False) -> Tuple[np.ndarray, np.ndarray]:
    """CVODES solution of the Euler–Lagrange ODE from ``(q0, q̇0)`` at ``t = 0``.

    ``t_eval``: strictly increasing output times, ``t_eval[0] >= 0`` (0 may be
    included).  Returns ``(q, q̇)``, each of shape ``(len(t_eval), n)``.
    Unconstrained systems only.  Raises ``RuntimeError`` if CVODES fails.

    CVODES runs its Adams method (``stiff=True``: BDF).  For the double
    pendulum at tolerance 1e-12 Adams was 10–20 times more accurate than BDF
    (error 5e-11 against 7e-10 at T = 2) and faster; ``rtol = atol = 1e-14``
    agrees with RK4 at 200 000 steps to 2e-13.
    """
    if isinstance(system, LagrangianSystem) and system.nc:
        raise ValueError("reference() handles unconstrained systems only "
                         "(use an unconstrained coordinate form, e.g. angles instead of (x, y))")
    q0, qd0 = _check_state(system, q0, qd0)
    rtol, atol = positive("rtol", rtol), positive("atol", atol)
    try:
        te = np.asarray(t_eval, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InputError("t_eval must be a sequence of times") from None
    if te.size < 1 or not np.all(np.isfinite(te)):
        raise InputError("t_eval must be a non-empty sequence of finite times")
    if te[0] < 0 or np.any(np.diff(te) <= 0):
        raise InputError("t_eval must be strictly increasing and start at t >= 0")
    n = system.nq
    x, ts, f = _first_order(system)
    opts = {"abstol": atol, "reltol": rtol, "max_num_steps": 10 ** 7,
            "linear_multistep_method": "bdf" if stiff else "adams"}
    dae = {"x": x, "ode": f, **({"t": ts} if ca.depends_on(f, ts) else {})}
    F = ca.integrator("ref", "cvodes", dae, 0.0, te, opts)
    try:
        X = np.asarray(F(x0=np.concatenate([q0, qd0]))["xf"]).reshape(2 * n, te.size).T
    except RuntimeError as err:
        raise RuntimeError(f"reference integration (CVODES) failed: {err}") from None
    return X[:, :n].copy(), X[:, n:].copy()


# ----------------------------------------------------------------------------- contact baseline
def moreau_jean(system: LagrangianSystem, q0, qd0, T: float, N: int, sweeps: int = 50) -> Stepped:
    """Moreau–Jean time stepping (θ = ½) for a system with a Contact term: the classical baseline.

    Each step: ``q_m = q_k + h/2 v_k``; the contacts whose gap at ``q_m`` is
    closed are active; ``M (v_{k+1} − v_k) = h f(q_m, v_k) + Σ_j ∇φ_jᵀ μ_j`` with
    Newton's law at velocity level ``∇φ_j v_{k+1} + e ∇φ_j v_k ≥ 0 ⟂ μ_j ≥ 0``
    (active contacts; projected Gauss–Seidel); ``q_{k+1} = q_m + h/2 v_{k+1}``.
    Impacts happen at steps, not at the impact time: first order in h.
    """
    q0, qd0, T, N = _check(system, q0, qd0, T, N)
    if system.contact is None:
        raise InputError("moreau_jean needs a system with a Contact term")
    e = system.contact.restitution
    t0 = time.perf_counter()
    acc, gap, Mf = system.acceleration, system.gap, system.mass_matrix
    build = time.perf_counter() - t0
    t0 = time.perf_counter()
    h = T / N
    q = np.zeros((N + 1, system.nq))
    v = np.zeros_like(q)
    q[0], v[0] = q0, qd0
    for k in range(N):
        qm = q[k] + 0.5 * h * v[k]
        M = np.asarray(Mf(qm))
        vf = v[k] + h * np.asarray(acc(qm, v[k])).reshape(-1)
        phi, J = (np.asarray(x) for x in gap(qm))
        active = np.where(phi.reshape(-1) <= 0.0)[0]
        vn = vf
        if active.size:
            Ja = J[active]
            W = Ja @ np.linalg.solve(M, Ja.T)
            MiJt = np.linalg.solve(M, Ja.T)
            target = -e * (Ja @ v[k])
            mu = np.zeros(active.size)
            for _ in range(sweeps):
                for i in range(active.size):
                    r = Ja[i] @ (vf + MiJt @ mu) - target[i]
                    mu[i] = max(0.0, mu[i] - r / W[i, i])
            vn = vf + MiJt @ mu
        v[k + 1] = vn
        q[k + 1] = qm + 0.5 * h * vn
    solve = time.perf_counter() - t0
    t = np.linspace(0.0, T, N + 1)
    ok = bool(np.all(np.isfinite(q)))
    return Stepped(t=t, q=q, qd=v, energy=system.energies(q, v), method="moreau-jean", scheme=None,
                   build_time_s=build, solve_time_s=solve, success=ok,
                   message="marched" if ok else "non-finite state")
