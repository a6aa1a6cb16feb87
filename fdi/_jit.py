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

STEPS19 = 1000      # fdi.profiles.STEPS19 (a compile-time constant here; tests/test_kernels.py checks they agree)
MIN_STEPS19 = 100   # fdi.profiles.MIN_STEPS19 (likewise)

from .profiles import _exp
from .trig import _trig
from .tape import (ABS, ACOS, ACOSH, ADD, ASIN, ASINH, ATAN, ATANH, CONST, COS, COSH, DIV, EXP, LOADF,  # noqa: F401
                   LOADP, LOADS, LOG, MUL, NEG, POW, RECIP, SIGN, SIN, SINH, SQRT, SQUARE, SUB, TAN)


@njit(cache=True, nogil=True)
def _steps19(span, step):  # pragma: no cover - compiled
    """fdi.profiles.steps19: ``step``-second RK4 steps over ``span``, at least MIN_STEPS19, at most STEPS19."""
    return STEPS19 if span / step > STEPS19 else max(MIN_STEPS19, int(np.ceil(span / step)))


@njit(cache=True, nogil=True)
def rk4_19(tau, p0, b5, b6, b7, step):  # pragma: no cover - compiled
    """Eq. (19) by RK4 on a uniform grid, Hermite-interpolated at ``tau`` (pop, N); see
    :func:`fdi.profiles._model19` (one grid step for all rows, from the largest tau)."""
    pop, n = tau.shape
    span = 0.0
    for r in range(pop):
        for j in range(n):
            if tau[r, j] > span:
                span = tau[r, j]
    k = _steps19(span, step)
    h = span / k if span > 0 else step
    grid = np.empty(k + 1)
    slope = np.empty(k + 1)
    out = np.empty((pop, n))
    for r in range(pop):
        _rk4_grid(p0, b5[r], b6[r], b7[r], h, k, grid, slope)
        for j in range(n):
            out[r, j] = _hermite(tau[r, j], h, k, grid, slope)
    return out


@njit(cache=True, nogil=True)
def _rk4_grid(p0, c5, c6, c7, h, k, grid, slope):  # pragma: no cover - compiled
    """Eq. (19)'s P and dP/dt on the grid 0, h, ..., k h by classical RK4 (inf past a blow-up)."""
    h2, h6 = h / 2, h / 6
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


@njit(cache=True, nogil=True)
def _hermite(tau, h, k, grid, slope):  # pragma: no cover - compiled
    """The grid's cubic Hermite interpolant at ``tau`` (NaN at a NaN tau, inf next to a blow-up)."""
    x = tau / h
    if x != x:                   # a NaN onset: numpy's path cannot index it either
        return np.nan
    if x < 0:
        x = 0.0
    elif x > k:
        x = float(k)
    i0 = min(int(math.floor(x)), k - 1)
    s = x - i0
    pa, pb = grid[i0], grid[i0 + 1]
    if not (math.isfinite(pa) and math.isfinite(pb)):
        return np.inf
    va, vb = slope[i0] * h, slope[i0 + 1] * h
    s2 = s * s
    s3 = s * s * s
    return (2 * s3 - 3 * s2 + 1) * pa + (s3 - 2 * s2 + s) * va + (-2 * s3 + 3 * s2) * pb + (s3 - s2) * vb


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
        for j in range(m):
            wj = weights[r, j]
            x[j] = points[r, j] if wj > 0 else 0.0
            w[j] = wj
        out[r] = _median(x, w, m)
    return out


@njit(cache=True, nogil=True)
def _median(x, w, m):  # pragma: no cover - compiled
    """The weighted median of x[:m] with weights w[:m] (0 if they weigh nothing), reordering both.
    From ``BRACKET_FROM`` points on, a sample's weighted quantiles around the half bracket it first
    (Floyd and Rivest's idea): one reading pass sums the weight below and above the bracket and
    keeps the points inside (a fifth to a third), where the selection continues; a bracket that misses
    (a sample unlike the rest) falls back to the selection on every point. 1.5-2.4x faster on
    1 000-2 000 points (a solved magnitude's points: two residuals' samples)."""
    total = 0.0
    for j in range(m):
        total += w[j]
    if not total > 0:
        return 0.0
    half = 0.5 * total
    if m >= BRACKET_FROM:
        s = min(BRACKET_SAMPLE, int(4.0 * math.sqrt(m)))
        delta = 1.5 / math.sqrt(s)            # three standard errors of a sample's median
        step = m // s
        xs = np.empty(s)
        ws = np.empty(s)
        sw = 0.0
        for k in range(s):
            xs[k] = x[k * step]
            ws[k] = w[k * step]
            sw += ws[k]
        if sw > 0:
            a = _select(xs, ws, 0, s, 0.0, sw * (0.5 - delta))
            b = _select(xs, ws, 0, s, 0.0, sw * (0.5 + delta))
            xm = np.empty(m)
            wm = np.empty(m)
            below, above, k = 0.0, 0.0, 0
            for j in range(m):
                xj = x[j]
                if xj < a:
                    below += w[j]
                elif xj > b:
                    above += w[j]
                else:
                    xm[k] = xj
                    wm[k] = w[j]
                    k += 1
            if below < half and total - above >= half and k > 0:
                return _select(xm, wm, 0, k, below, half)
    return _select(x, w, 0, m, 0.0, half)


@njit(cache=True, nogil=True)
def _select(x, w, lo, hi, below, half):  # pragma: no cover - compiled
    """The smallest point v of x[lo:hi] at which ``below`` plus the weight of the points at or
    below it reaches ``half``, by a three-way weighted quickselect in O(n) (reordering both)."""
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
            return pivot
        else:
            below += wl + we
            lo = gt


BRACKET_FROM = 256       # points from which a sample brackets the median first
BRACKET_SAMPLE = 256     # the sample's largest size (4 sqrt(m) below)


@njit(cache=True, nogil=True)
def intermittent(t, t0, nominal, value, period):  # pragma: no cover - compiled
    """Eq. (15) for every row: :func:`fdi.profiles.intermittent`'s numbers without a sine per
    sample (:func:`_intermittent`)."""
    rows, n = t0.shape[0], t.shape[0]
    out = np.empty((rows, n))
    for r in range(rows):
        for j in range(n):
            out[r, j] = _intermittent(t[j], t0[r], nominal, value[r], period[r])
    return out


@njit(cache=True, nogil=True)
def _intermittent(t, a, nominal, v, T):  # pragma: no cover - compiled
    """Eq. (15) at one time. The phase x = 2 pi (t - t0) / T is formed by numpy's operations;
    sin(x) > 0 exactly when floor(x / pi) is even, which decides every sample farther than 1e-6 of
    a half-period from a switch; those nearer (and x = 0, where eq. (15) gives the mean) take the
    sine itself."""
    if not t >= a:
        return nominal
    x = 2 * np.pi * (t - a) / T
    u = x / np.pi
    k = math.floor(u)
    f = u - k
    if f > 1e-6 and f < 1 - 1e-6:
        s = 1.0 if k % 2 == 0 else -1.0
    else:
        y = math.sin(x)
        s = 1.0 if y > 0 else (-1.0 if y < 0 else 0.0)    # NaN: neither, the mean (np.sign)
    return v if s > 0 else (nominal if s < 0 else (nominal + v) / 2)


@njit(cache=True, nogil=True)
def incipient17(t, t0, nominal, b2):  # pragma: no cover - compiled
    """Eq. (17) for every row, as :func:`fdi.profiles.incipient` (model 2) computes it
    (:func:`_eq17`). ``nominal`` is not 0 (the caller's case)."""
    rows, n = t0.shape[0], t.shape[0]
    out = np.empty((rows, n))
    c = 0.0 if math.isinf(nominal) else 1.0 / nominal
    for r in range(rows):
        for j in range(n):
            out[r, j] = _eq17(t[j], t0[r], nominal, c, b2[r])
    return out


@njit(cache=True, nogil=True)
def _eq17(t, a, nominal, c, b):  # pragma: no cover - compiled
    """1/P = 1/P0 - b2 tau from t0 on (c = 1/P0), infinite past the pole: only subtractions,
    products and one division, so the numbers are numpy's."""
    if not t >= a:
        return nominal
    tau = t - a
    if not tau > 0:
        return nominal
    den = c - b * tau
    return 1.0 / den if den > 0 else np.inf


@njit(cache=True, nogil=True)
def decode_rows(real, bits, log, scale, powers, vpow, zeta, t_last):  # pragma: no cover - compiled
    """:func:`fdi.encoding.decode_table` for the fused objective, with what it reads next: per fault
    and individual the type, model, value, period and coefficients (faults, pop[, 7]), the
    rows the caller gives a profile of (``pre_at``, all -1 here: the solved steps are numbered by
    the caller), the count of eq. (16) and (18) rows per fault (``counts``), eq. (19)'s span per fault (the
    latest onset's t_last - t0, NaN onsets left out, at least 0) and, per fault, whether an
    individual makes it abrupt or intermittent. ``powers`` holds numpy's 10 ** x of each rate
    slot (fault j's at column j) and of each logarithmic value (fault j's at ``vpow[j]``): numpy's
    power is SIMD code, so it stays numpy's; the rest are products, a quotient and a difference,
    the same operations. ``bits`` are booleans; ``zeta`` is :func:`fdi.encoding.repair_zeta` of
    each zeta code."""
    pop = real.shape[0]
    nf = log.shape[0]
    kinds = np.empty((nf, pop), dtype=np.int64)
    models = np.empty((nf, pop), dtype=np.int64)
    values = np.empty((nf, pop))
    periods = np.empty((nf, pop))
    b = np.empty((nf, pop, 7))
    counts = np.zeros((nf, 2), dtype=np.int64)
    span19 = np.zeros(nf)
    level = np.zeros(nf, dtype=np.bool_)
    for j in range(nf):
        c0 = 9 * j
        z0 = 5 * j
        late_max = -np.inf
        seen = False
        for r in range(pop):
            kind = zeta[4 * bits[r, z0] + 2 * bits[r, z0 + 1] + bits[r, z0 + 2]]
            model = 1 + 2 * np.int64(bits[r, z0 + 3]) + np.int64(bits[r, z0 + 4])
            kinds[j, r] = kind
            models[j, r] = model
            values[j, r] = powers[r, vpow[j]] if log[j] else real[r, c0]
            periods[j, r] = real[r, c0 + 1]
            for q in range(7):
                b[j, r, q] = real[r, c0 + 2 + q] * scale[j, q]
            rate = powers[r, j]
            b[j, r, 2] = rate - 1.0 / rate
            if kind < 2:
                level[j] = True
            elif model == 1:
                counts[j, 0] += 1
            elif model == 3:
                counts[j, 1] += 1
            elif model == 4:
                late = t_last - real[r, real.shape[1] - 1]
                if late == late:
                    seen = True
                    if late > late_max:
                        late_max = late
        if seen and late_max > 0.0:
            span19[j] = late_max
    pre_at = np.full((nf, pop), -1, dtype=np.int64)
    return kinds, models, values, periods, b, pre_at, counts, span19, level


@njit(cache=True, nogil=True)
def _eq18_roots(b3):  # pragma: no cover - compiled
    """Eq. (18)'s rates r1, r2 as :func:`fdi.profiles._model18` forms them (b3 ** 2 is numpy's square)."""
    root = np.sqrt(b3 * b3 + 4.0)
    return (b3 + root) / 2, (b3 - root) / 2


# the kernels' exponential (fdi/kernels.c vexp): fdi.profiles._exp, its one Python statement of the
# operations, compiled as it is, so the C, numba and a simulation's instant give the same bits
_vexp = njit(cache=True, nogil=True)(_exp)


# the tapes' cos, sin and tan (fdi/kernels.c vtrig): fdi.trig._trig compiled as it is (the same bits).
# numba's disk cache keys a function by its own file: the functions here that call _vexp or _vtrig
# are not compiled again when only fdi/profiles.py or fdi/trig.py changes (an installation replaces
# every file; when editing those, touch this file: tests/test_kernels.py compares the paths' bits)
_vtrig = njit(cache=True, nogil=True)(_trig)


@njit(cache=True, nogil=True)
def trig(x, which):  # pragma: no cover - compiled
    """cos (``which`` 0), sin (1) or tan (2) of every element of ``x`` as the tapes take them."""
    out = np.empty_like(x)
    flat, dst = x.ravel(), out.ravel()
    for i in range(flat.size):
        dst[i] = _vtrig(flat[i], which)
    return out


@njit(cache=True, nogil=True)
def incipient_exp(t, t0, nominal, model, b):  # pragma: no cover - compiled
    """Eq. (16) (model 1: P0 exp(b1 tau)) or eq. (18) (model 3, finite P0: -b4 + a exp(r1 tau) +
    c exp(r2 tau)) from t0 on, the nominal value before, for every row of ``b`` and time (tau =
    max(t - t0, 0), NaN stays NaN): the products, quotients and sums of
    :func:`fdi.profiles.incipient` in its order, with :func:`_vexp` (the C's exponential; numpy's
    differs in the last bit), in one pass and no temporary (numpy's path takes three passes and two)."""
    rows, n = b.shape[0], t.shape[0]
    out = np.empty((rows, n))
    for r in range(rows):
        a = t0[r]
        if model == 1:
            r1 = b[r, 0]
            for i in range(n):
                x = t[i] - a
                tau = 0.0 if x < 0 else x
                out[r, i] = nominal * _vexp(r1 * tau) if t[i] >= a else nominal
        else:
            b4 = b[r, 1]
            r1, r2 = _eq18_roots(b[r, 0])
            ca = -r2 * (nominal + b4) / (r1 - r2)
            cc = r1 * (nominal + b4) / (r1 - r2)
            for i in range(n):
                x = t[i] - a
                tau = 0.0 if x < 0 else x
                out[r, i] = (-b4 + ca * _vexp(r1 * tau)) + cc * _vexp(r2 * tau) if t[i] >= a else nominal
    return out


@njit(cache=True, nogil=True)
def edges_seen0(t, edges, signs, seen, h, blends):  # pragma: no cover - compiled
    """:func:`fdi.derivatives.edges_seen` for order 0 (``seen``: the smoothing filter's view of a
    step, 2 h values; ``blends`` False when no window fits): per row the sharp steps summed sample
    by sample (exact: sums of +-1), then each edge's blend added edge after edge in (row, column)
    order, np.add.at's order, so the same bits where two edges' windows meet. ``signs`` (rows or
    1, edges)."""
    rows, ne = edges.shape
    nw = t.shape[0]
    out = np.empty((rows, nw))
    jumps = np.empty(nw + 1)
    for r in range(rows):
        sr = signs[0] if signs.shape[0] == 1 else signs[r]
        jumps[:] = 0.0
        for e in range(ne):
            if np.isfinite(edges[r, e]):
                jumps[np.searchsorted(t, edges[r, e])] += sr[e]
        acc = 0.0
        for i in range(nw):
            acc += jumps[i]
            out[r, i] = acc
        if not blends:
            continue
        for e in range(ne):
            if not np.isfinite(edges[r, e]):
                continue
            q = np.searchsorted(t, edges[r, e])
            if q >= nw:
                continue
            for k in range(2 * h):
                a = q - h + k
                if h <= a < nw - h:
                    out[r, a] += sr[e] * (seen[k] - (1.0 if k >= h else 0.0))
    return out


@njit(cache=True, nogil=True)
def fir(x, half, start, count, stride):  # pragma: no cover - compiled
    """:func:`fdi.derivatives.fir` for rows of ``x`` (rows, samples): out[r, k, i], the numpy
    path's operations in its order (the middle sample times tap 0, then the pairs j = 1, 2, ...).
    The loop over samples is the inner one, on contiguous reads (each phase of a strided row
    gathered once), so LLVM vectorises it without reordering any sum."""
    rows = x.shape[0]
    n = 2 * (half.shape[0] - 1) + 1
    out = np.empty((rows, half.shape[1], count))
    length = count + (n - 1) // stride + 1
    phases = np.empty((min(stride, n), length))
    pair = np.empty((2, count))
    for r in range(rows):
        _fir_row(x[r], half, start, count, stride, out[r], 0, phases, pair)
    return out


@njit(cache=True, nogil=True)
def _fir_row(src, half, start, count, stride, S, at, phases, pair):  # pragma: no cover - compiled
    """The filter of :func:`fir` on one row ``src`` into S[at + k, :count]."""
    h = half.shape[0] - 1
    n = 2 * h + 1
    length = count + (n - 1) // stride + 1
    if stride == 1:
        phases[0, :count + n - 1] = src[start:start + count + n - 1]
    else:
        for ph in range(min(stride, n)):
            for t in range(length):
                q = start + ph + t * stride
                phases[ph, t] = src[q] if q < src.shape[0] else 0.0
    mid = phases[h % stride, h // stride:h // stride + count]
    for k in range(half.shape[1]):
        acc = S[at + k]
        c = half[0, k]
        for i in range(count):
            acc[i] = mid[i] * c
    plus = pair[0]
    minus = pair[1]
    for j in range(1, h + 1):
        up = phases[(h + j) % stride, (h + j) // stride:(h + j) // stride + count]
        down = phases[(h - j) % stride, (h - j) // stride:(h - j) // stride + count]
        for i in range(count):
            plus[i] = up[i] + down[i]
            minus[i] = up[i] - down[i]
        for k in range(half.shape[1]):
            acc = S[at + k]
            c = half[j, k]
            v = minus if k % 2 else plus
            for i in range(count):
                acc[i] += v[i] * c


# ---------------------------------------------------------------- the fused objective (fdi.fused)

@njit(cache=True, nogil=True, error_model="numpy")
def _edge_rates(x, edge, n, h, start, m, stride, out):  # pragma: no cover - compiled
    """A stored quantity's rate at the samples evaluated (start, start + stride, ... m of them)
    that lie within h of the window's ends, into ``out``: by the polynomial of the whole edge
    window (``edge[0]``: the first n samples, ``edge[1]``: the last n), as derivatives.estimate's
    ``interp``."""
    nw = x.shape[0]
    for j in range(m):
        i = start + j * stride
        if i < h:
            a = 0.0
            for r in range(n):
                a += x[r] * edge[0, r, i]
            out[j] = a
        elif i >= nw - h:
            a = 0.0
            for r in range(n):
                a += x[nw - n + r] * edge[1, r, i - (nw - h)]
            out[j] = a


@njit(cache=True, nogil=True, error_model="numpy")
def _tape(code, R, L, s0, F, P, S, consts):  # pragma: no cover - compiled
    """Run a tape (:mod:`fdi.tape`) on samples [s0, s0 + L) of one individual (its parameter
    slots P and filtered signals S): registers R (registers, block), each operation elementwise,
    in the generated code's order (numpy's operations, sample by sample)."""
    for q in range(code.shape[0]):
        op = code[q, 0]
        out = R[code[q, 1]]
        a = code[q, 2]
        b = code[q, 3]
        if op == LOADF:
            for t in range(L):
                out[t] = F[a, s0 + t]
        elif op == LOADP:
            for t in range(L):
                out[t] = P[a, s0 + t]
        elif op == LOADS:
            for t in range(L):
                out[t] = S[a, s0 + t]
        elif op == CONST:
            c = consts[a]
            for t in range(L):
                out[t] = c
        elif op < NEG:
            u = R[a]
            v = R[b]
            if op == ADD:
                for t in range(L):
                    out[t] = u[t] + v[t]
            elif op == SUB:
                for t in range(L):
                    out[t] = u[t] - v[t]
            elif op == MUL:
                for t in range(L):
                    out[t] = u[t] * v[t]
            elif op == DIV:
                for t in range(L):
                    out[t] = u[t] / v[t]
            elif op == POW:
                for t in range(L):
                    out[t] = u[t] ** v[t]
            else:
                for t in range(L):
                    out[t] = np.arctan2(u[t], v[t])
        else:
            u = R[a]
            if op == NEG:
                for t in range(L):
                    out[t] = -u[t]
            elif op == ABS:
                for t in range(L):
                    out[t] = abs(u[t])
            elif op == SIGN:
                for t in range(L):
                    out[t] = np.sign(u[t])
            elif op == SQRT:
                for t in range(L):
                    out[t] = np.sqrt(u[t])
            elif op == SQUARE:
                for t in range(L):
                    out[t] = u[t] * u[t]
            elif op == RECIP:
                for t in range(L):
                    out[t] = 1.0 / u[t]
            elif op == EXP:
                for t in range(L):
                    out[t] = np.exp(u[t])
            elif op == LOG:
                for t in range(L):
                    out[t] = np.log(u[t])
            elif op == SIN:
                for t in range(L):
                    out[t] = _vtrig(u[t], 1)
            elif op == COS:
                for t in range(L):
                    out[t] = _vtrig(u[t], 0)
            elif op == TAN:
                for t in range(L):
                    out[t] = _vtrig(u[t], 2)
            elif op == ASIN:
                for t in range(L):
                    out[t] = np.arcsin(u[t])
            elif op == ACOS:
                for t in range(L):
                    out[t] = np.arccos(u[t])
            elif op == ATAN:
                for t in range(L):
                    out[t] = np.arctan(u[t])
            elif op == SINH:
                for t in range(L):
                    out[t] = np.sinh(u[t])
            elif op == COSH:
                for t in range(L):
                    out[t] = np.cosh(u[t])
            elif op == ASINH:
                for t in range(L):
                    out[t] = np.arcsinh(u[t])
            elif op == ACOSH:
                for t in range(L):
                    out[t] = np.arccosh(u[t])
            elif op == ATANH:
                for t in range(L):
                    out[t] = np.arctanh(u[t])
            else:
                for t in range(L):
                    out[t] = np.tanh(u[t])


@njit(cache=True, nogil=True, error_model="numpy")
def _corrected(raw, v, is_source, beta, bias, half, cp):  # pragma: no cover - compiled
    """Signal v corrected as :func:`fdi.residuals.corrected_signals` does (the offset ``bias``
    removed, then divided by the sensor's efficiency factor ``beta``, or a source's multiplied;
    empty arrays: none), into cp[half:half + samples], mirrored about its end samples into the
    margins (np.pad's ``reflect``, as the numpy path's ``edges="mirror"``)."""
    n = raw.shape[1]
    for j in range(n):
        x = raw[v, j]
        if bias.shape[0]:
            x = x + bias[j] if is_source[v] else x - bias[j]
        if beta.shape[0]:
            x = x * beta[j] if is_source[v] else x / beta[j]
        cp[half + j] = x
    for j in range(1, half + 1):
        cp[half - j] = cp[half + j]
        cp[half + n - 1 + j] = cp[half + n - 1 - j]


@njit(cache=True, nogil=True, error_model="numpy")
def _profile(t, j, row, onset, kinds, models, values, periods, coeffs, pre, pre_at, nominal, unit, linear, k19, h19,
             grid, slope, out):  # pragma: no cover - compiled
    """Fault j's profile for individual ``row`` at every time of ``t`` into ``out``, as
    :func:`fdi.encoding.profiles` gives it (the numpy path's operations; eqs. 16 and 18 with
    :func:`_vexp`, the C's exponential); a linear fault that is
    abrupt or intermittent at its unit value (its solved magnitude's unit step; from ``pre``
    when given there: the step or square wave as the filtered residuals see it)."""
    kind = kinds[j, row]
    a = onset[row]
    val = unit if (linear and kind < 2) else values[j, row]
    n = t.shape[0]
    if kind < 2 and linear and pre_at[j, row] >= 0:       # its step or square wave as the filters see it (numpy's)
        k = pre_at[j, row]
        for i in range(n):
            out[i] = pre[k, i]
    elif kind == 0:
        z = 0.0 * val
        for i in range(n):
            out[i] = (val if t[i] >= a else nominal) + z
    elif kind == 1:
        T = periods[j, row]
        for i in range(n):
            out[i] = _intermittent(t[i], a, nominal, val, T)
    else:
        model = models[j, row]
        if model == 2:
            if nominal == 0:
                for i in range(n):
                    out[i] = 0.0
            else:
                c = 0.0 if math.isinf(nominal) else 1.0 / nominal
                b = coeffs[j, row, 0]
                for i in range(n):
                    out[i] = _eq17(t[i], a, nominal, c, b)
        elif model == 4:
            if math.isinf(nominal):
                for i in range(n):
                    out[i] = np.inf if t[i] >= a else nominal
            else:
                _rk4_grid(nominal, coeffs[j, row, 1], coeffs[j, row, 2], coeffs[j, row, 3], h19, k19, grid, slope)
                for i in range(n):
                    tau = t[i] - a
                    if tau < 0:                    # np.maximum(t - t0, 0): NaN stays NaN
                        tau = 0.0
                    p = _hermite(tau, h19, k19, grid, slope)
                    out[i] = p if t[i] >= a else nominal
        elif model == 1:                           # eq. (16): fdi.profiles.incipient's operations
            r1 = coeffs[j, row, 4]
            for i in range(n):
                x = t[i] - a
                tau = 0.0 if x < 0 else x
                out[i] = nominal * _vexp(r1 * tau) if t[i] >= a else nominal
        elif math.isinf(nominal):                  # eq. (18) never leaves an infinite P0
            for i in range(n):
                out[i] = np.inf
        else:                                      # eq. (18)
            b4 = coeffs[j, row, 6]
            r1, r2 = _eq18_roots(coeffs[j, row, 5])
            ca = -r2 * (nominal + b4) / (r1 - r2)
            cc = r1 * (nominal + b4) / (r1 - r2)
            for i in range(n):
                x = t[i] - a
                tau = 0.0 if x < 0 else x
                out[i] = (-b4 + ca * _vexp(r1 * tau)) + cc * _vexp(r2 * tau) if t[i] >= a else nominal


@njit(cache=True, nogil=True, error_model="numpy")
def _others(d, gain, enters, srow, jj, ji, m, extra):  # pragma: no cover - compiled
    """Into ``extra``, the sum over the solved linear faults but ``jj`` that enter joint residual
    ``ji`` of magnitude times unit-step gain, taken in the faults' order (the first term, then each
    next added); returns whether there was any. One pass per fault over the samples (SIMD code),
    not a loop over the faults inside each sample's."""
    others = False
    for kk in range(d.shape[0]):
        if kk != jj and enters[kk, ji] and srow[kk]:
            dk = d[kk]
            g = gain[kk, ji]
            if others:
                for s in range(m):
                    extra[s] = extra[s] + dk * g[s]
            else:
                for s in range(m):
                    extra[s] = dk * g[s]
            others = True
    return others


@njit(cache=True, nogil=True, error_model="numpy")
def _points(base, extra, others, x, w, m, pts, wts):  # pragma: no cover - compiled
    """A solved magnitude's weighted-median points on one joint residual: -rest / x with weight
    w |x|, rest the residual with the other faults' terms (``extra`` when ``others``), x the fault's
    unit-step gain; a sample where x is 0 or either is not finite weighs nothing (its point 0).
    Written without branches, so that the division is SIMD code."""
    for s in range(m):
        rest = base[s] + extra[s] if others else base[s]
        xs = x[s]
        ok = (xs != 0) & (abs(rest) < np.inf) & (abs(xs) < np.inf)
        wc = w * abs(xs) if ok else 0.0
        q = -rest / (xs if xs != 0 else 1.0)
        wts[s] = wc
        pts[s] = q if wc > 0 else 0.0


@njit(cache=True, nogil=True, error_model="numpy")
def _slots(prof, solved, slot_fault, slot_step, slot_group, f_nominal, tnom, start, count, stride,
           out):  # pragma: no cover - compiled
    """The parameter slots of one individual at samples start, start + stride, ... (``count`` of
    them) into ``out``: each slot's fault profile (a group fault's times its target's nominal value
    ``tnom``), a solved fault's base slots at its nominal value (its stepped slots keep the unit step)."""
    for k in range(slot_fault.shape[0]):
        j = slot_fault[k]
        dst = out[k]
        if solved[j] and not slot_step[k]:
            c = f_nominal[j]
            for s in range(count):
                dst[s] = tnom[k, start + s * stride] * c if slot_group[k] else c
        else:
            src = prof[j]
            for s in range(count):
                q = start + s * stride
                dst[s] = tnom[k, q] * src[q] if slot_group[k] else src[q]


@njit(cache=True, nogil=True, error_model="numpy")
def fused_cost(t, onset, kinds, models, values, periods, coeffs, pre, pre_at,
               f_nominal, f_unit, f_linear, f_role, f_lo, f_hi, span19, step19,
               slot_fault, slot_step, slot_group, tnom,
               code, results, registers, consts, F,
               raw, is_source, beta_fault, beta_fixed, bias_fault, bias_fixed, corr_fixed,
               fk, fk_n, fk_orders, s_at, n_slots, start, stride, m,
               plain, plain_w, joint, joint_w, enters, lin_fault, lo, hi, passes, gaps, constant,
               block, n_comp, icode, level_at, level_members, members, result_of, iregisters, iconsts, ifixed,
               full_of, n_full, comp_at, full_at, comp_order, ck, ck_n, edge):  # pragma: no cover - compiled
    """Eq. (24)'s cost of every individual in one call, as :meth:`fdi.objective.Objective.evaluate`
    computes it on the numpy path. Per individual: each candidate fault's profile over the
    window (:func:`_profile`; a solved linear fault at its nominal value, its unit step kept for
    the gains), the invalid ones marked (a NaN profile; an efficiency factor not finite and
    positive, an offset not finite: replaced by 1 or 0, as the numpy path does); the parameter
    slots at the m samples start, start + stride, ... (a group fault's parameters times their
    nominal values ``tnom``); each corrected signal filtered there (:func:`_corrected`,
    :func:`_fir_row`); the residuals' tape (:func:`fdi.tape.program`: residual q in register
    results[q, 0], with linear fault v's parameters at their unit step in results[q, 1 + v]) run
    on blocks of ``block`` samples (zero at the ``gaps``); the plain residuals' weighted sums of
    |r|; for the joint ones the base residual and each solved fault's unit-step gain, the
    magnitudes by weighted medians (``passes`` rounds over the faults, clipped to [lo, hi]),
    then their weighted sums. Returns (totals with ``constant`` first, each linear fault's
    magnitude per individual (0 where not solved), the invalid individuals).

    Stored quantities an individual changes (``n_comp`` of them, :meth:`fdi.fused.Fused._stored_quantities`),
    one level of nesting after another (level l: instructions ``level_at[l]:level_at[l + 1]`` of
    ``icode``, quantities ``members[level_members[l]:level_members[l + 1]]``, each in register
    ``result_of``): the tape run on every sample of the window (the parameter slots over the whole
    window, the corrected signals' samples and derivatives ``full_of[signal, order]``, inner
    quantities' rates), each quantity
    checked finite (else the individual is invalid, its samples read as 0), then filtered (``ck``:
    the centred kernels of order ``comp_order``) at the samples evaluated into the
    filtered-signal slots ``comp_at``, and on every sample into the whole-window slots ``full_at``
    (the edge half-windows by ``edge``'s kernels, the polynomial of the edge window), before the
    residuals' tape reads them."""
    nf, pop = kinds.shape
    nw = t.shape[0]
    nlin = lin_fault.shape[0]
    nj = joint.shape[0]
    npl = plain.shape[0]
    nslot = slot_fault.shape[0]
    total = np.empty(pop)
    deltas = np.zeros((nlin, pop))
    invalid = np.zeros(pop, dtype=np.bool_)
    prof = np.empty((max(1, nf), nw))
    bad = np.zeros(max(1, nf), dtype=np.bool_)
    solved = np.zeros(max(1, nf), dtype=np.bool_)
    k19 = np.empty(max(1, nf), dtype=np.int64)
    h19 = np.empty(max(1, nf))
    kmax = 1
    for j in range(nf):
        span = span19[j]
        k19[j] = _steps19(span, step19)
        h19[j] = span / k19[j] if span > 0 else step19
        kmax = max(kmax, k19[j])
    grid = np.empty(kmax + 1)
    slope = np.empty(kmax + 1)
    ones = np.ones(nw)
    zeros = np.zeros(nw)
    empty = np.empty(0)
    Prow = np.empty((max(1, nslot), m))
    R = np.empty((max(1, registers), block))
    S = np.empty((max(1, n_slots), m))
    base = np.empty((max(1, nj), m))
    gain = np.zeros((max(1, nlin), max(1, nj), m))
    pts = np.empty(max(1, nj * m))
    wts = np.empty(max(1, nj * m))
    d = np.zeros(max(1, nlin))
    extra = np.empty(m)
    fresh = np.zeros(max(1, nlin), dtype=np.bool_)    # a fault's median taken, with the others at seen[fault]
    seen = np.zeros((max(1, nlin), max(1, nlin)))
    srow = np.zeros(max(1, nlin), dtype=np.bool_)
    parts = np.zeros(max(1, npl))
    nmax = 2 * (max(fk.shape[1], ck.shape[1]) - 1) + 1     # the longest window (fk, ck hold half kernels)
    cp = np.empty(nw + nmax)
    Pfull = np.empty((max(1, nslot) if n_comp else 1, nw))
    Sfull = np.empty((n_full if n_comp else 1, nw))
    Ri = np.empty((max(1, iregisters) if n_comp else 1, block))
    X = np.empty((max(1, n_comp), nw if n_comp else 1))
    T = np.empty((max(ck.shape[2], fk.shape[2]), nw if n_comp else 1))   # a filter's orders on every sample
    phases_full = np.empty((1, nw + nmax if n_comp else 1))
    pair_full = np.empty((2, nw if n_comp else 1))
    phases = np.empty((max(1, min(stride, nmax)), m + (nmax - 1) // stride + 1))
    pair = np.empty((2, m))
    for row in range(pop):
        inv = False
        for j in range(nf):
            _profile(t, j, row, onset, kinds, models, values, periods, coeffs, pre, pre_at, f_nominal[j],
                     f_unit[j], f_linear[j], k19[j], h19[j], grid, slope, prof[j])
            solved[j] = f_linear[j] and kinds[j, row] < 2
            b = False
            if not solved[j]:                   # a solved fault's profile is its nominal value
                role = f_role[j]
                for i in range(nw):
                    x = prof[j, i]
                    if x != x or (role == 1 and not (np.isfinite(x) and x > 0 and f_lo[j] <= x <= f_hi[j])) or \
                            (role == 2 and not (np.isfinite(x) and f_lo[j] <= x <= f_hi[j])):
                        b = True
                        break
            bad[j] = b
            inv = inv or b
        _slots(prof, solved, slot_fault, slot_step, slot_group, f_nominal, tnom, start, m, stride, Prow)
        for v in range(raw.shape[0]):
            be = empty
            if beta_fault[v] >= 0:
                be = ones if bad[beta_fault[v]] else prof[beta_fault[v]]
            elif beta_fixed[v] >= 0:
                be = corr_fixed[beta_fixed[v]]
            bi = empty
            if bias_fault[v] >= 0:
                bi = zeros if bad[bias_fault[v]] else prof[bias_fault[v]]
            elif bias_fixed[v] >= 0:
                bi = corr_fixed[bias_fixed[v]]
            h = fk_n[v] // 2
            _corrected(raw, v, is_source, be, bi, h, cp)
            _fir_row(cp[:nw + 2 * h], fk[v, :h + 1, :fk_orders[v]], start, m, stride, S, s_at[v], phases, pair)
            if n_comp:
                if full_of[v, 0] >= 0:
                    Sfull[full_of[v, 0], :] = cp[h:h + nw]
                deriv = False
                for k in range(1, full_of.shape[1]):
                    deriv = deriv or full_of[v, k] >= 0
                if deriv:                    # its derivatives on every sample (the mirrored ends: the numpy path's)
                    _fir_row(cp[:nw + 2 * h], fk[v, :h + 1, :fk_orders[v]], 0, nw, 1, T, 0, phases_full, pair_full)
                    for k in range(1, full_of.shape[1]):
                        if full_of[v, k] >= 0:
                            Sfull[full_of[v, k], :] = T[k, :nw]
        if n_comp:                   # the stored quantities, on every sample, then their rates
            _slots(prof, solved, slot_fault, slot_step, slot_group, f_nominal, tnom, 0, nw, 1, Pfull)
            for lev in range(level_at.shape[0] - 1):
                code_l = icode[level_at[lev]:level_at[lev + 1]]
                for s0 in range(0, nw, block):
                    L = min(block, nw - s0)
                    _tape(code_l, Ri, L, s0, ifixed, Pfull, Sfull, iconsts)
                    for k in range(level_members[lev], level_members[lev + 1]):
                        c = members[k]
                        reg = Ri[result_of[c]]
                        dst = X[c]
                        for t_ in range(L):
                            dst[s0 + t_] = reg[t_]
                for k in range(level_members[lev], level_members[lev + 1]):
                    c = members[k]
                    n = ck_n[c]
                    h = n // 2
                    o = comp_order[c]
                    x = X[c]
                    for i in range(nw):
                        if not np.isfinite(x[i]):
                            x[i] = 0.0
                            inv = True
                    if comp_at[c] >= 0:
                        if start >= h and start + (m - 1) * stride + h < nw:
                            _fir_row(x, ck[c, :h + 1, :o + 1], start - h, m, stride, S, comp_at[c], phases, pair)
                        else:            # samples within h of the window's ends: zeros beyond, then fitted
                            for i in range(h):
                                cp[i] = 0.0
                                cp[h + nw + i] = 0.0
                            for i in range(nw):
                                cp[h + i] = x[i]
                            _fir_row(cp[:nw + 2 * h], ck[c, :h + 1, :o + 1], start, m, stride, S, comp_at[c], phases,
                                     pair)
                            _edge_rates(x, edge[c], n, h, start, m, stride, S[comp_at[c] + o])
                    if full_at[c] >= 0:          # every sample: the middle filtered, the edges fitted
                        dst = Sfull[full_at[c]]
                        _fir_row(x, ck[c, :h + 1, :o + 1], 0, nw - 2 * h, 1, T, 0, phases_full, pair_full)
                        for i in range(nw - 2 * h):
                            dst[h + i] = T[o, i]
                        for q in range(h):
                            a0 = 0.0
                            a1 = 0.0
                            for i in range(n):
                                a0 += x[i] * edge[c, 0, i, q]
                                a1 += x[nw - n + i] * edge[c, 1, i, q]
                            dst[q] = a0
                            dst[nw - h + q] = a1
        invalid[row] = inv
        for jj in range(nlin):
            srow[jj] = solved[lin_fault[jj]]
        for pi in range(npl):
            parts[pi] = 0.0
        for s0 in range(0, m, block):
            L = min(block, m - s0)
            _tape(code, R, L, s0, F, Prow, S, consts)
            for pi in range(npl):
                r = R[results[plain[pi], 0]]
                part = parts[pi]
                for t_ in range(L):
                    if not gaps[s0 + t_]:
                        part += abs(r[t_])
                parts[pi] = part
            for ji in range(nj):
                q = joint[ji]
                r = R[results[q, 0]]
                for t_ in range(L):
                    base[ji, s0 + t_] = 0.0 if gaps[s0 + t_] else r[t_]
                for jj in range(nlin):
                    if enters[jj, ji] and srow[jj]:
                        rv = R[results[q, 1 + jj]]
                        for t_ in range(L):
                            gain[jj, ji, s0 + t_] = (0.0 if gaps[s0 + t_] else rv[t_]) - base[ji, s0 + t_]
        acc = constant
        for pi in range(npl):
            acc += plain_w[pi] * parts[pi]
        if nj:
            for jj in range(nlin):
                d[jj] = 0.0
                fresh[jj] = False
            for _ in range(passes):
                for jj in range(nlin):
                    if not srow[jj]:
                        d[jj] = 0.0
                        continue
                    same = fresh[jj]        # the others as at this fault's last median: the same median again
                    for kk in range(nlin):
                        if same and kk != jj and seen[jj, kk] != d[kk]:
                            same = False
                    if same:
                        continue
                    c = 0
                    for ji in range(nj):
                        if not enters[jj, ji]:
                            continue
                        others = _others(d, gain, enters, srow, jj, ji, m, extra)
                        _points(base[ji], extra, others, gain[jj, ji], joint_w[ji], m, pts[c:c + m], wts[c:c + m])
                        c += m
                    med = _median(pts, wts, c)
                    d[jj] = min(max(med, lo[jj]), hi[jj])
                    fresh[jj] = True
                    for kk in range(nlin):
                        seen[jj, kk] = d[kk]
            for jj in range(nlin):
                deltas[jj, row] = d[jj]
            for ji in range(nj):
                others = _others(d, gain, enters, srow, -1, ji, m, extra)
                b_ = base[ji]
                if others:
                    for s in range(m):
                        extra[s] = abs(b_[s] + extra[s])
                else:
                    for s in range(m):
                        extra[s] = abs(b_[s])
                part = 0.0
                for s in range(m):           # sample after sample, as before
                    part += extra[s]
                acc += joint_w[ji] * part
        total[row] = acc
    return total, deltas, invalid
