"""The system files of examples/ (and one that lives only here), through `castrajectory system`.

Oracles: CVODES on the same Euler–Lagrange equations (at the scheme's order: the error falls 4x when N
doubles), the normal-mode beats of the coupled pendulums, the hoop's angle form, bounded energy."""
import json
import math
import os
import subprocess
import sys

import casadi as ca
import numpy as np
import pytest

import castrajectory as ct
from castrajectory.baselines import stepping
from castrajectory.cli import system as cli_system

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXAMPLES = ["coupled_pendulums", "cart_pendulum_spring", "bead_on_rotating_hoop"]
KEYS = ("status", "iterations", "build_time_s", "solve_time_s", "scheme", "method", "t", "q", "energy",
        "error_estimate", "warnings")


def example(name):
    path = os.path.join(ROOT, "examples", f"{name}.py")
    mod = cli_system.load(path)
    return (mod,) + cli_system.described(mod, path)


def cli(*args, cwd=ROOT):
    return subprocess.run([sys.executable, "-m", "castrajectory.cli", "system", *args], capture_output=True,
                          text=True, cwd=cwd, env={**os.environ, "MPLBACKEND": "Agg"}, timeout=300)


@pytest.mark.parametrize("name", EXAMPLES)
def test_example_runs_from_the_command_line(name):
    p = cli(f"examples/{name}.py", "--T", "2", "--n", "400", "--json")
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    assert all(k in out for k in KEYS) and out["status"] == "ok"
    assert out["error_estimate"]["available"] and out["warnings"] == []


def _reference_angles(name, mod, system, q0, qd0, t):
    """CVODES on the example's equations; the hoop in its angle form (CVODES takes no constraints)."""
    if name != "bead_on_rotating_hoop":
        return stepping.reference(system, q0, qd0, t[1:], rtol=1e-12, atol=1e-12)[0]
    th = ca.SX.sym("theta", 1)
    pos = mod.R * ca.vertcat(ca.sin(th), -ca.cos(th))
    angle_form = ct.LagrangianSystem(th, ct.Atoms([pos], [mod.m]),
                                     [ct.Potential(mod.m * mod.g * pos[1], "gravity"),
                                      ct.Potential(-0.5 * mod.m * mod.omega ** 2 * pos[0] ** 2, "centrifugal")])
    return stepping.reference(angle_form, [mod.theta0], [0.0], t[1:], rtol=1e-12, atol=1e-12)[0]


def _angles(name, q):
    return np.arctan2(q[:, 0], -q[:, 1])[:, None] if name == "bead_on_rotating_hoop" else q


@pytest.mark.parametrize("name", EXAMPLES)
def test_example_agrees_with_cvodes_at_second_order(name):
    mod, system, q0, qd0 = example(name)
    T = 2.0
    errs = []
    for n in (400, 800):
        run = ct.simulate(system, q0, qd0, T, n)
        assert run.success
        ref = _reference_angles(name, mod, system, q0, qd0, run.t)
        errs.append(float(np.max(np.abs(_angles(name, run.q)[1:] - ref))))
    assert 3.0 < errs[0] / errs[1] < 5.0, errs          # midpoint: second order
    assert errs[1] < 1e-3


def test_coupled_pendulums_beat_at_the_normal_mode_frequencies():
    mod, system, q0, qd0 = example("coupled_pendulums")
    run = ct.simulate(system, q0, qd0, 30.0, 6000, "galerkin4")
    w1 = math.sqrt(mod.g / mod.l)
    w2 = math.sqrt(mod.g / mod.l + 2 * mod.k / mod.m)
    th0 = q0[0]
    lin1 = th0 / 2 * (np.cos(w1 * run.t) + np.cos(w2 * run.t))
    lin2 = th0 / 2 * (np.cos(w1 * run.t) - np.cos(w2 * run.t))
    # small angles: the nonlinear correction is O(θ0³) relative to the linear modes
    assert np.max(np.abs(run.q[:, 0] - lin1)) < 0.02 * th0
    assert np.max(np.abs(run.q[:, 1] - lin2)) < 0.02 * th0
    # half a beat period later the energy sits in the second pendulum
    half = np.argmin(np.abs(run.t - math.pi / (w2 - w1)))
    assert abs(run.q[half, 0]) < 0.05 * th0


@pytest.mark.parametrize("name", EXAMPLES)
def test_energy_stays_bounded_over_a_long_horizon(name):
    """200 s at each example's own step (T/n of its file): the variational scheme's energy error
    oscillates, bounded, instead of drifting (the second half's largest deviation is no larger than
    twice the first half's)."""
    mod, system, q0, qd0 = example(name)
    h = mod.T / mod.n
    N = int(round(200.0 / h))
    run = ct.simulate(system, q0, qd0, N * h, N)
    assert run.success
    dev = np.abs(run.energy - run.energy[0])
    assert np.max(dev) / abs(run.energy[0]) < 1e-3
    assert np.max(dev[N // 2:]) < 2.0 * np.max(dev[:N // 2])    # bounded, no drift


def test_a_system_file_that_lives_only_in_the_tests(tmp_path):
    """A spherical pendulum: a 3-D bob on a rod of length 1 (a constraint) under gravity; |x| stays 1."""
    f = tmp_path / "rod.py"
    f.write_text("import casadi as ca\nimport castrajectory as ct\n"
                 "q0 = [1.0, 0.0, 0.0]\nqd0 = [0.0, 0.0, 1.5]\nT, n = 3.0, 600\n"
                 "def system():\n    x = ca.SX.sym('x', 3)\n"
                 "    return ct.LagrangianSystem(x, ct.MassMatrix(ca.DM.eye(3)), [ct.Potential(9.81 * x[1], 'gravity')],\n"
                 "                               constraints=[(ca.dot(x, x) - 1) / 2], names=['x', 'y', 'z'])\n")
    p = cli(str(f), "--json")
    assert p.returncode == 0, p.stderr
    q = np.asarray(json.loads(p.stdout)["q"])
    assert np.max(np.abs(np.sum(q ** 2, axis=1) - 1.0)) < 1e-10


@pytest.mark.parametrize("text,needle", [
    (None, "no such file"),
    ("import nosuchmodule_xyz\n", "does not import"),
    ("x = 1\n", "defines no system()"),
    ("def system():\n    return 42\nq0 = [0]\nqd0 = [0]\n", "not a castrajectory.LagrangianSystem"),
    ("import casadi as ca, castrajectory as ct\ndef system():\n    q = ca.SX.sym('q', 2)\n"
     "    return ct.LagrangianSystem(q, ct.MassMatrix(ca.DM.eye(2)))\nq0 = [0.0, float('nan')]\nqd0 = [0.0, 0.0]\n",
     "must be finite"),
    ("import casadi as ca, castrajectory as ct\ndef system():\n    q = ca.SX.sym('q', 2)\n"
     "    return ct.LagrangianSystem(q, ct.MassMatrix(ca.diag(ca.DM([1.0, 0.0]))), names=['a', 'b'])\n"
     "q0 = [0.0, 0.0]\nqd0 = [0.0, 0.0]\n", "coordinate 'b' has no inertia"),
    ("import casadi as ca, castrajectory as ct\ndef system():\n    x = ca.SX.sym('x', 2)\n"
     "    return ct.LagrangianSystem(x, ct.MassMatrix(ca.DM.eye(2)), constraints=[(ca.dot(x, x) - 1) / 2])\n"
     "q0 = [2.0, 0.0]\nqd0 = [0.0, 0.0]\n", "violate the holonomic constraints"),
    # forces and time (#22): a stray symbol is named, a force of the wrong length, a negative damping
    ("import casadi as ca, castrajectory as ct\ndef system():\n    x = ca.SX.sym('x', 1)\n    k = ca.SX.sym('k')\n"
     "    return ct.LagrangianSystem(x, ct.MassMatrix(1.0), [ct.Potential(k * x[0] ** 2)])\nq0 = [1.0]\nqd0 = [0.0]\n",
     "depends on the symbol k"),
    ("import casadi as ca, castrajectory as ct\ndef system():\n    x = ca.SX.sym('x', 1)\n"
     "    return ct.LagrangianSystem(x, ct.MassMatrix(1.0), [ct.Force(ca.vertcat(1, ct.time()))])\n"
     "q0 = [1.0]\nqd0 = [0.0]\n", "has 2 entries; it needs one per coordinate"),
    ("import casadi as ca, castrajectory as ct\ndef system():\n    x = ca.SX.sym('x', 1)\n"
     "    return ct.LagrangianSystem(x, ct.MassMatrix(1.0), [ct.Damping(-0.5)])\nq0 = [1.0]\nqd0 = [0.0]\n",
     "damping must not be negative"),
    # a user's own system, tried as a new user would (#23)
    ("import casadi as ca, castrajectory as ct\ndef system():\n    q = ca.SX.sym('q', 4)\n"
     "    return ct.LagrangianSystem(q, ct.MassMatrix(ca.DM.eye(4)))\nq0 = [[0.1, 0.2], [0.3, 0.4]]\nqd0 = [0.0] * 4\n",
     "q0 must be a flat list of 4 numbers"),
    ("import casadi as ca, castrajectory as ct\ndef system():\n    q = ca.SX.sym('q', 2)\n"
     "    return ct.LagrangianSystem(q, ct.MassMatrix(ca.DM.eye(2)))\nq0 = [0.0]\nqd0 = [0.0, 0.0]\n",
     "the system has 2 coordinates (q_0, q_1)"),
    ("import casadi as ca, castrajectory as ct\ndef system():\n    q = ca.SX.sym('q', 2)\n"
     "    x = ca.vertcat(ca.sin(q[0]) * ca.cos(q[1]), ca.sin(q[0]) * ca.sin(q[1]), -ca.cos(q[0]))\n"
     "    return ct.LagrangianSystem(q, ct.Atoms([x], [1.0]), [ct.Gravity(9.81)])\nq0 = [0.5, 0.0]\nqd0 = [0.0, 1.0]\n",
     "Gravity on atoms of 3 coordinates needs a direction"),
])
def test_bad_system_files_are_refused(tmp_path, text, needle):
    f = tmp_path / "user.py"
    if text is not None:
        f.write_text(text)
    p = cli(str(f))
    assert p.returncode == 2 and p.stdout == ""
    assert len(p.stderr.strip().splitlines()) == 1 and needle in p.stderr, p.stderr


# ----------------------------------------------------------------------------- the generated derivation
@pytest.mark.parametrize("name", EXAMPLES + ["double_pendulum"])
def test_generated_equations_are_the_model(name):
    """The printed Euler–Lagrange equations (lambdified from the same sympy expressions the document
    prints) give the package's own acceleration at random states to 1e-10."""
    derivation = pytest.importorskip("castrajectory.inspect.derivation")
    pytest.importorskip("sympy")
    if name == "double_pendulum":
        from castrajectory.models.pendulum import double_pendulum
        system, q0 = double_pendulum(), np.array([2.0, 1.0])
    else:
        _, system, q0, _ = example(name)
    acc = derivation.accelerations(derivation.equations(system))
    rng = np.random.default_rng(3)
    for _ in range(10):
        q, v = q0 + rng.uniform(-0.5, 0.5, system.nq), rng.uniform(-2, 2, system.nq)
        if system.nc:   # a state on the constraint: the hoop's circle, the velocity tangent to it
            q = q / np.linalg.norm(q)
            v = v - (v @ q) * q
        want = np.asarray(system.acceleration(q, v), float).reshape(-1)
        assert np.max(np.abs(acc(q, v) - want)) <= 1e-10 * (1 + np.max(np.abs(want)))


def test_derive_writes_the_document(tmp_path):
    pytest.importorskip("sympy")
    out = tmp_path / "derivation.md"
    p = subprocess.run([sys.executable, "-m", "castrajectory.cli", "derive", "examples/bead_on_rotating_hoop.py",
                        "--out", str(out)], capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert p.returncode == 0, p.stderr
    text = out.read_text()
    for heading in ("## Coordinates", "## Energies and the Lagrangian", "## The Euler–Lagrange equations",
                    "## The discrete problem", "## Energy", "## Symmetries and conserved quantities"):
        assert heading in text
    assert r"\lambda" in text and "= 0$$" in text            # the constraint and its multiplier
    p = subprocess.run([sys.executable, "-m", "castrajectory.cli", "derive", str(tmp_path / "none.py"),
                        "--out", str(out)], capture_output=True, text=True, cwd=ROOT, timeout=60)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1 and "no such file" in p.stderr


def test_a_cyclic_coordinate_is_found_and_its_momentum_named():
    derivation = pytest.importorskip("castrajectory.inspect.derivation")
    pytest.importorskip("sympy")
    xy = ca.SX.sym("xy", 2)
    thrown = ct.LagrangianSystem(xy, ct.Atoms([xy], [2.0]), [ct.Gravity(9.81)], names=["x", "y"])
    eq = derivation.equations(thrown)
    assert eq.cyclic == [0]                       # x: the horizontal momentum 2 ẋ is conserved
    text = derivation.markdown(thrown, "throw")
    assert r"$x$ does not appear in $L$ (cyclic)" in text and r"2 \dot{x}" in text


def test_system_writes_its_derivation_beside_the_solve(tmp_path):
    pytest.importorskip("sympy")
    out = tmp_path / "coupled.md"
    p = cli("examples/coupled_pendulums.py", "--T", "1", "--n", "100", "--derive", str(out), "--json")
    assert p.returncode == 0, p.stderr
    assert json.loads(p.stdout)["status"] == "ok"
    assert "## The Euler–Lagrange equations" in out.read_text()
    p = cli("examples/coupled_pendulums.py", "--derive", str(tmp_path / "nofolder" / "x.md"))
    assert p.returncode == 2 and "--derive" in p.stderr


@pytest.mark.parametrize("name", EXAMPLES)
def test_whole_trajectory_agrees_with_dop853_on_the_generated_equations(name):
    """solve_ivp (DOP853, rtol 1e-12) integrates the *printed* equations (lambdified from the derivation);
    the whole-trajectory solution converges to it at the scheme's order (error / 4 when N doubles)."""
    derivation = pytest.importorskip("castrajectory.inspect.derivation")
    pytest.importorskip("sympy")
    solve_ivp = pytest.importorskip("scipy.integrate").solve_ivp
    mod, system, q0, qd0 = example(name)
    acc = derivation.accelerations(derivation.equations(system))
    nq, T = system.nq, 2.0
    ref = solve_ivp(lambda t, y: np.concatenate([y[nq:], acc(y[:nq], y[nq:])]), (0.0, T),
                    np.concatenate([q0, qd0]), method="DOP853", rtol=1e-12, atol=1e-12, dense_output=True)
    errs = []
    for n in (400, 800):
        run = ct.simulate(system, q0, qd0, T, n)
        errs.append(float(np.max(np.abs(run.q - ref.sol(run.t)[:nq].T))))
    assert 3.0 < errs[0] / errs[1] < 5.0 and errs[1] < 1e-3, errs


@pytest.mark.parametrize("m1,m2,l1,l2,g", [(1.0, 1.0, 1.0, 1.0, 9.81), (1.3, 0.7, 0.9, 1.4, 9.81),
                                           (2.0, 0.5, 1.5, 0.5, 3.7)])
def test_generated_double_pendulum_matches_the_handwritten_derivation(m1, m2, l1, l2, g):
    """docs/derivations.md, "The double pendulum from the least-action principle", term by term: the
    generated M(q), and f(q, q̇) = −c(q, q̇) − ∇U(q), equal the hand-written formulas as expressions in
    θ₁, θ₂, θ̇₁, θ̇₂ (trigonometric functions expanded; coefficients compared to 1e-12)."""
    derivation = pytest.importorskip("castrajectory.inspect.derivation")
    sp = pytest.importorskip("sympy")
    from castrajectory.models.pendulum import double_pendulum
    eq = derivation.equations(double_pendulum(m1, m2, l1, l2, g))
    t1, t2 = eq.q
    w1, w2 = eq.qd
    D = t1 - t2
    M_hand = sp.Matrix([[(m1 + m2) * l1 ** 2, m2 * l1 * l2 * sp.cos(D)], [m2 * l1 * l2 * sp.cos(D), m2 * l2 ** 2]])
    c_hand = m2 * l1 * l2 * sp.sin(D) * sp.Matrix([w2 ** 2, -w1 ** 2])
    gradU_hand = sp.Matrix([(m1 + m2) * g * l1 * sp.sin(t1), m2 * g * l2 * sp.sin(t2)])

    def zero(e):
        e = sp.expand(sp.expand_trig(e))
        return e.xreplace({f: 0 for f in e.atoms(sp.Float) if abs(f) < 1e-12}) == 0

    assert all(zero(eq.M[i, j] - M_hand[i, j]) for i in range(2) for j in range(2))
    assert all(zero(eq.forces[i] + c_hand[i] + gradU_hand[i]) for i in range(2))
    assert zero(eq.U + (m1 + m2) * g * l1 * sp.cos(t1) + m2 * g * l2 * sp.cos(t2))


# ----------------------------------------------------------------------------- forces and time (#22)
#: the examples with forces or time, and the grids on which galerkin4 is in its asymptotic range over T = 2
FORCED = {"damped_oscillator": (100, 200), "driven_pendulum": (100, 200), "kapitza_pendulum": (800, 1600)}


@pytest.mark.parametrize("name", list(FORCED))
def test_forced_examples_agree_with_dop853_on_their_generated_equations(name):
    """The derivation's printed equations ``d/dt ∂L/∂q̇ − ∂L/∂q = Q`` (with the time), lambdified, match the
    package's acceleration at random ``(q, q̇, t)``, and DOP853 (rtol 1e-12) on them is the limit the
    whole trajectory converges to at galerkin4's order (error / 16 when N doubles)."""
    derivation = pytest.importorskip("castrajectory.inspect.derivation")
    pytest.importorskip("sympy")
    solve_ivp = pytest.importorskip("scipy.integrate").solve_ivp
    mod, system, q0, qd0 = example(name)
    acc = derivation.accelerations(derivation.equations(system))
    rng = np.random.default_rng(5)
    for _ in range(5):
        q, v, t = q0 + rng.uniform(-0.5, 0.5, system.nq), rng.uniform(-2, 2, system.nq), rng.uniform(0, 10)
        want = np.asarray(system.acceleration(q, v, t), float).reshape(-1)
        assert np.max(np.abs(acc(q, v, t) - want)) <= 1e-10 * (1 + np.max(np.abs(want)))
    nq, T = system.nq, 2.0
    ref = solve_ivp(lambda t, y: np.concatenate([y[nq:], acc(y[:nq], y[nq:], t)]), (0.0, T),
                    np.concatenate([q0, qd0]), method="DOP853", rtol=1e-12, atol=1e-12, dense_output=True)
    errs = []
    for n in FORCED[name]:
        run = ct.simulate(system, q0, qd0, T, n, "galerkin4")
        errs.append(float(np.max(np.abs(run.q - ref.sol(run.t)[:nq].T))))
    assert 12.0 < errs[0] / errs[1] < 20.0 and errs[1] < 1e-5, errs    # Kapitza: 1.9e-5, 1.2e-6 measured
