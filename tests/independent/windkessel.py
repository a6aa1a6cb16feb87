"""Independent simulator of tests/data/windkessel.yaml: the three-element Windkessel of the systemic
arteries (Westerhof, Lankhaar & Westerhof, Med Biol Eng Comput 47:131, 2009), typed by hand from
its two laws, never importing ``bondgraph`` or ``fdi``:

    C dpc/dt = Q(t) - pc/Rp       (the arteries' compliance filled by the aortic inflow, drained
                                   through the peripheral resistance)
    p = pc + Zc Q(t)              (the aortic root pressure: the characteristic impedance's drop on top)

A fault from ``t0`` multiplies ``which`` (Rp, C or Zc) by ``factor``; the stored volume C pc is
continuous when C changes. Integrated by scipy's LSODA (rtol 1e-10) piece by piece from the steady
state of the mean inflow; the pressure reads with 30 Pa of noise (0.2 mmHg), the inflow exactly."""
from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

NOMINAL = {"Zc": 6.67e6, "C": 1.125e-8, "Rp": 1.333e8}     # Pa s/m^3, m^3/Pa, Pa s/m^3
TS, NOISE, Q_MEAN = 0.01, 30.0, 9.0e-5                    # s, Pa, m^3/s (5.4 l/min)


def inflow(t):
    """The aortic inflow (m^3/s): one beat of 0.8 s and its second harmonic (the model's input
    expression, written out)."""
    return Q_MEAN * (1 + 0.9 * np.sin(7.854 * t) + 0.3 * np.sin(15.708 * t))


def simulate(seed: int, T: float = 90.0, t0: float | None = None, factor: float = 1.0,
             which: str = "Rp") -> dict[str, np.ndarray]:
    """Columns t, Q, p every TS s over [0, T]; from ``t0`` parameter ``which`` times ``factor``."""
    def par(t, name):
        return NOMINAL[name] * (factor if t0 is not None and which == name and t >= t0 else 1.0)

    t = np.arange(0.0, T + TS / 2, TS)
    edges = [0.0, T] if t0 is None else [0.0, t0, T]
    volume = NOMINAL["C"] * NOMINAL["Rp"] * Q_MEAN          # C pc at rest under the mean inflow
    pieces = []
    for a, b in zip(edges[:-1], edges[1:]):
        C, Rp = par(a, "C"), par(a, "Rp")
        keep = t[(t >= a) & ((t < b) | (b == T))]
        s = solve_ivp(lambda tt, v: [inflow(tt) - v[0] / (C * Rp)], (a, b), [volume],
                      t_eval=np.append(keep, b) if keep[-1] < b else keep, rtol=1e-10, atol=1e-18, method="LSODA")
        pieces.append(s.y[0, :keep.size] / C)
        volume = s.y[0, -1]
    pc = np.concatenate(pieces)
    zc = np.array([par(x, "Zc") for x in t])
    p = pc + zc * inflow(t) + np.random.default_rng(seed).normal(0.0, NOISE, t.size)
    return {"t": t, "Q": inflow(t), "p": p}
