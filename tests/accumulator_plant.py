"""Independent simulator of the accumulator / check-valve circuit of tests/data/unverified/
accumulator_check_valve.yaml (scipy solve_ivp), from the physics in that file's header, not from
bgfdi: written by a user trial (session 33) with its own simulator. Columns t, Qp, v_cmd, pp, pa, Ql."""
import numpy as np
from scipy.integrate import solve_ivp

NOM = dict(V0=4.0e-3, p0=5.0e6, n=1.4, Kc=4.7e-7, Kv=7.2e-8, Rleak=9.0e11)
QP_ON = 3.333e-4
TS = 0.01

def params_at(t, fault):
    p = dict(NOM)
    if fault and t >= fault["t0"]:
        k = fault["target"]
        if fault["type"] == "abrupt":
            p[k] = fault["value"]
        elif fault["type"] == "incipient":        # d theta/dt = b theta  (paper's model 1)
            p[k] = NOM[k] * np.exp(fault["b"] * (t - fault["t0"]))
    return p

def pa_of(q, p):
    return p["p0"] * (p["V0"] / (p["V0"] - q)) ** p["n"]

def q_of(pa, p):
    return p["V0"] * (1 - (p["p0"] / pa) ** (1 / p["n"]))

def pump_line(Qp, pa, p):
    """pp and check-valve flow. Pump on: Qp - pp/Rleak = Kc sqrt(pp - pa) (solve for x = sqrt(pp-pa))."""
    if Qp <= 0:
        return 0.0, 0.0
    A = Qp - pa / p["Rleak"]
    if A <= 0:
        return Qp * p["Rleak"], 0.0
    x = 2 * A / (p["Kc"] + np.sqrt(p["Kc"] ** 2 + 4 * A / p["Rleak"]))
    return pa + x * x, p["Kc"] * x

def rhs(t, y, Qp, v, fault):
    p = params_at(t, fault)
    q = y[0]
    pa = pa_of(q, p)
    _, Qc = pump_line(Qp, pa, p)
    Ql = v * p["Kv"] * np.sqrt(max(pa, 0.0))
    return [Qc - Ql]

def valve_cmd(t):
    return 1 if (t % 5.0) < 3.0 else 0

def simulate(T=60.0, seed=0, fault=None, sensor_bias=None, noise=True):
    rng = np.random.default_rng(seed)
    k_noise = 1.0 if noise else 0.0
    N = int(round(T / TS)) + 1
    t = np.arange(N) * TS
    q = q_of(1.2e7, NOM)
    pump = 1
    rows = []
    for k in range(N):
        tk = t[k]
        p = params_at(tk, fault)
        pa = pa_of(q, p)
        bias = sensor_bias["value"] if (sensor_bias and tk >= sensor_bias["t0"]) else 0.0
        pa_meas_clean = pa + bias
        # pump controller (hysteresis on the transmitter's reading, sampled)
        if pa_meas_clean > 1.5e7:
            pump = 0
        elif pa_meas_clean < 1.0e7:
            pump = 1
        Qp = QP_ON * pump
        v = valve_cmd(tk)
        pp, _ = pump_line(Qp, pa, p)
        Ql = v * p["Kv"] * np.sqrt(pa)
        rows.append((tk, Qp, v, pp + k_noise * rng.normal(0, 5e3), pa_meas_clean + k_noise * rng.normal(0, 5e3),
                     Ql + k_noise * rng.normal(0, 2e-6)))
        if k < N - 1:
            sol = solve_ivp(rhs, (tk, t[k + 1]), [q], args=(Qp, v, fault), method="RK45", rtol=1e-9, atol=1e-12)
            q = sol.y[0, -1]
    return np.array(rows)

def write(path, data):
    np.savetxt(path, data, delimiter=",", header="t,Qp,v_cmd,pp,pa,Ql", comments="", fmt="%.10g")
