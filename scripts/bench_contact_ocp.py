#!/usr/bin/env python
"""Benchmark of contact-implicit optimal control: castrajectory against nosnoc, measured in one run.

This is a benchmark, not a test: it measures and reports, and exits with status 0 (2 for bad flags).  PASS/MISS
lines say whether a goal was met in *this* run on *this* machine.

Problem: the push to a target (nosnoc's inelastic 2-D OCP): a unit point mass from rest at (0, 1.5) falls onto the
floor (restitution 0, μ = 0.6) and a horizontal force |u| <= 10 brings it to (3, 0) at rest at T = 2, minimising
∫u² dt.  The reference J_ref is castrajectory's own, certified, on a ladder of grids (N = 80, 160, 320),
extrapolated at its fitted order.  castrajectory: a sweep over N (midpoint, the whole MPCC with the exact-penalty
homotopy, every answer certified by the contact march), wall time (build + solve, a fresh problem each run) and
|J − J_ref|.  nosnoc (the ``nosnoc`` package of the ``bench`` extra; skipped with a message without it): its own
formulation of the same problem (scripts/nosnoc_ocp.py: time freezing, FESD Radau IIA, Scholtes homotopy) at its
example's defaults and at its tightest setting, its cost, time and complementarity; nosnoc gives no certificate.

The hopper (problems/hopper.py; nosnoc's hopper_ocp), with --hopper: castrajectory at N = 20 (one step per stage of
nosnoc's 20 control stages, as the push's comparison) and at its default N = 40 (two steps per stage), each
certified, and nosnoc at its example's defaults and its tightest setting, their costs and times and the ratios.
Each lands in a local optimum of its own (nosnoc's stance does not slip, castrajectory's may), so no accuracy is
equal: the ratio is of the times to each one's answer, castrajectory's certified.  The hopper is run at its default
goal (most goals certify, #27's note): no reference.  The script prints castrajectory's ceiling: Ipopt's time per
iteration times its first round's iterations.  Measured (three runs, nosnoc's default 26.6 to 28.9 s): N = 20
certifies 11.038 in 2.3 to 2.6 s, 10.9x to 11.8x; N = 40 11.220 in 6.7 to 8.7 s, 3.3x to 4.0x, whose first round
alone (341 iterations) caps it at 10x to 12x.

Goal (issue #27): a certified cost within 1e-6 of the reference at least 10x faster than nosnoc at equal accuracy.
Measured: nosnoc lands in a local optimum of its own (82.66, on its 20 control stages), castrajectory in a lower one
(67.96 on the same 20 steps), so no accuracy is equal: the script compares the time to a certified cost at or below
nosnoc's.  The cost converges at order 2 (controls constant per step, contacts switching inside steps), so 1e-6 of
the reference needs N of several thousand: the sweep prints that ceiling.

    python scripts/bench_contact_ocp.py
    python scripts/bench_contact_ocp.py --quick
"""
from __future__ import annotations

import argparse
import importlib.util
import math
import os
import pathlib
import sys
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")



HERE = pathlib.Path(__file__).resolve().parent


def _module(path: pathlib.Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def push(N: int):
    """The push to a target (problems/push_to_target.py, its defaults) on N steps: (answer, wall time)."""
    _, ocp = _module(HERE.parent / "problems" / "push_to_target.py", "push_to_target").problem(
        1.5, 3.0, 0.6, 10.0, 2.0, 9.81, N)
    t0 = time.perf_counter()
    sol = ocp.solve()
    return sol, time.perf_counter() - t0


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="a shorter sweep and nosnoc's defaults only")
    p.add_argument("--hopper", action="store_true", help="also run the hopper, against nosnoc's")
    args = p.parse_args(argv)
    grids = (20, 40, 80, 160) if args.quick else (20, 40, 80, 160, 320, 640)
    print("push to a target: castrajectory (midpoint, certified) against nosnoc, one run")
    rows, sols = [], {}
    for N in grids:
        sol, wall = push(N)
        sols[N] = sol
        rows.append({"label": "castrajectory", "n": N, "time_s": wall, "success": sol.success, "cost": sol.cost,
                     "certificate": sol.certificate})
    # the reference: the three finest certified answers, extrapolated at their fitted order
    fine = [r for r in rows if r["success"]][-3:]
    J = [r["cost"] for r in fine]
    order = math.log2((J[0] - J[1]) / (J[1] - J[2])) if len(J) == 3 and (J[1] - J[2]) != 0 else 2.0
    J_ref = J[-1] - (J[-2] - J[-1]) / (2 ** order - 1)
    print(f"reference J_ref = {J_ref:.10g} (N = {fine[-1]['n']}, fitted order {order:.2f}, extrapolated)")
    print(f"  {'N':>5s} {'status':12s} {'cost':>14s} {'|J - J_ref|':>12s} {'time s':>8s} {'certificate':>11s}")
    for r in rows:
        r["error"] = abs(r["cost"] - J_ref) if r["success"] else math.nan
        print(f"  {r['n']:5d} {'ok' if r['success'] else 'failed':12s} {r['cost']:14.10g} {r['error']:12.3e} "
              f"{r['time_s']:8.3f} {r['certificate']:11.1e}")
    nmax = fine[-1]["n"]
    err_max = abs(J[-1] - J_ref)
    need = nmax * (err_max / 1e-6) ** (1 / max(order, 1e-3))
    print(f"ceiling: 1e-6 of J_ref needs N ~ {need:.0f} at order {order:.2f} (not run: the finest here, N = {nmax}, "
          f"is {err_max:.1e} away)")
    peer = _module(HERE / "nosnoc_ocp.py", "nosnoc_ocp")
    if not peer.available():
        print("nosnoc is not installed (pip install castrajectory[bench]): the comparison is skipped")
        return 0
    print("\nnosnoc (time freezing, FESD, Scholtes homotopy; no certificate):")
    print(f"  {'setting':8s} {'status':24s} {'cost':>14s} {'|J - J_ref|':>12s} {'time s':>8s} {'build s':>8s} "
          f"{'compl':>9s} {'landing err':>11s}")
    verdict = []
    for setting in (("default",) if args.quick else ("default", "tight")):
        r = peer.push_to_target(20, setting)
        err = abs(r.get("cost", math.nan) - J_ref)
        land = abs(r.get("landing_time", math.nan) - math.sqrt(3 / 9.81))
        print(f"  {setting:8s} {str(r['status'])[:24]:24s} {r.get('cost', math.nan):14.10g} {err:12.3e} "
              f"{r.get('time_s', math.nan):8.2f} {r.get('build_s', math.nan):8.2f} "
              f"{r.get('complementarity', math.nan):9.1e} {land:11.1e}")
        if r["status"] == "ok" and math.isfinite(err):
            verdict.append((setting, r))
    # nosnoc's answers are a local optimum of their own (82.66 at its 20 control stages, against castrajectory's
    # 67.96 on the same 20 steps), so "equal accuracy" against one reference does not apply: the comparison is the
    # time to a certified cost at least as low as nosnoc's, and the same control grid
    print("\ncastrajectory's time to a certified cost at or below nosnoc's (the first such N of the sweep):")
    for setting, r in verdict:
        theirs = r["time_s"] + r.get("build_s", 0.0)
        first = next((row for row in rows if row["success"] and row["cost"] <= r["cost"]), None)
        if first is None:
            print(f"  nosnoc {setting}: cost {r['cost']:.8g} in {theirs:.2f} s; no certified castrajectory answer as low")
            continue
        ratio = theirs / first["time_s"]
        print(f"  nosnoc {setting}: cost {r['cost']:.8g} in {theirs:.2f} s (complementarity "
              f"{r.get('complementarity', math.nan):.0e}, no certificate); castrajectory N = {first['n']}: "
              f"{first['cost']:.8g} in {first['time_s']:.3f} s, certified {first['certificate']:.0e}: ratio "
              f"{ratio:.0f}x  {'PASS' if ratio >= 10 else 'MISS'} (goal 10x)")
    print("(nosnoc's 1e-6 of castrajectory's reference is not reached by either: nosnoc stays at its own optimum, "
          "castrajectory's cost converges at order 2 -- the ceiling above)")
    if args.hopper:
        hop = _module(HERE.parent / "problems" / "hopper.py", "hopper")
        runs = []
        for N in (20, 40):
            ocp = hop.problem(N=N)
            t0 = time.perf_counter()
            sol = ocp.solve(guess=ocp.guess)
            wall = time.perf_counter() - t0
            runs.append((N, sol, wall))
            print(f"\nhopper: castrajectory N = {N}: {sol.status}, cost {sol.cost:.8g}, {wall:.2f} s, certificate "
                  f"{sol.certificate:.1e}, complementarity {sol.complementarity:.1e}")
            # the ceiling: Ipopt's time per iteration times the first timing round's iterations (the least any
            # answer from this guess takes); the rest is the later rounds, the polish and the marches
            its = sum(h.iterations for h in sol.homotopy)
            ipopt = sum(h.solve_time_s for h in sol.homotopy)
            first = sol.homotopy[0].iterations if sol.homotopy else 0
            per = ipopt / max(its, 1)
            print(f"hopper: castrajectory's time: Ipopt {ipopt:.2f} s over {its} iterations ({1e3 * per:.1f} ms "
                  f"each), the rest (build, marches, certificate) {wall - ipopt:.2f} s; its first round alone, "
                  f"{first} iterations, takes {first * per:.2f} s: the ceiling of the ratio below at this cost per "
                  f"iteration")
        for setting in (("default",) if args.quick else ("default", "tight")):
            r = peer.hopper(setting)
            theirs = r.get("time_s", math.nan) + r.get("build_s", 0.0)
            print(f"hopper: nosnoc {setting}: {r['status']}, cost {r.get('cost', math.nan):.8g}, {theirs:.2f} s "
                  f"(build included), complementarity {r.get('complementarity', math.nan):.1e}, no certificate")
            for N, sol, wall in runs:
                ratio = theirs / wall if sol.success and r["status"] == "ok" else math.nan
                print(f"  castrajectory N = {N}: time ratio {ratio:.1f}x {'PASS' if ratio >= 10 else 'MISS'} (goal "
                      f"10x); cost {sol.cost - r.get('cost', math.nan):+.3g} from nosnoc's (two local optima"
                      f"{'; the same 20 control stages' if N == 20 else ''})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
