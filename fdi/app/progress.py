"""What the command line says on standard error: the ``bgfdi`` logger (``-q``, ``-v``) and progress.

- :func:`configure` sets up the ``bgfdi`` logger for a command: errors as ``bgfdi: error: ...``,
  notes (info) as they are, details (debug, ``-v``) with the seconds since the command started.
  ``-q`` keeps warnings and errors only; ``-v`` adds stage timings (:func:`stage`) and details.
- :class:`Progress` is every progress display of the application (a simulation's time, the
  estimators of a diagnosis, the files of a fleet, the scenarios of a suite): on a terminal a bar
  with its ETA, drawn by tqdm when it is installed (``pip install 'bgfdi[progress]'``) and by a
  plain fallback with the same information otherwise; when standard error is not a terminal (a
  log file, CI), a line in the log every 10 % or every 30 s, whichever comes first, never one
  per tick, and a summary line at the end; nothing for a task done within 2 s, and nothing at all
  with ``-q``.

The library core never logs to the terminal by itself: it takes a ``progress`` callback, and only
the application installs a handler (a Python program that uses ``fdi.app`` configures logging as
it likes; the ``bgfdi`` logger is then an ordinary logger).
"""
from __future__ import annotations

import logging
import sys
import time
from contextlib import contextmanager
from typing import Iterator

LOG = logging.getLogger("bgfdi")

QUIET, NORMAL, VERBOSE = -1, 0, 1
EVERY = 0.10            # non-terminal progress: a line per 10 % of the work ...
INTERVAL = 30.0         # ... or per 30 s, whichever comes first;
QUIET_START = 2.0       # ... from 2 s on: a task done sooner logs nothing
REDRAW = 0.1            # s between redraws of the plain terminal bar


class _Stderr(logging.Handler):
    """Writes to the standard error of the moment (``sys.stderr`` looked up at each record, so a
    test's captured stream or a redirected one is honoured)."""

    def emit(self, record: logging.LogRecord) -> None:
        stream = sys.stderr
        if stream is None:                     # started with standard error closed (``2>&-``)
            return
        try:
            stream.write(self.format(record) + "\n")
            stream.flush()
        except (OSError, ValueError):          # standard error closed: nothing left to tell
            pass


def shown(message: str, keep_line_ends: bool = False) -> str:
    """``message`` with its control characters escaped (a line end as ``\\n``, ESC as ``\\x1b``):
    a file name or a name read from a file can neither start a second error line nor drive the
    terminal (colours, clearing, a forged prompt). Printable text, Unicode included, is kept.

    >>> shown("a\\nb.csv: cannot read")
    'a\\\\nb.csv: cannot read'
    >>> shown("\\x1b[2J\u00b5.csv")
    '\\\\x1b[2J\u00b5.csv'
    """
    if message.isprintable():
        return message
    return "".join(c if c.isprintable() or (keep_line_ends and c == "\n")
                   else c.encode("unicode_escape").decode("ascii") for c in message)


class _Format(logging.Formatter):
    def __init__(self, start: float) -> None:
        super().__init__()
        self.start = start

    def format(self, record: logging.LogRecord) -> str:
        # warnings and errors are one line each; notes may span lines, but carry no other control
        message = shown(record.getMessage(), keep_line_ends=record.levelno < logging.WARNING)
        if record.levelno >= logging.CRITICAL:
            return f"bgfdi: {message}"
        if record.levelno >= logging.ERROR:
            return f"bgfdi: error: {message}"
        if record.levelno >= logging.WARNING:
            return f"bgfdi: warning: {message}"
        if record.levelno >= logging.INFO:
            return message
        return f"[{record.created - self.start:7.2f} s] {message}"


def configure(verbosity: int = NORMAL) -> None:
    """The ``bgfdi`` logger for one command: QUIET (warnings and errors), NORMAL (and notes,
    progress) or VERBOSE (and stage timings, details). Called again, it replaces its handler."""
    for h in [h for h in LOG.handlers if isinstance(h, _Stderr)]:
        LOG.removeHandler(h)
    handler = _Stderr()
    handler.setFormatter(_Format(time.time()))
    LOG.addHandler(handler)
    LOG.setLevel(logging.WARNING if verbosity <= QUIET else logging.DEBUG if verbosity >= VERBOSE else logging.INFO)
    LOG.propagate = False                  # the command's own lines, not twice through a root handler


@contextmanager
def stage(name: str) -> Iterator[None]:
    """``with stage("derivation"): ...`` logs the stage's wall time with ``-v``."""
    start = time.perf_counter()
    try:
        yield
    finally:
        LOG.debug("%s: %.3f s", name, time.perf_counter() - start)


def duration(seconds: float) -> str:
    """12 s, 3 min 05 s, 2 h 03 min."""
    s = int(round(max(0.0, seconds)))
    if s < 60:
        return f"{seconds:.1f} s" if seconds < 10 else f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {s % 3600 // 60:02d} min"


def _number(x: float) -> str:
    return f"{x:g}" if float(x).is_integer() else f"{x:.4g}"


def _tqdm():
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    return tqdm


class Progress:
    """Progress of one task of ``total`` units (seconds simulated, estimators, files).

    ``progress(done)`` sets the amount done (a simulator's callback), ``progress.advance(n)`` adds
    to it; ``close()`` (or leaving a ``with`` block) ends the display. ``stream`` is standard error
    unless given; ``tty`` overrides the terminal test, ``use_tqdm=False`` forces the plain bar on a
    terminal, ``clock`` replaces time.monotonic (tests)."""

    def __init__(self, total: float, label: str, unit: str = "", *, stream=None, tty: bool | None = None,
                 use_tqdm: bool = True, clock=time.monotonic) -> None:
        self.total, self.label, self.unit = float(total), label, unit
        self.done = 0.0
        self.clock = clock
        self.start = self._last_line = clock()
        self._last_draw = 0.0
        self._next_step = EVERY
        self._closed = False
        self._logged = False
        self._bar = None
        self.stream = stream
        out = stream if stream is not None else sys.stderr
        if not LOG.isEnabledFor(logging.INFO):
            self.kind = "off"
        elif tty if tty is not None else _isatty(out):
            tqdm = _tqdm() if use_tqdm and _columns(out) > 0 else None      # tqdm draws nothing 0 wide
            self.kind = "tqdm" if tqdm else "bar"
            if tqdm:
                self._bar = tqdm(total=self.total, desc=label, unit=unit or "it", file=out, leave=True,
                                 dynamic_ncols=True, smoothing=0.1,
                                 bar_format="{l_bar}{bar}| {n:.4g}/{total:.4g}" + (f" {unit}" if unit else "")
                                            + " [{elapsed}<{remaining}]")
        else:
            self.kind = "log"

    # -------------------------------------------------------------- updates

    def __call__(self, done: float) -> None:
        self.update(done)

    def advance(self, n: float = 1.0) -> None:
        self.update(self.done + n)

    def update(self, done: float) -> None:
        if self._closed:
            return
        done = min(float(done), self.total) if self.total else float(done)
        step, self.done = done - self.done, done
        if self.kind == "tqdm":
            if step > 0:
                self._bar.update(step)
        elif self.kind == "bar":
            now = self.clock()
            if now - self._last_draw >= REDRAW or self.fraction >= 1.0:
                self._last_draw = now
                self._draw()
        elif self.kind == "log":
            now = self.clock()
            if now - self.start >= QUIET_START and (self.fraction >= self._next_step
                                                    or now - self._last_line >= INTERVAL):
                if self.fraction < 1.0:                   # the last line is close()'s
                    LOG.info(self.line())
                    self._logged = True
                    self._last_line = now
                    while self._next_step <= self.fraction:
                        self._next_step += EVERY
        if self.total and self.done >= self.total:
            self.close()

    @property
    def fraction(self) -> float:
        return min(1.0, self.done / self.total) if self.total > 0 else 1.0

    def eta(self) -> float | None:
        """Seconds left at the mean rate so far; None before any progress."""
        if self.done <= 0 or self.total <= 0:
            return None
        elapsed = self.clock() - self.start
        return elapsed * (self.total - self.done) / self.done

    def line(self) -> str:
        """``simulating: 40 % (24 of 60 s), 3.2 s elapsed, ETA 4.8 s``: what every display shows."""
        unit = f" {self.unit}" if self.unit else ""
        eta = self.eta()
        return (f"{self.label}: {100 * self.fraction:.0f} % ({_number(self.done)} of {_number(self.total)}{unit}), "
                f"{duration(self.clock() - self.start)} elapsed"
                + ("" if self.fraction >= 1.0 else f", ETA {duration(eta)}" if eta is not None else ""))

    def _draw(self) -> None:
        out = self.stream if self.stream is not None else sys.stderr
        bar = "#" * int(30 * self.fraction)
        try:
            out.write(f"\r{bar:<30} {self.line()}\033[K")
            out.flush()
        except (OSError, ValueError):
            self.kind = "off"

    # -------------------------------------------------------------- end

    def close(self, failed: bool = False) -> None:
        """End the display; ``failed``: the task stopped on an error (no summary line then)."""
        if self._closed:
            return
        self._closed = True
        if self.kind == "tqdm":
            self._bar.close()
        elif self.kind == "bar":
            self._draw()
            out = self.stream if self.stream is not None else sys.stderr
            try:
                out.write("\n")
                out.flush()
            except (OSError, ValueError):
                pass
        elif (self.kind == "log" and self.done > 0 and not failed
              and (self._logged or self.clock() - self.start >= QUIET_START)):
            LOG.info(self.line())

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, kind, *exc) -> None:
        self.close(failed=kind is not None)


def _isatty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


class Steps:
    """A progress callback ``(done, total)``, as the core's are (the estimators of a diagnosis),
    whose total is known only at the first call: ``with Steps("estimators") as tick:
    diagnose(..., progress=tick)``."""

    def __init__(self, label: str, unit: str = "", **kw) -> None:
        self.label, self.unit, self.kw = label, unit, kw
        self.bar: Progress | None = None
        self.start = kw.get("clock", time.monotonic)()

    def __call__(self, done: float, total: float) -> None:
        if self.bar is None or self.bar.total != total:
            if self.bar is not None:
                self.bar.close()
            self.bar = Progress(total, self.label, self.unit, **self.kw)
            if self.bar.kind != "tqdm":
                self.bar.start = self.bar._last_line = self.start     # the task began before its first step
        self.bar(done)

    def close(self, failed: bool = False) -> None:
        if self.bar is not None:
            self.bar.close(failed)

    def __enter__(self) -> "Steps":
        return self

    def __exit__(self, kind, *exc) -> None:
        self.close(failed=kind is not None)


def _columns(stream) -> int:
    import os
    try:
        return os.get_terminal_size(stream.fileno()).columns
    except (AttributeError, ValueError, OSError):
        return 80
