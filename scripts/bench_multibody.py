#!/usr/bin/env python
"""Many bodies (issue 45): the cost of an n-link chain against scipy's DOP853 on the same equations.

The chain: n uniform rods (m = 1, l = 1, I = 1/12 about the centre) hung from a pin at the origin, every link at
0.5 rad from the vertical, at rest, over T = 3 s (``ct.Multibody``; the first pin at 0.5, the others straight).
Each formulation of the builder is timed:

* ``maximal``: each rod its own centre of mass and angle, each pin two constraints;
* ``joint``: the pins' angles (recursive kinematics, a dense mass matrix);

against DOP853 on the joint formulation's own equations of motion (CasADi's compiled M(q)⁻¹ f, the same model).
The reference is DOP853 at rtol 1e-13.  For each run the cheapest grid (schemes galerkin6 and galerkin8, N a
ladder) whose largest error in the joint angles at the nodes is at most the target (1e-8) is searched, and timed
warm (the compiled functions cached), the best of ``--repeat``; its time includes the error estimate's coarser grids
that every answer carries.  DOP853 is timed at the loosest rtol that reaches the target.  Printed: per n the best
run of each formulation and its ratio to DOP853, then the growth exponents fitted over n (time ∝ n^p).  Peak memory
is each process's resident high-water mark (``--memory``: one child process per run).

    python scripts/bench_multibody.py                 # n = 2, 4, 8, 16, 32
    python scripts/bench_multibody.py --links 2,4,8 --target 1e-6
"""
from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np

try:
    from scipy.integrate import solve_ivp
except ImportError:          # (scipy is in the bench extra)
    solve_ivp = None

import castrajectory as ct

T = 3.0
SCHEMES = ("galerkin6", "galerkin8")
NS = (40, 60, 90, 120, 180, 240, 360)


def chain(n: int) -> ct.Multibody:
    mb = ct.Multibody(g=9.81)
    parent, at = mb.world, (0.0, 0.0)
    for i in range(n):
        rod = mb.body(f"rod{i + 1}", 1.0, 1.0 / 12, outline=[(0.0, 0.5), (0.0, -0.5)])
        mb.revolute(parent, rod, parent_point=at, child_point=(0.0, 0.5), name=f"pin{i + 1}")
        parent, at = rod, (0.0, -0.5)
    return mb


def start(n: int):
    return np.r_[0.5, np.zeros(n - 1)], np.zeros(n)


def reference(mb, n):
    """DOP853 at rtol 1e-13 on the joint equations: a dense-output solution of the joint angles."""
    system = mb.system("joint")
    q0, v0 = start(n)
    acc = system.acceleration

    def f(t, y):
        return np.concatenate([y[n:], np.asarray(acc(y[:n], y[n:], t)).reshape(-1)])
    sol = solve_ivp(f, (0.0, T), np.concatenate([q0, v0]), method="DOP853", rtol=1e-13, atol=1e-14, dense_output=True)
    return sol.sol, f


def dop853_time(f, n, ref, target, repeat):
    """The loosest rtol (a decade ladder) whose solution is within ``target`` of the reference, and its time."""
    q0, v0 = start(n)
    for rtol in (1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12):
        best = math.inf
        for _ in range(repeat):
            t0 = time.perf_counter()
            s = solve_ivp(f, (0.0, T), np.concatenate([q0, v0]), method="DOP853", rtol=rtol, atol=rtol * 1e-2)
            best = min(best, time.perf_counter() - t0)
        err = float(np.max(np.abs(s.y[:n].T - ref(s.t)[:n].T)))
        if err <= target:
            return rtol, best, err
    return None, math.inf, math.inf


def castrajectory_run(mb, n, form, ref, target, repeat):
    """The cheapest (scheme, N) of ``form`` reaching ``target`` at the nodes, timed warm: ``(scheme, N, s, err)``."""
    system = mb.system(form)
    q0, v0 = mb.state(*start(n), formulation=form)
    best = None
    for scheme in SCHEMES:
        for N in NS:
            run = ct.simulate(system, q0, v0, T, N, scheme=scheme)
            if not run.success:
                continue
            angles = np.array([mb.joint_positions(q) for q in run.q]) if form == "maximal" else run.q
            err = float(np.max(np.abs(angles - ref(run.t)[:n].T)))
            if err > target:
                continue
            wall = math.inf
            for _ in range(repeat):
                t0 = time.perf_counter()
                ct.simulate(system, q0, v0, T, N, scheme=scheme)
                wall = min(wall, time.perf_counter() - t0)
            if best is None or wall < best[2]:
                best = (scheme, N, wall, err)
            break                        # (finer N of this scheme cost more)
    return best


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--links", default="2,4,8,16,32", help="chain lengths, comma-separated")
    p.add_argument("--target", type=float, default=1e-8, help="largest error of the joint angles at the nodes")
    p.add_argument("--repeat", type=int, default=3, help="timed runs per setting (the best counts)")
    p.add_argument("--formulations", default="maximal,joint", help="of the builder, comma-separated")
    args = p.parse_args(argv)
    if solve_ivp is None:
        print("scipy is not installed (pip install '.[bench]'): no DOP853 to compare with", file=sys.stderr)
        return 0
    try:
        links = [int(v) for v in args.links.split(",")]
    except ValueError:
        p.error("--links: integers, comma-separated")
    if any(n < 1 for n in links) or not (args.target > 0) or args.repeat < 1:
        p.error("--links >= 1, --target > 0 and --repeat >= 1")
    forms = args.formulations.split(",")
    if any(f not in ("maximal", "joint") for f in forms):
        p.error("--formulations: maximal and/or joint")
    print(f"n-link chain of rods, T = {T:g} s, target {args.target:g} (joint angles at the nodes), warm, best of "
          f"{args.repeat}")
    print(f"{'n':>4s} {'formulation':>11s} {'scheme':>10s} {'N':>5s} {'error':>9s} {'time s':>8s} {'DOP853 s':>9s} "
          f"{'rtol':>7s} {'ratio':>7s}")
    rows = []
    for n in links:
        mb = chain(n)
        ref, f = reference(mb, n)
        rtol, tdop, _ = dop853_time(f, n, ref, args.target, args.repeat)
        for form in forms:
            got = castrajectory_run(mb, n, form, ref, args.target, args.repeat)
            if got is None:
                print(f"{n:4d} {form:>11s}  no grid of {', '.join(SCHEMES)} up to N = {NS[-1]} reached the target",
                      flush=True)
                continue
            scheme, N, wall, err = got
            rows.append((n, form, wall, tdop))
            print(f"{n:4d} {form:>11s} {scheme:>10s} {N:5d} {err:9.2e} {wall:8.4f} {tdop:9.4f} {rtol:7.0e} "
                  f"{wall / tdop:7.1f}", flush=True)
    print()
    for form in forms + ["DOP853"]:
        pts = [(n, (w if form != "DOP853" else d)) for n, fo, w, d in rows if fo == (form if form != "DOP853" else forms[0])]
        if len(pts) >= 2:
            ns, ts = np.array(pts).T
            print(f"growth exponent {form}: time ∝ n^{np.polyfit(np.log(ns), np.log(ts), 1)[0]:.2f} over n = "
                  f"{int(ns[0])} ... {int(ns[-1])}")
    print("goal (issue 45): exponent at most 1.2, and the 32-link chain within 3x of DOP853")
    return 0


if __name__ == "__main__":
    sys.exit(main())
