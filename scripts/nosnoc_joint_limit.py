"""Pendulum against a joint limit with ``nosnoc`` (optional peer): wall time needed to reach a given impact-time error.

Scene: issue #25's pendulum of ``scripts/bench_contact.py`` (``JOINT_LIMIT``, ``PENDULUM``): a point
mass on a massless rod of length ``l`` under gravity ``g``, angle θ from the downward vertical, against
a joint limit θ ≤ ``limit`` with restitution ``e``, released at rest from θ₀, over ``[0, T]``.  nosnoc
0.2 is run as an FESD / Radau IIA time-stepper on the *time-freezing* reformulation of the pendulum
(as ``scripts/nosnoc_ball.py`` does for the ball): state ``x = (θ, ω, t)`` with the physical time
``t`` as a state; for θ < limit the pendulum's flight ``(ω, -(g/l) sin θ, 1)``, beyond the limit an
auxiliary spring-damper ``(ω, -k (θ - limit) - c ω, 0)`` whose half period reverses the angular
velocity (times ``e``) while the physical clock is frozen.  Each impact is the physical time at the
finite-element boundary where θ crosses the limit (FESD puts the switch on an element boundary).
``error`` is the max abs difference to the impact times of the event-driven reference that the bench
measures castrajectory against (``castrajectory.baselines.events``); a run with more or fewer impacts
before ``T`` than the reference gets no error (NaN) and says so in ``status``.

Options are those of ``nosnoc_ball.py`` (Stewart, ELASTIC_INEQ, sigma_0 = 0.1, HEURISTIC_MEAN,
k = 100, c from ``e``), and so is the recovery of a failed step (redone with the previous one as one
step of twice the length, else with one more finite element).  nosnoc is an optional peer, not a
dependency of castrajectory: ``available()`` tells whether it is installed; the script returns early
without it.

    python scripts/nosnoc_joint_limit.py
"""
import contextlib
import copy
import io
import math
import time

import numpy as np

from nosnoc_ball import available  # the same test; the bench asks this module

# coarse -> fine (Radau IIA stages, element length step/n_fe, tolerance); keys are solve() keyword
# arguments (step: numerical time per NLP).  Measured: 2.5e-3 s (n_s = 2) down to a floor of 1e-12 to
# 3e-12 s on the second impact from n_s = 4 and elements of 0.025 on, which neither more stages, shorter
# elements nor a tighter tolerance lowers; a softer k_tf (a longer contact, better resolved) reaches 1.2e-12.
SETTINGS = [
    dict(n_stages=2, n_fe=2, step=0.1),
    dict(n_stages=3, n_fe=2, step=0.1),
    dict(n_stages=4, n_fe=2, step=0.2, tol=1e-12),
    dict(n_stages=4, n_fe=2, step=0.1),
    dict(n_stages=4, n_fe=3, step=0.15, tol=1e-12),
    dict(n_stages=4, n_fe=4, step=0.1, tol=1e-12),
    dict(n_stages=4, n_fe=3, step=0.05, tol=1e-12),
    dict(n_stages=3, n_fe=2, step=0.02),
    dict(n_stages=4, n_fe=2, step=0.02, tol=1e-12),
    dict(n_stages=5, n_fe=4, step=0.05, tol=1e-13),
    dict(n_stages=4, n_fe=4, step=0.1, tol=1e-12, k_tf=25.0),
]


def _model(ns, ca, scene, k_tf):
    """The time-freezing pendulum: Stewart regions θ < limit (flight) and θ > limit (frozen clock)."""
    th, w, t = ca.SX.sym("theta"), ca.SX.sym("omega"), ca.SX.sym("t")
    log_e = math.log(scene["e"])
    c_tf = 2 * abs(log_e) * math.sqrt(k_tf / (math.pi ** 2 + log_e ** 2))  # decay e over a half period
    flight = ca.vertcat(w, -scene["g"] / scene["l"] * ca.sin(th), 1)
    spring = ca.vertcat(w, -k_tf * (th - scene["limit"]) - c_tf * w, 0)
    return ns.NosnocModel(x=ca.vertcat(th, w, t), F=[ca.horzcat(flight, spring)], c=[scene["limit"] - th],
                          S=[np.array([[1], [-1]])], x0=np.array([scene["th0"], 0.0, 0.0]), t_var=t,
                          name="joint_limit")


def _options(ns, n_stages, n_fe, h, tol):
    """nosnoc options of one FESD step of numerical length ``h`` (those of ``nosnoc_ball.py``)."""
    o = ns.NosnocOpts()
    o.opts_casadi_nlp = copy.deepcopy(o.opts_casadi_nlp)  # a class-level dict in nosnoc 0.2
    o.opts_casadi_nlp["ipopt"].update(print_level=0, sb="yes")
    settings = dict(
        irk_scheme=ns.IrkSchemes.RADAU_IIA, n_s=int(n_stages), pss_mode=ns.PssMode.STEWART, use_fesd=True,
        cross_comp_mode=ns.CrossComplementarityMode.SUM_LAMBDAS_COMPLEMENT_WITH_EVERY_THETA,
        mpcc_mode=ns.MpccMode.ELASTIC_INEQ, step_equilibration=ns.StepEquilibrationMode.HEURISTIC_MEAN,
        homotopy_update_rule=ns.HomotopyUpdateRule.LINEAR, homotopy_update_slope=0.1, sigma_0=0.1,
        comp_tol=float(tol), tol_ipopt=float(tol) * 1e-2, N_stages=1, N_finite_elements=int(n_fe),
        terminal_time=float(h), equidistant_control_grid=True, print_level=0)
    for key, val in settings.items():
        setattr(o, key, val)
    return o


def impact_times(X: np.ndarray, limit: float, T: float) -> np.ndarray:
    """Impact times as nosnoc computes them: the physical time ``t`` at the finite-element boundary where
    θ reaches the limit while rising (FESD places an element boundary on the switch; inside the limit the
    clock is frozen, so the boundaries next to the switch carry the same ``t``).  An impact lasts until θ
    is back below the limit with ω < 0: FESD may put two boundaries on the switch, one a rounding error
    (1e-14 rad) on either side, and that dip is not a second impact."""
    th, w, t = np.asarray(X, dtype=float).T
    out, inside = [], False
    for i in range(len(th) - 1):
        if not inside and th[i] < limit <= th[i + 1] and w[i] > 0.0:
            out.append(t[i + 1])
            inside = True
        elif inside and th[i + 1] < limit and w[i + 1] < 0.0:
            inside = False
    out = np.array(out)
    return out[out < T]


def march(run, x0, T: float, max_steps: int):
    """FESD steps from ``x0`` until the physical clock ``x[2]`` passes ``T`` (or ``max_steps`` steps).

    ``run(variant, x)`` solves one step from ``x`` and returns (states at the finite-element ends, ok);
    variant "main" is the ordinary step, "double" the step of twice the length with twice the elements,
    "alt" the step with one more element.  A failed step is typically a switch just after its start: it
    is redone together with the previous step as one "double" step, else with "alt" (kept even if that
    fails too).  Returns (states from ``x0`` on, steps, retried steps, steps still failed)."""

    def one(x, prev):  # -> (states, whether they redo the previous step, retried, failed)
        xs, ok = run("main", x)
        if ok:
            return xs, False, 0, 0
        if prev is not None:
            ys, ok = run("double", prev[0])
            if ok:
                return ys, True, 1, 0
        xs, ok = run("alt", x)
        return xs, False, 1, int(not ok)

    X, prev, counts = [np.asarray(x0, dtype=float)], None, np.zeros(3, dtype=int)
    while X[-1][2] < T and counts[0] < max_steps:
        end = len(X)
        xs, redo, retried, failed = one(X[-1], prev)
        X[prev[1] if redo else end:] = xs
        prev = None if redo else (X[end - 1], end)  # (start state, index of its first state) of a single step
        counts += (1, retried, failed)
    return np.array(X), *map(int, counts)


def solve(reference, scene: dict, n_stages=4, n_fe=2, step=0.05, tol=1e-9, k_tf=100.0, max_steps=5000) -> dict:
    """Simulate with nosnoc until the physical clock passes ``scene["T"]``.

    reference: the event-driven impact times before T; scene: ``limit, e, th0, T, g, l`` (see the
    module doc).  n_stages: Radau IIA stages per finite element (nosnoc ``n_s``); n_fe: finite
    elements per step; step: numerical time per NLP (one FESD step); tol: nosnoc ``comp_tol`` (Ipopt
    tol is tol/100); k_tf: stiffness of the auxiliary time-freezing dynamics (a contact lasts about
    pi/sqrt(k_tf) numerical time).  A step whose NLP fails (Ipopt not converged or complementarity
    residual > 10 tol) is redone as ``march`` says; ``retried_steps`` / ``failed_steps`` count retries /
    steps still failed.  ``status``: "ok", "failed_steps", "max_steps", or the impacts missed
    or added against the reference (then ``error`` is NaN).
    """
    import casadi as ca
    import nosnoc as ns

    if not 0.0 < scene["e"] <= 1.0:
        raise ValueError("time-freezing spring needs 0 < e <= 1")
    t0 = time.perf_counter()
    built = {}
    variants = {"main": (n_fe, step), "alt": (n_fe + 1, step), "double": (2 * n_fe, 2 * step)}
    model = _model(ns, ca, scene, k_tf)

    def run(key, x):
        if key not in built:
            built[key] = ns.NosnocSolver(_options(ns, n_stages, *variants[key], tol), model)
        built[key].set("x0", x)
        r = built[key].solve()
        comp = float(built[key].problem.comp_res(r["w_sol"], built[key].p_val))  # elastic modes can
        ok = r["status"] == ns.Status.SUCCESS and comp <= 10 * tol  # "succeed" with slack left
        return [np.asarray(y, dtype=float).ravel() for y in r["x_list"]], ok

    with contextlib.redirect_stdout(io.StringIO()):  # nosnoc prints Ipopt warnings
        X, n_steps, retried, failed = march(run, [scene["th0"], 0.0, 0.0], scene["T"], max_steps)
    wall = time.perf_counter() - t0
    imp = impact_times(X, scene["limit"], scene["T"])
    exact = np.asarray(reference, dtype=float)
    if imp.size == exact.size:
        err = float(np.max(np.abs(imp - exact))) if imp.size else 0.0
        status = "ok" if failed == 0 and X[-1, 2] >= scene["T"] else ("failed_steps" if failed else "max_steps")
    else:
        err = math.nan
        status = f"{'missed' if imp.size < exact.size else 'added'} impacts: {imp.size}, reference {exact.size}"
    return {"status": status, "wall_time_s": wall, "impact_times": imp, "error": err, "exact_times": exact,
            "n_steps": n_steps, "retried_steps": retried, "failed_steps": failed,
            "settings": dict(n_stages=n_stages, n_fe=n_fe, step=step, tol=tol, k_tf=k_tf)}


if __name__ == "__main__":
    if not available():
        raise SystemExit("nosnoc not installed (optional peer)")
    from bench_contact import joint_limit_scene
    scene, _, ref = joint_limit_scene()
    print(f"{'n_stages':>8} {'n_fe':>4} {'step':>5} {'tol':>6} {'k_tf':>5} {'steps':>5} {'retry':>5} {'failed':>6} "
          f"{'time [s]':>9} {'error [s]':>10} status")
    for s in SETTINGS:
        r = solve(ref.times, scene, **s)
        c = r["settings"]
        print(f"{c['n_stages']:>8} {c['n_fe']:>4} {c['step']:>5} {c['tol']:>6.0e} {c['k_tf']:>5g} {r['n_steps']:>5} "
              f"{r['retried_steps']:>5} {r['failed_steps']:>6} {r['wall_time_s']:>9.2f} {r['error']:>10.2e} "
              f"{r['status']}")
