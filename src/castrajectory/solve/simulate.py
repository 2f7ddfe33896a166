"""One entry point for every way of computing a trajectory, with one result shape.

``method="whole"`` is the library's method (:mod:`castrajectory.solve.trajectory`);
``"march"``, ``"rk4"`` and ``"implicit-euler"`` are the time-stepping
baselines of :mod:`castrajectory.baselines.stepping`, kept for comparison.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from ..baselines import stepping
from . import trajectory
from ..discretise.lagrangians import SCHEMES
from ..models.mechanics import LagrangianSystem
from ..result import Result
from ..validation import InputError, one_of

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

    def as_dict(self) -> dict:
        """The JSON keys shared by every mechanics scene: the contract, scheme, method, t, q, energy."""
        return {**super().as_dict(), **trajectory.trajectory_keys(self)}


def simulate(system: LagrangianSystem, q0, qd0, T: float, N: int, scheme: str = "midpoint",
             method: str = "whole", options: Optional[dict] = None, verbose: bool = False) -> Run:
    """Trajectory from ``(q0, q̇0)`` over ``[0, T]`` on ``N`` uniform steps."""
    one_of("method", method, METHODS)
    one_of("scheme", scheme, tuple(SCHEMES))
    if system.contact is not None and method != "whole":
        raise InputError(f"the {method} baseline has no contact model; contact scenes use method 'whole'")
    if method == "whole":
        tr = trajectory.solve_initial_value(system, q0, qd0, T, N, scheme, options=options, verbose=verbose)
        run = Run(t=tr.t, q=tr.q, v=tr.v, energy=tr.energy, scheme=scheme, method=method, detail=tr,
                  **tr.contract())
    else:
        # (the whole solve checks the state itself)
        trajectory._check_finite_state(system, trajectory._check_state("q0", q0, system.nq),
                                       trajectory._check_state("qd0", qd0, system.nq))
        if method == "march":
            st = stepping.march(system, q0, qd0, T, N, scheme)
        elif method == "rk4":
            st = stepping.rk4(system, q0, qd0, T, N)
        else:
            st = stepping.implicit_euler(system, q0, qd0, T, N)
        run = Run(t=st.t, q=st.q, v=st.qd, energy=st.energy, scheme=scheme if method == "march" else None,
                  method=method, detail=st, **st.contract())
    if run.success and system.contact is None:
        run.warnings += resolution_warnings(system, q0, T / N)
    return run


def resolution_warnings(system: LagrangianSystem, q0, h: float) -> list:
    """A warning if the step ``h`` is longer than the fastest time scale of the motion linearised at
    ``q0``: ``1/ω`` with ``ω² = max |λ(M⁻¹ ∇²U)|`` (a pendulum's ``√(g/l)``, a spring's ``√(k/m)``; an
    unstable equilibrium's growth rate likewise).  Such a step does not resolve the motion: the answer
    is the scheme's, not the physics' (the double pendulum on 100 steps of 10⁴ s reported "ok")."""
    import casadi as ca

    q = ca.SX.sym("q", system.nq)
    U = system.energy(q, ca.DM.zeros(system.nq))        # the potential: the energy at rest
    Hf = ca.Function("hessU", [q], [ca.hessian(U, q)[0]])
    with np.errstate(all="ignore"):
        Hm = np.asarray(Hf(np.asarray(q0, float)), float)
        M = np.asarray(system.mass_matrix(np.asarray(q0, float)), float)
        try:
            lam = np.linalg.eigvals(np.linalg.solve(M, Hm))
        except np.linalg.LinAlgError:
            return []
    w2 = float(np.max(np.abs(lam), initial=0.0))
    if not np.isfinite(w2) or w2 <= 0.0:
        return []
    tau = 1.0 / np.sqrt(w2)
    if h <= tau:
        return []
    return [f"the step h = {h:.3g} s is longer than the motion's fastest time scale 1/ω = {tau:.3g} s "
            f"(linearised at the start: h ω = {h / tau:.3g}); the grid does not resolve it, refine n"]
