"""Residuals of a stream from carried filter state: each sample's residual computed once.

The Savitzky-Golay derivative (:mod:`fdi.derivatives`) is a centred FIR filter of n samples; its
state is the last n - 1 samples it read. A stream that brings its residuals up to date every block
of rows keeps those samples (the stream's buffer does) and asks the filter only for the samples
that became final since the last block (``at=`` of :func:`fdi.derivatives.estimate`, ``crop=`` of
the residual kernels): the samples before them are read, never filtered again. The monitor's
first version re-filtered a margin of two windows and the lag on every block (a block of 50 rows
filtered ~150 rows, each with its edge fits); this module filters each sample once, so a block of
any size costs its own rows plus a fixed per-call overhead.

The numbers are those of the whole record (:func:`fdi.residuals.evaluate`) to round-off: each
sample's derivative is the same kernel over the same n samples, the record's first samples by the
same edge fit. Models whose residuals differentiate a stored quantity (``composites``) or whose
modes switch inside the record (command columns, autonomous modes: the filter restarts at every
switch) take the whole-segment path, with a margin of two windows before the first sample asked
for, as before.

>>> import numpy as np
>>> from bondgraph.examples import rc_parallel
>>> from fdi.data import Measurements, signals_from_data
>>> from fdi.residuals import compile_residuals, evaluate
>>> from fdi.scaph import derive_arrs
>>> m = rc_parallel()
>>> kernels = compile_residuals(m, derive_arrs(m))
>>> t = np.arange(0.0, 1.0, 0.001)
>>> v = 2 + np.sin(2 * np.pi * t)
>>> table = np.column_stack([t, 1e-3 * 2 * np.pi * np.cos(2 * np.pi * t) + v / 50, v])
>>> carried = Carried(m, kernels, 0.05, ["t", "i_in", "v"])
>>> whole = evaluate(m, kernels, signals_from_data(m, Measurements("x", t, {"t": t, "i_in": table[:, 1], "v": v})),
...                  0.001, window=0.05)
>>> lo = 500 - carried.behind(0.001)                       # the carried samples, then 100 new ones
>>> part = carried(table[lo:700], 0.001, 500 - lo, 600 - lo)
>>> bool(np.allclose(part, whole[:, 500:600], rtol=1e-12, atol=1e-15))
True
"""
from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from bondgraph.model import Model

from . import derivatives
from .data import Measurements, commanded, signals_from_data
from .residuals import SHORT_STRETCH, Residual, corrected_signals, derivative_orders, evaluate, parameter_values


class Carried:
    """The residuals of ``kernels`` on rows of a stream (columns of ``header``), computed only
    at the samples asked for. ``mode``: values that override the model's (``--mode``)."""

    def __init__(self, model: Model, kernels: list[Residual], window: float, header: list[str],
                 mode: Mapping[str, float] | None = None, source: str = "<stream>") -> None:
        self.model, self.kernels, self.window, self.header, self.source = model, list(kernels), window, list(header), source
        self.mode = {k: float(v) for k, v in (mode or {}).items()}
        self.orders = derivative_orders(self.kernels)
        self.cropped = not any(r.composites for r in self.kernels) and \
            not any(m.column or m.autonomous for m in model.modes.values())
        self.constants = parameter_values(model, self.mode)     # nominal values, once (not per block)
        self.ti = self.header.index("t")
        self._behind: dict[float, int] = {}

    def behind(self, ts: float) -> int:
        """Samples before the first one asked for that the filters read (their carried state):
        half the longest derivative window, or on the whole-segment path two windows and a sample
        and the fast-switching bound (:meth:`tail`): a stretch cut by the segment's start looked
        short, and its samples before the next switch were left out where the file's long stretch
        keeps them."""
        known = self._behind.get(ts)
        if known is not None:
            return known
        if not self.cropped:
            out = 2 * (int(math.ceil(self.window / ts)) + 1) + self.tail(ts)
        else:
            out = self._longest(ts) // 2 if self.orders else 0
        if len(self._behind) > 64:                  # a stream's sampling time is one number, give or take round-off
            self._behind.clear()
        self._behind[ts] = out
        return out

    def __call__(self, table: np.ndarray, ts: float, lo: int, hi: int) -> np.ndarray:
        """(residuals, hi - lo): the residuals at rows [lo, hi) of ``table`` (rows x columns of the
        header: the carried rows, then the new ones, up to half a window past ``hi``). The first
        row of ``table`` is the record's first, or at least :meth:`behind` rows before ``lo``."""
        seg = Measurements(self.source, table[:, self.ti], {h: table[:, i] for i, h in enumerate(self.header)})
        raw = signals_from_data(self.model, seg)
        modes = commanded(self.model, raw)
        if not self.cropped:
            r = evaluate(self.model, self.kernels, raw, ts, window=self.window, values={**modes, **self.mode})
            return np.asarray(r)[:, lo:hi]
        values = {**self.constants, **modes, **self.mode}
        out = np.empty((len(self.kernels), hi - lo))
        if lo < self.behind(ts):                  # the record's first samples: the filter's edge fit
            at = slice(lo, hi)
            sig = corrected_signals(self.model, raw, ts, self.orders, window=self.window, at=at)
            for row, r in zip(out, self.kernels):
                row[:] = r(sig, values, ts, self.window, crop=at)
            return out
        sig = {name: filtered(np.asarray(raw[name], dtype=float), ts, order, self.window, lo, hi)
               for name, order in self.orders.items()}
        for row, r in zip(out, self.kernels):
            row[:] = r(sig, values, ts, self.window)
        return out

    def tail(self, ts: float) -> int:
        """SHORT_STRETCH of the longest filter windows and one: the rows that tell whether the
        stretch before a switch is a long one, whose samples up to the switch the file keeps
        (one-sided fits), or a short one (half a window left out)."""
        return SHORT_STRETCH * self._longest(ts) + 1

    def _longest(self, ts: float) -> int:
        """The longest filter window in samples over the derivative orders the kernels take."""
        return max(derivatives.window_samples(self.window, ts, max(derivatives.DEFAULT_ORDER, k))
                   for k in [0, *self.orders.values()])


def filtered(x: np.ndarray, ts: float, order: int, window: float, lo: int, hi: int) -> list[np.ndarray]:
    """[x, dx/dt, ..., d^order x/dt^order] at samples [lo, hi) of ``x``, each sample's whole window
    inside ``x``: the Savitzky-Golay kernels of :func:`fdi.derivatives.centred` applied by
    :func:`fdi.derivatives.fir`, as :func:`fdi.derivatives.estimate` does: each sample's taps
    summed in the same fixed order, so the whole record's numbers bit for bit (a Coulomb
    friction's sign(dθ/dt) of an encoder standing still, a derivative of exactly 0 give or take
    round-off, would otherwise flip a residual by its full term).

    >>> t = np.arange(0.0, 1.0, 0.01)
    >>> x, v = filtered(t ** 3, 0.01, 1, 0.1, 5, 95)
    >>> bool(np.allclose(v, 3 * t[5:95] ** 2))
    True
    """
    p = max(derivatives.DEFAULT_ORDER, order)
    n = derivatives.window_samples(window, ts, p)
    half = n // 2
    if lo < half or hi + half > x.shape[-1]:
        raise ValueError(f"samples [{lo}, {hi}) need {half} samples either side; {x.shape[-1]} given")
    out = derivatives.fir(x, derivatives.centred(n, p, order, float(ts)), lo - half, hi - lo)
    return [out[:, k] for k in range(order + 1)]
