"""Fixtures shared by several test files."""
import os
import subprocess
import sys

import pytest


@pytest.fixture(scope="session")
def quick_report(tmp_path_factory):
    """One `castrajectory report --quick` for every test that reads a report (about 40 s): its folder.

    Under pytest-xdist (the README's ``-n auto``) a session fixture runs once per worker: the workers share this
    run's temporary root, and the first to get its lock writes the report there for all (xdist's documented
    pattern, with ``fcntl`` for the lock)."""
    if not os.environ.get("PYTEST_XDIST_WORKER"):
        return _write_quick_report(tmp_path_factory.mktemp("report") / "rep")
    import fcntl
    root = tmp_path_factory.getbasetemp().parent            # (this run's, shared by its workers)
    out, done = root / "quick_report" / "rep", root / "quick_report" / "written"
    with open(root / "quick_report.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not done.exists():
            _write_quick_report(out)
            done.write_text("ok")
    return out


def _write_quick_report(out):
    p = subprocess.run([sys.executable, "-m", "castrajectory.cli", "report", "--out", str(out), "--quick", "--quiet"],
                       capture_output=True, text=True, env={**os.environ, "MPLBACKEND": "Agg"}, timeout=900)
    assert p.returncode == 0, p.stdout + p.stderr
    return out
