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
    trajectory._check_finite_state(system, trajectory._check_state("q0", q0, system.nq),
                                   trajectory._check_state("qd0", qd0, system.nq))
    if system.contact is not None and method != "whole":
        raise InputError(f"the {method} baseline has no contact model; contact scenes use method 'whole'")
    if method == "whole":
        tr = trajectory.solve_initial_value(system, q0, qd0, T, N, scheme, options=options, verbose=verbose)
        return Run(t=tr.t, q=tr.q, v=tr.v, energy=tr.energy, scheme=scheme, method=method, detail=tr,
                   **tr.contract())
    if method == "march":
        st = stepping.march(system, q0, qd0, T, N, scheme)
    elif method == "rk4":
        st = stepping.rk4(system, q0, qd0, T, N)
    else:
        st = stepping.implicit_euler(system, q0, qd0, T, N)
    return Run(t=st.t, q=st.q, v=st.qd, energy=st.energy, scheme=scheme if method == "march" else None,
               method=method, detail=st, **st.contract())
