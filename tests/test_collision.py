"""Tests of castrajectory.models.collision and problems/collision_impulse.py.

* mass matrix of the uniform rectangle: atom quadrature (the seed's definition)
  == diag(m, m, m(w²+h²)/12), independent of θ and c;
* the CasADi-derived admissible direction M⁻¹(∂y/∂q)ᵀ
  == the closed form (0, 1/m, (d_x cos θ − d_y sin θ)/I);
* the impact law: restitution, energy, μ ≥ 0, separating contacts, direction of Δv, and the flat-fall
  corner impact against a hand-derived formula (re-derived below, independently of the module);
* the script: clean JSON, one-line refusals with exit code 2.
"""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from castrajectory.models import collision as col
from castrajectory.validation import InputError

ROOT = Path(__file__).resolve().parents[1]
SCRIPT = str(ROOT / "problems" / "collision_impulse.py")
ENV = dict(os.environ, MPLBACKEND="Agg")
RNG = np.random.default_rng(20240522)

SIZES = [(1.0, 2.0, 1.0), (3.5, 0.2, 4.0), (0.01, 1e-2, 7.0), (250.0, 1.0, 1.0)]


# ----------------------------------------------------------------------------- mass matrix
@pytest.mark.parametrize("m,w,h", SIZES)
@pytest.mark.parametrize("points", [2, 3, 5])
def test_mass_matrix_quadrature_equals_closed_form(m, w, h, points):
    system = col.rectangle_atoms(m, w, h, points=points)
    assert len(system.kinetic.masses) == points ** 2
    assert math.isclose(sum(system.kinetic.masses), m, rel_tol=1e-14)
    exact = np.diag([m, m, m * (w * w + h * h) / 12.0])      # I = m|d|²/3 with |d|² = (w² + h²)/4
    d2 = (w / 2) ** 2 + (h / 2) ** 2
    assert math.isclose(exact[2, 2], m * d2 / 3.0, rel_tol=1e-14)
    np.testing.assert_allclose(col.rectangle_mass_matrix(m, w, h), exact, rtol=1e-14, atol=0)
    scale = np.max(np.abs(exact))
    for q in ([0.0, 0.0, 0.0], [1.3, -2.0, 0.3], [-40.0, 7.0, 2.9], *RNG.uniform(-10, 10, (3, 3))):
        M = np.asarray(system.mass_matrix(q))
        assert np.max(np.abs(M - exact)) <= 1e-12 * scale, (q, M)
    # the closed-form system gives the same matrix through the same LagrangianSystem call
    np.testing.assert_allclose(np.asarray(col.rectangle(m, w, h).mass_matrix([0.1, 0.2, 0.3])), exact, rtol=1e-14)


def test_seed_equation_8_value_is_twice_the_quadrature():
    """Eq. (8) of the seed puts m|d|²/3 in M/2, i.e. M₃₃ = 2m|d|²/3; the atom quadrature gives half that."""
    m, w, h = 2.0, 3.0, 1.5
    M = np.asarray(col.rectangle_atoms(m, w, h).mass_matrix([0.0, 0.0, 0.7]))
    d2 = (w / 2) ** 2 + (h / 2) ** 2
    seed_M33 = 2 * (m * d2 / 3)
    assert math.isclose(M[2, 2], m * d2 / 3, rel_tol=1e-13)
    assert math.isclose(seed_M33 / M[2, 2], 2.0, rel_tol=1e-13)


# ----------------------------------------------------------------------------- admissible direction
def test_casadi_admissible_direction_equals_closed_form():
    fn = col.admissible_direction_function()
    for _ in range(50):
        theta = RNG.uniform(-2 * math.pi, 2 * math.pi)
        d = RNG.uniform(-3, 3, 2)
        c = RNG.uniform(-5, 5, 2)
        m, inertia = RNG.uniform(0.1, 10, 2)
        derived = np.asarray(fn([c[0], c[1], theta], d, m, inertia)).reshape(-1)
        closed = np.array([0.0, 1.0 / m, (d[0] * math.cos(theta) - d[1] * math.sin(theta)) / inertia])
        np.testing.assert_allclose(derived, closed, rtol=1e-13, atol=1e-14)
        np.testing.assert_allclose(col.admissible_direction(m, inertia, theta, d), closed, rtol=1e-14, atol=0)


def test_casadi_jacobian_of_height_is_the_closed_form():
    q, d = ca.SX.sym("q", 3), ca.SX.sym("d", 2)
    J = ca.Function("J", [q, d], [ca.jacobian(col.point_height(q, d), q)])
    for _ in range(20):
        qv, dv = RNG.uniform(-4, 4, 3), RNG.uniform(-2, 2, 2)
        np.testing.assert_allclose(np.asarray(J(qv, dv)).reshape(-1), col.corner_jacobian(qv[2], dv),
                                   rtol=1e-14, atol=1e-15)


# ----------------------------------------------------------------------------- impact law
def random_cases(n=40):
    for _ in range(n):
        m = RNG.uniform(0.1, 10)
        w, h = RNG.uniform(0.1, 5, 2)
        theta = RNG.uniform(-math.pi, math.pi)
        corner = RNG.choice([-0.5, 0.5], 2) * np.array([w, h])   # one of the four corners
        v = RNG.uniform(-5, 5, 3)
        yield m, w, h, theta, corner, v


@pytest.mark.parametrize("e", [0.0, 0.3, 0.8, 1.0])
def test_impact_law(e):
    approaching = 0
    for m, w, h, theta, corner, v in random_cases():
        imp = col.rectangle_impact(m, w, h, theta, v, e, corner)
        J = imp.jacobian
        vn = float(J @ v)
        assert imp.mu >= 0.0
        if vn < 0:
            approaching += 1
            assert imp.mu > 0
            # J v⁺ = −e J v⁻
            assert abs(float(J @ imp.v_after) + e * vn) <= 1e-12 * max(1.0, abs(vn))
        else:
            assert imp.mu == 0.0 and np.array_equal(imp.v_after, v)
        # Δv is a non-negative multiple of M⁻¹Jᵀ
        Minv_JT = np.array([0.0, 1.0 / m, J[2] / (m * (w * w + h * h) / 12)])
        np.testing.assert_allclose(imp.direction, Minv_JT, rtol=1e-13, atol=1e-15)
        np.testing.assert_allclose(imp.v_after - v, imp.mu * Minv_JT, rtol=1e-12, atol=1e-12)
        # energy: conserved for e = 1, never gained
        if e == 1.0:
            assert abs(imp.ke_after - imp.ke_before) <= 1e-12 * max(1.0, imp.ke_before)
        else:
            assert imp.ke_after <= imp.ke_before * (1 + 1e-14)
    assert approaching >= 5


def test_elastic_mu_is_the_nontrivial_root_of_the_energy_equation():
    m, w, h, theta, d, v = 1.7, 2.0, 0.6, 0.4, [-1.0, -0.3], [0.5, -1.5, 0.8]
    imp = col.rectangle_impact(m, w, h, theta, v, 1.0, d)
    M = col.rectangle_mass_matrix(m, w, h)
    dK = lambda mu: 0.5 * (v + mu * imp.direction) @ M @ (v + mu * imp.direction) - 0.5 * np.dot(v, M @ v)
    assert abs(dK(imp.mu)) < 1e-12 and abs(dK(0.0)) == 0.0 and imp.mu > 0
    assert dK(0.5 * imp.mu) < 0   # between the roots kinetic energy is lower (inelastic)


def test_perfectly_inelastic_stops_the_corner():
    for m, w, h, theta, corner, v in random_cases(20):
        v[1] = -abs(v[1]) - 5.0 * (abs(v[0]) + abs(v[2]) * (w + h))   # make the corner approach
        imp = col.rectangle_impact(m, w, h, theta, v, 0.0, corner)
        assert imp.mu > 0
        assert abs(imp.normal_velocity_after) <= 1e-12 * abs(imp.normal_velocity_before)
        assert abs(imp.point_velocity(imp.v_after)[1]) <= 1e-12 * abs(imp.normal_velocity_before)


def test_separating_corner_keeps_its_velocity():
    # θ = 0, lower-left corner, body moving up and spinning slowly: J v = v_y − (w/2) ω > 0
    imp = col.rectangle_impact(1.0, 2.0, 1.0, 0.0, [3.0, 1.0, 0.5], 0.7)
    assert imp.normal_velocity_before > 0
    assert imp.mu == 0.0 and np.array_equal(imp.v_after, imp.v_before) and imp.ke_after == imp.ke_before
    # grazing (J v = 0) is not an impact either
    imp = col.rectangle_impact(1.0, 2.0, 1.0, 0.0, [3.0, 1.0, 1.0], 1.0)
    assert imp.normal_velocity_before == 0.0 and imp.mu == 0.0


@pytest.mark.parametrize("m,w,h", SIZES)
@pytest.mark.parametrize("e", [0.0, 0.5, 1.0])
def test_flat_fall_corner_impact(m, w, h, e):
    """θ = 0, d = (−w/2, −h/2), v⁻ = (0, −v, 0).

    J = ∂(c_y + sin θ d_x + cos θ d_y)/∂q = (0, 1, cos θ d_x − sin θ d_y) = (0, 1, −w/2).
    I = m(w² + h²)/12, so J M⁻¹ Jᵀ = 1/m + (w²/4)/I = (4w² + h²)/(m(w² + h²)), and J v⁻ = −v:
        μ = (1 + e) v m (w² + h²)/(4w² + h²),  v_y⁺ = −v + μ/m,  ω⁺ = −(w/2) μ/I,  v_x⁺ = 0.
    """
    v = 1.7
    imp = col.rectangle_impact(m, w, h, 0.0, [0.0, -v, 0.0], e)
    inertia = m * (w * w + h * h) / 12
    mu = (1 + e) * v * m * (w * w + h * h) / (4 * w * w + h * h)
    np.testing.assert_allclose(imp.jacobian, [0.0, 1.0, -w / 2], rtol=1e-15, atol=0)
    assert math.isclose(imp.mu, mu, rel_tol=1e-13)
    np.testing.assert_allclose(imp.v_after, [0.0, -v + mu / m, -(w / 2) * mu / inertia], rtol=1e-13, atol=1e-15)
    assert imp.v_after[2] < 0    # the struck lower-left corner is pushed up: clockwise spin


def test_thin_rod_limit_textbook_values():
    """h → 0, e = 0: a rod falling flat onto one end gets μ = m v/4, v_y⁺ = −3v/4, ω⁺ = −3v/(2w)."""
    m, w, v = 2.0, 1.5, 3.0
    imp = col.rectangle_impact(m, w, 1e-9, 0.0, [0.0, -v, 0.0], 0.0)
    assert math.isclose(imp.mu, m * v / 4, rel_tol=1e-12)
    assert math.isclose(imp.v_after[1], -3 * v / 4, rel_tol=1e-12)
    assert math.isclose(imp.v_after[2], -3 * v / (2 * w), rel_tol=1e-12)


def test_general_system_impact_matches_the_rectangle():
    """The (M, J) law on the atom system with a CasADi gap equals the closed-form corner impact."""
    for m, w, h, theta, corner, v in random_cases(10):
        system = col.rectangle_atoms(m, w, h)
        q = [RNG.uniform(-3, 3), RNG.uniform(-3, 3), theta]
        gap = col.point_height(system.q, corner)
        for e in (0.0, 0.6, 1.0):
            a = col.system_impact(system, gap, q, v, e)
            b = col.rectangle_impact(m, w, h, theta, v, e, corner)
            assert math.isclose(a.mu, b.mu, rel_tol=1e-11, abs_tol=1e-13)
            np.testing.assert_allclose(a.v_after, b.v_after, rtol=1e-11, atol=1e-12)


def test_general_law_on_two_point_masses():
    """Two point masses on a line with gap x1 − x2 ≥ 0: the general law gives the textbook 1-D collision."""
    m1, m2, e = 2.0, 3.0, 0.5
    M = np.diag([m1, m2])
    J = [1.0, -1.0]           # gap = x1 − x2 ≥ 0 (mass 1 on the right)
    v = np.array([-1.0, 2.0])
    imp = col.resolve_impact(M, J, v, e)
    # textbook: v1' = (m1 v1 + m2 v2 − m2 e (v1 − v2))/(m1 + m2), likewise v2'
    v1 = (m1 * v[0] + m2 * v[1] - m2 * e * (v[0] - v[1])) / (m1 + m2)
    v2 = (m1 * v[0] + m2 * v[1] + m1 * e * (v[0] - v[1])) / (m1 + m2)
    np.testing.assert_allclose(imp.v_after, [v1, v2], rtol=1e-14)
    assert math.isclose(m1 * imp.v_after[0] + m2 * imp.v_after[1], m1 * v[0] + m2 * v[1], rel_tol=1e-14)


BAD_CALLS = [
    (lambda: col.rectangle_impact(1, 2, 1, 0.3, [1, -2, 0], 1.5), "restitution must be between 0 and 1"),
    (lambda: col.rectangle_impact(1, 2, 1, 0.3, [1, -2, 0], -0.1), "restitution must be between 0 and 1"),
    (lambda: col.rectangle_impact(1, 2, 1, 0.3, [1, -2, 0], float("nan")), "restitution must be finite"),
    (lambda: col.rectangle_impact(0, 2, 1, 0.3, [1, -2, 0], 1), "mass must be positive"),
    (lambda: col.rectangle_impact(1, -2, 1, 0.3, [1, -2, 0], 1), "width must be positive"),
    (lambda: col.rectangle_impact(1, 2, 0, 0.3, [1, -2, 0], 1), "height must be positive"),
    (lambda: col.rectangle_impact(1, 2, 1, float("inf"), [1, -2, 0], 1), "angle must be finite"),
    (lambda: col.rectangle_impact(1, 2, 1, 0.3, [1, float("nan"), 0], 1), "velocity must be finite"),
    (lambda: col.rectangle_impact(1, 2, 1, 0.3, [1, -2], 1), "velocity must have 3 components"),
    (lambda: col.rectangle_impact(1, 2, 1, 0.3, [1, -2, 0], 1, [0, float("inf")]), "corner must be finite"),
    (lambda: col.rectangle_atoms(1, 2, 1, points=1), "quadrature points must be an integer >= 2"),
    (lambda: col.resolve_impact(np.diag([1.0, -1.0]), [1, 0], [0, -1], 1), "positive definite"),
    (lambda: col.resolve_impact([[1.0, 0.5], [0.0, 1.0]], [1, 0], [0, -1], 1), "symmetric"),
    (lambda: col.resolve_impact(np.eye(2), [0, 0], [0, -1], 1), "nonzero"),
    (lambda: col.resolve_impact(np.eye(3), [0, 1], [0, -1], 1), "must be 2 x 2"),
]


@pytest.mark.parametrize("call,needle", BAD_CALLS)
def test_bad_input_refused(call, needle):
    with pytest.raises(InputError, match=needle) as info:
        call()
    assert "\n" not in str(info.value)


# ----------------------------------------------------------------------------- the script
def run(*args):
    return subprocess.run([sys.executable, SCRIPT, *args], capture_output=True, text=True, env=ENV, timeout=120)


def test_script_default_summary():
    p = run()
    assert p.returncode == 0, p.stderr
    assert "admissible Δv = μ·(0, 1/m, (d_x cos θ − d_y sin θ)/I)" in p.stdout
    assert "kinetic energy" in p.stdout and "status: ok" in p.stdout


def test_script_json_default():
    p = run("--json", "--verbose")
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)  # nothing else on stdout
    for k in ("status", "mu", "vx", "vy", "omega", "ke_before", "ke_after", "admissible_direction",
              "corner_velocity_before", "corner_velocity_after"):
        assert k in d
    assert d["status"] == "ok" and d["mu"] > 0
    # defaults: m = 1, w = 2, h = 1, θ = 0.3, corner (−1, −0.5), v = (1, −2, 0), e = 1
    th, inertia = 0.3, (4 + 1) / 12
    arm = -1 * math.cos(th) + 0.5 * math.sin(th)
    np.testing.assert_allclose(d["admissible_direction"], [0.0, 1.0, arm / inertia], rtol=1e-14)
    mu = 2 * 2 / (1 + arm * arm / inertia)
    assert math.isclose(d["mu"], mu, rel_tol=1e-13)
    assert [d["vx"], d["vy"], d["omega"]] == pytest.approx([1.0, -2 + mu, mu * arm / inertia], rel=1e-13)
    assert math.isclose(d["ke_before"], 2.5, rel_tol=1e-15) and math.isclose(d["ke_after"], 2.5, rel_tol=1e-12)
    assert math.isclose(d["corner_velocity_after"][1], 2.0, rel_tol=1e-12)


def test_script_flat_fall_json():
    p = run("--angle", "0", "--vx", "0", "--vy", "-1", "--restitution", "0", "--corner", "-1", "-0.5", "--json")
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert math.isclose(d["mu"], 5 / 17, rel_tol=1e-13)   # (1 + e) v m (w² + h²)/(4w² + h²)
    assert abs(d["corner_velocity_after"][1]) < 1e-15


def test_console_runs_the_scene():
    p = subprocess.run([sys.executable, "-m", "castrajectory.cli", "run", "collision_impulse", "--json"],
                       capture_output=True, text=True, env=ENV, timeout=120)
    assert p.returncode == 0, p.stderr
    assert json.loads(p.stdout)["status"] == "ok"


@pytest.mark.parametrize("args,needle", [
    (["--restitution", "1.5"], "restitution must be between 0 and 1"),
    (["--restitution", "-0.2"], "restitution must be between 0 and 1"),
    (["--mass", "0"], "mass must be positive"),
    (["--width", "-1"], "width must be positive"),
    (["--height", "0"], "height must be positive"),
    (["--vx", "nan"], "vx must be finite"),
    (["--omega", "inf"], "omega must be finite"),
    (["--angle", "nan"], "angle must be finite"),
    (["--corner", "0", "nan"], "corner DY must be finite"),
    (["--corner", "1"], "expected 2 arguments"),
    (["--mass", "abc"], "invalid float"),
])
def test_script_refuses_bad_input(args, needle):
    p = run(*args, "--json")
    assert p.returncode == 2
    assert p.stdout == ""
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0] and "Traceback" not in p.stderr
