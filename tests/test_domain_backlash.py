"""A gearbox's backlash growing with wear (my trial, session 40; tests/data/backlash_drive.yaml, plant
in tests/backlash_plant.py): the shaft's law is a dead zone, written with max and min and read at the
twist the two encoders measure. At 1 kHz the default identification window (N = 1000 samples) is one
second of a drift of 0.03 /s: the wear was typed a step by a margin of 1.021, with nothing said. The
report now says the step is barely decided while the record goes on, with the --samples that fits
all of it; with those samples the drift is found (eq. 16) and its end of life forecast."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from fdi.app.cli import main

from .backlash_plant import EOL, ONSET, RATE, record

MODEL = Path(__file__).parent / "data" / "backlash_drive.yaml"


@pytest.mark.slow
def test_backlash_growth_is_a_drift_once_the_whole_record_is_read(tmp_path, capsys):
    nominal, wear = tmp_path / "nominal.csv", tmp_path / "wear.csv"
    record(nominal)
    record(wear, wear=True)
    calibrated = tmp_path / "backlash.yaml"
    assert main(["calibrate", str(MODEL), str(nominal), "-o", str(calibrated)]) == 0
    capsys.readouterr()
    assert main(["diagnose", str(calibrated), str(wear), "--json", "--workers", "1"]) == 0
    first = json.loads(capsys.readouterr().out)
    (step,) = first["diagnosis"]["faults"]
    assert step["name"] == "d"
    if step["type"] == "abrupt":            # the short window's reading: said, with what to do
        note = first["note"]
        assert "d typed a step, barely" in note and "fits it on the whole record" in note
        samples = note.split("--samples ")[1].split()[0]
    else:
        samples = "20000"
    assert main(["diagnose", str(calibrated), str(wear), "--json", "--workers", "1", "--samples", samples]) == 0
    report = json.loads(capsys.readouterr().out)
    (drift,) = report["diagnosis"]["faults"]
    assert drift["name"] == "d" and drift["type"] == "incipient" and drift["model"] == 1
    assert drift["b"][0] == pytest.approx(RATE, rel=0.06) and drift["t0"] == pytest.approx(ONSET, abs=2.0)
    (g,) = report["prognosis"]
    assert g["eol"] == pytest.approx(EOL, abs=1.0)
