"""What the residuals themselves say about a fault before any fit: its period, its phase, its onset.

The identification's narrow basins (an intermittent fault's period and phase, an onset) are found
far more surely from a seed the data give than from a random screen:

- **Period and phase** (:func:`square_waves`). Eq. (15) makes an intermittent fault faulty during
  the first half of each period T from its onset t0, so a residual it enters carries the fault's
  effect switched on and off by a square wave of period T: its magnitude |r(t)| (the excitation may
  change the sign of the effect, not whether it is there) has a spectral peak at 1/T. The peaks of
  the periodogram of |r| that stand out of the periodogram's own median by ``SIGNIFICANCE`` are
  refined by the square wave that correlates best with |r| (periods within ``REFINE`` of the peak,
  phases one sample apart): the periodogram's bin is 1/span wide, far coarser than the basin
  (0.7 % of the period on the CyCab's 0.7 s encoder fault). :func:`candidate_periods` adds each
  peak's harmonics and sub-harmonics (a square wave's third harmonic is a peak of its own; a
  search seeded at T/3 alone fits the wrong period).
- **Onset** (:func:`departure`, :func:`onset_interval`). A residual leaves its noise band (the
  largest deviation from its median over a stretch before the fault, times ``BAND_MARGIN``) at or
  after the fault begins, and the centred derivative filter makes it move up to its look-ahead
  (nesting depth x half the derivative window) before: the onset is never earlier than the first
  departure minus that look-ahead, and never later than the detection plus it.

A square wave of period 0.7 s from t0 = 0.2 s, seen through |r| with noise, is found with its phase;
noise alone gives no period:

>>> import numpy as np
>>> t = np.arange(0.0, 10.0, 0.01)
>>> x = np.abs(np.where(np.sin(2 * np.pi * (t - 0.2) / 0.7) > 0, 1.0, 0.0)
...            + 0.2 * np.random.default_rng(0).standard_normal(t.size))
>>> (w,) = square_waves(x, 0.01, 0.5, 10.0, count=1)
>>> bool(abs(w.period - 0.7) < 0.002), bool(abs(w.phase - 0.2) < 0.015)    # within 0.3 % and 1.5 samples
(True, True)
>>> square_waves(np.abs(np.random.default_rng(1).standard_normal(t.size)), 0.01, 0.5, 10.0)
()
"""
from __future__ import annotations

import hashlib
from collections import OrderedDict
from dataclasses import dataclass
from typing import Callable

import numpy as np

from . import kernels

SIGNIFICANCE = 25.0   # a peak of the periodogram of |r| this many times its median (of white noise: max/median ~ 10)
REFINE_VALUES = 1 << 18   # positions per block of periods in refine (2 MB per temporary)
REFINE = 0.04         # periods searched within 4 % of the periodogram's peak (its bin at 14 periods per window: 7 %)
LOCAL = 2.0           # the median a peak is compared with: over frequencies from f / 2 to 2 f
PAD = 8               # zero padding of the periodogram: peaks located to an eighth of a bin before the refinement
BAND_MARGIN = 1.2     # the noise band: the reference stretch's largest deviation times this
MULTIPLES = (1.0, 2.0, 3.0, 0.5, 1.0 / 3.0)   # each peak's period, its sub-harmonics and harmonics


@dataclass(frozen=True)
class SquareWave:
    """A square wave found in |r|: its period T (s), its phase (s, in [0, T): the wave is high on
    [phase + k T, phase + k T + T/2)), and its strength (the peak over the periodogram's median)."""
    period: float
    phase: float
    strength: float


def square_waves(x: np.ndarray, ts: float, low: float, high: float, count: int = 5) -> tuple[SquareWave, ...]:
    """Up to ``count`` square waves of period in [low / 3, high] (s) in the magnitude signal ``x``
    (sampled every ``ts`` s; time 0 at its first sample), strongest first; none when no peak of its
    periodogram stands ``SIGNIFICANCE`` times above the periodogram's median from half to twice its
    frequency (``LOCAL``). A record near a double's range (1e300) overflows the periodogram: no
    wave, no warning."""
    with np.errstate(all="ignore"):
        return _square_waves(x, ts, low, high, count)


def _square_waves(x: np.ndarray, ts: float, low: float, high: float, count: int) -> tuple[SquareWave, ...]:
    x = np.asarray(x, dtype=float)
    x = x[np.isfinite(x)] if not np.isfinite(x).all() else x
    n = x.size
    if n < 8 or high <= 0:
        return ()
    y = x - x.mean()
    power = np.abs(np.fft.rfft(y, PAD * n)) ** 2
    freq = np.fft.rfftfreq(PAD * n, ts)
    # down to a third of the shortest period: a sensor's gain switching makes its derivatives spike at
    # both edges, a peak at T/2 (measured on the CyCab encoder fault of period 0.7 s: the peak at 0.35 s)
    band = (freq >= 1.0 / high) & (freq <= 1.0 / max(low / 3, 2 * ts)) & (freq > 0)
    if band.sum() < 3:
        return ()
    p = np.where(band, power, 0.0)
    peaks = np.flatnonzero((p[1:-1] > p[:-2]) & (p[1:-1] >= p[2:])) + 1
    # against the periodogram's median within an octave around the peak: filtered noise is coloured
    local = {int(k): float(np.median(power[(freq >= freq[k] / LOCAL) & (freq <= freq[k] * LOCAL) & (freq > 0)]))
             or 1e-300 for k in peaks}
    peaks = np.asarray([k for k in peaks if p[k] >= SIGNIFICANCE * local[int(k)]], dtype=int)
    out: list[SquareWave] = []
    for k in peaks[np.argsort(-p[peaks])]:
        period = 1.0 / freq[k]
        if any(abs(period - w.period) <= REFINE * w.period for w in out):
            continue
        T, phase = refine(y, ts, period, low / 3, high)
        out.append(SquareWave(T, phase, float(p[k] / local[int(k)])))
        if len(out) == count:
            break
    return tuple(out)


def refine(y: np.ndarray, ts: float, period: float, low: float, high: float,
           steps: int = 81, reach: float | None = None) -> tuple[float, float]:
    """The period within ``REFINE`` of ``period`` (or one periodogram bin: few periods in the data
    leave a peak as wide as T / span) and the phase whose square wave correlates best
    with the zero-mean magnitude ``y``: (period, phase) in s.

    The score of a phase, sum(y where the wave is high) - sum(y where it is low), is read off the
    prefix sums of y sorted by each sample's position within the period (O(n log n) per period,
    not O(n x phases)). The periods are taken a block at a time (sorts, prefix sums and scores in
    one pass per block, at most ``REFINE_VALUES`` positions): the same operations per period as
    one at a time, so the same numbers, without a dozen numpy calls per period.

    >>> ts = 0.01
    >>> t = ts * np.arange(2000)
    >>> y = np.where(np.mod(t - 0.3, 0.7) < 0.35, 1.0, 0.0)
    >>> T, phase = refine(y - y.mean(), ts, 0.69, 0.5, 1.0)
    >>> round(T, 3), round(phase, 2)       # high on (phase, phase + T/2): the sample before 0.3 s
    (0.7, 0.29)
    """
    y = np.asarray(y, dtype=float)
    n = y.size
    t = ts * np.arange(n)
    total = float(y.sum())
    best = (-np.inf, period, 0.0)
    if reach is None:
        reach = max(REFINE, period / (ts * n))      # a periodogram bin, as a share of the period: T / span
    periods = np.unique(np.clip(period * (1 + np.linspace(-reach, reach, steps)), low, high))
    rows = max(1, REFINE_VALUES // max(1, n))
    for first in range(0, periods.size, rows):
        Ts = periods[first:first + rows]
        pos = np.mod(t[None, :], Ts[:, None])                   # each period's np.mod(t, T)
        order = np.argsort(pos, axis=1, kind="stable")
        pos = np.take_along_axis(pos, order, axis=1)
        cum = np.zeros((Ts.size, n + 1))
        np.cumsum(y[order], axis=1, out=cum[:, 1:])             # each row summed in order, as one at a time
        phases = [np.arange(0.0, T, max(ts, T / 200)) for T in Ts]
        counts = [p.size for p in phases]
        ph = np.concatenate(phases)
        T_of = np.repeat(Ts, counts)
        row = np.repeat(np.arange(Ts.size), counts)
        # high on ((t - phase) mod T) in (0, T/2): positions in (phase, phase + T/2), wrapping past T
        end = ph + T_of / 2
        inside = end < T_of
        upto = np.minimum(end, T_of)
        wrapped = np.where(~inside, end - T_of, 0.0)
        a, b, b2 = np.empty(ph.size, dtype=np.intp), np.empty(ph.size, dtype=np.intp), np.empty(ph.size, dtype=np.intp)
        at = 0
        for r, count in enumerate(counts):
            part = slice(at, at + count)
            a[part] = np.searchsorted(pos[r], ph[part], side="right")
            b[part] = np.searchsorted(pos[r], upto[part], side="left")
            b2[part] = np.searchsorted(pos[r], wrapped[part], side="left")
            at += count
        b = np.where(inside, b, n)
        high_sum = cum[row, b] - cum[row, a]
        high_sum = high_sum + np.where(~inside, cum[row, b2], 0.0)
        score = 2.0 * high_sum - total
        at = 0
        for r, count in enumerate(counts):
            i = int(np.argmax(score[at:at + count]))
            if score[at + i] > best[0]:
                best = (float(score[at + i]), float(Ts[r]), float(phases[r][i]))
            at += count
    return best[1], best[2]


_PERIODS: OrderedDict = OrderedDict()     # periods(): the latest magnitudes' answers, by content
PERIODS_KEPT = 64


def periods(x: np.ndarray, ts: float, low: float, high: float) -> list[tuple[float, float]]:
    """:func:`candidate_periods` of the :func:`square_waves` in the magnitude ``x`` (none when ``x``
    is empty), kept for the last ``PERIODS_KEPT`` magnitudes by their bytes: a pure function of its
    inputs, and the estimators of one diagnosis ask it again and again for the same residuals on
    the same window (the tutorial's RC filter: 15 objectives, 1.6 of 9 s CPU in these hints).

    >>> ts = 0.01
    >>> t = ts * np.arange(2000)
    >>> x = np.where(np.mod(t - 0.3, 0.7) < 0.35, 1.0, 0.0)
    >>> [round(T, 2) for T, _ in periods(x, ts, 0.5, 1.0)]     # the strongest wave first
    [0.7, 0.69, 0.71, 0.67]
    >>> periods(x, ts, 0.5, 1.0) == candidate_periods(x, ts, square_waves(x, ts, 0.5, 1.0), 0.5, 1.0)
    True
    """
    x = np.ascontiguousarray(x, dtype=float)
    key = (hashlib.blake2b(x.tobytes(), digest_size=16).digest(), x.size, float(ts), float(low), float(high))
    return list(_kept(_PERIODS, PERIODS_KEPT, key, lambda: tuple(
        candidate_periods(x, ts, square_waves(x, ts, low, high) if x.size else (), low, high))))


def _kept(cache: OrderedDict, size: int, key, compute):
    """``cache[key]``, computed by ``compute()`` when absent; the ``size`` latest answers are kept.
    Threads may share a cache: an entry another one dropped meanwhile is no error."""
    got = cache.get(key)
    if got is None:
        got = cache[key] = compute()
    try:
        cache.move_to_end(key)
        while len(cache) > size:
            cache.popitem(last=False)
    except KeyError:
        pass
    return got


def candidate_periods(x: np.ndarray, ts: float, waves: tuple[SquareWave, ...], low: float,
                      high: float) -> list[tuple[float, float]]:
    """(period, phase) pairs to seed a search with: each wave's period and its multiples
    (``MULTIPLES``) within [low, high], every wave's own first, then every wave's double, ...,
    without repeats. A multiple gets its own phase (and its period a last touch, within a
    twentieth of ``REFINE``) from the magnitude ``x``: the edges of a wave at T/2 (a sensor's gain
    switching) do not say which half of T is faulty."""
    x = np.asarray(x, dtype=float)
    y = np.where(np.isfinite(x), x, 0.0)
    y = y - y.mean()
    out: list[tuple[float, float]] = []
    for m in MULTIPLES:
        for w in waves:
            T = w.period * m
            if low <= T <= high and not any(abs(T - u) <= 1e-3 * u for u, _ in out):
                out.append((T, w.phase % T) if m == 1.0 else refine(y, ts, T, low, high, steps=9, reach=REFINE / 20))
    return out


def aligned_onsets(period: float, phase: float, origin: float, low: float, high: float,
                   limit: int = 64) -> list[float]:
    """The onsets in [low, high] (s) at which a square wave of ``period`` and ``phase`` (relative to
    ``origin``, s) switches on, the first ``limit`` of them; the switch nearest the interval when
    none falls inside."""
    k0 = int(np.ceil((low - origin - phase) / period - 1e-9))
    out = [origin + phase + k * period for k in range(k0, k0 + limit) if origin + phase + k * period <= high + 1e-9]
    if out:
        return out
    return [float(np.clip(origin + phase + (k0 - 1) * period, low, high))]


def noise_band(r: np.ndarray, reference: np.ndarray) -> tuple[float, float]:
    """The residual's median over the ``reference`` samples (a boolean mask of a stretch without
    fault) and its band: the largest deviation from that median there, times ``BAND_MARGIN``."""
    ref = r[reference & np.isfinite(r)]
    if ref.size == 0:
        return 0.0, np.inf
    centre = float(np.median(ref))
    return centre, BAND_MARGIN * float(np.max(np.abs(ref - centre)))


def departure(r: np.ndarray, t: np.ndarray, start: float, until: float) -> float | None:
    """Where the residual ``r`` first leaves its noise band after the reference stretch: the band
    from the first half of [start, until] (a stretch before the fault: from the settling time to
    the threshold crossing), the departure the first sample of the second half outside it. None
    when it never leaves.

    >>> t = np.arange(0.0, 20.0, 0.01)
    >>> r = 0.1 * np.sin(37 * t) + np.where(t >= 12.0, 1.0, 0.0)
    >>> departure(r, t, 1.0, 15.0)
    12.0
    """
    r = np.asarray(r, dtype=float)
    middle = (start + until) / 2
    centre, band = noise_band(r, (t >= start) & (t < middle))
    out = np.flatnonzero((t >= middle) & (t <= until) & (np.abs(r - centre) > band))
    return float(t[out[0]]) if out.size else None


def evidence(r: np.ndarray, t: np.ndarray, thresholds: np.ndarray, start: float) -> list[tuple[int, float, float]]:
    """For each residual (a row of ``r``) that crosses its threshold at or after ``start``: its
    index, its first crossing, and where its evidence begins, its departure from its noise band
    before that crossing (:func:`departure`; the crossing itself where it never leaves the band).

    >>> t = np.arange(0.0, 20.0, 0.01)
    >>> r = np.vstack([0.1 * np.sin(37 * t) + np.where(t >= 12.0, 1.0, 0.0), 0 * t])
    >>> evidence(r, t, np.array([0.5, 0.5]), 1.0)
    [(0, 12.0, 12.0)]
    """
    r = np.asarray(r, dtype=float).reshape(len(thresholds), -1)
    out = []
    for i, (row, thr) in enumerate(zip(r, thresholds)):
        over = np.flatnonzero((t >= start) & (np.abs(row) > thr))
        if over.size:
            cross = float(t[over[0]])
            dep = departure(row, t, start, cross)
            out.append((i, cross, cross if dep is None else dep))
    return out


def onset_interval(r: np.ndarray, t: np.ndarray, thresholds: np.ndarray, t_d: float, start: float,
                   lookahead: np.ndarray, late: float | None = None) -> tuple[float, float]:
    """The onsets the evidence allows: from the earliest departure from its noise band
    (:func:`departure`, before its first threshold crossing at or after ``start``) of a residual
    that crossed, minus its ``lookahead`` (s), to the detection ``t_d`` plus the look-ahead of the
    residuals that crossed at t_D (the filter crosses before the fault); from ``late`` instead where
    the excursion that confirmed the detection began there, apart from t_D's
    (:attr:`fdi.detect.Detection.excursion`). ``r`` (residuals x samples), ``thresholds`` and
    ``lookahead`` one per residual.

    >>> t = np.arange(0.0, 20.0, 0.01)
    >>> r = np.vstack([0.1 * np.sin(37 * t) + np.where(t >= 12.0, 0.1 * (t - 12.0) ** 2, 0.0), 0 * t])
    >>> lo, hi = onset_interval(r, t, np.array([1.0, 1.0]), 15.0, 1.0, np.array([0.25, 0.25]))
    >>> bool(12.0 - 0.25 <= lo <= 12.0 + 1.0), hi     # the drift starts at 12 s; the band is 0.12 wide
    (True, 15.25)
    """
    lookahead = np.broadcast_to(np.asarray(lookahead, dtype=float), (len(thresholds),))
    late = t_d if late is None else max(t_d, late)
    lows, highs = [], []
    for i, cross, began in evidence(r, t, thresholds, start):
        if cross <= late + 1e-9:
            highs.append(late + lookahead[i])
        lows.append(began - lookahead[i])
    if not lows:
        return t_d, late + float(lookahead.max(initial=0.0))
    return max(float(t[0]), min(min(lows), t_d)), float(max(highs) if highs else late + lookahead.max())


def intermittent_rows(spaces: list, bits: np.ndarray, seeds: list[list[tuple[float, float]]],
                      onsets=None, levels: int = 4) -> np.ndarray:
    """Decision vectors (``fdi.encoding``'s reals, plus the onset last when ``onsets`` is given)
    seeding the intermittent faults of the structure of ``bits``: for each such fault j and each
    (period, phase) of ``seeds[j]``, ``levels`` faulty values spread over its bounds, the onset at
    each of ``onsets(period, phase)``; NaN elsewhere (the engine draws those). No rows when the
    structure has no intermittent fault with a seed."""
    from . import encoding
    d = encoding.N_REAL * len(spaces) + (1 if onsets is not None else 0)
    blocks = []
    for j, kind in enumerate(_kinds(spaces, bits)):
        if kind != 1 or not seeds[j]:
            continue
        for period, phase in seeds[j]:
            block = _value_grid(spaces[j], j, onsets(period, phase) if onsets is not None else None, levels, d)
            block[:, encoding.N_REAL * j + 1] = period
            blocks.append(block)
    return np.vstack(blocks) if blocks else np.empty((0, d))


def step_rows(spaces: list, bits: np.ndarray, onsets: list[list[float]], levels: int) -> np.ndarray:
    """Decision vectors (``fdi.encoding``'s reals, the onset last) seeding the abrupt faults of the
    structure of ``bits`` that have ``onsets``: for each such fault j, ``levels`` values spread
    evenly over its bounds (in its decades when logarithmic) at each onset of ``onsets[j]``; NaN
    elsewhere (the engine draws those). No rows when none has.

    >>> from fdi import encoding
    >>> s = encoding.FaultSpace.make("Kv", 2e-8, (2e-10, 2e-6))
    >>> _, bits = encoding.encode([s], [{"type": "abrupt", "value": 2e-8}])
    >>> rows = step_rows([s], bits, [[2.0, 2.001]], 4)
    >>> rows.shape, rows[:4, 0].round(2).tolist(), rows[[0, 4], -1].tolist()
    ((8, 10), [-9.2, -8.2, -7.2, -6.2], [2.0, 2.001])
    """
    from . import encoding
    d = encoding.N_REAL * len(spaces) + 1
    blocks = [_value_grid(spaces[j], j, onsets[j], levels, d)
              for j, kind in enumerate(_kinds(spaces, bits)) if kind == 0 and onsets[j]]
    return np.vstack(blocks) if blocks else np.empty((0, d))


def _kinds(spaces: list, bits: np.ndarray) -> list[int]:
    """Each fault's type in the structure of ``bits`` (0 abrupt, 1 intermittent, 2 incipient)."""
    from . import encoding
    decoded = encoding.decode(spaces, np.zeros((1, encoding.N_REAL * len(spaces))), np.asarray(bits)[None, :])
    return [int(dec.kind[0]) for dec in decoded]


def _value_grid(space, j: int, starts, levels: int, d: int) -> np.ndarray:
    """(len(starts) x levels, d) rows, NaN but for fault j's value, ``levels`` of them spread evenly
    over its bounds (``fdi.encoding``'s reals: its decades when logarithmic), at each onset of
    ``starts`` in the last column (values inner); one set of values and no onset when ``starts`` is
    None."""
    from . import encoding
    lo, hi = encoding.bounds([space])[0]
    values = lo + (np.arange(levels) + 0.5) / levels * (hi - lo)
    count = 1 if starts is None else len(starts)
    block = np.full((count * levels, d), np.nan)
    block[:, encoding.N_REAL * j] = np.tile(values, count)
    if starts is not None:
        block[:, -1] = np.repeat(np.asarray(starts, dtype=float), levels)
    return block


def nesting_depth(residual) -> int:
    """How many derivative filters a residual's samples pass through in series: one for its signals,
    and for a stored quantity it differentiates (``composites``), one for the rate plus those of the
    quantity's own inputs: none where it reads measured samples (C e of the measured e,
    :class:`fdi.residuals.Estimates`), one where it reads a derivative, more for a stored quantity
    inside it (the three tanks' d(C1 p1)/dt inside d(C2 (...))/dt: two)."""
    return max([1] + [1 + _inside(kernel) for _, kernel in getattr(residual, "composites", ())])


def _inside(kernel) -> int:
    """The filters in series inside a stored quantity's expression (see :func:`nesting_depth`)."""
    reads = 1 if any(k >= 1 for _, k in kernel.signals) else 0
    return max([reads] + [1 + _inside(inner) for _, inner in getattr(kernel, "composites", ())])


def _draws(rng: np.random.Generator, box: np.ndarray, linear: list[bool], count: int | None = None) -> np.ndarray:
    """``count`` (default TRANSLATE_DRAWS) points in ``box`` (one row per coefficient): uniform, and
    for a coefficient coded as itself (``linear``; eq. 18's rate is coded as a logarithm already) whose box holds
    zero, half of them log-uniform in magnitude (five decades below the box's largest, either
    sign). Why: eq. (19)'s box is [-20, 20] x [-1, 1]^2 and a slow drift's b6, b7 are
    a few thousandths; uniform draws almost never come near them and the halving boxes then close
    on a wrong basin (an encoder drift of eq. 19 with b = [10.4, 0.002, -0.0045] re-expressed from an
    eq. (18) fit: profile error 19.4 uniform, 2.1 with these draws; the engine's cost 7094 for a fit
    of 457)."""
    lo, hi = box[:, 0], box[:, 1]
    x = lo + rng.random((count or TRANSLATE_DRAWS, len(box))) * (hi - lo)
    span = np.maximum(np.abs(lo), np.abs(hi))
    both = (lo < 0) & (hi > 0) & np.asarray(linear, dtype=bool)
    if both.any():
        mag = span * 10.0 ** rng.uniform(-TRANSLATE_DECADES, 0.0, x.shape)
        signed = np.clip(np.where(rng.random(x.shape) < 0.5, -mag, mag), lo, hi)
        x = np.where(both & (rng.random(x.shape) < 0.5), signed, x)
    return x


def _line_search(rng: np.random.Generator, box: np.ndarray, linear: list[bool],
                 cost: Callable[[np.ndarray], np.ndarray]) -> np.ndarray | None:
    """The coefficient of a one-coefficient model (eqs. 16, 17) nearest by ``cost``: LINE_DRAWS draws
    over the box (:func:`_draws`), then LINE_ROUNDS even grids of LINE_POINTS between the best
    point's neighbours among those evaluated (each round narrows the bracket some eight times).
    Why: the shrinking random search of several coefficients spent 5 376 profiles on one; on 52
    such translations of scenario 2 and the tutorial (captured, replayed) this finds a distance no
    worse on every one, 260 times smaller on one, with 224. None when no point has a finite cost.

    >>> rng = np.random.default_rng(0)
    >>> x = _line_search(rng, np.array([[-1.0, 1.0]]), [True], lambda x: np.abs(x[:, 0] - 0.0123))
    >>> bool(abs(x[0] - 0.0123) < 1e-6)
    True
    """
    lo, hi = box[0]
    xs = _draws(rng, box, linear, LINE_DRAWS)[:, 0]
    es = cost(xs[:, None])
    for _ in range(LINE_ROUNDS):
        x = xs[int(np.argmin(es))]
        below, above = xs[xs < x], xs[xs > x]      # its neighbours among the distinct points evaluated
        a = below.max() if below.size else lo
        b = above.min() if above.size else hi
        grid = np.linspace(a, b, LINE_POINTS + 2)[1:-1]
        xs, es = np.concatenate([xs, grid]), np.concatenate([es, cost(grid[:, None])])
    k = int(np.argmin(es))
    return np.array([xs[k]]) if np.isfinite(es[k]) else None


def _box_search(rng: np.random.Generator, box: np.ndarray, linear: list[bool],
                cost: Callable[[np.ndarray], np.ndarray]) -> np.ndarray | None:
    """The coefficients of a model of several (eqs. 18, 19) nearest by ``cost``: TRANSLATE_ROUNDS
    rounds of TRANSLATE_DRAWS draws (:func:`_draws`), each in a box half as wide around the best
    so far (the best kept among the next round's draws). None when no point has a finite cost."""
    best_x, best_e = None, np.inf
    lo, hi = box[:, 0].copy(), box[:, 1].copy()
    for _ in range(TRANSLATE_ROUNDS):
        x = _draws(rng, box, linear)
        if best_x is not None:
            x[0] = best_x
        e = cost(x)
        i = int(np.argmin(e))
        if e[i] < best_e:
            best_x, best_e = x[i].copy(), float(e[i])
        half = (box[:, 1] - box[:, 0]) / 4
        centre = best_x if best_x is not None else (box[:, 0] + box[:, 1]) / 2
        box = np.column_stack([np.maximum(lo, centre - half), np.minimum(hi, centre + half)])
    return best_x


LINE_DRAWS = 128          # a one-coefficient translation: draws over the box first,
LINE_POINTS = 16          # ... then even grids of this many points between the best one's neighbours,
LINE_ROUNDS = 6           # ... this many rounds

TRANSLATE_DECADES = 5.0   # decades of magnitude below a coefficient's bound the log-uniform draws reach
TRANSLATE_POINTS = 160    # profile samples a translation compares (the window, evenly)
TRANSLATE_DRAWS = 768     # candidate coefficient vectors per round of the translation's search
TRANSLATE_ROUNDS = 7      # rounds, each in a box half as wide around the best so far


_TRANSLATED: OrderedDict = OrderedDict()   # translate(): the latest answers, by content
TRANSLATIONS_KEPT = 32


def forget() -> None:
    """Drop the answers :func:`periods` and :func:`translate` keep (a benchmark that runs the same
    diagnosis twice measures the second as a new record would cost)."""
    _PERIODS.clear()
    _TRANSLATED.clear()


def translate(spaces: list, real: np.ndarray, bits_from: np.ndarray, bits_to: np.ndarray, t: np.ndarray,
              t0: float, seed: int = 0, t0_to: float | None = None) -> np.ndarray:
    """The reals (``fdi.encoding``'s, without the onset) with which the structure of ``bits_to``
    reproduces the fault profiles that ``real`` gives under ``bits_from`` over the times ``t``, the
    onset ``t0`` shared; NaN where a fault keeps its type and model (its reals carry over as they
    are) or where nothing translates (an intermittent target from another type: the engine keeps
    its own point there). An abrupt target takes the profile's median after the onset; a
    degradation model (16)-(19) the coefficients whose profile is nearest, in the parameter's
    scale (its reciprocal when the nominal value is infinite): a line search for the one
    coefficient of eqs. (16), (17) (:func:`_line_search`), a shrinking random search over the
    coefficients' box for eqs. (18), (19). No residual is evaluated: a profile costs microseconds.
    With ``t0_to`` the target's onset is that one (a drift re-expressed as one that started earlier); an
    incipient fault that keeps its model is then re-expressed too.

    Why: a family whose degradation model differs from the winner's starts the final check from a
    screen of its own, at the rim of a narrow basin (a drift of eq. (19) at 6-7 times the winner's
    cost after the race): re-expressed from the winner's profile, it starts near the bottom when
    the data are its kind.

    An eq. (17) drift 1/P = 1 + 0.02 tau re-expressed as eq. (16) P = exp(b1 tau): over 10 s the
    nearest b1 is about the mean log-slope, -0.019:

    >>> from fdi import encoding
    >>> s = encoding.FaultSpace.make("beta", 1.0, (0.05, 1.5))
    >>> real, bits = encoding.encode([s], [{"type": "incipient", "model": 2, "b": [-0.02]}])
    >>> _, to = encoding.encode([s], [{"type": "incipient", "model": 1, "b": [0.0]}])
    >>> out = translate([s], real, bits, to, np.linspace(0.0, 10.0, 101), 0.0)
    >>> b1 = encoding.describe([s], np.where(np.isnan(out), real, out), to)[0]["b"][0]
    >>> bool(-0.021 < b1 < -0.017)
    True

    A pure function of its inputs, kept for the last ``TRANSLATIONS_KEPT`` of them by content: one
    diagnosis asks some again (the final check and the other degradation models translate the same
    winner to the same structure: 3 of scenario 2's 17).
    """
    key = (tuple(spaces), np.asarray(real, dtype=float).tobytes(), np.asarray(bits_from, dtype=bool).tobytes(),
           np.asarray(bits_to, dtype=bool).tobytes(),
           hashlib.blake2b(np.ascontiguousarray(t, dtype=float).tobytes(), digest_size=16).digest(),
           float(t0), int(seed), None if t0_to is None else float(t0_to))
    return _kept(_TRANSLATED, TRANSLATIONS_KEPT, key,
                 lambda: _translate(spaces, real, bits_from, bits_to, t, t0, seed, t0_to)).copy()


def _distance(q: np.ndarray, target: np.ndarray, first: int, inverse: bool) -> np.ndarray:
    """Each row's sum over the samples ``first:`` of |scale(q) - target| (``scale``: the reciprocal
    when ``inverse``), in one buffer laid out samples-major: each row's terms are added sample by
    sample, in the order (and to the bits) of the boolean-indexed copy this replaced, in a third
    of its time (three passes over the population's profiles instead of six)."""
    fast = kernels.jit()
    if hasattr(fast, "distance_rows") and q.ndim == 2 and q.shape[0] > 1 and q.shape[1] == target.shape[0]:
        # C: the same sums in one pass (one row only here: numpy sums a single column pairwise)
        return fast.distance_rows(q, target, first, inverse)
    qt = q.T[first:]
    d = np.empty(qt.shape)
    with np.errstate(all="ignore"):
        if inverse:
            np.divide(1.0, qt, out=d)
        else:
            d[...] = qt
        d -= target[first:, None]
        np.abs(d, out=d)
    return d.sum(axis=0)


def _translate(spaces: list, real: np.ndarray, bits_from: np.ndarray, bits_to: np.ndarray, t: np.ndarray,
               t0: float, seed: int, t0_to: float | None) -> np.ndarray:
    """:func:`translate`, computed."""

    from . import encoding
    rng = np.random.default_rng(seed)
    n_real = encoding.N_REAL
    out = np.full(n_real * len(spaces), np.nan)
    t = np.asarray(t, dtype=float)
    t = t[np.linspace(0, t.size - 1, min(t.size, TRANSLATE_POINTS)).astype(int)] if t.size else t
    after = t >= t0
    if not after.any():
        return out
    first = int(np.argmax(after))           # t ascends: the samples after the onset are t[first:]
    shift = t0_to is not None and t0_to != t0
    onset = t0 if t0_to is None else t0_to
    src = encoding.decode(spaces, real[None, :], np.asarray(bits_from)[None, :])
    dst = encoding.decode(spaces, real[None, :], np.asarray(bits_to)[None, :])
    bounds = encoding.bounds(spaces)
    for j, (space, a, b) in enumerate(zip(spaces, src, dst)):
        ka, kb = int(a.kind[0]), int(b.kind[0])
        if ka == kb and (kb != 2 or int(a.model[0]) == int(b.model[0])) and not (shift and kb == 2):
            continue
        p = encoding.profiles([space], [a], t, t0)[0][0]
        if not np.isfinite(p[after]).all():
            continue
        inverse = not np.isfinite(space.nominal)
        scale = (lambda v: 1.0 / v) if inverse else (lambda v: v)
        target = scale(p)
        if kb == 0:
            value = float(np.median(p[after]))
            if space.log and not value > 0:   # a profile gone through zero has no abrupt value coded by its log
                continue
            out[n_real * j] = np.log10(value) if space.log else value
            lo, hi = bounds[n_real * j]
            out[n_real * j] = float(np.clip(out[n_real * j], lo, hi))
        elif kb == 2:
            model = int(b.model[0])
            cols = [n_real * j + slot for slot in encoding.COEFF_SLOTS[model]]
            box = bounds[cols].astype(float).copy()
            width = np.abs(target[after] - scale(space.nominal) if np.isfinite(scale(space.nominal))
                           else target[after]).max() + 1e-300
            linear = [slot != encoding.RATE_SLOT for slot in encoding.COEFF_SLOTS[model]]

            def cost(x: np.ndarray) -> np.ndarray:
                rows = np.tile(real[n_real * j: n_real * (j + 1)], (len(x), 1))
                rows[:, [c - n_real * j for c in cols]] = x
                bits_j = np.tile(np.asarray(bits_to)[encoding.N_BITS * j: encoding.N_BITS * (j + 1)], (len(x), 1))
                (q,) = encoding.profiles([space], encoding.decode([space], rows, bits_j), t, onset)
                with np.errstate(all="ignore"):
                    e = _distance(q, target, first, inverse) / width
                return np.where(np.isfinite(e), e, np.inf)
            best_x = (_line_search if len(cols) == 1 else _box_search)(rng, box, linear, cost)
            if best_x is not None:
                out[cols] = best_x
    return out
