"""Independent simulator of tests/data/solenoid.yaml: a held solenoid's coil (Karnopp, Margolis &
Rosenberg, System Dynamics, ch. 4), typed by hand, never importing ``bondgraph`` or ``fdi``, with
the flux as the state:

    dq/dt = (V - Rc i) / N,   i = q / (N P),   P = Pc Pg / (Pc + Pg)

under V(t) = 12 + 6 sin(20 t) V from rest. Fault from ``t0``: the air-gap permeance Pg becomes
``pg`` (the gap grown); the flux is continuous there, so the current jumps (i P is). Integrated by
scipy (LSODA, steps of at most one sample); the current with 1 mA noise."""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

RC, N, PC, PG = 4.0, 500.0, 4.0e-6, 4.0e-7     # Ohm, turns, Wb/A, Wb/A
TS = 0.0005                                     # s


def supply(t):
    """The supply voltage (V): the model's input expression, written out."""
    return 12 + 6 * np.sin(20 * t)


def simulate(seed: int, T: float = 3.0, t0: float | None = None, pg: float = PG) -> dict[str, np.ndarray]:
    """Columns t, V, i every TS s over [0, T]; from ``t0`` the gap's permeance is ``pg``."""
    def permeance(s):
        g = pg if t0 is not None and s >= t0 else PG
        return PC * g / (PC + g)
    t = np.arange(0.0, T + TS / 2, TS)
    sol = solve_ivp(lambda s, y: [(supply(s) - RC * y[0] / (N * permeance(s))) / N], (0.0, T), [0.0], t_eval=t,
                    method="LSODA", rtol=1e-10, atol=1e-14, max_step=TS)
    i = sol.y[0] / (N * np.array([permeance(s) for s in t]))
    return {"t": t, "V": supply(t), "i": i + np.random.default_rng(seed).normal(0.0, 1e-3, t.size)}
