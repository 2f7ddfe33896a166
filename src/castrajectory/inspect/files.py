"""Files written atomically: to a temporary file beside the target, then renamed into place.

An interrupted or failed write (Ctrl-C, a full disk, a plotting error) never leaves a partial file
where a good one was: the target is either the old file or the new one.
"""
from __future__ import annotations

import contextlib
import os
import tempfile
from typing import Callable

from ..solve import interrupt


def write_atomically(path: str, write: Callable[[str], None]) -> None:
    """``write(tmp)`` to a temporary file beside ``path`` (same extension, so a format read from it is the
    same), then rename it into place; on any failure the temporary file is removed and ``path`` is
    left as it was."""
    folder, name = os.path.split(os.path.abspath(path))
    root, ext = os.path.splitext(name)
    fd, tmp = tempfile.mkstemp(prefix=f".{root}.", suffix=f".tmp{ext}", dir=folder)
    os.close(fd)
    try:
        write(tmp)
        # (a Ctrl-C that matplotlib's weakref callback swallowed while rendering: the earlier file stays)
        interrupt.check()
        # mkstemp makes the file private (0600); the output gets the mode an ordinary open() would give it
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_text(path: str, text: str) -> None:
    """``text`` into ``path``, atomically."""
    def write(tmp):
        with open(tmp, "w") as fh:
            fh.write(text)
    write_atomically(path, write)


def save_figure(fig, path: str) -> None:
    """A matplotlib figure into ``path`` (format from its extension), atomically."""
    write_atomically(path, fig.savefig)
