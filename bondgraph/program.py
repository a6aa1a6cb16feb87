"""Straight-line programs: state equations as named lines, compiled to Python once.

:func:`bondgraph.equations.resolve` can write every bond variable as a line ``name = small
expression of earlier names`` instead of one expression nested through the whole model. The
simulator then works on lines: the implicit equations ``x' = r(x, x')`` are linear in x', their
coefficients ``dr_i/dx'_j`` come from forward differentiation line by line (only the lines that
depend on some x'), and the lines are printed as they are into the body of a Python function.
Every step is linear in the size of the model; no matrix of symbolic derivatives is formed.
"""
from __future__ import annotations

import math
from typing import Callable, Sequence

import networkx as nx
import numpy
import sympy as sp
from sympy.printing.numpy import NumPyPrinter
from sympy.printing.pycode import PythonCodePrinter

Line = tuple[sp.Symbol, sp.Expr]


class Program:
    """Lines in order, each a name for a small expression of atoms and earlier names."""

    def __init__(self, prefix: str = "__v"):
        self.lines: list[Line] = []
        self.prefix = prefix
        self._names: dict[sp.Expr, sp.Symbol] = {}

    def name(self, expr: sp.Expr) -> sp.Expr:
        """``expr`` itself when it is an atom, else its name: the existing one when the same
        expression was named before (two bonds carrying one value compute it once), else a new line."""
        if expr.is_Atom:
            return expr
        if expr not in self._names:
            self._names[expr] = sp.Symbol(f"{self.prefix}{len(self.lines)}")
            self.lines.append((self._names[expr], expr))
        return self._names[expr]


def substitute(lines: Sequence[Line], mapping: dict) -> tuple[list[Line], dict]:
    """``mapping`` applied to every line (each is small: linear in total). A line that becomes an
    atom (a term that vanishes at x' = 0, say) is folded into the lines after it: returns the
    remaining lines and ``mapping`` extended by the folded names, to apply to outputs too."""
    mapping = dict(mapping)
    out: list[Line] = []
    for name, expr in lines:
        expr = expr.xreplace(mapping)
        if expr.is_Atom:
            mapping[name] = expr
        else:
            out.append((name, expr))
    return out, mapping


def line_diff(expr: sp.Expr, var: sp.Symbol) -> sp.Expr:
    """d expr/d var of one small expression (a line, a local law). The laws of junctions and
    two-ports are the variable itself, a product with it once (x, a*x, x/m) or sums of such
    terms: their derivative is read off directly, which spares sympy's general ``diff`` machinery on most of a model."""
    if expr == var:
        return sp.Integer(1)
    if expr.is_Add:
        return sp.Add(*[line_diff(a, var) for a in expr.args if a.has(var)])
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
    coefficients = Program("__g")
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
        grad[name] = {u: coefficients.name(c) for u, c in total.items() if c != 0}
    return coefficients.lines, grad


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


def _shared_calls(lines: list[Line]) -> list[Line]:
    """Common subexpressions of the lines that call functions (a modulus such as
    1/(r cos(beta + theta)) enters every relation through its element) as lines of their own,
    each placed before its first use. Lines of plain arithmetic are left alone: cse over
    thousands of them would cost more than it saves."""
    calls = [i for i, (_, e) in enumerate(lines) if e.atoms(sp.Function)]
    if not calls:
        return lines
    shared, reduced = sp.cse([lines[i][1] for i in calls], symbols=sp.numbered_symbols("__c"))
    pending = dict(shared)
    order = [s for s, _ in shared]
    replaced = dict(zip(calls, reduced))
    out: list[Line] = []
    for i, (name, expr) in enumerate(lines):
        if i in replaced:
            expr = replaced[i]
            want = {s for s in expr.free_symbols if s in pending}
            if want:
                for s in reversed(order):              # a shared term may use earlier ones
                    if s in want:
                        want |= {u for u in pending[s].free_symbols if u in pending}
                out += [(s, pending.pop(s)) for s in order if s in want]
        out.append((name, expr))
    return out


def compile_lines(args: Sequence, program: Sequence[Line], outputs: Sequence[sp.Expr], modules: str) -> Callable:
    """A Python function of ``args`` (symbols, or lists of symbols passed as one tuple) returning
    the list of ``outputs``, with the program's lines as its body: printed one by one, never
    nested, terms in the order they have (sorting them for display is most of the cost of
    printing sympy). Lines that no output needs are dropped. ``modules``: "math" (scalars) or
    "numpy" (arrays, elementwise)."""
    kept = _shared_calls(needed_lines(program, outputs))
    printer = (NumPyPrinter if modules == "numpy" else PythonCodePrinter)(
        {"fully_qualified_modules": True, "inline": True, "allow_unknown_functions": True, "order": "none"})
    names, body = [], []
    for k, arg in enumerate(args):
        if isinstance(arg, (list, tuple)):
            names.append(f"_arg{k}")
            if arg:
                body.append(f"{', '.join(str(s) for s in arg)}, = _arg{k}")
        else:
            names.append(str(arg))
    body += [f"{name} = {printer.doprint(expr)}" for name, expr in kept]
    body.append(f"return [{', '.join(printer.doprint(o) for o in outputs)}]")
    source = f"def generated({', '.join(names)}):\n" + "".join(f"    {line}\n" for line in body)
    namespace = {"math": math, "numpy": numpy}
    exec(compile(source, "<bondgraph.program>", "exec"), namespace)
    return namespace["generated"]
