"""The variable-volume actuator of models/variable_volume_actuator.yaml integrated from its
equations by scipy, apart from bgfdi (Merritt 1967, eq. 3-28: a chamber of volume V0 + A x):

    p' = (beta_e (beta_Q Q - p/Rl - A v) - p A v) / (V0 + A x),   m v' = A p - b v - x/ck,   x' = v
"""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

NOMINAL = {"beta_e": 1.0e9, "V0": 1.0e-4, "A": 1.0e-3, "Rl": 1.0e11, "m": 5.0, "b": 500.0, "ck": 5.0e-5}


def pump(t):
    return 1.0e-5 * np.sin(2 * t) + 0.5e-5 * np.sin(5 * t)


def simulate(T: float, seed: int, *, fs: float = 1000.0, changes: dict[str, tuple[float, float]] | None = None,
             pump_rate: tuple[float, float] | None = None, p_gain: tuple[float, float] | None = None,
             noise: tuple[float, float] = (50.0, 1.0e-6)) -> dict[str, np.ndarray]:
    """Columns t, Q, p, x. ``changes``: parameter -> (t0, value), abrupt; ``pump_rate``: (t0, b1), the
    pump's volumetric efficiency beta_Q = exp(b1 (t - t0)) from t0 (eq. 16); ``p_gain``: (t0, gain)
    of the pressure transducer; ``noise``: standard deviations of p and x."""
    changes = changes or {}

    def par(name, t):
        c = changes.get(name)
        return c[1] if c and t >= c[0] else NOMINAL[name]

    def beta_q(t):
        return np.exp(pump_rate[1] * np.maximum(t - pump_rate[0], 0.0)) if pump_rate else 1.0

    def rhs(t, y):
        p, v, x = y
        P = {k: par(k, t) for k in NOMINAL}
        volume = P["V0"] + P["A"] * x
        flow = beta_q(t) * pump(t) - p / P["Rl"] - P["A"] * v
        return [(P["beta_e"] * flow - p * P["A"] * v) / volume, (P["A"] * p - P["b"] * v - x / P["ck"]) / P["m"], v]
    t = np.arange(int(round(T * fs)) + 1) / fs
    cuts = sorted({0.0, T, *(c[0] for c in changes.values() if 0 < c[0] < T)})
    y = np.zeros((3, t.size))
    state = np.zeros(3)
    for a, b in zip(cuts[:-1], cuts[1:]):
        mask = (t >= a) & ((t < b) | (b == T))
        sol = solve_ivp(rhs, (a, b), state, t_eval=t[mask], method="Radau", rtol=1e-10, atol=[1e-3, 1e-12, 1e-13],
                        dense_output=True)
        y[:, mask] = sol.y
        state = sol.sol(b)
    rng = np.random.default_rng(seed)
    p = y[0] * (np.where(t >= p_gain[0], p_gain[1], 1.0) if p_gain else 1.0)
    return {"t": t, "Q": pump(t), "p": p + rng.normal(0, noise[0], t.size), "x": y[2] + rng.normal(0, noise[1], t.size)}
