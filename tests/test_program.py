"""Straight-line programs and their linear lines mean the same as sympy's nested expressions."""
from __future__ import annotations

import math
from pathlib import Path

import pytest
import sympy as sp

from bondgraph.causality import SIMULATION, assign
from bondgraph.chains import chain_yaml
from bondgraph.equations import relations, resolve
from bondgraph.linear import Linear, as_expr, combine
from bondgraph.loader import load_model, load_model_text
from bondgraph.model import t
from bondgraph.program import Program, compile_lines, linear_coefficients
from bondgraph.simulation import _known_values

a, b, x, y, z = sp.symbols("a b x y z")
MODELS = Path(__file__).resolve().parent.parent / "models"


def test_combine_reduces_to_the_simplest_form():
    assert combine([]) == 0
    assert combine([(sp.Integer(1), x)]) is x                       # 1*x is the name itself
    assert combine([(a, sp.Integer(1))]) == a                       # a constant term
    assert combine([(a, x), (-a, x)]) == 0                          # terms of one name merged
    assert combine([(a, sp.Integer(0)), (b, sp.Integer(2))]) == 2 * b
    line = combine([(a, x), (sp.Integer(-1), y), (1 / b, z), (-1 / b, x)])
    assert isinstance(line, Linear)
    assert sp.simplify(line.as_expr() - (a * x - y + z / b - x / b)) == 0
    assert line.free_symbols == {a, b, x, y, z}
    assert line == combine([(a, x), (sp.Integer(-1), y), (1 / b, z), (-1 / b, x)])
    assert hash(line) == hash(combine([(a, x), (sp.Integer(-1), y), (1 / b, z), (-1 / b, x)]))
    assert as_expr(x) is x


def test_linear_lines_substitute_and_print_as_their_sympy_expression():
    line = combine([(a, x), (sp.Integer(-1), y), (1 / b, z), (-a / b, sp.Integer(3))])
    assert line.xreplace({x: sp.Integer(0), y: z}) == combine([(1 / b - 1, z), (-3 * a / b, sp.Integer(1))])
    assert line.xreplace({a: b}).as_expr() == line.as_expr().xreplace({a: b})
    program = Program()
    out = program.name(line)
    fn = compile_lines([[a, b, x, y, z]], program.lines, [out], "math")
    values = {a: 1.5, b: -0.3, x: 2.0, y: 0.7, z: 1.1}
    expected = float(line.as_expr().xreplace(values))
    assert fn(tuple(values.values()))[0] == pytest.approx(expected, rel=1e-14)


def test_coefficients_of_linear_lines_are_their_derivatives():
    dx = sp.Symbol("dx")
    program = Program()
    v1 = program.name(combine([(a, dx), (b, x)]))
    v2 = program.name(sp.sin(x) * v1 + y)
    v3 = program.name(combine([(sp.Integer(-1), v2), (a, v1)]))
    lines, grad = linear_coefficients(program.lines, [dx])
    nested = as_expr(program.lines[-1][1])
    for name, expr in reversed(program.lines[:-1]):
        nested = nested.xreplace({name: as_expr(expr)})
    value = {s: as_expr(e) for s, e in lines}
    coefficient = grad[v3][dx]
    for s, e in reversed(lines):
        coefficient = coefficient.xreplace({s: value[s]})
    assert sp.simplify(coefficient - sp.diff(nested, dx)) == 0


def _state_relations(model):
    """The relations the simulator derives its state equations from (see simulation._build)."""
    causality = assign(model, SIMULATION)
    integral = [e for e in model.elements.values() if e.kind in ("C", "I") and causality.storage[e.name] == "integral"]
    states = {e.name: sp.Function(f"x_{e.name}", real=True)(t) for e in integral}
    signals = {model.symbols[i]: model.inputs[i].expr for i in model.inputs if model.inputs[i].expr is not None}
    signals.update({model.symbols[s.name]: sp.Symbol(f"__signal_{s.name}") for s in model.sensors.values()})
    rels = relations(model, causality, known=_known_values(model, frozenset()), states=states, signals=signals)
    return rels, states


@pytest.mark.parametrize("model", ["chain", "cycab_steering", "two_tank_valve"])
def test_program_lines_evaluate_to_the_nested_sympy_values(model):
    """resolve(..., program=...) (linear lines, names) against resolve without a program (sympy's
    nested expressions of the whole model), evaluated at one point: every variable agrees."""
    if model == "chain":
        m = load_model_text(chain_yaml(40), "chain_40")
    else:
        m = load_model(MODELS / f"{model}.yaml")
    rels, states = _state_relations(m)
    nested = resolve(rels)
    program = Program()
    named = resolve(rels, program=program)
    assert any(isinstance(e, Linear) for _, e in program.lines)
    symbols = sorted(set().union(*(e.free_symbols for e in nested.values())) - {t}, key=str)
    point = {s: sp.Float(0.3 + 0.07 * k) for k, s in enumerate(symbols)}
    point[t] = sp.Float(0.41)
    for k, (_, X) in enumerate(sorted(states.items())):
        point[sp.Derivative(X, t)] = sp.Float(-0.2 + 0.05 * k)
        point[X] = sp.Float(0.6 - 0.1 * k)

    def number(expr: sp.Expr) -> complex:
        expr = expr.xreplace({d: v for d, v in point.items() if isinstance(d, sp.Derivative)})
        return complex(sp.N(expr.xreplace(point).doit(), 30))
    value: dict = {}
    for name, expr in program.lines:
        value[name] = sp.Float(number(as_expr(expr).xreplace(value)).real, 30)
    for var, expr in nested.items():
        if any(s.name.startswith("__signal") for s in expr.free_symbols):     # not simulated
            continue
        want = number(expr)
        got = number(as_expr(named[var]).xreplace(value))
        assert math.isclose(got.real, want.real, rel_tol=1e-12, abs_tol=1e-12), var
