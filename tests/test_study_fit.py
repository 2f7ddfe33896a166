"""The work-precision readings: the observed order's fit range, the one-line reading, scipy's peers."""
import math

import numpy as np
import pytest

from castrajectory.inspect import study
from castrajectory.models import pendulum


def rows_of(label, ns, errors, times=None):
    times = times or [1e-3 * n for n in ns]
    return [{"label": label, "n": n, "status": "ok", "success": True, "error_final": e, "time_s": t}
            for n, e, t in zip(ns, errors, times)]


def test_order_is_fitted_before_a_floor():
    """galerkin4's measured errors on the double pendulum (T = 5): order 4, then the solve's floor."""
    errs = [1.03e-3, 6.48e-5, 4.06e-6, 2.54e-7, 1.59e-8, 5.68e-10, 3.67e-10]
    ns = [250, 500, 1000, 2000, 4000, 8000, 16000]
    o = study.trajectory_order(rows_of("g4", ns, errs), "g4")
    assert o["order"] == pytest.approx(4.0, abs=0.02)
    assert o["n_max"] == 4000 and o["stalled_at"] == 8000


def test_pure_power_law_and_pre_asymptotic_runs():
    ns = [100, 200, 400, 800]
    o = study.trajectory_order(rows_of("p2", ns, [3.0 * n ** -2.0 for n in ns]), "p2")
    assert o["order"] == pytest.approx(2.0, abs=1e-12) and o["n_max"] == 800 and math.isnan(o["stalled_at"])
    ie = study.trajectory_order(rows_of("ie", ns, [2.45, 2.28, 2.19, 1.95]), "ie")
    assert math.isnan(ie["order"]) and ie["note"].startswith("pre-asymptotic")


def test_reading_names_the_cheapest_method_at_each_target():
    a = rows_of("a", [100, 200, 400], [1e-3, 1e-5, 1e-7], [1.0, 2.0, 4.0])
    b = rows_of("b", [100, 200, 400], [1e-3, 1e-5, 1e-7], [0.1, 0.2, 0.4])
    c = rows_of("c", [100, 200], [1e-1, 1e-2], [0.01, 0.02])
    line = study.reading(a + b + c, ["a", "b", "c"], (1e-5, 1e-7))
    assert "at 1e-05 b wins (0.2 s, 10.0x ahead of a)" in line and "at 1e-07 b wins" in line
    assert "c never reached 1e-07" in line


def test_peer_sweep_matches_its_reference():
    pytest.importorskip("scipy")
    rows = study.peer_sweep(pendulum.double_pendulum, [1.0, 0.5], [0.0, 0.0], 1.0, methods=("DOP853",),
                            rtols=(1e-6, 1e-10))
    assert [r["label"] for r in rows] == ["scipy-DOP853"] * 2
    assert rows[1]["error_final"] < rows[0]["error_final"] < 1e-4 and rows[1]["n"] > rows[0]["n"]
    assert all(np.isfinite(r["time_s"]) and r["success"] for r in rows)
