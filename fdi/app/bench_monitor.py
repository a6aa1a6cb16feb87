"""``bgfdi bench monitor``: the streaming monitor on hours of CyCab data at 100 Hz, against its floor.

The data: ``hours`` of the CyCab rig at 100 Hz from the independent reference plant
(:mod:`fdi.app.plant_cycab`), nominal until an internal leakage (R4 = 2.5221e7, abrupt) 30 s
before the end, written once to a temporary CSV file (the simulation's own seconds are reported
apart). The monitor: the path ``bgfdi monitor MODEL FILE`` takes, in process: the file read a
megabyte at a time and parsed in C (:mod:`fdi.chunks`), fed as blocks of ``block`` rows
(:meth:`fdi.stream.Stream.feed`), residuals from carried filter state (:mod:`fdi.carry`), the
persistence rule, the detection and the first decision handed to the worker process (its seconds
are the identification's, not the stream's: reported apart, and the stream's CPU time does not
count them). The summary at the end of the stream (a diagnosis of the whole record) is left out.

Measured in the same run, each the least CPU time (``time.process_time``) of ``repeat`` runs:

- **monitor**: the stream over the whole file;
- **per block**: the same rows fed 50 at a time through the line reader of live sources
  (:func:`fdi.data.blocks`): what a live producer at its own pace costs;
- **a pipe**: ``cat FILE | bgfdi monitor M -``, a producer ahead of the monitor: the line reader's
  blocks joined while more are waiting (:func:`fdi.chunks.gathered`; a live stream, so the
  identification runs beside it);
- **floor**: what cannot be avoided, done once over the hour: the file parsed in one call (by
  pyarrow when installed, else numpy), the filters and residual kernels over the whole record in
  one call, the persistence rule over it (:func:`floor_once`).

Memory: the resident set size (``/proc/self/statm``) when the stream reaches 10 min, 1 h and 4 h
(as far as the data go) and its last nominal minute, with ``--history 60`` (the stream keeps 60 s
before a detection) and the default hour: the buffer grows to two histories of rows (shifted once
as many as it keeps have aged out), then stays.
"""
from __future__ import annotations

import io
import os
import shutil
import tempfile
import time
from pathlib import Path
from typing import Callable

import numpy as np

BLOCK = 50                      # rows per block: bgfdi monitor's default --block
CHECKPOINTS = (600.0, 3600.0, 14400.0)      # s of stream at which the resident memory is read
MEMORY_HISTORIES = (60.0, 3600.0)           # --history of the memory runs (s)
COLUMNS = ("t", "u_in", "theta1", "theta2", "p1", "p2")


def rss_mb() -> float:
    """The process's resident set size in MB (Linux ``/proc``; elsewhere the peak, from getrusage)."""
    try:
        with open("/proc/self/statm", encoding="ascii") as fh:
            return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 1e6
    except (OSError, ValueError, IndexError, AttributeError):
        import resource
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3


def write_data(path: Path, hours: float, seed: int = 11) -> float:
    """``hours`` of the reference plant at 100 Hz, a leak 30 s before the end, as CSV; CPU seconds."""
    from bondgraph.loader import load_model

    from .plant_cycab import run_scenario
    from .resources import shipped_model
    from .scenario import parse_scenario

    t0 = time.process_time()
    T = 3600.0 * hours
    model = load_model(shipped_model("cycab_steering"))
    scenario = parse_scenario({"seed": seed, "T": T, "fs": 100, "theta2_0": -0.15, "faults": [
        {"target": "R4", "type": "abrupt", "t0": T - 30.0, "value": 2.5221e7}]}, model)
    cols = run_scenario(scenario)
    table = np.column_stack([cols[c] for c in COLUMNS])
    del cols
    np.savetxt(path, table, delimiter=",", header=",".join(COLUMNS), comments="", fmt="%.10g")
    return time.process_time() - t0


def stream_once(path: Path, block: int = BLOCK, history: float = 3600.0, reader: str = "chunks",
                memory: Callable[[float], None] | None = None, parser: str = "auto") -> tuple[float, list[dict]]:
    """The monitor over the file: CPU seconds of the stream (reading, parsing, residuals,
    detection; not the identification in the worker, nor the summary) and its events.
    ``memory(t)`` is called after each fed table with the stream time reached."""
    from ..chunks import chunks, gathered
    from ..data import blocks, open_text
    from ..monitor import compiled
    from ..options import Options
    from .resources import shipped_model

    events: list[dict] = []
    monitor = compiled(str(shipped_model("cycab_steering"))).stream(events.append, Options(workers=1),
                                                                     source=str(path), history=history,
                                                                     live=reader == "pipe")
    def read(fh, source, rows):
        if reader == "chunks":
            return chunks(fh, source, rows, parser=parser)
        if reader == "pipe":
            return gathered(blocks(fh, source, rows), fh)
        return blocks(fh, source, rows)
    if reader == "pipe":                         # a producer ahead of the monitor: cat FILE | bgfdi monitor M -
        import subprocess
        producer = subprocess.Popen(["cat", str(path)], stdout=subprocess.PIPE)
        opened = io.TextIOWrapper(producer.stdout, encoding="utf-8", newline="")
    else:
        producer, opened = None, open_text(path)
    try:
        with opened as fh:
            t0 = time.process_time()
            for header, table in read(fh, str(path), block):
                monitor.feed(header, table, rows=block)
                if memory is not None:
                    memory(float(table[-1, 0]))
            seconds = time.process_time() - t0
    finally:
        monitor.stop(now=True)
        if producer is not None:
            producer.wait()
    return seconds, events


def memory_run(path: Path, block: int, history: float, marks: list[float]) -> dict[str, float]:
    """The resident MB when the stream reaches each of ``marks`` (s), in a process of its own (this
    one holds the simulated data and the earlier runs' memory): ``{"10 min": MB, ...}``."""
    import json
    import subprocess
    import sys

    code = ("import json, sys; from pathlib import Path; from fdi.app.bench_monitor import memory_marks; "
            "print(json.dumps(memory_marks(Path(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3]), "
            "[float(m) for m in sys.argv[4:]])))")
    out = subprocess.run([sys.executable, "-c", code, str(path), str(block), repr(history), *map(repr, marks)],
                         check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def memory_marks(path: Path, block: int, history: float, marks: list[float]) -> dict[str, float]:
    """The stream over the file (as :func:`stream_once`), the resident MB read at each mark:
    before the first table, then as the stream time passes each of ``marks``."""
    seen: dict[str, float] = {}

    def memory(t: float) -> None:
        for mark in marks:
            key = f"{mark / 60:g} min"
            if t >= mark and key not in seen:
                seen[key] = rss_mb()
    stream_once(path, block, history=history, memory=memory)
    return seen


def floor_once(path: Path) -> dict:
    """The floor's parts, CPU seconds, each done once over the whole record with the fastest path
    bgfdi has: the file parsed in one call (pyarrow's reader when installed, else numpy's), the
    filters and residual kernels over all of it in one call (:class:`fdi.carry.Carried`, the
    edges left out), the persistence rule over it (:func:`fdi.detect.alarms`)."""
    from ..carry import Carried
    from ..chunks import arrow_available
    from ..detect import alarms, settling, thresholds_for
    from ..monitor import compiled
    from ..scales import detection_rule
    from .resources import shipped_model

    c = compiled(str(shipped_model("cycab_steering")))
    window = c.config.derivative_window
    t0 = time.process_time()
    if arrow_available():
        import pyarrow.csv as pc
        frame = pc.read_csv(path, read_options=pc.ReadOptions(use_threads=False))
        table = np.column_stack([frame.column(h).to_numpy() for h in COLUMNS])
        del frame
    else:
        text = path.read_text(encoding="ascii")
        body = text[text.index("\n") + 1:]
        table = np.fromstring(body.replace("\n", ","), dtype=float, sep=",").reshape(-1, len(COLUMNS))
        del text, body
    t1 = time.process_time()
    ts = float(table[1, 0] - table[0, 0])
    carried = Carried(c.model, list(c.residuals), window, list(COLUMNS))
    half = carried.behind(ts)
    r = carried(table, ts, half, table.shape[0] - half)
    t2 = time.process_time()
    persistence, span = detection_rule(window, c.config.waiting_time, c.config.persistence)
    alarms(r, table[half:-half, 0], thresholds_for(c.config.thresholds, list(c.names)), settling(None, window / 2),
           0.0, persistence, span)
    t3 = time.process_time()
    return {"parser": "pyarrow" if arrow_available() else "numpy", "parse_s": t1 - t0, "residuals_s": t2 - t1,
            "detect_s": t3 - t2, "total_s": t3 - t0}


def monitor_rows(hours: float = 1.0, block: int = BLOCK, repeat: int = 3, echo: Callable[[str], None] | None = None,
                 folder: str | None = None) -> dict:
    """Every measurement of ``bench monitor``, in one run (module doc)."""
    from ..chunks import arrow_available

    say = echo or (lambda line: None)
    with tempfile.TemporaryDirectory(dir=folder) as tmp:
        path = Path(tmp) / "cycab_stream.csv"
        say(f"simulating {hours:g} h of the CyCab rig at 100 Hz (reference plant) ...")
        sim_s = write_data(path, hours)
        samples = int(round(hours * 3600 * 100)) + 1
        runs, events = [], []
        for _ in range(repeat):
            seconds, events = stream_once(path, block)
            runs.append(seconds)
        numpy_s = min(stream_once(path, block, parser="numpy")[0] for _ in range(repeat)) if arrow_available() else None
        say("the same rows 50 at a time through the line reader, and through a pipe ...")
        per_block = min(stream_once(path, BLOCK, reader="blocks")[0] for _ in range(1 if hours > 1 else min(2, repeat)))
        pipe = min(stream_once(path, block, reader="pipe")[0] for _ in range(repeat)) if shutil.which("cat") else None
        floors = [floor_once(path) for _ in range(repeat)]
        floor = min(floors, key=lambda f: f["total_s"])
        marks = [m for m in CHECKPOINTS if m < hours * 3600 - 60] + [hours * 3600 - 60]    # the last: nominal still
        start = rss_mb()
        rss = {f"{history:g}": memory_run(path, block, history, marks) for history in MEMORY_HISTORIES}
        file_mb = path.stat().st_size / 1e6
    best = min(runs)
    real = hours * 3600.0
    detection = next((e for e in events if e["event"] == "detection"), None)
    decision = next((e for e in events if e["event"] == "decision"), None)
    return {"hours": hours, "samples": samples, "block": block, "file_mb": file_mb, "simulation_s": sim_s,
            "parser": "pyarrow" if arrow_available() else "numpy", "monitor_s": best, "runs_s": runs,
            "monitor_numpy_s": numpy_s, "x_real_time": real / best, "us_per_sample": 1e6 * best / samples,
            "per_block_s": per_block, "per_block_x_real_time": real / per_block, "pipe_s": pipe,
            "floor": floor, "floor_x_real_time": real / floor["total_s"], "over_floor": best / floor["total_s"],
            "detection": None if detection is None else {"t": detection["t"], "known_at": detection["known_at"]},
            "identification_s": None if decision is None else decision.get("identification_s"),
            "rss_start_mb": start, "rss_mb": rss}


def format_monitor(row: dict) -> str:
    f = row["floor"]
    out = [f"Streaming monitor: {row['hours']:g} h of CyCab data at 100 Hz ({row['samples']:,} samples, "
           f"{row['file_mb']:.0f} MB CSV; a leak 30 s before the end), blocks of {row['block']} rows; "
           f"CPU s, least of the runs",
           f"{'':<34}{'s':>8}{'x real time':>14}{'us/sample':>11}",
           f"{'monitor (chunks, ' + row['parser'] + ')':<34}{row['monitor_s']:>8.3f}{row['x_real_time']:>14,.0f}"
           f"{row['us_per_sample']:>11.2f}",
           *([f"{'monitor (chunks, numpy)':<34}{row['monitor_numpy_s']:>8.3f}"
              f"{row['hours'] * 3600 / row['monitor_numpy_s']:>14,.0f}{1e6 * row['monitor_numpy_s'] / row['samples']:>11.2f}"]
             if row["monitor_numpy_s"] else []),
           f"{'50 rows at a time (live reader)':<34}{row['per_block_s']:>8.3f}{row['per_block_x_real_time']:>14,.0f}"
           f"{1e6 * row['per_block_s'] / row['samples']:>11.2f}",
           *([f"{'a pipe (cat FILE |), rows gathered':<34}{row['pipe_s']:>8.3f}{row['hours'] * 3600 / row['pipe_s']:>14,.0f}"
              f"{1e6 * row['pipe_s'] / row['samples']:>11.2f}"] if row["pipe_s"] else []),
           f"{'floor (one pass of each)':<34}{f['total_s']:>8.3f}{row['floor_x_real_time']:>14,.0f}"
           f"{1e6 * f['total_s'] / row['samples']:>11.2f}",
           f"  floor: parse {f['parse_s']:.3f} s ({f['parser']}), filters and residual kernels {f['residuals_s']:.3f} s, "
           f"persistence rule {f['detect_s']:.3f} s; the monitor is {row['over_floor']:.2f}x its floor",
           f"target: <= 0.4 s per hour (>= 9,000x real time): "
           + ("met" if row["monitor_s"] <= 0.4 * row["hours"] else "not met")]
    if row["detection"]:
        out.append(f"detection at t = {row['detection']['t']:g} s (known at {row['detection']['known_at']:g} s); "
                   f"identification in the worker: {row['identification_s'] or 0:.2f} s wall (not counted)")
    for history, seen in row["rss_mb"].items():
        marks = ", ".join(f"{k}: {v:.1f}" for k, v in seen.items())
        out.append(f"resident memory (MB), --history {history}: {marks}")
    out.append(f"(simulating the data took {row['simulation_s']:.1f} s CPU, not counted)")
    return "\n".join(out) + "\n"


def monitor_json(row: dict) -> dict:
    """``bench monitor --json``."""
    return {"benchmark": "monitor", **row}
