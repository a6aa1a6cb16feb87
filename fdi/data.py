"""Measurement files: read a CSV, check it against the model, compute the model's signals.

A measurement file has a header row ``t,<columns>`` and one row per sample on a uniform time
axis, SI units. Problems (missing column, NaN rows, non-uniform or decreasing time, a file made
for another model) raise :class:`DataError` with one line that names the file and the fix.

A voltage logged in millivolts (the sensor's ``expr`` converts it) and a current source given as
an expression of time: the model's signals in SI units, sample by sample.

>>> from bondgraph.loader import load_model_text
>>> m = load_model_text('''
... parameters: {C1: {value: 1.0e-3, unit: F}, R: {value: 100.0, unit: Ohm}}
... data: {columns: [t, v_mV]}
... inputs: {i_in: {unit: A, expr: "0.01*t"}}
... elements: {src: {type: MSf, input: i_in}, cap: {type: C, parameter: C1}, res: {type: R, parameter: R}}
... junctions: {j: {type: "0"}}
... sensors: {v: {type: De, junction: j, unit: V, expr: v_mV / 1000}}
... bonds: {1: [src, j], 2: [j, cap], 3: [j, res]}
... ''')
>>> run = checked("run.csv", ["t", "v_mV"], np.array([[0.0, 2000.0], [0.5, 2500.0], [1.0, 3000.0]]))
>>> signals = signals_from_data(m, run)
>>> run.ts, signals["v"].tolist(), signals["i_in"].tolist()
(0.5, [2.0, 2.5, 3.0], [0.0, 0.005, 0.01])
>>> checked("run.csv", ["t", "v_mV"], np.array([[0.0, 1.0], [0.1, 1.0], [0.3, 1.0]]))
Traceback (most recent call last):
...
fdi.data.DataError: run.csv: non-uniform time axis (step 0.1 s at line 3, mean 0.15 s); resample to a constant sampling time
"""
from __future__ import annotations

import csv
import gzip
import io
import itertools
import os
import stat
import sys
import warnings
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator, Mapping

import numpy as np

from bondgraph.model import Model
from bondgraph.names import look_alike, same_name, skeleton

from .inputs import NoWriter, open_binary


class DataError(ValueError):
    """A measurement file the diagnosis cannot use."""


@dataclass(frozen=True)
class Measurements:
    path: str
    t: np.ndarray
    columns: Mapping[str, np.ndarray]

    @property
    def ts(self) -> float:
        return float(self.t[1] - self.t[0])


CHUNK = 8192           # rows parsed at a time (their text as Python objects: about 5 MB for 6 columns)
MAX_VALUES = 100_000_000   # numbers in one file (800 MB as float64): beyond, split the file
MAX_LINE = 1 << 20         # characters in one line (the header or a row): 1 MiB, some 50 000 numbers
MAX_COLUMNS = 10_000       # columns of the header
PANDAS_BYTES = 128 << 20   # files from this size are read by pandas (when installed) even if not imported yet
MAX_TIME = 1.0e9           # s (31 years): a time column beyond it is not seconds
BOMS = ((b"\xef\xbb\xbf", "utf-8-sig"), (b"\xff\xfe", "utf-16"), (b"\xfe\xff", "utf-16"))


def _open_text(path: str | Path) -> io.TextIOWrapper:
    """The file as text: gunzipped when it starts with gzip's magic bytes, decoded as UTF-8, or
    as UTF-16 when it starts with that byte-order mark (a spreadsheet's "Unicode text")."""
    return text_of(open_binary(path))        # a FIFO with no writer: NoWriter, not a wait


def text_of(raw) -> io.TextIOWrapper:
    """A binary stream (a file, standard input's buffer) as text, read as :func:`_open_text` reads a
    file: gunzipped after gzip's magic bytes, UTF-16 after its byte-order mark, else UTF-8 (a
    UTF-8 byte-order mark dropped). On a pipe, waits for its first bytes."""
    head = raw.peek(4)[:4] if hasattr(raw, "peek") else b""
    if head[:2] == b"\x1f\x8b":
        raw = gzip.open(raw, "rb")
        head = raw.peek(4)[:4]
    encoding = next((name for bom, name in BOMS if head.startswith(bom)), "utf-8")
    return io.TextIOWrapper(raw, encoding=encoding, newline="")


def blocks(fh, path: str, rows: int = CHUNK, cut: Callable[[str], None] | None = None,
           on_header: Callable[[list[str]], None] | None = None,
           skipped: int = 0) -> Iterator[tuple[list[str], np.ndarray]]:
    """(header, block of at most ``rows`` rows as float64) from a CSV text stream, as the rows
    arrive (a file, or standard input for the monitor); the header is checked for a ``t`` column,
    the separator found from it (semicolons: a decimal comma is read as a point). Empty fields are
    NaN; the caller checks them. Decoding and CSV errors become one-line DataErrors.

    With ``cut`` (a stream: the monitor), a last row with fewer values than the header, a stream
    cut while a row was written, is dropped and ``cut(message)`` told; a short row anywhere
    else is an error, as it is in a file. ``on_header(header)`` is called once the header is read
    and checked, before any row is waited for (the monitor's first event waits for it); what it
    raises is its own (a failed write of that event is standard output's error, not this file's).
    ``skipped``: rows of the file read before this stream's first row (by :func:`fdi.chunks.chunks`,
    which hands the rest of a recording over with its header again), so a message names the file's line."""
    in_callback = False
    try:
        lines = bounded_lines(fh, path, skipped)
        first = next(lines, "")
        delimiter = ";" if first.count(";") > first.count(",") else ","
        reader = csv.reader(itertools.chain([first], lines), delimiter=delimiter)
        header = [h.strip() for h in next(reader, [])]
        if len(header) > MAX_COLUMNS:
            raise DataError(f"{path}: {len(header):,} columns in the header, more than {MAX_COLUMNS:,}; a measurement "
                            "file has t and the model's columns")
        check_header(path, header)
        if first == "":
            raise DataError(f"{path}: the file is empty; a measurement file starts with a header line (t and the "
                            "model's columns)")
        if "t" not in header:
            shown = delimiter.join(header)
            if first.lstrip().startswith("#"):       # (a trial's logger wrote a comment line first)
                raise DataError(f"{path}: the first line is a comment ({shown[:60]}); a measurement file starts "
                                "with its header line (t and the model's columns): remove the comment lines")
            raise DataError(f"{path}: no 't' column in the header ({shown[:80]}); a measurement file has a "
                            "column named t, the time in s (any place in the header)")
        if on_header is not None:
            in_callback = True
            on_header(header)
            in_callback = False
        comma = delimiter == ";"
        pending: list[tuple[int, list[str]]] = []      # (line in the file, row): messages name the line
        count, done = 0, 1 + skipped                   # values read; lines of the file read (the header's)
        width = len(header)
        group: list[str] = []
        for line in itertools.chain(lines, [None]):   # plain rows: numpy's C parser, a block at a time
            if line is not None:
                group.append(line)
                if len(group) < rows:
                    continue
            block = _plain(group, width, comma) if group else None
            if block is None:
                if line is None and not group:      # the end, every row read
                    return
                break
            count += block.size
            if count > MAX_VALUES:
                raise DataError(f"{path}: more than {MAX_VALUES:.0e} values; split the file")
            done += len(group)
            group = []
            yield header, block
            if line is None:
                return
        # anything else (quotes, empty fields, a short or long row, a stream cut mid-row, a number
        # only Python reads): the csv module from the first block that was not plain, as before
        reader = csv.reader(itertools.chain(group, lines), delimiter=delimiter)
        for row in reader:
            if row:
                pending.append((done + reader.line_num, row))
            if len(pending) >= rows:
                count += len(pending) * width
                if count > MAX_VALUES:
                    raise DataError(f"{path}: more than {MAX_VALUES:.0e} values; split the file")
                held = [pending.pop()] if cut and len(pending[-1][1]) < width else []
                if pending:                       # a short last row waits: it may be where the stream ends
                    block, pending = _numbers(path, pending, width, comma, header), held     # the text freed first
                    yield header, block
                    del block
                pending = held
        if cut and pending and len(pending[-1][1]) < width:
            _, short = pending.pop()
            cut(f"{path}: the last row was cut ({len(short)} of {width} values): dropped")
        if pending:
            block, pending = _numbers(path, pending, width, comma, header), []
            yield header, block
    except OSError as exc:
        if in_callback:
            raise
        what = exc.strerror or str(exc)
        raise DataError(f"{path}: cannot read ({what})") from None
    except (UnicodeDecodeError, UnicodeError) as exc:
        at = f" (byte {exc.start})" if isinstance(exc, UnicodeDecodeError) else ""
        raise DataError(f"{path}: not UTF-8 text{at}; save the file as UTF-8 CSV") from None
    except (csv.Error, EOFError, zlib.error) as exc:
        raise DataError(f"{path}: not a CSV file ({str(exc)[:80]})") from None


def bounded_lines(fh, path: str, skipped: int = 0) -> Iterator[str]:
    """The lines of a text stream, each read with a limit of MAX_LINE characters: a file with no
    line end (``/dev/zero``, a binary file, one endless row) is refused after 1 MiB, where reading
    a line without limit would hold all of it in memory first. ``skipped``: lines of the file read
    past before the stream's second line (the line numbers of its messages count them)."""
    readline = fh.readline
    number = 0
    while True:
        line = readline(MAX_LINE + 1)
        if not line:
            return
        number += 1 if number != 1 else 1 + skipped
        if len(line) > MAX_LINE and line[-1] not in "\r\n":
            raise DataError(f"{path}: line {number} is longer than {MAX_LINE:,} characters (no line end within "
                            f"{MAX_LINE >> 20} MiB); a measurement file has one short row per sample: is it a CSV file?")
        yield line


def check_header(path: str, header: list[str]) -> None:
    """Refuse a header whose names cannot all be meant: a name given twice (which column would
    the model read? a dict keeps the last, silently), or two names that are one once
    Unicode-normalised (NFKC: 'µ' and 'μ', 'ﬁx' and 'fix' look alike and Python reads them as one)."""
    pair = same_name(header)
    if pair:
        i, j = pair
        first, name = header[i], header[j]
        if first == name:
            raise DataError(f"{path}: column '{name}' appears twice in the header (columns {i + 1} and {j + 1}); "
                            "rename or remove one")
        raise DataError(f"{path}: columns '{first}' (column {i + 1}) and '{name}' (column {j + 1}) are one name "
                        "once Unicode-normalised (NFKC); rename one")


def open_text(path: str | Path):
    """A measurement file as text (see :func:`_open_text`), errors as one-line DataErrors."""
    try:
        if Path(path).is_dir():
            raise DataError(f"{path}: is a folder; give a measurement CSV file")
        if str(path) == "-" and not Path(path).exists():
            raise DataError("-: no file of that name; this command reads measurement files (a command's output as "
                            "<(command)); a live stream on standard input is read by bgfdi monitor MODEL -")
        return _open_text(path)
    except (EOFError, zlib.error) as exc:            # gzip's magic bytes, then a cut or broken stream
        raise DataError(f"{path}: not a complete gzip file ({str(exc)[:80]})") from None
    except NoWriter as exc:
        raise DataError(str(exc)) from None
    except OSError as exc:
        raise DataError(f"{path}: cannot read ({exc.strerror or exc})") from None


def read_csv(path: str | Path) -> Measurements:
    """Read a measurement file row by row, straight into one float64 array per column (a 41 MB
    file of 600 001 rows x 6 takes its 29 MB of numbers and a block of text, where a list of rows
    took 14 times the file and stacked blocks twice the numbers). Accepted as well: a UTF-8
    byte-order mark, UTF-16 with its mark, a gzip-compressed file, and semicolons as separators
    (then a decimal comma is read as a point)."""
    fast = _by_pandas(str(path))
    if fast is not None:
        return checked(str(path), *fast)
    bound = line_bound(path)
    with open_text(path) as fh:
        header, table = _filled(blocks(fh, str(path)), bound)
    return checked(str(path), header, table)


class _Header(Exception):
    """The header a reader has read and checked (raised from ``blocks``' on_header to stop there)."""


def _by_pandas(path: str) -> tuple[list[str], np.ndarray] | None:
    """The header and table of a plain comma-separated regular file by pandas' C parser (the
    ``pandas`` extra; 0.23 s for a 69 MB file of 1 000 000 rows x 6, where Python's float took
    2.8 s and numpy's parser 1.1 s; the same numbers, bit for bit). The header is read and checked
    by :func:`blocks`, as for every file. Used when pandas is imported already (a notebook) or the
    file has PANDAS_BYTES or more (below, importing pandas costs more time than it saves: a 41 MB
    file reads in 0.61 s by numpy's parser, 0.55 s by pandas' with its import, which also takes
    70 MB). None when pandas is absent or the file is anything but plain (gzip, UTF-16, a BOM,
    semicolons, a pipe, more than MAX_VALUES numbers), and after pandas
    when a value is missing, a row is short or long or a number is one only Python reads: the reader
    of every other source then reads the file and says what is wrong, in its words.

    From PANDAS_BYTES on, the table is allocated for the most rows the file's size allows (each
    row at least one character per number and one separator or line end per number), at most
    MAX_VALUES numbers: rows never written are pages never touched (address space, not memory),
    and the file is not read once more to count its lines (0.19 s of 1.9 on 250 MB). A smaller
    file has its lines counted (:func:`line_bound`), so that what is allocated is what is used."""
    try:
        info = os.stat(path)
    except OSError:
        return None
    if not stat.S_ISREG(info.st_mode):
        return None                       # a pipe or a FIFO is read once, by the reader of every source
    if "pandas" not in sys.modules and info.st_size < PANDAS_BYTES:
        return None                       # importing pandas (0.32 s, 70 MB resident) costs more than it saves
    try:
        import pandas as pd
    except ImportError:
        return None
    with open(path, "rb") as raw:
        first = raw.readline(MAX_LINE + 1)
    if first[:2] == b"\x1f\x8b" or first[:3] == b"\xef\xbb\xbf" or first[:2] in (b"\xff\xfe", b"\xfe\xff") \
            or first.count(b";") > first.count(b","):
        return None

    def stop(header: list[str]) -> None:
        raise _Header(header)
    try:
        with open_text(path) as fh:
            next(blocks(fh, path, on_header=stop), None)
        return None                                    # no header: the reader says so
    except _Header as got:
        header = list(got.args[0])
    width = len(header)
    if info.st_size >= PANDAS_BYTES:      # a large file: not read once more to count its lines
        if not ends_every_mib(path, info.st_size):
            return None                   # a line pandas would hold whole (1 GB of it took 10.6 GB): the reader refuses it
        bound = min(info.st_size // (2 * width) + 1, MAX_VALUES // width + 1)
    else:                                 # a smaller one: its lines counted, the table as large as they allow
        bound = line_bound(path)
        if bound is None or bound * width > MAX_VALUES:
            return None
    table = np.empty((bound, width), order="F")     # columns contiguous: checked() takes views
    rows = 0
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")            # a long row is a warning to pandas (its data dropped)
            chunks = pd.read_csv(path, header=None, skiprows=1, dtype=float, engine="c", names=list(range(width)),
                                 index_col=False, skip_blank_lines=True, chunksize=CHUNK * 4)
            with chunks:
                for frame in chunks:                  # pieces of 32 768 rows: the parser's memory stays small
                    if frame.shape[1] != width or rows + frame.shape[0] > bound:
                        return None
                    piece = frame.to_numpy(dtype=float, copy=False)
                    if not np.isfinite(piece).all():  # checked while in the cache
                        return None
                    table[rows:rows + frame.shape[0]] = piece
                    rows += frame.shape[0]
    except (ValueError, TypeError, OverflowError, UnicodeDecodeError, pd.errors.ParserError, Warning):
        return None
    return header, table[:rows]


def ends_every_mib(path: str, size: int) -> bool:
    """Whether every whole MiB of the file holds a line end (\\n or \\r), so that no line is longer
    than 2 MiB (the last, shorter piece needs none: the MiB before it bounds its line): pandas' parser
    holds a line whole, and a file padded with a GB of zeros after its first rows took 10.6 GB before
    its refusal (a user trial). Each MiB is searched from its start to its first line end only
    (memory-mapped: a page or two per MiB, a few ms for 250 MB)."""
    import mmap
    step = 1 << 20
    try:
        with open(path, "rb") as raw, mmap.mmap(raw.fileno(), 0, access=mmap.ACCESS_READ) as mm:
            for start in range(0, max(size - step, 0) + 1, step):
                end = min(start + step, size)
                if mm.find(b"\n", start, end) < 0 and mm.find(b"\r", start, end) < 0:
                    return False
    except (OSError, ValueError):
        return False
    return True


def line_bound(path: str | Path) -> int | None:
    """At most how many lines a regular file (gunzipped if gzip) has: its line ends counted in one
    pass of 1 MiB reads (a line ends at \\n, \\r or \\r\\n; in any encoding each end holds one of
    those bytes, so the count only errs upward), up to MAX_VALUES. None for a pipe or a FIFO (read
    once) and for a MiB without a line end (no CSV file: the reader says so after its first line)."""
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            return None
        with open(path, "rb") as raw:
            stream = gzip.open(raw, "rb") if raw.peek(2)[:2] == b"\x1f\x8b" else raw
            ends, last = 1, b""
            while ends <= MAX_VALUES and (block := stream.read(1 << 20)):
                found = block.count(b"\n")
                if b"\r" in block:                      # scanned once more only where a \r is (0.4 -> 0.26 s on 250 MB)
                    found += block.count(b"\r") - block.count(b"\r\n")
                if not found:                    # no line end in 1 MiB: the reader refuses the file at once
                    return None
                ends += found - (last == b"\r" and block[:1] == b"\n")     # a \r\n split by the read
                last = block[-1:]
            return ends
    except (OSError, EOFError, zlib.error):           # the read itself says what is wrong
        return None


def _filled(parts: Iterator[tuple[list[str], np.ndarray]], bound: int | None) -> tuple[list[str], np.ndarray]:
    """The header and the blocks written one after the other into one (rows, width) array in
    column order (each column contiguous: ``checked`` then takes views, no copies), allocated once
    for ``bound`` rows (lines of the file, MAX_VALUES numbers at most); without a bound (a pipe) or
    past it (a file that grew while read), grown by doubling. Rows never written are pages never
    touched: they take address space, not memory."""
    header: list[str] = []
    table = np.empty((0, 1), order="F")
    rows = 0
    for header, block in parts:
        need = rows + block.shape[0]
        if need > table.shape[0] or table.shape[1] != block.shape[1]:
            width = max(1, block.shape[1])
            size = bound if bound is not None and rows == 0 else 2 * table.shape[0]
            size = max(need, min(size or 0, MAX_VALUES // width + 1), 4 * CHUNK if bound is None else 0)
            grown = np.empty((size, width), order="F")
            grown[:rows] = table[:rows]
            table = grown
        table[rows:need] = block
        rows = need
        del block
    return header, table[:rows]


def checked(path: str, header: list[str], table: np.ndarray, in_memory: bool = False) -> Measurements:
    """Measurements from a parsed table (rows x columns of ``header``), after the checks every
    source of data gets: two samples at least, no NaN, time increasing on a uniform axis. A bad
    sample is named by its line of the file (the header is line 1), or with ``in_memory`` (arrays,
    a DataFrame) by its position from 0 (a DataFrame's own index labels are not read)."""
    def at(i: int) -> str:
        return f"position {i}" if in_memory else f"line {i + 2}"
    check_header(path, list(header))
    if table.shape[0] < 2:
        raise DataError(f"{path}: needs a header row and at least two samples")
    cols = {h: np.ascontiguousarray(table[:, i]) for i, h in enumerate(header)}
    del table
    finite = np.ones(len(cols["t"]), dtype=bool)                 # a column at a time: temporaries of booleans
    for column in cols.values():
        finite &= np.isfinite(column)
    bad = np.flatnonzero(~finite)
    if bad.size:
        raise DataError(f"{path}: {bad.size} row(s) with NaN, infinite or missing values, first at {at(int(bad[0]))}; "
                        "remove or fill them")
    time = cols["t"]
    largest = max(time.max(), -time.min())                        # max |t|, without an array of |t|
    if largest > MAX_TIME:
        far = float(time.max()) if time.max() >= -time.min() else float(time.min())
        raise DataError(f"{path}: time values beyond +-{MAX_TIME:.0e} s ({'largest' if far > 0 else 'smallest'} "
                        f"{far:.10g} s); the t column must be time in s")
    dt = np.diff(time)
    if not (dt > 0).all():
        i = int(np.flatnonzero(dt <= 0)[0])
        reversed_ = " (it decreases throughout: the rows in reverse order? sort them by time)" if (dt < 0).all() else ""
        raise DataError(f"{path}: time does not increase at {at(i + 1)} (t = {time[i + 1]:g} s){reversed_}")
    mean = dt.mean()
    if max(dt.max() - mean, mean - dt.min()) > 1e-6 * max(1.0, abs(mean)) + 1e-3 * mean:   # max |dt - mean|
        i = int(np.argmax(np.abs(dt - mean)))
        raise DataError(f"{path}: non-uniform time axis (step {dt[i]:g} s at {at(i + 1)}, mean {mean:g} s); "
                        "resample to a constant sampling time")
    return Measurements(str(path), time, cols)


def _plain(lines: list[str], width: int, comma: bool = False) -> np.ndarray | None:
    """A block of plain rows (``width`` numbers each, no quotes or empty fields) as a (rows, width)
    float array, parsed by numpy in C; None for anything else, which :func:`_numbers` then reads
    with its messages (so both paths give the same numbers and the same errors). Measured on a
    69 MB file of 1 000 000 rows x 6: 2.8 s by the csv module and Python's float, 0.6 s so."""
    sep = ";" if comma else ","
    if any(line.count(sep) != width - 1 for line in lines):
        return None
    text = "".join(lines)
    if comma:
        text = text.replace(",", ".").replace(";", ",")
    text = text.replace("\n", ",")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            values = np.fromstring(text[:-1] if text.endswith(",") else text, dtype=float, sep=",")
    except (ValueError, DeprecationWarning):
        return None
    if values.size != len(lines) * width:
        return None
    return values.reshape(len(lines), width)


def _numbers(path, numbered: list[tuple[int, list[str]]], width: int, comma: bool = False,
             header: list[str] | None = None) -> np.ndarray:
    """A block of rows, each with its line in the file, as a (rows, width) float array; empty fields
    become NaN; with ``comma`` (a semicolon-separated file) a decimal comma is read as a point. A
    row of another width or a value that is no number is refused naming its line and column."""
    for line, r in numbered:
        if len(r) != width:
            raise DataError(f"{path}: rows do not all have {width} values: line {line} has {len(r)} "
                            f"({'cut short?' if len(r) < width else 'a separator too many?'}); fix or remove it")
    rows = [r for _, r in numbered]
    if comma:
        rows = [[x.replace(",", ".") for x in r] for r in rows]
    try:
        return np.array([[float(x) if x.strip() else np.nan for x in r] for r in rows], dtype=float).reshape(-1, width)
    except ValueError as exc:
        i = next((i for i, r in enumerate(rows) if not _floats(r)), None)
        at = f" at line {numbered[i][0]}" if i is not None else ""
        k = next((k for k, x in enumerate(rows[i]) if not _floats([x])), None) if i is not None else None
        if k is not None and header is not None and k < len(header):
            at += f", column '{header[k]}'"          # (a trial's command logged as 'on' named no column)
        raise DataError(f"{path}: a value is not a number{at} ({str(exc)[:80]})") from None


def _floats(row: list[str]) -> bool:
    """Every field of ``row`` is a number or empty (what :func:`_numbers` reads)."""
    try:
        for x in row:
            if x.strip():
                float(x)
    except ValueError:
        return False
    return True


def check_against_model(model: Model, data: Measurements) -> None:
    """Every column the model reads must be there."""
    functions = _signal_functions(model)
    needed = set()
    for s in model.sensors:
        needed |= set(functions[s][0])
    for i in model.inputs.values():
        if i.column:
            needed.add(i.column)
    needed |= {m.column for m in model.modes.values() if m.column}
    missing = sorted(needed - set(data.columns))
    if missing:
        found = len(set(data.columns) & needed)
        other = f" (is it a file for another model than {model.name}?)" if found < len(needed) / 2 else ""
        alike = [f"'{c}' looks like '{m}' ({look_alike(c, m)})" for m in missing for c in data.columns
                 if c != m and skeleton(c) == skeleton(m)]
        raise DataError(f"{data.path}: missing column(s) {', '.join(missing)} that model {model.name} reads"
                        f"{other}; columns found: {', '.join(data.columns)}"
                        + (f"; {'; '.join(alike)}: rename it in the header" if alike else ""))


_SIGNALS: dict[int, tuple[Model, dict]] = {}     # lambdified sensor and input expressions per model
MODE = "mode "                                     # the key prefix of an autonomous mode's condition


def _signal_functions(model: Model) -> dict:
    """(argument names, function) of each sensor's signal, each input without a column and each
    autonomous mode's condition (key ``"mode <name>"``), lambdified once per model (the monitor
    asks for them on every block of rows; a compiled model carries them: :mod:`fdi.persist`)."""
    hit = _SIGNALS.get(id(model))
    if hit is not None and hit[0] is model:
        return hit[1]
    import sympy as sp
    out = {}
    for s in model.sensors.values():
        syms = sorted(s.signal.free_symbols, key=lambda x: x.name)
        out[s.name] = ([x.name for x in syms], sp.lambdify(syms, s.signal, modules="numpy"))
    nominal = {k: v for k, v in model.nominal_values().items()}
    for i in model.inputs.values():
        if i.expr is not None:
            out[i.name] = (["t"], sp.lambdify([sp.Symbol("t", real=True)], i.expr.xreplace(nominal), modules="numpy"))
    for m in model.modes.values():
        if m.positive is not None:
            syms = sorted(m.positive.free_symbols, key=lambda x: x.name)
            out[MODE + m.name] = ([x.name for x in syms], sp.lambdify(syms, m.positive, modules="numpy"))
    if len(_SIGNALS) > 16:
        _SIGNALS.clear()
    _SIGNALS[id(model)] = (model, out)
    return out


def input_values(model: Model, name: str, t: np.ndarray) -> np.ndarray:
    """Input ``name``'s expression at the model's nominal values, at the times ``t`` (what a
    simulation drives it with and logs)."""
    t = np.asarray(t, dtype=float)
    _, fn = _signal_functions(model)[name]
    return np.asarray(fn(t), dtype=float) * np.ones_like(t)


def signals_from_data(model: Model, data: Measurements) -> dict[str, np.ndarray]:
    """Each sensor's measured signal and each input, by name, from the data columns."""
    check_against_model(model, data)
    functions = _signal_functions(model)
    out: dict[str, np.ndarray] = {}
    for s in model.sensors.values():
        names, fn = functions[s.name]
        value = np.asarray(fn(*[data.columns[x] for x in names]), dtype=float)
        out[s.name] = value if value.shape == data.t.shape else value * np.ones_like(data.t)   # a column: no copy
    for i in model.inputs.values():
        out[i.name] = data.columns[i.column] if i.column else input_values(model, i.name, data.t)
    for m in model.modes.values():
        if m.column:
            out[m.name] = (np.asarray(data.columns[m.column], dtype=float) >= 0.5).astype(float)
    out.update(autonomous_modes(model, out))
    return out


def unread_columns(model: Model) -> list[str]:
    """The columns ``data: columns`` declares that no sensor, input or commanded mode reads: a
    command column a mode was meant to follow (``m_cmd`` beside a mode ``m`` without ``column:``
    is held at its nominal value, and every switch of the real contactor looks like a fault).

    >>> from bondgraph.loader import load_model
    >>> unread_columns(load_model("models/two_tank_commanded.yaml"))
    []
    """
    read = {"t"} | {i.column for i in model.inputs.values() if i.column} | {
        m.column for m in model.modes.values() if m.column}
    for s in model.sensors.values():
        read |= {str(x) for x in s.signal.free_symbols}
    return [c for c in model.columns if c not in read]


def autonomous_modes(model: Model, signals: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Each autonomous mode, sample by sample: 1 where its condition (``positive``) is above zero."""
    out = {}
    functions = _signal_functions(model)
    nominal = model.nominal_by_name()
    for m in model.modes.values():
        if m.positive is None:
            continue
        names, fn = functions[MODE + m.name]
        value = fn(*[signals[x] if x in signals else float(nominal[x]) for x in names])
        n = len(next(iter(signals.values()))) if signals else 1
        out[m.name] = (np.asarray(value, dtype=float) > 0).astype(float) * np.ones(n)
    return out


def commanded(model: Model, raw: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The commanded and autonomous mode variables' values, sample by sample (0 or 1; a command
    column is read as 1 from 0.5 up), by mode name: residuals evaluate each sample in its mode."""
    return {m.name: np.asarray(raw[m.name]) for m in model.modes.values()
            if (m.column or m.autonomous) and m.name in raw}
