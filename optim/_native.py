"""The C version of a DE generation's arithmetic (``optim/trials.c``, built by :mod:`optim.native`;
imported only through :mod:`optim.kernels`): :func:`trials` with :func:`optim._jit.trials`'s
signature and numbers."""
from __future__ import annotations

import numpy as np

from . import native
from .native import address as _at
from .native import floats as _f
from .native import ints as _i

_lib = native.require("bgfdi_trials", __file__, "trials.c", {"trials": ("r", "piipi" + "p" * 14 + "ppp")})


def trials(x, cols, F_old, CR_old, redraw_F, new_F, redraw_CR, new_CR, order, pick, hop1, hop2, cross, forced,
           lo, hi):
    """:func:`optim._jit.trials` (the same arguments and results)."""
    x, cols = _f(x), _i(cols)
    n, D = x.shape
    m = cols.shape[0]
    trial = np.empty_like(x)
    F, CR = np.empty(n), np.empty(n)
    keep = [x, cols, _f(F_old), _f(CR_old), _f(redraw_F), _f(new_F), _f(redraw_CR), _f(new_CR), _i(order), _i(pick),
            _i(hop1), _i(hop2), _f(cross), _i(forced), _f(lo), _f(hi)]
    a = [_at(k) for k in keep]
    _lib.trials(a[0], n, D, a[1], m, *a[2:], _at(trial), _at(F), _at(CR))
    return trial, F, CR
