"""The variable-volume actuator (models/variable_volume_actuator.yaml), whose chamber capacitance
is modulated by the measured piston position, diagnosed as the other domains are: thresholds from
`calibrate` on two nominal runs, no alarm on a third, the designed faults detected, isolated,
typed and sized within 5 %, and the pump's wear (an incipient fault) with its RUL within 12.5 %.

Data: the actuator integrated from its equations by scipy (tests/independent/chamber.py); faults
from t = 6 s (the pump's wear from 4 s), 50 Pa and 1 um of sensor noise."""
from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

from bondgraph.loader import load_model
from fdi.arrs import select_arrs
from fdi.calibrate import calibrate
from fdi.data import Measurements
from fdi.api import Options, diagnose

from .conftest import ROOT
from .independent import chamber

MODEL = str(ROOT / "models" / "variable_volume_actuator.yaml")


def run(seed: int, **fault) -> Measurements:
    d = chamber.simulate(12.0, seed, **fault)
    return Measurements(f"run{seed}", d["t"], d)


@pytest.fixture(scope="module")
def thresholds() -> dict[str, float]:
    cal = calibrate(MODEL, [run(1), run(2)])
    return dict(zip(("ARR1", "ARR2"), (float(x) for x in cal.thresholds)))


def test_the_chamber_balance_carries_the_rate_of_its_volume():
    m = load_model(MODEL)
    (arr,) = [a for a in select_arrs(m).arrs if "Q" in {g.func.__name__ for g in a.expr.atoms(sp.core.function.AppliedUndef)}]
    f = {g.func.__name__: g for g in arr.expr.atoms(sp.core.function.AppliedUndef)}
    t = f["p"].args[0]
    s = m.symbols
    p, x, q = f["p"] / s["beta_p"], f["x"] / s["beta_x"], f["Q"] * s["beta_Q"]
    stored = p * (s["V0"] + s["A"] * x) / s["beta_e"]
    assert sp.simplify(arr.expr - (q - p / s["Rl"] - s["A"] * sp.diff(x, t) - sp.diff(stored, t))) == 0


def test_no_alarm_on_a_held_out_nominal_run(thresholds):
    assert diagnose(MODEL, run(3), Options(workers=1, seed=0, thresholds=thresholds)).to_dict()["detection"] is None


@pytest.mark.parametrize("fault, true, data", [
    ("b", 800.0, {"changes": {"b": (6.0, 800.0)}}),            # friction up 60 %
    ("beta_p", 0.9, {"p_gain": (6.0, 0.9)}),                   # the pressure transducer reads 10 % low
])
def test_abrupt_faults_are_found_and_sized(thresholds, fault, true, data):
    report = diagnose(MODEL, run(4, **data), Options(workers=1, seed=0, thresholds=thresholds, max_set=1)).to_dict()
    assert 6.0 - 0.05 <= report["detection"]["time"] <= 6.2
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"]) == (fault, "abrupt")
    assert found["value"] == pytest.approx(true, rel=0.05)


def test_the_pumps_wear_is_incipient_and_its_rul_is_predicted(thresholds):
    rate, onset, failure = -0.05, 4.0, 0.7
    report = diagnose(MODEL, run(4, pump_rate=(onset, rate)),
                             Options(workers=1, seed=0, thresholds=thresholds, max_set=1)).to_dict()
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"], found["model"]) == ("beta_Q", "incipient", 1)
    assert found["b"][0] == pytest.approx(rate, rel=0.05)
    (life,) = report["prognosis"]
    eol = onset + math.log(failure) / rate                     # beta_Q = exp(rate (t - onset)) reaches 0.7
    assert life["rul"] == pytest.approx(eol - life["at"], rel=0.125)
    assert np.isfinite(life["rul_low"]) and life["rul_low"] <= life["rul"] <= life["rul_high"]
