"""Fault injection (issue 42): every fault the issue names, injected into a real run, and whether it held.

Usage::

    python scripts/fault_injection.py            # the whole set (about 3-4 minutes on 2 cores)
    python scripts/fault_injection.py --only cache signals

Families: ``cache`` (the compile cache damaged in a temporary cache folder, each load in a child process),
``signals`` (SIGINT, SIGTERM and SIGKILL at several points of a run), ``inputs`` (malformed system and control
files and flags), ``memory`` (impossible sizes under ``setrlimit``), ``sweeps`` (Ctrl-C into a sweep).  A fault
*held* when the run ended as the issue asks: the right exit code, one line on stderr and no traceback, the right
answer, and no earlier output overwritten.  Prints one table row per fault; exits 1 if any did not hold.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import resource
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "MPLBACKEND": "Agg"}
PY = sys.executable

#: the probe of the cache cases: compiled through the cache in a child, its values against the VM's
PROBE = r"""
import json, sys
import casadi as ca
from castrajectory.solve import jit
x = ca.SX.sym("x", 2)
f = ca.Function("fault_probe", [x], [ca.vertcat(ca.sin(x[0]) * x[1] + float(sys.argv[1]), x[0] ** 3)])
g = jit.compiled(f)
v = [0.3, 2.0]
print(json.dumps({"right": [float(a) for a in ca.vertsplit(g(v))] == [float(a) for a in ca.vertsplit(f(v))],
                  "stats": jit.stats}))
"""

OSCILLATOR = """
import casadi as ca
import castrajectory as ct
x = ca.SX.sym("x", 1)
K = 4.0
def system():
    return ct.LagrangianSystem(x, ct.MassMatrix({mass}), [ct.Potential(0.5 * K * x[0] ** 2)], names=["x"])
q0 = [1.0]
qd0 = [0.0]
"""

CONTROL = """
import casadi as ca
import castrajectory as ct
def problem(N=40, scheme="midpoint"):
    u = ct.Control("u", 1, lower=-50, upper=50)
    x = ca.SX.sym("x", 1)
    block = ct.LagrangianSystem(x, ct.MassMatrix(-1.0), [ct.Force(u)], names=["x"])
    ocp = ct.OptimalControl(block, T=1.0, N=N, scheme=scheme)
    ocp.initial(q=[0.0], qd=[0.0])
    ocp.final(q=[1.0], qd=[0.0])
    ocp.minimize(running=u ** 2)
    return ocp
"""


def _run(args, timeout=300, cwd=None, env=None, limit_as=None):
    pre = None
    if limit_as is not None:
        def pre():
            resource.setrlimit(resource.RLIMIT_AS, (limit_as, limit_as))
    t0 = time.perf_counter()
    p = subprocess.run([PY, *args], capture_output=True, text=True, timeout=timeout, cwd=cwd, env=env or ENV,
                       preexec_fn=pre)
    return p, time.perf_counter() - t0


def _one_line(p, code):
    """The issue's refusal: ``code``, one line on stderr, no traceback."""
    lines = p.stderr.strip().splitlines()
    return p.returncode == code and len(lines) == 1 and "Traceback" not in p.stderr


def _signal_after(args, seconds, sig, cwd=None):
    p = subprocess.Popen([PY, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV, cwd=cwd,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    time.sleep(seconds)
    if p.poll() is not None:
        p.communicate()
        return None
    t0 = time.perf_counter()
    p.send_signal(sig)
    out, err = p.communicate(timeout=300)
    return p.returncode, out, err, time.perf_counter() - t0


# ------------------------------------------------------------------------------------------------ cache
def _probe(cache, tag):
    p, _ = _run(["-c", PROBE, repr(tag)], env={**ENV, "CASTRAJECTORY_CACHE_DIR": str(cache), "CASTRAJECTORY_JIT": "1"})
    if p.returncode != 0:
        return None, p
    return json.loads(p.stdout), p


def cache_cases():
    def damaged(kind):
        def case():
            with tempfile.TemporaryDirectory() as tmp:
                cache = Path(tmp)
                _probe(cache, 0.25)
                (lib,) = sorted((cache / "jit").glob("fault_probe_*.so"))
                stamp = lib.with_name(lib.name + ".sha256")
                if kind.startswith("swapped"):
                    _probe(cache, -3.5)
                    other = [q for q in (cache / "jit").glob("fault_probe_*.so") if q != lib][0]
                    lib.write_bytes(other.read_bytes())
                    if kind.endswith("stamp"):
                        stamp.write_text(other.with_name(other.name + ".sha256").read_text())
                elif kind == "truncated to half":
                    lib.write_bytes(lib.read_bytes()[:lib.stat().st_size // 2])
                elif kind == "code bytes zeroed":
                    data = bytearray(lib.read_bytes())
                    data[len(data) // 4:len(data) // 2] = bytes(len(data) // 2 - len(data) // 4)
                    lib.write_bytes(bytes(data))
                else:
                    stamp.unlink()
                out, p = _probe(cache, 0.25)
                if out is None:
                    return f"exit {p.returncode} (a crash: {-p.returncode if p.returncode < 0 else ''})", False
                lines = p.stderr.strip().splitlines()
                again, p2 = _probe(cache, 0.25)
                held = (out["right"] and out["stats"]["quarantined"] == 1 and len(lines) == 1 and again is not None
                        and again["stats"]["compiled"] == 0 and p2.stderr == "")
                return (f"exit 0, values {'right' if out['right'] else 'WRONG'}, {len(lines)} line, quarantined "
                        f"{out['stats']['quarantined']}, recompiled; next run loads silently"), held
        return case

    def dead_build():
        with tempfile.TemporaryDirectory() as tmp:
            cache = Path(tmp)
            dead = subprocess.Popen([PY, "-c", "pass"])
            dead.wait()
            host = socket.gethostname().replace("-", "_")
            gone = cache / "jit" / f".build-{host}-{dead.pid}-x"
            gone.mkdir(parents=True)
            _probe(cache, 0.5)
            return ("removed at the next run" if not gone.exists() else "left"), not gone.exists()

    kinds = ["swapped for other constants", "swapped with its stamp", "truncated to half", "code bytes zeroed",
             "without its stamp"]
    return [("cache", f"library {k}", damaged(k)) for k in kinds] + \
        [("cache", "build folder of a killed compile", dead_build)]


# ------------------------------------------------------------------------------------------------ signals
def signal_cases():
    def sigint_block_move():
        codes, slowest, n = [], 0.0, 25
        for i in range(n):
            got = _signal_after([str(ROOT / "problems" / "block_move.py"), "--n", "20000"], 1.2 + 0.15 * i,
                                signal.SIGINT)
            if got is None:
                continue
            rc, out, err, dt = got
            codes.append(rc == 130 and err.strip().splitlines() == ["block_move.py: interrupted"])
            slowest = max(slowest, dt)
        return (f"{sum(codes)} of {len(codes)} exit 130 with one line; slowest {slowest:.2f} s after the signal",
                all(codes) and len(codes) >= n // 2)

    def sigterm_solve():
        with tempfile.TemporaryDirectory() as tmp:
            keep = Path(tmp) / "keep.png"
            keep.write_bytes(b"earlier")
            got = _signal_after([str(ROOT / "problems" / "n_link_pendulum.py"), "--links", "12", "--n", "4000", "--T",
                                 "10", "--plot", str(keep)], 3.0, signal.SIGTERM)
            if got is None:
                return "ended before the signal", False
            rc, out, err, dt = got
            clean = [f.name for f in Path(tmp).iterdir()] == ["keep.png"] and keep.read_bytes() == b"earlier"
            return (f"exit {rc} after {dt:.2f} s, {len(err.strip().splitlines())} line, earlier picture "
                    f"{'kept' if clean else 'CHANGED'}, no temporary file" if clean else "temporaries left"), \
                rc == 143 and clean and len(err.strip().splitlines()) == 1

    def report(sig, label):
        def case():
            with tempfile.TemporaryDirectory() as tmp:
                out_dir = Path(tmp) / "report"
                out_dir.mkdir()
                (out_dir / "summary.md").write_text("earlier\n")
                got = _signal_after(["-m", "castrajectory.cli", "report", "--out", str(out_dir), "--quick"], 8.0, sig)
                if got is None:
                    return "ended before the signal", False
                rc, out, err, dt = got
                same = sorted(f.name for f in out_dir.iterdir()) == ["summary.md"] and \
                    (out_dir / "summary.md").read_text() == "earlier\n"
                return f"exit {rc}; the earlier report {'untouched' if same else 'MIXED with new files'}", \
                    same and rc == {signal.SIGINT: 130, signal.SIGTERM: 143, signal.SIGKILL: -9}[sig]
        return case

    def during_compile(sig, group):
        def case():
            word, code = ("interrupted", 130) if sig == signal.SIGINT else ("terminated", 143)
            held, notes = [], []
            for delay in (0.0, 0.05, 0.2, 0.5):
                with tempfile.TemporaryDirectory() as tmp:
                    cache = Path(tmp) / "cache"
                    env = {**ENV, "CASTRAJECTORY_CACHE_DIR": str(cache)}
                    args = [PY, str(ROOT / "problems" / "n_link_pendulum.py"), "--links", "6", "--n", "3000", "--T",
                            "3"]
                    p = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                                         start_new_session=True)
                    t0 = time.perf_counter()
                    while not any((b / "f.c").exists() for b in (cache / "jit").glob(".build-*")):
                        if p.poll() is not None or time.perf_counter() - t0 > 60:
                            break
                        time.sleep(0.005)
                    if p.poll() is not None:
                        p.communicate()
                        notes.append("ended first")
                        continue
                    time.sleep(delay)
                    (os.killpg(p.pid, sig) if group else p.send_signal(sig))
                    out, err = p.communicate(timeout=300)
                    jit_dir = cache / "jit"
                    clean = not list(jit_dir.glob(".build-*")) and all(
                        (jit_dir / (f.name + ".sha256")).exists() for f in jit_dir.glob("*.so"))
                    again, _ = _run(args[1:], env=env)
                    ok = (p.returncode == code and err.strip().splitlines() == [f"n_link_pendulum.py: {word}"]
                          and clean and again.returncode == 0 and again.stderr == "")
                    held.append(ok)
            return (f"{sum(held)} of {len(held)} delays: exit {code}, one line, no build folder or unstamped "
                    f"library left, the next run ok and silent" + (f" ({', '.join(notes)})" if notes else "")), \
                all(held) and len(held) >= 3
        return case

    return [("signals", "SIGINT into optimal control (block_move, 25 delays)", sigint_block_move),
            ("signals", "Ctrl-C (process group) during a compile, 4 delays", during_compile(signal.SIGINT, True)),
            ("signals", "SIGTERM during a compile, 4 delays", during_compile(signal.SIGTERM, False)),
            ("signals", "SIGTERM during Ipopt with --plot", sigterm_solve),
            ("signals", "SIGINT into the report", report(signal.SIGINT, "SIGINT")),
            ("signals", "SIGTERM into the report", report(signal.SIGTERM, "SIGTERM")),
            ("signals", "SIGKILL into the report", report(signal.SIGKILL, "SIGKILL"))]


# ------------------------------------------------------------------------------------------------ inputs
def input_cases():
    def system_file(extra, mass=1.0, cmd="system"):
        def case():
            with tempfile.TemporaryDirectory() as tmp:
                path = Path(tmp) / "user.py"
                path.write_text(textwrap.dedent(OSCILLATOR.format(mass=mass)) + extra + "\n")
                p, dt = _run(["-m", "castrajectory.cli", cmd, str(path)])
                line = (p.stderr.strip().splitlines() or [""])[-1].replace(str(path), "FILE")
                return f"exit {p.returncode}: {line[:110]}", _one_line(p, 2) and p.stdout == ""
        return case

    def huge_state():
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "user.py"
            path.write_text(textwrap.dedent(OSCILLATOR.format(mass=1.0)).replace(
                "q0 = [1.0]", "q0 = [1.0] * 2_000_000 + ['x']"))
            p, _ = _run(["-m", "castrajectory.cli", "system", str(path)])
            return f"exit {p.returncode}, stderr {len(p.stderr)} characters", _one_line(p, 2) and len(p.stderr) < 400

    def control_negative_mass():
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "block.py"
            path.write_text(textwrap.dedent(CONTROL))
            p, _ = _run(["-m", "castrajectory.cli", "control", str(path)])
            return f"exit {p.returncode}: {(p.stderr.strip().splitlines() or [''])[-1][-80:]}", _one_line(p, 2)

    def report_out_file():
        with tempfile.TemporaryDirectory() as tmp:
            f = Path(tmp) / "a_file"
            f.write_text("mine\n")
            p, _ = _run(["-m", "castrajectory.cli", "report", "--out", str(f), "--quick"])
            return f"exit {p.returncode}", _one_line(p, 2) and f.read_text() == "mine\n"

    def huge_span():
        p, _ = _run([str(ROOT / "problems" / "droplet.py"), "--span", "1e6", "--json"])
        err = json.loads(p.stdout)["errors"]["pressure"] if p.returncode == 0 else float("nan")
        return f"exit {p.returncode}, stderr {len(p.stderr)} characters, pressure error {err:.2e}", \
            p.returncode == 0 and p.stderr == "" and err < 1e-4

    def sibling():
        with tempfile.TemporaryDirectory() as tmp:
            (Path(tmp) / "fault_sibling_k.py").write_text("K = 4.0\n")
            path = Path(tmp) / "user.py"
            path.write_text(textwrap.dedent(OSCILLATOR.format(mass=1.0)).replace("K = 4.0",
                                                                                  "from fault_sibling_k import K"))
            p, _ = _run(["-m", "castrajectory.cli", "system", str(path), "--json"], cwd=str(ROOT))
            return f"exit {p.returncode}", p.returncode == 0

    return [("inputs", "system file: T = 'two'", system_file("T = 'two'")),
            ("inputs", "system file: n = inf", system_file("n = float('inf')")),
            ("inputs", "system file: links = 5", system_file("links = 5")),
            ("inputs", "system file: n = 200.7", system_file("n = 200.7")),
            ("inputs", "system file: 2e6-entry q0 with one word", huge_state),
            ("inputs", "system file: sys.exit(0)", system_file("import sys\nsys.exit(0)")),
            ("inputs", "control file: negative mass", control_negative_mass),
            ("inputs", "report --out FILE", report_out_file),
            ("inputs", "droplet --span 1e6 (oracle, warnings)", huge_span),
            ("inputs", "system file importing its sibling module", sibling)]


# ------------------------------------------------------------------------------------------------ memory
def memory_cases():
    def limited(args, label):
        def case():
            p, dt = _run(args, limit_as=4 << 30, timeout=600)
            line = (p.stderr.strip().splitlines() or [""])[-1]
            return f"exit {p.returncode} after {dt:.1f} s: {line[:90]}", _one_line(p, 2) and dt < 30
        return case
    return [("memory", "droplet N = 5e7 under a 4 GB limit",
             limited([str(ROOT / "problems" / "droplet.py"), "--n", "50000000"], "droplet")),
            ("memory", "optimal control N = 3e6 under a 4 GB limit",
             limited([str(ROOT / "problems" / "block_move.py"), "--n", "3000000"], "ocp"))]


# ------------------------------------------------------------------------------------------------ sweeps
def sweep_cases():
    def ctrl_c(workers):
        def case():
            with tempfile.TemporaryDirectory() as tmp:
                folder = Path(tmp) / "battery"
                out = folder / "battery.csv"
                args = [str(ROOT / "scripts" / "contact_battery.py"), "--count", "30", "--family", "ball", "--out",
                        str(folder)]
                if workers:
                    args += ["--workers", str(workers)]
                got = _signal_after(args, 8.0, signal.SIGINT)
                if got is None:
                    return "ended before the signal", False
                rc, o, err, dt = got
                rows = max(0, len(out.read_text().splitlines()) - 1) if out.exists() else 0
                lines = err.strip().splitlines()
                return f"exit {rc} after {dt:.1f} s, {len(lines)} line(s), {rows} finished rows kept", \
                    rc == 130 and len(lines) == 1 and "Traceback" not in err and dt < 5.0 and rows > 0
        return case
    def dask_dies():
        try:
            import distributed  # noqa: F401
        except ImportError:
            return "distributed not installed (the dist extra): skipped", True
        cluster = subprocess.Popen([PY, "-c", CLUSTER], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                   env=ENV)
        try:
            address = cluster.stdout.readline().strip()
            with tempfile.TemporaryDirectory() as tmp:
                folder = Path(tmp) / "battery"
                p = subprocess.Popen([PY, str(ROOT / "scripts" / "contact_battery.py"), "--count", "30", "--family",
                                      "ball", "--dask-scheduler", address, "--out", str(folder)],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)
                done = 0
                while done < 2:                           # two finished scenes, then the scheduler dies
                    line = p.stdout.readline()
                    if not line:
                        break
                    done += bool(re.match(r"\s*\d{3} ", line))
                cluster.kill()
                t0 = time.perf_counter()
                _, err = p.communicate(timeout=120)
                dt = time.perf_counter() - t0
                out = folder / "battery.csv"
                rows = max(0, len(out.read_text().splitlines()) - 1) if out.exists() else 0
                lines = err.strip().splitlines()
                return f"exit {p.returncode} after {dt:.1f} s, {len(lines)} line(s), {rows} finished rows kept", \
                    p.returncode == 1 and len(lines) == 1 and "Traceback" not in err and rows > 0
        finally:
            cluster.kill()
            cluster.communicate()

    return [("sweeps", "Ctrl-C into contact_battery.py (serial)", ctrl_c(0)),
            ("sweeps", "Ctrl-C into contact_battery.py --workers 2", ctrl_c(2)),
            ("sweeps", "the Dask scheduler killed mid-sweep", dask_dies)]


#: a Dask scheduler and worker in one process, for the sweep case (its address on the first line)
CLUSTER = """
import time
from distributed import LocalCluster
cluster = LocalCluster(host="127.0.0.1", protocol="tcp", scheduler_port=0, n_workers=1, threads_per_worker=2,
                       processes=False, dashboard_address=None)
print(cluster.scheduler_address, flush=True)
time.sleep(300)
"""


FAMILIES = {"cache": cache_cases, "signals": signal_cases, "inputs": input_cases, "memory": memory_cases,
            "sweeps": sweep_cases}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="+", choices=sorted(FAMILIES), help="run only these families")
    args = ap.parse_args(argv)
    rows, t_all = [], time.perf_counter()
    print(f"| family | fault | outcome | held | s |\n|---|---|---|---|---|", flush=True)
    for fam in args.only or list(FAMILIES):
        for family, fault, case in FAMILIES[fam]():
            t0 = time.perf_counter()
            try:
                outcome, held = case()
            except Exception as exc:  # a case that cannot run is reported, not hidden
                outcome, held = f"the case itself failed: {exc.__class__.__name__}: {str(exc)[:80]}", False
            rows.append(held)
            print(f"| {family} | {fault} | {outcome} | {'held' if held else 'NOT HELD'} | "
                  f"{time.perf_counter() - t0:.1f} |", flush=True)
    print(f"\n{sum(rows)} of {len(rows)} faults held ({time.perf_counter() - t_all:.0f} s)")
    return 0 if all(rows) else 1


if __name__ == "__main__":
    sys.exit(main())
