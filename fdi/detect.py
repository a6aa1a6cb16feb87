"""Fault detection: thresholds, coherence vectors, detection time and waiting time (eq. 29).

A residual is inconsistent at a sample where |r| exceeds its threshold. The coherence vector is
*latched* from the detection time tD on: c_i(t) = 1 once residual i has crossed its threshold in
[tD, t], since a fault that lit a residual stays a candidate even when the residual later dips
(an intermittent fault does). The decision waits Twt (eq. 29): Out = In(tD + Twt), so that a
slowly growing incipient fault can light its residuals before candidates are formed. The first
``settle`` seconds and the last ``edge`` seconds are ignored: there the derivative filter is not
centred (half a derivative window at each end by default, :mod:`fdi.scales`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np


@dataclass(frozen=True)
class Detection:
    """The first threshold crossing t_D (sample ``index``), the coherence vector there, and the
    coherence vector at the decision time t_D + T_wt (clipped to the data)."""
    time: float                         # tD
    coherence: tuple[int, ...]          # at tD
    decision_time: float                # tD + Twt (clipped to the data)
    final_coherence: tuple[int, ...]    # at tD + Twt
    index: int                          # sample index of tD

    def to_dict(self) -> dict:
        return {"time": self.time, "coherence": list(self.coherence), "decision_time": self.decision_time,
                "final_coherence": list(self.final_coherence)}


def inconsistency(residuals: np.ndarray, thresholds: np.ndarray) -> np.ndarray:
    """Boolean (n_residuals, samples): |r_i| > eps_i."""
    return np.abs(residuals) > np.asarray(thresholds, dtype=float)[:, None]


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


def detect(residuals: np.ndarray, t: np.ndarray, thresholds: np.ndarray, waiting_time: float,
           settle: float = 0.0, edge: float = 0.0) -> Detection | None:
    """The first threshold crossing at least ``settle`` s after the data start and ``edge`` s before
    its end, and the coherence vector Twt later; None if none."""
    bad = inconsistency(residuals, thresholds) & trusted(t, settle, edge)[None, :]
    any_bad = bad.any(axis=0)
    if not any_bad.any():
        return None
    i = int(np.argmax(any_bad))
    td = float(t[i])
    j = int(np.searchsorted(t, td + waiting_time, side="right"))
    first = tuple(int(x) for x in bad[:, i])
    final = tuple(int(x) for x in bad[:, i:max(j, i + 1)].any(axis=1))
    return Detection(td, first, float(t[min(j, t.size) - 1]), final, i)


def coherence_over_time(residuals: np.ndarray, t: np.ndarray, thresholds: np.ndarray, settle: float = 0.0,
                        edge: float = 0.0) -> np.ndarray:
    """The latched coherence vector at every sample (n_residuals, samples)."""
    bad = inconsistency(residuals, thresholds) & trusted(t, settle, edge)[None, :]
    return np.maximum.accumulate(bad, axis=1).astype(int)


def thresholds_for(model_thresholds: Mapping[str, float], names: list[str], overrides: Mapping[str, float] | None = None) -> np.ndarray:
    merged = dict(model_thresholds)
    merged.update(overrides or {})
    missing = [n for n in names if n not in merged]
    if missing:
        raise ValueError(f"no threshold for {', '.join(missing)}: add thresholds to the model or pass --threshold")
    return np.array([merged[n] for n in names], dtype=float)
