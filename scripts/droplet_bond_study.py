"""Shape of a sessile drop against its Bond number, 2-D and 3-D: the NLP against the closed form / shooting.

For Bo = 1e-3 … 1e3 (2-D: A / l_c²; a drop of revolution: V^(2/3) / l_c²) at Young's angle θ, the height and
the contact radius (2-D: the half span) from the NLP and from the oracle (the closed form in elliptic
integrals, the puddle limit beyond its range, or the Young–Laplace shooting in 3-D).  Checks and prints the
issue's claims on the oracle's values: the 2-D height rises monotonically to the puddle limit 2 l_c sin(θ/2);
the 3-D height overshoots it (the peak located on the shooting by a grid in log V, zoomed) and falls back to it.
Writes a CSV, a Markdown table and a plot.

    python scripts/droplet_bond_study.py --out out/
    python scripts/droplet_bond_study.py --per-decade 1 --no-nlp --out out/   # quick: oracles only

Exit 0 when every NLP converged, 1 otherwise.
"""
import argparse
import math
import os
import sys

#: Single-threaded BLAS unless the caller chose otherwise (as scripts/bench_droplet.py): on a loaded machine
#: OpenBLAS's worker threads only contend with the solves (the bench measured SLSQP 30x slower with them).
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from castrajectory.inspect import bond, files  # noqa: E402


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="out", help="output directory")
    p.add_argument("--theta", type=float, default=90.0, help="Young's angle in degrees (0 < θ < 180)")
    p.add_argument("--bo-min", type=float, default=1e-3)
    p.add_argument("--bo-max", type=float, default=1e3)
    p.add_argument("--per-decade", type=int, default=2, help="Bond numbers per decade (default 2)")
    p.add_argument("--dims", nargs="+", choices=("2-D", "3-D"), default=["2-D", "3-D"])
    p.add_argument("--no-nlp", action="store_true", help="the oracles only")
    p.add_argument("--no-peak", action="store_true", help="skip the search of the 3-D peak")
    args = p.parse_args(argv)
    if not (0.0 < args.theta < 180.0) or not (0.0 < args.bo_min <= args.bo_max) or args.per_decade < 1:
        p.error("need 0 < --theta < 180, 0 < --bo-min <= --bo-max and --per-decade >= 1")
    decades = math.log10(args.bo_max / args.bo_min)
    bonds = np.logspace(math.log10(args.bo_min), math.log10(args.bo_max),
                        max(2, int(round(decades * args.per_decade)) + 1))
    os.makedirs(args.out, exist_ok=True)

    def progress(r):
        print(f"{r['dim']} Bo={r['bond']:9.3g} h_ref={r['height_ref']:.8f} r_ref={r['radius_ref']:.6g} "
              f"({r['reference']}) N={r['n']:>4} {r['status']:>4} h={r['height']:.8f} r={r['radius']:.6g} "
              f"err h={r['err_height']:.1e} r={r['err_radius']:.1e} {r['time_s']:.2f}s", flush=True)

    rows = bond.sweep(bonds, args.dims, args.theta, nlp_bonds=[] if args.no_nlp else None, progress=progress)
    peak = None if (args.no_peak or "3-D" not in args.dims) else bond.overshoot(args.theta)
    found = bond.findings(rows, args.theta, peak)
    stem = os.path.join(args.out, "droplet_bond_study")
    bond.write_csv(rows, stem + ".csv")
    files.write_text(stem + ".md", "\n".join(["# Drop shape against the Bond number", "", *bond.markdown(rows), "",
                                              *("- " + ln for ln in found["lines"])]) + "\n")
    bond.plot(rows, stem + ".png", args.theta, peak)
    print(*found["lines"], sep="\n")
    print(f"wrote {stem}.csv, {stem}.md and {stem}.png")
    failed = [r for r in rows if r["status"] not in ("ok", "-")]
    for r in failed:
        print(f"FAILED: {r['dim']} Bo = {r['bond']:.3g}: {r['status']}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
