"""One entry point for every way of computing a trajectory, with one result shape.

``method="whole"`` is the library's method (:mod:`castrajectory.trajectory`);
``"march"``, ``"rk4"`` and ``"implicit-euler"`` are the time-stepping
baselines of :mod:`castrajectory.stepping`, kept for comparison.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from . import stepping, trajectory
from .discrete import SCHEMES
from .mechanics import LagrangianSystem
from .validation import InputError, one_of

METHODS = ("whole", "march", "rk4", "implicit-euler")


@dataclass
class Run:
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    energy: np.ndarray
    status: str
    success: bool
    message: str
    iterations: int
    build_time_s: float
    solve_time_s: float
    scheme: Optional[str]
    method: str
    detail: object = None  # the underlying Trajectory or Stepped

    @property
    def time_s(self) -> float:
        return self.build_time_s + self.solve_time_s

    def as_dict(self) -> dict:
        """The JSON keys shared by every mechanics scene (see DESIGN.md and issue 3)."""
        return trajectory_json(self)


def trajectory_json(run) -> dict:
    """``status, iterations, build_time_s, solve_time_s, scheme, method, t, q, energy`` of a run."""
    return {k: getattr(run, k) for k in ("status", "iterations", "build_time_s", "solve_time_s",
                                         "scheme", "method", "t", "q", "energy")}


def simulate(system: LagrangianSystem, q0, qd0, T: float, N: int, scheme: str = "midpoint",
             method: str = "whole", options: Optional[dict] = None, verbose: bool = False) -> Run:
    """Trajectory from ``(q0, q̇0)`` over ``[0, T]`` on ``N`` uniform steps."""
    one_of("method", method, METHODS)
    one_of("scheme", scheme, tuple(SCHEMES))
    if system.contact is not None and method != "whole":
        raise InputError(f"the {method} baseline has no contact model; contact scenes use method 'whole'")
    if method == "whole":
        tr = trajectory.solve_initial_value(system, q0, qd0, T, N, scheme, options=options, verbose=verbose)
        status = "ok" if tr.success else tr.status
        return Run(tr.t, tr.q, tr.v, tr.energy, status, tr.success, tr.message, tr.iterations,
                   tr.build_time_s, tr.solve_time_s, scheme, method, tr)
    if method == "march":
        st = stepping.march(system, q0, qd0, T, N, scheme)
    elif method == "rk4":
        st = stepping.rk4(system, q0, qd0, T, N)
    else:
        st = stepping.implicit_euler(system, q0, qd0, T, N)
    status = "ok" if st.success else "failed"
    return Run(st.t, st.q, st.qd, st.energy, status, st.success, st.message, 0,
               st.build_time_s, st.solve_time_s, scheme if method == "march" else None, method, st)
