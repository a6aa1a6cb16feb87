"""Independent simulator of tests/data/lc_ladder.yaml: a damped two-section LC ladder filter
feeding a resistive load, from Kirchhoff's laws typed by hand (any circuits text, e.g. Nilsson &
Riedel, Electric Circuits, ch. 7-8), never importing ``bondgraph`` or ``fdi``. States: the
inductors' fluxes p1, p2 and the capacitors' charges q1, q2 (a capacitance that steps keeps its
charge, so its voltage jumps, as a bond graph's C element does):

    dp1/dt = u - R1 i1 - v1,   dq1/dt = i1 - i2,   dp2/dt = v1 - v2,   dq2/dt = i2 - v2 / RL

with i = p / L and v = q / C; u(t) = 24 + 3 sin(150 t) + 2 sin(420 t) V, from the steady state of
its mean (i = 24 / (R1 + RL)). Integrated by scipy's LSODA at rtol 1e-10, piece by piece on each
side of the fault onset ``t0``. Faults from ``t0``: the output capacitor ``c2_fault``, the load
``rl_fault`` (F, Ohm). The current i1 and the output voltage v2 are read with white noise."""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

COLUMNS = ["t", "u", "i1", "v2"]
NOMINAL = {"R1": 2.0, "L1": 10.0e-3, "C1": 470e-6, "L2": 10.0e-3, "C2": 470e-6, "RL": 8.0}
NOISE = {"i1": 0.005, "v2": 0.02}      # A, V
TS = 2.0e-4                            # s


def supply(t):
    """The supply voltage (V) at the times ``t``."""
    return 24.0 + 3.0 * np.sin(150.0 * t) + 2.0 * np.sin(420.0 * t)


def simulate(seed: int, T: float = 2.0, t0: float | None = None, c2_fault: float | None = None,
             rl_fault: float | None = None) -> dict:
    """Columns t, u, i1, v2 every TS s over [0, T]; from ``t0`` the faults given."""
    R1, L1, C1, L2 = (NOMINAL[k] for k in ("R1", "L1", "C1", "L2"))
    t = TS * np.arange(int(round(T / TS)) + 1)
    i0 = 24.0 / (R1 + NOMINAL["RL"])
    x = np.array([L1 * i0, C1 * i0 * NOMINAL["RL"], L2 * i0, NOMINAL["C2"] * i0 * NOMINAL["RL"]])
    edges = [0.0, T] if t0 is None else [0.0, t0, T]
    out, c2s = [], []
    for k, (a, b) in enumerate(zip(edges[:-1], edges[1:])):
        c2 = c2_fault if k == 1 and c2_fault is not None else NOMINAL["C2"]
        rl = rl_fault if k == 1 and rl_fault is not None else NOMINAL["RL"]

        def rates(s, y, c2=c2, rl=rl):
            p1, q1, p2, q2 = y
            i1, v1, i2, v2 = p1 / L1, q1 / C1, p2 / L2, q2 / c2
            return [supply(s) - R1 * i1 - v1, i1 - i2, v1 - v2, i2 - v2 / rl]
        keep = t[(t >= a) & (t < b)]
        sol = solve_ivp(rates, (a, b), x, t_eval=np.append(keep, b), method="LSODA", rtol=1e-10,
                        atol=1e-13, max_step=TS)
        out.append(sol.y[:, :-1])
        c2s.append(np.full(keep.size, c2))
        x = sol.y[:, -1]
    y = np.hstack(out + [x[:, None]])
    c2 = np.append(np.concatenate(c2s), c2s[-1][-1] if c2s[-1].size else NOMINAL["C2"])
    rng = np.random.default_rng(seed)
    i1 = y[0] / L1 + NOISE["i1"] * rng.standard_normal(t.size)
    v2 = y[3] / c2 + NOISE["v2"] * rng.standard_normal(t.size)
    return {"t": t, "u": supply(t), "i1": i1, "v2": v2}
