"""Fleets: many measurement files diagnosed with one model, one report each, in the files' order.

``bgfdi diagnose model a.csv b.csv ... --jobs N`` runs them in N local processes;
``--scheduler local`` on a dask LocalCluster, ``--scheduler tcp://host:8786`` on a running dask
cluster (the optional extra ``pip install 'bgfdi[dask]'``). From Python::

    from fdi.app.fleet import diagnose_many
    reports = diagnose_many("models/cycab_steering.yaml", ["a.csv", "b.csv"], jobs=2)
    reports = diagnose_many(model, files, client=Client("tcp://10.0.0.5:8786"))

Each report is what ``bgfdi diagnose FILE --json`` prints, with the file and ``error`` (null)
first (``{"file": ..., "error": null, "detection": ..., ...}``); a file that cannot be diagnosed
has the same keys, its one-line ``error`` and every other key null (a bad file does not stop the
others). :func:`to_table` makes one DataFrame of them, :func:`write_parquet` a Parquet file. Every file is diagnosed in one process with one
estimator process (``workers=1``): the diagnosis is seeded, so the reports are the same bytes
whichever way they are run (processes, a LocalCluster, a remote cluster) and whatever the order
the files finish in. The model is derived once, in this process (or read from the compiled-model
cache on disk); local processes (``--jobs``) get the monitor once each, at their start, compiled
(:meth:`fdi.monitor.Monitor.__reduce__`: no worker derives the model), and each file as its path.

On a remote dask cluster, this process reads the model and every file (with the reader and checks
of the local path, so a bad file gives the same line) and sends them to the workers: the workers
need bgfdi installed (the same version), not the files. On a LocalCluster only each file's path
is sent (its workers read the files, as local processes do), the files dealt into a few tasks per
worker. The compiled monitor is scattered to every worker once. A LocalCluster started by the
command has at most one worker per file (``--jobs 16`` for 2 files starts 2) and, on Linux, forks
its workers (:func:`start_method`).
"""
from __future__ import annotations

import importlib.util
import os
import re
import threading
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path
from typing import Callable, Iterable

from ..errors import UsageError
from .parallel import map_in_order

CONNECT_TIMEOUT = 10.0          # s a scheduler address is given to answer
BATCHES_PER_WORKER = 4          # a LocalCluster's fleet: files dealt round-robin into this many tasks per worker
# The LocalCluster the command starts does fleets only: no sampling profiler, and its monitors polled
# less often (an idle 2-worker cluster took 0.049 s of CPU per second, 0.018 with these)
LOCAL_SETTINGS = {"distributed.scheduler.worker-saturation": 1.0,   # a batch to a worker as it frees up
                  "distributed.worker.profile.enabled": False,
                  "distributed.worker.memory.monitor-interval": "1s",
                  "distributed.admin.system-monitor.interval": "2s",
                  "distributed.admin.tick.interval": "200ms"}
DASK_EXTRA = "pip install 'bgfdi[dask]'"
ADDRESS = re.compile(r"^(?:(?:tcp|tls|ucx|ws|wss)://)?(?:\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9_.\-]+):\d{1,5}/?$")


def have_dask() -> bool:
    """dask.distributed importable (the ``dask`` extra)."""
    try:
        return importlib.util.find_spec("distributed") is not None
    except (ImportError, ValueError):
        return False


def need_dask(option: str = "--scheduler") -> UsageError:
    return UsageError(f"{option}: running on dask needs dask.distributed: {DASK_EXTRA}")


def check_address(text: str) -> str:
    """``local`` or a dask scheduler address with its port (``tcp://10.0.0.5:8786``,
    ``10.0.0.5:8786``, ``tls://host:8786``, ``tcp://[::1]:8786``); anything else is a ValueError."""
    text = text.strip()
    if text == "local" or (ADDRESS.match(text) and not text.startswith("-")):
        return text
    raise ValueError(f"must be local or a dask scheduler address such as tcp://10.0.0.5:8786, got {text!r}")


# ------------------------------------------------------------------ one file

def _user_errors() -> tuple:
    from bondgraph.errors import CausalityError, ModelError

    from ..data import DataError
    return ModelError, CausalityError, DataError, UsageError


def read_file(path: str, options, monitor=None):
    """The measurements of one file, checked against ``options.samples`` (DataError, UsageError):
    N samples span the model's shortest intermittent period (fdi.scales.min_period)."""
    from ..data import read_csv
    from ..options import check_samples
    data = read_csv(path)
    if monitor is not None:
        check_samples(options.samples, data.ts, "--samples", monitor.min_period(options, data.ts))
    return data


def diagnose_data(monitor, path: str, data, options, timings: bool = False) -> dict:
    """One file's measurements diagnosed (in a worker): its report as one JSON-ready object with
    the file first, or the one-line error."""
    try:
        d = monitor.diagnose(data, replace(options, workers=1))
    except _user_errors() as exc:
        return line(path, error=str(exc), timings=timings)
    return line(path, d.to_dict(timings))


def diagnose_file(monitor, path: str, options, timings: bool = False) -> dict:
    """One file of a fleet, read and diagnosed in this process (a local worker process, which
    derives the model once: :mod:`fdi.monitor`)."""
    try:
        data = read_file(path, options, monitor)
    except _user_errors() as exc:
        return line(path, error=str(exc), timings=timings)
    return diagnose_data(monitor, path, data, options, timings)


def diagnose_files(monitor, paths: list[str], options, timings: bool = False) -> list[dict]:
    """A batch of a fleet's files, each read and diagnosed in this process (one dask task: a
    thousand short files are a few tasks per worker, not a thousand)."""
    return [diagnose_file(monitor, path, options, timings) for path in paths]


def line(path: str, report: dict | None = None, error: str | None = None, timings: bool = False) -> dict:
    """A fleet's line: ``file``, ``error`` (None), then the report; a failed file's line has the
    same keys (``timings`` too, with ``timings``), every one but ``file`` and ``error`` None."""
    from ..results import REPORT_KEYS
    if report is None:
        report = dict.fromkeys(REPORT_KEYS + (("timings",) if timings else ()))
    return {"file": path, "error": error, **report}


PARQUET_EXTRA = "pip install 'bgfdi[parquet]'"


def have_parquet() -> bool:
    """pandas and pyarrow importable (the ``parquet`` extra)."""
    return all(importlib.util.find_spec(m) is not None for m in ("pandas", "pyarrow"))


def need_parquet(option: str) -> UsageError:
    return UsageError(f"{option}: a Parquet file needs pandas and pyarrow: {PARQUET_EXTRA}")


def to_table(lines: list[dict]):
    """A fleet's lines as one pandas DataFrame, one row per fault (a file without a fault, or that
    failed, has one row: :func:`fdi.results.fault_rows`, columns :data:`fdi.results.ROW_KEYS`)."""
    from ..results import to_frame
    return to_frame(lines)


def parquet_bytes(lines: list[dict]) -> bytes:
    """:func:`to_table` as the bytes of a Parquet file (``b`` lists as lists of floats)."""
    import io
    if not have_parquet():
        raise need_parquet("Parquet")
    buffer = io.BytesIO()
    to_table(lines).to_parquet(buffer, engine="pyarrow", index=False)
    return buffer.getvalue()


_worker_monitor = None        # the fleet's monitor in a local worker process, set once by _keep


def _keep(monitor) -> None:
    """A local worker's initializer: the monitor arrives once (unpickled compiled: nothing derived)
    and keeps its signature matrices between files; each job is a path."""
    global _worker_monitor
    _worker_monitor = monitor


def _job(job: tuple) -> dict:
    return diagnose_file(_worker_monitor, *job)


# ------------------------------------------------------------------ many files

def diagnose_many(model, files: Iterable[str | Path], options=None, *, client=None, jobs: int = 1,
                  timings: bool = False, progress: Callable[[int, int], None] | None = None) -> list[dict]:
    """Diagnose every file with one model; the reports in the order of ``files``.

    ``model``: a path, a loaded Model or YAML text (as for :func:`fdi.api.diagnose`); ``options``
    an :class:`fdi.options.Options` (checked first; its ``workers`` is set to 1 per file), or a
    :class:`fdi.config.MonitorConfig` to use instead of the model file's monitor settings.
    ``client``: a ``dask.distributed.Client``, whose workers run the files; without one, ``jobs``
    local processes (1: in this process). ``timings`` adds wall-clock times to each report (they
    then differ between runs). ``progress(done, total)`` is called as files finish."""
    from ..config import MonitorConfig
    from ..monitor import monitor_of
    from ..options import Options

    if isinstance(options, MonitorConfig):
        options = Options(settings=options)
    options = options or Options()
    options.check()
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise UsageError(f"jobs: must be an integer >= 1, got {jobs!r}")
    monitor = monitor_of(model)
    files = [str(f) for f in files]
    if not files:
        return []
    if client is not None:
        return _on_dask(client, monitor, files, options, timings, progress)
    return map_in_order(_job, [(f, options, timings) for f in files], jobs, progress, _keep, (monitor,))


def _on_dask(client, monitor, files: list[str], options, timings: bool, progress) -> list[dict]:
    """The files on a dask cluster. On a LocalCluster each worker reads its files; on another
    cluster the client reads each file (errors as for local processes: the same reader on the same
    path) and sends it. The monitor, compiled, is scattered to every worker once; the workers
    diagnose."""
    model_ref = client.scatter(monitor, broadcast=True, hash=False)
    out: list[dict | None] = [None] * len(files)
    if same_machine(client):            # the workers read the files: only the paths travel, a batch per task
        n = min(len(files), max(1, workers_of(client)) * BATCHES_PER_WORKER)
        # one map, not a submit per batch: the scheduler sees the whole group at once, queues it
        # as root tasks and hands a batch to a worker as it frees up (submitted one by one, the
        # first batches were placed at once, 5 of 8 on one worker: it ended 0.45 s after the other)
        futures = client.map(diagnose_files, [model_ref] * n, [files[k::n] for k in range(n)], [options] * n,
                             [timings] * n, pure=False)
        batches = {f: list(range(k, len(files), n)) for k, f in enumerate(futures)}
        return _collect(batches, out, 0, progress, model_ref)
    pending, done = {}, 0
    for i, path in enumerate(files):
        try:
            data = read_file(path, options, monitor)
        except _user_errors() as exc:
            out[i] = line(path, error=str(exc), timings=timings)
            done += 1
            if progress:
                progress(done, len(files))
            continue
        pending[client.submit(diagnose_data, model_ref, path, data, options, timings, pure=False)] = [i]
    return _collect(pending, out, done, progress, model_ref)


def _collect(futures: dict, out: list, done: int, progress, model_ref) -> list:
    """``out`` filled from dask futures as they complete: each future gives the lines of its list of
    file indices (one line, or a batch's list); every future and the scattered monitor released."""
    from distributed import as_completed
    try:
        for future in as_completed(list(futures)):
            got = future.result()
            for j, result in zip(futures[future], got if isinstance(got, list) else [got]):
                out[j] = result
            done += len(futures[future])
            if progress:
                progress(done, len(out))
    finally:
        for future in futures:
            future.release()
        model_ref.release()
    return out


def same_machine(client) -> bool:
    """The client's cluster is a LocalCluster of this process: its workers see this machine's
    files, so a fleet sends each file's path, not its data."""
    try:
        from distributed import LocalCluster
    except ImportError:
        return False
    return isinstance(getattr(client, "cluster", None), LocalCluster)


def start_method() -> str | None:
    """How a LocalCluster started here starts its workers: ``fork`` on Linux (a worker inherits
    the imported modules and the compiled model: a fleet of 8 short files on 2 workers took 3.6 s
    of CPU with dask's default ``spawn``, 2.2 s with ``fork``), else dask's own setting."""
    import multiprocessing
    import sys
    if sys.platform.startswith("linux") and "fork" in multiprocessing.get_all_start_methods():
        return "fork"
    return None


# ------------------------------------------------------------------ clusters

class Cluster:
    """``with Cluster(address, workers) as client:`` a Client of a new LocalCluster (``local``: that
    many worker processes, one thread each) or of the scheduler at ``address``; closed at the end.
    A missing extra or a scheduler that does not answer is a UsageError (one line, exit 2)."""

    def __init__(self, address: str, workers: int | None = None, files: int | None = None) -> None:
        self.address, self.workers, self.files = address, workers, files
        self.cluster = self.client = None

    def __enter__(self):
        if not have_dask():
            raise need_dask()
        import logging

        from distributed import Client, LocalCluster
        if self.address == "local":
            n = self.workers or max(1, os.cpu_count() or 1)
            if self.files is not None:
                n = max(1, min(n, self.files))            # a worker per file at most
            import dask
            method = start_method()
            settings = dict(LOCAL_SETTINGS)
            if method:
                settings["distributed.worker.multiprocessing-method"] = method
            # dask's nannies start workers with MALLOC_TRIM_THRESHOLD_=65536, which fixes glibc's mmap
            # threshold: every array over 128 kB is mapped and unmapped again, and a diagnosis spends
            # 11x the system time in page faults (8.0 s -> 12.6 s CPU a file): the workers here keep
            # glibc's defaults, as --jobs processes do.
            settings["distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_"] = None
            if method == "fork":
                _warm_for_fork()
            with dask.config.set(settings), _quick_start():
                self.cluster = LocalCluster(n_workers=n, processes=True, threads_per_worker=1,
                                            dashboard_address=":0", silence_logs=logging.ERROR)
            self.client = Client(self.cluster)
            return self.client
        try:
            self.client = Client(self.address, timeout=CONNECT_TIMEOUT)
        except (OSError, TimeoutError) as exc:
            raise UsageError(f"--scheduler: no dask scheduler answers at {self.address} "
                             f"({str(exc).splitlines()[0] if str(exc) else type(exc).__name__}); "
                             f"start one with 'dask scheduler' and workers with 'dask worker ADDRESS', "
                             f"or check the address") from None
        return self.client

    def __exit__(self, *exc) -> None:
        if self.client is not None:
            self.client.close()
        if self.cluster is not None:
            self.cluster.close()


def _warm_for_fork() -> None:
    """What each forked worker of a LocalCluster would otherwise work out on its own, worked out
    here once before the fork, so that the workers inherit it: the installed packages' versions a
    worker sends the scheduler when it registers (``distributed.versions`` keeps them per process,
    read from package metadata: ~30 ms in each new worker; the scheduler and the client here ask
    for them anyway) and ``numpy.random``, which dask's worker start reseeds (its import: ~13 ms in
    each worker). A fresh process's first 2-worker cluster answered its first task 0.123-0.142 s
    after the start began, 0.100-0.122 s with this (6 fresh processes each, interleaved)."""
    import numpy.random  # noqa: F401  (imported for the forked workers)
    try:
        from distributed.versions import get_versions
        get_versions()
    except Exception:       # a dask without it, or metadata it cannot read: the workers read their own
        pass


_POLL_LOCK = threading.Lock()
_POLL_SAVED: list = []          # [dask's value, then one None per cluster starting now]
INIT_POLL_S = 0.002            # s between a nanny's looks for its new worker's first message (dask's own: 0.05)


@contextmanager
def _quick_start():
    """While a LocalCluster starts here, each nanny looks for its new worker's first message every
    :data:`INIT_POLL_S` instead of dask's 50 ms (``distributed.nanny.WorkerProcess``'s class
    attribute ``_init_msg_interval``, not a setting: left alone where it is missing). A forked
    worker is ready in ~20 ms and waited for up to 50: the start of a 2-worker cluster took
    0.069-0.074 s, 0.036-0.041 s with this (the fleet's fixed cost against ``--jobs``). Restored
    once the cluster is up (its later restarts poll as dask does)."""
    try:
        from distributed.nanny import WorkerProcess
    except ImportError:
        yield
        return
    with _POLL_LOCK:                     # clusters starting at once in threads: dask's value saved by the first
        if not _POLL_SAVED and isinstance(dask_value := WorkerProcess.__dict__.get("_init_msg_interval"), (int, float)):
            _POLL_SAVED.append(dask_value)
        quick = bool(_POLL_SAVED)
        if quick:
            _POLL_SAVED.append(None)     # one entry per cluster starting (the first is dask's value)
            WorkerProcess._init_msg_interval = min(_POLL_SAVED[0], INIT_POLL_S)
    try:
        yield
    finally:
        if quick:
            with _POLL_LOCK:
                _POLL_SAVED.pop()
                if len(_POLL_SAVED) == 1:        # the last one up: dask's value back
                    WorkerProcess._init_msg_interval = _POLL_SAVED.pop()


def workers_of(client) -> int:
    """How many workers a client's cluster has now."""
    return len(client.scheduler_info().get("workers", {}))
