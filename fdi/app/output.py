"""Writing results: atomically (temporary file, then rename), so that nothing is half-written.

``-`` names standard output. A new file gets the mode the user's umask gives (0666 & ~umask, as
``open`` would), an existing file keeps its mode. An existing target that is no regular file (a
FIFO, ``/dev/null``) is written into directly: renaming over it would replace the device.
Failures are one-line :class:`OutputError`\\ s naming the path.
"""
from __future__ import annotations

import os
import stat
import sys
import tempfile
from pathlib import Path
from typing import Iterable

from ..errors import UsageError

STDOUT = "-"


class OutputError(UsageError):
    """An output path that cannot be written (one line: the option, the path, what to change)."""


def is_stdout(path: str | Path | None) -> bool:
    """True when ``path`` is ``-``: write to standard output."""
    return str(path) == STDOUT


def check_output(path: str | Path, option: str = "-o") -> None:
    """Refuse, before any work, an output path that cannot be a file: a folder, a path in a
    missing folder or under a file, a folder we may not write into."""
    if is_stdout(path):
        return
    if str(path).strip() == "":
        raise OutputError(f"{option}: the path is empty; name a file (or - for standard output)")
    p = Path(path)
    if p.is_dir():
        raise OutputError(f"{option}: '{path}' is a folder; name a file (or - for standard output)")
    parent = p.parent
    if not parent.exists():
        raise OutputError(f"{option}: folder '{parent}' does not exist; create it or name a file in an existing folder")
    if not parent.is_dir():
        raise OutputError(f"{option}: '{parent}' is not a folder; name a file in a folder")
    if not p.exists() and not os.access(parent, os.W_OK | os.X_OK):
        raise OutputError(f"{option}: cannot create files in '{parent}' (permission denied); choose another folder")
    if p.exists() and not os.access(p, os.W_OK):
        raise OutputError(f"{option}: '{path}' is not writable; choose another file")


def _umask() -> int:
    """The process's umask (os.umask can only be read by setting it, so it is set back at once)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _chunks(text: str | Iterable[str]) -> Iterable[str]:
    return (text,) if isinstance(text, str) else text


def write_atomic(path: str | Path, text: str | Iterable[str]) -> None:
    """Write ``text`` (a string or an iterable of pieces, so a large CSV need not be one string)
    to ``path`` through a temporary file in the same folder, or to standard output for ``-``."""
    if is_stdout(path):
        for piece in _chunks(text):
            sys.stdout.write(piece)
        sys.stdout.flush()
        return
    p = Path(path)
    if p.is_symlink():
        p = Path(os.path.realpath(p))                     # replace the file the link names, keep the link
    try:
        if p.exists() and not stat.S_ISREG(p.stat().st_mode):
            _write_direct(p, text)
        else:
            _write_replace(p, text)
    except OSError as exc:
        raise OutputError(f"{path}: cannot write ({exc.strerror or exc}); choose another file") from None


def _write_direct(p: Path, text: str | Iterable[str]) -> None:
    """Into an existing FIFO or device, which a rename would replace."""
    with open(p, "w", encoding="utf-8", newline="") as fh:
        for piece in _chunks(text):
            fh.write(piece)


def _write_replace(p: Path, text: str | Iterable[str]) -> None:
    """Temporary file in the target's folder, mode set as ``open`` would, then an atomic rename."""
    mode = stat.S_IMODE(p.stat().st_mode) if p.exists() else 0o666 & ~_umask()
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", dir=p.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as fh:
            os.fchmod(fh.fileno(), mode)
            for piece in _chunks(text):
                fh.write(piece)
        os.replace(tmp, p)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
