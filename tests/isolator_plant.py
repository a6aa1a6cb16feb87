"""A base-excited vibration isolator with a gap end stop, simulated apart from bgfdi (scipy only;
written by a user trial from the physics, kept as the tests' reference plant for
tests/data/isolator_end_stop.yaml).

Physics (delta = x_b - x_m, the isolator's compression; v the mass velocity; vb the base velocity):
    delta' = vb(t) - v
    m v'   = k delta + b delta' + c * (k_s (delta - g) + b_s delta'),   c = 1 while delta > g
The contact is located exactly with solve_ivp's event detection on delta - g = 0 (terminal),
and the integration restarts in the other mode.  Abrupt faults split the integration at t0.
Output: CSV with columns t, vb, v, delta (sampled at fs, sensor noise added after sampling).
"""
import numpy as np
from scipy.integrate import solve_ivp

NOM = dict(m=10.0, k=4000.0, b=40.0, k_s=1.0e5, b_s=200.0, g=0.005)
NOISE = dict(v=1.0e-4, delta=1.0e-5, vb=2.0e-5)


def excitation(seed, amp):
    """A sum of 5 sines (0.8 to 5 Hz, random phases), ramped in over 2 s; returns vb(t), vb'(t)."""
    rng = np.random.default_rng(1000 + seed)
    f = np.sort(rng.uniform(0.8, 5.0, 5))
    f[2] = rng.uniform(2.8, 3.4)                    # one near the 3.18 Hz resonance
    a = amp * rng.uniform(0.3, 1.0, 5)
    ph = rng.uniform(0, 2 * np.pi, 5)
    w = 2 * np.pi * f

    def vb(t):
        t = np.asarray(t, float)
        ramp = np.where(t < 2.0, 0.5 * (1 - np.cos(np.pi * t / 2.0)), 1.0)
        s = sum(a[i] * np.sin(w[i] * t + ph[i]) for i in range(5))
        return ramp * s
    return vb, dict(freqs_hz=f.round(3).tolist(), amps=a.round(4).tolist())


def params_at(t, faults):
    p = dict(NOM)
    for fl in faults:
        if fl["target"] in p and t >= fl["t0"]:
            if fl["type"] == "abrupt":
                p[fl["target"]] = fl["value"]
            elif fl["type"] == "drift":          # linear drift of the relative value: p0 * (1 + rate (t - t0))
                p[fl["target"]] = NOM[fl["target"]] * (1 + fl["rate"] * (t - fl["t0"]))
    return p


def simulate(T, fs, seed, amp, faults):
    """(t, vb, v, delta, contacts, excitation) of a noise-free run of T s sampled at fs Hz."""
    vb, info = excitation(seed, amp)
    breaks = sorted({fl["t0"] for fl in faults if fl["type"] == "abrupt" and fl["target"] in NOM})

    def rhs(t, y, c):
        delta, v = y
        p = params_at(t, faults)
        dd = vb(t) - v
        F = p["k"] * delta + p["b"] * dd
        if c:
            F += p["k_s"] * (delta - p["g"]) + p["b_s"] * dd
        return [dd, F / p["m"]]

    def make_event(c):
        def ev(t, y, c_):
            return y[0] - params_at(t, faults)["g"]
        ev.terminal = True
        ev.direction = 1 if c == 0 else -1      # free: look for entering the stop; contact: for leaving it
        return ev

    tgrid = np.arange(int(round(T * fs)) + 1) / fs
    ts, ys = [], []
    t, y, c = 0.0, np.array([0.0, 0.0]), 0
    contacts = 0
    stops = breaks + [T]
    while t < T - 1e-12:
        tend = min(s for s in stops if s > t + 1e-12)
        sol = solve_ivp(rhs, (t, tend), y, args=(c,), events=make_event(c), method="DOP853", rtol=1e-10, atol=1e-13,
                        max_step=2e-3, dense_output=True)
        tf = sol.t[-1]
        sel = tgrid[(tgrid >= t) & (tgrid < tf)] if tf < T else tgrid[tgrid >= t]
        if len(sel):
            ts.append(sel)
            ys.append(sol.sol(sel).T)
        y = sol.y[:, -1].copy()
        if sol.status == 1:                      # contact made or lost
            c = 1 - c
            contacts += c
            # step just past the event so it is not found again at the start
        t = tf
    tt = np.concatenate(ts)
    Y = np.concatenate(ys)
    assert np.allclose(tt, tgrid), (len(tt), len(tgrid))
    return tgrid, vb(tgrid), Y[:, 1], Y[:, 0], contacts, info


def measured(T, fs, seed, amp, faults=()):
    """The data columns of a run (t, vb, v, delta) with the sensors' noise, sensor faults applied."""
    t, vb, v, delta, _, _ = simulate(T, fs, seed, amp, list(faults))
    rng = np.random.default_rng(seed)
    vb_m = vb + NOISE["vb"] * rng.standard_normal(len(t))
    v_m = v + NOISE["v"] * rng.standard_normal(len(t))
    d_m = delta + NOISE["delta"] * rng.standard_normal(len(t))
    for fl in faults:
        on = t >= fl["t0"]
        if fl["target"] == "bias_delta":
            d_m[on] += fl["value"]
        elif fl["target"] == "beta_v":
            v_m[on] *= fl["value"]
    return {"t": t, "vb": vb_m, "v": v_m, "delta": d_m}
