"""A battery of answers whose true error is measured against an independent reference, beside the error
estimate each answer carries (issue 41, part 1).

Every case solves one scene with ``ct.simulate`` (or ``droplet.solve``), measures its true error against a
reference that shares nothing with the discretisation, and prints one row: the estimate of the same
quantity, their ratio, the order the grids show, the regime, whether the estimate calls itself reliable,
its measured floor, the status, whether the answer warns, and the time of the answer.  A trajectory's
quantity is ``q``, ``max over nodes and coordinates |q − q_ref|`` (the estimate's ``errors["q"]``); an
``rtol`` row compares the relative errors (the true one against the estimate's ``scales["q"]``); a
droplet's is the contact angle (the span, pressure and energy ratios are in the notes).

The references: CVODES at 1e-13 (the double pendulum), Kepler's equation (the orbit), DOP853 at 1e-13 on
the ladder's one-degree-of-freedom equation, on Newton's three-body equations, on Euler's equations of the
free body and on the disk's reduced rolling or sliding motion (event-driven at the slip's reversals), RK4 in
extended precision on the cart's hand-written equations, the analytic impacts of the ball on a spring, the
circular cap.  Each DOP853 reference's own error (its distance from DOP853 at 3e-14, or the extended one's
from half its steps) is printed; a true error within 3x of it is not measured ("< ...", no ratio).

A row whose estimate is more than 10x off its true error (``under`` or ``over``), or whose ``rtol`` is
claimed met at more than 10x the tolerance, without a warning and with status ok is marked ``MISS``: the
bar of issue 41 (within a factor of 10, or the answer warns).

The estimate's cost (``--cost``; by default on the double pendulum, the flip, the ladder, the contact scene
and the droplet), once the answer's NLPs are built: the median over 5 runs of the answer's wall time as it
is and with its estimate skipped (the function forming it replaced by "none", no coarser grid solved:
"with / alone", "added (wall)"), and of the time spent inside the estimate's own functions during the
answer ("in the estimate": that time over the rest of the answer; the coarser grids the answer's ladder
solved anyway are not counted, they are part of its solve).

It runs against whichever castrajectory is imported (the first line says which), and tolerates an older
estimate without the newer fields (observed order, regime, reliable, floor: "-").

    python scripts/estimate_battery.py                 # every case (about 3 minutes on 2 cores)
    python scripts/estimate_battery.py --quick         # five small cases (a few seconds)
    python scripts/estimate_battery.py --only ladder --json rows.json
    PYTHONPATH=<another checkout>/src python scripts/estimate_battery.py    # another version of the package
"""
from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import runpy
import sys
import time
from dataclasses import dataclass
from typing import Callable, Dict, List, Optional

import numpy as np
from scipy.integrate import solve_ivp

import castrajectory as ct
from castrajectory.baselines import stepping
from castrajectory.models import collision, pendulum
from castrajectory.models.orbit import kepler_orbit
from castrajectory.models import rigidbody as rb

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXAMPLES = os.path.join(ROOT, "examples")


def example(name: str) -> dict:
    return runpy.run_path(os.path.join(EXAMPLES, f"{name}.py"))


def max_err(q, ref) -> float:
    return float(np.max(np.abs(np.asarray(q, float) - np.asarray(ref, float))))


def excursion(q) -> float:
    """The scale of a motion as the new estimate measures it: ``max_k ‖q_k − q_0‖∞``."""
    q = np.asarray(q, float)
    return float(np.max(np.abs(q - q[0])))


# ----------------------------------------------------------------------------- references
DP = pendulum.double_pendulum(1.0, 1.0, 1.0, 1.0, 9.81)


def dp_reference(t):
    """CVODES at 1e-13 on the double pendulum's Euler–Lagrange equations (as tests/test_estimate.py)."""
    return stepping.reference(DP, [2.0, 1.0], [0.0, 0.0], t, rtol=1e-13, atol=1e-13)[0]


def ladder_reference(mod, t):
    """While both ends touch: θ̈ = −(3g/2L) cos θ (DOP853 at 1e-13), the centre on the circle of radius L/2."""
    g, L = mod["g"], mod["L"]
    th, err = dop853_with_error(lambda _, z: [z[1], -1.5 * g / L * math.cos(z[0])], [mod["theta0"], 0.0], t, 1)
    th = th[:, 0]
    return np.column_stack([0.5 * L * np.cos(th), 0.5 * L * np.sin(th), th]), err


#: DOP853's tightest tolerance without scipy's warning (it raises anything below 100 eps to 100 eps)
TIGHTEST = 3e-14


def dop853(rhs, y0, t, nq: int, rtol: float = 1e-13):
    """``q`` at the times ``t`` by DOP853 at ``rtol = atol``."""
    s = solve_ivp(rhs, (0.0, float(t[-1])), np.asarray(y0, float), method="DOP853", rtol=rtol, atol=rtol, t_eval=t)
    assert s.success, s.message
    return s.y[:nq].T


def dop853_with_error(rhs, y0, t, nq: int):
    """DOP853 at 1e-13 and its own error, bounded by its distance from DOP853 at :data:`TIGHTEST`."""
    ref = dop853(rhs, y0, t, nq)
    return ref, max_err(ref, dop853(rhs, y0, t, nq, TIGHTEST))


def figure8_rhs(masses, G=1.0):
    def rhs(_, y):
        x, v = y[:6].reshape(3, 2), y[6:]
        a = np.zeros((3, 2))
        for i in range(3):
            for j in range(3):
                if i != j:
                    d = x[i] - x[j]
                    a[i] -= G * masses[j] * d / np.linalg.norm(d) ** 3
        return np.concatenate([v, a.reshape(-1)])
    return rhs


def figure8_reference(mod, t, rtol=1e-13):
    return dop853(figure8_rhs(mod["masses"], mod["G"]), np.concatenate([mod["q0"], mod["qd0"]]), t, 6, rtol)


_CART = {}


def cart_reference(mod, t):
    """The cart's motion in extended precision: RK4 in numpy.longdouble on the hand-written equations of
    examples/cart_double_pendulum.py (a 3x3 Cramer solve), Richardson from 24000 and 48000 steps
    (scripts/_extended_reference.py); its error bounded by the same from 12000 and 24000 steps.  DOP853 at
    1e-13 is itself about 4e-13 off this motion, above the answers' errors at N >= 26."""
    if not _CART:
        sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
        from _extended_reference import LD, Reference
        m0, m1, m2, l1, l2 = (LD(mod[k]) for k in ("m0", "m1", "m2", "l1", "l2"))
        g = LD(str(mod["g"]))

        def rhs(y):
            _, t1, t2, v, w1, w2 = y
            c1, s1, c2, s2 = np.cos(t1), np.sin(t1), np.cos(t2), np.sin(t2)
            c12, s12 = np.cos(t1 - t2), np.sin(t1 - t2)
            a, b, c = m0 + m1 + m2, (m1 + m2) * l1 * c1, m2 * l2 * c2     # M = [[a, b, c], [b, d, e], [c, e, f]]
            d, e, f = (m1 + m2) * l1 * l1, m2 * l1 * l2 * c12, m2 * l2 * l2
            r0 = (m1 + m2) * l1 * s1 * w1 * w1 + m2 * l2 * s2 * w2 * w2
            r1 = -m2 * l1 * l2 * s12 * w2 * w2 - (m1 + m2) * g * l1 * s1
            r2 = m2 * l1 * l2 * s12 * w1 * w1 - m2 * g * l2 * s2
            det = a * (d * f - e * e) - b * (b * f - e * c) + c * (b * e - d * c)
            x0 = (r0 * (d * f - e * e) - b * (r1 * f - e * r2) + c * (r1 * e - d * r2)) / det
            x1 = (a * (r1 * f - e * r2) - r0 * (b * f - e * c) + c * (b * r2 - r1 * c)) / det
            x2 = (a * (d * r2 - r1 * e) - b * (b * r2 - r1 * c) + r0 * (b * e - d * c)) / det
            return np.array([v, w1, w2, x0, x1, x2], dtype=LD)
        y0 = np.array(list(mod["q0"]) + list(mod["qd0"]), dtype=LD)
        T = float(mod["T"])
        _CART["ref"] = Reference(rhs, y0, T, 24000)
        probe = np.linspace(0.0, T, 2001)
        _CART["err"] = max_err(_CART["ref"].q(probe), Reference(rhs, y0, T, 12000).q(probe))
        M, f = mod["equations"](np.array([0.3, 1.0, -0.4]), np.array([0.5, -1.0, 2.0]))
        assert max_err(rhs(np.array([0.3, 1.0, -0.4, 0.5, -1.0, 2.0], dtype=LD))[3:].astype(float),
                       np.linalg.solve(M, f)) < 1e-12
    return _CART["ref"].q(t), _CART["err"]


def flip_reference(inertia, w0, t):
    """Euler's equations I ω̇ = (Iω) × ω with q̇ = ½ q ⊗ (0, ω), DOP853 at 1e-13 (the quaternion renormalised
    only by the integrator's accuracy)."""
    I = np.asarray(inertia.moments, float)

    def rhs(_, y):
        q, w = y[:4], y[4:]
        qd = rb.quaternion_rate(q, w)
        wd = np.cross(I * w, w) / I
        return np.concatenate([qd, wd])
    return dop853_with_error(rhs, np.concatenate([[1.0, 0.0, 0.0, 0.0], w0]), t, 4)


def disk_bowl_reference(mod, mu, t, rtol=1e-13):
    """Event-driven Coulomb friction on the reduced coordinates (φ, φ̇, θ, θ̇): sliding (F = −μ N sign u) or
    rolling (u = 0, F = m g sin φ / 3 while |F| <= μ N); returns q at the times t, and the events (time, kind)."""
    m, r, R, g = mod["m"], mod["r"], mod["R"], mod["g"]
    I, L = 0.5 * m * r * r, R - r
    def normal(z):
        return m * g * math.cos(z[0]) + m * L * z[1] ** 2
    def f_roll(z):
        return m * g * math.sin(z[0]) / (1.0 / m + r * r / I) / m
    def slide(s):
        def rhs(_, z):
            F = -mu * normal(z) * s
            return [z[1], (-m * g * math.sin(z[0]) + F) / (m * L), z[3], r * F / I]
        return rhs
    def roll(_, z):
        F = f_roll(z)
        a = (-m * g * math.sin(z[0]) + F) / (m * L)
        return [z[1], a, z[3], -L * a / r]
    def breakaway(_, z):
        return mu * normal(z) - abs(f_roll(z))
    breakaway.terminal = True
    t = np.asarray(t, float)
    T = float(t[-1])
    z = np.array([mod["phi0"], 0.0, 0.0, 0.0])
    t0, events = 0.0, []
    out = np.full((t.size, 4), np.nan)

    def decide(z):
        F = f_roll(z)
        if abs(F) <= mu * normal(z):
            return "roll"
        return -np.sign(F)          # the slip's sign as the disk breaks away
    mode = decide(z)
    while t0 < T - 1e-15:
        if mode == "roll":
            fn, ev = roll, [breakaway]
        else:
            fn = slide(mode)
            def sl(_, z):
                return L * z[1] + r * z[3]
            sl.terminal = True
            sl.direction = -mode     # u leaves with sign s, so it crosses zero going the other way
            ev = [sl]
        sol = solve_ivp(fn, (t0, T), z, method="DOP853", rtol=rtol, atol=rtol, events=ev, dense_output=True)
        t1 = sol.t[-1]
        sel = (t >= t0) & (t <= t1)
        out[sel] = sol.sol(t[sel]).T
        if sol.status != 1:
            break
        z = sol.y[:, -1].copy()
        if mode != "roll":
            z[3] = -L * z[1] / r        # exactly on u = 0
        if mode == "roll":
            mode, kind = (decide(z) if decide(z) != "roll" else -np.sign(f_roll(z))), "breaks away"
        else:
            mode = "roll" if decide(z) == "roll" else -mode
            kind = "sticks (rolls)" if mode == "roll" else "slip reverses"
        events.append((t1, kind))
        t0 = t1
    phi, th = out[:, 0], out[:, 2]
    return np.column_stack([L * np.sin(phi), -L * np.cos(phi), th]), events


# ----------------------------------------------------------------------------- the estimate skipped (costs)
@contextlib.contextmanager
def patched(patches):
    """Inside: each ``(module, name, value)`` of ``patches`` set; restored on the way out."""
    saved = [(m, k, getattr(m, k)) for m, k, _ in patches]
    try:
        for m, k, v in patches:
            setattr(m, k, v)
        yield
    finally:
        for m, k, v in saved:
            setattr(m, k, v)


@contextlib.contextmanager
def estimate_skipped():
    """Inside: a whole-trajectory or contact answer is solved without its estimate (no coarser grid, no
    floor); every function replaced exists in both versions measured (or is skipped where absent)."""
    from castrajectory.solve import estimate as est_mod
    from castrajectory.solve import trajectory
    from castrajectory.solve.contact import strategy

    def none(*_a, **_k):
        return est_mod.ErrorEstimate.none("skipped for timing")

    orig_once = strategy._solve_once

    def once(*a, certify=True, **k):     # the older contact solve asks for its N/2 grid with certify=False
        return orig_once(*a, certify=certify, **k) if certify else None

    patches = [(trajectory, "_estimate", none), (strategy, "_estimate", none), (strategy, "_solve_once", once)]
    if hasattr(est_mod, "coarser"):
        patches.append((est_mod, "coarser", lambda n: []))
    with patched(patches):
        yield


@contextlib.contextmanager
def estimate_clock(clock: list):
    """Inside: the time spent in the estimate's own work is added to ``clock[0]``: the function that forms a
    whole trajectory's or a droplet's estimate (its coarser grids where the ladder did not solve them, and
    the floor), a contact answer's coarser solves (``_solve_once(certify=False)``) and estimate, and a
    baseline's runs after the first (its coarser grids)."""
    from castrajectory.solve import droplet, trajectory
    from castrajectory.solve.contact import strategy

    def timing(fn, when=lambda a, k: True):
        def wrapped(*a, **k):
            if not when(a, k):
                return fn(*a, **k)
            t0 = time.perf_counter()
            try:
                return fn(*a, **k)
            finally:
                clock[0] += time.perf_counter() - t0
        return wrapped

    calls = [0]

    def later_run(a, k):
        calls[0] += 1
        return calls[0] > 1

    patches = [(trajectory, "_estimate", timing(trajectory._estimate)),
               (strategy, "_estimate", timing(strategy._estimate)),
               (strategy, "_solve_once", timing(strategy._solve_once, lambda a, k: k.get("certify", True) is False)),
               (droplet, "_estimate", timing(droplet._estimate)),
               (stepping, "rk4", timing(stepping.rk4, later_run))]
    with patched(patches):
        yield


def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t0


def costs(c: "Case", repeats: int = 5) -> dict:
    """Once the answer's NLPs are built: the median wall time of the answer as it is, of the answer with its
    estimate skipped (:func:`estimate_skipped`), interleaved, and the median time inside the estimate's own
    work during the answer (:func:`estimate_clock`)."""
    with_s, alone_s, inside_s = [], [], []
    for _ in range(repeats):
        clock = [0.0]
        with estimate_clock(clock):
            with_s.append(timed(c.solve)[1])
        inside_s.append(clock[0])
        if c.alone is not None:
            alone_s.append(timed(c.alone)[1])
    w, i = float(np.median(with_s)), float(np.median(inside_s))
    out = {"time_with_s": w, "time_inside_s": i, "added_inside": i / max(w - i, 1e-12)}
    if alone_s:
        a = float(np.median(alone_s))
        out.update(time_alone_s=a, added=w / a - 1.0)
    return out


# ----------------------------------------------------------------------------- cases
@dataclass
class Case:
    name: str
    scheme: str
    N: int
    solve: Callable[[], object]                 # the answer (a Run, a ContactTrajectory, a DropletSolution)
    truth: Callable[[object], Dict[str, float]]  # the true errors of the answer, by the estimate's keys
    key: str = "q"                               # the quantity of the row
    alone: Optional[Callable[[], object]] = None  # the answer's own solve without its estimate (costs)
    cost: bool = False                           # measured by default
    quick: bool = False
    rtol: Optional[float] = None                 # rtol cases: the row compares the relative errors
    note: Callable[[object, Dict[str, float]], str] = lambda r, t: ""


def sim(system, q0, qd0, T, N, scheme="midpoint", method="whole", **kw):
    return lambda: ct.simulate(system, q0, qd0, T, N, scheme, method, **kw)


def alone_sim(system, q0, qd0, T, N, scheme="midpoint", method="whole"):
    if method != "whole":
        return None      # a baseline's estimate runs inside simulate's own loop: timed by estimate_clock only

    def go():
        with estimate_skipped():
            return ct.simulate(system, q0, qd0, T, N, scheme, method)
    return go


def traj_truth(ref_of):
    def truth(r):
        ref = ref_of(np.asarray(r.t, float))
        ref, ref_err = ref if isinstance(ref, tuple) else (ref, 0.0)
        err = np.max(np.abs(np.asarray(r.q, float) - ref), axis=1)
        return {"q": float(err.max()), "q_T": float(err[-1]), "_scale": excursion(r.q), "_ref_err": ref_err}
    return truth


def cases() -> List[Case]:
    out: List[Case] = []
    dq0, dqd0 = [2.0, 1.0], [0.0, 0.0]
    # 1. the double pendulum over 3 s (CVODES 1e-13)
    for scheme, method, N, quick in (("midpoint", "whole", 800, False), ("galerkin4", "whole", 300, True),
                                     ("midpoint", "rk4", 400, True)):
        out.append(Case(f"double pendulum T=3" + (" (RK4)" if method == "rk4" else ""),
                        "rk4" if method == "rk4" else scheme, N, sim(DP, dq0, dqd0, 3.0, N, scheme, method),
                        traj_truth(dp_reference), alone=alone_sim(DP, dq0, dqd0, 3.0, N, scheme, method),
                        cost=True, quick=quick))
    # 2. chaotic horizon, coarse grid
    out.append(Case("double pendulum T=10 (chaotic, coarse)", "midpoint", 300, sim(DP, dq0, dqd0, 10.0, 300),
                    traj_truth(dp_reference), alone=alone_sim(DP, dq0, dqd0, 10.0, 300)))
    # 3. Kepler, galerkin24 over three periods (closed form)
    kep = example("kepler")
    ks = kep["system"]()
    for N in (100, 400):
        out.append(Case("Kepler e=0.44, T=45", "galerkin24", N, sim(ks, kep["q0"], kep["qd0"], 45.0, N, "galerkin24"),
                        traj_truth(kepler_orbit),
                        alone=alone_sim(ks, kep["q0"], kep["qd0"], 45.0, N, "galerkin24")))
    # 4. the sliding ladder, both contacts held (DOP853 on the reduced equation)
    lad = example("sliding_ladder")
    ls = lad["system"]()
    lref = lambda t: ladder_reference(lad, t)  # noqa: E731
    for scheme, quick in (("galerkin8", True), ("midpoint", False)):
        out.append(Case("sliding ladder T=0.4", scheme, 400, sim(ls, lad["q0"], lad["qd0"], 0.4, 400, scheme),
                        traj_truth(lref), alone=alone_sim(ls, lad["q0"], lad["qd0"], 0.4, 400, scheme),
                        cost=True, quick=quick))
    for scheme, rtol in (("galerkin4", 1e-6), ("galerkin8", 1e-6), ("galerkin8", 1e-8)):
        out.append(Case(f"sliding ladder T=0.4, rtol={rtol:g} (from n=200)", scheme, 200,
                        sim(ls, lad["q0"], lad["qd0"], 0.4, 200, scheme, rtol=rtol), traj_truth(lref), rtol=rtol))
    # 5. the figure eight, ten periods
    f8 = example("three_body_figure8")
    fs = f8["system"]()
    T8 = 10 * f8["period"]

    def f8_note(r, tr):
        t = np.asarray(r.t, float)
        d = max_err(figure8_reference(f8, t, 1e-12), figure8_reference(f8, t, 1e-13))
        return f"reference DOP853 1e-13 vs 1e-12: {d:.1e}"
    f8_rhs, f8_y0 = figure8_rhs(f8["masses"], f8["G"]), np.concatenate([f8["q0"], f8["qd0"]])
    out.append(Case("figure-eight 3-body, 10 periods", "galerkin24", 500,
                    sim(fs, f8["q0"], f8["qd0"], T8, 500, "galerkin24"),
                    traj_truth(lambda t: dop853_with_error(f8_rhs, f8_y0, t, 6)),
                    alone=alone_sim(fs, f8["q0"], f8["qd0"], T8, 500, "galerkin24"), note=f8_note))
    # 6. the cart with a double pendulum
    cdp = example("cart_double_pendulum")
    cs = cdp["system"]()
    for scheme, Ns in (("galerkin24", (24, 25, 28, 50)), ("gauss24", (25, 50))):
        for N in Ns:
            out.append(Case("cart + double pendulum T=3", scheme, N, sim(cs, cdp["q0"], cdp["qd0"], 3.0, N, scheme),
                            traj_truth(lambda t: cart_reference(cdp, t)),
                            alone=alone_sim(cs, cdp["q0"], cdp["qd0"], 3.0, N, scheme)))
    # 7. the ball on a spring, bouncing (analytic impacts)
    H, g, k, m, anchor, e, Tb = 1.0, 9.81, 50.0, 1.0, 0.3, 0.8, 2.5
    ball = collision.bouncing_ball(m, g, e, stiffness=k, anchor=anchor)

    def ball_truth(r):
        y, times = collision.spring_ball_height(np.asarray(r.t, float), H, g, k, m, anchor, e, Tb)
        err = np.abs(np.asarray(r.q, float)[:, 0] - y)
        got = np.array([i.t for i in getattr(r.detail, "impacts", []) if not i.caught])
        n = min(got.size, times.size)
        out = {"q": float(err.max()), "q_T": float(err[-1]), "_scale": excursion(r.q)}
        if n:
            out["impact_times"] = float(np.max(np.abs(got[:n] - times[:n])))
        return out

    def ball_note(r, tr):
        e_ = getattr(r, "error_estimate", None)
        it = (getattr(e_, "errors", {}) or {}).get("impact_times", math.nan)
        return f"impact times: true {tr.get('impact_times', math.nan):.2e}, estimate {it:.2e}"
    out.append(Case("ball on a spring, e=0.8, T=2.5", "midpoint", 400, sim(ball, [H], [0.0], Tb, 400), ball_truth,
                    alone=alone_sim(ball, [H], [0.0], Tb, 400), cost=True, quick=True, note=ball_note))
    # 8. the Dzhanibekov flip (inertia 1 2 3, ω0 = (1e-3, 1, 1e-3)); reference: Euler's equations, DOP853
    inertia = rb.Inertia(1.0, 2.0, 3.0)
    w0 = np.array([1e-3, 1.0, 1e-3])
    body = rb.free_body(inertia)
    qq0 = np.array([1.0, 0.0, 0.0, 0.0])
    qqd0 = rb.quaternion_rate(qq0, w0)
    for scheme, N in (("midpoint", 2000), ("galerkin4", 1000)):
        out.append(Case("Dzhanibekov flip T=30", scheme, N, sim(body, qq0, qqd0, 30.0, N, scheme),
                        traj_truth(lambda t: flip_reference(inertia, w0, t)),
                        alone=alone_sim(body, qq0, qqd0, 30.0, N, scheme), cost=True))
    # 10. a disk in a circular bowl with Coulomb friction: rolling (μ = 1) and sliding (μ = 0.05), against the
    # event-driven reduced motion (DOP853 at 1e-13 between the slip's reversals, stick checked at each)
    bowl = example("disk_in_bowl")
    for mu, scheme in ((1.0, "midpoint"), (1.0, "galerkin4"), (0.05, "midpoint"), (0.05, "galerkin4")):
        bs = bowl["system"](mu)

        def bowl_ref(t, mu=mu):
            q, _ = disk_bowl_reference(bowl, mu, t)
            return q, max_err(q, disk_bowl_reference(bowl, mu, t, 1e-11)[0])

        def bowl_note(r, tr, mu=mu):
            _, ev = disk_bowl_reference(bowl, mu, np.asarray(r.t, float))
            return ("the reference rolls throughout" if not ev else
                    "the reference: " + ", ".join(f"{k} at t = {a:.4f}" for a, k in ev))
        out.append(Case(f"disk in a bowl, mu={mu:g}, T=2", scheme, 400,
                        sim(bs, bowl["q0"], bowl["qd0"], bowl["T"], 400, scheme), traj_truth(bowl_ref),
                        alone=alone_sim(bs, bowl["q0"], bowl["qd0"], bowl["T"], 400, scheme), note=bowl_note))
    # 9. the droplet: the analytic circular cap
    from castrajectory.solve import droplet
    drop = droplet.Droplet(1.0, 0.5, 1.0, 1.0, None)

    def drop_truth(s):
        cap = s.analytic
        return {"contact_angle": abs(s.contact_angle - cap.contact_angle), "span": abs(s.span - cap.span),
                "pressure": abs(s.pressure - cap.pressure), "energy": abs(s.energy - cap.energy)}

    def drop_note(s, tr):
        est = getattr(s.error_estimate, "errors", {}) or {}
        return "; ".join(f"{k} {est.get(k, math.nan) / tr[k]:.2g}x" for k in ("span", "pressure", "energy")
                         if tr[k] > 0)
    out.append(Case("droplet (circular cap), curve", "curve", 400, lambda: droplet.solve(drop, 400, "curve"),
                    drop_truth, key="contact_angle", alone=lambda: droplet.solve(drop, 400, "curve", estimate=False),
                    cost=True, quick=True, note=drop_note))
    return out


# ----------------------------------------------------------------------------- one row
def fmt(x, spec=".2e"):
    if x is None:
        return "-"
    if isinstance(x, float) and not math.isfinite(x):
        return "-" if math.isnan(x) else str(x)
    return format(x, spec)


def run_case(c: Case, cost: bool) -> dict:
    r, t_first = timed(c.solve)
    e = getattr(r, "error_estimate", None)
    errors = dict(getattr(e, "errors", {}) or {})
    tr = c.truth(r)
    est = errors.get(c.key, math.nan)
    true = tr[c.key]
    row = {"case": c.name, "scheme": c.scheme, "N": c.N, "quantity": c.key, "true": true, "estimate": est,
           "ratio": est / true if true > 0 else math.nan,
           "observed_order": getattr(e, "observed_order", None), "order": getattr(e, "order", None),
           "order_used": getattr(e, "order_used", None), "regime": getattr(e, "regime", None),
           "reliable": getattr(e, "reliable", None) if e is not None and getattr(e, "available", False) else False,
           "available": bool(getattr(e, "available", False)), "levels": list(getattr(e, "levels", ()) or ()),
           "status": getattr(r, "status", "?"), "warnings": list(getattr(r, "warnings", []) or []),
           "time_s": t_first, "line": e.line() if e is not None and hasattr(e, "line") else ""}
    if c.rtol is not None:
        n_final = len(r.t) - 1
        row["N"] = f"{c.N}->{n_final}"
        row["quantity"] = "q relative"
        scale = (getattr(e, "scales", {}) or {}).get("q") or tr["_scale"]
        row["true"] = true / scale
        row["estimate"] = float(getattr(e, "relative", math.nan))
        row["ratio"] = row["estimate"] / row["true"] if row["true"] > 0 else math.nan
        row["rtol"] = c.rtol
        row["met"] = bool(getattr(r, "success", False))
    else:
        scale = 1.0
    row["warns"] = bool(row["warnings"])
    row["ref_err"] = float(tr.get("_ref_err", 0.0))
    row["floor"] = (getattr(e, "floor", {}) or {}).get(c.key) if e is not None else None
    # the true error is measured only above the reference's own error (3x it)
    row["measured"] = row["true"] > 3.0 * row["ref_err"] * (1.0 if c.rtol is None else 1.0 / scale)
    off = None
    if row["measured"] and row["true"] > 0 and math.isfinite(row["estimate"]):
        off = "under" if row["estimate"] < row["true"] / 10 else "over" if row["estimate"] > 10 * row["true"] else None
    if c.rtol is not None and row["met"] and row["true"] > 10 * c.rtol:   # the claim "met" is wrong
        off = "under"
    row["miss"] = off if (off and not row["warns"] and row["status"] == "ok") else None
    try:
        row["note"] = c.note(r, tr)
    except Exception as exc:  # a note never stops the battery
        row["note"] = f"note failed: {exc}"
    if cost:
        row.update(costs(c))
    return row


def markdown(rows: List[dict]) -> str:
    head = ("| case | scheme | N | quantity | true | estimate | est/true | obs. order | regime | reliable | floor "
            "| status | warns | t (s) | t with / alone (s) | added (wall) | in the estimate |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in rows:
        cost = (f"{r['time_with_s']:.3f} / " + (f"{r['time_alone_s']:.3f}" if "time_alone_s" in r else "-")
                if "time_with_s" in r else "")
        added = f"{r['added']:+.0%}" if "added" in r else ""
        inside = f"{r['added_inside']:+.0%}" if "added_inside" in r else ""
        reliable = "-" if r["regime"] is None else ("yes" if r["reliable"] else "no")
        flag = f" **MISS ({r['miss']})**" if r.get("miss") else ""
        true = fmt(r["true"]) if r.get("measured", True) else f"< {fmt(3 * r['ref_err'])}"
        lines.append(f"| {r['case']} | {r['scheme']} | {r['N']} | {r['quantity']} | {true} | "
                     f"{fmt(r['estimate'])} | {fmt(r['ratio'], '.3g') if r.get('measured', True) else '-'}{flag} | "
                     f"{fmt(r['observed_order'], '.2f')} | {r['regime'] or '-'} | {reliable} | "
                     f"{fmt(r.get('floor'), '.1e')} | {r['status']} | {'yes' if r['warns'] else 'no'} | "
                     f"{r['time_s']:.2f} | {cost} | {added} | {inside} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="a few small cases (< 60 s)")
    p.add_argument("--only", default=None, help="the cases whose name contains this text")
    p.add_argument("--cost", choices=("default", "all", "none"), default="default",
                   help="time the answer with and without its estimate: the default cases, all, or none")
    p.add_argument("--json", metavar="PATH", default=None, help="also write the rows as JSON")
    a = p.parse_args(argv)
    chosen = [c for c in cases() if (c.quick or not a.quick) and (a.only is None or a.only in c.name)]
    if not chosen:
        print("no case matches", file=sys.stderr)
        return 2
    print(f"castrajectory from {os.path.dirname(ct.__file__)}", flush=True)
    rows = []
    for c in chosen:
        cost = a.cost == "all" or (a.cost == "default" and c.cost and not a.quick)
        try:
            row = run_case(c, cost)
        except Exception as exc:  # a case that raises is a row that says so
            row = {"case": c.name, "scheme": c.scheme, "N": c.N, "quantity": c.key, "true": math.nan,
                   "estimate": math.nan, "ratio": math.nan, "observed_order": None, "regime": None, "reliable": None,
                   "status": f"raised {type(exc).__name__}: {exc}"[:120], "warns": False, "warnings": [],
                   "time_s": math.nan, "miss": None, "note": ""}
        rows.append(row)
        print(f"{c.name} [{c.scheme}, N={row['N']}]: true {fmt(row['true'])}, estimate {fmt(row['estimate'])}, "
              f"ratio {fmt(row['ratio'], '.3g')}, {row['regime']}, {row['status']}"
              + (f" MISS ({row['miss']})" if row.get("miss") else "")
              + (f"; {row['note']}" if row.get("note") else ""), flush=True)
    print()
    print(markdown(rows))
    notes = [f"- {r['case']} [{r['scheme']}, N={r['N']}]: {r['note']}" for r in rows if r.get("note")]
    warned = [f"- {r['case']} [{r['scheme']}, N={r['N']}]: {' | '.join(r['warnings'])}" for r in rows if r["warnings"]]
    if notes:
        print("\nnotes:\n" + "\n".join(notes))
    if warned:
        print("\nwarnings of the answers:\n" + "\n".join(warned))
    costs_ = [r for r in rows if "added_inside" in r]
    if costs_:
        print(f"\nthe estimate's added cost, answers timed once built (median of 5): wall with / alone - 1: median "
              f"{np.median([r['added'] for r in costs_ if 'added' in r]):+.0%}; time inside the estimate / the rest "
              f"of the answer: "
              f"median {np.median([r['added_inside'] for r in costs_]):+.0%}, "
              f"largest {max(r['added_inside'] for r in costs_):+.0%}")
        # the ceiling of issue 41's 30 % goal, measured in the same run's terms
        print("the ceiling: the two coarser grids (N/2, N/4) hold 3/4 of the answer's steps, so the estimate adds "
              "about 75 % where each of their steps costs what the answer's did (the same Newton iterations per "
              "step: a motion solved in windows, as the flip, or a contact march), and 75 % x (their iterations / the "
              "answer's) where they start from the answer and converge faster (the double pendulum: 1 against 3-4, "
              "about 25 %); 30 % everywhere would need coarser grids (N/4 and N/16: 31 %), outside the asymptotic "
              "range of the high-order schemes at these N")
    refs = [f"- {r['case']} [{r['scheme']}, N={r['N']}]: the reference's own error {r['ref_err']:.1e}"
            for r in rows if r.get("ref_err")]
    if refs:
        print("\nreferences:\n" + "\n".join(refs))
    misses = [r for r in rows if r.get("miss")]
    print(f"\n{len(rows)} cases; {len(misses)} estimates more than 10x off their true error without a warning"
          + (": " + ", ".join(f"{r['case']} [{r['scheme']}, N={r['N']}] ({r['miss']})" for r in misses)
             if misses else ""))
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1, default=lambda o: o if not isinstance(o, np.generic) else o.item())
    return 0


if __name__ == "__main__":
    sys.exit(main())
