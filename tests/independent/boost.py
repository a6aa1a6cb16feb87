"""A PWM boost converter integrated from its circuit equations (Erickson & Maksimovic, ch. 2),
apart from bgfdi: one linear ODE per switch position, scipy between the PWM edges.

    s = 1:  L diL/dt = Vin - (rL + Ron) iL,          Co dvo/dt = -vo/Rload
    s = 0:  L diL/dt = Vin - (rL + Rd) iL - vo,      Co dvo/dt = iL - vo/Rload
"""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

NOMINAL = {"L": 1.0e-4, "rL": 0.05, "Ron": 0.02, "Rd": 0.05, "Co": 1.0e-4, "Rload": 10.0, "Vin": 12.0}
F_PWM = 20_000.0


def simulate(T: float, fs: float = 1.0e6, *, changes: dict[str, tuple[float, float]] | None = None,
             noise: float = 0.0, seed: int = 0, x0: tuple[float, float] = (0.0, 0.0),
             gains: dict[str, tuple[float, float]] | None = None) -> dict[str, np.ndarray]:
    """Columns t, Vin, s_cmd, iL, vo sampled at ``fs``; ``changes``: parameter -> (t0, new value),
    an abrupt fault; ``gains``: sensor (iL, vo) -> (t0, gain), a sensor's gain fault; ``noise``:
    standard deviation added to iL and vo."""
    changes = changes or {}
    t = np.round(np.arange(0.0, T + 0.5 / fs, 1.0 / fs), 12)
    half = 0.5 / F_PWM
    edges = sorted({0.0, T, *(k * half for k in range(1, int(T / half) + 1) if k * half < T),
                    *(c[0] for c in changes.values() if 0 < c[0] < T)})

    def value(name: str, at: float) -> float:
        c = changes.get(name)
        return c[1] if c and at >= c[0] else NOMINAL[name]

    x = np.array(x0, dtype=float)
    out = np.zeros((2, t.size))
    for a, b in zip(edges[:-1], edges[1:]):
        mid = 0.5 * (a + b)
        on = (mid % (2 * half)) < half
        p = {k: value(k, mid) for k in NOMINAL}

        def rhs(_t, y, p=p, on=on):
            i, v = y
            if on:
                return [(p["Vin"] - (p["rL"] + p["Ron"]) * i) / p["L"], -v / (p["Rload"] * p["Co"])]
            return [(p["Vin"] - (p["rL"] + p["Rd"]) * i - v) / p["L"], (i - v / p["Rload"]) / p["Co"]]
        last = b == edges[-1]
        mask = (t >= a - 1e-15) & ((t < b - 1e-15) | last)
        sol = solve_ivp(rhs, (a, b), x, t_eval=np.clip(t[mask], a, b), method="LSODA", rtol=1e-11, atol=1e-12)
        out[:, mask] = sol.y
        x = solve_ivp(rhs, (a, b), x, method="LSODA", rtol=1e-11, atol=1e-12).y[:, -1]
    s = ((t % (2 * half)) < half).astype(float)
    for k, name in enumerate(("iL", "vo")):
        if gains and name in gains:
            out[k] = np.where(t >= gains[name][0], gains[name][1] * out[k], out[k])
    rng = np.random.default_rng(seed)
    iL = out[0] + (rng.normal(0.0, noise, t.size) if noise else 0.0)
    vo = out[1] + (rng.normal(0.0, noise, t.size) if noise else 0.0)
    return {"t": t, "Vin": np.full(t.size, NOMINAL["Vin"]), "s_cmd": s, "iL": iL, "vo": vo}


def simulate_dcm(T: float, fs: float = 1.0e6, p: dict | None = None) -> dict[str, np.ndarray]:
    """The converter in discontinuous conduction: while the switch is open the diode conducts
    until the inductor current reaches zero (an event located by scipy), then both branches are
    off, the current stays zero and the capacitor feeds the load alone."""
    p = dict(NOMINAL, **(p or {}))
    t = np.round(np.arange(0.0, T + 0.5 / fs, 1.0 / fs), 12)
    half = 0.5 / F_PWM
    out = np.zeros((2, t.size))
    x = np.zeros(2)

    def on(_t, y):
        return [(p["Vin"] - (p["rL"] + p["Ron"]) * y[0]) / p["L"], -y[1] / (p["Rload"] * p["Co"])]

    def diode(_t, y):
        return [(p["Vin"] - (p["rL"] + p["Rd"]) * y[0] - y[1]) / p["L"], (y[0] - y[1] / p["Rload"]) / p["Co"]]

    def off(_t, y):
        return [0.0, -y[1] / (p["Rload"] * p["Co"])]

    def empty(_t, y):
        return y[0]
    empty.terminal, empty.direction = True, -1
    k = 0
    a = 0.0
    while a < T - 1e-15:
        b = min(T, (k + 1) * half)
        phases = [(on, None)] if k % 2 == 0 else [(diode, empty), (off, None)]
        start = a
        for rhs, event in phases:
            if x[0] <= 0 and rhs is diode:
                x[0] = 0.0
                continue
            sol = solve_ivp(rhs, (start, b), x, method="LSODA", rtol=1e-11, atol=1e-12, dense_output=True,
                            events=event)
            end = sol.t[-1]
            last = end >= T - 1e-15
            mask = (t >= start - 1e-15) & ((t < end - 1e-15) | last)
            out[:, mask] = sol.sol(t[mask])
            x = sol.y[:, -1].copy()
            if event is not None and sol.status == 1:     # the current reached zero: the diode blocks
                x[0] = 0.0
                start = end
                continue
            break
        a = b
        k += 1
    out[0] = np.where(out[0] < 0, 0.0, out[0])
    s = ((t % (2 * half)) < half).astype(float)
    return {"t": t, "Vin": np.full(t.size, p["Vin"]), "s_cmd": s, "iL": out[0], "vo": out[1]}
