"""The fault-mode estimator (Sec. III-C): which mode variables the data say changed.

The MCSM names the suspected mode variables; a binary differential evolution (``optim.bde``)
searches their values with the cost of eq. (24), the others keeping their current values.

A mode hypothesis may switch a residual off: a residual that holds in one mode only (its mode's
indicator times its relation, :func:`fdi.modewise.complete_by_mode`) is identically zero in the
others. Eq. (24) would then charge nothing for it, so switching it off explains any excursion of
it for free, its noise included. Each such sample (zero under the hypothesis, not under the data's
own modes) is charged the residual's noise floor instead: what the residual costs a sample where
it holds (:func:`noise_floors <fdi.pipeline.noise_floors>`, measured before the detection).
Measured on a user's e-bike freewheel (stiffness k_f 100 -> 50 while engaged, its relation c * ARR3,
a 25 ms derivative window): the freewheel free (c = 0) cost 393 against the k_f fit's 521, its
relation's cost dropped to 0; charged, 509. It still wins there: halving k_f doubles the noise
of the relation's T'/k_f term, which eq. (24) does not expect (at the 0.3 s window k_f wins).
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import Iterable

import numpy as np

from bondgraph.model import Model
from optim import bde
from optim.core import fitness

from .data import commanded
from .objective import Objective, Window, window_gaps
from .residuals import Residual, corrected_signals, derivative_orders, parameter_values
from . import derivatives, results
from .results import Estimate

MODE_TABLE = 4     # suspected mode variables up to which every combination's cost is reported and the estimate read
                   # from it (16 rows; 81 with four commanded to switch, each also as commanded)
COMMANDED = results.COMMANDED   # the table's value of a variable commanded to switch that follows its command


@dataclass(frozen=True)
class ModeEstimate:
    """The fault-mode estimator's answer: every mode variable's estimated value, its cost, and
    (for at most MODE_TABLE suspected variables) the cost of every combination of them, the
    evidence behind the estimate (plotted as the paper's Fig. 8)."""
    mode: dict[str, int]
    cost: float
    table: list[dict]
    stuck: tuple[str, ...] = ()          # variables commanded to switch that the data say stayed put
    following: tuple[str, ...] = ()      # variables commanded to switch that follow their command (their
                                         # ``mode`` entry is then the command at the window's start)
    ties: tuple[dict, ...] = ()          # other hypotheses as far from the defaults within 1 % of its cost


def switched_off(hypothesis: np.ndarray, data: np.ndarray, each: bool = False) -> np.ndarray:
    """Per row of ``hypothesis`` (a residual's values under mode hypotheses, rows x samples), how
    many samples it is identically zero where ``data`` (the same residual under the data's own
    modes) is not: the samples the hypothesis switched the residual off (with ``each``, which ones).
    A residual's value from noisy measurements is exactly zero only when a mode indicator multiplies
    it away.

    >>> switched_off(np.array([[0.0, 0.0, 0.3], [0.1, 0.0, 0.4]]), np.array([0.2, 0.0, 0.3]))
    array([1, 0])
    """
    data = np.asarray(data, dtype=float)
    off = (np.asarray(hypothesis) == 0) & (data != 0) & np.isfinite(data)
    return off if each else off.sum(axis=-1)


def samples_of(value, n: int) -> np.ndarray:
    """A residual's value over ``n`` samples as one row: a (1, n) or (n,) array, or a constant.

    >>> samples_of(2.0, 3).tolist(), samples_of(np.ones((1, 3)), 3).shape
    ([2.0, 2.0, 2.0], (3,))
    """
    a = np.asarray(value, dtype=float)
    if a.size == n:
        return a.reshape(-1)
    if a.size == 1:
        return np.broadcast_to(a.reshape(-1), (n,))
    raise ValueError(f"a residual of {a.size} values on a window of {n} samples")


def off_charge(rows: list[np.ndarray], data: list, floors: np.ndarray | None, weights: np.ndarray,
               each: bool = False) -> np.ndarray | float:
    """What a mode hypothesis's switched-off samples cost (``rows``: each residual's values under the
    hypotheses, rows x samples, or one row; ``data``: the same residuals under the data's own modes):
    each residual's noise floor (its mean |r| where it holds) times its weight on every sample it is
    switched off (:func:`switched_off`), less the same for the residuals the hypothesis switches on
    there (zero under the data's modes, not under the hypothesis: they judge that sample in its
    place), never below 0; summed per row (with ``each``, per sample). A valve stuck soft swaps the
    firm mode's body balance for the soft mode's: charged for the one switched off and not credited
    for the one switched on, it cost 559 against a leak of the firm path at its bound's 385 (a user
    trial's quarter car)."""
    if floors is None:
        return 0.0
    net = 0.0
    for row, d, floor, w in zip(rows, data, floors, weights):
        if d is None or floor is None or not np.isfinite(floor) or floor <= 0:
            continue
        d = np.asarray(d, dtype=float)
        row = np.asarray(row)
        on = (row != 0) & np.isfinite(row) & (d == 0)
        net = net + w * floor * (switched_off(row, d, True).astype(float) - on)
    net = np.maximum(net, 0.0)
    return net if each else np.sum(net, axis=-1)


def estimate_mode(model: Model, residuals: tuple[Residual, ...], win: Window, weights: np.ndarray,
                  seed: int, window_s: float, variables: list[str] | None = None,
                  modes: dict[str, float] | None = None, floors: np.ndarray | None = None,
                  following: Iterable[str] = (), switch_span: int = 0) -> ModeEstimate:
    """The fault-mode estimator over the suspected mode variables (Sec. III-C: the MCSM names
    them; the others keep their current values), same cost as eq. (24), each sample a hypothesis
    switches a residual off charged that residual's noise floor (``floors``, per residual, in its
    own units: the module's docstring). Up to :data:`MODE_TABLE` variables every combination is
    costed (the report's table) and the estimate read from it, the optimum BDE converges to; beyond,
    BDE (Sec. III-C) searches them. Of the hypotheses within 1 % of the best, the one with the
    fewest variables away from their default (their command, or their value at the window's start).

    ``following``: variables commanded to switch within the window (a PWM switch, an ABS valve).
    A value held over the window is then a valve stuck there, not the mode it should be in; the
    mode it should be in is its command, sample by sample, and a held value is reported
    (``ModeEstimate.stuck``) only where it explains the data better than the command does (a
    trial's ABS inlet valve stuck open under a command switching 18 times a second was never
    considered).

    ``switch_span``: a hypothesis may switch in at any of the window's first ``switch_span`` samples
    (the default mode before it), where the evidence allows a fault's onset: its cost is its best
    switch's. Held from the window's start, a relay welded closed 68 s after t_D (a 143 s window's
    look-ahead) cost more than no fault at all, its closed contact contradicting the 68 s of data
    before (a user trial: no diagnosis)."""
    names = list(variables or model.modes)
    follow_all = frozenset(following) & set(names)
    nominal = parameter_values(model)
    nominal.update(commanded(model, win.raw))        # commanded modes follow their command sample by sample
    nominal.update(modes or {})                      # the mode variables the caller knows
    signals = corrected_signals(model, win.raw, win.ts, derivative_orders(list(residuals)), None, window_s)
    c = win.crop
    # the mode each variable should be in: the command at the window's start, or the nominal mode
    current = {m: int(np.asarray(nominal[m]).reshape(-1)[c.start]) if np.ndim(nominal[m]) else int(nominal[m])
               for m in model.modes}                # a mode the caller fixed (Options.mode) is that mode

    gaps = window_gaps(model, residuals, win, signals, window_s)[c]    # samples no hypothesis is judged on
    data = [None] * len(residuals)
    if floors is not None:               # each residual under the data's own modes: where it holds
        data = [np.where(gaps, np.nan, samples_of(r(signals, nominal, win.ts, window_s), win.t.size)[c])
                for r in residuals]      # (a gap is judged for no hypothesis: charged for none)

    def cost(real: np.ndarray, bits: np.ndarray, follow: frozenset = frozenset(), each: bool = False) -> np.ndarray:
        """Each row's cost; with ``each``, per sample (rows x samples)."""
        values = dict(nominal)
        for j, n in enumerate(names):
            if n not in follow:          # (a variable that follows keeps its command)
                values[n] = bits[:, j:j + 1].astype(float)
        total = np.zeros((bits.shape[0], c.stop - c.start) if each else bits.shape[0])
        outs = []
        for i, r in enumerate(residuals):
            out = np.broadcast_to(np.asarray(r(signals, values, win.ts, window_s), dtype=float),
                                  (bits.shape[0], win.t.size))[:, c]
            if gaps.any():               # (a switching command leaves a gap at each switch: NaN there)
                out = np.where(gaps, 0.0, out)
            total += weights[i] * (np.abs(out) if each else np.abs(out).sum(axis=1))
            outs.append(out)
        return total + off_charge(outs, data, floors, weights, each)
    # each variable's value when it is not at fault: its command (one that switches within the window:
    # followed sample by sample), else its value at the window's start
    default = {n: COMMANDED if n in follow_all else current[n] for n in names}

    span = min(int(switch_span), c.stop - c.start - 1)

    def costs(rows: list[tuple]) -> np.ndarray:
        """The cost of each row (a value per variable of ``names``: 0, 1 or COMMANDED), switched in
        at its best sample of the first ``span`` (the default row before it)."""
        out = np.empty(len(rows))
        groups: dict[frozenset, list[int]] = {}
        first = tuple(default[n] for n in names)
        every = list(rows) + [first] if span > 0 else list(rows)
        for k, row in enumerate(every):
            groups.setdefault(frozenset(n for n, v in zip(names, row) if v == COMMANDED), []).append(k)
        per = np.empty((len(every), c.stop - c.start)) if span > 0 else None
        whole = np.empty(len(every))
        for follow, ks in groups.items():          # one vectorised call per set of variables that follow
            bits = np.array([[v == 1 for v in every[k]] for k in ks], dtype=bool)
            if per is None:
                whole[ks] = cost(np.zeros((len(ks), 0)), bits, follow)
            else:
                per[ks] = cost(np.zeros((len(ks), 0)), bits, follow, each=True)
        if per is None:
            return whole[:len(rows)]
        # switched at sample k: the default's samples before k, the row's from k on (k = 0: held throughout)
        before = np.concatenate([[0.0], np.cumsum(per[-1])[:span]])
        for k in range(len(rows)):
            after = per[k].sum() - np.concatenate([[0.0], np.cumsum(per[k])[:span]])
            out[k] = float(np.min(before + after))
        return out

    table = []
    if len(names) <= MODE_TABLE:
        # every combination (a variable commanded to switch also as commanded): the estimate is read from
        # the table, the optimum BDE converges to, with no search noise
        rows = list(itertools.product(*[(0, 1, COMMANDED) if n in follow_all else (0, 1) for n in names]))
        row_costs = costs(rows)
        table = [{"mode": dict(zip(names, row)), "cost": float(c)} for row, c in zip(rows, row_costs)]
    else:
        r = bde.minimize(cost, len(names), pop=max(8, 4 * len(names)), generations=20, seed=seed)
        best = tuple(int(b) for b in r.bits)
        rows = [best] + [tuple(default[n] if k == j else v for k, (n, v) in enumerate(zip(names, best)))
                         for j in range(len(names))]
        rows.append(tuple(default[n] for n in names))
        row_costs = costs(rows)
    # a mode variable the data cannot see (a2 once a burnt driver has stopped the motor) is put back, and
    # one commanded to switch follows its command: of the rows within 1 % of the best, the one with the
    # fewest variables away from their default (one fault mode at a time, as the paper assumes, unless the
    # data need more), the cheapest of those; its own cost is the estimate's
    finite = np.isfinite(row_costs)
    if not finite.any():
        return ModeEstimate(current, float("inf"), table)
    lowest = float(row_costs[finite].min())
    near = [k for k in range(len(rows)) if finite[k] and row_costs[k] <= 1.01 * lowest]
    away = [frozenset(n for n, v in zip(names, rows[k]) if v != default[n]) for k in range(len(rows))]
    pick = min(near, key=lambda k: (len(away[k]), row_costs[k]))
    chosen = dict(zip(names, rows[pick]))
    current.update({n: int(v) for n, v in chosen.items() if v != COMMANDED})
    # as many variables away from their default, other ones, within 1 %: the data hardly tell them apart
    ties = tuple(dict(zip(names, rows[k])) for k in near
                 if away[pick] and len(away[k]) == len(away[pick]) and away[k] != away[pick])
    return ModeEstimate(current, float(row_costs[pick]), table,
                        tuple(n for n in names if n in follow_all and chosen[n] != COMMANDED),
                        tuple(n for n in names if chosen[n] == COMMANDED), ties)


def mode_variable(model: Model, name: str) -> str:
    """The mode variable of a mode fault (or of a mode change named by its variable)."""
    f = model.faults.get(name)
    return f.targets[0] if f is not None and f.kind == "mode" else name


def mode_values(model: Model, win: Window, mode_faults: list[dict], modes: dict[str, float] | None = None,
                seen: tuple[float, frozenset[str]] | None = None) -> dict:
    """Mode variables over the window with mode faults switched in: each variable keeps its value
    (commanded sample by sample, fixed by the caller, or nominal) before its fault's ``t0`` and the
    fault's value from it, (1, window samples) arrays for the residuals (:class:`fdi.objective.Objective`).

    ``seen`` (the derivative window, s, and the variables every residual reads affinely,
    :func:`affine_modes`): those variables' switches as the filtered residuals see them, blended
    over the filter's window as a held component fault's step is (:func:`fdi.objective.seen_profile`):
    the data's derivative terms spread a switch's effect over the window while a sharp step in the
    mode variable would not, so a mode fault paid a mismatch its component twin did not (a relief
    valve stuck open, its relation h v / Rr, cost 502 against 451 for a leak h / Rleak of the same
    resistance, which won: a user trial)."""
    out: dict = {}
    known = {**commanded(model, win.raw), **(modes or {})}     # a mode the caller fixed wins over its command
    for f in mode_faults:
        var = mode_variable(model, f["name"])
        base = out.get(var, known.get(var, model.modes[var].nominal))
        base = np.broadcast_to(np.asarray(base, dtype=float).reshape(-1), win.t.shape)
        t0, value = float(f.get("t0", -np.inf)), float(f["value"])
        if seen is not None and var in seen[1] and np.isfinite(t0):
            step = derivatives.step_seen(win.t, np.array([t0]), derivatives.STEP_ORDER, seen[0], win.ts)[0]
            out[var] = (base + (value - base) * step)[None, :]
        else:
            out[var] = np.where(win.t >= t0, value, base)[None, :]
    return {**(modes or {}), **out}


_affine: dict[tuple, frozenset[str]] = {}


def affine_modes(model: Model, residuals) -> frozenset[str]:
    """The mode variables every residual reads affinely (a v r1 + r2, as a switch's indicator
    multiplies its relation): their switches may be blended as the filter sees them
    (:func:`mode_values`); one read otherwise (a division by it) is stepped sharply."""
    import sympy as sp
    key = (model.name, tuple(getattr(r, "ident", None) or str(r.expr) for r in residuals))
    if key not in _affine:
        if len(_affine) > 64:
            _affine.clear()
        syms = {m: model.symbols[m] for m in model.modes}
        _affine[key] = frozenset(m for m, x in syms.items()
                                 if all(sp.diff(r.expr, x, 2) == 0 for r in residuals if r.expr.has(x)))
    return _affine[key]


def residual_rows(obj: Objective) -> list[np.ndarray]:
    """Each residual of ``obj`` on its window's samples with no candidate fault (its held faults and
    mode values in): what :meth:`fdi.objective.Objective.constant` sums, residual by residual."""
    return [samples_of(r(obj.base_signals, obj.nominal, obj.win.ts, obj.window_s), obj.win.t.size)[obj.crop()]
            for r in obj.residuals]


def mode_change_fits(monitor, win: Window, weights: np.ndarray, known: list[dict], changes: list[tuple[str, int]],
                     t_change: float, modes: dict[str, float] | None = None,
                     floors: np.ndarray | None = None) -> list:
    """A mode change as a later decision's explanation (the paper's fault-mode estimator, at any
    event): the ``known`` faults held at their fit and each mode fault of ``changes`` (name,
    value) switched in at the onset, searched over t_change +- half a derivative window on a grid
    of samples, that explains the data best. Returns one :class:`fdi.results.Estimate` per change
    (no parameter is identified: its cost is what the information criterion charges nothing for).
    The samples a change switches a residual off cost its noise floor (``floors``: the module's
    docstring)."""
    w = monitor.config.derivative_window
    steps = max(1, int(round(w / 2 / win.ts)))
    grid = t_change + win.ts * np.arange(-steps, steps + 1, max(1, steps // 12))
    out = []
    for name, value in changes:
        cost, onset = switched_at(monitor, win, weights, known, [{"name": name, "type": "mode", "value": int(value)}],
                                  grid, modes, floors)
        fault = {"name": name, "type": "mode", "value": int(value), "t0": onset}
        out.append(Estimate(tuple(g["name"] for g in known) + (name,), cost, float(fitness(cost)), (), None,
                            tuple(known) + (fault,), grid.size, 0.0, 0.0, held=tuple(g["name"] for g in known)))
    return out


def switched_at(monitor, win: Window, weights: np.ndarray, known: list[dict], switches: list[dict], grid: np.ndarray,
                modes: dict[str, float] | None = None, floors: np.ndarray | None = None) -> tuple[float, float]:
    """The cost and onset of the mode faults ``switches`` (name, type mode, value) switched in together at
    the onset of ``grid`` (s) that explains ``win``'s data best, the ``known`` faults held (the first at
    the earliest onset of a tie). A mode fault's onset is searched as a component fault's is: a relief
    valve stuck open from 250 s, detected at 249.2 s (a 5.3 s derivative window's look-ahead), cost 546
    switched from t_D, where a leak of the valve's resistance dated 249.99 s cost 451 and won (a user
    trial). The samples a switch turns a residual off cost its noise floor (``floors``: the module's
    docstring)."""
    model, w = monitor.model, monitor.config.derivative_window
    components = [f for f in known if f["type"] != "mode"]
    known_modes = [f for f in known if f["type"] == "mode"]
    seen = (w, monitor.affine)
    data = None
    if floors is not None:               # the residuals with the known faults alone: where each holds
        data = residual_rows(Objective(model, monitor.residuals, win, (), weights, w, fixed=components,
                                       config=monitor.config, modes=mode_values(model, win, known_modes, modes, seen)))
    best = (np.inf, float(grid[0]))
    for onset in grid:
        values = mode_values(model, win, known_modes + [{**f, "t0": float(onset)} for f in switches], modes, seen)
        obj = Objective(model, monitor.residuals, win, (), weights, w, fixed=components, config=monitor.config,
                        modes=values)
        if data is None:
            c = obj.constant()
        else:                            # what constant() sums, residual by residual, each evaluated once
            rows = residual_rows(obj)
            c = float(sum(weights[i] * np.nansum(np.abs(row)) for i, row in enumerate(rows))
                      + off_charge(rows, data, floors, weights))
        if c < best[0]:
            best = (c, float(onset))
    return float(best[0]), best[1]
