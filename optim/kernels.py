"""Whether the engines' compiled arithmetic runs: numba's (:mod:`optim._jit`), when it is installed
(the ``fast`` extra) and not switched off (``BGFDI_NUMBA=0``, or :func:`use_numba`), else numpy's;
both give the same numbers to the bit. ``fdi.kernels.use_numba`` switches this one too."""
from __future__ import annotations

import os
from types import ModuleType

_wanted = os.environ.get("BGFDI_NUMBA", "1") not in ("0", "false", "no", "")
_module: ModuleType | None = None
_tried = False


def use_numba(on: bool) -> bool:
    """Switch the numba path on or off (for this process); returns whether it was in use before."""
    global _wanted
    before = _wanted and jit() is not None
    _wanted = bool(on)
    return before


def jit() -> ModuleType | None:
    """:mod:`optim._jit` (numba imported on first use), or None without numba or switched off."""
    global _module, _tried
    if _wanted and not _tried:
        _tried = True
        try:
            from . import _jit
            _module = _jit
        except ImportError:
            _module = None
    return _module if _wanted else None
