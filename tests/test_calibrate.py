"""bgfdi calibrate (issue 13): thresholds from simulated nominal runs hold on the independent
reference runs: no alarm on the nominal one, every reference fault still detected."""
from __future__ import annotations

import numpy as np

from bondgraph.loader import load_model
from fdi.config import load_text
from fdi.calibrate import calibrate, nominal_residuals, with_thresholds
from fdi.data import Measurements
from fdi.app.resources import scenarios_dir
from fdi.app.scenario import load_scenario, run

from .conftest import CYCAB, DATA


def _simulated(name: str) -> Measurements:
    model = load_model(CYCAB)
    cols = run(model, load_scenario(scenarios_dir() / "suite_cycab_steering" / f"{name}.json", model))
    return Measurements(name, cols["t"], cols)


def test_thresholds_from_simulated_nominal_runs_hold_on_the_reference_data():
    runs = [_simulated(n) for n in ("nominal_a", "nominal_b", "nominal_c")]
    c = calibrate(str(CYCAB), runs)
    assert c.names == ["ARR1", "ARR2", "ARR3"] and c.units == ["N*m", "m^3/s", "N*m"]
    thresholds = np.array(c.thresholds)
    assert np.allclose(thresholds, 1.5 * np.max(c.peaks, axis=0))
    assert c.false_alarms is not None and len(c.false_alarms) == 3
    # the independent simulator's nominal run: no alarm
    assert (nominal_residuals(str(CYCAB), DATA / "nominal.csv").max(axis=1) < thresholds).all()
    # its faulty runs: each still detected (some residual crosses after the fault at 32 s)
    for name in ("scenario1", "scenario2", "scenario3"):
        r = nominal_residuals(str(CYCAB), DATA / f"{name}.csv")
        assert (r > thresholds[:, None]).any(), name


def test_thresholds_written_into_the_model_text():
    c = calibrate(str(CYCAB), [DATA / "nominal.csv"])
    assert c.false_alarms is None                                  # one run: nothing to leave out
    text = CYCAB.read_text(encoding="utf-8")
    out = with_thresholds(text, c)
    before = [ln for ln in text.splitlines() if not ln.startswith("thresholds:")]
    after = [ln for ln in out.splitlines() if not ln.startswith("thresholds:")]
    assert before == after                                         # every other line, comments included, kept
    _, config = load_text(out, "calibrated.yaml")
    assert [config.thresholds[n] for n in c.names] == [float(f"{t:.4g}") for t in c.thresholds]
