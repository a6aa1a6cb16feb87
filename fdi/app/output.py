"""Checking outputs before any work: paths that can be written, and none of them an input.

Writing itself is :func:`fdi.atomic.write_atomic` (atomic, ``-`` for standard output, no link
planted by another user followed). Refused here, each as a one-line :class:`OutputError` naming
the option and the path, before the command starts:

- an output that resolves (through links, ``..``, hard links) to one of the command's inputs:
  ``diagnose M data.csv -o data.csv`` would replace the data it reads;
- a symbolic link owned by another user in a shared sticky folder (:func:`fdi.atomic.foreign_link`);
- a folder, a missing folder, a folder or file that cannot be written; a ``--plot`` folder that
  cannot be created or written into.
"""
from __future__ import annotations

import os
import stat
import tempfile
from pathlib import Path
from typing import Iterable

from ..atomic import STDOUT, OutputError, Terminated, foreign_link, is_stdout, write_atomic

__all__ = ["STDOUT", "OutputError", "Terminated", "check_folder", "check_folder_not_input", "check_not_input",
           "check_output", "foreign_link", "is_stdout", "write_atomic"]


def check_output(path: str | Path, option: str = "-o") -> None:
    """Refuse, before any work, an output path that cannot be a file: a folder, a path in a
    missing folder or under a file, a folder we may not write into, a link planted by another
    user in a shared folder."""
    if is_stdout(path):
        return
    if str(path).strip() == "":
        raise OutputError(f"{option}: the path is empty; name a file (or - for standard output)")
    last = os.path.basename(str(path))
    if last in ("", ".", "..") or (os.altsep and str(path).endswith(os.altsep)):
        # 'out/' and 'out/.' name a folder; Path() drops the ending, and the file 'out' was written
        # (over an existing file of that name: a user trial)
        raise OutputError(f"{option}: '{path}' names a folder (it ends with '{str(path)[-1] if last == '' else last}'); "
                          "name a file (or - for standard output)")
    p = Path(path)
    long = next((part for part in p.parts if len(os.fsencode(part)) > 255), None)
    if long is not None:
        raise OutputError(f"{option}: the name '{long[:40]}...' is longer than a file system takes (255 bytes); "
                          "choose a shorter name")
    if p.is_dir():
        raise OutputError(f"{option}: '{path}' is a folder; name a file (or - for standard output)")
    parent = p.parent
    if not parent.exists():
        raise OutputError(f"{option}: folder '{parent}' does not exist; create it or name a file in an existing folder")
    if not parent.is_dir():
        raise OutputError(f"{option}: '{parent}' is not a folder; name a file in a folder")
    foreign_link(p, option)
    if p.exists() and not os.access(p, os.W_OK):
        raise OutputError(f"{option}: '{path}' is not writable; choose another file")
    if p.exists() and not stat.S_ISREG(p.stat().st_mode):
        return                                       # a FIFO or a device: written into, not replaced
    folder = p.resolve().parent if p.exists() else parent
    problem = _cannot_create(folder)
    if problem:
        raise OutputError(f"{option}: cannot create files in '{folder}' ({problem}); choose another folder")


def check_folder(path: str | Path, option: str = "--plot") -> None:
    """Refuse, before any work, a folder of outputs that cannot be written into (or created)."""
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise OutputError(f"{option}: '{path}' is a file; name a folder")
    if not p.exists():
        if not p.parent.is_dir():
            raise OutputError(f"{option}: folder '{p.parent}' does not exist; create it or name a folder in an "
                              "existing one")
        problem = _cannot_create(p.parent, folder=True)
        if problem:
            raise OutputError(f"{option}: cannot create folder '{path}' in '{p.parent}' ({problem}); "
                              "choose another folder")
        return
    problem = _cannot_create(p)
    if problem:
        raise OutputError(f"{option}: cannot write into folder '{path}' ({problem}); choose another folder")


def _cannot_create(where: Path, folder: bool = False) -> str | None:
    """Why a file (or, with ``folder``, a folder) cannot be created in ``where``, or None: tried
    for real with a private temporary name removed at once (permissions alone say nothing of a
    read-only file system, and nothing to the superuser)."""
    try:
        if folder:
            os.rmdir(tempfile.mkdtemp(prefix=".bgfdi-probe-", dir=where))
        else:
            fd, name = tempfile.mkstemp(prefix=".bgfdi-probe-", dir=where)
            os.close(fd)
            os.unlink(name)
    except OSError as exc:
        return exc.strerror or str(exc)
    return None


def _identity(path: str | Path) -> tuple | None:
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        return None
    return (st.st_dev, st.st_ino)


def check_not_input(path: str | Path, inputs: Iterable[str | Path], option: str = "-o") -> None:
    """Refuse an output that is one of the command's inputs: the same file (through links, hard
    links or another spelling of its path), or a file that does not exist yet whose resolved path
    is an input's."""
    if is_stdout(path):
        return
    out_id, out_real = _identity(path), os.path.realpath(path)
    for source in inputs:
        if source is None or is_stdout(source):
            continue
        same_id = out_id is not None and out_id == _identity(source)
        if same_id and not stat.S_ISREG(os.stat(path).st_mode):
            continue                                # /dev/null or a FIFO as both: nothing is replaced
        if same_id or out_real == os.path.realpath(source):
            raise OutputError(f"{option}: '{path}' is the input {source} of this command; writing it would "
                              "replace what is read; name another file")


def check_folder_not_input(folder: str | Path, inputs: Iterable[str | Path], option: str = "--plot") -> None:
    """Refuse a plot folder holding an input PNG file (the plots are PNG files named by figure)."""
    real = os.path.realpath(folder)
    for source in inputs:
        if source is None or is_stdout(source):
            continue
        src = os.path.realpath(source)
        if os.path.dirname(src) == real and src.lower().endswith(".png"):
            raise OutputError(f"{option}: folder '{folder}' holds the input {source}, which a plot could replace; "
                              "name another folder")
