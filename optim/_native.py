"""The C version of a DE generation's arithmetic (``optim/trials.c``, built by :mod:`optim.native`;
imported only through :mod:`optim.kernels`): :func:`trials` with :func:`optim._jit.trials`'s
signature and numbers, and :func:`trials_batch`, which also takes the random draws, from numpy's
own generator through its C interface."""
from __future__ import annotations

import math

import numpy as np

from . import native
from .native import address as _at
from .native import floats as _f
from .native import ints as _i

_lib = native.require("bgfdi_trials", __file__, "trials.c", {"trials": ("r", "piipi" + "p" * 14 + "ppp"),
                                                             "trials_batch": ("r", "pip")})


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


def trials_batch(rng, populations: list[tuple]) -> list[tuple] | None:
    """:meth:`optim.ahde.AHDE.trials` for several populations in one call, their random draws
    included: ``populations`` of (x, cols, F, CR, order, lo, hi) (``order`` = the costs' argsort,
    taken by numpy: its order of ties), each drawn from ``rng`` (a numpy Generator) in turn, in
    the method's order and by numpy's algorithms (its bit generator's own functions, Lemire's
    bounded integers): the same trial points, F and CR, and the generator left in the same state
    (tests/test_optim.py). None (nothing drawn) when a population is outside what the C covers
    (fewer than 3 points; no free real). Why: the method takes nine numpy draws and a kernel call
    per structure and generation, ~60 us; this takes ~5 us a population."""
    desc = np.empty((len(populations), 14), dtype=np.int64)
    out, keep = [], []
    for k, (x, cols, F_old, CR_old, order, lo, hi) in enumerate(populations):
        x, cols, F_old, CR_old, order, lo, hi = _f(x), _i(cols), _f(F_old), _f(CR_old), _i(order), _f(lo), _f(hi)
        n, D = x.shape
        m = cols.shape[0]
        if n < 3 or m < 1 or n >= 2 ** 31:
            return None
        if not (F_old.shape == CR_old.shape == order.shape == (n,) and lo.shape == hi.shape == (m,)
                and ((cols >= 0) & (cols < D)).all()):
            raise ValueError("trials_batch: F, CR and order need one entry per point, lo and hi one per free "
                             "column, and the columns must lie within the population's")
        trial, F, CR = np.empty_like(x), np.empty(n), np.empty(n)
        desc[k] = (_at(x), n, D, _at(cols), m, _at(F_old), _at(CR_old), _at(order), _at(lo), _at(hi), _at(trial),
                   _at(F), _at(CR), max(2, math.ceil(0.2 * n)))
        keep.append((x, cols, F_old, CR_old, order, lo, hi))
        out.append((trial, F, CR))
    g = rng.bit_generator
    with g.lock:
        code = _lib.trials_batch(g.ctypes.bit_generator.value, len(populations), _at(desc))
    if code:
        raise MemoryError("the C trials could not allocate their scratch arrays")
    return out
