"""Independent simulator of tests/data/car_longitudinal.yaml: a car's longitudinal dynamics on a
level road (Gillespie, Fundamentals of Vehicle Dynamics, ch. 2 and 4), typed by hand from Newton's
law, never importing ``bondgraph`` or ``fdi``:

    m dv/dt = F(t) - kd v|v| - Fr sign(v)

A fault from ``t0`` multiplies ``which`` (kd, Fr) by ``factor``, or the speed sensor's reading
(beta_v). Integrated by scipy's LSODA (rtol 1e-10) from the steady speed under F(0); the speed reads
with 0.05 m/s of noise, the traction force exactly."""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

NOMINAL = {"m": 1500.0, "kd": 0.396, "Fr": 147.0}          # kg, N s^2/m^2, N
TS, NOISE = 0.1, 0.05                                       # s, m/s


def force(t):
    """The traction force (N): the model's input expression, written out."""
    return 400.0 + 250.0 * np.sin(2 * np.pi * t / 90.0) + 150.0 * np.sin(2 * np.pi * t / 23.0)


def simulate(seed: int, T: float = 700.0, t0: float | None = None, factor: float = 1.0,
             which: str = "kd") -> dict[str, np.ndarray]:
    """Columns t, F, v every TS s over [0, T]; from ``t0`` ``which`` times ``factor``."""
    def par(t, name):
        return NOMINAL[name] * (factor if t0 is not None and which == name and t >= t0 else 1.0)

    def rhs(t, x, kd, Fr):
        v = x[0]
        return [(force(t) - kd * v * abs(v) - Fr * np.sign(v)) / NOMINAL["m"]]

    t = np.arange(0.0, T + TS / 2, TS)
    v0 = np.sqrt((force(0.0) - NOMINAL["Fr"]) / NOMINAL["kd"])
    edges = [0.0, T] if t0 is None else [0.0, t0, T]
    pieces, x = [], [v0]
    for a, b in zip(edges[:-1], edges[1:]):
        keep = t[(t >= a) & ((t < b) | (b == T))]
        s = solve_ivp(rhs, (a, b), x, args=(par(a, "kd"), par(a, "Fr")),
                      t_eval=np.append(keep, b) if keep[-1] < b else keep, rtol=1e-10, atol=1e-12, method="LSODA")
        pieces.append(s.y[0, :keep.size])
        x = [s.y[0, -1]]
    v = np.concatenate(pieces)
    gain = np.where(t >= t0, factor, 1.0) if t0 is not None and which == "beta_v" else 1.0
    return {"t": t, "F": force(t), "v": gain * v + np.random.default_rng(seed).normal(0.0, NOISE, t.size)}
