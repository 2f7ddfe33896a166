"""Error estimates of an answer from two grids, and the choice of a grid for a requested accuracy.

Richardson's estimate
---------------------
A discretisation of order ``p`` has, for ``h`` small enough, the error ``e(h) = u(h) − u ≈ C hᵖ``.
Two solutions on steps ``h_c > h_f`` (ratio ``r = h_c/h_f``) then give the error of the finer one,

    e(h_f) ≈ (u(h_c) − u(h_f)) / (rᵖ − 1),

for every quantity ``u`` read from both: a trajectory's configuration at the nodes the two grids
share, its energy there, the times of its impacts; a droplet's contact angle, span, pressure and
energy.  The estimate is as good as the assumption behind it: that both grids are in the
asymptotic range.  Where they are not (a chaotic horizon on a coarse grid), the estimate is off by
a factor of order one, and large, which is what the warning needs (the double pendulum at T = 10
on N = 2000: 4.8 rad estimated, 8.1 true).

The headline number is ``relative``: the largest estimated error of a quantity divided by the
quantity's scale (for a trajectory, the largest excursion ``max_k ‖q_k − q_0‖∞``: the error
measured against how far the motion went).  ``rtol`` (:func:`castrajectory.solve.simulate.simulate`,
``--rtol``) asks for ``relative ≤ rtol``; the summary warns above :data:`WARN_RELATIVE`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

import numpy as np

#: A successful answer whose estimated relative error exceeds this is reported with a warning.
WARN_RELATIVE = 1e-2
#: The largest grid ``rtol`` refines to unless the caller sets ``n_max`` (or memory allows less).
N_MAX_RTOL = 1 << 20
#: The grid grows by a power of two between 2 and this factor per refinement (``rtol``).
MAX_GROWTH = 16
#: A solved grid at most this many times coarser than the answer is its estimate's partner (coarser
#: ones, or none: the grid N/2 is solved for the estimate).
PARTNER_RATIO = 64
#: Two node times are the same node when they agree to this fraction of the step.
SAME_NODE = 1e-9
#: Relative scales are floored at this fraction of the quantity's magnitude (a body at rest has no
#: excursion, and its round-off is not an error of the method).
SCALE_FLOOR = 1.5e-8


@dataclass
class ErrorEstimate:
    """The estimated error of an answer (see module docstring).

    ``errors``: estimated absolute error per quantity (in the quantity's units); ``scales``: the
    scale each is measured against; ``relative``: ``max errors[k] / scales[k]`` over the quantities
    with a scale; ``levels``: the two grids (coarse, fine); ``order``: the ``p`` used;
    ``note``: how it was formed, or why it could not be (then ``available`` is False); ``final``: why no
    finer grid can give one either (a motion near a singular chart, :mod:`~castrajectory.solve.charts`):
    a refinement for ``rtol`` stops at once with it.
    """

    available: bool
    note: str
    levels: Tuple[int, ...] = ()
    order: float = float("nan")
    errors: Dict[str, float] = field(default_factory=dict)
    scales: Dict[str, float] = field(default_factory=dict)
    relative: float = float("nan")
    final: Optional[str] = None
    #: ``richardson`` (two grids and an order), or ``degree`` (a spectral answer against a lower degree's)
    method: str = "richardson"

    @classmethod
    def none(cls, why: str, final: bool = False) -> "ErrorEstimate":
        """No estimate, and why (``final``: refining cannot cure it)."""
        return cls(available=False, note=why, final=why if final else None)

    def as_dict(self) -> dict:
        return {"available": self.available, "method": self.method if self.available else None,
                "levels": list(self.levels), "order": self.order, "errors": dict(self.errors),
                "scales": dict(self.scales), "relative": self.relative,
                "note": self.note, "final": self.final}

    def line(self) -> str:
        """One line for a summary."""
        if not self.available:
            return f"error estimate: none ({self.note})"
        parts = ", ".join(f"{k} {v:.2e}" for k, v in self.errors.items())
        if self.method == "degree":
            return (f"error estimate (degree {self.levels[1]} against {self.levels[0]}): {parts}; "
                    f"relative {self.relative:.2e}")
        return (f"error estimate (Richardson, N = {self.levels[0]} and {self.levels[1]}, order {self.order:g}): "
                f"{parts}; relative {self.relative:.2e}")

    def warnings(self) -> List[str]:
        """A warning when the estimate is large, or missing."""
        if self.final:
            return [self.final]
        if not self.available:
            return [f"no error estimate could be formed: {self.note}"]
        if not (self.relative <= WARN_RELATIVE):
            return [f"the estimated error is {self.relative:.3g} of the answer's scale (more than "
                    f"{WARN_RELATIVE:.0%}): the answer is not converged on this grid; refine n or ask for --rtol"]
        return []


def richardson(coarse: Dict[str, float], fine: Dict[str, float], ratio: float, order: float) -> Dict[str, float]:
    """``|u_c − u_f| / (ratioᵖ − 1)`` for every quantity in both."""
    d = ratio ** order - 1.0
    return {k: abs(float(coarse[k]) - float(fine[k])) / d for k in fine if k in coarse}


def common_nodes(t_c: np.ndarray, t_f: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """Indices ``(i_c, i_f)`` of the node times the two grids share (to :data:`SAME_NODE` of a step)."""
    t_c, t_f = np.asarray(t_c, float), np.asarray(t_f, float)
    tol = SAME_NODE * max(float(np.min(np.diff(t_f))) if t_f.size > 1 else 1.0, 1e-300)
    j = np.clip(np.searchsorted(t_f, t_c), 0, t_f.size - 1)
    jm = np.clip(j - 1, 0, t_f.size - 1)
    pick = np.where(np.abs(t_f[jm] - t_c) < np.abs(t_f[j] - t_c), jm, j)
    ok = np.abs(t_f[pick] - t_c) <= tol
    return np.nonzero(ok)[0], pick[ok]


def _interpolate(t_old: np.ndarray, Y: np.ndarray, t_new: np.ndarray, points: int = 6) -> np.ndarray:
    """Lagrange interpolation (``points``-point stencils) of the rows of ``Y`` given on ``t_old`` (any spacing)."""
    n = t_old.size
    points = min(points, n)
    i = np.clip(np.searchsorted(t_old, t_new) - points // 2, 0, n - points)
    out = np.zeros((t_new.size, Y.shape[1]))
    for j in range(points):
        w = np.ones(t_new.size)
        for k in range(points):
            if k != j:
                w *= (t_new - t_old[i + k]) / (t_old[i + j] - t_old[i + k])
        out += w[:, None] * Y[i + j]
    return out


def kinetic_scale(system, q: np.ndarray, v: np.ndarray) -> float:
    """The energy scale of a motion: its largest kinetic energy ``K = E(q, v) − E(q, 0)`` over the nodes
    (the energy that moves; a total energy can sit near zero, or far from it, by the choice of ``U``'s zero)."""
    with np.errstate(all="ignore"):
        E = np.asarray(system.energies(q, v), float)
        K = E - np.asarray(system.energies(q, np.zeros_like(v)), float)
    K = K[np.isfinite(K)]
    return max(float(np.max(K, initial=0.0)), SCALE_FLOOR * max(1.0, float(np.max(np.abs(E), initial=0.0))))


def trajectory_estimate(coarse, fine, order: float, smooth: bool = True,
                        extra: Optional[Tuple[Dict[str, float], Dict[str, float], Dict[str, float]]] = None,
                        energy_scale: Optional[float] = None, levels: Optional[Tuple[int, int]] = None,
                        system=None) -> ErrorEstimate:
    """Richardson estimate of the finer of two trajectories (objects with ``t``, ``q``, ``energy``).

    The configuration is compared at the nodes both grids share; where they share only the ends
    (an odd ``N``) and the motion is ``smooth``, the finer solution is interpolated (6-point
    stencils) to the coarse nodes.  ``errors``: ``q`` (the largest over the nodes compared, max-norm
    over the coordinates), ``q_T`` (at T), ``energy`` (the largest over those nodes; measured against
    ``energy_scale``, the motion's largest kinetic energy, :func:`kinetic_scale`).  ``extra``:
    (coarse values, fine values, scales) of further quantities (impact times, ...).  ``levels``: the two grids' step counts (default: their
    nodes less one; a contact grid refined where impacts crowd has more nodes than its base steps).
    ``system``: the finer motion is first watched for a singular chart
    (:func:`castrajectory.solve.charts.singular_chart`); near one there is no estimate, for this grid or
    any finer one (``final``).
    """
    if system is not None:
        from .charts import singular_chart
        why = singular_chart(system, fine.t, fine.q)
        if why is not None:
            return ErrorEstimate.none(why, final=True)
    t_c, t_f = np.asarray(coarse.t, float), np.asarray(fine.t, float)
    q_c, q_f = np.asarray(coarse.q, float), np.asarray(fine.q, float)
    E_c, E_f = np.asarray(coarse.energy, float), np.asarray(fine.energy, float)
    n_c, n_f = levels if levels is not None else (t_c.size - 1, t_f.size - 1)
    if not (np.all(np.isfinite(q_c)) and np.all(np.isfinite(q_f))):
        return ErrorEstimate.none("a trajectory holds non-finite values")
    ratio = n_f / n_c
    ic, jf = common_nodes(t_c, t_f)
    if ic.size >= max(3, 0.4 * n_c) or not smooth:
        dq = q_c[ic] - q_f[jf]
        dE = E_c[ic] - E_f[jf]
    else:
        dq = q_c - _interpolate(t_f, q_f, t_c)
        dE = E_c - _interpolate(t_f, E_f[:, None], t_c)[:, 0]
    d = ratio ** order - 1.0
    note = f"Richardson extrapolation from N = {n_c} and N = {n_f}, order {order:g}"
    errors = {"q": float(np.max(np.abs(dq))) / d, "q_T": float(np.max(np.abs(q_c[-1] - q_f[-1]))) / d}
    if np.all(np.isfinite(dE)) and dE.size:
        errors["energy"] = float(np.max(np.abs(dE))) / d
    excursion = float(np.max(np.abs(q_f - q_f[0]))) if q_f.size else 0.0
    scales = {"q": max(excursion, SCALE_FLOOR * max(1.0, float(np.max(np.abs(q_f)))))}
    if energy_scale is not None and "energy" in errors:
        scales["energy"] = float(energy_scale)
    if extra is not None:
        ec, ef, sc = extra
        errors.update({k: abs(ec[k] - ef[k]) / d for k in ef if k in ec})
        scales.update({k: v for k, v in sc.items() if k in errors})
    rel = max((errors[k] / scales[k] for k in scales if k in errors and scales[k] > 0), default=0.0)
    return ErrorEstimate(available=True, note=note, levels=(n_c, n_f), order=float(order), errors=errors,
                         scales=scales, relative=float(rel))


def next_n(N: int, estimate: ErrorEstimate, rtol: float, order: float) -> int:
    """The next grid for ``rtol``: ``N`` times the power of two (2 to :data:`MAX_GROWTH`) that the
    estimate's decay at ``order`` predicts, with a margin of 2 on the error."""
    if not estimate.available or not np.isfinite(estimate.relative):
        return 2 * N
    want = (2.0 * estimate.relative / rtol) ** (1.0 / order)
    growth = 2 ** int(min(max(math.ceil(math.log2(max(want, 2.0))), 1), int(math.log2(MAX_GROWTH))))
    return int(N * growth)


def next_grid(N: int, estimate: ErrorEstimate, rtol: float, order: float, limit: int) -> Optional[int]:
    """:func:`next_n` within ``limit`` (the limit itself if ``N`` is below it), or ``None``: no finer grid."""
    n2 = next_n(N, estimate, rtol, order)
    if n2 <= limit:
        return n2
    return limit if N < limit else None


def refine(rtol: Optional[float], N: int, est: ErrorEstimate, order: float, limit: int, advance):
    """Accuracy on request: from the answer on ``N`` with estimate ``est``, solve finer grids
    (:func:`next_grid`) until ``est.relative <= rtol``.  ``advance(n)`` solves on ``n`` steps and returns
    ``(True, its estimate)`` or ``(False, the solver's status)``.  Returns ``(estimate, N, why)``: the last
    answer's, and why it stopped short (``None`` when the tolerance was met, or none was asked)."""
    while rtol is not None and not (est.available and est.relative <= rtol):
        if est.final:
            return est, N, est.final
        n2 = next_grid(N, est, rtol, order, limit)
        if n2 is None:
            return est, N, "the grid cannot be refined further"
        ok, out = advance(n2)
        if not ok:
            return est, N, f"the solve at N = {n2} did not converge ({out})"
        N, est = n2, out
    return est, N, None


def refine_runs(rtol: Optional[float], fine, est: ErrorEstimate, N: int, order: float, limit: int, solve,
                estimate_of, runs: list):
    """:func:`refine` for methods that solve each grid from scratch (contact, the baselines):
    ``solve(n)`` returns a result, ``estimate_of(coarse, fine)`` an estimate; every result is appended
    to ``runs``.  Returns ``(the last answer, its estimate, its N, why it stopped short)``."""
    state = {"fine": fine}

    def advance(n2):
        nxt = solve(n2)
        runs.append(nxt)
        if not nxt.success:
            return False, nxt.solver_status or nxt.status
        prev, state["fine"] = state["fine"], nxt
        return True, estimate_of(prev, nxt)

    est, N, short = refine(rtol, N, est, order, limit, advance)
    return state["fine"], est, N, short


def conclude(result, est: ErrorEstimate, costs, rtol: Optional[float], N: int, limit: int, short: Optional[str]):
    """Give ``result`` its estimate, its warnings, the cost of every solve in ``costs`` (objects with
    ``iterations``, ``build_time_s``, ``solve_time_s``), and the failure of an unmet ``rtol``."""
    result.iterations = int(sum(c.iterations for c in costs))
    result.build_time_s = float(sum(c.build_time_s for c in costs))
    result.solve_time_s = float(sum(c.solve_time_s for c in costs))
    result.error_estimate = est
    result.warnings += est.warnings()
    if short is not None:
        result.fail("Tolerance_Not_Reached", tolerance_message(est, rtol, N, limit, short))
    return result


def tolerance_message(estimate: ErrorEstimate, rtol: float, N: int, limit: int, why: str) -> str:
    """The message of a run that ended above its tolerance."""
    if estimate.final:
        return f"the requested rtol = {rtol:g} was not reached at N = {N}: {estimate.final}"
    got = f"{estimate.relative:.3g}" if estimate.available else f"unknown ({estimate.note})"
    return (f"the requested rtol = {rtol:g} was not reached: the estimated relative error at N = {N} is {got}, "
            f"and {why} (limit N <= {limit})")


def limit_n(n_max: Optional[int], memory_limit: int) -> int:
    """The largest grid a refinement may use: the caller's ``n_max`` or :data:`N_MAX_RTOL`, within memory."""
    cap = N_MAX_RTOL if n_max is None else int(n_max)
    return int(min(cap, memory_limit))

