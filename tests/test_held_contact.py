"""Held contacts at the scheme's order (docs/derivations.md, "Contact trajectories", §7): the contact's force and its
friction act at the stages, and a release is timed inside its step by the force of the continuous motion.

Oracles: the sliding ladder's reduced equation and its closed-form lift-off (sin θ* = ⅔ sin θ₀), the disk rolling in
a circular bowl (the reduced equation (3/2)(R − r)φ̈ = −g sin φ), the same disk sliding at μ = 0.05 against the
event-driven reference (its slip reversals).  Each fits the log-log slope over errors above 1e-11 and compares it
with the scheme's order."""
import math
import os
import runpy

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp

import castrajectory as ct
from castrajectory.baselines.events import event_driven

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LADDER = runpy.run_path(os.path.join(ROOT, "examples", "sliding_ladder.py"))
DISK = runpy.run_path(os.path.join(ROOT, "examples", "disk_in_bowl.py"))


def _slope(Ns, errors):
    return -np.polyfit(np.log(Ns), np.log(errors), 1)[0]


def _lift_off_time() -> float:
    """The ladder leaves the wall at sin θ* = ⅔ sin θ₀, at t* = ∫ dθ / θ̇ with θ̇² = (3g/L)(sin θ₀ − sin θ): scipy's
    adaptive quadrature in u = √(θ₀ − θ), the difference of sines written 2 cos(θ₀ − u²/2) sin(u²/2) (without
    cancellation; models.held.ladder_lift_off takes Gauss–Legendre on the same integrand, and agrees to 2e-16 s)."""
    th0, g, L = LADDER["theta0"], LADDER["g"], LADDER["L"]
    k = 3.0 * g / L
    ths = math.asin(2.0 / 3.0 * math.sin(th0))

    def f(u):
        if u == 0.0:
            return 2.0 / math.sqrt(k * math.cos(th0))
        return 2.0 * u / math.sqrt(2.0 * k * math.cos(th0 - 0.5 * u * u) * math.sin(0.5 * u * u))
    return quad(f, 0.0, math.sqrt(th0 - ths), epsabs=1e-14, epsrel=1e-14, limit=200)[0]


def _ladder_theta(t):
    g, L = LADDER["g"], LADDER["L"]
    s = solve_ivp(lambda _, z: [z[1], -1.5 * g / L * math.cos(z[0])], (0.0, float(t[-1])), [LADDER["theta0"], 0.0],
                  method="DOP853", rtol=1e-13, atol=1e-14, t_eval=t)
    return s.y[0]


def _ladder(scheme, N, T=0.5):
    r = ct.simulate(LADDER["system"](), LADDER["q0"], LADDER["qd0"], T, N, scheme=scheme)
    assert r.success, r.message
    return r


def test_the_ladder_held_on_the_wall_and_its_lift_off_are_fourth_order_with_galerkin4():
    """Before lift-off both ends are held (the wall's and the floor's forces at the stages): θ at t = 0.4 converges at
    order 4 (measured 4.40e-9, 2.75e-10, 1.72e-11 at N = 25, 50, 100; it was 8.9e-6 ... 5.6e-7, second order, for
    every scheme).  The lift-off is timed at its step's sub-node by the wall's force (mode E): 1.13e-8, 5.96e-10,
    3.72e-11 s from the closed form at N = 12, 25, 50."""
    tstar = _lift_off_time()
    errs = []
    for N in (25, 50, 100):
        r = _ladder("galerkin4", N)
        i = int(round(0.4 / 0.5 * N))
        errs.append(abs(r.q[i, 2] - _ladder_theta(np.array([0.0, 0.4]))[-1]))
        # the centre stays L/2 from the corner while both ends touch (the constraints the contacts hold)
        held = r.t <= tstar
        assert np.max(np.abs(np.hypot(r.q[held, 0], r.q[held, 1]) - 0.5 * LADDER["L"])) < 1e-12
    assert errs[-1] < 1e-10
    assert _slope([25, 50, 100], errs) == pytest.approx(4.0, abs=0.3), errs
    lift = []
    for N in (12, 25, 50):
        rel = [x for x in _ladder("galerkin4", N).detail.releases if x.contact == 0]
        assert len(rel) == 1 and rel[0].timed and not rel[0].at_impact
        lift.append(abs(rel[0].t - tstar))
    assert min(lift) > 1e-11
    assert _slope([12, 25, 50], lift) == pytest.approx(4.0, abs=0.3), lift


def test_the_ladder_lift_off_with_galerkin6_and_midpoint_at_their_orders():
    """galerkin6 times the lift-off to 6.5e-11 s on 5 steps (0.1 s each) and below 1e-12 s on 10; midpoint at order 2
    (8.2e-8, 2.1e-8, 5.1e-9 s at N = 200, 400, 800)."""
    tstar = _lift_off_time()
    rel = [x for x in _ladder("galerkin6", 5).detail.releases if x.contact == 0]
    assert rel[0].timed and abs(rel[0].t - tstar) < 3e-10
    rel = [x for x in _ladder("galerkin6", 10).detail.releases if x.contact == 0]
    assert rel[0].timed and abs(rel[0].t - tstar) < 1e-11
    lift = []
    for N in (200, 400, 800):
        rel = [x for x in _ladder("midpoint", N).detail.releases if x.contact == 0]
        assert rel[0].timed
        lift.append(abs(rel[0].t - tstar))
    assert _slope([200, 400, 800], lift) == pytest.approx(2.0, abs=0.3), lift


def _disk_error(scheme, N, T, mu=1.0):
    """The disk rolling in the bowl against the reduced equation: the largest error of the centre's angle φ and of
    r θ (θ = −(R − r)(φ − φ₀)/r while it rolls)."""
    D = DISK
    r = ct.simulate(D["system"](mu), D["q0"], D["qd0"], T, N, scheme=scheme)
    assert r.success, r.message
    Rr = D["R"] - D["r"]
    sol = solve_ivp(lambda t, y: [y[1], -D["g"] * math.sin(y[0]) / (1.5 * Rr)], (0.0, T), [D["phi0"], 0.0],
                    t_eval=r.t, rtol=1e-13, atol=1e-14, method="DOP853")
    phi = np.arctan2(r.q[:, 0], -r.q[:, 1])
    theta = -Rr * (sol.y[0] - D["phi0"]) / D["r"]
    err = max(np.max(np.abs(phi - sol.y[0])), D["r"] * np.max(np.abs(r.q[:, 2] - theta)))
    return err, r


@pytest.mark.parametrize("scheme,T,Ns", [
    ("midpoint", 1.0, (50, 100, 200)),
    ("galerkin4", 1.0, (25, 50, 100)),
    ("gauss4", 1.0, (25, 50, 100)),
    ("galerkin6", 4.0, (10, 14, 20)),
    ("galerkin8", 4.0, (8, 10, 14)),
])
def test_a_disk_rolling_in_a_bowl_converges_at_the_schemes_order(scheme, T, Ns):
    """Sticking friction at the stages (the contact point's displacement held at zero there): the disk rolls at the
    scheme's order (measured: midpoint 4.1e-5, 1.0e-5, 2.6e-6; galerkin4 7.9e-9, 4.9e-10, 3.1e-11; galerkin6 over
    4 s 3.7e-6, 4.9e-7, 5.8e-8; galerkin8 1.0e-7, 1.8e-8, 1.2e-9).  Before, every scheme was second order here."""
    errs, ests = [], []
    for N in Ns:
        e, r = _disk_error(scheme, N, T)
        errs.append(e)
        ests.append(r.error_estimate.errors["q"])
    order = ct.schemes()[scheme]
    assert min(errs) > 1e-11
    assert _slope(Ns, errs) == pytest.approx(order, abs=0.3), errs
    # the estimate measures it too (within 10x of the true error on the finest grid)
    assert errs[-1] / 10 <= ests[-1] <= 10 * errs[-1], (ests, errs)


def test_a_disk_sliding_in_a_bowl_reverses_stops_and_restarts_its_slip_at_the_schemes_order():
    """μ = 0.05 over 3 s: the disk slides, its slip reversing twice, stopping, and starting again when the sticking force
    reaches the cone (the event-driven reference: reversals at 0.714778, 1.769606 s, a stop at 2.576312 s, a start at
    2.603804 s).  Sliding and sticking friction at the stages; the reversals and the stop timed at their steps'
    sub-nodes by the slip velocity (mode W), the start by the cone margin of the continuous motion (mode G).  galerkin4,
    N = 150, 300, 600: configuration 6.4e-9, 5.1e-10, 2.4e-11; the four events 2.6e-9, 1.8e-10, 1.1e-11 s."""
    D = DISK
    system = D["system"](0.05)
    ref = event_driven(system, np.array(D["q0"]), np.array(D["qd0"]), 3.0)
    events = sorted(s.t for s in ref.switches if s.kind in ("stop", "slip"))
    assert len(events) == 4
    qerr, terr = [], []
    for N in (150, 300, 600):
        r = ct.simulate(system, D["q0"], D["qd0"], 3.0, N, scheme="galerkin4")
        assert r.success, r.message
        qerr.append(np.max(np.abs(r.q - np.array([ref.state(t)[0] for t in r.t]))))
        timed = r.detail.slip_turns
        assert [k for _, _, k in sorted(timed)] == ["turn", "turn", "stop", "start"]
        terr.append(max(abs(a - b) for a, b in zip(sorted(t for t, _, _ in timed), events)))
        assert r.detail.slip_starts(0)[0] == pytest.approx(events[3], abs=1e-8)
    assert qerr[-1] < 1e-10 and _slope([150, 300, 600], qerr) == pytest.approx(4.0, abs=0.3), qerr
    assert _slope([150, 300, 600], terr) == pytest.approx(4.0, abs=0.3), terr


def _sphere_case():
    """A sphere (r = 0.2) rolling inside a spherical bowl (R = 1, μ = 1): from 0.4 rad up the bowl, moving sideways
    at 0.8 m/s without slipping and spinning at 0.5 rad/s about the normal, so that it rolls round the bowl in 3-D."""
    from castrajectory.models import rigidbody as rb
    r, Rb = 0.2, 1.0
    system = rb.sphere_in_bowl(1.0, r, Rb, 1.0, 9.81)
    c0 = (Rb - r) * np.array([math.sin(0.4), 0.0, -math.cos(0.4)])
    n0 = c0 / np.linalg.norm(c0)
    v0 = np.array([0.0, 0.8, 0.0])
    w0 = np.cross(v0, n0) / r + 0.5 * n0
    quat0 = rb.axis_angle([0.3, 0.2, 1.0], 0.3)
    R0 = np.asarray(rb.rotation(quat0), float)
    q0 = np.concatenate([c0, quat0])
    qd0 = np.concatenate([v0, rb.quaternion_rate(quat0, R0.T @ w0)])
    return system, q0, qd0


def _rolling_reference(system, q0, qd0, T):
    """Our own reference for the rolling sphere: the continuous index-1 DAE with the contact held and sticking and the
    quaternion on its sphere, ``M q̈ = f + Gᵀ Λ``, ``G q̈ + (G q̇)_q q̇ = 0`` (G the constraint's, the gap's and the slip's
    Jacobians), integrated by scipy's DOP853 at 1e-13: independent of the discretisation."""
    import casadi as ca
    q, qd = system.q, system.qd
    M, f = system.dynamics_exprs()
    G = ca.vertcat(system.constraint(q)[1], system.gap(q)[1], system.tangent(q))
    K = ca.blockcat([[M, -G.T], [G, ca.SX.zeros(G.shape[0], G.shape[0])]])
    sol = ca.solve(K, ca.vertcat(f, -ca.jtimes(ca.mtimes(G, qd), q, qd)))
    acc = ca.Function("acc", [q, qd], [sol[:q.numel()]])
    n = q.numel()
    out = solve_ivp(lambda t, y: np.concatenate([y[n:], np.asarray(acc(y[:n], y[n:])).reshape(-1)]), (0.0, T),
                    np.concatenate([q0, qd0]), method="DOP853", rtol=1e-13, atol=1e-14, dense_output=True)
    return lambda t: out.sol(t)[:n].T


@pytest.mark.parametrize("scheme,Ns", [("galerkin4", (20, 40, 80)), ("galerkin6", (10, 20))])
def test_a_sphere_rolling_in_a_spherical_bowl_converges_at_the_schemes_order(scheme, Ns):
    """The 3-D circular cone, sticking: the contact point's displacement on the tangent plane held at zero at the
    stages, a nonholonomic constraint (the slip is not the rate of a function of q).  Over 1 s (measured: galerkin4
    1.42e-7, 8.87e-9, 5.55e-10; galerkin6 6.62e-10, 1.02e-11; midpoint on SO(3), 4.4e-4 ... 2.7e-5, second order)."""
    system, q0, qd0 = _sphere_case()
    ref = _rolling_reference(system, q0, qd0, 1.0)
    errs = []
    for N in Ns:
        r = ct.simulate(system, q0, qd0, 1.0, N, scheme=scheme)
        assert r.success, r.message
        assert r.detail.intervals[0] == [(0.0, 1.0, "stick")]
        errs.append(float(np.max(np.abs(r.q - ref(r.t)))))
    assert min(errs) > 1e-12
    assert _slope(Ns, errs) == pytest.approx(ct.schemes()[scheme], abs=0.3), errs


WHEEL = dict(spokes=8, length=1.0, slope=0.08, mass=1.0, g=9.8, inertia=0.01, mu=1.0)


def _wheel_pivot_angle(t, omega0):
    """The rimless wheel's stance: a pendulum about the planted tip, (1 + κ) l φ̈ = g sin(φ − γ) (φ the spoke's angle
    from the slope's normal, θ itself for spoke 0), from φ = α at φ̇ = −ω0, by Gragg–Bulirsch–Stoer extrapolation of
    order 16 from node to node (baselines.events.gbs_step): it reaches −α within 2e-14 rad of the touchdown time that
    Gauss–Legendre quadrature of dt = dφ/|φ̇| gives."""
    from castrajectory.baselines.events import gbs_step
    a, k = math.pi / WHEEL["spokes"], WHEEL["g"] / (WHEEL["length"] * (1.0 + WHEEL["inertia"]))
    x, out = np.array([a, -omega0]), [a]
    for dt in np.diff(t):
        x = gbs_step(lambda z: np.array([z[1], k * math.sin(z[0] - WHEEL["slope"])]), x, dt)
        out.append(x[0])
    return np.array(out)


@pytest.mark.parametrize("scheme,Ns", [("galerkin4", (10, 20, 40)), ("galerkin6", (6, 12))])
def test_the_rimless_wheels_stance_converges_at_the_schemes_order(scheme, Ns):
    """McGeer's rimless wheel (8 spokes, γ = 0.08, κ = 0.01, μ = 1) over its stance from just after a touchdown
    (ω0 = 1.5; the next touchdown at 0.592 s, T = 0.5): the planted spoke sticks (its tip's displacement held at the
    stages) while the trailing one leaves from t = 0.  The pivot angle against the pendulum about the tip (measured:
    galerkin4 5.80e-9, 3.57e-10, 2.23e-11; galerkin6 2.60e-10, 4.07e-12; midpoint 1.4e-4 ... 2.1e-6 at N = 25–200,
    second order; galerkin8 below 4e-14 from N = 6).  The step rates after the touchdowns, against the oracle's map
    (problems/rimless_wheel.py), converge at the same orders, but their constant depends on where a touchdown falls
    in its step (up to 10³ times, galerkin6), so a ladder over a fixed horizon scatters about the slope: this stance
    is the held contact alone."""
    from castrajectory.models import collision
    system = collision.rimless_wheel(**WHEEL)
    l, w0 = WHEEL["length"], 1.5
    q0, qd0 = collision.rimless_wheel_start(WHEEL["spokes"], l, w0)
    errs = []
    for N in Ns:
        r = ct.simulate(system, q0, qd0, 0.5, N, scheme=scheme)
        assert r.success, r.message
        assert not r.detail.impacts
        errs.append(float(np.max(np.abs(r.q[:, 2] - _wheel_pivot_angle(r.t, w0)))))
        # the tip stays planted at the origin: on the slope, and its drift along it (the stick's quadrature, of the
        # scheme's order) within 3.1e-9 m (galerkin4, N = 10)
        tip = np.stack([r.q[:, 0] + l * np.sin(r.q[:, 2]), r.q[:, 1] - l * np.cos(r.q[:, 2])])
        assert np.max(np.abs(tip)) < 1e-8
    assert min(errs) > 1e-12 and errs[-1] < {"galerkin4": 1e-10, "galerkin6": 4e-11}[scheme], errs
    assert _slope(Ns, errs) == pytest.approx(ct.schemes()[scheme], abs=0.3), errs
    est = r.error_estimate.errors["q"]
    assert errs[-1] / 10 <= est <= 10 * errs[-1], (est, errs)
