"""Smoke runs of every problem script and of the console command, headless, with small sizes.

Checks the shared conventions: clean JSON on stdout, exit codes 0/1/2, one-line refusals without a
traceback, and no output written by a refused or failed run.
"""
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
ENV = dict(os.environ, MPLBACKEND="Agg")


def run(args, cwd=None):
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, env=ENV, cwd=cwd, timeout=300)


def script(name):
    return str(ROOT / "problems" / f"{name}.py")


def test_droplet_default_summary_and_plot(tmp_path):
    out = tmp_path / "drop.png"
    p = run([script("droplet"), "--n", "60", "--plot", str(out)])
    assert p.returncode == 0, p.stderr
    assert "status: ok" in p.stdout and "Young residual" in p.stdout
    assert out.stat().st_size > 10_000


@pytest.mark.parametrize("extra", [[], ["--formulation", "graph"], ["--span", "1.5"], ["--gamma-sl", "1.5"]])
def test_droplet_json_is_the_only_stdout(extra):
    p = run([script("droplet"), "--n", "50", "--json", "--verbose", *extra])  # --verbose: the log must go to stderr
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)  # fails if anything else was printed
    assert "Ipopt" in p.stderr
    for k in ("status", "formulation", "iterations", "build_time_s", "solve_time_s", "contact_angle", "span",
              "pressure", "energy", "young_residual", "x", "y", "analytic", "errors"):
        assert k in d
    assert set(d["analytic"]) == {"contact_angle", "span", "radius", "pressure", "energy"}
    assert set(d["errors"]) == {"shape", "contact_angle", "span", "energy", "pressure"}
    assert d["status"] == "ok" and len(d["x"]) == len(d["y"]) == 51
    assert d["x"][0] == 0.0 and d["y"][0] == 0.0 and d["y"][-1] == 0.0
    assert math.isclose(d["x"][-1], d["span"], rel_tol=1e-12)
    # the numbers in the JSON agree with the analytic cap to discretisation error at N = 50
    assert abs(d["pressure"] - d["analytic"]["pressure"]) < 1e-2 * d["analytic"]["pressure"]
    if "--span" not in extra:
        assert abs(d["young_residual"]) < 1e-2
    else:
        assert d["span"] == 1.5


def test_droplet_angle_json():
    p = run([script("droplet_angle"), "--gamma-sl", "0.2", "--json"])
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert set(("status", "contact_angle", "young_residual", "radius", "span", "energy")) <= set(d)
    assert math.isclose(d["contact_angle"], math.acos(0.8), abs_tol=1e-10)
    assert abs(d["young_residual"]) < 1e-10


def test_droplet_angle_plot(tmp_path):
    out = tmp_path / "e.png"
    p = run([script("droplet_angle"), "--plot", str(out)])
    assert p.returncode == 0 and out.stat().st_size > 10_000


BAD = [
    (["--gamma-gl", "0"], "gamma_gl must be positive"),
    (["--gamma-gl", "-1"], "gamma_gl must be positive"),
    (["--area", "0"], "area must be positive"),
    (["--area", "nan"], "area must be finite"),
    (["--gamma-sl", "inf"], "gamma_sl must be finite"),
    (["--n", "2"], "n must be an integer >= 3"),
    (["--gamma-sg", "3"], "spreading coefficient"),
    (["--gamma-sl", "2.5"], "pi"),
    (["--gamma-sl", "1.5", "--formulation", "graph"], "90 degrees"),
    (["--span", "-1"], "span must be positive"),
    (["--span", "0.5", "--formulation", "graph"], "90 degrees"),
    (["--n", "abc"], "invalid int"),
    (["--formulation", "spline"], "invalid choice"),
]


@pytest.mark.parametrize("args,needle", BAD)
def test_droplet_refuses_bad_input(tmp_path, args, needle):
    out = tmp_path / "keep.png"
    out.write_bytes(b"earlier output")
    p = run([script("droplet"), *args, "--json", "--plot", str(out)])
    assert p.returncode == 2
    assert p.stdout == ""
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0] and "Traceback" not in p.stderr
    assert out.read_bytes() == b"earlier output"


def test_droplet_angle_refuses_bad_input():
    p = run([script("droplet_angle"), "--gamma-sg", "2.5"])
    assert p.returncode == 2 and "spreading coefficient" in p.stderr and "Traceback" not in p.stderr


def test_solver_failure_exits_1_and_writes_nothing(tmp_path):
    out = tmp_path / "keep.png"
    out.write_bytes(b"earlier output")
    p = run([script("droplet"), "--n", "200", "--max-iter", "1", "--json", "--plot", str(out)])
    assert p.returncode == 1
    d = json.loads(p.stdout)
    assert d["status"] == "Maximum_Iterations_Exceeded"
    assert "did not converge" in p.stderr
    assert out.read_bytes() == b"earlier output"


def test_console_list_run_and_report(quick_report):
    p = run(["-m", "castrajectory.cli", "list"])
    assert p.returncode == 0 and "droplet" in p.stdout and "droplet_angle" in p.stdout
    p = run(["-m", "castrajectory.cli", "run", "droplet", "--n", "30", "--json"])
    assert p.returncode == 0 and json.loads(p.stdout)["status"] == "ok"
    p = run(["-m", "castrajectory.cli", "run", "nosuchscene"])
    assert p.returncode == 2 and "unknown scene" in p.stderr
    out = quick_report
    summary = (out / "summary.md").read_text()
    for f in ("droplet_curve.png", "droplet_angle.png", "droplet_convergence.png", "droplet_overhang.png"):
        assert f in summary and (out / f).exists()
    assert (out / "droplet_convergence.csv").read_text().count("\n") > 10
    # what the report adds: one stability table over every family, and what each scene carries
    stab = summary.split("## Stability on stiff and extreme cases")[1].split("\n## ")[0]
    for family in ("droplet", "stiff spring", "pendulum", "contact", "rigid body"):
        assert f"| {family} |" in stab
    assert "FAILED" not in stab and "cases pass." in stab and "Contact battery" in stab
    carries = {line.split(" | ")[0].strip("| "): line for line in
               summary.split("## What each scene carries")[1].splitlines() if line.startswith("| ")}
    assert "| 0 (0) |" in carries["double_pendulum"] and "gravity" in carries["double_pendulum"]
    assert "gravity" not in carries["double_pendulum_g0"]
    assert "contact: 1 gap" in carries["bouncing_ball"] and "| 0 (0) | equal" not in carries["bouncing_ball"]
    assert "no NLP" in carries["collision_impulse"]
    # the optimal-control section (#24): every scene against its oracle, the swing-ups animated
    ocs = summary.split("## Optimal control on the discrete action (DMOC)")[1].split("\n## ")[0]
    for stem in ("block_move", "min_time", "damped_transfer", "satellite_slew", "cartpole_swingup", "pendulum_swingup"):
        assert f"({stem}_plot.png)" in ocs and (out / f"{stem}.json").exists()
    assert (out / "pendulum_swingup.gif").exists() and "status: ok" in ocs and "FAILED" not in ocs
    table = [[cell.strip() for cell in ln.strip("| ").split(" | ")] for ln in
             ocs.split("### Orders")[1].splitlines() if ln.startswith("| ")]
    head, rows = table[0], {row[0]: row for row in table[1:]}
    cost, states = head.index("order of J"), head.index("order of (x, ẋ)")
    for scheme, order in (("midpoint", 2), ("galerkin4", 4), ("gauss4", 4), ("galerkin6", 6)):
        assert abs(float(rows[scheme][cost]) - order) < 0.1 and abs(float(rows[scheme][states]) - order) < 0.1
    # the contact-implicit section (#27): each scene ok against its oracle, certified (no battery in the quick size)
    cic = summary.split("## Contact-implicit optimal control")[1].split("\n## ")[0]
    for stem in ("block_push", "block_push_sticks", "bounce_to_target", "push_to_target", "hopper"):
        assert f"({stem}_plot.png)" in cic and (out / f"{stem}.json").exists()
    assert "FAILED" not in cic and cic.count("status: ok") == 5 and (out / "hopper.gif").exists()
    # the hopper at its defaults (N = 40): a motion of the hopper under its own controls (the contact march of its
    # controls reproduces it: certificate 2e-14, the whole march 6e-13), complementarity 3e-11, no flipped biactive
    # pair descends, the foot never enters the floor and the leg keeps its bounds; its cost 10.826 below nosnoc's own
    # local optimum on the same problem (11.38, scripts/bench_contact_ocp.py --hopper)
    d = json.loads((out / "hopper.json").read_text())
    assert d["status"] == "ok" and d["certificate"] < 1e-9 and d["march_distance"] < 1e-8
    assert d["complementarity"] < 1e-9
    # (its landing and lift-off, once pinned against their steps' windows at 11.22, moved across their nodes: no event
    # is held by a window, and any held on a node says so; issue 41)
    assert d["b_stationary"] and all(p["held"] == "node" for p in d["pinned"])
    assert all(f"step {p['step']} sits on the node" in " ".join(d["warnings"]) for p in d["pinned"])
    q = np.asarray(d["q"])
    assert np.min(q[:, 1] - q[:, 3] * np.cos(q[:, 2])) > -1e-9
    assert 0.1 - 1e-9 <= np.min(q[:, 3]) and np.max(q[:, 3]) <= 0.5 + 1e-9
    assert d["cost"] <= 10.83 and len(d["impact_times"]) >= 1          # (measured 10.8259)
    # the built-in scenes' derivations, generated and linked (sympy is in CI's extras)
    assert "(derivation_double_pendulum.md)" in summary
    assert "## The Euler–Lagrange equations" in (out / "derivation_double_pendulum.md").read_text()


def test_convergence_script_small(tmp_path):
    p = run([str(ROOT / "scripts" / "droplet_convergence.py"), "--n-max", "256", "--out", str(tmp_path)])
    assert p.returncode == 0, p.stderr
    assert "observed orders" in p.stdout
    assert (tmp_path / "droplet_convergence.png").exists()


def test_estimate_battery_quick(tmp_path):
    """scripts/estimate_battery.py --quick: a few answers against their independent references, each estimate
    within 10x of its true error (measured 1.0x-1.9x), and the rows written as JSON."""
    out = tmp_path / "rows.json"
    p = run([str(ROOT / "scripts" / "estimate_battery.py"), "--quick", "--json", str(out)])
    assert p.returncode == 0, p.stderr
    rows = json.loads(out.read_text())
    assert len(rows) >= 4 and all(r["status"] == "ok" for r in rows)
    assert all(0.1 <= r["ratio"] <= 10 for r in rows), [(r["case"], r["ratio"]) for r in rows]
    assert "0 estimates more than 10x off" in p.stdout


def test_every_scene_is_installed_as_castrajectory_problems():
    """problems/__init__.py makes the scripts the installed package castrajectory.problems,
    which is what `castrajectory run <scene>` imports."""
    import importlib

    import castrajectory.problems
    from castrajectory.cli import SCENES

    files = {p.stem for p in (ROOT / "problems").glob("*.py") if p.stem != "__init__"}
    assert files == set(SCENES)
    for name, module in SCENES.items():
        mod = importlib.import_module(module)
        assert callable(mod.main) and mod.__doc__


# ----------------------------------------------------------------------------- mechanics scenes
MECH_KEYS = ("status", "iterations", "build_time_s", "solve_time_s", "t", "q", "energy", "scheme", "method")


@pytest.mark.parametrize("method,scheme", [("whole", "midpoint"), ("whole", "galerkin4"), ("whole", "trapezoid"),
                                           ("march", "midpoint"), ("rk4", "midpoint"),
                                           ("implicit-euler", "midpoint")])
def test_double_pendulum_json(method, scheme):
    p = run([script("double_pendulum"), "--T", "1", "--n", "200", "--method", method, "--scheme", scheme, "--json"])
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    for k in MECH_KEYS:
        assert k in d
    assert d["status"] == "ok" and d["method"] == method
    assert len(d["t"]) == len(d["q"]) == len(d["energy"]) == 201
    assert d["t"][-1] == 1.0 and d["q"][0] == [2.0, 1.0] and len(d["q"][0]) == 2
    e = d["energy"]
    if method == "implicit-euler":
        # first order and dissipative: energy only decreases
        assert e[-1] < e[0] and all(b <= a + 1e-9 for a, b in zip(e, e[1:]))
    else:
        # conserved to discretisation accuracy at this step (h = 5 ms)
        assert max(abs(v - e[0]) for v in e) < 1e-2 * abs(e[0])


def test_double_pendulum_plot_and_animation(tmp_path):
    gif, png = tmp_path / "dp.gif", tmp_path / "dp.png"
    p = run([script("double_pendulum"), "--T", "1", "--n", "100", "--animate", str(gif), "--plot", str(png)])
    assert p.returncode == 0, p.stderr
    assert "status: ok" in p.stdout
    assert gif.read_bytes()[:4] == b"GIF8" and png.stat().st_size > 10_000


MECH_BAD = [
    ("double_pendulum", ["--T", "0"], "T must be positive"),
    ("double_pendulum", ["--T", "-2"], "T must be positive"),
    ("double_pendulum", ["--n", "1"], "n must be an integer >= 2"),
    ("double_pendulum", ["--m1", "0"], "mass 1 must be positive"),
    ("double_pendulum", ["--m2", "-1"], "mass 2 must be positive"),
    ("double_pendulum", ["--l1", "0"], "length 1 must be positive"),
    ("double_pendulum", ["--l2", "nan"], "length 2 must be finite"),
    ("double_pendulum", ["--theta1", "nan"], "must be finite"),
    ("double_pendulum", ["--omega2", "inf"], "must be finite"),
    ("double_pendulum", ["--g", "nan"], "g must be finite"),
    ("double_pendulum", ["--animate", "x.avi"], ".gif or .mp4"),
    ("double_pendulum", ["--scheme", "euler"], "invalid choice"),
    ("n_link_pendulum", ["--links", "0"], "links must be an integer >= 1"),
    ("n_link_pendulum", ["--links", "1000"], "at most 170 links"),      # ran silently for > 300 s
    ("stiff_spring_pendulum", ["--ratio", "0"], "ratio must be positive"),
    ("stiff_spring_pendulum", ["--mass", "-1"], "mass must be positive"),
    ("thrown_ball", ["--T", "0"], "T must be positive"),
    ("thrown_ball", ["--mass", "0"], "mass must be positive"),
    # values that are finite but overflow, non-physical lengths, Ipopt options that Ipopt would refuse
    ("double_pendulum", ["--omega1", "1e300"], "overflows"),
    ("double_pendulum", ["--method", "rk4", "--omega2", "1e300"], "overflows"),
    ("stiff_spring_pendulum", ["--stretch", "-2"], "must be positive"),
    ("double_pendulum", ["--max-iter", "-1"], "--max-iter must be at least 1"),
    ("double_pendulum", ["--max-iter", "0"], "--max-iter must be at least 1"),
    ("double_pendulum", ["--n", "1000000000"], "GB of memory"),          # refused at once, not after minutes
    ("n_link_pendulum", ["--links", "3", "--theta", "1e300"], "too large"),   # Ipopt diverged (exit 1)
    ("thrown_ball", ["--distance", "1e300"], "too large"),                # NaN in Ipopt (exit 1)
]


def test_collision_impulse_refuses_a_corner_outside_the_body():
    p = run([script("collision_impulse"), "--corner", "5", "5", "--json"])
    assert p.returncode == 2 and p.stdout == ""
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "outside the 2 x 1 body" in lines[0]


@pytest.mark.parametrize("name,args,needle", MECH_BAD)
def test_mechanics_scripts_refuse_bad_input(tmp_path, name, args, needle):
    assert_refused(tmp_path, name, args, needle)


def assert_refused(tmp_path, name, args, needle):
    """Exit 2, nothing on stdout, one stderr line naming the problem, earlier output untouched."""
    out = tmp_path / "keep.png"
    out.write_bytes(b"earlier output")
    p = run([script(name), *args, "--json", "--plot", str(out)])
    assert p.returncode == 2, p.stderr
    assert p.stdout == ""
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0] and "Traceback" not in p.stderr
    assert out.read_bytes() == b"earlier output"


#: Runs a problem script with the contact march disabled, so that an Ipopt budget can make it fail.
NO_MARCH = ("import runpy, sys; import castrajectory.solve.contact.strategy as s; "
            "s.discrete_march = lambda *a, **k: None; sys.argv = sys.argv[1:]; "
            "runpy.run_path(sys.argv[0], run_name='__main__')")


@pytest.mark.parametrize("name,args", [
    ("double_pendulum", ["--T", "5", "--n", "400", "--max-iter", "1"]),
    ("rectangle_drop", ["--T", "1", "--n", "300", "--max-iter", "2"]),
])
def test_mechanics_solver_failure_exits_1_and_writes_nothing(tmp_path, name, args):
    out = tmp_path / "keep.png"
    out.write_bytes(b"earlier output")
    # the contact scene solves its march without Ipopt: its failure is made by disabling the march
    head = ["-c", NO_MARCH] if name == "rectangle_drop" else []
    p = run([*head, script(name), *args, "--json", "--plot", str(out)])
    assert p.returncode == 1, p.stderr
    assert json.loads(p.stdout)["status"] != "ok"
    assert out.read_bytes() == b"earlier output"


def test_stiff_spring_whole_is_stable_where_rk4_fails():
    """Stiffness ratio 1e6, h ω ≈ 16: midpoint (whole trajectory) stays bounded, explicit RK4 blows up."""
    p = run([script("stiff_spring_pendulum"), "--ratio", "1e6", "--T", "1", "--n", "200", "--json"])
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    e = d["energy"]
    assert max(abs(v - e[0]) for v in e) < 1e-3 * abs(e[0])
    assert all(abs(r - 1.0) < 1e-2 for r, _ in d["q"])  # the spring stays near its rest length
    p = run([script("stiff_spring_pendulum"), "--ratio", "1e6", "--T", "1", "--n", "200", "--method", "rk4"])
    assert p.returncode == 1 and "non-finite" in p.stderr


@pytest.mark.parametrize("scheme", ["midpoint", "trapezoid", "galerkin4"])
def test_thrown_ball_matches_parabola(scheme):
    p = run([script("thrown_ball"), "--scheme", scheme, "--n", "50", "--json"])
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["parabola_error"] < 1e-9 and d["launch_velocity_error"] < 1e-8
    assert d["q"][0] == [0.0, 0.0] and d["q"][-1] == [10.0, 2.0]


def test_n_link_pendulum_runs():
    p = run([script("n_link_pendulum"), "--links", "3", "--T", "1", "--n", "200", "--json"])
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["links"] == 3 and len(d["q"][0]) == 3 and d["status"] == "ok"


# ----------------------------------------------------------------------------- contact scenes
def test_bouncing_ball_json_keys_and_oracle():
    p = run([script("bouncing_ball"), "--n", "600", "--json"])
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    for key in ("status", "t", "q", "mu", "apex_heights", "energy", "complementarity_residual"):
        assert key in d
    assert d["status"] == "ok" and len(d["t"]) == len(d["q"]) == len(d["mu"]) == 601
    assert isinstance(d["q"][0], float)  # heights, not rows
    # e = 1: every apex is H, every impact time the analytic one
    assert max(abs(a - 1.0) for a in d["apex_heights"]) < 1e-6
    assert max(abs(a - b) for a, b in zip(d["impact_times"], d["impact_times_exact"])) < 1e-6


def test_rectangle_drop_json_impacts_match_the_corner_law(tmp_path):
    gif, png = tmp_path / "r.gif", tmp_path / "r.png"
    p = run([script("rectangle_drop"), "--T", "1.2", "--n", "400", "--json", "--plot", str(png),
             "--animate", str(gif)])
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    for key in ("status", "t", "q", "mu", "mass", "width", "height", "restitution", "impacts"):
        assert key in d
    assert len(d["q"][0]) == 3 and len(d["mu"][0]) == 4
    assert d["impacts"], "the default drop hits the ground within 1.2 s"
    for imp in d["impacts"]:
        assert set(("t", "corner", "angle", "v_before", "v_after", "mu")) <= set(imp)
        assert max(abs(a - b) for a, b in zip(imp["v_after"], imp["v_after_exact"])) < 1e-7
    assert gif.read_bytes()[:4] == b"GIF8" and png.stat().st_size > 10_000


def test_flat_landing_is_one_simultaneous_impact():
    """θ₀ = 0: both lower corners hit at once; e = 1 sends the body back up with v_y = V, ω = 0."""
    p = run([script("rectangle_drop"), "--angle", "0", "--vx", "0", "--omega", "0", "--y", "1.5",
             "--T", "0.6", "--n", "400", "--json"])
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    first = [i for i in d["impacts"] if i["simultaneous"]]
    assert len(first) == 2 and {tuple(i["corner"]) for i in first} == {(-1.0, -0.5), (1.0, -0.5)}
    V = math.sqrt(2 * 9.81 * 1.0)  # centroid falls 1.5 - 0.5 = 1 m
    for imp in first:
        assert abs(imp["v_after"][1] - V) < 1e-6 and abs(imp["v_after"][2]) < 1e-8
        assert imp["law_error"] < 1e-7 and abs(imp["mu"] - imp["mu_exact"]) < 1e-6


def test_bowl_json_keys():
    p = run([script("bowl"), "--T", "1", "--n", "400", "--json"])
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    for key in ("status", "t", "q", "gap", "mu", "energy"):
        assert key in d
    assert min(d["gap"]) > -1e-9
    assert max(abs(e - d["energy"][0]) for e in d["energy"]) < 1e-5 * abs(d["energy"][0])


def test_bowl3d_json_keys_and_animation(tmp_path):
    """The 3-D bowl from the command line: its JSON keys, a no-penetration and energy reading, and a
    3-D animation with as many frames as asked for."""
    gif = tmp_path / "bowl3d.gif"
    p = run([script("bowl3d"), "--T", "0.6", "--n", "240", "--json", "--animate", str(gif)])
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    for key in ("status", "t", "position", "quaternion", "gap", "mu", "energy", "impacts"):
        assert key in d
    K = len(d["t"])
    assert len(d["position"]) == K and len(d["position"][0]) == 3
    assert len(d["quaternion"]) == K and len(d["quaternion"][0]) == 4
    assert len(d["mu"]) == K and len(d["mu"][0]) == 8          # nodes x corners
    assert min(d["gap"]) > -1e-12 and len(d["impacts"]) >= 1
    assert max(abs(e - d["energy"][0]) for e in d["energy"]) < 1e-6 * abs(d["energy"][0])
    from PIL import Image
    assert Image.open(gif).n_frames >= 30


CONTACT_BAD = [
    ("bouncing_ball", ["--height", "-1"], "inside the ground"),
    ("bouncing_ball", ["--restitution", "1.5"], "restitution must be between 0 and 1"),
    ("bouncing_ball", ["--restitution", "nan"], "restitution must be finite"),
    ("bouncing_ball", ["--mass", "0"], "mass must be positive"),
    ("bouncing_ball", ["--T", "0"], "T must be positive"),
    ("bouncing_ball", ["--n", "1"], "n must be an integer >= 2"),
    ("bouncing_ball", ["--g", "-1"], "g must be >= 0"),
    ("rectangle_drop", ["--y", "0.1"], "penetrates contact"),
    ("rectangle_drop", ["--width", "0"], "width must be positive"),
    ("rectangle_drop", ["--restitution", "-0.1"], "restitution must be between 0 and 1"),
    ("rectangle_drop", ["--mass", "-2"], "mass must be positive"),
    ("bowl", ["--radius", "0"], "radius must be positive"),
    ("bowl", ["--y", "-1"], "penetrates contact"),
    ("bowl3d", ["--radius", "0"], "radius must be positive"),
    ("bowl3d", ["--position", "0", "0", "0"], "penetrates contact"),
    ("bowl3d", ["--axis", "0", "0", "0"], "axis must not be zero"),
    ("bowl3d", ["--size", "0.4", "-1", "0.2"], "box edge 2 must be positive"),
    ("bowl3d", ["--omega", "1", "nan", "0"], "omega 2 must be finite"),
    ("bouncing_ball", ["--velocity", "1e300"], "overflows"),
    ("bouncing_ball", ["--n", "1000000000"], "GB of memory"),
    ("bowl3d", ["--omega", "1e300", "0", "0"], "overflows"),
]


@pytest.mark.parametrize("name,args,needle", CONTACT_BAD)
def test_contact_scripts_refuse_bad_input(tmp_path, name, args, needle):
    assert_refused(tmp_path, name, args, needle)


def test_resting_ball_reports_m_g_h_per_step():
    """Resting contact: the nodes stay on the ground and every settled step carries m g h."""
    p = run([script("bouncing_ball"), "--height", "0", "--T", "1", "--n", "200", "--json"])
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["resting_nodes"] >= 190
    assert d["resting_impulse_error"] < 1e-6 and d["max_height_at_rest"] < 1e-9


#: The contact scenes, each with --scheme (every registered scheme, default midpoint).
CONTACT_SCENES = ("bouncing_ball", "rectangle_drop", "bowl", "bowl3d", "newtons_cradle", "sliding_block",
                  "pushed_box", "rolling_ball", "rimless_wheel")


def _rectangle_first_impact(y=2.0, angle=0.3, omega=1.0, w=2.0, h=1.0, g=9.81):
    """Free flight of the w x h rectangle from rest in y: when its lower-left corner, height
    y - g t²/2 - (w/2) sin θ - (h/2) cos θ with θ = angle + omega t, first reaches y = 0 (bisection)."""
    def gap(t):
        th = angle + omega * t
        return y - g * t * t / 2 - w / 2 * math.sin(th) - h / 2 * math.cos(th)
    lo, hi = 0.0, 0.8
    for _ in range(200):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if gap(mid) > 0 else (lo, mid)
    return (lo + hi) / 2


@pytest.mark.parametrize("name,argv", [
    ("bouncing_ball", ["--restitution", "0.7", "--T", "2", "--n", "100"]),
    ("rectangle_drop", ["--y", "2", "--angle", "0.3", "--omega", "1", "--vy", "0", "--T", "1.2", "--n", "100"]),
    ("newtons_cradle", ["--balls", "3", "--T", "1", "--n", "100"]),
    ("newtons_cradle", ["--balls", "3", "--law", "simultaneous", "--n", "100"]),
    ("sliding_block", ["--n", "100"]),
    ("sliding_block", ["--incline", "0.3", "--mu", "0.1", "--v0", "0", "--n", "100"]),
])
def test_contact_scenes_with_a_fourth_order_scheme(name, argv):
    """--scheme galerkin4 on the contact scenes, against each scene's own oracle (measured, galerkin4):

    * bouncing ball, e = 0.7, N = 100: every flight is a parabola, which every scheme follows exactly, so
      the 4 impact times, speeds, impulses and apexes match the closed form to rounding (measured 4.4e-16 s,
      8.9e-16 m/s, 1.8e-15, 2.8e-16 m);
    * rectangle drop, N = 100, T = 1.2: both impacts against the closed-form corner law (4.8e-13), the first
      impact's time against the free flight's root (5e-16 s; θ linear and the centre quadratic in t are
      exact), energy with e = 1 (1.7e-14 relative);
    * Newton's cradle, 3 touching balls, N = 100: the first impact's time against the elliptic integral and
      the speeds after it against the law (sequential, T = 1: 3.1e-12 s, 1.6e-10 m/s; simultaneous: 0 s,
      1.1e-10 m/s; midpoint: 1e-5 s, 1e-6 m/s);
    * sliding block, N = 100: on the flat floor the path within 5.6e-16 m of the closed form (the stop timed by
      its step's sub-node, as with midpoint) and at rest from the node after the exact stop; sliding down the
      whole time (tan 0.3 > 0.1) a parabola, within 2.4e-15 m.
    """
    p = run([script(name), *argv, "--scheme", "galerkin4", "--json"])
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["status"] == "ok" and d["scheme"] == "galerkin4"
    if name == "bouncing_ball":
        assert len(d["impact_times"]) == len(d["impact_times_exact"]) == 4
        for key, tol in (("impact_times", 1e-13), ("impact_speeds", 1e-13), ("impulses", 1e-13),
                         ("apex_heights", 1e-13)):
            assert max(abs(a - b) for a, b in zip(d[key], d[key + "_exact"])) < tol, key
    elif name == "rectangle_drop":
        assert len(d["impacts"]) == 2 and not any(i["caught"] for i in d["impacts"])
        assert d["impact_law_error"] < 1e-11
        assert abs(d["impacts"][0]["t"] - _rectangle_first_impact()) < 1e-13
        e = d["energy"]
        assert max(abs(x - e[0]) for x in e) < 1e-12 * abs(e[0])
    elif name == "newtons_cradle":
        assert abs(d["first_impact_time"] - d["first_impact_time_exact"]) < 1e-10
        assert d["first_impact_contacts"] == ["1-2", "2-3"]
        assert d["speeds_error"] < 1e-8
    elif "--incline" in argv:
        assert d["stop_time"] is None and d["stop_time_exact"] is None and d["error_vs_exact"] < 1e-13
    else:
        h = 1.0 / 100
        assert d["error_vs_exact"] < 1e-13 and abs(d["stop_time"] - d["stop_time_exact"]) <= 1e-12
        assert 0 <= d["stop_node_time"] - d["stop_time_exact"] <= 3 * h


@pytest.mark.parametrize("n", [50, 100])
def test_cradle_galerkin4_impact_on_a_node(n):
    """The default horizon T = 2 t1 puts the first impact on node N/2; galerkin4 meets it there to rounding
    (0 s), and the sequential law sends the last ball off alone, (0, 0, V): measured 2.6e-9 and 1.7e-10 m/s
    at N = 50 and 100.  (The cascade at the node had left the stopped balls 2.3e-10 inside each other, below
    the march's 1e-12 tolerance for a cascade's end, and the simultaneous law's (−1/3, 2/3, 2/3) V was kept
    and reported ok; the stopped balls now count as touching within 1e-9, and a cascade that cannot be
    applied fails the step instead.)"""
    p = run([script("newtons_cradle"), "--balls", "3", "--n", str(n), "--scheme", "galerkin4", "--json"])
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["first_impact_time"] == pytest.approx(d["first_impact_time_exact"], abs=1e-12)
    assert d["speeds_error"] < 3e-7


def test_contact_scenes_offer_every_scheme(capsys):
    """Every contact scene's --scheme takes each registered scheme and refuses any other name: exit 2,
    one line on stderr, nothing on stdout (in-process: argparse refuses before any solve)."""
    import importlib

    import castrajectory

    for name in CONTACT_SCENES:
        mod = importlib.import_module(f"castrajectory.problems.{name}")
        action = next(a for a in mod.parser()._actions if "--scheme" in a.option_strings)
        assert list(action.choices) == list(castrajectory.schemes()) and action.default == "midpoint", name
        with pytest.raises(SystemExit) as exc:
            mod.main(["--scheme", "nonsense", "--json"])
        assert exc.value.code == 2, name
        out, err = capsys.readouterr()
        lines = err.strip().splitlines()
        assert out == "" and len(lines) == 1 and "invalid choice: 'nonsense'" in lines[0], (name, err)
        assert "Traceback" not in err


def test_scheme_nonsense_exits_2_from_the_command_line():
    p = run([script("bouncing_ball"), "--scheme", "nonsense", "--json"])
    assert p.returncode == 2 and p.stdout == ""
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "argument --scheme: invalid choice: 'nonsense'" in lines[0]


def test_contact_battery_runs_and_checks_against_the_oracle(tmp_path):
    """The battery from a clone: three ball scenes (with the refinement twin of none), each solved, each
    checked against the event-driven reference; the CSV and the summary are written."""
    p = run([str(ROOT / "scripts" / "contact_battery.py"), "--count", "3", "--family", "ball", "--timeout", "60",
             "--out", str(tmp_path)])
    assert p.returncode == 0, p.stderr
    import csv
    rows = list(csv.DictReader((tmp_path / "battery.csv").open()))
    assert len(rows) == 1 and rows[0]["family"] == "ball"   # every third scene is a ball
    assert rows[0]["solved"] == "True"
    # the ball's flight is exact on the grid: impact times to rounding (measured 1e-14 s)
    assert float(rows[0]["impact_time_error"]) <= 1e-9
    assert "solved with every residual check" in (tmp_path / "summary.md").read_text()
    p = run([str(ROOT / "scripts" / "contact_battery.py"), "--count", "0"])
    assert p.returncode == 2 and p.stderr.count("\n") == 1


# ----------------------------------------------------------------------------- interrupts and output files
def _interrupt_after(args, seconds: float, cwd=None):
    """Start ``python args``, send a real SIGINT after ``seconds``; (returncode, stdout, stderr, seconds
    from the signal to the exit)."""
    import signal
    import time
    # the child gets SIGINT's default disposition, as under a terminal (a test runner started as a
    # background job passes SIGINT on ignored, and Python then keeps ignoring it)
    p = subprocess.Popen([sys.executable, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         env=ENV, cwd=cwd, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    time.sleep(seconds)
    assert p.poll() is None, "the run ended before the interrupt: pick a longer one"
    t0 = time.perf_counter()
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=120)
    return p.returncode, out, err, time.perf_counter() - t0


def test_sigint_stops_a_solve_at_once(tmp_path):
    """Ctrl-C during Ipopt (a 12-link pendulum that takes ~9 s): exit 130 within seconds, one line, no
    traceback, no retry of the interrupted solve, and the earlier picture untouched."""
    keep = tmp_path / "keep.png"
    keep.write_bytes(b"earlier output")
    rc, out, err, dt = _interrupt_after([script("n_link_pendulum"), "--links", "12", "--n", "4000", "--T", "10",
                                         "--plot", str(keep)], 3.0)
    assert rc == 130, err
    assert err.strip().splitlines() == ["n_link_pendulum.py: interrupted"] and out == ""
    assert dt < 5.0          # stopped between Ipopt iterations (measured 0.08 s), not after more attempts
    assert keep.read_bytes() == b"earlier output"
    assert [f.name for f in tmp_path.iterdir()] == ["keep.png"]       # no temporary file left


def test_sigint_stops_the_report_and_keeps_earlier_files(tmp_path):
    """Ctrl-C during `castrajectory report`: exit 130 with one line; the summary of an earlier report
    (written last) is as it was, no temporary file is left, and no interrupt is recorded as a result."""
    out_dir = tmp_path / "report"
    out_dir.mkdir()
    (out_dir / "summary.md").write_text("an earlier report\n")
    rc, out, err, dt = _interrupt_after(["-m", "castrajectory.cli", "report", "--out", str(out_dir), "--quick"], 6.0)
    assert rc == 130, err
    assert err.strip().splitlines() == ["castrajectory report: interrupted"]
    assert (out_dir / "summary.md").read_text() == "an earlier report\n"
    assert not [f for f in out_dir.iterdir() if ".tmp" in f.name]
    for csv_file in out_dir.glob("*.csv"):
        assert "interrupt" not in csv_file.read_text().lower()


def test_output_paths_are_refused_before_the_solve(tmp_path):
    """A --plot in a missing folder, or naming a folder, or without an extension: exit 2 and one line,
    before any solve (N = 10⁸ would take minutes), and nothing created."""
    for path, needle in [(tmp_path / "missing" / "x.png", "does not exist"), (tmp_path, "is a folder"),
                         (tmp_path / "noext", "needs a file extension"), ("/proc/x.png", "cannot write files")]:
        p = run([script("double_pendulum"), "--n", "100000000", "--plot", str(path)])
        assert p.returncode == 2, p.stderr
        lines = p.stderr.strip().splitlines()
        assert len(lines) == 1 and needle in lines[0] and "Traceback" not in p.stderr
    assert not (tmp_path / "missing").exists() and not (tmp_path / "noext").exists()


def test_a_picture_format_nobody_writes_is_refused_before_the_solve(tmp_path):
    """A --plot path whose format matplotlib does not know: exit 2 and one line before any solve (it was
    solved, printed, then exit 3), the earlier file left as it was."""
    bad = tmp_path / "plot.unknownformat"
    bad.write_bytes(b"earlier output")
    p = run([script("double_pendulum"), "--T", "1", "--n", "100", "--json", "--plot", str(bad)])
    assert p.returncode == 2, p.stderr
    assert p.stdout == ""
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "no picture format .unknownformat" in lines[0]
    assert bad.read_bytes() == b"earlier output"
    assert sorted(f.name for f in tmp_path.iterdir()) == ["plot.unknownformat"]


def test_max_iter_caps_the_whole_run():
    """--max-iter is the Ipopt budget of the whole run, every level and window included (it was applied
    per sub-solve: 299 solves, 1374 iterations for --max-iter 5)."""
    p = run([script("double_pendulum"), "--T", "10", "--scheme", "midpoint", "--n", "2000", "--max-iter", "5", "--json"])
    assert p.returncode == 1
    d = json.loads(p.stdout)
    assert d["status"] != "ok" and 1 <= d["iterations"] <= 5


def test_an_unresolved_elastic_run_is_not_silent():
    """The elastic ball over T = 1000 s on 10 steps (h = 100 s against 0.9 s flights): every arrival is
    caught and the energy goes; the run says so in the JSON's `warnings` and in the summary.  A resolved
    run has an empty list, and every scene's JSON carries the key."""
    p = run([script("bouncing_ball"), "--T", "1000", "--n", "10", "--json"])
    assert p.returncode == 0, p.stderr
    w = json.loads(p.stdout)["warnings"]
    assert any("lost 100 % of the energy" in x for x in w)
    p = run([script("bouncing_ball"), "--T", "1000", "--n", "10"])
    assert "warning: an elastic contact (e = 1) lost" in p.stdout
    for name, args in [("bouncing_ball", []), ("double_pendulum", ["--T", "1", "--n", "100"])]:
        p = run([script(name), *args, "--json"])
        assert p.returncode == 0 and json.loads(p.stdout)["warnings"] == []


def test_a_step_longer_than_the_motion_warns():
    """The double pendulum on 100 steps of 10⁴ s (its linearised 1/ω is 0.42 s at the start) solves and
    said nothing; it now warns, and its estimated error is its whole excursion: not ok (issue 41), exit 1.
    A resolved run (h ω = 0.02) does not warn."""
    p = run([script("double_pendulum"), "--T", "1e6", "--n", "100", "--scheme", "midpoint", "--json"])
    assert p.returncode == 1, p.stderr
    out = json.loads(p.stdout)
    assert out["status"] == "Not_Resolved" and out["error_estimate"]["relative"] >= 0.5
    assert any("longer than the motion's fastest time scale" in x and "0.415 s" in x for x in out["warnings"])
    p = run([script("double_pendulum"), "--T", "1", "--n", "200", "--json"])
    assert json.loads(p.stdout)["warnings"] == []


# ----------------------------------------------------------------------------- forces and time (#22)
def test_damped_oscillator_json_and_plot(tmp_path):
    out = tmp_path / "osc.png"
    p = run([script("damped_oscillator"), "--scheme", "galerkin6", "--n", "100", "--json", "--plot", str(out)])
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    for k in ("t", "q", "energy", "work", "error_vs_exact", "error_estimate", "regime"):
        assert k in d
    assert d["error_vs_exact"] < 1e-8                  # measured 2.7e-10 (galerkin6, N = 100, T = 10)
    e, w = d["energy"], d["work"]
    assert max(abs(e[i] - e[0] - w[i]) for i in range(len(e))) < 1e-8
    assert out.stat().st_size > 10_000


@pytest.mark.parametrize("args", [["--damping", "0", "--drive-frequency", "2"],          # undamped resonance
                                  ["--damping", "4"], ["--damping", "10", "--drive-amplitude", "0"]])
def test_damped_oscillator_regimes(args):
    p = run([script("damped_oscillator"), *args, "--scheme", "galerkin4", "--json"])
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["error_vs_exact"] < 1e-5, d["regime"]      # galerkin4, N = 200: 3e-8 to 4e-7 measured


def test_driven_pendulum_poincare_and_plot(tmp_path):
    out = tmp_path / "attractor.png"
    p = run([script("driven_pendulum"), "--T", "60", "--n", "1200", "--json", "--plot", str(out)])
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    period = 2 * math.pi / (2.0 / 3.0)
    assert len(d["poincare_t"]) == int(60 // period) + 1 and abs(d["poincare_t"][1] - period) < 1e-12
    # the first section point is the initial state
    assert abs(d["poincare_theta"][0]) < 1e-12 and abs(d["poincare_omega"][0]) < 1e-12
    assert out.stat().st_size > 10_000


@pytest.mark.parametrize("frequency,up", [("100", True), ("30", False)])
def test_kapitza_pendulum_json(frequency, up):
    p = run([script("kapitza_pendulum"), "--frequency", frequency, "--json"])
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["inverted_stable_predicted"] == up and d["stayed_up"] == up


@pytest.mark.parametrize("name,args,needle", [
    ("damped_oscillator", ["--damping", "-0.5"], "--damping must not be negative"),
    ("damped_oscillator", ["--mass", "0"], "--mass must be positive"),
    ("damped_oscillator", ["--scheme", "galerkin5"], "invalid choice"),
    ("driven_pendulum", ["--gamma", "-1"], "--gamma must not be negative"),
    ("driven_pendulum", ["--drive-frequency", "0"], "--drive-frequency must be positive"),
    ("kapitza_pendulum", ["--length", "-1"], "--length must be positive"),
    ("kapitza_pendulum", ["--frequency", "nan"], "--frequency"),
])
def test_forced_scenes_refuse_bad_input(tmp_path, name, args, needle):
    assert_refused(tmp_path, name, args, needle)


def test_rimless_wheel_script_against_its_oracle():
    """problems/rimless_wheel.py: two touchdowns in 1.5 s, each sticking (a tangential impulse inside the cone),
    the rates after them within 2e-4 of the oracle's (measured 1.2e-6 and 2.4e-6 relative at N = 300), and the
    limit cycle's rate for κ = 0.01 (McGeer's 1.0949 for κ → 0)."""
    p = run([script("rimless_wheel"), "--T", "1.5", "--n", "300", "--json"])
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert len(d["step_rates"]) == 2
    np.testing.assert_allclose(d["step_rates"], d["step_rates_exact"], rtol=2e-4)
    assert d["limit_cycle_rate"] == pytest.approx(1.0984620907773177, abs=1e-12)
    for mu_n, mu_t in d["tip_impulses"]:
        assert mu_n > 0 and abs(mu_t) < 1.0 * mu_n


@pytest.mark.parametrize("name,extra", [
    ("rectangle_drop", ["--friction", "0.5", "--restitution", "0.5", "--T", "1.0", "--n", "300"]),
    ("bowl", ["--friction", "0.4", "--restitution", "0.8", "--T", "1.0", "--n", "400"]),
])
def test_friction_on_the_rectangle_scenes(name, extra):
    """--friction on the rectangle drop and the bowl: every bounce loses kinetic energy (measured at least 0.68
    and 0.064 of it), the tangential impulses lie in the cone, and each bounce is the frictional law applied to
    its own arrival (measured 8e-12 and 3.4e-10 m/s)."""
    p = run([script(name), *extra, "--json"])
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["friction"] > 0 and d["impact_energy_gain"] is not None
    assert d["impact_energy_gain"] <= 1e-12
    assert d["friction_cone"] <= 1e-12
    assert d["frictional_law_error"] <= 1e-8


@pytest.mark.slow       # (9 s; the same physics in the default run: test_friction_3d.py's box in a 3-D bowl)
def test_bowl3d_with_friction():
    """--friction on the box in the 3-D bowl (μ = 0.5, e = 0.5): friction on each corner's tangent plane, every
    bounce loses kinetic energy (measured at least 0.71 of it), the tangential impulses inside the
    circular cone, each bounce the plane's frictional law on its own arrival (measured 9.7e-12 m/s)."""
    p = run([script("bowl3d"), "--friction", "0.5", "--restitution", "0.5", "--T", "0.7", "--n", "200", "--json"])
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["impact_energy_gain"] <= 1e-12 and d["friction_cone"] <= 1e-12
    assert d["frictional_law_error"] <= 1e-9


def test_rolling_sphere_on_so3():
    """rolling_ball.py --body sphere3d: the sphere on SO(3) rolls at 5 v0/7 (measured 4.9e-5 m/s at N = 200,
    second order: the quaternion's midpoint rule), from 2 v0/(7 μ g) (read from the impulses: measured 1.6e-5 s,
    the planar sphere's 3e-17; its nodes within two steps), its spin about the
    vertical kept (10 rad/s to 1e-12) and its quaternion on the unit sphere."""
    p = run([script("rolling_ball"), "--body", "sphere3d", "--top-spin", "10", "--n", "200", "--json"])
    assert p.returncode == 0, p.stderr
    d = json.loads(p.stdout)
    assert d["error_vs_exact"] < 1e-3
    assert abs(d["rolling_time"] - d["rolling_time_exact"]) <= 1e-3
    assert 0 <= d["rolling_node_time"] - d["rolling_time_exact"] <= 2 * 1.0 / 200
    assert abs(d["top_spin_final"] - 10.0) <= 1e-10 and d["quaternion_norm_error"] <= 1e-13


def test_hopper_runs_headless_and_says_it_failed(tmp_path):
    """problems/hopper.py at a small size with a run-wide cap of 40 Ipopt iterations: it
    stops there and says so (exit 1, the JSON's status not ok, the cap kept, no picture written), and refuses bad
    input before any solve (exit 2, one line).  Measured: 2.2 s."""
    out = tmp_path / "hopper.png"
    p = run([script("hopper"), "--n", "20", "--max-iter", "40", "--json", "--plot", str(out)])
    assert p.returncode == 1, p.stderr
    d = json.loads(p.stdout)
    assert d["status"] != "ok" and d["iterations"] <= 40 and not out.exists()
    assert "failed" in p.stderr and "Traceback" not in p.stderr
    p = run([script("hopper"), "--goal", "0.05"])
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1
