"""Coulomb friction on held contacts (#25): a block on a floor and on an incline against the closed forms.

A block (a point mass) on the plane y = 0, s along the plane, gravity g at the angle α (from the normal),
friction μ: launched along a flat floor at v₀ it stops after v₀/(μg) at v₀²/(2μg); on an incline from
rest it sticks iff tan α ≤ μ, else slides down at a = g(sin α − μ cos α); launched uphill it stops after
v₀²/(2g(sin α + μ cos α)).  Sliding at a constant deceleration, the midpoint positions are exact at the
nodes; a stop or a turn inside a step is resolved to first order in its time (the sub-node does not time
friction transitions yet).
"""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

import castrajectory as ct
from castrajectory.validation import InputError

G = 9.81


def block(alpha: float, mu: float):
    q = ca.SX.sym("q", 2)
    qd = ct.velocity(q)
    return ct.LagrangianSystem(q, ct.Atoms([q], [1.0]), [ct.Gravity(G, direction=(-math.sin(alpha), -math.cos(alpha)))],
                               names=["s", "y"], contact=ct.Contact([q[1]], restitution=0.0, friction=mu, slip=[qd[0]]))


@pytest.mark.parametrize("N", [100, 400])
def test_a_block_sliding_on_a_floor_stops_where_coulomb_says(N):
    """v₀ = 2, μ = 0.5: at rest at v₀²/(2μg) = 0.40774720 (measured to 5.6e-17 m at N = 100 and 400: the stop's
    step times it at its sub-node), its position exact at every node while it slides (1e-15), stuck after
    (velocity 0 to 1e-26); certified by the march's branch."""
    run = ct.simulate(block(0.0, 0.5), [0.0, 0.0], [2.0, 0.0], 0.6, N)
    assert run.success
    t, x, v = run.t, run.q[:, 0], run.v[:, 0]
    stop = 2.0 / (0.5 * G)
    sliding = t < stop - 2 * (t[1] - t[0])
    assert np.max(np.abs(x[sliding] - (2.0 * t[sliding] - 0.25 * G * t[sliding] ** 2))) < 1e-12
    assert abs(x[-1] - 4.0 / (2 * 0.5 * G)) < 1e-13
    assert np.max(np.abs(v[t > stop + 2 * (t[1] - t[0])])) < 1e-15
    assert np.max(np.abs(run.q[:, 1])) < 1e-15


@pytest.mark.parametrize("alpha,mu,v0", [(0.3, 0.5, 0.0), (0.6, 0.5, 0.0), (0.3, 0.5, 2.0)])
def test_a_block_on_an_incline(alpha, mu, v0):
    """From rest: sticks for tan α ≤ μ (0.309 < 0.5: it does not move, measured |q| ≤ 1.7e-49 -- the held steps'
    Newton in one call leaves that much of its start), slides down at g(sin α − μ cos α) otherwise (0.684 > 0.5:
    s(1) = −0.74543574, measured to 1e-14); launched uphill at 2 m/s with tan α ≤ μ: stops at
    v₀²/(2g(sin α + μ cos α)) = 0.26367905 (to 8e-16 at N = 200: the stop's step times it at its sub-node) and
    stays."""
    run = ct.simulate(block(alpha, mu), [0.0, 0.0], [v0, 0.0], 1.0, 200)
    assert run.success
    s_end = run.q[-1, 0]
    if v0 == 0 and math.tan(alpha) <= mu:
        assert np.max(np.abs(run.q)) <= 1e-40
    elif v0 == 0:
        a = G * (math.sin(alpha) - mu * math.cos(alpha))
        assert abs(s_end + 0.5 * a) < 1e-12 and abs(run.v[-1, 0] + a) < 1e-12
    else:
        dist = v0 ** 2 / (2 * G * (math.sin(alpha) + mu * math.cos(alpha)))
        assert abs(s_end - dist) < 1e-13 and run.v[-1, 0] == pytest.approx(0.0, abs=1e-15)


@pytest.mark.parametrize("alpha,N", [(0.3, 100), (0.3, 200), (0.6, 100), (0.6, 200), (0.6, 800)])
def test_a_slip_that_stops_or_turns_inside_a_step_is_timed_by_its_sub_node(alpha, N):
    """Launched uphill at 2 m/s (μ = 0.5): on tan α ≤ μ the slip stops and the block sticks, else it turns and slides
    back.  The step holding the stop or the turn is split at it (mode W: its sub-node where the slip velocity,
    after the contact's share of the first part's force, vanishes; sliding before, sticking or sliding back
    after), so every node lies on the closed form's path to rounding (measured 8e-16 to 6e-15 m; before, the
    turn inside a step was first order: 9.2e-4 m at N = 200, 5.4e-4 at 800), and the stop is read at its sub-node
    (to 5e-16 s); a turn is not a stop."""
    from castrajectory.models import collision as col
    from castrajectory.solve import trajectory
    s = col.sliding_block(1.0, 0.5, alpha, G)
    tr = trajectory.solve_initial_value(s, [0.0, 0.0], [2.0, 0.0], 1.0, N)
    assert tr.success, tr.message
    path, stop = col.sliding_block_oracle(2.0, 0.5, alpha, G, tr.t)
    assert np.max(np.abs(tr.q[:, 0] - path)) < 1e-13
    kinds = [kind for _, _, kind in tr.slip_turns]
    if stop is None:
        assert kinds == ["turn"] and tr.slip_stops(0) == []
    else:
        assert kinds == ["stop"] and abs(tr.slip_stops(0)[0] - stop) < 1e-13


def test_friction_zero_keeps_the_frictionless_program():
    """friction = 0 builds no friction variable or row: the same element functions and the same answer."""
    from castrajectory.discretise.contact.elements import ContactMechanics
    q = ca.SX.sym("q", 2)
    qd = ct.velocity(q)
    plain = ct.LagrangianSystem(q, ct.Atoms([q], [1.0]), [ct.Gravity(G)], contact=ct.Contact([q[1]], 0.5))
    zero = ct.LagrangianSystem(q, ct.Atoms([q], [1.0]), [ct.Gravity(G)],
                               contact=ct.Contact([q[1]], 0.5, friction=0.0, slip=[qd[0]]))
    a, b = ContactMechanics(plain, "midpoint"), ContactMechanics(zero, "midpoint")
    assert not b.friction and a.march_step.n_in() == b.march_step.n_in() and a.sub.n_in() == b.sub.n_in()
    ra = ct.simulate(plain, [0.0, 1.0], [1.0, 0.0], 1.5, 300)
    rb = ct.simulate(zero, [0.0, 1.0], [1.0, 0.0], 1.5, 300)
    assert np.array_equal(ra.q, rb.q)


@pytest.mark.parametrize("kwargs,needle", [
    ({"friction": 0.5}, "slip velocity"),
    ({"friction": -0.1, "slip": ["v"]}, ">= 0"),
    ({"friction": [0.1, 0.2], "slip": ["v"]}, "one number per contact"),
    ({"friction": 0.5, "slip": ["v2"]}, "linear in the velocity"),
])
def test_bad_friction_is_refused(kwargs, needle):
    q = ca.SX.sym("q", 2)
    qd = ct.velocity(q)
    slip = {"v": [qd[0]], "v2": [qd[0] ** 2]}
    kw = dict(kwargs)
    if "slip" in kw:
        kw["slip"] = slip[kw["slip"][0]]
    with pytest.raises(InputError, match=needle):
        s = ct.LagrangianSystem(q, ct.Atoms([q], [1.0]), [ct.Gravity(G)], contact=ct.Contact([q[1]], 0.0, **kw))
        s.gap  # noqa: B018 - the system's checks run at construction


def _scene(*argv):
    import json
    import os
    import subprocess
    import sys
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    p = subprocess.run([sys.executable, os.path.join(root, "problems", "sliding_block.py"), *argv],
                       capture_output=True, text=True, timeout=300)
    return p, (json.loads(p.stdout) if p.returncode == 0 and "--json" in argv else None)


@pytest.mark.parametrize("argv,stop", [((), 2.0 / (0.5 * G)), (("--incline", "0.3"), 2.0 / (G * (math.sin(0.3) + 0.5 * math.cos(0.3)))),
                                       (("--incline", "0.6"), None)])
def test_the_sliding_block_scene(argv, stop):
    """problems/sliding_block.py: JSON t, s, v, stop_time (null if it never rests) against the closed form;
    the first node at rest within three steps after the stop (N = 200, h = 0.005), the path to rounding (measured 5.6e-17,
    8.3e-16 and 2.7e-15 m: the stop's or the turn's step times it at its sub-node; the turn of the 0.6 rad incline
    inside a step had been first order, 9e-4 m)."""
    p, d = _scene(*argv, "--n", "200", "--json")
    assert p.returncode == 0, p.stderr
    for key in ("t", "s", "v", "stop_time", "stop_time_exact", "error_vs_exact"):
        assert key in d
    if stop is None:
        assert d["stop_time"] is None and d["stop_time_exact"] is None
    else:
        # the stop inside its step, from the impulses (measured to 1e-15), the nodes at rest within 3 steps after
        assert abs(d["stop_time"] - stop) <= 1e-12 and abs(d["stop_time_exact"] - stop) < 1e-12
        assert 0 <= d["stop_node_time"] - stop <= 3 * 0.005
    assert d["error_vs_exact"] < 1e-13


def test_the_sliding_block_refuses_bad_input():
    for argv, needle in ((("--mu", "-1"), "--mu"), (("--incline", "2"), "--incline"), (("--T", "0"), "--T")):
        p, _ = _scene(*argv)
        assert p.returncode == 2 and needle in p.stderr and "Traceback" not in p.stderr


def _box(*argv):
    import importlib.util
    import os
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    spec = importlib.util.spec_from_file_location("pushed_box", os.path.join(root, "problems", "pushed_box.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.run(mod.parser().parse_args(list(argv)))


@pytest.mark.parametrize("mu,force,outcome", [(0.3, 2.93, "rests"), (0.3, 2.96, "slides"),
                                              (0.8, 4.88, "rests"), (0.8, 4.93, "tips")])
def test_a_pushed_box_slides_tips_or_rests_as_statics_says(mu, force, outcome):
    """problems/pushed_box.py (m = 1, b = 0.5, H = 1, h_p = 0.5; a ct.Force with contact and friction):
    within 0.5 % of the thresholds μ m g = 2.943 N (μ = 0.3 < b/(2h_p) = 0.5) and m g b/(2 h_p) = 4.905 N
    (μ = 0.8) the motion does what statics says; sliding, the centroid runs at (F − μ m g)/m exactly
    (x(T) to 1e-12)."""
    out = _box("--mu", str(mu), "--force", str(force))
    d = out.data
    assert out.success and d["outcome"] == d["outcome_exact"] == outcome
    if outcome == "slides":
        T = 0.5
        assert abs(d["q"][-1][0] - 0.5 * (force - mu * G) * T * T) < 1e-12


@pytest.mark.parametrize("body,v0,spin", [("disk", 2.0, 0.0), ("sphere", 2.0, 0.0), ("sphere", 1.0, 30.0),
                                          ("disk", 1.0, -20.0)])
def test_a_sliding_ball_ends_rolling_at_the_closed_form_speed(body, v0, spin):
    """problems/rolling_ball.py (R = 0.1, μ = 0.3, N = 200): the final speed (5v₀ + 2Rω₀)/7 (sphere) or
    (2v₀ + Rω₀)/3 (disk) to 1e-10 (measured 1e-12: the angular momentum about the contact point is kept by
    the discrete friction exactly), the rolling start within two steps after u₀ k/((1 + k) μ g) (measured
    1.3–1.4 steps: the transition inside a step is first order)."""
    import importlib.util
    import os
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    spec = importlib.util.spec_from_file_location("rolling_ball", os.path.join(root, "problems", "rolling_ball.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    out = mod.run(mod.parser().parse_args(["--body", body, "--v0", str(v0), "--spin", str(spin), "--n", "200"]))
    d = out.data
    assert out.success and abs(d["final_speed"] - d["final_speed_exact"]) < 1e-10
    # the slip's end inside its step, from the impulses (measured 3e-17 s); the nodes roll within 2 steps
    assert abs(d["rolling_time"] - d["rolling_time_exact"]) <= 1e-12
    assert 0 <= d["rolling_node_time"] - d["rolling_time_exact"] <= 2 * 1.0 / 200
    k = {"disk": 0.5, "sphere": 0.4}[body]
    assert abs(d["rolling_time_exact"] - abs(v0 - 0.1 * spin) * k / ((1 + k) * 0.3 * G)) < 1e-15


def _coulomb_residuals(d, mu_f):
    """Largest violations of the friction cone |ρ| <= μ_f, of maximal dissipation (ρ s <= 0: the friction
    never pushes along its slip), and of sticking (|ρ| < μ_f with a normal force: no slip), over every step,
    contact and part (node force, sub-node impulse), from an answer's JSON arrays."""
    rho, slip = np.asarray(d["friction_ratio"], float), np.asarray(d["slip"], float)
    normal = np.stack([np.asarray(d["nu"], float)[:rho.shape[0]], np.asarray(d["mu"], float)], axis=2)   # (N, c, 2)
    cone = float(np.max(np.abs(rho) - mu_f))
    work = float(np.max(rho * slip))
    inside = (np.abs(rho) < mu_f * (1 - 1e-6)) & (normal > 1e-12 * np.max(normal))
    stick = float(np.max(np.abs(slip[inside]))) if np.any(inside) else 0.0
    return cone, work, stick


@pytest.mark.parametrize("argv", [("--mu", "0.3", "--force", "2.96"), ("--mu", "0.8", "--force", "4.93"),
                                  ("--mu", "0.3", "--force", "2.0")])
def test_the_pushed_box_obeys_coulomb_step_by_step(argv):
    """Every step of the pushed box (sliding, tipping, resting): the ratios within the cone, the friction never
    along its slip, and where the ratio is inside the cone with a normal force, no slip -- whichever of the
    non-unique valid sets the march chose (two corners sticking share the friction in any valid way)."""
    out = _box(*argv)
    d = out.data
    assert out.success and d["outcome"] == d["outcome_exact"]
    cone, work, stick = _coulomb_residuals(d, float(argv[1]))
    assert cone <= 1e-14 and work <= 1e-14 and stick <= 1e-14, (cone, work, stick)   # measured 0, 2e-16, 4e-16


@pytest.mark.parametrize("case", ["disk", "sphere", "flat", "uphill", "downhill"])
def test_slip_stops_are_timed_inside_their_step(case):
    """ContactTrajectory.slip_stops reads when sliding ends from the impulses: the friction impulse until then
    is μ times the normal impulse over the sliding time, exact in the discrete solution for a constant normal
    force, so the rolling start and the stops on a floor or an incline come out to rounding (measured 3e-17 to
    2e-14 s at N = 100 and 400), where the nodes resolve them to one or two steps."""
    from castrajectory.models import collision as col
    from castrajectory.solve import trajectory
    for N in (100, 400):
        if case in ("disk", "sphere"):
            s = col.rolling_body(case, 1.0, 0.1, 0.3, G)
            tr = trajectory.solve_initial_value(s, [0.0, 0.1, 0.0], [1.0, 0.0, -30.0], 1.0, N)
            exact, _ = col.rolling_oracle(case, 1.0, 30.0, 0.1, 0.3, G)
        else:
            alpha, v0 = {"flat": (0.0, 2.0), "uphill": (0.3, 2.0), "downhill": (0.3, -1.0)}[case]
            tr = trajectory.solve_initial_value(col.sliding_block(1.0, 0.5, alpha, G), [0.0, 0.0], [v0, 0.0], 1.0, N)
            _, exact = col.sliding_block_oracle(v0, 0.5, alpha, G, tr.t)
        (stop,) = tr.slip_stops(0)
        assert abs(stop - exact) <= 1e-12


def test_a_pivot_that_starts_to_slip_converges_to_the_event_driven_reference():
    """The rectangle lands on a corner (e = 0, μ = 0.5), pivots on it sticking, and slips once its friction
    reaches the cone (at t = 0.4932 by the event-driven reference, which flies the pivot and the slide as
    phases and locates the switch to rounding).  The march's slip rows take the contact point's displacement
    with the slip Jacobian at each part's midpoint, so the pivot holds its point to O(h³) a step and the
    tangential impulses of the node and the sub-node stay equal shares: the answer converges at second order
    (measured 1.9e-6, 5.8e-7, 1.3e-7 at N = 110, 220, 440).  (With D at the part's start the first part's
    drift was O(h²), its tangential impulse took O(1) of the wrong share, the sub-node slot slid ten steps
    early and the error fell at first order: 3.9e-4, 2.0e-4, 9.8e-5.)"""
    from castrajectory.baselines.events import event_driven
    from castrajectory.models import collision as col
    from castrajectory.solve import trajectory
    s = col.rectangle_drop(1.0, 1.0, 0.5, 9.81, 0.0, friction=0.5)
    q0, v0, T = [0.0, 1.0, 0.4], [0.5, 0.0, 1.0], 0.55
    ref = event_driven(s, q0, v0, T)
    assert [w.kind for w in ref.switches] == ["slip"] and ref.reason == "horizon"
    qT = ref.state(T)[0]
    Ns = (110, 220, 440)
    errs = [float(np.max(np.abs(np.asarray(trajectory.solve_initial_value(s, q0, v0, T, N).q)[-1] - qT))) for N in Ns]
    slope = -np.polyfit(np.log(Ns), np.log(errs), 1)[0]
    assert slope > 1.7 and errs[-1] < 1e-6, (slope, errs)
