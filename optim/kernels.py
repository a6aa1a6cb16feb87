"""The one switch for compiled code, the engines' (a DE generation's arithmetic) and the objective's
(through ``fdi.kernels``). Three paths give the same numbers:

- ``c``: C built once per machine by its C compiler and loaded with ctypes (:mod:`optim.native`;
  ``optim._native``, ``fdi._native``): no JIT, a millisecond to load;
- ``numba``: numba's, when it is installed (the ``fast`` extra; ``optim._jit``, ``fdi._jit``):
  cached on disk by numba, 0.65 s to start in each process;
- ``numpy``: the reference the others are tested against.

``auto`` (the default) takes C when built libraries outlive the process (a store is set,
:func:`optim.native.use_store`: bgfdi's disk cache) and a compiler or a built library is at hand,
else numba, else numpy (a library built for one process alone costs it about 1.5 s: asked for
with ``c``). ``BGFDI_KERNELS`` in the environment
(``auto``, ``c``, ``numba``, ``numpy``) or :func:`use` chooses; ``BGFDI_NUMBA=0`` (older) means
numpy.

>>> before = use("numpy")
>>> jit() is None
True
>>> _ = use(before)
"""
from __future__ import annotations

import importlib
import os
from types import ModuleType

PATHS = ("auto", "c", "numba", "numpy")


def _from_environment() -> str:
    chosen = os.environ.get("BGFDI_KERNELS", "").strip().lower()
    if chosen in PATHS:
        return chosen
    if os.environ.get("BGFDI_NUMBA", "1") in ("0", "false", "no", ""):
        return "numpy"
    return "auto"


def environment_problem() -> str | None:
    """What is wrong with ``BGFDI_KERNELS`` in the environment, if it is set to no path (read as
    ``auto``, which would run another path than the one asked for): for a front door to refuse."""
    given = os.environ.get("BGFDI_KERNELS")
    if given is None or given.strip().lower() in PATHS:
        return None
    return f"BGFDI_KERNELS={given[:40]}: expected one of {', '.join(PATHS)} (or unset it: auto)"


def available() -> list[str]:
    """The compiled paths this machine can run: ``c`` (a C compiler, or a built library kept),
    ``numba`` (installed)."""
    import importlib.util

    from . import native
    return [p for p, ok in (("c", native.compiler() is not None or native.has_store()),
                            ("numba", importlib.util.find_spec("numba") is not None)) if ok]


_wanted = _from_environment()
_loaded: dict[str, ModuleType | None] = {}


def use(path: str) -> str:
    """Choose the path for this process (one of :data:`PATHS`); returns the one chosen before."""
    global _wanted
    if path not in PATHS:
        raise ValueError(f"kernels path {path!r}: expected one of {', '.join(PATHS)}")
    before = _wanted
    _wanted = path
    for key in [k for k in _loaded if k.startswith("auto:")]:
        del _loaded[key]                     # auto decides again
    return before


def use_numba(on: bool) -> bool:
    """Compiled code on (``auto``) or off (``numpy``); returns whether it was on before."""
    return use("auto" if on else "numpy") != "numpy"


def wanted() -> str:
    """The path asked for (:data:`PATHS`)."""
    return _wanted


def _module(name: str) -> ModuleType | None:
    if name not in _loaded:
        try:
            _loaded[name] = importlib.import_module(name)
        except ImportError:
            _loaded[name] = None
    return _loaded[name]


def compiled(package: str) -> ModuleType | None:
    """The compiled module of ``package`` (``optim`` or ``fdi``) on the path in use: its
    ``_native`` (C) or ``_jit`` (numba) module, imported on first use; None on the numpy path."""
    path = _wanted
    if path == "numpy":
        return None
    if path == "c":
        return _module(package + "._native")
    if path == "numba":
        return _module(package + "._jit")
    key = "auto:" + package                  # decided once per process (a store's check reads the disk)
    if key not in _loaded:
        from . import native
        if native.has_store():
            _loaded[key] = _module(package + "._native") or _module(package + "._jit")
        else:
            _loaded[key] = _module(package + "._jit")
    return _loaded[key]


def cheap(package: str) -> bool:
    """Whether :func:`compiled` spares this process numba's 0.65 s start: the module is loaded,
    or the path is C (a library built once per machine and kept by the store, or built now by the
    compiler at hand: the first call costs ~75 ms, optim's import and the library's load). For
    callers that run small work compiled once they have spent that much (:func:`fdi.derivatives.fir`)."""
    path = _wanted
    if path == "numpy":
        return False
    key = {"c": package + "._native", "numba": package + "._jit"}.get(path, "auto:" + package)
    if _loaded.get(key) is not None:
        return True
    if path == "c":
        return True
    if path == "auto":
        from . import native
        return native.has_store() and native.compiler() is not None
    return False


def jit() -> ModuleType | None:
    """The engines' compiled module (``optim._native`` or ``optim._jit``), or None (see :func:`compiled`)."""
    return compiled("optim")


def path() -> str:
    """The path that runs: ``c``, ``numba`` or ``numpy``."""
    mod = jit()
    return "numpy" if mod is None else ("c" if mod.__name__.endswith("_native") else "numba")
