"""Augmented global analytical redundancy relations (AGARRs) from the diagnostic hybrid bond graph,
and what every residual of bgfdi is made of: the :class:`ARR` type, the known values, the
causality-free structural system the MSO residuals are taken from, and the simplification of
mode variables.

For each sensor junction, its constitutive relation is written with the unknown variables
eliminated along the causal paths of the SCAPH assignment back to known ones. Known are the
sources, each multiplied by its efficiency factor (``beta_u_in * u_in(t)``), and the sensors,
each measurement divided by its efficiency factor (``theta1(t)/beta_theta1``; a sensor that
measures a displacement gives its junction the flow ``d/dt(theta1(t)/beta_theta1)``). Mode
variables stay symbols: every output of a controlled junction is multiplied by its own.

This is the bottom of the residual modules: :mod:`fdi.signatures`, :mod:`fdi.selection`,
:mod:`fdi.modewise` and :mod:`fdi.tables` build on it, and :mod:`fdi.arrs` (the residual set
bgfdi diagnoses with) on all of them.
"""
from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from bondgraph.causality import DIAGNOSIS, Causality, assign, require
from bondgraph.equations import is_signal, relations, resolve, signal
from bondgraph.model import Model, t
from bondgraph.structure import DERIVATIVE, EquationSystem, equations

from .notation import expr_latex


@dataclass(frozen=True)
class ARR:
    """One AGARR: ``expr`` = 0 holds while the system is healthy. The residual is its value.

    ``origin`` is ``SCAPH`` (the sensor's junction law along the causal strokes) or ``MSO`` (a
    minimal over-determined equation set, ``equations``, computed along a causal sequence and
    written at ``junction``, the node of its residual equation). ``causality`` says whether it
    only differentiates measured signals (``derivative``) or also integrates (``mixed``: then
    ``states`` are its integrated variables X(t), each with X' = rhs, integrated from the start
    of the data window). ``exact``, where given, keeps the time derivative of a stored quantity
    whose law carries a fault parameter whole (``Derivative(CT2*p2(t), t)``), for evaluation
    under a time-varying fault."""
    name: str
    sensor: str | None
    junction: str
    expr: sp.Expr
    origin: str = "SCAPH"
    equations: tuple[str, ...] = ()
    causality: str = DERIVATIVE
    states: tuple = ()
    exact: sp.Expr | None = None

    def _repr_latex_(self) -> str:
        """The relation as a notebook shows it: ``ARR1: 0 = ...``, signals' derivatives dotted."""
        return rf"$\displaystyle \mathrm{{{self.name}}}:\quad 0 = {expr_latex(self.expr)}$"


def sensor_value(model: Model, name: str) -> sp.Expr:
    """The true value of a sensor's signal: measurement over efficiency factor."""
    return signal(name) / model.beta_symbol(name)


def source_value(model: Model, element_name: str) -> sp.Expr:
    """A source's output with its efficiency factor: beta * input(t) or beta * value, a value that
    reads inputs or sensors reading their signals as a law does (a heater's Joule heat U**2/Rh on
    the measured mains voltage U)."""
    e = model.elements[element_name]
    base = signal(e.input) if e.input else e.value.xreplace(signal_substitutions(model))
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
    """The AGARRs of ``model`` (SCAPH), one per sensor in the order the sensors are listed.

    The first sensor on a junction is inverted and closes the junction's law; every further
    sensor on the same junction is a detector of the junction's common variable, and its AGARR is
    measurement minus that variable (``v - dx/dt`` for a speed and a position sensor on one mass)."""
    causality = require(causality or assign(model, DIAGNOSIS))
    known = known_variables(model)
    rels = relations(model, causality, known=known, states={}, signals=signal_substitutions(model))
    wanted = []
    for s in model.sensors.values():
        if s.name in causality.detectors:
            # a detector: the junction's common variable on the sensor bond
            wanted.append(("e", s.name) if s.kind == "De" else ("f", s.name))
        else:
            # the junction's output on the sensor bond: flow of a De's 0-junction, effort of a Df's 1-junction
            wanted.append(("f", s.name) if s.kind == "De" else ("e", s.name))
    values = resolve(rels, wanted)
    whole = frozenset(storage_fault_parameters(model))
    exact = resolve(rels, wanted, whole) if whole else None
    modes = [model.symbols[m] for m in model.modes]
    out = []
    for name, s, w in zip(model.arr_names(), model.sensors.values(), wanted):
        forms = [values[w]] + ([exact[w]] if exact is not None else [])
        forms = [known[s.name] - f if s.name in causality.detectors else f for f in forms]
        stored_rate = len(forms) > 1 and any(not is_signal(d.expr) for d in forms[1].atoms(sp.Derivative))
        out.append(ARR(name, s.name, s.junction, binary_modes(forms[0], modes),
                       exact=binary_modes(forms[1], modes) if stored_rate else None))
    return out


def structural_system(model: Model, causality: Causality | None = None, mode=None) -> EquationSystem:
    """The model's causality-free equations with this module's known values: sources times
    their efficiency factors, measurements divided by theirs; controlled junctions keep the
    strong bond SCAPH gives them (one causality in every mode)."""
    causality = causality or assign(model, DIAGNOSIS)
    sensors = {s: sensor_value(model, s) for s in model.sensors}
    sources = {e.name: source_value(model, e.name) for e in model.sources()}
    return equations(model, sources=sources, sensors=sensors, signals=signal_substitutions(model),
                     strong=causality.strong, mode=mode)


def storage_fault_parameters(model: Model) -> set[sp.Symbol]:
    """Parameters of storage laws that a candidate fault changes."""
    targets = {p for f in model.faults.values() if f.kind == "parametric" for p in f.targets}
    out = set()
    for e in model.elements.values():
        if e.kind in ("C", "I"):
            syms = {s.name for law in e.laws.values() for s in law.free_symbols}
            if e.parameter:
                syms.add(e.parameter)
            out |= {model.symbols[n] for n in syms & targets}
    return out


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