"""Static figures (with :mod:`.animation`, the only modules that import matplotlib).

Figures are built with ``matplotlib.figure.Figure`` directly, so no GUI
backend or display is needed and nothing global is touched.
"""
from __future__ import annotations

import math
from typing import Dict, List, Optional, Sequence

import numpy as np
from matplotlib.figure import Figure

from .animation import (  # noqa: F401  (the animations, re-exported: scenes call plotting.animate_points)
    ANIMATION_DPI, ANIMATION_WIDTH_IN, PointsAnimation, _as_time, animate_points, animate_rigid_body,
    clip_polyline, mp4_available, time_stamp, view_window)

_ERROR_STYLE = {"shape": "o-", "contact_angle": "s-", "span": "^-", "energy": "v-", "pressure": "d-"}


def figure_formats() -> List[str]:
    """The file extensions a figure can be saved as (matplotlib's, lower case, sorted)."""
    return sorted(Figure().canvas.get_supported_filetypes())


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
    """The discrete drop over the analytic profile (the circle, or the heavy drop's closed form), with the
    contact angle drawn and labelled at the left contact.  A pendant drop is drawn hanging (y downwards)."""
    cap = sol.analytic
    heavy = sol.drop.rho_g > 0.0
    revolution = sol.drop.axisymmetric
    fig = Figure(figsize=(8.4, 4.2), layout="constrained")
    ax = fig.add_subplot()
    if cap is not None:
        pts = cap.points(720)
        if revolution:  # the half profile from the apex, mirrored: the drop's section, left contact at 0
            pts = np.column_stack([cap.contact_radius + np.concatenate([-pts[::-1, 0], pts[1:, 0]]),
                                   np.concatenate([pts[::-1, 1], pts[1:, 1]])])
        label = ("Young–Laplace shooting" if revolution else "closed form (elliptic integrals)") if heavy else (
            "spherical cap" if revolution else "analytic arc")
        ax.plot(pts[:, 0], pts[:, 1], "-", color="0.6", lw=3, label=label)
    sx, sy = sol.x, sol.y
    if revolution:
        sx = sol.contact_radius + np.concatenate([-sol.x[::-1], sol.x[1:]])
        sy = np.concatenate([sol.y[::-1], sol.y[1:]])
    stride = max(1, len(sx) // 200)
    size = f"degree {sol.n}" if sol.formulation == "spectral" else f"N = {sol.n}"
    ax.plot(sx, sy, "-", color="C0", lw=1.2, label=f"discrete ({sol.formulation}, {size})")
    ax.plot(sx[::stride], sy[::stride], ".", color="C0", ms=3)
    lo, hi = min(sx.min(), 0.0), max(sx.max(), sol.span if cap is None else cap.span)
    pad = 0.08 * (hi - lo)
    ax.axhline(0.0, color="k", lw=1)
    ax.fill_between([lo - pad, hi + pad], [0, 0], [-0.04 * (hi - lo)] * 2, color="0.85")
    if sol.drop.patterned:  # the pattern, centred under the drop
        mid, half = (sol.contact_radius if revolution else 0.5 * sol.span), 0.5 * sol.drop.pattern_width
        ax.fill_between([mid - half, mid + half], [0, 0], [-0.04 * (hi - lo)] * 2, color="C2", alpha=0.5,
                        label=f"pattern (γ_sl = {sol.drop.gamma_sl:g}; outside {sol.drop.gamma_sl_out:g})")
    _mark_contact_angle(ax, (sx[0], sy[0]), sol.contact_angle, 0.15 * (hi - lo))
    ax.set_aspect("equal")
    ax.set_xlabel("x (a section through the axis)" if revolution else "x")
    ax.set_ylabel("y (down from the ceiling)" if sol.drop.pendant else "y")
    if sol.drop.pendant:
        ax.invert_yaxis()
    if sol.drop.patterned:
        mode = (f"{'of revolution ' if revolution else ''}on a patterned table, width {sol.drop.pattern_width:g}, "
                f"{sol.pattern['regime'] if sol.pattern else ''}")
    elif revolution:
        mode = (f"of revolution, volume {sol.drop.area:g}, "
                + (f"{'pendant' if sol.drop.pendant else 'sessile'}, Bond number {sol.drop.bond_number:.4g}"
                   if heavy else "weightless"))
    elif heavy:
        mode = (f"{'pendant' if sol.drop.pendant else 'sessile'} under gravity, Bond number "
                f"{sol.drop.bond_number:.4g}")
    else:
        mode = "free span (Young)" if sol.drop.span is None else f"pinned span a = {sol.drop.span:g}"
    closed = "" if cap is None else f" (analytic {math.degrees(cap.contact_angle):.4f}°)"
    shape = f", shape error {sol.errors['shape']:.1e}" if "shape" in sol.errors else ""
    ax.set_title(f"Droplet, {mode}, {sol.formulation}, {size}\n"
                 f"θ = {math.degrees(sol.contact_angle):.4f}°{closed}{shape}", fontsize=10)
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


def bond_study(rows: List[dict], theta_deg: float = 90.0, peak: Optional[dict] = None) -> Figure:
    """The shape-against-Bond study (:mod:`castrajectory.inspect.bond`): height and contact radius (2-D: half
    span) against Bo, the oracle as lines and the NLP as markers, the puddle limit and the 3-D peak."""
    limit = 2.0 * math.sin(0.5 * math.radians(theta_deg))
    fig = Figure(figsize=(11.0, 4.2), layout="constrained")
    ax_h, ax_r = fig.subplots(1, 2)
    for dim, color in (("2-D", "C0"), ("3-D", "C3")):
        sel = sorted((r for r in rows if r["dim"] == dim), key=lambda r: r["bond"])
        if not sel:
            continue
        bo = np.array([r["bond"] for r in sel])
        ax_h.semilogx(bo, [r["height_ref"] for r in sel], "-", color=color, lw=1.2, label=f"{dim}, oracle")
        ax_r.loglog(bo, [r["radius_ref"] for r in sel], "-", color=color, lw=1.2, label=f"{dim}, oracle")
        ok = [r for r in sel if r["status"] == "ok"]
        ax_h.semilogx([r["bond"] for r in ok], [r["height"] for r in ok], "o", color=color, mfc="none", ms=6,
                      label=f"{dim}, NLP")
        ax_r.loglog([r["bond"] for r in ok], [r["radius"] for r in ok], "o", color=color, mfc="none", ms=6,
                    label=f"{dim}, NLP")
    ax_h.axhline(limit, color="k", ls="--", lw=0.8, label="puddle limit 2 l_c sin(θ/2)")
    if peak is not None:
        ax_h.plot([peak["bond"]], [peak["height"]], "k*", ms=9,
                  label=f"3-D peak: V = {peak['volume']:.3g} l_c³, h = {peak['height']:.4f}")
    ax_h.set_xlabel("Bond number (2-D A/l_c², 3-D V^(2/3)/l_c²)")
    ax_h.set_ylabel("height h / l_c")
    ax_h.set_title(f"height against Bo (θ = {theta_deg:g}°)")
    ax_r.set_xlabel("Bond number")
    ax_r.set_ylabel("2-D half span X, 3-D contact radius r_c (/ l_c)")
    ax_r.set_title("contact radius against Bo")
    for ax in (ax_h, ax_r):
        ax.grid(True, which="major", alpha=0.3)
        ax.legend(fontsize=7)
    return fig


# ----------------------------------------------------------------------------- trajectories
# The functions below return a Figure and leave saving to the caller
# (``fig.savefig(path)``); nothing global is touched.

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


def energy_quantities_plot(t, energies: Dict[str, np.ndarray], quantities: Dict[str, np.ndarray],
                           title: Optional[str] = None, relative: bool = True) -> Figure:
    """:func:`energy_plot` with a second panel: the declared quantities of a system against time, each
    as its change from its first value (a conserved one is a flat line at rounding level)."""
    if not quantities:
        return energy_plot(t, energies, title, relative)
    fig = Figure(figsize=(6.4, 6.4), layout="constrained")
    ax, bx = fig.subplots(2, 1)
    _energy_axes(ax, t, energies, relative)
    ax.set_title(title or "Energy error", fontsize=10)
    for name, y in quantities.items():
        y = np.asarray(y, float).reshape(-1)
        bx.plot(np.asarray(t, float)[:y.size], y - y[0], lw=1.2, label=name)
    bx.axhline(0.0, color="0.5", lw=0.8)
    bx.set_xlabel("t")
    bx.set_ylabel("change from t = 0")
    bx.set_title("declared quantities", fontsize=10)
    bx.grid(True, alpha=0.3)
    bx.legend(fontsize=8)
    return fig


def control_plot(t, q, names: Sequence[str], u, control_names: Sequence[str], title: Optional[str] = None,
                 exact_u=None, t_u=None) -> Figure:
    """An optimal control's answer: the configuration against time, and the controls -- constant per step
    (one value per step: drawn as steps) or at the control points ``t_u`` (drawn through them) -- with a
    closed-form control ``exact_u(t)`` dashed where one exists."""
    t = np.asarray(t, float)
    q, u = np.atleast_2d(np.asarray(q, float)), np.asarray(u, float)
    u = u.reshape(u.shape[0], -1)
    fig = Figure(figsize=(6.4, 6.0), layout="constrained")
    ax, bx = fig.subplots(2, 1, sharex=True)
    for j in range(q.shape[1]):
        ax.plot(t, q[:, j], lw=1.2, label=names[j] if j < len(names) else f"q{j}")
    ax.set_ylabel("q")
    ax.grid(True, alpha=0.3)
    if q.shape[1] <= _MAX_LEGEND:
        ax.legend(fontsize=8)
    ax.set_title(title or "optimal control", fontsize=10)
    for j in range(u.shape[1]):
        label = control_names[j] if j < len(control_names) else f"u{j}"
        if u.shape[0] == t.size - 1:
            bx.stairs(u[:, j], t, lw=1.2, label=label)
        else:
            bx.plot(np.asarray(t_u, float), u[:, j], ".-", lw=1.0, ms=3, label=label)
    if exact_u is not None:
        tt = np.linspace(t[0], t[-1], 400)
        bx.plot(tt, exact_u(tt), "k--", lw=0.9, label="closed form")
    bx.set_xlabel("t")
    bx.set_ylabel("u")
    bx.grid(True, alpha=0.3)
    if u.shape[1] or exact_u is not None:      # (a problem without controls: no legend, and no warning on stderr)
        bx.legend(fontsize=8)
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


#: the colours of the contact states on the intervals' timeline (contact_plot)
STATE_COLOURS = {"open": "0.88", "held": "C0", "stick": "C2", "slide+": "C1", "slide-": "C3", "slide": "C1"}


def contact_plot(t, series: Dict[str, np.ndarray], t_impulse, impulses, reference: Optional[Dict[str, tuple]] = None,
                 ylabel: str = "height", title: Optional[str] = None, impacts: Optional[dict] = None,
                 intervals: Optional[Dict[str, list]] = None) -> Figure:
    """A contact trajectory: curves against time (with analytic references) over a stem plot of impulses.

    ``series`` maps labels to values at ``t``; ``reference`` maps labels to
    ``(t_ref, y_ref)`` drawn dashed; ``impulses`` (at ``t_impulse``) go in the
    lower panel.  ``impacts`` (the keyword arguments of :func:`impacts_axes`:
    ``outlines``, ``times``, ``ground``, ...) adds a panel on the left with the
    body drawn at its impacts over the ground; it is the figure's first axes.  ``intervals`` (contact name ->
    ``[(from, to, state), ...]``, :attr:`ContactTrajectory.intervals`) adds a timeline of each contact's states
    (open, held, stick, slide) under the impulses.
    """
    rows = 3 if intervals else 2
    ratios = [2, 1, 0.25 + 0.25 * len(intervals)] if intervals else [2, 1]
    if impacts is None:
        fig = Figure(figsize=(6.4, 5.2 + (1.0 if intervals else 0.0)), layout="constrained")
        axes = fig.subplots(rows, 1, sharex=True, height_ratios=ratios)
        ax, bx = axes[0], axes[1]
    else:
        fig = Figure(figsize=(13.0, 5.2 + (1.0 if intervals else 0.0)), layout="constrained")
        grid = fig.add_gridspec(rows, 2, width_ratios=[1.15, 1.0], height_ratios=ratios)
        sx = fig.add_subplot(grid[:, 0])
        impacts_axes(sx, **impacts)
        sx.set_title("the body at its impacts", fontsize=10)
        ax = fig.add_subplot(grid[0, 1])
        bx = fig.add_subplot(grid[1, 1], sharex=ax)
        axes = [ax, bx] + ([fig.add_subplot(grid[2, 1], sharex=ax)] if intervals else [])
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
    bx.grid(True, alpha=0.3)
    if intervals:
        bx.tick_params(labelbottom=False)
        _intervals_axes(axes[2], intervals)
    else:
        bx.set_xlabel("t")
    return fig


def _intervals_axes(ax, intervals: Dict[str, list]) -> None:
    """One bar per contact, coloured by its state over each interval (:data:`STATE_COLOURS`)."""
    names = list(intervals)
    seen = set()
    for row, name in enumerate(names):
        for a, b, state in intervals[name]:
            label = state if state not in seen else None
            seen.add(state)
            ax.broken_barh([(a, b - a)], (row - 0.4, 0.8), facecolors=STATE_COLOURS.get(state, "0.5"), label=label)
    ax.set_yticks(range(len(names)))
    ax.set_yticklabels(names, fontsize=8)
    ax.set_ylim(-0.6, len(names) - 0.4)
    ax.set_xlabel("t")
    ax.legend(fontsize=7, ncol=6, loc="upper center", bbox_to_anchor=(0.5, -0.45), frameon=False)


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


def poincare_section(t, theta, omega, period: float, t0: float = 0.0):
    """The state sampled once per drive ``period`` (at ``t0 + j·period`` inside the run): ``(θ wrapped to
    (−π, π], θ̇)``, each interpolated between the nodes by the cubic Hermite polynomial of ``(θ, θ̇)``."""
    t, th, om = (np.asarray(a, float) for a in (t, theta, omega))
    ts = t0 + period * np.arange(int(math.floor((t[-1] - t0) / period + 1e-9)) + 1)
    ts = ts[(ts >= t[0]) & (ts <= t[-1])]
    k = np.clip(np.searchsorted(t, ts, side="right") - 1, 0, t.size - 2)
    h = t[k + 1] - t[k]
    s = (ts - t[k]) / h
    h00, h10, h01, h11 = 2 * s ** 3 - 3 * s ** 2 + 1, s ** 3 - 2 * s ** 2 + s, -2 * s ** 3 + 3 * s ** 2, s ** 3 - s ** 2
    x = h00 * th[k] + h10 * h * om[k] + h01 * th[k + 1] + h11 * h * om[k + 1]
    # the rate from the derivative of the same cubic
    d00, d10, d01, d11 = 6 * s ** 2 - 6 * s, 3 * s ** 2 - 4 * s + 1, -6 * s ** 2 + 6 * s, 3 * s ** 2 - 2 * s
    v = (d00 * th[k] + d10 * h * om[k] + d01 * th[k + 1] + d11 * h * om[k + 1]) / h
    return ts, np.angle(np.exp(1j * x)), v


def poincare_plot(t, theta, omega, period: float, title: Optional[str] = None, skip: int = 0) -> Figure:
    """The angle against time and the Poincaré section of ``(θ, θ̇)`` sampled once per drive period
    (:func:`poincare_section`; the first ``skip`` samples, the transient, left out)."""
    ts, x, v = poincare_section(t, theta, omega, period)
    fig = Figure(figsize=(10.0, 4.2), layout="constrained")
    a1, a2 = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.4, 1]})
    a1.plot(t, theta, lw=0.8)
    a1.set_xlabel("t")
    a1.set_ylabel("θ (rad)")
    a1.set_title("angle", fontsize=10)
    a2.plot(x[skip:], v[skip:], ".", ms=2.0 if x.size > 500 else 4.0, color="C3")
    a2.set_xlim(-math.pi, math.pi)
    a2.set_xlabel("θ mod 2π (rad)")
    a2.set_ylabel("θ̇ (rad/s)")
    a2.set_title(f"Poincaré section: {max(x.size - skip, 0)} points, one per drive period", fontsize=10)
    if title:
        fig.suptitle(title, fontsize=11)
    return fig
