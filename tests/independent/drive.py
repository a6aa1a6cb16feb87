"""Independent simulator of models/electromechanical_drive.yaml: a DC motor, gearbox and flexible
shaft to a load, from its four state equations (Karnopp, Margolis & Rosenberg, System Dynamics,
5th ed., Sec. 8.2 and ch. 4), typed by hand:

    La di/dt  = beta_u u - Ra i - K wm
    Jm dwm/dt = K i - bm wm - tau/n,      tau = ks th + ds (wm/n - wL)
    dth/dt    = wm/n - wL
    JL dwL/dt = tau - bL wL

The state is (i, wm, th, wL), th the shaft twist: when ks changes the twist is continuous and the
torque jumps. Integrated by scipy's LSODA (with the Jacobian by hand) at rtol 1e-10, piece by piece
between fault onsets; Radau at the same tolerance agrees to 1e-7 and takes 20 times longer.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

from .faults import Fault, breakpoints, noisy, parameter_function, sensor_gain

COLUMNS = ["t", "u", "i", "wm", "wL"]
NOMINAL = {"Ra": 1.0, "La": 1.0e-3, "K": 0.05, "Jm": 1.0e-4, "bm": 2.0e-5, "n": 5.0,
           "ks": 50.0, "ds": 0.05, "JL": 5.0e-3, "bL": 5.0e-3}
NOISE = {"i": 2.0e-3, "wm": 2.0e-3, "wL": 2.0e-3}


def voltage(t):
    """The armature voltage the amplifier is commanded (V)."""
    return 12.0 + 4.0 * np.sin(2 * math.pi * 3 * t) + 2.0 * np.sin(2 * math.pi * 20 * t)


def rates(t: float, x: np.ndarray, p: dict) -> list[float]:
    i, wm, th, wL = x
    twist_rate = wm / p["n"] - wL
    tau = p["ks"] * th + p["ds"] * twist_rate
    u = 12.0 + 4.0 * math.sin(2 * math.pi * 3 * t) + 2.0 * math.sin(2 * math.pi * 20 * t)
    return [(p["beta_u"] * u - p["Ra"] * i - p["K"] * wm) / p["La"],
            (p["K"] * i - p["bm"] * wm - tau / p["n"]) / p["Jm"],
            twist_rate,
            (tau - p["bL"] * wL) / p["JL"]]


def jacobian(p: dict) -> np.ndarray:
    """d(rates)/d(i, wm, th, wL), by hand from the equations above (they are linear)."""
    Ra, La, K, Jm, bm, n, ks, ds, JL, bL = (p[k] for k in ("Ra", "La", "K", "Jm", "bm", "n", "ks", "ds", "JL", "bL"))
    return np.array([[-Ra / La, -K / La, 0.0, 0.0],
                     [K / Jm, (-bm - ds / n ** 2) / Jm, -ks / (n * Jm), ds / (n * Jm)],
                     [0.0, 1 / n, 0.0, -1.0],
                     [0.0, ds / (n * JL), ks / JL, (-ds - bL) / JL]])


def states(T: float, fs: float, faults: tuple[Fault, ...] = ()) -> tuple[np.ndarray, np.ndarray]:
    """Sample times and the noise-free states (4, N) from rest."""
    params = parameter_function({**NOMINAL, "beta_u": 1.0}, faults)
    drifting = any(f.kind != "abrupt" for f in faults)
    t = np.arange(int(round(T * fs)) + 1) / fs
    x0 = np.zeros(4)
    out = np.empty((4, t.size))
    for a, b in zip(edges := breakpoints(faults, T), edges[1:]):
        at = (t >= a) & ((t < b) | (b == T))
        when = np.union1d(t[at], [b])                 # the piece's samples and its end
        if drifting:                                  # parameters change along the piece
            fun, jac = (lambda s, x: rates(s, x, params(s))), (lambda s, x: jacobian(params(s)))
        else:                                         # constant between abrupt onsets
            p = params(0.5 * (a + b))
            fun, jac = (lambda s, x, p=p: rates(s, x, p)), (lambda s, x, J=jacobian(p): J)
        sol = solve_ivp(fun, (a, b), x0, method="LSODA", jac=jac, t_eval=when, rtol=1e-10, atol=1e-12)
        assert sol.success, sol.message
        out[:, at] = sol.y[:, :at.sum()]
        x0 = sol.y[:, -1]
    return t, out


def simulate(T: float = 2.0, fs: float = 1.0e4, faults: tuple[Fault, ...] = (), seed: int = 0,
             noise: dict | None = None) -> dict[str, np.ndarray]:
    """Measured columns: sensor gains applied, then seeded noise (the model's by default)."""
    t, (i, wm, th, wL) = states(T, fs, faults)
    cols = {"t": t, "u": voltage(t),
            "i": sensor_gain(t, "i", faults) * i,
            "wm": sensor_gain(t, "wm", faults) * wm,
            "wL": sensor_gain(t, "wL", faults) * wL}
    return noisy(cols, NOISE if noise is None else noise, seed)
