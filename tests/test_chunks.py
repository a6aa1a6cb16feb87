"""A recording read in chunks parsed in C (fdi.chunks, issue 24): the numbers Python's float reads,
in the blocks data.blocks would give, and for anything not plain the same errors."""
from __future__ import annotations

import io

import numpy as np
import pytest

from fdi.chunks import arrow_available, chunks
from fdi.data import DataError, blocks

PARSERS = ["numpy"] + (["arrow"] if arrow_available() else [])


def _text(rows: int, seed: int = 0) -> tuple[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    values = rng.standard_normal((rows, 4)) * 10.0 ** rng.integers(-12, 12, (rows, 4))
    lines = [f"{k * 0.01:.2f}," + ",".join(repr(float(v)) for v in row) for k, row in enumerate(values)]
    return "t,a,b,c,d\n" + "\n".join(lines) + "\n", np.array([[float(x) for x in line.split(",")] for line in lines])


@pytest.mark.parametrize("parser", PARSERS)
def test_numbers_are_those_of_python_float_in_whole_blocks(parser):
    """17-digit numbers from 1e-12 to 1e12: every value as Python's float parses it, in tables
    of whole 50-row blocks (the last one shorter) when the text comes in chunks of 4 kB."""
    text, expected = _text(1234)
    parts = list(chunks(io.StringIO(text), "x.csv", 50, size=4096, parser=parser))
    assert all(h == ["t", "a", "b", "c", "d"] for h, _ in parts)
    assert all(b.shape[0] % 50 == 0 for _, b in parts[:-1]) and parts[-1][1].shape[0] == 1234 % 50
    assert np.array_equal(np.concatenate([b for _, b in parts]), expected)


@pytest.mark.parametrize("parser", PARSERS)
@pytest.mark.parametrize("damage, message", [
    (lambda rows: rows[:600] + [rows[600][:9]] + rows[601:], "rows do not all have 5 values: line 602 has "),
    (lambda rows: rows[:700] + [rows[700] + ",1.0"] + rows[701:], "rows do not all have 5 values: line 702 has 6"),
    (lambda rows: rows[:800] + ['"' + rows[800] + '"'] + rows[801:], "rows do not all have 5 values: line 802 has 1"),
])
def test_rows_not_plain_give_the_errors_of_blocks(parser, damage, message):
    """A short row, a long row, a quoted row in the middle of a recording: the blocks before it as
    data.blocks gives them, then its error, naming the row's line in the file (the header is line 1)
    in both, though chunks hands the rest of the file to blocks after rows it parsed itself."""
    text, _ = _text(1000)
    head, *rows = text.splitlines()
    bad = head + "\n" + "\n".join(damage(rows)) + "\n"
    got, want = [], []
    with pytest.raises(DataError, match=message) as by_chunks:
        for _, b in chunks(io.StringIO(bad), "x.csv", 50, size=4096, parser=parser):
            got.append(b)
    with pytest.raises(DataError, match=message) as by_blocks:
        for _, b in blocks(io.StringIO(bad), "x.csv", 50):
            want.append(b)
    assert str(by_chunks.value) == str(by_blocks.value)
    assert np.array_equal(np.concatenate(got), np.concatenate(want))


def test_a_cut_last_row_is_dropped_with_its_warning():
    text, expected = _text(300)
    last = text.rstrip("\n").rsplit("\n", 1)[1]
    cut = text[:-len(last) - 1] + ",".join(last.split(",")[:2])         # the last row: 2 of its 5 values
    told = []
    parts = [b for _, b in chunks(io.StringIO(cut), "x.csv", 50, cut=told.append, size=2048)]
    assert np.array_equal(np.concatenate(parts), expected[:-1])
    assert told == ["x.csv: the last row was cut (2 of 5 values): dropped"]


@pytest.mark.parametrize("parser", PARSERS)
def test_windows_line_ends_read_as_the_line_reader_reads_them(parser):
    """A recording saved with CRLF line ends: the numbers of data.blocks, in whole blocks."""
    text, expected = _text(777, seed=3)
    crlf = text.replace("\n", "\r\n")
    got = np.concatenate([b for _, b in chunks(io.StringIO(crlf, newline=""), "x.csv", 50, size=4096, parser=parser)])
    want = np.concatenate([b for _, b in blocks(io.StringIO(crlf, newline=""), "x.csv", 50)])
    assert np.array_equal(got, expected) and np.array_equal(want, expected)


class _Counted(io.StringIO):
    """A text stream that counts the characters read from it."""
    taken = 0

    def read(self, size=-1):
        out = super().read(size)
        self.taken += len(out)
        return out

    def readline(self, size=-1):
        out = super().readline(size)
        self.taken += len(out)
        return out


@pytest.mark.parametrize("rows", [5, 7])
def test_rows_short_of_a_block_then_no_line_end_are_refused_after_a_mebibyte(rows):
    """Seven rows then NULs without a line end (a sparse 2 GB file after its rows, a user trial's):
    with blocks of 5, the two rows short of a block kept the text growing by a chunk per read, to
    the whole file (500 MB held, minutes); now refused within a few MiB, at the line of the file
    that has no end (the header is line 1, the rows 2 to 8)."""
    text = "t,x\n" + "".join(f"{k / 10},{k}\n" for k in range(7)) + "\0" * (8 << 20)
    fh = _Counted(text)
    with pytest.raises(DataError, match="line 9 is longer than 1,048,576 characters"):
        for _ in chunks(fh, "sparse.csv", rows, size=1 << 20):
            pass
    assert fh.taken < 4 << 20
