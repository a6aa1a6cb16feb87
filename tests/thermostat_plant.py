"""A two-zone building simulated from its physics with scipy, apart from bgfdi (the model is
tests/data/two_zone_thermostat.yaml; a user trial's domain: thermal, effort = temperature in K,
flow = heat flow in W):

    C1 dT1/dt = h P_h - (T1 - T_out)/R1a - (T1 - T2)/R12
    C2 dT2/dt = (T1 - T2)/R12 - (T2 - T_out)/R2a - w (T2 - T_out)/Rv

a digital thermostat on the measured T1 (sampled every 60 s, held, +-0.5 K about 293.15 K) drives
the heater's relay h; a window w opens 07:00-07:30 and 18:00-18:20; the outdoor temperature is a
daily sinusoid. 48 h at 60 s, thermometers with 0.05 K of noise. RK45 at rtol 1e-10 between samples.
"""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

C1, C2 = 2.0e6, 1.5e6
R12, R1A, R2A, RV, PH = 0.008, 0.015, 0.02, 0.01, 3000.0
TS, HOURS, SET, HYST, NOISE = 60.0, 48.0, 293.15, 0.5, 0.05
HEAD = ["t", "T_out", "heater_cmd", "window_cmd", "T1", "T2"]


def t_out(t, mean: float = 278.15, amp: float = 5.0):
    return mean + amp * np.sin(2 * np.pi * (t - 9 * 3600) / 86400)


def simulate(seed: int, offset: tuple[float, float] | None = None, mean: float = 278.15, amp: float = 5.0,
             windows=((7.0, 7.5), (18.0, 18 + 1 / 3)), noise: float = NOISE,
             heater: tuple[float, float] | None = None) -> np.ndarray:
    """Rows of ``HEAD``. ``offset``: (onset s, K) added to the T2 thermometer's readings from then;
    ``heater``: (onset s, factor) of the heater's power from then;
    ``noise``: the thermometers' (K; less noise, fewer relay chatters and longer stretches)."""
    rng = np.random.default_rng(seed)
    n = int(HOURS * 3600 / TS) + 1
    t = np.arange(n) * TS
    x = np.array([293.0, 290.5])
    rows = np.empty((n, len(HEAD)))
    h = 1
    for k in range(n):
        tk = t[k]
        T1m = x[0] + noise * rng.standard_normal()
        T2m = x[1] + noise * rng.standard_normal()
        if offset is not None and tk >= offset[0]:
            T2m += offset[1]
        To = t_out(tk, mean, amp) + 0.05 * rng.standard_normal()
        if T1m < SET - HYST:
            h = 1
        elif T1m > SET + HYST:
            h = 0
        tod = (tk % 86400) / 3600.0
        w = int(any(a <= tod < b for a, b in windows))
        rows[k] = (tk, To, h, w, T1m, T2m)
        if k == n - 1:
            break

        power = PH * (heater[1] if heater is not None and tk >= heater[0] else 1.0)

        def f(s, y, h=h, w=w, power=power):
            To = t_out(s, mean, amp)
            return [(h * power - (y[0] - To) / R1A - (y[0] - y[1]) / R12) / C1,
                    ((y[0] - y[1]) / R12 - (y[1] - To) / R2A - w * (y[1] - To) / RV) / C2]
        x = solve_ivp(f, (tk, tk + TS), x, method="RK45", rtol=1e-10, atol=1e-9).y[:, -1]
    return rows
