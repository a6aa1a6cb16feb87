"""Independent simulator of models/hydraulic_actuator.yaml: pump, supply line, metering orifice,
leaking chamber and a piston on a spring-loaded mass, from the hydraulic state equations
(Karnopp, Margolis & Rosenberg, System Dynamics, 5th ed., ch. 10; Merritt, Hydraulic Control
Systems, ch. 3: the turbulent orifice Q = Kv sign(dp) sqrt|dp|), typed by hand:

    dVs/dt = beta_Qp Qp - Qo                ps = Vs/Cs,  Qo = Kv sign(ps - pc) sqrt|ps - pc|
    dVc/dt = Qo - pc/Rl - A v               pc = Vc/Cc
    dx/dt  = v
    dP/dt  = A pc - b v - k x               v = P/m

The state is the oil volume compressed into each compliance (Vs, Vc), the position x and the
momentum P of the mass: when a compliance changes the stored volume is continuous and its
pressure jumps (the convention bgfdi's storage faults follow). Integrated by scipy's LSODA with
the Jacobian by hand, rtol 1e-10, piece by piece between fault onsets, from rest at the mean pump
flow; Radau at the same tolerance agrees within 0.02 Pa and takes 20 times longer.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

from .faults import Fault, breakpoints, noisy, parameter_function, sensor_gain

COLUMNS = ["t", "Qp", "ps", "pc", "x"]
NOMINAL = {"Cs": 7.1e-13, "Kv": 5.0e-8, "Cc": 3.6e-13, "Rl": 1.0e11, "A": 1.0e-3, "m": 20.0,
           "b": 2000.0, "k": 1.0e5}
NOISE = {"ps": 5.0e3, "pc": 5.0e3, "x": 1.0e-6}
Q_MEAN = 5.0e-5


def pump_flow(t):
    """The pump's nominal delivery (m^3/s)."""
    return Q_MEAN * (1 + 0.4 * np.sin(math.pi * t) + 0.2 * np.sin(6 * math.pi * t))


def rest(p: dict) -> np.ndarray:
    """The state at rest under the mean flow: all of it leaks, pc = Rl Q, ps = pc + (Q/Kv)^2."""
    pc = p["Rl"] * Q_MEAN
    ps = pc + (Q_MEAN / p["Kv"]) ** 2
    return np.array([p["Cs"] * ps, p["Cc"] * pc, p["A"] * pc / p["k"], 0.0])


def rates(t: float, y: np.ndarray, p: dict) -> list[float]:
    Vs, Vc, x, P = y
    ps, pc, v = Vs / p["Cs"], Vc / p["Cc"], P / p["m"]
    dp = ps - pc
    Qo = p["Kv"] * math.copysign(math.sqrt(abs(dp)), dp)
    Qp = Q_MEAN * (1 + 0.4 * math.sin(math.pi * t) + 0.2 * math.sin(6 * math.pi * t))
    return [p["beta_Qp"] * Qp - Qo,
            Qo - pc / p["Rl"] - p["A"] * v,
            v,
            p["A"] * pc - p["b"] * v - p["k"] * x]


def jacobian(y: np.ndarray, p: dict) -> np.ndarray:
    """d(rates)/d(Vs, Vc, x, P), by hand: dQo/d(dp) = Kv / (2 sqrt|dp|)."""
    Vs, Vc = y[0], y[1]
    Cs, Cc, Rl, A, m, b, k = (p[n] for n in ("Cs", "Cc", "Rl", "A", "m", "b", "k"))
    g = p["Kv"] / (2 * math.sqrt(max(abs(Vs / Cs - Vc / Cc), 1.0)))
    return np.array([[-g / Cs, g / Cc, 0.0, 0.0],
                     [g / Cs, -g / Cc - 1 / (Rl * Cc), 0.0, -A / m],
                     [0.0, 0.0, 0.0, 1 / m],
                     [0.0, A / Cc, -k, -b / m]])


def states(T: float, fs: float, faults: tuple[Fault, ...] = ()) -> tuple[np.ndarray, np.ndarray, dict]:
    """Sample times, the states (4, N) and the parameters at every sample (for ps, pc, v)."""
    params = parameter_function({**NOMINAL, "beta_Qp": 1.0}, faults)
    t = np.arange(int(round(T * fs)) + 1) / fs
    y0 = rest(params(0.0))
    out = np.empty((4, t.size))
    for a, b in zip(edges := breakpoints(faults, T), edges[1:]):
        at = (t >= a) & ((t < b) | (b == T))
        when = np.union1d(t[at], [b])
        sol = solve_ivp(lambda s, y: rates(s, y, params(s)), (a, b), y0, method="LSODA",
                        jac=lambda s, y: jacobian(y, params(s)), t_eval=when, rtol=1e-10, atol=1e-14)
        assert sol.success, sol.message
        out[:, at] = sol.y[:, :at.sum()]
        y0 = sol.y[:, -1]
    Cs = np.array([params(float(s))["Cs"] for s in t])
    Cc = np.array([params(float(s))["Cc"] for s in t])
    return t, out, {"Cs": Cs, "Cc": Cc}


def simulate(T: float = 8.0, fs: float = 2.0e3, faults: tuple[Fault, ...] = (), seed: int = 0,
             noise: dict | None = None) -> dict[str, np.ndarray]:
    """Measured columns: sensor gains applied, then seeded noise (the model's by default)."""
    t, (Vs, Vc, x, P), c = states(T, fs, faults)
    cols = {"t": t, "Qp": pump_flow(t),
            "ps": sensor_gain(t, "ps", faults) * Vs / c["Cs"],
            "pc": sensor_gain(t, "pc", faults) * Vc / c["Cc"],
            "x": sensor_gain(t, "x", faults) * x}
    return noisy(cols, NOISE if noise is None else noise, seed)
