import pytest
import sympy as sp

from bondgraph.expressions import ExpressionError, parse_expression

X, Y = sp.symbols("x y", real=True)
SYMS = {"x": X, "y": Y}


def test_arithmetic_and_functions():
    e = parse_expression("sign(x)*sqrt(abs(x))/y + 2**3 - -x", SYMS)
    assert sp.simplify(e - (sp.sign(X) * sp.sqrt(sp.Abs(X)) / Y + 8 + X)) == 0


def test_numbers_pass_through():
    assert parse_expression(2.5, SYMS) == sp.Float(2.5)
    assert parse_expression(3, SYMS) == 3


@pytest.mark.parametrize("text, fragment", [
    ("__import__('os').system('true')", "calling '__import__('os').system' is not allowed in"),
    ("x.__class__", "not allowed"),
    ("(lambda: 1)()", "calling 'lambda: 1' is not allowed in '(lambda: 1)()'; only the functions abs, acos,"),
    ("open('f')", "function 'open' is not allowed"),
    ("x ^ 2", "use ** for powers"),
    ("'abc'", "only numbers"),
    ("sin(x, y=1)", "keyword"),
    ("z + 1", "undefined symbol 'z'"),
    ("sin", "is a function"),
    ("x +", "cannot parse"),
    ("[x, y]", "not allowed"),
])
def test_forbidden_expressions(text, fragment):
    with pytest.raises(ExpressionError, match=None) as info:
        parse_expression(text, SYMS)
    assert fragment in str(info.value)


def test_misspelt_symbol_gets_a_suggestion():
    with pytest.raises(ExpressionError, match="did you mean 'kf2'"):
        parse_expression("kf3*f", {"kf2": X, "f": Y})
