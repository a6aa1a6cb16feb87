"""Products and substitutions in sympy's canonical form, built without its general machinery.

A long chain's derivation builds tens of thousands of small products (a law's ``x/C`` or
``m*e2``, a transformer's modulus times the value passed to it) and substitutes resolved values
into small laws. ``sympy.Mul`` reaches each product through its general ``flatten`` (numeric
bases, rational powers of numbers, infinities, non-commuting factors, repeated bases): about half
of the residual derivation of a 10 000-element chain. :func:`product` builds the same object
directly where none of that can apply, and :func:`substitute` is ``xreplace`` with its products
so built. Anything else goes to sympy as before, so every expression is the one sympy builds
(tests/test_canonical.py compares ``srepr`` with sympy's own on every law and value of the shipped
models and of random products).
"""
from __future__ import annotations

from typing import Mapping, Sequence

import sympy as sp
from sympy.core.mul import _mulsort

_PLAIN = (sp.Symbol, sp.core.function.AppliedUndef, sp.Derivative, sp.UnevaluatedExpr, sp.Add)


def _base(x: sp.Expr) -> sp.Expr | None:
    """The base ``Mul.flatten`` files ``x`` under where that is ``x`` itself or, for a rational
    power of such a factor, its base; None for anything flatten may treat otherwise (numbers,
    powers of numbers or of products, non-commuting factors)."""
    if x.is_Pow:
        b, e = x.args
        return b if e.is_Rational and e not in (0, 1) and _plain(b) else None
    return x if _plain(x) else None


def _plain(x: sp.Expr) -> bool:
    """A commuting factor that ``Mul.flatten`` keeps whole, with exponent 1: a symbol, a signal,
    a derivative, a grouped product, a sum, or a function that is its own base (``sign(f)``)."""
    if x.is_commutative is not True:
        return False
    if isinstance(x, _PLAIN):
        return True
    return isinstance(x, sp.Function) and x.as_base_exp()[1] is sp.S.One


def product(factors: Sequence[sp.Expr]) -> sp.Expr:
    """``sympy.Mul(*factors)``, built directly where the factors (products among them taken
    apart) are rational numbers and :func:`_plain` factors or their rational powers, each base
    once, and a sum is never multiplied by a number other than 1 (which sympy distributes):
    the numbers multiplied into one coefficient in front, the rest in sympy's canonical order.

    >>> x, y = sp.symbols("x y", real=True)
    >>> m = sp.Symbol("m", positive=True)
    >>> p = product([sp.Integer(-1), x, 1 / m, y + 1])
    >>> p, sp.srepr(p) == sp.srepr(sp.Mul(-1, x, 1 / m, y + 1))
    (-x*(y + 1)/m, True)
    """
    coeff = sp.S.One
    seq: list[sp.Expr] = []
    bases: set = set()
    add = False
    for f in factors:
        for g in (f.args if f.is_Mul else (f,)):
            if g.is_Rational:
                if g.is_zero:
                    return sp.Mul(*factors)
                coeff = coeff * g
                continue
            b = _base(g)
            if b is None or b in bases:
                return sp.Mul(*factors)
            bases.add(b)
            add = add or g.is_Add
            seq.append(g)
    if add and coeff is not sp.S.One:
        return sp.Mul(*factors)
    if not seq:
        return coeff
    if coeff is sp.S.One and len(seq) == 1:
        return seq[0]
    _mulsort(seq)
    if coeff is not sp.S.One:
        seq.insert(0, coeff)
    return sp.Mul._from_args(seq, True)


def quotient(a: sp.Expr, b: sp.Expr) -> sp.Expr:
    """``a / b`` as sympy writes it (``Mul(a, Pow(b, -1))``), the product by :func:`product`."""
    return product([a, sp.Pow(b, sp.S.NegativeOne)])


_WALK = (sp.Mul, sp.Add, sp.Pow, sp.Function)


def substitute(expr: sp.Expr, rule: Mapping) -> sp.Expr:
    """``expr.xreplace(rule)``, its products rebuilt by :func:`product`. Sums, powers and
    functions are rebuilt as xreplace does (``func(*args)``), and any other node is left to
    xreplace itself. For small laws into which large values are put: the values are not walked.

    >>> x, y = sp.symbols("x y", real=True)
    >>> n = sp.Symbol("n", positive=True)
    >>> e = x / n + sp.sign(x)
    >>> substitute(e, {x: 2 * y}), sp.srepr(substitute(e, {x: 2 * y})) == sp.srepr(e.xreplace({x: 2 * y}))
    (sign(y) + 2*y/n, True)
    """
    return _substitute(expr, rule)[0] if rule else expr


def _substitute(expr: sp.Expr, rule: Mapping) -> tuple[sp.Expr, bool]:
    """:func:`substitute` as ``Basic._xreplace``: the value and whether the rule applied below
    (a node is rebuilt then, as xreplace rebuilds it, even where the new arguments are the old)."""
    if expr in rule:
        return rule[expr], True
    if not isinstance(expr, _WALK):
        return expr._xreplace(rule)
    args, changed = [], False
    for a in expr.args:
        a, hit = _substitute(a, rule)
        args.append(a)
        changed |= hit
    if not changed:
        return expr, False
    return (product(args) if expr.is_Mul else expr.func(*args)), True
