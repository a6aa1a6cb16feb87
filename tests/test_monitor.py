"""The monitor (issue 10): a stream gives the residuals, events and final diagnosis of the file."""
from __future__ import annotations

import io
import json
import multiprocessing
import time

import numpy as np
import pytest

from fdi.app.cli import main
from fdi.data import read_csv, signals_from_data
from fdi.options import Options
from fdi.monitor import compiled
from fdi.residuals import evaluate

from .conftest import CYCAB, DATA


def _table(name: str):
    m = read_csv(DATA / f"{name}.csv")
    header = list(m.columns)
    return m, header, np.column_stack([m.columns[h] for h in header])


def test_streamed_residuals_equal_those_of_the_whole_file():
    # the Savitzky-Golay filter is local: computed on each block with a margin of one window, the
    # residuals equal the whole file's wherever the window is complete (all but the last lag)
    m, header, table = _table("scenario2")
    mon = compiled(CYCAB).stream(lambda e: None, Options(workers=1))
    pieces, done = [], 0
    for a in range(0, 2000, 37):                     # 20 s in uneven blocks, before the detection
        mon.feed(header, table[a:a + 37])
        if mon.done > done:
            pieces.append(mon.residuals)
            done = mon.done
    streamed = np.concatenate(pieces, axis=1)
    c = compiled(str(CYCAB))
    model = c.model
    whole = evaluate(model, list(c.residuals), signals_from_data(model, m), m.ts, window=c.config.derivative_window)
    assert streamed.shape[1] == mon.done >= 2000 - 20
    np.testing.assert_allclose(streamed[:, 50:], whole[:, 50:mon.done], rtol=1e-9, atol=1e-12)


def test_events_of_scenario1_in_stream_time():
    _, header, table = _table("scenario1")
    events: list[dict] = []
    mon = compiled(CYCAB).stream(events.append, Options(workers=1))
    for a in range(0, table.shape[0], 100):
        mon.feed(header, table[a:a + 100])
    mon.close()
    kinds = [e["event"] for e in events]
    assert kinds[0] == "start" and kinds[-1] == "summary" and "detection" in kinds and "decision" in kinds
    detection = events[kinds.index("detection")]
    decision = events[kinds.index("decision")]
    summary = events[-1]                             # the diagnosis of the whole file
    assert detection["t"] == summary["detection"]["time"] == 31.88
    assert detection["known_at"] >= detection["t"] + events[0]["lag_s"]
    # decided once the waiting time has passed and N = 1000 samples (10 s) have arrived
    assert decision["t"] == summary["detection"]["decision_time"] and decision["known_at"] >= 31.88 + 10
    assert {f["name"] for f in decision["faults"]} == {"R4", "beta_theta1"}


@pytest.mark.slow
def test_stdin_stream_ends_with_the_diagnosis_of_the_file(capsys, monkeypatch):
    path = str(DATA / "scenario2.csv")
    assert main(["diagnose", str(CYCAB), path, "--json", "--workers", "1"]) == 0
    batch = json.loads(capsys.readouterr().out)
    with open(path, encoding="utf-8") as fh:
        monkeypatch.setattr("sys.stdin", io.StringIO(fh.read()))
    assert main(["monitor", str(CYCAB), "-", "--workers", "1"]) == 0
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    summary = dict(lines[-1])
    assert summary.pop("event") == "summary"
    assert summary == batch
    prognoses = [e["prognosis"] for e in lines if e["event"] == "decision" and e.get("prognosis")]
    assert prognoses and prognoses[-1][0]["name"] == "beta_theta2"


def test_a_long_stream_keeps_a_bounded_history_and_still_detects():
    """Before a detection only ``history`` seconds are kept: the buffer stays bounded over a long
    nominal stream, the residuals stay those of the whole file, and a fault afterwards is detected
    at the time the whole file gives (scenario 2's R4 leak and encoder drift from 32 s)."""
    m, header, table = _table("scenario2")
    events: list[dict] = []
    mon = compiled(CYCAB).stream(events.append, Options(workers=1), history=5.0)
    sizes = []
    for a in range(0, 3300, 50):                     # up to 33 s, the detection at 31.98 s
        mon.feed(header, table[a:a + 50])
        sizes.append(mon.n)
    assert max(sizes[:60]) <= 2 * 500 + 50          # 5 s at 100 Hz kept, shifted at twice that
    assert mon.buffer[0, mon.ti] > 10.0             # the start of the stream was forgotten
    detection = next(e for e in events if e["event"] == "detection")
    whole = next(e for e in _events_of_whole(header, table[:3300]) if e["event"] == "detection")
    assert detection["t"] == whole["t"] and detection["coherence"] == whole["coherence"]


def test_a_bad_row_is_numbered_from_the_stream_start_after_rows_were_forgotten():
    """The stream named a NaN row by its place in the buffer: once the history had dropped the
    stream's first rows, "sample 1001" was the 1 501st. Designed: scenario 2 with 5 s of history,
    a NaN in the 1 501st row: sample 1501."""
    from fdi.data import DataError
    m, header, table = _table("scenario2")
    bad = table[:2000].copy()
    bad[1500, 1] = np.nan
    mon = compiled(CYCAB).stream(lambda e: None, Options(workers=1), history=5.0)
    with pytest.raises(DataError, match=r"at sample 1501 \(its 1501st data row, blank lines not counted\)"):
        for a in range(0, 2000, 50):
            mon.feed(header, bad[a:a + 50])
    assert mon.forgotten > 0


def test_the_default_history_is_a_number_of_samples_whatever_the_rate(monkeypatch):
    """Without ``history`` the stream keeps HISTORY_SAMPLES samples (360 000: an hour at 100 Hz,
    100 h at 1 Hz, 36 s at 10 kHz), where an hour in seconds held 1.7 GB at 10 kHz and 3 600
    samples at 1 Hz. Here 500 samples on scenario 2's stream: the buffer bounded as with
    ``history=5.0`` at its 100 Hz (the test above), the start forgotten; and the rule at any rate."""
    import fdi.stream
    monkeypatch.setattr(fdi.stream, "HISTORY_SAMPLES", 500)
    m, header, table = _table("scenario2")
    mon = compiled(CYCAB).stream(lambda e: None, Options(workers=1))
    sizes = []
    for a in range(0, 2500, 50):
        mon.feed(header, table[a:a + 50])
        sizes.append(mon.n)
    assert max(sizes) <= 2 * 500 + 50 and mon.buffer[0, mon.ti] > 10.0
    assert [mon._kept(ts) for ts in (1e-4, 0.01, 1.0)] == [500] * 3
    mon.history = 5.0
    assert [mon._kept(ts) for ts in (1e-4, 0.01, 1.0)] == [50_000, 500, 5]


def test_a_prognosis_is_refreshed_every_identification_window_by_default():
    """Without ``refresh`` a growing fault's prognosis is refitted every N ts of data (the CyCab's
    1 000 samples at 100 Hz: 10 s; where a fixed 5 s was a refit every 5 samples of a system
    sampled each second); with it, every ``refresh`` seconds."""
    m, header, table = _table("scenario2")
    for given, period in ((None, 10.0), (5.0, 5.0)):
        mon = compiled(CYCAB).stream(lambda e: None, Options(workers=1), refresh=given)
        mon.feed(header, table[:300])
        assert mon.samples == 1000 and mon._refresh_period() == pytest.approx(period, rel=1e-12)


def test_a_live_stream_that_ends_before_a_refresh_ran_refits_its_prognosis_at_the_end():
    """A trial's elevator record piped into `bgfdi monitor -` arrived faster than its first decision
    was identified: the stream ended with that decision's prognosis, fitted on one window after the
    detection, while 20 s of the drift had been read (a file replayed refreshed it 20 times). Now
    the end of a stream whose last fit is a refresh period older than its last sample refits it
    once more. Scenario 2 streamed live in one block: the last event before the summary is a
    prognosis at the last sample, whose EOL is the design's, beta = 1 / (1 + 0.03 (t - 32))
    reaching 0.5 at 32 + 1 / 0.03 = 65.33 s (README)."""
    m, header, table = _table("scenario2")
    events: list[dict] = []
    mon = compiled(CYCAB).stream(events.append, Options(workers=1), live=True, worker="thread")
    mon.feed(header, table)
    mon.close()
    kinds = [e["event"] for e in events]
    assert kinds[-2:] == ["prognosis", "summary"] and "decision" in kinds
    last = events[-2]
    assert last["t"] == pytest.approx(float(table[-1, header.index("t")]))
    (g,) = last["prognosis"]
    assert g["name"] == "beta_theta2" and g["eol"] == pytest.approx(32 + 1 / 0.03, rel=0.01)
    assert g["at"] == pytest.approx(last["t"])


def _events_of_whole(header, table):
    events: list[dict] = []
    mon = compiled(CYCAB).stream(events.append, Options(workers=1))
    mon.feed(header, table)
    return events


@pytest.mark.parametrize("block", [1, 50])
def test_a_stream_cut_mid_row_ends_with_its_summary(capsys, monkeypatch, block):
    """A producer killed while writing a row: the partial last row is dropped with one warning
    and the stream's summary still comes (the rows before it, a nominal run: nothing detected).
    A short row in the middle of a stream stays an error (exit 2), as in a file."""
    text = (DATA / "nominal.csv").read_text(encoding="utf-8")[:200000]
    assert not text.endswith("\n") and len(text.splitlines()[-1].split(",")) < 6      # cut inside a row
    monkeypatch.setattr("sys.stdin", io.StringIO(text))
    assert main(["monitor", str(CYCAB), "-", "--block", str(block)]) == 0
    captured = capsys.readouterr()
    lines = [json.loads(line) for line in captured.out.splitlines()]
    assert lines[-1]["event"] == "summary" and lines[-1]["detection"] is None
    assert "the last row was cut (2 of 6 values): dropped" in captured.err
    rows = text.splitlines()
    broken = "\n".join(rows[:1000] + [rows[1000][:12]] + rows[1001:3000]) + "\n"
    monkeypatch.setattr("sys.stdin", io.StringIO(broken))
    assert main(["monitor", str(CYCAB), "-", "--block", str(block)]) == 2
    assert "rows do not all have 6 values" in capsys.readouterr().err


# R4 leak and beta_theta2 at 15 s (the first decision: several candidate sets, seconds of
# identification), then beta_theta1 at 30 s: ARR1 joins while that identification runs
THREE_FAULTS = {"seed": 7, "T": 80, "fs": 100, "theta2_0": -0.15, "faults": [
    {"target": "R4", "type": "abrupt", "t0": 15, "value": 2.5e7},
    {"target": "beta_theta2", "type": "abrupt", "t0": 15.2, "value": 0.8},
    {"target": "beta_theta1", "type": "abrupt", "t0": 30, "value": 0.5}]}


def _paced(header, table, speed: float, start: float, block: int = 50, burst: float | None = None):
    """Blocks of rows as a live source gives them: the first ``start`` seconds at once, then at
    ``speed`` times real time (a sleep before each block until its last sample is due); the blocks
    up to ``burst`` s as fast as the monitor takes them (a source catching up)."""
    i0 = int(np.searchsorted(table[:, 0], start))
    yield table[:i0]
    wall, t_ref = time.perf_counter(), table[i0, 0]
    for a in range(i0, table.shape[0], block):
        rows = table[a:a + block]
        if burst is not None and rows[-1, 0] <= burst:
            yield rows
            wall, t_ref = time.perf_counter(), rows[-1, 0]
            continue
        wait = wall + (rows[-1, 0] - t_ref) / speed - time.perf_counter()
        if wait > 0:
            time.sleep(wait)
        yield rows


def test_the_monitor_keeps_reading_while_it_identifies(tmp_path):
    """Fed while the first decision is identified (in the worker), the stream's coherence event comes
    during that identification, and the decision follows with how long it took; the worker ends
    with the stream (no process left)."""
    from bondgraph.loader import load_model
    from fdi import kernels
    from fdi.app.scenario import load_scenario, run
    from optim import kernels as optim_kernels

    # the C kernels built before the stream starts (this test process's cache folder may be new):
    # building them takes 4 s on a slow host, which the worker otherwise spent inside the 6.6 s
    # the stream lasts, and the decision came after its end
    kernels.jit()
    optim_kernels.compiled("optim")                 # the engines' (optim/trials.c) likewise
    model = load_model(CYCAB)
    (tmp_path / "three.json").write_text(json.dumps(THREE_FAULTS), encoding="utf-8")
    columns = run(model, load_scenario(tmp_path / "three.json", model))
    header = list(columns)
    table = np.column_stack([columns[h] for h in header])
    stamped: list[tuple[float, dict]] = []
    mon = compiled(CYCAB).stream(lambda e: stamped.append((time.perf_counter(), e)), Options(workers=1))
    try:
        # the rows up to 31 s at once, then 10x real time: the coherence change at 30 s reaches the
        # monitor while the first decision is identified however fast that is (0.4 s once a process
        # has identified on these data before: another test in the same worker; 3.4 s the first time)
        for rows in _paced(header, table, speed=10.0, start=14.0, burst=31.0):
            mon.feed(header, rows)
            if any(e["event"] == "decision" for _, e in stamped):
                break
    finally:
        mon.stop(now=True)
    assert not multiprocessing.active_children()
    (ended, decision), = [(w, e) for w, e in stamped if e["event"] == "decision"]
    # read while the decision was pending: emitted before it, about data after it came due
    during = [e for w, e in stamped
              if w < ended and e["event"] != "decision" and e.get("known_at", -1.0) > decision["t"]]
    assert [e["event"] for e in during] == ["coherence"] and during[0]["coherence"] == [1, 1, 1]
    # stamped in stream time too: the coherence change was known before the decision was
    assert during[0]["known_at"] < decision["known_at"] and decision["coherence"] == [0, 1, 1]
    assert decision["identification_s"] > 0.0       # how long it took is reported (its speed is bench's)


def test_a_stream_decides_a_glitch_as_it_detected_it():
    """The stream's detection reads every sample as recorded (its filters carry state); its decisions
    and summary diagnosed the same samples with one-sample spikes repaired (fdi.spikes), so a glitch
    was announced and then never decided, the summary saying nothing was detected (the final review
    of session 33). Now the stream's diagnoses read the samples as recorded too. The record: the
    paper's nominal run with a designed 0.5 rad miscount of the motor encoder at 20 s."""
    m, header, table = _table("nominal")
    table = table.copy()
    i = int(np.argmin(np.abs(m.t - 20.0)))
    table[i, header.index("theta1")] += 0.5
    events: list[dict] = []
    mon = compiled(CYCAB).stream(events.append, Options(workers=1, pop=12, generations=5))
    mon.feed(header, table)
    mon.close()
    kinds = [e["event"] for e in events]
    assert "detection" in kinds and kinds[-1] == "summary"
    detected = next(e for e in events if e["event"] == "detection")
    summary = events[-1]
    assert summary["detection"] is not None and summary["detection"]["time"] == pytest.approx(detected["t"])
    assert "1 one-sample spike(s) read as recorded: theta1 at 20 s" in summary["note"]
