"""C sources built into shared libraries by the machine's C compiler and loaded with ctypes.

Why: numba's compiled kernels cost every process 0.65 s before their first result (numba's import
and the first call's loading of its lowering registries, measured on a one-line function), more than
a whole short diagnosis computes. A library built from C once per machine loads in about a
millisecond, and needs neither numba nor a JIT. The kernels' C (``optim/trials.c``,
``fdi/kernels.c``) does the numba functions' operations in their order, so the numbers are the
same (tests/test_kernels.py, tests/test_optim.py).

The compiler is ``$CC``, else ``cc``, ``gcc`` or ``clang`` on the PATH; the flags keep IEEE
arithmetic as written (:data:`FLAGS`: no fast-math, no contraction into fused multiply-adds). A
built library is kept by a *store* (:func:`use_store`; bgfdi gives its disk cache,
:mod:`fdi.diskcache`: a private folder, entries signed with a key only the user can read, so a
planted or stale file is never loaded) and loaded from a private temporary copy. Without a store
each process builds its own (about a second). A build that fails is remembered by the store with
the compiler it failed with (path, size, modification time), so later processes go straight to
the other kernels' path until the compiler or ``CC`` changes.

>>> lib = load("doctest", b"double twice(double x) { return 2 * x; }", {"twice": ("d", "d")})
>>> lib is None or lib.twice(1.5) == 3.0
True
"""
from __future__ import annotations

import ctypes
import hashlib
import os
import platform
import shutil
import subprocess
import sys
import tempfile
from typing import Protocol

import numpy as np

# IEEE arithmetic as written: no fast-math (it reorders sums), no contraction into fused
# multiply-adds (they change last bits); errno and traps ignored (numba's assumptions too: the
# loops over samples then vectorise; the values are the same). -fno-fast-math first: given after
# them, it turned errno and traps back on (GCC 12), and the loops with selects stayed scalar
FLAGS = ("-O3", "-std=c99", "-fPIC", "-shared", "-fno-fast-math", "-ffp-contract=off", "-fno-math-errno",
         "-fno-trapping-math")
NATIVE = ("-march=native",)     # this machine's vector units (its CPU is in the library's key); dropped if refused
# ... for x86-64's second level where the processor has it (SSE4.2: the kernels' exponential, cos,
# sin and tan loops still vectorise, where a build without -march keeps them scalar at about twice
# libm's time), then none


def _has_sse42() -> bool:
    """Whether this Linux machine's processor reports SSE4.2 (x86-64-v2's newest part)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as fh:
            return any(line.startswith("flags") and " sse4_2" in line for line in fh.read(1 << 16).splitlines())
    except OSError:
        return False


FALLBACKS = ((("-march=x86-64-v2",),) if platform.machine().lower() in ("x86_64", "amd64") and _has_sse42()
             else ()) + ((),)
TIMEOUT_S = 60.0        # a build that takes longer is abandoned (the callers fall back); it takes 1-2 s

_TYPES = {"d": ctypes.c_double, "i": ctypes.c_int64, "p": ctypes.c_void_p, "r": ctypes.c_int}


class Store(Protocol):
    """Where built libraries are kept between processes (:func:`use_store`)."""

    def fetch(self, kind: str, source: bytes) -> bytes | None: ...
    def store(self, kind: str, source: bytes, payload: bytes) -> bool: ...
    def ready(self) -> bool: ...


_store: Store | None = None
_loaded: dict[str, object] = {}
notes: list[str] = []          # why a library could not be built (for -v and the benches)


def use_store(store: Store | None) -> None:
    """Keep built libraries in ``store`` (None: build in each process)."""
    global _store
    _store = store


def has_store() -> bool:
    """True when built libraries outlive the process (a store is set and can be written)."""
    return _store is not None and _store.ready()


def compiler() -> str | None:
    """The C compiler's path: ``$CC`` (its first word), else cc, gcc or clang on the PATH; None without one."""
    given = os.environ.get("CC", "").split()
    for name in ([given[0]] if given else []) + ["cc", "gcc", "clang"]:
        found = shutil.which(name)
        if found:
            return found
    return None


def cpu() -> str:
    """This machine's processor as a library built with :data:`NATIVE` depends on it: the model and
    feature flags the kernel reports (Linux), else what :mod:`platform` says. A home folder shared
    by machines of different processors then keeps one library per processor."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as fh:
            lines = fh.read(1 << 16).splitlines()
        keep = [line for line in lines if line.split(":")[0].strip() in ("model name", "flags", "Features", "CPU part")]
        if keep:
            return hashlib.sha256("\n".join(sorted(set(keep))).encode()).hexdigest()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _identity(source: bytes) -> bytes:
    """What a built library depends on: the source, the flags and the machine (not which compiler
    built it: any gives the arithmetic as written, and a library kept loads without one)."""
    return b"\0".join([source, " ".join(FLAGS + NATIVE).encode(), repr(FALLBACKS).encode(), platform.machine().encode(),
                       sys.platform.encode(), cpu().encode()])


def load(name: str, source: bytes, signatures: dict[str, tuple[str, str]]) -> object | None:
    """The library built from C ``source`` with its functions typed by ``signatures`` (name ->
    (result code, argument codes): ``d`` double, ``i`` int64, ``p`` a pointer, ``r`` int), once per
    process; None when there is no compiler or the build fails (a note in :data:`notes` says why)."""
    key = name + ":" + hashlib.sha256(source).hexdigest()
    if key in _loaded:
        return _loaded[key]
    try:
        lib = _load(name, source)
    except OSError as exc:                  # no temporary folder, a full disk: the other paths run
        notes.append(f"{name}: cannot build or load it here ({exc.strerror or exc})")
        lib = None
    if lib is not None:
        for fn, (res, args) in signatures.items():
            f = getattr(lib, fn)
            f.restype = _TYPES[res]
            f.argtypes = [_TYPES[c] for c in args]
    _loaded[key] = lib
    return lib


def require(name: str, package_file: str, c_file: str, signatures: dict[str, tuple[str, str]]) -> ctypes.CDLL:
    """:func:`load` of the C source ``c_file`` beside ``package_file``, or ImportError with the note
    why (a kernels module that cannot be built is not importable: the switch takes another path)."""
    lib = load(name, source(package_file, c_file), signatures)
    if lib is None:
        raise ImportError("the C kernels could not be built: " + "; ".join(notes[-1:]))
    return lib


def floats(a) -> np.ndarray:
    """``a`` as a C-contiguous float64 array (no copy when it is one)."""
    return np.ascontiguousarray(a, dtype=np.float64)


def ints(a) -> np.ndarray:
    """``a`` as a C-contiguous int64 array (no copy when it is one)."""
    return np.ascontiguousarray(a, dtype=np.int64)


def _load(name: str, source: bytes) -> ctypes.CDLL | None:
    cc = compiler()
    ident = _identity(source)
    kind = "clib-" + name
    payload = _store.fetch(kind, ident) if _store is not None else None
    if payload is None:
        if cc is None:
            notes.append(f"{name}: no C compiler (set CC or install cc)")
            return None
        failed = ident + b"\0" + _tool(cc)
        if _store is not None and (why := _store.fetch("clib-failed-" + name, failed)) is not None:
            notes.append(why.decode(errors="replace") + " (not tried again with this compiler: change CC or "
                         "update it to try again)")
            return None
        payload = _build(name, source, cc)
        if payload is None:
            if _store is not None and notes:             # each later process skips the failing build
                _store.store("clib-failed-" + name, failed, notes[-1].encode())
            return None
        if _store is not None:
            _store.store(kind, ident, payload)
    return _open(name, payload)


def _tool(cc: str) -> bytes:
    """Which compiler a failed build was tried with: its path, size and modification time (an
    updated or another compiler is tried again)."""
    try:
        st = os.stat(cc)
        return f"{os.path.realpath(cc)}:{st.st_size}:{st.st_mtime_ns}".encode()
    except OSError:
        return cc.encode()


def _build(name: str, source: bytes, cc: str) -> bytes | None:
    """The shared library's bytes, built in a private temporary folder."""
    with tempfile.TemporaryDirectory(prefix="bgfdi-cc-") as tmp:
        src, out = os.path.join(tmp, name + ".c"), os.path.join(tmp, name + ".so")
        with open(src, "wb") as fh:
            fh.write(source)
        for native in (NATIVE, *FALLBACKS):
            try:
                done = subprocess.run([cc, *FLAGS, *native, "-o", out, src, "-lm"], capture_output=True,
                                      timeout=TIMEOUT_S, stdin=subprocess.DEVNULL)
            except (OSError, subprocess.TimeoutExpired) as exc:
                notes.append(f"{name}: the C compiler {cc} failed to run ({exc})")
                return None
            if done.returncode == 0 and os.path.exists(out):
                break
        if done.returncode != 0 or not os.path.exists(out):
            lines = done.stderr.decode(errors="replace").strip().splitlines() or ["no message"]
            first = next((line for line in lines if "error" in line), lines[0])
            notes.append(f"{name}: {cc} could not build it ({first})")
            return None
        with open(out, "rb") as fh:
            return fh.read()


def _open(name: str, payload: bytes) -> ctypes.CDLL | None:
    """Load library bytes from a private temporary copy (removed once loaded, where the system allows)."""
    tmp = tempfile.mkdtemp(prefix="bgfdi-lib-")          # 0700
    path = os.path.join(tmp, name + ".so")
    try:
        with open(path, "wb") as fh:
            fh.write(payload)
        try:
            return ctypes.CDLL(path)
        except OSError as exc:
            notes.append(f"{name}: the built library does not load ({exc})")
            return None
    finally:
        try:
            os.unlink(path)
            os.rmdir(tmp)
        except OSError:
            pass


_buffer = ctypes.c_char.from_buffer


def address(a) -> int:
    """The address of a C-contiguous numpy array's first element: 0.3 us by the buffer protocol
    where ``a.ctypes.data`` takes 0.9 us (a read-only or empty array takes that way)."""
    try:
        return ctypes.addressof(_buffer(a))
    except (TypeError, ValueError):
        return a.ctypes.data


def source(package_file: str, name: str) -> bytes:
    """The C source ``name`` beside the module file ``package_file``."""
    with open(os.path.join(os.path.dirname(os.path.abspath(package_file)), name), "rb") as fh:
        return fh.read()

