"""Issue #26, the drops under gravity beyond the single scene: the refusal of a pendant drop whose fold the
continuation cannot bracket, and the shape-against-Bond study (scripts/droplet_bond_study.py)."""
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from castrajectory.solve import droplet as dl
from castrajectory.validation import InputError

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("args", [["--area", "1e200"], ["--axisymmetric", "--area", "1e80"]])
def test_pendant_beyond_what_can_be_bracketed_exits_2_before_any_solve(tmp_path, args):
    out = tmp_path / "keep.png"
    out.write_bytes(b"earlier output")
    p = subprocess.run([sys.executable, str(ROOT / "problems" / "droplet.py"), "--gravity", "1", "--gamma-sl", "1",
                        "--pendant", *args, "--json", "--plot", str(out)], capture_output=True, text=True,
                       env=dict(os.environ, MPLBACKEND="Agg"), timeout=120)
    assert p.returncode == 2 and p.stdout == ""
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "beyond what the continuation can bracket" in lines[0] and "Traceback" not in p.stderr
    assert out.read_bytes() == b"earlier output"


def test_bracketable_bound_is_checked_before_the_solve():
    """The refusal comes from the API too (no Ipopt run: it raises at once); the bound leaves the
    continuation's step budget room to bisect the fold (measured: log2(Bo/Bo*) + 24 steps)."""
    assert math.log2(dl.MAX_PENDANT_BOND) + 2 * math.log2(1.0 / dl.FOLD_RTOL) <= dl.CONTINUATION_MAX_STEPS + 1
    with pytest.raises(InputError, match="bracket"):
        dl.solve(dl.Droplet(1.0, 1.0, 1.0, 2.0 * dl.MAX_PENDANT_BOND, None, 1.0, True), 40)


def test_bond_study_script_small(tmp_path):
    """scripts/droplet_bond_study.py on Bo = 0.1, 1, 10 (both dims, NLP and oracle): its outputs, its claims."""
    p = subprocess.run([sys.executable, str(ROOT / "scripts" / "droplet_bond_study.py"), "--bo-min", "0.1",
                        "--bo-max", "10", "--per-decade", "1", "--no-peak", "--out", str(tmp_path)],
                       capture_output=True, text=True, env=dict(os.environ, MPLBACKEND="Agg"), timeout=300)
    assert p.returncode == 0, p.stdout + p.stderr
    assert "2-D: height rises monotonically" in p.stdout and "3-D: height rises monotonically" in p.stdout
    rows = (tmp_path / "droplet_bond_study.csv").read_text().splitlines()
    assert len(rows) == 7 and all(",ok," in r for r in rows[1:])
    assert (tmp_path / "droplet_bond_study.png").stat().st_size > 10_000
    assert "| 3-D | 10 |" in (tmp_path / "droplet_bond_study.md").read_text()


def test_bond_findings_on_the_oracle():
    """The 3-D height overshoots the puddle limit √2 near V ~ 100-1000 l_c³ and has come back towards it by
    V = 1000; the 2-D height stays below 2 l_c sin(θ/2) (oracles only: the closed form and the shooting)."""
    from castrajectory.inspect import bond
    rows = bond.sweep([1.0, 10.0, 100.0], nlp_bonds=[])
    f = bond.findings(rows)
    assert f["2-D"]["monotonic"] and not f["2-D"]["above_limit"]
    assert f["3-D"]["above_limit"] and f["3-D"]["max_height"] > math.sqrt(2.0) + 0.03
