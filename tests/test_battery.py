"""The contact battery's scheme families (scripts/contact_battery.py --schemes, issue #25): drawn scenes solved
and checked against the event-driven reference through the battery's own run function; and its bouncing friction
families (--friction: a spinning disk or sphere, the rectangle and the bowl with friction at their impacts)."""
from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest

from castrajectory.inspect import battery

ROOT = Path(__file__).resolve().parents[1]


def test_scheme_scenes_are_solved_with_every_check():
    """Two drawn scenes (a pendulum at its joint limit, a double pendulum at a wall) and their twins at 2N, each
    solved in process by run_scene: every impact of the reference matched, times within max(2 h^p, 1e-12) s
    (measured 1.8e-11 and 5.2e-11 s at N = 400), Newton's law, energy per flight, and the twins no worse
    (gauss4 at order 3.99).  About 3 s."""
    scenes = battery.draw_scheme_scenes(13, 2)
    assert [s["family"] for s in scenes] == ["pendulum", "pendulum", "double_pendulum", "double_pendulum"]
    assert [s["scheme"] for s in scenes[::2]] == ["galerkin4", "gauss4"]
    rows = [{**sc, **battery.run_scene(sc)} for sc in scenes]
    battery.check_twins(rows)
    for r in rows:
        assert r["success"] and r["solved"], (r["id"], r["status"], r["failed"])
        assert r["impacts"] == r["oracle_impacts"] >= 1 and r["caught"] == 0
        assert r["impact_time_error"] <= r["time_tol"] and r["impact_law"] <= battery.SCHEME_LAW_TOL
        assert r["energy_error"] <= r["energy_tol"]
    for r in rows[1::2]:
        assert r["twin_ok"] and r["N"] == 2 * rows[rows.index(r) - 1]["N"]
    order = battery.fitted_order(rows[2], rows[3])
    assert abs(order - 4) < 0.5


def test_a_drawn_scene_is_screened_against_its_reference():
    """The screen keeps only scenes whose impacts every grid resolves: it keeps issue #25's joint-limit pendulum
    (impacts at 0.71 and 2.31 s, T = 3) and refuses it when T falls within ten coarsest steps of an impact, when
    the pendulum never reaches its limit, and when its rebound comes back too slowly to be an impact on 100 steps."""
    base = dict(family="pendulum", e=0.5, limit=0.5, q0=[-1.0], v0=[0.0], T=3.0)
    assert battery.screen_scheme_scene(base) is None
    assert battery.screen_scheme_scene(dict(base, T=2.35)).startswith("impacts closer")
    assert battery.screen_scheme_scene(dict(base, q0=[-0.4])) == "no impact"
    assert battery.screen_scheme_scene(dict(base, e=0.1)).startswith("a slow arrival")


def test_twins_worse_than_their_run_are_not_solved():
    rows = [dict(id="a", solved=True, impact_time_error=1e-9), dict(id="ax2", twin_of="a", solved=True,
                                                                    impact_time_error=2e-9),
            dict(id="b", solved=True, impact_time_error=4e-13), dict(id="bx2", twin_of="b", solved=True,
                                                                     impact_time_error=6e-13)]
    battery.check_twins(rows)
    assert not rows[1]["twin_ok"] and not rows[1]["solved"] and "worse" in rows[1]["failed"]
    assert rows[3]["twin_ok"] and rows[3]["solved"]          # both at the 1e-12 floor
    assert math.isnan(battery.fitted_order(rows[2], rows[3]))


def test_bouncing_friction_scenes_are_solved_with_every_check():
    """Three drawn scenes of the bouncing friction families (seed 17): a disk bouncing with spin (μ = 0.82, e = 0.49,
    N = 200), the rectangle with a corner straight under its centroid (μ = 1.23, e = 0.8, N = 800) and the bowl
    (μ = 0.54, e = 1, N = 200), each solved in process by run_scene: no penetration, the cone, maximal dissipation
    and sticking at the held contacts, no bounce gaining energy, the closed-form bounce (measured 8e-16 and 3e-15 s,
    7e-14 and 6e-13 of the speed) and the event-driven reference's first impact time (2e-16 s).  About 3 s."""
    scenes = {s["id"]: s for s in battery.draw_friction_scenes(17, 40)}
    picked = [scenes[i] for i in ("f007", "f035", "f027")]
    assert [s["family"] for s in picked] == ["spin-drop", "rectangle-friction", "bowl-friction"]
    assert picked[1]["centred"] and all(s["mu"] > 0 for s in picked)
    for sc in picked:
        r = battery.run_scene(sc)
        assert r["success"] and r["solved"], (sc["id"], r["status"], r.get("failed"))
        assert r["impacts"] >= 1 and r["impact_time_error"] <= battery.IMPACT_TIME_TOL
        assert r["cone"] <= battery.FRICTION_TOL and r["impact_cone"] <= battery.IMPACT_CONE_TOL
        assert r["impact_energy"] <= battery.IMPACT_ENERGY_TOL
        if sc["family"] != "bowl-friction":
            assert r["oracle_error"] <= battery.BOUNCE_TOL and r["oracle_impacts"] >= 1
        else:
            assert r["first_arrival"] == "compared"


def test_friction_twins_worse_than_their_run_are_not_solved():
    rows = [dict(id="a", solved=True, impact_time_error=1e-9, oracle_error=math.nan),
            dict(id="ax2", twin_of="a", solved=True, impact_time_error=2e-9, oracle_error=math.nan),
            dict(id="b", solved=True, impact_time_error=4e-16, oracle_error=3e-11),
            dict(id="bx2", twin_of="b", solved=True, impact_time_error=6e-12, oracle_error=5e-11)]
    battery.check_friction_twins(rows)
    assert not rows[1]["twin_ok"] and not rows[1]["solved"] and "impact_time_error" in rows[1]["failed"]
    assert rows[3]["twin_ok"] and rows[3]["solved"]          # both at the rounding floor


@pytest.mark.slow
def test_scheme_battery_script_writes_its_report(tmp_path):
    """The script with --schemes: six scenes and their twins in child processes, every goal PASS (about 12 s)."""
    p = subprocess.run([sys.executable, str(ROOT / "scripts" / "contact_battery.py"), "--schemes", "--count", "6",
                        "--out", str(tmp_path)], capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    assert "MISS" not in p.stdout and p.stdout.count("PASS") == 4
    import csv
    rows = list(csv.DictReader((tmp_path / "schemes.csv").open()))
    assert len(rows) == 12 and all(r["solved"] == "True" for r in rows)
    assert "fitted order" in (tmp_path / "schemes_summary.md").read_text()
