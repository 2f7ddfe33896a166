#!/usr/bin/env python
"""Many bodies (issue 45): the cost of chains of n bodies against scipy's DOP853 on the same equations.

Two systems, each built with ``ct.Multibody`` and timed in both of its formulations:

* ``chain``: n uniform rods (m = 1, l = 1, I = 1/12 about the centre) in the plane, hung from a pin at the origin,
  the first pin at 0.5 rad, the others straight, at rest, over T = 3 s (the issue's table);
* ``rope``: n uniform rods in space (m = 1, l = 1, a thin cylinder of radius 0.05) joined end to end by
  spherical joints, the first at the origin tilted 0.5 rad about x and turning at 1 rad/s about its axis z, over
  T = 2 s.

Formulations: ``maximal`` (each body its own position and orientation, each joint a few constraints) and
``joint`` (joint coordinates: angles, or a quaternion per spherical joint; a dense mass matrix).  The error is
measured against DOP853 at rtol 1e-13 on the maximal formulation's index-1 equations (``K (q̈, λ) = b``: the
compiled sparse matrix, assembled in O(n), and a dense or sparse solve per evaluation, see :func:`rhs`), in the
joint angles at the nodes (chain) or the rods' centres of mass at the nodes (rope); DOP853's time is the faster
of that right-hand side and the joint formulation's.  For each n and
formulation the cheapest grid (schemes galerkin6 and galerkin8, N a ladder) whose error is at most the target is
found and timed warm, the best of ``--repeat``; the time includes the error estimate's coarser grids that every
answer carries.  DOP853 is timed on the same right-hand side at the loosest rtol (a decade ladder) that reaches
the target.  Each (system, n, formulation) runs in a child process of its own, so its first call (``cold``:
building, compiling or loading the compiled functions, solving) and its peak resident memory are its own, and the
compile's fallbacks to CasADi's virtual machine (``VM``: functions whose C code is past the compiler's size
limit) are counted.  Printed: a row per run and its ratio to DOP853, then the growth exponents fitted over n
(time ∝ n^p).

    python scripts/bench_multibody.py                                   # chain and rope, n = 2 ... 32
    python scripts/bench_multibody.py --systems chain --links 2,4,8,16,32,64 --target 1e-6
"""
from __future__ import annotations

import argparse
import json
import math
import resource
import subprocess
import sys
import time

import numpy as np

try:
    from scipy.integrate import solve_ivp
except ImportError:          # (scipy is in the bench extra)
    solve_ivp = None

import casadi as ca

import castrajectory as ct
from castrajectory.models.rigidbody import axis_angle, quaternion_rate
from castrajectory.solve import jit

SCHEMES = ("galerkin6", "galerkin8")
NS = (20, 30, 40, 60, 90, 120, 180, 240, 360, 480)
HORIZON = {"chain": 3.0, "rope": 2.0}


def chain(n: int) -> ct.Multibody:
    mb = ct.Multibody(g=9.81)
    parent, at = mb.world, (0.0, 0.0)
    for i in range(n):
        rod = mb.body(f"rod{i + 1}", 1.0, 1.0 / 12, outline=[(0.0, 0.5), (0.0, -0.5)])
        mb.revolute(parent, rod, parent_point=at, child_point=(0.0, 0.5), name=f"pin{i + 1}")
        parent, at = rod, (0.0, -0.5)
    return mb


def rope(n: int) -> ct.Multibody:
    mb = ct.Multibody(g=9.81, dim=3)
    parent, at = mb.world, (0.0, 0.0, 0.0)
    r = 0.05
    side = (3 * r * r + 1.0) / 12
    for i in range(n):
        rod = mb.body(f"rod{i + 1}", 1.0, [side, side, r * r / 2], outline=[(0, 0, 0.5), (0, 0, -0.5)])
        mb.spherical(parent, rod, parent_point=at, child_point=(0.0, 0.0, 0.5), name=f"ball{i + 1}")
        parent, at = rod, (0.0, 0.0, -0.5)
    return mb


BUILD = {"chain": chain, "rope": rope}


def start(kind: str, mb: ct.Multibody):
    """The joint coordinates and rates at t = 0."""
    names = mb.joint_names()
    q, v = np.zeros(len(names)), np.zeros(len(names))
    if kind == "chain":
        q[0] = 0.5
        return q, v
    q[0::4] = 1.0
    tilt = axis_angle([1.0, 0.0, 0.0], 0.5)
    q[0:4] = tilt
    v[0:4] = quaternion_rate(tilt, [0.0, 0.0, 1.0])
    return q, v


def readings(kind: str, mb: ct.Multibody, form: str):
    """``(q rows) -> the compared quantities``: joint angles (chain), centres of mass (rope)."""
    if kind == "chain":
        return (lambda Q: np.array([mb.joint_positions(q) for q in Q])) if form == "maximal" else (lambda Q: Q)
    system = mb.system(form)
    if form == "maximal":
        idx = np.concatenate([7 * i + np.arange(3) for i in range(len(mb.bodies))])
        return lambda Q: np.asarray(Q)[:, idx]
    s = ca.SX.sym("s", system.nq)
    frames = mb._frames(s)
    com = ca.Function("com", [s], [ca.vertcat(*[mb._com(b, *frames[b.index]) for b in mb.bodies])])
    return lambda Q: np.asarray(com.map(len(Q))(np.asarray(Q).T)).T


def rhs(system):
    """DOP853's right-hand side: a formulation's index-1 equations ``K (q̈, λ) = b``, compiled, and solved by a
    dense LAPACK solve up to :data:`DENSE` unknowns, by a sparse LU above.  DOP853 is timed with the maximal
    formulation's (``K`` sparse, a few entries per body: O(n) to assemble) and the joint formulation's (the
    dense mass matrix, fewer unknowns), and the faster counts."""
    from scipy.sparse import csc_matrix
    from scipy.sparse.linalg import spsolve
    n = system.nq
    fn = jit.compiled(system.index1_system)
    sp = fn.sparsity_out(0)
    rows, cols = (np.asarray(v) for v in sp.get_triplet())
    size = sp.size1()

    def f(t, y):
        K, b = fn(y[:n], y[n:], t)
        b = np.asarray(b).reshape(-1)
        if size <= DENSE:
            a = np.linalg.solve(np.asarray(K), b)
        else:
            a = spsolve(csc_matrix((np.asarray(K.nonzeros()), (rows, cols)), shape=(size, size)), b)
        return np.concatenate([y[n:], a[:n]])
    return f


#: DOP853's index-1 solve is dense up to this many unknowns, sparse above (measured crossover on the chain)
DENSE = 120
#: DOP853 is timed on the joint equations too up to this many joint coordinates: above, their dense mass matrix
#: alone costs more than the maximal equations' whole solve (16 rods: 1.30 against 0.62 s), and at 64 rods its
#: compiled function is past the compiler's size limit (minutes in CasADi's virtual machine)
JOINT_RHS_MAX = 16


def child(kind: str, n: int, form: str, target: float, repeat: int) -> dict:
    mb = BUILD[kind](n)
    T = HORIZON[kind]
    qj, vj = start(kind, mb)
    maximal = mb.system("maximal")
    f = rhs(maximal)
    y0 = np.concatenate(mb.state(qj, vj))
    nm = maximal.nq
    ref = solve_ivp(f, (0.0, T), y0, method="DOP853", rtol=1e-13, atol=1e-14, dense_output=True).sol
    read_ref = readings(kind, mb, "maximal")
    out = {"dop853": None}
    if form == "maximal":          # (DOP853 is timed once per n, with the maximal run: both right-hand sides)
        joint = mb.system("joint")
        read_joint = readings(kind, mb, "joint")
        sides = [("maximal", f, y0, nm, read_ref)]
        if joint.nq <= JOINT_RHS_MAX:
            sides.append(("joint", rhs(joint), np.concatenate([qj, vj]), joint.nq, read_joint))
        for name, fr, yr, nr, rd in sides:
            for rtol in (1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12):
                best = math.inf
                for _ in range(repeat):
                    t0 = time.perf_counter()
                    s = solve_ivp(fr, (0.0, T), yr, method="DOP853", rtol=rtol, atol=rtol * 1e-2)
                    best = min(best, time.perf_counter() - t0)
                err = float(np.max(np.abs(rd(s.y[:nr].T) - read_ref(ref(s.t)[:nm].T))))
                if err <= target:
                    if out["dop853"] is None or best < out["dop853"]["time"]:
                        out["dop853"] = {"rtol": rtol, "time": best, "error": err, "rhs": name}
                    break
    system = mb.system(form)
    q0, v0 = mb.state(qj, vj, formulation=form)
    read = readings(kind, mb, form)
    before = dict(jit.stats)
    t0 = time.perf_counter()
    first = None
    for scheme in SCHEMES:
        for N in NS:
            run = ct.simulate(system, q0, v0, T, N, scheme=scheme)
            if first is None:
                first = time.perf_counter() - t0
            if not run.success:
                continue
            err = float(np.max(np.abs(read(run.q) - read_ref(ref(run.t)[:nm].T))))
            if err > target:
                continue
            wall = math.inf
            for _ in range(repeat):
                t1 = time.perf_counter()
                ct.simulate(system, q0, v0, T, N, scheme=scheme)
                wall = min(wall, time.perf_counter() - t1)
            if "best" not in out or wall < out["best"]["time"]:
                out["best"] = {"scheme": scheme, "N": N, "time": wall, "error": err}
            break                        # (finer N of this scheme cost more)
    out["cold"] = first
    out["fallbacks"] = jit.stats["fallbacks"] - before["fallbacks"]
    out["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return out


def fit(ns, ts) -> float:
    return float(np.polyfit(np.log(ns), np.log(ts), 1)[0])


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--systems", default="chain,rope", help="chain and/or rope, comma-separated")
    p.add_argument("--links", default="2,4,8,16,32", help="numbers of bodies, comma-separated")
    p.add_argument("--target", type=float, default=1e-8, help="largest error of the readings at the nodes")
    p.add_argument("--repeat", type=int, default=3, help="timed runs per setting (the best counts)")
    p.add_argument("--formulations", default="maximal,joint", help="of the builder, comma-separated")
    p.add_argument("--child", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if solve_ivp is None:
        print("scipy is not installed (pip install '.[bench]'): no DOP853 to compare with", file=sys.stderr)
        return 0
    if args.child:
        kind, n, form = args.child.split(":")
        print(json.dumps(child(kind, int(n), form, args.target, args.repeat)))
        return 0
    try:
        links = [int(v) for v in args.links.split(",")]
    except ValueError:
        p.error("--links: integers, comma-separated")
    systems, forms = args.systems.split(","), args.formulations.split(",")
    if any(n < 1 for n in links) or not (args.target > 0) or args.repeat < 1:
        p.error("--links >= 1, --target > 0 and --repeat >= 1")
    if any(s not in BUILD for s in systems) or any(f not in ("maximal", "joint") for f in forms):
        p.error("--systems: chain and/or rope; --formulations: maximal and/or joint")
    forms = ["maximal"] + [f for f in forms if f != "maximal"]     # (the maximal child times DOP853)
    print(f"target {args.target:g}; warm times the best of {args.repeat}; cold: the first call in a fresh process")
    print(f"{'system':>6s} {'n':>3s} {'formulation':>11s} {'scheme':>10s} {'N':>4s} {'error':>8s} {'warm s':>8s} "
          f"{'cold s':>7s} {'peak MB':>8s} {'VM':>3s} {'DOP853 s':>9s} {'ratio':>6s}")
    rows = []
    for kind in systems:
        for n in links:
            dop = None
            for form in forms:
                cmd = [sys.executable, __file__, "--child", f"{kind}:{n}:{form}", "--target", str(args.target),
                       "--repeat", str(args.repeat)]
                done = subprocess.run(cmd, capture_output=True, text=True)
                if done.returncode != 0:
                    print(f"{kind:>6s} {n:3d} {form:>11s}  failed: {done.stderr.strip().splitlines()[-1:]}")
                    continue
                got = json.loads(done.stdout.strip().splitlines()[-1])
                dop = got["dop853"] or dop
                best = got.get("best")
                if best is None:
                    print(f"{kind:>6s} {n:3d} {form:>11s}  no grid of {', '.join(SCHEMES)} up to N = {NS[-1]} "
                          f"reached the target (cold {got['cold']:.2f} s)", flush=True)
                    continue
                tdop = dop["time"] if dop else math.nan
                if form == "maximal" and dop:
                    print(f"{'':>6s} {n:3d} {'DOP853':>11s} rtol {dop['rtol']:.0e} on the {dop['rhs']} equations, "
                          f"error {dop['error']:.1e}", flush=True)
                rows.append((kind, n, form, best["time"], tdop, got["cold"]))
                print(f"{kind:>6s} {n:3d} {form:>11s} {best['scheme']:>10s} {best['N']:4d} {best['error']:8.1e} "
                      f"{best['time']:8.4f} {got['cold']:7.2f} {got['peak_mb']:8.0f} {got['fallbacks']:3d} "
                      f"{tdop:9.4f} {best['time'] / tdop:6.1f}", flush=True)
    print()
    for kind in systems:
        for form in forms + ["DOP853"]:
            pts = [(n, (w if form != "DOP853" else d)) for k, n, fo, w, d, _ in rows
                   if k == kind and fo == (form if form != "DOP853" else "maximal")]
            if len(pts) >= 2:
                ns, ts = np.array(pts).T
                print(f"{kind}: growth exponent {form}: time ∝ n^{fit(ns, ts):.2f} over n = {int(ns[0])} ... "
                      f"{int(ns[-1])}")
    print("goal (issue 45): exponent at most 1.2, the 32-link chain within 3x of DOP853, its first call under 5 s, "
          "no VM fallback")
    return 0


if __name__ == "__main__":
    sys.exit(main())
