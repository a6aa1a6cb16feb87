"""Opening an input file without waiting on a FIFO that nothing writes into.

Opening a named FIFO for reading waits until some process opens it for writing: a FIFO made and
forgotten (``mkfifo sc.json; bgfdi simulate M sc.json``) would hang the command for good. Here a
named FIFO is opened without waiting (``O_NONBLOCK``) and read at once: end of file means no
writer (or one that wrote nothing and left), refused with :class:`NoWriter`; bytes, or a read that
would block (a writer that has not written yet), show a writer, and the file is then read as any
other, through that same descriptor (opening it again would wait anew once a quick writer has
left) and with the bytes already read in front. Process substitution (``<(command)``, a pipe the
shell made, not a named FIFO) is opened as a file: its open never waits.
"""
from __future__ import annotations

import io
import os
import stat
from pathlib import Path
from typing import BinaryIO


class NoWriter(Exception):
    """A named FIFO with no process writing into it."""

    def __init__(self, path: str) -> None:
        super().__init__(f"{path}: a FIFO that nothing writes into (reading it would wait for a writer that may "
                         "never come); start its writer first (as <(command) does), or give a regular file")


def is_named_fifo(path: str | Path) -> bool:
    """A FIFO in a file system (not a pipe reached through /dev/fd, whose open never waits)."""
    try:
        if not stat.S_ISFIFO(os.stat(path).st_mode):
            return False
        return "pipe:[" not in os.path.realpath(path)
    except (OSError, ValueError):
        return False


def open_binary(path: str | Path) -> BinaryIO:
    """``open(path, "rb")``, but a named FIFO is opened without waiting and refused (NoWriter)
    when nothing writes into it (module doc). OSError as ``open`` raises it."""
    if not is_named_fifo(path) or not hasattr(os, "O_NONBLOCK"):
        return open(path, "rb")
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    try:
        first = os.read(fd, 1 << 16)
    except BlockingIOError:                  # a writer, nothing written yet
        first = None
    except OSError:
        os.close(fd)
        raise
    if first == b"":
        os.close(fd)
        raise NoWriter(str(path))
    os.set_blocking(fd, True)
    return io.BufferedReader(_Prefixed(first or b"", io.FileIO(fd, "rb", closefd=True)))


class _Prefixed(io.RawIOBase):
    """A raw stream that gives ``prefix`` first, then the rest of ``raw``."""

    def __init__(self, prefix: bytes, raw: io.FileIO) -> None:
        self._prefix, self._raw = memoryview(prefix), raw

    def readable(self) -> bool:
        return True

    def readinto(self, buffer) -> int:
        if len(self._prefix):
            n = min(len(buffer), len(self._prefix))
            buffer[:n] = self._prefix[:n]
            self._prefix = self._prefix[n:]
            return n
        return self._raw.readinto(buffer)

    def close(self) -> None:
        try:
            self._raw.close()
        finally:
            super().close()
