"""A storage water heater with its electrical side (a user trial, session 42): the heater's Joule
heat is a source whose value reads the measured mains voltage, U**2/Rh (simulate, verify and
diagnose ended in a traceback on it), and a relay thermostat with hysteresis switches it. Graded on
the trial's scipy plant (tests/independent/water_heater_relay.py), a designed truth.

An element fault (Rh x 1.5) that begins while the relay is off shows only once it closes: the
current's residual fires first, the thermal one later, and the later decision's fit, made afresh,
was dated at the detection with nothing said of the hours before, when nothing could show it."""
from __future__ import annotations

from pathlib import Path

import pytest

from fdi.api import Options, diagnose
from fdi.data import Measurements

from .independent import water_heater_relay as plant

MODEL = str(Path(__file__).parent / "data" / "water_heater_relay.yaml")
DRAWS = [(600.0, 600.0, 0.1), (5000.0, 300.0, 0.1)]      # a shower cools the tank: the relay closes at 692 s


def _diagnose(element):
    rows = plant.simulate(10800.0, DRAWS, element, seed=0)
    meas = Measurements("heater", rows[:, 0].copy(), {h: rows[:, i].copy() for i, h in enumerate(plant.HEAD)})
    return diagnose(MODEL, meas, Options(workers=1, seed=0)).to_dict(), rows


def test_fault_free_runs_raise_no_alarm():
    r, _ = _diagnose(None)
    assert r["detection"] is None


def test_an_element_fault_hidden_while_the_relay_is_off_is_sized_and_dated_within_its_band():
    r, rows = _diagnose((300.0, 1.5))
    closes = rows[1:, 0][(rows[1:, 3] == 1) & (rows[:-1, 3] == 0)][0]
    assert closes == pytest.approx(692.0, abs=2.0)                     # the plant's relay, after the shower
    assert r["episodes"], "the thermal residual joins later: a later decision"
    (f,) = r["diagnosis"]["faults"]
    assert f["name"] == "element" and f["type"] == "abrupt"
    assert f["value"] == pytest.approx(17.6 * 1.5, rel=0.01)
    assert f["t0"] >= closes - 5.0                                   # nothing shows it before the relay closes
    low, high = f["t0_band"]                                          # ... so the data do not tell when it began
    assert low <= 300.0 <= high
