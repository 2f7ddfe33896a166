"""Two contact-implicit optimal-control problems with ``nosnoc`` 0.2 (optional peer, for the benchmark).

Both are solved the way nosnoc 0.2 solves contact: a hand-made *time-freezing* reformulation (nosnoc 0.2
has no contact model class; this is what its ``examples/hopper_robot`` do by hand and what MATLAB
nosnoc's ``time_freezing.cls_inelastic`` builds automatically) turned into a piecewise-smooth system in
nosnoc's **Step** (Heaviside) representation (``PssMode.STEP``, model given by ``f_x``/``alpha``/``g_z`` as
in ``examples/hopper_robot/hopper_ocp_step.py``), discretised by FESD with Radau IIA and solved by
nosnoc's homotopy of Scholtes-relaxed NLPs (Ipopt/MUMPS).  Why Step and not Stewart: with the dense
8-region Stewart matrix of ``hopper_ocp.py`` six regions share the same flight vector field, the relaxed
NLPs are degenerate and Ipopt stalls (push: 1000 iterations in the first NLP, > 170 s); with the sparse
4-region Stewart matrix the push was infeasible; Step has 3 switching multipliers instead of 8 and solved
the push in 15-60 s.

Time freezing (state ``x = (q, v, L, t)``, ``t`` the physical clock, ``L`` a cost quadrature state).  With
gap ``f_c(q)``, contact normal ``J_n(q)`` and tangent ``J_t(q)`` (``v_n = J_n' v``, ``v_t = J_t' v``) and the
switching functions ``c = (f_c, v_n, v_t)``, ``alpha_i`` the Step value of ``c_i > 0``::

    f_ode     = (v, M^-1 f_v(q, u), l(x, u), 1)             flight: physical time runs
    f_aux_pos = (0, M^-1 (J_n - mu J_t) a_n, 0, 0)           in contact, approaching, v_t > 0: clock frozen
    f_aux_neg = (0, M^-1 (J_n + mu J_t) a_n, 0, 0)           ... v_t < 0
    x' = s_k (th_ode f_ode + th_pos f_aux_pos + th_neg f_aux_neg),
    th_ode = a_0 + (1 - a_0) a_1,  th_pos = (1 - a_0)(1 - a_1) a_2,  th_neg = (1 - a_0)(1 - a_1)(1 - a_2).

The auxiliary dynamics run, with the clock frozen, until ``v_n = 0``: an inelastic impact (restitution 0)
with the Coulomb friction impulse (at most ``mu`` times the normal one); persistent contact is the
Filippov sliding mode on ``f_c = v_n = 0`` (the clock then runs at ``th_ode < 1``).  (nosnoc_py's
``hopper_ocp_step.py`` writes ``th_ode = a_0 + (1 - a_0)(1 - a_1)``, which does not sum with the others to
one; that looks like a slip of that example, so the MATLAB / dense-Stewart logic above is used.)
``s_k`` is a speed-of-time variable per control stage (``SpeedOfTimeVariableMode.LOCAL``) and nosnoc's
clock constraint ``t(end of stage k) = (k + 1) T / N`` holds exactly (``time_freezing_tolerance = 0``):
every control stage spans ``T / N`` physical seconds, so controls are piecewise constant on the uniform
physical grid.  The running cost is integrated by the quadrature state ``L`` in ``f_ode`` only (MATLAB
nosnoc's ``time_freezing_quadrature_state``), so nosnoc's objective is the *physical* integral; without it
the cost would also run during frozen (impact) time and be weighted ``1 / th_ode`` during stance.

1. ``push_to_target`` -- MATLAB nosnoc ``examples/time_freezing/time_freezing_inelastic_tutorial/
   inelastic_2d_ocp.m`` (no Python version exists).  Unit point mass, ``q = (x, y)``, ``v = q'``,
   ``M = I``, ``f_v = (u, -g)``, g = 9.81; ground ``f_c = y >= 0``, ``J_n = (0, 1)``, ``J_t = (1, 0)``,
   e = 0, mu = 0.6, a_n = g (as there); ``q(0) = (0, 1.5)``, ``v(0) = 0``; scalar force ``|u| <= 10``;
   terminal equality ``q(T) = (3, 0)``, ``v(T) = 0``; T = 2; minimise ``int_0^T u^2 dt``; N = 20 control
   stages (u constant on each, 0.1 s), 3 finite elements per stage, Radau IIA with n_s = 2 (the MATLAB
   file uses n_s = 3: measured here it reached the same kind of solution, cost 82.72, but took ~60 s),
   speed of time in [0.99, 10] (as there).  Homotopy "default" as there: sigma_0 = 1, superlinear update
   (x0.1 or ^1.5), 7 NLPs, comp_tol = sigma_N = 1e-9, Ipopt max_iter 1000, Ipopt tol comp_tol / 100 =
   1e-11 (nosnoc_py's default; MATLAB's is 1e-12); its first NLP (sigma = 1) typically ends at 1000
   iterations or a failed restoration, and the homotopy recovers from it.  "tight": comp_tol = sigma_N =
   1e-10, linear update x0.1 (11 NLPs), Ipopt tol 1e-10 (the superlinear update with these tolerances
   ended in a worse local optimum, 83.95, its last NLP only "acceptable"; comp_tol = Ipopt tol = 1e-12:
   the last NLP was declared infeasible).  The landing is at sqrt(2 * 1.5 / g) = 0.5530 s whatever the
   push (no force along y).
2. ``hopper`` -- MATLAB nosnoc ``examples/time_freezing/time_freezing_hopper_ocp/hopper_ocp.m`` (T = 1.5,
   x_goal = 0.7; nosnoc_py's ``examples/hopper_robot/hopper_ocp*.py`` pose the same robot, with
   T = 5 and longer goals).  ``q = (x, y, theta, l)`` (body position, leg angle from the vertical, leg
   length), ``v = q'``; ``M = diag(mb + ml, mb + ml, Ib + Il, ml)`` with mb = 1, ml = 0.1, Ib = 0.25,
   Il = 0.025; ``f_v = -(0, (mb + ml) g, 0, 0) + B(q) (u1, u2)`` with ``B = [[0, -sin theta],
   [0, cos theta], [1, 0], [0, 1]]`` (u1: torque on theta, u2: leg force along the leg); foot gap
   ``f_c = y - l cos theta``; ``J_n = (0, 1, l sin theta, -cos theta)``, ``J_t = (1, 0, l cos theta,
   sin theta)`` (``v_t = J_t' v`` is the foot's slip velocity); mu = 0.45, a_n = 100, e = 0.
   ``x0 = (0.1, 0.5, 0, 0.5, 0, 0, 0, 0)``; controls ``u = (u1, u2, u3)`` in ``[-50, 50]^2 x [0, 100]``
   (u3 is a slack of the original no-slip formulation; it enters only the cost, and is ~0 at the optimum);
   state bounds ``(0, 0, -pi, 0.1, -10, -10, -5, -5) <= x <= (0.8, 1.5, pi, 0.5, 10, 10, 5, 5)``.
   Cost ``int_0^T (x - x_ref,k)' Q (x - x_ref,k) + u' R u dt + (x(T) - x_end)' Q_T (x(T) - x_end)``,
   ``x = (q, v)``, Q = diag(50, 50, 20, 50, 0.1, 0.1, 0.1, 0.1), Q_T = diag(300, 300, 300, 300, 0.1, 0.1,
   0.1, 0.1), R = diag(0.01, 0.01, 1e-5); the reference is constant on control stage k (k = 0..N-1):
   ``x_ref,k = P(k / (N - 1))``, P the parabola (MATLAB's 3-point 'spline') through x0 at 0,
   ``x_mid = (0.4, 0.8, 0, 0.1, 0, 0, 0, 0)`` at 1/2 and ``x_end = (0.7, 0.5, 0, 0.5, 0, 0, 0, 0)`` at 1:
   ``P(s) = x0 (1 - s)(1 - 2 s) + 4 x_mid s (1 - s) + x_end s (2 s - 1)``.  No terminal equality: the goal
   x = 0.7 is only the reference's end.  No-slip in contact as in nosnoc_py's ``hopper_ocp*.py``: path
   complementarities ``v_t (th_pos + th_neg) = 0`` and ``-v_t (th_pos + th_neg) = 0`` (relaxed like the
   others; MATLAB's variant ``v_t u3 = 0, f_c u3 = 0`` is not used).  T = 1.5, N = 20 stages (0.075 s),
   3 finite elements per stage, Radau IIA n_s = 2, speed of time in [1, 25] (MATLAB's defaults).
   Homotopy "default" as nosnoc_py's ``hopper_ocp.py`` (``get_default_options``): sigma_0 = 100, linear
   update x0.1, 6 NLPs (so it stops at sigma = 1e-3: complementarity ~1e-3, by that example's design),
   Ipopt tol comp_tol / 100 = 1e-11, acceptable_tol 1e-6, max_iter 4000.  MATLAB's homotopy (sigma_0 = 1,
   6 NLPs, Ipopt tol 1e-6) failed here: the sigma = 1e-4 NLP ran out of its 4000 iterations.
   "tight": the same from sigma_0 = 100 with the superlinear update (x0.1 or ^1.5) down to comp_tol =
   sigma_N = 1e-9 (9 NLPs); the linear update to 1e-9 (12 NLPs) needs still longer.
   (The initial guess is nosnoc's: every state at x0, u = 0.  The NLP is nonconvex and the answer is a
   local optimum: other guesses or formulations give other gaits, e.g. the dense Stewart variant with a
   clock tolerance 1e-3 gave a Lagrange part of 10.35 against 11.31 here.)

Comparing costs: nosnoc's controls are piecewise constant on the N stages (20 by default), a coarser
control space than a solver with one control per time step; ``push_to_target(N_stages=...)`` refines it
(slower).  Both problems are nonconvex: the costs are those of the local optima nosnoc reaches.

Settings (``setting``): "default" is the example's own homotopy and tolerances, "tight" drives the
complementarity to the tolerance (see ``SETTINGS``).  ``status`` is "ok" when the last NLP of the
homotopy converged (Ipopt ``Solve_Succeeded`` or ``Solved_To_Acceptable_Level``), else
``"ipopt: <its status>"``; read ``complementarity`` (nosnoc's residual: the largest complementarity
product) beside it.  A solve has a time budget (``time_budget_s``, 90 s): no homotopy NLP starts after
it, and Ipopt's ``max_wall_time`` caps each NLP; then ``status`` says "time budget ... exceeded" and the
fields are read off the last finished NLP (its sigma in ``last_sigma``).  ``time_s`` is the wall time
of ``NosnocSolver.solve()`` (all homotopy NLPs), ``build_s`` the construction of the NLP and its Ipopt
instance.  nosnoc is an optional peer, not a dependency of castrajectory: ``available()`` tells whether
it is installed.

Measured (this 2-core machine, ``python scripts/nosnoc_ocp.py``; build 0.5-0.7 s each):

    push    default  ok  cost 82.6625252162  35.0 s  compl. 1.0e-9   landing 0.5530012636 (exact 0.5530012636)
    push    tight    ok  cost 82.6625254388  40.5 s  compl. 9.6e-11  q(T) = (3, 0), v(T) = 0, t(T) = 2
    hopper  default  ok  cost 11.380791 (11.311016 + terminal 0.069775)  23.3 s  compl. 1.0e-3  x(T) = 0.694
    hopper  tight    time budget exceeded: the 8th NLP (sigma = 1.8e-7) hit Ipopt's 90 s wall time (120 s in all)

    python scripts/nosnoc_ocp.py
"""
import contextlib
import copy
import io
import math
import time
import warnings

import numpy as np

G = 9.81
# no new homotopy NLP starts after this many seconds of a solve, and Ipopt's max_wall_time caps each NLP
TIME_BUDGET_S = 90.0

# nosnoc options per problem and setting (see the module doc); ipopt_tol None: nosnoc's comp_tol / 100
SETTINGS = {
    "push": {
        "default": dict(comp_tol=1e-9, sigma_0=1.0, sigma_N=1e-9, rule="superlinear", max_homotopy=7,
                        ipopt_tol=None, max_iter=1000),
        "tight": dict(comp_tol=1e-10, sigma_N=1e-10, sigma_0=1.0, rule="linear", max_homotopy=0,
                      ipopt_tol=1e-10, max_iter=1000),
    },
    "hopper": {
        "default": dict(comp_tol=1e-9, sigma_0=100.0, sigma_N=1e-9, rule="linear", max_homotopy=6,
                        ipopt_tol=None, max_iter=4000),
        "tight": dict(comp_tol=1e-9, sigma_0=100.0, sigma_N=1e-9, rule="superlinear", max_homotopy=0,
                      ipopt_tol=None, max_iter=4000),
    },
}


def available() -> bool:
    """True if ``import nosnoc`` works."""
    try:
        import nosnoc  # noqa: F401
        return True
    except Exception:
        return False


def _step_thetas(ca, alpha):
    """Time-freezing weights (flight, aux v_t > 0, aux v_t < 0) of the Step values of (f_c, v_n, v_t) > 0."""
    return ca.vertcat(alpha[0] + (1 - alpha[0]) * alpha[1],
                      (1 - alpha[0]) * (1 - alpha[1]) * alpha[2],
                      (1 - alpha[0]) * (1 - alpha[1]) * (1 - alpha[2]))


def _options(ns, s, N, n_fe, T, sot, budget):
    o = ns.NosnocOpts()
    o.opts_casadi_nlp = copy.deepcopy(o.opts_casadi_nlp)  # a class-level dict in nosnoc 0.2
    o.opts_casadi_nlp["ipopt"].update(print_level=0, sb="yes", max_iter=int(s["max_iter"]), acceptable_tol=1e-6,
                                      max_wall_time=float(budget))
    if "acceptable_iter" in s:
        o.opts_casadi_nlp["ipopt"]["acceptable_iter"] = int(s["acceptable_iter"])
    o.irk_scheme, o.n_s = ns.IrkSchemes.RADAU_IIA, 2
    o.pss_mode, o.use_fesd = ns.PssMode.STEP, True
    o.mpcc_mode = ns.MpccMode.SCHOLTES_INEQ
    o.cross_comp_mode = ns.CrossComplementarityMode.SUM_LAMBDAS_COMPLEMENT_WITH_EVERY_THETA
    o.step_equilibration = ns.StepEquilibrationMode.HEURISTIC_MEAN
    o.comp_tol, o.sigma_0, o.sigma_N = s["comp_tol"], s["sigma_0"], s["sigma_N"]
    o.homotopy_update_slope = 0.1
    o.homotopy_update_rule = (ns.HomotopyUpdateRule.SUPERLINEAR if s["rule"] == "superlinear"
                              else ns.HomotopyUpdateRule.LINEAR)
    o.max_iter_homotopy = int(s["max_homotopy"])  # 0: nosnoc's count from comp_tol and sigma_0
    if s["ipopt_tol"] is not None:
        o.tol_ipopt = s["ipopt_tol"]
    o.time_freezing, o.time_freezing_tolerance = True, 0.0
    o.speed_of_time_variables = ns.SpeedOfTimeVariableMode.LOCAL
    o.speed_of_time_min, o.speed_of_time_max = sot
    o.N_stages, o.N_finite_elements, o.terminal_time = int(N), int(n_fe), float(T)
    o.equidistant_control_grid = True
    o.print_level = 0
    return o


class _OverBudget(Exception):
    pass


class _Budgeted:
    """Stands in for nosnoc's Ipopt ``Function`` (``solver.solver``): refuses to start another homotopy NLP
    once ``budget`` seconds of the solve have passed (each NLP is also capped by Ipopt's max_wall_time),
    and keeps the last NLP's solution, sigma and statistics."""

    def __init__(self, nlp, budget, i_sigma):
        self.nlp, self.budget, self.i_sigma, self.t0 = nlp, budget, i_sigma, time.perf_counter()
        self.last, self.sigma, self.iters = None, math.nan, []

    def __call__(self, **kw):
        if time.perf_counter() - self.t0 > self.budget:
            raise _OverBudget(f"time budget {self.budget:g} s exceeded after {len(self.iters)} homotopy NLPs "
                              f"(last sigma {self.sigma:.1e}, Ipopt: {self.stats().get('return_status', '?')})")
        self.last = self.nlp(**kw)
        self.sigma = float(np.asarray(kw["p"]).ravel()[self.i_sigma])
        self.iters.append(int(self.nlp.stats().get("iter_count", 0)))
        return self.last

    def stats(self):
        return self.nlp.stats()


def _solve(ns, build, budget):
    """Build (timed) and solve (timed) with nosnoc's and Ipopt's printing suppressed.  If the time budget
    runs out, the results are read off the last finished homotopy NLP and the status says so."""
    from nosnoc.solver import get_results_from_primal_vector

    with contextlib.redirect_stdout(io.StringIO()), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # nosnoc warns about path complementarities (hopper)
        t0 = time.perf_counter()
        solver = build()
        t1 = time.perf_counter()
        model = solver.problem.model
        i_sigma = model.p_val_ctrl_stages.size  # p = (stage parameters, sigma, tau, lambda00, x0)
        solver.solver = guard = _Budgeted(solver.solver, budget, i_sigma)
        try:
            r = solver.solve()
            status = "ok" if r["status"] == ns.Status.SUCCESS else f"ipopt: {guard.stats()['return_status']}"
        except _OverBudget as exc:
            status = str(exc)
            if guard.last is None:
                return solver, None, dict(status=status, time_s=time.perf_counter() - t1, build_s=t1 - t0)
            r = get_results_from_primal_vector(solver.problem, guard.last["x"].full().ravel())
            r["w_sol"], r["cost_val"] = guard.last["x"].full().ravel(), float(guard.last["f"])
        t2 = time.perf_counter()
    comp = float(solver.problem.comp_res(r["w_sol"], solver.p_val))
    return solver, r, dict(status=status, ipopt_status=guard.stats().get("return_status", "?"), time_s=t2 - t1,
                           build_s=t1 - t0, complementarity=comp, iterations=int(sum(guard.iters)),
                           nlp_iterations=guard.iters, homotopy_steps=len(guard.iters), last_sigma=guard.sigma)


def _solved(ns, build, budget, formulation):
    """:func:`_solve`, with a build or solve error, or a budget spent before any NLP finished, this setting's failure:
    ``(results, out)``, the results ``None`` for a failure (``out`` its dict, :func:`_failure`)."""
    try:
        _, r, out = _solve(ns, build, budget)
    except Exception as exc:  # a build or solve error is this setting's failure
        return None, _failure(f"error: {exc}", formulation)
    if r is None:
        return None, _failure(out["status"], formulation, out["time_s"], out["build_s"])
    return r, out


def _failure(msg, formulation, time_s=math.nan, build_s=math.nan):
    nan = math.nan
    return {"status": msg, "cost": nan, "time_s": time_s, "build_s": build_s, "complementarity": nan,
            "t": np.array([]), "q": np.zeros((0, 0)), "u": np.zeros((0, 0)), "iterations": 0,
            "formulation": formulation}


PUSH_FORMULATION = "time-freezing (inelastic, Coulomb), Step PSS, FESD Radau IIA n_s=2, Scholtes homotopy"


def push_to_target(N_stages: int = 20, setting: str = "default", time_budget_s: float = TIME_BUDGET_S) -> dict:
    """nosnoc's inelastic 2-D OCP (see the module doc); ``N_stages`` control stages of T / N_stages, 3 FE each.

    Returns status, cost (int u^2 dt, the quadrature state L(T)), time_s, build_s, complementarity,
    t (physical time at the finite-element boundaries), q (positions there), u (per control stage),
    t_u (stage starts), iterations, formulation, and the checks: landing_time (physical time of the first
    finite-element boundary with y <= 1e-7), landing_exact, q_T, v_T, cost_stagewise (sum u_k^2 dt_k)."""
    if not available():
        return _failure("nosnoc not installed", PUSH_FORMULATION)
    import casadi as ca
    import nosnoc as ns

    if setting not in SETTINGS["push"]:
        raise ValueError(f"setting must be one of {sorted(SETTINGS['push'])}")
    s = SETTINGS["push"][setting]
    T, y0, goal, mu, u_max, a_n, n_fe = 2.0, 1.5, 3.0, 0.6, 10.0, G, 3

    def build():
        q, v = ca.SX.sym("q", 2), ca.SX.sym("v", 2)
        L, t, u = ca.SX.sym("L"), ca.SX.sym("t"), ca.SX.sym("u")
        f_ode = ca.vertcat(v, u, -G, u ** 2, 1)
        f_pos = ca.vertcat(0, 0, -mu * a_n, a_n, 0, 0)  # M^-1 (J_n - mu J_t) a_n, J_n = (0, 1), J_t = (1, 0)
        f_neg = ca.vertcat(0, 0, mu * a_n, a_n, 0, 0)
        alpha, th = ca.SX.sym("alpha", 3), ca.SX.sym("theta", 3)
        model = ns.NosnocModel(
            x=ca.vertcat(q, v, L, t), f_x=[th[0] * f_ode + th[1] * f_pos + th[2] * f_neg], alpha=[alpha],
            c=[ca.vertcat(q[1], v[1], v[0])], z=th, z0=np.array([1.0, 0.0, 0.0]), g_z=th - _step_thetas(ca, alpha),
            u=u, x0=np.array([0.0, y0, 0.0, 0.0, 0.0, 0.0]), t_var=t, name="push_to_target")
        ocp = ns.NosnocOcp(lbu=np.array([-u_max]), ubu=np.array([u_max]), f_terminal=L,
                           g_terminal=ca.vertcat(q - np.array([goal, 0.0]), v))
        return ns.NosnocSolver(_options(ns, s, N_stages, n_fe, T, (0.99, 10.0), time_budget_s), model, ocp)

    r, out = _solved(ns, build, time_budget_s, PUSH_FORMULATION)
    if r is None:
        return out
    X = np.array(r["x_traj"], dtype=float)  # (N_stages * n_fe + 1) x 6 at the finite-element boundaries
    U = np.array(r["u_list"], dtype=float).reshape(N_stages, 1)
    t = X[:, 5]
    t_stage = t[::n_fe]
    landed = np.nonzero(X[:, 1] <= 1e-7)[0]
    out.update(cost=float(X[-1, 4]), t=t, q=X[:, :2], v=X[:, 2:4], u=U, t_u=t_stage[:-1],
               formulation=PUSH_FORMULATION, setting=setting, options=dict(s),
               cost_stagewise=float(np.sum(U[:, 0] ** 2 * np.diff(t_stage))),
               objective=float(r["cost_val"]), speed_of_time=np.array(r["sot"], dtype=float).ravel(),
               landing_time=float(t[landed[0]]) if landed.size else math.nan,
               landing_exact=math.sqrt(2 * y0 / G), q_T=X[-1, :2], v_T=X[-1, 2:4], t_T=float(t[-1]))
    return out


HOPPER_FORMULATION = ("time-freezing (inelastic, Coulomb, no-slip path comp.), Step PSS, FESD Radau IIA n_s=2, "
                      "Scholtes homotopy")


def hopper_reference(N: int = 20) -> np.ndarray:
    """The hopper's stage references x_ref,k = P(k / (N - 1)), k = 0..N-1 (module doc), N x 8."""
    x0 = np.array([0.1, 0.5, 0, 0.5, 0, 0, 0, 0])
    x_mid = np.array([0.4, 0.8, 0, 0.1, 0, 0, 0, 0])
    x_end = np.array([0.7, 0.5, 0, 0.5, 0, 0, 0, 0])
    s = np.linspace(0.0, 1.0, N)[:, None]
    return x0 * (1 - s) * (1 - 2 * s) + 4 * x_mid * s * (1 - s) + x_end * s * (2 * s - 1)


def hopper(setting: str = "default", time_budget_s: float = TIME_BUDGET_S) -> dict:
    """nosnoc's hopper OCP (MATLAB hopper_ocp.m: T = 1.5, x_goal = 0.7; see the module doc).

    Returns status, cost (the example's: quadrature L(T) plus the terminal term), lagrange, terminal,
    time_s, build_s, complementarity, t, q (x, y, theta, l at the finite-element boundaries), v, u (per
    stage, 3 columns), t_u, iterations, formulation, and checks: x_T, min_gap (smallest foot gap at the
    boundaries), max_slip (largest |v_t| at boundaries in contact, gap <= 1e-6)."""
    if not available():
        return _failure("nosnoc not installed", HOPPER_FORMULATION)
    import casadi as ca
    import nosnoc as ns

    if setting not in SETTINGS["hopper"]:
        raise ValueError(f"setting must be one of {sorted(SETTINGS['hopper'])}")
    s = SETTINGS["hopper"][setting]
    N, n_fe, T, x_goal = 20, 3, 1.5, 0.7
    mb, ml, Ib, Il, mu, a_n = 1.0, 0.1, 0.25, 0.025, 0.45, 100.0
    M = np.diag([mb + ml, mb + ml, Ib + Il, ml])
    iM = np.linalg.inv(M)
    Q = np.diag([50, 50, 20, 50, 0.1, 0.1, 0.1, 0.1])
    QT = np.diag([300, 300, 300, 300, 0.1, 0.1, 0.1, 0.1])
    R = np.diag([0.01, 0.01, 1e-5])
    x_ref = hopper_reference(N)
    x_end = np.array([x_goal, 0.5, 0, 0.5, 0, 0, 0, 0])
    x0 = x_ref[0]
    sym = {}

    def build():
        q, v = ca.SX.sym("q", 4), ca.SX.sym("v", 4)
        L, t, u = ca.SX.sym("L"), ca.SX.sym("t"), ca.SX.sym("u", 3)
        xs = ca.vertcat(q, v)
        p_ref = ca.SX.sym("x_ref", 8)
        B = ca.vertcat(ca.horzcat(0, -ca.sin(q[2])), ca.horzcat(0, ca.cos(q[2])), ca.horzcat(1, 0), ca.horzcat(0, 1))
        J_n = ca.vertcat(0, 1, q[3] * ca.sin(q[2]), -ca.cos(q[2]))
        J_t = ca.vertcat(1, 0, q[3] * ca.cos(q[2]), ca.sin(q[2]))
        v_n, v_t = J_n.T @ v, J_t.T @ v
        f_c = q[1] - q[3] * ca.cos(q[2])
        f_v = -np.array([0, (mb + ml) * G, 0, 0]) + B @ u[:2]
        running = (xs - p_ref).T @ Q @ (xs - p_ref) + u.T @ R @ u
        f_ode = ca.vertcat(v, iM @ f_v, running, 1)
        f_pos = ca.vertcat(ca.SX.zeros(4), iM @ (J_n - mu * J_t) * a_n, 0, 0)
        f_neg = ca.vertcat(ca.SX.zeros(4), iM @ (J_n + mu * J_t) * a_n, 0, 0)
        alpha, th = ca.SX.sym("alpha", 3), ca.SX.sym("theta", 3)
        model = ns.NosnocModel(
            x=ca.vertcat(xs, L, t), f_x=[th[0] * f_ode + th[1] * f_pos + th[2] * f_neg], alpha=[alpha],
            c=[ca.vertcat(f_c, v_n, v_t)], z=th, z0=np.array([1.0, 0.0, 0.0]), g_z=th - _step_thetas(ca, alpha),
            u=u, x0=np.concatenate((x0, [0.0, 0.0])), p_time_var=p_ref, p_time_var_val=x_ref, t_var=t,
            name="hopper")
        no_slip = ca.horzcat(ca.vertcat(v_t, -v_t), ca.vertcat(th[1] + th[2], th[1] + th[2]))
        lbx = np.array([0, 0, -np.pi, 0.1, -10, -10, -5, -5, -np.inf, -np.inf])
        ubx = np.array([x_goal + 0.1, 1.5, np.pi, 0.5, 10, 10, 5, 5, np.inf, np.inf])
        ocp = ns.NosnocOcp(lbu=np.array([-50.0, -50.0, 0.0]), ubu=np.array([50.0, 50.0, 100.0]), u_guess=np.zeros(3),
                           f_terminal=(xs - x_end).T @ QT @ (xs - x_end) + L, g_path_comp=no_slip, lbx=lbx, ubx=ubx)
        sym["gap"] = ca.Function("gap", [xs], [f_c])
        sym["slip"] = ca.Function("slip", [xs], [v_t])
        return ns.NosnocSolver(_options(ns, s, N, n_fe, T, (1.0, 25.0), time_budget_s), model, ocp)

    r, out = _solved(ns, build, time_budget_s, HOPPER_FORMULATION)
    if r is None:
        return out
    X = np.array(r["x_traj"], dtype=float)  # (N * n_fe + 1) x 10: q, v, L, t
    U = np.array(r["u_list"], dtype=float).reshape(N, 3)
    t = X[:, 9]
    dx = X[-1, :8] - x_end
    terminal = float(dx @ QT @ dx)
    gap = np.array(sym["gap"](X[:, :8].T)).ravel()
    slip = np.array(sym["slip"](X[:, :8].T)).ravel()
    contact = gap <= 1e-6
    out.update(cost=float(X[-1, 8]) + terminal, lagrange=float(X[-1, 8]), terminal=terminal, t=t, q=X[:, :4],
               v=X[:, 4:8], u=U, t_u=t[::n_fe][:-1], formulation=HOPPER_FORMULATION, setting=setting,
               options=dict(s), objective=float(r["cost_val"]),
               speed_of_time=np.array(r["sot"], dtype=float).ravel(), x_T=float(X[-1, 0]), q_T=X[-1, :4],
               t_T=float(t[-1]), min_gap=float(gap.min()),
               max_slip=float(np.max(np.abs(slip[contact]))) if contact.any() else 0.0)
    return out


def _row(name, setting, r):
    return (f"{name:<7} {setting:<8} {r['status']:<10.10} {r['cost']:>12.6f} {r['time_s']:>8.2f} {r['build_s']:>7.2f} "
            f"{r['complementarity']:>9.1e} {r['iterations']:>6}")


if __name__ == "__main__":
    if not available():
        raise SystemExit("nosnoc not installed (optional peer)")
    print(f"{'problem':<7} {'setting':<8} {'status':<10} {'cost':>12} {'time [s]':>8} {'build':>7} {'compl.':>9} "
          f"{'iters':>6}")
    results = {}
    for setting in ("default", "tight"):
        results["push", setting] = r = push_to_target(setting=setting)
        print(_row("push", setting, r))
        results["hopper", setting] = r = hopper(setting=setting)
        print(_row("hopper", setting, r))
    print()
    for (name, setting), r in results.items():
        if r["status"] != "ok":
            print(f"{name:<6} {setting:<8} status: {r['status']}")
    for setting in ("default", "tight"):
        r = results["push", setting]
        if np.size(r["q"]):
            print(f"push   {setting:<8} landing {r['landing_time']:.10f} s (free fall {r['landing_exact']:.10f}); "
                  f"q(T) = ({r['q_T'][0]:.12g}, {r['q_T'][1]:.1e}), v(T) = ({r['v_T'][0]:.1e}, {r['v_T'][1]:.1e}), "
                  f"t(T) = {r['t_T']:.12g}; sum u_k^2 dt_k = {r['cost_stagewise']:.10f}")
        r = results["hopper", setting]
        if np.size(r["q"]):
            print(f"hopper {setting:<8} x(T) = {r['x_T']:.4f} (goal 0.7), q(T) = {np.round(r['q_T'], 4)}, "
                  f"t(T) = {r['t_T']:.12g}; min gap {r['min_gap']:.1e}, max slip in contact {r['max_slip']:.1e}; "
                  f"lagrange {r['lagrange']:.6f} + terminal {r['terminal']:.6f}")
