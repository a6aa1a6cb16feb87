"""Issue 13: fleets on dask give the lines of ``--jobs``; fdi.app.fleet.diagnose_many in file order.

The four reference files are diagnosed once with ``--jobs 2`` (module fixture) and compared byte
for byte with the same options on a dask LocalCluster, through the CLI (the scheduler's address)
and through Python; small populations keep it cheap (the identity, not the accuracy, is tested
here: test_batch compares ``--jobs`` with single diagnoses at the same options)."""
from __future__ import annotations

import contextlib
import io
import json
import socket

import pytest

from fdi.app import fleet
from fdi.app.cli import main
from fdi.options import Options

from .conftest import CYCAB, DATA

FILES = [str(DATA / f"{n}.csv") for n in ("nominal", "scenario1", "scenario2", "scenario3")]
CHEAP = ["--pop", "12", "--generations", "10", "--seed", "3"]
OPTIONS = Options(pop=12, generations=10, seed=3)


def _run(argv: list[str]) -> tuple[int, str]:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main(argv)
    return code, out.getvalue()


@pytest.fixture(scope="module")
def jobs_lines() -> str:
    code, out = _run(["diagnose", str(CYCAB), *FILES, "--jobs", "2", "-q", *CHEAP])
    assert code == 0 and len(out.splitlines()) == 4
    return out


def test_diagnose_many_in_this_process_gives_the_jobs_lines(jobs_lines):
    seen = []
    reports = fleet.diagnose_many(CYCAB, FILES, OPTIONS, progress=lambda done, total: seen.append((done, total)))
    assert [r["file"] for r in reports] == FILES
    assert reports == [json.loads(line) for line in jobs_lines.splitlines()]
    assert seen == [(1, 4), (2, 4), (3, 4), (4, 4)]
    assert fleet.diagnose_many(CYCAB, [], OPTIONS) == []


def test_scheduler_values_and_combinations_are_checked_before_any_work(capsys, monkeypatch):
    assert main(["diagnose", str(CYCAB), *FILES, "--scheduler", "localhost"]) == 2
    assert capsys.readouterr().err == ("bgfdi: error: --scheduler: must be local or a dask scheduler address such as "
                                       "tcp://10.0.0.5:8786, got 'localhost'\n")
    monkeypatch.setattr(fleet, "have_dask", lambda: False)
    assert main(["diagnose", str(CYCAB), *FILES, "--scheduler", "local"]) == 2
    assert capsys.readouterr().err == ("bgfdi: error: --scheduler: running on dask needs dask.distributed: "
                                       "pip install 'bgfdi[dask]'\n")
    monkeypatch.setattr(fleet, "have_dask", lambda: True)
    assert main(["diagnose", str(CYCAB), *FILES, "--scheduler", "tcp://10.0.0.5:8786", "--jobs", "2"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.startswith("bgfdi: error: --jobs: the cluster at tcp://10.0.0.5:8786 runs") \
        and err.count("\n") == 1


def test_addresses():
    for good in ("local", "tcp://10.0.0.5:8786", "10.0.0.5:8786", "tls://sched.lab:8786", "tcp://[::1]:8786"):
        assert fleet.check_address(good) == good
    for bad in ("", "tcp://", "http://h:1", "h", "h:port", "-h:1"):
        with pytest.raises(ValueError, match="must be local or a dask scheduler address"):
            fleet.check_address(bad)


# ------------------------------------------------------------------ on dask

@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    import logging
    with distributed.LocalCluster(n_workers=2, processes=True, threads_per_worker=1, dashboard_address=":0",
                                  silence_logs=logging.ERROR) as c:
        yield c


def test_a_scheduler_address_gives_the_jobs_lines(cluster, jobs_lines):
    code, out = _run(["diagnose", str(CYCAB), *FILES, "--scheduler", cluster.scheduler_address, "-q", *CHEAP])
    assert code == 0 and out == jobs_lines


def test_diagnose_many_on_a_client_in_file_order(cluster, jobs_lines, tmp_path):
    from distributed import Client
    bad = tmp_path / "bad.csv"
    bad.write_text("t,x\n0,1\n0.1,2\n")
    files = [FILES[2], str(tmp_path / "missing.csv"), FILES[0], str(bad)]
    with Client(cluster) as client:
        reports = fleet.diagnose_many(str(CYCAB), files, OPTIONS, client=client)
    expected = {r["file"]: r for r in map(json.loads, jobs_lines.splitlines())}
    assert [r["file"] for r in reports] == files
    assert reports[0] == expected[FILES[2]] and reports[2] == expected[FILES[0]]
    from fdi.results import REPORT_KEYS
    assert reports[1] == {"file": files[1], "error": f"{files[1]}: cannot read (No such file or directory)",
                          **dict.fromkeys(REPORT_KEYS)}
    assert "missing column(s)" in reports[3]["error"]
    assert reports == fleet.diagnose_many(str(CYCAB), files, OPTIONS)            # the same as locally


def test_a_local_cluster_from_the_command_line(jobs_lines):
    pytest.importorskip("distributed")
    code, out = _run(["diagnose", str(CYCAB), FILES[0], "--scheduler", "local", "--jobs", "1", "-q", *CHEAP])
    assert code == 0 and out == jobs_lines.splitlines(keepends=True)[0]


def test_a_local_cluster_starts_with_the_quick_poll_and_leaves_dask_as_it_was(monkeypatch):
    """The nannies of a LocalCluster the command starts look for their workers every INIT_POLL_S
    (dask's 50 ms made a 2-worker start 0.07 s, 0.04 s with it); dask's class attribute is dask's
    again once the cluster is up, and a dask without it is left alone."""
    pytest.importorskip("distributed")
    from distributed.nanny import WorkerProcess
    before = WorkerProcess.__dict__["_init_msg_interval"]
    seen = []
    real = WorkerProcess.start

    async def start(self):
        seen.append(self._init_msg_interval)
        return await real(self)
    monkeypatch.setattr(WorkerProcess, "start", start)
    with fleet.Cluster("local", 1, 1) as client:
        assert client.submit(sum, [1, 2]).result() == 3
    assert seen == [fleet.INIT_POLL_S] and WorkerProcess.__dict__["_init_msg_interval"] == before
    a, b = fleet._quick_start(), fleet._quick_start()      # two clusters starting at once (threads): the
    a.__enter__()                                          # first one up leaves the second's poll quick, the
    b.__enter__()                                          # last one up restores dask's (the final review)
    a.__exit__(None, None, None)
    assert WorkerProcess._init_msg_interval == fleet.INIT_POLL_S
    b.__exit__(None, None, None)
    assert WorkerProcess.__dict__["_init_msg_interval"] == before
    monkeypatch.delattr(WorkerProcess, "_init_msg_interval")
    with fleet._quick_start():
        assert "_init_msg_interval" not in WorkerProcess.__dict__


def test_no_scheduler_at_the_address(capsys, monkeypatch):
    pytest.importorskip("distributed")
    with socket.socket() as s:                          # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    monkeypatch.setattr(fleet, "CONNECT_TIMEOUT", 1.0)
    assert main(["diagnose", str(CYCAB), FILES[0], "--scheduler", f"tcp://127.0.0.1:{port}", "-q", *CHEAP]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1
    assert err.startswith(f"bgfdi: error: --scheduler: no dask scheduler answers at tcp://127.0.0.1:{port}")


def test_monitor_settings_reach_every_file():
    """A MonitorConfig given to diagnose_many replaces the file's settings in every diagnosis:
    thresholds above every residual detect nothing in the four reference files."""
    from fdi.config import load
    quiet = load(CYCAB)[1].replace(thresholds={"ARR1": 1e9, "ARR2": 1e9, "ARR3": 1e9})
    reports = fleet.diagnose_many(CYCAB, FILES, quiet, jobs=2)
    assert [r["file"] for r in reports] == FILES
    assert all(r["detection"] is None and r["diagnosis"]["faults"] == [] for r in reports)
