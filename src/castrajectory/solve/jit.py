"""Compile small CasADi functions to machine code, with a disk cache and a silent fallback.

CasADi evaluates an SX function in a virtual machine: one interpreted
instruction per scalar operation.  For the element functions of
:mod:`castrajectory.solve.nlp` (one discrete Euler–Lagrange residual, its Jacobian,
one polyline segment ...) evaluated tens of thousands of times per Ipopt
iteration, that interpreter is the bulk of the function-evaluation time.
:func:`compiled` turns such a function into C with CasADi's code generator,
compiles it with the system C compiler into a shared library and loads it with
``casadi.external``.  The compiled function has the same inputs, outputs and
sparsity; it is meant to be ``map``-ped over elements, so the code (and the
compile time) does not grow with the number of elements.

Cache.  The library is stored under :func:`cache_dir` with a name made of a
SHA-256 hash of the generated C code, the compiler and its flags, so a later
run (tests, the report, the benchmarks) loads it instead of recompiling.  A
change to the function changes its code and therefore its hash; stale entries
are never reused.  Several processes (a process pool, Dask workers, two
terminals) may share the cache: a library is compiled into a private
temporary folder inside the cache folder and renamed into place with
``os.replace`` (atomic on one file system), so a concurrent reader finds
either no library or a whole one, never a half-written one.  Two processes
compiling the same function at once both succeed; the later rename wins,
with identical content.

Verified loads.  Nothing is loaded that the cache cannot vouch for: beside each library lies its stamp
(``NAME.so.sha256``: the key it was compiled for and the SHA-256 of its bytes), written before the library
is renamed into place.  Before ``dlopen`` the library's bytes are hashed and checked against the stamp; a
library without a stamp, with another key's stamp, or whose bytes differ (swapped, truncated, zeroed) is
never loaded, since loading a damaged shared library can crash the process (SIGBUS, SIGSEGV) before Python
can react.  It is moved to the cache's ``quarantine`` folder, one line says so on stderr, and the function
is compiled again; a verified library that still fails to load is quarantined and compiled again once.  The
key covers the generated code, the compiler (its path and its ``--version``), the flags and the casadi
version.  Build folders of compilations whose process died (named by host and pid) are removed at the next
compilation, others after :data:`STALE_BUILD_S`.

Fallback.  Whenever no C compiler is found, compilation or loading fails, the code is longer
than :data:`MAX_CODE_CHARS`, or compilation is switched off, :func:`compiled` returns the function unchanged
(CasADi's virtual machine): results are the same, only slower.

Environment:

``CASTRAJECTORY_JIT``
    ``0``/``off``/``false``/``no`` switches compilation off.
``CASTRAJECTORY_CACHE_DIR``
    cache directory (default ``$XDG_CACHE_HOME/castrajectory``, else
    ``~/.cache/castrajectory``); compiled libraries go to its ``jit`` subfolder.
``CC``
    the C compiler (default: the first of ``cc``, ``gcc``, ``clang`` on ``PATH``).
"""
from __future__ import annotations

import hashlib
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Dict, Optional

import casadi as ca

from . import interrupt

#: Compiler flags.  ``-O2`` without fast-math and with ``-ffp-contract=off`` (no fused multiply-add)
#: keeps the operation-by-operation IEEE arithmetic of the virtual machine; no ``-march=native``, so
#: a shared cache stays valid on other machines of the same architecture.
FLAGS = ("-O2", "-ffp-contract=off", "-fPIC", "-shared")
#: Code longer than this (characters) is compiled at ``-O1`` instead: on long straight-line code ``-O2``'s
#: compile time grows faster than the code, for little run time (a 32-rod chain's galerkin8 elements in
#: maximal coordinates, three functions: 11.3 s to compile at -O2, 3.9 s at -O1, the solve 2.33 against 2.47 s).
LARGE_CODE_CHARS = 100_000
#: Seconds before a compilation is abandoned (the function is then evaluated by the VM).
COMPILE_TIMEOUT_S = 60.0

#: Counters (per process), for tests and diagnostics.
stats: Dict[str, int] = {"compiled": 0, "cache_hits": 0, "memory_hits": 0, "fallbacks": 0, "quarantined": 0}

#: Generated C code longer than this (characters) is not compiled: the VM evaluates it.  The exact
#: Hessian of Newton's law for a box on SO(3) (a 7 × 7 mass matrix solved symbolically, projected on
#: the quaternion constraint) is 2 MB of C that took 34 s to compile, once as the element and once as
#: its chunk; the marched step of that box (444 kB) took 11 s to compile for a 20 % faster march, paid
#: again for every new box size (its edges are constants of the code).
MAX_CODE_CHARS = 1_000_000
#: Largest number of compiled libraries kept in the cache (least recently used ones are deleted).
MAX_ENTRIES = 2000
#: A build folder (``.build-*``) older than this (seconds) belongs to a compilation that was killed
#: (a cancelled worker, Ctrl-C): it is removed.  Far above :data:`COMPILE_TIMEOUT_S`, so a running
#: compilation of another process is never touched.
STALE_BUILD_S = 3600.0

_loaded: Dict[str, ca.Function] = {}  # key -> loaded external function (this process)
_failed: set = set()  # keys whose compilation or loading failed in this process
_too_large: Dict[int, ca.Function] = {}  # functions whose code exceeds MAX_CODE_CHARS (this process)
_by_form: Dict[str, str] = {}  # sha256 of a function's serialize() -> its key in _loaded (this process)
_compiler_checked: Dict[str, Optional[str]] = {}


def enabled() -> bool:
    """False when ``CASTRAJECTORY_JIT`` switches compilation off."""
    return os.environ.get("CASTRAJECTORY_JIT", "1").strip().lower() not in ("0", "off", "false", "no")


def cache_dir() -> Path:
    """Per-user cache directory (see the module docstring for the environment variables)."""
    root = os.environ.get("CASTRAJECTORY_CACHE_DIR")
    if root:
        return Path(root).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME")
    base = Path(xdg).expanduser() if xdg else Path.home() / ".cache"
    return base / "castrajectory"


def compiler() -> Optional[str]:
    """Path of the C compiler to use, or None."""
    cc = os.environ.get("CC")
    if cc in _compiler_checked:
        return _compiler_checked[cc]
    found = None
    for name in ([cc] if cc else ["cc", "gcc", "clang"]):
        path = shutil.which(name)
        if path:
            found = path
            break
    _compiler_checked[cc] = found
    return found


def c_code(fn: ca.Function) -> str:
    """CasADi's C code of ``fn`` (entry point named ``fn.name()``)."""
    cg = ca.CodeGenerator(fn.name(), {"with_header": False})
    cg.add(fn)
    return cg.dump()


_compiler_ids: Dict[str, str] = {}


def _compiler_id(cc: str) -> str:
    """The compiler's identity for the cache's keys: its path and the first line of its ``--version``."""
    if cc not in _compiler_ids:
        try:
            out = subprocess.run([cc, "--version"], capture_output=True, text=True, timeout=10).stdout
            first = (out.strip().splitlines() or [""])[0]
        except (OSError, subprocess.SubprocessError):
            first = ""
        _compiler_ids[cc] = f"{cc} {first}"
    return _compiler_ids[cc]


def _key(code: str, cc: str) -> str:
    h = hashlib.sha256()
    for part in (code, _compiler_id(cc), " ".join(_flags(code)), ca.__version__):
        h.update(part.encode())
        h.update(b"\0")
    return h.hexdigest()[:24]


def _stamp_path(lib: Path) -> Path:
    return lib.with_name(lib.name + ".sha256")


def _digest(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _check(lib: Path, key: str) -> Optional[str]:
    """None where ``lib`` holds the bytes compiled for ``key`` (its stamp says so); else what is wrong."""
    try:
        stamp = _stamp_path(lib).read_text().split()
    except OSError:
        return "has no stamp"
    if len(stamp) != 2 or stamp[0] != key:
        return "carries the stamp of another function"
    try:
        digest = _digest(lib)
    except OSError:
        return "cannot be read"
    return None if digest == stamp[1] else "differs from its stamp (changed or damaged on disk)"


def _quarantine(lib: Path, why: str) -> None:
    """Set a library the cache cannot vouch for aside (``quarantine``), with one line on stderr."""
    dest = lib.parent / "quarantine"
    try:
        dest.mkdir(exist_ok=True)
        os.replace(lib, dest / f"{lib.name}.{os.getpid()}.{time.time_ns()}")
    except OSError:
        try:
            lib.unlink(missing_ok=True)
        except OSError:
            pass
    try:
        _stamp_path(lib).unlink(missing_ok=True)
    except OSError:
        pass
    stats["quarantined"] += 1
    print(f"castrajectory: the cached compiled function {lib.name} {why}: set aside in {dest} and compiled again",
          file=sys.stderr, flush=True)


def compiled(fn: ca.Function, build: bool = True) -> ca.Function:
    """A compiled equivalent of ``fn`` (SX function), or ``fn`` itself when that is not possible.

    With ``build=False`` only an already compiled library (this process or the disk
    cache) is used; nothing is compiled.
    """
    if not enabled():
        return fn
    try:
        cc = compiler()
        if cc is None:
            stats["fallbacks"] += 1
            return fn
        if id(fn) in _too_large:
            return fn
        # in this process, a function already compiled is found by its serialised form (3x cheaper than
        # generating its C code: 0.2 against 0.65 ms for galerkin4's DEL element, 20 per solve)
        form = hashlib.sha256(fn.serialize().encode()).hexdigest()
        if _by_form.get(form) in _loaded:
            stats["memory_hits"] += 1
            return _loaded[_by_form[form]]
        folder = cache_dir() / "jit"
        # across processes, the serialised form names its library too (an index file beside it), so a
        # function compiled before is loaded without generating its C code again (3-10 ms per kernel of
        # a new system: every simulate() builds its system afresh)
        _clean_dead_builds(folder)
        indexed = _indexed(folder, form, cc)
        if indexed is not None:
            key, lib = indexed
            why = _check(lib, key)
            if why is None:
                out = _load(fn, lib)
                stats["cache_hits"] += 1
                _loaded[key] = out
                _by_form[form] = key
                return out
            _quarantine(lib, why)        # (then compiled again below, from its code)
        if not build:
            # not compiled before (no index names it) and not to be compiled now: the virtual machine, without
            # generating the C code only to look for a library that is not there
            return fn
        code = c_code(fn)
        if len(code) > MAX_CODE_CHARS:
            _too_large[id(fn)] = fn          # (the reference keeps the id valid)
            stats["fallbacks"] += 1
            return fn
        key = _key(code, cc)
        if key in _loaded:
            stats["memory_hits"] += 1
            _by_form[form] = key
            return _loaded[key]
        if key in _failed:
            return fn
        lib = folder / f"{fn.name()}_{key}.so"
        out = _from_disk(fn, code, cc, folder, key, lib, build)
        if out is None:
            return fn
        _loaded[key] = out
        _by_form[form] = key
        _index(folder, form, cc, lib)
        return out
    except Exception as exc:  # no compiler, failed compile, unwritable cache, failed load: use the VM
        interrupt.reraise(exc)          # ... but an interrupt inside CasADi's code generation stops
        stats["fallbacks"] += 1
        if "key" in locals():
            _failed.add(key)
        return fn


def _from_disk(fn: ca.Function, code: str, cc: str, folder: Path, key: str, lib: Path, build: bool):
    """The library ``lib`` of ``fn`` loaded: verified (:func:`_check`; set aside if it fails), compiled where it is
    missing (None where ``build`` is off), and, where verified bytes do not load, set aside and compiled once more."""
    if lib.exists():
        why = _check(lib, key)
        if why is not None:
            _quarantine(lib, why)
    built = False
    if lib.exists():
        stats["cache_hits"] += 1
        _touch(lib)
    elif not build:
        return None
    else:
        _build(code, cc, folder, key, lib)
        built = True
        stats["compiled"] += 1
        _prune(folder)
    try:
        return _load(fn, lib)
    except Exception as exc:
        interrupt.reraise(exc)
        if built:
            raise
        # (verified bytes that do not load: compiled on another machine of the cache, say) once again
        _quarantine(lib, f"does not load ({exc.__class__.__name__})")
        _build(code, cc, folder, key, lib)
        stats["compiled"] += 1
        return _load(fn, lib)


def _load(fn: ca.Function, lib: Path) -> ca.Function:
    """``dlopen`` a library :func:`_check` verified (its bytes are the ones compiled for its key)."""
    out = ca.external(fn.name(), str(lib))
    if out.n_in() != fn.n_in() or out.n_out() != fn.n_out():
        raise RuntimeError("compiled function has another signature")
    return out


def _index_path(folder: Path, form: str, cc: str) -> Path:
    """The index file of a serialised form (with the compiler and flags, as the library's own key)."""
    h = hashlib.sha256("\0".join([form, _compiler_id(cc), *FLAGS, str(LARGE_CODE_CHARS), ca.__version__]).encode()).hexdigest()[:24]
    return folder / f"form_{h}.txt"


def _indexed(folder: Path, form: str, cc: str):
    """``(key, library)`` of a form compiled before, if its index file names a library that exists."""
    try:
        name = _index_path(folder, form, cc).read_text().strip()
    except OSError:
        return None
    lib = folder / name
    if not name.endswith(".so") or "/" in name or not lib.exists():
        return None
    _touch(lib)
    return name[:-3].rsplit("_", 1)[-1], lib


def _index(folder: Path, form: str, cc: str, lib: Path) -> None:
    """Record ``form -> library`` (written atomically; a failure only costs the next process a lookup)."""
    try:
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=".form.")
        with os.fdopen(fd, "w") as fh:
            fh.write(lib.name)
        os.replace(tmp, _index_path(folder, form, cc))
    except OSError:
        pass


def warm_up(run, active: bool = True):
    """Run ``run()`` (untimed work that compiles or loads element code); describe what happened.

    Returns ``(info, line)``: a JSON-ready dict (switch, compiler, cache, counters, seconds) and a
    one-line summary for benchmark output.
    """
    t = time.perf_counter()
    run()
    info = {"on": bool(active and enabled()), "compiler": compiler(), "cache": str(cache_dir()),
            "warmup_stats": dict(stats), "warmup_s": time.perf_counter() - t}
    line = (f"jit: {'on' if info['on'] else 'off'}, compiler {info['compiler']}, cache {info['cache']}; "
            f"warm-up {info['warmup_s']:.2f} s compiled {stats['compiled']} and loaded {stats['cache_hits']} "
            f"cached libraries")
    return info, line


def _touch(lib: Path) -> None:
    try:
        os.utime(lib)  # recently used: kept by _prune
    except OSError:
        pass


def _prune(folder: Path) -> None:
    """Keep at most :data:`MAX_ENTRIES` libraries, dropping the least recently used, and remove the
    build folders of compilations killed midway (older than :data:`STALE_BUILD_S`)."""
    try:
        libs = sorted(folder.glob("*.so"), key=lambda q: q.stat().st_mtime)
        for old in libs[:max(0, len(libs) - MAX_ENTRIES)]:
            old.unlink()
            _stamp_path(old).unlink(missing_ok=True)
        forms = sorted(folder.glob("form_*.txt"), key=lambda q: q.stat().st_mtime)  # (an index file is tiny)
        for old in forms[:max(0, len(forms) - 4 * MAX_ENTRIES)]:
            old.unlink()
    except OSError:
        pass
    now = time.time()
    for tmp in folder.glob(".build-*"):
        try:
            if now - tmp.stat().st_mtime > STALE_BUILD_S:
                shutil.rmtree(tmp, ignore_errors=True)
        except OSError:
            pass
    try:
        quarantined = sorted((folder / "quarantine").glob("*"), key=lambda q: q.stat().st_mtime)
        for old in quarantined[:max(0, len(quarantined) - MAX_QUARANTINED)]:
            old.unlink()
    except OSError:
        pass


#: Libraries kept in the quarantine folder (the latest; evidence of what was set aside, not reused).
MAX_QUARANTINED = 20
_cleaned: set = set()  # cache folders whose dead builds this process removed


def _build_prefix() -> str:
    """A build folder's name prefix: its host and process, so that a later run can tell a dead compilation."""
    return f".build-{socket.gethostname().replace('-', '_')}-{os.getpid()}-"


def _clean_dead_builds(folder: Path) -> None:
    """Remove (once per process) the build folders of this host's compilations whose process is gone (killed
    during a compile): the age rule (:data:`STALE_BUILD_S`) left them for an hour."""
    if folder in _cleaned:
        return
    _cleaned.add(folder)
    host = socket.gethostname().replace("-", "_")
    for tmp in folder.glob(".build-*"):
        parts = tmp.name.split("-")
        if len(parts) < 4 or parts[1] != host or not parts[2].isdigit():
            continue
        try:
            os.kill(int(parts[2]), 0)
        except ProcessLookupError:
            shutil.rmtree(tmp, ignore_errors=True)
        except OSError:
            pass                                    # (alive, another user's)


def _flags(code: str) -> tuple:
    """The compiler flags of ``code``: :data:`FLAGS`, at ``-O1`` past :data:`LARGE_CODE_CHARS`."""
    return FLAGS if len(code) <= LARGE_CODE_CHARS else ("-O1",) + FLAGS[1:]


def _build(code: str, cc: str, folder: Path, key: str, lib: Path) -> None:
    """Compile ``code`` into ``lib``: in a private build folder, its stamp written and renamed into place before
    the library (a reader finds no library, or a whole one with its stamp)."""
    folder.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=folder, prefix=_build_prefix()) as tmp:
        src = Path(tmp) / "f.c"
        src.write_text(code)
        tmp_lib = Path(tmp) / "f.so"
        subprocess.run([cc, *_flags(code), "-o", str(tmp_lib), str(src), "-lm"], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=COMPILE_TIMEOUT_S)
        stamp = Path(tmp) / "f.sha256"
        stamp.write_text(f"{key} {_digest(tmp_lib)}\n")
        os.replace(stamp, _stamp_path(lib))
        os.replace(tmp_lib, lib)  # atomic: a concurrent reader sees no half-written library
