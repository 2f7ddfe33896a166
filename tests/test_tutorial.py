"""Every command of docs/your-own-system.md runs (in a scratch folder holding a copy of examples/),
and the tutorial's system file is the example's."""
import os
import re
import shlex
import shutil
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DOC = os.path.join(ROOT, "docs", "your-own-system.md")


def blocks(lang):
    text = open(DOC).read()
    return re.findall(rf"```{lang}\n(.*?)```", text, flags=re.S)


COMMANDS = [line for b in blocks("bash") for line in b.splitlines() if line.strip() and not line.startswith("#")]


@pytest.mark.parametrize("command", COMMANDS)
def test_tutorial_command_runs(command, tmp_path):
    if "derive" in command:
        pytest.importorskip("sympy")
    shutil.copytree(os.path.join(ROOT, "examples"), tmp_path / "examples")
    argv = shlex.split(command)
    assert argv[0] == "castrajectory"
    p = subprocess.run([sys.executable, "-m", "castrajectory.cli", *argv[1:]], capture_output=True, text=True,
                       cwd=tmp_path, env={**os.environ, "MPLBACKEND": "Agg"}, timeout=600)
    assert p.returncode == 0, p.stderr
    for token in argv:
        if token.endswith((".png", ".gif", ".md")):
            assert (tmp_path / token).stat().st_size > 0


def test_the_tutorial_files_are_the_examples():
    """The files the tutorial shows are examples/coupled_pendulums.py and examples/heavy_top.py, statement
    for statement (after their docstrings)."""
    codes = blocks("python")
    assert len(codes) == 2
    for code, name in zip(codes, ("coupled_pendulums", "heavy_top")):
        example = open(os.path.join(ROOT, "examples", f"{name}.py")).read()
        assert example.endswith(code) and example[:len(example) - len(code)].strip().endswith('"""')
