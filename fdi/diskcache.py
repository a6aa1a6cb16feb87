"""A per-user cache of compiled models on disk, safe against planted, stale and tampered files.

A process that diagnoses pays for the derivation of its model (residual selection, kernels, time
scales, signature matrices) before its first sample; this cache keeps the result between processes
so a warm run starts in milliseconds. Loading a pickle runs code, so nothing is unpickled that this
user's bgfdi did not write:

- the folder is ``$BGFDI_CACHE_DIR``, else ``$XDG_CACHE_HOME/bgfdi``, else ``~/.cache/bgfdi``, made
  0700; it is refused (cache off, one note) unless this user owns it and no one else may write
  it (nor read it: the key lives there);
- every entry is authenticated by an HMAC-SHA256 under a random 32-byte key kept in a 0600 file
  of that folder (made once, atomically), and the HMAC, which also binds the entry's name, is
  checked **before** the payload is unpickled; a planted, truncated, tampered, renamed or foreign
  entry, or one written under another key, is ignored (and rebuilt by the caller);
- the entry's name is a digest of what it was derived from and of everything that could change
  the result: the bgfdi version, a fingerprint of bgfdi's own source files (size and mtime of
  each, so an edited checkout never serves a stale derivation), Python, numpy and sympy;
- entries are written atomically (a temporary file, then a rename), so a concurrent reader sees
  the old entry, the new one, or none; the folder is pruned to :data:`MAX_ENTRIES` entries and
  :data:`MAX_BYTES`, least recently used first;
- ``BGFDI_CACHE=off`` (or ``--no-cache`` on the command line) turns it off.

>>> import os, tempfile
>>> saved = {k: os.environ.pop(k, None) for k in (ENV, DIR_ENV)}
>>> os.environ[DIR_ENV] = tempfile.mkdtemp()
>>> store("demo", b"some text", b"payload")
True
>>> fetch("demo", b"some text"), fetch("demo", b"other text")
(b'payload', None)
>>> _ = [os.environ.pop(k, None) if v is None else os.environ.__setitem__(k, v) for k, v in saved.items()]
"""
from __future__ import annotations

import hashlib
import hmac
import os
import secrets
import stat
import sys
import tempfile
from pathlib import Path

ENV = "BGFDI_CACHE"              # "off" (or 0, no, false) turns the cache off
DIR_ENV = "BGFDI_CACHE_DIR"      # the folder, instead of $XDG_CACHE_HOME/bgfdi
MAGIC = b"BGFDI-CACHE-1\n"       # an entry: MAGIC, 32 bytes of HMAC, the payload
KEY_FILE = "key"
SUFFIX = ".entry"
MAX_ENTRIES = 64                 # least recently used entries beyond these are removed
MAX_BYTES = 64 << 20             # and beyond this total size
_OFF = {"off", "0", "no", "false"}

notes: list[str] = []            # why the cache is off, if it is, and where each compiled model came from (-v prints them)
_state: dict[str, object] = {}


def enabled() -> bool:
    """The cache is on unless ``BGFDI_CACHE`` says off."""
    return os.environ.get(ENV, "").strip().lower() not in _OFF


def disable() -> None:
    """Turn the cache off in this process and the processes it starts (``--no-cache``)."""
    os.environ[ENV] = "off"


def folder() -> Path:
    """Where the cache lives (not checked: :func:`_ready` checks)."""
    given = os.environ.get(DIR_ENV)
    if given:
        return Path(given)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "bgfdi"


def note(text: str) -> None:
    """Keep a line for -v (once): why the cache is off, where a compiled model came from."""
    if text not in notes:
        notes.append(text)


def _private(st: os.stat_result, what: str, path: Path, mask: int) -> bool:
    """``path`` is ours and no one else may use it (``mask``: the forbidden permission bits)."""
    if hasattr(os, "getuid") and st.st_uid != os.getuid():
        note(f"cache off: {what} {path} is owned by another user (uid {st.st_uid}); remove it or set {DIR_ENV}")
        return False
    if st.st_mode & mask:
        note(f"cache off: {what} {path} has mode {stat.S_IMODE(st.st_mode):o}; "
              f"make it {0o700 if what == 'folder' else 0o600:o} (chmod) or set {DIR_ENV}")
        return False
    return True


def ready() -> bool:
    """True when entries can be read and written here (the cache on, its folder and key checked)."""
    return _ready() is not None


def _ready() -> tuple[Path, bytes] | None:
    """The checked folder and the HMAC key, or None (cache off, with a note)."""
    if not enabled():
        return None
    where = folder()
    cached = _state.get("ready")
    if cached is not None and cached[0] == where:
        return cached[1]
    out = _open(where)
    _state["ready"] = (where, out)
    return out


def _open(where: Path) -> tuple[Path, bytes] | None:
    try:
        where.mkdir(mode=0o700, parents=True, exist_ok=True)
        st = os.lstat(where)
    except OSError as exc:
        note(f"cache off: cannot make the folder {where} ({exc.strerror or exc})")
        return None
    if not stat.S_ISDIR(st.st_mode):
        note(f"cache off: {where} is not a folder (a link or a file); remove it or set {DIR_ENV}")
        return None
    if not _private(st, "folder", where, 0o077 if os.name == "posix" else 0):
        return None
    key = _key(where)
    return None if key is None else (where, key)


def _key(where: Path) -> bytes | None:
    """The folder's HMAC key: read, or made once (written to a private temporary file, then linked
    in place, so two processes that make it at once agree on the one that got there first)."""
    path = where / KEY_FILE
    for _ in range(2):
        try:
            got = _read_regular(path, 65)
        except FileNotFoundError:
            got = None
        except OSError as exc:
            note(f"cache off: cannot read the key {path} ({exc.strerror or exc}); remove it")
            return None
        if got is not None:
            st, key = got
            if st is None:
                note(f"cache off: the key {path} is not a regular file (a folder, FIFO or device); remove it")
                return None
            if not _private(st, "key", path, 0o077 if os.name == "posix" else 0):
                return None
            if len(key) != 32:
                note(f"cache off: the key {path} is not 32 bytes; remove it")
                return None
            return key
        tmp = tempfile.NamedTemporaryFile(dir=where, prefix=".key-", delete=False)     # mode 0600
        try:
            tmp.write(secrets.token_bytes(32))
            tmp.flush()
            os.fsync(tmp.fileno())
            tmp.close()
            try:
                os.link(tmp.name, path)                 # fails if another process made it first
            except FileExistsError:
                pass
            except OSError:                             # no hard links here: a rename (last one wins)
                os.replace(tmp.name, path)
        finally:
            tmp.close()
            if os.path.exists(tmp.name):
                os.unlink(tmp.name)
    return None


def _read_regular(path: Path, limit: int) -> tuple[os.stat_result | None, bytes]:
    """At most ``limit`` bytes of the regular file ``path`` and its status, never through a link
    (``O_NOFOLLOW``) and never waiting (``O_NONBLOCK``: a FIFO planted under the name would block
    an ordinary open until a writer came); ``(None, b"")`` for anything but a regular file (a
    folder, FIFO, socket or device: nothing is read from it); ``(status, b"")`` for a file larger
    than ``limit`` (not read: a planted giant costs no memory). OSError as ``os.open`` raises it."""
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            return None, b""
        if st.st_size > limit:
            return st, b""
        chunks, left = [], limit
        while left > 0 and (chunk := os.read(fd, min(left, 1 << 20))):
            chunks.append(chunk)
            left -= len(chunk)
        return st, b"".join(chunks)
    finally:
        os.close(fd)


def fingerprint() -> str:
    """What a derivation depends on besides its input: bgfdi's source files (each file's name,
    size and modification time), Python, numpy and sympy."""
    if "fingerprint" in _state:
        return _state["fingerprint"]
    h = hashlib.sha256()
    root = Path(__file__).resolve().parent.parent
    for package in ("fdi", "bondgraph", "optim"):
        base = root / package
        try:
            names = sorted(p for p in os.listdir(base) if p.endswith(".py"))
        except OSError:
            continue
        for name in names:
            try:
                st = os.stat(base / name)
            except OSError:
                continue
            h.update(f"{package}/{name}:{st.st_size}:{st.st_mtime_ns}\n".encode())
        if package == "fdi":
            for name in sorted(os.listdir(base / "app")) if (base / "app").is_dir() else ():
                if name.endswith(".py"):
                    st = os.stat(base / "app" / name)
                    h.update(f"fdi/app/{name}:{st.st_size}:{st.st_mtime_ns}\n".encode())
    h.update(f"python {sys.version}\n".encode())
    h.update(f"numpy {_installed('numpy')}\n".encode())
    for name in ("sympy", "networkx", "scipy", "yaml"):   # expressions, causality, time scales, the loader: by their
        h.update(f"{name} {_distribution(name)}\n".encode())   # installed metadata (a warm start imports none of them)
    _state["fingerprint"] = out = h.hexdigest()
    return out


def _distribution(name: str) -> str:
    """A library's installed distribution (its ``*.dist-info`` folder's name, with the version)
    without importing it (importlib.metadata costs 50 ms; networkx's import more): a library
    upgraded under a cached derivation changes the entry's name."""
    import importlib.util
    try:
        spec = importlib.util.find_spec(name)
    except (ImportError, ValueError):
        return "absent"
    if spec is None or not spec.origin:
        return "absent"
    root = Path(spec.origin).resolve().parent.parent
    prefix = {"yaml": "pyyaml"}.get(name, name).lower() + "-"
    try:
        found = sorted(e for e in os.listdir(root) if e.lower().startswith(prefix) and e.endswith(".dist-info"))
    except OSError:
        found = []
    return ",".join(found) or str(spec.origin)


def _installed(name: str) -> str:
    """A library's version as imported (numpy is imported by whoever reads a compiled model anyway:
    one way of reading it, so every process names an entry alike)."""
    import importlib
    return str(getattr(importlib.import_module(name), "__version__", "?"))


def entry_name(kind: str, source: bytes) -> str:
    """An entry's file name: a digest of its kind, its source and :func:`fingerprint`."""
    h = hashlib.sha256()
    for part in (kind.encode(), source, fingerprint().encode(), _bgfdi_version().encode()):
        h.update(len(part).to_bytes(8, "big"))
        h.update(part)
    return h.hexdigest() + SUFFIX


def _bgfdi_version() -> str:
    """bgfdi's version from its source tree (cheap: no importlib.metadata), else installed."""
    if "version" not in _state:
        import re
        try:
            text = (Path(__file__).resolve().parent.parent / "pyproject.toml").read_text(encoding="utf-8")
            found = re.search(r"""^version\s*=\s*["']([^"']+)["']""", text, re.M)
            _state["version"] = found.group(1) if found else "?"
        except OSError:
            from . import __version__
            _state["version"] = __version__
    return _state["version"]


def _mac(key: bytes, name: str, payload: bytes) -> bytes:
    return hmac.new(key, MAGIC + name.encode() + b"\0" + payload, hashlib.sha256).digest()


def fetch(kind: str, source: bytes) -> bytes | None:
    """The payload stored for (``kind``, ``source``), authenticated; None when absent, foreign,
    truncated, tampered or the cache is off."""
    ready = _ready()
    if ready is None:
        return None
    where, key = ready
    name = entry_name(kind, source)
    path = where / name
    try:
        st, raw = _read_regular(path, MAX_BYTES + 1)
    except OSError:
        return None
    if st is None or len(raw) > MAX_BYTES:        # not a regular file, or larger than an entry may be
        return None
    if hasattr(os, "getuid") and st.st_uid != os.getuid():
        return None
    head = len(MAGIC) + 32
    if len(raw) < head or not raw.startswith(MAGIC):
        return None
    payload = raw[head:]
    if not hmac.compare_digest(raw[len(MAGIC):head], _mac(key, name, payload)):
        return None
    try:
        os.utime(path)                          # recently used: pruned last
    except OSError:
        pass
    return payload


def store(kind: str, source: bytes, payload: bytes) -> bool:
    """Store ``payload`` for (``kind``, ``source``), atomically; False when the cache is off or
    the folder cannot be written (a cache never fails its caller)."""
    ready = _ready()
    if ready is None:
        return False
    where, key = ready
    name = entry_name(kind, source)
    data = MAGIC + _mac(key, name, payload) + payload
    try:
        fd, tmp = tempfile.mkstemp(dir=where, prefix=".tmp-", suffix=SUFFIX)     # 0600
        try:
            with os.fdopen(fd, "wb") as fh:
                fh.write(data)
            os.replace(tmp, where / name)
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)
    except OSError as exc:
        note(f"cache: cannot write {where / name} ({exc.strerror or exc})")
        return False
    prune(where)
    return True


def prune(where: Path | None = None, entries: int = MAX_ENTRIES, size: int = MAX_BYTES) -> None:
    """Remove the least recently used entries beyond ``entries`` and ``size`` bytes in all."""
    where = where or folder()
    found = []
    try:
        with os.scandir(where) as it:
            for e in it:
                if e.name.endswith(SUFFIX) and not e.name.startswith("."):
                    try:
                        st = e.stat(follow_symlinks=False)
                    except OSError:
                        continue
                    found.append((st.st_mtime_ns, st.st_size, e.name))
    except OSError:
        return
    found.sort(reverse=True)
    total = 0
    for i, (_, n, name) in enumerate(found):
        total += n
        if i >= entries or total > size:
            try:
                os.unlink(where / name)
            except OSError:
                pass


def clear() -> int:
    """Remove every entry (not the key); how many."""
    ready = _ready()
    if ready is None:
        return 0
    n = 0
    for p in ready[0].glob("*" + SUFFIX):
        try:
            p.unlink()
            n += 1
        except OSError:
            pass
    return n


__all__ = ["enabled", "disable", "note", "folder", "fetch", "store", "prune", "clear", "fingerprint", "entry_name",
           "notes", "ENV", "DIR_ENV"]
