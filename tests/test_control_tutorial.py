"""Every command of docs/optimal-control.md runs (in a scratch folder holding a copy of examples/), and the
tutorial's code is the example's, line for line."""
import os
import re
import shlex
import shutil
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DOC = os.path.join(ROOT, "docs", "optimal-control.md")


def blocks(lang):
    return re.findall(rf"```{lang}\n(.*?)```", open(DOC).read(), flags=re.S)


COMMANDS = [line for b in blocks("bash") for line in b.splitlines() if line.strip() and not line.startswith("#")]


@pytest.mark.parametrize("command", COMMANDS)
def test_tutorial_command_runs(command, tmp_path):
    shutil.copytree(os.path.join(ROOT, "examples"), tmp_path / "examples")
    argv = shlex.split(command)
    assert argv[0] == "castrajectory"
    p = subprocess.run([sys.executable, "-m", "castrajectory.cli", *argv[1:]], capture_output=True, text=True,
                       cwd=tmp_path, env={**os.environ, "MPLBACKEND": "Agg"}, timeout=600)
    assert p.returncode == 0, p.stderr
    for token in argv:
        if token.endswith((".png", ".gif")):
            assert (tmp_path / token).stat().st_size > 0


def test_the_tutorial_code_is_the_example():
    example = open(os.path.join(ROOT, "examples", "pendulum_swingup.py")).read()
    for code in blocks("python"):
        for line in code.strip().splitlines():
            assert line.strip() in example, line
