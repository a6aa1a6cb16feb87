"""The plant of tests/data/hydro_surge.yaml, written apart from bgfdi (a user trial's, from the
physics): a reservoir of 50 m head feeds a penstock (inertance rho L / A, quadratic friction) that
ends at a surge tank (A_s / (rho g)) and a turbine gate (Rg0 / u); a relief valve, commanded open
from 400 to 420 s, discharges the tank's junction through Rr. scipy's LSODA, piecewise between
the switching and fault instants, from the steady state at the gate's first opening; 600 s at
10 Hz with seeded noise (Qp, Qg 5 l/s, the level 1 cm).

Runs (``columns(run, seed)``): nominal | fouling (friction x exp(0.003 (t - 150)) from 150 s) |
leak (Rleak 3e6 from 250 s) | gate (Rg0 x1.5 from 250 s) | bias (level +0.3 m from 250 s) |
stuck_closed (the valve never opens) | stuck_open (open from 250 s, whatever its command).
"""
import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

rho, g = 1000.0, 9.81
H0 = 50.0
P0 = rho * g * H0                 # 490500 Pa
L, A = 300.0, 0.5
Ip = rho * L / A                  # 6e5 kg/m^4
As = 2.0
Cs = As / (rho * g)               # 2.0387e-4 m^3/Pa
Kp0 = 7357.5                      # Pa s^2/m^6 (3 m head loss at 2 m^3/s)
Rg00 = 1.85e5                     # Pa s/m^3
Rr = 1.5e6
T, fs = 600.0, 10.0
T_OPEN, T_CLOSE = 400.0, 420.0    # relief valve command
TF = 250.0                        # abrupt fault onset
SIG = {"Qp": 0.005, "h": 0.01, "Qg": 0.005}


def u_of(t):
    return (0.75 + 0.1 * np.tanh((t - 60) / 8) - 0.15 * np.tanh((t - 180) / 10)
            + 0.1 * np.tanh((t - 330) / 8) + 0.03 * np.sin(2 * np.pi * t / 45))


def vcmd_of(t):
    return ((t >= T_OPEN) & (t < T_CLOSE)).astype(float) if np.ndim(t) else float(T_OPEN <= t < T_CLOSE)


def params(run, t):
    Kp, Rg0, Rleak, bias = Kp0, Rg00, np.inf, 0.0
    if run == "fouling" and t >= 150.0:
        Kp = Kp0 * np.exp(0.003 * (t - 150.0))       # eq. (16), b1 = 0.003 /s from 150 s
    if run == "leak" and t >= TF:
        Rleak = 3.0e6
    if run == "gate" and t >= TF:
        Rg0 = 1.5 * Rg00
    if run == "bias" and t >= TF:
        bias = 0.3                                     # m of level
    return Kp, Rg0, Rleak, bias


def v_phys(run, t):
    if run == "stuck_closed":
        return 0.0
    if run == "stuck_open" and t >= TF:
        return 1.0
    return vcmd_of(t)


def rhs(t, x, run, v):
    Qp, P = x
    Kp, Rg0, Rleak, _ = params(run, t)
    u = u_of(t)
    dQ = (P0 - Kp * Qp * abs(Qp) - P) / Ip
    dP = (Qp - u * P / Rg0 - v * P / Rr - P / Rleak) / Cs
    return [dQ, dP]


def simulate(run, seed):
    t = np.round(np.arange(0, int(T * fs) + 1) / fs, 10)
    # steady state at u(0)
    u0 = u_of(0.0)
    Q0 = brentq(lambda Q: P0 - Kp0 * Q * Q - Rg00 * Q / u0, 0.0, 10.0)
    x0 = [Q0, Rg00 * Q0 / u0]
    breaks = sorted({0.0, T_OPEN, T_CLOSE, TF, 150.0, T})
    X = np.zeros((len(t), 2))
    X[0] = x0
    for a, b in zip(breaks[:-1], breaks[1:]):
        tm = 0.5 * (a + b)
        v = v_phys(run, tm)
        sel = (t > a - 1e-9) & (t <= b + 1e-9)
        sol = solve_ivp(rhs, (a, b), x0, args=(run, v), method="LSODA", t_eval=t[sel],
                        rtol=1e-10, atol=[1e-10, 1e-4], max_step=0.1)
        assert sol.success, sol.message
        X[sel] = sol.y.T
        x0 = sol.y[:, -1]
    Qp, P = X[:, 0], X[:, 1]
    u = u_of(t)
    Rg0 = np.array([params(run, tt)[1] for tt in t])
    bias = np.array([params(run, tt)[3] for tt in t])
    Qg = u * P / Rg0
    rng = np.random.default_rng(seed)
    out = {
        "t": t, "u": u, "v_cmd": vcmd_of(t),
        "Qp": Qp + rng.normal(0, SIG["Qp"], len(t)),
        "h": P / (rho * g) + bias + rng.normal(0, SIG["h"], len(t)),
        "Qg": Qg + rng.normal(0, SIG["Qg"], len(t)),
    }
    return out, X


def columns(run: str, seed: int) -> dict:
    """The record of one run: t, u, v_cmd, Qp, h (m), Qg."""
    return simulate(run, seed)[0]
