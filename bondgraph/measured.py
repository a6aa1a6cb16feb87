"""Storage elements whose state the sensors measure.

A sensor that ``measures: displacement`` reads the time integral of its 1-junction's flow; a C's
displacement q is the time integral of its bond's flow. Where the junction structure makes the C's
flow a fixed signed sum of such junctions' flows (the C on the sensor's own junction; a coupling
spring on the relative-velocity junction of two measured masses: q = x1 - x2), q is that sum of
the readings, up to a constant the model's ``initial`` values fix (the simulator integrates every
state from them, 0 where not given). Dually for an I's momentum and ``measures: momentum`` sensors
on 0-junctions. :func:`bondgraph.structure.equations` writes the relation in place of the storage
element's rate, so that the residuals read its law at the measured state (a position sensor on a
spring's mass gives m x'' + b x' + k x = F, not its derivative).

>>> from bondgraph.loader import load_model
>>> measured_storage(load_model("models/mass_spring_damper_two_sensors.yaml"))
{'spring': {'x': 1}}
>>> measured_storage(load_model("models/two_mass_positions.yaml"))
{'spring': {'x1': 1, 'x2': -1}}
"""
from __future__ import annotations

import numpy as np
import sympy as sp

from .graph import ports, to_networkx
from .laws import bond_variables, model_laws, two_port_equations
from .model import Model

MAX_JUNCTIONS = 200     # junctions of plain structure searched around a storage element (a long chain's are not)
WANTED = (("displacement", "C", "1"), ("momentum", "I", "0"))   # what a sensor measures, whose state, on which junction


def measured_storage(model: Model) -> dict[str, dict[str, sp.Expr]]:
    """Each storage element whose state is a fixed signed sum of sensors' readings: element name ->
    {sensor: coefficient} (q = sum(coefficient * reading) + constant, :func:`offset`). Only plain
    0- and 1-junctions carry the relation (a controlled junction multiplies its outputs by its mode
    variable; a transformer by its modulus); a junction with two such sensors is read by its first.
    Worked out once per model (causality, the structure and verify ask)."""
    return model_laws(model, ("measured storage",), lambda: _measured(model))


def _measured(model: Model) -> dict[str, dict[str, sp.Expr]]:
    out: dict[str, dict[str, sp.Expr]] = {}
    for measures, kind, base in WANTED:
        sensors: dict[str, str] = {}
        for s in model.sensors.values():
            if s.measures == measures and model.junctions[s.junction].kind == base:
                sensors.setdefault(s.junction, s.name)
        if not sensors:
            continue
        g = to_networkx(model)
        for el in model.elements.values():
            if el.kind == kind:
                got = _sum_of(model, g, el.name, base, sensors)
                if got:
                    out[el.name] = got
    return out


def offset(model: Model, element: str, readings: dict[str, sp.Expr]) -> float:
    """The constant of ``q = sum(a * x) + constant``: the element's initial state less the readings'
    initial values, each 0 where the model's ``initial`` gives none (a coefficient's parameters at
    their values)."""
    return float(model.initial.get(element, 0.0) - sum(coefficient(model, a) * model.initial.get(s, 0.0)
                                                       for s, a in readings.items()))


def coefficient(model: Model, a: sp.Expr) -> float:
    """A reading's coefficient as a number (a gearbox's 1/N at N's value)."""
    values = model.nominal_by_name()
    return float(sp.sympify(a).subs({x: values[str(x)] for x in sp.sympify(a).free_symbols if str(x) in values}))


def _plain(model: Model, node: str) -> bool:
    return node in model.junctions and model.junctions[node].kind in ("0", "1")


def _sum_of(model: Model, g, element: str, base: str, sensors: dict[str, str]) -> dict[str, sp.Expr] | None:
    """The element's rate (flow of a C, effort of an I) as a sum of the sensors' junctions' common
    variables, from the plain junctions joined to its own, directly or through transformers of a
    constant modulus no fault changes (a gearbox: the motor's angle over its ratio); a bond to
    anything else (a controlled junction included) carries a rate they do not fix. None where they
    do not fix it. (A modulus that changed would part the integrals: d(x/N)/dt is not x'/N.)"""
    ps = [p for p in ports(g, element) if not isinstance(p[0], str)]
    if len(ps) != 1 or not _plain(model, ps[0][1]):
        return None
    bond, start = ps[0][0], ps[0][1]
    rate = 1 if base == "1" else 0                       # index of the rate in (e, f)
    faulted = {name for f in model.faults.values() if f.kind == "parametric" for name in f.targets}
    seen, todo, eqs = {start}, [start], []
    while todo:
        here = todo.pop()
        if here in sensors and here != start:
            continue                                     # its bonds' rates are its sensor's: nothing beyond adds
        for _, other, _ in ports(g, here):
            if other in seen:
                continue
            if _plain(model, other):
                seen.add(other)
                todo.append(other)
            elif other in model.elements and model.elements[other].kind == "TF" and not (
                    {str(x) for x in model.elements[other].modulus.free_symbols} & faulted):
                two = [p for p in ports(g, other) if not isinstance(p[0], str)]
                if len(two) == 2 and all(_plain(model, n) for _, n, _ in two):
                    seen.add(other)                  # its rate relation: f2 = m f1, or e1 = m e2
                    eqs.append(two_port_equations(model.elements[other], two)[rate].expr)
                    for _, n, _ in two:
                        if n not in seen:
                            seen.add(n)
                            todo.append(n)
            if len(seen) > MAX_JUNCTIONS:
                return None
    known = {}
    unknowns = set()
    for j in sorted(n for n in seen if n in model.junctions):
        bonds = [(k, sign) for k, _, sign in ports(g, j) if not isinstance(k, str)]
        xs = [bond_variables(k)[rate] for k, _ in bonds]
        if j in sensors:
            known[xs[0]] = sensors[j]                    # the junction's first bond: its common variable
        unknowns.update(xs)
        if model.junctions[j].kind == base:              # the common variable: equal on every bond
            eqs += [x - xs[0] for x in xs[1:]]
        else:                                            # the balance: signed sum zero
            eqs.append(sp.Add(*[sign * x for (_, sign), x in zip(bonds, xs)]))
    if not known:
        return None
    target = bond_variables(bond)[rate]
    if target in known:
        value = target
    else:
        free = sorted(unknowns - set(known), key=str)
        if not _determined(model, eqs, free, target):
            return None                                  # (sympy only where the numbers say it is fixed)
        solved = sp.solve(eqs, free, dict=True)
        if len(solved) != 1 or target not in solved[0]:
            return None
        value = sp.expand(solved[0][target])
    if not value.free_symbols & set(known) or any(x not in known and not _parameter(model, x)
                                                  for x in value.free_symbols):
        return None
    coefficients = {known[x]: sp.simplify(value.coeff(x)) for x in sorted(set(known) & value.free_symbols, key=str)}
    return {s: a for s, a in coefficients.items() if a != 0} or None


def _parameter(model: Model, symbol: sp.Symbol) -> bool:
    return str(symbol) in model.parameters


def _determined(model: Model, eqs: list[sp.Expr], free: list[sp.Symbol], target: sp.Symbol) -> bool:
    """Whether the linear relations ``eqs`` fix ``target`` once every symbol but ``free`` is known:
    numerically (the parameters at their values), no null vector of the free part moves it. A long
    chain's 200 junctions: milliseconds, where sympy took minutes."""
    values = {model.symbols[k]: v for k, v in model.nominal_by_name().items() if k in model.symbols}
    index = {x: k for k, x in enumerate(free)}
    a = np.zeros((len(eqs), len(free)))
    for r, e in enumerate(eqs):
        for x, c in sp.expand(e).as_coefficients_dict().items():
            if x in index:
                a[r, index[x]] = float(sp.sympify(c).subs(values)) if not c.is_number else float(c)
            elif x.free_symbols & set(index):            # a product of a rate and a parameter
                for y in x.free_symbols & set(index):
                    a[r, index[y]] = float((c * x / y).subs(values))
    _, sv, vt = np.linalg.svd(a)
    rank = int((sv > 1e-9 * max(1.0, sv.max(initial=0.0))).sum())
    null = vt[rank:]
    return not null.size or bool(np.all(np.abs(null[:, index[target]]) < 1e-9))
