"""A stability case: a command (a scene and its arguments) and its oracle, with the oracles the scenes use.

A :class:`Case` is declared with its scene in the registry (:mod:`castrajectory.cli.registry`) and run
by :mod:`castrajectory.cli.stability`.  A check is a function of the scene's JSON data returning
``(error against the oracle, tolerance, what was compared)``; the tolerances are the measured errors
with a margin.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Optional, Tuple

import numpy as np

Check = Callable[[dict], Tuple[float, float, str]]


@dataclass(frozen=True)
class Case:
    family: str
    title: str
    scene: str
    argv: Tuple[str, ...]
    check: Optional[Check]
    #: "solve", or "unresolved": a grid too coarse for the motion, whose run must stop unconverged and
    #: say which N resolves it (failure reported as failure is the behaviour checked), or "no_stable_drop":
    #: a pendant drop beyond its family's fold, whose run must end with that verdict (status No_Stable_Drop)
    #: and whose check judges the fold it found
    expect: str = "solve"
    #: over a few seconds: tests/test_stability.py marks it slow (the report runs it regardless)
    slow: bool = False

    @property
    def command(self) -> str:
        return f"python problems/{self.scene}.py {' '.join(self.argv)}".rstrip()



# ----------------------------------------------------------------------------- oracles
def droplet_check(key: str, tol: float, what: str) -> Check:
    def check(d):
        return float(d["errors"][key]), tol, what
    return check


def puddle_check(theta_deg: float, tol: float) -> Check:
    def check(d):
        """A 2-D puddle (κ_a below 1e-100 / l_c, beyond the closed form's range): its span against the force
        balance X = (ρg A/2 + γ sin θ)/P with P = ρg h∞, h∞ = 2 l_c sin(θ/2), and the pressure at the table
        against ρg h∞ (relative; the worse of the two).  The height itself is not judged: the edge, one l_c
        wide, lies inside a chord or two (measured at Bo = 1e4, N = 2000: 11 % high)."""
        rho_g, lc, bo = float(d["gravity"]), float(d["capillary_length"]), float(d["bond_number"])
        gamma, area = rho_g * lc ** 2, bo * lc ** 2
        theta = math.radians(theta_deg)
        p_inf = rho_g * 2.0 * lc * math.sin(0.5 * theta)
        span = 2.0 * (0.5 * rho_g * area + gamma * math.sin(theta)) / p_inf
        err = max(abs(float(d["span"]) - span) / span, abs(float(d["pressure"]) - p_inf) / p_inf)
        return err, tol, (f"span and pressure against the puddle's force balance (relative; height "
                          f"{float(d['height']) / (2.0 * lc * math.sin(0.5 * theta)) - 1.0:+.2f} off 2 l_c sin(θ/2): "
                          "the edge is unresolved)")
    return check


def _rel_energy_drift(d) -> float:
    E = np.asarray(d["energy"], float)
    return float(np.max(np.abs(E - E[0])) / max(abs(E[0]), 1e-300))


def energy_bounded(tol: float) -> Check:
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


def rigid_pendulum(tol: float) -> Check:
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


def chaotic_reference(rtol: float) -> Check:
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


def contact_check(keys: Tuple[Tuple[str, float], ...], what: str) -> Check:
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


def flip_interval(tol: float) -> Check:
    def check(d):
        exact, err = d.get("flip_interval_exact"), d.get("flip_interval_error")
        if exact is None or err is None:
            return math.inf, tol, "flip interval against 2K(m)/s (no flips measured)"
        return float(err) / float(exact), tol, \
            f"flip interval against 2K(m)/s (relative), ‖L‖ drift {d['angular_momentum_drift']:.0e}"
    return check


def no_flip(tol: float) -> Check:
    def check(d):
        """On the intermediate axis exactly: no flip, and the rate off that axis stays at rounding."""
        w = np.asarray(d["omega"], float)
        off = float(np.max(np.abs(np.delete(w, int(d["flip_axis"]) - 1, axis=1))))
        return (off if len(d["flip_times"]) == 0 else math.inf), tol, \
            "no flip: the largest rate off the intermediate axis (rad/s)"
    return check
