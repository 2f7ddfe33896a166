"""Guesses for the whole-trajectory solves: interpolation between grids, Richardson extrapolation to a
new step, the integrated motion (RK4 on substeps of the Euler–Lagrange equations) and the straight line.

A grid is a :class:`castrajectory.solve.trajectory.TrajectoryNLP` (its ``dm``, ``N``, ``T``, ``h``, ``q0``).
Every stage guess is read from the scheme's own stage times (:attr:`Scheme.stage_times
<castrajectory.discretise.schemes.Scheme.stage_times>`).  The strategies that use them are
:mod:`castrajectory.solve.trajectory`.
"""
from __future__ import annotations

from typing import Dict, Optional

import casadi as ca
import numpy as np

from ..discretise.lagrangians import DiscreteMechanics, rk4_step
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


def _refine(prev, values: Dict[str, np.ndarray], nxt,
            points: int = 4) -> Dict[str, np.ndarray]:
    """Interpolate a solution on ``prev``'s grid to a guess on ``nxt``'s grid (see :func:`_resample`)."""
    dm = prev.dm
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


#: RK4 substeps per step of the integrated guesses (:func:`_flow_guess`).
GUESS_SUBSTEPS = 4
#: The integrated guess is used where ``h ω / GUESS_SUBSTEPS`` is at most this (RK4 is then far
#: inside its stability interval, |hλ| < 2.78); otherwise a stiff step falls back to the
#: straight line (coarsest level) or the shifted level guess (windows).
GUESS_H_OMEGA = 1.0
_FLOWS: Dict[tuple, tuple] = {}  # (id(dm), "step") -> (dm, step, compiled?); (id(step), steps) -> (step, flow)


def _flow_step(dm: DiscreteMechanics, compile_: bool) -> ca.Function:
    """One step ``(x₀ = (q, q̇), h, t₀) ↦`` (state at its end node, configurations at the scheme's stage
    times, multipliers at its start node and at the stage times): RK4 of the Euler–Lagrange equations,
    piece by piece between the scheme's control times (``GUESS_SUBSTEPS`` substeps per step, shared
    among the pieces by their lengths, at least one each).  ``compile_``: compiled
    (:mod:`~castrajectory.solve.jit`), once per system and scheme (``h`` and ``t₀`` are inputs, so every
    level and window shares it); otherwise a compiled version is used only if one is cached (as for
    the NLP's element families)."""
    # keyed by the discrete functions (shared by the systems of the same Lagrangian: discrete_mechanics)
    key = (id(dm.del_residual), "step")
    hit = _FLOWS.get(key)
    if hit is not None and hit[0] is dm.del_residual and (hit[2] or not compile_):  # not a reused id
        return hit[1]
    n = dm.n
    acc, lamf = dm.system.acceleration, dm.system.multiplier
    x, hs, ts = ca.SX.sym("x", 2 * n), ca.SX.sym("h"), ca.SX.sym("t0")
    if dm.timed:
        f = lambda y, t: ca.vertcat(y[n:], acc(y[:n], y[n:], t))  # noqa: E731
        lam_at = lambda y, t: lamf(y[:n], y[n:], t)  # noqa: E731
    else:
        f = lambda y: ca.vertcat(y[n:], acc(y[:n], y[n:]))  # noqa: E731
        lam_at = lambda y, t: lamf(y[:n], y[n:])  # noqa: E731
    c = dm.scheme.control
    y, t, stage, stage_lam = x, ts, [], []
    for j in range(c.size - 1):
        length = float(c[j + 1] - c[j])
        sub = max(1, int(round(GUESS_SUBSTEPS * length)))
        dt = hs / sub if length == 1.0 else hs * length / sub
        for _ in range(sub):
            y = rk4_step(f, y, dt, t if dm.timed else None)
            t = t + dt
        if j < c.size - 2:
            stage.append(y[:n])
            stage_lam.append(lam_at(y, t))
    empty = ca.SX(0, 1)
    step = ca.Function("guess_step", [x, hs, ts], [y, ca.vertcat(*stage) if stage else empty, lam_at(x, ts),
                                                   ca.vertcat(*stage_lam) if stage_lam else empty])
    # a short flow uses a compiled step only if one was compiled before (found by its serialised form,
    # without generating its C code: jit's index); a long one compiles it
    fast = jit.compiled(step, compile_) if _nlp.JIT else step
    if len(_FLOWS) > 64:
        _FLOWS.clear()
    _FLOWS[key] = (dm.del_residual, fast, fast is not step)
    return fast


def _flow(dm: DiscreteMechanics, h: float, steps: int, t0: float = 0.0):
    """:func:`_flow_step` over ``steps`` steps of length ``h`` from ``t0``: ``x₀ ↦`` one column per step."""
    step = _flow_step(dm, steps >= _nlp.JIT_MIN_ELEMENTS)
    key = (id(step), int(steps))
    hit = _FLOWS.get(key)
    if hit is not None and hit[0] is step:
        fn = hit[1]
    else:
        # the step's start time is accumulated: the time is the step function's third input and output
        xs, hs, ts = ca.MX.sym("x", 2 * dm.n), ca.MX.sym("h"), ca.MX.sym("t")
        out = step(xs, hs, ts)
        timed = ca.Function("guess_step_t", [xs, hs, ts], [out[0], ts + hs, out[1], out[2], out[3]])
        acc = timed.mapaccum("guess_flow", int(steps), [0, 2], [0, 1])
        fn = acc
        if len(_FLOWS) > 64:
            _FLOWS.clear()
        _FLOWS[key] = (step, fn)

    def run(x0):
        out = fn(x0, float(h), float(t0))  # (end state, end time, stages, multipliers, stage multipliers)
        return [out[0], out[2], out[3], out[4]]
    return run


def _flow_guess(dm: DiscreteMechanics, q0, qd0, h: float, steps: int, t0: float = 0.0) -> Optional[Dict[str, np.ndarray]]:
    """Guess of ``steps`` steps from ``(q₀, q̇₀)`` at ``t₀`` by integrating the motion (RK4, substeps): the
    configuration at the nodes and stage times and the constraint multipliers of the motion
    (``λ`` of the index-1 equations, the discrete multipliers' sign and scale).  ``None`` if the
    integration leaves the finite numbers (then the caller keeps its own guess)."""
    n, s, m = dm.n, dm.s, dm.m
    out_f = _flow(dm, h, steps, t0)(np.concatenate([q0, qd0]))
    X, S, Lam, Nu = (np.asarray(v) for v in out_f)
    if not all(np.all(np.isfinite(v)) for v in (X, S, Lam, Nu)):
        return None
    q = np.vstack([np.asarray(q0, float)[None, :], X[:n].T])
    out = {"q": q.reshape(-1)}
    if s:
        out["Z"] = S.T.reshape(-1)
    if m:
        out["lam"] = Lam.T.reshape(-1)
        if s:
            out["nu"] = Nu.T.reshape(-1)
    return out


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
