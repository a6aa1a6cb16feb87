"""Residuals: the AGARRs lambdified for numpy and evaluated on sampled data.

A residual is called with the *corrected* signals: each measurement divided by its sensor's
efficiency factor profile beta(t), each input multiplied by its source's, and then
differentiated numerically (:mod:`fdi.derivatives`). Correcting before differentiating is what
makes a time-varying beta(t) (intermittent, incipient) exact: d/dt(theta1/beta) includes the
beta'(t) terms, and the jumps of an intermittent sensor fault cancel when the profile is right.
Every argument may be a scalar or an array broadcastable to (population, samples).

A current source feeding C || R, its voltage measured: the residual is Kirchhoff's current law
``i_in - C dv/dt - v/R``. On data that obey it, v = 2 + sin(2 pi t) V and i_in = C dv/dt + v/R,
it stays at zero (to the derivative filter's error, away from its ends); on data from a resistor
of half the value, it is the current the model misses, v/R.

>>> import numpy as np
>>> from bondgraph.examples import rc_parallel
>>> from fdi.scaph import derive_arrs
>>> m = rc_parallel()
>>> kcl = compile_residual(m, derive_arrs(m)[0])
>>> kcl.signals                               # what it reads: i_in, v and dv/dt
(('i_in', 0), ('v', 0), ('v', 1))
>>> t = np.arange(0.0, 1.0, 0.001)
>>> v, dv = 2 + np.sin(2 * np.pi * t), 2 * np.pi * np.cos(2 * np.pi * t)
>>> inner = slice(50, -50)                    # half a derivative window from each end
>>> r = evaluate(m, [kcl], {"v": v, "i_in": 1e-3 * dv + v / 100}, 0.001, window=0.05)[0]
>>> bool(np.abs(r[inner]).max() < 1e-6)
True
>>> r = evaluate(m, [kcl], {"v": v, "i_in": 1e-3 * dv + v / 50}, 0.001, window=0.05)[0]
>>> bool(np.allclose(r[inner], v[inner] / 100, rtol=1e-4))
True
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable, Mapping, Sequence

import numpy as np

from bondgraph.deferred import deferred
from bondgraph.model import Fault, Model

from . import derivatives

if TYPE_CHECKING:           # sympy and the derivation: imported where a residual is compiled, not where one runs
    import sympy as sp

    from .scaph import ARR


class Estimates(list):
    """A signal's [x, dx/dt, ...] as filtered (:func:`fdi.derivatives.estimate`), with the
    (corrected) samples they were filtered from, ``raw``, and the mode switches the filter was
    broken at, ``breaks``. A stored quantity (``Residual.composites``) is formed from the samples
    themselves, not from their smoothed values: q = C e of the measured e is continuous where the
    physics keeps it so (a capacitance that drops at t0 makes p jump and C p stay), and one filter,
    the rate's, then acts on it, as on every other term (a residual reads its signals through one
    filter, not two in series). Formed from the smoothed e, C e jumped by dC e_hat(t0) at a
    capacitance fault's onset, and the rate's filter, in series with the smoothing, reached a
    whole window before the fault (measured on a chain of 100 tanks: a capacitance 20 % low from
    100 s detected at 95 s, the design fitted at 3836 but a 1.4 % change of the next tank given at
    5090)."""
    __slots__ = ("raw", "breaks", "settle")

    def __init__(self, estimates, raw: np.ndarray, breaks: np.ndarray | None = None, settle: int = 0) -> None:
        super().__init__(estimates)
        self.settle = settle        # samples after each break a too fast transient holds (switch_samples)
        self.raw = raw
        self.breaks = np.zeros(0, dtype=int) if breaks is None else breaks


def samples_of(series) -> np.ndarray:
    """The samples a signal's estimates were filtered from (its smoothed value where they are not
    known: a caller's own list)."""
    return series.raw if isinstance(series, Estimates) else series[0]


@deferred("expr")
@dataclass(frozen=True)
class Residual:
    name: str
    sensor: str | None
    func: Callable[..., np.ndarray]
    signals: tuple[tuple[str, int], ...]     # (signal, derivative order), in argument order
    symbols: tuple[str, ...]                 # parameters, remaining efficiency factors, modes
    expr: sp.Expr                            # the numeric form that was lambdified
    composites: tuple = ()                   # (derivative order, inner kernel): d^k/dt^k of a stored quantity
    ident: str = ""                          # the expression exactly (sympy's srepr), as plain text: two residuals
                                             # that store one quantity share its rate (no sympy read to compare)

    def __call__(self, signals: Mapping[str, list[np.ndarray]], values: Mapping[str, object],
                 ts: float | None = None, window: float = derivatives.DEFAULT_WINDOW,
                 crop: slice | None = None, rates: dict | None = None,
                 polyorder: int = derivatives.DEFAULT_ORDER) -> np.ndarray:
        """The residual on the samples of ``crop`` (all by default): signals and time-varying values
        are cut before the kernel runs; stored quantities are formed on the whole span (the filter reads
        their neighbours) and differentiated at the samples of ``crop`` only, by a Savitzky-Golay
        filter of order ``polyorder`` over ``window`` (that of the signals' derivatives, so that both
        forms of an ARR see the data alike; fdi.verify asks the order of its own signals).

        ``rates``: a dict the caller keeps while its ``signals`` and ``values`` stay the same arrays
        (one objective evaluation): a stored quantity's rate is filtered once there and reused by
        every residual that reads it with the same inputs (the CyCab's and the RC filter's ARR2 and
        ARR3 share d(C1 v)/dt; a linear fault's unit step leaves it unchanged)."""
        args = self.arguments(signals, values, crop, ts, window, rates, polyorder)
        try:
            with np.errstate(all="ignore"):     # NaN or inf where a law leaves its domain: the report says where
                out = self.func(*args)
        except OverflowError:
            # a constant beyond a double in Python's own arithmetic (a parameter of 1e299 squared raises
            # where numpy gives inf: a user's model crashed diagnose with a traceback): the same
            # operations on numpy's doubles, whose overflow is inf (the report then says the residual
            # is not finite, and where)
            with np.errstate(all="ignore"):
                out = self.func(*[np.float64(a) if isinstance(a, float) else a for a in args])
        return np.asarray(out, dtype=float)

    def arguments(self, signals: Mapping[str, list[np.ndarray]], values: Mapping[str, object],
                  crop: slice | None = None, ts: float | None = None, window: float = derivatives.DEFAULT_WINDOW,
                  rates: dict | None = None, polyorder: int = derivatives.DEFAULT_ORDER) -> list:
        """The kernel's arguments in order (:meth:`__call__` without the call): signals and values
        cut to ``crop``, stored quantities' rates filtered."""
        def cut(a):      # an array along the samples is cut; a number, or one value per row (pop, 1), is not
            return a[..., crop] if crop is not None and isinstance(a, np.ndarray) and a.ndim and a.shape[-1] > 1 else a
        args = [cut(signals[s][k]) for s, k in self.signals]
        for order, inner in self.composites:
            if ts is None:
                raise ValueError(f"{self.name} differentiates a stored quantity numerically: pass ts")
            args.append(self._rate(order, inner, signals, values, ts, window, crop, rates, polyorder))
        args += [cut(values[n]) for n in self.symbols]
        return args

    @staticmethod
    def _rate(order: int, inner: "Residual", signals: Mapping, values: Mapping, ts: float, window: float,
              crop: slice | None, rates: dict | None, polyorder: int = derivatives.DEFAULT_ORDER) -> np.ndarray:
        """d^order/dt^order of the stored quantity ``inner`` at the samples of ``crop``; from ``rates``
        when the same quantity was filtered there from the very same input arrays (compared by
        identity, and held by the entry, so an id is never reused while it is compared)."""
        reads = tuple(signals[s][k] for s, k in inner.signal_orders()) + \
            tuple(values[n] for n in sorted(inner.parameter_names()))
        key = (inner.key, order, polyorder, None if crop is None else (crop.start, crop.stop, crop.step))
        if rates is not None:
            for held, rate in rates.get(key, ()):
                if len(held) == len(reads) and all(a is b for a, b in zip(held, reads)):
                    return rate
        measured = {s: Estimates([samples_of(v)] + list(v[1:]), samples_of(v), getattr(v, "breaks", None),
                                 getattr(v, "settle", 0)) for s, v in signals.items()}
        x = np.asarray(inner(measured, values, ts, window, rates=rates, polyorder=polyorder), dtype=float)
        finite = np.isfinite(x)
        # a sample no row has (a signal's derivative left out at a mode switch by design, a spike in
        # the data) leaves the rate NaN only where the filter reads it, as the generated C monitor's
        # does; a row alone not finite somewhere is an individual past a pole: no residual for it (an
        # individual evaluated alone keeps its NaN local: outside the designed gaps that makes its
        # cost infinite all the same, fdi.objective)
        # (until 2026-11 any sample made the whole record NaN: one contact of an end stop, whose
        # stored quantity reads a derivative, blinded the residual on every sample)
        common = ~finite if x.ndim == 1 else ~finite.any(axis=tuple(range(x.ndim - 1)))
        bad = (~finite & ~common).any(axis=-1, keepdims=True)
        x = np.where(common, np.nan, np.where(finite, x, 0.0))
        broken = next((b for b in signals.values() if isinstance(b, Estimates) and len(b.breaks)), None)
        if broken is not None:       # its rate broken at the mode switches, as the signals' derivatives are
            d = _piecewise(x, ts, order, window, broken.breaks, polyorder, broken.settle)[order]
        else:
            d = derivatives.estimate(x, ts, order, window, polyorder=polyorder, at=crop)[order]
        rate = np.where(bad, np.nan, d[..., crop] if crop is not None else d)
        if rates is not None:
            rates.setdefault(key, []).append((reads, rate))
        return rate

    @property
    def key(self) -> object:
        """What identifies the quantity this kernel computes among residuals (two ARRs that store
        one quantity share its rate): its exact expression as text, without reading sympy."""
        return self.ident or self.expr

    def parameter_names(self) -> set[str]:
        """Every parameter, efficiency factor and mode this kernel reads, its stored quantities' included."""
        return set(self.symbols).union(*(inner.parameter_names() for _, inner in self.composites))

    def signal_orders(self) -> list[tuple[str, int]]:
        """Every (signal, derivative order) this kernel reads, its stored quantities' included."""
        out = list(self.signals)
        for _, inner in self.composites:
            out += inner.signal_orders()
        return out

    def highest_order(self) -> int:
        """The highest derivative of a measured signal this kernel takes, a stored quantity's rate
        counting its own (d/dt of m v' is a second derivative of v)."""
        return max([k for _, k in self.signals] + [order + inner.highest_order() for order, inner in self.composites],
                   default=0)


def numeric_form(model: Model, expr: sp.Expr) -> sp.Expr:
    """Sensor and input efficiency factors set to 1: the caller passes corrected signals."""
    import sympy as sp
    ones = {model.beta_symbol(s): sp.Integer(1) for s in model.sensors}
    ones.update({model.beta_symbol(e.input): sp.Integer(1) for e in model.sources() if e.input})
    return expr.xreplace(ones)


def compile_residual(model: Model, arr: ARR) -> Residual:
    """Lambdify one ARR: signal derivatives become plain array arguments. Where the ARR has an
    ``exact`` form (a storage law with a fault parameter), that form is compiled: the rate of the
    stored quantity, ``Derivative(C*e(t), t)``, is evaluated by computing C*e on the data (C may
    vary per individual and sample) and differentiating it with the same filter as the signals,
    so that a capacitance that drops at t0 leaves q = C e continuous, as the simulator does."""
    if arr.states:
        raise ValueError(f"{arr.name} integrates states (mixed causality); bgfdi evaluates residuals in "
                         "derivative causality on data: use the derivative-causality residual set")
    return _compile(model, evaluated_form(model, arr), arr.name, arr.sensor)


def evaluated_form(model: Model, arr: ARR) -> sp.Expr:
    """The expression of ``arr`` a residual kernel evaluates: its exact form where it has one (a
    storage law with a fault parameter), efficiency factors at 1 (:func:`numeric_form`)."""
    return numeric_form(model, arr.exact if arr.exact is not None else arr.expr)


def _compile(model: Model, expr: sp.Expr, name: str, sensor: str | None) -> Residual:
    import sympy as sp

    from bondgraph.equations import is_signal
    from bondgraph.model import t
    names = list(model.sensors) + list(model.inputs)
    composite_syms: list[sp.Symbol] = []
    stored: list[tuple[int, Residual]] = []
    while True:     # outermost first: a rate may also appear inside another (three tanks: d(C1 p1)/dt in d(C2 (...))/dt)
        whole = [d for d in expr.atoms(sp.Derivative) if not is_signal(d.expr)]
        if not whole:
            break
        outer = sorted((d for d in whole if not any(o is not d and o.has(d) for o in whole)), key=str)
        syms = [sp.Symbol(f"__stored{len(composite_syms) + i}", real=True) for i in range(len(outer))]
        stored += [(int(sum(c for v, c in d.variable_count if v == t)), _compile(model, d.expr, name, sensor)) for d in outer]
        composite_syms += syms
        expr = expr.xreplace(dict(zip(outer, syms)))
    composites = tuple(stored)
    replace: dict[sp.Expr, sp.Symbol] = {}
    used: list[tuple[str, int]] = []
    for d in sorted(expr.atoms(sp.Derivative), key=str):
        fn = d.expr
        if not is_signal(fn):
            raise ValueError(f"{name}: cannot evaluate the derivative {d} numerically")
        order = int(sum(c for v, c in d.variable_count if v == t))   # a Python int: sympy's cost 10 us per use
        replace[d] = sp.Symbol(f"{fn.func.__name__}__d{order}", real=True)
        used.append((fn.func.__name__, order))
    for fn in expr.atoms(sp.core.function.AppliedUndef):
        if fn.func.__name__ in names:
            replace[fn] = sp.Symbol(f"{fn.func.__name__}__d0", real=True)
            used.append((fn.func.__name__, 0))
    # replace derivatives first so that theta1(t) inside Derivative(theta1(t), t) is not touched
    numeric = expr.xreplace({k: v for k, v in replace.items() if isinstance(k, sp.Derivative)})
    numeric = numeric.xreplace({k: v for k, v in replace.items() if not isinstance(k, sp.Derivative)})
    used = sorted(set(used))
    signal_syms = [sp.Symbol(f"{s}__d{k}", real=True) for s, k in used]
    others = sorted((s for s in numeric.free_symbols if s not in set(signal_syms) and s not in set(composite_syms)),
                    key=lambda s: s.name)
    func = _kernel(signal_syms + composite_syms + others, numeric)
    return Residual(name, sensor, func, tuple(used), tuple(s.name for s in others), expr, composites, sp.srepr(expr))


def _kernel(args: list[sp.Symbol], expr: sp.Expr):
    """``expr`` lambdified over ``args``, each renamed ``_a0``, ``_a1``, ... (zero-padded to one width) first: a parameter
    may be named like a numpy function (exp, sign) without shadowing it, and the printed code (the
    order of every product and sum, hence the last bits of every residual) depends on the
    arguments' positions only. sympy's own ``dummify`` names arguments by a process-wide counter
    that sorts as text: a model derived a second time in one process gave residuals 6e-14 apart."""
    import sympy as sp
    width = len(str(max(len(args) - 1, 0)))
    names = [sp.Symbol(f"_a{i:0{width}d}", real=True) for i in range(len(args))]
    return sp.lambdify(names, expr.xreplace(dict(zip(args, names))), modules="numpy", cse=True)


def compile_residuals(model: Model, arrs: list[ARR]) -> list[Residual]:
    return [compile_residual(model, a) for a in arrs]


def divided_by_mode(model: Model, arrs: Sequence[ARR], residuals: Sequence[Residual],
                    tables: Mapping[str, Mapping[tuple, float]]) -> tuple[Residual, ...]:
    """``residuals`` with each one that has a table of thresholds by mode (:mod:`fdi.mode_thresholds`)
    replaced by its ARR divided by its mode's threshold (:func:`fdi.mode_thresholds.weight`),
    compiled as any residual (:func:`compile_residual`)."""
    if not tables:
        return tuple(residuals)
    from .mode_thresholds import weight
    by_name = {a.name: a for a in arrs}
    out = []
    for r in residuals:
        table = tables.get(r.name)
        if table is None:
            out.append(r)
            continue
        arr = by_name[r.name]
        expr = evaluated_form(model, arr) * weight(model, table)
        out.append(_compile(model, expr, arr.name, arr.sensor))
    return tuple(out)


def derivative_orders(residuals: list[Residual]) -> dict[str, int]:
    """The highest derivative of each signal that any residual needs."""
    orders: dict[str, int] = {}
    for r in residuals:
        for s, k in r.signal_orders():
            orders[s] = max(orders.get(s, 0), k)
    return orders


def corrected_signals(model: Model, raw: Mapping[str, np.ndarray], ts: float, orders: Mapping[str, int],
                      betas: Mapping[str, object] | None = None,
                      window: float = derivatives.DEFAULT_WINDOW, edges: str = "interp",
                      biases: Mapping[str, object] | None = None, at: slice | None = None) -> dict[str, list[np.ndarray]]:
    """Each signal (sensor measurement / beta, or beta * input) and its derivatives; ``biases``
    are additive offsets removed first (a sensor reads true + b: (measured - b) / beta; a source
    gives commanded + b: beta * (input + b)). ``at``: only those samples are needed
    (:func:`fdi.derivatives.estimate`; ignored where a mode switch splits the record)."""
    betas = betas or {}
    biases = biases or {}
    out: dict[str, list[np.ndarray]] = {}
    breaks = mode_breaks(model, raw)
    settle = switch_samples(model, ts) if len(breaks) else 0
    for name, order in orders.items():
        x = np.asarray(raw[name], dtype=float)
        bias = biases.get(name)
        if bias is not None:
            x = x - bias if name in model.sensors else x + bias
        beta = betas.get(name)
        if beta is not None:
            x = x / beta if name in model.sensors else x * beta
        out[name] = Estimates(derivatives.estimate(x, ts, order, window, edges=edges, at=at) if not len(breaks) else
                              _piecewise(x, ts, order, window, breaks, settle=settle), x, breaks, settle)
    return out


def mode_breaks(model: Model, raw: Mapping[str, np.ndarray]) -> np.ndarray:
    """Sample indices where a commanded or autonomous mode switches (its values, or its command column,
    cross 0.5): a switch makes the
    derivatives of the signals jump (an inductor's current slope at every PWM edge), which no
    filter window may straddle."""
    cols = [m.name if m.name in raw else m.column for m in model.modes.values()
            if (m.column or m.autonomous) and (m.name in raw or m.column in raw)]
    if not cols:
        return np.zeros(0, dtype=int)
    on = np.stack([np.asarray(raw[c], dtype=float) >= 0.5 for c in cols])
    return np.flatnonzero(np.any(on[:, 1:] != on[:, :-1], axis=0)) + 1


def switch_samples(model: Model, ts: float) -> int:
    """Samples from each mode switch on that hold a transient too fast for data sampled every
    ``ts`` s (:func:`fdi.scales.switch_settle`; 0: none): with the samples whose filter window
    reaches back to them, they are left out (:func:`stretches`)."""
    from bondgraph.timescales import model_time_scales
    from .scales import switch_settle
    seconds = switch_settle(ts, model_time_scales(model).eigenvalues)
    return int(np.ceil(seconds / ts - 1e-9)) if seconds > 0 else 0


SHORT_STRETCH = 4     # windows: a stretch between switches shorter than this is fast switching


def _piecewise(x: np.ndarray, ts: float, order: int, window: float, breaks: np.ndarray,
               polyorder: int = derivatives.DEFAULT_ORDER, settle: int = 0) -> list[np.ndarray]:
    """Derivatives estimated on each stretch between mode switches apart. A stretch a few windows
    long or more is fitted up to its ends (one-sided fits there: a valve commanded shut is seen at
    once); in fast switching (a stretch shorter than SHORT_STRETCH windows, a PWM half-period) only
    where the filter's whole window fits inside, since one-sided fits amplify the noise several
    times and would set the thresholds (measured on the boost converter: 15 times looser). After a
    switch, ``settle`` samples of a transient too fast for the data (:func:`switch_samples`) and
    those whose window reads them are left out too. Samples left out give NaN, which detection,
    calibration and identification skip."""
    out = [np.full(x.shape, np.nan) for _ in range(order + 1)]
    need = derivatives.window_samples(window, ts, max(polyorder, order))
    for (a, b), keep in stretches(x.shape[-1], breaks, need, derivatives.edge_trim(need, max(polyorder, order), order),
                                  settle):
        for k, d in enumerate(derivatives.estimate(x[..., a:b], ts, order, window, polyorder=polyorder)):
            out[k][..., keep] = d[..., keep.start - a:keep.stop - a]
    return out


def channel_orders(residuals: list["Residual"]) -> set[int]:
    """Every derivative order the residuals filter a channel at: each signal's highest (as
    :func:`derivative_orders`) and each stored quantity's rate (``composites``, nested ones too)."""
    out = set(derivative_orders(residuals).values())
    todo = list(residuals)
    while todo:
        r = todo.pop()
        for order, inner in r.composites:
            out.add(order)
            todo.append(inner)
    return out


def designed_gaps(residuals: list["Residual"], size: int, breaks: np.ndarray, window: float, ts: float,
                  polyorder: int = derivatives.DEFAULT_ORDER, settle: int = 0) -> np.ndarray:
    """The samples some residual leaves NaN by design at mode switches (:func:`_piecewise` on each of
    its channels, :func:`stretches`): True there. Every channel's order counts, for each has its own
    window and edge trim (a stored quantity's first rate beside signals read undifferentiated);
    ``settle``: :func:`switch_samples` of the model."""
    def trimmed(order: int) -> np.ndarray:
        p = max(polyorder, order)
        need = derivatives.window_samples(window, ts, p)
        kept = np.zeros(size, dtype=bool)
        for _, keep in stretches(size, breaks, need, derivatives.edge_trim(need, p, order), settle):
            kept[keep] = True
        return ~kept

    gaps = np.zeros(size, dtype=bool)
    for order in channel_orders(residuals) | {0}:
        gaps |= trimmed(order)
    if len(breaks):
        highest = derivative_orders(residuals)
        for r in residuals:                 # (a rate inside a rate: through the outer one, _rate_gaps)
            for order, inner in r.composites:
                gaps |= _rate_gaps(order, inner, highest, trimmed, size, breaks, window, ts, polyorder)
    return gaps


def switch_gaps(model: Model, residuals: Sequence["Residual"], raw: Mapping[str, np.ndarray], size: int,
                window: float, ts: float) -> np.ndarray | None:
    """The samples of a record (``raw``, ``size`` samples every ``ts`` s) the evaluator leaves out by
    design at its mode switches (:func:`designed_gaps`, with the model's :func:`switch_samples`);
    None when the record does not switch: the one call the diagnosis, the objective and calibrate
    make, so that each leaves out what :func:`corrected_signals` leaves NaN."""
    breaks = mode_breaks(model, raw)
    if not len(breaks):
        return None
    return designed_gaps(list(residuals), size, breaks, window, ts, settle=switch_samples(model, ts))


def _rate_gaps(order: int, inner: "Residual", highest: Mapping[str, int], trimmed: Callable, size: int,
               breaks: np.ndarray, window: float, ts: float, polyorder: int) -> np.ndarray:
    """Where a stored quantity's rate is NaN because the quantity is (:meth:`Residual._rate`: it
    reads a signal's derivative, left out near a switch, or an inner quantity's rate): the rate's
    filter reads such a sample from half a window away, and a stretch's edge fit from its first or
    last whole window."""
    x = np.zeros(size, dtype=bool)
    for sig, k in inner.signals:
        if k >= 1:
            x |= trimmed(highest.get(sig, k))
    for o, q in inner.composites:          # an inner rate: its own trim at each switch and what it inherits
        x |= trimmed(o) | _rate_gaps(o, q, highest, trimmed, size, breaks, window, ts, polyorder)
    if not x.any():
        return x
    n = derivatives.window_samples(window, ts, max(polyorder, order))
    half = n // 2
    out = np.zeros(size, dtype=bool)
    hits = np.r_[0, np.cumsum(x)]              # hits[j] - hits[i]: NaN samples of x in [i, j)
    for (a, b), _ in stretches(size, breaks, n):
        i = np.arange(a + half, b - half)
        out[i] = hits[i + half + 1] - hits[i - half] > 0
        out[a:a + half] = hits[a + n] - hits[a] > 0
        out[b - half:b] = hits[b] - hits[b - n] > 0
    return out


def stretches(size: int, breaks: np.ndarray, need: int, edge: int = 0, settle: int = 0) -> list[tuple[tuple[int, int], slice]]:
    """The stretches between mode switches that :func:`_piecewise` estimates, each (its samples
    [a, b), the samples kept): none shorter than the filter's window (``need`` samples); in fast
    switching (shorter than SHORT_STRETCH windows) half a window trimmed at each switch, in a longer
    one ``edge`` samples (where the one-sided fit is too noisy: :func:`fdi.derivatives.edge_trim`);
    after a switch at least ``settle`` samples (a transient too fast for the data,
    :func:`switch_samples`) and the half window whose fits read them, when ``settle`` > 0.
    The other samples are NaN by design (the report's note on residuals that are not finite leaves
    them out)."""
    edges = np.r_[0, breaks, size]
    out = []
    for a, b in zip(edges[:-1].tolist(), edges[1:].tolist()):
        if b - a < need:
            continue
        trim = need // 2 if b - a < SHORT_STRETCH * need else edge
        start = max(trim, settle + need // 2) if settle else trim
        out.append(((a, b), slice(min(a + start, b) if a > 0 else a, b - trim if b < size else b)))
    return out


def corrects_signal(model: Model, f: Fault) -> bool:
    """Whether sensor or source fault ``f`` corrects a data signal before the derivatives (a
    sensor's reading, a source's input column). A source with a fixed ``value`` (Sf/Se) has no
    signal: its efficiency factor ``beta_<name>`` stays a parameter of the residuals, set per
    individual like a parametric fault's."""
    return f.kind == "sensor" or (f.kind == "source" and f.targets[0] in model.inputs)


def parameter_values(model: Model, overrides: Mapping[str, object] | None = None) -> dict[str, object]:
    """Nominal parameter, efficiency factor and mode values by name, with overrides applied."""
    values: dict[str, object] = dict(model.nominal_by_name())
    values.update(overrides or {})
    return values


def evaluate(model: Model, residuals: list[Residual], raw: Mapping[str, np.ndarray], ts: float, *,
             values: Mapping[str, object] | None = None, betas: Mapping[str, object] | None = None,
             window: float = derivatives.DEFAULT_WINDOW, biases: Mapping[str, object] | None = None) -> np.ndarray:
    """Residuals on data: array of shape (n_residuals, ..., samples)."""
    blocked = _in_blocks(model, residuals, raw, ts, parameter_values(model, values), betas, window, biases)
    if blocked is not None:
        return blocked
    sig = corrected_signals(model, raw, ts, derivative_orders(residuals), betas, window, biases=biases)
    vals = parameter_values(model, values)
    samples = _one_record(residuals, sig, vals)
    if samples > EVAL_BLOCK:                      # one long record: each residual written in place, in blocks
        out = np.empty((len(residuals), samples))
        for row, r in zip(out, residuals):
            for a in range(0, samples, EVAL_BLOCK):
                b = min(samples, a + EVAL_BLOCK)
                row[a:b] = r(sig, vals, ts, window, crop=slice(a, b))
        return out
    outs = [r(sig, vals, ts, window) for r in residuals]
    shape = np.broadcast_shapes(*[o.shape for o in outs], *[np.shape(v[0]) for v in sig.values()])
    return np.stack([np.broadcast_to(o, shape) for o in outs])


EVAL_BLOCK = 1 << 16    # samples per call of a residual kernel on one long record (its temporaries: 0.5 MB each)


def _in_blocks(model: Model, residuals: list[Residual], raw: Mapping[str, np.ndarray], ts: float,
               vals: Mapping[str, object], betas: Mapping[str, object] | None, window: float,
               biases: Mapping[str, object] | None) -> np.ndarray | None:
    """The residuals of one long record (more than EVAL_BLOCK samples, every signal 1-D), the
    signals' derivatives included, computed EVAL_BLOCK samples at a time from the samples of the
    block and half a derivative window each side (the first and last whole windows at the ends):
    memory of one block of derivatives, not of (signals x orders x samples) (a minute at 10 kHz:
    37 MB for the CyCab). Each sample's derivative is the same filter over the same samples, so the
    numbers are the whole record's, bit for bit. None where that does not hold (mode switches,
    stored quantities, profiles or populations): the caller evaluates the whole record."""
    orders = derivative_orders(residuals)
    if not orders or any(r.composites for r in residuals):
        return None
    signals = [np.asarray(raw[name]) for name in orders]
    samples = signals[0].shape[-1] if signals[0].ndim == 1 else 0
    if samples <= EVAL_BLOCK or any(x.shape != (samples,) for x in signals):
        return None
    corrections = list((betas or {}).values()) + list((biases or {}).values())
    if any(np.ndim(v) for v in corrections):
        return None
    varying = {n for r in residuals for n in r.symbols if np.ndim(vals[n])}
    if any(np.shape(vals[n]) != (samples,) for n in varying):
        return None
    n = max(derivatives.window_samples(window, ts, max(derivatives.DEFAULT_ORDER, k)) for k in orders.values())
    if 4 * n > EVAL_BLOCK or len(mode_breaks(model, raw)):
        return None
    half = n // 2
    out = np.empty((len(residuals), samples))
    for a in range(0, samples, EVAL_BLOCK):
        b = min(samples, a + EVAL_BLOCK)
        lo, hi = max(0, min(a - half, samples - n)), min(samples, max(b + half, n))
        part = {name: x[lo:hi] for name, x in zip(orders, signals)}
        sig = corrected_signals(model, part, ts, orders, betas, window, biases=biases)
        here = {**vals, **{name: np.asarray(vals[name])[lo:hi] for name in varying}}
        for row, r in zip(out, residuals):
            row[a:b] = r(sig, here, ts, window, crop=slice(a - lo, b - lo))
        del sig, part
    return out


def _one_record(residuals: list[Residual], sig: Mapping[str, list[np.ndarray]], vals: Mapping[str, object]) -> int:
    """The number of samples when the residuals are evaluated on one record (every signal and
    time-varying value 1-D, no stored quantity differentiated on the whole span), else 0. Such
    residuals are computed EVAL_BLOCK samples at a time: a kernel's common subexpressions are
    arrays as long as its arguments (a minute at 10 kHz made them 80 MB), and the numbers are the
    same, sample by sample. Populations (the estimators' windows) are evaluated in one call."""
    lengths = {np.shape(x[0]) for x in sig.values()}
    if len(lengths) != 1 or len(next(iter(lengths))) != 1 or any(r.composites for r in residuals):
        return 0
    shape = next(iter(lengths))
    if any(np.ndim(vals[n]) != 0 and np.shape(vals[n]) != shape for r in residuals for n in r.symbols):
        return 0
    return shape[0]


def never_finite_text(model, residuals, names: list[str]) -> str:
    """What :func:`fdi.pipeline.never_finite`'s refusal (and calibrate's) says: the residuals
    ``names`` of ``residuals``, the laws they may read that are defined on part of the real line
    only (a root, a logarithm, an inverse trigonometric function of the kind the residuals hold,
    of parameters they read or of none), and what to check."""
    from bondgraph.expressions import limited_parts
    from bondgraph.model import LAW_VARIABLES

    def kinds(expr) -> set:
        return {("pow", e.exp) if e.is_Pow else type(e) for e in limited_parts(expr)}
    local = {v.name for v in LAW_VARIABLES.values()}
    chosen = [r for r in residuals if r.name in names]
    read = {s for r in chosen for s in r.symbols}
    held = set().union(*(kinds(r.expr) for r in chosen)) if chosen else set()
    laws = []
    for el in model.elements.values():       # (a law of parameters none of them reads: not theirs)
        for law, expr in el.laws.items():
            named = {s.name for s in expr.free_symbols} - local
            if kinds(expr) & held and (not named or read & named):
                laws.append(f"{el.name}'s {law} {str(expr).replace('~', '')}")
    one = len(names) == 1
    it, they = ("it", "it") if one else ("them", "they")
    where = f" in {model.path}" if getattr(model, "path", None) else ""
    cause = (f"a law {they} read{'s' if one else ''} leaves its domain on these data "
             f"({'; '.join(laws[:3])}{'; ...' if len(laws) > 3 else ''}{where}): check the law against the values "
             "the data take there, and the data's units" if laws else
             "a law of the model overflows a double or leaves its domain on these data (a parameter of 0 or .inf "
             "it divides by, an exponent through a parameter), or the record holds values no sensor reads; "
             "bgfdi tables shows the residuals")
    return (f"{', '.join(names)} {'is' if one else 'are'} not finite on any sample, so no threshold can judge {it} "
            f"and a diagnosis would read {it} as silent: {cause}")
