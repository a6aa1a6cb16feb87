"""Independent simulator of tests/data/rc_two_sensors.yaml: a source u through R into a capacitor C
with a load RL across it, typed by hand (C dv/dt = (u - v)/R - v/RL, i = (u - v)/R), never importing
``bondgraph`` or ``fdi``. u = 5 + 2 sin(3 t); v starts at the source mean's equilibrium; the current
reads with 10 uA of noise, the voltage with 1 mV (seeded)."""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

R, C, RL = 100.0, 1.0e-3, 200.0
TS = 1.0e-3


def simulate(T: float, seed: int, drift: tuple[float, float] | None = None) -> dict[str, np.ndarray]:
    """Columns t, u, i, v of a run of ``T`` seconds: fault-free, or with the load decaying from
    ``drift`` = (t0, b) as RL exp(b (t - t0)) (eq. 16's profile, written here by hand)."""
    t = np.arange(0.0, T, TS)
    u = 5.0 + 2.0 * np.sin(3.0 * t)

    def load(s: float) -> float:
        return RL if drift is None or s < drift[0] else RL * np.exp(drift[1] * (s - drift[0]))
    sol = solve_ivp(lambda s, x: [((5.0 + 2.0 * np.sin(3.0 * s) - x[0]) / R - x[0] / load(s)) / C], (0.0, T),
                    [5.0 * RL / (R + RL)], t_eval=t, rtol=1e-10, atol=1e-12, max_step=1e-2)
    rng = np.random.default_rng(seed)
    v = sol.y[0] + rng.normal(0.0, 1e-3, t.size)
    i = (u - sol.y[0]) / R + rng.normal(0.0, 1e-5, t.size)
    return {"t": t, "u": u, "i": i, "v": v}


def write(path, columns: dict[str, np.ndarray]) -> None:
    """The columns as a measurement CSV, every digit kept."""
    np.savetxt(path, np.column_stack([columns[k] for k in ("t", "u", "i", "v")]), delimiter=",",
               header="t,u,i,v", comments="", fmt="%.17g")
