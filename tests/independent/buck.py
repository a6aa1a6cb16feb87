"""Independent simulator of tests/data/buck_averaged.yaml: the averaged buck converter (Erickson &
Maksimovic, Fundamentals of Power Electronics, ch. 7), typed by hand from its two state equations,
never importing ``bondgraph`` or ``fdi``:

    L diL/dt = d Vin - rL iL - vC        C dvC/dt = iL - vC/R

With Vin constant and the duty cycle d = 0.5 + 0.1 sin(2 pi 20 t), the drive d Vin is a constant
plus one tone: the system is linear, solved exactly (:func:`tones_steady`, :func:`piecewise_linear`),
starting in its steady state. A fault from ``t0`` multiplies the load R by ``factor``, or the output
voltage sensor's reading (beta_vC). The current reads with 10 mA of noise, the voltage with 10 mV;
Vin and d exactly."""
from __future__ import annotations

import numpy as np

from . import piecewise_linear, tones_steady

NOMINAL = {"L": 1.0e-4, "rL": 0.05, "C": 4.7e-4, "R": 5.0}
TS = 2.0e-5
VIN = 24.0
DUTY = (0.5, 0.1, 20.0)                       # mean, amplitude, frequency (Hz)
NOISE = {"iL": 0.01, "vC": 0.01}


def duty(t):
    mean, a, f = DUTY
    return mean + a * np.sin(2 * np.pi * f * t)


def _system(P: dict) -> tuple[np.ndarray, np.ndarray]:
    """A and B of x = (iL, vC) driven by u = d Vin."""
    return (np.array([[-P["rL"] / P["L"], -1.0 / P["L"]], [1.0 / P["C"], -1.0 / (P["R"] * P["C"])]]),
            np.array([1.0 / P["L"], 0.0]))


def simulate(seed: int, T: float = 0.2, t0: float | None = None, factor: float = 1.0,
             which: str = "R") -> dict[str, np.ndarray]:
    """Columns t, Vin, d, iL, vC every TS s over [0, T]; from ``t0`` (a sample time) ``which`` times ``factor``."""
    t = np.arange(0.0, T + TS / 2, TS)
    k0 = t.size if t0 is None or which == "beta_vC" else int(np.searchsorted(t, t0 - TS / 2))
    faulty = {**NOMINAL, **({which: NOMINAL[which] * factor} if which in NOMINAL else {})}
    mean, a, f = DUTY
    x = piecewise_linear(t, ((0, k0, NOMINAL), (k0, t.size, faulty)), _system,
                         lambda A, B, tt: tones_steady(A, B, tt, ((VIN * a, f),), VIN * mean))
    iL, v = x
    rng = np.random.default_rng(seed)
    gain = np.where(t >= t0, factor, 1.0) if t0 is not None and which == "beta_vC" else 1.0
    return {"t": t, "Vin": np.full(t.size, VIN), "d": duty(t), "iL": iL + rng.normal(0.0, NOISE["iL"], t.size),
            "vC": gain * v + rng.normal(0.0, NOISE["vC"], t.size)}
