"""The report's sections run in a pool of processes (issue 41: the default report within about 2 minutes on 2
cores): the summary is the same whatever the pool, its sections in the report's order, and a bad ``--jobs`` is
refused before anything runs."""
from __future__ import annotations

import re
import subprocess
import sys

from castrajectory.cli import report
from castrajectory.cli.report import collisions, rigid_bodies


def _body(path):
    """The summary with its run times blanked (seconds, and the headline and last line, which hold the report's)."""
    lines = path.read_text(encoding="utf-8").splitlines()
    return [re.sub(r"\d+(\.\d+)?(e[-+]?\d+)? s\b", "# s", ln) for ln in lines
            if not ln.startswith(("Report (", "What was solved"))]


def test_pooled_sections_write_the_summary_of_one_process(tmp_path, monkeypatch):
    """Two sections, the shorter first in the report's order and started last by the pool: two processes and one
    write the same summary, in the report's order, and both exit 0."""
    monkeypatch.setattr(report, "SECTIONS", [collisions, rigid_bodies])
    monkeypatch.setattr(report, "SECONDS", {rigid_bodies: 10.0})
    one, two = tmp_path / "one", tmp_path / "two"
    assert report.write_report(str(one), "quick", quiet=True, jobs=1) == 0
    assert report.write_report(str(two), "quick", quiet=True, jobs=2) == 0
    a, b = _body(one / "summary.md"), _body(two / "summary.md")
    assert a == b
    text = "\n".join(b)
    assert text.index("## Collisions") < text.index("## Rigid bodies")
    for stem in ("collision_impulse", "dzhanibekov", "heavy_top"):
        assert (two / f"{stem}.json").exists()
    assert "by 2 processes" in (two / "summary.md").read_text(encoding="utf-8")


def test_jobs_below_one_is_refused(tmp_path):
    out = tmp_path / "rep"
    p = subprocess.run([sys.executable, "-m", "castrajectory.cli", "report", "--out", str(out), "--jobs", "0"],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and p.stdout == ""
    assert p.stderr.strip().splitlines() == ["castrajectory report: error: --jobs must be at least 1"]
    assert not out.exists()
