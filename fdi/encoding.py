"""A candidate set's decision vector <-> the flat real and bit arrays the optimisers see.

Per fault, 9 reals and 5 bits:

    reals  [v, T, b1, b2, b3, b4, b5, b6, b7]     bits [zeta_ab, zeta_int, zeta_inc, eta1, eta2]

``v`` is the faulty value, of an abrupt fault or of an intermittent one (searched as log10 when the
fault's bounds span more than two decades or its nominal value is infinite). The paper's GA keeps
two values, one per type; one shared slot is the same physical quantity and lets a search change
a fault's type without losing its magnitude (measured: with two slots, the improved AHDE could not
move "R4 intermittent" to "R4 abrupt" on a simulated scenario 1). ``T`` is the intermittent period, ``b1..b7`` the degradation coefficients of eqs. (16)-(19), searched
*normalised* by a reference value P_ref of the fault (its nominal value, or for an infinite
nominal the geometric mean of its bounds) so that one set of bounds serves every fault:
b1, b6 are rates (1/s) as they are; b2 = b2n / P_ref, b4 = b4n * P_ref, b5 = b5n / P_ref,
b7 = b7n * P_ref. eta = [0 0], [0 1], [1 0], [1 1] selects model (16), (17), (18), (19).

Eq. (18)'s b3 is searched through the rate of the mode that grows, r1 = (b3 + sqrt(b3^2 + 4))/2 > 0
(the other root is -1/r1: every eq. (18) drift grows as exp(r1 tau)), as log10(r1), with r1 W in
[0.1, 100] for an identification window of W seconds (the CyCab's W = 10 s: log10 r1 in [-2, 1],
time constants from 0.1 s to 100 s); b3 = r1 - 1/r1. Every coefficient's bounds are in units of W
(:func:`coefficient_bounds`). Searched as b3 in [-3, 3], eq. (18) could
not be slower than exp(0.30 tau): a slow drift of this model (the CyCab suite's beta_theta2,
b3 = -3) sat on the bound, and its fit seen from t_D needs b3 = -3.7 (measured: cost 551 against
2036 for the best fit inside the old bounds).

Repair of a zeta that is not one-hot (engines that evolve plain bits can produce 000, 110, ...):
the nearest one-hot code in Hamming distance, ties going to the type with fewer parameters
(abrupt, then intermittent, then incipient): 000, 110, 101, 111 -> abrupt; 011 -> intermittent.
Engines that know one-hot groups (``onehot_groups``) never need it.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .profiles import N_COEFFICIENTS, TYPES, incipient, intermittent, abrupt

N_REAL = 9
N_BITS = 5
COEFF_SLOTS = {1: [2], 2: [3], 3: [4, 5], 4: [6, 7, 8]}           # real indices of each model's b's
# The degradation coefficients' bounds in units of the identification window W = N ts (s): over one
# window an eq. (16)/(17) drift changes its exponent or reciprocal by at most 3 (b1 W, b2n W), eq.
# (18)'s growing mode has r1 W in [0.1, 100], eq. (19)'s b6 W^2 and b7n W^2 are within 100; b4
# and b5n are dimensionless. Why: bounds in seconds (the CyCab's, W = 10 s) left a microsecond
# converter no drift it could express over its 2 ms window (b1 W <= 6e-4) and eq. (18) no drift
# slower than 100 s; in window units every time scale gets the CyCab's search space.
WINDOW_COEFF_BOUNDS = ((-3.0, 3.0), (-3.0, 3.0), (-1.0, 2.0), (-2.0, 0.0), (-20.0, 20.0), (-100.0, 100.0),
                       (-100.0, 100.0))
REFERENCE_WINDOW = 10.0       # s: the CyCab's identification window (1000 samples at 100 Hz)


def coefficient_bounds(window: float) -> tuple[tuple[float, float], ...]:
    """The bounds of [b1, b2n, log10 r1, b4n, b5n, b6, b7n] for an identification window of
    ``window`` seconds (:data:`WINDOW_COEFF_BOUNDS` in units of it). ``window`` is read to six
    significant digits (a window from a sampling period measured in the data, 1000 x 0.01000000001 s,
    is the 10 s one).

    >>> coefficient_bounds(10.0)[:3]
    ((-0.3, 0.3), (-0.3, 0.3), (-2.0, 1.0))
    >>> coefficient_bounds(0.002)[0], coefficient_bounds(0.002)[5]
    ((-1500.0, 1500.0), (-25000000.0, 25000000.0))
    """
    w = float(f"{float(window):.6g}")
    if not (np.isfinite(w) and w > 0):
        raise ValueError(f"the identification window must be a positive number of seconds, got {window!r}")
    lw = float(np.log10(w))
    per = (w, w, None, 1.0, 1.0, w * w, w * w)                # each bound's divisor (s, s^2)
    return tuple((lo - lw, hi - lw) if k is None else (lo / k, hi / k)
                 for (lo, hi), k in zip(WINDOW_COEFF_BOUNDS, per))


DEFAULT_COEFF_BOUNDS = list(coefficient_bounds(REFERENCE_WINDOW))      # a FaultSpace made without a window
RATE_SLOT = 4                 # real index of eq. (18)'s log10(r1) (b3 = r1 - 1/r1)
# The intermittent period's search interval (s) of a FaultSpace made without data: the optimiser
# benchmarks' synthetic problems, on the CyCab's time axis. A diagnosis always gives its own, from
# two derivative windows (fdi.scales.min_period) to the identification window's span.
DEFAULT_PERIOD = (0.5, 20.0)


@dataclass(frozen=True)
class FaultSpace:
    """The search space of one fault."""
    name: str
    nominal: float
    bounds: tuple[float, float]
    period: tuple[float, float] = DEFAULT_PERIOD
    coefficients: tuple[tuple[float, float], ...] = tuple(DEFAULT_COEFF_BOUNDS)
    log: bool = field(default=False)

    @property
    def reference(self) -> float:
        if np.isfinite(self.nominal) and self.nominal != 0:
            return abs(self.nominal)
        return float(np.sqrt(abs(self.bounds[0] * self.bounds[1]))) or 1.0

    @staticmethod
    def make(name: str, nominal: float, bounds: tuple[float, float], **kw) -> "FaultSpace":
        lo, hi = bounds
        log = bool(np.isinf(nominal) or (lo > 0 and hi / lo > 100))
        return FaultSpace(name, nominal, (lo, hi), log=log, **kw)


def _value_bounds(s: FaultSpace) -> tuple[float, float]:
    return (np.log10(s.bounds[0]), np.log10(s.bounds[1])) if s.log else s.bounds


def bounds(spaces: list[FaultSpace]) -> np.ndarray:
    """Real bounds, (9 * n_faults, 2)."""
    rows = []
    for s in spaces:
        rows += [_value_bounds(s), s.period] + list(s.coefficients)
    return np.asarray(rows, dtype=float)


def onehot_groups(spaces: list[FaultSpace]) -> list[tuple[int, int, int]]:
    """The zeta bits of each fault: exactly one must be set."""
    return [(N_BITS * i, N_BITS * i + 1, N_BITS * i + 2) for i in range(len(spaces))]


def repair_zeta(zeta: np.ndarray) -> np.ndarray:
    """Type index (0 abrupt, 1 intermittent, 2 incipient) of each zeta row (pop, 3); see module doc."""
    z = np.asarray(zeta, dtype=bool)
    codes = np.eye(3, dtype=bool)
    dist = (z[:, None, :] != codes[None, :, :]).sum(axis=2)          # (pop, 3)
    return np.argmin(dist, axis=1)                                     # argmin takes the first tie


def model_index(eta: np.ndarray) -> np.ndarray:
    """eta bits (..., 2) -> degradation model 1..4 (eqs. 16-19)."""
    e = np.asarray(eta, dtype=int)
    return 1 + 2 * e[..., 0] + e[..., 1]


@dataclass
class Decoded:
    """One fault's decision, for every individual."""
    kind: np.ndarray          # (pop,) 0 abrupt, 1 intermittent, 2 incipient
    model: np.ndarray         # (pop,) 1..4
    value_ab: np.ndarray
    value_int: np.ndarray
    period: np.ndarray
    b: np.ndarray             # (pop, 7) coefficients in the paper's units


@dataclass(frozen=True)
class Table:
    """Every fault's decision for every individual, as arrays: ``kind`` and ``model`` (faults,
    pop), ``value`` and ``period`` (faults, pop), ``b`` (faults, pop, 7) in the paper's units.
    What the compiled objective reads (:mod:`fdi.fused`); :func:`decode` gives its rows."""
    kind: np.ndarray
    model: np.ndarray
    value: np.ndarray
    period: np.ndarray
    b: np.ndarray


# repair_zeta of each zeta code z0 z1 z2 (index 4 z0 + 2 z1 + z2): the table every decoder looks types up
# in (decode_table here, the compiled one of fdi.fused)
ZETA_TYPES = repair_zeta(np.array([[(c >> 2) & 1, (c >> 1) & 1, c & 1] for c in range(8)], dtype=bool)).astype(np.int64)
_LAYOUTS: dict = {}


def _layout(spaces: list[FaultSpace]) -> tuple[np.ndarray, np.ndarray, bool]:
    """Per fault of ``spaces``: searched as log10 (bool), the coefficients' scales (faults, 7), and
    whether any fault is logarithmic; kept per tuple of spaces (a search decodes thousands of times)."""
    key = tuple(spaces)
    try:
        got = _LAYOUTS.get(key)
    except TypeError:                      # an unhashable space: nothing kept
        got, key = None, None
    if got is None:
        log = np.array([s.log for s in spaces], dtype=bool)
        scale = np.array([[1, 1 / s.reference, 1, s.reference, 1 / s.reference, 1, s.reference] for s in spaces],
                         dtype=float).reshape(len(spaces), N_REAL - 2)
        got = (log, scale, bool(log.any()))
        if key is not None:
            if len(_LAYOUTS) > 256:
                _LAYOUTS.clear()
            _LAYOUTS[key] = got
    return got


def decode_table(spaces: list[FaultSpace], real: np.ndarray, bits: np.ndarray) -> Table:
    """The decision of every fault for every individual, in one pass (no loop over faults): the
    same operations on the same values as a fault at a time, so the same numbers (numpy's
    elementwise functions give an element the same result wherever it lies in an array).

    >>> s = [FaultSpace.make("R", np.inf, (1e6, 1e9)), FaultSpace("b", 1.0, (0.05, 1.5))]
    >>> t = decode_table(s, np.array([[7.0, 1, 0, 0, 0, 0, 0, 0, 0, 0.5, 2, 0.1, 0, 0, 0, 0, 0, 0]]),
    ...                  np.array([[1, 0, 0, 0, 0, 0, 0, 1, 1, 0]], dtype=bool))
    >>> t.kind.tolist(), t.model.tolist(), t.value.tolist(), float(t.b[1, 0, 0])
    ([[0], [2]], [[1], [3]], [[10000000.0], [0.5]], 0.1)
    """
    real = np.atleast_2d(real)
    bits = np.atleast_2d(bits)
    nf = len(spaces)
    log, scale, any_log = _layout(spaces)
    r = real[:, :N_REAL * nf].reshape(real.shape[0], nf, N_REAL).transpose(1, 0, 2)     # (faults, pop, 9)
    z = bits[:, :N_BITS * nf].reshape(bits.shape[0], nf, N_BITS).transpose(1, 0, 2)
    zeta = z[:, :, :3].astype(bool).astype(np.int64)        # as repair_zeta reads them
    value = r[:, :, 0].copy()
    if any_log:
        value[log] = 10 ** value[log]
    coeff = r[:, :, 2:] * scale[:, None, :]
    rate = 10.0 ** r[:, :, RATE_SLOT]
    coeff[:, :, RATE_SLOT - 2] = rate - 1.0 / rate
    kind = ZETA_TYPES[4 * zeta[:, :, 0] + 2 * zeta[:, :, 1] + zeta[:, :, 2]]
    return Table(kind, model_index(z[:, :, 3:]), value, r[:, :, 1].copy(), coeff)


def decode(spaces: list[FaultSpace], real: np.ndarray, bits: np.ndarray) -> list[Decoded]:
    """Each fault's decision for every individual (the rows of :func:`decode_table`)."""
    t = decode_table(spaces, real, bits)
    return [Decoded(t.kind[i], t.model[i], t.value[i], t.value[i], t.period[i], t.b[i]) for i in range(len(spaces))]


def encode(spaces: list[FaultSpace], faults: list[dict]) -> tuple[np.ndarray, np.ndarray]:
    """A diagnosis (dicts with type, value, period, model, b) -> one real row and one bit row."""
    real = np.concatenate([bounds([s]).mean(axis=1) for s in spaces])
    bits = np.zeros(N_BITS * len(spaces), dtype=bool)
    for i, (s, f) in enumerate(zip(spaces, faults)):
        k = TYPES.index(f["type"])
        bits[N_BITS * i + k] = True
        base = N_REAL * i
        to = (lambda v: np.log10(v)) if s.log else (lambda v: v)
        if k == 0:
            real[base] = to(f["value"])
        elif k == 1:
            real[base], real[base + 1] = to(f["value"]), f["period"]
        else:
            m = int(f["model"])
            bits[N_BITS * i + 3], bits[N_BITS * i + 4] = bool((m - 1) // 2), bool((m - 1) % 2)
            ref = s.reference
            scale = np.array([1, 1 / ref, 1, ref, 1 / ref, 1, ref])
            for slot, bval in zip(COEFF_SLOTS[m], f["b"]):
                if slot == RATE_SLOT:
                    real[base + slot] = np.log10((bval + np.sqrt(bval * bval + 4.0)) / 2.0)
                else:
                    real[base + slot] = bval / scale[slot - 2]
    return real, bits


def profiles(spaces: list[FaultSpace], decoded: list[Decoded], t: np.ndarray, t0) -> list[np.ndarray]:
    """Each fault's profile P(t) for every individual, (pop, N) per fault; ``t0`` is the onset,
    one for all or one per individual."""
    out = []
    for s, d in zip(spaces, decoded):
        pop = d.kind.shape[0]
        onset = np.broadcast_to(np.asarray(t0, dtype=float), (pop,))
        parts = []                               # (rows, their profiles) per type and model present
        m = d.kind == 0
        if m.any():
            parts.append((m, abrupt(t, onset[m], s.nominal, d.value_ab[m])))
        m = d.kind == 1
        if m.any():
            parts.append((m, intermittent(t, onset[m], s.nominal, d.value_int[m], d.period[m])))
        for model in (1, 2, 3, 4):
            m = (d.kind == 2) & (d.model == model)
            if m.any():
                cols = [slot - 2 for slot in COEFF_SLOTS[model]]
                parts.append((m, incipient(t, onset[m], s.nominal, model, d.b[m][:, cols])))
        if len(parts) == 1 and parts[0][0].all() and _own(parts[0][1], (pop, t.size)):
            out.append(parts[0][1])              # one type and model for all (a translation's 768 rows): as made,
            continue                             # not copied through a mask
        p = np.empty((pop, t.size))
        for m, rows in parts:
            p[m] = rows
        out.append(p)
    return out


def _own(a: np.ndarray, shape: tuple) -> bool:
    """Whether ``a`` is a fresh float array of ``shape`` a caller may keep and write (not a view)."""
    return (a.shape == shape and a.dtype == np.float64 and a.base is None and a.flags.c_contiguous
            and a.flags.writeable)


_ZETA_LIST = ZETA_TYPES.tolist()


def _decisions(spaces: list[FaultSpace], bits: np.ndarray) -> list[tuple[int, int]]:
    """Per fault of one individual, its type index and degradation model, read as :func:`decode`
    reads them (zeta as booleans, repaired; eta as integers), without the reals: the engine asks
    for the structure of a bit pattern thousands of times."""
    v = np.asarray(bits).reshape(-1)[:N_BITS * len(spaces)].tolist()
    return [(_ZETA_LIST[4 * bool(v[k]) + 2 * bool(v[k + 1]) + bool(v[k + 2])], 1 + 2 * int(v[k + 3]) + int(v[k + 4]))
            for k in range(0, N_BITS * len(spaces), N_BITS)]


def structure(spaces: list[FaultSpace], bits: np.ndarray) -> tuple:
    """The discrete decision of one individual: per fault its type and (incipient) model."""
    return tuple((TYPES[kind], model if kind == 2 else None) for kind, model in _decisions(spaces, bits))


def family(spaces: list[FaultSpace], bits: np.ndarray) -> frozenset:
    """The families of one individual's structure, one per fault: (fault index, type, degradation
    model or None). Each family's best structure is a champion of the race: every degradation
    model (16)-(19) of every fault keeps one structure through the first rungs and is re-polished
    at the end, whatever the other faults are (a narrow basin of one model is not left behind
    because a smooth fit of another costs less after two generations)."""
    return frozenset((i, kind, model) for i, (kind, model) in enumerate(structure(spaces, bits)))


def free(spaces: list[FaultSpace], bits: np.ndarray) -> np.ndarray:
    """The reals one individual's structure reads (bool, 9 per fault): an abrupt fault its value, an
    intermittent one its value and period, an incipient one the coefficients of its model."""
    mask = np.zeros(N_REAL * len(spaces), dtype=bool)
    for i, (kind, model) in enumerate(_decisions(spaces, bits)):
        base = N_REAL * i
        slots = [0] if kind == 0 else [0, 1] if kind == 1 else COEFF_SLOTS[model]
        mask[[base + s for s in slots]] = True
    return mask


def describe(spaces: list[FaultSpace], real: np.ndarray, bits: np.ndarray) -> list[dict]:
    """The best individual as the report's fault entries (paper units)."""
    out = []
    for s, d in zip(spaces, decode(spaces, real[None, :], bits[None, :])):
        kind = TYPES[int(d.kind[0])]
        entry: dict = {"name": s.name, "type": kind}
        if kind == "abrupt":
            entry["value"] = float(d.value_ab[0])
        elif kind == "intermittent":
            entry["value"], entry["period"] = float(d.value_int[0]), float(d.period[0])
        else:
            m = int(d.model[0])
            entry["model"] = m
            entry["eta"] = [(m - 1) // 2, (m - 1) % 2]
            entry["b"] = [float(d.b[0, slot - 2]) for slot in COEFF_SLOTS[m]]
        out.append(entry)
    return out


__all__ = ["FaultSpace", "bounds", "onehot_groups", "repair_zeta", "decode", "encode", "profiles", "structure",
           "family", "free", "describe", "N_COEFFICIENTS"]
