"""An engine cooling circuit simulated apart from bgfdi (no bgfdi import; written by a user trial
from the physics, Karnopp, Margolis & Rosenberg's thermal pseudo bond graphs, and kept as the
tests' reference plant for tests/data/engine_cooling.yaml).

  Ce dTe/dt = Qin - Gh (Te - Ta) - Gt x(Te) (Te - Tr)
  Cr dTr/dt = Gt x(Te) (Te - Tr) - (Ua0 + fan Uf) (Tr - Ta)
  x(Te) = clip((Te - Tst)/dTst, 0, 1)     the wax thermostat's lift
The ECU switches the fan on above 92 degC and off below 88 degC of the measured Te, evaluated each
sample and held until the next (the logged command); a dead fan does not run from ``fan_dead`` on
while the command is still logged. Integrated sample by sample (LSODA). ``run`` writes t, Qin,
Tamb, fan_cmd, Te, Tr as a CSV.
"""
import numpy as np
from scipy.integrate import solve_ivp

P = dict(Ce=45000.0, Cr=8000.0, Gt=3600.0, Tst=358.15, dTst=12.0, Ua0=900.0, Uf=900.0, Gh=150.0)
FAN_ON, FAN_OFF = 365.15, 361.15
NOISE = 0.1


def qin(t):
    return 38000 + 12000 * np.sin(2 * np.pi * t / 500) + 6000 * np.sin(2 * np.pi * t / 137 + 1) \
        + 4000 * np.sin(2 * np.pi * t / 61)


def tamb(t):
    return 303.15 + 2.0 * np.sin(2 * np.pi * t / 3000)


def run(path, seed, T=2400.0, fs=10.0, fan_dead=None, Te0=360.15, Tr0=340.15):
    rng = np.random.default_rng(seed)
    dt = 1.0 / fs
    n = int(round(T * fs)) + 1
    t = np.arange(n) * dt

    def rhs(tt, y, fan):
        Te, Tr = y
        Ta = tamb(tt)
        q = P["Gt"] * float(np.clip((Te - P["Tst"]) / P["dTst"], 0, 1)) * (Te - Tr)
        return [(qin(tt) - P["Gh"] * (Te - Ta) - q) / P["Ce"], (q - (P["Ua0"] + fan * P["Uf"]) * (Tr - Ta)) / P["Cr"]]

    y = np.array([Te0, Tr0])
    fan = 0
    Te, Tr, cmd = np.empty(n), np.empty(n), np.empty(n)
    noise_e, noise_r = rng.normal(0, NOISE, n), rng.normal(0, NOISE, n)
    for k in range(n):
        Te[k], Tr[k] = y
        measured = y[0] + noise_e[k]
        if fan == 0 and measured > FAN_ON:
            fan = 1
        elif fan == 1 and measured < FAN_OFF:
            fan = 0
        cmd[k] = fan
        if k == n - 1:
            break
        running = 0 if fan_dead is not None and t[k] >= fan_dead else fan
        y = solve_ivp(rhs, (t[k], t[k + 1]), y, args=(running,), method="LSODA", rtol=1e-9, atol=1e-9).y[:, -1]
    with open(path, "w") as f:
        f.write("t,Qin,Tamb,fan_cmd,Te,Tr\n")
        for k in range(n):
            f.write(f"{t[k]:.1f},{qin(t[k]):.3f},{tamb(t[k]):.4f},{int(cmd[k])},{Te[k] + noise_e[k]:.4f},"
                    f"{Tr[k] + noise_r[k]:.4f}\n")
    return t, cmd
