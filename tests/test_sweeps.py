"""Sweeps beyond one machine (issue 15): the same rows whichever executor ran them, progress bars on
stderr only, and a compile cache that several processes can share.

A sweep's rows hold the same values serially, on a local process pool and on a Dask cluster; only
the timing columns (``study.TIMING_COLUMNS``) differ.  The Dask test starts a ``LocalCluster`` on
loopback (the ``dist`` extra, installed in CI by the README's test command).
"""
from __future__ import annotations

import concurrent.futures as cf
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from castrajectory.inspect import study
from castrajectory.models import pendulum
from castrajectory.validation import InputError

ROOT = Path(__file__).resolve().parents[1]

DROPLET_NS = [8, 64, 512]
TRAJ_PAIRS = [("whole", "midpoint"), ("whole", "galerkin4"), ("march", "trapezoid"), ("rk4", None)]
TRAJ_NS = [100, 200]
TRAJ = dict(q0=[2.0, 1.0], qd0=[0.0, 0.0], T=1.0)


def _droplet(executor=None):
    return study.droplet_sweep(DROPLET_NS, executor=executor)


def _trajectory(executor=None):
    return study.work_precision_sweep(pendulum.double_pendulum, TRAJ["q0"], TRAJ["qd0"], TRAJ["T"], TRAJ_PAIRS,
                                      TRAJ_NS, executor=executor, warmup=False)


def _assert_same_rows(a, b):
    """Same rows, same keys, every non-timing value exactly equal (NaN equals NaN)."""
    assert len(a) == len(b)
    for ra, rb in zip(a, b):
        assert list(ra) == list(rb)
        for k in ra:
            if k in study.TIMING_COLUMNS:
                continue
            va, vb = ra[k], rb[k]
            if isinstance(va, float) and math.isnan(va):
                assert isinstance(vb, float) and math.isnan(vb), (k, va, vb)
            else:
                assert type(va) is type(vb) and va == vb, (k, va, vb)


@pytest.fixture(scope="module")
def serial_rows():
    rows = {"droplet": _droplet(), "trajectory": _trajectory()}
    assert all(r["status"] == "ok" for r in rows["droplet"] + rows["trajectory"])
    assert len(rows["droplet"]) == len(DROPLET_NS) * 2 and len(rows["trajectory"]) == len(TRAJ_PAIRS) * len(TRAJ_NS)
    return rows


def test_sweep_rows_identical_on_a_process_pool(serial_rows):
    with study.executor_for(workers=2) as ex:
        assert isinstance(ex, cf.ProcessPoolExecutor)
        droplet_rows, traj_rows = _droplet(ex), _trajectory(ex)
    _assert_same_rows(serial_rows["droplet"], droplet_rows)
    _assert_same_rows(serial_rows["trajectory"], traj_rows)


def test_sweep_rows_identical_on_a_dask_local_cluster(serial_rows):
    distributed = pytest.importorskip("distributed")  # the `dist` extra; CI installs it
    with distributed.LocalCluster(host="127.0.0.1", processes=True, n_workers=2, threads_per_worker=1,
                                  dashboard_address=None) as cluster:
        with study.executor_for(dask_scheduler=cluster.scheduler_address) as ex:
            droplet_rows, traj_rows = _droplet(ex), _trajectory(ex)
            ran_on = set(ex.client.run(os.getpid).values())
    assert os.getpid() not in ran_on
    _assert_same_rows(serial_rows["droplet"], droplet_rows)
    _assert_same_rows(serial_rows["trajectory"], traj_rows)


def test_sweep_executor_for_choices(monkeypatch):
    assert isinstance(study.executor_for(), study.SerialExecutor)
    assert isinstance(study.executor_for(workers=1), study.SerialExecutor)
    with study.executor_for(workers=3) as ex:
        assert isinstance(ex, cf.ProcessPoolExecutor) and ex._max_workers == 3
    for bad in (0, -2):
        with pytest.raises(InputError, match="--workers"):
            study.executor_for(workers=bad)
    with pytest.raises(InputError, match="not both"):
        study.executor_for(workers=2, dask_scheduler="tcp://127.0.0.1:8786")
    monkeypatch.setitem(sys.modules, "distributed", None)   # as without the `dist` extra
    with pytest.raises(InputError, match=r"castrajectory\[dist\]"):
        study.executor_for(dask_scheduler="tcp://127.0.0.1:8786")


def test_sweep_of_a_built_system_refuses_a_process_pool():
    """A built system holds CasADi expressions, which do not pickle: a pool needs its factory."""
    with study.executor_for(workers=2) as ex:
        with pytest.raises(TypeError, match="picklable function"):
            study.work_precision_sweep(pendulum.double_pendulum(), [0.1, 0.0], [0.0, 0.0], 0.1,
                                       [("rk4", None)], [10], executor=ex, warmup=False)


def test_sweep_serial_executor_is_lazy_and_in_order():
    ex = study.SerialExecutor()
    assert list(ex.map(abs, [-1, 2, -3])) == [1, 2, 3]
    fut = ex.submit(int, "x")
    assert isinstance(fut.exception(), ValueError)
    seen = []
    assert study.run_tasks(abs, [-3, -1, 2], progress=seen.append) == [3, 1, 2] and seen == [3, 1, 2]


def test_sweep_pool_results_in_task_order_progress_as_finished():
    seen = []
    with study.executor_for(workers=2) as ex:
        out = study.run_tasks(abs, list(range(-6, 0)), ex, progress=seen.append)
    assert out == [6, 5, 4, 3, 2, 1] and sorted(seen) == [1, 2, 3, 4, 5, 6]


# ----------------------------------------------------------------------------- progress bars
def test_sweep_progress_bar_on_stderr_only(capsys):
    study.run_tasks(abs, [-1, -2, -3], desc="bar-test")          # stderr is not a terminal: no bar
    out, err = capsys.readouterr()
    assert out == "" and err == ""
    study.run_tasks(abs, [-1, -2, -3], desc="bar-test", bar=True, progress=print)   # asked for
    out, err = capsys.readouterr()
    assert out.split() == ["1", "2", "3"]                      # the progress lines, nothing else
    assert "bar-test" in err and "3/3" in err
    study.run_tasks(abs, [-1, -2, -3], desc="bar-test", bar=True, quiet=True)
    assert capsys.readouterr() == ("", "")


def test_sweep_script_progress_and_quiet(tmp_path):
    """A sweep script: ``--progress`` draws the bar on stderr (stdout keeps only its table);
    ``--quiet`` leaves neither bar nor per-run lines; bad executor flags are one line, exit 2."""
    script = str(ROOT / "scripts" / "droplet_convergence.py")
    env = dict(os.environ, MPLBACKEND="Agg")
    base = [sys.executable, script, "--n-max", "32", "--formulations", "curve", "--out", str(tmp_path)]
    p = subprocess.run([*base, "--progress", "--workers", "2"], capture_output=True, text=True, env=env, timeout=120)
    assert p.returncode == 0, p.stderr
    assert "droplet: 100%" in p.stderr and "%|" not in p.stdout and "N=     32" in p.stdout
    p = subprocess.run([*base, "--quiet"], capture_output=True, text=True, env=env, timeout=120)
    assert p.returncode == 0, p.stderr
    assert "%|" not in p.stderr and "N=" not in p.stdout and "observed orders" in p.stdout
    p = subprocess.run([*base, "--workers", "0"], capture_output=True, text=True, env=env, timeout=120)
    assert p.returncode == 2 and p.stderr.count("\n") == 1 and "--workers" in p.stderr


# ----------------------------------------------------------------------------- the contact battery
def test_sweep_battery_rows_identical_on_a_process_pool():
    from castrajectory.inspect import battery

    scenes = [s for s in battery.draw_scenes(13, 6) if s["family"] == "ball"]
    tasks = [(s, 60.0) for s in scenes]
    serial = study.run_tasks(battery.battery_task, tasks)
    with study.executor_for(workers=2) as ex:
        pooled = study.run_tasks(battery.battery_task, tasks, ex)
    assert [r["id"] for r in serial] == [s["id"] for s in scenes] and all(r["solved"] for r in serial)
    _assert_same_rows(serial, pooled)


def test_sweep_battery_scene_over_its_time_limit_is_a_failed_row():
    from castrajectory.inspect import battery

    sc = battery.draw_scenes(13, 1)[0]
    row = battery.battery_task((sc, 0.01))
    assert row["status"].startswith("timeout") and row["solved"] is False and row["id"] == sc["id"]


# ----------------------------------------------------------------------------- the shared compile cache
_RACE = r"""
import json, os, sys, time
import casadi as ca
from castrajectory.solve import jit
x = ca.SX.sym("x", 12)
y = x
for k in range(40):                         # enough code that compiling takes a moment
    y = ca.sin(y) * ca.cos(y[::-1]) + 0.01 * k * y
f = ca.Function("race_fn", [x], [ca.sum1(y)])
open(sys.argv[1] + ".ready" + sys.argv[2], "w").close()
while not os.path.exists(sys.argv[1]):
    time.sleep(0.001)
g = jit.compiled(f)
v = [0.1 * i for i in range(12)]
print(json.dumps({"stats": jit.stats, "external": g is not f, "value": float(g(v)), "vm": float(f(v))}))
"""


def test_sweep_compile_cache_shared_by_two_processes_compiling_at_once(tmp_path):
    """Two processes compile the same function at the same moment into one fresh cache: both load a
    compiled library (no fallback), with the virtual machine's value; one library is left, and no
    temporary build folder."""
    import shutil as _sh
    if not any(_sh.which(c) for c in ("cc", "gcc", "clang")):
        pytest.skip("no C compiler")
    cache = tmp_path / "cache"
    go = tmp_path / "go"
    env = dict(os.environ, CASTRAJECTORY_CACHE_DIR=str(cache), CASTRAJECTORY_JIT="1")
    procs = [subprocess.Popen([sys.executable, "-c", _RACE, str(go), str(i)], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True, env=env) for i in range(2)]
    deadline = time.time() + 60
    while not all(Path(f"{go}.ready{i}").exists() for i in range(2)):
        assert time.time() < deadline and all(p.poll() is None for p in procs), "children did not start"
        time.sleep(0.01)
    time.sleep(0.5)                     # both past their imports, waiting for the signal
    go.touch()
    outs = [p.communicate(timeout=120) for p in procs]
    assert all(p.returncode == 0 for p in procs), [o[1] for o in outs]
    res = [json.loads(o[0]) for o in outs]
    for r in res:
        assert r["external"] and r["stats"]["fallbacks"] == 0
        assert r["stats"]["compiled"] + r["stats"]["cache_hits"] == 1
        assert r["value"] == r["vm"]
    libs = list((cache / "jit").glob("race_fn_*.so"))
    assert len(libs) == 1
    assert not list((cache / "jit").glob(".build-*"))


def test_sweep_compile_cache_never_holds_a_half_written_library(tmp_path, monkeypatch):
    """A compiler that writes half a library and then fails leaves nothing at the cache's path (the
    output goes to a temporary folder): the function falls back to the virtual machine."""
    import casadi as ca

    from castrajectory.solve import jit

    fake = tmp_path / "fakecc"
    fake.write_text('#!/bin/sh\nwhile [ "$1" != "-o" ]; do shift; done\nprintf "\\177ELF-half" > "$2"\nexit 1\n')
    fake.chmod(0o755)
    monkeypatch.setenv("CASTRAJECTORY_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("CASTRAJECTORY_JIT", "1")
    monkeypatch.setenv("CC", str(fake))
    x = ca.SX.sym("x")
    f = ca.Function("half_fn", [x], [x * x + 3])
    assert jit.compiled(f) is f
    folder = tmp_path / "cache" / "jit"
    assert not list(folder.glob("*.so")) and not list(folder.glob(".build-*"))
