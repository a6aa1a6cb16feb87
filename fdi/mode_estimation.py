"""The fault-mode estimator (Sec. III-C): which mode variables the data say changed.

The MCSM names the suspected mode variables; a binary differential evolution (``optim.bde``)
searches their values with the cost of eq. (24), the others keeping their current values.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from bondgraph.model import Model
from optim import bde

from .data import commanded
from .objective import Window
from .residuals import Residual, corrected_signals, derivative_orders, parameter_values

MODE_TABLE = 4     # suspected mode variables up to which every combination's cost is reported (16 rows)


@dataclass(frozen=True)
class ModeEstimate:
    """The fault-mode estimator's answer: every mode variable's estimated value, its cost, and
    (for at most MODE_TABLE suspected variables) the cost of every combination of them, the
    evidence behind the estimate (plotted as the paper's Fig. 8)."""
    mode: dict[str, int]
    cost: float
    table: list[dict]


def estimate_mode(model: Model, residuals: tuple[Residual, ...], win: Window, weights: np.ndarray,
                  seed: int, window_s: float, variables: list[str] | None = None,
                  modes: dict[str, float] | None = None) -> ModeEstimate:
    """The fault-mode estimator: BDE over the suspected mode variables (Sec. III-C: the MCSM names
    them; the others keep their current values), same cost as eq. (24)."""
    names = list(variables or model.modes)
    nominal = parameter_values(model)
    nominal.update(commanded(model, win.raw))        # commanded modes follow their command sample by sample
    nominal.update(modes or {})                      # the mode variables the caller knows
    signals = corrected_signals(model, win.raw, win.ts, derivative_orders(list(residuals)), None, window_s)
    c = win.crop
    # the mode each variable should be in: the command at the window's start, or the nominal mode
    current = {m: int(np.asarray(nominal[m]).reshape(-1)[c.start]) if np.ndim(nominal[m]) else int(nominal[m])
               for m in model.modes}                # a mode the caller fixed (Options.mode) is that mode

    def cost(real: np.ndarray, bits: np.ndarray) -> np.ndarray:
        values = dict(nominal)
        for j, n in enumerate(names):
            values[n] = bits[:, j:j + 1].astype(float)
        total = np.zeros(bits.shape[0])
        for i, r in enumerate(residuals):
            out = np.broadcast_to(np.asarray(r(signals, values, win.ts, window_s), dtype=float),
                                  (bits.shape[0], win.t.size))
            total += weights[i] * np.abs(out[:, c]).sum(axis=1)
        return total
    r = bde.minimize(cost, len(names), pop=max(8, 4 * len(names)), generations=20, seed=seed)
    # a mode variable the data cannot see (a2 once a burnt driver has stopped the motor) is put back:
    # one fault mode at a time, as the paper assumes, unless the data need more (cost within 1 %)
    best = r.bits.copy()
    best_cost = float(r.cost)
    for j in range(len(names)):
        if best[j] != bool(current[names[j]]):
            trial = best.copy()
            trial[j] = bool(current[names[j]])
            trial_cost = float(cost(np.zeros((1, 0)), trial[None, :])[0])
            if trial_cost <= 1.01 * best_cost:
                best, best_cost = trial, min(best_cost, trial_cost)
    current.update({n: int(b) for n, b in zip(names, best)})
    table = []
    if len(names) <= MODE_TABLE:
        combos = np.array(list(itertools.product((0, 1), repeat=len(names))), dtype=bool)
        table = [{"mode": {n: int(v) for n, v in zip(names, row)}, "cost": float(c)}
                 for row, c in zip(combos, cost(np.zeros((len(combos), 0)), combos))]
    return ModeEstimate(current, best_cost, table)
