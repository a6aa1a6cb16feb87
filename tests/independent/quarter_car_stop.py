"""Independent simulator of tests/data/quarter_car_bump_stop.yaml (a user trial's model): a quarter
car with a two-stage damper (soft c_s always, c_f added while the valve is firm) and a bump stop
(kb (xs - gb) once the suspension's compression xs passes the gap gb), from Newton's laws for the
two masses (Gillespie, Fundamentals of Vehicle Dynamics, ch. 5), typed by hand, never importing
``bondgraph`` or ``fdi``. About the static equilibrium (gravity drops out), xs = zu - zs the
suspension's compression, xt = zr - zu the tyre's:

    ms vs' = ks xs + c (vu - vs) + [xs > gb] kb (xs - gb),    c = c_s + valve c_f
    mu vu' = kt xt + ct (vr - vu) - ks xs - c (vu - vs) - [xs > gb] kb (xs - gb)
    xs' = vu - vs,    xt' = vr(t) - vu

The contact is located by solve_ivp's event on xs - gb (DOP853, rtol 1e-10), the integration
restarted at each contact and valve switch. The road: three sines and one bump that drives the
stop. Output columns as the model's data: t, vr, defl (= -xs), vs, vu, valve."""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

P = dict(ms=300.0, mu=40.0, ks=20000.0, kt=200000.0, ct=50.0, c_s=800.0, c_f=2200.0, kb=200000.0, gb=0.05)
VALVE = ((0.0, 0), (1.5, 1), (3.0, 0), (4.5, 1))        # (from t, valve): soft, firm, soft, firm
BUMP = (2.0, 0.12, 0.12)                                 # start (s), height (m), length in time (s)


def road(t):
    """The road's vertical velocity (m/s): three sines and a (1 - cos) bump."""
    t = np.asarray(t, float)
    v = 0.05 * np.sin(2 * np.pi * 1.1 * t) + 0.03 * np.sin(2 * np.pi * 3.7 * t + 1) + 0.02 * np.sin(2 * np.pi * 9 * t + 2)
    t0, h, L = BUMP
    on = (t >= t0) & (t <= t0 + L)
    return v + np.where(on, h / 2 * (2 * np.pi / L) * np.sin(2 * np.pi * (t - t0) / L), 0.0)


def valve(t: float) -> int:
    return [s for t0, s in VALVE if t >= t0 - 1e-12][-1]


def simulate(T: float = 6.0, fs: float = 1000.0) -> tuple[dict, int]:
    """The noise-free columns of a run of ``T`` s sampled at ``fs`` Hz, and how many contacts it made."""
    def rhs(t, y, v, c):
        xs, xt, vs, vu = y
        damp = P["c_s"] + v * P["c_f"]
        force = P["ks"] * xs + damp * (vu - vs) + c * P["kb"] * (xs - P["gb"])
        return [vu - vs, float(road(t)) - vu, force / P["ms"], (P["kt"] * xt + P["ct"] * (float(road(t)) - vu) - force) / P["mu"]]

    def contact(c):
        def ev(t, y, v, c_):
            return y[0] - P["gb"]
        ev.terminal, ev.direction = True, (1 if c == 0 else -1)
        return ev

    grid = np.arange(int(round(T * fs)) + 1) / fs
    out = np.zeros((grid.size, 4))
    t, y, c, contacts = 0.0, np.zeros(4), 0, 0
    stops = sorted({t0 for t0, _ in VALVE if t0 > 0} | {T})
    while t < T - 1e-12:
        end = min(s for s in stops if s > t + 1e-12)
        sol = solve_ivp(rhs, (t, end), y, args=(valve(t), c), events=contact(c), method="DOP853", rtol=1e-10,
                        atol=1e-13, max_step=1e-3, dense_output=True)
        inside = (grid >= t) & (grid <= sol.t[-1])
        out[inside] = sol.sol(grid[inside]).T
        y, t = sol.y[:, -1].copy(), sol.t[-1]
        if sol.status == 1:
            c = 1 - c
            contacts += c
    valves = np.array([valve(x) for x in grid], float)
    return {"t": grid, "vr": road(grid), "defl": -out[:, 0], "vs": out[:, 2], "vu": out[:, 3], "valve": valves}, contacts
