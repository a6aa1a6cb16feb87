"""``bgfdi codegen``: the residual monitor of a model as self-contained C99 (docs/deploy.md).

What the generated monitor computes is what ``bgfdi diagnose`` and ``bgfdi monitor`` compute up
to detection, sample by sample:

- the model's signals from a sample's columns (a sensor's ``expr``, an input's column or its
  expression of t, commanded modes from their command columns, autonomous modes from their
  condition);
- their Savitzky-Golay derivatives (:mod:`fdi.derivatives`: the same window in samples, polynomial
  and coefficients, computed here and emitted as constants), broken at mode switches as
  :func:`fdi.residuals.corrected_signals` breaks them (one-sided fits at the ends of stretches
  four windows long or more but for the samples at a switch where they are more than 1.5 times
  as noisy as the centred filter, :func:`fdi.derivatives.edge_trim`; nothing within half a window of
  the switches of shorter ones);
- the rates of stored quantities ``d(C e)/dt`` (``Residual.composites``): C e computed per
  sample and filtered on the whole stream;
- the residual kernels, printed from the compiled ARRs by sympy's C printer with common
  subexpressions (:mod:`fdi.codegen_printer`);
- detection (:mod:`fdi.detect`): thresholds, the settling time, evidence and persistence
  within the span (:func:`fdi.scales.detection_rule`), the latched coherence vector, t_D, the
  alarm and the decision T_wt after it.

:func:`plan` gathers all of that from a :class:`fdi.monitor.Monitor` into a :class:`Plan` (no C
yet); :mod:`fdi.codegen_c` writes it as C; :func:`generate` does both and :func:`write_folder`
writes the files, all or none.
"""
from __future__ import annotations

import math
import os
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

import numpy as np
import sympy as sp

from bondgraph.equations import is_signal
from bondgraph.model import Model, t as TIME
from bondgraph.timescales import model_time_scales

from . import derivatives, scales
from .codegen_names import comment, identifier
from .codegen_printer import Body, CodegenError, c_function_body
from .detect import evidence_samples, settling, thresholds_for
from .residuals import Residual, derivative_orders, evaluated_form, parameter_values, switch_samples

LANGUAGES = ("c",)
MAX_ORDER = 7               # derivatives the C filter computes (its MAX_P)
MAX_RING = 1 << 22          # samples held per ring: beyond, the windows are too long for a controller


@dataclass(frozen=True)
class Column:
    """One value of a sample, in the order ``step`` takes them."""
    name: str
    unit: str
    role: str


@dataclass(frozen=True)
class Channel:
    """One filtered sequence: a signal (measured or input) or a stored quantity's inner value.
    Its derivatives 0..``orders`` are outputs ``out``..``out + orders`` of the gathered values;
    ``n`` samples per window, polynomial order ``p`` (:func:`fdi.derivatives.estimate`)."""
    name: str
    kind: str                  # "signal" or "stored"
    orders: int
    n: int
    p: int
    out: int
    unit: str
    inner: Body | None = None  # stored: the statements computing its value from the gathered values
    inputs: tuple[int, ...] = ()   # stored: the channels it reads
    lag: int = 0               # samples after which its values are final (start-up and switches aside)


@dataclass(frozen=True)
class Parameter:
    """A value a kernel reads that is the same at every sample: a field of the params struct."""
    name: str
    field: str
    value: float
    note: str


@dataclass(frozen=True)
class Mode:
    """A mode variable read per sample: from its command column (its index in the sample), or,
    autonomous (``column`` None), from its condition on the sample's signals."""
    name: str
    column: int | None


@dataclass(frozen=True)
class Kernel:
    """One residual: its ARR's name, what it is, unit, threshold and the C statements computing it."""
    name: str
    what: str                  # "the AGARR of sensor theta1", "the MSO residual at junction shaft"
    unit: str
    threshold: float
    text: str                  # the ARR as sympy prints it (for the comment)
    body: Body


@dataclass(frozen=True)
class Plan:
    """Everything the C monitor computes, resolved for sampling time ``ts`` (module doc)."""
    model: str
    prefix: str
    ts: float
    window: float
    wait: float
    persistence: float
    span: float
    span_samples: int
    settle: float
    end_edge: float
    columns: tuple[Column, ...]
    channels: tuple[Channel, ...]
    signals: int                       # channels[:signals] are signals, the rest stored quantities
    take: tuple[str, ...]              # C statements: the signals and modes of one sample (col -> x, mode)
    take_helpers: frozenset[str]
    modes: tuple[Mode, ...]
    parameters: tuple[Parameter, ...]
    residuals: tuple[Kernel, ...]
    ring: int
    lag: int
    switch_settle: int = 0             # samples of a transient too fast for the data after a switch

    @property
    def outputs(self) -> int:
        """Filtered values gathered per sample (every channel's derivatives)."""
        return sum(c.orders + 1 for c in self.channels)

    @property
    def helpers(self) -> frozenset[str]:
        out = set(self.take_helpers)
        for k in self.residuals:
            out |= k.body.helpers
        for c in self.channels:
            if c.inner is not None:
                out |= c.inner.helpers
        return frozenset(out)

    def state_bytes(self) -> int:
        """sizeof the monitor's state struct, to within its padding: what a controller must hold."""
        r = len(self.residuals)
        rings = self.ring * (8 * (1 + max(1, len(self.modes)) + len(self.channels) + self.outputs + r) + 1)
        return (rings + (9 * r + 8) * self.span_samples + 8 * (max(1, len(self.parameters)) + 6 * r)
                + 16 * len(self.channels) + 2 * r + 8 * 18)


def sampling_time(model: Model, given: float | None) -> float:
    """The sampling time the monitor is generated for: ``given``, else the model file's."""
    ts = given if given is not None else model.sampling_time
    if ts is None:
        raise CodegenError(f"{model.path or model.name}: the model gives no data.sampling_time; pass "
                           "--sampling-time SECONDS (the filter's coefficients depend on it)")
    if not (math.isfinite(ts) and ts > 0):
        raise CodegenError(f"--sampling-time: must be a time in s > 0, got {ts!r}")
    return float(ts)


def prefix_for(model: Model, given: str | None = None) -> str:
    """The C prefix of the generated names and files: ``given`` (checked), or bgfdi_ and the
    model's name in lower-case ASCII words joined by ``_``.

    >>> from bondgraph.examples import rc_parallel
    >>> prefix_for(rc_parallel()), prefix_for(rc_parallel(), "Pump_A")
    ('bgfdi_rc_parallel', 'pump_a')
    """
    if given is not None:
        if not (given.isascii() and given[:1].isalpha() and all(c.isalnum() or c == "_" for c in given)
                and len(given) <= 40):
            raise CodegenError(f"--prefix: must be a C identifier (a letter, then letters, digits and _; "
                               f"at most 40 characters), got {given!r}")
        return given.lower()
    words = re.findall(r"[a-z0-9]+", model.name.lower())
    return ("bgfdi_" + "_".join(words))[:40].rstrip("_") if words else "bgfdi_model"


def plan(monitor, ts: float | None = None, options=None, prefix: str | None = None) -> Plan:
    """The C monitor of ``monitor`` (a :class:`fdi.monitor.Monitor`, or a model path, YAML text or
    Model: :func:`fdi.monitor.monitor_of`) for data sampled every ``ts`` s (the model file's
    sampling time by default), with the run ``options`` a diagnosis would use
    (:class:`fdi.options.Options`: thresholds, waiting time, persistence and settling overrides)."""
    from .monitor import monitor_of
    from .options import Options
    o = options or Options()
    from .pipeline import with_overrides
    monitor = with_overrides(monitor_of(monitor).with_config(o.settings), o.thresholds)
    model = monitor.model
    where = model.path or model.name
    ts = sampling_time(model, ts)
    monitor, sc = monitor.scaled(ts)
    config = monitor.config
    names = list(monitor.names)
    if not names:
        raise CodegenError(f"{where}: the model has no residual to monitor (bgfdi check {where} says why)")
    try:
        thresholds = thresholds_for(config.thresholds, names, o.thresholds)
    except ValueError as exc:
        raise CodegenError(f"{where}: {exc} (bgfdi calibrate -o writes them into a copy of the model)") from None
    window = float(config.derivative_window)
    wait = float(config.waiting_time if o.waiting_time is None else o.waiting_time)
    persistence, span = scales.detection_rule(window, wait, o.persistence, config.persistence)
    settle = settling(o.settle, scales.settle(window, model_time_scales(model).eigenvalues))

    columns, column_index = _columns(model)
    per_sample = [m for m in model.modes.values() if m.column or m.autonomous]
    piecewise = bool(per_sample)
    residuals = list(monitor.residuals)
    orders = derivative_orders(residuals)
    signal_names = [s for s in list(model.sensors) + list(model.inputs) if s in orders]
    values = parameter_values(model)
    varying = {m.name for m in per_sample}

    builder = _Builder(model, ts, window, values, varying)
    for s in signal_names:
        builder.signal(s, orders[s])
    kernels = []
    for r, arr, unit, eps in zip(residuals, monitor.arrs, monitor.units, thresholds):
        expr = builder.numeric(r, f"{arr.name}")
        body = _body(expr, builder, f"{where}: {arr.name}")
        shown = evaluated_form(model, arr)
        what = (f"the AGARR of sensor {arr.sensor}" if arr.origin == "SCAPH" and arr.sensor else
                f"the MSO residual at junction {arr.junction} (sensors {arr.sensor})")
        if arr.name in config.mode_thresholds:          # fdi.mode_thresholds: the function divides it
            what += ", divided by its threshold in each mode (thresholds by mode; judged against 1)"
        kernels.append(Kernel(arr.name, what, unit, float(eps), sp.sstr(shown), body))
    take, take_helpers, modes = _take(model, column_index, builder, per_sample)
    channels = tuple(builder.channels)
    deepest = max(c.orders for c in channels)
    if deepest > MAX_ORDER:
        raise CodegenError(f"{where}: a residual needs the derivative of order {deepest} of a signal; the generated "
                           f"filter goes to order {MAX_ORDER}")
    lag = max(c.lag for c in channels)
    slow = max((4 * c.n if (c.kind == "signal" and piecewise) else c.n) for c in channels)
    worst = _worst_lag(channels, slow)
    ring = 1 << max(4, math.ceil(math.log2(2 * (worst + max(c.n for c in channels) + 2))))
    if ring > MAX_RING:
        raise CodegenError(f"{where}: the derivative window ({window:g} s) is {max(c.n for c in channels)} samples "
                           f"at {ts:g} s: the monitor would hold {ring} samples per signal; sample slower or "
                           "shorten diagnosis.derivative_window")
    return Plan(model.name, prefix_for(model, prefix), ts, window, wait, float(persistence), float(span),
                evidence_samples(span, ts), float(settle), scales.end_edge(window), tuple(columns), channels,
                len(signal_names), take, take_helpers, tuple(modes), tuple(builder.parameters()), tuple(kernels),
                ring, lag, switch_samples(model, ts) if piecewise else 0)


def _worst_lag(channels: tuple[Channel, ...], signal_lag: int) -> int:
    """The most samples by which a channel's final values can trail the newest sample: a signal's
    at a stretch's start (four windows with mode switches, one without), plus a window per
    stored quantity it feeds."""
    worst: list[int] = []
    for c in channels:
        if c.kind == "signal":
            worst.append(signal_lag)
        else:
            worst.append(max([worst[i] for i in c.inputs] or [0]) + c.n)
    return max(worst)


def _columns(model: Model) -> tuple[list[Column], dict[str, int]]:
    """The sample's values: t, then every column the model reads, in the file's column order."""
    needed: dict[str, str] = {}
    for s in model.sensors.values():
        for x in sorted(s.signal.free_symbols, key=lambda x: x.name):
            unit = s.unit if s.signal == x else "?"
            needed.setdefault(x.name, f"{unit}|sensor {s.name} = {sp.sstr(s.signal)}")
    for i in model.inputs.values():
        if i.column:
            needed[i.column] = f"{i.unit}|input {i.name}"
    for m in model.modes.values():
        if m.column:
            needed[m.column] = f"0/1|command of mode {m.name} (1 from 0.5 up)"
    needed.pop("t", None)
    order = [c for c in model.columns if c in needed] + sorted(c for c in needed if c not in model.columns)
    columns = [Column("t", "s", "time")] + [Column(c, *needed[c].split("|", 1)) for c in order]
    return columns, {c.name: i for i, c in enumerate(columns)}


class _Builder:
    """Channels, parameters and the symbols of the residual kernels, made as the kernels are
    translated. Every value a kernel reads becomes a sympy symbol named as the C expression that
    reads it (``s_theta1_d1``, ``p->k1``, ``q0``): the expressions then hold no symbol of the
    model's, and their common subexpressions come out in the same order on every run."""

    def __init__(self, model: Model, ts: float, window: float, values: Mapping[str, object], varying: set[str]):
        self.model, self.ts, self.window, self.values, self.varying = model, ts, window, values, varying
        self.channels: list[Channel] = []
        self.by_signal: dict[str, int] = {}
        self.by_stored: dict[object, int] = {}
        self.symbols: dict[tuple, sp.Symbol] = {}
        self.names: dict[sp.Symbol, str] = {}
        self.loads: dict[sp.Symbol, str] = {}          # a local's load statement
        self.channel_of: dict[sp.Symbol, int] = {}
        self.fields: dict[str, str] = {}               # parameter name -> struct field
        self.taken: set[str] = set()
        self.locals: set[str] = {"v", "p"}
        self.mode_index = {m.name: i for i, m in enumerate(m for m in model.modes.values()
                                                              if m.column or m.autonomous)}

    def _symbol(self, key: tuple, c_text: str, load: str | None = None, channel: int | None = None) -> sp.Symbol:
        sym = sp.Symbol(c_text, real=True)
        self.symbols[key] = sym
        self.names[sym] = c_text
        if load is not None:
            self.loads[sym] = load
        if channel is not None:
            self.channel_of[sym] = channel
        return sym

    def _channel(self, name: str, kind: str, orders: int, unit: str, inner: Body | None = None,
                 inputs: tuple[int, ...] = ()) -> int:
        p = max(derivatives.DEFAULT_ORDER, orders)
        n = derivatives.window_samples(self.window, self.ts, p)
        out = sum(c.orders + 1 for c in self.channels)
        lag = n // 2 + max([self.channels[i].lag for i in inputs] or [0])
        self.channels.append(Channel(name, kind, orders, n, p, out, unit, inner, inputs, lag))
        return len(self.channels) - 1

    def signal(self, name: str, orders: int) -> None:
        unit = self.model.sensors[name].unit if name in self.model.sensors else self.model.inputs[name].unit
        self.by_signal[name] = self._channel(name, "signal", orders, unit)

    def signal_symbol(self, name: str, order: int) -> sp.Symbol:
        key = ("signal", name, order)
        if key in self.symbols:
            return self.symbols[key]
        channel = self.by_signal[name]
        c = self.channels[channel]
        local = identifier(f"s_{identifier(name)}" + (f"_d{order}" if order else ""), self.locals)
        what = f"d{order}/dt{order} " if order > 1 else "d/dt " if order == 1 else ""
        unit = c.unit + ("/s" if order == 1 else f"/s^{order}" if order > 1 else "")
        load = f"const double {local} = v[{c.out + order}];   /* {comment(what + name, 60)} ({comment(unit, 30)}) */"
        return self._symbol(key, local, load, channel)

    def sample_symbol(self, name: str) -> sp.Symbol:
        """Signal ``name`` as sampled (a stored quantity's input): the runtime gathers it after the
        modes, in channel order, for the stored quantities' kernels only; it waits for no filter."""
        key = ("sample", name)
        if key in self.symbols:
            return self.symbols[key]
        c = self.channels[self.by_signal[name]]
        local = identifier(f"x_{identifier(name)}", self.locals)
        load = (f"const double {local} = v[OUTPUTS + MODES_N + {self.by_signal[name]}];   "
                f"/* {comment(name, 60)} as sampled ({comment(c.unit, 30)}) */")
        return self._symbol(key, local, load)

    def mode_symbol(self, name: str) -> sp.Symbol:
        key = ("mode", name)
        if key in self.symbols:
            return self.symbols[key]
        local = identifier(f"m_{identifier(name)}", self.locals)
        load = (f"const double {local} = v[OUTPUTS + {self.mode_index[name]}];   "
                f"/* mode {comment(name, 60)} at this sample (0 or 1) */")
        return self._symbol(key, local, load)

    def parameter_symbol(self, name: str) -> sp.Symbol:
        key = ("parameter", name)
        if key in self.symbols:
            return self.symbols[key]
        self.fields[name] = identifier(name, self.taken)
        return self._symbol(key, f"p->{self.fields[name]}")

    def stored_symbol(self, order: int, channel: int, label: str) -> sp.Symbol:
        key = ("stored", channel, order)
        if key in self.symbols:
            return self.symbols[key]
        c = self.channels[channel]
        first = sum(1 for x in self.channels if x.kind == "signal")
        local = identifier(f"rate{channel - first}" + ("" if order == 1 else f"_d{order}"), self.locals)
        rate = "d/dt" if order == 1 else f"d{order}/dt{order}"
        load = f"const double {local} = v[{c.out + order}];   /* {rate} of {comment(label, 70)} */"
        return self._symbol(key, local, load, channel)

    def numeric(self, r: Residual, label: str, measured: bool = False) -> sp.Expr:
        """The kernel of ``r`` with every signal, derivative, stored rate, mode and parameter as a
        symbol of this builder (the arguments :func:`fdi.residuals._compile` lambdifies over);
        ``measured``: a stored quantity's, whose signals are read as sampled, not smoothed
        (:class:`fdi.residuals.Estimates`)."""
        expr = r.expr
        stored = {}
        for i, (order, inner) in enumerate(r.composites):
            shown = sp.sstr(shown_form(inner))
            channel = self.stored(inner, order, f"stored quantity {shown}")
            stored[sp.Symbol(f"__stored{i}", real=True)] = self.stored_symbol(order, channel, shown)
        replace: dict[sp.Expr, sp.Expr] = {}
        for d in sorted(expr.atoms(sp.Derivative), key=sp.srepr):     # in one order: the same C every run
            if not is_signal(d.expr) or d.expr.func.__name__ not in self.by_signal:
                raise CodegenError(f"{label}: cannot evaluate the derivative {sp.sstr(d)} numerically")
            order = sum(c for v, c in d.variable_count if v == TIME)
            replace[d] = self.signal_symbol(d.expr.func.__name__, order)
        read = self.sample_symbol if measured else (lambda name: self.signal_symbol(name, 0))
        plain = {fn: read(fn.func.__name__) for fn in sorted(expr.atoms(sp.core.function.AppliedUndef), key=sp.srepr)
                 if fn.func.__name__ in self.by_signal}
        # derivatives first, so that theta1(t) inside Derivative(theta1(t), t) is not replaced
        expr = expr.xreplace(replace).xreplace(plain).xreplace(stored)
        rest = {}
        for s in sorted(expr.free_symbols, key=lambda x: x.name):
            if s in self.names:
                continue
            if s.name in self.varying:
                rest[s] = self.mode_symbol(s.name)
            elif s.name in self.values:
                rest[s] = self.parameter_symbol(s.name)
            else:
                raise CodegenError(f"{label}: no value for {s.name}")
        return expr.xreplace(rest)

    def stored(self, inner: Residual, order: int, label: str) -> int:
        """The channel filtering ``inner`` (a stored quantity) for its ``order``-th rate, made once."""
        key = (_structure(inner), order)
        if key in self.by_stored:
            return self.by_stored[key]
        body = _body(self.numeric(inner, label, measured=True), self, label)
        inputs = sorted({self.channel_of[s] for s in body.reads if s in self.channel_of})
        index = self._channel(label, "stored", order, "", body, tuple(inputs))
        self.by_stored[key] = index
        return index

    def parameters(self) -> list[Parameter]:
        out = []
        for name, field in self.fields.items():
            value = float(np.asarray(self.values[name], dtype=float))
            if name in self.model.parameters:
                unit = self.model.parameters[name].unit
                note = f"parameter{' (' + unit + ')' if unit else ''}"
            elif name in self.model.modes:
                note = "mode variable (0 or 1), not read per sample: its nominal value"
            else:
                note = "efficiency factor"
            out.append(Parameter(name, field, value, note))
        return out


def shown_form(r: Residual) -> sp.Expr:
    """``r``'s expression with the rate of each stored quantity inside it written out
    (``Derivative(CT1*p1(t), t)`` for the placeholder the compiled kernel reads)."""
    return r.expr.xreplace({sp.Symbol(f"__stored{i}", real=True): sp.Derivative(shown_form(inner), (TIME, order))
                            for i, (order, inner) in enumerate(r.composites)})


def _structure(r: Residual) -> tuple:
    """A stored quantity's identity: its expression and those of the stored quantities inside it."""
    return (sp.srepr(r.expr),) + tuple((order, _structure(inner)) for order, inner in r.composites)


def _body(expr: sp.Expr, builder: _Builder, label: str) -> Body:
    """The C statements of one kernel: the loads of the gathered values it reads, then its expression."""
    try:
        body = c_function_body(expr, builder.names)
    except CodegenError as exc:
        raise CodegenError(f"{label} uses {exc}, which the C generator does not translate (C99 has no such "
                           "function, or its C counterpart computes something else than numpy's); rewrite the "
                           "model's law without it to generate C") from None
    loads = tuple(builder.loads[s] for s in sorted(body.reads, key=lambda s: builder.names[s]) if s in builder.loads)
    return Body(loads + body.lines, body.helpers, body.reads)


def _take(model: Model, index: dict[str, int], builder: _Builder,
          per_sample: list) -> tuple[tuple[str, ...], frozenset[str], list[Mode]]:
    """C statements filling ``x`` (each signal channel's value) and ``mode`` (each per-sample mode)
    from one sample ``col``, as :func:`fdi.data.signals_from_data` computes them from a row:
    sensors from their columns, inputs from theirs (or their expression of t at nominal values),
    commanded modes from their command, autonomous modes from their condition on those."""
    where = model.path or model.name
    helpers: set[str] = set()
    taken: set[str] = set()
    local: dict[str, str] = {}
    nominal = dict(model.nominal_values())
    wanted = {c.name for c in builder.channels if c.kind == "signal"}
    for m in per_sample:
        if m.positive is not None:
            wanted |= {s.name for s in m.positive.free_symbols}

    def of_columns(expr: sp.Expr) -> dict[sp.Symbol, str]:
        out = {}
        for s in sorted(expr.free_symbols, key=lambda x: x.name):
            if s.name not in index:
                raise CodegenError(f"{where}: {s.name} is no column of the data; the generated code cannot read it")
            out[s] = f"col[{index[s.name]}]"
        return out

    def of_signals(expr: sp.Expr) -> dict[sp.Symbol, str]:
        out = {}
        for s in sorted(expr.free_symbols, key=lambda x: x.name):
            if s.name in local:
                out[s] = local[s.name]
            elif s.name in builder.values:
                out[s] = builder.names[builder.parameter_symbol(s.name)]
            else:
                raise CodegenError(f"{where}: no value for {s.name} in the generated code")
        return out

    lines: list[str] = []

    def assign(name: str, expr: sp.Expr, names: dict, what: str, base: str | None = None) -> None:
        local[name] = identifier("y_" + (base or identifier(name)), taken)
        body = c_function_body(expr, names, target=f"const double {local[name]}")
        helpers.update(body.helpers)
        lines.append(f"/* {comment(what, 100)} */")
        if len(body.lines) > 1:                 # common subexpressions: their own block
            lines.append(f"double {local[name]};")
            inner = c_function_body(expr, names, target=local[name])
            lines.extend(["{"] + ["    " + x for x in inner.lines] + ["}"])
        else:
            lines.extend(body.lines)

    for s in model.sensors.values():
        if s.name in wanted:
            assign(s.name, s.signal, of_columns(s.signal), f"sensor {s.name} ({s.unit}) = {sp.sstr(s.signal)}")
    for i in model.inputs.values():
        if i.name not in wanted:
            continue
        if i.column:
            expr = sp.Symbol(i.column)
            assign(i.name, expr, of_columns(expr), f"input {i.name} ({i.unit}): column {i.column}")
        else:
            expr = i.expr.xreplace(nominal) if i.expr is not None else sp.Float(0.0)
            assign(i.name, expr, of_columns(expr), f"input {i.name} ({i.unit}) = {sp.sstr(i.expr)}, nominal values")
    for m in per_sample:                  # commands first: a condition may read them, as in fdi.data
        if m.column:
            lines.append(f"/* mode {comment(m.name, 40)}: its command, column {comment(m.column, 40)}, 1 from 0.5 up */")
            local[m.name] = identifier("y_" + identifier(m.name), taken)
            lines.append(f"const double {local[m.name]} = col[{index[m.column]}] >= 0.5 ? 1.0 : 0.0;")
    for m in per_sample:
        if not m.column:
            assign(m.name, m.positive, of_signals(m.positive), f"mode {m.name}: 1 while {sp.sstr(m.positive)} > 0",
                   base=f"{identifier(m.name)}_condition")
    modes = []
    for k, m in enumerate(per_sample):
        lines.append(f"mode[{k}] = {local[m.name]};" if m.column else f"mode[{k}] = {local[m.name]} > 0.0 ? 1.0 : 0.0;")
        modes.append(Mode(m.name, index[m.column] if m.column else None))
    for c, ch in enumerate(builder.channels):
        if ch.kind == "signal":
            lines.append(f"x[{c}] = {local[ch.name]};")
    return tuple(lines), frozenset(helpers), modes


def generate(monitor, ts: float | None = None, options=None, prefix: str | None = None,
             lang: str = "c") -> dict[str, str]:
    """The files of the generated monitor by name (the header, the monitor, ``main.c``, the
    Makefile); the arguments as :func:`plan`'s.

    >>> files = generate("models/cycab_steering.yaml")
    >>> sorted(files)
    ['Makefile', 'bgfdi_cycab_steering.c', 'bgfdi_cycab_steering.h', 'main.c']
    >>> "#define BGFDI_CYCAB_STEERING_LAG 12" in files["bgfdi_cycab_steering.h"]
    True
    """
    if lang not in LANGUAGES:
        raise CodegenError(f"--lang: must be one of {', '.join(LANGUAGES)}, got {lang!r}")
    from .codegen_c import render
    return render(plan(monitor, ts, options, prefix))


def write_folder(files: Mapping[str, str], folder: str | Path) -> list[Path]:
    """Write ``files`` into ``folder``: a new folder is made complete under a temporary name and
    renamed into place (all or nothing); in an existing folder each file is replaced atomically
    (:func:`fdi.atomic.write_atomic`) once every file has been generated."""
    from .atomic import OutputError, write_atomic
    folder = Path(folder)
    if folder.exists():
        for name, text in files.items():
            write_atomic(folder / name, text)
        return [folder / n for n in files]
    tmp = Path(tempfile.mkdtemp(prefix=f".{folder.name}.", suffix=".part", dir=folder.parent))
    try:
        os.chmod(tmp, 0o777 & ~_umask())
        for name, text in files.items():
            with open(tmp / name, "w", encoding="utf-8", newline="\n") as fh:
                fh.write(text)
            os.chmod(tmp / name, 0o666 & ~_umask())
        os.rename(tmp, folder)
    except OSError as exc:
        raise OutputError(f"-o: cannot write folder '{folder}' ({exc.strerror or exc}); choose another") from None
    finally:
        if tmp.exists():
            for p in tmp.iterdir():
                p.unlink()
            tmp.rmdir()
    return [folder / n for n in files]


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask

