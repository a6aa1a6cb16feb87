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
from scipy.linalg import expm

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


def _steady(A: np.ndarray, B: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(3, t.size): the equilibrium of the mean torque plus, per tone, Im(X e^{j w t}), X = (j w I - A)^-1 B a."""
    out = np.repeat(np.linalg.solve(-A, B * MEAN)[:, None], t.size, axis=1)
    for a, f in TONES:
        w = 2 * np.pi * f
        X = np.linalg.solve(1j * w * np.eye(3) - A, B * a)
        out += np.imag(X[:, None] * np.exp(1j * w * t)[None, :])
    return out


def simulate(seed: int, T: float = 14.0, t0: float | None = None, factor: float = 1.0,
             which: str = "Rl") -> dict[str, np.ndarray]:
    """Columns t, Te, wp, P, wm every TS s over [0, T]; from ``t0`` (a sample time) ``which`` times ``factor``."""
    t = np.arange(0.0, T + TS / 2, TS)
    k0 = t.size if t0 is None or which == "beta_P" else int(np.searchsorted(t, t0 - TS / 2))
    x = np.empty((3, t.size))
    state = None
    for a, b, scale in ((0, k0, 1.0), (k0, t.size, factor)):
        if a >= b:
            continue
        P = dict(NOMINAL)
        if which in P:
            P[which] *= scale
        A, B = _system(P)
        ss = _steady(A, B, t[a:b])
        step = expm(A * TS)
        z = np.zeros(3) if state is None else state - ss[:, 0]     # the transient at the stretch's start
        for k in range(b - a):
            x[:, a + k] = ss[:, k] + z
            z = step @ z
        if b < t.size:                        # the state at the next stretch's first sample, these parameters'
            state = _steady(A, B, t[b:b + 1])[:, 0] + z
    wp, p, wm = x
    rng = np.random.default_rng(seed)
    gain = np.where(t >= t0, factor, 1.0) if t0 is not None and which == "beta_P" else 1.0
    return {"t": t, "Te": torque(t), "wp": wp + rng.normal(0.0, NOISE["wp"], t.size),
            "P": gain * p + rng.normal(0.0, NOISE["P"], t.size), "wm": wm + rng.normal(0.0, NOISE["wm"], t.size)}
