"""A system no shipped model covers: two rooms as a thermal pseudo bond graph (effort: temperature
in K, flow: heat flow in W; their product is no power), tests/data/two_rooms.yaml. References: the
heat balances of each room (Karnopp, Margolis & Rosenberg, ch. 12), the unit of a heat balance
(W), nominal runs that must raise no alarm, and a designed wall fault."""
from __future__ import annotations

import sympy as sp

from fdi.arrs import arr_unit, select_arrs
from fdi.config import load
from fdi.data import Measurements
from fdi.api import Options, diagnose
from fdi.app.scenario import parse_scenario, run

from .conftest import ROOT

MODEL = ROOT / "tests" / "data" / "two_rooms.yaml"


def _run(scenario: dict, name: str) -> dict:
    model, _ = load(MODEL)
    cols = run(model, parse_scenario(scenario, model, name))
    return diagnose(str(MODEL), Measurements(name, cols["t"], cols), Options(workers=1, seed=0)).to_dict()


def test_the_residuals_are_the_heat_balances_in_watts():
    model, _ = load(MODEL)
    arrs = {a.name: a for a in select_arrs(model).arrs}
    signals = {f.func.__name__: f for a in arrs.values() for f in a.expr.atoms(sp.core.function.AppliedUndef)}
    T1, T2, q = signals["T1"], signals["T2"], signals["q"]                # signals as functions of time
    t = T1.args[0]
    C1, C2, R12, R2 = (model.symbols[n] for n in ("C1", "C2", "R12", "R2"))
    b1, b2, bq = (model.symbols[n] for n in ("beta_T1", "beta_T2", "beta_q"))
    x1, x2 = T1 / b1, T2 / b2                              # the temperatures, each sensor's gain removed
    room1 = bq * q - C1 * sp.diff(x1, t) - (x1 - x2) / R12
    room2 = (x1 - x2) / R12 - C2 * sp.diff(x2, t) - x2 / R2
    assert sp.simplify(arrs["ARR1"].expr - room1) == 0
    assert sp.simplify(arrs["ARR2"].expr - room2) == 0
    assert sp.simplify(arrs["ARR3"].expr - (room1 + room2)) == 0          # the whole house
    assert {arr_unit(model, a) for a in arrs.values()} == {"W"}          # not W/K: e*f is no power here


def test_the_filter_edge_of_a_long_derivative_window_raises_no_alarm():
    # seeds whose first 15 s (half the 31 s window) exceed the thresholds: 956 W for 580 (seed 8)
    for seed in (8, 9):
        report = _run({"seed": seed, "T": 600, "fs": 1, "faults": []}, f"nominal{seed}")
        assert report["detection"] is None, seed


def test_a_wall_losing_its_insulation_is_found_and_sized():
    report = _run({"seed": 7, "T": 3600, "fs": 1,
                   "faults": [{"target": "wall_insulation", "type": "abrupt", "t0": 1500, "value": 0.004}]}, "wall")
    assert 1500 <= report["detection"]["time"] <= 1510
    (fault,) = report["diagnosis"]["faults"]
    assert (fault["name"], fault["type"]) == ("wall_insulation", "abrupt")
    assert abs(fault["value"] - 0.004) <= 0.05 * 0.004
