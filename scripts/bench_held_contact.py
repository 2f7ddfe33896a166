"""Held contact at the scheme's order: time to a target accuracy against the event-driven reference (issue 44).

Two held-contact scenes with closed forms:

* the disk rolling in a circular bowl (μ = 1, φ₀ = 0.5, T = 2 s): the configuration against the reduced equation
  (3/2)(R − r) φ̈ = −g sin φ (Gragg–Bulirsch–Stoer, order 16, at 1 ms);
* the ladder sliding down a frictionless wall (θ₀ = 70°, T = 0.5 s): its lift-off from the wall against the closed
  form sin θ* = ⅔ sin θ₀, and its angle before it against the reduced motion.

For each target (1e-8 and 1e-10) the cheapest castrajectory run that reaches it is searched over the schemes and a
ladder of grids (``simulate``, warm: the compiled functions cached, the best of three runs); its time includes the
error estimate's two coarser grids, which every answer carries.  The event-driven reference
(``baselines.events.event_driven``, phases of the index-1 contact dynamics flown by GBS extrapolation, each event
bisected to rounding) is timed on the same scene; its own error is printed too.  The ratio is castrajectory's time
over the reference's, measured in the same run.

The peers MuJoCo and pymunk (the ``bench`` extra) are not compared here yet: both are penalty or impulse-based
time-steppers whose held contacts are first order at best; their comparison on these scenes is left for a later
session (a message says so).

    python scripts/bench_held_contact.py
"""
from __future__ import annotations

import math
import time

import numpy as np

import castrajectory as ct
from castrajectory.baselines.events import event_driven, gbs_step
from castrajectory.models import held

SCHEMES = ("galerkin4", "galerkin6", "galerkin8")
TARGETS = (1e-8, 1e-10)


def _best_of(fn, repeats=3):
    best, out = math.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def disk_error(run, phi0=0.5, r=0.2, R=1.0, g=9.81) -> float:
    Rr = R - r
    f = lambda y: np.array([y[1], -g * math.sin(y[0]) / (1.5 * Rr)])  # noqa: E731
    y, now, phis = np.array([phi0, 0.0]), 0.0, []
    for tt in run.t:
        while now < tt:
            H = min(1e-3, tt - now)
            y, now = gbs_step(f, y, H), now + H
        phis.append(y[0])
    phi = np.array(phis)
    ref = np.stack([Rr * np.sin(phi), -Rr * np.cos(phi), -Rr * (phi - phi0) / r], axis=1)
    return float(np.max(np.abs(run.q - ref)))


def ladder_error(run, theta0=math.radians(70.0)) -> float:
    t_star, _ = held.ladder_lift_off(theta0)
    rel = [x for x in run.detail.releases if x.contact == 0]
    if not rel:
        return math.inf
    before = run.t < t_star
    th = held.ladder_angle(run.t[before], theta0)
    return max(abs(rel[0].t - t_star), float(np.max(np.abs(run.q[before, 2] - th))))


def scenes():
    disk = held.disk_in_bowl(mu=1.0)
    ladder = held.sliding_ladder()
    return [("rolling disk (configuration)", disk, *held.disk_start(0.5), 2.0, disk_error),
            ("sliding ladder (lift-off time, angle)", ladder, *held.ladder_start(math.radians(70.0)), 0.5, ladder_error)]


def cheapest(system, q0, v0, T, error_of, target):
    """The cheapest (time, scheme, N, error) over the schemes and grids N = 4·2^k that reaches ``target``."""
    best = None
    for scheme in SCHEMES:
        N = 4
        while N <= 4096:
            run = ct.simulate(system, q0, v0, T, N, scheme=scheme)
            err = error_of(run) if run.success else math.inf
            if err <= target:
                wall, _ = _best_of(lambda: ct.simulate(system, q0, v0, T, N, scheme=scheme))
                if best is None or wall < best[0]:
                    best = (wall, scheme, N, err)
                break
            N *= 2
    return best


def main():
    print("held contact: castrajectory (warm, the best of 3, with its error estimate) against the event-driven "
          "reference (baselines.events), on 2 cores")
    print("MuJoCo, pymunk: not compared on these scenes in this script yet (see its docstring)")
    print(f"{'scene':40s} {'target':>8s} {'scheme':>10s} {'N':>5s} {'error':>9s} {'time s':>8s} "
          f"{'ref s':>8s} {'ref err':>9s} {'ratio':>7s}")
    for name, system, q0, v0, T, error_of in scenes():
        ref_time, ref = _best_of(lambda: event_driven(system, np.array(q0, float), np.array(v0, float), T))
        ref_err = _reference_error(name, ref, T)
        for target in TARGETS:
            got = cheapest(system, q0, v0, T, error_of, target)
            if got is None:
                print(f"{name:40s} {target:8.0e} {'-':>10s} not reached within N = 4096")
                continue
            wall, scheme, N, err = got
            print(f"{name:40s} {target:8.0e} {scheme:>10s} {N:5d} {err:9.2e} {wall:8.4f} {ref_time:8.4f} "
                  f"{ref_err:9.2e} {wall / ref_time:7.1f}")
    print("ceiling: a castrajectory answer is one solve of its grid and two of the coarser grids of its error estimate, "
          "each a march of compiled steps and a certificate (a sparse QR of the whole branch); the reference flies "
          "each phase in closed-form steps without an estimate.")


def _reference_error(name, ref, T) -> float:
    if name.startswith("rolling"):
        class R:
            t = np.linspace(0.0, T, 41)
            q = np.array([ref.state(t)[0] for t in np.linspace(0.0, T, 41)])
        return disk_error(R)
    t_star, _ = held.ladder_lift_off(math.radians(70.0))
    lifts = [s.t for s in ref.switches if s.kind == "lift-off" and s.contact == 0]
    return abs(lifts[0] - t_star) if lifts else math.inf


if __name__ == "__main__":
    main()
