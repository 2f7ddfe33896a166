"""An interrupt (SIGINT, Ctrl-C) during a solve stops it: it is raised as ``KeyboardInterrupt``, never
reported as a failed attempt that a strategy would retry.

CasADi checks for signals between Ipopt iterations and stops Ipopt there, but then returns a status
(``NonIpopt_Exception_Thrown`` or ``User_Requested_Stop``) as if the solve had failed, and the Python
exception is gone.  :func:`watching` notes every SIGINT that arrives while a solve runs (and passes it
on to the handler that was installed before, by default Python's, which raises ``KeyboardInterrupt``);
:func:`raise_if_interrupted` then raises it after the solver returns.
"""
from __future__ import annotations

import contextlib
import os
import signal
import sys
import tempfile
import threading

_seen = False
#: A SIGINT arrived since :func:`install` (kept until the process handles it: a KeyboardInterrupt raised
#: inside a finaliser or a weakref callback is printed and dropped by Python, so long-running commands
#: also call :func:`check` at their safe points)
_pending = False


def install() -> None:
    """For a long-running command (the report): every SIGINT is noted and raised as ``KeyboardInterrupt``;
    :func:`check` raises it again at the command's safe points if Python dropped it (a SIGINT that lands in
    a matplotlib weakref callback is "ignored" and the report went on to exit 0).  A SIGINT that whoever
    started the process ignores stays ignored."""
    if not _main_thread() or signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        return

    def note(signum, frame):
        global _pending
        _pending = True
        if _in_finaliser(frame):
            # raised there, Python would print "Exception ignored in ..." with a traceback on stderr and
            # drop it: leave it to check() at the command's next safe point
            return
        raise KeyboardInterrupt

    signal.signal(signal.SIGINT, note)


#: Code that Python runs as a finaliser or a weakref callback, where an exception is printed and dropped.
_FINALISER_FILES = ("weakref.py", "_weakrefset.py")


def _in_finaliser(frame) -> bool:
    """Is the interrupted frame (or a caller of it) a ``__del__`` or a weakref callback?  (Measured: a SIGINT
    6 s into ``castrajectory report --quick`` landed in ``WeakSet._remove``, and the report's stderr held
    Python's "Exception ignored" and its traceback before the one line of the interrupt.)"""
    while frame is not None:
        code = frame.f_code
        if code.co_name == "__del__" or code.co_filename.endswith(_FINALISER_FILES):
            return True
        frame = frame.f_back
    return False


def check() -> None:
    """Raise ``KeyboardInterrupt`` if a SIGINT arrived since :func:`install` (see there)."""
    if _pending:
        raise KeyboardInterrupt


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@contextlib.contextmanager
def watching():
    """Note SIGINTs for the duration (main thread only; elsewhere signals cannot be handled anyway)."""
    global _seen
    if not _main_thread():
        yield
        return
    previous = signal.getsignal(signal.SIGINT)
    if previous == signal.SIG_IGN:          # ignored by whoever started us (nohup, a background job)
        yield
        return

    def note(signum, frame):
        global _seen
        _seen = True
        if callable(previous):
            previous(signum, frame)
        elif previous == signal.SIG_DFL:
            raise KeyboardInterrupt

    _seen = False
    signal.signal(signal.SIGINT, note)
    # CasADi reports the interrupt on file descriptor 2 ("KeyboardInterruptException"); what C and C++
    # print there during the solve is held back and passed on after it, without that line
    held = _hold_stderr()
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        _release_stderr(held, drop="KeyboardInterrupt" if _seen else None)


def _hold_stderr():
    try:
        sys.stderr.flush()
        tmp = tempfile.TemporaryFile()
        saved = os.dup(2)
        os.dup2(tmp.fileno(), 2)
        return tmp, saved
    except (OSError, ValueError, AttributeError):
        return None


def _release_stderr(held, drop):
    if held is None:
        return
    tmp, saved = held
    os.dup2(saved, 2)
    os.close(saved)
    tmp.seek(0)
    text = tmp.read().decode(errors="replace")
    tmp.close()
    if drop:
        text = "".join(line for line in text.splitlines(True) if drop not in line)
    if text:
        sys.stderr.write(text)
        sys.stderr.flush()


def raise_if_interrupted() -> None:
    """Raise ``KeyboardInterrupt`` if a SIGINT arrived in the last :func:`watching` block."""
    global _seen
    if _seen:
        _seen = False
        raise KeyboardInterrupt


def reraise(exc: BaseException) -> None:
    """Raise ``KeyboardInterrupt`` if ``exc`` is CasADi's report of one (a SIGINT that arrived inside a
    long CasADi operation, e.g. code generation, comes back as a RuntimeError naming it); for the
    ``except`` clauses that turn other errors into fallbacks."""
    if "KeyboardInterrupt" in str(exc):
        raise KeyboardInterrupt from exc
