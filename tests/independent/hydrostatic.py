"""Independent simulator of tests/data/hydrostatic_transmission.yaml: a hydrostatic drive (Merritt,
Hydraulic Control Systems, ch. 6; Karnopp, Margolis & Rosenberg, System Dynamics, ch. 9), typed by
hand from its three state equations, never importing ``bondgraph`` or ``fdi``:

    Jp dwp/dt = Te - bp wp - Dp P        (the pump's shaft, driven by the motor's torque Te)
    C  dP/dt  = Dp wp - P / Rl - Dm wm   (the line between pump and motor, leaking through Rl)
    Jm dwm/dt = Dm P - bm wm             (the hydraulic motor's shaft and its load)

Linear, driven by a constant plus two sines, so solved exactly rather than integrated: on each
stretch of constant parameters the state is the steady state (the constant's equilibrium plus each
tone's phasor (j w I - A)^-1 B a) plus exp(A (t - a)) times the difference at the stretch's start,
stepped sample to sample by expm(A Ts). It starts in that steady state. A fault from ``t0``
multiplies ``which`` (Rl, bm) by ``factor``, or the pressure transducer's reading (beta_P). The
speeds read with 0.5 rad/s of noise, the pressure with 0.2 bar, the torque exactly."""
from __future__ import annotations

import numpy as np

from . import piecewise_linear, tones_steady

NOMINAL = {"Jp": 0.05, "bp": 0.01, "Dp": 1.0e-5, "C": 6.7e-13, "Rl": 1.0e12, "Dm": 1.5e-5, "Jm": 0.5, "bm": 0.2}
TS = 1.0e-3
NOISE = {"wp": 0.5, "P": 2.0e4, "wm": 0.5}
MEAN = 50.0                                   # N m
TONES = ((20.0, 0.5), (5.0, 1.7))             # amplitude (N m), frequency (Hz): Te = MEAN + sum a sin(2 pi f t)


def torque(t):
    """The drive's torque (N m)."""
    return MEAN + sum(a * np.sin(2 * np.pi * f * t) for a, f in TONES)


def _system(P: dict) -> tuple[np.ndarray, np.ndarray]:
    """A and B of x = (wp, P, wm)."""
    A = np.array([[-P["bp"] / P["Jp"], -P["Dp"] / P["Jp"], 0.0],
                  [P["Dp"] / P["C"], -1.0 / (P["Rl"] * P["C"]), -P["Dm"] / P["C"]],
                  [0.0, P["Dm"] / P["Jm"], -P["bm"] / P["Jm"]]])
    return A, np.array([1.0 / P["Jp"], 0.0, 0.0])


def simulate(seed: int, T: float = 14.0, t0: float | None = None, factor: float = 1.0,
             which: str = "Rl") -> dict[str, np.ndarray]:
    """Columns t, Te, wp, P, wm every TS s over [0, T]; from ``t0`` (a sample time) ``which`` times ``factor``."""
    t = np.arange(0.0, T + TS / 2, TS)
    k0 = t.size if t0 is None or which == "beta_P" else int(np.searchsorted(t, t0 - TS / 2))
    faulty = {**NOMINAL, **({which: NOMINAL[which] * factor} if which in NOMINAL else {})}
    x = piecewise_linear(t, ((0, k0, NOMINAL), (k0, t.size, faulty)), _system,
                         lambda A, B, tt: tones_steady(A, B, tt, TONES, MEAN))
    wp, p, wm = x
    rng = np.random.default_rng(seed)
    gain = np.where(t >= t0, factor, 1.0) if t0 is not None and which == "beta_P" else 1.0
    return {"t": t, "Te": torque(t), "wp": wp + rng.normal(0.0, NOISE["wp"], t.size),
            "P": gain * p + rng.normal(0.0, NOISE["P"], t.size), "wm": wm + rng.normal(0.0, NOISE["wm"], t.size)}
