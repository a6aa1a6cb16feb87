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
