"""The every-scheme family of the contact battery (issue #25): the pendulum at a joint limit and the double
pendulum at a wall, for every scheme of order >= 4, against the event-driven reference."""
from __future__ import annotations

import math
import time

import numpy as np

from .common import GAP_TOL, G, _check_twins


# ----------------------------------------------------------------------------- every scheme of order >= 4
#: the scheme family (issue #25): each scene solved with one of these, at N drawn from SCHEME_NS, and
#: again at 2N (its twin)
SCHEME_SET = ("galerkin4", "gauss4", "galerkin6", "gauss6", "galerkin8")
SCHEME_FAMILIES = ("pendulum", "double_pendulum")
SCHEME_NS = (100, 200, 400)
#: a drawn scene is kept when the reference holds to T (no accumulation) and, on its flight out to
#: T + SCHEME_SEPARATION coarsest steps: every impact (and t = 0, T) at least SCHEME_SEPARATION of the
#: coarsest steps h = T / min(SCHEME_NS) from the next, every arrival at least SCHEME_APPROACH sqrt(g ℓ) fast
#: (ℓ = 1) and SCHEME_ARRIVAL times faster than the slowest arrival the solver lists as an impact
#: (MarchOptions.impact_speed_steps steps' worth of the normal acceleration, |J q̈| h: slower is resting contact), and every
#: turn short of the contact at least SCHEME_CLEARANCE ℓ away from it; else it is drawn again
SCHEME_SEPARATION, SCHEME_APPROACH, SCHEME_ARRIVAL, SCHEME_CLEARANCE = 10, 0.1, 2.0, 1e-2
#: the checks: impact times within max(TIME_C h^p, TIME_FLOOR) s of the reference (h in s), Newton's law
#: to SCHEME_LAW_TOL relative, node energies within max(ENERGY_C h^p, ENERGY_FLOOR) × m g ℓ of the
#: reference's flight energy, no penetration beyond GAP_TOL ℓ.  Over 120 scenes and their twins (seeds 1 to 5
#: and 13) the time errors reached at most 0.18 of their tolerance (0.21 h^p where above the floor), the
#: energies 0.12 (1.8 h^p where above the floor)
TIME_C = 2.0
TIME_FLOOR = 1e-12
SCHEME_LAW_TOL = 1e-8
ENERGY_C = 30.0
ENERGY_FLOOR = 1e-10


def joint_limit_pendulum(limit: float, e: float):
    """A unit pendulum (length 1, mass 1) under gravity with the joint limit θ ≤ ``limit``."""
    import casadi as ca
    from ...models.contact import Contact
    from ...models.mechanics import Atoms, Gravity, LagrangianSystem
    th = ca.SX.sym("th", 1)
    return LagrangianSystem(th, Atoms([ca.vertcat(ca.sin(th[0]), -ca.cos(th[0]))], [1.0]), [Gravity(G)],
                            names=["theta"], contact=Contact([limit - th[0]], restitution=e))


def double_pendulum_wall(wall: float, e: float):
    """A unit double pendulum (lengths and masses 1) under gravity whose second bob meets the wall x = ``wall``."""
    import casadi as ca
    from ...models.contact import Contact
    from ...models.mechanics import Atoms, Gravity, LagrangianSystem
    th = ca.SX.sym("th", 2)
    p1 = ca.vertcat(ca.sin(th[0]), -ca.cos(th[0]))
    p2 = p1 + ca.vertcat(ca.sin(th[1]), -ca.cos(th[1]))
    return LagrangianSystem(th, Atoms([p1, p2], [1.0, 1.0]), [Gravity(G)], names=["th1", "th2"],
                            contact=Contact([wall - p2[0]], restitution=e, names=["wall"]))


def build_scheme_scene(sc):
    """``(system, q0, v0)`` of a scheme-family scene."""
    system = joint_limit_pendulum(sc["limit"], sc["e"]) if sc["family"] == "pendulum" else \
        double_pendulum_wall(sc["wall"], sc["e"])
    return system, np.array(sc["q0"], float), np.array(sc["v0"], float)


def screen_scheme_scene(sc):
    """Why a drawn scene is not kept (None when it is): the reference must hold to T and its impacts stay
    resolvable by every grid drawn (see SCHEME_SEPARATION, SCHEME_APPROACH, SCHEME_ARRIVAL, SCHEME_CLEARANCE)."""
    from ...baselines.events import event_driven
    from ...solve.contact import MarchOptions
    speed_steps = MarchOptions().impact_speed_steps        # (the solver's, at the battery's default settings)

    system, q0, v0 = build_scheme_scene(sc)
    T = sc["T"]
    sep = SCHEME_SEPARATION * T / min(SCHEME_NS)
    ref = event_driven(system, q0, v0, T + sep)
    if ref.reason != "horizon":
        return f"accumulation at t = {ref.horizon:.3g} s"
    times = np.array([ev.t for ev in ref.events])
    if not ref.events or times[0] > T:
        return "no impact"
    if np.any(np.diff(np.concatenate([[0.0], times])) < sep) or np.any(np.abs(times - T) < sep):
        return "impacts closer than the separation (or to 0, T)"
    h = T / min(SCHEME_NS)
    for ev in ref.events:
        J = np.asarray(system.gap(ev.q)[1])
        an = np.abs(J @ np.asarray(system.acceleration(ev.q, ev.v_before)).reshape(-1))
        slow = np.maximum(SCHEME_APPROACH * math.sqrt(G), SCHEME_ARRIVAL * speed_steps * an * h)
        if any(-float(J[j] @ ev.v_before) < slow[j] for j in ev.contacts):
            return f"a slow arrival at t = {ev.t:.3g} s"
    if _turn_clearance(system, ref, T + sep) < SCHEME_CLEARANCE:
        return "a turn near the contact"
    return None


def _turn_clearance(system, ref, T: float, dt: float = 1e-2) -> float:
    """The smallest gap at a local minimum inside a flight of the reference (a turn short of the contact),
    sampled every ``dt`` seconds along the reference's flight to ``T``."""
    c = system.contact.count
    starts = [(0.0, ref.q0, ref.v0)] + [(ev.t, ev.q, ev.v_after) for ev in ref.events]
    ends = [ev.t for ev in ref.events] + [T]
    worst = math.inf
    for (t0, q, v), t1 in zip(starts, ends):
        n = max(int(math.ceil((t1 - t0) / dt)), 2)
        step = (t1 - t0) / n
        gaps = [np.asarray(system.gap(q)[0]).reshape(c)]
        for _ in range(n):
            q, v = ref.flight(q, v, step)
            gaps.append(np.asarray(system.gap(q)[0]).reshape(c))
        g = np.array(gaps)
        turn = (g[1:-1] <= g[:-2]) & (g[1:-1] <= g[2:])
        if np.any(turn):
            worst = min(worst, float(np.min(g[1:-1][turn])))
    return worst


def draw_scheme_scenes(seed: int, count: int):
    """The scheme families (issue #25), alternating: the unit pendulum against a joint limit (limit in [0.2, 1.2],
    θ₀ in [−1.5, −0.3] at rest or at a rate in [−0.5, 0.5], T in [2, 4]) and the unit double pendulum from rest
    whose second bob meets a wall (θ₁ in [−1.5, −0.3], θ₂ in [−1.5, 0.3], the wall at 40 to 100 % of the bob's
    starting distance from the axis, at least 0.2; T in [2, 3]); e in [0.3, 0.95].  A draw the screen refuses
    (:func:`screen_scheme_scene`) is drawn again from the same generator.  The schemes take turns through
    SCHEME_SET (each family meets each scheme within ten scenes), N is drawn from SCHEME_NS, and every scene
    has its twin at 2N."""
    rng = np.random.default_rng(seed)
    scenes = []
    for i in range(count):
        fam = ("pendulum", "double_pendulum")[i % 2]
        scheme = SCHEME_SET[i % len(SCHEME_SET)]
        N = int(rng.choice(SCHEME_NS))
        for _ in range(200):
            e = float(np.round(rng.uniform(0.3, 0.95), 3))
            if fam == "pendulum":
                rate = 0.0 if rng.random() < 0.5 else float(np.round(rng.uniform(-0.5, 0.5), 3))
                sc = dict(family=fam, e=e, limit=float(np.round(rng.uniform(0.2, 1.2), 3)),
                          q0=[float(np.round(rng.uniform(-1.5, -0.3), 3))], v0=[rate],
                          T=float(np.round(rng.uniform(2.0, 4.0), 2)))
            else:
                th = [float(np.round(rng.uniform(-1.5, -0.3), 3)), float(np.round(rng.uniform(-1.5, 0.3), 3))]
                reach = abs(math.sin(th[0]) + math.sin(th[1]))
                sc = dict(family=fam, e=e, wall=float(np.round(max(rng.uniform(0.4, 1.0) * reach, 0.2), 3)),
                          q0=th, v0=[0.0, 0.0], T=float(np.round(rng.uniform(2.0, 3.0), 2)))
            if screen_scheme_scene(sc) is None:
                break
        else:
            raise RuntimeError(f"draw_scheme_scenes: no acceptable {fam} scene in 200 draws (seed {seed}, scene {i})")
        sc.update(scheme=scheme, N=N, id=f"s{i:03d}")
        scenes.append(sc)
        scenes.append(dict(sc, N=2 * N, id=f"s{i:03d}x2", twin_of=sc["id"]))
    return scenes


def run_scheme_scene(sc) -> dict:
    """One scheme-family scene solved and checked against the event-driven reference: every impact matched in
    order (same count, same contact), impact times within max(TIME_C h^p, TIME_FLOOR), Newton's law at every
    impact (a catch fails: the screened scenes have none), node energies on each flight within
    max(ENERGY_C h^p, ENERGY_FLOOR) m g ℓ of the reference's energy of that flight, no penetration.  The twin
    comparison needs both rows: :func:`check_twins`."""
    from ...baselines.events import event_driven
    from ...discretise.schemes import listing
    from ...solve import trajectory

    system, q0, v0 = build_scheme_scene(sc)
    T, N = sc["T"], sc["N"]
    h, order = T / N, listing()[sc["scheme"]]
    t0 = time.perf_counter()
    tr = trajectory.solve_initial_value(system, q0, v0, T, N, scheme=sc["scheme"])
    wall = time.perf_counter() - t0
    out = {"status": tr.status, "success": bool(tr.success), "iterations": int(tr.iterations), "time_s": wall,
           "order": order, "time_tol": max(TIME_C * h ** order, TIME_FLOOR)}
    ref = event_driven(system, q0, v0, T)
    imps = sorted(tr.impacts, key=lambda i: i.t)
    out.update(oracle_impacts=len(ref.events), impacts=len(imps), caught=sum(1 for i in imps if i.caught))
    if not tr.success:
        out.update(checks=False, solved=False, failed="solve")
        return out
    matched = len(imps) == len(ref.events) and all(i.contact in ev.contacts for i, ev in zip(imps, ref.events))
    out["impact_time_error"] = max((abs(i.t - ev.t) for i, ev in zip(imps, ref.events)), default=0.0) \
        if matched else math.inf
    law = 0.0
    for imp in imps:
        J = np.asarray(system.gap(imp.q)[1])[imp.contact]
        vb, va = float(J @ imp.v_before), float(J @ imp.v_after)
        law = max(law, math.inf if imp.caught else abs(va + sc["e"] * vb) / max(abs(vb), 1e-300))
    out["impact_law"] = law
    mgl = G * len(q0) * len(q0)      # masses and lengths 1: m g ℓ of the whole chain
    out["energy_tol"] = max(ENERGY_C * h ** order, ENERGY_FLOOR)
    if matched:
        # each node's flight: the number of impacts at or before it (a node at an impact carries the momentum after it)
        Eref = system.energies(np.vstack([q0] + [ev.q for ev in ref.events]),
                               np.vstack([v0] + [ev.v_after for ev in ref.events]))
        seg = np.searchsorted(np.array([i.t for i in imps]), np.asarray(tr.t), side="right")
        out["energy_error"] = float(np.max(np.abs(np.asarray(tr.energy) - Eref[seg]))) / mgl
    else:
        out["energy_error"] = math.nan
    out["min_gap"] = float(min(np.min(tr.gap), np.min(tr.gap_sub)))
    failed = [name for name, bad in (
        ("impacts matched", not matched), ("impact times", not out["impact_time_error"] <= out["time_tol"]),
        ("Newton's law", not law <= SCHEME_LAW_TOL), ("energy", not out["energy_error"] <= out["energy_tol"]),
        ("gap", out["min_gap"] < -GAP_TOL)) if bad]
    out.update(checks=not failed, solved=not failed, failed=", ".join(failed))
    return out


def check_twins(rows) -> None:
    """The scheme twins, on the impact-time error: no worse, or both at TIME_FLOOR."""
    _check_twins(rows, {"impact_time_error": TIME_FLOOR}, 0.0)


def fitted_order(coarse: dict, fine: dict) -> float:
    """log2 of the impact-time error ratio of a pair (N, 2N), where both are above TIME_FLOOR (else nan)."""
    a, b = coarse.get("impact_time_error", math.nan), fine.get("impact_time_error", math.nan)
    if not (isinstance(a, float) and isinstance(b, float) and a > TIME_FLOOR and b > TIME_FLOOR
            and math.isfinite(a) and math.isfinite(b)):
        return math.nan
    return math.log2(a / b)
