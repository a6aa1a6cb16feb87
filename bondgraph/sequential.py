"""Residuals from an over-determined equation set along a causal sequence.

An MSO set has one equation more than unknowns. One equation is kept as the residual; the others
compute the unknowns in the order of the just-determined set's block-triangular form
(Dulmage-Mendelsohn): a block of one equation is solved explicitly (with the form the model
gives: a friction law yields e from f only), a block of several equations is an algebraic loop,
solved jointly by sympy where it can. A differential constraint dx = d/dt x is used

- in ``derivative`` causality only to differentiate (dx from x, exact, by the chain rule), as
  SCAPH does; a loop through a differentiation cannot be computed;
- in ``mixed`` causality also to integrate (x from dx): x becomes a state X(t) of the residual
  generator, ``X' = rhs``, integrated from the start of the data window (the report says so).

The residual is ``plain sympy`` in the measured signals (functions of t), parameters, efficiency
factors and mode variables, like an AGARR.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

import sympy as sp

from .model import t
from .rates import ddt
from .structure import DERIVATIVE, EquationSystem, _match


@dataclass(frozen=True)
class SequentialResidual:
    """``expr`` = 0 on healthy data. ``states`` (mixed causality only) are the integrated
    variables, each ``(X(t), rhs)`` with X' = rhs; ``exact`` keeps d/dt of energy variables
    whose law carries a fault parameter unexpanded (``Derivative(CT2*p2(t), t)``: the time
    derivative of the stored quantity, exact when the parameter changes)."""
    expr: sp.Expr
    equations: frozenset
    residual_equation: int
    causality: str
    states: tuple[tuple[sp.Expr, sp.Expr], ...] = ()
    differentiations: int = 0
    exact: sp.Expr | None = None


def _admissible(system: EquationSystem, causality: str):
    def ok(e: int, v) -> bool:
        eq = system.equations[e]
        if eq.differential:
            x, dx = eq.differential
            return v == dx if causality == DERIVATIVE else v in (x, dx)
        return v in eq.solutions
    return ok


def plan(system: EquationSystem, eqs: Iterable[int], causality: str = DERIVATIVE) -> dict | None:
    """A computation order for the just-determined set ``eqs``: {'matching', 'blocks'}; None if
    no matching respects the explicit forms and the causality, or a loop passes through a
    differentiation (derivative causality) or is not algebraic."""
    eqs = sorted(eqs)
    inc = system.incidence()
    variables = set().union(*(inc[e] for e in eqs)) if eqs else set()
    if len(variables) != len(eqs):
        return None
    m = _match(inc, eqs, _admissible(system, causality))
    if len(m) != len(eqs):
        return None
    blocks = _blocks(system, eqs, m)
    for b in blocks:
        if len(b) > 1:
            for e in b:
                d = system.equations[e].differential
                if d and m[e] == d[1]:          # differentiation inside a loop
                    return None
            if causality == DERIVATIVE and any(system.equations[e].differential for e in b):
                return None
    diffs = sum(1 for e in eqs if system.equations[e].differential and m[e] == system.equations[e].differential[1])
    return {"matching": m, "blocks": blocks, "differentiations": diffs}


def realize(system: EquationSystem, mso: Iterable[int], causality: str = DERIVATIVE,
            exact: Iterable[sp.Symbol] = ()) -> SequentialResidual | None:
    """The residual of ``mso`` with the fewest differentiations (ties: a junction balance or a
    sensor equation as the residual); None if no equation of the set leaves a computable rest.
    ``exact``: parameters whose storage laws are differentiated as a whole (see the class doc)."""
    mso = sorted(mso)
    best = residual_plan(system, mso, causality)
    if best is None:
        return None
    r, p = best
    exact = set(exact)
    expr, states = _compute(system, mso, r, p, set())
    ex = None
    if exact and _touches(system, mso, exact):
        ex, _ = _compute(system, mso, r, p, exact)
    return SequentialResidual(expr, frozenset(mso), r, causality, tuple(states), p["differentiations"], ex)


def residual_plan(system: EquationSystem, mso: Iterable[int], causality: str = DERIVATIVE) -> tuple[int, dict] | None:
    """The residual equation of ``mso`` and the plan of the rest (:func:`plan`): fewest
    differentiations first, then a junction balance, then a law, then a differential constraint;
    None if no equation leaves a computable rest."""
    best = None
    for r in sorted(mso):
        p = plan(system, [e for e in mso if e != r], causality)
        if p is None:
            continue
        eq = system.equations[r]
        rank = (p["differentiations"], 0 if eq.name.endswith(".balance") else 1 if not eq.differential else 2, r)
        if best is None or rank < best[0]:
            best = (rank, r, p)
    return None if best is None else best[1:]


def _touches(system: EquationSystem, eqs, params: set) -> bool:
    nodes = {system.equations[e].node for e in eqs if system.equations[e].differential}
    return any(system.equations[e].node in nodes and not system.equations[e].differential
               and system.equations[e].symbols & params for e in eqs)


def _compute(system: EquationSystem, mso, r: int, p: dict, exact: set):
    values: dict = {}
    states: list = []
    m = p["matching"]
    whole = {system.equations[e].node for e in mso
             if not system.equations[e].differential and system.equations[e].symbols & exact}
    for block in p["blocks"]:
        _block(system, block, m, values, states, whole)
    eq = system.equations[r]
    if eq.differential:
        x, dx = eq.differential
        expr = values[dx] - _ddt(values[x], eq.node in whole)
    else:
        expr = eq.expr.xreplace(values)
    resolved = [(X, values[dx]) for X, dx in states]
    return _states_out(expr, resolved), resolved


def _ddt(expr: sp.Expr, whole: bool) -> sp.Expr:
    return sp.Derivative(expr, t) if whole and not expr.is_number else ddt(expr)


def _block(system, block, m, values, states, whole) -> None:
    if len(block) == 1:
        (e,) = block
        eq = system.equations[e]
        v = m[e]
        if eq.differential:
            x, dx = eq.differential
            if v == dx:
                values[dx] = _ddt(values[x], eq.node in whole)
            else:                                   # integration: x is a state
                X = sp.Function(f"X_{eq.node}", real=True)(t)
                values[x] = X
                states.append([X, dx])
            return
        values[v] = eq.solutions[v].xreplace(values)
        return
    integrated = [e for e in block if system.equations[e].differential and m[e] == system.equations[e].differential[0]]
    if integrated:
        pending = []
        for e in integrated:
            x, dx = system.equations[e].differential
            X = sp.Function(f"X_{system.equations[e].node}", real=True)(t)
            values[x] = X
            pending.append([X, dx])
        rest = [e for e in block if e not in integrated]
        for b in _blocks(system, rest, m):
            _block(system, b, m, values, states, whole)
        states.extend(pending)
        return
    unknowns = [m[e] for e in block]
    exprs = [system.equations[e].expr.xreplace(values) for e in block]
    if not _linear_in(exprs, unknowns):
        # sympy's solve on a transcendental loop (a diode's exp law beside a shunt: e = f(e)) ran
        # without end (a user trial's check: 15 CPU-minutes, 860 MB); a loop has a unique solution
        # that solve finds only where it is linear in its unknowns
        raise ValueError("algebraic loop through " + ", ".join(system.equations[e].name for e in block)
                         + " is nonlinear in its unknowns: no unique symbolic solution")
    sol = sp.solve(exprs, unknowns, dict=True)
    if len(sol) != 1 or set(sol[0]) != set(unknowns):
        raise ValueError("algebraic loop through " + ", ".join(system.equations[e].name for e in block)
                         + " has no unique symbolic solution")
    values.update(sol[0])


def _linear_in(exprs: list[sp.Expr], unknowns: list) -> bool:
    """Whether every equation of an algebraic loop is of degree at most 1 in its unknowns (a
    function of an unknown, exp(e) or sign(f), is not).

    >>> x, y, a = sp.symbols("x y a")
    >>> _linear_in([a*x + y - 1, x - a*y], [x, y]), _linear_in([sp.exp(x) + x - a], [x])
    (True, False)
    """
    for e in exprs:
        try:
            if sp.Poly(e, *unknowns).total_degree() > 1:
                return False
        except sp.PolynomialError:
            return False
    return True


def _blocks(system: EquationSystem, eqs, m) -> list[list[int]]:
    """The block-triangular order of ``eqs`` under the matching ``m`` (equation -> variable):
    strongly connected blocks in topological order. Variables matched outside ``eqs`` count as
    known (the rest of a loop once its states are)."""
    inc = system.incidence()
    owner = {m[e]: e for e in eqs}
    import networkx as nx                   # here, not at import: bgfdi's warm start needs no networkx
    g = nx.DiGraph()
    g.add_nodes_from(eqs)
    for e in eqs:
        for v in inc[e]:
            if v in owner and owner[v] != e:
                g.add_edge(owner[v], e)
    cond = nx.condensation(g)
    return [sorted(cond.nodes[c]["members"]) for c in nx.topological_sort(cond)]


def _states_out(expr: sp.Expr, states: list) -> sp.Expr:
    """Replace derivatives of the states X(t) by their right-hand sides (X' = rhs)."""
    rhs = dict(states)
    for _ in range(4):
        ds = [d for d in expr.atoms(sp.Derivative) if d.expr in rhs]
        if not ds:
            break
        rep = {}
        for d in ds:
            order = sum(c for _, c in d.variable_count)
            value = rhs[d.expr]
            value = ddt(value, order - 1)
            rep[d] = value
        expr = expr.xreplace(rep)
    return expr
