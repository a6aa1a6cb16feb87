"""An independent vehicle driveline with a clutch (scipy's Radau, from the physics; not bgfdi's
simulator), written for tests/test_domain_driveline.py after a user trial's plant.

    J1 w1' = Te - b1 w1 - T          J2 w2' = T - b2 w2 - Tr sign(w2) - ca w2 |w2|
    engaged:    T = k_c th + c_c (w1 - w2),   th' = w1 - w2
    disengaged: T = 0,                       th' = -k_c th / c_c   (the spring relaxes)

Karnopp, Margolis & Rosenberg, System Dynamics, ch. 4 (rotational mechanics). The engine
torque follows a throttle profile while the clutch is engaged and matches the engine's speed
to the wheels' while it is open (gear shifts). Measured: w1, w2 (0.05 rad/s noise), the shaft
torque T (1 N m noise), the engine torque Te and the clutch command.
"""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

P = dict(J1=0.25, b1=0.05, k_c=500.0, c_c=5.0, J2=4.0, b2=0.2, Tr=15.0, ca=0.002)
TS = 0.001
OPEN = [(8.0, 9.5), (20.0, 21.0)]            # s: the clutch open (gear shifts)
NOISE = dict(w1=0.05, w2=0.05, T=1.0)
HEAD = ["t", "Te", "c_cmd", "w1", "w2", "T"]


def command(t):
    t = np.asarray(t, dtype=float)
    out = np.ones_like(t)
    for a, b in OPEN:
        out[(t >= a) & (t < b)] = 0.0
    return out


def throttle(t):
    return 100 + 25 * np.sin(3 * t) + 15 * np.sin(0.7 * t + 1)


def _params(t: float, fault: dict | None) -> dict:
    p = dict(P)
    if fault and t >= fault["t0"]:
        p[fault["name"]] = P[fault["name"]] * (np.exp(fault["rate"] * (t - fault["t0"])) if "rate" in fault
                                               else fault["factor"])
    return p


def _engine(t, w1, w2, engaged):
    return np.where(engaged, throttle(t), P["b1"] * w1 + P["J1"] * 2.0 * (w2 - w1))   # rev matching, 0.5 s


def _rhs(t, x, engaged, fault):
    w1, w2, th = x
    p = _params(t, fault)
    T = p["k_c"] * th + p["c_c"] * (w1 - w2) if engaged else 0.0
    dth = w1 - w2 if engaged else -p["k_c"] * th / p["c_c"]
    dw1 = (float(_engine(t, w1, w2, engaged)) - p["b1"] * w1 - T) / p["J1"]
    dw2 = (T - p["b2"] * w2 - p["Tr"] * np.sign(w2) - p["ca"] * w2 * abs(w2)) / p["J2"]
    return [dw1, dw2, dth]


def simulate(t_end: float, seed: int, fault: dict | None = None) -> np.ndarray:
    """Rows of HEAD at TS from 0 to ``t_end``, from the engaged equilibrium; ``fault``:
    ``{"name": "k_c", "factor": 0.6, "t0": 12.0}``, a parameter's step, or ``{"name": "b2", "rate": 0.05,
    "t0": 3.0}``, its drift P0 exp(rate (t - t0)) (the paper's eq. 16)."""
    t = np.round(np.arange(0.0, t_end + TS / 2, TS), 9)
    u0 = throttle(0.0)
    w = brentq(lambda w: u0 - (P["b1"] + P["b2"]) * w - P["Tr"] - P["ca"] * w * w, 1, 1000)
    x = np.array([w, w, (u0 - P["b1"] * w) / P["k_c"]])
    cuts = sorted({0.0, t_end, *[c for ab in OPEN for c in ab if c < t_end], *([fault["t0"]] if fault else [])})
    X = np.zeros((t.size, 3))
    for a, b in zip(cuts[:-1], cuts[1:]):
        engaged = bool(command(0.5 * (a + b)))
        idx = np.flatnonzero((t >= a - 1e-12) & ((t < b - 1e-12) if b < t_end else True))
        sol = solve_ivp(_rhs, (a, b), x, method="Radau", t_eval=t[idx], args=(engaged, fault), rtol=1e-10,
                        atol=1e-10, max_step=0.01, dense_output=True)
        assert sol.success, sol.message
        X[idx] = sol.y.T
        x = sol.sol(b)
    c = command(t)
    k = np.array([_params(ti, fault)["k_c"] for ti in t]) if fault and fault["name"] == "k_c" else P["k_c"]
    cc = np.array([_params(ti, fault)["c_c"] for ti in t]) if fault and fault["name"] == "c_c" else P["c_c"]
    torque = np.where(c > 0, k * X[:, 2] + cc * (X[:, 0] - X[:, 1]), 0.0)
    rng = np.random.default_rng(seed)
    return np.column_stack([t, _engine(t, X[:, 0], X[:, 1], c > 0), c,
                            X[:, 0] + rng.normal(0, NOISE["w1"], t.size), X[:, 1] + rng.normal(0, NOISE["w2"], t.size),
                            torque + rng.normal(0, NOISE["T"], t.size)])
