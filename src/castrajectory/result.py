"""The outcome of one NLP solve.

Sign convention for multipliers (stated once, used everywhere)
--------------------------------------------------------------
For a constraint ``lb <= c(x) <= ub`` (an equality has ``lb == ub == b``) the
multiplier reported under the constraint's name is

    multiplier = d f* / d b,

the rate at which the optimal objective ``f*`` changes when the active bound
``b`` is raised.  It is the negative of CasADi's ``lam_g``.  Consequences:

* an equality ``area(x) = A`` reports ``dE*/dA`` (for the droplet: the
  Laplace pressure, positive);
* an inequality active at its *lower* bound, such as a gap ``phi(q) >= 0``,
  reports a value ``>= 0`` (a contact impulse reads positive);
* an inequality active at its *upper* bound reports a value ``<= 0``;
* an inactive inequality reports (numerically) zero.

Bound multipliers on decision variables follow the same rule
(``-lam_x``: positive when a lower bound is active).

Failure
-------
A solve that did not converge does **not** raise.  It returns a ``Result``
with ``success = False`` and a ``message`` saying what happened and what to try
next; :meth:`Result.raise_for_status` turns that into an exception for callers
that prefer one.  Only Ipopt's ``Solve_Succeeded`` counts as success;
``Solved_To_Acceptable_Level`` is reported as a failure, because the requested
tolerance was not reached.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional

import numpy as np

#: Ipopt return statuses counted as converged.
SUCCESS_STATUSES = frozenset({"Solve_Succeeded"})

_ADVICE = {
    "Maximum_Iterations_Exceeded": "raise max_iter or supply a better initial guess",
    "Solved_To_Acceptable_Level": "the requested tolerance was not reached; loosen tol or rescale the problem",
    "Infeasible_Problem_Detected": "the constraints appear inconsistent; check the inputs",
    "Restoration_Failed": "Ipopt lost feasibility; supply a better initial guess",
    "Error_In_Step_Computation": "the linear systems became singular; check for redundant constraints",
    "Maximum_CpuTime_Exceeded": "raise max_cpu_time or reduce the problem size",
    "Maximum_WallTime_Exceeded": "raise max_wall_time or reduce the problem size",
    "Invalid_Number_Detected": "the model produced NaN or Inf at some iterate; check the model's domain",
    "Diverging_Iterates": "iterates diverged; the problem may be unbounded",
}


class SolveError(RuntimeError):
    """Raised by :meth:`Result.raise_for_status` for an unsuccessful solve."""

    def __init__(self, result: "Result"):
        super().__init__(result.message)
        self.result = result


@dataclass
class HomotopyStep:
    """One step of a complementarity homotopy.

    ``sigma`` is the value of the homotopy parameter named by ``parameter``:
    ``"sigma"`` for the Scholtes relaxation of :meth:`castrajectory.nlp.NLP.solve`
    (``a_i b_i ≤ σ``, σ → 0), ``"rho"`` for the exact-penalty weight of
    :mod:`castrajectory.contact` (ρ rising until complementarity holds).
    """

    sigma: float
    status: str
    iterations: int
    solve_time_s: float
    complementarity_residual: float
    parameter: str = "sigma"


@dataclass
class Result:
    """Values, multipliers and statistics of one NLP solve (see module docstring)."""

    values: Dict[str, np.ndarray]
    multipliers: Dict[str, np.ndarray]
    bound_multipliers: Dict[str, np.ndarray]
    objective: float
    status: str
    success: bool
    message: str
    iterations: int
    build_time_s: float
    solve_time_s: float
    complementarity_residual: Optional[float] = None
    homotopy: List[HomotopyStep] = field(default_factory=list)
    # Raw primal/dual vectors, kept for warm starts.
    x: Optional[np.ndarray] = field(default=None, repr=False)
    lam_x: Optional[np.ndarray] = field(default=None, repr=False)
    lam_g: Optional[np.ndarray] = field(default=None, repr=False)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.values[name]

    def raise_for_status(self) -> "Result":
        """Return ``self`` if the solve succeeded, raise :class:`SolveError` otherwise."""
        if not self.success:
            raise SolveError(self)
        return self

    @staticmethod
    def describe_status(status: str) -> str:
        """A one-line message for an Ipopt return status, with advice when it failed."""
        if status in SUCCESS_STATUSES:
            return "Ipopt converged to the requested tolerance"
        advice = _ADVICE.get(status, "see Ipopt's documentation of this status")
        return f"Ipopt did not converge ({status}): {advice}"
