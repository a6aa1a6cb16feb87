"""Sensor columns recorded coarser than the model says: a logger's quantisation far above the
declared noise and resolution, which every threshold and fit assume.

A user trial's pressure column rounded to three values (steps 520 times the declared noise)
was calibrated into a threshold 90 times too large and diagnosed as a clogged port, with no word
of the column. The step is read as the smallest gap between the distinct values of the first
:data:`LOOK` samples.

>>> import numpy as np
>>> x = np.round(np.random.default_rng(0).normal(0, 3000, 5000), -4)
>>> coarse({"pA": x}, {"pA": 10.0}, {}, {"pA": "Pa"})
"pA holds 3 distinct values in 5000 samples, in steps of 10000 Pa (1000 times its declared noise of 10 Pa): the model's noise does not describe it; declare its resolution under its sensor (resolution: 10000) or log it finer"
"""
from __future__ import annotations

from typing import Mapping

import numpy as np

LOOK = 200_000       # the samples the distinct values are counted on (np.unique sorts them)
COARSER = 10.0       # a step this many times the declared noise (or resolution) is noted
FEW = 0.01           # ... where the distinct values are fewer than this share of the samples


def coarse(columns: Mapping[str, np.ndarray], noise: Mapping[str, float], resolution: Mapping[str, float],
           units: Mapping[str, str]) -> str | None:
    """One note for the columns whose values come in steps over COARSER times their declared
    noise or resolution (the larger), their distinct values fewer than FEW of the samples; None
    when none does or nothing is declared."""
    parts = []
    for name, values in columns.items():
        declared = max(float(noise.get(name, 0.0)), float(resolution.get(name, 0.0)))
        if not declared > 0:
            continue
        v = np.asarray(values, dtype=float)[:LOOK]
        distinct = np.unique(v[np.isfinite(v)])
        if distinct.size < 2 or distinct.size >= FEW * v.size:
            continue
        step = float(np.min(np.diff(distinct)))
        if step <= COARSER * declared:
            continue
        unit = f" {units[name]}" if units.get(name) else ""
        what = "noise" if noise.get(name, 0.0) >= resolution.get(name, 0.0) else "resolution"
        parts.append(f"{name} holds {distinct.size} distinct values in {v.size} samples, in steps of {step:g}{unit} "
                     f"({step / declared:.0f} times its declared {what} of {declared:g}{unit}): the model's noise "
                     f"does not describe it; declare its resolution under its sensor (resolution: {step:g}) or log "
                     f"it finer")
    return "; ".join(parts) or None


__all__ = ["coarse"]
