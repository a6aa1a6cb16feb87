"""Files written atomically (temporary file in the target's folder, then a rename), so that
nothing is half-written, and never through a link another user planted in a shared folder.

``-`` names standard output. A new file gets the mode the user's umask gives (0666 & ~umask, as
``open`` would), an existing file keeps its mode. An existing target that is no regular file (a
FIFO, ``/dev/null``) is written into directly: renaming over it would replace the device. A
symbolic link is followed (the file it names is replaced, the link kept), unless another user
owns it in a sticky, world-writable folder such as ``/tmp`` (:func:`foreign_link`: the rule of
Linux's ``fs.protected_symlinks``, applied whatever the kernel's setting).

The temporary file is made with ``mkstemp`` (a private name, mode 0600 until it is complete);
SIGINT, SIGTERM and SIGHUP during the write remove it before the process ends
(:class:`Terminated`; the command line exits with 128 + the signal). Failures are one-line
:class:`OutputError`\\ s naming the path.
"""
from __future__ import annotations

import contextlib
import os
import signal
import stat
import sys
import tempfile
import threading
from pathlib import Path
from typing import Iterable, Iterator

from .errors import UsageError

STDOUT = "-"
SIGNALS = tuple(getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name))


class OutputError(UsageError):
    """An output path that cannot be written (one line: the option, the path, what to change)."""


class Terminated(BaseException):
    """A SIGTERM or SIGHUP received while an output was written: the partial file is removed,
    then the command ends with 128 + ``signum``."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


def is_stdout(path: str | Path | None) -> bool:
    """True when ``path`` is ``-``: write to standard output."""
    return str(path) == STDOUT


def foreign_link(p: Path, option: str) -> None:
    """Refuse a symbolic link that another user owns in a sticky, world-writable folder (``/tmp``):
    only its owner, the folder's owner or we may have planted it there for us to follow."""
    if not p.is_symlink():
        return
    try:
        link, folder = os.lstat(p), os.stat(p.parent)
    except OSError:
        return
    shared = folder.st_mode & stat.S_ISVTX and folder.st_mode & stat.S_IWOTH
    if shared and link.st_uid not in (os.geteuid(), folder.st_uid):
        raise OutputError(f"{option}: '{p}' is a symbolic link owned by another user (uid {link.st_uid}) in the "
                          f"shared folder '{p.parent}'; it is not followed: remove it or name another file")


def _umask() -> int:
    """The process's umask (os.umask can only be read by setting it, so it is set back at once)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


Content = str | bytes | Iterable[str]


def _chunks(text: Content) -> Iterable[str | bytes]:
    return (text,) if isinstance(text, (str, bytes)) else text


def write_atomic(path: str | Path, text: Content) -> None:
    """Write ``text`` (a string, bytes, or an iterable of strings, so a large CSV need not be one
    string) to ``path`` through a temporary file in the same folder, or to standard output for
    ``-``. A link is followed (and kept) unless :func:`foreign_link` refuses it."""
    if is_stdout(path):
        for piece in _chunks(text):
            if isinstance(piece, bytes):
                sys.stdout.flush()
                sys.stdout.buffer.write(piece)
            else:
                sys.stdout.write(piece)
        sys.stdout.flush()
        return
    p = Path(path)
    foreign_link(p, "output")
    if p.is_symlink():
        p = Path(os.path.realpath(p))                     # replace the file the link names, keep the link
    try:
        if p.exists() and not stat.S_ISREG(p.stat().st_mode):
            _write_direct(p, text)
        else:
            _write_replace(p, text)
    except OSError as exc:
        raise OutputError(f"{path}: cannot write ({exc.strerror or exc}); choose another file") from None


def _open_mode(text: Content) -> dict:
    return {"mode": "wb"} if isinstance(text, bytes) else {"mode": "w", "encoding": "utf-8", "newline": ""}


def _write_direct(p: Path, text: Content) -> None:
    """Into an existing FIFO or device, which a rename would replace."""
    with open(p, **_open_mode(text)) as fh:
        for piece in _chunks(text):
            fh.write(piece)


def _write_replace(p: Path, text: Content) -> None:
    """Temporary file in the target's folder, mode set as ``open`` would, then an atomic rename;
    the temporary file is removed on any failure or interruption."""
    mode = stat.S_IMODE(p.stat().st_mode) if p.exists() else 0o666 & ~_umask()
    tmp = None
    with _signals_raise():
        try:
            fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".part", dir=p.parent)
            with os.fdopen(fd, **_open_mode(text)) as fh:
                for piece in _chunks(text):
                    fh.write(piece)
                os.fchmod(fh.fileno(), mode)
            os.replace(tmp, p)
        except BaseException:
            if tmp is not None:
                Path(tmp).unlink(missing_ok=True)
            raise


@contextlib.contextmanager
def on_signals(handler) -> Iterator[None]:
    """While the block runs, SIGTERM and SIGHUP call ``handler(signum, frame)``; the handlers are
    set back after. Only the main thread can set handlers; elsewhere the block runs as it is."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = {}
    try:
        for s in SIGNALS:
            old[s] = signal.signal(s, handler)
        yield
    finally:
        for s, h in old.items():
            if h is not None:                        # None: a handler set outside Python, not restorable
                signal.signal(s, h)


def _signals_raise():
    """While the block runs, SIGTERM and SIGHUP raise :class:`Terminated` (SIGINT raises
    KeyboardInterrupt already), so that its clean-up runs."""
    def handler(signum, frame):
        raise Terminated(signum)
    return on_signals(handler)
