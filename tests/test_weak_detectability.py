"""Weak detectability in `bgfdi isolability`: a structural 1 whose residual a fault barely moves.

Designed truth (measured on the independent simulator of tests/independent/drive.py): a gain
fault of the drive's current sensor moves the armature-loop residual far past its threshold and
the two others about ten times under theirs, so their silence must not exonerate it. The same
holds on the hydraulic actuator for the chamber transducer (tests/test_domain_hydraulic.py: it
lights ARR1 and ARR3 and leaves ARR2 ten times under)."""
from __future__ import annotations

import json
import subprocess
import sys

from .conftest import ROOT


def _isolability(model: str) -> dict:
    out = subprocess.run([sys.executable, "-m", "fdi.app.cli", "isolability", model, "--json"], cwd=ROOT,
                         capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def test_the_current_sensor_gain_is_weak_where_the_drive_data_left_residuals_quiet():
    weak = _isolability("models/electromechanical_drive.yaml")["weakly_detectable"]
    assert set(weak["beta_i"]) == {"ARR1", "ARR3"}
    assert all(0 < x < 0.25 for x in weak["beta_i"].values())      # about ten times under


def test_the_chamber_transducer_is_weak_in_the_piston_residual():
    weak = _isolability("models/hydraulic_actuator.yaml")["weakly_detectable"]
    assert "ARR2" in weak["beta_pc"] and weak["beta_pc"]["ARR2"] < 0.1


def test_without_thresholds_the_analysis_says_why_it_is_not_made():
    result = _isolability("tests/data/rc_two_sensors.yaml")
    assert result["weakly_detectable"] == {}
    assert any("weak detectability not assessed" in n and "threshold" in n for n in result["notes"])
