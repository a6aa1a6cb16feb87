"""The health-monitoring pipeline of Yu & Wang (2014), Sec. III: detect, isolate, identify, prognose.

data -> residuals -> detection (tD, coherence at tD + Twt) -> candidate sets (MD-FSM) and suspected
mode changes (MCSM) -> fault-mode estimator (BDE) when a mode change is suspected -> one
estimator per candidate set (parallel processes) -> the fittest -> prognosis of its incipient
faults. The result is the report dictionary whose JSON shape ``bgfdi diagnose --json`` prints.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Mapping

import numpy as np

from bondgraph.errors import ModelError
from optim import DEFAULT_ENGINE, ENGINES

from .errors import UsageError
from .data import DataError, Measurements, commanded, read_csv, signals_from_data
from .derivatives import DEFAULT_ORDER, window_samples
from . import scales
from .detect import detect, inconsistency, settling, thresholds_for, trusted
from .config import MonitorConfig
from .identify import Compiled, Objective, compiled, estimate_mode, nominal, run_estimators, window
from .isolate import candidate_sets, pruned_sets, relaxed_sets, suspected_mode_changes
from .prognose import prognose
from .residuals import evaluate
from .sensitivity import effective, weak_entries
from .stuck import stuck_from
from .signatures import fault_signature_matrix, mode_change_signature_matrix, nominal_mode


@dataclass
class Options:
    thresholds: Mapping[str, float] = field(default_factory=dict)
    waiting_time: float | None = None
    exoneration: bool = True
    max_set: int = 3                   # largest candidate set identified; larger ones are counted and reported
    engine: str = DEFAULT_ENGINE
    pop: int = 100
    generations: int = 150
    samples: int | None = None
    seed: int = 0
    workers: int = 1
    failures: Mapping[str, float] = field(default_factory=dict)
    weights: str = "thresholds"
    settle: float | None = None            # s ignored after the data start (None: half the derivative window)
    mode: Mapping[str, int] | None = None
    settings: MonitorConfig | None = None   # the monitor settings to use instead of the model file's

    def check(self) -> None:
        """Refuse settings that would crash a worker or give a nonsense diagnosis (a population
        too small for DE's mutation, no generation, a negative waiting time or threshold), with one
        line naming the field; the CLI checks its options the same way while parsing them."""
        if self.engine not in ENGINES:
            raise UsageError(f"Options.engine: unknown engine '{self.engine}' (use {', '.join(ENGINES)})")
        _whole("pop", self.pop, MIN_POP, MAX_POP)
        _whole("generations", self.generations, 1, MAX_GENERATIONS)
        _whole("workers", self.workers, 1)
        _whole("seed", self.seed, 0)
        _whole("max_set", self.max_set, 1, 6)
        if self.samples is not None:
            _whole("samples", self.samples, MIN_SAMPLES)
        if self.waiting_time is not None:
            _real("waiting_time", self.waiting_time, 0.0)
        for name, value in self.thresholds.items():
            _real(f"thresholds[{name}]", value, 0.0, strict=True)
        for name, value in self.failures.items():
            _real(f"failures[{name}]", value)


MIN_POP = 4                # DE's mutation takes three other members of the population
MAX_POP = 100_000          # a population is held in memory: 100 000 members is far past the paper's 100
MAX_GENERATIONS = 1_000_000
MIN_SAMPLES = 2            # N samples from t_D: fewer leave nothing to fit
MIN_WINDOW_S = 0.5         # s: the CyCab's shortest period (scales.min_period of its 0.25 s window), for callers without a model


def min_samples(ts: float, min_period: float = MIN_WINDOW_S) -> int:
    """The fewest identification samples N for data sampled every ``ts`` s: N * ts must reach the
    shortest intermittent period searched (:func:`fdi.scales.min_period`), or the period's search
    interval would be empty."""
    n = max(MIN_SAMPLES, math.ceil(min_period / ts))
    while n * ts < min_period:
        n += 1
    return n


def check_samples(samples: int | None, ts: float, option: str = "Options.samples",
                  min_period: float = MIN_WINDOW_S) -> None:
    """``samples`` (None: the model's) spans at least ``min_period`` of data sampled every ``ts`` s."""
    if samples is not None and samples < min_samples(ts, min_period):
        raise UsageError(f"{option}: must be at least {min_samples(ts, min_period)} for data sampled every {ts:g} s "
                         f"(N * t_s >= {min_period:g} s, the shortest intermittent period identified), got {samples}")


def scales_for(path: str, o: "Options", ts: float) -> tuple["Options", "scales.Scales"]:
    """``o`` with the monitor settings the model file leaves to the data filled in (its derivative
    window and waiting time, :func:`fdi.scales.resolve`), and the time scales of the diagnosis."""
    c = compiled_for(path, o.settings)
    config = scales.resolve(c.config, c.model, ts)
    if config is not c.config:
        o = replace(o, settings=config)
    return o, scales.for_model(c.model, config, ts)


def _whole(name: str, value, low: int, high: int | None = None) -> None:
    """``value`` is an int in [low, high]; else a UsageError naming ``Options.<name>``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low \
            or (high is not None and value > high):
        span = f">= {low}" if high is None else f"from {low} to {high}"
        raise UsageError(f"Options.{name}: must be an integer {span}, got {value!r}")


def _real(name: str, value, low: float | None = None, strict: bool = False) -> None:
    """``value`` is a finite number, >= ``low`` (> with ``strict``); else a UsageError."""
    ok = not isinstance(value, bool) and isinstance(value, (int, float, np.number)) and bool(np.isfinite(value))
    if ok and low is not None:
        ok = value > low if strict else value >= low
    if not ok:
        bound = "" if low is None else f" {'>' if strict else '>='} {low:g}"
        raise UsageError(f"Options.{name}: must be a finite number{bound}, got {value!r}")


def diagnose(model_path: str | Path, data: str | Path | Measurements, options: Options | None = None,
             progress=None, memo: dict | None = None) -> dict:
    """Run the whole pipeline; returns the report (plus private keys starting with '_' for plots)."""
    o = options or Options()
    o.check()
    timings: dict[str, float] = {}
    clock = time.perf_counter()
    path = str(model_path)
    compiled_for(path, o.settings)                  # the model checked before the data are read
    meas = data if isinstance(data, Measurements) else read_csv(data)
    o, sc = scales_for(path, o, meas.ts)            # the file's times, else the data's and the model's
    c = compiled_for(path, o.settings)
    model, config, arrs, residuals = c.model, c.config, c.arrs, c.residuals
    w = config.derivative_window
    check_samples(o.samples, meas.ts, min_period=sc.min_period)
    raw = signals_from_data(model, meas)
    need = window_samples(w, meas.ts, DEFAULT_ORDER) + 1
    if meas.t.size < need:
        raise DataError(f"{meas.path}: {meas.t.size} samples are too few: the derivative window of {model.name} "
                        f"({w:g} s) needs at least {need}")
    names = [a.name for a in arrs]
    try:
        thresholds = thresholds_for(config.thresholds, names, o.thresholds)
    except ValueError as exc:
        raise ModelError(str(exc), file=model.path, where="thresholds") from None
    wait = config.waiting_time if o.waiting_time is None else o.waiting_time
    samples = o.samples or max(config.samples, sc.min_samples())     # N ts covers the shortest period
    timings["load"] = time.perf_counter() - clock
    clock = time.perf_counter()
    r = evaluate(model, list(residuals), raw, meas.ts, window=w, values=commanded(model, raw))
    timings["residuals"] = time.perf_counter() - clock
    settle = settling(o.settle, sc.settle)
    det = detect(r, meas.t, thresholds, wait, settle, sc.end_edge)
    mode = dict(o.mode or nominal_mode(model))
    report: dict = {"detection": None, "mode": mode, "candidates": [], "estimators": [],
                    "diagnosis": {"faults": []}, "prognosis": [],
                    "_residuals": r, "_t": meas.t, "_thresholds": thresholds, "_names": names, "_timings": timings}
    blind = [n for n, row in zip(names, r.reshape(len(names), -1)) if not np.isfinite(row).any()]
    if blind:            # fast switching leaves no whole derivative window between two switches
        report["note"] = (f"{', '.join(blind)} had no sample: every stretch between two mode switches is shorter "
                          f"than the derivative window ({w:g} s); shorten diagnosis.derivative_window or sample faster")
    if det is None:
        return report
    report["detection"] = {"time": det.time, "coherence": list(det.coherence), "decision_time": det.decision_time,
                           "final_coherence": list(det.final_coherence)}
    for name, values in commanded(model, raw).items():      # the mode the controller commands at t_D
        if not o.mode or name not in o.mode:
            mode[name] = int(values[det.index])
            report["mode"] = mode
    clock = time.perf_counter()
    fsm = fault_signature_matrix(model, list(arrs), mode)
    mcsm = mode_change_signature_matrix(model, list(arrs), mode)
    if o.exoneration and config.exoneration == "sensitivity":   # a quiet residual exonerates only a fault that could have moved it
        win = window(meas.t, raw, det.time, samples, w)
        weak = weak_entries(model, list(residuals), win.raw, meas.ts, w, fsm, det.final_coherence, thresholds,
                            win.crop, commanded(model, win.raw))
        if weak:
            fsm = effective(fsm, weak)
            report["weakly_detectable"] = {x.fault: sorted(y.residual for y in weak if y.fault == x.fault)
                                           for x in weak}
    candidates = candidate_sets(fsm, det.final_coherence, o.exoneration, o.max_set)
    pruned = pruned_sets(fsm, det.final_coherence, o.exoneration, o.max_set)
    if pruned:
        report["pruned"] = {"max_set": o.max_set, "sets": pruned}
    suspects = suspected_mode_changes(mcsm, det.final_coherence)
    report["candidates"] = [list(c) for c in candidates]
    report["suspected_mode_changes"] = suspects
    timings["isolation"] = time.perf_counter() - clock
    weights = 1.0 / thresholds if o.weights == "thresholds" else np.ones(len(names))
    mode_fault = None
    if suspects:
        clock = time.perf_counter()
        win = window(meas.t, raw, det.time, samples, w)
        by_fault = {f.name: f.targets[0] for f in model.faults.values() if f.kind == "mode"}
        variables = sorted({by_fault.get(m, m) for m in suspects})
        estimate = estimate_mode(model, residuals, win, weights, o.seed, w, variables)
        estimated, mode_cost = estimate.mode, estimate.cost
        timings["mode estimation"] = time.perf_counter() - clock
        report["mode_estimate"] = estimated
        if estimate.table:
            report["mode_costs"] = estimate.table
        changed = [m for m in estimated if estimated[m] != mode[m]]
        if changed:
            mode_fault = {"mode": estimated, "cost": mode_cost,
                          "faults": [{"name": mode_fault_name(model, m, estimated[m]), "type": "mode",
                                      "value": estimated[m]} for m in changed]}
            report["mode_fault_cost"] = mode_cost
            if not candidates:
                report["mode"] = estimated
                report["diagnosis"]["faults"] = mode_fault["faults"]
                return report
    if not candidates and o.exoneration:
        candidates = relaxed_sets(fsm, det.final_coherence, o.max_set)
        if candidates:
            report["candidates"] = [list(c) for c in candidates]
            report["exoneration_relaxed"] = True
    if any(model.faults[f].effect == "stuck" for c in candidates for f in c):
        # a frozen sensor: confirmed by its signal, not fitted (fdi.stuck); a stuck fault that the
        # data do not show leaves the candidates
        end = float(det.decision_time)
        for c in candidates:
            if len(c) == 1 and model.faults[c[0]].effect == "stuck":
                sensor = model.faults[c[0]].targets[0]
                found = stuck_from(model, c[0], meas.t, raw[sensor], det.time, end, w)
                if found is not None:
                    report["diagnosis"]["faults"] = [{"name": c[0], "type": "stuck", "value": found.value,
                                                      "t0": found.onset}]
                    report["winner"] = [c[0]]
                    return report
        candidates = [c for c in candidates if not any(model.faults[f].effect == "stuck" for f in c)]
        report["candidates"] = [list(c) for c in candidates]
    if not candidates:
        return report
    try:
        check_window(meas, det.time, samples, sc.min_period)
    except DataError as exc:                  # detected at the end of the data: reported, not identified
        report["note"] = str(exc).split(": ", 1)[-1]
        return report
    clock = time.perf_counter()
    settings = {"engine": o.engine, "pop": o.pop, "generations": o.generations, "config": o.settings}
    results = run_estimators(path, meas.t, raw, det.time, samples, candidates, weights, settings, o.seed,
                             o.workers, progress, memo=memo)
    # a drift may have started long before it crossed a threshold: its onset is searched back to the
    # start of the data (after the settling time)
    lookback = max(wait, det.time - float(meas.t[0]) - settle)
    results = refit_early_onsets(path, meas, raw, det.time, samples, candidates, results, weights, settings, o,
                                 lookback, memo)
    timings["identification"] = time.perf_counter() - clock
    report["estimators"] = [{"candidate": list(e.candidate), "fitness": e.fitness, "history": e.history,
                             "margin": e.margin, "cost": e.cost, "faults": e.faults, "evaluations": e.evaluations,
                             "wall_s": e.wall_s, "objective_s": e.objective_s} for e in results]
    n_eff = effective_samples(samples, len(residuals), meas.ts, w)
    best = select_winner(results, n_eff)
    if mode_fault is not None and (information(mode_fault["cost"], mode_fault["faults"], n_eff)
                                   <= information(best.cost, best.faults, n_eff)):
        # the fault mode explains the data better than any component fault once parameters are
        # charged (Sec. III-C's order, with the comparison the paper leaves implicit: a valve stuck
        # closed also looks like a clogged one, and a pair of component faults can over-fit the window)
        report["mode"] = mode_fault["mode"]
        report["diagnosis"]["faults"] = mode_fault["faults"]
        report["alternatives"] = alternatives(results, mode_fault, n_eff)
        return report
    report["alternatives"] = alternatives(results, {"cost": best.cost, "faults": best.faults}, n_eff, mode_fault,
                                          skip=best)
    report["diagnosis"]["faults"] = best.faults
    report["winner"] = list(best.candidate)
    win = window(meas.t, raw, det.time, samples, w)
    now = win.t0 + (win.crop.stop - win.crop.start) * win.ts
    clock = time.perf_counter()
    report["episodes"] = []
    lit = latched(r, meas.t, thresholds, det.index, settle, sc.end_edge)
    j = int(np.searchsorted(meas.t, det.decision_time, side="right")) - 1
    while (change := next_change(lit, j)) is not None:
        k, j = change, decision_index(meas.t, change, wait)
        coherence = tuple(int(x) for x in lit[:, j])
        episode = redecide(path, meas, raw, det, weights, settings, o, fsm, report["diagnosis"]["faults"],
                           float(meas.t[k]), float(meas.t[j]), coherence, samples, len(report["episodes"]) + 1, memo,
                           wait)
        report["episodes"].append(episode)
        report["diagnosis"]["faults"] = episode["faults"]
        report["winner"] = episode["winner"]
        now = float(meas.t[j])
    if report["episodes"]:
        timings["re-diagnosis"] = time.perf_counter() - clock
    report["window"] = [float(det.time), float(now)]          # the data the final fit saw, in s
    kept, dropped = significant(path, meas, raw, det.time, now, samples, report["diagnosis"]["faults"], weights,
                                o.settings)
    if dropped:
        report["diagnosis"]["faults"] = kept
        report["insignificant"] = dropped
    incipient = [f for f in report["diagnosis"]["faults"] if f["type"] == "incipient"]
    if incipient:
        clock = time.perf_counter()
        for f in incipient:
            failure = o.failures.get(f["name"], config.failure(f["name"]))
            if failure is None:
                continue
            report["prognosis"].append(prognose(f, nominal(model, f["name"]), failure, f.get("t0", win.t0), now))
        timings["prognosis"] = time.perf_counter() - clock
    return report


def compiled_for(path: str, settings: MonitorConfig | None) -> Compiled:
    """The compiled model file, with ``settings`` in place of the file's monitor settings when given."""
    c = compiled(path)
    return c if settings is None else replace(c, config=settings)


def mode_fault_name(model, variable: str, value: int) -> str:
    """The model's mode fault that puts ``variable`` at ``value`` (a valve stuck closed, or one stuck
    open), else the first fault on the variable, else the variable itself."""
    on = [f for f in model.faults.values() if f.kind == "mode" and f.targets[0] == variable]
    exact = [f for f in on if (0 if f.value is None else int(f.value)) == int(value)]
    return (exact or on)[0].name if on else variable


def latched(r: np.ndarray, t: np.ndarray, thresholds: np.ndarray, start: int, settle: float,
            edge: float = 0.0) -> np.ndarray:
    """The coherence vector latched from sample ``start`` (the detection) on, at every sample."""
    bad = inconsistency(r, thresholds) & trusted(t, settle, edge)[None, :]
    bad[:, :start] = False
    return np.maximum.accumulate(bad, axis=1)


def next_change(lit: np.ndarray, j: int) -> int | None:
    """The first sample after ``j`` where the latched coherence gains a residual, or None."""
    later = np.flatnonzero((lit[:, j + 1:] != lit[:, j:j + 1]).any(axis=0))
    return int(j + 1 + later[0]) if later.size else None


def decision_index(t: np.ndarray, k: int, wait: float) -> int:
    """The sample of the decision for a change at sample ``k``: the waiting time later, or the last."""
    return max(k, min(t.size - 1, int(np.searchsorted(t, t[k] + wait, side="right")) - 1))


def significant(path: str, meas: Measurements, raw: dict, t_d: float, now: float, samples: int,
                faults: list[dict], weights: np.ndarray,
                settings: MonitorConfig | None = None) -> tuple[list[dict], list[dict]]:
    """The faults of a final diagnosis that earn their parameters on the data since the detection,
    and those that do not. Each fault is held at its fit and removed in turn; while the information
    criterion is no worse without one, the least useful goes (a first decision's fault that a later
    one made redundant: measured on the CyCab second-fault run, beta_theta1 at 1.0006 that a
    transient of ARR1 had asked for). A fault that is structurally needed but numerically a no-op
    is reported apart, not hidden."""
    c = compiled_for(path, settings)
    model, residuals, w = c.model, c.residuals, c.config.derivative_window
    start, span = since_detection(meas.t, t_d, now, samples, MAX_GROWTH)
    win = window(meas.t, raw, start, span, w)
    n_eff = effective_samples(span, len(residuals), meas.ts, w)

    def cost(fs: list[dict]) -> float:
        return Objective(model, residuals, win, (), weights, w, fixed=fs, config=c.config).constant()
    kept, dropped = [f for f in faults if f["type"] != "mode"], []
    modes = [f for f in faults if f["type"] == "mode"]
    while len(kept) > 1:
        current = information(cost(kept), kept, n_eff)
        trials = [(information(cost([g for g in kept if g is not f]), [g for g in kept if g is not f], n_eff), f)
                  for f in kept]
        best, f = min(trials, key=lambda x: x[0])
        if best > current:
            break
        kept = [g for g in kept if g is not f]
        dropped.append({**f, "criterion_without": best - current})
    return modes + kept, dropped


REFIT_REACH = 2.5   # a refit with an earlier onset lowered a biased drift's cost 4-fold (581 -> 133, best 308)


def refit_early_onsets(path: str, meas: Measurements, raw: dict, t_d: float, samples: int, candidates: list,
                       results: list, weights: np.ndarray, settings: dict, o: Options, lookback: float,
                       memo: dict | None = None) -> list:
    """Estimators fitted with their onset at t_D, the earliest the search allows, refitted from
    their fit (and the structures one decision away: an abrupt fault may be a drift seen late) with
    the onset free up to ``lookback`` before t_D (back to the data's start); the better fit is kept. A slow drift crosses its threshold well after it starts, and fitted
    from t_D on, its rate comes out biased while spurious extra faults absorb the rest (measured: a
    beta_theta2 drift from 20 s, detected at 22.5 s: b2 -0.042 for -0.03, and {R4, R5, beta_theta2}
    won; refitted: b2 -0.0298, onset 19.98 s, and beta_theta2 alone wins). Only fits within
    REFIT_REACH of the best cost are refitted, and only these: a wider
    onset range for every fit makes an intermittent fault's phase far harder to find."""
    ts = float(meas.t[1] - meas.t[0])
    best = min(e.cost for e in results)
    redo = [i for i, e in enumerate(results) if e.faults and min(f["t0"] for f in e.faults) <= t_d + 1.5 * ts
            and e.cost <= REFIT_REACH * best]
    if not redo or lookback <= 0:
        return results
    window_s = compiled_for(path, o.settings).config.derivative_window
    refits = run_estimators(path, meas.t, raw, t_d, samples, [candidates[i] for i in redo], weights, settings,
                            o.seed + 15485863, o.workers, None, None, [(t_d - lookback, t_d + window_s)] * len(redo),
                            [[results[i].faults] for i in redo], memo)
    out = list(results)
    for i, r in zip(redo, refits):
        if r.cost < out[i].cost:
            out[i] = replace(r, evaluations=r.evaluations + out[i].evaluations, history=out[i].history + r.history)
    return out


def since_detection(t: np.ndarray, t_d: float, end: float, samples: int, cap: int) -> tuple[float, int]:
    """(start, samples) of the window from the detection t_D to ``end`` (at least ``samples`` long,
    at most ``cap`` identification windows, keeping the latest data when capped)."""
    i0 = int(np.searchsorted(t, t_d - 1e-9))
    i1 = int(np.searchsorted(t, end, side="right"))
    span = min(max(samples, i1 - i0), cap * samples, t.size - i0)
    return float(t[max(i0, min(i1, t.size) - span)]), span


MAX_GROWTH = 6      # a re-decision fits at most this many times the identification window


def redecide(path: str, meas: Measurements, raw: dict, det, weights: np.ndarray, settings: dict, o: Options,
             fsm, known: list[dict], t_change: float, t_decision: float, coherence: tuple[int, ...],
             samples: int, episode: int, memo: dict | None = None, wait: float = 0.0) -> dict:
    """A later decision: the coherence vector gained a residual at ``t_change`` after the diagnosis
    ``known`` was made. Candidate sets come from the new coherence vector; every set is fitted on
    the data since the first onset (t_D to the new decision, at most MAX_GROWTH windows), so their
    costs compare. A set that contains the known faults is fitted twice: keeping them at their fit,
    each with its own onset, while the others are searched with an onset at the change (a second
    fault), and afresh with one onset (a slow fault seen late); a set no larger than the known one
    is fitted afresh (the first decision may have been wrong); all start from the known fit.
    Larger sets that drop a known fault are not tried. The winner is chosen as at the first
    decision."""
    c = compiled_for(path, o.settings)
    w = c.config.derivative_window
    names = {f["name"] for f in known}
    plan = []
    for s in candidate_sets(fsm, coherence, o.exoneration, o.max_set):
        if names < set(s):
            plan.append((tuple(x for x in s if x not in names), known, (t_change, t_change + w)))
        if names < set(s) or len(s) <= len(names):
            plan.append((tuple(s), [], None))
    start, span = since_detection(meas.t, det.time, t_decision, samples, MAX_GROWTH)
    results = run_estimators(path, meas.t, raw, start, span, [p[0] for p in plan], weights, settings,
                             o.seed + 7919 * episode, o.workers, None, [p[1] for p in plan], [p[2] for p in plan],
                             [[known] for _ in plan], memo)
    full = [replace(e, candidate=tuple(f["name"] for f in p[1]) + e.candidate, faults=list(p[1]) + e.faults)
            for e, p in zip(results, plan)]
    n_eff = effective_samples(span, len(c.residuals), meas.ts, w)
    best = select_winner(full, n_eff)
    return {"time": t_change, "decision_time": t_decision, "coherence": list(coherence), "previous": known,
            "candidates": [list(e.candidate) for e in full],
            "estimators": [{"candidate": list(e.candidate), "fitness": e.fitness, "margin": e.margin, "cost": e.cost,
                            "faults": e.faults, "evaluations": e.evaluations, "wall_s": e.wall_s,
                            "objective_s": e.objective_s} for e in full],
            "winner": list(best.candidate), "faults": best.faults}


MAX_REFIT = 20      # a prognosis refit uses at most this many identification windows of data


def refresh_prognosis(path: str, meas: Measurements, report: dict, options: Options | None = None,
                      memo: dict | None = None) -> tuple[list[dict], list[dict]]:
    """The diagnosis' incipient faults refitted on the data since the detection up to the last
    sample (at most MAX_REFIT windows), the other faults held at their fit, and the prognosis from
    the refit at that time: a degradation seen longer is known better (the monitor refreshes it as
    data arrive; ``bgfdi evaluate`` asks for it at 50 % and 90 % of a fault's life). Returns the
    faults and the prognosis; unchanged when there is no incipient fault with a failure value."""
    o, sc = scales_for(path, options or Options(), meas.ts)
    faults = list(report["diagnosis"]["faults"])
    c = compiled_for(path, o.settings)
    model, config, arrs = c.model, c.config, c.arrs
    failures = {f["name"]: o.failures.get(f["name"], config.failure(f["name"])) for f in faults}
    growing = [f for f in faults if f["type"] == "incipient" and failures.get(f["name"]) is not None]
    if not growing or report.get("detection") is None:
        return faults, list(report.get("prognosis", []))
    others = [f for f in faults if f not in growing]
    names = [a.name for a in arrs]
    thresholds = thresholds_for(config.thresholds, names, o.thresholds)
    weights = 1.0 / thresholds if o.weights == "thresholds" else np.ones(len(names))
    samples = o.samples or max(config.samples, sc.min_samples())
    raw = signals_from_data(model, meas)
    start, span = since_detection(meas.t, report["detection"]["time"], float(meas.t[-1]), samples, MAX_REFIT)
    t0 = min(f["t0"] for f in growing)
    w = config.derivative_window
    settings = {"engine": o.engine, "pop": o.pop, "generations": o.generations, "config": o.settings}
    (result,) = run_estimators(path, meas.t, raw, start, span, [tuple(f["name"] for f in growing)], weights,
                               settings, o.seed + 104729, 1, None, [others], [(t0 - w, t0 + w)], [[growing]], memo)
    refit = others + result.faults
    now = float(meas.t[-1])
    prognosis = [prognose(f, nominal(model, f["name"]), failures[f["name"]], f["t0"], now)
                 for f in result.faults if f["type"] == "incipient"]
    return refit, prognosis


def check_window(meas: Measurements, t0: float, samples: int, min_period: float = MIN_WINDOW_S) -> None:
    """The identification window (N samples from t_D, as identify.window cuts it) spans at least
    the shortest period searched: data that end just after the detection leave no period to search."""
    i0 = int(np.searchsorted(meas.t, t0 - 1e-9))
    span = min(samples, meas.t.size - i0) * meas.ts
    if span < min_period:
        raise DataError(f"{meas.path}: the data end {span:g} s after the detection at t_D = {t0:g} s; identification "
                        f"needs at least {min_period:g} s after t_D: record longer")


def parameters(faults: list[dict]) -> int:
    """The identified parameters of an explanation: a value per abrupt fault, value and period per
    intermittent one, its coefficients per incipient one, none for a mode fault; plus the onset."""
    k = {"abrupt": 1, "intermittent": 2, "mode": 0}
    n = sum(k[f["type"]] if f["type"] in k else len(f.get("b", ())) for f in faults)
    return n + (1 if any(f["type"] != "mode" for f in faults) else 0)


def effective_samples(samples: int, residuals: int, ts: float, window_s: float) -> float:
    """Independent residual samples in an identification window: the filter correlates the samples
    within one derivative window, so N residual samples carry about N / (window in samples)."""
    return max(1.0, samples * residuals / max(1.0, round(window_s / ts)))


def information(cost: float, faults: list[dict], n_eff: float) -> float:
    """Schwarz's criterion (BIC) of an explanation on the weighted L1 cost of eq. (24): with
    Laplace-distributed residuals of common scale profiled out, -2 ln L = 2 N_eff ln C + const, and
    each identified parameter is charged ln N_eff. Smaller is better; a difference below 2 is not
    a preference (Kass & Raftery 1995)."""
    return 2.0 * n_eff * math.log(max(cost, 1e-300)) + parameters(faults) * math.log(n_eff)


def select_winner(results, n_eff: float):
    """The explanation with the smallest information criterion: a larger candidate set wins only
    when its better fit pays for the parameters it adds (measured on CyCab scenario 2: R5 as a
    no-op fault bought 0.03 % of cost for two parameters, far below the 0.8 % per parameter that
    N_eff = 120 asks). Ties go to the smaller set."""
    return min(results, key=lambda e: (information(e.cost, e.faults, n_eff), len(e.candidate)))


def alternatives(results, winner: dict, n_eff: float, mode_fault: dict | None = None, skip=None) -> list[dict]:
    """Explanations the data hardly separate from the winner (``cost`` and ``faults``; criterion
    within 2 of it: a valve stuck closed and its conductance at zero), with their costs, for the
    report. ``skip``: the estimator that is the winner."""
    best = information(winner["cost"], winner["faults"], n_eff)
    others = [(list(e.candidate), e.faults, e.cost) for e in results if e is not skip]
    if mode_fault is not None and mode_fault is not winner:
        others.append(([f["name"] for f in mode_fault["faults"]], mode_fault["faults"], mode_fault["cost"]))
    out = [{"candidate": c, "faults": fs, "cost": cost, "criterion": information(cost, fs, n_eff) - best}
           for c, fs, cost in others]
    return sorted((a for a in out if a["criterion"] < 2.0), key=lambda a: a["criterion"])


def deterministic(x):
    """A report (or any part of it) without wall-clock entries, so that two runs of one diagnosis
    compare equal (``--timings`` keeps them)."""
    if isinstance(x, dict):
        return {k: deterministic(v) for k, v in x.items() if k not in ("wall_s", "objective_s", "timings")}
    if isinstance(x, list):
        return [deterministic(v) for v in x]
    return x


def public(report: dict) -> dict:
    """The report without its private (plotting) entries, JSON-ready."""
    def clean(x):
        if isinstance(x, dict):
            return {k: clean(v) for k, v in x.items() if not str(k).startswith("_")}
        if isinstance(x, (list, tuple)):
            return [clean(v) for v in x]
        if isinstance(x, (np.floating, float)):
            return None if not np.isfinite(x) else float(x)
        if isinstance(x, np.integer):
            return int(x)
        return x
    return clean(report)
