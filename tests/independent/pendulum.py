"""Independent simulator of tests/data/pendulum.yaml: a torque-driven pendulum with viscous pivot
friction (Karnopp, Margolis & Rosenberg, ch. 4), typed by hand, never importing ``bondgraph`` or
``fdi``:

    J theta'' = tau - b theta' - mgl sin(theta),    tau(t) = 0.6 sin(2 t) N m

from rest hanging down. Faults from ``t0``: the friction ``b``, the tachometer's gain ``g``.
Integrated by scipy (LSODA, steps of at most one sample); the encoder with 0.5 mrad noise, the
tachometer with 2 mrad/s."""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

J, B, MGL, TS = 0.05, 0.02, 1.2, 0.001      # kg m^2, N m s/rad, N m, s


def torque(t):
    """The motor's torque (N m): the model's input expression, written out."""
    return 0.6 * np.sin(2.0 * t)


def simulate(seed: int, T: float = 12.0, t0: float | None = None, b: float = B, g: float = 1.0) -> dict:
    """Columns t, tau, theta, omega every TS s over [0, T]; from ``t0`` the faults' values."""
    def after(s):
        return t0 is not None and s >= t0

    def rhs(s, y):
        theta, w = y
        return [w, (torque(s) - (b if after(s) else B) * w - MGL * np.sin(theta)) / J]
    t = np.arange(0.0, T + TS / 2, TS)
    sol = solve_ivp(rhs, (0.0, T), [0.0, 0.0], t_eval=t, method="LSODA", rtol=1e-10, atol=1e-10, max_step=TS)
    rng = np.random.default_rng(seed)
    gain = np.where([after(s) for s in t], g, 1.0)
    return {"t": t, "tau": torque(t), "theta": sol.y[0] + rng.normal(0.0, 0.0005, t.size),
            "omega": gain * sol.y[1] + rng.normal(0.0, 0.002, t.size)}
