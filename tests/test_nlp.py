"""Tests of the NLP core: values, multipliers (sign convention and sensitivities),
failure reporting, output, timing, complementarity and naming rules."""
from __future__ import annotations

import time

import casadi as ca
import numpy as np
import pytest

from castrajectory.solve.nlp import NLP, X
from castrajectory.result import SolveError

SYMBOLICS = pytest.mark.parametrize("sym", [ca.SX, ca.MX], ids=["SX", "MX"])


# ----------------------------------------------------------------------------- a convex QP with known KKT point
#
#   min (x-3)² + 2(y-1)² + z² + (u-5)² + (v+1)² + (s-1)² + (w-4)²
#   s.t.  x + 2y = b          (equality)          b = 2
#         2z >= c             (active lower)      c = 2
#         u <= d              (active upper)      d = 1
#         0 <= w <= 10        (inactive)
#         v >= lv             (variable bound)    lv = 2
#         s <= us             (variable bound)    us = -1
#
# By hand (Lagrange):  x - 3 = y - 1 = mu/2 with 5 + 1.5 mu = b  =>  mu = (b - 5)/1.5,
#   f*(b) = 0.75 mu²,  df*/db = mu = -2;  z = c/2, df*/dc = c/2 = 1;
#   u = d, df*/dd = 2(d-5) = -8;  v = lv, df*/dlv = 2(lv+1) = 6;  s = us, df*/dus = 2(us-1) = -4.
QP_RHS = {"b": 2.0, "c": 2.0, "d": 1.0, "lv": 2.0, "us": -1.0}


def qp_exact(b, c, d, lv, us):
    mu = (b - 5.0) / 1.5
    x, y = 3.0 + mu / 2, 1.0 + mu / 2
    z, u, v, s, w = c / 2, d, lv, us, 4.0
    f = (x - 3) ** 2 + 2 * (y - 1) ** 2 + z ** 2 + (u - 5) ** 2 + (v + 1) ** 2 + (s - 1) ** 2 + (w - 4) ** 2
    values = dict(x=x, y=y, z=z, u=u, v=v, s=s, w=w)
    mult = {"eq": mu, "low": c / 2, "up": 2 * (d - 5), "box": 0.0}
    bmult = dict(x=0.0, y=0.0, z=0.0, u=0.0, v=2 * (lv + 1), s=2 * (us - 1), w=0.0)
    return values, f, mult, bmult


def build_qp(sym=ca.SX, b=2.0, c=2.0, d=1.0, lv=2.0, us=-1.0):
    nlp = NLP(sym)
    x = nlp.variable("x")
    y = nlp.variable("y")
    z = nlp.variable("z")
    u = nlp.variable("u")
    v = nlp.variable("v", lb=lv, init=lv + 1.0)
    s = nlp.variable("s", ub=us, init=us - 1.0)
    w = nlp.variable("w", init=1.0)
    f = (x - 3) ** 2 + 2 * (y - 1) ** 2 + z ** 2 + (u - 5) ** 2 + (v + 1) ** 2 + (s - 1) ** 2 + (w - 4) ** 2
    nlp.minimize(f)
    nlp.equal("eq", x + 2 * y, b)
    nlp.inequality("low", 2 * z, lb=c)
    nlp.inequality("up", u, ub=d)
    nlp.inequality("box", w, lb=0.0, ub=10.0)
    syms = dict(x=x, y=y, z=z, u=u, v=v, s=s, w=w)
    return nlp, syms, f


def kkt_stationarity(nlp_syms, f, constraints, res):
    """|grad f - J^T m - m_x| at the solution, with J from CasADi (independent of the NLP's own bookkeeping)."""
    names = list(nlp_syms)
    X = ca.vertcat(*[nlp_syms[k] for k in names])
    G = ca.vertcat(*[g for _, g in constraints])
    fun = ca.Function("kkt", [X], [ca.gradient(f, X), ca.jacobian(G, X)])
    xv = np.concatenate([res[k] for k in names])
    grad, jac = (np.asarray(v, float) for v in fun(xv))
    m = np.concatenate([res.multipliers[name] for name, _ in constraints])
    mx = np.concatenate([res.bound_multipliers[k] for k in names])
    return np.max(np.abs(grad.reshape(-1) - jac.T @ m - mx))


@SYMBOLICS
def test_qp_values_objective_and_multipliers(sym):
    nlp, syms, f = build_qp(sym)
    res = nlp.solve()
    assert res.success and res.solver_status == "Solve_Succeeded" and res.status == "ok"
    values, fstar, mult, bmult = qp_exact(**QP_RHS)
    for k, v in values.items():
        assert res[k] == pytest.approx([v], abs=1e-7), k
    assert res.objective == pytest.approx(fstar, rel=1e-7)
    for k, m in mult.items():
        assert res.multipliers[k] == pytest.approx([m], abs=1e-6), k
    for k, m in bmult.items():
        assert res.bound_multipliers[k] == pytest.approx([m], abs=1e-6), k
    # sign convention spelled out
    assert res.multipliers["low"][0] > 0.5          # lower bound active -> positive
    assert res.multipliers["up"][0] < -0.5          # upper bound active -> negative
    assert res.bound_multipliers["v"][0] > 0.5      # variable lower bound active -> positive
    assert res.bound_multipliers["s"][0] < -0.5     # variable upper bound active -> negative
    # KKT stationarity with the reported multipliers: grad f = J^T m + m_x
    cons = [("eq", syms["x"] + 2 * syms["y"]), ("low", 2 * syms["z"]), ("up", syms["u"]), ("box", syms["w"])]
    assert kkt_stationarity(syms, f, cons, res) < 1e-7


@pytest.mark.parametrize("rhs, multiplier", [
    ("b", ("multipliers", "eq")),
    ("c", ("multipliers", "low")),
    ("d", ("multipliers", "up")),
    ("lv", ("bound_multipliers", "v")),
    ("us", ("bound_multipliers", "s")),
])
def test_qp_multiplier_is_derivative_of_optimal_objective(rhs, multiplier):
    """multiplier = d f*/d rhs, checked by a central difference of re-solved problems."""
    base = build_qp()[0].solve()
    reported = getattr(base, multiplier[0])[multiplier[1]][0]
    h = 1e-4
    fp = build_qp(**{**QP_RHS, rhs: QP_RHS[rhs] + h})[0].solve()
    fm = build_qp(**{**QP_RHS, rhs: QP_RHS[rhs] - h})[0].solve()
    assert fp.success and fm.success
    fd = (fp.objective - fm.objective) / (2 * h)
    assert reported == pytest.approx(fd, rel=1e-5, abs=1e-6)


# ----------------------------------------------------------------------------- nonlinear convex problems
def disk_problem(sym, rhs, kind):
    """min x + y  s.t. x² + y² (= or <=) rhs: x = y = -sqrt(rhs/2), f* = -sqrt(2 rhs), df*/drhs = -1/sqrt(2 rhs)."""
    nlp = NLP(sym)
    x = nlp.variable("x", 2, init=[0.3, -0.2])
    nlp.minimize(x[0] + x[1])
    if kind == "equality":
        nlp.equal("disk", ca.sumsqr(x), rhs)
    else:
        nlp.inequality("disk", ca.sumsqr(x), ub=rhs)
    return nlp


def hyperbola_problem(sym, rhs, kind):
    """min x² + y²  s.t. x y >= rhs, x, y >= 0: x = y = sqrt(rhs), f* = 2 rhs, df*/drhs = 2."""
    nlp = NLP(sym)
    x = nlp.variable("x", 2, lb=0.0, init=[2.0, 1.5])
    nlp.minimize(ca.sumsqr(x))
    nlp.inequality("hyp", x[0] * x[1], lb=rhs)
    return nlp


@SYMBOLICS
@pytest.mark.parametrize("problem, name, kind, rhs, xstar, fstar, dfstar", [
    (disk_problem, "disk", "equality", 2.0, [-1.0, -1.0], -2.0, -0.5),
    (disk_problem, "disk", "upper", 8.0, [-2.0, -2.0], -4.0, -0.25),
    (hyperbola_problem, "hyp", "lower", 4.0, [2.0, 2.0], 8.0, 2.0),
])
def test_nonlinear_multiplier_analytic_and_fd(sym, problem, name, kind, rhs, xstar, fstar, dfstar):
    res = problem(sym, rhs, kind).solve()
    assert res.success
    assert res["x"] == pytest.approx(xstar, abs=1e-7)
    assert res.objective == pytest.approx(fstar, rel=1e-8)
    assert res.multipliers[name][0] == pytest.approx(dfstar, rel=1e-6)
    h = 1e-4 * rhs
    fp, fm = problem(sym, rhs + h, kind).solve(), problem(sym, rhs - h, kind).solve()
    assert res.multipliers[name][0] == pytest.approx((fp.objective - fm.objective) / (2 * h), rel=1e-6)
    # bounds x >= 0 of the hyperbola problem are inactive: zero bound multipliers
    assert np.max(np.abs(res.bound_multipliers["x"])) < 1e-7


# ----------------------------------------------------------------------------- failure is reported
def rosenbrock(sym=ca.SX):
    nlp = NLP(sym)
    x = nlp.variable("x", 2, init=[-1.2, 1.0])
    nlp.minimize((1 - x[0]) ** 2 + 100 * (x[1] - x[0] ** 2) ** 2)
    return nlp


def test_max_iter_reported_not_raised():
    res = rosenbrock().solve(options={"max_iter": 1})
    assert res.success is False
    assert res.status == "Maximum_Iterations_Exceeded"
    assert "Maximum_Iterations_Exceeded" in res.message and "max_iter" in res.message
    assert res.iterations == 1
    with pytest.raises(SolveError) as info:
        res.raise_for_status()
    assert info.value.result is res
    assert "Maximum_Iterations_Exceeded" in str(info.value)


def test_success_raise_for_status_returns_result():
    res = rosenbrock().solve()
    assert res.success and res.raise_for_status() is res
    assert res["x"] == pytest.approx([1.0, 1.0], abs=1e-8)


@pytest.mark.parametrize("case", ["negative_square", "bounds_vs_constraint"])
def test_infeasible_problem_reported(case):
    nlp = NLP()
    if case == "negative_square":
        x = nlp.variable("x", 2, init=1.0)
        nlp.minimize(ca.sumsqr(x))
        nlp.equal("impossible", ca.sumsqr(x), -1.0)
    else:
        x = nlp.variable("x", 1, lb=0.0, ub=1.0)
        nlp.minimize(x ** 2)
        nlp.inequality("impossible", x, lb=2.0)
    res = nlp.solve()
    assert res.success is False
    assert res.status != "Solve_Succeeded"
    assert res.status in res.message
    with pytest.raises(SolveError):
        res.raise_for_status()


# ----------------------------------------------------------------------------- output
def test_quiet_by_default(capfd):
    capfd.readouterr()
    res = rosenbrock().solve()
    out, err = capfd.readouterr()
    assert res.success
    assert out == ""
    assert "Ipopt" not in err


def test_quiet_on_failure(capfd):
    capfd.readouterr()
    res = rosenbrock().solve(options={"max_iter": 2})
    out, _ = capfd.readouterr()
    assert not res.success
    assert out == ""


def test_verbose_prints_ipopt_log(capfd):
    capfd.readouterr()
    res = rosenbrock().solve(verbose=True)
    out, _ = capfd.readouterr()
    assert res.success
    assert "Ipopt" in out
    assert "EXIT: Optimal Solution Found" in out
    assert "iter" in out and "objective" in out


# ----------------------------------------------------------------------------- timing and solver reuse
def test_build_and_solve_times_positive_and_separate():
    t0 = time.perf_counter()
    nlp = rosenbrock()
    r1 = nlp.solve()
    wall = time.perf_counter() - t0
    assert r1.build_time_s > 0 and r1.solve_time_s > 0
    # the two intervals do not overlap: together they fit in the measured wall time
    assert r1.build_time_s + r1.solve_time_s <= wall
    r2 = nlp.solve()
    assert r2.success
    assert r2.build_time_s == r1.build_time_s  # no rebuild
    assert r2.solve_time_s > 0


def test_parameter_change_reuses_solver():
    nlp = NLP()
    x = nlp.variable("x", 2, init=[-1.2, 1.0])
    p = nlp.parameter("p", 1, value=1.0)
    nlp.minimize((p - x[0]) ** 2 + 100 * (x[1] - x[0] ** 2) ** 2)
    r1 = nlp.solve()
    nlp.set_parameter("p", 2.0)
    r2 = nlp.solve()
    assert r1.success and r2.success
    assert r1["x"] == pytest.approx([1.0, 1.0], abs=1e-8)
    assert r2["x"] == pytest.approx([2.0, 4.0], abs=1e-8)
    assert r2.build_time_s == r1.build_time_s
    # a warm start at the solution needs (almost) no iterations
    r3 = nlp.solve(warm=r2)
    assert r3.success and r3.iterations <= 1 < r2.iterations
    # an explicit initial guess by name is used
    r4 = nlp.solve(init={"x": [2.0, 4.0]})
    assert r4.success and r4.iterations <= 1


def test_rebuild_time_excludes_earlier_work():
    nlp = rosenbrock()
    nlp.solve()
    time.sleep(0.3)
    t0 = time.perf_counter()
    r = nlp.solve(options={"tol": 1e-9})  # different options: solver is rebuilt
    wall = time.perf_counter() - t0
    assert r.build_time_s <= wall


def test_nlp_frozen_after_build():
    nlp = rosenbrock()
    nlp.solve()
    with pytest.raises(RuntimeError):
        nlp.variable("late")
    with pytest.raises(RuntimeError):
        nlp.equal("late", ca.SX.sym("q"), 0.0)


# ----------------------------------------------------------------------------- names and symbolics
@SYMBOLICS
def test_duplicate_names_rejected(sym):
    nlp = NLP(sym)
    x = nlp.variable("x", 2)
    with pytest.raises(ValueError, match="duplicate"):
        nlp.variable("x", 1)
    with pytest.raises(ValueError, match="duplicate"):
        nlp.parameter("x", 1)
    nlp.parameter("p")
    with pytest.raises(ValueError, match="duplicate"):
        nlp.variable("p")
    nlp.equal("c", x[0], 1.0)
    with pytest.raises(ValueError, match="duplicate"):
        nlp.inequality("c", x[1], lb=0.0)


def test_objective_set_once_and_required():
    nlp = NLP()
    x = nlp.variable("x")
    with pytest.raises(ValueError, match="objective"):
        nlp.solve()
    nlp.minimize(x ** 2)
    with pytest.raises(ValueError, match="objective"):
        nlp.minimize(x ** 4)


def test_inconsistent_bounds_rejected():
    nlp = NLP()
    x = nlp.variable("x", 2)
    with pytest.raises(ValueError):
        nlp.inequality("bad", x, lb=1.0, ub=0.0)
    with pytest.raises(ValueError):
        nlp.variable("y", 3, init=[1.0, 2.0])


@SYMBOLICS
def test_symbolic_kinds_agree(sym):
    res = build_qp(sym)[0].solve()
    ref = build_qp(ca.SX)[0].solve()
    for k in ref.values:
        assert res[k] == pytest.approx(ref[k], abs=1e-9)
    for k in ref.multipliers:
        assert res.multipliers[k] == pytest.approx(ref.multipliers[k], abs=1e-7)


# ----------------------------------------------------------------------------- compiled element functions
def _element_chain_nlp(E: int, hessian: str = "exact") -> NLP:
    """A nonlinear chain with every kind of element argument (shared variable, parameter, constants)."""
    from castrajectory.solve.nlp import P

    a, b, s, c, k = (ca.SX.sym(n) for n in "abs" "ck")
    con = ca.Function("con", [a, b, s, c, k], [ca.vertcat(ca.sin(a) * b ** 2 + s * c - k, a * ca.exp(0.1 * b) * s)])
    obj = ca.Function("obj", [a, b, s], [ca.cos(a) * b ** 2 + ca.log(1 + s ** 2) * a])
    nlp = NLP(hessian=hessian)
    nlp.variable("x", E + 1, init=np.linspace(0.3, 1.1, E + 1))
    nlp.variable("s", 1, init=0.7)
    nlp.parameter("k", 1, value=0.4)
    xi, si = nlp.index("x"), nlp.index("s")
    e = np.arange(E)
    cst = np.linspace(-1.0, 1.0, E)[:, None]
    nlp.equal_elements("con", con, [X(xi[e, None]), X(xi[e + 1, None]), X(si), cst, P(nlp.parameter_index("k"))])
    if hessian == "exact":
        nlp.minimize_elements("obj", obj, [X(xi[e, None]), X(xi[e + 1, None]), X(si)])
    else:
        nlp.minimize(ca.SX(0))
    return nlp


def _evaluate_functions(nlp: NLP, seed: int = 0) -> dict:
    rng = np.random.default_rng(seed)
    fns = nlp.functions()
    nx = fns["jac_g"].size1_in(0)
    ng = fns["jac_g"].size1_out(0)
    x, p = rng.uniform(0.2, 1.2, nx), np.array([0.4])
    lam_g = rng.standard_normal(ng)
    out = {"g": fns["jac_g"](x, p)[0], "jac_g": fns["jac_g"](x, p)[1], "grad_f": fns["grad_f"](x, p)[1],
           "hess": fns["hess_lag"](x, p, 0.8, lam_g)}
    return {k: ca.DM(v) for k, v in out.items()}


@pytest.mark.parametrize("E", [5, 200, 1301])  # a plain map (5, 200); chunks of 64 plus a rest (1301)
def test_compiled_elements_match_virtual_machine(monkeypatch, tmp_path, E):
    """Compiled and interpreted element functions give the same Jacobian and Hessian (1e-12)."""
    from castrajectory.solve import jit, nlp as nlp_mod

    if jit.compiler() is None:
        pytest.skip("no C compiler")
    monkeypatch.setenv("CASTRAJECTORY_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(nlp_mod, "JIT_MIN_ELEMENTS", 1)
    monkeypatch.setattr(nlp_mod, "_KERNELS", {})  # kernels of an earlier case would be found by their form
    before = dict(jit.stats)
    monkeypatch.setattr(nlp_mod, "JIT", True)
    compiled = _evaluate_functions(_element_chain_nlp(E))
    assert jit.stats["compiled"] + jit.stats["memory_hits"] + jit.stats["cache_hits"] > \
        before["compiled"] + before["memory_hits"] + before["cache_hits"]
    monkeypatch.setattr(nlp_mod, "JIT", False)
    vm = _evaluate_functions(_element_chain_nlp(E))
    for k in vm:
        assert compiled[k].sparsity() == vm[k].sparsity(), k
        scale = max(1.0, float(ca.mmax(ca.fabs(vm[k]))))
        assert float(ca.mmax(ca.fabs(compiled[k] - vm[k]))) <= 1e-12 * scale, k


def _square_chain(E: int) -> NLP:
    """``x_0 = 0.5``, ``x_{e+1} = x_e + 0.01 sin(x_e)``: a square system (zero Hessian is exact)."""
    a, b = ca.SX.sym("a"), ca.SX.sym("b")
    nlp = NLP(hessian="zero")
    nlp.variable("x", E + 1, init=0.5)
    xi = nlp.index("x")
    e = np.arange(E)
    nlp.minimize(ca.SX(0))
    nlp.equal_elements("first", ca.Function("first", [a], [a - 0.5]), [X(xi[:1, None])])
    nlp.equal_elements("step", ca.Function("step", [a, b], [b - a - 0.01 * ca.sin(a)]),
                       [X(xi[e, None]), X(xi[e + 1, None])])
    return nlp


def test_compiled_solve_matches_virtual_machine(monkeypatch, tmp_path):
    from castrajectory.solve import jit, nlp as nlp_mod

    monkeypatch.setenv("CASTRAJECTORY_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(nlp_mod, "JIT_MIN_ELEMENTS", 1)
    results = {}
    for on in (True, False):
        monkeypatch.setattr(nlp_mod, "JIT", on)
        n0 = jit.stats["compiled"]
        results[on] = _square_chain(300).solve()
        assert results[on].success
        assert (jit.stats["compiled"] > n0) == (on and jit.compiler() is not None)
    assert np.max(np.abs(results[True].x - results[False].x)) <= 1e-12


def _fresh_function(tag: float) -> ca.Function:
    x = ca.SX.sym("x", 2)
    return ca.Function("jit_probe", [x], [ca.vertcat(ca.sin(x[0]) * x[1] + tag, x[0] ** 3)])


def test_jit_disk_cache_hit_does_not_recompile(monkeypatch, tmp_path):
    from castrajectory.solve import jit

    if jit.compiler() is None:
        pytest.skip("no C compiler")
    monkeypatch.setenv("CASTRAJECTORY_CACHE_DIR", str(tmp_path))
    f = _fresh_function(float(np.random.default_rng().uniform()))
    n0 = dict(jit.stats)
    g = jit.compiled(f)
    assert g is not f and g.class_name() == "External"
    assert jit.stats["compiled"] == n0["compiled"] + 1
    libs = list((tmp_path / "jit").glob("jit_probe_*.so"))
    assert len(libs) == 1
    assert float(g([0.3, 2.0])[0]) == pytest.approx(float(f([0.3, 2.0])[0]), abs=1e-15)
    # same process: memory hit; a new process (memory cleared): disk hit; no recompilation either way
    assert jit.compiled(f) is g
    monkeypatch.setattr(jit, "_loaded", {})
    h = jit.compiled(_fresh_function(float(f([0.0, 0.0])[0])))  # an identical function built anew
    assert h.class_name() == "External"
    assert jit.stats["compiled"] == n0["compiled"] + 1
    assert jit.stats["cache_hits"] == n0["cache_hits"] + 1
    # build=False never compiles
    other = _fresh_function(-7.25)
    assert jit.compiled(other, build=False) is other
    assert jit.stats["compiled"] == n0["compiled"] + 1


@pytest.mark.parametrize("how", ["missing", "failing", "disabled"])
def test_jit_falls_back_to_virtual_machine(monkeypatch, tmp_path, how):
    from castrajectory.solve import jit, nlp as nlp_mod

    monkeypatch.setenv("CASTRAJECTORY_CACHE_DIR", str(tmp_path))
    if how == "missing":
        monkeypatch.setenv("CC", str(tmp_path / "no-such-compiler"))
    elif how == "failing":
        fail = tmp_path / "failing-cc"
        fail.write_text("#!/bin/sh\nexit 1\n")
        fail.chmod(0o755)
        monkeypatch.setenv("CC", str(fail))
    else:
        monkeypatch.setenv("CASTRAJECTORY_JIT", "0")
    f = _fresh_function(float(np.random.default_rng().uniform()))
    assert jit.compiled(f) is f
    assert not list(tmp_path.glob("jit/*.so"))
    # an NLP with element families still solves, on the virtual machine
    monkeypatch.setattr(nlp_mod, "JIT_MIN_ELEMENTS", 1)
    nlp = NLP()
    nlp.variable("x", 200, init=1.0)
    a = ca.SX.sym("a")
    nlp.minimize_elements("sq", ca.Function("sq", [a], [(a - 2.0) ** 2 + 0.1 * a ** 4]), [X(nlp.index("x")[:, None])])
    res = nlp.solve()
    assert res.success
    assert not list(tmp_path.glob("jit/*.so"))


def test_jit_cache_dir_is_per_user_and_overridable(monkeypatch, tmp_path):
    from castrajectory.solve import jit

    monkeypatch.delenv("CASTRAJECTORY_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert jit.cache_dir() == tmp_path / "xdg" / "castrajectory"
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert jit.cache_dir() == __import__("pathlib").Path.home() / ".cache" / "castrajectory"
    monkeypatch.setenv("CASTRAJECTORY_CACHE_DIR", str(tmp_path / "mine"))
    assert jit.cache_dir() == tmp_path / "mine"


# ----------------------------------------------------------------------------- rows and the check of an assembled point
def _stepping_chain(E: int) -> NLP:
    """x_{e+1} = x_e + 0.1 sin(x_e) + c_e (element rows), x_0 fixed by its bounds, and one expression row
    fixing the extra unknown y: a square feasibility problem."""
    a, b, c = (ca.SX.sym(n) for n in "abc")
    step = ca.Function("step", [a, b, c], [b - a - 0.1 * ca.sin(a) - c])
    nlp = NLP(hessian="zero")
    nlp.variable("x", E + 1, lb=np.r_[0.5, -np.inf * np.ones(E)], ub=np.r_[0.5, np.inf * np.ones(E)], init=0.5)
    nlp.variable("y", 1, init=0.0)
    xi, e = nlp.index("x"), np.arange(E)
    nlp.equal_elements("step", step, [X(xi[e, None]), X(xi[e + 1, None]), np.linspace(0.0, 0.2, E)[:, None]])
    x = nlp._vars[0].sym
    nlp.equal("y_row", nlp._vars[1].sym - x[E] ** 2)
    nlp.minimize(ca.SX(0))
    return nlp


def test_row_values_match_the_rows_handed_to_ipopt():
    nlp = _element_chain_nlp(300)
    fns = nlp.functions()
    x = np.random.default_rng(3).uniform(0.2, 1.2, fns["jac_g"].size1_in(0))
    g_ipopt = np.asarray(fns["jac_g"](x, np.array([0.4]))[0]).reshape(-1)
    assert nlp.row_values(x) == pytest.approx(g_ipopt, abs=1e-14)
    g, grad = nlp._rows_and_gradients(x)
    assert g == pytest.approx(g_ipopt, abs=1e-14)
    J = np.abs(np.asarray(ca.DM(fns["jac_g"](x, np.array([0.4]))[1]).full()))
    # each row's largest derivative (no variable enters an element of this family twice)
    assert grad == pytest.approx(J.max(axis=1), rel=1e-14)


def test_check_verifies_a_solution_and_rejects_a_perturbed_one():
    nlp = _stepping_chain(400)
    x0, c = [0.5], np.linspace(0.0, 0.2, 400)
    for ce in c:
        x0.append(x0[-1] + 0.1 * np.sin(x0[-1]) + ce)
    x0 = np.asarray(x0) + 1e-3 * np.sin(np.arange(401))  # near the solution, not on it
    x0[0] = 0.5
    sol = nlp.solve({"x": x0}, options={"tol": 1e-12})
    assert sol.success
    # the point computed by Ipopt, handed back by name: every row holds
    chk = nlp.check({"x": sol["x"], "y": sol["y"]}, 1e-10)
    assert chk.success and chk.solver_status == "Rows_Verified" and chk.iterations == 0
    assert chk["x"] == pytest.approx(sol["x"], abs=0)
    assert all(np.all(v == 0) for v in chk.multipliers.values())
    # one node moved by 1e-6: its two rows miss
    x = sol["x"].copy()
    x[200] += 1e-6
    bad = nlp.check({"x": x, "y": sol["y"]}, 1e-10)
    assert not bad.success and bad.solver_status == "Rows_Not_Verified" and "1e-10" in bad.message
    # the fixed unknown off its bound
    x = sol["x"].copy()
    x[0] += 1e-6
    assert not nlp.check({"x": x, "y": sol["y"]}, 1e-10).success


def test_check_is_only_for_square_feasibility_problems():
    with pytest.raises(ValueError, match="square feasibility"):
        _element_chain_nlp(10).check({}, 1e-10)
