"""Independent simulator of tests/data/closed_box_speaker.yaml: a closed-box loudspeaker (Thiele-Small;
Beranek & Mellow, Acoustics: Sound Fields, Transducers and Vibration, 2nd ed., ch. 7 and 11), typed
by hand from its four state equations, never importing ``bondgraph`` or ``fdi``:

    Le di/dt  = u - Re i - Bl v                     (the voice coil)
    Mms dv/dt = Bl i - Rms v - x / Cms - Sd p,  dx/dt = v      (the cone on its suspension)
    Cab dp/dt = Sd v - p / Ral                      (the box's air, leaking through Ral)

The system is linear and its input a sum of sines, so it is solved exactly rather than integrated:
on each stretch of constant parameters the state is the sinusoidal steady state (the phasors
(j w I - A)^-1 B of each tone) plus exp(A (t - a)) times the difference at the stretch's start,
stepped sample to sample by expm(A Ts). From rest at t = 0. A fault from ``t0`` multiplies
``which`` (Re, Cms, Ral) by ``factor``, or the microphone's reading (beta_p). The signals read with
noise (1 mA, 1 mm/s, 0.5 Pa), the voltage exactly."""
from __future__ import annotations

import numpy as np

from . import piecewise_linear, tones_steady

NOMINAL = {"Re": 6.0, "Le": 5.0e-4, "Bl": 7.0, "Mms": 0.015, "Rms": 1.5, "Cms": 1.0e-3, "Sd": 0.013,
           "Cab": 7.08e-8, "Ral": 1.0e6}
TS = 1.0e-4
NOISE = {"i": 1.0e-3, "v": 1.0e-3, "p": 0.5}
TONES = ((2.0, 40.0), (1.0, 110.0))          # amplitude (V), frequency (Hz): u = sum a sin(2 pi f t)


def voltage(t):
    """The amplifier's voltage (V): the model's input expression, written out."""
    return sum(a * np.sin(2 * np.pi * f * t) for a, f in TONES)


def _system(P: dict) -> tuple[np.ndarray, np.ndarray]:
    """A and B of x = (i, v, x, p)."""
    A = np.array([[-P["Re"] / P["Le"], -P["Bl"] / P["Le"], 0.0, 0.0],
                  [P["Bl"] / P["Mms"], -P["Rms"] / P["Mms"], -1.0 / (P["Cms"] * P["Mms"]), -P["Sd"] / P["Mms"]],
                  [0.0, 1.0, 0.0, 0.0],
                  [0.0, P["Sd"] / P["Cab"], 0.0, -1.0 / (P["Ral"] * P["Cab"])]])
    return A, np.array([1.0 / P["Le"], 0.0, 0.0, 0.0])


def simulate(seed: int, T: float = 2.0, t0: float | None = None, factor: float = 1.0,
             which: str = "Re") -> dict[str, np.ndarray]:
    """Columns t, u, i, v, p every TS s over [0, T]; from ``t0`` (a sample time) ``which`` times ``factor``."""
    t = np.arange(0.0, T + TS / 2, TS)
    k0 = t.size if t0 is None or which == "beta_p" else int(np.searchsorted(t, t0 - TS / 2))
    faulty = {**NOMINAL, **({which: NOMINAL[which] * factor} if which in NOMINAL else {})}
    x = piecewise_linear(t, ((0, k0, NOMINAL), (k0, t.size, faulty)), _system,
                         lambda A, B, tt: tones_steady(A, B, tt, TONES), start=np.zeros(4))
    i, v, _, p = x
    rng = np.random.default_rng(seed)
    gain = np.where(t >= t0, factor, 1.0) if t0 is not None and which == "beta_p" else 1.0
    return {"t": t, "u": voltage(t), "i": i + rng.normal(0.0, NOISE["i"], t.size),
            "v": v + rng.normal(0.0, NOISE["v"], t.size), "p": gain * p + rng.normal(0.0, NOISE["p"], t.size)}
