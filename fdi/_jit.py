"""The numba versions of the objective's generic heavy parts (imported only through :mod:`fdi.kernels`).

Each function does the same floating-point operations, in the same order, as its numpy
counterpart (:func:`fdi.profiles._model19_numpy`, :func:`fdi.objective.weighted_median_numpy`),
so the numbers agree to round-off-free equality in practice and to 1e-9 by test
(tests/test_kernels.py). They are generic (no model-specific source), so ``cache=True`` keeps
their machine code on disk: only the first process on a machine pays the compilation.
No fastmath: it would reorder sums and contract products into FMAs, and the paths would differ.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def rk4_19(tau, p0, b5, b6, b7, step):  # pragma: no cover - compiled
    """Eq. (19) by RK4 on a uniform grid, Hermite-interpolated at ``tau`` (pop, N); see
    :func:`fdi.profiles._model19`."""
    pop, n = tau.shape
    span = 0.0
    for r in range(pop):
        for j in range(n):
            if tau[r, j] > span:
                span = tau[r, j]
    k = max(1, int(np.ceil(span / step)))
    h = span / k if span > 0 else step
    grid = np.empty(k + 1)
    slope = np.empty(k + 1)
    out = np.empty((pop, n))
    h2, h6 = h / 2, h / 6
    for r in range(pop):
        c5, c6, c7 = b5[r], b6[r], b7[r]
        p, v = p0, 0.0
        grid[0], slope[0] = p, v
        for i in range(1, k + 1):
            k1p = v
            k1v = c5 * v * v + c6 * p + c7
            k2p = v + h2 * k1v
            q, w = p + h2 * k1p, v + h2 * k1v
            k2v = c5 * w * w + c6 * q + c7
            k3p = v + h2 * k2v
            q, w = p + h2 * k2p, v + h2 * k2v
            k3v = c5 * w * w + c6 * q + c7
            k4p = v + h * k3v
            q, w = p + h * k3p, v + h * k3v
            k4v = c5 * w * w + c6 * q + c7
            p = p + h6 * (k1p + 2 * k2p + 2 * k3p + k4p)
            v = v + h6 * (k1v + 2 * k2v + 2 * k3v + k4v)
            if math.isfinite(p):
                grid[i], slope[i] = p, v
            else:
                grid[i], slope[i] = np.inf, 0.0
        for j in range(n):
            x = tau[r, j] / h
            if x != x:                   # a NaN onset: numpy's path cannot index it either
                out[r, j] = np.nan
                continue
            if x < 0:
                x = 0.0
            elif x > k:
                x = float(k)
            i0 = min(int(math.floor(x)), k - 1)
            s = x - i0
            pa, pb = grid[i0], grid[i0 + 1]
            if not (math.isfinite(pa) and math.isfinite(pb)):
                out[r, j] = np.inf
                continue
            va, vb = slope[i0] * h, slope[i0 + 1] * h
            s2 = s * s
            s3 = s * s * s
            out[r, j] = ((2 * s3 - 3 * s2 + 1) * pa + (s3 - 2 * s2 + s) * va + (-2 * s3 + 3 * s2) * pb
                         + (s3 - s2) * vb)
    return out


@njit(cache=True, nogil=True)
def weighted_median(points, weights):  # pragma: no cover - compiled
    """Per row, the weighted median of :func:`fdi.objective.weighted_median`: the smallest point v
    whose points at or below it weigh at least half the total (the sorted cumulative sum's
    crossing, found by a three-way weighted quickselect in O(m), not a sort: numba's argsort is
    twice as slow as numpy's, a selection five times faster). The partial sums are taken in
    another order than the sorted cumulative sum: the two agree unless a partial sum is within
    round-off of half the total."""
    n, m = points.shape
    out = np.zeros(n)
    x = np.empty(m)
    w = np.empty(m)
    for r in range(n):
        total = 0.0
        for j in range(m):
            wj = weights[r, j]
            x[j] = points[r, j] if wj > 0 else 0.0
            w[j] = wj
            total += wj
        if not total > 0:
            continue
        half = 0.5 * total
        below = 0.0                  # weight of the points already known to lie below the answer
        lo, hi = 0, m                # the candidates: x[lo:hi]
        while True:
            a, b, c = x[lo], x[(lo + hi - 1) // 2], x[hi - 1]
            pivot = max(min(a, b), min(max(a, b), c))     # median of three
            # three-way partition of x[lo:hi]: [lo, lt) < pivot, [lt, gt) == pivot, [gt, hi) > pivot
            lt, i, gt = lo, lo, hi
            wl, we = 0.0, 0.0
            while i < gt:
                xi = x[i]
                if xi < pivot:
                    wl += w[i]
                    x[i], x[lt] = x[lt], xi
                    w[i], w[lt] = w[lt], w[i]
                    lt += 1
                    i += 1
                elif xi > pivot:
                    gt -= 1
                    x[i], x[gt] = x[gt], xi
                    w[i], w[gt] = w[gt], w[i]
                else:
                    we += w[i]
                    i += 1
            if below + wl >= half and lt > lo:
                hi = lt
            elif below + wl + we >= half or gt == hi:
                out[r] = pivot
                break
            else:
                below += wl + we
                lo = gt
    return out


@njit(cache=True, nogil=True)
def intermittent(t, t0, nominal, value, period):  # pragma: no cover - compiled
    """Eq. (15) for every row: :func:`fdi.profiles.intermittent`'s numbers without a sine per
    sample. The phase x = 2 pi (t - t0) / T is formed by the same operations; sin(x) > 0 exactly
    when floor(x / pi) is even, which decides every sample farther than 1e-6 of a half-period from
    a switch; those nearer (and x = 0, where eq. (15) gives the mean) take the sine itself."""
    rows, n = t0.shape[0], t.shape[0]
    out = np.empty((rows, n))
    two_pi = 2 * np.pi
    for r in range(rows):
        a, v, T = t0[r], value[r], period[r]
        mean = (nominal + v) / 2
        for j in range(n):
            if not t[j] >= a:
                out[r, j] = nominal
                continue
            x = two_pi * (t[j] - a) / T
            u = x / np.pi
            k = math.floor(u)
            f = u - k
            if f > 1e-6 and f < 1 - 1e-6:
                s = 1.0 if k % 2 == 0 else -1.0
            else:
                y = math.sin(x)
                s = 1.0 if y > 0 else (-1.0 if y < 0 else 0.0)    # NaN: neither, the mean (np.sign)
            out[r, j] = v if s > 0 else (nominal if s < 0 else mean)
    return out


@njit(cache=True, nogil=True)
def incipient17(t, t0, nominal, b2):  # pragma: no cover - compiled
    """Eq. (17) for every row, as :func:`fdi.profiles.incipient` (model 2) computes it: 1/P = 1/P0 -
    b2 tau from t0 on, infinite past the pole; only subtractions, products and one division per
    sample, so the numbers are numpy's. ``nominal`` is not 0 (the caller's case)."""
    rows, n = t0.shape[0], t.shape[0]
    out = np.empty((rows, n))
    c = 0.0 if math.isinf(nominal) else 1.0 / nominal
    for r in range(rows):
        a, b = t0[r], b2[r]
        for j in range(n):
            if not t[j] >= a:
                out[r, j] = nominal
                continue
            tau = t[j] - a
            if not tau > 0:
                out[r, j] = nominal
                continue
            den = c - b * tau
            out[r, j] = 1.0 / den if den > 0 else np.inf
    return out


@njit(cache=True, nogil=True)
def fir(x, kernel, start, count, stride):  # pragma: no cover - compiled
    """:func:`fdi.derivatives.fir` for rows of ``x`` (rows, samples): out[r, k, i] = sum_j
    x[r, start + i stride + j] kernel[j, k], j in order from 0, each product rounded, then added
    (the numpy path's operations, sample by sample). The loop over samples is the inner one, on
    contiguous reads (with a stride, each phase of the samples gathered once per row), so LLVM
    vectorises it without reordering any sum: 0.12 ns a tap, a third of a matrix product's time."""
    rows = x.shape[0]
    n, orders = kernel.shape
    out = np.empty((rows, orders, count))
    length = count + (n - 1) // stride + 1
    phases = np.empty((min(stride, n), length))
    for r in range(rows):
        if stride == 1:
            phases[0, :count + n - 1] = x[r, start:start + count + n - 1]
        else:
            for ph in range(min(stride, n)):
                for t in range(length):
                    q = start + ph + t * stride
                    phases[ph, t] = x[r, q] if q < x.shape[1] else 0.0
        for k in range(orders):
            acc = out[r, k]
            c = kernel[0, k]
            src = phases[0]
            for i in range(count):
                acc[i] = src[i] * c
            for j in range(1, n):
                c = kernel[j, k]
                part = phases[j % stride, j // stride:j // stride + count]
                for i in range(count):
                    acc[i] += part[i] * c
    return out
