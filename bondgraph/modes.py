"""A hybrid bond graph in one mode: every controlled junction made ordinary or switched off.

The diagnostic hybrid bond graph (DHBG) multiplies each *output* of a controlled junction by its
mode variable and keeps one causality for every mode. That is right when a switched-off junction's
outputs are what the physics sets to zero; it is wrong when the rest of the graph must then take
over a variable the junction imposed: in a boost converter the switch's 1c junction gives the
switch node its voltage while the switch conducts, and while it is open the voltage comes from
the diode's branch (the output voltage plus the diode's drop), which one causality cannot say.

:func:`in_mode` gives the plain bond graph of one mode, on which SCAPH is the textbook procedure:
a controlled junction whose mode is 1 becomes an ordinary junction; one whose mode is 0 imposes
its constraint on every bond: a 1c junction carries no flow (a zero flow source on each of its
bonds' other ends: ``Sf = 0``), a 0c junction no effort (``Se = 0``). The junction itself and the
elements and sensors it alone connects are removed with it; a sensor on it measures zero. So is a
part it cuts off that holds no sensor and no storage (:func:`_cut_off`): nothing of it is measured
nor carried over the mode, and its laws could only contradict the junction's zero (a bump stop's
force written from the measured compression, behind a 0c that is off while there is no contact;
a user trial's residual kb*(xs - gb) = 0, false on every record). For residuals, ``keep_states``
off removes such parts with storage too: a state nothing measures gives no residual. A
junction declared ``switched_off: outputs`` keeps the DHBG's switching (only its outputs are zero) and
stays controlled.

>>> from bondgraph.loader import load_model
>>> m = load_model("models/two_tank_valve.yaml")
>>> closed = in_mode(m, {"v": 0})
>>> sorted(e for e in closed.model.elements if e not in m.elements), sorted(closed.removed)
(['Jv~off3', 'Jv~off5'], ['Jv', 'valve'])
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Mapping

import sympy as sp

from .model import Bond, Element, Junction, Model


@dataclass(frozen=True)
class ModeGraph:
    """The bond graph of one mode. ``removed``: switched-off junctions and the elements they
    alone connected; ``zero_sensors``: sensors on a switched-off junction (they measure 0)."""
    mode: Mapping[str, int]
    model: Model
    removed: frozenset[str]
    zero_sensors: frozenset[str]


def in_mode(model: Model, mode: Mapping[str, int], keep_states: bool = True) -> ModeGraph:
    """The plain bond graph of ``model`` with its mode variables at ``mode`` (see module doc)."""
    values = {model.symbols[k]: sp.Integer(v) for k, v in mode.items()}
    off: set[str] = set()
    junctions = dict(model.junctions)
    for j in model.junctions.values():
        if not j.controlled or j.off == "outputs":     # the DHBG's own switching: kept as it is
            continue
        a = model.symbols[j.mode].xreplace(values)
        if a == 0:
            off.add(j.name)
        elif a == 1:
            junctions[j.name] = Junction(j.name, j.base, None, j.description)
        else:
            raise ValueError(f"mode of junction {j.name} is not 0 or 1 in mode {dict(mode)}")
    if not off:
        return ModeGraph(dict(mode), replace(model, junctions=junctions), frozenset(), frozenset())
    # elements that hang on a switched-off junction alone go with it (a one-port on it, a
    # two-port whose other side is gone too is left: it is joined to something live)
    removed = set(off)
    elements = dict(model.elements)
    for e in model.elements.values():
        ends = {b.other(e.name) for b in model.bonds_of(e.name)}
        if ends and ends <= off:
            removed.add(e.name)
            del elements[e.name]
    bonds: list[Bond] = []
    for b in model.bonds:
        if b.source in removed and b.target in removed:
            continue
        if b.source in off or b.target in off:
            j = model.junctions[b.source if b.source in off else b.target]
            live = b.other(j.name)
            name = f"{j.name}~off{b.id}"
            kind = "Sf" if j.base == "1" else "Se"
            elements[name] = Element(name, kind, value=sp.Integer(0), description=f"{j.name} switched off")
            # the zero source keeps the bond's power direction and id (so its number stays its own)
            bonds.append(Bond(b.id, name, live) if b.source == j.name else Bond(b.id, live, name))
            continue
        bonds.append(b)
    for name in off:
        del junctions[name]
    cut = _cut_off(model, elements, junctions, bonds, keep_states)
    if cut:
        removed |= {n for n in cut if n in model.elements or n in model.junctions}
        elements = {k: e for k, e in elements.items() if k not in cut}
        junctions = {k: j for k, j in junctions.items() if k not in cut}
        bonds = [b for b in bonds if b.source not in cut]
    zero = frozenset(s.name for s in model.sensors.values() if s.junction in off)
    sensors = {k: s for k, s in model.sensors.items() if k not in zero}
    symbols = dict(model.symbols)
    for name, e in elements.items():
        if name not in model.elements:
            symbols[f"beta_{name}"] = sp.Symbol(f"beta_{name}", positive=True)
    spec = replace(model, elements=elements, junctions=junctions, bonds=tuple(bonds), sensors=sensors,
                   symbols=symbols)
    return ModeGraph(dict(mode), spec, frozenset(removed), zero)


def _cut_off(model: Model, elements: Mapping[str, Element], junctions: Mapping[str, Junction],
             bonds: list[Bond], keep_states: bool) -> set[str]:
    """The nodes of the parts of a mode's graph (bonds joined, switched-off junctions gone) that hold
    no sensor and, with ``keep_states``, no storage (C or I): parts a switched-off junction cut off
    from everything measured. The part that holds a sensor or a state stays whole."""
    nodes = set(elements) | set(junctions)
    links: dict[str, list[str]] = {n: [] for n in nodes}
    for b in bonds:
        if b.source in links and b.target in links:
            links[b.source].append(b.target)
            links[b.target].append(b.source)
    seen = {s.junction for s in model.sensors.values() if s.junction in nodes}
    if keep_states:
        seen |= {k for k, e in elements.items() if e.kind in ("C", "I")}
    todo = list(seen)
    while todo:
        for n in links[todo.pop()]:
            if n not in seen:
                seen.add(n)
                todo.append(n)
    return nodes - seen


def held_still(model: Model) -> list[str]:
    """What switching a controlled junction off imposes beyond its own bonds, one note each: a 1c
    joined to a plain 1-junction that carries an inertia (an I) holds that junction's common flow at
    0 while off (a 1c carries no flow on any bond), so the inertia stands still; dually a 0c on a
    plain 0-junction with a capacitance (a C) holds its effort at 0. Right for a valve that closes a
    line of fluid inertance; wrong for a brake or a clutch, which should only cut its branch's
    effort: a trial's elevator wrote its brake as a 1c on the sheave's junction, which locked the
    sheave whenever the brake was released, and only a note on mixed units hinted it.

    >>> from bondgraph.loader import load_model
    >>> held_still(load_model("models/two_tank_valve.yaml"))
    []
    """
    out = []
    for j in model.junctions.values():
        if not j.controlled or j.off == "outputs":
            continue
        storage = "I" if j.base == "1" else "C"
        for b in model.bonds_of(j.name):
            n = model.junctions.get(b.other(j.name))
            if n is None or n.controlled or n.kind != j.base:
                continue
            others = sorted(b2.other(n.name) for b2 in model.bonds_of(n.name) if b2.other(n.name) != j.name)
            frozen = [e for e in others if e in model.elements and model.elements[e].kind == storage]
            if not frozen:
                continue
            if j.base == "1":
                what, state, fix = "flow", "stand(s) still", ("a valve that closes a line", "a brake or a clutch",
                                                              "effort (its torque or force)", "0c")
            else:
                what, state, fix = "effort", "discharge(s) to 0", ("a switch that shorts a node", "a switch",
                                                                 "flow (its current)", "1c")
            out.append(f"with {j.mode} = 0, {j.name} ({j.kind}) carries no {what} on any bond, so it holds {n.name}'s "
                       f"{what} at 0: {', '.join(frozen)} {state} in that mode (with {', '.join(others)}); right for "
                       f"{fix[0]}, not for {fix[1]} that should only cut its branch's {fix[2]}: that is a {fix[3]} "
                       f"on the branch, or {j.name} with switched_off: outputs")
    return out


def latching(model: Model) -> list[str]:
    """The autonomous modes the simulator can never switch back, one note each: a condition
    (``positive:``) that reads a sensor on a junction its own mode switches off reads that sensor
    at 0 there (a 0c carries no effort, a 1c no flow), and where the condition is not above zero at
    0 (or is, for a junction off at 1) the mode keeps the value that switched it off. A trial's
    hoist wrote its rope's slack as ``taut: {positive: T}`` with the load cell T on the rope's 0c:
    once slack, the simulated load fell freely to the end of the run, without a word. Records
    decide such a mode from the logged signal, so only simulation is held.

    >>> from bondgraph.loader import load_model
    >>> latching(load_model("models/two_tank_valve.yaml"))
    []
    """
    out = []
    for m in model.modes.values():
        if m.positive is None:
            continue
        var = model.symbols.get(m.name)
        for s in model.sensors.values():
            j = model.junctions.get(s.junction)
            if j is None or not j.controlled or j.off == "outputs" or j.mode is None:
                continue
            if s.measures != ("effort" if j.base == "0" else "flow"):
                continue
            sym = next((x for x in m.positive.free_symbols if x.name == s.name), None)
            switch = model.symbols.get(j.mode)
            if sym is None or var is None or switch is None or sp.sympify(switch).free_symbols != {var}:
                continue
            off = [v for v in (0, 1) if sp.sympify(switch).subs(var, v) == 0]
            at_zero = m.positive.subs(sym, 0)
            if len(off) != 1 or at_zero.free_symbols or not at_zero.is_real:
                continue
            if int(bool(at_zero > 0)) == off[0]:
                out.append(f"mode {m.name} can never switch back in simulation once {m.name} = {off[0]}: its condition "
                           f"'{m.positive}' reads {s.name}, a sensor on {j.name}, which {m.name} = {off[0]} switches "
                           f"off ({s.name} reads 0 there, and the condition is then {at_zero}); records decide it from "
                           f"the logged {s.name}, but bgfdi simulate and check --verify hold it; write the condition on a "
                           f"signal the switch leaves defined (a state's sensor, or one on another junction)")
    return out
