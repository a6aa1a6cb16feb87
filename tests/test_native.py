"""The C kernels' builder and loader (optim.native): a library is built by the machine's compiler,
kept by a store and loaded again without a compiler; a build that fails, a missing compiler and a
planted or damaged entry of bgfdi's disk cache each leave a note and a working process (the
kernels fall back to numba or numpy), never a crash or a foreign library loaded."""
from __future__ import annotations

import numpy as np
import pytest

from optim import native

pytestmark = pytest.mark.skipif(native.compiler() is None, reason="no C compiler on this machine")

SOURCE = b"#include <stdint.h>\nint64_t add3(int64_t a) { return a + 3; }\n"
SIG = {"add3": ("i", "i")}
BUILD = native._build


class DictStore:
    """A store in memory, counting what it was asked."""

    def __init__(self) -> None:
        self.entries: dict = {}
        self.fetches = 0

    def fetch(self, kind, source):
        self.fetches += 1
        return self.entries.get((kind, source))

    def store(self, kind, source, payload):
        self.entries[(kind, source)] = payload
        return True

    def ready(self):
        return True


@pytest.fixture
def fresh(monkeypatch):
    """No library loaded in this process, no store: each test sets its own."""
    monkeypatch.setattr(native, "_loaded", {})
    monkeypatch.setattr(native, "_store", None)
    monkeypatch.setattr(native, "notes", [])


def test_a_built_library_is_kept_and_loaded_again_without_a_compiler(fresh, monkeypatch):
    store = DictStore()
    native.use_store(store)
    lib = native.load("t_add", SOURCE, SIG)
    assert lib.add3(4) == 7
    assert len(store.entries) == 1 and next(iter(store.entries))[0] == "clib-t_add"
    monkeypatch.setattr(native, "_loaded", {})
    monkeypatch.setattr(native, "compiler", lambda: None)      # the build cannot run: the store serves
    monkeypatch.setattr(native, "_build", lambda *a: pytest.fail("built again"))
    again = native.load("t_add", SOURCE, SIG)
    assert again.add3(-10) == -7


def test_no_compiler_and_a_failed_build_leave_a_note_and_none(fresh, monkeypatch):
    assert native.load("t_bad", b"int broken( { return ; }\n", {}) is None
    assert "t_bad:" in native.notes[-1] and "error" in native.notes[-1]
    monkeypatch.setattr(native, "compiler", lambda: None)
    assert native.load("t_none", SOURCE, SIG) is None
    assert "no C compiler" in native.notes[-1]


def test_the_library_depends_on_source_flags_and_processor(monkeypatch):
    a = native._identity(SOURCE)
    assert a != native._identity(SOURCE + b"\n")
    monkeypatch.setattr(native, "FLAGS", native.FLAGS + ("-O0",))
    assert a != native._identity(SOURCE)
    monkeypatch.undo()
    monkeypatch.setattr(native, "cpu", lambda: "another processor")
    assert a != native._identity(SOURCE)


def test_a_planted_or_damaged_cache_entry_is_never_loaded(fresh, tmp_path, monkeypatch):
    """bgfdi's disk cache as the store: an entry written by someone without the folder's key (a
    library of theirs), or a kept library cut short, is refused and the library built again."""
    from fdi import diskcache
    monkeypatch.setenv("BGFDI_CACHE", "on")
    monkeypatch.setenv("BGFDI_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(diskcache, "_state", {})
    native.use_store(diskcache)
    assert native.has_store()
    assert native.load("t_add", SOURCE, SIG).add3(1) == 4
    entry = tmp_path / "cache" / diskcache.entry_name("clib-t_add", native._identity(SOURCE))
    good = entry.read_bytes()
    other = SOURCE.replace(b"a + 3", b"a + 1000")
    for planted in (good[:len(good) // 2], good[:len(diskcache.MAGIC)] + b"\0" * 32 + native._build("x", other,
                                                                                                    native.compiler())):
        entry.write_bytes(planted)
        monkeypatch.setattr(native, "_loaded", {})
        assert native.load("t_add", SOURCE, SIG).add3(1) == 4          # built again: theirs not loaded
        assert entry.read_bytes() != planted                            # and the entry stored anew


def test_auto_takes_c_when_libraries_are_kept_and_the_numbers_do_not_change(fresh):
    """With a store, ``auto`` runs C; the objective's kernels give numba's numbers (test_kernels
    compares every function): here eq. (17) on one row, against its closed form."""
    from fdi import kernels as fk
    from optim import kernels
    native.use_store(DictStore())
    before = kernels.use("auto")
    try:
        assert kernels.path() == "c"
        jit = fk.jit()
        assert jit.__name__ == "fdi._native"
        t = np.linspace(0.0, 2.0, 5)
        got = jit.incipient17(t, np.array([0.5]), 2.0, np.array([0.1]))
        tau = np.maximum(t - 0.5, 0.0)
        assert np.allclose(got[0], np.where(t >= 0.5, 1.0 / (0.5 - 0.1 * tau), 2.0), rtol=1e-15)
    finally:
        kernels.use(before)


def test_kernels_paths_are_checked():
    from optim import kernels
    with pytest.raises(ValueError, match="expected one of auto, c, numba, numpy"):
        kernels.use("fortran")


def test_a_misspelt_kernels_setting_is_refused_by_the_cli(monkeypatch, capsys):
    from fdi.app.cli import main
    monkeypatch.setenv("BGFDI_KERNELS", "fortran")
    assert main(["check", "cycab_steering"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["bgfdi: error: BGFDI_KERNELS=fortran: expected one of auto, c, numba, numpy (or unset it: auto)"]


def test_a_compiler_that_fails_leaves_the_numbers_to_another_path(fresh, monkeypatch, tmp_path):
    """$CC naming a program that exits 1 (here /bin/false's kind): no library, a note, and the
    kernels' switch takes numba or numpy; the diagnosis does not notice."""
    fake = tmp_path / "cc"
    fake.write_text("#!/bin/sh\nexit 1\n")
    fake.chmod(0o755)
    monkeypatch.setenv("CC", str(fake))
    assert native.load("t_fails", SOURCE, SIG) is None
    assert native.notes[-1].startswith(f"t_fails: {fake} could not build it")


def test_a_failed_build_is_not_tried_again_until_the_compiler_changes(fresh, monkeypatch, tmp_path):
    """Designed: a compiler that fails once is remembered by the store (every later process would
    pay its failed attempt); the note says why, and another compiler (or this one updated) is tried."""
    store = DictStore()
    native.use_store(store)
    fake = tmp_path / "cc"
    fake.write_text("#!/bin/sh\necho 'error: no headers' >&2\nexit 1\n")
    fake.chmod(0o755)
    monkeypatch.setenv("CC", str(fake))
    assert native.load("t_once", SOURCE, SIG) is None
    runs = []
    monkeypatch.setattr(native, "_loaded", {})
    monkeypatch.setattr(native, "_build", lambda *a: runs.append(a) or None)
    assert native.load("t_once", SOURCE, SIG) is None and runs == []          # a later process: not tried
    assert "could not build it (error: no headers)" in native.notes[-1] and "not tried again" in native.notes[-1]
    fake.write_text("#!/bin/sh\nexit 1\n\n")                                # the compiler updated
    monkeypatch.setattr(native, "_loaded", {})
    assert native.load("t_once", SOURCE, SIG) is None and len(runs) == 1
    monkeypatch.setattr(native, "_loaded", {})
    monkeypatch.setattr(native, "_build", BUILD)
    monkeypatch.delenv("CC")                                                   # the machine's own compiler
    assert native.load("t_once", SOURCE, SIG).add3(1) == 4



def test_a_diagnosis_on_the_c_path_is_numba_s_to_the_bit():
    """CyCab scenario 2 diagnosed end to end (a small search: population 30, 20 generations) on the
    C kernels and on numba's: the same report, every number (the trials, the objective, the
    profiles and the medians agree to the bit; tests/test_kernels.py compares them one by one)."""
    from fdi.api import Options, diagnose
    from fdi.app.resources import reference_data, shipped_model
    from optim import kernels
    if "numba" not in kernels.available():
        pytest.skip("numba is not installed")
    got = {}
    for path in ("c", "numba"):
        before = kernels.use(path)
        try:
            assert kernels.path() == path
            report = diagnose(shipped_model("cycab_steering"), reference_data("scenario2.csv"),
                              Options(pop=30, generations=20, workers=1, seed=2)).to_dict()
        finally:
            kernels.use(before)
        report.pop("timings", None)
        got[path] = report
    assert got["c"]["diagnosis"]["faults"] and got["c"] == got["numba"]


def test_no_room_for_the_build_leaves_a_note_not_a_crash(fresh, monkeypatch, tmp_path):
    """A temporary folder that cannot be used (here a file where the folder should be; a full disk,
    a read-only TMPDIR alike): no library, a note naming why, and no exception out of the loader
    (the kernels' switch then takes numba or numpy)."""
    import tempfile
    blocked = tmp_path / "not_a_folder"
    blocked.write_text("")
    monkeypatch.setattr(tempfile, "tempdir", str(blocked))
    assert native.load("t_noroom", SOURCE, SIG) is None
    assert native.notes[-1].startswith("t_noroom: cannot build or load it here")


def _knows_v2() -> bool:
    """Whether this machine's compiler builds for -march=x86-64-v2 (GCC 11 on, clang 12 on)."""
    import subprocess
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        src = f"{tmp}/t.c"
        with open(src, "w") as fh:
            fh.write("int f(void) { return 1; }\n")
        return subprocess.run([native.compiler(), "-march=x86-64-v2", "-c", src, "-o", f"{tmp}/t.o"],
                              capture_output=True).returncode == 0


@pytest.mark.skipif(native.FALLBACKS == ((),) or native.compiler() is None or not _knows_v2(),
                    reason="x86-64-v2: its processors and compilers")
def test_a_compiler_that_refuses_march_native_builds_for_x86_64_v2_then_for_none(fresh, monkeypatch, tmp_path):
    """A compiler that refuses -march=native (a cross or older compiler) builds for x86-64's second
    level (SSE4.2, where the kernels' exponential and trigonometric loops still vectorise), and
    one that refuses that too builds without -march: the library loads and computes either way."""
    real = native.compiler()
    log = tmp_path / "flags"
    for refused, used in (("native", "-march=x86-64-v2"), ("*", "")):
        fake = tmp_path / "cc"
        fake.write_text(f"#!/bin/sh\ncase \"$*\" in *-march={refused}*) exit 1;; esac\n"
                        f"echo \"$*\" > {log}\nexec {real} \"$@\"\n")
        fake.chmod(0o755)
        monkeypatch.setenv("CC", str(fake))
        monkeypatch.setattr(native, "_loaded", {})
        lib = native.load(f"t_level_{len(used)}", SOURCE, SIG)
        assert lib is not None and lib.add3(4) == 7
        flags = log.read_text()
        assert (used in flags if used else "-march" not in flags), flags
