"""Independent simulator of tests/data/li_ion_cell.yaml: a lithium-ion cell as its Thevenin
equivalent circuit (Plett, Battery Management Systems vol. 1, ch. 2), typed by hand, never importing
``bondgraph`` or ``fdi``:

    C1 du1/dt = I - u1 / R1,   V = E - R0 I - u1

under the load current I(t) = 2 + 1.5 sin(0.2 t) A. Fault from ``t0``: the ohmic resistance R0
stepping to ``r0`` (a loose tab, a cracked weld). Integrated by scipy (LSODA, steps of at most one
sample); the terminal voltage with 1 mV noise."""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

E, R0, R1, C1 = 3.7, 0.05, 0.03, 1000.0     # V, Ohm, Ohm, F
TS = 0.1                                    # s


def load(t):
    """The load current (A): the model's input expression, written out."""
    return 2 + 1.5 * np.sin(0.2 * t)


def simulate(seed: int, T: float = 600.0, t0: float | None = None, r0: float = R0) -> dict[str, np.ndarray]:
    """Columns t, I, V every TS s over [0, T]; from ``t0`` the ohmic resistance is ``r0``."""
    t = np.arange(0.0, T + TS / 2, TS)
    sol = solve_ivp(lambda s, y: [(load(s) - y[0] / R1) / C1], (0.0, T), [R1 * load(0.0)], t_eval=t,
                    method="LSODA", rtol=1e-10, atol=1e-12, max_step=TS)
    r = np.where(t >= t0, r0, R0) if t0 is not None else np.full(t.size, R0)
    v = E - r * load(t) - sol.y[0]
    return {"t": t, "I": load(t), "V": v + np.random.default_rng(seed).normal(0.0, 1e-3, t.size)}
