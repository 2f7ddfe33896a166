"""The one result contract of castrajectory, and the result of one NLP solve.

The contract (:class:`Result`, after scipy's ``OdeResult``)
-----------------------------------------------------------
Every method and every scene returns a subclass of :class:`Result`:

* ``success``: the method reached what it was asked for (for Ipopt: ``Solve_Succeeded``);
* ``status``: ``"ok"``, or the failure's name (``Maximum_Iterations_Exceeded``, ...);
* ``solver_status``: the method's own word for how it ended (Ipopt's return status), kept
  for the record; ``None`` where the method has none;
* ``message``: one line saying what happened, and on failure what to try next;
* ``warnings``: sentences a reader of a successful answer should know (empty when there are none);
* ``error_estimate``: the answer's estimated error (an
  :class:`~castrajectory.solve.estimate.ErrorEstimate`: Richardson from two grids), or ``None``
  for a result that is not a discretised answer (one NLP solve);
* ``iterations``, ``build_time_s``, ``solve_time_s``: counters and wall times summed over
  every solve the method ran;
* ``as_dict()``: the JSON object of the result (the contract's keys, then the subclass's);
* ``raise_for_status()``: ``self`` on success, :class:`SolveError` otherwise.

A solve that did not converge does **not** raise: it returns a result with
``success = False``.  For one NLP only Ipopt's ``Solve_Succeeded`` counts as success;
``Solved_To_Acceptable_Level`` is reported as a failure, because the requested
tolerance was not reached.  A method that can measure its answer decides from the
measurements instead: an optimal control stopped at Ipopt's acceptable level is ok
when a warm re-solve meets a looser tolerance and its certificate holds
(:func:`castrajectory.solve.optimal_control._judge_acceptable`).

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
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Dict, List, Optional

import numpy as np

#: Statuses counted as converged: Ipopt's, and ``Rows_Verified`` (:meth:`NLP.check
#: <castrajectory.solve.nlp.NLP.check>`, :meth:`NLP.certify <castrajectory.solve.nlp.NLP.certify>`:
#: every row of a square problem holds to the tolerance at a point computed piecewise, and its
#: multipliers follow from stationarity, so it is a KKT point).
SUCCESS_STATUSES = frozenset({"Solve_Succeeded", "Rows_Verified"})
#: Ipopt stopped at its acceptable level: the requested tolerance was not reached, so it is never a success by
#: itself; a strategy may go on from its point (:attr:`NLPResult.continuable`), and the method's own measurement
#: (a re-solve, a certificate) decides the answer.
ACCEPTABLE = "Solved_To_Acceptable_Level"
#: An optimal control's certificate (``ControlResult.certificate``: every step of its controls, marched from the
#: answer's own node by the discrete equations, smooth or through contact, lands on the next node to this, relative to
#: the motion's scale) certifies it at most this: the one tolerance of both certificates.
CERTIFICATE_TOL = 1e-7



@dataclass(frozen=True)
class Certificate:
    """The check of an optimal-control answer against the discrete equations of the continuous problem under its own
    controls, the one interface of both certificates: the smooth one marches each step by Newton on its DEL, stage and
    constraint rows (:mod:`castrajectory.solve.optimal_control`), the contact one by the contact march with its modes
    and impacts (:mod:`castrajectory.solve.contact.certificate`).

    * ``local``: every step marched from the answer's own node (and incoming momentum) lands on the answer's next node
      to this, relative to the motion's scale :func:`motion_scale` (the certificate proper: each step is a step of the
      system under its control; ``inf`` where a step's march failed);
    * ``march``: the whole motion marched from the initial state, against the answer (what the motion's own
      instability makes of rounding: a swing-up held upright amplifies it, a sliding block drifts neutrally).

    ``holds(tol)``: ``local <= tol`` (NaN, not measured, does not hold)."""

    local: float = math.nan
    march: float = math.nan

    def holds(self, tol: float = CERTIFICATE_TOL) -> bool:
        return bool(self.local <= tol)


def motion_scale(Q) -> float:
    """The scale a certificate's distances are relative to: ``max(1, max |q|)`` over the answer's nodes."""
    return max(1.0, float(np.max(np.abs(np.asarray(Q, float)))))


_ADVICE = {
    "Maximum_Iterations_Exceeded": "raise max_iter or supply a better initial guess",
    "Solved_To_Acceptable_Level": "the requested tolerance was not reached; loosen tol or rescale the problem",
    # Ipopt's restoration phase converged to a local minimiser of the constraint violation: no proof that no
    # feasible point exists (the acrobot at N = 40 and a paddle to an apex of 1.0 both solved when seeded).  The
    # word "inconsistent" is kept for what the input checks prove before a solve (crossed bounds).
    "Infeasible_Problem_Detected": ("no feasible point found from this start (Ipopt's local infeasibility, not a "
                                    "proof); try a better guess, a seeded start (the answer of an easier or "
                                    "coarser problem), or a coarser grid first"),
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


#: The contract's fields, in the order of :meth:`Result.as_dict`.
CONTRACT = ("status", "message", "iterations", "build_time_s", "solve_time_s", "warnings", "error_estimate")


@dataclass(kw_only=True)
class Result:
    """The contract shared by every method's and scene's result (see module docstring)."""

    success: bool
    status: str = ""
    message: str = ""
    iterations: int = 0
    build_time_s: float = 0.0
    solve_time_s: float = 0.0
    solver_status: Optional[str] = None
    #: What a reader of a successful answer should know: an answer the grid does not resolve, say
    #: (one sentence each; empty when there is nothing to say).
    warnings: List[str] = field(default_factory=list)
    #: The answer's estimated error (:class:`castrajectory.solve.estimate.ErrorEstimate`), where the
    #: method forms one; ``None`` where the result is not an answer a grid approximates (one NLP solve).
    error_estimate: Optional[object] = None

    def __post_init__(self):
        if self.success:
            self.status = "ok"
        elif not self.status or self.status == "ok":
            self.status = self.solver_status or "failed"

    @property
    def time_s(self) -> float:
        """Build plus solve wall time."""
        return self.build_time_s + self.solve_time_s

    def contract(self) -> dict:
        """The contract's fields, to hand on to a result built from this one (``Sub(..., **r.contract())``)."""
        return {"success": self.success, "status": self.status, "message": self.message,
                "iterations": self.iterations, "build_time_s": self.build_time_s,
                "solve_time_s": self.solve_time_s, "solver_status": self.solver_status,
                "warnings": list(self.warnings), "error_estimate": self.error_estimate}

    def fail(self, status: str, message: str) -> None:
        """Turn this result into a failure named ``status`` (e.g. a check after the solver converged)."""
        self.success, self.status, self.message = False, status, message

    def as_dict(self) -> dict:
        """The JSON object: the contract's keys; subclasses add theirs (``{**super().as_dict(), ...}``)."""
        out = {k: getattr(self, k) for k in CONTRACT}
        if out["error_estimate"] is not None:
            out["error_estimate"] = out["error_estimate"].as_dict()
        return out

    def raise_for_status(self) -> "Result":
        """Return ``self`` if the method succeeded, raise :class:`SolveError` otherwise."""
        if not self.success:
            raise SolveError(self)
        return self


@dataclass
class HomotopyStep:
    """One step of a complementarity homotopy.

    ``sigma`` is the value of the homotopy parameter named by ``parameter``:
    ``"sigma"`` for the Scholtes relaxation of :meth:`castrajectory.solve.nlp.NLP.solve`
    (``a_i b_i ≤ σ``, σ → 0), ``"rho"`` for the exact-penalty weight of
    :mod:`castrajectory.solve.contact` (ρ rising until complementarity holds).  ``status`` is
    the solver's own (Ipopt's return status): a step is a record of the solve, not a result.
    """

    sigma: float
    status: str
    iterations: int
    solve_time_s: float
    complementarity_residual: float
    parameter: str = "sigma"


@dataclass(kw_only=True)
class NLPResult(Result):
    """Values, multipliers and statistics of one NLP solve (see module docstring).

    ``solver_status`` is Ipopt's return status; ``status`` is ``"ok"`` or that status.
    """

    values: Dict[str, np.ndarray]
    multipliers: Dict[str, np.ndarray]
    bound_multipliers: Dict[str, np.ndarray]
    objective: float
    complementarity_residual: Optional[float] = None
    homotopy: List[HomotopyStep] = field(default_factory=list)
    # Raw primal/dual vectors, kept for warm starts.
    x: Optional[np.ndarray] = field(default=None, repr=False)
    lam_x: Optional[np.ndarray] = field(default=None, repr=False)
    lam_g: Optional[np.ndarray] = field(default=None, repr=False)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.values[name]

    @property
    def continuable(self) -> bool:
        """A point a strategy may go on from: a success, or Ipopt's acceptable level (:data:`ACCEPTABLE`), whose point
        the next solve or the certificate takes up.  The one acceptance predicate besides ``success``."""
        return self.success or self.solver_status == ACCEPTABLE

    def as_dict(self) -> dict:
        return {**super().as_dict(), "objective": self.objective, "values": self.values,
                "multipliers": self.multipliers, "complementarity_residual": self.complementarity_residual}

    @staticmethod
    def describe_status(status: str) -> str:
        """A one-line message for an Ipopt return status, with advice when it failed."""
        if status == "Rows_Verified":
            return ("every row holds to the requested tolerance at a point solved outside Ipopt (piece by piece, "
                    "or step by step), checked as a KKT point of its square problem; no Ipopt iteration")
        if status in SUCCESS_STATUSES:
            return "Ipopt converged to the requested tolerance"
        advice = _ADVICE.get(status, "see Ipopt's documentation of this status")
        return f"Ipopt did not converge ({status}): {advice}"


@dataclass(kw_only=True)
class ControlResult(Result):
    """The answer of an :class:`OptimalControl`: the result contract, plus ``cost``, ``T``, node times ``t``,
    configurations ``q`` and velocities ``v`` at the nodes, the controls ``u`` per step (``(N, nu)``; by name
    in ``controls``), the discrete ``costates`` at the interior nodes, ``(N−1, n)``: ``∂J*/∂p_k``, the change
    of the optimal cost per unit impulse at node k (the DEL row's multiplier ``∂J*/∂rhs`` times ``−1/h``:
    an impulse ``ι`` is the right-hand side ``−ι/h`` of the row, a momentum balance per unit time), which
    converge to the continuous costates of the momenta; the ``certificate``: the largest distance of a
    step of the controls' march, taken from the optimal nodes, from the next optimal node (relative to the
    motion's scale), and ``march_distance``: the same for the whole march (see :class:`Certificate`); ``grids``:
    the grids solved (see :meth:`OptimalControl.solve`); ``q_stages``: a higher-order scheme's stage
    configurations, ``(N, stages, n)``, at the times ``t_k + c_j h`` of its ``stage_times`` c."""

    cost: float
    T: float
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    u: np.ndarray
    t_u: Optional[np.ndarray] = None
    controls: Dict[str, np.ndarray] = field(default_factory=dict)
    costates: Optional[np.ndarray] = None
    certificate: float = math.nan
    march_distance: float = math.nan
    scheme: str = "midpoint"
    grids: List[int] = field(default_factory=list)
    q_stages: Optional[np.ndarray] = None

    def as_dict(self) -> dict:
        return {**super().as_dict(), "cost": self.cost, "T": self.T, "t": self.t, "q": self.q, "v": self.v,
                "u": self.u, "t_u": self.t_u, "controls": self.controls, "costates": self.costates, "certificate": self.certificate,
                "march_distance": self.march_distance, "grids": self.grids,
                "scheme": self.scheme}
