"""The top of the report: one line per exercise, read from the scenes' JSON."""
from __future__ import annotations

import json
import math
import os
from typing import List


def lines(out: str, stability_line: str) -> List[str]:
    """The top of the report: what was solved, how accurately, at what cost; one line per exercise,
    read from the scenes' JSON written below."""
    def load(stem):
        try:
            with open(os.path.join(out, f"{stem}.json")) as fh:
                return json.load(fh)
        except (OSError, ValueError):
            return None

    def cost(d):
        if "solve_time_s" not in d:
            return "closed form"
        return f"{d.get('build_time_s', 0.0) + d['solve_time_s']:.3f} s, {d.get('iterations', 0)} iterations"

    rows = []
    d = load("droplet_curve")
    if d:
        rows.append(("2.1 droplet (free span, θ = 60°)", f"θ = {math.degrees(d['contact_angle']):.6f}°, pressure "
                     f"{d['pressure']:.6f}", f"angle {d['errors']['contact_angle']:.1e} rad, pressure "
                     f"{d['errors']['pressure']:.1e} (relative) against the circle and Young", cost(d)))
    d = load("collision_impulse")
    if d:
        law = abs(d["corner_normal_velocity_after"] + d["restitution"] * d["corner_normal_velocity_before"])
        rows.append(("2.2 collision (corner impact, e = 1)", f"μ = {d['mu']:.6f}",
                     f"impact law to {law:.1e} m/s, kinetic energy {d['ke_before']:g} → {d['ke_after']:.12g} J",
                     cost(d)))
    d = load("bouncing_ball")
    if d:
        rows.append(("contact (bouncing ball, N = 3000)", f"{len(d['impacts'])} impacts",
                     f"bounce times {d['impact_time_error']:.1e} s against the closed form", cost(d)))
    d = load("double_pendulum_galerkin4")
    if d:
        e = d["error_estimate"]
        rows.append(("2.3 least action (double pendulum, galerkin4, T = 5 s)", f"θ(T) = {d['q'][-1][0]:.6f}, "
                     f"{d['q'][-1][1]:.6f}", f"estimated {e['relative']:.1e} relative (Richardson)", cost(d)))
    d = load("thrown_ball")
    if d:
        rows.append(("2.3 least action (thrown ball, two-point boundary)", "the parabola",
                     f"{d['parabola_error']:.1e} m against it", cost(d)))
    d = load("dzhanibekov")
    if d and d.get("flip_interval_error") is not None:
        rows.append(("3-D rigid body (Dzhanibekov flip)", f"{len(d['flip_times'])} flips, interval "
                     f"{d['flip_interval']:.6f} s", f"{d['flip_interval_error'] / d['flip_interval_exact']:.1e} "
                     "relative against 2K(m)/s", cost(d)))
    return ["| exercise | answer | accuracy | cost |", "|---|---|---|---|",
            *[f"| {a} | {b} | {c} | {t} |" for a, b, c, t in rows], "", stability_line, ""]
