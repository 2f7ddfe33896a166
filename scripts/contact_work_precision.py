#!/usr/bin/env python
"""Work–precision of contact trajectories: impact times, speeds and apex heights against the analytic ones.

Cases (``study.CONTACT_CASES``): the bouncing ball under gravity (e = 1,
three bounces; the midpoint rule is exact on parabolas, so only the solver
tolerance is left) and the ball on a spring (e = 0.9, five bounces; harmonic
flight, second order expected).  Methods: the whole-trajectory contact NLP
(collision sub-nodes) and the Moreau–Jean time-stepping baseline (impacts at
steps: first order).  Writes a CSV and a two-panel plot (error against wall
time and against N) and prints observed orders.

    python scripts/contact_work_precision.py --out contact_wp
    python scripts/contact_work_precision.py --sizes 250 500 1000 --out /tmp/wp
    python scripts/contact_work_precision.py --workers 2 --out /tmp/wp     # a local pool of 2 processes

Runs go one after another in this process (fair wall times) unless ``--workers N`` (a local
process pool) or ``--dask-scheduler ADDRESS`` (a Dask cluster) is given.
"""
from __future__ import annotations

import argparse
import os
import sys

import numpy as np

from castrajectory.cli import sweeps
from castrajectory.inspect import plotting, study

PROG = "contact_work_precision.py"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sizes", type=int, nargs="+", default=[250, 500, 1000, 2000, 4000])
    p.add_argument("--out", default="contact_work_precision", help="output directory")
    sweeps.add_sweep_flags(p)
    args = p.parse_args(argv)
    if any(n < 2 for n in args.sizes):
        print(f"{PROG}: error: every size must be >= 2", file=sys.stderr)
        return 2
    executor = sweeps.executor(args, PROG)
    os.makedirs(args.out, exist_ok=True)
    csv_path = os.path.join(args.out, "contact_work_precision.csv")

    def write(rows):
        study.write_csv(rows, csv_path)
        return csv_path

    rows = sweeps.run(PROG, executor, lambda on_row: study.contact_work_precision(
        sorted(args.sizes), executor=executor, progress=on_row, bar=sweeps.bar(args), quiet=args.quiet),
        write, total=len(args.sizes) * len(study.CONTACT_CASES) * 2)       # (2 methods: whole, moreau-jean)
    write(rows)
    fig = plotting.contact_work_precision(rows, title="Contact trajectories: bounce times against the analytic ones")
    fig.savefig(os.path.join(args.out, "contact_work_precision.png"))
    print(f"{'case':12s} {'method':12s} {'N':>6s} {'time s':>8s} {'|Δt| max':>10s} {'|Δv|/v max':>11s} "
          f"{'|Δapex| max':>11s} status")
    for r in rows:
        print(f"{r['case']:12s} {r['method']:12s} {r['n']:6d} {r['build_time_s'] + r['solve_time_s']:8.3f} "
              f"{r['impact_time_error']:10.2e} {r['impact_speed_error']:11.2e} {r['apex_error']:11.2e} {r['status']}")
    for case in study.CONTACT_CASES:
        for method in ("whole", "moreau-jean"):
            sel = [r for r in rows if r["case"] == case and r["method"] == method and r["status"] == "ok"
                   and np.isfinite(r["impact_time_error"]) and r["impact_time_error"] > 1e-9]
            if len(sel) >= 2:
                slope = study.loglog_slope([r["n"] for r in sel], [r["impact_time_error"] for r in sel])
                print(f"observed order of the impact time, {case} / {method}: {-slope:.2f}")
            else:
                print(f"observed order of the impact time, {case} / {method}: - (errors at the solver tolerance)")
    return 0


if __name__ == "__main__":
    sys.exit(sweeps.command(main, PROG))
