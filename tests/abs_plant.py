"""An independent one-wheel ABS brake modulator (scipy's LSODA, from the physics; not bgfdi's
simulator), written for tests/test_domain_abs.py after a user trial's plant.

    Cc pc' = a_in (Pm - pc)/Rin - a_out (pc - p_lpa)/Rout - pc/Rleak       (Merritt, ch. 3)
    Jw w'  = rw Fx - kb pc tanh(w/w0),   Fx = Nz Dm sin(Cp atan(Bp s)),  s = (v - rw w)/v
    m v'   = -Fx                                                       (Rajamani, ch. 6)

The ABS controller decides every 10 ms on the measured slip (above 0.15: release, a_in = 0,
a_out = 1; below 0.07: apply, 1, 0; else hold, 0, 0; at least 50 ms in a mode): the valves'
commands switch about ten times a second. Measured: the master-cylinder pressure Pm, the vehicle
speed v, the commands a_in and a_out, the caliper pressure pc (2e4 Pa noise) and the wheel speed w
(0.05 rad/s). A fault from ``t0``: the inlet restriction times ``size`` (``rin``), or an inlet
valve stuck open whatever its command (``in_stuck_open``; the command column keeps the command).
"""
from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

P = dict(Rin=1.5e12, Rout=5.0e11, Cc=1.0e-13, p_lpa=2.0e5, Jw=1.2, rw=0.3, kb=2.0e-4,
         Nz=4000.0, Dm=0.4, Cp=1.9, Bp=10.0, w0=0.5)
MASS = 4000.0 / 9.81
TS = 0.001
TICK = 0.01                      # s: the controller's period
HEAD = ["t", "Pm", "v", "a_in", "a_out", "pc", "w"]


def _pm(t: float) -> float:
    return 8.0e6 * min(t / 0.2, 1.0)


def simulate(t_end: float, seed: int, fault: str | None = None, t0: float = 5.0, size: float = 3.0) -> np.ndarray:
    """Rows of HEAD sampled at TS from 0 to ``t_end``."""
    rng = np.random.default_rng(seed)

    def rin(t):
        return P["Rin"] * (size if fault == "rin" and t >= t0 else 1.0)

    def rhs(t, x, ain, aout):
        pc, w, v = x
        qin = ain * (_pm(t) - pc) / rin(t)
        qout = aout * (pc - P["p_lpa"]) / P["Rout"]
        s = (v - P["rw"] * w) / v
        fx = P["Nz"] * P["Dm"] * math.sin(P["Cp"] * math.atan(P["Bp"] * s))
        return [(qin - qout) / P["Cc"], (P["rw"] * fx - P["kb"] * pc * math.tanh(w / P["w0"])) / P["Jw"], -fx / MASS]

    n = int(round(t_end / TS)) + 1
    t_all = np.arange(n) * TS
    x = np.array([0.0, 40.0 / P["rw"], 40.0])
    X, ain_col, aout_col = np.zeros((n, 3)), np.zeros(n), np.zeros(n)
    ain, aout, dwell, k, t = 1, 0, 0, 0, 0.0
    while k < n:
        slip = (x[2] + rng.normal(0, 0.02) - P["rw"] * (x[1] + rng.normal(0, 0.05))) / x[2]
        if dwell <= 0:
            new = (0, 1) if slip > 0.15 else (1, 0) if slip < 0.07 else (0, 0)
            if new != (ain, aout):
                (ain, aout), dwell = new, 5
        dwell -= 1
        idx = np.nonzero((t_all >= t - 1e-12) & (t_all < t + TICK - 1e-12))[0]
        valve_in = 1 if fault == "in_stuck_open" and t >= t0 - 1e-12 else ain
        sol = solve_ivp(rhs, (t, t + TICK), x, args=(valve_in, aout), method="LSODA", rtol=1e-9,
                        atol=[1.0, 1e-8, 1e-8], dense_output=True, max_step=1e-3)
        assert sol.success, sol.message
        if len(idx):
            X[idx] = sol.sol(t_all[idx]).T
            ain_col[idx], aout_col[idx] = ain, aout
            k = idx[-1] + 1
        x, t = sol.y[:, -1], t + TICK
    pc, w, v = X.T
    return np.column_stack([t_all, np.array([_pm(s) for s in t_all]) + rng.normal(0, 2.0e4, n),
                            v + rng.normal(0, 0.02, n), ain_col, aout_col, pc + rng.normal(0, 2.0e4, n),
                            w + rng.normal(0, 0.05, n)])
