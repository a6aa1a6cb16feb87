"""The C versions of the objective's generic heavy parts (``fdi/kernels.c``, built by
:mod:`optim.native`; imported only through :mod:`fdi.kernels`): :mod:`fdi._jit`'s functions with
their signatures and numbers, for processes that should not pay numba's start (0.65 s).

Each wrapper hands C-contiguous arrays of the C function's types and allocates the results. The
fused objective's seventy arguments travel as one descriptor (five int64 words per argument: an
array's address and dimensions, or an integer) and one double per argument; the words of the
arrays an objective's calls share are kept by identity (behind weak references), so a call
describes only its own population's arrays."""
from __future__ import annotations

import weakref

import numpy as np

from optim import native

_SIGNATURES = {
    "rk4_19": ("r", "piidpppdp"),
    "weighted_median": ("r", "ppiip"),
    "intermittent": ("r", "pipidppp"),
    "incipient17": ("r", "pipidpp"),
    "exp_arguments": ("r", "pipipiip"),
    "incipient_exp": ("r", "pipdipiipp"),
    "fir": ("r", "piipiiiiip"),
    "decode_rows": ("r", "piipipppipp" + "di" + "p" * 9),
    "fused_cost": ("r", "ppppp"),
    "fused_arity": ("r", ""),
}
_lib = native.load("bgfdi_kernels", native.source(__file__, "kernels.c"), _SIGNATURES)
if _lib is None:
    raise ImportError("the C kernels could not be built: " + "; ".join(native.notes[-1:]))

# fused_cost's arguments, in order: f float64 array, i int64 array, b bool array, n integer, x float
FUSED_TYPES = "ffiiffffi" "ffbifffx" "ibbf" "iinff" "fbiiiif" "fiiinnnn" "ififbiffnbxn" "niiiiinffiniiifif"
assert len(FUSED_TYPES) == _lib.fused_arity() == 70
_DTYPES = {"f": np.float64, "i": np.int64, "b": np.bool_}
FRESH = {1, 2, 3, 4, 5, 6, 7, 8, 15}      # the population's arrays (onsets, decoded structure, eq. 16/18, span)
_kept: dict[int, tuple[weakref.ref, list[int], tuple]] = {}
KEPT = 4096


def _check(code: int) -> None:
    if code != 0:
        raise MemoryError("the C kernels could not allocate their scratch arrays")


def _f(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float64)


def _i(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.int64)


def rk4_19(tau, p0, b5, b6, b7, step):
    """:func:`fdi._jit.rk4_19`."""
    tau = _f(tau)
    pop, n = tau.shape
    out = np.empty((pop, n))
    b5, b6, b7 = _f(b5), _f(b6), _f(b7)
    _check(_lib.rk4_19(tau.ctypes.data, pop, n, float(p0), b5.ctypes.data, b6.ctypes.data, b7.ctypes.data,
                       float(step), out.ctypes.data))
    return out


def weighted_median(points, weights):
    """:func:`fdi._jit.weighted_median`."""
    points, weights = _f(points), _f(weights)
    n, m = points.shape
    out = np.zeros(n)
    _check(_lib.weighted_median(points.ctypes.data, weights.ctypes.data, n, m, out.ctypes.data))
    return out


def intermittent(t, t0, nominal, value, period):
    """:func:`fdi._jit.intermittent`."""
    t, t0, value, period = _f(t), _f(t0), _f(value), _f(period)
    out = np.empty((t0.shape[0], t.shape[0]))
    _check(_lib.intermittent(t.ctypes.data, t.shape[0], t0.ctypes.data, t0.shape[0], float(nominal),
                             value.ctypes.data, period.ctypes.data, out.ctypes.data))
    return out


def incipient17(t, t0, nominal, b2):
    """:func:`fdi._jit.incipient17`."""
    t, t0, b2 = _f(t), _f(t0), _f(b2)
    out = np.empty((t0.shape[0], t.shape[0]))
    _check(_lib.incipient17(t.ctypes.data, t.shape[0], t0.ctypes.data, t0.shape[0], float(nominal), b2.ctypes.data,
                            out.ctypes.data))
    return out


def exp_arguments(t, t0, model, b):
    """:func:`fdi._jit.exp_arguments`."""
    t, t0, b = _f(t), _f(t0), _f(b)
    rows, n = b.shape[0], t.shape[0]
    out = np.empty((1 if model == 1 else 2, rows, n))
    _check(_lib.exp_arguments(t.ctypes.data, n, t0.ctypes.data, int(model), b.ctypes.data, rows, b.shape[1],
                              out.ctypes.data))
    return out


def incipient_exp(t, t0, nominal, model, b, e):
    """:func:`fdi._jit.incipient_exp`."""
    t, t0, b, e = _f(t), _f(t0), _f(b), _f(e)
    rows, n = b.shape[0], t.shape[0]
    out = np.empty((rows, n))
    _check(_lib.incipient_exp(t.ctypes.data, n, t0.ctypes.data, float(nominal), int(model), b.ctypes.data, rows,
                              b.shape[1], e.ctypes.data, out.ctypes.data))
    return out


def fir(x, half, start, count, stride):
    """:func:`fdi._jit.fir`."""
    x, half = _f(x), _f(half)
    rows = x.shape[0]
    out = np.empty((rows, half.shape[1], count))
    _check(_lib.fir(x.ctypes.data, rows, x.shape[1], half.ctypes.data, half.shape[0], half.shape[1], int(start),
                    int(count), int(stride), out.ctypes.data))
    return out


def decode_rows(real, bits, log, scale, powers, vpow, zeta, t_last):
    """:func:`fdi._jit.decode_rows`."""
    real = _f(real)
    bits = np.ascontiguousarray(bits, dtype=np.bool_)
    log = np.ascontiguousarray(log, dtype=np.bool_)
    scale, powers, vpow, zeta = _f(scale), _f(powers), _i(vpow), _i(zeta)
    pop, nf = real.shape[0], log.shape[0]
    kinds = np.empty((nf, pop), dtype=np.int64)
    models = np.empty((nf, pop), dtype=np.int64)
    values = np.empty((nf, pop))
    periods = np.empty((nf, pop))
    b = np.empty((nf, pop, 7))
    pre_at = np.empty((nf, pop), dtype=np.int64)
    counts = np.zeros((nf, 2), dtype=np.int64)
    span19 = np.zeros(nf)
    level = np.zeros(nf, dtype=np.bool_)
    _check(_lib.decode_rows(real.ctypes.data, pop, real.shape[1], bits.ctypes.data, bits.shape[1], log.ctypes.data,
                            scale.ctypes.data, powers.ctypes.data, powers.shape[1], vpow.ctypes.data, zeta.ctypes.data,
                            float(t_last), nf, kinds.ctypes.data, models.ctypes.data, values.ctypes.data,
                            periods.ctypes.data, b.ctypes.data, pre_at.ctypes.data, counts.ctypes.data,
                            span19.ctypes.data, level.ctypes.data))
    return kinds, models, values, periods, b, pre_at, counts, span19, level


def _words(a: np.ndarray, code: str, keep: list, shared: bool) -> list[int]:
    """An array argument's five words (address, four dimensions). A ``shared`` argument's (one the
    calls of an objective share) are kept by identity, behind a weak reference: an array's address
    never changes, and its shape and type are checked again."""
    if shared:
        got = _kept.get(id(a))
        if got is not None and got[0]() is a and a.shape == got[2] and a.dtype == _DTYPES[code] \
                and a.flags.c_contiguous:
            return got[1]
    c = np.ascontiguousarray(a, dtype=_DTYPES[code])
    if c.ndim > 4:
        raise ValueError("fused_cost: an argument of more than four dimensions")
    words = [c.ctypes.data, *c.shape, *([0] * (4 - c.ndim))]
    if shared and c is a:
        if len(_kept) >= KEPT:          # the dead first, else all (threads may prune at once)
            for k in [k for k, v in list(_kept.items()) if v[0]() is None] or list(_kept):
                _kept.pop(k, None)
        _kept[id(a)] = (weakref.ref(a), words, a.shape)
    else:
        keep.append(c)                  # alive until the call returns
    return words


def fused_cost(*args):
    """:func:`fdi._jit.fused_cost` (the same seventy arguments and three results)."""
    if len(args) != len(FUSED_TYPES):
        raise TypeError(f"fused_cost takes {len(FUSED_TYPES)} arguments ({len(args)} given)")
    D: list[int] = []
    X = np.zeros(len(args))
    keep: list = []
    for k, (a, code) in enumerate(zip(args, FUSED_TYPES)):
        if code == "n":
            D += [int(a), 0, 0, 0, 0]
        elif code == "x":
            X[k] = float(a)
            D += [0, 0, 0, 0, 0]
        else:
            D += _words(a, code, keep, k not in FRESH)
    d = np.array(D, dtype=np.int64)
    nf, pop = args[2].shape
    nlin = args[46].shape[0]
    total = np.empty(pop)
    deltas = np.zeros((nlin, pop))
    invalid = np.zeros(pop, dtype=np.bool_)
    _check(_lib.fused_cost(d.ctypes.data, X.ctypes.data, total.ctypes.data, deltas.ctypes.data, invalid.ctypes.data))
    return total, deltas, invalid
