"""A gearbox's backlash growing with wear (my trial, session 40; tests/data/backlash_drive.yaml, plant
in tests/backlash_plant.py): the shaft's law is a dead zone, written with max and min and read at the
twist the two encoders measure. At 1 kHz the default identification window (N = 1000 samples) is one
second of a drift of 0.03 /s: the wear was typed a step by a margin of 1.021, with nothing said; then
the report said the step was barely decided and gave the --samples that fits the whole record. Now
the step's fit stops explaining the data 12 s later (a lack of fit, fdi.pipeline.misfit_at) and is
decided again on the data from t_D: the drift (eq. 16) and its end of life, in one diagnosis."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from fdi.app.cli import main

from .backlash_plant import EOL, ONSET, RATE, record

MODEL = Path(__file__).parent / "data" / "backlash_drive.yaml"


@pytest.mark.slow
def test_backlash_growth_typed_a_step_on_one_window_is_decided_again_as_a_drift(tmp_path, capsys):
    nominal, wear = tmp_path / "nominal.csv", tmp_path / "wear.csv"
    record(nominal)
    record(wear, wear=True)
    calibrated = tmp_path / "backlash.yaml"
    assert main(["calibrate", str(MODEL), str(nominal), "-o", str(calibrated)]) == 0
    capsys.readouterr()
    assert main(["diagnose", str(calibrated), str(wear), "--json", "--workers", "1"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert [e["cause"] for e in report["episodes"]] == ["misfit"]
    assert report["episodes"][0]["previous"][0]["type"] == "abrupt"        # the first window's step
    (drift,) = report["diagnosis"]["faults"]
    assert drift["name"] == "d" and drift["type"] == "incipient" and drift["model"] == 1
    assert drift["b"][0] == pytest.approx(RATE, rel=0.06) and drift["t0"] == pytest.approx(ONSET, abs=2.0)
    (g,) = report["prognosis"]
    assert g["eol"] == pytest.approx(EOL, abs=1.0)
    assert g["rul_low"] <= EOL - g["at"] <= g["rul_high"]
    assert "fits it on the whole record" in report["note"]       # a band this wide: what the record's rest would add
