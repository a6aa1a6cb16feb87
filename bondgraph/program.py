"""Straight-line programs: state equations as named lines, compiled to Python once.

:func:`bondgraph.equations.resolve` can write every bond variable as a line ``name = small
expression of earlier names`` instead of one expression nested through the whole model. The
simulator then works on lines: the implicit equations ``x' = r(x, x')`` are linear in x', their
coefficients ``dr_i/dx'_j`` come from forward differentiation line by line (only the lines that
depend on some x'), and the lines are printed as they are into the body of a Python function.
Every step is linear in the size of the model; no matrix of symbolic derivatives is formed.
A line's right-hand side is a sympy expression or, for the many linear ones, a
:class:`bondgraph.linear.Linear` sum of terms, which every function here handles term by term.
"""
from __future__ import annotations

import functools
import math
from typing import Callable, Sequence

import numpy
import sympy as sp
from sympy.printing.numpy import NumPyPrinter
from sympy.printing.pycode import PythonCodePrinter

from .linear import Linear, as_expr, combine, replace

Line = tuple[sp.Symbol, "sp.Expr | Linear"]     # name = expression (sympy, or a Linear sum of names)


class Program:
    """Lines in order, each a name for a small expression of atoms and earlier names."""

    def __init__(self, prefix: str = "__v"):
        self.lines: list[Line] = []
        self.prefix = prefix
        self._names: dict[sp.Expr, sp.Symbol] = {}

    def name(self, expr: sp.Expr | Linear) -> sp.Expr:
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
    cache: dict = {}
    for name, expr in lines:
        expr = replace(expr, mapping, cache)
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
        if isinstance(expr, Linear):
            deps = [(m, d) for d, m in expr.terms if m in grad]
        else:
            deps = [(m, None) for m in expr.free_symbols if m in grad]
        if not deps:
            continue
        total: dict[sp.Symbol, list] = {}
        for m, d in deps:
            if d is None:
                d = line_diff(expr, m)
            if d.free_symbols & grad.keys():
                raise ValueError(f"not linear in {', '.join(str(u) for u in unknowns)}")
            for u, c in grad[m].items():
                total.setdefault(u, []).append((d, c))
        named = {u: coefficients.name(combine(pairs)) for u, pairs in total.items()}
        grad[name] = {u: c for u, c in named.items() if c is not sp.S.Zero}
    return coefficients.lines, grad


def triangular_order(coefficients: dict[int, dict[int, sp.Expr]], n: int) -> list[int] | None:
    """An order in which x'_i can be solved one by one (every x'_j it needs solved before),
    or None when the equations are coupled in a cycle and need a linear solve."""
    import networkx as nx                   # here, not at import: bgfdi's warm start needs no networkx
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
    thousands of them would cost more than it saves; so are the calling lines when no call
    occurs twice (a friction law sign(f_i) per element of a chain: nothing to share)."""
    known: dict[sp.Expr, bool] = {}
    calls = [i for i, (_, e) in enumerate(lines) if _calls(e, known)]
    exprs = [as_expr(lines[i][1]) for i in calls]
    seen: set = set()
    for node in (n for e in exprs for n in sp.preorder_traversal(e) if isinstance(n, sp.Function)):
        if node in seen:
            break
        seen.add(node)
    else:
        return lines
    shared, reduced = sp.cse(exprs, symbols=sp.numbered_symbols("__c"))
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


def _calls(expr: sp.Expr | Linear, known: dict[sp.Expr, bool]) -> bool:
    """Whether ``expr`` calls a function; ``known`` remembers the answer for coefficients, which
    many linear lines share."""
    if isinstance(expr, Linear):
        return any(_calls(c, known) for c, _ in expr.terms)
    if expr.is_Atom:
        return False
    if expr not in known:
        known[expr] = bool(expr.atoms(sp.Function))
    return known[expr]


def _code(printer: PythonCodePrinter, expr: sp.Expr) -> str:
    """``printer.doprint(expr)`` for one line's expression; without doprint's preparation (an
    assignment target, real parts of unevaluated products) where it has nothing to do."""
    if expr.is_Symbol:
        return printer._print(expr)
    return printer.doprint(expr) if expr.has(sp.re) else printer._print(expr)


class _RealPowers(PythonCodePrinter):
    """Python's printer, with a power of an exponent not an integer as ``math.pow``: Python's
    ``(-8.0)**(1/3)`` is a complex number, which flowed on into math's functions (a TypeError) or
    out as a complex output; ``math.pow`` raises a ValueError there, which the compiled function
    turns into NaN (:func:`compile_lines`), as numpy does."""

    def _print_Pow(self, expr, rational=False):
        if expr.exp.is_integer or expr.exp == sp.S.Half or expr.exp == -sp.S.Half:
            return super()._print_Pow(expr, rational=rational)       # (sqrt: math.sqrt, a domain check too)
        return f"math.pow({self._print(expr.base)}, {self._print(expr.exp)})"


def compile_lines(args: Sequence, program: Sequence[Line], outputs: Sequence[sp.Expr], modules: str) -> Callable:
    """A Python function of ``args`` (symbols, or lists of symbols passed as one tuple) returning
    the list of ``outputs``, with the program's lines as its body: printed one by one, never
    nested, terms in the order they have (sorting them for display is most of the cost of
    printing sympy). Lines that no output needs are dropped. ``modules``: "math" (scalars) or
    "numpy" (arrays, elementwise)."""
    kept = _shared_calls(needed_lines(program, outputs))
    printer = (NumPyPrinter if modules == "numpy" else _RealPowers)(
        {"fully_qualified_modules": True, "inline": True, "allow_unknown_functions": True, "order": "none"})
    names, body = [], []
    for k, arg in enumerate(args):
        if isinstance(arg, (list, tuple)):
            names.append(f"_arg{k}")
            if arg:
                body.append(f"{', '.join(_code(printer, s) for s in arg)}, = _arg{k}")
        else:
            names.append(_code(printer, arg))
    printed: dict[sp.Expr, str] = {}

    def text(expr: sp.Expr) -> str:            # coefficients and names recur: each printed once
        if expr not in printed:
            printed[expr] = _code(printer, expr)
        return printed[expr]
    lines = [f"{text(name)} = {expr.code(text) if isinstance(expr, Linear) else _code(printer, expr)}"
             for name, expr in kept]
    lines.append(f"return [{', '.join(_code(printer, o) for o in outputs)}]")
    if modules == "math":
        # a law outside its domain at this point (a gas spring's (V0/(V0 - q))**n past its shell: a
        # complex power, which math's functions refuse with a TypeError; math.sqrt(-1)) is NaN, as
        # numpy gives: the integrator steps back from it, verify leaves the run out (it raised)
        lines = ["try:"] + [f"    {line}" for line in lines] + [
            "except (ValueError, TypeError, ZeroDivisionError, OverflowError):",
            f"    return [math.nan] * {len(outputs)}"]
    body += lines
    source = f"def generated({', '.join(names)}):\n" + "".join(f"    {line}\n" for line in body)
    namespace = {"math": math, "numpy": numpy, "functools": functools}   # numpy's printer: max/min as functools.reduce
    exec(compile(source, "<bondgraph.program>", "exec"), namespace)
    return namespace["generated"]
