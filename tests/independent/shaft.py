"""Independent simulator of models/two_inertia_shaft.yaml: a torque drives a flywheel through a
torsional shaft to a load, from Newton's laws for rotation (Karnopp, Margolis & Rosenberg, System
Dynamics, ch. 4), typed by hand:

    J1 dw1/dt = tau - b1 w1 - T,    dT/dt = k (w1 - w2),    J2 dw2/dt = T - b2 w2

with tau = 1 + 0.5 sin(2 t) N m, both speeds measured with white noise. Integrated by scipy's LSODA
at rtol 1e-9, piece by piece between fault onsets.
"""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

COLUMNS = ["t", "tau", "w1", "w2"]
NOMINAL = {"J1": 0.05, "J2": 0.2, "b1": 0.01, "b2": 0.05, "k": 50.0}
NOISE = {"w1": 1.0e-3, "w2": 1.0e-3}
TS = 1.0e-3


def torque(t):
    return 1.0 + 0.5 * np.sin(2.0 * t)


def simulate(duration: float = 30.0, seed: int = 0, b2_step: tuple[float, float] | None = None) -> dict:
    """Columns of a run of ``duration`` s sampled every TS; ``b2_step`` = (onset s, new b2) steps the
    load friction (a dragging brake)."""
    p = dict(NOMINAL)
    t = TS * np.arange(int(round(duration / TS)) + 1)
    edges = [0.0, duration] if b2_step is None else [0.0, b2_step[0], duration]
    x, out = np.zeros(3), []
    for i, (a, b) in enumerate(zip(edges[:-1], edges[1:])):
        b2 = p["b2"] if i == 0 else b2_step[1]

        def rates(s, y, b2=b2):
            w1, T, w2 = y
            return [(torque(s) - p["b1"] * w1 - T) / p["J1"], p["k"] * (w1 - w2), (T - b2 * w2) / p["J2"]]
        keep = t[(t >= a) & (t < b)]
        sol = solve_ivp(rates, (a, b), x, t_eval=np.append(keep, b), method="LSODA", rtol=1e-9, atol=1e-11,
                        max_step=0.01)
        out.append(sol.y[:, :-1])
        x = sol.y[:, -1]
    y = np.hstack(out + [x[:, None]])
    rng = np.random.default_rng(seed)
    return {"t": t, "tau": torque(t), "w1": y[0] + NOISE["w1"] * rng.standard_normal(t.size),
            "w2": y[2] + NOISE["w2"] * rng.standard_normal(t.size)}
