"""The C versions of the objective's generic heavy parts (``fdi/kernels.c``, built by
:mod:`optim.native`; imported only through :mod:`fdi.kernels`): :mod:`fdi._jit`'s functions with
their signatures and numbers, for processes that should not pay numba's start (0.65 s).

Each wrapper hands C-contiguous arrays of the C function's types and allocates the results. The
fused objective's seventy arguments travel as one descriptor (five int64 words per argument: an
array's address and dimensions, or an integer) and one double per argument; the words of the
arrays an objective's calls share are described once (found by identity, behind weak
references), so a call describes only its own population's arrays (20 us a call, not 130)."""
from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np

from optim import native
from optim.native import address as _at
from optim.native import floats as _f
from optim.native import ints as _i

_SIGNATURES = {
    "rk4_19": ("r", "piidpppdp"),
    "weighted_median": ("r", "ppiip"),
    "intermittent": ("r", "pipidppp"),
    "incipient17": ("r", "pipidpp"),
    "incipient_exp": ("r", "pipdipiip"),
    "fir": ("r", "piipiiiiip"),
    "edges_seen0": ("r", "pipiipipiip"),
    "square_seen": ("r", "pidppipiiiddp"),
    "decode_rows": ("r", "piipipppipp" + "di" + "p" * 9),
    "fused_cost": ("r", "ppppp"),
    "fused_arity": ("r", ""),
    "distance_rows": ("r", "piipiip"),
    "incipient19": ("r", "pipidpppdp"),
    "trig": ("r", "piip"),
}
_lib = native.require("bgfdi_kernels", __file__, "kernels.c", _SIGNATURES)

# fused_cost's arguments, in order: f float64 array, i int64 array, b bool array, n integer, x float
FUSED_TYPES = "ffiiffffi" "ffbifffx" "ibbf" "iinff" "fbiiiif" "fiiinnnn" "ififbiffnbxn" "niiiiinffiniiifif"
assert len(FUSED_TYPES) == _lib.fused_arity() == 70
_DTYPES = {"f": np.float64, "i": np.int64, "b": np.bool_}
FRESH = (1, 2, 3, 4, 5, 6, 7, 8, 15)      # the population's arrays (onsets, decoded structure, eq. 16/18, span)
SHARED = [k for k, c in enumerate(FUSED_TYPES) if c in "fib" and k not in FRESH]
NUMBERS = [k for k, c in enumerate(FUSED_TYPES) if c in "nx"]
_templates: dict[tuple, "_Template"] = {}
TEMPLATES = 256


def _check(code: int) -> None:
    if code != 0:
        raise MemoryError("the C kernels could not allocate their scratch arrays")


def rk4_19(tau, p0, b5, b6, b7, step):
    """:func:`fdi._jit.rk4_19`."""
    tau = _f(tau)
    pop, n = tau.shape
    out = np.empty((pop, n))
    b5, b6, b7 = _f(b5), _f(b6), _f(b7)
    _check(_lib.rk4_19(_at(tau), pop, n, float(p0), _at(b5), _at(b6), _at(b7),
                       float(step), _at(out)))
    return out


def distance_rows(q, target, first, inverse):
    """:func:`fdi.hints._distance` (the same numbers): each row's sum over the samples ``first:`` of
    |scale(q) - target|, one pass in C."""
    q, target = _f(q), _f(target)
    if q.ndim != 2 or target.shape != (q.shape[1],):
        raise ValueError("distance_rows: q must be (rows, samples) and target one value per sample")
    out = np.empty(q.shape[0])
    _check(_lib.distance_rows(_at(q), q.shape[0], q.shape[1], _at(target), int(first), int(bool(inverse)), _at(out)))
    return out


def incipient19(t, t0, p0, b5, b6, b7, step):
    """Eq. (19)'s profiles (rows of ``t0`` and the coefficients) on the samples ``t``, the nominal
    ``p0`` before each onset: :func:`rk4_19` on max(t - t0, 0) then numpy's select, in one call."""
    t, t0, b5, b6, b7 = _f(t), _f(t0), _f(b5), _f(b6), _f(b7)
    if not (t.ndim == 1 and t0.ndim == 1 and b5.shape == b6.shape == b7.shape == t0.shape):
        raise ValueError("incipient19: t one row of samples, t0 and b5, b6, b7 one value per row")
    out = np.empty((t0.shape[0], t.shape[0]))
    _check(_lib.incipient19(_at(t), t.shape[0], _at(t0), t0.shape[0], float(p0), _at(b5), _at(b6), _at(b7),
                            float(step), _at(out)))
    return out


def weighted_median(points, weights):
    """:func:`fdi._jit.weighted_median`."""
    points, weights = _f(points), _f(weights)
    n, m = points.shape
    out = np.zeros(n)
    _check(_lib.weighted_median(_at(points), _at(weights), n, m, _at(out)))
    return out


def intermittent(t, t0, nominal, value, period):
    """:func:`fdi._jit.intermittent`."""
    t, t0, value, period = _f(t), _f(t0), _f(value), _f(period)
    out = np.empty((t0.shape[0], t.shape[0]))
    _check(_lib.intermittent(_at(t), t.shape[0], _at(t0), t0.shape[0], float(nominal),
                             _at(value), _at(period), _at(out)))
    return out


def incipient17(t, t0, nominal, b2):
    """:func:`fdi._jit.incipient17`."""
    t, t0, b2 = _f(t), _f(t0), _f(b2)
    out = np.empty((t0.shape[0], t.shape[0]))
    _check(_lib.incipient17(_at(t), t.shape[0], _at(t0), t0.shape[0], float(nominal), _at(b2),
                            _at(out)))
    return out


def incipient_exp(t, t0, nominal, model, b):
    """:func:`fdi._jit.incipient_exp`."""
    t, t0, b = _f(t), _f(t0), _f(b)
    rows, n = b.shape[0], t.shape[0]
    out = np.empty((rows, n))
    _check(_lib.incipient_exp(_at(t), n, _at(t0), float(nominal), int(model), _at(b), rows, b.shape[1], _at(out)))
    return out


def trig(x, which):
    """:func:`fdi._jit.trig`."""
    x = _f(x)
    out = np.empty_like(x)
    _check(_lib.trig(_at(x), x.size, int(which), _at(out)))
    return out


def edges_seen0(t, edges, signs, seen, h, blends):
    """:func:`fdi._jit.edges_seen0`."""
    t, edges, signs, seen = _f(t), _f(edges), _f(signs), _f(seen)
    rows, ne = edges.shape
    out = np.empty((rows, t.shape[0]))
    _check(_lib.edges_seen0(_at(t), t.shape[0], _at(edges), rows, ne, _at(signs), signs.shape[0], _at(seen),
                            int(h), int(bool(blends)), _at(out)))
    return out


def square_seen(t, t_end, t0, period, seen, h, blends, transform, nominal, unit):
    """An intermittent linear fault's seen square waves as its values (kernels.c's square_seen:
    fdi.profiles.intermittent_edges, fdi._jit.edges_seen0 and fdi.objective.seen_profile in one
    pass); ``transform`` 0 identity, 1 reciprocal. None when the edges' table would be impossible."""
    t, t0, period, seen = _f(t), _f(t0), _f(period), _f(seen)
    rows = t0.shape[0]
    out = np.empty((rows, t.shape[0]))
    code = _lib.square_seen(_at(t), t.shape[0], float(t_end), _at(t0), _at(period), rows, _at(seen), int(h),
                            int(bool(blends)), int(transform), float(nominal), float(unit), _at(out))
    if code == -2:
        return None
    _check(code)
    return out


def fir(x, half, start, count, stride):
    """:func:`fdi._jit.fir`."""
    x, half = _f(x), _f(half)
    rows = x.shape[0]
    out = np.empty((rows, half.shape[1], count))
    _check(_lib.fir(_at(x), rows, x.shape[1], _at(half), half.shape[0], half.shape[1], int(start),
                    int(count), int(stride), _at(out)))
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
    _check(_lib.decode_rows(_at(real), pop, real.shape[1], _at(bits), bits.shape[1], _at(log),
                            _at(scale), _at(powers), powers.shape[1], _at(vpow), _at(zeta),
                            float(t_last), nf, _at(kinds), _at(models), _at(values),
                            _at(periods), _at(b), _at(pre_at), _at(counts),
                            _at(span19), _at(level)))
    return kinds, models, values, periods, b, pre_at, counts, span19, level


def _words(a, code: str, keep: list) -> list[int]:
    """An array argument's five words (address, four dimensions), converted to its C type if need be
    (the converted copy kept alive in ``keep`` until the call returns)."""
    c = np.ascontiguousarray(a, dtype=_DTYPES[code])
    if c.ndim > 4:
        raise ValueError("fused_cost: an argument of more than four dimensions")
    if c is not a:                          # a copy, or a view of a: alive until the call returns
        keep.append(c)
    return [_at(c), *c.shape, *([0] * (4 - c.ndim))]


@dataclass
class _Template:
    """The descriptor of one objective's shared arguments (:data:`SHARED`), and what checks that
    a call passes the very same arrays: weak references to them, their shapes and type codes."""
    refs: list
    shapes: list
    chars: list
    words: np.ndarray
    numbers: np.ndarray

    def matches(self, shared: list) -> bool:
        return all(r() is x and x.shape == s and x.dtype.char == c
                   for r, x, s, c in zip(self.refs, shared, self.shapes, self.chars))


def _describe(args: tuple, indices, words: np.ndarray, numbers: np.ndarray, keep: list) -> None:
    """The descriptor's entries of the arguments ``indices``: an integer's word, a float's number,
    an array's five words (:func:`_words`)."""
    for k in indices:
        a, code = args[k], FUSED_TYPES[k]
        if code == "n":
            words[5 * k] = int(a)
        elif code == "x":
            numbers[k] = float(a)
        else:
            words[5 * k:5 * k + 5] = _words(a, code, keep)


def _template(args: tuple, shared: list) -> _Template | None:
    """The descriptor of every argument but the population's (:data:`FRESH`); None when a shared
    array is not of its C type (converted on every call instead)."""
    for k in SHARED:
        c = np.ascontiguousarray(args[k], dtype=_DTYPES[FUSED_TYPES[k]])
        if c is not args[k] and c.base is not args[k]:
            return None
    words, numbers = np.zeros(5 * len(FUSED_TYPES), dtype=np.int64), np.zeros(len(FUSED_TYPES))
    _describe(args, [k for k in range(len(FUSED_TYPES)) if k not in FRESH], words, numbers, [])
    return _Template([weakref.ref(a) for a in shared], [a.shape for a in shared], [a.dtype.char for a in shared],
                     words, numbers)


def bind_fused(args: tuple, fresh: tuple):
    """:func:`fused_cost` with every argument but the population's (``fresh``, which must be
    :data:`FRESH`) described once: a callable of those nine arrays, in their order. The
    objective that binds it owns the arrays (held here too), so no call looks them up or checks
    them again (``fused_cost``'s template search and its fifty identity checks, ~60 us a call).
    None when a shared array is not of its C type (then :func:`fused_cost` converts it each call)."""
    if tuple(fresh) != FRESH or len(args) != len(FUSED_TYPES):
        return None
    held = list(args)
    shared = [held[k] for k in SHARED]
    if not all(isinstance(a, np.ndarray) for a in shared):
        return None
    t = _template(held, shared)
    if t is None:
        return None
    pop_at, nlin = FRESH.index(2), held[46].shape[0]
    wanted = [np.dtype(_DTYPES[FUSED_TYPES[k]]) for k in FRESH]
    at = np.array([5 * k + q for k in FRESH for q in range(5)])     # the fresh arrays' words in the descriptor

    def call(*values):
        # the fresh arrays' five words each (address, four dimensions), written with one index:
        # ~12 us a call where _describe's per-array conversions and slices took ~30
        words: list = []
        keep: list = []                 # converted copies, alive until the call returns
        for v, want in zip(values, wanted):
            v = np.asarray(v)
            if v.dtype != want or not v.flags.c_contiguous or v.ndim == 0:
                v = np.ascontiguousarray(v, dtype=want)          # (at least one dimension, as _words)
                keep.append(v)
            if v.ndim > 4:
                raise ValueError("fused_cost: an argument of more than four dimensions")
            words.append(_at(v))
            words += v.shape
            words += _ZEROS[v.ndim]
        d = t.words.copy()              # (a call's own descriptor: an objective may be shared between threads)
        d[at] = words
        pop = values[pop_at].shape[1]
        total, deltas, invalid = np.empty(pop), np.zeros((nlin, pop)), np.zeros(pop, dtype=np.bool_)
        _check(_lib.fused_cost(_at(d), _at(t.numbers), _at(total), _at(deltas), _at(invalid)))
        return total, deltas, invalid
    return call


_ZEROS = [(0,) * (4 - n) for n in range(5)]


def fused_cost(*args):
    """:func:`fdi._jit.fused_cost` (the same seventy arguments and three results). The arguments an
    objective's calls share are described once (:class:`_Template`, found by their identities and
    checked to be the same arrays); a call describes its population's (:data:`FRESH`)."""
    if len(args) != len(FUSED_TYPES):
        raise TypeError(f"fused_cost takes {len(FUSED_TYPES)} arguments ({len(args)} given)")
    shared = [args[k] for k in SHARED]
    key = tuple(map(id, shared)) + tuple(args[k] for k in NUMBERS)
    t = _templates.get(key)
    if t is None or not t.matches(shared):
        if not all(isinstance(a, np.ndarray) for a in shared):
            shared = [np.asarray(a) for a in shared]
        t = _template(args, shared)
        if t is not None:
            if len(_templates) >= TEMPLATES:
                _templates.clear()
            _templates[key] = t
    keep: list = []
    if t is None:                           # a shared argument of another type: every word this call
        d, X = np.zeros(5 * len(FUSED_TYPES), dtype=np.int64), np.zeros(len(FUSED_TYPES))
        _describe(args, range(len(FUSED_TYPES)), d, X, keep)
    else:
        d, X = t.words.copy(), t.numbers
        _describe(args, FRESH, d, X, keep)
    pop = args[2].shape[1]
    nlin = args[46].shape[0]
    total = np.empty(pop)
    deltas = np.zeros((nlin, pop))
    invalid = np.zeros(pop, dtype=np.bool_)
    _check(_lib.fused_cost(_at(d), _at(X), _at(total), _at(deltas), _at(invalid)))
    return total, deltas, invalid
