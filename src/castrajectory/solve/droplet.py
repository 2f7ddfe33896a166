"""The droplet solved: one NLP per size handed to Ipopt, and the reduced problem in the contact angle.

:func:`solve` writes a discretisation (:mod:`castrajectory.discretise.droplet`) into one
:class:`~castrajectory.solve.nlp.NLP`, solves it (with a coarse presolve and a fallback ladder,
see its docstring) and returns a :class:`DropletSolution` with the errors against the oracle
(:func:`castrajectory.models.droplet.analytic`).  :func:`solve_angle` minimises the reduced
energy ``E(theta)``.

All NLPs are posed in units where ``A = 1`` and ``gamma_gl = 1`` (length unit
``sqrt(A)``, energy unit ``gamma_gl sqrt(A)``); results are converted back.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Dict, Optional

import casadi as ca
import numpy as np

from ..discretise.droplet import (  # noqa: F401  (the discretisations, re-exported with the model)
    DISCRETISATIONS, FORMULATIONS, MIN_N, Curve, Geometry, Graph, contact_angle_estimate, resample_polyline)
from ..models.droplet import (  # noqa: F401
    CircularCap, Droplet, analytic, arc_points, reduced_energy, segment_area_factor, young_angle)
from ..result import NLPResult, Result
from ..validation import InputError, integer_at_least, one_of
from .nlp import NLP


#: Ipopt options for the droplet NLPs.  ``constr_mult_init_max = 0`` starts every constraint multiplier
#: at zero instead of Ipopt's least-squares estimate: at the default guesses that estimate of the area
#: multiplier is far off (-0.48 against -1.72 for a pinned span), the first step then overshoots and
#: Ipopt spends dozens of iterations with a huge Hessian regularisation (measured: graph at 20° and
#: N = 100 failed; pinned overhanging curves needed iterations growing with N).  Zero multipliers made
#: every case of a 2°–178° sweep converge in at most 15 iterations.  ``mu_init = 1e-9``: the only
#: inequality is the free span's ``a >= 1e-8``, far from active, so the barrier has nothing to do and
#: Ipopt's default ``mu_init = 0.1`` only costs iterations spent lowering it (a sweep over both forms,
#: 2°–178°, N = 8–2000 and pinned spans: 478 -> 438 iterations in total, 22 cases fewer, 1 case one more).
#: ``mumps_pivot_order = 6`` (QAMD) instead of MUMPS' automatic choice: the free span enters every
#: element, a dense row and column of the KKT matrix, which QAMD orders well (measured at N = 1e5: graph
#: 10.5 -> 1.8 s, curve 6.1 -> 3.1 s; N = 400 and 4000 unchanged or faster; same iterations and errors).
SOLVER_OPTIONS = {"constr_mult_init_max": 0.0, "mu_init": 1e-9, "mumps_pivot_order": 6}


# ---------------------------------------------------------------------------- solve
@dataclass
class DropletSolution(Result):
    """The discrete drop, its physical readings and their errors against the oracle.

    The contract's fields (:class:`castrajectory.result.Result`) are those of the solve, summed over
    every solve the strategy ran; ``result`` is the final NLP solve itself.
    """

    drop: Droplet
    formulation: str
    n: int
    result: NLPResult
    x: np.ndarray
    y: np.ndarray
    contact_angle: float
    span: float
    pressure: float
    energy: float
    young_residual: Optional[float]
    analytic: CircularCap
    errors: Dict[str, float] = field(default_factory=dict)
    #: what the NLP carries: its terms and the program's anatomy
    program: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        """The JSON object of ``problems/droplet.py --json``."""
        return {
            **super().as_dict(),
            "formulation": self.formulation,
            "n": self.n,
            "mode": "free-span" if self.drop.span is None else "fixed-span",
            "contact_angle": self.contact_angle,
            "span": self.span,
            "pressure": self.pressure,
            "energy": self.energy,
            "young_residual": self.young_residual,
            "analytic": self.analytic.as_dict(),
            "errors": dict(self.errors),
            "x": self.x.tolist(),
            "y": self.y.tolist(),
            "program": self.program,
        }


#: Coarse grid of the fallback ladder (see :func:`solve`).
COARSE_N = 40
#: Iteration budget of the direct curve solve before the ladder takes over.
FIRST_ATTEMPT_MAX_ITER = 30
#: Curve solves with at least this many segments start from a coarse solve on PRESOLVE_N segments.
PRESOLVE_MIN_N = 2000
PRESOLVE_N = 200


def _check_formulation(drop: Droplet, formulation: str) -> None:
    one_of("formulation", formulation, FORMULATIONS)
    cap = analytic(drop)
    if formulation == "graph" and cap.contact_angle >= 0.5 * math.pi:
        raise InputError(
            f"the graph formulation y(x) cannot represent contact angles of 90 degrees or more "
            f"(this drop's angle is {math.degrees(cap.contact_angle):.4g} degrees); use the curve formulation")


def make_nlp(drop: Droplet, n: int, formulation: str = "curve", guess: Optional[np.ndarray] = None):
    """Build (but do not solve) the droplet NLP in scaled units; return ``(nlp, geometry, area_constraint)``."""
    n = integer_at_least("n", n, MIN_N)
    _check_formulation(drop, formulation)
    L = drop.length_scale
    nlp = NLP()
    disc = Curve(n, guess) if formulation == "curve" else DISCRETISATIONS[formulation](n)
    # The scene's terms: surface tension (the length elements, added by the discretisation) always;
    # the wetting term only when the span is free and it is non-zero.
    geo = disc.build(nlp, None if drop.span is None else drop.span / L)
    w = drop.wetting / drop.gamma_gl
    if drop.span is None and w != 0.0:
        nlp.minimize(w * geo.span)
    return nlp, geo, nlp.constraint("area")


def solve(drop: Droplet, n: int = 400, formulation: str = "curve", *, options: Optional[dict] = None,
          verbose: bool = False) -> DropletSolution:
    """Minimise the discrete droplet energy; never raises on non-convergence (see ``castrajectory.result``).

    Strategy (curve form):

    * from ``PRESOLVE_MIN_N`` segments on, the drop is first solved on ``PRESOLVE_N``
      segments (from the default guess) and that polyline, resampled by arclength,
      starts the fine solve: it then needs about half the Newton iterations, and each
      fine iteration costs far more than the whole coarse solve;
    * if a solve fails, a ladder of coarser solves (``COARSE_N``, doubling up to ``n``) is run,
      each resampled by arclength as the next guess.

    The reported times and iterations include every solve; the status is that of the
    final solve at ``n``.
    """
    n = integer_at_least("n", n, MIN_N)
    _check_formulation(drop, formulation)
    opts = {**SOLVER_OPTIONS, **(options or {})}
    res, nlp, geo = _solve_scaled(drop, n, formulation, opts, verbose)
    r = _readings(drop, res, geo)
    cap = analytic(drop)
    errors = {
        "shape": float(np.max(np.abs(cap.distance(r["x"], r["y"])))) / cap.radius,
        "contact_angle": abs(r["contact_angle"] - cap.contact_angle),
        "span": abs(r["span"] - cap.span) / cap.span,
        "energy": abs(r["energy"] - cap.energy) / abs(cap.energy),
        "pressure": abs(r["pressure"] - cap.pressure) / cap.pressure,
    }
    young = None if drop.span is not None else drop.gamma_gl * math.cos(r["contact_angle"]) + drop.wetting
    terms = ["surface tension γ_gl × length", "area constraint"]
    if drop.span is None and drop.wetting != 0.0:
        terms.insert(1, "wetting (γ_sl − γ_sg) × span")
    elif drop.span is not None:
        terms.append("span pinned")
    sol = DropletSolution(drop, formulation, n, res, r["x"], r["y"], r["contact_angle"], r["span"], r["pressure"],
                          r["energy"], young, cap, errors, {"terms": terms, "steps": int(n), **nlp.anatomy()},
                          **res.contract())
    if sol.success:
        sol.error_estimate = _estimate(drop, n, formulation, opts, verbose, r, sol)
        sol.warnings += sol.error_estimate.warnings()
    return sol


#: The droplet discretisations' order (shape, span, angle, pressure, energy: second order in 1/N).
ORDER = 2
#: The quantities of the droplet's error estimate.
ESTIMATED = ("contact_angle", "span", "pressure", "energy")


def _readings(drop: Droplet, res: NLPResult, geo) -> dict:
    """The physical readings of a solve, in the drop's units."""
    L, g = drop.length_scale, drop.gamma_gl
    xs, ys, span = geo.vertices(res)
    x, y = L * xs, L * ys
    span, length = L * span, L * float(np.sum(np.hypot(np.diff(xs), np.diff(ys))))
    return {"x": x, "y": y, "xs": xs, "ys": ys, "contact_angle": contact_angle_estimate(x, y), "span": span,
            "pressure": g / L * float(res.multipliers["area"][0]), "energy": g * length + drop.wetting * span}


def _estimate(drop: Droplet, n: int, formulation: str, opts: dict, verbose: bool, fine: dict,
              sol: DropletSolution):
    """Richardson estimate from the same drop on ``n/2`` segments, started from the answer resampled
    (a few Newton iterations); its cost is added to ``sol``'s.  Errors of the contact angle (scale π/2),
    span, pressure and energy (each against its own size)."""
    from .estimate import ErrorEstimate, richardson
    nc = n // 2
    if nc < MIN_N:
        return ErrorEstimate.none(f"N = {n} has no coarser grid (at least {MIN_N} segments)")
    guess = resample_polyline(fine["xs"], fine["ys"], nc) if formulation == "curve" else None
    nlp, geo, _ = make_nlp(drop, nc, formulation, guess)
    res = nlp.solve(options=opts, verbose=verbose)
    sol.iterations += res.iterations
    sol.build_time_s += res.build_time_s
    sol.solve_time_s += res.solve_time_s
    if not res.success:
        return ErrorEstimate.none(f"the drop on N = {nc} segments for the estimate did not converge ({res.solver_status})")
    coarse = _readings(drop, res, geo)
    errors = richardson({k: coarse[k] for k in ESTIMATED}, {k: fine[k] for k in ESTIMATED}, n / nc, ORDER)
    scales = {"contact_angle": 0.5 * math.pi, "span": abs(fine["span"]), "pressure": abs(fine["pressure"]),
              "energy": abs(fine["energy"])}
    rel = max(errors[k] / scales[k] for k in errors if scales[k] > 0)
    return ErrorEstimate(available=True, note=f"Richardson extrapolation from N = {nc} and N = {n}, order {ORDER}",
                         levels=(nc, n), order=float(ORDER), errors=errors, scales=scales, relative=float(rel))


def _solve_scaled(drop: Droplet, n: int, formulation: str, opts: dict, verbose: bool):
    """The strategy of :func:`solve`; returns ``(result, nlp, geometry)`` in scaled units."""
    ladder = formulation == "curve" and n > COARSE_N
    first = dict(opts)
    if ladder:  # a good start converges in <= 15 iterations; do not spend a long failing run
        first["max_iter"] = min(int(opts.get("max_iter", 200)), FIRST_ATTEMPT_MAX_ITER)
    guess, spent = None, []
    if formulation == "curve" and n >= PRESOLVE_MIN_N:
        coarse, cnlp, cgeo = _solve_scaled(drop, PRESOLVE_N, "curve", opts, verbose)
        spent.append(coarse)
        if coarse.success:
            xs, ys, _ = cgeo.vertices(coarse)
            guess = resample_polyline(xs, ys, n)
    nlp, geo, _ = make_nlp(drop, n, formulation, guess)
    res = nlp.solve(options=first, verbose=verbose)
    if not res.success and ladder:
        res, nlp, geo = _coarse_to_fine(drop, n, opts, verbose, res)
    for r in spent:
        res.build_time_s += r.build_time_s
        res.solve_time_s += r.solve_time_s
        res.iterations += r.iterations
    return res, nlp, geo


def _coarse_to_fine(drop: Droplet, n: int, opts: dict, verbose: bool, failed: NLPResult):
    """Fallback ladder COARSE_N, 2 COARSE_N, ..., n; every solve's time and iterations are counted."""
    build, solve_t, iters = failed.build_time_s, failed.solve_time_s, failed.iterations
    guess, m = None, COARSE_N
    while True:
        nlp, geo, _ = make_nlp(drop, m, "curve", guess)
        res = nlp.solve(options=opts, verbose=verbose)
        build, solve_t, iters = build + res.build_time_s, solve_t + res.solve_time_s, iters + res.iterations
        if not res.success or m == n:
            break
        xs, ys, _ = geo.vertices(res)
        m = min(2 * m, n)
        guess = resample_polyline(xs, ys, m)
    res.build_time_s, res.solve_time_s, res.iterations = build, solve_t, iters
    return res, nlp, geo


# ---------------------------------------------------------------------------- reduced problem in theta
@dataclass
class AngleSolution(Result):
    """Minimiser of the reduced energy ``E(theta)`` (the contract's fields are those of its solve)."""

    drop: Droplet
    result: NLPResult
    contact_angle: float
    radius: float
    span: float
    energy: float
    young_residual: float
    energy_function: ca.Function  # theta -> E(theta), physical units

    def as_dict(self) -> dict:
        return {**super().as_dict(), "contact_angle": self.contact_angle,
                "young_residual": self.young_residual, "radius": self.radius, "span": self.span,
                "energy": self.energy}


def solve_angle(drop: Droplet, *, options: Optional[dict] = None, verbose: bool = False) -> AngleSolution:
    """Minimise ``E(theta)`` over ``theta`` in ``(0, pi)`` as a one-variable NLP (scaled: A = gamma_gl = 1)."""
    if drop.span is not None:
        raise InputError("the reduced problem in theta is posed for a free span; drop the span")
    unit = Droplet(1.0, drop.wetting / drop.gamma_gl, 0.0, 1.0)
    E_unit, _ = reduced_energy(unit)
    nlp = NLP()
    th = nlp.variable("theta", 1, lb=1e-6, ub=math.pi - 1e-6, init=0.5 * math.pi)
    nlp.minimize(E_unit(th))
    res = nlp.solve(options={"tol": 1e-12, **(options or {})}, verbose=verbose)
    theta = float(res["theta"][0])
    E, Rf = reduced_energy(drop)
    radius = float(Rf(theta))
    return AngleSolution(drop, res, theta, radius, 2.0 * radius * math.sin(theta), float(E(theta)),
                         drop.gamma_gl * math.cos(theta) + drop.wetting, E, **res.contract())
