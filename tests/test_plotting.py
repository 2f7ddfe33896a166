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
    """200 frames, the default cap, 640 px wide, from a long fine trajectory: a few seconds, one small
    palette, under 1.5 MB (measured: 1.1 s and 0.8 MB)."""
    import time
    t, P = _double_pendulum_positions(K=3000, T=10.0)
    path = tmp_path / "long.gif"
    t0 = time.perf_counter()
    plotting.animate_points(P, t, str(path), title="double pendulum")
    elapsed = time.perf_counter() - t0
    with Image.open(path) as im:
        assert 180 <= im.n_frames <= 200
        assert im.size[0] >= 640 and im.size[0] % 2 == 0 and im.size[1] % 2 == 0
        assert len(im.getpalette()) // 3 <= 64
    assert path.stat().st_size < 1.5e6
    assert elapsed < 15.0


# ----------------------------------------------------------------------------- pictures a reader needs (#14)
import importlib
import re

from castrajectory.solve import droplet as droplet_solve


def _scene(name, argv):
    """Run a problem script's scene in-process; returns (module, args, outcome)."""
    mod = importlib.import_module(f"castrajectory.problems.{name}")
    args = mod.parser().parse_args(argv)
    out = mod.run(args)
    assert out.success, out.message
    return mod, args, out


def _rectangle(K=400, T=3.0, w=2.0, h=1.0):
    """Corners (closed outline) of a w x h rectangle thrown at x = 0, y = 2, tumbling and bouncing on y = 0."""
    t = np.linspace(0.0, T, K)
    th = 0.3 + 1.0 * t
    cx = 0.5 * t
    cy = 1.2 + 0.8 * np.abs(np.cos(2.0 * t))
    local = np.array([[-w, -h], [w, -h], [w, h], [-w, h], [-w, -h]]) / 2
    c, s = np.cos(th)[:, None], np.sin(th)[:, None]
    P = np.stack([cx[:, None] + c * local[:, 0] - s * local[:, 1], cy[:, None] + s * local[:, 0] + c * local[:, 1]], -1)
    P[..., 1] -= min(0.0, P[..., 1].min())  # resting on the ground at worst
    return t, P


def _check_window(anim, min_fraction=None):
    """Every frame: the bodies are inside the window; with ``min_fraction``, the body spans at least that
    fraction of the window's width and of its height.  Returns the window's (width, height)."""
    (x0, x1), (y0, y1) = anim.ax.get_xlim(), anim.ax.get_ylim()
    W, H = x1 - x0, y1 - y0
    for i in anim.frames:
        anim.draw(i)
        x, y = (np.asarray(a, float) for a in anim.markers.get_data())
        assert x0 <= x.min() and x.max() <= x1 and y0 <= y.min() and y.max() <= y1
        if min_fraction is not None:
            assert np.ptp(x) >= min_fraction * W and np.ptp(y) >= min_fraction * H, (i, np.ptp(x) / W, np.ptp(y) / H)
    return W, H


def test_animation_window_follows_the_body_not_the_ground():
    """The rectangle drop's ground ran ±1000 m and set the limits; now the motion does, the ground is cut to it."""
    t, P = _rectangle()
    anim = plotting.PointsAnimation(P, t, links=True, pivot=None, trail=False, max_frames=60,
                                    ground=np.array([[-1e3, 0.0], [1e3, 0.0]]))
    W, H = _check_window(anim, min_fraction=0.1)
    span = np.ptp(P.reshape(-1, 2), axis=0)
    assert W <= 1.5 * span.max() and H <= 1.5 * span.max()
    # the ground is drawn exactly across the window, on y = 0, inside it
    (x0, x1), (y0, y1) = anim.ax.get_xlim(), anim.ax.get_ylim()
    g = anim.ground
    assert np.isclose(g[:, 0].min(), x0) and np.isclose(g[:, 0].max(), x1)
    assert np.all(g[:, 1] == 0.0) and y0 < 0.0 < y1
    assert anim.ax.get_aspect() == 1.0


def test_clip_polyline_pieces():
    poly = np.array([[-2.0, 0.0], [0.0, 0.0], [0.0, 5.0], [0.5, 5.0], [0.5, 0.5], [3.0, 0.5]])
    out = plotting.clip_polyline(poly, (-1.0, -1.0), (1.0, 1.0))
    pieces = np.split(out, np.where(np.isnan(out[:, 0]))[0])
    assert len(pieces) == 2  # the excursion above y = 1 splits it
    assert np.allclose(out[0], [-1.0, 0.0]) and np.allclose(out[-1], [1.0, 0.5])
    assert np.all(np.abs(out[~np.isnan(out[:, 0])]) <= 1.0)
    assert plotting.clip_polyline(poly, (10.0, 10.0), (11.0, 11.0)) is None


@pytest.mark.parametrize("name,argv,min_fraction", [
    ("rectangle_drop", ["--T", "1.2", "--n", "300"], 0.1),
    ("bowl", ["--T", "1", "--n", "200"], 0.1),
    ("bouncing_ball", ["--n", "200"], None),
    ("double_pendulum", ["--T", "1", "--n", "100"], None),
])
def test_scene_animations_share_the_motion_window(monkeypatch, tmp_path, name, argv, min_fraction):
    """Each scene's --animate hook goes through animate_points: its window comes from the motion."""
    _, _, out = _scene(name, argv)
    calls = []
    monkeypatch.setattr(plotting, "animate_points", lambda P, t, path, **kw: calls.append((P, t, kw)))
    out.writers["animate"](str(tmp_path / "a.gif"))
    ((P, t, kw),) = calls
    kw = {k: v for k, v in kw.items() if k != "fps"}
    anim = plotting.PointsAnimation(P, t, max_frames=40, **kw)
    W, H = _check_window(anim, min_fraction)
    moving = np.asarray(P, float).reshape(-1, 2)
    if kw.get("links", True) and kw.get("pivot", (0.0, 0.0)) is not None:
        moving = np.vstack([moving, [0.0, 0.0]])
    assert max(W, H) <= 1.5 * max(np.ptp(moving, axis=0).max(), 1e-9) + 1e-9
    if anim.ground is not None:
        (x0, x1), (y0, y1) = anim.ax.get_xlim(), anim.ax.get_ylim()
        g = anim.ground[~np.isnan(anim.ground[:, 0])]
        assert np.all((g[:, 0] >= x0 - 1e-12) & (g[:, 0] <= x1 + 1e-12) & (g[:, 1] >= y0 - 1e-12) & (g[:, 1] <= y1 + 1e-12))


def test_thrown_ball_plot_is_the_path_over_the_parabola(tmp_path):
    mod, args, out = _scene("thrown_ball", ["--n", "50"])
    (ax,) = mod.figure(out, args).axes
    labelled = [l for l in ax.get_lines() if not l.get_label().startswith("_")]
    assert len(labelled) == 2
    (analytic,) = [l for l in labelled if l.get_label() == "analytic parabola"]
    (computed,) = [l for l in labelled if l.get_label().startswith("least action")]
    ref, xy = np.column_stack(analytic.get_data()), np.column_stack(computed.get_data())
    assert xy.shape == ref.shape == (51, 2)
    assert np.max(np.abs(xy - ref)) < 1e-8
    # the analytic line is the parabola through both ends with acceleration -g
    t = np.asarray(out.data["t"], float)
    T, h = t[-1], t[1] - t[0]
    assert np.allclose(ref[0], [0.0, 0.0]) and np.allclose(ref[-1], [args.distance, args.height])
    assert np.allclose(np.diff(ref[:, 1], 2) / h**2, -args.g, rtol=1e-9)
    assert np.allclose(np.diff(ref[:, 0], 2), 0.0, atol=1e-12)
    assert np.allclose(ref[:, 1], args.height * t / T + args.g * t * (T - t) / 2, rtol=0, atol=1e-12)
    out.writers["plot"](str(tmp_path / "ball.png"))
    assert (tmp_path / "ball.png").stat().st_size > 10_000


@pytest.mark.parametrize("name,argv,angles", [
    ("double_pendulum", ["--T", "1", "--n", "100"], [0, 1]),
    ("n_link_pendulum", ["--links", "3", "--T", "1", "--n", "100"], [0, 1, 2]),
    ("stiff_spring_pendulum", ["--T", "0.5", "--n", "100"], [1]),   # q = (r, θ)
])
def test_pendulum_plot_has_angles_against_time(tmp_path, name, argv, angles):
    mod, _, out = _scene(name, argv)
    fig = mod.figure(out)
    t, q = np.asarray(out.data["t"], float), np.asarray(out.data["q"], float)
    (ax,) = [a for a in fig.axes if "angle" in a.get_ylabel()]
    lines = ax.get_lines()
    assert len(lines) == len(angles)
    for line, j in zip(lines, angles):
        x, y = line.get_data()
        assert np.array_equal(np.asarray(x, float), t) and np.array_equal(np.asarray(y, float), q[:, j])
        assert line.get_label().startswith("θ")
    assert fig.axes[-1].get_xlabel() == "t"
    assert any(a.get_yscale() == "log" for a in fig.axes)  # the energy error stays in the picture
    out.writers["plot"](str(tmp_path / "p.png"))
    assert (tmp_path / "p.png").stat().st_size > 10_000


def _check_contact_angle(ax, theta, point):
    (tangent,) = [l for l in ax.get_lines() if l.get_label().startswith("tangent")]
    x, y = (np.asarray(a, float) for a in tangent.get_data())
    assert np.allclose([x[0], y[0]], point)
    assert np.isclose((y[-1] - y[0]) / (x[-1] - x[0]), math.tan(theta), rtol=1e-12)
    labels = [tx.get_text() for tx in ax.texts] + [tangent.get_label()]
    found = [re.search(r"θ = (\d+)\.(\d+)°", s) for s in labels]
    assert all(found) and len(found) == 2
    for m in found:
        value, digits = float(f"{m.group(1)}.{m.group(2)}"), len(m.group(2))
        assert abs(value - math.degrees(theta)) <= 0.5 * 10.0**-digits + 1e-12


@pytest.mark.parametrize("gamma_sl", [0.5, 1.6])   # 60° and above 90°
def test_droplet_plot_draws_the_contact_angle(gamma_sl):
    sol = droplet_solve.solve(droplet_solve.Droplet(1.0, gamma_sl, 1.0, 1.0), 60)
    fig = plotting.droplet_figure(sol)
    _check_contact_angle(fig.axes[0], sol.contact_angle, (sol.x[0], sol.y[0]))


def test_droplet_angle_plot_draws_the_contact_angle():
    sol = droplet_solve.solve_angle(droplet_solve.Droplet(1.0, 0.2, 1.0, 1.0))
    fig = plotting.reduced_energy_figure(sol)
    _check_contact_angle(fig.axes[1], sol.contact_angle, (0.0, 0.0))


# ----------------------------------------------------------------------------- animations a reader can see (#15)
def test_animation_frames_are_640_px_with_the_time_stamped():
    """Each frame is at least 640 px wide, shows "t = … s" at its own sample, and the rendered frame
    (blitted) has the figure's size and differs from the next one."""
    t, P = _double_pendulum_positions(K=300, T=3.0)
    anim = plotting.PointsAnimation(P, t, max_frames=30, title="test")
    w, h = anim.fig.canvas.get_width_height()
    assert w >= 640 and w % 2 == 0 and h % 2 == 0
    frames = []
    for i in anim.frames[:3]:
        frames.append(anim.render(i))
        assert anim._stamp.get_text() == f"t = {t[i]:.2f} s"
        assert re.fullmatch(r"t = \d+\.\d\d s", anim._stamp.get_text())
        assert frames[-1].shape == (h, w, 4)
    assert not np.array_equal(frames[0], frames[1])
    # the bob drawn in the rendered pixels: the marker colour (C0) appears near the projected bob
    x, y = anim.ax.transData.transform(P[anim.frames[2], -1])
    px = frames[2][int(round(h - y)) - 3:int(round(h - y)) + 4, int(round(x)) - 3:int(round(x)) + 4, :3].astype(int)
    assert np.any(np.abs(px - np.array([31, 119, 180])).sum(axis=-1) < 60)


def test_rigid_body_animation_is_640_px(tmp_path):
    t = np.linspace(0.0, 1.0, 50)
    c, s = np.cos(t), np.sin(t)
    R = np.zeros((50, 3, 3))
    R[:, 0, 0], R[:, 0, 1], R[:, 1, 0], R[:, 1, 1], R[:, 2, 2] = c, -s, s, c, 1.0
    path = tmp_path / "box.gif"
    plotting.animate_rigid_body(t, R, str(path), (1.0, 0.6, 0.3), momentum=(0, 0, 1), max_frames=20)
    with Image.open(path) as im:
        assert im.size[0] >= 640 and im.n_frames == 20


@pytest.mark.skipif(not plotting.mp4_available(), reason="ffmpeg not installed: no MP4 encoder")
@pytest.mark.parametrize("kind", ["points", "rigid"])
def test_animation_writes_mp4_with_ffmpeg(tmp_path, kind):
    """With ffmpeg a path ending in .mp4 is an H.264 MP4 (yuv420p: what browsers play) of the frame's size."""
    import shutil
    import subprocess
    path = tmp_path / "a.mp4"
    if kind == "points":
        t, P = _double_pendulum_positions(K=100, T=2.0)
        plotting.animate_points(P, t, str(path), max_frames=25)
        size = plotting.PointsAnimation(P, t, max_frames=25).fig.canvas.get_width_height()
    else:
        t = np.linspace(0.0, 1.0, 30)
        plotting.animate_rigid_body(t, np.repeat(np.eye(3)[None], 30, axis=0), str(path), (1, 1, 1), max_frames=25)
        size = (640, 640)
    data = path.read_bytes()
    assert data[4:8] == b"ftyp"
    if shutil.which("ffprobe"):
        p = subprocess.run(["ffprobe", "-v", "error", "-select_streams", "v:0", "-count_frames", "-show_entries",
                            "stream=codec_name,width,height,pix_fmt,nb_read_frames", "-of", "json", str(path)],
                           capture_output=True, text=True, check=True)
        import json
        (st,) = json.loads(p.stdout)["streams"]
        assert (st["codec_name"], st["pix_fmt"]) == ("h264", "yuv420p")
        assert (st["width"], st["height"]) == tuple(size) and int(st["nb_read_frames"]) == 25


# ----------------------------------------------------------------------------- plots that show the motion (#15)
def _system_of(name, args):
    from castrajectory.models import collision, pendulum
    if name == "double_pendulum":
        return pendulum.double_pendulum(args.m1, args.m2, args.l1, args.l2, args.g)
    if name == "n_link_pendulum":
        return pendulum.n_link_pendulum([args.mass] * args.links, [args.length] * args.links, args.g)
    body = collision.Body(args.mass, args.width, args.height)
    ground = collision.bowl_ground(args.radius) if name == "bowl" else collision.flat_ground
    return collision.rectangle_contact_system(body, args.g, args.restitution, ground)


@pytest.mark.parametrize("name,argv,links", [
    ("double_pendulum", ["--T", "1", "--n", "100"], [1.0, 1.0]),
    ("n_link_pendulum", ["--links", "3", "--T", "1", "--n", "100", "--length", "0.7"], [0.7, 0.7, 0.7]),
])
def test_pendulum_plot_shows_the_paths_in_the_plane(tmp_path, name, argv, links):
    """The first panel holds one path per bob: its data are system.positions(q), each bob at its link's
    length from the one before (from the pivot), drawn at equal aspect."""
    mod, args, out = _scene(name, argv)
    system = _system_of(name, args)
    fig = mod.figure(out, system)
    ax = fig.axes[0]
    assert ax.get_aspect() == 1.0 and ax.get_xlabel() == "x" and ax.get_ylabel() == "y"
    paths = [l for l in ax.get_lines() if l.get_label().endswith(" path")]
    assert [l.get_label() for l in paths] == [f"bob {j + 1} path" for j in range(len(links))]
    P = system.positions(np.asarray(out.data["q"], float))
    prev = np.zeros((P.shape[0], 2))
    for j, (line, length) in enumerate(zip(paths, links)):
        xy = np.column_stack(line.get_data())
        assert np.array_equal(xy, P[:, j])
        assert np.allclose(np.linalg.norm(xy - prev, axis=1), length, rtol=0, atol=1e-9)
        prev = xy
    # the time panels are still there, and the --plot writer draws this figure
    assert any("angle" in a.get_ylabel() for a in fig.axes) and fig.axes[-1].get_xlabel() == "t"
    out.writers["plot"](str(tmp_path / "p.png"))
    with Image.open(tmp_path / "p.png") as im:
        assert im.size[0] > 1000  # two columns: the time panels and the plane


@pytest.mark.parametrize("name,argv", [
    ("bowl", ["--T", "1", "--n", "200"]),
    ("rectangle_drop", ["--T", "1.2", "--n", "300"]),
])
def test_contact_plot_draws_the_body_at_its_impacts(tmp_path, name, argv):
    """The first panel draws the body at each impact over the ground: one closed outline per impact,
    labelled with its time, each touching the ground (its lowest corner's gap ~ 0, none below), the
    corner that struck marked on the ground; the ground drawn is y = x²/(2R) (bowl) or y = 0."""
    mod, args, out = _scene(name, argv)
    system = _system_of(name, args)
    fig = mod.figure(out, system)
    ax = fig.axes[0]
    impacts = out.data["impacts"]
    assert impacts, "the scene hits the ground"
    R = getattr(args, "radius", None)

    def gap(xy):
        return xy[:, 1] - (xy[:, 0] ** 2 / (2 * R) if R else 0.0)

    outlines = [l for l in ax.get_lines() if l.get_label().startswith("impact at t = ")]
    assert len(outlines) == len(impacts)
    for line, imp in zip(outlines, impacts):
        xy = np.column_stack(line.get_data())
        assert xy.shape == (5, 2) and np.array_equal(xy[0], xy[-1])  # a closed rectangle
        assert float(line.get_label().split("= ")[1].split(" s")[0]) == pytest.approx(imp["t"], abs=1e-4)
        g = gap(xy[:4])
        assert abs(g.min()) < 1e-6 and abs(g[imp["contact"]]) < 1e-6
        assert np.isclose(np.linalg.norm(xy[1] - xy[0]), args.width) and np.isclose(np.linalg.norm(xy[2] - xy[1]), args.height)
    (struck,) = [l for l in ax.get_lines() if l.get_label() == "corner that struck"]
    assert np.all(np.abs(gap(np.column_stack(struck.get_data())).astype(float)) < 1e-6)
    (ground,) = [l for l in ax.get_lines() if l.get_label().startswith(("bowl", "ground"))]
    gxy = np.column_stack(ground.get_data())
    gxy = gxy[~np.isnan(gxy[:, 0])]
    assert len(gxy) >= 2 and np.allclose(gap(gxy[1:-1]), 0.0, atol=1e-12)  # the ends: cut mid-chord
    assert np.allclose(gap(gxy), 0.0, atol=1e-5)
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    assert np.isclose(gxy[0, 0], x0) and np.isclose(gxy[-1, 0], x1)  # across the window, cut to it
    assert ax.get_aspect() == 1.0
    # the time panels of the contact plot follow it, and --plot writes this figure
    assert fig.axes[-1].get_xlabel() == "t" and fig.axes[-1].get_ylabel() == "impulse"
    out.writers["plot"](str(tmp_path / "c.png"))
    assert (tmp_path / "c.png").stat().st_size > 20_000


def test_animation_links_join_the_pairs_asked_for():
    """links as pairs of point indices (-1: the pivot): the drawn segments are exactly those pairs."""
    from castrajectory.inspect.plotting import PointsAnimation
    t = np.linspace(0.0, 1.0, 5)
    P = np.stack([np.stack([[k, 0.0], [k, -1.0], [k + 1.0, -1.0]]) for k in t])   # cart, bob, second bob
    anim = PointsAnimation(P, t, links=[(0, 1), (0, 2), (-1, 0)], trail=False)
    anim.draw(2)
    x, y = anim.links.get_data()
    seg = np.column_stack([x, y]).reshape(3, 3, 2)
    assert np.allclose(seg[:, :2], [[P[2, 0], P[2, 1]], [P[2, 0], P[2, 2]], [[0.0, 0.0], P[2, 0]]])
    assert np.all(np.isnan(seg[:, 2]))
    with pytest.raises(ValueError):
        PointsAnimation(P, t, links=[(0, 3)])
    with pytest.raises(ValueError):
        PointsAnimation(P, t, links=[(-1, 0)], pivot=None)


def test_control_plot_without_controls_is_quiet():
    """A contact problem without controls (the bounce to a target: only its launch is free) drew an empty legend,
    and matplotlib's "No artists with labels" warning reached the report's stderr."""
    import warnings

    from castrajectory.inspect.plotting import control_plot
    t = np.linspace(0.0, 1.0, 11)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fig = control_plot(t, np.c_[t, t ** 2], ["x", "y"], np.zeros((10, 0)), [])
    assert len(fig.axes) == 2 and fig.axes[1].get_legend() is None
