"""Fixtures shared by several test files."""
import os
import subprocess
import sys

import pytest


@pytest.fixture(scope="session")
def quick_report(tmp_path_factory):
    """One `castrajectory report --quick` for every test that reads a report (about 40 s): its folder."""
    out = tmp_path_factory.mktemp("report") / "rep"
    p = subprocess.run([sys.executable, "-m", "castrajectory.cli", "report", "--out", str(out), "--quick", "--quiet"],
                       capture_output=True, text=True, env={**os.environ, "MPLBACKEND": "Agg"}, timeout=900)
    assert p.returncode == 0, p.stdout + p.stderr
    return out
