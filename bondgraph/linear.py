"""Linear lines: ``c1*v1 + c2*v2 + ...`` kept as a tuple of terms instead of a sympy expression.

Most lines of a bond graph's state equations (:mod:`bondgraph.program`) are linear in earlier
names: a junction's balance, a transformer's ``m*x``, a gyrator's ``x/r``, a linear storage
element's ``I*dx``, and, in the forward differentiation that finds the coefficients of x', every
``d(line)/dx'`` assembled from such lines. Building each of them as a sympy ``Add`` of ``Mul``
(flattening, canonical ordering, hashing of every new node), substituting into it and printing it
with sympy's printer was most of the cost of deriving a large model. :class:`Linear` holds the
terms as they are: building, substituting, differentiating (the coefficient of a name) and
printing cost a few tuple operations per term. The coefficients stay sympy expressions (a
parameter, its inverse, a modulus), small and shared between lines, so that their substitution
and printing are done once each (``cache``).

A :class:`Linear` answers the few questions the program functions ask of a line (``free_symbols``,
``xreplace``, ``has``, ``atoms``, ``is_Atom``); :meth:`Linear.as_expr` gives the sympy
expression it stands for (for sympy's ``cse``, and for tests).

A 0-junction's balance ``f1 - f2 - f3``, the ``f2`` term given twice: merged, and a sum that
leaves one term of coefficient 1 reduces to its atom:

>>> import sympy as sp
>>> f1, f2, f3 = sp.symbols("f1 f2 f3")
>>> line = combine([(ONE, f1), (-ONE / 2, f2), (-ONE / 2, f2), (MINUS_ONE, f3)])
>>> line.as_expr() == f1 - f2 - f3
True
>>> combine([(ONE, f1), (ONE, f2), (MINUS_ONE, f2)])
f1
"""
from __future__ import annotations

from typing import Callable, Iterable, Mapping

import sympy as sp

ONE = sp.Integer(1)
ZERO = sp.Integer(0)
MINUS_ONE = sp.Integer(-1)

Term = tuple[sp.Expr, sp.Expr]          # (coefficient, atom): a constant term has the atom 1


class Linear:
    """``sum(c * v for c, v in terms)``: each ``v`` a sympy atom (a name, a symbol, or 1 for a
    constant term), each appearing once, each ``c`` a nonzero sympy expression. Immutable and
    hashable, so that a :class:`bondgraph.program.Program` names equal lines once. Build it with
    :func:`combine`, which also gives the plain atom or expression a sum reduces to."""
    __slots__ = ("terms", "_free", "_hash")
    is_Atom = False
    is_number = False

    def __init__(self, terms: tuple[Term, ...]):
        self.terms = terms
        self._free: frozenset | None = None
        self._hash = hash(("Linear", terms))

    def __hash__(self) -> int:
        return self._hash

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Linear) and self._hash == other._hash and self.terms == other.terms

    def __repr__(self) -> str:
        return f"Linear({' + '.join(f'({c})*{v}' for c, v in self.terms)})"

    @property
    def free_symbols(self) -> frozenset:
        """The symbols of the coefficients and the names the line reads."""
        if self._free is None:
            free: set = set()
            for c, v in self.terms:
                free |= c.free_symbols
                free |= v.free_symbols
            self._free = frozenset(free)
        return self._free

    def xreplace(self, mapping: Mapping, cache: dict | None = None) -> sp.Expr | Linear:
        """The line with ``mapping`` applied to its atoms and coefficients (a mapped atom must
        stay an atom: a name, a symbol or a number). ``cache`` remembers replaced coefficients
        across lines (valid while ``mapping`` only grows by keys no earlier coefficient holds)."""
        if cache is None:
            cache = {}
        pairs = []
        changed = False
        for c, v in self.terms:
            if c in cache:
                c2 = cache[c]
            else:
                c2 = cache[c] = c.xreplace(mapping)
            v2 = mapping.get(v, v)
            changed = changed or c2 is not c or v2 is not v
            pairs.append((c2, v2))
        return combine(pairs) if changed else self

    def has(self, *patterns) -> bool:
        """Whether a coefficient has any of ``patterns`` (the atoms are plain names)."""
        return any(c.has(*patterns) for c, _ in self.terms)

    def atoms(self, *types) -> set:
        """The atoms of ``types`` in the coefficients and among the names read."""
        found: set = set()
        for c, v in self.terms:
            found |= c.atoms(*types)
            found |= v.atoms(*types)
        return found

    def as_expr(self) -> sp.Expr:
        """The sympy expression of the line."""
        return sp.Add(*[c * v for c, v in self.terms])

    def code(self, text: Callable[[sp.Expr], str]) -> str:
        """The line as Python source, given ``text`` (a caching printer) for coefficients and names:
        ``v`` for a coefficient of 1, ``-v``, ``v/b`` for ``1/b``, ``-v/b``, else ``(c)*v``."""
        parts = []
        for c, v in self.terms:
            name = text(v) if v.is_Atom else f"({text(v)})"
            if v is ONE:
                parts.append(f"({text(c)})")
            elif c is ONE:
                parts.append(name)
            elif c is MINUS_ONE:
                parts.append(f"-{name}")
            elif c.is_Pow and c.exp is MINUS_ONE:
                parts.append(f"{name}/({text(c.base)})")
            elif c.is_Mul and len(c.args) == 2 and c.args[0] is MINUS_ONE and c.args[1].is_Pow \
                    and c.args[1].exp is MINUS_ONE:
                parts.append(f"-{name}/({text(c.args[1].base)})")
            else:
                parts.append(f"({text(c)})*{name}")
        return " + ".join(parts)


def combine(pairs: Iterable[tuple[sp.Expr, sp.Expr]]) -> sp.Expr | Linear:
    """``sum(c * v)`` over ``pairs`` of (coefficient, atom), as what it reduces to: 0, an atom
    (a single term ``1*v``), a sympy expression (a single constant term), or a :class:`Linear`.
    Terms reading the same atom are merged; zero terms are dropped; a number ``v`` becomes part
    of a constant term."""
    merged: dict[sp.Expr, sp.Expr] = {}
    for c, v in pairs:
        if v.is_Number:
            if _zero(v):
                continue
            c, v = (c if v is ONE else c * v), ONE
        if _zero(c):
            continue
        merged[v] = merged[v] + c if v in merged else c
    terms = tuple((c, v) for v, c in merged.items() if not _zero(c))
    if not terms:
        return ZERO
    if len(terms) == 1:
        c, v = terms[0]
        if c is ONE:
            return v
        if v is ONE:
            return c
    return Linear(terms)


def _zero(c: sp.Expr) -> bool:
    """c == 0, without sympify's cost on every comparison."""
    return c is ZERO or (c.is_Number and c == 0)


def replace(expr: sp.Expr | Linear, mapping: Mapping, cache: dict) -> sp.Expr | Linear:
    """``expr.xreplace(mapping)`` for a sympy expression or a :class:`Linear` (``cache``: see
    :meth:`Linear.xreplace`)."""
    if isinstance(expr, Linear):
        return expr.xreplace(mapping, cache)
    return expr.xreplace(mapping)


def as_expr(expr: sp.Expr | Linear) -> sp.Expr:
    """A sympy expression either way."""
    return expr.as_expr() if isinstance(expr, Linear) else expr
