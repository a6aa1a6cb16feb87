"""Two compressed-air vessels (tests/data/air_vessels.yaml, a domain no shipped model covers), data
from tests/independent/air_vessels.py (scipy, the mass balances typed by hand, apart from bgfdi).

What it guards: a storage fault's stored quantity, C2 p2, is formed from the measured pressure (the
mass is continuous, the pressure jumps). Formed from the smoothed pressure, the rate's filter in series
with the smoothing saw the fault a whole 20 s window early (detection at 580 s for 600 s) and the
intrusion came out 6 % off (8.83e-8 kg/Pa for 8.33e-8); now half a window early and within 1 %."""
from __future__ import annotations

from functools import partial

import pytest

from fdi.api import Options, diagnose

from .independent import air_vessels, measurements, thresholds_fixture

MODEL = str(__import__("pathlib").Path(__file__).resolve().parent / "data" / "air_vessels.yaml")

_data = partial(measurements, air_vessels.simulate)    # (name, seed, **the simulator's keywords)
thresholds = thresholds_fixture(MODEL, air_vessels.simulate)    # two nominal runs; a third asserted quiet


def test_a_bladder_intrusion_is_found_with_its_size(thresholds):
    report = diagnose(MODEL, _data("intrusion", 4, t0=600.0, factor=0.7),
                      Options(workers=1, seed=0, thresholds=thresholds)).to_dict()
    assert 589.0 <= report["detection"]["time"] <= 600.0       # half the 20 s derivative window early at most
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"]) == ("intrusion", "abrupt")
    assert found["value"] == pytest.approx(0.7 * air_vessels.C0, rel=0.01)
    assert found["t0"] == pytest.approx(600.0, abs=2.0)
