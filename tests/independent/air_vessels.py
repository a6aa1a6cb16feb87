"""Independent simulator of tests/data/air_vessels.yaml: two compressed-air vessels (isothermal ideal
gas, Beater, Pneumatic Drives, ch. 3), typed by hand from the mass balances, never importing
``bondgraph`` or ``fdi``:

    dm1/dt = m_in - (p1 - p2)/R12,   dm2/dt = (p1 - p2)/R12 - p2/Rv,   p_i = m_i / C_i(t)

with C = V/(R_air T). A bladder intrusion takes part of vessel 2's volume: its stored mass stays,
so p2 jumps. Integrated by scipy's LSODA piece by piece between the fault's onset, from the
equilibrium of the mean compressor flow; pressures (gauge) with 5 Pa noise."""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

C0, R12, RV, NOISE = 1.19e-7, 1.0e9, 1.0e9, 5.0      # kg/Pa, Pa s/kg, Pa s/kg, Pa


def compressor(t):
    """The compressor's mass flow (kg/s): the model's input expression, written out."""
    return 1.0e-5 * (1 + 0.3 * np.sin(0.02 * t))


def simulate(seed: int, t0: float | None = None, factor: float = 1.0, T: float = 1200.0) -> dict[str, np.ndarray]:
    """Columns t, m_in, p1, p2 every second over [0, T]; from ``t0`` vessel 2's capacitance is
    ``factor`` times its nominal value."""
    def c2(t: float) -> float:
        return C0 * (factor if t0 is not None and t >= t0 else 1.0)

    def rates(t, m):
        p1, p2 = m[0] / C0, m[1] / c2(t)
        return [compressor(t) - (p1 - p2) / R12, (p1 - p2) / R12 - p2 / RV]

    t = np.arange(0.0, T + 0.5, 1.0)
    p2_rest = 1.0e-5 * RV
    m0 = [C0 * (p2_rest + 1.0e-5 * R12), C0 * p2_rest]
    out = np.zeros((2, t.size))
    edges = [0.0] + ([t0] if t0 is not None else []) + [T]
    for a, b in zip(edges[:-1], edges[1:]):
        keep = (t >= a) & (t <= b)
        sol = solve_ivp(rates, (a, b), m0, t_eval=t[keep], rtol=1e-10, atol=1e-16, method="LSODA")
        out[:, keep] = sol.y
        m0 = sol.y[:, -1]
    rng = np.random.default_rng(seed)
    p1 = out[0] / C0 + rng.normal(0.0, NOISE, t.size)
    p2 = out[1] / np.array([c2(x) for x in t]) + rng.normal(0.0, NOISE, t.size)
    return {"t": t, "m_in": compressor(t), "p1": p1, "p2": p2}
