"""Independent simulator of tests/data/helmholtz.yaml: two acoustic cavities linked by a neck, the
second vented through a port (Kinsler et al., Fundamentals of Acoustics, ch. 10), typed by hand,
never importing ``bondgraph`` or ``fdi``, with the cavities' pressures and the neck's volume
velocity as states:

    C1 p1' = Q - f,    In f' = p1 - p2 - Rn f,    C2 p2' = f - p2 / Rp

under Q(t) = 1e-4 (1 + 0.5 sin(31.4 t)) m^3/s from the steady state of Q(0). Faults from ``t0``:
the neck's resistance ``rn``, the port's ``rp``, microphone 2's gain ``g2``. Integrated by scipy
(LSODA, steps of at most one sample); both pressures with 0.05 Pa noise."""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

C1, C2, IN, RN, RP = 7.09e-9, 1.418e-8, 600.0, 1.4e5, 3.5e6   # m^3/Pa, m^3/Pa, kg/m^4, Pa s/m^3, Pa s/m^3
TS = 0.0005                                                    # s


def volume_velocity(t):
    """The loudspeaker's volume velocity (m^3/s): the model's input expression, written out."""
    return 1.0e-4 * (1 + 0.5 * np.sin(31.4 * t))


def simulate(seed: int, T: float = 2.0, t0: float | None = None, rn: float = RN, rp: float = RP,
             g2: float = 1.0) -> dict[str, np.ndarray]:
    """Columns t, Q, p1, p2 every TS s over [0, T]; from ``t0`` the faults' values."""
    def after(s):
        return t0 is not None and s >= t0

    def rhs(s, y):
        p1, f, p2 = y
        return [(volume_velocity(s) - f) / C1, (p1 - p2 - (rn if after(s) else RN) * f) / IN,
                (f - p2 / (rp if after(s) else RP)) / C2]
    q0 = volume_velocity(0.0)
    t = np.arange(0.0, T + TS / 2, TS)
    sol = solve_ivp(rhs, (0.0, T), [q0 * (RP + RN), q0, q0 * RP], t_eval=t, method="LSODA", rtol=1e-10,
                    atol=1e-9, max_step=TS)
    rng = np.random.default_rng(seed)
    gain = np.where([after(s) for s in t], g2, 1.0)
    return {"t": t, "Q": volume_velocity(t), "p1": sol.y[0] + rng.normal(0.0, 0.05, t.size),
            "p2": gain * sol.y[2] + rng.normal(0.0, 0.05, t.size)}
