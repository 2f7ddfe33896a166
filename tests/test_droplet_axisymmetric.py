"""Drops of revolution (issue #26, 3-D): the Young–Laplace shooting against OpenDrop's test values, the issue's
sessile table and scipy's solve_ivp; the exact identity V = π r_c² (2/b + h) − 2π r_c sin θ; the NLP against the
spherical cap and the shooting at the discretisation's order (the axis: the height, read at the apex, converges
like log N / N²); the pressure at the table as the volume multiplier; the pendant fold V* = 3.411028; the script."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from castrajectory.models import droplet as md
from castrajectory.solve import droplet as dl

from helpers import observed_order
from test_droplet_gravity import _run  # problems/droplet.py headless, in a subprocess


def revolution(deg, volume, rho_g=1.0, pendant=False):
    """A drop of revolution with Young's angle ``deg`` (gamma = 1)."""
    return md.Droplet(1.0, 1.0 - math.cos(math.radians(deg)), 1.0, volume, rho_g=rho_g, pendant=pendant,
                      axisymmetric=True)


def _digits(ref: float) -> float:
    return 0.5 * 10.0 ** -len(repr(ref).split(".")[1])


# ----------------------------------------------------------------------------- the shooting
OPENDROP = [(1.6, 1.036716, 1.016825), (3.2, 0.353237, 2.406454)]


def test_shooting_reproduces_opendrop():
    """OpenDrop's Young–Laplace test values (Bo = 0.21, pendant, lengths in apex radii)."""
    for s, r, z in OPENDROP:
        prof = md.young_laplace(0.21, -1, s_end=s)
        assert abs(prof.r[-1] - r) <= _digits(r) and abs(prof.z[-1] - z) <= _digits(z)
    assert abs(md.young_laplace(0.21, -1, s_end=4.0).volume - 5.536329) <= 0.5e-6


def _scipy_profile(bond, g, s_end):
    integrate = pytest.importorskip("scipy.integrate")

    def rhs(s, q):
        r, z, phi = q[:3]
        k = 1.0 + 0.5 * g * bond * z if r == 0.0 else 2.0 + g * bond * z - math.sin(phi) / r
        return [math.cos(phi), math.sin(phi), k, math.pi * r * r * math.sin(phi)]

    sol = integrate.solve_ivp(rhs, [0.0, s_end], [0.0] * 4, rtol=1e-12, atol=1e-14, method="DOP853")
    return sol.y[:, -1]


@pytest.mark.parametrize("bond, g, s_end", [(0.21, -1, 1.6), (0.21, -1, 4.0), (2.0, 1, 2.5), (30.0, 1, 1.2)])
def test_shooting_against_solve_ivp(bond, g, s_end):
    r, z, phi, vol = _scipy_profile(bond, g, s_end)
    prof = md.young_laplace(bond, g, s_end=s_end)
    for mine, ref in ((prof.r[-1], r), (prof.z[-1], z), (prof.phi[-1], phi), (prof.volume, vol)):
        assert mine == pytest.approx(ref, rel=1e-10, abs=1e-10)  # measured <= 6.2e-12


# the table (units of l_c): theta, V, h, r_c
TABLE = [(90, 1.0, 0.720266, 0.816898), (90, 10.0, 1.244156, 1.953168), (60, 1.0, 0.534970, 1.025241),
         (120, 1.0, 0.883400, 0.631669)]


@pytest.mark.parametrize("deg, volume, h, rc", TABLE)
def test_sessile_table_and_identity(deg, volume, h, rc):
    cap = md.analytic(revolution(deg, volume))
    assert abs(cap.volume - volume) <= 1e-13 * volume  # the apex radius solved to rounding (measured <= 5.3e-16)
    assert abs(cap.height - h) <= _digits(h) and abs(cap.contact_radius - rc) <= _digits(rc)
    b, th = cap.apex_radius, math.radians(deg)
    identity = math.pi * cap.contact_radius ** 2 * (2 / b + cap.height) - 2 * math.pi * cap.contact_radius * math.sin(th)
    assert identity == pytest.approx(cap.volume, rel=1e-10)  # measured <= 3.6e-12 (RK4 error; exact for the ODE)
    assert cap.pressure == pytest.approx(2 / b + cap.height, rel=1e-15)  # the pressure at the table


def test_sessile_against_solve_ivp_shooting():
    """The same drop's end point by scipy from the apex radius found here (an independent integrator)."""
    cap = md.analytic(revolution(120, 1.0))
    b = cap.apex_radius
    r, z, phi, vol = _scipy_profile(b * b, 1, cap.profile.s[-1])
    assert phi == pytest.approx(math.radians(120), abs=1e-10)
    assert b * r == pytest.approx(cap.contact_radius, rel=1e-10) and b * z == pytest.approx(cap.height, rel=1e-10)
    assert b ** 3 * vol == pytest.approx(1.0, rel=1e-10)


def test_pendant_fold_of_the_shooting():
    fold = md.revolution_fold(revolution(90, 1.0, pendant=True))
    assert abs(fold.volume - 3.411028) <= 0.5e-6  # the value; 3.4110285 here
    with pytest.raises(md.BeyondFold):
        md.analytic(revolution(90, 3.4111, pendant=True))
    below = md.analytic(revolution(90, 3.4, pendant=True))
    assert below.volume == pytest.approx(3.4, rel=1e-10)


def test_spherical_cap_formulas():
    cap = md.analytic(revolution(60, 1.0, rho_g=0.0))
    R, th = cap.radius, math.radians(60)
    assert cap.volume == pytest.approx(1.0, rel=1e-15)
    assert cap.pressure == 2 / R and cap.height == pytest.approx(R / 2, rel=1e-15)
    # the identity without gravity: V = π r_c² (2/R) − 2π r_c sin θ ... + π r_c² h term vanishes with ρg
    assert math.pi * cap.contact_radius ** 2 * 2 / R - 2 * math.pi * cap.contact_radius * math.sin(th) == \
        pytest.approx(0.0, abs=1e-14)


# ----------------------------------------------------------------------------- the NLP
NS = [50, 100, 200, 400]
RIM = ("contact_angle", "contact_radius", "pressure", "energy")


@pytest.mark.parametrize("deg, volume, rho_g", [(60, 1.0, 0.0), (120, 1.0, 0.0), (90, 1.0, 1.0)],
                         ids=["cap60", "cap120", "sessile90"])
def test_second_order_against_the_oracles(deg, volume, rho_g):
    """The rim's readings and the integrals at order 2; the height (the apex vertex, on the axis) at order 2
    up to a logarithm: e N² grows by a constant per doubling of N."""
    drop = revolution(deg, volume, rho_g)
    errs = {k: [] for k in (*RIM, "height", "apex_curvature")}
    for n in NS:
        sol = dl.solve(drop, n)
        assert sol.success, sol.message
        assert sol.volume == pytest.approx(volume, rel=1e-9)
        for k in errs:
            errs[k].append(sol.errors[k])
    for k in RIM:
        assert 1.9 <= observed_order(NS, errs[k]) <= 2.1, (k, errs[k])
    h = np.array(errs["height"]) * np.array(NS) ** 2  # measured (60°) 1.16, 1.29, 1.41, 1.54: + 0.18 ln N
    steps = np.diff(h)
    assert np.all(steps > 0) and np.ptp(steps) < 0.15 * np.mean(steps)  # e N² = a + b ln N
    assert h[-1] < 100.0 and 1.8 <= observed_order(NS, errs["height"]) <= 2.0
    assert errs["apex_curvature"][-1] < 1e-5  # (P − g ρg h)/2γ: measured 4.6e-7 to 1.2e-6 at N = 400


def test_pressure_is_the_volume_multiplier_and_the_identity():
    """P against 2γ/b + ρg h of the oracle, against dE*/dV of the discrete optimum, and the identity
    V = π r_c² P − 2π r_c γ sin θ (ρg = 1) from the NLP's readings at the discretisation's order."""
    drop, n = revolution(90, 1.0), 200
    sol = dl.solve(drop, n)
    cap = sol.analytic
    assert abs(sol.pressure - cap.pressure) / cap.pressure < 10 / n ** 2  # measured 0.12 / N²
    balance = math.pi * sol.contact_radius ** 2 * sol.pressure - 2 * math.pi * sol.contact_radius * math.sin(
        sol.contact_angle)
    assert abs(balance - 1.0) < 100 / n ** 2  # measured 1.65 / N²
    eps = 1e-4
    up, down = dl.solve(revolution(90, 1 + eps), n), dl.solve(revolution(90, 1 - eps), n)
    assert sol.pressure == pytest.approx((up.energy - down.energy) / (2 * eps), rel=1e-6)


def test_fold_of_the_pendant_family_of_revolution():
    exact = md.revolution_fold(revolution(90, 1.0, pendant=True)).volume
    ns = [20, 40]
    sols = [dl.solve(revolution(90, 4.0, pendant=True), n) for n in ns]
    assert all(s.status == dl.NO_STABLE_DROP and not s.success for s in sols)
    assert all("no stable pendant drop of volume 4" in s.message and "3.411028" in s.message for s in sols)
    assert all(s.stability["reduced_hessian"]["positive_definite"] for s in sols)  # the last drop is a minimum
    found = [s.stability["fold"]["area"] for s in sols]
    errs = [(a - exact) / exact for a in found]  # measured 2.31e-3, 5.83e-4 (and 1.46e-4 at N = 80)
    assert all(e > 0 for e in errs) and 1.9 <= observed_order(ns, errs) <= 2.1
    assert errs[-1] * ns[-1] ** 2 < 100.0  # measured 0.93


def test_terms_are_composed():
    """A weightless drop of revolution carries no gravity; a 2-D drop no term of revolution."""
    fam = lambda d: [f["name"] for f in dl.make_nlp(d, 30)[0].anatomy()["families"]]  # noqa: E731
    assert "gravity" not in fam(revolution(60, 1.0, 0.0)) and "gravity" in fam(revolution(60, 1.0))
    assert "surface" in fam(revolution(60, 1.0)) and "surface" not in fam(md.Droplet())


# ----------------------------------------------------------------------------- the script
def test_script_axisymmetric_json_and_plot(tmp_path):
    out = tmp_path / "drop.png"
    p = _run("--axisymmetric", "--gravity", "1", "--gamma-sl", "1", "--area", "10", "--n", "60", "--json",
             "--plot", str(out))
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    for k in ("volume", "contact_radius", "height", "apex_curvature", "pressure_at_table", "x", "y"):
        assert k in d
    assert d["axisymmetric"] and d["volume"] == pytest.approx(10.0, rel=1e-9)
    assert abs(d["height"] - 1.244156) < 1e-3 and abs(d["contact_radius"] - 1.953168) < 1e-3
    assert d["x"][0] == 0.0 and d["y"][-1] == 0.0  # the half profile from the apex on the axis
    assert out.stat().st_size > 10_000


@pytest.mark.parametrize("args, needle", [
    (["--formulation", "graph"], "curve or spectral formulation"), (["--span", "1"], "pinned contact radius"),
    (["--area", "-1"], "positive"), (["--gravity", "-1"], ">= 0"),
])
def test_script_refuses_bad_axisymmetric_input(args, needle):
    p = _run("--axisymmetric", *args, "--json")
    assert p.returncode == 2 and p.stdout == ""
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0] and "Traceback" not in p.stderr


# ----------------------------------------------------------------------------- flat, beading and heavy extremes
@pytest.mark.parametrize("deg, measured", [(3, 1.2e-4), (10, 1.2e-4), (30, 1.2e-4), (170, 1.6e-4)])
def test_flat_and_beading_caps_of_revolution(deg, measured):
    """The weightless drop of revolution from 3° to 170° at N = 100, against the spherical cap (its start is the
    cap of Young's angle, resampled: the discrete optimum is not, and Ipopt must find it).  From the hemisphere
    the 30° drop crossed the axis and its energy ran to -87, and the 10° one did not converge."""
    sol = dl.solve(revolution(deg, 1.0, 0.0), 100)
    assert sol.success, sol.message
    assert sol.errors["height"] < 100 * measured
    assert abs(sol.contact_angle - math.radians(deg)) < 100 * 2.2e-3 * math.radians(deg)  # measured 2.2e-3 at 170°
    assert np.all(sol.x[1:] > 0.0)  # the profile stays off the axis


def test_heavy_drop_of_revolution_at_bond_100_at_second_order():
    """Bond 100 at 60° (V = 1000 l_c³): the height against the Young–Laplace shooting at N = 100 and 400 at order
    about 2 (measured 1.23e-4, 7.7e-6: order 2.0).  The family is followed on the coarse polyline, then refined.
    Before, the apex node sat on the axis below the drop (a chord along the axis has no area and no volume)."""
    drop = revolution(60, 100.0 ** 1.5, 1.0)
    errs = []
    for n in (100, 400):
        sol = dl.solve(drop, n)
        assert sol.success, sol.message
        errs.append(sol.errors["height"])
    assert errs[-1] < 100 * 7.7e-6 and 1.8 <= observed_order((100, 400), errs) <= 2.2


def test_puddle_beyond_the_shooting_is_said():
    """A puddle so flat that its apex radius overflows (θ = 8.1°, Bo = 1000): the oracle says why it has no answer
    (it raised an OverflowError before), and the solve reports the drop with that warning and no errors."""
    drop = revolution(8.1, 1000.0 ** 1.5, 1.0)
    sol = dl.solve(drop, 100)  # (its oracle raised the ValueError that the warning quotes)
    assert sol.success and sol.errors == {}
    assert any("beyond the shooting" in w for w in sol.warnings)
