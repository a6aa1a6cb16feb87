"""The compiled-model cache on disk (fdi.diskcache, fdi.persist): nothing is unpickled that this
user's bgfdi did not write (a planted entry, a flipped byte, another key, another version), a
folder or key others may touch turns it off, two writers at once leave a readable entry, and a
monitor read back diagnoses exactly as one derived afresh. A warm process imports neither
sympy nor networkx nor the derivation's modules."""
from __future__ import annotations

import json
import os
import pickle
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from fdi import diskcache
from fdi.monitor import Monitor, _disk_source

from .conftest import CYCAB, DATA, ROOT

PY = [sys.executable]


@pytest.fixture()
def cache(tmp_path, monkeypatch):
    """The cache on, in a private folder of its own, with no state kept from another test."""
    where = tmp_path / "cache"
    monkeypatch.setenv(diskcache.DIR_ENV, str(where))
    monkeypatch.setenv(diskcache.ENV, "on")
    diskcache._state.pop("ready", None)
    diskcache.notes.clear()
    yield where
    diskcache._state.pop("ready", None)


def _env(where) -> dict:
    return {**os.environ, diskcache.DIR_ENV: str(where), diskcache.ENV: "on", "PYTHONPATH": str(ROOT)}


def _entry(where):
    (entry,) = where.glob("*" + diskcache.SUFFIX)
    return entry


class _Boom:
    """A pickle that runs code when it is loaded: it writes a marker file."""
    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return (open, (self.marker, "w"))


def test_round_trip_and_folder_modes(cache):
    assert diskcache.store("k", b"source", b"payload")
    assert diskcache.fetch("k", b"source") == b"payload"
    assert diskcache.fetch("k", b"other source") is None
    if os.name == "posix":
        assert oct(cache.stat().st_mode & 0o777) == oct(0o700)
        assert oct((cache / diskcache.KEY_FILE).stat().st_mode & 0o777) == oct(0o600)
        assert oct(_entry(cache).stat().st_mode & 0o777) == oct(0o600)


def test_a_planted_entry_is_never_unpickled(cache, tmp_path):
    diskcache.store("warm", b"x", b"")              # the folder and its key exist
    name = diskcache.entry_name("monitor", _disk_source(str(CYCAB)))
    marker = tmp_path / "ran"
    planted = pickle.dumps(_Boom(marker))
    for body in (planted, diskcache.MAGIC + b"\0" * 32 + planted, diskcache.MAGIC + planted[:32] + planted):
        (cache / name).write_bytes(body)
        os.chmod(cache / name, 0o600)
        assert diskcache.fetch("monitor", _disk_source(str(CYCAB))) is None
        from fdi.monitor import _from_disk
        assert _from_disk(str(CYCAB), _disk_source(str(CYCAB))) is None
        assert not marker.exists()


def test_a_tampered_byte_a_truncated_entry_and_a_renamed_one_are_refused(cache):
    assert diskcache.store("k", b"source", b"the payload, long enough")
    entry = _entry(cache)
    good = entry.read_bytes()
    for i in (0, len(diskcache.MAGIC) + 3, len(good) - 1):     # the magic, the HMAC, the payload
        bad = bytearray(good)
        bad[i] ^= 0x01
        entry.write_bytes(bytes(bad))
        assert diskcache.fetch("k", b"source") is None
    entry.write_bytes(good[:-5])
    assert diskcache.fetch("k", b"source") is None
    entry.write_bytes(good)
    assert diskcache.fetch("k", b"source") == b"the payload, long enough"
    other = cache / diskcache.entry_name("k", b"another source")   # a valid entry under another name
    other.write_bytes(good)
    assert diskcache.fetch("k", b"another source") is None


def test_an_entry_written_under_another_key_is_refused(cache):
    assert diskcache.store("k", b"source", b"payload")
    key = cache / diskcache.KEY_FILE
    key.write_bytes(os.urandom(32))
    diskcache._state.pop("ready", None)
    assert diskcache.fetch("k", b"source") is None


def test_another_version_or_source_tree_is_another_entry(cache, monkeypatch):
    assert diskcache.store("k", b"source", b"payload")
    monkeypatch.setitem(diskcache._state, "version", "999.0")
    assert diskcache.fetch("k", b"source") is None
    monkeypatch.setitem(diskcache._state, "version", diskcache._bgfdi_version())
    monkeypatch.setitem(diskcache._state, "fingerprint", "an edited checkout")
    assert diskcache.fetch("k", b"source") is None


def _within(seconds, call, fifos=()):
    """``call()``'s result, or a failure when it has not returned within ``seconds`` (a FIFO's open
    waiting for a writer): each FIFO is then opened for writing, which releases the waiting open."""
    import threading
    out = []
    worker = threading.Thread(target=lambda: out.append(call()), daemon=True)
    worker.start()
    worker.join(seconds)
    if worker.is_alive():
        for f in fifos:
            os.close(os.open(f, os.O_WRONLY | os.O_NONBLOCK))
        worker.join(5)
        pytest.fail(f"still waiting after {seconds} s: a FIFO was opened as a file")
    return out[0]


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="POSIX FIFOs")
def test_a_folder_or_fifo_under_an_entry_or_key_name_is_ignored_without_waiting(cache):
    """Found by trying to break the cache (trial3): a FIFO planted under an entry's or the key's
    name hung every later process in ``open`` (waiting for a writer), a folder crashed it with
    IsADirectoryError. Each is now no entry (derived afresh) or, for the key, the cache off with a
    note, and nothing waits."""
    assert diskcache.store("k", b"source", b"payload")
    entry = _entry(cache)
    entry.unlink()
    entry.mkdir()
    assert _within(20, lambda: diskcache.fetch("k", b"source")) is None
    entry.rmdir()
    os.mkfifo(entry, 0o600)
    assert _within(20, lambda: diskcache.fetch("k", b"source"), [entry]) is None
    assert diskcache.store("k", b"other", b"x") and diskcache.fetch("k", b"other") == b"x"   # the others work on
    entry.unlink()
    key = cache / diskcache.KEY_FILE
    saved = key.read_bytes()
    for plant in (key.mkdir, lambda: os.mkfifo(key, 0o600)):
        key.unlink() if key.is_file() or key.is_fifo() else key.rmdir()
        plant()
        diskcache._state.pop("ready", None)
        diskcache.notes.clear()
        assert _within(20, lambda: diskcache.fetch("k", b"source"), [key] if key.is_fifo() else []) is None
        assert any("not a regular file" in n for n in diskcache.notes), diskcache.notes
    key.unlink()
    key.write_bytes(saved)
    os.chmod(key, 0o600)
    diskcache._state.pop("ready", None)
    assert diskcache.store("k", b"source", b"payload") and diskcache.fetch("k", b"source") == b"payload"


@pytest.mark.skipif(os.name != "posix", reason="POSIX permissions")
def test_a_folder_or_key_others_may_touch_turns_the_cache_off(cache):
    assert diskcache.store("k", b"source", b"payload")
    os.chmod(cache, 0o777)
    diskcache._state.pop("ready", None)
    assert diskcache.fetch("k", b"source") is None and not diskcache.store("k", b"s", b"p")
    assert any("mode 777" in n for n in diskcache.notes)
    os.chmod(cache, 0o700)
    os.chmod(cache / diskcache.KEY_FILE, 0o644)
    diskcache._state.pop("ready", None)
    assert diskcache.fetch("k", b"source") is None
    os.chmod(cache / diskcache.KEY_FILE, 0o600)
    diskcache._state.pop("ready", None)
    assert diskcache.fetch("k", b"source") == b"payload"


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() != 0, reason="chown needs root")
def test_a_foreign_owner_turns_the_cache_off(cache):
    assert diskcache.store("k", b"source", b"payload")
    os.chown(cache, 4242, 4242)
    diskcache._state.pop("ready", None)
    assert diskcache.fetch("k", b"source") is None
    assert any("owned by another user" in n for n in diskcache.notes)
    os.chown(cache, 0, 0)
    os.chown(_entry(cache), 4242, 4242)            # an entry someone else wrote
    diskcache._state.pop("ready", None)
    assert diskcache.fetch("k", b"source") is None


def test_an_off_switch(cache, monkeypatch):
    monkeypatch.setenv(diskcache.ENV, "off")
    assert not diskcache.store("k", b"source", b"payload")
    assert not cache.exists()


def test_the_least_recently_used_entries_are_pruned(cache):
    for i in range(5):
        diskcache.store("k", str(i).encode(), b"x" * 100)
        os.utime(cache / diskcache.entry_name("k", str(i).encode()), ns=(i * 10**9, i * 10**9))
    diskcache.fetch("k", b"0")                       # used: now the most recent
    diskcache.prune(cache, entries=2)
    assert diskcache.fetch("k", b"0") is not None and diskcache.fetch("k", b"4") is not None
    assert all(diskcache.fetch("k", str(i).encode()) is None for i in (1, 2, 3))


WRITER = textwrap.dedent("""
    import sys
    from fdi import diskcache
    for i in range(40):
        assert diskcache.store("k", b"shared", sys.argv[1].encode() * 2000)
        got = diskcache.fetch("k", b"shared")
        assert got in (b"a" * 2000, b"b" * 2000), got[:20]
    print("ok")
""")


def test_two_writers_at_once_agree_on_one_key_and_leave_a_whole_entry(cache):
    procs = [subprocess.Popen(PY + ["-c", WRITER, w], cwd=ROOT, env=_env(cache), stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True) for w in "ab"]
    outs = [p.communicate(timeout=120) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], [o[1][-500:] for o in outs]
    assert diskcache.fetch("k", b"shared") in (b"a" * 2000, b"b" * 2000)
    assert not list(cache.glob(".tmp-*")) and not list(cache.glob(".key-*"))


def test_the_cached_monitor_diagnoses_as_the_fresh_one(cache):
    """Three processes: the first derives and stores, the second reads the entry back, the third
    derives with the cache off. Same report bytes; the residuals on scenario 2 the same floats."""
    script = textwrap.dedent(f"""
        import json, sys
        import numpy as np
        from fdi.monitor import compiled, persist
        from fdi.data import read_csv
        from fdi.options import Options
        from fdi.residuals import evaluate
        m = compiled({str(CYCAB)!r})
        d = m.diagnose({str(DATA / 'scenario3.csv')!r}, Options(workers=1))
        persist(m)
        data = read_csv({str(DATA / 'scenario2.csv')!r})
        from fdi.data import signals_from_data
        r = evaluate(m.model, list(m.residuals), signals_from_data(m.model, data), data.ts)
        np.save(sys.argv[1], np.asarray(r))
        print(json.dumps(d.to_dict()))
        print(json.dumps(sorted(sys.modules)))
    """)
    runs = []
    for i, env in enumerate((_env(cache), _env(cache), {**_env(cache), diskcache.ENV: "off"})):
        out = subprocess.run(PY + ["-c", script, str(cache.parent / f"r{i}.npy")], cwd=ROOT, env=env,
                             capture_output=True, text=True, timeout=300)
        assert out.returncode == 0, out.stderr[-2000:]
        report, modules = out.stdout.splitlines()[-2:]
        runs.append((report, set(json.loads(modules)), np.load(cache.parent / f"r{i}.npy")))
    assert runs[0][0] == runs[1][0] == runs[2][0]
    assert json.loads(runs[0][0])["diagnosis"]["faults"][0]["name"] == "a1"      # the burnt driver (README)
    assert np.array_equal(runs[0][2], runs[1][2], equal_nan=True)
    assert np.array_equal(runs[1][2], runs[2][2], equal_nan=True)
    assert "fdi.selection" in runs[0][1] and "fdi.selection" not in runs[1][1]   # the second derived nothing


@pytest.mark.parametrize("model, data", [
    (CYCAB, DATA / "scenario3.csv"),                                  # a mode fault, isolated
    (ROOT / "models" / "hydraulic_actuator.yaml", ROOT / "tests" / "golden" / "hydraulic_clog.csv.gz"),
    (ROOT / "tests" / "data" / "drained_tank.yaml", "clog"),
], ids=["cycab_mode_fault", "hydraulic_stored_quantity", "faults_read_together"])
def test_a_warm_diagnose_process_imports_neither_sympy_nor_networkx(cache, tmp_path, model, data):
    """``bgfdi diagnose`` twice: the second process reads the compiled model and imports neither
    sympy (the model's expressions, the AGARRs and each residual's expression stay pickled bytes:
    bondgraph.deferred) nor networkx nor the modules that derive residuals, and writes the same
    report. The hydraulic actuator's residuals differentiate stored quantities (the chamber's
    C p), identified with its clogging: the rate shared between residuals is found without sympy.
    The drained tank's clog (tests/independent/drained_tank.py) has an alternative read together
    with the winner (fdi.identifiability): the pair travels with the compiled model."""
    if data == "clog":
        from .independent import drained_tank
        cols = drained_tank.simulate(7, t0=60.0, factor=0.7)
        data = tmp_path / "clog.csv"
        np.savetxt(data, np.column_stack([cols[c] for c in ("t", "Qin", "Qout")]), delimiter=",",
                   header="t,Qin,Qout", comments="", fmt="%.12g")
        text = model.read_text(encoding="utf-8") + "thresholds: {ARR1: 0.008}\n"   # calibrated: 0.0080 m^3/s
        model = tmp_path / "drained_tank.yaml"
        model.write_text(text, encoding="utf-8")
    if str(data).endswith(".gz"):
        import gzip
        plain = tmp_path / "data.csv"
        plain.write_bytes(gzip.decompress(data.read_bytes()))
        data = plain
    script = textwrap.dedent(f"""
        import json, sys
        from fdi.app.cli import main
        code = main(["diagnose", {str(model)!r}, {str(data)!r}, "-q", "--json", "--workers", "1"])
        sys.stdout.flush()
        print(json.dumps([code, sorted(sys.modules)]))
    """)
    seen = []
    for _ in range(2):
        out = subprocess.run(PY + ["-c", script], cwd=ROOT, env=_env(cache), capture_output=True, text=True,
                             timeout=300)
        assert out.returncode == 0, out.stderr[-2000:]
        *report, last = out.stdout.splitlines()
        code, modules = json.loads(last)
        assert code == 0
        seen.append(("\n".join(report), set(modules)))
    (cold_report, cold), (warm_report, warm) = seen
    derivation = {"sympy", "networkx", "fdi.arrs", "fdi.selection", "fdi.modewise", "fdi.isolability", "fdi.scaph"}
    assert derivation <= cold                        # the first process derived (the test can see it)
    assert not derivation & warm, sorted(derivation & warm)
    assert json.loads(warm_report) == json.loads(cold_report)
    assert json.loads(warm_report)["diagnosis"]["faults"]
    if model.name == "drained_tank.yaml":
        assert any(a["coincides"] for a in json.loads(warm_report)["alternatives"])
        assert "fdi.identifiability" not in warm


def test_a_worker_that_receives_a_compiled_monitor_imports_no_sympy(tmp_path):
    """A monitor pickled as a pool or a dask cluster sends it (fdi.persist) and unpickled in a fresh
    process with the cache off: the worker diagnoses without importing sympy, as the process that
    derived it does, report for report (the faults' linear transforms travel with it)."""
    from fdi.monitor import compiled
    from fdi.options import Options
    m = compiled(str(CYCAB))
    options = Options(workers=1, pop=12, generations=5, seed=3)
    here = m.diagnose(str(DATA / "scenario2.csv"), options).to_dict()
    (tmp_path / "m.pickle").write_bytes(pickle.dumps((m, options)))
    script = textwrap.dedent(f"""
        import json, pickle, sys
        m, options = pickle.loads(open({str(tmp_path / 'm.pickle')!r}, "rb").read())
        d = m.diagnose({str(DATA / 'scenario2.csv')!r}, options)
        print(json.dumps([d.to_dict(), "sympy" in sys.modules]))
    """)
    env = {**os.environ, diskcache.ENV: "off", "PYTHONPATH": str(ROOT)}
    out = subprocess.run(PY + ["-c", script], cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    there, imported = json.loads(out.stdout.splitlines()[-1])
    assert not imported
    assert there == json.loads(json.dumps(here))
    assert [f["name"] for f in there["diagnosis"]["faults"]] == ["R4", "beta_theta2"]    # the paper's scenario 2


def _in_two_processes(script: str, cache) -> list:
    """``script`` run in two fresh processes one after the other, sharing the cache: each one's last
    printed line, read as JSON."""
    seen = []
    for _ in range(2):
        out = subprocess.run(PY + ["-c", script], cwd=ROOT, env=_env(cache), capture_output=True, text=True,
                             timeout=300)
        assert out.returncode == 0, out.stderr[-2000:]
        seen.append(json.loads(out.stdout.splitlines()[-1]))
    return seen


def test_the_api_keeps_what_a_diagnosis_derived_for_the_next_process(cache):
    """``fdi.api.diagnose`` twice, in two processes: the first derives the model's time scales (a
    simulation system per mode, their eigenvalues) and keeps them with the compiled model, as the
    CLI does; the second derives none (they cost every API process 0.27 s of its first diagnosis)."""
    script = textwrap.dedent(f"""
        import json, sys
        import bondgraph.timescales as T
        calls = []
        inner = T.time_scales
        T.time_scales = lambda *a, **k: calls.append(1) or inner(*a, **k)
        from fdi.api import diagnose
        d = diagnose({str(CYCAB)!r}, {str(DATA / 'scenario2.csv')!r}, workers=1, pop=12, generations=5)
        print(json.dumps([len(calls), d.to_dict()["detection"]["time"]]))
    """)
    seen = _in_two_processes(script, cache)
    (first, t1), (second, t2) = seen
    assert first > 0 and second == 0 and t1 == t2


def test_a_stream_from_the_api_keeps_what_it_derived_for_the_next_process(cache):
    """``compiled(path).stream(...)`` twice, in two processes: the first stream derives the model's
    time scales (its settling time and detection rule need them) and, closed, keeps them with the
    compiled model; the second derives none (before, only the CLI and ``diagnose`` kept them, and a
    notebook's streams derived the simulation system again in every process: the CyCab's 1.2 s)."""
    script = textwrap.dedent(f"""
        import json
        import bondgraph.timescales as T
        calls = []
        inner = T.time_scales
        T.time_scales = lambda *a, **k: calls.append(1) or inner(*a, **k)
        from fdi.api import Options
        from fdi.data import read_csv
        from fdi.monitor import compiled
        import numpy as np
        data = read_csv({str(DATA / 'nominal.csv')!r})
        header = ["t"] + [k for k in data.columns if k != "t"]
        table = np.column_stack([data.t] + [data.columns[k] for k in header[1:]])
        events = []
        s = compiled({str(CYCAB)!r}).stream(events.append, Options(workers=1))
        s.feed(header, table[:3000])
        s.close()
        print(json.dumps([len(calls), events[-1]["event"]]))
    """)
    seen = _in_two_processes(script, cache)
    (first, e1), (second, e2) = seen
    assert first > 0 and second == 0 and e1 == e2 == "summary"


def test_no_cache_option_derives_afresh(cache):
    out = subprocess.run(PY + ["-m", "fdi", "diagnose", str(CYCAB), str(DATA / "scenario3.csv"), "-q", "--no-cache"],
                         cwd=ROOT, env=_env(cache), capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert not list(cache.glob("*" + diskcache.SUFFIX))


def test_a_kernel_read_back_computes_what_sympy_computes(cache):
    """The persisted kernel against sympy's own numeric evaluation of the residual's expression."""
    from fdi.persist import pack, restore
    m = Monitor(str(ROOT / "models" / "two_tank_valve.yaml"))
    back = restore(pack(m))
    for fresh, read in zip(m.residuals, back["_residuals"]):
        assert read.signals == fresh.signals and read.symbols == fresh.symbols
        rng = np.random.default_rng(1)
        args = [rng.uniform(0.5, 2.0, 7) for _ in range(len(fresh.signals) + len(fresh.composites) + len(fresh.symbols))]
        assert np.array_equal(read.func(*args), fresh.func(*args))


def test_a_monitor_read_from_disk_is_packed_again_for_workers(cache, monkeypatch):
    """A warm fleet ships the monitor it read from disk to its workers compiled (none derives):
    the kernels compiled from their source keep it, and the bytes read back give the same kernels."""
    from collections import OrderedDict

    from fdi import monitor as mon
    from fdi.persist import pack, restore
    path = str(ROOT / "models" / "two_tank_valve.yaml")
    monkeypatch.setattr(mon, "_files", OrderedDict())
    fresh = mon.compiled(path)                       # derived, stored
    monkeypatch.setattr(mon, "_files", OrderedDict())
    warm = mon.compiled(path)                        # read back
    assert getattr(warm, "_disk", None) is not None and warm is not fresh
    again = pack(warm)
    assert again is not None
    back = restore(again)["_residuals"]
    rng = np.random.default_rng(2)
    for f, b in zip(fresh.residuals, back):
        args = [rng.uniform(0.5, 2.0, 5) for _ in range(len(f.signals) + len(f.composites) + len(f.symbols))]
        assert np.array_equal(f.func(*args), b.func(*args))
