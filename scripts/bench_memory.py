#!/usr/bin/env python
"""Peak memory of a whole-trajectory solve against N, per scheme and scene, and the fit behind the limit.

This is a measurement, not a test: it exits 0 (2 for bad flags).  Each run is a child process (a fresh
interpreter: its peak resident set size is its own), solving one scene at one N with one scheme, and
the parent reads the child's peak RSS and peak virtual size.  For each (scene, scheme) the slope of
the peak against N is the memory per step; the table compares it with the estimates the solver uses to
refuse or stop a grid (``castrajectory.solve.memory.bytes_per_step`` for resident memory, times
``ADDRESS_SPACE_FACTOR`` under an address-space limit), whose ratios measured/estimated must stay below 1.

Scenes: the double pendulum (2 coordinates), the free rigid body on a quaternion (4 coordinates and a
constraint), pendulum chains of 8 and 16 links (dense mass matrices), the bouncing ball (contact).

    python scripts/bench_memory.py
    python scripts/bench_memory.py --quick
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys

import numpy as np

CHILD = r"""
import json, resource, sys
import numpy as np
scene, scheme, N, mode = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
from castrajectory.solve import memory, simulate
if scene == "double_pendulum":
    from castrajectory.models.pendulum import double_pendulum
    system, q0, qd0, T = double_pendulum(), [1.0, 0.5], [0.0, 0.0], 5.0
elif scene == "free_body":
    from castrajectory.models import rigidbody as rb
    I = rb.Inertia(1.0, 2.0, 3.0)
    system, q0, T = rb.free_body(I), np.array([1.0, 0, 0, 0]), 20.0
    qd0 = rb.quaternion_rate(q0, np.array([0.1, 1.0, 0.1]))
elif scene.startswith("chain"):
    from castrajectory.models.pendulum import n_link_pendulum
    k = int(scene[5:])
    system, q0, qd0, T = n_link_pendulum([1.0] * k, [1.0] * k), [0.3] * k, [0.0] * k, 2.0
else:
    from castrajectory.models import collision as col
    system, q0, qd0, T = col.bouncing_ball(), [1.0], [0.0], 3.0
def vm_peak():  # peak virtual size (Linux), what an address-space limit (RLIMIT_AS) counts
    try:
        return float([ln.split()[1] for ln in open("/proc/self/status") if ln.startswith("VmPeak")][0]) * 1024.0
    except (OSError, IndexError, ValueError):
        return float("nan")
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0
if mode == "rtol":  # a refinement that ends at N: levels N/4, N/2, N, each polished
    run = simulate.simulate(system, q0, qd0, T, N // 4, scheme, rtol=1e-15, n_max=N)
    run.status = "ok" if len(run.t) - 1 == N else f"stopped at {len(run.t) - 1}"
else:
    run = simulate.simulate(system, q0, qd0, T, N, scheme)
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0
print(json.dumps({"status": run.status, "peak": peak, "base": base, "vm_peak": vm_peak(),
                  "estimate_per_step": memory.bytes_per_step(system, scheme),
                  "vm_estimate_per_step": memory.bytes_per_step(system, scheme) * memory.ADDRESS_SPACE_FACTOR}))
"""


def measure(scene, scheme, n, mode="single"):
    p = subprocess.run([sys.executable, "-c", CHILD, scene, scheme, str(n), mode], capture_output=True, text=True,
                       timeout=3600)
    if p.returncode != 0:
        return {"status": f"exit {p.returncode}: {p.stderr.strip().splitlines()[-1] if p.stderr.strip() else ''}"}
    return json.loads(p.stdout.strip().splitlines()[-1])


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="two sizes per case (about two minutes)")
    args = p.parse_args(argv)
    cases = [("double_pendulum", "midpoint", [20000, 80000, 160000]),
             ("double_pendulum", "galerkin4", [10000, 40000, 80000]),
             ("double_pendulum", "galerkin8", [4000, 16000, 32000]),
             ("free_body", "midpoint", [10000, 40000, 80000]),
             ("free_body", "galerkin4", [5000, 20000, 40000]),
             ("free_body", "galerkin8", [2000, 8000, 16000]),
             ("chain8", "midpoint", [4000, 16000, 32000]),
             ("chain8", "galerkin4", [2000, 8000, 16000]),
             ("chain16", "midpoint", [2000, 8000, 16000]),
             ("chain16", "galerkin4", [1000, 4000, 8000]),
             ("bouncing_ball", "midpoint", [20000, 80000, 160000])]
    print("peak resident memory of one simulate() per N (child processes); the slope is the memory per step")
    print(f"  {'scene':16s} {'scheme':10s} {'N':>8s} {'peak MB':>9s} {'VM peak':>9s}")
    worst = 0.0
    for scene, scheme, ns in cases:
        if args.quick:
            ns = ns[:2]
        rows = []
        for n in ns:
            r = measure(scene, scheme, n)
            if "peak" not in r or r["status"] != "ok":
                print(f"  {scene:16s} {scheme:10s} {n:8d}  {r.get('status')}")
                continue
            rows.append((n, r["peak"], r["estimate_per_step"], r["vm_peak"], r["vm_estimate_per_step"]))
            print(f"  {scene:16s} {scheme:10s} {n:8d} {r['peak'] / 1e6:9.1f} {r['vm_peak'] / 1e6:9.1f}")
        if len(rows) >= 2:
            n_, peak_, est_, vm_, vest_ = (np.array(c) for c in zip(*rows))
            slope = float(np.polyfit(n_, peak_, 1)[0])
            vslope = float(np.polyfit(n_, vm_, 1)[0])
            ratio, vratio = slope / float(est_[0]), vslope / float(vest_[0])
            worst = max(worst, ratio, vratio)
            print(f"    -> resident {slope / 1e3:.2f} kB per step measured, {est_[0] / 1e3:.2f} kB estimated "
                  f"(ratio {ratio:.2f}); virtual {vslope / 1e3:.2f} kB measured, {vest_[0] / 1e3:.2f} kB estimated "
                  f"(ratio {vratio:.2f})")
    print(f"\nlargest measured / estimated: {worst:.2f} "
          f"({'PASS' if worst <= 1.0 else 'MISS'}: the estimate must bound the measurement)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
