"""A multirotor's propulsion unit simulated apart from bgfdi (no bgfdi import; written by a user
trial from the physics, Karnopp, Margolis & Rosenberg's DC motor and McCormick's propeller torque,
and kept as the tests' reference plant for tests/data/drone_propulsion.yaml).

States: im (winding current), w (rotor speed), Q (charge drawn, for the open-circuit voltage's
slow fall).
  Voc = V0 - Q/Cb               (Cb = 15000 F: about 1.2 V over 5 Ah)
  ib = d*im, vb = Voc - Rb*ib
  La dim/dt = d*vb - Ra*im - K*w        (armed; disarmed: the current collapses in about 10 us)
  J dw/dt = K*im - b*w - kq*w*|w|
Time constants: electrical La/(Ra + Rb d^2) ~ 0.36 ms, shorter than the 1 ms sampling time;
mechanical ~ 13 ms. ``run`` writes t, d (throttle), arm, ib, vb, w as a CSV.
"""
import numpy as np
from scipy.integrate import solve_ivp

P = dict(V0=16.0, Cb=15000.0, Rb=0.02, Ra=0.08, La=3e-5, K=0.0104, J=2e-5, b=5e-6, kq=2e-7)
NOISE = dict(ib=0.1, vb=0.02, w=1.0)

def throttle(t, ph):
    return 0.65 + 0.1*np.sin(2*np.pi*0.4*t + ph[0]) + 0.05*np.sin(2*np.pi*1.3*t + ph[1]) + 0.02*np.sin(2*np.pi*3.1*t + ph[2])

def run(path, seed, T=60.0, fs=1000.0, fault=None, disarm=None, phases=None):
    rng = np.random.default_rng(seed)
    ph = phases if phases is not None else rng.uniform(0, 2*np.pi, 3)
    def par(name, t):
        v = P[name]
        if fault and fault["target"] == name and t >= fault["t0"]:
            if fault["type"] == "abrupt":
                v = fault["value"]
            elif fault["type"] == "incipient":   # eq. 16: dP/dt = b1 P
                v = v*np.exp(fault["b1"]*(t - fault["t0"]))
        return v
    def armed(t):
        return not (disarm and disarm[0] <= t < disarm[1])
    def dcmd(t):
        return throttle(t, ph) if armed(t) else 0.0
    def rates(t, x):
        im, w, Q = x
        d = dcmd(t)
        Voc = P["V0"] - Q/P["Cb"]
        Ra, b, kq = par("Ra", t), par("b", t), par("kq", t)
        if armed(t):
            ib = d*im
            vb = Voc - P["Rb"]*ib
            dim = (d*vb - Ra*im - P["K"]*w)/P["La"]
        else:
            ib, dim = 0.0, -im/1e-5   # current collapses (freewheel) in ~10 us
        dw = (P["K"]*im - b*w - kq*w*abs(w))/P["J"]
        return [dim, dw, ib]
    t = np.arange(0.0, T + 0.5/fs, 1.0/fs)
    # breakpoints: fault onset, disarm edges
    bps = sorted({0.0, T} | ({fault["t0"]} if fault else set()) | (set(disarm) if disarm else set()))
    # initial steady state: w where K*im = load, d*V0 = Ra*im + K*w  (solve by a spin-up)
    x0 = [0.0, 0.0, 0.0]
    pre = solve_ivp(lambda tt, x: rates(0.0, x)[:2] + [0.0], (0, 1.0), x0, method="LSODA", rtol=1e-8, atol=1e-10)
    x0 = [pre.y[0, -1], pre.y[1, -1], 0.0]
    X = np.zeros((t.size, 3))
    for a, bnd in zip(bps[:-1], bps[1:]):
        m = (t >= a) & (t < bnd) if bnd < T else (t >= a)
        te = t[m]
        end = bnd if bnd < T else te[-1]             # to the breakpoint itself: the next piece starts there
        sol = solve_ivp(rates, (a, end), x0, t_eval=np.r_[te, end] if te[-1] < end else te, method="LSODA",
                        rtol=1e-9, atol=1e-11, max_step=1e-3)
        assert sol.success, sol.message
        X[m] = sol.y[:, :te.size].T
        x0 = sol.y[:, -1]
    im, w, Q = X.T
    d = np.array([dcmd(tt) for tt in t]); arm = np.array([1.0 if armed(tt) else 0.0 for tt in t])
    ib = d*im*arm
    vb = P["V0"] - Q/P["Cb"] - P["Rb"]*ib
    ib_m = ib + rng.normal(0, NOISE["ib"], t.size)
    vb_m = vb + rng.normal(0, NOISE["vb"], t.size)
    w_m = w + rng.normal(0, NOISE["w"], t.size)
    if fault and fault["target"] == "bias_ib":
        ib_m = ib_m + np.where(t >= fault["t0"], fault["value"], 0.0)
    if fault and fault["target"] == "beta_w":
        w_m = np.where(t >= fault["t0"], fault["value"]*w + rng.normal(0, NOISE["w"], t.size), w_m)
    np.savetxt(path, np.column_stack([t, d, arm, ib_m, vb_m, w_m]), delimiter=",",
               header="t,d,arm,ib,vb,w", comments="", fmt="%.9g")
    return dict(w_range=(float(w.min()), float(w.max())), ib_range=(float(ib.min()), float(ib.max())),
                vb_range=(float(vb.min()), float(vb.max())), dOCV=float(Q[-1]/P["Cb"]))
