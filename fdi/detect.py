"""Fault detection: thresholds, coherence vectors, detection time and waiting time (eq. 29).

A residual is inconsistent at a sample where |r| exceeds its threshold. The coherence vector is
*latched* from the detection time tD on: c_i(t) = 1 once residual i has crossed its threshold in
[tD, t], since a fault that lit a residual stays a candidate even when the residual later dips
(an intermittent fault does). The decision waits Twt (eq. 29): Out = In(tD + Twt), so that a
slowly growing incipient fault can light its residuals before candidates are formed. The first
``settle`` seconds are ignored (start-up transient, derivative-filter edge).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np


@dataclass(frozen=True)
class Detection:
    time: float                         # tD
    coherence: tuple[int, ...]          # at tD
    decision_time: float                # tD + Twt (clipped to the data)
    final_coherence: tuple[int, ...]    # at tD + Twt
    index: int                          # sample index of tD


def inconsistency(residuals: np.ndarray, thresholds: np.ndarray) -> np.ndarray:
    """Boolean (n_residuals, samples): |r_i| > eps_i."""
    return np.abs(residuals) > np.asarray(thresholds, dtype=float)[:, None]


def settling(settle: float, window_s: float) -> float:
    """The seconds after the data start that detection ignores: ``settle``, and at least half the
    derivative window, where the Savitzky-Golay filter has no past samples (measured on a thermal
    model with a 31 s window: nominal residuals of 1085 W at the first sample for thresholds near
    600 W, under them from the eighth; a 1 s settle raised an alarm at t = 1 s).

    >>> settling(1.0, 0.25), settling(1.0, 31.0)
    (1.0, 15.5)
    """
    return max(settle, window_s / 2)


def detect(residuals: np.ndarray, t: np.ndarray, thresholds: np.ndarray, waiting_time: float,
           settle: float = 1.0) -> Detection | None:
    """The first threshold crossing after ``settle`` s and the coherence vector Twt later; None if none."""
    bad = inconsistency(residuals, thresholds) & (t >= t[0] + settle)[None, :]
    any_bad = bad.any(axis=0)
    if not any_bad.any():
        return None
    i = int(np.argmax(any_bad))
    td = float(t[i])
    j = int(np.searchsorted(t, td + waiting_time, side="right"))
    first = tuple(int(x) for x in bad[:, i])
    final = tuple(int(x) for x in bad[:, i:max(j, i + 1)].any(axis=1))
    return Detection(td, first, float(t[min(j, t.size) - 1]), final, i)


def coherence_over_time(residuals: np.ndarray, t: np.ndarray, thresholds: np.ndarray, settle: float = 1.0) -> np.ndarray:
    """The latched coherence vector at every sample (n_residuals, samples)."""
    bad = inconsistency(residuals, thresholds) & (t >= t[0] + settle)[None, :]
    return np.maximum.accumulate(bad, axis=1).astype(int)


def thresholds_for(model_thresholds: Mapping[str, float], names: list[str], overrides: Mapping[str, float] | None = None) -> np.ndarray:
    merged = dict(model_thresholds)
    merged.update(overrides or {})
    missing = [n for n in names if n not in merged]
    if missing:
        raise ValueError(f"no threshold for {', '.join(missing)}: add thresholds to the model or pass --threshold")
    return np.array([merged[n] for n in names], dtype=float)
