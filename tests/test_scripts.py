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


def test_console_list_run_and_report(tmp_path):
    p = run(["-m", "castrajectory.cli", "list"])
    assert p.returncode == 0 and "droplet" in p.stdout and "droplet_angle" in p.stdout
    p = run(["-m", "castrajectory.cli", "run", "droplet", "--n", "30", "--json"])
    assert p.returncode == 0 and json.loads(p.stdout)["status"] == "ok"
    p = run(["-m", "castrajectory.cli", "run", "nosuchscene"])
    assert p.returncode == 2 and "unknown scene" in p.stderr
    out = tmp_path / "rep"
    p = run(["-m", "castrajectory.cli", "report", "--out", str(out), "--quick"])
    assert p.returncode == 0, p.stderr
    summary = (out / "summary.md").read_text()
    for f in ("droplet_curve.png", "droplet_angle.png", "droplet_convergence.png", "droplet_overhang.png"):
        assert f in summary and (out / f).exists()
    assert (out / "droplet_convergence.csv").read_text().count("\n") > 10


def test_convergence_script_small(tmp_path):
    p = run([str(ROOT / "scripts" / "droplet_convergence.py"), "--n-max", "256", "--out", str(tmp_path)])
    assert p.returncode == 0, p.stderr
    assert "observed orders" in p.stdout
    assert (tmp_path / "droplet_convergence.png").exists()


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
