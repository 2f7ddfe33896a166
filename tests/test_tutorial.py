"""Every command of docs/your-own-system.md runs (in a scratch folder holding a copy of examples/),
and the tutorial's system file is the example's."""
import os
import re

import pytest
from helpers import run_tutorial_command

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
    run_tutorial_command(command, tmp_path, ROOT)


def test_the_tutorial_files_are_the_examples():
    """The files the tutorial shows are examples/coupled_pendulums.py, examples/heavy_top.py,
    examples/rod_chain.py and examples/arm.py, statement for statement (after their docstrings)."""
    codes = blocks("python")
    assert len(codes) == 4
    for code, name in zip(codes, ("coupled_pendulums", "heavy_top", "rod_chain", "arm")):
        example = open(os.path.join(ROOT, "examples", f"{name}.py")).read()
        assert example.endswith(code) and example[:len(example) - len(code)].strip().endswith('"""')
