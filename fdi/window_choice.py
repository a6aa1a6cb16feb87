"""The derivative window from nominal runs (``bgfdi calibrate --window auto``).

The rule's window (half the model's fastest time constant, :mod:`fdi.scales`) suits a residual's
first derivatives; one that takes a second derivative of a noisy signal can be far noisier at it
than any fault moves it. Each candidate window is scored on the nominal runs by the smallest
relative change of each fault its calibrated thresholds detect; the rule's window stays where it
detects every fault from DETECT_GOAL, else the best candidate wins. Measured on ten domain models
in docs/diagnosis.md (Time scales).
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from bondgraph.timescales import model_time_scales

from . import derivatives, scales
from .data import Measurements, commanded, signals_from_data
from .detect import settling, trusted
from .monitor import compiled
from .residuals import evaluate
from .sensitivity import STEP, perturbed

# ``--window auto``: the candidate derivative windows are the rule's times sqrt(2)^k, k = 0..8 (up
# to 16 times it), each at most a tenth of the shortest run and clear of the model's modes
# (clear_of_modes), and k = -1..-4 (down to a quarter of it, at least the rule's fewest samples:
# inputs faster than the model's time constants, a heartbeat driving the arteries, are smoothed by
# the rule's window); unless the rule's window is good enough (DETECT_GOAL), the one with the
# smallest detectable changes wins, the shortest of those within WINDOW_TIE of it (a shorter window
# detects sooner)
WINDOW_FACTORS = (1.0,) + tuple(2.0 ** (k / 2) for k in range(-4, 0)) + tuple(2.0 ** (k / 2) for k in range(1, 9))
WINDOW_TIE = 0.05
MODE_CLEARANCE = 4.0      # a mode is cut when its frequency is this many times the filter's cutoff
# ... and at most this fraction of a run's samples without a residual (within half a window of a
# commanded or autonomous switch, fdi.residuals.mode_breaks). Measured on the water heater (its
# thermostat relay and tap switching): 50 % at its hand-set 901 s window, whose designed truths
# hold; 64 % at 1143 s, where the element's fault was typed a sensor offset, the insulation's seen
# 1 500 s late and a relay stuck open not found
MAX_GAPS = 0.5
# The rule's window stays when every fault's detectable change is at most DETECT_GOAL there: a
# longer window detects smaller changes but blurs what identification reads (measured on the
# domain tests: at the longest-scoring windows a transformer's shorted turns took a spurious second
# fault, the LC ladder's output capacitor too, where the rule's window finds them alone)
DETECT_GOAL = 0.1


@dataclass(frozen=True)
class WindowScore:
    """One candidate derivative window (s, and samples of the first run) and, per fault, the
    smallest relative change of it the calibrated thresholds detect on the nominal runs (the
    change whose RMS effect on its most telling residual equals that residual's threshold; 0.1 is
    10 %); ``score`` is their geometric mean; ``rule``: the rule's window (scored first)."""
    window: float
    samples: int
    detectable: dict[str, float]
    score: float
    rule: bool = False
    judged: float = 1.0                                # the least share of a run it judges (settling, ends)
    modes: tuple[str, ...] = ()                        # the commanded modes where a residual has samples ("v=1")


def cutoff(samples: int, ts: float, polyorder: int = derivatives.DEFAULT_ORDER) -> float:
    """The half-power frequency (Hz) of a Savitzky-Golay filter of order p over ``samples`` = 2M + 1
    samples: (p + 1)/(3.2 M - 4.6) of the Nyquist frequency (Schafer, IEEE Signal Processing
    Magazine 28(4), 2011).

    >>> round(cutoff(103, 0.001), 1), round(cutoff(145, 0.001), 1)   # the quarter car's candidates
    (12.6, 8.9)
    """
    m = (samples - 1) / 2
    return (polyorder + 1) / max(3.2 * m - 4.6, polyorder + 1) / (2.0 * ts)


def clear_of_modes(samples: int, ts: float, eigenvalues, polyorder: int = derivatives.DEFAULT_ORDER) -> bool:
    """Whether a window passes each mode of the model (its frequency |lambda|/2 pi at most the
    filter's :func:`cutoff`) or cuts it well (at least MODE_CLEARANCE times the cutoff). Why: a
    residual's terms are filtered by the smoother and by its derivative filters, which agree on what
    they pass and on what they cut, not in between: a mode near the cutoff leaves a bias in the
    residual that nominal runs, exciting it little, do not show. Measured on the quarter car (wheel
    hop 11 Hz): at 103 samples (cutoff 12.6 Hz) its damper's loss is isolated and sized (400.2 for
    400); at 145 (8.9 Hz) the nominal runs score better still, but after the loss the tyre's balance
    fires too and the damper is exonerated. The loudspeaker's electrical mode (1.9 kHz at 20 kHz
    sampling) is passed by the rule's 9 samples and cut from 73 on (a 3.6 ms window), where its
    mechanical residuals become useful.

    >>> wheel_hop = [complex(-20.0, 69.0), complex(-20.0, -69.0)]
    >>> clear_of_modes(103, 0.001, wheel_hop), clear_of_modes(145, 0.001, wheel_hop)
    (True, False)
    """
    fc = cutoff(samples, ts, polyorder)
    for lam in eigenvalues:
        f = abs(lam) / (2.0 * np.pi)
        if fc < f < MODE_CLEARANCE * fc:
            return False
    return True


def choose_window(model_path: str, data: list[Measurements], thresholds_of: Callable[[list[np.ndarray]], np.ndarray],
                  settle: float | None = None, factors: tuple[float, ...] = WINDOW_FACTORS) -> list[WindowScore]:
    """Every candidate derivative window's :class:`WindowScore` on the nominal runs ``data``, the rule's
    window first, then the shorter and the longer ones (:data:`WINDOW_FACTORS` times it). Why: the rule
    (half the fastest time constant, fdi.scales) suits a residual's first derivatives; a residual that
    takes a second derivative of a noisy signal (a mass's acceleration from its velocity, a capacitor's
    current's rate) is noisy at that window, its calibrated threshold far above what a fault moves it by
    (the quarter car's damper: 3.65 m/s against 0.06 m/s). A longer window lowers the noise and biases
    the fast dynamics: the thresholds from the runs see both, and each fault's effect (its parameter or
    factor moved by fdi.sensitivity.STEP) is measured through the same filter. ``thresholds_of``: the
    calibration's rule, |r| on the trusted samples of each run -> one threshold per residual
    (:func:`fdi.calibrate.calibrate` passes its margin and quantile). ``factors``: the windows
    scored, times the rule's (``(1.0,)``: the rule's alone, what a calibration at it reports)."""
    c = compiled(model_path)
    model, residuals = c.model, list(c.arr_residuals)
    ts = data[0].ts
    rule = scales.for_model(model, c.config, ts).window
    shortest = min(meas.t.size for meas in data)                    # samples of the shortest run
    longest = shortest / 10 * ts                                     # at least ten windows per run
    eigenvalues = model_time_scales(model).eigenvalues
    nominal = {k: float(v) for k, v in model.nominal_by_name().items()}
    runs = []
    for meas in data:
        raw = signals_from_data(model, meas)
        runs.append((meas, raw, commanded(model, raw)))
    out: list[WindowScore] = []
    faults = None
    for factor in factors:
        window = rule * factor
        if factor > 1 and window > longest:
            break
        samples = derivatives.window_samples(window, ts, derivatives.DEFAULT_ORDER)
        if factor < 1 and samples < scales.min_window_samples():
            continue                      # below the rule's fewest samples
        if samples >= shortest:
            if factor > 1:
                break
            continue                      # longer than a run: no residual sample (the rule's too; shorter ones may do)
        if factor > 1 and not clear_of_modes(samples, ts, eigenvalues):
            continue
        config = replace(c.config, derivative_window=float(window))
        keeps = []
        for meas, _, _ in runs:
            sc = scales.for_model(model, config, meas.ts)
            keeps.append(trusted(meas.t, settling(settle, sc.settle), sc.end_edge))
        if factor > 1 and min(int(k.sum()) for k in keeps) < 4 * samples:
            continue                      # its settling (7 decay times of the modes it spans) leaves too little
        nominal_r = [np.asarray(evaluate(model, residuals, raw, meas.ts, window=window, values=modes))[:, keep]
                     for (meas, raw, modes), keep in zip(runs, keeps)]
        if max(float(np.isnan(r0).any(axis=0).mean()) if r0.size else 1.0 for r0 in nominal_r) > MAX_GAPS:
            if factor > 1:
                break                     # longer windows leave more of a run without residuals still
            continue                      # (the rule's too: a thermostat's stretches shorter than it, 8 of 2 881
                                          # samples with a residual, their thresholds from those alone)
        thresholds = thresholds_of([np.abs(r0) for r0 in nominal_r])
        detectable = {}
        for f, rms in _effects(model, residuals, runs, keeps, nominal_r, window, nominal).items():
            with np.errstate(all="ignore"):
                sizes = STEP * thresholds / rms
            sizes = sizes[np.isfinite(sizes) & (rms > 0)]
            if sizes.size:
                detectable[f] = float(sizes.min())
        if faults is None:
            faults = sorted(detectable)                # the faults the rule's window scores
        if any(f not in detectable for f in faults):
            continue
        score = float(np.exp(np.mean(np.log([detectable[f] for f in faults])))) if faults else float("inf")
        judged = min(float(k.mean()) for k in keeps)
        out.append(WindowScore(float(window), samples, {f: detectable[f] for f in faults}, score, factor == 1.0,
                               judged, _modes_with_residuals(runs, keeps, nominal_r) if len(factors) > 1 else ()))
    return out


def _modes_with_residuals(runs, keeps, nominal_r) -> tuple[str, ...]:
    """The commanded modes ("v=1", "a=0,b=1") in which some residual has a sample on the
    runs' judged samples: a window longer than a mode's stretches leaves that mode unwatched (a relief
    valve open for 20 s of a run, under a 21 s window: its stuck-closed fault could not be detected)."""
    seen = set()
    for (_, _, modes), keep, r0 in zip(runs, keeps, nominal_r):
        if not modes or not r0.size:
            continue
        has = np.isfinite(r0).any(axis=0)
        names = sorted(modes)
        rows = np.stack([np.broadcast_to(np.asarray(modes[n]).reshape(-1), keep.shape)[keep] for n in names], axis=1)
        for row in np.unique(rows[has], axis=0):
            seen.add(",".join(f"{n}={int(v)}" for n, v in zip(names, row)))
    return tuple(sorted(seen))


def _effects(model, residuals, runs, keeps, nominal_r, window: float, nominal: dict) -> dict[str, np.ndarray]:
    """Per fault that can be moved (fdi.sensitivity.perturbed), the RMS over the runs' trusted
    samples of each residual's change when it is moved by STEP, at ``window``."""
    sums: dict[str, tuple] = {}
    for (meas, raw, modes), keep, r0 in zip(runs, keeps, nominal_r):
        for f in model.faults:
            step = perturbed(model, f, nominal, raw)
            if step is None:
                continue
            params, betas, biases = step
            r1 = evaluate(model, residuals, raw, meas.ts, window=window, values={**modes, **params},
                          betas=betas, biases=biases)
            d = np.asarray(r1)[:, keep] - r0
            ok = np.isfinite(d)               # sums of squares and counts: no copy of a long run per fault
            total, count = sums.get(f, (0.0, 0))
            sums[f] = (total + np.where(ok, d * d, 0.0).sum(axis=1), count + ok.sum(axis=1))
    with np.errstate(all="ignore"):
        return {f: np.sqrt(total / count) for f, (total, count) in sums.items()}


MAX_LOSS = 0.1     # a window may judge at most this share of a run less than the rule's (its longer settling)


def set_aside(scores: list[WindowScore]) -> dict[float, str]:
    """The candidate windows --window auto does not take whatever their scores, by window, and why:
    one that judges over MAX_LOSS of a run less than the rule's (the least share over the runs) (its settling: a surge
    tank's 21 s window left the first 262 s of 600 unjudged, a fault there undetected and every
    detection dated after it) or leaves a commanded mode the rule's window watches without a
    residual sample (a relief valve opened for 20 s: its stuck-closed fault undetectable). None
    when the rule's window was not scored (it left over half a run without residuals)."""
    rule = scores[0] if scores else None
    if rule is None or not rule.rule:
        return {}
    out = {}
    for s in scores[1:]:
        lost = sorted(set(rule.modes) - set(s.modes))
        if s.judged < rule.judged - MAX_LOSS:
            out[s.window] = (f"it judges {100 * s.judged:.0f} % of a run at least, the rule's "
                             f"{100 * rule.judged:.0f} % (its settling)")
        elif lost:
            out[s.window] = "no residual while " + "; ".join(lost) + " (stretches shorter than it)"
    return out


def chosen(scores: list[WindowScore]) -> WindowScore:
    """The rule's window (the first, when it was scored) when it detects a change of DETECT_GOAL of
    every fault; else, of the windows not set aside (:func:`set_aside`), the one with the smallest
    score, or the shortest within WINDOW_TIE of it."""
    rule = scores[0]
    if rule.rule and rule.detectable and max(rule.detectable.values()) <= DETECT_GOAL:
        return rule
    aside = set_aside(scores)
    kept = [s for s in scores if s.window not in aside]
    best = min(s.score for s in kept)
    return next(s for s in sorted(kept, key=lambda s: s.window) if s.score <= best * (1 + WINDOW_TIE))
