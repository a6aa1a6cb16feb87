"""The numba version of a DE generation's arithmetic (imported only through :mod:`optim.kernels`).

:func:`trials` does, row by row, the array operations of :meth:`optim.ahde.AHDE.trials` on the
random draws that method takes from numpy's generator (the same draws, in the same order, are
taken by the caller): the same floating-point operations in the same order, so the trial points
are numpy's to the bit (tests/test_optim.py compares them). No fastmath: it would contract the
mutation's products and sums into FMAs."""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def trials(x, cols, F_old, CR_old, redraw_F, new_F, redraw_CR, new_CR, order, pick, hop1, hop2, cross, forced,
           lo, hi):  # pragma: no cover - compiled
    """DE/current-to-pbest/1/bin: x (n, D) the population, ``cols`` its free reals; jDE's F and
    CR (each redrawn where its draw is below 0.1); pbest = order[pick], r1 = (i + hop1) % n,
    r2 = (r1 + hop2) % n (moved on by one where it is i); crossover where ``cross`` <= CR, and at
    the column ``forced``; a point out of [lo, hi] halfway back to its parent. Returns
    (trial, F, CR)."""
    n = x.shape[0]
    m = cols.shape[0]
    F = np.empty(n)
    CR = np.empty(n)
    trial = x.copy()
    for i in range(n):
        F[i] = new_F[i] if redraw_F[i] < 0.1 else F_old[i]
        CR[i] = new_CR[i] if redraw_CR[i] < 0.1 else CR_old[i]
    for i in range(n):
        p = order[pick[i]]
        r1 = (i + hop1[i]) % n
        r2 = (r1 + hop2[i]) % n
        if r2 == i:
            r2 = (r2 + 1) % n
        f = F[i]
        for k in range(m):
            c = cols[k]
            xi = x[i, c]
            v = xi + f * (x[p, c] - xi) + f * (x[r1, c] - x[r2, c])
            u = v if (cross[i, k] <= CR[i] or k == forced[i]) else xi
            if u < lo[k]:
                u = (lo[k] + xi) / 2
            if u > hi[k]:
                u = (hi[k] + xi) / 2
            trial[i, c] = u
    return trial, F, CR
