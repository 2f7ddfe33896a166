"""Plots (the only module that imports matplotlib).

Figures are built with ``matplotlib.figure.Figure`` directly, so no GUI
backend or display is needed and nothing global is touched.
"""
from __future__ import annotations

import math
from io import BytesIO
from typing import Dict, List, Optional, Sequence

import numpy as np
from matplotlib import animation
from matplotlib.figure import Figure
from PIL import Image

_ERROR_STYLE = {"shape": "o-", "contact_angle": "s-", "span": "^-", "energy": "v-", "pressure": "d-"}


def _mark_contact_angle(ax, point, theta: float, size: float, digits: int = 4, color: str = "C3") -> None:
    """Draw the contact angle ``theta`` at the left contact ``point`` of a drop on ``y = point[1]``.

    The interface's tangent leaves the point along ``(cos θ, sin θ)`` (slope ``tan θ``; the liquid is to the
    right); an arc of radius ``size`` from the ground to the tangent marks the angle, labelled in degrees
    with ``digits`` decimals.  The tangent line carries the label too, for the legend.
    """
    x0, y0 = float(point[0]), float(point[1])
    deg = f"θ = {math.degrees(theta):.{digits}f}°"
    c, s = math.cos(theta), math.sin(theta)
    ax.plot([x0, x0 + 2.2 * size * c], [y0, y0 + 2.2 * size * s], "--", color=color, lw=1.2,
            label=f"tangent at the contact, {deg}")
    phi = np.linspace(0.0, theta, 60)
    ax.plot(x0 + size * np.cos(phi), y0 + size * np.sin(phi), "-", color=color, lw=1.2)
    ax.text(x0 + 1.25 * size * math.cos(0.5 * theta), y0 + 1.25 * size * math.sin(0.5 * theta), deg,
            color=color, fontsize=9, ha="left" if theta < 0.5 * math.pi else "center", va="bottom")


def droplet_figure(sol) -> Figure:
    """The discrete drop over the analytic circle, with the contact angle drawn and labelled at the left contact."""
    cap = sol.analytic
    fig = Figure(figsize=(8.4, 4.2), layout="constrained")
    ax = fig.add_subplot()
    pts = cap.points(720)
    ax.plot(pts[:, 0], pts[:, 1], "-", color="0.6", lw=3, label="analytic arc")
    stride = max(1, len(sol.x) // 200)
    ax.plot(sol.x, sol.y, "-", color="C0", lw=1.2, label=f"discrete ({sol.formulation}, N = {sol.n})")
    ax.plot(sol.x[::stride], sol.y[::stride], ".", color="C0", ms=3)
    lo, hi = min(sol.x.min(), 0.0), max(sol.x.max(), cap.span)
    pad = 0.08 * (hi - lo)
    ax.axhline(0.0, color="k", lw=1)
    ax.fill_between([lo - pad, hi + pad], [0, 0], [-0.04 * (hi - lo)] * 2, color="0.85")
    _mark_contact_angle(ax, (sol.x[0], sol.y[0]), sol.contact_angle, 0.15 * (hi - lo))
    ax.set_aspect("equal")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    mode = "free span (Young)" if sol.drop.span is None else f"pinned span a = {sol.drop.span:g}"
    ax.set_title(f"Droplet, {mode}, {sol.formulation}, N = {sol.n}\n"
                 f"θ = {math.degrees(sol.contact_angle):.4f}° (analytic {math.degrees(cap.contact_angle):.4f}°), "
                 f"shape error {sol.errors['shape']:.1e}", fontsize=10)
    ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8)
    return fig


def droplet_shape(sol, path: str) -> None:
    """:func:`droplet_figure` written to ``path``."""
    droplet_figure(sol).savefig(path, dpi=130)


def reduced_energy_figure(sol) -> Figure:
    """E(θ) of the reduced problem with the optimum and Young's angle marked, beside the cap of the optimal
    angle with its contact angle drawn and labelled."""
    from ..models.droplet import arc_points

    th = np.linspace(0.02, math.pi - 0.02, 600)
    E = np.array([float(sol.energy_function(t)) for t in th])
    fig = Figure(figsize=(10.4, 4.0), layout="constrained")
    ax, bx = fig.subplots(1, 2, width_ratios=[1.3, 1.0])
    ax.plot(np.degrees(th), E, lw=1.5)
    ax.plot([math.degrees(sol.contact_angle)], [sol.energy], "o", color="C3",
            label=f"Ipopt optimum θ = {math.degrees(sol.contact_angle):.6f}°, E = {sol.energy:.6g}")
    d = sol.drop
    young = math.degrees(math.acos((d.gamma_sg - d.gamma_sl) / d.gamma_gl))
    ax.axvline(young, color="0.5", ls="--", lw=1, label=f"Young's angle {young:.6f}°")
    ymax = min(E.max(), sol.energy + 3.0 * (np.median(E) - sol.energy + 1e-12))
    ax.set_ylim(sol.energy - 0.1 * (ymax - sol.energy), ymax)
    ax.set_xlabel("θ (degrees)")
    ax.set_ylabel("E(θ)")
    ax.set_title("Reduced droplet energy E(θ) = 2R(θ)(γ_gl θ + (γ_sl − γ_sg) sin θ)", fontsize=10)
    ax.legend(fontsize=8)
    pts = arc_points(sol.contact_angle, sol.radius, 400)
    lo, hi = min(pts[:, 0].min(), 0.0), max(pts[:, 0].max(), sol.span)
    bx.plot(pts[:, 0], pts[:, 1], "-", color="C0", lw=1.5, label=f"cap, R = {sol.radius:.6g}")
    bx.axhline(0.0, color="k", lw=1)
    _mark_contact_angle(bx, (0.0, 0.0), sol.contact_angle, 0.15 * (hi - lo), digits=6)
    bx.set_aspect("equal")
    bx.set_xlabel("x")
    bx.set_ylabel("y")
    bx.set_title("the drop at the optimum", fontsize=10)
    bx.legend(loc="upper center", bbox_to_anchor=(0.5, -0.3), fontsize=8)
    return fig


def reduced_energy(sol, path: str) -> None:
    """:func:`reduced_energy_figure` written to ``path``."""
    reduced_energy_figure(sol).savefig(path, dpi=130)


def droplet_convergence(rows: List[dict], path: str) -> None:
    """Errors against N and against wall time (build + solve), log-log, one column per formulation."""
    forms = sorted({r["formulation"] for r in rows})
    fig = Figure(figsize=(5.2 * len(forms), 8.0), layout="constrained")
    axes = fig.subplots(2, len(forms), squeeze=False)
    for j, f in enumerate(forms):
        sel = sorted((r for r in rows if r["formulation"] == f and r["status"] == "ok"), key=lambda r: r["n"])
        n = np.array([r["n"] for r in sel], float)
        t = np.array([r["total_time_s"] for r in sel], float)
        for k, style in _ERROR_STYLE.items():
            e = np.array([r[f"err_{k}"] for r in sel], float)
            axes[0, j].loglog(n, e, style, ms=4, lw=1, label=k)
            axes[1, j].loglog(t, e, style, ms=4, lw=1, label=k)
        if len(n):
            ref = sel[len(sel) // 2]["err_shape"] * (n / n[len(n) // 2]) ** -2
            axes[0, j].loglog(n, ref, "k--", lw=0.8, label="N⁻²")
        axes[0, j].set_xlabel("N (segments)")
        axes[1, j].set_xlabel("wall time, build + solve (s)")
        for i in range(2):
            axes[i, j].set_ylabel("error")
            axes[i, j].grid(True, which="major", alpha=0.3)
            axes[i, j].legend(fontsize=7)
        axes[0, j].set_title(f"{f}: error against N")
        axes[1, j].set_title(f"{f}: error against run time")
    fig.savefig(path, dpi=120)


# ----------------------------------------------------------------------------- trajectories
# The functions below return a Figure and leave saving to the caller
# (``fig.savefig(path)``); nothing global is touched.

def _as_time(t, label: str) -> np.ndarray:
    t = np.asarray(t, dtype=float).reshape(-1)
    if t.size == 0:
        raise ValueError(f"{label}: the time array is empty")
    return t


def _series_time(t, key: str, n: int) -> np.ndarray:
    """The time array for series ``key``: ``t`` itself, or ``t[key]`` when ``t`` is a dict."""
    tk = _as_time(t[key] if isinstance(t, dict) else t, key)
    if tk.size != n:
        raise ValueError(f"{key}: {n} values but {tk.size} times")
    return tk


def _positive(y: np.ndarray) -> np.ndarray:
    """``y`` with non-positive or non-finite entries masked (NaN), for log axes."""
    y = np.array(y, dtype=float)
    y[~np.isfinite(y) | (y <= 0)] = np.nan
    return y


def _energy_axes(ax, t, energies: Dict[str, np.ndarray], relative: bool = True) -> None:
    """Draw the energy drift of each labelled run on ``ax`` (see :func:`energy_plot`)."""
    absolute = False
    for label, E in energies.items():
        E = np.asarray(E, dtype=float).reshape(-1)
        tk = _series_time(t, label, E.size)
        dE = E - E[0]
        if relative:
            scale = abs(E[0])
            if scale > 0:
                y = np.abs(dE) / scale
            else:
                y, absolute = np.abs(dE), True
            ax.plot(tk, _positive(y), lw=1.2, label=label)
        else:
            ax.plot(tk, dE, lw=1.2, label=label)
    if relative:
        ax.set_yscale("log")
        ax.set_ylabel("|E − E₀|" + ("" if absolute else " / |E₀|"))
    else:
        ax.axhline(0.0, color="0.5", lw=0.8)
        ax.set_ylabel("E − E₀")
    ax.set_xlabel("t")
    ax.grid(True, which="major", alpha=0.3)
    if energies:
        ax.legend(fontsize=8)


def energy_plot(t, energies: Dict[str, np.ndarray], title: Optional[str] = None,
                relative: bool = True) -> Figure:
    """Energy drift of one or several labelled runs.

    ``energies`` maps a label to ``E(t)``; ``t`` is one time array shared by all
    runs or a dict with the same labels.  With ``relative=True`` the plot shows
    ``|E − E₀| / |E₀|`` on a log axis (``|E − E₀|`` when ``E₀ = 0``; exact
    zeros, such as the first sample, are left out); otherwise ``E − E₀`` on a
    linear axis.
    """
    fig = Figure(figsize=(6.4, 4.0), layout="constrained")
    ax = fig.add_subplot()
    _energy_axes(ax, t, energies, relative)
    ax.set_title(title or "Energy error", fontsize=10)
    return fig


#: More coordinates than this in one panel of :func:`trajectory_plot` get no legend.
_MAX_LEGEND = 12


def plane_paths_axes(ax, positions, names: Optional[Sequence[str]] = None, pivot=None) -> None:
    """The paths of moving points in the plane on ``ax``, equal aspect.

    ``positions`` (K, n_points, 2), e.g. ``system.positions(q)`` of a pendulum's bobs: one line per
    point labelled ``"<name> path"`` (``names`` default ``bob 1`` …), the configuration at the start
    (dashed, through ``pivot`` when given) and at the end (solid), and the ``pivot`` as a square.
    """
    P = np.asarray(positions, dtype=float)
    if P.ndim == 2:
        P = P[:, None, :]
    if P.ndim != 3 or P.shape[-1] != 2 or P.shape[0] == 0:
        raise ValueError(f"plane_paths_axes: positions must have shape (K, n_points, 2), got {np.shape(positions)}")
    names = list(names) if names is not None else [f"bob {j + 1}" for j in range(P.shape[1])]
    if len(names) != P.shape[1]:
        raise ValueError(f"plane_paths_axes: {P.shape[1]} points but {len(names)} names")
    for j, name in enumerate(names):
        ax.plot(P[:, j, 0], P[:, j, 1], "-", color=f"C{j % 10}", lw=0.8, alpha=0.8, label=f"{name} path")
    for k, style, label in ((0, "--", "start"), (-1, "-", "end")):
        chain = P[k] if pivot is None else np.vstack([np.asarray(pivot, float).reshape(1, 2), P[k]])
        ax.plot(chain[:, 0], chain[:, 1], style, color="k", lw=1.2, marker="o", ms=4,
                mfc="white" if k == 0 else "k", label=label)
    if pivot is not None:
        ax.plot([pivot[0]], [pivot[1]], "s", color="k", ms=5, label="pivot")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=7, loc="best")


def trajectory_plot(t, q, names: Sequence[str], title: Optional[str] = None,
                    panels: Optional[Sequence[tuple]] = None,
                    energies: Optional[Dict[str, np.ndarray]] = None, plane=None,
                    plane_names: Optional[Sequence[str]] = None, pivot=(0.0, 0.0)) -> Figure:
    """Generalised coordinates ``q`` (shape (K, n)) against time, one line per coordinate.

    ``panels`` is a list of ``(ylabel, columns)``, one axes each (e.g. ``[("angle (rad)", [1]),
    ("r (m)", [0])]`` keeps a length apart from an angle); by default every coordinate shares one
    axes labelled ``q``.  ``energies`` (label -> ``E(t)``) adds the relative energy error below, as
    :func:`energy_plot` draws it.  The axes share the time axis.  ``plane`` (K, n_points, 2), the
    points' positions at ``t`` (e.g. a pendulum's bobs), adds a panel on the right with their paths
    in the plane (:func:`plane_paths_axes`, from ``pivot``; ``None`` for no pivot); it is the
    figure's first axes.
    """
    t = _as_time(t, "trajectory_plot")
    q = np.asarray(q, dtype=float)
    if q.ndim == 1:
        q = q[:, None]
    if q.shape[0] != t.size:
        raise ValueError(f"trajectory_plot: {q.shape[0]} rows of q but {t.size} times")
    names = list(names)
    if len(names) != q.shape[1]:
        raise ValueError(f"trajectory_plot: {q.shape[1]} coordinates but {len(names)} names")
    panels = list(panels) if panels else [("q", range(q.shape[1]))]
    rows = len(panels) + (1 if energies else 0)
    if plane is None:
        fig = Figure(figsize=(6.4, 2.2 + 1.8 * rows), layout="constrained")
        axes = fig.subplots(rows, 1, sharex=True, squeeze=False)[:, 0]
    else:
        P = np.asarray(plane, dtype=float)
        if P.shape[0] != t.size:
            raise ValueError(f"trajectory_plot: {P.shape[0]} rows of plane positions but {t.size} times")
        fig = Figure(figsize=(11.5, max(2.2 + 1.8 * rows, 5.0)), layout="constrained")
        grid = fig.add_gridspec(rows, 2, width_ratios=[1.2, 1.0])
        pax = fig.add_subplot(grid[:, 1])
        plane_paths_axes(pax, P, plane_names, pivot)
        pax.set_title("paths in the plane", fontsize=10)
        first = fig.add_subplot(grid[0, 0])
        axes = [first] + [fig.add_subplot(grid[r, 0], sharex=first) for r in range(1, rows)]
        for a in axes[:-1]:
            a.tick_params(labelbottom=False)
    for ax, (ylabel, cols) in zip(axes, panels):
        cols = list(cols)
        for j in cols:
            ax.plot(t, q[:, j], lw=1.2, label=names[j])
        ax.set_ylabel(ylabel)
        ax.grid(True, which="major", alpha=0.3)
        if len(cols) <= _MAX_LEGEND:
            ax.legend(fontsize=8, loc="upper right")
    if energies:
        _energy_axes(axes[-1], t, energies)
        axes[-1].set_title("energy error", fontsize=9)
    axes[-1].set_xlabel("t")
    axes[0].set_title(title or "Generalised coordinates", fontsize=10)
    return fig


def path_plot(q, reference=None, label: str = "computed", reference_label: str = "analytic",
              xlabel: str = "x", ylabel: str = "y", title: Optional[str] = None) -> Figure:
    """A planar path ``q`` (shape (K, 2)) drawn over a ``reference`` path (same shape, e.g. the analytic one
    at the same times), equal aspect; the largest distance between them is in the legend."""
    q = np.asarray(q, dtype=float).reshape(-1, 2)
    fig = Figure(figsize=(6.4, 4.0), layout="constrained")
    ax = fig.add_subplot()
    if reference is not None:
        ref = np.asarray(reference, dtype=float).reshape(-1, 2)
        if ref.shape != q.shape:
            raise ValueError(f"path_plot: the reference has shape {ref.shape}, the path {q.shape}")
        err = float(np.max(np.abs(q - ref))) if q.size else float("nan")
        ax.plot(ref[:, 0], ref[:, 1], "-", color="0.6", lw=4, label=reference_label)
        label = f"{label} (max deviation {err:.1e})"
    stride = max(1, len(q) // 40)
    ax.plot(q[:, 0], q[:, 1], "-", color="C0", lw=1.2, label=label)
    ax.plot(q[::stride, 0], q[::stride, 1], "o", color="C0", ms=3)
    ax.plot(q[[0, -1], 0], q[[0, -1], 1], "s", color="k", ms=5)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title or "Path", fontsize=10)
    return fig


def long_horizon_plot(t, energy_errors: Dict[str, np.ndarray], period: Optional[float] = None,
                      title: Optional[str] = None) -> Figure:
    """``|E − E₀|`` against time (or against periods when ``period`` is given), log y.

    ``energy_errors`` maps a label (e.g. ``"RK4"``, ``"midpoint"``) to the
    energy error ``E(t) − E₀`` (the sign is dropped); ``t`` is shared or a dict
    keyed like ``energy_errors``.  Typical use: RK4's secular drift against the
    bounded oscillation of a variational scheme.
    """
    if period is not None and not (np.isfinite(period) and period > 0):
        raise ValueError(f"long_horizon_plot: period must be positive, got {period!r}")
    fig = Figure(figsize=(7.0, 4.0), layout="constrained")
    ax = fig.add_subplot()
    for label, err in energy_errors.items():
        err = np.asarray(err, dtype=float).reshape(-1)
        tk = _series_time(t, label, err.size)
        x = tk / period if period else tk
        ax.plot(x, _positive(np.abs(err)), lw=1.0, label=label)
    ax.set_yscale("log")
    ax.set_xlabel("t / period" if period else "t")
    ax.set_ylabel("|E − E₀|")
    ax.grid(True, which="major", alpha=0.3)
    ax.set_title(title or "Long-horizon energy error", fontsize=10)
    if energy_errors:
        ax.legend(fontsize=8)
    return fig


# ----------------------------------------------------------------------------- work-precision
_WP_X = {"time": "wall time, build + solve (s)", "solve_time_s": "solve time (s)",
         "build_time_s": "build time (s)", "n": "N (steps)"}
_WP_Y_ALIAS = {"error": "error_final", "energy": "energy_error_max"}
_WP_Y_LABEL = {"error_final": "final-state error", "energy_error_max": "max |E − E₀|",
               "flip_interval_error": "|flip interval − 2K(m)/s| (s)",
               "impact_time_error": "max |t_impact − exact| (s)", "apex_error": "max |apex − exact| (m)"}
_WP_MARKERS = "os^vD<>pPX*h"


def _wp_value(row: dict, key: str) -> float:
    if key == "time":
        return float(row["build_time_s"]) + float(row["solve_time_s"])
    return float(row[key])


def _work_precision_axes(ax, rows: List[dict], x: str, y: str, group: Sequence[str]) -> int:
    """Draw one work-precision diagram on ``ax``; returns the number of groups drawn."""
    if x not in _WP_X:
        raise ValueError(f"work_precision: x must be one of {sorted(_WP_X)}, got {x!r}")
    ykey = _WP_Y_ALIAS.get(y, y)
    group = (group,) if isinstance(group, str) else tuple(group)
    groups: Dict[tuple, list] = {}
    for r in rows:
        if r.get("status", "ok") != "ok":
            continue
        try:
            xv, yv = _wp_value(r, x), _wp_value(r, ykey)
        except (KeyError, TypeError, ValueError):
            continue
        if not (np.isfinite(xv) and np.isfinite(yv) and xv > 0 and yv > 0):
            continue
        groups.setdefault(tuple(r.get(g) for g in group), []).append((r.get("n", 0), xv, yv))
    for k, (key, pts) in enumerate(sorted(groups.items(), key=lambda kv: tuple(map(str, kv[0])))):
        pts.sort(key=lambda p: p[0])
        xs = [p[1] for p in pts]
        ys = [p[2] for p in pts]
        label = " / ".join(str(v) for v in key if v is not None)
        ax.plot(xs, ys, "-", marker=_WP_MARKERS[k % len(_WP_MARKERS)], ms=4, lw=1, label=label)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(_WP_X[x])
    ax.set_ylabel(_WP_Y_LABEL.get(ykey, ykey))
    ax.grid(True, which="both", alpha=0.25)
    if groups:
        ax.legend(fontsize=7)
    return len(groups)


def work_precision(rows: List[dict], x: str = "time", y: str = "error",
                   group: Sequence[str] = ("method", "scheme"), title: Optional[str] = None) -> Figure:
    """Work–precision diagram (SciML style): error against cost, log-log.

    ``rows`` are dicts with at least ``method``, ``scheme``, ``n``,
    ``error_final``, ``energy_error_max``, ``build_time_s``, ``solve_time_s``.
    ``x`` is ``"time"`` (build + solve), ``"solve_time_s"``, ``"build_time_s"``
    or ``"n"``; ``y`` is a row key (``"error"`` means ``error_final``,
    ``"energy"`` means ``energy_error_max``).  One line with markers per
    ``group`` value, its points sorted by ``n``.  Rows whose ``status`` is
    present and not ``"ok"``, or whose x or y is missing, non-finite or
    non-positive, are skipped.
    """
    fig = Figure(figsize=(6.4, 4.6), layout="constrained")
    ax = fig.add_subplot()
    _work_precision_axes(ax, rows, x, y, group)
    ax.set_title(title or "Work–precision", fontsize=10)
    return fig


def work_precision_panels(rows: List[dict], x: str = "time",
                          group: Sequence[str] = ("method", "scheme"),
                          title: Optional[str] = None, error: str = "error_final") -> Figure:
    """Two work–precision panels side by side: ``error`` (final-state error by default) and max
    energy error against ``x``."""
    fig = Figure(figsize=(11.0, 4.6), layout="constrained")
    ax_err, ax_en = fig.subplots(1, 2)
    _work_precision_axes(ax_err, rows, x, error, group)
    _work_precision_axes(ax_en, rows, x, "energy_error_max", group)
    ax_err.set_title(_WP_Y_LABEL.get(error, error) if error != "error_final" else "final-state error", fontsize=10)
    ax_en.set_title("max energy error", fontsize=10)
    if title:
        fig.suptitle(title, fontsize=11)
    return fig


def contact_work_precision(rows: List[dict], title: Optional[str] = None) -> Figure:
    """Impact-time and apex-height errors of contact runs against wall time and N (``study.contact_run`` rows)."""
    fig = Figure(figsize=(11.0, 8.4), layout="constrained")
    (ax_t, ax_n), (bx_t, bx_n) = fig.subplots(2, 2)
    _work_precision_axes(ax_t, rows, "time", "impact_time_error", ("case", "method"))
    _work_precision_axes(ax_n, rows, "n", "impact_time_error", ("case", "method"))
    _work_precision_axes(bx_t, rows, "time", "apex_error", ("case", "method"))
    _work_precision_axes(bx_n, rows, "n", "apex_error", ("case", "method"))
    ax_t.set_title("impact-time error against wall time", fontsize=10)
    ax_n.set_title("impact-time error against N", fontsize=10)
    bx_t.set_title("apex-height error against wall time", fontsize=10)
    bx_n.set_title("apex-height error against N", fontsize=10)
    if title:
        fig.suptitle(title, fontsize=11)
    return fig


# ----------------------------------------------------------------------------- animation
def mp4_available() -> bool:
    """Whether an MP4 encoder (ffmpeg) is present for :func:`animate_points`."""
    return bool(animation.FFMpegWriter.isAvailable())


class _SharedPaletteGifWriter(animation.PillowWriter):
    """:class:`~matplotlib.animation.PillowWriter` that quantises every frame to one shared palette.

    Pillow otherwise builds an adaptive palette per RGB frame while saving,
    which costs more than drawing the frames; mapping all frames onto one
    palette (taken from a mosaic of a few frames) is about ten times faster
    and gives a smaller file.  The palette has :attr:`colors` entries: 64 keep
    the antialiased lines and text of a plot clean and make a 640-px, 200-frame
    GIF about 0.8 MB (255: 1.1 MB).  Frames must be opaque.
    """

    colors = 64

    def setup(self, fig, outfile, dpi=None):
        super().setup(fig, outfile, dpi=dpi)
        self._rgb = []

    def grab_frame(self, **savefig_kwargs):
        buf = BytesIO()
        self.fig.savefig(buf, **{**savefig_kwargs, "format": "rgba", "dpi": self.dpi})
        self._rgb.append(Image.frombuffer("RGBA", self.frame_size, buf.getbuffer(), "raw", "RGBA", 0, 1)
                         .convert("RGB"))

    def grab_rgba(self, rgba: np.ndarray) -> None:
        """Add a frame already rendered (an (H, W, 4) uint8 array, e.g. a blitted canvas buffer)."""
        self._rgb.append(Image.fromarray(np.ascontiguousarray(rgba[..., :3])))

    def finish(self):
        frames = self._rgb
        picks = [frames[i] for i in np.unique(np.linspace(0, len(frames) - 1, 8).round().astype(int))]
        w, h = picks[0].size
        mosaic = Image.new("RGB", (w, h * len(picks)))
        for k, im in enumerate(picks):
            mosaic.paste(im, (0, k * h))
        palette = mosaic.quantize(colors=self.colors)
        quantised = [im.quantize(palette=palette, dither=Image.Dither.NONE) for im in frames]
        quantised[0].save(self.outfile, save_all=True, append_images=quantised[1:],
                          duration=int(1000 / self.fps), loop=0)


class _RawFFMpegWriter(animation.FFMpegWriter):
    """:class:`~matplotlib.animation.FFMpegWriter` that also takes frames already rendered (H.264, yuv420p)."""

    def grab_rgba(self, rgba: np.ndarray) -> None:
        """Pipe an (H, W, 4) uint8 frame of the writer's frame size to ffmpeg."""
        if (rgba.shape[1], rgba.shape[0]) != tuple(self.frame_size):
            raise ValueError(f"frame of {rgba.shape[1]} x {rgba.shape[0]} px, the movie is {self.frame_size}")
        self._proc.stdin.write(np.ascontiguousarray(rgba).tobytes())


def _writer(path, fps: int):
    """The animation writer for ``path``: a GIF (Pillow) or an MP4 (ffmpeg); ``ValueError`` otherwise."""
    ext = str(path).lower().rsplit(".", 1)[-1] if "." in str(path) else ""
    if ext == "gif":
        return _SharedPaletteGifWriter(fps=fps)
    if ext == "mp4":
        if not animation.FFMpegWriter.isAvailable():
            raise ValueError(f"cannot write {path}: MP4 needs ffmpeg, which was not found; "
                             "install ffmpeg or ask for a .gif")
        return _RawFFMpegWriter(fps=fps, codec="h264", extra_args=["-pix_fmt", "yuv420p"])
    raise ValueError(f"cannot write {path}: the animation path must end in .gif or .mp4")


def _frames(t: np.ndarray, max_frames: int) -> np.ndarray:
    """Frame indices evenly in time: the last sample at or before each of ``max_frames`` target times."""
    targets = np.linspace(t[0], t[-1], min(t.size, int(max_frames)))
    return np.unique(np.clip(np.searchsorted(t, targets, side="right") - 1, 0, t.size - 1))


#: Every animation's frame: this many inches wide at this many dots per inch (640 px; text and lines
#: scale with the dpi, so they stay readable at the larger size).
ANIMATION_WIDTH_IN = 4.0
ANIMATION_DPI = 160


def time_stamp(t: float) -> str:
    """The time shown in an animation's frame: ``"t = 1.23 s"``."""
    return f"t = {t:.2f} s"


#: Margin of an animation's window around the motion, as a fraction of the motion's largest half-extent.
VIEW_MARGIN = 0.12


def view_window(points, margin: float = VIEW_MARGIN, min_aspect: float = 0.5, cube: bool = False):
    """The view box of an animation: ``(lo, hi)`` around ``points`` (shape (M, d), every position the
    bodies take, every frame).

    One rule for every animation: the box is the points' bounding box, each half-width raised to at
    least ``min_aspect`` of the largest one (all equal with ``cube``, for a 3-D box), then grown by
    ``margin`` of the largest.  Fixed scenery (a ground, a bowl) does not widen it; it is clipped to it.
    """
    P = np.asarray(points, dtype=float).reshape(-1, np.shape(points)[-1])
    lo, hi = P.min(axis=0), P.max(axis=0)
    centre, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    big = float(half.max())
    if not big > 1e-12 * max(1.0, float(np.abs(centre).max())):  # nothing moves: a unit window around it
        big = 0.5 * max(1.0, float(np.abs(centre).max()))
    half = np.full_like(half, big) if cube else np.maximum(half, min_aspect * big)
    half = half + margin * big
    return centre - half, centre + half


def clip_polyline(poly, lo, hi) -> Optional[np.ndarray]:
    """The parts of the polyline ``poly`` (M, 2) inside the box ``[lo, hi]`` (Liang–Barsky per segment),
    as one polyline with a NaN row between separate pieces; ``None`` when no part is inside."""
    poly = np.asarray(poly, dtype=float).reshape(-1, 2)
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    pieces: List[List[np.ndarray]] = []
    for a, b in zip(poly[:-1], poly[1:]):
        d = b - a
        t0, t1 = 0.0, 1.0
        for k in range(2):
            for p, r in ((-d[k], a[k] - lo[k]), (d[k], hi[k] - a[k])):
                if p == 0.0:
                    if r < 0.0:
                        t0, t1 = 1.0, 0.0
                elif p < 0.0:
                    t0 = max(t0, r / p)
                else:
                    t1 = min(t1, r / p)
        if t0 > t1:
            continue
        pa, pb = a + t0 * d, a + t1 * d
        if pieces and t0 == 0.0 and np.array_equal(pieces[-1][-1], pa):
            pieces[-1].append(pb)
        else:
            pieces.append([pa, pb])
    if not pieces:
        return None
    out = []
    for k, piece in enumerate(pieces):
        if k:
            out.append(np.full(2, np.nan))
        out.extend(piece)
    return np.array(out)


class PointsAnimation:
    """The figure of :func:`animate_points` and how to draw one sample on it, before anything is written.

    ``fig`` and ``ax`` are fixed for the whole animation (limits from :func:`view_window`);
    ``frames`` are the sample indices drawn; ``ground`` is the scenery polyline drawn (clipped to the
    window) or ``None``; ``markers`` and ``links`` are the moving artists, set by :meth:`draw`;
    :meth:`render` gives a frame's pixels.  The frame is ``ANIMATION_WIDTH_IN * dpi`` pixels wide
    (640 by default), with the time stamped in its corner (:func:`time_stamp`).
    """

    def __init__(self, positions, t, trail: bool = True, max_frames: int = 200, links: bool = True,
                 pivot=(0.0, 0.0), title: Optional[str] = None, trail_time: float = 1.0,
                 dpi: int = ANIMATION_DPI, ground=None):
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.collections import LineCollection

        P = np.asarray(positions, dtype=float)
        if P.ndim == 2 and P.shape[-1] == 2:
            P = P[:, None, :]
        if P.ndim != 3 or P.shape[-1] != 2 or P.shape[0] == 0:
            raise ValueError(f"positions must have shape (K, n_points, 2), got {np.shape(positions)}")
        t = _as_time(t, "animate_points")
        if t.size != P.shape[0]:
            raise ValueError(f"animate_points: {P.shape[0]} position rows but {t.size} times")
        if not np.all(np.isfinite(t)) or np.any(np.diff(t) < 0):
            raise ValueError("animate_points: t must be finite and non-decreasing")
        if not np.all(np.isfinite(P)):
            raise ValueError("animate_points: positions contain non-finite values")
        if int(max_frames) < 1:
            raise ValueError("animate_points: max_frames must be positive")
        self.P, self.t, self.trail, self.trail_time = P, t, trail, trail_time
        self.frames = _frames(t, max_frames)
        self.has_pivot = pivot is not None
        self.pivot = np.asarray(pivot if self.has_pivot else (0.0, 0.0), dtype=float).reshape(2)
        # links: True (the pivot and the points joined in order), False, or pairs (i, j) of point indices
        # to join (-1: the pivot), e.g. [(0, 1), (0, 2)] for two bobs hanging from one cart
        self.pairs = None
        if not isinstance(links, (bool, np.bool_)):
            pairs = [tuple(int(k) for k in pr) for pr in links]
            n_pts = P.shape[1]
            if any(len(pr) != 2 or not all(-1 <= k < n_pts for k in pr) for pr in pairs):
                raise ValueError(f"links: pairs of point indices in [0, {n_pts}) (-1: the pivot), got {links!r}")
            if any(-1 in pr for pr in pairs) and not self.has_pivot:
                raise ValueError("links: index -1 joins the pivot, but there is no pivot")
            self.pairs = pairs
        self.show_links = bool(links) if self.pairs is None else bool(self.pairs)
        links = self.show_links

        # the window follows the bodies (and the pivot they hang from), never the scenery
        moving = P.reshape(-1, 2)
        if links and self.has_pivot:
            moving = np.vstack([moving, self.pivot])
        lo, hi = view_window(moving)
        self.ground = None if ground is None else clip_polyline(ground, lo, hi)
        half = 0.5 * (hi - lo)

        # figure shaped to the window (aspect clamped), in even pixel counts as ffmpeg wants
        dpi = int(dpi)
        left, right, bottom, top_in = 0.5, 0.12, 0.35, (0.35 if title else 0.12)
        aspect = float(np.clip(half[1] / half[0], 0.4, 1.2))
        width_px = 2 * round(ANIMATION_WIDTH_IN * dpi / 2)
        axes_w = width_px / dpi - left - right
        height_px = 2 * round((axes_w * aspect + bottom + top_in) * dpi / 2)
        fig = Figure(figsize=(width_px / dpi, height_px / dpi), dpi=dpi)
        canvas = FigureCanvasAgg(fig)
        W, H = width_px / dpi, height_px / dpi
        fig.subplots_adjust(left=left / W, right=1 - right / W, bottom=bottom / H, top=1 - top_in / H)
        ax = fig.add_subplot()
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal", adjustable="box")
        ax.tick_params(labelsize=7)
        ax.grid(True, alpha=0.2)
        if title:
            ax.set_title(title, fontsize=9)
        if links and self.has_pivot:
            ax.plot([self.pivot[0]], [self.pivot[1]], "s", color="k", ms=4)
        if self.ground is not None:
            ax.plot(self.ground[:, 0], self.ground[:, 1], "-", color="0.3", lw=1.5)
        # The moving artists are animated: the static part (frame, ticks, grid, title, pivot, ground)
        # is rendered once and kept as a background; each frame restores it and draws only the moving
        # artists on it (blitting), which keeps a 200-frame GIF of 640 px around a second.
        (self.links,) = ax.plot([], [], "-", color="0.25", lw=1.6, visible=links, animated=True)
        self._trail = LineCollection([], linewidths=1.5, animated=True)
        ax.add_collection(self._trail, autolim=False)
        (self.markers,) = ax.plot([], [], "o", color="C0", ms=7, mec="k", mew=0.6, zorder=3, animated=True)
        self._stamp = ax.text(0.02, 0.97, "", transform=ax.transAxes, va="top", fontsize=9, animated=True,
                              bbox=dict(boxstyle="round,pad=0.2", fc="white", ec="0.7", lw=0.5, alpha=0.85))
        canvas.draw()
        self._background = canvas.copy_from_bbox(fig.bbox)
        self.fig, self.ax, self.dpi, self.canvas = fig, ax, dpi, canvas

    def render(self, i: int) -> np.ndarray:
        """The pixels of sample ``i``'s frame: an (H, W, 4) uint8 array (a copy)."""
        self.draw(i)
        self.canvas.restore_region(self._background)
        for artist in (self.links, self._trail, self.markers, self._stamp):
            self.ax.draw_artist(artist)
        return np.array(self.canvas.buffer_rgba())

    def draw(self, i: int) -> None:
        """Set the moving artists to sample ``i``."""
        P, t, pts = self.P, self.t, self.P[i]
        if self.show_links and self.pairs is not None:
            ext = np.vstack([pts, self.pivot[None, :]])          # index -1: the pivot
            seg = np.full((3 * len(self.pairs), 2), np.nan)      # segments separated by NaN rows
            for k, (a, b) in enumerate(self.pairs):
                seg[3 * k], seg[3 * k + 1] = ext[a], ext[b]
            self.links.set_data(seg[:, 0], seg[:, 1])
        elif self.show_links:
            chain = np.vstack([self.pivot, pts]) if self.has_pivot else pts
            self.links.set_data(chain[:, 0], chain[:, 1])
        self.markers.set_data(pts[:, 0], pts[:, 1])
        if self.trail:
            tt = self.trail_time
            j0 = int(np.searchsorted(t, t[i] - tt, side="left"))
            idx = np.arange(j0, i + 1)
            if idx.size > 150:
                idx = np.unique(np.linspace(j0, i, 150).round().astype(int))
            tr = P[idx, -1, :]
            if len(tr) >= 2:
                segs = np.stack([tr[:-1], tr[1:]], axis=1)
                age = (t[i] - t[idx[1:]]) / tt if tt > 0 else np.zeros(len(segs))
                colors = np.empty((len(segs), 4))
                colors[:, :3] = (0.84, 0.15, 0.16)  # C3
                colors[:, 3] = np.clip(1.0 - age, 0.0, 1.0) * 0.9
                self._trail.set_segments(segs)
                self._trail.set_color(colors)
            else:
                self._trail.set_segments([])
        self._stamp.set_text(time_stamp(t[i]))


def animate_points(positions, t, path: str, trail: bool = True, fps: int = 20, max_frames: int = 200,
                   links: bool = True, pivot=(0.0, 0.0), title: Optional[str] = None,
                   trail_time: float = 1.0, dpi: int = ANIMATION_DPI, ground=None) -> str:
    """Animate moving points (e.g. a pendulum's bobs) and write a GIF or an MP4.

    ``positions`` has shape (K, n_points, 2) and ``t`` length K.  With
    ``links=True`` segments join ``pivot`` and the points in order; each frame
    shows markers at the points and, with ``trail=True``, a fading trail of
    the last point over the preceding ``trail_time`` (s).  Frames are
    subsampled evenly in time to at most ``max_frames``.  ``path`` ending in
    ``.gif`` is written with Pillow; ``.mp4`` needs ffmpeg (``ValueError``
    otherwise).  The axes are fixed and equal-aspect; the window is
    :func:`view_window` of every position (and the pivot), so the bodies fill
    it.  ``pivot=None`` joins only the points (a rigid body's outline);
    ``ground`` (an (M, 2) polyline, e.g. the floor or a bowl, as long as
    wanted) is drawn clipped to the window.  The figure is
    :class:`PointsAnimation`: 640 px wide at the default ``dpi``, the time
    stamped in each frame.  Returns ``path``.
    """
    writer = _writer(path, fps)
    if fps <= 0:
        raise ValueError("animate_points: fps must be positive")
    anim = PointsAnimation(positions, t, trail=trail, max_frames=max_frames, links=links, pivot=pivot,
                           title=title, trail_time=trail_time, dpi=dpi, ground=ground)
    with writer.saving(anim.fig, str(path), dpi=anim.dpi):
        for i in anim.frames:
            writer.grab_rgba(anim.render(i))
    return str(path)


def impacts_axes(ax, outlines, times, ground=None, path=None, contacts=None, ground_label: str = "ground"):
    """A body drawn at its impacts over the ground, on ``ax`` (equal aspect).

    ``outlines`` are closed polylines (M, 2), the body at each impact, at ``times`` (coloured by time,
    with a colour bar; each line labelled ``"impact at t = … s"``); ``ground`` (G, 2) is the scenery,
    clipped to a window around the motion; ``path`` (K, 2), e.g. the centre's, is drawn thin;
    ``contacts`` (one (x, y) per impact) marks the corner that struck.
    """
    from matplotlib import cm
    from matplotlib import colors as mcolors
    from matplotlib.lines import Line2D

    outlines = [np.asarray(o, float).reshape(-1, 2) for o in outlines]
    times = np.asarray(times, float).reshape(-1)
    if len(outlines) != times.size:
        raise ValueError(f"impacts_axes: {len(outlines)} outlines but {times.size} times")
    moving = outlines + ([np.asarray(path, float).reshape(-1, 2)] if path is not None else [])
    handles = []
    if moving:
        lo, hi = view_window(np.vstack(moving), min_aspect=0.3)
        if ground is not None:
            g = clip_polyline(ground, lo, hi)
            if g is not None:
                handles += ax.plot(g[:, 0], g[:, 1], "-", color="0.3", lw=2.0, label=ground_label)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
    if path is not None:
        p = np.asarray(path, float).reshape(-1, 2)
        handles += ax.plot(p[:, 0], p[:, 1], "-", color="0.55", lw=0.8, label="centre path")
    hi_t = float(times.max()) if times.size else 1.0
    lo_t = float(times.min()) if times.size else 0.0
    norm = mcolors.Normalize(lo_t, hi_t if hi_t > lo_t else lo_t + 1.0)
    cmap = cm.viridis
    for o, tk in zip(outlines, times):
        ax.plot(o[:, 0], o[:, 1], "-", color=cmap(norm(tk)), lw=1.4, label=f"impact at t = {tk:.4f} s")
    if outlines:
        handles.append(Line2D([], [], color=cmap(0.5), lw=1.4, label=f"the body at its {len(outlines)} impacts"))
        ax.figure.colorbar(cm.ScalarMappable(norm=norm, cmap=cmap), ax=ax, label="impact time (s)", shrink=0.8)
    if contacts is not None and len(contacts):
        c = np.asarray(contacts, float).reshape(-1, 2)
        handles += ax.plot(c[:, 0], c[:, 1], "x", color="C3", ms=6, mew=1.5, label="corner that struck")
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.grid(True, alpha=0.3)
    if handles:
        ax.legend(handles=handles, fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2)


def contact_plot(t, series: Dict[str, np.ndarray], t_impulse, impulses, reference: Optional[Dict[str, tuple]] = None,
                 ylabel: str = "height", title: Optional[str] = None, impacts: Optional[dict] = None) -> Figure:
    """A contact trajectory: curves against time (with analytic references) over a stem plot of impulses.

    ``series`` maps labels to values at ``t``; ``reference`` maps labels to
    ``(t_ref, y_ref)`` drawn dashed; ``impulses`` (at ``t_impulse``) go in the
    lower panel.  ``impacts`` (the keyword arguments of :func:`impacts_axes`:
    ``outlines``, ``times``, ``ground``, ...) adds a panel on the left with the
    body drawn at its impacts over the ground; it is the figure's first axes.
    """
    if impacts is None:
        fig = Figure(figsize=(6.4, 5.2), layout="constrained")
        ax, bx = fig.subplots(2, 1, sharex=True, height_ratios=[2, 1])
    else:
        fig = Figure(figsize=(13.0, 5.2), layout="constrained")
        grid = fig.add_gridspec(2, 2, width_ratios=[1.15, 1.0], height_ratios=[2, 1])
        sx = fig.add_subplot(grid[:, 0])
        impacts_axes(sx, **impacts)
        sx.set_title("the body at its impacts", fontsize=10)
        ax = fig.add_subplot(grid[0, 1])
        bx = fig.add_subplot(grid[1, 1], sharex=ax)
        ax.tick_params(labelbottom=False)
    t = _as_time(t, "contact_plot")
    for label, y in series.items():
        ax.plot(t, np.asarray(y, float), lw=1.2, label=label)
    for label, (tr, yr) in (reference or {}).items():
        ax.plot(np.asarray(tr, float), np.asarray(yr, float), "--", lw=1.0, color="k", label=label)
    ax.axhline(0.0, color="0.4", lw=0.8)
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title or "Contact trajectory", fontsize=10)
    ti = np.asarray(t_impulse, float).reshape(-1)
    mu = np.asarray(impulses, float).reshape(-1)
    keep = mu > 1e-9 * max(float(np.max(np.abs(mu))) if mu.size else 0.0, 1e-300)  # interior-point zeros
    ti, mu = ti[keep], mu[keep]
    if ti.size:
        bx.vlines(ti, 0.0, mu, color="C3", lw=1.2)
        bx.plot(ti, mu, "o", color="C3", ms=3)
    bx.set_ylabel("impulse")
    bx.set_xlabel("t")
    bx.grid(True, alpha=0.3)
    return fig


# ----------------------------------------------------------------------------- rigid bodies in 3-D
def rigid_body_rates(t, omega, flips=(), labels=("ω₁", "ω₂", "ω₃"), title: Optional[str] = None,
                     flip_interval_exact: Optional[float] = None) -> Figure:
    """Body angular velocity components against time, the located flips marked."""
    t = _as_time(t, "rigid_body_rates")
    w = np.asarray(omega, float).reshape(t.size, 3)
    fig = Figure(figsize=(7.0, 3.8), layout="constrained")
    ax = fig.subplots()
    for i in range(3):
        ax.plot(t, w[:, i], lw=1.2, label=labels[i])
    for k, tf in enumerate(np.asarray(flips, float).reshape(-1)):
        ax.axvline(tf, color="0.4", lw=0.8, ls="--", label="flips" if k == 0 else None)
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.set_xlabel("t")
    ax.set_ylabel("body angular velocity")
    txt = title or "rigid body: body angular velocity"
    if flip_interval_exact is not None and np.isfinite(flip_interval_exact):
        txt += f" (analytic flip interval {flip_interval_exact:.6g})"
    ax.set_title(txt, fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="upper right")
    return fig


def heavy_top_angles(t, tilt, precession, title: Optional[str] = None) -> Figure:
    """Tilt (nutation) and precession angle of a top against time."""
    t = _as_time(t, "heavy_top_angles")
    fig = Figure(figsize=(6.4, 4.6), layout="constrained")
    ax, bx = fig.subplots(2, 1, sharex=True)
    ax.plot(t, np.asarray(tilt, float), lw=1.2, color="C0")
    ax.set_ylabel("tilt θ (rad)")
    ax.grid(True, alpha=0.3)
    ax.set_title(title or "heavy top", fontsize=10)
    bx.plot(t, np.asarray(precession, float), lw=1.2, color="C1")
    bx.set_ylabel("precession φ (rad)")
    bx.set_xlabel("t")
    bx.grid(True, alpha=0.3)
    return fig


_BOX_EDGES = [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5), (2, 6), (3, 7)]


def animate_rigid_body(t, rotations, path: str, size, momentum=None, center=None, fps: int = 20,
                       max_frames: int = 150, title: Optional[str] = None, dpi: int = ANIMATION_DPI,
                       surface=None) -> str:
    """Animate a box tumbling in 3-D (matplotlib's mplot3d) and write a GIF or an MP4.

    ``rotations`` (K, 3, 3) are the body-to-space rotations at times ``t``; the box has edges
    ``size`` along the body axes, centred at ``center`` (K, 3; the origin by default).  The body
    axes are drawn from the centre (red, green, blue for 1, 2, 3) and ``momentum`` (a fixed
    spatial vector, e.g. the angular momentum) as a black arrow.  ``surface`` ``(X, Y, Z)`` (2-D
    arrays) is drawn as a fixed wireframe, e.g. the ground under the body.  Frames are subsampled
    evenly in time to at most ``max_frames``; each is ``ANIMATION_WIDTH_IN * dpi`` pixels square (640
    by default) with the time stamped in its corner.  Returns ``path``.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    writer = _writer(path, fps)
    t = _as_time(t, "animate_rigid_body")
    R = np.asarray(rotations, float)
    if R.shape != (t.size, 3, 3) or not np.all(np.isfinite(R)):
        raise ValueError(f"animate_rigid_body: rotations must be finite with shape ({t.size}, 3, 3)")
    C = np.zeros((t.size, 3)) if center is None else np.asarray(center, float).reshape(t.size, 3)
    half = 0.5 * np.asarray(size, float).reshape(3)
    signs = np.array([(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1),
                      (-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)], float)
    corners = signs * half
    frames = _frames(t, max_frames)
    # the window follows the body (its corners and drawn axes at every frame, and the origin the
    # momentum arrow starts from), as in animate_points; the surface is clipped to it
    tips = np.concatenate([corners, np.diag(half * 1.4), -np.diag(half * 1.4)])
    moving = (C[frames, None, :] + np.einsum("kij,mj->kmi", R[frames], tips)).reshape(-1, 3)
    if momentum is not None:
        moving = np.vstack([moving, np.zeros(3)])
    lo, hi = view_window(moving, cube=True)
    side = 2 * round(ANIMATION_WIDTH_IN * dpi / 2) / dpi  # square, even pixels
    fig = Figure(figsize=(side, side), dpi=dpi)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_subplot(projection="3d")
    if surface is not None:
        X, Y, Z = (np.asarray(a, float) for a in surface)
        inside = (X >= lo[0]) & (X <= hi[0]) & (Y >= lo[1]) & (Y <= hi[1]) & (Z >= lo[2]) & (Z <= hi[2])
        ax.plot_wireframe(X, Y, np.where(inside, Z, np.nan), color="0.7", lw=0.5, rstride=1, cstride=1)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect((1, 1, 1))
    ax.tick_params(labelsize=6)
    if title:
        ax.set_title(title, fontsize=9)
    # the box, its axes and the time are animated: drawn over the static background each frame (blitting)
    edge_lines = [ax.plot([], [], [], "-", color="0.25", lw=1.2, animated=True)[0] for _ in _BOX_EDGES]
    axis_lines = [ax.plot([], [], [], "-", color=c, lw=2.0, animated=True)[0] for c in ("C3", "C2", "C0")]
    if momentum is not None:
        Lv = np.asarray(momentum, float).reshape(3)
        u = Lv / max(float(np.linalg.norm(Lv)), 1e-300)
        with np.errstate(divide="ignore", invalid="ignore"):  # the longest arrow from the origin in the window
            room = np.where(u > 0, hi / u, np.where(u < 0, lo / u, np.inf))
        Lv = u * 0.9 * float(np.min(room))
        ax.plot([0, Lv[0]], [0, Lv[1]], [0, Lv[2]], "-", color="k", lw=1.5)
        ax.text(Lv[0], Lv[1], Lv[2], "L", fontsize=8)
    stamp = ax.text2D(0.02, 0.95, "", transform=ax.transAxes, fontsize=9, animated=True)
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    with writer.saving(fig, str(path), dpi=dpi):
        for i in frames:
            P = C[i] + corners @ R[i].T
            for line, (a, b) in zip(edge_lines, _BOX_EDGES):
                line.set_data_3d([P[a, 0], P[b, 0]], [P[a, 1], P[b, 1]], [P[a, 2], P[b, 2]])
            for k, line in enumerate(axis_lines):
                tip = C[i] + R[i][:, k] * half[k] * 1.4
                line.set_data_3d([C[i, 0], tip[0]], [C[i, 1], tip[1]], [C[i, 2], tip[2]])
            stamp.set_text(time_stamp(t[i]))
            canvas.restore_region(background)
            for artist in (*edge_lines, *axis_lines, stamp):
                ax.draw_artist(artist)
            writer.grab_rgba(np.array(canvas.buffer_rgba()))
    return str(path)
