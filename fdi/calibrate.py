"""Thresholds from fault-free runs (``bgfdi calibrate``).

A residual's threshold must stay above what noise, filter and model error make of it when
nothing is wrong, and as low as that allows so that faults are seen early. From nominal runs:

- ``peak`` (default): the largest |r| of each residual over all the runs, times a margin (1.5:
  the peak of a longer or noisier run exceeds the one seen);
- ``quantile``: the q-quantile of |r| over all samples, times the margin (for long records with
  rare spikes; a quantile below 1 accepts that fraction of samples above the threshold).

Only the samples detection looks at count: half a derivative window after each run's start and
before its end are left out (:func:`fdi.detect.trusted`, :mod:`fdi.scales`), where the
Savitzky-Golay filter is evaluated off its centre and its noise is several times the interior's
(measured: peaks taken at the last sample made thresholds 1.3 to 2.7 times too loose).

With two runs or more the false-alarm rate is estimated by leaving each run out: thresholds from
the others, and whether the left-out run crosses one. That is an estimate of the chance that a new
fault-free run, as long as these, raises an alarm with the thresholds of all of them; with n runs
it can only be a multiple of 1/n, and it is pessimistic (the thresholds used come from one run
fewer). Each left-out run's worst residual is reported with its ratio to the others' threshold.
Each residual's unit is given (:func:`fdi.arrs.arr_unit`): it depends on the variable it sums
(m^3/s for one residual of a hydraulic model, Pa or N*m for the next).

``bgfdi calibrate --window auto`` also chooses the derivative window for a model that sets none
(:mod:`fdi.window_choice`; measured in docs/diagnosis.md, Time scales): the rule's
window unless a fault needs more than a 10 % change to be detected there, else the candidate
where the faults need the smallest changes. A model whose time constants are unknown (one that
cannot be linearised: :mod:`bondgraph.timescales` says why), or whose fastest is far below a
sample (an artefact of a law that jumps where the model is linearised), gives the rule nothing the
data show to follow: calibrate says so and why (``Calibration.blind``), and what to do:
``--window auto``, or initial values where the system operates.

``bgfdi calibrate -o`` writes the thresholds into a copy of the model file, the rest untouched:

>>> c = Calibration("rc", ["ARR1"], ["A"], [[0.002]], [0.003], "peak", 1.5, None, ["nominal.csv"])
>>> print(with_thresholds("name: rc   # an RC node\\nthresholds:\\n  ARR1: 1.0\\nparameters: {}\\n", c), end="")
name: rc   # an RC node
thresholds: {ARR1: 0.003}   # bgfdi calibrate: peak of |r| x 1.5 over 1 nominal run(s)
parameters: {}
"""
from __future__ import annotations

import os
import re
import itertools
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from bondgraph.timescales import TimeScales, time_scales

from . import derivatives, scales
from .arrs import arr_unit
from .data import DataError, Measurements, commanded, read_csv, signals_from_data
from .monitor import compiled
from .mode_thresholds import key_text
from .noise import mode_text, predicted_noise
from .detect import settling, trusted
from .residuals import evaluate, never_finite_text, switch_gaps
from .spikes import despiked
from .window_choice import DETECT_GOAL, WindowScore, choose_window, chosen, set_aside

DEFAULT_MARGIN = 1.5
DISAGREE = 1000.0      # a residual this many times its predicted noise on fault-free runs: model and data disagree
NOISE_EXCESS = 5.0       # runs whose residual varies this much more than the declared noise explains: a note
MODE_SAMPLES = 100       # samples of a mode in the runs (at least two derivative windows) to compare or calibrate it
MEDIAN_SIGMA = 0.6744897501960817     # median |x| of a standard normal x


@dataclass
class Calibration:
    """Thresholds by residual, their units and the measurements behind them."""
    model: str
    names: list[str]
    units: list[str]
    peaks: list[list[float | None]]     # per run, per residual: max |r| between the filter's edges (None: no sample)
    thresholds: list[float]
    rule: str
    margin: float
    false_alarms: list[bool] | None     # per run left out: did it cross a threshold of the others?
    runs: list[str]
    worst: list[tuple[str, float]] | None = None   # per run left out: its residual nearest (or furthest
                                                    # past) the others' threshold, and |r| / that threshold
    window: float | None = None         # the derivative window (s) the residuals were filtered with
    window_samples: int | None = None   # ... in samples of the first run
    window_given: bool = True           # from diagnosis.derivative_window (else the rule's, fdi.scales)
    highest_order: int = 0              # the highest derivative the residuals take
    window_chosen: bool = False         # chosen by ``--window auto`` (fdi.window_choice): written with -o
    window_scores: list[WindowScore] | None = None    # every candidate window's, the rule's first when scored;
                                                      # at the rule's window (not --window auto): the rule's alone
    blind: tuple[str, ...] = ()         # why the rule's window follows no time constant the data show
    spikes: tuple[tuple[str, float, str], ...] = ()   # (residual, its peak / its median, the run):
                                                     # a peak rule's threshold set by a spike (SPIKE)
    noise: tuple[dict, ...] = ()        # per residual and mode the runs visit: their level against the
                                        # noise the sensors' declared noise predicts (fdi.noise)
    mode_thresholds: dict = field(default_factory=dict)   # by residual: {"p=0 m=1": threshold, ...}, what -o
                                        # writes (fdi.mode_thresholds); ``thresholds`` keeps one per residual
    unvisited: dict = field(default_factory=dict)   # by residual: the combinations no run visits (scaled from
                                        # the visited ones by the predicted noise)
    glitches: tuple[tuple[str, str], ...] = ()   # (run, what fdi.spikes found in its sensor columns and did)
    rises: tuple[tuple[str, str, float, str], ...] = ()   # (residual, mode, ratio, run): its level rose within
                                                         # the run (RISE): a fault in a nominal run
    mode_units: dict = field(default_factory=dict)   # by residual calibrated by mode: {"brake=0": "N*m", ...}
                                        # where its unit differs between modes (arr_unit says "?" for it)
    unscored: tuple[str, ...] = ()      # with --window auto: parametric faults no window scores (a nominal value
                                        # infinite or zero: no relative change of it, fdi.sensitivity.perturbed)
    at_switches: tuple[tuple[str, str, float, float, float], ...] = ()   # (residual, run, t, peak, peak elsewhere):
                                        # its peak at a commanded switch, SWITCH_PEAK times the rest's

    @property
    def false_alarm_rate(self) -> float | None:
        return None if self.false_alarms is None else float(np.mean(self.false_alarms))

    def to_dict(self) -> dict:
        return {**asdict(self), "false_alarm_rate": self.false_alarm_rate}


def nominal_residuals(model_path: str, data: str | Measurements, settle: float | None = None,
                      window: float | None = None) -> np.ndarray:
    """|r| of every residual on one run, on the samples detection looks at (the derivative
    filter's edges left out, at least ``settle`` s at the start): (residuals, samples). ``window``
    (s): the derivative window, else the file's or the rule's."""
    return _nominal(model_path, data, settle, window)[0]


def _nominal(model_path: str, data: str | Measurements, settle: float | None,
             window: float | None) -> tuple[np.ndarray, dict[str, np.ndarray], np.ndarray]:
    """:func:`nominal_residuals`, the commanded and autonomous modes' values on the same samples,
    and their times."""
    c, meas, sc, raw = _run(model_path, data, window)
    model = c.model
    scales.check_record_length(model, sc.window, derivatives.window_samples(sc.window, meas.ts, derivatives.DEFAULT_ORDER)
                               + 1, meas.ts, meas.t.size, meas.path)
    modes = commanded(model, raw)
    r = evaluate(model, list(c.arr_residuals), raw, meas.ts, window=sc.window, values=modes)
    keep = trusted(meas.t, settling(settle, sc.settle), sc.end_edge)
    return (np.abs(np.asarray(r))[:, keep], {k: np.broadcast_to(v, meas.t.shape)[keep] for k, v in modes.items()},
            meas.t[keep])


SWITCH_PEAK = 3.0   # a residual's peak this many times its peak away from the commanded switches: set by them


def _switch_peaks(names: list[str], samples: list[np.ndarray], modes: list[dict], times: list[np.ndarray],
                  runs: list[str], near: list[int]) -> tuple[tuple[str, str, float, float, float], ...]:
    """(residual, run, time, peak, peak elsewhere) where a residual's peak over the runs (the peak
    rule's base) lies within ``near`` samples (per run) of a switch of ``modes`` (the commanded ones:
    an autonomous mode's switch is the plant's own) and stands SWITCH_PEAK times above its peak
    everywhere else: the plant and its command column disagree there (a trial's PV disconnect: the
    logger wrote the command a sample before the plant switched, and the transient at 250.09 s set
    ARR1's threshold 7.8 times its peak elsewhere; a 10 % current gain then went undetected)."""
    out = []
    for i, name in enumerate(names):
        best, away = (-np.inf, None, None), 0.0
        for r, m, t, run, k in zip(samples, modes, times, runs, near):
            x = r[i]
            close = np.zeros(x.size, dtype=bool)
            for v in m.values():
                for e in np.flatnonzero(np.diff(np.asarray(v, dtype=float)) != 0):
                    close[max(0, e - k):e + k + 2] = True
            finite = np.isfinite(x)
            if (finite & ~close).any():
                away = max(away, float(x[finite & ~close].max()))
            if (finite & close).any():
                top = int(np.flatnonzero(finite & close)[np.argmax(x[finite & close])])
                if x[top] > best[0]:
                    best = (float(x[top]), run, float(t[top]))
        peak, run, at = best
        if run is not None and away > 0 and peak > SWITCH_PEAK * away:
            out.append((name, run, at, peak, away))
    return tuple(out)


def _run(model_path: str, data: str | Measurements, window: float | None):
    """A run as calibrate reads it: the compiled model, the run despiked, its scales at ``window``
    (None: the file's or the rule's) and its signals."""
    c = compiled(model_path)
    meas = despiked(c.model, data if isinstance(data, Measurements) else read_csv(data))[0]   # (calibrate's: done)
    config = c.config if window is None else replace(c.config, derivative_window=float(window))
    return c, meas, scales.for_model(c.model, config, meas.ts), signals_from_data(c.model, meas)


def _switches_leave_none(model_path: str, data: str | Measurements, window: float | None) -> bool:
    """Whether the evaluator leaves every trusted sample of a run out by design: every stretch
    between two mode switches shorter than the derivative window (:func:`fdi.residuals.designed_gaps`)."""
    c, meas, sc, raw = _run(model_path, data, window)
    gaps = switch_gaps(c.model, c.arr_residuals, raw, meas.t.size, sc.window, meas.ts)
    return gaps is not None and bool(gaps.all())


def _threshold(samples: list[np.ndarray], quantile: float | None, margin: float) -> np.ndarray:
    joined = np.concatenate(samples, axis=1)
    # NaN: samples with no residual (within half a derivative window of a commanded switch)
    level = np.nanmax(joined, axis=1) if quantile is None else np.nanquantile(joined, quantile, axis=1)
    return margin * level


def calibrate(model_path: str, runs: list, margin: float = DEFAULT_MARGIN, quantile: float | None = None,
              settle: float | None = None, window: str | None = None, by_mode: bool = False) -> Calibration:
    """Thresholds from nominal ``runs`` (paths or Measurements); see the module doc. ``window="auto"``
    also chooses the derivative window (:func:`fdi.window_choice.choose_window`) and calibrates at it; a model file
    that sets diagnosis.derivative_window keeps its own (a ValueError says so). Thresholds by mode
    (:mod:`fdi.mode_thresholds`) for the residuals whose form switches with a commanded or
    autonomous mode and whose unit, or predicted noise (:data:`fdi.noise.SPREAD` times), differs
    between modes; with ``by_mode``, for every residual whose form switches."""
    c = compiled(model_path)
    model, arrs = c.model, c.arrs
    names = [a.name for a in arrs]
    if window not in (None, "auto"):
        raise ValueError(f"window must be None or 'auto', got {window!r}")
    if window == "auto" and c.config.derivative_window is not None:
        raise DataError(f"{model_path}: diagnosis.derivative_window is set ({c.config.derivative_window:g} s): remove "
                        "it to let calibrate --window auto choose one, or calibrate without --window")
    seen: dict[str, str] = {}
    for run in runs:
        if not isinstance(run, Measurements):
            key = os.path.realpath(run)
            if key in seen:             # the false-alarm estimate leaves each run out in turn: its twin stays
                raise DataError(f"{run}: given twice (also as {seen[key]}); give each nominal run once")
            seen[key] = str(run)
    data = [run if isinstance(run, Measurements) else read_csv(run) for run in runs]
    repaired = [despiked(model, meas, advice="diagnose reads them so too, unless --keep-spikes") for meas in data]
    data = [meas for meas, _ in repaired]
    glitches = tuple((meas.path, words) for meas, words in repaired if words)
    for meas in data:
        scales.check_derivative_window(model, c.config.derivative_window, meas.ts, meas.path)
        if all(np.ptp(v) == 0 for k, v in meas.columns.items() if k != "t"):
            raise DataError(f"{meas.path}: every column is constant: no sensor noise and nothing moving, so no "
                            "threshold can be learnt from it (it would be 0, or miss the noise every real run "
                            "has); calibrate on fault-free runs recorded from the plant, noise included")
        frozen = sorted({c for s in model.sensors.values() for c, sd in s.noise.items()      # (a quantised one
                         if sd > 0 and not s.resolution.get(c) and c in meas.columns  # may read one count)
                         and np.ptp(meas.columns[c]) == 0})
        if frozen:      # a stuck sensor is a fault: a trial's frozen thermometers raised the thresholds 40-75 %
            raise DataError(f"{meas.path}: the sensor column(s) {', '.join(frozen)} never change, though the model "
                            "gives them noise: a frozen (stuck) sensor is a fault, not a nominal run; leave the run "
                            "out, or check the sensor")
    rule_of = lambda s: _threshold(s, quantile, margin)      # noqa: E731 (the calibration's rule, for the scores)
    if window == "auto":
        scores = choose_window(model_path, data, rule_of, settle)
    elif c.config.derivative_window is None:   # the rule's window, scored alone: how large a change each fault needs
        scores = choose_window(model_path, data, rule_of, settle, (1.0,)) or None
    else:
        scores = None
    pick = chosen(scores).window if scores and window == "auto" else None
    nominal = [_nominal(model_path, meas, settle, pick) for meas in data]
    runs_modes = [(r, m) for r, m, _ in nominal]
    samples = [r for r, _ in runs_modes]
    config = c.config if pick is None else replace(c.config, derivative_window=pick)
    sc = scales.for_model(model, config, data[0].ts)
    used = sc.window        # the file's, the rule's (from the data's sampling time) or the chosen
    short = [m for m, r in zip(data, samples) if not r.shape[1]]
    if short:               # (a window set long in the file: its settling outlasts the run)
        meas = short[0]
        start = settling(settle, scales.for_model(model, config, meas.ts).settle)
        raise DataError(f"{', '.join(m.path for m in short)}: no sample that detection looks at: it starts "
                        f"{start:.6g} s into a run (the start-up settling at the derivative window {used:g} s"
                        f"{', or --settle' if settle is not None else ''}) and ends {sc.end_edge:.6g} s before its "
                        f"end, and the run is {meas.t[-1] - meas.t[0]:.6g} s long: calibrate on longer runs, or "
                        f"shorten diagnosis.derivative_window")
    thresholds = _threshold(samples, quantile, margin)
    joined = np.concatenate(samples, axis=1)
    spiked = [n for n, v, row in zip(names, thresholds, joined) if not np.isfinite(v) and np.isfinite(row).any()]
    if spiked:
        raise DataError(f"{model_path}: {', '.join(spiked)} reach(es) infinity on the runs: a value no sensor reads "
                        "(a spike) in a run meant to be fault-free; remove it from the run, or calibrate with "
                        "--quantile 0.99")
    blank = [n for n, v in zip(names, thresholds) if not np.isfinite(v)]
    if blank and not all(_switches_leave_none(model_path, m, pick) for m in data):
        # not for want of samples: a law leaves its domain (or overflows) on every sample
        raise DataError(f"{model_path}: {never_finite_text(model, c.arr_residuals, blank)}")
    if blank:
        raise DataError(f"{model_path}: {', '.join(blank)} have no sample to calibrate on: every stretch between "
                        f"two mode switches is shorter than the derivative window ({used:g} s); "
                        "shorten diagnosis.derivative_window or sample faster")
    empty = [m.path for m, s in zip(data, samples) if not np.isfinite(s).any()]
    if empty:
        raise DataError(f"{', '.join(empty)}: no residual sample at the derivative window "
                        f"({used:g} s): every stretch between two "
                        "mode switches is shorter than it; leave the run(s) out, or shorten "
                        "diagnosis.derivative_window")
    zero = [n for n, v in zip(names, thresholds) if not v > 0]
    for j, n in enumerate(names):
        held = _vanishes_where_judged(model, arrs[j], [r[j] for r in samples], [m for _, m in runs_modes]) \
            if n in zero else None
        if held:
            raise DataError(f"{model_path}: {n} is judged only in mode(s) where it is identically 0 ({held}: the mode "
                            f"switches its whole relation off); in the others every stretch between two mode "
                            f"switches is shorter than the derivative window ({used:g} s): shorten "
                            f"diagnosis.derivative_window, or calibrate on runs that stay longer in those modes")
    if zero:
        raise DataError(f"{model_path}: {', '.join(zero)} would get a threshold of 0 (the residual is exactly 0 on "
                        "every sample of the runs: noise-free data?); a zero threshold alarms on any noise: "
                        "calibrate on runs recorded with the sensors' noise")
    predicted = predicted_noise(model, c.arr_residuals, float(sc.window), data[0].ts)
    need = max(MODE_SAMPLES, 2 * derivatives.window_samples(sc.window, data[0].ts, derivatives.DEFAULT_ORDER))
    modal = _by_mode(model, arrs, predicted, [m for _, m in runs_modes], by_mode)
    tables, unvisited = {}, {}
    for j, variables in modal.items():
        got = _mode_table([s[j] for s in samples], [m for _, m in runs_modes], variables, quantile, margin, need,
                          predicted.get(names[j], ()))
        if got is not None:
            tables[j], unvisited[names[j]] = got
    false_alarms = worst = None
    if len(samples) > 1:
        false_alarms, worst = [], []
        for i, left in enumerate(samples):
            others = _threshold(samples[:i] + samples[i + 1:], quantile, margin)
            limit = np.broadcast_to(others[:, None], left.shape).copy()
            kept = [k for k in range(len(samples)) if k != i]
            for j in tables:                # each sample judged with the others' threshold of its mode
                got = _mode_table([samples[k][j] for k in kept], [runs_modes[k][1] for k in kept], modal[j],
                                  quantile, margin, need, predicted.get(names[j], ()))
                if got is not None:
                    limit[j] = _per_sample(got[0], runs_modes[i][1], modal[j], left.shape[1])
            with np.errstate(all="ignore"):
                ratio = np.nanmax(np.where(np.isnan(left), -np.inf, left / limit), axis=1)   # -inf: no sample
            false_alarms.append(bool((left > limit).any()))
            worst.append((names[int(np.argmax(ratio))], float(ratio.max())))
    spikes = _spikes(names, samples, [m.path for m in data]) if quantile is None else ()
    rises = _rises(names, samples, [m for _, m in runs_modes], [m.path for m in data], need)
    commanded_only = [{k: v for k, v in m.items() if not model.modes[k].autonomous} for _, m in runs_modes]
    at_switches = (_switch_peaks(names, samples, commanded_only, [t for _, _, t in nominal], [m.path for m in data],
                                 [int(derivatives.window_samples(sc.window, m.ts, derivatives.DEFAULT_ORDER)) + 2
                                  for m in data])
                   if quantile is None else ())      # (a quantile's threshold is not its peak's)
    blind = _blind(scales.model_time_scales(model), data[0].ts) if c.config.derivative_window is None else ()
    if blind:
        blind += _operating_point(model, data)
    noise = noise_against_prediction(arrs, runs_modes, predicted, need)
    return Calibration(model.name, names, [arr_unit(model, a) for a in arrs],
                       [[_peak(row) for row in s] for s in samples], [float(x) for x in thresholds],
                       "peak" if quantile is None else f"quantile {quantile:g}", margin, false_alarms,
                       [m.path for m in data], worst, float(sc.window),
                       int(derivatives.window_samples(sc.window, data[0].ts, derivatives.DEFAULT_ORDER)),
                       c.config.derivative_window is not None,
                       max((r.highest_order() for r in c.arr_residuals), default=0), pick is not None, scores, blind,
                       spikes, noise, {names[j]: {key_text(k): float(v) for k, v in t.items()} for j, t in tables.items()},
                       {n: [key_text(k) for k in u] for n, u in unvisited.items() if u}, glitches, rises,
                       _mode_units(model, arrs, names, tables), _unscored(model) if pick is not None else (), at_switches)


def _unscored(model) -> tuple[str, ...]:
    """The parametric faults whose size ``--window auto`` cannot score: one the window scores cannot
    move (:func:`fdi.sensitivity.perturbed`: a parameter whose nominal value is infinite or zero, a
    healthy leak's resistance, has no relative change to detect)."""
    from .sensitivity import perturbed
    nominal = model.nominal_by_name()
    return tuple(f for f, v in model.faults.items() if v.kind == "parametric" and perturbed(model, f, nominal, {}) is None)


def _mode_units(model, arrs, names: list[str], tables: dict) -> dict[str, dict[str, str]]:
    """The unit of each residual calibrated by mode in each of its table's modes, where one unit
    does not hold for all (the table then says what each threshold is in: a trial's user read "?";
    the EV precharge's loop was labelled V, and is in A with both contactors open)."""
    from .arrs import units_by_mode
    from .signatures import nominal_mode
    out = {}
    for j, table in tables.items():
        units = {}
        for key in table:
            found = units_by_mode(model, arrs[j], [{**nominal_mode(model), **dict(key)}])
            if len(found) == 1:
                units[key_text(key)] = next(iter(found))
        if len(set(units.values())) > 1:
            out[names[j]] = units
    return out


def _by_mode(model, arrs, predicted, modes: list[dict], every: bool) -> dict[int, tuple[str, ...]]:
    """The residuals to calibrate by mode, by index, with the commanded or autonomous mode variables
    their form switches on (in the model's order; those the runs record): every such residual with
    ``every``, else those whose unit differs between modes or whose predicted noise differs
    :data:`fdi.noise.SPREAD` times between modes of one unit."""
    from .arrs import units_by_mode
    from .noise import spreads
    from .signatures import operating_modes
    recorded = set.intersection(*(set(m) for m in modes)) if modes else set()
    switching = [n for n, m in model.modes.items() if (m.column or m.autonomous) and n in recorded]
    flagged = {a.name for a, _, _, _ in spreads(model, arrs, predicted)}
    operating = operating_modes(model)
    out = {}
    for j, a in enumerate(arrs):
        present = {s.name for s in a.expr.free_symbols}
        variables = tuple(n for n in switching if model.symbols[n].name in present)
        if not variables:
            continue
        if every or a.name in flagged or len(units_by_mode(model, a, operating)) > 1:
            out[j] = variables
    return out


def _vanishes_where_judged(model, arr, rows: list[np.ndarray], modes: list[dict]) -> str:
    """The mode combinations (as ``s=0``) of the finite samples of one residual's ``rows`` when
    its relation is identically 0 in every one of them (a relay's current balance s*(U - Rh*I) with
    the relay open: a trial's window left it no sample with the relay closed, and calibrate said
    "noise-free data?"); else ""."""
    import sympy as sp
    present = {s.name for s in arr.expr.free_symbols}
    names = [n for n in model.modes if n in present and all(n in m for m in modes)]
    if not names:
        return ""
    combos = set()
    for row, m in zip(rows, modes):
        finite = np.isfinite(row)
        if finite.any():
            bits = np.stack([np.asarray(m[n])[finite] >= 0.5 for n in names], axis=1)
            combos |= {tuple(int(b) for b in x) for x in np.unique(bits, axis=0)}
    if not combos:
        return ""
    for bits in combos:
        if sp.expand(arr.expr.xreplace({model.symbols[n]: int(b) for n, b in zip(names, bits)})) != 0:
            return ""
    return "; ".join(",".join(f"{n}={b}" for n, b in zip(names, bits)) for bits in sorted(combos))


def _mask(modes: dict[str, np.ndarray], key: tuple, n: int) -> np.ndarray:
    """The samples of a run (its kept samples' mode values) in the combination ``key``."""
    here = np.ones(n, dtype=bool)
    for name, bit in key:
        here &= (np.asarray(modes[name]) >= 0.5) == bool(bit)
    return here


def _mode_table(rows: list[np.ndarray], modes: list[dict], variables: tuple[str, ...], quantile: float | None,
                margin: float, need: int, predicted) -> tuple[dict[tuple, float], list[tuple]] | None:
    """One residual's threshold in each combination of ``variables``: the rule on the runs' samples
    in it (``need`` finite ones at least), and for a combination the runs do not visit enough the
    visited ones' scaled by the predicted noise (the largest; the largest visited without a
    prediction), as for one where the residual is exactly 0 on every sample (a threshold of 0 would
    alarm on any noise); with those combinations. None when no combination gets a threshold."""
    table: dict[tuple, float] = {}
    combos = [tuple(zip(variables, bits)) for bits in itertools.product((0, 1), repeat=len(variables))]
    for key in combos:
        x = np.concatenate([row[_mask(m, key, row.size)] for row, m in zip(rows, modes)])
        x = x[np.isfinite(x)]
        level = margin * float(np.max(x) if quantile is None else np.quantile(x, quantile)) if x.size >= need else 0.0
        if level > 0:           # 0: exactly 0 on every sample of the mode (a reading quantised to 0): as unvisited
            table[key] = level
    if not table:
        return None
    sigma: dict[tuple, float] = {}
    for row in predicted:
        if row.std is not None and row.std > 0:
            key = tuple((v, int(row.mode.get(v, 0))) for v in variables)
            sigma[key] = max(sigma.get(key, 0.0), row.std)
    unvisited = [k for k in combos if k not in table]
    visited = dict(table)
    for key in unvisited:
        scaled = [t * sigma[key] / sigma[v] for v, t in visited.items() if key in sigma and v in sigma]
        table[key] = max(scaled) if scaled else max(visited.values())
    return table, unvisited


def _per_sample(table: dict[tuple, float], modes: dict[str, np.ndarray], variables: tuple[str, ...], n: int
                ) -> np.ndarray:
    """Each of a run's ``n`` kept samples' threshold from a table by mode."""
    out = np.empty(n)
    for key, value in table.items():
        out[_mask(modes, key, n)] = value
    return out



def noise_against_prediction(arrs, runs: list[tuple[np.ndarray, dict[str, np.ndarray]]], predicted,
                             need: int) -> tuple[dict, ...]:
    """Per residual and per operating mode the runs visit (:data:`MODE_SAMPLES` samples at least,
    two derivative windows), the residual's level on the runs beside its noise predicted from the
    sensors' declared noise (:func:`fdi.noise.predicted_noise`, at the calibrated window):
    ``{"residual", "mode", "samples", "level", "predicted"}``. The level is the median |r| over
    0.6745, the standard deviation of Gaussian noise and robust to a spike (which the peak rule's
    note names); an offset the model leaves counts in it. Where the level is several times the
    prediction, the thresholds are set by what the model does not explain (a parameter's value,
    a law, an unmodelled input or disturbance), or by noise the file understates; where they agree,
    by the sensors' noise, and only better sensors or a longer window lower them. Empty when no
    sensor declares noise. ``predicted``: :func:`fdi.noise.predicted_noise`'s, at the calibrated
    window; ``need``: the samples a mode needs."""
    if not predicted:
        return ()
    out = []
    for i, a in enumerate(arrs):
        for row in predicted.get(a.name, ()):
            parts = []
            for r, values in runs:
                x = r[i][_mask(values, tuple((name, row.mode.get(name, 0)) for name in values), r.shape[1])]
                parts.append(x[np.isfinite(x)])
            x = np.concatenate(parts) if parts else np.zeros(0)
            if x.size < need or row.std is None:
                continue
            out.append({"residual": a.name, "mode": dict(row.mode), "samples": int(x.size),
                        "level": float(np.median(x) / MEDIAN_SIGMA), "predicted": float(row.std)})
    return tuple(out)


def _peak(row: np.ndarray) -> float | None:
    """A run's largest |r| of one residual; None where it has no sample (every stretch between two
    mode switches shorter than the derivative window: NaN, which is no JSON)."""
    return float(np.nanmax(row)) if np.isfinite(row).any() or np.isinf(row).any() else None


SPIKE = 1000.0   # a residual's peak this many times its median |r| is a spike, not noise: a normal law's peak over
                 # a million samples is 8 times its median |r|, heavy tails and a nominal run's transients tens
                 # (the median: one bad sample spreads over a derivative window, a share no quantile near 1 is
                 # safe from on a short run)


RISE = 10.0    # a residual whose median |r| in a mode is this many times higher over a run's last third than
               # over its first: the run changed within (a nominal run's levels move by 1.0-1.6x: the
               # CyCab's, the precharge's and the accumulator's runs, from their own simulators)


def _rises(names: list[str], samples: list[np.ndarray], modes: list[dict], runs: list[str],
           need: int) -> tuple[tuple[str, str, float, str], ...]:
    """(residual, mode, ratio, run) where a residual's level (median |r|) in one combination of the
    runs' mode variables rises ``RISE`` times from a run's first third of samples in it to its last
    third (``need`` samples each at least): a fault in a run meant to be fault-free. The peak note
    (:func:`_spikes`) misses it (the median rises with the fault), and the noise note names the
    residual without the run: a trial's run with the load orifice clogged from half-way set ARR3's
    threshold 40 times higher, and calibrate named ARR1's spike at the valve."""
    out = []
    for r, values, run in zip(samples, modes, runs):
        names_m = sorted(values)
        for key in itertools.product((0, 1), repeat=len(names_m)):
            here = np.flatnonzero(_mask(values, tuple(zip(names_m, key)), r.shape[1]))
            for i, name in enumerate(names):
                x = r[i, here]
                x = x[np.isfinite(x)]
                third = x.size // 3
                if third < need:
                    continue
                first, last = float(np.median(x[:third])), float(np.median(x[-third:]))
                if first > 0 and last > RISE * first:
                    out.append((name, mode_text(dict(zip(names_m, key))) if names_m else "", last / first, run))
    return tuple(out)


def _spikes(names: list[str], samples: list[np.ndarray], runs: list[str]) -> tuple[tuple[str, float, str], ...]:
    """The residuals whose peak (the threshold's base under the peak rule) stands ``SPIKE`` times above
    their median |r| over the runs, with that ratio and the run it is in: one bad sample in a run
    meant to be fault-free sets the threshold (a 1e200 V cell made the RC circuit's ARR1 threshold
    1.6e199, and a faulty run then raised nothing)."""
    joined = np.concatenate(samples, axis=1)
    level, peak = np.nanmedian(joined, axis=1), np.nanmax(joined, axis=1)
    out = []
    for i, name in enumerate(names):
        if level[i] > 0 and peak[i] > SPIKE * level[i]:
            run = int(np.argmax([np.max(np.where(np.isnan(s[i]), -np.inf, s[i])) for s in samples]))
            out.append((name, float(peak[i] / level[i]), runs[run]))
    return tuple(out)


SUBSAMPLE = 100    # a time constant this many times shorter than a sample: likely an operating point's artefact


def _blind(tau: TimeScales, ts: float) -> tuple[str, ...]:
    """Why the rule's window follows nothing the data show: the model's time constants unknown
    (:mod:`bondgraph.timescales`' notes: the model could not be linearised; or integrators only),
    or the fastest far below a sample, where a law that jumps at the operating point makes one (a
    car linearised at rest: Coulomb rolling resistance differenced across v = 0 gave 7e-13 s, where
    the car at 25 m/s has 76 s); empty when neither."""
    if not tau.known:
        if tau.notes:
            return tuple(tau.notes)
        return ("its linearisation has integrators only (every eigenvalue 0): no time constant",) if tau.eigenvalues \
            else ("it has no state: no time constant",)
    if tau.fastest < ts / SUBSAMPLE:
        return (f"the fastest time constant, {tau.fastest:.3g} s, is below a hundredth of a sample "
                f"({ts:.3g} s): a law that jumps or has no slope where the model is linearised (the "
                f"initial state) makes such a one; if the system has none, give initial values where it "
                f"operates (initial: {{SENSOR: value}})",)
    return ()


def _operating_point(model, data: list[Measurements]) -> tuple[str, ...]:
    """What the runs say to give as ``initial``: each sensor's median over them (a sensor's reading
    is met by solving for the states), and the time constant the model has there, when it has one
    that is not below a hundredth of a sample (the car's two nominal runs: v 25.55 m/s, 74.1 s);
    else nothing."""
    signals = [signals_from_data(model, m) for m in data]
    values = {name: float(np.nanmedian(np.concatenate([np.asarray(raw[name], dtype=float) for raw in signals])))
              for name in model.sensors if all(name in raw for raw in signals)}
    values = {k: v for k, v in values.items() if np.isfinite(v)}
    if not values:
        return ()
    try:
        tau = time_scales(replace(model, initial={**model.initial, **values}))
    except Exception:                 # noqa: BLE001 - a suggestion only: no suggestion
        return ()
    if not tau.known or tau.fastest < data[0].ts / SUBSAMPLE:
        return ()
    shown = ", ".join(f"{k}: {v:.4g}" for k, v in values.items())
    return (f"at the runs' medians, initial: {{{shown}}}, the fastest time constant is {tau.fastest:.3g} s",)


def _not_scored(c: Calibration) -> str:
    if not c.unscored:
        return ""
    return (f"; not scored: {', '.join(c.unscored)} (a nominal value infinite or zero: no relative change of "
            f"{'it' if len(c.unscored) == 1 else 'them'} to detect)")


def format_calibration(c: Calibration) -> str:
    lines = [f"thresholds of {c.model} from {len(c.runs)} nominal run(s): {c.rule} of |r| x {c.margin:g}",
             f"{'residual':<10}{'unit':<10}{'largest |r|':>14}{'threshold':>14}"]
    for i, name in enumerate(c.names):
        peak = max(p[i] for p in c.peaks if p[i] is not None)
        table = c.mode_thresholds.get(name)
        units = c.mode_units.get(name, {})
        unit = "by mode" if units else c.units[i]
        lines.append(f"{name:<10}{unit:<10}{peak:>14.4g}" + (f"{'by mode':>14}" if table else
                                                               f"{c.thresholds[i]:>14.4g}"))
        for key, value in (table or {}).items():
            note = " (no run visits it: scaled from the others by the predicted noise)" \
                if key in c.unvisited.get(name, ()) else ""
            lines.append(f"  {key:<22}{units.get(key, ''):<10}{value:>14.4g}{note}")
    if c.false_alarms is None:
        lines.append("false alarms: give two runs or more to estimate them (each is left out in turn)")
    else:
        n = len(c.false_alarms)
        lines.append(f"false alarms, each run left out in turn: {sum(c.false_alarms)} of {n} "
                     f"({100 * c.false_alarm_rate:.0f} %): how often a fault-free run alarms with thresholds "
                     f"calibrated without it,")
        lines.append(f"  an estimate of the chance that a new fault-free run as long as these alarms (in steps of "
                     f"1/{n}; pessimistic: one run fewer)")
        for run, alarmed, (name, ratio) in zip(c.runs, c.false_alarms, c.worst or ()):
            if ratio < 0:                                  # -inf: no sample of any residual in the run
                lines.append(f"  {run}: no residual has a sample to judge")
                continue
            if np.isnan(ratio):                            # inf over inf: spikes in it and in the others
                lines.append(f"  {run}: {name} cannot be compared (not finite in it and in the others' threshold: "
                             "a spike, see the notes below)")
                continue
            shown = f"{ratio:.2f}" if ratio < 1e6 else f"{ratio:.3g}"      # a spike's: no 300-digit number
            lines.append(f"  {run}: {name} reaches {shown} x the others' threshold"
                         + (" (an alarm)" if alarmed else ""))
    if (c.window is not None and c.window_chosen and c.window_scores and c.window_scores[0].rule
            and chosen(c.window_scores) is c.window_scores[0]):
        rule = c.window_scores[0]
        head = f"derivative window: {c.window:.4g} s ({c.window_samples} samples), the rule's, kept by --window auto: "
        if not rule.detectable:
            lines.append(head + "no fault can be moved to score the windows (stuck and mode faults only)")
        else:
            worst = max(rule.detectable, key=rule.detectable.get)
            largest = f"{worst}, {_change(rule.detectable[worst])}"
            lines.append(head + (f"every fault is detected from a change of at most {100 * DETECT_GOAL:g} % there "
                                 f"(the largest: {largest})" if rule.detectable[worst] <= DETECT_GOAL else
                                 f"no other window does better (shorter: down to a quarter of it, "
                                 f"{scales.min_window_samples()} samples at least; longer: at most a tenth of a "
                                 f"run, clear of the model's modes, under half a run without residuals); the "
                                 f"largest change to detect: {largest}") + _not_scored(c))
    elif c.window is not None and c.window_chosen and c.window_scores:
        rule, pick = c.window_scores[0], chosen(c.window_scores)
        span = (f"{len(c.window_scores)} ({min(x.window for x in c.window_scores):.4g} s to "
                f"{max(x.window for x in c.window_scores):.4g} s")
        if rule.rule:
            lines.append(f"derivative window: {c.window:.4g} s ({c.window_samples} samples), chosen by --window auto "
                         f"from {span}; the rule's {rule.window:.4g} s): the smallest change each fault needs to be "
                         f"detected (relative to its value; an offset's to its signal's RMS), geometric mean {100 * rule.score:.3g} % at the rule's, {100 * pick.score:.3g} % "
                         f"at this one{_not_scored(c)}")
            for f in pick.detectable:
                lines.append(f"  {f}: {_change(rule.detectable[f])} -> {_change(pick.detectable[f])}")
        else:               # the rule's window left over half a run without residuals: not scored
            lines.append(f"derivative window: {c.window:.4g} s ({c.window_samples} samples), chosen by --window auto "
                         f"from {span}): the rule's window left over half a run without residuals (stretches "
                         f"between mode switches shorter than it, or a settling as long as a run); the smallest "
                         f"change each fault needs to be detected (relative to its value; an offset's to its "
                         f"signal's RMS), geometric mean {100 * pick.score:.3g} % at this one")
            for f in pick.detectable:
                lines.append(f"  {f}: {_change(pick.detectable[f])}")
            if c.unscored:
                lines.append(f"  {_not_scored(c)[2:]}")
        aside = set_aside(c.window_scores)
        if aside:
            lines.append("  set aside whatever their scores: " + "; ".join(
                f"{w:.4g} s: {why}" for w, why in sorted(aside.items())))
        if pick is max(c.window_scores, key=lambda x: x.window) and len(c.window_scores) > 1:
            lines.append("  the longest window scored won: the scores may still fall beyond it, where no window was "
                         "tried (at most a tenth of a run, clear of the model's modes, under half a run without "
                         "residuals): longer nominal runs let longer windows be tried")
    elif c.window is not None:
        lines.append(f"derivative window: {c.window:.4g} s ({c.window_samples} samples), "
                     + ("diagnosis.derivative_window" if c.window_given else
                        "the rule's, from no time constant of the data (the note below)" if c.blind else
                        "the rule's (half the model's fastest time constant, docs/diagnosis.md)"
                        + (f": the residuals take derivatives of order {c.highest_order}, whose noise falls as the "
                           f"window's length to the power {c.highest_order + 0.5:g}; if faults go undetected, calibrate "
                           "--window auto chooses a window from the runs" if c.highest_order >= 2 else "")))
        if not c.window_given and c.window_scores and c.window_scores[0].detectable:
            rule = c.window_scores[0]
            worst = max(rule.detectable, key=rule.detectable.get)
            far = rule.detectable[worst] > DETECT_GOAL
            lines.append(f"  at it the faults need a change of {100 * rule.score:.3g} % to be detected (geometric mean; "
                         f"the most: {worst}, {_change(rule.detectable[worst])}; relative to a value, an offset's to "
                         f"its signal's RMS)" + (f": over {100 * DETECT_GOAL:g} %; calibrate --window auto scores "
                                                 "longer and shorter windows on these runs and keeps the best" if far
                                                 else ""))
    if c.blind and not c.window_chosen:
        lines.append(f"note: the rule's window follows no time constant of the data ({'; '.join(c.blind)}): "
                     f"calibrate --window auto chooses one from the runs")
    for run, words in c.glitches:
        lines.append(f"note: {run}: {words}")
    for name, mode, ratio, run in c.rises:
        lines.append(f"note: {name}{' in ' + mode if mode else ''} rises {ratio:.3g}x within {run} (median |r| over its "
                     f"last third against its first): a fault in a run meant to be fault-free sets its threshold; "
                     f"check that run, or leave it out")
    for name, run, at, peak, away in c.at_switches:
        lines.append(f"note: {name}'s peak ({peak:.4g}) is at a commanded switch, {at:.4g} s in {run}, {peak / away:.3g} "
                     f"times its peak elsewhere ({away:.4g}): the plant and its command column disagree there (a "
                     f"logger's lag of a sample or more?), or the switched mode settles faster than a sample; the "
                     f"threshold this peak sets hides faults one set by the rest would see: align the command column "
                     f"with the plant's switching, or check that switch")
    for name, ratio, run in c.spikes:
        lines.append(f"note: {name}'s peak is {ratio:.3g} times its median, in {run}: a spike or a fault in a run "
                     "meant to be fault-free sets its threshold; check that run, or calibrate with --quantile 0.99")
    for x in c.noise:
        if x["predicted"] > 0 and x["level"] >= NOISE_EXCESS * x["predicted"]:
            where = f" in {mode_text(x['mode'])}" if len({tuple(y['mode'].items()) for y in c.noise}) > 1 else ""
            lines.append(f"note: {x['residual']}{where} varies {x['level'] / x['predicted']:.3g}x more on the runs "
                         f"({x['level']:.4g}, median |r| / 0.6745) than the sensors' declared noise explains "
                         f"({x['predicted']:.4g}, fdi.noise): its threshold is set by what the model does not "
                         f"explain (a parameter's value, a law, an unmodelled input or disturbance, a column's unit: "
                         f"degrees for radians, mm for m, bar for Pa) or by noise the file understates"
                         + (f"; at {x['level'] / x['predicted']:.3g}x the model and these runs disagree: the threshold "
                            f"hides every fault smaller than that disagreement, find its cause before using it"
                            if x["level"] >= DISAGREE * x["predicted"] else ""))
    if c.mode_thresholds:
        lines.append(f"thresholds by mode for {', '.join(c.mode_thresholds)}: each monitored divided by its mode's "
                     f"threshold, against 1 (their noise or unit differs between modes; docs/patterns.md)")
    lines.append(_thresholds_line(c))
    return "\n".join(lines) + "\n"


def _change(size: float) -> str:
    """A fault's smallest detectable change, relative (an offset's: to its signal's RMS), as the
    text prints it; beyond a thousandfold, no residual moves with the fault at that window (an
    offset read only through derivatives), and a percentage of 1e15 says nothing.

    >>> _change(0.123), _change(5e12)
    ('12.3 %', 'none seen (no residual moves with it)')
    """
    return f"{100 * size:.3g} %" if size <= 1e3 else "none seen (no residual moves with it)"


def _thresholds_line(c: Calibration) -> str:
    """``thresholds: {ARR1: {p=0 m=1: 120, other: 0.8}, ARR2: 56.8}`` (YAML flow)."""
    def value(name: str, t: float) -> str:
        table = c.mode_thresholds.get(name)
        return "{" + ", ".join(f"{k}: {v:.4g}" for k, v in table.items()) + "}" if table else f"{t:.4g}"
    return "thresholds: {" + ", ".join(f"{n}: {value(n, t)}" for n, t in zip(c.names, c.thresholds)) + "}"


def with_thresholds(text: str, c: Calibration) -> str:
    """The model file's text with its top-level ``thresholds`` replaced by the calibrated ones (the
    rest of the file, comments included, untouched); added at the end when there is none. A window
    chosen by ``--window auto`` is written as diagnosis.derivative_window (:func:`with_window`)."""
    if c.window_chosen and c.window is not None:
        text = with_window(text, c.window)
    line = _thresholds_line(c)
    line += f"   # bgfdi calibrate: {c.rule} of |r| x {c.margin:g} over {len(c.runs)} nominal run(s)\n"
    pattern = re.compile(r"^thresholds:.*\n(?:[ \t]+.*\n)*", re.M)      # the key and its indented lines
    if pattern.search(text):
        return pattern.sub(lambda _: line, text, count=1)
    return text.rstrip("\n") + "\n\n" + line


def with_window(text: str, window: float) -> str:
    """The model file's text with ``derivative_window`` (s) in its top-level ``diagnosis`` (which
    does not set one): added to a one-line ``{...}`` mapping or as the first line of a block one,
    or a new ``diagnosis`` at the end. Raises ValueError for a layout it cannot edit safely.

    >>> print(with_window("name: m\\ndiagnosis: {samples: 500}\\n", 0.06), end="")
    name: m
    diagnosis: {derivative_window: 0.06, samples: 500}   # derivative_window: bgfdi calibrate --window auto
    >>> print(with_window("diagnosis:\\n  samples: 500\\n", 0.06), end="")
    diagnosis:
      derivative_window: 0.06   # bgfdi calibrate --window auto
      samples: 500
    >>> print(with_window("name: m\\n", 1e-05), end="")
    name: m
    <BLANKLINE>
    diagnosis: {derivative_window: 1.0e-05}   # bgfdi calibrate --window auto
    """
    value = f"{window:.4g}"
    mantissa, e, exponent = value.partition("e")
    if e and "." not in mantissa:            # YAML 1.1 reads 1e-05 as text: 1.0e-05 is a number
        value = f"{mantissa}.0e{exponent}"
    found = list(re.finditer(r"^diagnosis:(.*)\n?", text, re.M))
    if not found:
        out = text.rstrip("\n") + f"\n\ndiagnosis: {{derivative_window: {value}}}   # bgfdi calibrate --window auto\n"
    elif len(found) > 1:
        raise ValueError("the file has two top-level diagnosis keys")
    else:
        m = found[0]
        rest = m.group(1).split("#", 1)[0].strip()
        if rest.startswith("{") and rest.endswith("}"):
            inner = rest[1:-1].strip()
            mapping = "{derivative_window: " + value + (", " + inner if inner else "") + "}"
            out = text[:m.start()] + f"diagnosis: {mapping}   # derivative_window: bgfdi calibrate --window auto\n" \
                + text[m.end():]
        elif rest:
            raise ValueError("its diagnosis key is not a one-line {...} mapping or a block")
        else:
            head = text[:m.end()] if text[:m.end()].endswith("\n") else text[:m.end()] + "\n"
            child = re.compile(r"(?:[ \t]*(?:#.*)?\n)*([ \t]+)[^\s#]").match(text, m.end())   # blank, comment lines skipped
            indent = child.group(1) if child else "  "
            out = head + f"{indent}derivative_window: {value}   # bgfdi calibrate --window auto\n" + text[m.end():]
    _check_window_edit(text, out, float(value))
    return out


def _check_window_edit(before: str, after: str, window: float) -> None:
    """The edited text must read as the original plus diagnosis.derivative_window, nothing else."""
    import yaml
    try:
        old, new = yaml.safe_load(before), yaml.safe_load(after)
    except yaml.YAMLError as e:
        raise ValueError(f"the edited file would not read as YAML ({type(e).__name__})") from None
    expected = dict(old or {})
    diag = expected.get("diagnosis")
    expected["diagnosis"] = {"derivative_window": window, **(diag if isinstance(diag, dict) else {})}
    if new != expected:
        raise ValueError("the edited file would read differently from the original plus derivative_window")
