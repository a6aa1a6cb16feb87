"""A recorded CSV read a megabyte at a time and parsed in C: what ``bgfdi monitor`` replays a file with.

:func:`fdi.data.blocks` reads a stream line by line, as its rows arrive, and hands over ``rows``
of them at a time: right for a live source (a pipe, a socket), where a block is what has come.
A recording (a regular file, or text already in memory) has all its rows there: reading them one
Python line at a time cost more than the monitor's own work (1 h at 100 Hz: 7 200 reads of 50
rows). :func:`chunks` reads ~1 MB of text at once, checks in numpy that every line is plain (the
header's number of values, separated by commas, no quotes), parses it with numpy's C parser, and
yields a whole number of ``rows``-row blocks per chunk, so that ``Stream.feed(header, table,
rows=...)`` sees the same blocks as before and emits the same events.

Anything else (a semicolon-separated file, quotes, empty fields, a short or long row, a row cut
at the end of the stream, text that is not ASCII) is handed, from the first block it touches, to
:func:`fdi.data.blocks` with the rest of the stream: the same numbers, errors and messages.

>>> import io
>>> text = "t,x\\n" + "".join(f"{k / 10},{k}\\n" for k in range(7))
>>> [(h, b.shape) for h, b in chunks(io.StringIO(text), "x.csv", 3)]
[(['t', 'x'], (6, 2)), (['t', 'x'], (1, 2))]
"""
from __future__ import annotations

import io
import warnings
import zlib
from typing import Callable, Iterator

import numpy as np

from .data import MAX_LINE, MAX_VALUES, DataError, blocks

CHUNK_CHARS = 1 << 20       # characters read at a time (~14 000 rows of 6 columns; the text and its array ~10 MB)


def chunks(fh, path: str, rows: int, cut: Callable[[str], None] | None = None,
           on_header: Callable[[list[str]], None] | None = None,
           size: int = CHUNK_CHARS, parser: str = "auto") -> Iterator[tuple[list[str], np.ndarray]]:
    """(header, table) from a recorded CSV text stream: tables of a whole number of ``rows``-row
    blocks (the last one may end with a shorter block), as :func:`fdi.data.blocks` would group
    them; ``cut`` and ``on_header`` as there. ``parser``: ``numpy``, ``arrow`` (pyarrow's CSV
    reader, the ``arrow`` extra: twice as fast) or ``auto`` (pyarrow when installed and the
    recording fills a chunk: its import, 0.12 s, is not paid on a short file)."""
    if parser not in ("auto", "numpy", "arrow"):
        raise ValueError(f"parser: 'auto', 'numpy' or 'arrow', not {parser!r}")
    head = _read(fh, path, lambda: fh.readline(MAX_LINE + 1))
    got: list[list[str]] = []

    def held(header: list[str]) -> None:
        got.append(header)
        if on_header is not None:
            on_header(header)
    for _ in blocks(io.StringIO(head), path, rows, cut, held):   # the header's checks and messages
        pass
    header = got[0]
    width = len(header)
    text, values = "", 0
    semicolons = head.count(";") > head.count(",")      # decimal commas: blocks' own path
    while not semicolons:
        more = _read(fh, path, lambda: fh.read(size))
        if not more:
            break                                 # the end: what is left goes to blocks (a cut row, a last short block)
        text += more
        end = text.rfind("\n") + 1
        if len(text) - end > MAX_LINE:
            break                                 # a line with no end within MAX_LINE: blocks says so (a row
        if not end:                               # short of a block before it kept text growing: a 2 GB file
            continue                              # of NULs past 202 rows held 500 MB and ran for minutes)
        if parser == "auto":
            parser = "arrow" if len(more) >= size and arrow_available() else "numpy"
        table, used = _parse(text[:end], width, rows, parser == "arrow")
        if table is None:
            break
        values += table.size
        if values > MAX_VALUES:
            raise DataError(f"{path}: more than {MAX_VALUES:.0e} values; split the file")
        text = text[used:]
        if table.size:
            yield header, table
    rest = _Joined(head + text, fh)
    yield from blocks(rest, path, rows, cut, skipped=values // width)


GATHER_ROWS = 16384         # rows of a live stream joined at most while more are already waiting


def gathered(parts: Iterator[tuple[list[str], np.ndarray]], fh,
             most: int = GATHER_ROWS) -> Iterator[tuple[list[str], np.ndarray]]:
    """The blocks of a live stream (:func:`fdi.data.blocks`), joined while the next ones are
    already waiting in it (``select`` on its descriptor says so): a producer far ahead of the
    monitor (``cat data.csv | bgfdi monitor M -``) is taken thousands of rows at a time, a live
    one block by block as before, never waiting for more than a block. A failure of the source
    comes after the blocks read before it, as without joining."""
    try:
        fd = fh.fileno()
    except (AttributeError, OSError, ValueError):
        fd = None
    pending: list[np.ndarray] = []
    header: list[str] = []
    it = iter(parts)
    while True:
        try:
            header, block = next(it)
        except StopIteration:
            break
        except BaseException:
            if pending:
                yield header, np.concatenate(pending)
            raise
        pending.append(block)
        if sum(b.shape[0] for b in pending) < most and fd is not None and _waiting(fd):
            continue
        yield header, pending[0] if len(pending) == 1 else np.concatenate(pending)
        pending = []
    if pending:
        yield header, np.concatenate(pending)


def _waiting(fd: int) -> bool:
    """Whether reading ``fd`` now would not wait (data or its end are there)."""
    import select
    try:
        return bool(select.select([fd], [], [], 0)[0])
    except (OSError, ValueError):
        return False


def _parse(text: str, width: int, rows: int, arrow: bool = False) -> tuple[np.ndarray | None, int]:
    """The first whole ``rows``-row blocks of ``text`` (complete lines) as a float table, and the
    characters they took; (None, 0) when a line is not plain (the caller hands over to blocks).
    ``arrow``: parsed by pyarrow's CSV reader (one thread), which checks each row's number of
    values itself; else numpy checks the separators and parses."""
    if '"' in text or not text.isascii():
        return None, 0
    lines = text.count("\n")
    take = lines - lines % rows
    if not take:
        return np.empty((0, width)), 0
    used = len(text)
    for _ in range(lines - take):                       # fewer than ``rows`` lines wait for the next chunk
        used = text.rindex("\n", 0, used - 1) + 1
    data = text[:used].encode("ascii")
    table = _arrow(data, width) if arrow else _numpy(data, width)
    if table is None or table.shape != (take, width):
        return None, 0
    return table, used


def _numpy(data: bytes, width: int) -> np.ndarray | None:
    """Plain rows of ``width`` comma-separated numbers parsed by numpy (None for anything else):
    each line's separators checked in numpy (width - 1 commas, then the line end)."""
    raw = np.frombuffer(data, dtype=np.uint8)
    seps = raw[(raw == 44) | (raw == 10)]                  # every comma and line end, in order
    if seps.size % width:
        return None
    seps = seps.reshape(-1, width)
    if not (seps[:, -1] == 10).all() or (width > 1 and not (seps[:, :-1] == 44).all()):
        return None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            values = np.fromstring(data[:-1].replace(b"\n", b",").decode("ascii"), dtype=float, sep=",")
    except (ValueError, DeprecationWarning):
        return None
    if values.size != seps.shape[0] * width:
        return None
    return values.reshape(-1, width)


def _arrow(data: bytes, width: int) -> np.ndarray | None:
    """Rows parsed by pyarrow (the ``arrow`` extra): every row ``width`` values, each a number
    (a null, an empty field or "nan" among them: None, and data.blocks says what is wrong). Its
    buffers come from the C library's allocator, which hands them back when the table is copied
    out: with pyarrow's default pool (mimalloc) the resident memory of an endless stream wandered
    by 6 MB, with this one by 1.6 MB over 4 h (measured)."""
    import pyarrow as pa
    import pyarrow.csv as pc

    names = [f"c{i}" for i in range(width)]
    try:
        table = pc.read_csv(pa.BufferReader(data), read_options=pc.ReadOptions(column_names=names, use_threads=False),
                            convert_options=pc.ConvertOptions(column_types=dict.fromkeys(names, pa.float64())),
                            memory_pool=pa.system_memory_pool())
    except (pa.ArrowInvalid, pa.ArrowTypeError, ValueError):
        return None
    if any(column.null_count for column in table.columns):
        return None
    return np.column_stack([column.to_numpy() for column in table.columns])


def arrow_available() -> bool:
    """Whether pyarrow (the ``arrow`` extra) can be imported."""
    try:
        import pyarrow.csv  # noqa: F401
    except ImportError:
        return False
    return True


def _read(fh, path: str, read: Callable[[], str]) -> str:
    """``read()`` on the stream, its failures the one-line errors of :func:`fdi.data.blocks`."""
    try:
        return read()
    except OSError as exc:
        raise DataError(f"{path}: cannot read ({exc.strerror or exc})") from None
    except (UnicodeDecodeError, UnicodeError) as exc:
        at = f" (byte {exc.start})" if isinstance(exc, UnicodeDecodeError) else ""
        raise DataError(f"{path}: not UTF-8 text{at}; save the file as UTF-8 CSV") from None
    except (EOFError, zlib.error) as exc:
        raise DataError(f"{path}: not a CSV file ({str(exc)[:80]})") from None


class _Joined:
    """Text already read, then the rest of the stream, line by line (what blocks reads)."""

    def __init__(self, first: str, rest) -> None:
        self.first, self.rest = io.StringIO(first), rest

    def readline(self, limit: int = -1) -> str:
        line = self.first.readline(limit)
        if line.endswith("\n") or (limit >= 0 and len(line) >= limit):
            return line
        return line + self.rest.readline(limit - len(line) if limit >= 0 else -1)
