"""The contact battery's scenes: drawn from a seed, each solved and checked against the oracle (issue 13).

:func:`draw_scenes` draws the scenes (plain dicts; :func:`draw_friction_scenes` the friction families,
:func:`draw_scheme_scenes` the pendulum at a joint limit and the double pendulum at a wall for every scheme of
order >= 4), :func:`run_scene` solves one and checks its residuals and impact times against the event-driven
reference (:func:`check_twins` then compares each scheme scene's twin at 2N with it), and :func:`battery_task` is the task
a sweep's executor runs (:func:`castrajectory.inspect.study.run_tasks`): one scene in a child
Python process with a time limit.  ``scripts/contact_battery.py`` runs the battery and writes its
report.  This module holds the frictionless families and the runner; the friction families are
:mod:`.friction`, the every-scheme family :mod:`.schemes`, and what they share :mod:`.common`.

The child is a fresh interpreter (``python -c``), not a fork: it runs the same way in this
process, in a process pool's worker and in a Dask worker (daemonic processes cannot fork
``multiprocessing`` children, and forking a process with threads is unsafe), so a scene's row is
the same whichever executor ran it.  It costs about 0.2 s of interpreter start per scene, outside
the scene's ``time_s``.
"""
from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time

import numpy as np

from .common import COMP_TOL, ENERGY_TOL, GAP_TOL, LAW_TOL, NS, G, _rect_clearance  # noqa: F401
from .friction import (  # noqa: F401  (the friction families)
    FRICTION_FAMILIES, IMPACT_FRICTION_FAMILIES, FRICTION_NS, draw_friction_scenes, coulomb_residuals,
    impact_residuals, FRICTION_TOL, FRICTION_PATH_STEPS, FRICTION_CONE, STICK_ROUNDING, run_friction_scene,
    STOP_TIME_TOL, IMPACT_TIME_TOL, BOUNCE_TOL, IMPACT_ENERGY_TOL, IMPACT_CONE_TOL, TWIN_FLOOR, TWIN_SLACK,
    ORACLE_MARGIN_STEPS, REBOUND_STEPS, ARRIVAL_MARGIN, round_bounce, spin_drop_oracle,
    run_impact_friction_scene, check_friction_twins, reference_order, ORDER_FLOOR)
from .schemes import (  # noqa: F401  (every scheme of order >= 4)
    SCHEME_SET, SCHEME_FAMILIES, SCHEME_NS, SCHEME_SEPARATION, SCHEME_APPROACH, SCHEME_ARRIVAL, SCHEME_CLEARANCE,
    TIME_C, TIME_FLOOR, SCHEME_LAW_TOL, ENERGY_C, ENERGY_FLOOR, joint_limit_pendulum, double_pendulum_wall,
    build_scheme_scene, screen_scheme_scene, draw_scheme_scenes, run_scheme_scene, check_twins, fitted_order)


# ----------------------------------------------------------------------------- scenes
def draw_scenes(seed: int, count: int):
    rng = np.random.default_rng(seed)
    scenes = []
    for i in range(count):
        fam = ("ball", "rectangle", "bowl")[i % 3]
        e = float(rng.choice([0.0, 1.0])) if rng.random() < 0.2 else float(np.round(rng.uniform(0, 1), 3))
        N = int(rng.choice(NS))
        if fam == "ball":
            sc = dict(family=fam, e=e, height=float(np.round(rng.uniform(0.2, 3.0), 3)),
                      velocity=float(np.round(rng.uniform(-2, 2), 3)), T=float(np.round(rng.uniform(1.0, 5.0), 2)))
        elif fam == "rectangle":
            w = 1.0
            ratio = float(np.round(rng.uniform(1.0, 4.0), 3))
            th = float(np.round(rng.uniform(0, math.pi / 2), 4))
            hgt = w / ratio if rng.random() < 0.5 else w
            wid = w if hgt != w else w * ratio
            y = _rect_clearance(wid, hgt, th) + float(np.round(rng.uniform(0.1, 1.5), 3))
            sc = dict(family=fam, e=e, width=wid, height=hgt, x=0.0, y=y, angle=th,
                      vx=float(np.round(rng.uniform(-1, 1), 3)), vy=0.0,
                      omega=float(np.round(rng.uniform(-3, 3), 3)), T=float(np.round(rng.uniform(1.5, 3.0), 2)))
        else:
            R = float(np.round(rng.uniform(1.0, 4.0), 3))
            wid, hgt = 0.4, 0.2
            th = float(np.round(rng.uniform(-0.6, 0.6), 4))
            x = float(np.round(rng.uniform(-0.4, 0.4) * R, 3))
            # above the bowl by a clearance, every corner included
            y = x * x / (2 * R) + math.hypot(wid, hgt) / 2 + abs(x) / R * 0.5 + float(np.round(rng.uniform(0.05, 0.6), 3))
            sc = dict(family=fam, e=e, width=wid, height=hgt, x=x, y=y, angle=th, vx=0.0, vy=0.0,
                      omega=float(np.round(rng.uniform(-2, 2), 3)), radius=R, T=float(np.round(rng.uniform(1.5, 3.0), 2)))
        sc["N"] = N
        sc["id"] = f"{i:03d}"
        scenes.append(sc)
        if i % 10 == 9:
            twin = dict(sc, N=2 * N, id=f"{i:03d}x2", twin_of=sc["id"])
            scenes.append(twin)
    return scenes


def build(sc):
    from ...models import collision as col

    if sc["family"] == "ball":
        return col.bouncing_ball(1.0, G, sc["e"]), np.array([sc["height"]]), np.array([sc["velocity"]])
    if sc["family"] == "rectangle":
        system = col.rectangle_drop(1.0, sc["width"], sc["height"], G, sc["e"])
    else:
        system = col.bowl(1.0, sc["width"], sc["height"], G, sc["e"], sc["radius"])
    return system, np.array([sc["x"], sc["y"], sc["angle"]]), np.array([sc["vx"], sc["vy"], sc["omega"]])


def command(sc) -> str:
    if sc["family"] in SCHEME_FAMILIES + IMPACT_FRICTION_FAMILIES:   # no problem script: through run_scene
        skip = ("id", "twin_of")
        scene = json.dumps({k: v for k, v in sc.items() if k not in skip})
        return f"python -c 'from castrajectory.inspect.battery import run_scene; print(run_scene({scene}))'"
    scheme = f" --scheme {sc['scheme']}" if sc.get("scheme") else ""
    if sc["family"] == "incline":
        return (f"python problems/sliding_block.py --mu {sc['mu']} --incline {sc['alpha']} --v0 {sc['v0']} "
                f"--T {sc['T']} --n {sc['N']}{scheme}")
    if sc["family"] == "rolling":
        return (f"python problems/rolling_ball.py --body {sc['body']} --mu {sc['mu']} --v0 {sc['v0']} "
                f"--spin {sc['spin']} --T {sc['T']} --n {sc['N']}{scheme}")
    if sc["family"] == "ball":
        return (f"python problems/bouncing_ball.py --restitution {sc['e']} --height {sc['height']} "
                f"--velocity {sc['velocity']} --T {sc['T']} --n {sc['N']}")
    script = "rectangle_drop" if sc["family"] == "rectangle" else "bowl"
    extra = f" --radius {sc['radius']}" if sc["family"] == "bowl" else ""
    return (f"python problems/{script}.py --restitution {sc['e']} --width {sc['width']} --height {sc['height']} "
            f"--x {sc['x']} --y {sc['y']!r} --angle {sc['angle']} --vx {sc['vx']} --vy {sc['vy']} "
            f"--omega {sc['omega']} --T {sc['T']} --n {sc['N']}{extra}")


# ----------------------------------------------------------------------------- one scene, checked
def impact_time_error(tr, ref, h: float) -> float:
    """Max over the oracle's resolvable impacts of |t − t_oracle| to the nearest listed impact of the
    same contact (inf if the solution lists none)."""
    evs = [ev for ev in ref.events if ev.t <= min(tr.t[-1], ref.horizon)]
    if not evs:
        return 0.0
    times = np.array([ev.t for ev in evs])
    gaps = np.diff(np.concatenate([[-np.inf], times, [np.inf]]))
    ok = (gaps[:-1] >= 3 * h) & (gaps[1:] >= 3 * h) & (times <= tr.t[-1] - 3 * h)
    worst = 0.0
    for ev, use in zip(evs, ok):
        if not use:
            continue
        cand = [abs(i.t - ev.t) for i in tr.impacts if i.contact in ev.contacts]
        worst = max(worst, min(cand) if cand else math.inf)
    return worst


def run_scene(sc) -> dict:
    from ...baselines.events import event_driven
    from ...solve import trajectory

    if sc["family"] in ("incline", "rolling"):
        return run_friction_scene(sc)
    if sc["family"] in IMPACT_FRICTION_FAMILIES:
        return run_impact_friction_scene(sc)
    if sc["family"] in SCHEME_FAMILIES:
        return run_scheme_scene(sc)
    system, q0, v0 = build(sc)
    t0 = time.perf_counter()
    tr = trajectory.solve_initial_value(system, q0, v0, sc["T"], sc["N"])
    wall = time.perf_counter() - t0
    out = {"status": tr.status, "success": bool(tr.success), "iterations": int(tr.iterations), "time_s": wall}
    h = sc["T"] / sc["N"]
    ell = max(1.0, float(np.max(np.abs(q0))))
    M = np.asarray(system.mass_matrix(q0))
    vref = max(float(np.max(np.abs(v0))), math.sqrt(G * ell))
    pref = float(np.max(np.diag(M))) * vref
    gaps = np.concatenate([np.asarray(tr.gap).reshape(-1), np.asarray(tr.gap_sub).reshape(-1)])
    out["min_gap"] = float(np.min(gaps))
    comp = max(float(np.max(np.abs(np.asarray(tr.gap) * np.asarray(tr.nu)))),
               float(np.max(np.abs(np.asarray(tr.gap_sub) * np.asarray(tr.mu)))))
    out["complementarity"] = comp / (ell * pref)
    e = sc["e"]
    law, resolvable = 0.0, 0
    acc = np.asarray(system.acceleration(q0, v0)).reshape(-1)
    for imp in tr.impacts:
        J = np.asarray(system.gap(imp.q)[1])[imp.contact]
        vb, va = float(J @ imp.v_before), float(J @ imp.v_after)
        if getattr(imp, "caught", False):
            # a catch is the discrete end of an accumulation only where the bounce would come back
            # within two steps (e |v_n⁻| < |a_n| h); a slower-than-that catch is a wrong answer
            resolvable += int(e * abs(vb) >= abs(float(J @ acc)) * h)
            continue
        law = max(law, abs(va + e * vb) / max(abs(vb), 1e-300))
    out["impact_law"] = law
    out["impacts"] = len(tr.impacts)
    out["caught"] = sum(1 for i in tr.impacts if getattr(i, "caught", False))
    out["resolvable_catches"] = resolvable
    E = np.asarray(tr.energy)
    out["energy_change"] = float(np.max(np.abs(E - E[0])) / abs(E[0])) if e == 1.0 else math.nan
    ref = event_driven(system, q0, v0, sc["T"])
    out["oracle_impacts"] = len(ref.events)
    out["oracle_horizon"] = ref.horizon
    out["impact_time_error"] = impact_time_error(tr, ref, h) if tr.success else math.nan
    checks = (out["min_gap"] >= -GAP_TOL * ell and out["complementarity"] <= COMP_TOL and law <= LAW_TOL
              and resolvable == 0 and (e != 1.0 or out["energy_change"] <= ENERGY_TOL))
    out["checks"] = bool(checks)
    out["solved"] = bool(tr.success and checks)
    return out


# ----------------------------------------------------------------------------- one scene in a child process
_CHILD = "from castrajectory.inspect.battery import _child_main; _child_main()"


def battery_task(task) -> dict:
    """``(scene, timeout)`` -> the scene's row: the scene's fields, :func:`run_scene`'s results and its
    ``command``.  The scene runs in a child Python process stopped after ``timeout`` seconds (``None``: no
    limit, as the report runs it: a wall-clock limit judges the machine's load, not the scene, and every solve
    stops at its iteration limit); a crash, an exception or a timeout gives a row with ``solved = False`` and the
    reason as ``status``."""
    sc, timeout = task
    res = _run_in_child(sc, None if timeout is None else float(timeout))
    return {**sc, **res, "command": command(sc)}


#: The environment variable that gives the child its parent's process id (see :func:`_end_with_parent`).
_PARENT = "CASTRAJECTORY_BATTERY_PARENT"


def _run_in_child(sc, timeout) -> dict:
    try:
        p = subprocess.run([sys.executable, "-c", _CHILD], input=json.dumps(sc), capture_output=True,
                           text=True, timeout=timeout, env={**os.environ, _PARENT: str(os.getpid())})
    except subprocess.TimeoutExpired:
        return {"status": f"timeout ({timeout:g} s)", "success": False, "solved": False, "time_s": timeout}
    if p.returncode == 0 and p.stdout.strip():
        return json.loads(p.stdout)
    last = (p.stderr.strip().splitlines() or [""])[-1]
    return {"status": f"crashed (exit {p.returncode}) {last}"[:200].strip(), "success": False, "solved": False}


def _child_main() -> None:
    """The child: a scene as JSON on stdin, its results as JSON on the original stdout (anything the
    solver prints goes to stderr)."""
    _end_with_parent()
    out = os.fdopen(os.dup(1), "w")
    os.dup2(2, 1)
    sc = json.loads(sys.stdin.read())
    try:
        res = run_scene(sc)
    except Exception as exc:  # noqa: BLE001 - reported as a failed row, not a crash of the battery
        res = {"status": f"error: {type(exc).__name__}: {exc}"[:200], "success": False, "solved": False}
    json.dump(res, out)
    out.flush()


def _end_with_parent() -> None:
    """The child ends (SIGTERM) when the process that started it ends: a sweep stopped by Ctrl-C ends its pool's
    workers with SIGTERM, and their scenes' children would otherwise run on as orphans to the end of their
    scene or its time limit (Linux's ``PR_SET_PDEATHSIG``; elsewhere nothing).  A parent that ended before the
    call ends the child now."""
    parent = os.environ.get(_PARENT)
    if not sys.platform.startswith("linux") or not parent:
        return
    try:
        import ctypes

        if ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGTERM), 0, 0, 0) != 0:   # 1: PR_SET_PDEATHSIG
            return
    except (OSError, AttributeError):
        return
    if os.getppid() != int(parent):
        os._exit(1)
