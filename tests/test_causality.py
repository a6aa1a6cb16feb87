"""SCAPH / SCAP on every shipped model, and the reporting of conflicts and loops."""
from __future__ import annotations

import pytest

from bondgraph.causality import DIAGNOSIS, SIMULATION, assign
from bondgraph.graph import to_networkx
from bondgraph.loader import load_model, load_model_text
from fdi.app.cli import main

from .conftest import SHIPPED
from .test_loader import BASE


SCAPH_CLEAN = [p for p in SHIPPED if p.stem in ("cycab_steering", "two_tank_valve", "dc_motor_clutch")]


@pytest.mark.parametrize("path", SCAPH_CLEAN, ids=lambda p: p.stem)
def test_diagnostic_causality_of_every_shipped_model(path):
    m = load_model(path)
    c = assign(m, DIAGNOSIS)
    assert c.ok, (c.problems, c.loops)
    assert set(c.storage) == {e.name for e in m.elements.values() if e.kind in ("C", "I")}
    assert all(v == "derivative" for v in c.storage.values())
    assert len(c.modes_checked) == 2 ** len(m.modes)
    # every bond and sensor bond has a causal stroke, every junction exactly one strong bond
    assert set(c.effort_to) == {b.id for b in m.bonds} | set(m.sensors)
    assert set(c.strong) == set(m.junctions)


def test_cycab_strong_bonds_follow_the_paper(cycab):
    c = assign(cycab, DIAGNOSIS)
    # sensors impose their variable on their junctions (inverted causality)
    assert c.strong["J_13"] == "theta1" and c.strong["J_01"] == "dp" and c.strong["J_15"] == "theta2"
    # the causal paths of eqs. (3), (4), (7), (12)
    assert c.strong["J_motor"] == 9 and c.strong["J_pump"] == 14 and c.strong["J_wheel"] == 26
    assert c.strong["sw_a1"] == 3 and c.strong["sw_a2"] == 13
    assert c.resistors["R_R4"] == "conductance"       # f19 = sign(dp)sqrt|dp|/R4, eq. (1)
    assert c.resistors["R_R2"] == c.resistors["R_R3"] == c.resistors["R_R5"] == "resistance"


def test_dc_motor_simulates_in_integral_causality():
    m = load_model([p for p in SHIPPED if p.stem == "dc_motor_clutch"][0])
    c = assign(m, SIMULATION)
    assert c.ok and all(v == "integral" for v in c.storage.values())


def test_graph_has_sensor_signal_bonds(cycab):
    g = to_networkx(cycab)
    assert g.number_of_edges() == len(cycab.bonds) + len(cycab.sensors)
    assert g.nodes["sw_a1"]["mode"] == "a1"


def test_two_effort_sources_on_a_zero_junction_conflict():
    text = BASE.replace("  cap: {type: C, parameter: C1}", "  cap: {type: C, parameter: C1}\n  se2: {type: Se, value: 1.0}")
    text += "  5: [se2, j0]\n"
    c = assign(load_model_text(text), DIAGNOSIS)
    assert not c.ok
    assert any("j0" in p for p in c.problems)


def test_storage_forced_out_of_derivative_causality_is_reported():
    # no sensor next to the capacitor: its effort cannot be known, so it stays integral
    text = BASE.replace("v: {type: De, junction: j0, column: v, unit: V}", "v: {type: Df, junction: j1, column: v, unit: A}")
    c = assign(load_model_text(text), DIAGNOSIS)
    assert any("storage cap" in p and "integral" in p for p in c.problems)


def test_algebraic_loop_is_reported():
    # Ra in series with Rb || Rc and no storage: whatever resistor causality is chosen, the
    # junction structure closes a loop of algebraic relations
    text = """\
parameters:
  Ra: {value: 1.0, unit: Ohm}
  Rb: {value: 2.0, unit: Ohm}
  Rc: {value: 3.0, unit: Ohm}
elements:
  src: {type: Se, value: 1.0}
  ra: {type: R, parameter: Ra}
  rb: {type: R, parameter: Rb}
  rc: {type: R, parameter: Rc}
junctions:
  j1: {type: "1"}
  j0: {type: "0"}
  j2: {type: "1"}
bonds:
  1: [src, j1]
  2: [j1, ra]
  3: [j1, j0]
  4: [j0, rb]
  5: [j0, j2]
  6: [j2, rc]
"""
    c = assign(load_model_text(text), SIMULATION)
    assert not c.ok
    assert any(l.startswith("algebraic loop through bonds") for l in c.loops)
    assert any("2" in l and "3" in l for l in c.loops)


def test_graph_command_writes_dot(tmp_path):
    out = tmp_path / "g.dot"
    assert main(["graph", "models/cycab_steering.yaml", "-o", str(out)]) == 0
    dot = out.read_text()
    assert dot.startswith("digraph") and "0c (a1)" in dot and "tee" in dot and "lvee" in dot
