"""A thermostat-switched heater that loses 30 % of its power, on the two-zone building
(tests/data/two_zone_building.yaml), simulated here from the physics apart from bgfdi:

  C1 T1' = s beta Ph - (T1 - T2)/R12 - (T1 - Ta)/R1a
  C2 T2' = (T1 - T2)/R12 - (T2 - Ta)/R2a

a linear plant between the controller's samples, stepped exactly by the matrix exponential
(scipy.linalg.expm; the outdoor temperature held at each step's midpoint), a thermostat with its
own noise-free probe in zone 1 and a 1 K band, deciding each second; thermometers with 0.05 K of
noise. The designed truth: beta drops from 1 to 0.7 at t0 (a 900 W loss).

What broke: zone 1's balance fires; the total balance (both zones) sees the same 900 W, under its
threshold. Exoneration by sensitivity sized the fault by zone 1's peak (noise and the relay's
switching spikes in it: 1 113 W), predicted the total balance past its 1 087 W threshold at that
size, and its quiet then exonerated the heater: a thermometer drift was reported instead. The
fault's part of a peak is what rises above the residual's own level before the fault."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm

from fdi.api import diagnose
from fdi.config import load

BUILDING = Path(__file__).parent / "data" / "two_zone_building.yaml"
C1, C2, R1a, R12, R2a, PH = 5.0e5, 8.0e5, 0.02, 0.01, 0.015, 3000.0
SET, BAND, NOISE = 293.15, 0.5, 0.05
THRESHOLDS = {"ARR1": 437.1, "ARR2": 896.8, "ARR3": 1087.0, "ARR4": 6.563e4}   # calibrated on nominal runs


def outdoor(t: np.ndarray) -> np.ndarray:
    return 278.15 + 3.0 * np.sin(2 * np.pi * t / 86400.0) + 0.8 * np.sin(2 * np.pi * t / 7200.0 + 1.0)


def building(duration: float, t0: float, beta: float, seed: int) -> dict[str, np.ndarray]:
    """Measured columns of a run sampled at 1 s (module doc)."""
    a = np.array([[-(1 / R12 + 1 / R1a) / C1, 1 / (R12 * C1)],
                  [1 / (R12 * C2), -(1 / R12 + 1 / R2a) / C2]])
    b = np.array([[1 / C1, 1 / (R1a * C1)], [0.0, 1 / (R2a * C2)]])      # inputs: heat into zone 1, Ta
    m = expm(np.block([[a, b], [np.zeros((2, 4))]]))                    # exact for inputs held over 1 s
    ad, bd = m[:2, :2], m[:2, 2:]
    t = np.arange(int(duration) + 1, dtype=float)
    ta = outdoor(t)
    x = np.array([SET, ta[0] + (SET - ta[0]) * R2a / (R12 + R2a)])
    s, xs, cmd = 1.0, np.empty((t.size, 2)), np.empty(t.size)
    for k in range(t.size):
        if x[0] > SET + BAND:
            s = 0.0
        elif x[0] < SET - BAND:
            s = 1.0
        xs[k], cmd[k] = x, s
        heat = s * PH * (beta if t[k] >= t0 else 1.0)
        x = ad @ x + bd @ np.array([heat, outdoor(t[k] + 0.5)])
    rng = np.random.default_rng(seed)
    noisy = lambda v: v + rng.normal(0.0, NOISE, v.size)
    return {"t": t, "Ph": np.full(t.size, PH), "Ta": noisy(ta), "s_cmd": cmd, "T1": noisy(xs[:, 0]),
            "T2": noisy(xs[:, 1])}


def test_a_heater_losing_power_is_found_though_the_total_balance_stays_quiet():
    model, settings = load(BUILDING)
    settings = settings.replace(thresholds=THRESHOLDS, derivative_window=201.0)
    data = building(40000.0, t0=36000.0, beta=0.7, seed=12)    # zone 1's peak 1 089 W after the fault, 285 W before
    d = diagnose(model, data, settings, max_set=1)
    assert d.detection is not None and abs(d.detection.time - 36000.0) < 300.0   # a centred 201 s filter
    assert ("heater_power",) in d.isolation.candidates
    assert "ARR3" in d.isolation.weak["heater_power"]            # the total balance could not have fired
    assert [f.name for f in d.faults] == ["heater_power"]
    assert d.faults[0].value == pytest.approx(0.7, abs=0.02)
