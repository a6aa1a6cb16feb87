"""The boost converter (models/boost_converter.yaml) diagnosed as the other domains are: thresholds
from `calibrate` on two nominal runs, no alarm on a third, and each designed fault detected,
isolated, typed and sized, at 1 MHz sampling with 20 kHz PWM, no rescaling of time.

Data: the converter integrated from its circuit equations by scipy (tests/independent/boost.py),
10 ms from a running state, 10 mA / 10 mV of sensor noise; faults from t = 5 ms."""
from __future__ import annotations

import numpy as np
import pytest

from fdi.calibrate import calibrate
from fdi.data import Measurements
from fdi.api import Options, diagnose

from .conftest import ROOT
from .independent import boost

MODEL = str(ROOT / "models" / "boost_converter.yaml")
T0 = 0.005


def run(seed: int, **fault) -> Measurements:
    d = boost.simulate(0.01, noise=0.01, seed=seed, x0=(8.0, 22.0), **fault)
    return Measurements(f"run{seed}", d["t"], d)


@pytest.fixture(scope="module")
def thresholds() -> dict[str, float]:
    cal = calibrate(MODEL, [run(1), run(2)])
    return dict(zip(("ARR1", "ARR2"), (float(x) for x in cal.thresholds)))


def test_no_alarm_on_a_held_out_nominal_run(thresholds):
    report = diagnose(MODEL, run(3), Options(workers=1, seed=0, thresholds=thresholds)).to_dict()
    assert report["detection"] is None


@pytest.mark.parametrize("fault, true, data", [
    ("rL", 0.5, {"changes": {"rL": (T0, 0.5)}}),             # a hot, loosened inductor connection
    ("Co", 0.5e-4, {"changes": {"Co": (T0, 0.5e-4)}}),       # half the output capacitance lost
    ("Rload", 5.0, {"changes": {"Rload": (T0, 5.0)}}),       # the load doubled
    ("beta_iL", 0.9, {"gains": {"iL": (T0, 0.9)}}),          # the current-sense gain 10 % low
])
def test_each_designed_fault_is_found_typed_and_sized(thresholds, fault, true, data):
    report = diagnose(MODEL, run(4, **data), Options(workers=1, seed=0, thresholds=thresholds)).to_dict()
    assert T0 - 1e-5 <= report["detection"]["time"] <= T0 + 2e-4
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"]) == (fault, "abrupt")
    assert found["value"] == pytest.approx(true, rel=0.05)


def test_switching_faster_than_the_derivative_window_is_said_not_silent():
    """A 20 kHz PWM leaves 25 us between switches; with a 40 us window no residual has a sample,
    and the record is refused saying so and what to change, instead of 'nothing detected' (which
    read as healthy: exit 0, --fail-on-fault passed)."""
    from fdi.config import load
    from fdi.data import DataError
    _, config = load(MODEL)
    with pytest.raises(DataError, match=r"no residual has a sample to judge, .*had no sample: .*derivative_window"):
        diagnose(MODEL, run(5), Options(workers=1, seed=0, thresholds={"ARR1": 1.5, "ARR2": 1.4},
                                        settings=config.replace(derivative_window=4e-5)))
