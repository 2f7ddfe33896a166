"""One entry point for every way of computing a trajectory, with one result shape.

``method="whole"`` is the library's method (:mod:`castrajectory.solve.trajectory`);
``"march"``, ``"rk4"`` and ``"implicit-euler"`` are the time-stepping
baselines of :mod:`castrajectory.baselines.stepping`, kept for comparison.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import math

import numpy as np

from ..baselines import stepping
from . import estimate, memory, trajectory
from ..discretise.lagrangians import SCHEMES
from ..models.mechanics import LagrangianSystem
from ..result import Result
from ..validation import InputError, integer_at_least, one_of, positive

METHODS = ("whole", "march", "rk4", "implicit-euler")


@dataclass(kw_only=True)
class Run(Result):
    """A trajectory by any method: the contract, ``t``, ``q``, velocities ``v``, ``energy``, and the
    method's own result in ``detail`` (a :class:`~castrajectory.solve.trajectory.Trajectory` or a
    :class:`~castrajectory.baselines.stepping.Stepped`)."""

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    energy: np.ndarray
    scheme: Optional[str]
    method: str
    detail: object = None
    #: momenta ``∂L/∂q̇`` at the nodes (for a variational answer, its discrete momenta)
    p: Optional[np.ndarray] = None

    def as_dict(self) -> dict:
        """The JSON keys shared by every mechanics scene: the contract, scheme, method, t, q, energy."""
        return {**super().as_dict(), **trajectory.trajectory_keys(self)}


def simulate(system: LagrangianSystem, q0, qd0, T: float, N: int, scheme: str = "midpoint",
             method: str = "whole", options: Optional[dict] = None, verbose: bool = False,
             rtol: Optional[float] = None, n_max: Optional[int] = None) -> Run:
    """Trajectory from ``(q0, q̇0)`` over ``[0, T]`` on ``N`` uniform steps.

    Every run carries an error estimate (``error_estimate``: Richardson from the run and the same
    method on a coarser grid, :mod:`castrajectory.solve.estimate`).  ``rtol`` (as ``solve_ivp``'s):
    refine ``N`` by powers of two until the estimated relative error is at most ``rtol``, up to
    ``n_max`` steps; a run that ends above it fails (``Tolerance_Not_Reached``), its message giving
    the estimate.

    The double pendulum from θ = (1, 0.5) at rest, to a relative accuracy of 1e-6:

    >>> import castrajectory as ct
    >>> from castrajectory.models.pendulum import double_pendulum
    >>> run = ct.simulate(double_pendulum(), [1.0, 0.5], [0.0, 0.0], T=2.0, N=200, scheme="galerkin4", rtol=1e-6)
    >>> run.success, run.error_estimate.relative <= 1e-6, run.warnings
    (True, True, [])
    """
    one_of("method", method, METHODS)
    one_of("scheme", scheme, tuple(SCHEMES))
    if isinstance(system, LagrangianSystem) and system.controls:
        raise InputError(f"the system has control inputs ({', '.join(c.name for c in system.controls)}): solve it "
                         "with ct.OptimalControl")
    if system.contact is not None and method != "whole":
        raise InputError(f"the {method} baseline has no contact model; contact scenes use method 'whole'")
    if method == "whole":
        tr = trajectory.solve_initial_value(system, q0, qd0, T, N, scheme, options=options, verbose=verbose,
                                            rtol=rtol, n_max=n_max)
        run = Run(t=tr.t, q=tr.q, v=tr.v, energy=tr.energy, scheme=scheme, method=method, detail=tr,
                  **tr.contract())
    else:
        run = _baseline(system, q0, qd0, T, N, scheme, method, rtol, n_max)
    if run.success and system.contact is None:
        h = run.t[-1] / (len(run.t) - 1)
        run.warnings += resolution_warnings(system, q0, h)
        est = run.error_estimate
        hw = h * _linear_frequency(system, q0)
        # a step's polynomial of degree r (a scheme of order 2r) samples r + 1 points: it holds at most r
        # half-periods of the motion
        degree = max(1.0, 0.5 * (SCHEMES[scheme].order if method in ("whole", "march") else
                                 BASELINE_ORDER.get(method, 2)))
        if hw > math.pi * degree and est is not None and est.available and est.relative >= estimate.FAIL_RELATIVE:
            # the step cannot represent the fastest linearised motion, and the grids' estimate is as large as the
            # motion itself: no digit of the answer is right.  (A grid that resolves the motion keeps an unconverged
            # chaotic answer ok, with its warnings: the 1000 periods of a pendulum on 20 steps each are a study of
            # its energy, whose phase has drifted by design; gauss14 on 8 steps of h ω = 10 is 7e-3 off, where its
            # coarser grids of 2 and 4 steps estimate 10 times its excursion)
            run.fail("Not_Resolved", f"the step does not resolve the motion (h ω = {hw:.3g}, more than π times the "
                     f"step's polynomial degree {degree:g}), and the estimated error is {est.relative:.3g} of the "
                     f"answer's own scale: no digit of it is right; refine n")
    own = getattr(run.detail, "p", None)
    if own is not None:
        run.p = np.asarray(own, float)
    elif np.all(np.isfinite(run.q)) and np.all(np.isfinite(run.v)):
        run.p = system.momenta(run.q, run.v, run.t)
    if not run.success and len(run.t) > 1:
        # a failure near a singular chart says where (a success says it through its estimate)
        from .charts import singular_chart
        why = singular_chart(system, run.t, run.q)
        if why is not None:
            run.message += f"; {why}"
    return run


#: Order of each baseline (for its error estimate); ``march`` takes its scheme's.
BASELINE_ORDER = {"rk4": 4, "implicit-euler": 1}


def _baseline(system, q0, qd0, T, N, scheme, method, rtol, n_max) -> Run:
    """A time-stepping baseline, with the same error estimate (the stepper on ``N/2``) and ``rtol``."""
    T, N = trajectory._validate(system, T, N, scheme)
    rtol = None if rtol is None else positive("rtol", rtol)
    limit = estimate.limit_n(None if n_max is None else integer_at_least("n_max", n_max, N),
                             memory.limit(system, scheme))
    # (the whole solve checks the state itself)
    trajectory._check_finite_state(system, trajectory._check_state("q0", q0, system.nq, system.names),
                                   trajectory._check_state("qd0", qd0, system.nq, system.names))
    order = SCHEMES[scheme].order if method == "march" else BASELINE_ORDER[method]

    def step(n):
        if method == "march":
            st = stepping.march(system, q0, qd0, T, n, scheme)
        elif method == "rk4":
            st = stepping.rk4(system, q0, qd0, T, n)
        else:
            st = stepping.implicit_euler(system, q0, qd0, T, n)
        return Run(t=st.t, q=st.q, v=st.qd, energy=st.energy, scheme=scheme if method == "march" else None,
                   method=method, detail=st, **st.contract())

    fine = step(N)
    if not fine.success:
        fine.error_estimate = estimate.ErrorEstimate.none("the run did not succeed")
        return fine
    grids = [step(m) for m in estimate.coarser(N)]
    runs = [fine] + grids

    def est_of(cs, f):
        if not cs:
            return estimate.ErrorEstimate.none(f"N = {len(f.t) - 1} has no coarser grid")
        bad = [c for c in cs if not c.success]
        if bad:
            return estimate.ErrorEstimate.none(f"the run on N = {len(bad[-1].t) - 1} for the estimate failed")
        return estimate.trajectory_estimate(list(cs), f, order, energy_scale=estimate.kinetic_scale(system, f.q, f.v),
                                            system=system)

    fine, est, n, short = estimate.refine_runs(rtol, grids, fine, N, order, limit, step, est_of, runs)
    return estimate.conclude(fine, est, runs, rtol, n, limit, short)


def _linear_frequency(system: LagrangianSystem, q0) -> float:
    """``ω`` of :func:`resolution_warnings` (0 where it has none)."""
    with np.errstate(all="ignore"):
        try:
            w = float(trajectory._fastest_frequency(system, np.asarray(q0, float), np.zeros(system.nq)))
        except np.linalg.LinAlgError:
            return 0.0
    return w if np.isfinite(w) and w > 0.0 else 0.0


def resolution_warnings(system: LagrangianSystem, q0, h: float) -> list:
    """A warning if the step ``h`` is longer than the fastest time scale of the motion linearised at
    ``q0``: ``1/ω`` with ``ω² = max |λ(M⁻¹ ∇²U)|`` (a pendulum's ``√(g/l)``, a spring's ``√(k/m)``; an
    unstable equilibrium's growth rate likewise; a force's rates too, a damping's ``c/m``).  Such a step does not resolve the motion: the answer
    is the scheme's, not the physics' (the double pendulum on 100 steps of 10⁴ s reported "ok")."""
    with np.errstate(all="ignore"):
        try:
            w = trajectory._fastest_frequency(system, np.asarray(q0, float), np.zeros(system.nq))
        except np.linalg.LinAlgError:
            return []
    w2 = w * w
    if not np.isfinite(w2) or w2 <= 0.0:
        return []
    tau = 1.0 / np.sqrt(w2)
    if h <= tau:
        return []
    return [f"the step h = {h:.3g} s is longer than the motion's fastest time scale 1/ω = {tau:.3g} s "
            f"(linearised at the start: h ω = {h / tau:.3g}); the grid does not resolve it, refine n"]
