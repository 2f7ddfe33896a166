#!/usr/bin/env python
"""Benchmark of the droplet solver (``castrajectory.solve.droplet``) and an SLSQP baseline.

This is a benchmark, not a test: it measures and reports, and always exits
with status 0 (2 for bad command-line flags, as argparse does).  PASS/MISS
lines say whether the performance goals were met in *this* run on *this*
machine; nothing is gated on them.

What is measured
----------------
1. Scaling.  For each ``N`` in ``--sizes`` the default drop
   (``gamma_gl = 1, gamma_sl = 0.5, gamma_sg = 1, A = 1``: Young's angle 60°)
   is solved with ``droplet.solve(drop, N, formulation)`` ``--repeats`` times,
   each time from scratch (a fresh NLP, so a fresh CasADi graph and Ipopt
   solver; from ``droplet.PRESOLVE_MIN_N`` segments on, ``solve`` first solves the
   drop on ``droplet.PRESOLVE_N`` segments to start from, and that coarse solve's
   build and solve times and iterations are included).  Reported per ``N``: the
   best build time (``Result.build_time_s``: graph construction plus ``nlpsol``),
   the best Ipopt solve time
   (``Result.solve_time_s``), the best per-run sum build + solve, the best wall
   time of the whole ``solve()`` call (which also post-processes the result),
   Ipopt's iteration count, the status and the shape error (largest distance of
   a vertex from the exact circle, divided by its radius).  Between consecutive
   sizes the script prints the time ratio and the ratio of time per ``N``; over
   all sizes it fits the slope of ``log(build + solve)`` against ``log N`` (the
   growth exponent; linear cost is 1).

2. SLSQP baseline.  For each ``N`` in ``--slsqp-sizes`` the *same* discrete
   problem as :class:`droplet.Curve` is posed in scaled units
   (``A = gamma_gl = 1``) for ``scipy.optimize.minimize(method="SLSQP")``:

   * unknowns ``z = (x_1..x_{N-1}, y_1..y_{N-1}, a)``, with ``p_0 = (0, 0)``
     and ``p_N = (a, 0)``;
   * objective ``sum_i |p_{i+1} - p_i| + w a``, ``w = (gamma_sl - gamma_sg) / gamma_gl``;
   * equalities ``(|p_{i+2} - p_{i+1}|² - |p_{i+1} - p_i|²) / (2 l_ref²) = 0``
     (``l_ref`` the mean segment of the initial guess, as in ``Curve``) and the
     shoelace area ``sum_i (x_{i+1} y_i - x_i y_{i+1}) / 2 = 1``
     (``Curve`` writes the same sum as a chain of partial sums; the feasible
     set and the minimiser are the same);
   * initial guess: the half-disc arc of unit area, as in ``Curve``;
   * exact derivatives: gradient and constraint Jacobians are written out
     analytically (vectorised numpy) and checked once against central finite
     differences before anything is timed;
   * options ``maxiter = 2000, ftol = 1e-10``.

   The SLSQP wall time is the best of ``--repeats`` runs (only one run if the
   first takes longer than 20 s).  Reported: success flag, message, iteration
   count, final constraint violation, energy error against the analytic energy
   ``droplet.analytic(drop).energy``, and the largest vertex distance from the
   castrajectory solution at the same ``N`` (a check that both solved the same
   problem).  castrajectory is re-run at the same ``N`` (best of
   ``--repeats``) and two speed ratios, both measured in this run, are printed:
   SLSQP time / castrajectory solve time and SLSQP time / castrajectory
   (build + solve) time.

3. The axisymmetric sessile drop (issue #26; ``--axisymmetric``, skipped with ``--no-axisymmetric`` or
   without scipy): θ = 90°, V = 1 l_c³ (the issue's table: h = 0.720266).  Target: the drop height to
   ``AXI_TOL`` = 1e-8 *relative* to h (h = 0.72 l_c, so 7.2e-9 l_c), against the model's own shooting
   (classical RK4 at 512 steps per l_c, about 1e-12; cross-checked with scipy's DOP853 at rtol 1e-12).
   The baseline is a Young–Laplace shooting with scipy: ``solve_ivp`` (DOP853) from the apex with a
   terminal event at φ = θ (the arclength of the contact), inside ``brentq`` on the apex curvature for
   the volume; its rtol is the loosest of 1e-6 … 1e-12 whose height meets the target.  Two NLPs:
   the polyline (order 2; its apex height converges as (a + b ln N)/N², Droplet §10: a and b fitted from
   N = 200 and 400, the N that meets the target predicted and solved), and the spectral profile (§12: the
   tangent angle a polynomial; the lowest even degree that meets the target).  Both are timed as
   ``droplet.solve`` without the comparison to the oracle (``compare=False``: the oracle is the shooting
   itself); the spectral one without and with its error estimate (a second solve), and cold (the first call
   at a degree forms the element derivatives).  The stability verdict (the reduced Hessian, dense) is timed
   at the spectral degree and at N = ``AXI_HESSIAN_N`` for the polyline.  Printed: the wall times of this run,
   the ratios, and the goal's PASS/MISS on the spectral answer with P and the verdict.

An untimed warm-up solve at small ``N`` runs first, so that loading the Ipopt
plugin is not billed to the first size.

Compiled element functions (``castrajectory.solve.jit``).  Families of at least
``nlp.JIT_MIN_ELEMENTS`` elements are compiled to machine code once per machine
and then loaded from a per-user disk cache.  A second untimed warm-up at that
size does any compiling before the timings; the script prints how many
libraries were compiled (and how long the warm-up took) and checks that no
compilation happened inside the timed runs.  ``--jit off`` measures CasADi's
virtual machine instead (the state before compilation was introduced).

BLAS threads: unless the caller already set them, ``OPENBLAS_NUM_THREADS``,
``OMP_NUM_THREADS`` and ``MKL_NUM_THREADS`` are set to 1 before numpy is
imported.  SLSQP's dense linear algebra goes through numpy/scipy's OpenBLAS;
on a machine whose cores are busy with other work, OpenBLAS worker threads
were measured to slow SLSQP at N = 160 down some 30-fold (about 1.3 s
single-threaded against about 40 s threaded), which would inflate the speed-up
ratios.  Ipopt's timings were not affected measurably.  Export the variables
yourself to benchmark another setting; the values in effect are printed.
Timings on a shared machine are noisy: compare numbers from one run only.

Usage::

    python scripts/bench_droplet.py
    python scripts/bench_droplet.py --sizes 1000 10000 --repeats 1
    python scripts/bench_droplet.py --slsqp-sizes 40 160 --json bench.json
"""
from __future__ import annotations

import argparse
import json
import math
import os
import platform
import sys
import time
from typing import Dict, List, Optional

#: Single-threaded BLAS unless the caller chose otherwise (see the module docstring); must precede numpy.
BLAS_THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
for _var in BLAS_THREAD_VARS:
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from castrajectory.solve import droplet as d  # noqa: E402
from castrajectory.solve import jit  # noqa: E402
from castrajectory.solve import nlp as nlp_mod  # noqa: E402

#: The benchmarked scene (partial wetting, Young's angle 60 degrees).
DROP = d.Droplet(gamma_gl=1.0, gamma_sl=0.5, gamma_sg=1.0, area=1.0)

#: Goals reported as PASS/MISS.
GOAL_MAX_ITER = 15
GOAL_N_TIME = 10_000
GOAL_TIME_S = 0.3
GOAL_MAX_EXPONENT = 1.15
GOAL_SPEEDUP_N = 160
GOAL_SPEEDUP = 1000.0

#: The axisymmetric section: the drop (θ = 90°, V = 1, l_c = 1), the height's target, the shooting's rtols
#: tried, and the size of the stability check.
AXI_DROP = d.Droplet(1.0, 1.0, 1.0, 1.0, None, 1.0, False, True)
AXI_TOL = 1e-8
AXI_RTOLS = (1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12)
AXI_HESSIAN_N = 100

#: SLSQP runs slower than this are not repeated.
SLSQP_REPEAT_LIMIT_S = 20.0


# ---------------------------------------------------------------------------- castrajectory
def run_castrajectory(n: int, formulation: str, repeats: int) -> Dict[str, object]:
    """Solve ``repeats`` times from scratch; keep the best times and the last run's readings."""
    builds, solves, sums, walls = [], [], [], []
    sol = None
    for _ in range(repeats):
        t = time.perf_counter()
        sol = d.solve(DROP, n, formulation)
        walls.append(time.perf_counter() - t)
        r = sol.result
        builds.append(r.build_time_s)
        solves.append(r.solve_time_s)
        sums.append(r.build_time_s + r.solve_time_s)
    return {
        "n": n,
        "build_s": min(builds),
        "solve_s": min(solves),
        "build_plus_solve_s": min(sums),
        "wall_s": min(walls),
        "iterations": sol.result.iterations,
        "status": sol.status,
        "success": bool(sol.success),
        "errors": dict(sol.errors),
        "energy": sol.energy,
        "_solution": sol,
    }


def loglog_slope(ns: List[int], ts: List[float]) -> Optional[float]:
    """Least-squares slope of ``log t`` against ``log n`` (None with fewer than two distinct sizes)."""
    if len(set(ns)) < 2:
        return None
    return float(np.polyfit(np.log(ns), np.log(ts), 1)[0])


# ---------------------------------------------------------------------------- SLSQP baseline
class SlsqpDroplet:
    """The ``Curve`` discretisation in scaled units with analytic first derivatives.

    ``z = (x_1..x_{n-1}, y_1..y_{n-1}, a)``; all derivatives are first taken with
    respect to the full vertex arrays ``X = x_0..x_n`` and ``Y = y_0..y_n`` and then
    restricted to the unknowns (interior ``X``, interior ``Y``, and ``X_n = a``).
    """

    def __init__(self, drop: d.Droplet, n: int):
        self.n = n
        self.w = drop.wetting / drop.gamma_gl
        guess = d.arc_points(0.5 * math.pi, math.sqrt(1.0 / d.segment_area_factor(0.5 * math.pi)), n)
        self.z0 = np.concatenate([guess[1:-1, 0], guess[1:-1, 1], [guess[-1, 0]]])
        seg0 = float(np.hypot(*np.diff(guess, axis=0).T).mean())
        self.eq_scale = 1.0 / (2.0 * seg0 ** 2)

    # -- unknowns <-> vertices
    def vertices(self, z):
        n = self.n
        X = np.empty(n + 1)
        Y = np.zeros(n + 1)
        X[0], X[1:n], X[n] = 0.0, z[:n - 1], z[-1]
        Y[1:n] = z[n - 1:2 * n - 2]
        return X, Y

    def restrict(self, gX, gY):
        """Derivatives w.r.t. X and Y (last axis has n + 1 entries) -> w.r.t. z."""
        n = self.n
        return np.concatenate([gX[..., 1:n], gY[..., 1:n], gX[..., n:n + 1]], axis=-1)

    # -- objective: sum of segment lengths + w a
    def energy(self, z):
        X, Y = self.vertices(z)
        return float(np.hypot(np.diff(X), np.diff(Y)).sum() + self.w * z[-1])

    def energy_grad(self, z):
        X, Y = self.vertices(z)
        dx, dy = np.diff(X), np.diff(Y)
        length = np.hypot(dx, dy)
        ux, uy = dx / length, dy / length
        gX = np.zeros(self.n + 1)
        gY = np.zeros(self.n + 1)
        gX[1:] += ux
        gX[:-1] -= ux
        gY[1:] += uy
        gY[:-1] -= uy
        g = self.restrict(gX, gY)
        g[-1] += self.w
        return g

    # -- equalities: equal consecutive squared segments, scaled as in Curve
    def equal_segments(self, z):
        X, Y = self.vertices(z)
        sq = np.diff(X) ** 2 + np.diff(Y) ** 2
        return self.eq_scale * (sq[1:] - sq[:-1])

    def equal_segments_jac(self, z):
        n = self.n
        X, Y = self.vertices(z)
        dx, dy = np.diff(X), np.diff(Y)
        rows = np.arange(n - 1)
        # row i: s_{i+1} - s_i, with d s_k / d X_k = -2 dx_k and d s_k / d X_{k+1} = +2 dx_k
        JX = np.zeros((n - 1, n + 1))
        JY = np.zeros((n - 1, n + 1))
        for J, dd in ((JX, dx), (JY, dy)):
            J[rows, rows] = 2.0 * dd[:-1]
            J[rows, rows + 1] = -2.0 * (dd[:-1] + dd[1:])
            J[rows, rows + 2] = 2.0 * dd[1:]
        return self.eq_scale * self.restrict(JX, JY)

    # -- equality: shoelace area (clockwise traversal, so positive) == 1
    def area(self, z):
        X, Y = self.vertices(z)
        return float(0.5 * np.sum(X[1:] * Y[:-1] - X[:-1] * Y[1:]))

    def area_residual(self, z):
        return np.array([self.area(z) - 1.0])

    def area_jac(self, z):
        X, Y = self.vertices(z)
        Xp, Yp = np.pad(X, 1), np.pad(Y, 1)
        gX = 0.5 * (Yp[:-2] - Yp[2:])    # d/dX_k = (Y_{k-1} - Y_{k+1}) / 2
        gY = 0.5 * (Xp[2:] - Xp[:-2])    # d/dY_k = (X_{k+1} - X_{k-1}) / 2
        return self.restrict(gX, gY)[None, :]

    def constraints(self):
        return [
            {"type": "eq", "fun": self.equal_segments, "jac": self.equal_segments_jac},
            {"type": "eq", "fun": self.area_residual, "jac": self.area_jac},
        ]

    def violation(self, z) -> float:
        return float(max(np.max(np.abs(self.equal_segments(z))), abs(self.area(z) - 1.0)))


def _central_jacobian(fun, z, h=1e-6):
    f0 = np.atleast_1d(fun(z))
    J = np.empty((f0.size, z.size))
    for k in range(z.size):
        e = np.zeros_like(z)
        e[k] = h
        J[:, k] = (np.atleast_1d(fun(z + e)) - np.atleast_1d(fun(z - e))) / (2.0 * h)
    return J


def check_slsqp_derivatives(n: int = 7, seed: int = 0) -> float:
    """Compare the analytic derivatives with central differences at a perturbed guess; assert agreement."""
    prob = SlsqpDroplet(DROP, n)
    rng = np.random.default_rng(seed)
    z = prob.z0 + 0.05 * rng.standard_normal(prob.z0.size)
    worst = 0.0
    for name, fun, jac in (("energy", prob.energy, lambda v: prob.energy_grad(v)[None, :]),
                           ("equal_segments", prob.equal_segments, prob.equal_segments_jac),
                           ("area", prob.area_residual, prob.area_jac)):
        exact, approx = np.atleast_2d(jac(z)), _central_jacobian(fun, z)
        err = float(np.max(np.abs(exact - approx)) / max(1.0, float(np.max(np.abs(approx)))))
        assert exact.shape == approx.shape, f"{name}: Jacobian shape {exact.shape} != {approx.shape}"
        assert err < 1e-6, f"{name}: analytic derivative disagrees with finite differences ({err:.2e})"
        worst = max(worst, err)
    return worst


def run_slsqp(n: int, repeats: int) -> Dict[str, object]:
    from scipy.optimize import minimize

    prob = SlsqpDroplet(DROP, n)
    times, res = [], None
    for _ in range(repeats):
        t = time.perf_counter()
        res = minimize(prob.energy, prob.z0, jac=prob.energy_grad, method="SLSQP",
                       constraints=prob.constraints(), options={"maxiter": 2000, "ftol": 1e-10})
        times.append(time.perf_counter() - t)
        if times[-1] > SLSQP_REPEAT_LIMIT_S:
            break
    cap = d.analytic(DROP)
    scale = DROP.gamma_gl * DROP.length_scale
    energy = scale * float(res.fun)
    X, Y = prob.vertices(res.x)
    return {
        "n": n,
        "time_s": min(times),
        "runs": len(times),
        "success": bool(res.success),
        "message": str(res.message),
        "nit": int(res.nit),
        "energy": energy,
        "energy_error": abs(energy - cap.energy) / abs(cap.energy),
        "constraint_violation": prob.violation(res.x),
        "_xy": (X, Y),
    }


# ---------------------------------------------------------------------------- the axisymmetric drop
def shoot_scipy(drop: d.Droplet, rtol: float) -> Dict[str, float]:
    """The sessile drop of revolution by shooting with scipy (units of l_c, z down from the apex):
    ``r' = cos φ, z' = sin φ, φ' = 2κ + z − sin φ / r`` (``κ`` on the axis), ``V' = π r² sin φ``;
    ``solve_ivp`` (DOP853, rtol, atol = rtol/100) to the event φ = θ, ``brentq`` on κ for the volume."""
    from scipy.integrate import solve_ivp
    from scipy.optimize import brentq

    theta = d.young_angle(drop.gamma_gl, drop.gamma_sl, drop.gamma_sg)
    lc = drop.capillary_length
    volume = drop.area / lc ** 3

    def rhs(s, q, k):
        r, z, phi = q[0], q[1], q[2]
        sn = math.sin(phi)
        return [math.cos(phi), sn, k if r <= 0.0 else 2.0 * k + z - sn / r, math.pi * r * r * sn]

    def contact(s, q, k):
        return q[2] - theta
    contact.terminal, contact.direction = True, 1

    def shoot(k):
        sol = solve_ivp(rhs, (0.0, 100.0 / k), [0.0, 0.0, 0.0, 0.0], method="DOP853", rtol=rtol,
                        atol=1e-2 * rtol, events=contact, args=(k,))
        return sol.y_events[0][0]

    c = math.cos(theta)  # the weightless cap's curvature k0 (gravity lowers it): bracket [k0 / 5, 2 k0]
    k0 = (math.pi * (2.0 - 3.0 * c + c ** 3) / 3.0 / volume) ** (1.0 / 3.0)
    k = brentq(lambda k: shoot(k)[3] - volume, 0.2 * k0, 2.0 * k0, xtol=1e-15, rtol=1e-15)
    r, z, _, _ = shoot(k)
    return {"height": z * lc, "contact_radius": r * lc, "apex_curvature": k / lc}


def _best(fn, repeats: int):
    best, out = math.inf, None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def run_axisymmetric(repeats: int) -> Dict[str, object]:
    """Section 3 (see the module docstring): the NLP and scipy's shooting to the height at AXI_TOL."""
    from castrajectory.solve.second_order import reduced_hessian

    drop, cap = AXI_DROP, d.analytic(AXI_DROP)
    h_ref = cap.height
    check = shoot_scipy(drop, 1e-12)["height"]
    out = {"height_reference": h_ref, "scipy_rtol_1e-12_vs_reference": abs(check - h_ref) / h_ref}
    # the shooting: the loosest rtol that meets the target, timed
    shooting = None
    for rtol in AXI_RTOLS:
        t, r = _best(lambda: shoot_scipy(drop, rtol), repeats)
        err = abs(r["height"] - h_ref) / h_ref
        if err <= AXI_TOL:
            shooting = {"rtol": rtol, "time_s": t, "height": r["height"], "error": err}
            break
    out["shooting"] = shooting

    def nlp_height(n):  # droplet.solve as a user calls it (from N = 2000 a presolve on 200; its error estimate)
        t, sol = _best(lambda: d.solve(drop, n, compare=False), repeats)
        return t, sol, {"height": sol.height, "pressure": sol.pressure}

    fit = {}
    for n in (200, 400):
        _, _, r = nlp_height(n)
        fit[n] = (r["height"] - h_ref) / h_ref * n * n  # = a + b ln N
    b = (fit[400] - fit[200]) / math.log(2.0)
    a = fit[200] - b * math.log(200.0)
    n = 400
    while abs(a + b * math.log(n)) / n ** 2 > AXI_TOL:
        n = int(n * 1.1)
    nlp_rows = []
    while True:
        t, res, r = nlp_height(n)
        err = abs(r["height"] - h_ref) / h_ref
        nlp_rows.append({"n": n, "time_s": t, "iterations": res.iterations, "status": res.status, "error": err,
                         "pressure": r["pressure"], "success": bool(res.success)})
        if err <= AXI_TOL or not res.success or n > 1_000_000:
            break
        n *= 2
    out.update(fit_a=a, fit_b=b, nlp=nlp_rows)
    # the spectral profile (its tangent angle, a polynomial): the lowest even degree that meets the target,
    # as a user calls it (with its error estimate, a second solve at 3/4 of the degree), and its verdict
    spectral_rows = []
    for p in range(6, 66, 2):
        cold = time.perf_counter()  # the first solve at this degree forms its element derivatives
        d.solve(drop, p, "spectral", compare=False, estimate=False)
        cold = time.perf_counter() - cold
        t, sol = _best(lambda: d.solve(drop, p, "spectral", compare=False, estimate=False), repeats)
        t_est, sol_est = _best(lambda: d.solve(drop, p, "spectral", compare=False), repeats)
        err = abs(sol.height - h_ref) / h_ref
        spectral_rows.append({"n": p, "time_s": t, "cold_s": cold, "with_estimate_s": t_est,
                              "iterations": sol.iterations, "status": sol.status, "error": err,
                              "pressure": sol.pressure, "success": bool(sol.success),
                              "estimate": sol_est.error_estimate.relative if sol_est.error_estimate else None})
        if err <= AXI_TOL or not sol.success:
            break
    out["spectral"] = spectral_rows
    nlp_s = d.make_nlp(drop, spectral_rows[-1]["n"], "spectral")[0]
    res_s = nlp_s.solve(options={**d.SOLVER_OPTIONS, **d.SPECTRAL_OPTIONS})
    t_s, hess_s = _best(lambda: reduced_hessian(nlp_s, res_s), repeats)
    out["spectral_stability"] = {"n": spectral_rows[-1]["n"], "time_s": t_s,
                                 "positive_definite": hess_s.positive_definite, "min_eigenvalue": hess_s.min_eigenvalue}
    nlp_h = d.make_nlp(drop, AXI_HESSIAN_N)[0]
    res_h = nlp_h.solve(options=d.SOLVER_OPTIONS)
    t_h, hess = _best(lambda: reduced_hessian(nlp_h, res_h), 1)
    out["stability"] = {"n": AXI_HESSIAN_N, "time_s": t_h, "positive_definite": hess.positive_definite,
                        "min_eigenvalue": hess.min_eigenvalue}
    return out


def print_axisymmetric(ax: Dict[str, object], floor: Dict[str, float]) -> tuple:
    """Print section 3; return its goal ``(text, ok, detail)``."""
    s, last, st = ax["shooting"], ax["nlp"][-1], ax["stability"]
    print(f"   reference h = {ax['height_reference']:.12f} (model's RK4 shooting); scipy DOP853 at rtol 1e-12 "
          f"agrees to {ax['scipy_rtol_1e-12_vs_reference']:.1e} (relative)")
    if s is None:
        print("   scipy shooting did not reach the target at any rtol tried")
    else:
        print(f"   scipy shooting (solve_ivp DOP853 + event φ = θ, brentq on κ): rtol {s['rtol']:g}, height error "
              f"{s['error']:.2e}, {s['time_s'] * 1e3:.2f} ms (height, contact radius, apex curvature only)")
    print(f"   NLP apex height error fit (N = 200, 400): e N² = {ax['fit_a']:.4f} + {ax['fit_b']:.4f} ln N")
    for r in ax["nlp"]:
        print(f"   NLP N = {r['n']:>6}: {r['status']}, {r['iterations']} iterations, height error {r['error']:.2e}, "
              f"{r['time_s'] * 1e3:.1f} ms (with the pressure at the table P = {r['pressure']:.10f})")
    print(f"   stability verdict (reduced Hessian, dense) at N = {st['n']}: "
          f"{'positive definite' if st['positive_definite'] else 'indefinite'} (λ_min {st['min_eigenvalue']:.3e}), "
          f"{st['time_s'] * 1e3:.1f} ms")
    if s is not None and last["success"] and last["error"] <= AXI_TOL:
        print(f"   polyline: {last['time_s'] * 1e3:.1f} ms at N = {last['n']} + verdict {st['time_s'] * 1e3:.1f} ms (at N = "
              f"{st['n']}) = {(last['time_s'] + st['time_s']) / s['time_s']:.1f}x the shooting: its order 2 (and the "
              f"apex's log) is what the spectral profile removes")
    for r in ax["spectral"]:
        est = "none" if r["estimate"] is None else f"{r['estimate']:.1e}"
        print(f"   spectral degree {r['n']:>3}: {r['status']}, {r['iterations']} iterations, height error {r['error']:.2e}, "
              f"{r['time_s'] * 1e3:.2f} ms (first call at this degree {r['cold_s'] * 1e3:.1f} ms; with the error "
              f"estimate, {est}, {r['with_estimate_s'] * 1e3:.2f} ms) (P = {r['pressure']:.12f})")
    sp, sst = ax["spectral"][-1], ax["spectral_stability"]
    print(f"   spectral stability verdict at degree {sst['n']}: "
          f"{'positive definite' if sst['positive_definite'] else 'indefinite'} (λ_min {sst['min_eigenvalue']:.3e}), "
          f"{sst['time_s'] * 1e3:.2f} ms")
    text = f"axisymmetric sessile drop: height to {AXI_TOL:g} (relative) faster than scipy's shooting, with P and the verdict"
    if s is None or not sp["success"] or sp["error"] > AXI_TOL:
        return text, None, "not comparable: " + ("the shooting missed" if s is None else "the NLP missed the target")
    nlp_t = sp["time_s"] + sst["time_s"]
    ratio = nlp_t / s["time_s"]
    print(f"   wall times in this run: spectral NLP {sp['time_s'] * 1e3:.2f} ms (the answer and P) + verdict "
          f"{sst['time_s'] * 1e3:.2f} ms = {nlp_t * 1e3:.2f} ms; shooting {s['time_s'] * 1e3:.2f} ms; ratio NLP / shooting "
          f"= {ratio:.2f}; with the error estimate too (a second solve at 3/4 of the degree) "
          f"{(sp['with_estimate_s'] + sst['time_s']) / s['time_s']:.2f}; the first call at the degree "
          f"{(sp['cold_s'] + sst['time_s']) / s['time_s']:.2f}")
    ok = ratio < 1.0
    if not ok:
        print(f"   ceiling: Ipopt's fixed cost alone is {floor['time_s'] * 1e3:.2f} ms ({floor['iterations']} iterations) "
              f"per solve, {floor['time_s'] / s['time_s']:.2f} of the shooting's time")
    return text, ok, (f"spectral NLP {nlp_t * 1e3:.2f} ms (degree {sp['n']}, the answer, P and the verdict) vs "
                      f"shooting {s['time_s'] * 1e3:.2f} ms: ratio {ratio:.2f}")


# ---------------------------------------------------------------------------- reporting
def ipopt_floor(repeats: int) -> Dict[str, float]:
    """Ipopt's fixed cost per solve: a 2-variable problem with the droplet's Ipopt options.

    ``min (x - 1)^4 + (y - 2)^2  s.t.  x + y = 1`` takes a handful of Newton iterations
    whose linear algebra and function evaluations cost nothing; what remains is what any
    Ipopt solve through CasADi pays (application set-up, MUMPS initialisation, the
    per-iteration bookkeeping).  It bounds the speed-up over SLSQP that any Ipopt-based
    solver could reach on this machine.
    """
    import casadi as ca
    x = ca.SX.sym("x", 2)
    opts = dict(nlp_mod.DEFAULT_IPOPT_OPTIONS)
    opts.update(d.SOLVER_OPTIONS)
    opts.update(print_level=0, sb="yes")
    solver = ca.nlpsol("floor", "ipopt", {"x": x, "f": (x[0] - 1) ** 4 + (x[1] - 2) ** 2, "g": x[0] + x[1]},
                       {"ipopt": opts, "print_time": False})
    best, iters = math.inf, 0
    for _ in range(max(5, repeats)):
        t0 = time.perf_counter()
        solver(x0=[0.0, 0.0], lbg=1.0, ubg=1.0)
        best = min(best, time.perf_counter() - t0)
        iters = int(solver.stats()["iter_count"])
    return {"time_s": best, "iterations": iters}


def goal_line(ok: Optional[bool], text: str, detail: str) -> str:
    tag = "SKIP" if ok is None else ("PASS" if ok else "MISS")
    return f"  {tag}  {text}: {detail}"


def fmt_s(t: float) -> str:
    return f"{t:9.4f}"


def _positive_int(s: str) -> int:
    try:
        v = int(s)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {s!r}") from None
    if v < d.MIN_N:
        raise argparse.ArgumentTypeError(f"N must be at least {d.MIN_N}, got {v}")
    return v


def _repeats(s: str) -> int:
    try:
        v = int(s)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {s!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"repeats must be at least 1, got {v}")
    return v


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sizes", type=_positive_int, nargs="+", default=[1000, 10000, 100000],
                   help="segment counts N for the scaling study (default: 1000 10000 100000)")
    p.add_argument("--slsqp-sizes", type=_positive_int, nargs="*", default=[40, 160],
                   help="segment counts N for the SLSQP comparison (default: 40 160; none to skip)")
    p.add_argument("--repeats", type=_repeats, default=3, help="runs per measurement; best time kept (default 3)")
    p.add_argument("--formulation", choices=("curve", "graph"), default="curve",
                   help="droplet discretisation (default curve; the SLSQP baseline always poses the curve)")
    p.add_argument("--jit", choices=("on", "off"), default="on",
                   help="compiled element functions (default on; off: CasADi's virtual machine)")
    p.add_argument("--no-axisymmetric", action="store_true",
                   help="skip section 3, the axisymmetric sessile drop against scipy's shooting")
    p.add_argument("--json", metavar="PATH", help="also write all numbers as JSON to PATH")
    return p.parse_args(argv)


def main(argv=None) -> int:
    args = parse_args(argv)
    sizes = sorted(set(args.sizes))
    slsqp_sizes = sorted(set(args.slsqp_sizes))
    cap = d.analytic(DROP)
    import casadi
    try:
        import scipy
    except ImportError:  # the SLSQP baseline and the shooting need scipy (the optional extra "bench")
        scipy = None

    env = {"python": platform.python_version(), "platform": platform.platform(),
           "casadi": casadi.__version__, "numpy": np.__version__,
           "cpus": os.cpu_count()}
    env["scipy"] = None if scipy is None else scipy.__version__
    env.update({v: os.environ.get(v) for v in BLAS_THREAD_VARS})
    print("castrajectory droplet benchmark")
    print(f"  drop: gamma_gl={DROP.gamma_gl:g} gamma_sl={DROP.gamma_sl:g} gamma_sg={DROP.gamma_sg:g} "
          f"area={DROP.area:g}  (Young's angle {math.degrees(cap.contact_angle):.4g} deg, "
          f"analytic energy {cap.energy:.12g})")
    print(f"  formulation={args.formulation}  repeats={args.repeats} (best time kept)")
    print("  " + "  ".join(f"{k} {env[k]}" for k in ("python", "casadi", "numpy", "scipy", "cpus")))
    print("  " + "  ".join(f"{v}={env[v]}" for v in BLAS_THREAD_VARS) + "  (1 unless set by the caller)")
    print(f"  {env['platform']}")

    nlp_mod.JIT = args.jit == "on"
    d.solve(DROP, 20, args.formulation)  # warm-up: load the Ipopt plugin outside the timings

    def compile_element_code():  # untimed: compile (or load) the element code of every timed formulation
        for form in {args.formulation, "curve" if slsqp_sizes else args.formulation}:
            d.solve(DROP, nlp_mod.JIT_MIN_ELEMENTS, form)

    env["jit"], line = jit.warm_up(compile_element_code, nlp_mod.JIT)
    jit_before = dict(jit.stats)
    print("  " + line)

    # -------------------------------------------------------------- 1. scaling
    print()
    print(f"1. Scaling of droplet.solve(drop, N, {args.formulation!r}), fresh build every run; times in seconds")
    head = (f"  {'N':>8} {'build':>9} {'solve':>9} {'build+solve':>11} {'wall':>9} {'iter':>5}  "
            f"{'status':<24} {'shape err':>9}")
    print(head)
    print("  " + "-" * (len(head) - 2))
    scaling = []
    for n in sizes:
        r = run_castrajectory(n, args.formulation, args.repeats)
        r.pop("_solution")
        scaling.append(r)
        print(f"  {n:>8} {fmt_s(r['build_s'])} {fmt_s(r['solve_s'])} {r['build_plus_solve_s']:11.4f} "
              f"{fmt_s(r['wall_s'])} {r['iterations']:>5}  {r['status']:<24} {r['errors']['shape']:9.2e}",
              flush=True)

    ratios = []
    if len(scaling) > 1:
        print()
        print("  consecutive sizes (build+solve):")
        print(f"  {'N1 -> N2':>18} {'N ratio':>8} {'t ratio':>8} {'(t/N) ratio':>11} {'local exponent':>15}")
        for a, b in zip(scaling, scaling[1:]):
            nr = b["n"] / a["n"]
            tr = b["build_plus_solve_s"] / a["build_plus_solve_s"]
            ratios.append({"n1": a["n"], "n2": b["n"], "n_ratio": nr, "time_ratio": tr,
                           "time_per_n_ratio": tr / nr, "local_exponent": math.log(tr) / math.log(nr)})
            print(f"  {str(a['n']) + ' -> ' + str(b['n']):>18} {nr:8.2f} {tr:8.2f} {tr / nr:11.3f} "
                  f"{math.log(tr) / math.log(nr):15.3f}")
    slope = loglog_slope([r["n"] for r in scaling], [r["build_plus_solve_s"] for r in scaling])
    print()
    print("  growth exponent (least-squares slope of log(build+solve) vs log N; linear = 1): "
          + ("n/a (needs two sizes)" if slope is None else f"{slope:.3f}"))

    goals = []
    print()
    print("  goals:")
    max_iter = max(r["iterations"] for r in scaling)
    ok = max_iter <= GOAL_MAX_ITER and all(r["success"] for r in scaling)
    detail = f"max {max_iter} iterations over N = {', '.join(str(r['n']) for r in scaling)}"
    if not all(r["success"] for r in scaling):
        detail += "; some solves failed: " + ", ".join(f"N={r['n']} {r['status']}" for r in scaling if not r["success"])
    goals.append(("iterations <= 15 at every N", ok, detail))
    at = [r for r in scaling if r["n"] == GOAL_N_TIME]
    goals.append((f"build+solve at N = {GOAL_N_TIME} < {GOAL_TIME_S} s",
                  None if not at else at[0]["build_plus_solve_s"] < GOAL_TIME_S,
                  f"N = {GOAL_N_TIME} not in --sizes" if not at else f"{at[0]['build_plus_solve_s']:.4f} s"))
    goals.append((f"growth exponent <= {GOAL_MAX_EXPONENT}", None if slope is None else slope <= GOAL_MAX_EXPONENT,
                  "needs two sizes" if slope is None else f"{slope:.3f}"))
    for text, ok, detail in goals:
        print(goal_line(ok, text, detail))

    # -------------------------------------------------------------- 2. SLSQP baseline
    comparison = []
    fd_err = None
    if slsqp_sizes and scipy is None:
        print()
        print("2. SLSQP baseline: SKIP (scipy is not installed; pip install castrajectory[bench])")
    if slsqp_sizes and scipy is not None:
        print()
        print("2. SLSQP baseline (scipy.optimize.minimize, method='SLSQP', maxiter=2000, ftol=1e-10)")
        print("   same curve discretisation, scaled units, analytic gradient and Jacobians, half-disc guess")
        fd_err = check_slsqp_derivatives()
        print(f"   derivative check vs central differences at N=7: max relative difference {fd_err:.1e} (OK)")
        head = (f"  {'N':>5} {'SLSQP s':>9} {'runs':>4} {'ok':>3} {'nit':>5} {'viol':>8} {'E err':>9} "
                f"{'|dx| vs cas':>11} | {'cas solve':>9} {'cas b+s':>9} {'cas E err':>9} | "
                f"{'SLSQP/solve':>11} {'SLSQP/(b+s)':>11}")
        print(head)
        print("  " + "-" * (len(head) - 2))
        for n in slsqp_sizes:
            s = run_slsqp(n, args.repeats)
            c = run_castrajectory(n, "curve", args.repeats)
            sol = c.pop("_solution")
            X, Y = s.pop("_xy")
            L = DROP.length_scale
            dist = float(np.max(np.hypot(X - sol.x / L, Y - sol.y / L)))
            row = {"n": n, "slsqp": s, "castrajectory": c, "max_vertex_distance": dist,
                   "ratio_vs_solve": s["time_s"] / c["solve_s"],
                   "ratio_vs_build_plus_solve": s["time_s"] / c["build_plus_solve_s"]}
            comparison.append(row)
            print(f"  {n:>5} {fmt_s(s['time_s'])} {s['runs']:>4} {'yes' if s['success'] else 'NO':>3} "
                  f"{s['nit']:>5} {s['constraint_violation']:8.1e} {s['energy_error']:9.2e} {dist:11.2e} | "
                  f"{fmt_s(c['solve_s'])} {fmt_s(c['build_plus_solve_s'])} {c['errors']['energy']:9.2e} | "
                  f"{row['ratio_vs_solve']:10.0f}x {row['ratio_vs_build_plus_solve']:10.0f}x", flush=True)
            if not s["success"]:
                print(f"        SLSQP failed: {s['message']}")
            if not c["success"]:
                print(f"        castrajectory failed: {c['status']}")
        print("   E err: |E - E_analytic| / E_analytic (discretisation error, O(1/N²), the same for both if both converge);")
        print("   |dx| vs cas: largest vertex distance between the SLSQP and castrajectory solutions;")
        print("   ratios: SLSQP wall time / castrajectory solve time, and / castrajectory build+solve time.")
        print()
        print("  goals:")
        at = [r for r in comparison if r["n"] == GOAL_SPEEDUP_N]
        for key, label in (("ratio_vs_solve", "SLSQP time / castrajectory solve time"),
                           ("ratio_vs_build_plus_solve", "SLSQP time / castrajectory build+solve time")):
            text = f">= {GOAL_SPEEDUP:g}x faster than SLSQP at N = {GOAL_SPEEDUP_N} ({label})"
            if not at:
                ok, detail = None, f"N = {GOAL_SPEEDUP_N} not in --slsqp-sizes"
            elif not at[0]["slsqp"]["success"]:
                ok, detail = None, f"{at[0][key]:.0f}x, not comparable: SLSQP failed: {at[0]['slsqp']['message']}"
            elif not at[0]["castrajectory"]["success"]:
                ok, detail = None, f"{at[0][key]:.0f}x, not comparable: castrajectory failed"
            else:
                ok, detail = at[0][key] >= GOAL_SPEEDUP, f"{at[0][key]:.0f}x"
            goals.append((text, ok, detail))
            print(goal_line(ok, text, detail))
        floor = ipopt_floor(args.repeats)
        if at and at[0]["slsqp"]["success"]:
            it = at[0]["castrajectory"]["iterations"]
            print(f"  evidence: Ipopt's fixed cost here, 2-variable problem with the same options: "
                  f"{floor['time_s'] * 1e3:.2f} ms for {floor['iterations']} iterations "
                  f"(castrajectory at N = {GOAL_SPEEDUP_N}: {it} iterations, solve "
                  f"{at[0]['castrajectory']['solve_s'] * 1e3:.2f} ms).")
            scaled = floor["time_s"] * it / max(floor["iterations"], 1)
            print(f"            Ceiling for any Ipopt solve at N = {GOAL_SPEEDUP_N} on this machine: SLSQP "
                  f"{at[0]['slsqp']['time_s']:.3f} s / that floor = {at[0]['slsqp']['time_s'] / floor['time_s']:.0f}x; "
                  f"with the floor scaled to {it} iterations ({scaled * 1e3:.2f} ms): "
                  f"{at[0]['slsqp']['time_s'] / scaled:.0f}x.")
        comparison.append({"ipopt_floor": floor})

    # -------------------------------------------------------------- 3. the axisymmetric drop
    axi = None
    if not args.no_axisymmetric:
        print()
        print(f"3. Axisymmetric sessile drop (θ = 90°, V = 1 l_c³): the height to {AXI_TOL:g} relative, "
              "NLP against scipy's Young–Laplace shooting")
        if scipy is None:
            print("   SKIP: scipy is not installed (pip install castrajectory[bench]); the shooting needs it")
        else:
            axi = run_axisymmetric(args.repeats)
            floor = ipopt_floor(args.repeats)
            axi["ipopt_floor"] = floor
            text, ok, detail = print_axisymmetric(axi, floor)
            goals.append((text, ok, detail))
            print()
            print("  goals:")
            print(goal_line(ok, text, detail))

    compiled_in_timed = jit.stats["compiled"] - jit_before["compiled"]
    print()
    print(f"  compilations inside the timed runs: {compiled_in_timed}"
          + ("" if not compiled_in_timed else "  (their cost is included in the build times above)"))
    if args.json:
        out = {"environment": env, "drop": {"gamma_gl": DROP.gamma_gl, "gamma_sl": DROP.gamma_sl,
                                            "gamma_sg": DROP.gamma_sg, "area": DROP.area},
               "analytic": cap.as_dict(), "formulation": args.formulation, "repeats": args.repeats,
               "scaling": scaling, "consecutive": ratios, "growth_exponent": slope,
               "slsqp_derivative_check": fd_err, "slsqp_comparison": comparison, "axisymmetric": axi,
               "goals": [{"goal": t, "result": "SKIP" if ok is None else ("PASS" if ok else "MISS"),
                          "detail": det} for t, ok, det in goals]}
        with open(args.json, "w") as fh:
            json.dump(out, fh, indent=2)
        print()
        print(f"JSON written to {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
