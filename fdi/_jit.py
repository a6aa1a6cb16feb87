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

from .tape import (ABS, ACOS, ADD, ASIN, ATAN, CONST, COS, COSH, DIV, EXP, LOADF, LOADP, LOADS, LOG, MUL, NEG, POW,  # noqa: F401
                   RECIP, SIGN, SIN, SINH, SQRT, SQUARE, SUB, TAN)


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
        for j in range(m):
            wj = weights[r, j]
            x[j] = points[r, j] if wj > 0 else 0.0
            w[j] = wj
        out[r] = _median(x, w, m)
    return out


@njit(cache=True, nogil=True)
def _median(x, w, m):  # pragma: no cover - compiled
    """The weighted median of x[:m] with weights w[:m] (0 if they weigh nothing), reordering both."""
    total = 0.0
    for j in range(m):
        total += w[j]
    if not total > 0:
        return 0.0
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
            return pivot
        else:
            below += wl + we
            lo = gt


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


# ---------------------------------------------------------------- the fused objective (fdi.fused)

@njit(cache=True, nogil=True, error_model="numpy")
def _tape(code, R, L, s0, row, F, P, S, consts):  # pragma: no cover - compiled
    """Run a tape (:mod:`fdi.tape`) on samples [s0, s0 + L) of individual ``row``: registers R
    (registers, block), each operation elementwise, in the generated code's order (numpy's
    operations, sample by sample)."""
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
                out[t] = P[a, row, s0 + t]
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
                    out[t] = np.sin(u[t])
            elif op == COS:
                for t in range(L):
                    out[t] = np.cos(u[t])
            elif op == TAN:
                for t in range(L):
                    out[t] = np.tan(u[t])
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
            else:
                for t in range(L):
                    out[t] = np.tanh(u[t])


@njit(cache=True, nogil=True, error_model="numpy")
def _corrected(raw, v, row, is_source, beta_at, beta_rows, bias_at, bias_rows, corr_rows, corr_fixed, half, cp):  # pragma: no cover - compiled
    """Signal v of individual ``row`` corrected as :func:`fdi.residuals.corrected_signals` does
    (offset removed, then divided by the sensor's efficiency factor, or a source's multiplied),
    into cp[half:half + samples], mirrored about its end samples into the margins (np.pad's
    ``reflect``, as the numpy path's ``edges="mirror"``)."""
    n = raw.shape[1]
    for j in range(n):
        x = raw[v, j]
        if bias_at[v] >= 0:
            bb = corr_rows[bias_at[v], row, j] if bias_rows[v] else corr_fixed[bias_at[v], j]
            x = x + bb if is_source[v] else x - bb
        if beta_at[v] >= 0:
            be = corr_rows[beta_at[v], row, j] if beta_rows[v] else corr_fixed[beta_at[v], j]
            x = x * be if is_source[v] else x / be
        cp[half + j] = x
    for j in range(1, half + 1):
        cp[half - j] = cp[half + j]
        cp[half + n - 1 + j] = cp[half + n - 1 - j]


@njit(cache=True, nogil=True)
def _fir_row(cp, kernel, n, orders, start, count, stride, S, at, phases):  # pragma: no cover - compiled
    """:func:`fir` of one row into S[at + k, :count]: the same taps in the same order."""
    length = count + (n - 1) // stride + 1
    if stride == 1:
        phases[0, :count + n - 1] = cp[start:start + count + n - 1]
    else:
        for ph in range(min(stride, n)):
            for t in range(length):
                q = start + ph + t * stride
                phases[ph, t] = cp[q] if q < cp.shape[0] else 0.0
    for k in range(orders):
        acc = S[at + k]
        c = kernel[0, k]
        src = phases[0]
        for i in range(count):
            acc[i] = src[i] * c
        for j in range(1, n):
            c = kernel[j, k]
            part = phases[j % stride, j // stride:j // stride + count]
            for i in range(count):
                acc[i] += part[i] * c


@njit(cache=True, nogil=True, error_model="numpy")
def fused_cost(pop, code, results, registers, consts, F, P,
               raw, is_source, beta_at, beta_rows, bias_at, bias_rows, corr_rows, corr_fixed,
               fk, fk_n, fk_orders, s_at, n_slots, start, stride, m,
               plain, plain_w, joint, joint_w, enters, solve_rows, lo, hi, passes, gaps, constant, block):  # pragma: no cover - compiled
    """Eq. (24)'s cost of every individual (rows of P, corr_rows and solve_rows) in one call, as
    :meth:`fdi.objective.Objective.evaluate` computes it on the numpy path: each corrected signal
    filtered at the m samples start, start + stride, ... (:func:`_corrected`, :func:`_fir_row`);
    the residuals' tape (:func:`fdi.tape.program`: residual q in register results[q, 0], with
    linear fault v's parameters at their unit step in results[q, 1 + v]) run on blocks of
    ``block`` samples (zero at the ``gaps``); the plain residuals' weighted sums of |r|; for the
    joint ones (those a solved linear fault enters) the base residual and each solved fault's
    unit-step gain, the magnitudes by weighted medians (``passes`` rounds over the faults, clipped
    to [lo, hi]), then their weighted sums. Returns (totals, deltas): the weighted sums with
    ``constant`` first, and each linear fault's magnitude per individual (0 where not solved)."""
    nsolve = solve_rows.shape[0]
    nj = joint.shape[0]
    npl = plain.shape[0]
    total = np.empty(pop)
    deltas = np.zeros((nsolve, pop))
    R = np.empty((max(1, registers), block))
    S = np.empty((max(1, n_slots), m))
    base = np.empty((max(1, nj), m))
    gain = np.zeros((max(1, nsolve), max(1, nj), m))
    pts = np.empty(max(1, nj * m))
    wts = np.empty(max(1, nj * m))
    d = np.zeros(max(1, nsolve))
    parts = np.zeros(max(1, npl))
    nmax = fk.shape[1]
    cp = np.empty(raw.shape[1] + nmax)
    phases = np.empty((max(1, min(stride, nmax)), m + (nmax - 1) // stride + 1))
    for row in range(pop):
        for v in range(raw.shape[0]):
            h = fk_n[v] // 2
            _corrected(raw, v, row, is_source, beta_at, beta_rows, bias_at, bias_rows, corr_rows, corr_fixed, h, cp)
            _fir_row(cp, fk[v], fk_n[v], fk_orders[v], start, m, stride, S, s_at[v], phases)
        for pi in range(npl):
            parts[pi] = 0.0
        for s0 in range(0, m, block):
            L = min(block, m - s0)
            _tape(code, R, L, s0, row, F, P, S, consts)
            for pi in range(npl):
                r = R[results[plain[pi], 0]]
                part = parts[pi]
                for t in range(L):
                    if not gaps[s0 + t]:
                        part += abs(r[t])
                parts[pi] = part
            for ji in range(nj):
                q = joint[ji]
                r = R[results[q, 0]]
                for t in range(L):
                    base[ji, s0 + t] = 0.0 if gaps[s0 + t] else r[t]
                for jj in range(nsolve):
                    if enters[jj, ji] and solve_rows[jj, row]:
                        rv = R[results[q, 1 + jj]]
                        for t in range(L):
                            gain[jj, ji, s0 + t] = (0.0 if gaps[s0 + t] else rv[t]) - base[ji, s0 + t]
        acc = constant
        for pi in range(npl):
            acc += plain_w[pi] * parts[pi]
        if nj:
            for jj in range(nsolve):
                d[jj] = 0.0
            for _ in range(passes):
                for jj in range(nsolve):
                    if not solve_rows[jj, row]:
                        d[jj] = 0.0
                        continue
                    c = 0
                    for ji in range(nj):
                        if not enters[jj, ji]:
                            continue
                        w = joint_w[ji]
                        for s in range(m):
                            rest = base[ji, s]
                            others = False
                            extra = 0.0
                            for kk in range(nsolve):
                                if kk != jj and enters[kk, ji] and solve_rows[kk, row]:
                                    term = d[kk] * gain[kk, ji, s]
                                    extra = term if not others else extra + term
                                    others = True
                            if others:
                                rest = rest + extra
                            x = gain[jj, ji, s]
                            wc = w * abs(x) if (x != 0 and np.isfinite(rest) and np.isfinite(x)) else 0.0
                            wts[c] = wc
                            pts[c] = -rest / (x if x != 0 else 1.0) if wc > 0 else 0.0
                            c += 1
                    med = _median(pts, wts, c)
                    d[jj] = min(max(med, lo[jj]), hi[jj])
            for jj in range(nsolve):
                deltas[jj, row] = d[jj]
            for ji in range(nj):
                part = 0.0
                for s in range(m):
                    extra = 0.0
                    others = False
                    for kk in range(nsolve):
                        if enters[kk, ji] and solve_rows[kk, row]:
                            term = d[kk] * gain[kk, ji, s]
                            extra = term if not others else extra + term
                            others = True
                    part += abs(base[ji, s] + extra) if others else abs(base[ji, s])
                acc += joint_w[ji] * part
        total[row] = acc
    return total, deltas
