"""Fault detection: thresholds, coherence vectors, detection time and waiting time (eq. 29).

A residual is inconsistent at a sample where |r| exceeds its threshold. The coherence vector is
*latched* from the detection time tD on: c_i(t) = 1 once residual i has crossed its threshold in
[tD, t], since a fault that lit a residual stays a candidate even when the residual later dips
(an intermittent fault does). The decision waits Twt (eq. 29): Out = In(tD + Twt), so that a
slowly growing incipient fault can light its residuals before candidates are formed. The first
``settle`` seconds and the last ``edge`` seconds are ignored: there the derivative filter is not
centred (half a derivative window at each end by default, :mod:`fdi.scales`).

**Persistence.** A residual joins the coherence vector only when its excursions above the
threshold carry enough evidence: the time it spends above the threshold, each sample weighted by
how far above (|r|/eps), summed over the last ``span`` seconds, must reach ``persistence``
(threshold-seconds: the time a residual just above its threshold takes; at twice it, half that).
It is a debounce counter of the kind engine monitors use, weighted like a CUSUM. A brief excursion
(a filter transient, a spike as a leak opens: 0.12 threshold-seconds measured on the CyCab, whose
persistence is 0.25) is not latched; a fault's residual is, and one the excitation modulates
(above for a moment in each cycle) adds its crossings up within the span. ``persistence`` = 0 is
the paper's rule (the first sample above the threshold). The detection time t_D is the first
crossing inside the span that confirmed the alarm, so the identification window still starts
with the fault; the decision waits T_wt from the alarm, when the monitor knows.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from .errors import UsageError


@dataclass(frozen=True)
class Detection:
    """The start t_D (sample ``index``) of the first excursion that persisted, the residuals
    confirmed at its ``alarm`` (the coherence vector at detection), and the coherence vector at the
    decision time alarm + T_wt (clipped to the data). Without persistence alarm = t_D."""
    time: float                         # tD
    coherence: tuple[int, ...]          # at the alarm
    decision_time: float                # alarm + Twt (clipped to the data)
    final_coherence: tuple[int, ...]    # at the decision time
    index: int                          # sample index of tD
    alarm: float | None = None          # when the persistence rule confirmed the excursion (None: t_D)
    excursion: float | None = None      # where the confirming excursion's own crossings began, when a quiet
                                        # run parts them from earlier crossings of the span (None: at t_D)

    @property
    def alarm_time(self) -> float:
        return self.time if self.alarm is None else self.alarm

    def to_dict(self) -> dict:
        return {"time": self.time, "alarm": self.alarm_time, "coherence": list(self.coherence),
                "decision_time": self.decision_time, "final_coherence": list(self.final_coherence)}


@dataclass(frozen=True)
class Alarms:
    """Per residual: the sample of its first alarm (-1: none), its first crossing inside the
    span that confirmed the alarm, and the first crossing of the excursion that confirmed it
    (:func:`excursion_start`)."""
    at: np.ndarray
    start: np.ndarray
    excursion: np.ndarray | None = None

    def latched(self, samples: int) -> np.ndarray:
        """Boolean (n_residuals, samples): residual i confirmed at or before sample k."""
        k = np.arange(samples)[None, :]
        return (self.at[:, None] >= 0) & (k >= self.at[:, None])


def settling(settle: float | None, floor: float) -> float:
    """The seconds after the data start that detection ignores: the data's own settling time
    ``floor`` (:func:`fdi.scales.settle`: at least half the derivative window, where the
    Savitzky-Golay filter has no past samples), or ``settle`` when one is given and longer.

    >>> settling(None, 0.125), settling(1.0, 0.125), settling(1.0, 15.5)
    (0.125, 1.0, 15.5)
    """
    return floor if settle is None else max(settle, floor)


def trusted(t: np.ndarray, settle: float, edge: float = 0.0) -> np.ndarray:
    """The samples detection looks at: from ``settle`` s after the data start to ``edge`` s before
    its end (the derivative filter's off-centre ends); the last sample at least.

    >>> trusted(np.arange(10.0), 2.0, 3.0).nonzero()[0].tolist()
    [2, 3, 4, 5, 6]
    """
    return (t >= t[0] + settle) & (t <= t[-1] - edge)


def evidence(residuals: np.ndarray, thresholds: np.ndarray, ts: float, keep: np.ndarray | None = None) -> np.ndarray:
    """Each sample's evidence in threshold-seconds: t_s |r|/eps above the threshold, else 0 (and 0
    where a residual has no value or the sample is not looked at, ``keep`` False). One array like
    ``residuals``, computed in place (a minute at 10 kHz: one row is 4.8 MB)."""
    with np.errstate(invalid="ignore"):
        z = np.abs(residuals)
        z /= np.asarray(thresholds, dtype=float)[:, None]
        ok = np.isfinite(z)
        ok &= z > 1.0
    z *= ts
    if keep is not None:
        ok &= keep[None, :]
    z[~ok] = 0.0
    return z


SUM_BLOCK = 1 << 16     # columns subtracted at a time in moving_sum (its temporary: one such block)


def moving_sum(x: np.ndarray, n: int, head: np.ndarray | None = None) -> np.ndarray:
    """The sum of each row of ``x`` over its last ``n`` samples (``head``: the samples before the
    block, at least n - 1 columns when given): the cumulative sum minus itself n samples back,
    subtracted in place from the end (a column's lagged sum is read before it is changed).

    >>> moving_sum(np.array([[1.0, 2.0, 3.0, 4.0]]), 2).tolist()
    [[1.0, 3.0, 5.0, 7.0]]
    """
    k = x.shape[1]
    full = x if head is None else np.concatenate([head, x], axis=1)
    c = np.cumsum(full, axis=1)
    first = full.shape[1] - k                                 # index in full of the block's first sample
    stop = max(first, n)                                      # from there on, j - n >= 0: subtract
    for b in range(c.shape[1], stop, -SUM_BLOCK):
        a = max(stop, b - SUM_BLOCK)
        c[:, a:b] -= c[:, a - n:b - n]
    return c[:, first:]


def evidence_samples(span: float, ts: float) -> int:
    """Samples of the evidence span (at least one)."""
    return max(1, int(round(span / ts)))


def confirmed(z: np.ndarray, n: int, persistence: float, head: np.ndarray | None = None) -> np.ndarray:
    """Boolean like ``z`` (evidence, residuals x samples): where a crossing brings the evidence of
    the last ``n`` samples (``head``: those before the block) past ``persistence``; with 0, every
    crossing (the paper's rule)."""
    if persistence <= 0:
        return z > 0
    return (moving_sum(z, n, head) > persistence) & (z > 0)


def span_start(z: np.ndarray, at: int, n: int) -> int:
    """The first crossing of the ``n`` samples of evidence ``z`` (one residual) that end at ``at``."""
    lo = max(0, at - n + 1)
    return lo + int(np.argmax(z[lo:at + 1] > 0))


QUIET_SHARE = 8    # a run without a crossing longer than this share of the span parts two excursions


def excursion_start(z: np.ndarray, at: int, n: int) -> int:
    """The first crossing of the excursion that confirmed the alarm at ``at`` (a crossing): of the
    ``n`` samples of evidence ``z`` that end there, the crossings back to the first run of more than
    ``max(1, n // QUIET_SHARE)`` samples without one (half a derivative window in the default span
    of four windows). t_D stays the span's first crossing (a slow drift flickers about its threshold: a
    chamber's wear crossed at 4.17 s, then after 40 quiet samples from 4.21 s, and the window from
    4.17 s fits it best); where t_D's crossings follow a mode switch it bounds how late the fault
    may have begun (:func:`fdi.pipeline.switch_excursion`): a user trial's engine cooling, a fan
    switching on, set the residuals above their thresholds for 4 s, unconfirmed, and 19 s of quiet
    later the fan's failure confirmed; the onsets searched ended half a window after the switch's
    excursion, 21 s before the failure (:func:`fdi.hints.onset_interval`).

    >>> z = np.array([0, 1, 1, 0, 0, 0, 0, 0, 0, 0, 1, 0, 1, 1.0])
    >>> excursion_start(z, 13, 14), span_start(z, 13, 14)     # 7 quiet samples part them (more than 14 // 8)
    (10, 1)
    >>> excursion_start(z, 13, 64)                            # in a span of 64 they do not
    1
    """
    lo = max(0, at - n + 1)
    hits = np.flatnonzero(z[lo:at + 1] > 0) + lo
    parted = np.flatnonzero(np.diff(hits) - 1 > max(1, n // QUIET_SHARE))
    return int(hits[parted[-1] + 1]) if parted.size else int(hits[0])


def alarms(residuals: np.ndarray, t: np.ndarray, thresholds: np.ndarray, settle: float = 0.0, edge: float = 0.0,
           persistence: float = 0.0, span: float = 0.0) -> Alarms:
    """Each residual's first confirmed alarm (see the module doc) on the samples detection looks
    at, and the first crossing of the span that confirmed it.

    >>> t = np.arange(10) * 0.1
    >>> r = np.array([[0, 3, 0, 0, 0, 0, 2, 2, 2, 0.0]])     # a spike, then an excursion that lasts
    >>> a = alarms(r, t, np.array([1.0]), persistence=0.5, span=0.4)
    >>> int(a.at[0]), int(a.start[0])
    (8, 6)
    >>> int(alarms(r, t, np.array([1.0])).at[0])          # persistence 0: the paper's first crossing
    1
    """
    ts = float(t[1] - t[0]) if t.size > 1 else 1.0
    keep = trusted(t, settle, edge)
    n = evidence_samples(span, ts)
    thresholds = np.asarray(thresholds, dtype=float)
    at, start, excursion = [], [], []
    for i in range(residuals.shape[0]):        # a residual at a time: memory of a few rows, not of all
        z = evidence(residuals[i:i + 1], thresholds[i:i + 1], ts, keep)
        fired = confirmed(z, n, persistence)[0]
        a = int(np.argmax(fired)) if fired.any() else -1
        at.append(a)
        start.append(span_start(z[0], a, n) if a >= 0 else -1)
        excursion.append(excursion_start(z[0], a, n) if a >= 0 else -1)
    return Alarms(np.asarray(at, dtype=int), np.asarray(start, dtype=int), np.asarray(excursion, dtype=int))


def detect(residuals: np.ndarray, t: np.ndarray, thresholds: np.ndarray, waiting_time: float,
           settle: float = 0.0, edge: float = 0.0, persistence: float = 0.0, span: float = 0.0) -> Detection | None:
    """The first confirmed excursion at least ``settle`` s after the data start and ``edge`` s
    before its end, and the coherence vector T_wt after its alarm; None if none."""
    a = alarms(residuals, t, thresholds, settle, edge, persistence, span)
    if not (a.at >= 0).any():
        return None
    k = int(a.at[a.at >= 0].min())
    i = int(a.start[a.at == k].min())
    j = int(np.searchsorted(t, float(t[k]) + waiting_time, side="right"))
    decided = min(max(j, k + 1), t.size) - 1
    first = tuple(int(0 <= x <= k) for x in a.at)
    final = tuple(int(0 <= x <= decided) for x in a.at)
    e = int(a.excursion[a.at == k].min())
    return Detection(float(t[i]), first, float(t[decided]), final, i, None if k == i else float(t[k]),
                     None if e == i else float(t[e]))


def coherence_over_time(residuals: np.ndarray, t: np.ndarray, thresholds: np.ndarray, settle: float = 0.0,
                        edge: float = 0.0, persistence: float = 0.0, span: float = 0.0) -> np.ndarray:
    """The latched coherence vector at every sample (n_residuals, samples)."""
    return alarms(residuals, t, thresholds, settle, edge, persistence, span).latched(t.size).astype(int)


def stray_thresholds(model_thresholds: Mapping[str, float], names: list[str]) -> str | None:
    """The message for thresholds that name no residual of the model (a residual renamed or gone
    since calibrate wrote them: ignored, a threshold would be lost silently); None when every one
    names a residual. ``check`` refuses them as ``diagnose`` does.

    >>> stray_thresholds({"ARR1": 1.0, "ARR9": 2.0}, ["ARR1", "ARR2"])[:40]
    'ARR9 name(s) no residual of the model (i'
    """
    stray = [n for n in model_thresholds if n not in names]
    if not stray:
        return None
    return (f"{', '.join(map(str, stray))} name(s) no residual of the model (its residuals: "
            f"{', '.join(names)}); correct or remove them, or run bgfdi calibrate again")


def stray_error(model, model_thresholds: Mapping[str, float], names: list[str]):
    """The ModelError for thresholds that name no residual (:func:`stray_thresholds`), at the first
    one's key and line in the model file (read again: the model keeps no lines); None when every
    one names a residual."""
    message = stray_thresholds(model_thresholds, names)
    if message is None:
        return None
    from bondgraph.errors import ModelError
    first = next(n for n in model_thresholds if n not in names)
    return ModelError(message, file=model.path, where=f"thresholds.{first}", line=_line(model.path, ("thresholds", first)))


def _line(path: str | None, where: tuple) -> int | None:
    """The line of the key at ``where`` in the model file ``path``, when it is a file that reads."""
    import os
    if not path or not os.path.isfile(path):
        return None
    from bondgraph.errors import ModelError
    from bondgraph.loader import read_document
    try:
        return read_document(path).lines.get(where)
    except (ModelError, OSError, ValueError):
        return None


def checked_thresholds(model, model_thresholds: Mapping[str, float], names: list[str]) -> str | None:
    """``check``'s reading of the file's thresholds against its residuals ``names`` (text and
    --json alike): a ModelError for one naming no residual, as ``diagnose`` refuses it; the note
    naming residuals without one (:func:`missing_thresholds`), or None."""
    if (error := stray_error(model, model_thresholds, names)) is not None:
        raise error
    return missing_thresholds(model_thresholds, names)


def missing_thresholds(model_thresholds: Mapping[str, float], names: list[str]) -> str | None:
    """``check``'s note for residuals the file gives no threshold (``diagnose`` refuses to run
    without one for each, unless --threshold gives it)."""
    missing = [n for n in names if n not in model_thresholds]
    if not missing:
        return None
    return (f"no threshold for {', '.join(missing)} in the file: diagnose needs one for each residual (bgfdi "
            f"calibrate learns them from fault-free runs; --threshold gives one for a run)")


def thresholds_for(model_thresholds: Mapping[str, float], names: list[str], overrides: Mapping[str, float] | None = None) -> np.ndarray:
    stray = stray_thresholds(model_thresholds, names)
    if stray:
        raise ValueError(stray)
    loose = [n for n in (overrides or {}) if n not in names]
    if loose:          # the options' (the command line checks its own --threshold names first)
        raise UsageError(f"thresholds: {', '.join(map(str, loose))} name(s) no residual of the model (its residuals: "
                         f"{', '.join(names)})")
    merged = dict(model_thresholds)
    merged.update(overrides or {})
    missing = [n for n in names if n not in merged]
    if missing:
        raise ValueError(f"no threshold for {', '.join(missing)}: add thresholds to the model (bgfdi calibrate learns them from fault-free runs) or pass --threshold")
    return np.array([merged[n] for n in names], dtype=float)
