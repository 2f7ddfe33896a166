"""Optimal control on the discrete action (DMOC, #24): exact discrete optima, closed forms, fitted orders,
the costates, the certificate, failures and bad input.

Oracles: the block move ẍ = u, 0 -> d at rest in T, min ∫u²: J* = 12d²/T³, u* = (6 − 12t/T)d/T², and the
midpoint DMOC optimum exactly J_N = J*·N²/(N²−1); the minimum-time move with |u| <= u_max: T* = 2√(d/u_max)
(bang-bang, switch at T*/2); the damped transfer ẍ + cẋ + kx = u, min ∫u², J* = dᵀW⁻¹d with the
controllability Gramian (1.674735875385 for c = 0.5, k = 1, T = 2, d = (1, 0)).
"""
from __future__ import annotations


import math

import casadi as ca
import numpy as np
import pytest

import castrajectory as ct
from castrajectory.validation import InputError


def block(lower=None, upper=None):
    u = ct.Control("u", 1, lower=lower, upper=upper)
    x = ca.SX.sym("x", 1)
    return ct.LagrangianSystem(x, ct.MassMatrix(1.0), [ct.Force(u)], names=["x"]), u


def block_move(N, scheme="midpoint", d=1.0, T=1.0, controls="step"):
    system, u = block()
    ocp = ct.OptimalControl(system, T=T, N=N, scheme=scheme, controls=controls)
    ocp.initial(q=[0.0], qd=[0.0])
    ocp.final(q=[d], qd=[0.0])
    ocp.minimize(running=u ** 2)
    return ocp.solve()


@pytest.mark.parametrize("scheme", ["midpoint", "trapezoid", "galerkin4"])
@pytest.mark.parametrize("N", [2, 7, 40])
def test_block_move_hits_the_exact_discrete_optimum(scheme, N):
    """J_N = 12 N²/(N² − 1) for d = T = 1 (measured to 2e-13 at most; galerkin4 too: a piecewise-constant
    control sees the same discrete problem)."""
    sol = block_move(N, scheme)
    assert sol.success and sol.certificate < 1e-12
    assert abs(sol.cost - 12 * N * N / (N * N - 1)) < 1e-11


@pytest.mark.parametrize("scheme", ["galerkin4", "gauss4", "galerkin6"])
def test_controls_at_the_quadrature_nodes_hold_the_linear_optimum(scheme):
    """Controls at the quadrature nodes: the block move's linear u* is then in the discrete space, and its
    cost is J* itself (measured within 5.5e-13), its controls u* (the orders on the damped transfer: below)."""
    sol = block_move(10, scheme, controls="quadrature")
    assert sol.success and abs(sol.cost - 12.0) < 5e-11 and np.max(np.abs(sol.u[:, 0] - (6 - 12 * sol.t_u))) < 1e-9


def test_block_move_converges_at_second_order_to_the_closed_form():
    """Fitted orders of the cost and of the controls (at the step midpoints) against J* and u*."""
    Ns = np.array([10, 20, 40, 80])
    dJ, du = [], []
    for N in Ns:
        sol = block_move(int(N), d=0.7, T=1.3)
        tm = (np.arange(N) + 0.5) * 1.3 / N
        dJ.append(abs(sol.cost - 12 * 0.7 ** 2 / 1.3 ** 3))
        du.append(np.max(np.abs(sol.u[:, 0] - (6 - 12 * tm / 1.3) * 0.7 / 1.3 ** 2)))
    oJ = -np.polyfit(np.log(Ns), np.log(dJ), 1)[0]
    ou = -np.polyfit(np.log(Ns), np.log(du), 1)[0]
    assert abs(oJ - 2.0) < 0.05 and abs(ou - 2.0) < 0.1


def test_block_move_costates_converge_to_the_adjoint():
    """The continuous costate of the velocity is λ_v(t) = −2u*(t) = −2(6 − 12t) (d = T = 1): linear in t.
    The discrete costates (∂J*/∂p_k) are linear in t too (a straight-line fit leaves 3e-16 of their range)
    and converge to λ_v at second order (measured errors 9.7e-2 ... 1.8e-3 for N = 10 ... 80, slope 1.91)."""
    Ns = np.array([10, 20, 40, 80])
    errs = []
    for N in Ns:
        sol = block_move(int(N))
        lam, t = sol.costates[:, 0], sol.t[1:-1]
        assert sol.costates.shape == (N - 1, 1)
        assert np.max(np.abs(lam - np.polyval(np.polyfit(t, lam, 1), t))) < 5e-14 * np.ptp(lam)
        errs.append(np.max(np.abs(lam + 2 * (6 - 12 * t))))
    order = -np.polyfit(np.log(Ns), np.log(errs), 1)[0]
    assert abs(order - 2.0) < 0.15 and errs[-1] < 4e-3


def test_minimum_time_move_is_bang_bang():
    """|u| <= 1, d = 1: T* = 2 (for even N the discrete minimum is the continuous one), switch at T/2."""
    system, u = block(-1.0, 1.0)
    ocp = ct.OptimalControl(system, T=(0.5, 10.0), N=20)
    ocp.initial(q=[0.0], qd=[0.0])
    ocp.final(q=[1.0], qd=[0.0])
    ocp.minimize(final=ocp.T_symbol)
    sol = ocp.solve()
    assert sol.success and sol.certificate < 1e-12
    assert abs(sol.T - 2.0) < 1e-8                             # measured 1.8e-10 (Ipopt's tol)
    assert np.allclose(sol.u[:10, 0], 1.0, atol=1e-6) and np.allclose(sol.u[10:, 0], -1.0, atol=1e-6)


def _damped_transfer():
    import importlib.util
    spec = importlib.util.spec_from_file_location("damped_transfer", os.path.join(ROOT, "problems", "damped_transfer.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.parametrize("scheme,Ns,order,control_order", [
    ("midpoint", (20, 40, 80), 2, 2), ("galerkin4", (5, 10, 20), 4, 4), ("gauss4", (5, 10, 20), 4, 3),
    ("galerkin6", (4, 8, 16), 6, 5)])
def test_damped_transfer_orders_against_its_closed_form(scheme, Ns, order, control_order):
    """The damped transfer (c = 0.5, k = 1, T = 2, d = 1) against u*(t), z*(t) and λ_v = −2u* of the Gramian's
    closed form: the cost, the nodal (x, ẋ) and the costates converge at the scheme's order, the controls at
    the quadrature nodes at one more than the number of nodes (measured: midpoint 2.00/2.00/1.98/1.99,
    galerkin4 4.01 throughout, gauss4 3.99/3.97/3.89/3.00, galerkin6 5.98/6.01/5.74/5.07)."""
    mod = _damped_transfer()
    errs = {}
    for N in Ns:
        out = mod.run(mod.parser().parse_args(["--scheme", scheme, "--n", str(N)]))
        assert out.success and out.data["certificate"] < 1e-12
        for key in ("error_vs_exact", "state_error", "costate_error", "control_error"):
            errs.setdefault(key, []).append(out.data[key])
    fitted = {k: -np.polyfit(np.log(Ns), np.log(v), 1)[0] for k, v in errs.items()}
    assert abs(fitted["error_vs_exact"] - order) < 0.1 and abs(fitted["state_error"] - order) < 0.1
    assert abs(fitted["costate_error"] - order) < 0.3 and abs(fitted["control_error"] - control_order) < 0.15


@pytest.mark.parametrize("c,k,T,d,J", [(0.0, 0.0, 1.3, 0.7, 12 * 0.7 ** 2 / 1.3 ** 3), (2.0, 1.0, 2.0, 1.0, None)])
def test_the_closed_form_holds_for_defective_dynamics(c, k, T, d, J):
    """A = [[0, 1], [−k, −c]] is defective for c = k = 0 (the block move: J* = 12d²/T³) and at critical
    damping c² = 4k (an eigendecomposition fails or is wrong there: it gave 36.4 for 5.418); the closed form
    (Van Loan's block exponential) against galerkin6 DMOC at N = 32 (measured 1.1e-10 and 1.1e-11 at c = 2)."""
    mod = _damped_transfer()
    opt = mod.Optimum(c, k, T, d)
    if J is not None:
        assert abs(opt.J - J) < 1e-13 * J
    out = mod.run(mod.parser().parse_args(["--damping", str(c), "--stiffness", str(k), "--T", str(T),
                                           "--distance", str(d), "--scheme", "galerkin6", "--n", "32"]))
    assert out.success and out.data["error_vs_exact"] < 2e-9 * opt.J and out.data["state_error"] < 1e-9


def bryson_denham(N, scheme, l):
    system, u = block()
    ocp = ct.OptimalControl(system, T=1.0, N=N, scheme=scheme)
    ocp.initial(q=[0.0], qd=[1.0])
    ocp.final(q=[0.0], qd=[-1.0])
    ocp.minimize(running=0.5 * u ** 2)
    ocp.subject_to(system.q[0] <= l)
    return ocp.solve()


@pytest.mark.parametrize("l,J,N", [(1 / 9, 4.0, 12), (0.2, 2.24, 10)])
def test_bryson_denham_state_constraint(l, J, N):
    """Bryson and Denham's double integrator (x: 0 → 0, ẋ: 1 → −1 in T = 1, min ½∫u², x <= l): a boundary
    arc on [3l, 1 − 3l] with J* = 4/(9l) for l <= 1/6, one touch point at t = 1/2 with J* = 2 + 6(1 − 4l)²
    for 1/6 <= l <= 1/4.  The optimal x is cubic between its junctions, which lie on nodes here: galerkin4
    reaches J* (measured 2e-10, 9e-12).  Midpoint converges at order 2 (1.005e-2, 2.50e-3, 6.25e-4 at
    N = 30, 60, 120 for l = 1/9).  On a grid whose junctions fall inside steps the constraint holds at the
    stages too (without those rows galerkin4 at N = 5 cuts the corners: 3.9468 instead of 3.9903)."""
    sol = bryson_denham(N, "galerkin4", l)
    assert sol.success and abs(sol.cost - J) < 1e-8 and sol.certificate < 1e-12
    coarse = bryson_denham(5, "galerkin4", l)
    assert coarse.success and np.max(coarse.q) <= l + 1e-9 and np.max(coarse.q_stages) <= l + 1e-9
    assert np.max(coarse.q_stages) > l - 1e-6                       # the constraint holds at a stage
    if l < 1 / 6:
        errs = [bryson_denham(n, "midpoint", l).cost - J for n in (30, 60, 120)]
        assert all(abs(np.log2(errs[i] / errs[i + 1]) - 2.0) < 0.02 for i in range(2))


@pytest.mark.parametrize("scheme", ["galerkin4", "gauss4"])
def test_a_control_constraint_holds_at_every_control_value(scheme):
    """subject_to(u <= 3) on the block move (u* = 6 − 12t unconstrained): every control value of every
    quadrature node obeys it, the Lobatto steps' end values included."""
    system, u = block()
    ocp = ct.OptimalControl(system, T=1.0, N=8, scheme=scheme)
    ocp.initial(q=[0.0], qd=[0.0])
    ocp.final(q=[1.0], qd=[0.0])
    ocp.minimize(running=u ** 2)
    ocp.subject_to(u <= 3.0)
    sol = ocp.solve()
    assert sol.success and np.max(sol.u) <= 3.0 + 1e-9 and np.max(sol.u) > 3.0 - 1e-6


def test_an_infeasible_problem_is_a_failure():
    """|u| <= 0.1 cannot move the block by 1 in 1 s (the most it can do is 0.025)."""
    system, u = block(-0.1, 0.1)
    ocp = ct.OptimalControl(system, T=1.0, N=20)
    ocp.initial(q=[0.0], qd=[0.0])
    ocp.final(q=[1.0], qd=[0.0])
    ocp.minimize(running=u ** 2)
    sol = ocp.solve()
    assert not sol.success and sol.status != "ok" and "Infeasible" in sol.solver_status


@pytest.mark.parametrize("make,needle", [
    (lambda s, u: ct.OptimalControl(s, T=(0.0, 1.0), N=10), "0 < lo <= hi"),
    (lambda s, u: ct.OptimalControl(s, T=(2.0, 1.0), N=10), "0 < lo <= hi"),
    (lambda s, u: ct.OptimalControl(s, T=1.0, N=10).initial(q=[0.0, 1.0]), "has 2 values"),
    (lambda s, u: ct.OptimalControl(s, T=1.0, N=10).minimize(running=ca.vertcat(u, u)), "must be a scalar"),
    (lambda s, u: ct.OptimalControl(s, T=1.0, N=10).minimize(running=ct.Control("v", 1) ** 2), "appears in no force"),
    (lambda s, u: ct.Control("w", 1, lower=1.0, upper=0.0), "lower bound is above"),
])
def test_bad_problems_are_refused(make, needle):
    system, u = block()
    with pytest.raises(InputError, match=needle):
        make(system, u)


def test_a_system_without_controls_is_refused():
    x = ca.SX.sym("x", 1)
    with pytest.raises(InputError, match="no control"):
        ct.OptimalControl(ct.LagrangianSystem(x, ct.MassMatrix(1.0)), T=1.0, N=10)


def test_a_controlled_system_cannot_be_simulated():
    system, u = block()
    with pytest.raises(InputError, match="control"):
        ct.simulate(system, [0.0], [0.0], T=1.0, N=10)


# ----------------------------------------------------------------------------- the scenes
import json  # noqa: E402
import os  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def scene(name, *args):
    return subprocess.run([sys.executable, os.path.join(ROOT, "problems", f"{name}.py"), *args], capture_output=True,
                          text=True, timeout=300, env={**os.environ, "MPLBACKEND": "Agg"})


@pytest.mark.parametrize("name,args,oracle,tol", [
    ("block_move", ("--distance", "2", "--T", "3", "--n", "30"), lambda d: 12 * 4 / 27 * 900 / 899, 1e-12),
    ("min_time", ("--distance", "3", "--u-max", "0.5", "--n", "20"), lambda d: 2 * math.sqrt(6.0), 1e-8),
    ("damped_transfer", ("--n", "160"), lambda d: 1.674735875385, 1e-4),
])
def test_scene_json_against_its_oracle(name, args, oracle, tol):
    """Each scene's JSON: cost, T, t, q, u, costates, certificate, error_vs_exact; the answer against its closed
    form (block move: the exact discrete optimum; min time: T*; damped transfer: the Gramian's J*, 6.4e-5 at
    N = 160 measured)."""
    p = scene(name, *args, "--json")
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    for key in ("cost", "T", "t", "q", "u", "costates", "certificate", "error_vs_exact"):
        assert key in d, key
    value = d["T"] if name == "min_time" else d["cost"]
    assert abs(value - oracle(d)) < tol and d["certificate"] < 1e-12


def test_scene_picture_and_bad_input(tmp_path):
    out = tmp_path / "bm.png"
    p = scene("block_move", "--n", "20", "--plot", str(out))
    assert p.returncode == 0 and out.stat().st_size > 0
    p = scene("min_time", "--u-max", "-1")
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1 and "--u-max" in p.stderr


def test_the_certificate_catches_controls_that_do_not_make_the_motion():
    """The march of perturbed controls (1e-6 on one step) departs from the optimal nodes: the certificate sees
    it at the size of the perturbation's effect (h² Δu on the next node), far above the answer's own 1e-16."""
    from castrajectory.discretise.lagrangians import discrete_mechanics
    from castrajectory.solve.optimal_control import certify
    system, u = block()
    ocp = ct.OptimalControl(system, T=1.0, N=20)
    ocp.initial(q=[0.0], qd=[0.0])
    ocp.final(q=[1.0], qd=[0.0])
    ocp.minimize(running=u ** 2)
    sol = ocp.solve()
    dm = discrete_mechanics(system, "midpoint")
    Z = np.zeros((20, 0))
    p = dm.momenta(sol.q, Z, 0.05, 0.0, sol.u)
    assert certify(dm, sol.q, Z, sol.u, 0.05, sol.t, p[0]).local < 1e-14
    bad = sol.u.copy()
    bad[7] += 1e-6
    C = certify(dm, sol.q, Z, bad, 0.05, sol.t, p[0])
    assert 1e-10 < C.local < 1e-8 and C.march > C.local and not C.holds(1e-10)
    from castrajectory.result import Certificate
    assert not Certificate().holds() and not Certificate(float("inf"), 0.0).holds()     # not measured, march stopped


def test_pendulum_swing_up_converges_at_second_order():
    """examples/pendulum_swingup.py: the local optimum J* = 65.48558 approached at order 2 (measured errors
    0.285, 0.0714, 0.0179 at N = 100, 200, 400), every answer certified (2-3e-13)."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("swingup", os.path.join(ROOT, "examples", "pendulum_swingup.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    errs = []
    for N in (100, 200, 400):
        sol = mod.problem(N).solve()
        assert sol.success and sol.certificate < 1e-11 and np.max(np.abs(sol.u)) <= 3.0
        errs.append(sol.cost - 65.48558)
    order = np.log2(errs[0] / errs[1]), np.log2(errs[1] / errs[2])
    assert all(abs(o - 2.0) < 0.05 for o in order) and abs(errs[-1]) < 0.03


def test_control_command_runs_a_problem_file(tmp_path):
    p = subprocess.run([sys.executable, "-m", "castrajectory.cli", "control", "examples/pendulum_swingup.py", "--n",
                        "100", "--json"], capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert abs(d["cost"] - 65.77087593) < 1e-6 and len(d["u"]) == 100 and d["certificate"] < 1e-11
    bad = tmp_path / "bad.py"
    bad.write_text("def problem():\n    return 3\n")
    p = subprocess.run([sys.executable, "-m", "castrajectory.cli", "control", str(bad)], capture_output=True,
                       text=True, timeout=300)
    assert p.returncode == 2 and "not a castrajectory.OptimalControl" in p.stderr


def test_satellite_slew_on_a_quaternion():
    """A rigid body on SO(3) (quaternion and its unit-norm constraint), rest to rest by Θ = 1 about (1, 1, 0)/√2
    in T = 2: spherical inertia converges at order 2 to J* = 12 j²Θ²/T³ = 1.5 (measured J − J* 5.2e-4, 1.3e-4
    at N = 40, 80); the asymmetric body I = (1, 2, 3) at order 2 as well (3.71852080, 3.71746645, 3.71720306
    at N = 40, 80, 160); every answer certified."""
    J = {}
    for inertia in ("1 1 1", "1 2 3"):
        for N in ((40, 80) if inertia == "1 1 1" else (40, 80, 160)):
            p = scene("satellite_slew", "--inertia", *inertia.split(), "--n", str(N), "--json")
            assert p.returncode == 0, p.stderr
            d = json.loads(p.stdout)
            assert d["certificate"] < 1e-12 and len(d["u"]) == N and len(d["u"][0]) == 3
            J[(inertia, N)] = d["cost"]
    e40, e80 = J[("1 1 1", 40)] - 1.5, J[("1 1 1", 80)] - 1.5
    assert abs(np.log2(e40 / e80) - 2.0) < 0.05 and 0 < e80 < 2e-4
    d1 = J[("1 2 3", 40)] - J[("1 2 3", 80)]
    d2 = J[("1 2 3", 80)] - J[("1 2 3", 160)]
    assert abs(np.log2(d1 / d2) - 2.0) < 0.05


def test_cartpole_swing_up_converges_to_kellys_optimum():
    """Kelly's cart-pole (SIAM Review 2017 §6): J* = 58.8076674582; midpoint DMOC at order 2 (measured
    J − J* = 0.1822, 0.04554 at N = 100, 200; max |u| 13.97, the bounds inactive), certified."""
    errs = []
    for N in (100, 200):
        p = scene("cartpole_swingup", "--n", str(N), "--json")
        assert p.returncode == 0, p.stderr
        d = json.loads(p.stdout)
        assert d["certificate"] < 1e-11 and max(abs(v[0]) for v in d["u"]) < 20.0
        errs.append(d["cost"] - 58.8076674582)
    assert abs(np.log2(errs[0] / errs[1]) - 2.0) < 0.05 and 0 < errs[1] < 0.05


def test_an_impossible_swing_up_exits_1_with_ipopts_status():
    p = scene("pendulum_swingup", "--u-max", "0.1", "--T", "1", "--n", "50")
    assert p.returncode == 1 and "Infeasible_Problem_Detected" in p.stderr
    p = scene("pendulum_swingup", "--n", "100", "--json")
    d = json.loads(p.stdout)
    assert p.returncode == 0 and abs(d["cost"] - 65.77087593) < 1e-6 and d["certificate"] < 1e-11


@pytest.mark.parametrize("scheme,N,tol", [("midpoint", 100, 1e-3), ("galerkin4", 5, 1e-11)])
def test_a_final_cost_in_the_final_velocity(scheme, N, tol):
    """min ∫₀¹ u² + 5 v(1)², x: 0 -> 1 from rest, v(1) free: u = a + b t, J* = 8, v(1) = 2/3 (closed form).
    The final velocity is the last step's discrete Legendre transform. Measured: midpoint N = 100 5.3e-4
    (order 2), galerkin4 with controls at its nodes 1.5e-14 (the linear u* is in the discrete space)."""
    system, u = block()
    v = ct.velocity(system.q)
    ocp = ct.OptimalControl(system, T=1.0, N=N, scheme=scheme)
    ocp.initial(q=[0.0], qd=[0.0])
    ocp.final(q=[1.0])
    ocp.minimize(running=u ** 2, final=5.0 * v[0] ** 2)
    sol = ocp.solve()
    assert sol.success and abs(sol.cost - 8.0) < tol and abs(sol.v[-1, 0] - 2.0 / 3.0) < tol
    with pytest.raises(InputError, match="final time T"):
        ocp.minimize(final=ct.time())


def test_a_given_guess_is_used():
    """Started from its own answer, a block move with a quartic cost (not a QP: 2 Ipopt iterations from the
    straight line) takes none (measured) and lands on the same optimum; a guess of the wrong size is refused.
    (Only primal values are given: with bounds, the barrier's own iterations remain.)"""
    system, u = block()
    ocp = ct.OptimalControl(system, T=1.0, N=30)
    ocp.initial(q=[0.0], qd=[0.0])
    ocp.final(q=[1.0], qd=[0.0])
    ocp.minimize(running=u ** 2 + 0.1 * system.q[0] ** 4)
    first = ocp.solve()
    again = ocp.solve(guess={"q": first.q, "u": first.u})
    assert first.success and again.success and again.iterations <= 1 < first.iterations
    assert abs(again.cost - first.cost) < 1e-10
    with pytest.raises(InputError, match="guess of u"):
        ocp.solve(guess={"u": np.zeros(7)})


def test_a_time_dependent_system_meets_its_final_velocity_at_the_schemes_order():
    """A spring stiffening in time, k(t) = 1 + 3t, x: 0 -> 1 from rest to v(1) = 0.5, min ∫u².  The final velocity row
    is the last step's Legendre transform at that step's own time: the answer's v(1) is the one asked for (measured
    within 2e-15), and galerkin4's cost converges at its order 4 (fitted 4.00 from N = 10, 20, 40).  (With the last step
    evaluated one step early, v(1) missed by 3.1e-4 at N = 40 and the cost converged at order 2.)"""
    u = ct.Control("u", 1)
    x = ca.SX.sym("x", 1)
    t = ct.time()
    system = ct.LagrangianSystem(x, ct.MassMatrix(1.0), [ct.Potential(0.5 * (1 + 3 * t) * x[0] ** 2), ct.Force(u)],
                                 names=["x"])
    costs = []
    for N in (10, 20, 40):
        ocp = ct.OptimalControl(system, T=1.0, N=N, scheme="galerkin4")
        ocp.initial(q=[0.0], qd=[0.0])
        ocp.final(q=[1.0], qd=[0.5])
        ocp.minimize(running=u ** 2)
        sol = ocp.solve()
        assert sol.success and abs(sol.v[-1, 0] - 0.5) < 1e-12
        costs.append(sol.cost)
    order = math.log2((costs[0] - costs[1]) / (costs[1] - costs[2]))
    assert abs(order - 4.0) < 0.1
