"""Which implementation runs the objective's generic heavy parts: numba's, when it is installed
(the ``fast`` extra) and not switched off, else numpy's.

The parts are the ones a profile of identification names and that do not depend on the model:
eq. (19)'s RK4 over the population (a Python loop of ~100 steps of ~40 numpy calls on (pop,)
arrays, ~4 ms per call) and the weighted median that solves a linear fault's magnitude (a sort
per row). Both paths give the same numbers (tests/test_kernels.py: 1e-9 relative on random
populations); the model-specific part, the ARR expressions, stays in numpy (a JIT per model would
cost each process seconds: CI runs ~1000 tests in many processes).

``BGFDI_NUMBA=0`` in the environment, or ``use_numba(False)``, selects the numpy path (the
reference the tests compare with). The compiled code is cached on disk by numba (``cache=True``;
``NUMBA_CACHE_DIR`` where the package directory is read-only): the first process on a machine
compiles (about 2 s), later ones load it.

>>> before = use_numba(False)
>>> enabled()
False
>>> _ = use_numba(before)
"""
from __future__ import annotations

import os
from types import ModuleType

_wanted = os.environ.get("BGFDI_NUMBA", "1") not in ("0", "false", "no", "")
_module: ModuleType | None = None
_tried = False


def use_numba(on: bool) -> bool:
    """Switch the numba path on or off (for this process); returns whether it was in use before."""
    global _wanted
    before = enabled()
    _wanted = bool(on)
    return before


def enabled() -> bool:
    """True when the compiled kernels run (numba importable and not switched off)."""
    return _wanted and jit() is not None


def jit() -> ModuleType | None:
    """:mod:`fdi._jit` (numba imported on first use, not at start-up), or None without numba."""
    global _module, _tried
    if not _tried:
        _tried = True
        try:
            from . import _jit
            _module = _jit
        except ImportError:
            _module = None
    return _module if _wanted else None
