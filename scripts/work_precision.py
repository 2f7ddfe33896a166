#!/usr/bin/env python
"""Work–precision study of the trajectory methods on the chaotic double pendulum.

Double pendulum (unit masses and lengths, g = 9.81) from rest at
``θ = (θ1, θ2)`` (default (2, 1) rad, chaotic) over ``[0, T]`` (default 5 s).
Every method × scheme is run over a doubling sweep of step counts ``N``:

* ``whole`` (the library: one NLP for the whole trajectory) × midpoint, trapezoid, galerkin4;
* ``march`` (the same variational integrators marched step by step) × midpoint, trapezoid, galerkin4;
* ``rk4`` and ``implicit-euler`` (the classical baselines).

Per run: the final-state error ``max_i |q_i(T) − q_ref,i(T)|`` against CVODES
(``stepping.reference`` at rtol = atol = 1e-14; its distance to the
1e-15 solution is printed as the error floor), the largest energy error
``max_k |E_k − E(q0, q̇0)|``, build and solve times.  Writes
``work_precision.csv``, ``work_precision_error.png`` (final error against
build + solve time), ``work_precision_energy.png`` (max energy error against
time) and ``work_precision_panels.png`` (both side by side) into ``--out``;
prints the table, the observed orders (log-log slope of the final error
against N over the three finest runs with
1e-11 < error < 1e-2 before the error stops decreasing; a stall is reported), each method's time to reach a final
error of 1e-8 (log-log interpolation between the bracketing runs) and the
ratio whole-galerkin4 / rk4 at 1e-8.

Runs go one after another in this process (fair wall times), each with a
fresh system, after one untimed warm-up run per method; ``--workers N`` runs
them on a local pool of N processes and ``--dask-scheduler ADDRESS`` on a Dask
cluster (same errors, but the times then disturb each other).  BLAS threads are
pinned to 1 unless the caller set them.  Exit code 1 if any run failed.

    python scripts/work_precision.py --out out/
    python scripts/work_precision.py --quick --out out/
    python scripts/work_precision.py --quick --workers 2 --out out/
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time

BLAS_THREAD_VARS = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
for _var in BLAS_THREAD_VARS:
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from castrajectory.models import pendulum  # noqa: E402
from castrajectory.cli import sweeps  # noqa: E402
from castrajectory.inspect import plotting, study  # noqa: E402
from castrajectory.baselines import stepping  # noqa: E402

PROG = "work_precision.py"
TARGET = 1e-8
#: CVODES tolerance of the reference: at 1e-13 the double pendulum's q(5) is off by
#: ~1.5e-10 (measured against 1e-14 / 1e-15 and RK4 at 128 000 steps), too close to
#: the errors studied here; at 1e-14 it agrees with 1e-15 to ~2e-12.
REFERENCE_RTOL = 1e-14
SCHEMES = ("midpoint", "trapezoid", "galerkin4")
METHODS_SCHEMES = ([("whole", s) for s in SCHEMES] + [("march", s) for s in SCHEMES]
                   + [("rk4", None), ("implicit-euler", None)])


def doubling(lo: int, hi: int):
    ns = [lo]
    while ns[-1] * 2 <= hi:
        ns.append(ns[-1] * 2)
    return ns


def sizes(quick: bool) -> dict:
    """Step counts per method.  RK4 is cheap enough to reach its error floor;
    implicit Euler (first order: O(1) error on this chaotic problem until N is
    huge) stops at 128 000 steps (~ a few seconds)."""
    if quick:
        base = doubling(250, 4000)
        # galerkin4 and RK4 cross 1e-8 between N = 4000 and 8000: one more size for the ratio
        return {("whole", "galerkin4"): doubling(250, 8000), "whole": base, "march": base,
                "rk4": doubling(250, 16000), "implicit-euler": base}
    base = doubling(250, 32000)
    return {"whole": base, "march": base, "rk4": doubling(250, 128000),
            "implicit-euler": doubling(250, 128000)}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--T", type=float, default=5.0, help="horizon in seconds (default 5)")
    p.add_argument("--theta1", type=float, default=2.0, help="initial angle of link 1, rad (default 2)")
    p.add_argument("--theta2", type=float, default=1.0, help="initial angle of link 2, rad (default 1)")
    p.add_argument("--out", default="out", help="output directory (default out)")
    p.add_argument("--quick", action="store_true", help="N up to 4000 only (whole-galerkin4 8000, RK4 16000)")
    sweeps.add_sweep_flags(p)
    args = p.parse_args(argv)
    if not (math.isfinite(args.T) and args.T > 0):
        p.error("--T must be positive")
    if not (math.isfinite(args.theta1) and math.isfinite(args.theta2)):
        p.error("--theta1 and --theta2 must be finite")
    executor = sweeps.executor(args, PROG)
    os.makedirs(args.out, exist_ok=True)

    q0, qd0 = np.array([args.theta1, args.theta2]), np.zeros(2)
    system = pendulum.double_pendulum()
    refs = {tol: stepping.reference(system, q0, qd0, [args.T], rtol=tol, atol=tol)[0][-1]
            for tol in (REFERENCE_RTOL * 10, REFERENCE_RTOL, REFERENCE_RTOL / 10)}
    ref = refs[REFERENCE_RTOL]
    ref_spread = float(np.max(np.abs(ref - refs[REFERENCE_RTOL / 10])))
    print(f"double pendulum, theta = ({args.theta1:g}, {args.theta2:g}) rad at rest, T = {args.T:g} s")
    print(f"reference: CVODES rtol = atol = {REFERENCE_RTOL:g}, q(T) = {ref.tolist()}")
    print(f"  differs from rtol = {REFERENCE_RTOL / 10:g} by {ref_spread:.1e} (error floor of this study); "
          f"rtol = {REFERENCE_RTOL * 10:g} would be off by "
          f"{float(np.max(np.abs(refs[REFERENCE_RTOL * 10] - ref))):.1e}")
    print("  " + "  ".join(f"{v}={os.environ.get(v)}" for v in BLAS_THREAD_VARS))

    def progress(r):
        print(f"  {r['label']:18s} N={r['n']:>7d} {r['status']:>4s} it={r['iterations']:>4d} "
              f"build={r['build_time_s']:8.3f}s solve={r['solve_time_s']:8.3f}s "
              f"err={r['error_final']:9.2e} dE={r['energy_error_max']:9.2e}", flush=True)

    csv_path = os.path.join(args.out, "work_precision.csv")

    def write(rows):
        study.write_csv(rows, csv_path)
        return csv_path

    ns = sizes(args.quick)
    t_start = time.perf_counter()
    rows = sweeps.run(PROG, executor, lambda on_row: study.work_precision_sweep(
        pendulum.double_pendulum, q0, qd0, args.T, METHODS_SCHEMES, ns, executor=executor,
        reference_rtol=REFERENCE_RTOL, progress=on_row, bar=sweeps.bar(args), quiet=args.quiet),
        write, total=sum(len(study._ns_for(ns, m, s)) for m, s in METHODS_SCHEMES),
        progress=None if args.quiet else progress)
    sweep_s = time.perf_counter() - t_start
    write(rows)
    title = f"double pendulum, θ0 = ({args.theta1:g}, {args.theta2:g}), T = {args.T:g} s"
    figs = {
        "work_precision_error.png": plotting.work_precision(rows, x="time", y="error", group=("label",),
                                                            title=f"Final-state error, {title}"),
        "work_precision_energy.png": plotting.work_precision(rows, x="time", y="energy", group=("label",),
                                                             title=f"Max energy error, {title}"),
        "work_precision_panels.png": plotting.work_precision_panels(rows, x="time", group=("label",),
                                                                    title=title),
    }
    for name, fig in figs.items():
        fig.savefig(os.path.join(args.out, name), dpi=120)
    print(f"wrote {csv_path} and {', '.join(os.path.join(args.out, n) for n in figs)}")

    labels = [study.trajectory_label(m, s) for m, s in METHODS_SCHEMES]
    print()
    print(f"{'method':18s} {'order':>6s} {'fit range':>15s}   {'time to 1e-8':>14s} {'N at 1e-8':>10s}  "
          f"{'best error':>10s} {'at time':>9s}  note")
    reach = {}
    for lab in labels:
        o = study.trajectory_order(rows, lab, floor=max(1e-11, 10 * ref_spread), ceiling=1e-2, last=3)
        tt = study.time_to_error(rows, lab, TARGET)
        reach[lab] = tt
        ok = [r for r in rows if r["label"] == lab and r["status"] == "ok"]
        best = min(ok, key=lambda r: r["error_final"]) if ok else None
        rng = f"{o['n_min']:.0f}..{o['n_max']:.0f}" if o["points"] >= 2 else "n/a"
        when = (f"{tt['cost']:12.4f} s" if tt["note"] != "not reached" else f"{'not reached':>14s}")
        if tt["note"] == "at smallest N":
            when = f"<={tt['cost']:10.4f} s"
        print(f"{lab:18s} {o['order']:6.2f} {rng:>15s}   {when:>14s} "
              f"{tt['n']:10.0f}  {best['error_final'] if best else math.nan:10.2e} "
              f"{best['time_s'] if best else math.nan:9.3f}"
              + (f"  error stalls from N = {o['stalled_at']:.0f} (accuracy floor of the method)"
                 if np.isfinite(o["stalled_at"]) else ""))
    g, r = reach["whole-galerkin4"], reach["rk4"]
    print()
    if g["note"] != "not reached" and r["note"] != "not reached":
        print(f"time to final error 1e-8: whole-galerkin4 {g['cost']:.4f} s, rk4 {r['cost']:.4f} s, "
              f"ratio whole-galerkin4 / rk4 = {g['cost'] / r['cost']:.1f}")
    else:
        print("time to final error 1e-8: ratio whole-galerkin4 / rk4 not available "
              f"(whole-galerkin4: {g['note']}, rk4: {r['note']})")
    m, w = reach.get("march-galerkin4"), reach.get("whole-galerkin4")
    if m and m["note"] != "not reached" and w["note"] != "not reached":
        print(f"                          whole-galerkin4 / march-galerkin4 = {w['cost'] / m['cost']:.2f}")
    print(f"sweep: {len(rows)} runs in {sweep_s:.1f} s")
    failed = [row for row in rows if row["status"] != "ok"]
    for row in failed:
        print(f"FAILED: {row['label']} N={row['n']}: {row['status']}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(sweeps.command(main, PROG))
