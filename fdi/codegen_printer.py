"""Residual kernels as C: sympy's C99 code printer, with common subexpressions, numpy's semantics.

A residual kernel is a sympy expression of named values (signals and their derivatives,
parameters, mode variables, rates of stored quantities). :func:`c_function_body` prints it as C99
statements: ``sympy.cse`` takes the common subexpressions out (as ``lambdify(..., cse=True)``
does for the numpy kernels :mod:`fdi.residuals` evaluates), each symbol is printed as the C
expression the caller maps it to, and the functions keep the meaning numpy gives them, where C's
differs:

- ``sign(x)``: numpy gives NaN for NaN (C's idiom ``(x > 0) - (x < 0)`` gives 0): a helper;
- ``Heaviside(x)``: numpy's ``heaviside(x, 1/2)``: a helper;
- ``Min``/``Max``: numpy's ``amin``/``amax`` propagate NaN (C's ``fmin``/``fmax`` drop it): helpers;
- ``x**(1/3)``: numpy's power gives NaN below 0 (sympy prints C's ``cbrt``, which does not): ``pow``;
- pi and E: their double values (C99 has no ``M_PI``; POSIX adds it).

A function C has no counterpart for (``DiracDelta``, the derivative of a step; a function sympy
left unevaluated) raises :class:`CodegenError` naming it: the generated code would not compile,
or would compute something else.

>>> import sympy as sp
>>> x, k = sp.symbols("x k", real=True)
>>> body = c_function_body(k * sp.sign(x) * sp.sqrt(abs(x)) + sp.sqrt(abs(x)), {x: "s_x", k: "p->k"})
>>> print("\\n".join(body.lines))
const double c0 = sqrt(fabs(s_x));
return c0*p->k*fdi_sign(s_x) + c0;
>>> sorted(body.helpers)
['fdi_sign']
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import sympy as sp
from sympy.printing.c import C99CodePrinter

from .errors import UsageError

# sympy's functions a residual may hold that print as C99 with numpy's meaning (helpers where needed)
SUPPORTED = (sp.sin, sp.cos, sp.tan, sp.asin, sp.acos, sp.atan, sp.atan2, sp.sinh, sp.cosh, sp.tanh,
             sp.asinh, sp.acosh, sp.atanh,
             sp.exp, sp.log, sp.Abs, sp.sign, sp.Min, sp.Max, sp.Heaviside, sp.Piecewise)

HELPERS = {
    "fdi_sign": """static double fdi_sign(double x)
{
    /* numpy's sign: -1, 0 or 1, and NaN for NaN */
    return x > 0.0 ? 1.0 : x < 0.0 ? -1.0 : x;
}""",
    "fdi_heaviside": """static double fdi_heaviside(double x, double at_zero)
{
    /* numpy's heaviside(x, at_zero): NaN for NaN */
    return isnan(x) ? x : x > 0.0 ? 1.0 : x < 0.0 ? 0.0 : at_zero;
}""",
    "fdi_min": """static double fdi_min(double a, double b)
{
    /* numpy's minimum: NaN when either is NaN (C's fmin drops it) */
    return isnan(a) || isnan(b) ? a + b : a < b ? a : b;
}""",
    "fdi_max": """static double fdi_max(double a, double b)
{
    /* numpy's maximum: NaN when either is NaN (C's fmax drops it) */
    return isnan(a) || isnan(b) ? a + b : a > b ? a : b;
}""",
}


class CodegenError(UsageError):
    """A model or setting the C generator cannot translate: one line naming what and why (exit 2)."""


@dataclass(frozen=True)
class Body:
    """C statements computing one expression: ``const double cK = ...;`` lines, then ``return ...;``
    (or an assignment to ``target``); the helpers they call; the symbols they read."""
    lines: tuple[str, ...]
    helpers: frozenset[str]
    reads: frozenset[sp.Symbol]


class _Printer(C99CodePrinter):
    """C99 with every symbol printed as the caller maps it, and numpy's meaning kept (module doc)."""

    def __init__(self, names: Mapping[sp.Symbol, str]) -> None:
        super().__init__({"strict": True})
        self.names = dict(names)
        self.helpers: set[str] = set()

    def _print_Symbol(self, expr: sp.Symbol) -> str:            # noqa: N802 (sympy's names)
        try:
            return self.names[expr]
        except KeyError:
            raise CodegenError(f"no value for {expr.name} in the generated code") from None

    _print_Dummy = _print_Symbol

    def _print_sign(self, expr) -> str:
        self.helpers.add("fdi_sign")
        return f"fdi_sign({self._print(expr.args[0])})"

    def _print_Heaviside(self, expr) -> str:
        self.helpers.add("fdi_heaviside")
        at_zero = expr.args[1] if len(expr.args) > 1 else sp.Rational(1, 2)
        return f"fdi_heaviside({self._print(expr.args[0])}, {self._print(sp.Float(float(at_zero)))})"

    def _fold(self, name: str, args) -> str:
        self.helpers.add(name)
        out = self._print(args[0])
        for a in args[1:]:
            out = f"{name}({out}, {self._print(a)})"
        return out

    def _print_Min(self, expr) -> str:
        return self._fold("fdi_min", expr.args)

    def _print_Max(self, expr) -> str:
        return self._fold("fdi_max", expr.args)

    def _print_Pow(self, expr, rational=False) -> str:
        if expr.exp.is_Rational and not expr.exp.is_Integer and expr.exp.q != 2:
            return f"pow({self._print(expr.base)}, {self._print(sp.Float(float(expr.exp)))})"
        return super()._print_Pow(expr)

    def _print_Float(self, expr) -> str:
        return _double(float(expr))

    def _print_NumberSymbol(self, expr) -> str:
        return _double(float(expr))

    _print_Pi = _print_NumberSymbol
    _print_Exp1 = _print_NumberSymbol
    _print_EulerGamma = _print_NumberSymbol
    _print_GoldenRatio = _print_NumberSymbol
    _print_Catalan = _print_NumberSymbol


def _double(x: float) -> str:
    """A double as a C literal that reads back as the same double (Python's shortest repr)."""
    if x != x:
        return "NAN"
    if x in (float("inf"), float("-inf")):
        return "INFINITY" if x > 0 else "(-INFINITY)"
    text = repr(x)
    if not any(c in text for c in ".en"):
        text += ".0"
    return text if x >= 0 else f"({text})"


double = _double


def unsupported(expr: sp.Expr) -> list[str]:
    """The functions and operations in ``expr`` the C printer does not translate, by name."""
    bad = set()
    for f in expr.atoms(sp.Function):
        if not isinstance(f, SUPPORTED):
            bad.add(type(f).__name__)
    for node in sp.preorder_traversal(expr):
        if isinstance(node, (sp.Derivative, sp.Integral, sp.Subs)):
            bad.add(type(node).__name__)
        elif node.is_number and node.has(sp.I):
            bad.add("complex numbers")
    return sorted(bad)


def c_function_body(expr: sp.Expr, names: Mapping[sp.Symbol, str], target: str | None = None) -> Body:
    """``expr`` as C99 statements (see the module doc); every free symbol must be in ``names``."""
    bad = unsupported(expr)
    if bad:
        raise CodegenError(f"{', '.join(bad)}")
    temps = sp.numbered_symbols("c", cls=sp.Dummy)
    replacements, (reduced,) = sp.cse(expr, symbols=temps)
    mapping = dict(names)
    for i, (sym, _) in enumerate(replacements):
        mapping[sym] = f"c{i}"
    printer = _Printer(mapping)
    lines = [f"const double c{i} = {printer.doprint(value)};" for i, (_, value) in enumerate(replacements)]
    result = printer.doprint(reduced)
    lines.append(f"return {result};" if target is None else f"{target} = {result};")
    reads = frozenset(s for s in expr.free_symbols if s in names)
    return Body(tuple(lines), frozenset(printer.helpers), reads)
