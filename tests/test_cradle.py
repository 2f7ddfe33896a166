"""Newton's cradle and the impact laws (#25): problems/newtons_cradle.py against its oracles.

Oracles: the first impact's time (the pendulum's elliptic quadrature), and just after a touching row's
impact the speeds by the law: the sequential cascade of two-ball impacts (for e = 1 the last ball leaves
with the first's speed V, the others stop) or the simultaneous law's linear complementarity problem
(three balls, e = 1: (−1/3, 2/3, 2/3) V), each computed by the script with its own small algorithm.
"""
from __future__ import annotations

import importlib.util
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _cradle():
    spec = importlib.util.spec_from_file_location("newtons_cradle", os.path.join(ROOT, "problems", "newtons_cradle.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def run(*argv):
    mod = _cradle()
    return mod.run(mod.parser().parse_args(list(argv))).data


def test_the_chain_oracles_are_the_textbook_ones():
    mod = _cradle()
    v = np.array([1.0, 0, 0])
    assert np.allclose(mod.chain_after(v, 1.0, "simultaneous"), [-1 / 3, 2 / 3, 2 / 3], atol=1e-15)
    assert np.allclose(mod.chain_after(np.array([1.0, 0, 0, 0, 0]), 1.0, "sequential"), [0, 0, 0, 0, 1], atol=1e-15)
    # e = 0: both laws send the whole row off together at V/n (momentum kept)
    for law in ("simultaneous", "sequential"):
        assert np.allclose(mod.chain_after(v, 0.0, law), [1 / 3] * 3, atol=1e-12)


@pytest.mark.parametrize("law,balls", [("simultaneous", 3), ("sequential", 3), ("sequential", 5)])
def test_a_touching_row_follows_its_law(law, balls):
    """N = 200: the speeds after the impact within 1e-6 m/s of the law's (V = 1.5498 m/s; measured 1.7e-7
    simultaneous, 2.5e-7 sequential: the discrete arrival speed's own error; the impact time 2.5e-6 s), the
    energy within the
    midpoint rule's O(h²) wobble of the pendulum (8e-8 of ½mV², across the impact too), every contact of the
    row listed at the first impact."""
    d = run("--balls", str(balls), "--law", law, "--n", "200")
    assert d["speeds_error"] < 1e-6 and d["error_vs_exact"] < 1e-5      # measured 2.5e-7 and 2.5e-6
    assert d["first_impact_contacts"] == [f"{i + 1}-{i + 2}" for i in range(balls - 1)]
    E = np.asarray(d["energy"])
    assert np.max(np.abs(E - E[0])) < 1e-6 * 0.5 * d["impact_speed_exact"] ** 2   # measured 8e-8 of ½mV²


def test_the_first_impact_time_converges_at_second_order():
    """Midpoint between impacts: the first impact's time against the elliptic quadrature at order 2
    (measured errors 1.0e-5, 2.5e-6, 6.2e-7 at N = 100, 200, 400)."""
    errs = []
    for N in (100, 200, 400):
        d = run("--balls", "3", "--n", str(N))
        errs.append(abs(d["first_impact_time"] - d["first_impact_time_exact"]))
    orders = [math.log2(errs[i] / errs[i + 1]) for i in range(2)]
    assert all(abs(o - 2.0) < 0.1 for o in orders) and errs[-1] < 1.2e-6


def test_gaps_separate_the_impacts_and_the_laws_agree():
    """With gaps the row takes its impacts one after the other: both laws give the same motion (to
    rounding), and it approaches the sequential law's vanishing-gap limit as the gap shrinks (speeds off
    by 1.8e-5 at gap 1e-3, 1.8e-7 at 1e-4: quadratic in the gap)."""
    a = run("--gap", "1e-3", "--law", "sequential", "--n", "400")
    b = run("--gap", "1e-3", "--law", "simultaneous", "--n", "400")
    assert np.max(np.abs(np.asarray(a["q"]) - np.asarray(b["q"]))) < 1e-12
    c = run("--gap", "1e-4", "--law", "sequential", "--n", "400")
    assert a["first_impact_contacts"] == ["1-2"]
    assert c["speeds_error"] < 0.02 * a["speeds_error"] and a["speeds_error"] < 1e-4


@pytest.mark.parametrize("argv,needle", [(("--balls", "1"), "--balls"), (("--lift", "2"), "--lift"),
                                         (("--gap", "-1"), "--gap"), (("--restitution", "1.5"), "restitution")])
def test_bad_input_is_refused(argv, needle):
    p = subprocess.run([sys.executable, os.path.join(ROOT, "problems", "newtons_cradle.py"), *argv],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and needle in p.stderr and len(p.stderr.strip().splitlines()) == 1
    assert "Traceback" not in p.stderr


def test_json_holds_the_oracles():
    p = subprocess.run([sys.executable, os.path.join(ROOT, "problems", "newtons_cradle.py"), "--balls", "3",
                        "--n", "200", "--json"], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    for key in ("t", "q", "v", "impacts", "law", "first_impact_time", "first_impact_time_exact", "speeds_after",
                "speeds_after_exact", "error_vs_exact"):
        assert key in d, key
    assert len(d["impacts"]) == 2 and d["law"] == "sequential"


def test_a_cradle_with_gaps_against_the_event_driven_reference():
    """Gap 1e-3, three balls: the impacts come one after the other; their times converge at order 2 to the
    event-driven reference (a numerical flight, CasADi's order-12 collocation; measured 6.0e-7, 1.5e-7 s at
    N = 400, 800)."""
    from castrajectory.baselines.events import event_driven
    mod = _cradle()
    system = mod.cradle(3, 1.0, 1.0, 0.05, 1e-3, 1.0, "sequential", 9.81)
    q0 = np.array([-0.5, 0.0, 0.0])
    ref = event_driven(system, q0, np.zeros(3), 1.0)
    assert ref.reason == "horizon" and [ev.contacts for ev in ref.events] == [(0,), (1,)]
    errs = []
    for N in (400, 800):
        d = run("--balls", "3", "--gap", "1e-3", "--T", "1.0", "--n", str(N))
        errs.append(np.max(np.abs(np.sort([i["t"] for i in d["impacts"]]) - ref.times)))
    assert abs(math.log2(errs[0] / errs[1]) - 2.0) < 0.1 and errs[-1] < 4e-7

