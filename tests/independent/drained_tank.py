"""Independent simulator of tests/data/drained_tank.yaml: a pumped tank drained through a valve
(Torricelli's law, Munson, Fundamentals of Fluid Mechanics; Ogata, System Dynamics, liquid-level
systems), typed by hand from the volume balance of the pressure at its bottom, never importing
``bondgraph`` or ``fdi``:

    C dp/dt = Qin(t) - Kv sign(p) sqrt|p|,    Qout = Kv sqrt(p)

A fault from ``t0`` multiplies the valve coefficient Kv (a clog) or the capacitance C (sediment
narrowing the tank) by ``factor``. Integrated by scipy from the steady state of the mean inflow;
the outflow meter reads with 2e-5 m^3/s of noise (0.2 % of the flow)."""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

C, KV, TS = 5.097e-6, 1.0e-4, 0.05        # m^3/Pa, m^3/s/Pa^0.5, s


def inflow(t):
    """The pumped inflow (m^3/s): the model's input expression, written out."""
    return 0.01 * (1 + 0.3 * np.sin(0.5 * t))


def simulate(seed: int, T: float = 120.0, t0: float | None = None, factor: float = 1.0,
             which: str = "Kv") -> dict[str, np.ndarray]:
    """Columns t, Qin, Qout every TS s over [0, T]; from ``t0`` parameter ``which`` times ``factor``."""
    def kv(t):
        return KV * factor if t0 is not None and which == "Kv" and t >= t0 else KV

    def cap(t):
        return C * factor if t0 is not None and which == "C" and t >= t0 else C

    def rhs(t, p):
        return [(inflow(t) - kv(t) * np.sign(p[0]) * np.sqrt(abs(p[0]))) / cap(t)]

    t = np.arange(0.0, T + TS / 2, TS)
    edges = [0.0, T] if t0 is None else [0.0, t0, T]
    p, pieces = [(inflow(0.0) / KV) ** 2], []
    for a, b in zip(edges[:-1], edges[1:]):
        keep = t[(t >= a) & ((t < b) | (b == T))]
        sol = solve_ivp(rhs, (a, b), p, method="LSODA", t_eval=keep, rtol=1e-10, atol=1e-8, dense_output=True)
        pieces.append(sol.y[0])
        p = sol.sol(b)
    pressure = np.concatenate(pieces)
    qout = np.array([kv(x) for x in t]) * np.sqrt(pressure)
    rng = np.random.default_rng(seed)
    return {"t": t, "Qin": inflow(t), "Qout": qout + rng.normal(0.0, 2.0e-5, t.size)}
