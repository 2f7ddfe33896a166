"""Guesses for the whole-trajectory solves: interpolation between grids, Richardson extrapolation to a
new step, the integrated motion (RK4 on substeps of the Euler–Lagrange equations) and the straight line.

A grid is a :class:`castrajectory.solve.trajectory.TrajectoryNLP` (its ``dm``, ``N``, ``T``, ``h``, ``q0``).
Every stage guess is read from the scheme's own stage times (:attr:`Scheme.stage_times
<castrajectory.discretise.schemes.Scheme.stage_times>`).  The strategies that use them are
:mod:`castrajectory.solve.trajectory`.
"""
from __future__ import annotations

from typing import Dict, Optional, Tuple

import casadi as ca
import numpy as np

from ..discretise.lagrangians import GUESS_SUBSTEPS, DiscreteMechanics, rk4_step
from . import jit
from . import nlp as _nlp

def _resample(t_old: np.ndarray, Y: np.ndarray, t_new: np.ndarray, points: int = 4) -> np.ndarray:
    """Lagrange interpolation of rows of ``Y`` on a uniform grid ``t_old`` (``points``-point stencils,
    centred and clipped at the ends: cubic for 4 points, quintic for 6)."""
    n_old = t_old.size
    if n_old < points:
        if n_old < 4:
            return np.stack([np.interp(t_new, t_old, Y[:, j]) for j in range(Y.shape[1])], axis=1)
        points = 4
    h = t_old[1] - t_old[0]
    i = np.clip(np.floor((t_new - t_old[0]) / h).astype(int) - (points // 2 - 1), 0, n_old - points)
    s = (t_new - t_old[i]) / h  # in [0, points - 1]
    out = np.zeros((t_new.size, Y.shape[1]))
    for j in range(points):
        w = np.ones_like(s)
        for k in range(points):
            if k != j:
                w *= (s - k) / (j - k)
        out += w[:, None] * Y[i + j]
    return out


#: Largest stencil of :func:`_refine`'s interpolation (points): equispaced stencils clipped at the
#: ends of the horizon grow their Lebesgue constant with the points.
MAX_REFINE_POINTS = 10


def refine_points(order: int) -> int:
    """The stencil of :func:`_refine` for a scheme of ``order``: cubic (4 points, O(h⁴)) up to order 4,
    then ``order + 2`` points (at most :data:`MAX_REFINE_POINTS`), so that the interpolation's error
    stays near the scheme's own.  A cubic stencil left the restriction of galerkin8's answer to the
    estimate's grid N/2 10 iterations from converging (the stage values between the shared nodes off
    by O(h⁴) = 1e-2 at h = 1/3: the Dzhanibekov flip, T = 100, N = 300); 6 points: 4 iterations, 10: 3."""
    return 4 if order <= 4 else min(int(order) + 2, MAX_REFINE_POINTS)


def _refine(prev, values: Dict[str, np.ndarray], nxt,
            points: Optional[int] = None) -> Dict[str, np.ndarray]:
    """Interpolate a solution on ``prev``'s grid to a guess on ``nxt``'s grid (see :func:`_resample`;
    ``points``: the stencil, :func:`refine_points` of the scheme's order by default)."""
    dm = prev.dm
    points = refine_points(dm.scheme.order) if points is None else points
    n, s, m = dm.n, dm.s, dm.m
    t_old = np.linspace(0, prev.T, prev.N + 1)
    t_new = np.linspace(0, nxt.T, nxt.N + 1)
    q_old = values["q"].reshape(prev.N + 1, n)
    q_new = _resample(t_old, q_old, t_new, points)
    q_new[0] = nxt.q0
    out = {"q": q_new.reshape(-1)}
    st = dm.scheme.stages
    c = dm.scheme.stage_times  # stage j of step k sits at t_k + c_j h
    if s:
        ts = np.concatenate([t_new[:-1, None] + c[j] * nxt.h for j in range(st)], axis=1)
        Zn = np.hstack([_resample(t_old, q_old, ts[:, j], points) for j in range(st)])
        out["Z"] = Zn.reshape(-1)
    if m and prev.mode == "initial_value":
        lam_old = values["lam"].reshape(-1, m)
        out["lam"] = _resample(t_old[:-1], lam_old, t_new[:-1], points).reshape(-1)
        if s:
            # each stage's multipliers, interpolated at its own times
            nu_old = values["nu"].reshape(prev.N, st, m)
            out["nu"] = np.stack([_resample(t_old[:-1] + c[j] * prev.h, nu_old[:, j], t_new[:-1] + c[j] * nxt.h,
                                            points) for j in range(st)], axis=1).reshape(-1)
    return out


#: Stencil (points) of the interpolations in :func:`_extrapolate`: quintic, see its docstring.
EXTRAPOLATION_POINTS = 6


def _extrapolate(coarse, fine, nxt) -> Dict[str, np.ndarray]:
    """Guess on ``nxt``'s grid from two solved levels by Richardson extrapolation *to nxt's step*.

    ``coarse`` and ``fine`` are ``(TrajectoryNLP, values)``.  With a scheme of order ``p``
    the level's error is ``e(h) ≈ C h^p``; the two levels give
    ``C h_f^p ≈ (u_c − u_f)/((h_c/h_f)^p − 1)`` (``u_c`` interpolated to the fine grid), and
    the solution on ``nxt``'s grid is ``u_f − C h_f^p (1 − (h/h_f)^p)`` — the discrete
    solution at ``h``, not the limit ``h → 0``: that is what the Newton iteration on the
    finer grid converges to.  Both interpolations use quintic stencils
    (``EXTRAPOLATION_POINTS``): a cubic one, O(H⁴), is of galerkin4's own order and left its
    extrapolated guess no better than plain interpolation (measured 6.1e-7 vs 6.7e-7;
    quintic 4.7e-8; double pendulum, T = 2, levels 100 and 200, target 1600).
    """
    (tc, vc), (tf, vf) = coarse, fine
    p = tf.dm.scheme.order
    vc_f = _refine(tc, vc, tf, EXTRAPOLATION_POINTS)
    w = (1.0 - (nxt.h / tf.h) ** p) / ((tc.h / tf.h) ** p - 1.0)
    ext = {k: vf[k] + w * (vf[k] - vc_f[k]) for k in vc_f if k in vf}
    return _refine(tf, ext, nxt, EXTRAPOLATION_POINTS)


#: The integrated guess doubles its substeps until two successive flows agree to this (the largest
#: difference at a node, per coordinate relative to 1 + the coordinate's largest magnitude): the
#: difference is the coarser flow's error, so the finer one kept is about 2⁴ = 16 times closer.
#: A motion that amplifies errors (the flip of a free body near its intermediate axis, chaos) needs
#: more substeps than a smooth one, and only it pays for them.  Measured on the Dzhanibekov flip
#: (I = (1, 2, 3), T = 100, galerkin8, N = 300), the flows' largest distance to the discrete
#: solution: 4 substeps 0.51, 8: 1.8e-2, 16: 3.0e-4, 32: 9.5e-6, and the successive differences
#: 0.50, 1.8e-2, 2.9e-4 -- the difference tracks the error to two digits.  The whole solve converges
#: from 16 substeps and fails (10 iterations, then horizon windows) from 4.
GUESS_TOL = 1e-2
#: The ladder's last rung (substeps per step).
GUESS_MAX_SUBSTEPS = 32
#: The integrated guess is used where ``h ω / GUESS_SUBSTEPS`` is at most this (RK4 is then far
#: inside its stability interval, |hλ| < 2.78); otherwise a stiff step falls back to the
#: straight line (coarsest level) or the shifted level guess (windows).
GUESS_H_OMEGA = 1.0
_FLOWS: Dict[tuple, tuple] = {}  # (id(dm), "substep") -> (dm, substep, compiled?); (id(substep), count) -> flow


def _substep(dm: DiscreteMechanics, compile_: bool) -> ca.Function:
    """One RK4 substep of the Euler–Lagrange equations, ``(x = (q, q̇), t, dt) ↦ (x', t + dt, λ')``, with
    the constraint multipliers ``λ'`` of the motion (index-1 equations) at its end.
    ``compile_``: compiled (:mod:`~castrajectory.solve.jit`), once per system (the step is an input,
    so every level, window and rung of the guess shares it); otherwise a compiled version is used only
    if one is cached (as for the NLP's element families).  One substep, not one step of the scheme: a
    step of galerkin8 with 16 substeps on the quaternion body is 117 000 instructions, past the size
    the compiler is given, and ran in CasADi's virtual machine at 1.5 ms per step; the compiled
    substep costs 2.6 us."""
    # keyed by the discrete functions (shared by the systems of the same Lagrangian: discrete_mechanics)
    key = (id(dm.del_residual), "substep")
    hit = _FLOWS.get(key)
    if hit is not None and hit[0] is dm.del_residual and (hit[2] or not compile_):  # not a reused id
        return hit[1]
    n = dm.n
    if _sparse_index1(dm):
        fast = _sparse_substep(dm, compile_)
        _FLOWS[key] = (dm.del_residual, fast, True)
        return fast
    acc, lamf = dm.system.acceleration, dm.system.multiplier
    x, ts, dt = ca.SX.sym("x", 2 * n), ca.SX.sym("t"), ca.SX.sym("dt")
    if dm.timed:
        y = rk4_step(lambda y, t: ca.vertcat(y[n:], acc(y[:n], y[n:], t)), x, dt, ts)
    else:
        y = rk4_step(lambda y: ca.vertcat(y[n:], acc(y[:n], y[n:])), x, dt)
    lam = lamf(y[:n], y[n:], ts + dt) if dm.m else ca.SX(0, 1)
    sub = ca.Function("guess_substep", [x, ts, dt], [y, ts + dt, lam])
    fast = jit.compiled(sub, compile_) if _nlp.JIT else sub
    if len(_FLOWS) > 64:
        _FLOWS.clear()
    _FLOWS[key] = (dm.del_residual, fast, fast is not sub)
    return fast


#: The integrated guess solves the index-1 equations numerically, with a sparse QR factorisation per
#: evaluation, where they have at least this many unknowns (coordinates and multipliers); below, their
#: symbolic solution is compiled (straight-line code, fastest for a few unknowns).
SPARSE_INDEX1 = 8


def _sparse_index1(dm: DiscreteMechanics) -> bool:
    return SPARSE_INDEX1 > 0 and dm.n + dm.m >= SPARSE_INDEX1


def _sparse_substep(dm: DiscreteMechanics, compile_: bool) -> ca.Function:
    """:func:`_substep` with the index-1 equations ``K (q̈, λ) = b`` assembled by a compiled function and solved
    numerically by a sparse QR factorisation at each of RK4's evaluations (CasADi's ``qr`` linear solver in an MX
    graph), instead of their symbolic solution, whose expressions grow as the cube of the unknowns: a chain of 8
    bodies in maximal coordinates (40 unknowns) ran its guess in 0.32 s per flow."""
    n = dm.n
    kkt = dm.system.index1_system
    kkt = jit.compiled(kkt, compile_) if _nlp.JIT else kkt
    x, ts, dt = ca.MX.sym("x", 2 * n), ca.MX.sym("t"), ca.MX.sym("dt")

    def solve(y, t):
        K, b = kkt(y[:n], y[n:], t)
        return ca.solve(K, b, "qr")

    y = rk4_step(lambda y, t: ca.vertcat(y[n:], solve(y, t)[:n]), x, dt, ts)
    lam = solve(y, ts + dt)[n:] if dm.m else ca.MX(0, 1)
    return ca.Function("guess_substep", [x, ts, dt], [y, ts + dt, lam])


def _pieces(dm: DiscreteMechanics, substeps: int) -> np.ndarray:
    """Substeps of each piece of a step between the scheme's control times: ``substeps /
    GUESS_SUBSTEPS`` times the pieces' base counts (``GUESS_SUBSTEPS / 2`` per step shared among the
    pieces by their lengths, at least one each), so that doubling ``substeps`` doubles every piece."""
    c = dm.scheme.control
    factor = max(1, 2 * int(substeps) // GUESS_SUBSTEPS)
    return np.array([max(1, int(round(GUESS_SUBSTEPS // 2 * float(c[j + 1] - c[j])))) * factor
                     for j in range(c.size - 1)])


def _flow_values(dm: DiscreteMechanics, q0, qd0, h: float, steps: int, t0: float,
                 substeps: int) -> Optional[Dict[str, np.ndarray]]:
    """One integrated guess: RK4 of the Euler–Lagrange equations over ``steps`` steps of length ``h``
    from ``t₀``, piece by piece between the scheme's control times (:func:`_pieces`), read at the nodes
    and the stage times, with the multipliers of the motion there (see :func:`_flow_guess`)."""
    n, s, m = dm.n, dm.s, dm.m
    counts = _pieces(dm, substeps)
    c = dm.scheme.control
    per = int(counts.sum())
    total = per * int(steps)
    sub = _substep(dm, total >= _nlp.JIT_MIN_ELEMENTS * GUESS_SUBSTEPS)
    key = (id(sub), total)
    hit = _FLOWS.get(key)
    if hit is not None and hit[0] is sub:
        fn = hit[1]
    else:
        fn = sub.mapaccum("guess_flow", total, [0, 1], [0, 1])  # (x0, t0, dts) -> (X, T, Λ)
        if len(_FLOWS) > 64:
            _FLOWS.clear()
        _FLOWS[key] = (sub, fn)
    dts = np.concatenate([np.full(k, h * float(c[j + 1] - c[j]) / k) for j, k in enumerate(counts)])
    x0 = np.concatenate([q0, qd0])
    X, _, Lam = (v.full() for v in fn(x0, float(t0), np.tile(dts, int(steps))[None, :]))
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(Lam))):
        return None
    ends = np.cumsum(counts) - 1  # the substep that ends each piece, within a step
    base = per * np.arange(int(steps))[:, None]
    X = X.T  # one row per substep
    q = np.vstack([np.asarray(q0, float)[None, :], X[base[:, 0] + ends[-1], :n]])
    out = {"q": q.reshape(-1)}
    if s:
        out["Z"] = X[(base + ends[None, :-1]).reshape(-1), :n].reshape(-1)
    if m:
        # the multipliers at the start node of each step and at its stage times
        Lam = Lam.T
        lam0 = dm.system.index1_values(q0, qd0, float(t0))[1].reshape(1, -1)
        out["lam"] = np.vstack([lam0, Lam[base[:-1, 0] + ends[-1]]]).reshape(-1)
        if s:
            out["nu"] = Lam[(base + ends[None, :-1]).reshape(-1)].reshape(-1)
    return out


def _flow_guess(dm: DiscreteMechanics, q0, qd0, h: float, steps: int, t0: float = 0.0,
                substeps: Optional[int] = None) -> Optional[Dict[str, np.ndarray]]:
    """Guess of ``steps`` steps from ``(q₀, q̇₀)`` at ``t₀`` by integrating the motion (RK4, substeps): the
    configuration at the nodes and stage times and the constraint multipliers of the motion
    (``λ`` of the index-1 equations, the discrete multipliers' sign and scale).  ``None`` if the
    integration leaves the finite numbers (then the caller keeps its own guess).  ``substeps``: as
    many as a flow of the same motion and step took before (:func:`_integrated`, which measures how many
    it needs, is used without it)."""
    if substeps is not None:
        return _flow_values(dm, q0, qd0, h, steps, t0, substeps)
    return _integrated(dm, q0, qd0, h, steps, t0)[0]


def _integrated(dm: DiscreteMechanics, q0, qd0, h: float, steps: int,
                t0: float = 0.0) -> Tuple[Optional[Dict[str, np.ndarray]], int]:
    """:func:`_flow_guess` and the substeps per step it took.

    Its accuracy is measured, not assumed: the substeps double from ``GUESS_SUBSTEPS // 2`` until two
    successive flows agree to :data:`GUESS_TOL` (or ``GUESS_MAX_SUBSTEPS`` is reached), and the finer
    one is returned.  A smooth motion stops at ``GUESS_SUBSTEPS`` (1.5 times one flow's cost); more
    says that the motion amplifies errors (:func:`castrajectory.solve.trajectory.solve_initial_value`
    then skips the coarse levels, whose guesses would part from the motion the same way)."""
    n = dm.n
    sub = max(1, GUESS_SUBSTEPS // 2)
    g = _flow_values(dm, q0, qd0, h, steps, t0, sub)
    while sub < GUESS_MAX_SUBSTEPS:
        g2 = _flow_values(dm, q0, qd0, h, steps, t0, 2 * sub)
        if g2 is None:
            return (g, sub) if sub >= GUESS_SUBSTEPS else (None, sub)
        sub *= 2
        if g is not None:
            q1, q2 = g["q"].reshape(-1, n), g2["q"].reshape(-1, n)
            scale = 1.0 + np.max(np.abs(q2), axis=0)
            if np.max(np.abs(q2 - q1) / scale) <= GUESS_TOL and sub >= GUESS_SUBSTEPS:
                return g2, sub
        g = g2
    return g, sub


def _initial_guess(tn, qd0: np.ndarray) -> Dict[str, np.ndarray]:
    """Straight-line guess ``q(t) = q0 + t q̇0`` (boundary mode: the chord from q0 to qT)."""
    dm, N = tn.dm, tn.N
    t = np.linspace(0, tn.T, N + 1)[:, None]
    if tn.mode == "initial_value":
        q = tn.q0[None, :] + t * qd0[None, :]
    else:
        q = tn.q0[None, :] + (t / tn.T) * (tn.end - tn.q0)[None, :]
    out = {"q": q.reshape(-1)}
    if dm.s:
        out["Z"] = dm.stage_guess(q[:-1], q[1:]).reshape(-1)
    if dm.m and tn.mode == "initial_value":
        out["lam"] = np.zeros(N * dm.m)
        if dm.s:
            out["nu"] = np.zeros(N * dm.scheme.stages * dm.m)
    return out
