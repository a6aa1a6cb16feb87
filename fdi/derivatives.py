"""Time derivatives of sampled, noisy, quantised signals.

Savitzky-Golay filtering (a local least-squares polynomial fit in a sliding window, evaluated
with its analytic derivatives) is the default: it is linear, exact for polynomials up to its
order, and handles the quantisation steps of encoders far better than finite differences, whose
noise grows as 1/ts^k. The window length sets the trade-off between noise and lag; it is given in
seconds and rounded to an odd number of samples. No window is a constant in seconds: it is the
model file's, or the one :func:`fdi.scales.derivative_window` derives from the sampling time and
the model's fastest time constant; with neither (``window=None``), 25 samples. All orders come
from one fit, so the signal and its derivatives stay consistent; arrays of any leading shape
(population x samples) are handled along the last axis.

The filter is centred (it looks half a window ahead): no lag, but a sample's derivative is known
half a window after it. The coefficients depend only on the window, the polynomial order and the
sampling period, so they are computed once (numpy least squares, the same numbers as scipy's
``savgol_coeffs``, without importing scipy.signal, which costs 0.4 s at start-up), and every order
comes from one pass over the samples: a FIR filter (:func:`fir`) whose taps are summed in ONE
fixed order, each product rounded, then added. The centred kernel is made exactly symmetric (even
orders) or antisymmetric (odd orders) about its middle tap (:func:`centred`: each tap averaged
with its mirror image, a last-bit change), and the samples are paired: the middle sample times
its weight, then for j = 1, 2, ... (x[i+j] + x[i-j]) or (x[i+j] - x[i-j]) times tap j. So a
derivative of a signal that stands still over the window is exactly 0 (not +-1e-16 of round-off),
and a Coulomb friction's sign of it is 0, whatever the summation order of a library: the
CyCab's burnt driver (scenario 3) left theta1 still, and the sign of BLAS's round-off moved the
fault-mode estimator's cost from 92 to 438. The compiled objective (:mod:`fdi._jit`) filters
with the same loop, so both paths give the same bits.
The samples are filtered in blocks of :data:`FIR_BLOCK` (memory O(samples),
temporaries in cache). The edges of ``interp`` take a kernel per position of the
half-window (n^2 / 2 values, cached) while that is small; for longer windows the polynomial of the
edge window is fitted once and evaluated (the same fit; numbers equal to round-off).
"""
from __future__ import annotations

from functools import lru_cache
from math import comb, factorial

import numpy as np

from . import kernels as _kernels

DEFAULT_WINDOW = None   # no window in s: None is fdi.scales' window of a model with no known time constant
DEFAULT_ORDER = 3

# A linear fault's abrupt step (each edge of an intermittent one) is seen through the filter of this
# derivative order: 0, the smoothing filter every signal's value goes through, so that a
# parameter's step and a source's or a sensor's (applied to the signal before the filters) are
# seen alike. Before, it stepped sharply against
# filtered signals and paid the mismatch for half a window each side of its onset: a water
# heater's insulation (901 s window) lost to an element fault, its onset found 386 s late. The
# slope's filter (1, the derivative that jumps in the tank's balance) fits a parameter's step
# better still, but a source's step is smoothed by the order-0 filter: measured, it then made
# every element fault an insulation fault (stop note of 2026-11-29: the whole remedy filters each
# residual's terms alike)
STEP_ORDER = 0

# Below this many products the numpy loop runs (the same bits), unless the compiled filter already
# ran in this process: numba's import and first compiled call cost
# 0.6 s of a short diagnosis's start (scenario 3, warm cache: 1.47 s process, of which 0.45 s in the
# residuals' first filter). A long stream's blocks are each below it (58 ns a sample by numpy, 20
# by C, order 2 and 25 taps): once the numpy loop has filtered FIR_RENT products in this process
# (~50 ms), about what reaching the C kernels costs (75 ms: optim's import and the library's
# load), they run compiled when that path is C (not numba: 0.65 s). A short file never pays the
# load; an endless stream pays it once (rent, then buy: never more than twice the better choice)
FIR_JIT_WORK = 1 << 21
FIR_RENT = 1 << 25
_fir_warm = False
_fir_spent = 0
FIR_BLOCK = 1 << 15     # values (rows x samples) filtered at a time: 256 kB temporaries, in L2 (a 30 x 1 000 population: 3.0 ms, 4.0 ms at 1 << 13)
EDGE_VALUES = 1 << 18   # edge kernels kept per window (2 MB: windows up to ~360 samples); longer: one fit per edge


def window_samples(window: float | None, ts: float, polyorder: int) -> int:
    """An odd number of samples covering ``window`` seconds (None: :func:`fdi.scales.derivative_window`
    of a model with no known time constant), enough for ``polyorder``."""
    if window is None:
        from .scales import derivative_window
        window = derivative_window(ts, float("inf"))
    n = max(int(round(window / ts)), polyorder + 2)
    return n if n % 2 == 1 else n + 1


def estimate(x: np.ndarray, ts: float, orders: int, window: float | None = DEFAULT_WINDOW,
             polyorder: int = DEFAULT_ORDER, edges: str = "interp", at: slice | None = None) -> list[np.ndarray]:
    """[x, dx/dt, ..., d^orders x/dt^orders] estimated along the last axis of ``x``.

    ``edges``: the first and last half-windows are either fitted by the polynomial of the first
    (last) whole window (``interp``, as scipy's ``savgol_filter``), or filtered on the signal
    mirrored about its end samples (``mirror``: cheaper, for callers that crop the edges away).
    ``at``: only the samples of that slice are estimated, the others are NaN (an estimator
    screening on every k-th sample needs a k-th of the filter's work); the samples estimated are
    the same numbers as without it (edge samples by the fit of their whole edge window).

    >>> t = np.arange(0, 1, 0.01)
    >>> x, v = estimate(t ** 3, 0.01, 1, window=0.1)
    >>> bool(np.allclose(v, 3 * t ** 2))
    True
    """
    x = np.asarray(x, dtype=float)
    p = max(polyorder, orders)
    n = window_samples(window, ts, p)
    if x.shape[-1] < n:
        raise ValueError(f"{x.shape[-1]} samples are fewer than the derivative window ({n} samples)")
    if edges not in ("interp", "mirror"):
        raise ValueError(f"edges must be 'interp' or 'mirror', not {edges!r}")
    half = n // 2
    pad = [(0, 0)] * (x.ndim - 1) + [(half, half)]
    if at is not None:
        idx = np.arange(x.shape[-1])[at]
        out = np.full(x.shape + (orders + 1,), np.nan)
        kernel = centred(n, p, orders, float(ts))
        inner = idx if edges == "mirror" else idx[(idx >= half) & (idx < x.shape[-1] - half)]
        if inner.size:
            stride = int(inner[1] - inner[0]) if inner.size > 1 else 1
            first, last = int(inner[0]), int(inner[-1])
            if first >= half and last < x.shape[-1] - half:       # whole windows: no padding
                out[..., first:last + 1:stride, :] = fir(x, kernel, first - half, inner.size, stride)
            else:                                                 # mirrored about the end samples
                out[..., first:last + 1:stride, :] = fir(np.pad(x, pad, mode="reflect"), kernel, first, inner.size,
                                                         stride)
        if edges == "interp" and inner.size < idx.size:       # the edge samples asked for, as without at=
            first, last = idx[idx < half], idx[idx >= x.shape[-1] - half]
            if first.size:
                out[..., first, :] = _edges(x, n, p, orders, float(ts), start=True)[..., first, :]
            if last.size:
                out[..., last, :] = _edges(x, n, p, orders, float(ts), start=False)[..., last - (x.shape[-1] - half), :]
        return [out[..., k] for k in range(orders + 1)]
    out = fir(np.pad(x, pad, mode="reflect"), centred(n, p, orders, float(ts)), 0, x.shape[-1])
    if edges == "interp":
        out[..., :half, :] = _edges(x, n, p, orders, float(ts), start=True)
        out[..., -half:, :] = _edges(x, n, p, orders, float(ts), start=False)
    return [out[..., k] for k in range(orders + 1)]


def _edges(x: np.ndarray, n: int, polyorder: int, orders: int, ts: float, start: bool) -> np.ndarray:
    """(..., half, orders + 1): the first (``start``) or last half-window of samples estimated by the
    polynomial of the first or last whole window: a kernel per edge position, kept, while that is
    small; for longer windows one fit per edge, evaluated."""
    half = n // 2
    first, stop = (0, half) if start else (half + 1, n)
    part = x[..., :n] if start else x[..., -n:]
    if n * half * (orders + 1) <= EDGE_VALUES:
        return np.einsum("...n,npk->...pk", part, kernels_at(n, polyorder, orders, ts, first, stop))
    return _edge(part, polyorder, orders, ts, range(first, stop))


def _edge(x: np.ndarray, polyorder: int, orders: int, ts: float, positions: range) -> np.ndarray:
    """(..., positions, orders + 1): the least-squares polynomial through the n samples of ``x``
    (its last axis), fitted once and evaluated with its derivatives at ``positions`` of that
    window: O(n) memory, where a kernel per position took O(n^2)."""
    n = x.shape[-1]
    half = n // 2
    coef = x @ kernels(n, polyorder, polyorder, 1.0, half)        # (..., p + 1): derivatives at the centre,
    d = np.arange(positions.start, positions.stop, dtype=float) - half      # per sample^k; offsets from it
    out = np.empty(x.shape[:-1] + (len(d), orders + 1))
    for k in range(orders + 1):
        # d^k/dt^k of sum_j c_j d^j / j!  =  sum_{j>=k} c_j d^(j-k) / (j-k)!, per ts^k
        taylor = np.stack([d ** (j - k) / factorial(j - k) for j in range(k, polyorder + 1)], axis=1)
        out[..., k] = coef[..., k:] @ taylor.T / ts ** k
    return out


# A one-sided fit is kept at a mode switch from the first sample where its noise is at most this
# many times the centred filter's (:func:`edge_trim`). Measured on the water heater (a draw's start
# is a switch of its tap's autonomous mode): at 2 the first kept samples after a draw still set the
# calibrated threshold at the --window auto window (242 W, one of two runs alarming with the other's
# thresholds); at 1.5, 196 W and none (the building's thresholds the same at both)
EDGE_GAIN = 1.5


EXACT_EDGE = 2001   # windows up to this many samples (polyorder 4 at most): each position's pseudo-inverse
# (0.56 s at 2 001); from polyorder 5 the unscaled Vandermonde's pseudo-inverse loses the gains (a review:
# 100 % off, trims of 371 for 813 at 2 001 samples), the normal equations about the centre keep them


def _edge_gains(n: int, polyorder: int, order: int) -> np.ndarray:
    """(order + 1, n // 2 + 1): the noise gain of a one-sided fit of ``n`` samples at each position
    from the end to the centre, per derivative order: the norm of its taps (a pseudo-inverse each)."""
    half = n // 2
    j = np.arange(n, dtype=float)
    gains = np.empty((order + 1, half + 1))
    for pos in range(half + 1):
        pinv = np.linalg.pinv(np.vander(j - pos, polyorder + 1, increasing=True))
        for k in range(order + 1):
            gains[k, pos] = float(np.sqrt(np.dot(pinv[k], pinv[k]))) * factorial(k)
    return gains


def _edge_gains_by_moments(n: int, polyorder: int, order: int) -> np.ndarray:
    """:func:`_edge_gains` from the normal equations, every position at once: the squared norm of
    derivative k's taps is (M^-1)_kk with M_ab = sum_j (j - pos)^(a + b), the sums expanded about
    the centre c, sum_j ((j - c) + (c - pos))^m = sum_i C(m, i) (c - pos)^(m - i) sum_j (j - c)^i, whose
    terms are all of one sign up to the centre (odd central sums vanish): no cancellation. O(n p)
    where the pseudo-inverses cost O(n^2 p^2): a 39 601-sample window (660 s sampled every 1/60 s,
    a record stamped in hours) took 114 s, 0.08 s this way; the trims agree with the pseudo-inverses'
    at every 40th size from 2 001 to 3 000 samples, polyorder 3 and 4 (a review: within 2e-9 of a
    column-scaled QR for polyorder 2-6 up to 1e6 samples)."""
    half, scale = n // 2, float(n)
    x = (np.arange(n, dtype=float) - (n - 1) / 2) / scale
    central = [float(np.sum(x ** i)) for i in range(2 * polyorder + 1)]
    d = ((n - 1) / 2 - np.arange(half + 1, dtype=float)) / scale
    sums = np.stack([sum(comb(m, i) * d ** (m - i) * central[i] for i in range(m + 1))
                     for m in range(2 * polyorder + 1)], axis=-1)
    inverse = np.linalg.inv(sums[:, np.add.outer(np.arange(polyorder + 1), np.arange(polyorder + 1))])
    k = np.arange(order + 1)
    return (np.sqrt(inverse[:, k, k]) * np.array([factorial(i) for i in k], dtype=float) / scale ** k).T


@lru_cache(maxsize=256)
def edge_trim(n: int, polyorder: int, order: int) -> int:
    """How many samples at a stretch's end (a mode switch) a one-sided fit of ``n`` samples leaves
    out for a channel that needs derivatives 0..``order``: past the last position where the fit's
    noise gain for one of them (the norm of its taps) exceeds EDGE_GAIN times the centred
    filter's. The end sample's fit is several times noisier than the centre's (a cubic over 101
    samples: 3.9 times for a first derivative, 5.9 for a second); on a thermostat's 251 switches a
    day those samples set the calibrated thresholds (a building's zone balance: 2 024 W at a
    switch, 609 W at the 99th percentile elsewhere), ten times what the heater's 900 W loss moves
    it by. A derivative of the polynomial's own order is flat across the window (a gain of 1).

    >>> [edge_trim(101, 3, k) for k in range(4)]
    [8, 18, 41, 41]
    """
    if not 0 <= order <= polyorder < n:
        raise ValueError(f"a derivative of order {order} needs a polynomial of at least that order and fewer "
                         f"than {n} samples (polyorder {polyorder})")
    exact = n <= EXACT_EDGE and polyorder <= 4
    gains = _edge_gains(n, polyorder, order) if exact else _edge_gains_by_moments(n, polyorder, order)
    over = gains > EDGE_GAIN * gains[:, -1:]
    return int(np.flatnonzero(over.any(axis=0)).max() + 1) if over.any() else 0


def fir(x: np.ndarray, half: np.ndarray, start: int, count: int, stride: int = 1) -> np.ndarray:
    """(..., count, orders + 1): the centred filter of :func:`centred`'s ``half`` (h + 1 taps:
    the middle, then j = 1..h) at output samples i = 0..count - 1, whose windows start at
    x[..., start + i * stride] (the middle at + h): order k is x[m] w0 + sum over j = 1, 2, ..., h in
    that order of (x[m + j] + x[m - j]) wj (even k) or (x[m + j] - x[m - j]) wj (odd k), each
    product rounded, then added. :func:`fdi._jit.fir` runs the same loop compiled (used when numba
    is, :mod:`fdi.kernels`): the same bits. ``x`` holds every sample the windows read.

    A filter of three taps (h = 1) with middle weights 1 and 0 and outer ones 10 and 5: x[m] + 10
    (x[m+1] + x[m-1]), and 5 (x[m+1] - x[m-1]):

    >>> fir(np.arange(6.0), np.array([[1.0, 0.0], [10.0, 5.0]]), 1, 2, 2).tolist()
    [[42.0, 10.0], [84.0, 10.0]]
    """
    global _fir_warm, _fir_spent
    x = np.asarray(x, dtype=float)
    work = int(np.prod(x.shape[:-1], dtype=np.int64)) * count * half.shape[0] * half.shape[1]
    fast = _kernels.jit() if count and (_fir_warm or work >= FIR_JIT_WORK or
                                        (_fir_spent >= FIR_RENT and _kernels.cheap())) else None
    if fast is None:
        _fir_spent += work
    else:
        flat = np.ascontiguousarray(x).reshape(-1, x.shape[-1])
        out = fast.fir(flat, np.ascontiguousarray(half, dtype=float), int(start), int(count), int(stride))
        _fir_warm = True
        return np.moveaxis(out.reshape(x.shape[:-1] + out.shape[1:]), -2, -1)
    h, orders = half.shape[0] - 1, half.shape[1]
    out = np.empty(x.shape[:-1] + (orders, count))
    rows = int(np.prod(x.shape[:-1], dtype=np.int64))
    step = max(1, FIR_BLOCK // max(1, rows))
    width = min(step, count)
    pair = np.empty(x.shape[:-1] + (2, width))        # x[m+j] + x[m-j], x[m+j] - x[m-j]
    part = np.empty(x.shape[:-1] + (width,))
    for a in range(0, count, step):                 # blocks of samples: the temporaries stay in cache
        b = min(count, a + step)
        m0, m1 = start + h + a * stride, start + h + (b - 1) * stride + 1     # the middles
        plus, minus, prod = pair[..., 0, :b - a], pair[..., 1, :b - a], part[..., :b - a]
        for k in range(orders):
            np.multiply(x[..., m0:m1:stride], half[0, k], out=out[..., k, a:b])
        for j in range(1, h + 1):
            np.add(x[..., m0 + j:m1 + j:stride], x[..., m0 - j:m1 - j:stride], out=plus)
            np.subtract(x[..., m0 + j:m1 + j:stride], x[..., m0 - j:m1 - j:stride], out=minus)
            for k in range(orders):
                np.multiply(minus if k % 2 else plus, half[j, k], out=prod)
                out[..., k, a:b] += prod
    return np.moveaxis(out, -2, -1)


def step_seen(t: np.ndarray, onsets: np.ndarray, order: int, window: float | None, ts: float) -> np.ndarray:
    """(rows, t.size): a unit step at each of ``onsets`` as a residual computed from filtered
    signals sees it, when the step makes the ``order``-th derivative of the measured signals jump
    (a resistance that steps makes a capacitor's voltage's slope jump, ``order`` 1; a damping
    coefficient an inertia's acceleration, ``order`` 2): the Savitzky-Golay filter of that order
    (:func:`kernels`, the window the residuals use) applied to (t - onset)_+^order / order!, the
    signal whose ``order``-th derivative is the step. Where the filter's window lies wholly before
    an onset it is exactly 0, wholly at or after it exactly 1 (the filter is exact on polynomials),
    so only the 2 h samples around each onset are computed.

    Why: a residual's derivative terms are filtered, so a parameter step's effect on them is
    spread over the filter's window, while the parameter's own term in the residual stepped
    sharply: the true fault paid the mismatch over a window at its onset, a sensor's or a
    source's fault (applied to the signal before the filter) did not, and a long window against a
    short identification span made a parametric fault lose to another kind (a water heater's
    insulation, 901 s window: its true values cost 686, an element fault 181). For a fault whose
    magnitude enters the residuals affinely (:func:`fdi.objective.linear_transform`) the residual
    is then exactly the filter's view of the two levels, blended.

    A step at 0.5 s seen by the slope filter of a 0.1 s window at 100 Hz: 0 and 1 away from it,
    about a half at it:

    >>> t = np.arange(0.0, 1.0, 0.01)
    >>> s = step_seen(t, np.array([0.5]), 1, 0.1, 0.01)[0]
    >>> float(s[40]), float(s[60]), bool(0.3 < s[50] < 0.7)
    (0.0, 1.0, True)
    """
    t = np.asarray(t, dtype=float)
    onsets = np.atleast_1d(np.asarray(onsets, dtype=float))
    out = (t[None, :] >= onsets[:, None]).astype(float)
    blends = step_blends(t, onsets, order, window, ts)
    if blends is not None:
        at, seen, valid = blends
        out[blend_rows(valid), at[valid]] = seen[valid]
    return out


def step_blends(t: np.ndarray, steps: np.ndarray, order: int, window: float | None, ts: float) -> tuple | None:
    """Where :func:`step_seen` is neither the sharp step's 0 nor its 1: for each step time of
    ``steps`` (1-D), the samples whose filter window holds it (``at``: q - h .. q + h - 1, q the
    first sample at or after it), the step as the filter sees it there (``seen``), both (steps, 2 h),
    and where the window lies inside ``t`` (``valid``, a mask: :func:`blend_rows` gives each valid
    place's step); None when no window fits. A caller that needs
    only a function of the seen step (:meth:`fdi.objective.Objective.seen_steps`) computes it on
    these 2 h samples a step, not on the whole window."""
    nw = t.size
    p = max(DEFAULT_ORDER, order)
    n = window_samples(window, ts, p)
    h = n // 2
    if not steps.size or nw < n:
        return None
    table = _step_table(n, p, order, float(ts))                          # (2 h, order + 1)
    q = np.searchsorted(t, steps, side="left")
    inside = q < nw
    if order == 0:               # the smoothing filter's view of a step: the same wherever between two samples
        seen = np.broadcast_to(table[:, 0], (steps.size, 2 * h))
    else:
        frac = np.zeros(steps.size)
        frac[inside] = (t[q[inside]] - steps[inside]) / ts               # where the step falls before q, in samples
        seen = (frac[:, None] ** np.arange(order + 1)[None, :]) @ table.T    # (steps, 2 h)
    at = q[:, None] + np.arange(-h, h)[None, :]
    valid = inside[:, None] & (at >= h) & (at < nw - h)
    return at, seen, valid


def smoothed_step(window: float | None, ts: float) -> np.ndarray:
    """(2 h,): a unit step as the smoothing filter (order 0) sees it at the samples q - h .. q + h - 1
    (q the first sample at or after the step, n = 2 h + 1 the filter's window): the same wherever
    the step falls between two samples (:func:`step_blends`' ``seen`` for order 0, one row).

    >>> s = smoothed_step(0.05, 0.01)
    >>> s.size, bool(s[0] < 0.5 < s[-1])
    (4, True)
    """
    p = DEFAULT_ORDER
    n = window_samples(window, ts, p)
    return _step_table(n, p, 0, float(ts))[:, 0]


def blend_rows(valid: np.ndarray) -> np.ndarray:
    """The step (row) of each place :func:`step_blends` marks ``valid``, in the mask's order."""
    return np.broadcast_to(np.arange(valid.shape[0])[:, None], valid.shape)[valid]


def edges_seen(t: np.ndarray, edges: np.ndarray, signs: np.ndarray, order: int, window: float | None,
               ts: float) -> np.ndarray:
    """(rows, t.size): the sum over each row's ``edges`` (NaN: none) of ``signs`` times a unit step
    there, as :func:`step_seen` sees each: a square wave's rises (+1) and falls (-1), an
    intermittent fault's profile. Exactly the sum of the sharp steps where no edge is within half
    a window; within it, each edge's blend added (the filter is linear). For order 0 on a compiled
    path (:mod:`fdi.kernels`) :func:`fdi._jit.edges_seen0` computes it, the same bits.

    >>> t = np.arange(0.0, 2.0, 0.01)
    >>> s = edges_seen(t, np.array([[0.5, 1.2]]), np.array([[1.0, -1.0]]), 0, 0.1, 0.01)[0]
    >>> float(s[40]), float(s[80]), float(s[150]), bool(0.3 < s[50] < 0.7)
    (0.0, 1.0, 0.0, True)
    """
    t = np.asarray(t, dtype=float)
    edges = np.atleast_2d(np.asarray(edges, dtype=float))
    fast = _kernels.jit() if order == 0 and edges.size and _kernels.cheap() else None
    if fast is not None:          # compiled, the same bits (fdi._jit.edges_seen0): 100 rows 5.2 -> 0.4 ms
        given = np.atleast_2d(np.asarray(signs, dtype=float))
        if given.shape != edges.shape and given.shape != (1, edges.shape[1]):
            given = np.broadcast_to(given, edges.shape)
        p = DEFAULT_ORDER
        n = window_samples(window, ts, p)
        return fast.edges_seen0(t, edges, np.ascontiguousarray(given), _step_table(n, p, 0, float(ts))[:, 0],
                                n // 2, t.size >= n)
    signs = np.broadcast_to(np.asarray(signs, dtype=float), edges.shape)
    rows, nw = edges.shape[0], t.size
    r, e = np.nonzero(np.isfinite(edges))
    at_edge, sign = edges[r, e], signs[r, e]
    jumps = np.zeros((rows, nw + 1))
    np.add.at(jumps, (r, np.searchsorted(t, at_edge, side="left")), sign)
    out = np.cumsum(jumps[:, :nw], axis=1)                               # the sharp steps
    blends = step_blends(t, at_edge, order, window, ts)
    if blends is not None:                                               # each edge's blend for its sharp step
        at, seen, valid = blends
        h = at.shape[1] // 2
        _add_in_order(out.reshape(-1), ((r * nw)[:, None] + at)[valid],
                      (sign[:, None] * (seen - (np.arange(2 * h) >= h)))[valid])
    return out


def _add_in_order(out: np.ndarray, at: np.ndarray, terms: np.ndarray) -> None:
    """``np.add.at(out, at, terms)``, the same bits: the places one term reaches take a plain
    indexed sum, only those several reach (two edges' windows meeting) np.add.at's sequential one,
    in its order. Measured on 100 square waves of 40 edges (a 1 050-sample window), with the
    order-0 blends taken as one vector (:func:`step_blends`): edges_seen 9.6 -> 6.3 ms."""
    shared = np.bincount(at, minlength=out.size)[at] > 1
    out[at[~shared]] += terms[~shared]
    if shared.any():
        np.add.at(out, at[shared], terms[shared])


@lru_cache(maxsize=16)
def _step_table(n: int, polyorder: int, order: int, ts: float) -> np.ndarray:
    """(n - 1, order + 1): :func:`step_seen` at the samples q + o, o = -h .. h - 1 (q the first
    sample at or after the onset), as a polynomial in f = (t_q - onset) / ts: the filter's taps
    c_k on (t_(q+o+k) - onset)_+^order / order! = (ts (o + k + f))^order / order! for o + k >= 0,
    expanded by the binomial theorem (uniform sampling, as the filters assume)."""
    h = n // 2
    half = centred(n, polyorder, order, ts)[:, order]
    taps = np.concatenate([half[:0:-1] * (-1.0) ** order, half])        # on x[m - h] .. x[m + h]
    out = np.empty((2 * h, order + 1))
    if order == 0:                                                       # the taps at or after the onset
        out[:, 0] = np.cumsum(taps[::-1])[::-1][2 * h:0:-1]                # offset o: the taps k >= -o
    else:
        k = np.arange(-h, h + 1)
        for lo in range(0, 2 * h, STEP_TABLE_ROWS):                      # blocks of offsets: memory ~ rows x n
            o = np.arange(lo - h, min(2 * h, lo + STEP_TABLE_ROWS) - h)[:, None]
            reach = (o + k[None, :]).astype(float)                       # sample offsets from q
            after = reach >= 0
            for m in range(order + 1):
                terms = np.where(after, reach ** (order - m), 0.0) * taps[None, :]
                out[lo:lo + o.shape[0], m] = comb(order, m) * ts ** order / factorial(order) * terms.sum(axis=1)
    out.setflags(write=False)
    return out


STEP_TABLE_ROWS = 256       # offsets of _step_table computed at a time (a 10 kHz, 1 s window: 256 x 10 001 values)


@lru_cache(maxsize=64)
def centred(n: int, polyorder: int, orders: int, ts: float) -> np.ndarray:
    """(n // 2 + 1, orders + 1): the centred kernels of :func:`kernels` (the middle tap, then the
    taps j = 1 .. n // 2 after it), each tap averaged with (-1)^k times its mirror image, so that
    order k is exactly symmetric or antisymmetric (the least-squares fit is, up to round-off; an
    odd order's middle weight is then exactly 0), as :func:`fir` reads them."""
    full = kernels(n, polyorder, orders, ts, n // 2)
    h = n // 2
    sign = np.array([(-1.0) ** k for k in range(orders + 1)])
    out = 0.5 * (full[h:] + sign * full[h::-1])
    out.setflags(write=False)
    return out


@lru_cache(maxsize=64)
def kernels(n: int, polyorder: int, orders: int, ts: float, pos: int) -> np.ndarray:
    """(n, orders + 1): column k, applied to n samples, gives the k-th derivative at sample ``pos``
    of the least-squares polynomial of order ``polyorder`` through them."""
    offsets = (np.arange(n) - pos).astype(float)
    fit = np.linalg.pinv(np.vander(offsets, polyorder + 1, increasing=True))    # (p + 1, n): samples -> coefficients
    out = np.stack([factorial(k) / ts ** k * fit[k] for k in range(orders + 1)], axis=1)
    out.setflags(write=False)
    return out


@lru_cache(maxsize=64)
def kernels_at(n: int, polyorder: int, orders: int, ts: float, first: int, stop: int) -> np.ndarray:
    """(n, positions, orders + 1): the kernels for every position in [first, stop) of one window."""
    out = np.stack([kernels(n, polyorder, orders, ts, pos) for pos in range(first, stop)], axis=1)
    out.setflags(write=False)
    return out
