"""The drop on a patterned table (issue #26): gamma_sl steps at x = ±w/2 (a disc of diameter w for a drop of
revolution).  The oracle is Gibbs' criterion, written here from the issue's formula and solved with scipy: while
the edge is pinned, A = (w/2)² (θ − sin θ cos θ) / sin² θ fixes the apparent angle; below the inner Young angle's
area the drop sits inside at that angle, above the outer one's it spreads at the outer angle.  The NLP (the
wetted measure split at the step, the pinning a bound: Droplet §11) against it at the discretisation's order:
θ(A) across a sweep, the angle in each regime, the areas where the edge pins and depins, the pinning multiplier
(its bounds, its value, and dE*/dw by finite differences), the complementarity of the split, the reduced
Hessian, the composition of the program and the refusals."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from castrajectory.models import droplet as md
from castrajectory.solve import droplet as dl
from castrajectory.solve.second_order import reduced_hessian
from castrajectory.validation import InputError

from helpers import observed_order
from test_droplet_gravity import _run  # problems/droplet.py headless, in a subprocess

TH_IN, TH_OUT, WIDTH = math.radians(60.0), math.radians(120.0), 1.0


def patterned(area=1.0, axisymmetric=False, deg_in=60.0, deg_out=120.0, width=WIDTH):
    """gamma_gl = gamma_sg = 1: gamma_sl = 1 − cos θ_in on the pattern, 1 − cos θ_out outside."""
    return md.Droplet(1.0, 1.0 - math.cos(math.radians(deg_in)), 1.0, area, pattern_width=width,
                      gamma_sl_out=1.0 - math.cos(math.radians(deg_out)), axisymmetric=axisymmetric)


def pinned_area(theta, axisymmetric=False):
    """The issue's formula (2-D), and the spherical cap of contact radius w/2 (3-D)."""
    s, c = math.sin(theta), math.cos(theta)
    if axisymmetric:
        return math.pi * (WIDTH / 2) ** 3 * (2 - 3 * c + c ** 3) / (3 * s ** 3)
    return (WIDTH / 2) ** 2 * (theta - s * c) / s ** 2


def gibbs_angle(area, axisymmetric=False):
    """The apparent angle of Gibbs' criterion: θ_in, the pinned angle from the formula, or θ_out."""
    if area <= pinned_area(TH_IN, axisymmetric):
        return TH_IN
    if area >= pinned_area(TH_OUT, axisymmetric):
        return TH_OUT
    return brentq(lambda t: pinned_area(t, axisymmetric) - area, TH_IN, TH_OUT, xtol=1e-15)


def sweep_areas(axisymmetric=False):
    a_in, a_out = pinned_area(TH_IN, axisymmetric), pinned_area(TH_OUT, axisymmetric)
    return np.concatenate([np.linspace(0.5 * a_in, 0.9 * a_in, 3), np.linspace(1.1 * a_in, 0.95 * a_out, 8),
                           np.linspace(1.05 * a_out, 2 * a_out, 3)])


_SWEEPS = {}


def sweep(n, axisymmetric=False):
    key = (n, axisymmetric)
    if key not in _SWEEPS:
        _SWEEPS[key] = dl.solve_pattern_sweep(patterned(axisymmetric=axisymmetric), sweep_areas(axisymmetric), n)
    return _SWEEPS[key]


# ----------------------------------------------------------------------------- the oracle
@pytest.mark.parametrize("axi", [False, True])
def test_oracle_is_gibbs_criterion(axi):
    for area in sweep_areas(axi):
        cap = md.analytic(patterned(area, axi))
        assert cap.contact_angle == pytest.approx(gibbs_angle(area, axi), abs=1e-13)
        assert cap.area == pytest.approx(area, rel=1e-13)
        if cap.regime == "pinned":  # the edge at the step
            edge = cap.contact_radius if axi else 0.5 * cap.span
            assert edge == pytest.approx(WIDTH / 2, rel=1e-13)
        # the pinning multiplier γ(cos θ_in − cos θ) spans [0, γ_sl_out − γ_sl] across the regimes
        assert -1e-15 <= cap.pinning_multiplier <= math.cos(TH_IN) - math.cos(TH_OUT) + 1e-15
    assert md.analytic(patterned(0.5, axi)).areas == pytest.approx(
        (pinned_area(TH_IN, axi), pinned_area(TH_OUT, axi)), rel=1e-14)
    # the energy is continuous where the edge pins and depins (the kink is in the wetting energy's slope)
    for a in md.analytic(patterned(1.0, axi)).areas:
        lo, hi = md.analytic(patterned(a * (1 - 1e-9), axi)), md.analytic(patterned(a * (1 + 1e-9), axi))
        assert lo.energy == pytest.approx(hi.energy, rel=1e-8)


def test_non_wetting_outside_never_depins():
    """γ_sl_out − γ_sg >= γ_gl: the outer Young angle is π, and the edge stays pinned at every area."""
    cap = md.analytic(md.Droplet(1.0, 0.5, 1.0, 50.0, pattern_width=1.0, gamma_sl_out=2.5))
    assert cap.regime == "pinned" and cap.areas[1] == math.inf and math.degrees(cap.contact_angle) > 170


# ----------------------------------------------------------------------------- the NLP against it
def test_apparent_angle_follows_gibbs_at_second_order():
    """θ(A) across the sweep (inside, pinned, spread) at N = 50, 100: measured 5.57e-4, 1.39e-4 rad (order 2.00);
    the regimes read off the split match the oracle's at every area."""
    ns, errs = (50, 100), []
    for n in ns:
        sols = sweep(n)
        assert all(s.success for s in sols)
        assert [s.pattern["regime"] for s in sols] == [md.analytic(s.drop).regime for s in sols] == \
            ["inside"] * 3 + ["pinned"] * 8 + ["spread"] * 3
        assert [s.analytic.contact_angle for s in sols] == pytest.approx([gibbs_angle(s.drop.area) for s in sols],
                                                                        abs=1e-12)
        errs.append(max(abs(s.contact_angle - gibbs_angle(s.drop.area)) for s in sols))
    assert errs[-1] * ns[-1] ** 2 < 100 * 1.4  # measured 1.39 (5.57e-4 N² / 4 at N = 50)
    assert 1.9 <= observed_order(ns, errs) <= 2.1  # measured 2.00


def test_angles_in_each_regime():
    """Inside: Young's inner angle (residual γ cos θ + γ_sl − γ_sg); pinned: span = w to the solver's tolerance
    and no Young residual; spread: the outer angle.  Measured at N = 100: 3.2e-5, 1.4e-4, 1.3e-4 rad; the span
    of a pinned drop 3.1e-10 from w, Young's residual at most 1.1e-4."""
    worst = {"inside": 3.2e-5, "pinned": 1.4e-4, "spread": 1.3e-4}
    for s in sweep(100):
        regime = s.pattern["regime"]
        assert abs(s.contact_angle - gibbs_angle(s.drop.area)) < 100 * worst[regime]
        if regime == "pinned":
            assert s.young_residual is None and s.span == pytest.approx(WIDTH, rel=1e-8)
        else:
            assert abs(s.young_residual) < 100 * 1.1e-4
            assert (s.span < WIDTH) == (regime == "inside")


@pytest.mark.parametrize("axi, ns, measured", [
    (False, (50, 100), (8.6e-5, 4.7e-4)), (True, (40, 80), (2.6e-5, 2.4e-4)),
])
def test_pinning_and_depinning_areas_at_second_order(axi, ns, measured):
    """The discrete edge reaches the step where the pinning multiplier leaves 0 and depins where the outside's
    vanishes (``pattern_transitions``): against the formula at θ_in and θ_out.  Measured relative errors, 2-D at
    N = 50, 100, 200: pinning 3.4e-4, 8.6e-5, 2.3e-5, depinning 1.9e-3, 4.6e-4, 1.2e-4; 3-D at N = 40, 80:
    1.0e-4, 2.5e-5 and 9.1e-4, 2.3e-4 (orders 1.97-2.02)."""
    drop = patterned(axisymmetric=axi)
    exact = (pinned_area(TH_IN, axi), pinned_area(TH_OUT, axi))
    errs = {"pinning": [], "depinning": []}
    for n in ns:
        found = dl.pattern_transitions(drop, n)
        for key, a in zip(errs, exact):
            errs[key].append(abs(found[key] - a) / a)
    for key, m in zip(errs, measured):
        assert errs[key][-1] < 100 * m
        assert 1.9 <= observed_order(ns, errs[key]) <= 2.1
    # the discrete drop pins a little early and depins a little early (its polygon's area is below the arc's)
    assert found["pinning"] < exact[0] and found["depinning"] < exact[1]


def test_pinning_multiplier_bounds_value_and_sensitivity():
    """The multiplier of the pinning bound lies in [0, γ_sl_out − γ_sl] (with the outside's bound carrying the
    rest, to rounding), is γ(cos θ_in − cos θ) at order 2 (measured 2.2e-4 of Δγ at N = 100), is −dE*/dw
    (central differences in the width, step 1e-4: measured 4.4e-13), and the split's complementarity
    m_out (step − m_in) holds without being imposed (measured 4.9e-12)."""
    jump = math.cos(TH_IN) - math.cos(TH_OUT)
    for s in sweep(100):
        p = s.pattern
        assert -1e-8 <= p["pinning_multiplier"] <= jump + 1e-8 and p["pinning_bounds"] == pytest.approx([0, jump])
        assert p["pinning_multiplier"] + p["outside_multiplier"] == pytest.approx(jump, abs=1e-8)
        assert abs(p["pinning_multiplier"] - s.analytic.pinning_multiplier) < 100 * 2.3e-4 * jump
        assert p["wetted_outside"] * (p["step"] - p["wetted_inside"]) < 1e-9
        if p["regime"] == "pinned":
            assert 0.0 < p["pinning_multiplier"] < jump
    area, h, n = 0.5, 1e-4, 100
    e = [dl.solve(patterned(area, width=WIDTH + d), n).energy for d in (-h, h)]
    mult = dl.solve(patterned(area), n).pattern["pinning_multiplier"]
    assert -(e[1] - e[0]) / (2 * h) == pytest.approx(mult, abs=1e-10)


def test_pinned_drop_is_a_strict_minimum():
    """With the two bounds of the split active, the reduced Hessian on the rest is positive definite."""
    drop = patterned(0.5)
    nlp, _, _ = dl.make_nlp(drop, 40)
    res = nlp.solve(options={**dl.SOLVER_OPTIONS, **dl.PATTERN_OPTIONS})
    assert res.success and reduced_hessian(nlp, res).positive_definite


def test_drop_of_revolution_on_a_pattern():
    """The disc of diameter w: the same split on π r_c².  θ(V) across a sweep at N = 40, 80 (measured 3.1e-4,
    7.7e-5 rad: order 2.00), regimes, multipliers."""
    ns, errs = (40, 80), []
    for n in ns:
        sols = sweep(n, True)
        assert all(s.success for s in sols)
        assert [s.pattern["regime"] for s in sols] == ["inside"] * 3 + ["pinned"] * 8 + ["spread"] * 3
        errs.append(max(abs(s.contact_angle - gibbs_angle(s.drop.area, True)) for s in sols))
        jump = math.cos(TH_IN) - math.cos(TH_OUT)
        assert all(-1e-8 <= s.pattern["pinning_multiplier"] <= jump + 1e-8 for s in sols)
        assert max(s.errors["pinning_multiplier"] for s in sols) < 100 * 3.3e-4  # measured 3.3e-4, 8.3e-5
    assert errs[-1] < 100 * 7.7e-5 and 1.9 <= observed_order(ns, errs) <= 2.1


def test_terms_are_composed():
    """A pattern adds the split (two unknowns, one row); without it the program has neither."""
    plain = dl.make_nlp(md.Droplet(), 30)[0]
    split = dl.make_nlp(patterned(0.5), 30)[0]
    assert "wetted_split" not in plain.constraint_names and "wetted_inside" not in plain.variable_names
    assert "wetted_split" in split.constraint_names
    assert split.sizes()["variables"] == plain.sizes()["variables"] + 2
    assert split.sizes()["equality_rows"] == plain.sizes()["equality_rows"] + 1
    assert split.anatomy()["complementarity_pairs"] == 0  # the split's complementarity is not imposed


# ----------------------------------------------------------------------------- bad input and the script
@pytest.mark.parametrize("kw, needle", [
    (dict(pattern_width=0.0, gamma_sl_out=1.5), "must be positive"),
    (dict(pattern_width=-1.0, gamma_sl_out=1.5), "must be positive"),
    (dict(pattern_width=float("nan"), gamma_sl_out=1.5), "finite"),
    (dict(pattern_width=1.0, gamma_sl_out=0.5), "both Young angles are equal"),
    (dict(pattern_width=1.0, gamma_sl_out=0.2), "more wettable"),
    (dict(pattern_width=1.0, gamma_sl_out=float("inf")), "finite"),
    (dict(pattern_width=1.0), "both its width"),
    (dict(pattern_width=1.0, gamma_sl_out=1.5, span=1.0), "pinned span"),
    (dict(pattern_width=1.0, gamma_sl_out=1.5, rho_g=1.0), "gravity"),
    (dict(pattern_width=1.0, gamma_sl_out=1.5, gamma_sl=-0.5), "complete wetting"),
])
def test_bad_pattern_input(kw, needle):
    with pytest.raises(InputError, match=needle):
        md.Droplet(**kw)


def test_script_pattern_json_and_plot(tmp_path):
    out = tmp_path / "pattern.png"
    p = _run("--pattern", "1", "1.5", "--area", "0.5", "--n", "60", "--json", "--plot", str(out))
    assert p.returncode == 0, p.stderr
    assert out.stat().st_size > 10_000
    d = json.loads(p.stdout)
    assert d["regime"] == "pinned" and d["pattern"]["regime"] == "pinned"
    assert d["apparent_angle"] == d["contact_angle"]
    assert abs(d["apparent_angle"] - gibbs_angle(0.5)) < 1e-2  # measured 3.8e-4 at N = 60
    assert 0 < d["pinning_multiplier"] < 1 and d["analytic"]["regime"] == "pinned"


@pytest.mark.parametrize("args, needle", [
    (["--pattern", "0", "1.5"], "must be positive"), (["--pattern", "1", "0.5"], "both Young angles are equal"),
])
def test_script_refuses_bad_pattern(args, needle):
    p = _run(*args, "--json")
    assert p.returncode == 2 and p.stdout == ""
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0] and "Traceback" not in p.stderr
