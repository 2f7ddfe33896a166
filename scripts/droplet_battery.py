#!/usr/bin/env python
"""A battery of seeded random drops, each solved by the spectral profile and checked against its oracle.

This is a measurement, not a test: it exits 0 (2 for bad flags).  Each drop draws 2-D or of revolution,
sessile (Young's angle 5°–175°, Bond number 10^-2 … 10^1.7) or pendant (60°–120°, a random fraction 0.05–0.9
of the 90° fold's size: beyond its own angle's fold the answer is ``No_Stable_Drop``, which is the expected
verdict there, checked against the closed-form fold), and a degree 16, 24 or 32.  Each row records the status,
the largest relative error of the height, the contact angle and the pressure against the oracle (the elliptic
closed form in 2-D, the Young–Laplace shooting in 3-D), the error estimate and the time.  Goal: every drop
solved or stopped at its fold, every error within 100x of its estimate or below 1e-8.

    python scripts/droplet_battery.py
    python scripts/droplet_battery.py --count 100 --seed 3 --csv battery/droplet_spectral.csv
"""
from __future__ import annotations

import argparse
import csv
import math
import os
import sys
import tempfile
import time

import numpy as np

from castrajectory.models import droplet as md
from castrajectory.solve import droplet as dl

#: The 90° folds (units of l_c): the pendant drops are drawn as fractions of these.
FOLD_2D, FOLD_3D = 2.7151505, 3.4110285
#: An error counts as resolved below this, whatever its estimate.
RESOLVED = 1e-8


def draw(rng):
    axi, pendant = bool(rng.integers(2)), bool(rng.random() < 0.25)
    deg = float(rng.uniform(60, 120) if pendant else rng.uniform(5, 175))
    size = float(rng.uniform(0.05, 0.9) if pendant else 10 ** rng.uniform(-2, 1.7))
    if axi:
        measure = size * FOLD_3D if pendant else size ** 1.5
    else:
        measure = size * FOLD_2D if pendant else size
    drop = md.Droplet(1.0, 1.0 - math.cos(math.radians(deg)), 1.0, measure, rho_g=1.0, pendant=pendant,
                      axisymmetric=axi)
    return drop, int(rng.choice([16, 24, 32])), deg


def run_one(drop, degree):
    t = time.perf_counter()
    sol = dl.solve(drop, degree, "spectral")
    dt = time.perf_counter() - t
    err = max((v for k, v in sol.errors.items() if k in ("height", "contact_angle", "pressure")), default=math.nan)
    est = sol.error_estimate.relative if sol.error_estimate is not None and sol.error_estimate.available else math.nan
    fold = (sol.stability or {}).get("fold")
    fold_err = math.nan if not fold or fold.get("analytic_area") is None else \
        abs(fold["extrapolated_area"] - fold["analytic_area"]) / fold["analytic_area"]
    return {"status": sol.status, "error": err, "estimate": est, "fold_error": fold_err, "time_s": dt,
            "iterations": sol.iterations}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    p.add_argument("--count", type=int, default=60)
    p.add_argument("--seed", type=int, default=7)
    p.add_argument("--csv", metavar="PATH", help="also write the rows as CSV to PATH")
    args = p.parse_args(argv)
    if args.count < 1:
        p.error("--count must be at least 1")
    rng = np.random.default_rng(args.seed)
    rows = []
    print(f"{'#':>3} {'kind':<10} {'angle':>6} {'measure':>9} {'deg':>4} {'status':<16} {'error':>8} {'estimate':>8} "
          f"{'fold err':>8} {'time':>7}")
    for i in range(args.count):
        drop, degree, deg = draw(rng)
        r = run_one(drop, degree)
        kind = f"{'3-D' if drop.axisymmetric else '2-D'} {'pend' if drop.pendant else 'sess'}"
        rows.append({"case": i, "kind": kind, "angle_deg": deg, "measure": drop.area, "degree": degree, **r})
        print(f"{i:>3} {kind:<10} {deg:>6.1f} {drop.area:>9.4g} {degree:>4} {r['status']:<16} {r['error']:>8.1e} "
              f"{r['estimate']:>8.1e} {r['fold_error']:>8.1e} {r['time_s']:>6.2f}s", flush=True)
    solved = [r for r in rows if r["status"] == "ok"]
    folds = [r for r in rows if r["status"] == dl.NO_STABLE_DROP]
    bad = [r for r in solved if not (r["error"] < RESOLVED or r["error"] <= 100 * r["estimate"])]
    fold_errors = ", ".join(f"{r['fold_error']:.1e}" for r in folds) or "-"
    print(f"\nsolved {len(solved)}/{len(rows)}; stopped at a fold {len(folds)} (fold errors {fold_errors}); "
          f"other {len(rows) - len(solved) - len(folds)}")
    if solved:
        print(f"worst error {max(r['error'] for r in solved):.2e}; errors beyond 100x their estimate (and 1e-8): "
              f"{len(bad)}; median time {np.median([r['time_s'] for r in rows]):.2f} s, worst "
              f"{max(r['time_s'] for r in rows):.2f} s")
    ok = len(solved) + len(folds) == len(rows) and not bad
    print(f"goal (every drop solved or stopped at its fold; every error within 100x its estimate or below 1e-8): "
          f"{'PASS' if ok else 'MISS'}")
    if args.csv:
        folder = os.path.dirname(os.path.abspath(args.csv))
        fd, tmp = tempfile.mkstemp(dir=folder, suffix=".csv")
        with os.fdopen(fd, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        os.replace(tmp, args.csv)
    return 0


if __name__ == "__main__":
    sys.exit(main())
