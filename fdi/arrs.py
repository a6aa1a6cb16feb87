"""The residuals bgfdi diagnoses with (:func:`select_arrs`): the SCAPH AGARRs of the diagnostic
hybrid bond graph (:mod:`fdi.scaph`) where they reach the model's best structural isolability,
completed by MSO residuals where they do not (:mod:`fdi.selection`), each checked in every mode
of a switched model and rebuilt where the one causality is wrong (:mod:`fdi.modewise`); and
each residual's unit.

The AGARRs' own derivation lives in :mod:`fdi.scaph`; its names (:class:`ARR`,
:func:`derive_arrs`, :func:`structural_system`, ...) are importable from here too, as before.
"""
from __future__ import annotations

import math
from dataclasses import replace

import sympy as sp

from bondgraph.model import Model, t
from bondgraph.deep import has_any
from bondgraph.errors import ModelError
from bondgraph.structure import DERIVATIVE

from .modewise import check_modes
# the derivation's names, re-exported: importers have always found them here (fdi.arrs.ARR, ...)
from .scaph import (ARR, binary_modes, derive_arrs, known_variables, sensor_value, signal_substitutions,
                    source_value, storage_fault_parameters, structural_system)
from .selection import BUDGET, ResidualSet, select


def select_arrs(model: Model, causality: str = DERIVATIVE, *, budget: float | None = None) -> ResidualSet:
    """The residual set of :func:`_select`, each residual checked in every mode combination of a
    switched model and rebuilt where the diagnostic hybrid bond graph's single causality is wrong
    in some mode (:mod:`fdi.modewise`)."""
    chosen = _select(model, causality, budget=budget)
    _zero_divisors(model, chosen.arrs)
    arrs, checks = check_modes(model, list(chosen.arrs))
    rebuilt = sorted({c.arr for c in checks if not c.holds})
    chosen = _with_mode_residuals(model, chosen, arrs)
    _zero_divisors(model, [a for a in chosen.arrs if " in mode " in a.origin])     # (a mode's own, added)
    if not rebuilt:
        return chosen
    where = {name: ", ".join(" ".join(f"{k}={v}" for k, v in c.mode.items()) for c in checks
                             if c.arr == name and not c.holds) for name in rebuilt}
    if all(a.origin == "SCAPH by mode" for a in arrs):        # the whole set replaced (fdi.modewise._by_sensor)
        notes = chosen.notes + ("residual set rebuilt mode by mode (one SCAPH ARR per sensor, joined by mode "
                                "indicators): the one-causality form is wrong for "
                                + "; ".join(f"{n} ({w})" for n, w in where.items())
                                + f"; replaced {', '.join(a.name for a in chosen.arrs)}",)
    else:
        zero = {a.name for a in arrs if a.origin.endswith("+zero")}
        notes = chosen.notes + tuple(f"{name} reads its sensor's zero in {w}: the junction its sensor is on is "
                                     f"switched off there, where the one-causality form is 0 = 0" if name in zero else
                                     f"{name} rebuilt mode by mode: the one-causality form is wrong in {w}"
                                     for name, w in where.items())
    return replace(chosen, arrs=tuple(arrs), notes=notes)


def _with_mode_residuals(model: Model, chosen: ResidualSet, arrs: list) -> ResidualSet:
    """``chosen`` with the residuals of single modes :func:`fdi.modewise.complete_by_mode` added
    (the last of ``arrs``), each said in a note; the selection's note that the set falls short of
    the best structural isolability is dropped when they close the gap."""
    added = [a for a in arrs if " in mode " in a.origin]
    if not added:
        return chosen
    from .selection import shortfall_of
    notes = [n for n in chosen.notes if not n.startswith("the computable residuals do not reach")]
    for a in added:
        notes.append(f"{a.name} holds in mode {a.origin.split(' in mode ')[1]} only (0 in the others): "
                     f"that mode's own ARR {f'of {a.sensor}' if a.sensor else f'at {a.junction}'}, which the "
                     f"diagnostic bond graph's one causality "
                     f"does not give (a relation of that mode alone)")
    short = shortfall_of(model, list(chosen.arrs) + added, chosen.causality)
    if short:
        notes.append("the computable residuals do not reach the best structural isolability "
                     f"(undetected: {', '.join(short.undetected) or 'none'}; pairs not told apart: "
                     f"{len(short.pairs)})")
    return replace(chosen, arrs=tuple(chosen.arrs) + tuple(added), notes=tuple(notes))


def _zero_divisors(model: Model, arrs) -> None:
    """A parameter of value 0 that a residual divides by (a wall's thermal resistance R12: 0.0, a
    user trial), or of value ``.inf`` that it multiplies by (an inertia J1: .inf, another), makes
    the residual infinite on every sample: refused with its key, as the loader refuses a TF's
    modulus of 0. Only models with such a parameter pay for the check."""
    for name, p in model.parameters.items():
        if p.value != 0 and not math.isinf(p.value):
            continue
        sym = model.symbols[name]
        value = sp.Integer(0) if p.value == 0 else sp.oo if p.value > 0 else -sp.oo
        for a in arrs:
            if sym in a.expr.free_symbols and a.expr.xreplace({sym: value}).has(sp.zoo, sp.nan, sp.oo, -sp.oo):
                if p.value == 0:
                    raise ModelError(f"parameter '{name}' is 0, and {a.name} divides by it (its residual would be "
                                     f"infinite on every sample): give its value in SI units, nonzero",
                                     file=getattr(model, "path", None), where=f"parameters.{name}.value")
                raise ModelError(f"parameter '{name}' is infinite, and {a.name} multiplies by it (its residual "
                                 f"would be infinite on every sample): give its value in SI units, finite "
                                 f"(.inf suits a parameter residuals divide by, such as a leakage resistance)",
                                 file=getattr(model, "path", None), where=f"parameters.{name}.value")


def _select(model: Model, causality: str = DERIVATIVE, *, budget: float | None = None) -> ResidualSet:
    """A small residual set reaching the model's best structural isolability (in ``causality``,
    derivative by default): the SCAPH AGARRs where they already do (the CyCab keeps eqs. 5, 9,
    13), otherwise completed (or, where SCAPH gives up, replaced) by MSO residuals chosen on the
    structure first and realised with sympy only once chosen (:mod:`fdi.selection`): the most
    detections and pairs told apart, then the lowest derivative order, fewest differentiations,
    fewest equations. ``budget`` bounds the search in seconds (default
    :data:`fdi.selection.BUDGET`); the notes say when it cut it."""
    return select(model, causality, BUDGET if budget is None else budget)


def undefined_in_modes(model: Model, arrs: list[ARR], modes: list[dict[str, int]]) -> list[str]:
    """The residuals that have no value in some mode (a division by a mode variable that is 0
    there, or an infinite term): one text per residual and mode, empty when all are defined."""
    bad = []
    for mode in modes:
        for a in arrs:
            e = a.expr.xreplace({model.symbols[m]: v for m, v in mode.items()}) if mode else a.expr
            if has_any(e, (sp.zoo, sp.nan, sp.oo, -sp.oo)):         # each shared part once (bondgraph.deep)
                bad.append(f"{a.name} undefined in mode {mode}")
    return bad


def arr_unit(model: Model, arr: ARR) -> str:
    """The unit of a residual: the unit of the variables its equation sums. A junction law sums
    flows at a 0-junction and efforts at a 1-junction; a storage element's law in derivative
    causality sums flows at a C (f = C de/dt) and efforts at an I (e = I df/dt), whatever junction
    it sits on; a sensor's equation, the variable it measures. Each summed term, as the residual
    is written, is read for its dimension: the units of the parameters, inputs and sensors it
    multiplies (a time derivative divides by s, efficiency factors and mode variables have none,
    a state X(t) integrated by a mixed-causality residual has its rate's unit times s), and the
    terms must agree (a number added alone is taken to carry their unit). Where no term can be
    read (a unit the file does not give), the junction's sensor says it: its common variable,
    and the summed variable read off an element on the junction or from effort x flow = power.
    ``?`` only when neither says anything.

    >>> from bondgraph.loader import load_model
    >>> m = load_model("models/two_tank_valve.yaml")
    >>> arr_unit(m, select_arrs(m).arrs[0])
    'm^3/s'
    """
    from bondgraph.units import format_dimension

    summed = _residual_dimension(model, arr)
    if summed is not None:
        return format_dimension(summed)
    return _junction_unit(model, arr)


def units_by_mode(model: Model, arr: ARR, modes: list[dict[str, int]]) -> dict[str, list[dict[str, int]]]:
    """The unit ``arr`` sums in each of ``modes`` (its expression reduced there), by unit: more than
    one entry when a residual rebuilt mode by mode joins forms of different units (an EV precharge
    circuit's link residual: a voltage loop while a contactor is closed, the battery current, in A,
    while both are open). One threshold then judges volts and amperes alike; calibrate sets it from
    the noisier, and a fault in the other mode goes undetected. Modes whose terms cannot be read
    are left out.

    >>> from bondgraph.loader import load_model
    >>> from fdi.signatures import all_modes
    >>> m = load_model("models/two_tank_commanded.yaml")
    >>> [list(units_by_mode(m, a, all_modes(m))) for a in select_arrs(m).arrs]
    [['m^3/s'], ['m^3/s'], ['m^3/s']]
    """
    from dataclasses import replace

    from bondgraph.units import format_dimension

    out: dict[str, list[dict[str, int]]] = {}
    for mode in modes:
        expr = arr.expr.xreplace({model.symbols[m]: v for m, v in mode.items()}) if mode else arr.expr
        if expr == 0:
            continue
        d = _residual_dimension(model, replace(arr, expr=expr))
        if d is not None:
            out.setdefault(format_dimension(d), []).append(dict(mode))
    return out


def unit_clash_notes(model: Model, arrs: list[ARR]) -> list[str]:
    """One note per residual that adds terms of different units (read from the units the file gives
    its parameters, inputs and sensors, as :func:`arr_unit` reads them): a unit in the file, or a
    law, is wrong (a user's isolator gave its spring stiffness N*s/m: its force balance added m/s
    and m/s^2, and calibrate labelled the residual N, the junction's unit, without a word).

    >>> from bondgraph.loader import load_model
    >>> m = load_model("models/two_tank_valve.yaml")
    >>> unit_clash_notes(m, list(select_arrs(m).arrs))
    []
    """
    from dataclasses import replace

    from bondgraph.units import format_dimension

    from .signatures import operating_modes

    modes = operating_modes(model)
    notes = []
    for a in arrs:
        clashes: list = []
        for mode in modes:                  # each mode's own form (a residual rebuilt by mode joins forms of
            expr = a.expr.xreplace({model.symbols[m]: v for m, v in mode.items()}) if mode else a.expr
            _residual_dimension(model, replace(a, expr=expr), clashes)     # other units: mixed_unit_notes)
            if clashes:
                break
        if clashes:
            (t1, d1), (t2, d2) = clashes[0]
            shown = [str(x) if len(str(x)) <= 60 else str(x)[:57] + "..." for x in (t1, t2)]
            notes.append(f"{a.name} adds terms of different units: {shown[0]} in {format_dimension(d1) or '1'}, "
                         f"{shown[1]} in {format_dimension(d2) or '1'}; a unit in the file (a parameter's, an "
                         f"input's, a sensor's) or a law is wrong, and its residual's unit cannot be trusted")
    return notes


def mixed_unit_notes(model: Model, arrs: list[ARR]) -> list[str]:
    """One note per residual whose modes sum different units (:func:`units_by_mode`), in the modes
    the plant runs in (:func:`fdi.signatures.operating_modes`: a fault-only mode is a fault, not a
    mode a threshold is set in); ``check`` prints them with the residuals."""
    from .signatures import operating_modes

    modes = operating_modes(model)
    if len(modes) < 2:
        return []
    notes = []
    for a in arrs:
        units = units_by_mode(model, a, modes)
        if len(units) > 1:
            where = "; ".join(f"{u} in {', '.join(' '.join(f'{k}={v}' for k, v in m.items()) for m in ms)}"
                              for u, ms in units.items())
            notes.append(f"{a.name} sums different units by mode ({where}): one threshold judges them all, set by "
                         f"the noisier; a fault that moves it only in the other modes may go undetected")
    return notes


def _residual_dimension(model: Model, arr: ARR, clashes: list | None = None) -> dict[str, float] | None:
    """The dimension of the terms ``arr.expr`` sums; None when no term can be read or they disagree.
    ``clashes`` (a list) receives, for each sum whose readable terms disagree, (term, its
    dimension) of two that do."""
    from bondgraph.units import dimension

    units: dict[str, str] = {p.name: p.unit for p in model.parameters.values()}
    units.update({i.name: i.unit for i in model.inputs.values()})
    units.update({s.name: s.unit for s in model.sensors.values()})
    dimensionless = set(model.modes)           # and every beta_<name>: the names are reserved for them
    states = {X: rhs for X, rhs in arr.states}
    seen: set = set()
    second = {"s": 1.0}

    def unit(name: str) -> dict[str, float] | None:
        if name in dimensionless or (name.startswith("beta_") and name not in model.parameters):
            return {}                      # (a parameter named beta_e, a bulk modulus, has its unit)
        text = units.get(name)
        if text is None:
            return None
        try:
            return dimension(text)
        except ValueError:
            return None

    def dim(e: sp.Expr) -> dict[str, float] | None:
        if e.is_number:
            return {}
        if e == t:
            return dict(second)
        if isinstance(e, sp.Symbol):
            return unit(e.name)
        if e in states:
            if e in seen:
                return None
            seen.add(e)
            rate = dim(states[e])
            return None if rate is None else _times(rate, second, 1)
        if isinstance(e, sp.Derivative):
            inner = dim(e.expr)
            order = sum(int(c) for v, c in e.variable_count if v == t)
            return None if inner is None else _times(inner, second, -order)
        if isinstance(e, sp.Add):
            terms = [a for a in e.args if not a.is_number]
            dims = [dim(a) for a in terms]
            common = _agree(dims)
            if common is None and clashes is not None:
                known = [(a, d) for a, d in zip(terms, dims) if d is not None]
                other = next(((a, d) for a, d in known[1:] if _agree([known[0][1], d]) is None), None)
                if other is not None:
                    clashes.append((known[0], other))
            return common
        if isinstance(e, sp.Mul):
            out: dict[str, float] = {}
            for a in e.args:
                d = dim(a)
                if d is None:
                    return None
                out = _times(out, d, 1)
            return out
        if isinstance(e, sp.Pow):
            if not e.exp.is_number:
                return {}
            d = dim(e.base)
            return None if d is None else _times({}, d, float(e.exp))
        if isinstance(e, (sp.Abs, sp.Min, sp.Max)):
            return _agree([dim(a) for a in e.args])
        if isinstance(e, sp.core.function.AppliedUndef):          # a measured signal y(t)
            return unit(type(e).__name__)
        return {}                                   # sign, heaviside, exp, sin, atan2, ...: a pure number

    return dim(arr.expr)


def _times(a: dict[str, float], b: dict[str, float], power: float) -> dict[str, float]:
    out = dict(a)
    for k, v in b.items():
        out[k] = out.get(k, 0.0) + power * v
    return {k: v for k, v in out.items() if abs(v) > 1e-12}


def _agree(dims: list[dict[str, float] | None]) -> dict[str, float] | None:
    """The common dimension of summed terms (those that can be read); None if none can or two differ."""
    known = [d for d in dims if d is not None]
    if not known or any(set(d) != set(known[0]) or any(abs(d[k] - known[0][k]) > 1e-9 for k in d) for d in known):
        return None
    return known[0]


def _junction_unit(model: Model, arr: ARR) -> str:
    """The unit the junction of ``arr`` sums, from the sensor on it (see :func:`arr_unit`)."""
    from bondgraph.units import combine, dimension, format_dimension

    name = arr.junction
    if name not in model.junctions:            # an MSO residual written at a storage element: its law
        bonded = [b.other(name) for b in model.bonds_of(name)]
        element = model.elements.get(name)
        if element is None or element.kind not in ("C", "I") or len(bonded) != 1 or bonded[0] not in model.junctions:
            return "?"
        name = bonded[0]                       # in derivative causality: f = C de/dt, e = I df/dt
    sensors = [s for s in model.sensors.values() if s.junction == name]
    if not sensors:
        return "?"
    s = sensors[0]
    try:
        measured = dimension(s.unit)
    except ValueError:
        return "?"
    if s.measures in ("displacement", "momentum"):
        measured = combine((measured, 1), (dimension("s"), -1))
    summed = _summed_dimension(model, name, measured)
    return format_dimension(summed if summed is not None else combine((dimension("W"), 1), (measured, -1)))


def _summed_dimension(model: Model, junction: str, common: dict[str, float]) -> dict[str, float] | None:
    """The dimension of the variable a junction sums, read off an element on it: a source of that
    variable (its input's unit), a storage element (C: f = C de/dt, I: e = I df/dt) or a linear R
    (f = e/R at a 0-junction, e = R f at a 1-junction), with ``common`` the junction's common
    variable. None when no element says it; then effort x flow = power gives it. This is what
    makes a pseudo bond graph right (thermal: effort K, flow W; their product is no power)."""
    from bondgraph.units import combine, dimension

    zero = model.junctions[junction].base == "0"
    per_second = {"s": -1.0}
    for b in model.bonds_of(junction):
        e = model.elements.get(b.other(junction))
        if e is None:
            continue
        try:
            if e.kind == ("MSf" if zero else "MSe") and e.input in model.inputs:
                return dimension(model.inputs[e.input].unit)
            if e.parameter is None or e.parameter not in model.parameters:
                continue
            par = dimension(model.parameters[e.parameter].unit)
            if e.kind == ("C" if zero else "I") and not e.laws:
                return combine((par, 1), (common, 1), (per_second, 1))
            if e.kind == "R" and not e.laws:
                return combine((common, 1), (par, -1 if zero else 1))
        except ValueError:
            continue
    return None
