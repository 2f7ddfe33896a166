"""Error estimates of an answer from three grids, and the choice of a grid for a requested accuracy.

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
on N = 2000 midpoint steps: 14 rad estimated, 8.1 true; such an answer is ``Not_Resolved``).

The order is measured, not assumed
---------------------------------
A scheme reaches its nominal order only where the solution is smooth enough and the grids are in the
asymptotic range: an event the march leaves untimed (a release or a slip's change at a node: the optimal
control's march, a step whose timed solve failed) lowers it; a coarse grid on a fast motion is not yet asymptotic;
a solve at its tolerance's floor does not converge at all.  So the
answer on ``N`` is compared with ``N/2`` *and* ``N/4`` (Roache's grid convergence index, ASME V&V 20):
with the differences ``d_c = |u(N/4) − u(N/2)|`` and ``d_f = |u(N/2) − u(N)|`` the grids show the order

    p_obs = ln(d_c / d_f) / ln 2        (Roache's fixed point for unequal ratios, :func:`observed_order`),

and the estimate divides ``d_f`` by ``2^p − 1`` with ``p = min(p_obs, p_nominal)``.  What the grids show
is named in :attr:`ErrorEstimate.regime`:

* ``asymptotic``: ``P_MIN < p_obs <= p_nominal + slack`` (:func:`order_slack`): the estimate is reliable;
* ``floor``: the grids agree to what the solve can resolve (``d_f`` within :data:`FLOOR_FACTOR` of the
  measured floor, :attr:`ErrorEstimate.floor`): the estimate is the floor, never less;
* ``stalled``: the differences do not shrink (``p_obs <= P_MIN``) above any measured floor: the error is
  at least about ``d_f``, and the grids are not in the asymptotic range;
* ``pre-asymptotic``: ``p_obs`` far above the nominal order (the coarse grid is outside the asymptotic
  range, and its difference says little about the fine one's);
* ``two grids``: ``N/4`` has fewer than :data:`MIN_STEPS` steps, the nominal order is assumed;
* ``not nested``: the grids share only their ends (a prime ``N``, :func:`coarser`) and the order is high.

The last four are *unreliable*: the answer warns, and ``rtol`` is never met on them.

The floor (:meth:`castrajectory.solve.nlp.NLP.floor`) is measured where the answer solves a square
system (the whole trajectory): one sparse factorisation of the rows' Jacobian ``J`` at the answer gives
the Newton step ``J⁻¹ g``, how far the answer is from the exact solution of its rows (the solver's
tolerance and the rows' rounding, amplified by the conditioning: a chaotic horizon's growth included).
No difference of grids can be trusted below it.  Where no floor is measured (a march, a time-stepper, a
contact answer) it is the a-priori bound of rounding accumulated over the steps, ``10 N u max|q|``
(:func:`rounding_floor`).

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
#: ... and one on a grid that cannot represent its motion (fewer than two steps per period of its fastest linearised
#: frequency) whose estimated error is at least this fraction of its own scale is not ok (``Not_Resolved``,
#: :func:`castrajectory.solve.simulate.simulate`): the oscillator at T = 1e6 on 200 steps (h ω = 5e3) is estimated
#: at 0.99999948 of its excursion and is 169 % off its closed form
FAIL_RELATIVE = 0.5
#: The largest grid ``rtol`` refines to unless the caller sets ``n_max`` (or memory allows less).
N_MAX_RTOL = 1 << 20
#: The grid grows by a power of two between 2 and this factor per refinement (``rtol``).
MAX_GROWTH = 16
#: A solved grid at most this many times coarser than the answer is its estimate's partner (coarser
#: ones, or none: the grid N/2 is solved for the estimate).
PARTNER_RATIO = 64
#: Two node times are the same node when they agree to this fraction of the step.
SAME_NODE = 1e-9
#: Observed orders at or below this say the grids' differences do not shrink (``stalled``).
P_MIN = 0.5
#: The grids are at the floor when the fine difference is within this factor of the measured floor.
FLOOR_FACTOR = 4.0
#: An observed order below this fraction of the nominal one is named in the answer's warnings.
LOW_ORDER = 0.5
#: The fewest steps of the coarsest grid for a measured order (fewer: two grids, the nominal order).
MIN_STEPS = 2
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
    #: ``richardson`` (grids and an order), or ``degree`` (a spectral answer against a lower degree's)
    method: str = "richardson"
    #: the order the three grids show (``nan``: not measured, two grids only)
    observed_order: float = float("nan")
    #: the order the estimate divides by: ``min(observed, nominal)`` (the nominal one where not measured)
    order_used: float = float("nan")
    #: what the grids show (module docstring): asymptotic, floor, stalled, pre-asymptotic, two grids
    regime: str = "asymptotic"
    #: the measured floor per quantity (absolute; empty where none was measured)
    floor: Dict[str, float] = field(default_factory=dict)
    #: the order each quantity shows (the governing one's is ``observed_order``)
    observed_orders: Dict[str, float] = field(default_factory=dict)

    @property
    def reliable(self) -> bool:
        """The grids confirm the estimate (asymptotic, or at a measured floor)."""
        return self.available and self.regime in ("asymptotic", "floor")

    @classmethod
    def none(cls, why: str, final: bool = False) -> "ErrorEstimate":
        """No estimate, and why (``final``: refining cannot cure it)."""
        return cls(available=False, note=why, final=why if final else None)

    def as_dict(self) -> dict:
        return {"available": self.available, "method": self.method if self.available else None,
                "levels": list(self.levels), "order": self.order, "observed_order": self.observed_order,
                "order_used": self.order_used,
                "observed_orders": dict(self.observed_orders), "regime": self.regime if self.available else None,
                "reliable": self.reliable, "floor": dict(self.floor), "errors": dict(self.errors),
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
        grids = ", ".join(str(n) for n in self.levels)
        orders = (f"observed order {self.observed_order:.2f}, nominal {self.order:g}"
                  if math.isfinite(self.observed_order) else f"nominal order {self.order:g}, not measured")
        head = (f"at the solver's floor, about {self.relative:.1e} relative" if self.regime == "floor"
                else f"relative {self.relative:.2e}")
        flag = "" if self.reliable else f" [unreliable: {self.regime}]"
        return f"error estimate (Richardson, N = {grids}; {orders}): {parts}; {head}{flag}"

    def warnings(self) -> List[str]:
        """A warning when the estimate is large, or missing."""
        if self.final:
            return [self.final]
        if not self.available:
            return [f"no error estimate could be formed: {self.note}"]
        out = []
        if not self.reliable:
            out.append(f"the error estimate is unreliable ({self.regime}): {self.note}")
        elif self.regime == "asymptotic" and self.observed_order < LOW_ORDER * self.order:
            out.append(f"the grids show order {self.observed_order:.2f}, below half the scheme's nominal {self.order:g}: "
                       f"the estimate divides by it, which is right where the order is reduced (an event left untimed "
                       f"in its step) and pessimistic where a high order is not yet asymptotic")
        if not (self.relative <= WARN_RELATIVE):
            out.append(f"the estimated error is {self.relative:.3g} of the answer's scale (more than "
                       f"{WARN_RELATIVE:.0%}): the answer is not converged on this grid; refine n or ask for --rtol")
        return out


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


def observed_order(d_c: float, d_f: float, r_c: float, r_f: float) -> float:
    """The order three grids show (Roache): ``d_c = |u₃ − u₂|`` on the ratio ``r_c = h₃/h₂``, ``d_f =
    |u₂ − u₁|`` on ``r_f = h₂/h₁``.  ``ln(d_c/d_f)/ln r`` for equal ratios, else the fixed point of
    ``p = [ln(d_c/d_f) + ln((r_fᵖ − 1)/(r_cᵖ − 1))] / ln r_f``; negative where the differences grow,
    ``inf`` where the fine one vanishes, ``nan`` where both do."""
    if not (d_c > 0.0 or d_f > 0.0) or not (math.isfinite(d_c) and math.isfinite(d_f)):
        return float("nan")
    if d_f <= 0.0:
        return float("inf")
    if d_c <= 0.0:
        return float("-inf")
    p = math.log(d_c / d_f) / math.log(r_f)
    if abs(r_c - r_f) > 1e-12 * r_f:
        for _ in range(50):
            if not (0.0 < p < 200.0):
                break
            p_new = (math.log(d_c / d_f) + math.log((r_f ** p - 1.0) / (r_c ** p - 1.0))) / math.log(r_f)
            if abs(p_new - p) < 1e-10:
                p = p_new
                break
            p = p_new
    return float(p)


def order_slack(nominal: float) -> float:
    """How far above the nominal order an observed one may sit and still be read as asymptotic: one
    order, or half the nominal one for a high order (whose grids rarely show it exactly)."""
    return max(1.0, 0.5 * nominal)


def judge(d_c: Optional[float], d_f: float, r_c: float, r_f: float, nominal: float,
          floor: Optional[float]) -> Tuple[str, float, float, str]:
    """``(regime, observed order, order used, note)`` of one quantity's grid differences (module docstring);
    ``d_c = None``: two grids only."""
    if floor is not None and floor > 0.0 and d_f <= FLOOR_FACTOR * floor:
        p = observed_order(d_c, d_f, r_c, r_f) if d_c is not None else float("nan")
        return ("floor", p, float(nominal),
                f"the grids agree to {d_f:.2g}, within {FLOOR_FACTOR:g}x of the solve's floor {floor:.2g}")
    if d_c is None:
        return "two grids", float("nan"), float(nominal), f"the order is not measured (two grids): the nominal " \
                                                           f"order {nominal:g} is assumed"
    p = observed_order(d_c, d_f, r_c, r_f)
    if math.isnan(p):
        return "floor", p, float(nominal), "the grids agree exactly"
    if p <= P_MIN:
        return ("stalled", p, float("nan"),
                f"the differences between grids do not shrink (observed order {p:.2f}, nominal {nominal:g}): "
                f"the grids are not in the asymptotic range, or at a floor; the error is at least about {d_f:.2g}")
    if p > nominal + order_slack(nominal):
        return ("pre-asymptotic", p, float(nominal),
                f"the observed order {p:.2f} is far above the nominal {nominal:g}: the coarse grid is outside the "
                f"asymptotic range")
    return "asymptotic", p, float(min(p, nominal)), ""


def grid_estimate(diffs: List[Dict[str, float]], ratios: List[float], scales: Dict[str, float], order: float,
                  levels: Tuple[int, ...], floor: Optional[Dict[str, float]] = None, note: str = "",
                  govern: Optional[List[str]] = None) -> ErrorEstimate:
    """The estimate from the grids' differences per quantity: ``diffs`` ``[d_c, d_f]`` (or ``[d_f]`` for
    two grids), ``ratios`` their step ratios (``[r_c, r_f]`` or ``[r_f]``), the ``scales`` the relative
    error is measured against, the nominal ``order``, the measured ``floor`` per quantity.  The regime and
    the order are judged on the governing quantity: the one of ``govern`` (default: all with a scale)
    whose fine difference is the largest relative to its scale."""
    floor = {k: float(v) for k, v in (floor or {}).items() if np.isfinite(v)}
    d_f, r_f = diffs[-1], ratios[-1]
    d_c, r_c = (diffs[0], ratios[0]) if len(diffs) > 1 else (None, None)
    cand = [k for k in (govern or list(scales)) if k in d_f and scales.get(k, 0) > 0]
    key = max(cand, key=lambda k: d_f[k] / scales[k]) if cand else next(iter(d_f))
    regime, p_obs, p_used, why = judge(None if d_c is None or key not in d_c else d_c[key], d_f[key],
                                       r_c, r_f, order, floor.get(key))
    errors, orders = {}, {}
    for k, d in d_f.items():
        p_k = p_used
        if k != key and d_c is not None and regime == "asymptotic" and np.isfinite(d_c.get(k, np.nan)):
            # a quantity in its own asymptotic range is divided by its own order (RK4's energy converges
            # faster than its configuration); otherwise by the governing quantity's
            reg_k, p_obs_k, p_used_k, _ = judge(d_c[k], d, r_c, r_f, order, floor.get(k))
            orders[k] = p_obs_k
            if reg_k == "asymptotic":
                p_k = p_used_k
        if regime == "stalled":
            e = d
        else:
            e = d / (r_f ** p_k - 1.0)
        errors[k] = max(e, floor.get(k, 0.0))
    rel = max((errors[k] / scales[k] for k in scales if k in errors and scales[k] > 0), default=0.0)
    grids = ", ".join(str(n) for n in levels)
    used = f"order {p_used:.3g}" if math.isfinite(p_used) else "no order (the fine difference itself)"
    text = f"Richardson extrapolation from N = {grids}, {used}" + (f"; {why}" if why else "") + note
    return ErrorEstimate(available=True, note=text, levels=tuple(int(n) for n in levels), order=float(order),
                         errors=errors, scales=dict(scales), relative=float(rel), observed_order=float(p_obs),
                         order_used=float(p_used), regime=regime, floor=floor,
                         observed_orders={key: float(p_obs), **orders})


#: Rounding per step of a march or a time-stepper, in units of the machine epsilon (:func:`rounding_floor`):
#: the contact march's Newton steps stop at the level of rounding and leave about 2u per step (the bouncing ball,
#: exact for midpoint between its impacts: its grids 750, 1500, 3000 differ by 1.2e-11 and 6e-12), with a margin
ROUNDING_PER_STEP = 10.0


def rounding_floor(n: int, q) -> float:
    """The a-priori floor of an answer whose floor is not measured (a march, a time-stepper): rounding
    accumulated over its ``n`` steps, ``ROUNDING_PER_STEP n u max(1, |q|)``."""
    q = np.asarray(q, float)
    return float(ROUNDING_PER_STEP * n * np.finfo(float).eps * max(1.0, float(np.max(np.abs(q), initial=0.0))))


#: The interpolation of a finer trajectory to coarse nodes it does not share (6-point stencils) is exact to
#: about this order: grids of a higher order that do not nest are compared where they share nodes only
INTERPOLATION_ORDER = 6


def _trajectory_differences(coarse, fine, smooth: bool, order: float = 2.0) -> Dict[str, float]:
    """Largest differences of two trajectories: ``q`` at the nodes they share (where they share only the
    ends, an odd ``N``, and the motion is ``smooth``, the finer one interpolated to the coarse nodes if the
    scheme's ``order`` is below :data:`INTERPOLATION_ORDER`: above it the interpolation's error is the
    difference, 1e7 times galerkin24's on 25 steps), ``q_T`` at T, ``energy`` at those nodes."""
    t_c, t_f = np.asarray(coarse.t, float), np.asarray(fine.t, float)
    q_c, q_f = np.asarray(coarse.q, float), np.asarray(fine.q, float)
    E_c, E_f = np.asarray(coarse.energy, float), np.asarray(fine.energy, float)
    ic, jf = common_nodes(t_c, t_f)
    with np.errstate(invalid="ignore", over="ignore"):     # (an energy that is not finite: judged below, quietly)
        if ic.size >= max(3, 0.4 * (t_c.size - 1)) or not smooth or order >= INTERPOLATION_ORDER:
            dq = q_c[ic] - q_f[jf]
            dE = E_c[ic] - E_f[jf]
        else:
            dq = q_c - _interpolate(t_f, q_f, t_c)
            dE = E_c - _interpolate(t_f, E_f[:, None], t_c)[:, 0]
    out = {"q": float(np.max(np.abs(dq), initial=0.0)), "q_T": float(np.max(np.abs(q_c[-1] - q_f[-1])))}
    if np.all(np.isfinite(dE)) and dE.size:
        out["energy"] = float(np.max(np.abs(dE)))
    return out


def trajectory_estimate(grids, fine, order: float, smooth: bool = True,
                        extra: Optional[Tuple[List[Dict[str, float]], Dict[str, float]]] = None,
                        energy_scale: Optional[float] = None, levels: Optional[Tuple[int, ...]] = None,
                        system=None, floor: Optional[float] = None, note: str = "") -> ErrorEstimate:
    """Estimate of the finest of three trajectories (objects with ``t``, ``q``, ``energy``; module docstring).

    ``grids``: the coarser solutions, coarsest first (``[N/4, N/2]``; one, or one object, for two grids).
    ``errors``: ``q`` (the largest difference over the nodes compared, max-norm over the coordinates),
    ``q_T`` (at T), ``energy`` (the largest over those nodes; measured against ``energy_scale``, the
    motion's largest kinetic energy, :func:`kinetic_scale`).  ``extra``: (the differences of further
    quantities per pair of grids, coarse pair first; their scales) -- impact times, say.  ``levels``: the
    grids' step counts, coarsest first (default: their nodes less one; a contact grid refined where
    impacts crowd has more nodes than its base steps).  ``floor``: the measured floor of ``q`` (absolute;
    :meth:`castrajectory.solve.nlp.NLP.floor`).  ``system``: the finest motion is first watched for a
    singular chart (:func:`castrajectory.solve.charts.singular_chart`); near one there is no estimate,
    for this grid or any finer one (``final``).
    """
    if not isinstance(grids, (list, tuple)):
        grids = [grids]
    grids = [g for g in grids if g is not None]
    if system is not None:
        from .charts import singular_chart
        why = singular_chart(system, fine.t, fine.q)
        if why is not None:
            return ErrorEstimate.none(why, final=True)
    chain = list(grids) + [fine]
    if not all(np.all(np.isfinite(np.asarray(g.q, float))) for g in chain):
        return ErrorEstimate.none("a trajectory holds non-finite values")
    n = list(levels) if levels is not None else [np.asarray(g.t).size - 1 for g in chain]
    diffs = [_trajectory_differences(a, b, smooth, order) for a, b in zip(chain[:-1], chain[1:])]
    ratios = [n[i + 1] / n[i] for i in range(len(chain) - 1)]
    q_f = np.asarray(fine.q, float)
    excursion = float(np.max(np.abs(q_f - q_f[0]))) if q_f.size else 0.0
    scales = {"q": max(excursion, SCALE_FLOOR * max(1.0, float(np.max(np.abs(q_f)))))}
    if energy_scale is not None and "energy" in diffs[-1]:
        scales["energy"] = float(energy_scale)
    if extra is not None:
        ed, es = extra
        for d, e in zip(diffs, ed[-len(diffs):]):
            d.update(e)
        scales.update({k: v for k, v in es.items() if k in diffs[-1]})
    if floor is None or not np.isfinite(floor):
        # no floor measured (a march, a time-stepper): rounding accumulated over the steps (rounding_floor)
        floor = rounding_floor(n[-1], q_f)
    fl = {"q": float(floor), "q_T": float(floor)}
    if not nested(n) and smooth and order >= INTERPOLATION_ORDER:
        note += "; the grids do not nest (compared at their shared nodes only, the ends): an odd or prime N"
    # the order is judged on the configuration over the nodes (a single time's difference can cross zero,
    # and a pair of grids may pair no impacts), and the other quantities are divided by it
    est = grid_estimate(diffs, ratios, scales, order, tuple(n), fl, note=note, govern=["q"])
    if not nested(n) and smooth and order >= INTERPOLATION_ORDER and est.regime != "floor":
        est.regime = "not nested"
    return est


def rate(estimate: ErrorEstimate, order: float) -> float:
    """The order a refinement may count on: the one the estimate divided by (the observed order where
    it is below the nominal one), else ``order``; 1 where the grids stalled."""
    if estimate.available and estimate.regime == "stalled":
        return 1.0
    p = estimate.order_used if estimate.available and math.isfinite(estimate.order_used) else order
    return float(max(min(p, order), P_MIN))


def needed_n(N: int, estimate: ErrorEstimate, rtol: float, order: float) -> float:
    """The grid the estimate's decay at its order (:func:`rate`) predicts for ``rtol``."""
    return N * (estimate.relative / rtol) ** (1.0 / rate(estimate, order))


def next_n(N: int, estimate: ErrorEstimate, rtol: float, order: float) -> int:
    """The next grid for ``rtol``: ``N`` times the power of two (2 to :data:`MAX_GROWTH`) that the
    estimate's decay at its order (:func:`rate`) predicts, with a margin of 2 on the error."""
    if not estimate.available or not np.isfinite(estimate.relative) or not estimate.reliable:
        return 2 * N
    want = (2.0 * estimate.relative / rtol) ** (1.0 / rate(estimate, order))
    growth = 2 ** int(min(max(math.ceil(math.log2(max(want, 2.0))), 1), int(math.log2(MAX_GROWTH))))
    return int(N * growth)


def next_grid(N: int, estimate: ErrorEstimate, rtol: float, order: float, limit: int) -> Optional[int]:
    """:func:`next_n` within ``limit`` (the limit itself if ``N`` is below it), or ``None``: no finer grid."""
    n2 = next_n(N, estimate, rtol, order)
    if n2 <= limit:
        return n2
    return limit if N < limit else None


def met(estimate: ErrorEstimate, rtol: float) -> bool:
    """``rtol`` is met: the estimate is reliable (its grids confirm it) and within ``rtol``."""
    return bool(estimate.available and estimate.reliable and estimate.relative <= rtol)


def refine(rtol: Optional[float], N: int, est: ErrorEstimate, order: float, limit: int, advance):
    """Accuracy on request: from the answer on ``N`` with estimate ``est``, solve finer grids
    (:func:`next_grid`) until the tolerance is met (:func:`met`: a reliable estimate within ``rtol``).
    ``advance(n)`` solves on ``n`` steps and returns ``(True, its estimate)`` or ``(False, the solver's
    status)``.  Returns ``(estimate, N, why)``: the last answer's, and why it stopped short (``None``
    when the tolerance was met, or none was asked).

    It stops at once, without solving, where the answer is at its floor above ``rtol`` (no finer grid
    goes below the floor), or where the order the grids show predicts a grid beyond ``limit``
    (:func:`needed_n`)."""
    while rtol is not None and not met(est, rtol):
        if est.final:
            return est, N, est.final
        if est.available and est.regime == "floor" and est.relative > rtol:
            return est, N, (f"the answer is at its solver's floor, about {est.relative:.2g} relative: "
                            f"no finer grid goes below it")
        if est.available and est.regime == "asymptotic" and np.isfinite(est.relative):
            need = needed_n(N, est, rtol, order)
            if need > limit:
                return est, N, (f"the order the grids show ({est.order_used:.2f}) predicts N of about {need:.3g} "
                                f"for rtol = {rtol:g}")
        n2 = next_grid(N, est, rtol, order, limit)
        if n2 is None:
            return est, N, "the grid cannot be refined further"
        ok, out = advance(n2)
        if not ok:
            return est, N, f"the solve at N = {n2} did not converge ({out})"
        N, est = n2, out
    return est, N, None


def refine_runs(rtol: Optional[float], grids: list, fine, N: int, order: float, limit: int, solve, estimate_of,
                runs: list):
    """:func:`refine` for methods that solve each grid from scratch (contact, the baselines):
    ``grids`` the coarser answers already solved (coarsest first, ``N/4`` and ``N/2``; ``None`` where
    absent), ``solve(n)`` returns a result, ``estimate_of(grids, fine)`` an estimate from the coarser
    grids (coarsest first) and the fine one; every result is appended to ``runs``.  Each refinement's
    estimate uses the two answers before it.  Returns ``(the last answer, its estimate, its N, why it
    stopped short)``."""
    state = {"fine": fine, "grids": [g for g in grids if g is not None]}

    def advance(n2):
        nxt = solve(n2)
        runs.append(nxt)
        if not nxt.success:
            return False, nxt.solver_status or nxt.status
        state["grids"] = (state["grids"] + [state["fine"]])[-2:]
        state["fine"] = nxt
        return True, estimate_of(state["grids"], nxt)

    est, N, short = refine(rtol, N, estimate_of(state["grids"], fine), order, limit, advance)
    return state["fine"], est, N, short


#: The largest step ratio between an estimate's nested grids (:func:`coarser`).
MAX_NEST_RATIO = 8


def _nested(n: int) -> Optional[int]:
    """The finest proper divisor ``m`` of ``n`` with ``n / m <= MAX_NEST_RATIO`` (``n/2`` for an even ``n``), or
    ``None``."""
    for r in range(2, MAX_NEST_RATIO + 1):
        if n % r == 0 and n // r >= MIN_STEPS:
            return n // r
    return None


def coarser(n: int) -> List[int]:
    """The coarser grids of an estimate, coarsest first: two grids that nest in ``n`` and in each other, so that
    all three share the coarsest one's nodes (``n/4`` and ``n/2`` for ``n`` divisible by 4; ``n = 50``: 5 and 25;
    ``n = 45``: 5 and 15), each at least :data:`MIN_STEPS` steps.  Where ``n`` has no such divisor (a prime), ``n/2``
    rounded up and its half, which share only their ends with ``n``: then compared at their ends alone, and the
    answer says so.  (Compared by interpolation instead, the interpolation's own error was the difference:
    galerkin24 on 25 steps of the cart and double pendulum, estimated 2.4e-3 where it is 1.5e-10.)"""
    half = _nested(n)
    if half is not None:
        quarter = _nested(half)
        return [quarter, half] if quarter is not None else [half]
    h1 = n // 2 if n % 2 == 0 else (n + 1) // 2
    h2 = h1 // 2 if h1 % 2 == 0 else (h1 + 1) // 2
    return [m for m in (h2, h1) if MIN_STEPS <= m < n and (m != h2 or h2 < h1)]


def nested(levels) -> bool:
    """The grids (step counts, coarsest first) nest: each divides the next."""
    return all(b % a == 0 for a, b in zip(levels[:-1], levels[1:]))


def conclude(result, est: ErrorEstimate, costs, rtol: Optional[float], N: int, limit: int, short: Optional[str]):
    """Give ``result`` its estimate, its warnings, the cost of every solve in ``costs`` (objects with
    ``iterations``, ``build_time_s``, ``solve_time_s``), and the failure of an unmet ``rtol``."""
    result.iterations = int(sum(c.iterations for c in costs))
    result.build_time_s = float(sum(c.build_time_s for c in costs))
    result.solve_time_s = float(sum(c.solve_time_s for c in costs))
    result.error_estimate = est
    result.warnings += est.warnings()
    energy = getattr(result, "energy", None)
    if getattr(result, "success", False) and energy is not None and not np.all(np.isfinite(np.asarray(energy, float))):
        # (T = 1e300: E(0) finite, the energy's later values not; an answer whose energy is not finite is no answer)
        result.fail("Energy_Not_Finite", "the answer's energy is not finite at some node: the horizon or the state "
                    "overflows double precision; shorten T or rescale the problem")
    elif not est.available and not est.final and getattr(result, "success", False):
        # an answer whose error cannot be estimated is not an answer to trust
        result.fail("Error_Not_Estimated", f"the answer's error could not be estimated: {est.note}; "
                    f"solve on a larger n")
    elif short is not None:
        result.fail("Tolerance_Not_Reached", tolerance_message(est, rtol, N, limit, short))
    return result


def tolerance_message(estimate: ErrorEstimate, rtol: float, N: int, limit: int, why: str) -> str:
    """The message of a run that ended above its tolerance."""
    if estimate.final:
        return f"the requested rtol = {rtol:g} was not reached at N = {N}: {estimate.final}"
    got = f"{estimate.relative:.3g}" if estimate.available else f"unknown ({estimate.note})"
    if estimate.available and not estimate.reliable:
        got += f" (unreliable: {estimate.regime})"
    return (f"the requested rtol = {rtol:g} was not reached: the estimated relative error at N = {N} is {got}, "
            f"and {why} (limit N <= {limit})")


def limit_n(n_max: Optional[int], memory_limit: int) -> int:
    """The largest grid a refinement may use: the caller's ``n_max`` or :data:`N_MAX_RTOL`, within memory."""
    cap = N_MAX_RTOL if n_max is None else int(n_max)
    return int(min(cap, memory_limit))

