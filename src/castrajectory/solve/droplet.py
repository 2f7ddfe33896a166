"""The droplet solved: one NLP per size handed to Ipopt, and the reduced problem in the contact angle.

:func:`solve` writes a discretisation (:mod:`castrajectory.discretise.droplet`) into one
:class:`~castrajectory.solve.nlp.NLP`, solves it (with a coarse presolve and a fallback ladder,
see its docstring) and returns a :class:`DropletSolution` with the errors against the oracle
(:func:`castrajectory.models.droplet.analytic`).  :func:`solve_angle` minimises the reduced
energy ``E(theta)``.

A heavy drop (``Droplet.rho_g > 0``) adds the weight (:func:`~castrajectory.discretise.droplet.add_gravity`);
the area multiplier is then the pressure at the wall.  A pendant drop is followed from the weightless
drop by continuation in the area (the Bond number), and every step's reduced Hessian
(:mod:`castrajectory.solve.second_order`) says whether it is still a minimum: beyond the family's fold
there is no stable drop, and the result says so (status ``No_Stable_Drop``).

All NLPs are posed in units where ``A = 1`` and ``gamma_gl = 1`` (length unit
``sqrt(A)``, energy unit ``gamma_gl sqrt(A)``); results are converted back.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Dict, Optional

import casadi as ca
import numpy as np

from ..discretise.droplet import (  # noqa: F401  (the discretisations, re-exported with the model)
    DISCRETISATIONS, FORMULATIONS, MIN_N, POLYLINES, Curve, Geometry, Graph, Revolution, add_gravity, add_pattern,
    chord_weights, contact_angle_at_rim, contact_angle_estimate, resample_polyline)
from ..discretise.droplet_spectral import MAX_DEGREE, MIN_DEGREE, Spectral
from ..models.droplet import (  # noqa: F401
    AxisymmetricDrop, BeyondFold, CircularCap, Droplet, HeavyDrop, PatternedCap, SphericalCap, analytic, arc_points,
    outer_young_angle, pendant_fold, puddle_height, reduced_energy, revolution_fold, segment_area_factor,
    step_measure, young_angle)
from ..result import NLPResult, Result
from ..validation import InputError, integer_at_least, one_of
from . import memory
from .droplet_readings import check_profile, errors_against, pattern_readings, readings
from .nlp import DEFAULT_IPOPT_OPTIONS, NLP
from .second_order import reduced_hessian


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
#: The spectral profile starts from the cap of the weightless angle, where Ipopt's least-squares estimate of
#: the area multiplier is the pressure itself; and the 2-D profile's length, ``2 L``, is linear in the
#: unknowns, so with a zero multiplier the Lagrangian's Hessian vanishes (the weightless 2-D pendant start:
#: a first step of 4e16, Restoration_Failed).  Ipopt's default (``constr_mult_init_max = 1000``) then.
SPECTRAL_OPTIONS = {"constr_mult_init_max": 1000.0}


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
    #: the largest ``y`` of the vertices (from the wall into the liquid)
    height: float = math.nan
    #: the curvature of the circle through the three vertices at the top
    apex_curvature: float = math.nan
    #: a pendant drop's stability: the reduced Hessian at the answer and the continuation that led there
    #: (the fold, when the family ended before the requested area); None where it was not checked
    stability: Optional[dict] = None
    #: a drop of revolution: its volume (the polyline of revolution's, exactly) and contact radius
    volume: float = math.nan
    contact_radius: float = math.nan
    #: a patterned table: the regime, the apparent angle, the pinning multiplier and the split (:func:`_pattern_readings`)
    pattern: Optional[dict] = None

    @property
    def pressure_at_table(self) -> float:
        """The area multiplier ``dE*/dA``: the pressure at the wall (the Laplace pressure without gravity)."""
        return self.pressure

    def as_dict(self) -> dict:
        """The JSON object of ``problems/droplet.py --json``."""
        out = {
            **super().as_dict(),
            "formulation": self.formulation,
            "n": self.n,
            "mode": "free-span" if self.drop.span is None else "fixed-span",
            "contact_angle": self.contact_angle,
            "span": self.span,
            "pressure": self.pressure,
            "energy": self.energy,
            "young_residual": self.young_residual,
            "height": self.height,
            "apex_curvature": self.apex_curvature,
            "pressure_at_table": self.pressure_at_table,
            "analytic": None if self.analytic is None else self.analytic.as_dict(),
            "errors": dict(self.errors),
            "x": self.x.tolist(),
            "y": self.y.tolist(),
            "program": self.program,
        }
        if self.drop.axisymmetric:  # x, y: the half profile (r, z) from the apex; span: the contact diameter
            out.update(axisymmetric=True, volume=self.volume, contact_radius=self.contact_radius)
        if self.drop.rho_g > 0.0:
            out.update(gravity=self.drop.rho_g, pendant=self.drop.pendant, bond_number=self.drop.bond_number,
                       capillary_length=self.drop.capillary_length)
        if self.stability is not None:
            out["stability"] = self.stability
        if self.pattern is not None:
            out.update(regime=self.pattern["regime"], apparent_angle=self.pattern["apparent_angle"],
                       pinning_multiplier=self.pattern["pinning_multiplier"], pattern=self.pattern)
        return out


#: Coarse grid of the fallback ladder (see :func:`solve`).
COARSE_N = 40
#: Iteration budget of the direct curve solve before the ladder takes over.
FIRST_ATTEMPT_MAX_ITER = 30
#: Curve solves with at least this many segments start from a coarse solve on PRESOLVE_N segments.
PRESOLVE_MIN_N = 2000
PRESOLVE_N = 200


def _check_formulation(drop: Droplet, formulation: str, n: Optional[int] = None) -> None:
    one_of("formulation", formulation, FORMULATIONS)
    if formulation == "spectral":
        if drop.patterned:
            raise InputError("the spectral formulation is not offered on a patterned table (the pinned edge's "
                             "kink is held by the curve's split); use the curve formulation")
        if n is not None and not MIN_DEGREE <= n <= MAX_DEGREE:
            raise InputError(f"the spectral formulation's --n is the degree of the profile's tangent angle: "
                             f"{MIN_DEGREE} to {MAX_DEGREE} (got {n})")
        return
    if drop.axisymmetric and formulation == "graph":
        raise InputError("a drop of revolution is discretised as a curve (its half profile from the axis); the "
                         "graph formulation is not offered for it: use the curve or spectral formulation")
    if formulation != "graph":
        return
    if drop.pendant:
        raise InputError("the graph formulation y(x) cannot represent a pendant drop's neck (it overhangs); "
                         "use the curve formulation")
    theta = young_angle(drop.gamma_gl, drop.gamma_sl, drop.gamma_sg) if drop.rho_g > 0.0 else \
        analytic(drop).contact_angle
    if theta >= 0.5 * math.pi:
        raise InputError(
            f"the graph formulation y(x) cannot represent contact angles of 90 degrees or more "
            f"(this drop's angle is {math.degrees(theta):.4g} degrees); use the curve formulation")


def make_nlp(drop: Droplet, n: int, formulation: str = "curve", guess=None):
    """Build (but do not solve) the droplet NLP in scaled units; return ``(nlp, geometry, area_constraint)``."""
    n = integer_at_least("n", n, MIN_N)
    _check_formulation(drop, formulation, n)
    L = drop.length_scale
    nlp = NLP()
    if formulation == "spectral":
        nlp.compile_elements = False  # one element per family: nothing to gain from compiling (or looking up)  # starts from the cap of the weightless angle, as a drop of revolution does
        disc = Spectral(n, drop.axisymmetric, analytic(replace(drop, rho_g=0.0, pendant=False)).contact_angle,
                        guess)  # guess: (psi at the nodes, L), or None
    elif formulation == "curve":
        # a drop of revolution starts from the cap of its weightless angle (Young's, or Gibbs' on a pattern)
        disc = Revolution(n, guess, analytic(replace(drop, rho_g=0.0, pendant=False)).contact_angle,
                          _heavy_weights(drop, n)) if drop.axisymmetric else Curve(n, guess, _heavy_weights(drop, n))
    else:
        disc = DISCRETISATIONS[formulation](n)
    # The scene's terms: surface tension (the length elements, added by the discretisation) always;
    # the wetting term only when the span is free and it is non-zero (on the wetted disc pi r_c² for a drop
    # of revolution, whose surface tension is its frustums' area).
    geo = disc.build(nlp, None if drop.span is None else drop.span / L)
    w = drop.wetting / drop.gamma_gl
    if drop.patterned:  # the wetting energy split at the pattern's step (its kink held by a bound)
        nlp.minimize(add_pattern(nlp, geo, w, drop.wetting_out / drop.gamma_gl, _scaled_step(drop)))
    elif drop.span is None and w != 0.0:
        nlp.minimize(w * (geo.span if geo.wetted is None else geo.wetted))
    # gravity only for a heavy drop (a weightless drop builds exactly the program it had before)
    if drop.rho_g > 0.0:
        add_gravity(nlp, geo, drop.gravity_sign * drop.bond_number)
    return nlp, geo, nlp.constraint("area")


def _estimated_length(drop: Droplet) -> float:
    """An estimate of a heavy drop's curve length from the drop alone (scaled units): the larger of the
    weightless cap's and a puddle's of height ``h∞`` (2-D: the whole curve, ``A / h∞``; a drop of revolution:
    the half profile from the apex, about the puddle's radius ``sqrt(V / π h∞)``)."""
    cap = analytic(replace(drop, rho_g=0.0, pendant=False))
    if drop.axisymmetric:
        return max(cap.radius * cap.contact_angle, math.sqrt(drop.area / (math.pi * puddle_height(drop)))) / \
            drop.length_scale
    return max(2.0 * cap.radius * cap.contact_angle, drop.area / puddle_height(drop)) / drop.length_scale


def _heavy_weights(drop: Droplet, n: int) -> Optional[np.ndarray]:
    """The chords of a heavy drop's polyline, graded toward its contact line (:func:`chord_weights`), or None
    (equal chords) for a weightless drop.  A drop of revolution's half profile from the apex is graded toward
    the rim only: the half of a whole curve twice its length."""
    if drop.rho_g <= 0.0 or drop.span is not None or drop.patterned:
        return None
    ell, length = drop.capillary_length / drop.length_scale, _estimated_length(drop)
    if drop.axisymmetric:
        return chord_weights(2 * n, ell, 2.0 * length)[n:]
    return chord_weights(n, ell, length)


def _scaled_step(drop: Droplet, area: Optional[float] = None) -> float:
    """The pattern's step measure (width, or disc area) in the scaled units of a drop of ``area``."""
    L = drop.length_scale if area is None else replace(drop, area=area).length_scale
    return step_measure(drop) / L ** (2 if drop.axisymmetric else 1)


def solve(drop: Droplet, n: int = 400, formulation: str = "curve", *, options: Optional[dict] = None,
          verbose: bool = False, compare: bool = True, estimate: bool = True) -> DropletSolution:
    """Minimise the discrete droplet energy; never raises on non-convergence (see ``castrajectory.result``).

    ``compare``: the errors against the closed form (``analytic``).  A heavy drop of revolution's is a
    Young–Laplace shooting that costs more than a spectral solve (about 60 ms against 10); ``False`` skips it
    (``errors`` is then empty, and the error estimate is what the answer carries).  ``estimate``: the error
    estimate (a second solve, on a coarser grid or a lower degree); ``False`` leaves it out, and says so in
    the answer's warnings.

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
    _check_formulation(drop, formulation, n)
    _check_bracketable(drop)
    memory.check_droplet(drop, n, formulation, compare)  # refused before anything is built
    opts = {**SOLVER_OPTIONS, **(SPECTRAL_OPTIONS if formulation == "spectral" else {}), **(options or {})}
    floor = _rounding_floor(drop, n) if formulation == "curve" else None
    if floor is not None and floor > float(opts.get("tol", DEFAULT_IPOPT_OPTIONS["tol"])):
        opts["tol"] = floor
    if drop.pendant:
        sol = _solve_pendant(drop, n, formulation, opts, verbose, compare, estimate)
    else:
        if drop.patterned:
            opts = {**opts, **PATTERN_OPTIONS, **(options or {})}
        res, nlp, geo = _solve_scaled(drop, n, formulation, opts, verbose)
        cap, note = _oracle(drop) if compare else (None, None)
        sol = _solution(drop, n, formulation, opts, verbose, res, nlp, geo, cap, estimate=estimate)
        if note and sol.success:
            sol.warnings.append(note)
    if not estimate and sol.success:
        sol.warnings.append("no error estimate: left out on request (estimate=False)")
    if floor is not None and opts.get("tol") == floor and sol.success:
        sol.warnings.append(f"Ipopt's tolerance raised to {floor:.2e}: the rounding floor of this graded polyline "
                            "(its smallest chords against its largest coordinates)")
    return sol


#: A graded polyline's rounding floor, in units of ``eps n / w_min`` times the largest weight of a chord's
#: length in the energy (2-D: 1; a drop of revolution: its frustum's ``2 pi r_c``): its smallest chords,
#: ``w_min / n`` of the mean one, are differences of coordinates as large as the curve, so each chord's
#: direction (the gradient of its length, a unit vector) carries a rounding error of about ``eps n / w_min``,
#: and Ipopt's dual infeasibility stalls there.  Measured: Bond number 1e4, N = 1600 (2-D): 2.9e-10 where
#: ``eps n / w_min`` = 4.4e-10; a drop of revolution, Bond 1e4, N = 400: 2.5e-10 where the floor's unit is
#: 8.8e-10.  Ipopt's default tolerance 1e-10 then ends in Search_Direction_Becomes_Too_Small or
#: Solved_To_Acceptable_Level with the drop converged.
ROUNDING_FLOOR = 2.0


def _rounding_floor(drop: Droplet, n: int) -> Optional[float]:
    """The smallest Ipopt tolerance a heavy drop's graded polyline of ``n`` chords can reach (None: equal chords)."""
    w = _heavy_weights(drop, n)
    if w is None:
        return None
    weight = 2.0 * math.pi * _estimated_length(drop) if drop.axisymmetric else 1.0
    return ROUNDING_FLOOR * float(np.finfo(float).eps) * n / float(w.min()) * weight


def _oracle(drop: Droplet):
    """``(oracle, None)``, or ``(None, why)`` where the closed form has no answer (a pendant drop between
    the closed form's fold and the discrete family's, or a puddle beyond the closed form's range)."""
    try:
        return analytic(drop), None
    except ValueError as exc:
        return None, f"no errors against the closed form: {exc}"


def _terms(drop: Droplet) -> list:
    """The scene's terms, as the NLP carries them."""
    if drop.patterned:
        measure = "π r_c²" if drop.axisymmetric else "span"
        return ["surface tension γ_gl × " + ("area of revolution (Σ π(r_i + r_i+1) l_i)" if drop.axisymmetric
                                              else "length"),
                f"wetting split at the pattern's step: {measure} = inside + outside, (γ_sl − γ_sg) × inside + "
                "(γ_sl_out − γ_sg) × outside, inside ≤ step (pinning bound)",
                "volume constraint" if drop.axisymmetric else "area constraint"]
    if drop.axisymmetric:
        terms = ["surface tension γ_gl × area of revolution (Σ π(r_i + r_i+1) l_i)", "volume constraint"]
        if drop.wetting != 0.0:
            terms.insert(1, "wetting (γ_sl − γ_sg) × π r_c²")
        if drop.rho_g > 0.0:
            terms.append("gravity −ρg ∫ y dV (pendant: hanging under the wall)" if drop.pendant else
                         "gravity ρg ∫ y dV (sessile)")
        return terms
    terms = ["surface tension γ_gl × length", "area constraint"]
    if drop.span is None and drop.wetting != 0.0:
        terms.insert(1, "wetting (γ_sl − γ_sg) × span")
    elif drop.span is not None:
        terms.append("span pinned")
    if drop.rho_g > 0.0:
        terms.append("gravity −ρg ∫∫ y dA (pendant: hanging under the wall)" if drop.pendant else
                     "gravity ρg ∫∫ y dA (sessile)")
    return terms


def _solution(drop: Droplet, n: int, formulation: str, opts: dict, verbose: bool, res: NLPResult, nlp, geo,
              cap, stability: Optional[dict] = None, estimate: bool = True) -> DropletSolution:
    """The solution of the drop from its final solve: readings, errors against ``cap`` (None: no oracle),
    and on success (and ``estimate``) the error estimate."""
    r = readings(drop, res, geo)
    check_profile(drop, res, r)
    errors = {} if cap is None else errors_against(r, cap)
    young = None if drop.span is not None else drop.gamma_gl * math.cos(r["contact_angle"]) + drop.wetting
    if drop.patterned:  # Young's law holds at the regime's angle; a pinned edge obeys Gibbs' criterion instead
        regime = r["pattern"]["regime"]
        young = None if regime == "pinned" else drop.gamma_gl * math.cos(r["contact_angle"]) + (
            drop.wetting if regime == "inside" else drop.wetting_out)
    sol = DropletSolution(drop, formulation, n, res, r["x"], r["y"], r["contact_angle"], r["span"], r["pressure"],
                          r["energy"], young, cap, errors, {"terms": _terms(drop), "steps": int(n), **nlp.anatomy()},
                          height=r["height"], apex_curvature=r["apex_curvature"], stability=stability,
                          volume=r.get("volume", math.nan), contact_radius=r.get("contact_radius", math.nan),
                          pattern=r.get("pattern"), **res.contract())
    if sol.success and estimate:
        sol.error_estimate = _estimate(drop, n, formulation, opts, verbose, r, sol)
        sol.warnings += sol.error_estimate.warnings()
    check_readings(sol, apex_read=formulation != "spectral" and not drop.axisymmetric)
    return sol


#: The largest disagreement of a drop's readings with the laws they obey that still counts as an answer,
#: relative to their size: Young's law at the contact line, ``|γ_gl cos θ + γ_sl − γ_sg| / γ_gl``, and the
#: Laplace pressure, ``|P − (γ κ_a ± ρg h)| / (γ |κ_a| + ρg h)``.  Both are measured errors of the answer,
#: independent of its error estimate (which a grid that misses the contact line fools: it claimed 0.87 % for a
#: contact angle of 4.7° where Young's is 60°).  A resolved drop meets both far below it (N = 400: 8e-5 and 4e-6
#: at Bond numbers 100 to 1e6 with graded chords; weightless, N = 6: 7.7e-3 and 1.6e-2 ... N = 10: 2.8e-3 and
#: below 1e-2); the unresolved heavy drop does not (equal chords at Bond 1e4, N = 400: 0.497 and 0.21).
CHECK_RTOL = 1e-2
#: The status of an answer whose readings fail those checks.
CHECK_FAILED = "Check_Failed"


def check_readings(sol: DropletSolution, apex_read: bool = True) -> None:
    """Fail a converged drop whose readings disagree with Young's law or the Laplace pressure beyond
    ``CHECK_RTOL`` (the message says which check failed and by how much).  ``apex_read``: the apex curvature is
    read off the vertices (a 2-D polyline), not derived from the pressure (the spectral profile, a drop of
    revolution), so the pressure check is a check."""
    if not sol.success:
        return
    drop, failed = sol.drop, []
    if sol.young_residual is not None and abs(sol.young_residual) > CHECK_RTOL * drop.gamma_gl:
        wanted = "Young's" if sol.pattern is None else "the regime's Young"
        failed.append(f"Young's law: γ_gl cos θ + γ_sl − γ_sg = {sol.young_residual:.3g}, "
                      f"{abs(sol.young_residual) / drop.gamma_gl:.3g} of γ_gl (the contact angle "
                      f"{math.degrees(sol.contact_angle):.4g}° against {wanted} angle)")
    if apex_read and drop.span is None and math.isfinite(sol.apex_curvature):
        hydro = drop.gravity_sign * drop.rho_g * sol.height if drop.rho_g > 0.0 else 0.0
        laplace = drop.gamma_gl * sol.apex_curvature + hydro
        scale = drop.gamma_gl * abs(sol.apex_curvature) + abs(hydro)
        if scale > 0.0 and abs(sol.pressure - laplace) > CHECK_RTOL * scale:
            failed.append(f"the Laplace pressure: the area multiplier {sol.pressure:.6g} against γ κ_a "
                          f"{'± ρg h ' if drop.rho_g > 0.0 else ''}= {laplace:.6g} from the vertices, "
                          f"{abs(sol.pressure - laplace) / scale:.3g} relative")
    if failed:
        sol.fail(CHECK_FAILED, "the drop fails " + " and ".join(failed) + f", beyond {CHECK_RTOL:g}: the grid "
                 "does not resolve it (under gravity, its contact line within a capillary length); raise n")


def _add_costs(res, spent):
    """Add the iterations and times of the solves ``spent`` to ``res`` (an NLPResult or a solution: the
    reported cost is the whole run's)."""
    for r in spent:
        res.build_time_s += r.build_time_s
        res.solve_time_s += r.solve_time_s
        res.iterations += r.iterations
    return res


# ---------------------------------------------------------------------------- continuation in the area
#: The first step of the continuation in the Bond number, as a fraction of the target (then doubled
#: after each accepted step, halved after each refused one).
CONTINUATION_FIRST_STEP = 0.25
#: The continuation stops refining the last step when it is below this fraction of the Bond number
#: reached: the fold is then bracketed to this relative width.
FOLD_RTOL = 1e-7
#: Ipopt iterations per continuation step (a step from the last drop takes a few, 4-7 measured up to 1e-7
#: below the fold of a pendant drop; a step beyond the fold does not converge, and should not cost long).
CONTINUATION_MAX_ITER = 20
#: Ipopt options of a continuation step: start from the last drop's multipliers too.  Without
#: ``warm_start_init_point`` Ipopt discards the given multipliers (``constr_mult_init_max = 0`` then sets the
#: area's to zero), so every step began with the pressure missing from the Lagrangian's Hessian: an indefinite
#: Hessian, inertia correction and a jump of order one.  Measured on the 90-degree drop at Bond 1e4 (N = 40):
#: without, the steps stalled at Bond 28.23 after 200 steps and 3125 iterations; with, 28 steps, 391 iterations.
WARM_STEP_OPTIONS = {"warm_start_init_point": "yes", "warm_start_bound_push": 1e-9,
                     "warm_start_mult_bound_push": 1e-9}
#: Steps of one continuation at most (reaching a fold to FOLD_RTOL takes about 30).
CONTINUATION_MAX_STEPS = 200
#: The status of a pendant drop asked for beyond the fold of its family.
NO_STABLE_DROP = "No_Stable_Drop"
#: The largest Bond number of a pendant drop whose fold the continuation can bracket: from its first step
#: (a quarter of the target) it halves until a drop is found, about log2(Bo / Bo*) refused steps, then
#: bisects the fold to FOLD_RTOL (about 24 more; measured 23.5-25 steps beyond log2(Bo / Bo*) at N = 40,
#: 2-D and 3-D, Bo up to 1e30).  2^152 (5.7e45) leaves CONTINUATION_MAX_STEPS room for folds down to
#: Bo* = 2^-24; above it the continuation would stall, so the drop is refused before any solve.
MAX_PENDANT_BOND = 2.0 ** (CONTINUATION_MAX_STEPS - 2 * math.ceil(math.log2(1.0 / FOLD_RTOL)))


def _check_bracketable(drop: Droplet) -> None:
    """Refuse a pendant drop too large for the continuation to bracket its family's fold (see MAX_PENDANT_BOND)."""
    if drop.pendant and drop.bond_number > MAX_PENDANT_BOND:
        raise InputError(f"a pendant drop of {drop.measure} {drop.area:g} (Bond number {drop.bond_number:.3g}) is "
                         f"beyond what the continuation can bracket (Bond number <= {MAX_PENDANT_BOND:.3g}); "
                         "every pendant family folds at a Bond number of order one, so no stable drop exists there")


@dataclass
class _Continuation:
    """Where a continuation in the area ended: the last accepted solve, its program, and the record."""

    result: NLPResult
    nlp: object
    geo: Geometry
    bond: float  # the Bond number reached
    hessian: object  # its ReducedHessian (None when stability was not checked)
    steps: list  # one dict per step tried
    refused: Optional[float]  # the smallest Bond number refused beyond the last accepted one


def _continuation(drop: Droplet, n: int, formulation: str, opts: dict, verbose: bool,
                  stability: bool = True) -> _Continuation:
    """Follow the drop's family from the weightless drop (Bond number 0) to ``drop.bond_number``.

    One program, whose weight is a parameter: each step sets it and starts Ipopt from the last accepted
    drop and its multipliers.  A step is accepted when Ipopt converges and (``stability``) the reduced
    Hessian ``Zᵀ∇²L Z`` is positive definite: the drop is a minimum.  A refused step is bisected between
    the last accepted drop and it; once that bracket is below ``FOLD_RTOL`` of the Bond number reached, the
    refused value is tried once more from the bracket's lower end (an earlier refusal may only have been
    too long a step), and if it fails again the family has ended there (a fold) and the continuation
    stops.  Every solve's iterations and times are counted in the returned result.
    """
    target, sign = drop.bond_number, drop.gravity_sign
    nlp, geo, _ = make_nlp(drop, n, formulation)
    nlp.set_parameter("gravity", 0.0)
    res = nlp.solve(options=opts, verbose=verbose)
    spent = []
    hess = reduced_hessian(nlp, res) if (stability and res.success) else None
    steps = [_step_record(drop, 0.0, res, hess)]
    bond, step, refused = 0.0, CONTINUATION_FIRST_STEP * target, None
    step_opts = {**opts, **WARM_STEP_OPTIONS,
                 "max_iter": min(int(opts.get("max_iter", CONTINUATION_MAX_ITER)), CONTINUATION_MAX_ITER)}
    if not res.success or (hess is not None and not hess.positive_definite):
        return _Continuation(res, nlp, geo, bond, hess, steps, 0.0)
    refused_from = None
    while bond < target:
        if len(steps) > CONTINUATION_MAX_STEPS:
            res.fail("Continuation_Stalled", f"the continuation in the area took more than {CONTINUATION_MAX_STEPS} "
                     f"steps and reached the Bond number {bond:.6g} of {target:.6g}; supply other Ipopt options")
            return _Continuation(res, nlp, geo, bond, hess, steps, None)
        if refused is not None and refused - bond <= FOLD_RTOL * max(bond, FOLD_RTOL):
            if refused_from == bond:  # refused from within the tolerance: the family ends in this bracket
                break
            trial = refused  # a refusal from further away may only have been too long a step: try again
        else:
            trial = min(bond + step, target)
            if refused is not None:  # bisect the bracket [accepted, refused]
                trial = min(trial, 0.5 * (bond + refused))
        nlp.set_parameter("gravity", sign * trial)
        r = nlp.solve(warm=res, options=step_opts, verbose=verbose)
        r.build_time_s = 0.0  # the same program: built once, counted once
        h = reduced_hessian(nlp, r) if (stability and r.success) else None
        steps.append(_step_record(drop, trial, r, h))
        if r.success and (h is None or h.positive_definite):
            spent.append(res)
            bond, res, hess = trial, r, h
            step *= 2.0
            if refused is not None and (bond >= refused or not stability):
                refused = None  # without a stability test a refusal marks no fold: only a step too long
            continue
        spent.append(r)
        refused, refused_from = trial, bond
        step = 0.5 * (trial - bond)
    nlp.set_parameter("gravity", sign * bond)
    return _Continuation(_add_costs(res, spent), nlp, geo, bond, hess, steps, refused if bond < target else None)


def _step_record(drop: Droplet, bond: float, res: NLPResult, hess) -> dict:
    return {"bond_number": bond, "area": drop.area_for_bond(bond), "status": res.status,
            "iterations": res.iterations,
            "min_eigenvalue": None if hess is None else hess.min_eigenvalue,
            "positive_definite": None if hess is None else hess.positive_definite}


def _fold_estimate(steps: list) -> Optional[float]:
    """The fold's area from the two last stable steps: near a fold the reduced Hessian's smallest
    eigenvalue vanishes like ``sqrt(A* − A)``, so its square is extrapolated linearly to zero."""
    ok = [s for s in steps if s["positive_definite"]]
    if len(ok) < 2:
        return None
    (a1, l1), (a2, l2) = [(s["area"], s["min_eigenvalue"]) for s in ok[-2:]]
    if not l1 ** 2 > l2 ** 2:
        return None
    return a2 + l2 ** 2 * (a2 - a1) / (l1 ** 2 - l2 ** 2)


def _solve_pendant(drop: Droplet, n: int, formulation: str, opts: dict, verbose: bool,
                   compare: bool = True, estimate: bool = True) -> DropletSolution:
    """A pendant drop by continuation in the area (see :func:`_continuation`); beyond the fold, the last
    stable drop with the status ``No_Stable_Drop``."""
    cont = _continuation(drop, n, formulation, opts, verbose)
    res = cont.result
    try:
        fold = revolution_fold(drop) if drop.axisymmetric else pendant_fold(drop)
    except ValueError:  # a contact angle whose family closes its neck first: no closed form
        fold = None
    stability = {"reduced_hessian": None if cont.hessian is None else cont.hessian.as_dict(),
                 "continuation": cont.steps, "fold": None}
    if not res.success or cont.bond >= drop.bond_number:
        cap, note = _oracle(drop) if compare else (None, None)
        sol = _solution(drop, n, formulation, opts, verbose, res, cont.nlp, cont.geo, cap, stability,
                        estimate=estimate)
        if note and sol.success:
            sol.warnings.append(note)
        return sol
    # the family ended before the requested area: the answer is the last stable drop, and the verdict
    last = replace(drop, area=drop.area_for_bond(cont.bond))
    found = {"area": last.area, "refused_area": drop.area_for_bond(cont.refused),
             "extrapolated_area": _fold_estimate(cont.steps),
             "analytic_area": None if fold is None else fold.area}
    stability["fold"] = found
    sol = _solution(last, n, formulation, opts, verbose, res, cont.nlp, cont.geo, fold, stability, estimate=False)
    what, sym = drop.measure, "V" if drop.axisymmetric else "A"
    closed = "" if fold is None else (f"; the closed form's fold is A* = {fold.area:.7g}" if not drop.axisymmetric
                                      else f"; the Young–Laplace shooting's fold is V* = {fold.area:.7g}")
    sol.fail(NO_STABLE_DROP,
             f"no stable pendant drop of {what} {drop.area:g}: following the family by continuation in the {what}, "
             f"the reduced Hessian of the Lagrangian stays positive definite up to {sym} = {last.area:.7g} and no "
             f"stable drop exists beyond it (the fold of the family at N = {n}){closed}")
    if fold is not None:
        sol.errors = {"fold_area": abs(last.area - fold.area) / fold.area}
    return sol


#: The droplet discretisations' order (shape, span, angle, pressure, energy: second order in 1/N).
ORDER = 2
#: The quantities of the droplet's error estimate.
ESTIMATED = ("contact_angle", "span", "pressure", "energy")


#: Ipopt options of a patterned table on top of SOLVER_OPTIONS: the pinning bound is active in two regimes of
#: three, so the barrier starts at Ipopt's default (``mu_init = 1e-9`` of the smooth drop, with no active
#: inequality, ...) and the bounds are not relaxed (the split stays exact; contact code does the same).
PATTERN_OPTIONS = {"mu_init": 0.1, "bound_relax_factor": 0.0}


def _estimate(drop: Droplet, n: int, formulation: str, opts: dict, verbose: bool, fine: dict,
              sol: DropletSolution):
    """The estimate from the same drop on ``n/2`` and ``n/4`` segments, each started from the answer
    resampled (a few Newton iterations; :func:`castrajectory.solve.estimate.grid_estimate`: the order the
    three grids show); their cost is added to ``sol``'s.  Errors of the contact angle (scale π/2), span,
    pressure and energy (each against its own size); the order is judged on the one whose difference is
    the largest against its scale.  Two grids (the nominal order) where ``n/4`` is below
    :data:`MIN_N`."""
    from .estimate import ErrorEstimate, grid_estimate
    if formulation == "spectral":
        return _spectral_estimate(drop, n, opts, verbose, fine, sol)
    grids = [m for m in (n // 4, n // 2) if m >= MIN_N]
    if not grids or grids[-1] != n // 2:
        return ErrorEstimate.none(f"N = {n} has no coarser grid (at least {MIN_N} segments)")
    read = []
    for nc in grids:
        guess = resample_polyline(fine["xs"], fine["ys"], nc) if formulation == "curve" else None
        nlp, geo, _ = make_nlp(drop, nc, formulation, guess)
        res = nlp.solve(options=opts, verbose=verbose)
        _add_costs(sol, [res])  # the estimate's solves are part of the answer's cost
        if not res.success:
            return ErrorEstimate.none(f"the drop on N = {nc} segments for the estimate did not converge "
                                      f"({res.solver_status})")
        read.append(readings(drop, res, geo))
    read.append(fine)
    diffs = [{k: abs(float(a[k]) - float(b[k])) for k in ESTIMATED} for a, b in zip(read[:-1], read[1:])]
    levels = tuple(grids) + (n,)
    ratios = [levels[i + 1] / levels[i] for i in range(len(levels) - 1)]
    return grid_estimate(diffs, ratios, _estimate_scales(drop, fine), ORDER, levels)


def _estimate_scales(drop: Droplet, fine: dict) -> Dict[str, float]:
    """The size each estimated reading is measured against (a pendant drop's pressure passes through zero:
    there the scale of its two parts, the capillary and the hydrostatic)."""
    scales = {"contact_angle": 0.5 * math.pi, "span": abs(fine["span"]), "pressure": abs(fine["pressure"]),
              "energy": abs(fine["energy"])}
    if drop.rho_g > 0.0:
        scales["pressure"] = (2.0 if drop.axisymmetric else 1.0) * drop.gamma_gl * abs(fine["apex_curvature"]) + \
            drop.rho_g * fine["height"]
    return scales


#: The spectral estimate's coarser degree, as a fraction of the degree: the difference of the two readings
#: bounds the coarser one's error, so it overstates the finer one's (by a factor that grows with the degree).
SPECTRAL_COARSE = 0.75


def _spectral_estimate(drop: Droplet, n: int, opts: dict, verbose: bool, fine: dict, sol: DropletSolution):
    """The readings' differences to the same drop at degree ``ceil(3n/4)``: no extrapolation (a spectral
    error has no power law to extrapolate), an upper bound of the coarser degree's error."""
    from .estimate import ErrorEstimate
    nc = max(MIN_DEGREE, int(math.ceil(SPECTRAL_COARSE * n)))
    if nc >= n:
        return ErrorEstimate.none(f"degree {n} has no lower degree to compare with (at least {MIN_DEGREE})")
    # from the fine answer, resampled to the coarse nodes (a few Newton iterations; no continuation)
    nlp, geo, _ = make_nlp(drop, nc, "spectral", (Spectral.resample(fine["psi"], nc), fine["length"]))
    res = nlp.solve(options=opts, verbose=verbose)
    if not res.success:  # the coarse answer is far from the fine one (an unresolved drop): solve it afresh
        warm = res
        res, nlp, geo = _solve_scaled(drop, nc, "spectral", opts, verbose)
        res = _add_costs(res, [warm])
    _add_costs(sol, [res])  # the estimate's solve is part of the answer's cost
    if not res.success:
        return ErrorEstimate.none(f"the drop at degree {nc} for the estimate did not converge ({res.solver_status})")
    coarse = readings(drop, res, geo)
    errors = {k: abs(fine[k] - coarse[k]) for k in ESTIMATED}
    scales = _estimate_scales(drop, fine)
    rel = max(errors[k] / scales[k] for k in errors if scales[k] > 0)
    return ErrorEstimate(available=True, note=f"difference to degree {nc} (bounds that degree's error; "
                         f"degree {n}'s is smaller)", levels=(nc, n), errors=errors, scales=scales,
                         relative=float(rel), method="degree")


def _solve_scaled(drop: Droplet, n: int, formulation: str, opts: dict, verbose: bool):
    """The strategy of :func:`solve`; returns ``(result, nlp, geometry)`` in scaled units."""
    ladder = formulation == "curve" and n > COARSE_N
    heavy = drop.rho_g > 0.0  # its fallback: continuation in the area from the weightless drop
    first = dict(opts)
    if ladder or heavy:  # a good start converges in <= 15 iterations; do not spend a long failing run
        first["max_iter"] = min(int(opts.get("max_iter", 200)), FIRST_ATTEMPT_MAX_ITER)
    guess, spent = None, []
    # a heavy drop's default guess is the weightless one: far from a heavy drop at any N, and a first attempt
    # from it at fine N spends its iterations in Ipopt's inertia correction (N = 1000, Bond 100: 37 s)
    if formulation == "curve" and (n >= PRESOLVE_MIN_N or (heavy and n > PRESOLVE_N)):
        coarse, cnlp, cgeo = _solve_scaled(drop, PRESOLVE_N, "curve", opts, verbose)
        spent.append(coarse)
        if coarse.success:
            xs, ys, _ = cgeo.vertices(coarse)
            guess = resample_polyline(xs, ys, n)
    nlp, geo, _ = make_nlp(drop, n, formulation, guess)
    res = nlp.solve(options=first, verbose=verbose)
    if not res.success and heavy:
        # the family is followed on the coarse polyline (a continuation step from a weightless drop at fine N
        # drove Ipopt into its inertia correction: 30 s for one refused step at N = 1000), then refined
        spent.append(res)
        m = min(n, COARSE_N) if formulation == "curve" else n
        cont = _continuation(drop, m, formulation, opts, verbose, stability=False)
        res, nlp, geo = cont.result, cont.nlp, cont.geo
        if m < n and res.success:
            res, nlp, geo = _coarse_to_fine(drop, n, opts, verbose, res, start=(m, geo))
    elif not res.success and ladder:
        res, nlp, geo = _coarse_to_fine(drop, n, opts, verbose, res)
    return _add_costs(res, spent), nlp, geo


def _coarse_to_fine(drop: Droplet, n: int, opts: dict, verbose: bool, failed: NLPResult, start=None):
    """Fallback ladder COARSE_N, 2 COARSE_N, ..., n; every solve's time and iterations are counted.

    ``start = (m, geometry)``: ``failed`` is instead a solved drop on ``m`` segments, and the ladder climbs
    from it (its costs are counted)."""
    build, solve_t, iters = failed.build_time_s, failed.solve_time_s, failed.iterations
    guess, m = None, COARSE_N
    if start is not None:
        m, geo = start
        xs, ys, _ = geo.vertices(failed)
        m = min(2 * m, n)
        guess = resample_polyline(xs, ys, m)
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


# ---------------------------------------------------------------------------- a sweep of the area on a pattern
#: Options of a warm-started step of a sweep: the last drop is near the next, so the barrier starts small.
WARM_OPTIONS = {"mu_init": 1e-9}


def _pattern_step(nlp, drop: Droplet, last: Optional[NLPResult], opts: dict, verbose: bool) -> NLPResult:
    """One solve of a pattern's program at ``drop``'s area (only the pinning bound changes), started from ``last``
    (a warm step that fails is solved once more from the default guess)."""
    bounds = {"wetted_inside": (0.0, _scaled_step(drop))}
    res = nlp.solve(warm=last, options={**opts, **WARM_OPTIONS} if last else opts, verbose=verbose, bounds=bounds)
    if not res.success and last is not None:
        res = _add_costs(nlp.solve(options=opts, verbose=verbose, bounds=bounds), [res])
    return res


def solve_pattern_sweep(drop: Droplet, areas, n: int = 100, formulation: str = "curve", *,
                        options: Optional[dict] = None, verbose: bool = False, warm: bool = True) -> list:
    """The drop on its patterned table at each area (volume) of ``areas``, in order: one program (the scaled
    drop has area 1 whatever its area; only the pinning bound, the step in units of the drop's size, changes),
    each solve started from the last drop and its multipliers (``warm``), or from the default guess.  Returns a
    :class:`DropletSolution` per area (errors against :func:`~castrajectory.models.droplet.patterned_cap`; no
    error estimate); a failed solve is returned as such and the next starts afresh."""
    if not drop.patterned:
        raise InputError("a pattern sweep needs a patterned table (pattern_width and gamma_sl_out)")
    n = integer_at_least("n", n, MIN_N)
    _check_formulation(drop, formulation)
    memory.check_droplet(drop, n, formulation, compare=False)
    opts = {**SOLVER_OPTIONS, **PATTERN_OPTIONS, **(options or {})}
    nlp, geo, _ = make_nlp(drop, n, formulation)
    out, last = [], None
    for area in areas:
        last = last if warm else None
        here = replace(drop, area=float(area))
        _check_formulation(here, formulation)
        res = _pattern_step(nlp, here, last, opts, verbose)
        if out:
            res.build_time_s = 0.0  # one program, built once
        cap, _ = _oracle(here)
        out.append(_solution(here, n, formulation, opts, verbose, res, nlp, geo, cap, estimate=False))
        last = res if res.success else None
    return out


def pattern_transitions(drop: Droplet, n: int = 100, formulation: str = "curve", *, options: Optional[dict] = None,
                        verbose: bool = False, rtol: float = 1e-10) -> dict:
    """The areas (volumes) where the discrete drop's edge reaches the step and where it depins, to ``rtol``.

    Each is the root of a signed reading that is continuous through the transition: at the pinning area
    ``λ_in / Δγ − (step − m_in) / step`` (the pinning multiplier on the pinned side, the gap to the step inside),
    at the depinning area ``λ_out / Δγ − m_out / step`` (``Δγ = gamma_sl_out − gamma_sl``), found by the Illinois
    regula falsi from brackets around the oracle's areas; one program, each solve warm-started from the last.
    Returns ``{"pinning": A_pin, "depinning": A_depin}`` (``None`` where the edge never depins, a
    non-wetting outside) and ``{"solves": k, "iterations": i}``.  A study helper, not a scene's solve: a drop
    that does not converge raises ``RuntimeError``."""
    from ..models.droplet import _illinois, patterned_cap
    memory.check_droplet(drop, n, formulation, compare=False)
    opts = {**SOLVER_OPTIONS, **PATTERN_OPTIONS, **(options or {})}
    nlp, geo, _ = make_nlp(drop, n, formulation)
    jump = drop.gamma_sl_out - drop.gamma_sl
    state = {"last": None, "solves": 0, "iterations": 0}

    def reading(area: float, key: str) -> float:
        here = replace(drop, area=area)
        res = _pattern_step(nlp, here, state["last"], opts, verbose)
        state["solves"] += 1
        state["iterations"] += res.iterations
        if not res.success:
            raise RuntimeError(f"the drop of {drop.measure} {area:g} did not converge ({res.solver_status})")
        state["last"] = res
        p = pattern_readings(here, res, geo)["pattern"]
        if key == "pinning":
            return p["pinning_multiplier"] / jump - (p["step"] - p["wetted_inside"]) / p["step"]
        return p["outside_multiplier"] / jump - p["wetted_outside"] / p["step"]

    out = {}
    for key, exact in zip(("pinning", "depinning"), patterned_cap(drop).areas):
        if not math.isfinite(exact):
            out[key] = None
            continue
        lo, hi = 0.8 * exact, 1.25 * exact
        f = lambda a: reading(a, key)  # noqa: E731
        flo, fhi = f(lo), f(hi)
        while (flo > 0.0) == (fhi > 0.0):  # widen the bracket (the discrete transition moves by O(N^-2))
            lo, hi = 0.8 * lo, 1.25 * hi
            flo, fhi = f(lo), f(hi)
        out[key] = _illinois(f, lo, hi, flo, fhi, rtol)
    return {**out, "solves": state["solves"], "iterations": state["iterations"]}


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
    if drop.rho_g > 0.0:
        raise InputError("the reduced problem in theta is the weightless drop's (a circular cap); drop the gravity")
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
