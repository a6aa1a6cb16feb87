"""Safe parsing of model expressions into sympy, against a whitelist of symbols and functions.

Model files are data: an expression such as ``kf2*f + Fu2*sign(f)`` is parsed with Python's
``ast`` module and rebuilt node by node into sympy. Only numbers, the names the caller allows,
the arithmetic operators and the functions in :data:`FUNCTIONS` are accepted; anything else
(attributes, subscripts, lambdas, strings, keyword arguments, ...) is refused with a message.
Nothing here calls ``eval``, ``exec`` or ``sympify`` on the text.

Limits that keep a hostile file from exhausting time or memory (docs/model-format.md): at most
:data:`MAX_LENGTH` characters, a syntax tree at most :data:`MAX_DEPTH` levels deep, finite number
literals, and numeric exponents of magnitude at most :data:`MAX_EXPONENT` (``9**9**9`` would
otherwise be evaluated exactly by sympy, a number with 370 million digits).

>>> import sympy as sp
>>> R, f = sp.symbols("R f")
>>> parse_expression("R*f*abs(f)", {"R": R, "f": f})         # a quadratic valve law
R*f*Abs(f)
>>> parse_expression("f.real", {"f": f})
Traceback (most recent call last):
...
bondgraph.expressions.ExpressionError: 'f.real' is not allowed in an expression ('f.real')
>>> parse_expression("9**9**9", {})
Traceback (most recent call last):
...
bondgraph.expressions.ExpressionError: exponent 387420489 too large in '9**9**9' (numeric exponents must be within +-100)
"""
from __future__ import annotations

import ast
import math
import unicodedata
from collections.abc import Mapping

import sympy as sp

from .canonical import product, quotient


FUNCTIONS: dict[str, object] = {
    "sin": sp.sin, "cos": sp.cos, "tan": sp.tan, "asin": sp.asin, "acos": sp.acos,
    "atan": sp.atan, "atan2": sp.atan2, "sinh": sp.sinh, "cosh": sp.cosh, "tanh": sp.tanh,
    "asinh": sp.asinh, "acosh": sp.acosh, "atanh": sp.atanh,
    "exp": sp.exp, "log": sp.log, "sqrt": sp.sqrt, "abs": sp.Abs, "sign": sp.sign,
    "min": sp.Min, "max": sp.Max, "heaviside": sp.Heaviside,
}
CONSTANTS: dict[str, sp.Expr] = {"pi": sp.pi, "E": sp.E}

_BINOPS = {
    ast.Add: lambda a, b: a + b,
    ast.Sub: lambda a, b: a - b,
    ast.Mult: lambda a, b: product([a, b]),      # a * b as sympy builds it, without Mul's general flatten
    ast.Div: lambda a, b: quotient(a, b),
    ast.Pow: lambda a, b: a ** b,
}


MAX_LENGTH = 2000
MAX_DEPTH = 100
MAX_EXPONENT = 100


class ExpressionError(ValueError):
    """An expression uses something outside the whitelist; the message says what to change."""


def parse_expression(text: str | int | float, symbols: Mapping[str, sp.Expr]) -> sp.Expr:
    """Parse ``text`` into a sympy expression using only ``symbols``, numbers and FUNCTIONS."""
    if isinstance(text, bool):
        raise ExpressionError("expected a number or an expression, not true/false")
    if isinstance(text, (int, float)):
        return sp.Float(text) if isinstance(text, float) else sp.Integer(text)
    if not isinstance(text, str):
        raise ExpressionError(f"expected an expression string, got {type(text).__name__}")
    src = text.strip()
    if not src:
        raise ExpressionError("empty expression")
    if len(src) > MAX_LENGTH:
        raise ExpressionError(f"expression longer than {MAX_LENGTH} characters; name parts of it under definitions")
    try:
        tree = ast.parse(src, mode="eval")
    except SyntaxError as exc:
        raise ExpressionError(f"cannot parse '{_short(src)}': {exc.msg}") from None
    except (RecursionError, MemoryError):
        raise ExpressionError(f"expression nested too deeply ('{_short(src)}')") from None
    if len(src) > MAX_DEPTH // 2 and _depth(tree.body) > MAX_DEPTH:     # each level takes a character:
        # a text of at most MAX_DEPTH / 2 characters is shallower than MAX_DEPTH (the walk, for the
        # 5 000 laws of a 10 000-element chain, cost a fifth of their parsing)
        raise ExpressionError(f"expression nested deeper than {MAX_DEPTH} levels ('{_short(src)}'); "
                              "name parts of it under definitions")
    expr = _build(tree.body, symbols, _short(src))
    if expr.has(sp.zoo, sp.nan):
        raise ExpressionError(f"'{_short(src)}' divides by zero")
    _doubles(expr, _short(src))
    return expr


def _short(src: str, limit: int = 80) -> str:
    """The expression as messages quote it: one line, at most ``limit`` characters."""
    return src if len(src) <= limit else src[:limit - 3] + "..."


def _depth(root: ast.AST) -> int:
    """Levels of the syntax tree, counted without recursion (a 1000-deep tree must not overflow)."""
    deepest, stack = 0, [(root, 1)]
    while stack:
        node, d = stack.pop()
        deepest = max(deepest, d)
        if d <= MAX_DEPTH:
            stack.extend((child, d + 1) for child in ast.iter_child_nodes(node))
    return deepest


def _power(base: sp.Expr, exponent: sp.Expr, src: str) -> sp.Expr:
    """base**exponent, refusing numeric exponents beyond MAX_EXPONENT (a power tower would be
    evaluated exactly)."""
    v = _doubles(exponent)                 # (in doubles: float() of exp(exp(exp(x - x + 100))) ran for minutes)
    if v is not None and not abs(v) <= MAX_EXPONENT:
        raise ExpressionError(f"exponent {_short(str(exponent), 20)} too large in '{src}' "
                              f"(numeric exponents must be within +-{MAX_EXPONENT})")
    return base ** exponent


# the functions as floats, for the constant parts' range check (:func:`_doubles`)
_FLOATS = {"sin": math.sin, "cos": math.cos, "tan": math.tan, "asin": math.asin, "acos": math.acos,
           "atan": math.atan, "atan2": math.atan2, "sinh": math.sinh, "cosh": math.cosh, "tanh": math.tanh,
           "asinh": math.asinh, "acosh": math.acosh, "atanh": math.atanh,
           "exp": math.exp, "log": math.log, "sqrt": math.sqrt, "abs": abs,
           "sign": lambda x: float((x > 0) - (x < 0)), "min": min, "max": max,
           "heaviside": lambda x, h=0.5: 0.0 if x < 0 else (1.0 if x > 0 else h)}
MAX_CONSTANT = 1e300
_BY_CLASS = {FUNCTIONS[name]: f for name, f in _FLOATS.items()}      # sympy's function -> its double


def _atom_double(e: sp.Basic) -> float | None:
    """A number, pi or E as a double (inf past a double's range), NaN for the imaginary unit; None
    for a symbol."""
    if e.is_Number:
        try:
            return float(e)
        except OverflowError:
            return math.inf
    if e is sp.pi or e is sp.E:
        return math.pi if e is sp.pi else math.e
    return math.nan if e is sp.I else None


def _node_double(e: sp.Basic, args: list[float]) -> float | None:
    """``e`` (a sum, product, power or allowed function) in doubles from its arguments' doubles: an
    overflow inf, a value outside a function's domain (or not real) NaN; None for anything else."""
    try:
        if e.is_Add:
            return math.fsum(args)
        if e.is_Mul:
            return math.prod(args)
        if e.is_Pow:
            return math.pow(*args)
        f = _BY_CLASS.get(type(e))
        return None if f is None else float(f(*args))
    except OverflowError:
        return math.inf
    except (ValueError, ZeroDivisionError, TypeError):
        return math.nan


def _post_order(expr: sp.Expr):
    """Every part of ``expr``, each after its arguments, without recursion (a deep expression
    would exhaust Python's stack)."""
    stack = [(expr, False)]
    while stack:
        e, seen = stack.pop()
        if not e.is_Atom and not seen:
            stack.append((e, True))
            stack.extend((a, False) for a in e.args)
            continue
        yield e


def _doubles(expr: sp.Expr, src: str | None = None) -> float | None:
    """The value of ``expr`` in doubles where it names no symbol (None where it does), walked once
    bottom-up: never sympy's exact evaluation, which ran for minutes on exp(exp(exp(100))). With
    ``src``, every part that names no symbol (as sympy built it: parts merged, symbols that
    cancelled, definitions substituted) must be a real double within MAX_CONSTANT, or an
    ExpressionError names it: the residuals it enters would be inf or NaN on every sample (a
    diagnosis blind without an error)."""
    values: dict[int, float | None] = {}
    for e in _post_order(expr):
        if e.is_Atom:
            v = _atom_double(e)
        else:
            args = [values.get(id(a)) for a in e.args]
            v = None if any(a is None for a in args) else _node_double(e, args)
        values[id(e)] = v
        if src is not None and _outside(v):
            shown = e.evalf(3) if e.is_Number else e
            raise ExpressionError(f"the constant '{_short(str(shown), 40)}' of '{src}' (as the parts combine) "
                                  f"{_outside(v)}; the residuals would be inf or NaN on every sample")
    return values[id(expr)]


def left_domain(expr: sp.Expr, values: Mapping[sp.Symbol, float]) -> sp.Expr | None:
    """The first part of ``expr`` (bottom-up) that leaves its function's domain, or is not real,
    once the symbols of ``values`` take their values (a model's parameters): each of its arguments
    a finite double, it is NaN. None where no such part exists; a part that reads any other
    symbol (a law's variable, a signal) is not evaluated. A law written ``k*q*log(-k)`` at k = 1e6
    is complex on every sample: its residuals would be NaN everywhere, and a diagnosis blind to
    them reads them as silent (a user trial).

    >>> k, q = sp.symbols("k q")
    >>> left_domain(k*q*sp.log(-k), {k: 1e6})
    log(-k)
    >>> left_domain(k*q*sp.log(k), {k: 1e6}) is None
    True
    """
    got: dict[int, float | None] = {}
    for e in _post_order(expr):
        if e.is_Atom:
            v = values.get(e) if e.is_Symbol else _atom_double(e)
            v = None if v is None else float(v)
        else:
            args = [got.get(id(a)) for a in e.args]
            if any(a is None for a in args):
                v = None
            elif e.is_Pow and args[0] == 0 and args[1] < 0:
                v = math.inf        # a divisor of 0: not this check's (the loader names it as such)
            else:
                v = _node_double(e, args)
            if v is not None and v != v and all(math.isfinite(a) for a in args):
                return e        # (inf - inf, 0 * inf: a parameter of .inf or 0, which the loader names as such)
        got[id(e)] = v
    return None


_LIMITED = (sp.log, sp.asin, sp.acos, sp.acosh, sp.atanh)


def limited_parts(expr: sp.Expr) -> list[sp.Expr]:
    """The parts of ``expr`` defined on part of the real line only: logarithms, asin, acos, acosh,
    atanh, roots and other powers of an exponent not an integer.

    >>> f = sp.Symbol("f")
    >>> limited_parts(3*f*sp.sqrt(f - 1000))
    [sqrt(f - 1000)]
    >>> limited_parts(f**2 + sp.exp(f))
    []
    """
    return [e for e in sp.preorder_traversal(expr)
            if isinstance(e, _LIMITED) or (e.is_Pow and e.exp.is_integer is not True)]


def _outside(v: float | None) -> str:
    """What is wrong with a constant part's double ``v``: '' when it is a real double within range
    (or no constant: None)."""
    if v is None or abs(v) <= MAX_CONSTANT:
        return ""
    return "is not a real number" if v != v else f"is beyond {MAX_CONSTANT:g} in magnitude"


def _build(node: ast.AST, symbols: Mapping[str, sp.Expr], src: str) -> sp.Expr:
    if isinstance(node, ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
            raise ExpressionError(f"only numbers are allowed as constants in '{src}'")
        if (abs(node.value) > 10 ** 300 if isinstance(node.value, int)          # (a float may not hold it)
                else not math.isfinite(node.value) or abs(node.value) > 1e300):
            raise ExpressionError(f"number {_short(str(node.value), 20)} out of range in '{src}' (at most 1e300)")
        return sp.Integer(node.value) if isinstance(node.value, int) else sp.Float(node.value)
    if isinstance(node, ast.Name):
        name = node.id                               # Python's parser gives identifiers in NFKC form
        if name in symbols:
            return symbols[name]
        written = [k for k in symbols if unicodedata.normalize("NFKC", k) == name]
        if len(written) == 1:                        # a name written in another form ('µ' read as 'μ')
            return symbols[written[0]]
        if name in CONSTANTS:
            return CONSTANTS[name]
        if name in FUNCTIONS:
            raise ExpressionError(f"'{name}' is a function; call it as {name}(...) in '{src}'")
        raise ExpressionError(f"undefined symbol '{name}' in '{src}'{_suggest(name, symbols)}")
    if isinstance(node, ast.BinOp):
        op = _BINOPS.get(type(node.op))
        if op is None:
            hint = " (use ** for powers)" if isinstance(node.op, ast.BitXor) else ""
            raise ExpressionError(f"operator not allowed in '{src}'{hint}")
        left, right = _build(node.left, symbols, src), _build(node.right, symbols, src)
        if isinstance(node.op, ast.Pow):
            return _power(left, right, src)
        return op(left, right)
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        value = _build(node.operand, symbols, src)
        return -value if isinstance(node.op, ast.USub) else value
    if isinstance(node, ast.Call):
        if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
            allowed = ", ".join(sorted(FUNCTIONS))
            if not isinstance(node.func, ast.Name):     # a call of an attribute, a lambda, a call's result
                called = ast.unparse(node.func)
                called = called if len(called) <= 40 else called[:37] + "..."
                raise ExpressionError(f"calling '{called}' is not allowed in '{src}'; only the functions {allowed} "
                                      "may be called, by name")
            raise ExpressionError(f"function '{node.func.id}' is not allowed in '{src}' (allowed: {allowed})")
        if node.keywords:
            raise ExpressionError(f"keyword arguments are not allowed in '{src}'")
        args = [_build(a, symbols, src) for a in node.args]
        try:
            out = FUNCTIONS[node.func.id](*args)  # type: ignore[operator]
        except TypeError:
            raise ExpressionError(f"wrong number of arguments to {node.func.id} in '{src}'") from None
        wrong = _outside(_doubles(out))    # a constant call checked where it is made: sympy works on it next
        if wrong:
            raise ExpressionError(f"'{_short(ast.unparse(node), 40)}' {wrong} in '{src}'; the residuals would be inf "
                                  "or NaN on every sample")
        return out
    raise ExpressionError(f"'{ast.unparse(node)}' is not allowed in an expression ('{src}')")


def _suggest(name: str, symbols: Mapping[str, sp.Expr]) -> str:
    import difflib

    close = difflib.get_close_matches(name, list(symbols), n=1)
    if close:
        return f"; did you mean '{close[0]}'?"
    return ("; define it under parameters, inputs, modes, sensors or definitions (a definition may use the "
            "definitions listed before it, none after it or itself)")
