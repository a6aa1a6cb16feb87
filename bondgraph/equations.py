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

from dataclasses import dataclass, replace
from typing import Callable, Mapping

import sympy as sp

from .causality import Causality
from .graph import BondKey, port_table, to_networkx
from .linear import combine
from .model import LAW_VARIABLES, Element, Model, t
from .program import Program, line_diff
from .rates import NONSMOOTH, ddt

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
    coefficients: tuple[sp.Expr, ...] | None = None       # linear law: output = sum(c_i * input_i)
                                                          # (derivative: c * d(input)/dt)


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
    return sp.Mul(ParameterProduct(sp.Mul(*group)), *rest)


def signal(name: str) -> sp.Expr:
    """A measured or input signal as a function of time, ``name(t)``."""
    return sp.Function(name, real=True)(t)


def is_signal(expr: sp.Expr) -> bool:
    """Whether ``expr`` is a bare signal ``name(t)`` (not an expression of signals)."""
    return isinstance(expr, sp.core.function.AppliedUndef) and expr.args == (t,)


def relations(model: Model, causality: Causality, *, known: Mapping[str, sp.Expr],
              states: Mapping[str, sp.Expr], signals: Mapping[sp.Symbol, sp.Expr]) -> list[Relation]:
    """One relation per computed bond variable.

    ``known`` gives each source's and sensor's output (by node name); ``states`` the energy
    variable (q or p) of each storage element in integral causality; ``signals`` replaces the
    signal symbols that modulated elements use (e.g. theta2 in F1(theta2)).
    """
    g = to_networkx(model)
    table = port_table(g)
    out: list[Relation] = []
    recv = causality.effort_to
    for node, kind in g.nodes(data="kind"):
        ps = table[node]
        if kind in ("0", "1", "0c", "1c"):
            out.extend(_junction(model, node, kind, ps, causality))
        elif kind in ("TF", "MTF", "GY", "MGY"):
            out.extend(_two_port(model.elements[node], ps, recv, signals))
        elif kind in ("De", "Df", "Se", "Sf", "MSe", "MSf"):
            (k, _, _), = ps
            var = ("e", k) if recv[k] != node else ("f", k)
            if node in causality.detectors:          # a detector's signal bond carries no power
                out.append(Relation(var, (), lambda: sp.Integer(0)))
            else:
                out.append(Relation(var, (), (lambda v=known[node]: v)))
        elif kind == "R":
            out.append(_resistor(model, _modulated(model.elements[node], signals), ps[0][0], causality.resistors[node]))
        elif kind in ("C", "I"):
            out.append(_storage(model, _modulated(model.elements[node], signals), ps[0][0], causality.storage[node],
                                states))
    return out


def _junction(model: Model, node: str, kind: str, ps, causality: Causality) -> list[Relation]:
    strong = causality.strong[node]
    junction = model.junctions[node]
    a = model.symbols[junction.mode] if junction.controlled else sp.Integer(1)
    common, total = ("e", "f") if kind[0] == "0" else ("f", "e")
    sign = {k: s for k, _, s in ps}
    rels = [Relation((common, k), ((common, strong),), (lambda x, a=a: a * x), coefficients=(a,))
            for k, _, _ in ps if k != strong]
    others = tuple((total, k) for k, _, _ in ps if k != strong)
    weights = [sign[k] for _, k in others]

    def balance(*xs, a=a, s=sign[strong], w=weights):
        return a * (-s) * sp.Add(*[wi * xi for wi, xi in zip(w, xs)])
    rels.append(Relation((total, strong), others, balance,
                         coefficients=tuple(a * (-sign[strong] * wi) for wi in weights)))
    return rels


def _modulated(e: Element, signals: Mapping[sp.Symbol, sp.Expr]) -> Element:
    """``e`` with the signals its laws use (a chamber's capacitance of the piston's position, a
    resistance of a measured temperature) replaced by their values as functions of time: a
    modulated R, C or I. Its laws then vary in time, and their rates carry d/dt of the signal."""
    if not signals or not any(law.free_symbols & set(signals) for law in e.laws.values()):
        return e
    return replace(e, laws={k: law.xreplace(dict(signals)) for k, law in e.laws.items()})


def _modulus(e: Element, signals: Mapping[sp.Symbol, sp.Expr]) -> sp.Expr:
    m = e.modulus
    if signals and m.free_symbols & set(signals):
        m = m.xreplace(dict(signals))
    return m


def _two_port(e: Element, ps, recv, signals) -> list[Relation]:
    m = _modulus(e, signals)
    (b1, _, s1), (b2, _, s2) = ps
    if s1 < 0:                      # b1 must be the bond bringing power in
        b1, b2 = b2, b1
    times, over = (m,), (1 / m,)
    if e.kind in ("TF", "MTF"):     # e1 = m e2, f2 = m f1
        if recv[b1] == e.name:
            return [Relation(("e", b2), (("e", b1),), lambda x: x / m, coefficients=over),
                    Relation(("f", b1), (("f", b2),), lambda x: x / m, coefficients=over)]
        return [Relation(("e", b1), (("e", b2),), lambda x: m * x, coefficients=times),
                Relation(("f", b2), (("f", b1),), lambda x: m * x, coefficients=times)]
    if recv[b1] == e.name:          # GY, effort in on both ports: f2 = e1/r, f1 = e2/r
        return [Relation(("f", b2), (("e", b1),), lambda x: x / m, coefficients=over),
                Relation(("f", b1), (("e", b2),), lambda x: x / m, coefficients=over)]
    return [Relation(("e", b1), (("f", b2),), lambda x: m * x, coefficients=times),
            Relation(("e", b2), (("f", b1),), lambda x: m * x, coefficients=times)]


def _resistor(model: Model, e: Element, k: BondKey, form: str) -> Relation:
    if form == "resistance":
        if "effort" in e.laws:
            law = e.laws["effort"]
            return Relation(("e", k), (("f", k),), lambda x: law.xreplace({LAW_VARIABLES["f"]: x}))
        r = model.symbols[e.parameter]
        return Relation(("e", k), (("f", k),), lambda x: r * x, coefficients=(r,))
    if "flow" in e.laws:
        law = e.laws["flow"]
        return Relation(("f", k), (("e", k),), lambda x: law.xreplace({LAW_VARIABLES["e"]: x}))
    r = model.symbols[e.parameter]
    return Relation(("f", k), (("e", k),), lambda x: x / r, coefficients=(1 / r,))


def _storage(model: Model, e: Element, k: BondKey, form: str, states: Mapping[str, sp.Expr]) -> Relation:
    p = model.symbols[e.parameter] if e.parameter else None
    if form == "integral":
        x = states[e.name]
        var = ("e", k) if e.kind == "C" else ("f", k)
        law_key, energy = ("effort", "q") if e.kind == "C" else ("flow", "p")
        if law_key in e.laws:
            expr = e.laws[law_key].xreplace({LAW_VARIABLES[energy]: x})
        else:
            expr = x / p
        return Relation(var, (), lambda v=expr: v)
    # derivative causality: C gets e, gives f = d/dt q(e); I gets f, gives e = d/dt p(f)
    inp, out, law_key, local = (("e", k), ("f", k), "displacement", "e") if e.kind == "C" else \
        (("f", k), ("e", k), "momentum", "f")
    if law_key in e.laws:
        u = sp.Dummy("u", real=True)
        q = e.laws[law_key].xreplace({LAW_VARIABLES[local]: u})
        slope = sp.diff(q, u)   # dQ/du
        if q.has(t):            # modulated: q(u, t), its rate dQ/du u' + dQ/dt
            drift = ddt(q)
            return Relation(out, (inp,), lambda x, dx: slope.xreplace({u: x}) * dx + drift.xreplace({u: x}),
                            derivative=True, energy=lambda x: q.xreplace({u: x}),
                            parameters=frozenset(q.free_symbols - {u, t}))
        return Relation(out, (inp,), lambda x, dx: slope.xreplace({u: x}) * dx, derivative=True,
                        energy=lambda x: q.xreplace({u: x}), parameters=frozenset(q.free_symbols - {u}))
    return Relation(out, (inp,), lambda x, dx: p * dx, derivative=True, energy=lambda x: p * x,
                    parameters=frozenset({p}), coefficients=(p,))


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
            value = _compact(law.xreplace({u[0]: series[i][0] for u, i in zip(local, r.inputs)}))
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
        series[v] = [_compact(expr.xreplace(subs)) for expr in laws]
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
