"""The plant of tests/data/unverified/pv_string.yaml, written apart from bgfdi (a user trial's, reduced): a
string of 600 cells by the single-diode law (Villalva et al. 2009), Is = Isc G / 1000 -
I0 (exp((vpv + Rs Is) / nVtNs) - 1) - (vpv + Rs Is) / Rsh, through the line Rl to a battery
(Vbat, Rb). Its capacitors (Cin 100 uF, Cbus 2 mF) settle in 50 us to 0.5 ms, against 10 ms
samples and irradiance that changes over seconds: each sample is the network's operating point,
solved by brentq (the capacitors' currents, Cin dvpv/dt ~ 1e-4 A, are far under the current
sensor's 5 mA noise). 60 s at 100 Hz; partial shading drops Isc by 30 % at ``shade`` s."""
from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

ISC, I0, NVT, RS, RSH = 9.0, 1.7e-8, 18.496, 2.0, 3000.0
RL, RB, VBAT = 0.5, 0.5, 320.0
NOISE = {"Is": 0.005, "vpv": 0.03, "vbus": 0.03, "G": 0.2}


def irradiance(t):
    """A passing cloud and a slow swing, W/m^2."""
    return 900.0 - 300 * np.exp(-((t - 20) / 6) ** 2) + 30 * np.sin(2 * np.pi * t / 17)


def operating_point(G: float, isc: float) -> tuple[float, float, float]:
    """(Is, vpv, vbus) where the string's law meets the line and battery: Is = (vpv - Vbat) / (Rl + Rb)."""
    def kcl(v):
        i = (v - VBAT) / (RL + RB)
        d = v + RS * i
        return isc * G / 1000 - I0 * np.expm1(d / NVT) - d / RSH - i
    v = brentq(kcl, VBAT, VBAT + 200.0, xtol=1e-12)
    i = (v - VBAT) / (RL + RB)
    return i, v, VBAT + RB * i


def record(path, seed: int, shade: float | None = None, T: float = 60.0, fs: float = 100.0) -> None:
    t = np.round(np.arange(0.0, T, 1.0 / fs), 10)
    G = irradiance(t)
    rows = np.array([operating_point(g, ISC * 0.7 if shade is not None and tk >= shade else ISC)
                     for tk, g in zip(t, G)])
    rng = np.random.default_rng(seed)
    noisy = [G + NOISE["G"] * rng.standard_normal(t.size)]
    noisy += [rows[:, k] + NOISE[name] * rng.standard_normal(t.size) for k, name in enumerate(("Is", "vpv", "vbus"))]
    np.savetxt(path, np.column_stack([t, *noisy]), delimiter=",", header="t,G,Is,vpv,vbus", comments="", fmt="%.10g")
