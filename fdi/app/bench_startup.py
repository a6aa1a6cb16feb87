"""``bgfdi bench startup``: a whole ``bgfdi diagnose`` process, cold and warm, minus the diagnosis.

``bgfdi diagnose models/cycab_steering.yaml scenario3.csv`` (a diagnosis of a few milliseconds: the
process is almost all start-up) as a child process, with the compiled-model cache off (cold: the
model derived) and on (warm: a private cache folder, filled by one run before), Python's bytecode
cached in that folder as a user's Python caches it beside the sources; the least CPU time
(user + system, ``getrusage`` of the children) of ``repeat`` runs; the diagnosis itself in this
process (the monitor compiled, ``time.process_time``, least of ``repeat``) is subtracted:
start-up = process - in-process diagnosis. The floor of the design, ``python -c "import numpy"``
(a warm process imports numpy and no sympy: :mod:`bondgraph.deferred`), is measured beside it.
Every figure is of this run; no stored reference.
"""
from __future__ import annotations

import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def process_cpu(args: list[str], env: dict | None = None) -> float:
    """CPU seconds (user + system) of one child process running ``args``."""
    return process_times(args, env)[1]


def process_times(args: list[str], env: dict | None = None) -> tuple[float, float]:
    """Wall and CPU seconds (user + system) of one child process running ``args`` (exit 0, or 3:
    a fault found); a RuntimeError naming its exit otherwise."""
    before, start = _children_cpu(), time.perf_counter()
    out = subprocess.run(args, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - start
    if out.returncode not in (0, 3):
        raise RuntimeError(f"{' '.join(args)}: exit {out.returncode}: {out.stderr.strip()[-300:]}")
    return wall, _children_cpu() - before


def startup_row(model: Path, data: Path, repeat: int = 3) -> dict:
    """Whole-process CPU of ``bgfdi diagnose`` cold and warm, the in-process diagnosis, their
    differences (start-up) and the floor (Python with numpy imported)."""
    from ..monitor import compiled
    from ..options import Options
    folder = Path(tempfile.mkdtemp(prefix="bgfdi-bench-cache-"))
    try:
        # bytecode cached as a user's Python caches it (PYTHONDONTWRITEBYTECODE, set on some
        # build machines, made every process compile bgfdi's modules again: warm start-up 0.711 s
        # for 0.587 s), in the private folder, not beside the installed sources; one run fills it
        base = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
        base.update(BGFDI_CACHE_DIR=str(folder / "cache"), PYTHONPYCACHEPREFIX=str(folder / "pycache"))
        cmd = [sys.executable, "-m", "fdi", "diagnose", str(model), str(data), "-q"]
        process_cpu(cmd, {**base, "BGFDI_CACHE": "off"})                  # fills the bytecode cache
        cold = min(process_cpu(cmd, {**base, "BGFDI_CACHE": "off"}) for _ in range(repeat))
        process_cpu(cmd, {**base, "BGFDI_CACHE": "on"})                   # fills the cache
        warm = min(process_cpu(cmd, {**base, "BGFDI_CACHE": "on"}) for _ in range(repeat))
        floor = min(process_cpu([sys.executable, "-c", "import numpy"], base) for _ in range(repeat))
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    monitor = compiled(model)
    monitor.diagnose(str(data), Options(workers=1))                        # everything derived once
    inner = []
    for _ in range(repeat):
        t = time.process_time()
        monitor.diagnose(str(data), Options(workers=1))
        inner.append(time.process_time() - t)
    diagnosis = min(inner)
    return {"file": data.name, "cold_process_s": cold, "warm_process_s": warm, "diagnosis_s": diagnosis,
            "cold_startup_s": cold - diagnosis, "warm_startup_s": warm - diagnosis, "floor_s": floor}


def format_startup(row: dict) -> str:
    return (f"bgfdi diagnose {row['file']}, one whole process (CPU s, least of 3; in-process diagnosis "
            f"{row['diagnosis_s']:.3f} s):\n"
            f"  cold (cache off): {row['cold_process_s']:.3f} s, start-up {row['cold_startup_s']:.3f} s\n"
            f"  warm (cache on):  {row['warm_process_s']:.3f} s, start-up {row['warm_startup_s']:.3f} s\n"
            f"  floor (python -c 'import numpy'): {row['floor_s']:.3f} s\n")


def startup_json(row: dict) -> dict:
    """``bench startup --json``."""
    return {"benchmark": "startup", **row}


__all__ = ["startup_row", "format_startup", "startup_json", "process_cpu"]
