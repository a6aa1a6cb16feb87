"""Time derivatives of expressions that may hold nonsmooth laws.

Engineering laws are often nonsmooth: an orifice ``sign(dp)*sqrt(abs(dp))``, Coulomb friction
``sign(v)``, a saturation ``min``/``max``, a diode ``Piecewise``. ``sympy.diff`` differentiates them
into ``DiracDelta`` and ``Heaviside`` terms, which no sampled signal can evaluate, and even where
the result is an ordinary function (d/dt sign(x) sqrt|x| = x'/(2 sqrt|x|)) it is singular where
the law's argument crosses zero. So a residual never differentiates a nonsmooth law
symbolically: :func:`ddt` leaves the rate of every additive term that holds one *unexpanded*,
``Derivative(term, t)``, and :mod:`fdi.residuals` evaluates the term on the data and
differentiates that signal numerically, with the same filter as the measurements. Smooth terms
are differentiated exactly, as before; parameters stay inside a rate left whole (a fault profile
Kv(t) in an orifice's law changes the term, and its rate with it); rates already left unexpanded are carried to the next
order (``Derivative(term, (t, 2))``), never expanded.

>>> import sympy as sp
>>> from bondgraph.model import t
>>> x = sp.Function("x", real=True)(t)
>>> ddt(3 * x ** 2)
6*x(t)*Derivative(x(t), t)
>>> k = sp.Symbol("k", positive=True)
>>> ddt(2 * k * sp.sign(x) * sp.sqrt(sp.Abs(x)) + x)
2*Derivative(k*sqrt(Abs(x(t)))*sign(x(t)), t) + Derivative(x(t), t)
>>> ddt(ddt(sp.sign(x) * x ** 2))
Derivative(x(t)**2*sign(x(t)), (t, 2))
"""
from __future__ import annotations

import sympy as sp

from .model import t

NONSMOOTH = (sp.sign, sp.Abs, sp.Heaviside, sp.Min, sp.Max, sp.Piecewise, sp.floor, sp.ceiling)


def is_nonsmooth(expr: sp.Expr) -> bool:
    """Whether ``expr`` applies a nonsmooth function to something that varies in time."""
    return any(f.has(t) for f in expr.atoms(*NONSMOOTH))


def _is_signal(expr: sp.Expr) -> bool:
    return isinstance(expr, sp.core.function.AppliedUndef) and expr.args == (t,)


def _order(d: sp.Derivative) -> int:
    return sum(c for v, c in d.variable_count if v == t)


def ddt(expr: sp.Expr, n: int = 1) -> sp.Expr:
    """The ``n``-th time derivative of ``expr``: exact for smooth terms, left unexpanded
    (``Derivative(term, (t, n))``) for every additive term that holds a nonsmooth function of
    time; an unexpanded rate of a non-signal expression is never expanded (its order grows)."""
    if n == 0:
        return expr
    if not expr.has(t):
        return sp.Integer(0)
    out = []
    for term in sp.Add.make_args(expr):
        if not term.has(t):
            continue
        number, varying = term.as_coeff_Mul()
        if varying.is_Add:
            out.append(number * ddt(varying, n))
        elif is_nonsmooth(varying):
            # parameters stay inside: under a fault profile (a clogging orifice, Kv(t)) the rate
            # of the whole term is what the physics has, continuous where a stored quantity is
            out.append(number * _rate(varying, n))
        else:
            out.append(number * _smooth(varying, n))
    return sp.Add(*out)


def _rate(expr: sp.Expr, n: int) -> sp.Expr:
    """``Derivative(expr, (t, n))``, merged with a rate ``expr`` already is."""
    if isinstance(expr, sp.Derivative) and not _is_signal(expr.expr) and set(expr.variables) == {t}:
        return sp.Derivative(expr.expr, (t, _order(expr) + n))
    return sp.Derivative(expr, (t, n))


def _smooth(expr: sp.Expr, n: int) -> sp.Expr:
    """sympy's derivative, with every unexpanded rate of a non-signal expression held as an
    opaque function of time so that sympy does not expand it."""
    rates = [d for d in expr.atoms(sp.Derivative) if not _is_signal(d.expr)]
    if not rates:
        return sp.diff(expr, t, n)
    held = {d: sp.Function(f"__rate{i}", real=True)(t) for i, d in enumerate(rates)}
    back = {}
    out = sp.diff(expr.xreplace(held), t, n)
    for d, h in held.items():
        for k in range(n, 0, -1):
            back[sp.Derivative(h, (t, k))] = sp.Derivative(d.expr, (t, _order(d) + k))
        back[h] = d
    for k in range(n, 0, -1):      # highest first: Derivative(h, t) inside Derivative(h, (t, 2)) is not an atom
        out = out.xreplace({a: v for a, v in back.items() if isinstance(a, sp.Derivative) and _order(a) == k})
    return out.xreplace({h: d for d, h in held.items()})
