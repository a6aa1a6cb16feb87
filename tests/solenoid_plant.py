"""An independent plant of tests/data/solenoid_valve.yaml (a user trial's, 2026-12): a PWM-driven linear
solenoid actuator with a free-wheeling diode, integrated by scipy from its equations.

Physics (not bgfdi):
  switch on  (s=1):               L di/dt = u - R i - K v
  switch off, diode on (i > 0):   L di/dt = -(R + Rd) i - K v
  switch off, diode off (i = 0):  i = 0 (diode blocks; re-enters conduction when -K v > 0)
  m dv/dt = K i - b v - k x,   dx/dt = v
Faults: parameters as functions of time; current-sensor bias/gain; switch stuck.
Columns t, u, s_cmd, i, x (s_cmd: the driver's command, what the controller logs): :func:`columns`.
"""
import numpy as np
from scipy.integrate import solve_ivp

P0 = dict(R=12.0, L=0.05, Rd=1.0, K=5.0, m=0.05, b=14.0, k=2000.0, U=24.0)
F_PWM = 20.0      # Hz
DUTY = 0.5
FS = 10000.0


def command(t):
    ph = np.mod(t * F_PWM, 1.0)
    return (ph < DUTY - 1e-12).astype(float) if np.ndim(t) else float(ph < DUTY - 1e-12)


def param(name, t, faults):
    v = P0[name]
    for f in faults:
        if f.get("target") != name or t < f["t0"]:
            continue
        if f["type"] == "abrupt":
            v = f["value"]
        elif f["type"] == "incipient":          # dθ/dt = b1 θ  (exponential drift)
            v = v * np.exp(f["b1"] * (t - f["t0"]))
    return v


def switch_state(t, faults):
    s = command(t)
    for f in faults:
        if f.get("target") == "switch" and t >= f["t0"]:
            s = float(f["value"])
    return s


def simulate(T, faults, seed, noise_i=0.005, noise_x=2e-6):
    # breakpoints: PWM edges and fault onsets
    edges = set(np.round(np.arange(0, T + 1e-12, 0.5 / F_PWM * 2 * DUTY), 12))
    edges |= set(np.round(np.arange(DUTY / F_PWM, T, 1.0 / F_PWM), 12))
    for f in faults:
        edges.add(round(f["t0"], 12))
    edges = sorted(e for e in edges if 0 <= e <= T) + [T]
    edges = sorted(set(edges))
    tgrid = np.round(np.arange(0, int(round(T * FS)) + 1) / FS, 10)
    Y = np.zeros((len(tgrid), 3))
    y = np.array([0.0, 0.0, 0.0])   # i, x, v

    def rhs(t, y, s, conducting):
        i, x, v = y
        R, L, Rd, K, m, b, k = (param(n, t, faults) for n in ("R", "L", "Rd", "K", "m", "b", "k"))
        if s >= 0.5:
            di = (P0["U"] - R * i - K * v) / L
        elif conducting:
            di = (-(R + Rd) * i - K * v) / L
        else:
            di = 0.0
        dv = (K * i - b * v - k * x) / m
        return [di, v, dv]

    filled = np.zeros(len(tgrid), bool)
    for a, bnd in zip(edges[:-1], edges[1:]):
        if bnd - a < 1e-12:
            continue
        tm = 0.5 * (a + bnd)
        s = switch_state(tm, faults)
        t0 = a
        while t0 < bnd - 1e-13:
            if s >= 0.5:
                conducting = True
            else:
                conducting = y[0] > 1e-12 or (-P0["K"] * y[2] > 0)
                if not conducting:
                    y[0] = 0.0
            ev_i0 = lambda t, y, *_: y[0]
            ev_i0.terminal, ev_i0.direction = True, -1
            ev_v0 = lambda t, y, *_: y[2]
            ev_v0.terminal, ev_v0.direction = True, -1
            events = []
            if s < 0.5 and conducting:
                events = [ev_i0]
            elif s < 0.5 and not conducting:
                events = [ev_v0]
            sol = solve_ivp(rhs, (t0, bnd), y, args=(s, conducting), method="RK45", rtol=1e-10,
                            atol=[1e-12, 1e-14, 1e-12], dense_output=True, events=events or None,
                            max_step=2e-4)
            tend = sol.t[-1]
            sel = (tgrid >= t0 - 1e-12) & (tgrid <= tend + 1e-12) & ~filled
            if sel.any():
                Y[sel] = sol.sol(tgrid[sel]).T
                filled |= sel
            y = sol.y[:, -1].copy()
            if s < 0.5 and conducting and sol.status == 1:
                y[0] = 0.0
            t0 = tend
            if sol.status == 0:
                break
    assert filled.all()
    rng = np.random.default_rng(seed)
    i_true, x_true = Y[:, 0], Y[:, 1]
    i_meas = i_true.copy()
    for f in faults:
        if f.get("target") == "sensor_i":
            on = tgrid >= f["t0"]
            if f["effect"] == "bias":
                i_meas[on] += f["value"]
            else:
                i_meas[on] *= f["value"]
    i_meas = i_meas + rng.normal(0, noise_i, len(tgrid))
    x_meas = x_true + rng.normal(0, noise_x, len(tgrid))
    u = np.full(len(tgrid), P0["U"])
    return tgrid, u, command(tgrid), i_meas, x_meas, Y


def columns(T: float, faults: list[dict], seed: int) -> dict[str, np.ndarray]:
    """The record bgfdi reads: time, supply, command, measured current and position."""
    t, u, s, i, x, _ = simulate(T, faults, seed)
    return {"t": t, "u": u, "s_cmd": s, "i": i, "x": x}
