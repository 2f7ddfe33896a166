"""A user's own system, trusted (#23): gravity in any direction, bad input refused before any solve.

Oracles: the conical pendulum (a z-up spherical pendulum whose tilt stays fixed at θ₀ with the azimuth
rate Ω² = g/(l cos θ₀): a closed form), the spherical pendulum's equations written by hand and integrated
by CVODES, and the planar scenes' numbers with gravity's default direction.
"""
from __future__ import annotations

import math
import subprocess
import sys

import casadi as ca
import numpy as np
import pytest

import castrajectory as ct
from castrajectory.validation import InputError

G = 9.81


def spherical(direction=(0.0, 0.0, -1.0), up=2):
    """A unit pendulum in angles (θ from the downward vertical, φ about it), written with ``up`` the
    index of the vertical axis and gravity along ``direction``."""
    q = ca.SX.sym("q", 2)
    th, ph = q[0], q[1]
    horiz = [ca.sin(th) * ca.cos(ph), ca.sin(th) * ca.sin(ph)]
    comps = horiz[:up] + [-ca.cos(th)] + horiz[up:]
    return ct.LagrangianSystem(q, ct.Atoms([ca.vertcat(*comps)], [1.0]), [ct.Gravity(G, direction=direction)],
                               names=["theta", "phi"])


def spherical_reference(q0, qd0, T):
    """θ̈ = sin θ cos θ φ̇² − g sin θ, φ̈ = −2 cot θ θ̇ φ̇ (unit length and mass), CVODES at 1e-12."""
    x = ca.SX.sym("x", 4)
    th, ph, thd, phd = x[0], x[1], x[2], x[3]
    rhs = ca.vertcat(thd, phd, ca.sin(th) * ca.cos(th) * phd ** 2 - G * ca.sin(th),
                     -2.0 * ca.cos(th) / ca.sin(th) * thd * phd)
    F = ca.integrator("F", "cvodes", {"x": x, "ode": rhs}, 0.0, T, {"abstol": 1e-13, "reltol": 1e-13})
    return np.asarray(F(x0=np.concatenate([q0, qd0]))["xf"]).reshape(-1)


def test_conical_pendulum_written_z_up_keeps_its_tilt():
    """Tilt θ₀ = 0.6 with Ω = √(g/cos θ₀): θ stays at θ₀ and φ = Ω t.  The discrete motion of a uniform
    rotation is exact (the symmetry), so only rounding is left."""
    th0 = 0.6
    Om = math.sqrt(G / math.cos(th0))
    T = 2.0
    run = ct.simulate(spherical(), [th0, 0.0], [0.0, Om], T=T, N=400, scheme="galerkin4")
    assert run.success
    assert np.max(np.abs(run.q[:, 0] - th0)) < 1e-13           # measured 6.7e-16
    assert abs(run.q[-1, 1] - Om * T) < 2e-12                    # measured 2.7e-14


@pytest.mark.parametrize("up,direction", [(2, (0, 0, -1)), (1, (0, -1, 0)), (2, (0, 0, -2.5))],
                         ids=["z-up", "y-up", "z-up unnormalised"])
def test_spherical_pendulum_in_any_frame_matches_its_equations(up, direction):
    q0, qd0, T = np.array([0.9, 0.2]), np.array([0.3, 1.1]), 1.5
    ref = spherical_reference(q0, qd0, T)
    run = ct.simulate(spherical(direction, up), q0, qd0, T=T, N=600, scheme="galerkin4")
    assert run.success
    assert np.max(np.abs(run.q[-1] - ref[:2])) < 1e-7            # measured 4.2e-9 (order 4, h = 2.5e-3)


def test_planar_gravity_keeps_its_expression():
    """Planar atoms default to −e_y; an explicit (0, −1) builds the same potential."""
    th = ca.SX.sym("theta", 1)
    bob = ca.vertcat(ca.sin(th), -ca.cos(th))
    a = ct.LagrangianSystem(th, ct.Atoms([bob], [2.0]), [ct.Gravity(G)])
    b = ct.LagrangianSystem(th, ct.Atoms([bob], [2.0]), [ct.Gravity(G, direction=(0, -1))])
    for x in (0.1, 1.3, -2.0):
        assert float(a.potential([x], 0.0)) == float(b.potential([x], 0.0)) == pytest.approx(-2 * G * math.cos(x))


@pytest.mark.parametrize("kw,needle", [
    ({}, "needs a direction"),
    ({"direction": (0, -1)}, "has 2 components, the atoms 3 coordinates"),
    ({"direction": (0, 0, 0)}, "finite, nonzero"),
    ({"direction": (0, float("nan"), 1)}, "finite, nonzero"),
    ({"direction": (0, 0, -1), "heights": [0.0], "masses": [1.0]}, "not both"),
])
def test_ambiguous_or_bad_gravity_is_refused(kw, needle):
    q = ca.SX.sym("q", 3)
    with pytest.raises(InputError, match=needle):
        ct.LagrangianSystem(q, ct.Atoms([q], [1.0]), [ct.Gravity(G, **kw)])


# ----------------------------------------------------------------------------- bad input through the API
def _free2():
    q = ca.SX.sym("q", 2)
    return ct.LagrangianSystem(q, ct.MassMatrix(ca.DM.eye(2)), [ct.Potential(ca.sumsqr(q))])


@pytest.mark.parametrize("method", ["whole", "rk4", "march"])
def test_nested_state_is_refused(method):
    q = ca.SX.sym("q", 4)
    s = ct.LagrangianSystem(q, ct.MassMatrix(ca.DM.eye(4)), [ct.Potential(ca.sumsqr(q))])
    with pytest.raises(InputError, match=r"flat list of 4 numbers.*shape \(2, 2\)"):
        ct.simulate(s, [[0.1, 0.2], [0.3, 0.4]], [0.0] * 4, T=1.0, N=10, method=method)


def test_a_column_state_is_a_vector():
    run = ct.simulate(_free2(), ca.DM([0.1, 0.2]), np.zeros((2, 1)), T=0.5, N=20)
    assert run.success and run.q.shape == (21, 2)


@pytest.mark.parametrize("method", ["whole", "rk4", "march"])
def test_massless_coordinate_through_the_api_is_refused(method):
    q = ca.SX.sym("q", 2)
    s = ct.LagrangianSystem(q, ct.MassMatrix(ca.diag(ca.vertcat(1.0, 0.0))), [ct.Potential(ca.sumsqr(q))],
                            names=["a", "b"])
    with pytest.raises(InputError, match="coordinate 'b' has no inertia"):
        ct.simulate(s, [0.1, 0.2], [0.0, 0.0], T=1.0, N=10, method=method)


def test_default_names_are_the_symbols():
    assert _free2().names == ["q_0", "q_1"]
    x, y = ca.SX.sym("x"), ca.SX.sym("y")
    assert ct.LagrangianSystem(ca.vertcat(x, y), ct.MassMatrix(ca.DM.eye(2))).names == ["x", "y"]
    twins = ca.vertcat(ca.SX.sym("a"), ca.SX.sym("a"))
    assert ct.LagrangianSystem(twins, ct.MassMatrix(ca.DM.eye(2))).names == ["q[0]", "q[1]"]
    with pytest.raises(InputError, match="names has 1 entries"):
        ct.LagrangianSystem(twins, ct.MassMatrix(ca.DM.eye(2)), names=["a"])


def test_unknown_plot_format_is_refused_before_the_solve(tmp_path):
    f = tmp_path / "user.py"
    f.write_text("import casadi as ca, castrajectory as ct\ndef system():\n    q = ca.SX.sym('q', 1)\n"
                 "    return ct.LagrangianSystem(q, ct.MassMatrix(1.0), [ct.Potential(q[0] ** 2)])\n"
                 "q0 = [1.0]\nqd0 = [0.0]\n")
    out = tmp_path / "x.xyz"
    p = subprocess.run([sys.executable, "-m", "castrajectory.cli", "system", str(f), "--plot", str(out)],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 2 and p.stdout == "" and not out.exists()
    assert len(p.stderr.strip().splitlines()) == 1 and "no picture format .xyz" in p.stderr
