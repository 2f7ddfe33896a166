"""A cache that verifies what it loads (issue 42): a compiled library is loaded only where its bytes are the ones
compiled for its key.  Each case runs in a temporary cache folder, and every load of a damaged file runs in a child
process, so that a library that got through would crash that process, not the tests: the child must exit 0 with
the function's own values and one line on stderr."""
from __future__ import annotations

import json
import os
import socket
import subprocess
import sys

import pytest

from castrajectory.solve import jit

pytestmark = pytest.mark.skipif(jit.compiler() is None, reason="no C compiler")

#: A child process: the probe function of tag argv[1] compiled through the cache, evaluated, compared with the VM.
CHILD = r"""
import json, sys
import casadi as ca
from castrajectory.solve import jit
x = ca.SX.sym("x", 2)
f = ca.Function("cache_probe", [x], [ca.vertcat(ca.sin(x[0]) * x[1] + float(sys.argv[1]), x[0] ** 3)])
g = jit.compiled(f)
v = [0.3, 2.0]
print(json.dumps({"external": g is not f, "value": [float(a) for a in ca.vertsplit(g(v))],
                  "vm": [float(a) for a in ca.vertsplit(f(v))], "stats": jit.stats}))
"""


def _child(cache, tag):
    p = subprocess.run([sys.executable, "-c", CHILD, repr(tag)], capture_output=True, text=True, timeout=120,
                       env={**os.environ, "CASTRAJECTORY_CACHE_DIR": str(cache), "CASTRAJECTORY_JIT": "1"})
    assert p.returncode == 0, (p.returncode, p.stderr[-2000:])
    out = json.loads(p.stdout)
    assert out["external"] and out["value"] == out["vm"]          # compiled, and its own function's values
    return out, p.stderr


def _lib(cache):
    libs = sorted((cache / "jit").glob("cache_probe_*.so"))
    assert libs, "nothing compiled"
    return libs


def test_a_clean_cache_is_loaded_without_a_word(tmp_path):
    out, err = _child(tmp_path, 0.25)
    assert out["stats"]["compiled"] == 1 and err == ""
    out, err = _child(tmp_path, 0.25)
    assert out["stats"]["compiled"] == 0 and out["stats"]["cache_hits"] == 1 and err == ""


@pytest.mark.parametrize("damage", ["swapped", "swapped with its stamp", "truncated", "zeroed", "unstamped"])
def test_a_damaged_library_is_set_aside_and_compiled_again(tmp_path, damage):
    """The issue's cases: a library replaced by the same element compiled for other constants (a wrong answer with
    status ok), truncated to half (SIGBUS, exit 135) or with zeroed code bytes (SIGSEGV, exit 139), and a library
    without its stamp: never loaded, set aside with one line, compiled again, and the run goes on."""
    _child(tmp_path, 0.25)
    (lib,) = _lib(tmp_path)
    stamp = lib.with_name(lib.name + ".sha256")
    if damage.startswith("swapped"):
        _child(tmp_path, -3.5)                                    # the same element for another constant
        other = [q for q in _lib(tmp_path) if q != lib][0]
        lib.write_bytes(other.read_bytes())
        if damage == "swapped with its stamp":
            stamp.write_text(other.with_name(other.name + ".sha256").read_text())
    elif damage == "truncated":
        data = lib.read_bytes()
        lib.write_bytes(data[:len(data) // 2])
    elif damage == "zeroed":
        data = bytearray(lib.read_bytes())
        data[len(data) // 4:len(data) // 2] = bytes(len(data) // 2 - len(data) // 4)
        lib.write_bytes(bytes(data))
    else:
        stamp.unlink()
    out, err = _child(tmp_path, 0.25)
    assert out["stats"]["quarantined"] == 1 and out["stats"]["compiled"] == 1
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lib.name in lines[0] and "set aside" in lines[0]
    assert len(list((tmp_path / "jit" / "quarantine").iterdir())) == 1
    # healed: the next run loads it silently
    out, err = _child(tmp_path, 0.25)
    assert out["stats"]["compiled"] == 0 and out["stats"]["quarantined"] == 0 and err == ""


def test_a_dead_compilations_build_folder_is_removed(tmp_path):
    """A run killed during a compile leaves its build folder: the next run removes it at once where its process is
    gone (it was left for an hour), and leaves a live process's alone."""
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    host = socket.gethostname().replace("-", "_")
    gone = tmp_path / "jit" / f".build-{host}-{dead.pid}-abc"
    alive = tmp_path / "jit" / f".build-{host}-{os.getpid()}-abc"
    for d in (gone, alive):
        d.mkdir(parents=True)
        (d / "f.c").write_text("int x;")
    _child(tmp_path, 0.5)
    assert not gone.exists() and alive.exists()
