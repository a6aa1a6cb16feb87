"""The physics of a bond graph, stated once: each law as one causality-free equation.

Every constitutive law (R, C, I, TF, GY and their modulated forms), junction law and source is
written here, and only here, as an :class:`Equation` ``expr = 0`` in the bond variables ``e[k]``,
``f[k]`` (and a storage element's energy variable ``q[name]`` / ``p[name]``), with the variables
it can be solved for explicitly (``solutions``). Everything else is derived from these:

- :func:`bondgraph.structure.equations` assembles them into the model's equation system
  (matchings, MSO sets, sequential residuals);
- :func:`bondgraph.equations.relations` solves each for the output its causal stroke gives
  (SCAPH for the ARRs, integral causality for the simulator), and
  :func:`bondgraph.causality.dependency_graph` reads which variable each output depends on;
- the simulator reads a resistor's conductance form and a storage element's energy variable
  from them (:mod:`bondgraph.simulation`).

What a causal form adds and no equation states is kept where it is used: a storage element in
derivative causality differentiates the solution for its energy variable (kept whole as
``Derivative(q(x), t)`` where its law is nonsmooth or carries a fault parameter:
:mod:`bondgraph.rates`); a sensor's signal bond in the diagnostic bond graph
(:func:`bondgraph.equations.relations`); a controlled junction switched off as a whole
(:mod:`bondgraph.modes`).

>>> import sympy as sp
>>> from bondgraph.model import Element
>>> e1, f1 = bond_variables(1)
>>> e2, f2 = bond_variables(2)
>>> m = sp.Symbol("m", positive=True)
>>> eq_e, eq_f = two_port_equations(Element("tf", "TF", modulus=m), [(1, "a", 1), (2, "b", -1)])
>>> eq_e.expr, solve_for(eq_e, e2)       # e1 = m e2; effort in at bond 1 gives e2
(e[1] - e[2]*m, e[1]/m)
"""
from __future__ import annotations

import functools
import operator
import weakref
from dataclasses import dataclass, field
from typing import Callable, Iterable, Mapping, Sequence

import sympy as sp
from sympy.core.add import _addsort   # sympy's canonical order of a sum's terms (signed_sum)

from .canonical import product, quotient, substitute
from .model import LAW_VARIABLES, Element, Model, t

Port = tuple  # (bond key, neighbour, sign): sign +1 where power flows into the node (bondgraph.graph)
Sub = Callable[[sp.Expr], sp.Expr]


def _same(x: sp.Expr) -> sp.Expr:
    return x


@dataclass(frozen=True)
class Equation:
    """``expr = 0``. ``solutions`` gives the variables it may be solved for, explicitly.
    A differential constraint (``differential = (x, dx)``: dx = d/dt x) has ``expr`` dx - x'
    only symbolically; the derivation treats it by differentiation (or integration).
    ``linear``: ``expr`` is linear in its variables by construction (a junction, a transformer
    or gyrator, a law given by a parameter), so a solution is a weighted sum of the others."""
    name: str
    node: str
    expr: sp.Expr
    variables: frozenset
    solutions: Mapping[sp.Symbol, sp.Expr] = field(default_factory=dict)
    differential: tuple[sp.Symbol, sp.Symbol] | None = None
    linear: bool = False

    @property
    def symbols(self) -> frozenset:
        """Parameters, efficiency factors and mode variables in the equation (no unknowns)."""
        return frozenset(s for s in self.expr.free_symbols if s not in self.variables and s != t)


@functools.lru_cache(maxsize=1 << 16)
def bond_variables(bond) -> tuple[sp.Symbol, sp.Symbol]:
    """The effort and flow of a bond (a power bond's id or a sensor's signal bond), ``e[k]``, ``f[k]``.
    Kept (a symbol with assumptions costs about 10 us to make, and a chain asks 20 times per bond)."""
    return sp.Symbol(f"e[{bond}]", real=True), sp.Symbol(f"f[{bond}]", real=True)


def coefficient(expr: sp.Expr, var: sp.Symbol) -> sp.Expr:
    """d expr / d var. A sum whose terms hold ``var`` as a plain factor (every law of this module
    that is linear) is read term by term, as ``sympy.diff`` would build it, at a fraction of its
    cost (a junction of n bonds is solved for each of them); anything else goes to ``sympy.diff``."""
    out = []
    for term in sp.Add.make_args(expr):
        if term == var:
            out.append(sp.Integer(1))
        elif term.is_Mul and var in term.args:
            others = [f for f in term.args if f != var]
            if len(others) != len(term.args) - 1 or any(f.has(var) for f in others):
                return sp.diff(expr, var)
            out.append(functools.reduce(operator.mul, others, sp.Integer(1)))
        elif term.has(var):
            return sp.diff(expr, var)
    return sp.Add.fromiter(out)


def _plain_coefficient(expr: sp.Expr, var: sp.Symbol) -> bool | None:
    """Whether ``var`` has a nonzero coefficient free of ``var`` in ``expr``, read without
    building it where ``var`` is a plain factor of exactly one term (a junction's, transformer's
    or linear law's equation): True when that term's other factors are free of ``var``
    (symbols and numbers here are never 0). None where it takes :func:`coefficient`."""
    found = None
    for term in sp.Add.make_args(expr):
        if term == var:
            hit = True
        elif term.is_Mul and var in term.args:
            hit = all(f.is_Symbol and f != var or f.is_Number and f != 0 for f in term.args if f != var) \
                and term.args.count(var) == 1
            if not hit:
                return None
        elif term.is_Symbol or term.is_Number:
            continue
        elif term.has(var):
            return None
        else:
            continue
        if found is not None:
            return None
        found = hit
    return found


def solve_linear(expr: sp.Expr, var: sp.Symbol) -> sp.Expr | None:
    """var from expr = 0 when expr is linear in var with a coefficient free of unknowns:
    ``-rest / coefficient``. A law's sum with ``var`` a plain factor of one term (junctions,
    transformers, linear laws: :func:`_split`) is solved without rebuilding the sum
    (:func:`_solve_split`); anything else by :func:`solve_linear_plain`. Both give the same
    expression (tests/test_laws.py checks every law of the shipped models both ways)."""
    if not expr.has(var):
        return None
    split = _split(expr, var)
    if split is not None:
        return _solve_split(expr, var, *split)
    return solve_linear_plain(expr, var)


def solve_linear_plain(expr: sp.Expr, var: sp.Symbol) -> sp.Expr | None:
    """:func:`solve_linear` by plain sympy arithmetic: the coefficient, ``var`` replaced by 0,
    ``-rest / coefficient``."""
    if not expr.has(var):
        return None
    coeff = coefficient(expr, var)
    if coeff.has(var) or coeff == 0:
        return None
    rest = expr.xreplace({var: sp.Integer(0)})
    return -rest / coeff


def _simple(term: sp.Expr) -> bool:
    """A symbol, or a product of a number and symbols (a law's term)."""
    return term.is_Symbol or term.is_Mul and all(a.is_Symbol or a.is_Number for a in term.args)


def _split(expr: sp.Expr, var: sp.Symbol) -> tuple[sp.Expr | None, list[sp.Expr], list[sp.Expr]] | None:
    """``(c, factors, others)`` where ``expr`` is a sum whose one term holding ``var`` holds it as
    a plain factor times ``factors``, symbols and nonzero numbers (``c``: the number where it is
    the only one, else None), and ``others`` (the other terms, in their order) are free of
    ``var`` and :func:`_simple`. None for anything else."""
    if not expr.is_Add:
        return None
    found, c, factors, others = False, None, [], []
    for term in expr.args:
        if term is var or term == var:
            if found:
                return None
            found, c = True, sp.S.One
        elif term.is_Mul and var in term.args:
            factors = [a for a in term.args if a != var]
            if found or len(factors) != len(term.args) - 1 or \
                    not all(a.is_Symbol or a.is_Number and a != 0 for a in factors):
                return None
            found = True
            c = factors[0] if len(factors) == 1 and factors[0].is_Number else None
        elif _simple(term):
            others.append(term)
        else:
            return None
    return (c, factors, others) if found else None


def _solve_split(expr: sp.Expr, var: sp.Symbol, c: sp.Expr | None, factors: list[sp.Expr],
                 others: list[sp.Expr]) -> sp.Expr:
    """:func:`solve_linear_plain` of a :func:`_split` sum, with the same operations on the same
    values where they are not identities: ``rest`` (``expr`` with ``var`` at 0) is the sum of the
    other terms, which are already in canonical order (a sum's terms minus one need no sorting);
    a coefficient of 1 divides nothing (``-rest``), and one of -1 negates twice (``rest``: the
    other terms are numbers times symbols, whose double negation is themselves). A single other
    term over a product of symbols (a transformer's ``e1 - m e2`` for ``e2``) is a monomial, one
    product: sympy's product of monomials has one canonical form whichever way it is reached."""
    if not others:
        rest = sp.S.Zero
    elif len(others) == 1:
        rest = others[0]
    else:
        rest = sp.Add._from_args(others)
    if c is sp.S.One:
        return -rest
    if c is sp.S.NegativeOne:
        return rest
    if c is None and len(others) == 1:
        k, inverse = sp.S.NegativeOne, []
        for f in factors:
            if f.is_Number:
                k = k / f
            else:
                inverse.append(sp.Pow(f, sp.S.NegativeOne))
        return product([k, rest, *inverse])
    coeff = c if c is not None else coefficient(expr, var)
    return -rest / coeff


def solve_for(eq: Equation, var: sp.Symbol) -> sp.Expr | None:
    """``var`` from ``eq``: its explicit solution, else None (the law gives it in no closed form)."""
    return eq.solutions.get(var)


class _Solutions(Mapping):
    """An equation's explicit solutions: those given, and those of the ``linear`` variables,
    each solved (:func:`solve_linear`) only when asked for. A causal form needs one solution per
    equation, the dependency graph none: solving every law for every variable up front cost
    most of the derivation of a long chain. Which variables it gives (``in``, iteration: the
    structure of the equations) is read from the coefficient alone, without solving."""
    __slots__ = ("_expr", "_given", "_linear", "_solved", "_solvable", "_keys")

    def __init__(self, expr: sp.Expr, given: dict, linear: Sequence) -> None:
        self._expr, self._given = expr, given
        self._linear = [v for v in dict.fromkeys(linear) if v not in given]
        self._solved: dict = {}
        self._solvable: dict = {}
        self._keys: tuple | None = None

    def _solve(self, v) -> sp.Expr | None:
        if v not in self._solved:
            self._solved[v] = solve_linear(self._expr, v)
        return self._solved[v]

    def _gives(self, v) -> bool:
        """Whether :func:`solve_linear` would give ``v``: the same tests, without the solution."""
        if v not in self._solvable:
            if v in self._solved:
                self._solvable[v] = self._solved[v] is not None
            elif (plain := _plain_coefficient(self._expr, v)) is not None:
                self._solvable[v] = plain
            else:
                coeff = coefficient(self._expr, v) if self._expr.has(v) else sp.Integer(0)
                self._solvable[v] = coeff != 0 and not coeff.has(v)
        return self._solvable[v]

    def __getitem__(self, v) -> sp.Expr:
        if v in self._given:
            return self._given[v]
        if v in self._linear and self._solve(v) is not None:
            return self._solved[v]
        raise KeyError(v)

    def __contains__(self, v) -> bool:
        return v in self._given or (v in self._linear and self._gives(v))

    def __iter__(self):
        if self._keys is None:
            self._keys = tuple(self._given) + tuple(v for v in self._linear if self._gives(v))
        return iter(self._keys)

    def __len__(self) -> int:
        return sum(1 for _ in self)

    def __repr__(self) -> str:
        return repr(dict(self))


def equation(name: str, node: str, expr: sp.Expr, variables: Iterable, solutions=None, linear: Sequence = (),
             differential=None, is_linear: bool = False) -> Equation:
    """An :class:`Equation`, solved linearly for each variable of ``linear`` it gives no solution
    for; variables ``expr`` no longer holds (a mode at 0 removes some) are left out."""
    present = expr.free_symbols
    variables = frozenset(v for v in variables if v in present)
    given = {v: x for v, x in (solutions or {}).items() if v in variables}
    sol = _Solutions(expr, given, [v for v in linear if v in variables]) if linear else given
    return Equation(name, node, expr, variables, sol, differential, bool(linear) or is_linear)


def _factor(x: sp.Expr) -> bool:
    """A factor a sympy product keeps as it is: a symbol, a rational power of one, or a
    function or derivative (``sign(f)``, ``u(t)``, ``Derivative(q, t)``) that is its own base."""
    if x.is_Symbol:
        return True
    if x.is_Pow:
        return x.base.is_Symbol and x.exp.is_Rational
    return isinstance(x, (sp.Function, sp.Derivative)) and x.as_base_exp() == (x, sp.S.One)


def _term(x: sp.Expr) -> bool:
    """A law's term: a :func:`_factor` or a product of them, with no number or with -1."""
    if not x.is_Mul:
        return _factor(x)
    args = x.args[1:] if x.args[0] is sp.S.NegativeOne else x.args
    return all(_factor(a) for a in args)


def _negated(x: sp.Expr) -> sp.Expr:
    """``-x`` of a :func:`_term`, as sympy writes it (a -1 in front, or taken off)."""
    if x.is_Mul and x.args[0] is sp.S.NegativeOne:
        rest = x.args[1:]
        return rest[0] if len(rest) == 1 else sp.Mul._from_args(rest)
    return sp.Mul._from_args((sp.S.NegativeOne,) + (x.args if x.is_Mul else (x,)))


def signed_sum(terms: Sequence[tuple[int, sp.Expr]]) -> sp.Expr:
    """``sum(sign * x)`` for signs +-1 and :func:`_term` terms that differ other than in sign
    (bond variables, ``m*e[2]``, ``q/C``, ``c*sign(f)``): the expression ``sympy.Add`` builds
    (the signed terms in its canonical order), without its general flatten, which rebuilds every
    negated term (a 10 000-element chain's laws are 20 000 such sums). Anything else is
    ``sympy.Add(*(sign * x))``.

    >>> x, y, z = sp.symbols("x y z", real=True)
    >>> e = signed_sum([(1, z), (-1, x), (-1, y)])
    >>> e, e == sp.Add(z, -x, -y), sp.srepr(e) == sp.srepr(z - x - y)
    (-x - y + z, True, True)
    """
    fast = _signed_sum(terms)
    return fast if fast is not None else sp.Add(*[s * x for s, x in terms])


def _signed_sum(terms: Sequence[tuple[int, sp.Expr]]) -> sp.Expr | None:
    """:func:`signed_sum` where it applies, else None."""
    if len(terms) < 2 or not all(s in (1, -1) and _term(x) for s, x in terms):
        return None
    args = [x if s == 1 else _negated(x) for s, x in terms]
    unsigned = {_negated(a) if a.is_Mul and a.args[0] is sp.S.NegativeOne else a for a in args}
    if len(unsigned) != len(args):          # terms that sympy would collect
        return None
    _addsort(args)
    return sp.Add._from_args(args)


def difference(a: sp.Expr, b: sp.Expr) -> sp.Expr:
    """``a - b``: as :func:`signed_sum` where ``a`` is a :func:`_term` and ``b`` one or a sum of
    them (sympy distributes the minus over a sum), else by sympy's own ``a - b``."""
    bs = b.args if b.is_Add else (b,)
    fast = _signed_sum([(1, a)] + [(-1, x) for x in bs]) if _term(a) else None
    return fast if fast is not None else a - b


def junction_equations(model: Model, node: str, ports: Sequence[Port], reference, sub: Sub = _same) -> list[Equation]:
    """A junction's law: its common variable (effort of a 0, flow of a 1) equal on every bond, and
    its balance ``sum(sign * total) = 0``, written against the ``reference`` bond.

    A controlled junction (diagnostic hybrid bond graph) multiplies each *output*, every bond but
    the reference (its strong bond), by its mode variable: the first output is ``a x_ref``
    (never solved for the reference: a division by a), the others equal the first, and the
    balance gives the reference's total as ``a`` times the others'. One form serves every mode."""
    junction = model.junctions[node]
    common_i, total_i = (0, 1) if junction.base == "0" else (1, 0)
    c = "e" if common_i == 0 else "f"
    var = {k: bond_variables(k) for k, _, _ in ports}
    sign = {k: s for k, _, s in ports}
    out: list[Equation] = []
    if junction.controlled:
        s = reference
        a = sub(model.symbols[junction.mode])
        outputs = [k for k in var if k != s]
        for n, k in enumerate(outputs):
            x, xs = var[k][common_i], var[s][common_i]
            if n == 0:      # the output times the mode: never solved for the strong side (division by a)
                out.append(equation(f"{node}.{c}{k}", node, x - a * xs, {x, xs}, solutions={x: a * xs}, is_linear=True))
            else:           # outputs equal one another in every mode
                x0 = var[outputs[0]][common_i]
                out.append(equation(f"{node}.{c}{k}", node, x - x0, {x, x0}, linear=[x, x0]))
        ys = var[s][total_i]
        others = [sign[k] * var[k][total_i] for k in var if k != s]
        value = a * (-sign[s]) * sp.Add(*others)
        vs = {ys} | {var[k][total_i] for k in var if k != s}     # a mode at 0 leaves ys alone (equation)
        out.append(equation(f"{node}.balance", node, ys - value, vs, solutions={ys: value}, is_linear=True))
        return out
    for k, _, _ in ports:
        if k == reference:
            continue
        x, x0 = var[k][common_i], var[reference][common_i]
        out.append(equation(f"{node}.{c}{k}", node, difference(x, x0), {x, x0}, linear=[x, x0]))
    ys = [var[k][total_i] for k, _, _ in ports]
    expr = signed_sum([(sign[k], var[k][total_i]) for k, _, _ in ports])
    out.append(equation(f"{node}.balance", node, expr, set(ys), linear=ys))
    return out


def source_equation(node: str, kind: str, bond, value: sp.Expr, sub: Sub = _same) -> Equation:
    """A source's law: the effort (Se, MSe) or flow (Sf, MSf) of its bond is ``value``."""
    e, f = bond_variables(bond)
    x = e if kind in ("Se", "MSe") else f
    value = sub(value)
    return equation(node, node, x - value, {x}, solutions={x: value})


def _law(law: sp.Expr, local: str, value: sp.Expr, sub: Sub) -> sp.Expr:
    return sub(substitute(law, {LAW_VARIABLES[local]: value}))


def resistor_equation(model: Model, el: Element, bond, sub: Sub = _same) -> Equation:
    """An R's law, ``e = R f`` (a parameter) or the laws the model gives: ``effort`` (e from f,
    resistance causality) and ``flow`` (f from e, conductance causality). A law given both ways
    and a parameter: each direction by its law where given, by the parameter otherwise."""
    e, f = bond_variables(bond)
    sol: dict = {}
    r = model.symbols[el.parameter] if el.parameter is not None else None
    if "effort" in el.laws:
        sol[e] = _law(el.laws["effort"], "f", f, sub)
    elif r is not None:
        sol[e] = sub(product([r, f]))
    if "flow" in el.laws:
        sol[f] = _law(el.laws["flow"], "e", e, sub)
    elif r is not None:
        sol[f] = sub(quotient(e, r))
    expr = difference(e, sol[e]) if e in sol else difference(f, sol[f])
    return equation(el.name, el.name, expr, {e, f}, solutions=sol, is_linear=not el.laws)


def energy_variable(el: Element) -> sp.Symbol:
    """The energy variable of a storage element: ``q[name]`` of a C, ``p[name]`` of an I."""
    return sp.Symbol(f"{'q' if el.kind == 'C' else 'p'}[{el.name}]", real=True)


STORAGE_KEYS = {"C": ("effort", "displacement", "q", "e"), "I": ("flow", "momentum", "p", "f")}
"""A storage element's law keys and variables: its law (co-energy of energy), its inverse (energy of
co-energy), the energy variable, the co-energy variable."""


def has_inverse(el: Element) -> bool:
    """Whether a storage element's law gives its energy variable of its co-energy variable in closed
    form (q of e for a C, p of f for an I): derivative causality needs it, integral causality does
    not. A parameter gives both ways; a law in q (p) alone gives it where the loader could solve
    it (:mod:`bondgraph.loader`), or where the model gives the inverse.

    >>> import sympy as sp
    >>> from bondgraph.model import Element
    >>> q = sp.Symbol("q")
    >>> has_inverse(Element("spring", "C", parameter="c")), has_inverse(Element("spring", "C", laws={"effort": q + q**3}))
    (True, False)
    """
    return (el.parameter is not None and not el.laws) or STORAGE_KEYS[el.kind][1] in el.laws


def storage_law(model: Model, el: Element, bond, sub: Sub = _same) -> tuple[sp.Symbol, Equation]:
    """A storage element's energy variable x and its constitutive law: C: e = phi(q), I:
    f = phi(p), solved for the energy variable too where the model gives the inverse
    (``displacement``/``momentum``) or a parameter. (The causal forms need only this; the rate
    equation is :func:`storage_equations`'.)"""
    e, f = bond_variables(bond)
    x = energy_variable(el)
    if el.kind == "C":
        out_var, law_key, inv_key, energy, local = e, "effort", "displacement", "q", "e"
    else:
        out_var, law_key, inv_key, energy, local = f, "flow", "momentum", "p", "f"
    sol: dict = {}
    if law_key in el.laws:
        sol[out_var] = _law(el.laws[law_key], energy, x, sub)
    elif el.parameter is not None:
        sol[out_var] = sub(quotient(x, model.symbols[el.parameter]))
    if inv_key in el.laws:
        sol[x] = _law(el.laws[inv_key], local, out_var, sub)
    elif el.parameter is not None and law_key not in el.laws:
        sol[x] = sub(product([model.symbols[el.parameter], out_var]))
    expr = difference(out_var, sol[out_var]) if out_var in sol else difference(x, sol[x])
    return x, equation(el.name, el.name, expr, {x, out_var}, solutions=sol, is_linear=not el.laws)


def storage_equations(model: Model, el: Element, bond, sub: Sub = _same) -> tuple[sp.Symbol, list[Equation]]:
    """A storage element's energy variable x and its two equations: its law
    (:func:`storage_law`) and its rate, C: f = dq/dt; I: e = dp/dt."""
    e, f = bond_variables(bond)
    x, law = storage_law(model, el, bond, sub)
    rate = f if el.kind == "C" else e
    diff = equation(f"{el.name}.d/dt", el.name, rate - sp.Derivative(x, t), {x, rate}, differential=(x, rate))
    return x, [law, diff]


def two_port_equations(el: Element, ports: Sequence[Port], sub: Sub = _same) -> list[Equation]:
    """A TF's ``e1 = m e2``, ``f2 = m f1``; a GY's ``e1 = r f2``, ``e2 = r f1`` (bond 1 the one
    bringing power in; a modulated modulus is a function of signals)."""
    (b1, _, s1), (b2, _, s2) = ports
    if s1 < 0:
        b1, b2 = b2, b1
    m = sub(el.modulus)
    e1, f1 = bond_variables(b1)
    e2, f2 = bond_variables(b2)
    if el.kind in ("TF", "MTF"):
        return [equation(f"{el.name}.e", el.name, difference(e1, product([m, e2])), {e1, e2}, linear=[e1, e2]),
                equation(f"{el.name}.f", el.name, difference(f2, product([m, f1])), {f1, f2}, linear=[f1, f2])]
    return [equation(f"{el.name}.e{b1}", el.name, difference(e1, product([m, f2])), {e1, f2}, linear=[e1, f2]),
            equation(f"{el.name}.e{b2}", el.name, difference(e2, product([m, f1])), {e2, f1}, linear=[e2, f1])]


_LAWS: dict[int, dict] = {}


def model_laws(model: Model, key: tuple, build: Callable[[], object]) -> object:
    """``build()`` once per model and ``key`` (a node and what its laws depend on): the
    dependency graph of a causality assignment, the relations derived from it and the
    simulator's configurations read the same laws; sympy's own cache holds too few expressions
    to keep a long chain's. Models are frozen; the entry goes with the model."""
    table = _LAWS.get(id(model))
    if table is None:
        table = _LAWS[id(model)] = {}
        weakref.finalize(model, _LAWS.pop, id(model), None)
    if key not in table:
        table[key] = build()
    return table[key]


def substitution(signals: Mapping[sp.Symbol, sp.Expr] | None = None,
                 modes: Mapping[sp.Symbol, sp.Expr] | None = None) -> Sub:
    """The substitution a law's expressions take: signal symbols of modulated laws by their
    values, then mode variables by theirs (either may be empty)."""
    signals = dict(signals or {})
    modes = dict(modes or {})

    def sub(x: sp.Expr) -> sp.Expr:
        x = x.xreplace(signals) if signals else x
        return x.xreplace(modes) if modes else x
    return sub
