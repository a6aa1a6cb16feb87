"""Independent simulator of tests/data/cstr.yaml: a continuous stirred-tank reactor with a first-order
reaction A -> B (Fogler, Elements of Chemical Reaction Engineering, ch. 5), typed by hand from the
mole balance of A, never importing ``bondgraph`` or ``fdi``:

    V dcA/dt = F(t) - q cA - k(t) V cA,    q = 1/Rout,   k V = 1/Rrx(t)

Catalyst deactivation: from ``t0`` the reaction's resistance 1/(k V) grows as dR/dt = b R (the
activity decays exponentially, eq. 16 of the paper). Integrated by scipy from the steady state of the
mean feed; concentration with 0.2 mol/m^3 noise, feed with 0.02 mol/s."""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

V, ROUT, RRX = 0.5, 100.0, 100.0          # m^3, s/m^3, s/m^3
TS = 0.1                                  # s


def feed(t):
    """The molar feed of A (mol/s): the model's input expression, written out."""
    return 10 + 3 * np.sin(0.05 * t) + 2 * np.sin(0.013 * t)


def simulate(seed: int, T: float = 900.0, t0: float | None = None, b: float = 0.0) -> dict[str, np.ndarray]:
    """Columns t, F, c every TS s over [0, T]; from ``t0`` the reaction's resistance grows at rate ``b``."""
    def rrx(t):
        return RRX * (np.exp(b * (t - t0)) if t0 is not None and t >= t0 else 1.0)

    t = np.arange(0.0, T + 1e-9, TS)
    sol = solve_ivp(lambda tt, y: [(feed(tt) - y[0] / ROUT - y[0] / rrx(tt)) / V], (0.0, T), [500.0],
                    t_eval=t, rtol=1e-10, atol=1e-8, max_step=0.5)
    rng = np.random.default_rng(seed)
    return {"t": t, "F": feed(t) + rng.normal(0.0, 0.02, t.size), "c": sol.y[0] + rng.normal(0.0, 0.2, t.size)}
