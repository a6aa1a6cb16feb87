"""Straight-line programs: state equations as named lines, compiled to Python once.

:func:`bondgraph.equations.resolve` can write every bond variable as a line ``name = small
expression of earlier names`` instead of one expression nested through the whole model. The
simulator then works on lines: the implicit equations ``x' = r(x, x')`` are linear in x', their
coefficients ``dr_i/dx'_j`` come from forward differentiation line by line (only the lines that
depend on some x'), and lambdify prints the lines as they are (``cse`` given the program). Every
step is linear in the size of the model; no matrix of symbolic derivatives is formed.
"""
from __future__ import annotations

from typing import Callable, Iterable, Sequence

import networkx as nx
import sympy as sp
from sympy.printing.numpy import NumPyPrinter
from sympy.printing.pycode import PythonCodePrinter

Line = tuple[sp.Symbol, sp.Expr]


def name_line(expr: sp.Expr, program: list[Line], prefix: str = "__v") -> sp.Expr:
    """``expr`` itself when it is an atom, else a new name for it appended to ``program``."""
    if expr.is_Atom:
        return expr
    name = sp.Symbol(f"{prefix}{len(program)}")
    program.append((name, expr))
    return name


def substitute(program: Sequence[Line], mapping: dict) -> list[Line]:
    """The program with ``mapping`` applied to every line (each line is small: linear in total)."""
    return [(s, e.xreplace(mapping)) for s, e in program]


def line_diff(expr: sp.Expr, var: sp.Symbol) -> sp.Expr:
    """d expr/d var of one small expression (a line, a local law). The laws of junctions and
    two-ports are the variable itself or a product with it once (x, a*x, x/m): their derivative
    is read off directly, which spares sympy's general ``diff`` machinery on most of a model."""
    if expr == var:
        return sp.Integer(1)
    if expr.is_Mul and var in expr.args and sum(f.has(var) for f in expr.args) == 1:
        return sp.Mul(*[f for f in expr.args if f != var])
    return sp.diff(expr, var)


def linear_coefficients(program: Sequence[Line], unknowns: Sequence[sp.Symbol]
                        ) -> tuple[list[Line], dict[sp.Symbol, dict[sp.Symbol, sp.Expr]]]:
    """Forward differentiation of ``program`` with respect to ``unknowns``, for lines linear in them.

    Returns new lines (the non-trivial coefficients, named) and, for every line that depends on
    an unknown, ``{unknown: coefficient}``. Raises ValueError when a coefficient itself depends on
    an unknown (the program is not linear in them)."""
    grad: dict[sp.Symbol, dict[sp.Symbol, sp.Expr]] = {u: {u: sp.Integer(1)} for u in unknowns}
    lines: list[Line] = []
    for name, expr in program:
        deps = [m for m in expr.free_symbols if m in grad]
        if not deps:
            continue
        total: dict[sp.Symbol, sp.Expr] = {}
        for m in deps:
            d = line_diff(expr, m)
            if d.free_symbols & grad.keys():
                raise ValueError(f"not linear in {', '.join(str(u) for u in unknowns)}")
            for u, c in grad[m].items():
                total[u] = total.get(u, sp.Integer(0)) + d * c
        grad[name] = {u: name_line(c, lines, "__g") for u, c in total.items() if c != 0}
    return lines, grad


def triangular_order(coefficients: dict[int, dict[int, sp.Expr]], n: int) -> list[int] | None:
    """An order in which x'_i can be solved one by one (every x'_j it needs solved before),
    or None when the equations are coupled in a cycle and need a linear solve."""
    g = nx.DiGraph()
    g.add_nodes_from(range(n))
    g.add_edges_from((j, i) for i, row in coefficients.items() for j in row if j != i)
    try:
        return list(nx.topological_sort(g))
    except nx.NetworkXUnfeasible:
        return None


def needed_lines(program: Sequence[Line], outputs: Sequence[sp.Expr]) -> list[Line]:
    """The lines of ``program`` that ``outputs`` need, in order."""
    needed: set = set().union(*(o.free_symbols for o in outputs))
    kept: list[Line] = []
    for name, expr in reversed(program):
        if name in needed:
            kept.append((name, expr))
            needed |= expr.free_symbols
    kept.reverse()
    return kept


def compile_lines(args: Iterable, program: Sequence[Line], outputs: Sequence[sp.Expr], modules: str) -> Callable:
    """lambdify with the program as its common subexpressions: printed line by line, never nested,
    terms in the order they have (sorting them for display is most of the cost of printing).
    Lines that no output needs are dropped. ``modules``: "math" (scalars) or "numpy" (arrays)."""
    kept = needed_lines(program, outputs)
    printer = (NumPyPrinter if modules == "numpy" else PythonCodePrinter)(
        {"fully_qualified_modules": False, "inline": True, "allow_unknown_functions": True, "order": "none"})
    return sp.lambdify(list(args), list(outputs), modules=modules, printer=printer, cse=lambda exprs: (kept, exprs))
