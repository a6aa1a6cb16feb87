"""Every hostile input of issue 12 ends in exit 2 with one line naming what to change, or works
(exit 0) where it is valid but unusual; nothing raises, hangs or writes a partial file."""
from __future__ import annotations

import contextlib
import io
import os
import signal
import sys
import tempfile
import time
from pathlib import Path

import pytest

from fdi.app.cli import main

from .hostile import CASES, Fifo, Link

LIMIT_S = 20


class Hang(Exception):
    pass


def _alarm(signum, frame):
    raise Hang()


def run_case(files: dict, argv: list[str], folder: Path) -> tuple[int | str, str, str, float]:
    """(exit status or the exception's name, stdout, stderr, seconds) of one case run in-process."""
    for name, content in files.items():
        path = folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, Fifo):
            os.mkfifo(path)
        elif isinstance(content, Link):
            path.symlink_to(folder / content.target)
        else:
            path.write_bytes(content if isinstance(content, bytes) else content.encode("utf-8"))
    args = [a.replace("{out}", str(folder)) for a in argv]
    for name in files:
        args = [a.replace("{" + name + "}", str(folder / name)) for a in args]
    out, err = io.StringIO(), io.StringIO()
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(LIMIT_S)
    t0 = time.perf_counter()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            rc: int | str = main(args)
    except SystemExit as exc:                  # argparse's own usage errors exit 2 with its usage text
        rc = exc.code if isinstance(exc.code, int) else 2
    except Hang:
        rc = "hang"
    except BaseException as exc:               # noqa: BLE001 - the point is to catch everything
        rc = type(exc).__name__
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    return rc, out.getvalue(), err.getvalue(), time.perf_counter() - t0


def verdict(expect: str, rc, out: str, err: str) -> str | None:
    """None when the case behaved, else what went wrong."""
    if not isinstance(rc, int):
        return f"raised {rc}"
    if expect == "ok":
        return None if rc == 0 else f"exit {rc}: {err.strip()[:200]}"
    if rc != 2:
        return f"exit {rc} (wanted 2): {(err or out).strip()[:200]}"
    lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith(("usage:", "bgfdi: warning:"))]
    if "Traceback" in err or len(lines) != 1:
        return f"{len(lines)} error lines: {err.strip()[:300]}"
    if "\x1b" in err:
        return f"a terminal escape reached standard error: {err.strip()[:300]!r}"
    return None


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_hostile_input(case, tmp_path):
    name, files, argv, expect = case
    rc, out, err, _ = run_case(files, argv, tmp_path)
    problem = verdict(expect, rc, out, err)
    assert problem is None, f"{name}: {problem}"
    written = {p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*") if p.is_file() or p.is_symlink()}
    if expect == "error":
        assert written <= set(files), f"a file was written: {sorted(written - set(files))}"
    for fname, content in files.items():              # every input as it was
        if isinstance(content, (str, bytes)):
            raw = content if isinstance(content, bytes) else content.encode("utf-8")
            assert (tmp_path / fname).read_bytes() == raw, f"{fname} was changed"


if __name__ == "__main__":          # python -m tests.test_hostile: the counts, before and after a change
    bad = 0
    for name, files, argv, expect in CASES:
        with tempfile.TemporaryDirectory() as d:
            rc, out, err, secs = run_case(files, argv, Path(d))
        problem = verdict(expect, rc, out, err)
        bad += problem is not None
        print(f"{'FAIL' if problem else 'ok  '} {name:32s} {secs:6.2f} s  {problem or err.strip()[:110]}")
    print(f"{bad} of {len(CASES)} hostile inputs misbehave")
    sys.exit(1 if bad else 0)
