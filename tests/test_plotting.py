"""Plots and animations on small synthetic data (headless: Figure / Agg only)."""
import math

import numpy as np
import pytest
from matplotlib import animation
from matplotlib.figure import Figure
from PIL import Image

from castrajectory.inspect import plotting


def _t(n=200, T=2.0):
    return np.linspace(0.0, T, n)


def _rows():
    rows = []
    for method, scheme, c in [("whole", "midpoint", 1.0), ("march", "midpoint", 2.0), ("rk4", "-", 0.5)]:
        for n in (400, 100, 200):  # unsorted on purpose
            rows.append({"method": method, "scheme": scheme, "n": n, "status": "ok",
                         "error_final": c / n**2, "energy_error_max": c / n,
                         "build_time_s": 1e-3 * n, "solve_time_s": 2e-3 * n})
    return rows


def test_energy_plot_relative_and_absolute():
    t = _t()
    E = {"midpoint": 1.0 + 1e-6 * np.sin(5 * t), "rk4": 1.0 - 1e-5 * t}
    fig = plotting.energy_plot(t, E, title="pendulum")
    assert isinstance(fig, Figure)
    (ax,) = fig.axes
    assert len(ax.get_lines()) == 2
    assert ax.get_yscale() == "log"
    fig = plotting.energy_plot({"a": t, "b": t[:50]}, {"a": E["rk4"], "b": E["midpoint"][:50]}, relative=False)
    (ax,) = fig.axes
    assert ax.get_yscale() == "linear"
    assert [len(l.get_xdata()) for l in ax.get_lines() if len(l.get_xdata()) > 2] == [200, 50]


def test_energy_plot_zero_reference_energy():
    t = _t()
    fig = plotting.energy_plot(t, {"a": 1e-3 * np.sin(t)})
    assert "/ |E₀|" not in fig.axes[0].get_ylabel()


def test_trajectory_plot_one_line_per_coordinate():
    t = _t()
    q = np.column_stack([np.sin(t), np.cos(t), t])
    fig = plotting.trajectory_plot(t, q, ["θ1", "θ2", "x"])
    (ax,) = fig.axes
    assert [l.get_label() for l in ax.get_lines()] == ["θ1", "θ2", "x"]
    with pytest.raises(ValueError):
        plotting.trajectory_plot(t, q, ["θ1"])


def test_long_horizon_plot_in_periods():
    t = _t(500, 50.0)
    fig = plotting.long_horizon_plot(t, {"RK4": -1e-6 * t, "midpoint": 1e-5 * np.sin(t) ** 2}, period=2.0)
    (ax,) = fig.axes
    assert len(ax.get_lines()) == 2
    assert ax.get_yscale() == "log"
    assert np.isclose(ax.get_lines()[0].get_xdata()[-1], 25.0)
    assert "period" in ax.get_xlabel()


def test_work_precision_groups_sorted_by_n():
    fig = plotting.work_precision(_rows(), title="double pendulum")
    (ax,) = fig.axes
    lines = ax.get_lines()
    assert len(lines) == 3
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    for line in lines:
        x = np.asarray(line.get_xdata())
        assert np.all(np.diff(x) > 0)  # time grows with n: sorted by n
        assert line.get_marker() not in (None, "None", "")
    labels = sorted(l.get_label() for l in lines)
    assert labels == ["march / midpoint", "rk4 / -", "whole / midpoint"]


@pytest.mark.parametrize("x", ["time", "solve_time_s", "n"])
@pytest.mark.parametrize("y", ["error", "error_final", "energy_error_max"])
def test_work_precision_axes_choice(x, y):
    fig = plotting.work_precision(_rows(), x=x, y=y)
    assert len(fig.axes[0].get_lines()) == 3


def test_work_precision_skips_bad_values():
    rows = _rows()
    rows += [
        {**rows[0], "n": 800, "error_final": 0.0},
        {**rows[0], "n": 1600, "error_final": -1.0},
        {**rows[0], "n": 3200, "error_final": math.nan},
        {**rows[0], "n": 6400, "error_final": math.inf},
        {**rows[0], "n": 12800, "solve_time_s": math.nan},
        {**rows[0], "n": 25600, "status": "solver failed"},
        {"method": "broken", "scheme": "x", "n": 10, "error_final": 0.0, "energy_error_max": -1.0,
         "build_time_s": 0.0, "solve_time_s": 0.0},
    ]
    fig = plotting.work_precision(rows)
    lines = fig.axes[0].get_lines()
    assert len(lines) == 3  # the all-bad group draws nothing
    for line in lines:
        assert len(line.get_xdata()) == 3
        assert np.all(np.asarray(line.get_ydata()) > 0)
    with pytest.raises(ValueError):
        plotting.work_precision(rows, x="iterations")


def test_work_precision_panels_two_axes():
    fig = plotting.work_precision_panels(_rows())
    assert len(fig.axes) == 2
    for ax in fig.axes:
        assert len(ax.get_lines()) == 3
        assert ax.get_xscale() == "log" and ax.get_yscale() == "log"


def _double_pendulum_positions(K=600, T=4.0):
    t = np.linspace(0.0, T, K)
    th1, th2 = 1.2 * np.cos(2.0 * t), 2.0 * np.sin(3.1 * t)
    p1 = np.column_stack([np.sin(th1), -np.cos(th1)])
    p2 = p1 + np.column_stack([np.sin(th2), -np.cos(th2)])
    return t, np.stack([p1, p2], axis=1)


@pytest.mark.parametrize("links", [True, False])
def test_animate_points_writes_gif(tmp_path, links):
    t, P = _double_pendulum_positions()
    path = tmp_path / "pendulum.gif"
    out = plotting.animate_points(P, t, str(path), max_frames=40, fps=20, links=links, title="test")
    assert out == str(path)
    assert path.read_bytes()[:4] == b"GIF8"
    with Image.open(path) as im:
        assert im.format == "GIF"
        assert 1 < im.n_frames <= 40


def test_animate_points_fewer_samples_than_frames(tmp_path):
    t, P = _double_pendulum_positions(K=12, T=1.0)
    path = tmp_path / "short.gif"
    plotting.animate_points(P, t, str(path), max_frames=300)
    with Image.open(path) as im:
        assert im.n_frames <= 12


def test_animate_points_mp4_without_ffmpeg(tmp_path, monkeypatch):
    monkeypatch.setattr(animation.FFMpegWriter, "isAvailable", classmethod(lambda cls: False))
    t, P = _double_pendulum_positions(K=20)
    with pytest.raises(ValueError, match="ffmpeg"):
        plotting.animate_points(P, t, str(tmp_path / "a.mp4"))
    assert not (tmp_path / "a.mp4").exists()


def test_animate_points_bad_input(tmp_path):
    t, P = _double_pendulum_positions(K=20)
    with pytest.raises(ValueError):
        plotting.animate_points(P, t, str(tmp_path / "a.png"))
    with pytest.raises(ValueError):
        plotting.animate_points(P[:, :, :1], t, str(tmp_path / "a.gif"))
    with pytest.raises(ValueError):
        plotting.animate_points(P, t[:-1], str(tmp_path / "a.gif"))
    with pytest.raises(ValueError):
        plotting.animate_points(P, t[::-1], str(tmp_path / "a.gif"))


def test_animate_points_full_size_is_fast(tmp_path):
    """300 frames, the default cap, from a long fine trajectory: a few seconds, one palette."""
    import time
    t, P = _double_pendulum_positions(K=3000, T=10.0)
    path = tmp_path / "long.gif"
    t0 = time.perf_counter()
    plotting.animate_points(P, t, str(path), title="double pendulum")
    elapsed = time.perf_counter() - t0
    with Image.open(path) as im:
        assert 250 <= im.n_frames <= 300
        assert im.size[0] % 2 == 0 and im.size[1] % 2 == 0
    assert elapsed < 15.0
