"""Independent simulator of tests/data/water_heater.yaml: a stirred 150 l tank heated by a 2 kW
element that a thermostat relay switches (on below 55 C, off above 60 C, decided once a second
from the true temperature), losing heat through its insulation (UA = 2 W/K) to a 20 C room and
to the 15 C mains water that replaces each draw (Incropera & DeWitt, ch. 1: the tank's energy
balance), typed by hand, never importing ``bondgraph`` or ``fdi``:

    Ct dT/dt = s(t) beta Ph - (T - Tamb)/Rw - cp mdot(t) (T - Tin)

Between two samples the relay and the draw are constant, so the balance is linear with constant
coefficients and each step is its exact solution, T(t + h) = Teq + (T - Teq) exp(-g h / Ct) with
g = 1/Rw + cp mdot and Teq the temperature the step tends to. Faults from ``t0``: the element's
power scaled by ``beta`` (partly burnt out), the insulation ``rw``, the relay stuck open
(``stuck_off``: the command goes on, the element gets nothing). The probe reads T with 0.05 K
of noise."""
from __future__ import annotations

import numpy as np

CT, RW, CP, PH = 6.279e5, 0.5, 4186.0, 2000.0       # J/K, K/W, J/(kg K), W
TAMB, TIN, TS = 293.15, 288.15, 1.0                  # K, K, s
LOW, HIGH = 328.15, 333.15                           # the thermostat's band, K
DRAWS = ((1200, 1500, 0.12), (4000, 4200, 0.08), (7000, 7600, 0.1), (10500, 10800, 0.15))   # s, s, kg/s


def draw(t: np.ndarray) -> np.ndarray:
    """The hot-water draw (kg/s) at the times ``t``."""
    m = np.zeros_like(t)
    for a, b, q in DRAWS:
        m = np.where((t >= a) & (t < b), q, m)
    return m


def simulate(seed: int, T: float = 12000.0, t0: float | None = None, beta: float = 1.0, rw: float = RW,
             stuck_off: bool = False) -> dict:
    """Columns t, Ph, s_cmd, Tamb, Tin, mdot, T every TS s over [0, T]; from ``t0`` the faults."""
    t = np.arange(0.0, T + TS / 2, TS)
    mdot = draw(t)
    temp, relay_cmd = np.empty(t.size), np.empty(t.size)
    x, relay = 330.0, 1.0
    for k, tk in enumerate(t):
        temp[k] = x
        relay = 1.0 if x < LOW else 0.0 if x > HIGH else relay
        relay_cmd[k] = relay
        late = t0 is not None and tk >= t0
        power = PH * (beta if late else 1.0) * (0.0 if late and stuck_off else relay)
        r = rw if late else RW
        g = 1.0 / r + CP * mdot[k]
        teq = (power + TAMB / r + CP * mdot[k] * TIN) / g
        x = teq + (x - teq) * np.exp(-g * TS / CT)
    rng = np.random.default_rng(seed)
    n = t.size
    return {"t": t, "Ph": np.full(n, PH), "s_cmd": relay_cmd, "Tamb": np.full(n, TAMB), "Tin": np.full(n, TIN),
            "mdot": mdot, "T": temp + rng.normal(0.0, 0.05, n)}
