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
from typing import Optional

_seen = False
#: A SIGINT or SIGTERM arrived since :func:`install` (kept until the process handles it: a KeyboardInterrupt
#: raised inside a finaliser or a weakref callback is printed and dropped by Python, and one raised inside
#: CasADi comes back as a solver status, so commands also call :func:`check` at their safe points)
_pending = False
#: The signal :func:`install`'s handler saw last (SIGINT or SIGTERM): the exit code's (:func:`exit_code`)
_signal: Optional[int] = None


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised as an interrupt so that every interrupt's clean-up runs (temporaries removed, one line);
    the command then exits 143, as a shell reports a run that SIGTERM ended."""


def install() -> None:
    """For a command (a scene, the report, a sweep): every SIGINT and SIGTERM is noted and raised as
    ``KeyboardInterrupt`` (:class:`Terminated` for SIGTERM, whose default would kill the process and leave its
    temporary files); :func:`check` raises it again at the command's safe points if Python or CasADi dropped it
    (a SIGINT that lands in a matplotlib weakref callback is "ignored" and the report went on to exit 0).  A
    signal that whoever started the process ignores stays ignored."""
    global _pending, _signal
    if not _main_thread():
        return
    _pending, _signal = False, None          # (a new command: what an earlier one in this process saw is done)

    def note(signum, frame):
        global _pending, _signal
        _pending, _signal = True, signum
        if _in_finaliser(frame):
            # raised there, Python would print "Exception ignored in ..." with a traceback on stderr and
            # drop it: leave it to check() at the command's next safe point
            return
        raise Terminated if signum == signal.SIGTERM else KeyboardInterrupt

    for sig in (signal.SIGINT, signal.SIGTERM):
        if signal.getsignal(sig) != signal.SIG_IGN:
            signal.signal(sig, note)


def pending() -> bool:
    """Whether :func:`install`'s handler saw a signal that the command has not acted on yet."""
    return _pending


def exit_code() -> int:
    """The exit code of a command a signal stopped: 143 for SIGTERM, 130 for SIGINT (as a shell reports them)."""
    return 143 if _signal == signal.SIGTERM else 130


def what() -> str:
    """``terminated`` (SIGTERM) or ``interrupted`` (SIGINT), for the command's one line."""
    return "terminated" if _signal == signal.SIGTERM else "interrupted"


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
    """Raise ``KeyboardInterrupt`` (:class:`Terminated`) if a signal arrived since :func:`install` (see there)."""
    if _pending:
        raise Terminated if _signal == signal.SIGTERM else KeyboardInterrupt


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
        _release_stderr(held, drop="KeyboardInterrupt" if (_seen or _pending) else None)


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
    """Raise ``KeyboardInterrupt`` if a SIGINT arrived in the last :func:`watching` block, or any signal
    :func:`install`'s handler noted (a SIGTERM inside Ipopt: CasADi stops the solve and drops the exception)."""
    global _seen
    if _seen:
        _seen = False
        raise KeyboardInterrupt
    check()


def reraise(exc: BaseException) -> None:
    """Raise ``KeyboardInterrupt`` if ``exc`` is CasADi's report of one (a SIGINT that arrived inside a
    long CasADi operation, e.g. code generation, comes back as a RuntimeError naming it); for the
    ``except`` clauses that turn other errors into fallbacks."""
    if "KeyboardInterrupt" in str(exc):
        raise KeyboardInterrupt from exc
