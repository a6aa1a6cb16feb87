"""The health-monitoring pipeline of Yu & Wang (2014), Sec. III, as named steps over typed values.

    prepare -> residuals -> detect -> isolate -> estimate modes -> confirm stuck sensors
            -> estimate (one estimator per candidate set) -> select -> re-decide -> significance
            -> prognose

:func:`run` is what ``Monitor.diagnose`` does; each step is a function of the compiled
:class:`fdi.monitor.Monitor`, the :class:`Prepared` data and the values of the steps before, and
returns a typed value of :mod:`fdi.results`. The result is a :class:`fdi.results.Diagnosis`.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Callable

import numpy as np

from bondgraph.errors import ModelError

from .data import DataError, Measurements, commanded, signals_from_data
from .decide import alternatives, effective_samples, information, select_winner, significant
from .derivatives import DEFAULT_ORDER, window_samples
from .detect import Detection, confirmed, detect, evidence, evidence_samples, settling, span_start, stray_error, thresholds_for
from .episodes import MAX_GROWTH, decision_index, decision_window, latched, next_change, redecide, since_detection
from .estimators import (Estimators, Search, date_onsets, evidence_onsets, evidence_start, refit_early_onsets,
                         drift_onset_band, step_onset_band, steps_at_window_start)
from .ingest import measurements
from .isolate import COVERING_NOTE, candidate_sets, fitted_sets, new_mode_changes, pruned_sets, relaxed_sets, suspected_mode_changes
from .mode_estimation import estimate_mode, mode_variable, residual_rows, switched_at
from .objective import Objective, fault_space, nominal, window
from .options import MIN_WINDOW_S, Options, check_samples
from .prognose import prognose
from .residuals import evaluate, mode_breaks, never_finite_text, switch_gaps
from .scales import STARTUP_DECAYS, check_derivative_window, check_record_length
from .results import DETERMINED, Alternative, Diagnosis, Isolation, ModeFault, Prognosis, faults_of
from .sensitivity import effective, weak_entries
from .signatures import mode_fault_name, nominal_mode, over_modes
from .spikes import despiked
from .stuck import stuck_from

if TYPE_CHECKING:
    from .monitor import Monitor
    from .scales import Scales


@dataclass(frozen=True)
class Prepared:
    """A diagnosis' inputs, checked and resolved: the monitor with the times the file left to the
    data, the time scales, the measurements and their signals, thresholds, waiting time, the
    identification window N, the settling time and the estimators' residual weights."""
    monitor: "Monitor"
    scales: "Scales"
    meas: Measurements
    raw: dict
    thresholds: np.ndarray
    wait: float
    samples: int
    settle: float
    weights: np.ndarray
    options: Options
    read: str | None = None           # what the reading found (fdi.spikes' spikes, a sampling time other than
                                      # the file's): the report's note

    @property
    def first_trusted(self) -> float:
        """The first sample after the settling time: where residuals and onsets are trusted."""
        return float(self.meas.t[0]) + self.settle

    @property
    def modes(self) -> dict[str, float]:
        """The mode variables the options fix (``Options.mode``): residuals and estimators use them."""
        return {k: float(v) for k, v in (self.options.mode or {}).items()}

    def values(self, raw: dict) -> dict:
        """Mode values for the residuals of ``raw``: commanded modes as commanded, the options' fixed."""
        return {**commanded(self.monitor.model, raw), **self.modes}

    @property
    def prognosed(self) -> frozenset[str]:
        """The faults with a failure value (the options' or the model's): those a prognosis follows."""
        config = self.monitor.config
        return frozenset(n for n in self.monitor.model.faults
                         if self.options.failures.get(n, config.failure(n)) is not None)

    @property
    def window_s(self) -> float:
        return self.monitor.config.derivative_window

    @property
    def rule(self) -> tuple[float, float]:
        """Detection's persistence (threshold-seconds) and evidence span (s), :mod:`fdi.detect`."""
        from .scales import detection_rule
        return detection_rule(self.window_s, self.wait, self.options.persistence, self.monitor.config.persistence)

    @property
    def covering(self) -> bool:
        """Whether a mode change whose MCSM signature contains the coherence vector is suspected
        (exoneration off, or by sensitivity: a residual a change enters may stay quiet)."""
        return not self.options.exoneration or self.monitor.config.exoneration == "sensitivity"


class Clock:
    """Wall-clock seconds by stage (``--timings``)."""

    def __init__(self) -> None:
        self.times: dict[str, float] = {}
        self._start = time.perf_counter()

    def lap(self, stage: str) -> None:
        now = time.perf_counter()
        self.times[stage] = now - self._start
        self._start = now

    def restart(self) -> None:
        self._start = time.perf_counter()


def _noted(note: str | None, more: str) -> str:
    """A diagnosis' note with ``more`` appended (a later step's note never replaces an earlier one)."""
    return f"{note}; {more}" if note else more


def run(monitor: "Monitor", data, options: Options | None = None, progress: Callable | None = None,
        memo: dict | None = None) -> Diagnosis:
    """Detect, isolate, identify and prognose ``data`` (a CSV path, Measurements, a DataFrame, a
    dict of arrays or a structured array: :func:`fdi.ingest.measurements`)."""
    o = options or Options()
    o.check()
    clock = Clock()
    monitor = monitor.with_config(o.settings)
    meas = measurements(data)
    p = prepare(monitor, meas, o)
    clock.lap("load")
    r = evaluate(p.monitor.model, list(p.monitor.residuals), p.raw, meas.ts, window=p.window_s, values=p.values(p.raw))
    clock.lap("residuals")
    found = _empty(p, r)                 # (mode breaks and designed gaps: worked out once for both)
    never = never_finite(p, r, found)
    if never:
        raise DataError(f"{meas.path}: {never_finite_text(p.monitor.model, p.monitor.residuals, never)}")
    blinded = blind(p, r, found)
    if r.size and not np.isfinite(r).any():
        # nothing was monitored: "nothing detected" (exit 0, --fail-on-fault passed) would read as healthy
        raise DataError(f"{meas.path}: no residual has a sample to judge, so nothing can be detected: {blinded}")
    det = detect(r, meas.t, p.thresholds, p.wait, p.settle, p.scales.end_edge, *p.rule)
    base = Diagnosis(p.monitor.model.name, dict(o.mode or nominal_mode(p.monitor.model)),
                     note="; ".join(n for n in (p.read, blinded) if n) or None,
                     t=meas.t, residuals=r, thresholds=p.thresholds, names=p.monitor.names, units=p.monitor.units,
                     timings=clock.times,
                     bond_graph=p.monitor.model)
    if det is None:
        return base
    d = decide(p, replace(base, detection=det, mode=mode_at(p, det)), r, clock, progress, memo)
    notes = "; ".join(n for n in (from_the_start(p, det) if d.faults else None, undecided_mode(d),
                                  unused_record(p, d)) if n)
    return replace(d, note=_noted(d.note, notes)) if notes else d


def undecided_mode(d: Diagnosis) -> str | None:
    """The note when the diagnosis is the fault-mode estimator's answer and other fault modes cost
    within 1 % of it (a user trial's ABS: the outlet stuck closed named within 0.3 % of the inlet
    stuck open, the truth, in a window where both valves' commands switch)."""
    mf = d.mode_fault
    if mf is None or not mf.ties or not d.faults or {f.name for f in d.faults} != {f.name for f in mf.faults}:
        return None
    others = "; ".join(" ".join(f"{k}={v}" for k, v in tie.items()) for tie in mf.ties)
    return (f"the fault mode is barely decided: {others} cost{'s' if len(mf.ties) == 1 else ''} within 1 % of it "
            "(mode_costs): these data hardly tell them apart")


START_WINDOWS = 2.0   # a detection within this many derivative windows of the first trusted sample: at the start


def from_the_start(p: Prepared, det: Detection) -> str | None:
    """The note when the detection comes with the first samples that are trusted: the fault was
    there from the start, or the data do not match the model. A user trial's records in bar for
    Pa, with two columns swapped, or of another valve law were each diagnosed as faults "from
    0.04 s", with nothing to say the model and the data disagree from their first samples."""
    if det.time - p.first_trusted > START_WINDOWS * p.window_s:
        return None
    return (f"detected at t_D = {det.time:.4g} s, with the first samples judged (from {p.first_trusted:.4g} s): "
            "unless the fault began that early, these data may not match the model (a column's unit or order, a "
            "command's polarity, another model); a record of the same system in health tells")


WEAK_TYPE = 1.05   # a type decision margin up to this is barely decided (the report's "weak", or "fair" at its edge)


def unused_record(p: Prepared, d: Diagnosis) -> str | None:
    """The note when the fit is poorly determined while the record goes on for more than an
    identification window past the data it was fitted on (N samples from t_D, eqs. 30-31; a later
    decision's data to it): a prognosis whose RUL band is wider than the RUL, or a step in a winner
    whose type decision margin is at most WEAK_TYPE (a drift seen for one window passes for a step;
    a margin between two degradation models of a drift is the prognosis band's to say). A trial's elevator rope (1 kHz, N = 1000: 1 s of a 22 s
    drift) gave RUL 27 s in a band of 0 to 132 s, the whole record (``--samples``) 55.66 s for an
    EOL of 55.67 s; a gearbox's backlash growing by eq. (16) was typed a step on 1 s (margin 1.021),
    a drift (b 3 % off, EOL 56.50 s for 56.62 s) on 15 s. Not always the whole record: a trial's
    drone bearing was right on 10 s (EOL 71.44 s for 71.99) and worse on 60 s, where the battery's
    unmodelled voltage fall bought a second fault."""
    if d.detection is None or d.window is None:
        return None
    t_end, window = float(p.meas.t[-1]), p.samples * p.meas.ts
    fitted_to = float(d.window[1])
    if t_end - fitted_to <= window:
        return None
    whole = int(math.ceil((t_end - d.detection.time) / p.meas.ts))
    advice = (f"(identification windows of N = {p.samples} samples from the detection), the record goes on to "
              f"{t_end:.4g} s: --samples {whole} fits it on the whole record, a shorter N on part of it (a "
              f"long window also reads more of what the model leaves out)")
    wide = [g for g in d.prognosis if math.isfinite(g.rul) and g.rul > 0 and g.rul_high - g.rul_low > g.rul]
    if wide:
        return (f"{', '.join(g.name for g in wide)}'s RUL band is wider than the RUL: the drift is fitted on the data "
                f"to {fitted_to:.4g} s {advice}; bgfdi monitor refits it as data arrive")
    pool = d.episodes[-1].estimates if d.episodes else d.estimates      # (the final decision's)
    won = next((e for e in pool if d.winner is not None and tuple(e.candidate) == tuple(d.winner)), None)
    steps = [f.name for f in d.faults if f.type == "abrupt"]
    if won is not None and won.margin is not None and won.margin <= WEAK_TYPE and steps:
        return (f"{', '.join(steps)} typed a step, barely (type decision margin {won.margin:.3f}), on the data to "
                f"{fitted_to:.4g} s {advice} (a drift seen for one window can pass for a step)")
    return None


def with_samples(monitor: "Monitor", samples: int | None) -> "Monitor":
    """``monitor`` with the options' N as its configured N (``samples``; None keeps the file's): the
    window of identification and the unit of its degradation coefficients' bounds (W = N ts,
    fdi.objective), so that N given as an option and N given in the settings are one diagnosis
    (they gave eq. (16) and eq. (17) for one drift, a user trial at N = 15 000)."""
    if samples is None or samples == monitor.config.samples:
        return monitor
    return monitor.with_config(monitor.config.replace(samples=samples))


def with_overrides(monitor: "Monitor", thresholds: dict | None) -> "Monitor":
    """``monitor`` without the thresholds by mode of the residuals the options give one threshold
    (``--threshold ARR1=...``): those are monitored undivided, against that number."""
    tables = monitor.config.mode_thresholds
    given = {k: v for k, v in (thresholds or {}).items() if k in tables}
    return monitor.with_config(monitor.config.replace(thresholds=given)) if given else monitor


def prepare(monitor: "Monitor", meas: Measurements, o: Options) -> Prepared:
    """The monitor resolved for the data's sampling time, the data checked against the window
    the derivatives need, the thresholds (the file's, overridden by name), T_wt and N."""
    monitor, sc = with_overrides(with_samples(monitor, o.samples), o.thresholds).scaled(meas.ts)  # the prognosis' refits too
    model, config = monitor.model, monitor.config
    w = config.derivative_window
    check_samples(o.samples, meas.ts, min_period=sc.min_period)
    meas, spiked = despiked(model, meas, o.keep_spikes)
    settle = settling(o.settle, sc.settle)
    raw = signals_from_data(model, meas)
    check_derivative_window(model, w, meas.ts, meas.path)
    check_record_length(model, w, window_samples(w, meas.ts, DEFAULT_ORDER) + 1, meas.ts, meas.t.size, meas.path)
    if (stray := stray_error(model, config.thresholds, list(monitor.names))) is not None:
        raise stray
    try:
        thresholds = thresholds_for(config.thresholds, list(monitor.names), o.thresholds)
    except ValueError as exc:
        raise ModelError(str(exc), file=model.path, where="thresholds") from None
    check_judged(meas, sc, settle, o.settle is not None)
    read = "; ".join(n for n in (spiked, sampled_otherwise(model, meas), commands_read(model, meas, o.mode),
                                 started_late(meas, sc, o.settle)) if n) or None
    wait = config.waiting_time if o.waiting_time is None else o.waiting_time
    samples = o.samples or max(config.samples, sc.min_samples())     # N ts covers the shortest period
    weights = 1.0 / thresholds if o.weights == "thresholds" else np.ones(len(monitor.names))
    return Prepared(monitor, sc, meas, raw, thresholds, wait, samples, settle, weights, o, read)


SAMPLING_SLACK = 0.01   # a record's step this far (relative) from the file's data.sampling_time is named


def sampled_otherwise(model, meas: Measurements) -> str | None:
    """The note when the record's sampling time differs from the model file's ``data:
    sampling_time`` by over 1 %: the diagnosis follows the record (its windows and filters come from
    its own step), but what the file's time was used for does not (``check``'s noise prediction,
    the generated C monitor's filters), and a record decimated or stamped in the wrong unit looks
    just like this (a user trial: a record at 5 times the file's step, not a word)."""
    given = model.sampling_time
    if not given or abs(meas.ts - given) <= SAMPLING_SLACK * given:
        return None
    ratio = meas.ts / given
    unit = next((f", {ratio:.4g} times the file's: is the time column in {name}? (bgfdi reads seconds)"
                 for factor, name in ((1e3, "ms"), (1e6, "us"), (1 / 60, "minutes"), (1 / 3600, "hours"))
                 if abs(ratio - factor) <= SAMPLING_SLACK * factor), "")
    return (f"the record is sampled every {meas.ts:g} s, the model file's data.sampling_time is {given:g} s{unit}: "
            f"the diagnosis follows the record; check's noise prediction and generated code follow the file "
            f"(set it to {meas.ts:g} if the record is right)")


def commands_read(model, meas: Measurements, fixed=None) -> str | None:
    """The note when a mode's command column holds values other than 0 and 1: each sample is read
    as 1 from 0.5 up, 0 below (docs/model-format.md), which a column of 0 and 2, of percent or of a
    valve's opening in between reads without a word otherwise (a trial: a brake column of 2 and of
    0.5 read as engaged, silently). ``fixed``: the mode variables the options fix (their columns are
    not read)."""
    out = []
    for m in model.modes.values():
        if not m.column or m.column not in meas.columns or m.name in (fixed or {}):
            continue
        x = np.asarray(meas.columns[m.column], dtype=float)
        odd = np.flatnonzero(np.isfinite(x) & (x != 0.0) & (x != 1.0))
        if odd.size:
            k = int(odd[0])
            out.append(f"column {m.column} (mode {m.name}) holds values other than 0 and 1 ({odd.size} sample(s); "
                       f"at {meas.t[k]:g} s the first: {x[k]:g}): each is read as 1 from 0.5 up and 0 below; write the "
                       f"mode as 0 or 1 if that is not what it means")
    return "; ".join(out) or None


LATE_SHARE = 0.05       # a start-up settling that leaves this share of the record unjudged is named


def check_judged(meas: Measurements, sc: "Scales", settle: float, given: bool) -> None:
    """Refuse (DataError) a record that ends before detection starts: ``settle`` s after its
    start, and the derivative filter's edge before its end, leave no sample to judge, and "nothing
    detected" (exit 0, --fail-on-fault passed) would read as a healthy plant (the review: a 2 s
    record against a 2.8 s settling). ``given``: --settle set it."""
    span = float(meas.t[-1] - meas.t[0])
    if span > 0 and settle >= span - sc.end_edge:
        raise DataError(f"{meas.path}: the record ({span:.3g} s) ends before detection starts ({settle:.3g} s after "
                        f"its start, and the last {sc.end_edge:.3g} s are the derivative filter's edge): no sample "
                        f"can be judged; record longer, or shorten diagnosis.derivative_window"
                        + (" or --settle" if given else ""))


def started_late(meas: Measurements, sc: "Scales", given: float | None) -> str | None:
    """The note when detection starts late for the model's own reason: the start-up settling
    (:func:`fdi.scales.settle`: 7 decay times of the modes the derivative window cannot follow,
    longer than the filter's half window) leaves 5 % of the record or more unjudged. A fault that
    begins there is seen only as long as it lasts, and the onset estimated for one present from the
    start is the settling's end, so the report says where judging began and what would move it (a
    user trial: the first 3.5 s of a 10 s record skipped without a word). None when ``--settle``
    (``given``) set it as long or longer: the user chose it."""
    if sc.settle <= sc.window / 2 * (1 + 1e-9) or (given is not None and given >= sc.settle):
        return None
    span = float(meas.t[-1] - meas.t[0])
    if span <= 0 or sc.settle < LATE_SHARE * span:
        return None
    return (f"detection starts {sc.settle:.3g} s after the data start ({sc.settle / span:.0%} of the record): 7 decay times "
            f"({sc.settle / STARTUP_DECAYS:.3g} s each) of the modes the {sc.window:.3g} s derivative window cannot "
            f"differentiate, whose start-up transient would read as a fault; a fault before then is seen only as it "
            f"lasts (a shorter diagnosis.derivative_window in the model file starts it sooner)")


SPARSE = 0.5     # a record with more than this share of its samples left out at mode switches is noted


def _empty(p: Prepared, r: np.ndarray) -> tuple[list[str], np.ndarray | None]:
    """The residuals without a finite sample, and (with mode switches in the record) the samples the
    evaluator leaves out by design (:func:`fdi.residuals.designed_gaps`), else None."""
    finite = np.isfinite(r.reshape(len(p.monitor.names), -1))
    empty = [n for n, f in zip(p.monitor.names, finite) if not f.any()]
    designed = switch_gaps(p.monitor.model, p.monitor.residuals, p.raw, p.meas.t.size, p.window_s, p.meas.ts)
    return empty, designed


def never_finite(p: Prepared, r: np.ndarray, found: tuple | None = None) -> list[str]:
    """The residuals not finite on any sample for want of a law's value, not of samples (every
    stretch between mode switches shorter than the derivative window leaves none by design: that
    is :func:`blind`'s note). Such a residual never crosses its threshold: a diagnosis would read it
    as silent and isolate on the others (a trial's hoist, a damper written c f sqrt(f - 1000):
    the car's extra load diagnosed, exit 0, as a drifting friction), so the record is refused."""
    empty, designed = found or _empty(p, r)
    return [] if designed is not None and designed.all() else empty


def blind(p: Prepared, r: np.ndarray, found: tuple | None = None) -> str | None:
    """What to change when a residual has samples it cannot judge: with mode switches in the record,
    none at all when every stretch between two switches is shorter than the derivative window (its
    samples near a switch are left out by design); elsewhere, a residual that is not finite on some
    samples, where the record or a law overflows a double or leaves its domain (a value no sensor
    reads, an exponent through a parameter): no threshold judges those, so the report says so.
    ``found``: :func:`_empty`'s answer, when the caller has it."""
    names, t = p.monitor.names, p.meas.t
    finite = np.isfinite(r.reshape(len(names), -1))
    empty, designed = found or _empty(p, r)
    if designed is not None:
        # the samples the evaluator leaves out by design (fdi.residuals.designed_gaps) are not reported
        if empty and designed.all():
            return (f"{', '.join(empty)} had no sample: every stretch between two mode switches is shorter than the "
                    f"derivative window ({p.window_s:g} s); shorten diagnosis.derivative_window or sample faster")
        finite = finite | designed          # (a residual empty on long stretches too: not finite there, below)
    notes = []
    if designed is not None and designed.mean() > SPARSE:
        # most of the record left out by design: "nothing detected" there would read as healthy (a
        # thermostat's 20-minute stretches against a 2 232 s window: 8 of 2 881 samples judged)
        notes.append(f"only {int((~designed).sum())} of {t.size} samples have a residual: most stretches between mode "
                     f"switches are shorter than the derivative window ({p.window_s:g} s), whose half at each switch "
                     f"is left out; shorten diagnosis.derivative_window (bgfdi calibrate --window auto chooses one)")
    for n, f in zip(names, finite):      # (one with no finite sample at all: never_finite refuses the record)
        if n not in empty and f.any() and not f.all():
            bad = np.flatnonzero(~f)
            notes.append(f"{n} is not finite at {bad.size} sample(s) from {t[bad[0]]:g} s to {t[bad[-1]]:g} s: the "
                         "record holds values it overflows on or leaves its domain at there (no threshold judges "
                         "them)")
    return "; ".join(notes) or None


def mode_at(p: Prepared, det: Detection) -> dict[str, int]:
    """The mode at t_D: the options' mode variables, the commanded ones as commanded then, the
    others nominal."""
    return visited_modes(p, det.index, det.index)[0]


def decide(p: Prepared, d: Diagnosis, r: np.ndarray, clock: Clock, progress, memo) -> Diagnosis:
    """From a detection to the diagnosis: isolation, the fault mode, stuck sensors, then the
    estimators and everything after them."""
    clock.restart()
    fsm, iso = isolate(p, d.detection, d.mode, r)
    clock.lap("isolation")
    d = replace(d, isolation=iso)
    if iso.suspected:
        # the onsets the evidence allows (a mode fault switches in, and is dated, within them) and the
        # residuals' nominal level, each worked out once
        onsets = evidence_onsets(p.monitor, r, p.meas.t, p.thresholds, d.detection.time, p.first_trusted,
                                 switch_excursion(p, d.detection))
        mf = estimate_modes(p, d.detection, d.mode, iso.suspected, noise_floors(p, r, d.detection.time), onsets[1])
        clock.lap("mode estimation")
        d = replace(d, mode_fault=mf)
        nominal = nominal_cost(p, r, d.detection.time) if mf.faults else float("inf")

        def dated() -> ModeFault:        # the mode fault's switch dated, where it is the diagnosis
            return dated_mode_fault(p, d.detection, mf, onsets, r)
        if mf.faults and not iso.candidates and (
                explains(mf.cost, nominal)
                or not (p.options.exoneration and relaxed_sets(fsm, d.detection.final_coherence, p.options.max_set))):
            # the fault mode, where it explains the data or no set covers the coherence vector; else
            # the covering sets are fitted beside it and the criterion chooses (a heater element's
            # fault, seen in the current's residual alone before the thermal one joined, was named a
            # relay stuck open that left the residuals far above their noise: a user trial)
            mf = dated()
            return replace(d, mode_fault=mf, mode=dict(mf.mode), faults=mf.faults)
        level = nominal if iso.weak else float("inf")
        if explains(mf.cost, level) and not candidate_sets(p.monitor.fsm(d.mode), d.detection.final_coherence,
                                                           p.options.exoneration, p.options.max_set):
            # the mode change matches the coherence vector as it is; the sets only weak entries admit
            # would be identified to lose to it (a stuck valve: 8 sets, 16 s, for the same answer)
            note = (f"the fault mode explains the data ({mf.cost / level:.2g} times the residuals' nominal level): "
                    "the candidate sets that only weak entries admit were not identified")
            mf = dated()
            return replace(d, mode_fault=mf, isolation=replace(iso, candidates=(), pruned=0), mode=dict(mf.mode),
                           faults=mf.faults, note=_noted(d.note, note))
    if not iso.candidates and p.options.exoneration:
        relaxed = relaxed_sets(fsm, d.detection.final_coherence, p.options.max_set)
        if relaxed:
            d = replace(d, isolation=replace(iso, candidates=tuple(map(tuple, relaxed)), relaxed=True))
    d = stuck_sensors(p, d)
    if d.winner is not None or not d.candidates:
        return d
    try:
        check_window(p.meas, d.detection.time, p.samples, p.scales.min_period)
    except DataError as exc:                  # detected at the end of the data: reported, not identified
        why = str(exc).split(": ", 1)[-1]
        return replace(d, note=_noted(d.note, why))
    search = Search(p.options.engine, p.options.pop, p.options.generations)
    with Estimators(p.monitor, search, p.options.workers, memo, p.modes, p.prognosed) as est:
        return identify(p, d, fsm, r, est, clock, progress)


def isolate(p: Prepared, det: Detection, mode: dict[str, int], r: np.ndarray | None = None):
    """The MD-FSM in the mode at t_D (its weak entries removed when the data show a quiet residual
    could not have moved), the candidate sets of the final coherence vector, the sets too large to
    identify, and the MCSM's suspected mode changes."""
    o, m = p.options, p.monitor
    fsm = m.fsm(mode)
    weak = None
    if o.exoneration and m.config.exoneration == "sensitivity":   # a quiet residual exonerates only a fault that could have moved it
        fsm, weak = weakened(p, det, fsm, r)
    candidates = candidate_sets(fsm, det.final_coherence, o.exoneration, o.max_set)
    pruned = pruned_sets(fsm, det.final_coherence, o.exoneration, o.max_set)
    suspects = possible_mode_faults(m.model, suspected_mode_changes(m.mcsm(mode), det.final_coherence, p.covering))
    return fsm, Isolation(tuple(map(tuple, candidates)), tuple(suspects), int(pruned or 0),
                          o.max_set, False, weak)


def nominal_span(p: Prepared, t_d: float) -> np.ndarray | None:
    """The samples that show the residuals without the fault: trusted, before the detection less a
    derivative window (the filter's look-ahead); None when there are too few (a fault from the
    start) to say."""
    t = p.meas.t
    before = np.flatnonzero((t >= p.first_trusted) & (t < t_d - p.window_s))
    return before if before.size >= max(10, window_samples(p.window_s, p.meas.ts, DEFAULT_ORDER)) else None


def quiet_level(p: Prepared, r: np.ndarray | None, t_d: float) -> np.ndarray | None:
    """Each residual's peak |r| on the trusted data just before the detection (less a derivative
    window, the filter's look-ahead; over as many samples as the identification window, so that a
    long record's rare spike does not count): its noise and spikes without the fault; None when
    there are too few such samples (a fault from the start) to say, NaN for a residual with none."""
    before = None if r is None else nominal_span(p, t_d)
    if before is None:
        return None
    return np.fmax.reduce(np.abs(np.asarray(r)[:, before[-p.samples:]]), axis=1)      # NaN skipped, no warning


MEAN_OVER_MEDIAN = 1.1829   # mean |x| / median |x| of Gaussian noise: sqrt(2/pi) / 0.67449


def noise_floors(p: Prepared, r: np.ndarray | None, t_d: float) -> np.ndarray | None:
    """Each residual's noise floor, what a sample where it holds costs before its weight (the charge
    for a sample a mode hypothesis switches it off, :mod:`fdi.mode_estimation`): its mean |r| on
    the trusted samples before the detection (less a derivative window; the last identification
    window's worth) where its mode has it on, else its median |r| over every trusted sample where
    it is on (robust while the fault holds fewer than half of them) times Gaussian noise's mean over
    median (:data:`MEAN_OVER_MEDIAN`); NaN for a residual never on."""
    if r is None:
        return None
    r = np.abs(np.asarray(r, dtype=float))
    on = (r != 0) & np.isfinite(r)
    trusted = p.meas.t >= p.first_trusted
    before = nominal_span(p, t_d)
    floors = np.full(r.shape[0], np.nan)
    least = window_samples(p.window_s, p.meas.ts, DEFAULT_ORDER)
    for i in range(r.shape[0]):
        if before is not None and (k := before[-p.samples:][on[i, before[-p.samples:]]]).size >= least:
            floors[i] = float(r[i, k].mean())
        elif (k := np.flatnonzero(on[i] & trusted)).size:
            floors[i] = MEAN_OVER_MEDIAN * float(np.median(r[i, k]))
    return floors


def weakened(p: Prepared, det: Detection, fsm, r: np.ndarray | None = None):
    """The MD-FSM with the entries the data show weak removed (a quiet residual that the fault could
    not have moved over the identification window, :func:`fdi.sensitivity.weak_entries`), and those
    entries (fault -> residuals; None when there is none)."""
    m = p.monitor
    win = window(p.meas.t, p.raw, det.time, p.samples, p.window_s)
    entries = weak_entries(m.model, list(m.residuals), win.raw, p.meas.ts, p.window_s, fsm, det.final_coherence,
                           p.thresholds, win.crop, p.values(win.raw), quiet_level(p, r, det.time))
    if not entries:
        return fsm, None
    return effective(fsm, entries), {x.fault: tuple(sorted(y.residual for y in entries if y.fault == x.fault))
                                     for x in entries}


LACK_OF_FIT = 5.0   # a best fit whose cost is this many times the residuals' nominal level explains nothing


def explains(cost: float | None, level: float) -> bool:
    """Whether a fit of ``cost`` leaves the residuals within LACK_OF_FIT times their nominal level
    ``level`` (:func:`nominal_cost`; False where that level is unknown, inf)."""
    return cost is not None and np.isfinite(cost) and np.isfinite(level) and level > 0 and cost <= LACK_OF_FIT * level


def nominal_cost(p: Prepared, r: np.ndarray, t_d: float) -> float:
    """What noise alone costs over the identification window: N samples times the weighted mean
    |residual| of the trusted data before the detection (less a derivative window, the filter's
    look-ahead); inf when there are too few such samples (a fault from the start) to say."""
    before = nominal_span(p, t_d)
    if before is None:
        return float("inf")
    t = p.meas.t
    level = np.nanmean(np.abs(np.asarray(r)[:, before]), axis=1)
    return float(min(p.samples, t.size - int(np.searchsorted(t, t_d - 1e-9))) * np.dot(p.weights.reshape(-1), level))


def widen(p: Prepared, d: Diagnosis, fsm, r: np.ndarray, results: list, est: Estimators, onsets) -> tuple:
    """Exoneration (the paper's structural rule, or by sensitivity) kept while its candidate sets
    explain the data; when the best of them leaves residuals ``LACK_OF_FIT`` times their nominal
    level, a quiet residual exonerated the true fault: with the structural rule the sets a quiet
    residual could not have exonerated (weak entries, as ``exoneration: sensitivity`` finds them)
    are identified too; where there are none, or with exoneration by sensitivity (its weak entries
    are already out), the smallest sets covering the coherence vector. They compete on the same
    criterion. Measured on a closed-box loudspeaker (tests/test_domain_speaker.py): a microphone 20 %
    low left the cone's balance just under its threshold, the one exact set (a box leak) fitted 17
    times the nominal level; the covering set {beta_p} fits to the noise. On the CyCab (structural):
    an encoder gain beta_theta1 decaying from 15 s moves ARR1 too little to fire it in 45 s; the
    paper's {R4} left residuals 35 times the nominal level (cost 3 940) and was the diagnosis;
    beta_theta1 (signature [1 1 0]) fits to the noise (cost 105, b -0.05002 for -0.05). On the 43
    runs of the CyCab plant suite the best fit (or the fault mode) costs 0.6-2.0 times the nominal
    level but for three: a leak with a slow drift 4.8, the encoder drift of eq. (19) 5.5 (its
    paper's set {R4}), the drift above 33. Returns the diagnosis (isolation and note updated) and
    the results."""
    o, m, det = p.options, p.monitor, d.detection
    if not (o.exoneration and results):
        return d, results
    level = nominal_cost(p, r, det.time)
    mf = d.mode_fault if d.mode_fault is not None and d.mode_fault.faults else None
    best = min([e.cost for e in results] + ([mf.cost] if mf else []))
    if not best > LACK_OF_FIT * level:
        return d, results
    have, extra, weak, left = set(d.candidates), [], None, 0
    if m.config.exoneration == "structural":
        eff, weak = weakened(p, det, fsm, r)
        if weak:
            extra = [c for c in fitted_sets(m.model, candidate_sets(eff, det.final_coherence, True, o.max_set))
                     if c not in have]
    covering = not extra
    if covering:        # no new set from weak entries: the smallest sets covering the coherence vector,
        cols = [j for j, x in enumerate(det.final_coherence) if not x]     # nearest the vector first
        quiet = {row.fault: sum(row.nominal[j] for j in cols) for row in fsm.rows}
        extra = sorted((c for c in fitted_sets(m.model, relaxed_sets(fsm, det.final_coherence, o.max_set))
                        if c not in have), key=lambda c: sum(quiet.get(f, 0) for f in c))
        extra, left = extra[:MAX_COVERING], max(0, len(extra) - MAX_COVERING)
    if not extra and not (np.isfinite(best) and level > 0):
        return d, results             # (every fit infinite: identify's note says so)
    if not extra:                 # nothing more to try: the report says the best explains the data poorly
        note = (f"the best explanation left residuals {best / level:.3g} times their nominal level, and no other "
                "candidate set was left to try: a fault outside the candidates, or values no sensor reads in the "
                "record, near the detection")
        return replace(d, note=_noted(d.note, note)), results
    more = est.run(p.meas.t, p.raw, det.time, p.samples, extra, p.weights, o.seed + 104723, None, None,
                   [(det.time, onsets[1])] * len(extra))
    more = refit_early_onsets(est, p.meas.t, p.raw, det.time, p.samples, extra, more, p.weights, o.seed + 104723,
                              onsets, p.first_trusted, quiet=(p.thresholds, p.rule))
    ratio = best / level
    times = f"{ratio:.0f}" if ratio < 1e6 else f"{ratio:.3g}"        # a spike's: no 150-digit number
    tail = (COVERING_NOTE + (f" ({len(extra)} of them, the {left} whose faults enter more quiet residuals left out)"
                             if left else "") if covering else
            "sets a quiet residual could not have exonerated were identified too")
    note = f"the best explanation exoneration left had residuals {times} times their nominal level; {tail}"
    iso = replace(d.isolation, candidates=tuple(d.candidates) + tuple(extra), weak=weak or d.isolation.weak,
                  relaxed=d.isolation.relaxed or covering)
    return replace(d, isolation=iso, note=_noted(d.note, note)), list(results) + list(more)


MAX_COVERING = 6     # covering sets identified at most when the exact ones fit badly (each costs an estimator)


def switching(p: Prepared, det: Detection, suspect: str) -> bool:
    """Whether a suspected mode change's variable is commanded to switch within the identification
    window (a PWM switch, an ABS valve): the mode it should be in is then its command sample by
    sample, and a value held over the window is a switch stuck there (the fault-mode estimator's
    ``following``)."""
    model = p.monitor.model
    var = mode_variable(model, suspect)
    cmd = commanded(model, p.raw).get(var)
    if cmd is None or (p.options.mode and var in p.options.mode):
        return False
    i0 = int(np.searchsorted(p.meas.t, det.time - 1e-9))
    seen = np.asarray(cmd).reshape(-1)[i0:i0 + p.samples]
    return seen.size > 0 and bool(np.any(seen != seen[0]))


def estimate_modes(p: Prepared, det: Detection, mode: dict[str, int], suspects,
                   floors: np.ndarray | None = None, late: float | None = None) -> ModeFault:
    """The fault-mode estimator over the suspected mode variables (Sec. III-C), and the mode faults
    its estimate implies (none when it agrees with the mode at t_D); ``floors``: the residuals'
    noise floors (:func:`noise_floors`), charged where a mode switches a residual off; with
    ``late``, the latest onset the evidence allows a component fault (:func:`evidence_onsets`), each
    hypothesis switched in at its best sample from t_D to it, as :func:`dated_mode_fault` then dates it."""
    model = p.monitor.model
    win = window(p.meas.t, p.raw, det.time, p.samples, p.window_s)
    variables = sorted({mode_variable(model, s) for s in suspects})
    following = {v for v in variables if switching(p, det, v)}
    span = 0 if late is None else max(0, int(np.floor((late - det.time) / p.meas.ts + 1e-9)))
    e = estimate_mode(model, p.monitor.residuals, win, p.weights, p.options.seed, p.window_s, variables, p.modes,
                      floors, following, span)
    # no mode fault where no mode explains the data finitely (a sample of 1e308 the residuals
    # overflow on: every mode's cost infinite, and the first mode tried was named a stuck contactor)
    finite = e.cost is not None and np.isfinite(e.cost)
    estimate = dict(e.mode) if finite else {v: mode[v] for v in e.mode}     # no estimate: the mode at t_D
    # a switch commanded to switch is faulty where it stayed put (whatever its value at t_D), another
    # where its estimate is not its mode at t_D
    changed = [v for v in estimate if (finite and v in e.stuck) or (v not in following and estimate[v] != mode[v])]
    faults = tuple(faults_of({"name": mode_fault_name(model, v, estimate[v]), "type": "mode", "value": estimate[v]}
                             for v in changed))
    return ModeFault(estimate, e.cost, tuple(e.table or ()), faults, tuple(e.following) if finite else (),
                     tuple(e.ties) if finite and faults else ())


def stuck_sensors(p: Prepared, d: Diagnosis) -> Diagnosis:
    """A frozen sensor is confirmed by its signal, not fitted (:mod:`fdi.stuck`): the first single
    stuck candidate the data show wins; stuck faults the data do not show leave the candidates."""
    model = p.monitor.model
    if not any(model.faults[f].effect == "stuck" for c in d.candidates for f in c):
        return d
    for c in d.candidates:
        if len(c) == 1 and model.faults[c[0]].effect == "stuck":
            sensor = model.faults[c[0]].targets[0]
            found = stuck_from(model, c[0], p.meas.t, p.raw[sensor], d.detection.time,
                               float(d.detection.decision_time), p.window_s)
            if found is not None:
                return replace(d, faults=faults_of([{"name": c[0], "type": "stuck", "value": found.value,
                                                     "t0": found.onset}]), winner=(c[0],))
    return replace(d, isolation=replace(d.isolation, candidates=tuple(fitted_sets(model, d.candidates))))


def check_window(meas: Measurements, t0: float, samples: int, min_period: float = MIN_WINDOW_S) -> None:
    """The identification window (N samples from t_D, as fdi.objective.window cuts it) spans at least
    the shortest period searched: data that end just after the detection leave no period to search."""
    i0 = int(np.searchsorted(meas.t, t0 - 1e-9))
    span = min(samples, meas.t.size - i0) * meas.ts
    if span < min_period:
        raise DataError(f"{meas.path}: the data end {span:g} s after the detection at t_D = {t0:g} s; identification "
                        f"needs at least {min_period:g} s after t_D: record longer")


def switch_excursion(p: Prepared, det: Detection) -> float | None:
    """Where the excursion that confirmed the detection began (:attr:`fdi.detect.Detection.excursion`)
    when t_D's crossings, parted from it by a quiet run, came within a derivative window after a
    commanded or autonomous switch: the switch's transient, not the fault's start, so the onsets
    reach past the confirming excursion (:func:`fdi.estimators.evidence_onsets`); else None. A user
    trial's engine cooling: the fan switched on at 559.8 s, its residuals crossed for 4 s from 566 s,
    unconfirmed; the fan died at 600 s and its excursion confirmed; every onset searched ended at
    579 s, and a radiator fouling drift beat the dead fan. Crossings parted by a quiet run away
    from a switch are a slow drift's flicker about its threshold (a CyCab encoder drift): its
    onset lies before t_D, and a later bound only widens the search (measured: one of three such
    scenarios isolated better, one worse, on two seeds)."""
    if det.excursion is None:
        return None
    t = p.meas.t
    switches = t[mode_breaks(p.monitor.model, p.raw)]
    near = (switches <= det.time) & (switches >= det.time - p.window_s)
    end = det.time + (p.samples - 1) * p.meas.ts         # not past the identification window's data
    return min(det.excursion, end) if near.any() else None


def identify(p: Prepared, d: Diagnosis, fsm, r: np.ndarray, est: Estimators, clock: Clock, progress) -> Diagnosis:
    """One estimator per candidate set, the winner (or the fault mode), the later decisions, the
    significance check and the prognosis."""
    det, o, t = d.detection, p.options, p.meas.t
    clock.restart()
    earliest = p.first_trusted
    # onsets the evidence allows: from the first departure from a noise band (minus the filter's
    # look-ahead) to t_D plus the look-ahead; searched from t_D first, then back for a drift seen late
    onsets = evidence_onsets(p.monitor, r, t, p.thresholds, det.time, earliest, switch_excursion(p, det))
    ts = float(t[1] - t[0])
    results = est.run(t, p.raw, det.time, p.samples, list(d.candidates), p.weights, o.seed, progress, None,
                      [(det.time, onsets[1])] * len(d.candidates), None,
                      lambda i, e: steps_at_window_start(e, det.time, ts))
    results = refit_early_onsets(est, t, p.raw, det.time, p.samples, list(d.candidates), results, p.weights,
                                 o.seed, onsets, earliest, quiet=(p.thresholds, p.rule))
    d, results = widen(p, d, fsm, r, results, est, onsets)
    n_eff = effective_samples(p.samples, len(p.monitor.residuals), p.meas.ts, p.window_s)
    mf = d.mode_fault if d.mode_fault is not None and d.mode_fault.faults else None
    if mf is not None:
        mf = dated_mode_fault(p, det, mf, onsets, r)
        d = replace(d, mode_fault=mf)
    if mf is None and not any(np.isfinite(e.cost) for e in results):
        # every fit's residuals overflow (a sample no sensor reads, 1e308 in a record): detected and
        # isolated, not identified
        clock.lap("identification")
        note = (f"no candidate set's fit has a finite cost on the window from {det.time:g} s: the residuals "
                "overflow on these data (look for a value no sensor reads, or a spike, near the detection)")
        return replace(d, estimates=tuple(results), note=_noted(d.note, note))
    won = select_winner(results, n_eff)
    mode_faults = [f.to_dict() for f in mf.faults] if mf else []
    if mf is not None and information(mf.cost, mode_faults, n_eff) <= information(won.cost, list(won.faults), n_eff):
        # the fault mode explains the data better than any component fault once parameters are
        # charged (Sec. III-C's order, with the comparison the paper leaves implicit: a valve stuck
        # closed also looks like a clogged one, and a pair of component faults can over-fit the window)
        clock.lap("identification")
        return replace(d, estimates=tuple(results), mode=dict(mf.mode), faults=mf.faults,
                       alternatives=alternatives(results, mf.cost, mode_faults, n_eff, close=SAME_FIT,
                                                 coinciding=lambda: p.monitor.coinciding))
    # the winner's steps dated from the evidence before t_D (its estimator's entry too)
    best = date_onsets(est, t, p.raw, det.time, p.samples, won, p.weights, o.seed, onsets,
                       evidence_start(p.monitor, r, t, p.thresholds, earliest), earliest)
    best = step_onset_band(est, t, p.raw, best, p.thresholds, earliest, p.rule)
    best = drift_onset_band(est, t, p.raw, det.time, p.samples, best, p.weights, earliest)
    results = [best if e is won else e for e in results]
    clock.lap("identification")
    d = replace(d, estimates=tuple(results))
    extra = [Alternative(tuple(f["name"] for f in mode_faults), tuple(mode_faults), mf.cost, 0.0)] if mf else []
    d = replace(d, alternatives=alternatives(results, best.cost, list(best.faults), n_eff, extra, skip=best,
                                             coinciding=lambda: p.monitor.coinciding),
                faults=faults_of(best.faults), winner=tuple(best.candidate))
    d, now = later_decisions(p, d, fsm, r, est, clock, progress)
    return prognoses(p, significance(p, d, now, noise_floors(p, r, d.detection.time)), now, clock)


SAME_FIT = 0.01       # a component fault set that fits within this share of a winning fault mode's cost is listed
                      # beside it, whatever its parameters cost (a relief valve stuck open and a leak of its
                      # resistance: one physics on the data, the criterion alone +4 for the leak's value; the
                      # onsets of both are charged, fdi.criterion.parameters)
ONSET_GRID = 24        # a mode fault's onset: first on this many steps over its band, then to the sample


def dated_mode_fault(p: Prepared, det: Detection, mf: ModeFault, onsets: tuple[float, float],
                     r: np.ndarray) -> ModeFault:
    """The fault mode with its switch dated (:func:`fdi.mode_estimation.switched_at`): its mode faults'
    common onset searched over the band a component fault's is first searched over (t_D to the end
    of the filters' look-ahead, :func:`fdi.estimators.evidence_onsets`), on a coarse grid and then to
    the sample; its cost the lower of the best onset's and the estimator's (which switches each
    hypothesis at its best sample of the same band, :func:`estimate_modes`)."""
    ts, lo = p.meas.ts, det.time
    n = max(0, int(np.floor((max(lo, onsets[1]) - lo) / ts + 1e-9)))
    if n == 0:
        return mf
    win = window(p.meas.t, p.raw, lo, p.samples, p.window_s)
    switches, floors = [f.to_dict() for f in mf.faults], noise_floors(p, r, lo)
    step = max(1, -(-n // ONSET_GRID))
    cost, onset = switched_at(p.monitor, win, p.weights, [], switches, lo + ts * np.arange(0, n + 1, step), p.modes,
                              floors)
    if step > 1:
        k = int(round((onset - lo) / ts))
        fine = lo + ts * np.arange(max(0, k - step + 1), min(n, k + step - 1) + 1)
        cost, onset = min((cost, onset), switched_at(p.monitor, win, p.weights, [], switches, fine, p.modes, floors))
    if not np.isfinite(cost):
        return mf
    return replace(mf, cost=min(cost, mf.cost),
                   faults=faults_of({**f, "t0": onset, **held_band(p, f, onset)} for f in switches))


def held_band(p: Prepared, fault: dict, onset: float) -> dict:
    """A mode fault's ``t0_band`` where its variable's command (or an autonomous mode's condition)
    already held the stuck value before ``onset``: a valve stuck open while commanded open is the
    same plant, so the data cannot tell how long before it stuck (the two-tank valve stuck open from
    250 s, seen when the command closed it at 300 s, was dated 301 s with nothing said). The stretch
    is the last one held before the onset, if the command left the value less than two derivative
    windows before the onset (longer away, the data would have shown a fault already there); the
    band starts at its first sample (the record's first trusted sample if it starts the record).
    {} where the stretch is under two derivative windows, or the variable is neither commanded nor
    autonomous."""
    var = mode_variable(p.monitor.model, fault["name"])
    cmd = commanded(p.monitor.model, p.raw).get(var)
    if cmd is None:
        return {}
    t = p.meas.t
    held = np.broadcast_to((np.asarray(cmd, dtype=float) >= 0.5) == bool(fault["value"]), t.shape)
    k = int(np.searchsorted(t, onset - 1e-9))
    kept = np.flatnonzero(held[:k])
    if not kept.size or onset - t[kept[-1]] > 2 * p.window_s:
        return {}
    away = np.flatnonzero(~held[:kept[-1]])
    start = max(float(t[away[-1] + 1]) if away.size else float(t[0]), float(p.first_trusted))
    if onset - start < 2 * p.window_s:
        return {}
    return {"t0_band": [start, float(onset)]}


def later_decisions(p: Prepared, d: Diagnosis, fsm, r: np.ndarray, est: Estimators,
                    clock: Clock, progress: Callable | None = None) -> tuple[Diagnosis, float]:
    """Every later change of the latched coherence vector decided again T_wt after it
    (:func:`fdi.episodes.redecide`); the diagnosis follows the last. Returns it and the time of
    the data the final fit saw."""
    det, t = d.detection, p.meas.t
    i0 = int(np.searchsorted(t, det.time - 1e-9))
    now = float(t[i0]) + min(p.samples, t.size - i0) * float(t[1] - t[0])   # the first window's end
    clock.restart()
    lit, began = latched(r, t, p.thresholds, p.settle, p.scales.end_edge, *p.rule)
    j = int(np.searchsorted(t, det.decision_time, side="right")) - 1
    episodes = []
    faults = [f.to_dict() for f in d.faults]
    winner = d.winner
    mcsm = p.monitor.mcsm(d.mode)
    onsets = evidence_onsets(p.monitor, r, t, p.thresholds, det.time, p.first_trusted, switch_excursion(p, det))
    floors = noise_floors(p, r, det.time)
    misfits = 0
    while True:
        change = next_change(lit, j)
        seen_to = int(np.searchsorted(t, now - 1e-9))
        # (a lack of fit is looked for while the fit has seen less than the longest window a decision fits)
        short = seen_to - i0 < MAX_GROWTH * p.samples
        found = misfit_at(p, faults, seen_to, change) if misfits < MISFITS and short else None
        misfit = False
        if found is not None:
            # decided again on twice the data the fit saw since t_D (or the record's end), so that a
            # drift typed a step on one window is judged on a longer one, not on a few samples more
            twice = int(np.searchsorted(t, det.time + 2 * (now - det.time) - 1e-9))
            at = min(max(decision_index(t, found[0], p.wait), twice), t.size - 1)
            misfit = change is None or at < change          # (else the coherence change is decided first)
        if change is None and not misfit:
            break
        if misfit:                       # the fit no longer explains the data: decided again, same coherence
            misfits += 1
            (k, onset), j = found, at
            coherence = before = tuple(int(x) for x in lit[:, j])
        else:
            k, j = change, decision_index(t, change, p.wait)
            coherence = tuple(int(x) for x in lit[:, j])
            before = tuple(int(x) for x in lit[:, k - 1])
            joined = (lit[:, k] & ~lit[:, k - 1]).nonzero()[0]
            onset = int(min(began[joined])) if joined.size else k        # where the new excursion began
        changes = mode_changes_at(p, possible_mode_faults(p.monitor.model, new_mode_changes(mcsm, before, coherence,
                                                                                     p.covering)), onset, faults)
        now_fsm = over_modes([fsm] + [p.monitor.fsm(m) for m in visited_modes(p, i0, j) if m != d.mode])
        e = redecide(est, p.meas, p.raw, det, p.weights, p.options, now_fsm, faults, float(t[onset]), float(t[j]),
                     coherence, p.samples, len(episodes) + 1, changes, p.modes, onsets, p.first_trusted,
                     progress, floors, (p.thresholds, p.rule),   # (a later decision's sets: minutes on a model its data defy)
                     "misfit" if misfit else "coherence")
        episodes.append(e)
        faults, winner = list(e.faults), e.winner
        # the end of the data the decision fitted (redecide's window: from t_D at least N samples, so
        # past t[j] where it came within the first window; a prognosis is given there, not at t[j])
        start, span = decision_window(t, det.time, float(t[j]), p.samples, "misfit" if misfit else "coherence")
        now = start + span * float(t[1] - t[0])
    if episodes:
        clock.lap("re-diagnosis")
    switched = {mode_variable(p.monitor.model, f["name"]): int(f["value"]) for f in faults if f["type"] == "mode"}
    return replace(d, episodes=tuple(episodes), faults=faults_of(faults), winner=winner, mode={**d.mode, **switched},
                   window=(float(det.time), float(now))), now


MISFITS = 3          # decisions taken again for a lack of fit, at most, per diagnosis
MISFIT_BLOCK = 20    # identification windows of data judged at a time for a lack of fit


def misfit_at(p: Prepared, faults: list[dict], after: int, before: int | None,
              guard: bool = True) -> tuple[int, int] | None:
    """Where the decided fit stops explaining the data: the first sample from ``after`` (the end of
    the data it was fitted on) and before ``before`` (the next change of the coherence vector) at
    which the residuals, with the decided faults held at their fit, confirm an alarm by the
    detector's own rule (thresholds, persistence and span), and the sample that excursion began
    at; None where they stay quiet, the fit holds a mode fault, or (``guard``) it does not explain
    the last window of the data it saw (up to N samples before ``after``). A user trial's cylinder
    friction, growing for 20 s, was typed a step on the first window and reported so to the end
    of the record: no new residual fired, so nothing was decided again; decided again on 4 s, it
    was an oscillating eq. (19) drift, which the data after those 4 s refute as well."""
    if not faults or any(f["type"] == "mode" for f in faults):
        return None
    t, ts = p.meas.t, p.meas.ts
    stop = min(t.size if before is None else before, int(np.searchsorted(t, t[-1] - p.scales.end_edge, side="right")))
    persistence, span = p.rule
    n = max(1, evidence_samples(span, ts))
    model, w = p.monitor.model, p.window_s

    def alarms(lo: int, m: int) -> tuple[np.ndarray, np.ndarray]:
        """Evidence and confirmed alarms (residuals x samples) of the fit on samples lo .. lo + m."""
        win = window(t, p.raw, float(t[lo]), m, w)
        obj = Objective(model, p.monitor.residuals, win, (), p.weights, w, fixed=faults, config=p.monitor.config,
                        modes=p.modes)
        with np.errstate(all="ignore"):
            rows = np.vstack([np.asarray(x, dtype=float) for x in residual_rows(obj)])
        z = evidence(rows, p.thresholds, ts, ~obj.gaps[obj.crop()])
        return z, confirmed(z, n, persistence)

    if guard and not explains_own(p, faults, after):
        return None
    block, i = max(MISFIT_BLOCK * p.samples, 4 * n), after
    while i < stop:
        lo = max(after, i - n)                      # the evidence of the span before the block too
        m = min(block, stop - lo)
        if m <= 0:
            break
        z, c = alarms(lo, m)
        hit = c.any(axis=0)
        if hit.any():
            at = int(np.argmax(hit))
            return lo + at, lo + min(span_start(z[r], at, n) for r in np.flatnonzero(c[:, at]))
        i = lo + m
    return None


def refuted(monitor: "Monitor", meas: Measurements, d: Diagnosis, options: Options | None = None,
            since: float | None = None) -> bool | None:
    """Whether the samples of ``meas`` refute ``d``'s fit (:func:`misfit_at`): judged from ``since``
    (s; the records' samples before it give the filters their margin), or, None, from the end of
    the data the fit read, with its last window in ``meas`` to tell whether the fit explains its
    own data. None where no later sample can refute it: a fit with a mode fault or without a fault,
    or one that does not explain its own window. The streaming monitor asks this of the samples
    since it last asked, so each check reads the new samples once (a fit that keeps explaining the
    data costs a monitor the same per sample however long it runs)."""
    faults = [f.to_dict() for f in d.faults]
    if not faults or any(f["type"] == "mode" for f in faults) or d.window is None:
        return None
    o = replace(options or Options(), settle=0.0)      # (the samples may start anywhere in a record)
    p = prepare(monitor.with_config(o.settings), meas, o)
    t = p.meas.t
    persistence, span = p.rule
    after = int(np.searchsorted(t, (d.window[1] if since is None else since - span) - 1e-9))
    if since is None and not explains_own(p, faults, after):
        return None
    return misfit_at(p, faults, after, None, guard=False) is not None


def explains_own(p: Prepared, faults: list[dict], after: int) -> bool:
    """Whether the fit explains the last window of the data it read (up to N samples before sample
    ``after``, from its first onset): no confirmed alarm of its residuals there. A fit that does not
    explains nothing later either: no lack of fit to find (a trial's ABS on data that defy the model
    was decided again three times, minutes each)."""
    t = p.meas.t
    first = max(int(np.searchsorted(t, min(float(f.get("t0") or t[0]) for f in faults) - 1e-9)), after - p.samples)
    return first >= after or misfit_at(p, faults, first, after, guard=False) is None


def visited_modes(p: Prepared, i: int, j: int) -> list[dict[str, int]]:
    """The modes the record went through from sample ``i`` to ``j`` (included), as :func:`mode_at`
    reads one: the options' mode variables, the commanded and autonomous ones sample by sample, the
    others nominal; each once, in the order first met."""
    model, o = p.monitor.model, p.options
    base = dict(o.mode or nominal_mode(model))
    varying = {name: np.asarray(v[i:j + 1]).astype(int) for name, v in commanded(model, p.raw).items()
               if not o.mode or name not in o.mode}
    if not varying:
        return [base]
    names = list(varying)
    rows = np.stack([varying[n] for n in names], axis=1)
    _, first = np.unique(rows, axis=0, return_index=True)
    return [{**base, **{n: int(x) for n, x in zip(names, rows[k])}} for k in sorted(first)]


def possible_mode_faults(model, changes: list[str]) -> list[str]:
    """The suspected mode changes a fault can make: a commanded switch or one only a fault changes
    (the paper's mode faults, declared or not), and an autonomous one only where a declared mode fault
    holds it (a diode failing open). An autonomous variable is what its condition on the measured
    signals says: a trial's quarter car had its bump stop 'engaged' on a record with no contact, a
    hypothesis that switched every body residual off and cost less than the valve stuck soft."""
    held = {f.targets[0] for f in model.faults.values() if f.kind == "mode"}       # variables a declared fault holds
    return [s for s in changes if (var := mode_variable(model, s)) in held or not model.modes[var].autonomous]


def mode_changes_at(p: Prepared, suspects: list[str], k: int, known: list[dict]) -> list[tuple[str, int]]:
    """The mode faults (name, value) a later decision tries for the suspected mode changes: each
    variable to the other value than it has at sample ``k`` (as commanded, fixed, or nominal), one at
    a time as the paper assumes; none on a variable a known fault already switched."""
    model = p.monitor.model
    taken = {mode_variable(model, f["name"]) for f in known if f["type"] == "mode"}
    now = {**{m: int(model.modes[m].nominal) for m in model.modes}, **p.modes,
           **{m: int(v[k]) for m, v in commanded(model, p.raw).items()}}
    out = []
    for s in suspects:
        var = mode_variable(model, s)
        if var in taken:
            continue
        value = 1 - int(now[var])
        out.append((mode_fault_name(model, var, value), value))
    return list(dict.fromkeys(out))


def significance(p: Prepared, d: Diagnosis, now: float, floors: np.ndarray | None = None) -> Diagnosis:
    """The final faults that earn their parameters on the data since t_D, and the criterion's change
    without them all (:func:`fdi.decide.significant`); of two or more, those whose own effect stays
    below the residuals' noise floors (:func:`noise_floors`; the thresholds where a floor is unknown)."""
    start, span = since_detection(p.meas.t, d.detection.time, now, p.samples, MAX_GROWTH)
    levels = np.asarray(p.thresholds, dtype=float).reshape(-1)
    if floors is not None:
        levels = np.where(np.isfinite(floors) & (floors > 0), floors, levels)
    kept, dropped, without, left = significant(p.monitor, p.meas, p.raw, start, span,
                                                [f.to_dict() for f in d.faults], p.weights, p.modes,
                                                quiet=(levels, p.rule), healthy=healthy_stretch(p, d))
    d = replace(d, faults=faults_of(kept) if dropped else d.faults, insignificant=dropped or None,
                criterion_without=without)
    unexplained = None
    if left > UNEXPLAINED and p.options.weights == "thresholds":
        # (a trial's outdoor temperature at 1e300 on every row: two drifts at -600 /s reported, nothing said)
        unexplained = (f"the final fit leaves the residuals at {left:.3g} times their thresholds on average since the "
                       f"detection: no candidate explains these data; look for a column whose values no sensor or "
                       f"input reads (its unit or scale, a frozen or saturated channel) or a fault the model lacks")
    notes = [n for n in (unexplained, undetermined(p, d), at_bounds(p, d.faults), read_together(p, d)) if n]
    return replace(d, note=_noted(d.note, "; ".join(notes))) if notes else d


def read_together(p: Prepared, d: Diagnosis) -> str | None:
    """The note naming each final fault the residuals read only together with another declared
    fault not in the diagnosis (:attr:`fdi.monitor.Monitor.coinciding`), where no alternative
    already offers that pair: a change of either fits the data as well, so the name is where the
    search settled, not what the data say. A trial's hoist reported its drum bearing's friction
    drifting (the motor bearing's was), then a step of one beside a drift of the other; the
    residuals read the two only as bm + bd/N**2, and only a first decision's alternatives said so."""
    final = {f.name for f in d.faults if f.type != "mode"}
    if not final:
        return None
    offered = {frozenset(a.coincides.faults) for a in d.alternatives or () if a.coincides is not None}
    out = []
    for c in p.monitor.coinciding:
        for f, g in (c.faults, c.faults[::-1]):
            if f in final and g not in final and frozenset(c.faults) not in offered:
                out.append(f"{c.describe()}: a change of {g} fits these data as well as one of {f} (no data separate "
                           f"them; {f} is where the search settled)")
    return "; ".join(out) or None


def healthy_stretch(p: Prepared, d: Diagnosis) -> tuple[float, int] | None:
    """The start (s) and samples of the fault-free stretch before the detection and every final
    fault's onset (its earliest band's start), less a derivative window (:func:`nominal_span`), at
    most an identification window long; None when too short to judge."""
    first = min([d.detection.time] + [f.t0_band[0] if f.t0_band else f.t0 for f in d.faults
                                      if f.type != "mode" and f.t0 is not None])
    before = nominal_span(p, first)
    if before is None:
        return None
    n = min(p.samples, before.size)
    return float(p.meas.t[before[-n]]), n


UNEXPLAINED = 100.0   # a final fit leaving the residuals this many thresholds away on average explains nothing:
# measured over the test suite's 157 diagnoses, 1.7 at most where the fit is right but for a clogged orifice's
# 5.1 (thresholds at twice the nominal peak), 9.7 for a search too small to fit, 23 for an offset past its
# bounds; a record with an input at 1e300: 4e296


def undetermined(p: Prepared, d: Diagnosis) -> str | None:
    """The note when the data since t_D do not determine the final fit (the criterion without its
    faults under ``DETERMINED`` above the fit's): its numbers are not measurements. Where the detection
    came at a mode switch, it says that identification leaves those samples out (a departure seen
    only in switching transients: the derivative filter may not straddle a switch)."""
    if d.determined is not False:
        return None
    note = (f"the data since the detection do not determine the fit: the fault-free model explains them nearly "
            f"as well (criterion {d.criterion_without:+.2f}; {DETERMINED:g} or more is strong), so its values are not "
            f"reliable measurements (the fault may be another candidate, or sized far from its value)")
    t, det = p.meas.t, d.detection
    near = [float(t[i]) for i in mode_breaks(p.monitor.model, p.raw) if abs(float(t[i]) - det.time) <= p.window_s]
    if near:
        note += (f"; the detection came at a mode switch ({near[0]:g} s), whose samples identification leaves out "
                 f"(within half a derivative window of a switch): a fault seen only in switching transients is "
                 f"not sized there")
    return note + "; a longer record after the detection, or more excitation, would decide"


BOUND_SLACK = 1e-3      # a value within this share of its search range (of its decades, on a log range) is at a bound


def at_bounds(p: Prepared, faults) -> str | None:
    """The note naming the final faults whose value (abrupt, intermittent) sits at a bound of its
    search (:func:`fdi.objective.fault_space`): the data asked for a value the search did not
    allow, so the number is the bound, not a measurement, and the fault may be another one (a
    trial: a block of readings at 1e300 diagnosed as a cable stiffness and a load cell's gain,
    each at its bound; a pump leak intermittent at its bound beside a transducer's offset)."""
    out = []
    for f in faults:
        if f.type not in ("abrupt", "intermittent") or f.value is None or f.name not in p.monitor.model.faults:
            continue
        try:
            space = fault_space(p.monitor.model, f.name, config=p.monitor.config)
        except ModelError:
            continue
        lo, hi = space.bounds
        logged = space.log and lo > 0 and f.value > 0          # (a range from 0 is read linearly)
        where = ((np.log10(f.value) - np.log10(lo)) / (np.log10(hi) - np.log10(lo)) if logged
                 else (f.value - lo) / (hi - lo) if hi > lo else 0.5)
        side = "lower" if where <= BOUND_SLACK else "upper" if where >= 1 - BOUND_SLACK else None
        if side:
            out.append(f"{f.name}'s value {f.value:.5g} is at the {side} bound of its search [{lo:g}, {hi:g}]: the "
                       f"fit pressed against it, so the number is the bound's, not a measurement (if the bound is "
                       f"no physical limit, widen faults.{f.name}.bounds in the model; else suspect another fault)")
    return "; ".join(out) or None


def prognoses(p: Prepared, d: Diagnosis, now: float, clock: Clock) -> Diagnosis:
    """The end of life and RUL at ``now`` of every incipient fault with a failure value."""
    incipient = [f for f in d.faults if f.type == "incipient"]
    if not incipient or d.determined is False:        # (an undetermined drift's end of life is no forecast)
        return d
    clock.restart()
    t, o, model = p.meas.t, p.options, p.monitor.model
    t0 = float(t[int(np.searchsorted(t, d.detection.time - 1e-9))])
    out = []
    for f in incipient:
        failure = o.failures.get(f.name, p.monitor.config.failure(f.name))
        if failure is not None:
            out.append(Prognosis.from_dict(prognose(f.to_dict(), nominal(model, f.name), failure,
                                                    t0 if f.t0 is None else f.t0, now, p.meas.ts)))
    clock.lap("prognosis")
    return replace(d, prognosis=tuple(out))


MAX_REFIT = 20      # a prognosis refit uses at most this many identification windows of data


def refresh_prognosis(monitor: "Monitor", meas: Measurements, d: Diagnosis, options: Options | None = None,
                      memo: dict | None = None) -> tuple[tuple[dict, ...], tuple[Prognosis, ...]]:
    """The diagnosis' incipient faults refitted on the data since the detection up to the last
    sample (at most MAX_REFIT windows), the other faults held at their fit, and the prognosis from
    the refit at that time: a degradation seen longer is known better (the streaming monitor
    refreshes it as data arrive; ``bgfdi evaluate`` asks for it at 50 % and 90 % of a fault's
    life). Returns the faults and the prognosis; unchanged when there is no incipient fault with a
    failure value."""
    o = options or Options()
    p = prepare(monitor.with_config(o.settings), meas, o)
    faults = [f.to_dict() for f in d.faults]
    failures = {f["name"]: o.failures.get(f["name"], p.monitor.config.failure(f["name"])) for f in faults}
    growing = [f for f in faults if f["type"] == "incipient" and failures.get(f["name"]) is not None]
    if not growing or d.detection is None:
        return tuple(faults), d.prognosis
    others = [f for f in faults if f not in growing]
    start, span = since_detection(meas.t, d.detection.time, float(meas.t[-1]), p.samples, MAX_REFIT)
    t0 = min(f["t0"] for f in growing)
    w = p.window_s
    # the onset searched up to the decision's band for it, not only a window past its fit: a trial's
    # battery cell (R0 growing from 600 s, fitted from 544 s at the decision, band to 707 s) had every
    # refit pinned at 572.5 s, the true onset outside the band of every prognosis
    late = max([t0 + w] + [f["t0_band"][1] for f in growing if f.get("t0_band")])
    late = min(late, max(d.detection.time, t0 + w))
    search = Search(o.engine, o.pop, o.generations)
    with Estimators(p.monitor, search, 1, memo, p.modes, p.prognosed) as est:
        (result,) = est.run(meas.t, p.raw, start, span, [tuple(f["name"] for f in growing)], p.weights,
                            o.seed + 104729, None, [others], [(min(t0 - w, p.first_trusted), late)],
                            [[growing]])
    now = float(meas.t[-1])
    prognosis = tuple(Prognosis.from_dict(prognose(f, nominal(p.monitor.model, f["name"]), failures[f["name"]],
                                                   f["t0"], now, meas.ts))
                      for f in result.faults if f["type"] == "incipient")
    return tuple(others) + tuple(result.faults), prognosis


__all__ = ["run", "prepare", "Prepared", "refresh_prognosis", "refuted", "check_window", "mode_fault_name"]
