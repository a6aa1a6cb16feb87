"""Independent simulator of tests/data/quarter_car.yaml: a quarter-car suspension driven by the
road's vertical velocity, from Newton's laws for the two masses (Karnopp, Margolis & Rosenberg,
System Dynamics, ch. 4; Gillespie, Fundamentals of Vehicle Dynamics, ch. 5), typed by hand, never
importing ``bondgraph`` or ``fdi``. With xs the suspension's compression and xt the tyre's (about
the static equilibrium, so gravity drops out):

    ms dvs/dt = ks xs + bs (vu - vs)
    mu dvu/dt = kt xt - ks xs - bs (vu - vs)
    dxs/dt = vu - vs,    dxt/dt = vr(t) - vu

with vr(t) a sum of three sines (0.6, 1.3 and 2.7 Hz, 0.13 m/s at most), from rest. Integrated by
scipy's LSODA at rtol 1e-10, piece by piece on each side of the fault onset ``t0``. Faults from
``t0``: the damper ``bs_fault`` (losing oil), the spring ``ks_fault``, the tyre ``kt_fault``, and
a sensor gain (``gain_vs``, ``gain_vu``: the sensor reads gain times the true velocity). Both
velocities are read with white noise of NOISE m/s."""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

COLUMNS = ["t", "vr", "vs", "vu"]
NOMINAL = {"ms": 250.0, "mu": 35.0, "ks": 16000.0, "bs": 1000.0, "kt": 160000.0}
NOISE = 2.0e-4          # m/s, each velocity sensor
TS = 1.0e-3             # s
ROAD = ((0.06, 0.6, 0.0), (0.04, 1.3, 1.0), (0.03, 2.7, 2.0))     # m/s, Hz, rad


def road(t):
    """The road's vertical velocity (m/s) under the tyre at the times ``t``."""
    return sum(a * np.sin(2.0 * np.pi * f * t + ph) for a, f, ph in ROAD)


def simulate(seed: int, T: float = 16.0, t0: float | None = None, bs_fault: float | None = None,
             ks_fault: float | None = None, kt_fault: float | None = None, gain_vs: float = 1.0,
             gain_vu: float = 1.0) -> dict:
    """Columns t, vr, vs, vu every TS s over [0, T]; from ``t0`` the faults given."""
    ms, mu = NOMINAL["ms"], NOMINAL["mu"]
    t = TS * np.arange(int(round(T / TS)) + 1)
    faulty = {"bs": bs_fault, "ks": ks_fault, "kt": kt_fault}
    edges = [0.0, T] if t0 is None else [0.0, t0, T]
    x, out = np.zeros(4), []         # vs, vu, xs, xt
    for i, (a, b) in enumerate(zip(edges[:-1], edges[1:])):
        p = {k: (faulty[k] if i == 1 and faulty.get(k) is not None else NOMINAL[k]) for k in ("bs", "ks", "kt")}

        def rates(s, y, ks=p["ks"], bs=p["bs"], kt=p["kt"]):
            vs, vu, xs, xt = y
            fs = ks * xs + bs * (vu - vs)            # the suspension's force on the body
            return [fs / ms, (kt * xt - fs) / mu, vu - vs, road(s) - vu]
        keep = t[(t >= a) & (t < b)]
        sol = solve_ivp(rates, (a, b), x, t_eval=np.append(keep, b), method="LSODA", rtol=1e-10,
                        atol=1e-12, max_step=0.002)
        out.append(sol.y[:, :-1])
        x = sol.y[:, -1]
    y = np.hstack(out + [x[:, None]])
    late = np.zeros(t.size, bool) if t0 is None else t >= t0
    rng = np.random.default_rng(seed)
    vs = y[0] * np.where(late, gain_vs, 1.0) + NOISE * rng.standard_normal(t.size)
    vu = y[1] * np.where(late, gain_vu, 1.0) + NOISE * rng.standard_normal(t.size)
    return {"t": t, "vr": road(t), "vs": vs, "vu": vu}
