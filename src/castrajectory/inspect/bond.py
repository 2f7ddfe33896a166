"""The shape of a drop under gravity against its Bond number (issue #26): height and contact radius, 2-D and 3-D.

For each Bond number (``Bo = A / l_c²`` in 2-D, ``V^(2/3) / l_c²`` for a drop of revolution) a sessile drop
(Young's angle θ) is solved as the NLP and compared with its oracle: the closed form in elliptic integrals
(2-D; beyond its range, A > ~650 l_c² at 90°, the puddle's ``h = 2 l_c sin(θ/2)`` and ``X = (A/2 + sin θ)/h``,
exact to rounding there since κ_a < 1e-100 / l_c) or the Young–Laplace shooting (3-D).  Lengths in units of
``l_c`` (``γ_gl = ρg = 1``).  The half span ``X`` (2-D) and the contact radius ``r_c`` (3-D) are the same
column, ``radius``.

:func:`sweep` gives the rows, :func:`findings` the checks of the issue's claims (the 2-D height rises
monotonically to the puddle limit; the 3-D height overshoots it, then falls to it) measured on the
oracle's values, :func:`write_csv` / :func:`markdown` the outputs, :func:`plot` the figure (drawn by :func:`castrajectory.inspect.plotting.bond_study`).
"""
from __future__ import annotations

import csv
import math
import time
from typing import Dict, List, Optional, Sequence

import numpy as np

from ..models import droplet as md
from ..solve import droplet as dl
from . import files

#: Chords per capillary length of the NLP's profile (its edge, a boundary layer of width ~l_c, needs them
#: once the drop is a puddle), between N_MIN and N_MAX segments.
CHORDS_PER_LC = 8
N_MIN, N_MAX = 200, 3000
COLUMNS = ("dim", "bond", "measure", "n", "status", "iterations", "time_s", "height", "radius", "height_ref",
           "radius_ref", "reference", "err_height", "err_radius")


def gamma_sl(theta_deg: float) -> float:
    """γ_sl giving Young's angle ``theta_deg`` with γ_gl = γ_sg = 1 (exactly 1 at 90°: without cos's rounding,
    6e-17, the program carries no wetting term, as ``--gamma-sl 1``)."""
    c = math.cos(math.radians(theta_deg))
    return 1.0 - (0.0 if abs(c) < 1e-15 else c)


def drop(dim: str, bond: float, theta_deg: float = 90.0) -> md.Droplet:
    """The sessile drop of Bond number ``bond`` (``dim`` "2-D" or "3-D") in units of l_c."""
    ax = dim == "3-D"
    return md.Droplet(1.0, gamma_sl(theta_deg), 1.0, bond ** 1.5 if ax else bond, None, 1.0, False, ax)


def reference(d: md.Droplet) -> tuple:
    """``(height, radius, what)`` of the oracle (see the module docstring)."""
    theta = md.young_angle(d.gamma_gl, d.gamma_sl, d.gamma_sg)
    if d.axisymmetric:
        c = md.analytic(d)
        return c.height, c.contact_radius, "Young–Laplace shooting"
    try:
        c = md.analytic(d)
        return c.height, 0.5 * c.span, "closed form"
    except ValueError:  # a puddle beyond the closed form's range: its limit, exact to rounding there
        h = md.puddle_height(d)
        return h, (0.5 * d.area + math.sin(theta)) / h, "puddle (κ_a < 1e-100)"


def _segments(h: float, radius: float, dim: str) -> int:
    """N_MIN, unless the profile is longer than N_MIN l_c (the 2-D puddles from Bo ~ 300): then CHORDS_PER_LC
    chords per l_c, at most N_MAX.  (Measured: the 2-D drop at Bo = 100 on N = 600 took 600 s of continuation
    and on N = 800 did not finish in 20 minutes, against 2.9 s on N = 200, height error 1.8e-4, and 4.6 s at
    Bo = 1e3 on N = 3000; not investigated, hence no gradual rule.)"""
    arc = (2.0 if dim == "2-D" else 1.0) * (radius + h)  # the profile's length, roughly (units of l_c)
    return N_MIN if arc <= N_MIN else int(min(N_MAX, math.ceil(CHORDS_PER_LC * arc)))


def row(dim: str, bond: float, theta_deg: float = 90.0, nlp: bool = True, n: Optional[int] = None) -> dict:
    """One drop: the oracle's height and radius and (``nlp``) the NLP's, with their relative errors."""
    d = drop(dim, bond, theta_deg)
    h_ref, r_ref, what = reference(d)
    out = {"dim": dim, "bond": bond, "measure": d.area, "height_ref": h_ref, "radius_ref": r_ref,
           "reference": what, "n": 0, "status": "-", "iterations": 0, "time_s": math.nan, "height": math.nan,
           "radius": math.nan, "err_height": math.nan, "err_radius": math.nan}
    if nlp:
        n = n or _segments(h_ref, r_ref, dim)
        t0 = time.perf_counter()
        sol = dl.solve(d, n)
        radius = sol.contact_radius if d.axisymmetric else 0.5 * sol.span
        out.update(n=n, status=sol.status, iterations=sol.iterations, time_s=time.perf_counter() - t0,
                   height=sol.height, radius=radius, err_height=abs(sol.height - h_ref) / h_ref,
                   err_radius=abs(radius - r_ref) / r_ref)
    return out


def sweep(bonds: Sequence[float], dims: Sequence[str] = ("2-D", "3-D"), theta_deg: float = 90.0,
          nlp_bonds: Optional[Sequence[float]] = None, progress=None) -> List[dict]:
    """The rows over ``bonds`` for each of ``dims``; the NLP is solved at ``nlp_bonds`` (default: every one)."""
    rows = []
    for dim in dims:
        for bo in bonds:
            r = row(dim, float(bo), theta_deg, nlp=nlp_bonds is None or any(math.isclose(bo, b) for b in nlp_bonds))
            rows.append(r)
            if progress is not None:
                progress(r)
    return rows


def overshoot(theta_deg: float = 90.0, lo: float = 10.0, hi: float = 1000.0, rtol: float = 1e-4) -> dict:
    """The 3-D sessile drop's largest height (shooting) over ``V`` in ``[lo, hi]``: a 5-point grid in ``log V``
    zoomed onto its best point's neighbours until it is ``rtol`` wide.  Each zoom keeps three of its five points,
    whose shootings are not run again (45 shootings to 21 at ``rtol`` 1e-2: the default report's study from 14 s
    to 7)."""
    seen: Dict[float, float] = {}

    def height(lv: float) -> float:
        if lv not in seen:
            seen[lv] = reference(drop("3-D", math.exp(lv) ** (2.0 / 3.0), theta_deg))[0]
        return seen[lv]
    a, c = math.log(lo), math.log(hi)
    best = None
    while c - a > rtol:
        grid = np.linspace(a, c, 5)
        hs = [height(x) for x in grid]
        k = int(np.argmax(hs))
        best = (grid[k], hs[k])
        a, c = grid[max(k - 1, 0)], grid[min(k + 1, 4)]
    v = math.exp(best[0])
    return {"volume": v, "bond": v ** (2.0 / 3.0), "height": best[1],
            "excess": best[1] / (2.0 * math.sin(0.5 * math.radians(theta_deg))) - 1.0}


def findings(rows: List[dict], theta_deg: float = 90.0, peak: Optional[dict] = None) -> Dict[str, object]:
    """The issue's claims, checked on the oracle's heights (and the NLP's where solved): returns a dict of
    measured facts and ``lines`` to print."""
    limit = 2.0 * math.sin(0.5 * math.radians(theta_deg))
    out: Dict[str, object] = {"limit": limit}
    lines = [f"puddle limit 2 l_c sin(θ/2) = {limit:.10g} (θ = {theta_deg:g}°)"]
    for dim in ("2-D", "3-D"):
        sel = sorted((r for r in rows if r["dim"] == dim), key=lambda r: r["bond"])
        if len(sel) < 2:
            continue
        h = np.array([r["height_ref"] for r in sel])
        steps = np.diff(h)
        mono = bool(np.all(steps >= -1e-12 * limit))
        top = int(np.argmax(h))
        gap = limit - h[-1]
        solved = [r for r in sel if r["status"] == "ok"]
        hn = np.array([r["height"] for r in solved])
        nlp_mono = bool(np.all(np.diff(hn) >= 0.0)) if len(hn) > 1 else None
        worst = max((r["err_height"] for r in solved), default=math.nan)
        worst_r = max((r["err_radius"] for r in solved), default=math.nan)
        out[dim] = {"monotonic": mono, "nlp_monotonic": nlp_mono, "max_height": float(h[top]),
                    "max_at_bond": sel[top]["bond"], "last_gap": float(gap), "above_limit": bool(np.max(h) > limit),
                    "worst_err_height": worst, "worst_err_radius": worst_r,
                    "failed": [r["bond"] for r in sel if r["status"] not in ("ok", "-")]}
        head = (f"{dim}: height {'rises monotonically' if mono else 'is NOT monotonic'} over Bo = "
                f"{sel[0]['bond']:.3g} … {sel[-1]['bond']:.3g} (oracle)")
        if dim == "2-D":
            lines.append(head + f", never above the limit ({'yes' if h.max() <= limit * (1 + 1e-15) else 'NO'}); "
                         f"limit − h at Bo = {sel[-1]['bond']:.3g}: {gap:.2e}")
        else:
            lines.append(head + f"; largest on the grid h = {h[top]:.8f} at Bo = {sel[top]['bond']:.3g} "
                         f"(V = {sel[top]['measure']:.4g}), {'above' if h[top] > limit else 'not above'} the limit; "
                         f"h − limit at Bo = {sel[-1]['bond']:.3g} (V = {sel[-1]['measure']:.4g}, r_c = "
                         f"{sel[-1]['radius_ref']:.4g}): {-gap:.3e}, times r_c: {-gap * sel[-1]['radius_ref']:.3f}")
        if solved:
            lines.append(f"{dim}: NLP at {len(solved)} Bond numbers: worst relative error height {worst:.2e}, "
                         f"radius {worst_r:.2e}; NLP heights monotonic: {nlp_mono}")
        if out[dim]["failed"]:
            lines.append(f"{dim}: NLP FAILED at Bo = {out[dim]['failed']}")
    if peak is not None:
        out["peak"] = peak
        lines.append(f"3-D overshoot (shooting, a zoomed 5-point grid in log V): largest height {peak['height']:.8f} at "
                     f"V = {peak['volume']:.4g} l_c³ (Bo = {peak['bond']:.4g}), {100 * peak['excess']:.3f} % above "
                     "the puddle limit")
    out["lines"] = lines
    return out


def write_csv(rows: List[dict], path: str) -> None:
    def write(p):
        with open(p, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=COLUMNS)
            w.writeheader()
            for r in rows:
                w.writerow({k: r[k] for k in COLUMNS})
    files.write_atomically(path, write)


def markdown(rows: List[dict]) -> List[str]:
    """A Markdown table of the rows (oracle and NLP side by side)."""
    f = lambda v, s: "-" if not isinstance(v, (int, float)) or not math.isfinite(v) else format(v, s)  # noqa: E731
    lines = ["| dim | Bo | A or V (l_c units) | h (oracle) | X or r_c (oracle) | oracle | N | NLP status | h (NLP) "
             "| X or r_c (NLP) | h rel. err | radius rel. err | time (s) |", "|" + "---|" * 13]
    for r in rows:
        lines.append(f"| {r['dim']} | {r['bond']:.3g} | {r['measure']:.4g} | {r['height_ref']:.8f} | "
                     f"{r['radius_ref']:.6g} | {r['reference']} | {r['n'] or '-'} | {r['status']} | "
                     f"{f(r['height'], '.8f')} | {f(r['radius'], '.6g')} | {f(r['err_height'], '.1e')} | "
                     f"{f(r['err_radius'], '.1e')} | {f(r['time_s'], '.2f')} |")
    return lines


def plot(rows: List[dict], path: str, theta_deg: float = 90.0, peak: Optional[dict] = None) -> None:
    """The study's figure (:func:`castrajectory.inspect.plotting.bond_study`) written to ``path``."""
    from .plotting import bond_study
    bond_study(rows, theta_deg, peak).savefig(path, dpi=120)
