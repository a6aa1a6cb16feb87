"""Modulated elements: a C whose law depends on a measured state (a hydraulic chamber whose volume
follows its piston, tests/data/modulated_chamber.yaml). Its ARR must carry the rate of the volume
(dq/dt = V p'/beta_e + A x' p/beta_e), and bgfdi must simulate it.

References: the continuity equation of a moving volume (Merritt 1967, eq. 3-28), written here by
hand, and the chamber integrated from it by scipy, apart from bgfdi."""
from __future__ import annotations

import numpy as np
import sympy as sp
from scipy.integrate import solve_ivp

from bondgraph.loader import load_model
from bondgraph.simulation import simulate as bg_simulate
from fdi.arrs import select_arrs
from fdi.residuals import compile_residuals, evaluate

from .conftest import ROOT

MODEL = ROOT / "tests" / "data" / "modulated_chamber.yaml"
P = {"beta_e": 1.0e9, "V0": 1.0e-4, "A": 1.0e-3, "m": 5.0, "b": 500.0, "Rl": 1.0e12}
TS = 0.001


def pump(t):
    return 1.0e-5 * np.sin(2 * t)


def independent(T: float) -> dict[str, np.ndarray]:
    """p' = (beta_e (Q - p/Rl - A v) - p A v) / (V0 + A x), m v' = A p - b v, x' = v."""
    def rhs(t, y):
        p, v, x = y
        volume = P["V0"] + P["A"] * x
        return [(P["beta_e"] * (pump(t) - p / P["Rl"] - P["A"] * v) - p * P["A"] * v) / volume,
                (P["A"] * p - P["b"] * v) / P["m"], v]
    t = np.arange(0.0, T + TS / 2, TS)
    sol = solve_ivp(rhs, (0.0, T), [0.0, 0.0, 0.0], t_eval=t, method="Radau", rtol=1e-11, atol=[1e-6, 1e-14, 1e-14])
    return {"t": t, "Q": pump(t), "p": sol.y[0], "x": sol.y[2]}


def test_the_chamber_balance_carries_the_rate_of_its_volume():
    m = load_model(MODEL)
    arr = next(a for a in select_arrs(m).arrs if a.sensor == "p")
    f = {g.func.__name__: g for g in arr.expr.atoms(sp.core.function.AppliedUndef)}
    t = f["p"].args[0]
    s = m.symbols
    p, x, q = f["p"] / s["beta_p"], f["x"] / s["beta_x"], f["Q"] * s["beta_Q"]
    stored = p * (s["V0"] + s["A"] * x) / s["beta_e"]
    hand = q - p / s["Rl"] - s["A"] * sp.diff(x, t) - sp.diff(stored, t)
    assert sp.simplify(arr.expr - hand) == 0


def test_residuals_vanish_on_the_independent_simulation_and_bgfdi_simulates_the_same():
    m = load_model(MODEL)
    data = independent(5.0)
    kernels = compile_residuals(m, list(select_arrs(m).arrs))
    r = evaluate(m, kernels, data, TS, window=0.02)[:, 50:-50]
    # flows of 1e-5 m^3/s and forces of some N: what is left is the derivative filter's bias
    assert np.max(np.abs(r[0])) < 1e-4 * 1.0e-5 and np.max(np.abs(r[1])) < 1e-3
    nominal = {k.name: float(v) for k, v in m.nominal_values().items()}
    traj = bg_simulate(m, data["t"], values=lambda tt: nominal)
    assert np.max(np.abs(traj.signals["p"] - data["p"])) < 1e-3 * np.max(np.abs(data["p"]))
    assert np.max(np.abs(traj.signals["x"] - data["x"])) < 1e-3 * np.max(np.abs(data["x"]))
