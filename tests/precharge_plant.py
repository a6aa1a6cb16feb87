"""An EV precharge circuit simulated apart from bgfdi (no bgfdi import; written by a user trial from
the circuit, Hauser & Kuhn ch. 11, and kept as the tests' reference plant for
tests/data/ev_precharge.yaml).

States: vC (DC-link capacitor internal voltage), v1 (battery polarisation RC voltage).
Battery: Vb = Vocv - R0*ib - v1 (the BMS measures Vb at the pack terminals).
Contactor branches: conductance G = p/Rp + m/Rm between battery terminal and the link.
Link: ib = i_br + d*vdc/Rdis + iinv;  vdc = vC + Resr*i_br;  C dvC/dt = i_br - vC/Rleak.
Exact discretisation (ZOH on Vocv, iinv; matrix exponential per sample, parameters frozen over a
sample). BMS logic in the loop: precharge, close main at 95 % of Vb (measured), open precharge
50 ms later, inverter load steps with undervoltage lockout, key-off, active discharge.
"""
import numpy as np
from scipy.linalg import expm

NOM = dict(Rp=50.0, Rm=0.002, C=1.0e-3, Resr=0.005, Rleak=5.0e4, Rdis=200.0,
           R0=0.08, R1=0.03, C1=1000.0, Vocv=400.0)
NOISE = dict(Vb=0.2, iinv=0.2, ib=0.3, vdc=0.2)


def algebra(P, p, m, d):
    """y = (ib, vdc, i_br, Vb) = K x + L u with x = (vC, v1), u = (Vocv, iinv)."""
    G = p / P["Rp"] + m / P["Rm"]
    M = np.array([[1.0, G, 0.0, -G],          # ib - G (Vb - vdc) = 0
                  [P["R0"], 0.0, 0.0, 1.0],      # Vb + R0 ib = Vocv - v1
                  [1.0, -d / P["Rdis"], -1.0, 0.0],  # ib - d vdc/Rdis - i_br = iinv
                  [0.0, 1.0, -P["Resr"], 0.0]])   # vdc - Resr i_br = vC
    N = np.array([[0, 0], [0, -1.0], [0, 0], [1.0, 0]])
    U = np.array([[0, 0], [1.0, 0], [0, 1.0], [0, 0]])
    Mi = np.linalg.inv(M)
    return Mi @ N, Mi @ U


def dynamics(P, K, L):
    # xdot = [(i_br - vC/Rleak)/C, ib/C1 - v1/(R1 C1)]
    S = np.array([[0, 0, 1.0 / P["C"], 0], [1.0 / P["C1"], 0, 0, 0]])
    A = S @ K + np.array([[-1.0 / (P["Rleak"] * P["C"]), 0], [0, -1.0 / (P["R1"] * P["C1"])]])
    B = S @ L
    return A, B


def step_matrices(A, B, dt):
    n, k = A.shape[0], B.shape[1]
    Mx = np.zeros((n + k, n + k)); Mx[:n, :n] = A; Mx[:n, n:] = B
    E = expm(Mx * dt)
    return E[:n, :n], E[:n, n:]


RAMP = 0.0      # s: the inverter's current ramps (0: steps)


def simulate(T=30.0, fs=1000.0, seed=0, faults=(), cycle=3.0, load_scale=1.0, Vocv=400.0):
    """(t, columns by name, truth) of a run of T s at fs Hz: a drive cycle every ``cycle`` s
    (precharge, main contactor, inverter load steps, key-off, active discharge); ``faults``: dicts
    with target (Rp, C, vdc_bias, beta_ib, main_stuck_open, pre_stuck_open), t0 and value (C: b, a
    rate of exponential decay)."""
    rng = np.random.default_rng(seed)
    dt = 1.0 / fs
    n = int(round(T * fs)) + 1
    t = np.arange(n) * dt
    x = np.zeros(2)
    cols = {k: np.zeros(n) for k in ["Vb", "iinv", "p_cmd", "m_cmd", "d_cmd", "ib", "vdc"]}
    truth = {k: np.zeros(n) for k in ["vdc_true", "ib_true", "C_true", "Rp_true", "m_phys"]}
    p_cmd = m_cmd = d_cmd = 0
    pre_start = main_close = None
    cyc_prev = -1
    cache = {}
    prev = None
    logged = (0, 0, 0)
    for k in range(n):
        tk = t[k]
        P = dict(NOM); P["Vocv"] = Vocv
        bias_vdc = 0.0; gain_ib = 1.0; m_stuck = None; p_stuck = None
        for f in faults:
            if tk < f["t0"]:
                continue
            if f["target"] == "Rp":
                P["Rp"] = f["value"]
            elif f["target"] == "C":
                P["C"] = NOM["C"] * np.exp(f["b"] * (tk - f["t0"]))
            elif f["target"] == "vdc_bias":
                bias_vdc = f["value"]
            elif f["target"] == "beta_ib":
                gain_ib = f["value"]
            elif f["target"] == "main_stuck_open":
                m_stuck = 0
            elif f["target"] == "pre_stuck_open":
                p_stuck = 0
        # --- BMS / VCU command logic (decided on the previous sample's measurements)
        c = int(tk // cycle); tc = tk - c * cycle
        if c != cyc_prev:
            cyc_prev = c; pre_start = main_close = None; p_cmd = m_cmd = d_cmd = 0
        vdc_m = cols["vdc"][k - 1] if k else 0.0
        vb_m = cols["Vb"][k - 1] if k else Vocv
        if pre_start is None and tc >= 0.1 - 1e-9:
            p_cmd = 1; pre_start = tk
        if pre_start is not None and main_close is None and p_cmd == 1 and tk - pre_start >= 0.05 \
                and vdc_m >= 0.95 * vb_m:
            m_cmd = 1; main_close = tk
        if pre_start is not None and main_close is None and tk - pre_start > 1.0:
            p_cmd = 0                       # precharge timeout: abort
        if main_close is not None and tk - main_close >= 0.05 - 1e-9:
            p_cmd = 0
        if tc >= 2.1 - 1e-9:
            m_cmd = 0; p_cmd = 0
        if 2.2 - 1e-9 <= tc < 2.95 and vdc_m > 20.0:
            d_cmd = 1
        else:
            d_cmd = 0
        # inverter DC current demand with undervoltage lockout (250 V)
        # torque (current) demand, ramped over RAMP s by the inverter's rate limiter
        pts = [(0.6, 0.0, 20.0), (1.0, 20.0, 80.0), (1.5, 80.0, -30.0), (1.9, -30.0, 0.0)]
        dem = 0.0
        for ts, a0, a1 in pts:
            if tc >= ts:
                dem = a1 if tc >= ts + RAMP else a0 + (a1 - a0) * (tc - ts) / RAMP
        iinv = load_scale * dem if (m_cmd == 1 and vdc_m > 250.0) else 0.0
        p = p_cmd if p_stuck is None else p_stuck
        m = m_cmd if m_stuck is None else m_stuck
        key = (p, m, d_cmd, P["Rp"], P["C"])
        if key not in cache:
            if len(cache) > 50000: cache.clear()
            K, L = algebra(P, p, m, d_cmd)
            A, B = dynamics(P, K, L)
            Ad, Bd = step_matrices(A, B, dt)
            cache[key] = (K, L, Ad, Bd)
        K, L, Ad, Bd = cache[key]
        u = np.array([Vocv, iinv])
        # the sample at t_k is taken just before the switches commanded at t_k act
        Ko, Lo, uo = (K, L, u) if prev is None else prev
        y = Ko @ x + Lo @ uo
        prev = (K, L, u)
        ib, vdc, i_br, Vb = y
        cols["Vb"][k] = Vb + NOISE["Vb"] * rng.standard_normal()
        cols["iinv"][k] = uo[1] + NOISE["iinv"] * rng.standard_normal()
        # the logged command is the one in force at the measured instant (issued one sample before)
        cols["p_cmd"][k], cols["m_cmd"][k], cols["d_cmd"][k] = logged
        logged = (p_cmd, m_cmd, d_cmd)
        cols["ib"][k] = gain_ib * ib + NOISE["ib"] * rng.standard_normal()
        cols["vdc"][k] = vdc + bias_vdc + NOISE["vdc"] * rng.standard_normal()
        truth["vdc_true"][k] = vdc; truth["ib_true"][k] = ib; truth["C_true"][k] = P["C"]
        truth["Rp_true"][k] = P["Rp"]; truth["m_phys"][k] = m
        x = Ad @ x + Bd @ u
    return t, cols, truth
