"""Bouncing ball with ``nosnoc`` (optional peer): wall time needed to reach a given impact-time error.

Scene: point mass dropped at rest from ``height`` onto the ground ``y = 0`` (g = 9.81, restitution
``e``, horizon ``T``).  nosnoc 0.2 is run as an FESD / Radau IIA time-stepper on the
*time-freezing* reformulation of the ball (as in nosnoc's ``elastic_ball_in_box`` example):
state ``x = (q, v, t)`` with the physical time ``t`` as a state; for ``q > 0`` free flight
``(v, -g, 1)``, for ``q < 0`` an auxiliary spring-damper ``(v, -k q - c v, 0)`` whose half
period reverses the velocity (times ``e``) while the physical clock is frozen.  Each impact is
the physical time at the finite-element boundary where the ball enters ``q <= 0`` (FESD puts the
switch on an element boundary).  ``error`` is the max abs difference to ``castrajectory``'s ``ball_oracle``.

nosnoc's own ``time_freezing=True`` option only adds clock constraints ``t(stage end) = t0 + h``
(needs speed-of-time variables); stepping with it squeezes each contact into a few finite
elements and gave infeasible steps, so it is off by default (``clock=True`` to try it).
Options otherwise follow that example (Stewart, ELASTIC_INEQ, sigma_0 = 0.1, HEURISTIC_MEAN,
k = 100, c from ``e``).  nosnoc is an optional peer, not a dependency of castrajectory:
``available()`` tells whether it is installed; ``cheapest()`` and the script return early without it.
"""
import contextlib
import copy
import io
import math
import time

import numpy as np

G = 9.81
# coarse -> fine; keys are solve() keyword arguments
SETTINGS = [
    dict(n_stages=3, n_fe=2, step=0.15),
    dict(n_stages=4, n_fe=2, step=0.15),
    dict(n_stages=4, n_fe=3, step=0.15),
    dict(n_stages=5, n_fe=3, step=0.15),
    dict(n_stages=5, n_fe=4, step=0.15, tol=1e-11),
]


def available() -> bool:
    """True if ``import nosnoc`` works."""
    try:
        import nosnoc  # noqa: F401
        return True
    except Exception:
        return False


def _model(ns, ca, height, e, k_tf):
    q, v, t = ca.SX.sym("q"), ca.SX.sym("v"), ca.SX.sym("t")
    c_tf = 2 * abs(math.log(e)) * math.sqrt(k_tf / (math.pi ** 2 + math.log(e) ** 2))
    F = ca.horzcat(ca.vertcat(v, -G, 1), ca.vertcat(v, -k_tf * q - c_tf * v, 0))
    return ns.NosnocModel(x=ca.vertcat(q, v, t), F=[F], c=[q], S=[np.array([[1], [-1]])],
                          x0=np.array([height, 0.0, 0.0]), t_var=t, name="ball")


def _solver(ns, ca, height, e, k_tf, n_stages, n_fe, h, tol, clock, extra):
    o = ns.NosnocOpts()
    o.opts_casadi_nlp = copy.deepcopy(o.opts_casadi_nlp)  # class-level dict in nosnoc 0.2
    o.opts_casadi_nlp["ipopt"].update(print_level=0, sb="yes")
    o.irk_scheme, o.n_s = ns.IrkSchemes.RADAU_IIA, int(n_stages)
    o.pss_mode, o.use_fesd = ns.PssMode.STEWART, True
    o.cross_comp_mode = ns.CrossComplementarityMode.SUM_LAMBDAS_COMPLEMENT_WITH_EVERY_THETA
    o.mpcc_mode = ns.MpccMode.ELASTIC_INEQ  # as elastic_ball_in_box; SCHOLTES_INEQ ~5x slower here
    o.step_equilibration = ns.StepEquilibrationMode.HEURISTIC_MEAN
    o.homotopy_update_rule, o.homotopy_update_slope = ns.HomotopyUpdateRule.LINEAR, 0.1
    o.sigma_0, o.comp_tol = 0.1, float(tol)
    o.tol_ipopt = float(tol) * 1e-2
    o.N_stages, o.N_finite_elements, o.terminal_time = 1, int(n_fe), float(h)
    o.equidistant_control_grid = True
    o.time_freezing = bool(clock)
    if clock:
        o.time_freezing_tolerance = 0.0
        o.speed_of_time_variables = ns.SpeedOfTimeVariableMode.LOCAL
    o.print_level = 0
    for key, val in extra.items():  # other NosnocOpts, e.g. mpcc_mode=ns.MpccMode.SCHOLTES_INEQ
        if not hasattr(o, key):
            raise TypeError(f"unknown NosnocOpts field {key!r}")
        setattr(o, key, val)
    return ns.NosnocSolver(o, _model(ns, ca, height, e, k_tf))


def impact_times(X: np.ndarray, T: float) -> np.ndarray:
    """Impact times as nosnoc computes them: the physical time ``t`` at the finite-element boundary
    where the ball enters ``q <= 0`` (FESD places an element boundary on the switch).  No closed form
    of the flight is used: that would borrow an accuracy the method does not have."""
    q, v, t = np.asarray(X, dtype=float).T
    out = []
    for i in range(len(q) - 1):
        if q[i] > 0.0 and q[i + 1] <= 0.0 and v[i] < 0.0:
            out.append(t[i + 1])
    out = np.array(out)
    return out[out < T]


def solve(height=1.3, e=1.0, T=3.8, n_stages=4, n_fe=4, tol=1e-9, step=0.15, k_tf=100.0,
          clock=False, max_steps=5000, **kw) -> dict:
    """Simulate with nosnoc until the physical clock passes ``T``.

    n_stages: Radau IIA stages per finite element (nosnoc ``n_s``); n_fe: finite elements per
    step; step: numerical time per NLP (one FESD step); tol: nosnoc ``comp_tol`` (Ipopt tol is
    tol/100); **kw: further NosnocOpts fields; k_tf: stiffness of the auxiliary time-freezing dynamics (contact lasts
    pi/sqrt(k_tf) numerical time).  A step whose NLP fails (Ipopt not converged or complementarity residual > 10 tol) is redone together with
    the previous step as one step of ``2*step`` with ``2*n_fe`` elements, else retried with
    ``n_fe + 1``; ``retried_steps`` / ``failed_steps`` count retries / steps still failed.
    """
    import casadi as ca
    import nosnoc as ns
    from castrajectory.models.collision import ball_oracle

    if not 0.0 < e <= 1.0:
        raise ValueError("time-freezing spring needs 0 < e <= 1")
    t0 = time.perf_counter()
    built, n_steps, retried, failed = {}, 0, 0, 0
    variants = {"main": (n_fe, step), "alt": (n_fe + 1, step), "double": (2 * n_fe, 2 * step)}

    def run(key, x):
        if key not in built:
            built[key] = _solver(ns, ca, height, e, k_tf, n_stages, *variants[key], tol, clock, kw)
        built[key].set("x0", x)
        r = built[key].solve()
        comp = float(built[key].problem.comp_res(r["w_sol"], built[key].p_val))  # elastic modes can
        ok = r["status"] == ns.Status.SUCCESS and comp <= 10 * tol  # "succeed" with slack left
        return [np.asarray(y, dtype=float).ravel() for y in r["x_list"]], ok

    x = np.array([height, 0.0, 0.0])
    X, prev = [x], None  # prev: (start state, len(X)) of the last accepted single step
    with contextlib.redirect_stdout(io.StringIO()):  # nosnoc prints Ipopt warnings
        while x[2] < T and n_steps < max_steps:
            n_steps += 1
            xs, ok = run("main", x)
            if not ok and prev is not None:  # typically an impact just after the step start:
                ys, ok = run("double", prev[0])  # redo the previous step and this one as one
                if ok:
                    retried += 1
                    del X[prev[1]:]
                    X += ys
                    x, prev = X[-1], None
                    continue
            if not ok:
                xs, ok = run("alt", x)
                retried += 1
                failed += not ok
            prev = (x, len(X))
            X += xs
            x = X[-1]
    wall = time.perf_counter() - t0
    imp = impact_times(np.array(X), T)
    exact = ball_oracle(height, 0.0, G, e, T)[0]
    err = float(np.max(np.abs(imp - exact))) if len(imp) == len(exact) and len(imp) else math.inf
    status = "ok" if failed == 0 and x[2] >= T else ("failed_steps" if failed else "max_steps")
    return {"status": status, "wall_time_s": wall, "impact_times": imp, "error": err,
            "exact_times": exact, "n_steps": n_steps, "retried_steps": retried, "failed_steps": failed,
            "settings": dict(n_stages=n_stages, n_fe=n_fe, step=step, tol=tol, k_tf=k_tf, clock=clock)}


def cheapest(target: float, settings=None) -> dict:
    """First (cheapest) setting whose impact-time error is <= ``target``, else the most accurate one
    with ``reached=False``.  ``tried`` lists (settings, wall_time_s, error) of all runs."""
    if not available():
        return {"reached": False, "status": "nosnoc not installed", "error": math.inf,
                "wall_time_s": math.nan, "settings": None, "tried": []}
    tried, best = [], None
    for s in (settings or SETTINGS):
        try:
            r = solve(**s)
        except Exception as exc:  # build/solve errors count as a failed setting
            r = {"status": f"error: {exc}", "wall_time_s": math.nan, "error": math.inf, "settings": s}
        tried.append((dict(s), r["wall_time_s"], r["error"]))
        if best is None or r["error"] < best["error"]:
            best = r
        if r["error"] <= target:
            return dict(r, reached=True, tried=tried)
    return dict(best, reached=False, tried=tried)


if __name__ == "__main__":
    if not available():
        raise SystemExit("nosnoc not installed (optional peer)")
    print(f"{'n_stages':>8} {'n_fe':>4} {'step':>5} {'tol':>6} {'steps':>5} {'retry':>5} {'failed':>6} "
          f"{'time [s]':>9} {'error [s]':>10}")
    for s in SETTINGS:
        r = solve(**s)
        print(f"{s['n_stages']:>8} {s['n_fe']:>4} {s['step']:>5} {r['settings']['tol']:>6.0e} {r['n_steps']:>5} "
              f"{r['retried_steps']:>5} {r['failed_steps']:>6} "
              f"{r['wall_time_s']:>9.2f} {r['error']:>10.2e}")
