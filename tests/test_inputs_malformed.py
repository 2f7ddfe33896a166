"""Malformed files and flags (issue 42): each is refused with exit code 2 and one line on stderr, without a
traceback, before any solve; what is well formed but was misread (a folder's own module, an integral float
``n``) is read as Python reads it; and the droplet's oracle keeps its digits for a huge span (its pressure against
the flat arc's closed form ``12 gamma A / a³``).
"""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

import castrajectory as ct
from castrajectory.cli import system as cli_system
from castrajectory.models.droplet import Droplet, analytic, segment_area_factor
from castrajectory.validation import EXCERPT, InputError, finite, quoted, state_vector

ROOT = Path(__file__).resolve().parents[1]
ENV = dict(os.environ, MPLBACKEND="Agg")

#: A unit oscillator x'' = -K x (K = 4: omega = 2), from x = 1 at rest.
OSCILLATOR = """
import casadi as ca
import castrajectory as ct
K = 4.0
x = ca.SX.sym("x", 1)
def system():
    return ct.LagrangianSystem(x, ct.MassMatrix(1.0), [ct.Potential(0.5 * K * x[0] ** 2)], names=["x"])
q0 = [1.0]
qd0 = [0.0]
"""

#: A cart (atom 0) on a line and a bob (atom 1) on a rod beneath it: two atoms for ``links``.
CART = """
import casadi as ca
import castrajectory as ct
q = ca.SX.sym("q", 2)
cart = ca.vertcat(q[0], 0)
bob = ca.vertcat(q[0] + ca.sin(q[1]), -ca.cos(q[1]))
def system():
    return ct.LagrangianSystem(q, ct.Atoms([cart, bob], [1.0, 0.5]), [ct.Gravity(9.81)], names=["x", "theta"])
q0 = [0.0, 0.1]
qd0 = [0.0, 0.0]
"""


def cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "castrajectory.cli", *args], capture_output=True, text=True,
                          env=ENV, cwd=cwd, timeout=120)


def refused(p, *needles):
    """Exit 2, one line on stderr holding every needle, no traceback, nothing on stdout (no solve ran)."""
    assert p.returncode == 2, (p.returncode, p.stdout[-2000:], p.stderr[-2000:])
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in p.stderr, p.stderr[-2000:]
    for needle in needles:
        assert needle in lines[0], lines[0]
    assert p.stdout == ""
    return lines[0]


def write(tmp_path, text, name="user.py"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


# ----------------------------------------------------------------------------- the file's own settings
@pytest.mark.parametrize("base, extra, needles", [
    (OSCILLATOR, "T = 'two'", ["T must be a number, not the text 'two'"]),
    (OSCILLATOR, "n = float('inf')", ["n must be finite (got inf)"]),
    (OSCILLATOR, "n = 10 ** 400", ["n must be finite"]),
    (OSCILLATOR, "n = 200.7", ["n must be an integer >= 2 (got 200.7)"]),
    (OSCILLATOR, "title = 5", ["title must be text (got 5)"]),
    (OSCILLATOR, "links = [(0, 1)]", ["links must be True or False: the system has no atoms to join"]),
    (CART, "links = 5", ["links must be True, False or pairs (i, j) of atom indices from -1", "to 1 (got 5)"]),
    (CART, "links = [(0, 2)]", ["links must be", "(got [(0, 2)])"]),
    (CART, "links = [(0, 'a')]", ["links must be"]),
    (CART, "links = 'ab'", ["links must be", "(got 'ab')"]),
    # a key mistyped in case was ignored: N = 200 ran the default 1000 steps
    (OSCILLATOR, "N = 200", ["defines N but no n: did you mean n?"]),
    (OSCILLATOR, "t = 2.0", ["defines t but no T: did you mean T?"]),
    (OSCILLATOR.replace("qd0 = [0.0]", "QD0 = [0.0]"), "", ["defines QD0 but no qd0"]),
], ids=["T-text", "n-inf", "n-huge-int", "n-fraction", "title-number", "links-no-atoms", "links-number",
        "links-out-of-range", "links-text-index", "links-text", "N-for-n", "t-for-T", "QD0-for-qd0"])
def test_malformed_settings_are_refused(tmp_path, base, extra, needles):
    """``T = 'two'``, ``n = inf`` and ``links = 5`` gave a traceback and exit 1; ``n = 200.7`` ran 200 steps."""
    path = write(tmp_path, base + extra + "\n")
    line = refused(cli("system", str(path)), str(path), *needles)
    assert len(line) < len(str(path)) + 200


def test_the_files_settings_are_checked_for_derive_too(tmp_path):
    path = write(tmp_path, OSCILLATOR + "n = 200.7\n")
    refused(cli("derive", str(path), "--out", str(tmp_path / "d.md")), "n must be an integer >= 2 (got 200.7)")
    assert not (tmp_path / "d.md").exists()


def test_integral_float_n_and_a_symbol_named_t_are_accepted(tmp_path):
    """``n = 200.0`` is 200 steps; ``t = ct.time()`` is the user's own symbol, not a mistyped horizon."""
    path = write(tmp_path, OSCILLATOR + "T, n = 3.0, 200.0\nt = ct.time()\n")
    p = cli("system", str(path), "--json")
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    t, q = np.asarray(d["t"]), np.asarray(d["q"])[:, 0]
    assert t.size == 201 and t[-1] == pytest.approx(3.0, rel=1e-12)
    # x = cos(2 t); midpoint at h = 0.015: 3.6e-4 measured
    assert np.max(np.abs(q - np.cos(2.0 * t))) < 2e-3


# ----------------------------------------------------------------------------- a huge value is quoted by an excerpt
def test_a_huge_state_with_one_word_is_one_short_line(tmp_path):
    """A 200 MB q0 with one non-number gave a 125 MB stderr "line": the value was quoted whole."""
    path = write(tmp_path, OSCILLATOR + "q0 = [0.0] * 2_000_000 + ['x']\n")
    line = refused(cli("system", str(path)), "q0 must be a list of 1 numbers, not text (entry 2000000 is 'x')")
    assert len(line) < len(str(path)) + 120  # the whole value was 10 MB


@pytest.mark.parametrize("value, needle", [
    ([0.0] * 1_000_000 + ["x"], "not text (entry 1000000 is 'x')"),
    ([0.0] * 1_000_000 + [object()], "q0 must be a list of 3 numbers (entry 1000000 is <object object"),
    ("0.5" * 1_000_000, "not text (got '0.50.5"),
    ([0.0, 0.0, float("inf")], "q0 must be finite (entry 2 is inf)"),
    ([[1.0] * 100_000] * 3, "q0 must be a flat list of 3 numbers"),
], ids=["word", "object", "text", "inf", "nested"])
def test_state_messages_quote_an_excerpt(value, needle):
    with pytest.raises(InputError) as err:
        state_vector("q0", value, 3, ["x", "y", "z"])
    message = str(err.value)
    assert needle in message and len(message) < 2 * EXCERPT + 60 and "\n" not in message


def test_quoted_values_are_cut():
    assert len(quoted("a" * 10 ** 7)) <= EXCERPT and len(quoted(list(range(10 ** 6)))) <= EXCERPT
    assert quoted("two") == "'two'" and quoted(np.float64(2.5)) == "2.5"
    with pytest.raises(InputError) as err:
        finite("T", "x" * 10 ** 6)
    assert len(str(err.value)) < EXCERPT + 40


# ----------------------------------------------------------------------------- a file that exits
@pytest.mark.parametrize("body, needle", [
    ("import sys\nsys.exit(0)\n", "called sys.exit(0) while loading; it must define system(), not exit"),
    ("raise SystemExit('done')\n", "called sys.exit('done') while loading"),
    ("exit()\n", "called sys.exit() while loading"),
], ids=["exit-0", "exit-text", "builtin-exit"])
def test_a_file_that_exits_while_loading_is_refused(tmp_path, body, needle):
    """``sys.exit(0)`` inside a system file exited 0 with no output."""
    path = write(tmp_path, OSCILLATOR + body)
    refused(cli("system", str(path)), str(path), needle)


def test_a_system_function_that_exits_is_refused(tmp_path):
    path = write(tmp_path, OSCILLATOR.replace("    return ct.", "    import sys; sys.exit(3)\n    return ct."))
    refused(cli("system", str(path)), "system() called sys.exit(3); it must return a castrajectory.LagrangianSystem")


def test_a_control_file_that_exits_is_refused(tmp_path):
    path = write(tmp_path, "import sys\nsys.exit(0)\n")
    refused(cli("control", str(path)), "called sys.exit(0) while loading; it must define problem(), not exit")


# ----------------------------------------------------------------------------- one inertia check for both kinds of file
CONTROL = """
import casadi as ca
import castrajectory as ct

def problem(N=40, scheme="midpoint"):
    u = ct.Control("u", 1, lower=-50, upper=50)
    x = ca.SX.sym("x", 1)
    block = ct.LagrangianSystem(x, ct.MassMatrix({mass}), [ct.Force(u)], names=["x"])
    ocp = ct.OptimalControl(block, T=1.0, N=N, scheme=scheme)
    ocp.initial(q=[0.0], qd=[0.0])
    ocp.final(q=[1.0], qd=[0.0])
    ocp.minimize(running=u ** 2)
    return ocp
"""


def test_control_files_refuse_a_negative_mass_as_system_files_do(tmp_path):
    """A control file with mass -1 was solved (status ok, cost 12.1); a system file with it is refused."""
    needle = "the mass matrix is not positive definite at q0 (smallest eigenvalue -1): coordinate 'x' has no inertia"
    control = write(tmp_path, CONTROL.format(mass=-1.0), "block.py")
    refused(cli("control", str(control)), str(control), needle)
    system = write(tmp_path, OSCILLATOR.replace("MassMatrix(1.0)", "MassMatrix(-1.0)"), "osc.py")
    refused(cli("system", str(system)), str(system), needle)
    # one check: the API refuses both with the same sentence
    x = ca.SX.sym("x", 1)
    block = ct.LagrangianSystem(x, ct.MassMatrix(-1.0), [ct.Force(ct.Control("u", 1))], names=["x"])
    with pytest.raises(InputError) as control_err:
        ct.OptimalControl(block, T=1.0, N=10).initial(q=[0.0], qd=[0.0])
    with pytest.raises(InputError) as simulate_err:
        ct.simulate(ct.LagrangianSystem(x, ct.MassMatrix(-1.0), [], names=["x"]), [0.0], [0.0], T=1.0, N=10)
    assert str(control_err.value) == str(simulate_err.value) == needle


def test_a_control_file_with_a_positive_mass_solves(tmp_path):
    """The same block of unit mass moved by 1 in 1 s: J* = 12 N² / (N² - 1) on midpoint (the class docstring)."""
    control = write(tmp_path, CONTROL.format(mass=1.0), "block.py")
    p = cli("control", str(control), "--n", "10", "--json")
    assert p.returncode == 0, p.stderr
    assert json.loads(p.stdout)["cost"] == pytest.approx(12 * 100 / 99, rel=1e-13)  # 1.5e-16 measured


# ----------------------------------------------------------------------------- a module beside the file
SIBLING = "castrajectory_test_sibling_stiffness"


def test_a_file_imports_a_module_of_its_own_folder(tmp_path):
    """``from <sibling> import K`` failed with "does not import": the folder was not on the import path."""
    (tmp_path / f"{SIBLING}.py").write_text("K = 4.0\n")
    path = write(tmp_path, OSCILLATOR.replace("K = 4.0", f"from {SIBLING} import K") + "T, n = 3.0, 200\n")
    p = cli("system", str(path), "--json", cwd=str(ROOT))
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    t, q = np.asarray(d["t"]), np.asarray(d["q"])[:, 0]
    assert np.max(np.abs(q - np.cos(2.0 * t))) < 2e-3  # K = 4 from the sibling: omega = 2; 3.6e-4 measured


def test_the_folder_leaves_the_import_path_after_loading(tmp_path):
    (tmp_path / f"{SIBLING}_2.py").write_text("K = 4.0\n")
    path = write(tmp_path, OSCILLATOR.replace("K = 4.0", f"from {SIBLING}_2 import K"))
    before = list(sys.path)
    module = cli_system.load(str(path))
    system, q0, _ = cli_system.described(module, str(path))
    assert sys.path == before and str(tmp_path) not in sys.path
    assert module.K == 4.0 and system.nq == 1 and q0.tolist() == [1.0]


# ----------------------------------------------------------------------------- the droplet's oracle at a huge span
@pytest.mark.parametrize("span", [1e3, 1e6, 1e10, 1e100])
def test_flat_arc_oracle_against_its_closed_form(span):
    """A pinned span a with area A is a flat arc: with t0 = 6 A / a², half-angle t = t0 (1 - 2 t0²/15 ...) and
    pressure 2 gamma sin(t) / a = 12 gamma A / a³ (1 - 3 t0²/10 ...).  The oracle read 2.1e-14 for 1.2e-17 at
    a = 1e6 (t - sin(2t)/2 at t = 6e-12 kept no digit): the 99.9 % pressure error on a right answer."""
    area, gamma = 1.0, 1.3
    cap = analytic(Droplet(gamma_gl=gamma, gamma_sl=0.2, gamma_sg=0.5, area=area, span=span))
    t = 6.0 * area / span ** 2
    assert cap.contact_angle == pytest.approx(t * (1.0 - 2.0 * t * t / 15.0), rel=2e-14)  # 2.2e-16 measured
    assert cap.pressure == pytest.approx(12.0 * gamma * area / span ** 3 * (1.0 - 0.3 * t * t), rel=2e-14)
    assert cap.span == pytest.approx(span, rel=1e-14)


def test_cap_oracle_at_the_semicircle_and_the_full_circle():
    """A = pi a² / 8 is a semicircle (t = pi/2, R = a/2); a tiny span holds a full circle, R = sqrt(A / pi)."""
    semi = analytic(Droplet(gamma_gl=1.0, gamma_sl=0.2, gamma_sg=0.5, area=math.pi / 8.0 * 4.0, span=2.0))
    assert semi.contact_angle == pytest.approx(math.pi / 2.0, abs=1e-14)  # 0 measured
    assert semi.radius == pytest.approx(1.0, rel=1e-14)  # 0 measured
    for span in (1e-6, 1e-200):
        round_ = analytic(Droplet(gamma_gl=1.0, gamma_sl=0.2, gamma_sg=0.5, area=2.0, span=span))
        assert round_.radius == pytest.approx(math.sqrt(2.0 / math.pi), rel=1e-14)  # 1.1e-16 measured
    # the area factor t - sin(2t)/2 = 2 t³/3 (1 - t²/5 + 2 t⁴/105 ...) of a flat cap: it read 0 at t = 6e-12
    for t in (6e-12, 1e-4, 1e-3):
        series = 2.0 * t ** 3 / 3.0 * (1.0 - t ** 2 / 5.0 + 2.0 * t ** 4 / 105.0)
        assert segment_area_factor(t) == pytest.approx(series, rel=1e-14)  # 0 measured
    assert segment_area_factor(1.2) == pytest.approx(1.2 - 0.5 * math.sin(2.4), rel=1e-15)  # no cancellation there


def test_droplet_script_at_a_huge_span_is_right_and_quiet():
    """``problems/droplet.py --span 1e6``: the answer's pressure 1.2000075e-17 against 12 A / a³ = 1.2e-17 (the
    discretisation's 6.25e-6 at N = 400); the oracle's reported error was 99.9 %.  Nothing on stderr."""
    p = subprocess.run([sys.executable, str(ROOT / "problems" / "droplet.py"), "--span", "1e6", "--json"],
                       capture_output=True, text=True, env=ENV, timeout=120)
    assert p.returncode == 0 and p.stderr == "", p.stderr
    d = json.loads(p.stdout)
    assert d["analytic"]["pressure"] == pytest.approx(1.2e-17, rel=1e-12)
    assert d["pressure"] == pytest.approx(1.2e-17, rel=6e-4)  # 6.25e-6 measured
    assert d["errors"]["pressure"] < 6e-4  # 6.25e-6 measured (0.9994 before)


def test_droplet_span_beyond_double_precision_is_refused():
    """At a = 1e150 the arc's pressure 1.2e-449 is no double: a ZeroDivisionError traceback and overflow warnings."""
    p = subprocess.run([sys.executable, str(ROOT / "problems" / "droplet.py"), "--span", "1e150"],
                       capture_output=True, text=True, env=ENV, timeout=120)
    refused(p, "span 1e+150 with area 1 is an arc of radius about 1e449", "beyond double precision")
