"""Independent simulator of tests/data/battery_pack.yaml (a user trial's plant, trimmed): three
lithium-ion cells in series, each a first-order Thevenin circuit (Plett, Battery Management
Systems vol. 1, ch. 2), a main contactor and a bleed resistor Rb across the pack, never importing
``bondgraph`` or ``fdi``. With ich = -i the string's charging current, q_k the charge each cell
stored since the start and u_k its polarisation voltage:

    V_k = U_k + q_k / Cb_k + R0_k ich + u_k,    q_k' = ich,    C1_k u_k' = ich - u_k / R1_k
    ich = -c Iinv(t) - Vp / Rb,    Vp = V1 + V2 + V3      (solved for ich: one linear equation)

c is the contactor (1 closed); ``stuck_open`` holds it at 0 from that time; ``growth`` = (cell, t0,
b) makes that cell's R0 grow as R0 e^(b (t - t0)) from t0 (an ageing cell, eq. (16)'s form). scipy's
LSODA at rtol 1e-10, restarted where the contactor switches and where the growth starts."""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

U = np.array([4.04, 4.0222, 4.0578])
CB, R0, R1, C1, RB = 225000.0, 0.0015, 0.001, 30000.0, 50.0
NOISE = {"i": 0.2, "Qd": 0.05, "V1": 1e-3, "V2": 1e-3, "V3": 1e-3, "Vp": 5e-3}


def current(t):
    """The inverter's draw (A), as the model's input expression."""
    return 60.0 + 50.0 * np.sin(0.05 * np.asarray(t, float))


def command(t, opens: tuple[float, float] | None = None):
    """The contactor's command: closed from 20 s (as the model's mode expression), open over ``opens``."""
    t = np.asarray(t, float)
    c = (t >= 20.0).astype(float)
    if opens is not None:
        c[(t >= opens[0]) & (t < opens[1])] = 0.0
    return c


def simulate(T: float, fs: float, opens=None, stuck_open: float | None = None, seed: int | None = None,
             growth: tuple[int, float, float] | None = None) -> dict:
    """The data columns (t, Iinv, c_cmd, i, Qd, V1, V2, V3, Vp) of a run; the sensors' noise when
    ``seed`` is given."""
    t = np.arange(int(round(T * fs)) + 1) / fs
    cmd = command(t, opens)

    def actual(tt: float) -> float:
        if stuck_open is not None and tt >= stuck_open:
            return 0.0
        return float(command([tt], opens)[0])

    def r0(tt: float) -> np.ndarray:
        out = np.full(3, R0)
        if growth is not None and tt >= growth[1]:
            out[growth[0]] *= np.exp(growth[2] * (tt - growth[1]))
        return out

    def charging(tt, x, c):
        ocv, u = U + x[0:3] / CB, x[3:6]
        return (-c * float(current(tt)) - (ocv + u).sum() / RB) / (1 + r0(tt).sum() / RB)

    def rhs(tt, x, c):
        ich = charging(tt, x, c)
        return np.concatenate([[ich] * 3, (ich - x[3:6] / R1) / C1])

    edges = sorted({0.0, T} | {float(x) for x in t[1:][np.diff(cmd) != 0]}
                   | ({stuck_open} if stuck_open is not None else set()) | ({growth[1]} if growth else set()))
    X, x = np.zeros((t.size, 6)), np.zeros(6)
    for a, b in zip(edges[:-1], edges[1:]):
        c = actual(a + 1e-9)
        inside = (t >= a - 1e-9) & (t <= b + 1e-9)
        sol = solve_ivp(rhs, (a, b), x, args=(c,), t_eval=t[inside], rtol=1e-10, atol=1e-10, method="LSODA")
        X[inside], x = sol.y.T, sol.y[:, -1]
    ich = np.array([charging(tt, X[n], actual(tt + 1e-9)) for n, tt in enumerate(t)])
    V = U + X[:, 0:3] / CB + np.array([r0(tt) for tt in t]) * ich[:, None] + X[:, 3:6]
    cols = {"t": t, "Iinv": current(t), "c_cmd": cmd, "i": -ich, "Qd": -X[:, 0], "V1": V[:, 0], "V2": V[:, 1],
            "V3": V[:, 2], "Vp": V.sum(axis=1)}
    if seed is not None:
        rng = np.random.default_rng(seed)
        for k, s in NOISE.items():
            cols[k] = cols[k] + s * rng.standard_normal(t.size)
    return cols
