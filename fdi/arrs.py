"""Augmented global analytical redundancy relations (AGARRs) from the diagnostic hybrid bond graph.

For each sensor junction, its constitutive relation is written with the unknown variables
eliminated along the causal paths of the SCAPH assignment back to known ones. Known are the
sources, each multiplied by its efficiency factor (``beta_u_in * u_in(t)``), and the sensors,
each measurement divided by its efficiency factor (``theta1(t)/beta_theta1``; a sensor that
measures a displacement gives its junction the flow ``d/dt(theta1(t)/beta_theta1)``). Mode
variables stay symbols: every output of a controlled junction is multiplied by its own.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from bondgraph.causality import DIAGNOSIS, Causality, assign, require
from bondgraph.equations import relations, resolve, signal
from bondgraph.model import Model, t


@dataclass(frozen=True)
class ARR:
    """One AGARR: ``expr`` = 0 holds while the system is healthy. The residual is its value."""
    name: str
    sensor: str
    junction: str
    expr: sp.Expr


def sensor_value(model: Model, name: str) -> sp.Expr:
    """The true value of a sensor's signal: measurement over efficiency factor."""
    return signal(name) / model.beta_symbol(name)


def source_value(model: Model, element_name: str) -> sp.Expr:
    """A source's output with its efficiency factor: beta * input(t) or beta * value."""
    e = model.elements[element_name]
    base = signal(e.input) if e.input else e.value
    return model.beta_symbol(e.input or e.name) * base


def known_variables(model: Model) -> dict[str, sp.Expr]:
    """What each source and (inverted) sensor imposes on its bond in the diagnostic graph."""
    known = {e.name: source_value(model, e.name) for e in model.sources()}
    for s in model.sensors.values():
        value = sensor_value(model, s.name)
        known[s.name] = sp.diff(value, t) if s.measures in ("displacement", "momentum") else value
    return known


def signal_substitutions(model: Model) -> dict[sp.Symbol, sp.Expr]:
    """Signal symbols in modulated laws (F1(theta2)) -> their true values as functions of t."""
    subs: dict[sp.Symbol, sp.Expr] = {model.symbols[s]: sensor_value(model, s) for s in model.sensors}
    subs.update({model.symbols[i]: signal(i) for i in model.inputs})
    return subs


def derive_arrs(model: Model, causality: Causality | None = None) -> list[ARR]:
    """The AGARRs of ``model``, one per sensor in the order the sensors are listed."""
    causality = require(causality or assign(model, DIAGNOSIS))
    rels = relations(model, causality, known=known_variables(model), states={},
                     signals=signal_substitutions(model))
    wanted = []
    for s in model.sensors.values():
        # the junction's output on the sensor bond: flow of a De's 0-junction, effort of a Df's 1-junction
        wanted.append(("f", s.name) if s.kind == "De" else ("e", s.name))
    values = resolve(rels, wanted)
    modes = [model.symbols[m] for m in model.modes]
    return [ARR(name, s.name, s.junction, binary_modes(values[w], modes))
            for name, s, w in zip(model.arr_names(), model.sensors.values(), wanted)]


def binary_modes(expr: sp.Expr, modes: list[sp.Symbol]) -> sp.Expr:
    """Simplify with a in {0, 1}: a**n -> a, sign(a*x) -> a*sign(x), abs(a*x) -> a*abs(x)."""
    if not modes:
        return expr
    mode_set = set(modes)

    def split(arg: sp.Expr) -> tuple[sp.Expr, sp.Expr]:
        if isinstance(arg, sp.Mul):
            ms = [f for f in arg.args if f in mode_set]
            if ms:
                return sp.Mul(*ms), sp.Mul(*[f for f in arg.args if f not in mode_set])
        return sp.Integer(1), arg

    def pow_rule(e: sp.Pow) -> sp.Expr:
        if e.base in mode_set and e.exp.is_positive:
            return e.base
        a, rest = split(e.base)
        if a != 1 and e.exp.is_positive:
            return a * rest ** e.exp
        return e

    def fn_rule(e: sp.Expr) -> sp.Expr:
        a, rest = split(e.args[0])
        return a * e.func(rest) if a != 1 else e

    expr = expr.replace(lambda e: isinstance(e, (sp.sign, sp.Abs)) and isinstance(e.args[0], sp.Mul), fn_rule)
    return expr.replace(lambda e: isinstance(e, sp.Pow), pow_rule)
