"""``bgfdi bench csv``: reading a large measurement file, beside the libraries users already have.

A plain comma-separated file of ``megabytes`` MB (the CyCab's columns: t and five signals, numbers
as a logger writes them, ``%.10g``) is written to a temporary folder, then read in a fresh child
process each by:

- ``bgfdi``: :func:`fdi.data.read_csv` as a diagnosis reads it (pandas' C parser in pieces when the
  ``pandas`` extra is installed and the file is large, with bgfdi's checks and messages);
- ``bgfdi numpy``: the same reader without pandas (numpy's parser on blocks of rows: the path of a
  machine without the extra);
- ``pandas.read_csv`` alone (when installed), the reference a user would compare with.

Each child reports the CPU seconds of the read alone (``time.process_time`` around the call, its
imports excluded: pandas is imported before the read in both of its paths) and its peak resident memory above what it held before the read
(Linux: the high-water mark reset before the read, ``/proc/self/clear_refs``; elsewhere
``getrusage``'s ``ru_maxrss``), the least over ``repeat`` children. Ratios are of this run; the
file is deleted after.
"""
from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

COLUMNS = ["t", "theta1", "theta2", "dp", "u_in", "i_m"]
ROWS_PER_BLOCK = 100_000


def write_file(path: Path, megabytes: float, seed: int = 0) -> int:
    """A plain CSV of about ``megabytes`` MB (header and rows of six numbers); returns its rows."""
    rng = np.random.default_rng(seed)
    target = int(megabytes * 1e6)
    rows = 0
    with open(path, "w") as fh:
        fh.write(",".join(COLUMNS) + "\n")
        while fh.tell() < target:
            t = (rows + np.arange(ROWS_PER_BLOCK)) * 0.01
            block = np.column_stack([t] + [rng.normal(size=ROWS_PER_BLOCK) * 10 ** k for k in range(5)])
            np.savetxt(fh, block, fmt="%.10g", delimiter=",")
            rows += ROWS_PER_BLOCK
    return rows


def _status(key: str) -> int | None:
    """A field of /proc/self/status in bytes (Linux), else None."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith(key + ":"):
                    return int(line.split()[1]) * 1024
    except OSError:
        return None
    return None


def _reset_peak() -> int:
    """Start counting the peak afresh where the system allows it (Linux: the high-water mark is
    reset to the current resident size); returns the resident size now."""
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
    except OSError:
        pass
    now = _status("VmRSS")
    return now if now is not None else _peak_bytes()


def _peak_bytes() -> int:
    """This process's peak resident memory (Linux: VmHWM; elsewhere getrusage, kB on Linux, bytes on macOS)."""
    hwm = _status("VmHWM")
    if hwm is not None:
        return hwm
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak if sys.platform == "darwin" else peak * 1024


def probe(path: str, how: str) -> None:
    """Run in a child: read ``path`` one way and print {"cpu_s", "peak_bytes", "rows"} as JSON."""
    import importlib.util
    import time
    if how == "pandas":
        import pandas as pd

        def read():
            return pd.read_csv(path, dtype=float, engine="c").shape[0]
    else:
        from .. import data
        if how == "bgfdi" and importlib.util.find_spec("pandas"):
            import pandas  # noqa: F401  (imported before, as for pandas.read_csv: the parse is compared)
        if how == "numpy":
            data._by_pandas = lambda *_: None          # the reader of a machine without the extra

        def read():
            return data.read_csv(path).t.size
    base = _reset_peak()
    c = time.process_time()
    rows = read()
    cpu = time.process_time() - c
    print(json.dumps({"cpu_s": cpu, "peak_bytes": max(0, _peak_bytes() - base), "rows": rows}))


def _child(path: Path, how: str) -> dict | None:
    out = subprocess.run([sys.executable, "-c", f"from fdi.app.bench_csv import probe; probe({str(path)!r}, {how!r})"],
                         capture_output=True, text=True, env=dict(os.environ, BGFDI_CACHE="off"))
    if out.returncode != 0:
        return None
    return json.loads(out.stdout.strip().splitlines()[-1])


def csv_rows(megabytes: float = 250.0, repeat: int = 2, echo=None) -> dict:
    """Each reader's least CPU and peak memory over ``repeat`` children on one file of ``megabytes``."""
    import importlib.util
    ways = ["bgfdi", "bgfdi numpy"] + (["pandas"] if importlib.util.find_spec("pandas") else [])
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "bench.csv"
        rows = write_file(path, megabytes)
        size = path.stat().st_size
        out = {"file_bytes": size, "rows": rows, "readers": {}}
        for way in ways:
            got = [r for r in (_child(path, way.split()[-1]) for _ in range(repeat)) if r is not None]
            if got:
                out["readers"][way] = {"cpu_s": min(r["cpu_s"] for r in got),
                                       "peak_bytes": min(r["peak_bytes"] for r in got)}
                if echo:
                    echo(f"{way}: {out['readers'][way]['cpu_s']:.2f} s CPU")
    return out


def format_csv(row: dict) -> str:
    size = row["file_bytes"]
    readers = row["readers"]
    ref = readers.get("pandas")
    lines = [f"Reading a plain CSV of {size / 1e6:.0f} MB ({row['rows']} rows x {len(COLUMNS)}), each reader in a "
             f"fresh process, least of the runs",
             f"{'reader':<14}{'CPU [s]':>9}{'vs pandas':>11}{'peak [MB]':>11}{'peak/file':>11}"]
    for way, r in readers.items():
        ratio = f"{r['cpu_s'] / ref['cpu_s']:.2f}x" if ref else "-"
        lines.append(f"{way:<14}{r['cpu_s']:>9.2f}{ratio:>11}{r['peak_bytes'] / 1e6:>11.0f}{r['peak_bytes'] / size:>11.2f}")
    return "\n".join(lines) + "\n"


def csv_json(row: dict) -> dict:
    ref = row["readers"].get("pandas")
    return {"benchmark": "csv", "file_bytes": row["file_bytes"], "rows": row["rows"],
            "readers": {k: {**v, "vs_pandas": v["cpu_s"] / ref["cpu_s"] if ref else None,
                            "peak_over_file": v["peak_bytes"] / row["file_bytes"]} for k, v in row["readers"].items()}}
