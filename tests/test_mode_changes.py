"""The mode change signature matrix (MCSM) and the residuals' check in every mode, on a thermal RC
network with a thermostat relay (tests/data/two_zone_building.yaml: two zones, their walls to the
outdoors and between them, a heater behind a commanded relay s; written for a user trial from
Incropera's lumped capacitance and Karnopp's thermal bond graphs) and on the commanded two-tank.

The references: the paper's definition (a residual's MCSM entry is 1 when the residual is
sensitive to the mode change) and the energy balances written by hand:
  zone 1: C1 T1' = s Pin - (T1 - T2)/R12 - (T1 - Ta)/R1a         (ARR1)
  zone 2: C2 T2' = (T1 - T2)/R12 - (T2 - Ta)/R2a                  (ARR2: no heater)
  both:   C1 T1' + C2 T2' = s Pin - (T1 - Ta)/R1a - (T2 - Ta)/R2a  (ARR3)
and zone 1's balance with T1 taken from zone 2's (ARR4, T2 alone, T2'' in it)."""
from __future__ import annotations

from pathlib import Path

import sympy as sp

from bondgraph.loader import load_model
from bondgraph.model import t
from fdi.arrs import select_arrs
from fdi.modewise import check_modes
from fdi.signatures import mode_change_signature_matrix

from .conftest import MODELS

BUILDING = Path(__file__).parent / "data" / "two_zone_building.yaml"


def _rows(model, arrs, mode) -> dict[str, tuple[int, ...]]:
    return {r.mode_change: r.signature for r in mode_change_signature_matrix(model, arrs, mode).rows}


def test_a_relay_stuck_off_reacts_where_the_heater_enters():
    """From s = 1 the relay stuck off removes s Pin: ARR1, ARR3 and ARR4 react, zone 2's balance
    ARR2 does not (it read [1 1 ...]: the symbol s appears in every residual of a set rebuilt mode
    by mode, as s X + (1 - s) X, and appearing is not reacting). From s = 0 the change is the relay
    switching on, which no fault of the model names: the row is the variable's, and it reacts where
    the heater enters (it was labelled relay_stuck_off, the variable's only fault)."""
    model = load_model(BUILDING)
    arrs = list(select_arrs(model).arrs)
    assert _rows(model, arrs, {"s": 1}) == {"relay_stuck_off": (1, 0, 1, 1)}
    assert _rows(model, arrs, {"s": 0}) == {"s": (1, 0, 1, 1)}


def test_a_mode_change_is_named_for_the_fault_that_holds_the_value_it_goes_to():
    """The commanded two-tank's valve has two mode faults, stuck open (v = 1) and stuck closed
    (v = 0): the change from v = 1 is stuck closed (it was labelled v_open, the first fault found
    for the variable), the change from v = 0 stuck open, and both react alike (one switch, either
    way: the valve's flow enters both tanks' balances)."""
    model = load_model(MODELS / "two_tank_commanded.yaml")
    arrs = list(select_arrs(model).arrs)
    from_open, from_closed = (_rows(model, arrs, {"v": v}) for v in (1, 0))
    assert list(from_open) == ["v_closed"] and list(from_closed) == ["v_open"]
    assert from_open["v_closed"] == from_closed["v_open"] and any(from_open["v_closed"])


def test_a_residual_that_uses_a_derivative_of_a_modes_relations_holds_in_that_mode():
    """ARR4 (zone 1's balance with T1 from zone 2's: T2'' in it) is, by hand, ARR1 + (1 + R12/R1a)
    ARR2 + C1 R12 d(ARR2)/dt, valid in both modes; the mode check fitted it to the mode's own ARRs
    without their derivatives, refused it in both modes, and rebuilt the whole set one SCAPH ARR per
    sensor (the total balance ARR3, valid, lost with it; the note named ARR4, which the output no
    longer had). Now every ARR holds in every mode and the set is kept as selected."""
    model = load_model(BUILDING)
    chosen = select_arrs(model)
    e = {a.name: a.expr for a in chosen.arrs}
    s = model.symbols
    identity = e["ARR4"] - e["ARR1"] - (1 + s["R12"] / s["R1a"]) * e["ARR2"] - s["C1"] * s["R12"] * sp.diff(e["ARR2"], t)
    assert sp.simplify(identity) == 0
    assert [a.name for a in chosen.arrs] == ["ARR1", "ARR2", "ARR3", "ARR4"] and not chosen.notes
    kept, checks = check_modes(model, list(chosen.arrs))
    assert len(checks) == 8 and all(c.holds for c in checks)
    assert all(a is b for a, b in zip(kept, chosen.arrs))


def test_a_diode_changes_nothing_while_the_switch_conducts():
    """The boost converter in discontinuous conduction (tests/data/boost_dcm.yaml: switch s, diode c,
    autonomous): while the switch conducts the inductor's current returns through it and the
    residuals' forms in s = 1 are the same for either diode state, so the diode's change reacts
    nowhere from s = 1 (the old rule, the symbol c appears, read (1, 1)) and in both residuals from
    s = 0, where the diode carries the inductor's current to the output. A mode the caller leaves
    out takes its nominal value (it raised KeyError)."""
    model = load_model(Path(__file__).parent / "data" / "boost_dcm.yaml")
    arrs = list(select_arrs(model).arrs)
    for c in (0, 1):
        s_on, s_off = (_rows(model, arrs, {"s": s, "c": c}) for s in (1, 0))
        assert s_on["c"] == (0, 0) and s_off["c"] == (1, 1)
        assert s_on["s"] == s_off["s"] == (1, 1)
        for arr in arrs:              # the definition, on the residuals themselves
            forms = [arr.expr.subs({model.symbols["s"]: 1, model.symbols["c"]: v}) for v in (0, 1)]
            assert sp.expand(forms[0] - forms[1]) == 0
    assert _rows(model, arrs, {"s": 0}) == _rows(model, arrs, {"s": 0, "c": model.modes["c"].nominal})


def test_a_parameter_of_zero_a_residual_divides_by_is_refused(tmp_path):
    """The internal wall's resistance R12 at 0 (a user trial): zone 1's balance reads (T1 - T2)/R12,
    infinite on every sample, and the diagnosis said only that its residuals had no sample. Now the
    residual selection refuses it with its key; the model as written passes."""
    import pytest

    from bondgraph.errors import ModelError
    text = BUILDING.read_text()
    assert "  R12: {value: 0.01," in text
    zero = tmp_path / "zero.yaml"
    zero.write_text(text.replace("  R12: {value: 0.01,", "  R12: {value: 0.0,"))
    with pytest.raises(ModelError, match=r"parameters\.R12\.value: parameter 'R12' is 0, and ARR\d divides by it"):
        select_arrs(load_model(zero))
    assert select_arrs(load_model(BUILDING)).arrs
