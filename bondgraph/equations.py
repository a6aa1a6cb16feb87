"""Constitutive relations along causal paths: every bond variable as a sympy expression.

Given a causal assignment, each bond's effort and flow is computed by exactly one node. The
relations are built per node and resolved in topological order of the causal dependency graph,
so that each expression is constructed once (no ``subs`` on growing expressions, no
``simplify``): derivation stays near-linear in the size of the model. Long products of positive
parameters (the cumulative moduli of a chain of transformers) are kept as one nested factor,
:class:`ParameterProduct`, so that passing them on costs the same at every stage. Storage elements in
derivative causality differentiate their input with ``sympy.diff`` (exact, chain rule included).

Sign conventions are those of :mod:`bondgraph.model`. A controlled junction multiplies each of its
output variables by its mode variable (diagnostic hybrid bond graph).
"""
from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable, Mapping

import sympy as sp
from sympy.core.assumptions import StdFactKB

from .canonical import product, substitute
from .graph import BondKey, port_table, to_networkx
from .laws import (Equation, bond_variables, coefficient, energy_variable, junction_equations, model_laws,
                   resistor_equation, solve_for, source_equation, storage_law, substitution, two_port_equations)
from .linear import combine
from .model import Element, Model, t
from .program import Program, line_diff
from .rates import NONSMOOTH, ddt

if TYPE_CHECKING:
    from .causality import Causality

Var = tuple[str, BondKey]          # ('e' | 'f', bond key)


@dataclass(frozen=True)
class Relation:
    """``output = law(*inputs)``; for a storage element in derivative causality
    (``derivative=True``) the law takes the input and its time derivative, ``law(x, dx/dt)``."""
    output: Var
    inputs: tuple[Var, ...]
    law: Callable[..., sp.Expr]
    derivative: bool = False
    energy: Callable[[sp.Expr], sp.Expr] | None = None   # storage: q(e) or p(f), the stored quantity
    parameters: frozenset = frozenset()                   # symbols of the storage law
    linear_coefficients: Callable[[], tuple[sp.Expr, ...]] | None = None   # see ``coefficients``

    @functools.cached_property
    def coefficients(self) -> tuple[sp.Expr, ...] | None:
        """A linear law's coefficients, ``output = sum(c_i * input_i)`` (derivative: c *
        d(input)/dt); None for another law. Read when first asked: only straight-line code (the
        simulator) uses them, and reading them cost a long chain's AGARR a tenth of its time."""
        return None if self.linear_coefficients is None else self.linear_coefficients()


PRODUCT_LIMIT = 6     # positive parameter factors a term may carry before they are grouped


class ParameterProduct(sp.UnevaluatedExpr):
    """A product of positive parameters kept as one factor (``sympy.UnevaluatedExpr``, made
    commutative and positive). Without it, every transformer of a chain multiplies the flows by
    one more modulus and sympy re-sorts the whole product each time: derivation time grows with
    the square of the chain's length. The expression is the same mathematically; ``.doit()``
    flattens it, lambdify prints it as a parenthesised product."""
    is_commutative = True

    def _eval_is_positive(self) -> bool | None:
        """True when every factor is (cheaper than asking the product: no sign analysis)."""
        return True if all(f.is_positive for f in sp.Mul.make_args(self.args[0])) else None


def _is_parameter_factor(f: sp.Expr) -> bool:
    """A positive parameter, a grouped product of them, or a rational power of either."""
    base = f.base if f.is_Pow and f.exp.is_Rational else f
    return (base.is_Symbol and base != t or isinstance(base, ParameterProduct)) and base.is_positive is True


def _compact(expr: sp.Expr) -> sp.Expr:
    """``expr`` with the positive parameter factors of a product grouped into one
    :class:`ParameterProduct` once there are more than :data:`PRODUCT_LIMIT` of them."""
    if not expr.is_Mul or len(expr.args) <= PRODUCT_LIMIT:
        return expr
    group, rest = [], []
    for f in expr.args:
        (group if _is_parameter_factor(f) else rest).append(f)
    if len(group) <= PRODUCT_LIMIT:
        return expr
    return product([_positive_product(group), *rest])


def _positive_product(factors: list[sp.Expr]) -> ParameterProduct:
    """The :class:`ParameterProduct` of ``factors``, each positive (:func:`_is_parameter_factor`),
    created knowing so: sympy would otherwise deduce it, through its general assumption machinery,
    the first time anything asks (every product that takes it in: a tenth of a long chain's
    derivation). The facts are those ``_eval_is_positive`` gives; the expression is unchanged."""
    grouped = ParameterProduct(product(factors))
    grouped._assumptions = StdFactKB({"positive": True, "commutative": True})
    return grouped


def signal(name: str) -> sp.Expr:
    """A measured or input signal as a function of time, ``name(t)``."""
    return sp.Function(name, real=True)(t)


def is_signal(expr: sp.Expr) -> bool:
    """Whether ``expr`` is a bare signal ``name(t)`` (not an expression of signals)."""
    return isinstance(expr, sp.core.function.AppliedUndef) and expr.args == (t,)


def relations(model: Model, causality: Causality, *, known: Mapping[str, sp.Expr],
              states: Mapping[str, sp.Expr], signals: Mapping[sp.Symbol, sp.Expr]) -> list[Relation]:
    """One relation per computed bond variable: each law of :mod:`bondgraph.laws` solved for the
    output the causal strokes give it (:func:`causal_forms`).

    ``known`` gives each source's and sensor's output (by node name); ``states`` the energy
    variable (q or p) of each storage element in integral causality; ``signals`` replaces the
    signal symbols that modulated elements use (e.g. theta2 in F1(theta2)).

    >>> from bondgraph.examples import source_resistor
    >>> from bondgraph.causality import assign
    >>> m = source_resistor()
    >>> rels = relations(m, assign(m), known={"src": signal("u"), "i": signal("i")}, states={}, signals={})
    >>> resolve(rels, [("e", "i")])[("e", "i")]      # the junction's balance: the ARR u - R i
    -R*i(t) + u(t)
    """
    return [_relation(form, states) for form in causal_forms(model, causality, signals, known)]


@dataclass(frozen=True)
class CausalForm:
    """A law solved for the output its causal stroke gives: ``output = expr`` in the bond
    variables ``symbols`` of ``inputs`` (``expr`` None where the law gives the output in no
    closed form: a problem the causality reports). ``kind``: ``law``, ``source``, ``sensor``,
    ``detector`` (a signal bond that carries no power), ``state`` (a storage element in integral
    causality, ``expr`` in its energy variable ``symbols[0]``) or ``derivative`` (in derivative
    causality, ``expr`` its energy variable as a function of its input)."""
    node: str
    output: Var
    inputs: tuple[Var, ...]
    symbols: tuple[sp.Symbol, ...]
    expr: sp.Expr | None
    kind: str = "law"
    linear: bool = False


def causal_forms(model: Model, causality: Causality, signals: Mapping[sp.Symbol, sp.Expr] | None = None,
                 known: Mapping[str, sp.Expr] | None = None) -> list[CausalForm]:
    """Every computed bond variable as the law that gives it, solved for it (node by node, in
    the graph's order): a junction's laws written against its strong bond, each solved for the
    weak bond's common variable and the strong bond's total; a two-port's, a resistor's, a
    storage element's and a source's for the variable its stroke makes it give. Without
    ``known`` (each source's and sensor's value) the sources' and sensors' ``expr`` is None:
    the forms then say only what is computed from what (:func:`bondgraph.causality.dependency_graph`)."""
    g = to_networkx(model)
    table = port_table(g)
    recv = causality.effort_to
    solve = known is not None      # without values, only which variable is computed from which
    out: list[CausalForm] = []
    for node, kind in g.nodes(data="kind"):
        ps = table[node]
        if kind in ("0", "1", "0c", "1c"):
            strong = causality.strong.get(node)
            if strong is None:
                continue
            common, total = (0, 1) if kind[0] == "0" else (1, 0)
            outputs = [bond_variables(k)[common] for k, _, _ in ps if k != strong]
            outputs.append(bond_variables(strong)[total])
            j = model.junctions[node]
            if not solve and not j.controlled:      # which variable from which: no sympy needed
                eqs = _junction_shape(kind, ps, strong)
            else:
                used = model.symbols[j.mode].free_symbols if j.controlled else ()
                eqs = _laws(model, ("junction", node, strong), used, signals,
                            lambda sub: junction_equations(model, node, ps, strong, sub))
            out += _solved(node, eqs, outputs, ps, solve)
        elif kind in ("TF", "MTF", "GY", "MGY"):
            (b1, _, s1), (b2, _, _) = ps
            if s1 < 0:                      # b1: the bond bringing power in
                b1, b2 = b2, b1
            gets1 = recv.get(b1) == node    # effort in at b1: flow out there
            gets2 = gets1 if kind in ("GY", "MGY") else not gets1
            outputs = [bond_variables(b)[1 if gets else 0] for b, gets in ((b1, gets1), (b2, gets2))]
            el = model.elements[node]
            if not solve and el.modulus != 0:
                eqs = _two_port_shape(kind, b1, b2)
            else:
                eqs = _laws(model, ("two-port", node), el.modulus.free_symbols, signals,
                            lambda sub: two_port_equations(el, ps, sub))
            out += _solved(node, eqs, outputs, ps, solve)
        elif kind == "R":
            k = ps[0][0]
            el = model.elements[node]
            resistance = causality.resistors.get(node) == "resistance"
            if not solve and not el.laws:            # e = R f: e and f, linear
                out += _solved(node, [_Shape(frozenset(bond_variables(k)))], [bond_variables(k)[0 if resistance else 1]],
                               ps, solve)
                continue
            eq = _laws(model, ("R", node), _law_symbols(el), signals, lambda sub: resistor_equation(model, el, k, sub))
            resistance = causality.resistors.get(node) == "resistance"
            out += _solved(node, [eq], [bond_variables(k)[0 if resistance else 1]], ps, solve)
        elif kind in ("C", "I"):
            el = model.elements[node]
            if not solve and not el.laws:            # given by a parameter: no law needed to say what it computes
                out.append(_storage_shape(el, ps[0][0], causality.storage.get(node)))
                continue
            x, law = _laws(model, ("storage law", node), _law_symbols(el), signals,
                           lambda sub: storage_law(model, el, ps[0][0], sub))
            out.append(_storage(el, ps[0][0], causality.storage.get(node), x, law))
        elif kind in ("De", "Df", "Se", "Sf", "MSe", "MSf"):
            (k, _, _), = ps
            var = ("e", k) if recv.get(k) != node else ("f", k)
            if kind in ("De", "Df"):
                # the diagnostic bond graph's sensor: an inverted one imposes its measurement,
                # a detector's signal bond carries no power
                detector = node in causality.detectors
                value = None if known is None else sp.Integer(0) if detector else known[node]
                out.append(CausalForm(node, var, (), (), value, "detector" if detector else "sensor"))
            else:
                value = None
                if known is not None:
                    eq = source_equation(node, kind, k, known[node])
                    value = solve_for(eq, next(iter(eq.variables)))
                out.append(CausalForm(node, var, (), (), value, "source"))
    return out


@dataclass(frozen=True)
class _Shape:
    """What the dependency graph reads of an equation: the variables it holds, and whether it is
    linear in them. The laws of a long chain cost most of its causality when built in sympy only
    to be read for this (a 10 000-element chain's junctions and transformers)."""
    variables: frozenset
    linear: bool = True


def _junction_shape(kind: str, ps, reference) -> list[_Shape]:
    """The variables of :func:`bondgraph.laws.junction_equations` of an uncontrolled junction, in
    its order: the common variable of each bond with the reference's, then the balance."""
    common, total = (0, 1) if kind[0] == "0" else (1, 0)
    x0 = bond_variables(reference)[common]
    out = [_Shape(frozenset((bond_variables(k)[common], x0))) for k, _, _ in ps if k != reference]
    return out + [_Shape(frozenset(bond_variables(k)[total] for k, _, _ in ps))]


def _two_port_shape(kind: str, b1, b2) -> list[_Shape]:
    """The variables of :func:`bondgraph.laws.two_port_equations` (a modulus other than 0)."""
    (e1, f1), (e2, f2) = bond_variables(b1), bond_variables(b2)
    if kind in ("TF", "MTF"):
        return [_Shape(frozenset((e1, e2))), _Shape(frozenset((f1, f2)))]
    return [_Shape(frozenset((e1, f2))), _Shape(frozenset((e2, f1)))]


def _storage_shape(e: Element, k: BondKey, form: str | None) -> CausalForm:
    """:func:`_storage`'s form of a storage element given by a parameter, without its law (``expr`` None)."""
    ek, fk = bond_variables(k)
    given, taken = (ek, fk) if e.kind == "C" else (fk, ek)
    var = {ek: ("e", k), fk: ("f", k)}
    if form == "integral":
        return CausalForm(e.name, var[given], (), (energy_variable(e),), None, "state")
    return CausalForm(e.name, var[taken], (var[given],), (given,), None, "derivative", True)


def _solved(node: str, eqs: list[Equation], outputs: list[sp.Symbol], ps, solve: bool = True) -> list[CausalForm]:
    """Each equation of a node solved for the one output it holds, outputs of the node's other
    equations substituted (a controlled junction's further outputs equal its first); in the
    order of the equations, inputs in the order of the node's bonds (effort, then flow).
    Without ``solve``, only the outputs and inputs (``expr`` None)."""
    variables = {}
    for k, _, _ in ps:
        e, f = bond_variables(k)
        variables[e], variables[f] = ("e", k), ("f", k)
    order = {v: i for i, v in enumerate(variables)}
    wanted = set(outputs)
    done: dict[sp.Symbol, tuple[sp.Expr | None, frozenset, bool]] = {}
    gives: dict[int, sp.Symbol] = {}
    progress = True
    while progress:
        progress = False
        for i, eq in enumerate(eqs):
            unknown = [v for v in eq.variables if v in wanted and v not in done]
            if i in gives or len(unknown) != 1:
                continue
            v = unknown[0]
            expr = solve_for(eq, v) if solve else None
            inner = [w for w in eq.variables if w in done]
            if expr is not None and inner:
                expr = substitute(expr, {w: done[w][0] for w in inner}) if all(done[w][0] is not None for w in inner) \
                    else None
            inputs = frozenset(eq.variables - wanted).union(*(done[w][1] for w in inner))
            linear = eq.linear and all(done[w][2] for w in inner)
            done[v], gives[i] = (expr, inputs, linear), v
            progress = True
    out = []
    for i, eq in enumerate(eqs):
        if i not in gives:
            continue
        v = gives[i]
        expr, inputs, linear = done[v]
        symbols = tuple(sorted(inputs, key=order.__getitem__))
        out.append(CausalForm(node, variables[v], tuple(variables[s] for s in symbols), symbols, expr, linear=linear))
    return out


def _laws(model: Model, key: tuple, used, signals: Mapping[sp.Symbol, sp.Expr] | None, build) -> object:
    """A node's laws with the signals its expressions use substituted; built once per model
    (:func:`bondgraph.laws.model_laws`) when it uses none."""
    if signals and any(s in signals for s in used):
        return build(substitution(signals))
    return model_laws(model, key, lambda: build(substitution()))


def _law_symbols(e: Element) -> set:
    return set().union(*(law.free_symbols for law in e.laws.values()))


def _storage(e: Element, k: BondKey, form: str | None, x: sp.Symbol, law: Equation) -> CausalForm:
    """A storage element's form. Integral causality: its effort (C) or flow (I) from its energy
    variable x, a state. Derivative: its energy variable from its effort (C) or flow (I), whose
    time derivative is the flow (C) or effort (I) it gives (the differential constraint)."""
    ek, fk = bond_variables(k)
    given, taken = (ek, fk) if e.kind == "C" else (fk, ek)
    var = {ek: ("e", k), fk: ("f", k)}
    if form == "integral":
        return CausalForm(e.name, var[given], (), (x,), solve_for(law, given), "state")
    return CausalForm(e.name, var[taken], (var[given],), (given,), solve_for(law, x), "derivative", law.linear)


def _relation(form: CausalForm, states: Mapping[str, sp.Expr]) -> Relation:
    """The relation of a causal form: its law a function of the inputs' values."""
    if form.kind in ("source", "sensor", "detector"):
        return Relation(form.output, (), lambda v=form.expr: v)
    if form.kind == "state":
        value = substitute(form.expr, {form.symbols[0]: states[form.node]})
        return Relation(form.output, (), lambda v=value: v)
    if form.expr is None:
        raise ValueError(f"{form.node} gives {form.output[0]}{form.output[1]} in no closed form (see its causality)")
    if form.kind == "derivative":
        return _rate_relation(form)
    expr, symbols = form.expr, form.symbols
    coefficients = (lambda: tuple(coefficient(expr, s) for s in symbols)) if form.linear and symbols else None
    if expr in symbols:         # an input passed on as it is (a junction's common variable)
        i = symbols.index(expr)
        return Relation(form.output, form.inputs, lambda *xs: xs[i], linear_coefficients=coefficients)
    return Relation(form.output, form.inputs, lambda *xs: substitute(expr, dict(zip(symbols, xs))),
                    linear_coefficients=coefficients)


def _rate_relation(form: CausalForm) -> Relation:
    """A storage element in derivative causality: ``out = d/dt Q(x)``, Q its energy variable as a
    function of its input x, as ``dQ/dx x'`` (plus ``dQ/dt`` where the law is modulated: Q(x, t))."""
    u = sp.Dummy("u", real=True)
    q = substitute(form.expr, {form.symbols[0]: u})
    slope = coefficient(q, u)   # dQ/du
    coefficients = (lambda: (slope,)) if form.linear else None
    if q.has(t):            # modulated: q(u, t), its rate dQ/du u' + dQ/dt
        drift = ddt(q)
        return Relation(form.output, form.inputs, lambda x, dx: product([substitute(slope, {u: x}), dx]) + substitute(drift, {u: x}),
                        derivative=True, energy=lambda x: substitute(q, {u: x}),
                        parameters=frozenset(q.free_symbols - {u, t}), linear_coefficients=coefficients)
    return Relation(form.output, form.inputs, lambda x, dx: product([substitute(slope, {u: x}), dx]), derivative=True,
                    energy=lambda x: substitute(q, {u: x}), parameters=frozenset(q.free_symbols - {u}),
                    linear_coefficients=coefficients)
def resolve(rels: list[Relation], wanted: list[Var] | None = None, whole: frozenset = frozenset(),
            program: Program | None = None) -> dict[Var, sp.Expr]:
    """Evaluate relations in causal order; only the ancestors of ``wanted`` if given.

    Time derivatives (storage elements in derivative causality) are propagated forward along the
    causal graph: each relation's law is written in local dummy inputs, its total derivative is
    taken on that small local expression (chain rule, explicit t-dependence of modulated laws
    included), and the resolved inputs and their derivatives are substituted afterwards. No
    ``diff`` ever runs on a grown expression, so the cost per relation does not grow with the
    model. Raises ValueError naming the variables of a causal loop.

    ``whole``: parameters whose storage laws are differentiated as a whole: such an element gives
    ``Derivative(q(x), t)`` unexpanded (the rate of the stored quantity, exact when the parameter
    varies in time: a capacitance fault changes e at constant q, and dq/dt carries the dC/dt e
    term), for evaluation by :mod:`fdi.residuals`.

    ``program``: when given, every computed expression is named in it as a line
    (:mod:`bondgraph.program`) and passed on by its name, so that no value is nested through the
    model: the returned values are names or atoms, for code generation (the simulator). A law
    linear with constant coefficients (junctions, transformers, gyrators, linear resistors and
    storage elements) is then built as a :class:`bondgraph.linear.Linear` line, without sympy."""
    by_output = {r.output: r for r in rels}
    variables = dict.fromkeys(v for r in rels for v in (*r.inputs, r.output))
    roots = list(variables) if wanted is None else [w for w in wanted if w in variables]
    order = _causal_order(by_output, roots)
    missing = [v for v in order if v not in by_output]
    if missing:
        v = missing[0]
        raise ValueError(f"variable {v[0]}{v[1]} is computed by no element (open causality)")
    need = {v: 0 for v in order}                  # highest time derivative each variable must provide
    for v in reversed(order):
        r = by_output[v]
        for i in r.inputs:
            need[i] = max(need[i], need[v] + (1 if r.derivative else 0))
    series: dict[Var, list[sp.Expr]] = {}          # variable -> [value, d/dt, d2/dt2, ...]
    for v in order:
        r = by_output[v]
        k = need[v]
        if not r.inputs:
            values = [r.law()]
            for _ in range(k):
                values.append(ddt(values[-1]))
            series[v] = values if program is None else [program.name(x) for x in values]
            continue
        if r.derivative and r.energy is not None and (r.parameters & whole or _nonsmooth_law(r)):
            # the rate of the stored quantity kept whole: under a time-varying fault parameter,
            # or when the storage law is nonsmooth (evaluated on data, differentiated numerically)
            inner = r.energy(series[r.inputs[0]][0])
            series[v] = [sp.Derivative(inner, (t, j + 1)) for j in range(k + 1)]
            continue
        if program is not None and r.coefficients is not None and (k == 0 or not _varying(r.coefficients)):
            # a linear law with constant coefficients: its j-th derivative is the same sum of
            # the inputs' j-th derivatives (of their first derivatives for a storage element)
            shift = 1 if r.derivative else 0
            series[v] = [program.name(combine([(c, series[i][j + shift]) for c, i in zip(r.coefficients, r.inputs)]))
                         for j in range(k + 1)]
            continue
        if k == 0 and not r.derivative:           # no derivative: the law on the values themselves
            expr = _compact(r.law(*[series[i][0] for i in r.inputs]))
            series[v] = [expr if program is None else program.name(expr)]
            continue
        top = k + (1 if r.derivative else 0)
        local = [[sp.Dummy(f"u{i}_{j}") for j in range(top + 1)] for i in range(len(r.inputs))]
        law = r.law(local[0][0], local[0][1]) if r.derivative else r.law(*[u[0] for u in local])
        if not r.derivative and _nonsmooth_in(law, [u[0] for u in local]):
            # a nonsmooth law (orifice, Coulomb friction, saturation): its rates are left to be
            # estimated on data (bondgraph.rates), never differentiated into DiracDelta terms
            value = _compact(substitute(law, {u[0]: series[i][0] for u, i in zip(local, r.inputs)}))
            series[v] = [value] + [ddt(value, j) for j in range(1, k + 1)]
            if program is not None:
                series[v] = [program.name(expr) for expr in series[v]]
            continue
        laws = [law]
        for _ in range(k):
            prev = laws[-1]
            step = sp.diff(prev, t) if prev.has(t) else sp.Integer(0)     # most laws are time-invariant
            for u in local:
                for j in range(top):
                    if prev.has(u[j]):
                        step += line_diff(prev, u[j]) * u[j + 1]
            laws.append(step)
        subs = {u[j]: series[i][j] for u, i in zip(local, r.inputs) for j in range(len(u)) if j < len(series[i])}
        series[v] = [_compact(substitute(expr, subs)) for expr in laws]
        if program is not None:
            series[v] = [program.name(expr) for expr in series[v]]
    return {v: series[v][0] for v in order}


def _nonsmooth_in(law: sp.Expr, inputs: list[sp.Expr]) -> bool:
    """Whether a local law applies a nonsmooth function to one of its inputs (or to time)."""
    return any(f.has(t, *inputs) for f in law.atoms(*NONSMOOTH))


def _nonsmooth_law(r: Relation) -> bool:
    """Whether a storage element's law q(x) (p(x)) is nonsmooth in its input."""
    u = sp.Dummy("u", real=True)
    return _nonsmooth_in(r.energy(u), [u])


def _causal_order(by_output: Mapping[Var, Relation], roots: list[Var]) -> list[Var]:
    """``roots`` and every variable they are computed from, each after its inputs (depth first,
    with an explicit stack: a chain of thousands of elements is as deep). Raises ValueError
    naming the variables of a causal loop."""
    order: list[Var] = []
    done: set[Var] = set()
    for root in roots:
        if root in done:
            continue
        path, on_path = [root], {root}
        stack = [iter(by_output[root].inputs if root in by_output else ())]
        while stack:
            for u in stack[-1]:
                if u in on_path:
                    loop = path[path.index(u):]
                    raise ValueError("causal loop through " + ", ".join(f"{v[0]}{v[1]}" for v in loop))
                if u not in done:
                    path.append(u)
                    on_path.add(u)
                    stack.append(iter(by_output[u].inputs if u in by_output else ()))
                    break
            else:
                v = path.pop()
                on_path.discard(v)
                stack.pop()
                done.add(v)
                order.append(v)
    return order


def _varying(coefficients: tuple[sp.Expr, ...]) -> bool:
    """Whether a coefficient changes in time (a modulus of a signal or of a state)."""
    return any(c.has(t) for c in coefficients)
