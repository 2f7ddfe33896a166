"""Statuses that tell the truth (issue 41, section 3): Ipopt's acceptable level judged by measurements (a warm
re-solve's KKT test and the certificate's march), and "infeasible" said only where it is proved."""
from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

import castrajectory as ct
from castrajectory.solve import optimal_control

#: Ipopt stopped at its first acceptable iterate (a requested tol it cannot reach, one acceptable iterate)
FORCED = {"tol": 1e-14, "acceptable_iter": 1, "acceptable_tol": 1e-1}


def min_time(N=40):
    """ẍ = u, |u| <= 1, from rest at 0 to rest at 1 in least time: T* = 2 (bang-bang; midpoint on an even N
    reaches T* itself)."""
    u = ct.Control("u", 1, lower=-1.0, upper=1.0)
    x = ca.SX.sym("x", 1)
    block = ct.LagrangianSystem(x, ct.MassMatrix(1.0), [ct.Force(u)], names=["x"])
    ocp = ct.OptimalControl(block, T=(0.2, 20.0), N=N)
    ocp.initial(q=[0.0], qd=[0.0])
    ocp.final(q=[1.0], qd=[0.0])
    ocp.minimize(final=ocp.T_symbol)
    return ocp


def acrobot(N, scheme="galerkin8"):
    """The acrobot (two unit links and masses, the elbow's torque |u| <= 20) swung up in 4 s at least ∫u²."""
    u = ct.Control("u", 1, lower=-20.0, upper=20.0)
    q = ca.SX.sym("q", 2)
    p1 = ca.vertcat(ca.sin(q[0]), -ca.cos(q[0]))
    p2 = p1 + ca.vertcat(ca.sin(q[0] + q[1]), -ca.cos(q[0] + q[1]))
    system = ct.LagrangianSystem(q, ct.Atoms([p1, p2], [1.0, 1.0]), [ct.Gravity(9.81), ct.Force(ca.vertcat(0, u))])
    ocp = ct.OptimalControl(system, T=4.0, N=N, scheme=scheme)
    ocp.initial(q=[0.0, 0.0], qd=[0.0, 0.0])
    ocp.final(q=[math.pi, 0.0], qd=[0.0, 0.0])
    ocp.minimize(running=u ** 2)
    return ocp


def test_acceptable_level_measured_and_certified_is_ok():
    """Ipopt forced to stop at its first acceptable iterate: the warm re-solve meets tol = 1e-8 (4 iterations),
    the march certifies it, and the answer is ok at the closed form's T* (measured 4e-10), with a warning that
    the requested tol was not reached."""
    sol = min_time().solve(options=FORCED)
    assert sol.success and sol.status == "ok" and sol.solver_status == "Solved_To_Acceptable_Level"
    assert abs(sol.T - 2.0) <= 4e-8
    assert sol.certificate <= optimal_control.CERTIFICATE_TOL
    assert "tol = 1e-08" in sol.message and any("tol = 1e-14 was not reached" in w for w in sol.warnings)


def test_acceptable_level_without_the_kkt_conditions_fails_and_says_what_to_do(monkeypatch):
    """The same stop, its re-solve allowed no iteration (it measures the point only): its scaled residual is 4e-4,
    so the answer is not ok -- rightly, its T is 0.095 off T* -- and the message names the tol that would accept
    it."""
    monkeypatch.setattr(optimal_control, "ACCEPTABLE_ITER", 0)
    sol = min_time().solve(options=FORCED)
    assert not sol.success and sol.status == "Solved_To_Acceptable_Level"
    assert abs(sol.T - 2.0) > 1e-3
    assert "scaled feasibility and stationarity residual" in sol.message and "options={'tol': 0.001}" in sol.message


def test_acrobot_on_a_fine_grid_at_ipopts_acceptable_level_is_ok():
    """The issue's case: the acrobot, galerkin8, N = 160 stops at Ipopt's acceptable level at tol = 1e-10 (its
    scaled dual infeasibility 2.4e-10); certified, and its cost is the tol = 1e-8 solve's (measured 5e-13
    relative)."""
    sol = acrobot(160).solve()
    assert sol.solver_status == "Solved_To_Acceptable_Level" and sol.success
    assert sol.certificate <= optimal_control.CERTIFICATE_TOL
    ref = acrobot(160).solve(options={"tol": 1e-8})
    assert ref.success and ref.solver_status == "Solve_Succeeded"
    assert abs(sol.cost - ref.cost) <= 1e-10 * ref.cost


# ----------------------------------------------------------------------------- "infeasible" only when proved
def detour(N=20, bound=None):
    """A unit point mass moved from (−1, 0) to (1, 0) in 2 s at least ∫|u|², kept out of the disk of radius ½
    about the origin.  Feasible (any detour around the disk); the straight-line guess is symmetric about the x
    axis, and from it Ipopt finds no feasible point."""
    u = ct.Control("u", 2, lower=-10.0, upper=10.0)
    p = ca.SX.sym("p", 2)
    mass = ct.LagrangianSystem(p, ct.MassMatrix(ca.DM.eye(2)), [ct.Force(u)], names=["x", "y"])
    ocp = ct.OptimalControl(mass, T=2.0, N=N)
    ocp.initial(q=[-1.0, 0.0], qd=[0.0, 0.0])
    ocp.final(q=[1.0, 0.0], qd=[0.0, 0.0])
    ocp.minimize(running=ca.sumsqr(u))
    ocp.subject_to(p[0] ** 2 + p[1] ** 2 >= 0.25)
    if bound is not None:
        ocp.subject_to(*bound(p, u))
    return ocp


def test_local_infeasibility_is_reported_as_no_feasible_point_from_this_start():
    """Ipopt's Infeasible_Problem_Detected on a feasible problem: the message says what it is (no feasible point
    from this start, not a proof) and what to try; the seeded start it suggests solves it (certified, outside
    the disk at every node)."""
    cold = detour().solve()
    assert not cold.success and cold.status == "Infeasible_Problem_Detected"
    assert "no feasible point found from this start" in cold.message and "not a proof" in cold.message
    assert "seeded start" in cold.message and "inconsistent" not in cold.message
    s = np.linspace(0.0, 1.0, 21)
    seeded = detour().solve(guess={"q": np.column_stack([-np.cos(np.pi * s), 0.6 * np.sin(np.pi * s)])})
    assert seeded.success and seeded.certificate <= optimal_control.CERTIFICATE_TOL
    assert np.min(np.hypot(seeded.q[:, 0], seeded.q[:, 1])) >= 0.5 - 1e-9


@pytest.mark.parametrize("bound, needle", [
    (lambda p, u: (p[1] <= -1.0, 2 * p[1] >= 1.0), "y must be at least 0.5"),                 # crossed path bounds
    (lambda p, u: (u[0] >= 11.0,), "at most 10 (the upper bound of control u)"),              # against a control's
    (lambda p, u: (p[0] >= -0.5,), "the initial configuration [-1.0, 0.0] violates"),         # against the start
])
def test_proved_inconsistency_is_refused_before_the_solve(bound, needle):
    """Bounds that cross, or a boundary configuration outside a path constraint that holds at every node, are
    proved inconsistent before any solve: refused as bad input, with the word."""
    from castrajectory.validation import InputError
    with pytest.raises(InputError, match="the problem is inconsistent") as err:
        detour(bound=bound).solve()
    assert needle in str(err.value)


def test_proved_inconsistency_exits_2_from_the_command_line(tmp_path):
    """`castrajectory control` on a problem whose path bounds cross: exit 2, one line on stderr, no traceback."""
    import subprocess
    import sys
    f = tmp_path / "crossed.py"
    f.write_text("import casadi as ca, castrajectory as ct\n"
                 "def problem():\n"
                 "    u = ct.Control('u', 1, lower=-1, upper=1)\n"
                 "    x = ca.SX.sym('x', 1)\n"
                 "    ocp = ct.OptimalControl(ct.LagrangianSystem(x, ct.MassMatrix(1.0), [ct.Force(u)], names=['x']),"
                 " T=1.0, N=10)\n"
                 "    ocp.initial(q=[0.0], qd=[0.0]); ocp.final(q=[0.1], qd=[0.0]); ocp.minimize(running=u ** 2)\n"
                 "    ocp.subject_to(x[0] <= 2, x[0] >= 3)\n"
                 "    return ocp\n")
    p = subprocess.run([sys.executable, "-m", "castrajectory.cli", "control", str(f)], capture_output=True, text=True,
                       timeout=120)
    assert p.returncode == 2, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "inconsistent" in lines[0] and "Traceback" not in p.stderr
