"""Fault profiles P(t) of Yu & Wang (2014), eqs. (14)-(19), vectorised over a population.

Every function takes the sample times ``t`` (N,) and per-individual parameters of shape (pop,)
(or scalars), the onset ``t0`` included, and returns (pop, N). ``nominal`` is P, the healthy value, which may be infinite (a
leakage resistance): the formulas are written so that infinity is handled exactly.

- abrupt (14): P before t0, P_ab from t0 on;
- intermittent (15): P_int during the first half of each period T from t0, P during the second
  (at the exact switching instants sign(sin) = 0 and eq. (15) gives the mean, as written);
- incipient, with P(t0) = P (and dP/dt(t0) = 0 for the second-order models), tau = t - t0:
  (16) dP/dt = b1 P               -> P = P0 exp(b1 tau)
  (17) dP/dt = b2 P^2             -> 1/P = 1/P0 - b2 tau  (infinite P0 allowed; past the pole: inf)
  (18) d2P/dt2 = b3 dP/dt + P + b4 -> closed form, roots (b3 +- sqrt(b3^2 + 4))/2
  (19) d2P/dt2 = b5 (dP/dt)^2 + b6 P + b7 -> classical RK4 on a 0.1 s grid (at least
       MIN_STEPS19 and at most STEPS19 steps over the window), Hermite-interpolated

From t0 = 1 s: an abrupt fault to 4 (nominal 10); an efficiency factor decaying as (17) with
b2 = -0.5, 1/P = 1 + 0.5 (t - t0), so 2/3 at t = 2 s and 1/2 at t = 3 s; an intermittent fault
of period 1 s, faulty during the first half of each period (the mean at the switching instants):

>>> t = np.array([0.0, 1.0, 2.0, 3.0])
>>> abrupt(t, 1.0, 10.0, 4.0).tolist()
[[10.0, 4.0, 4.0, 4.0]]
>>> incipient(t, 1.0, 1.0, 2, [[-0.5]]).round(4).tolist()
[[1.0, 1.0, 0.6667, 0.5]]
>>> intermittent(np.array([0.5, 1.0, 1.25, 1.75]), 1.0, 1.0, 3.0, 1.0).tolist()
[[1.0, 2.0, 3.0, 1.0]]
"""
from __future__ import annotations

import functools
import math

import numpy as np

from . import kernels

TYPES = ("abrupt", "intermittent", "incipient")
MODELS = (1, 2, 3, 4)                       # eqs. (16), (17), (18), (19)
N_COEFFICIENTS = {1: 1, 2: 1, 3: 2, 4: 3}  # b1 | b2 | b3, b4 | b5, b6, b7
# Eq. (19)'s RK4 grid (steps19, the same rule in fdi._jit and fdi/kernels.c): 0.1 s steps, at
# least MIN_STEPS19 and at most STEPS19 of them over a span. Why a cap: a grid in seconds cost the
# water heater (1 s samples, windows of hours) 10^5 steps per individual, most of its diagnosis;
# over 1000 steps RK4's error on a drift that evolves over the window is ~1e-12 of it, and an
# individual whose own time scale is a few steps (|b6| h^2 ~ 1) is as far from such a drift as the
# bounds allow. Why a floor: a grid in seconds gave a millisecond window one RK4 step, read by
# Hermite interpolation, where the coefficients' bounds (fdi.encoding.coefficient_bounds, in units
# of the identification window W) reach |b6| W^2 = 100. Spans from 10 s to 100 s keep the 0.1 s
# grid (the CyCab's identification windows: its numbers unchanged).
STEPS19 = 1000
MIN_STEPS19 = 100
STEP19 = 0.1        # s: eq. (19)'s RK4 step on windows up to STEPS19 steps


def _col(x) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    return a.reshape(-1, 1) if a.ndim else a.reshape(1, 1)


def abrupt(t: np.ndarray, t0, nominal: float, value) -> np.ndarray:
    t = np.asarray(t, dtype=float)[None, :]
    return np.where(t >= _col(t0), _col(value), nominal) + 0.0 * _col(value)


def intermittent(t: np.ndarray, t0, nominal: float, value, period) -> np.ndarray:
    t = np.asarray(t, dtype=float)[None, :]
    value, period, t0 = _col(value), _col(period), _col(t0)
    fast = kernels.jit()
    if fast is not None and t.size:        # the same numbers without a sine per sample (fdi.kernels)
        rows = max(value.shape[0], period.shape[0], t0.shape[0])

        def per_row(x: np.ndarray) -> np.ndarray:
            return np.ascontiguousarray(np.broadcast_to(x[:, 0], (rows,)))
        return fast.intermittent(np.ascontiguousarray(t[0]), per_row(t0), float(nominal), per_row(value), per_row(period))
    s = np.sign(np.sin(2 * np.pi * (t - t0) / period))
    with np.errstate(invalid="ignore"):
        mean = (nominal + value) / 2
    out = np.where(s > 0, value, np.where(s < 0, nominal, mean))
    return np.where(t >= t0, out, nominal)


def intermittent_edges(t_end: float, t0: np.ndarray, period: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eq. (15)'s square waves as edges up to ``t_end``: per row (one per onset and period), the
    rises at t0 + m T and the falls half a period later, NaN where none (after ``t_end``, or an
    onset or period that is not a finite positive number), and their signs, +1 and -1 (for
    :func:`fdi.derivatives.edges_seen`).

    On from 0.5 s with a 1 s period, up to 2 s: on over [0.5, 1) and [1.5, 2):

    >>> edges, signs = intermittent_edges(2.0, np.array([0.5]), np.array([1.0]))
    >>> edges.tolist(), signs.tolist()
    ([[0.5, 1.5, nan, 1.0, 2.0, nan]], [[1.0, 1.0, 1.0, -1.0, -1.0, -1.0]])
    """
    t0, period = np.asarray(t0, dtype=float), np.asarray(period, dtype=float)
    ok = np.isfinite(t0) & np.isfinite(period) & (period > 0)
    span = float(t_end - np.min(np.where(ok, t0, np.inf))) if ok.any() else 0.0
    shortest = float(np.min(period[ok])) if ok.any() else 1.0
    m = np.arange(max(1, int(np.ceil(span / shortest)) + 1))[None, :]
    rises = np.where(ok[:, None], t0[:, None] + m * period[:, None], np.nan)
    edges = np.hstack([rises, rises + period[:, None] / 2])
    edges[edges > t_end] = np.nan
    return edges, np.hstack([np.ones(m.size), -np.ones(m.size)])[None, :]


def incipient(t: np.ndarray, t0, nominal: float, model: int, b) -> np.ndarray:
    """One degradation model for the whole population; ``b`` of shape (pop, n_coefficients)."""
    t = np.asarray(t, dtype=float)
    b = np.atleast_2d(np.asarray(b, dtype=float))
    t0 = _col(t0)
    fast = kernels.jit()
    if model == 2 and nominal != 0 and fast is not None and t.size:    # the same numbers in one pass (fdi.kernels)
        rows = max(b.shape[0], t0.shape[0])
        return fast.incipient17(t, np.ascontiguousarray(np.broadcast_to(t0[:, 0], (rows,))), float(nominal),
                                np.ascontiguousarray(np.broadcast_to(b[:, 0], (rows,))))
    if model in (1, 3) and fast is not None and t.size and not (model == 3 and np.isinf(nominal)):
        return _exponential(fast, t, t0[:, 0], nominal, model, b)
    if model == 4 and hasattr(fast, "incipient19") and t.size and np.isfinite(nominal):
        rows = max(b.shape[0], t0.shape[0])       # C: _model19's numbers and the select below, in one call
        return fast.incipient19(t, np.ascontiguousarray(np.broadcast_to(t0[:, 0], (rows,))), float(nominal),
                                *(np.ascontiguousarray(np.broadcast_to(b[:, k], (rows,))) for k in range(3)), STEP19)
    tau = np.maximum(t[None, :] - t0, 0.0)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        if model == 1:
            p = nominal * np.exp(b[:, :1] * tau)
        elif model == 2 and nominal == 0:          # 1/P = 1/P0 - b2 tau never leaves P0 = 0 (an offset)
            p = np.zeros(np.broadcast(tau, b[:, :1]).shape)
        elif model == 2:
            den = (0.0 if np.isinf(nominal) else 1.0 / nominal) - b[:, :1] * tau
            p = np.where(den > 0, 1.0 / np.where(den > 0, den, 1.0), np.inf)
            p = np.where(tau > 0, p, nominal)
        elif model == 3:
            p = _model18(tau, nominal, b[:, 0:1], b[:, 1:2])
        elif model == 4:
            p = _model19(tau, nominal, b[:, 0], b[:, 1], b[:, 2])
        else:
            raise ValueError(f"degradation model must be 1..4 (eqs. 16-19), got {model}")
    return np.where(t[None, :] >= t0, p, nominal)


def _exponential(fast, t: np.ndarray, t0: np.ndarray, nominal: float, model: int, b: np.ndarray) -> np.ndarray:
    """Eq. (16) or (18) (finite P0) by the compiled kernels (fdi.kernels): the numpy path's
    operations in one pass with the kernels' exponential (:func:`_exp`'s numbers, within 1 ulp of
    numpy's; a loop that vectorises, where libm's is a call per sample), and no temporary. It was three passes around
    numpy's exponential (22 ns a sample where this takes 9): a translation's search
    (fdi.hints.translate) forms 860 000 samples of profiles."""
    rows = max(b.shape[0], t0.shape[0])
    t = np.ascontiguousarray(t)
    t0 = np.ascontiguousarray(t0 if t0.shape[0] == rows else np.broadcast_to(t0, (rows,)))
    b = b[:, :1] if model == 1 else b[:, :2]
    b = np.ascontiguousarray(b if b.shape[0] == rows else np.broadcast_to(b, (rows, b.shape[1])))
    return fast.incipient_exp(t, t0, float(nominal), model, b)


def _model18(tau: np.ndarray, p0: float, b3: np.ndarray, b4: np.ndarray) -> np.ndarray:
    if np.isinf(p0):
        return np.full(np.broadcast(tau, b3).shape, np.inf)
    root = np.sqrt(b3 ** 2 + 4.0)
    r1, r2 = (b3 + root) / 2, (b3 - root) / 2
    a = -r2 * (p0 + b4) / (r1 - r2)
    c = r1 * (p0 + b4) / (r1 - r2)
    return -b4 + a * np.exp(r1 * tau) + c * np.exp(r2 * tau)


def _model19(tau: np.ndarray, p0: float, b5, b6, b7, step: float = STEP19) -> np.ndarray:
    """RK4 in tau = t - t0 on a uniform grid of ``step`` seconds, all rows at once, read between grid
    points by cubic Hermite interpolation on P and dP/dt (error O(step^4): 1e-5 of P against cos(tau)
    at a rate of 1/s, where linear interpolation on a 0.05 s grid leaves h^2/8 P'' = 3e-4)."""
    b5, b6, b7 = (np.atleast_1d(np.asarray(x, dtype=float)) for x in (b5, b6, b7))
    pop = max(np.broadcast(b5, b6, b7).shape[0], tau.shape[0])
    tau = np.broadcast_to(tau, (pop, tau.shape[-1]))
    if np.isinf(p0):
        return np.full(tau.shape, np.inf)
    fast = kernels.jit()
    if fast is not None and tau.size:     # the same operations compiled (fdi.kernels): ~4 ms -> ~0.1 ms a call
        return fast.rk4_19(np.ascontiguousarray(tau), float(p0), *(np.ascontiguousarray(np.broadcast_to(x, (pop,)))
                                                                    for x in (b5, b6, b7)), float(step))
    span = float(tau.max()) if tau.size else 0.0
    grid, slope, h = _rk4_grid(p0, b5, b6, b7, pop, span, step)
    k = grid.shape[1] - 1
    x = np.clip(tau / h, 0, k)
    i0 = np.minimum(np.floor(x).astype(int), k - 1)
    s = x - i0
    rows = np.arange(pop)[:, None]
    pa, pb, va, vb = grid[rows, i0], grid[rows, i0 + 1], slope[rows, i0] * h, slope[rows, i0 + 1] * h
    with np.errstate(invalid="ignore"):
        out = hermite(s, pa, pb, va, vb)
    return np.where(np.isfinite(pa) & np.isfinite(pb), out, np.inf)


def steps19(span: float, step: float) -> int:
    """The number of RK4 steps eq. (19) takes over ``span`` seconds (the same rule in fdi._jit and
    fdi/kernels.c): ``step``-second steps, at least MIN_STEPS19, at most STEPS19.

    >>> steps19(10.0, 0.1), steps19(60.0, 0.1), steps19(0.002, 0.1), steps19(7200.0, 0.1)
    (100, 600, 100, 1000)
    """
    return STEPS19 if span / step > STEPS19 else max(MIN_STEPS19, int(math.ceil(span / step)))


def hermite(s, pa, pb, va, vb):
    """The cubic Hermite from (pa, va) at s = 0 to (pb, vb) at s = 1 (slopes per unit of s), at s:
    how eq. (19)'s grid is read between its points (fdi._jit and fdi/kernels.c in the same order).

    >>> float(hermite(0.5, 0.0, 1.0, 0.0, 0.0))
    0.5
    """
    s2, s3 = s * s, s * s * s
    return (2 * s3 - 3 * s2 + 1) * pa + (s3 - 2 * s2 + s) * va + (-2 * s3 + 3 * s2) * pb + (s3 - s2) * vb


def rk4_step19(p, v, h, b5, b6, b7):
    """One classical RK4 step of eq. (19), P'' = b5 P'^2 + b6 P + b7, from (P, P') = (p, v): the
    operations of fdi._jit and fdi/kernels.c in their order (the same bits).

    >>> [round(float(x), 6) for x in rk4_step19(1.0, 0.0, 0.1, 0.0, 0.0, 2.0)]      # P = 1 + t^2
    [1.01, 0.2]
    """
    def acc(p, v):
        return b5 * v * v + b6 * p + b7
    k1p, k1v = v, acc(p, v)
    k2p, k2v = v + h / 2 * k1v, acc(p + h / 2 * k1p, v + h / 2 * k1v)
    k3p, k3v = v + h / 2 * k2v, acc(p + h / 2 * k2p, v + h / 2 * k2v)
    k4p, k4v = v + h * k3v, acc(p + h * k3p, v + h * k3v)
    return p + h / 6 * (k1p + 2 * k2p + 2 * k3p + k4p), v + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)


def _rk4_grid(p0: float, b5, b6, b7, pop: int, span: float, step: float) -> tuple[np.ndarray, np.ndarray, float]:
    """Eq. (19) by classical RK4 from tau = 0 to ``span`` on :func:`steps19` equal steps: P and
    dP/dt at the grid points, (pop, k + 1) each (P infinite and its slope 0 once P overflows), and
    the step h."""
    k = steps19(span, step)
    h = span / k if span > 0 else step
    grid, slope = np.empty((pop, k + 1)), np.empty((pop, k + 1))
    p, v = np.full(pop, float(p0)), np.zeros(pop)
    grid[:, 0], slope[:, 0] = p, v
    with np.errstate(over="ignore", invalid="ignore"):
        for i in range(1, k + 1):
            p, v = rk4_step19(p, v, h, b5, b6, b7)
            grid[:, i] = np.where(np.isfinite(p), p, np.inf)
            slope[:, i] = np.where(np.isfinite(p), v, 0.0)
    return grid, slope, h


@functools.lru_cache(maxsize=16)
def _table19(p0: float, b: tuple[float, float, float], span: float) -> tuple[list[float], list[float], float]:
    """Eq. (19)'s RK4 grid for one fault over tau in [0, span], as Python floats (kept: a
    simulation reads it at every step)."""
    grid, slope, h = _rk4_grid(p0, *(np.array([x]) for x in b), 1, span, STEP19)
    return grid[0].tolist(), slope[0].tolist(), h


def _at19(tau: float, p0: float, b: tuple[float, float, float], span: float) -> float:
    """Eq. (19) at one tau in [0, span]: the array function's reading (grid and Hermite
    interpolation) of a window whose last sample is tau = span, on Python floats."""
    if math.isinf(p0):
        return math.inf
    grid, slope, h = _table19(p0, b, span)
    k = len(grid) - 1
    x = min(max(tau / h, 0.0), float(k))
    i0 = min(int(math.floor(x)), k - 1)
    s = x - i0
    pa, pb, va, vb = grid[i0], grid[i0 + 1], slope[i0] * h, slope[i0 + 1] * h
    if not (math.isfinite(pa) and math.isfinite(pb)):
        return math.inf
    return hermite(s, pa, pb, va, vb)


def at(kind: str, t: float, t0: float, nominal: float, *, value=None, model: int | None = None,
       b=None, span: float | None = None) -> float | None:
    """One profile's value at one instant, by the array functions' operations on Python floats
    (their bits: IEEE sums, products and quotients; the compiled kernels' exponential (:func:`_exp`),
    libm's square root; on the numpy path, numpy's exponential differs from it in the last bit), or None where only the array functions compute it (eq. 15; eq. 19 past
    ``span`` or without one). Why: a simulation's right-hand side asks for the parameters one
    instant at a time (twice a step of LSODA), and the array functions cost ~25 us a call on one
    sample where this takes ~2 (the tutorial's 30 s drift: 60 000 calls).

    Eq. (19) has no closed form: its array function integrates RK4 from the onset to the window's
    last instant at every call, which one instant at a time is quadratic in the run's length (the
    tutorial's RC filter with an eq. (19) drift, 8 s at 1 kHz under LSODA: 9.1 s; 30 s: 10.3 s).
    With ``span`` (the run's end minus t0) its grid is integrated once per fault to the run's end
    and read at each instant (3.0 s and 5.8 s): the array function's numbers on the whole run's
    window.

    >>> at("incipient", 3.0, 1.0, 1.0, model=2, b=[-0.5]), at("abrupt", 0.5, 1.0, 10.0, value=4.0)
    (0.5, 10.0)
    """
    if kind == "abrupt":
        return (value if t >= t0 else nominal) + 0.0 * value
    if kind != "incipient" or model not in (1, 2, 3, 4):
        return None
    x = t - t0
    if model == 4:
        if span is None or not (x <= span) or not math.isfinite(span):
            return None
        if not t >= t0:
            return nominal
        return _at19(x, float(nominal), (float(b[0]), float(b[1]), float(b[2])), float(span))
    tau = 0.0 if x < 0 else x                      # NaN stays NaN, as np.maximum keeps it
    if not t >= t0:
        return nominal
    if model == 1:
        return nominal * _exp(b[0] * tau)
    if model == 2:
        if nominal == 0:
            return 0.0
        if not tau > 0:
            return nominal
        den = (0.0 if math.isinf(nominal) else 1.0 / nominal) - b[0] * tau
        return 1.0 / den if den > 0 else math.inf
    if math.isinf(nominal):
        return math.inf
    b3, b4 = b[0], b[1]
    root = math.sqrt(b3 * b3 + 4.0)
    r1, r2 = (b3 + root) / 2, (b3 - root) / 2
    a = -r2 * (nominal + b4) / (r1 - r2)
    c = r1 * (nominal + b4) / (r1 - r2)
    return (-b4 + a * _exp(r1 * tau)) + c * _exp(r2 * tau)


_SHIFT, _LOG2E = float.fromhex("0x1.8p52"), float.fromhex("0x1.71547652b82fep+0")
_LN2HI, _LN2LO = float.fromhex("0x1.62e42fee00000p-1"), float.fromhex("0x1.a39ef35793c76p-33")
_TAYLOR = tuple(float.fromhex(h) for h in (       # 1/13!, 1/12!, ..., 1/2!: Horner's order, innermost first
    "0x1.6124613a86d09p-33", "0x1.1eed8eff8d898p-29", "0x1.ae64567f544e4p-26", "0x1.27e4fb7789f5cp-22",
    "0x1.71de3a556c734p-19", "0x1.a01a01a01a01ap-16", "0x1.a01a01a01a01ap-13", "0x1.6c16c16c16c17p-10",
    "0x1.1111111111111p-7", "0x1.5555555555555p-5", "0x1.5555555555555p-3", "0x1p-1"))
_HI, _LO = 2.0 ** 600, 2.0 ** -600


def _exp(x: float) -> float:
    """The compiled kernels' exponential on a Python float (fdi/kernels.c vexp; numba compiles this
    very function as fdi._jit._vexp): their operations in their order, so a simulation's profile at
    one instant is theirs to the bit:
    x = k ln2 + r (k by the 1.5 * 2^52 shift, ln2 in two parts), exp(r) by Taylor to degree 13, times
    2^k (in two steps near the range's ends); within 1 ulp of the correctly rounded value (1.16 ulp
    of the exact one at most), inf past 709.78, 0 below -745.13, NaN kept. 0.7 us a call where
    math.exp takes 0.1: a simulation's instant (:func:`at`) costs ~1 us more.

    >>> _exp(0.0), abs(_exp(1.0) - math.e) <= math.ulp(math.e), _exp(710.0), _exp(-746.0)
    (1.0, True, inf, 0.0)
    """
    if x != x:
        return x
    if x > 709.782712893384:
        return math.inf
    if x < -745.1332191019412:
        return 0.0
    kd = (x * _LOG2E + _SHIFT) - _SHIFT
    r = (x - kd * _LN2HI) - kd * _LN2LO
    c13, c12, c11, c10, c9, c8, c7, c6, c5, c4, c3, c2 = _TAYLOR
    p = 1.0 + r * (1.0 + r * (c2 + r * (c3 + r * (c4 + r * (c5 + r * (c6 + r * (c7 + r * (c8 + r * (
        c9 + r * (c10 + r * (c11 + r * (c12 + r * c13))))))))))))
    k = int(kd)
    if kd > 1000.0:
        return (p * math.ldexp(1.0, k - 600)) * _HI
    if kd < -1000.0:
        return (p * math.ldexp(1.0, k + 600)) * _LO
    return p * math.ldexp(1.0, k)


def profile(kind: str, t: np.ndarray, t0: float, nominal: float, *, value=None, period=None, model: int | None = None,
            b=None) -> np.ndarray:
    """One fault profile by name (abrupt, intermittent, incipient)."""
    if kind == "abrupt":
        return abrupt(t, t0, nominal, value)
    if kind == "intermittent":
        return intermittent(t, t0, nominal, value, period)
    if kind == "incipient":
        return incipient(t, t0, nominal, int(model), b)
    raise ValueError(f"unknown fault type '{kind}' (abrupt, intermittent, incipient)")
