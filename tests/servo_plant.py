"""An independent plant of tests/data/servo_gearbox.yaml (a user trial's, 2026-12): the servo drive (motor,
gearbox, flexible shaft, load) integrated by scipy's LSODA from the textbook's equations.
Physics (textbook):
  La i'  = u - Ra i - Kt wm
  Jm wm' = Kt i - bm wm - tau_s/N
  JL wL' = tau_s - bL wL
  tau_s  = ks (th_m/N - th_L) + cs (wm/N - wL)
Faults from T0 = 10 s: :func:`columns`; the encoders quantised to 14 bits, the current with 10 mA of noise.
"""
import numpy as np
from scipy.integrate import solve_ivp

P = dict(Ra=1.0, La=2e-3, Kt=0.1, Jm=1e-4, bm=1e-4, N=10.0, ks=200.0, cs=0.1, JL=1e-2, bL=2e-2)
T0 = 10.0
RES = 2*np.pi/16384          # encoder quantisation (rad)
NOISE_I = 0.01               # A

PH = np.zeros(4)
def u(t):
    return 6 + 4*np.sin(2*np.pi*0.7*t + PH[0]) + 2*np.sin(2*np.pi*3.1*t + PH[1]) + 1*np.sin(2*np.pi*13*t + PH[2]) + 0.5*np.sin(2*np.pi*29*t + PH[3])

def params(t, fault):
    p = dict(P)
    if fault and "+" in fault:                  # several at once: each applied
        for one in fault.split("+"):
            p.update({k: v for k, v in params(t, one).items() if v != P[k]})
        return p
    if fault == "ks190" and t >= T0:            # a 5 % stiffness loss at once
        p["ks"] = 190.0
    if fault == "Ra" and t >= T0:
        p["Ra"] = 1.5
    if fault == "bL" and t >= T0:
        p["bL"] = 0.04
    if fault == "ks" and t >= T0:
        p["ks"] = 200.0*np.exp(-0.05*(t - T0))     # eq. (16): dks/dt = b1 ks, b1 = -0.05
    return p

def rhs(t, x, fault):
    i, wm, thm, wL, thL = x
    p = params(t, fault)
    tau = p["ks"]*(thm/p["N"] - thL) + p["cs"]*(wm/p["N"] - wL)
    di = (u(t) - p["Ra"]*i - p["Kt"]*wm)/p["La"]
    dwm = (p["Kt"]*i - p["bm"]*wm - tau/p["N"])/p["Jm"]
    dwL = (tau - p["bL"]*wL)/p["JL"]
    return [di, dwm, wm, dwL, wL]

def run(fault, seed, T=20.0, fs=1000.0):
    t = np.arange(0, round(T*fs) + 1)/fs
    PH[:] = np.random.default_rng(1000 + seed).uniform(0, 2*np.pi, 4)   # input phases vary run to run
    x0 = [0, 0, 0, 0, 0]
    if fault and any(f in ("Ra", "bL", "ks", "ks190") for f in fault.split("+")):   # in two pieces: the onset a breakpoint
        s1 = solve_ivp(rhs, (0, T0), x0, method="LSODA", t_eval=t[t <= T0], args=(None,), rtol=1e-10, atol=1e-12, max_step=1e-3)
        s2 = solve_ivp(rhs, (T0, T), s1.y[:, -1], method="LSODA", t_eval=t[t > T0], args=(fault,), rtol=1e-10, atol=1e-12, max_step=1e-3)
        y = np.hstack([s1.y, s2.y])
    else:
        s = solve_ivp(rhs, (0, T), x0, method="LSODA", t_eval=t, args=(None,), rtol=1e-10, atol=1e-12, max_step=1e-3)
        y = s.y
    i, wm, thm, wL, thL = y
    rng = np.random.default_rng(seed)
    i_m = i + NOISE_I*rng.standard_normal(t.size)
    if fault == "beta_theta_m":
        thm = np.where(t >= T0, 0.95*thm, thm)
    if fault and "bias_theta_L" in fault.split("+"):
        thL = np.where(t >= T0, thL + 0.05, thL)
    thm_m = np.round(thm/RES)*RES
    thL_m = np.round(thL/RES)*RES
    return t, np.c_[t, u(t), i_m, thm_m, thL_m]


def columns(fault: str | None, seed: int, T: float = 20.0) -> dict[str, np.ndarray]:
    """The record bgfdi reads: t, u, i, theta_m, theta_L."""
    _, d = run(fault, seed, T)
    return {name: d[:, k].copy() for k, name in enumerate(("t", "u", "i", "theta_m", "theta_L"))}
