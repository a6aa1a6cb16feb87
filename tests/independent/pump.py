"""Independent simulator of tests/data/motor_pump_tank.yaml: a DC motor driving a positive-
displacement pump that fills an accumulator drained through a valve (Karnopp, Margolis &
Rosenberg, System Dynamics, Sec. 8.2 and ch. 4), typed by hand from its three state equations,
never importing ``bondgraph`` or ``fdi``:

    La di/dt = u - Ra i - K w,     J dw/dt = K i - b w - D p,     C dp/dt = D w - p / Ro

A fault from ``t0`` multiplies ``which`` (Ro, Ra, b) by ``factor``, or the pressure transducer's
reading (beta_p). Integrated by scipy's LSODA from the steady state under u = 12 V (solved by hand);
the signals read with noise (10 mA, 0.1 rad/s, 100 Pa), the voltage exactly."""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

NOMINAL = {"Ra": 1.0, "La": 0.01, "K": 0.05, "J": 1.0e-4, "b": 1.0e-5, "D": 1.0e-6, "C": 1.0e-8, "Ro": 1.0e9}
TS = 1.0e-3
NOISE = {"i": 1.0e-2, "w": 0.1, "p": 100.0}


def voltage(t):
    """The armature voltage (V): the model's input expression, written out."""
    return 12.0 + 2.0 * np.sin(2 * np.pi * 0.5 * t)


def simulate(seed: int, T: float = 40.0, t0: float | None = None, factor: float = 1.0,
             which: str = "Ro") -> dict[str, np.ndarray]:
    """Columns t, u, i, w, p every TS s over [0, T]; from ``t0`` ``which`` times ``factor``."""
    n = NOMINAL

    def rhs(t, x, Ra, b, Ro):
        i, w, p = x
        return [(voltage(t) - Ra * i - n["K"] * w) / n["La"], (n["K"] * i - b * w - n["D"] * p) / n["J"],
                (n["D"] * w - p / Ro) / n["C"]]

    def par(t, name):
        return n[name] * (factor if t0 is not None and which == name and t >= t0 else 1.0)

    w0 = n["K"] * 12.0 / n["Ra"] / (n["K"] ** 2 / n["Ra"] + n["b"] + n["D"] ** 2 * n["Ro"])     # steady, by hand
    x = [(12.0 - n["K"] * w0) / n["Ra"], w0, n["Ro"] * n["D"] * w0]
    t = np.arange(0.0, T + TS / 2, TS)
    edges = [0.0, T] if t0 is None else [0.0, t0, T]
    pieces = []
    for a, c in zip(edges[:-1], edges[1:]):
        keep = t[(t >= a) & ((t < c) | (c == T))]
        s = solve_ivp(rhs, (a, c), x, args=(par(a, "Ra"), par(a, "b"), par(a, "Ro")),
                      t_eval=np.append(keep, c) if keep[-1] < c else keep, method="LSODA", rtol=1e-10,
                      atol=[1e-10, 1e-8, 1e-4], max_step=0.01)
        pieces.append(s.y[:, :keep.size])
        x = list(s.y[:, -1])
    i, w, p = np.hstack(pieces)
    rng = np.random.default_rng(seed)
    gain = np.where(t >= t0, factor, 1.0) if t0 is not None and which == "beta_p" else 1.0
    return {"t": t, "u": voltage(t), "i": i + rng.normal(0.0, NOISE["i"], t.size),
            "w": w + rng.normal(0.0, NOISE["w"], t.size), "p": gain * p + rng.normal(0.0, NOISE["p"], t.size)}
