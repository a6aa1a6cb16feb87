"""Residual noise predicted from the sensors' declared noise, mode by mode (fdi.noise), against the
hand-derived propagation through the circuit's laws and scipy's Savitzky-Golay coefficients.

The EV precharge circuit (tests/data/ev_precharge.yaml; Hauser & Kuhn, ch. 11): with the
precharge contactor closed and the main one open, the loop residual is Vb - Rp ib - vdc (Kirchhoff's
voltage law round the precharge branch), so its noise is the smoothing filter's gain times
sqrt((Rp sigma_ib)^2 + sigma_vdc^2); with the main contactor closed, the link balance reads the
contactor's current as (Vb - vdc)/Rm, so its noise is about the gain times sigma_vdc / Rm: 2 mOhm
turns the link voltage's 0.2 V into tens of amperes, where the precharge mode reads ib's 0.3 A.
"""
from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from scipy.signal import savgol_coeffs

from bondgraph.loader import load_model
from fdi.arrs import select_arrs
from fdi.derivatives import DEFAULT_ORDER
from fdi.noise import SPREAD, noise_notes, predicted_noise
from fdi.residuals import compile_residuals, numeric_form

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "tests" / "data" / "ev_precharge.yaml"
TS, WINDOW, SAMPLES = 1e-3, 9e-3, 9          # the file's sampling time; a 9-sample derivative window


@pytest.fixture(scope="module")
def precharge():
    model = load_model(str(MODEL))
    arrs = list(select_arrs(model).arrs)
    return model, arrs, predicted_noise(model, compile_residuals(model, arrs), WINDOW, TS)


def _in_mode(model, arr, mode):
    return sp.expand(numeric_form(model, arr.expr).xreplace({model.symbols[k]: v for k, v in mode.items()}))


def _plain(expr):
    """The expression with each signal x(t) a plain symbol x (no derivative may be left)."""
    assert not expr.atoms(sp.Derivative)
    return expr.xreplace({f: sp.Symbol(f.func.__name__, real=True) for f in expr.atoms(sp.core.function.AppliedUndef)})


def _row(pred, name, mode):
    return next(x for x in pred[name] if dict(x.mode) == mode)


def test_loop_residual_noise_is_kirchhoffs_propagation(precharge):
    model, arrs, pred = precharge
    mode = {"p": 1, "m": 0, "d": 0}
    Vb, vdc, ib = (sp.Symbol(n, real=True) for n in ("Vb", "vdc", "ib"))
    Rp = model.symbols["Rp"]
    loop = next(a for a in arrs if _in_mode(model, a, mode).has(Rp))
    form = _plain(_in_mode(model, loop, mode))
    assert sp.simplify(form - (Vb - Rp * ib - vdc)) == 0 or sp.simplify(form + (Vb - Rp * ib - vdc)) == 0
    gain = np.linalg.norm(savgol_coeffs(SAMPLES, DEFAULT_ORDER, deriv=0))     # the smoothed samples' noise gain
    s_ib, s_vdc = model.sensors["ib"].noise["ib"], model.sensors["vdc"].noise["vdc"]
    rp = model.parameters["Rp"].value
    expected = gain * math.hypot(rp * s_ib, s_vdc)
    row = _row(pred, loop.name, mode)
    assert row.std == pytest.approx(expected, rel=0.08)
    assert row.shares["ib"] == pytest.approx((rp * s_ib) ** 2 / ((rp * s_ib) ** 2 + s_vdc ** 2), abs=0.01)


def test_link_balance_reads_the_contactor_current_through_its_resistance(precharge):
    model, arrs, pred = precharge
    closed, precharging = {"p": 0, "m": 1, "d": 0}, {"p": 1, "m": 0, "d": 0}
    C = model.symbols["C"]
    link = next(a for a in arrs if _in_mode(model, a, closed).has(C))
    gain = np.linalg.norm(savgol_coeffs(SAMPLES, DEFAULT_ORDER, deriv=0))
    s_vdc, rm = model.sensors["vdc"].noise["vdc"], model.parameters["Rm"].value
    noisy = _row(pred, link.name, closed)
    assert noisy.std == pytest.approx(gain * s_vdc / rm, rel=0.08)      # (Vb - vdc)/Rm: the derivative terms are C-small
    assert noisy.shares["vdc"] > 0.99
    quiet = _row(pred, link.name, precharging)
    assert noisy.std / quiet.std > 100                  # ib's 0.3 A (smoothed) where the precharge branch carries it
    notes = noise_notes(model, arrs, pred, WINDOW)
    mine = [n for n in notes if n.startswith(f"{link.name}'s noise")]
    assert mine and "(vdc 100 %)" in mine[0] and "p=0 m=1" in mine[0]


def test_a_model_without_modes_or_declared_noise_gets_no_note():
    model = load_model(str(ROOT / "models" / "two_mass_spring_damper.yaml"))
    arrs = list(select_arrs(model).arrs)
    pred = predicted_noise(model, compile_residuals(model, arrs), 0.05, 1e-3)
    assert all(len(rows) == 1 for rows in pred.values())       # one operating mode
    assert noise_notes(model, arrs, pred, 0.05) == []
    assert SPREAD >= 10


def test_check_prints_and_serialises_the_prediction():
    run = subprocess.run([sys.executable, "-m", "fdi", "check", "--json", str(MODEL)], capture_output=True,
                         text=True, cwd=ROOT, timeout=120)
    assert run.returncode == 0, run.stderr
    noise = json.loads(run.stdout)["residuals"]["noise"]
    assert noise["derivative_window"] > 0
    rows = [r for rows in noise["by_residual"].values() for r in rows]
    assert len(rows) == 2 * 8 and all(r["std"] is None or r["std"] >= 0 for r in rows)
    text = subprocess.run([sys.executable, "-m", "fdi", "check", str(MODEL)], capture_output=True, text=True,
                          cwd=ROOT, timeout=120).stdout
    assert "noise predicted from the sensors' declared noise" in text


# ---------------------------------------------------------------- calibrate: runs against the prediction
RC = ROOT / "tests" / "data" / "rc_two_sensors.yaml"


def _rc_run(seed: int, rl_true: float = 200.0, seconds: float = 6.0):
    """The RC circuit with its load (u -> R -> node with C and RL; i through R, v across C) from
    Kirchhoff's laws, integrated by scipy (tight tolerances) and sampled at 1 kHz, with the file's
    sensor noise (i: 1e-5 A, v: 1e-3 V); ``rl_true``: the load the plant really has."""
    from scipy.integrate import solve_ivp

    from fdi.data import Measurements
    R, C = 100.0, 1.0e-3
    t = np.arange(0.0, seconds, 1e-3)

    def u(x):
        return 5 + 2 * np.sin(3 * x)
    sol = solve_ivp(lambda x, v: [((u(x) - v[0]) / R - v[0] / rl_true) / C], (0, t[-1]), [5 * rl_true / (R + rl_true)],
                    t_eval=t, rtol=1e-11, atol=1e-13, method="LSODA")
    v = sol.y[0]
    rng = np.random.default_rng(seed)
    i = (u(t) - v) / R
    return Measurements(f"rc-{seed}.csv", t, {"t": t, "u": u(t), "i": i + 1e-5 * rng.standard_normal(t.size),
                                               "v": v + 1e-3 * rng.standard_normal(t.size)})


def test_calibrate_finds_the_runs_noise_as_declared():
    from fdi.calibrate import calibrate, format_calibration
    c = calibrate(str(RC), [_rc_run(seed) for seed in (1, 2, 3)])
    assert {x["residual"] for x in c.noise} == {"ARR1", "ARR2"}
    for x in c.noise:      # the runs' noise is the file's: level and prediction agree
        assert 0.7 < x["level"] / x["predicted"] < 1.4, x
    assert "sensors' declared noise explains" not in format_calibration(c)


def test_calibrate_names_the_residual_the_model_does_not_explain():
    """The plant's load is 180 Ohm where the file says 200: the node balance ARR2 (i - C v' - v/RL)
    carries v (1/180 - 1/200), about 2 mA, tens of times what noise explains; the loop ARR1
    (u - R i - v) does not contain RL and stays at its noise."""
    from fdi.calibrate import calibrate, format_calibration
    c = calibrate(str(RC), [_rc_run(seed, rl_true=180.0) for seed in (1, 2)])
    ratio = {x["residual"]: x["level"] / x["predicted"] for x in c.noise}
    assert ratio["ARR1"] < 1.4 and ratio["ARR2"] > 20
    notes = [line for line in format_calibration(c).splitlines() if "declared noise explains" in line]
    assert len(notes) == 1 and notes[0].startswith("note: ARR2 varies")
