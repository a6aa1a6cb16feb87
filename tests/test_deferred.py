"""Symbolic fields that unpickle on first read (bondgraph.deferred): a model read back equals the
model it was pickled from, field by field, whichever way it is read (attribute, equality,
``dataclasses.replace``, copies, pickling it again), and its expressions stay bytes until one is
read. The truth is the model loaded from its file."""
from __future__ import annotations

import copy
import dataclasses
import pickle

from bondgraph.deferred import loaded
from bondgraph.loader import load_model

from .conftest import CYCAB, ROOT


def _fresh():
    return load_model(str(CYCAB))


def test_a_model_read_back_equals_its_original_field_by_field():
    m = _fresh()
    back = pickle.loads(pickle.dumps(m, protocol=pickle.HIGHEST_PROTOCOL))
    assert not any(loaded(s) for s in back.sensors.values())
    assert [s.unit for s in back.sensors.values()] == [s.unit for s in m.sensors.values()]
    assert not any(loaded(s) for s in back.sensors.values())        # plain fields read, nothing unpickled
    for name, s in m.sensors.items():
        assert back.sensors[name].signal == s.signal and back.sensors[name].columns == s.columns
    for name, e in m.elements.items():
        b = back.elements[name]
        assert (b.laws, b.modulus, b.value) == (e.laws, e.modulus, e.value)
    assert back.symbols == m.symbols and back.definitions == m.definitions
    assert back == m
    assert back.nominal_values() == m.nominal_values()
    assert back.nominal_by_name() == {s.name: v for s, v in m.nominal_values().items()}


def test_replace_copy_and_pickling_again_read_the_deferred_fields():
    m = _fresh()
    back = pickle.loads(pickle.dumps(m))
    dp = back.sensors["dp"]
    changed = dataclasses.replace(dp, unit="bar")
    assert changed.signal == m.sensors["dp"].signal and changed.unit == "bar"
    assert copy.deepcopy(pickle.loads(pickle.dumps(m))) == m
    unread = pickle.loads(pickle.dumps(m)).sensors["theta1"]
    again = pickle.loads(pickle.dumps(unread))                       # never read: its bytes passed on as they are
    assert not loaded(again) and again == m.sensors["theta1"]


def test_a_field_that_is_none_stays_plain():
    """A commanded mode's ``positive is None`` is answered without unpickling its command's
    expression; an autonomous mode's condition reads back whole."""
    m = load_model(str(ROOT / "tests" / "data" / "boost_dcm.yaml"))
    back = pickle.loads(pickle.dumps(m))
    switch, diode = back.modes["s"], back.modes["c"]
    assert switch.positive is None and switch.column == "s_cmd"
    assert not loaded(switch)                                         # Heaviside(sin(...)) still bytes
    assert switch.expr == m.modes["s"].expr and loaded(switch)
    assert diode.positive == m.modes["c"].positive and diode.expr is None
    assert back.modes == m.modes


def test_a_residual_read_back_keeps_its_identity_without_its_expression():
    """Two residuals that store one quantity share its rate by ``key`` (its exact expression as
    text), read without unpickling the expression."""
    from fdi.monitor import Monitor
    from fdi.persist import pack, restore
    m = Monitor(str(ROOT / "models" / "hydraulic_actuator.yaml"))
    back = restore(pack(m))["_residuals"]
    inner = [(r.name, q) for r in m.residuals for _, q in r.composites]
    assert inner                                                      # the chambers' stored quantities
    read = [q for r in back for _, q in r.composites]
    assert [q.key for q in read] == [q.key for _, q in inner]
    assert not any(loaded(q) for q in read)
    assert [q.expr for q in read] == [q.expr for _, q in inner]
