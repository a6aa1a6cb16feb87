"""The one switch for compiled code, the engines' (:mod:`optim._jit`: a DE generation's arithmetic)
and the objective's (``fdi._jit``, through ``fdi.kernels``): numba's when it is installed (the ``fast``
extra) and not switched off (``BGFDI_NUMBA=0`` in the environment, or :func:`use_numba`), else numpy's.

>>> before = use_numba(False)
>>> jit() is None
True
>>> _ = use_numba(before)
"""
from __future__ import annotations

import importlib
import os
from types import ModuleType

_wanted = os.environ.get("BGFDI_NUMBA", "1") not in ("0", "false", "no", "")
_loaded: dict[str, ModuleType | None] = {}


def use_numba(on: bool) -> bool:
    """Switch compiled code on or off (for this process); returns whether it was wanted before."""
    global _wanted
    before = _wanted
    _wanted = bool(on)
    return before


def compiled(module: str) -> ModuleType | None:
    """The numba module ``module``, imported on first use; None without numba or switched off."""
    if not _wanted:
        return None
    if module not in _loaded:
        try:
            _loaded[module] = importlib.import_module(module)
        except ImportError:
            _loaded[module] = None
    return _loaded[module]


def jit() -> ModuleType | None:
    """:mod:`optim._jit`, or None (see :func:`compiled`)."""
    return compiled("optim._jit")
