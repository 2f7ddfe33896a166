#!/usr/bin/env python
"""Optimal control of a chain of n rods (issue 45): castrajectory's DMOC on ``ct.Multibody`` against rockit.

This is a benchmark, not a test: it measures and reports, and exits with status 0 (2 for bad flags).

Problem: n uniform rods (m = 1, l = 1) hung end to end from a pin, a torque u_i on every pin (|u_i| <= 200 N m),
from rest hanging straight down to rest with the first pin at 0.3 rad and the others straight (the chain's tip
swung to (n sin 0.3, −n cos 0.3)), T = 2 s, minimise ∫ Σ u_i² dt.  J* is castrajectory's galerkin8 on the finest grid of the
sweep, checked against the next finer one (printed).  Every method starts from the same motion (the joint angles
linear in time): the problem has several local optima, and each formulation's own default guess finds another.

Methods: castrajectory's DMOC (``ct.OptimalControl``) on the builder's system with the torques as joint efforts
(``system(..., efforts=...)``), in maximal coordinates (galerkin4, galerkin6) and in joint coordinates (galerkin6);
rockit (``rockit-meco``, in the ``bench`` extra; skipped with a message without it) with Ipopt on the same model, the
joint coordinates' equations of motion q̈ = M(q)⁻¹ (f(q, q̇) + u) generated from the same system (CasADi's symbolic
solve), multiple shooting with RK4 and direct collocation (Radau, degree 4), controls piecewise linear.  Each
method sweeps N; the wall time (build + solve, a fresh problem each run, the best of --repeats) and |J − J*| are
printed, and the time to reach 1e-6 relative is interpolated in log-log.

    python scripts/bench_multibody_ocp.py            # n = 8
    python scripts/bench_multibody_ocp.py --links 4 --quick
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402

import castrajectory as ct  # noqa: E402
from castrajectory.inspect.study import time_to_error  # noqa: E402

from bench_multibody import chain  # noqa: E402  (the same rods: scripts/ is on the path of a script)

T, UMAX, TARGET_ANGLE = 2.0, 200.0, 0.3
IPOPT = {"tol": 1e-10, "max_iter": 3000, "print_level": 0}


def final_angles(n: int) -> np.ndarray:
    return np.r_[TARGET_ANGLE, np.zeros(n - 1)]


def dmoc(n: int, N: int, scheme: str, form: str):
    mb = chain(n)
    u = ct.Control("u", n, lower=-UMAX, upper=UMAX)
    system = mb.system(form, efforts={f"pin{i + 1}": u[i] for i in range(n)})
    q0, v0 = mb.state(formulation=form)
    qT, vT = mb.state(final_angles(n), formulation=form)
    ocp = ct.OptimalControl(system, T=T, N=N, scheme=scheme)
    ocp.initial(q=q0, qd=v0)
    ocp.final(q=qT, qd=vT)
    ocp.minimize(running=ca.sumsqr(u))
    # every method starts from the same motion, the joint angles linear in time (rockit's set_initial below):
    # swung to 1 rad, the problem has several local optima (on 2 rods from the formulations' default guesses
    # 14.70, 23.56 and 34.64), and the comparison is of the time to one of them
    s = np.linspace(0.0, 1.0, N + 1)
    guess = np.array([mb.state(si * final_angles(n), formulation=form)[0] for si in s])
    sol = ocp.solve(guess={"q": guess}, options={"tol": 1e-10})
    return sol.success, float(sol.cost)


def joint_ode(n: int):
    """q̈(q, q̇, u) of the joint coordinates, from the builder's joint system with the torques as efforts."""
    mb = chain(n)
    u = ct.Control("u", n, lower=-UMAX, upper=UMAX)
    system = mb.system("joint", efforts={f"pin{i + 1}": u[i] for i in range(n)})
    qdd = system._index1_exprs()[0]
    return ca.Function("qdd", [system.q, system.qd, system.control_vector], [qdd])


def rockit_run(n: int, N: int, method: str, acc):
    from rockit import DirectCollocation, MultipleShooting, Ocp
    ocp = Ocp(T=T)
    q = ocp.state(n)
    v = ocp.state(n)
    u = ocp.control(n, order=1)
    ocp.set_der(q, v)
    ocp.set_der(v, acc(q, v, u))
    ocp.subject_to(ocp.at_t0(q) == 0)
    ocp.subject_to(ocp.at_t0(v) == 0)
    ocp.subject_to(ocp.at_tf(q) == ca.DM(final_angles(n)))
    ocp.subject_to(ocp.at_tf(v) == 0)
    ocp.subject_to(-UMAX <= (u <= UMAX))
    ocp.set_initial(q, ocp.t / T * ca.DM(final_angles(n)))
    ocp.add_objective(ocp.integral(ca.sumsqr(u)))
    ocp.solver("ipopt", {"print_time": False, "ipopt": dict(IPOPT)})
    ocp.method(MultipleShooting(N=N, M=1, intg="rk") if method == "ms" else DirectCollocation(N=N, degree=4))
    try:
        sol = ocp.solve()
        return True, float(sol.value(ocp.objective))
    except Exception:  # noqa: BLE001 - a failed solve of a peer is a row, not a crash
        return False, math.nan


def sweep(label, fn, ns, repeats, stop_time, jstar):
    rows = []
    for N in ns:
        best, ok, J = math.inf, False, math.nan
        for _ in range(repeats):
            t0 = time.perf_counter()
            ok, J = fn(N)
            best = min(best, time.perf_counter() - t0)
            if best > 10.0:
                break
        err = abs(J - jstar) / abs(jstar) if ok else math.nan
        rows.append({"label": label, "n": N, "success": ok, "status": "ok" if ok else "failed", "time_s": best,
                     "error": err})
        print(f"  {label:36s} N = {N:5d}  {'ok' if ok else 'FAILED':6s} {best:8.3f} s  J = {J:.10g}  "
              f"|J - J*|/J* = {err:.2e}", flush=True)
        if best > stop_time or (ok and err < 1e-10):
            break
    return rows


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--links", type=int, default=8, help="rods in the chain")
    p.add_argument("--quick", action="store_true", help="shorter sweeps")
    p.add_argument("--repeats", type=int, default=2, help="runs per point, best kept")
    args = p.parse_args(argv)
    if args.links < 1 or args.repeats < 1:
        p.error("--links >= 1 and --repeats >= 1")
    n = args.links
    stop = 15.0 if args.quick else 60.0
    ok1, j1 = dmoc(n, 80, "galerkin8", "maximal")
    ok2, j2 = dmoc(n, 160, "galerkin8", "maximal")
    jstar = j2
    print(f"{n}-rod chain swung to its first pin at {TARGET_ANGLE} rad, T = {T}, |u| <= {UMAX}, min ∫|u|²")
    print(f"J* = {jstar:.12g} (galerkin8, N = 160; N = 80 gives {j1:.12g}: {abs(j1 - j2) / abs(j2):.1e} relative)"
          + ("" if ok1 and ok2 else "  (a reference solve FAILED)"))
    plans = [("castrajectory maximal galerkin4", lambda N: dmoc(n, N, "galerkin4", "maximal"), [10, 20, 40, 80, 160]),
             ("castrajectory maximal galerkin6", lambda N: dmoc(n, N, "galerkin6", "maximal"), [10, 20, 40, 80]),
             ("castrajectory joint galerkin6", lambda N: dmoc(n, N, "galerkin6", "joint"), [10, 20, 40, 80])]
    import importlib.util
    if importlib.util.find_spec("rockit") is not None:
        acc = joint_ode(n)
        plans += [("rockit multiple shooting RK4", lambda N: rockit_run(n, N, "ms", acc), [25, 50, 100, 200, 400]),
                  ("rockit collocation Radau 4", lambda N: rockit_run(n, N, "dc", acc), [10, 20, 40, 80, 160])]
    else:
        print("  rockit: skipped (pip install '.[bench]' installs rockit-meco)")
    rows = []
    for label, fn, ns in plans:
        rows += sweep(label, fn, ns[:3] if args.quick else ns, args.repeats, stop, jstar)
    print("\n  time to |J - J*| / J* <= 1e-6 (interpolated in log-log)")
    cost = {}
    for lab in dict.fromkeys(r["label"] for r in rows):
        r = time_to_error(rows, lab, 1e-6, key="error", cost="time_s")
        cost[lab] = r["cost"]
        print(f"  {lab:36s} " + (f"{r['cost']:.3f} s (N = {r['n']:.0f})" if math.isfinite(r["cost"]) else r["note"]))
    ours = [c for lab, c in cost.items() if lab.startswith("castrajectory") and math.isfinite(c)]
    peers = [c for lab, c in cost.items() if lab.startswith("rockit") and math.isfinite(c)]
    if ours and peers:
        print(f"\n  castrajectory's best {min(ours):.3f} s against rockit's best {min(peers):.3f} s: "
              f"{min(peers) / min(ours):.1f}x, measured in this run")
    return 0


if __name__ == "__main__":
    sys.exit(main())
