"""Signals and partial outputs (issue 42): SIGTERM is an interrupt too (exit 143, one line, temporaries removed),
a report is moved into place only when it is whole, and a write that a dropped Ctrl-C did not stop keeps the
earlier file."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "MPLBACKEND": "Agg"}


def _signal_after(args, seconds: float, sig=signal.SIGTERM, cwd=None):
    """Start ``python args``, send ``sig`` after ``seconds``: (returncode, stdout, stderr, seconds to the exit)."""
    p = subprocess.Popen([sys.executable, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV,
                         cwd=cwd, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    time.sleep(seconds)
    assert p.poll() is None, "the run ended before the signal: pick a longer one"
    t0 = time.perf_counter()
    p.send_signal(sig)
    out, err = p.communicate(timeout=120)
    return p.returncode, out, err, time.perf_counter() - t0


def test_sigterm_stops_a_solve_like_ctrl_c(tmp_path):
    """SIGTERM during Ipopt (a 12-link pendulum, ~9 s): exit 143 within seconds with one line, no traceback, the
    earlier picture untouched and no temporary file left (SIGTERM's default killed the run and left
    ``.NAME.XXXX.tmp.png`` files behind)."""
    keep = tmp_path / "keep.png"
    keep.write_bytes(b"earlier output")
    rc, out, err, dt = _signal_after([str(ROOT / "problems" / "n_link_pendulum.py"), "--links", "12", "--n", "4000",
                                      "--T", "10", "--plot", str(keep)], 3.0)
    assert rc == 143, err
    assert err.strip().splitlines() == ["n_link_pendulum.py: terminated"] and out == ""
    assert dt < 5.0
    assert keep.read_bytes() == b"earlier output"
    assert [f.name for f in tmp_path.iterdir()] == ["keep.png"]


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL])
def test_a_stopped_report_leaves_the_earlier_one_whole(tmp_path, sig):
    """A report stopped midway (SIGTERM: exit 143 and one line; SIGKILL: no say at all) leaves the earlier report's
    folder exactly as it was: no file of the new run beside its summary (it left 9).  A killed run's hidden
    partial folder is removed by the next report."""
    out_dir = tmp_path / "report"
    out_dir.mkdir()
    (out_dir / "summary.md").write_text("an earlier report\n")
    (out_dir / "earlier.csv").write_text("x\n1\n")
    before = sorted(f.name for f in out_dir.iterdir())
    rc, out, err, _ = _signal_after(["-m", "castrajectory.cli", "report", "--out", str(out_dir), "--quick"], 8.0,
                                    sig=sig)
    assert sorted(f.name for f in out_dir.iterdir()) == before
    assert (out_dir / "summary.md").read_text() == "an earlier report\n"
    partial = [f for f in tmp_path.iterdir() if f.name.startswith(".report.partial-")]
    if sig == signal.SIGTERM:
        assert rc == 143 and err.strip().splitlines() == ["castrajectory report: terminated"], err
        assert partial == []
    else:
        assert rc == -signal.SIGKILL and len(partial) == 1
        from castrajectory.cli import report
        report._partial_folder(str(out_dir))           # (the next report's first step)
        assert not partial[0].exists()


def test_report_out_naming_a_file_is_refused(tmp_path):
    f = tmp_path / "a_file"
    f.write_text("mine\n")
    p = subprocess.run([sys.executable, "-m", "castrajectory.cli", "report", "--out", str(f), "--quick"],
                       capture_output=True, text=True, env=ENV, timeout=60)
    assert p.returncode == 2 and p.stdout == "" and "Traceback" not in p.stderr
    assert p.stderr.strip().splitlines() == [f"castrajectory report: error: --out {f} is a file, not a folder"]
    assert f.read_text() == "mine\n" and sorted(x.name for x in tmp_path.iterdir()) == ["a_file"]


def test_a_write_that_a_dropped_interrupt_did_not_stop_keeps_the_earlier_file(tmp_path, monkeypatch):
    """A SIGINT that matplotlib's weakref callback swallowed while a GIF rendered let the write finish and replace
    the earlier file (1 of 125 tries): the write checks for a noted signal before it renames its file into place."""
    from castrajectory.inspect import files
    from castrajectory.solve import interrupt

    target = tmp_path / "anim.gif"
    target.write_bytes(b"earlier")

    def render(tmp):
        Path(tmp).write_bytes(b"new")
        monkeypatch.setattr(interrupt, "_pending", True)   # noted by install()'s handler, its exception dropped

    with pytest.raises(KeyboardInterrupt):
        files.write_atomically(str(target), render)
    monkeypatch.setattr(interrupt, "_pending", False)
    assert target.read_bytes() == b"earlier" and [f.name for f in tmp_path.iterdir()] == ["anim.gif"]


def test_ctrl_c_into_an_optimal_control_run_is_never_lost():
    """5 of 25 SIGINTs sent into block_move at spread delays were lost: the run went on and exited 0 with its
    answer (the exception raised inside CasADi's evaluation was dropped with the solve's status).  The handler
    notes every signal and the run checks at its safe points: each delay exits 130 with one line (measured 25 of
    25, the slowest 1.9 s after the signal).  (The delays start after the interpreter's imports, about 0.5 s
    unloaded: a SIGINT before the script's first line runs is Python's own, with its traceback.)"""
    for d in (1.5, 2.2, 2.9, 3.6, 4.3):
        p = subprocess.Popen([sys.executable, str(ROOT / "problems" / "block_move.py"), "--n", "20000"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV,
                             preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
        time.sleep(d)
        if p.poll() is not None:          # (a fast machine finished first: nothing to interrupt)
            p.communicate()
            continue
        t0 = time.perf_counter()
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=120)
        assert p.returncode == 130, (d, p.returncode, err[-500:])
        assert err.strip().splitlines() == ["block_move.py: interrupted"], (d, err[-500:])
        assert time.perf_counter() - t0 < 10.0


def test_a_refusal_is_one_short_line_whatever_it_quotes(tmp_path):
    """The last guard of every scene's refusal: a message that quotes a huge value (here the optimal control's
    ``T`` check, which quotes it whole) is cut to one line of at most MESSAGE_LIMIT characters."""
    from castrajectory.cli import scene
    from castrajectory.validation import InputError

    def run(args):
        raise InputError("T must be positive (got " + "9" * 10 ** 6 + ")\nsecond line")

    parser = scene.scene_parser("probe.py", "a probe")
    import io
    import contextlib
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        code = scene.run_scene(parser, run, [])
    assert code == 2
    lines = err.getvalue().splitlines()
    assert len(lines) == 1 and len(lines[0]) <= scene.MESSAGE_LIMIT + len("probe.py: error: ")
    assert lines[0].startswith("probe.py: error: T must be positive (got 999") and lines[0].endswith("…")


@pytest.mark.parametrize("sig,group", [(signal.SIGINT, True), (signal.SIGTERM, False)])
def test_a_signal_during_a_compile_leaves_a_cache_that_the_next_run_trusts(tmp_path, sig, group):
    """A signal while the C compiler runs (an empty cache, a 6-link pendulum on 3000 steps: its element
    functions compile for about 1.3 s): exit 130 (Ctrl-C, sent to the whole process group as a terminal sends
    it, so the compiler gets it too) or 143 (SIGTERM, to the run only), one line, no build folder left behind
    and no library without its stamp; the next run loads or compiles what it needs, says nothing about the
    cache, and ends ok with the same answer as a run that was never interrupted."""
    cache = tmp_path / "cache"
    env = {**ENV, "CASTRAJECTORY_CACHE_DIR": str(cache)}
    args = [sys.executable, str(ROOT / "problems" / "n_link_pendulum.py"), "--links", "6", "--n", "3000", "--T", "3",
            "--json"]
    p = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                         start_new_session=True)
    jit_dir, t0 = cache / "jit", time.perf_counter()
    while not any((b / "f.c").exists() for b in jit_dir.glob(".build-*")):   # the compiler has its source
        assert p.poll() is None and time.perf_counter() - t0 < 60, "no compile seen"
        time.sleep(0.005)
    time.sleep(0.05)
    (os.killpg(p.pid, sig) if group else p.send_signal(sig))
    out, err = p.communicate(timeout=120)
    code, word = (130, "interrupted") if sig == signal.SIGINT else (143, "terminated")
    assert p.returncode == code and out == "", (p.returncode, err[-800:])
    assert err.strip().splitlines() == [f"n_link_pendulum.py: {word}"], err[-800:]
    assert list(jit_dir.glob(".build-*")) == []
    libs = list(jit_dir.glob("*.so"))
    assert all((jit_dir / (f.name + ".sha256")).exists() for f in libs)
    again = subprocess.run(args, capture_output=True, text=True, env=env, timeout=300)
    assert again.returncode == 0 and again.stderr == "", again.stderr[-800:]
    fresh = subprocess.run(args, capture_output=True, text=True, env={**ENV, "CASTRAJECTORY_JIT": "0"}, timeout=300)
    import json
    a, b = json.loads(again.stdout), json.loads(fresh.stdout)
    assert a["status"] == "ok"
    assert max(abs(x - y) for x, y in zip(a["q"][-1], b["q"][-1])) <= 1e-13   # (measured: identical)
