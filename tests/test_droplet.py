"""Tests of the droplet model against independent oracles (see helpers.py):
circle fits, Young's angle, cap formulas, KKT/sensitivity (pressure = dE*/dA),
observed convergence orders, scaling invariance and input validation."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from castrajectory.solve import droplet as dl
from castrajectory.models.droplet import Droplet
from castrajectory.validation import InputError

from helpers import (
    cap_area,
    circle_points,
    droplet_errors,
    fit_circle,
    free_cap,
    observed_order,
    pinned_cap,
    tensions_for_angle,
    young_angle,
)

ERROR_KEYS = ("shape", "contact_angle", "span", "energy", "pressure")


def free_drop(deg, g_gl=1.0, area=1.0, g_sl=0.3):
    return Droplet(*tensions_for_angle(math.radians(deg), g_gl, g_sl), area=area)


def oracle(drop: Droplet):
    if drop.span is None:
        return free_cap(drop.gamma_gl, drop.gamma_sl, drop.gamma_sg, drop.area)
    return pinned_cap(drop.gamma_gl, drop.gamma_sl, drop.gamma_sg, drop.area, drop.span)


def fd_pressure(drop: Droplet, n: int, form: str, eps: float = 1e-4) -> float:
    """dE*/dA of the *discrete* optimum by a central difference in the area."""
    plus = dl.solve(dataclasses.replace(drop, area=drop.area * (1 + eps)), n, form)
    minus = dl.solve(dataclasses.replace(drop, area=drop.area * (1 - eps)), n, form)
    assert plus.success and minus.success
    return (plus.energy - minus.energy) / (2 * eps * drop.area)


# ----------------------------------------------------------------------------- fixed span
# (formulation, gamma_gl, area, span); the arc's half-angle follows from area/span².
PINNED = [
    ("curve", 1.3, 2.0, 3.0),    # ~63.7 deg
    ("curve", 1.3, 2.0, 2.0),    # ~100.5 deg (overhang)
    ("curve", 0.7, 2.0, 1.6),    # ~117.5 deg
    ("curve", 2.0, 0.5, 2.0),    # ~40.1 deg
    ("graph", 1.3, 2.0, 3.0),
    ("graph", 2.0, 0.5, 4.0),    # ~10.7 deg, flat
    ("graph", 1.0, 1.0, 2.0),    # ~71.0 deg
]


@pytest.mark.parametrize("form, g, area, span", PINNED)
def test_fixed_span_is_circular_arc(form, g, area, span):
    drop = Droplet(gamma_gl=g, gamma_sl=0.2, gamma_sg=0.5, area=area, span=span)
    cap = oracle(drop)
    n = 200
    sol = dl.solve(drop, n, form)
    assert sol.success and sol.result.iterations <= 15
    assert sol.young_residual is None
    # contact points pinned
    assert (sol.x[0], sol.y[0]) == pytest.approx((0.0, 0.0), abs=1e-12)
    assert (sol.x[-1], sol.y[-1]) == pytest.approx((span, 0.0), abs=1e-12)
    assert sol.span == pytest.approx(span, rel=1e-12)
    # independent circle fit through all vertices
    circ = fit_circle(sol.x, sol.y)
    h = 1.0 / n ** 2
    # (measured constants err*N²: radius <= 1.3, centre height <= 2.5, off-circle <= 0.41)
    assert abs(circ.r - cap.radius) / cap.radius < 4 * h
    assert abs(circ.cx - 0.5 * span) / cap.radius < 1e-9          # symmetric
    assert abs(circ.cy - (-cap.radius * math.cos(cap.theta))) / cap.radius < 4 * h
    assert np.max(np.abs(circ.distance(sol.x, sol.y))) / cap.radius < 1 * h
    # the polygon encloses the requested area (shoelace, computed here)
    shoelace = 0.5 * abs(np.dot(sol.x, np.roll(sol.y, -1)) - np.dot(sol.y, np.roll(sol.x, -1)))
    assert shoelace == pytest.approx(area, rel=1e-8)
    # pressure = gamma/R within discretisation error; energy and contact angle too
    err = droplet_errors(sol, cap)
    assert err["pressure"] < 4 * h
    assert err["energy"] < 2 * h
    assert err["contact_angle"] < 4 * h
    assert err["shape"] < 4 * h
    # library's own error report agrees with the independent oracle
    for k in ("shape", "contact_angle", "energy", "pressure"):
        assert sol.errors[k] == pytest.approx(err[k], rel=1e-6, abs=1e-13), k


@pytest.mark.parametrize("form, g, area, span", PINNED)
def test_fixed_span_pressure_is_energy_sensitivity(form, g, area, span):
    """KKT/sensitivity oracle: area multiplier = dE*/dA of the discrete optimum."""
    drop = Droplet(gamma_gl=g, gamma_sl=0.2, gamma_sg=0.5, area=area, span=span)
    n = 100
    sol = dl.solve(drop, n, form)
    assert sol.success
    assert sol.pressure == pytest.approx(fd_pressure(drop, n, form), rel=1e-6)


# Regression: with Ipopt's default least-squares estimate of the initial
# constraint multipliers these cases needed O(N) iterations, hit max_iter or
# diverged; droplet.SOLVER_OPTIONS starts from zero multipliers instead.  The
# sweeps cap max_iter at 40 (about 3x a healthy solve) to stay fast.
def test_pinned_balloon_converges_through_the_coarse_ladder():
    """A pinned balloon (span 0.6, area 2: an arc of about 160°) does not converge from the
    half-ellipse guess at N = 200; the coarse-to-fine fallback (40 -> 80 -> 160 -> 200) does,
    and the reported iterations count every solve."""
    drop = Droplet(gamma_gl=1.3, gamma_sl=0.2, gamma_sg=0.5, area=2.0, span=0.6)
    direct, _, _ = dl.make_nlp(drop, 200, "curve")
    assert not direct.solve(options={**dl.SOLVER_OPTIONS, "max_iter": 40}).success
    sol = dl.solve(drop, 200, "curve", options={"max_iter": 40})
    assert sol.success and sol.errors["shape"] < 1e-3
    assert sol.result.iterations > dl.FIRST_ATTEMPT_MAX_ITER  # the failed first attempt is counted
    # second order: the pinned arc error at N = 400 is about a quarter of that at N = 200
    sol2 = dl.solve(drop, 400, "curve")
    assert sol2.success and 3.0 < sol.errors["shape"] / sol2.errors["shape"] < 5.0


def test_large_n_starts_from_a_coarse_solve(monkeypatch):
    """From PRESOLVE_MIN_N segments on, the curve solve starts from a coarse solve (PRESOLVE_N
    segments, resampled); its iterations are part of the reported count."""
    built = []
    make_nlp = dl.make_nlp

    def spy(drop, n, formulation="curve", guess=None):
        built.append((n, guess is not None))
        return make_nlp(drop, n, formulation, guess)

    monkeypatch.setattr(dl, "make_nlp", spy)
    drop = free_drop(60)
    sol = dl.solve(drop, dl.PRESOLVE_MIN_N)
    # (then the error estimate's grids, N/4 and N/2, from the answer resampled)
    assert built == [(dl.PRESOLVE_N, False), (dl.PRESOLVE_MIN_N, True), (dl.PRESOLVE_MIN_N // 4, True),
                     (dl.PRESOLVE_MIN_N // 2, True)]
    assert sol.success and sol.result.iterations <= 15
    assert droplet_errors(sol, oracle(drop))["shape"] < 1.0 / dl.PRESOLVE_MIN_N ** 2
    built.clear()
    dl.solve(drop, dl.PRESOLVE_MIN_N - 1)
    assert built == [(dl.PRESOLVE_MIN_N - 1, False), ((dl.PRESOLVE_MIN_N - 1) // 4, True),
                     ((dl.PRESOLVE_MIN_N - 1) // 2, True)]


def test_pinned_balloon_at_large_n():
    """The pinned balloon of the ladder test at N = 2000: from the coarse solve it converges in
    about a second (from the half-ellipse guess, the direct attempt and the ladder gave no result
    within 300 s when measured)."""
    drop = Droplet(gamma_gl=1.3, gamma_sl=0.2, gamma_sg=0.5, area=2.0, span=0.6)
    sol = dl.solve(drop, 2000, "curve")
    assert sol.success and droplet_errors(sol, oracle(drop))["shape"] < 4e-6


def test_fixed_span_curve_sweep_converges():
    bad = []
    for span, area in [(4.0, 0.5), (3.0, 0.5), (2.5, 0.5), (1.0, 2.0)]:
        drop = Droplet(gamma_gl=1.3, gamma_sl=0.2, gamma_sg=0.5, area=area, span=span)
        for n in (100, 200):
            sol = dl.solve(drop, n, "curve", options={"max_iter": 40})
            if not (sol.success and sol.result.iterations <= 15):
                bad.append((span, area, n, sol.result.status, sol.result.iterations))
    assert not bad, bad


def test_free_span_graph_small_angle_sweep_converges():
    bad = []
    for deg in range(4, 33, 4):
        drop = free_drop(deg)
        for n in (100, 150, 200):
            sol = dl.solve(drop, n, "graph", options={"max_iter": 40})
            if not (sol.success and sol.result.iterations <= 15):
                bad.append((deg, n, sol.result.status, sol.result.iterations))
    assert not bad, bad


@pytest.mark.parametrize("form, drop, n", [
    ("curve", Droplet(1.3, 0.2, 0.5, 2.0, span=1.0), 400),
    ("curve", Droplet(1.3, 0.2, 0.5, 0.5, span=3.0), 800),
    ("graph", Droplet(*tensions_for_angle(math.radians(20), 1.0, 0.3)), 100),
], ids=["curve-pinned-142deg", "curve-pinned-19deg", "graph-free-20deg"])
def test_zero_initial_multipliers_workaround(form, drop, n):
    """The cases of the bug converge quickly and correctly once Ipopt starts from zero multipliers,
    i.e. the model itself is fine."""
    sol = dl.solve(drop, n, form, options={"constr_mult_init_max": 0.0})
    assert sol.success and sol.result.iterations <= 15
    err = droplet_errors(sol, oracle(drop))
    assert err["shape"] < 4.0 / n ** 2 and err["pressure"] < 4.0 / n ** 2


# ----------------------------------------------------------------------------- free span
CURVE_ANGLES = [2, 30, 60, 90, 120, 150, 178]
GRAPH_ANGLES = [2, 30, 60, 88]
FREE_CASES = [("curve", a) for a in CURVE_ANGLES] + [("graph", a) for a in GRAPH_ANGLES]

# Errors at N = 400 are ~C/N² with C <= 4 (bound 2.5e-5) except where the
# asymptotic regime starts late (measured; see test_graph_near_90_reaches_second_order):
#   curve 178 deg: the span is 2 R sin 2deg, so its *relative* error is large (2.4e-2);
#     shape and angle errors ~ 8.6e-4 (order ~1.9 at N=400);
#   graph 88 deg: y' = tan 88deg ~ 29 at the contact, pre-asymptotic up to N ~ 5000.
N_FREE = 400
DEFAULT_TOL = 2.5e-5
TOL_OVERRIDES = {
    ("curve", 150): {"shape": 1e-4, "contact_angle": 1e-4, "span": 1e-4},
    ("curve", 178): {"shape": 2e-3, "contact_angle": 2e-3, "span": 5e-2, "young": 1e-4},
    ("graph", 88): {"shape": 2e-3, "contact_angle": 1e-2, "span": 1e-3, "young": 1e-2},
}


@pytest.mark.parametrize("form, deg", FREE_CASES)
def test_free_span_matches_young_and_cap(form, deg):
    g_gl, area = 1.7, 0.8
    drop = free_drop(deg, g_gl=g_gl, area=area)
    cap = oracle(drop)
    assert cap.theta == pytest.approx(math.radians(deg), abs=1e-12)
    sol = dl.solve(drop, N_FREE, form)
    assert sol.success, sol.result.message
    assert sol.result.iterations <= 15
    tol = {**{k: DEFAULT_TOL for k in ERROR_KEYS + ("young",)}, **TOL_OVERRIDES.get((form, deg), {})}
    err = droplet_errors(sol, cap)
    for k in ERROR_KEYS:
        assert err[k] < tol[k], (k, err[k])
        # the library's self-reported errors agree with the independent oracle
        assert sol.errors[k] == pytest.approx(err[k], rel=1e-6, abs=1e-13), k
    # Young's equation for the reported contact angle, recomputed here
    young = g_gl * math.cos(sol.contact_angle) + drop.gamma_sl - drop.gamma_sg
    assert sol.young_residual == pytest.approx(young, abs=1e-15)
    assert abs(young) / g_gl < tol["young"]
    # energy and pressure relations of the oracle: E = 2 gamma A / R, p = gamma / R => E = 2 A p
    assert sol.energy == pytest.approx(2 * area * sol.pressure, rel=2 * tol["energy"])


@pytest.mark.parametrize("form, deg", [("curve", 30), ("curve", 120), ("graph", 60)])
def test_free_span_pressure_is_energy_sensitivity(form, deg):
    drop = free_drop(deg, g_gl=1.3, area=2.0)
    sol = dl.solve(drop, 100, form)
    assert sol.success
    assert sol.pressure == pytest.approx(fd_pressure(drop, 100, form), rel=1e-6)


@pytest.mark.parametrize("form, deg", [("curve", 30), ("curve", 120), ("graph", 60)])
def test_contact_angle_is_stationary_in_span(form, deg):
    """With the free span at its optimum, pinning the span at the reported value reproduces the
    same discrete solution (same energy): the free-span optimum is stationary in a."""
    drop = free_drop(deg, g_gl=1.0, area=1.0)
    free = dl.solve(drop, 200, form)
    pinned = dl.solve(dataclasses.replace(drop, span=free.span), 200, form)
    assert pinned.success
    assert pinned.energy == pytest.approx(free.energy, rel=1e-10)
    assert pinned.pressure == pytest.approx(free.pressure, rel=1e-7)
    assert np.max(np.abs(pinned.y - free.y)) < 1e-7


# ----------------------------------------------------------------------------- convergence order
NS = [50, 100, 200, 400, 800]
ORDER_CASES = [("curve", 30), ("curve", 60), ("curve", 120), ("curve", 150), ("graph", 30), ("graph", 60)]


@pytest.mark.parametrize("form, deg", ORDER_CASES)
def test_second_order_convergence(form, deg):
    drop = free_drop(deg)
    cap = oracle(drop)
    errs = {k: [] for k in ERROR_KEYS + ("young",)}
    for n in NS:
        sol = dl.solve(drop, n, form)
        assert sol.success
        e = droplet_errors(sol, cap)
        for k in ERROR_KEYS:
            errs[k].append(e[k])
        errs["young"].append(abs(sol.young_residual))
    orders = {k: observed_order(NS, v) for k, v in errs.items()}
    for k, p in orders.items():
        assert 1.9 <= p <= 2.1, (k, p, orders)


@pytest.mark.parametrize("form", ["curve", "graph"])
def test_fixed_span_second_order(form):
    drop = Droplet(gamma_gl=1.3, gamma_sl=0.2, gamma_sg=0.5, area=2.0, span=3.0)
    cap = oracle(drop)
    ns = [100, 200, 400, 800]
    errs = {k: [] for k in ("shape", "contact_angle", "energy", "pressure")}
    for n in ns:
        e = droplet_errors(dl.solve(drop, n, form), cap)
        for k in errs:
            errs[k].append(e[k])
    for k, v in errs.items():
        assert 1.9 <= observed_order(ns, v) <= 2.1, (k, observed_order(ns, v))


def test_90_degrees_curve_contact_angle_exact():
    """At 90 deg with no wetting term the discrete optimum is half a regular 2N-gon (mirror image in
    the table), so the contact-angle estimate is exact, not merely O(1/N²)."""
    drop = free_drop(90)
    for n in (7, 50, 400):
        sol = dl.solve(drop, n, "curve")
        assert abs(sol.contact_angle - 0.5 * math.pi) < 1e-9
        assert abs(sol.young_residual) < 1e-9
        # vertices equally spaced in angle about the centre (a, 0)/2
        ang = np.arctan2(sol.y, sol.x - 0.5 * sol.span)
        assert np.max(np.abs(np.diff(ang) + math.pi / n)) < 1e-8


def test_contact_angle_estimator_exact_on_circle():
    for deg in (5, 45, 90, 135, 175):
        th = math.radians(deg)
        for n in (3, 10, 101):
            pts = circle_points(th, 1.7, n)
            assert dl.contact_angle_estimate(pts[:, 0], pts[:, 1]) == pytest.approx(th, abs=1e-12)


@pytest.mark.slow
def test_graph_near_90_reaches_second_order():
    """At 88 deg the graph formulation is pre-asymptotic until N ~ 5000 (order ~0.8 for the contact
    angle over 50..800); at large N it is second order."""
    drop = free_drop(88)
    cap = oracle(drop)
    ns = [6400, 12800, 25600]
    errs = {k: [] for k in ERROR_KEYS}
    for n in ns:
        e = droplet_errors(dl.solve(drop, n, "graph"), cap)
        for k in errs:
            errs[k].append(e[k])
    for k, v in errs.items():
        assert 1.85 <= observed_order(ns, v) <= 2.1, (k, observed_order(ns, v))


# ----------------------------------------------------------------------------- across N
def _check_across_n(form, n):
    drop = free_drop(60, g_gl=1.2, area=3.0)
    cap = oracle(drop)
    sol = dl.solve(drop, n, form)
    assert sol.success, sol.result.message
    assert sol.result.iterations <= 15
    assert len(sol.x) == n + 1
    err = droplet_errors(sol, cap)
    # measured constants e*N² at 60 deg are <= 1 for every error and every N >= 3
    for k in ERROR_KEYS:
        assert err[k] * n * n < 2.0, (k, err[k] * n * n)
    assert abs(sol.young_residual) / drop.gamma_gl * n * n < 2.0


@pytest.mark.parametrize("form", ["curve", "graph"])
@pytest.mark.parametrize("n", [8, 100, 1000, 10000])  # (N = 3: the checks refuse it, test_minimum_n_solves)
def test_converges_across_n(form, n):
    _check_across_n(form, n)


@pytest.mark.slow
@pytest.mark.parametrize("form", ["curve", "graph"])
def test_converges_n_100000(form):
    _check_across_n(form, 100000)


# ----------------------------------------------------------------------------- reduced problem in theta
ANGLE_CASES = [(g, deg, area) for g in (0.5, 1.0, 3.7) for deg, area in
               [(10, 1.0), (30, 2.5), (60, 0.3), (90, 1.0), (120, 7.0), (150, 1.0), (175, 0.2), (179, 1.0)]]


@pytest.mark.parametrize("g, deg, area", ANGLE_CASES)
def test_solve_angle_is_young(g, deg, area):
    gl, sl, sg = tensions_for_angle(math.radians(deg), g, 0.4 * g)
    drop = Droplet(gl, sl, sg, area)
    sol = dl.solve_angle(drop)
    assert sol.success, sol.result.message
    theta_y = young_angle(gl, sl, sg)
    # d(residual)/d(theta) = -gamma_gl sin(theta): near theta = pi the angle is ill-conditioned in the residual
    assert abs(sol.contact_angle - theta_y) <= 1e-10 / math.sin(theta_y)
    assert abs(sol.young_residual) <= 1e-10
    cap = free_cap(gl, sl, sg, area)
    assert sol.radius == pytest.approx(cap.radius, rel=1e-10)
    # a = 2 R sin(theta): relative sensitivity |cot theta| times the angle bound above
    assert sol.span == pytest.approx(cap.span, rel=1e-9 + 2e-10 * abs(1 / math.tan(theta_y)) / math.sin(theta_y))
    assert sol.energy == pytest.approx(cap.energy, rel=1e-12)
    # E(theta) is minimal at theta*: larger at neighbours, and flat (zero derivative)
    E = lambda t: float(sol.energy_function(t))
    assert E(sol.contact_angle) == pytest.approx(sol.energy, rel=1e-14)
    for d in (1e-3, 1e-2, 1e-1):
        for t in (sol.contact_angle - d, sol.contact_angle + d):
            if 0 < t < math.pi:
                assert E(t) > sol.energy
    h = 1e-5
    assert abs(E(sol.contact_angle + h) - E(sol.contact_angle - h)) / (2 * h) < 1e-8 * g * math.sqrt(area)


@pytest.mark.parametrize("deg", [0.5, 1.0, 2.0, 5.0])
def test_solve_angle_small_angles_accurate(deg):
    drop = Droplet(*tensions_for_angle(math.radians(deg), 1.0, 0.4), area=2.5)
    sol = dl.solve_angle(drop)
    assert abs(sol.contact_angle - math.radians(deg)) <= 1e-10
    assert abs(sol.young_residual) <= 1e-10
    assert sol.energy == pytest.approx(free_cap(drop.gamma_gl, drop.gamma_sl, drop.gamma_sg, 2.5).energy, rel=1e-12)


@pytest.mark.parametrize("deg", [0.5, 1.0])
def test_solve_angle_small_angle_reports_success(deg):
    drop = Droplet(*tensions_for_angle(math.radians(deg), 1.0, 0.4), area=2.5)
    sol = dl.solve_angle(drop)
    assert sol.success, sol.result.status


def test_solve_angle_refuses_pinned_span():
    with pytest.raises(InputError):
        dl.solve_angle(Droplet(1.0, 0.5, 1.0, 1.0, span=2.0))


# ----------------------------------------------------------------------------- invariance
@pytest.mark.parametrize("form, deg, span", [("curve", 40, None), ("curve", 130, None), ("graph", 50, None),
                                             ("curve", None, 1.5), ("graph", None, 3.0)])
def test_scaling_invariance(form, deg, span):
    s, k = 1.9, 3.3
    if span is None:
        base = free_drop(deg, g_gl=1.1, area=0.7)
    else:
        base = Droplet(1.1, 0.2, 0.5, 0.7, span=span)
    scaled = Droplet(k * base.gamma_gl, k * base.gamma_sl, k * base.gamma_sg, s * s * base.area,
                     None if span is None else s * span)
    n = 60
    a, b = dl.solve(base, n, form), dl.solve(scaled, n, form)
    assert a.success and b.success
    assert b.energy == pytest.approx(k * s * a.energy, rel=1e-9)
    assert b.pressure == pytest.approx(k / s * a.pressure, rel=1e-9)
    assert b.span == pytest.approx(s * a.span, rel=1e-9)
    assert b.contact_angle == pytest.approx(a.contact_angle, abs=1e-9)
    assert np.max(np.abs(b.x - s * a.x)) < 1e-9 * s
    assert np.max(np.abs(b.y - s * a.y)) < 1e-9 * s
    if span is None:
        assert b.young_residual == pytest.approx(k * a.young_residual, abs=1e-9 * k)
    # and against the oracle in physical units
    cap = oracle(scaled)
    assert b.pressure == pytest.approx(cap.pressure, rel=1e-3)
    assert b.energy == pytest.approx(cap.energy, rel=1e-3)


def test_energy_includes_wetting_term():
    """E = gamma_gl * length + (gamma_sl - gamma_sg) * span, recomputed from the vertices."""
    drop = free_drop(50, g_gl=1.4, area=2.0)
    sol = dl.solve(drop, 100, "curve")
    length = float(np.sum(np.hypot(np.diff(sol.x), np.diff(sol.y))))
    assert sol.energy == pytest.approx(drop.gamma_gl * length + (drop.gamma_sl - drop.gamma_sg) * sol.span,
                                       rel=1e-12)
    shoelace = 0.5 * abs(np.dot(sol.x, np.roll(sol.y, -1)) - np.dot(sol.y, np.roll(sol.x, -1)))
    assert shoelace == pytest.approx(drop.area, rel=1e-8)


# ----------------------------------------------------------------------------- symmetry
@pytest.mark.parametrize("form, deg", [("curve", 20), ("curve", 100), ("curve", 165), ("graph", 45), ("graph", 80)])
def test_solution_symmetric(form, deg):
    sol = dl.solve(free_drop(deg), 201, form)
    assert sol.success
    a = sol.span
    assert np.max(np.abs(sol.x + sol.x[::-1] - a)) / a < 1e-8
    assert np.max(np.abs(sol.y - sol.y[::-1])) / a < 1e-8


# ----------------------------------------------------------------------------- bad input
NAN, INF = float("nan"), float("inf")


def _drop(**kw):
    base = dict(gamma_gl=1.0, gamma_sl=0.5, gamma_sg=1.0, area=1.0, span=None)
    base.update(kw)
    return Droplet(**base)


@pytest.mark.parametrize("kw, words", [
    (dict(gamma_gl=0.0), ["gamma_gl", "positive"]),
    (dict(gamma_gl=-1.0), ["gamma_gl", "positive"]),
    (dict(area=0.0), ["area", "positive"]),
    (dict(area=-2.0), ["area", "positive"]),
    (dict(span=0.0), ["span", "positive"]),
    (dict(span=-1.0), ["span", "positive"]),
    (dict(gamma_gl=NAN), ["gamma_gl", "finite"]),
    (dict(gamma_sl=NAN), ["gamma_sl", "finite"]),
    (dict(gamma_sg=INF), ["gamma_sg", "finite"]),
    (dict(area=INF), ["area", "finite"]),
    (dict(area=NAN), ["area", "finite"]),
    (dict(span=NAN), ["span", "finite"]),
    (dict(span=-INF), ["span", "finite"]),
    (dict(gamma_gl="abc"), ["gamma_gl", "number"]),
    (dict(gamma_sg=2.5), ["spreading coefficient"]),          # S = 2.5 - 0.5 - 1 > 0
    (dict(gamma_sg=1.5), ["spreading coefficient"]),          # S = 0 exactly: complete wetting
    (dict(gamma_sl=2.0), ["pi"]),                             # gamma_sl - gamma_sg = gamma_gl
    (dict(gamma_sl=3.0), ["pi"]),
])
def test_bad_droplet_input(kw, words):
    with pytest.raises(InputError) as info:
        _drop(**kw)
    msg = str(info.value)
    for w in words:
        assert w in msg, msg


def test_pinned_span_allows_any_tensions():
    # the wetting conditions concern the free span only
    sol = dl.solve(_drop(gamma_sg=2.5, span=1.5), 50, "curve")
    assert sol.success
    assert sol.pressure == pytest.approx(oracle(_drop(gamma_sg=2.5, span=1.5)).pressure, rel=1e-3)


@pytest.mark.parametrize("n, words", [(2, ["n", "3"]), (0, ["n"]), (-5, ["n"]), (3.5, ["n", "integer"]),
                                      (NAN, ["n", "finite"]), (INF, ["n", "finite"]), ("ten", ["n", "number"])])
def test_bad_n(n, words):
    with pytest.raises(InputError) as info:
        dl.solve(_drop(), n, "curve")
    for w in words:
        assert w in str(info.value)


def test_unknown_formulation():
    with pytest.raises(InputError) as info:
        dl.solve(_drop(), 50, "spline")
    assert "formulation" in str(info.value) and "curve" in str(info.value)


@pytest.mark.parametrize("drop", [
    _drop(gamma_sg=0.5),                                  # 90 deg exactly
    _drop(gamma_sg=0.0),                                  # 120 deg
    _drop(gamma_sg=0.5 + math.cos(math.radians(91))),     # just above 90
    _drop(area=1.0, span=1.0),                            # pinned arc > 90 deg (A/a² > pi/8)
    _drop(area=1.01 * math.pi / 8, span=1.0),             # pinned arc just above 90 deg
], ids=["free90", "free120", "free91", "pinned_wide", "pinned91"])
def test_graph_refuses_90_degrees_or_more(drop):
    with pytest.raises(InputError) as info:
        dl.solve(drop, 50, "graph")
    assert "90" in str(info.value) and "curve" in str(info.value)


def test_graph_accepts_just_below_90():
    sol = dl.solve(_drop(area=0.99 * math.pi / 8, span=1.0), 50, "graph")
    assert sol.success
    assert math.degrees(sol.analytic.contact_angle) < 90.0


def test_minimum_n_solves():
    """At MIN_N the NLP converges, but three chords miss Young's law by 2.5 % of γ (measured 0.025-0.026): the
    checks refuse the answer and say which law failed and by how much."""
    for form in ("curve", "graph"):
        sol = dl.solve(free_drop(45), dl.MIN_N, form)
        assert sol.result.success and len(sol.x) == dl.MIN_N + 1
        assert not sol.success and sol.status == dl.CHECK_FAILED
        assert abs(sol.young_residual) > dl.CHECK_RTOL * sol.drop.gamma_gl
        assert "Young's law" in sol.message and f"{abs(sol.young_residual):.3g}" in sol.message
