"""Residuals from carried filter state (fdi.carry, issue 24): a stream fed in blocks of any size,
one row, fewer rows than the derivative window, or thousands at once, gives the residuals the
whole record gives (``fdi.residuals.evaluate`` on the file: the batch path), to round-off."""
from __future__ import annotations

import numpy as np
import pytest

from fdi.data import read_csv, signals_from_data
from fdi.monitor import compiled
from fdi.options import Options
from fdi.residuals import evaluate

from .conftest import CYCAB, DATA


def _sizes(rng: np.random.Generator, total: int, window: int) -> list[int]:
    """Block sizes covering ``total`` rows: single rows, blocks shorter than the filter window,
    about a window, and long ones, in random order."""
    out: list[int] = []
    while sum(out) < total:
        kind = rng.integers(4)
        out.append(1 if kind == 0 else int(rng.integers(2, window)) if kind == 1 else
                   int(rng.integers(window, 3 * window)) if kind == 2 else int(rng.integers(100, 700)))
    return out


def _whole(name: str):
    m = read_csv(DATA / f"{name}.csv")
    c = compiled(str(CYCAB))
    whole = evaluate(c.model, list(c.residuals), signals_from_data(c.model, m), m.ts, window=c.config.derivative_window)
    header = list(m.columns)
    return header, np.column_stack([m.columns[h] for h in header]), whole


@pytest.mark.parametrize("seed", [0, 1])
def test_blocks_of_random_sizes_give_the_batch_residuals(seed):
    """The CyCab's nominal reference run (60 s at 100 Hz, a 25-sample window) fed in random
    blocks, 1 row to 700, each its own ``feed``: every residual sample made final equals the
    whole file's, from the first sample on (the record's start takes the same edge fit)."""
    header, table, whole = _whole("nominal")
    mon = compiled(CYCAB).stream(lambda e: None, Options(workers=1))
    pieces, a = [], 0
    for size in _sizes(np.random.default_rng(seed), table.shape[0], 25):
        before = mon.done
        mon.feed(header, table[a:a + size])
        a += size
        if mon.done > before:
            assert mon.residuals.shape[1] == mon.done - before        # each sample once
            pieces.append(mon.residuals)
    streamed = np.concatenate(pieces, axis=1)
    assert streamed.shape[1] == mon.done >= table.shape[0] - 14
    np.testing.assert_allclose(streamed, whole[:, :mon.done], rtol=1e-9, atol=1e-12 * np.abs(whole).max())


def test_chunks_taken_as_blocks_give_the_batch_residuals_and_the_same_events():
    """Chunks of thousands of rows fed with ``rows=50`` (what ``bgfdi monitor`` does with a
    recording) give the whole file's residuals, and the events of feeding 50 rows at a time,
    ``known_at`` included, on scenario 1 (a detection at 31.88 s, then a decision)."""
    header, table, whole = _whole("nominal")
    mon = compiled(CYCAB).stream(lambda e: None, Options(workers=1))
    pieces = []
    for a in range(0, table.shape[0], 2345):
        before = mon.done
        mon.feed(header, table[a:a + 2345], rows=50)
        if mon.done > before:
            pieces.append(mon.residuals)
    streamed = np.concatenate(pieces, axis=1)
    np.testing.assert_allclose(streamed, whole[:, :mon.done], rtol=1e-9, atol=1e-12 * np.abs(whole).max())

    s1 = read_csv(DATA / "scenario1.csv")
    table = np.column_stack([s1.columns[h] for h in header])
    by_block, by_chunk = [], []
    one = compiled(CYCAB).stream(by_block.append, Options(workers=1), live=False)
    for a in range(0, table.shape[0], 50):
        one.feed(header, table[a:a + 50])
    many = compiled(CYCAB).stream(by_chunk.append, Options(workers=1), live=False)
    for a in range(0, table.shape[0], 1000):
        many.feed(header, table[a:a + 1000], rows=50)
    strip = [{k: v for k, v in e.items() if k != "identification_s"} for e in by_block]
    kinds = [e["event"] for e in by_block]
    assert kinds[:2] == ["start", "detection"] and "decision" in kinds
    assert [{k: v for k, v in e.items() if k != "identification_s"} for e in by_chunk] == strip
    one.stop(now=True)
    many.stop(now=True)


def test_chunks_forget_what_blocks_forget():
    """With 5 s of history, chunks taken as 50-row blocks forget the rows 50-row feeds forget
    (the buffer's start and length at every chunk's end) and detect scenario 2's leak at the
    time and with the coherence the whole file gives (31.98 s, [0 1 0]), known at the same time."""
    s2 = read_csv(DATA / "scenario2.csv")
    header = list(s2.columns)
    table = np.column_stack([s2.columns[h] for h in header])[:3300]
    by_block, by_chunk = [], []
    one = compiled(CYCAB).stream(by_block.append, Options(workers=1), history=5.0)
    many = compiled(CYCAB).stream(by_chunk.append, Options(workers=1), history=5.0)
    for a in range(0, 3300, 1100):
        for b in range(a, a + 1100, 50):
            one.feed(header, table[b:b + 50])
        many.feed(header, table[a:a + 1100], rows=50)
        assert (many.n, many.done) == (one.n, one.done)
        assert many.buffer[0, many.ti] == one.buffer[0, one.ti] > 0.0
    detection = [e for e in by_chunk if e["event"] == "detection"]
    assert detection == [e for e in by_block if e["event"] == "detection"]
    assert detection[0]["t"] == 31.98 and detection[0]["coherence"] == [0, 1, 0]
    one.stop(now=True)
    many.stop(now=True)
