"""An engine cooling circuit, a thermal pseudo bond graph (a user trial's model and plant).

Temperature is the effort (K), heat flow the flow (W): the engine block's and the radiator's heat
capacities, a wax thermostat opening the radiator branch above 85 degC (an autonomous mode), a
fan the ECU switches with hysteresis (a commanded mode), the radiator's conductance to ambient.
Data from the trial's plant, simulated apart from bgfdi (tests/cooling_plant.py); thresholds and
the derivative window from ``bgfdi calibrate --window auto`` on three of its fault-free runs.

A fan that dies while commanded on halves the radiator's conductance. The fan's switching on
40 s earlier put two residuals above their thresholds for 4 s, unconfirmed; the failure's
excursion confirmed 19 s of quiet later, inside the evidence span, so t_D is the switch's
excursion, and every onset searched ended half a window after it: the fault mode fitted from
579 s worse than a radiator fouling drift that "reached its failure value" (a user would have
replaced a clean radiator). The onsets now reach half a window past the confirming excursion
(fdi.detect.excursion_start).
"""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from fdi.api import diagnose
from fdi.options import Options

from . import cooling_plant as plant

MODEL = Path(__file__).parent / "data" / "engine_cooling.yaml"


@pytest.mark.slow
def test_a_fan_that_dies_while_commanded_on_is_the_fan_from_its_failure(tmp_path):
    path = tmp_path / "fan_dead.csv"
    t, cmd = plant.run(str(path), seed=14, T=800.0, fan_dead=600.0)
    assert cmd[(t >= 560.0) & (t <= 700.0)].all()           # commanded on from before the failure to past the window
    d = diagnose(str(MODEL), str(path), Options(workers=1))
    assert d.detection is not None and d.detection.time < 580.0    # t_D: the switch's excursion (the test's point)
    (fault,) = d.faults
    assert fault.name == "fan_dead" and 599.0 <= fault.t0 <= 601.5, d.faults


def test_calibrating_at_the_rules_window_says_how_large_a_change_each_fault_needs(tmp_path):
    """The rule's window (half the fastest time constant: the radiator's, 2.2 s) differentiates the
    engine's 45 kJ/K heat capacity over 23 noisy samples; its thresholds are tens of kW and the
    pump's wear needs a change over 10 % to be seen, which a calibration at it did not say (a user
    trial: 28.8 kW, three quarters of the engine's heat). It says so now, with --window auto's
    score of the same window, and names the option."""
    from fdi.calibrate import calibrate, format_calibration

    runs = []
    for seed in (1, 2):
        path = tmp_path / f"nominal{seed}.csv"
        plant.run(str(path), seed=seed, T=600.0)
        runs.append(str(path))
    text = re.sub(r"^(thresholds|diagnosis):.*\n", "", MODEL.read_text(encoding="utf-8"), flags=re.M)
    model = tmp_path / "cooling.yaml"                   # the model as written, before its calibration
    model.write_text(text, encoding="utf-8")
    at_rule = calibrate(str(model), runs)
    auto = calibrate(str(model), runs, window="auto")
    (rule,) = at_rule.window_scores
    assert rule.rule and rule.detectable == auto.window_scores[0].detectable       # the same score as auto's
    assert max(rule.detectable.values()) > 0.10
    report = format_calibration(at_rule)
    assert "at it a fault is detected from a change of" in report and "calibrate --window auto" in report
    assert auto.window > at_rule.window and min(s.score for s in auto.window_scores) < rule.score / 2
