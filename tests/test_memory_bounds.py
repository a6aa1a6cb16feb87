"""Bounded memory on long records (issue 23): a measurement file is read straight into one array
per column, the residuals of one long record are evaluated with their derivatives a block at a
time, and detection's evidence and moving sums hold a row or two, never (residuals x samples)
several times. Each test checks the numbers against a reference built apart (values written by
numpy, sums taken by a plain loop, the two-tank ARR by hand) and the memory with tracemalloc."""
from __future__ import annotations

import gzip
import os
import threading
import time
import tracemalloc

import numpy as np
import pytest

from fdi import detect
from fdi.data import read_csv

from .conftest import MODELS


def _table(rows: int, seed: int = 0) -> dict[str, np.ndarray]:
    """t on a 1 ms grid and three columns of random numbers (written with 17 digits: read back exactly)."""
    rng = np.random.default_rng(seed)
    return {"t": np.arange(rows) * 1e-3, "a": rng.normal(size=rows), "b": rng.uniform(-1e5, 1e5, rows),
            "c": np.round(rng.normal(size=rows), 3)}


def _text(cols: dict[str, np.ndarray], sep: str = ",", end: str = "\n") -> str:
    body = np.column_stack(list(cols.values()))
    lines = [sep.join(cols)] + [sep.join(f"{v:.17g}" for v in row) for row in body]
    return end.join(lines) + end


@pytest.mark.parametrize("kind", ["lf", "crlf", "cr", "gzip", "utf16", "semicolon"])
def test_a_file_is_read_into_the_numbers_written(tmp_path, kind):
    """Every line-end convention, gzip, UTF-16 and semicolons: the columns are the numbers numpy
    wrote, bit for bit (the array is sized from the file's line ends, which each form counts
    differently: CR LF once, UTF-16's 0x0A 0x00 as one end)."""
    cols = _table(20_000, seed=len(kind))
    path = tmp_path / "run.csv"
    end = {"crlf": "\r\n", "cr": "\r"}.get(kind, "\n")
    text = _text(cols, ";" if kind == "semicolon" else ",", end)
    if kind == "semicolon":
        text = text.replace(".", ",")
    if kind == "gzip":
        path.write_bytes(gzip.compress(text.encode("ascii")))
    elif kind == "utf16":
        path.write_bytes(text.encode("utf-16"))
    else:
        path.write_bytes(text.encode("ascii"))
    data = read_csv(path)
    assert list(data.columns) == list(cols)
    for name, values in cols.items():
        assert np.array_equal(data.columns[name], values), name
        assert data.columns[name].flags.c_contiguous


def test_a_pipe_of_unknown_length_is_read_whole(tmp_path):
    """A FIFO (process substitution's kind: no length to size the array from) delivering 100 000
    rows, more than the first allocation of 32 768: grown as it comes, every number kept."""
    if not hasattr(os, "mkfifo"):
        pytest.skip("no FIFOs here")
    cols = _table(100_000, seed=7)
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    text = _text(cols).encode("ascii")

    def write() -> None:
        with open(fifo, "wb") as fh:
            fh.write(text)
    writer = threading.Thread(target=write, daemon=True)
    writer.start()
    time.sleep(0.3)             # the writer waits in open(): started first, as <(command) is (fdi.inputs)
    data = read_csv(fifo)
    writer.join(10)
    for name, values in cols.items():
        assert np.array_equal(data.columns[name], values), name


@pytest.mark.slow
def test_reading_holds_the_numbers_once(tmp_path):
    """300 000 rows x 4 (9.2 MiB of numbers): reading allocates the table once (1.0x) and a block of
    text, where stacking blocks after the read held the numbers twice (measured: 2.3x)."""
    cols = _table(300_000, seed=3)
    path = tmp_path / "long.csv"
    path.write_text(_text(cols), encoding="ascii")
    numbers = 300_000 * 4 * 8
    tracemalloc.start()
    try:
        data = read_csv(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert np.array_equal(data.columns["b"], cols["b"])
    assert peak < 1.6 * numbers, peak / numbers


def test_long_record_residuals_hold_one_block_of_derivatives(monkeypatch):
    """The two-tank ARR1 = Qin - (A1/(rho g)) dp1/dt - (p1 - p2)/R12 (docs: the model file's own
    derivation) on 400 000 samples, p1 rising at 2 Pa/s: the hand value at every sample the filter
    sees whole, the same array as evaluating the whole record's derivatives at once (to round-off:
    a matrix product over a block of windows need not sum in the same order on every CPU),
    and beyond the result (3 x 400 000 values) at most 6 MiB, where the whole record's derivatives
    took 17 MiB more (p1 and p2 with their rates, Qin smoothed)."""
    from fdi import residuals as R
    from fdi.data import checked, signals_from_data
    from fdi.monitor import Monitor
    m = Monitor(MODELS / "two_tank_valve.yaml")
    n = 400_000
    t = np.arange(n) * 0.1
    rng = np.random.default_rng(11)
    cols = {"t": t, "Qin": np.full(n, 1e-4), "p1": 5000 + 2.0 * t, "p2": np.full(n, 1000.0)}
    noisy = dict(cols, p2=1000.0 + rng.normal(size=n))
    for table, hand in ((cols, True), (noisy, False)):
        raw = signals_from_data(m.model, checked("x", list(table), np.column_stack(list(table.values()))))
        # once untraced first: a process's first long filter loads the compiled kernels (numba's
        # import and cache: 17-34 MiB of Python objects, once per process, not per record)
        R.evaluate(m.model, list(m.residuals), raw, 0.1, window=5.0)
        tracemalloc.start()
        try:
            blocked = R.evaluate(m.model, list(m.residuals), raw, 0.1, window=5.0)
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert peak - blocked.nbytes < 6 << 20, (peak - blocked.nbytes) / 2 ** 20
        with monkeypatch.context() as patched:
            patched.setattr(R, "EVAL_BLOCK", 1 << 30)                 # the whole record at once
            whole = R.evaluate(m.model, list(m.residuals), raw, 0.1, window=5.0)
        assert np.allclose(whole, blocked, rtol=1e-12, atol=1e-12 * np.abs(whole).max())   # round-off only
        if hand:
            arr1 = 1e-4 - 0.0154 / (1000 * 9.81) * 2.0 - (cols["p1"] - 1000.0) / 1.0e7
            i = m.names.index("ARR1")
            assert np.allclose(blocked[i][25:-25], arr1[25:-25], rtol=1e-9, atol=1e-15)


def test_moving_sums_and_evidence_are_the_plain_loop_s(monkeypatch):
    """The sum over the last n samples, with and without the samples before a block, subtracted
    in place in blocks of 7 columns: equal to a plain loop's sums of the same numbers taken in the
    same order (cumulative sums) for n below, at and above the block; the evidence is t_s |r|/eps
    where |r| > eps on a kept sample, 0 elsewhere (NaN and inf residuals included)."""
    monkeypatch.setattr(detect, "SUM_BLOCK", 7)
    rng = np.random.default_rng(2)
    x = rng.uniform(0, 1, (2, 40))
    head = rng.uniform(0, 1, (2, 12))
    for n in (1, 3, 7, 12, 13, 60):
        for before in (None, head):
            full = x if before is None else np.hstack([before, x])
            c = np.cumsum(full, axis=1)
            first = full.shape[1] - x.shape[1]
            expected = np.array([[c[i, j] - (c[i, j - n] if j - n >= 0 else 0.0) for j in range(first, full.shape[1])]
                                 for i in range(2)])
            assert np.array_equal(detect.moving_sum(x, n, before), expected), (n, before is None)
    r = np.array([[0.5, -2.0, np.nan, np.inf, 3.0, -0.1]])
    keep = np.array([True, True, True, True, False, True])
    z = detect.evidence(r, np.array([1.0]), 0.01, keep)
    assert np.array_equal(z, np.array([[0.0, 0.02, 0.0, 0.0, 0.0, 0.0]]))


def test_detection_holds_a_row_or_two_not_residuals_times_samples():
    """Three residuals of 600 000 samples (about a minute at 10 kHz; 13.7 MiB): the alarms take at most
    three rows' worth (one row: 4.6 MiB) beyond them, where the earlier evidence and moving sum
    took seven; the alarm is where the designed excursion (2 x the threshold from sample 300 000)
    has gathered the persistence, 0.25 threshold-seconds."""
    n = 600_000
    ts = 2.0 ** -13                          # 0.12 ms: evidence 2 ts per sample and its sums exact in binary
    t = np.arange(n) * ts
    r = np.zeros((3, n))
    r[1, 300_000:] = 2.0
    tracemalloc.start()
    try:
        a = detect.alarms(r, t, np.ones(3), persistence=0.25, span=1.0)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 3 * n * 8, peak / (n * 8)
    # evidence 2 ts = 2^-12 per sample: the sum passes 0.25 at the 1025th sample above (1024 give exactly 0.25)
    assert a.at.tolist() == [-1, 300_000 + 1024, -1] and a.start.tolist() == [-1, 300_000, -1]


@pytest.mark.slow
def test_a_long_simulation_holds_its_output_and_a_chunk(monkeypatch):
    """The DC motor's step response (L di/dt = u - R i - K w, J dw/dt = K i - (bm + bL) w, u = 1 V
    from rest: the matrix exponential's solution, computed here) on 12 001 output points, laid
    out and tabulated 1 000 points at a time: within 1e-4 of the exact solution, and each output
    point adds to the peak memory less than 2.5 times what it adds to the output (one number per
    signal and state), where tabulating every point at once held Python lists of each point's
    parameters and states (measured: 14 times). The peak of a run of 3 001 points is the base."""
    import scipy.linalg

    from bondgraph import simulation
    from bondgraph.loader import load_model
    monkeypatch.setattr(simulation, "ROS2_CHUNK", 1000)
    monkeypatch.setattr(simulation, "OUTPUT_BLOCK", 1000)
    model = load_model(MODELS / "dc_motor_clutch.yaml")
    p = {k: v.value for k, v in model.parameters.items()}
    values = {s.name: v for s, v in model.nominal_values().items()}
    simulation.simulate(model, np.linspace(0, 0.06, 3_001), values=lambda tt: values, method="ros2")   # warm
    runs = []
    for n in (3_001, 12_001):
        t = np.linspace(0, 0.6 * (n - 1) / 30_000, n)
        tracemalloc.start()
        try:
            traj = simulation.simulate(model, t, values=lambda tt: values, method="ros2")
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        runs.append((peak, traj.t.nbytes + sum(v.nbytes for v in (*traj.signals.values(), *traj.states.values()))))
    (short, short_out), (long, long_out) = runs
    assert long - short < 2.5 * (long_out - short_out), (long - short) / (long_out - short_out)
    A = np.array([[-p["Ra"] / p["La"], -p["K"] / p["La"]], [p["K"] / p["Jm"], -(p["bm"] + p["bL"]) / p["Jm"]]])
    B = np.array([1 / p["La"], 0.0])
    exact = np.array([np.linalg.solve(A, (scipy.linalg.expm(A * tt) - np.eye(2)) @ B) for tt in t[::100]])
    assert np.allclose(traj.signals["i"][::100], exact[:, 0], rtol=1e-4, atol=1e-6)
    assert np.allclose(traj.signals["w"][::100], exact[:, 1], rtol=1e-4, atol=1e-7)
