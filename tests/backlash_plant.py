"""The plant of tests/data/backlash_drive.yaml, written apart from bgfdi from the physics: a motor
inertia Jm (bearing bm) driven by a known torque tau(t), a gearbox 1/N, a shaft whose torque is
ks dz(q, d) + cs (w_m / N - w_L) with the dead zone dz(q, d) = max(q - d, 0) + min(q + d, 0) on
the twist q = theta_m / N - theta_L (backlash of half-width d), and a load inertia JL (friction bL).
scipy's LSODA, piecewise at the fault instants; both encoders quantised to 1e-4 rad; 60 s at 1 kHz.
Runs: nominal | wear (d x exp(0.03 (t - 20)) from 20 s: eq. (16), reaching 0.03 at 56.62 s)."""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

JM, BM, N, KS, D0, CS, JL, BL = 2e-3, 1e-3, 5.0, 50.0, 0.01, 0.05, 5e-2, 5e-2
ONSET, RATE, COUNT = 20.0, 0.03, 1e-4
EOL = ONSET + np.log(0.03 / D0) / RATE         # 56.62 s


def torque(t):
    return 0.3 * np.sin(2 * np.pi * 0.5 * t) + 0.1 * np.sin(2 * np.pi * 2.3 * t)


def record(path, wear: bool = False, T: float = 60.0, fs: float = 1000.0) -> None:
    def rates(t, x):
        th_m, w_m, th_L, w_L = x
        d = D0 * np.exp(RATE * (t - ONSET)) if wear and t >= ONSET else D0
        q = th_m / N - th_L
        shaft = KS * (max(q - d, 0.0) + min(q + d, 0.0)) + CS * (w_m / N - w_L)
        return [w_m, (torque(t) - BM * w_m - shaft / N) / JM, w_L, (shaft - BL * w_L) / JL]
    t = np.arange(0.0, T, 1.0 / fs)
    X, x0 = np.zeros((t.size, 4)), [0.0, 0.0, 0.0, 0.0]
    for a, b in ((0.0, ONSET), (ONSET, T)):
        m = (t >= a) & (t < b)
        sol = solve_ivp(rates, (a, t[m][-1]), x0, t_eval=t[m], method="LSODA", rtol=1e-9, atol=1e-11, max_step=1e-3)
        X[m], x0 = sol.y.T, sol.y[:, -1]
    counts = lambda v: np.round(v / COUNT) * COUNT          # noqa: E731  (the encoders' quantisation)
    np.savetxt(path, np.column_stack([t, torque(t), counts(X[:, 0]), counts(X[:, 2])]), delimiter=",",
               header="t,tau,theta_m,theta_L", comments="", fmt="%.10g")
