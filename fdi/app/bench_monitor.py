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
  (:func:`fdi.data.blocks`): what a pipe costs;
- **floor**: what cannot be avoided, done once over the hour: the file's text read and parsed
  by numpy in one call, the residual kernels over the whole record (:func:`fdi.residuals.evaluate`),
  and the persistence rule over it (:func:`fdi.detect.alarms`).

Memory: the resident set size (``/proc/self/statm``) when the stream reaches 10 min, 1 h and 4 h
(as far as the data go), with ``--history 60`` (the stream keeps 60 s before a detection); with
the default hour of history the buffer grows to two hours of rows (shifted once as many as it
keeps have aged out), then stays.
"""
from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path
from typing import Callable

import numpy as np

BLOCK = 50                      # rows per block: bgfdi monitor's default --block
CHECKPOINTS = (600.0, 3600.0, 14400.0)      # s of stream at which the resident memory is read
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
                memory: Callable[[float], None] | None = None) -> tuple[float, list[dict]]:
    """The monitor over the file: CPU seconds of the stream (reading, parsing, residuals,
    detection; not the identification in the worker, nor the summary) and its events.
    ``memory(t)`` is called after each fed table with the stream time reached."""
    from ..chunks import chunks
    from ..data import blocks, open_text
    from ..monitor import compiled
    from ..options import Options
    from .resources import shipped_model

    events: list[dict] = []
    monitor = compiled(str(shipped_model("cycab_steering"))).stream(events.append, Options(workers=1),
                                                                     source=str(path), history=history, live=False)
    read = chunks if reader == "chunks" else blocks
    try:
        with open_text(path) as fh:
            t0 = time.process_time()
            for header, table in read(fh, str(path), block):
                monitor.feed(header, table, rows=block)
                if memory is not None:
                    memory(float(table[-1, 0]))
            seconds = time.process_time() - t0
    finally:
        monitor.stop(now=True)
    return seconds, events


def floor_once(path: Path) -> dict:
    """The floor's parts, CPU seconds: numpy parsing the whole text in one call, the residual
    kernels over the whole record, the persistence rule over it."""
    from ..data import Measurements, signals_from_data
    from ..detect import alarms, settling, thresholds_for
    from ..scales import detection_rule
    from ..monitor import compiled
    from ..residuals import evaluate
    from .resources import shipped_model

    c = compiled(str(shipped_model("cycab_steering")))
    t0 = time.process_time()
    text = path.read_text(encoding="ascii")
    body = text[text.index("\n") + 1:]
    table = np.fromstring(body.replace("\n", ","), dtype=float, sep=",").reshape(-1, len(COLUMNS))
    del text, body
    t1 = time.process_time()
    m = Measurements(str(path), table[:, 0], {h: np.ascontiguousarray(table[:, i]) for i, h in enumerate(COLUMNS)})
    r = evaluate(c.model, list(c.residuals), signals_from_data(c.model, m), m.ts, window=c.config.derivative_window)
    t2 = time.process_time()
    window = c.config.derivative_window
    persistence, span = detection_rule(window, c.config.waiting_time, c.config.persistence)
    alarms(r, m.t, thresholds_for(c.config.thresholds, list(c.names)), settling(None, window / 2), 0.0,
           persistence, span)
    t3 = time.process_time()
    return {"parse_s": t1 - t0, "residuals_s": t2 - t1, "detect_s": t3 - t2, "total_s": t3 - t0}


def monitor_rows(hours: float = 1.0, block: int = BLOCK, repeat: int = 3, echo: Callable[[str], None] | None = None,
                 folder: str | None = None) -> dict:
    """Every measurement of ``bench monitor``, in one run (module doc)."""
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
        say("the same rows 50 at a time through the line reader ...")
        per_block = min(stream_once(path, BLOCK, reader="blocks")[0] for _ in range(1 if hours > 1 else min(2, repeat)))
        floors = [floor_once(path) for _ in range(repeat)]
        floor = min(floors, key=lambda f: f["total_s"])
        rss: dict[str, float] = {}
        start = rss_mb()

        def memory(t: float) -> None:
            for mark in CHECKPOINTS:
                key = f"{mark / 60:g} min"
                if t >= mark and key not in rss:
                    rss[key] = rss_mb()
        stream_once(path, block, history=60.0, memory=memory)
        file_mb = path.stat().st_size / 1e6
    best = min(runs)
    real = hours * 3600.0
    detection = next((e for e in events if e["event"] == "detection"), None)
    decision = next((e for e in events if e["event"] == "decision"), None)
    return {"hours": hours, "samples": samples, "block": block, "file_mb": file_mb, "simulation_s": sim_s,
            "monitor_s": best, "runs_s": runs, "x_real_time": real / best, "us_per_sample": 1e6 * best / samples,
            "per_block_s": per_block, "per_block_x_real_time": real / per_block,
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
           f"{'monitor (chunks parsed in C)':<34}{row['monitor_s']:>8.3f}{row['x_real_time']:>14,.0f}"
           f"{row['us_per_sample']:>11.2f}",
           f"{'50 rows at a time (live reader)':<34}{row['per_block_s']:>8.3f}{row['per_block_x_real_time']:>14,.0f}"
           f"{1e6 * row['per_block_s'] / row['samples']:>11.2f}",
           f"{'floor (one pass, numpy)':<34}{f['total_s']:>8.3f}{row['floor_x_real_time']:>14,.0f}"
           f"{1e6 * f['total_s'] / row['samples']:>11.2f}",
           f"  floor: parse {f['parse_s']:.3f} s, residual kernels {f['residuals_s']:.3f} s, "
           f"persistence rule {f['detect_s']:.3f} s; the monitor is {row['over_floor']:.2f}x its floor",
           f"target: <= 0.4 s per hour (>= 9,000x real time): "
           + ("met" if row["monitor_s"] <= 0.4 * row["hours"] else "not met")]
    if row["detection"]:
        out.append(f"detection at t = {row['detection']['t']:g} s (known at {row['detection']['known_at']:g} s); "
                   f"identification in the worker: {row['identification_s'] or 0:.2f} s wall (not counted)")
    marks = ", ".join(f"{k}: {v:.1f}" for k, v in row["rss_mb"].items())
    out.append(f"resident memory with --history 60 (MB): start {row['rss_start_mb']:.1f}; {marks}")
    out.append(f"(simulating the data took {row['simulation_s']:.1f} s CPU, not counted)")
    return "\n".join(out) + "\n"


def monitor_json(row: dict) -> dict:
    """``bench monitor --json``."""
    return {"benchmark": "monitor", **row}
