"""``bgfdi bench fleet``: one fleet through ``--jobs 1``, ``--jobs N`` and a dask LocalCluster of N
workers, in the same run; then a fleet of many short files in files per second.

The fleet: the four CyCab reference files (``models/data/cycab``) copied ``copies`` times into a
temporary directory (8 files by default), diagnosed at a small population (``pop`` 12,
``generations`` 5: the fleet's machinery, not the search, is measured; the search is
``bench diagnose``'s). The short fleet: ``short`` copies of the first 3 s of the nominal file
(nothing detected: the cost is reading, shipping and the detector, per file).

The ways run in turn three times and each keeps its least wall time (this machine's speed drifts
by tens of percent within minutes: one run of each compared the drift, not the ways). Each way is
timed as the command runs it: the pool or the LocalCluster is started inside the
timing (``bgfdi diagnose --scheduler local`` starts one per call); the cluster's start (dask's
import included) and its close are also reported apart, and the ratio on a running cluster (a
``--scheduler`` address: neither started nor closed by the command) without them. CPU time is
this process's and its reaped children's (``resource.getrusage``: the pool's processes and the
cluster's workers, closed before it is read); wall time by
``time.perf_counter``. Each way starts without the answers an earlier one kept by content
(:func:`fdi.hints.forget`): a pool forked from this process would inherit them, which a new
``bgfdi diagnose --jobs N`` process does not (it made ``--jobs 2`` look 17 % faster at the
paper's settings). Each way's reports are compared with ``--jobs 1``'s (the same lines, or
the bench says not). Ratios are of numbers measured in this run.
"""
from __future__ import annotations

import resource
import shutil
import statistics
import tempfile
import time
from pathlib import Path
from typing import Callable

from .fleet import Cluster, diagnose_many, have_dask

REFERENCE = ("nominal", "scenario1", "scenario2", "scenario3")
SHORT_ROWS = 300                 # 3 s at 100 Hz


def _cpu() -> float:
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def _ways(workers: int) -> list[tuple[str, int, bool]]:
    ways = [("--jobs 1", 1, False), (f"--jobs {workers}", workers, False)]
    if have_dask():
        ways.append((f"LocalCluster({workers})", workers, True))
    return ways


def run_ways(model: str, files: list[str], options, workers: int, repeat: int = 3) -> list[dict]:
    """Each way's wall and CPU seconds, its cluster's start and whether its reports are ``--jobs 1``'s:
    the ways run in turn ``repeat`` times (interleaved, so a slow spell of the machine falls on all of
    them) and each keeps its least wall time; ``runs`` holds every wall time, ``first_start_s`` the
    cluster's first start in this call (with dask's import, as a new process pays it, only in the
    bench's first call). Only the answers kept by content are forgotten between runs: the ways run
    here or forked from here find this process's other warm caches, a cluster's new workers do not."""
    from .. import hints
    runs: dict[int, list[dict]] = {}         # by the way's place (--workers 1 has --jobs 1 twice)
    first = None
    for _ in range(repeat):
        for way, (name, n, dask) in enumerate(_ways(workers)):
            hints.forget()      # as a new process starts: a pool forked from here would inherit the last way's answers
            w0, c0 = time.perf_counter(), _cpu()
            start = stop = 0.0
            if dask:
                with Cluster("local", n, len(files)) as client:
                    start = time.perf_counter() - w0
                    reports = diagnose_many(model, files, options, client=client)
                    done = time.perf_counter()
                stop = time.perf_counter() - done
            else:
                reports = diagnose_many(model, files, options, jobs=n)
            wall, cpu = time.perf_counter() - w0, _cpu() - c0
            first = reports if first is None else first
            runs.setdefault(way, []).append({"way": name, "wall_s": wall, "cpu_s": cpu, "start_s": start,
                                             "stop_s": stop, "files": len(files), "same": reports == first})
    return [{**min(rows, key=lambda r: r["wall_s"]), "same": all(r["same"] for r in rows),
             "runs": [r["wall_s"] for r in rows], "first_start_s": rows[0]["start_s"]} for rows in runs.values()]


def fleet_rows(reference_dir: Path, model: str, copies: int = 2, short: int = 1000, workers: int = 2,
               echo: Callable[[str], None] | None = None) -> dict:
    """The measurements of ``bench fleet`` (module docstring)."""
    from ..options import Options
    options = Options(pop=12, generations=5, seed=3)
    tmp = Path(tempfile.mkdtemp(prefix="bgfdi-bench-fleet-"))
    try:
        files = []
        for c in range(copies):
            for name in REFERENCE:
                files.append(str(shutil.copy(reference_dir / f"{name}.csv", tmp / f"{name}-{c}.csv")))
        if echo:
            echo(f"{len(files)} reference files, {', '.join(w[0] for w in _ways(workers))}")
        full = run_ways(model, files, options, workers)
        with open(reference_dir / "nominal.csv", encoding="utf-8") as fh:
            head = "".join(fh.readline() for _ in range(SHORT_ROWS + 1))
        shorts = []
        for i in range(short):
            p = tmp / f"short-{i:04d}.csv"
            p.write_text(head, encoding="utf-8")
            shorts.append(str(p))
        if echo:
            echo(f"{short} short files")
        brief = run_ways(model, shorts, options, workers) if short else []
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return {"workers": workers, "fleet": full, "short": brief, "short_rows": SHORT_ROWS}


def _table(rows: list[dict], per_second: bool) -> list[str]:
    base = rows[0]
    out = [f"{'way':<18}{'wall [s]':>10}{'CPU [s]':>10}{'start [s]':>11}{'x --jobs 1':>12}"
           f"{'files/s' if per_second else '':>10}  same reports"]
    for r in rows:
        rate = f"{r['files'] / r['wall_s']:>10.0f}" if per_second else f"{'':>10}"
        out.append(f"{r['way']:<18}{r['wall_s']:>10.2f}{r['cpu_s']:>10.2f}{r['start_s']:>11.2f}"
                   f"{r['wall_s'] / base['wall_s']:>12.2f}{rate}  {'yes' if r['same'] else 'NO'}")
    return out


def format_fleet(row: dict) -> str:
    n = row["workers"]
    runs = len(row["fleet"][0].get("runs", [0]))
    out = [f"A fleet of {row['fleet'][0]['files']} CyCab files (pop 12, 5 generations), each way started and "
           f"timed as the command runs it, the least of {runs} runs (the ways in turn); CPU: this process and its "
           f"workers"]
    out += _table(row["fleet"], False)
    by = {r["way"]: r for r in row["fleet"]}
    cluster = by.get(f"LocalCluster({n})")
    if cluster:
        jobs = by[f"--jobs {n}"]
        out.append(f"LocalCluster({n}) / --jobs {n}: wall {cluster['wall_s'] / jobs['wall_s']:.2f}, "
                   f"CPU {cluster['cpu_s'] / jobs['cpu_s']:.2f} (target: wall <= 1.10); on a running cluster "
                   f"(its start and its close left out: {cluster['start_s']:.2f} + {cluster['stop_s']:.2f} s) wall "
                   f"{(cluster['wall_s'] - cluster['start_s'] - cluster['stop_s']) / jobs['wall_s']:.2f}; "
                   f"its first start, dask's import in it as in a new process: {cluster['first_start_s']:.2f} s")
        turns = turn_ratios(cluster, jobs)
        if len(turns) > 1:
            out.append(f"LocalCluster({n}) / --jobs {n} turn by turn (the two run back to back): "
                       f"{', '.join(f'{r:.2f}' for r in turns)}; median {statistics.median(turns):.2f}")
    if row["short"]:
        out.append("")
        out.append(f"{row['short'][0]['files']} short files ({row['short_rows']} rows each, nothing detected)")
        out += _table(row["short"], True)
    return "\n".join(out) + "\n"


def turn_ratios(cluster: dict, jobs: dict) -> list[float]:
    """The cluster's wall time over ``--jobs N``'s in each turn of :func:`run_ways` (the ways run
    back to back, so a slow spell of the machine falls on both: this machine's speed drifts by tens
    of percent within minutes, and the least of each way may come from different spells).

    >>> turn_ratios({"runs": [1.2, 1.0, 1.1]}, {"runs": [1.0, 1.0, 1.0]})
    [1.2, 1.0, 1.1]
    """
    return [c / j for c, j in zip(cluster.get("runs", []), jobs.get("runs", [])) if j > 0]


def fleet_json(row: dict) -> dict:
    """``bench fleet --json``: the measurements, and the cluster's ratio to ``--jobs N`` turn by turn
    (``turn_ratios``, empty without dask)."""
    by = {r["way"]: r for r in row["fleet"]}
    n = row["workers"]
    cluster, jobs = by.get(f"LocalCluster({n})"), by.get(f"--jobs {n}")
    return {"benchmark": "fleet", **row, "turn_ratios": turn_ratios(cluster, jobs) if cluster and jobs else []}
