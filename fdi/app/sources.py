"""The command line's inputs: ``-`` for standard input and shipped files by name.

Every file a command reads (the model, a scenario, measurement files, calibration runs, scenario
suites) may be given as

- a path: it always wins, even when a shipped file has the same name;
- ``-``: standard input, read once into a private temporary file (so every reader, the fleet's
  workers included, sees an ordinary file; messages name it "standard input"). At most one input
  of a command can be ``-``; ``monitor``'s data ``-`` is a stream, read as the rows arrive;
- the name of a shipped file (no such path exists): a model (``cycab_steering``, from
  ``models/``, installed as ``fdi.models``), a scenario (``cycab_scenario2``), reference data
  (``scenario2``: ``models/data/cycab/scenario2.csv``) or a scenario suite
  (``suite_cycab_steering``).
"""
from __future__ import annotations

import argparse
import os
import re
import shutil
import sys
import tempfile
from pathlib import Path

from ..errors import UsageError
from .resources import models_dir, scenarios_dir, shipped_models

STDIN = "-"
STDIN_NAME = "standard input"
MAX_TEXT = 1 << 20               # a model or scenario: its reader refuses more than 1 MiB, and says so
MAX_DATA = 1 << 32               # 4 GiB of CSV text: beyond the readers' 100 million numbers
NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*\Z")      # a bare name: no folder, no ~


def _suffixed(name: str, suffixes: tuple[str, ...]) -> list[str]:
    return [name] if name.lower().endswith(suffixes) else [name + s for s in suffixes]


ENCODED = (b"\x1f\x8b", b"\xff\xfe", b"\xfe\xff")   # gzip's magic bytes, UTF-16's marks: NUL bytes are theirs
MAX_NAME = 240     # bytes: a longer name is no shipped file's (file systems take 255 a path component)


def shipped(kind: str, name: str) -> Path | None:
    """The shipped file (or suite folder) ``name`` of ``kind`` (model, scenario, data, suite), or None."""
    if not NAME.match(name) or len(name.encode()) > MAX_NAME:
        return None
    if kind == "model":
        found = [models_dir() / n for n in _suffixed(name, (".yaml",))]
    elif kind == "scenario":
        found = [scenarios_dir() / n for n in _suffixed(name, (".json", ".yaml"))]
    elif kind == "suite":
        found = [scenarios_dir() / name] + [scenarios_dir() / n for n in _suffixed(name, (".json", ".yaml"))]
    else:                                              # measurement files: models/data/<set>/<name>.csv
        found = sorted((models_dir() / "data").glob("*/" + (name if name.lower().endswith(".csv") else name + ".csv")))
    return next((p for p in found if _is(p, kind)), None)


def _is(path: Path, kind: str) -> bool:
    """Whether ``path`` is a shipped file (a folder for a suite); False where the system cannot say
    (a name longer than the file system takes: the name is then read as the path it is)."""
    try:
        return path.is_file() or (kind == "suite" and path.is_dir())
    except OSError:
        return False


def shipped_names(kind: str) -> list[str]:
    """The names a user can give for ``kind`` (for messages)."""
    if kind == "model":
        return [p.stem for p in shipped_models()]
    if kind == "scenario":
        return sorted(p.stem for p in scenarios_dir().glob("*.json"))
    if kind == "suite":
        return sorted(p.name for p in scenarios_dir().iterdir() if p.is_dir() and p.name.startswith("suite_"))
    return sorted(p.stem for p in (models_dir() / "data").glob("*/*.csv"))


_COPIES: set[str] = set()        # the temporary copies of standard input of the running command


def shown(path: object) -> str:
    """``path`` as the user gave it: "standard input" for the copy of ``-``."""
    return STDIN_NAME if str(path) in _COPIES else str(path)


def said(text: str) -> str:
    """A message with the copy of ``-`` named "standard input"."""
    for copy in _COPIES:
        text = text.replace(copy, STDIN_NAME)
    return text


class Sources:
    """Resolves a parsed command line's inputs in place (``resolve``) and removes the temporary
    copy of standard input afterwards (``close``); ``message`` puts "standard input" back into a
    message that names the copy."""

    def __init__(self) -> None:
        self.folder: str | None = None
        self.copy: str | None = None
        self.taken: str | None = None           # the option that took standard input

    def resolve(self, args: argparse.Namespace) -> None:
        command = getattr(args, "command", None)
        if isinstance(getattr(args, "model", None), str):
            args.model = self._one(args.model, "model", "the model")
        if command == "simulate":
            args.scenario = self._one(args.scenario, "scenario", "the scenario")
        if command == "diagnose":
            args.data = [self._one(d, "data", "the data") for d in args.data]
        if command == "monitor" and args.data == STDIN:
            self._take("the data")             # a stream, read as it comes: only claimed here
        elif command == "monitor":
            args.data = self._one(args.data, "data", "the data")
        if command == "calibrate":
            args.runs = [self._one(r, "data", "a run") for r in args.runs]
        if command == "evaluate":
            args.scenarios = [self._one(s, "suite", "the scenarios") for s in args.scenarios]

    def _take(self, what: str) -> None:
        if self.taken is not None:
            raise UsageError(f"-: standard input is already {self.taken}; give {what} as a file")
        self.taken = what

    def _one(self, value: str, kind: str, what: str) -> str:
        if value == STDIN:
            self._take(what)
            return self._copy_stdin(kind)
        if os.path.lexists(value) or not NAME.match(value):
            return value                          # a path wins over a shipped name
        found = shipped(kind, value)
        if found is not None:
            return str(found)
        if kind == "model" and "." not in value:    # a bare word: most likely a misspelt shipped name
            raise UsageError(f"{value}: no such file, nor a shipped model (shipped: {', '.join(shipped_names('model'))})")
        return value

    def _copy_stdin(self, kind: str) -> str:
        stream = sys.stdin.buffer if sys.stdin is not None and hasattr(sys.stdin, "buffer") else None
        if stream is None or sys.stdin.closed:
            raise UsageError("-: standard input is closed; pipe the file in, or give its path")
        suffix = {"model": ".yaml", "data": ".csv"}.get(kind, ".yaml")
        self.folder = tempfile.mkdtemp(prefix="bgfdi-stdin-")
        copy = os.path.join(self.folder, "stdin")
        limit = MAX_DATA if kind == "data" else MAX_TEXT + 1     # the text readers say "larger than 1 MB"
        try:
            with open(copy, "wb") as fh:
                kept = 0
                while kept < limit and (block := stream.read(min(1 << 20, limit - kept))):
                    if kept == 0 and b"\0" in block and not block.startswith(ENCODED):
                        # not text, nor what the readers decode (gzip, UTF-16): refused before a gigabyte is copied
                        raise UsageError(f"-: standard input holds a NUL byte at offset {block.index(0)}: not a "
                                         "text file; pipe a CSV or YAML file in")
                    fh.write(block)
                    kept += len(block)
        except (OSError, ValueError) as exc:      # not readable (a closed descriptor, a test's capture)
            raise UsageError(f"-: cannot read standard input ({getattr(exc, 'strerror', None) or exc}); pipe the "
                             "file in, or give its path") from None
        if kind == "data" and kept >= limit:
            raise UsageError(f"-: standard input holds more than {MAX_DATA >> 30} GiB of measurements; split the "
                             "record, or give it as a file")
        with open(copy, "rb") as fh:
            head = fh.read(64)
        if kind in ("scenario", "suite") and head.lstrip(b"\xef\xbb\xbf \t\r\n").startswith(b"{"):
            suffix = ".json"                      # a JSON scenario: its reader refuses duplicate keys
        self.copy = copy + suffix
        os.replace(copy, self.copy)
        _COPIES.add(self.copy)
        return self.copy

    def message(self, text: str) -> str:
        return said(text)

    def close(self) -> None:
        _COPIES.discard(self.copy or "")
        if self.folder is not None:
            shutil.rmtree(self.folder, ignore_errors=True)
            self.folder = None
