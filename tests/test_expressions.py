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


@pytest.mark.parametrize("text, fragment", [
    ("x*exp(exp(exp(100)))", "'exp(exp(100))' is beyond 1e+300 in magnitude"),   # held `tables` for minutes
    ("x*exp(710)", "'exp(710)' is beyond 1e+300"),
    ("x*1e300*1e300", "the constant '1.00e+600' of 'x*1e300*1e300' (as the parts combine) is beyond"),
    ("exp(690)*x*exp(690)", "the constant 'exp(1380)'"),                           # merged by sympy
    ("(x*exp(8))**100", "the constant 'exp(800)'"),                                # a power of a part in range
    ("x*exp(800*x/x)", "'exp(800 * x / x)' is beyond"),                            # a symbol that cancels
    ("1e300*x + 5*x**2 + exp(exp(exp(x-x+100)))", "'exp(exp(x - x + 100))' is beyond"),   # minutes in evalf
    ("x**exp(exp(exp(x-x+100)))", "is beyond"),                                    # float() of the exponent too
    ("x*" + "9" * 400, "out of range"),                                            # not a float
    ("x*log(-1)", "'log(-1)' is not a real number"),
    ("x*log(x-x-1)", "is not a real number"),
    ("x*sqrt(-2) + y", "'sqrt(-2)' is not a real number"),
    ("x*(1/0)", "divides by zero"),
])
def test_a_constant_part_beyond_a_double_is_refused(text, fragment):
    """A part of an expression that names no symbol is a number the residuals carry on every sample:
    beyond a double's range (1e300 here) or not a real number, they would be inf or NaN everywhere
    (a diagnosis that sees nothing, without an error), and sympy would work exactly on what a double
    cannot hold. The range is a double's, computed in doubles (an independent reference: math)."""
    with pytest.raises(ExpressionError, match=None) as err:
        parse_expression(text, SYMS)
    assert fragment in str(err.value)


def test_constant_parts_within_a_double_pass():
    assert parse_expression("x*exp(-800)", SYMS) == X * sp.exp(-800)       # underflows to 0: harmless
    assert parse_expression("x*2**100 + sin(1) + max(1, 2)", SYMS) == X * 2 ** 100 + sp.sin(1) + 2
    assert parse_expression("x*1e300*1e-300", SYMS) == 1.0 * X


def test_every_function_has_its_double_for_the_range_check():
    """The constant parts are computed in doubles by their math twins: one per allowed function."""
    from bondgraph.expressions import _FLOATS, FUNCTIONS
    assert set(_FLOATS) == set(FUNCTIONS)
