#!/usr/bin/env python
"""Long-horizon energy behaviour: variational schemes stay bounded, RK4 drifts.

Simple pendulum (``pendulum.n_link_pendulum([1], [1])``, g = 9.81) released
from rest at a small angle (default 0.1 rad) and followed for many periods
(default 1000 small-angle periods ``2π√(l/g)``) with a fixed number of steps
per period (default 20), every method at the same step:

* ``whole`` × midpoint and × galerkin4 (the library's whole-trajectory solve;
  ``--skip-whole-galerkin4`` leaves out the slowest run);
* ``march`` × midpoint and × galerkin4 (the same integrators marched);
* ``rk4`` (explicit, not symplectic).

For each run ``dE(t) = |E(t) − E(q0, q̇0)|`` is summarised (``study.energy_drift_summary``):
maxima over the first half, the second half and the whole run, the slope of a
least-squares line through ``(t, dE)``, and the ratio of the maxima over the
last and the first tenth of the run.  Writes ``long_horizon.csv`` (one row per
method) and ``long_horizon.png`` (``dE`` against time in periods) into ``--out``.

Verdict: every variational run is *bounded* (second-half max ≤ 1.5 × first-half
max) and RK4 *drifts* (fit slope > 0 and last/first tenth ratio > 3).  Exit
code 1 if the verdict fails or a run fails, 0 otherwise.

    python scripts/long_horizon.py --out out/
    python scripts/long_horizon.py --periods 100 --out out/     # quick
    python scripts/long_horizon.py --workers 2 --out out/       # the runs on a local pool of 2 processes

The runs go one after another in this process (fair wall times) unless ``--workers N`` (a local
process pool) or ``--dask-scheduler ADDRESS`` (a Dask cluster) is given.
"""
from __future__ import annotations

import argparse
import functools
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

PROG = "long_horizon.py"
BOUNDED_FACTOR = 1.5
DRIFT_TAIL_RATIO = 3.0


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--amplitude", type=float, default=0.1, help="initial angle, rad (default 0.1)")
    p.add_argument("--periods", type=int, default=1000, help="number of small-angle periods (default 1000)")
    p.add_argument("--steps-per-period", type=int, default=20, help="steps per period (default 20)")
    p.add_argument("--length", type=float, default=1.0, help="pendulum length, m (default 1)")
    p.add_argument("--g", type=float, default=9.81, help="gravity, m/s² (default 9.81)")
    p.add_argument("--skip-whole-galerkin4", action="store_true",
                   help="leave out the whole-trajectory galerkin4 run (the slowest)")
    p.add_argument("--out", default="out", help="output directory (default out)")
    sweeps.add_sweep_flags(p)
    args = p.parse_args(argv)
    if not (math.isfinite(args.amplitude) and 0 < abs(args.amplitude) < math.pi):
        p.error("--amplitude must be in (0, pi)")
    if args.periods < 2 or args.steps_per_period < 2:
        p.error("--periods and --steps-per-period must be at least 2")
    if not (args.length > 0 and args.g > 0 and math.isfinite(args.length) and math.isfinite(args.g)):
        p.error("--length and --g must be positive")
    executor = sweeps.executor(args, PROG)
    os.makedirs(args.out, exist_ok=True)

    # a factory, not a built system: a process pool or a Dask worker builds it where it runs
    system = functools.partial(pendulum.n_link_pendulum, [1.0], [args.length], args.g)
    period = 2 * math.pi * math.sqrt(args.length / args.g)
    T = args.periods * period
    N = args.periods * args.steps_per_period
    q0, qd0 = [args.amplitude], [0.0]
    runs = [("whole", "midpoint"), ("whole", "galerkin4"), ("march", "midpoint"), ("march", "galerkin4"),
            ("rk4", None)]
    if args.skip_whole_galerkin4:
        runs.remove(("whole", "galerkin4"))
    print(f"simple pendulum l = {args.length:g} m, g = {args.g:g}, amplitude {args.amplitude:g} rad, "
          f"small-angle period {period:.6f} s")
    print(f"T = {args.periods} periods = {T:.3f} s, N = {N} steps ({args.steps_per_period} per period, "
          f"h = {T / N:.5f} s)")

    def progress(result):
        row = result[0]
        extra = f" levels={row['levels']} it={row['iterations']}" if row["method"] == "whole" else ""
        print(f"  {row['label']:16s} {row['status']:>4s} build={row['build_time_s']:7.3f}s "
              f"solve={row['solve_time_s']:8.3f}s wall={row['wall_time_s']:8.3f}s{extra}", flush=True)

    csv_path, png_path = os.path.join(args.out, "long_horizon.csv"), os.path.join(args.out, "long_horizon.png")

    def write(results):
        study.write_csv([row for row, _, _ in results], csv_path)
        return csv_path

    t_all = time.perf_counter()
    results = sweeps.run(PROG, executor, lambda on_result: study.long_horizon_sweep(
        system, q0, qd0, T, N, runs, executor=executor, progress=on_result, bar=sweeps.bar(args), quiet=args.quiet),
        write, total=len(runs), progress=None if args.quiet else progress)
    rows, series, tseries = [], {}, {}
    for row, t, energy in results:
        rows.append(row)
        if np.all(np.isfinite(energy)):
            series[row["label"]] = energy - row["E0"]
            tseries[row["label"]] = t
    total = time.perf_counter() - t_all

    study.write_csv(rows, csv_path)
    fig = plotting.long_horizon_plot(tseries, series, period=period,
                                     title=f"Simple pendulum, θ0 = {args.amplitude:g} rad, "
                                           f"{args.steps_per_period} steps per period")
    fig.savefig(png_path, dpi=120)
    print(f"wrote {csv_path} and {png_path}")

    print()
    print(f"  {'method':16s} {'max 1st half':>12s} {'max 2nd half':>12s} {'max':>10s} {'2nd/1st':>8s} "
          f"{'slope (J/s)':>12s} {'last/first 10%':>14s}  verdict")
    failures = []
    for r in rows:
        lab = r["label"]
        ratio = r["max_second_half"] / r["max_first_half"] if r["max_first_half"] > 0 else math.inf
        if not r["success"]:
            verdict, ok = f"FAILED ({r['status']})", False
        elif r["method"] == "rk4":
            ok = r["drift_slope"] > 0 and r["tail_ratio"] > DRIFT_TAIL_RATIO
            verdict = "drifts" if ok else "does NOT drift"
        else:
            ok = r["max_second_half"] <= BOUNDED_FACTOR * r["max_first_half"]
            verdict = "bounded" if ok else "NOT bounded"
        if not ok:
            failures.append(lab)
        print(f"  {lab:16s} {r['max_first_half']:12.3e} {r['max_second_half']:12.3e} {r['max']:10.3e} "
              f"{ratio:8.3f} {r['drift_slope']:12.3e} {r['tail_ratio']:14.3f}  {verdict}")
    print()
    print(f"criteria: variational runs bounded (2nd-half max <= {BOUNDED_FACTOR:g} x 1st-half max); "
          f"rk4 drifts (slope > 0 and last/first 10% max ratio > {DRIFT_TAIL_RATIO:g})")
    print(f"total time of the runs: {total:.1f} s")
    if failures:
        print(f"VERDICT: FAIL ({', '.join(failures)})")
        return 1
    print("VERDICT: PASS (variational schemes bounded, RK4 drifting)")
    return 0


if __name__ == "__main__":
    sys.exit(sweeps.command(main, PROG))
