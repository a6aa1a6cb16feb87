"""Commanded modes (issue 10): a mode variable that follows a data column; a valve that does not
follow its command is a mode fault (models/two_tank_commanded.yaml, designed scenarios)."""
from __future__ import annotations

import numpy as np
import pytest

from bondgraph.errors import ModelError
from bondgraph.loader import load_model, load_model_text
from fdi.data import Measurements
from fdi.api import Options, diagnose
from fdi.app.resources import scenarios_dir
from fdi.app.scenario import load_scenario, run

from .conftest import MODELS

MODEL = MODELS / "two_tank_commanded.yaml"


def _diagnose(name: str) -> dict:
    model = load_model(MODEL)
    cols = run(model, load_scenario(scenarios_dir() / "suite_two_tank_commanded" / f"{name}.json", model))
    return cols, diagnose(str(MODEL), Measurements(name, cols["t"], cols), Options(workers=2, seed=0)).to_dict()


def test_the_command_is_simulated_and_logged():
    cols, report = _diagnose("nominal")
    assert np.array_equal(cols["v_cmd"], (cols["t"] <= 300).astype(float))     # heaviside(300 - t): open, then closed
    assert report["detection"] is None                                        # residuals follow the command


def test_a_valve_stuck_open_against_its_command_is_a_mode_fault():
    _, report = _diagnose("stuck_open")
    # stuck open from 250 s: unseen while the command is open too, seen when it closes the valve at 300 s,
    # after the samples whose one-sided fits are too noisy (fdi.derivatives.edge_trim: 9 of the 51-sample
    # window, 0.9 s)
    assert 300.9 <= report["detection"]["time"] < 302
    (f,) = report["diagnosis"]["faults"]
    assert {k: f[k] for k in ("name", "type", "value")} == {"name": "v_open", "type": "mode", "value": 1}
    assert 300.0 <= f["t0"] < 302             # dated where the data first show it: the command closing ...
    low, high = f["t0_band"]                  # ... and the command held it open from the start: the data
    assert low <= 250.0 and high == f["t0"]   # cannot tell when it stuck (designed: 250 s)
    # the mode change matches the coherence vector exactly and explains the data: the parametric
    # sets that only weak entries admit are not identified (8 of them, 16 s, lost to it)
    assert report["estimators"] == []


@pytest.mark.slow
def test_a_valve_stuck_closed_against_its_command_is_a_mode_fault():
    _, report = _diagnose("stuck_closed")
    assert 150 <= report["detection"]["time"] < 152
    (f,) = report["diagnosis"]["faults"]
    assert {k: f[k] for k in ("name", "type", "value")} == {"name": "v_closed", "type": "mode", "value": 0}
    assert f["t0"] == pytest.approx(150.0, abs=2.5)           # the design's, within half the 5 s window


def test_a_command_expression_needs_its_column():
    text = MODEL.read_text(encoding="utf-8").replace("column: v_cmd, ", "")
    with pytest.raises(ModelError, match="give column"):
        load_model_text(text, "m.yaml")
    text = MODEL.read_text(encoding="utf-8").replace("column: v_cmd", "column: valve")
    with pytest.raises(ModelError, match="not among data.columns"):
        load_model_text(text, "m.yaml")
