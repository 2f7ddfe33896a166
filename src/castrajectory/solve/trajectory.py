"""Whole-trajectory solves: all discrete Euler–Lagrange equations in one NLP, handed to Ipopt.

The rows are written by :class:`castrajectory.discretise.trajectory.TrajectoryTranscription`;
this module solves them.

Two modes: **initial value** (:func:`solve_initial_value`: ``q_0`` and ``q̇_0`` given, a square
system of DEL equations with a zero objective, on which Ipopt performs a globalised Newton
method) and **two-point boundary** (:func:`solve_boundary`: ``q_0`` and ``q_N`` given; Ipopt
*minimises* the discrete action — least action proper).

Robust strategy (initial value), chosen by the library:

1. **coarse to fine** — solve on ``N/2^j`` steps first (coarsest ≥ 32 steps and
   fine enough that ``h ω ≤ 0.5`` for the fastest linearised frequency at the start),
   to tolerance ``COARSE_TOL``; the guess of the next level is the last solution
   interpolated (cubic), or from the third level on the Richardson extrapolation of
   the last two *to the new step* (:func:`_extrapolate`, quintic interpolation).
   A level that converged from such a guess in one Newton iteration is followed by
   the requested N itself;
2. **horizon continuation** — if a level does not converge from its guess
   (chaotic motion: a coarse solution can differ O(1) from the fine one at
   late times), march a window over the trajectory: each window is itself a
   small whole-trajectory initial-value solve of ``L`` steps started from the
   last solved node and its discrete momentum ``p⁻ = D₂L_d``; ``L`` doubles
   after a success and halves after a failure.  The assembled trajectory is
   the guess of a final whole solve at that level with every equation active.

The status reported is always that of the last whole-trajectory solve at the
requested N; levels and windows are listed in :attr:`Trajectory.levels`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Dict, List, Optional

import casadi as ca
import numpy as np

from ..discretise.lagrangians import SCHEMES, DiscreteMechanics, discrete_mechanics
from ..discretise.trajectory import TrajectoryTranscription
from . import estimate, memory
from ..models.mechanics import LagrangianSystem
from ..result import NLPResult, Result
from .guesses import (EXTRAPOLATION_POINTS, GUESS_H_OMEGA, GUESS_SUBSTEPS, _extrapolate,  # noqa: F401
                      _flow_guess, _initial_guess, _integrated, _refine)  # (EXTRAPOLATION_POINTS: the tests read it here)
from .nlp import NEWTON_MAX_ITER, NEWTON_MIN_BLOCK, NLP
from ..validation import InputError, integer_at_least, one_of, positive, state_vector

#: Ipopt settings for the square DEL systems (MUMPS scaling off: see solve.nlp.DEFAULT_IPOPT_OPTIONS).
#: ``min_refinement_steps 0``: no forced iterative-refinement solve per KKT solve (Ipopt still
#: refines when the residual ratio asks for it); measured 0.17 -> 0.145 s for the 1-iteration
#: final solve of the double pendulum at N = 32000 (midpoint), 0.33 -> 0.28 s (galerkin4).
#: ``mumps_pivot_order = 6`` (QAMD) instead of MUMPS' automatic choice: wall time of simulate(), best of 4,
#: alternating in one process (double pendulum, T = 5): galerkin4 N = 4000 0.188 -> 0.137 s, N = 8000
#: 0.281 -> 0.185 s; midpoint N = 32000 0.725 -> 0.512 s.
TRAJECTORY_IPOPT = {"tol": 1e-12, "max_iter": 100, "constr_mult_init_max": 0, "min_refinement_steps": 0,
                    "mumps_pivtol": 1e-8, "mumps_pivot_order": 6}


@dataclass
class Level:
    """One whole-trajectory solve on the way to the answer (a record: ``status`` is Ipopt's return status)."""

    n: int
    horizon: int  # nodes with active equations (n = full trajectory)
    status: str
    iterations: int
    build_time_s: float
    solve_time_s: float
    #: part of solve_time_s spent evaluating residuals and Jacobians (CasADi); the rest is
    #: Ipopt itself, chiefly the sparse LDLᵀ factorisation (MUMPS) of its KKT matrix
    function_time_s: float = 0.0
    #: the solve's part in the run: "solve" (towards the answer) or "estimate" (a coarser grid solved
    #: only for the answer's error estimate, after it)
    purpose: str = "solve"


@dataclass(kw_only=True)
class Trajectory(Result):
    """A whole-trajectory solution (the contract of :class:`castrajectory.result.Result`, plus these).

    ``t`` (N+1,), ``q`` (N+1, n), ``stages`` (N, s), node momenta ``p`` and velocities ``v``
    (from the discrete Legendre transform), ``energy`` (N+1,), constraint ``multipliers``
    (or None), the discrete action ``action``, and every sub-solve in ``levels``.
    """

    t: np.ndarray
    q: np.ndarray
    stages: np.ndarray
    p: np.ndarray
    v: np.ndarray
    energy: np.ndarray
    multipliers: Optional[np.ndarray]
    scheme: str
    mode: str
    method: str = "whole"
    levels: List[Level] = field(default_factory=list)
    action: float = float("nan")  # discrete action S_d = Σ L_d
    #: the work done on the motion up to each node (N+1,): of the non-conservative forces (``∫Q·q̇ dt``)
    #: plus that of the time dependence (``−∫∂L/∂t dt``), each by the scheme's quadrature, so that
    #: ``energy − energy[0] − work`` is the energy balance's error (zeros for a conservative system)
    work: Optional[np.ndarray] = None
    work_forces: Optional[np.ndarray] = None
    work_time: Optional[np.ndarray] = None
    #: what the answer's NLP carries: the system's terms and the program's anatomy
    #: (:meth:`~castrajectory.discretise.program.Program.anatomy`), with its number of steps
    program: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        return {**super().as_dict(), **trajectory_keys(self), "mode": self.mode,
                "levels": [vars(lv) for lv in self.levels]}


def work_of(run) -> Optional[np.ndarray]:
    """The work of forces and time dependence at the nodes of a run (its own or its method's), or None."""
    work = getattr(run, "work", None)
    return work if work is not None else getattr(getattr(run, "detail", None), "work", None)


def trajectory_keys(run) -> dict:
    """The keys every mechanics scene's JSON holds besides the contract: scheme, method, t, q, energy, and
    ``program`` (what the whole-trajectory NLP carries; ``null`` for a time-stepping baseline)."""
    out = {k: getattr(run, k) for k in ("scheme", "method", "t", "q", "energy")}
    work = work_of(run)
    if work is not None:  # the energy balance: energy - energy[0] - work
        out["work"] = work
    out["program"] = getattr(run, "program", None) or getattr(getattr(run, "detail", None), "program", None) or None
    return out


#: A mass matrix whose smallest eigenvalue is below this fraction of its largest at q0 is refused.
PD_TOL = 1e-12


def check_inertia(system: LagrangianSystem, q0) -> None:
    """Refuse a mass matrix that is not positive definite at ``q0``, naming the coordinate without
    inertia (the eigenvector of the smallest eigenvalue points at it), before any solve."""
    M = np.asarray(system.mass_matrix(q0, 0.0), float)
    with np.errstate(all="ignore"):
        ok = np.all(np.isfinite(M))
        lam, vec = np.linalg.eigh(0.5 * (M + M.T)) if ok else (np.array([np.nan]), np.eye(M.shape[0]))
    if not np.all(np.isfinite(lam)) or lam[0] <= PD_TOL * max(abs(lam[-1]), 1e-300):
        j = int(np.argmax(np.abs(vec[:, 0])))
        raise InputError(f"the mass matrix is not positive definite at q0 (smallest eigenvalue {lam[0]:.3g}): "
                         f"coordinate {system.names[j]!r} has no inertia")


def _check_finite_state(system: LagrangianSystem, q0, qd0) -> None:
    """Refuse an initial state whose mass matrix is singular (:func:`check_inertia`), or whose energy or
    acceleration overflows (finite inputs such as 1e300 whose squares do not exist in floating point),
    before any solve."""
    check_inertia(system, q0)
    with np.errstate(all="ignore"):
        E = float(np.asarray(system.energy(q0, qd0, 0.0)).reshape(-1)[0])
        a = system.index1_values(q0, qd0, 0.0)[0]
    if not (np.isfinite(E) and np.all(np.isfinite(a)) and abs(E) < 1e150 and np.max(np.abs(a), initial=0.0) < 1e150):
        raise InputError(f"the initial state's energy ({E:.3g}) or acceleration ({np.max(np.abs(a), initial=0.0):.3g}) "
                         "overflows: the inputs are too large for double precision")


#: A coordinate at least this large is refused: the spacing of doubles there is >= 0.1, which leaves
#: no digits for a motion (an angle of 1e300 rad diverged in Ipopt; a throw to 1e300 m gave NaN).
MAX_COORDINATE = 1e15


def _check_state(name, value, n, names=None):
    arr = state_vector(name, value, n, names)
    if name.startswith("q") and not name.startswith("qd") and np.max(np.abs(arr), initial=0.0) >= MAX_COORDINATE:
        raise InputError(f"{name} = {arr.tolist()} is too large: a coordinate of {MAX_COORDINATE:.0e} or more leaves "
                         "no digits of double precision for its motion")
    return arr


class TrajectoryNLP(TrajectoryTranscription):
    """The whole-trajectory transcription of one grid, written into an Ipopt :class:`~castrajectory.solve.nlp.NLP`."""

    program = NLP

    def __init__(self, dm: DiscreteMechanics, N: int, T: float, mode: str, q0, end, t0: float = 0.0):
        self.function_time_s = 0.0  # of the last solve (see Level.function_time_s)
        super().__init__(dm, N, T, mode, q0, end, t0)


    def solve(self, guess: Dict[str, np.ndarray], options: Optional[dict] = None,
              verbose: bool = False) -> NLPResult:
        opts = dict(TRAJECTORY_IPOPT)
        if self.mode == "boundary":
            # The gradient of S_d/h is the DEL residual, whose round-off floor grows like
            # eps |q| M / h²; scale it to a position-level quantity (as Ipopt's row scaling
            # does for the initial-value rows), relative to the size of the configurations, so that
            # tol stays reachable at large N and far from the origin (a ball thrown 100 m on 2000
            # steps stopped at Search_Direction_Becomes_Too_Small with its gradient at 2e-12).
            m_ref = float(np.max(np.diag(np.asarray(self.dm.system.mass_matrix(self.q0, self.t0)))))
            size = max(1.0, float(np.max(np.abs(self.q0))), float(np.max(np.abs(self.end))))
            opts["obj_scaling_factor"] = min(1.0, 100.0 * self.h ** 2 / (m_ref * size))
        opts.update(options or {})
        init = {k: v for k, v in guess.items() if k in self.nlp.variable_names}
        # (a step's unknowns on average: below NEWTON_MIN_BLOCK no block can pay, and the block form is not looked for)
        per_step = sum(b.init.size for b in self.nlp._vars) / self.N
        if self.mode == "initial_value" and not verbose and per_step >= NEWTON_MIN_BLOCK:
            # the square initial-value system by Newton's method, its linear solves block by block in time
            # (NLP.newton: linear in the bodies of a chain in maximal coordinates, where Ipopt's symmetric
            # factorisation is cubic); where it does not contract from this guess, Ipopt solves from it
            res = self.nlp.newton(init, float(opts["tol"]), bounds=self.fixed_bounds(),
                                  max_iter=min(int(opts.get("max_iter", NEWTON_MAX_ITER)), NEWTON_MAX_ITER))
            if res is not None:
                self.function_time_s = 0.0
                return res
            # (a caller's max_iter caps the solve: Newton's iterations and Ipopt's together; the default cap is left
            # as it is, whose change would build another Ipopt solver)
            if options and "max_iter" in options:
                opts["max_iter"] = max(0, int(opts["max_iter"]) - int(getattr(self.nlp, "newton_iterations", 0)))
        before = self.nlp._solver
        res = self.nlp.solve(init=init, options=opts, verbose=verbose, bounds=self.fixed_bounds())
        # (a Newton attempt that did not converge spent iterations too: they count with this solve's)
        res.iterations += int(getattr(self.nlp, "newton_iterations", 0)) if self.mode == "initial_value" else 0
        self.nlp.newton_iterations = 0
        if before is not None and self.nlp._solver is before:
            res.build_time_s = 0.0  # nothing was built for this solve (a reused NLP: _trajectory_nlp)
        stats = self.nlp.last_stats  # of the solver just used
        self.function_time_s = float(sum(v for k, v in stats.items() if k.startswith("t_wall_nlp_")))
        return res


    def check(self, values: Dict[str, np.ndarray], options: Optional[dict] = None) -> NLPResult:
        """Check an assembled trajectory against every row (initial value: a square problem), to the
        ``tol`` of ``options`` (or :data:`TRAJECTORY_IPOPT`'s); see :meth:`NLP.check`."""
        tol = float({**TRAJECTORY_IPOPT, **(options or {})}["tol"])
        init = {k: v for k, v in values.items() if k in self.nlp.variable_names}
        return self.nlp.check(init, tol, bounds=self.fixed_bounds())


#: Whole-trajectory NLPs kept for reuse, at most NLP_CACHE_ENTRIES of them and NLP_CACHE_MAX_UNKNOWNS
#: unknowns in all (the least recently used go first; at about 2 kB per unknown, see memory.bytes_per_step,
#: some 400 MB); see :func:`_trajectory_nlp`.  A budget in all, not per NLP: a 32-rod chain's three grids
#: (galerkin8, N = 120, 60, 30: 77 000, 38 000 and 19 000 unknowns) were rebuilt on every run at 20 000 per NLP
#: (2.42 s a run; 1.88 s kept, and the process's peak 356 -> 309 MB without the rebuilds' garbage).
NLP_CACHE_ENTRIES, NLP_CACHE_MAX_UNKNOWNS = 8, 200_000
_NLPS: "Dict[tuple, TrajectoryNLP]" = {}


def _trajectory_nlp(dm: DiscreteMechanics, N: int, T: float, mode: str, q0, end, t0: float = 0.0) -> "TrajectoryNLP":
    """The :class:`TrajectoryNLP` of ``(dm, N, T, mode)``: one built before for the same discrete functions
    (a system of the same Lagrangian: :func:`~castrajectory.discretise.lagrangians.discrete_mechanics`),
    grid and mode is reused with its Ipopt solver, given the new start (``set_start``) and bound to
    ``dm``'s system; otherwise a new one.  Building one costs more than solving it on a few hundred
    steps of a high order (galerkin12, N = 150: 8 ms per build, two per run); a repeated run (a sweep
    over initial states, a fresh system object each time) builds none."""
    key = (id(dm.del_residual), int(N), float(T), mode)
    hit = _NLPS.pop(key, None)
    if hit is not None and hit.dm.del_residual is dm.del_residual:
        hit.dm = dm
        hit.set_start(q0, end, t0)
        _NLPS[key] = hit  # most recently used last
        return hit
    tn = TrajectoryNLP(dm, N, T, mode, q0, end, t0)
    size = _unknowns(tn)
    if size <= NLP_CACHE_MAX_UNKNOWNS:
        while _NLPS and (len(_NLPS) >= NLP_CACHE_ENTRIES
                         or sum(_unknowns(v) for v in _NLPS.values()) + size > NLP_CACHE_MAX_UNKNOWNS):
            _NLPS.pop(next(iter(_NLPS)))
        _NLPS[key] = tn
    return tn


def _unknowns(tn: "TrajectoryNLP") -> int:
    dm = tn.dm
    return tn.N * (dm.n + dm.s + dm.m * (1 + dm.scheme.stages))


# ----------------------------------------------------------------------------- drivers
#: Coarse levels must resolve the fastest linearised motion: h ω ≤ this.
COARSE_H_OMEGA = 0.5
#: An estimate's coarser grid whose step covers more than this much of the fastest linearised motion's
#: phase, or more radians than the scheme's order if that is more (a Gauss scheme of order p has p/2
#: stages: two radians of phase each), gets its first attempt only, without the horizon windows: its
#: error is far from its asymptotic regime, and where the attempt fails the windows and the final whole
#: attempt fail too (rod chains in maximal coordinates, galerkin6, T = 3, N = 15: at h ω = 4.3 (8 rods)
#: it solved in 0.02 s with observed order 6.04; at 6.8 (16 rods) it spent 3.3 s in 9 attempts and
#: failed, where the answer took 0.3 s).  A linear oscillator's grid of 2 steps at h ω = 3.5 solves.
PARTNER_H_OMEGA = math.pi
#: Schemes of a higher order than this skip the coarse levels when the integrated motion (RK4 on
#: substeps) resolves the grid: it is then a closer guess than any coarse level's interpolated answer,
#: and N is solved from it at once (the error estimate's coarser grid follows from the answer).  Their
#: ladder cost more than it saved: double pendulum (2, 1) at rest, T = 5, wall time of the whole run,
#: median of 4: galerkin8 N = 480 0.183 -> 0.131 s (9 -> 3 iterations), galerkin10 N = 375 0.198 ->
#: 0.145 s (10 -> 3).  Orders up to 4 keep the ladder (their iteration counts are unchanged).
LADDER_MAX_ORDER = 4


def _fastest_frequency(system: LagrangianSystem, q0: np.ndarray, qd0: np.ndarray) -> float:
    """Largest linearised angular frequency at the initial state: √|eig(M⁻¹ ∇²U)|, or |q̇0|-based if larger;
    with forces also the rates of their linearisation, |eig(M⁻¹ ∂Q/∂q̇)| (a damping's 1/time) and
    √|eig(M⁻¹ ∂Q/∂q)|.  With holonomic constraints the linearisation is the constrained one: on the tangent
    space ``Z`` of the constraints (``C Z = 0``), the stiffness ``Zᵀ ∇²(U + λ·c) Z`` against the mass ``Zᵀ M Z``,
    ``λ`` the multipliers of the motion (the constraint forces' curvature: a chain in maximal coordinates has a
    gravity linear in its coordinates, and its every frequency comes from the pins' tensions)."""
    q, t = system.q, system.t
    M = np.asarray(system.mass_matrix(q0, 0.0))
    Z = np.eye(system.nq)
    if system.nc:
        lam_sym = ca.SX.sym("lam", system.nc)
        V = system.potential_expr() + ca.dot(lam_sym, system.constraint_expr())
        lam = system.index1_values(q0, qd0, 0.0)[1]
        H = np.asarray(ca.Function("hessV", [q, t, lam_sym], [ca.hessian(V, q)[0]])(q0, 0.0, lam))
        C = np.asarray(system.constraint(q0, 0.0)[1])
        _, sv, vt = np.linalg.svd(C)
        rank = int(np.sum(sv > 1e-10 * max(1.0, sv.max(initial=0.0))))
        Z = vt[rank:].T
    else:
        H = np.asarray(ca.Function("hessU", [q, t], [ca.hessian(system.potential_expr(), q)[0]])(q0, 0.0))
    Mr = Z.T @ M @ Z

    def fastest(A):
        return np.abs(np.linalg.eigvals(np.linalg.solve(Mr, Z.T @ np.asarray(A) @ Z))).max() if Z.shape[1] else 0.0
    rates = [np.sqrt(fastest(H)), np.abs(qd0).max()]
    if system.forced:
        Q = system.force_expr()
        J = ca.Function("dQ", [q, system.qd, t], [ca.jacobian(Q, system.qd), ca.jacobian(Q, q)])(q0, qd0, 0.0)
        rates.append(fastest(J[0]))
        rates.append(np.sqrt(fastest(J[1])))
    return float(max(rates))


def _levels(N: int, coarsest: int) -> List[int]:
    ns = [N]
    while ns[-1] // 2 >= coarsest:
        ns.append(int(math.ceil(ns[-1] / 2)))
    return ns[::-1]


#: Iteration budget of a whole-trajectory attempt from an interpolated guess before the
#: horizon continuation takes over (a good guess converges in 0-6 Newton iterations).
FIRST_ATTEMPT_MAX_ITER = 10
#: A motion that amplifies errors (see solve_initial_value) goes to N.  There a scheme of at least this
#: order attempts the whole trajectory from the integrated motion, within SENSITIVE_FIRST_MAX_ITER
#: iterations; a lower order goes straight to the horizon windows.  The attempt converges when the
#: scheme's discrete motion at N is about as close to the motion as the guess (GUESS_TOL).  Measured
#: on the Dzhanibekov flip (T = 100): galerkin4 N = 4000 1 iteration (0.76 s in all, against 19
#: iterations and 0.87 s through windows), galerkin8 N = 300 2 (0.37 s, against 0.82 s).  Midpoint
#: and trapezoid are 5e-3 s off in the flip interval at N = 4000: their attempt fails (3 iterations,
#: 0.24 s lost at N = 4000, 1.2 s at N = 16000).
SENSITIVE_WHOLE_MIN_ORDER = 4
#: The whole attempt's iteration budget there: a converging one takes 1-2 iterations.
SENSITIVE_FIRST_MAX_ITER = 3
#: A level that converged from an *extrapolated* guess (:func:`_extrapolate`) in at most this
#: many Newton iterations is in the asymptotic regime: the next level is the requested N itself
#: (measured, double pendulum T = 5 s, N = 32000: midpoint 1000 -> 32000, galerkin4
#: 500 -> 32000, each final solve 1 iteration).  Otherwise the grid is doubled.
FINAL_JUMP_ITERATIONS = 1
#: Tolerance of the coarse levels (unless the caller sets ``tol``).  They only supply guesses,
#: so this is far below their discretisation error; it saves the last Newton iteration of
#: most levels (the requested N keeps TRAJECTORY_IPOPT's ``tol``).  Measured (chaotic double
#: pendulum, N = 32000, best of 5): 1e-7 and 1e-6 skip the midpoint ladder's 2000-step level
#: that 1e-8 needs (levels before N 0.094 -> 0.077 s), final solve 1 iteration either way.
COARSE_TOL = 1e-7
#: Iteration budget of one window of the horizon continuation.
WINDOW_MAX_ITER = 10


def _window_guess(tn: TrajectoryNLP, guess, current, pK, K: int, L: int, omega: float, guess_substeps):
    """A horizon window's guess (:func:`_solve_level`): the motion integrated from the window's start state ``(q_K,
    p_K)`` where the step resolves it, else the level's guess shifted to the window's start, with the multipliers
    solved so far (``current``: the nodes, node and stage multipliers assembled so far)."""
    dm, N, h = tn.dm, tn.N, tn.h
    n, s, m, st = dm.n, dm.s, dm.m, dm.scheme.stages
    Qc, Lc, Nc = current
    tK = tn.t0 + K * h
    if h * omega <= GUESS_SUBSTEPS * GUESS_H_OMEGA:  # the motion from the window's start state
        vK = dm.velocities(Qc[K][None, :], pK[None, :], tK)[0]
        wg = _flow_guess(dm, Qc[K], vK, h, L, tK, guess_substeps)
        if wg is not None:
            return wg
    shift = Qc[K] - np.asarray(guess["q"]).reshape(N + 1, n)[K]
    wg = {"q": (np.asarray(guess["q"]).reshape(N + 1, n)[K:K + L + 1] + shift).reshape(-1)}
    wg["q"][:n] = Qc[K]
    if s:
        wg["Z"] = (np.asarray(guess["Z"]).reshape(N, s)[K:K + L] + np.tile(shift, st)).reshape(-1)
    if m:
        wg["lam"] = Lc[K:K + L].reshape(-1).copy()
        if s:
            wg["nu"] = Nc[K:K + L].reshape(-1).copy()
    return wg


def _take_window(tn: TrajectoryNLP, r: NLPResult, guess, current, K: int, L: int) -> np.ndarray:
    """A converged window's values written into the assembly ``current`` (nodes, stages, node and stage multipliers;
    the nodes after it follow the level's guess, shifted to the window's end); the momentum ``p_{K+L}⁻`` at its end,
    the next window's start."""
    dm, N, h = tn.dm, tn.N, tn.h
    n, s, m, st = dm.n, dm.s, dm.m, dm.scheme.stages
    Qc, Zc, Lc, Nc = current
    qw = r.values["q"].reshape(L + 1, n)
    Qc[K + 1:K + L + 1] = qw[1:]
    Qc[K + L + 1:] = np.asarray(guess["q"]).reshape(N + 1, n)[K + L + 1:] + \
        (qw[-1] - np.asarray(guess["q"]).reshape(N + 1, n)[K + L])
    if s:
        Zc[K:K + L] = r.values["Z"].reshape(L, s)
    if m:
        lw = r.values["lam"].reshape(L, m).copy()
        if K > 0:
            lw[0] /= 2.0  # window start weight w vs interior node weight 2w
        Lc[K:K + L] = lw
        if s:
            Nc[K:K + L] = r.values["nu"].reshape(L, st * m)
    Zlast = Zc[K + L - 1] if s else np.zeros(0)
    return np.asarray(dm.p_minus(Qc[K + L - 1], Zlast, Qc[K + L], h, tn.t0 + (K + L - 1) * h,
                                 np.zeros(0))).reshape(-1)


def _solve_level(tn: TrajectoryNLP, guess, options, verbose, log: List[Level], allow_windows: bool,
                 final: bool = True, omega: float = math.inf, windows_first: bool = False,
                 windows_after_failure: bool = True, first_max_iter: int = None,
                 guess_substeps: Optional[int] = None):
    """Solve one level: a whole attempt from ``guess``, then horizon windows if it fails
    (``windows_first``: straight to the windows, when the levels before showed that a whole
    attempt from a level guess does not converge; ``windows_after_failure = False``: return the
    failed attempt instead, for the caller to go to N; ``first_max_iter``: the whole attempt's
    iteration budget, :data:`FIRST_ATTEMPT_MAX_ITER` by default; ``guess_substeps``: the RK4 substeps
    the level's integrated guess took, for the windows' own integrated guesses: the same motion on
    the same step; measured again without it)."""
    first = dict(options or {})
    window_opts = dict(first)
    if allow_windows:
        cap = int(first.get("max_iter", TRAJECTORY_IPOPT["max_iter"]))
        first["max_iter"] = min(cap, FIRST_ATTEMPT_MAX_ITER if first_max_iter is None else first_max_iter)
        window_opts["max_iter"] = min(cap, WINDOW_MAX_ITER)
    if not (windows_first and allow_windows):
        res = tn.solve(guess, options=first, verbose=verbose)
        log.append(Level(tn.N, tn.N, res.solver_status, res.iterations, res.build_time_s, res.solve_time_s,
                         tn.function_time_s))
        if res.success or not allow_windows or not windows_after_failure:
            return res
    # Horizon continuation: march a window over the trajectory.  Each window is itself a
    # whole-trajectory initial-value solve of L steps, started from the last solved node and
    # its discrete momentum; L doubles after a success and halves after a failure.
    # The assembled trajectory then starts the final whole solve at the full N.
    dm, N, h = tn.dm, tn.N, tn.h
    n, s, m, st = dm.n, dm.s, dm.m, dm.scheme.stages
    cur = {k: np.asarray(v, float).reshape(-1).copy() for k, v in guess.items()}
    Qc = cur["q"].reshape(N + 1, n)
    Zc = cur["Z"].reshape(N, s) if s else None
    Lc = cur["lam"].reshape(N, m) if m else None
    Nc = cur["nu"].reshape(N, st * m) if (m and s) else None
    cache: Dict[int, TrajectoryNLP] = {}
    K, L = 0, 1 << max(1, int(math.log2(max(2, N // 32))))  # powers of two: few distinct window NLPs
    # A window length that failed is not tried again on this level: it measures how far the
    # integrated motion stays within Newton's reach of the discrete one, a property of the motion.
    cap = N
    pK = tn.end.copy()
    while K < N:
        L = min(L, N - K)
        tK = tn.t0 + K * h  # a window starts at its own time
        if L not in cache:
            cache[L] = TrajectoryNLP(dm, L, L * h, "initial_value", Qc[K], pK, tK)
            new_build = True
        else:
            new_build = False
        w = cache[L]
        w.set_start(Qc[K], pK, tK)
        wg = _window_guess(tn, guess, (Qc, Lc, Nc), pK, K, L, omega, guess_substeps)
        r = w.solve(wg, options=window_opts, verbose=verbose)
        log.append(Level(N, K + L, r.solver_status, r.iterations, r.build_time_s if new_build else 0.0, r.solve_time_s,
                         w.function_time_s))
        if r.success:
            pK = _take_window(tn, r, guess, (Qc, Zc, Lc, Nc), K, L)
            K, L = K + L, min(2 * L, cap)
        else:
            L //= 2
            cap = L
            if L == 0:
                break  # no window converges here; the whole solve below reports the failure honestly
    # Every row solved window by window (K = N): the assembled point is checked against every row
    # of the whole (square) NLP, which costs one evaluation instead of building its solver.  If a
    # row misses (or the windows stopped short), the whole solve follows: from the assembly it
    # usually takes 0 iterations and keeps the first attempt's solver; otherwise it gets the
    # caller's iteration budget to report the failure -- at the requested N only: a coarse level
    # that fails is dropped anyway.
    if K >= N and tn.mode == "initial_value":
        res = tn.check(cur, options=first)
        log.append(Level(N, N, res.solver_status, 0, 0.0, res.solve_time_s, 0.0))
        if res.success:
            return res
    solver_before = tn.nlp._solver
    res = tn.solve(cur, options=first if (K >= N or not final) else options, verbose=verbose)
    rebuilt = tn.nlp._solver is not solver_before  # other Ipopt options than the first attempt
    log.append(Level(N, N, res.solver_status, res.iterations, res.build_time_s if rebuilt else 0.0, res.solve_time_s,
                     tn.function_time_s))
    return res


def _finish(tn: TrajectoryNLP, res: NLPResult, log: List[Level], mode: str) -> Trajectory:
    dm, N = tn.dm, tn.N
    q = res.values["q"].reshape(N + 1, dm.n)
    Z = res.values["Z"].reshape(N, dm.s) if dm.s else np.zeros((N, 0))
    t = tn.times
    p = dm.momenta(q, Z, tn.h, tn.t0)
    v = dm.velocities(q, p, t)
    energy = tn.dm.system.energies(q, v, t)
    work = dm.work(q, Z, tn.h, tn.t0) if (dm.forced or dm.timed) else np.zeros((N + 1, 2))
    lam = None
    if dm.m:
        if mode == "initial_value":
            lam = res.values["lam"].reshape(-1, dm.m)
        else:
            # Ipopt's multiplier of c(q_k) = 0 in min S_d/h is the quadrature weight 2w times λ_k
            lam = res.multipliers["constraint"].reshape(-1, dm.m) / (2 * dm.scheme.node_weight)
    return Trajectory(
        t=t, q=q, stages=Z, p=p, v=v, energy=energy, multipliers=lam, work=work[:, 0] + work[:, 1],
        work_forces=work[:, 0], work_time=work[:, 1],
        **{**res.contract(), "iterations": int(sum(lv.iterations for lv in log)),
           "build_time_s": float(sum(lv.build_time_s for lv in log)),
           "solve_time_s": float(sum(lv.solve_time_s for lv in log))},
        scheme=dm.scheme.name, mode=mode, levels=log,
        program={"terms": dm.system.terms(), "steps": int(N), **tn.nlp.anatomy()},
        action=float(np.sum(np.asarray(dm.Ld.map(N)(q[:-1].T, Z.T, q[1:].T, tn.h, t[None, :-1])))))


def _validate(system, T, N, scheme: str = "midpoint", polish: bool = False):
    positive("T", T)
    N = integer_at_least("n", N, 2)
    # a grid the machine cannot hold is refused before anything is built (it failed after 14-80 s with
    # a MemoryError traceback or std::bad_alloc)
    limit, per, what = memory.plan(system, scheme, polish)
    if N > limit:
        raise InputError(f"n = {N} needs about {per * N / 1e9:.3g} GB of memory for the whole-trajectory NLP "
                         f"(about {per / 1e3:.3g} kB per step with {scheme}{' and rtol' if polish else ''}, "
                         f"measured), more than {what} leaves this process"
                         + (f": use n <= {limit}" if limit >= 2 else " (no grid fits)"))
    return float(T), N


def solve_initial_value(system: LagrangianSystem, q0, qd0, T: float, N: int, scheme: str = "midpoint",
                        options: Optional[dict] = None, verbose: bool = False,
                        coarsest: int = 32, contact=None, rtol: Optional[float] = None,
                        n_max: Optional[int] = None) -> Trajectory:
    """Solve the initial-value problem as one whole-trajectory NLP (robust strategy in the module doc).

    A system with a :class:`~castrajectory.models.mechanics.Contact` term is transcribed by
    :func:`castrajectory.solve.contact.solve_contact` (collision sub-nodes and complementarity)
    and returns a :class:`~castrajectory.solve.contact.ContactTrajectory`; ``contact`` (a
    :class:`~castrajectory.solve.contact.ContactOptions`) sets that solve.

    Every answer carries an :class:`~castrajectory.solve.estimate.ErrorEstimate` (Richardson from
    the answer and the finest coarser level, see :func:`_estimate`).  ``rtol``: refine past ``N``
    (the ladder continues, each grid a power of two finer) until the estimated relative error is
    at most ``rtol``, up to ``n_max`` steps (:data:`~castrajectory.solve.estimate.N_MAX_RTOL` and
    the memory by default); a run that stops above it fails with the estimate in its message.
    """
    one_of("scheme", scheme, tuple(SCHEMES))
    rtol = None if rtol is None else positive("rtol", rtol)
    T, N = _validate(system, T, N, scheme, polish=rtol is not None)
    n_limit = estimate.limit_n(None if n_max is None else integer_at_least("n_max", n_max, N),
                               memory.limit(system, scheme, polish=rtol is not None))
    q0 = _check_state("q0", q0, system.nq, system.names)
    qd0 = _check_state("qd0", qd0, system.nq, system.names)
    _check_finite_state(system, q0, qd0)
    if system.contact is not None:
        from .contact import solve_contact
        return solve_contact(system, q0, qd0, T, N, scheme, options=options, verbose=verbose, contact=contact,
                             rtol=rtol, n_limit=n_limit)
    if system.nc:
        c, C = system.constraint(q0, 0.0)
        ct = np.asarray(system.constraint_rate(q0, 0.0)).reshape(-1)
        if np.max(np.abs(np.asarray(c))) > 1e-9 or np.max(np.abs(np.asarray(C) @ qd0 + ct)) > 1e-9:
            raise InputError("the initial state violates the holonomic constraints (position or velocity level)")
    dm = discrete_mechanics(system, scheme)
    p0 = np.asarray(system.momentum(q0, qd0, 0.0)).reshape(-1)
    log: List[Level] = []
    solved: List[tuple] = []  # (TrajectoryNLP, values) of the converged levels, finest last
    omega = _fastest_frequency(system, q0, qd0)
    coarsest = max(coarsest, int(math.ceil(T * omega / COARSE_H_OMEGA)))
    if dm.scheme.order > LADDER_MAX_ORDER and (T / N) * omega <= GUESS_SUBSTEPS * GUESS_H_OMEGA:
        coarsest = N  # a high order starts at N from the integrated motion (see LADDER_MAX_ORDER)
    levels = _levels(N, coarsest)
    windowed: List[bool] = []  # per level solved: did it need horizon windows?
    flow_first = False
    flow_failed = False  # a level that started from the integrated motion did not converge
    first_cap = None  # the whole attempts' iteration budget (_solve_level's default)
    i = 0
    while i < len(levels):
        tn = _trajectory_nlp(dm, levels[i], T, "initial_value", q0, p0)
        level_substeps = None  # the substeps of this level's integrated guess, if it has one
        if not solved:
            guess = None
            if tn.h * omega <= GUESS_SUBSTEPS * GUESS_H_OMEGA:
                guess, substeps = _integrated(dm, q0, qd0, tn.h, tn.N)
                if guess is not None and substeps > GUESS_SUBSTEPS and i < len(levels) - 1:
                    # The integrated motion needed more substeps than a smooth one to agree with itself:
                    # the motion amplifies errors (an unstable flip, chaos), and so the coarse levels'
                    # discrete motions part from the finer ones' -- each level's guess would fail and
                    # need windows.  Go to N, from the integrated motion (measured: the Dzhanibekov
                    # flip, T = 100, galerkin4, N = 4000: 59 iterations and 2.3 s through the ladder,
                    # whose 32-substep guess at N = 125 converged; 3 iterations at N).
                    i = len(levels) - 1
                    tn = _trajectory_nlp(dm, levels[i], T, "initial_value", q0, p0)
                    guess, substeps = _integrated(dm, q0, qd0, tn.h, tn.N)
                    first_cap = SENSITIVE_FIRST_MAX_ITER
                    flow_failed = dm.scheme.order < SENSITIVE_WHOLE_MIN_ORDER  # straight to the windows
            flow_first = guess is not None
            level_substeps = substeps if flow_first else None
            guess = guess or _initial_guess(tn, qd0)
        elif len(solved) == 1:
            guess = _refine(*solved[-1], tn)
        else:
            guess = _extrapolate(solved[-2], solved[-1], tn)
        extrapolated = len(solved) >= 2
        n_log = len(log)
        final = i == len(levels) - 1
        level_options = options if final else {"tol": COARSE_TOL, **(options or {})}
        jumped = windowed[-2:] == [True, True] or flow_failed
        after_windows = (bool(windowed) and windowed[-1] and not jumped) or (not solved and flow_first)
        # after a windowed level, a coarse level whose whole attempt fails is not windowed itself:
        # two such levels in a row send the ladder to N (below), where the windows are worth it
        res = _solve_level(tn, guess, level_options, verbose, log, allow_windows=True, final=final, omega=omega,
                           windows_first=jumped, windows_after_failure=final or not after_windows,
                           first_max_iter=first_cap, guess_substeps=level_substeps)
        i += 1
        if res.success:
            solved.append((tn, res.values))
            # One Newton step from an extrapolated guess: the levels are in the asymptotic
            # regime, and the guess for N, extrapolated from this level and the one before,
            # is no worse than this level's was.
            if extrapolated and len(log) == n_log + 1 and res.iterations <= FINAL_JUMP_ITERATIONS:
                i = max(i, len(levels) - 1)
        windowed.append(jumped or len(log) > n_log + 1 or (after_windows and not res.success))
        if not res.success and not solved and flow_first:
            # The integrated motion is also the guess of every finer level until one converges.
            # It failed here: over this horizon the discrete motion of a grid this coarse parts from
            # it (near-separatrix or chaotic motion), and refining towards N only narrows the gap.
            # Go to N, straight to the windows, which start from the integrated motion piece by piece.
            flow_failed = True
            i = max(i, len(levels) - 1)
        if windowed[-2:] == [True, True]:
            # Two levels in a row needed horizon windows (the guess from the coarser level was too
            # far for one Newton solve: chaotic or near-separatrix motion, not a coarse grid's
            # passing trouble).  Finer levels would need them again, and their windows start from
            # the integrated motion, not from the levels: go to N itself, and there straight to the
            # windows (a whole attempt from the level guess would fail the same way).
            i = max(i, len(levels) - 1)
        # A coarse level that fails is too coarse to resolve the motion: drop it and go finer.
    if not res.success:
        if T / N * omega > COARSE_H_OMEGA:
            # the motion is not resolved by the grid (e.g. a fast spin at a coarse N): say so
            res.message += (f"; the grid does not resolve the motion (h ω = {T / N * omega:.3g} at the start, "
                            f"where ω is the fastest linearised frequency or coordinate rate): "
                            f"N >= {int(math.ceil(T * omega / COARSE_H_OMEGA))} resolves it")
        out = _finish(tn, res, log, "initial_value")
        out.error_estimate = estimate.ErrorEstimate.none("the solve did not converge")
        return out
    if rtol is not None:
        _polish(tn, res, solved)
    out = _finish(tn, res, log, "initial_value")
    est = _estimate(solved, tn, res, out, options, verbose, log, omega, polish=rtol is not None)
    state = {"tn": tn, "res": res, "out": out}

    def advance(N2):
        # accuracy on request: the ladder goes on past N, its next level extrapolated from the last two
        # (the levels before them are let go: each holds its NLP, and a refinement would keep them all)
        del solved[:-2]
        nxt = _trajectory_nlp(dm, N2, T, "initial_value", q0, p0)
        guess = _extrapolate(solved[-2], solved[-1], nxt) if len(solved) >= 2 else _refine(*solved[-1], nxt)
        r2 = _solve_level(nxt, guess, options, verbose, log, allow_windows=True, final=True, omega=omega)
        if not r2.success:
            return False, r2.solver_status
        solved.append((nxt, r2.values))
        _polish(nxt, r2, solved)
        o2 = _finish(nxt, r2, log, "initial_value")
        state.update(tn=nxt, res=r2, out=o2)
        return True, _estimate(solved, nxt, r2, o2, options, verbose, log, omega, polish=True)

    est, _, short = estimate.refine(rtol, tn.N, est, dm.scheme.order, n_limit, advance)
    tn, out = state["tn"], state["out"]
    # the run's cost: every solve, the estimate's included
    return estimate.conclude(out, est, log, rtol, tn.N, n_limit, short)


def _path(tn: TrajectoryNLP, values: Dict[str, np.ndarray]):
    """Nodes, configurations and energies of a solved level (for estimates: the answer's own readings)."""
    from types import SimpleNamespace
    dm, N = tn.dm, tn.N
    q = values["q"].reshape(N + 1, dm.n)
    Z = values["Z"].reshape(N, dm.s) if dm.s else np.zeros((N, 0))
    t = tn.times
    v = dm.velocities(q, dm.momenta(q, Z, tn.h, tn.t0), t)
    return SimpleNamespace(t=t, q=q, energy=dm.system.energies(q, v, t))


def _polish(tn: TrajectoryNLP, res: NLPResult, solved: List[tuple]) -> None:
    """One Newton step of the whole system on a converged level (:meth:`NLP.polish
    <castrajectory.solve.nlp.NLP.polish>`), in ``res`` and in ``solved``'s last entry if it is this level.

    Ipopt stops when the rows, scaled down by up to ``100/|∇g|`` (``h²/M`` for the DEL rows of a short
    step), are within ``tol``: an unscaled residual far above rounding, which a chaotic motion
    amplifies into the answer (the double pendulum at T = 10, galerkin4, N = 64000: 1.5e-6 rad off the
    reference where the scheme's error is 6e-9; 5e-10 after the step).  The estimate cannot see such
    an error (a coarser grid solved from the answer inherits it), so it is removed instead -- when an
    ``rtol`` asks for the last digits: the step's sparse QR costs as much as 2-3 Ipopt iterations
    (0.13 s for galerkin4 at N = 32000), and without a chaotic amplification the floor is far below
    the discretisation error (1e-10 for the double pendulum at T = 5)."""
    res.values = tn.nlp.polish({k: v for k, v in res.values.items() if k in tn.nlp.variable_names},
                               TRAJECTORY_IPOPT["tol"], bounds=tn.fixed_bounds())
    if solved and solved[-1][0] is tn:
        solved[-1] = (tn, res.values)


def _coarse_partner(tn: TrajectoryNLP, values, Nc: int, options, verbose, log: List[Level], omega: float,
                    polish: bool, windowed: bool, windows: bool = True) -> Optional[tuple]:
    """The grid ``Nc`` solved for an estimate from the answer on ``tn`` restricted to it (one or two
    Newton iterations, or its own windows, straight away where the answer needed them: the discrete
    motions of N and N/2 part further than the guess from N is off; the 20-flip midpoint body,
    N = 11200: a whole attempt of 10 iterations, 2.1 s); ``(nlp, values)``, or ``None`` if it did not
    converge.  ``polish``: it takes a Newton step too, as the answer did.  ``windows = False``: its first
    attempt only (:data:`PARTNER_H_OMEGA`)."""
    pc = _trajectory_nlp(tn.dm, Nc, tn.T, tn.mode, tn.q0, tn.end)
    n_log = len(log)
    allow = tn.mode == "initial_value"
    rc = _solve_level(pc, _refine(tn, values, pc), options, verbose, log, allow_windows=allow,
                      final=True, omega=omega, windows_first=windowed and windows, windows_after_failure=windows)
    for lv in log[n_log:]:
        lv.purpose = "estimate"
    if not rc.success:
        return None
    if polish:
        _polish(pc, rc, [])
    return pc, rc.values


def _partners(solved: List[tuple], tn: TrajectoryNLP, res: NLPResult, options, verbose, log: List[Level],
              omega: float, polish: bool):
    """The two coarser grids of the answer's estimate, coarsest first, or why there are none.

    The ladder's own levels where two of them are at most
    :data:`~castrajectory.solve.estimate.PARTNER_RATIO` times coarser (the estimate costs nothing);
    otherwise (the ladder jumped further, or went straight to ``N``) the grids ``N/2`` and ``N/4`` are
    solved from the answer (:func:`_coarse_partner`).  Only ``N/2`` where ``N/4`` would have fewer than
    :data:`~castrajectory.solve.estimate.MIN_STEPS` steps."""
    earlier = [lv for lv in solved if lv[0] is not tn and lv[0].N < tn.N]
    ladder = [lv for lv in earlier if tn.N / lv[0].N <= estimate.PARTNER_RATIO]
    if len(ladder) >= 2 and estimate.nested([lv[0].N for lv in ladder[-2:]] + [tn.N]):
        return ladder[-2:], ""
    want = estimate.coarser(tn.N)
    if not want:
        return [], f"N = {tn.N} has no coarser grid"
    windowed = any(lv.n == tn.N and lv.horizon < tn.N for lv in log)
    grids, why = [], ""
    # (a grid past the bound, where the answer's own grid is within it, has its first attempt only: no windows)
    bound = max(PARTNER_H_OMEGA, float(tn.dm.scheme.order))
    resolved = math.isfinite(omega) and tn.T / tn.N * omega <= bound
    for Nc in reversed(want):
        src = grids[0] if grids else (tn, res.values)
        got = _coarse_partner(src[0], src[1], Nc, options, verbose, log, omega, polish, windowed,
                              windows=not (resolved and tn.T / Nc * omega > bound))
        if got is None:
            if not grids:
                st = log[-1].status if log else "no log"
                return [], (f"the grid N = {Nc} for the estimate did not converge ({st}): the answer may not "
                            f"be converged either")
            why = f"; the grid N = {Nc} did not converge ({log[-1].status if log else 'no log'})"
            break
        grids.insert(0, got)
    return grids, why


def _floor(tn: TrajectoryNLP, values) -> Optional[float]:
    """The measured floor of the answer's configurations (:meth:`NLP.floor <castrajectory.solve.nlp.NLP.floor>`:
    the Newton step to the exact solution of the rows plus rounding's effect), max over nodes and
    coordinates; ``None`` where it cannot be measured."""
    fl = tn.nlp.floor({k: v for k, v in values.items() if k in tn.nlp.variable_names}, bounds=tn.fixed_bounds())
    if fl is None or "q" not in fl:
        return None
    return float(np.max(fl["q"], initial=0.0))


def _estimate(solved: List[tuple], tn: TrajectoryNLP, res: NLPResult, answer: "Trajectory", options, verbose,
              log: List[Level], omega: float, polish: bool = False) -> "estimate.ErrorEstimate":
    """The estimate of the answer on ``tn`` from two coarser grids (:func:`_partners`; module
    :mod:`~castrajectory.solve.estimate`) and the answer's measured floor (:func:`_floor`)."""
    grids, why = _partners(solved, tn, res, options, verbose, log, omega, polish)
    if not grids:
        return estimate.ErrorEstimate.none(why)
    system = tn.dm.system
    scale = estimate.kinetic_scale(system, answer.q, answer.v) if tn.mode == "initial_value" else None
    return estimate.trajectory_estimate([_path(*g) for g in grids], answer, tn.dm.scheme.order,
                                        energy_scale=scale, system=system,
                                        levels=tuple(g[0].N for g in grids) + (tn.N,),
                                        floor=_floor(tn, res.values), note=why or "")


def solve_boundary(system: LagrangianSystem, q0, qT, T: float, N: int, scheme: str = "midpoint",
                   options: Optional[dict] = None, verbose: bool = False, coarsest: int = 32) -> Trajectory:
    """Least action proper: minimise the discrete action with ``q(0) = q0`` and ``q(T) = qT``."""
    T, N = _validate(system, T, N, scheme)
    if system.contact is not None:
        raise InputError("the two-point boundary mode does not handle contact; use the initial-value mode")
    q0 = _check_state("q0", q0, system.nq, system.names)
    qT = _check_state("qT", qT, system.nq, system.names)
    dm = discrete_mechanics(system, scheme)
    log: List[Level] = []
    prev, values = None, None
    solved: List[tuple] = []
    for Nl in _levels(N, coarsest):
        tn = _trajectory_nlp(dm, Nl, T, "boundary", q0, qT)
        guess = _initial_guess(tn, None) if prev is None else _refine(prev, values, tn)
        res = _solve_level(tn, guess, options, verbose, log, allow_windows=False)
        if not res.success:
            break
        prev, values = tn, res.values
        solved.append((tn, res.values))
    out = _finish(tn, res, log, "boundary")
    if not res.success:
        out.error_estimate = estimate.ErrorEstimate.none("the solve did not converge")
    else:
        n_log = len(log)
        out.error_estimate = _estimate(solved, tn, res, out, options, verbose, log, math.inf)
        for lv in log[n_log:]:
            out.iterations += lv.iterations
            out.build_time_s += lv.build_time_s
            out.solve_time_s += lv.solve_time_s
    if res.success:
        out.warnings += out.error_estimate.warnings()
    return out
