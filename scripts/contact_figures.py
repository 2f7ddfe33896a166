#!/usr/bin/env python
"""Issue 43's figures ("What must not change"), measured in one run, by the existing batteries and problems.

Families (``--only`` picks some, comma-separated; default all, run one after another, never in parallel):

* ``contact``, ``friction``, ``schemes``: scripts/contact_battery.py at its defaults (66 scenes, seed 13), with
  ``--friction`` (110, seed 17) and with ``--schemes`` (40, seed 13): solved/total from its CSV;
* ``ocp``: scripts/ocp_battery.py at its defaults (40 problems, seed 1): the certified share of the feasible
  problems (its own summary line), and each problem's cost;
* ``contact-ocp``: scripts/contact_ocp_battery.py at seed 1 (30 problems) and seed 2 (60): certified/total (its own
  summary line) and each problem's status, cost, error against its oracle, certificate and time;
* ``hopper``: problems/hopper.py's problem at N = 20 and N = 40, solved from its guess and timed as
  scripts/bench_contact_ocp.py --hopper does (a fresh process each): cost, certificate, wall time;
* ``bench``: scripts/bench_contact_ocp.py --hopper (skipped, with a message, when nosnoc is not installed): the
  hopper's time ratios against nosnoc and the push's; its own hopper runs are listed beside the ``hopper`` family's;
* ``oracles``: problems/block_push.py (its defaults, sliding, and ``--T 2 --n 160``, sticking),
  problems/bounce_to_target.py and problems/push_to_target.py at their defaults, ``--json``: cost, oracle, error.

The batteries run the scripts themselves; the two OCP batteries run through their own ``battery()``/``main()`` in a
child process of this script (``--worker``) whose problem draws are wrapped only to record each answer.  Every
child is started with this interpreter from this checkout.  Output: a table on stdout; with ``--out FILE`` a
markdown file and a JSON file beside it (FILE with the suffix .json; or .md if FILE ends in .json), written after
every family, and the children's raw outputs in FILE's stem + ``_logs``.  ``--compare BEFORE.json`` adds a column
of the earlier figures and the per-problem cost differences (``--from AFTER.json`` compares two files without
running anything).

    python scripts/contact_figures.py --out figs_before.md
    python scripts/contact_figures.py --only hopper,oracles
    python scripts/contact_figures.py --out figs_after.md --compare figs_before.json
    python scripts/contact_figures.py --from figs_after.json --compare figs_before.json

Exit status 0 when every family ran (a figure that is worse is still 0: this measures), 1 when a family could not
be measured (its error is in the table), 2 for bad flags.
"""
from __future__ import annotations

import argparse
import csv
import importlib.util
import json
import math
import os
import platform
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PY = sys.executable
FAMILIES = ["contact", "friction", "schemes", "ocp", "contact-ocp", "hopper", "bench", "oracles"]
#: the contact-OCP battery's runs: (seed, count), issue 43's 29/30 and 57/60
OCP_SEEDS = ((1, 30), (2, 60))
HOPPER_N = (20, 40)
MARK = "@@contact_figures@@ "


# ----------------------------------------------------------------------------- helpers
def _load(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _num(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def _g(x, fmt=".12g"):
    x = _num(x)
    return "-" if math.isnan(x) else format(x, fmt)


def _git(*args) -> str:
    try:
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, timeout=30).stdout.strip()
    except Exception:
        return ""


def _loadavg() -> str:
    try:
        return " ".join(f"{v:.2f}" for v in os.getloadavg())
    except OSError:
        return "-"


class Runner:
    """Runs children one at a time, each in its own process group (ended with it on a timeout or a Ctrl-C), their
    stdout and stderr written to ``logs``."""

    def __init__(self, logs: Path, timeout: float | None):
        self.logs, self.timeout = logs, timeout
        logs.mkdir(parents=True, exist_ok=True)

    def run(self, tag: str, args: list) -> dict:
        out, err = self.logs / f"{tag}.out", self.logs / f"{tag}.err"
        env = _child_env()
        t0 = time.perf_counter()
        with open(out, "w") as fo, open(err, "w") as fe:
            proc = subprocess.Popen([PY, *map(str, args)], cwd=ROOT, stdout=fo, stderr=fe, env=env,
                                    start_new_session=True)
            try:
                rc = proc.wait(timeout=self.timeout)
            except subprocess.TimeoutExpired:
                self._stop(proc)
                rc = "timeout"
            except KeyboardInterrupt:
                self._stop(proc)
                raise
        wall = time.perf_counter() - t0
        return {"rc": rc, "wall_s": wall, "stdout": out.read_text(errors="replace"),
                "stderr": err.read_text(errors="replace"), "log": out.name}

    @staticmethod
    def _stop(proc):
        for sig, wait in ((signal.SIGTERM, 10), (signal.SIGKILL, 10)):
            try:
                os.killpg(proc.pid, sig)
                proc.wait(timeout=wait)
                return
            except (ProcessLookupError, subprocess.TimeoutExpired):
                continue


def _child_env() -> dict:
    """The children's environment: this checkout's src first on the path, so that its code is measured whichever
    checkout the interpreter's (editable) install points at."""
    path = os.pathsep.join(p for p in (str(ROOT / "src"), os.environ.get("PYTHONPATH")) if p)
    return dict(os.environ, PYTHONUNBUFFERED="1", PYTHONPATH=path)


def _package_path() -> str:
    """Where the children import castrajectory from (a check that it is this checkout's)."""
    try:
        return subprocess.run([PY, "-c", "import castrajectory; print(castrajectory.__file__)"], cwd=ROOT,
                              env=_child_env(), capture_output=True, text=True, timeout=120).stdout.strip()
    except Exception:
        return ""


def _tail(text: str, n=5) -> str:
    return " | ".join(line.strip() for line in text.strip().splitlines()[-n:])


def _payload(res: dict) -> dict:
    """The JSON a ``--worker`` child printed last."""
    for line in reversed(res["stdout"].splitlines()):
        if line.startswith(MARK):
            return json.loads(line[len(MARK):])
    raise RuntimeError(f"no result from the child (exit {res['rc']}): {_tail(res['stderr']) or _tail(res['stdout'])}")


# ----------------------------------------------------------------------------- workers (run in a child process)
def _sol_fields(sol) -> dict:
    its = _num(getattr(sol, "iterations", None))
    return {"status": str(getattr(sol, "status", "")), "success": bool(getattr(sol, "success", False)),
            "cost": _num(getattr(sol, "cost", None)), "certificate": _num(getattr(sol, "certificate", None)),
            "iterations": int(its) if math.isfinite(its) else None}


def worker_contact_ocp(seed: int, count: int) -> dict:
    """scripts/contact_ocp_battery.py's own battery(count, seed), each draw wrapped to record its answer."""
    mod = _load(ROOT / "scripts" / "contact_ocp_battery.py", "contact_ocp_battery")
    rows = []

    def wrap(family):
        def draw(rng):
            name, solve, check = family(rng)
            row = {"index": len(rows), "family": family.__name__, "name": name}
            rows.append(row)

            def timed_solve():
                t0 = time.perf_counter()
                sol = solve()
                row["time_s"] = time.perf_counter() - t0
                row.update(_sol_fields(sol))
                return sol

            def recorded_check(sol):
                err = check(sol)
                row["error"] = _num(err)
                return err
            return name, timed_solve, recorded_check
        draw.__name__ = family.__name__
        return draw

    summary = mod.battery(count, seed, [wrap(f) for f in mod.FAMILIES])
    return {"seed": seed, "count": count, "summary": summary, "rows": rows}


def worker_ocp() -> dict:
    """scripts/ocp_battery.py's own main() at its defaults, each problem's solve wrapped to record its answer."""
    mod = _load(ROOT / "scripts" / "ocp_battery.py", "ocp_battery")
    rows = []

    def wrap(family):
        def draw(rng):
            name, ocp, feasible = family(rng)
            row = {"index": len(rows), "family": family.__name__, "name": name, "feasible": bool(feasible)}
            rows.append(row)

            def timed_solve(*a, **k):
                # the class's own solve, with this wrapper off the instance meanwhile: a solve that copies its
                # problem (the ladder of grids: copy.copy(self).solve()) must not copy the wrapper
                del ocp.solve
                try:
                    t0 = time.perf_counter()
                    sol = type(ocp).solve(ocp, *a, **k)
                    row["time_s"] = time.perf_counter() - t0
                finally:
                    ocp.solve = timed_solve
                row.update(_sol_fields(sol))
                return sol
            ocp.solve = timed_solve
            return name, ocp, feasible
        draw.__name__ = family.__name__
        return draw

    mod.FAMILIES = tuple(wrap(f) for f in mod.FAMILIES)
    mod.main([])
    good = [r for r in rows if r["feasible"] and r.get("success") and r.get("certificate", math.inf) <= mod.GOAL_CERTIFICATE]
    return {"rows": rows, "certified": len(good), "feasible": sum(r["feasible"] for r in rows)}


def worker_hopper(N: int) -> dict:
    """problems/hopper.py's problem on N steps, solved from its guess, timed as bench_contact_ocp.py --hopper."""
    hop = _load(ROOT / "problems" / "hopper.py", "hopper")
    ocp = hop.problem(N=N)
    t0 = time.perf_counter()
    sol = ocp.solve(guess=ocp.guess)
    wall = time.perf_counter() - t0
    imp = sol.impact_times[0] if getattr(sol, "impact_times", None) else []
    return {"N": N, "time_s": wall, **_sol_fields(sol), "complementarity": _num(getattr(sol, "complementarity", None)),
            "end_x": float(sol.q[-1, 0]), "impact_times": [float(t) for t in imp]}


def worker(kind: str, a: list) -> int:
    if kind == "contact-ocp":
        out = worker_contact_ocp(int(a[0]), int(a[1]))
    elif kind == "ocp":
        out = worker_ocp()
    elif kind == "hopper":
        out = worker_hopper(int(a[0]))
    else:
        print(f"contact_figures: unknown worker {kind}", file=sys.stderr)
        return 2
    sys.stdout.flush()
    print(MARK + json.dumps(out, default=str))
    return 0


# ----------------------------------------------------------------------------- families (run in the parent)
def fam_battery(run: Runner, which: str) -> dict:
    flag, csv_name = {"contact": ([], "battery.csv"), "friction": (["--friction"], "friction.csv"),
                      "schemes": (["--schemes"], "schemes.csv")}[which]
    out = run.logs / f"battery_{which}"
    res = run.run(f"battery_{which}", ["scripts/contact_battery.py", *flag, "--quiet", "--out", out])
    path = out / csv_name
    if res["rc"] != 0 or not path.exists():
        raise RuntimeError(f"contact_battery.py {' '.join(flag)} exit {res['rc']}: {_tail(res['stderr'])}")
    with open(path, newline="") as f:
        scenes = list(csv.DictReader(f))
    keep = ("id", "family", "scheme", "N", "e", "mu", "status", "solved", "iterations", "time_s", "failed")
    rows = [{k: r[k] for k in keep if k in r} for r in scenes]
    for r in rows:
        r["solved"] = r.get("solved") == "True"
    times = sorted(_num(r.get("time_s")) for r in rows if not math.isnan(_num(r.get("time_s"))))
    m = re.search(r"wall time of the battery (\d+) s", res["stdout"])
    solved = sum(r["solved"] for r in rows)
    return {"value": f"{solved}/{len(rows)}", "solved": solved, "total": len(rows), "wall_s": res["wall_s"],
            "battery_wall_s": int(m.group(1)) if m else None,
            "median_s": times[len(times) // 2] if times else None, "worst_s": times[-1] if times else None,
            "not_solved": [r for r in rows if not r["solved"]], "rows": rows}


def fam_ocp(run: Runner) -> dict:
    res = run.run("ocp_battery", [Path(__file__).resolve(), "--worker", "ocp"])
    data = _payload(res)
    m = re.search(r"solved and certified \(<= [^)]*\): (\d+) of (\d+) feasible \((\d+)%\); infeasible by "
                  r"construction: (\d+), of which reported ok: (\d+)", res["stdout"])
    if not m:
        raise RuntimeError(f"ocp_battery.py: no summary line (exit {res['rc']}): {_tail(res['stderr'])}")
    good, feas, pct, infeas, wrong = map(int, m.groups())
    note = "" if (good, feas) == (data["certified"], data["feasible"]) else \
        f" (the recorded rows say {data['certified']}/{data['feasible']})"
    return {"value": f"{good}/{feas} feasible ({pct}%); infeasible {infeas}, reported ok {wrong}{note}",
            "certified": good, "feasible": feas, "infeasible": infeas, "infeasible_ok": wrong,
            "wall_s": res["wall_s"], "rows": data["rows"]}


def fam_contact_ocp(run: Runner) -> dict:
    out = {"runs": [], "wall_s": 0.0}
    for seed, count in OCP_SEEDS:
        res = run.run(f"contact_ocp_seed{seed}", [Path(__file__).resolve(), "--worker", "contact-ocp", seed, count])
        out["wall_s"] += res["wall_s"]
        data = _payload(res)
        m = re.search(r"solved with a certificate: (\d+) of (\d+)", res["stdout"])
        b = re.search(r"B-stationarity proxy[^:]*: (\d+) of (\d+) ok answers", res["stdout"])
        t = re.search(r"time: median ([\d.]+) s, worst ([\d.]+) s", res["stdout"])
        if not m:
            raise RuntimeError(f"contact_ocp_battery.py seed {seed}: no summary line: {_tail(res['stderr'])}")
        out["runs"].append({"seed": seed, "count": count, "certified": int(m.group(1)), "total": int(m.group(2)),
                            "b_stationary": int(b.group(1)) if b else None,
                            "median_s": float(t.group(1)) if t else None, "worst_s": float(t.group(2)) if t else None,
                            "wall_s": res["wall_s"], "rows": data["rows"]})
    out["value"] = ", ".join(f"seed {r['seed']}: {r['certified']}/{r['total']}" for r in out["runs"])
    return out


def fam_hopper(run: Runner) -> dict:
    out = {"runs": [], "wall_s": 0.0}
    for N in HOPPER_N:
        res = run.run(f"hopper_N{N}", [Path(__file__).resolve(), "--worker", "hopper", N])
        out["wall_s"] += res["wall_s"]
        out["runs"].append(_payload(res))
    out["value"] = "; ".join(f"N = {r['N']}: {r['status']}, cost {_g(r['cost'], '.10g')}, certificate "
                             f"{_g(r['certificate'], '.1e')}, {r['time_s']:.2f} s" for r in out["runs"])
    return out


def _nosnoc() -> bool:
    return importlib.util.find_spec("nosnoc") is not None


def fam_bench(run: Runner) -> dict:
    if not _nosnoc():
        return {"skipped": "nosnoc is not installed in this interpreter (pip install -e '.[bench]'): no ratio",
                "value": "skipped (no nosnoc)", "wall_s": 0.0}
    res = run.run("bench_contact_ocp", ["scripts/bench_contact_ocp.py", "--hopper"])
    text = res["stdout"]
    if res["rc"] != 0:
        raise RuntimeError(f"bench_contact_ocp.py --hopper exit {res['rc']}: {_tail(res['stderr'])}")
    ours = [{"N": int(m.group(1)), "status": m.group(2), "cost": _num(m.group(3)), "time_s": _num(m.group(4)),
             "certificate": _num(m.group(5))} for m in re.finditer(
        r"^hopper: castrajectory N = (\d+): (\S+), cost (\S+), ([\d.]+) s, certificate ([^,\s]+)", text, re.M)]
    theirs, setting = [], None
    for line in text.splitlines():
        m = re.match(r"hopper: nosnoc (\w+): (.*), cost (\S+), ([\d.]+) s \(build included\)", line)
        if m:
            setting = {"setting": m.group(1), "status": m.group(2), "cost": _num(m.group(3)),
                       "time_s": _num(m.group(4)), "ratios": {}}
            theirs.append(setting)
            continue
        m = re.match(r"\s+castrajectory N = (\d+): time ratio (\S+)x", line)
        if m and setting is not None:
            setting["ratios"][m.group(1)] = _num(m.group(2))
    push = [{"setting": m.group(1), "nosnoc_cost": _num(m.group(2)), "nosnoc_s": _num(m.group(3)),
             "N": int(m.group(4)), "cost": _num(m.group(5)), "time_s": _num(m.group(6)), "ratio": _num(m.group(7))}
            for m in re.finditer(r"^\s+nosnoc (\w+): cost (\S+) in ([\d.]+) s .*?castrajectory N = (\d+): (\S+) in "
                                 r"([\d.]+) s, certified \S+: ratio (\d+)x", text, re.M)]
    ref = re.search(r"reference J_ref = (\S+)", text)
    value = "; ".join(f"nosnoc {s['setting']} ({s['status']}, {s['time_s']:.1f} s): " + ", ".join(
        f"N = {n} {_ratio(r)}" for n, r in s["ratios"].items()) for s in theirs) or "no ratio printed"
    return {"value": value, "hopper": ours, "nosnoc_hopper": theirs, "push": push,
            "push_reference": _num(ref.group(1)) if ref else None, "wall_s": res["wall_s"]}


ORACLE_RUNS = (
    ("block push (sliding)", "problems/block_push.py", []),
    ("block push (sticks, T = 2, N = 160)", "problems/block_push.py", ["--T", "2", "--n", "160"]),
    ("bounce to a target", "problems/bounce_to_target.py", []),
    ("push to a target", "problems/push_to_target.py", []),
)


def fam_oracles(run: Runner) -> dict:
    out = {"runs": [], "wall_s": 0.0}
    for i, (label, script, flags) in enumerate(ORACLE_RUNS):
        res = run.run(f"oracle_{i}", [script, *flags, "--json"])
        out["wall_s"] += res["wall_s"]
        line = next((ln for ln in reversed(res["stdout"].splitlines()) if ln.startswith("{")), None)
        if line is None:
            out["runs"].append({"label": label, "error_text": f"exit {res['rc']}: {_tail(res['stderr'])}"})
            continue
        d = json.loads(line)
        r = {"label": label, "command": " ".join(["python", script, *flags]), "status": d.get("status"),
             "cost": d.get("cost"), "certificate": d.get("certificate"), "iterations": d.get("iterations"),
             "wall_s": res["wall_s"], "solve_time_s": d.get("solve_time_s")}
        if "block_push" in script:
            r.update(oracle="closed form J*", oracle_value=d.get("exact_cost"), error=d.get("error_vs_exact"),
                     discrete_optimum=d.get("discrete_optimum"),
                     discrete_error=abs(_num(d.get("cost")) - _num(d.get("discrete_optimum"))),
                     sticks=d.get("sticks"), stuck_time=d.get("stuck_time"), cost_estimate=d.get("cost_estimate"))
        elif "bounce" in script:
            exact = d.get("exact") or {}
            r.update(oracle="closed form v0, T, impact times", oracle_value=exact.get("v0"), oracle_T=exact.get("T"),
                     v0=d.get("v0"), T=d.get("T"),
                     error=max(_num(d.get(k)) for k in ("v0_error", "T_error", "impact_time_error")),
                     v0_error=d.get("v0_error"), T_error=d.get("T_error"), impact_time_error=d.get("impact_time_error"))
        else:
            r.update(oracle="free-fall landing time", oracle_value=d.get("landing_time"), error=d.get("landing_error"),
                     cost_estimate=d.get("cost_estimate"))
        out["runs"].append(r)
    out["value"] = "; ".join(f"{r['label']}: " + (r["error_text"] if "error_text" in r else
                                                   f"{r['status']}, error {_g(r.get('error'), '.1e')}")
                             for r in out["runs"])
    return out


RUNNERS = {"contact": lambda r: fam_battery(r, "contact"), "friction": lambda r: fam_battery(r, "friction"),
           "schemes": lambda r: fam_battery(r, "schemes"), "ocp": fam_ocp, "contact-ocp": fam_contact_ocp,
           "hopper": fam_hopper, "bench": fam_bench, "oracles": fam_oracles}


# ----------------------------------------------------------------------------- report
def _rows(fams: dict) -> list:
    """(key, label, value) of every figure, keys stable between runs (for --compare)."""
    out = []
    for key, label in (("contact", "contact battery (solved/total)"), ("friction", "friction battery"),
                       ("schemes", "scheme battery")):
        f = fams.get(key)
        if f and "error" not in f:
            out.append((key, label, f"{f['value']} (median {_g(f['median_s'], '.2f')} s, worst "
                                    f"{_g(f['worst_s'], '.2f')} s)"))
    f = fams.get("ocp")
    if f and "error" not in f:
        out.append(("ocp", "OCP battery share (certified <= 1e-8 / feasible)", f["value"]))
    f = fams.get("contact-ocp")
    if f and "error" not in f:
        for r in f["runs"]:
            costs = sum(_num(x.get("cost")) for x in r["rows"] if x.get("success"))
            out.append((f"contact-ocp-{r['seed']}", f"contact-OCP battery seed {r['seed']} (certified/total)",
                        f"{r['certified']}/{r['total']} (B-stationary proxy {r['b_stationary']}; median "
                        f"{_g(r['median_s'], '.2f')} s, worst {_g(r['worst_s'], '.2f')} s; sum of certified costs "
                        f"{costs:.10g})"))
    f = fams.get("hopper")
    if f and "error" not in f:
        for r in f["runs"]:
            out.append((f"hopper-{r['N']}", f"hopper N = {r['N']} (cost, certificate, time)",
                        f"{r['status']}, {_g(r['cost'], '.10g')}, {_g(r['certificate'], '.1e')}, {r['time_s']:.2f} s "
                        f"({r['iterations']} it)"))
    f = fams.get("bench")
    if f and "error" not in f:
        if f.get("skipped"):
            out.append(("bench", "bench: hopper ratio vs nosnoc", f["skipped"]))
        else:
            for s in f["nosnoc_hopper"]:
                for n, ratio in s["ratios"].items():
                    mine = next((h for h in f["hopper"] if str(h["N"]) == n), {})
                    out.append((f"bench-hopper-{s['setting']}-{n}",
                                f"bench: hopper N = {n} vs nosnoc {s['setting']} (time ratio)",
                                f"{_ratio(ratio)} (nosnoc {s['status']}, cost {_g(s['cost'], '.8g')}, "
                                f"{s['time_s']:.2f} s; castrajectory {_g(mine.get('cost'), '.8g')} in "
                                f"{_g(mine.get('time_s'), '.2f')} s)"))
            for p in f["push"]:
                out.append((f"bench-push-{p['setting']}", f"bench: push to a target vs nosnoc {p['setting']}",
                            f"{_g(p['ratio'], '.0f')}x (N = {p['N']}: {_g(p['cost'], '.8g')} in {p['time_s']:.3f} s; "
                            f"nosnoc {_g(p['nosnoc_cost'], '.8g')} in {p['nosnoc_s']:.2f} s)"))
    f = fams.get("oracles")
    if f and "error" not in f:
        for i, r in enumerate(f["runs"]):
            if "error_text" in r:
                out.append((f"oracle-{i}", r["label"], r["error_text"]))
                continue
            extra = ""
            if "discrete_optimum" in r:
                extra = f"; midpoint optimum J_N {_g(r['discrete_optimum'])}, |J − J_N| {_g(r['discrete_error'], '.1e')}"
            if "v0_error" in r:
                value = (f"{r['status']}, v0 {_g(r['v0'])} (closed form {_g(r['oracle_value'])}, error "
                         f"{_g(r['v0_error'], '.1e')}), T {_g(r['T'])} ({_g(r['oracle_T'])}, {_g(r['T_error'], '.1e')}), "
                         f"impact times {_g(r['impact_time_error'], '.1e')}; error {_g(r['error'], '.2e')}")
            else:
                value = (f"{r['status']}, cost {_g(r['cost'])}, oracle {_g(r['oracle_value'])}, error "
                         f"{_g(r['error'], '.2e')}{extra}; cost's own estimate {_g(r.get('cost_estimate'), '.1e')}")
            out.append((f"oracle-{i}", f"{r['label']} against {r['oracle']}",
                        f"{value}; certificate {_g(r['certificate'], '.1e')}"))
    for key, f in fams.items():
        if "error" in f:
            out.append((key, f"{key}: NOT MEASURED", f["error"]))
    return out


def _ratio(x) -> str:
    return "no ratio" if math.isnan(_num(x)) else f"{_num(x):.1f}x"


def _esc(s) -> str:
    return str(s).replace("|", "\\|")


def render(data: dict, before: dict | None = None) -> str:
    fams = data["families"]
    meta = data["meta"]
    lines = ["# Issue 43's contact figures", "",
             f"commit {meta['commit']}{' (with uncommitted changes)' if meta['dirty'] else ''}; python "
             f"{meta['python']}, casadi {meta['casadi']}, nosnoc {meta['nosnoc']}; {meta['cpus']} CPUs; started "
             f"{meta['started']}, {meta['wall_s']:.0f} s in all; load average at start {meta['load_start']}, at end "
             f"{meta['load_end']}", "", f"rerun: `{meta['command']}`", ""]
    b_rows = {k: v for k, _, v in _rows(before["families"])} if before else {}
    if before:
        bm = before["meta"]
        lines += [f"compared with: commit {bm['commit']}{' (dirty)' if bm['dirty'] else ''}, started {bm['started']}",
                  ""]
        lines += ["| figure | now | before |", "|---|---|---|"]
        lines += [f"| {_esc(label)} | {_esc(v)} | {_esc(b_rows.get(k, '-'))} |" for k, label, v in _rows(fams)]
    else:
        lines += ["| figure | value |", "|---|---|"]
        lines += [f"| {_esc(label)} | {_esc(v)} |" for _, label, v in _rows(fams)]
    lines += ["", "## Wall time per family", "", "| family | wall s |", "|---|---|"]
    lines += [f"| {k} | {f.get('wall_s', 0):.0f} |" for k, f in fams.items()]
    for key in ("contact", "friction", "schemes"):
        f = fams.get(key)
        if f and f.get("not_solved"):
            lines += ["", f"## {key} battery: not solved", ""]
            lines += [f"* {r.get('id')} {r.get('family')} N = {r.get('N')}: {r.get('status')} {r.get('failed', '')}"
                      for r in f["not_solved"]]
    f = fams.get("contact-ocp")
    if f and "error" not in f:
        bruns = {r["seed"]: r for r in (before or {}).get("families", {}).get("contact-ocp", {}).get("runs", [])}
        for r in f["runs"]:
            brows = {x["index"]: x for x in bruns.get(r["seed"], {}).get("rows", [])}
            lines += ["", f"## contact-OCP battery, seed {r['seed']}: every problem", ""]
            head = "| # | problem | status | cost | error | certificate | it | time s |"
            if before:
                head += " cost before | status before | change |"
            lines += [head, "|" + "---|" * (head.count("|") - 1)]
            for x in r["rows"]:
                cells = [x["index"], _esc(x["name"]), x.get("status", "-"), _g(x.get("cost")), _g(x.get("error"), ".1e"),
                         _g(x.get("certificate"), ".1e"), x.get("iterations", "-"), _g(x.get("time_s"), ".2f")]
                if before:
                    y = _same_draw(brows, x)
                    cells += [_g(y.get("cost")), y.get("status", "-"), _change(y, x)]
                lines.append("| " + " | ".join(str(c) for c in cells) + " |")
    f = fams.get("ocp")
    if f and "error" not in f:
        brows = {x["index"]: x for x in (before or {}).get("families", {}).get("ocp", {}).get("rows", [])}
        lines += ["", "## OCP battery: every problem", ""]
        head = "| # | problem | feasible | status | cost | certificate | it | time s |"
        if before:
            head += " cost before | change |"
        lines += [head, "|" + "---|" * (head.count("|") - 1)]
        for x in f["rows"]:
            cells = [x["index"], _esc(x["name"]), x["feasible"], x.get("status", "-"), _g(x.get("cost")),
                     _g(x.get("certificate"), ".1e"), x.get("iterations", "-"), _g(x.get("time_s"), ".3f")]
            if before:
                y = _same_draw(brows, x)
                cells += [_g(y.get("cost")), _change(y, x)]
            lines.append("| " + " | ".join(str(c) for c in cells) + " |")
    notes = data.get("notes") or []
    if notes:
        lines += ["", "## Notes", ""] + [f"* {n}" for n in notes]
    return "\n".join(lines) + "\n"


def _same_draw(before_rows: dict, now: dict) -> dict:
    """The earlier run's row of the same draw (same index, same name), or {}: a battery whose draws changed is not
    compared row by row."""
    y = before_rows.get(now["index"], {})
    return y if y.get("name") == now["name"] else {}


def _change(before: dict, now: dict) -> str:
    a, b = _num(before.get("cost")), _num(now.get("cost"))
    if not before:
        return "new row"
    if before.get("success") != now.get("success"):
        return f"success {before.get('success')} -> {now.get('success')}"
    if math.isnan(a) or math.isnan(b):
        return "-"
    d = b - a
    if abs(d) <= 1e-9 * max(1.0, abs(a)):
        return "same"
    return f"{'lower' if d < 0 else 'higher'} by {abs(d):.3g}"


def _meta(started: float) -> dict:
    try:
        import casadi
        cas = casadi.__version__
    except Exception:
        cas = "-"
    return {"commit": _git("rev-parse", "--short", "HEAD") or "-", "dirty": bool(_git("status", "--porcelain",
                                                                                        "--untracked-files=no")),
            "python": platform.python_version(), "casadi": cas, "nosnoc": "yes" if _nosnoc() else "no",
            "cpus": os.cpu_count(), "started": time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(started)),
            "load_start": _loadavg(), "load_end": None, "wall_s": 0.0,
            "command": "python scripts/contact_figures.py " + " ".join(sys.argv[1:])}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", help="markdown file of the figures (a JSON file beside it, the raw logs in FILE's stem + "
                   "_logs)")
    p.add_argument("--only", help="families, comma-separated: " + ",".join(FAMILIES))
    p.add_argument("--timeout", type=float, default=None, help="seconds per child process (default: none)")
    p.add_argument("--compare", metavar="BEFORE.json", help="an earlier run's JSON: its figures beside these")
    p.add_argument("--from", dest="from_json", metavar="AFTER.json", help="render this JSON instead of running")
    p.add_argument("--worker", nargs="+", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.worker:
        return worker(args.worker[0], args.worker[1:])
    # SIGTERM as Ctrl-C: the running child's process group is ended with this process, the finished families kept
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    names = FAMILIES if not args.only else [s.strip() for s in args.only.split(",") if s.strip()]
    unknown = [n for n in names if n not in FAMILIES]
    if unknown:
        p.error(f"--only: unknown {', '.join(unknown)} (choose from {', '.join(FAMILIES)})")
    before = json.loads(Path(args.compare).read_text()) if args.compare else None
    if args.out:
        out = Path(args.out)
        md, js = (out.with_suffix(".md"), out) if out.suffix == ".json" else (out, out.with_suffix(".json"))
        logs = out.with_name(out.stem + "_logs")
    else:
        md = js = None
        logs = Path(tempfile.mkdtemp(prefix="contact_figures_"))

    if args.from_json:
        data = json.loads(Path(args.from_json).read_text())
    else:
        started = time.time()
        data = {"meta": _meta(started), "families": {}, "notes": []}
        if data["meta"]["dirty"]:
            data["notes"].append("the checkout has uncommitted changes to tracked files")
        pkg = _package_path()
        data["meta"]["package_in_checkout"] = bool(pkg) and Path(pkg).resolve().is_relative_to(ROOT / "src")
        if not data["meta"]["package_in_checkout"]:
            print(f"contact_figures: the children would import castrajectory from {pkg or '(nowhere)'}, not from "
                  f"this checkout's src: nothing measured", file=sys.stderr)
            return 2
        print(f"contact figures: {', '.join(names)}; raw outputs in {logs}", file=sys.stderr)
        run = Runner(logs, args.timeout)
        for name in names:
            print(f"[{time.strftime('%H:%M:%S')}] {name} ...", file=sys.stderr, flush=True)
            t0 = time.perf_counter()
            try:
                fam = RUNNERS[name](run)
            except KeyboardInterrupt:
                print("contact_figures: interrupted; the families that finished are written", file=sys.stderr)
                break
            except Exception as exc:  # one family that cannot be measured does not stop the others
                fam = {"error": f"{type(exc).__name__}: {exc}", "value": "not measured"}
            fam.setdefault("wall_s", time.perf_counter() - t0)
            data["families"][name] = fam
            if fam.get("skipped"):
                data["notes"].append(f"{name}: {fam['skipped']}")
            print(f"[{time.strftime('%H:%M:%S')}] {name}: {fam.get('value')} ({fam['wall_s']:.0f} s)",
                  file=sys.stderr, flush=True)
            data["meta"]["load_end"] = _loadavg()
            data["meta"]["wall_s"] = time.time() - started
            if js:
                js.write_text(json.dumps(data, indent=1, default=str))
                md.write_text(render(data, before))
    text = render(data, before)
    print(text)
    if md:
        md.write_text(text)
        if not args.from_json:
            js.write_text(json.dumps(data, indent=1, default=str))
        print(f"written: {md}" + ("" if args.from_json else f", {js}"), file=sys.stderr)
    return 1 if any("error" in f for f in data["families"].values()) else 0


if __name__ == "__main__":
    sys.exit(main())
