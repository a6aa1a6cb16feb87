"""A fault on a storage law's parameter in a switched model (tests/data/unverified/
accumulator_check_valve.yaml, a user trial's accumulator circuit: a gas spring charged through a
check valve, discharged through a commanded valve; its residuals are rebuilt mode by mode).

The residual must keep the rate of the stored quantity whole, d/dt[V0 (1 - (p0/pa)^(1/n))], so that
a drifting precharge p0 enters it through dp0/dt (docs/structure.md, "Storage faults"). Rebuilding
the residual mode by mode dropped that form: the precharge's drift left 1.4e-5 m^3/s in the residual
on noise-free data (55 % of its threshold) and was typed intermittent (period 4.7 s). The data
come from the trial's own simulator (tests/accumulator_plant.py: scipy, from the physics)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fdi.api import Options, diagnose
from fdi.calibrate import calibrate
from fdi.data import Measurements, commanded, signals_from_data
from fdi.monitor import compiled
from fdi.residuals import evaluate

from . import accumulator_plant as plant

MODEL = str(Path(__file__).parent / "data" / "unverified" / "accumulator_check_valve.yaml")
DRIFT = dict(target="p0", type="incipient", t0=20.0, b=-0.01)      # d p0/dt = -0.01 p0 from 20 s


def _measurements(name: str, rows: np.ndarray) -> Measurements:
    head = ["t", "Qp", "v_cmd", "pp", "pa", "Ql"]
    return Measurements(name, rows[:, 0].copy(), {h: rows[:, i].copy() for i, h in enumerate(head)})


def test_the_accumulator_balance_keeps_the_precharge_s_drift_when_rebuilt_by_mode():
    monitor = compiled(MODEL)
    names = list(monitor.names)
    residual = monitor.arr_residuals[names.index("ARR2")]
    meas = _measurements("drift", plant.simulate(T=40.0, fault=DRIFT, noise=False))
    raw = signals_from_data(monitor.model, meas)
    t = meas.t
    p0 = np.array([plant.params_at(x, DRIFT)["p0"] for x in t])       # the drift as it is: the residual vanishes
    r = evaluate(monitor.model, [residual], raw, plant.TS, window=0.3,
                 values={**commanded(monitor.model, raw), "p0": p0})[0]
    steady = (t > 21.0) & (t < 39.0) & np.isfinite(r)
    # samples away from the pump's and the valve's switches (the check valve's flow jumps there)
    switches = np.flatnonzero((np.diff(meas.columns["Qp"]) != 0) | (np.diff(meas.columns["v_cmd"]) != 0))
    for i in switches:
        steady[max(0, i - 20):i + 21] = False
    assert steady.sum() > 500
    assert np.median(np.abs(r[steady])) < 1.0e-6          # the form without d p0/dt: 1.4e-5 m^3/s


def test_a_drifting_precharge_is_typed_and_sized():
    runs = [_measurements(f"nominal{s}", plant.simulate(T=40.0, seed=s)) for s in (1, 2)]
    got = calibrate(MODEL, runs)
    thresholds = dict(zip(got.names, got.thresholds))
    drift = _measurements("drift", plant.simulate(T=40.0, seed=12, fault=DRIFT))
    d = diagnose(MODEL, drift, Options(workers=1, seed=0, thresholds=thresholds))
    (fault,) = d.faults
    assert fault.name == "p0" and fault.type == "incipient"
    assert fault.model == 1 and fault.b[0] == pytest.approx(-0.01, rel=0.05)
