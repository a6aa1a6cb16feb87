"""Stuck sensors: a measurement frozen at one value (a seized potentiometer, a dead transmitter
holding its last reading, a saturated ADC).

A stuck sensor carries no information about the system any more, so no profile of a gain or an
offset fits it; what shows it is the data themselves: from some instant on the signal stays
within its noise band while it moved before. A candidate fault ``effect: stuck`` of that sensor
is confirmed when its signal stays about one level from about the detection on (within six noise
standard deviations of its median, or two quantisation steps, or, where the model declares
neither, a millionth of its earlier range) and had left that level by more than three such bands
before; its onset is the first sample of the flat stretch and its value the level it holds.

A voltage sensor (noise 0.01 V, so a band of 0.06 V) that rose 1 V/s and froze at 5 V at t = 5 s,
the residuals alarming at 6 s:

>>> import numpy as np
>>> from bondgraph.loader import load_model_text
>>> m = load_model_text('''
... parameters: {C1: {value: 1.0e-3, unit: F}, R: {value: 100.0, unit: Ohm}}
... elements: {cap: {type: C, parameter: C1}, res: {type: R, parameter: R}}
... junctions: {j: {type: "0"}}
... sensors: {v: {type: De, junction: j, unit: V, noise: 0.01}}
... bonds: {1: [j, cap], 2: [j, res]}
... faults: {v_stuck: {kind: sensor, sensor: v, effect: stuck}}
... ''')
>>> t = np.arange(0.0, 10.0, 0.1)
>>> stuck_from(m, "v_stuck", t, np.minimum(t, 5.0), t_d=6.0, end=10.0)
Stuck(fault='v_stuck', sensor='v', onset=5.0, value=5.0)
>>> stuck_from(m, "v_stuck", t, t, t_d=6.0, end=10.0) is None       # still moving: not stuck
True
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bondgraph.model import Model

NOISE_BAND = 6.0        # standard deviations of the sensor's noise a frozen signal stays within
STEPS_BAND = 2.0        # quantisation steps likewise
MOVED = 3.0             # bands the signal must have moved before it froze


@dataclass(frozen=True)
class Stuck:
    """Sensor fault ``fault`` confirmed: its signal holds ``value`` from ``onset`` (s)."""
    fault: str
    sensor: str
    onset: float
    value: float


def band(model: Model, sensor: str, before: np.ndarray) -> float:
    """How far a frozen reading of ``sensor`` may wander: its declared noise and resolution, else
    a millionth of what it spanned before."""
    s = model.sensors[sensor]
    noise = max(s.noise.values(), default=0.0)
    step = max(s.resolution.values(), default=0.0)
    out = max(NOISE_BAND * noise, STEPS_BAND * step)
    if out == 0.0 and before.size:
        out = 1e-6 * float(np.ptp(before))
    return out


def stuck_from(model: Model, fault: str, t: np.ndarray, signal: np.ndarray, t_d: float,
               end: float, margin: float = 0.0) -> Stuck | None:
    """The stuck-sensor fault ``fault`` confirmed on the samples up to ``end`` (the decision), or
    None: the signal must be flat from ``t_d + margin`` (the residuals may cross their thresholds
    up to a derivative window, ``margin``, before the reading froze) and have moved before; the
    flat stretch is followed back as far as it stays flat."""
    sensor = model.faults[fault].targets[0]
    signal = np.asarray(signal, dtype=float)
    i_d = int(np.searchsorted(t, t_d + margin))
    i_end = int(np.searchsorted(t, end, side="right"))
    if i_end - i_d < 3 or i_d < 3:
        return None
    tail = signal[i_d:i_end]
    width = band(model, sensor, signal[:i_d])
    level = float(np.median(tail))
    if width <= 0 or np.max(np.abs(tail - level)) > width:
        return None
    k = i_d
    while k > 0 and abs(signal[k - 1] - level) <= width:
        k -= 1
    if k == 0 or np.max(np.abs(signal[:k] - level)) <= MOVED * width:
        return None
    return Stuck(fault, sensor, float(t[k]), float(np.median(signal[k:i_end])))
