"""A storage fault, consistent between simulation and residuals: a tank narrowed to half its
cross-section (half its capacitance) at t0 is identified from simulated data. The simulator keeps
the stored volume q continuous (the pressure jumps); the residual differentiates q = A2 p2/(rho g)
as a whole, so the dC/dt * e term is there (designed truth: the scenario's value)."""
from __future__ import annotations

from pathlib import Path

import pytest

from bondgraph.loader import load_model
from fdi.arrs import select_arrs
from fdi.api import Options, diagnose
from fdi.app.scenario import parse_scenario, run, to_csv

from .conftest import MODELS


def _variant(tmp_path: Path) -> Path:
    text = (MODELS / "two_tank_valve.yaml").read_text()
    text = text.replace("  v:        {kind: mode,",
                        "  A2:       {kind: parametric, parameters: [A2], description: tank 2 narrowed}\n"
                        "  v:        {kind: mode,")
    text = text.replace("derivative_window: 5.0", "derivative_window: 1.0").replace("noise: 20.0", "noise: 2.0")
    path = tmp_path / "tanks.yaml"
    path.write_text(text)
    return path


def test_halved_tank_capacitance_is_identified_within_5_percent(tmp_path):
    path = _variant(tmp_path)
    model = load_model(path)
    arrs = select_arrs(model).arrs
    assert all(a.exact is not None for a in arrs if a.expr.has(model.symbols["A2"]))
    truth = 0.0154 / 2
    cols = run(model, parse_scenario({"T": 600, "fs": 10, "seed": 1, "faults": [
        {"target": "A2", "type": "abrupt", "t0": 300, "value": truth}]}, model, "halved"))
    data = tmp_path / "halved.csv"
    data.write_text(to_csv(cols))
    report = diagnose(path, data, Options(pop=40, generations=60)).to_dict()
    (fault,) = report["diagnosis"]["faults"]
    assert fault["name"] == "A2" and fault["type"] == "abrupt"
    assert fault["value"] == pytest.approx(truth, rel=0.05)
