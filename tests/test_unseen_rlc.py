"""A system no shipped model covers: an electrical circuit (a supply V through R1 and L into a
capacitor C with a load R2 across it; current i and capacitor voltage uc measured),
tests/data/rlc_load.yaml. References: Kirchhoff's laws of the circuit, and a designed intermittent
load (R2 halved during the first half of every 1.7 s period from 10 s), whose narrow period basin
is what the racing engine's family protection and revival are for."""
from __future__ import annotations

import sympy as sp

from fdi.arrs import arr_unit, select_arrs
from fdi.config import load
from fdi.data import Measurements
from fdi.api import Options, diagnose
from fdi.app.scenario import parse_scenario, run

from .conftest import ROOT

MODEL = ROOT / "tests" / "data" / "rlc_load.yaml"


def test_the_residuals_are_kirchhoffs_laws():
    model, _ = load(MODEL)
    arrs = {a.name: a for a in select_arrs(model).arrs}
    signals = {f.func.__name__: f for a in arrs.values() for f in a.expr.atoms(sp.core.function.AppliedUndef)}
    i, uc, v = signals["i"], signals["uc"], signals["V"]
    t = i.args[0]
    R1, L, C, R2 = (model.symbols[n] for n in ("R1", "L", "C", "R2"))
    bi, bu, bv = (model.symbols[n] for n in ("beta_i", "beta_uc", "beta_V"))
    current, voltage = i / bi, uc / bu
    loop = bv * v - R1 * current - L * sp.diff(current, t) - voltage      # voltage law round the series loop
    node = current - C * sp.diff(voltage, t) - voltage / R2                # current law at the capacitor
    assert sp.simplify(arrs["ARR1"].expr - loop) == 0
    assert sp.simplify(arrs["ARR2"].expr - node) == 0
    assert (arr_unit(model, arrs["ARR1"]), arr_unit(model, arrs["ARR2"])) == ("V", "A")


def test_an_intermittent_load_is_found_typed_and_sized():
    model, _ = load(MODEL)
    design = {"seed": 5, "T": 20, "fs": 1000,
              "faults": [{"target": "R2", "type": "intermittent", "t0": 10, "value": 5.0, "period": 1.7}]}
    cols = run(model, parse_scenario(design, model, "load"))
    report = diagnose(str(MODEL), Measurements("load", cols["t"], cols), Options(workers=1, seed=0)).to_dict()
    assert 10.0 - 0.025 <= report["detection"]["time"] <= 10.1      # half the 0.05 s window early at most
    (fault,) = report["diagnosis"]["faults"]
    assert (fault["name"], fault["type"]) == ("R2", "intermittent")
    assert abs(fault["value"] - 5.0) <= 0.02 * 5.0 and abs(fault["period"] - 1.7) <= 0.02 * 1.7
