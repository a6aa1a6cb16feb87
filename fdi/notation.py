r"""How a residual's expression is written for people: signals as plain names, their time
derivatives primed (``theta1'``) in text or dotted (``\dot{\theta}_1``) in LaTeX, efficiency
factors as Greek letters (``\beta_{\theta_{1}}``). It reads only expressions, so the ARR type
(:mod:`fdi.scaph`, whose notebook view uses it) and the tables (:mod:`fdi.tables`) both build on it.

>>> import sympy as sp
>>> from bondgraph.equations import signal
>>> from bondgraph.model import t
>>> expr = sp.Symbol("J") * sp.diff(signal("theta1"), t, 2) / sp.Symbol("beta_theta1")
>>> expr_text(expr)
"J*theta1''/beta_theta1"
>>> print(expr_latex(expr))
\frac{J \ddot{\theta}_{1}}{\beta_{\theta_{1}}}
"""
from __future__ import annotations

import re

import sympy as sp

from bondgraph.equations import is_signal

_DOTS = {1: "dot", 2: "ddot", 3: "dddot"}


def display(expr: sp.Expr, latex: bool) -> sp.Expr:
    """Signals as plain symbols, derivatives as theta1' (text) or a dot accent (LaTeX)."""
    rep: dict[sp.Expr, sp.Expr] = {}
    rates = [d for d in expr.atoms(sp.Derivative) if not is_signal(d.expr)]
    for d in rates:         # the rate of an expression estimated on data (bondgraph.rates): d/dt(...)
        order = sum(c for _, c in d.variable_count)
        inner = display(d.expr, latex)
        if latex:
            rep[d] = sp.Derivative(inner, (sp.Symbol("t"), order))
        else:
            rep[d] = sp.Function("d/dt" if order == 1 else f"d^{order}/dt^{order}")(inner)
    expr = expr.xreplace(rep)
    rep = {}
    for d in expr.atoms(sp.Derivative):
        if not is_signal(d.expr):
            continue
        name = d.expr.func.__name__
        order = sum(c for _, c in d.variable_count)
        if latex and order in _DOTS:
            m = re.match(r"^([A-Za-z]+?)(\d*)$", name)
            base, sub = (m.group(1), m.group(2)) if m else (name, "")
            rep[d] = sp.Symbol(f"{base}{_DOTS[order]}" + (f"_{sub}" if sub else ""))
        else:
            rep[d] = sp.Symbol(name + "'" * order)
    expr = expr.xreplace(rep)
    funcs = {f: sp.Symbol(f.func.__name__) for f in expr.atoms(sp.core.function.AppliedUndef) if is_signal(f)}
    return expr.xreplace(funcs)


def latex_names(expr: sp.Expr) -> dict[sp.Symbol, str]:
    """LaTeX names: an efficiency factor beta_theta1 as \\beta_{\\theta_{1}} (sympy would write
    \\beta_{theta1}, the word), beta_u_in as \\beta_{u_{in}}."""
    out = {}
    for s in expr.free_symbols:
        if isinstance(s, sp.Symbol) and s.name.startswith("beta_") and len(s.name) > 5:
            out[s] = r"\beta_{" + sp.latex(sp.Symbol(s.name[5:])) + "}"
    return out


def expr_text(expr: sp.Expr) -> str:
    """``expr`` as one line of text, derivatives of signals primed."""
    return str(display(expr, latex=False))


def expr_latex(expr: sp.Expr) -> str:
    """``expr`` in LaTeX, derivatives of signals dotted, efficiency factors as beta with a subscript."""
    e = display(expr, latex=True)
    return sp.latex(e, symbol_names=latex_names(e))
