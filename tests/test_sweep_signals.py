"""A sweep that is stopped keeps what finished (issue 42): Ctrl-C or SIGTERM into a sweep script, serially or on a
process pool, exits 130 or 143 within seconds with one line on stderr and the finished rows in its CSV (it printed a
20-32-line traceback, kept nothing and took 6-23 s, waiting for the pool's runs); a Dask scheduler that dies midway
keeps the finished rows too, says how many scenes were not run, and exits 1 (it printed two tracebacks, 51 lines, and
wrote no CSV).

Real signals go to a subprocess running a small contact battery (the ball scenes, under a second each); the
scenes' child processes must not outlive the sweep (each run carries a marker in its environment)."""
from __future__ import annotations

import concurrent.futures as cf
import csv
import os
import re
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
BATTERY = str(ROOT / "scripts" / "contact_battery.py")
#: --count 30 --family ball: 10 ball scenes and one twin at 2N
BALLS = ["--count", "30", "--family", "ball", "--timeout", "60"]
SCENES = 11
LINE = re.compile(r"contact_battery\.py: (interrupted|terminated) (?:after (\d+) of 11 scenes; their rows are in (.+)"
                  r"|before any of 11 scenes finished; nothing written)$")


def _start(args, mark):
    # the child gets SIGINT's default disposition, as under a terminal (a test runner started as a background job
    # passes SIGINT on ignored, and Python then keeps ignoring it)
    env = {**os.environ, "MPLBACKEND": "Agg", "SWEEP_SIGNALS_TEST": mark}
    return subprocess.Popen([sys.executable, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def _rows_printed(p, k):
    """Read the sweep's stdout until ``k`` scene lines were printed; their ids."""
    ids = []
    while len(ids) < k:
        line = p.stdout.readline()
        assert line, f"the sweep ended before {k} scenes: {p.stderr.read()}"
        ids.append(line.split()[0])
    return ids


def _in_first_scene(p, mark, seconds=60.0):
    """Wait until the sweep runs its first scene (a child process of the sweep carries ``mark``): past the imports,
    which Python's default handlers cover (a signal there gets Python's default, as in every command)."""
    if not os.path.isdir("/proc"):
        time.sleep(3.0)
        return
    t0 = time.perf_counter()
    while not any(_parent(pid) == p.pid for pid in _alive(mark)):
        assert p.poll() is None and time.perf_counter() - t0 < seconds, "no scene started"
        time.sleep(0.02)


def _parent(pid):
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return int(fh.read().rsplit(")", 1)[1].split()[1])
    except OSError:
        return None


def _alive(mark):
    """Processes still running (not zombies) whose environment holds ``mark``."""
    left = []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/environ", "rb") as fh:
                if mark.encode() not in fh.read():
                    continue
            with open(f"/proc/{pid}/stat") as fh:
                if fh.read().rsplit(")", 1)[1].split()[0] != "Z":
                    left.append(int(pid))
        except OSError:
            continue
    return left


def _none_left(mark, seconds=5.0):
    if not os.path.isdir("/proc"):
        return True
    t0 = time.perf_counter()
    while _alive(mark):
        if time.perf_counter() - t0 > seconds:
            return False
        time.sleep(0.1)
    return True


def _csv_rows(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


@pytest.mark.parametrize("workers, sig, after", [
    (1, signal.SIGINT, 2),          # serially, between scenes' child processes
    (1, signal.SIGTERM, 0),         # in the first scene: nothing to write
    (2, signal.SIGINT, 1),          # on a process pool, two scenes running
    (2, signal.SIGTERM, 2),
], ids=["serial-int-after-2", "serial-term-at-start", "pool-int-after-1", "pool-term-after-2"])
def test_a_signal_stops_the_sweep_and_keeps_the_finished_rows(tmp_path, workers, sig, after):
    out = tmp_path / "battery"
    mark = uuid.uuid4().hex
    p = _start([BATTERY, *BALLS, "--workers", str(workers), "--out", str(out)], mark)
    try:
        printed = _rows_printed(p, after) if after else []
        if not after:
            _in_first_scene(p, mark)
        t0 = time.perf_counter()
        p.send_signal(sig)
        stdout, err = p.communicate(timeout=60)
        seconds = time.perf_counter() - t0
    finally:
        p.kill()
    assert p.returncode == (130 if sig == signal.SIGINT else 143), err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    m = LINE.match(lines[0])
    assert m and m[1] == ("interrupted" if sig == signal.SIGINT else "terminated"), lines[0]
    assert seconds < 5.0, seconds            # measured 0.05-0.3 s (it was 6-23 s on a pool)
    csv_path = out / "battery.csv"
    if m[2] is None:
        assert not printed and not csv_path.exists()
    else:
        assert Path(m[3]) == csv_path
        rows = _csv_rows(csv_path)
        assert len(rows) == int(m[2]) >= len(printed)
        assert {r["id"] for r in rows} >= set(printed)          # every scene it printed is in the file
        assert all(r["family"] == "ball" and r["solved"] in ("True", "False") and float(r["time_s"]) > 0
                   for r in rows)
        assert (out / "summary.md").read_text().startswith(f"**Stopped after {len(rows)} of {SCENES} scenes")
    assert not [f for f in out.iterdir() if ".tmp" in f.name]
    assert _none_left(mark), "a scene's child process outlived the sweep"


def test_every_sweep_script_shares_it(tmp_path):
    """Another sweep script (the droplet's convergence) on a pool: the same one line, exit code and rows."""
    mark = uuid.uuid4().hex
    p = _start([str(ROOT / "scripts" / "droplet_convergence.py"), "--n-max", "100000", "--workers", "2",
                "--out", str(tmp_path)], mark)
    try:
        printed = _rows_printed(p, 3)
        t0 = time.perf_counter()
        p.send_signal(signal.SIGTERM)
        _, err = p.communicate(timeout=60)
        seconds = time.perf_counter() - t0
    finally:
        p.kill()
    assert p.returncode == 143 and seconds < 5.0, err
    path = tmp_path / "droplet_convergence.csv"
    m = re.fullmatch(r"droplet_convergence\.py: terminated after (\d+) of 30 runs; their rows are in (.+)\n", err)
    assert m and Path(m[2]) == path, err
    rows = _csv_rows(path)
    assert len(rows) == int(m[1]) >= len(printed) and all(r["status"] == "ok" for r in rows)
    assert _none_left(mark)


_CLUSTER = """
import time
from distributed import LocalCluster
cluster = LocalCluster(host="127.0.0.1", protocol="tcp", scheduler_port=0, n_workers=1, threads_per_worker=2, processes=False,
                       dashboard_address=None)
print(cluster.scheduler_address, flush=True)
time.sleep(300)
"""


def test_a_dask_scheduler_that_dies_keeps_the_finished_rows(tmp_path):
    """The scheduler (and its worker) killed with SIGKILL after two scenes: exit 1, one line naming the scenes not
    run, and the finished rows in the CSV."""
    pytest.importorskip("distributed")
    mark = uuid.uuid4().hex
    cluster = _start(["-c", _CLUSTER], mark)
    try:
        address = cluster.stdout.readline().strip()
        assert address.startswith("tcp://"), cluster.stderr.read()
        out = tmp_path / "battery"
        p = _start([BATTERY, *BALLS, "--dask-scheduler", address, "--out", str(out)], mark)
        try:
            printed = _rows_printed(p, 2)
            t0 = time.perf_counter()
            cluster.kill()
            _, err = p.communicate(timeout=60)
            seconds = time.perf_counter() - t0
        finally:
            p.kill()
    finally:
        cluster.kill()
        cluster.communicate()
    assert p.returncode == 1, err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    m = re.fullmatch(r"contact_battery\.py: lost the Dask scheduler at (\S+); (\d+) of 11 scenes not run; (\d+) "
                     r"finished, their rows are in (.+)", lines[0])
    assert m and m[1] == address and int(m[2]) + int(m[3]) == SCENES, lines[0]
    assert seconds < 10.0, seconds
    rows = _csv_rows(m[4])
    assert Path(m[4]) == out / "battery.csv" and len(rows) == int(m[3]) >= len(printed)
    assert {r["id"] for r in rows} >= set(printed) and all(r["family"] == "ball" for r in rows)
    assert _none_left(mark)


# ----------------------------------------------------------------------------- sweeps.run in this process
def _write_to(tmp_path, seen):
    def write(rows):
        seen.extend(rows)
        path = tmp_path / "rows.csv"
        path.write_text("x\n" + "".join(f"{r}\n" for r in rows))
        return str(path)
    return write


def _exit_after_two(x):
    if x >= 2:
        time.sleep(0.5 * (x - 1))   # (the first two come back first)
        os._exit(3)
    return x


def test_a_pool_worker_that_dies_is_a_lost_executor(tmp_path, capsys):
    from castrajectory.cli import sweeps

    seen = []
    ex = cf.ProcessPoolExecutor(max_workers=2, initializer=sweeps._worker_init)
    with pytest.raises(SystemExit) as stop:
        sweeps.run("sweep", ex, lambda on: _study_run(_exit_after_two, range(6), ex, on), _write_to(tmp_path, seen),
                   total=6)
    assert stop.value.code == 1
    err = capsys.readouterr().err
    assert re.fullmatch(r"sweep: a worker process of the pool died; 4 of 6 runs not run; 2 finished, their rows are "
                        r"in .*rows\.csv\n", err), err
    assert sorted(seen) == [0, 1]


def _study_run(fn, tasks, ex, on):
    from castrajectory.inspect import study
    return study.run_tasks(fn, list(tasks), ex, on)


def _fails_at_three(x):
    if x == 3:
        raise ValueError("a bug in the task")
    return x


def test_a_task_error_is_raised_with_the_finished_rows_kept(tmp_path):
    """A task's own error (a bug) keeps its traceback, and the rows that finished are written and named in it."""
    from castrajectory.cli import sweeps
    from castrajectory.inspect import study

    seen = []
    with pytest.raises(ValueError, match="a bug in the task") as err:
        sweeps.run("sweep", study.SerialExecutor(), lambda on: _study_run(_fails_at_three, range(6),
                                                                          study.SerialExecutor(), on),
                   _write_to(tmp_path, seen), total=6)
    assert seen == [0, 1, 2]
    assert any("3 of 6 runs finished; their rows are in" in n for n in err.value.__notes__)


def test_a_finished_sweep_returns_its_rows_and_writes_nothing(tmp_path):
    from castrajectory.cli import sweeps
    from castrajectory.inspect import study

    seen, printed = [], []
    rows = sweeps.run("sweep", study.SerialExecutor(), lambda on: _study_run(abs, [-1, -2], study.SerialExecutor(), on),
                      _write_to(tmp_path, seen), total=2, progress=printed.append)
    assert rows == [1, 2] and printed == [1, 2] and seen == [] and not (tmp_path / "rows.csv").exists()
