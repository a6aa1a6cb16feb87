"""Each law stated once (bondgraph/laws.py); its causal forms are the hand-solved textbook ones."""
from __future__ import annotations

import sympy as sp

from bondgraph.causality import DIAGNOSIS, SIMULATION, assign, resistor_forms
from bondgraph.equations import causal_forms, relations, resolve, signal
from bondgraph.laws import bond_variables, resistor_equation
from bondgraph.loader import load_model_text
from bondgraph.model import t

# u -> 1-junction (R, TF) -> TF -> 0-junction (C, second R); a pressure-like sensor on the 0
RC_TF = """\
parameters:
  R1: {value: 2.0, unit: Ohm}
  R2: {value: 5.0, unit: Ohm}
  C1: {value: 1.0e-3, unit: F}
  m: {value: 3.0, unit: "1"}
inputs:
  u: {column: u, unit: V}
elements:
  src: {type: MSe, input: u}
  r1: {type: R, parameter: R1}
  tf: {type: TF, modulus: m}
  cap: {type: C, parameter: C1}
  r2: {type: R, parameter: R2}
junctions:
  j1: {type: "1"}
  j0: {type: "0"}
sensors:
  v: {type: De, junction: j0, unit: V}
bonds:
  1: [src, j1]
  2: [j1, r1]
  3: [j1, tf]
  4: [tf, j0]
  5: [j0, cap]
  6: [j0, r2]
"""


def _forms(model, purpose):
    c = assign(model, purpose)
    known = {"src": signal("u"), "v": signal("v")}
    return {f.output: f for f in causal_forms(model, c, known=known, signals={})
            if f.kind not in ("source", "sensor", "detector")}


def test_scaph_forms_are_the_hand_solved_laws():
    m = load_model_text(RC_TF)
    s = m.symbols
    forms = _forms(m, DIAGNOSIS)
    e, f = {k: bond_variables(k)[0] for k in range(1, 7)}, {k: bond_variables(k)[1] for k in range(1, 7)}
    # the sensor imposes e on the 0-junction: the TF gets effort at bond 4 and gives e3 = m e4,
    # and takes f3 from the 1-junction to give f4 = m f3 (e1 = m e2, f2 = m f1 with power in at 3)
    assert forms[("e", 3)].expr == s["m"] * e[4]
    assert forms[("f", 4)].expr == s["m"] * f[3]
    # C in derivative causality: q = C e, its rate is the flow
    assert forms[("f", 5)].kind == "derivative" and forms[("f", 5)].expr == s["C1"] * e[5]
    # R2 receives the junction's effort: conductance, f = e / R
    assert forms[("f", 6)].expr == e[6] / s["R2"]
    # the 0-junction's balance, solved for the sensor bond's flow (power in at 4, out at 5, 6, v)
    assert sp.expand(forms[("f", "v")].expr - (f[4] - f[5] - f[6])) == 0


def test_the_arr_is_the_hand_derived_one():
    m = load_model_text(RC_TF)
    s = m.symbols
    c = assign(m, DIAGNOSIS)
    u, v = signal("u"), signal("v")
    rels = relations(m, c, known={"src": u, "v": v}, states={}, signals={})
    arr = resolve(rels, [("f", "v")])[("f", "v")]
    # f4 = m f3, f3 = (u - m v)/R1 (1-junction: u = R1 f + m e4), minus C dv/dt and v/R2
    expected = s["m"] * (u - s["m"] * v) / s["R1"] - s["C1"] * sp.diff(v, t) - v / s["R2"]
    assert sp.simplify(arr - expected) == 0


def test_integral_causality_reads_the_state():
    m = load_model_text(RC_TF)
    forms = _forms(m, SIMULATION)
    q = sp.Symbol("q[cap]", real=True)
    assert forms[("e", 5)].kind == "state" and forms[("e", 5)].expr == q / m.symbols["C1"]


def test_a_resistor_law_given_one_way_allows_that_causality_only():
    text = RC_TF.replace("r2: {type: R, parameter: R2}", "r2: {type: R, effort: R2*f + sign(f)}")
    m = load_model_text(text)
    assert resistor_forms(m, m.elements["r2"]) == frozenset({"resistance"})
    assert resistor_forms(m, m.elements["r1"]) == frozenset({"resistance", "conductance"})
    c = assign(m, DIAGNOSIS)
    assert any("resistor r2 needs conductance causality" in p for p in c.problems)


def test_a_parameter_and_a_law_each_give_their_own_direction():
    text = RC_TF.replace("r2: {type: R, parameter: R2}", "r2: {type: R, parameter: R2, flow: e**3}")
    m = load_model_text(text)
    eq = resistor_equation(m, m.elements["r2"], 6)
    e6, f6 = bond_variables(6)
    assert eq.solutions[f6] == e6 ** 3                 # the law, where given
    assert eq.solutions[e6] == m.symbols["R2"] * f6     # the parameter, the other way


def _shipped_and_chain_models():
    from pathlib import Path

    from bondgraph.chains import chain_yaml, fault_chain_yaml
    from bondgraph.loader import load_model
    root = Path(__file__).resolve().parent.parent / "models"
    return [load_model(p) for p in sorted(root.glob("*.yaml"))] + \
        [load_model_text(chain_yaml(60), "chain_60"), load_model_text(fault_chain_yaml(4), "fault_chain_4")]


def test_a_law_is_solved_as_plain_sympy_arithmetic_solves_it():
    """solve_linear's shortcut for a law's sum (no rebuilt sum, no division by +-1) gives the very
    expression of the plain path (coefficient, var at 0, -rest/coefficient), for every variable of
    every law of the shipped models, a drivetrain chain and a tank chain, and for sums the laws
    do not write (numbers, several signs, a term of the variable twice)."""
    from bondgraph.laws import _split, solve_linear, solve_linear_plain
    from bondgraph.structure import equations
    checked = fast = 0
    for m in _shipped_and_chain_models():
        for eq in equations(m).equations:
            for v in eq.variables:
                got, want = solve_linear(eq.expr, v), solve_linear_plain(eq.expr, v)
                assert got == want and sp.srepr(got) == sp.srepr(want), (m.name, eq.name, v)
                checked += 1
                fast += _split(eq.expr, v) is not None       # the shortcut taken
    assert checked > 1000 and fast > 600
    x, y, z, w = sp.symbols("x y z w", real=True)
    a, b = sp.symbols("a b", positive=True)
    for expr in (x - y, y - x, x + y + z, -x - y + 2 * z, 3 * x - a * y, x - a * b * y + z, -2 * x + y - w,
                 x + 1 - y, x * y - z, x - x * y, a * x + a * y, -x + a * (y + z), x + sp.sin(y) - z,
                 a * x - a * y, 2 * x - 3 * a * y, -x + a * y, a * b * x - b * y, x / a - y / b, 2 * a * x - y / 3,
                 x - a * y - b * z, x ** 2 - a * y):
        for v in (x, y, z, w):
            got, want = solve_linear(expr, v), solve_linear_plain(expr, v)
            assert got == want and sp.srepr(got) == sp.srepr(want), (expr, v)


def test_a_signed_sum_is_the_sum_sympy_builds():
    """signed_sum and difference (the laws' sums, without sympy's general flatten) against
    sympy.Add and subtraction themselves: sign patterns of up to five of a mixed set of bond,
    energy and named symbols and products and powers of them, in several orders; a repeated
    term, a sign other than +-1, a number or a sum is sympy's own arithmetic."""
    import itertools
    import random

    from bondgraph.laws import difference, signed_sum
    a, c = sp.Symbol("a", positive=True), sp.Symbol("c", positive=True)
    q = sp.Symbol("q[tank]", real=True)
    pool = [*bond_variables(7), *bond_variables(12), *bond_variables("y_1"), q, a, sp.Symbol("Z"),
            a * bond_variables(3)[0], q / c, a * c * bond_variables(4)[1], 1 / a, q ** 2 / a, c * q,
            sp.sign(q), c * sp.sign(bond_variables(3)[1]), sp.Derivative(sp.Function("u")(t), t), -a * q,
            sp.sqrt(c) * q, sp.Function("p1", real=True)(t) / a, sp.exp(q), a * sp.exp(q), -q, 2 * q]
    rng = random.Random(4)
    for n in range(1, 6):
        for _ in range(60):
            xs = rng.sample(pool, n)
            for signs in itertools.islice(itertools.product((1, -1), repeat=n), 8):
                terms = list(zip(signs, xs))
                got, want = signed_sum(terms), sp.Add(*[s * x for s, x in terms])
                assert got == want and sp.srepr(got) == sp.srepr(want), terms
                assert got.is_Atom or sp.srepr(got.func(*got.args)) == sp.srepr(got)   # canonical: rebuilt the same
            got, want = difference(xs[0], xs[-1]), xs[0] - xs[-1]
            assert got == want and sp.srepr(got) == sp.srepr(want), xs
    x = pool[0]
    assert signed_sum([(1, x), (-1, x)]) == 0 and signed_sum([(2, x), (-1, pool[1])]) == 2 * x - pool[1]
    for b in (x, 2 * pool[1], pool[1] + q, sp.sin(q), sp.Integer(0), -a * q, sp.Float(1.5) * q, q + 1,
              a * pool[1] + c * sp.sign(pool[1]), x - q, -x + a * q - c * sp.sign(q), pool[2] + q, -pool[2] + q,
              q * (a + c), a * sp.exp(q) - q, 3 * q - a):
        assert sp.srepr(difference(pool[2], b)) == sp.srepr(pool[2] - b), b
        for i in range(0, len(pool), 3):
            assert sp.srepr(difference(pool[i], b)) == sp.srepr(pool[i] - b), (pool[i], b)
