"""Droplet convergence study: errors against N and against run time, both formulations.

Sweeps N (default 8 … 100 000, factor ~2), records every error against the
analytic cap and the build/solve wall times, writes a CSV and a log-log plot
(error vs N, error vs build + solve time) and prints the observed orders.

    python scripts/droplet_convergence.py --out out/
    python scripts/droplet_convergence.py --n-max 4096 --out out/      # quick
    python scripts/droplet_convergence.py --workers 2 --out out/       # on a local pool of 2 processes

Runs go one after another in this process (fair wall times) unless ``--workers N`` (a local
process pool) or ``--dask-scheduler ADDRESS`` (a Dask cluster) is given.
"""
import argparse
import os
import sys

from castrajectory.cli import sweeps
from castrajectory.solve import droplet
from castrajectory.inspect import plotting, study

PROG = "droplet_convergence.py"


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="out", help="output directory")
    p.add_argument("--n-min", type=int, default=8)
    p.add_argument("--n-max", type=int, default=100_000)
    p.add_argument("--formulations", nargs="+", choices=droplet.POLYLINES, default=list(droplet.POLYLINES))
    sweeps.add_sweep_flags(p)
    args = p.parse_args(argv)
    if args.n_min < droplet.MIN_N or args.n_max < args.n_min:
        p.error(f"need {droplet.MIN_N} <= --n-min <= --n-max")
    executor = sweeps.executor(args, PROG)
    os.makedirs(args.out, exist_ok=True)

    def progress(r):
        print(f"{r['formulation']:6s} N={r['n']:>7d} {r['status']:>4s} it={r['iterations']:>2d} "
              f"build={r['build_time_s']:.3f}s solve={r['solve_time_s']:.3f}s  "
              + " ".join(f"{k}={r['err_' + k]:.2e}" for k in study.DROPLET_ERRORS), flush=True)

    csv_path, png_path = os.path.join(args.out, "droplet_convergence.csv"), os.path.join(args.out,
                                                                                         "droplet_convergence.png")

    def write(rows):
        study.write_csv(rows, csv_path)
        return csv_path

    ns = study.sweep_sizes(args.n_max, args.n_min)
    rows = sweeps.run(PROG, executor, lambda on_row: study.droplet_sweep(
        ns, args.formulations, executor=executor, progress=on_row, bar=sweeps.bar(args), quiet=args.quiet),
        write, total=len(ns) * len(args.formulations), progress=None if args.quiet else progress)
    write(rows)
    plotting.droplet_convergence(rows, png_path)
    print(f"wrote {csv_path} and {png_path}")
    print("observed orders (err ~ N^-p, fit over N >= 32):")
    for f in args.formulations:
        orders = study.observed_orders(rows, f)
        print(f"  {f:6s} " + "  ".join(f"{k}={v:.2f}" for k, v in orders.items()))
    failed = [r for r in rows if r["status"] != "ok"]
    for r in failed:
        print(f"FAILED: {r['formulation']} N={r['n']}: {r['status']}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(sweeps.command(main, PROG))
