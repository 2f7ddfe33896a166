"""Rigid bodies in 3-D: the Dzhanibekov flip and the heavy top as whole-trajectory least action.

Oracles:
* the flip interval ``2K(m)/s`` checked against an independent numerical integration of
  Euler's equations (numpy RK4 here, no castrajectory code), and the value 27.530841 for
  I = (1, 2, 3), ω₀ = (1e-3, 1, 1e-3);
* the whole-trajectory flip interval converging at the scheme's order (2 and 4);
* discrete Noether: spatial L of the free body, L_z and L₃ of the top, to solver tolerance;
* the unit-quaternion constraint at every node; energy bounded without drift;
* the heavy top against Euler–Poisson integrated by CVODES, tilt and precession converging at
  the scheme's order;
* whole and marched solutions of the same discrete equations agree to solver tolerance.
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from castrajectory.baselines import rigidbody as euler
from castrajectory.inspect import rigidbody as readings
from castrajectory.models import rigidbody as rb
from castrajectory.solve import simulate
from castrajectory.validation import InputError

from helpers import observed_order

ROOT = Path(__file__).resolve().parents[1]
I123 = rb.Inertia(1.0, 2.0, 3.0)
W0 = np.array([1e-3, 1.0, 1e-3])
Q0 = np.array([1.0, 0.0, 0.0, 0.0])


def free_run(w0, T, N, scheme="midpoint", method="whole", inertia=I123):
    system = rb.free_body(inertia)
    run = simulate.simulate(system, Q0, rb.quaternion_rate(Q0, w0), T, N, scheme, method)
    assert run.success, run.message
    return system, run, readings.free_body(system, run, inertia, w0)


# ----------------------------------------------------------------------------- the oracle itself
def _euler_rk4_numpy(I, w0, T, n):
    """Body rates of the free body by plain RK4 on Euler's equations (independent of the package)."""
    I = np.asarray(I, float)
    f = lambda w: np.cross(I * w, w) / I  # noqa: E731
    h, w, out = T / n, np.asarray(w0, float), [np.asarray(w0, float)]
    for _ in range(n):
        k1 = f(w)
        k2 = f(w + h / 2 * k1)
        k3 = f(w + h / 2 * k2)
        k4 = f(w + h * k3)
        w = w + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        out.append(w)
    return np.linspace(0, T, n + 1), np.array(out)


def _zero_crossings(t, y):
    k = np.where(np.sign(y[:-1]) * np.sign(y[1:]) < 0)[0]
    return t[k] - y[k] * (t[k + 1] - t[k]) / (y[k + 1] - y[k])


def test_flip_interval_closed_form():
    assert rb.flip_interval(I123, W0) == pytest.approx(27.530841, abs=1e-6)


def _naive_interval(I, w):
    """Landau–Lifshitz's m and s formed from the invariants directly (cancellation near m = 1)."""
    I, w = np.asarray(I, float), np.asarray(w, float)
    E2, L2 = np.sum(I * w * w), np.sum((I * w) ** 2)
    Ia, Ib, Ic = np.sort(I)
    if L2 > E2 * Ib:
        m = (Ib - Ia) * (E2 * Ic - L2) / ((Ic - Ib) * (L2 - E2 * Ia))
        s = math.sqrt((Ic - Ib) * (L2 - E2 * Ia) / (Ia * Ib * Ic))
    else:
        m = (Ic - Ib) * (L2 - E2 * Ia) / ((Ib - Ia) * (E2 * Ic - L2))
        s = math.sqrt((Ib - Ia) * (E2 * Ic - L2) / (Ia * Ib * Ic))
    # K by its series in m: an independent route to the AGM of the code
    K, term, k = 0.0, 1.0, 0
    while term > 1e-17:
        K += term
        k += 1
        term *= ((2 * k - 1) / (2 * k)) ** 2 * m
    return math.pi * K / s


@pytest.mark.parametrize("I,w", [((1.0, 2.0, 3.0), (0.3, 1.0, 0.2)), ((2.0, 3.0, 4.5), (0.4, 0.8, 0.1)),
                                 ((1.0, 2.0, 3.0), (0.5, 0.2, 0.05))])
def test_flip_interval_cancellation_free_form_matches_the_naive_one_away_from_the_separatrix(I, w):
    # away from m = 1 the two forms agree to rounding; near it only the cancellation-free one keeps digits
    assert rb.flip_interval(rb.Inertia(*I), w) == pytest.approx(_naive_interval(I, w), rel=1e-12)


def test_flip_interval_keeps_its_digits_near_the_separatrix():
    # A relative change of 1e-15 in the large rate hardly moves r = L²/2E: the interval moves by
    # far less than the 4e-10 of the naive form's rounding.
    T0 = rb.flip_interval(I123, W0)
    for k in range(3):
        w = W0.copy()
        w[k] *= 1 + 1e-15
        assert abs(rb.flip_interval(I123, w) - T0) < 1e-12


def test_flip_interval_sensitivity_against_the_naive_form_away_from_the_separatrix():
    # far from m = 1 the naive closed form is accurate to rounding: its difference is the oracle
    I, w = (1.0, 2.0, 3.0), np.array([0.3, 1.0, 0.2])
    grad = rb.flip_interval_sensitivity(rb.Inertia(*I), w)
    for k in range(3):
        d = 1e-5
        wp, wm = w.copy(), w.copy()
        wp[k] += d
        wm[k] -= d
        assert grad[k] == pytest.approx((_naive_interval(I, wp) - _naive_interval(I, wm)) / (2 * d), rel=1e-6)
    # near the separatrix: the small rates dominate (figures of the docstring)
    g = rb.flip_interval_sensitivity(I123, W0)
    assert g == pytest.approx([1732.0, -24.07, -5196.2], rel=1e-3)


@pytest.mark.slow       # (16 s a case: the default run is at its 10-minute guideline; the closed form's own tests,
#                         test_flip_interval_closed_form and the separatrix ones, stay in it)
@pytest.mark.parametrize("inertia,w0", [((1.0, 2.0, 3.0), (0.05, 1.0, 0.02)),
                                        # (the RK4 integration of Euler's equations against the closed form)
                                        pytest.param((2.0, 3.0, 4.5), (0.1, 0.8, 0.0),   # L² < 2E I₂ side
                                                     marks=pytest.mark.slow),
                                        pytest.param((1.0, 2.0, 3.0), (0.0, 1.0, 0.05), marks=pytest.mark.slow)])
def test_flip_interval_against_numerical_euler(inertia, w0):
    t, w = _euler_rk4_numpy(inertia, w0, 200.0, 200_000)
    flips = _zero_crossings(t, w[:, 1])
    assert flips.size >= 3
    assert np.mean(np.diff(flips)) == pytest.approx(rb.flip_interval(rb.Inertia(*inertia), w0), rel=1e-6)


def test_elliptic_k_known_values():
    assert rb.elliptic_k(0.0) == pytest.approx(math.pi / 2, rel=1e-15)
    assert rb.elliptic_k(0.5) == pytest.approx(1.8540746773013719, rel=1e-14)


# ----------------------------------------------------------------------------- the flip
@pytest.mark.parametrize("scheme,ns,order", [("midpoint", (1400, 2800, 5600), 2.0),
                                             ("galerkin4", (350, 500, 700), 4.0)])
def test_flip_interval_order(scheme, ns, order):
    """Three flips within T = 70 s; the flip interval converges at the scheme's order.

    galerkin4 is measured where its error (1e-5 .. 3e-6) is well above the floor that the solver's
    tolerance sets on this near-separatrix start (about 1e-7 .. 1e-6: docs/derivations.md, rigid bodies, §6).
    """
    errs = []
    for n in ns:
        _, _, r = free_run(W0, 70.0, n, scheme)
        assert r["flip_times"].size == 3
        errs.append(r["flip_interval_error"])
    assert observed_order(ns, errs) == pytest.approx(order, abs=0.3)
    assert errs[-1] < (5e-3 if order == 2 else 5e-6)


@pytest.mark.parametrize("w0", [(1e-2, 1e-2, 1.0), (1.0, 1e-2, 1e-2)], ids=["major", "minor"])
def test_major_and_minor_axis_spins_are_stable(w0):
    _, run, r = free_run(w0, 60.0, 1200)
    axis = int(np.argmax(np.abs(w0)))
    assert r["flip_times"].size == 0 and r["flip_interval_exact"] is None
    # the spin component keeps its sign and stays near its start; the others stay small
    assert np.all(r["omega"][:, axis] > 0.9 * w0[axis])
    others = [i for i in range(3) if i != axis]
    assert np.max(np.abs(r["omega"][:, others])) < 0.05


def test_conservation_free_body():
    """Spatial L to solver tolerance (discrete Noether), |q| = 1 at every node, energy without drift."""
    system, run, r = free_run(W0, 100.0, 2000, "trapezoid")
    assert r["flip_times"].size == 4
    assert r["angular_momentum_drift"] <= 1e-9
    assert r["quaternion_norm_error"] <= 1e-10
    # the energy error of a variational integrator is O(h²) and bounded: it does not grow
    E = np.asarray(run.energy)
    assert r["energy_drift"] <= 1e-3
    assert np.max(np.abs(E[E.size // 2:] - E[0])) <= 1.5 * np.max(np.abs(E[:E.size // 2] - E[0]))


@pytest.mark.slow
def test_twenty_flips_energy_bounded():
    _, run, r = free_run(W0, 560.0, 11200)
    assert r["flip_times"].size == 20
    assert r["angular_momentum_drift"] <= 1e-9 and r["quaternion_norm_error"] <= 1e-10
    E = np.asarray(run.energy)
    half = E.size // 2
    # bounded, no drift: the second half wanders no further than the first
    assert np.max(np.abs(E[half:] - E[0])) <= 2 * np.max(np.abs(E[:half] - E[0])) + 1e-12


def test_time_stepper_drifts_where_the_variational_solution_does_not():
    """RK4 on Euler's equations (no renormalisation): |q| and |L| drift at the step's order."""
    system = rb.free_body(I123)
    st = euler.euler_rk4(system, I123.moments, Q0, W0, 100.0, 2000)
    q = st.q
    assert np.max(np.abs(np.linalg.norm(q, axis=1) - 1.0)) > 1e-10
    p = np.asarray(system.momentum.map(q.shape[0])(q.T, st.qd.T, 0.0)).T
    L = rb.spatial_momentum(q, p)
    assert readings.drift(L) > 1e-9


@pytest.mark.parametrize("scheme", ["midpoint", "trapezoid", "galerkin4"])
def test_whole_equals_march(scheme):
    _, whole, _ = free_run((0.2, 1.0, 0.1), 20.0, 400, scheme)
    _, march, _ = free_run((0.2, 1.0, 0.1), 20.0, 400, scheme, method="march")
    assert np.max(np.abs(whole.q - march.q)) < 1e-8


def test_spatial_momentum_is_R_I_omega():
    """The momentum map of the left action, at continuous momenta, is the spatial L = R I ω."""
    system = rb.free_body(I123)
    rng = np.random.default_rng(1)
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    w = rng.normal(size=3)
    qd = rb.quaternion_rate(q, w)
    p = np.asarray(system.momentum(q, qd)).reshape(-1)
    L = rb.spatial_momentum(q, p)[0]
    assert np.allclose(L, rb.rotation(q) @ (I123.moments * w), atol=1e-13)
    assert np.allclose(rb.body_momentum(q, p)[0], I123.moments * w, atol=1e-13)
    assert np.allclose(rb.body_rates(q, qd), w, atol=1e-13)
    assert float(system.energy(q, qd)) == pytest.approx(0.5 * float(w @ (I123.moments * w)), rel=1e-13)


def test_box_inertia_and_refusals():
    box = rb.Inertia.box(0.3, 1.0, 2.0, 1.0)
    assert np.allclose(box.moments, [(1 + 4) / 12, (0.09 + 4) / 12, (0.09 + 1) / 12])
    for bad, needle in [((0.0, 1.0, 1.0), "positive"), ((-1.0, 1.0, 1.0), "positive"),
                        ((1.0, 1.0, float("nan")), "finite"), ((1.0, 1.0, 2.5), "triangle")]:
        with pytest.raises(InputError, match=needle):
            rb.Inertia(*bad)
    with pytest.raises(InputError, match="positive"):
        rb.Inertia.box(0.3, -1.0, 2.0, 1.0)
    rb.Inertia(1.0, 1.0, 2.0)  # a flat plate: the triangle's equality is allowed


# ----------------------------------------------------------------------------- heavy top
TOP = dict(mass=1.0, inertia=rb.Inertia(0.002, 0.002, 0.004), distance=0.1, g=9.81)


def _top_start(tilt=0.3, spin=100.0, precession=0.0):
    q0 = rb.axis_angle([1.0, 0.0, 0.0], tilt)
    R = rb.rotation(q0)
    wb = R.T @ (precession * np.array([0.0, 0.0, 1.0]) + spin * R[:, 2])
    return q0, wb


def _top_run(T, N, scheme):
    system = rb.heavy_top(**TOP)
    q0, wb = _top_start()
    run = simulate.simulate(system, q0, rb.quaternion_rate(q0, wb), T, N, scheme)
    assert run.success, run.message
    return system, run, readings.heavy_top(system, run)


def _top_reference(t):
    q0, wb = _top_start()
    pivot = TOP["inertia"].about(TOP["mass"], [0.0, 0.0, TOP["distance"]])
    q, _ = euler.euler_reference(pivot.moments, q0, wb, t, weight=TOP["mass"] * TOP["g"],
                                 com=[0.0, 0.0, TOP["distance"]])
    a = rb.rotation(q)[:, :, 2]
    return np.arccos(a[:, 2]), np.unwrap(np.arctan2(a[:, 0], -a[:, 1]))


@pytest.mark.parametrize("scheme,ns,order", [("midpoint", (1000, 2000, 4000), 2.0),
                                             ("galerkin4", (250, 500, 1000), 4.0)])
def test_heavy_top_converges_to_euler_poisson(scheme, ns, order):
    T = 0.5
    tilt_ref, prec_ref = _top_reference(np.array([0.0, T]))
    e_tilt, e_prec = [], []
    for n in ns:
        system, run, r = _top_run(T, n, scheme)
        e_tilt.append(abs(r["tilt"][-1] - tilt_ref[-1]))
        e_prec.append(abs(r["precession"][-1] - prec_ref[-1]))
        assert r["angular_momentum_vertical_drift"] <= 1e-9
        assert r["angular_momentum_axis_drift"] <= 1e-9
        assert r["quaternion_norm_error"] <= 1e-10
    assert observed_order(ns, e_prec) == pytest.approx(order, abs=0.35)
    assert observed_order(ns, e_tilt) == pytest.approx(order, abs=0.35)


def test_heavy_top_energy_bounded():
    """Over 2 s (about 30 nutations): the energy error oscillates at O(h²) without drift."""
    system, run, r = _top_run(2.0, 2000, "midpoint")
    E = np.asarray(run.energy)
    dE = np.abs(E - E[0])
    assert np.max(dE) / abs(E[0]) < 1e-4
    assert np.max(dE[E.size // 2:]) <= 1.5 * np.max(dE[:E.size // 2])
    assert r["angular_momentum_vertical_drift"] <= 1e-9 and r["angular_momentum_axis_drift"] <= 1e-9


def test_heavy_top_without_gravity_is_a_free_symmetric_body():
    system = rb.heavy_top(1.0, rb.Inertia(0.002, 0.002, 0.004), 0.1, g=0.0)
    assert not system.potentials  # no gravity term when g = 0


# ----------------------------------------------------------------------------- scripts
ENV = {**os.environ, "MPLBACKEND": "Agg"}


def _script(name, *args):
    return subprocess.run([sys.executable, str(ROOT / "problems" / f"{name}.py"), *args],
                          capture_output=True, text=True, env=ENV, timeout=300)


def test_dzhanibekov_script_json(tmp_path):
    import json
    png, gif = tmp_path / "w.png", tmp_path / "flip.gif"
    p = _script("dzhanibekov", "--T", "60", "--n", "1200", "--json", "--plot", str(png), "--animate", str(gif))
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    for key in ("status", "iterations", "build_time_s", "solve_time_s", "scheme", "method", "t", "quaternion",
                "omega", "flip_times", "flip_interval_exact", "energy", "angular_momentum",
                "angular_momentum_norm"):
        assert key in d, key
    assert d["status"] == "ok" and len(d["flip_times"]) == 2
    assert d["flip_interval_exact"] == pytest.approx(27.530841, abs=1e-6)
    assert np.asarray(d["quaternion"]).shape == (1201, 4) and np.asarray(d["omega"]).shape == (1201, 3)
    assert png.stat().st_size > 1000 and gif.stat().st_size > 1000


def test_heavy_top_script_json():
    import json
    p = _script("heavy_top", "--T", "0.3", "--n", "600", "--json", "--reference")
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    for key in ("t", "quaternion", "tilt", "precession", "energy", "angular_momentum_vertical",
                "angular_momentum_axis"):
        assert key in d, key
    Lz = np.asarray(d["angular_momentum_vertical"])
    assert np.max(np.abs(Lz - Lz[0])) <= 1e-9 * abs(Lz[0])
    assert d["tilt_error"] < 1e-3


@pytest.mark.parametrize("name,args,needle", [
    ("dzhanibekov", ["--inertia", "0", "2", "3"], "must be positive"),
    ("dzhanibekov", ["--inertia", "1", "2", "nan"], "must be finite"),
    ("dzhanibekov", ["--inertia", "1", "1", "3"], "triangle"),
    ("dzhanibekov", ["--box", "1", "-2", "3"], "must be positive"),
    ("dzhanibekov", ["--box", "1", "2", "3", "--mass", "0"], "mass must be positive"),
    ("dzhanibekov", ["--box", "1", "2", "3", "--inertia", "1", "2", "3"], "not both"),
    ("dzhanibekov", ["--omega", "0", "0", "0"], "must not be zero"),
    ("dzhanibekov", ["--omega", "0", "inf", "0"], "must be finite"),
    ("dzhanibekov", ["--n", "1"], "n must be an integer >= 2"),
    ("dzhanibekov", ["--T", "0"], "T must be positive"),
    ("heavy_top", ["--inertia", "0.002", "0.005"], "triangle"),
    ("heavy_top", ["--mass", "-1"], "mass must be positive"),
    ("heavy_top", ["--distance", "0"], "distance must be positive"),
    ("heavy_top", ["--T", "-1"], "T must be positive"),
])
def test_rigid_body_scripts_refuse_bad_input(tmp_path, name, args, needle):
    out = tmp_path / "keep.png"
    out.write_bytes(b"earlier output")
    p = _script(name, *args, "--plot", str(out))
    assert p.returncode == 2, p.stderr
    assert p.stdout == ""
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0] and "Traceback" not in p.stderr
    assert out.read_bytes() == b"earlier output"
