"""The spectral droplet profile (discretise/droplet_spectral.py): the tangent angle a polynomial of degree p.

Oracles: exactness of the Lobatto quadrature and integration matrix on polynomials; the elliptic closed form
(2-D heavy drop), the Young–Laplace shooting and the issue's table (3-D), the circular arc (pinned span), the
closed-form folds; convergence faster than any power of 1/p, fitted from the errors themselves."""
from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from castrajectory.discretise.droplet_spectral import Spectral, lobatto
from castrajectory.models import droplet as md
from castrajectory.solve import droplet as dl

from test_droplet_axisymmetric import revolution
from test_droplet_gravity import heavy

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("p", [4, 7, 12, 40])
def test_lobatto_rules_are_exact_on_polynomials(p):
    """Weights integrate t^k over [0, 1] for k <= 2p - 1; the integration matrix integrates every polynomial of
    degree <= p from 0 to each node (measured to 1e-14 at p = 40)."""
    t, w, Q = lobatto(p)
    for k in range(2 * p):
        assert abs(w @ t ** k - 1.0 / (k + 1)) < 1e-13
    for k in range(p + 1):
        assert np.max(np.abs(Q @ t ** k - t ** (k + 1) / (k + 1))) < 1e-13
    poly = np.polynomial.Polynomial(np.cos(np.arange(min(p, 8) + 1)))  # resampling is exact on degree <= p
    assert np.max(np.abs(Spectral.resample(poly(t), p + 3) - poly(lobatto(p + 3)[0]))) < 1e-11


def _errors(drop, degrees, key):
    out = []
    for p in degrees:
        sol = dl.solve(drop, p, "spectral")
        assert sol.success, sol.message
        out.append(sol.errors[key])
    return np.array(out)


@pytest.mark.parametrize("name, drop, key, measured", [
    ("2-D heavy, 120°, A = 1 (elliptic)", heavy(120, 1.0), "height", (7.0e-8, 5.5e-9, 9.5e-11, 1.1e-12)),
    ("3-D sessile, 90°, V = 1 (shooting)", revolution(90, 1.0, 1.0), "height", (5.3e-7, 2.3e-8, 6.3e-10, 1.7e-11)),
    ("3-D sessile, 60°, Bo = 10 (shooting)", revolution(60, 10 ** 1.5, 1.0), "height", (1.3e-5, 3.4e-6, 1.5e-7, 8.3e-10)),
])
def test_converges_faster_than_any_power(name, drop, key, measured):
    """Degrees 6, 8, 10, 12: the error falls by at least 4x per two degrees and its log is concave-down or
    straight in p (geometric, not algebraic: an algebraic rate p^-k would flatten, each step dividing less).
    Measured errors in the parameters; the last within 100x."""
    degrees = (6, 8, 10, 12)
    errs = _errors(drop, degrees, key)
    assert errs[-1] < 100 * measured[-1]
    assert np.all(errs[1:] < errs[:-1] / 3.0)
    # an algebraic order fitted between 6 and 12 exceeds any the polyline reaches (order 2)
    order = -math.log(errs[-1] / errs[0]) / math.log(12 / 6)
    assert order > 8.0, order


def test_issue_table_to_every_digit_at_degree_12():
    """The issue's sessile table (units of l_c): V = 1 at 60°, 90°, 120° and V = 10 at 90°, every digit given."""
    table = [(90, 1.0, 0.720266, 0.816898), (90, 10.0, 1.244156, 1.953168), (60, 1.0, 0.534970, 1.025241),
             (120, 1.0, 0.883400, 0.631669)]
    for deg, volume, h, rc in table:
        sol = dl.solve(revolution(deg, volume, 1.0), 12, "spectral", compare=False)
        assert sol.success
        assert abs(sol.height - h) <= 5e-7 and abs(sol.contact_radius - rc) <= 5e-7, (deg, volume, sol.height)


def test_weightless_caps_and_pinned_arc_to_rounding():
    """Without gravity the answer is a circle: the tangent angle is linear in arclength, a polynomial of degree 1,
    so every degree holds it to rounding (measured 5e-15 for the pinned arc, 1e-11 for the free caps)."""
    for drop in (md.Droplet(span=1.5), md.Droplet(span=0.3, area=1.0), md.Droplet(1.0, 0.0, 0.9),
                 revolution(30, 1.0, 0.0), revolution(170, 2.0, 0.0)):
        sol = dl.solve(drop, 8, "spectral")
        assert sol.success, sol.message
        assert max(sol.errors[k] for k in ("contact_angle", "pressure", "energy")) < 1e-9, sol.errors


def test_folds_to_the_closed_form():
    """The pendant families end at their folds: 2-D A* = 2.7151505 (elliptic) and 3-D V* = 3.4110285 (shooting);
    the continuation's extrapolated fold at degree 16 (measured 5e-11 and 4e-11 relative)."""
    for drop in (heavy(90, 2.8, pendant=True), revolution(90, 3.5, 1.0, pendant=True)):
        sol = dl.solve(drop, 16, "spectral")
        assert sol.status == dl.NO_STABLE_DROP
        fold = sol.stability["fold"]
        assert abs(fold["extrapolated_area"] - fold["analytic_area"]) < 100 * 5e-11 * fold["analytic_area"]


def test_puddle_is_resolved_with_over_integration():
    """Bond 100 (3-D, 60°): the profile's edge is a layer a capillary length wide; at degree 32 the height is within
    3.9e-10 and the energy is not below the drop's (evaluated at the degree's own nodes, an unresolved profile
    wiggled between them and priced itself 60 below the drop)."""
    drop = revolution(60, 100 ** 1.5, 1.0)
    sol = dl.solve(drop, 32, "spectral")
    assert sol.success, sol.message
    assert sol.errors["height"] < 100 * 3.9e-10
    assert sol.energy >= md.analytic(drop).energy - 1e-9 * abs(sol.energy)


def test_estimate_bounds_the_error():
    """The estimate (the difference to degree ceil(3p/4)) bounds the error of the answer's readings it covers."""
    for drop in (heavy(120, 1.0), revolution(60, 10 ** 1.5, 1.0)):
        for p in (8, 12):
            sol = dl.solve(drop, p, "spectral")
            est = sol.error_estimate
            assert est.available and est.as_dict()["method"] == "degree"
            truth = abs(sol.contact_angle - md.analytic(drop).contact_angle)
            assert truth <= est.errors["contact_angle"] + 1e-12


@pytest.mark.parametrize("args, needle", [
    (["--formulation", "spectral", "--n", "3"], "degree"),
    (["--formulation", "spectral", "--n", "500"], "degree"),
    (["--formulation", "spectral", "--pattern", "1", "1.5"], "patterned"),
])
def test_script_refuses_bad_spectral_input(args, needle):
    out = subprocess.run([sys.executable, str(ROOT / "problems" / "droplet.py"), *args], capture_output=True,
                         text=True)
    assert out.returncode == 2 and out.stdout == ""
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], out.stderr


def test_script_spectral_json():
    out = subprocess.run([sys.executable, str(ROOT / "problems" / "droplet.py"), "--axisymmetric", "--gravity", "1",
                          "--gamma-sl", "0.5", "--gamma-sg", "0.5", "--formulation", "spectral", "--n", "12", "--json"],
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    import json
    d = json.loads(out.stdout)
    assert d["status"] == "ok" and d["formulation"] == "spectral" and d["error_estimate"]["method"] == "degree"
    assert abs(d["height"] - 0.720266) < 5e-7 and abs(d["contact_radius"] - 0.816898) < 5e-7
