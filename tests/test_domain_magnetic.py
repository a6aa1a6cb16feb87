"""A solenoid (tests/data/solenoid.yaml: a coil of N turns on an iron core with an air gap, its
armature held; magnetic circuits as bond graphs, MMF as effort and flux rate as flow: a domain no
shipped model covers), data from tests/independent/solenoid.py (scipy, the flux as its state).

Designed truth: the air gap grows at 1 s, its permeance 4e-7 -> 2e-7 Wb/A (the coil's inductance
0.091 -> 0.048 H; the flux is continuous, the current jumps). Found on the way: the core and the
gap written as two C elements on one 1-junction (their states are one flux) leave SCAPH a storage
in integral causality and no residual; ``bgfdi check`` now names the pair and the fix (one C whose
MMF law sums theirs), which this model takes."""
from __future__ import annotations

from functools import partial
from pathlib import Path

import pytest

from fdi.api import Options, diagnose

from .independent import by_hand, measurements, solenoid, thresholds_fixture

MODEL = str(Path(__file__).resolve().parent / "data" / "solenoid.yaml")
T0 = 1.0

_data = partial(measurements, solenoid.simulate)    # (name, seed, **the simulator's keywords)
thresholds = thresholds_fixture(MODEL, solenoid.simulate)    # two nominal runs; a third asserted quiet


def test_the_residual_is_the_coil_s_voltage_balance():
    """By hand (input and sensor factors at 1): V - Rc i - N^2 Pc Pg / (Pc + Pg) di/dt, up to its sign."""
    import sympy as sp

    from bondgraph.model import t
    from fdi.monitor import compiled
    (arr,) = compiled(MODEL).arrs
    expr, syms, fn = by_hand(arr.expr)
    Rc, N, Pc, Pg = (syms[n] for n in ("Rc", "N", "Pc", "Pg"))
    hand = fn["V"] - Rc * fn["i"] - N ** 2 * Pc * Pg / (Pc + Pg) * sp.diff(fn["i"], t)
    assert sp.simplify(expr - hand) == 0 or sp.simplify(expr + hand) == 0


def test_core_and_gap_as_two_capacitors_are_refused_with_the_fix(tmp_path):
    """The same circuit with the core and the gap as two C on a 1-junction: the check names the pair
    and says to write one C whose MMF law sums theirs."""
    from bondgraph.causality import assign
    from bondgraph.loader import load_model
    text = Path(MODEL).read_text().replace(
        '  circuit: {type: C, effort: "q/Pc + q/Pg", description: "core and air gap in series: MMF = flux (1/Pc + 1/Pg)"}',
        "  core: {type: C, parameter: Pc}\n  gap_c: {type: C, parameter: Pg}").replace(
        "  4: [coil, circuit]", "  4: [coil, M]\n  5: [M, core]\n  6: [M, gap_c]").replace(
        '  E: {type: "1", description: coil current}', '  E: {type: "1", description: coil current}\n  M: {type: "1"}')
    path = tmp_path / "two_capacitors.yaml"
    path.write_text(text)
    (problem,) = [p for p in assign(load_model(path), "diagnosis").problems if "forced into" in p]
    assert "gap_c (C) is forced into integral causality" in problem
    assert "follows core's: both on M" in problem and "write them as one C whose effort law in q sums theirs" in problem


def test_a_grown_air_gap_is_found_and_sized(thresholds):
    report = diagnose(MODEL, _data("gap", 4, t0=T0, pg=2.0e-7),
                      Options(workers=1, seed=0, thresholds=thresholds)).to_dict()
    assert T0 - 0.01 <= report["detection"]["time"] <= T0 + 0.05    # the 10 ms window's half early at most
    (found,) = report["diagnosis"]["faults"]
    assert (found["name"], found["type"]) == ("gap", "abrupt")
    assert found["value"] == pytest.approx(2.0e-7, rel=0.01)
