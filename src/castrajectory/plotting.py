"""Plots (the only module that imports matplotlib).

Figures are built with ``matplotlib.figure.Figure`` directly, so no GUI
backend or display is needed and nothing global is touched.
"""
from __future__ import annotations

import math
from typing import List

import numpy as np
from matplotlib.figure import Figure

_ERROR_STYLE = {"shape": "o-", "contact_angle": "s-", "span": "^-", "energy": "v-", "pressure": "d-"}


def droplet_shape(sol, path: str) -> None:
    """The discrete drop over the analytic circle, with the contact angles."""
    cap = sol.analytic
    fig = Figure(figsize=(7.0, 4.2), layout="constrained")
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
    ax.set_aspect("equal")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    mode = "free span (Young)" if sol.drop.span is None else f"pinned span a = {sol.drop.span:g}"
    ax.set_title(f"Droplet, {mode}, {sol.formulation}, N = {sol.n}\n"
                 f"θ = {math.degrees(sol.contact_angle):.4f}° (analytic {math.degrees(cap.contact_angle):.4f}°), "
                 f"shape error {sol.errors['shape']:.1e}", fontsize=10)
    ax.legend(loc="upper right", fontsize=8)
    fig.savefig(path, dpi=130)


def reduced_energy(sol, path: str) -> None:
    """E(θ) of the reduced problem with the optimum and Young's angle marked."""
    th = np.linspace(0.02, math.pi - 0.02, 600)
    E = np.array([float(sol.energy_function(t)) for t in th])
    fig = Figure(figsize=(6.4, 4.0), layout="constrained")
    ax = fig.add_subplot()
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
    ax.set_title("Reduced droplet energy E(θ) = 2R(θ)(γ_gl θ + (γ_sl − γ_sg) sin θ)")
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=130)


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
