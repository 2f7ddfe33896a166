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
    th, thd, phd = x[0], x[2], x[3]
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


# ----------------------------------------------------------------------------- singular charts
def _pole_rate(d, th0=1.0):
    """The azimuth rate from θ₀ at rest in θ that makes the pendulum pass about ``d`` rad from the pole
    (its momentum sin²θ φ̇ over the speed at the bottom)."""
    return d * math.sqrt(2 * G * (1 - math.cos(th0))) / math.sin(th0) ** 2


@pytest.mark.parametrize("d,N", [(1e-4, 1000), (1e-6, 4000)])
def test_spherical_pendulum_through_the_pole_warns(d, N):
    """Measured before the watch: 1e-6 rad from the pole, N = 4000 was 1.5e-2 off with an estimate of 1.5e-7."""
    run = ct.simulate(spherical(), [1.0, 0.0], [0.0, _pole_rate(d)], T=3.0, N=N, scheme="galerkin4")
    chart = [w for w in run.warnings if "singular chart" in w]
    assert len(chart) == 1 and "(theta, phi)" in chart[0] and "at t = " in chart[0]
    assert not run.error_estimate.available      # no small error is reported there


def test_rtol_near_a_singular_chart_stops_at_once():
    run = ct.simulate(spherical(), [1.0, 0.0], [0.0, _pole_rate(1e-6)], T=3.0, N=1000, scheme="galerkin4",
                      rtol=1e-6)
    assert not run.success and run.status == "Tolerance_Not_Reached"
    assert "singular chart" in run.message and len(run.t) == 1001     # no finer grid was solved


def test_spherical_pendulum_clear_of_the_pole_does_not_warn():
    run = ct.simulate(spherical(), [1.0, 0.0], [0.0, _pole_rate(0.3)], T=3.0, N=1000, scheme="galerkin4")
    assert run.success and run.warnings == [] and run.error_estimate.available


def _rot(axis, a):
    c, s = ca.cos(a), ca.sin(a)
    rows = {0: [[1, 0, 0], [0, c, -s], [0, s, c]], 1: [[c, 0, s], [0, 1, 0], [-s, 0, c]],
            2: [[c, -s, 0], [s, c, 0], [0, 0, 1]]}[axis]
    return ca.vertcat(*[ca.horzcat(*r) for r in rows])


def euler_angle_body():
    """A free body of unit isotropic inertia in yaw-pitch-roll angles (R = R_z R_y R_x): gimbal lock at
    pitch ±π/2.  Returns the system, R(q) and the map from angle rates at q = 0 to the space rate."""
    q = ca.SX.sym("q", 3)
    qd = ct.velocity(q)
    R = _rot(2, q[0]) @ _rot(1, q[1]) @ _rot(0, q[2])
    Rd = ca.reshape(ca.jacobian(ca.vec(R), q) @ qd, 3, 3)
    Wb, Ws = R.T @ Rd, Rd @ R.T
    J = ca.jacobian(ca.vertcat(Wb[2, 1], Wb[0, 2], Wb[1, 0]), qd)
    system = ct.LagrangianSystem(q, ct.MassMatrix(J.T @ J), [], names=["yaw", "pitch", "roll"])
    A = ca.Function("A", [q, qd], [ca.jacobian(ca.vertcat(Ws[2, 1], Ws[0, 2], Ws[1, 0]), qd)])
    return system, ca.Function("R", [q], [R]), np.asarray(A([0, 0, 0], [0, 0, 0]))


@pytest.mark.parametrize("eps,warns", [(0.5, False), (1e-2, True), (1e-4, True)])
def test_euler_angles_at_gimbal_lock(eps, warns):
    """The isotropic body turns uniformly about n = (0, 1, ε)/|.|: R(t) = exp(t [n]) exactly.  Its pitch
    comes within about ε of π/2.  Measured (galerkin4, N = 600, T = 3): rotation error 2.1e-10 at ε = 0.5,
    8.4e-4 at 1e-2, 0.31 at 1e-4."""
    system, Rf, A = euler_angle_body()
    n = np.array([0.0, 1.0, eps]) / math.hypot(1.0, eps)
    run = ct.simulate(system, [0, 0, 0], np.linalg.solve(A, n), T=3.0, N=600, scheme="galerkin4")
    assert run.success
    chart = [w for w in run.warnings if "singular chart" in w]
    assert bool(chart) == warns
    if warns:
        assert "pitch" in chart[0] and not run.error_estimate.available
    else:
        K = np.array([[0, -n[2], n[1]], [n[2], 0, -n[0]], [-n[1], n[0], 0]])
        err = max(np.max(np.abs(np.asarray(Rf(run.q[k])) - (np.eye(3) + math.sin(run.t[k]) * K
                                                               + (1 - math.cos(run.t[k])) * K @ K)))
                  for k in range(0, 601, 10))
        assert err < 2e-8 and run.error_estimate.relative < 1e-8      # measured 2.1e-10, 7.9e-11


# ----------------------------------------------------------------------------- memory
_LIMITED = r"""
import os, resource, sys
import castrajectory as ct
from castrajectory.models.pendulum import double_pendulum
ct.simulate(double_pendulum(), [1.0, 0.5], [0.0, 0.0], 1.0, 50)       # the libraries mapped, Ipopt loaded
mapped = int(open("/proc/self/statm").read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
resource.setrlimit(resource.RLIMIT_AS, (int(mapped + float(sys.argv[1])), resource.RLIM_INFINITY))
from castrajectory.cli import main
sys.exit(main(["run", "double_pendulum", "--rtol", "1e-13", "--n", "1000"]))
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="RLIMIT_AS and /proc/self/statm are Linux's")
def test_refinement_stops_within_an_address_space_limit():
    """A refinement towards an unreachable rtol under 1.5 GB of address space beyond the mapped
    libraries: it stops at its memory limit with the tolerance message (exit 1), not killed or aborted
    by std::bad_alloc (which a reserve-free limit gave at 0.5 GB)."""
    p = subprocess.run([sys.executable, "-c", _LIMITED, "1.5e9"], capture_output=True, text=True, timeout=600,
                       env={**__import__("os").environ, "MPLBACKEND": "Agg"})
    assert p.returncode == 1, p.stderr[-2000:]
    err = p.stderr.strip().splitlines()
    # (the order the grids show predicts a grid beyond the memory's limit, and it stops there at once)
    assert len(err) == 1 and "Traceback" not in p.stderr and "limit N <= " in err[0]
    assert "the grid cannot be refined further" in err[0] or "predicts N of about" in err[0]


def test_memory_per_step_follows_the_scheme():
    """The estimate grows with the unknowns and Jacobian nonzeros of a step: galerkin4 carries a stage
    and its couplings (2 -> 4 unknowns, 12 -> 32 nonzeros per step of the double pendulum)."""
    from castrajectory.models.pendulum import double_pendulum
    from castrajectory.solve import memory as tr
    a, b = tr.bytes_per_step(double_pendulum(), "midpoint"), tr.bytes_per_step(double_pendulum(), "galerkin4")
    assert a == tr.BYTES_PER_UNKNOWN * 2 + tr.BYTES_PER_NONZERO * 12
    assert b == tr.BYTES_PER_UNKNOWN * 4 + tr.BYTES_PER_NONZERO * 32


# ----------------------------------------------------------------------------- the whole state, quantities, symmetries
ROOT = __import__("os").path.dirname(__import__("os").path.dirname(__import__("os").path.abspath(__file__)))


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "castrajectory.cli", *args], capture_output=True, text=True,
                          cwd=ROOT, timeout=300, env={**__import__("os").environ, "MPLBACKEND": "Agg"})


def test_json_holds_velocities_momenta_and_declared_quantities():
    """Kepler in Cartesian coordinates (examples/kepler.py): unit mass, so p = v; L_z, the momentum of the
    rotation symmetry, is conserved by the discrete solution to the solver's tolerance (measured 8e-13),
    the energy to the scheme's bounded error (8e-13 here), the Runge-Lenz angle is not a Noether momentum."""
    import json
    p = _cli("system", "examples/kepler.py", "--scheme", "galerkin4", "--json")
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    v, mom = np.asarray(d["v"]), np.asarray(d["p"])
    assert v.shape == mom.shape == (4001, 2) and np.max(np.abs(mom - v)) < 1e-12
    Lz = np.asarray(d["quantities"]["L_z"])
    assert Lz.shape == (4001,) and abs(Lz[0] - 1.2) < 1e-15 and np.ptp(Lz) < 5e-11


def test_derivation_finds_the_rotation_symmetry_of_kepler(tmp_path):
    pytest.importorskip("sympy")
    out = tmp_path / "kepler.md"
    p = _cli("derive", "examples/kepler.py", "--out", str(out))
    assert p.returncode == 0, p.stderr
    text = out.read_text()
    assert "rotation in the (x, y) plane" in text
    assert "**L_z**" in text and "the discrete solution conserves it exactly" in text.split("**L_z**")[1].split("\n")[0]
    assert "is the energy" in text.split("**E**")[1].split("\n")[0]
    assert "need not conserve it" in text.split("**Runge-Lenz angle**")[1].split("\n")[0]


def test_every_contact_of_a_simultaneous_impact_is_listed(tmp_path):
    """A dumbbell dropped level from 1 m: both ends land at t = sqrt(2/g) together, with equal impulses, and the
    answer warns that a simultaneous impact's outcome depends on the impact law."""
    import json
    f = tmp_path / "dumbbell.py"
    f.write_text("import casadi as ca, castrajectory as ct\nq0 = [0.0, 1.0, 1.0, 1.0]\nqd0 = [0.0] * 4\nT, n = 0.6, 300\n"
                 "def system():\n    q = ca.SX.sym('q', 4)\n    a, b = q[0:2], q[2:4]\n"
                 "    return ct.LagrangianSystem(q, ct.Atoms([a, b], [1.0, 1.0]), [ct.Gravity(9.81)],\n"
                 "        constraints=[(ca.sumsqr(a - b) - 1.0) / 2], names=['x1', 'y1', 'x2', 'y2'],\n"
                 "        contact=ct.Contact([a[1], b[1]], restitution=0.5, names=['left', 'right']))\n")
    p = _cli("system", str(f), "--json")
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    imp = out["impacts"]
    assert any("simultaneous impact" in w and "left, right" in w for w in out["warnings"])
    first = [i for i in imp if abs(i["t"] - math.sqrt(2 / G)) < 1e-9]
    assert sorted(i["name"] for i in first) == ["left", "right"]
    assert abs(first[0]["impulse"] - first[1]["impulse"]) < 1e-9 * first[0]["impulse"]


def test_affine_symmetries_of_known_systems():
    from castrajectory.models import rigidbody as rb
    from castrajectory.models.pendulum import double_pendulum
    from castrajectory.models.symmetries import affine_symmetries
    x = ca.SX.sym("x", 3)
    free = ct.LagrangianSystem(x, ct.Atoms([x], [1.0]), [], names=["x", "y", "z"])
    assert sorted(s.description for s in affine_symmetries(free)) == [
        "rotation in the (x, y) plane", "rotation in the (x, z) plane", "rotation in the (y, z) plane",
        "translation of x", "translation of y", "translation of z"]
    assert affine_symmetries(double_pendulum()) == []
    # z-up spherical pendulum in Cartesian coordinates: only the rotation about the vertical survives gravity
    sph = ct.LagrangianSystem(x, ct.Atoms([x], [1.0]), [ct.Gravity(G, direction=(0, 0, -1))],
                              constraints=[(ca.dot(x, x) - 1) / 2], names=["x", "y", "z"])
    assert [s.description for s in affine_symmetries(sph, [0, 0, -1.0])] == ["rotation in the (x, y) plane"]
    # a quaternion body: left multiplication by a unit quaternion (spatial rotations), three of them
    assert len(affine_symmetries(rb.free_body(rb.Inertia(1, 2, 3)), [1.0, 0, 0, 0])) == 3


def test_the_discrete_solution_conserves_the_momenta_of_the_symmetries_found():
    """The quaternion free body: the three momenta found (the spatial angular momentum) stay constant along
    a galerkin4 solve to the solver's tolerance (measured 4.8e-13 at a scale of 4), over a motion that turns the body."""
    from castrajectory.models import rigidbody as rb
    from castrajectory.models.symmetries import affine_symmetries
    body = rb.free_body(rb.Inertia(1, 2, 3))
    q0 = np.array([1.0, 0, 0, 0])
    syms = affine_symmetries(body, q0)
    run = ct.simulate(body, q0, rb.quaternion_rate(q0, np.array([0.3, 1.0, 0.2])), T=5.0, N=500, scheme="galerkin4")
    assert run.success
    for s in syms:
        J = ca.Function("J", [body.q, body.qd], [s.momentum]).map(run.q.shape[0])
        vals = np.asarray(J(run.q.T, run.v.T)).reshape(-1)
        assert np.ptp(vals) < 1e-11 * max(1.0, np.max(np.abs(vals)))


def test_heavy_top_written_with_public_names_keeps_its_momenta():
    """examples/heavy_top.py (public names only): L_z and L_3 conserved along the solve (measured 1.3e-13 and
    1.6e-14), the declared L_z equal to ct.angular_momentum of the solution's (q, p) (2.7e-15), and the
    motion equal to the package's own heavy top (models.rigidbody.heavy_top: the same Lagrangian, so the
    same discrete equations; identical to the last bit here)."""
    from castrajectory.cli import system as cli_system
    from castrajectory.models import rigidbody as rb
    path = __import__("os").path.join(ROOT, "examples", "heavy_top.py")
    mod = cli_system.load(path)
    system, q0, qd0 = cli_system.described(mod, path)
    run = ct.simulate(system, q0, qd0, T=1.0, N=500, scheme="galerkin4")
    assert run.success and run.warnings == []
    qv = system.quantity_values(run.q, run.v, run.t)
    assert np.ptp(qv["L_z"]) < 5e-12 and np.ptp(qv["L_3"]) < 1e-12
    L = ct.angular_momentum(run.q, run.p)
    assert np.max(np.abs(L[:, 2] - qv["L_z"])) < 1e-13
    ref = ct.simulate(rb.heavy_top(mod.m, mod.inertia, mod.l, mod.g), q0, qd0, T=1.0, N=500, scheme="galerkin4")
    assert np.max(np.abs(run.q - ref.q)) < 1e-13


def test_cli_rtol_near_a_singular_chart_exits_at_once(tmp_path):
    """A user's spherical pendulum in angles passing 1e-6 rad from the pole, asked for --rtol 1e-6: exit 1 with
    the chart's message on one line (the first grid solved only; it ran 506 s before the watch)."""
    f = tmp_path / "sph.py"
    f.write_text("import math, casadi as ca, castrajectory as ct\n"
                 f"q0 = [1.0, 0.0]\nqd0 = [0.0, {_pole_rate(1e-6)!r}]\nT, n = 3.0, 1000\n"
                 "def system():\n    q = ca.SX.sym('q', 2)\n"
                 "    x = ca.vertcat(ca.sin(q[0]) * ca.cos(q[1]), ca.sin(q[0]) * ca.sin(q[1]), -ca.cos(q[0]))\n"
                 "    return ct.LagrangianSystem(q, ct.Atoms([x], [1.0]), [ct.Gravity(9.81, direction=(0, 0, -1))],\n"
                 "                               names=['theta', 'phi'])\n")
    p = _cli("system", str(f), "--scheme", "galerkin4", "--rtol", "1e-6")
    assert p.returncode == 1
    err = p.stderr.strip().splitlines()
    assert len(err) == 1 and "(theta, phi) are near a singular chart" in err[0] and "N = 1000" in err[0]
    p = _cli("system", str(f), "--scheme", "galerkin4")
    assert p.returncode == 0 and "warning: the coordinates (theta, phi) are near a singular chart" in p.stdout
