"""Independent simulator of tests/data/transformer.yaml: a single-phase transformer on the 50 Hz mains
feeding an R-L load (Hughes, Electrical and Electronic Technology, ch. 31: the equivalent circuit with
the magnetising branch neglected), typed by hand from Kirchhoff's laws, never importing ``bondgraph``
or ``fdi``:

    v1 = V - R1 i1,   v2 = v1 / N,   i1 = i2 / N,   L2 di2/dt = v2 - R2 i2

Faults from ``t0``: the load resistance R2 or the turns ratio N (shorted turns) stepping to a new
value. Integrated by scipy (LSODA, steps of at most one sample); currents with 2 mA (primary) and
20 mA (secondary) noise."""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

R1, N, R2, L2 = 0.5, 10.0, 2.0, 5.0e-3     # Ohm, -, Ohm, H
TS = 1.0e-4                                # s


def mains(t):
    """The primary voltage (V): the model's input expression, written out."""
    return 325 * np.sin(314.159 * t)


def simulate(seed: int, T: float = 2.0, t0: float | None = None, r2: float = R2,
             n: float = N) -> dict[str, np.ndarray]:
    """Columns t, V, i1, i2 every TS s over [0, T]; from ``t0`` the load is ``r2`` and the ratio ``n``."""
    def at(t):
        late = t0 is not None and t >= t0
        return (r2, n) if late else (R2, N)

    def rhs(t, y):
        r, k = at(t)
        i1 = y[0] / k
        return [((mains(t) - R1 * i1) / k - r * y[0]) / L2]

    t = np.arange(0.0, T + TS / 2, TS)
    sol = solve_ivp(rhs, (0.0, T), [0.0], t_eval=t, method="LSODA", rtol=1e-9, atol=1e-11, max_step=TS)
    i2 = sol.y[0]
    i1 = i2 / np.array([at(x)[1] for x in t])
    rng = np.random.default_rng(seed)
    return {"t": t, "V": mains(t), "i1": i1 + rng.normal(0.0, 2e-3, t.size), "i2": i2 + rng.normal(0.0, 2e-2, t.size)}
