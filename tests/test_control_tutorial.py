"""Every command of docs/optimal-control.md runs (in a scratch folder holding a copy of examples/), and the
tutorial's code is the example's, line for line."""
import os
import re

import pytest
from helpers import run_tutorial_command

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DOC = os.path.join(ROOT, "docs", "optimal-control.md")


def blocks(lang):
    return re.findall(rf"```{lang}\n(.*?)```", open(DOC).read(), flags=re.S)


COMMANDS = [line for b in blocks("bash") for line in b.splitlines() if line.strip() and not line.startswith("#")]


@pytest.mark.parametrize("command", COMMANDS)
def test_tutorial_command_runs(command, tmp_path):
    run_tutorial_command(command, tmp_path, ROOT)


def test_the_tutorial_code_is_the_example():
    """Sections 1-5 build the swing-up of examples/pendulum_swingup.py (section 6's recipes are tested by
    tests/test_contact_policies.py)."""
    example = open(os.path.join(ROOT, "examples", "pendulum_swingup.py")).read()
    tutorial = open(DOC).read().split("\n## 6.")[0]
    for code in re.findall(r"```python\n(.*?)```", tutorial, flags=re.S):
        for line in code.strip().splitlines():
            assert line.strip() in example, line
