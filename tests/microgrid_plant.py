"""A DC microgrid bus simulated from its physics with scipy, apart from bgfdi (the model is
tests/data/dc_microgrid.yaml): a PV string's current i_pv = 5 + 2 sin(0.5 t) A and a battery
(EMF 48 V behind R_b = 1 ohm) feed a DC-link capacitor C = 10 mF; a 10 ohm load is switched in
while sin(t) > 0 (a contactor: the command column ``load_cmd`` as sampled). Kirchhoff:

    C dv/dt = i_pv + (E - v) / R_b - load v / R_L,    i_b = (E - v) / R_b

integrated stretch by stretch between the contactor's switches (at k pi, between samples) and the
fault's onset, LSODA at rtol 1e-10. Sensors: v (noise 0.02 V) and i_b (0.01 A).
"""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

C0, RB0, RL, E, TS = 0.01, 1.0, 10.0, 48.0, 0.001
HEAD = ["t", "i_pv", "load_cmd", "v", "i_b"]


def simulate(T: float, seed: int, fault: dict | None = None) -> np.ndarray:
    """Rows of ``HEAD`` at 1 kHz for ``T`` s. ``fault``: {"name": "R_b", "t0", "value"} (a step of the
    battery's resistance) or {"name": "C", "t0", "b"} (the capacitance drifting as C0 e^(b (t - t0)))."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, T + TS / 2, TS)

    def ipv(s):
        return 5 + 2 * np.sin(0.5 * s)

    def par(s: float) -> tuple[float, float]:
        C, Rb = C0, RB0
        if fault and s >= fault["t0"]:
            if fault["name"] == "R_b":
                Rb = fault["value"]
            else:
                C = C0 * np.exp(fault["b"] * (s - fault["t0"]))
        return C, Rb

    cuts = sorted({0.0, T, *(k * np.pi for k in range(1, int(T / np.pi) + 1)), *([fault["t0"]] if fault else [])})
    v, y = np.empty(t.size), [46.0]
    v[0] = y[0]
    for a, b in zip(cuts[:-1], cuts[1:]):
        closed = float(np.sin((a + b) / 2) > 0)

        def rhs(s, x, closed=closed):
            C, Rb = par(s)
            return [(ipv(s) + (E - x[0]) / Rb - closed * x[0] / RL) / C]
        inside = (t > a) & (t <= b)
        at = t[inside] if np.isclose(t[inside][-1], b) else np.r_[t[inside], b]
        sol = solve_ivp(rhs, (a, b), y, t_eval=at, rtol=1e-10, atol=1e-12, method="LSODA")
        v[inside] = sol.y[0, :inside.sum()]
        y = [sol.y[0, -1]]
    Rb = np.array([par(s)[1] for s in t])
    rows = np.column_stack([t, ipv(t), (np.sin(t) > 0).astype(float), v, (E - v) / Rb])
    rows[:, 3] += rng.normal(0, 0.02, t.size)
    rows[:, 4] += rng.normal(0, 0.01, t.size)
    return rows
