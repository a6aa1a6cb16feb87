"""Every residual has a unit (issue 20): the residuals structural analysis adds (MSO) were printed
as '?' when no sensor sat on their junction. Checked against units derived by hand from the
relations each residual sums (the models' comments give the relations):

- three tanks (Frisk et al. 2012): both MSO residuals are tank 2's and tank 3's volume balances
  rewritten with the measured p1, q2 and pump flow q0: CT*dp/dt [m^3/Pa * Pa/s] - q [m^3/s]: m^3/s;
- two masses (velocities measured): ARR_a = F - m1 dv1/dt - m2 dv2/dt, a force: N; the spring's
  two residuals are its law in derivative causality, v1 - v2 - Ck d(F_spring)/dt
  [m/s - m/N * N/s]: m/s;
- two masses (positions measured): the same relations with v = dx/dt: N and m/s;
- a mass-spring-damper with a speed and a position sensor: the spring's law (m/s) and the two
  sensors' agreement v - dx/dt: m/s."""
from __future__ import annotations

import pytest

from bondgraph.loader import load_model
from fdi.arrs import arr_unit, select_arrs

from .conftest import ROOT

HAND = {
    "three_tank": {"ARR1": "m^3/s", "ARR2": "m^3/s"},
    "two_mass_spring_damper": {"ARR1": "m/s", "ARR2": "N", "ARR3": "m/s"},
    "two_mass_positions": {"ARR1": "N", "ARR2": "N", "ARR3": "N"},         # the spring's compression x1 - x2
    "mass_spring_damper_two_sensors": {"ARR1": "m/s", "ARR2": "N"},     # the force balance, the spring read from x
}


@pytest.mark.parametrize("name", list(HAND))
def test_structural_residuals_have_the_unit_of_what_they_sum(name):
    model = load_model(ROOT / "models" / f"{name}.yaml")
    arrs = select_arrs(model).arrs
    assert {a.name: arr_unit(model, a) for a in arrs} == HAND[name]
    assert any(a.origin == "MSO" for a in arrs)


def test_an_integrated_state_carries_its_rate_times_seconds():
    """Mixed-causality residuals integrate states X' = rhs (a tank's volume from its flows): their
    terms in X still have a unit. Three tanks: the valves' laws p_i - p_j - Rv q with p = X/CT,
    and a tank's pressure p1 - X1/CT1: Pa. Two masses by their positions: velocities (m/s) or a
    position integrated from a momentum (m), never '?'."""
    tanks = load_model(ROOT / "models" / "three_tank.yaml")
    arrs = select_arrs(tanks, "mixed").arrs
    assert any(a.states for a in arrs) and {arr_unit(tanks, a) for a in arrs} <= {"Pa", "m^3/s"}
    masses = load_model(ROOT / "models" / "two_mass_positions.yaml")
    assert {arr_unit(masses, a) for a in select_arrs(masses, "mixed").arrs} <= {"m/s", "m", "N"}


def test_a_wrong_unit_in_the_file_is_named_by_the_sum_it_breaks():
    """The RC circuit with its capacitance given in F*s (a typing slip): its node balance
    i - C dv/dt - v/RL adds C dv/dt in F*s*V/s = A*s beside i in A; its loop u - R i - v, which does
    not read C, adds volts to volts (by hand, Kirchhoff's laws)."""
    from bondgraph.loader import load_model_text
    from fdi.arrs import unit_clash_notes
    text = (ROOT / "tests" / "data" / "rc_two_sensors.yaml").read_text(encoding="utf-8")
    wrong = text.replace("C:  {value: 1.0e-3, unit: F}", "C:  {value: 1.0e-3, unit: F*s}")
    assert wrong != text
    model = load_model_text(wrong, "rc.yaml")
    notes = unit_clash_notes(model, list(select_arrs(model).arrs))
    assert len(notes) == 1 and notes[0].startswith("ARR2 adds terms of different units") and " in s*A" in notes[0]


@pytest.mark.parametrize("path", sorted((ROOT / "models").glob("*.yaml")), ids=lambda p: p.stem)
def test_no_shipped_model_adds_terms_of_different_units(path):
    """Every shipped model's residuals add like terms in each mode the plant runs in (a parameter
    named beta_e, a bulk modulus, has its unit: only an efficiency factor's beta is a pure number)."""
    from fdi.arrs import unit_clash_notes
    model = load_model(path)
    assert unit_clash_notes(model, list(select_arrs(model).arrs)) == []
