"""Stability on stiff and extreme cases, for every family: each case runs its problem script and is
judged by its own oracle.

A :class:`Case` is a command (scene and arguments) and a check: a function of the scene's JSON data
returning ``(error against the oracle, tolerance, what was compared)``.  :func:`run_case` runs it
in process and returns a :class:`Row`: the solve's outcome, iterations and time, the worst
constraint or complementarity residual the scene reports, the energy or invariant drift, the error
estimate, and whether the oracle passed.  A row passes only if the solve converged *and* the oracle
holds: a converged wrong answer is a failed row.  The report prints one table of every case
(:func:`table`); ``tests/test_stability.py`` runs each case on its own.

The tolerances are the measured errors with a margin (the measured values are in each check's
docstring or comment); they state what the case shows, not a bound on the method.
"""
from __future__ import annotations

import importlib
import math
import time
from dataclasses import dataclass
from typing import Callable, List, Optional, Tuple

import numpy as np

from .scene import SCENES

Check = Callable[[dict], Tuple[float, float, str]]


@dataclass(frozen=True)
class Case:
    family: str
    title: str
    scene: str
    argv: Tuple[str, ...]
    check: Optional[Check]
    #: "solve", or "unresolved": a grid too coarse for the motion, whose run must stop unconverged and
    #: say which N resolves it (failure reported as failure is the behaviour checked)
    expect: str = "solve"

    @property
    def command(self) -> str:
        return f"python problems/{self.scene}.py {' '.join(self.argv)}".rstrip()


@dataclass
class Row:
    case: Case
    success: bool
    status: str
    iterations: int
    time_s: float
    residual: Optional[float]
    drift: Optional[str]
    estimate: Optional[float]
    error: float
    tolerance: float
    what: str

    @property
    def passed(self) -> bool:
        return bool(self.success and math.isfinite(self.error) and self.error <= self.tolerance)


# ----------------------------------------------------------------------------- oracles
def _droplet(key: str, tol: float, what: str) -> Check:
    def check(d):
        return float(d["errors"][key]), tol, what
    return check


def _rel_energy_drift(d) -> float:
    E = np.asarray(d["energy"], float)
    return float(np.max(np.abs(E - E[0])) / max(abs(E[0]), 1e-300))


def _energy_bounded(tol: float) -> Check:
    def check(d):
        """max |E − E(0)| / |E(0)| over the run, and no growth: the second half's largest deviation is
        within twice the first half's (a drift would double it)."""
        E = np.asarray(d["energy"], float)
        dev = np.abs(E - E[0])
        half = dev.size // 2
        growth = float(np.max(dev[half:]) / max(np.max(dev[:half]), 1e-300))
        err = _rel_energy_drift(d)
        return (err if growth <= 2.0 else math.inf), tol, \
            f"energy bounded: max |E − E(0)|/|E(0)| (second half / first half {growth:.2f})"
    return check


def _rigid_pendulum(tol: float) -> Check:
    def check(d):
        """The stiff limit is the rigid pendulum: θ(t) against the pendulum of length r(0) (CVODES)."""
        from ..baselines import stepping
        from ..models import pendulum
        t, q = np.asarray(d["t"], float), np.asarray(d["q"], float)
        r0, th0 = q[0]
        sysm = pendulum.n_link_pendulum([1.0], [r0], 9.81)
        ref, _ = stepping.reference(sysm, [th0], [0.0], t[::max(1, t.size // 200)], rtol=1e-12, atol=1e-12)
        return float(np.max(np.abs(q[::max(1, t.size // 200), 1] - ref[:, 0]))), tol, \
            "θ(t) against the rigid pendulum of length r(0) (the stiff limit; CVODES)"
    return check


def _chaotic_reference(rtol: float) -> Check:
    def check(d):
        from ..baselines import stepping
        from ..models import pendulum
        q = np.asarray(d["q"], float)
        ref, _ = stepping.reference(pendulum.double_pendulum(), q[0], [0.0, 0.0], [float(d["t"][-1])],
                                    rtol=1e-13, atol=1e-13)
        scale = float(np.max(np.abs(q - q[0])))
        return float(np.max(np.abs(q[-1] - ref[-1])) / scale), rtol, \
            "θ(T) against CVODES at 1e-13, relative to the excursion (the requested rtol)"
    return check


def _contact(keys: Tuple[Tuple[str, float], ...], what: str) -> Check:
    def check(d):
        """The worst of the scene's oracle errors, each against its tolerance (reported as error/tolerance
        times the first tolerance), and no penetration (lowest gap >= -1e-9 of the length scale)."""
        worst, tol0 = 0.0, keys[0][1]
        for key, tol in keys:
            v = d.get(key)
            if v is None:
                return math.inf, tol0, f"{what} ({key} missing)"
            worst = max(worst, float(v) / tol)
        gap = d.get("min_gap")
        if gap is None and "gap" in d:
            gap = float(np.min(np.asarray(d["gap"], float)))
        if gap is not None and gap < -1e-9:
            worst = math.inf
        return worst * tol0, tol0, what
    return check


def _flip_interval(tol: float) -> Check:
    def check(d):
        exact, err = d.get("flip_interval_exact"), d.get("flip_interval_error")
        if exact is None or err is None:
            return math.inf, tol, "flip interval against 2K(m)/s (no flips measured)"
        return float(err) / float(exact), tol, \
            f"flip interval against 2K(m)/s (relative), ‖L‖ drift {d['angular_momentum_drift']:.0e}"
    return check


def _no_flip(tol: float) -> Check:
    def check(d):
        """On the intermediate axis exactly: no flip, and the rate off that axis stays at rounding."""
        w = np.asarray(d["omega"], float)
        off = float(np.max(np.abs(np.delete(w, int(d["flip_axis"]) - 1, axis=1))))
        return (off if len(d["flip_times"]) == 0 else math.inf), tol, \
            "no flip: the largest rate off the intermediate axis (rad/s)"
    return check


# ----------------------------------------------------------------------------- the cases
GSL = {2: 1.0 - math.cos(math.radians(2.0)), 90: 1.0, 178: 1.0 - math.cos(math.radians(178.0))}

CASES: List[Case] = [
    # droplet: Young's angle at the extremes, and a large N (measured errors in the comments)
    Case("droplet", "θ = 2° (nearly wetting), curve", "droplet", ("--gamma-sl", f"{GSL[2]:.12g}", "--n", "400"),
         _droplet("contact_angle", 1e-5, "contact angle against Young's (rad)")),           # 1.1e-7
    Case("droplet", "θ = 2°, graph", "droplet", ("--gamma-sl", f"{GSL[2]:.12g}", "--n", "400", "--formulation",
                                                   "graph"),
         _droplet("contact_angle", 1e-5, "contact angle against Young's (rad)")),
    Case("droplet", "θ = 90°, curve", "droplet", ("--gamma-sl", "1", "--n", "400"),
         _droplet("contact_angle", 1e-4, "contact angle against Young's (rad)")),
    Case("droplet", "θ = 178° (nearly non-wetting), curve", "droplet", ("--gamma-sl", f"{GSL[178]:.12g}", "--n", "4000"),
         _droplet("contact_angle", 1e-4, "contact angle against Young's (rad)")),           # 8.5e-4 at N = 400
    Case("droplet", "N = 10⁵, curve", "droplet", ("--n", "100000"),
         _droplet("shape", 1e-9, "shape: max distance to the analytic circle / R")),
    Case("droplet", "N = 10⁵, graph", "droplet", ("--n", "100000", "--formulation", "graph"),
         _droplet("shape", 1e-9, "shape: max distance to the analytic circle / R")),
    # stiff springs: far beyond the step's resolution of the radial motion
    Case("stiff spring", "k l/(m g) = 10⁶ (h ω ≈ 16)", "stiff_spring_pendulum", ("--ratio", "1e6"),
         _rigid_pendulum(1e-2)),
    Case("stiff spring", "k l/(m g) = 10⁸ (h ω ≈ 160)", "stiff_spring_pendulum", ("--ratio", "1e8"),
         _rigid_pendulum(1e-2)),
    # long horizon and chaos
    Case("pendulum", "1000 periods (amplitude 0.1 rad, 20 steps per period)", "n_link_pendulum",
         ("--links", "1", "--theta", "0.1", "--T", f"{1000 * 2 * math.pi / math.sqrt(9.81):.6f}", "--n", "20000"),
         _energy_bounded(1e-2)),
    Case("pendulum", "chaotic double pendulum, T = 10 s, rtol 1e-6", "double_pendulum",
         ("--scheme", "galerkin4", "--rtol", "1e-6"), _chaotic_reference(1e-6)),
]


CASES += [
    # contact: the scenes' own oracles (closed-form bounce times, apexes, the corner impact law, m g h per node)
    Case("contact", "high-speed impact (443 m/s, 100× the default)", "bouncing_ball",
         ("--velocity", "-442.9", "--T", "0.5", "--n", "1000"),
         _contact((("impact_time_error", 1e-12), ("apex_error", 1e-9)), "bounce times (s), apexes (m)")),
    Case("contact", "grazing corner (g = 0, spinning, 1e-4 m overlap of the sweep)", "rectangle_drop",
         ("--g", "0", "--y", "1.1179339887", "--angle", "0", "--vx", "0", "--vy", "0", "--omega", "2",
          "--T", "1.5", "--n", "1000"), _contact((("impact_law_error", 1e-9),), "impact law (relative)")),
    Case("contact", "resting contact (ball at rest on the ground)", "bouncing_ball",
         ("--height", "0", "--T", "1", "--n", "200"),
         _contact((("resting_impulse_error", 1e-12),), "impulse per node against m g h (relative)")),
    Case("contact", "Zeno-like bouncing, e = 0.3", "bouncing_ball", ("--restitution", "0.3", "--T", "3", "--n", "1500"),
         _contact((("impact_time_error", 1e-12), ("apex_error", 1e-12), ("resting_impulse_error", 1e-12)),
                  "bounce times (s), apexes (m), then m g h per node")),
    Case("contact", "flat rectangle landing (θ₀ = 0: two corners at once)", "rectangle_drop",
         ("--angle", "0", "--vx", "0", "--omega", "0", "--y", "1.5", "--T", "1.5", "--n", "1000"),
         _contact((("impact_law_error", 1e-9),), "simultaneous impact law (relative)")),
    Case("contact", "nearly flat landing (θ₀ = 0.01: corners 2.5 ms apart, h = 1.5 ms)", "rectangle_drop",
         ("--angle", "0.01", "--vx", "0", "--omega", "0", "--y", "1.5", "--T", "1.5", "--n", "1000"),
         _contact((("impact_law_error", 1e-9),), "sequential corner impacts, impact law (relative)")),
    Case("contact", "flatter landing (θ₀ = 1e-3: three impacts within 0.74 ms, h = 1.5 ms)", "rectangle_drop",
         ("--angle", "0.001", "--vx", "0", "--omega", "0", "--y", "1.5", "--T", "1.5", "--n", "1000"),
         _contact((("impact_law_error", 1e-9),), "impact law in a cascade within one step (relative)")),
    Case("contact", "rocking block, e = 0.5 (rocking accumulation on the edge)", "rectangle_drop",
         ("--restitution", "0.5"),
         _contact((("impact_law_error", 1e-3),), "impact law (relative; 2e-4 measured: the accumulation's last "
                                                  "bounces, nearly caught)")),
    Case("contact", "rocking block, e = 0.3", "rectangle_drop", ("--restitution", "0.3"),
         _contact((("impact_law_error", 1e-9),), "impact law (relative)")),
    # rigid bodies
    Case("rigid body", "nearly symmetric body, I = (1, 2.999, 3): flips every 391 s", "dzhanibekov",
         ("--inertia", "1", "2.999", "3", "--T", "1000", "--n", "20000"), _flip_interval(3e-3)),   # 6.3e-4
    Case("rigid body", "fast spin |ω| = 100 rad/s on the default grid (h|ω| = 2.5 rad per step)", "dzhanibekov",
         ("--omega", "1e-3", "100", "1e-3"), None, expect="unresolved"),
    Case("rigid body", "fast spin |ω| = 100 rad/s over T = 5 s (h|ω| = 0.125)", "dzhanibekov",
         ("--omega", "1e-3", "100", "1e-3", "--T", "5"), _flip_interval(1e-2)),                  # 4.3e-3
    Case("rigid body", "20 flips (T = 560 s, N = 11200)", "dzhanibekov", ("--T", "560", "--n", "11200"),
         _flip_interval(3e-3)),                                                                   # 7e-4
    Case("rigid body", "spin exactly on the intermediate axis, ω₀ = (0, 1, 0)", "dzhanibekov",
         ("--omega", "0", "1", "0"), _no_flip(1e-12)),
]


def run_case(case: Case) -> Row:
    """Run ``case`` in process through its problem script; the oracle is applied only to a converged run."""
    mod = importlib.import_module(SCENES[case.scene])
    t0 = time.perf_counter()
    out = mod.run(mod.parser().parse_args(list(case.argv)))
    wall = time.perf_counter() - t0
    d = out.data
    residual = None
    for key in ("complementarity_residual", "quaternion_norm_error", "young_residual"):
        if d.get(key) is not None:
            residual = abs(float(d[key])) if residual is None else max(residual, abs(float(d[key])))
    E = np.asarray(d["energy"], float) if d.get("energy") is not None and np.ndim(d["energy"]) == 1 else None
    if d.get("angular_momentum_drift") is not None:
        drift = f"‖L‖ {float(d['angular_momentum_drift']):.1e} relative"
    elif E is not None and case.family == "contact":  # restitution below 1 loses energy by design
        drift = f"E {E[0]:.4g} → {E[-1]:.4g}"
    elif E is not None:
        drift = f"E {float(np.max(np.abs(E - E[0])) / max(float(np.max(np.abs(E))), 1e-300)):.1e} relative"
    else:
        drift = None
    est = d.get("error_estimate") or {}
    estimate = est.get("relative") if est.get("available") else None
    if case.expect == "unresolved":
        # the run must fail, and its message must name the N that resolves the motion
        named = not out.success and "resolves it" in out.message and "N >=" in out.message
        return Row(case, True, out.status, int(out.iterations), wall, None, None, None, 0.0 if named else math.inf,
                   0.0, "fails and names the N that resolves the motion" + ("" if out.success else
                                                                           f": {out.message.split('; ')[-1]}"))
    if out.success:
        err, tol, what = case.check(d)
    else:
        err, tol, what = math.inf, math.nan, out.message
    return Row(case, bool(out.success), out.status, int(out.iterations), wall, residual, drift, estimate,
               float(err), float(tol), what)


def table(rows: List[Row]) -> List[str]:
    """The report's stability table (Markdown)."""
    f = (lambda v, s=".1e": "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else format(v, s))  # noqa: E731
    lines = ["| family | case | command | outcome | iterations | time (s) | worst residual | drift "
             "| error estimate | oracle error (tolerance) | checked |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        outcome = ("solved" if r.passed else "FAILED: " + (r.status if not r.success else "oracle missed"))
        drift = r.drift or "-"
        lines.append(f"| {r.case.family} | {r.case.title} | `{r.case.command}` | {outcome} | {r.iterations} | "
                     f"{r.time_s:.2f} | {f(r.residual)} | {drift} | {f(r.estimate)} | "
                     f"{f(r.error)} ({f(r.tolerance, '.0e')}) | {r.what} |")
    return lines
